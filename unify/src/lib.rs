//! No code: this crate only asks for the union of the features that lobefit's crates
//! ask of their shared dependencies, so that every package selection builds each of
//! them once (see its Cargo.toml).
