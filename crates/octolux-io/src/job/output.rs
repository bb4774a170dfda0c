//! The output set of a render: `OUT.exr`, `OUT.png` and `OUT.json` (issue 12, item 4), and the
//! single output files of `bake` and `report`, all by the one rule of [`crate::files`]
//! (issue 27: never over a device node, a FIFO, a socket or a folder, never over an input).
//!
//! - [`Outputs::check`] runs before any work: each of the three paths passes
//!   [`files::check_output`] (a file name of at most 255 bytes, not ending in `/`; its folder
//!   exists, created first by the jobs where it is missing, and takes a probe file; nothing but a regular file under the name; not an input),
//!   and the name ends in `.exr`. A render is never lost to a typo in `-o`.
//! - [`Outputs::write`] writes each file to a unique staging name in the same folder
//!   (`.NAME.PID-N-NANOS.staged`, so two runs never share one), and only when all three are
//!   complete checks the targets again and renames them to their final names, EXR, PNG, then
//!   JSON last: a complete JSON means a complete set. On Unix the renames happen under an
//!   exclusive `flock` of the folder, so two renders to the same path leave one run's whole
//!   set, never a mix.
//! - Any failure (disk full, permissions) removes the staged files: the previous outputs stay
//!   untouched and no new file appears under a final name. Staged files are also listed in a
//!   process-wide registry so that a second interrupt, which exits at once, removes them
//!   ([`remove_staged`]).

use super::{bail, Context, JobError, Result};
use crate::files::{self, staging_name};
use octolux::image::Image;
use std::path::{Path, PathBuf};

/// The three final paths of one render.
#[derive(Clone, Debug)]
pub struct Outputs {
    pub exr: PathBuf,
    pub png: PathBuf,
    pub json: PathBuf,
    /// The folder holding them (`.` for a bare file name).
    dir: PathBuf,
}

impl Outputs {
    /// Validate `-o OUT.exr` before any work (module docs).
    pub fn check(exr: &Path) -> Result<Outputs> {
        // `sub.exr/` is refused by the rule before its extension is looked at
        files::check_output(exr).map_err(JobError)?;
        let ext = exr.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !ext.eq_ignore_ascii_case("exr") {
            bail!("output '{}' must end in .exr (a .png and a .json are written beside it)", exr.display());
        }
        let o = Outputs {
            exr: exr.to_path_buf(),
            png: exr.with_extension("png"),
            json: exr.with_extension("json"),
            dir: files::folder_of(exr),
        };
        for p in [&o.png, &o.json] {
            files::check_output(p).map_err(JobError)?;
        }
        Ok(o)
    }

    /// The checks of what exists under each name, again ([`files::recheck_output`]): run once
    /// the scene and every file it names are read, before the long work, so that a texture or
    /// a mesh that is one of these outputs (noted as an input only when it is read) is refused
    /// then, not after the render.
    pub fn recheck(&self) -> Result<()> {
        for p in [&self.exr, &self.png, &self.json] {
            files::recheck_output(p).map_err(JobError)?;
        }
        Ok(())
    }

    /// Write the set (module docs). `json` gives the complete text of `OUT.json`, asked for
    /// once the images are staged (so that it can hold their write time).
    pub fn write(&self, image: &Image, json: impl FnOnce() -> Result<String>) -> Result<()> {
        let staged = [staging_name(&self.exr, "staged"), staging_name(&self.png, "staged"), staging_name(&self.json, "staged")];
        for s in &staged {
            files::note_staged(s);
        }
        let result = self.write_staged(image, json, &staged);
        for s in &staged {
            // Renamed ones are gone already; a failed run leaves none behind.
            let _ = std::fs::remove_file(s);
            files::forget_staged(s);
        }
        result
    }

    fn write_staged(&self, image: &Image, json: impl FnOnce() -> Result<String>, staged: &[PathBuf; 3]) -> Result<()> {
        let [exr, png, js] = staged;
        crate::image_io::write_exr(exr, image).with_context(|| format!("cannot write {}", self.exr.display()))?;
        crate::image_io::write_png(png, image).with_context(|| format!("cannot write {}", self.png.display()))?;
        files::write_synced(js, json()?.as_bytes()).with_context(|| format!("cannot write {}", self.json.display()))?;
        let _lock = lock_folder(&self.dir)?;
        // every target checked again before the first rename: a set is whole or not written
        for to in [&self.exr, &self.png, &self.json] {
            files::recheck_output(to).map_err(JobError)?;
        }
        for (from, to) in [(exr, &self.exr), (png, &self.png), (js, &self.json)] {
            files::commit(from, to).map_err(JobError)?;
        }
        Ok(())
    }
}

/// An output file other than the render set (`bake`'s cache, `report`'s page), checked as
/// [`Outputs::check`] checks the set, before any work.
pub fn check_file(path: &Path) -> Result<()> {
    files::check_output(path).map_err(JobError)
}

/// Write one file as the output set is written: checked, staged beside it, synced, checked
/// again, then renamed, so that the final name holds the previous file or the whole new one.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    files::write_atomic(path, bytes).map_err(JobError)
}

/// The output of frame `i` of an animation: `out.exr` -> `out_0001.exr` (at least four
/// digits, as many as `last` needs).
pub fn frame_path(exr: &Path, i: u64, last: u64) -> PathBuf {
    let width = last.to_string().len().max(4);
    let stem = exr.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let ext = exr.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "exr".into());
    exr.with_file_name(format!("{stem}_{i:0width$}.{ext}"))
}

/// Remove every staged file of this process (called by the second interrupt before exiting).
pub fn remove_staged() {
    files::remove_staged();
}

/// An exclusive lock on the output folder while the set is renamed (released on drop).
#[cfg(unix)]
fn lock_folder(dir: &Path) -> Result<nix::fcntl::Flock<std::fs::File>> {
    let f = std::fs::File::open(dir).with_context(|| format!("cannot open output folder '{}'", dir.display()))?;
    nix::fcntl::Flock::lock(f, nix::fcntl::FlockArg::LockExclusive)
        .map_err(|(_, e)| JobError(format!("cannot lock output folder '{}': {e}", dir.display())))
}

#[cfg(not(unix))]
fn lock_folder(_dir: &Path) -> Result<()> {
    Ok(())
}
