//! The one way an FMU reads a file a master names (parameter files, the wind's coefficient
//! table, the structure's modes file), and the tools a file a user names (command tables, logs,
//! parameter sets, sweep files, wind records): only a regular file, only up to a declared size,
//! into memory reserved fallibly.
//!
//! A master may name anything: a FIFO, whose `open` or `read` would block the call for ever;
//! `/dev/zero`, which never ends; a file of gigabytes, whose buffer would abort the process
//! when the allocation fails. An FMU must answer every call and never take its host down, so
//! the file is opened without blocking, checked to be a regular file by the descriptor it was
//! opened with (no window between the check and the read), and read up to its limit plus one
//! byte, so that a file that grows while it is read is refused too.

use std::fs::{File, OpenOptions};
use std::io::Read;
use std::path::{Path, PathBuf};

/// The largest parameter file an FMU reads, bytes (1 MiB): a parameter file holds a few
/// hundred assignments of a few dozen bytes each, so this is a thousand times the largest
/// useful one.
pub const MAX_PARAMETER_FILE_BYTES: u64 = 1 << 20;

/// Opening flag that makes `open` of a FIFO return at once instead of waiting for a writer
/// (`O_NONBLOCK` of Linux; the value is fixed by the kernel's ABI). Regular files ignore it.
#[cfg(unix)]
const O_NONBLOCK: i32 = 0o4000;

/// Opens `path` for reading without waiting on a FIFO's writer (on Windows a file opens without
/// such a wait, and the regular-file check below refuses pipes and devices alike).
fn open_without_blocking(path: &Path) -> std::io::Result<File> {
    let mut options = OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, O_NONBLOCK);
    options.open(path)
}

/// Why a file was not read; `what` names the file ("parameter file", "modes file").
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("cannot read {what} {}: {source}", .path.display())]
    Open { what: &'static str, path: PathBuf, source: std::io::Error },
    #[error("{what} {} is not a regular file ({kind}); only regular files are read, so that a FIFO or a device cannot block or flood the reader", .path.display())]
    NotRegular { what: &'static str, path: PathBuf, kind: &'static str },
    #[error("{what} {} has {len} bytes, more than the {max_bytes} bytes read", .path.display())]
    TooLarge { what: &'static str, path: PathBuf, len: u64, max_bytes: u64 },
    #[error("cannot read {what} {}: {source}", .path.display())]
    Read { what: &'static str, path: PathBuf, source: ReadError },
}

/// Why the bytes of an open regular file could not be taken as text.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error("cannot reserve {bytes} bytes: {source}")]
    Reserve { bytes: u64, source: std::collections::TryReserveError },
    #[error("{0}")]
    Io(#[source] std::io::Error),
    #[error("the file grew beyond {max_bytes} bytes while it was read")]
    Grew { max_bytes: u64 },
    #[error("not UTF-8 text ({0})")]
    NotUtf8(#[source] std::string::FromUtf8Error),
}

/// Reads the whole of `path` as UTF-8 text, if it is a regular file of at most `max_bytes`
/// bytes. `what` names the file in the error ("parameter file", "modes file").
pub fn read_regular_file(path: &Path, max_bytes: u64, what: &'static str) -> Result<String, FileError> {
    let open = |source| FileError::Open { what, path: path.to_path_buf(), source };
    let file = open_without_blocking(path).map_err(open)?;
    let metadata = file.metadata().map_err(open)?;
    if !metadata.is_file() {
        return Err(FileError::NotRegular { what, path: path.to_path_buf(), kind: describe_file_type(&metadata) });
    }
    if metadata.len() > max_bytes {
        return Err(FileError::TooLarge { what, path: path.to_path_buf(), len: metadata.len(), max_bytes });
    }
    read_bounded(file, max_bytes).map_err(|source| FileError::Read { what, path: path.to_path_buf(), source })
}

/// Reads at most `max_bytes` from an open regular file into a buffer reserved fallibly.
fn read_bounded(file: File, max_bytes: u64) -> Result<String, ReadError> {
    let mut bytes = Vec::new();
    let expected = file.metadata().map(|m| m.len()).unwrap_or(0).min(max_bytes);
    bytes.try_reserve_exact(expected as usize + 1).map_err(|source| ReadError::Reserve { bytes: expected, source })?;
    file.take(max_bytes + 1).read_to_end(&mut bytes).map_err(ReadError::Io)?;
    if bytes.len() as u64 > max_bytes {
        return Err(ReadError::Grew { max_bytes });
    }
    String::from_utf8(bytes).map_err(ReadError::NotUtf8)
}

#[cfg(unix)]
fn describe_file_type(metadata: &std::fs::Metadata) -> &'static str {
    use std::os::unix::fs::FileTypeExt;
    let ty = metadata.file_type();
    if ty.is_dir() {
        "a directory"
    } else if ty.is_fifo() {
        "a FIFO"
    } else if ty.is_char_device() {
        "a character device"
    } else if ty.is_block_device() {
        "a block device"
    } else if ty.is_socket() {
        "a socket"
    } else {
        "not a regular file"
    }
}

/// What a file that is not a regular one is (Windows tells directories from the rest).
#[cfg(not(unix))]
fn describe_file_type(metadata: &std::fs::Metadata) -> &'static str {
    if metadata.is_dir() {
        "a directory"
    } else {
        "not a regular file"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_and_directories_are_refused_at_once() {
        for (path, kind) in
            [("/dev/zero", "character device"), ("/dev/null", "character device"), ("/tmp", "directory")]
        {
            let error = read_regular_file(Path::new(path), 1024, "test file").unwrap_err().to_string();
            assert!(error.contains(kind) && error.contains("not a regular file"), "{path}: {error}");
        }
    }

    #[test]
    fn a_fifo_is_refused_without_blocking() {
        let dir = std::env::temp_dir().join(format!("fmu-runtime-fifo-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let fifo = dir.join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if !made.is_ok_and(|s| s.success()) {
            // No mkfifo on this machine: nothing to check, the device test covers the rule.
            let _ = std::fs::remove_dir_all(&dir);
            return;
        }
        let started = std::time::Instant::now();
        let error = read_regular_file(&fifo, 1024, "test file").unwrap_err().to_string();
        assert!(error.contains("FIFO"), "{error}");
        assert!(started.elapsed().as_secs_f64() < 1.0);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn files_beyond_the_limit_are_refused_and_smaller_ones_read() {
        let path = std::env::temp_dir().join(format!("fmu-runtime-limit-{}", std::process::id()));
        std::fs::write(&path, "a = 1\n").unwrap();
        assert_eq!(read_regular_file(&path, 6, "test file").unwrap(), "a = 1\n");
        let error = read_regular_file(&path, 5, "test file").unwrap_err().to_string();
        assert!(error.contains("more than the 5 bytes"), "{error}");
        let _ = std::fs::remove_file(&path);
    }
}
