//! The one list of tables (`lobefit_tables::KINDS`, in `tables/src/lib.rs`) against the
//! committed files and the family types: the list is exactly `tables/data/*.lobefit`,
//! each file is read by exactly one type (through [`TableType`]), whose `KINDS` and
//! `VERSION` agree with the file's metadata.

use std::path::PathBuf;

use lobefit_tables::{
    BestIsg, CapExponent, DiskLight, LoadError, LobeIntegral, LobeProduct, LogZh, MaskWeights, RefitIsg, SgFit, ShExp,
    Table, TableType, Wedge, Wrap, KINDS,
};

fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data")
}

/// The committed file of table `kind` (`tables/data/<kind>.lobefit`).
pub fn committed(kind: &str) -> Vec<u8> {
    let path = data_dir().join(format!("{kind}.lobefit"));
    std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// One family type, as plain data and function pointers so that all of them fit in
/// one array.
struct Family {
    name: &'static str,
    kind: &'static str,
    kinds: &'static [&'static str],
    version: u32,
    /// `T::from_table`, returning the kind of the table it holds.
    from_table: fn(Table) -> Result<String, LoadError>,
    /// `T::from_bytes` (the trait's), returning the kind of the table it holds.
    from_bytes: fn(&[u8]) -> Result<String, LoadError>,
}

fn family<T: TableType>() -> Family {
    Family {
        name: std::any::type_name::<T>(),
        kind: T::KIND,
        kinds: T::KINDS,
        version: T::VERSION,
        from_table: |t| T::from_table(t).map(|x| x.table().meta().kind.clone()),
        from_bytes: |b| T::from_bytes(b).map(|x| x.table().meta().kind.clone()),
    }
}

/// Every family type that reads a table. A type missing here leaves its kinds without
/// a reader, which `every_kind_has_one_reader_with_matching_constants` reports.
fn families() -> Vec<Family> {
    vec![
        family::<LobeIntegral>(),
        family::<CapExponent>(),
        family::<RefitIsg>(),
        family::<BestIsg>(),
        family::<SgFit>(),
        family::<LogZh>(),
        family::<Wedge>(),
        family::<Wrap>(),
        family::<DiskLight>(),
        family::<ShExp>(),
        family::<LobeProduct>(),
        family::<MaskWeights>(),
    ]
}

#[test]
fn kinds_are_the_committed_files() {
    let mut files: Vec<String> = std::fs::read_dir(data_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "lobefit"))
        .map(|p| p.file_stem().unwrap().to_str().unwrap().to_string())
        .collect();
    files.sort();
    let mut kinds: Vec<String> = KINDS.iter().map(|k| k.to_string()).collect();
    kinds.sort();
    // Equal as sorted lists: no kind listed twice, none missing, none without a file.
    assert_eq!(kinds, files, "KINDS (sorted) vs tables/data/*.lobefit");
}

#[test]
fn every_kind_has_one_reader_with_matching_constants() {
    let families = families();
    for kind in KINDS {
        let bytes = committed(kind);
        let table = Table::from_bytes(&bytes).unwrap_or_else(|e| panic!("{kind}: {e}"));
        assert_eq!(table.meta().kind, kind);
        let readers: Vec<&Family> = families.iter().filter(|f| f.kinds.contains(&kind)).collect();
        assert_eq!(
            readers.len(),
            1,
            "{kind}: read by {:?}",
            readers.iter().map(|f| f.name).collect::<Vec<_>>()
        );
        let f = readers[0];
        assert_eq!(f.version, table.meta().table_version, "{kind}: {}::VERSION", f.name);
        assert_eq!(
            (f.from_bytes)(&bytes).as_deref(),
            Ok(kind),
            "{kind}: {}::from_bytes",
            f.name
        );
        assert_eq!(
            (f.from_table)(table.clone()).as_deref(),
            Ok(kind),
            "{kind}: {}::from_table",
            f.name
        );
        // Every other type refuses it for its kind, before looking at the layout.
        for other in families.iter().filter(|o| o.name != f.name) {
            match (other.from_table)(table.clone()) {
                Err(LoadError::WrongKind { expected, found }) => {
                    assert!(other.kinds.contains(&expected.as_str()), "{}: {expected}", other.name);
                    assert_eq!(found, kind);
                }
                r => panic!("{} on {kind}: {r:?}", other.name),
            }
        }
    }
}

#[test]
fn every_type_reads_only_listed_kinds_with_its_kind_first() {
    for f in families() {
        assert_eq!(f.kinds.first(), Some(&f.kind), "{}: KIND leads KINDS", f.name);
        for k in f.kinds {
            assert!(KINDS.contains(k), "{}: {k} is not in KINDS", f.name);
        }
    }
    // The inherent constants callers use are the trait's.
    assert_eq!(lobefit_tables::sg_fit::KIND, SgFit::KIND);
    assert_eq!(lobefit_tables::sg_fit::VERSION, <SgFit as TableType>::VERSION);
    assert_eq!(
        LobeProduct::KINDS,
        [
            lobefit_tables::lobe_product::KIND_ENERGY,
            lobefit_tables::lobe_product::KIND_L2
        ]
    );
}

#[cfg(feature = "embedded")]
#[test]
fn embedded_tables_are_the_committed_files() {
    for kind in KINDS {
        let bytes = lobefit_tables::embedded::by_kind(kind).unwrap_or_else(|| panic!("{kind} not embedded"));
        assert!(bytes == committed(kind), "{kind}: embedded bytes differ from the file");
    }
    assert_eq!(lobefit_tables::embedded::by_kind("no-such-kind"), None);
    // The generated constructors load the line's kind (embedded_l2 is the l2 table).
    assert_eq!(LobeProduct::embedded().unwrap().table().meta().kind, "lobe-product");
    assert_eq!(
        LobeProduct::embedded_l2().unwrap().table().meta().kind,
        "lobe-product-l2"
    );
    assert_eq!(MaskWeights::embedded().unwrap().table().meta().kind, "mask-weights");
    // Parsed once: the same table on every call.
    assert!(std::ptr::eq(SgFit::embedded().unwrap(), SgFit::embedded().unwrap()));
}
