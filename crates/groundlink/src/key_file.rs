//! The link key on disk: one line of 32 hexadecimal characters, readable by its owner only.
//!
//! [`create`] writes a fresh random key into a new file created with mode 0600 (never over an
//! existing file); [`load`] reads one back and refuses a file that its group or others can
//! read, because whoever holds the key can drive the robot.

use std::fmt;
use std::fs::{File, OpenOptions};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::string::String;

use crate::v2::{KeyParseError, LinkKey};

/// Longest key file read (a key line with generous whitespace); longer files are malformed.
const MAX_FILE_LEN: u64 = 256;

/// Why a key file could not be read or written. Every message names the file and what to do.
#[derive(Debug)]
pub enum KeyFileError {
    /// The file does not exist.
    Missing {
        /// The file.
        path: PathBuf,
    },
    /// The file's group or others can read or write it.
    Permissions {
        /// The file.
        path: PathBuf,
        /// Its permission bits.
        mode: u32,
    },
    /// The file does not hold a key.
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong with its text (`None`: too long, or not UTF-8).
        error: Option<KeyParseError>,
    },
    /// `create` refuses to overwrite an existing file.
    Exists {
        /// The file.
        path: PathBuf,
    },
    /// The operating system's random source failed.
    Random(getrandom::Error),
    /// Any other input/output error.
    Io {
        /// The file.
        path: PathBuf,
        /// The error.
        source: io::Error,
    },
}

impl fmt::Display for KeyFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            KeyFileError::Missing { path } => write!(
                f,
                "link key file {} does not exist: create one with `dima keygen {}` and copy it to \
                 the ground station",
                path.display(),
                path.display()
            ),
            KeyFileError::Permissions { path, mode } => write!(
                f,
                "link key file {} is accessible by group or others (mode {:03o}): run `chmod 600 {}`",
                path.display(),
                mode & 0o777,
                path.display()
            ),
            KeyFileError::Malformed { path, error } => {
                write!(f, "link key file {} does not hold a link key", path.display())?;
                if let Some(error) = error {
                    write!(f, " ({error})")?;
                }
                write!(
                    f,
                    ": it must be one line of {} hexadecimal characters; make a new one with \
                     `dima keygen PATH`",
                    LinkKey::HEX_LEN
                )
            }
            KeyFileError::Exists { path } => write!(
                f,
                "{} exists already: keygen never overwrites a key file; remove it first or choose \
                 another path",
                path.display()
            ),
            KeyFileError::Random(error) => {
                write!(f, "the operating system's random source failed: {error}")
            }
            KeyFileError::Io { path, source } => {
                write!(f, "link key file {}: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for KeyFileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            KeyFileError::Io { source, .. } => Some(source),
            KeyFileError::Malformed {
                error: Some(error), ..
            } => Some(error),
            _ => None,
        }
    }
}

/// A fresh random key from the operating system's random source.
pub fn generate() -> Result<LinkKey, KeyFileError> {
    let mut bytes = [0u8; LinkKey::LEN];
    getrandom::fill(&mut bytes).map_err(KeyFileError::Random)?;
    Ok(LinkKey::from_bytes(bytes))
}

/// Reads the key in `path`, refusing a file its group or others can access.
pub fn load(path: &Path) -> Result<LinkKey, KeyFileError> {
    let io_error = |source: io::Error| match source.kind() {
        io::ErrorKind::NotFound => KeyFileError::Missing {
            path: path.to_path_buf(),
        },
        _ => KeyFileError::Io {
            path: path.to_path_buf(),
            source,
        },
    };
    let file = File::open(path).map_err(io_error)?;
    check_permissions(&file, path)?;
    let mut text = String::new();
    file.take(MAX_FILE_LEN + 1)
        .read_to_string(&mut text)
        .map_err(|source| match source.kind() {
            io::ErrorKind::InvalidData => KeyFileError::Malformed {
                path: path.to_path_buf(),
                error: None,
            },
            _ => io_error(source),
        })?;
    if text.len() as u64 > MAX_FILE_LEN {
        return Err(KeyFileError::Malformed {
            path: path.to_path_buf(),
            error: None,
        });
    }
    LinkKey::parse_hex(&text).map_err(|error| KeyFileError::Malformed {
        path: path.to_path_buf(),
        error: Some(error),
    })
}

/// Writes a fresh random key to a new file `path`, created with mode 0600 (no moment where
/// others could read it), and returns the key. Refuses to overwrite an existing file.
pub fn create(path: &Path) -> Result<LinkKey, KeyFileError> {
    let key = generate()?;
    let mut options = OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o600);
    let mut file = options.open(path).map_err(|source| match source.kind() {
        io::ErrorKind::AlreadyExists => KeyFileError::Exists {
            path: path.to_path_buf(),
        },
        _ => KeyFileError::Io {
            path: path.to_path_buf(),
            source,
        },
    })?;
    let mut line = [0u8; LinkKey::HEX_LEN + 1];
    line[..LinkKey::HEX_LEN].copy_from_slice(&key.to_hex());
    line[LinkKey::HEX_LEN] = b'\n';
    file.write_all(&line)
        .and_then(|()| file.sync_all())
        .map_err(|source| KeyFileError::Io {
            path: path.to_path_buf(),
            source,
        })?;
    Ok(key)
}

#[cfg(unix)]
fn check_permissions(file: &File, path: &Path) -> Result<(), KeyFileError> {
    use std::os::unix::fs::PermissionsExt;
    let mode = file
        .metadata()
        .map_err(|source| KeyFileError::Io {
            path: path.to_path_buf(),
            source,
        })?
        .permissions()
        .mode();
    if mode & 0o077 != 0 {
        return Err(KeyFileError::Permissions {
            path: path.to_path_buf(),
            mode,
        });
    }
    Ok(())
}

#[cfg(not(unix))]
fn check_permissions(_file: &File, _path: &Path) -> Result<(), KeyFileError> {
    Ok(())
}
