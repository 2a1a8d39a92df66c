//! `lobefit::io::write_atomic`: planted links are never followed, temporaries never
//! outlive a write, and a killed run's leftovers are cleaned up.

use std::path::Path;

use lobefit::io::write_atomic;

/// Hidden temporaries in `dir` (the writer's `.<name>.<random>.tmp`).
fn temporaries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.') && n.ends_with(".tmp"))
        .collect()
}

/// A symlink planted at the temporary name an earlier version used
/// (`.<name>.<pid>.tmp`) must not redirect the write to the link's target.
#[cfg(unix)]
#[test]
fn planted_symlink_at_the_old_temporary_name_is_not_followed() {
    let dir = tempfile::tempdir().unwrap();
    let victim = dir.path().join("victim.txt");
    std::fs::write(&victim, b"precious").unwrap();
    let planted = dir.path().join(format!(".t.lobefit.{}.tmp", std::process::id()));
    std::os::unix::fs::symlink(&victim, &planted).unwrap();
    let target = dir.path().join("t.lobefit");
    write_atomic(&target, b"table bytes").unwrap();
    assert_eq!(
        std::fs::read(&victim).unwrap(),
        b"precious",
        "the link's target was overwritten"
    );
    assert!(std::fs::symlink_metadata(&target).unwrap().file_type().is_file());
    assert_eq!(std::fs::read(&target).unwrap(), b"table bytes");
}

/// Temporaries of a killed run (empty or complete, any random part) are removed by
/// the next successful write of the same table; other tables' files are left alone.
#[test]
fn leftovers_of_a_killed_run_are_removed() {
    let dir = tempfile::tempdir().unwrap();
    let stale = [".t.lobefit.a1B2c3.tmp", ".t.lobefit.12345.tmp"];
    std::fs::write(dir.path().join(stale[0]), b"").unwrap();
    std::fs::write(dir.path().join(stale[1]), b"a whole old table").unwrap();
    let other = ".u.lobefit.a1B2c3.tmp";
    std::fs::write(dir.path().join(other), b"").unwrap();
    write_atomic(&dir.path().join("t.lobefit"), b"new").unwrap();
    assert_eq!(temporaries(dir.path()), vec![other.to_string()]);
    assert_eq!(std::fs::read(dir.path().join("t.lobefit")).unwrap(), b"new");
}

/// A failed rename (the target is a non-empty directory) leaves no temporary.
#[test]
fn a_failed_write_leaves_no_temporary() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("t.lobefit");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep"), b"x").unwrap();
    assert!(write_atomic(&target, b"table").is_err());
    assert!(temporaries(dir.path()).is_empty(), "{:?}", temporaries(dir.path()));
    assert!(target.join("keep").exists());
}

/// The written file gets the permissions `File::create` would give it, not the
/// temporary's private 0600.
#[cfg(unix)]
#[test]
fn written_table_has_ordinary_permissions() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain");
    std::fs::File::create(&plain).unwrap();
    let target = dir.path().join("t.lobefit");
    write_atomic(&target, b"table").unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&target), mode(&plain));
}

/// A PNG figure (render panels, plots: `plot::line_chart`, `plot::heatmaps`) gets the
/// same permissions as a table, through the same atomic-write temporary.
#[cfg(unix)]
#[test]
fn a_png_figure_has_ordinary_permissions() {
    use lobefit::plot::{line_chart, LineChart, Series};
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let plain = dir.path().join("plain");
    std::fs::File::create(&plain).unwrap();
    let chart = LineChart {
        title: "t".into(),
        x_label: "x".into(),
        y_label: "y".into(),
        log_x: false,
        log_y: false,
        series: vec![Series {
            name: "s".into(),
            points: vec![(0.0, 0.0), (1.0, 1.0)],
        }],
    };
    let png = line_chart(&dir.path().join("c.png"), &chart).unwrap();
    let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
    assert_eq!(mode(&png), mode(&plain), "{:o}", mode(&png));
}
