//! `Table::from_path` on paths that are not table files: refused from the file's
//! metadata, before anything is read (or, for a FIFO, opened).

use std::path::Path;
use std::sync::mpsc;
use std::time::Duration;

use lobefit_tables::format::MAX_FILE_LEN;
use lobefit_tables::{LoadError, Table};

/// Generous bound on a load that must not block; only a regression reaches it.
const NO_HANG: Duration = Duration::from_secs(60);

/// `Table::from_path(path)` on a helper thread, so that a load that blocks fails
/// the test instead of hanging it.
fn load(path: &Path) -> Result<Table, LoadError> {
    let (tx, rx) = mpsc::channel();
    let p = path.to_path_buf();
    std::thread::spawn(move || {
        let _ = tx.send(Table::from_path(p));
    });
    rx.recv_timeout(NO_HANG)
        .unwrap_or_else(|_| panic!("loading {} blocked", path.display()))
}

#[test]
fn oversized_sparse_file_is_refused_before_it_is_read() {
    let f = tempfile::NamedTempFile::new().unwrap();
    let len = MAX_FILE_LEN + MAX_FILE_LEN / 5;
    f.as_file().set_len(len).unwrap();
    match load(f.path()) {
        Err(LoadError::TooLarge { len: l, limit, .. }) => {
            assert_eq!((l, limit), (len, MAX_FILE_LEN));
        }
        other => panic!("expected TooLarge, got {other:?}"),
    }
}

#[test]
fn directory_is_not_a_file() {
    let d = tempfile::tempdir().unwrap();
    let e = load(d.path()).unwrap_err();
    assert!(
        matches!(
            e,
            LoadError::NotAFile {
                what: "a directory",
                ..
            }
        ),
        "{e:?}"
    );
}

#[cfg(unix)]
#[test]
fn character_device_is_refused_before_it_is_read() {
    let e = load(Path::new("/dev/zero")).unwrap_err();
    assert!(
        matches!(
            e,
            LoadError::NotAFile {
                what: "a character device",
                ..
            }
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "cannot read table file /dev/zero: it is a character device, not a regular file"
    );
}

#[cfg(unix)]
#[test]
fn fifo_is_refused_without_blocking() {
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("t.lobefit");
    match std::process::Command::new("mkfifo").arg(&fifo).status() {
        Ok(s) if s.success() => {}
        _ => {
            eprintln!("skipped: mkfifo is unavailable");
            return;
        }
    }
    let e = load(&fifo).unwrap_err();
    assert!(matches!(e, LoadError::NotAFile { what: "a FIFO", .. }), "{e:?}");
}
