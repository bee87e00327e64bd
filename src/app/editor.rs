//! The in-place edit line of the editable tables (the Parameters screen's filter and values, the
//! Inspector's filter and rates): one editor, whatever it edits.
//!
//! The line is the app's edit buffer ([`TextLine`]), opened with the value to edit (or empty),
//! in [`Mode::Edit`]. It takes the line-editing keys and typed characters; `enter` closes it
//! and hands the text typed for a value to the table, which checks it and sends it (its
//! validation: an error goes to the status bar, nothing is sent); esc closes it and nothing is
//! taken. While a filter is typed, the table follows each change and up/down move through what
//! the filter leaves; a value may complete (tab) from the names the table knows for it.

use super::input::TextLine;
use crate::keymap::{Action, Key, KeyCode, Mode};

/// What the line is for: how its keys behave.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) struct EditKind {
    /// A filter (followed as typed, up/down move the selection, `enter` keeps it) rather than
    /// a value (taken at `enter`).
    pub filter: bool,
    /// The table completes a value at tab ([`Edited::Complete`]).
    pub completes: bool,
}

/// What a key did to the line, for the table to carry out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Edited {
    /// `enter`: the line is closed. A value's text is taken out of the line (`Some`); a
    /// filter's stays in place (`None`).
    Submit(Option<String>),
    /// esc: the line is closed; nothing taken.
    Cancel,
    /// up (-1) or down (+1) while filtering.
    Move(isize),
    /// tab on a value of a table that completes.
    Complete,
    /// The text or the cursor changed, or the key did nothing.
    Typed,
}

/// Open the line on `text` (the value to edit, or the filter so far).
pub(super) fn open(line: &mut TextLine, mode: &mut Mode, text: &str) {
    line.set(text);
    *mode = Mode::Edit;
}

/// Open the line empty (a value typed from scratch).
pub(super) fn open_empty(line: &mut TextLine, mode: &mut Mode) {
    line.clear();
    *mode = Mode::Edit;
}

/// A key on the open line (`action`: what the keymap makes of it in edit mode).
pub(super) fn key(
    line: &mut TextLine,
    mode: &mut Mode,
    kind: EditKind,
    key: Key,
    action: Option<Action>,
) -> Edited {
    match action {
        Some(Action::Submit) => {
            *mode = Mode::Normal;
            Edited::Submit((!kind.filter).then(|| line.take()))
        }
        Some(Action::Cancel) => {
            *mode = Mode::Normal;
            Edited::Cancel
        }
        Some(Action::HistoryPrev) if kind.filter => Edited::Move(-1),
        Some(Action::HistoryNext) if kind.filter => Edited::Move(1),
        Some(Action::Complete) if kind.completes && !kind.filter => Edited::Complete,
        Some(a) => {
            line.edit(a);
            Edited::Typed
        }
        None => {
            if let (KeyCode::Char(c), false, false) = (key.code, key.ctrl, key.alt) {
                line.insert(c);
            }
            Edited::Typed
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const VALUE: EditKind = EditKind {
        filter: false,
        completes: true,
    };
    const FILTER: EditKind = EditKind {
        filter: true,
        completes: false,
    };

    fn typed(line: &mut TextLine, mode: &mut Mode, kind: EditKind, text: &str) {
        for c in text.chars() {
            assert_eq!(key(line, mode, kind, Key::ch(c), None), Edited::Typed);
        }
    }

    #[test]
    fn a_value_is_taken_at_enter_and_the_line_closes() {
        let (mut line, mut mode) = (TextLine::default(), Mode::Normal);
        open(&mut line, &mut mode, "1.5");
        assert_eq!(mode, Mode::Edit);
        typed(&mut line, &mut mode, VALUE, "0");
        let k = key(
            &mut line,
            &mut mode,
            VALUE,
            Key::ch('\n'),
            Some(Action::Submit),
        );
        assert_eq!(k, Edited::Submit(Some("1.50".into())));
        assert_eq!(
            (line.text.as_str(), line.cursor, mode),
            ("", 0, Mode::Normal)
        );
    }

    #[test]
    fn a_filter_stays_at_enter_and_esc_takes_nothing() {
        let (mut line, mut mode) = (TextLine::default(), Mode::Normal);
        open_empty(&mut line, &mut mode);
        typed(&mut line, &mut mode, FILTER, "ATC");
        let k = key(
            &mut line,
            &mut mode,
            FILTER,
            Key::ch('\n'),
            Some(Action::Submit),
        );
        assert_eq!((k, line.text.as_str()), (Edited::Submit(None), "ATC"));
        open(&mut line, &mut mode, "x");
        let k = key(
            &mut line,
            &mut mode,
            VALUE,
            Key::ch('\x1b'),
            Some(Action::Cancel),
        );
        assert_eq!((k, mode), (Edited::Cancel, Mode::Normal));
    }

    #[test]
    fn up_down_move_only_a_filter_and_tab_completes_only_a_value() {
        let (mut line, mut mode) = (TextLine::default(), Mode::Edit);
        let up = Some(Action::HistoryPrev);
        assert_eq!(
            key(&mut line, &mut mode, FILTER, Key::ch('k'), up),
            Edited::Move(-1)
        );
        assert_eq!(
            key(&mut line, &mut mode, VALUE, Key::ch('k'), up),
            Edited::Typed
        );
        let tab = Some(Action::Complete);
        assert_eq!(
            key(&mut line, &mut mode, VALUE, Key::ch('\t'), tab),
            Edited::Complete
        );
        let plain = EditKind {
            completes: false,
            ..VALUE
        };
        assert_eq!(
            key(&mut line, &mut mode, plain, Key::ch('\t'), tab),
            Edited::Typed
        );
        // Ctrl or Alt with a letter types nothing.
        let mut ctrl = Key::ch('a');
        ctrl.ctrl = true;
        assert_eq!(key(&mut line, &mut mode, VALUE, ctrl, None), Edited::Typed);
        assert_eq!(line.text, "");
    }
}
