//! `lobefit export --shaders`: the WGSL shader library of the runtime crate
//! (`lobefit_tables::shaders`, the one source) and its translations by naga to GLSL
//! (Vulkan/desktop 450 and ES 3.0) and HLSL (shader model 5.1).
//!
//! naga translates a module through an entry point, not a bare function library: the
//! library is parsed with a stub fragment entry point appended (it references no
//! function; naga's GLSL and HLSL writers emit every function that uses no global,
//! which is every library function, since textures are arguments), validated, written,
//! and the stub's lines are then cut from the output.

use std::path::{Path, PathBuf};

use lobefit_tables::uniform::LfTex;

use lobefit_tables::shaders;

/// A shading language `export --shaders` writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ShaderLang {
    /// WGSL (WebGPU, wgpu): the source as it ships in the runtime crate.
    Wgsl,
    /// GLSL: `lobefit.glsl` (450, Vulkan and desktop GL) and `lobefit.es.glsl` (ES 3.0, WebGL 2).
    Glsl,
    /// HLSL shader model 5.1 (D3D11/12; dxc and fxc).
    Hlsl,
}

impl ShaderLang {
    /// All languages.
    pub const ALL: [ShaderLang; 3] = [ShaderLang::Wgsl, ShaderLang::Glsl, ShaderLang::Hlsl];
    /// CLI name.
    pub fn name(self) -> &'static str {
        match self {
            ShaderLang::Wgsl => "wgsl",
            ShaderLang::Glsl => "glsl",
            ShaderLang::Hlsl => "hlsl",
        }
    }
    /// Parses a CLI name.
    pub fn parse(s: &str) -> Result<ShaderLang, String> {
        ShaderLang::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| format!("unknown shading language {s:?} (wgsl, glsl, hlsl)"))
    }
}

/// The stub entry point appended for translation; its lines are removed afterwards.
const STUB_NAME: &str = "lf_library_stub";
pub(crate) const STUB: &str =
    "\n@fragment\nfn lf_library_stub() -> @location(0) vec4<f32> {\n    return vec4<f32>(0.0);\n}\n";

/// The library parsed and validated by naga (with the stub entry point).
pub fn module() -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    module_of(&(shaders::library() + STUB))
}

/// A WGSL source parsed and validated by naga (all validation flags, all capabilities).
pub fn module_of(src: &str) -> Result<(naga::Module, naga::valid::ModuleInfo), String> {
    let module = naga::front::wgsl::parse_str(src).map_err(|e| format!("WGSL: {}", e.emit_to_string(src)))?;
    let info = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| format!("naga validation: {}", e.emit_to_string(src)))?;
    Ok((module, info))
}

/// GLSL of the library: `es` selects ES 3.0 (else 450 core). No `#version` line (the
/// including shader has one) and no entry point.
pub fn glsl(es: bool) -> Result<String, String> {
    let (module, info) = module()?;
    let version = if es {
        naga::back::glsl::Version::Embedded {
            version: 300,
            is_webgl: false,
        }
    } else {
        naga::back::glsl::Version::Desktop(450)
    };
    let options = naga::back::glsl::Options {
        version,
        writer_flags: naga::back::glsl::WriterFlags::empty(),
        ..Default::default()
    };
    let pipeline = naga::back::glsl::PipelineOptions {
        shader_stage: naga::ShaderStage::Fragment,
        entry_point: STUB_NAME.into(),
        multiview: None,
    };
    let mut out = String::new();
    naga::back::glsl::Writer::new(
        &mut out,
        &module,
        &info,
        &options,
        &pipeline,
        naga::proc::BoundsCheckPolicies::default(),
    )
    .map_err(|e| format!("GLSL writer: {e}"))?
    .write()
    .map_err(|e| format!("GLSL writer: {e}"))?;
    let mut lines: Vec<&str> = out.lines().filter(|l| !l.starts_with("#version")).collect();
    if es {
        // ES samplers default to lowp, which would narrow what a lookup returns.
        if let Some(i) = lines.iter().position(|l| l.starts_with("precision highp int;")) {
            lines.insert(
                i + 1,
                "precision highp sampler2D;\nprecision highp sampler2DArray;\nprecision highp sampler3D;",
            );
        }
    }
    Ok(strip_function(&lines, "void main()").join("\n") + "\n")
}

/// HLSL (shader model 5.1) of the library, without the entry point.
pub fn hlsl() -> Result<String, String> {
    let (module, info) = module()?;
    let options = naga::back::hlsl::Options {
        shader_model: naga::back::hlsl::ShaderModel::V5_1,
        ..Default::default()
    };
    let pipeline = naga::back::hlsl::PipelineOptions { entry_point: None };
    let mut out = String::new();
    naga::back::hlsl::Writer::new(&mut out, &options, &pipeline)
        .write(&module, &info, None)
        .map_err(|e| format!("HLSL writer: {e}"))?;
    let lines: Vec<&str> = out.lines().collect();
    Ok(strip_function(&lines, STUB_NAME).join("\n") + "\n")
}

/// `lines` without the function whose header line contains `marker` (through its
/// closing brace at column 0) and without the stub's output declarations.
fn strip_function<'a>(lines: &[&'a str], marker: &str) -> Vec<&'a str> {
    let mut out = Vec::with_capacity(lines.len());
    let mut skipping = false;
    for &l in lines {
        if skipping {
            if l.starts_with('}') {
                skipping = false;
            }
            continue;
        }
        if l.contains(marker) && !l.trim_end().ends_with(';') {
            skipping = !l.trim_end().ends_with('}');
            continue;
        }
        if l.contains("_fs2p_location0") {
            continue;
        }
        out.push(l);
    }
    out
}

/// WGSL function name suffix of texture `name`: lower case, every character other than
/// ASCII letters and digits `_` (`lobe-product-lnw` → `lobe_product_lnw`).
pub fn wgsl_identifier(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

/// File name of an export's baked uniforms ([`baked_uniforms`]).
pub const BAKED_UNIFORMS: &str = "lobefit_uniforms.wgsl";

/// The uniforms of an export's textures as WGSL constants: per texture
/// `fn lf_tex_<name>_manual() -> LfTex` and `_hardware()` (`<name>` by
/// [`wgsl_identifier`]), to concatenate after the library. A shader then passes
/// `lf_tex_cap_exponent_manual()` where the library takes an `LfTex`: no uniform
/// buffer, the constants known to the compiler. `textures`: (name, manual, hardware).
pub fn baked_uniforms(textures: &[(String, LfTex, LfTex)]) -> String {
    use std::fmt::Write as _;
    // f32 literals (suffix f): parsed as f32 directly, the shortest digits round trip.
    let f = |v: f32| format!("{v:e}f");
    let rows = |r: &[[f32; 4]]| {
        let v: Vec<String> = r
            .iter()
            .map(|q| format!("vec4<f32>({})", q.iter().map(|&x| f(x)).collect::<Vec<_>>().join(", ")))
            .collect();
        format!("array<vec4<f32>, {}>({})", r.len(), v.join(", "))
    };
    let mut s = format!(
        "// lobefit export: the LfTex of every texture here as constants (lobefit {}).\n\
         // Concatenate after the shader library; pass lf_tex_<texture>_manual() (or\n\
         // _hardware()) where a function takes an LfTex. Generated; do not edit.\n",
        env!("CARGO_PKG_VERSION")
    );
    for (name, manual, hardware) in textures {
        let id = wgsl_identifier(name);
        for (what, u) in [("manual", manual), ("hardware", hardware)] {
            let _ = write!(
                s,
                "\nfn lf_tex_{id}_{what}() -> LfTex {{\n    return LfTex(\n        {},\n        {},\n        {},\n        {},\n        {},\n        {},\n        vec4<u32>({}u, {}u, {}u, {}u),\n    );\n}}\n",
                rows(&u.axis),
                rows(&u.map),
                rows(&u.offset),
                rows(&u.scale),
                rows(&u.trend),
                rows(&u.decode),
                u.mode[0],
                u.mode[1],
                u.mode[2],
                u.mode[3]
            );
        }
    }
    s
}

/// The header of every written file: what it is and where it comes from.
fn header(comment: &str, what: &str) -> String {
    format!(
        "{comment} lobefit shader library ({what}), lobefit {}.\n{comment} Generated from the WGSL in lobefit-tables \
         (tables/shaders) by `lobefit export --shaders`; do not edit.\n{comment} Textures are function arguments; \
         each LfTex comes from an export (lobefit_uniforms.wgsl, lobefit_uniforms.h, or the manifest).\n\n",
        env!("CARGO_PKG_VERSION")
    )
}

/// Writes the library in each language of `langs` into `dir` (created if missing):
/// `lobefit.wgsl`, `lobefit.glsl` + `lobefit.es.glsl`, `lobefit.hlsl`. Atomic writes.
pub fn write(langs: &[ShaderLang], dir: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut files: Vec<(String, String)> = Vec::new();
    for &l in langs {
        match l {
            ShaderLang::Wgsl => files.push(("lobefit.wgsl".into(), header("//", "WGSL") + &shaders::library())),
            ShaderLang::Glsl => {
                files.push((
                    "lobefit.glsl".into(),
                    header("//", "GLSL 450: after `#version 450`") + &glsl(false)?,
                ));
                files.push((
                    "lobefit.es.glsl".into(),
                    header("//", "GLSL ES 3.0: after `#version 300 es`") + &glsl(true)?,
                ));
            }
            ShaderLang::Hlsl => files.push(("lobefit.hlsl".into(), header("//", "HLSL, shader model 5.1") + &hlsl()?)),
        }
    }
    let mut paths = Vec::new();
    for (name, text) in files {
        let p = dir.join(name);
        crate::io::write_atomic(&p, text.as_bytes()).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        paths.push(p);
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every WGSL file parses and validates (with those it needs before it), and the
    /// whole library translates to GLSL 450, GLSL ES 3.0 and HLSL without error.
    #[test]
    fn library_validates_and_translates() {
        let mut prefix = String::new();
        for (name, src) in shaders::FILES {
            prefix.push_str(src);
            if let Err(e) = module_of(&(prefix.clone() + STUB)) {
                panic!("{name}: {e}");
            }
        }
        for es in [false, true] {
            let g = glsl(es).unwrap();
            assert!(g.contains("lf_disk_irradiance("), "GLSL lacks a library function");
            assert!(
                !g.contains(STUB_NAME) && !g.contains("void main()"),
                "stub left in GLSL"
            );
        }
        let h = hlsl().unwrap();
        assert!(h.contains("lf_isg_best("), "HLSL lacks a library function");
        assert!(!h.contains(STUB_NAME), "stub left in HLSL");
    }
}
