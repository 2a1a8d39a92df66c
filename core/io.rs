//! File output that never leaves a half-written table behind.

use std::io::Write;
use std::path::Path;

/// Writes `bytes` to `path` atomically: a temporary file in the same directory,
/// flushed to disk, then renamed over the target (rename is atomic on POSIX and
/// NTFS), and the directory flushed so the rename survives a crash. On error the
/// target is untouched and the temporary is removed.
///
/// The temporary is created exclusively (`O_EXCL`) under an unpredictable name
/// `.<name>.<random>.tmp`, so a symlink or file planted in the directory is never
/// followed or overwritten. After a successful write, temporaries of the same
/// table left by a killed run (hidden, ignored by the loader) are removed.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    // Dropping a `NamedTempFile` (on every `?` below, and inside a failed
    // `persist`) deletes it.
    let mut tmp = temp_beside(path, TMP_SUFFIX)?;
    tmp.write_all(bytes)?;
    persist(tmp, path)?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    remove_stale(dir, &format!(".{name}."));
    Ok(())
}

/// The temporary of an atomic write of `path` (every file lobefit writes goes
/// through it: [`write_atomic`], the PNG figures): created in `path`'s directory
/// (made if missing), exclusively (`O_EXCL`) under an unpredictable name
/// `.<name>.<random><suffix>`, with the permissions `File::create` gives a new file
/// (0666 less the umask; tempfile's own default, 0600, would make every output
/// private). Removed when dropped; [`persist`] renames it into place.
pub fn temp_beside(path: &Path, suffix: &str) -> std::io::Result<tempfile::NamedTempFile> {
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let prefix = format!(".{name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(suffix);
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder.tempfile_in(dir)
}

/// Completes an atomic write: `tmp` (from [`temp_beside`]) flushed to disk, renamed
/// over `path`, and the directory flushed so the rename survives a crash. On error
/// the target is untouched and the temporary removed.
pub fn persist(tmp: tempfile::NamedTempFile, path: &Path) -> std::io::Result<()> {
    check_replaceable(path)?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map_err(|e| e.error)?;
    let dir = path
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    sync_dir(dir)
}

/// Refuses to write over `path` when something other than a regular file is there
/// (a device, a FIFO, a socket, a directory, a symbolic link: the rename of an atomic
/// write would replace it with a regular file; as root, `--out /dev/null` would destroy
/// the device). A missing `path` or a regular file passes. Every writer calls it before
/// its rename ([`persist`]); commands call it on their `--out` before their work, so a
/// long job is not lost at its end.
pub fn check_replaceable(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        Ok(m) if !m.file_type().is_file() => Err(std::io::Error::new(
            std::io::ErrorKind::AlreadyExists,
            format!(
                "{} is {}, not a regular file: lobefit replaces only regular files",
                path.display(),
                lobefit_tables::table::file_type_name(m.file_type())
            ),
        )),
        _ => Ok(()),
    }
}

/// Suffix of the temporary files of [`write_atomic`].
const TMP_SUFFIX: &str = ".tmp";

/// Flushes a directory entry change (the rename) to disk. Windows cannot open a
/// directory as a file; NTFS journals the rename itself.
fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    std::fs::File::open(dir)?.sync_all()?;
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

/// Removes leftovers `<prefix><alphanumeric>.tmp` (this writer's names, and the
/// `<pid>` names of earlier versions) that are plain files. Best effort: a leftover
/// that cannot be removed does not fail a write that succeeded.
fn remove_stale(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let file_name = e.file_name();
        let Some(n) = file_name.to_str() else { continue };
        let Some(middle) = n.strip_prefix(prefix).and_then(|r| r.strip_suffix(TMP_SUFFIX)) else {
            continue;
        };
        let ours = !middle.is_empty() && middle.bytes().all(|b| b.is_ascii_alphanumeric());
        if ours && e.file_type().is_ok_and(|t| t.is_file()) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// Reads a small text file (a scene, a manifest): refuses what is not a regular file
/// (a FIFO would block) or is longer than `limit` bytes, before reading it.
pub fn read_text(path: &Path, limit: u64) -> Result<String, String> {
    let bytes = read_bytes(path, limit, "")?;
    String::from_utf8(bytes).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// Reads a file of at most `limit` bytes: refuses what is not a regular file (a FIFO
/// would block the open, a device never end) before opening it, and stops reading at
/// `limit + 1` bytes whatever the file's size said (a file growing meanwhile).
/// Errors name the path, and `limit_name` (the constant that sets the limit, if any)
/// when the file is too long.
pub fn read_bytes(path: &Path, limit: u64, limit_name: &str) -> Result<Vec<u8>, String> {
    use std::io::Read;
    let cannot = |e: std::io::Error| format!("cannot read {}: {e}", path.display());
    let meta = std::fs::metadata(path).map_err(cannot)?;
    let named = if limit_name.is_empty() {
        String::new()
    } else {
        format!(" ({limit_name})")
    };
    let too_long = |n: u64| {
        format!(
            "{} is {n} bytes, more than the {limit} this file may have{named}",
            path.display()
        )
    };
    if !meta.is_file() {
        return Err(format!(
            "{} is {}, not a regular file",
            path.display(),
            lobefit_tables::table::file_type_name(meta.file_type())
        ));
    }
    if meta.len() > limit {
        return Err(too_long(meta.len()));
    }
    let f = std::fs::File::open(path).map_err(cannot)?;
    let mut bytes = Vec::new();
    f.take(limit + 1).read_to_end(&mut bytes).map_err(cannot)?;
    if bytes.len() as u64 > limit {
        return Err(too_long(bytes.len() as u64));
    }
    Ok(bytes)
}
