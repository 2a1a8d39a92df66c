//! # lobefit
//!
//! The numerical library behind the `lobefit` CLI: quadrature, the table families
//! (`fits/`, one folder each, listed in [`fits::registry`]), the rendering pipelines
//! that combine them (`pipelines/`, [`pipelines::registry`]), the build driver, the
//! checker and the CSV evaluator. No argument parsing and no printing live here.
//!
//! Conventions are those of docs/math.md §1 and of the runtime crate [`lobefit_tables`]:
//! unit direction vectors, solid angle in steradians, angles in radians, natural log,
//! cosine lobe Ψ(v; a, e) = max(a·v, 0)^e.

pub mod build;
pub mod catalog;
pub mod check;
pub mod ci;
pub mod eigen;
pub mod eval;
pub mod export;
pub mod family;
pub mod io;
pub mod memo;
pub mod plot;
pub mod quad;
pub mod rng;
pub mod sh;

/// The table families, one module each (kept in `fits/` at the repository root).
#[path = "../fits/mod.rs"]
pub mod fits;

/// The papers' rendering pipelines and what they share: scenes, the Monte Carlo
/// reference, image statistics, equal-error timing (kept in `pipelines/`).
#[path = "../pipelines/mod.rs"]
pub mod pipelines;

pub use lobefit_tables as tables;
