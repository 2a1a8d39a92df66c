//! Γ_L, the prefiltered environment (Iwasaki et al. eq. 10; docs/environment.md,
//! "Γ_L, the prefiltered map"): an equirectangular map convolved with a spherical
//! Gaussian G(ω; a, λ) = exp(λ(a·ω − 1)) on a ladder of sharpness λ, written as a
//! lobefit table (kind [`KIND`]) of three axes (λ, θ, φ) and three channels (R, G, B).
//!
//! **What is stored** is the map's mean radiance under the lobe,
//! Γ̄(a, λ) = ∫ L G dω / ∫ G dω, with ∫ G dω = 2π(1 − e^{−2λ})/λ in closed form: the
//! value stays in the map's units at every λ, so the table interpolates well across
//! the ladder, and ∫ L G dω (the paper's μ Γ_L) is Γ̄ times that closed form.
//!
//! **The build** is direct quadrature of the map's texels, each a constant radiance
//! over its exact solid angle. Per level, the map is box-filtered (energy-exact) down
//! while its texels stay below 0.1 σ (σ = 1/√λ, the lobe's width), each texel then
//! taken as its energy at its centroid, per channel; where the map's own texels are wider, each is split into cells
//! of at most 0.3 σ, each integrated by the 2 × 2 Gauss–Legendre rule. Texels where
//! G < e^{−12} are skipped. The nodes are the map's texel corners, at most
//! [`MAX_NODES`] per side (a coarser grid for larger maps).
//!
//! **The check** ([`check`]) is independent of the build: every texel of the original
//! map integrated against G by Gauss–Legendre in (cos θ, φ) of an order set by the
//! lobe's width, at random (a, λ), half of them drawn by the map's luminance (where
//! its features are).

use std::f64::consts::{PI, TAU};

use lobefit_tables::format::{self, Axis, Channel, Diagnostics, Encoding, FitInfo, Mapping, Meta, Placement, Storage};
use lobefit_tables::glam::DVec3;
use lobefit_tables::Table;
use rayon::prelude::*;

use crate::envmap::EnvMap;

/// The table's kind.
pub const KIND: &str = "env-prefilter";
/// The kind's version.
pub const VERSION: u32 = 1;
/// Levels per doubling of λ: the ladder is λ_k = 2^(k / `PER_OCTAVE`).
pub const PER_OCTAVE: u32 = 2;
/// The ladder's levels: λ from 1 to [`LAMBDA_MAX`].
pub const LEVELS: u32 = 13 * PER_OCTAVE + 1;
/// The ladder's top (the ISG tables' γ reach 10⁴).
pub const LAMBDA_MAX: f64 = 8192.0;

/// λ of level `k`.
pub fn level(k: u32) -> f64 {
    (k as f64 / PER_OCTAVE as f64).exp2()
}
/// The box-filtered texels' largest size, relative to the lobe's width σ = 1/√λ:
/// averaging the radiance over a texel costs about (h/σ)²/12 of the texel's share
/// where G curves, 1e-3 at 0.1.
const H_BOX: f64 = 0.1;
/// The Gauss–Legendre cells' largest size, relative to σ (the 2 × 2 rule's error on a
/// Gaussian is about (h/σ)⁴/4320: 2e-6).
const H_CELL: f64 = 0.3;
/// The node grid's most rows of cells (columns: twice as many).
pub const MAX_NODES: usize = 128;
/// Texels where G < e^{−CUT} are skipped (the build) or not integrated (the check):
/// the lobe's mass beyond is e^{−CUT} ≈ 6e-6 of it.
const CUT: f64 = 12.0;

/// ∫ exp(λ(a·ω − 1)) dω over the sphere: 2π(1 − e^{−2λ})/λ.
pub fn sg_integral(lambda: f64) -> f64 {
    TAU * (-(-2.0 * lambda).exp_m1()) / lambda
}

/// Polar angle θ ∈ [0, π] and azimuth φ ∈ [0, 2π) of unit `d` (z up, the maps'
/// convention).
pub fn angles(d: DVec3) -> (f64, f64) {
    (d.z.clamp(-1.0, 1.0).acos(), d.y.atan2(d.x).rem_euclid(TAU))
}

fn dir(theta: f64, phi: f64) -> DVec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    DVec3::new(st * cp, st * sp, ct)
}

/// One level's source: the map box-filtered by a power of two (energy kept) while its
/// texels stay within [`H_BOX`] σ, each texel then taken as its energy at its
/// centroid; or, where the map's
/// own texels are wider than that, the map itself with each texel split into `n` × `n`
/// cells no wider than [`H_CELL`] σ, each integrated by the 2 × 2 Gauss–Legendre rule.
struct Source {
    width: usize,
    height: usize,
    rgb: Vec<[f64; 3]>,
    /// Cells per texel side (0: box-filtered texels, each taken at its centroids).
    n: usize,
    /// Box-filtered texels: per channel the energy ∫ L dω, and the unit direction of
    /// the luminance's centroid ∫ Y ω dω. A bright spot (a sun) keeps its place inside
    /// the merged texel, so the first-order error of moving it to the texel's centre,
    /// about (offset/σ)·(its share), is gone; what remains is second order (and the
    /// channels' centroids' spread, where colour changes inside the texel).
    moments: Vec<([f64; 3], DVec3)>,
}

impl Source {
    fn new(map: &EnvMap, lambda: f64) -> Source {
        let sigma = lambda.powf(-0.5);
        let h = PI / map.height as f64;
        if h > H_BOX * sigma {
            let n = (h / (H_CELL * sigma)).ceil().max(1.0) as usize;
            return Source {
                width: map.width,
                height: map.height,
                rgb: map.rgb.clone(),
                n,
                moments: Vec::new(),
            };
        }
        let mut f = 1;
        while h * (2 * f) as f64 <= H_BOX * sigma
            && map.width.is_multiple_of(2 * f)
            && map.height.is_multiple_of(2 * f)
            && map.height / (2 * f) >= 2
        {
            f *= 2;
        }
        let (width, height) = (map.width / f, map.height / f);
        let mut rgb = vec![[0.0; 3]; width * height];
        let mut moments = vec![([0.0; 3], DVec3::Z); width * height];
        for v in 0..height {
            for u in 0..width {
                let (mut s, mut w) = ([0.0; 3], 0.0);
                let mut m = DVec3::ZERO;
                for vv in v * f..(v + 1) * f {
                    let dw = map.solid_angle(vv);
                    for uu in u * f..(u + 1) * f {
                        let l = map.rgb[vv * map.width + uu];
                        for c in 0..3 {
                            s[c] += l[c] * dw;
                        }
                        // Y > 0 wherever a channel is (texels are never negative).
                        let y = 0.2126 * l[0] + 0.7152 * l[1] + 0.0722 * l[2];
                        m += y * dw * map.direction(uu, vv);
                        w += dw;
                    }
                }
                rgb[v * width + u] = s.map(|x| x / w);
                moments[v * width + u] = (s, m.try_normalize().unwrap_or(map.direction(u * f, v * f)));
            }
        }
        Source {
            width,
            height,
            rgb,
            n: 0,
            moments,
        }
    }

    /// ∫ L G dω towards unit `a` at `lambda`, per channel.
    fn convolve(&self, a: DVec3, lambda: f64) -> [f64; 3] {
        let (ta, pa) = angles(a);
        let reach = if CUT / lambda >= 2.0 {
            PI
        } else {
            (1.0 - CUT / lambda).acos()
        };
        let (hv, hu) = (PI / self.height as f64, TAU / self.width as f64);
        let v0 = ((ta - reach) / hv).floor().max(0.0) as usize;
        let v1 = (((ta + reach) / hv).ceil() as usize).min(self.height);
        // The cap's azimuthal half-width, where it holds no pole.
        let half = if ta - reach <= 0.0 || ta + reach >= PI {
            PI
        } else {
            let s = reach.sin() / ta.sin();
            if s >= 1.0 {
                PI
            } else {
                s.asin() + hu
            }
        };
        let (u_lo, count) = if half >= PI {
            (0i64, self.width as i64)
        } else {
            let lo = ((pa - half) / hu).floor() as i64;
            let hi = ((pa + half) / hu).ceil() as i64;
            (lo, (hi - lo + 1).min(self.width as i64))
        };
        if self.n == 0 {
            let mut acc = [0.0; 3];
            for v in v0..v1 {
                for du in 0..count {
                    let u = (u_lo + du).rem_euclid(self.width as i64) as usize;
                    let (e, d) = self.moments[v * self.width + u];
                    if e != [0.0; 3] {
                        let g = (lambda * (d.dot(a) - 1.0)).exp();
                        for c in 0..3 {
                            acc[c] += e[c] * g;
                        }
                    }
                }
            }
            return acc;
        }
        // Per texel side: (offset within the texel in [0, 1], weight), one point for
        // the midpoint rule, 2 per cell for Gauss–Legendre.
        let g = 0.5 / 3f64.sqrt();
        let nodes: Vec<(f64, f64)> = if self.n == 0 {
            vec![(0.5, 1.0)]
        } else {
            let n = self.n as f64;
            (0..self.n)
                .flat_map(|k| [((k as f64 + 0.5 - g) / n, 0.5 / n), ((k as f64 + 0.5 + g) / n, 0.5 / n)])
                .collect()
        };
        // cos φ, sin φ of every column node in the window, and whether it lies beyond
        // the cap's azimuthal reach (a cell wide of margin).
        let cell = if self.n > 0 { hu / self.n as f64 } else { hu };
        let mut cols: Vec<(usize, f64, f64, f64, bool)> = Vec::with_capacity(count as usize * nodes.len());
        for du in 0..count {
            let u = (u_lo + du).rem_euclid(self.width as i64) as usize;
            for &(ou, wu) in &nodes {
                let phi = hu * (u as f64 + ou);
                let off = (phi - pa).rem_euclid(TAU);
                let far = half < PI && off.min(TAU - off) > half - hu + cell;
                let (sp, cp) = phi.sin_cos();
                cols.push((u, cp, sp, wu, far));
            }
        }
        let per = nodes.len();
        let gl = self.n > 0;
        let mut acc = [0.0; 3];
        for v in v0..v1 {
            for &(ov, wv) in &nodes {
                let theta = hv * (v as f64 + ov);
                if (theta - ta).abs() > reach + cell {
                    continue;
                }
                // The row's solid angle element: exact for the midpoint rule on a whole
                // texel (its band's area), sin θ dθ at the node for Gauss–Legendre.
                let dw = if gl {
                    theta.sin() * hv * wv * hu
                } else {
                    hu * ((hv * v as f64).cos() - (hv * (v + 1) as f64).cos())
                };
                let (st, ct) = theta.sin_cos();
                let (sx, sy, cz) = (st * a.x, st * a.y, ct * a.z - 1.0);
                for texel in cols.chunks_exact(per) {
                    let l = self.rgb[v * self.width + texel[0].0];
                    if l == [0.0; 3] {
                        continue;
                    }
                    let mut s = 0.0;
                    for &(_, cp, sp, wu, far) in texel {
                        if !far {
                            s += wu * (lambda * (cp * sx + sp * sy + cz)).exp();
                        }
                    }
                    for c in 0..3 {
                        acc[c] += dw * s * l[c];
                    }
                }
            }
        }
        acc
    }
}

/// The node grid's rows and columns of cells for `map`: its own, at most
/// [`MAX_NODES`] × 2 [`MAX_NODES`].
pub fn grid(map: &EnvMap) -> (usize, usize) {
    (map.height.min(MAX_NODES), map.width.min(2 * MAX_NODES))
}

/// The prefiltered map of `map` on the ladder, as a table: with R × C from [`grid`],
/// nodes at θ = π j / R (j = 0 ..= R) and φ = 2π i / C (i = 0 ..= C, the last
/// repeating the first), at every λ of the ladder. Returns the table and the build's
/// wall time per level (s).
pub fn build(map: &EnvMap, name: &str) -> Result<(Table, Vec<f64>), String> {
    let (rows_n, cols_n) = grid(map);
    let (nt, np) = (rows_n + 1, cols_n + 1);
    let mut payload = Vec::with_capacity(LEVELS as usize * nt * np * 3);
    let mut times = Vec::new();
    for k in 0..LEVELS {
        let lambda = level(k);
        let t0 = std::time::Instant::now();
        let src = Source::new(map, lambda);
        let norm = 1.0 / sg_integral(lambda);
        let rows: Vec<Vec<[f64; 3]>> = (0..nt)
            .into_par_iter()
            .map(|j| {
                let theta = PI * j as f64 / rows_n as f64;
                if j == 0 || j == rows_n {
                    // The pole: one value for every φ.
                    let g = src.convolve(dir(theta, 0.0), lambda);
                    return vec![g; np];
                }
                let mut row: Vec<[f64; 3]> = (0..cols_n)
                    .map(|i| src.convolve(dir(theta, TAU * i as f64 / cols_n as f64), lambda))
                    .collect();
                row.push(row[0]);
                row
            })
            .collect();
        for row in rows {
            for g in row {
                payload.extend(g.map(|x| (x * norm) as f32));
            }
        }
        times.push(t0.elapsed().as_secs_f64());
    }
    let axis = |name: &str, unit: &str, lo: f64, hi: f64, mapping: Mapping, count: usize| Axis {
        name: name.into(),
        unit: unit.into(),
        lo,
        hi,
        mapping,
        count: count as u32,
        placement: Placement::Endpoints,
    };
    let channel = |c: &str| Channel {
        name: c.into(),
        unit: "the map's radiance".into(),
        encoding: Encoding::Linear,
        description: format!(
            "the map's {c} channel averaged under the SG of sharpness λ centred on (θ, φ): ∫ L G dω / ∫ G dω"
        ),
    };
    let settings: Vec<(String, String)> = vec![
        ("map".into(), name.into()),
        ("size".into(), format!("{}x{}", map.width, map.height)),
        ("ladder".into(), format!("2^(k/{PER_OCTAVE}), k = 0..{}", LEVELS - 1)),
        ("h_box".into(), H_BOX.to_string()),
        ("h_cell".into(), H_CELL.to_string()),
        ("cut".into(), CUT.to_string()),
    ];
    let method = "direct quadrature of the map's texels times the SG (box-filtered to 0.1 of the lobe's width and the midpoint rule, or texels split to 0.3 of it and 2x2 Gauss-Legendre)";
    let entries = (LEVELS as usize * nt * np) as u64;
    let meta = Meta {
        kind: KIND.into(),
        table_version: VERSION,
        generator: format!("lobefit {}", env!("CARGO_PKG_VERSION")),
        description: "Γ_L, an equirectangular map (z up, row 0 the zenith, φ from +x towards +y) prefiltered by spherical Gaussians exp(λ(a·ω − 1)): per (λ, θ, φ) of a, the map's mean radiance under the lobe. Multiply by 2π(1 − e^(−2λ))/λ for ∫ L G dω. Interpolate linearly in ln λ, θ and φ; φ's last node repeats its first.".into(),
        axes: vec![
            axis("lambda", "1", 1.0, LAMBDA_MAX, Mapping::Log, LEVELS as usize),
            axis("theta", "rad", 0.0, PI, Mapping::Linear, nt),
            axis("phi", "rad", 0.0, TAU, Mapping::Linear, np),
        ],
        channels: vec![channel("r"), channel("g"), channel("b")],
        storage: Storage::F32,
        fit: FitInfo {
            method: method.into(),
            settings_hash: format::settings_hash(method, &settings),
            settings,
        },
        diagnostics: Diagnostics {
            residual_meaning: "none: a quadrature, not a fit".into(),
            entries,
            converged: entries,
            max_residual: 0.0,
            mean_residual: 0.0,
            max_iterations: 0,
            per_entry: None,
        },
        thresholds: vec![],
    };
    let bytes = format::encode(&meta, &payload)?;
    let table = Table::from_bytes(&bytes).map_err(|e| e.to_string())?;
    Ok((table, times))
}

/// Γ̄ at unit `a` and `lambda` ∈ [1, 8192] from a prefiltered table (RGB, the map's
/// units): bilinear in (θ, φ) on four levels of the ladder around `lambda`, cubic
/// (Lagrange) in log₂ λ between them, clamped at 0 (radiance is never negative). Linear
/// interpolation across the ladder's factor-2 steps errs by 1–2 % where the map is
/// smooth ([`lookup_linear`]; docs/environment.md).
pub fn lookup(table: &Table, a: DVec3, lambda: f64) -> Result<[f64; 3], String> {
    table.expect_kind(KIND, VERSION).map_err(|e| e.to_string())?;
    let top = (LEVELS - 1) as f64;
    let t = lambda.log2() * PER_OCTAVE as f64;
    if !(0.0..=top).contains(&t) {
        return Err(format!("λ = {lambda} is outside the ladder's [1, {LAMBDA_MAX}]"));
    }
    let (theta, phi) = angles(a);
    let j0 = (t.floor() - 1.0).clamp(0.0, top - 3.0);
    let mut out = [0.0; 3];
    for i in 0..4 {
        let ji = j0 + i as f64;
        // Lagrange's weight of node ji among j0 ..= j0 + 3 at t.
        let w: f64 = (0..4)
            .filter(|&k| k != i)
            .map(|k| (t - (j0 + k as f64)) / (ji - (j0 + k as f64)))
            .product();
        let mut v = [0.0; 3];
        table
            .interpolate(&[level(ji as u32), theta, phi], &mut v)
            .map_err(|e| e.to_string())?;
        for c in 0..3 {
            out[c] += w * v[c];
        }
    }
    Ok(out.map(|x| x.max(0.0)))
}

/// The table as a GPU texture for the shader library's `lf_prefiltered`
/// (tables/shaders/prefilter.wgsl; docs/environment.md, "Γ_L on the GPU"): a 2D array
/// texture, one layer per level of the ladder (λ_k = 2^(k / [`PER_OCTAVE`])), x the φ
/// nodes (the last repeating the first, so clamp-to-edge filtering needs no wrap), y
/// the θ nodes, RGBA: the table's R, G, B and their luminance (Rec. 709) in A, the
/// channel the ISG's eq. 9 reads for scalar radiance. Texel (i, j) of a layer is the
/// node itself: the texture's values are the table's, rounded to the storage.
pub fn texture(table: &Table, name: &str) -> Result<lobefit_core::export::Texture, String> {
    table.expect_kind(KIND, VERSION).map_err(|e| e.to_string())?;
    let axes = &table.meta().axes;
    let (levels, nt, np) = (axes[0].count, axes[1].count, axes[2].count);
    if levels != LEVELS {
        return Err(format!("a prefiltered table has {LEVELS} levels; this one {levels}"));
    }
    let data = table
        .values()
        .chunks_exact(3)
        .flat_map(|c| [c[0], c[1], c[2], 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2]])
        .collect();
    let tex = lobefit_core::export::Texture {
        name: name.into(),
        dimension: 2,
        width: np,
        height: nt,
        depth: 1,
        layers: levels,
        channels: 4,
        data,
    };
    tex.validate()?;
    Ok(tex)
}

/// [`lookup`] with linear interpolation in ln λ between the two neighbouring levels
/// (what trilinear filtering of the levels as a mip chain gives).
pub fn lookup_linear(table: &Table, a: DVec3, lambda: f64) -> Result<[f64; 3], String> {
    table.expect_kind(KIND, VERSION).map_err(|e| e.to_string())?;
    let (theta, phi) = angles(a);
    let mut out = [0.0; 3];
    table
        .interpolate(&[lambda, theta, phi], &mut out)
        .map_err(|e| e.to_string())?;
    Ok(out)
}

/// The reference: Γ̄ of `map` at unit `a` and `lambda`, every texel integrated against
/// G by Gauss–Legendre in (cos θ, φ) (module doc: independent of the build). A texel
/// wider than 2σ is split into cells no wider; each cell takes an order-m product rule,
/// m from 2 (the lobe far wider than the cell) to 6.
pub fn reference(map: &EnvMap, a: DVec3, lambda: f64) -> [f64; 3] {
    let sigma = lambda.powf(-0.5);
    let (hv, hu) = (PI / map.height as f64, TAU / map.width as f64);
    let split = (hv.max(hu) / (2.0 * sigma)).ceil().max(1.0) as usize;
    let (cv, cu) = (hv / split as f64, hu / split as f64);
    let m = ((3.0 * cv.max(cu) / sigma).ceil() as usize + 1).clamp(2, 6);
    let (x, w) = lobefit_tables::gaunt::gauss_legendre(m);
    let reach = if CUT / lambda >= 2.0 {
        PI
    } else {
        (1.0 - CUT / lambda).acos()
    };
    let near = |d: DVec3, half_diag: f64| d.dot(a).clamp(-1.0, 1.0).acos() - half_diag <= reach;
    let texel_diag = 0.5 * (hv * hv + hu * hu).sqrt();
    let cell_diag = 0.5 * (cv * cv + cu * cu).sqrt();
    let mut acc = [0.0; 3];
    for v in 0..map.height {
        for u in 0..map.width {
            let l = map.rgb[v * map.width + u];
            if l == [0.0; 3] || !near(map.direction(u, v), texel_diag) {
                continue;
            }
            let mut s = 0.0;
            for i in 0..split {
                let (t0, t1) = (hv * v as f64 + cv * i as f64, hv * v as f64 + cv * (i + 1) as f64);
                let (c0, c1) = (t0.cos(), t1.cos());
                for j in 0..split {
                    let p0 = hu * u as f64 + cu * j as f64;
                    if split > 1 && !near(dir(0.5 * (t0 + t1), p0 + 0.5 * cu), cell_diag) {
                        continue;
                    }
                    let mut q = 0.0;
                    for (xi, wi) in x.iter().zip(&w) {
                        let ct = 0.5 * (c0 + c1) + 0.5 * (c0 - c1) * xi;
                        let st = (1.0 - ct * ct).max(0.0).sqrt();
                        for (xj, wj) in x.iter().zip(&w) {
                            let phi = p0 + 0.5 * cu * (1.0 + xj);
                            let d = DVec3::new(st * phi.cos(), st * phi.sin(), ct);
                            q += wi * wj * (lambda * (d.dot(a) - 1.0)).exp();
                        }
                    }
                    s += q * 0.25 * (c0 - c1) * cu;
                }
            }
            for c in 0..3 {
                acc[c] += s * l[c];
            }
        }
    }
    acc.map(|v| v / sg_integral(lambda))
}

/// One checked point: λ, the direction, the table's and the reference's luminance.
#[derive(Debug, Clone, Copy)]
pub struct CheckPoint {
    /// Sharpness.
    pub lambda: f64,
    /// Direction.
    pub a: DVec3,
    /// The table's Γ̄ (luminance, Rec. 709), by [`lookup`].
    pub table: f64,
    /// The same by [`lookup_linear`].
    pub linear: f64,
    /// The reference's.
    pub reference: f64,
    /// Largest relative error over the three channels (each against its reference,
    /// channels below 1e-6 of the luminance skipped).
    pub worst_channel: f64,
}

/// The table against [`reference`] at `count` random (a, λ): λ log-uniform over the
/// ladder, a uniform on the sphere for half of them, drawn by the map's luminance ×
/// solid angle for the other half. Seeded.
pub fn check(map: &EnvMap, table: &Table, count: usize, seed: u64) -> Result<Vec<CheckPoint>, String> {
    let lum = |c: [f64; 3]| 0.2126 * c[0] + 0.7152 * c[1] + 0.0722 * c[2];
    let mut cdf = Vec::with_capacity(map.rgb.len());
    let mut total = 0.0;
    for v in 0..map.height {
        let dw = map.solid_angle(v);
        for u in 0..map.width {
            total += lum(map.rgb[v * map.width + u]) * dw;
            cdf.push(total);
        }
    }
    let mut rng = lobefit_core::rng::Rng::new(seed);
    let lmax = LAMBDA_MAX.ln();
    let points: Vec<(DVec3, f64)> = (0..count)
        .map(|i| {
            let lambda = rng.range(0.0, lmax).exp();
            let a = if i % 2 == 0 || total <= 0.0 {
                let z = rng.range(-1.0, 1.0);
                let p = rng.range(0.0, TAU);
                let r = (1.0 - z * z).sqrt();
                DVec3::new(r * p.cos(), r * p.sin(), z)
            } else {
                let t = rng.uniform() * total;
                let k = cdf.partition_point(|&c| c < t).min(cdf.len() - 1);
                let (u, v) = (k % map.width, k / map.width);
                let theta = PI * (v as f64 + rng.uniform()) / map.height as f64;
                let phi = TAU * (u as f64 + rng.uniform()) / map.width as f64;
                dir(theta, phi)
            };
            (a, lambda)
        })
        .collect();
    points
        .par_iter()
        .map(|&(a, lambda)| {
            let t = lookup(table, a, lambda)?;
            let tl = lookup_linear(table, a, lambda)?;
            let r = reference(map, a, lambda);
            let worst = (0..3)
                .filter(|&c| r[c] > 1e-6 * lum(r))
                .map(|c| (t[c] / r[c] - 1.0).abs())
                .fold(0.0, f64::max);
            Ok(CheckPoint {
                lambda,
                a,
                table: lum(t),
                linear: lum(tl),
                reference: lum(r),
                worst_channel: worst,
            })
        })
        .collect()
}

/// The build against [`reference`] at `count` random nodes of the table (a random
/// level and node, so no lookup is involved): per node the largest relative error
/// over the channels (channels below 1e-6 of the luminance skipped). Seeded.
pub fn check_nodes(map: &EnvMap, table: &Table, count: usize, seed: u64) -> Result<Vec<(f64, f64)>, String> {
    let (rows_n, cols_n) = grid(map);
    let mut rng = lobefit_core::rng::Rng::new(seed);
    let picks: Vec<(u32, usize, usize)> = (0..count)
        .map(|_| {
            let k = ((rng.uniform() * LEVELS as f64) as u32).min(LEVELS - 1);
            let j = ((rng.uniform() * (rows_n + 1) as f64) as usize).min(rows_n);
            let i = ((rng.uniform() * cols_n as f64) as usize).min(cols_n - 1);
            (k, j, i)
        })
        .collect();
    picks
        .par_iter()
        .map(|&(k, j, i)| {
            let node = table.node(&[k, j as u32, i as u32]).map_err(|e| e.to_string())?;
            let a = dir(PI * j as f64 / rows_n as f64, TAU * i as f64 / cols_n as f64);
            let r = reference(map, a, level(k));
            let y = 0.2126 * r[0] + 0.7152 * r[1] + 0.0722 * r[2];
            let e = (0..3)
                .filter(|&c| r[c] > 1e-6 * y)
                .map(|c| (node[c] as f64 / r[c] - 1.0).abs())
                .fold(0.0, f64::max);
            Ok((level(k), e))
        })
        .collect()
}

/// One λ band of the check.
#[derive(Debug, Clone)]
pub struct Band {
    /// "λ lo–hi".
    pub band: String,
    /// Points in it with a positive reference (a relative error is defined).
    pub points: usize,
    /// Points in it where the map is black under the lobe (reference 0), left out.
    pub black: usize,
    /// Median and max relative error of the luminance by [`lookup`] (`None`: no point).
    pub cubic: Option<(f64, f64)>,
    /// The same by [`lookup_linear`].
    pub linear: Option<(f64, f64)>,
    /// The largest relative error of a channel by [`lookup`].
    pub worst_channel: f64,
}

/// The check's summary per λ band.
pub fn summary(points: &[CheckPoint]) -> Vec<Band> {
    let bands: [(f64, f64); 4] = [(1.0, 8.0), (8.0, 64.0), (64.0, 512.0), (512.0, 8193.0)];
    let med_max = |mut e: Vec<f64>| {
        e.sort_by(f64::total_cmp);
        (!e.is_empty()).then(|| (e[e.len() / 2], e[e.len() - 1]))
    };
    bands
        .iter()
        .map(|&(lo, hi)| {
            let band: Vec<&CheckPoint> = points.iter().filter(|p| p.lambda >= lo && p.lambda < hi).collect();
            let inside: Vec<&CheckPoint> = band.iter().copied().filter(|p| p.reference > 0.0).collect();
            Band {
                band: format!("λ {lo:.0}–{:.0}", hi.min(8192.0)),
                points: inside.len(),
                black: band.len() - inside.len(),
                cubic: med_max(inside.iter().map(|p| (p.table / p.reference - 1.0).abs()).collect()),
                linear: med_max(inside.iter().map(|p| (p.linear / p.reference - 1.0).abs()).collect()),
                worst_channel: inside.iter().map(|p| p.worst_channel).fold(0.0, f64::max),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 32 × 16 map: a sky gradient and a bright 2 × 1-texel spot.
    fn small_map() -> EnvMap {
        let (w, h) = (32, 16);
        let mut rgb = Vec::new();
        for v in 0..h {
            for u in 0..w {
                let base = 0.2 + 0.8 * (1.0 - v as f64 / h as f64);
                let spot = if (u == 7 || u == 8) && v == 4 { 40.0 } else { 0.0 };
                rgb.push([base + spot, 0.9 * base + 0.5 * spot, 1.1 * base]);
            }
        }
        EnvMap::new(w, h, rgb).unwrap()
    }

    /// The closed form: a constant map gives back its radiance at every λ, from the
    /// build, the lookup and the reference; ∫ G dω matches quadrature.
    #[test]
    fn a_constant_map_is_its_own_prefilter() {
        let map = EnvMap::new(16, 8, vec![[0.5, 1.0, 2.0]; 128]).unwrap();
        for lambda in [1.0, 37.0, 5000.0] {
            let r = reference(&map, DVec3::new(0.3, -0.4, 0.866).normalize(), lambda);
            for (c, want) in [0.5, 1.0, 2.0].iter().enumerate() {
                assert!((r[c] / want - 1.0).abs() < 1e-6, "λ {lambda}: {r:?}");
            }
        }
        let (t, _) = build(&map, "const").unwrap();
        for lambda in [1.0, 3.0, 700.0, 8192.0] {
            for a in [
                DVec3::Z,
                -DVec3::Z,
                DVec3::new(0.6, 0.0, 0.8),
                DVec3::new(-0.1, -0.99, 0.05).normalize(),
            ] {
                let g = lookup(&t, a, lambda).unwrap();
                for (c, want) in [0.5, 1.0, 2.0].iter().enumerate() {
                    assert!((g[c] / want - 1.0).abs() < 2e-3, "λ {lambda} at {a}: {g:?}");
                }
            }
        }
        // ∫ G dω by a product rule in (cos θ, φ) about the lobe's axis.
        let (x, w) = lobefit_tables::gaunt::gauss_legendre(64);
        for lambda in [0.5, 10.0, 300.0] {
            let q: f64 = x
                .iter()
                .zip(&w)
                .map(|(c, wi)| wi * TAU * (lambda * (c - 1.0)).exp())
                .sum();
            assert!((q / sg_integral(lambda) - 1.0).abs() < 1e-9, "λ {lambda}");
        }
    }

    /// On a small map with a bright spot: at the nodes (every ladder λ, a spread of
    /// node directions) the build is within 1e-3 of the reference, the midpoint rule's
    /// promise; between nodes the bilinear lookup adds its own error, about
    /// (h/σ)²/8 for nodes h apart: on 16 rows (11°) under 5 % for λ ≤ 4, far more for
    /// sharper lobes (docs/environment.md gives the full maps').
    /// Out-of-ladder λ are errors.
    #[test]
    fn the_table_matches_quadrature_on_a_small_map() {
        let map = small_map();
        let (t, _) = build(&map, "small").unwrap();
        let (rows_n, cols_n) = grid(&map);
        let (nt, np) = (rows_n + 1, cols_n + 1);
        for k in 0..LEVELS {
            let lambda = level(k);
            for (j, i) in [(0, 0), (3, 7), (4, 8), (5, 8), (8, 20), (16, 3)] {
                let theta = PI * j as f64 / rows_n as f64;
                let phi = TAU * i as f64 / cols_n as f64;
                let node = t.node(&[k, j as u32, i as u32]).unwrap();
                let r = reference(&map, dir(theta, phi), lambda);
                for c in 0..3 {
                    let e = (node[c] as f64 / r[c] - 1.0).abs();
                    assert!(
                        e < 1e-3,
                        "λ {lambda}, node ({j}, {i}) of {nt} × {np}, channel {c}: {} against {}",
                        node[c],
                        r[c]
                    );
                }
            }
        }
        for p in check(&map, &t, 48, 7).unwrap() {
            assert!(p.table.is_finite() && p.table >= 0.0);
            let e = (p.table / p.reference - 1.0).abs();
            assert!(
                p.lambda > 4.0 || e < 0.05,
                "λ {} at {}: {} against {}",
                p.lambda,
                p.a,
                p.table,
                p.reference
            );
        }
        assert!(lookup(&t, DVec3::Z, 0.5).is_err());
        assert!(lookup(&t, DVec3::Z, 9000.0).is_err());
    }

    /// Where the map is black under a sharp lobe the reference is 0 and a relative
    /// error is undefined: the summary leaves those points out and counts them, and
    /// every figure it gives is finite (a band without points gives none).
    #[test]
    fn the_summary_is_finite_where_the_map_is_black() {
        let (w, h) = (16, 8);
        let rgb = (0..w * h)
            .map(|k| if k / w < h / 2 { [0.0; 3] } else { [1.0, 2.0, 0.5] })
            .collect();
        let map = EnvMap::new(w, h, rgb).unwrap();
        let (t, _) = build(&map, "half").unwrap();
        let points = check(&map, &t, 40, 3).unwrap();
        let bands = summary(&points);
        assert_eq!(bands.iter().map(|b| b.points + b.black).sum::<usize>(), 40);
        assert!(bands.iter().any(|b| b.black > 0), "{bands:?}");
        for b in &bands {
            for (m, x) in b.cubic.into_iter().chain(b.linear) {
                assert!(m.is_finite() && x.is_finite(), "{b:?}");
            }
            assert!(b.worst_channel.is_finite(), "{b:?}");
        }
    }
}
