//! Table families: one module per family (grid, fit, reference, runtime hook), and
//! the registry that lists them. Adding a family = one module + one line below.

pub mod cap_exponent;
pub mod lobe_integral;

use crate::family::Family;

/// Optimizer backend for families fitted by a 1-D minimiser.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Backend {
    /// argmin (pure Rust; the default).
    #[default]
    Argmin,
    /// NLopt (C library; cargo feature `nlopt`).
    Nlopt,
}

impl Backend {
    /// Name used on the command line and in the stored settings.
    pub fn name(self) -> &'static str {
        match self {
            Backend::Argmin => "argmin",
            Backend::Nlopt => "nlopt",
        }
    }
}

/// Options that select how families are fitted.
#[derive(Debug, Clone, Copy, Default)]
pub struct FitOptions {
    /// Optimizer backend.
    pub backend: Backend,
}

/// Every family, in build order.
pub fn registry(opts: FitOptions) -> Vec<Box<dyn Family>> {
    vec![
        Box::new(lobe_integral::LobeIntegralFamily),
        Box::new(cap_exponent::CapExponentFamily { backend: opts.backend }),
    ]
}

/// Names of all families.
pub fn names() -> Vec<&'static str> {
    registry(FitOptions::default()).iter().map(|f| f.kind()).collect()
}

/// The family called `name`, if any.
pub fn by_name(name: &str, opts: FitOptions) -> Option<Box<dyn Family>> {
    registry(opts).into_iter().find(|f| f.kind() == name)
}
