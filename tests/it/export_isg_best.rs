//! isg-best exported as a GPU texture: the (γ, u) grid as one RGBA texture, with the
//! warp and the mirror about π/2 in the shader's f32 formulas. Meets the family's
//! target in f32 and f16 (both filters), checks from the files, and stays within it
//! right at the SG axis, where f32 `1 − sin x` would cancel.

use std::f64::consts::FRAC_PI_2;
use std::path::Path;

use lobefit::export::families::Emulated;
use lobefit::export::layout::{Filter, Sampler, WeightRounding};
use lobefit::export::manifest::Manifest;
use lobefit::export::run::{check_export, export, ExportOptions};
use lobefit::export::{formats, Format, Storage};
use lobefit::family::Checked;
use lobefit::fits::{registry, FitOptions};

fn opts(format: Format, storage: Storage) -> ExportOptions {
    ExportOptions {
        only: vec!["isg-best".into()],
        format,
        storage,
        scale: 1.0,
        allow_lossy: false,
    }
}

/// Exports, then asserts the manifest's manual-filter errors meet their targets and
/// that `check --export` re-measures every error, within its promise, from the files.
fn export_and_check(format: Format, storage: Storage, dir: &Path) -> Manifest {
    let m = export(&opts(format, storage), dir).unwrap_or_else(|e| panic!("{format} {storage}: {e}"));
    assert_eq!(m.families.len(), 1);
    let f = &m.families[0];
    assert_eq!(f.family, "isg-best");
    assert_eq!(f.inputs, ["gamma", "theta", "phi"]);
    assert_eq!(f.textures.len(), 1);
    let t = &f.textures[0];
    assert_eq!(t.dimension, 2);
    assert_eq!((t.extent[3], t.extent[4]), (1, 4), "one RGBA layer: a, b, c, d");
    let manual: Vec<_> = f.error.iter().filter(|e| e.filter == Filter::Manual).collect();
    assert!(!manual.is_empty());
    for e in f
        .error
        .iter()
        .filter(|e| e.filter == Filter::Manual || storage == Storage::F32)
    {
        assert!(
            e.meets_target(),
            "{format} {storage} {:?} {} {}: {} > {}",
            e.filter,
            e.output,
            e.metric,
            e.measured,
            e.target
        );
    }
    let checks = check_export(dir).unwrap_or_else(|e| panic!("{format} {storage}: {e}"));
    assert_eq!(checks.len(), f.error.len());
    for c in &checks {
        assert!(c.pass, "{format} {storage}: {c:?}");
        assert_eq!(c.now, c.entry.measured, "{c:?}");
    }
    m
}

#[test]
fn raw_f32_meets_the_target_and_checks() {
    let dir = tempfile::tempdir().unwrap();
    export_and_check(Format::Raw, Storage::F32, dir.path());
}

#[test]
fn raw_f16_meets_the_target_without_allow_lossy() {
    let dir = tempfile::tempdir().unwrap();
    let m = export_and_check(Format::Raw, Storage::F16, dir.path());
    // Half the bytes of f32 (the raw file holds the texels only).
    let (w, h) = (m.families[0].textures[0].extent[0], m.families[0].textures[0].extent[1]);
    assert_eq!(m.families[0].textures[0].bytes, u64::from(w * h * 4 * 2));
}

#[test]
fn ktx2_f32_checks() {
    let dir = tempfile::tempdir().unwrap();
    export_and_check(Format::Ktx2, Storage::F32, dir.path());
}

/// At angles within a few 1e-4 rad of the axis (and their mirrors) q = 1 − sin x is
/// below f32's resolution of 1: the shader's stable form must keep u, and so Ŝ,
/// within the target there, for small and large γ.
#[test]
fn near_the_axis_the_warp_keeps_its_digits() {
    let dir = tempfile::tempdir().unwrap();
    let m = export(&opts(Format::Raw, Storage::F32), dir.path()).unwrap();
    let t = &m.families[0].textures[0];
    let (texture, _) = formats::read(&dir.path().join(&t.file), Format::Raw).unwrap();
    let family: Box<dyn Checked> = registry(FitOptions::default())
        .into_iter()
        .find(|f| f.kind() == "isg-best")
        .unwrap();
    let target = family
        .thresholds()
        .into_iter()
        .find(|t| t.output == "s_hat" && t.metric == "offgrid.max_abs")
        .unwrap()
        .limit;
    let samplers = [Sampler {
        axes: t.axes.clone(),
        channels: t.channels.clone(),
        texture,
        filter: Filter::Manual,
        rounding: Default::default(),
    }];
    let emu = Emulated {
        family: lobefit::fits::gpu_family("isg-best").unwrap(),
        samplers: &samplers,
    };
    let mut worst: f64 = 0.0;
    for gamma in [0.5f32, 3.0, 100.0, 1e4] {
        for d in [3e-6, 3e-5, 1e-4, 2e-4, 4e-4, 1e-3] {
            for (theta, phi) in [(-d, -d), (d, d), (-d, d), (d, 0.5), (-0.3, -d)] {
                // Inputs as a shader gets them: f32.
                let x = [
                    f64::from(gamma),
                    f64::from((FRAC_PI_2 + theta) as f32),
                    f64::from((FRAC_PI_2 + phi) as f32),
                ];
                let (got, want) = family.check_point(&emu, &x).unwrap().unwrap();
                let err = (got[0] - want[0]).abs();
                assert!(
                    err <= target,
                    "γ {gamma}, θ {}, φ {}: Ŝ {} vs {}",
                    x[1],
                    x[2],
                    got[0],
                    want[0]
                );
                worst = worst.max(err);
            }
        }
    }
    assert!(worst > 0.0);
}

/// The 8-bit hardware filter's emulations (weights to nearest, and every corner of
/// weights a step past floor or ceil, f16 texels moved 2 ulps each way) span what
/// exact weights give: the span gpu-check holds a device's 8-bit unit to contains
/// lavapipe's exact filtering, channel by channel (each is monotone in its texel),
/// at random points of the isg-best texture, f32 and f16.
#[test]
fn hardware_emulations_span_exact_weights() {
    for storage in [Storage::F32, Storage::F16] {
        let dir = tempfile::tempdir().unwrap();
        let m = export(&opts(Format::Raw, storage), dir.path()).unwrap();
        let t = &m.families[0].textures[0];
        let (texture, _) = formats::read(&dir.path().join(&t.file), Format::Raw).unwrap();
        let sampler = |filter, rounding| Sampler {
            axes: t.axes.clone(),
            channels: t.channels.clone(),
            texture: texture.clone(),
            filter,
            rounding,
        };
        let exact = sampler(Filter::Manual, WeightRounding::Nearest);
        let mut spans: Vec<Sampler> = WeightRounding::corners(t.axes.len(), storage == Storage::F16)
            .map(|r| sampler(Filter::Hardware, r))
            .collect();
        assert_eq!(
            spans.len(),
            (1 << t.axes.len()) * if storage == Storage::F16 { 2 } else { 1 }
        );
        spans.push(sampler(Filter::Hardware, WeightRounding::Nearest));
        let mut rng = lobefit::rng::Rng::new(0x8b17);
        let (mut inside, mut moved) = (0, 0);
        for _ in 0..2000 {
            let x: Vec<f32> = t.axes.iter().map(|a| rng.range(a.axis.lo, a.axis.hi) as f32).collect();
            let e = exact.sample(&x);
            let all: Vec<Vec<f32>> = spans.iter().map(|s| s.sample(&x)).collect();
            for (k, v) in e.iter().enumerate() {
                let lo = all.iter().map(|a| a[k]).fold(f32::INFINITY, f32::min);
                let hi = all.iter().map(|a| a[k]).fold(f32::NEG_INFINITY, f32::max);
                // An f32 ulp of slack: the two paths compute the coordinate apart.
                let tol = 4.0 * f32::EPSILON * v.abs().max(lo.abs()).max(hi.abs());
                assert!(
                    lo - tol <= *v && *v <= hi + tol,
                    "{storage} at {x:?} channel {k}: {v} not in [{lo}, {hi}]"
                );
                inside += 1;
                moved += usize::from(hi > lo);
            }
        }
        // The span is not empty: the check would mean nothing.
        assert!(moved > inside / 2, "{moved} of {inside}");
    }
}
