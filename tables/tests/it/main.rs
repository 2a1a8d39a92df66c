//! The runtime crate's integration tests: one binary, one module per subject.

mod batch;
mod f32_twins;
mod files;
mod loader;
mod messages;
mod meta_errors;
mod table_types;
mod task_helpers;
