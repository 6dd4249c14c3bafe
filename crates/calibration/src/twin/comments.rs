//! The comments of a twin's files: each fitted or chosen value's provenance on the line that
//! sets it, found by the parameter's report name, and the TOML text written with them.

use crate::error::{Error, Result};
use crate::fit::FittedParam;
use crate::params::Param;
use serde::Serialize;
use std::collections::BTreeMap;

/// The comment of one fitted value: value, interval, dataset.
pub(super) fn comment_for(p: &FittedParam, dataset: &str, declared: Option<f64>) -> String {
    let interval = match (p.se, p.ci95) {
        (Some(se), Some(ci)) if se.is_finite() => {
            format!("± {se:.3e} (95 % [{:.6}, {:.6}])", ci[0], ci[1])
        }
        (Some(se), _) if se.is_infinite() => "no interval: the data do not constrain it".into(),
        _ if p.at_bound => format!(
            "no interval: ended on its search box [{}, {}] (a stand-in for something the model lacks)",
            p.lower, p.upper
        ),
        _ => "no interval (on/off parameter)".into(),
    };
    let declared = declared
        .map(|v| format!("; declared {v}"))
        .unwrap_or_else(|| "; off in the declared model".into());
    let ident = match p.identifiable {
        Some(false) => "; not identifiable",
        _ => "",
    };
    let unit = if p.unit == "-" || p.unit.is_empty() {
        String::new()
    } else {
        format!(" {}", p.unit)
    };
    // A share of the peak sits on the line of the value it sets: say which number it is.
    let what = if share_lines(&p.name).is_some() {
        "share of the peak "
    } else {
        ""
    };
    format!(
        "[fit] {dataset}: {what}{:.6}{unit} {interval}{declared}{ident}",
        p.value
    )
}

/// A parameter written as a share of another line's value: the dotted paths of the line it
/// sets and of the line it is a share of (the sliding friction's share of its peak).
fn share_lines(name: &str) -> Option<(&'static str, &'static str)> {
    (name == Param::SlidingShareLongitudinal.name())
        .then_some(("friction.sliding_longitudinal", "friction.peak_longitudinal"))
}

/// Which file holds the parameter named `name` (report name): the terrain file (`true`) or the
/// robot's, and the dotted path of the line that holds it there. `terrain` is the serialized
/// terrain file (an effect's parameter is in the file that carries the effect).
pub(super) fn file_path(name: &str, terrain: &toml::Value) -> Option<(bool, String)> {
    if let Some((line, _)) = share_lines(name) {
        return Some((true, line.into()));
    }
    if let Some(rest) = name.strip_prefix("robot.") {
        Some((false, rest.to_string()))
    } else if let Some(rest) = name.strip_prefix("terrain.") {
        Some((true, rest.to_string()))
    } else if let Some(key) = name.strip_prefix("effect.") {
        let path = format!("effects.{key}");
        Some((value_at(terrain, &path).is_some(), path))
    } else {
        None
    }
}

/// The value of the parameter named `name` in a serialized file, whose line is at `path`
/// ([`file_path`]): the line's value, or for a share of the peak the sliding value over the
/// peak.
pub(super) fn value_in_file(name: &str, path: &str, file: &toml::Value) -> Option<f64> {
    match share_lines(name) {
        Some((_, of)) => Some(value_at(file, path)? / value_at(file, of)?),
        None => value_at(file, path),
    }
}

/// Looks up `section.key` in a serialized file.
fn value_at(v: &toml::Value, path: &str) -> Option<f64> {
    let mut cur = v;
    for part in path.split('.') {
        cur = cur.get(part)?;
    }
    cur.as_float().or_else(|| cur.as_integer().map(|i| i as f64))
}

/// `value` as TOML text with `# comment`s after the lines whose dotted path (`section.key`)
/// has one, below a header of `# ` lines.
pub fn commented_toml<T: Serialize>(
    value: &T,
    header: &[String],
    comments: &BTreeMap<String, String>,
) -> Result<String> {
    let text = toml::to_string(value).map_err(|source| Error::Toml {
        what: "a twin file",
        source,
    })?;
    let mut out = String::new();
    for h in header {
        out.push_str("# ");
        out.push_str(h);
        out.push('\n');
    }
    let mut section = String::new();
    for line in text.lines() {
        let t = line.trim();
        if t.starts_with('[') && t.ends_with(']') {
            section = t.trim_matches(|c| c == '[' || c == ']').to_string();
        }
        out.push_str(line);
        if let Some((key, _)) = t.split_once(" = ") {
            let path = if section.is_empty() {
                key.trim().to_string()
            } else {
                format!("{section}.{}", key.trim())
            };
            if let Some(c) = comments.get(&path) {
                out.push_str("  # ");
                out.push_str(c);
            }
        }
        out.push('\n');
    }
    Ok(out)
}

/// `text` (a twin file) with the comment of the line that sets `key` amended by `note`: a
/// comment saying "no interval" has those words replaced, any other gets `; note` appended, a
/// line without one gets `# note`. `None` when no line sets `key`. Only the comment changes:
/// the file loads to the same model.
pub fn annotate_value(text: &str, key: &str, note: &str) -> Option<String> {
    let mut found = false;
    let mut out = String::with_capacity(text.len() + note.len() + 4);
    for line in text.lines() {
        let t = line.trim_start();
        let sets_key = !found
            && t.strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='));
        if sets_key {
            found = true;
            // Twin values are numbers: the first `#` after the `=` starts the comment.
            match line.split_once('#') {
                Some((value, comment)) if comment.contains("no interval") => {
                    out.push_str(value);
                    out.push('#');
                    out.push_str(&comment.replacen("no interval", note, 1));
                }
                Some((value, comment)) => {
                    out.push_str(value);
                    out.push('#');
                    out.push_str(comment.trim_end());
                    out.push_str("; ");
                    out.push_str(note);
                }
                None => {
                    out.push_str(line.trim_end());
                    out.push_str("  # ");
                    out.push_str(note);
                }
            }
        } else {
            out.push_str(line);
        }
        out.push('\n');
    }
    found.then_some(out)
}
