//! `lobefit-gpu render NAME [OPTIONS]`: the one entry point of the device renders.
//! NAME is a pipeline of `lobefit::pipelines::registry()` (the names `lobefit render`
//! takes), or [`LIBRARY`], the shader library's own test image; [`RENDERS`] is the list
//! it dispatches through, each entry a subcommand with its own options
//! (`lobefit-gpu render NAME --help`). Every render runs the same skeleton
//! (`crate::render`): the output checked, the pipeline's own checks, the export's
//! textures verified, the device opened, the image rendered and compared with the CPU,
//! the comparison reported.

use std::process::ExitCode;

pub use crate::render::{Render, LIBRARY};

/// Every device render, in the registry's order, then [`LIBRARY`].
pub const RENDERS: [Render; 5] = [
    crate::meunier::RENDER,
    crate::isg::RENDER,
    crate::shexp::RENDER,
    crate::rigs::RENDER,
    crate::render::RENDER,
];

/// The render called `name`; a name that is neither a pipeline of the registry nor
/// [`LIBRARY`] is refused with the names there are.
pub fn find(name: &str) -> Result<&'static Render, String> {
    let registry = lobefit::pipelines::registry();
    if name != LIBRARY && !registry.iter().any(|p| p.name == name) {
        return Err(format!(
            "render {name}: no such pipeline (the registry's: {}; or {LIBRARY}, the shader library's test image)",
            registry.iter().map(|p| p.name).collect::<Vec<_>>().join(", ")
        ));
    }
    RENDERS
        .iter()
        .find(|r| r.name == name)
        .ok_or_else(|| format!("render {name}: the pipeline has no device render"))
}

/// `lobefit-gpu`'s command with `render`'s subcommands, one per entry of [`RENDERS`].
pub fn with_renders(cli: clap::Command) -> clap::Command {
    cli.mut_subcommand("render", |c| {
        // A name not in the list reaches [`find`], which names the renders there are.
        let c = c
            .subcommand_required(true)
            .subcommand_value_name("NAME")
            .allow_external_subcommands(true);
        RENDERS.iter().fold(c, |c, r| c.subcommand(r.command()))
    })
}

/// Runs `render NAME` on its options `matches`.
pub fn run(name: &str, matches: &clap::ArgMatches) -> Result<ExitCode, String> {
    let r = find(name)?;
    (r.run)(matches)
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// Every pipeline of the registry has a device render under its name, and every
    /// render but the library's is a pipeline of the registry.
    #[test]
    fn renders_are_the_registry_and_the_library() {
        let registry: Vec<&str> = lobefit::pipelines::registry().iter().map(|p| p.name).collect();
        let names: Vec<&str> = RENDERS.iter().map(|r| r.name).filter(|n| *n != LIBRARY).collect();
        assert_eq!(names, registry);
        assert!(find(LIBRARY).is_ok());
        assert!(find("nope").unwrap_err().contains("no such pipeline"));
    }

    /// `lobefit-gpu` with every render is a valid clap command (no conflicting or
    /// malformed arguments).
    #[test]
    fn renders_are_valid_commands() {
        with_renders(crate::Cli::command()).debug_assert();
    }
}
