//! Crash-safe file replacement: write a temporary file beside the target, sync
//! it, then rename it over the target. A rename within one directory is atomic on
//! the platforms we support, so readers see either the old file or the new one,
//! never a half-written mix, and a failed write leaves the old file untouched.
//!
//! What a plain temporary-and-rename gets wrong, and what is done instead
//! (issue 13, items 10-12):
//!
//! * a symbolic link at the target would be replaced by a regular file: the
//!   link is followed and its target replaced, so the link stays a link;
//! * the new file would get the default mode (0644 under the usual umask):
//!   it takes the mode of the file it replaces;
//! * a process killed between creating and renaming its temporary leaves it
//!   behind for good: temporaries carry the writer's process id
//!   (`.name.tmp-PID-N`), and each write removes those of processes that no
//!   longer exist from the folder it writes into (Linux, where `/proc` tells).
//!
//! A hard link to the target is still broken (the name then points at a new
//! file): keeping it would mean writing in place, which is not atomic.

use crate::error::MeshError;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of concurrent writes from one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Most symbolic links followed from the target (as the kernel's ELOOP limit).
const MAX_LINKS: usize = 40;

/// Writes `path` through `fill`, atomically. On any error the temporary file is
/// removed and the error names `path`.
pub(crate) fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    let target = final_target(path).map_err(|e| MeshError::io(path, e))?;
    remove_stale_temporaries(&target);
    let temp = temp_path(&target)?;
    let file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&temp)
        .map_err(|e| MeshError::io(path, e))?;
    let result = keep_mode(&target, &file)
        .and_then(|()| fill_and_sync(file, fill))
        .and_then(|()| std::fs::rename(&temp, &target));
    result.map_err(|e| {
        // Best effort: the original error is what the caller needs to see.
        let _ = std::fs::remove_file(&temp);
        MeshError::io(path, e)
    })?;
    sync_folder(&target);
    Ok(())
}

/// Writes `bytes` to `path` atomically (see [`write_file`]).
pub(crate) fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    write_file(path, |out| out.write_all(bytes))
}

/// `path`, or where the chain of symbolic links starting at it ends (the end
/// need not exist yet).
fn final_target(path: &Path) -> std::io::Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match std::fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = std::fs::read_link(&current)?;
                current = match current.parent() {
                    Some(parent) if link.is_relative() => parent.join(link),
                    _ => link,
                };
            }
            _ => return Ok(current),
        }
    }
    Err(std::io::Error::other(format!("more than {MAX_LINKS} symbolic links")))
}

/// Gives the new file the permissions of the file it replaces, if any.
fn keep_mode(target: &Path, file: &File) -> std::io::Result<()> {
    match std::fs::metadata(target) {
        Ok(meta) if meta.is_file() => file.set_permissions(meta.permissions()),
        _ => Ok(()),
    }
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

/// Makes the rename itself durable (best effort: not every file system lets
/// a folder be opened and synced).
fn sync_folder(target: &Path) {
    #[cfg(unix)]
    if let Some(folder) = target.parent() {
        let folder = if folder.as_os_str().is_empty() { Path::new(".") } else { folder };
        if let Ok(dir) = File::open(folder) {
            let _ = dir.sync_all();
        }
    }
    #[cfg(not(unix))]
    let _ = target;
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

/// The writer's process id of a temporary file name `.name.tmp-PID-N`.
fn temporary_owner(file_name: &str) -> Option<u32> {
    let rest = file_name.strip_prefix('.')?;
    let (_, tail) = rest.rsplit_once(".tmp-")?;
    let (pid, n) = tail.split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(n)).then(|| pid.parse().ok()).flatten()
}

/// Removes, from the folder of `target`, the temporaries of writers that no
/// longer run. Only where `/proc` shows the running processes (Linux); best
/// effort, errors are ignored (another writer may be removing the same file).
fn remove_stale_temporaries(target: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let folder = match target.parent() {
        Some(f) if !f.as_os_str().is_empty() => f,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(folder) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temporary_owner) else { continue };
        let is_file = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        if is_file && !Path::new(&format!("/proc/{pid}")).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
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

    #[cfg(unix)]
    #[test]
    fn links_are_followed_and_the_mode_is_kept() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch_dir("link");
        let target = dir.join("real.ply");
        std::fs::write(&target, b"old").unwrap();
        std::fs::set_permissions(&target, std::fs::Permissions::from_mode(0o600)).unwrap();
        let link = dir.join("link.ply");
        std::os::unix::fs::symlink("real.ply", &link).unwrap();
        write_file(&link, |w| w.write_all(b"new")).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        let mode = std::fs::metadata(&target).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn temporaries_of_dead_writers_are_removed_and_others_kept() {
        assert_eq!(temporary_owner(".out.ply.tmp-123-0"), Some(123));
        assert_eq!(temporary_owner(".a.tmp-b.tmp-77-12"), Some(77));
        for name in ["out.ply.tmp-1-0", ".out.ply.tmp-x-0", ".out.ply.tmp-1-", ".out.ply"] {
            assert_eq!(temporary_owner(name), None, "{name}");
        }
        if !Path::new("/proc/self").exists() {
            return;
        }
        let dir = scratch_dir("stale");
        // No process has id u32::MAX - 1 (Linux pids stay below 2^22).
        let dead = dir.join(format!(".out.ply.tmp-{}-0", u32::MAX - 1));
        let alive = dir.join(format!(".other.ply.tmp-{}-999", std::process::id()));
        let unrelated = dir.join("keep.tmp-1-1");
        for f in [&dead, &alive, &unrelated] {
            std::fs::write(f, b"x").unwrap();
        }
        write_file(&dir.join("out.ply"), |w| w.write_all(b"new")).unwrap();
        assert!(!dead.exists());
        assert!(alive.exists() && unrelated.exists());
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
