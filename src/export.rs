//! GPU exports: the layouts, formats, manifest and shader library of `lobefit-core`'s
//! `export`, and [`run`], the `lobefit export` / `check --export` driver, which walks
//! every family's GPU part and so sits above the families.

pub use lobefit_core::export::*;

pub mod run;
