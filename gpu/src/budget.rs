//! llvmpipe's loop budget, shared by the pipeline renders.
//!
//! llvmpipe (lavapipe, Mesa's CPU Vulkan) ends the loops of an invocation after
//! [`LOOP_LIMIT`] iterations in all: one counter per SIMD group of invocations, set at
//! the kernel's start, decremented at the end of every iteration of every loop that the
//! compiler did not unroll; at zero every loop ends after its current iteration. A
//! kernel past it computes a wrong value and says nothing. So each render
//!
//! 1. bounds, before dispatch, the iterations a pixel can need (every loop counted as if
//!    none were unrolled) and refuses a scene over [`LOOP_LIMIT`] ([`refuse_over`]) on
//!    a CPU adapter (a GPU has no such budget: [`Gpu::loop_budget`](crate::device::Gpu));
//! 2. ends its kernel with [`SENTINEL`], a loop of two iterations whose bound the
//!    compiler cannot see: after one iteration when the budget is spent, which flags
//!    the pixel ([`FLAG_BUDGET`], read by [`flags`]) — any truncated loop, the library's
//!    included, is an error, never a silently wrong image.

/// Loop iterations llvmpipe runs per invocation, all loops together.
pub const LOOP_LIMIT: u64 = 65_535;

/// The flag a kernel writes for a pixel whose loop budget ran out.
pub const FLAG_BUDGET: f32 = 2.0;

/// WGSL statements, the last of a kernel body: `budget_flag` (a `var` the body
/// declares, 0 when nothing is wrong) becomes [`FLAG_BUDGET`] when llvmpipe's loop
/// budget ran out. The bound `N.y + 2u` (N.y is 0, in a storage buffer: lavapipe inlines
/// the uniforms a loop bound reads, not storage) is unknown to the compiler, so the
/// loop is not unrolled and counts.
pub const SENTINEL: &str = "    var budget_runs = 0u;
    loop {
        budget_runs += 1u;
        if budget_runs >= N.y + 2u {
            break;
        }
    }
    if budget_runs < 2u {
        budget_flag = 2.0;
    }
";

/// Refuses, before dispatch, a render whose pixels may need `worst` loop iterations
/// (an upper bound, `why` saying what it counts) when that exceeds `budget` (the
/// device's [`Gpu::loop_budget`](crate::device::Gpu): none on a GPU).
pub fn refuse_over(budget: Option<u64>, command: &str, worst: u64, why: &str) -> Result<(), String> {
    if budget.is_some_and(|b| worst > b) {
        return Err(format!(
            "{command}: a pixel may need up to {worst} loop iterations ({why}); llvmpipe ends an invocation's \
             loops after {LOOP_LIMIT} in all and would write a wrong image: use a smaller scene"
        ));
    }
    Ok(())
}

/// The first flagged pixel of a kernel's `flags` (one per pixel, 0: none) as an
/// error: [`FLAG_BUDGET`] names the loop budget, other flags `other(flag)` says.
pub fn flags(
    command: &str,
    flags: impl IntoIterator<Item = f32>,
    pixels: usize,
    other: impl Fn(f32) -> String,
) -> Result<(), String> {
    match flags.into_iter().enumerate().find(|(_, f)| *f != 0.0) {
        None => Ok(()),
        Some((k, f)) if f == FLAG_BUDGET => Err(format!(
            "{command}: pixel {k} of {pixels} ran out of llvmpipe's loop budget ({LOOP_LIMIT} iterations of an \
             invocation's loops in all): its value would be wrong; use a smaller scene"
        )),
        Some((k, f)) => Err(format!("{command}: pixel {k} of {pixels}: {}", other(f))),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_name_the_limit() {
        let b = Some(LOOP_LIMIT);
        assert!(refuse_over(b, "render-x", LOOP_LIMIT, "").is_ok());
        assert!(refuse_over(None, "render-x", 100 * LOOP_LIMIT, "").is_ok());
        let e = refuse_over(b, "render-x", LOOP_LIMIT + 1, "3 SGs").unwrap_err();
        assert!(e.contains("65535") && e.contains("65536") && e.contains("3 SGs"), "{e}");
        assert!(flags("render-x", [0.0, 0.0], 2, |_| String::new()).is_ok());
        let e = flags("render-x", [0.0, FLAG_BUDGET], 2, |_| String::new()).unwrap_err();
        assert!(e.contains("pixel 1 of 2") && e.contains("65535"), "{e}");
        let e = flags("render-x", [1.0], 1, |f| format!("flag {f}")).unwrap_err();
        assert!(e.contains("pixel 0 of 1: flag 1"), "{e}");
    }

    /// On the device: a kernel whose loop spends llvmpipe's budget is flagged by the
    /// sentinel (its loop cut short), one within it is not.
    #[test]
    fn sentinel_flags_a_spent_budget() {
        let gpu = crate::device::Gpu::new().unwrap();
        let dummy = gpu
            .upload(&crate::conformance::dummy_texture(), lobefit::export::Storage::F32)
            .unwrap();
        let body = format!(
            "    var s = 0.0;\n    for (var k = 0u; k < u32(x0); k++) {{\n        s += 1.0;\n    }}\n    Y[o] = s;\n\
             \x20   var budget_flag = 0.0;\n{SENTINEL}    Y[o + 1u] = budget_flag;"
        );
        let src = crate::kernel::kernel("texture_2d<f32>", 1, 2, &body);
        for (n, flag) in [(1000.0f32, 0.0), (70_000.0, FLAG_BUDGET)] {
            let got = gpu
                .run(&src, &[0u8; crate::kernel::LF_TEX_SIZE], &dummy, &[n], 1, 2)
                .unwrap();
            assert_eq!(got[1], flag, "{n} iterations: {got:?}");
            if flag == 0.0 {
                assert_eq!(got[0], n);
            } else {
                assert!(got[0] < n, "{got:?}");
            }
        }
    }
}
