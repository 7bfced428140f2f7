//! Unit tests of `plot.rs`.

use super::*;
use crate::trace::TraceRow;
use quick_xml::events::Event;
use quick_xml::Reader;
use std::time::Duration;

/// What an SVG holds, read by an XML parser: its root element, the texts, the lane
/// labels (the texts in a lane's colour) and the number of lane lines (the only polylines
/// drawn 2 px wide).
struct Svg {
    root: String,
    texts: Vec<String>,
    labels: Vec<String>,
    polylines: usize,
}

fn parse(svg: &str) -> Svg {
    let mut reader = Reader::from_str(svg);
    let mut out = Svg {
        root: String::new(),
        texts: Vec::new(),
        labels: Vec::new(),
        polylines: 0,
    };
    let mut label = false;
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
            if label {
                out.labels.push(text.trim().to_string());
            }
        }
        text.clear();
        match event {
            Event::Start(e) => {
                if depth == 0 {
                    out.root = e.name().as_ref().to_string();
                }
                label = e.name().as_ref() == "text"
                    && e.attributes().flatten().any(|a| {
                        a.key.as_ref() == "fill"
                            && ["#1F77B4", "#D62728", "#2C8C2C", "#9467BD"].contains(&&*a.value)
                    });
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

fn row(ms: u64, inputs: &[i64], outputs: &[i64], marking: &[u32]) -> TraceRow {
    TraceRow {
        time: Duration::from_millis(ms),
        inputs: inputs.to_vec(),
        outputs: outputs.to_vec(),
        marking: marking.to_vec(),
        fired: vec![],
        plant: vec![],
    }
}

fn trace() -> Trace {
    Trace {
        net: "demo".into(),
        period: Duration::from_millis(100),
        inputs: vec!["START".into(), "SPEED".into()],
        input_types: vec![SignalType::Bool, SignalType::Int],
        outputs: vec!["L1".into()],
        output_types: vec![SignalType::Bool],
        places: vec!["idle".into(), "buffer".into()],
        output_places: vec![vec![0, 1]],
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

fn options(signals: Option<&[&str]>, from: Option<u64>, to: Option<u64>) -> PlotOptions {
    PlotOptions {
        signals: signals.map(|s| s.iter().map(|n| n.to_string()).collect()),
        from: from.map(Duration::from_millis),
        to: to.map(Duration::from_millis),
        note: None,
    }
}

/// Renders `trace` with `options` and compares the lane labels, top to bottom (the texts
/// drawn in a lane colour, in order), and checks the title and axis.
fn check(trace: &Trace, options: &PlotOptions, expect_title: &str, expect_labels: &[&str]) {
    let svg = parse(&render_svg_with(trace, options).unwrap());
    assert_eq!(svg.root, "svg");
    assert_eq!(svg.labels, expect_labels, "lane labels");
    assert_eq!(svg.texts.first().map(String::as_str), Some(expect_title));
    assert!(svg.texts.iter().any(|t| t == "time (s)"));
    assert!(svg.polylines >= expect_labels.len(), "a step line per lane");
}

#[test]
fn draws_a_title_a_legend_and_a_labelled_lane_per_signal_and_place() {
    check(
        &trace(),
        &PlotOptions::default(),
        "demo · scan every 100 ms · 0 to 1 s",
        &["START", "SPEED [-2..5]", "L1", "m:idle", "m:buffer [0..3]"],
    );
    let svg = parse(&render_svg(&trace()).unwrap());
    for item in ["input", "output", "marking"] {
        assert!(svg.texts.iter().any(|t| t == item), "legend {item}");
    }
    assert!(!svg.texts.iter().any(|t| t.starts_with("changes faster")));
}

#[test]
fn a_place_that_repeats_an_output_is_named_on_its_lane() {
    let mut t = trace();
    t.places = vec!["L1".into(), "idle".into()];
    t.output_places = vec![vec![0]];
    for (r, m) in t.rows.iter_mut().zip([[0, 1], [1, 0], [0, 1]]) {
        r.marking = m.to_vec();
    }
    check(
        &t,
        &PlotOptions::default(),
        "demo · scan every 100 ms · 0 to 1 s",
        &["START", "SPEED [-2..5]", "L1 = m:L1", "m:idle"],
    );
    // Asked for by name, it is drawn.
    check(
        &t,
        &options(Some(&["m:L1", "L1"]), None, None),
        "demo · scan every 100 ms · 0 to 1 s",
        &["m:L1", "L1"],
    );
}

#[test]
fn signals_pick_lanes_in_the_order_given() {
    check(
        &trace(),
        &options(Some(&["m:buffer", "L1", "in:START", "SPEED"]), None, None),
        "demo · scan every 100 ms · 0 to 1 s",
        &["m:buffer [0..3]", "L1", "START", "SPEED [-2..5]"],
    );
    let e = options(Some(&["L1", "lamp"]), None, None)
        .check(&trace())
        .unwrap_err();
    assert!(e.is_bad_input());
    assert_eq!(
        e.to_string(),
        "--signals: `lamp` is neither a signal nor a place of this run; give input and \
         output names or m:PLACE, from: START, SPEED, L1, m:idle, m:buffer"
    );
    assert!(matches!(
        options(Some(&[]), None, None).check(&trace()),
        Err(PlotError::NoSignals)
    ));
}

#[test]
fn a_window_shows_the_state_it_opens_with() {
    // From 0.5 s: START is already 0 again, SPEED 5, buffer 3 then 1 (integer lanes
    // always show 0 in their range).
    check(
        &trace(),
        &options(None, Some(500), Some(900)),
        "demo · scan every 100 ms · 0.5 to 0.9 s",
        &["START", "SPEED [0..5]", "L1", "m:idle", "m:buffer [0..3]"],
    );
    // A window past the end is clamped to it.
    check(
        &trace(),
        &options(None, Some(200), Some(5000)),
        "demo · scan every 100 ms · 0.2 to 1 s",
        &["START", "SPEED [-2..5]", "L1", "m:idle", "m:buffer [0..3]"],
    );
    let e = options(None, Some(800), Some(800))
        .check(&trace())
        .unwrap_err();
    assert_eq!(
        e.to_string(),
        "--from 0.8 s is not before --to 0.8 s: the plot's time window is empty"
    );
    let e = render_svg_with(&trace(), &options(None, Some(1000), None)).unwrap_err();
    assert!(e.is_bad_input());
    assert!(e
        .to_string()
        .starts_with("--from 1 s is not before the end of the run (1 s)"));
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
        &PlotOptions::default(),
        "demo · scan every 100 ms · 0 to 1 s",
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
    assert!(svg.texts.iter().any(|t| t == "plant"), "legend plant");
    // Picked by name, in the order given; a window keeps a boolean plant lane boolean.
    check(
        &t,
        &options(
            Some(&["L1", "plant:E_fall", "plant:alpha"]),
            Some(500),
            None,
        ),
        "demo · scan every 100 ms · 0.5 to 1 s",
        &["L1", "plant:E_fall", "plant:alpha [0..9000]"],
    );
    let e = options(Some(&["plant:beta"]), None, None)
        .check(&t)
        .unwrap_err();
    assert!(
        e.to_string()
            .ends_with("m:buffer, plant:alpha, plant:E_fall"),
        "{e}"
    );
}

#[test]
fn draws_degenerate_traces() {
    check(
        &Trace::default(),
        &PlotOptions::default(),
        "trace · 0 to 1 s",
        &[],
    );
    let mut t = trace();
    t.rows.truncate(1);
    t.end = Duration::ZERO;
    t.places = vec!["a<b&c".into(), "buffer".into()];
    check(
        &t,
        &PlotOptions::default(),
        "demo · scan every 100 ms · 0 to 0.1 s",
        &["START", "SPEED [-2..0]", "L1", "m:a<b&c", "m:buffer"],
    );
}

#[test]
fn edges_too_close_to_draw_become_a_band() {
    let lane = |steps: &[(f64, i64)]| Lane {
        label: "x".into(),
        color: INPUT,
        scale: Scale::Bool,
        steps: steps.to_vec(),
    };
    // 100 px a second: edges 0.01 s apart are 1 px apart.
    let fast = lane(&[
        (0.0, 0),
        (1.0, 1),
        (1.01, 0),
        (1.02, 1),
        (1.03, 0),
        (2.0, 1),
    ]);
    let s = strokes(&fast, 3.0, 100.0);
    assert_eq!(s.bands, [((1.0, 1.03), (0.0, 1.0))]);
    assert_eq!(
        s.lines,
        [
            vec![(0.0, 0.0), (1.0, 0.0)],
            vec![(1.03, 0.0), (2.0, 0.0), (2.0, 1.0), (3.0, 1.0)]
        ]
    );
    // Zoomed in (10 000 px a second) the same edges are drawn one by one.
    let s = strokes(&fast, 3.0, 10_000.0);
    assert!(s.bands.is_empty());
    assert_eq!(s.lines.len(), 1);
    assert_eq!(s.lines[0].len(), 12);
    // A lone pair of close edges is still drawn as edges.
    let blip = lane(&[(0.0, 0), (1.0, 1), (1.01, 0)]);
    assert!(strokes(&blip, 2.0, 100.0).bands.is_empty());
}

#[test]
fn fast_signals_are_banded_and_the_legend_says_so() {
    let mut t = trace();
    // START toggles every 10 ms for 10 s: under a pixel apart on the whole run.
    t.rows = (0..1000)
        .map(|k| row(k * 10, &[k as i64 % 2, 0], &[0], &[1, 0]))
        .collect();
    t.end = Duration::from_secs(10);
    let svg = parse(&render_svg(&t).unwrap());
    assert!(svg
        .texts
        .iter()
        .any(|x| x == "changes faster than drawn (zoom with --from/--to)"));
    // Zoomed in to 0.1 s, 10 edges are 90 px apart: no band.
    let svg = parse(&render_svg_with(&t, &options(None, Some(0), Some(100))).unwrap());
    assert!(!svg.texts.iter().any(|x| x.starts_with("changes faster")));
}

#[test]
fn writes_a_file() {
    let dir = std::env::temp_dir().join(format!("petriplc-sim-plot-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("trace.svg");
    write_svg(&trace(), &PlotOptions::default(), &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert_eq!(text, render_svg(&trace()).unwrap());
    std::fs::remove_dir_all(&dir).unwrap();
    let e = write_svg(
        &trace(),
        &PlotOptions::default(),
        dir.join("missing/trace.svg"),
    )
    .unwrap_err();
    assert!(!e.is_bad_input());
    assert!(
        e.to_string().starts_with("cannot write the plot to "),
        "{e}"
    );
}

#[test]
fn a_note_gets_its_own_line_under_the_legend() {
    let plain = parse(&render_svg(&trace()).unwrap());
    let noted = PlotOptions {
        note: Some("incomplete: interrupted (Ctrl-C)\nafter t=0.7 s".into()),
        ..PlotOptions::default()
    };
    let svg = render_svg_with(&trace(), &noted).unwrap();
    let height = |svg: &str| {
        let h = svg.split("height=\"").nth(1).unwrap();
        h[..h.find('"').unwrap()].parse::<u32>().unwrap()
    };
    assert_eq!(
        height(&svg),
        height(&render_svg(&trace()).unwrap()) + NOTE_HEIGHT
    );
    let noted = parse(&svg);
    assert!(noted
        .texts
        .contains(&"incomplete: interrupted (Ctrl-C) after t=0.7 s".to_string()));
    assert_eq!(noted.labels, plain.labels);
    assert_eq!(noted.texts.len(), plain.texts.len() + 1);
}

#[test]
fn axis_numbers_are_trimmed() {
    assert_eq!(trim_number(0.30000000000000004), "0.3");
    assert_eq!(trim_number(2.0), "2");
    assert_eq!(trim_number(-0.0), "0");
    assert_eq!(human(Duration::from_millis(10)), "10 ms");
    assert_eq!(human(Duration::from_micros(1500)), "0.0015 s");
    assert_eq!(human(Duration::from_millis(1500)), "1.5 s");
}
