//! What the command line lists: the table families' names, `eval` queries and figure
//! sets (`fits/`) together with the pipelines' (`pipelines/`). It sits above both, so
//! neither `fits` nor `pipelines` needs to know the other's list.

use crate::family::{EvalFlags, View};
use crate::fits::{self, FitOptions, PlotFn};
use crate::pipelines;

/// Names `lobefit eval` accepts: every family, the families' extra views (`isg`),
/// then the pipelines' (`direct-light`).
pub fn eval_names() -> Vec<&'static str> {
    let mut v = fits::eval_names();
    v.extend(pipelines::eval_views().into_iter().map(|(n, _, _)| n));
    v
}

/// The query `lobefit eval NAME [flags]` runs, configured by its flags; errors name
/// the flag a query does not take or the value it does not know.
pub fn for_eval(name: &str, flags: &EvalFlags, opts: FitOptions) -> Result<Box<dyn View>, String> {
    match pipelines::eval_views().into_iter().find(|(n, _, _)| *n == name) {
        Some((_, _, view)) => view(flags),
        None => fits::for_eval(name, flags, opts),
    }
}

/// Every `lobefit plot` name with its generator, sorted by name: the families', the
/// pipelines', and the export study over every textured family.
pub fn plots() -> Vec<(&'static str, PlotFn)> {
    let mut v = fits::plots();
    v.extend(pipelines::plots());
    v.push(("export", crate::export::run::plot));
    v.sort_by_key(|(n, _)| *n);
    v
}

/// `lobefit eval --help`'s text after the usage: the format, then every family's and
/// pipeline's paragraph (columns, units, domains).
pub fn eval_help() -> String {
    let mut s = crate::eval::HELP_HEADER.to_string();
    for e in fits::entries() {
        s.push_str(e.eval_help);
    }
    for (_, help, _) in pipelines::eval_views() {
        s.push_str(help);
    }
    s
}
