//! Atomic file writing: every output of planemap is written to a temporary name in the same
//! directory and renamed into place, so a reader (or a `--resume` run) never sees a half-written
//! file and a crash never leaves a truncated output under its final name.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The temporary name `path` is written under before the rename:
/// `<name>.tmp-<pid>-<n>` in the same directory (same file system, so the rename is atomic on
/// POSIX), with `n` unique within the process, so that two writes of the same file at once
/// (two threads, or two processes) never share a temporary file.
pub fn temp_path(path: &Path) -> PathBuf {
    static NEXT: AtomicU64 = AtomicU64::new(0);
    let mut name = path
        .file_name()
        .map(|n| n.to_os_string())
        .unwrap_or_default();
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    name.push(format!(".tmp-{}-{n}", std::process::id()));
    path.with_file_name(name)
}

/// Creates `path.tmp-<pid>`, lets `write` fill it through a buffered writer, flushes it and
/// renames it onto `path` (replacing any existing file). If `write`, the flush or the rename
/// fails, the temporary file is removed and the error returned; `path` is then untouched.
///
/// The error type is the closure's, so format writers can return their own error enum (it
/// must convert from [`io::Error`] for the create/flush/rename steps). The data is flushed to
/// the OS but not `fsync`ed: atomicity against concurrent readers and failed writes, not
/// durability across power loss.
pub fn write_atomic<E, F>(path: &Path, write: F) -> Result<(), E>
where
    E: From<io::Error>,
    F: FnOnce(&mut BufWriter<File>) -> Result<(), E>,
{
    let tmp = temp_path(path);
    let file = File::create(&tmp)?;
    let mut writer = BufWriter::new(file);
    let result = write(&mut writer).and_then(|()| {
        writer.flush()?;
        drop(writer);
        fs::rename(&tmp, path)?;
        Ok(())
    });
    if result.is_err() {
        // Best effort: the temp file may already be gone (e.g. the rename half-happened).
        let _ = fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_and_renames() -> io::Result<()> {
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("out.txt");
        fs::write(&path, b"old contents")?;
        write_atomic(&path, |w: &mut BufWriter<File>| w.write_all(b"new"))?;
        assert_eq!(fs::read(&path)?, b"new");
        assert_eq!(
            fs::read_dir(dir.path())?.count(),
            1,
            "no temporary file left"
        );
        Ok(())
    }

    #[test]
    fn failure_keeps_old_file_and_removes_temp() -> io::Result<()> {
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("out.bin");
        fs::write(&path, b"keep me")?;
        let result = write_atomic(&path, |w: &mut BufWriter<File>| {
            w.write_all(b"partial")?;
            Err(io::Error::other("writer failed"))
        });
        assert_eq!(result.unwrap_err().to_string(), "writer failed");
        assert_eq!(fs::read(&path)?, b"keep me");
        assert_eq!(
            fs::read_dir(dir.path())?.count(),
            1,
            "no temporary file left"
        );
        Ok(())
    }

    #[test]
    fn temp_name_is_beside_target() {
        let tmp = temp_path(Path::new("/a/b/depth.pfm"));
        assert_eq!(tmp.parent(), Some(Path::new("/a/b")));
        let name = tmp.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            name.starts_with(&format!("depth.pfm.tmp-{}-", std::process::id())),
            "{name}"
        );
        assert_ne!(
            temp_path(Path::new("/a/b/depth.pfm")),
            tmp,
            "unique per write"
        );
    }

    #[test]
    fn concurrent_writes_of_one_file_do_not_collide() -> io::Result<()> {
        // `--views 0,0,0` once labelled a view three times at once, and the writes shared
        // one temporary file.
        let dir = tempfile::tempdir()?;
        let path = dir.path().join("same.bin");
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..8u8)
                .map(|k| {
                    let path = &path;
                    s.spawn(move || {
                        for _ in 0..50 {
                            write_atomic(path, |w: &mut BufWriter<File>| w.write_all(&[k; 4096]))?;
                        }
                        Ok::<(), io::Error>(())
                    })
                })
                .collect();
            for h in handles {
                h.join().expect("writer thread")?;
            }
            Ok::<(), io::Error>(())
        })?;
        let bytes = fs::read(&path)?;
        assert_eq!(bytes.len(), 4096);
        assert!(
            bytes.iter().all(|&b| b == bytes[0]),
            "one writer's content, whole"
        );
        assert_eq!(
            fs::read_dir(dir.path())?.count(),
            1,
            "no temporary file left"
        );
        Ok(())
    }
}
