//! A trace as an SVG timing diagram: one labelled step-plot lane per observed plant output,
//! input, output and place, stacked from top to bottom, over a shared time axis.
//!
//! Only plotters' SVG backend is used, with its built-in text size estimate: text becomes SVG
//! `<text>` elements, so no font files are needed to draw and the viewer picks the font.

use std::path::Path;

use plotters::prelude::*;

use crate::trace::Trace;
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
}

const WIDTH: u32 = 1000;
const LANE_HEIGHT: u32 = 28;
const TOP: u32 = 12;
const AXIS_HEIGHT: u32 = 45;

const INPUT: RGBColor = RGBColor(31, 119, 180);
const OUTPUT: RGBColor = RGBColor(214, 39, 40);
const PLACE: RGBColor = RGBColor(44, 140, 44);
const PLANT: RGBColor = RGBColor(148, 103, 189);
const SHADE: RGBColor = RGBColor(243, 243, 243);

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
    /// (time in seconds, value), one point per change.
    steps: Vec<(f64, i64)>,
}

impl Lane {
    fn new(
        name: &str,
        color: RGBColor,
        ty: SignalType,
        values: impl Iterator<Item = (f64, i64)>,
    ) -> Self {
        let mut steps: Vec<(f64, i64)> = Vec::new();
        for (t, v) in values {
            let v = if ty == SignalType::Bool {
                i64::from(v != 0)
            } else {
                v
            };
            if steps.last().is_none_or(|&(_, last)| last != v) {
                steps.push((t, v));
            }
        }
        let (min, max) = steps
            .iter()
            .fold((0, 0), |(lo, hi), &(_, v)| (lo.min(v), hi.max(v)));
        let (scale, label) = match ty {
            SignalType::Bool => (Scale::Bool, name.to_string()),
            SignalType::Int => (Scale::Int { min, max }, format!("{name} [{min}..{max}]")),
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

fn lanes(trace: &Trace) -> Vec<Lane> {
    let secs = |r: &crate::trace::TraceRow| r.time.as_secs_f64();
    let mut lanes = Vec::new();
    // The process first: what the plant does, then what the controller reads and writes.
    for (j, name) in trace.plant.iter().enumerate() {
        let values = trace.rows.iter().map(|r| (secs(r), r.plant[j]));
        let max = trace.rows.iter().map(|r| r.plant[j]).max().unwrap_or(0);
        let min = trace.rows.iter().map(|r| r.plant[j]).min().unwrap_or(0);
        // An output that only ever is 0 or 1 reads best as a boolean lane.
        let ty = if min >= 0 && max <= 1 {
            SignalType::Bool
        } else {
            SignalType::Int
        };
        lanes.push(Lane::new(&format!("plant:{name}"), PLANT, ty, values));
    }
    for (j, (name, ty)) in trace.inputs.iter().zip(&trace.input_types).enumerate() {
        lanes.push(Lane::new(
            name,
            INPUT,
            *ty,
            trace.rows.iter().map(|r| (secs(r), r.inputs[j])),
        ));
    }
    for (j, (name, ty)) in trace.outputs.iter().zip(&trace.output_types).enumerate() {
        lanes.push(Lane::new(
            name,
            OUTPUT,
            *ty,
            trace.rows.iter().map(|r| (secs(r), r.outputs[j])),
        ));
    }
    for (j, name) in trace.places.iter().enumerate() {
        let max = trace.rows.iter().map(|r| r.marking[j]).max().unwrap_or(0);
        // A safe place reads best as a boolean lane; others show their token count's range.
        let ty = if max <= 1 {
            SignalType::Bool
        } else {
            SignalType::Int
        };
        let values = trace
            .rows
            .iter()
            .map(|r| (secs(r), i64::from(r.marking[j])));
        lanes.push(Lane::new(&format!("m:{name}"), PLACE, ty, values));
    }
    lanes
}

/// The trace as an SVG document.
pub fn render_svg(trace: &Trace) -> Result<String, PlotError> {
    let lanes = lanes(trace);
    let n = lanes.len().max(1);
    let height = TOP + AXIS_HEIGHT + LANE_HEIGHT * n as u32;
    let end = trace.end.as_secs_f64();
    let end = if end > 0.0 { end } else { 1.0 };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, height)).into_drawing_area();
        draw(&root, &lanes, n, end).map_err(|e| PlotError::Draw(e.to_string()))?;
        root.present().map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    Ok(svg)
}

fn draw(
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    lanes: &[Lane],
    n: usize,
    end: f64,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    // Room for the longest label at about 7.5 px a character (13 px sans-serif), within reason.
    let longest = lanes
        .iter()
        .map(|l| l.label.chars().count())
        .max()
        .unwrap_or(0);
    let label_width = (longest as u32 * 15 / 2 + 24).clamp(100, 400);
    let (label_area, plot_area) = root.split_horizontally(label_width);
    let mut chart = ChartBuilder::on(&plot_area)
        .margin_top(TOP)
        .margin_right(20)
        .x_label_area_size(AXIS_HEIGHT)
        .build_cartesian_2d(0f64..end, 0f64..n as f64)?;
    // Shade every other lane first, so the grid stays visible on top of it.
    for i in (0..lanes.len()).step_by(2) {
        let base = (n - 1 - i) as f64;
        chart.draw_series(std::iter::once(Rectangle::new(
            [(0.0, base), (end, base + 1.0)],
            SHADE.filled(),
        )))?;
    }
    chart
        .configure_mesh()
        .disable_y_mesh()
        .disable_y_axis()
        .x_desc("time (s)")
        .x_label_formatter(&|x| trim_number(*x))
        .max_light_lines(1)
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;

    let label_font = ("sans-serif", 13).into_font();
    for (i, lane) in lanes.iter().enumerate() {
        let base = (n - 1 - i) as f64;
        let y = |v: i64| base + 0.15 + 0.7 * lane.fraction(v);
        let mut points = Vec::with_capacity(lane.steps.len() * 2 + 1);
        for (k, &(t, v)) in lane.steps.iter().enumerate() {
            if k > 0 {
                points.push((t, y(lane.steps[k - 1].1)));
            }
            points.push((t, y(v)));
        }
        if let Some(&(_, v)) = lane.steps.last() {
            points.push((end, y(v)));
        }
        chart.draw_series(LineSeries::new(points, lane.color.stroke_width(2)))?;
        let (_, py) = chart.backend_coord(&(0.0, base + 0.5));
        label_area.draw(&Text::new(
            lane.label.clone(),
            (8, py - 7),
            label_font.clone().color(&lane.color),
        ))?;
    }
    Ok(())
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

/// Draws the trace to an SVG file.
pub fn write_svg(trace: &Trace, path: impl AsRef<Path>) -> Result<(), PlotError> {
    let path = path.as_ref();
    let svg = render_svg(trace)?;
    std::fs::write(path, svg).map_err(|source| PlotError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::trace::TraceRow;
    use quick_xml::events::Event;
    use quick_xml::Reader;
    use std::time::Duration;

    /// What an SVG holds, read by an XML parser: its root element, the texts and the number of
    /// lane lines (the only polylines drawn 2 px wide).
    struct Svg {
        root: String,
        texts: Vec<String>,
        polylines: usize,
    }

    fn parse(svg: &str) -> Svg {
        let mut reader = Reader::from_str(svg);
        let mut out = Svg {
            root: String::new(),
            texts: Vec::new(),
            polylines: 0,
        };
        let mut depth = 0usize;
        // Text arrives in pieces around entity references; a piece ends at the next tag.
        let mut text = String::new();
        loop {
            let event = reader
                .read_event()
                .unwrap_or_else(|e| panic!("invalid XML: {e}\n{svg}"));
            match &event {
                Event::Text(t) => {
                    text.push_str(&t.xml10_content());
                    continue;
                }
                Event::GeneralRef(r) => {
                    text.push_str(match r.xml10_content().as_ref() {
                        "amp" => "&",
                        "lt" => "<",
                        "gt" => ">",
                        "quot" => "\"",
                        _ => "'",
                    });
                    continue;
                }
                _ => {}
            }
            if !text.trim().is_empty() {
                out.texts.push(text.trim().to_string());
            }
            text.clear();
            match event {
                Event::Start(e) => {
                    if depth == 0 {
                        out.root = e.name().as_ref().to_string();
                    }
                    depth += 1;
                }
                Event::End(_) => depth -= 1,
                Event::Empty(e) if e.name().as_ref() == "polyline" => {
                    let wide = e
                        .attributes()
                        .flatten()
                        .any(|a| a.key.as_ref() == "stroke-width" && a.value == "2");
                    out.polylines += usize::from(wide);
                }
                Event::Eof => break,
                _ => {}
            }
        }
        assert_eq!(depth, 0, "unbalanced elements");
        out
    }

    fn trace() -> Trace {
        let row = |ms: u64, inputs: &[i64], outputs: &[i64], marking: &[u32]| TraceRow {
            time: Duration::from_millis(ms),
            inputs: inputs.to_vec(),
            outputs: outputs.to_vec(),
            marking: marking.to_vec(),
            fired: vec![],
            plant: vec![],
        };
        Trace {
            inputs: vec!["START".into(), "SPEED".into()],
            input_types: vec![SignalType::Bool, SignalType::Int],
            outputs: vec!["L1".into()],
            output_types: vec![SignalType::Bool],
            places: vec!["idle".into(), "buffer".into()],
            plant: vec![],
            rows: vec![
                row(0, &[0, -2], &[0], &[1, 0]),
                row(300, &[1, 5], &[1], &[0, 3]),
                row(700, &[0, 5], &[0], &[1, 1]),
            ],
            end: Duration::from_secs(1),
            scans: 11,
        }
    }

    /// Renders `trace` and compares the lane labels (first texts, top to bottom) and the
    /// number of step lines.
    fn check(trace: &Trace, expect_labels: &[&str]) {
        let svg = parse(&render_svg(trace).unwrap());
        assert_eq!(svg.root, "svg");
        assert_eq!(svg.polylines, expect_labels.len(), "one step line per lane");
        for label in expect_labels {
            assert!(
                svg.texts.iter().any(|t| t == label),
                "no label {label:?} in {:?}",
                svg.texts
            );
        }
        assert!(svg.texts.iter().any(|t| t == "time (s)"));
    }

    #[test]
    fn draws_a_labelled_lane_per_signal_and_place() {
        check(
            &trace(),
            &["START", "SPEED [-2..5]", "L1", "m:idle", "m:buffer [0..3]"],
        );
    }

    #[test]
    fn draws_the_plant_first() {
        let mut t = trace();
        t.plant = vec!["alpha".into(), "E_fall".into()];
        for (r, v) in t.rows.iter_mut().zip([[0, 0], [4500, 0], [9000, 1]]) {
            r.plant = v.to_vec();
        }
        check(
            &t,
            &[
                "plant:alpha [0..9000]",
                "plant:E_fall",
                "START",
                "SPEED [-2..5]",
                "L1",
                "m:idle",
                "m:buffer [0..3]",
            ],
        );
        let svg = parse(&render_svg(&t).unwrap());
        let first = svg.texts.iter().position(|x| x.starts_with("plant:alpha"));
        let start = svg.texts.iter().position(|x| x == "START");
        assert!(first < start, "plant lanes come first: {:?}", svg.texts);
    }

    #[test]
    fn draws_degenerate_traces() {
        check(&Trace::default(), &[]);
        let mut t = trace();
        t.rows.truncate(1);
        t.end = Duration::ZERO;
        t.places = vec!["a<b&c".into(), "buffer".into()];
        check(&t, &["START", "SPEED [-2..0]", "L1", "m:a<b&c", "m:buffer"]);
    }

    #[test]
    fn writes_a_file() {
        let dir = std::env::temp_dir().join(format!("petriplc-sim-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("trace.svg");
        write_svg(&trace(), &path).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text, render_svg(&trace()).unwrap());
        std::fs::remove_dir_all(&dir).unwrap();
        let e = write_svg(&trace(), dir.join("missing/trace.svg")).unwrap_err();
        assert!(
            e.to_string().starts_with("cannot write the plot to "),
            "{e}"
        );
    }

    #[test]
    fn axis_numbers_are_trimmed() {
        assert_eq!(trim_number(0.30000000000000004), "0.3");
        assert_eq!(trim_number(2.0), "2");
        assert_eq!(trim_number(-0.0), "0");
    }
}
