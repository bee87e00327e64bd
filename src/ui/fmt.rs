//! Text, numbers and durations that fit a column. Text too wide is cut and ends with `…`
//! ([`fit`], the one place text is cut, by display width); numbers are exact when they fit,
//! abbreviated (`24.9k`, `1.2M`) when they do not, never cut: any value fits a column of 4 or
//! more characters. Lists longer than their pane say so ([`list_more`]), and table columns share
//! a width so that text columns get what the fixed ones leave ([`share`]).

use std::borrow::Cow;

use unicode_width::{UnicodeWidthChar, UnicodeWidthStr};

/// Columns `s` takes on a terminal.
pub fn width(s: &str) -> usize {
    UnicodeWidthStr::width(s)
}

/// `s` in at most `width` terminal columns: as it is if it fits, else cut and ending with `…`
/// (which takes one column), so a cut always shows. Wide characters are never split.
pub fn fit(s: &str, width: usize) -> Cow<'_, str> {
    if UnicodeWidthStr::width(s) <= width {
        return Cow::Borrowed(s);
    }
    if width == 0 {
        return Cow::Borrowed("");
    }
    let mut out = String::with_capacity(width + 2);
    let mut used = 0;
    for c in s.chars() {
        let w = c.width().unwrap_or(0);
        if used + w > width - 1 {
            break;
        }
        used += w;
        out.push(c);
    }
    out.push('…');
    Cow::Owned(out)
}

/// `text` in lines of at most `width` columns, broken at spaces; a word wider than a line
/// follows on the line it starts on and is broken where each line ends.
pub fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(1);
    let mut lines = vec![String::new()];
    let mut used = 0;
    for word in text.split(' ') {
        let ww = self::width(word);
        let line = lines.last_mut().expect("never empty");
        if used > 0 && used + 1 + ww <= width {
            line.push(' ');
            line.push_str(word);
            used += 1 + ww;
            continue;
        }
        if used > 0 && ww <= width {
            // The word fits a line of its own: it starts the next.
            lines.push(String::new());
            used = 0;
        } else if used > 0 && used < width {
            // Longer than any line: it follows on this one and breaks where it ends.
            line.push(' ');
            used += 1;
        }
        for c in word.chars() {
            let cw = c.width().unwrap_or(0);
            if used + cw > width {
                lines.push(String::new());
                used = 0;
            }
            lines.last_mut().expect("never empty").push(c);
            used += cw;
        }
    }
    lines
}

/// What a list shows of its rows when not all fit: `6 of 12, ↓ 6 more`, with `↑ 3 more` when
/// rows are hidden above too. `None` when every row is shown.
pub fn list_more(first_shown: usize, shown: usize, total: usize) -> Option<String> {
    let shown = shown.min(total.saturating_sub(first_shown));
    if shown >= total {
        return None;
    }
    let below = total - first_shown - shown;
    let mut s = format!("{shown} of {total}");
    if first_shown > 0 {
        s.push_str(&format!(", ↑ {first_shown} more"));
    }
    if below > 0 {
        s.push_str(&format!(", ↓ {below} more"));
    }
    Some(s)
}

/// The first row to show of a list of `total` rows in a window `visible` rows high so that row
/// `sel` is on screen: the window starts at the top, and the selection goes down to its last row
/// before the list scrolls with it.
pub fn scroll_offset(sel: usize, visible: usize, total: usize) -> usize {
    let visible = visible.max(1);
    sel.min(total.saturating_sub(1))
        .saturating_sub(visible - 1)
        .min(total.saturating_sub(visible))
}

/// The first row to show of a list of `total` rows in a window `visible` rows high that keeps
/// row `sel` in the middle (as the Parameters and Inspector lists do), the window never past
/// the end.
pub fn centred_offset(sel: usize, visible: usize, total: usize) -> usize {
    sel.saturating_sub(visible / 2)
        .min(total.saturating_sub(visible))
}

/// The widths a ratatui `Table` gives columns of `constraints` in `width` columns with
/// `spacing` between them (its default layout), so cells can be fitted to them beforehand:
/// a `Table` clips text silently.
pub fn table_widths(
    constraints: &[ratatui::layout::Constraint],
    width: u16,
    spacing: u16,
) -> Vec<usize> {
    use ratatui::layout::{Flex, Layout, Rect};
    Layout::horizontal(constraints.iter().copied())
        .flex(Flex::Start)
        .spacing(spacing)
        .split(Rect::new(0, 0, width, 1))
        .iter()
        .map(|r| r.width as usize)
        .collect()
}

/// A table column: the width it needs at least, the width that shows all of its text, and
/// whether it takes what is left once every column has its full width.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Col {
    pub min: usize,
    pub want: usize,
    pub fill: bool,
}

impl Col {
    /// A column that is always `w` wide.
    pub fn fixed(w: usize) -> Self {
        Col {
            min: w,
            want: w,
            fill: false,
        }
    }

    /// A text column as wide as the widest of `texts`, and at least `min` of that.
    pub fn text<'a>(min: usize, texts: impl IntoIterator<Item = &'a str>) -> Self {
        let want = texts.into_iter().map(width).max().unwrap_or(0);
        Col {
            min: min.min(want),
            want,
            fill: false,
        }
    }

    /// Also take what is left over.
    pub fn fill(self) -> Self {
        Col { fill: true, ..self }
    }
}

/// Widths of `cols` in `total` columns with `spacing` between them: every column its `min`,
/// then what is left to the columns short of their `want`, in order of `priority` (indices;
/// columns not listed come last, left to right), then what is still left to the `fill` columns,
/// shared evenly. When even the minimums do not fit, the last columns get less (down to 0): the
/// caller fits its text to the widths returned, so any cut shows.
pub fn share(cols: &[Col], total: usize, spacing: usize, priority: &[usize]) -> Vec<usize> {
    let n = cols.len();
    let mut left = total.saturating_sub(spacing * n.saturating_sub(1));
    let mut w = vec![0; n];
    for (i, c) in cols.iter().enumerate() {
        w[i] = c.min.min(left);
        left -= w[i];
    }
    let order: Vec<usize> = priority
        .iter()
        .copied()
        .filter(|&i| i < n)
        .chain((0..n).filter(|i| !priority.contains(i)))
        .collect();
    for i in order {
        let more = cols[i].want.saturating_sub(w[i]).min(left);
        w[i] += more;
        left -= more;
    }
    let fills: Vec<usize> = (0..n).filter(|&i| cols[i].fill).collect();
    if !fills.is_empty() {
        let each = left / fills.len();
        let mut extra = left % fills.len();
        for i in fills {
            w[i] += each + usize::from(extra > 0);
            extra = extra.saturating_sub(1);
        }
    }
    w
}

/// Decimal multipliers and their suffixes.
const UNITS: [(f64, char); 6] = [
    (1e3, 'k'),
    (1e6, 'M'),
    (1e9, 'G'),
    (1e12, 'T'),
    (1e15, 'P'),
    (1e18, 'E'),
];

/// A count in at most `width` characters: all its digits if they fit, else abbreviated.
pub fn count(n: u64, width: usize) -> String {
    let s = n.to_string();
    if s.len() <= width {
        s
    } else {
        abbreviate(n as f64, width)
    }
}

/// A size in bytes, short: `512 B`, `12.3 kB`, `123 kB`, `1.2 MB` (decimal units, as `ls -h
/// --si`).
pub fn size(bytes: u64) -> String {
    if bytes < 1000 {
        return format!("{bytes} B");
    }
    let mut x = bytes as f64;
    for unit in ["kB", "MB", "GB", "TB", "PB"] {
        x /= 1000.0;
        // One decimal below 100 (rounded to 100.0: none), as long as it stays under 1000.
        if format!("{x:.1}").len() <= 4 {
            return format!("{x:.1} {unit}");
        }
        if x < 999.5 {
            return format!("{x:.0} {unit}");
        }
    }
    format!("{:.0} EB", x / 1000.0)
}

/// A non-negative real (a rate) with `decimals` decimals if that fits in `width`, else with
/// none, else abbreviated. Negative and non-finite values show as 0.
pub fn real(x: f64, decimals: usize, width: usize) -> String {
    let x = if x.is_finite() && x > 0.0 { x } else { 0.0 };
    let s = format!("{x:.decimals$}");
    if s.len() <= width {
        return s;
    }
    let s = format!("{x:.0}");
    if s.len() <= width {
        return s;
    }
    abbreviate(x, width)
}

/// `x` as a mantissa of 1 to 999 and a unit suffix, with one decimal if that fits in `width`
/// (`24.9k`), else none (`25k`). Below 4 characters some values cannot fit at all: those are
/// cut with `…`, so the cut at least shows.
fn abbreviate(x: f64, width: usize) -> String {
    let mut shortest = None;
    for (unit, suffix) in UNITS {
        for decimals in [1, 0] {
            let digits = format!("{:.decimals$}", x / unit);
            // A mantissa that rounds to 1000 belongs to the next unit; below 1, to the previous.
            let rounded: f64 = digits.parse().unwrap_or(f64::INFINITY);
            if !(1.0..1000.0).contains(&rounded) {
                continue;
            }
            let s = format!("{digits}{suffix}");
            if s.chars().count() <= width {
                return s;
            }
            shortest = Some(s);
        }
    }
    fit(&shortest.unwrap_or_else(|| format!("{x:.0}")), width).into_owned()
}

/// Whole seconds as a compact duration: `42s`, `10m40s`, `3h07m`, `2d05h`.
pub fn duration(secs: u64) -> String {
    let (m, h, d) = (secs / 60, secs / 3600, secs / 86_400);
    if secs < 60 {
        format!("{secs}s")
    } else if secs < 3600 {
        format!("{m}m{:02}s", secs % 60)
    } else if secs < 86_400 {
        format!("{h}h{:02}m", m % 60)
    } else {
        format!("{d}d{:02}h", h % 24)
    }
}

/// A selected row's highlight carried to the edge: `spans` padded with `style` to `width`.
pub fn pad_row(
    spans: &mut Vec<ratatui::text::Span<'static>>,
    width: usize,
    style: ratatui::style::Style,
) {
    let so_far: usize = spans.iter().map(|s| self::width(&s.content)).sum();
    if so_far < width {
        spans.push(ratatui::text::Span::styled(
            " ".repeat(width - so_far),
            style,
        ));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_in_decimal_units() {
        let cases = [
            (0, "0 B"),
            (999, "999 B"),
            (1000, "1.0 kB"),
            (12_345, "12.3 kB"),
            (99_949, "99.9 kB"),
            (99_950, "100 kB"),
            (999_499, "999 kB"),
            (999_500, "1.0 MB"),
            (1_234_567_890, "1.2 GB"),
        ];
        for (n, want) in cases {
            assert_eq!(size(n), want, "{n}");
        }
    }

    #[test]
    fn counts_are_exact_when_they_fit() {
        assert_eq!(count(0, 4), "0");
        assert_eq!(count(9999, 4), "9999");
        assert_eq!(count(24_874, 5), "24874");
        assert_eq!(count(999_999, 6), "999999");
    }

    #[test]
    fn counts_that_do_not_fit_are_abbreviated_never_cut() {
        assert_eq!(count(24_874, 4), "25k");
        assert_eq!(count(24_874, 3), "25k");
        assert_eq!(count(123_456, 5), "123k");
        assert_eq!(count(123_456, 4), "123k");
        assert_eq!(count(999_499, 5), "999k");
        // Rounds up to the next unit rather than showing 1000k.
        assert_eq!(count(999_950, 5), "1.0M");
        assert_eq!(count(1_234_567, 5), "1.2M");
        assert_eq!(count(1_234_567, 4), "1.2M");
        assert_eq!(count(12_345_678, 5), "12.3M");
        assert_eq!(count(12_345_678, 4), "12M");
        assert_eq!(count(u64::MAX, 5), "18.4E");
        assert_eq!(count(u64::MAX, 4), "18E");
        // Every value fits 4 columns without a cut.
        for e in 0..19 {
            for n in [10u64.pow(e), 10u64.pow(e) * 5 - 1, 10u64.pow(e) * 10 - 1] {
                let s = count(n, 4);
                assert!(s.chars().count() <= 4 && !s.contains('…'), "{n}: {s}");
            }
        }
        // Too narrow for some values: the cut shows.
        assert_eq!(count(123_456, 3), "12…");
    }

    #[test]
    fn reals_drop_decimals_before_abbreviating() {
        assert_eq!(real(6.66, 1, 4), "6.7");
        assert_eq!(real(99.94, 1, 4), "99.9");
        assert_eq!(real(99.96, 1, 4), "100");
        assert_eq!(real(4894.0, 0, 5), "4894");
        assert_eq!(real(12_345.0, 0, 5), "12345");
        assert_eq!(real(12_345.0, 0, 4), "12k");
        assert_eq!(real(1_000_006.7, 1, 4), "1.0M");
        assert_eq!(real(f64::NAN, 1, 4), "0.0");
        assert_eq!(real(-3.0, 0, 4), "0");
    }

    #[test]
    fn fit_cuts_by_display_width_and_shows_the_cut() {
        assert_eq!(fit("QUADROTOR", 9), "QUADROTOR");
        assert_eq!(fit("QUADROTOR", 7), "QUADRO…");
        assert_eq!(fit("QUADROTOR", 1), "…");
        assert_eq!(fit("QUADROTOR", 0), "");
        // Wide characters take two columns and are never split.
        assert_eq!(fit("高度計", 6), "高度計");
        assert_eq!(fit("高度計", 5), "高度…");
        assert_eq!(fit("高度計", 4), "高…");
        assert_eq!(width(&fit("高度計", 4)), 3);
        assert!(matches!(fit("up", 10), Cow::Borrowed(_)));
    }

    #[test]
    fn list_more_counts_what_is_hidden_above_and_below() {
        assert_eq!(list_more(0, 6, 12).as_deref(), Some("6 of 12, ↓ 6 more"));
        assert_eq!(
            list_more(3, 6, 12).as_deref(),
            Some("6 of 12, ↑ 3 more, ↓ 3 more")
        );
        assert_eq!(list_more(6, 6, 12).as_deref(), Some("6 of 12, ↑ 6 more"));
        // A window taller than what is left shows only what is left.
        assert_eq!(list_more(8, 6, 12).as_deref(), Some("4 of 12, ↑ 8 more"));
        assert_eq!(list_more(0, 12, 12), None);
        assert_eq!(list_more(0, 20, 3), None);
        assert_eq!(list_more(0, 0, 0), None);
    }

    #[test]
    fn scrolling_keeps_the_selection_in_the_window() {
        // 12 rows, 5 shown: the window moves once the selection passes its last row.
        assert_eq!(scroll_offset(0, 5, 12), 0);
        assert_eq!(scroll_offset(4, 5, 12), 0);
        assert_eq!(scroll_offset(5, 5, 12), 1);
        assert_eq!(scroll_offset(11, 5, 12), 7);
        assert_eq!(scroll_offset(30, 5, 12), 7);
        assert_eq!(scroll_offset(3, 0, 12), 3);
        assert_eq!(scroll_offset(0, 5, 0), 0);
        // Centred, never past the end.
        assert_eq!(centred_offset(0, 5, 12), 0);
        assert_eq!(centred_offset(6, 5, 12), 4);
        assert_eq!(centred_offset(11, 5, 12), 7);
        assert_eq!(centred_offset(2, 20, 12), 0);
    }

    #[test]
    fn wrap_breaks_at_spaces_and_long_words_where_lines_end() {
        assert_eq!(
            wrap("down: Connection refused (os error 111)", 17),
            ["down: Connection", "refused (os error", "111)"]
        );
        assert_eq!(wrap("a  b", 10), ["a  b"]);
        assert_eq!(
            wrap("» 4 serial:/dev/ttyACM0", 12),
            ["» 4 serial:/", "dev/ttyACM0"]
        );
        for line in wrap("x 0123456789abcdef y", 4) {
            assert!(width(&line) <= 4, "{line}");
        }
    }

    #[test]
    fn share_gives_minimums_then_wants_in_priority_then_fills() {
        let cols = [
            Col::fixed(3),
            Col::text(4, ["QUADROTOR"]),
            Col::text(4, ["STABILIZE"]),
            Col::text(0, ["CLASH!"]).fill(),
        ];
        // Room for everything: the rest goes to the fill column.
        assert_eq!(share(&cols, 40, 1, &[]), [3, 9, 9, 16]);
        // Short: minimums, then column 2 before column 1.
        assert_eq!(share(&cols, 20, 1, &[2, 1]), [3, 5, 9, 0]);
        assert_eq!(share(&cols, 20, 1, &[]), [3, 9, 5, 0]);
        // Not even the minimums: the last columns get less.
        assert_eq!(share(&cols, 8, 1, &[]), [3, 2, 0, 0]);
        // A text column wants no more than its widest text.
        assert_eq!(Col::text(11, ["sim"]).min, 3);
    }

    #[test]
    fn durations() {
        assert_eq!(duration(0), "0s");
        assert_eq!(duration(59), "59s");
        assert_eq!(duration(60), "1m00s");
        assert_eq!(duration(640), "10m40s");
        assert_eq!(duration(3599), "59m59s");
        assert_eq!(duration(3600 + 7 * 60 + 5), "1h07m");
        assert_eq!(duration(2 * 86_400 + 5 * 3600), "2d05h");
    }
}
