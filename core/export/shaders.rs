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
/// The WGSL of the stub entry point (`export --shaders` translates the library with it).
pub const STUB: &str = "\n@fragment\nfn lf_library_stub() -> @location(0) vec4<f32> {\n    return vec4<f32>(0.0);\n}\n";

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
    glsl_of(&shaders::library(), es)
}

/// GLSL of a WGSL function library `src` (no entry point of its own), as [`glsl`].
pub fn glsl_of(src: &str, es: bool) -> Result<String, String> {
    glsl_of_module(&module_of(&format!("{src}{STUB}"))?, es)
}

/// GLSL of a library already parsed with the stub entry point, as [`glsl`].
fn glsl_of_module((module, info): &(naga::Module, naga::valid::ModuleInfo), es: bool) -> Result<String, String> {
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
        module,
        info,
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
    hlsl_of(&shaders::library())
}

/// HLSL of a WGSL function library `src` (no entry point of its own), as [`hlsl`].
pub fn hlsl_of(src: &str) -> Result<String, String> {
    hlsl_of_module(&module_of(&format!("{src}{STUB}"))?)
}

/// HLSL of a library already parsed with the stub entry point, as [`hlsl`].
fn hlsl_of_module((module, info): &(naga::Module, naga::valid::ModuleInfo)) -> Result<String, String> {
    let options = naga::back::hlsl::Options {
        shader_model: naga::back::hlsl::ShaderModel::V5_1,
        ..Default::default()
    };
    let pipeline = naga::back::hlsl::PipelineOptions { entry_point: None };
    let mut out = String::new();
    naga::back::hlsl::Writer::new(&mut out, &options, &pipeline)
        .write(module, info, None)
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

/// File names of an export's baked shader (see [`baked_shader`]): WGSL, GLSL 450,
/// GLSL ES 3.0, HLSL 5.1.
pub const BAKED_SHADERS: [&str; 4] = [
    "lobefit_baked.wgsl",
    "lobefit_baked.glsl",
    "lobefit_baked.es.glsl",
    "lobefit_baked.hlsl",
];

/// The wrappers of `baked` (see `Baked`) over the function library `library`:
/// per entry `<wrapper>(…)` calling the function with its `LfTex` arguments replaced
/// by the export's `lf_tex_<texture>_manual()`, and `<wrapper>_hw(…)` with
/// `_hardware()`; the other arguments and the return type as the function declares
/// them (its one-line header in the library).
pub fn baked_wrappers(library: &str, baked: &[super::families::Baked]) -> Result<String, String> {
    use std::fmt::Write as _;
    let mut out = String::new();
    for b in baked {
        let head = format!("fn {}(", b.function);
        let line = library
            .lines()
            .find(|l| l.starts_with(&head))
            .ok_or_else(|| format!("{}: no function {} in the shader library", b.wrapper, b.function))?;
        let open = head.len();
        let close = matching_paren(line, open - 1).ok_or_else(|| format!("{}: cannot read its header", b.function))?;
        let ret = line[close + 1..].trim().trim_end_matches('{').trim();
        let params = split_top_level(&line[open..close]);
        let lf = params
            .iter()
            .filter(|p| p.split_once(':').is_some_and(|(_, t)| t.trim() == "LfTex"))
            .count();
        if lf != b.textures.len() {
            return Err(format!(
                "{}: {} takes {lf} LfTex arguments, {} textures named",
                b.wrapper,
                b.function,
                b.textures.len()
            ));
        }
        // An exact fetch takes no sampler: one filter, one wrapper.
        let sampled = params
            .iter()
            .any(|p| p.split_once(':').is_some_and(|(_, t)| t.trim() == "sampler"));
        let filters: &[(&str, &str)] = if sampled {
            &[("", "manual"), ("_hw", "hardware")]
        } else {
            &[("", "manual")]
        };
        for &(suffix, filter) in filters {
            let mut kept = Vec::new();
            let mut args = Vec::new();
            let mut tex = b.textures.iter();
            for p in &params {
                let (name, ty) = p
                    .split_once(':')
                    .ok_or_else(|| format!("{}: cannot read {p:?}", b.function))?;
                if let Some((_, value)) = b.fixed.iter().find(|(n, _)| *n == name.trim()) {
                    args.push(value.to_string());
                } else if ty.trim() == "LfTex" {
                    let t = tex.next().map(|t| wgsl_identifier(t)).unwrap_or_default();
                    args.push(format!("lf_tex_{t}_{filter}()"));
                } else {
                    kept.push(p.trim().to_string());
                    args.push(name.trim().to_string());
                }
            }
            let _ = write!(
                out,
                "\nfn {}{suffix}({}) {ret} {{\n    return {}({});\n}}\n",
                b.wrapper,
                kept.join(", "),
                b.function,
                args.join(", ")
            );
        }
    }
    Ok(out)
}

/// The index of the `)` closing the `(` at byte `open` of `s`.
fn matching_paren(s: &str, open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (i, c) in s.char_indices().skip_while(|&(i, _)| i < open) {
        match c {
            '(' => depth += 1,
            ')' => {
                depth -= 1;
                if depth == 0 {
                    return Some(i);
                }
            }
            _ => {}
        }
    }
    None
}

/// `s` split at the commas outside `<…>` and `(…)` (WGSL parameter lists).
fn split_top_level(s: &str) -> Vec<&str> {
    let (mut depth, mut start, mut out) = (0i32, 0usize, Vec::new());
    for (i, c) in s.char_indices() {
        match c {
            '<' | '(' => depth += 1,
            '>' | ')' => depth -= 1,
            ',' if depth == 0 => {
                out.push(&s[start..i]);
                start = i + 1;
            }
            _ => {}
        }
    }
    if !s[start..].trim().is_empty() {
        out.push(&s[start..]);
    }
    out
}

/// An export's baked shader: the library, the export's uniforms as constants
/// (`uniforms`, from [`baked_uniforms`]) and the wrappers of `baked`, in WGSL
/// (validated by naga) and translated by naga like the library: one file per name
/// of [`BAKED_SHADERS`], in that order, each with its header.
pub fn baked_shader(uniforms: &str, baked: &[super::families::Baked]) -> Result<Vec<String>, String> {
    let lib = shaders::library();
    let wrappers = baked_wrappers(&lib, baked)?;
    let src = format!(
        "{lib}\n// The export's uniforms as constants.\n{uniforms}\n// Per family: the library's functions with this export's constants.\n{wrappers}"
    );
    // Parsed and validated once, translated three times (naga's front end and
    // validator are most of an export's or `check --export`'s time otherwise).
    let parsed = module_of(&format!("{src}{STUB}")).map_err(|e| format!("{}: {e}", BAKED_SHADERS[0]))?;
    let what = "baked for one export: call the `_baked` functions (manual filtering) or `_baked_hw` \
                (hardware filtering) with the texture bound";
    Ok(vec![
        header("//", &format!("WGSL, {what}")) + &src,
        header("//", &format!("GLSL 450 after `#version 450`, {what}")) + &glsl_of_module(&parsed, false)?,
        header("//", &format!("GLSL ES 3.0 after `#version 300 es`, {what}")) + &glsl_of_module(&parsed, true)?,
        header("//", &format!("HLSL, shader model 5.1, {what}")) + &hlsl_of_module(&parsed)?,
    ])
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

/// The library's files in each language of `langs`, (name, text): `lobefit.wgsl`,
/// `lobefit.glsl` + `lobefit.es.glsl`, `lobefit.hlsl`.
pub fn library_files(langs: &[ShaderLang]) -> Result<Vec<(&'static str, String)>, String> {
    let mut files = Vec::new();
    for &l in langs {
        match l {
            ShaderLang::Wgsl => files.push(("lobefit.wgsl", header("//", "WGSL") + &shaders::library())),
            ShaderLang::Glsl => {
                files.push((
                    "lobefit.glsl",
                    header("//", "GLSL 450: after `#version 450`") + &glsl(false)?,
                ));
                files.push((
                    "lobefit.es.glsl",
                    header("//", "GLSL ES 3.0: after `#version 300 es`") + &glsl(true)?,
                ));
            }
            ShaderLang::Hlsl => files.push(("lobefit.hlsl", header("//", "HLSL, shader model 5.1") + &hlsl()?)),
        }
    }
    Ok(files)
}

/// The names [`library_files`] may write.
pub const LIBRARY_FILES: [&str; 4] = ["lobefit.wgsl", "lobefit.glsl", "lobefit.es.glsl", "lobefit.hlsl"];

/// Writes [`library_files`] of `langs` into `dir` (created if missing). Atomic writes.
pub fn write(langs: &[ShaderLang], dir: &Path) -> Result<Vec<PathBuf>, String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let mut paths = Vec::new();
    for (name, text) in library_files(langs)? {
        let p = dir.join(name);
        crate::io::write_atomic(&p, text.as_bytes()).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        paths.push(p);
    }
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::export::families::Baked;

    /// Wrappers drop the `LfTex` arguments (and fixed ones), keep the rest in order,
    /// and get a `_hw` twin only when the function samples; a wrong function or a
    /// wrong number of textures is an error naming the wrapper.
    #[test]
    fn baked_wrappers_keep_the_signature_without_uniforms() {
        let lib = "fn f(tex: texture_2d<f32>, smp: sampler, p: LfTex, n: u32, v: array<f32, 8>) -> f32 {\n}\n\
                   fn g(tex: texture_3d<f32>, p: LfTex, tex2: texture_2d<f32>, p2: LfTex, x: f32) -> vec2<f32> {\n}\n";
        let b = |wrapper, function, textures, fixed| Baked {
            wrapper,
            function,
            textures,
            fixed,
        };
        let w = baked_wrappers(lib, &[b("f_b", "f", &["a-b"], &[("n", "4u")])]).unwrap();
        assert!(
            w.contains("fn f_b(tex: texture_2d<f32>, smp: sampler, v: array<f32, 8>) -> f32 {\n    return f(tex, smp, lf_tex_a_b_manual(), 4u, v);"),
            "{w}"
        );
        assert!(
            w.contains("fn f_b_hw(") && w.contains("lf_tex_a_b_hardware(), 4u, v)"),
            "{w}"
        );
        let w = baked_wrappers(lib, &[b("g_b", "g", &["t", "u"], &[])]).unwrap();
        assert!(
            w.contains("fn g_b(tex: texture_3d<f32>, tex2: texture_2d<f32>, x: f32) -> vec2<f32> {\n    return g(tex, lf_tex_t_manual(), tex2, lf_tex_u_manual(), x);"),
            "{w}"
        );
        assert!(!w.contains("g_b_hw"), "no sampler, no hardware twin: {w}");
        let e = baked_wrappers(lib, &[b("h_b", "h", &["t"], &[])]).unwrap_err();
        assert!(e.contains("h_b") && e.contains("no function h"), "{e}");
        let e = baked_wrappers(lib, &[b("g_b", "g", &["t"], &[])]).unwrap_err();
        assert!(e.contains("takes 2 LfTex arguments, 1 textures named"), "{e}");
    }

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
