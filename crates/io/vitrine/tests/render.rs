//! The vitrine's screen rendered from view models on ratatui's TestBackend at 80x24 and
//! 120x40, compared as text with snapshots: the panels' layout, the points table with every
//! value format and the forced marker, MatPLC `show` screens, sparklines, module statistics
//! and net markings.

use petriplc_runtime::status::{ModuleState, ModuleStatus};
use petriplc_vitrine::view::{
    render, text, GraphLine, NetLine, PointLine, ShowScreen, ShowText, View,
};
use ratatui::backend::TestBackend;
use ratatui::buffer::Buffer;
use ratatui::style::{Color, Modifier};
use ratatui::Terminal;

/// Draws `view` the way the module does, through a ratatui `Terminal`, on a TestBackend.
fn draw(view: &View, width: u16, height: u16) -> Buffer {
    let mut terminal = Terminal::new(TestBackend::new(width, height)).unwrap();
    terminal
        .draw(|f| {
            let area = f.area();
            render(view, area, f.buffer_mut());
        })
        .unwrap();
    terminal.backend().buffer().clone()
}

fn screen(view: &View, width: u16, height: u16) -> String {
    text(&draw(view, width, height))
}

fn point(name: &str, value: &str, on: Option<bool>, owner: &str, description: &str) -> PointLine {
    PointLine {
        name: name.into(),
        description: description.into(),
        value: value.into(),
        on,
        owner: owner.into(),
        forced: false,
    }
}

fn module(name: &str, kind: &str, state: ModuleState, scans: u64) -> ModuleStatus {
    let mut m = ModuleStatus::new(name, kind);
    m.state = state;
    m.scans = scans;
    m.cycle_us = [12.0, 45.4, 310.0];
    m.late_us = [20.0, 85.0, 400.0];
    m.overruns = 1;
    m.restarts = 0;
    m
}

/// The mixer of examples/mixer as the vitrine sees it mid-cycle, with B1 forced.
fn mixer() -> View {
    let mut b1 = point("B1", "ON", Some(true), "operator", "start button");
    b1.forced = true;
    let places = [
        ("ready", 0),
        ("filling", 1),
        ("half", 0),
        ("solute", 1),
        ("heating", 0),
        ("draining", 0),
        ("mixing", 2),
    ];
    View {
        title: "PLC mixer │ up 12.5 s".into(),
        message: "B1 forced ON for 300 ms".into(),
        points: vec![
            b1,
            point("N1", "off", Some(false), "tank", "level sensor: empty"),
            point("N2", "ON", Some(true), "tank", "level sensor: half"),
            point("N3", "off", Some(false), "tank", "level sensor: full"),
            point("L1", "off", Some(false), "controller", "lamp: ready"),
            point("V1", "ON", Some(true), "controller", "valve: solvent"),
            point("level", "-12", None, "tank", "tank level (i16)"),
            point("count", "40000", None, "tank", "cycles (u16)"),
            point("temp", "21.250", None, "tank", "temperature (f32)"),
            point("flow", "1.500e-5", None, "tank", "flow (f32)"),
        ],
        scroll: 0,
        show: None,
        graphs: vec![
            GraphLine {
                name: "level".into(),
                value: "-12".into(),
                lo: -20.0,
                hi: 20.0,
                samples: (0..80).map(|i| f64::from(i % 40) - 20.0).collect(),
            },
            GraphLine {
                name: "V1".into(),
                value: "ON".into(),
                lo: 0.0,
                hi: 1.0,
                samples: (0..80).map(|i| f64::from(u8::from(i % 20 < 10))).collect(),
            },
        ],
        modules: Some(vec![
            module("operator", "timeline", ModuleState::Running, 1250),
            module("tank", "plant", ModuleState::Running, 1250),
            module("controller", "petrinet", ModuleState::Running, 1249),
            module("vitrine", "vitrine", ModuleState::Running, 250),
        ]),
        nets: vec![NetLine {
            module: "controller".into(),
            places: places.iter().map(|(p, n)| (p.to_string(), *n)).collect(),
            note: String::new(),
        }],
        keys: vec![
            ("b".into(), "B1 pulse".into()),
            ("Del".into(), "release 1 forced".into()),
            ("q/Ctrl-C".into(), "stop the PLC".into()),
        ],
        log: vec![
            // What `petriplc run` writes to the pane: local time, then the line.
            "10:00:00 [WARN] hmi: forcing token 6880f0c0d1baf3061e4310dca89630db".into(),
            "10:00:12 [INFO] vitrine: B1 forced".into(),
        ],
    }
}

#[test]
fn mixer_at_80x24() {
    insta::assert_snapshot!(screen(&mixer(), 80, 24));
}

#[test]
fn mixer_at_120x40() {
    insta::assert_snapshot!(screen(&mixer(), 120, 40));
}

#[test]
fn every_panel_is_on_screen_at_both_sizes() {
    for (w, h) in [(80, 24), (120, 40)] {
        let s = screen(&mixer(), w, h);
        for needle in [
            "petriplc vitrine",
            "B1 forced ON for 300 ms",
            " points ",
            " modules ",
            " nets ",
            " graphs ",
            " log ",
            "q/Ctrl-C stop the PLC",
            "controller",
            "●filling",
            "●mixing×2",
            "○ready",
            "1.500e-5",
            "21.250",
            "40000",
            "-12",
            "vitrine: B1 forced",
        ] {
            assert!(s.contains(needle), "{w}x{h}: no `{needle}` in\n{s}");
        }
    }
}

#[test]
fn forced_points_are_marked_and_red() {
    let buf = draw(&mixer(), 120, 40);
    let s = text(&buf);
    let (y, line) = s
        .lines()
        .enumerate()
        .find(|(_, l)| l.contains("B1 ") && l.contains("start button"))
        .unwrap();
    assert!(line.contains("ON F operator"), "{line}");
    let x = line[..line.find(" F ").unwrap()].chars().count() + 1;
    assert_eq!(buf[(x as u16, y as u16)].fg, Color::Red);
    // A point that is not forced has no marker.
    let n1 = s
        .lines()
        .find(|l| l.contains("level sensor: empty"))
        .unwrap();
    assert!(n1.contains("off   tank"), "{n1}");
}

#[test]
fn marked_places_are_highlighted() {
    let buf = draw(&mixer(), 120, 40);
    let s = text(&buf);
    let (y, line) = s
        .lines()
        .enumerate()
        .find(|(_, l)| l.contains("●filling"))
        .unwrap();
    let x = line[..line.find("●filling").unwrap()].chars().count() as u16;
    assert_eq!(buf[(x, y as u16)].fg, Color::Green);
    assert!(buf[(x, y as u16)].modifier.contains(Modifier::BOLD));
    let x = line[..line.find("○ready").unwrap()].chars().count() as u16;
    assert_eq!(buf[(x, y as u16)].fg, Color::DarkGray);
}

#[test]
fn sparklines_draw_the_samples() {
    let s = screen(&mixer(), 120, 40);
    // The V1 graph alternates between the lowest bar and full bars; the level graph ramps.
    assert!(s.contains("▁▁▁▁▁▁▁▁▁▁██████████▁▁▁▁▁▁▁▁▁▁"), "{s}");
    assert!(s.contains("-20..20"), "{s}");
}

#[test]
fn a_matplc_show_screen() {
    let mut view = mixer();
    view.show = Some(ShowScreen {
        background: vec![
            "   MatPLC light chaser".into(),
            String::new(),
            "   lights:  L1 L2 L3 L4".into(),
            "   keys:    <L   R>   quit Q".into(),
        ],
        fields: vec![
            ShowText {
                row: 2,
                col: 26,
                text: "(*)".into(),
                on: Some(true),
            },
            ShowText {
                row: 2,
                col: 30,
                text: " -".into(),
                on: Some(false),
            },
            ShowText {
                row: 3,
                col: 30,
                text: "21.250".into(),
                on: None,
            },
            // Beyond the panel: clipped, never drawn over the border.
            ShowText {
                row: 1,
                col: 200,
                text: "far".into(),
                on: None,
            },
        ],
    });
    let s80 = screen(&view, 80, 24);
    insta::assert_snapshot!("show_80x24", s80);
    let s = screen(&view, 120, 40);
    insta::assert_snapshot!("show_120x40", s);
    assert!(s.contains("lights:  L1 L2 L3 L4   (*)  -"), "{s}");
    assert!(!s.contains("far"));
}

#[test]
fn waiting_for_status_and_many_points_scroll() {
    let mut view = mixer();
    view.modules = None;
    view.nets[0].places.clear();
    view.nets[0].note = "waiting for the PLC's status".into();
    view.points = (0..40)
        .map(|i| point(&format!("P{i}"), &i.to_string(), None, "m", "a point"))
        .collect();
    view.scroll = 10;
    let s = screen(&view, 80, 24);
    assert!(s.contains("waiting for the PLC's status"), "{s}");
    assert!(s.contains("points 11–"), "{s}");
    assert!(s.contains("of 40 (PgUp/PgDn)"), "{s}");
    assert!(s.contains("P10 "), "{s}");
    assert!(!s.contains("P9 "), "{s}");
}

#[test]
fn a_tiny_terminal_gets_a_note() {
    assert!(screen(&mixer(), 20, 5).contains("too small"));
}

#[test]
fn any_size_and_any_amount_of_content_renders() {
    let mut big = mixer();
    big.points = (0..200)
        .map(|i| {
            point(
                &format!("POINT_WITH_A_LONG_NAME_{i}"),
                "123456789012345",
                None,
                "m",
                "d",
            )
        })
        .collect();
    big.nets[0].places = (0..300).map(|i| (format!("place{i}"), i % 3)).collect();
    big.graphs = (0..30).map(|_| mixer().graphs[0].clone()).collect();
    big.keys = (0..40)
        .map(|i| (format!("F{i}"), "SOMETHING set 1".into()))
        .collect();
    big.log = (0..50)
        .map(|i| format!("line {i} {}", "x".repeat(300)))
        .collect();
    big.show = Some(ShowScreen {
        background: (0..60).map(|_| "#".repeat(200)).collect(),
        fields: vec![ShowText {
            row: 999,
            col: 999,
            text: "far".into(),
            on: Some(true),
        }],
    });
    let empty = View::default();
    for view in [&big, &empty, &mixer()] {
        for (w, h) in [
            (1, 1),
            (23, 7),
            (24, 8),
            (40, 12),
            (80, 24),
            (81, 25),
            (200, 60),
        ] {
            let s = screen(view, w, h);
            assert_eq!(s.lines().count(), h as usize);
        }
    }
    // The footer's key help wraps to two lines at most.
    let s = screen(&big, 80, 24);
    assert_eq!(s.lines().filter(|l| l.starts_with(" F")).count(), 2, "{s}");
}
