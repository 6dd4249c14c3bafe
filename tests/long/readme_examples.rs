//! The README's examples run as written, and every relative link of the README and `docs/`
//! resolves.
//!
//! **Which blocks run.** A fenced block whose info string is `sh example` (GitHub highlights it as
//! `sh`) is an example: each of its commands runs, in the README's order, and must exit with 0.
//! A line ending in `\` continues on the next; `#` starts a comment line. Plain `sh` blocks are
//! not run: the two commands (`cargo run --release` is CI's smoke stage and the test command is
//! CI itself), the line that puts the release binary on `PATH` (replaced here, see below),
//! benches and release-profile tests (minutes each), and cluster submissions (`sbatch`,
//! `docker`, `kubectl`: no batch system in CI).
//!
//! **Where they run.** In a temporary copy of a fresh clone's layout, as the README assumes after
//! the two commands: a directory holding a link to each entry of the repository's root (so
//! `robots/`, `sweeps/`, `tests/`, `.venv/` read as in the clone), with a fresh `out/`, and
//! `../shared` beside it linked to the repository's `../shared`. The `drive-sim` of `PATH` is
//! the binary this test build made (`CARGO_BIN_EXE_drive-sim`, its directory first on `PATH`).
//! Nothing is written into the repository.
//!
//! **Size.** The examples are kept small (20-step runs, a few fitted steps) so that this file
//! takes about a minute of the test command on two cores; `--nocapture` prints each block's
//! time.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// The info string that marks a block as an example.
const EXAMPLE_INFO: &str = "sh example";

/// One example block: where it starts in the README and its commands.
struct Block {
    line: usize,
    commands: Vec<String>,
}

/// The `sh example` blocks of a Markdown text, each command joined across `\` continuations.
fn example_blocks(markdown: &str) -> Vec<Block> {
    let mut blocks = Vec::new();
    let mut current: Option<(Block, String)> = None;
    for (i, line) in markdown.lines().enumerate() {
        match current.as_mut() {
            None => {
                if line.trim_start().starts_with("```") && line.trim()[3..].trim() == EXAMPLE_INFO {
                    let block = Block {
                        line: i + 1,
                        commands: Vec::new(),
                    };
                    current = Some((block, String::new()));
                }
            }
            Some((block, pending)) => {
                if line.trim_start().starts_with("```") {
                    assert!(
                        pending.is_empty(),
                        "README.md:{}: the block ends inside a continued command",
                        block.line
                    );
                    blocks.push(current.take().unwrap().0);
                    continue;
                }
                let text = line.trim();
                if pending.is_empty() && (text.is_empty() || text.starts_with('#')) {
                    continue;
                }
                match text.strip_suffix('\\') {
                    Some(head) => {
                        pending.push_str(head.trim_end());
                        pending.push(' ');
                    }
                    None => {
                        pending.push_str(text);
                        block.commands.push(std::mem::take(pending));
                    }
                }
            }
        }
    }
    assert!(current.is_none(), "README.md: an example block is not closed");
    blocks
}

/// A fresh clone's layout in `root`: `root/drive-sim` links every entry of the repository but
/// its build and output directories, and `root/shared` links the repository's `../shared`.
#[cfg(unix)]
fn clone_layout(repo: &Path, root: &Path) -> PathBuf {
    use std::os::unix::fs::symlink;
    let clone = root.join("drive-sim");
    std::fs::create_dir(&clone).unwrap();
    for entry in std::fs::read_dir(repo).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name();
        let keep = match name.to_str() {
            Some("target" | "out" | "runs" | ".git") => false,
            Some(n) => !n.starts_with('.') || n == ".venv",
            None => false,
        };
        if keep {
            symlink(entry.path(), clone.join(&name)).unwrap();
        }
    }
    let shared = repo.join("../shared");
    assert!(
        shared.is_dir(),
        "the README's examples read ../shared beside the repository ({} is missing)",
        shared.display()
    );
    symlink(shared.canonicalize().unwrap(), root.join("shared")).unwrap();
    clone
}

/// The examples of README.md, run in order in a fresh clone's layout.
#[cfg(unix)]
#[test]
fn the_readme_examples_run_as_written() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let readme = std::fs::read_to_string(repo.join("README.md")).unwrap();
    let blocks = example_blocks(&readme);
    assert!(
        !blocks.is_empty(),
        "README.md has no `{EXAMPLE_INFO}` block: the marker changed?"
    );

    let root = tempfile::tempdir().unwrap();
    let clone = clone_layout(repo, root.path());
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_drive-sim")).parent().unwrap();
    let path = std::env::join_paths(
        std::iter::once(bin_dir.to_path_buf()).chain(std::env::split_paths(
            &std::env::var_os("PATH").unwrap_or_default(),
        )),
    )
    .unwrap();

    let start = Instant::now();
    for block in &blocks {
        let t0 = Instant::now();
        for command in &block.commands {
            let out = Command::new("bash")
                .args(["-e", "-o", "pipefail", "-c", command])
                .current_dir(&clone)
                .env("PATH", &path)
                .output()
                .expect("bash runs");
            assert!(
                out.status.success(),
                "README.md:{}: `{command}` failed ({})\n--- stdout\n{}\n--- stderr\n{}",
                block.line,
                out.status,
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr),
            );
        }
        println!(
            "README.md:{}: {} command(s), {:.1} s",
            block.line,
            block.commands.len(),
            t0.elapsed().as_secs_f64()
        );
    }
    println!(
        "{} example blocks in {:.1} s",
        blocks.len(),
        start.elapsed().as_secs_f64()
    );
}

/// The Markdown files whose links are checked: README.md and every `.md` under `docs/`.
fn markdown_files(repo: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut files = vec![repo.join("README.md")];
    walk(&repo.join("docs"), &mut files);
    files.sort();
    files
}

/// The targets of the inline links and images of a Markdown text, outside code blocks and
/// code spans.
fn link_targets(markdown: &str) -> Vec<String> {
    let mut targets = Vec::new();
    let mut in_fence = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            continue;
        }
        if in_fence {
            continue;
        }
        // Code spans are not links: drop every other backtick-delimited piece.
        let prose: String = line
            .split('`')
            .enumerate()
            .filter(|(i, _)| i % 2 == 0)
            .map(|(_, s)| s)
            .collect::<Vec<_>>()
            .join(" ");
        let mut rest = prose.as_str();
        while let Some(at) = rest.find("](") {
            let after = &rest[at + 2..];
            match after.find(')') {
                Some(end) => {
                    targets.push(after[..end].trim().to_string());
                    rest = &after[end..];
                }
                None => break,
            }
        }
    }
    targets
}

/// GitHub's anchor of a heading: lower case, spaces to `-`, punctuation but `-` and `_` dropped.
fn anchor(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// The anchors of a Markdown file's headings.
fn anchors(markdown: &str) -> Vec<String> {
    let mut in_fence = false;
    let mut out = Vec::new();
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        } else if !in_fence && line.starts_with('#') {
            out.push(anchor(line.trim_start_matches('#')));
        }
    }
    out
}

/// Every relative link of README.md and docs/ names an existing file, and its `#anchor`, if
/// any, a heading of that file.
#[test]
fn the_readme_and_docs_links_resolve() {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut broken = Vec::new();
    for file in markdown_files(repo) {
        let text = std::fs::read_to_string(&file).unwrap();
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (path, fragment) = match target.split_once('#') {
                Some((p, f)) => (p, Some(f)),
                None => (target.as_str(), None),
            };
            let resolved = if path.is_empty() {
                file.clone()
            } else {
                file.parent().unwrap().join(path)
            };
            let shown = file.strip_prefix(repo).unwrap().display().to_string();
            if !resolved.exists() {
                broken.push(format!("{shown}: {target} (no such file)"));
                continue;
            }
            if let Some(fragment) = fragment {
                let heads = if resolved.is_file() {
                    anchors(&std::fs::read_to_string(&resolved).unwrap_or_default())
                } else {
                    Vec::new()
                };
                if !heads.iter().any(|h| h == fragment) {
                    broken.push(format!("{shown}: {target} (no such heading)"));
                }
            }
        }
    }
    assert!(broken.is_empty(), "broken links:\n{}", broken.join("\n"));
}

#[test]
fn example_blocks_join_continued_lines_and_skip_comments() {
    let md = "text\n```sh\nnot run\n```\n```sh example\n# a comment\na \\\n  b\n\nc\n```\n";
    let blocks = example_blocks(md);
    assert_eq!(blocks.len(), 1);
    assert_eq!(blocks[0].line, 5);
    assert_eq!(blocks[0].commands, vec!["a b".to_string(), "c".to_string()]);
}

#[test]
fn anchors_follow_github() {
    assert_eq!(anchor(" The `samplers` command"), "the-samplers-command");
    assert_eq!(anchor("Reading a large bag"), "reading-a-large-bag");
    assert_eq!(anchor("How to add ..."), "how-to-add-");
}
