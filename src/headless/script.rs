//! Replay scripts: what an operator did, as text, one event per line.
//!
//! ```text
//! # comment
//! # link sim://?seed=1          # header: the links to replay on
//! # size 100x30                 # header: the screen size
//! 0.5  key tab
//! 1.2  text "takeoff 10"     # each character as a key
//! 1.5  release up            # a key let go (Fly mode stops at once)
//! 1.8  resize 120x40           # the terminal was resized
//! 2.0  snapshot after-takeoff
//! 30   quit
//! ```
//!
//! The header comments `# link SPEC` (one per link) and `# size WxH` are what `--record` writes;
//! `--headless --input` uses them when no `--link` or `--size` is given on its command line.
//! Times are seconds from the start (decimal, up to microseconds), never decreasing. `#` starts a
//! comment only at the beginning of a line or after whitespace, so `key #` still means the `#`
//! key. The same format is written by the terminal's `--record`, so a session can be replayed.

use std::path::Path;

use crate::clock::{Micros, SECOND};
use crate::keymap::Key;

/// One thing the script does.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Step {
    Key(Key),
    /// A key let go (as a terminal with key-release reports tells): stops a Fly mode nudge.
    Release(Key),
    /// Typed text: each character is a key.
    Text(String),
    /// Render the screen and save it under this name.
    Snapshot(String),
    /// The screen is now this size (width, height): the terminal was resized.
    Resize(u16, u16),
    /// End the replay here.
    Quit,
}

/// A step and when it happens.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Timed {
    pub t: Micros,
    pub step: Step,
    /// 1-based line in the script, for messages.
    pub line: usize,
}

/// A parsed script.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Script {
    pub steps: Vec<Timed>,
    /// `# link SPEC` header lines: (line, spec as written).
    pub links: Vec<(usize, String)>,
    /// `# size WxH` header line.
    pub size: Option<(u16, u16)>,
}

/// Why a script was refused: the line and what is wrong with it.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    #[error("script {path}: {source}")]
    Io {
        path: String,
        source: std::io::Error,
    },
    #[error("script line {line}: {message}")]
    Parse { line: usize, message: String },
}

/// The latest time a script may name: a day. A replay is run to its last event, so a later time
/// is a typo (or a wall-clock time), not a session anyone means to wait for.
pub const MAX_SCRIPT_SECS: Micros = 86_400 * SECOND;

/// Seconds as written in scripts (`1.5`, `30`) to microseconds, exactly (no float rounding).
pub fn parse_secs(s: &str) -> Option<Micros> {
    let (whole, frac) = s.split_once('.').unwrap_or((s, ""));
    if whole.is_empty() && frac.is_empty() {
        return None;
    }
    let digits = |x: &str| x.chars().all(|c| c.is_ascii_digit());
    if !digits(whole) || !digits(frac) || frac.len() > 6 {
        return None;
    }
    let w: Micros = if whole.is_empty() {
        0
    } else {
        whole.parse().ok()?
    };
    let f: Micros = if frac.is_empty() {
        0
    } else {
        format!("{frac:0<6}").parse().ok()?
    };
    w.checked_mul(SECOND)?.checked_add(f)
}

/// Microseconds as script seconds, shortest exact form: `0.52`, `30`.
pub fn format_secs(t: Micros) -> String {
    let (w, f) = (t / SECOND, t % SECOND);
    if f == 0 {
        return w.to_string();
    }
    let frac = format!("{f:06}");
    format!("{w}.{}", frac.trim_end_matches('0'))
}

/// One script line for a key press at `t` (what `--record` writes).
pub fn key_line(t: Micros, key: Key) -> String {
    format!("{} key {key}", format_secs(t))
}

/// Parse `"..."` with `\"` and `\\` escapes; returns the text and what follows.
fn quoted(s: &str) -> Result<(String, &str), String> {
    let mut out = String::new();
    let mut chars = s.char_indices();
    match chars.next() {
        Some((_, '"')) => {}
        _ => return Err("text must be in double quotes, e.g. text \"takeoff 10\"".into()),
    }
    while let Some((i, c)) = chars.next() {
        match c {
            '"' => return Ok((out, &s[i + 1..])),
            '\\' => match chars.next() {
                Some((_, c @ ('"' | '\\'))) => out.push(c),
                Some((_, 'n')) => out.push('\n'),
                _ => return Err("unknown escape in text (use \\\" or \\\\)".into()),
            },
            c => out.push(c),
        }
    }
    Err("unterminated text: missing closing \"".into())
}

/// `WxH` with both at least 1.
pub fn parse_size(s: &str) -> Option<(u16, u16)> {
    let (w, h) = s.split_once(['x', 'X'])?;
    let (w, h): (u16, u16) = (w.parse().ok()?, h.parse().ok()?);
    (w > 0 && h > 0).then_some((w, h))
}

/// A header comment `# link SPEC` or `# size WxH` (one word after the keyword; any other
/// comment is free text): (keyword, value).
fn header(comment: &str) -> Option<(&str, &str)> {
    let rest = comment.strip_prefix('#')?.trim();
    let (keyword, value) = rest.split_once(char::is_whitespace)?;
    let value = value.trim();
    let header = matches!(keyword, "link" | "size") && !value.contains(char::is_whitespace);
    header.then_some((keyword, value))
}

/// Drop a trailing `# comment` that follows whitespace.
fn strip_comment(s: &str) -> &str {
    let mut prev_ws = true;
    for (i, c) in s.char_indices() {
        if c == '#' && prev_ws {
            return &s[..i];
        }
        prev_ws = c.is_whitespace();
    }
    s
}

fn valid_name(name: &str) -> bool {
    !name.is_empty()
        && !name.starts_with('.')
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'))
}

impl Script {
    pub fn load(path: &Path) -> Result<Script, ScriptError> {
        let text = crate::fsio::read_text(path, crate::fsio::MAX_READ).map_err(|source| {
            ScriptError::Io {
                path: path.display().to_string(),
                source,
            }
        })?;
        Script::parse(&text)
    }

    pub fn parse(text: &str) -> Result<Script, ScriptError> {
        let mut steps: Vec<Timed> = Vec::new();
        let mut links = Vec::new();
        let mut size = None;
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let err = |message: String| ScriptError::Parse { line, message };
            let trimmed = raw.trim();
            match header(trimmed) {
                Some(("link", spec)) => links.push((line, spec.to_string())),
                Some((_, wxh)) => {
                    size = Some(parse_size(wxh).ok_or_else(|| {
                        err(format!(
                            "`# size {wxh}`: expected WIDTHxHEIGHT, e.g. 120x40"
                        ))
                    })?);
                }
                None => {}
            }
            if trimmed.is_empty() || trimmed.starts_with('#') {
                continue;
            }
            let (time, rest) = trimmed
                .split_once(char::is_whitespace)
                .ok_or_else(|| err(format!("expected `SECONDS EVENT`, got `{trimmed}`")))?;
            let t = parse_secs(time)
                .ok_or_else(|| err(format!("`{time}` is not a time in seconds (e.g. 1.5)")))?;
            if t > MAX_SCRIPT_SECS {
                return Err(err(format!(
                    "time {time} s is over a day ({} s): times are seconds from the start",
                    MAX_SCRIPT_SECS / SECOND
                )));
            }
            if let Some(prev) = steps.last() {
                if prev.step == Step::Quit {
                    return Err(err(format!("event after `quit` (line {})", prev.line)));
                }
                if t < prev.t {
                    return Err(err(format!(
                        "time {time} is before the previous event's {} (line {})",
                        format_secs(prev.t),
                        prev.line
                    )));
                }
            }
            let rest = rest.trim_start();
            let (verb, arg) = rest.split_once(char::is_whitespace).unwrap_or((rest, ""));
            let step = match verb {
                "text" => {
                    let (s, after) = quoted(arg.trim()).map_err(err)?;
                    if !strip_comment(after).trim().is_empty() {
                        return Err(err(format!("unexpected `{}` after text", after.trim())));
                    }
                    Step::Text(s)
                }
                "key" | "release" => {
                    // The key name is the first word even when it is `#`.
                    let arg = arg.trim();
                    let (name, tail) = arg.split_once(char::is_whitespace).unwrap_or((arg, ""));
                    if !strip_comment(tail).trim().is_empty() {
                        return Err(err(format!("unexpected `{}` after the key", tail.trim())));
                    }
                    if name.is_empty() {
                        return Err(err("`key` needs a key name, e.g. `key tab`".into()));
                    }
                    let k = name.parse().map_err(|e| err(format!("{e}")))?;
                    if verb == "release" {
                        Step::Release(k)
                    } else {
                        Step::Key(k)
                    }
                }
                _ => {
                    let arg = strip_comment(arg).trim();
                    match verb {
                        "snapshot" if valid_name(arg) => Step::Snapshot(arg.to_string()),
                        "snapshot" => {
                            return Err(err(format!(
                                "snapshot name `{arg}`: use letters, digits, `-`, `_`, `.`"
                            )))
                        }
                        "resize" => {
                            let (w, h) = parse_size(arg).ok_or_else(|| {
                                err(format!(
                                    "resize `{arg}`: expected WIDTHxHEIGHT, e.g. 120x40"
                                ))
                            })?;
                            Step::Resize(w, h)
                        }
                        "quit" if arg.is_empty() => Step::Quit,
                        "quit" => return Err(err("`quit` takes no argument".into())),
                        other => {
                            return Err(err(format!(
                            "unknown event `{other}` (key, release, text, snapshot, resize, quit)"
                        )))
                        }
                    }
                }
            };
            steps.push(Timed { t, step, line });
        }
        Ok(Script { steps, links, size })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::keymap::KeyCode;

    #[test]
    fn parses_every_event_kind() {
        let s = Script::parse(
            "# start\n\n0.5 key tab\n1.0 key ctrl-p\n1.2 text \"takeoff 10\"  # typed\n\
             1.3 key enter\n1.4 key #\n2.0 snapshot after-takeoff\n30 quit\n",
        )
        .unwrap();
        let steps: Vec<(Micros, Step)> = s.steps.into_iter().map(|t| (t.t, t.step)).collect();
        assert_eq!(
            steps,
            vec![
                (500_000, Step::Key(Key::plain(KeyCode::Tab))),
                (1_000_000, Step::Key(Key::ctrl('p'))),
                (1_200_000, Step::Text("takeoff 10".into())),
                (1_300_000, Step::Key(Key::plain(KeyCode::Enter))),
                (1_400_000, Step::Key(Key::ch('#'))),
                (2_000_000, Step::Snapshot("after-takeoff".into())),
                (30_000_000, Step::Quit),
            ]
        );
    }

    #[test]
    fn errors_name_the_line() {
        for (text, line, needle) in [
            ("0.5 key tab\n1 key nosuchkey\n", 2, "nosuchkey"),
            ("1 key a\n0.5 key b\n", 2, "before"),
            ("x key a\n", 1, "not a time"),
            ("1 jump\n", 1, "unknown event `jump`"),
            ("1 text takeoff\n", 1, "double quotes"),
            ("1 text \"takeoff\n", 1, "unterminated"),
            ("1 snapshot ../etc\n", 1, "snapshot name"),
            ("1 quit\n2 key a\n", 2, "after `quit`"),
            ("1 key a b\n", 1, "unexpected `b`"),
            ("1 key\n", 1, "needs a key name"),
            ("\n\n1.1234567 key a", 3, "not a time"),
            ("1 key a\n86400.000001 key b\n", 2, "over a day"),
            ("1764345600 quit\n", 1, "over a day (86400 s)"),
            ("1 resize 80\n", 1, "resize `80`"),
            ("1 resize 0x24\n", 1, "resize `0x24`"),
            ("# size big\n1 key a\n", 1, "`# size big`"),
        ] {
            match Script::parse(text) {
                Err(ScriptError::Parse { line: l, message }) => {
                    assert_eq!(l, line, "{text:?}: {message}");
                    assert!(message.contains(needle), "{text:?}: {message}");
                }
                other => panic!("{text:?}: {other:?}"),
            }
        }
    }

    #[test]
    fn header_comments_and_resize() {
        let s = Script::parse(
            "# mavterm 0.1.0 recording\n# link sim://?seed=1\n# link tlog:a.tlog\n\
             # size 100x30\n# size of the screen: a comment, not a header\n\
             1 resize 80x24\n2 snapshot final\n2 quit\n",
        )
        .unwrap();
        assert_eq!(
            s.links,
            vec![
                (2, "sim://?seed=1".to_string()),
                (3, "tlog:a.tlog".to_string())
            ]
        );
        assert_eq!(s.size, Some((100, 30)));
        assert_eq!(s.steps[0].step, Step::Resize(80, 24));
        assert_eq!(s.steps.len(), 3);
    }

    #[test]
    fn seconds_are_exact_and_round_trip() {
        assert_eq!(parse_secs("0.52"), Some(520_000));
        assert_eq!(parse_secs("30"), Some(30 * SECOND));
        assert_eq!(parse_secs(".5"), Some(500_000));
        assert_eq!(parse_secs("1.000001"), Some(1_000_001));
        assert_eq!(parse_secs("-1"), None);
        for t in [0, 1, 520_000, 30 * SECOND, 123_456_789] {
            assert_eq!(parse_secs(&format_secs(t)), Some(t));
        }
        assert_eq!(format_secs(520_000), "0.52");
        assert_eq!(key_line(520_000, Key::plain(KeyCode::Tab)), "0.52 key tab");
    }
}
