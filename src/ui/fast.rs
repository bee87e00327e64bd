//! Drawing straight into a [`Buffer`] for the panes redrawn every frame (the Overview's
//! Vehicles, Links and Messages): the very cells (symbols and styles) ratatui's `Table`,
//! `Paragraph` and `Block` draw for what those panes use of them, without their cost per cell
//! (a bounds-checked index, grapheme segmentation and a width lookup for every character, a
//! style set over every cell of every area). Text of printable ASCII is written cell by cell from
//! one index per row; any other text goes through ratatui's own rendering, so wide and
//! zero-width characters come out exactly as before.
//!
//! Styles are patched onto cells (`Cell::set_style`), in the order ratatui applies them: a
//! table row's style over the row, then each cell's text style on the characters drawn, then the
//! selection's highlight over the row.

use ratatui::buffer::Buffer;
use ratatui::layout::{Constraint, Flex, Layout, Rect};
use ratatui::style::Style;
use ratatui::symbols::border;
use ratatui::text::{Line, Span, Text};
use ratatui::widgets::{Block, BorderType, Borders, Paragraph, Widget};

/// Characters other than printable ASCII drawn straight: each its own grapheme (none of them
/// joins a neighbour into a cluster) one column wide, as ratatui measures them.
const SIMPLE: [char; 8] = ['…', '»', '└', '·', '↓', '↑', '─', '━'];

/// Whether every character of `s` is printable ASCII or one of [`SIMPLE`]: one cell each, as
/// its own grapheme. The count of those cells, if so.
fn plain(s: &str) -> Option<usize> {
    if s.bytes().all(|b| (b' '..=b'~').contains(&b)) {
        return Some(s.len());
    }
    let mut n = 0;
    for c in s.chars() {
        if !(' '..='~').contains(&c) && !SIMPLE.contains(&c) {
            return None;
        }
        n += 1;
    }
    Some(n)
}

/// Index into `buf.content` of `(x, y)`, inside `buf.area`.
fn index(buf: &Buffer, x: u16, y: u16) -> usize {
    (y - buf.area.y) as usize * buf.area.width as usize + (x - buf.area.x) as usize
}

/// Patch `style` onto every cell of `area` (what `Buffer::set_style` does).
pub fn patch(buf: &mut Buffer, area: Rect, style: Style) {
    if style == Style::default() {
        return;
    }
    let area = buf.area.intersection(area);
    if area.is_empty() {
        return;
    }
    for y in area.top()..area.bottom() {
        let i = index(buf, area.x, y);
        for c in &mut buf.content[i..i + area.width as usize] {
            c.set_style(style);
        }
    }
}

/// Write `s`, [`plain`] text of `n` characters, from `(x, y)` (inside the buffer) in at most
/// `max` cells, each cell's style patched with `style`. Returns the cells written.
fn put(buf: &mut Buffer, x: u16, y: u16, max: u16, (s, n): (&str, usize), style: Style) -> u16 {
    let n = n.min(max as usize);
    let i = index(buf, x, y);
    let cells = &mut buf.content[i..i + n];
    let patch = style != Style::default();
    if s.len() == n || s.is_ascii() {
        for (c, b) in cells.iter_mut().zip(s.bytes()) {
            c.set_char(b as char);
            if patch {
                c.set_style(style);
            }
        }
    } else {
        for (c, ch) in cells.iter_mut().zip(s.chars()) {
            c.set_char(ch);
            if patch {
                c.set_style(style);
            }
        }
    }
    n as u16
}

/// `s` in the first row of `area` as a ratatui `Line` of one `Span` styled `style` (a table
/// cell made from a `Span`, a block's title): cut at the area's right edge.
pub fn span(buf: &mut Buffer, area: Rect, s: &str, style: Style) {
    let clip = area.intersection(buf.area);
    if clip.is_empty() {
        return;
    }
    if let Some(n) = plain(s) {
        put(buf, clip.x, clip.y, clip.width, (s, n), style);
    } else {
        Line::from(Span::styled(s, style)).render(area, buf);
    }
}

/// `s` in the first row of `area` as ratatui renders a table cell made from a string
/// (`Text::raw`).
pub fn raw(buf: &mut Buffer, area: Rect, s: &str) {
    if plain(s).is_some() {
        span(buf, area, s, Style::default());
    } else {
        Text::raw(s).render(Rect { height: 1, ..area }, buf);
    }
}

/// `spans` as one line of a `Paragraph` (left-aligned, not wrapped) in the first row of `area`:
/// cut at the area's right edge.
pub fn line(buf: &mut Buffer, area: Rect, spans: &[(&str, Style)]) {
    let area = Rect { height: 1, ..area }.intersection(buf.area);
    if area.is_empty() {
        return;
    }
    if spans.iter().all(|(s, _)| plain(s).is_some()) {
        let (mut x, end) = (area.x, area.right());
        for (s, style) in spans {
            if x >= end {
                break;
            }
            let n = plain(s).unwrap_or(0);
            x += put(buf, x, area.y, end - x, (s, n), *style);
        }
    } else {
        let line = Line::from(
            spans
                .iter()
                .map(|(s, style)| Span::styled(*s, *style))
                .collect::<Vec<_>>(),
        );
        Paragraph::new(line).render(area, buf);
    }
}

/// `l` as one line of a `Paragraph` (left-aligned, not wrapped) in the first row of `area`.
pub fn paragraph_line(buf: &mut Buffer, area: Rect, l: &Line) {
    if l.alignment
        .is_some_and(|a| a != ratatui::layout::Alignment::Left)
    {
        Paragraph::new(l.clone()).render(Rect { height: 1, ..area }.intersection(buf.area), buf);
        return;
    }
    let spans: Vec<(&str, Style)> = l
        .spans
        .iter()
        .map(|s| (s.content.as_ref(), l.style.patch(s.style)))
        .collect();
    line(buf, area, &spans);
}

/// A table drawn as ratatui's `Table` draws one of one-line rows with a one-line header, no
/// highlight symbol and `Flex::Start` columns of the given constraints: the header, then the
/// visible rows with their cells, row by row.
pub struct Table {
    area: Rect,
    /// Each column's x (relative to the table) and width.
    cols: Vec<(u16, u16)>,
}

impl Table {
    /// A table in `area` with columns of `widths`, `spacing` apart.
    pub fn new(area: Rect, widths: &[Constraint], spacing: u16) -> Self {
        Table {
            area,
            cols: columns(area.width, widths, spacing),
        }
    }

    /// Whether the table draws anything at all.
    pub fn is_empty(&self) -> bool {
        self.area.is_empty()
    }

    /// Rows of the area below the header.
    fn rows_height(&self) -> u16 {
        self.area.height.saturating_sub(1)
    }

    /// The header row: `style` over it, then the cells' text.
    pub fn header<'a>(
        &self,
        buf: &mut Buffer,
        style: Style,
        cells: impl IntoIterator<Item = &'a str>,
    ) {
        if self.is_empty() {
            return;
        }
        let y = self.area.y;
        patch(
            buf,
            Rect {
                height: 1,
                ..self.area
            },
            style,
        );
        for (col, s) in (0..self.cols.len()).zip(cells) {
            raw(buf, self.cell_area(y, col), s);
        }
    }

    /// The first row shown and the row after the last, of `len` rows from `offset` with row
    /// `selected` in view (`TableState`'s offset after rendering is the first).
    pub fn visible(&self, offset: usize, selected: Option<usize>, len: usize) -> (usize, usize) {
        if len == 0 {
            return (offset, offset);
        }
        let h = self.rows_height() as usize;
        let last = len - 1;
        let mut start = offset.min(last);
        if let Some(s) = selected {
            start = start.min(s);
        }
        let mut end = start;
        let mut height = 0;
        while end < len && height < h {
            height += 1;
            end += 1;
        }
        if let Some(s) = selected {
            let s = s.min(last);
            while s >= end {
                height += 1;
                end += 1;
                while height > h {
                    height -= 1;
                    start += 1;
                }
            }
        }
        if height < h && end < len {
            end += 1;
        }
        (start, end)
    }

    /// The screen row of the `k`th row shown.
    pub fn row_y(&self, k: usize) -> u16 {
        self.area.y + 1 + k as u16
    }

    /// The whole row at `y`.
    pub fn row_area(&self, y: u16) -> Rect {
        Rect {
            y,
            height: 1,
            ..self.area
        }
    }

    /// Patch `style` over the row at `y` (a row's style before its cells, the highlight after).
    pub fn patch_row(&self, buf: &mut Buffer, y: u16, style: Style) {
        patch(buf, self.row_area(y), style);
    }

    /// The area of column `col` in the row at `y` (empty past the last column).
    pub fn cell_area(&self, y: u16, col: usize) -> Rect {
        let (x, width) = self.cols.get(col).copied().unwrap_or((0, 0));
        Rect::new(self.area.x + x, y, width, 1)
    }

    /// A cell made from a string, in column `col` of the row at `y`.
    pub fn raw(&self, buf: &mut Buffer, y: u16, col: usize, s: &str) {
        if col < self.cols.len() {
            raw(buf, self.cell_area(y, col), s);
        }
    }

    /// A cell made from a `Span` styled `style`, in column `col` of the row at `y`.
    pub fn span(&self, buf: &mut Buffer, y: u16, col: usize, s: &str, style: Style) {
        if col < self.cols.len() {
            span(buf, self.cell_area(y, col), s, style);
        }
    }
}

/// Each column's x and width, as `Table::get_column_widths` lays them out with no selection
/// column: columns of fixed lengths that all fit simply follow each other; anything else is
/// left to ratatui's layout.
fn columns(width: u16, widths: &[Constraint], spacing: u16) -> Vec<(u16, u16)> {
    let lengths: Option<Vec<u16>> = widths
        .iter()
        .map(|c| match c {
            Constraint::Length(n) => Some(*n),
            _ => None,
        })
        .collect();
    if let Some(lengths) = lengths {
        let gaps = lengths.len().saturating_sub(1) * spacing as usize;
        if lengths.iter().map(|&n| n as usize).sum::<usize>() + gaps <= width as usize {
            let mut x = 0;
            return lengths
                .into_iter()
                .map(|n| {
                    let col = (x, n);
                    x += n + spacing;
                    col
                })
                .collect();
        }
    }
    let [_, area] = Layout::horizontal([Constraint::Length(0), Constraint::Fill(0)])
        .areas(Rect::new(0, 0, width, 1));
    Layout::horizontal(widths.iter().copied())
        .flex(Flex::Start)
        .spacing(spacing)
        .split(area)
        .iter()
        .map(|r| (r.x, r.width))
        .collect()
}

/// A pane's bordered block (all borders, plain or thick), its title at the top left styled like
/// its border, and an unstyled one at the bottom left: what ratatui's `Block` draws, without
/// setting a style over the whole area.
pub struct PaneBlock {
    pub style: Style,
    pub thick: bool,
    pub title: String,
    pub bottom: Option<String>,
}

impl PaneBlock {
    /// The same block as a ratatui `Block`.
    pub fn block(&self) -> Block<'_> {
        let mut b = Block::default()
            .borders(Borders::ALL)
            .border_style(self.style)
            .border_type(if self.thick {
                BorderType::Thick
            } else {
                BorderType::Plain
            })
            .title(Span::styled(self.title.as_str(), self.style));
        if let Some(t) = &self.bottom {
            b = b.title_bottom(Line::from(t.as_str()));
        }
        b
    }

    /// The area inside the borders (`Block::inner`).
    pub fn inner(&self, area: Rect) -> Rect {
        let mut inner = area;
        inner.x = inner.x.saturating_add(1).min(inner.right());
        inner.width = inner.width.saturating_sub(1);
        inner.y = inner.y.saturating_add(1).min(inner.bottom());
        inner.height = inner.height.saturating_sub(1);
        inner.width = inner.width.saturating_sub(1);
        inner.height = inner.height.saturating_sub(1);
        inner
    }

    pub fn render(&self, buf: &mut Buffer, area: Rect) {
        if area.intersection(buf.area) != area || area.width < 2 || area.height < 2 {
            self.block().render(area, buf);
            return;
        }
        let set = if self.thick {
            border::THICK
        } else {
            border::PLAIN
        };
        let style = self.style;
        let w = area.width as usize;
        let edge = |buf: &mut Buffer, y: u16, first: &str, mid: &str, last: &str| {
            let i = index(buf, area.x, y);
            let row = &mut buf.content[i..i + w];
            row[0].set_symbol(first).set_style(style);
            for c in &mut row[1..w - 1] {
                c.set_symbol(mid).set_style(style);
            }
            row[w - 1].set_symbol(last).set_style(style);
        };
        edge(buf, area.y, set.top_left, set.horizontal_top, set.top_right);
        for y in area.y + 1..area.bottom() - 1 {
            let i = index(buf, area.x, y);
            buf.content[i]
                .set_symbol(set.vertical_left)
                .set_style(style);
            buf.content[i + w - 1]
                .set_symbol(set.vertical_right)
                .set_style(style);
        }
        let bottom = area.bottom() - 1;
        edge(
            buf,
            bottom,
            set.bottom_left,
            set.horizontal_bottom,
            set.bottom_right,
        );
        let titles = [
            (area.y, self.title.as_str(), style),
            (
                bottom,
                self.bottom.as_deref().unwrap_or(""),
                Style::default(),
            ),
        ];
        for (y, t, style) in titles {
            let tw = plain(t).unwrap_or_else(|| Line::from(Span::styled(t, style)).width());
            let room = area.width - 2;
            let at = Rect::new(area.x + 1, y, (tw.min(room as usize)) as u16, 1);
            span(buf, at, t, style);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::style::{Color, Modifier};
    use ratatui::widgets::{Cell, Row, TableState};

    fn base(w: u16, h: u16) -> Buffer {
        // Something already there, styled, to patch over.
        let mut buf = Buffer::empty(Rect::new(0, 0, w, h));
        for (i, c) in buf.content.iter_mut().enumerate() {
            c.set_char(char::from(b'a' + (i % 26) as u8));
            if i % 3 == 0 {
                c.set_style(
                    Style::default()
                        .fg(Color::Green)
                        .add_modifier(Modifier::ITALIC),
                );
            }
        }
        buf
    }

    #[test]
    fn table_draws_what_ratatuis_table_draws() {
        let widths = [
            Constraint::Length(1),
            Constraint::Length(6),
            Constraint::Length(9),
            Constraint::Length(30),
        ];
        let texts = [
            ("1:1", "ARMED", "café ok"),
            ("2:1", "dis", "日本語日本語日本語 wide text that is long"),
            ("3:1", "ARMED", "plain text longer than its column for sure"),
            ("4:1", "", "tab\there"),
            ("5:1", "x", ""),
            ("6:1", "AR…", "   └ 1:1 » ·↓↑─━ and then some more"),
        ];
        let row_style = |i: usize| match i % 3 {
            0 => Style::default(),
            1 => Style::default().add_modifier(Modifier::DIM),
            _ => Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        };
        let cell_style = Style::default()
            .fg(Color::Yellow)
            .remove_modifier(Modifier::BOLD);
        let header_style = Style::default()
            .fg(Color::Cyan)
            .add_modifier(Modifier::UNDERLINED);
        let highlight = Style::default().add_modifier(Modifier::REVERSED);
        for (w, h, offset, sel) in [(50, 4, 0, 2), (40, 7, 1, 4), (12, 3, 0, 0), (60, 1, 0, 1)] {
            let area = Rect::new(1, 1, w, h);
            let mut want = base(w + 2, h + 2);
            let rows: Vec<Row> = texts
                .iter()
                .enumerate()
                .map(|(i, t)| {
                    Row::new(vec![
                        Cell::from(if i == sel { ">" } else { " " }),
                        Cell::from(t.0),
                        Cell::from(Span::styled(t.1, cell_style)),
                        Cell::from(t.2.to_string()),
                    ])
                    .style(row_style(i))
                })
                .collect();
            let table = ratatui::widgets::Table::new(rows, widths)
                .header(Row::new(vec!["", "ID", "ARMED", "TEXT"]).style(header_style))
                .column_spacing(1)
                .row_highlight_style(highlight);
            let mut state = TableState::default()
                .with_offset(offset)
                .with_selected(Some(sel));
            ratatui::widgets::StatefulWidget::render(table, area, &mut want, &mut state);

            let mut got = base(w + 2, h + 2);
            let t = Table::new(area, &widths, 1);
            t.header(&mut got, header_style, ["", "ID", "ARMED", "TEXT"]);
            let (start, end) = t.visible(offset, Some(sel), texts.len());
            assert_eq!(start, state.offset());
            for (k, i) in (start..end).enumerate() {
                let y = t.row_y(k);
                t.patch_row(&mut got, y, row_style(i));
                t.raw(&mut got, y, 0, if i == sel { ">" } else { " " });
                t.raw(&mut got, y, 1, texts[i].0);
                t.span(&mut got, y, 2, texts[i].1, cell_style);
                t.raw(&mut got, y, 3, texts[i].2);
                if i == sel {
                    t.patch_row(&mut got, y, highlight);
                }
            }
            assert_eq!(got, want, "{w}x{h}");
            // Styles are compared cell by cell too (Buffer equality does).
            if h > 1 {
                let sel_y = t.row_y(sel - start);
                assert!(got[(1, sel_y)].modifier.contains(Modifier::REVERSED));
                assert_eq!(got[(3, 1)].fg, Color::Cyan);
            }
        }
    }

    #[test]
    fn columns_are_where_ratatuis_layout_puts_them() {
        let layout = |width: u16, widths: &[Constraint], spacing: u16| -> Vec<(u16, u16)> {
            let [_, area] = Layout::horizontal([Constraint::Length(0), Constraint::Fill(0)])
                .areas(Rect::new(0, 0, width, 1));
            Layout::horizontal(widths.iter().copied())
                .flex(Flex::Start)
                .spacing(spacing)
                .split(area)
                .iter()
                .map(|r| (r.x, r.width))
                .collect()
        };
        let sets: [&[u16]; 6] = [
            &[1, 3, 8, 12, 5, 7, 4, 11, 20],
            &[16, 10, 5, 6, 7, 6, 4, 7, 5, 4, 5],
            &[0, 4, 0, 9],
            &[30],
            &[],
            &[2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2],
        ];
        for set in sets {
            let widths: Vec<Constraint> = set.iter().map(|&n| Constraint::Length(n)).collect();
            for spacing in [0, 1, 2, 3] {
                for width in 0..140 {
                    assert_eq!(
                        columns(width, &widths, spacing),
                        layout(width, &widths, spacing),
                        "{set:?} spacing {spacing} width {width}"
                    );
                }
            }
        }
    }

    #[test]
    fn lines_draw_what_a_paragraph_draws() {
        let dim = Style::default().fg(Color::DarkGray);
        let red = Style::default().fg(Color::Red).add_modifier(Modifier::BOLD);
        let cases: [&[(&str, Style)]; 5] = [
            &[
                ("12:00:01", dim),
                (" ", Style::default()),
                ("WARN  ", red),
                (" ", Style::default()),
                ("text to cut at the edge of the area", red),
            ],
            &[
                ("12:00:01", dim),
                (" ", Style::default()),
                ("温度 high café", red),
            ],
            &[
                ("tab\there", dim),
                ("日本語日本語日本語日本語日本語日本語", red),
            ],
            &[("", dim)],
            &[("» 1 tcp:5760 ·", dim), (" ↓ └ ─━ ↑ cut…", red), ("…", red)],
        ];
        for spans in cases {
            for w in [5u16, 20, 40, 80] {
                let area = Rect::new(2, 1, w, 1);
                let mut want = base(w + 4, 3);
                let line = Line::from(
                    spans
                        .iter()
                        .map(|(s, st)| Span::styled(*s, *st))
                        .collect::<Vec<_>>(),
                );
                Paragraph::new(line).render(area, &mut want);
                let mut got = base(w + 4, 3);
                super::line(&mut got, area, spans);
                assert_eq!(got, want);
            }
        }
    }

    #[test]
    fn pane_blocks_draw_what_a_block_draws() {
        let style = Style::default()
            .fg(Color::Cyan)
            .add_modifier(Modifier::BOLD);
        for thick in [false, true] {
            for title in [" Vehicles (3) ", " *Links (3) · signing on ", ""] {
                for bottom in [
                    None,
                    Some(" 5 of 12, ↓ 7 more ".to_string()),
                    Some(" 1 of 2 ".into()),
                ] {
                    for (w, h) in [(30u16, 5u16), (8, 2), (1, 4), (4, 1), (12, 3)] {
                        let pb = PaneBlock {
                            style,
                            thick,
                            title: title.to_string(),
                            bottom: bottom.clone(),
                        };
                        let area = Rect::new(1, 1, w, h);
                        let mut want = base(w + 2, h + 2);
                        pb.block().render(area, &mut want);
                        let mut got = base(w + 2, h + 2);
                        pb.render(&mut got, area);
                        assert_eq!(got, want, "{w}x{h} {title:?} {bottom:?}");
                        assert_eq!(pb.inner(area), pb.block().inner(area));
                    }
                }
            }
        }
    }
}
