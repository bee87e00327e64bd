//! The user guide's screens never go stale: every capture in `docs/screens/` is made again from
//! its replay script in `docs/scripts/` (on the virtual clock, in UTC, as
//! `mavterm --headless --input SCRIPT --utc --screens DIR` makes it) and compared with the file
//! and with each copy pasted into the pages (README.md, docs/*.md).
//!
//! A page includes a capture as a marker line followed by a text block:
//!
//! ````text
//! <!-- screen: overview -->
//! ```text
//! ...the screen...
//! ```
//! ````
//!
//! `UPDATE_DOCS=1 cargo test --test docs` rewrites the captures and the copies in the pages.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use mavterm::app::AppConfig;
use mavterm::headless::replay::{run_script_on_specs, ReplayOptions};
use mavterm::headless::script::Script;
use mavterm::link::LinkSpec;

const REFRESH: &str = "UPDATE_DOCS=1 cargo test --test docs";
const MARKER: &str = "<!-- screen: ";

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn updating() -> bool {
    std::env::var_os("UPDATE_DOCS").is_some_and(|v| !v.is_empty() && v != "0")
}

fn sorted_files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == ext))
        .collect();
    files.sort();
    files
}

/// Every capture made by every script: name -> (screen text, script it came from).
fn captures() -> BTreeMap<String, (String, PathBuf)> {
    let mut all = BTreeMap::new();
    let scripts = sorted_files(&root().join("docs/scripts"), "txt");
    assert!(!scripts.is_empty(), "no scripts in docs/scripts");
    for path in scripts {
        let script = Script::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let specs: Vec<LinkSpec> = script
            .links
            .iter()
            .map(|(line, spec)| {
                spec.parse()
                    .unwrap_or_else(|e| panic!("{}:{line}: bad link {spec}: {e}", path.display()))
            })
            .collect();
        assert!(
            !specs.is_empty(),
            "{}: no `# link SPEC` header",
            path.display()
        );
        let size = script
            .size
            .unwrap_or_else(|| panic!("{}: no `# size WxH` header", path.display()));
        let dir = tempfile::tempdir().unwrap();
        let opts = ReplayOptions {
            size,
            screens_dir: Some(dir.path().to_path_buf()),
            ..ReplayOptions::default()
        };
        // The scripts name files relative to the repository (`wp load tests/data/...`).
        let (outcome, _app) = run_script_on_specs(
            &script,
            &specs,
            AppConfig::default(),
            &opts,
            &mut Vec::new(),
        )
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        assert!(
            outcome.completed,
            "{}: the script did not run to its end (a key quit mavterm?)",
            path.display()
        );
        for name in outcome.snapshots {
            let text = std::fs::read_to_string(dir.path().join(format!("{name}.txt"))).unwrap();
            if let Some((_, other)) = all.insert(name.clone(), (text, path.clone())) {
                panic!(
                    "snapshot `{name}` is made by both {} and {}: names must be unique",
                    other.display(),
                    path.display()
                );
            }
        }
    }
    all
}

/// The pages that may paste captures.
fn pages() -> Vec<PathBuf> {
    let mut pages = vec![root().join("README.md")];
    pages.extend(sorted_files(&root().join("docs"), "md"));
    pages
}

/// One pasted capture: its name, the line of its marker and the byte range of its text.
struct Paste {
    name: String,
    line: usize,
    range: std::ops::Range<usize>,
}

/// Find the `<!-- screen: NAME -->` markers of a page and the text blocks that follow them.
fn pastes(page: &Path, text: &str) -> Vec<Paste> {
    let mut out = Vec::new();
    let mut offset = 0;
    let lines: Vec<&str> = text.split_inclusive('\n').collect();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i];
        offset += l.len();
        i += 1;
        let Some(rest) = l.trim_end().strip_prefix(MARKER) else {
            continue;
        };
        let marker_line = i;
        let name = rest
            .strip_suffix("-->")
            .unwrap_or_else(|| panic!("{}:{i}: marker without `-->`", page.display()))
            .trim()
            .to_string();
        assert!(
            lines.get(i).is_some_and(|l| l.trim_end() == "```text"),
            "{}:{i}: `{MARKER}{name} -->` must be followed by a ```text line",
            page.display()
        );
        offset += lines[i].len();
        i += 1;
        let start = offset;
        while i < lines.len() && lines[i].trim_end() != "```" {
            offset += lines[i].len();
            i += 1;
        }
        assert!(
            i < lines.len(),
            "{}: the text block of `{name}` is not closed",
            page.display()
        );
        out.push(Paste {
            name,
            line: marker_line,
            range: start..offset,
        });
    }
    out
}

/// A capture as pasted into a page: its lines, each followed by a newline.
fn as_pasted(screen: &str) -> String {
    let mut s = screen.to_string();
    if !s.ends_with('\n') {
        s.push('\n');
    }
    s
}

/// The first line that differs, for the failure message.
fn first_difference(want: &str, got: &str) -> String {
    for (n, (a, b)) in want.lines().zip(got.lines()).enumerate() {
        if a != b {
            return format!("line {}:\n  now:  {a:?}\n  file: {b:?}", n + 1);
        }
    }
    format!(
        "{} lines now, {} in the file",
        want.lines().count(),
        got.lines().count()
    )
}

#[test]
fn captures_and_pages_match_their_scripts() {
    let caps = captures();
    let update = updating();
    let mut stale = Vec::new();

    let screens = root().join("docs/screens");
    std::fs::create_dir_all(&screens).unwrap();
    for (name, (text, script)) in &caps {
        let path = screens.join(format!("{name}.txt"));
        let old = std::fs::read_to_string(&path).unwrap_or_default();
        if old != *text {
            if update {
                std::fs::write(&path, text).unwrap();
            } else {
                stale.push(format!(
                    "docs/screens/{name}.txt is not what {} makes now ({})",
                    script.strip_prefix(root()).unwrap_or(script).display(),
                    first_difference(text, &old)
                ));
            }
        }
    }
    for path in sorted_files(&screens, "txt") {
        let name = path.file_stem().unwrap().to_string_lossy().to_string();
        if !caps.contains_key(&name) {
            stale.push(format!(
                "docs/screens/{name}.txt is made by no script in docs/scripts (remove it)"
            ));
        }
    }

    let mut used = std::collections::BTreeSet::new();
    for page in pages() {
        let rel = page.strip_prefix(root()).unwrap().display().to_string();
        let text = std::fs::read_to_string(&page).unwrap();
        let mut new = String::new();
        let mut last = 0;
        for p in pastes(&page, &text) {
            let Some((screen, _)) = caps.get(&p.name) else {
                stale.push(format!(
                    "{rel}:{}: `{}` is no capture made by docs/scripts",
                    p.line, p.name
                ));
                continue;
            };
            used.insert(p.name.clone());
            let want = as_pasted(screen);
            if text[p.range.clone()] != want {
                stale.push(format!(
                    "{rel}:{}: the copy of `{}` differs from its script's screen ({})",
                    p.line,
                    p.name,
                    first_difference(&want, &text[p.range.clone()])
                ));
            }
            new.push_str(&text[last..p.range.start]);
            new.push_str(&want);
            last = p.range.end;
        }
        new.push_str(&text[last..]);
        if update && new != text {
            std::fs::write(&page, new).unwrap();
        }
    }
    for name in caps.keys() {
        if !used.contains(name) {
            stale.push(format!(
                "docs/screens/{name}.txt is pasted into no page (add `{MARKER}{name} -->` and a text block)"
            ));
        }
    }

    if update {
        stale.retain(|s| !s.contains("differs") && !s.contains("is not what"));
    }
    assert!(
        stale.is_empty(),
        "the user guide's screens are stale:\n  {}\nrefresh them with `{REFRESH}` and review the diff",
        stale.join("\n  ")
    );
}

/// The anchor a Markdown heading line gets (as GitHub makes it): lower case, spaces as `-`,
/// other punctuation dropped.
fn heading_anchor(line: &str) -> Option<String> {
    let title = line
        .strip_prefix('#')?
        .trim_start_matches('#')
        .strip_prefix(' ')?;
    Some(
        title
            .trim()
            .to_lowercase()
            .chars()
            .filter_map(|c| match c {
                ' ' => Some('-'),
                c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
                _ => None,
            })
            .collect(),
    )
}

/// Every relative link of the pages names a file that exists, and a heading of it when it has
/// an anchor.
#[test]
fn every_page_link_resolves() {
    for page in pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        let dir = page.parent().unwrap();
        for (n, line) in text.lines().enumerate() {
            let mut rest = line;
            while let Some(i) = rest.find("](") {
                rest = &rest[i + 2..];
                let Some(end) = rest.find(')') else { break };
                let target = &rest[..end];
                rest = &rest[end..];
                if target.contains("://") {
                    continue;
                }
                let (file, anchor) = target.split_once('#').unwrap_or((target, ""));
                let path = if file.is_empty() {
                    page.clone()
                } else {
                    dir.join(file)
                };
                assert!(
                    path.exists(),
                    "{}:{}: link to {target}, which does not exist",
                    page.display(),
                    n + 1
                );
                if !anchor.is_empty() {
                    let heads = std::fs::read_to_string(&path).unwrap();
                    assert!(
                        heads
                            .lines()
                            .any(|l| heading_anchor(l).as_deref() == Some(anchor)),
                        "{}:{}: link to {target}: {} has no heading with that anchor",
                        page.display(),
                        n + 1,
                        path.display()
                    );
                }
            }
        }
    }
}

/// The command replay.md gives makes the same screens as the test: `mavterm --headless --input
/// SCRIPT --utc --screens DIR` (with no config, keymap or cached metadata of the machine's).
#[test]
fn the_binary_makes_the_same_captures() {
    let caps = captures();
    let home = tempfile::tempdir().unwrap();
    let out = tempfile::tempdir().unwrap();
    for script in sorted_files(&root().join("docs/scripts"), "txt") {
        let status = std::process::Command::new(env!("CARGO_BIN_EXE_mavterm"))
            .current_dir(root())
            .env("HOME", home.path())
            .env("XDG_CONFIG_HOME", home.path().join("config"))
            .env("XDG_DATA_HOME", home.path().join("data"))
            .env("XDG_CACHE_HOME", home.path().join("cache"))
            .arg("--headless")
            .arg("--input")
            .arg(&script)
            .arg("--utc")
            .arg("--screens")
            .arg(out.path())
            .output()
            .unwrap();
        assert!(
            status.status.success(),
            "{}: {}",
            script.display(),
            String::from_utf8_lossy(&status.stderr)
        );
    }
    for (name, (text, script)) in &caps {
        let got = std::fs::read_to_string(out.path().join(format!("{name}.txt")))
            .unwrap_or_else(|e| panic!("{name}.txt from {}: {e}", script.display()));
        assert!(
            got == *text,
            "mavterm --headless --input {} --utc makes another `{name}` than the test ({})",
            script.display(),
            first_difference(text, &got)
        );
    }
}
