//! A trace as an SVG timing diagram: a title (the net, its scan period, the time window), a
//! legend, then one labelled step-plot lane per observed plant output, input, output and
//! place, stacked from top to bottom over a shared time axis.
//!
//! What is drawn is chosen to be read: the process first (what the plant does that the
//! controller does not read: `plant:NAME`), inputs in the user's order (the trace's), a place's
//! lane left out when it only repeats an output (every SIPN output is its place), and a signal
//! that changes faster than the plot can show drawn as a shaded band instead of a moiré of
//! edges (`--from`/`--to` zoom in). [`PlotOptions`] picks lanes and a window.
//!
//! Only plotters' SVG backend is used, with its built-in text size estimate: text becomes SVG
//! `<text>` elements, so no font files are needed to draw and the viewer picks the font.

use std::path::Path;
use std::time::Duration;

use plotters::prelude::*;

use crate::trace::{Trace, TraceRow};
use petriplc_net::time::format_seconds;
use petriplc_net::SignalType;

/// Why a plot could not be drawn or saved.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("cannot draw the plot: {0}")]
    Draw(String),
    #[error("cannot write the plot to {path}")]
    Io {
        path: String,
        #[source]
        source: std::io::Error,
    },
    #[error("--signals: `{name}` is neither a signal nor a place of this run; give input and output names or m:PLACE, from: {}", known.join(", "))]
    UnknownSignal { name: String, known: Vec<String> },
    #[error(
        "--signals: no name given; give input and output names or m:PLACE, separated by commas"
    )]
    NoSignals,
    #[error("--from {} s is not before --to {} s: the plot's time window is empty", format_seconds(*from), format_seconds(*to))]
    EmptyWindow { from: Duration, to: Duration },
    #[error("--from {} s is not before the end of the run ({} s): nothing to plot; give an earlier --from or a later --until", format_seconds(*from), format_seconds(*end))]
    AfterEnd { from: Duration, end: Duration },
}

impl PlotError {
    /// Whether the error is the user's options (exit code 2) rather than a failure to write.
    pub fn is_bad_input(&self) -> bool {
        !matches!(self, PlotError::Draw(_) | PlotError::Io { .. })
    }
}

/// What a plot shows.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct PlotOptions {
    /// The lanes, in this order: input names (or `in:NAME`), output names, `m:PLACE`,
    /// `plant:NAME`. When absent: every observed plant output, input, output and place, less
    /// the places that repeat an output.
    pub signals: Option<Vec<String>>,
    /// The start of the time window (default 0).
    pub from: Option<Duration>,
    /// The end of the time window (default: the last scan; later is clamped to it).
    pub to: Option<Duration>,
    /// A line in red under the legend: what a partial trace says about itself (`incomplete:
    /// the simulation failed at t=…`).
    pub note: Option<String>,
}

impl PlotOptions {
    /// Checks the options against the trace's columns (before the run: names and the
    /// window's order; [`render_svg`] checks the window against the run's end).
    pub fn check(&self, trace: &Trace) -> Result<(), PlotError> {
        if let (Some(from), Some(to)) = (self.from, self.to) {
            if from >= to {
                return Err(PlotError::EmptyWindow { from, to });
            }
        }
        self.lanes(trace).map(|_| ())
    }

    /// The lanes to draw: their sources and, for an output whose place's lane is left out,
    /// that place's label.
    fn lanes(&self, trace: &Trace) -> Result<Vec<(Source, Option<String>)>, PlotError> {
        let Some(names) = &self.signals else {
            return Ok(default_lanes(trace));
        };
        if names.is_empty() {
            return Err(PlotError::NoSignals);
        }
        names
            .iter()
            .map(|name| {
                resolve(trace, name.trim())
                    .map(|s| (s, None))
                    .ok_or_else(|| PlotError::UnknownSignal {
                        name: name.clone(),
                        known: known_names(trace),
                    })
            })
            .collect()
    }
}

/// Where a lane's values come from: an index into the rows' inputs, outputs, marking or
/// observed plant outputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    Input(usize),
    Output(usize),
    Place(usize),
    Plant(usize),
}

impl Source {
    fn value(self, trace: &Trace, row: &TraceRow) -> i64 {
        let bool_of = |v: i64, ty: SignalType| match ty {
            SignalType::Bool => i64::from(v != 0),
            SignalType::Int => v,
        };
        match self {
            Source::Input(j) => bool_of(row.inputs[j], trace.input_types[j]),
            Source::Output(j) => bool_of(row.outputs[j], trace.output_types[j]),
            Source::Place(j) => i64::from(row.marking[j]),
            Source::Plant(j) => row.plant[j],
        }
    }
}

fn resolve(trace: &Trace, name: &str) -> Option<Source> {
    if let Some(output) = name.strip_prefix("plant:") {
        return trace
            .plant
            .iter()
            .position(|p| p == output)
            .map(Source::Plant);
    }
    if let Some(place) = name.strip_prefix("m:") {
        return trace
            .places
            .iter()
            .position(|p| p == place)
            .map(Source::Place);
    }
    let input = name.strip_prefix("in:").unwrap_or(name);
    if let Some(j) = trace.inputs.iter().position(|n| n == input) {
        return Some(Source::Input(j));
    }
    trace
        .outputs
        .iter()
        .position(|n| n == name)
        .map(Source::Output)
}

fn known_names(trace: &Trace) -> Vec<String> {
    trace
        .inputs
        .iter()
        .chain(&trace.outputs)
        .cloned()
        .chain(trace.places.iter().map(|p| format!("m:{p}")))
        .chain(trace.plant.iter().map(|p| format!("plant:{p}")))
        .collect()
}

/// The process first (every observed plant output), then every input and output, and every
/// place but those that alone drive an output and whose
/// marking equals it at every recorded scan (the output's lane then names the place).
fn default_lanes(trace: &Trace) -> Vec<(Source, Option<String>)> {
    let mut repeated: Vec<Option<usize>> = vec![None; trace.outputs.len()];
    for (k, places) in trace.output_places.iter().enumerate() {
        if let [j] = places[..] {
            let (place, output) = (Source::Place(j), Source::Output(k));
            if trace
                .rows
                .iter()
                .all(|r| place.value(trace, r) == output.value(trace, r))
            {
                repeated[k] = Some(j);
            }
        }
    }
    let plant = (0..trace.plant.len()).map(|j| (Source::Plant(j), None));
    let inputs = (0..trace.inputs.len()).map(|j| (Source::Input(j), None));
    let outputs = repeated
        .iter()
        .enumerate()
        .map(|(k, r)| (Source::Output(k), r.map(|j| trace.places[j].clone())));
    let places = (0..trace.places.len())
        .filter(|j| !repeated.contains(&Some(*j)))
        .map(|j| (Source::Place(j), None));
    plant.chain(inputs).chain(outputs).chain(places).collect()
}

const WIDTH: u32 = 1000;
const LANE_HEIGHT: u32 = 28;
/// Room for the title and, below it, the legend, above the lanes.
const HEADER: u32 = 60;
/// Room for a note under the legend.
const NOTE_HEIGHT: u32 = 22;
const AXIS_HEIGHT: u32 = 45;
/// Edges closer than this (in pixels) cannot be told apart: runs of them become a band.
const MIN_EDGE_GAP: f64 = 3.0;

const INPUT: RGBColor = RGBColor(31, 119, 180);
const OUTPUT: RGBColor = RGBColor(214, 39, 40);
const PLACE: RGBColor = RGBColor(44, 140, 44);
const PLANT: RGBColor = RGBColor(148, 103, 189);
const SHADE: RGBColor = RGBColor(243, 243, 243);
const TEXT: RGBColor = RGBColor(40, 40, 40);
const GREY: RGBColor = RGBColor(120, 120, 120);
const WARNING: RGBColor = RGBColor(192, 0, 0);

/// How a lane scales its values into its height.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scale {
    Bool,
    Int { min: i64, max: i64 },
}

struct Lane {
    label: String,
    color: RGBColor,
    scale: Scale,
    /// (time in seconds, value), one point per change; the first at the window's start.
    steps: Vec<(f64, i64)>,
}

impl Lane {
    fn new(
        label: String,
        color: RGBColor,
        ty: SignalType,
        values: impl Iterator<Item = (f64, i64)>,
    ) -> Self {
        let mut steps: Vec<(f64, i64)> = Vec::new();
        for (t, v) in values {
            if steps.last().is_none_or(|&(_, last)| last != v) {
                steps.push((t, v));
            }
        }
        let (min, max) = steps
            .iter()
            .fold((0, 0), |(lo, hi), &(_, v)| (lo.min(v), hi.max(v)));
        let (scale, label) = match ty {
            SignalType::Bool => (Scale::Bool, label),
            SignalType::Int => (Scale::Int { min, max }, format!("{label} [{min}..{max}]")),
        };
        Lane {
            label,
            color,
            scale,
            steps,
        }
    }

    /// Where `v` sits within the lane, from 0 (bottom) to 1 (top).
    fn fraction(&self, v: i64) -> f64 {
        match self.scale {
            Scale::Bool => v.clamp(0, 1) as f64,
            Scale::Int { min, max } if max > min => (v - min) as f64 / (max - min) as f64,
            Scale::Int { .. } => 0.0,
        }
    }
}

/// The window of the plot in seconds, and the lanes' values within it.
struct View {
    from: f64,
    to: f64,
    lanes: Vec<Lane>,
    /// Some output's lane also stands for a place (`Y = m:P`).
    merged: bool,
}

fn view(trace: &Trace, options: &PlotOptions) -> Result<View, PlotError> {
    let from = options.from.unwrap_or(Duration::ZERO);
    let mut to = options.to.map_or(trace.end, |t| t.min(trace.end));
    if let Some(t) = options.to {
        if from >= t {
            return Err(PlotError::EmptyWindow { from, to: t });
        }
    }
    if from > Duration::ZERO && from >= trace.end {
        return Err(PlotError::AfterEnd {
            from,
            end: trace.end,
        });
    }
    if to <= from {
        // A run of one scan: a window one period (or a second) wide.
        to = from
            + if trace.period.is_zero() {
                Duration::from_secs(1)
            } else {
                trace.period
            };
    }
    // The rows that matter: the last one at or before `from` (the state the window opens
    // with), then every one inside the window.
    let start = trace
        .rows
        .partition_point(|r| r.time <= from)
        .saturating_sub(1);
    let rows: Vec<&TraceRow> = trace.rows[start..]
        .iter()
        .take_while(|r| r.time <= to)
        .collect();
    let (from_s, to_s) = (from.as_secs_f64(), to.as_secs_f64());
    let points = |src: Source| -> Vec<(f64, i64)> {
        rows.iter()
            .map(|r| (r.time.as_secs_f64().max(from_s), src.value(trace, r)))
            .collect()
    };
    let mut lanes = Vec::new();
    let mut merged = false;
    for (src, repeats) in options.lanes(trace)? {
        merged |= repeats.is_some();
        let values = points(src);
        let (label, color, ty) = match src {
            Source::Input(j) => (trace.inputs[j].clone(), INPUT, trace.input_types[j]),
            Source::Output(j) => {
                let label = match repeats {
                    Some(place) => format!("{} = m:{place}", trace.outputs[j]),
                    None => trace.outputs[j].clone(),
                };
                (label, OUTPUT, trace.output_types[j])
            }
            Source::Place(j) => {
                // A safe place reads best as a boolean lane; others show their range.
                let max = values.iter().map(|&(_, v)| v).max().unwrap_or(0);
                let ty = if max <= 1 {
                    SignalType::Bool
                } else {
                    SignalType::Int
                };
                (format!("m:{}", trace.places[j]), PLACE, ty)
            }
            Source::Plant(j) => {
                // An output that only ever is 0 or 1 (over the whole run) reads best as a
                // boolean lane.
                let all = || trace.rows.iter().map(|r| r.plant[j]);
                let ty = if all().min().unwrap_or(0) >= 0 && all().max().unwrap_or(0) <= 1 {
                    SignalType::Bool
                } else {
                    SignalType::Int
                };
                (format!("plant:{}", trace.plant[j]), PLANT, ty)
            }
        };
        lanes.push(Lane::new(label, color, ty, values.into_iter()));
    }
    Ok(View {
        from: from_s,
        to: to_s,
        lanes,
        merged,
    })
}

/// `10 ms`, `1.5 s`: a period for the title.
fn human(d: Duration) -> String {
    let ns = d.as_nanos();
    if ns % 1_000_000 == 0 && ns < 1_000_000_000 {
        format!("{} ms", ns / 1_000_000)
    } else {
        format!("{} s", format_seconds(d))
    }
}

fn title(trace: &Trace, view: &View) -> String {
    let mut t = if trace.net.is_empty() {
        "trace".to_string()
    } else {
        trace.net.clone()
    };
    if !trace.period.is_zero() {
        t.push_str(&format!(" · scan every {}", human(trace.period)));
    }
    t.push_str(&format!(
        " · {} to {} s",
        trim_number(view.from),
        trim_number(view.to)
    ));
    t
}

/// The trace as an SVG document: every lane, over the whole run.
pub fn render_svg(trace: &Trace) -> Result<String, PlotError> {
    render_svg_with(trace, &PlotOptions::default())
}

/// The trace as an SVG document, with the lanes and window of `options`.
pub fn render_svg_with(trace: &Trace, options: &PlotOptions) -> Result<String, PlotError> {
    let view = view(trace, options)?;
    let n = view.lanes.len().max(1);
    let note = options.note.as_deref().map(|n| n.replace('\n', " "));
    let header = HEADER + if note.is_some() { NOTE_HEIGHT } else { 0 };
    let height = header + AXIS_HEIGHT + LANE_HEIGHT * n as u32;
    let title = title(trace, &view);
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        let texts = Header {
            height: header,
            title: &title,
            note: note.as_deref(),
        };
        draw(&root, &view, n, &texts).map_err(|e| PlotError::Draw(e.to_string()))?;
        root.present().map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    Ok(svg)
}

/// A lane's drawing: step lines, and bands where edges come too fast to draw one by one.
#[derive(Debug, Default, PartialEq)]
struct Strokes {
    /// Polylines, in data coordinates (seconds, lane fraction 0..1).
    lines: Vec<Vec<(f64, f64)>>,
    /// Bands: (from, to) in seconds and (low, high) lane fractions.
    bands: Vec<((f64, f64), (f64, f64))>,
}

/// Splits a lane into lines and bands; `px` is the width of one second in pixels.
fn strokes(lane: &Lane, end: f64, px: f64) -> Strokes {
    let mut out = Strokes::default();
    let steps = &lane.steps;
    let Some(&(t0, v0)) = steps.first() else {
        return out;
    };
    let mut line = vec![(t0, lane.fraction(v0))];
    let mut k = 1;
    while k < steps.len() {
        // A run of edges each closer than MIN_EDGE_GAP to the one before.
        let mut last = k;
        while last + 1 < steps.len() && (steps[last + 1].0 - steps[last].0) * px < MIN_EDGE_GAP {
            last += 1;
        }
        // Two close edges (a one-scan pulse) still read as a spike; three or more are a blur.
        let dense = last >= k + 2;
        let before = lane.fraction(steps[k - 1].1);
        if dense {
            let (t_in, t_out) = (steps[k].0, steps[last].0);
            let (lo, hi) = steps[k - 1..=last]
                .iter()
                .map(|&(_, v)| lane.fraction(v))
                .fold((f64::MAX, f64::MIN), |(lo, hi), f| (lo.min(f), hi.max(f)));
            line.push((t_in, before));
            out.lines.push(std::mem::take(&mut line));
            out.bands.push(((t_in, t_out), (lo, hi)));
            line.push((t_out, lane.fraction(steps[last].1)));
            k = last + 1;
        } else {
            let (t, v) = steps[k];
            line.push((t, before));
            line.push((t, lane.fraction(v)));
            k += 1;
        }
    }
    let &(_, v) = steps.last().expect("not empty");
    line.push((end, lane.fraction(v)));
    out.lines.push(line);
    out
}

/// The lane colour lightened towards white, for bands.
fn light(c: RGBColor) -> RGBColor {
    let mix = |x: u8| ((u16::from(x) + 2 * 255) / 3) as u8;
    RGBColor(mix(c.0), mix(c.1), mix(c.2))
}

fn draw(
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    view: &View,
    n: usize,
    texts: &Header<'_>,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let (header, body) = root.split_vertically(texts.height);
    // Room for the longest label at about 6.5 px a character, within reason.
    let longest = view
        .lanes
        .iter()
        .map(|l| l.label.chars().count())
        .max()
        .unwrap_or(0);
    let label_width = (longest as u32 * 13 / 2 + 24).clamp(90, 360);
    let (label_area, plot_area) = body.split_horizontally(label_width);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin_right(20)
        .x_label_area_size(AXIS_HEIGHT)
        .build_cartesian_2d(view.from..view.to, 0f64..n as f64)?;
    let (x0, _) = chart.backend_coord(&(view.from, 0.0));
    let (x1, _) = chart.backend_coord(&(view.to, 0.0));
    let px = f64::from(x1 - x0) / (view.to - view.from);
    let strokes: Vec<Strokes> = view
        .lanes
        .iter()
        .map(|lane| strokes(lane, view.to, px))
        .collect();
    let any_band = strokes.iter().any(|s| !s.bands.is_empty());
    draw_header(&header, view, texts, any_band)?;

    // Shade every other lane first, so the grid stays visible on top of it.
    for i in (0..view.lanes.len()).step_by(2) {
        let base = (n - 1 - i) as f64;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(view.from, base), (view.to, base + 1.0)],
            SHADE.filled(),
        )))?;
    }
    chart
        .configure_mesh()
        .disable_y_mesh()
        .disable_y_axis()
        .x_desc("time (s)")
        .axis_desc_style(("sans-serif", 14))
        .x_label_style(("sans-serif", 13))
        .x_label_formatter(&|x| trim_number(*x))
        .max_light_lines(1)
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;

    let label_font = ("sans-serif", 13).into_font();
    for (i, (lane, s)) in view.lanes.iter().zip(strokes).enumerate() {
        let base = (n - 1 - i) as f64;
        let y = |f: f64| base + 0.15 + 0.7 * f;
        for &((t0, t1), (lo, hi)) in &s.bands {
            chart.draw_series(std::iter::once(Rectangle::new(
                [(t0, y(lo)), (t1, y(hi))],
                light(lane.color).filled(),
            )))?;
            chart.draw_series(std::iter::once(Rectangle::new(
                [(t0, y(lo)), (t1, y(hi))],
                lane.color.stroke_width(1),
            )))?;
        }
        for line in s.lines {
            let points = line.into_iter().map(|(t, f)| (t, y(f)));
            chart.draw_series(LineSeries::new(points, lane.color.stroke_width(2)))?;
        }
        // Backend coordinates are the whole image's; the label area starts below the header.
        let (_, py) = chart.backend_coord(&(view.from, base + 0.5));
        label_area.draw(&Text::new(
            lane.label.clone(),
            (8, py - 7 - HEADER as i32),
            label_font.clone().color(&lane.color),
        ))?;
    }
    Ok(())
}

/// The title, and below it the legend of colours (and of bands, when any).
/// The texts above the lanes, and the room they take.
struct Header<'a> {
    height: u32,
    title: &'a str,
    note: Option<&'a str>,
}

fn draw_header(
    header: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    view: &View,
    texts: &Header<'_>,
    any_band: bool,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    header.draw(&Text::new(
        texts.title.to_string(),
        (8, 10),
        ("sans-serif", 17).into_font().color(&TEXT),
    ))?;
    if let Some(note) = texts.note {
        header.draw(&Text::new(
            note.to_string(),
            (8, HEADER as i32 - 4),
            ("sans-serif", 13).into_font().color(&WARNING),
        ))?;
    }
    let mut legend: Vec<(&str, RGBColor, Swatch)> = Vec::new();
    for (name, color) in [
        ("plant", PLANT),
        ("input", INPUT),
        ("output", OUTPUT),
        ("marking", PLACE),
    ] {
        if view.lanes.iter().any(|l| l.color == color) {
            legend.push((name, color, Swatch::Line));
        }
    }
    if view.merged {
        legend.push(("Y = m:P: output Y is the marking of P", GREY, Swatch::None));
    }
    if any_band {
        legend.push((
            "changes faster than drawn (zoom with --from/--to)",
            GREY,
            Swatch::Band,
        ));
    }
    let legend_font = ("sans-serif", 13).into_font();
    // About 6 px a character at this size, plus the swatch and a gap.
    let widths: Vec<i32> = legend
        .iter()
        .map(|(name, _, swatch)| {
            let room = if *swatch == Swatch::None { 0 } else { 30 };
            room + name.chars().count() as i32 * 6 + 16
        })
        .collect();
    let mut x = 10;
    let y = 40;
    for ((name, color, swatch), w) in legend.iter().zip(widths) {
        let text_x = if *swatch == Swatch::None { x } else { x + 30 };
        if *swatch == Swatch::Band {
            header.draw(&Rectangle::new(
                [(x, y - 5), (x + 22, y + 5)],
                light(*color).filled(),
            ))?;
            header.draw(&Rectangle::new(
                [(x, y - 5), (x + 22, y + 5)],
                color.stroke_width(1),
            ))?;
        } else if *swatch == Swatch::Line {
            header.draw(&PathElement::new(
                vec![(x, y), (x + 22, y)],
                color.stroke_width(2),
            ))?;
        }
        header.draw(&Text::new(
            name.to_string(),
            (text_x, y - 6),
            legend_font.clone().color(&TEXT),
        ))?;
        x += w;
    }
    Ok(())
}

/// What a legend entry shows before its text.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Swatch {
    Line,
    Band,
    None,
}

/// Axis numbers without float noise: `0.3`, not `0.30000000000000004`.
fn trim_number(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

/// Draws the trace to an SVG file, with the lanes and window of `options`.
pub fn write_svg(
    trace: &Trace,
    options: &PlotOptions,
    path: impl AsRef<Path>,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    let svg = render_svg_with(trace, options)?;
    std::fs::write(path, svg).map_err(|source| PlotError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests;
