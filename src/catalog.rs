//! What the command line lists: the table families' names, `eval` queries and figure
//! sets (`fits/`) together with the pipelines' (`pipelines/`). It sits above both, so
//! neither `fits` nor `pipelines` needs to know the other's list.

use crate::family::{EvalError, EvalFlag, EvalFlags, View};
use crate::fits::{self, FitOptions, PlotFn};
use crate::pipelines;

/// Names `lobefit eval` accepts: every family, the families' extra views (`isg`),
/// then the pipelines' (`direct-light`).
pub fn eval_names() -> Vec<&'static str> {
    let mut v = fits::eval_names();
    v.extend(pipelines::eval_views().into_iter().map(|v| v.name));
    v
}

/// The query `lobefit eval NAME [flags]` runs, configured by its flags; errors name
/// the flag a query does not take or the value it does not know.
pub fn for_eval(name: &str, flags: &EvalFlags, opts: FitOptions) -> Result<Box<dyn View>, EvalError> {
    match pipelines::eval_views().into_iter().find(|v| v.name == name) {
        Some(v) => {
            flags.only(name, v.flags)?;
            (v.view)(flags)
        }
        None => Ok(fits::for_eval(name, flags, opts)?),
    }
}

/// Every flag `lobefit eval` offers, once per name, with the queries that take it and
/// what each says of its values (`order`: `log-zh: 1..=8 …`), in the order first
/// declared: the command line's `--NAME` arguments are built from this.
pub fn eval_flags() -> Vec<(EvalFlag, Vec<(&'static str, &'static str)>)> {
    let mut declared: Vec<(&'static str, EvalFlag)> = Vec::new();
    for name in fits::eval_names() {
        declared.extend(fits::eval_flags(name).iter().map(|f| (name, *f)));
    }
    for v in pipelines::eval_views() {
        declared.extend(v.flags.iter().map(|f| (v.name, *f)));
    }
    let mut out: Vec<(EvalFlag, Vec<(&'static str, &'static str)>)> = Vec::new();
    for (query, flag) in declared {
        match out.iter_mut().find(|(f, _)| f.name == flag.name) {
            Some((f, takers)) => {
                // One name, one kind of value: the command line parses it once.
                assert_eq!(f.count, flag.count, "--{} declared as a number and as a word", f.name);
                takers.push((query, flag.help));
            }
            None => out.push((flag, vec![(query, flag.help)])),
        }
    }
    out
}

/// Every `lobefit plot` name with its generator, sorted by name: the families', the
/// pipelines', and the export study over every textured family.
pub fn plots() -> Vec<(&'static str, PlotFn)> {
    let mut v = fits::plots();
    v.extend(pipelines::plots());
    v.push(("export", crate::export::run::plot));
    v.push(("baselines", pipelines::baselines::plot));
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
    for v in pipelines::eval_views() {
        s.push_str(v.help);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A flag is refused by every query that does not declare it (before, `eval wedge
    /// --mask aggressive` ran and ignored the flag), and the refusal names it.
    #[test]
    fn every_query_refuses_the_flags_it_does_not_declare() {
        let all = eval_flags();
        assert!(all.len() >= 11, "{} flags declared", all.len());
        for name in eval_names() {
            for (flag, takers) in &all {
                if takers.iter().any(|(q, _)| *q == name) {
                    continue;
                }
                let flags = if flag.count {
                    EvalFlags::default().with_count(flag.name, 1)
                } else {
                    EvalFlags::default().with(flag.name, "x")
                };
                let e = for_eval(name, &flags, FitOptions::default())
                    .err()
                    .map(|e| e.to_string());
                let want = format!("{name} takes no --{} flag", flag.name);
                assert!(
                    e.as_ref().is_some_and(|e| e.starts_with(&want)),
                    "{name} --{}: {e:?}",
                    flag.name
                );
            }
        }
    }
}
