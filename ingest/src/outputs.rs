//! Ingest's outputs never destroy its inputs, never appear half-written, and leave no temporary files
//! behind across runs.
//!
//! - Every output (the blob, the `--dump-json` listing) is written by [`write_atomic`]: a temporary
//!   file beside it, fsync, rename (`blob::write_atomic`). A reader sees the old file or the new one.
//! - An output that is also an input is refused before it is written, with an error naming both
//!   ([`IngestError::OutputIsInput`]): the root layer is checked before anything is read; the
//!   layers composition opened (sublayers, references, payloads) and the texture files baked are
//!   checked as soon as the stage is read, before packing (through
//!   [`crate::usd::LoadOptions::outputs`]). Files are compared by identity (device and inode, so a
//!   hard link or another spelling of the path is caught), else by canonical path.
//! - The temporary file is named `.<name>.tmp-<pid>`. A run that is killed leaves its temporary
//!   behind (up to a blob's size); the next run writing the same output removes every such file
//!   whose process no longer exists ([`remove_stale_temporaries`]), and never one of a live
//!   process (which may be writing it now).

use std::path::{Path, PathBuf};

use crate::IngestError;

/// Writes `bytes` to `path` atomically, first removing the temporaries earlier runs left for it.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), IngestError> {
    remove_stale_temporaries(path);
    blob::write_atomic(path, bytes).map_err(|e| IngestError::write(path, e))
}

/// The prefix of the temporary files `blob::write_atomic` makes for `path` (`.<name>.tmp-`),
/// followed by the writer's process id.
fn temporary_prefix(path: &Path) -> Option<String> {
    Some(format!(".{}.tmp-", path.file_name()?.to_string_lossy()))
}

/// Whether process `pid` exists, or `None` when this system cannot tell (no `/proc`).
fn process_exists(pid: u32) -> Option<bool> {
    let proc = Path::new("/proc");
    proc.join("self").exists().then(|| proc.join(pid.to_string()).exists())
}

/// Removes the temporaries of `path` whose writer process is gone; returns how many. Errors are
/// ignored: a temporary that cannot be removed is only disk space, never a wrong output.
pub fn remove_stale_temporaries(path: &Path) -> usize {
    let Some(prefix) = temporary_prefix(path) else { return 0 };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let Ok(entries) = std::fs::read_dir(dir) else { return 0 };
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) =
            name.to_str().and_then(|n| n.strip_prefix(&prefix)).and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id()
            && process_exists(pid) == Some(false)
            && std::fs::remove_file(entry.path()).is_ok()
        {
            removed += 1;
        }
    }
    removed
}

/// Whether `a` and `b` name the same file: the same device and inode when both exist, else the same
/// canonical path (a file not written yet is compared through its canonical parent directory).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
    }
    match (canonical(a), canonical(b)) {
        (Some(ca), Some(cb)) => ca == cb,
        _ => a == b,
    }
}

/// `path` made absolute with symbolic links resolved, through its parent when it does not exist.
fn canonical(path: &Path) -> Option<PathBuf> {
    if let Ok(c) = path.canonicalize() {
        return Some(c);
    }
    let name = path.file_name()?;
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Some(parent.canonicalize().ok()?.join(name))
}

/// The first of `outputs` that is `input`, if any.
pub(crate) fn output_named_by<'a>(input: &Path, outputs: &'a [PathBuf]) -> Option<&'a PathBuf> {
    outputs.iter().find(|o| same_file(input, o))
}

/// Refuses outputs that name the root layer `input` or each other, before anything is read.
pub(crate) fn check_outputs(input: &Path, outputs: &[PathBuf]) -> Result<(), IngestError> {
    if let Some(output) = output_named_by(input, outputs) {
        return Err(IngestError::OutputIsInput { output: output.clone(), input: input.to_path_buf() });
    }
    for (i, a) in outputs.iter().enumerate() {
        if let Some(b) = outputs[i + 1..].iter().find(|b| same_file(a, b)) {
            return Err(IngestError::OutputsCollide { first: a.clone(), second: b.clone() });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_and_live_ones_kept() {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("scene.blob");
        // A pid above the kernel's maximum (2^22) can be no live process.
        let dead = dir.path().join(".scene.blob.tmp-4194305");
        let mine = dir.path().join(format!(".scene.blob.tmp-{}", std::process::id()));
        let other_output = dir.path().join(".other.blob.tmp-4194305");
        for f in [&dead, &mine, &other_output] {
            std::fs::write(f, b"partial").unwrap();
        }
        assert_eq!(remove_stale_temporaries(&out), 1);
        assert!(!dead.exists());
        assert!(mine.exists() && other_output.exists());
    }

    #[test]
    fn the_same_file_is_found_through_other_spellings() {
        let dir = tempfile::tempdir().unwrap();
        let a = dir.path().join("a.usda");
        std::fs::write(&a, "#usda 1.0\n").unwrap();
        let dotted = dir.path().join(".").join("a.usda");
        let linked = dir.path().join("b.usda");
        std::fs::hard_link(&a, &linked).unwrap();
        assert!(same_file(&a, &dotted) && same_file(&a, &linked));
        assert!(!same_file(&a, &dir.path().join("c.usda")));
        assert!(same_file(&dir.path().join("new.blob"), &dir.path().join(".").join("new.blob")));
    }
}
