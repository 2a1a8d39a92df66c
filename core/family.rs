//! The traits a table family implements, each on top of the one before: [`View`]
//! (evaluate it: `lobefit eval`), [`Checked`] (hold it to its promises: `check`,
//! `export`) and [`Fit`] (build it: `build-tables`). A pipeline's eval view implements
//! [`View`] alone. A new family is one module in `fits/` plus one line in the registry
//! (`fits/lib.rs`).

use lobefit_tables::format::Threshold;
use lobefit_tables::{Axis, Channel, LoadError, LookupError, Table};

use crate::rng::Rng;

/// One flag of `lobefit eval`, declared by the family or pipeline query that takes it
/// (`Entry::eval_flags` in `lobefit_fits`, `EvalView::flags` in `lobefit_pipelines`).
/// The command line offers the union of the declarations and refuses, for a query,
/// every flag it does not declare: a new flag is one declaration beside the code that
/// reads it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct EvalFlag {
    /// Its name without the dashes (`order` for `--order`).
    pub name: &'static str,
    /// Its values and default, for `eval --help` (`paper | refit | best (default best)`).
    pub help: &'static str,
    /// Whether its value is a whole number (the command line parses it as one).
    pub count: bool,
}

/// A flag's value as parsed by the command line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum FlagValue {
    /// A word (`--model best`).
    Text(String),
    /// A whole number (`--order 6`).
    Count(usize),
}

/// Why `lobefit eval` could not set up a query: its flags (a usage error: a flag the
/// query does not take, a value outside its range, a scene of a kind it cannot shade;
/// exit 2) or an input file they name (a scene that cannot be read, parsed or built;
/// exit 1, as a table file's errors).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum EvalError {
    /// The flags.
    Usage(String),
    /// A file they name.
    Input(String),
}

impl From<String> for EvalError {
    fn from(e: String) -> Self {
        EvalError::Usage(e)
    }
}

impl From<&str> for EvalError {
    fn from(e: &str) -> Self {
        EvalError::Usage(e.into())
    }
}

impl std::fmt::Display for EvalError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            EvalError::Usage(e) | EvalError::Input(e) => f.write_str(e),
        }
    }
}

/// The flags given to `lobefit eval`, by name (without the dashes). Built by the
/// command line from the declared [`EvalFlag`]s; a query reads the ones it declares.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct EvalFlags(std::collections::BTreeMap<&'static str, FlagValue>);

impl EvalFlags {
    /// These flags with `--name value` added (a word).
    pub fn with(mut self, name: &'static str, value: impl Into<String>) -> Self {
        self.0.insert(name, FlagValue::Text(value.into()));
        self
    }

    /// These flags with `--name n` added (a whole number).
    pub fn with_count(mut self, name: &'static str, n: usize) -> Self {
        self.0.insert(name, FlagValue::Count(n));
        self
    }

    /// The word given for `--name`. A number given for it reads as its digits.
    pub fn text(&self, name: &str) -> Option<String> {
        self.0.get(name).map(|v| match v {
            FlagValue::Text(s) => s.clone(),
            FlagValue::Count(n) => n.to_string(),
        })
    }

    /// The whole number given for `--name`; a word that is not one is an error naming
    /// the flag.
    pub fn count(&self, name: &str) -> Result<Option<usize>, String> {
        match self.0.get(name) {
            None => Ok(None),
            Some(FlagValue::Count(n)) => Ok(Some(*n)),
            Some(FlagValue::Text(s)) => s
                .parse()
                .map(Some)
                .map_err(|_| format!("--{name} {s}: expected a whole number")),
        }
    }

    /// The flags that are set, as typed on the command line (`--order`), sorted.
    pub fn given(&self) -> Vec<String> {
        self.0.keys().map(|k| format!("--{k}")).collect()
    }

    /// Refuses the first flag `query` does not declare in `takes`, naming the ones it
    /// does.
    pub fn only(&self, query: &str, takes: &[EvalFlag]) -> Result<(), String> {
        let Some(bad) = self.0.keys().find(|k| !takes.iter().any(|f| f.name == **k)) else {
            return Ok(());
        };
        if takes.is_empty() {
            return Err(format!("{query} takes no --{bad} flag (it takes no flags)"));
        }
        let names: Vec<String> = takes.iter().map(|f| format!("--{}", f.name)).collect();
        Err(format!("{query} takes no --{bad} flag (only {})", names.join(", ")))
    }
}

#[cfg(test)]
mod eval_flag_tests {
    use super::*;

    const ORDER: EvalFlag = EvalFlag {
        name: "order",
        help: "1..=8",
        count: true,
    };

    #[test]
    fn flags_read_back_and_undeclared_ones_are_refused() {
        let f = EvalFlags::default().with("model", "best").with_count("order", 6);
        assert_eq!(f.text("model").as_deref(), Some("best"));
        assert_eq!(f.count("order"), Ok(Some(6)));
        assert_eq!(f.count("depth"), Ok(None));
        assert_eq!(f.given(), ["--model", "--order"]);
        let e = f.only("wedge", &[ORDER]).unwrap_err();
        assert_eq!(e, "wedge takes no --model flag (only --order)");
        assert!(EvalFlags::default()
            .with_count("order", 3)
            .only("wedge", &[ORDER])
            .is_ok());
        let e = EvalFlags::default().with("x", "1").only("sg-fit", &[]).unwrap_err();
        assert_eq!(e, "sg-fit takes no --x flag (it takes no flags)");
        let e = EvalFlags::default().with("order", "six").count("order").unwrap_err();
        assert_eq!(e, "--order six: expected a whole number");
    }
}

/// One extra checker section (see [`Checked::extra_checks`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Extra {
    /// (runtime value, reference value) pairs: reported as absolute and relative errors.
    Pairs(Vec<(f64, f64)>),
    /// A measured distribution (e.g. each fit's own residual, the floor no table can
    /// beat), reported as is; a threshold may bound it (metric `max`, `p99`, …).
    Values(Vec<f64>),
    /// (runtime value, reference value) pairs at grid nodes: reported as the grid
    /// errors of an output of this name (the per-node sections of
    /// [`Checked::nodes_in_extras`]).
    Nodes(Vec<(f64, f64)>),
}

/// Fit of one grid entry.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    /// Channel values (decoded: the writer applies each channel's encoding).
    pub values: Vec<f64>,
    /// Family-defined residual (see [`Fit::residual_meaning`]).
    pub residual: f64,
    /// Optimizer iterations or integrand evaluations.
    pub iterations: u32,
    /// Whether the fit met its tolerance; unconverged entries are never written.
    pub converged: bool,
}

/// The runtime lookup a family is checked through: the runtime crate's own API.
pub trait Lookup: Sync {
    /// Output columns (see [`View::outputs`]) at the input point `x`.
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError>;
    /// The same through the runtime's `_f32` twins: inputs `x` (already
    /// f32-representable) passed as f32, outputs widened. `None` where the family has
    /// no f32 twin. The checker reports these as the `<output> f32` rows.
    fn lookup_f32(&self, _x: &[f64]) -> Option<Result<Vec<f64>, LookupError>> {
        None
    }
}

/// A runtime whose [`Lookup::lookup`] is its f32 twin: [`Checked::check_point`] run
/// through it checks the twin with the family's own rules.
pub struct F32Twin<'a>(pub &'a dyn Lookup);

impl Lookup for F32Twin<'_> {
    fn lookup(&self, x: &[f64]) -> Result<Vec<f64>, LookupError> {
        self.0.lookup_f32(x).unwrap_or(Err(LookupError::Arity {
            expected: 0,
            got: x.len(),
        }))
    }
}

/// What `lobefit eval NAME` evaluates: input and output columns, the runtime lookup
/// over a table, and an independent answer for `--exact`. Every family implements it
/// (through [`Checked`]); so do the eval views that only read tables (`wedge --order
/// N`, and the pipelines' `direct-light`, `isg-shade`, `shexp-shade`), which promise
/// nothing the checker could hold them to.
pub trait View: Sync {
    /// Table kind, file stem and CLI name, e.g. `"cap-exponent"` (for a pipeline's
    /// view: the kind of the table `eval --table FILE` replaces).
    fn kind(&self) -> &'static str;
    /// Input columns of `lobefit eval` (and of [`View::reference`]).
    fn inputs(&self) -> &'static [&'static str];
    /// Output columns of `lobefit eval`.
    fn outputs(&self) -> &'static [&'static str];
    /// The committed default table of [`View::kind`], compiled into the runtime crate.
    fn embedded(&self) -> &'static [u8];
    /// Wraps a loaded table in the runtime crate's lookup for this view.
    fn runtime(&self, table: Table) -> Result<Box<dyn Lookup>, LoadError>;
    /// Independent reference (closed form, adaptive quadrature or converged Monte
    /// Carlo; never the fit's own numerics) of the outputs at `x`. Errors name an
    /// out-of-domain input.
    fn reference(&self, x: &[f64]) -> Result<Vec<f64>, String>;
    /// A caveat `lobefit eval` prints (to stderr, once per kind, with the number of
    /// rows) where the lookup at `x` is known to be less accurate than the family's
    /// promise, e.g. outside the range its error was measured on. Default: none.
    fn caveat(&self, _x: &[f64]) -> Option<&'static str> {
        None
    }
    /// `lobefit eval --exact`: the reference, or the fit run at exactly `x`.
    fn exact(&self, x: &[f64]) -> Result<Vec<f64>, String> {
        self.reference(x)
    }
    /// [`View::exact`] with a note `eval` prints as a warning naming the row, where the
    /// answer is given but less sure than usual (a Monte Carlo reference that stopped
    /// at its sample limit short of its error target). Default: [`View::exact`], no note.
    fn exact_noted(&self, x: &[f64]) -> Result<(Vec<f64>, Option<String>), String> {
        self.exact(x).map(|y| (y, None))
    }
}

/// A table the checker holds to its promises: what `check` and `export` need on top
/// of the [`View`]. Families implement it; views do not.
pub trait Checked: View {
    /// Accuracy promises: written into the file at build, enforced by the checker
    /// (from here, not from the file, so a file cannot switch its check off).
    fn thresholds(&self) -> Vec<Threshold>;
    /// A random input point of the domain, for the checker's off-grid test.
    fn sample(&self, rng: &mut Rng) -> Vec<f64>;
    /// Names of the quantities the checker compares (default: the eval outputs).
    fn checked(&self) -> &'static [&'static str] {
        self.outputs()
    }
    /// Input points the checker evaluates at a grid node (default: the node itself;
    /// several where the axes are derived quantities or where a node's values reach
    /// lookups along axes the grid does not have).
    fn node_inputs(&self, node: &[f64]) -> Vec<Vec<f64>> {
        vec![node.to_vec()]
    }
    /// The checker's comparison at `x`: (runtime values, reference values) of
    /// [`Checked::checked`], or `None` where the family promises nothing (e.g. a
    /// product too small to matter); a quantity whose runtime and reference values
    /// are both NaN is promised nothing at `x` alone (a NaN on one side only is an
    /// error). Default: the lookup against [`View::reference`].
    #[allow(clippy::type_complexity)]
    fn check_point(&self, runtime: &dyn Lookup, x: &[f64]) -> Result<Option<(Vec<f64>, Vec<f64>)>, String> {
        let got = runtime.lookup(x).map_err(|e| format!("lookup at {x:?}: {e}"))?;
        let want = self.reference(x).map_err(|e| format!("reference at {x:?}: {e}"))?;
        Ok(Some((got, want)))
    }
    /// Extra checker sections beyond pointwise lookups (e.g. whole-scene sums built
    /// from the table, or the paper's own grid metric), from `count` seeded random
    /// cases. Default: none.
    fn extra_checks(&self, _table: &Table, _count: usize, _seed: u64) -> Vec<(String, Result<Extra, String>)> {
        Vec::new()
    }
    /// Whether [`Checked::extra_checks`] verifies every grid node with sections
    /// cheaper than [`Checked::check_point`] (which then runs on an evenly strided
    /// subset of nodes). Default `false`: `check_point` at every node.
    fn nodes_in_extras(&self) -> bool {
        false
    }
}

/// Building a table: its grid and stored channels, how each node is fitted, and what
/// the file records about the fit. `build-tables` needs only this (and the
/// [`View::kind`] and [`Checked::thresholds`] it writes into the file).
pub trait Fit: Checked {
    /// The family's table version (bumped when layout or meaning changes).
    fn version(&self) -> u32;
    /// What the table holds and how to use it (stored in the file).
    fn description(&self) -> String;
    /// Grid axes, slowest first.
    fn axes(&self) -> Vec<Axis>;
    /// Stored channels.
    fn channels(&self) -> Vec<Channel>;
    /// Fit method (stored and hashed with the settings).
    fn method(&self) -> String;
    /// Every setting that changes the payload.
    fn settings(&self) -> Vec<(String, String)>;
    /// What [`Fitted::residual`] measures.
    fn residual_meaning(&self) -> &'static str;
    /// Fits one grid node (axis coordinates `node`). Pure and deterministic.
    fn fit(&self, node: &[f64]) -> Fitted;
    /// Equivalent grid node whose fit this node reuses (e.g. a symmetry), or `None`.
    /// The fit at the returned node must give exactly this node's values.
    fn mirror(&self, _node: &[f64]) -> Option<Vec<f64>> {
        None
    }
}
