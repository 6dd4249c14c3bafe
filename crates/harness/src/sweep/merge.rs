//! Merging the output directories of shards into one table.

use super::run::{read_record, Manifest, RunRecord, DONE_FILE, MANIFEST_FILE};
use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use serde_json::Value;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// Columns that come from the spec, before the result's own columns.
const SPEC_COLUMNS: &[&str] = &["index", "id", "robot", "terrain", "sampler", "seed", "steps"];

/// The completed runs of one or more shard directories, as one table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MergedReport {
    /// Column names: the spec columns, then the result's fields flattened with dotted names,
    /// sorted.
    pub columns: Vec<String>,
    /// One row per completed run, in spec order; each maps column to value (absent = null).
    pub rows: Vec<BTreeMap<String, Value>>,
    /// Ids of runs of the sweeps' matrices (from the directories' manifests) with no
    /// completion marker in any directory.
    pub missing: Vec<String>,
    /// Runs completed in more than one directory (shards that overlapped, or a run repeated
    /// by hand): the table keeps the first directory's, in the order given.
    #[serde(default)]
    pub duplicates: Vec<Duplicate>,
}

/// A run found complete in several directories.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Duplicate {
    /// Id of the run.
    pub id: String,
    /// Its directories, the one kept first.
    pub dirs: Vec<PathBuf>,
}

/// Flattens nested objects into dotted keys (`a.b`); arrays and scalars are leaves.
fn flatten(prefix: &str, v: &Value, out: &mut BTreeMap<String, Value>) {
    match v {
        Value::Object(map) => {
            for (k, x) in map {
                let key = if prefix.is_empty() {
                    k.clone()
                } else {
                    format!("{prefix}.{k}")
                };
                flatten(&key, x, out);
            }
        }
        _ => {
            let key = if prefix.is_empty() { "result" } else { prefix };
            out.insert(key.to_string(), v.clone());
        }
    }
}

fn row_of(rec: &RunRecord) -> BTreeMap<String, Value> {
    let mut row = BTreeMap::new();
    flatten("", &rec.result, &mut row);
    let s = &rec.spec;
    for (k, v) in [
        ("index", Value::from(s.index)),
        ("id", Value::from(s.id.clone())),
        ("robot", Value::from(s.robot.clone())),
        ("terrain", Value::from(s.terrain.clone())),
        ("sampler", Value::from(s.sampler.clone())),
        ("seed", Value::from(s.seed)),
        ("steps", Value::from(s.protocol.steps)),
    ] {
        row.insert(k.to_string(), v);
    }
    row
}

/// Merges the completed runs found in `dirs` (each a sweep output directory, e.g. one per
/// shard). A run done in several directories is reported in [`MergedReport::duplicates`] (its
/// figures may differ in wall time only); if its parameters differ, the merge fails naming
/// both places.
pub fn merge(dirs: &[PathBuf]) -> Result<MergedReport> {
    let mut records: BTreeMap<String, (RunRecord, PathBuf)> = BTreeMap::new();
    let mut expected: BTreeSet<(usize, String)> = BTreeSet::new();
    let mut sweep_names: BTreeSet<String> = BTreeSet::new();
    let mut duplicates: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
    for dir in dirs {
        let read = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        let manifest_path = dir.join(MANIFEST_FILE);
        if let Ok(text) = std::fs::read_to_string(&manifest_path) {
            let m: Manifest = serde_json::from_str(&text)
                .map_err(|e| Error::log(&manifest_path, format!("line {}", e.line()), e.to_string()))?;
            sweep_names.insert(m.matrix.name.clone());
            expected.extend(m.matrix.expand().into_iter().map(|s| (s.index, s.id)));
        }
        let mut subdirs: Vec<PathBuf> = read
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.is_dir())
            .collect();
        subdirs.sort();
        for sub in subdirs {
            if !sub.join(DONE_FILE).exists() {
                continue;
            }
            let rec = read_record(&sub)
                .ok_or_else(|| Error::log(sub.join(DONE_FILE), "(whole file)", "not a run record"))?;
            sweep_names.insert(rec.spec.sweep.clone());
            match records.get(&rec.spec.id) {
                Some((other, where_)) if other.spec != rec.spec => {
                    return Err(Error::log(
                        sub.join(DONE_FILE),
                        format!("run `{}`", rec.spec.id),
                        format!("has other parameters than the same run in {}", where_.display()),
                    ));
                }
                Some((_, where_)) => {
                    duplicates
                        .entry(rec.spec.id.clone())
                        .or_insert_with(|| vec![where_.clone()])
                        .push(sub.clone());
                }
                None => {
                    records.insert(rec.spec.id.clone(), (rec, sub.clone()));
                }
            }
        }
    }
    if sweep_names.len() > 1 {
        return Err(Error::MixedSweeps {
            sweeps: sweep_names.into_iter().collect(),
        });
    }
    let mut recs: Vec<RunRecord> = records.into_values().map(|(r, _)| r).collect();
    recs.sort_by(|a, b| (a.spec.index, &a.spec.id).cmp(&(b.spec.index, &b.spec.id)));
    let found: BTreeSet<&str> = recs.iter().map(|r| r.spec.id.as_str()).collect();
    let missing = expected
        .into_iter()
        .filter(|(_, id)| !found.contains(id.as_str()))
        .map(|(_, id)| id)
        .collect();
    let rows: Vec<BTreeMap<String, Value>> = recs.iter().map(row_of).collect();
    let mut result_cols: BTreeSet<String> = BTreeSet::new();
    for r in &rows {
        result_cols.extend(r.keys().filter(|k| !SPEC_COLUMNS.contains(&k.as_str())).cloned());
    }
    let columns = SPEC_COLUMNS
        .iter()
        .map(|s| s.to_string())
        .chain(result_cols)
        .collect();
    Ok(MergedReport {
        columns,
        rows,
        missing,
        duplicates: duplicates
            .into_iter()
            .map(|(id, dirs)| Duplicate { id, dirs })
            .collect(),
    })
}

/// A cell as CSV text: strings raw, null empty, anything else its JSON text.
fn cell(v: Option<&Value>) -> String {
    match v {
        None | Some(Value::Null) => String::new(),
        Some(Value::String(s)) => s.clone(),
        Some(x) => x.to_string(),
    }
}

impl MergedReport {
    /// The table as CSV text (header row of column names).
    pub fn to_csv(&self) -> Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.columns)?;
        for row in &self.rows {
            w.write_record(self.columns.iter().map(|c| cell(row.get(c))))?;
        }
        let bytes = w.into_inner().map_err(|e| Error::CsvFlush(e.into_error()))?;
        Ok(String::from_utf8(bytes)?)
    }

    /// Writes `merged.json` and `merged.csv` in `dir`; returns their paths.
    pub fn write(&self, dir: &Path) -> Result<(PathBuf, PathBuf)> {
        std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
        let json = dir.join("merged.json");
        let csv_path = dir.join("merged.csv");
        let text = serde_json::to_string_pretty(self).map_err(|e| Error::json(&json, e))?;
        std::fs::write(&json, text).map_err(|e| Error::io(&json, e))?;
        std::fs::write(&csv_path, self.to_csv()?).map_err(|e| Error::io(&csv_path, e))?;
        Ok((json, csv_path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn flatten_and_cells() {
        let mut out = BTreeMap::new();
        flatten(
            "",
            &json!({"a": {"b": 1, "c": [1, 2]}, "d": "x", "e": null}),
            &mut out,
        );
        assert_eq!(out.len(), 4);
        assert_eq!(cell(out.get("a.b")), "1");
        assert_eq!(cell(out.get("a.c")), "[1,2]");
        assert_eq!(cell(out.get("d")), "x");
        assert_eq!(cell(out.get("e")), "");
        let mut scalar = BTreeMap::new();
        flatten("", &json!(3.5), &mut scalar);
        assert_eq!(cell(scalar.get("result")), "3.5");
    }
}
