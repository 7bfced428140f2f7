//! The vitrine's screen as a pure function of a view model: [`render`] draws a [`View`]
//! into a ratatui buffer, so tests render to a plain buffer and read the text back.

use petriplc_runtime::status::{ModuleState, ModuleStatus};
use ratatui::buffer::Buffer;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Cell, Paragraph, Row, Sparkline, Table, Widget};

/// Everything the screen shows, in the order it is laid out.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct View {
    /// The title bar's left part (PLC id, uptime).
    pub title: String,
    /// The title bar's right part: what the last key did, or a warning.
    pub message: String,
    pub points: Vec<PointLine>,
    /// The first point shown (PageUp / PageDown).
    pub scroll: usize,
    /// MatPLC's `show` screen, when the section has `show` rows.
    pub show: Option<ShowScreen>,
    pub graphs: Vec<GraphLine>,
    /// Every module's state and statistics; `None` while the PLC has published none.
    pub modules: Option<Vec<ModuleStatus>>,
    pub nets: Vec<NetLine>,
    /// Key help: (key, what it does).
    pub keys: Vec<(String, String)>,
    /// The last log lines, oldest first.
    pub log: Vec<String>,
}

/// One row of the points table.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointLine {
    pub name: String,
    pub description: String,
    pub value: String,
    /// A bool point's value (drawn highlighted when on); `None` for numbers.
    pub on: Option<bool>,
    pub owner: String,
    pub forced: bool,
}

/// A MatPLC vitrine screen: a background and fields at fixed places.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShowScreen {
    pub background: Vec<String>,
    pub fields: Vec<ShowText>,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShowText {
    pub row: u16,
    pub col: u16,
    pub text: String,
    /// A bool field's value (drawn bold when on).
    pub on: Option<bool>,
}

impl ShowScreen {
    /// The rows the background and fields need.
    pub fn height(&self) -> u16 {
        let fields = self.fields.iter().map(|f| f.row.saturating_add(1));
        let bg = u16::try_from(self.background.len()).unwrap_or(u16::MAX);
        fields.fold(bg, u16::max)
    }
}

/// One graph: the point's last samples, oldest first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GraphLine {
    pub name: String,
    /// The latest value, formatted like the points table.
    pub value: String,
    /// The scale: configured, or the samples' range.
    pub lo: f64,
    pub hi: f64,
    pub samples: Vec<f64>,
}

/// One `petrinet` module's marking.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct NetLine {
    pub module: String,
    /// Every place (label, tokens) in place order.
    pub places: Vec<(String, u64)>,
    /// Shown when there is no marking (yet).
    pub note: String,
}

const TITLE: Style = Style::new()
    .fg(Color::Black)
    .bg(Color::Cyan)
    .add_modifier(Modifier::BOLD);
const HEADER: Style = Style::new().add_modifier(Modifier::BOLD);
const ON: Style = Style::new().fg(Color::Green).add_modifier(Modifier::BOLD);
const FORCED: Style = Style::new().fg(Color::Red).add_modifier(Modifier::BOLD);
const DIM: Style = Style::new().fg(Color::DarkGray);
const KEY: Style = Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD);

/// Draws `view` into `area` of `buf`.
pub fn render(view: &View, area: Rect, buf: &mut Buffer) {
    if area.width < 24 || area.height < 8 {
        Paragraph::new("terminal too small").render(area, buf);
        return;
    }
    let keys = key_lines(view, area.width);
    let log_rows: u16 = match area.height {
        0..=23 => 1,
        24..=33 => 2,
        _ => 4,
    };
    let [title, body, keys_area, log_area] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Min(0),
        Constraint::Length(keys.len() as u16),
        Constraint::Length(log_rows + 1),
    ])
    .areas(area);
    title_bar(view, title, buf);
    Paragraph::new(keys).render(keys_area, buf);
    log_panel(view, log_area, buf);

    let body = match &view.show {
        Some(show) => {
            // The screen gets what it needs, but leaves the panels below a few rows.
            let want = show.height().saturating_add(2);
            let h = want
                .min(body.height.saturating_sub(6))
                .max(3)
                .min(body.height);
            let [top, rest] =
                Layout::vertical([Constraint::Length(h), Constraint::Min(0)]).areas(body);
            show_panel(show, top, buf);
            rest
        }
        None => body,
    };
    if body.height < 3 {
        return;
    }
    let left_w = body.width / 2;
    let [left, right] =
        Layout::horizontal([Constraint::Length(left_w), Constraint::Min(0)]).areas(body);

    let modules_h = match &view.modules {
        Some(m) => m.len() as u16 + 3,
        None => 3,
    };
    let net_lines = net_lines(&view.nets, right.width.saturating_sub(2));
    let nets_h = if view.nets.is_empty() {
        0
    } else {
        net_lines.len() as u16 + 2
    };
    let points_h = view.points.len().saturating_sub(view.scroll) as u16 + 3;
    let graphs_h = if view.graphs.is_empty() {
        0
    } else {
        view.graphs.len() as u16 * 2 + 2
    };
    let spare_left = left.height.saturating_sub(points_h);
    let spare_right = right.height.saturating_sub(modules_h + nets_h);
    let graphs_left = graphs_h > 0 && spare_left > spare_right;

    let mut left_parts = vec![Constraint::Min(3)];
    if graphs_left {
        left_parts.push(Constraint::Length(graphs_h.min(spare_left.max(3))));
    }
    let left_areas = Layout::vertical(left_parts).split(left);
    points_panel(view, left_areas[0], buf);

    let mut right_parts = vec![Constraint::Length(modules_h)];
    if nets_h > 0 {
        right_parts.push(Constraint::Length(nets_h));
    }
    if graphs_h > 0 && !graphs_left {
        right_parts.push(Constraint::Min(3));
    } else {
        right_parts.push(Constraint::Min(0));
    }
    let right_areas = Layout::vertical(right_parts).split(right);
    modules_panel(view, right_areas[0], buf);
    if nets_h > 0 {
        let nets = Paragraph::new(net_lines).block(Block::bordered().title(" nets "));
        nets.render(right_areas[1], buf);
    }
    if graphs_h > 0 {
        let area = if graphs_left {
            left_areas[1]
        } else {
            right_areas[right_areas.len() - 1]
        };
        graphs_panel(view, area, buf);
    }
}

fn title_bar(view: &View, area: Rect, buf: &mut Buffer) {
    buf.set_style(area, TITLE);
    let left = format!(" petriplc vitrine │ {}", view.title);
    buf.set_stringn(area.x, area.y, &left, area.width as usize, TITLE);
    let msg = Span::raw(format!("{} ", view.message));
    let room = area
        .width
        .saturating_sub(Span::raw(&left).width() as u16 + 2);
    let w = (msg.width() as u16).min(room);
    if w > 0 {
        buf.set_stringn(
            area.x + area.width - w,
            area.y,
            msg.content.as_ref(),
            w as usize,
            TITLE,
        );
    }
}

/// The key help, wrapped to the width (two lines at most).
fn key_lines(view: &View, width: u16) -> Vec<Line<'static>> {
    let mut lines: Vec<Line<'static>> = vec![Line::default()];
    let mut used = 0usize;
    for (k, what) in &view.keys {
        let item = k.chars().count() + 1 + what.chars().count();
        let sep = if used == 0 { 1 } else { 2 };
        if used > 0 && used + sep + item > width as usize {
            if lines.len() == 2 {
                break;
            }
            lines.push(Line::default());
            used = 0;
        }
        let line = lines.last_mut().expect("one line at least");
        line.spans
            .push(Span::raw(if used == 0 { " " } else { "  " }));
        line.spans.push(Span::styled(k.clone(), KEY));
        line.spans.push(Span::raw(format!(" {what}")));
        used += sep + item;
    }
    lines
}

fn log_panel(view: &View, area: Rect, buf: &mut Buffer) {
    let block = Block::new()
        .borders(Borders::TOP)
        .title(" log ")
        .border_style(DIM);
    let inner = block.inner(area);
    block.render(area, buf);
    let n = inner.height as usize;
    let lines = view.log.iter().skip(view.log.len().saturating_sub(n));
    for (i, line) in lines.enumerate() {
        buf.set_stringn(
            inner.x,
            inner.y + i as u16,
            line,
            inner.width as usize,
            Style::new(),
        );
    }
}

fn show_panel(show: &ShowScreen, area: Rect, buf: &mut Buffer) {
    let block = Block::bordered().title(" screen ");
    let inner = block.inner(area);
    block.render(area, buf);
    let put = |buf: &mut Buffer, row: u16, col: u16, text: &str, style: Style| {
        if row < inner.height && col < inner.width {
            let room = (inner.width - col) as usize;
            buf.set_stringn(inner.x + col, inner.y + row, text, room, style);
        }
    };
    for (row, line) in show.background.iter().enumerate() {
        put(buf, row as u16, 0, line, Style::new());
    }
    for f in &show.fields {
        let style = match f.on {
            Some(true) => ON,
            _ => Style::new(),
        };
        put(buf, f.row, f.col, &f.text, style);
    }
}

fn points_panel(view: &View, area: Rect, buf: &mut Buffer) {
    let shown = &view.points[view.scroll.min(view.points.len())..];
    let rows_fit = area.height.saturating_sub(3) as usize;
    let title = if view.scroll == 0 && shown.len() <= rows_fit {
        " points ".to_string()
    } else {
        let last = (view.scroll + rows_fit).min(view.points.len());
        format!(
            " points {}–{} of {} (PgUp/PgDn) ",
            view.scroll + 1,
            last,
            view.points.len()
        )
    };
    let width = |f: fn(&PointLine) -> &str, header: &str, cap: usize| {
        let w = view
            .points
            .iter()
            .map(|p| f(p).chars().count())
            .max()
            .unwrap_or(0);
        w.max(header.chars().count()).min(cap) as u16
    };
    // Narrow: the description tells more than the owner.
    let with_owner = area.width >= 50;
    let mut widths = vec![
        Constraint::Length(width(|p| &p.name, "point", 16)),
        Constraint::Length(width(|p| &p.value, "value", 14)),
        Constraint::Length(1),
    ];
    if with_owner {
        widths.push(Constraint::Length(width(|p| &p.owner, "owner", 12)));
    }
    widths.push(Constraint::Min(0));
    let rows = shown.iter().map(|p| {
        let value_style = match (p.forced, p.on) {
            (true, _) => FORCED,
            (false, Some(true)) => ON,
            _ => Style::new(),
        };
        let mut cells = vec![
            Cell::from(p.name.clone()),
            Cell::from(Line::from(p.value.clone()).right_aligned()).style(value_style),
            Cell::from(if p.forced { "F" } else { "" }).style(FORCED),
        ];
        if with_owner {
            cells.push(Cell::from(p.owner.clone()).style(DIM));
        }
        cells.push(Cell::from(p.description.clone()));
        Row::new(cells)
    });
    let mut header = vec![
        Cell::from("point"),
        Cell::from(Line::from("value").right_aligned()),
        Cell::from(""),
    ];
    if with_owner {
        header.push(Cell::from("owner"));
    }
    header.push(Cell::from("description"));
    let header = Row::new(header).style(HEADER);
    Table::new(rows, widths)
        .header(header)
        .column_spacing(1)
        .block(Block::bordered().title(title))
        .render(area, buf);
}

fn modules_panel(view: &View, area: Rect, buf: &mut Buffer) {
    let block = Block::bordered().title(" modules ");
    let Some(modules) = &view.modules else {
        Paragraph::new(Line::styled("waiting for the PLC's status", DIM))
            .block(block)
            .render(area, buf);
        return;
    };
    let name_w = modules
        .iter()
        .map(|m| m.name.chars().count())
        .max()
        .unwrap_or(0)
        .clamp(6, 14) as u16;
    // What fits: lateness, overruns and restarts from 50 columns, the kind from 80.
    let inner = area.width.saturating_sub(2);
    let stats = inner >= name_w + 46;
    let kind = stats && inner >= name_w + 57;
    let state_style = |s: ModuleState| match s {
        ModuleState::Running => Style::new().fg(Color::Green),
        ModuleState::Failed => FORCED,
        ModuleState::Stopped => Style::new().fg(Color::Yellow),
        ModuleState::Starting => DIM,
    };
    let num = |x: f64| format!("{x:.0}");
    let right = |s: String| Cell::from(Line::from(s).right_aligned());
    let rows = modules.iter().map(|m| {
        let mut cells = vec![Cell::from(m.name.clone())];
        if kind {
            cells.push(Cell::from(m.kind.clone()).style(DIM));
        }
        cells.push(Cell::from(m.state.as_str()).style(state_style(m.state)));
        cells.push(right(m.scans.to_string()));
        cells.push(right(format!(
            "{}/{}",
            num(m.cycle_us[1]),
            num(m.cycle_us[2])
        )));
        if stats {
            cells.push(right(num(m.late_us[1])));
            cells.push(right(m.overruns.to_string()));
            cells.push(right(m.restarts.to_string()));
        }
        Row::new(cells)
    });
    let mut header = vec![Cell::from("module")];
    let mut widths = vec![Constraint::Length(name_w)];
    if kind {
        header.push(Cell::from("kind"));
        widths.push(Constraint::Length(10));
    }
    header.extend([
        Cell::from("state"),
        right("scans".into()),
        right("cycle µs".into()),
    ]);
    widths.extend([
        Constraint::Length(7),
        Constraint::Length(8),
        Constraint::Length(10),
    ]);
    if stats {
        header.extend([
            right("late99".into()),
            right("ovr".into()),
            right("rst".into()),
        ]);
        widths.extend([
            Constraint::Length(7),
            Constraint::Length(5),
            Constraint::Length(4),
        ]);
    }
    Table::new(rows, widths)
        .header(Row::new(header).style(HEADER))
        .column_spacing(1)
        .block(block)
        .render(area, buf);
}

/// The nets' markings as lines of at most `width` columns: per net its name, then its
/// places, a marked one as `●label` (`●label×3` for three tokens), an empty one as `○label`.
fn net_lines(nets: &[NetLine], width: u16) -> Vec<Line<'static>> {
    let width = width.max(8) as usize;
    let mut lines = Vec::new();
    for net in nets {
        let mut line = Line::from(Span::styled(format!("{}:", net.module), HEADER));
        let mut used = net.module.chars().count() + 1;
        if net.places.is_empty() {
            line.spans.push(Span::styled(format!(" {}", net.note), DIM));
            lines.push(line);
            continue;
        }
        for (label, tokens) in &net.places {
            let (text, style) = match tokens {
                0 => (format!("○{label}"), DIM),
                1 => (format!("●{label}"), ON),
                n => (format!("●{label}×{n}"), ON),
            };
            let w = text.chars().count();
            if used + 1 + w > width && used > 0 {
                lines.push(std::mem::take(&mut line));
                line.spans.push(Span::raw(" "));
                used = 1;
            } else {
                line.spans.push(Span::raw(" "));
                used += 1;
            }
            line.spans.push(Span::styled(text, style));
            used += w;
        }
        lines.push(line);
    }
    lines
}

fn graphs_panel(view: &View, area: Rect, buf: &mut Buffer) {
    let block = Block::bordered().title(" graphs ");
    let inner = block.inner(area);
    block.render(area, buf);
    if inner.height == 0 || inner.width < 8 {
        return;
    }
    let n = view.graphs.len() as u16;
    let h = (inner.height / n.max(1)).clamp(1, 4);
    let label_w = (inner.width / 3).clamp(6, 24);
    for (i, g) in view.graphs.iter().enumerate() {
        let y = inner.y + i as u16 * h;
        if y + h > inner.y + inner.height {
            break;
        }
        let label = format!("{} {}", g.name, g.value);
        buf.set_stringn(inner.x, y, &label, label_w as usize - 1, HEADER);
        if h >= 2 {
            let scale = format!("{}..{}", short(g.lo), short(g.hi));
            buf.set_stringn(inner.x, y + 1, &scale, label_w as usize - 1, DIM);
        }
        let plot = Rect::new(inner.x + label_w, y, inner.width - label_w, h);
        let levels = u64::from(h) * 8;
        let span = (g.hi - g.lo).max(f64::MIN_POSITIVE);
        let data: Vec<u64> = g
            .samples
            .iter()
            .skip(g.samples.len().saturating_sub(plot.width as usize))
            .map(|&v| {
                let x = ((v - g.lo) / span).clamp(0.0, 1.0);
                // The lowest value still draws the lowest bar, so a flat line is visible.
                1 + (x * (levels - 1) as f64).round() as u64
            })
            .collect();
        Sparkline::default()
            .data(&data)
            .max(levels)
            .style(Style::new().fg(Color::Cyan))
            .render(plot, buf);
    }
}

/// A scale bound in few characters.
fn short(x: f64) -> String {
    if x == x.trunc() && x.abs() < 1e9 {
        format!("{x:.0}")
    } else {
        format!("{x:.3}")
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

/// The buffer's text, one line per row, trailing spaces removed (for tests and tools).
pub fn text(buf: &Buffer) -> String {
    let area = buf.area;
    let mut out = String::new();
    for y in area.top()..area.bottom() {
        let mut line = String::new();
        for x in area.left()..area.right() {
            line.push_str(buf[(x, y)].symbol());
        }
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out
}
