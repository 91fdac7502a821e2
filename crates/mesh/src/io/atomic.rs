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
//!   longer exist from the folder it writes into (Linux, where `/proc` tells);
//! * a target that is not a regular file would be replaced by one: renamed
//!   over `/dev/null` (as root) or a named pipe, the device node or the pipe
//!   is gone. A character device (`/dev/null`, a terminal behind
//!   `/dev/stdout`) and a pipe are written straight into instead, as `cat >`
//!   would: there is no file to lose. A pipe must have a reader already
//!   (opening one for writing waits for a reader; it is opened non-blocking
//!   first, so the call fails at once instead). A folder is an
//!   `IsADirectory` error before anything is written; a block device or a
//!   socket is refused.
//!
//! A hard link to the target is still broken (the name then points at a new
//! file): keeping it would mean writing in place, which is not atomic.
//!
//! Writers that fill a file by its name rather than through a `Write` (the
//! Python package's numpy, zip and nibabel writers) use [`PendingWrite`]:
//! it hands out the temporary, and its `commit` does the same sync and rename
//! (or, for a device or a pipe, copies the bytes in). The naming rule, the
//! clean-up of dead writers' temporaries and the rename live here only.

use crate::error::{FormatError, Location, MeshError};
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temporary files of concurrent writes from one process.
static COUNTER: AtomicU64 = AtomicU64::new(0);

/// Most symbolic links followed from the target (as the kernel's ELOOP limit).
const MAX_LINKS: usize = 40;

/// Writes `path` through `fill`, atomically. On any error the temporary file is
/// removed and the error names `path`. A character device or a pipe at `path`
/// is written straight into (module comment).
pub(crate) fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    if let Some(stream) = stream_target(path)? {
        return write_stream(path, stream, fill);
    }
    let (replacement, file) = Replacement::create(path)?;
    let mut out = BufWriter::with_capacity(1 << 16, file);
    let filled = fill(&mut out)
        .and_then(|()| out.flush())
        .and_then(|()| out.into_inner().map_err(|e| e.into_error()));
    match filled {
        Ok(file) => replacement.finish(file),
        Err(e) => {
            replacement.abandon();
            Err(MeshError::io(path, e))
        }
    }
}

/// A temporary file beside the final target of `path` (links followed),
/// renamed over it by [`Replacement::finish`].
struct Replacement {
    /// What the caller asked for: errors name it.
    path: PathBuf,
    /// Where the chain of links from `path` ends.
    target: PathBuf,
    temporary: PathBuf,
}

impl Replacement {
    /// Removes the temporaries of dead writers beside the target, then
    /// creates this write's temporary (empty) and returns it open for writing.
    fn create(path: &Path) -> Result<(Self, File), MeshError> {
        let target = final_target(path).map_err(|e| MeshError::io(path, e))?;
        remove_stale_temporaries(folder_of(&target));
        let temporary = temp_path(&target)?;
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temporary)
            .map_err(|e| MeshError::io(path, e))?;
        Ok((Replacement { path: path.to_path_buf(), target, temporary }, file))
    }

    /// Gives the temporary (open as `file`) the mode of the file it replaces,
    /// syncs it and renames it over the target. On an error the temporary is
    /// removed and the error names the caller's path.
    fn finish(self, file: File) -> Result<(), MeshError> {
        let result = keep_mode(&self.target, &file)
            // Without the sync a power loss after the rename could leave an empty file.
            .and_then(|()| file.sync_all())
            .and_then(|()| std::fs::rename(&self.temporary, &self.target));
        drop(file);
        if let Err(e) = result {
            let error = MeshError::io(&self.path, e);
            self.abandon();
            return Err(error);
        }
        sync_folder(&self.target);
        Ok(())
    }

    /// Removes the temporary (best effort: the caller's error is what matters).
    fn abandon(self) {
        let _ = std::fs::remove_file(&self.temporary);
    }
}

/// A write through a file the caller fills by name (see the module comment):
/// [`PendingWrite::begin`] checks the target and creates the temporary,
/// the caller writes [`PendingWrite::temporary`], and
/// [`PendingWrite::commit`] puts the bytes in place. Dropped without a
/// commit (an error while filling), the temporary is removed and the target
/// is left as it was.
pub struct PendingWrite {
    /// What the caller asked for: errors name it.
    path: PathBuf,
    temporary: PathBuf,
    into: Into,
    /// Set once the temporary is gone (renamed or removed).
    done: bool,
}

/// Where the bytes of a [`PendingWrite`] go.
enum Into {
    /// A regular file or nothing yet: the temporary beside the target is
    /// synced and renamed over it.
    Replace { target: PathBuf },
    /// A character device or a pipe, open for writing from `begin` on: the
    /// temporary is a scratch file in the system's temporary folder (the
    /// writers seek, which a pipe cannot), copied in by `commit`. `_probe`
    /// keeps a pipe's reader (see [`write_stream`]).
    Stream { file: File, _probe: Option<File> },
}

impl PendingWrite {
    /// Starts a write of `path`: refuses a folder, a pipe that no process
    /// reads and anything else that is not a regular file, a character
    /// device or a pipe, as the mesh writers do; removes the temporaries of
    /// dead writers beside a regular target; creates the (empty) temporary.
    pub fn begin(path: &Path) -> Result<Self, MeshError> {
        let (temporary, into) = match stream_target(path)? {
            Some(stream) => {
                let (_probe, file) = open_stream(path, stream)?;
                let scratch = std::env::temp_dir().join(format!(
                    "spherify-stream-{}-{}",
                    std::process::id(),
                    COUNTER.fetch_add(1, Ordering::Relaxed)
                ));
                OpenOptions::new()
                    .write(true)
                    .create_new(true)
                    .open(&scratch)
                    .map_err(|e| MeshError::io(path, e))?;
                (scratch, Into::Stream { file, _probe })
            }
            None => {
                let (replacement, _) = Replacement::create(path)?;
                let Replacement { temporary, target, .. } = replacement;
                (temporary, Into::Replace { target })
            }
        };
        Ok(PendingWrite { path: path.to_path_buf(), temporary, into, done: false })
    }

    /// The file to write: beside the target (same file system, hidden, named
    /// `.name.tmp-PID-N`), or a scratch file for a device or a pipe.
    pub fn temporary(&self) -> &Path {
        &self.temporary
    }

    /// Puts what was written to [`PendingWrite::temporary`] in place: synced
    /// and renamed over the target with its mode, or copied into the device
    /// or pipe. On an error the temporary is removed and the error names
    /// the caller's path; the target is left as it was.
    pub fn commit(mut self) -> Result<(), MeshError> {
        let io = |e| MeshError::io(&self.path, e);
        match &mut self.into {
            Into::Replace { target } => {
                // An error here leaves the temporary to `drop`.
                let file = OpenOptions::new().write(true).open(&self.temporary).map_err(io)?;
                let replacement = Replacement {
                    path: self.path.clone(),
                    target: std::mem::take(target),
                    temporary: self.temporary.clone(),
                };
                // `finish` renames the temporary, or removes it on an error.
                self.done = true;
                replacement.finish(file)
            }
            Into::Stream { file, .. } => {
                // The scratch file is removed by `drop`, whatever happens.
                let mut scratch = File::open(&self.temporary).map_err(io)?;
                let mut out = BufWriter::with_capacity(1 << 16, &*file);
                std::io::copy(&mut scratch, &mut out).and_then(|_| out.flush()).map_err(io)
            }
        }
    }
}

impl Drop for PendingWrite {
    fn drop(&mut self) {
        if !self.done {
            // Best effort: a failed write's error is what the caller sees.
            let _ = std::fs::remove_file(&self.temporary);
        }
    }
}

/// Writes `bytes` to `path` atomically (see [`write_file`]).
pub(crate) fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    write_file(path, |out| out.write_all(bytes))
}

/// What is at a path that is written straight into rather than replaced.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Stream {
    /// A character device: `/dev/null`, a terminal.
    Device,
    /// A named or anonymous pipe (`/dev/stdout` into `| gzip`, `>(...)`).
    Pipe,
}

/// `Some` when `path` (links followed by the kernel, so `/dev/stdout` and
/// `/proc/self/fd/N` resolve too) is a character device or a pipe; `None`
/// when it is a regular file or nothing (yet), which are replaced
/// atomically. A folder is an `IsADirectory` error, anything else (a block
/// device, a socket) a [`MeshError::Format`] saying what it is.
fn stream_target(path: &Path) -> Result<Option<Stream>, MeshError> {
    // Absent, or not ours to look at: the replacing write then says why.
    let Ok(meta) = std::fs::metadata(path) else { return Ok(None) };
    let kind = meta.file_type();
    if kind.is_file() {
        return Ok(None);
    }
    if kind.is_dir() {
        return Err(MeshError::io(path, std::io::ErrorKind::IsADirectory.into()));
    }
    #[cfg(unix)]
    let what = {
        use std::os::unix::fs::FileTypeExt;
        if kind.is_char_device() {
            return Ok(Some(Stream::Device));
        }
        if kind.is_fifo() {
            return Ok(Some(Stream::Pipe));
        }
        if kind.is_block_device() {
            "a block device"
        } else if kind.is_socket() {
            "a socket"
        } else {
            "not a regular file"
        }
    };
    #[cfg(not(unix))]
    let what = "not a regular file";
    Err(refused(
        path,
        format!(
            "this is {what}: only regular files (replaced atomically), character devices \
             such as /dev/null and pipes are written"
        ),
    ))
}

/// A write refused for what the path is, as a [`MeshError::Format`] naming it
/// (reading refuses special files the same way).
fn refused(path: &Path, message: String) -> MeshError {
    FormatError::new(&path.display().to_string(), Location::File, message).into()
}

/// Writes a character device or a pipe through `fill`, in place: nothing is
/// renamed and nothing synced (neither can be).
fn write_stream(
    path: &Path,
    stream: Stream,
    fill: impl FnOnce(&mut BufWriter<File>) -> std::io::Result<()>,
) -> Result<(), MeshError> {
    let (_probe, file) = open_stream(path, stream)?;
    let mut out = BufWriter::with_capacity(1 << 16, file);
    fill(&mut out).and_then(|()| out.flush()).map_err(|e| MeshError::io(path, e))
}

/// Opens a character device or a pipe for writing; for a pipe, also the
/// probe that must stay open until the write is done.
fn open_stream(path: &Path, stream: Stream) -> Result<(Option<File>, File), MeshError> {
    let io = |e| MeshError::io(path, e);
    // Opening a pipe for writing waits until a process opens it for reading;
    // non-blocking, it fails at once (ENXIO) when none has. The probe stays
    // open until the write is done: a reader that finds no writer at all
    // between two opens reads end-of-file and may leave, and the open below
    // would then wait. With the probe open it finds the reader at once
    // (unless the reader leaves on its own in between: then it waits for
    // the next, as `cat > pipe` would).
    #[cfg(unix)]
    let probe = match stream {
        Stream::Device => None,
        Stream::Pipe => {
            use std::os::unix::fs::OpenOptionsExt;
            match OpenOptions::new().write(true).custom_flags(libc::O_NONBLOCK).open(path) {
                Err(e) if e.raw_os_error() == Some(libc::ENXIO) => {
                    return Err(refused(
                        path,
                        "this is a pipe that no process is reading: writing would wait for one"
                            .into(),
                    ))
                }
                Err(e) => return Err(io(e)),
                Ok(probe) => Some(probe),
            }
        }
    };
    #[cfg(not(unix))]
    let probe = {
        let _ = stream;
        None
    };
    let file = OpenOptions::new().write(true).open(path).map_err(io)?;
    // The path may have changed since it was looked at: a regular file now
    // would be overwritten in place, which is what the atomic write avoids.
    if file.metadata().map_err(io)?.is_file() {
        return Err(io(std::io::Error::other(
            "the path became a regular file while it was opened",
        )));
    }
    Ok((probe, file))
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

/// Bytes of the target's name that its temporary's name keeps. With the dot
/// and `.tmp-PID-N` (at most 32 bytes) that stays within the 255 bytes most
/// file systems allow in a name, so a target whose name is legal is never
/// refused for its temporary's ("File name too long" for a 245-byte name).
const TEMP_NAME_KEPT: usize = 200;

/// `dir/.name.tmp-PID-N` beside the target, so the final rename stays within one
/// file system; `name` cut to `TEMP_NAME_KEPT` (200) bytes (PID-N keeps it unique).
pub fn temp_path(path: &Path) -> Result<PathBuf, MeshError> {
    let name = path.file_name().ok_or_else(|| {
        MeshError::io(
            path,
            std::io::Error::new(std::io::ErrorKind::InvalidInput, "the path names no file"),
        )
    })?;
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let name = name.to_string_lossy();
    let mut kept = name.len().min(TEMP_NAME_KEPT);
    while !name.is_char_boundary(kept) {
        kept -= 1;
    }
    let temp_name = format!(".{}.tmp-{}-{}", &name[..kept], std::process::id(), n);
    Ok(path.with_file_name(temp_name))
}

/// The writer's process id of a temporary file name `.name.tmp-PID-N`;
/// `None` for a name that is not one.
pub fn temporary_owner(file_name: &str) -> Option<u32> {
    let rest = file_name.strip_prefix('.')?;
    let (_, tail) = rest.rsplit_once(".tmp-")?;
    let (pid, n) = tail.split_once('-')?;
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    (digits(pid) && digits(n)).then(|| pid.parse().ok()).flatten()
}

/// Whether process `pid` still runs, from `/proc/PID/stat` (Linux). A zombie
/// (state `Z`, or `X` while it is being removed) has ended: it only waits for
/// its parent to collect its exit status, which an orphan's new parent (PID 1
/// of a container, for one) may never do. So a killed batch worker's
/// temporaries are removed even while it lingers as a zombie.
fn process_is_running(pid: u32) -> bool {
    let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
        return false;
    };
    // "PID (command) STATE ...": the command may itself hold ") ", so the
    // state is the first field after the last ')'.
    let state = stat.rsplit_once(')').and_then(|(_, rest)| rest.trim_start().chars().next());
    !matches!(state, Some('Z' | 'X'))
}

/// Whether `file_name` is a temporary of a writer that no longer runs (a
/// killed run's leftover, safe to remove). Only where `/proc` shows the
/// running processes (Linux); elsewhere no temporary is taken for stale.
pub fn is_stale_temporary(file_name: &str) -> bool {
    Path::new("/proc/self").exists()
        && temporary_owner(file_name).is_some_and(|pid| !process_is_running(pid))
}

/// The folder a file at `target` is in (`.` for a bare name).
fn folder_of(target: &Path) -> &Path {
    match target.parent() {
        Some(f) if !f.as_os_str().is_empty() => f,
        _ => Path::new("."),
    }
}

/// Removes from `folder` the temporaries of writers that no longer run (see
/// [`is_stale_temporary`]). Best effort, errors are ignored (another writer
/// may be removing the same file).
pub fn remove_stale_temporaries(folder: &Path) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = std::fs::read_dir(folder) else { return };
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let is_file = entry.file_type().map(|t| t.is_file()).unwrap_or(false);
        if is_file && is_stale_temporary(name) {
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
    fn a_pending_write_commits_or_leaves_the_target_alone() {
        let dir = scratch_dir("pending");
        let target = dir.join("out.npz");
        std::fs::write(&target, b"old").unwrap();
        // Dropped without a commit (the writer failed): nothing changes.
        let pending = PendingWrite::begin(&target).unwrap();
        let temporary = pending.temporary().to_path_buf();
        assert_eq!(temporary.parent(), Some(dir.as_path()));
        assert!(temporary_owner(temporary.file_name().unwrap().to_str().unwrap()).is_some());
        std::fs::write(&temporary, b"half").unwrap();
        drop(pending);
        assert!(!temporary.exists());
        assert_eq!(std::fs::read(&target).unwrap(), b"old");
        // Committed: the new bytes, and only the target left.
        let pending = PendingWrite::begin(&target).unwrap();
        std::fs::write(pending.temporary(), b"new").unwrap();
        pending.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        // A folder that does not exist: an I/O error naming the target.
        let missing = dir.join("no").join("out.npz");
        let err = PendingWrite::begin(&missing).err().unwrap();
        assert!(
            matches!(&err, MeshError::Io { path, .. } if path == &missing.display().to_string())
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[cfg(unix)]
    #[test]
    fn a_pending_write_keeps_links_and_modes_and_writes_devices_in_place() {
        use std::os::unix::fs::PermissionsExt;
        let dir = scratch_dir("pending-link");
        let real = dir.join("real.npz");
        std::fs::write(&real, b"old").unwrap();
        std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o640)).unwrap();
        let link = dir.join("link.npz");
        std::os::unix::fs::symlink("real.npz", &link).unwrap();
        let pending = PendingWrite::begin(&link).unwrap();
        std::fs::write(pending.temporary(), b"new").unwrap();
        pending.commit().unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        assert_eq!(std::fs::metadata(&real).unwrap().permissions().mode() & 0o777, 0o640);
        // /dev/null is written into through a scratch file, which goes.
        let pending = PendingWrite::begin(Path::new("/dev/null")).unwrap();
        let scratch = pending.temporary().to_path_buf();
        assert!(!scratch.starts_with("/dev"));
        std::fs::write(&scratch, b"discarded").unwrap();
        pending.commit().unwrap();
        assert!(!scratch.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_long_legal_name_is_written() {
        // 251 and 254 bytes: legal names whose temporaries, with the full
        // name and `.tmp-PID-N`, were not ("File name too long").
        let dir = scratch_dir("long");
        for name in ["a".repeat(247) + ".ply", "é".repeat(125) + ".ply"] {
            let target = dir.join(&name);
            write_file(&target, |w| w.write_all(b"x")).unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"x");
            let temp = temp_path(&target).unwrap();
            let temp_name = temp.file_name().unwrap().to_str().unwrap();
            assert!(temp_name.len() <= 255 && temporary_owner(temp_name).is_some());
        }
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
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

    #[cfg(unix)]
    #[test]
    fn special_files_are_written_into_or_refused_never_replaced() {
        use std::os::unix::fs::FileTypeExt;
        // Classified only: a test must not risk replacing the machine's /dev/null.
        assert_eq!(stream_target(Path::new("/dev/null")).unwrap(), Some(Stream::Device));
        let dir = scratch_dir("special");
        assert_eq!(stream_target(&dir.join("absent.ply")).unwrap(), None);
        let regular = dir.join("regular.ply");
        std::fs::write(&regular, b"old").unwrap();
        assert_eq!(stream_target(&regular).unwrap(), None);

        // A pipe with a reader receives the bytes and stays a pipe.
        let pipe = dir.join("pipe.ply");
        assert!(std::process::Command::new("mkfifo").arg(&pipe).status().unwrap().success());
        let reader = {
            let pipe = pipe.clone();
            std::thread::spawn(move || std::fs::read(pipe).unwrap())
        };
        // The reader opens the pipe when its thread runs; until then the
        // write is refused for want of one, which is the other half of the test.
        let started = std::time::Instant::now();
        loop {
            match write_file(&pipe, |w| w.write_all(b"through the pipe")) {
                Ok(()) => break,
                Err(MeshError::Format(e)) => {
                    assert!(e.message.contains("no process is reading"), "{}", e.message);
                    assert!(started.elapsed().as_secs() < 10, "no reader appeared");
                    std::thread::sleep(std::time::Duration::from_millis(5));
                }
                Err(other) => panic!("{other:?}"),
            }
        }
        // Checked before the join: a pipe replaced by a file would leave the
        // reader waiting for ever.
        assert!(std::fs::metadata(&pipe).unwrap().file_type().is_fifo());
        assert_eq!(reader.join().unwrap(), b"through the pipe");

        // Without a reader: refused at once, not a wait.
        let started = std::time::Instant::now();
        let err = write_file(&pipe, |w| w.write_all(b"x")).unwrap_err();
        assert!(started.elapsed().as_secs() < 2);
        assert!(
            matches!(&err, MeshError::Format(e) if e.message.contains("no process is reading"))
        );
        assert!(std::fs::metadata(&pipe).unwrap().file_type().is_fifo());

        // A folder: IsADirectory before anything is written.
        let folder = dir.join("folder.ply");
        std::fs::create_dir(&folder).unwrap();
        let err = write_file(&folder, |w| w.write_all(b"x")).unwrap_err();
        assert!(matches!(&err, MeshError::Io { source, .. }
            if source.kind() == std::io::ErrorKind::IsADirectory));

        // A socket: refused, and still a socket.
        let socket = dir.join("socket.ply");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        let err = write_file(&socket, |w| w.write_all(b"x")).unwrap_err();
        assert!(matches!(&err, MeshError::Format(e) if e.message.contains("a socket")), "{err}");
        assert!(std::fs::metadata(&socket).unwrap().file_type().is_socket());

        // No temporary file was left anywhere.
        let mut names: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["folder.ply", "pipe.ply", "regular.ply", "socket.ply"]);
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

    #[test]
    fn a_zombie_writer_has_ended() {
        if !Path::new("/proc/self").exists() {
            return;
        }
        assert!(process_is_running(std::process::id()));
        // A child that has exited and that we do not collect yet is a zombie.
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
        while process_is_running(pid) && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let stat = std::fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
        assert!(stat.contains(") Z"), "{stat}");
        assert!(!process_is_running(pid));
        let dir = scratch_dir("zombie");
        let left = dir.join(format!(".out.ply.tmp-{pid}-3"));
        std::fs::write(&left, b"x").unwrap();
        write_file(&dir.join("out.ply"), |w| w.write_all(b"new")).unwrap();
        assert!(!left.exists());
        child.wait().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
