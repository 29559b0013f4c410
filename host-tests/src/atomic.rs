//! Outputs written whole or not at all: every file the harness writes goes to a temporary file
//! in the destination's directory and is renamed into place only when it is complete, so a
//! failed run leaves nothing at its output path and an existing file there untouched.
//!
//! **What may be at the path.** Nothing (a new file, mode 0666 less the umask, as a shell's
//! `>` makes it), or a regular file (replaced, its permission bits kept). A symbolic link is
//! followed: the link's final target is replaced the same way, so the link still points to the
//! output and a file elsewhere is not left stale behind it; a link to nothing is refused. A
//! directory, FIFO, socket or device is refused: renaming a new file over it would replace it
//! (`--out /dev/full` made a regular file of the device).
//!
//! **Interrupted.** The temporary files and staging directories being written are kept in a
//! registry; [`remove_partial_outputs_on_interrupt`] makes SIGINT and SIGTERM remove them
//! before the process exits (a Ctrl-C left a hidden `.NAME.XXXX.part` beside `--out` at every
//! interrupt). SIGKILL cannot be caught: a file it leaves behind stays.

use std::fs::{File, Metadata, Permissions};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

/// The temporary files and staging directories not yet renamed into place or removed.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn live() -> MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// On SIGINT or SIGTERM: removes every partial output (the registry of the module docs) and
/// exits with the status a shell gives a process killed by that signal (130, 143). Call once,
/// at the start of `main`.
pub fn remove_partial_outputs_on_interrupt() -> io::Result<()> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    let mut signals = signal_hook::iterator::Signals::new([SIGINT, SIGTERM])?;
    std::thread::spawn(move || {
        if let Some(signal) = signals.forever().next() {
            // Held until the exit: a commit waiting for it never renames a file half-removed.
            let live = live();
            for path in live.iter() {
                let _ = if path.is_dir() {
                    std::fs::remove_dir_all(path)
                } else {
                    std::fs::remove_file(path)
                };
            }
            std::process::exit(128 + signal);
        }
    });
    Ok(())
}

/// A partial output's entry in the registry (module docs), removed when dropped.
#[derive(Debug)]
struct Registered(PathBuf);

impl Registered {
    fn new(path: &Path) -> Self {
        live().push(path.to_owned());
        Self(path.to_owned())
    }

    /// Runs `settle` (which renames or removes the partial output) with the registry held, so
    /// that an interrupt handler does not remove the output half-way; then leaves it.
    fn settle<T>(&self, settle: impl FnOnce() -> T) -> T {
        let mut live = live();
        let value = settle();
        live.retain(|p| p != &self.0);
        value
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        live().retain(|p| p != &self.0);
    }
}

/// The longest file name the usual file systems take (`NAME_MAX`) [bytes].
const NAME_MAX_BYTES: usize = 255;
/// Random characters of a temporary name.
const TEMP_RAND_CHARS: usize = 6;
/// The end of a temporary name.
const TEMP_SUFFIX: &str = ".part";

/// The start of the temporary name of an output named `name`: `.NAME.`, `NAME` cut (at a
/// character's end) so the whole temporary name fits [`NAME_MAX_BYTES`] when the output's
/// name does (an output name of 243 to 255 bytes was refused: "File name too long" at the
/// temporary file's path).
fn temp_prefix(name: &str) -> String {
    let mut end = name
        .len()
        .min(NAME_MAX_BYTES - 2 - TEMP_RAND_CHARS - TEMP_SUFFIX.len());
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    format!(".{}.", &name[..end])
}

/// The error of creating the temporary file of `path` in `dir`, told of `path` (the temporary
/// name is none the user gave: "No such file or directory (os error 2) at path
/// \"/proc/.x.csv.JeItoH.part\"" for `--out /proc/x.csv`).
fn not_created(path: &Path, dir: &Path, e: &io::Error) -> io::Error {
    let why = if dir.is_dir() {
        let text = e.to_string();
        text.split(" at path ")
            .next()
            .unwrap_or_default()
            .to_owned()
    } else {
        format!("its folder {} does not exist", dir.display())
    };
    io::Error::new(e.kind(), format!("cannot create {}: {why}", path.display()))
}

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
    // Dropped last: the temporary file is removed before it leaves the registry.
    live: Registered,
}

impl AtomicFile {
    /// Starts writing `path`: creates the temporary file beside it (beside a symbolic link's
    /// target); refuses a path that holds something other than a regular file (module docs).
    pub fn create(path: &Path) -> io::Result<Self> {
        let (path, keep) = destination(path)?;
        let path = path.as_path();
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        let name = path
            .file_name()
            .map_or_else(|| "out".into(), |n| n.to_string_lossy().into_owned());
        let prefix = temp_prefix(&name);
        let mut builder = tempfile::Builder::new();
        builder
            .prefix(&prefix)
            .rand_bytes(TEMP_RAND_CHARS)
            .suffix(TEMP_SUFFIX);
        // open(2) applies the umask; tempfile's own default is 0600.
        #[cfg(unix)]
        builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
        let (file, tmp) = builder
            .tempfile_in(dir)
            .map_err(|e| not_created(path, dir, &e))?
            .into_parts();
        let live = Registered::new(&tmp);
        // The replaced file's bits exactly (fchmod, no umask).
        #[cfg(unix)]
        if let Some(keep) = keep {
            file.set_permissions(keep)?;
        }
        #[cfg(not(unix))]
        let _ = keep;
        Ok(Self {
            out: BufWriter::new(file),
            tmp,
            path: path.to_owned(),
            live,
        })
    }

    /// The buffered writer of the temporary file.
    pub fn writer(&mut self) -> &mut BufWriter<File> {
        &mut self.out
    }

    /// Flushes, syncs and renames the temporary file over the output path.
    pub fn commit(self) -> io::Result<()> {
        let Self {
            out,
            tmp,
            path,
            live,
        } = self;
        let file = out.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        live.settle(|| tmp.persist(&path).map_err(|e| e.error))?;
        Ok(())
    }
}

/// A set of outputs written into one directory whole or not at all (`nav sim`'s recording,
/// truth, description and fixes): every destination is checked before anything is written
/// ([`Self::new`]), the files are written into a hidden staging directory beside them, and
/// only once all are written are they renamed into place ([`Self::commit`]). A set dropped
/// without it removes the staging directory and leaves the destinations as they were (a
/// directory in the place of `truth.csv` left a new recording beside an earlier run's truth).
#[derive(Debug)]
pub struct FileSet {
    dir: PathBuf,
    names: Vec<String>,
    staging: tempfile::TempDir,
    // Dropped last: the staging directory is removed before it leaves the registry.
    live: Registered,
}

impl FileSet {
    /// Starts the set of `names` in `dir` (which must exist); refuses a destination that
    /// holds something other than a regular file, as [`AtomicFile::create`] does.
    pub fn new(dir: &Path, names: &[&str]) -> io::Result<Self> {
        for name in names {
            destination(&dir.join(name))?;
        }
        let staging = tempfile::Builder::new()
            .prefix(".staging.")
            .tempdir_in(dir)?;
        let live = Registered::new(staging.path());
        Ok(Self {
            dir: dir.to_owned(),
            names: names.iter().map(|n| (*n).to_owned()).collect(),
            staging,
            live,
        })
    }

    /// Where to write the file `name` of the set (in the staging directory); `None` for a
    /// name the set was not started with.
    pub fn staged(&self, name: &str) -> Option<PathBuf> {
        self.names
            .iter()
            .any(|n| n == name)
            .then(|| self.staging.path().join(name))
    }

    /// Renames every file of the set into place (over a symbolic link's target, keeping a
    /// replaced file's permission bits, as [`AtomicFile::commit`] does); fails, leaving
    /// every destination as it was, when one of them was not written.
    pub fn commit(self) -> io::Result<()> {
        let mut moves = Vec::with_capacity(self.names.len());
        for name in &self.names {
            let staged = self.staging.path().join(name);
            if !staged.is_file() {
                return Err(io::Error::other(format!(
                    "{} of the set was not written",
                    self.dir.join(name).display()
                )));
            }
            let (target, keep) = destination(&self.dir.join(name))?;
            if let Some(keep) = keep {
                std::fs::set_permissions(&staged, keep)?;
            }
            moves.push((staged, target));
        }
        self.live.settle(|| {
            for (staged, target) in moves {
                std::fs::rename(&staged, &target)?;
            }
            Ok(())
        })
    }
}

/// The file an output at `path` replaces and the permissions to keep (`None`: a new file);
/// refuses what is not a regular file (module docs).
fn destination(path: &Path) -> io::Result<(PathBuf, Option<Permissions>)> {
    let meta = match std::fs::symlink_metadata(path) {
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok((path.to_owned(), None)),
        other => other?,
    };
    let (target, meta) = if meta.file_type().is_symlink() {
        let target = path.canonicalize().map_err(|e| {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "output {} is a symbolic link whose target cannot be resolved ({e}): give \
                     the file's own path",
                    path.display()
                ),
            )
        })?;
        let meta = std::fs::metadata(&target)?;
        (target, meta)
    } else {
        (path.to_owned(), meta)
    };
    if !meta.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "output {} is not a regular file ({}): an output is written to a new file \
                 renamed over it, which would replace it",
                path.display(),
                kind(&meta)
            ),
        ));
    }
    Ok((target, Some(meta.permissions())))
}

/// What a file that is not a regular file is, for a message.
fn kind(meta: &Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_fifo() {
            return "a FIFO";
        } else if t.is_socket() {
            return "a socket";
        } else if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
    }
    if meta.is_dir() {
        "a directory"
    } else {
        "not a file"
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

/// Refuses two outputs that name one file (the later would replace the earlier), under any
/// name: a symbolic link is written through to its target (`crate::atomic`).
pub fn refuse_shared_outputs(outputs: &[(&str, &Path)]) -> io::Result<()> {
    // An existing file (or link) resolved; else the folder canonicalised and the name as
    // given (a folder that does not exist: the path as given).
    let key = |p: &Path| {
        if let Ok(file) = p.canonicalize() {
            return (
                file.parent().map(ToOwned::to_owned),
                file.file_name().map(ToOwned::to_owned),
            );
        }
        let dir = p.parent().filter(|d| !d.as_os_str().is_empty());
        match dir.map_or_else(|| Path::new(".").canonicalize(), Path::canonicalize) {
            Ok(dir) => (Some(dir), p.file_name().map(ToOwned::to_owned)),
            Err(_) => (Some(p.to_owned()), None),
        }
    };
    for (i, (a_name, a)) in outputs.iter().enumerate() {
        for (b_name, b) in &outputs[i + 1..] {
            if key(a) == key(b) {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!(
                        "{a_name} and {b_name} name the same file {}: each output needs its own",
                        b.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// An output name the file system takes is written whatever its length, its temporary
    /// name cut to fit (one of 246 to 255 characters was refused for its `.part` name).
    /// A file that cannot be created is told by its own name, not its temporary file's: a
    /// missing folder as such, and otherwise the system's reason without the temporary path.
    #[test]
    fn a_file_that_cannot_be_created_is_named_as_given() {
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("no-such-folder").join("out.csv");
        let e = write(&missing, |w| w.write_all(b"x")).unwrap_err();
        let text = e.to_string();
        assert!(
            text.starts_with(&format!("cannot create {}: its folder ", missing.display()))
                && text.ends_with("no-such-folder does not exist")
                && !text.contains(".part"),
            "{text}"
        );
        let proc_file = Path::new("/proc/out.csv");
        if Path::new("/proc").is_dir() {
            let text = write(proc_file, |w| w.write_all(b"x"))
                .unwrap_err()
                .to_string();
            assert!(
                text.starts_with("cannot create /proc/out.csv: ") && !text.contains(".part"),
                "{text}"
            );
        }
    }

    #[test]
    fn an_output_name_up_to_the_longest_is_written() {
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "a".repeat(250) + ".csv",
            "a".to_owned() + &"é".repeat(125) + ".csv",
        ] {
            assert!(
                name.len() >= 254 && name.len() <= NAME_MAX_BYTES,
                "{}",
                name.len()
            );
            let path = dir.path().join(&name);
            write(&path, |w| w.write_all(b"row\n")).unwrap();
            assert_eq!(std::fs::read_to_string(&path).unwrap(), "row\n");
        }
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    /// An output that is a link to another output is that file: refused, not written twice
    /// (the 1-sigma rows replaced the trajectory, reported as written).
    #[test]
    fn an_output_linked_to_another_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let nav = dir.path().join("a.nav");
        let link = dir.path().join("link.txt");
        std::fs::write(&nav, "old\n").unwrap();
        std::os::unix::fs::symlink("a.nav", &link).unwrap();
        let e = refuse_shared_outputs(&[("the trajectory (--out)", &nav), ("--std", &link)])
            .unwrap_err()
            .to_string();
        assert!(e.contains("name the same file"), "{e}");
        // Two files, one not there yet: not the same.
        let other = dir.path().join("std.txt");
        refuse_shared_outputs(&[("the trajectory (--out)", &nav), ("--std", &other)]).unwrap();
        refuse_shared_outputs(&[("--std", &other), ("the trajectory (--out)", &nav)]).unwrap();
    }

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
    fn a_file_set_is_put_in_place_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::write(d.join("a.csv"), "old a\n").unwrap();
        // One of the set not written: nothing moves, nothing is left behind.
        let set = FileSet::new(d, &["a.csv", "b.csv"]).unwrap();
        write(&set.staged("a.csv").unwrap(), |w| w.write_all(b"new a\n")).unwrap();
        assert!(set.staged("c.csv").is_none());
        let e = set.commit().unwrap_err();
        assert!(
            e.to_string().contains("b.csv of the set was not written"),
            "{e}"
        );
        assert_eq!(std::fs::read_to_string(d.join("a.csv")).unwrap(), "old a\n");
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
        // A destination that is a directory is refused before anything is written.
        std::fs::create_dir(d.join("b.csv")).unwrap();
        let e = FileSet::new(d, &["a.csv", "b.csv"]).unwrap_err();
        assert!(
            e.to_string()
                .contains("is not a regular file (a directory)"),
            "{e}"
        );
        std::fs::remove_dir(d.join("b.csv")).unwrap();
        // Dropped unfinished: nothing moves.
        let set = FileSet::new(d, &["a.csv"]).unwrap();
        write(&set.staged("a.csv").unwrap(), |w| w.write_all(b"new a\n")).unwrap();
        drop(set);
        assert_eq!(std::fs::read_to_string(d.join("a.csv")).unwrap(), "old a\n");
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 1);
        // Whole: both in place, the staging directory gone.
        let set = FileSet::new(d, &["a.csv", "b.csv"]).unwrap();
        for name in ["a.csv", "b.csv"] {
            write(&set.staged(name).unwrap(), |w| w.write_all(b"new\n")).unwrap();
        }
        set.commit().unwrap();
        for name in ["a.csv", "b.csv"] {
            assert_eq!(std::fs::read_to_string(d.join(name)).unwrap(), "new\n");
        }
        assert_eq!(std::fs::read_dir(d).unwrap().count(), 2);
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

    /// `--out` at a FIFO or a directory replaced it with a regular file; now refused before
    /// anything is opened (the FIFO is never opened: no reader blocks).
    #[cfg(unix)]
    #[test]
    fn a_fifo_or_a_directory_at_the_path_is_refused_and_left() {
        use std::os::unix::fs::FileTypeExt;
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap();
        assert!(made.success());
        let sub = dir.path().join("sub");
        std::fs::create_dir(&sub).unwrap();
        for (path, what) in [(&fifo, "(a FIFO)"), (&sub, "(a directory)")] {
            let e = write(path, |w| w.write_all(b"row\n")).unwrap_err();
            let msg = e.to_string();
            assert!(msg.contains("is not a regular file"), "{msg}");
            assert!(msg.contains(what), "{msg}");
            assert!(msg.contains(&path.display().to_string()), "{msg}");
            assert!(AtomicFile::create(path).is_err());
        }
        assert!(
            std::fs::symlink_metadata(&fifo)
                .unwrap()
                .file_type()
                .is_fifo()
        );
        assert!(sub.is_dir());
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);
    }

    /// A symbolic link was replaced by a file, its target left stale: the target is written
    /// now, the link kept; a link to nothing (or to a directory) is refused.
    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_followed_to_its_target() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("target.csv");
        std::fs::write(&target, "old\n").unwrap();
        let link = dir.path().join("link.csv");
        std::os::unix::fs::symlink("target.csv", &link).unwrap();
        write(&link, |w| w.write_all(b"new\n")).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().is_symlink());
        assert_eq!(std::fs::read_to_string(&target).unwrap(), "new\n");
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2);

        let dangling = dir.path().join("dangling.csv");
        std::os::unix::fs::symlink("missing.csv", &dangling).unwrap();
        let e = write(&dangling, |w| w.write_all(b"new\n")).unwrap_err();
        assert!(e.to_string().contains("symbolic link"), "{e}");
        let to_dir = dir.path().join("to_dir");
        std::os::unix::fs::symlink(".", &to_dir).unwrap();
        let e = write(&to_dir, |w| w.write_all(b"new\n")).unwrap_err();
        assert!(e.to_string().contains("(a directory)"), "{e}");
        assert!(!dir.path().join("missing.csv").exists());
    }

    /// Every output was 0600 (tempfile's default) and a replaced 0644 file became 0600: a new
    /// output now has the mode `File::create` gives (0666 less the umask), a replaced one keeps
    /// its bits.
    #[cfg(unix)]
    #[test]
    fn new_outputs_get_the_usual_mode_and_replaced_ones_keep_theirs() {
        use std::os::unix::fs::PermissionsExt;
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o7777;
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain");
        File::create(&plain).unwrap();
        let new = dir.path().join("new.csv");
        write(&new, |w| w.write_all(b"row\n")).unwrap();
        assert_eq!(mode(&new), mode(&plain));
        for bits in [0o644, 0o640, 0o666, 0o604] {
            std::fs::set_permissions(&new, Permissions::from_mode(bits)).unwrap();
            write(&new, |w| w.write_all(b"row\n")).unwrap();
            assert_eq!(mode(&new), bits, "{bits:o}");
            let mut f = AtomicFile::create(&new).unwrap();
            f.writer().write_all(b"row\n").unwrap();
            f.commit().unwrap();
            assert_eq!(mode(&new), bits, "{bits:o}");
        }
    }
}
