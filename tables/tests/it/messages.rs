//! Error messages say what is wrong in the caller's terms: numbers in short form,
//! and functions that read no table do not talk about axes and channels.

use lobefit_tables::error::short;
use lobefit_tables::glam::DVec3;
use lobefit_tables::{sh, shexp, CapExponent, Lobe, LobeProduct, LookupError};

#[test]
fn numbers_in_messages_are_short() {
    assert_eq!(short(1e308).to_string(), "1e308");
    assert_eq!(short(5e-324).to_string(), "5e-324");
    assert_eq!(short(-2.5e-5).to_string(), "-2.5e-5");
    assert_eq!(short(0.1).to_string(), "0.1");
    assert_eq!(short(std::f64::consts::FRAC_PI_2).to_string(), "1.5707963267948966");
    assert_eq!(short(123456.0).to_string(), "123456");
    assert_eq!(short(1e16).to_string(), "1e16");
    assert_eq!(short(0.0).to_string(), "0");
    assert_eq!(short(f64::NEG_INFINITY).to_string(), "-inf");
    let caps = CapExponent::embedded().unwrap();
    for (alpha, shown) in [(1e308, "1e308"), (-5e-324, "-5e-324")] {
        let msg = caps.e_cap(alpha).unwrap_err().to_string();
        assert!(
            msg.starts_with(&format!("alpha = {shown} is outside the domain [")),
            "{msg}"
        );
        assert!(msg.len() < 80, "{} characters: {msg}", msg.len());
    }
}

#[test]
fn sh_vector_of_a_non_square_length_is_named_as_such() {
    let mut out = [0.0; 9];
    let e = sh::rotate_z(&[0.0; 5], 0.1, &mut out).unwrap_err();
    assert_eq!(e, LookupError::ShLength { got: 5, max_order: 8 });
    assert_eq!(e.to_string(), "5 SH coefficients: not n² for an order n in 1..=8");
}

#[test]
fn short_sh_output_buffer_counts_coefficients() {
    let mut out = [0.0; 4];
    let e = sh::rotate_z(&[0.0; 9], 0.1, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 4 slots, needs 9 SH coefficients");
    let sx = shexp::ShExp::embedded().unwrap();
    let mut f = [0.0; 9];
    f[0] = 0.5;
    let e = sx.hyb(&f, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 4 slots, needs 9 SH coefficients");
}

#[test]
fn overflowing_lobe_product_blames_the_exponents() {
    let products = LobeProduct::embedded().unwrap();
    let a = Lobe {
        scale: 1.0,
        axis: DVec3::Z,
        exponent: 1e300,
    };
    let b = Lobe {
        scale: 1.0,
        axis: DVec3::new(0.1, 0.0, 1.0).normalize(),
        exponent: 10.0,
    };
    let e = products.product_sums(&[a], &[b], 0.0).unwrap_err();
    assert_eq!(
        e.to_string(),
        "the product of lobes with exponents e1 = 1e300 and e2 = 10 overflows"
    );
}

#[test]
fn short_output_buffers_of_closed_forms_name_what_they_hold() {
    use lobefit_tables::{log_zh, wedge, wrap};
    let mut out = [0.0; 3];
    let e = wrap::lambda_hat(8, 0.5, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 3 slots, needs 8 eigenvalues");
    let e = log_zh::phong(0.5, 2.0, 4, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 3 slots, needs 4 ZH coefficients");
    let e = wedge::slice_log(0.1, 0.5, 4, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 3 slots, needs 4 slice coefficients");
    let e = wrap::convolve(&[0.0; 4], 0.5, &mut out).unwrap_err();
    assert_eq!(e.to_string(), "output buffer has 3 slots, needs 4 SH coefficients");
}
