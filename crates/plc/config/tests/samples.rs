//! The three sample configurations of MatPLC's appendix (`appendix-matplc.conf`), each as
//! its own file, read to the typed model.

use std::path::Path;
use std::time::Duration;

use petriplc_config::{parse_str, PlcConfig, PointKind, PointValue};

const POINTS: &str = r#"
[PLC]
point P0.0  "full name 0.0" module1 at  0.0      # 1 bit point at 0.0
point P0.1  "full name 0.1" module1 at  0.1  5   # 5 bit point from 0.1 to 0.5
point P1    "full name 1.0" module2 at  1        # 32 bit point from 1.0 to 1.31
"#;

fn read(text: &str) -> PlcConfig {
    parse_str(text, "sample.conf", Path::new("/nonexistent")).unwrap_or_else(|e| panic!("{e}"))
}

fn points(c: &PlcConfig) -> Vec<String> {
    c.points
        .iter()
        .map(|p| {
            assert_eq!(p.kind, PointKind::Unsigned);
            assert_eq!(p.init, PointValue::Unsigned(0));
            format!("{} {} {:?} {}", p.name, p.owner, p.at, p.bits)
        })
        .collect()
}

#[test]
fn config_1_minimum_refers_to_an_undeclared_module() {
    let text = format!(
        "{POINTS}\n[PLC]\nmodule module1 /matplc.logic/...\n\n[module1]\n# specific settings\n"
    );
    let err = parse_str(&text, "sample.conf", Path::new("/nonexistent")).unwrap_err();
    assert_eq!(
        err.to_string(),
        "sample.conf:5: error[C022]: the owner of point P1, `module2`, is not a declared module: \
         add `module module2 KIND-or-PATH` to [PLC] or give the point another owner (declared \
         modules: module1)"
    );
    // Declaring module2 is all it takes.
    let c = read(&format!("{text}[PLC]\nmodule module2 /matplc.logic/...\n"));
    assert_eq!(
        points(&c),
        [
            "P0.0 module1 Some((0, 0)) 1",
            "P0.1 module1 Some((0, 1)) 5",
            "P1 module2 Some((1, 0)) 32"
        ]
    );
}

#[test]
fn config_2_simple_synchronisation() {
    let c = read(&format!(
        "{POINTS}
[PLC]
module module1 /matplc.logic/...
module module2 /matplc.logic/...

[PLC]
synch module1 -> module2
synch module2 -> module1
synch_start module1
module1: scan_period = 0.1

[module1]
[module2]
"
    ));
    assert_eq!(points(&c).len(), 3);
    let m1 = &c.modules[0];
    assert_eq!(m1.scan_period, Some(Duration::from_millis(100)));
    assert_eq!(m1.kind, "/matplc.logic/...");
    assert_eq!(c.modules[1].scan_period, None);
    let rules: Vec<String> = c
        .synch
        .rules
        .iter()
        .map(|r| format!("{} -{}-> {} @{}", r.from, r.weight, r.to, r.origin.line))
        .collect();
    assert_eq!(
        rules,
        ["module1 -1-> module2 @12", "module2 -1-> module1 @13"]
    );
    assert_eq!(c.synch.starts[0].0, "module1");
    assert!(c.synch.places.is_empty() && c.synch.arcs.is_empty());
}

#[test]
fn config_3_complex_synchronisation() {
    let c = read(&format!(
        "{POINTS}
[PLC]
module module1 /matplc.logic/...
module module2 /matplc.logic/...

[PLC]
place P_module1  1 # initialise with 1 token
place P_module2    # 0 is the default

transition  T_module1_beg
transition  T_module1_end
transition  T_module2_beg
transition  T_module2_end

arc P_module1     -> T_module1_beg
arc T_module1_end -> P_module2

arc P_module2     -> T_module2_beg
arc T_module2_end -> P_module1

module1: scan_beg = T_module1_beg
module1: scan_end = T_module1_end
module2: scan_beg = T_module2_beg
module2: scan_end = T_module2_end
module1: scan_period = 0.1
"
    ));
    let places: Vec<(String, u32)> = c
        .synch
        .places
        .iter()
        .map(|p| (p.name.clone(), p.tokens))
        .collect();
    assert_eq!(
        places,
        [("P_module1".to_string(), 1), ("P_module2".to_string(), 0)]
    );
    assert_eq!(c.synch.transitions.len(), 4);
    let arcs: Vec<String> = c
        .synch
        .arcs
        .iter()
        .map(|a| format!("{} -{}-> {}", a.from, a.weight, a.to))
        .collect();
    assert_eq!(
        arcs,
        [
            "P_module1 -1-> T_module1_beg",
            "T_module1_end -1-> P_module2",
            "P_module2 -1-> T_module2_beg",
            "T_module2_end -1-> P_module1"
        ]
    );
    let ends: Vec<(Option<&str>, Option<&str>)> = c
        .modules
        .iter()
        .map(|m| (m.scan_beg.as_deref(), m.scan_end.as_deref()))
        .collect();
    assert_eq!(
        ends,
        [
            (Some("T_module1_beg"), Some("T_module1_end")),
            (Some("T_module2_beg"), Some("T_module2_end"))
        ]
    );
    assert_eq!(c.modules[0].scan_period, Some(Duration::from_millis(100)));
    // The modules' sections exist only through the `module1:` shorthand.
    assert_eq!(c.sections["module1"].pairs.len(), 3);
}

#[test]
fn the_appendix_arrows_and_weights() {
    let c = read(
        "[PLC]\nplace P 2\ntransition T\narc P --2--> T\narc T (9)> P\narc P -0-> T\n\
         arc T 8> P\narc T -()-> P\n",
    );
    let w: Vec<u32> = c.synch.arcs.iter().map(|a| a.weight).collect();
    assert_eq!(w, [2, 9, 0, 8, 1]);
}
