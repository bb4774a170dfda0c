//! SIGINT / SIGTERM (and SIGHUP) during a render (issue 12, item 5).
//!
//! - While the render loop runs, the first signal raises the flag that
//!   [`octolux::render::render_cancellable`] checks before each tile: the loop drops the pass
//!   under way, the whole passes done so far are written, marked `partial` in `OUT.json`, and
//!   the run exits with status [`EXIT_INTERRUPTED`].
//! - A second signal, or the first one before the render loop has started (loading, photon
//!   pass: nothing to save yet), exits at once with that status, after removing this process's
//!   staged output files ([`octolux_io::files::remove_staged`]) and the output folders it
//!   created, if empty; the outputs under their final names are those of the previous run,
//!   untouched.
//! - `bake` installs the same handler and never starts a render loop: any signal exits at once
//!   that way (its cache file is staged and renamed like the render outputs).

use anyhow::{Context, Result};
use std::sync::atomic::{AtomicBool, Ordering};

/// Exit status of an interrupted run (the shell's 128 + SIGINT).
pub const EXIT_INTERRUPTED: u8 = 130;

/// Raised by the first signal while rendering; read by the render loop.
pub static CANCEL: AtomicBool = AtomicBool::new(false);
/// True while the render loop runs (a signal then asks it to stop instead of exiting).
static RENDERING: AtomicBool = AtomicBool::new(false);

/// Install the handler (once per process).
pub fn install() -> Result<()> {
    ctrlc::set_handler(|| {
        if RENDERING.load(Ordering::SeqCst) && !CANCEL.swap(true, Ordering::SeqCst) {
            say!("\noctolux: interrupted; writing the passes done so far (interrupt again to exit at once)");
            return;
        }
        octolux_io::files::remove_staged();
        octolux_io::files::remove_created_folders();
        say!("\noctolux: interrupted; exiting without writing");
        std::process::exit(EXIT_INTERRUPTED as i32);
    })
    .context("cannot install the interrupt handler")
}

/// Mark the render loop as running (`true`) or done (`false`).
pub fn set_rendering(on: bool) {
    RENDERING.store(on, Ordering::SeqCst);
}
