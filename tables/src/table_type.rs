//! [`TableType`], what every family type of the crate shares, and the two macros that
//! write its boilerplate: `impl_table_type!` (in each family's file: the trait impl,
//! `from_bytes`, `table`) and `table_types!` (once, in `lib.rs`: the list of every table
//! kind, from which the [`embedded`](crate::embedded) statics, [`KINDS`](crate::KINDS)
//! and each type's `embedded()` are generated). Only `from_table`, the family's own
//! validation, is written by hand.

use crate::error::LoadError;
use crate::table::Table;

/// A family type: a validated [`Table`] of one kind (or, for [`LobeProduct`](crate::LobeProduct),
/// of one of its variants' kinds) with the family's typed lookups on top.
///
/// Every family type also has the same functions as inherent methods (`T::from_bytes`,
/// `x.table()`, `T::embedded()`), so callers need not import this trait; it is for
/// code generic over families (a loader keyed by kind, a test over every table). The
/// trait is about files only: the kind is the string in the file's header and metadata,
/// the version a family-specific integer; units and domains are those of each family's
/// lookups (solid angle in sr, angles in rad; see the crate docs).
///
/// `Send + Sync + 'static`: a loaded table is immutable and shared between threads,
/// and `embedded()` keeps it in a `static`.
///
/// ```
/// use lobefit_tables::{LobeIntegral, TableType};
/// fn load<T: TableType>(bytes: &[u8]) -> Result<T, lobefit_tables::LoadError> {
///     T::from_bytes(bytes)
/// }
/// # #[cfg(feature = "embedded-lobe-integral")] {
/// let t: LobeIntegral = load(lobefit_tables::embedded::LOBE_INTEGRAL).unwrap();
/// assert_eq!(t.table().meta().kind, LobeIntegral::KIND);
/// # }
/// ```
pub trait TableType: Sized + Send + Sync + 'static {
    /// The table kind (`Meta::kind`, the file name in `tables/data/` without
    /// `.lobefit`) this type reads; for a type reading several, its default one.
    const KIND: &'static str;
    /// The family version (`Meta::table_version`) this runtime reads: a file of another
    /// version is refused, as its layout or meaning may differ.
    const VERSION: u32;
    /// Every kind [`TableType::from_table`] accepts: [`TableType::KIND`] alone, except for
    /// a family whose variants are separate tables (`lobe-product`, `lobe-product-l2`).
    const KINDS: &'static [&'static str] = &[Self::KIND];

    /// Wraps a loaded table, checking its kind (one of [`TableType::KINDS`]), version,
    /// layout and channel ranges: the family's own validation.
    fn from_table(table: Table) -> Result<Self, LoadError>;

    /// The underlying table, e.g. for GPU upload.
    fn table(&self) -> &Table;

    /// Loads and validates a table file held in memory: [`Table::from_bytes`] (format,
    /// checksums), then [`TableType::from_table`].
    fn from_bytes(bytes: &[u8]) -> Result<Self, LoadError> {
        Self::from_table(Table::from_bytes(bytes)?)
    }
}

/// Implements [`TableType`] for a family type with a `table: Table` field and a
/// hand-written inherent `from_table`, and gives it the inherent `from_bytes` and
/// `table` that callers use without importing the trait:
///
/// `impl_table_type!(LobeIntegral: KIND, VERSION);`, with doc lines in front for `table()`
/// (default "The underlying table."), `, kinds = [A, B]` after for a type reading
/// several kinds.
macro_rules! impl_table_type {
    ($ty:ident: $kind:expr, $version:expr $(, kinds = [$($kinds:expr),+])?) => {
        $crate::table_type::impl_table_type! {
            /// The underlying table.
            $ty: $kind, $version $(, kinds = [$($kinds),+])?
        }
    };
    ($(#[$table_doc:meta])+ $ty:ident: $kind:expr, $version:expr $(, kinds = [$($kinds:expr),+])?) => {
        impl $crate::TableType for $ty {
            const KIND: &'static str = $kind;
            const VERSION: u32 = $version;
            $(const KINDS: &'static [&'static str] = &[$($kinds),+];)?

            fn from_table(table: $crate::Table) -> Result<Self, $crate::LoadError> {
                // The inherent `from_table` (inherent items come first in a path).
                $ty::from_table(table)
            }

            fn table(&self) -> &$crate::Table {
                &self.table
            }
        }

        impl $ty {
            /// Loads and validates a table file held in memory: [`Table::from_bytes`](crate::Table::from_bytes)
            /// (format, checksums), then [`from_table`](Self::from_table).
            pub fn from_bytes(bytes: &[u8]) -> Result<Self, $crate::LoadError> {
                <Self as $crate::TableType>::from_bytes(bytes)
            }

            $(#[$table_doc])+
            pub fn table(&self) -> &$crate::Table {
                &self.table
            }
        }
    };
}
pub(crate) use impl_table_type;

/// The list of every table kind (invoked once, at the crate root), one line per table:
///
/// `"kind" => Type::method, STATIC, "embedded-kind" $(, "note")?;`
///
/// generates `embedded::STATIC` (the committed `tables/data/<kind>.lobefit`, behind the
/// cargo feature), `embedded::by_kind`, `KINDS` (the kinds in list order) and
/// `Type::method()`, the embedded table parsed and validated once. It checks at compile
/// time that each `Type` implements [`TableType`] and reads its line's kind, and that
/// every kind a type reads is in the list.
macro_rules! table_types {
    ($($kind:literal => $ty:ident :: $method:ident, $static:ident, $feature:literal $(, $note:literal)?;)+) => {
        /// The committed default tables (`tables/data/*.lobefit`), compiled in: each behind
        /// its cargo feature `embedded-<table>` (`embedded`, on by default, means all), so a
        /// renderer compiles in only the tables it uses.
        pub mod embedded {
            $(
                #[cfg(feature = $feature)]
                #[doc = concat!("`tables/data/", $kind, ".lobefit`", $(" (", $note, ")",)? ".")]
                pub static $static: &[u8] = include_bytes!(concat!("../data/", $kind, ".lobefit"));
            )+

            /// The compiled-in file of table `kind` ([`KINDS`](crate::KINDS)), or `None` when
            /// its `embedded-<kind>` feature is off or no table has that kind.
            // With no `embedded-<table>` feature on, only the `_` arm is left.
            #[allow(clippy::match_single_binding)]
            pub fn by_kind(kind: &str) -> Option<&'static [u8]> {
                match kind {
                    $(
                        #[cfg(feature = $feature)]
                        $kind => Some($static),
                    )+
                    _ => None,
                }
            }
        }

        /// Every table kind, in build order (`lobefit build-tables`): one per file
        /// `tables/data/<kind>.lobefit`, each read by one family type ([`TableType`]).
        pub const KINDS: [&str; [$($kind),+].len()] = [$($kind),+];

        // A line whose type does not read its kind, or a kind a type reads that is not
        // listed, is a build error rather than a wrong table at run time.
        const _: () = {
            $(
                assert!(
                    $crate::table_type::contains(<$ty as $crate::TableType>::KINDS, $kind),
                    concat!("table_types!: ", stringify!($ty), " does not read kind ", $kind),
                );
                assert!(
                    $crate::table_type::all_in(<$ty as $crate::TableType>::KINDS, &$crate::KINDS),
                    concat!("table_types!: ", stringify!($ty), " reads a kind missing from the list"),
                );
            )+
        };

        $(
            #[cfg(feature = $feature)]
            impl $ty {
                #[doc = concat!(
                    "The default table compiled into this crate: `tables/data/", $kind, ".lobefit`",
                    $(" (", $note, ")",)?
                    ", cargo feature `", $feature, "`. Parsed and validated on the first call; ",
                    "later calls return the same table (or the same error)."
                )]
                pub fn $method() -> Result<&'static Self, $crate::LoadError> {
                    static CELL: std::sync::OnceLock<Result<$ty, $crate::LoadError>> = std::sync::OnceLock::new();
                    CELL.get_or_init(|| {
                        // The kind is checked against the line, not only against the
                        // type's own `KINDS`: `LobeProduct::embedded_l2` must be l2.
                        let table = $crate::Table::from_bytes_of_kind(
                            $crate::embedded::$static,
                            $kind,
                            <$ty as $crate::TableType>::VERSION,
                        )?;
                        <$ty as $crate::TableType>::from_table(table)
                    })
                    .as_ref()
                    .map_err(Clone::clone)
                }
            }
        )+
    };
}
pub(crate) use table_types;

/// `s` is one of `list` (string equality in a constant, for `table_types!`'s checks).
pub(crate) const fn contains(list: &[&str], s: &str) -> bool {
    let mut i = 0;
    while i < list.len() {
        if str_eq(list[i], s) {
            return true;
        }
        i += 1;
    }
    false
}

/// Every string of `sub` is in `set`.
pub(crate) const fn all_in(sub: &[&str], set: &[&str]) -> bool {
    let mut i = 0;
    while i < sub.len() {
        if !contains(set, sub[i]) {
            return false;
        }
        i += 1;
    }
    true
}

const fn str_eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}
