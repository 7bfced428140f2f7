//! A trend as an SVG chart: real-valued series over time, each held until its next sample
//! (a logger records changes), on one value axis with a legend — the picture of a control
//! loop settling. Drawn with plotters' SVG backend, as the trace plot is.

use std::path::Path;

use plotters::prelude::*;

use crate::plot::PlotError;

/// One named series: (time in s, value) in time order; NaN samples leave a gap.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    pub name: String,
    pub samples: Vec<(f64, f64)>,
}

const WIDTH: u32 = 1000;
const HEIGHT: u32 = 480;
const COLORS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 140, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// The series as an SVG document, time from 0 to `end` s.
pub fn render_trend_svg(title: &str, series: &[Series], end: f64) -> Result<String, PlotError> {
    let finite = series
        .iter()
        .flat_map(|s| s.samples.iter().map(|p| p.1))
        .filter(|v| v.is_finite());
    let (lo, hi) = finite.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    let (lo, hi) = if lo.is_finite() {
        let pad = ((hi - lo) * 0.05).max(1e-9);
        (lo - pad, hi + pad)
    } else {
        (0.0, 1.0)
    };
    let end = if end > 0.0 { end } else { 1.0 };
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (WIDTH, HEIGHT)).into_drawing_area();
        draw(&root, title, series, end, lo, hi).map_err(|e| PlotError::Draw(e.to_string()))?;
        root.present().map_err(|e| PlotError::Draw(e.to_string()))?;
    }
    Ok(svg)
}

fn draw(
    root: &DrawingArea<SVGBackend<'_>, plotters::coord::Shift>,
    title: &str,
    series: &[Series],
    end: f64,
    lo: f64,
    hi: f64,
) -> Result<(), DrawingAreaErrorKind<std::io::Error>> {
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..end, lo..hi)?;
    chart
        .configure_mesh()
        .x_desc("time (s)")
        .light_line_style(RGBColor(235, 235, 235))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;
    for (i, s) in series.iter().enumerate() {
        let color = COLORS[i % COLORS.len()];
        // Steps: each value holds until the next sample; NaN breaks the line.
        let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
        for (k, &(t, v)) in s.samples.iter().enumerate() {
            let next = s.samples.get(k + 1).map_or(end, |n| n.0);
            if v.is_finite() {
                let run = runs.last_mut().unwrap_or_else(|| unreachable!());
                run.push((t, v));
                run.push((next, v));
            } else if !runs.last().is_some_and(Vec::is_empty) {
                runs.push(Vec::new());
            }
        }
        let mut first = true;
        for run in runs.into_iter().filter(|r| !r.is_empty()) {
            let drawn = chart.draw_series(LineSeries::new(run, color.stroke_width(2)))?;
            if first {
                drawn.label(s.name.clone()).legend(move |(x, y)| {
                    PathElement::new([(x, y), (x + 18, y)], color.stroke_width(2))
                });
                first = false;
            }
        }
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::LowerRight)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(200, 200, 200))
        .draw()?;
    Ok(())
}

/// Draws the series to an SVG file.
pub fn write_trend_svg(
    title: &str,
    series: &[Series],
    end: f64,
    path: impl AsRef<Path>,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    let svg = render_trend_svg(title, series, end)?;
    std::fs::write(path, svg).map_err(|source| PlotError::Io {
        path: path.display().to_string(),
        source,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_every_series_with_its_legend() {
        let series = vec![
            Series {
                name: "temp".into(),
                samples: vec![(0.0, 20.0), (1.0, 60.0), (2.0, 100.0)],
            },
            Series {
                name: "heater".into(),
                samples: vec![(0.0, 100.0), (1.5, f64::NAN), (1.8, 40.0)],
            },
            Series {
                name: "empty".into(),
                samples: vec![],
            },
        ];
        let svg = render_trend_svg("oven", &series, 3.0).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40]);
        for text in ["oven", "temp", "heater", "time (s)"] {
            assert!(svg.contains(&format!(">\n{text}\n<")), "no {text}");
        }
        // Per series its lines and its legend's sample: temp one line, heater two (broken
        // by its NaN), `empty` none.
        let lines = |color: &str| {
            svg.matches(&format!("stroke=\"{color}\" stroke-width=\"2\""))
                .count()
        };
        assert_eq!(lines("#1F77B4"), 1 + 1);
        assert_eq!(lines("#D62728"), 2 + 1);
        assert_eq!(lines("#2C8C2C"), 0);
    }
}
