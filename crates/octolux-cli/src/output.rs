//! The output set of a render: `OUT.exr`, `OUT.png` and `OUT.json` (issue 12, item 4).
//!
//! - [`Outputs::check`] runs before any work: the name ends in `.exr`, none of the three paths
//!   is a folder, the folder exists and a file can be created in it (a probe file, removed at
//!   once). A render is never lost to a typo in `-o`.
//! - [`Outputs::write`] writes each file to a unique staging name in the same folder
//!   (`.NAME.PID-N-NANOS.staged`, so two runs never share one), and only when all three are
//!   complete renames them to their final names, EXR, PNG, then JSON last: a complete JSON
//!   means a complete set. On Unix the renames happen under an exclusive `flock` of the folder,
//!   so two renders to the same path leave one run's whole set, never a mix.
//! - Any failure (disk full, permissions) removes the staged files: the previous outputs stay
//!   untouched and no new file appears under a final name. Staged files are also listed in a
//!   process-wide registry so that a second interrupt, which exits at once, removes them
//!   ([`remove_staged`]).

use anyhow::{bail, Context, Result};
use octolux::image::Image;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Mutex;

/// Staged files not yet renamed or removed (for the second-interrupt exit).
static STAGED: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The three final paths of one render.
#[derive(Clone, Debug)]
pub struct Outputs {
    pub exr: PathBuf,
    pub png: PathBuf,
    pub json: PathBuf,
    /// The folder holding them (`.` for a bare file name).
    dir: PathBuf,
}

/// A unique name beside `path`: pid, a process counter and the clock's nanoseconds.
fn staging_name(path: &Path, what: &str) -> PathBuf {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let nanos = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.subsec_nanos()).unwrap_or(0);
    let name = path.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    path.with_file_name(format!(".{name}.{}-{n}-{nanos}.{what}", std::process::id()))
}

impl Outputs {
    /// Validate `-o OUT.exr` before any work (module docs).
    pub fn check(exr: &Path) -> Result<Outputs> {
        let ext = exr.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !ext.eq_ignore_ascii_case("exr") {
            bail!("output '{}' must end in .exr (a .png and a .json are written beside it)", exr.display());
        }
        let o = Outputs {
            exr: exr.to_path_buf(),
            png: exr.with_extension("png"),
            json: exr.with_extension("json"),
            dir: match exr.parent() {
                Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
                _ => PathBuf::from("."),
            },
        };
        match std::fs::metadata(&o.dir) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => bail!("output folder '{}' is not a folder", o.dir.display()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!("output folder '{}' does not exist", o.dir.display()),
            Err(e) => bail!("output folder '{}' cannot be read: {e}", o.dir.display()),
        }
        for p in [&o.exr, &o.png, &o.json] {
            if p.is_dir() {
                bail!("output path '{}' is a folder", p.display());
            }
        }
        let probe = staging_name(&o.exr, "probe");
        let created = std::fs::OpenOptions::new().write(true).create_new(true).open(&probe);
        match created {
            Ok(f) => {
                drop(f);
                let _ = std::fs::remove_file(&probe);
            }
            Err(e) => bail!("output folder '{}' is not writable: {e}", o.dir.display()),
        }
        Ok(o)
    }

    /// Write the set (module docs). `json` gives the complete text of `OUT.json`, asked for
    /// once the images are staged (so that it can hold their write time).
    pub fn write(&self, image: &Image, json: impl FnOnce() -> Result<String>) -> Result<()> {
        let staged = [staging_name(&self.exr, "staged"), staging_name(&self.png, "staged"), staging_name(&self.json, "staged")];
        STAGED.lock().unwrap_or_else(|e| e.into_inner()).extend(staged.iter().cloned());
        let result = self.write_staged(image, json, &staged);
        for s in &staged {
            // Renamed ones are gone already; a failed run leaves none behind.
            let _ = std::fs::remove_file(s);
        }
        STAGED.lock().unwrap_or_else(|e| e.into_inner()).retain(|p| !staged.contains(p));
        result
    }

    fn write_staged(&self, image: &Image, json: impl FnOnce() -> Result<String>, staged: &[PathBuf; 3]) -> Result<()> {
        let [exr, png, js] = staged;
        octolux_io::image_io::write_exr(exr, image).with_context(|| format!("cannot write {}", self.exr.display()))?;
        octolux_io::image_io::write_png(png, image).with_context(|| format!("cannot write {}", self.png.display()))?;
        write_synced(js, json()?.as_bytes()).with_context(|| format!("cannot write {}", self.json.display()))?;
        let _lock = lock_folder(&self.dir)?;
        for (from, to) in [(exr, &self.exr), (png, &self.png), (js, &self.json)] {
            std::fs::rename(from, to).with_context(|| format!("cannot write {}", to.display()))?;
        }
        Ok(())
    }
}

/// The folder of an output file (`.` for a bare name), checked as [`Outputs::check`] checks
/// it: it exists, is a folder, and a file can be created in it; `path` is not a folder.
pub fn check_file(path: &Path) -> Result<()> {
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    match std::fs::metadata(&dir) {
        Ok(m) if m.is_dir() => {}
        Ok(_) => bail!("output folder '{}' is not a folder", dir.display()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => bail!("output folder '{}' does not exist", dir.display()),
        Err(e) => bail!("output folder '{}' cannot be read: {e}", dir.display()),
    }
    if path.is_dir() {
        bail!("output path '{}' is a folder", path.display());
    }
    let probe = staging_name(path, "probe");
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(f) => {
            drop(f);
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        Err(e) => bail!("output folder '{}' is not writable: {e}", dir.display()),
    }
}

/// Write one file as the output set is written: staged beside it, synced, then renamed, so
/// that the final name holds the previous file or the whole new one, never a part.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let staged = staging_name(path, "staged");
    STAGED.lock().unwrap_or_else(|e| e.into_inner()).push(staged.clone());
    let result = write_synced(&staged, bytes)
        .with_context(|| format!("cannot write {}", path.display()))
        .and_then(|()| std::fs::rename(&staged, path).with_context(|| format!("cannot write {}", path.display())));
    let _ = std::fs::remove_file(&staged);
    STAGED.lock().unwrap_or_else(|e| e.into_inner()).retain(|p| p != &staged);
    result
}

/// The output of frame `i` of an animation: `out.exr` -> `out_0001.exr` (at least four
/// digits, as many as `last` needs).
pub fn frame_path(exr: &Path, i: u64, last: u64) -> PathBuf {
    let width = last.to_string().len().max(4);
    let stem = exr.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let ext = exr.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "exr".into());
    exr.with_file_name(format!("{stem}_{i:0width$}.{ext}"))
}

/// Write `bytes` to a new file and flush it to the disk, so that a full disk shows here and
/// not after the rename.
fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut f = std::fs::OpenOptions::new().write(true).create_new(true).open(path)?;
    f.write_all(bytes)?;
    f.sync_all()
}

/// Remove every staged file of this process (called by the second interrupt before exiting).
pub fn remove_staged() {
    // try_lock: the exit must not wait on a writer that holds the list.
    if let Ok(list) = STAGED.try_lock() {
        for p in list.iter() {
            let _ = std::fs::remove_file(p);
        }
    }
}

/// An exclusive lock on the output folder while the set is renamed (released on drop).
#[cfg(unix)]
fn lock_folder(dir: &Path) -> Result<nix::fcntl::Flock<std::fs::File>> {
    let f = std::fs::File::open(dir).with_context(|| format!("cannot open output folder '{}'", dir.display()))?;
    nix::fcntl::Flock::lock(f, nix::fcntl::FlockArg::LockExclusive)
        .map_err(|(_, e)| anyhow::anyhow!("cannot lock output folder '{}': {e}", dir.display()))
}

#[cfg(not(unix))]
fn lock_folder(_dir: &Path) -> Result<()> {
    Ok(())
}
