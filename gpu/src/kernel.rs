//! Kernel plumbing: the `LfTex` uniform of a texture and the compute kernel around a
//! family's or function's body (the shader library, the bindings of `Gpu::run`), and
//! the conformance's [`Runner`] on a device.

use lobefit::export::gpu_check::{Kernel, Runner};
use lobefit::export::layout::Filter;
use lobefit::export::manifest::TextureEntry;

use crate::device::{Gpu, GpuTexture};

pub use lobefit_tables::uniform::LF_TEX_SIZE;

/// The uniform `LfTex` of a texture as bytes (`lobefit_tables::uniform::LfTex`, built
/// from the manifest entry).
pub fn lf_tex(t: &TextureEntry, filter: Filter) -> Result<Vec<u8>, String> {
    Ok(t.lf_tex(filter)?.to_bytes().to_vec())
}

/// The kernel: the library, the bindings of [`Gpu::run`], and `body` run per item with
/// inputs `x0 ..` and outputs written to `Y[o + k]`.
pub fn kernel(tex_type: &str, n_in: usize, n_out: usize, body: &str) -> String {
    kernel_with(tex_type, None, n_in, n_out, body)
}

/// [`kernel`] with a second texture of type `tex2_type` (`T2`, its `LfTex` `P2`: the
/// bindings of [`Gpu::run_with`]).
pub fn kernel_with(tex_type: &str, tex2_type: Option<&str>, n_in: usize, n_out: usize, body: &str) -> String {
    let mut types = vec![tex_type];
    types.extend(tex2_type);
    kernel_textures(&types, n_in, n_out, body)
}

/// [`kernel`] with the textures of `tex_types` (at least one): the first `T` (its
/// `LfTex` `P`), texture k ≥ 1 `T{k+1}` (`P{k+1}`), the bindings of
/// [`Gpu::run_textures`].
pub fn kernel_textures(tex_types: &[&str], n_in: usize, n_out: usize, body: &str) -> String {
    let xs: String = (0..n_in)
        .map(|k| format!("    let x{k} = X[i * {n_in}u + {k}u];\n"))
        .collect();
    let tex_type = tex_types.first().copied().unwrap_or("texture_2d<f32>");
    let second: String = (1..tex_types.len())
        .map(|k| {
            format!(
                "@group(0) @binding({}) var<uniform> P{}: LfTex;\n@group(0) @binding({}) var T{}: {};\n",
                4 + 2 * k,
                k + 1,
                5 + 2 * k,
                k + 1,
                tex_types[k]
            )
        })
        .collect();
    format!(
        "{lib}
@group(0) @binding(0) var<uniform> P: LfTex;
@group(0) @binding(1) var T: {tex_type};
@group(0) @binding(2) var S: sampler;
@group(0) @binding(3) var<storage, read> X: array<f32>;
@group(0) @binding(4) var<storage, read_write> Y: array<f32>;
@group(0) @binding(5) var<storage, read> N: vec4<u32>;
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

/// Runs the conformance's kernels ([`Kernel`]) on `gpu` with a family's uploaded
/// textures bound under one filter; a kernel naming no texture gets `dummy`.
pub struct Bound<'a> {
    /// The device.
    pub gpu: &'a Gpu,
    /// The family's textures as exported, in `grids` order.
    pub entries: &'a [TextureEntry],
    /// The same, uploaded.
    pub uploaded: &'a [GpuTexture],
    /// A texture for kernels that sample nothing.
    pub dummy: &'a GpuTexture,
    /// The filter (`LfTex.mode`).
    pub filter: Filter,
}

/// A kernel ready to dispatch: its WGSL source, `LfTex` bytes and texture, and a
/// second texture with its `LfTex`.
pub struct Prepared<'a> {
    /// WGSL source.
    pub source: String,
    /// The first texture's `LfTex` (zeros for none).
    pub params: Vec<u8>,
    /// The first texture (the dummy for none).
    pub texture: &'a GpuTexture,
    /// The second texture and its `LfTex`.
    pub second: Option<(Vec<u8>, &'a GpuTexture)>,
}

impl<'a> Bound<'a> {
    /// `k` over points of `n_in` inputs, with its textures bound.
    pub fn prepare(&self, k: &Kernel, n_in: usize) -> Result<Prepared<'a>, String> {
        let tex = |i: usize| -> Result<(&TextureEntry, &'a GpuTexture), String> {
            match (self.entries.get(i), self.uploaded.get(i)) {
                (Some(e), Some(t)) => Ok((e, t)),
                _ => Err(format!("{}: no texture {i} in this export", k.name)),
            }
        };
        Ok(match *k.textures.as_slice() {
            [] => Prepared {
                source: kernel("texture_2d<f32>", n_in, k.n_out, &k.body),
                params: vec![0u8; LF_TEX_SIZE],
                texture: self.dummy,
                second: None,
            },
            [a] => {
                let (e, t) = tex(a)?;
                Prepared {
                    source: kernel(t.wgsl_type, n_in, k.n_out, &k.body),
                    params: lf_tex(e, self.filter)?,
                    texture: t,
                    second: None,
                }
            }
            [a, b] => {
                let ((e, t), (e2, t2)) = (tex(a)?, tex(b)?);
                Prepared {
                    source: kernel_with(t.wgsl_type, Some(t2.wgsl_type), n_in, k.n_out, &k.body),
                    params: lf_tex(e, self.filter)?,
                    texture: t,
                    second: Some((lf_tex(e2, self.filter)?, t2)),
                }
            }
            _ => return Err(format!("{}: a kernel binds at most two textures", k.name)),
        })
    }
}

impl Bound<'_> {
    /// Dispatches `p` with `source` (its own, or a variant of it) over `inputs`
    /// (rounded to f32): `n_out` outputs per point, widened to f64.
    pub fn dispatch(
        &self,
        p: &Prepared,
        source: &str,
        inputs: &[Vec<f64>],
        n_out: usize,
    ) -> Result<Vec<Vec<f64>>, String> {
        let flat: Vec<f32> = inputs.iter().flat_map(|x| x.iter().map(|&v| v as f32)).collect();
        let out = self.gpu.run_with(
            source,
            &p.params,
            p.texture,
            p.second.as_ref().map(|(b, t)| (b.as_slice(), *t)),
            &flat,
            inputs.len(),
            n_out,
        )?;
        Ok(out
            .chunks(n_out)
            .map(|c| c.iter().map(|&v| f64::from(v)).collect())
            .collect())
    }
}

impl Runner for Bound<'_> {
    fn run(&self, k: &Kernel, inputs: &[Vec<f64>]) -> Result<Vec<Vec<f64>>, String> {
        let Some(n_in) = inputs.first().map(|x| x.len()) else {
            return Ok(Vec::new());
        };
        let p = self.prepare(k, n_in)?;
        self.dispatch(&p, &p.source, inputs, k.n_out)
    }
}

/// The line of a kernel file (gpu/shaders/<pipeline>.wgsl) between its functions and
/// its body (the statements of the entry point [`kernel`] writes).
pub const BODY_MARKER: &str = "// ---- main: the kernel's body (the statements inside its entry point, kernel.rs)\n";

/// A kernel file's (functions, body), split at [`BODY_MARKER`]; a file without it is
/// all functions.
pub fn split(shader: &'static str) -> (&'static str, &'static str) {
    shader.split_once(BODY_MARKER).unwrap_or((shader, ""))
}

#[cfg(test)]
mod tests {
    use lobefit::export::Storage;

    use super::*;

    /// `lf_tex` of an export's texture entry: the axis constants in axis[0], the mode
    /// in `mode` (the struct's layout against the WGSL: tests/it/export_shaders.rs).
    #[test]
    fn lf_tex_of_an_export_entry() {
        // A texture entry's axis constants land in axis[0], its mode in `mode`.
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path();
        let opts = lobefit::export::run::ExportOptions {
            only: vec!["cap-exponent".into()],
            format: lobefit::export::Format::Raw,
            storage: Storage::F32,
            scale: 1.0,
            allow_lossy: false,
        };
        let m = lobefit::export::run::export(&opts, dir).unwrap();
        let t = &m.families[0].textures[0];
        let b = lf_tex(t, Filter::Hardware).unwrap();
        assert_eq!(b.len(), LF_TEX_SIZE);
        let f = |off: usize| f32::from_le_bytes(b[off..off + 4].try_into().unwrap());
        assert_eq!(f(0), t.axes[0].mapped_lo as f32);
        assert_eq!(f(4), t.axes[0].mapped_hi as f32);
        assert_eq!(f(8), t.axes[0].axis.count as f32);
        assert_eq!(f(12), 3.0, "cap-exponent's axis is logit");
        assert_eq!(u32::from_le_bytes(b[624..628].try_into().unwrap()), 1);
    }

    /// f16 lobe-product: every compressed channel gets the export's width in
    /// `decode` (vec4 36 + layer), the others 0; the 1D ln W texture's six trend
    /// coefficients land at vec4 12 + 2k (c0..c3) and 13 + 2k (c4, c5).
    #[test]
    fn lf_tex_carries_compression_and_quintic_trends() {
        let tmp = tempfile::tempdir().unwrap();
        let dir = tmp.path().join("lp16");
        let opts = lobefit::export::run::ExportOptions {
            only: vec!["lobe-product-l2".into()],
            format: lobefit::export::Format::Raw,
            storage: Storage::F16,
            scale: 0.25,
            allow_lossy: true,
        };
        let m = lobefit::export::run::export(&opts, &dir).unwrap();
        let texs = &m.families[0].textures;
        let f = |b: &[u8], vec4: usize, c: usize| {
            let off = 16 * vec4 + 4 * c;
            f32::from_le_bytes(b[off..off + 4].try_into().unwrap())
        };
        let main = &texs[0];
        assert_eq!(main.channels.len(), 3, "c, ρ, κ");
        let b = lf_tex(main, Filter::Manual).unwrap();
        for ch in &main.channels {
            assert_eq!(ch.compression, 0.5, "{}", ch.name);
            assert_eq!(f(&b, 36 + ch.layer as usize, ch.component as usize), 0.5);
        }
        assert_eq!(f(&b, 36, 3), 0.0, "an unused channel is not decoded");
        let lnw = &texs[1];
        let ch = &lnw.channels[0];
        assert_eq!(ch.trend.len(), 6, "f16 1D textures carry a quintic trend");
        let b = lf_tex(lnw, Filter::Manual).unwrap();
        for (j, want) in ch.trend.iter().enumerate() {
            assert_eq!(f(&b, 12 + j / 4, j % 4), *want as f32, "coefficient {j}");
        }
        assert_eq!(f(&b, 36, 0), 0.0, "ln W is stored as is");
    }
}
