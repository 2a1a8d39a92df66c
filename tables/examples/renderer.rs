//! How a renderer uses lobefit-tables: no file system, no fitting code.
//!
//! Run: `cargo run -p lobefit-tables --example renderer`

use lobefit_tables::{CapExponent, LobeIntegral, LookupError};

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
