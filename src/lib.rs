//! # lobefit
//!
//! The `lobefit` CLI's library: argument-free orchestration on top of the layers
//! (`lobefit-core`, `lobefit-fits`, `lobefit-pipelines`), which it re-exports under
//! their old paths (`lobefit::quad`, `lobefit::fits`, `lobefit::pipelines`, …) so that
//! tests, benches and the GPU crate name one crate. What lives here names both families
//! and pipelines: the catalog of `eval`/`plot` names, the CSV evaluator, the export
//! run, the checker's CI reports. No argument parsing and no printing live here.
//!
//! Conventions are those of docs/math.md §1 and of the runtime crate [`lobefit_tables`]:
//! unit direction vectors, solid angle in steradians, angles in radians, natural log,
//! cosine lobe Ψ(v; a, e) = max(a·v, 0)^e.

pub mod catalog;
pub mod ci;
pub mod eval;
pub mod export;

pub use lobefit_core::{build, check, eigen, family, io, json, memo, plot, quad, rng, sh};
pub use lobefit_fits as fits;
pub use lobefit_pipelines as pipelines;
pub use lobefit_tables as tables;
