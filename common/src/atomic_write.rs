//! Writing a whole file so that no reader, and no process restarted after a crash, ever sees a
//! part of it: the one way every spindle process puts a file on disk (output images, the
//! coordinator's job images and assets, a fetched image).
//!
//! [`write`] puts the bytes in a temporary file in the destination's own directory (a rename is
//! atomic only within one file system), syncs it to disk, renames it over the destination, and
//! syncs the directory so that the rename itself survives a power cut. Until the rename the
//! destination keeps its old content; if any step fails, the temporary file is removed.
//!
//! `tempfile` (already used by every process) creates the uniquely named temporary file and
//! removes it on failure; `NamedTempFile::persist` is the rename. A crate such as
//! `atomic-write-file` would do the same steps but bring `nix` and `rand` into every build.
//!
//! Everything here blocks; async callers run it under `spawn_blocking`.

use std::io::Write;
use std::path::{Path, PathBuf};

/// A failed atomic write: the destination, the step that failed and the I/O error.
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {step}: {source}", path.display())]
pub struct AtomicWriteError {
    /// The file that was to be written.
    pub path: PathBuf,
    /// What was being done, e.g. "creating a temporary file in out".
    pub step: String,
    #[source]
    pub source: std::io::Error,
}

/// Writes `bytes` to `path` atomically and durably: afterwards `path` holds all of `bytes`;
/// on an error (or a crash) it holds its old content, or does not exist if it did not before.
///
/// The directory must exist. A new file gets the mode of any new file (`0o666` less the umask),
/// not a temporary file's private `0o600`.
pub fn write(path: impl AsRef<Path>, bytes: &[u8]) -> Result<(), AtomicWriteError> {
    let path = path.as_ref();
    let error = |step: String| {
        move |source| AtomicWriteError {
            path: path.to_path_buf(),
            step,
            source,
        }
    };
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    let mut builder = tempfile::Builder::new();
    builder.prefix(".spindle-").suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut temp = builder.tempfile_in(dir).map_err(error(format!(
        "creating a temporary file in {}",
        dir.display()
    )))?;
    temp.write_all(bytes)
        .map_err(error(format!("writing {}", temp.path().display())))?;
    temp.as_file()
        .sync_all()
        .map_err(error(format!("syncing {}", temp.path().display())))?;
    temp.persist(path)
        .map_err(|e| error("renaming the temporary file over it".into())(e.error))?;
    sync_dir(dir).map_err(error(format!("syncing the directory {}", dir.display())))
}

/// Makes the renames and new files in `dir` durable (an fsync of the directory). Only Unix can
/// sync a directory; elsewhere this does nothing.
pub fn sync_dir(dir: impl AsRef<Path>) -> std::io::Result<()> {
    #[cfg(unix)]
    std::fs::File::open(dir.as_ref())?.sync_all()?;
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

#[cfg(test)]
mod tests;
