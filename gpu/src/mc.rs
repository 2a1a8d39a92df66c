//! `lobefit-gpu mc`: Monte Carlo kernels on the device for every pipeline's scenes —
//! spheres, a height field and meshes' triangles under an SG environment (Lambert and
//! Phong: the ISG and SH-exponentiation scenes; gpu/shaders/mc.wgsl) or under one
//! spherical light (Lambert and Lafortune: Meunier's; gpu/shaders/mc_light.wgsl) —
//! the baseline a renderer engineer compares the analytic kernels with: per pixel, N
//! samples of the CPU's estimators (`lobefit::pipelines::sky`, the Meunier
//! reference) with exact visibility through the CPU's own hierarchies.
//!
//! Estimators ([`Estimator`]): `plain` (the CPU's `reference`: SGs picked by their
//! integral; uniform in the light's cap) and `cv-mis` (the CPU's `reference_cv` with
//! `Select::Contribution`: the unoccluded diffuse radiance in closed form as a control
//! variate, SGs picked by their contribution at the point), both with independent
//! random numbers (a PCG hash per pixel, batch, sample and dimension); `qmc` and
//! `qmc-cv-mis` draw them as Owen-scrambled Sobol points (the CPU's strongest
//! estimators); `hybrid` takes the SH-exponentiation kernel's integrand as its
//! control variate (the CPU's `reference_hybrid`).
//!
//! llvmpipe ends an invocation's loops after 65 535 iterations (`crate::budget`): the
//! samples run in batches of a power of two that fits, one dispatch each, their sums
//! added on the host in f64.

use std::io::Write as _;
use std::process::ExitCode;

use lobefit::export::Storage;
use lobefit::pipelines::estimate::Estimate;
use lobefit::pipelines::scene::{Hit, Scene};
use lobefit::pipelines::sky::{reference, reference_cv, reference_hybrid, Phong, Select};
use lobefit_tables::glam::DVec3;

use crate::budget;
use crate::conformance::dummy_texture;
use crate::device::Gpu;
use crate::kernel::{kernel, split, LF_TEX_SIZE};

/// The kernel's functions and body.
const SHADER: &str = include_str!("../shaders/mc.wgsl");
/// The light kernel's (Meunier's scenes: one spherical light).
const SHADER_LIGHT: &str = include_str!("../shaders/mc_light.wgsl");
/// The light kernel's Lafortune lobes per pixel, at most.
const MAX_LOBES: usize = 2;

/// Inputs per pixel: point, normal, view, k_d, k_s, Phong n, own sphere (−1: none),
/// own mesh and triangle (−1: none).
const N_IN: usize = 15;
/// Outputs per pixel: Σ f, Σ f², the closed form, the budget flag.
const N_OUT: usize = 4;
/// Most samples one dispatch takes (a power of two).
const MAX_BATCH: usize = 1024;

/// A device estimator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Estimator {
    /// One-sample MIS of the cosine, the Phong lobe and the SGs (by their integral);
    /// under a spherical light, directions uniform in its cap. Independent uniforms.
    Plain,
    /// The unoccluded diffuse radiance in closed form as a control variate; the SGs
    /// picked by their contribution at the point. Independent uniforms.
    CvMis,
    /// `plain` on Owen-scrambled Sobol points.
    Qmc,
    /// `cv-mis` on Owen-scrambled Sobol points (the CPU's strongest under a sky).
    QmcCvMis,
    /// The SH-exponentiation pipeline as the control variate (the CPU's `hybrid`):
    /// its radiance in closed form plus Monte Carlo of what it misses,
    /// (f − L a)/pdf with a its integrand ([`ShIntegrand`]: the device's SH-exp kernel
    /// writes it); one-sample MIS of the cosine, the Phong lobe, the SGs (by their
    /// integral) and the uniform sphere (a lives below the horizon too), on
    /// Owen-scrambled Sobol points. Scenes under an SG sky.
    Hybrid,
    /// The same with the ISG pipeline's integrand (packed by
    /// `isg::shade::Integrand::pack`, built by the CPU pipeline: the device's ISG
    /// kernel does not write it), a(ω) the shading itself: (f − a)/pdf.
    HybridIsg,
}

/// The hybrid's control variate at each pixel.
pub enum ControlVariate {
    /// The SH-exponentiation pipeline's integrands ([`ShIntegrand`]).
    Sh(Vec<ShIntegrand>),
    /// The ISG pipeline's integrands, each as `isg::shade::Integrand::pack`'s record.
    Isg(Vec<Vec<f32>>),
}

impl ControlVariate {
    /// The ISG pipeline's integrands at `hits` (default settings), built by the CPU.
    pub fn isg(sc: &Scene, hits: &[&Hit]) -> Result<ControlVariate, String> {
        let t = lobefit::pipelines::isg::shade::Tables::embedded().map_err(|e| e.to_string())?;
        let s = lobefit::pipelines::isg::shade::Settings::default();
        hits.iter()
            .map(|h| {
                let b = Phong::of(sc.brdf(h))?;
                let blockers = lobefit::pipelines::isg::render::blockers_of(sc, h);
                let a = lobefit::pipelines::isg::shade::integrand(&t, &s, &sc.environment, &b, &blockers, h)?;
                Ok(a.pack().into_iter().map(|v| v as f32).collect())
            })
            .collect::<Result<_, String>>()
            .map(ControlVariate::Isg)
    }

    fn len(&self) -> usize {
        match self {
            ControlVariate::Sh(v) => v.len(),
            ControlVariate::Isg(v) => v.len(),
        }
    }

    /// The estimator that takes it.
    fn estimator(&self) -> Estimator {
        match self {
            ControlVariate::Sh(_) => Estimator::Hybrid,
            ControlVariate::Isg(_) => Estimator::HybridIsg,
        }
    }

    /// Loop iterations of one evaluation of a(ω) at most: the ISG record's entries
    /// and its two loops' exits (the SH's are counted in [`iterations`]).
    fn loops(&self) -> u64 {
        match self {
            ControlVariate::Sh(_) => 0,
            ControlVariate::Isg(v) => v.iter().map(|p| (p[4] + p[5]) as u64 + 2).max().unwrap_or(0),
        }
    }
}

pub use crate::shexp::ShIntegrand;

impl Estimator {
    fn cv(self) -> bool {
        matches!(self, Estimator::CvMis | Estimator::QmcCvMis)
    }
    fn qmc(self) -> bool {
        matches!(
            self,
            Estimator::Qmc | Estimator::QmcCvMis | Estimator::Hybrid | Estimator::HybridIsg
        )
    }
    fn hybrid(self) -> bool {
        matches!(self, Estimator::Hybrid | Estimator::HybridIsg)
    }
    /// The name the reports use.
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Plain => "plain",
            Estimator::CvMis => "cv-mis",
            Estimator::Qmc => "qmc",
            Estimator::QmcCvMis => "qmc-cv-mis",
            Estimator::Hybrid => "hybrid",
            Estimator::HybridIsg => "hybrid-isg",
        }
    }
    /// The same estimator on independent uniforms (what the CPU side of an agreement
    /// draws: its standard errors are then true ones; [`cpu_estimate`] draws the
    /// hybrid's so).
    fn random(self) -> Estimator {
        match self {
            Estimator::Qmc => Estimator::Plain,
            Estimator::QmcCvMis => Estimator::CvMis,
            e => e,
        }
    }
}

/// Direction numbers of the first 4 Sobol dimensions (Joe and Kuo's: x; x + 1 with
/// m = 1; x² + x + 1 with m = 1, 3; x³ + x + 1 with m = 1, 3, 1), 32 bits each:
/// `[dim · 32 + bit]`, the bit-`bit` index's contribution.
fn sobol_directions() -> [u32; 128] {
    // (degree s, coefficients a, initial m_1..m_s) of dimensions 1..3.
    const DIMS: [(usize, u32, &[u32]); 3] = [(1, 0, &[1]), (2, 1, &[1, 3]), (3, 1, &[1, 3, 1])];
    let mut out = [0u32; 128];
    for (k, o) in out.iter_mut().take(32).enumerate() {
        *o = 1 << (31 - k);
    }
    for (d, &(s, a, m)) in DIMS.iter().enumerate() {
        let v = &mut out[32 * (d + 1)..32 * (d + 2)];
        for k in 0..32 {
            v[k] = if k < s {
                m[k] << (31 - k)
            } else {
                let mut x = v[k - s] ^ (v[k - s] >> s);
                for j in 1..s {
                    if (a >> (s - 1 - j)) & 1 == 1 {
                        x ^= v[k - j];
                    }
                }
                x
            };
        }
    }
    out
}

/// The direction numbers as the kernels read them (`mc_direction`): each as two 16-bit
/// halves, exact in f32; they end the input buffer, at `SOBOL0`.
fn direction_inputs() -> Vec<f32> {
    sobol_directions()
        .iter()
        .flat_map(|&d| [(d & 0xffff) as f32, (d >> 16) as f32])
        .collect()
}

/// The scene's sphere hierarchy ([`Scene::bvh`]) as the kernels read it (mc_blocked):
/// per node its box, widened by 10⁻⁵ of the scene's scale on every side (more than
/// f32 rounding moves a box or a sphere, so the f32 test culls no sphere the f32
/// sphere test would hit), the first index and the count; then the leaves' sphere
/// indices.
fn bvh_inputs(sc: &Scene) -> Vec<f32> {
    let bvh = sc.bvh();
    let scale = bvh.nodes().first().map_or(1.0, |n| {
        (n.hi - n.lo)
            .max_element()
            .max(n.lo.abs().max(n.hi.abs()).max_element())
    });
    let pad = 1e-5 * scale;
    let mut v = Vec::with_capacity(8 * bvh.nodes().len() + bvh.order().len());
    for n in bvh.nodes() {
        let (lo, hi) = (n.lo - pad, n.hi + pad);
        v.extend([lo.x, lo.y, lo.z, hi.x, hi.y, hi.z, n.first as f64, n.count as f64].map(|x| x as f32));
    }
    v.extend(bvh.order().iter().map(|&i| i as f32));
    v
}

/// The hierarchy's constants: its node count, the traversal's stack and the length
/// of its sphere indices.
fn bvh_consts(sc: &Scene) -> String {
    let bvh = sc.bvh();
    format!(
        "const NODES = {}u;\nconst STACK = {}u;\nconst NORDER = {}u;\n",
        bvh.nodes().len(),
        bvh.depth() + 1,
        bvh.order().len()
    )
}

/// Most samples a side of a height field the kernel takes: its offsets in the input
/// buffer are f32, exact below 2^24, and a node's cell indices are packed in 14 bits.
const HF_MAX_N: usize = 2049;

/// Where shadow rays leave a point for the height field, in units of its extent: the
/// CPU's `TERRAIN_T_MIN` (1e-9) is below f32 rounding of a point on the terrain
/// (≈ 1e-7 of the extent), which would shadow itself; 1e-4 skips that, missing only
/// hits closer than 1e-4 of the extent (a 40th of a cell of the 256² built-in terrain).
const HF_T_MIN: f64 = 1e-4;

/// The height field's quadtree levels (1 … L) and samples a side, if the scene has one.
fn hf_shape(sc: &Scene) -> Option<(usize, usize)> {
    sc.heightfield.as_ref().map(|(hf, _)| (hf.quadtree().len(), hf.n()))
}

/// The height field's constants (mc_terrain): HF, the samples a side HF_N, the
/// quadtree's top level HF_L, the grid's half extent and spacing, the shadow rays'
/// start HF_TMIN, the height ranges' widening HF_ZPAD (past f32 rounding of the ray's
/// heights) and the traversal's stack (3 children pending a level, and the root).
/// Inert values without a height field.
fn hf_consts(sc: &Scene) -> String {
    let f = |v: f64| format!("{:?}", v as f32);
    match &sc.heightfield {
        Some((hf, _)) => {
            let l = hf.quadtree().len();
            let scale = hf.extent() + hf.max_height().abs().max(hf.min_height().abs());
            format!(
                "const HF = true;\nconst HF_N = {}u;\nconst HF_L = {l}u;\nconst HF_HALF = {};\n\
                 const HF_SP = {};\nconst HF_TMIN = {};\nconst HF_ZPAD = {};\nconst HF_STACK = {}u;\n",
                hf.n(),
                f(0.5 * hf.extent()),
                f(hf.extent() / (hf.n() - 1) as f64),
                f(HF_T_MIN * hf.extent()),
                f(1e-5 * scale),
                3 * l + 1
            )
        }
        None => "const HF = false;\nconst HF_N = 2u;\nconst HF_L = 0u;\nconst HF_HALF = 1.0;\n\
                 const HF_SP = 1.0;\nconst HF_TMIN = 0.0;\nconst HF_ZPAD = 0.0;\nconst HF_STACK = 1u;\n"
            .to_string(),
    }
}

/// The height field as mc_terrain reads it, at HF0: 16 words whose first L are the
/// offsets (from HF0) of quadtree levels 1 … L, the heights (row-major, n²) from
/// HF0 + 16, then each level's [min, max] pairs. f32 rounding is monotone, so the
/// levels' ranges are exactly the ranges of the f32 heights below them. Empty without
/// a height field.
fn hf_inputs(sc: &Scene) -> Vec<f32> {
    let Some((hf, _)) = &sc.heightfield else {
        return Vec::new();
    };
    let mut v = vec![0.0f32; 16];
    v.extend(hf.heights().iter().map(|&h| h as f32));
    for (l, level) in hf.quadtree().iter().enumerate() {
        v[l] = v.len() as f32;
        v.extend(level.iter().flat_map(|r| [r[0] as f32, r[1] as f32]));
    }
    v
}

/// Where a mesh's shadow rays start on the device, in units of its diagonal: the
/// CPU's `MESH_T_MIN` (1e-9) is below f32 rounding of a point on the mesh, as
/// [`HF_T_MIN`] says of the terrain.
const MESH_T_MIN: f64 = 1e-4;

/// The meshes' constants (mc_meshes): their count NM, their nodes in all MNODES, the
/// traversal's stack MSTACK (the deepest hierarchy + 1), and the height field's
/// words before them, HF_LEN.
fn mesh_consts(sc: &Scene) -> String {
    let nodes: usize = sc.meshes.iter().map(|m| m.mesh.hierarchy().count()).sum();
    let depth = sc.meshes.iter().map(|m| m.mesh.depth()).max().unwrap_or(0);
    let (w, h) = sc
        .environment_map
        .as_ref()
        .map_or((1, 1), |m| (m.map.width, m.map.height));
    format!(
        "const HF_LEN = {}u;\nconst NM = {}u;\nconst MNODES = {nodes}u;\nconst MSTACK = {}u;\nconst MESH_LEN = {}u;\n\
         const MAP = {};\nconst MAP_W = {w}u;\nconst MAP_H = {h}u;\n",
        hf_inputs(sc).len(),
        sc.meshes.len(),
        depth + 1,
        mesh_inputs(sc).len(),
        sc.environment_map.is_some()
    )
}

/// A map's texels as the sky kernel reads them (after the meshes, `MAP0`): each
/// texel's luminance, then the running sums of luminance × solid angle over the
/// row-major texels divided by their total, the last exactly 1. The kernel draws a
/// texel by a binary search of the sums and takes the difference of two neighbours as
/// its probability, so the density it divides by is the one it samples (f32 sums and
/// all); the CPU's `LightMap::sample` draws the same way in f64. Empty without a map.
fn map_inputs(sc: &Scene) -> Vec<f32> {
    let Some(m) = &sc.environment_map else {
        return Vec::new();
    };
    let sums = m.running_sums();
    let total = m.total();
    let mut v: Vec<f32> = m.texel_luminance().iter().map(|&l| l as f32).collect();
    v.extend(sums.iter().map(|&c| (c / total) as f32));
    if let Some(last) = v.last_mut() {
        *last = 1.0;
    }
    v
}

/// Loop iterations of one draw from a map (the binary search of its sums: ⌈log₂ N⌉
/// passes and its exit), 0 without a map.
fn map_iterations(sc: &Scene) -> u64 {
    sc.environment_map.as_ref().map_or(0, |m| {
        let n = (m.map.width * m.map.height) as u64;
        u64::from(64 - (n - 1).leading_zeros()) + 1
    })
}

/// The SGs the sky kernel shades: the scene's, or none under a map (its light is the
/// map's texels; the lobes fitted to it are the pipelines').
fn kernel_sgs(sc: &Scene) -> &[lobefit_tables::Sg] {
    if sc.environment_map.is_some() {
        &[]
    } else {
        &sc.environment
    }
}

/// The meshes as mc_meshes reads them: per mesh its root node and its shadow rays'
/// start ([`MESH_T_MIN`] × its diagonal); every mesh's hierarchy in one list of nodes
/// (box widened by 10⁻⁵ of the mesh's scale, as [`bvh_inputs`]; first child or first
/// triangle record, count), indices made global; the triangle records in the leaves'
/// order (3 corners, the mesh, the triangle's index). Empty without meshes.
fn mesh_inputs(sc: &Scene) -> Vec<f32> {
    let mut head = Vec::new();
    let mut nodes = Vec::new();
    let mut tris = Vec::new();
    let (mut node0, mut tri0) = (0usize, 0usize);
    for (mi, m) in sc.meshes.iter().enumerate() {
        let (lo, hi) = m.mesh.bounds();
        let diagonal = (hi - lo).length();
        let scale = (hi - lo).max_element().max(lo.abs().max(hi.abs()).max_element());
        let pad = 1e-5 * scale;
        head.extend([node0 as f32, (MESH_T_MIN * diagonal) as f32]);
        let mut count = 0;
        for (lo, hi, first, n) in m.mesh.hierarchy() {
            let first = if n == 0 { node0 + first } else { tri0 + first };
            let (lo, hi) = (lo - pad, hi + pad);
            nodes.extend([lo.x, lo.y, lo.z, hi.x, hi.y, hi.z, first as f64, n as f64].map(|x| x as f32));
            count += 1;
        }
        node0 += count;
        for &k in m.mesh.order() {
            let [a, b, c] = m.mesh.corners(k as usize);
            tris.extend([a.x, a.y, a.z, b.x, b.y, b.z, c.x, c.y, c.z, mi as f64, f64::from(k)].map(|x| x as f32));
        }
        tri0 += m.mesh.order().len();
    }
    head.extend(nodes);
    head.extend(tris);
    head
}

/// Loop iterations of one ray against the meshes at most (mc_meshes): every node and
/// every triangle of every mesh, and the loop over the meshes.
fn mesh_iterations(sc: &Scene) -> u64 {
    sc.meshes
        .iter()
        .map(|m| (m.mesh.hierarchy().count() + m.mesh.order().len()) as u64 + 1)
        .sum()
}

/// Loop iterations of one terrain ray at most (mc_terrain): every node the ray's span
/// can meet, 4·side + 4 a level (a line crosses at most 2·side cells of a side × side
/// grid, twice that when it runs along grid lines and through corners, which closed
/// spans count on both sides), each internal one with its 4 children; 0 without a
/// height field.
fn hf_iterations(sc: &Scene) -> u64 {
    let Some((levels, n)) = hf_shape(sc) else {
        return 0;
    };
    let m = n as u64 - 1;
    (0..=levels as u32)
        .map(|l| {
            let side = (m + (1 << l) - 1) >> l;
            (4 * side + 4) * if l == 0 { 1 } else { 5 }
        })
        .sum()
}

/// Where the kernels' data lie in X (private variables, set by [`LAYOUT`] at the
/// start of the body): after the pixels' inputs, the batch index (`BATCH`), the
/// samples a dispatch (`SPP`), the spheres (`SPH0`), the SGs (`ENV0`, sky kernel
/// only), the direction numbers (`SOBOL0`), the hierarchy's nodes (`NODE0`) and its
/// sphere indices (`ORDER0`), then the height field (`HF0`) and the meshes (`MESH0`,
/// `MNODE0`, `MTRI0`: [`LAYOUT_SKY`]), sky kernel only. Data, not constants: one compiled kernel serves every
/// pixel count and sample count of a scene (a bench's ladder of 1 … 256 samples
/// compiled a kernel per rung).
const OFFSETS: &str = "var<private> BATCH: u32;\nvar<private> SPP: u32;\nvar<private> SPH0: u32;\n\
                       var<private> ENV0: u32;\nvar<private> SOBOL0: u32;\nvar<private> NODE0: u32;\n\
                       var<private> ORDER0: u32;\nvar<private> HF0: u32;\nvar<private> MESH0: u32;\n\
                       var<private> MNODE0: u32;\nvar<private> MTRI0: u32;\nvar<private> MAP0: u32;\n\
                       fn sph(b: u32) -> vec4<f32> {\n    let k = SPH0 + 4u * b;\n    \
                       return vec4<f32>(X[k], X[k + 1u], X[k + 2u], X[k + 3u]);\n}\n";

/// The body's first statements: [`OFFSETS`] from the pixel count N.x and the scene's
/// constants (N_IN, NS, NE, NODES, SOBOL_LEN).
const LAYOUT: &str = "    BATCH = N_IN * N.x;
    SPP = u32(X[BATCH + 1u]);
    SPH0 = BATCH + 2u;
    ENV0 = SPH0 + 4u * NS;
    SOBOL0 = ENV0 + 5u * NE + SHN;
    NODE0 = SOBOL0 + SOBOL_LEN;
    ORDER0 = NODE0 + 8u * NODES;
    HF0 = ORDER0 + NORDER;
";

/// The sky kernel's further statements after [`LAYOUT`]: where the meshes lie, after
/// the height field's HF_LEN words.
const LAYOUT_SKY: &str = "    MESH0 = HF0 + HF_LEN;
    MNODE0 = MESH0 + 2u * NM;
    MTRI0 = MNODE0 + 8u * MNODES;
    MAP0 = MESH0 + MESH_LEN;
";

/// Loop iterations of one pixel before its samples (the SG weights, with the control
/// variate each SG's clamped cosine twice) and of each sample (the SG pick, the
/// mixture's density and the light, the hierarchy: at most every node and every
/// sphere; `traced`: the height field's and the meshes' traversals, [`hf_iterations`]
/// and [`mesh_iterations`]), every loop counted.
fn iterations(spheres: usize, sgs: usize, traced: u64, est: Estimator, cv_loops: u64) -> (u64, u64) {
    let (ns, ne) = (spheres as u64 + nodes(spheres), sgs as u64);
    let cc = if est.cv() {
        crate::isg::CLAMPED_COSINE_ITERATIONS
    } else {
        0
    };
    // The SH hybrid: its 16 coefficients read once; per sample the order-4 SH basis
    // (`lf_sh_basis`: 4 + 10 loop passes and 20 of K_l^m's) and the dot product. The
    // ISG hybrid: per sample its record's loops (`cv_loops`).
    let (hyb_setup, hyb) = match est {
        Estimator::Hybrid => (17, 4 + 10 + 20 + 17),
        Estimator::HybridIsg => (0, cv_loops),
        _ => (0, 0),
    };
    let setup = (ne + 1) * (1 + cc) + if est.cv() { (ne + 1) * (1 + cc) } else { 0 } + 2 + hyb_setup;
    (setup, 1 + point_iterations(est) + ne + (ne + 1) + ns + traced + hyb)
}

/// The hierarchy's node count at most for `spheres` spheres (leaves of one to
/// `Bvh::LEAF` spheres: fewer than 2 · spheres nodes).
fn nodes(spheres: usize) -> u64 {
    2 * spheres as u64
}

/// Loop iterations of one sample's uniforms (`mc_point`): with QMC one loop over the
/// index's 32 bits at most.
fn point_iterations(est: Estimator) -> u64 {
    if est.qmc() {
        33
    } else {
        0
    }
}

/// Samples per dispatch: the largest power of two ≤ [`MAX_BATCH`] within llvmpipe's
/// loop budget, or an error naming the scene's size.
fn batch_size(spheres: usize, sgs: usize, traced: u64, est: Estimator, cv_loops: u64) -> Result<usize, String> {
    let (setup, per) = iterations(spheres, sgs, traced, est, cv_loops);
    let fit = budget::LOOP_LIMIT.saturating_sub(setup) / per;
    if fit == 0 {
        return Err(format!(
            "mc: one sample needs {per} loop iterations after {setup} of setup ({spheres} spheres, {sgs} SGs): \
             over llvmpipe's {} per invocation",
            budget::LOOP_LIMIT
        ));
    }
    let m = fit.min(MAX_BATCH as u64);
    Ok(1 << (63 - m.leading_zeros()))
}

/// Loop iterations of one evaluation of an SH environment of order `n` (0: none):
/// `lf_sh_basis` (n passes over m, n(n + 1)/2 over l, Σ_l l(l + 1) of K_l^m's) and the
/// sum over its n² coefficients, each loop's exit too.
fn sh_loops(n: usize) -> u64 {
    let n = n as u64;
    if n == 0 {
        return 0;
    }
    n + 1 + n * (n + 1) / 2 + n + (0..n).map(|l| l * (l + 1) + l + 1).sum::<u64>() + n * n + 1
}

/// The SH environment's order (0: none).
fn sh_order(sc: &Scene) -> usize {
    sc.sh_environment
        .as_ref()
        .map_or(0, |c| (c.len() as f64).sqrt().round() as usize)
}

/// Whether `sc` is a light scene (Meunier's: one spherical light, no distant light).
fn light_scene(sc: &Scene) -> bool {
    sc.environment.is_empty() && sc.sh_environment.is_none() && !sc.lights.is_empty()
}

/// Refuses a scene the kernels do not trace: no light, more than one spherical light,
/// a height field of more than [`HF_MAX_N`] samples a side.
pub fn supported(sc: &Scene) -> Result<(), String> {
    let why = if hf_shape(sc).is_some_and(|(_, n)| n > HF_MAX_N) {
        Some("a height field of more than 2049 samples a side")
    } else if light_scene(sc) && sc.lights.len() > 1 {
        Some("more than one spherical light")
    } else if sc.environment.is_empty() && sc.sh_environment.is_none() && !light_scene(sc) {
        Some("neither a distant light nor a spherical light")
    } else {
        None
    };
    match why {
        Some(w) => Err(format!(
            "mc: scene {} has {w}; the device's Monte Carlo traces spheres, a height field and meshes under \
             an SG sky, an SH sky, a map or one spherical light",
            sc.name
        )),
        None => Ok(()),
    }
}

/// The sky kernel for `sc` with estimator `est`: the pixel and sample counts are data
/// ([`OFFSETS`]).
fn source(sc: &Scene, est: Estimator) -> String {
    let cv = est.cv();
    let hyb = est.hybrid();
    let hyb_isg = est == Estimator::HybridIsg;
    let n_in = sky_inputs_per_pixel(est);
    let (ns, ne) = (sc.spheres.len(), kernel_sgs(sc).len());
    let sho = sh_order(sc);
    let consts = format!(
        "const N_IN = {n_in}u;\nconst NS = {ns}u;\nconst NE = {ne}u;\nconst NE_ARR = {}u;\nconst SHO = {sho}u;\nconst SHN = {}u;\n\
         const CV = {cv};\nconst HYB = {hyb};\nconst HYB_ISG = {hyb_isg};\n\
         const QMC = {};\n\
         const SOBOL_LEN = {}u;\n{OFFSETS}\
         fn env(e: u32) -> LfSg {{\n    let k = ENV0 + 5u * e;\n    return LfSg(vec3<f32>(X[k], X[k + 1u], X[k + 2u]), X[k + 3u], X[k + 4u]);\n}}\n{}{}",
        ne.max(1),
        sho * sho,
        est.qmc(),
        direction_inputs().len(),
        bvh_consts(sc),
        hf_consts(sc) + &mesh_consts(sc)
    );
    let (functions, body) = split(SHADER);
    let body = LAYOUT.to_string() + LAYOUT_SKY + body + budget::SENTINEL + "    Y[o + 3u] = budget_flag;";
    kernel("texture_2d<f32>", n_in, N_OUT, &body) + &consts + functions
}

/// The sky kernel's inputs per pixel: [`N_IN`], and after them the SH hybrid's
/// integrand, or where the ISG hybrid's record lies in the buffer.
fn sky_inputs_per_pixel(est: Estimator) -> usize {
    N_IN + match est {
        Estimator::Hybrid => 17,
        Estimator::HybridIsg => 1,
        _ => 0,
    }
}

/// Per pixel of `hits`: the estimate at `spp` samples (rounded up to whole batches)
/// and its standard error, as [`Estimate`]s; and the samples taken per pixel. A light
/// scene takes `plain` and `qmc` only (its CPU reference's estimator: uniform in the
/// light's cap). The hybrid takes the pipeline's integrand at each hit (`cv`; the
/// others none).
pub fn estimate(
    gpu: &Gpu,
    sc: &Scene,
    hits: &[&Hit],
    spp: usize,
    est: Estimator,
    cv: Option<&ControlVariate>,
) -> Result<(Vec<Estimate>, usize), String> {
    supported(sc)?;
    if hits.is_empty() || spp == 0 {
        return Err("mc: no pixel or no sample".into());
    }
    let light = light_scene(sc);
    check_estimator(sc, est, cv.map(|c| (c.estimator(), c.len())), hits.len())?;
    let (mut inputs, slot, per_batch, src) = if light {
        let (inputs, n_in, nl) = light_inputs(sc, hits)?;
        let traced = hf_iterations(sc) + mesh_iterations(sc);
        let per = batch_size_light(sc.spheres.len(), nl, traced, est)?;
        (inputs, n_in * hits.len(), per, source_light(sc, n_in, nl, est.qmc()))
    } else {
        let traced = hf_iterations(sc) + mesh_iterations(sc) + sh_loops(sh_order(sc)) + map_iterations(sc);
        let cv_loops = cv.map_or(0, ControlVariate::loops);
        let per = batch_size(sc.spheres.len(), kernel_sgs(sc).len(), traced, est, cv_loops)?;
        (
            sky_inputs(sc, hits, cv)?,
            sky_inputs_per_pixel(est) * hits.len(),
            per,
            source(sc, est),
        )
    };
    let batch = per_batch.min(spp.next_power_of_two());
    // The samples a dispatch, after the batch index (the kernels' SPP).
    inputs[slot + 1] = batch as f32;
    run_batches(gpu, &src, inputs, slot, hits.len(), spp.div_ceil(batch), batch)
}

/// Refuses an estimator `sc` does not take (a spherical light takes `plain` and
/// `qmc`), and control variates (`cv`: the estimator that takes them, their count)
/// that are not one per pixel of the hybrid's kind, or not none for the others.
fn check_estimator(sc: &Scene, est: Estimator, cv: Option<(Estimator, usize)>, pixels: usize) -> Result<(), String> {
    if light_scene(sc) && (est.cv() || est.hybrid()) {
        return Err(format!(
            "mc: scene {} has a spherical light: plain or qmc only",
            sc.name
        ));
    }
    if sc.environment_map.is_some() && (est.cv() || est.hybrid()) {
        return Err(format!(
            "mc: scene {} is lit by a map: plain or qmc only (the control variates are the fitted lobes', whose \
             residual against the map's texels is a spike of both signs: docs/environment.md)",
            sc.name
        ));
    }
    if sc.sh_environment.is_some() && (est.cv() || est.hybrid()) {
        return Err(format!(
            "mc: scene {} has an SH environment (its control variates are the SGs' closed forms): plain or qmc only",
            sc.name
        ));
    }
    match (est.hybrid(), cv) {
        (true, Some((e, n))) if e == est && n == pixels => Ok(()),
        (true, Some((e, _))) if e != est => Err(format!("mc: {} takes no integrands of {}", est.name(), e.name())),
        (true, Some((_, n))) => Err(format!("mc: {n} integrands for {pixels} pixels")),
        (true, None) => Err("mc: the hybrid estimator needs the pipeline's integrand at each pixel".into()),
        (false, Some(_)) => Err(format!("mc: {} takes no integrand", est.name())),
        (false, None) => Ok(()),
    }
}

/// The sky kernel's inputs: per pixel point, normal, view, k_d, k_s, Phong n, own
/// sphere, own mesh and triangle, and the hybrid's integrand (`cv`); the batch slot
/// and the samples a dispatch; the spheres; the SGs; the direction numbers; the
/// hierarchy; the height field; the meshes.
fn sky_inputs(sc: &Scene, hits: &[&Hit], cv: Option<&ControlVariate>) -> Result<Vec<f32>, String> {
    let mut inputs = Vec::with_capacity(hits.len() * (N_IN + 17) + 1 + 4 * sc.spheres.len() + 5 * sc.environment.len());
    for (p, hit) in hits.iter().enumerate() {
        let b = Phong::of(sc.brdf(hit))?;
        inputs.extend(
            [
                hit.x.x, hit.x.y, hit.x.z, hit.n.x, hit.n.y, hit.n.z, hit.wo.x, hit.wo.y, hit.wo.z,
            ]
            .map(|v| v as f32),
        );
        inputs.extend([b.diffuse, b.specular, b.exponent].map(|v| v as f32));
        inputs.push(hit.sphere.map_or(-1.0, |i| i as f32));
        let (mesh, tri) = hit.mesh.map_or((-1.0, -1.0), |(m, k)| (m as f32, k as f32));
        inputs.extend([mesh, tri]);
        let record: &[f32] = match cv {
            Some(ControlVariate::Sh(c)) => &c[p],
            Some(ControlVariate::Isg(c)) => &c[p],
            None => &[],
        };
        if let Some(bad) = record.iter().find(|v| !v.is_finite()) {
            return Err(format!("mc: the integrand at pixel {p} is not finite ({bad})"));
        }
        match cv {
            Some(ControlVariate::Sh(c)) => inputs.extend(c[p]),
            // Where its record lies: filled in below.
            Some(ControlVariate::Isg(_)) => inputs.push(0.0),
            None => {}
        }
    }
    inputs.extend([0.0, 0.0]);
    for s in &sc.spheres {
        inputs.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|v| v as f32));
    }
    for g in kernel_sgs(sc) {
        inputs.extend([g.axis.x, g.axis.y, g.axis.z, g.sharpness, g.amplitude].map(|v| v as f32));
    }
    inputs.extend(sc.sh_environment.iter().flatten().map(|&v| v as f32));
    inputs.extend(direction_inputs());
    inputs.extend(bvh_inputs(sc));
    inputs.extend(hf_inputs(sc));
    inputs.extend(mesh_inputs(sc));
    inputs.extend(map_inputs(sc));
    // The ISG hybrid's records after everything else, each pixel's start in its
    // inputs (an f32 index: exact below 2^24).
    if let Some(ControlVariate::Isg(c)) = cv {
        let n_in = sky_inputs_per_pixel(Estimator::HybridIsg);
        for (p, record) in c.iter().enumerate() {
            let at = inputs.len();
            if at + record.len() >= 1 << 24 {
                return Err(format!(
                    "mc: the ISG integrands pass 2^24 words at pixel {p} (fewer pixels a call)"
                ));
            }
            inputs[p * n_in + N_IN] = at as f32;
            inputs.extend(record);
        }
    }
    Ok(inputs)
}

/// The light kernel's inputs (see gpu/shaders/mc_light.wgsl): per pixel point, normal,
/// k_d/π, own sphere, own mesh and triangle, and `nl` Lafortune lobes (q, ρ, n); the
/// batch slot and the samples a dispatch; the spheres; the direction numbers; the
/// hierarchy; the height field; the meshes.
/// Returns them, the inputs per pixel and `nl` (the most lobes of a material seen).
fn light_inputs(sc: &Scene, hits: &[&Hit]) -> Result<(Vec<f32>, usize, usize), String> {
    use lobefit::pipelines::scene::Brdf;
    if hits
        .iter()
        .any(|h| matches!(sc.brdf(h), Brdf::CookTorrance { .. } | Brdf::BlinnPhong { .. }))
    {
        return Err(format!(
            "mc: {} has a cook_torrance or blinn_phong material; the device's Monte Carlo shades Lambert and Lafortune ones",
            sc.name
        ));
    }
    let lobes = |b: &Brdf| match b {
        Brdf::Lafortune { lobes, .. } => lobes.len(),
        _ => 0,
    };
    let nl = hits.iter().map(|h| lobes(sc.brdf(h))).max().unwrap_or(0);
    if nl > MAX_LOBES {
        return Err(format!(
            "mc: a material of {} has {nl} Lafortune lobes (at most {MAX_LOBES})",
            sc.name
        ));
    }
    let n_in = 10 + 5 * nl;
    let mut inputs = Vec::with_capacity(hits.len() * n_in + 1 + 4 * sc.spheres.len());
    for h in hits {
        inputs.extend([h.x.x, h.x.y, h.x.z, h.n.x, h.n.y, h.n.z].map(|v| v as f32));
        let (albedo, ls): (f64, &[lobefit_tables::geom::LafortuneLobe]) = match sc.brdf(h) {
            Brdf::Lambert { albedo } | Brdf::CookTorrance { albedo, .. } | Brdf::BlinnPhong { albedo, .. } => {
                (*albedo, &[])
            }
            Brdf::Lafortune { albedo, lobes } => (*albedo, lobes),
        };
        inputs.push((albedo / std::f64::consts::PI) as f32);
        inputs.push(h.sphere.map_or(-1.0, |i| i as f32));
        let (mesh, tri) = h.mesh.map_or((-1.0, -1.0), |(m, k)| (m as f32, k as f32));
        inputs.extend([mesh, tri]);
        // The CPU's brdf_value: the lobe's value ρ (a · (C ⊙ o))^n in the frame
        // (t, n × t, n), a and o the light and view directions there.
        let t = (h.t - h.t.dot(h.n) * h.n).normalize();
        let bt = h.n.cross(t);
        let o = [h.wo.dot(t), h.wo.dot(bt), h.wo.dot(h.n)];
        for k in 0..nl {
            match ls.get(k) {
                Some(l) => {
                    let q = l.c.x * o[0] * t + l.c.y * o[1] * bt + l.c.z * o[2] * h.n;
                    inputs.extend([q.x, q.y, q.z, l.rho, l.exponent].map(|v| v as f32));
                }
                None => inputs.extend([0.0, 0.0, 1.0, 0.0, 1.0]),
            }
        }
    }
    inputs.extend([0.0, 0.0]);
    for s in &sc.spheres {
        inputs.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|v| v as f32));
    }
    inputs.extend(direction_inputs());
    inputs.extend(bvh_inputs(sc));
    inputs.extend(hf_inputs(sc));
    inputs.extend(mesh_inputs(sc));
    Ok((inputs, n_in, nl))
}

/// Samples per dispatch of the light kernel (see [`batch_size`]): per sample the
/// sphere hierarchy, the height field's and the meshes' traversals (`traced`) and the
/// lobe loop.
fn batch_size_light(spheres: usize, lobes: usize, traced: u64, est: Estimator) -> Result<usize, String> {
    let per = 1 + point_iterations(est) + spheres as u64 + nodes(spheres) + traced + lobes as u64;
    let fit = (budget::LOOP_LIMIT - 2) / per;
    if fit == 0 {
        return Err(format!(
            "mc: {spheres} spheres: one sample ({per} loop iterations) is over llvmpipe's loop budget"
        ));
    }
    let m = fit.min(MAX_BATCH as u64);
    Ok(1 << (63 - m.leading_zeros()))
}

/// The light kernel for `sc` over `count` pixels of `n_in` inputs, `nl` lobes each,
/// `spp` samples a dispatch.
fn source_light(sc: &Scene, n_in: usize, nl: usize, qmc: bool) -> String {
    let l = sc.lights[0];
    let c = l.sphere.centre;
    let f = |v: f64| format!("{:?}", v as f32);
    let consts = format!(
        "const NS = {}u;\nconst NE = 0u;\nconst NL = {nl}u;\nconst N_IN = {n_in}u;\n\
         const QMC = {qmc};\nconst CV = false;\nconst HYB = false;\nconst HYB_ISG = false;\nconst SHO = 0u;\n\
         const SHN = 0u;\nconst SOBOL_LEN = {}u;\n{OFFSETS}\
         const LIGHT = vec4<f32>({}, {}, {}, {});\nconst LIGHT_RADIANCE = {};\n{}{}",
        sc.spheres.len(),
        direction_inputs().len(),
        f(c.x),
        f(c.y),
        f(c.z),
        f(l.sphere.radius),
        f(l.radiance),
        bvh_consts(sc),
        hf_consts(sc) + &mesh_consts(sc)
    );
    // The uniforms and the traversals (mc_point, mc_occluded) are the sky kernel's.
    let (shared, _) = split(SHADER);
    let (functions, body) = split(SHADER_LIGHT);
    let body = LAYOUT.to_string() + LAYOUT_SKY + body + budget::SENTINEL + "    Y[o + 3u] = budget_flag;";
    kernel("texture_2d<f32>", n_in, N_OUT, &body) + &consts + shared + functions
}

/// Runs `batches` dispatches of `src` (`batch` samples each) with the batch index at
/// `inputs[slot]`, and turns the sums into estimates.
fn run_batches(
    gpu: &Gpu,
    src: &str,
    mut inputs: Vec<f32>,
    slot: usize,
    count: usize,
    batches: usize,
    batch: usize,
) -> Result<(Vec<Estimate>, usize), String> {
    let dummy = gpu.upload(&dummy_texture(), Storage::F32)?;
    let (mut sum, mut sum2, mut open) = (vec![0.0f64; count], vec![0.0f64; count], vec![0.0; count]);
    for k in 0..batches {
        inputs[slot] = k as f32;
        let got = gpu.run(src, &[0u8; LF_TEX_SIZE], &dummy, &inputs, count, N_OUT)?;
        budget::flags("mc", got.chunks(N_OUT).map(|c| c[3]), count, |f| {
            format!("unknown flag {f}")
        })?;
        for (p, c) in got.chunks(N_OUT).enumerate() {
            sum[p] += f64::from(c[0]);
            sum2[p] += f64::from(c[1]);
            open[p] = f64::from(c[2]);
        }
    }
    let n = (batches * batch) as f64;
    let out = (0..count)
        .map(|p| {
            let mean = sum[p] / n;
            let var = ((sum2[p] / n - mean * mean) * n / (n - 1.0).max(1.0)).max(0.0);
            Estimate {
                mean: open[p] + mean,
                std_error: (var / n).sqrt(),
                samples: n as usize,
            }
        })
        .collect();
    Ok((out, batches * batch))
}

/// The CPU's estimator `est` at `spp` samples at each of `hits` (seeded per pixel).
pub fn cpu_estimate(sc: &Scene, hits: &[&Hit], spp: usize, est: Estimator, seed: u64) -> Result<Vec<Estimate>, String> {
    use lobefit::pipelines::estimate::Sampling;
    let sh = if est == Estimator::Hybrid {
        Some(ShPipeline::new(sc)?)
    } else {
        None
    };
    let isg = if est == Estimator::HybridIsg {
        Some(lobefit::pipelines::isg::shade::Tables::embedded().map_err(|e| e.to_string())?)
    } else {
        None
    };
    hits.iter()
        .enumerate()
        .map(|(p, h)| {
            let seed = seed ^ (p as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
            if light_scene(sc) {
                return Ok(lobefit::pipelines::meunier::render::reference(
                    sc,
                    &sc.lights[0],
                    h,
                    spp,
                    seed,
                ));
            }
            let b = Phong::of(sc.brdf(h))?;
            Ok(match est.random() {
                Estimator::Plain | Estimator::Qmc if sc.sh_environment.is_some() => {
                    lobefit::pipelines::shexp::reference(
                        sc,
                        |v| lobefit::pipelines::shexp::light(sc, v),
                        &b,
                        h,
                        spp,
                        seed,
                    )
                }
                Estimator::Plain | Estimator::Qmc => match &sc.environment_map {
                    Some(m) => lobefit::pipelines::sky::reference_map(
                        Sampling::Plain,
                        m,
                        |v| m.luminance(v),
                        &b,
                        |v| sc.occluded(h, v),
                        h,
                        spp,
                        seed,
                    ),
                    None => reference(&sc.environment, &b, |v| sc.occluded(h, v), h, spp, seed),
                },
                Estimator::CvMis | Estimator::QmcCvMis => reference_cv(
                    Sampling::Plain,
                    Select::Contribution,
                    &sc.environment,
                    &b,
                    |v| sc.occluded(h, v),
                    h,
                    spp,
                    seed,
                ),
                Estimator::HybridIsg => {
                    let t = isg.as_ref().ok_or("the ISG tables")?;
                    let s = lobefit::pipelines::isg::shade::Settings::default();
                    let blockers = lobefit::pipelines::isg::render::blockers_of(sc, h);
                    let a = lobefit::pipelines::isg::shade::integrand(t, &s, &sc.environment, &b, &blockers, h)?;
                    reference_hybrid(
                        Sampling::Plain,
                        &sc.environment,
                        |v| lobefit::pipelines::sg::environment(&sc.environment, v),
                        &b,
                        |v| sc.occluded(h, v),
                        h,
                        spp,
                        seed,
                        a.value,
                        |w| a.eval(w),
                    )
                }
                Estimator::Hybrid => {
                    let a = sh.as_ref().ok_or("the SH pipeline")?.integrand(sc, h)?;
                    let light = |v| lobefit::pipelines::shexp::light(sc, v);
                    reference_hybrid(
                        Sampling::Plain,
                        &sc.environment,
                        light,
                        &b,
                        |v| sc.occluded(h, v),
                        h,
                        spp,
                        seed,
                        a.value,
                        |w| light(w) * a.eval(w),
                    )
                }
            })
        })
        .collect()
}

/// The CPU's SH-exponentiation pipeline at its default settings under a scene's
/// light: what the hybrid's CPU side takes as its control variate.
struct ShPipeline {
    tables: lobefit::pipelines::shexp::shade::Tables,
    settings: lobefit::pipelines::shexp::shade::Settings,
    light: Vec<f64>,
}

impl ShPipeline {
    fn new(sc: &Scene) -> Result<ShPipeline, String> {
        let settings = lobefit::pipelines::shexp::shade::Settings::default();
        Ok(ShPipeline {
            tables: lobefit::pipelines::shexp::shade::Tables::embedded()?,
            light: lobefit::pipelines::shexp::light_sh(sc, settings.order)?,
            settings,
        })
    }

    /// The pipeline's integrand at `h`.
    fn integrand(&self, sc: &Scene, h: &Hit) -> Result<lobefit::pipelines::shexp::shade::Integrand, String> {
        let b = Phong::of(sc.brdf(h))?;
        lobefit::pipelines::shexp::shade::integrand(&self.tables, &self.settings, &self.light, &b, sc, h)
    }
}

/// The device's f32 resolution of an estimate, relative to it: where a control
/// variate leaves almost no variance (the ISG hybrid at an unshadowed diffuse point:
/// standard errors ~1e-9), the f32 closed form and sums differ from the CPU's f64 by
/// ~1e-7 of the value (measured: 1.1e-7 at fig12-diffuse's worst pixel), which alone
/// gave z = 32 there.
const F32_FLOOR: f64 = 1e-6;

/// [`F32_FLOOR`] for a scene: under an SG of sharpness λ the device's f32 exponent
/// λ (μ·ω − 1) carries about λ · 2⁻²⁴ of relative error into its exp, so the floor is
/// at least λ_max · 2⁻²³ (measured: 6e-5 relative at the skinned walker's
/// near-horizontal normals under its λ = 1 000 sun, pixels where no sample is
/// occluded and the closed-form control variate is the whole estimate: z up to 25
/// against the 1e-6 floor).
pub fn f32_floor(sc: &Scene) -> f64 {
    let lambda = sc.environment.iter().map(|g| g.sharpness).fold(0.0, f64::max);
    F32_FLOOR.max(lambda * f64::from(f32::EPSILON))
}

/// How two independent estimates of the same image agree: per pixel
/// z = (a − b)/√(se_a² + se_b² + (`floor` · max(|a|, |b|))²), `floor` the device's
/// relative f32 resolution ([`f32_floor`]); the mean of z, the mean of z², and the
/// fraction of pixels with |z| > 4.
pub fn agreement(a: &[Estimate], b: &[Estimate], floor: f64) -> (f64, f64, f64) {
    let z: Vec<f64> = a
        .iter()
        .zip(b)
        .filter_map(|(a, b)| {
            let f = floor * a.mean.abs().max(b.mean.abs());
            let s = (a.std_error * a.std_error + b.std_error * b.std_error + f * f).sqrt();
            (s > 0.0).then(|| (a.mean - b.mean) / s)
        })
        .collect();
    let n = z.len().max(1) as f64;
    (
        z.iter().sum::<f64>() / n,
        z.iter().map(|z| z * z).sum::<f64>() / n,
        z.iter().filter(|z| z.abs() > 4.0).count() as f64 / n,
    )
}

/// `lobefit-gpu mc`'s options.
#[derive(clap::Parser)]
pub struct Args {
    /// An ISG scene (fig12, fig12-diffuse: spheres under an SG sky), an
    /// SH-exponentiation scene with an SG sky (whale, whale-diffuse, wrecking: spheres
    /// over a height field), a Meunier scene (fig13, glossy: one spherical light;
    /// `plain` and `qmc` only) or such a scene file (triangle meshes too, e.g.
    /// assets/meshes/isg-bunny.json, assets/meshes/meunier-bunny.json).
    #[arg(long, default_value = "fig12")]
    scene: String,
    /// Image width (height 3/4 of it).
    #[arg(long, default_value_t = 32, value_parser = clap::value_parser!(u32).range(4..=1024))]
    width: u32,
    /// Samples per pixel (rounded up to whole batches); 256 at least: below, the
    /// control variate's standard errors are unreliable (a pixel whose few occluded
    /// samples one side drew and the other did not; measured at 64 spp on fig12: mean
    /// z² 2.4 for two unbiased estimates).
    #[arg(long, default_value_t = 1024, value_parser = clap::value_parser!(u32).range(256..=1 << 20))]
    spp: u32,
    /// The estimator.
    #[arg(long, value_enum, default_value_t = Estimator::CvMis)]
    estimator: Estimator,
    /// A `lobefit export` directory with wedge and shexp: the hybrid's control variate
    /// is the device's SH-exponentiation kernel (needed by `hybrid` only).
    #[arg(long, value_name = "DIR")]
    export: Option<std::path::PathBuf>,
}

/// Largest RMS difference, over the peak |value|, between the device's integrands and
/// the CPU's (the analytic kernels' conformance limit).
const INTEGRAND_RMS_MAX: f64 = 1e-4;

/// The device's SH-exponentiation integrands at `hits` (from the kernel on the export
/// `dir`), checked against the CPU pipeline's at the same f32-rounded hits: their RMS
/// difference over the peak |value| (all 17 numbers) is at most [`INTEGRAND_RMS_MAX`].
fn device_integrands(dir: &std::path::Path, sc: &Scene, hits: &[&Hit]) -> Result<(Gpu, ControlVariate), String> {
    let (ex, gpu) = crate::render::open(dir, crate::shexp::FAMILIES, |b| {
        crate::shexp::check_budget(b, sc, "mc --estimator hybrid", false)
    })?;
    let got = crate::shexp::integrands(&gpu, &ex, sc, hits)?;
    let sh = ShPipeline::new(sc)?;
    let r32 = |v: DVec3| DVec3::new(f64::from(v.x as f32), f64::from(v.y as f32), f64::from(v.z as f32));
    let (mut sum, mut peak, mut count) = (0.0f64, 0.0f64, 0usize);
    for (h, g) in hits.iter().zip(&got) {
        let at = Hit {
            x: r32(h.x),
            n: r32(h.n).normalize(),
            wo: r32(h.wo).normalize(),
            ..**h
        };
        let a = sh.integrand(sc, &at)?;
        peak = peak.max(a.value.abs());
        let want = std::iter::once(a.value).chain(a.coefficients(4));
        for (w, g) in want.zip(g) {
            sum += (f64::from(*g) - w).powi(2);
            count += 1;
        }
    }
    let rms = (sum / count.max(1) as f64).sqrt() / peak.max(f64::MIN_POSITIVE);
    out!(
        "mc hybrid {}: the device's SH-exponentiation integrands (value and 16 coefficients) against the CPU's: \
         RMS / peak {rms:.2e} (limit {INTEGRAND_RMS_MAX:.0e})",
        sc.name
    );
    if rms.is_nan() || rms > INTEGRAND_RMS_MAX {
        return Err(format!(
            "mc: the device's integrands differ from the CPU's by {rms:.2e} of the peak (limit {INTEGRAND_RMS_MAX:.0e})"
        ));
    }
    Ok((gpu, ControlVariate::Sh(got)))
}

/// Largest |mean z| and range of the mean z² the agreement accepts: for P pixels the
/// mean z has a standard deviation 1/√P and mean z² about √(2/P) when both sides are
/// unbiased; the bounds allow heavy tails (a pixel whose few bright samples its
/// standard error underestimates) without hiding a bias of a standard error.
const MEAN_Z_MAX: f64 = 0.25;
const MEAN_Z2: (f64, f64) = (0.7, 1.5);
/// Pixels with |z| > 4 the agreement accepts (Gaussian: 6e-5).
const FAR_MAX: f64 = 0.01;

/// `lobefit-gpu mc`: the device's estimate against the CPU's (same estimator, same
/// samples per pixel, independent random numbers); exit 1 when they disagree beyond
/// their standard errors.
pub fn run(a: Args) -> Result<ExitCode, String> {
    // The scene as the first pipeline that shades it loads it (a light scene takes the
    // light kernel, a sky scene the sky kernel: the scene decides, not the pipeline).
    let sc = lobefit::pipelines::load_for_any(&a.scene)?;
    supported(&sc)?;
    let hits: Vec<Hit> = crate::render::primary_hits(&sc, crate::render::image_size(a.width as usize))?
        .into_iter()
        .flatten()
        .collect();
    let refs: Vec<&Hit> = hits.iter().collect();
    let (gpu, cv) = match (a.estimator, &a.export) {
        (Estimator::Hybrid, Some(dir)) => {
            let (gpu, cv) = device_integrands(dir, &sc, &refs)?;
            (gpu, Some(cv))
        }
        (Estimator::Hybrid, None) => {
            return Err("mc: --estimator hybrid needs --export DIR (the SH-exponentiation kernel's textures)".into())
        }
        (Estimator::HybridIsg, _) => (Gpu::new()?, Some(ControlVariate::isg(&sc, &refs)?)),
        _ => (Gpu::new()?, None),
    };
    let t0 = std::time::Instant::now();
    let (got, spp) = estimate(&gpu, &sc, &refs, a.spp as usize, a.estimator, cv.as_ref())?;
    let t_gpu = t0.elapsed().as_secs_f64();
    let t0 = std::time::Instant::now();
    let cpu = cpu_estimate(&sc, &refs, spp, a.estimator, 0x6d63)?;
    let t_cpu = t0.elapsed().as_secs_f64();
    let (mz, mz2, far) = agreement(&got, &cpu, f32_floor(&sc));
    let mean = |e: &[Estimate]| e.iter().map(|e| e.mean).sum::<f64>() / e.len() as f64;
    let se = |e: &[Estimate]| e.iter().map(|e| e.std_error).sum::<f64>() / e.len() as f64;
    // A QMC estimate's error is below what its sample variance says: its mean z² may
    // fall under the lower bound, which binds the random estimators only.
    let z2_min = if a.estimator.qmc() { 0.0 } else { MEAN_Z2.0 };
    let ok = mz.abs() <= MEAN_Z_MAX && (z2_min..=MEAN_Z2.1).contains(&mz2) && far <= FAR_MAX;
    out!(
        "mc {} {}: {} pixels × {spp} spp on {}; device mean {:.5} (se {:.2e}), CPU mean {:.5} (se {:.2e}); \
         z: mean {mz:+.3} (limit ±{MEAN_Z_MAX}), mean z² {mz2:.3} (limit {}–{}), |z| > 4 {:.2} % (limit {} %); \
         {:.2} s device (batches, compiles and reads included), {:.2} s CPU: {}",
        a.estimator.name(),
        sc.name,
        refs.len(),
        gpu.info.name,
        mean(&got),
        se(&got),
        mean(&cpu),
        se(&cpu),
        z2_min,
        MEAN_Z2.1,
        100.0 * far,
        100.0 * FAR_MAX,
        t_gpu,
        t_cpu,
        if ok { "agree" } else { "DISAGREE" }
    );
    Ok(if ok { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// Samples per pixel of the bench's Monte Carlo rows: 1, 4, 16, … up to `max`.
pub fn bench_spp(max: usize) -> Vec<usize> {
    (0..)
        .map(|k| 1usize << (2 * k))
        .take_while(|&n| n <= max.max(1))
        .collect()
}
/// Samples per pixel of the bench's reference (the CPU's control-variate estimator).
const REF_SPP: usize = 1 << 14;

/// Where the bench's reference is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ReferenceOn {
    /// The CPU's estimator at every pixel (minutes past a few thousand pixels).
    Cpu,
    /// The device's own estimator at every pixel, checked against the CPU's on
    /// [`CHECK_PIXELS`] of them (the full-resolution comparison).
    Device,
}

/// Pixels (every k-th) on which a device reference is checked against the CPU: the
/// agreement's mean z then has a standard deviation of 1/16, its limit 0.25 four of them.
const CHECK_PIXELS: usize = 256;

/// The device's estimate `est` at [`REF_SPP`] over `refs`, and a line saying how it
/// agrees with the CPU's estimate on [`CHECK_PIXELS`] of them (independent seeds; the
/// agreement `mc` holds: mean z, mean z², the share of |z| > 4). An error where it
/// disagrees: the reference is then no reference.
fn device_reference(gpu: &Gpu, sc: &Scene, refs: &[&Hit], est: Estimator) -> Result<(Vec<Estimate>, String), String> {
    let (dev, spp) = estimate(gpu, sc, refs, REF_SPP, est, None)?;
    gpu.take_dispatches();
    let step = refs.len().div_ceil(CHECK_PIXELS).max(1);
    let idx: Vec<usize> = (0..refs.len()).step_by(step).collect();
    let sub: Vec<&Hit> = idx.iter().map(|&k| refs[k]).collect();
    let cpu = cpu_estimate(sc, &sub, spp, est, 0x7266)?;
    let on_dev: Vec<Estimate> = idx.iter().map(|&k| dev[k]).collect();
    let (mz, mz2, far) = agreement(&on_dev, &cpu, f32_floor(sc));
    let ok = mz.abs() <= MEAN_Z_MAX && (MEAN_Z2.0..=MEAN_Z2.1).contains(&mz2) && far <= FAR_MAX;
    let note = format!(
        "the device's {} at {spp} spp, checked against the CPU's on {} pixels: z mean {mz:+.3} (limit ±{MEAN_Z_MAX}), \
         mean z² {mz2:.3} (limit {}–{}), |z| > 4 {:.2} % (limit {} %)",
        est.name(),
        idx.len(),
        MEAN_Z2.0,
        MEAN_Z2.1,
        100.0 * far,
        100.0 * FAR_MAX
    );
    if !ok {
        return Err(format!("bench: the device's reference disagrees with the CPU: {note}"));
    }
    Ok((dev, note))
}

/// One Monte Carlo row of the bench.
pub struct McRow {
    /// The estimator.
    pub estimator: Estimator,
    /// Samples per pixel.
    pub spp: usize,
    /// Frames timed (ms).
    pub ms: Vec<f64>,
    /// Relative RMSE against the reference, its noise removed.
    pub rel_rmse: f64,
}

/// The bench's comparison on one scene: the analytic kernel and the device's
/// Monte Carlo at [`BENCH_SPP`], each against the CPU reference, and where each
/// estimator reaches the analytic kernel's error.
pub struct McBench {
    /// The pipeline whose device kernel is compared (isg, shexp, meunier).
    pub pipeline: &'static str,
    /// The scene's name.
    pub scene: String,
    /// Pixels that see geometry.
    pub pixels: usize,
    /// The reference's estimator, samples per pixel and mean relative standard error.
    pub reference: (Estimator, usize, f64),
    /// `None`: the reference is the CPU's; else the device's, and how it agrees with the
    /// CPU's on a subset ([`ReferenceOn::Device`]).
    pub reference_check: Option<String>,
    /// The analytic kernel's relative RMSE against the reference and its ms/frame.
    pub analytic: (f64, f64),
    /// The Monte Carlo rows.
    pub rows: Vec<McRow>,
}

impl McBench {
    /// The estimators measured, in order.
    pub fn estimators(&self) -> Vec<Estimator> {
        let mut v: Vec<Estimator> = Vec::new();
        for r in &self.rows {
            if !v.contains(&r.estimator) {
                v.push(r.estimator);
            }
        }
        v
    }

    /// Whether the analytic kernel's error is below what the reference resolves (its
    /// noise-free estimate is 0, or not finite): no equal-error point can be read.
    pub fn unresolved(&self) -> bool {
        !(self.analytic.0 > 0.0 && self.analytic.0.is_finite())
    }

    /// Per estimator: (samples per pixel, ms/frame) where its error reaches the
    /// analytic kernel's, interpolated log-log between measured points; `None` beyond
    /// the measured range (then the last point is a lower bound), and where the
    /// kernel's error, or the error after the crossing, is below what the reference
    /// resolves (noise-free estimate 0: [`McBench::unresolved`]), where a log-log
    /// interpolation means nothing.
    pub fn equal_error(&self, est: Estimator) -> Option<(f64, f64)> {
        let pts: Vec<&McRow> = self.rows.iter().filter(|r| r.estimator == est).collect();
        let target = self.analytic.0;
        if self.unresolved() {
            return None;
        }
        pts.windows(2).find_map(|w| {
            let (a, b) = (w[0], w[1]);
            let crosses = a.rel_rmse >= target && target >= b.rel_rmse && a.rel_rmse > b.rel_rmse;
            (crosses && b.rel_rmse > 0.0).then(|| {
                let t = (a.rel_rmse / target).ln() / (a.rel_rmse / b.rel_rmse).ln();
                let lerp = |x: f64, y: f64| (x.ln() + t * (y.ln() - x.ln())).exp();
                (
                    lerp(a.spp as f64, b.spp as f64),
                    lerp(
                        lobefit::pipelines::measure::Timing::of(&a.ms).median,
                        lobefit::pipelines::measure::Timing::of(&b.ms).median,
                    ),
                )
            })
        })
    }
}

/// The analytic kernel's integrands at given hits (the hybrid's control variate).
pub type Integrands<'a> = &'a dyn Fn(&[&Hit]) -> Result<ControlVariate, String>;

/// The analytic kernel the bench's Monte Carlo is compared with.
pub struct Analytic<'a> {
    /// The pipeline (isg, shexp, meunier).
    pub pipeline: &'static str,
    /// Its image over the pixels that see geometry.
    pub values: &'a [f64],
    /// Its time per frame (ms).
    pub ms: f64,
    /// Its integrands, where it serves as the hybrid's control variate.
    pub integrands: Option<Integrands<'a>>,
}

/// The bench's Monte Carlo comparison on `sc` at `width`: the analytic kernel's image
/// and time (`analytic`) and every estimator the scene takes at
/// [`bench_spp`]`(max_spp)` against the strongest of them at [`REF_SPP`], on the CPU or
/// on the device (`on`; checked against the CPU on a subset). A frame of more samples than a
/// dispatch takes is several dispatches: its time per frame is the sum of their
/// times, each frame timed as the bench times a kernel. Where the analytic kernel has
/// integrands, the hybrid estimator too; its frame is the analytic kernel's (which the
/// control variate needs) plus its dispatches.
pub fn bench(
    gpu: &Gpu,
    sc: &Scene,
    width: usize,
    analytic: Analytic,
    max_spp: usize,
    on: ReferenceOn,
) -> Result<McBench, String> {
    use lobefit::pipelines::image::noise_free_rel_rmse;
    supported(sc)?;
    let hits: Vec<Hit> = crate::render::primary_hits(sc, crate::render::image_size(width))?
        .into_iter()
        .flatten()
        .collect();
    let refs: Vec<&Hit> = hits.iter().collect();
    if analytic.values.len() != refs.len() {
        return Err(format!(
            "bench mc: {} analytic values for {} pixels",
            analytic.values.len(),
            refs.len()
        ));
    }
    // The reference: the CPU's strongest random estimator (its standard errors true):
    // cv-mis under an SG sky; plain (uniform in the cap) for a light; plain under an SH
    // sky or a map (its texels sampled), which take no control variate.
    let plain_only = light_scene(sc) || sc.sh_environment.is_some() || sc.environment_map.is_some();
    let (mut estimators, strongest) = if plain_only {
        (vec![Estimator::Plain, Estimator::Qmc], Estimator::Plain)
    } else {
        (
            vec![Estimator::Plain, Estimator::CvMis, Estimator::QmcCvMis],
            Estimator::CvMis,
        )
    };
    let cv = match analytic.integrands {
        Some(f) if !plain_only => {
            let cv = f(&refs)?;
            estimators.push(cv.estimator());
            Some(cv)
        }
        _ => None,
    };
    let (reference, reference_check) = match on {
        ReferenceOn::Cpu => (cpu_estimate(sc, &refs, REF_SPP, strongest, 0x7265)?, None),
        ReferenceOn::Device => {
            let (r, note) = device_reference(gpu, sc, &refs, strongest)?;
            (r, Some(note))
        }
    };
    let mean: Vec<f64> = reference.iter().map(|e| e.mean).collect();
    let se: Vec<f64> = reference.iter().map(|e| e.std_error).collect();
    let mask = vec![true; refs.len()];
    let mean_ref = mean.iter().sum::<f64>() / mean.len() as f64;
    let ref_rel_se = se.iter().sum::<f64>() / se.len() as f64 / mean_ref;
    let mut rows = Vec::new();
    for est in estimators {
        let (cv, extra) = match est {
            Estimator::Hybrid | Estimator::HybridIsg => (cv.as_ref(), analytic.ms),
            _ => (None, 0.0),
        };
        for spp in bench_spp(max_spp) {
            gpu.take_dispatches();
            let (got, n) = estimate(gpu, sc, &refs, spp, est, cv)?;
            let d = gpu.take_dispatches();
            let frames = d.first().map_or(0, |k| k.ms.len());
            if d.is_empty() || d.iter().any(|k| k.ms.len() != frames) {
                return Err(format!("bench mc: {spp} spp: its dispatches were not timed"));
            }
            let ms = (0..frames)
                .map(|f| extra + d.iter().map(|k| k.ms[f]).sum::<f64>())
                .collect();
            let img: Vec<f64> = got.iter().map(|e| e.mean).collect();
            rows.push(McRow {
                estimator: est,
                spp: n,
                ms,
                rel_rmse: noise_free_rel_rmse(&img, &mean, &se, &mask),
            });
        }
    }
    Ok(McBench {
        pipeline: analytic.pipeline,
        scene: sc.name.clone(),
        pixels: refs.len(),
        reference: (strongest, REF_SPP, ref_rel_se),
        reference_check,
        analytic: (noise_free_rel_rmse(analytic.values, &mean, &se, &mask), analytic.ms),
        rows,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The kernel functions from the comment starting `from` up to the one starting
    /// `to` (mc.wgsl's own order).
    fn section(from: &str, to: &str) -> String {
        let (functions, _) = split(SHADER);
        let a = functions
            .find(from)
            .unwrap_or_else(|| panic!("mc.wgsl has no {from:?}"));
        let b = functions.find(to).unwrap_or_else(|| panic!("mc.wgsl has no {to:?}"));
        functions[a..b].to_string()
    }

    /// Device against reference answers (blocked or not), ray for ray: at most
    /// `max_differ` rays differ, and the rays test something (10–90 % blocked).
    fn rays_agree(device: &[bool], reference: &[bool], max_differ: usize) {
        let count = reference.len();
        let differ: Vec<usize> = (0..count).filter(|&k| device[k] != reference[k]).collect();
        assert!(
            differ.len() <= max_differ,
            "{} of {count} rays differ, e.g. rays {:?}",
            differ.len(),
            &differ[..differ.len().min(5)]
        );
        let blocked = reference.iter().filter(|&&b| b).count();
        assert!(
            blocked > count / 10 && blocked < count * 9 / 10,
            "{blocked} of {count} rays blocked"
        );
    }

    /// The test kernel `src` over `count` invocations of `inputs` on the device (no
    /// texture): its `n_out` outputs each.
    fn run_on_device(src: &str, inputs: &[f32], count: usize, n_out: usize) -> Vec<f32> {
        let gpu = Gpu::new().unwrap();
        let dummy = gpu.upload(&dummy_texture(), Storage::F32).unwrap();
        gpu.run(src, &[0u8; LF_TEX_SIZE], &dummy, inputs, count, n_out).unwrap()
    }

    /// The rays' helpers (mc_inverse, mc_meets_box, mc_sphere_blocks).
    fn ray_helpers() -> String {
        section("// ---- rays:", "// Whether the ray x + t v meets a sphere other")
    }

    /// The bench's device reference: fig12 at width 12 (the device's cv-mis at 16 384
    /// spp), checked against the CPU's on every pixel (fewer than 256), agrees; the
    /// note says what was checked, and the reference is the device's own estimate.
    #[test]
    fn a_device_reference_is_checked_against_the_cpu() {
        let sc = lobefit::pipelines::load_for_any("fig12").unwrap();
        let hits: Vec<Hit> = crate::render::primary_hits(&sc, crate::render::image_size(12))
            .unwrap()
            .into_iter()
            .flatten()
            .collect();
        let refs: Vec<&Hit> = hits.iter().collect();
        let gpu = Gpu::new().unwrap();
        let (r, note) = device_reference(&gpu, &sc, &refs, Estimator::CvMis).unwrap();
        assert_eq!(r.len(), refs.len());
        assert!(r
            .iter()
            .all(|e| e.samples == REF_SPP && e.mean.is_finite() && e.std_error > 0.0));
        let n = refs.len();
        assert!(
            note.contains(&format!(
                "cv-mis at {REF_SPP} spp, checked against the CPU's on {n} pixels"
            )),
            "{note}"
        );
    }

    /// On the device: the kernels' traversal of the sphere hierarchy (mc_blocked)
    /// answers as a scan of every sphere with the same f32 ray–sphere test, ray for
    /// ray, on the 306 spheres of the ISG sweep: 4 096 rays from points in and around
    /// the spheres' box, in uniform directions, some skipping a sphere of their own,
    /// half with a finite t_max (the light kernel's) and half unbounded (the sky's).
    #[test]
    fn hierarchy_traversal_equals_a_scan_on_the_device() {
        let sc = lobefit::pipelines::isg::render::scene("sweep-306").unwrap();
        let ns = sc.spheres.len();
        let (lo, hi) = sc.spheres.iter().fold(
            (
                lobefit_tables::glam::DVec3::splat(f64::INFINITY),
                lobefit_tables::glam::DVec3::splat(f64::NEG_INFINITY),
            ),
            |(l, h), s| (l.min(s.centre - s.radius), h.max(s.centre + s.radius)),
        );
        let mut rng = lobefit::rng::Rng::new(7);
        let count = 4096;
        let mut inputs = Vec::with_capacity(8 * count);
        for k in 0..count {
            let u = lobefit_tables::glam::DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
            let x = lo - 0.1 * (hi - lo) + 1.2 * (hi - lo) * u;
            let z = 2.0 * rng.uniform() - 1.0;
            let phi = std::f64::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).sqrt();
            let v = [r * phi.cos(), r * phi.sin(), z];
            let own = if k % 4 == 0 { (k / 4 % ns) as f64 } else { -1.0 };
            let t_max = if k % 2 == 0 {
                3.4e38
            } else {
                rng.uniform() * (hi - lo).length()
            };
            inputs.extend([x.x, x.y, x.z, v[0], v[1], v[2], own, t_max].map(|v| v as f32));
        }
        let sph0 = 8 * count;
        for s in &sc.spheres {
            inputs.extend([s.centre.x, s.centre.y, s.centre.z, s.radius].map(|v| v as f32));
        }
        let node0 = inputs.len();
        inputs.extend(bvh_inputs(&sc));
        let blocked = section("// ---- rays:", "// Whether the ray x + t v (0 < t < t_max)");
        let consts = format!(
            "const NS = {ns}u;\nconst SPH0 = {sph0}u;\nconst NODE0 = {node0}u;\nconst ORDER0 = {}u;\n\
             fn sph(b: u32) -> vec4<f32> {{\n    let k = SPH0 + 4u * b;\n    return vec4<f32>(X[k], X[k + 1u], X[k + 2u], X[k + 3u]);\n}}\n{}",
            node0 + 8 * sc.bvh().nodes().len(),
            bvh_consts(&sc)
        );
        let body = "    let x = vec3<f32>(x0, x1, x2);
    let v = vec3<f32>(x3, x4, x5);
    let own = i32(x6);
    var scan = false;
    for (var b = 0u; b < NS; b++) {
        if i32(b) == own {
            continue;
        }
        scan = scan || mc_sphere_blocks(x, v, sph(b), x7);
    }
    Y[o] = select(0.0, 1.0, mc_blocked(x, v, own, x7));
    Y[o + 1u] = select(0.0, 1.0, scan);";
        let src = kernel("texture_2d<f32>", 8, 2, body) + &consts + &blocked;
        let got = run_on_device(&src, &inputs, count, 2);
        let walk: Vec<bool> = got.chunks(2).map(|c| c[0] == 1.0).collect();
        let scan: Vec<bool> = got.chunks(2).map(|c| c[1] == 1.0).collect();
        rays_agree(&walk, &scan, 0);
    }

    /// The height field's traversal on the device (mc_terrain, f32) answers as the
    /// CPU's f64 `HeightField::occluded` on the same f32-rounded rays, from the same
    /// start: 4 096 rays over the whale's 256² terrain, from points on the surface (as
    /// a hit: the sky kernel's) and above it, in directions of the upper hemisphere and
    /// some below, half with a finite t_max. A ray within 1e-3 rad of grazing the
    /// surface where it starts, or whose CPU hit lies within 1e-4 of the extent of
    /// where it starts or ends, may differ by rounding: at most 0.5 % of the rays do.
    #[test]
    fn terrain_traversal_agrees_with_the_cpu_on_the_device() {
        use lobefit_tables::glam::DVec3;
        let sc = lobefit::pipelines::shexp::render::scene("whale").unwrap();
        let (hf, _) = sc.heightfield.as_ref().unwrap();
        let half = 0.5 * hf.extent();
        let t_min = HF_T_MIN * hf.extent();
        let mut rng = lobefit::rng::Rng::new(11);
        let count = 4096;
        let mut inputs = Vec::with_capacity(8 * count);
        let mut rays = Vec::with_capacity(count);
        for k in 0..count {
            let (x, y) = (rng.range(-half, half), rng.range(-half, half));
            let h = hf.height(x, y).unwrap();
            let z = if k % 3 == 0 { h + rng.range(0.0, 1.0) } else { h };
            let cz = if k % 5 == 0 {
                rng.range(-0.3, 0.0)
            } else {
                rng.uniform()
            };
            let phi = std::f64::consts::TAU * rng.uniform();
            let r = (1.0 - cz * cz).sqrt();
            let v = DVec3::new(r * phi.cos(), r * phi.sin(), cz);
            let t_max = if k % 2 == 0 {
                3.4e38
            } else {
                rng.range(0.1, 1.0) * hf.extent()
            };
            let ray = [x, y, z, v.x, v.y, v.z, t_max].map(|c| c as f32);
            inputs.extend(ray);
            inputs.push(0.0);
            rays.push(ray.map(f64::from));
        }
        let hf0 = 8 * count;
        inputs.extend(hf_inputs(&sc));
        let terrain = section(
            "// The height field (the CPU's HeightField",
            "// A direction of the SG g's normalised density",
        );
        let consts = format!("const HF0 = {hf0}u;\n{}", hf_consts(&sc));
        let body =
            "    Y[o] = select(0.0, 1.0, mc_terrain(vec3<f32>(x0, x1, x2), vec3<f32>(x3, x4, x5), HF_TMIN, x6));";
        let src = kernel("texture_2d<f32>", 8, 1, body) + &consts + &terrain;
        let device: Vec<bool> = run_on_device(&src, &inputs, count, 1)
            .iter()
            .map(|&g| g == 1.0)
            .collect();
        let cpu: Vec<bool> = rays
            .iter()
            .map(|r| {
                let (x, v) = (DVec3::new(r[0], r[1], r[2]), DVec3::new(r[3], r[4], r[5]));
                hf.intersect(x, v, t_min, r[6]).is_some()
            })
            .collect();
        rays_agree(&device, &cpu, count / 200);
    }

    /// The meshes' traversal on the device (mc_meshes, f32) answers as the CPU's f64
    /// `Mesh::occluded` on the same f32-rounded rays: 4 096 rays against the bunny of
    /// `isg-bunny.json` (19 048 triangles), from points on its triangles (their own
    /// triangle skipped, from the device's t_min) and from points around it, in
    /// uniform directions, half with a finite t_max. Rays that pass within f32 rounding
    /// of an edge or start within 1e-4 of the diagonal from a triangle may differ: at
    /// most 0.5 % do.
    #[test]
    fn mesh_traversal_agrees_with_the_cpu_on_the_device() {
        use lobefit_tables::glam::DVec3;
        let sc = lobefit::pipelines::isg::render::scene(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/meshes/isg-bunny.json"
        ))
        .unwrap();
        let m = &sc.meshes[0].mesh;
        let (lo, hi) = m.bounds();
        let t_min = MESH_T_MIN * (hi - lo).length();
        let mut rng = lobefit::rng::Rng::new(13);
        let count = 4096;
        let mut inputs = Vec::with_capacity(10 * count);
        let mut rays = Vec::with_capacity(count);
        for k in 0..count {
            let (x, own) = if k % 2 == 0 {
                let t = (rng.next_u64() % m.triangles.len() as u64) as usize;
                let [a, b, c] = m.corners(t);
                let (u, w) = (rng.uniform(), rng.uniform());
                let (u, w) = if u + w > 1.0 { (1.0 - u, 1.0 - w) } else { (u, w) };
                (a + u * (b - a) + w * (c - a), t as f64)
            } else {
                let u = DVec3::new(rng.uniform(), rng.uniform(), rng.uniform());
                (lo - 0.2 * (hi - lo) + 1.4 * (hi - lo) * u, -1.0)
            };
            let z = 2.0 * rng.uniform() - 1.0;
            let phi = std::f64::consts::TAU * rng.uniform();
            let r = (1.0 - z * z).sqrt();
            let v = DVec3::new(r * phi.cos(), r * phi.sin(), z);
            let t_max = if k % 4 < 2 {
                3.4e38
            } else {
                rng.range(0.05, 1.0) * (hi - lo).length()
            };
            let ray = [x.x, x.y, x.z, v.x, v.y, v.z, t_max].map(|c| c as f32);
            inputs.extend(ray);
            inputs.extend([own as f32, 0.0, 0.0]);
            rays.push((ray.map(f64::from), own));
        }
        let mesh0 = 10 * count;
        let data = mesh_inputs(&sc);
        let nodes = m.hierarchy().count();
        inputs.extend(data);
        let meshes = ray_helpers()
            + &section(
                "// Whether the ray x + t v meets a triangle of one",
                "// The height field (the CPU's HeightField",
            );
        let consts = format!(
            "const NM = 1u;\nconst MSTACK = {}u;\nconst MESH0 = {mesh0}u;\nconst MNODE0 = {}u;\nconst MTRI0 = {}u;\n",
            m.depth() + 1,
            mesh0 + 2,
            mesh0 + 2 + 8 * nodes
        );
        let body =
            "    Y[o] = select(0.0, 1.0, mc_meshes(vec3<f32>(x0, x1, x2), vec3<f32>(x3, x4, x5), 0, i32(x7), x6));";
        let src = kernel("texture_2d<f32>", 10, 1, body) + &consts + &meshes;
        let device: Vec<bool> = run_on_device(&src, &inputs, count, 1)
            .iter()
            .map(|&g| g == 1.0)
            .collect();
        let cpu: Vec<bool> = rays
            .iter()
            .map(|(r, own)| {
                let (x, v) = (DVec3::new(r[0], r[1], r[2]), DVec3::new(r[3], r[4], r[5]));
                m.occluded(x, v, t_min, r[6], (*own >= 0.0).then_some(*own as usize))
            })
            .collect();
        rays_agree(&device, &cpu, count / 200);
    }

    /// The kernels of fig12 and of the whale (a height field) parse and validate with
    /// every estimator; batches fit the loop budget; scenes it cannot trace are errors
    /// naming what they have.
    #[test]
    fn kernel_validates_and_batches_fit() {
        let sc = lobefit::pipelines::isg::render::scene("fig12").unwrap();
        let whale = lobefit::pipelines::shexp::render::scene("whale").unwrap();
        let bunny = lobefit::pipelines::isg::render::scene(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/meshes/isg-bunny.json"
        ))
        .unwrap();
        for est in [
            Estimator::Plain,
            Estimator::CvMis,
            Estimator::Qmc,
            Estimator::QmcCvMis,
            Estimator::Hybrid,
            Estimator::HybridIsg,
        ] {
            // fig12, the whale over its height field, the bunny's triangles.
            for sc in [&sc, &whale, &bunny] {
                let traced = hf_iterations(sc) + mesh_iterations(sc);
                let b = batch_size(sc.spheres.len(), sc.environment.len(), traced, est, 40).unwrap();
                assert!(b.is_power_of_two() && b <= MAX_BATCH, "{b}");
                let (setup, per) = iterations(sc.spheres.len(), sc.environment.len(), traced, est, 40);
                assert!(setup + per * b as u64 <= budget::LOOP_LIMIT);
                supported(sc).unwrap();
                if let Err(e) = lobefit::export::shaders::module_of(&source(sc, est)) {
                    panic!("{} {est:?}: {e}", sc.name);
                }
            }
        }
        let m = lobefit::pipelines::meunier::render::scene("glossy").unwrap();
        for qmc in [false, true] {
            if let Err(e) = lobefit::export::shaders::module_of(&source_light(&m, 15, 1, qmc)) {
                panic!("light, qmc {qmc}: {e}");
            }
        }
        // A height field and meshes under a spherical light, and a height field past
        // HF_MAX_N samples a side.
        let mut lit_terrain = lobefit::pipelines::meunier::render::scene("fig13").unwrap();
        lit_terrain.heightfield = whale.heightfield.clone();
        let lit = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/meshes/meunier-bunny.json");
        let lit_bunny = lobefit::pipelines::meunier::render::scene(lit).unwrap();
        for sc in [&lit_terrain, &lit_bunny] {
            supported(sc).unwrap();
            let traced = hf_iterations(sc) + mesh_iterations(sc);
            for est in [Estimator::Plain, Estimator::Qmc] {
                let b = batch_size_light(sc.spheres.len(), 1, traced, est).unwrap();
                assert!(b.is_power_of_two() && b <= MAX_BATCH, "{b}");
                if let Err(e) = lobefit::export::shaders::module_of(&source_light(sc, 15, 1, est.qmc())) {
                    panic!("{} {est:?}: {e}", sc.name);
                }
            }
        }
        let mut big = whale.clone();
        let n = HF_MAX_N + 1;
        let hf = lobefit::pipelines::scene::HeightField::new(n, 8.0, vec![0.0; n * n]).unwrap();
        big.heightfield = Some((hf, 0));
        let e = supported(&big).unwrap_err();
        assert!(e.contains("more than 2049 samples a side"), "{e}");
        assert!(batch_size(70_000, 1, 0, Estimator::Plain, 0).is_err());
        // The estimators' arguments: the hybrid takes one integrand a pixel, the
        // others none, and a spherical light neither control variate.
        // An SH sky: its kernel validates with plain and qmc, and refuses the rest.
        let sky_sh = lobefit::pipelines::shexp::render::scene(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/scenes/shexp-whale-sh.json"
        ))
        .unwrap();
        supported(&sky_sh).unwrap();
        assert_eq!(sh_order(&sky_sh), 3);
        for est in [Estimator::Plain, Estimator::Qmc] {
            check_estimator(&sky_sh, est, None, 5).unwrap();
            let traced = hf_iterations(&sky_sh) + sh_loops(3);
            batch_size(sky_sh.spheres.len(), 0, traced, est, 0).unwrap();
            if let Err(e) = lobefit::export::shaders::module_of(&source(&sky_sh, est)) {
                panic!("SH sky {est:?}: {e}");
            }
        }
        for est in [Estimator::CvMis, Estimator::QmcCvMis] {
            let e = check_estimator(&sky_sh, est, None, 5).unwrap_err();
            assert!(e.contains("an SH environment"), "{e}");
        }
        let (sh, isg) = (Some((Estimator::Hybrid, 5)), Some((Estimator::HybridIsg, 5)));
        check_estimator(&whale, Estimator::Hybrid, sh, 5).unwrap();
        check_estimator(&sc, Estimator::HybridIsg, isg, 5).unwrap();
        check_estimator(&whale, Estimator::CvMis, None, 5).unwrap();
        for (sc, est, cv, what) in [
            (&whale, Estimator::Hybrid, None, "needs the pipeline's integrand"),
            (
                &whale,
                Estimator::Hybrid,
                Some((Estimator::Hybrid, 4)),
                "4 integrands for 5 pixels",
            ),
            (
                &sc,
                Estimator::HybridIsg,
                sh,
                "hybrid-isg takes no integrands of hybrid",
            ),
            (&whale, Estimator::QmcCvMis, sh, "qmc-cv-mis takes no integrand"),
            (&m, Estimator::HybridIsg, None, "plain or qmc only"),
            (&m, Estimator::CvMis, None, "plain or qmc only"),
        ] {
            let e = check_estimator(sc, est, cv, 5).unwrap_err();
            assert!(e.contains(what), "{est:?}: {e}");
        }
    }

    /// A scene lit by a map: its kernel validates with plain and qmc and fits the loop
    /// budget with the map's search; the control variates are refused by name; the
    /// map's data are its luminance and running sums, non-decreasing to exactly 1, whose
    /// differences (the probabilities the kernel draws with) sum to 1 and follow
    /// luminance × solid angle. The device's agreement with the CPU's `reference_map`
    /// (z scores, `lobefit-gpu mc`) is checked in .ci/run.
    #[test]
    fn a_map_scene_validates_and_its_sums_are_its_sampler() {
        let sc = lobefit::pipelines::isg::render::scene(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../assets/envmaps/isg-sky.json"
        ))
        .unwrap();
        let m = sc.environment_map.as_ref().unwrap();
        supported(&sc).unwrap();
        assert!(kernel_sgs(&sc).is_empty() && !sc.environment.is_empty());
        let n = m.map.width * m.map.height;
        assert_eq!(map_iterations(&sc), 18, "{n} texels: 17 halvings and the exit");
        for est in [Estimator::Plain, Estimator::Qmc] {
            check_estimator(&sc, est, None, 5).unwrap();
            let traced = hf_iterations(&sc) + mesh_iterations(&sc) + map_iterations(&sc);
            batch_size(sc.spheres.len(), 0, traced, est, 0).unwrap();
            if let Err(e) = lobefit::export::shaders::module_of(&source(&sc, est)) {
                panic!("map {est:?}: {e}");
            }
        }
        for est in [Estimator::CvMis, Estimator::QmcCvMis, Estimator::HybridIsg] {
            let e = check_estimator(&sc, est, None, 5).unwrap_err();
            assert!(e.contains("is lit by a map: plain or qmc only"), "{e}");
        }
        let data = map_inputs(&sc);
        assert_eq!(data.len(), 2 * n);
        let (lum, sums) = data.split_at(n);
        assert_eq!(sums[n - 1], 1.0);
        assert!(sums.windows(2).all(|w| w[0] <= w[1]) && sums[0] >= 0.0);
        // The brightest texel (the sun): its probability is its share of luminance ×
        // solid angle, to f32 rounding.
        let k = (0..n).max_by(|&a, &b| lum[a].total_cmp(&lum[b])).unwrap();
        let p = f64::from(sums[k] - sums[k - 1]);
        let want = m.texel_luminance()[k] * m.map.solid_angle(k / m.map.width) / m.total();
        assert!((p / want - 1.0).abs() < 1e-3, "{p} {want}");
        assert!(map_inputs(&lobefit::pipelines::isg::render::scene("fig12").unwrap()).is_empty());
    }

    /// A map too bright for the kernel's f32 sums (texels of 2^100 ≈ 1.3e30, whose
    /// samples' squares overflow f32) never reaches the device: its fitted lobes pass
    /// MAX_RADIANCE, so the scene is refused at load, naming it.
    #[test]
    fn a_map_too_bright_for_f32_is_refused_before_the_device() {
        let d = tempfile::tempdir().unwrap();
        let mut f = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n".to_vec();
        for _ in 0..16 * 8 {
            f.extend([128u8, 128, 128, 229]);
        }
        std::fs::write(d.path().join("bright.hdr"), &f).unwrap();
        let mut v: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/envmaps/isg-sky.json")).unwrap(),
        )
        .unwrap();
        v["environment"] = serde_json::json!({"map": "bright.hdr", "sgs": 2});
        let path = d.path().join("bright.json");
        std::fs::write(&path, v.to_string()).unwrap();
        let e = lobefit::pipelines::load_for_any(path.to_str().unwrap()).unwrap_err();
        assert!(e.contains("isg: ") && e.contains("MAX_RADIANCE"), "{e}");
    }

    /// `mc --estimator hybrid` without `--export` is refused by name before any
    /// device is opened; an SH sky refuses the control variate by name.
    #[test]
    fn hybrid_without_an_export_and_cv_under_an_sh_sky_are_errors() {
        use clap::Parser as _;
        let a = Args::try_parse_from(["mc", "--scene", "whale", "--width", "8", "--estimator", "hybrid"]).unwrap();
        let e = run(a).err().unwrap();
        assert!(e.contains("needs --export DIR"), "{e}");
        let sky_sh = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/scenes/shexp-whale-sh.json");
        let a = Args::try_parse_from(["mc", "--scene", sky_sh, "--width", "8", "--estimator", "cv-mis"]).unwrap();
        let e = run(a).err().unwrap();
        assert!(e.contains("an SH environment"), "{e}");
    }

    /// Agreement of two estimates: equal means give z = 0; a shift of two standard
    /// errors gives mean z 2/√2; where the standard errors vanish, a difference of f32
    /// rounding (1e-7 of the value) stays within one z, and 1e-5 does not.
    #[test]
    fn agreement_in_standard_errors() {
        let e = |mean, std_error| Estimate {
            mean,
            std_error,
            samples: 4,
        };
        let (mz, mz2, far) = agreement(&[e(1.0, 1.0), e(2.0, 1.0)], &[e(1.0, 1.0), e(2.0, 1.0)], F32_FLOOR);
        assert_eq!((mz, mz2, far), (0.0, 0.0, 0.0));
        let (mz, _, _) = agreement(&[e(3.0, 1.0)], &[e(1.0, 1.0)], F32_FLOOR);
        assert!((mz - 2.0 / 2f64.sqrt()).abs() < 1e-9);
        let (mz, _, _) = agreement(&[e(0.6 * (1.0 + 1e-7), 1e-9)], &[e(0.6, 1e-9)], F32_FLOOR);
        assert!(mz.abs() < 1.0, "{mz}");
        let (mz, _, _) = agreement(&[e(0.6 * (1.0 + 1e-5), 1e-9)], &[e(0.6, 1e-9)], F32_FLOOR);
        assert!(mz > 4.0, "{mz}");
    }

    /// The direction numbers make each dimension's first 2^m points one per interval
    /// of length 2^−m, and dimensions 0 and 1 a (0, m, 2)-net: every box of 2^a × 2^b
    /// cells (a + b = m) holds one point. Checked unscrambled (the scramble permutes
    /// these intervals).
    #[test]
    fn sobol_points_are_nets() {
        let dirs = sobol_directions();
        let sobol = |i: u32, d: usize| {
            (0..32)
                .filter(|b| i >> b & 1 == 1)
                .fold(0u32, |x, b| x ^ dirs[32 * d + b])
        };
        for m in 1..=10u32 {
            let n = 1u32 << m;
            for d in 0..4 {
                let mut cells: Vec<u32> = (0..n).map(|i| sobol(i, d) >> (32 - m)).collect();
                cells.sort_unstable();
                assert_eq!(cells, (0..n).collect::<Vec<_>>(), "dim {d}, 2^{m} points");
            }
            for a in 0..=m {
                let b = m - a;
                let mut boxes: Vec<(u32, u32)> = (0..n)
                    .map(|i| {
                        let (x, y) = (sobol(i, 0), sobol(i, 1));
                        (
                            if a == 0 { 0 } else { x >> (32 - a) },
                            if b == 0 { 0 } else { y >> (32 - b) },
                        )
                    })
                    .collect();
                boxes.sort_unstable();
                boxes.dedup();
                assert_eq!(boxes.len(), n as usize, "2^{a} × 2^{b} boxes of 2^{m} points");
            }
        }
    }
}
