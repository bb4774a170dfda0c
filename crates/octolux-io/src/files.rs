//! The rules for the files octolux reads and writes, shared by every loader and every writer
//! (the CLI's render set, `bake`, `report`, `export`, the image writers of
//! [`crate::image_io`]; issue 27).
//!
//! Inputs ([`read`], [`read_to_string`]): a file is read only when it is a regular file (a
//! link to one counts) whose size is within the memory budget ([`octolux::budget`]); a folder,
//! a device (`/dev/zero`), a FIFO or a socket is refused by name before a byte is read, so an
//! endless stream never fills the memory. Each file read is remembered as an input.
//!
//! Outputs:
//! - An output is checked before any long work ([`check_output`]): its name is a file name
//!   (not `sub.exr/`, at most [`NAME_MAX`] bytes), its folder exists and takes a new file (a
//!   probe file with the staging name is created and removed, so a name too long once staged
//!   fails here too), and what exists under the name is a regular file (or a link to one). A
//!   device node, a FIFO, a socket or a folder is refused: renaming over `/dev/null` would
//!   leave the whole machine a regular file there.
//! - A missing output folder is created first ([`create_output_folder`], `mkdir -p`, as the
//!   Dask farm does), by the front ends' jobs before they check their outputs; the folders a
//!   run created are removed again, if still empty, when it fails ([`remove_created_folders`]).
//! - An output is never one of the run's inputs: every file read through this module's
//!   readers, and every path a front end names with [`note_input`], is remembered by device
//!   and inode, so the same file under another name (a symbolic or hard link) is refused too.
//! - Everything is written under a staging name beside its final name ([`staging_name`]:
//!   `.NAME.PID-N-NANOS.WHAT`, shortened so that it stays a valid file name) and renamed into
//!   place only when complete; the target is checked again just before the rename
//!   ([`recheck_output`]). Staged paths are listed ([`note_staged`]) so that an exit on a
//!   signal removes them ([`remove_staged`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// The longest file name (one path component, in bytes) of the usual Unix file systems.
pub const NAME_MAX: usize = 255;

/// Inputs of this run: (device, inode, the path as named).
static INPUTS: Mutex<Vec<(u64, u64, PathBuf)>> = Mutex::new(Vec::new());
/// Staged files and folders not yet renamed or removed.
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Output folders this run created, outermost first.
static CREATED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Device and inode of a file (following links); `None` where it does not exist (or on a
/// platform without them).
fn identity(path: &Path) -> Option<(u64, u64)> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// Remember `path` as an input of this run (an output may not replace it). Paths that do not
/// exist (a built-in scene's name) are ignored.
pub fn note_input(path: &Path) {
    if let Some((dev, ino)) = identity(path) {
        let mut list = INPUTS.lock().unwrap_or_else(|e| e.into_inner());
        if !list.iter().any(|(d, i, _)| (*d, *i) == (dev, ino)) {
            list.push((dev, ino, path.to_path_buf()));
        }
    }
}

/// The input (as it was named) that `path` is the same file as, if any.
pub fn same_as_input(path: &Path) -> Option<PathBuf> {
    let id = identity(path)?;
    INPUTS.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|(d, i, _)| (*d, *i) == id).map(|(_, _, p)| p.clone())
}

/// What a file type is, in words ("a folder", "a FIFO", ...).
pub fn kind_of(ft: &std::fs::FileType) -> &'static str {
    if ft.is_dir() {
        return "a folder";
    }
    if ft.is_symlink() {
        return "a symbolic link";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if ft.is_char_device() {
            return "a character device";
        }
        if ft.is_block_device() {
            return "a block device";
        }
        if ft.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if ft.is_socket() {
            return "a socket";
        }
    }
    if ft.is_file() {
        "a regular file"
    } else {
        "a special file"
    }
}

/// A unique name beside `path`: `.NAME.PID-N-NANOS.WHAT` (pid, a process counter and the
/// clock's nanoseconds), with NAME shortened so that the whole stays within [`NAME_MAX`].
pub fn staging_name(path: &Path, what: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or(0);
    let suffix = format!(".{}-{n}-{nanos}.{what}", std::process::id());
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let room = NAME_MAX.saturating_sub(1 + suffix.len());
    let mut end = name.len().min(room);
    while !name.is_char_boundary(end) {
        end -= 1;
    }
    path.with_file_name(format!(".{}{suffix}", &name[..end]))
}

/// The folder of an output (`.` for a bare file name).
pub fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

use crate::IoError;

/// Whether `path` names something that can be read as a file, and its size: the error says
/// what it is instead (a folder, a device, ...) or that its size passes the memory budget.
pub fn check_input(path: &Path) -> Result<u64, IoError> {
    let m = std::fs::metadata(path).map_err(|e| IoError::os(path, e))?;
    let ft = m.file_type();
    if ft.is_dir() {
        return Err(IoError::invalid(path, "this is a folder, not a file"));
    }
    if !ft.is_file() {
        return Err(IoError::invalid(path, format!("this is {}, not a regular file: octolux reads only regular files", kind_of(&ft))));
    }
    let len = m.len();
    octolux::budget::check_items(|| format!("a file of {len} bytes"), len, 1).map_err(|b| IoError::invalid(path, b.to_string()))?;
    Ok(len)
}

/// Refuse an existing `path` that is not a regular file (a folder, a device, a FIFO, a socket),
/// saying what it is; a missing file or a regular one passes (the caller's own checks, such as
/// the file's format by its extension, come next). Loaders that choose a format by extension
/// call it first, so that `/dev/zero` named as a bitmap says it is a device, not that its
/// format is unknown.
pub fn refuse_non_regular(path: &Path) -> Result<(), IoError> {
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => check_input(path).map(|_| ()),
        _ => Ok(()),
    }
}

/// `unsupported <what> format '.ext' (expected ...)`, or `... has no file extension` for a
/// name without one: the message of a file whose format its extension does not give.
pub fn unknown_format(path: &Path, what: &str, expected: &str) -> IoError {
    match path.extension() {
        Some(ext) => IoError::invalid(path, format!("unsupported {what} format '.{}' (expected {expected})", ext.to_string_lossy())),
        None => IoError::invalid(
            path,
            format!("the {what} format is chosen by the file's extension, and this name has none (expected {expected})"),
        ),
    }
}

/// Read a whole input file by the rule (module docs); it is remembered as an input.
pub fn read(path: &Path) -> Result<Vec<u8>, IoError> {
    use std::io::Read;
    let len = check_input(path)?;
    let f = std::fs::File::open(path).map_err(|e| IoError::os(path, e))?;
    note_input(path);
    // at most the size checked (a file that grows meanwhile is cut there, then refused below)
    let mut bytes = Vec::with_capacity(len as usize);
    f.take(len.saturating_add(1)).read_to_end(&mut bytes).map_err(|e| IoError::os(path, e))?;
    if bytes.len() as u64 > len {
        return Err(IoError::invalid(path, "the file grew while it was read"));
    }
    Ok(bytes)
}

/// [`read`] as UTF-8 text.
pub fn read_to_string(path: &Path) -> Result<String, IoError> {
    String::from_utf8(read(path)?).map_err(|_| IoError::invalid(path, "the file is not UTF-8 text"))
}

/// Check an output path before any work (module docs); the message says what is wrong.
pub fn check_output(path: &Path) -> Result<(), String> {
    let shown = path.display();
    let text = path.as_os_str().to_string_lossy();
    if text.ends_with('/') || text.ends_with(std::path::MAIN_SEPARATOR) {
        return Err(format!("output '{shown}' ends in '/': that names a folder, not a file"));
    }
    let Some(name) = path.file_name() else { return Err(format!("output '{shown}' has no file name")) };
    let len = name.len();
    if len > NAME_MAX {
        return Err(format!("output name '{}' is {len} bytes long; a file name may have at most {NAME_MAX}", name.to_string_lossy()));
    }
    let dir = folder_of(path);
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => return Err(format!("output folder '{}' is not a folder", dir.display())),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Err(format!("output folder '{}' does not exist", dir.display())),
        Err(e) => return Err(format!("output folder '{}' cannot be read: {e}", dir.display())),
    }
    recheck_output(path)?;
    let probe = staging_name(path, "probe");
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => Err(format!("output folder '{}' is not writable: {e}", dir.display())),
    }
}

/// Create the folder of an output where it is missing, with the missing folders above it
/// (`render -o frames/f.exr` into a new `frames`), and remember them for
/// [`remove_created_folders`]. An existing folder, or a path whose folder cannot be looked at
/// (a file in the way), is left to [`check_output`], which says what is wrong; a folder that
/// cannot be created is an error naming it. Returns the folder when it was created.
pub fn create_output_folder(path: &Path) -> Result<Option<PathBuf>, String> {
    let dir = folder_of(path);
    match std::fs::metadata(&dir) {
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        _ => return Ok(None),
    }
    // the missing folders, innermost first (a dangling link stops the walk: creating below it fails)
    let mut missing = Vec::new();
    let mut d = dir.as_path();
    while std::fs::symlink_metadata(d).is_err() {
        missing.push(d.to_path_buf());
        match d.parent() {
            Some(p) if !p.as_os_str().is_empty() => d = p,
            _ => break,
        }
    }
    for m in missing.iter().rev() {
        match std::fs::create_dir(m) {
            Ok(()) => CREATED.lock().unwrap_or_else(|e| e.into_inner()).push(m.clone()),
            // another run made it meanwhile
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists && m.is_dir() => {}
            Err(e) => return Err(format!("cannot create the output folder '{}': {e}", m.display())),
        }
    }
    Ok(Some(dir))
}

/// Forget the output folders created so far: the job that wanted them succeeded, so a later
/// job's failure in the same process (Python, Dask) must not remove them.
pub fn keep_created_folders() {
    CREATED.lock().unwrap_or_else(|e| e.into_inner()).clear();
}

/// Remove the output folders this run created ([`create_output_folder`]) that are still empty,
/// innermost first: a failed run leaves no empty folder behind.
pub fn remove_created_folders() {
    // try_lock: a signal's exit must not wait
    if let Ok(mut list) = CREATED.try_lock() {
        while let Some(d) = list.pop() {
            // `remove_dir` removes only an empty folder
            let _ = std::fs::remove_dir(&d);
        }
    }
}

/// The checks of [`check_output`] on what exists under the name, repeated just before a
/// staged file is renamed over it: a regular file (or a link to one) that is not an input.
pub fn recheck_output(path: &Path) -> Result<(), String> {
    let shown = path.display();
    let Ok(m) = std::fs::symlink_metadata(path) else { return Ok(()) };
    let ft = m.file_type();
    if ft.is_dir() {
        return Err(format!("output path '{shown}' is a folder"));
    }
    if ft.is_symlink() {
        // `/dev/stdout` -> `/proc/self/fd/1`: a process's open file, not a file of its own;
        // renaming over the link would replace `/dev/stdout` itself for the whole machine
        let target = std::fs::read_link(path).unwrap_or_default();
        if target.starts_with("/proc") || target.starts_with("/dev/fd") {
            return Err(format!(
                "output '{shown}' is a link to '{}', an open file of a process: octolux writes only files it can replace",
                target.display()
            ));
        }
        if let Ok(t) = std::fs::metadata(path) {
            if t.is_dir() {
                return Err(format!("output path '{shown}' is a folder"));
            }
            if !t.is_file() {
                let target = std::fs::read_link(path).map(|t| t.display().to_string()).unwrap_or_default();
                return Err(format!(
                    "output '{shown}' is a link to {} ('{target}'), not to a regular file: octolux replaces only regular files",
                    kind_of(&t.file_type())
                ));
            }
        }
    } else if !ft.is_file() {
        return Err(format!("output '{shown}' is {}, not a regular file: octolux replaces only regular files", kind_of(&ft)));
    }
    if let Some(input) = same_as_input(path) {
        let also = if input == path { String::new() } else { format!(" (the same file as '{}')", input.display()) };
        return Err(format!("output '{shown}' is an input of this run{also}: writing it would destroy the input"));
    }
    Ok(())
}

/// Rename a complete staged file (or folder) over `to`, checking `to` again first.
pub fn commit(staged: &Path, to: &Path) -> Result<(), String> {
    recheck_output(to)?;
    std::fs::rename(staged, to).map_err(|e| format!("cannot write {}: {e}", to.display()))
}

/// Write `bytes` to a new file and flush it to the disk, so that a full disk shows here and
/// not after the rename.
pub fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new().write(true).create_new(true).open(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// Write one file by the rule: checked, staged beside it, synced, checked again and renamed,
/// so that the final name holds the previous file or the whole new one, never a part.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    check_output(path)?;
    let staged = staging_name(path, "staged");
    note_staged(&staged);
    let result =
        write_synced(&staged, bytes).map_err(|e| format!("cannot write {}: {e}", path.display())).and_then(|()| commit(&staged, path));
    let _ = std::fs::remove_file(&staged);
    forget_staged(&staged);
    result
}

/// List a staged path (file or folder) for [`remove_staged`].
pub fn note_staged(path: &Path) {
    STAGED.lock().unwrap_or_else(|e| e.into_inner()).push(path.to_path_buf());
}

/// Drop a staged path from the list (renamed or removed).
pub fn forget_staged(path: &Path) {
    STAGED.lock().unwrap_or_else(|e| e.into_inner()).retain(|p| p != path);
}

/// Remove every staged file and folder of this process (an exit on a signal).
pub fn remove_staged() {
    // try_lock: the exit must not wait on a writer that holds the list.
    if let Ok(list) = STAGED.try_lock() {
        for p in list.iter() {
            if p.is_dir() {
                let _ = std::fs::remove_dir_all(p);
            } else {
                let _ = std::fs::remove_file(p);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn staging_names_stay_valid_file_names() {
        let long = "a".repeat(250) + ".exr";
        let s = staging_name(Path::new("d").join(&long).as_path(), "staged");
        let name = s.file_name().unwrap().to_string_lossy().into_owned();
        assert!(name.len() <= NAME_MAX, "{} bytes", name.len());
        assert!(name.starts_with(".aaaa") && name.ends_with(".staged"), "{name}");
        // multibyte characters are cut at a character boundary
        let s = staging_name(Path::new(&"é".repeat(127)), "probe");
        assert!(s.file_name().unwrap().len() <= NAME_MAX);
        let short = staging_name(Path::new("x.exr"), "staged");
        assert!(short.file_name().unwrap().to_string_lossy().starts_with(".x.exr."));
    }
}
