//! Loading of the data files (`robots/*.toml`, `terrains/*.toml`): embedded built-ins, user
//! directories, explicit paths, and errors that name the file and the field.

use crate::error::{Error, Result};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// A data file that is validated after parsing.
pub trait Validate {
    /// Checks physical plausibility; returns the dotted field path and the reason on failure.
    fn validate(&self) -> std::result::Result<(), (String, String)>;
}

/// Parses TOML text into `T`, reporting the dotted field path of any missing or mistyped value.
pub fn parse_toml<T: DeserializeOwned + Validate>(text: &str, file: &Path) -> Result<T> {
    let de = toml::Deserializer::parse(text)
        .map_err(|e| Error::config(file, "(syntax)", e.to_string().trim().to_string()))?;
    let value: T = serde_path_to_error::deserialize(de).map_err(|e| {
        let path = e.path().to_string();
        let field = if path == "." || path.is_empty() {
            "(top level)".to_string()
        } else {
            path
        };
        Error::config(file, field, with_suggestion(e.into_inner().message().trim()))
    })?;
    value
        .validate()
        .map_err(|(field, msg)| Error::config(file, field, msg))?;
    Ok(value)
}

/// Reads and parses a TOML data file.
pub fn load_toml<T: DeserializeOwned + Validate>(path: &Path) -> Result<T> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse_toml(&text, path)
}

/// A named data file: its name (file stem) and where its text comes from.
#[derive(Debug, Clone)]
pub struct CatalogEntry {
    /// Name used on the command line (the file stem).
    pub name: String,
    /// Path of the file, or `<built-in>/kind/name.toml` for embedded ones.
    pub origin: PathBuf,
    /// The TOML text.
    pub text: String,
}

/// The robots or terrains a user can name: built-ins embedded in the binary, overridden and
/// extended by `*.toml` files in `./<kind>s/` and in the directory of `DRIVE_SIM_DATA`.
pub fn catalog(kind: &str, builtins: &[(&str, &str)]) -> Vec<CatalogEntry> {
    let mut entries: Vec<CatalogEntry> = builtins
        .iter()
        .map(|(name, text)| CatalogEntry {
            name: name.to_string(),
            origin: PathBuf::from(format!("<built-in>/{kind}s/{name}.toml")),
            text: text.to_string(),
        })
        .collect();
    let mut dirs = vec![PathBuf::from(format!("{kind}s"))];
    if let Ok(root) = std::env::var("DRIVE_SIM_DATA") {
        dirs.push(Path::new(&root).join(format!("{kind}s")));
    }
    for dir in dirs {
        let Ok(read) = std::fs::read_dir(&dir) else {
            continue;
        };
        let mut files: Vec<PathBuf> = read
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "toml"))
            .collect();
        files.sort();
        for path in files {
            let Some(name) = path.file_stem().and_then(|s| s.to_str()).map(str::to_string) else {
                continue;
            };
            let Ok(text) = std::fs::read_to_string(&path) else {
                continue;
            };
            entries.retain(|e| e.name != name);
            entries.push(CatalogEntry {
                name,
                origin: path,
                text,
            });
        }
    }
    entries.sort_by(|a, b| a.name.cmp(&b.name));
    entries
}

/// Resolves `name_or_path`: an existing `.toml` path is loaded directly, otherwise the name is
/// looked up in the catalog.
pub fn resolve<T: DeserializeOwned + Validate>(
    kind: &'static str,
    name_or_path: &str,
    builtins: &[(&str, &str)],
) -> Result<(T, PathBuf)> {
    let p = Path::new(name_or_path);
    if p.extension().is_some_and(|x| x == "toml") || p.components().count() > 1 {
        return Ok((load_toml(p)?, p.to_path_buf()));
    }
    let entries = catalog(kind, builtins);
    match entries.iter().find(|e| e.name == name_or_path) {
        Some(e) => Ok((parse_toml(&e.text, &e.origin)?, e.origin.clone())),
        None => Err(Error::Unknown {
            kind,
            name: name_or_path.to_string(),
            available: entries
                .iter()
                .map(|e| e.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        }),
    }
}

/// Checks that a value is finite and strictly positive.
pub fn positive(field: &str, v: f64) -> std::result::Result<(), (String, String)> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err((field.to_string(), format!("must be a finite number > 0, got {v}")))
    }
}

/// Checks that a value is finite and non-negative.
pub fn non_negative(field: &str, v: f64) -> std::result::Result<(), (String, String)> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err((
            field.to_string(),
            format!("must be a finite number >= 0, got {v}"),
        ))
    }
}

/// Checks that a value is finite and within `[lo, hi]` (in `unit`); the message gives the
/// allowed range with its unit.
pub fn in_range(
    field: &str,
    v: f64,
    lo: f64,
    hi: f64,
    unit: &str,
) -> std::result::Result<(), (String, String)> {
    if v.is_finite() && v >= lo && v <= hi {
        Ok(())
    } else {
        Err((
            field.to_string(),
            format!("must be in [{lo}, {hi}] {unit}, got {v}"),
        ))
    }
}

/// The candidate closest to `word` (Jaro-Winkler similarity at least 0.7), for "did you
/// mean" hints on mistyped keys and names.
pub fn did_you_mean<'a>(word: &str, candidates: impl IntoIterator<Item = &'a str>) -> Option<&'a str> {
    candidates
        .into_iter()
        .map(|c| (strsim::jaro_winkler(word, c), c))
        .filter(|(score, _)| *score >= 0.7)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, c)| c)
}

/// Serde's "unknown field `x`, expected one of `a`, `b`" with a "did you mean `a`?" added.
fn with_suggestion(message: &str) -> String {
    let Some(rest) = message.strip_prefix("unknown field `") else {
        return message.to_string();
    };
    let Some((word, expected)) = rest.split_once('`') else {
        return message.to_string();
    };
    let candidates: Vec<&str> = expected.split('`').skip(1).step_by(2).collect();
    match did_you_mean(word, candidates) {
        Some(c) => format!("{message}; did you mean `{c}`?"),
        None => message.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_fields_get_a_suggestion() {
        let m = with_suggestion("unknown field `terains`, expected one of `name`, `robots`, `terrains`");
        assert!(m.ends_with("did you mean `terrains`?"), "{m}");
        let m = with_suggestion("unknown field `zzz`, expected `name`");
        assert!(!m.contains("did you mean"), "{m}");
    }
}
