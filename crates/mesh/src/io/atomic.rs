//! Crash-safe file replacement: write a temporary file beside the target, sync
//! it, then rename it over the target. A rename within one directory is atomic on
//! the platforms we support, so readers see either the old file or the new one,
//! never a half-written mix, and a failed write leaves the old file untouched.

use crate::error::MeshError;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of concurrent writes from one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Writes `path` through `fill`, atomically. On any error the temporary file is
/// removed and the error names `path`.
pub(crate) fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    let temp = temp_path(path)?;
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(|e| MeshError::io(path, e))?;
    let result = fill_and_sync(file, fill).and_then(|()| std::fs::rename(&temp, path));
    result.map_err(|e| {
        // Best effort: the original error is what the caller needs to see.
        let _ = std::fs::remove_file(&temp);
        MeshError::io(path, e)
    })
}

fn fill_and_sync(
    file: File,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let mut out = BufWriter::with_capacity(1 << 16, file);
    fill(&mut out)?;
    out.flush()?;
    let file = out.into_inner().map_err(|e| e.into_error())?;
    // Without the sync a power loss after the rename could leave an empty file.
    file.sync_all()
}

/// `dir/.name.tmp-PID-N` beside the target, so the final rename stays within one
/// file system.
fn temp_path(path: &Path) -> Result<PathBuf, MeshError> {
    let name = path.file_name().ok_or_else(|| {
        MeshError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file"),
        )
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let temp_name = format!(".{}.tmp-{}-{}", name.to_string_lossy(), std::process::id(), n);
    Ok(path.with_file_name(temp_name))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch_dir(tag: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!(
            "spherify-atomic-{tag}-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn replaces_target_and_leaves_no_temp_file() {
        let dir = scratch_dir("ok");
        let target = dir.join("out.txt");
        std::fs::write(&target, b"old").unwrap();
        write_file(&target, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn failure_keeps_old_target_and_removes_temp_file() {
        let dir = scratch_dir("fail");
        let target = dir.join("out.txt");
        std::fs::write(&target, b"old").unwrap();
        let err = write_file(&target, |w| {
            w.write_all(b"partial")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(matches!(err, MeshError::Io { .. }));
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
