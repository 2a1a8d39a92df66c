//! The shader library: WGSL functions that evaluate the tables on the GPU from the
//! textures `lobefit export` writes (and the closed forms that need no texture).
//!
//! WGSL has no `#include`: concatenate [`COMMON`] and the files a shader needs, in the
//! order of [`FILES`], or take the whole library from [`library`]. Functions and types
//! are prefixed `lf_` / `Lf`; textures and samplers are function arguments, so the
//! library declares no bindings. Each textured function takes the texture's
//! parameters as an `LfTex` (filled from the export's `manifest.json`: the axis
//! mappings, channel offsets/scales/trends, and manual or hardware filtering); 1D
//! tables are bound as 2D textures of height 1. `lobefit export --shaders` writes the
//! library as WGSL, GLSL (450 and ES 3.0) and HLSL. Conventions (units, SH basis) are
//! those of the Rust runtime, stated per function in the sources.

/// Texture parameters (`LfTex`), coordinate mappings, manual and hardware filtering.
pub const COMMON: &str = include_str!("../shaders/common.wgsl");
/// Real SH basis (any order ≤ 8, order 3 by polynomials), ZH → SH, order-3 rotation.
pub const SH: &str = include_str!("../shaders/sh.wgsl");
/// Lobe integral, cap exponent, lobe → SG, SG product, evaluation, integrals.
pub const LOBE: &str = include_str!("../shaders/lobe.wgsl");
/// ISG models: paper (closed form), refit and best (textures); Ŝ, S and the patch integral.
pub const ISG: &str = include_str!("../shaders/isg.wgsl");
/// Wrap lighting: λ̂_l(a) in closed form.
pub const WRAP: &str = include_str!("../shaders/wrap.wgsl");
/// Log-ZH vectors in closed form (diffuse, Phong, blocker); needs [`WRAP`].
pub const LOG_ZH: &str = include_str!("../shaders/log_zh.wgsl");
/// Disk lights: canonical SH from the texture, rotation to world, irradiance; needs [`SH`].
pub const DISK_LIGHT: &str = include_str!("../shaders/disk_light.wgsl");
/// Wedge visibility operator: entries and the mat-vec.
pub const WEDGE: &str = include_str!("../shaders/wedge.wgsl");
/// Lobe products (both variants): peak, exponent, arc fraction, integral; the axis on the arc.
pub const LOBE_PRODUCT: &str = include_str!("../shaders/lobe_product.wgsl");
/// shexp: f, ‖f̂‖, a, b at θ_b (kink-aware); HYB's a, b at ‖f̂‖.
pub const SHEXP: &str = include_str!("../shaders/shexp.wgsl");
/// Shading with the ISG: the limiting cone, the ISG frame's pole, the clamped-cosine
/// integral of an SG (Iwasaki et al.'s pipeline).
pub const ISG_SHADE: &str = include_str!("../shaders/isg_shade.wgsl");

/// Every file of the library as (file name, source), in dependency order.
pub const FILES: [(&str, &str); 11] = [
    ("common.wgsl", COMMON),
    ("sh.wgsl", SH),
    ("lobe.wgsl", LOBE),
    ("isg.wgsl", ISG),
    ("wrap.wgsl", WRAP),
    ("log_zh.wgsl", LOG_ZH),
    ("disk_light.wgsl", DISK_LIGHT),
    ("wedge.wgsl", WEDGE),
    ("lobe_product.wgsl", LOBE_PRODUCT),
    ("shexp.wgsl", SHEXP),
    ("isg_shade.wgsl", ISG_SHADE),
];

/// The whole library as one WGSL source (the files of [`FILES`] concatenated).
pub fn library() -> String {
    let mut s = String::new();
    for (name, src) in FILES {
        s.push_str("// ---- ");
        s.push_str(name);
        s.push('\n');
        s.push_str(src);
        s.push('\n');
    }
    s
}
