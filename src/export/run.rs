//! The export driver (`lobefit export`) and its checker (`lobefit check --export`):
//! textures written, read back with independent readers, and sampled as a GPU
//! samples them, against the families' independent references.

use std::path::{Path, PathBuf};

use lobefit_tables::Table;
use rayon::prelude::*;
use serde::Serialize;

use super::families::{Emulated, GpuFamily};
use super::formats;
use super::layout::{Channel, Filter, Grid, Sampler, TexAxis};
use super::manifest::{
    ErrorEntry, FamilyEntry, Manifest, TextureEntry, MANIFEST, MANIFEST_SCHEMA, MANIFEST_SCHEMA_FILE, MANIFEST_VERSION,
};
use super::{Format, Storage, Texture};
use crate::check::{f32_point, offgrid_metrics};
use crate::family::Checked;
use crate::fits;
use crate::fits::{registry, FitOptions};
use crate::rng::Rng;

/// Off-grid samples per family the export error is measured on.
pub const SAMPLES: usize = 2000;
/// Their seed (the checker's).
pub const SEED: u64 = crate::check::CheckOptions::QUICK.seed;

/// What `lobefit export` writes.
#[derive(Debug, Clone, PartialEq)]
pub struct ExportOptions {
    /// Families (table kinds); empty = every textured family.
    pub only: Vec<String>,
    /// Container format.
    pub format: Format,
    /// Texel precision.
    pub storage: Storage,
    /// Nodes per axis relative to the table's (see [`grid_of_table`]).
    pub scale: f64,
    /// Export a texture that misses its target — the larger of the family's limit and
    /// the storage's rounding floor ([`Storage::rounding_floor`]): f16 beyond its
    /// floor, a coarse `scale` — with its measured error in the manifest, instead of
    /// refusing it.
    pub allow_lossy: bool,
}

/// The registry's family of `kind` (default options).
pub fn family_of(kind: &str) -> Option<Box<dyn Checked>> {
    registry(FitOptions::default())
        .into_iter()
        .find(|f| f.kind() == kind)
        .map(|f| -> Box<dyn Checked> { f })
}

/// The export error of one texture stored as `storage`, per filter: the family's own
/// pointwise check run through the emulated GPU lookup at seeded off-grid samples
/// (rounded to f32, the inputs a shader gets), reduced to the family's off-grid
/// threshold metrics, each with its rounding floor (see [`channel_floors`]).
pub fn measure(
    family: &dyn Checked,
    gpu: GpuFamily,
    textures: &[(Vec<TexAxis>, Vec<Channel>, super::Texture)],
    storage: Storage,
    samples: usize,
    seed: u64,
) -> Result<Vec<ErrorEntry>, String> {
    let points = sample_points(family, samples, seed)?;
    let floors = channel_floors(textures.iter().map(|(_, c, t)| (c.as_slice(), t)), storage);
    let mut out = Vec::new();
    for filter in Filter::ALL {
        let samplers: Vec<Sampler> = textures
            .iter()
            .map(|(axes, channels, texture)| Sampler {
                axes: axes.clone(),
                channels: channels.clone(),
                texture: texture.clone(),
                filter,
                rounding: Default::default(),
            })
            .collect();
        let emu = Emulated {
            family: gpu,
            samplers: &samplers,
        };
        out.extend(errors_of(family, &emu, &points, filter, &floors)?);
        if let Some(extra) = gpu.extra {
            for e in extra(&samplers, samples, seed).map_err(|e| format!("{}: {e}", family.kind()))? {
                let floor = floor_of(&floors, &e.output, &e.metric);
                out.push(entry(filter, e.output, e.metric, e.measured, e.target, floor));
            }
        }
    }
    Ok(out)
}

/// The seeded off-grid samples the export error is measured on: `samples` points of
/// `family.sample`, each rounded to the f32 inputs a shader gets (staying in the
/// runtime's domain).
pub fn sample_points(family: &dyn Checked, samples: usize, seed: u64) -> Result<Vec<Vec<f64>>, String> {
    let mut rng = Rng::new(seed);
    let points: Vec<Vec<f64>> = (0..samples).map(|_| family.sample(&mut rng)).collect();
    // The CPU runtime only tells which f32 roundings of a sample stay in the domain.
    let table = Table::from_bytes(family.embedded()).map_err(|e| format!("{}: {e}", family.kind()))?;
    let cpu = family.runtime(table).map_err(|e| format!("{}: {e}", family.kind()))?;
    Ok(points.iter().map(|x| f32_point(cpu.as_ref(), x)).collect())
}

/// The rounding floor of one channel of an export (see [`channel_floors`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ChannelFloor {
    /// Channel name.
    pub name: String,
    /// The texel holds the natural log: the floor is relative.
    pub log: bool,
    /// [`Storage::channel_floor`] of the channel.
    pub floor: f64,
}

/// The rounding floor of every channel of `textures` (each texture with its
/// channels) stored as `storage`: [`Storage::channel_floor`] of the channel's scale,
/// its largest |texel| and a bound on its largest decoded |value| (|offset| + |scale|
/// · max |texel| + Σ |trend coefficients|). A compressed channel states none.
pub fn channel_floors<'a>(
    textures: impl IntoIterator<Item = (&'a [Channel], &'a Texture)>,
    storage: Storage,
) -> Vec<ChannelFloor> {
    let mut out = Vec::new();
    for (channels, t) in textures {
        let per_texel = t.channels.max(1) as usize;
        let texels = (t.width * t.height * t.depth) as usize;
        for ch in channels.iter().filter(|c| c.compression == 0.0) {
            let max_texel = (0..texels)
                .filter_map(|i| {
                    t.data
                        .get((ch.layer as usize * texels + i) * per_texel + ch.component as usize)
                })
                .fold(0.0f64, |m, &v| m.max(f64::from(v).abs()));
            let max_value =
                ch.offset.abs() + ch.scale.abs() * max_texel + ch.trend.iter().map(|c| c.abs()).sum::<f64>();
            out.push(ChannelFloor {
                name: ch.name.clone(),
                log: ch.log,
                floor: storage.channel_floor(ch.scale, max_texel, max_value),
            });
        }
    }
    out
}

/// The floor of quantity `output` under `metric`: its channel's (same name) for an
/// `_abs` metric of a linear channel or a `_rel` metric of a log channel; 0 (none
/// stated) otherwise.
pub fn floor_of(floors: &[ChannelFloor], output: &str, metric: &str) -> f64 {
    floors
        .iter()
        .filter(|c| c.name == output && (c.log == metric.ends_with("_rel")))
        .map(|c| c.floor)
        .fold(0.0, f64::max)
}

/// One measured error with its rounding floor `floor`; its promise the family's target
/// where met, else the measured value (the floor decides only whether an export needs
/// `allow_lossy`: no promise is looser than what the file achieves).
fn entry(filter: Filter, output: String, metric: String, measured: f64, target: f64, floor: f64) -> ErrorEntry {
    ErrorEntry {
        filter,
        floor,
        promise: if measured <= target { target } else { measured },
        output,
        metric,
        measured,
        target,
    }
}

/// The family's own pointwise check (`Checked::check_point`) of `lookup` at `points`
/// (from [`sample_points`]), reduced to its off-grid threshold metrics: one entry per
/// threshold, labelled `filter`, with its rounding floor from `floors` ([`floor_of`]).
pub fn errors_of(
    family: &dyn Checked,
    lookup: &dyn crate::family::Lookup,
    points: &[Vec<f64>],
    filter: Filter,
    floors: &[ChannelFloor],
) -> Result<Vec<ErrorEntry>, String> {
    let mut out = Vec::new();
    let res: Vec<_> = points.par_iter().map(|x| family.check_point(lookup, x)).collect();
    if let Some(Err(e)) = res.iter().find(|r| r.is_err()) {
        return Err(format!("{}: {e}", family.kind()));
    }
    for (k, name) in family.checked().iter().enumerate() {
        let (mut abs, mut rel) = (Vec::new(), Vec::new());
        for (g, w) in res.iter().flatten().flatten() {
            if g[k].is_nan() && w[k].is_nan() {
                continue;
            }
            abs.push((g[k] - w[k]).abs());
            rel.push(crate::check::rel_err(g[k], w[k]));
        }
        for (metric, measured, limit) in offgrid_metrics(family, name, abs, rel) {
            let floor = floor_of(floors, name, &metric);
            out.push(entry(filter, name.to_string(), metric, measured, limit, floor));
        }
    }
    Ok(out)
}

/// The families `opts.only` names (every textured family when empty) and its scale,
/// checked: an unknown family, one a shader evaluates in closed form, or a scale
/// outside (0, 16] is refused (the usage errors of `lobefit export`).
pub fn validate(opts: &ExportOptions) -> Result<Vec<GpuFamily>, String> {
    super::layout::check_scale(opts.scale)?;
    if opts.only.is_empty() {
        return Ok(fits::textured());
    }
    opts.only
        .iter()
        .map(|k| {
            fits::gpu_family(k).ok_or_else(|| {
                if let Some(c) = fits::closed_form().into_iter().find(|c| c.kind == k) {
                    format!(
                        "{k} needs no texture: a shader evaluates it in closed form ({})",
                        c.formula
                    )
                } else {
                    let all: Vec<&str> = fits::textured().iter().map(|f| f.kind).collect();
                    format!("unknown family {k:?} (textured families: {})", all.join(", "))
                }
            })
        })
        .collect()
}

/// The texture-coordinate convention every manifest states.
pub const CONVENTION: &str = "Node i of an axis with n nodes sits at the centre of texel i: texture coordinate \
     u = (s + 0.5) / n with s ∈ [0, n − 1] the node coordinate (formula per axis). \
     2D textures: x = the table's fastest axis, y = the slower one. A channel's value is \
     trend(t) + offset + scale · texel (trend: a quintic in t = s / (n − 1), Horner in f32, 1D f16 textures only), then exp() for log channels. Manual filtering: fetch the two \
     (four) neighbouring texels and interpolate in f32; hardware filtering: a linear sampler \
     with clamp-to-edge addressing (its sub-texel weights have 8 fractional bits).";

/// The export lock's file in an export directory (see [`move_in`]).
pub const LOCK_FILE: &str = ".lobefit-export.lock";

/// The manifest entry of `grid`'s texture, written as `format` in a file of `bytes`.
fn texture_entry(grid: &Grid, format: Format, bytes: u64) -> TextureEntry {
    let t = &grid.texture;
    TextureEntry {
        file: format!("{}.{}", t.name, format.extension()),
        bytes,
        dimension: t.dimension,
        extent: [t.width, t.height, t.depth, t.layers, t.channels],
        axis_formulas: grid.axes.iter().map(TexAxis::formula).collect(),
        axes: grid.axes.clone(),
        channels: grid.channels.clone(),
    }
}

/// The manifest of an export of `families` with these settings.
fn manifest_of(format: Format, storage: Storage, scale: f64, families: Vec<FamilyEntry>) -> Manifest {
    Manifest {
        version: MANIFEST_VERSION,
        format,
        storage,
        scale,
        convention: CONVENTION.into(),
        samples: SAMPLES,
        seed: SEED,
        uniforms_header: formats::UNIFORMS_HEADER.into(),
        uniforms_wgsl: super::shaders::BAKED_UNIFORMS.into(),
        baked_shaders: super::shaders::BAKED_SHADERS.iter().map(|s| s.to_string()).collect(),
        families,
        closed_form: fits::closed_form()
            .iter()
            .map(|c| (c.kind.to_string(), c.formula.to_string()))
            .collect(),
    }
}

/// The files an export writes beside the textures and the manifest, by name, for
/// manifest `m`: the uniforms of its textures (C header, WGSL), the baked shaders in
/// every language, the manifest's schema.
fn companion_files(m: &Manifest) -> Result<Vec<(&'static str, String)>, String> {
    let mut uniforms = Vec::new();
    for t in m.families.iter().flat_map(|f| &f.textures) {
        let name = t.file.split('.').next().unwrap_or_default().to_string();
        uniforms.push((name, t.lf_tex(Filter::Manual)?, t.lf_tex(Filter::Hardware)?));
    }
    let wgsl = super::shaders::baked_uniforms(&uniforms);
    let baked: Vec<super::families::Baked> = m
        .families
        .iter()
        .filter_map(|f| fits::gpu_family(&f.family))
        .flat_map(|g| g.baked.iter().copied())
        .collect();
    let mut files = vec![(formats::UNIFORMS_HEADER, formats::uniforms_header(&uniforms))];
    files.extend(
        super::shaders::BAKED_SHADERS
            .into_iter()
            .zip(super::shaders::baked_shader(&wgsl, &baked)?),
    );
    files.push((super::shaders::BAKED_UNIFORMS, wgsl));
    files.push((MANIFEST_SCHEMA_FILE, MANIFEST_SCHEMA.to_string()));
    Ok(files)
}

/// The files an export directory may hold besides its textures: the manifest, its
/// schema, the lock, the companions (uniforms, baked shaders) and the shader library.
fn known_names() -> Vec<&'static str> {
    let mut v = vec![MANIFEST, MANIFEST_SCHEMA_FILE, LOCK_FILE, formats::UNIFORMS_HEADER];
    v.extend(super::shaders::BAKED_SHADERS);
    v.push(super::shaders::BAKED_UNIFORMS);
    v.extend(super::shaders::LIBRARY_FILES);
    v
}

/// The texture files (and raw sidecars) of the lobefit export in `dir`: those its
/// manifest lists, when `manifest.json` is a lobefit export manifest of this version
/// (read strictly, its structure whole); `None` when there is none, or it is another
/// program's or unreadable (its files then count as foreign, the manifest too).
fn listed_textures(dir: &Path) -> Option<Vec<String>> {
    let text = crate::io::read_text(&dir.join(MANIFEST), MAX_MANIFEST_BYTES).ok()?;
    let v = crate::json::value(&text).ok()?;
    if v.get("version").and_then(|v| v.as_u64()) != Some(u64::from(MANIFEST_VERSION)) {
        return None;
    }
    let m: Manifest = serde_json::from_value(v).ok()?;
    let mut out = Vec::new();
    for t in m.families.iter().flat_map(|f| &f.textures) {
        out.push(t.file.clone());
        if t.file.ends_with(".raw") {
            out.push(Path::new(&t.file).with_extension("json").to_string_lossy().into_owned());
        }
    }
    Some(out)
}

/// Whether `name` in an export directory is a staging folder of an export (hidden,
/// `.lobefit-export.<random>`), left by one under way or killed: never part of the
/// export, and neither the export nor its check counts it.
fn is_stage(name: &str) -> bool {
    name.starts_with(".lobefit-export.") && name != LOCK_FILE
}

/// Refuses an export into `dir` unless it is missing, empty, or holds only what a
/// lobefit export or shader library writes (an earlier export, which the new one
/// replaces whole: its textures that the new one does not write are removed). A file of
/// anything else would stay beside the export, and `check --export` refuses a
/// directory holding one; so does an existing `dir` that is not a directory. Staging
/// folders of a concurrent or killed export (hidden, `.lobefit-export.*`) are left,
/// and neither this nor `check --export` counts them.
pub fn check_dir(dir: &Path) -> Result<(), String> {
    let entries = match std::fs::read_dir(dir) {
        Ok(e) => e,
        Err(_) if !dir.exists() => return Ok(()),
        Err(e) => return Err(format!("--out {}: cannot read it as a directory: {e}", dir.display())),
    };
    // With a lobefit manifest: its textures and every companion are ours; without one,
    // only the shader library (`export --shaders` alone) and the lock.
    let listed = listed_textures(dir);
    let known: Vec<&str> = match &listed {
        Some(_) => known_names(),
        None => {
            let mut k = super::shaders::LIBRARY_FILES.to_vec();
            k.push(LOCK_FILE);
            k
        }
    };
    let listed = listed.unwrap_or_default();
    let mut foreign = Vec::new();
    for e in entries {
        let e = e.map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
        let name = e.file_name().to_string_lossy().into_owned();
        if is_stage(&name) {
            continue;
        }
        let ours = known.contains(&name.as_str()) || listed.contains(&name);
        let file = e.file_type().is_ok_and(|t| t.is_file());
        if !(ours && file) {
            foreign.push(name);
        }
    }
    if foreign.is_empty() {
        return Ok(());
    }
    foreign.sort();
    let shown: Vec<String> = foreign.iter().take(8).map(|n| format!("{n:?}")).collect();
    Err(format!(
        "--out {}: holds {} entr{} that no lobefit export writes: {}{} (export into a new or empty \
         directory, or over an earlier export, which is replaced whole)",
        dir.display(),
        foreign.len(),
        if foreign.len() == 1 { "y" } else { "ies" },
        shown.join(", "),
        if foreign.len() > 8 { ", …" } else { "" }
    ))
}

/// Writes the textures of `opts` and their manifest into `dir` (created if missing).
/// Returns the manifest. Refuses (an error naming the measured error and the target)
/// an f16 texture that misses its target with manual filtering, unless
/// `allow_lossy`. Every file is written atomically.
pub fn export(opts: &ExportOptions, dir: &Path) -> Result<Manifest, String> {
    let gpu = validate(opts)?;
    check_dir(dir)?;
    // All or nothing: every texture is written and measured in a hidden staging
    // directory (removed on any error); only then do the files move into `dir`.
    let stage = Stage::new(dir)?;
    let mut entries = Vec::new();
    for g in gpu {
        let family = family_of(g.kind).ok_or_else(|| format!("{}: not in the registry", g.kind))?;
        let table = Table::from_bytes(family.embedded()).map_err(|e| format!("{}: {e}", g.kind))?;
        let grids = (g.grids)(g.kind, &table, opts.storage, opts.scale)?;
        let mut back = Vec::new();
        let mut tex_entries = Vec::new();
        for grid in grids {
            let path = formats::write(&grid.texture, opts.format, opts.storage, stage.path())?;
            // Measure the file as a reader sees it, through the independent reader.
            let (tex, _) = formats::read(&path, opts.format)?;
            let bytes = std::fs::metadata(&path).map(|m| m.len()).unwrap_or(0);
            tex_entries.push(texture_entry(&grid, opts.format, bytes));
            back.push((grid.axes, grid.channels, tex));
        }
        let error = measure(family.as_ref(), g, &back, opts.storage, SAMPLES, SEED)?;
        // The target is the larger of the family's limit and the storage's rounding
        // floor: what is left (f16 beyond its floor, a coarse --scale) is a loss the
        // user asks for explicitly.
        if !opts.allow_lossy {
            if let Some(e) = error.iter().find(|e| e.filter == Filter::Manual && !e.meets_target()) {
                // f32 is suggested only where an f32 export at this scale meets every target.
                let f32_helps = opts.storage == Storage::F16
                    && measure_in_memory(family.as_ref(), g, &table, Storage::F32, opts.scale)?
                        .iter()
                        .all(|e| e.filter != Filter::Manual || e.meets_target());
                return Err(refusal(g.kind, opts, e, f32_helps));
            }
        }
        entries.push(FamilyEntry {
            family: g.kind.to_string(),
            inputs: family.inputs().iter().map(|s| s.to_string()).collect(),
            shader: g.shader.to_string(),
            textures: tex_entries,
            error,
        });
    }
    let manifest = manifest_of(opts.format, opts.storage, opts.scale, entries);
    // The uniforms' WGSL is valid: `companion_files` validated the baked shader, the
    // library with these uniforms and the wrappers, by naga.
    for (name, text) in companion_files(&manifest)? {
        crate::io::write_atomic(&stage.path().join(name), text.as_bytes())
            .map_err(|e| format!("cannot write {}: {e}", dir.join(name).display()))?;
    }
    let json = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
    crate::io::write_atomic(&stage.path().join(MANIFEST), json.as_bytes())
        .map_err(|e| format!("cannot write {}: {e}", dir.join(MANIFEST).display()))?;
    stage.commit()?;
    Ok(manifest)
}

/// The export errors of family `gpu`'s textures built from `table` at `storage` and
/// `scale` and measured in memory (texels rounded to `storage`, as a file holds them).
fn measure_in_memory(
    family: &dyn Checked,
    gpu: GpuFamily,
    table: &Table,
    storage: Storage,
    scale: f64,
) -> Result<Vec<ErrorEntry>, String> {
    let back: Vec<_> = (gpu.grids)(gpu.kind, table, storage, scale)?
        .into_iter()
        .map(|g| {
            let mut t = g.texture;
            for v in &mut t.data {
                *v = stored(*v, storage);
            }
            (g.axes, g.channels, t)
        })
        .collect();
    measure(family, gpu, &back, storage, SAMPLES, SEED)
}

/// `v` as a texel of `storage` holds it.
fn stored(v: f32, storage: Storage) -> f32 {
    match storage {
        Storage::F32 => v,
        Storage::F16 => half::f16::from_f32(v).to_f32(),
    }
}

/// Why an export of family `kind` with `opts` is refused: the measured error `e`
/// misses its target (manual filtering). Suggests only what would help: f32 where
/// the storage is f16 and an f32 export meets every target (`f32_helps`), the
/// table's own grid where `--scale` is below 1.
fn refusal(kind: &str, opts: &ExportOptions, e: &ErrorEntry, f32_helps: bool) -> String {
    let mut fixes = vec!["leave it out (--only)".to_string()];
    if f32_helps {
        fixes.push("use --storage f32".into());
    }
    if opts.scale < 1.0 {
        fixes.push("use a finer --scale (1 is the table's own grid)".into());
    }
    fixes.push("or --allow-lossy to export it with that error recorded".into());
    let against = if e.floor > 0.0 {
        format!(
            "{:.1e} (the larger of the family's limit {:.1e} and {}'s rounding floor {:.1e})",
            e.export_target(),
            e.target,
            opts.storage,
            e.floor
        )
    } else {
        format!("the family's limit {:.1e}", e.target)
    };
    format!(
        "{kind}: {} at scale {} misses the target: {} {} = {:.3e} against {against}, manual filtering; \
         nothing was written; {}",
        opts.storage,
        opts.scale,
        e.output,
        e.metric,
        e.measured,
        fixes.join(", ")
    )
}

/// The staging directory of an export (see [`export`]): a new `dir` is staged beside
/// it and renamed into place whole; into an existing `dir` the staged files move one
/// by one, the manifest last (a reader goes by the manifest). Dropped uncommitted, it
/// is removed with everything in it.
struct Stage {
    tmp: tempfile::TempDir,
    dir: std::path::PathBuf,
    fresh: bool,
}

impl Stage {
    fn new(dir: &Path) -> Result<Stage, String> {
        let cannot = |e: std::io::Error| format!("cannot create {}: {e}", dir.display());
        let fresh = !dir.exists();
        let parent = if fresh {
            let parent = dir
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            std::fs::create_dir_all(parent).map_err(cannot)?;
            parent
        } else if dir.is_dir() {
            dir
        } else {
            return Err(format!("{} exists and is not a directory", dir.display()));
        };
        let tmp = tempfile::Builder::new()
            .prefix(".lobefit-export.")
            .tempdir_in(parent)
            .map_err(cannot)?;
        Ok(Stage {
            tmp,
            dir: dir.to_path_buf(),
            fresh,
        })
    }

    fn path(&self) -> &Path {
        self.tmp.path()
    }

    fn commit(self) -> Result<(), String> {
        if self.fresh {
            let from = self.tmp.keep();
            match std::fs::rename(&from, &self.dir) {
                Ok(()) => return Ok(()),
                // Another export created the directory meanwhile: join it as an
                // export into an existing directory does.
                Err(_) if self.dir.is_dir() => {
                    let r = move_in(&from, &self.dir);
                    let _ = std::fs::remove_dir_all(&from);
                    return r;
                }
                Err(e) => {
                    let _ = std::fs::remove_dir_all(&from);
                    return Err(format!("cannot move {} to {}: {e}", from.display(), self.dir.display()));
                }
            }
        }
        move_in(self.path(), &self.dir)
    }
}

/// Moves every file of `stage` into `dir`, the manifest last, holding `dir`'s export
/// lock: concurrent exports into one directory each leave a manifest that describes
/// its own files (the last one wins whole). The lock is released when the file
/// closes, also on a crash.
fn move_in(stage: &Path, dir: &Path) -> Result<(), String> {
    let lock_path = dir.join(LOCK_FILE);
    let lock = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&lock_path)
        .map_err(|e| format!("cannot lock {}: {e}", lock_path.display()))?;
    lock.lock()
        .map_err(|e| format!("cannot lock {}: {e}", lock_path.display()))?;
    // The earlier export's textures, under the lock: those this one does not write go.
    let earlier = listed_textures(dir).unwrap_or_default();
    let mut names: Vec<std::ffi::OsString> = std::fs::read_dir(stage)
        .map_err(|e| format!("cannot read {}: {e}", stage.display()))?
        .map(|d| d.map(|d| d.file_name()))
        .collect::<Result<_, _>>()
        .map_err(|e| format!("cannot read {}: {e}", stage.display()))?;
    names.sort_by_key(|n| n == MANIFEST);
    for n in &names {
        let (from, to) = (stage.join(n), dir.join(n));
        std::fs::rename(&from, &to).map_err(|e| format!("cannot move {} to {}: {e}", from.display(), to.display()))?;
    }
    for old in earlier {
        let p = dir.join(&old);
        let plain = !old.contains(['/', '\\']) && !old.starts_with('.');
        if plain && !names.iter().any(|n| *n == *old) && std::fs::symlink_metadata(&p).is_ok_and(|m| m.is_file()) {
            std::fs::remove_file(&p).map_err(|e| format!("cannot remove {}: {e}", p.display()))?;
        }
    }
    Ok(())
}

/// One re-measured error of `check --export`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ExportCheck {
    /// Family.
    pub family: String,
    /// The manifest's entry and the value measured now.
    pub entry: ErrorEntry,
    /// Measured now.
    pub now: f64,
    /// `now` within the manifest's promise.
    pub pass: bool,
}

/// A manifest and its directory, read and checked.
pub struct Export {
    /// The manifest.
    pub manifest: Manifest,
    /// The textures of each family (in the manifest's order), read back by the
    /// independent readers.
    pub textures: Vec<Vec<(TextureEntry, Texture)>>,
}

/// Reads `dir/manifest.json` and every texture it names through the independent
/// readers, checking each file's storage and extent against the manifest (`check
/// --export` and `lobefit-gpu` both start here). Errors name the file.
pub fn read_export(dir: &Path) -> Result<Export, String> {
    read_export_json(dir).map(|(export, _)| export)
}

/// [`read_export`], with the manifest as the JSON it holds.
fn read_export_json(dir: &Path) -> Result<(Export, serde_json::Value), String> {
    if !dir.is_dir() {
        return Err(format!(
            "{}: no such export directory (run `lobefit export --format ktx2 --out DIR` first)",
            dir.display()
        ));
    }
    let path = dir.join(MANIFEST);
    regular_file(&path)?;
    let text = crate::io::read_text(&path, MAX_MANIFEST_BYTES)?;
    // The version first: an older layout is named as such, not as malformed.
    // Strictly: a key given twice would promise two things (a storage, a version).
    let value: serde_json::Value =
        crate::json::value(&text).map_err(|e| format!("{}: not a lobefit export manifest: {e}", path.display()))?;
    match value.get("version").map(|v| (v, v.as_u64())) {
        Some((_, Some(v))) if v == u64::from(MANIFEST_VERSION) => {}
        Some((_, Some(v))) => {
            return Err(format!(
                "{}: manifest version {v} (this lobefit reads {MANIFEST_VERSION}; export again)",
                path.display()
            ))
        }
        Some((v, None)) => {
            return Err(format!(
                "{}: manifest field `version` is {v}: expected the integer {MANIFEST_VERSION}",
                path.display()
            ))
        }
        None => {
            return Err(format!(
                "{}: not a lobefit export manifest: no field `version`",
                path.display()
            ))
        }
    }
    let manifest: Manifest = serde_json::from_value(value.clone())
        .map_err(|e| format!("{}: not a lobefit export manifest: {e}", path.display()))?;
    let mut textures = Vec::new();
    for f in &manifest.families {
        let mut ts = Vec::new();
        for t in &f.textures {
            let file = texture_path(dir, &t.file, manifest.format, manifest.storage, &t.extent)?;
            let (tex, storage) = formats::read(&file, manifest.format)?;
            if storage != manifest.storage {
                return Err(format!(
                    "{}: stored as {storage}, the manifest says {}",
                    file.display(),
                    manifest.storage
                ));
            }
            let e = &t.extent;
            if [tex.width, tex.height, tex.depth, tex.layers, tex.channels] != *e {
                return Err(format!(
                    "{}: extent {:?} does not match the manifest's {:?}",
                    file.display(),
                    [tex.width, tex.height, tex.depth, tex.layers, tex.channels],
                    e
                ));
            }
            ts.push((t.clone(), tex));
        }
        textures.push(ts);
    }
    Ok((Export { manifest, textures }, value))
}

/// The metadata of `path`, refused unless it is a regular file (not a symlink, FIFO,
/// device or directory): an export's files are read only from the export directory.
fn regular_file(path: &Path) -> Result<std::fs::Metadata, String> {
    let meta = std::fs::symlink_metadata(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    if meta.file_type().is_symlink() {
        return Err(format!(
            "{} is a symbolic link: an export's files are regular files in its directory",
            path.display()
        ));
    }
    if !meta.is_file() {
        return Err(format!("{} is not a regular file", path.display()));
    }
    Ok(meta)
}

/// Largest manifest `read_export` reads (an export's is tens of kilobytes).
pub const MAX_MANIFEST_BYTES: u64 = 16 << 20;

/// The path of texture `file` in export `dir`, refused unless it is a plain file name
/// in `dir` (no directory part, not hidden) with the format's extension, naming a
/// regular file (not a FIFO, device or directory) no larger than its manifest extent
/// needs plus a header.
fn texture_path(
    dir: &Path,
    file: &str,
    format: Format,
    storage: Storage,
    extent: &[u32; 5],
) -> Result<PathBuf, String> {
    let plain = !file.is_empty()
        && !file.starts_with('.')
        && !file.contains(['/', '\\', '\0'])
        && Path::new(file).extension().and_then(|e| e.to_str()) == Some(format.extension());
    if !plain {
        return Err(format!(
            "{}: texture file {file:?} is not a plain .{} file name in the export directory",
            dir.join(MANIFEST).display(),
            format.extension()
        ));
    }
    let path = dir.join(file);
    let meta = regular_file(&path)?;
    if format == Format::Raw {
        regular_file(&path.with_extension("json"))?;
    }
    let texels: u64 = extent.iter().map(|&n| u64::from(n)).product();
    // The C header spells each value in up to ~16 characters.
    let per_value = if format == Format::Inc {
        24
    } else {
        storage.bytes() as u64
    };
    let limit = texels.saturating_mul(per_value).saturating_add(1 << 16);
    if meta.len() > limit {
        return Err(format!(
            "{}: {} bytes, more than its manifest extent {extent:?} needs",
            path.display(),
            meta.len()
        ));
    }
    Ok(path)
}

/// `lobefit check --export DIR`: trusts nothing the manifest says. It reads the
/// manifest and every texture (independent readers), and rebuilds from this
/// lobefit's tables what an export of the manifest's families with its format,
/// storage and scale writes. Refused (an error naming the field or file): a manifest
/// that differs from that export's in any field (file names, sizes, layouts,
/// formulas, inputs, closed forms, …; unknown fields included) but the measured
/// errors; a file of the export that is missing, a symbolic link or not a regular
/// file; any other file in `DIR` (but the export lock). Failing rows: each texture's
/// texels compared with the rebuilt ones (any changed texel fails), every file
/// compared byte for byte (textures, raw sidecars, uniforms, baked shaders, the
/// manifest's schema); every error re-measured at the export's own sample count and
/// seed, and held to the value and promise an export of these files records (the
/// family's target where met, else the measured error of a lossy export) — a manifest
/// that lacks, adds or changes a measurement fails.
pub fn check_export(dir: &Path) -> Result<Vec<ExportCheck>, String> {
    let (Export { manifest: m, textures }, json) = read_export_json(dir)?;
    let path = dir.join(MANIFEST);
    if m.families.is_empty() {
        return Err(format!("{}: the manifest lists no family", path.display()));
    }
    if (m.samples, m.seed) != (SAMPLES, SEED) {
        return Err(format!(
            "{}: measured at {} samples, seed {:#x}; exports are measured at {SAMPLES}, seed {SEED:#x}",
            path.display(),
            m.samples,
            m.seed
        ));
    }
    // What an export of these families with these settings writes.
    let mut grids = Vec::new();
    let mut entries = Vec::new();
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for f in &m.families {
        let gpu = fits::gpu_family(&f.family).ok_or_else(|| {
            format!(
                "{}: families: {:?} is no textured family (textured: {})",
                path.display(),
                f.family,
                fits::textured().iter().map(|g| g.kind).collect::<Vec<_>>().join(", ")
            )
        })?;
        let family = family_of(gpu.kind).ok_or_else(|| format!("{}: not in the registry", gpu.kind))?;
        let fresh = fresh_grids(gpu.kind, m.storage, m.scale).map_err(|e| format!("{}: {e}", path.display()))?;
        let mut tex_entries = Vec::new();
        for g in &fresh {
            let bytes = formats::encode(&g.texture, m.format, m.storage)?;
            let entry = texture_entry(g, m.format, bytes.len() as u64);
            if m.format == Format::Raw {
                let sidecar = Path::new(&entry.file).with_extension("json");
                files.push((
                    sidecar.to_string_lossy().into_owned(),
                    formats::raw_sidecar(&g.texture, m.storage)?.into_bytes(),
                ));
            }
            files.push((entry.file.clone(), bytes));
            tex_entries.push(entry);
        }
        entries.push(FamilyEntry {
            family: gpu.kind.to_string(),
            inputs: family.inputs().iter().map(|s| s.to_string()).collect(),
            shader: gpu.shader.to_string(),
            textures: tex_entries,
            // Re-measured below, from the files.
            error: f.error.clone(),
        });
        grids.push(fresh);
    }
    let want = manifest_of(m.format, m.storage, m.scale, entries);
    let want_json = serde_json::to_value(&want).map_err(|e| e.to_string())?;
    if let Some(d) = first_difference("", &json, &want_json) {
        return Err(format!(
            "{}: {d} (`check --export` holds every field to what an export of these tables writes)",
            path.display()
        ));
    }
    // Texture files: their differences are counted by texel below.
    let texture_files: Vec<&str> = want
        .families
        .iter()
        .flat_map(|f| &f.textures)
        .map(|t| t.file.as_str())
        .collect();
    files.extend(
        companion_files(&want)?
            .into_iter()
            .map(|(n, t)| (n.to_string(), t.into_bytes())),
    );
    // The shader library (`export --shaders`) where present: this lobefit's, byte for byte.
    let library = super::shaders::library_files(&super::shaders::ShaderLang::ALL)?;
    files.extend(
        library
            .into_iter()
            .filter(|(n, _)| dir.join(n).exists())
            .map(|(n, t)| (n.to_string(), t.into_bytes())),
    );
    // Nothing else in the directory: a file there is one a renderer may take for
    // part of the export.
    let mut extra = Vec::new();
    for e in std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))? {
        let name = e
            .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
            .file_name()
            .to_string_lossy()
            .into_owned();
        if name != MANIFEST && name != LOCK_FILE && !is_stage(&name) && !files.iter().any(|(n, _)| *n == name) {
            extra.push(name);
        }
    }
    if !extra.is_empty() {
        extra.sort();
        let shown: Vec<String> = extra.iter().take(8).map(|n| format!("{n:?}")).collect();
        return Err(format!(
            "{}: {} file{} an export of the manifest's families does not write: {}{} \
             (an export directory holds one export and nothing else)",
            dir.display(),
            extra.len(),
            if extra.len() == 1 { "" } else { "s" },
            shown.join(", "),
            if extra.len() > 8 { ", …" } else { "" }
        ));
    }
    let mut out = Vec::new();
    let differs = |family: &str, what: String, count: f64| ExportCheck {
        family: family.to_string(),
        entry: ErrorEntry {
            filter: Filter::Manual,
            output: what,
            metric: "differs from a fresh export".into(),
            measured: count,
            target: 0.0,
            floor: 0.0,
            promise: 0.0,
        },
        now: count,
        pass: false,
    };
    // Every file byte for byte (textures: their texels are counted below).
    let mut changed = Vec::new();
    for (name, want) in &files {
        let file = dir.join(name);
        let meta = regular_file(&file)?;
        let same = meta.len() == want.len() as u64
            && std::fs::read(&file).map_err(|e| format!("cannot read {}: {e}", file.display()))? == *want;
        if !same {
            changed.push(name.clone());
        }
    }
    for name in changed.iter().filter(|n| !texture_files.contains(&n.as_str())) {
        out.push(differs("-", name.clone(), 1.0));
    }
    for ((f, texs), fresh) in m.families.iter().zip(textures).zip(grids) {
        let family = family_of(&f.family).ok_or_else(|| format!("{}: not in the registry", f.family))?;
        let gpu = fits::gpu_family(&f.family).ok_or_else(|| format!("{}: no GPU layout", f.family))?;
        let mut intact = true;
        for (g, (t, tex)) in fresh.iter().zip(&texs) {
            if let Some(differing) = texel_difference(&g.texture, tex, m.storage) {
                out.push(differs(&f.family, format!("texels of {}", t.file), differing as f64));
                intact = false;
            } else if changed.contains(&t.file) {
                out.push(differs(&f.family, t.file.clone(), 1.0));
            }
        }
        if !intact {
            continue;
        }
        let back: Vec<_> = texs.into_iter().map(|(t, tex)| (t.axes, t.channels, tex)).collect();
        let measured = measure(family.as_ref(), gpu, &back, m.storage, SAMPLES, SEED)?;
        let mut all_pass = true;
        for n in &measured {
            let recorded = f
                .error
                .iter()
                .find(|e| e.filter == n.filter && e.output == n.output && e.metric == n.metric);
            // The value and promise are what this export would record, whatever the file says.
            let pass = recorded.is_some_and(|e| {
                e.measured == n.measured && e.promise == n.promise && e.target == n.target && e.floor == n.floor
            }) && n.measured <= n.promise;
            all_pass &= pass;
            out.push(ExportCheck {
                family: f.family.clone(),
                entry: recorded.cloned().unwrap_or(ErrorEntry {
                    measured: f64::NAN,
                    promise: f64::NAN,
                    ..n.clone()
                }),
                now: n.measured,
                pass,
            });
        }
        // Entries beyond the measured ones, repeated or reordered.
        if all_pass && f.error != measured {
            out.push(differs(&f.family, format!("error: {} entries", f.error.len()), 1.0));
        }
    }
    Ok(out)
}

/// Family `kind`'s textures as an export of this lobefit's tables writes them at
/// `storage` and `scale` (what `check_export` and [`verify_family_texels`] compare
/// an export's files with).
fn fresh_grids(kind: &str, storage: Storage, scale: f64) -> Result<Vec<Grid>, String> {
    let family = family_of(kind).ok_or_else(|| format!("{kind}: not in the registry"))?;
    let gpu = fits::gpu_family(kind).ok_or_else(|| format!("{kind}: no GPU layout"))?;
    let table = Table::from_bytes(family.embedded()).map_err(|e| format!("{kind}: {e}"))?;
    (gpu.grids)(gpu.kind, &table, storage, scale).map_err(|e| format!("{kind}: {e}"))
}

/// The count of texels of `read` (a texture as read back from an export stored as
/// `storage`) whose bits differ from `fresh`'s rounded to `storage`; `None` where the
/// two are equal in length and every texel.
fn texel_difference(fresh: &Texture, read: &Texture, storage: Storage) -> Option<usize> {
    let differing = fresh
        .data
        .iter()
        .zip(&read.data)
        .filter(|(a, b)| stored(**a, storage).to_bits() != b.to_bits())
        .count();
    (differing > 0 || fresh.data.len() != read.data.len()).then_some(differing)
}

/// Verifies family `kind`'s textures in an export (`textures`, as [`read_export`]
/// read them from `dir` with the manifest `m`) as `check_export` does: each is
/// rebuilt from this lobefit's tables at the manifest's storage and scale and must
/// equal the file in layout and every texel. The error names the texture and the
/// count of texels that differ.
pub fn verify_family_texels(
    dir: &Path,
    m: &Manifest,
    kind: &str,
    textures: &[(TextureEntry, Texture)],
) -> Result<(), String> {
    let fresh = fresh_grids(kind, m.storage, m.scale)?;
    let refuse = |what: String| {
        format!(
            "{}: {what} differs from a fresh export (`lobefit check --export` fails): the export is \
             corrupt or from another lobefit; export it again",
            dir.display()
        )
    };
    if fresh.len() != textures.len() {
        return Err(refuse(format!("{kind}'s texture count {}", textures.len())));
    }
    for (g, (t, tex)) in fresh.iter().zip(textures) {
        if g.axes != t.axes || g.channels != t.channels || t.file.split('.').next() != Some(&g.texture.name) {
            return Err(refuse(format!("the layout of {}", t.file)));
        }
        if let Some(differing) = texel_difference(&g.texture, tex, m.storage) {
            return Err(refuse(format!("{} ({differing} texels)", t.file)));
        }
    }
    Ok(())
}

/// The first difference between a manifest as read (`got`) and as an export writes it
/// (`want`), as "<field path> …"; the measured errors (`families[i].error`) are left
/// to `check_export`, which re-measures them. Numbers compare by value (`1` = `1.0`).
fn first_difference(at: &str, got: &serde_json::Value, want: &serde_json::Value) -> Option<String> {
    use serde_json::Value;
    let field = |k: &str| {
        if at.is_empty() {
            k.to_string()
        } else {
            format!("{at}.{k}")
        }
    };
    let short = |v: &Value| {
        let s = v.to_string();
        if s.chars().count() > 100 {
            format!("{}…", s.chars().take(97).collect::<String>())
        } else {
            s
        }
    };
    match (got, want) {
        (Value::Object(g), Value::Object(w)) => {
            if let Some(k) = g.keys().find(|k| !w.contains_key(*k)) {
                return Some(format!("unknown field {}", field(k)));
            }
            let family = at.starts_with("families[") && !at.contains('.');
            for (k, wv) in w {
                if family && k == "error" {
                    continue;
                }
                let Some(gv) = g.get(k) else {
                    return Some(format!("{} is missing", field(k)));
                };
                if let Some(d) = first_difference(&field(k), gv, wv) {
                    return Some(d);
                }
            }
            None
        }
        (Value::Array(g), Value::Array(w)) => {
            for (i, (gv, wv)) in g.iter().zip(w).enumerate() {
                if let Some(d) = first_difference(&format!("{at}[{i}]"), gv, wv) {
                    return Some(d);
                }
            }
            (g.len() != w.len()).then(|| format!("{at} has {} entries; an export writes {}", g.len(), w.len()))
        }
        (Value::Number(g), Value::Number(w))
            if match (g.as_u64(), w.as_u64(), g.as_i64(), w.as_i64()) {
                (Some(a), Some(b), _, _) => a == b,
                (_, _, Some(a), Some(b)) => a == b,
                _ => g.as_f64() == w.as_f64(),
            } =>
        {
            None
        }
        _ if got == want => None,
        _ => Some(format!("{at} is {}; an export writes {}", short(got), short(want))),
    }
}

/// Resolutions `lobefit plot export` measures (nodes per axis relative to the tables').
pub const PLOT_SCALES: [f64; 3] = [0.25, 0.5, 1.0];

/// `lobefit plot export`: per family, the export's error against its bytes, f32 and f16,
/// manual filtering, at [`PLOT_SCALES`]: the error is the largest measured/target ratio
/// over the family's metrics (1 = at the target). Exports into a temporary directory.
pub fn plot(out: &Path) -> Result<Vec<std::path::PathBuf>, String> {
    use crate::plot::{line_chart, LineChart, Series};
    let tmp = tempfile::tempdir().map_err(|e| format!("temporary directory: {e}"))?;
    let mut files = Vec::new();
    for kind in fits::textured().into_iter().filter(|f| f.plot_export).map(|f| f.kind) {
        let mut series = Vec::new();
        for storage in [Storage::F32, Storage::F16] {
            let mut points = Vec::new();
            for scale in PLOT_SCALES {
                let dir = tmp.path().join(format!("{kind}-{storage}-{scale}"));
                let opts = ExportOptions {
                    only: vec![kind.to_string()],
                    format: Format::Raw,
                    storage,
                    scale,
                    allow_lossy: true,
                };
                let m = export(&opts, &dir)?;
                let f = &m.families[0];
                let bytes: u64 = f.textures.iter().map(|t| t.bytes).sum();
                let worst = f
                    .error
                    .iter()
                    .filter(|e| e.filter == Filter::Manual)
                    .map(|e| e.measured / e.export_target())
                    .fold(0.0, f64::max);
                points.push((bytes as f64, worst));
            }
            series.push(Series {
                name: format!("{storage}"),
                points,
            });
        }
        let bytes = series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let (lo, hi) = bytes.fold((f64::INFINITY, 0.0f64), |(a, b), x| (a.min(x), b.max(x)));
        series.push(Series {
            name: "target".into(),
            points: vec![(lo, 1.0), (hi, 1.0)],
        });
        files.push(line_chart(
            &out.join(format!("export-{kind}.png")),
            &LineChart {
                title: format!("{kind}: exported texture error against bytes (manual filtering)"),
                x_label: "texel bytes".into(),
                y_label: "max measured error / target".into(),
                log_x: true,
                log_y: true,
                series,
            },
        )?);
    }
    Ok(files)
}
