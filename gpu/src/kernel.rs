//! Kernel plumbing: the `LfTex` uniform of a texture and the compute kernel around a
//! family's or function's body (the shader library, the bindings of `Gpu::run`).

use lobefit::export::layout::Filter;
use lobefit::export::run::TextureEntry;
use lobefit_tables::Mapping;

/// Bytes of the uniform `LfTex` (tables/shaders/common.wgsl): 40 vec4.
pub const LF_TEX_SIZE: usize = 640;

/// The uniform `LfTex` of a texture (see tables/shaders/common.wgsl), [`LF_TEX_SIZE`]
/// bytes: 39 vec4 of f32 (axis 0..3, map 3..6, offset 6..9, scale 9..12, trend
/// 12..36, decode 36..39), then `mode`. Channels named `*_compressed` (lobe-product's
/// f16 export) get the export's compression width in `decode`.
pub fn lf_tex(t: &TextureEntry, filter: Filter) -> Vec<u8> {
    let mut v = [[0f32; 4]; 39];
    for (k, a) in t.axes.iter().enumerate() {
        let (kind, p0, p1) = match a.axis.mapping {
            Mapping::Linear => (0.0, 0.0, 0.0),
            Mapping::Log => (1.0, 0.0, 0.0),
            Mapping::Log1p { scale } => (2.0, scale, 0.0),
            Mapping::Logit { a, b } => (3.0, a, b),
            Mapping::Asinh { centre, width } => (4.0, centre, width),
        };
        v[k] = [a.mapped_lo as f32, a.mapped_hi as f32, a.axis.count as f32, kind];
        v[3 + k] = [p0 as f32, p1 as f32, 0.0, 0.0];
    }
    // Unused channels: offset 0, scale 1.
    for l in 0..3 {
        v[9 + l] = [1.0; 4];
    }
    for ch in &t.channels {
        let (l, c) = (ch.layer as usize, ch.component as usize);
        assert!(
            l < 3 && c < 4 && ch.trend.len() <= 6,
            "{}: channel {} (layer {l}, component {c}, {} trend coefficients) does not fit LfTex \
             (3 layers of 4 channels, quintic trends)",
            t.file,
            ch.name,
            ch.trend.len()
        );
        v[6 + l][c] = ch.offset as f32;
        v[9 + l][c] = ch.scale as f32;
        let k = 4 * l + c;
        for (j, coef) in ch.trend.iter().enumerate() {
            v[12 + 2 * k + j / 4][j % 4] = *coef as f32;
        }
        if ch.name.ends_with(lobefit::fits::lobe_product::gpu::COMPRESSED) {
            v[36 + l][c] = lobefit::fits::lobe_product::gpu::WIDTH as f32;
        }
    }
    let mut bytes: Vec<u8> = bytemuck::cast_slice(&v).to_vec();
    let mode: [u32; 4] = [if filter == Filter::Hardware { 1 } else { 0 }, 0, 0, 0];
    bytes.extend_from_slice(bytemuck::cast_slice(&mode));
    bytes
}

/// The kernel: the library, the bindings of [`Gpu::run`], and `body` run per item with
/// inputs `x0 ..` and outputs written to `Y[o + k]`.
pub fn kernel(tex_type: &str, n_in: usize, n_out: usize, body: &str) -> String {
    kernel_with(tex_type, None, n_in, n_out, body)
}

/// [`kernel`] with a second texture of type `tex2_type` (`T2`, its `LfTex` `P2`: the
/// bindings of [`Gpu::run_with`]).
pub fn kernel_with(tex_type: &str, tex2_type: Option<&str>, n_in: usize, n_out: usize, body: &str) -> String {
    let xs: String = (0..n_in)
        .map(|k| format!("    let x{k} = X[i * {n_in}u + {k}u];\n"))
        .collect();
    let second = tex2_type.map_or(String::new(), |t| {
        format!("@group(0) @binding(6) var<uniform> P2: LfTex;\n@group(0) @binding(7) var T2: {t};\n")
    });
    format!(
        "{lib}
@group(0) @binding(0) var<uniform> P: LfTex;
@group(0) @binding(1) var T: {tex_type};
@group(0) @binding(2) var S: sampler;
@group(0) @binding(3) var<storage, read> X: array<f32>;
@group(0) @binding(4) var<storage, read_write> Y: array<f32>;
@group(0) @binding(5) var<uniform> N: vec4<u32>;
{second}
@compute @workgroup_size(64)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {{
    let i = gid.x;
    if i >= N.x {{
        return;
    }}
    let o = i * {n_out}u;
{xs}{body}
}}
",
        lib = lobefit_tables::shaders::library()
    )
}
