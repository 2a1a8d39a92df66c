//! # lobefit-core
//!
//! The bottom layer of the lobefit toolchain, under the table families and the
//! pipelines: the family traits ([`family`]), quadrature ([`quad`]), spherical
//! harmonics ([`sh`]), dense linear algebra ([`eigen`]), the build driver ([`build`])
//! and checker ([`check`]), export layouts, formats, manifest and shader library
//! ([`export`]), figures ([`plot`]), atomic I/O ([`io`]). It names no family and no
//! pipeline: the compiler keeps it so (it depends on neither crate).
//!
//! Conventions are those of docs/math.md §1 and of the runtime crate [`lobefit_tables`]:
//! unit direction vectors, solid angle in steradians, angles in radians, natural log,
//! cosine lobe Ψ(v; a, e) = max(a·v, 0)^e.

pub mod build;
pub mod check;
pub mod eigen;
pub mod export;
pub mod family;
pub mod io;
pub mod json;
pub mod memo;
pub mod plot;
pub mod quad;
pub mod rng;
pub mod sh;

pub use lobefit_tables as tables;
