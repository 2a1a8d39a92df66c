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
//!
//! ## Map of the crate
//!
//! | family (table) | type | what a renderer asks it |
//! | --- | --- | --- |
//! | lobe-integral | [`LobeIntegral`] | ∫ of a cosine lobe (sr); also the closed form [`lobe_integral::exact`] |
//! | cap-exponent | [`CapExponent`] | the lobe exponent standing for a spherical cap (a light, a blocker) |
//! | lobe-product, lobe-product-l2 | [`LobeProduct`] | the product of two lobes as one lobe; lobe-sum triple products |
//! | isg-refit, isg-best | [`RefitIsg`], [`BestIsg`] ([`PaperIsg`] needs no table) | SG integrals over spherical rectangles |
//! | sg-fit | [`SgFit`] | the SG closest to a cosine lobe ([`Sg`]: SG algebra) |
//! | log-zh | [`LogZh`] | log-space ZH vectors of BRDFs and spherical blockers |
//! | wedge | [`Wedges`] | height-field wedge visibility in log space |
//! | shexp | [`ShExp`] | SH exponentiation (HYB) of summed log-visibility |
//! | wrap | [`WrapTable`] | per-band scalings of wrap lighting |
//! | disk-light | [`DiskLight`] | SH radiance and irradiance of a disk light |
//! | (no table) | [`rigs`], [`sh`], [`gaunt`] | irradiance rigs; SH basis, rotation, products |
//! | every table | [`Table`], [`format`](mod@format) | loading, validation, interpolation, the file format |
//!
//! Each family type loads its committed table with `embedded()` (cargo feature
//! `embedded-<table>`) or any file with `from_bytes` / `from_table`.
//!
//! ## Cargo features
//!
//! - `embedded` (default): all committed tables compiled in ([`embedded`]).
//! - `embedded-<table>` (e.g. `embedded-cap-exponent`): only that table, with
//!   `default-features = false`.
//! - `writer`: what only the table writer and fitter (the `lobefit` crate) need:
//!   `format::encode`, the families' axis builders and channel ranges, the models and
//!   reference closed forms the fits are built on. Not needed to read any table
//!   (adds the `visibility` proc-macro dependency).
//! - `ndarray`: `Table::view`, a table's stored values as an `ndarray::ArrayViewD<f32>`
//!   (axes × channels), for analysis code.
//!
//! ```
//! # #[cfg(feature = "embedded")] {
//! use lobefit_tables::glam::DVec3;
//! use lobefit_tables::*;
//! // Lobe product: two lobes as one (scale, axis, exponent).
//! let a = Lobe { scale: 1.0, axis: DVec3::Z, exponent: 20.0 };
//! let b = Lobe { scale: 1.0, axis: DVec3::new(0.1, 0.0, 1.0).normalize(), exponent: 20.0 };
//! let ab = LobeProduct::embedded().unwrap().product(&a, &b).unwrap();
//! assert!(ab.exponent > 20.0 && ab.axis.x > 0.0);
//! // SG closest to a cosine lobe of exponent 1, and the normalised ISG of a patch.
//! let sg = SgFit::embedded().unwrap().lobe_to_sg([0.0, 0.0, 1.0], 1.0, 1.0).unwrap();
//! assert!((sg.sharpness - 2.14).abs() < 0.01);
//! let s = BestIsg::embedded().unwrap().s_hat(1.2, 2.0, 10.0).unwrap();
//! assert!(s > 0.0 && s < 1.0);
//! // Log-ZH of a spherical blocker of angular radius 0.4 rad (order 4, ε = 0.1).
//! let mut z = [0.0; 4];
//! LogZh::embedded().unwrap().lookup(log_zh::Kind::Blocker, 0.1, 0.4, 4, &mut z).unwrap();
//! assert!(z[0] < 0.0);
//! // Turn it to the blocker's direction and exponentiate: SH visibility by HYB.
//! let mut f = [0.0; 16];
//! sh::zh_to_sh(&z, [0.0, 0.6, 0.8], &mut f).unwrap();
//! let mut vis = [0.0; 16];
//! ShExp::embedded().unwrap().hyb(&f, &mut vis).unwrap();
//! assert!(vis[0] > 0.0 && vis[0] < (4.0 * std::f64::consts::PI).sqrt());
//! // Wrap lighting's per-band scalings at a = 0.5.
//! let mut l = [0.0; 3];
//! WrapTable::embedded().unwrap().lookup(3, 0.5, &mut l).unwrap();
//! assert!(l[0] > l[1] && l[1] > l[2]);
//! // Irradiance at the origin (normal +z) from a disk light 2 m above, facing down.
//! let e = DiskLight::embedded()
//!     .unwrap()
//!     .irradiance(DVec3::ZERO, DVec3::Z, 2.0 * DVec3::Z, -DVec3::Z, 0.5, 1.0)
//!     .unwrap();
//! let exact = std::f64::consts::PI * 0.25 / (0.25 + 4.0); // π R²/(R² + d²), head-on
//! // Order-3 SH irradiance band-limits the clamped cosine: a small source on the
//! // normal reads up to 1/16 high (the truncated kernel is 1/4 + 1/2 + 5/16 at the pole).
//! assert!(e > exact && e < 1.0625 * exact, "{e} vs {exact}");
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
