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
//! | wedge | [`Wedge`] | height-field wedge visibility in log space |
//! | shexp | [`ShExp`] | SH exponentiation (HYB) of summed log-visibility |
//! | wrap | [`Wrap`] | per-band scalings of wrap lighting |
//! | disk-light | [`DiskLight`] | SH radiance and irradiance of a disk light |
//! | mask-weights | [`MaskWeights`] ([`meunier`]: the pipeline) | eq. 39's per-depth weights of visibility-mask leaf lobes; direct lighting with soft shadows from sphere blockers |
//! | (no table) | [`rigs`], [`sh`], [`gaunt`] | irradiance rigs; SH basis, rotation, products |
//! | (no table) | [`geom`] | the scene types every pipeline shares: spheres, spherical lights, BRDFs |
//! | (no table) | [`microfacet`] | Cook–Torrance (GGX), Blinn-Phong and Ashikhmin–Shirley terms; the first two as warped SGs for SG lighting, Cook–Torrance's directional albedo |
//! | every table | [`Table`], [`format`](mod@format) | loading, validation, interpolation, the file format |
//!
//! Each family type loads its committed table with `embedded()` (cargo feature
//! `embedded-<table>`) or any file with `from_bytes` / `from_table`.
//!
//! Every family type implements [`TableType`] (`KIND`, `VERSION`, `from_table`,
//! `table`, `from_bytes`), for code generic over families; the same functions are
//! inherent methods, so callers need not import the trait. The tables themselves are
//! one list in this file, in build order ([`KINDS`]): each line generates the
//! [`embedded`] static and the type's `embedded()`, and a line whose type does not
//! read its kind fails the build. A family's file writes only its validation
//! (`from_table`) and its lookups.
//!
//! ## Naming rules
//!
//! One name for one thing, so a renderer author can guess an API from its neighbours:
//!
//! - **Table types** are named after their family in CamelCase ([`CapExponent`],
//!   [`SgFit`], [`Wedge`], [`Wrap`]); a family with several models prefixes the model
//!   ([`RefitIsg`], [`BestIsg`]).
//! - **f32 twins**: a function's twin is `<name>_f32` (f32 in and out, computed in f64
//!   and rounded once); a value type's twin is `<Type>32` ([`Lobe32`], [`lobe_product::ProductParams32`],
//!   [`Sg32`], [`geom::Sphere32`]).
//! - **`embedded()`** returns `Result<&'static Self, LoadError>`: parsed and validated
//!   once, shared afterwards ([`Meunier::embedded`] too).
//! - **Argument order**: the selectors first (which table, kind, order, variant), then
//!   the continuous inputs in the order of the table's axes, then the output slice:
//!   `LogZh::lookup(kind, order, eps, param, out)`, `Wrap::lookup(order, a, out)`.
//! - **Errors**: a lookup's bad input is a [`LookupError`] naming the input; a file's, a
//!   [`LoadError`]; a pipeline's error carries what a table refused as the lookup's
//!   error ([`MeunierError::Lookup`]).
//! - **One quadrature of each kind**: Gauss–Legendre is `gaunt::gauss_legendre`
//!   (feature `writer`), shared by the fitter and its checks.
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
//! ## Vectors and f32
//!
//! Directions are glam vectors: `DVec3` for f64 calls (functions accept anything
//! `Into<DVec3>`, so `[f64; 3]` works too), `Vec3` for f32 calls. Every lookup has an
//! `_f32` twin (`e_cap_f32`, `params_f32`, `product_f32`, `product_sums_f32`,
//! `triple_product_f32`, `canonical_f32`, `irradiance_f32`, `hyb_f32`,
//! `hyb_threshold_f32`, `lookup_f32`, `lobe_to_sg_f32`, [`Sg32`], [`Lobe32`], …).
//! A twin takes and returns f32 and computes in f64, rounding once: its result is the
//! f64 lookup's correctly rounded, so its error is the f64 lookup's plus at most half
//! an f32 ulp. `lobefit check` measures every twin against the independent references
//! (the `<output> f32` rows) and holds it to the f64 promise widened by one rounding.
//! Twins taking an angle read `std::f32::consts::PI` (what `acos(-1.0f32)` returns,
//! π + 8.7e-8) as π ([`error::angle_f32`]).
//!
//! This is a choice: computing in f32 throughout, as a shader does, loses digits in
//! the mappings (logarithms, arc sines, the lgamma model of the lobe product) that
//! the tightest targets cannot spare (the lobe integral promises 1e-6 relative, eight
//! f32 ulps), and on a CPU costs about the same. What an f32-arithmetic pipeline gets
//! depends on that pipeline (its texture layout, filtering and mappings) and is
//! measured with it.
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
//! LogZh::embedded().unwrap().lookup(log_zh::Kind::Blocker, 4, 0.1, 0.4, &mut z).unwrap();
//! assert!(z[0] < 0.0);
//! // SH visibility (order 4) at the origin of two sphere blockers (centre, radius),
//! // by HYB, in one call (log_zh::sphere_cap gives one blocker's direction and angle).
//! let blockers = [(DVec3::new(0.0, 1.2, 1.6), 0.5), (DVec3::new(1.0, 0.0, 2.0), 0.3)];
//! let mut vis = [0.0; 16];
//! ShExp::embedded().unwrap().hyb_spheres(DVec3::ZERO, &blockers, 4, &mut vis).unwrap();
//! assert!(vis[0] > 0.0 && vis[0] < (4.0 * std::f64::consts::PI).sqrt());
//! // An SG's integral over a rectangle given in world space (θ from the pole +y,
//! // φ about it from +x): the SG axis +z sits at φ = π/2.
//! let (t, p) = ([1.2, 1.9], [1.3, 1.8]);
//! let i = BestIsg::embedded().unwrap().patch_world(&sg, DVec3::Y, DVec3::X, t, p).unwrap();
//! assert!(i > 0.0 && i < sg.integral());
//! // Wrap lighting's per-band scalings at a = 0.5.
//! let mut l = [0.0; 3];
//! Wrap::embedded().unwrap().lookup(3, 0.5, &mut l).unwrap();
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
pub mod geom;
pub mod isg;
pub mod lobe_integral;
pub mod lobe_product;
pub mod log_zh;
pub mod mask_weights;
mod meta_error;
pub mod meunier;
pub mod microfacet;
pub mod rigs;
pub mod sg_fit;
pub mod sh;
pub mod shaders;
pub mod shexp;
pub mod table;
mod table_type;
pub mod uniform;
pub mod wedge;
pub mod wrap;

pub use glam;

pub use cap_exponent::CapExponent;
pub use disk_light::DiskLight;
pub use error::{LoadError, LookupError};
pub use format::{Axis, Channel, Encoding, Mapping, Meta, Placement, Storage};
pub use isg::{BestAtGamma, BestIsg, IsgModel, PaperIsg, RefitIsg, SeparableIsg, Sg, Sg32};
pub use lobe_integral::LobeIntegral;
pub use lobe_product::{Lobe, Lobe32, LobeProduct, ProductParams, Variant};
pub use log_zh::LogZh;
pub use mask_weights::{MaskMode, MaskWeights, WeightSet};
pub use meunier::{Meunier, MeunierError};
pub use sg_fit::SgFit;
pub use shexp::ShExp;
pub use table::Table;
pub use table_type::TableType;
pub use wedge::Wedge;
pub use wrap::Wrap;

// The one list of tables: each line generates `embedded::<STATIC>` (behind its cargo
// feature), the type's `embedded()`-style constructor and an entry of `KINDS`; a new
// table is one line here, one `embedded-<kind>` feature in Cargo.toml and its
// family's `impl_table_type!`.
table_type::table_types! {
    // kind           => Type::constructor,        static in `embedded`, cargo feature[, note]
    "lobe-integral"   => LobeIntegral::embedded,   LOBE_INTEGRAL,   "embedded-lobe-integral";
    "cap-exponent"    => CapExponent::embedded,    CAP_EXPONENT,    "embedded-cap-exponent";
    "isg-refit"       => RefitIsg::embedded,       ISG_REFIT,       "embedded-isg-refit";
    "isg-best"        => BestIsg::embedded,        ISG_BEST,        "embedded-isg-best";
    "sg-fit"          => SgFit::embedded,          SG_FIT,          "embedded-sg-fit";
    "log-zh"          => LogZh::embedded,          LOG_ZH,          "embedded-log-zh";
    "wedge"           => Wedge::embedded,         WEDGE,           "embedded-wedge";
    "wrap"            => Wrap::embedded,      WRAP,            "embedded-wrap";
    "disk-light"      => DiskLight::embedded,      DISK_LIGHT,      "embedded-disk-light";
    "shexp"           => ShExp::embedded,          SHEXP,           "embedded-shexp";
    "lobe-product"    => LobeProduct::embedded,    LOBE_PRODUCT,    "embedded-lobe-product", "the `energy` variant";
    "lobe-product-l2" => LobeProduct::embedded_l2, LOBE_PRODUCT_L2, "embedded-lobe-product-l2";
    "mask-weights"    => MaskWeights::embedded,    MASK_WEIGHTS,    "embedded-mask-weights";
}

/// The crate README's examples, compiled and run as doctests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
struct ReadmeDoctests;
