//! The application's configuration: [`dima_core::config`] (one TOML file, every setting with a
//! documented default and its allowed range) and reading it from a file.

use std::path::Path;

pub use dima_core::config::*;

/// Reads and validates a configuration file. The error names the file, the key and what is
/// allowed.
pub fn load(path: &Path) -> anyhow::Result<Config> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        anyhow::anyhow!(
            "cannot read config file {}: {e} (write one with `dima config --print-default`)",
            path.display()
        )
    })?;
    Ok(Config::from_toml(&text, &path.display().to_string())?)
}
