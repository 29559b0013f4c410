//! Outputs written whole or not at all: every file the harness writes goes to a temporary file
//! in the destination's directory and is renamed into place only when it is complete, so a
//! failed run leaves nothing at its output path and an existing file there untouched.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// Writes `path` through `body`: a temporary `.NAME.*.part` beside it, flushed, synced and
/// renamed over `path` only when `body` succeeded. On any error the temporary file is removed
/// and `path` is as it was.
pub fn write<T, E: From<io::Error>>(
    path: &Path,
    body: impl FnOnce(&mut BufWriter<File>) -> Result<T, E>,
) -> Result<T, E> {
    let mut file = AtomicFile::create(path)?;
    let value = body(file.writer())?;
    file.commit()?;
    Ok(value)
}

/// An output written a piece at a time (e.g. row by row while a run goes on) and put in place
/// whole: the temporary `.NAME.*.part` beside `path` is renamed over it by [`Self::commit`]; an
/// `AtomicFile` dropped without it (an error, a panic) removes the temporary file and leaves
/// `path` as it was. [`write`] is the same for an output written by one closure.
#[derive(Debug)]
pub struct AtomicFile {
    out: BufWriter<File>,
    tmp: tempfile::TempPath,
    path: PathBuf,
}

impl AtomicFile {
    /// Starts writing `path`: creates the temporary file beside it.
    pub fn create(path: &Path) -> io::Result<Self> {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let tmp = tempfile::Builder::new()
            .prefix(&format!(".{name}."))
            .suffix(".part")
            .tempfile_in(dir)?;
        let (file, tmp) = tmp.into_parts();
        Ok(Self {
            out: BufWriter::new(file),
            tmp,
            path: path.to_owned(),
        })
    }

    /// The buffered writer of the temporary file.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        &mut self.out
    }

    /// Flushes, syncs and renames the temporary file over the output path.
    pub fn commit(self) -> io::Result<()> {
        let Self { out, tmp, path } = self;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        tmp.persist(&path).map_err(|e| e.error)?;
        Ok(())
    }
}

/// Refuses an output that is one of the inputs (the same file under any name), before
/// anything is opened for writing: writing it would destroy the input.
pub fn refuse_same_file(inputs: &[&Path], output: &Path) -> io::Result<()> {
    let Ok(out) = output.canonicalize() else {
        return Ok(()); // does not exist yet: not an input
    };
    for input in inputs {
        if input.canonicalize().is_ok_and(|i| i == out) {
            return Err(io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "output {} is the input {}: refusing to overwrite it",
                    output.display(),
                    input.display()
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn a_failed_write_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("log.csv");
        std::fs::write(&path, "old\n").unwrap();
        let r: io::Result<()> = write(&path, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("reader failed"))
        });
        assert!(r.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
        write(&path, |w| w.write_all(b"new\n")).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn an_atomic_file_dropped_unfinished_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.nav");
        let mut f = AtomicFile::create(&path).unwrap();
        f.writer().write_all(b"row\n").unwrap();
        assert!(!path.exists());
        drop(f);
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
        let mut f = AtomicFile::create(&path).unwrap();
        f.writer().write_all(b"row\n").unwrap();
        f.commit().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "row\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
    }

    #[test]
    fn the_same_file_under_another_name_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let input = dir.path().join("imu.bin");
        std::fs::write(&input, "data").unwrap();
        let other = dir.path().join(".").join("imu.bin");
        assert!(refuse_same_file(&[&input], &other).is_err());
        assert!(refuse_same_file(&[&input], &dir.path().join("new.csv")).is_ok());
        assert_eq!(std::fs::read_to_string(&input).unwrap(), "data");
    }
}
