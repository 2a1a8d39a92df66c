//! Table families: one module per family (grid, fit, reference, runtime hook), and
//! the registry that lists them. Adding a family = one module + one line below.

pub mod cap_exponent;
pub mod isg;
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

/// Fitting method for families that have a paper-faithful baseline.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Method {
    /// The product's method (closed forms, variable projection, polishing).
    #[default]
    Fast,
    /// The paper's way: a simplex optimizer on an objective evaluated by adaptive
    /// quadrature. Kept as the baseline that speed and accuracy are compared with.
    Paper,
}

impl Method {
    /// Name used on the command line and in the stored settings.
    pub fn name(self) -> &'static str {
        match self {
            Method::Fast => "fast",
            Method::Paper => "paper",
        }
    }
}

/// Options that select how families are fitted.
#[derive(Debug, Clone, Copy, Default)]
pub struct FitOptions {
    /// Optimizer backend.
    pub backend: Backend,
    /// Fitting method.
    pub method: Method,
}

/// Every family, in build order.
pub fn registry(opts: FitOptions) -> Vec<Box<dyn Family>> {
    vec![
        Box::new(lobe_integral::LobeIntegralFamily),
        Box::new(cap_exponent::CapExponentFamily {
            backend: opts.backend,
            method: opts.method,
        }),
        Box::new(isg::IsgFamily {
            model: isg::IsgModelKind::Refit,
        }),
        Box::new(isg::IsgFamily {
            model: isg::IsgModelKind::Best,
        }),
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
