//! Standard output errors for every command: a closed pipe (`spherebake inspect x.sphb | head -1`)
//! is the end of the output, exit 0 with nothing on stderr (as ripgrep does), or 1 when the command
//! had already failed ([`note_failure`]); any other write error (`> /dev/full`) is one line
//! `spherebake: error: stdout: <what>` and exit 1. Standard error never panics (`eline!`).
//!
//! The commands print with `println!`, which panics when a write fails; the panic hook below turns
//! exactly those panics (std's message "failed printing to stdout: ...") into the exits above, and
//! [`flush`] checks what is still buffered when the command returns. Any other panic keeps the
//! default hook.

use std::io::Write;
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, Ordering};

/// Set when the command has failed (an asset of a batch): a closed pipe then still exits 1.
static FAILED: AtomicBool = AtomicBool::new(false);

/// Records that the command fails, whatever happens to its output afterwards.
pub fn note_failure() {
    FAILED.store(true, Ordering::Relaxed);
}

/// The exit status when standard output turned out closed: 0, or 1 after [`note_failure`] (a
/// batch with a failed asset piped into `head` must not look successful).
pub fn closed_pipe_status() -> ExitCode {
    ExitCode::from(u8::from(FAILED.load(Ordering::Relaxed)))
}

/// Installs the hook. Call once, first thing in `main`.
pub fn install() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let p = info.payload();
        let msg = p.downcast_ref::<String>().map(String::as_str).or_else(|| p.downcast_ref::<&str>().copied());
        if let Some(what) = msg.and_then(|m| m.strip_prefix("failed printing to stdout: ")) {
            std::process::exit(report(what));
        }
        default(info);
    }));
}

/// Flushes stdout after the command; a failed flush becomes the exit status.
pub fn flush(code: ExitCode) -> ExitCode {
    match std::io::stdout().flush() {
        Ok(()) => code,
        Err(e) => ExitCode::from(report(&e.to_string()) as u8),
    }
}

fn report(what: &str) -> i32 {
    if what.contains("Broken pipe") || what.contains("os error 32") {
        return i32::from(FAILED.load(Ordering::Relaxed));
    }
    let _ = writeln!(std::io::stderr(), "spherebake: error: stdout: {what}");
    1
}
