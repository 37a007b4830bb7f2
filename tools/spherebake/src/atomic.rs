//! Safe output: never destroy an input, never leave a half-written file.
//!
//! Rules (also in the README and the guide):
//! - An output path that is one of the files the command read (same canonical path or same file
//!   identity, i.e. device + inode, so hard links and symlinks count) is refused before anything
//!   is written.
//! - A symlink is written through: the file it points to is replaced, the link stays (like `cp`
//!   and gltfpack). A link chain longer than 40 or a dangling link whose target directory does not
//!   exist is an error.
//! - A regular file (or a new path) is written atomically: a temp file `.spherebake-*.tmp` in the
//!   destination directory, synced, renamed over the target, then the directory is synced. The new
//!   file keeps an existing file's permission bits; a new file gets 0666 minus the umask.
//! - Any other existing file (character device such as `/dev/null` or `/dev/stdout`, FIFO,
//!   socket) is written to directly, in place: no temp file, no rename, no atomicity. A directory
//!   is refused.
//! - Several files written together (an output and its depfile) succeed or fail together: all
//!   temp files are written and synced first, then renamed; if a later rename fails the earlier
//!   ones are removed again.
//! - SIGINT / SIGTERM remove the temp files of this process before it dies by the signal, and
//!   each write removes `.spherebake-*.tmp` files in its directory last modified more than
//!   [`STALE_TEMP_AGE`] before this run started (left by a process that was killed with SIGKILL or
//!   lost power). A temp file of a bake running beside this one (ninja -j into one directory) is
//!   younger than that, however the two processes' starts fall.

use anyhow::{bail, Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};
use std::time::SystemTime;

const TMP_PREFIX: &str = ".spherebake-";
const TMP_SUFFIX: &str = ".tmp";

/// A temp file is stale when last modified this long before the run started. A live one is
/// renamed within the fsync after its last write; with "older than the run" alone, a bake that
/// started after a concurrent bake had written its temp file removed it before its rename, and
/// that bake failed (ninja building three assets into one directory, under load).
const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(600);

/// Temp files of this process that exist right now (removed by the signal handler).
static LIVE_TEMPS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
static RUN_START: OnceLock<SystemTime> = OnceLock::new();

/// Records the start of the run (stale temp files are those older than it) and installs the
/// SIGINT / SIGTERM handler that removes this process's temp files. Call once, first thing.
pub fn init() {
    RUN_START.get_or_init(SystemTime::now);
    #[cfg(unix)]
    {
        use signal_hook::consts::{SIGINT, SIGTERM};
        // A thread waits for the signals (nothing runs in signal context), removes the temp
        // files, then dies by the same signal so the parent sees the usual status.
        if let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT, SIGTERM]) {
            std::thread::spawn(move || {
                if let Some(sig) = signals.forever().next() {
                    let live = LIVE_TEMPS.lock().unwrap_or_else(|p| p.into_inner());
                    for p in live.iter() {
                        let _ = std::fs::remove_file(p);
                    }
                    let _ = signal_hook::low_level::emulate_default_handler(sig);
                    std::process::exit(128 + sig);
                }
            });
        }
    }
}

/// One file the command read, identified by canonical path and (on Unix) device + inode.
struct Identity {
    canonical: Option<PathBuf>,
    #[cfg(unix)]
    dev_ino: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Self {
        Identity {
            canonical: std::fs::canonicalize(path).ok(),
            #[cfg(unix)]
            dev_ino: std::fs::metadata(path).ok().map(|m| {
                use std::os::unix::fs::MetadataExt;
                (m.dev(), m.ino())
            }),
        }
    }

    fn same(&self, other: &Identity) -> bool {
        #[cfg(unix)]
        if let (Some(a), Some(b)) = (self.dev_ino, other.dev_ino) {
            return a == b;
        }
        matches!((&self.canonical, &other.canonical), (Some(a), Some(b)) if a == b)
    }
}

/// Errors when `output` is one of `inputs` (the files the command read): by canonical path or
/// by file identity, so `-o in.obj`, `-o ./Duck0.bin` or a hard link to the input are refused.
pub fn refuse_input_as_output(output: &Path, inputs: &[PathBuf]) -> Result<()> {
    let target = resolve_symlinks(output)?;
    let out = Identity::of(&target);
    if out.canonical.is_none() && out_dev_ino_missing(&out) {
        return Ok(()); // does not exist yet: cannot be an input
    }
    for i in inputs {
        if Identity::of(i).same(&out) {
            bail!("{}: refusing to write the output over {}, a file this command reads", output.display(), i.display());
        }
    }
    Ok(())
}

fn out_dev_ino_missing(_id: &Identity) -> bool {
    #[cfg(unix)]
    {
        _id.dev_ino.is_none()
    }
    #[cfg(not(unix))]
    {
        true
    }
}

/// Follows symlinks at `path` (not in its parent directories, which the OS follows anyway) to
/// the path that will really be written.
fn resolve_symlinks(path: &Path) -> Result<PathBuf> {
    let mut p = path.to_path_buf();
    for _ in 0..40 {
        match std::fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let link = std::fs::read_link(&p).with_context(|| format!("{}: reading symlink", p.display()))?;
                p = match p.parent() {
                    Some(d) if link.is_relative() => d.join(link),
                    _ => link,
                };
            }
            _ => return Ok(p),
        }
    }
    bail!("{}: too many levels of symbolic links", path.display())
}

/// Writes `bytes` to `path` (rules in the module docs), refusing a path that is one of `inputs`.
pub fn write_atomic(path: &Path, bytes: &[u8], inputs: &[PathBuf]) -> Result<()> {
    write_together(&[(path, bytes)], inputs)
}

enum Prepared {
    /// A temp file ready to be renamed onto `target`.
    Temp { file: tempfile::NamedTempFile, target: PathBuf, shown: PathBuf },
    /// A non-regular file (device, FIFO): written in place, nothing to rename.
    Streamed,
}

/// Writes every `(path, bytes)` so that they succeed or fail together (module docs), refusing
/// any path that is one of `inputs`.
pub fn write_together(files: &[(&Path, &[u8])], inputs: &[PathBuf]) -> Result<()> {
    for (path, _) in files {
        refuse_input_as_output(path, inputs)?;
    }
    let mut prepared = Vec::with_capacity(files.len());
    for (path, bytes) in files {
        prepared.push(prepare(path, bytes)?);
    }
    if let Some(ms) = std::env::var("SPHEREBAKE_TEST_HOLD_TEMP_MS").ok().and_then(|v| v.parse::<u64>().ok()) {
        // Test hook (tests/hostile.rs): keeps the temp files alive so a signal can be sent now.
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
    let mut done: Vec<PathBuf> = Vec::new();
    let mut dirs: Vec<PathBuf> = Vec::new();
    for p in prepared {
        let Prepared::Temp { file, target, shown } = p else { continue };
        let tmp_path = file.path().to_path_buf();
        match file.persist(&target) {
            Ok(_) => {
                unregister(&tmp_path);
                dirs.push(dir_of(&target));
                done.push(target);
            }
            Err(e) => {
                unregister(&tmp_path);
                drop(e.file); // removes the temp file
                for d in &done {
                    let _ = std::fs::remove_file(d);
                }
                return Err(anyhow::Error::new(e.error))
                    .with_context(|| format!("{}: renaming temporary file into place", shown.display()));
            }
        }
    }
    dirs.sort();
    dirs.dedup();
    for d in dirs {
        sync_dir(&d).with_context(|| format!("{}: syncing the directory", shown_dir(&d)))?;
    }
    Ok(())
}

fn dir_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// A directory for messages: never a bare `.`.
fn shown_dir(dir: &Path) -> String {
    if dir == Path::new(".") {
        "the current directory".to_string()
    } else {
        dir.display().to_string()
    }
}

fn sync_dir(dir: &Path) -> std::io::Result<()> {
    #[cfg(unix)]
    {
        std::fs::File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

fn unregister(tmp: &Path) {
    let mut live = LIVE_TEMPS.lock().unwrap_or_else(|p| p.into_inner());
    live.retain(|p| p != tmp);
}

fn prepare(path: &Path, bytes: &[u8]) -> Result<Prepared> {
    // A device, FIFO or pipe reached through any links, magic ones included (`/dev/stdout` is
    // `/proc/self/fd/1`, a link to `pipe:[N]` when stdout is a pipe): written in place.
    if let Ok(m) = std::fs::metadata(path) {
        if !m.is_file() && !m.is_dir() {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(path)
                .with_context(|| format!("{}: opening for writing", path.display()))?;
            f.write_all(bytes).and_then(|_| f.flush()).with_context(|| format!("{}: writing", path.display()))?;
            return Ok(Prepared::Streamed);
        }
    }
    let target = resolve_symlinks(path)?;
    let existing = std::fs::metadata(&target).ok();
    if let Some(m) = &existing {
        if m.is_dir() {
            bail!("{}: is a directory", path.display());
        }
        if !m.is_file() {
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .open(&target)
                .with_context(|| format!("{}: opening for writing", path.display()))?;
            f.write_all(bytes).and_then(|_| f.flush()).with_context(|| format!("{}: writing", path.display()))?;
            return Ok(Prepared::Streamed);
        }
    }
    let dir = dir_of(&target);
    if !dir.is_dir() {
        if target != path {
            bail!("{}: symlink to {}, whose directory does not exist", path.display(), target.display());
        }
        std::fs::create_dir_all(&dir)
            .with_context(|| format!("{}: creating its directory {}", path.display(), dir.display()))?;
    }
    remove_stale_temps(&dir);
    let mut builder = tempfile::Builder::new();
    builder.prefix(TMP_PREFIX).suffix(TMP_SUFFIX);
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        // Created with 0666 & !umask, as any new file.
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut live = LIVE_TEMPS.lock().unwrap_or_else(|p| p.into_inner());
    let mut tmp = builder
        .tempfile_in(&dir)
        .with_context(|| format!("{}: creating a temporary file in {}", path.display(), shown_dir(&dir)))?;
    live.push(tmp.path().to_path_buf());
    drop(live);
    let result = (|| -> std::io::Result<()> {
        if let Some(m) = &existing {
            std::fs::set_permissions(tmp.path(), m.permissions())?;
        }
        tmp.write_all(bytes)?;
        tmp.flush()?;
        tmp.as_file().sync_all()
    })();
    if let Err(e) = result {
        unregister(tmp.path());
        return Err(anyhow::Error::new(e)).with_context(|| format!("{}: writing", path.display()));
    }
    Ok(Prepared::Temp { file: tmp, target, shown: path.to_path_buf() })
}

/// Removes `.spherebake-*.tmp` regular files in `dir` last modified more than [`STALE_TEMP_AGE`]
/// before this run started.
fn remove_stale_temps(dir: &Path) {
    let run_start = *RUN_START.get_or_init(SystemTime::now);
    let Some(start) = run_start.checked_sub(STALE_TEMP_AGE) else { return };
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if !(name.starts_with(TMP_PREFIX) && name.ends_with(TMP_SUFFIX)) {
            continue;
        }
        let Ok(m) = e.path().symlink_metadata() else { continue };
        if m.is_file() && m.modified().is_ok_and(|t| t < start) {
            let _ = std::fs::remove_file(e.path());
        }
    }
}
