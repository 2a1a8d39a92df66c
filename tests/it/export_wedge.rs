//! `lobefit export --only wedge`: M_lin as one merged value per entry, fetched per
//! entry. f32 rounding of hi + lo misses the table's 1e-12 (the pair existed for
//! that), so both storages export as lossy promises of their measured error.

use lobefit::export::layout::Filter;
use lobefit::export::manifest::Manifest;
use lobefit::export::run::{check_export, export, ExportOptions};
use lobefit::export::{Format, Storage};

fn opts(format: Format, storage: Storage, allow_lossy: bool) -> ExportOptions {
    ExportOptions {
        only: vec!["wedge".into()],
        format,
        storage,
        scale: 1.0,
        allow_lossy,
    }
}

/// The measured error of `m` with `filter`.
fn measured(m: &Manifest, filter: Filter) -> f64 {
    let e = m.families[0]
        .error
        .iter()
        .find(|e| e.filter == filter && e.output == "m" && e.metric == "offgrid.max_abs")
        .expect("m offgrid.max_abs measured");
    assert!(!e.meets_target(), "a merged entry cannot hold 1e-12: {e:?}");
    assert_eq!(e.promise, e.measured);
    e.measured
}

#[test]
fn f32_is_the_entry_rounded_once() {
    let dir = tempfile::tempdir().unwrap();
    // f32 misses the 1e-12 promise of the f64 pairs too: lossy, by request only.
    let e = export(&opts(Format::Raw, Storage::F32, false), dir.path()).unwrap_err();
    assert!(
        e.contains("wedge: f32 at scale 1 misses the target") && e.contains("--allow-lossy"),
        "{e}"
    );
    let m = export(&opts(Format::Raw, Storage::F32, true), dir.path()).unwrap();
    let t = &m.families[0].textures[0];
    assert_eq!(t.extent, [16, 64, 5, 1, 1], "col × row × W, one channel");
    assert_eq!(t.bytes, 16 * 64 * 5 * 4);
    // Entries are fetched, not filtered: both filters give the same numbers, within
    // half an f32 ulp of |m| ≤ 1.3 (plus the table's own 1e-13).
    let (manual, hardware) = (measured(&m, Filter::Manual), measured(&m, Filter::Hardware));
    assert_eq!(manual, hardware);
    assert!(manual > 0.0 && manual < 6e-8, "{manual}");
    let checks = check_export(dir.path()).unwrap();
    assert_eq!(checks.len(), 2);
    assert!(checks.iter().all(|c| c.pass && c.now == c.entry.measured), "{checks:?}");
}

#[test]
fn f16_is_refused_unless_lossy() {
    let dir = tempfile::tempdir().unwrap();
    let e = export(&opts(Format::Raw, Storage::F16, false), dir.path()).unwrap_err();
    assert!(
        e.contains("wedge: f16 at scale 1 misses the target") && e.contains("--allow-lossy"),
        "{e}"
    );
    let m = export(&opts(Format::Raw, Storage::F16, true), dir.path()).unwrap();
    let manual = measured(&m, Filter::Manual);
    assert_eq!(manual, measured(&m, Filter::Hardware));
    // binary16 on [−1, 1] after offset and scale (half-range ≤ 1.3): ≤ 2⁻¹¹ · 1.3.
    assert!(manual < 7e-4, "{manual}");
    assert!(check_export(dir.path()).unwrap().iter().all(|c| c.pass));
}

#[test]
fn ktx2_round_trips() {
    let dir = tempfile::tempdir().unwrap();
    export(&opts(Format::Ktx2, Storage::F32, true), dir.path()).unwrap();
    assert!(check_export(dir.path()).unwrap().iter().all(|c| c.pass));
}
