//! lobe-integral on the GPU: the closed form 2π/(e + 1), no texture.

use lobefit_core::export::families::ClosedForm;
use lobefit_core::export::gpu_check::{closed_row, Kernel};
use lobefit_core::family::Checked;
use lobefit_core::rng::Rng;

const BODY: &str = "    Y[o] = lf_lobe_integral(x0);";

/// The closed form and its conformance.
pub const CLOSED: ClosedForm = ClosedForm {
    kind: lobefit_tables::lobe_integral::KIND,
    formula: "∫ max(a·v, 0)^e dω = 2π / (e + 1)",
    checks: |runner, samples, seed| {
        let family = super::LobeIntegralFamily;
        let cpu = |x: &[f64]| vec![lobefit_tables::lobe_integral::exact(x[0]).unwrap_or(f64::NAN)];
        Ok(vec![closed_row(
            runner,
            "lobe-integral",
            &family,
            BODY,
            &cpu,
            samples,
            seed,
        )?])
    },
    timed: |count, seed| {
        let mut rng = Rng::new(seed);
        let points = (0..count).map(|_| super::LobeIntegralFamily.sample(&mut rng)).collect();
        vec![(Kernel::new("lobe-integral", &[], BODY, 1), points)]
    },
};
