//! How a renderer uses lobefit-tables: no file system, no fitting code.
//!
//! Run: `cargo run -p lobefit-tables --example renderer`

use lobefit_tables::glam::DVec3;
use lobefit_tables::{CapExponent, Lobe, LobeIntegral, LobeProduct, LookupError};

/// A light seen from a shading point as a cone of half-angle `alpha` (rad) is
/// replaced by the cosine lobe that best matches that spherical cap (Meunier et al.
/// §5.2): returns (exponent, lobe integral in sr).
fn cap_as_lobe(caps: &CapExponent, lobes: &LobeIntegral, alpha: f32) -> Result<(f32, f32), LookupError> {
    let e = caps.e_cap_f32(alpha)?;
    let integral = lobes.integral_f32(e.min(1.0e5))?;
    Ok((e, integral))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // The committed default tables are compiled in (feature `embedded`, on by default).
    let caps = CapExponent::embedded()?;
    let lobes = LobeIntegral::embedded()?;

    for alpha in [0.01f32, 0.1, 0.5, 1.0, 1.5, 2.0] {
        let (e, i) = cap_as_lobe(caps, lobes, alpha)?;
        let cap_solid_angle = 2.0 * std::f32::consts::PI * (1.0 - alpha.cos());
        println!("cap {alpha:>4} rad: lobe exponent {e:>10.3}, lobe integral {i:.5} sr, cap {cap_solid_angle:.5} sr");
    }

    // Shading with lobe sums (Meunier et al. eq. 22): a glossy BRDF lobe, a light
    // cap as a lobe, one visibility lobe; products of sums are approximated lobe by
    // lobe (integral-conserving table), then integrated in closed form.
    let products = LobeProduct::embedded()?;
    let (e_light, _) = cap_as_lobe(caps, lobes, 0.2)?;
    let brdf = [Lobe {
        scale: 1.0,
        axis: DVec3::new(0.3, 0.0, 1.0).normalize(),
        exponent: 50.0,
    }];
    let light = [Lobe {
        scale: 5.0,
        axis: DVec3::new(0.4, 0.1, 1.0).normalize(),
        exponent: e_light as f64,
    }];
    let visibility = [Lobe {
        scale: 1.0,
        axis: DVec3::Z,
        exponent: 0.5,
    }];
    let lo = products.triple_product(&brdf, &light, &visibility, DVec3::Z, 1e-4)?;
    println!("outgoing radiance from lobe algebra: {lo:.5}");

    // Bad queries are errors a renderer can log, never NaN in the frame buffer.
    match caps.e_cap(f64::NAN) {
        Err(LookupError::NotFinite { name, .. }) => println!("rejected NaN {name}"),
        other => println!("unexpected: {other:?}"),
    }

    // For GPU upload: the payload is raw little-endian f32, 16-byte aligned in the
    // file; the axis mapping tells the shader how to compute texture coordinates.
    let t = caps.table();
    let axis = &t.meta().axes[0];
    println!(
        "texture: {} texels of '{}', axis '{}' mapping {:?}, {} payload bytes",
        axis.count,
        t.meta().channels[0].name,
        axis.name,
        axis.mapping,
        t.payload_bytes().len()
    );
    Ok(())
}
