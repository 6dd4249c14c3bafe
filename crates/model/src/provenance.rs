//! What every output records to be reproduced: the program version, the schema version of the
//! output, the hashes of the robot and terrain files, and the options that made it.
//!
//! Outputs carry it as an added `provenance` field; existing fields are never renamed or
//! removed (users' scripts read them).

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::Path;

/// Version of the layout of drive-sim's JSON outputs and log metadata; raised when a field is
/// added, so that a reader can tell what to expect.
pub const SCHEMA_VERSION: u32 = 2;

/// Hex SHA-256 of `bytes`.
pub fn sha256_hex(bytes: &[u8]) -> String {
    let d = Sha256::digest(bytes);
    d.iter().map(|b| format!("{b:02x}")).collect()
}

/// Hex SHA-256 of a model file: of the file on disk, or of the embedded text of a built-in
/// (`<built-in>/robots/warthog.toml`), or `None` when neither can be read.
pub fn model_file_sha256(origin: &Path, builtins: &[(&str, &str)]) -> Option<String> {
    if let Ok(bytes) = std::fs::read(origin) {
        return Some(sha256_hex(&bytes));
    }
    let stem = origin.file_stem()?.to_str()?;
    if origin.starts_with("<built-in>") {
        return builtins
            .iter()
            .find(|(n, _)| *n == stem)
            .map(|(_, text)| sha256_hex(text.as_bytes()));
    }
    None
}

/// Hex SHA-256 of an input file (a log), `None` for a directory or an unreadable file.
pub fn file_sha256(path: &Path) -> Option<String> {
    if path.is_dir() {
        return None;
    }
    std::fs::read(path).ok().map(|b| sha256_hex(&b))
}

/// The provenance block of an output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// drive-sim version that wrote the output.
    pub version: String,
    /// [`SCHEMA_VERSION`] of the output.
    pub schema_version: u32,
    /// The command line, as run; left out of logs (empty), whose bytes must depend only on
    /// the options, not on where they were written.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub command: Vec<String>,
    /// Input files with their SHA-256 (robot, terrain, logs), by role.
    pub inputs: Vec<InputFile>,
    /// Options and settings that determine the output (seed, physics rate, noise, effects,
    /// sampler, ...), as JSON.
    pub options: serde_json::Value,
}

/// One input of an output.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputFile {
    /// What it is: `robot`, `terrain`, `log`.
    pub role: String,
    /// Path (or `<built-in>/...`).
    pub path: String,
    /// Hex SHA-256 of its bytes, when readable.
    pub sha256: Option<String>,
}

impl Provenance {
    /// Provenance of an output made by this process with `options`.
    pub fn new(inputs: Vec<InputFile>, options: serde_json::Value) -> Self {
        Self {
            version: env!("CARGO_PKG_VERSION").to_string(),
            schema_version: SCHEMA_VERSION,
            command: COMMAND
                .with_borrow(|c| c.clone())
                .unwrap_or_else(|| std::env::args().collect()),
            inputs,
            options,
        }
    }
}

std::thread_local! {
    /// The command that [`with_command`] names instead of the process's arguments.
    static COMMAND: std::cell::RefCell<Option<Vec<String>>> = const { std::cell::RefCell::new(None) };
}

/// Runs `f` with `command` recorded as the command of every [`Provenance`] made on this
/// thread meanwhile, instead of the process's arguments: a library caller (the Python package)
/// names its own call, which the interpreter's arguments do not show.
pub fn with_command<R>(command: Vec<String>, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<Vec<String>>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let before = self.0.take();
            COMMAND.with_borrow_mut(|c| *c = before);
        }
    }
    let _restore = Restore(COMMAND.with_borrow_mut(|c| c.replace(command)));
    f()
}

/// Adds `provenance` as a top-level field `provenance` of the JSON object in the file at
/// `path` (rewritten atomically); the other fields are kept as they are.
pub fn stamp_json_file(path: &Path, provenance: &Provenance) -> crate::Result<()> {
    let text = std::fs::read_to_string(path).map_err(|e| crate::Error::io(path, e))?;
    let mut v: serde_json::Value = serde_json::from_str(&text).map_err(|e| crate::Error::json(path, e))?;
    if let Some(o) = v.as_object_mut() {
        o.insert(
            "provenance".into(),
            serde_json::to_value(provenance).map_err(|e| crate::Error::json(path, e))?,
        );
    }
    crate::output::write_json_atomic(path, &v)
}

impl InputFile {
    /// A log or other input file, hashed.
    pub fn of_file(role: &str, path: &Path) -> Self {
        Self {
            role: role.to_string(),
            path: path.display().to_string(),
            sha256: file_sha256(path),
        }
    }
    /// A robot or terrain file (or built-in), hashed.
    pub fn of_model(role: &str, origin: &Path, builtins: &[(&str, &str)]) -> Self {
        Self {
            role: role.to_string(),
            path: origin.display().to_string(),
            sha256: model_file_sha256(origin, builtins),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_abc() {
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }
}
