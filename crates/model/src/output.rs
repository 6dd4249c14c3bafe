//! Outputs that appear complete or not at all: every file and folder drive-sim writes goes
//! through here.
//!
//! A file is written under a temporary name in its own directory and renamed over the final
//! name once complete (a rename within one directory is atomic on POSIX file systems), so a
//! reader never sees half a file and an older file stays intact until the new one is whole. A
//! folder of outputs (an analysis, a calibration) is assembled in a hidden staging directory
//! beside its destination ([`StagedDir`]); committing it renames the whole folder into place
//! when the destination does not exist yet, or moves each finished file over its old version
//! when it does (a user's other files in `--out` are never removed). A failure before the
//! commit leaves the destination as it was.

use crate::error::{Error, Result};
use serde::Serialize;
use std::path::{Component, Path, PathBuf};

/// The temporary name a file is written under before [`write_atomic`] renames it:
/// `.<name>.tmp-<pid>` in the same directory.
pub fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "output".into());
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Writes `bytes` to `path` atomically (temporary name, then rename). The parent directory
/// must exist.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = temp_path(path);
    if let Err(e) = std::fs::write(&tmp, bytes) {
        let _ = std::fs::remove_file(&tmp);
        return Err(Error::io(path, e));
    }
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        Error::io(path, e)
    })
}

/// Writes pretty JSON to `path` atomically, naming the file on failure.
pub fn write_json_atomic(path: &Path, value: &impl Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value).map_err(|e| Error::json(path, e))?;
    write_atomic(path, text.as_bytes())
}

/// Creates directory `dir` (and its parents), with an error that names the first component
/// that is in the way (e.g. a file where a directory is needed). Called before any long work
/// so that an unusable `--out` is reported at once.
pub fn ensure_dir(dir: &Path, option: &str) -> Result<()> {
    let mut at = PathBuf::new();
    for c in dir.components() {
        at.push(c);
        if at.exists() && !at.is_dir() {
            return Err(Error::config(
                option,
                dir.display().to_string(),
                format!("`{}` is a file, not a directory", at.display()),
            ));
        }
    }
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))
}

/// Checks that `name` can be used as one file name inside an output directory: not empty, no
/// path separator, not `.` or `..`, no NUL, at most 200 bytes. `option` names the option or
/// field in the error (`--name`).
pub fn check_file_name(option: &str, name: &str) -> Result<()> {
    let bad = |why: &str| {
        Err(Error::config(
            "<command line>",
            option,
            format!("`{name}` {why}; a name is one file name inside --out (letters, digits, `-`, `_`, `.`)"),
        ))
    };
    if name.is_empty() {
        return bad("is empty");
    }
    if name.contains('/') || name.contains('\\') {
        return bad("contains a path separator");
    }
    if name == "." || name == ".." || name.starts_with('.') {
        return bad("starts with `.` (hidden or a parent directory)");
    }
    if name.contains('\0') || name.chars().any(char::is_control) {
        return bad("contains a control character");
    }
    if name.len() > 200 {
        return bad("is longer than 200 bytes");
    }
    // Belt and braces: whatever the platform's separators, one normal component.
    let mut comps = Path::new(name).components();
    if !matches!((comps.next(), comps.next()), (Some(Component::Normal(_)), None)) {
        return bad("is not a single file name");
    }
    Ok(())
}

/// A folder of outputs assembled out of sight and put in place whole by [`StagedDir::commit`].
/// Dropping it without committing removes the staging directory.
#[derive(Debug)]
pub struct StagedDir {
    dest: PathBuf,
    staging: PathBuf,
    committed: bool,
}

impl StagedDir {
    /// Prepares to write the folder `dest`: checks that its parent can hold it (reported at
    /// once, before any long work, naming `option`) and creates the staging directory
    /// `.<name>.partial-<pid>` beside it.
    pub fn begin(dest: &Path, option: &str) -> Result<Self> {
        if dest.exists() && !dest.is_dir() {
            return Err(Error::config(
                option,
                dest.display().to_string(),
                "is a file, not a directory".to_string(),
            ));
        }
        let name = dest
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "out".into());
        let parent = match dest.parent() {
            Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
            _ => PathBuf::from("."),
        };
        ensure_dir(&parent, option)?;
        let staging = parent.join(format!(".{name}.partial-{}", std::process::id()));
        if staging.exists() {
            std::fs::remove_dir_all(&staging).map_err(|e| Error::io(&staging, e))?;
        }
        std::fs::create_dir(&staging).map_err(|e| Error::io(&staging, e))?;
        Ok(Self {
            dest: dest.to_path_buf(),
            staging,
            committed: false,
        })
    }
    /// Where to write the folder's files now.
    pub fn path(&self) -> &Path {
        &self.staging
    }
    /// The final folder.
    pub fn dest(&self) -> &Path {
        &self.dest
    }
    /// `path` (under the staging directory) as it will be after the commit.
    pub fn final_path(&self, path: &Path) -> PathBuf {
        match path.strip_prefix(&self.staging) {
            Ok(rel) => self.dest.join(rel),
            Err(_) => path.to_path_buf(),
        }
    }
    /// Puts the folder in place: one rename if the destination does not exist, else each file
    /// moved over its old version (subfolders merged the same way).
    pub fn commit(mut self) -> Result<PathBuf> {
        if !self.dest.exists() {
            std::fs::rename(&self.staging, &self.dest).map_err(|e| Error::io(&self.dest, e))?;
        } else {
            merge_into(&self.staging, &self.dest)?;
            let _ = std::fs::remove_dir_all(&self.staging);
        }
        self.committed = true;
        Ok(self.dest.clone())
    }
}

fn merge_into(from: &Path, to: &Path) -> Result<()> {
    for entry in std::fs::read_dir(from).map_err(|e| Error::io(from, e))? {
        let entry = entry.map_err(|e| Error::io(from, e))?;
        let src = entry.path();
        let dst = to.join(entry.file_name());
        if src.is_dir() && dst.is_dir() {
            merge_into(&src, &dst)?;
        } else {
            if dst.is_dir() {
                std::fs::remove_dir_all(&dst).map_err(|e| Error::io(&dst, e))?;
            }
            std::fs::rename(&src, &dst).map_err(|e| Error::io(&dst, e))?;
        }
    }
    Ok(())
}

impl Drop for StagedDir {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_escape_are_refused() {
        for bad in ["../x", "../../../x", "a/b", "", "..", ".hidden", "a\\b"] {
            assert!(check_file_name("--name", bad).is_err(), "{bad}");
        }
        for good in ["run1", "warthog_ice_s3", "a.b-c"] {
            check_file_name("--name", good).unwrap();
        }
    }

    #[test]
    fn staged_dir_appears_whole_and_keeps_other_files() {
        let tmp = tempfile::tempdir().unwrap();
        let dest = tmp.path().join("out");
        let s = StagedDir::begin(&dest, "--out").unwrap();
        std::fs::write(s.path().join("a.json"), "1").unwrap();
        assert!(!dest.exists());
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(dest.join("a.json")).unwrap(), "1");
        std::fs::write(dest.join("mine.txt"), "keep").unwrap();
        let s = StagedDir::begin(&dest, "--out").unwrap();
        std::fs::write(s.path().join("a.json"), "2").unwrap();
        drop(s);
        assert_eq!(std::fs::read_to_string(dest.join("a.json")).unwrap(), "1");
        let s = StagedDir::begin(&dest, "--out").unwrap();
        std::fs::write(s.path().join("a.json"), "2").unwrap();
        s.commit().unwrap();
        assert_eq!(std::fs::read_to_string(dest.join("a.json")).unwrap(), "2");
        assert_eq!(std::fs::read_to_string(dest.join("mine.txt")).unwrap(), "keep");
        assert_eq!(std::fs::read_dir(tmp.path()).unwrap().count(), 1);
    }

    #[test]
    fn a_file_in_the_way_is_reported_before_work() {
        let tmp = tempfile::tempdir().unwrap();
        std::fs::write(tmp.path().join("f"), "").unwrap();
        let e = StagedDir::begin(&tmp.path().join("f/sub"), "--out").unwrap_err();
        assert!(e.is_bad_input() && e.to_string().contains("is a file"), "{e}");
    }
}
