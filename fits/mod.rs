//! Table families: one module per family (grid, fit, reference, runtime hook), and
//! the registry that lists them. Adding a family = one module + one line below.

pub mod cap_exponent;
pub mod disk_light;
pub mod isg;
pub mod lobe_integral;
pub mod lobe_product;
pub mod log_zh;
pub mod mask_weights;
pub mod sg_fit;
pub mod shexp;
pub mod wedge;
pub mod wrap;

use std::path::{Path, PathBuf};

use crate::family::{EvalFlags, Fit, Query};

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
pub fn registry(opts: FitOptions) -> Vec<Box<dyn Fit>> {
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
        Box::new(sg_fit::SgFitFamily),
        Box::new(log_zh::LogZhFamily::default()),
        Box::new(wedge::WedgeFamily),
        Box::new(wrap::WrapFamily::default()),
        Box::new(disk_light::DiskLightFamily),
        Box::new(shexp::ShExpFamily::default()),
        Box::new(lobe_product::LobeProductFamily {
            variant: lobefit_tables::Variant::Energy,
            method: opts.method,
        }),
        Box::new(lobe_product::LobeProductFamily {
            variant: lobefit_tables::Variant::L2,
            method: opts.method,
        }),
        Box::new(mask_weights::MaskWeightsFamily),
    ]
}

/// Names of all families.
pub fn names() -> Vec<&'static str> {
    registry(FitOptions::default()).iter().map(|f| f.kind()).collect()
}

/// The family called `name`, if any.
pub fn by_name(name: &str, opts: FitOptions) -> Option<Box<dyn Fit>> {
    registry(opts).into_iter().find(|f| f.kind() == name)
}

/// Names `lobefit eval` accepts. A name may select among several tables
/// through its flags (e.g. `lobe-product --variant l2`).
pub fn eval_names() -> Vec<&'static str> {
    let mut v = names();
    v.push("isg");
    v
}

/// The family `lobefit eval NAME [flags]` queries, configured by its flags.
/// Errors name the flag a family does not take or the value it does not know.
pub fn for_eval(name: &str, flags: &EvalFlags, opts: FitOptions) -> Result<Box<dyn Query>, String> {
    match name {
        "isg" => isg::for_eval(flags),
        "log-zh" => {
            if flags.variant.is_some() || flags.model.is_some() || flags.log.is_some() {
                return Err("log-zh takes only --kind and --order".into());
            }
            Ok(Box::new(log_zh::LogZhFamily::from_flags(
                flags.kind.as_deref(),
                flags.order,
            )?))
        }
        "wedge" => {
            if flags.variant.is_some() || flags.model.is_some() || flags.log.is_some() || flags.kind.is_some() {
                return Err("wedge takes only --order".into());
            }
            let order = flags.order.unwrap_or(log_zh::DEFAULT_ORDER);
            if !(1..=8).contains(&order) {
                return Err(format!("wedge: --order {order} is outside 1..=8"));
            }
            Ok(Box::new(wedge::WedgeSliceView { order }))
        }
        "wrap" => {
            if flags.given().iter().any(|f| *f != "--order") {
                return Err("wrap takes only --order".into());
            }
            let order = flags.order.unwrap_or(wrap::DEFAULT_ORDER);
            if !(1..=8).contains(&order) {
                return Err(format!("wrap: --order {order} is outside 1..=8"));
            }
            Ok(Box::new(wrap::WrapFamily { order }))
        }
        "shexp" => {
            if flags.variant.is_some() || flags.model.is_some() || flags.kind.is_some() {
                return Err("shexp takes only --order and --log".into());
            }
            Ok(Box::new(shexp::ShExpFamily::from_flags(
                flags.order,
                flags.log.as_deref(),
            )?))
        }
        "lobe-product" if flags.given() == ["--variant"] || flags.given().is_empty() => {
            let variant = match flags.variant.as_deref() {
                None | Some("energy") => lobefit_tables::Variant::Energy,
                Some("l2") => lobefit_tables::Variant::L2,
                Some(v) => return Err(format!("--variant {v}: expected energy or l2")),
            };
            Ok(Box::new(lobe_product::LobeProductFamily {
                variant,
                method: opts.method,
            }))
        }
        _ => {
            let f = by_name(name, opts).ok_or_else(|| format!("unknown family {name}"))?;
            if let Some(flag) = flags.given().first() {
                return Err(format!("{name} takes no {flag} flag"));
            }
            Ok(f)
        }
    }
}

/// A figure generator of `lobefit plot NAME`: writes its PNGs into the directory it is
/// given and returns their paths.
pub type PlotFn = fn(&Path) -> Result<Vec<PathBuf>, String>;

/// Every `lobefit plot` name with its generator.
pub fn plots() -> Vec<(&'static str, PlotFn)> {
    vec![
        ("disk-light", disk_light::plot),
        ("export", crate::export::run::plot),
        ("isg", isg::plot),
        ("lobe-product", lobe_product::plot),
        ("log-zh", crate::fits::log_zh::eps_study::plot),
        ("shexp", crate::fits::shexp::study::plot),
    ]
}
