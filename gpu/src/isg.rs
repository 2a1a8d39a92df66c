//! `lobefit-gpu render isg`: Iwasaki et al.'s pipeline (`lobefit::pipelines::isg`) as
//! one compute kernel per pixel, on the exported isg-best and sg-fit textures, against
//! the CPU pipeline's image (docs/isg-render.md).
//!
//! The kernel is the CPU's `shade::radiance` with its default settings (best model,
//! adaptive patches, ε = 0.01, binary occlusion, every lighting SG times the BRDF SG,
//! the exact clamped cosine) in f32: the library's `lf_isg_best`, `lf_lobe_to_sg`,
//! `lf_sg_product`, `lf_sg_clamped_cosine`, `lf_isg_cone`, `lf_any_orthonormal`, and
//! the patch loop. The scene's blockers (its spheres, then its meshes' sphere sets:
//! `Scene::proxies`) and SGs follow the pixels in the input buffer. Per SG product the
//! blockers meeting its cone are gathered once and each cap written into per-row bit
//! masks of the patch grid in closed form (the rows as statements: llvmpipe ends an
//! invocation's loops after 65 535 iterations in all), so the patch loop reads a bit
//! per patch with no loop over blockers inside; the best model's separable factors are
//! taken once per grid edge. The loops left are bounded before dispatch and checked
//! after it (`crate::budget`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use lobefit::export::layout::Filter;
use lobefit::export::Storage;
use lobefit::export::{manifest::TextureEntry, Texture};
use lobefit::pipelines::isg::shade::{radiance, Blockers, Phong, Settings, Specular, Tables};
use lobefit::pipelines::isg::vertex;
use lobefit::pipelines::scene::Hit;
use lobefit::pipelines::spheres::tree::SphereTree;

use crate::budget;
use crate::device::Gpu;
use crate::kernel::{kernel_textures, lf_tex, split};
use crate::render::{compare_and_write, family_textures, SceneRender, VerifiedExport};
use crate::render::{parse, Render};

/// `lobefit-gpu render isg`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// A `lobefit export` directory with isg-best and sg-fit.
    #[arg(long, value_name = "DIR")]
    export: PathBuf,
    /// A built-in ISG scene (fig12, fig12-diffuse) or a scene file.
    #[arg(long, default_value = "fig12")]
    scene: String,
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = WIDTH, value_parser = clap::value_parser!(u32).range(4..=1024))]
    width: u32,
    /// Output PNG.
    #[arg(long)]
    out: PathBuf,
    /// Render an animated scene as N frames (times 0 to 1), each against the CPU
    /// pipeline; the frames go to OUT's stem with `-frame-KKK.png`.
    #[arg(long, value_parser = clap::value_parser!(u32).range(2..=240))]
    frames: Option<u32>,
    /// Shade the meshes per vertex (Iwasaki et al.'s default): every used vertex of
    /// the scene's meshes by the kernel, each mesh pixel the barycentric blend of its
    /// triangle's three values; pixels on no mesh per pixel. Against the CPU pipeline
    /// at the same vertices.
    #[arg(long)]
    per_vertex: bool,
    /// Shade through the sphere hierarchy's cut at this angle (degrees, 0 to 90;
    /// docs/meshes.md, "A sphere hierarchy"): a node whose bound subtends less than it
    /// is one stand-in sphere; against the CPU pipeline's cut at the same angle.
    #[arg(long, value_name = "DEGREES", value_parser = parse_cut)]
    cut: Option<f64>,
}

/// `--cut`: finite degrees in [0, 90].
fn parse_cut(v: &str) -> Result<f64, String> {
    match v.parse::<f64>() {
        Ok(d) if (0.0..=90.0).contains(&d) => Ok(d),
        _ => Err(format!("{v}: the cut angle is degrees in [0, 90]")),
    }
}

/// How `render isg` shades beyond its defaults.
#[derive(Debug, Clone, Copy, Default)]
pub struct Options {
    /// Meshes per vertex (`--per-vertex`).
    pub per_vertex: bool,
    /// The sphere hierarchy's cut at this angle (radians; `--cut`).
    pub cut: Option<f64>,
}

/// `render isg`.
pub const RENDER: Render = Render {
    name: "isg",
    about: "Iwasaki et al.'s ISG pipeline per pixel on the GPU (the exported isg-best and sg-fit textures) \
            against the CPU pipeline's image (docs/isg-render.md)",
    options: <Args as clap::CommandFactory>::command,
    run: |m| run(parse(m)?),
    bench: Some(crate::render::Bench {
        rank: 0,
        scene: "fig12",
        any_scene: true,
        families: Some(FAMILIES),
        kernel: bench_kernel,
    }),
};

fn run(a: Args) -> Result<ExitCode, String> {
    crate::render::check_out(&a.out)?;
    let sc = lobefit::pipelines::isg::render::scene(&a.scene)?;
    check_sharpness(&sc)?;
    if a.per_vertex && sc.meshes.is_empty() {
        return Err(format!("render isg --per-vertex: scene {} has no mesh", a.scene));
    }
    let opts = Options {
        per_vertex: a.per_vertex,
        cut: a.cut.map(f64::to_radians),
    };
    let (ex, gpu) = crate::render::open(&a.export, FAMILIES, |budget| {
        check_scene(budget, &sc, "render isg", opts.cut.is_some())
    })?;
    if let Some(n) = a.frames {
        return crate::render::animate("render isg", &sc, n as usize, &gpu, &a.out, |still, path| {
            render_isg(&gpu, &ex, still, a.width as usize, path, opts)
        });
    }
    let r = render_isg(&gpu, &ex, &sc, a.width as usize, &a.out, opts)?;
    if sc.prefiltered.is_some() {
        out!(
            "render isg {}: the specular term by eq. 9 from the scene's Γ_L (textureLoad, f32)",
            a.scene
        );
    }
    crate::render::report("render isg", &a.scene, &r, &gpu, &a.out)
}

/// Default image width (height 3/4 of it).
pub const WIDTH: u32 = 64;

/// f32 inputs per pixel.
const INPUTS: usize = 14;

/// Refuses a scene a device with loop budget `budget` ([`Gpu::loop_budget`]: llvmpipe's,
/// or none on a GPU) cannot render: pixels that may need more loop iterations than it.
pub fn check_scene(
    budget: Option<u64>,
    scene: &lobefit::pipelines::scene::Scene,
    command: &str,
    cut: bool,
) -> Result<(), String> {
    budget::refuse_over(
        budget,
        command,
        iterations(
            scene.proxies.len(),
            scene.environment.len(),
            scene.prefiltered.is_some(),
            cut,
        ),
        &format!(
            "{} SGs, {} blocker spheres",
            scene.environment.len(),
            scene.proxies.len()
        ),
    )
}

/// Refuses a scene whose SG products may be sharper than the ISG table's γ ≤
/// [`GAMMA_MAX`](lobefit_tables::isg::GAMMA_MAX): the kernel reads the table there
/// (clamping γ subtracted a broader SG's patches: negative radiance), where the CPU
/// pipeline integrates such products by quadrature. The bound: a product's sharpness
/// is at most the sum of its factors' (the lighting SG's and the Phong lobe's fitted
/// SG, or the cosine's).
pub fn check_sharpness(scene: &lobefit::pipelines::scene::Scene) -> Result<(), String> {
    use lobefit_tables::geom::Brdf;
    let fit = lobefit_tables::SgFit::embedded().map_err(|e| e.to_string())?;
    let mut lobe = fit.fit(1.0).map_err(|e| e.to_string())?.0;
    for m in &scene.materials {
        if let Brdf::Lafortune { lobes, .. } = m {
            for l in lobes {
                lobe = lobe.max(fit.fit(l.exponent).map_err(|e| format!("scene {}: {e}", scene.name))?.0);
            }
        }
    }
    let light = scene.environment.iter().map(|g| g.sharpness).fold(0.0, f64::max);
    let max = lobefit_tables::isg::GAMMA_MAX;
    if light + lobe > max {
        return Err(format!(
            "render isg: scene {} has SG products up to sharpness {:.4e} (lighting {light:.4e} + lobe {lobe:.4e}); \
             the GPU kernel reads the ISG table, γ ≤ {max:e} (lobefit render isg integrates sharper \
             products by quadrature on the CPU)",
            scene.name,
            light + lobe
        ));
    }
    Ok(())
}

/// The kernel's flag where the hierarchy's walk passed its budget.
const FLAG_WALK: f32 = 3.0;

/// Passes of the hierarchy's walk a pixel may take on a device with loop budget
/// `budget` (all of the walks of its products together): what the rest of its loops
/// leave of llvmpipe's budget, less 64; none on a GPU. The kernel counts every pass of
/// both of the walk's loops and flags the pixel past it ([`FLAG_WALK`]): an error
/// naming the limit, never an image.
fn walk_budget(budget: Option<u64>, scene: &lobefit::pipelines::scene::Scene) -> u64 {
    match budget {
        None => u64::from(u32::MAX),
        Some(b) => b.saturating_sub(
            iterations(
                scene.proxies.len(),
                scene.environment.len(),
                scene.prefiltered.is_some(),
                true,
            ) + 64,
        ),
    }
}

/// Entries of the kernel's stack for the hierarchy's walk (`array<u32, 64>` in
/// gpu/shaders/isg.wgsl): a tree up to 63 deep.
const STACK: usize = 64;

/// Patches per side of an SG product's cone, at most (`clamp(.., 10, 20)`).
const MAX_PATCHES: u64 = 20;

/// Loop iterations of `lf_sg_clamped_cosine` at most: its insertion sort's loops
/// (15 + Σ_{i=1}^{14} (i + 1)) and its panel loop (15); the loops of a constant count
/// inside are unrolled.
pub(crate) const CLAMPED_COSINE_ITERATIONS: u64 = 15 + 119 + 15;

/// The families render isg reads, and how to export them.
pub const FAMILIES: (&[&str], &str) = (
    &[lobefit_tables::isg::KIND_BEST, lobefit_tables::sg_fit::KIND],
    "isg-best,sg-fit",
);

/// An upper bound on the loop iterations of one pixel's kernel (`crate::budget`): the
/// buried test over the blockers; the SG loop; per SG the clamped cosine and, per BRDF
/// term (diffuse, specular), the rows' trigonometry (k ≤ 20), the gather over every
/// blocker, or with `cut` the walk of the hierarchy over them (its grid rows are statements), the edge factors (k + 1 ≤ 21) and the patch
/// loops (k ≤ 20 per side); eq. 9's term where the scene names its Γ_L (one more
/// specular term, and its sum over the SGs off Γ_L's ladder); the sentinel.
pub fn iterations(spheres: usize, sgs: usize, eq9: bool, cut: bool) -> u64 {
    let (ns, ne) = (spheres as u64, sgs as u64);
    // The hierarchy's walk counts its own passes against its budget ([`walk_budget`]),
    // which takes what the rest leaves.
    let gather = if cut { 0 } else { ns + 1 };
    let term = (MAX_PATCHES + 1) + gather + (MAX_PATCHES + 2) + (MAX_PATCHES + 1) + MAX_PATCHES * (MAX_PATCHES + 1);
    let eq9 = if eq9 { term + (ne + 1) } else { 0 };
    (ns + 1) + (ne + 1) + ne * (CLAMPED_COSINE_ITERATIONS + 2 * term) + eq9 + 2
}

/// The export's first texture of family `kind`.
fn texture<'a>(export: &'a VerifiedExport, kind: &str) -> Result<(&'a TextureEntry, &'a Texture), String> {
    let (e, t) = &family_textures(export, kind)?[0];
    Ok((e, t))
}

/// The kernel's functions and body (gpu/shaders/isg.wgsl).
const SHADER: &str = include_str!("../shaders/isg.wgsl");

/// The line of gpu/shaders/isg.wgsl that [`row_test`]'s rows replace.
const ROWS_PLACEHOLDER: &str = "    //#ISG_ROWS\n";

/// One row of the patch grid's cap masks ([`ROWS_PLACEHOLDER`] in gpu/shaders/isg.wgsl, written
/// out for each of the grid's at most [`MAX_PATCHES`] rows: llvmpipe counts the
/// iterations of every loop, so the rows are statements, not a loop): the patch centres
/// of row `i` covered by the current cap, one interval of φ about the cap's azimuth
/// `ph0` (and its turn by 2π: the grid's φ lie in [0, π], the interval's centre in
/// (−π, π]), ORed into `rows[i]`.
fn row_test(i: u64) -> String {
    format!(
        "        if {i}u < k {{
            let r = su * trig[{i}].x;
            let q = cb - uy * trig[{i}].y;
            if r > q {{
                var m = 0xffffffffu;
                if -r < q {{
                    // The covered azimuths lie within al of ph0. With ph0 in [0, π] they
                    // meet the grid's [0, π] in one interval; with ph0 < 0, in [0, π]
                    // minus the gap (ph0 + al, ph0 + 2π − al): one rounding pair either
                    // way.
                    let al = isg_acos_ratio(q, r);
                    let behind = ph0 < 0.0;
                    let c = isg_columns(
                        select(ph0 - al, ph0 + al, behind),
                        select(ph0 + al, ph0 + 2.0 * LF_PI - al, behind),
                        lo, inv, k,
                    );
                    m = select(c, ~c, behind);
                }}
                m &= (1u << k) - 1u;
                rows[{i}] |= m;
                any |= m;
            }}
        }}
"
    )
}

/// The line of the kernel's body that [`EQ9_BLOCK`] replaces where the scene names its
/// map's Γ_L (and nothing replaces elsewhere).
const EQ9_PLACEHOLDER: &str = "    //#ISG_EQ9\n";

/// Eq. 9's specular term, reading Γ_L from `T3` (`lf_prefiltered`: the luminance in w).
const EQ9_BLOCK: &str = "    if x10 > 0.0 && !buried {
        let total_b = lf_sg_integral(lobe);
        if total_b > 0.0 {
            var pre = 0.0;
            if lobe.sharpness >= 1.0 && lobe.sharpness <= 8192.0 {
                pre = lobe.amplitude * lf_prefiltered(T3, lobe.axis, lobe.sharpness).w
                    * lf_sg_sphere_integral(lobe.sharpness);
            } else {
                for (var e = 0u; e < NE; e++) {
                    pre += lf_sg_integral(lf_sg_product(env(e), lobe));
                }
            }
            specular = pre * isg_visible(lobe, total_b, lobe, false, n, p, own) / total_b;
        }
    }
";

/// The kernel's per-product visible integral (the CPU's `visible_with`) and its body;
/// with `eq9`, the specular term by eq. 9 from Γ_L bound as `T3`; with `cut` (the
/// angle, rad, and the tree over the blockers), the blockers found through the tree's
/// cut (`crate::render::tree_inputs` after the SGs).
fn source(
    scene: &lobefit::pipelines::scene::Scene,
    cut: Option<(f64, &SphereTree, u64)>,
) -> Result<(String, String), String> {
    if scene.proxies.is_empty() {
        return Err(format!(
            "scene {}: render isg needs at least one sphere or mesh",
            scene.name
        ));
    }
    // The spheres (centre, radius) and the SGs (axis, sharpness, amplitude) follow the
    // pixels' inputs in the input buffer X (N.x pixels): storage, not constant arrays,
    // which a kernel would index dynamically. The source depends on the counts of
    // spheres and SGs (and whether the scene names a Γ_L) alone, so the frames of an
    // animation share one compiled kernel.
    let (ns, ne) = (scene.proxies.len(), scene.environment.len());
    let eq9 = scene.prefiltered.is_some();
    let (nn, sin_cut, walk) = match cut {
        Some((theta, t, walk)) => {
            // The walk's stack holds at most the tree's depth + 1 entries.
            if t.depth() > STACK - 1 {
                return Err(format!(
                    "scene {}: the sphere hierarchy is {} deep; the kernel's walk holds {}",
                    scene.name,
                    t.depth(),
                    STACK - 1
                ));
            }
            if walk < 1000 {
                return Err(format!(
                    "scene {}: the rest of the kernel's loops leave the hierarchy's walk {walk} of llvmpipe's {} \
                     iterations; use fewer SGs or spheres",
                    scene.name,
                    budget::LOOP_LIMIT
                ));
            }
            (
                t.given().len(),
                theta.clamp(0.0, std::f64::consts::FRAC_PI_2).sin(),
                walk,
            )
        }
        None => (0, 0.0, 0),
    };
    let is_cut = cut.is_some();
    let sin_cut32 = sin_cut as f32;
    let consts = format!(
        "const NS = {ns}u;\nconst NE = {ne}u;\nconst EQ9 = {eq9};\nconst CUT = {is_cut};\nconst NN = {nn}u;\n\
         const SIN_CUT: f32 = {sin_cut32:e};\nconst WALK_BUDGET = {walk}u;\nvar<private> isg_walk = 0u;\n\
         fn node(k: u32, j: u32) -> vec4<f32> {{\n    let i = {INPUTS}u * N.x + 4u * NS + 5u * NE + 16u * k + 4u * j;\n    \
         return vec4<f32>(X[i], X[i + 1u], X[i + 2u], X[i + 3u]);\n}}\n\
         var<private> isg_flag = 0.0;\n\
         fn sph(b: u32) -> vec4<f32> {{\n    let k = {INPUTS}u * N.x + 4u * b;\n    return vec4<f32>(X[k], X[k + 1u], X[k + 2u], X[k + 3u]);\n}}\n\
         fn env(e: u32) -> LfSg {{\n    let k = {INPUTS}u * N.x + 4u * NS + 5u * e;\n    return LfSg(vec3<f32>(X[k], X[k + 1u], X[k + 2u]), X[k + 3u], X[k + 4u]);\n}}\n{}",
        crate::render::own_proxy_wgsl() + crate::render::cut_walk_wgsl(),
    );
    let (functions, body) = split(SHADER);
    if body.matches(EQ9_PLACEHOLDER).count() != 1 {
        return Err(format!("gpu/shaders/isg.wgsl must hold {EQ9_PLACEHOLDER} once"));
    }
    let body = body.replace(EQ9_PLACEHOLDER, if eq9 { EQ9_BLOCK } else { "" })
        + budget::SENTINEL
        + "    Y[o + 1u] = budget_flag;";
    let rows: String = (0..MAX_PATCHES).map(row_test).collect();
    if functions.matches(ROWS_PLACEHOLDER).count() != 1 {
        return Err(format!("gpu/shaders/isg.wgsl must hold {ROWS_PLACEHOLDER} once"));
    }
    Ok((consts + &functions.replace(ROWS_PLACEHOLDER, &rows), body))
}

/// Renders `scene` (a built-in ISG scene or file) at `width` on the GPU and the CPU;
/// writes `out` (PNG, radiance / peak, gamma 1/2.2).
pub fn render_isg(
    gpu: &Gpu,
    export: &VerifiedExport,
    sc: &lobefit::pipelines::scene::Scene,
    width: usize,
    out: &Path,
    opts: Options,
) -> Result<SceneRender, String> {
    let per_vertex = opts.per_vertex;
    // The hierarchy over the blockers, for --cut (its nodes follow the SGs in X).
    let tree = opts.cut.map(|_| sc.proxy_tree());
    let m = &export.manifest;
    let (best_e, best_t) = texture(export, lobefit_tables::isg::KIND_BEST)?;
    let (fit_e, fit_t) = texture(export, lobefit_tables::sg_fit::KIND)?;
    let (best_up, fit_up) = (gpu.upload(best_t, m.storage)?, gpu.upload(fit_t, m.storage)?);
    let (w, h) = crate::render::image_size(width);
    let hits = crate::render::primary_hits(sc, (w, h))?;
    let visible: Vec<&Hit> = hits.iter().flatten().collect();
    // The shaded points: every pixel that sees geometry; per vertex, the pixels on no
    // mesh and every used vertex of the meshes (`isg::vertex`: the area-weighted
    // normal, towards the eye), whose values the mesh pixels then blend.
    let normals: Vec<Vec<lobefit_tables::glam::DVec3>> = if per_vertex {
        sc.meshes.iter().map(|m| vertex::vertex_normals(&m.mesh)).collect()
    } else {
        Vec::new()
    };
    let vertex_hits: Vec<Vec<Option<Hit>>> = (0..normals.len())
        .map(|mi| vertex::vertex_hits(sc, mi, &normals[mi]))
        .collect();
    let points: Vec<&Hit> = visible
        .iter()
        .copied()
        .filter(|h| !per_vertex || h.mesh.is_none())
        .chain(vertex_hits.iter().flatten().flatten())
        .collect();
    let visible = points;
    let (mut inputs, brdfs) = inputs_of(sc, &visible)?;
    if let Some(t) = &tree {
        inputs.extend(crate::render::tree_inputs(t));
    }
    let walk = walk_budget(gpu.loop_budget, sc);
    let (extra, body) = source(sc, opts.cut.zip(tree).map(|(c, t)| (c, t, walk)))?;
    let (best_p, fit_p) = (lf_tex(best_e, Filter::Manual)?, lf_tex(fit_e, Filter::Manual)?);
    let mut types = vec!["texture_2d<f32>", "texture_2d<f32>"];
    let mut textures = vec![(&best_p[..], &best_up), (&fit_p[..], &fit_up)];
    // The scene's Γ_L, in f32 (read by textureLoad, as the CPU's lookup interpolates).
    let gamma = match &sc.prefiltered {
        Some(t) => Some(gpu.upload(&lobefit::pipelines::prefilter::texture(t, "gamma-l")?, Storage::F32)?),
        None => None,
    };
    let none = [0u8; crate::kernel::LF_TEX_SIZE];
    if let Some(g) = &gamma {
        types.push("texture_2d_array<f32>");
        textures.push((&none[..], g));
    }
    let src = kernel_textures(&types, INPUTS, 2, &body) + &extra;
    let t0 = std::time::Instant::now();
    let got = gpu.run_textures(&src, &textures, &inputs, visible.len(), 2)?;
    let mut dispatch_ms = 1e3 * t0.elapsed().as_secs_f64();
    // With --cut, the flat kernel on the same points beside, for its time and the
    // cut's difference (each kernel built before it is timed; medians of 3).
    if let (Some(theta), Some(t)) = (opts.cut, &tree) {
        let (fx, fbody) = source(sc, None)?;
        let flat_src = kernel_textures(&types, INPUTS, 2, &fbody) + &fx;
        let (flat_inputs, _) = inputs_of(sc, &visible)?;
        let flat = gpu.run_textures(&flat_src, &textures, &flat_inputs, visible.len(), 2)?;
        let time = |src: &str, x: &[f32]| -> Result<f64, String> {
            let mut ms = Vec::new();
            for _ in 0..3 {
                let t0 = std::time::Instant::now();
                gpu.run_textures(src, &textures, x, visible.len(), 2)?;
                ms.push(1e3 * t0.elapsed().as_secs_f64());
            }
            ms.sort_by(f64::total_cmp);
            Ok(ms[1])
        };
        let (cut_ms, flat_ms) = (time(&src, &inputs)?, time(&flat_src, &flat_inputs)?);
        let mean = flat.chunks(2).map(|c| f64::from(c[0])).sum::<f64>() / visible.len().max(1) as f64;
        let d: Vec<f64> = got
            .chunks(2)
            .zip(flat.chunks(2))
            .map(|(a, b)| (f64::from(a[0]) - f64::from(b[0])).abs() / mean)
            .collect();
        let rms = (d.iter().map(|x| x * x).sum::<f64>() / d.len().max(1) as f64).sqrt();
        out!(
            "render isg {}: the cut at {:.1}° ({} nodes over {} spheres) {cut_ms:.1} ms, the flat set {flat_ms:.1} ms \
             ({:.2}×; dispatch and read-back, wall clock, medians of 3); the cut's image against the flat one: RMS {rms:.4}, \
             max {:.4} of the flat mean",
            sc.name,
            theta.to_degrees(),
            t.given().len(),
            sc.proxies.len(),
            cut_ms / flat_ms,
            d.iter().copied().fold(0.0, f64::max)
        );
    }
    // Per vertex, the same frame per pixel beside, for the time (the kernel built by
    // now: each dispatch timed warm, the per-vertex one again after it).
    let mut per_pixel_ms = f64::NAN;
    if per_vertex {
        let all: Vec<&Hit> = hits.iter().flatten().collect();
        let (mut pixel_inputs, _) = inputs_of(sc, &all)?;
        if let Some(t) = &tree {
            pixel_inputs.extend(crate::render::tree_inputs(t));
        }
        let t0 = std::time::Instant::now();
        gpu.run_textures(&src, &textures, &pixel_inputs, all.len(), 2)?;
        per_pixel_ms = 1e3 * t0.elapsed().as_secs_f64();
        let t0 = std::time::Instant::now();
        gpu.run_textures(&src, &textures, &inputs, visible.len(), 2)?;
        dispatch_ms = 1e3 * t0.elapsed().as_secs_f64();
    }
    budget::flags("render isg", got.chunks(2).map(|c| c[1]), visible.len(), |f| {
        if f == FLAG_WALK {
            format!(
                "the sphere hierarchy's walk passed its {walk} passes (what the kernel's other loops leave of \
                 llvmpipe's {}): its value would be wrong; use a larger --cut, fewer spheres or fewer SGs",
                budget::LOOP_LIMIT
            )
        } else {
            format!("unknown flag {f}")
        }
    })?;
    // The CPU pipeline (f64, the committed tables) at the same f32 inputs.
    let mut tables = Tables::embedded()?;
    tables.prefiltered = sc.prefiltered.clone();
    let settings = match sc.prefiltered {
        Some(_) => Settings {
            specular: Specular::Eq9Prefiltered,
            ..Settings::default()
        },
        None => Settings::default(),
    };
    let mut cpu = Vec::with_capacity(visible.len());
    for (k, (hit, b)) in visible.iter().zip(&brdfs).enumerate() {
        let v = |i: usize| f64::from(inputs[INPUTS * k + i]);
        let at = Hit {
            x: lobefit_tables::glam::DVec3::new(v(0), v(1), v(2)),
            n: lobefit_tables::glam::DVec3::new(v(3), v(4), v(5)).normalize(),
            wo: lobefit_tables::glam::DVec3::new(v(6), v(7), v(8)).normalize(),
            ..**hit
        };
        // A point buried in a blocker (a mesh's covering sphere) is in its full shadow
        // (`Scene::buried`, the CPU render's rule; the kernel tests the same).
        cpu.push(if sc.buried(&at) {
            0.0
        } else {
            radiance(
                &tables,
                &settings,
                &sc.environment,
                b,
                &match (&tree, opts.cut) {
                    (Some(t), Some(theta)) => Blockers::cut(t, theta, sc.own_proxies(hit)),
                    _ => lobefit::pipelines::isg::render::blockers_of(sc, hit),
                },
                &at,
            )?
        });
    }
    let values: Vec<f32> = got.chunks(2).map(|c| c[0]).collect();
    if !per_vertex {
        return compare_and_write(&values, &cpu, hits.iter().map(Option::is_some), (w, h), out);
    }
    // Per vertex: the pixels off meshes in order, then each mesh's used vertices; the
    // mesh pixels blend their triangle's three (the device's and the CPU's values alike).
    let off_mesh = hits.iter().flatten().filter(|h| h.mesh.is_none()).count();
    out!(
        "render isg {}: per vertex, {} points shaded ({} vertices, {off_mesh} pixels on no mesh) in \
         {dispatch_ms:.1} ms; per pixel {} in {per_pixel_ms:.1} ms (dispatch and read-back, wall clock, the kernel \
         built before either)",
        sc.name,
        visible.len(),
        visible.len() - off_mesh,
        hits.iter().flatten().count()
    );
    let spread = |v: &[f64]| -> Vec<Vec<f64>> {
        let mut k = off_mesh;
        vertex_hits
            .iter()
            .map(|mesh| {
                mesh.iter()
                    .map(|h| {
                        h.map_or(0.0, |_| {
                            k += 1;
                            v[k - 1]
                        })
                    })
                    .collect()
            })
            .collect()
    };
    let image = |v: &[f64]| -> Vec<f64> {
        let at_vertices = spread(v);
        let mut k = 0;
        hits.iter()
            .flatten()
            .map(|h| {
                vertex::blend(sc, &at_vertices, h).unwrap_or_else(|| {
                    k += 1;
                    v[k - 1]
                })
            })
            .collect()
    };
    let device: Vec<f32> = image(&values.iter().map(|&v| f64::from(v)).collect::<Vec<_>>())
        .into_iter()
        .map(|v| v as f32)
        .collect();
    compare_and_write(&device, &image(&cpu), hits.iter().map(Option::is_some), (w, h), out)
}

/// The kernel's inputs at `points` (point, normal, view, k_d, k_s, Phong n, the
/// blockers it lies on or in: `Scene::own_proxies`' first and end, as f32), then the
/// blockers and the SGs; and each point's BRDF.
fn inputs_of(sc: &lobefit::pipelines::scene::Scene, points: &[&Hit]) -> Result<(Vec<f32>, Vec<Phong>), String> {
    let mut inputs = Vec::with_capacity(points.len() * INPUTS);
    let mut brdfs = Vec::with_capacity(points.len());
    for hit in points {
        let b = Phong::of(sc.brdf(hit))?;
        inputs.extend(
            [
                hit.x.x, hit.x.y, hit.x.z, hit.n.x, hit.n.y, hit.n.z, hit.wo.x, hit.wo.y, hit.wo.z,
            ]
            .map(|v| v as f32),
        );
        inputs.extend([b.diffuse as f32, b.specular as f32, b.exponent as f32]);
        inputs.extend(crate::render::own_range(sc, hit));
        brdfs.push(b);
    }
    for s in &sc.proxies {
        inputs.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|v| v as f32));
    }
    for g in &sc.environment {
        inputs.extend([g.axis.x, g.axis.y, g.axis.z, g.sharpness, g.amplitude].map(|v| v as f32));
    }
    Ok((inputs, brdfs))
}

/// `bench`'s kernel: the ISG on `scene`, its image beside the device's Monte Carlo
/// with the ISG hybrid's integrands (the CPU pipeline's: the kernel writes none).
fn bench_kernel(
    gpu: &Gpu,
    ex: Option<&VerifiedExport>,
    scene: &str,
    width: usize,
    png: &Path,
) -> Result<crate::render::Benched, String> {
    let ex = ex.ok_or("bench isg: no export")?;
    let sc = lobefit::pipelines::isg::render::scene(scene)?;
    check_sharpness(&sc)?;
    check_scene(gpu.loop_budget, &sc, "bench isg", false)?;
    let method = format!(
        "ISG best, adaptive patches ({} SGs, {} spheres)",
        sc.environment.len(),
        sc.spheres.len()
    );
    let mut values = Vec::new();
    let timed = crate::bench::timed(gpu, "isg", || {
        let r = render_isg(gpu, ex, &sc, width, png, Options::default())?;
        values = r.values;
        Ok(r.rms)
    })?;
    let image = crate::render::AnalyticImage {
        scene: sc,
        values,
        integrands: Some(|_, _, sc, hits| crate::mc::ControlVariate::isg(sc, hits)),
    };
    Ok(crate::render::Benched {
        method,
        timed,
        image: Some(image),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel parses and validates (naga) with no sphere in its text: the same
    /// source for any scene of the same counts (an animation's frames share it), its
    /// size independent of the spheres (306 here); with a Γ_L, its eq. 9 block; through
    /// the sphere hierarchy's cut, its walk.
    #[test]
    fn the_kernel_validates_and_holds_no_scene_data() {
        let sc = lobefit::pipelines::isg::render::scene("sweep-306").unwrap();
        assert_eq!(sc.proxies.len(), 306);
        let (extra, body) = source(&sc, None).unwrap();
        let src = kernel_textures(&["texture_2d<f32>", "texture_2d<f32>"], INPUTS, 2, &body) + &extra;
        if let Err(e) = lobefit::export::shaders::module_of(&src) {
            panic!("{e}");
        }
        assert!(!extra.contains("vec4<f32>(") || !extra.contains(&format!("{:e}", sc.proxies[0].centre.x as f32)));
        let mut moved = sc.clone();
        for s in &mut moved.proxies {
            s.centre.x += 0.25;
        }
        assert_eq!(source(&moved, None).unwrap(), (extra, body.clone()));
        assert!(!body.contains("lf_prefiltered(T3"), "no Γ_L, no third texture");
        // With a Γ_L (a constant map's): the eq. 9 block reads T3, and validates.
        let map = lobefit::pipelines::envmap::EnvMap::new(8, 4, vec![[1.0, 0.5, 0.25]; 32]).unwrap();
        let (table, _) = lobefit::pipelines::prefilter::build(&map, "flat").unwrap();
        moved.prefiltered = Some(std::sync::Arc::new(table));
        // Through the hierarchy's cut: the walk's constants, and it validates.
        let tree = SphereTree::new(&sc.proxies);
        let (cx, cbody) = source(&sc, Some((10f64.to_radians(), &tree, 50_000))).unwrap();
        assert!(cx.contains("const CUT = true;") && cx.contains(&format!("const NN = {}u;", 2 * 306 - 1)));
        let types2 = ["texture_2d<f32>", "texture_2d<f32>"];
        if let Err(e) = lobefit::export::shaders::module_of(&(kernel_textures(&types2, INPUTS, 2, &cbody) + &cx)) {
            panic!("{e}");
        }
        // A walk the rest of the loops leave almost nothing of is refused.
        assert!(source(&sc, Some((0.1, &tree, 10)))
            .unwrap_err()
            .contains("hierarchy's walk"));
        let (extra, body) = source(&moved, None).unwrap();
        assert!(body.contains("lf_prefiltered(T3"), "{body}");
        let types = ["texture_2d<f32>", "texture_2d<f32>", "texture_2d_array<f32>"];
        let src = kernel_textures(&types, INPUTS, 2, &body) + &extra;
        if let Err(e) = lobefit::export::shaders::module_of(&src) {
            panic!("{e}");
        }
    }
}
