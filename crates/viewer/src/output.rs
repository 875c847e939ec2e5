//! Output files written atomically: the data goes to a temporary file beside the target (same
//! directory, so the same file system), which replaces the target by a rename only once
//! everything has been written. A run that fails, a plot that cannot be drawn or an error in
//! between leaves the target as it was (an existing run log survives, and no empty file
//! appears); the temporary file is removed when the [`AtomicFile`] is dropped uncommitted.

use std::fs::{self, File, OpenOptions};
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// A file that appears at its path only on [`AtomicFile::commit`].
#[derive(Debug)]
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    committed: bool,
}

impl AtomicFile {
    /// Creates the (empty) temporary file for `target`, so that an unwritable directory is
    /// reported now, before any work. Its name is hidden, unique to this process, and keeps
    /// `target`'s extension (an image encoder may choose the format from it).
    pub fn create(target: impl AsRef<Path>) -> io::Result<Self> {
        let target = target.as_ref().to_owned();
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "the path names no file"))?;
        if target.is_dir() {
            return Err(io::Error::new(
                io::ErrorKind::IsADirectory,
                "the path is a directory",
            ));
        }
        let dir = match target.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_owned(),
            _ => PathBuf::from("."),
        };
        let ext = target
            .extension()
            .map(|e| format!(".{}", e.to_string_lossy()))
            .unwrap_or_default();
        // Unique per process and per file, so two outputs never share a temporary file.
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let temp = dir.join(format!(
            ".{}.{}-{}.tmp{ext}",
            name.to_string_lossy(),
            std::process::id(),
            COUNT.fetch_add(1, Ordering::Relaxed)
        ));
        OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&temp)
            .or_else(|e| {
                // A stale file of an earlier process with the same id: ours to replace.
                if e.kind() == io::ErrorKind::AlreadyExists {
                    File::create(&temp)
                } else {
                    Err(e)
                }
            })?;
        Ok(AtomicFile {
            target,
            temp,
            committed: false,
        })
    }

    /// The temporary file, for writers that want a path.
    pub fn temp_path(&self) -> &Path {
        &self.temp
    }

    /// The temporary file opened for writing (truncated).
    pub fn file(&self) -> io::Result<File> {
        File::create(&self.temp)
    }

    /// Flushes the temporary file to disk and renames it over the target.
    pub fn commit(mut self) -> io::Result<()> {
        File::open(&self.temp)?.sync_all()?;
        fs::rename(&self.temp, &self.target)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = fs::remove_file(&self.temp);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("viewer-output-{}-{name}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).expect("scratch dir");
        dir
    }

    #[test]
    fn commit_replaces_and_drop_keeps_the_old_file() {
        let dir = scratch("commit");
        let target = dir.join("run.csv");
        fs::write(&target, "old").expect("old file");
        let out = AtomicFile::create(&target).expect("temp");
        assert_eq!(out.temp_path().parent(), Some(dir.as_path()));
        assert_eq!(
            out.temp_path().extension().and_then(|e| e.to_str()),
            Some("csv")
        );
        out.file().expect("open").write_all(b"new").expect("write");
        assert_eq!(fs::read_to_string(&target).expect("read"), "old");
        drop(out);
        assert_eq!(fs::read_to_string(&target).expect("read"), "old");
        assert_eq!(fs::read_dir(&dir).expect("dir").count(), 1, "temp removed");
        let out = AtomicFile::create(&target).expect("temp");
        out.file().expect("open").write_all(b"new").expect("write");
        out.commit().expect("commit");
        assert_eq!(fs::read_to_string(&target).expect("read"), "new");
        assert_eq!(fs::read_dir(&dir).expect("dir").count(), 1, "no temp left");
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn unwritable_targets_fail_at_creation() {
        let dir = scratch("unwritable");
        assert!(AtomicFile::create(dir.join("no/such/dir/run.csv")).is_err());
        assert!(AtomicFile::create(&dir).is_err(), "a directory");
        assert_eq!(fs::read_dir(&dir).expect("dir").count(), 0);
        let _ = fs::remove_dir_all(&dir);
    }
}
