//! Table families: one module per family (grid, fit, reference, runtime hook, GPU
//! export, figures), each exporting one [`Entry`], and [`entries`], the only list of
//! them. Everything that iterates "all families" (build, check, eval, export, the
//! shader conformance, the tests) goes through it. Adding a family = one module + one
//! line in [`entries`].

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

use lobefit_core::export::families::{ClosedForm, GpuFamily};
use lobefit_core::family::{EvalFlag, EvalFlags, Fit, View};

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

/// What one `fits/<family>/` folder gives the rest of the tree.
#[derive(Clone, Copy)]
pub struct Entry {
    /// Its tables' builders, one per table kind, in build order.
    pub tables: fn(FitOptions) -> Vec<Box<dyn Fit>>,
    /// `lobefit eval NAME [flags]` for its names (its tables' kinds and
    /// [`Entry::eval_names`]), parsing the flags it takes; `None`: each kind's table as
    /// built, with no flags.
    pub eval: Option<EvalFn>,
    /// `lobefit eval` names beyond its tables' kinds (e.g. `isg --model ...`).
    pub eval_names: &'static [&'static str],
    /// The flags each of its `eval` names takes (a name not listed takes none); the
    /// command line offers them and [`for_eval`] refuses every other.
    pub eval_flags: &'static [(&'static str, &'static [EvalFlag])],
    /// Its textured GPU exports (one per exported table kind; empty if none).
    pub gpu: &'static [GpuFamily],
    /// A table a shader evaluates in closed form instead, with no texture.
    pub closed_form: Option<ClosedForm>,
    /// `lobefit plot NAME`: its figures.
    pub plot: Option<(&'static str, PlotFn)>,
    /// Its paragraph of `lobefit eval --help`: names and flags, then each input (`in`)
    /// and output (`out`) column with its unit and domain.
    pub eval_help: &'static str,
}

/// A family's `lobefit eval` query for a name and flags (see [`Entry::eval`]).
pub type EvalFn = fn(&str, &EvalFlags, FitOptions) -> Result<Box<dyn View>, String>;

/// Every family, in build order: the only list.
pub fn entries() -> [Entry; 11] {
    [
        lobe_integral::ENTRY,
        cap_exponent::ENTRY,
        isg::ENTRY,
        sg_fit::ENTRY,
        log_zh::ENTRY,
        wedge::ENTRY,
        wrap::ENTRY,
        disk_light::ENTRY,
        shexp::ENTRY,
        lobe_product::ENTRY,
        mask_weights::ENTRY,
    ]
}

/// Every table's builder, in build order.
pub fn registry(opts: FitOptions) -> Vec<Box<dyn Fit>> {
    entries().iter().flat_map(|e| (e.tables)(opts)).collect()
}

/// Names of all families.
pub fn names() -> Vec<&'static str> {
    registry(FitOptions::default()).iter().map(|f| f.kind()).collect()
}

/// The family called `name`, if any.
pub fn by_name(name: &str, opts: FitOptions) -> Option<Box<dyn Fit>> {
    registry(opts).into_iter().find(|f| f.kind() == name)
}

/// Names `lobefit eval` accepts: every table kind, then the families' extra names. A
/// name may select among several tables through its flags (e.g. `lobe-product
/// --variant l2`).
pub fn eval_names() -> Vec<&'static str> {
    let mut v = names();
    v.extend(entries().iter().flat_map(|e| e.eval_names.iter().copied()));
    v
}

/// The flags `lobefit eval name` takes (none for a name no family declares them for).
pub fn eval_flags(name: &str) -> &'static [EvalFlag] {
    entries()
        .iter()
        .flat_map(|e| e.eval_flags.iter())
        .find(|(n, _)| *n == name)
        .map_or(&[], |(_, f)| *f)
}

/// The family `lobefit eval NAME [flags]` queries, configured by its flags.
/// Errors name the flag a family does not take or the value it does not know.
pub fn for_eval(name: &str, flags: &EvalFlags, opts: FitOptions) -> Result<Box<dyn View>, String> {
    let owns = |e: &Entry| e.eval_names.contains(&name) || (e.tables)(opts).iter().any(|f| f.kind() == name);
    let entry = entries()
        .into_iter()
        .find(owns)
        .ok_or_else(|| format!("unknown family {name}"))?;
    flags.only(name, eval_flags(name))?;
    match entry.eval {
        Some(eval) => eval(name, flags, opts),
        None => without_flags(name, flags, opts),
    }
}

/// `name`'s table as built, refusing every flag (the default of [`Entry::eval`]).
pub fn without_flags(name: &str, flags: &EvalFlags, opts: FitOptions) -> Result<Box<dyn View>, String> {
    flags.only(name, &[])?;
    by_name(name, opts)
        .map(|f| -> Box<dyn View> { f })
        .ok_or_else(|| format!("unknown family {name}"))
}

/// The families exported as textures, in build order.
pub fn textured() -> Vec<GpuFamily> {
    entries().iter().flat_map(|e| e.gpu.iter().copied()).collect()
}

/// A textured family's GPU export by kind.
pub fn gpu_family(kind: &str) -> Option<GpuFamily> {
    textured().into_iter().find(|f| f.kind == kind)
}

/// Tables a shader evaluates in closed form, with no texture.
pub fn closed_form() -> Vec<ClosedForm> {
    entries().iter().filter_map(|e| e.closed_form).collect()
}

/// A figure generator of `lobefit plot NAME`: writes its PNGs into the directory it is
/// given and returns their paths.
pub type PlotFn = fn(&Path) -> Result<Vec<PathBuf>, String>;

/// Every `lobefit plot` name of the families, with its generator.
pub fn plots() -> Vec<(&'static str, PlotFn)> {
    entries().iter().filter_map(|e| e.plot).collect()
}
