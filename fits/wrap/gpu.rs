//! wrap on the GPU: λ̂_l(a) in closed form (polynomials in a per band), no texture.

use lobefit_core::export::families::ClosedForm;
use lobefit_core::export::gpu_check::{closed_row, write_array, Kernel};
use lobefit_core::family::Checked;
use lobefit_core::rng::Rng;

/// The closed form and its conformance (8 bands).
pub const CLOSED: ClosedForm = ClosedForm {
    kind: lobefit_tables::wrap::KIND,
    formula: "λ̂_l(a) closed form (lobefit_tables::wrap::lambda_hat): polynomials in a per band, no texture",
    checks: |runner, samples, seed| {
        let cpu = |x: &[f64]| {
            let mut o = vec![0.0; 8];
            lobefit_tables::wrap::lambda_hat(8, x[0], &mut o)
                .map(|_| o)
                .unwrap_or(vec![f64::NAN; 8])
        };
        let body = write_array("lf_wrap_lambda_hat(8u, x0)", 8);
        let family = super::WrapFamily::default();
        Ok(vec![closed_row(runner, "wrap", &family, &body, &cpu, samples, seed)?])
    },
    timed: |count, seed| {
        let mut rng = Rng::new(seed);
        let family = super::WrapFamily::default();
        let points = (0..count).map(|_| family.sample(&mut rng)).collect();
        let body = write_array("lf_wrap_lambda_hat(8u, x0)", 8);
        vec![(Kernel::new("wrap (8 bands)", &[], &body, 8), points)]
    },
};
