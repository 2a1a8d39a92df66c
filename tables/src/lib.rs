//! # lobefit-tables
//!
//! The runtime half of lobefit: loads, validates and interpolates the precomputed
//! tables that `lobefit build-tables` writes, for renderers and GPU-upload code.
//! Its only dependencies are serde, postcard, crc32fast, thiserror and glam (whose
//! `Vec3`/`DVec3` the vector APIs take, re-exported as [`glam`]).
//!
//! Conventions (docs/math.md §1): directions are unit vectors, integrals are over solid angle
//! (steradians), angles are in radians, `log` is the natural logarithm. A cosine lobe
//! is `Ψ(v; a, e) = max(a·v, 0)^e`.
//!
//! ```
//! # #[cfg(feature = "embedded")] {
//! use lobefit_tables::{CapExponent, LobeIntegral};
//! // The default tables are compiled in; no file system needed.
//! let lobes = LobeIntegral::embedded().expect("committed table is valid");
//! let i = lobes.integral(10.0).unwrap(); // ∫ max(a·v,0)^10 dω in sr
//! assert!((i - 2.0 * std::f64::consts::PI / 11.0).abs() < 1e-6 * i);
//! let caps = CapExponent::embedded().unwrap();
//! let e = caps.e_cap(0.1).unwrap(); // lobe exponent best matching a 0.1 rad cap
//! assert!((e - 191.6426).abs() < 0.05);
//! // Bad queries are errors, not NaNs.
//! assert!(caps.e_cap(f64::NAN).is_err());
//! # }
//! ```

pub mod cap_exponent;
pub mod disk_light;
pub mod error;
pub mod format;
pub mod gaunt;
pub mod isg;
pub mod lobe_integral;
pub mod lobe_product;
pub mod log_zh;
mod meta_error;
pub mod rigs;
pub mod sg_fit;
pub mod sh;
pub mod shexp;
pub mod table;
pub mod wedge;
pub mod wrap;

pub use glam;

pub use cap_exponent::CapExponent;
pub use disk_light::DiskLight;
pub use error::{LoadError, LookupError};
pub use format::{Axis, Channel, Encoding, Mapping, Meta, Placement, Storage};
pub use isg::{BestIsg, IsgModel, PaperIsg, RefitIsg, Sg, Sg32};
pub use lobe_integral::LobeIntegral;
pub use lobe_product::{Lobe, LobeF32, LobeProduct, ProductParams, Variant};
pub use log_zh::LogZh;
pub use sg_fit::SgFit;
pub use shexp::ShExp;
pub use table::Table;
pub use wedge::Wedges;
pub use wrap::WrapTable;

/// The committed default tables (`tables/data/*.lobefit`), compiled in: each behind
/// its cargo feature `embedded-<table>` (`embedded`, on by default, means all), so a
/// renderer compiles in only the tables it uses.
pub mod embedded {
    #[cfg(feature = "embedded-lobe-integral")]
    /// `tables/data/lobe-integral.lobefit`.
    pub static LOBE_INTEGRAL: &[u8] = include_bytes!("../data/lobe-integral.lobefit");
    #[cfg(feature = "embedded-cap-exponent")]
    /// `tables/data/cap-exponent.lobefit`.
    pub static CAP_EXPONENT: &[u8] = include_bytes!("../data/cap-exponent.lobefit");
    #[cfg(feature = "embedded-isg-refit")]
    /// `tables/data/isg-refit.lobefit`.
    pub static ISG_REFIT: &[u8] = include_bytes!("../data/isg-refit.lobefit");
    #[cfg(feature = "embedded-isg-best")]
    /// `tables/data/isg-best.lobefit`.
    pub static ISG_BEST: &[u8] = include_bytes!("../data/isg-best.lobefit");
    #[cfg(feature = "embedded-sg-fit")]
    /// `tables/data/sg-fit.lobefit`.
    pub static SG_FIT: &[u8] = include_bytes!("../data/sg-fit.lobefit");
    #[cfg(feature = "embedded-log-zh")]
    /// `tables/data/log-zh.lobefit`.
    pub static LOG_ZH: &[u8] = include_bytes!("../data/log-zh.lobefit");
    #[cfg(feature = "embedded-wedge")]
    /// `tables/data/wedge.lobefit`.
    pub static WEDGE: &[u8] = include_bytes!("../data/wedge.lobefit");
    #[cfg(feature = "embedded-shexp")]
    /// `tables/data/shexp.lobefit`.
    pub static SHEXP: &[u8] = include_bytes!("../data/shexp.lobefit");
    #[cfg(feature = "embedded-lobe-product")]
    /// `tables/data/lobe-product.lobefit` (the `energy` variant).
    pub static LOBE_PRODUCT: &[u8] = include_bytes!("../data/lobe-product.lobefit");
    #[cfg(feature = "embedded-lobe-product-l2")]
    /// `tables/data/lobe-product-l2.lobefit`.
    pub static LOBE_PRODUCT_L2: &[u8] = include_bytes!("../data/lobe-product-l2.lobefit");
    #[cfg(feature = "embedded-disk-light")]
    /// `tables/data/disk-light.lobefit`.
    pub static DISK_LIGHT: &[u8] = include_bytes!("../data/disk-light.lobefit");
    #[cfg(feature = "embedded-wrap")]
    /// `tables/data/wrap.lobefit`.
    pub static WRAP: &[u8] = include_bytes!("../data/wrap.lobefit");
}
