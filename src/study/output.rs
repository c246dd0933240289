//! Where a study writes: `<out>/<name>/`, built only from validated names, reached atomically.
//!
//! A run holds an exclusive lock on `<out>/.<name>.lock` from start to end (an OS file lock, so
//! it is released however the process ends), writes into a fresh `<out>/.<name>.partial-<pid>/`,
//! and at the end renames that folder into place, after moving the previous results aside. So:
//! two runs into the same folder never mix (the second is refused while the first holds the
//! lock); an interrupted run leaves only a hidden `.partial-` folder, never a half-written
//! folder under the study's name; and a finished run's folder always holds one whole run.

use crate::error::{Error, Result};
use std::fs::{File, OpenOptions, TryLockError};
use std::path::{Component, Path, PathBuf};

/// A study's output in progress: the lock, the temporary folder and the final one.
pub(crate) struct OutputDir {
    _lock: File,
    temp: PathBuf,
    target: PathBuf,
}

fn io<'a>(file: &'a Path, action: &'static str) -> impl FnOnce(std::io::Error) -> Error + 'a {
    move |source| Error::Io { file: file.to_path_buf(), action, source }
}

impl OutputDir {
    /// Takes the lock and makes a fresh temporary folder; `name` must have passed
    /// `validate::check_file_name` (checked again here: a single normal path component).
    pub(crate) fn begin(root: &Path, name: &str) -> Result<Self> {
        let single = matches!(Path::new(name).components().collect::<Vec<_>>()[..], [Component::Normal(_)]);
        if !single || name.starts_with('.') {
            return Err(Error::Io {
                file: root.join(name),
                action: "cannot write",
                source: std::io::Error::new(
                    std::io::ErrorKind::InvalidInput,
                    format!("study name `{}` is not a plain folder name", name.escape_debug()),
                ),
            });
        }
        std::fs::create_dir_all(root).map_err(io(root, "cannot create"))?;
        let lock_path = root.join(format!(".{name}.lock"));
        let lock = OpenOptions::new()
            .create(true)
            .truncate(false)
            .write(true)
            .open(&lock_path)
            .map_err(io(&lock_path, "cannot create"))?;
        match lock.try_lock() {
            Ok(()) => {}
            // The folder's path leads the message (it used to read "mechanism ``:", a
            // mechanism error with no mechanism).
            Err(TryLockError::WouldBlock) => {
                return Err(Error::Io {
                    file: root.join(name),
                    action: "output folder busy",
                    source: std::io::Error::new(
                        std::io::ErrorKind::WouldBlock,
                        format!(
                            "it is being written by another kanedyn run (lock {}): wait for it to finish or give \
                             another --out",
                            lock_path.display()
                        ),
                    ),
                });
            }
            Err(TryLockError::Error(e)) => return Err(io(&lock_path, "cannot lock")(e)),
        }
        // Holding the lock, every `.partial-` folder of this name is a dead run's: clear them.
        if let Ok(entries) = std::fs::read_dir(root) {
            let prefix = format!(".{name}.partial-");
            for e in entries.flatten() {
                if e.file_name().to_str().is_some_and(|f| f.starts_with(&prefix)) {
                    std::fs::remove_dir_all(e.path()).ok();
                }
            }
        }
        let temp = root.join(format!(".{name}.partial-{}", std::process::id()));
        std::fs::create_dir(&temp).map_err(io(&temp, "cannot create"))?;
        Ok(Self { _lock: lock, temp, target: root.join(name) })
    }

    /// The folder to write into now.
    pub(crate) fn dir(&self) -> &Path {
        &self.temp
    }

    /// Moves the finished folder into place (the previous results are removed) and returns its
    /// path. On failure the results stay in the temporary folder, which the error names.
    pub(crate) fn finish(self) -> Result<PathBuf> {
        let root = self.target.parent().map(Path::to_path_buf).unwrap_or_default();
        if self.target.exists() {
            let old = root.join(format!(
                ".{}.old-{}",
                self.target.file_name().and_then(|f| f.to_str()).unwrap_or("study"),
                std::process::id()
            ));
            std::fs::rename(&self.target, &old).map_err(io(&self.target, "cannot replace"))?;
            std::fs::remove_dir_all(&old).ok();
        }
        std::fs::rename(&self.temp, &self.target).map_err(io(&self.temp, "cannot move into place"))?;
        Ok(self.target)
    }
}
