//! The `lobefit` crate's integration tests: one binary (one link of the crate),
//! one module per subject. Heavy sweeps are `#[ignore]`d here and run from `.ci/run`
//! (`cargo test --test it -- --ignored`, reusing this build).

mod check_ci;
mod check_corruption;
mod cli;
mod cli_io;
mod committed_tables;
mod common;
mod disk_light;
mod envmap;
mod eps_study;
mod eval_direct_light;
mod eval_memory;
mod export;
mod export_check;
mod export_formats;
mod export_isg_best;
mod export_shaders;
mod export_shexp;
mod export_wedge;
mod io;
mod isg;
mod lobe_product;
mod log_zh;
mod meshes;
mod meunier;
mod reliability;
mod render_isg;
mod render_meunier;
mod render_rigs;
mod render_shexp;
mod rigs;
mod shexp;
mod wedge;
mod wrap;
