//! Unit tests of the synchronisation net: the simple form's expansion, the advanced form,
//! configuration errors and the firing rule on an in-memory marking.

use petriplc_config::{ArcDecl, ModuleDecl, Origin, PlaceDecl, PlcConfig, Setting, SynchRule};
use proptest::prelude::*;

use super::*;

fn at(line: usize) -> Origin {
    Origin {
        file: "test.conf".into(),
        line,
    }
}

fn module(name: &str) -> ModuleDecl {
    ModuleDecl {
        origin: at(1),
        ..ModuleDecl::new(name, "test")
    }
}

fn with_scans(name: &str, beg: Option<&str>, end: Option<&str>) -> ModuleDecl {
    let mut m = module(name);
    m.scan_beg = beg.map(str::to_string);
    m.scan_end = end.map(str::to_string);
    for (key, value, line) in [("scan_beg", beg, 40), ("scan_end", end, 41)] {
        if let Some(v) = value {
            m.settings.insert(
                key.into(),
                Setting {
                    value: v.into(),
                    origin: at(line),
                },
            );
        }
    }
    m
}

fn config(modules: &[&str]) -> PlcConfig {
    PlcConfig {
        file: "test.conf".into(),
        modules: modules.iter().map(|m| module(m)).collect(),
        ..PlcConfig::default()
    }
}

fn rule(cfg: &mut PlcConfig, from: &str, weight: u32, to: &str, line: usize) {
    cfg.synch.rules.push(SynchRule {
        from: from.into(),
        to: to.into(),
        weight,
        origin: at(line),
    });
}

fn start(cfg: &mut PlcConfig, module: &str, line: usize) {
    cfg.synch.starts.push((module.into(), at(line)));
}

fn place(cfg: &mut PlcConfig, name: &str, tokens: u32, line: usize) {
    cfg.synch.places.push(PlaceDecl {
        name: name.into(),
        tokens,
        origin: at(line),
    });
}

fn transition(cfg: &mut PlcConfig, name: &str, line: usize) {
    cfg.synch.transitions.push((name.into(), at(line)));
}

fn arc(cfg: &mut PlcConfig, from: &str, weight: u32, to: &str, line: usize) {
    cfg.synch.arcs.push(ArcDecl {
        from: from.into(),
        to: to.into(),
        weight,
        origin: at(line),
    });
}

fn error_of(cfg: &PlcConfig) -> String {
    SynchNet::from_config(cfg)
        .expect_err("the configuration should be refused")
        .to_string()
}

fn t(net: &SynchNet, name: &str) -> TransitionRef {
    net.transition(name)
        .unwrap_or_else(|| panic!("no transition {name}"))
}

#[test]
fn simple_ring_expands_into_places_per_rule() {
    let mut cfg = config(&["a", "b"]);
    rule(&mut cfg, "a", 1, "b", 10);
    rule(&mut cfg, "b", 1, "a", 11);
    start(&mut cfg, "a", 12);
    let net = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(
        net.describe(),
        "places:\n  a->b 0\n  b->a 1\ntransitions:\n  a:beg\n  a:end\n  b:beg\n  b:end\n\
         arcs:\n  a:end -> a->b\n  a->b -> b:beg\n  b:end -> b->a\n  b->a -> a:beg\n\
         scans:\n  a: scan_beg = a:beg, scan_end = a:end\n  b: scan_beg = b:beg, scan_end = b:end\n"
    );
    assert_eq!(net.scan_beg("a"), t(&net, "a:beg"));
    assert_eq!(net.scan_end("b"), t(&net, "b:end"));
    assert_eq!(net.scan_beg("nobody"), TransitionRef::Null);
    assert_eq!(net.places()[1].origin, at(11));
}

#[test]
fn weighted_rule_gives_n_tokens_per_scan_and_takes_one() {
    let mut cfg = config(&["a", "b"]);
    rule(&mut cfg, "a", 2, "b", 10);
    rule(&mut cfg, "a", 1, "a", 11);
    start(&mut cfg, "a", 12);
    let net = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(
        net.describe(),
        "places:\n  a->b 0\n  a->a 1\ntransitions:\n  a:beg\n  a:end\n  b:beg\n  b:end\n\
         arcs:\n  a:end -2-> a->b\n  a->b -> b:beg\n  a:end -> a->a\n  a->a -> a:beg\n\
         scans:\n  a: scan_beg = a:beg, scan_end = a:end\n  b: scan_beg = b:beg, scan_end = b:end\n"
    );
    // One scan of a lets b make exactly two.
    let mut m = net.initial_marking();
    let (ab, ae, bb, be) = (
        net.scan_beg("a"),
        net.scan_end("a"),
        net.scan_beg("b"),
        net.scan_end("b"),
    );
    assert!(!m.enabled(&net, bb));
    assert!(m.fire(&net, ab) && m.fire(&net, ae));
    assert!(m.fire(&net, bb) && m.fire(&net, be));
    assert!(m.fire(&net, bb) && m.fire(&net, be));
    assert!(!m.enabled(&net, bb));
}

#[test]
fn start_without_incoming_rule_needs_nothing() {
    let mut cfg = config(&["a", "b", "c"]);
    rule(&mut cfg, "a", 1, "b", 10);
    start(&mut cfg, "a", 11);
    let net = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(net.initial_marking().tokens(), &[0]);
    let m = net.initial_marking();
    assert!(m.enabled(&net, net.scan_beg("a")));
    assert!(!m.enabled(&net, net.scan_beg("b")));
    assert_eq!(net.scan_beg("c"), TransitionRef::Null);
}

#[test]
fn fan_in_waits_for_every_predecessor() {
    let mut cfg = config(&["a", "b", "c"]);
    rule(&mut cfg, "a", 1, "c", 10);
    rule(&mut cfg, "b", 1, "c", 11);
    let net = SynchNet::from_config(&cfg).unwrap();
    let mut m = net.initial_marking();
    let c = net.scan_beg("c");
    assert!(m.fire(&net, net.scan_end("a")));
    assert!(!m.enabled(&net, c));
    assert!(m.fire(&net, net.scan_end("b")));
    assert!(m.fire(&net, c));
    // synch_start fills every place feeding c:beg.
    start(&mut cfg, "c", 12);
    let net = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(net.initial_marking().tokens(), &[1, 1]);
}

/// Seed 000's `basic_synch` complex example, with the "chaser once, vitrine twice"
/// weights.
fn chaser_config() -> PlcConfig {
    let mut cfg = config(&["Chaser", "vitrine", "kbd"]);
    cfg.modules[0] = with_scans("Chaser", Some("T_chaser_beg"), Some("T_chaser_end"));
    cfg.modules[1] = with_scans("vitrine", Some("T_vitrine_beg"), Some("T_vitrine_end"));
    cfg.modules[2] = with_scans("kbd", Some("NULL"), None);
    place(&mut cfg, "P_chaser", 2, 20);
    place(&mut cfg, "P_vitrine", 0, 21);
    for (i, name) in [
        "T_chaser_beg",
        "T_chaser_end",
        "T_vitrine_beg",
        "T_vitrine_end",
    ]
    .iter()
    .enumerate()
    {
        transition(&mut cfg, name, 22 + i);
    }
    arc(&mut cfg, "P_chaser", 2, "T_chaser_beg", 30);
    arc(&mut cfg, "T_chaser_end", 2, "P_vitrine", 31);
    arc(&mut cfg, "P_vitrine", 1, "T_vitrine_beg", 32);
    arc(&mut cfg, "T_vitrine_end", 1, "P_chaser", 33);
    cfg
}

#[test]
fn advanced_form_is_taken_as_written() {
    let net = SynchNet::from_config(&chaser_config()).unwrap();
    assert_eq!(
        net.describe(),
        "places:\n  P_chaser 2\n  P_vitrine 0\n\
         transitions:\n  T_chaser_beg\n  T_chaser_end\n  T_vitrine_beg\n  T_vitrine_end\n\
         arcs:\n  P_chaser -2-> T_chaser_beg\n  T_chaser_end -2-> P_vitrine\n  \
         P_vitrine -> T_vitrine_beg\n  T_vitrine_end -> P_chaser\n\
         scans:\n  Chaser: scan_beg = T_chaser_beg, scan_end = T_chaser_end\n  \
         vitrine: scan_beg = T_vitrine_beg, scan_end = T_vitrine_end\n"
    );
    assert_eq!(net.scan_beg("kbd"), TransitionRef::Null);
    assert_eq!(net.scan_end("kbd"), TransitionRef::Null);
    assert_eq!(net.transition("NULL"), Some(TransitionRef::Null));
    assert_eq!(net.transition("nope"), None);
}

#[test]
fn weight_zero_arc_needs_an_empty_place_and_takes_nothing() {
    let mut cfg = config(&[]);
    place(&mut cfg, "P", 0, 1);
    place(&mut cfg, "Q", 0, 2);
    transition(&mut cfg, "T", 3);
    transition(&mut cfg, "fill", 4);
    arc(&mut cfg, "P", 0, "T", 5);
    arc(&mut cfg, "T", 1, "Q", 6);
    arc(&mut cfg, "fill", 1, "P", 7);
    let net = SynchNet::from_config(&cfg).unwrap();
    assert!(net.describe().contains("  P -0-> T\n"));
    let (tt, fill) = (t(&net, "T"), t(&net, "fill"));
    let mut m = net.initial_marking();
    assert!(m.fire(&net, tt));
    assert!(m.fire(&net, tt));
    assert_eq!(m.tokens(), &[0, 2]);
    assert!(m.fire(&net, fill));
    assert!(!m.enabled(&net, tt));
    assert!(!m.fire(&net, tt));
    assert_eq!(m.tokens(), &[1, 2]);
    assert_eq!(m.by_name(&net)["Q"], 2);
}

#[test]
fn firing_rule_takes_and_gives_weights() {
    let mut cfg = config(&[]);
    place(&mut cfg, "in", 5, 1);
    place(&mut cfg, "out", 0, 2);
    place(&mut cfg, "loop", 1, 3);
    transition(&mut cfg, "T", 4);
    arc(&mut cfg, "in", 2, "T", 5);
    arc(&mut cfg, "T", 3, "out", 6);
    arc(&mut cfg, "loop", 1, "T", 7);
    arc(&mut cfg, "T", 1, "loop", 8);
    let net = SynchNet::from_config(&cfg).unwrap();
    let tt = t(&net, "T");
    let mut m = net.initial_marking();
    assert!(m.fire(&net, tt));
    assert_eq!(m.tokens(), &[3, 3, 1]);
    assert!(m.fire(&net, tt));
    assert_eq!(m.tokens(), &[1, 6, 1]);
    assert!(!m.fire(&net, tt), "needs 2 tokens, has 1");
    assert_eq!(m.tokens(), &[1, 6, 1]);
    assert!(m.fire(&net, TransitionRef::Null));
    assert_eq!(m.tokens(), &[1, 6, 1]);
}

#[test]
fn a_firing_that_would_overflow_a_place_is_disabled() {
    let mut cfg = config(&[]);
    place(&mut cfg, "P", u32::MAX - 1, 1);
    transition(&mut cfg, "T", 2);
    arc(&mut cfg, "T", 1, "P", 3);
    let net = SynchNet::from_config(&cfg).unwrap();
    let mut m = net.initial_marking();
    assert!(m.fire(&net, t(&net, "T")));
    assert!(!m.fire(&net, t(&net, "T")));
    assert_eq!(m.tokens(), &[u32::MAX]);
}

/// A change to a valid configuration that should make it invalid.
type Edit = Box<dyn Fn(&mut PlcConfig)>;

#[test]
fn errors_name_the_element_and_the_line() {
    let base = || {
        let mut cfg = config(&["a", "b"]);
        place(&mut cfg, "P", 0, 1);
        transition(&mut cfg, "T", 2);
        cfg
    };
    let cases: Vec<(Edit, &str)> = vec![
        (
            Box::new(|c| arc(c, "P", 1, "nowhere", 9)),
            "test.conf:9: arc `P -> nowhere`: `nowhere` is neither a place nor a transition",
        ),
        (Box::new(|c| arc(c, "P", 1, "P", 9)), "test.conf:9: arc `P -> P` joins two places"),
        (
            Box::new(|c| arc(c, "T", 1, "T", 9)),
            "test.conf:9: arc `T -> T` joins two transitions",
        ),
        (
            Box::new(|c| arc(c, "T", 0, "P", 9)),
            "test.conf:9: arc `T -0-> P`: weight 0",
        ),
        (
            Box::new(|c| arc(c, "P", 1, "NULL", 9)),
            "test.conf:9: arc `P -> NULL`: the NULL transition cannot have arcs",
        ),
        (
            Box::new(|c| {
                arc(c, "P", 1, "T", 8);
                arc(c, "P", 2, "T", 9);
            }),
            "test.conf:9: a second arc from `P` to `T` (the first is at test.conf:8)",
        ),
        (
            Box::new(|c| transition(c, "NULL", 9)),
            "test.conf:9: `NULL` is reserved",
        ),
        (
            Box::new(|c| place(c, "P", 3, 9)),
            "test.conf:9: `P` is already declared as a place at test.conf:1",
        ),
        (
            Box::new(|c| place(c, "T", 3, 9)),
            "test.conf:2: `T` is already declared as a place at test.conf:9",
        ),
        (
            Box::new(|c| transition(c, "a:beg", 9)),
            "test.conf:9: transition name `a:beg` contains `:`",
        ),
        (
            Box::new(|c| place(c, "a->b", 0, 9)),
            "test.conf:9: place name `a->b` contains `->`",
        ),
        (
            Box::new(|c| rule(c, "a", 0, "b", 9)),
            "test.conf:9: `synch a -0-> b`: a synch rule's weight must be at least 1",
        ),
        (
            Box::new(|c| rule(c, "a", 1, "ghost", 9)),
            "test.conf:9: `synch a -> ghost` names module `ghost`, which no `module` line declares",
        ),
        (
            Box::new(|c| {
                rule(c, "a", 1, "b", 8);
                rule(c, "a", 2, "b", 9);
            }),
            "test.conf:9: `synch a -> b` is written twice (first at test.conf:8)",
        ),
        (
            Box::new(|c| start(c, "ghost", 9)),
            "test.conf:9: `synch_start ghost`: no `module` line declares `ghost`",
        ),
        (
            Box::new(|c| {
                c.modules[1] = with_scans("b", None, Some("T"));
                rule(c, "a", 1, "b", 9);
            }),
            "test.conf:9: module `b` is in a `synch` rule and also sets `scan_end` (at test.conf:41)",
        ),
        (
            Box::new(|c| c.modules[0] = with_scans("a", Some("T_missing"), None)),
            "test.conf:40: module `a`: scan_beg = T_missing, but there is no transition `T_missing`",
        ),
    ];
    for (edit, expected) in cases {
        let mut cfg = base();
        edit(&mut cfg);
        let message = error_of(&cfg);
        assert!(
            message.starts_with(expected),
            "expected `{expected}`, got `{message}`"
        );
    }
    // The base itself is fine.
    SynchNet::from_config(&base()).unwrap();
}

#[test]
fn the_fingerprint_tells_nets_apart() {
    let mut cfg = config(&["a", "b"]);
    rule(&mut cfg, "a", 1, "b", 1);
    let one = SynchNet::from_config(&cfg).unwrap();
    assert_eq!(one.fingerprint(), one.clone().fingerprint());
    cfg.synch.rules[0].weight = 2;
    let two = SynchNet::from_config(&cfg).unwrap();
    assert_ne!(one.fingerprint(), two.fingerprint());
}

proptest! {
    /// Firing never loses or invents tokens: a successful firing changes each place by its
    /// output weight minus its input weight, a refused one changes nothing.
    #[test]
    fn firing_changes_exactly_the_arc_weights(
        tokens in proptest::collection::vec(0u32..4, 3),
        weights in proptest::collection::vec((0u32..3, 0u32..3), 3),
        steps in proptest::collection::vec(0usize..2, 0..20),
    ) {
        let mut cfg = config(&[]);
        for (i, n) in tokens.iter().enumerate() {
            place(&mut cfg, &format!("P{i}"), *n, i);
        }
        transition(&mut cfg, "T0", 10);
        transition(&mut cfg, "T1", 11);
        for (i, (w_in, w_out)) in weights.iter().enumerate() {
            let tr = if i % 2 == 0 { "T0" } else { "T1" };
            arc(&mut cfg, &format!("P{i}"), *w_in, tr, 20 + i);
            if *w_out > 0 {
                arc(&mut cfg, tr, *w_out, &format!("P{i}"), 30 + i);
            }
        }
        let net = SynchNet::from_config(&cfg).unwrap();
        let mut m = net.initial_marking();
        for step in steps {
            let before = m.tokens().to_vec();
            let fired = m.fire(&net, TransitionRef::Index(step));
            for (i, (w_in, w_out)) in weights.iter().enumerate() {
                let touched = (i % 2) == step;
                let expected = if fired && touched {
                    before[i] - w_in + w_out
                } else {
                    before[i]
                };
                prop_assert_eq!(m.tokens()[i], expected);
                if touched && *w_in == 0 && fired {
                    prop_assert_eq!(before[i], 0);
                }
                if touched && *w_in > 0 && !fired && before[i] >= *w_in {
                    // Refused for another place's sake: that place must be short.
                    let short = weights.iter().enumerate().any(|(j, (wj, _))| {
                        j % 2 == step && (if *wj == 0 { before[j] != 0 } else { before[j] < *wj })
                    });
                    prop_assert!(short, "refused although every input was satisfied");
                }
            }
        }
    }
}

mod never_scanning {
    use super::*;

    /// The modules `net` can never let scan (`None`: undecided).
    fn check(cfg: &PlcConfig, others_fire: bool, expect: Option<&[&str]>) {
        let net = SynchNet::from_config(cfg).unwrap();
        let got = net.never_scanning(others_fire);
        assert_eq!(
            got,
            expect.map(|e| e.iter().map(|s| s.to_string()).collect::<Vec<_>>()),
            "{}",
            net.describe()
        );
    }

    #[test]
    fn a_ring_without_synch_start_never_scans() {
        let mut cfg = config(&["a", "b", "c", "free"]);
        rule(&mut cfg, "a", 1, "b", 2);
        rule(&mut cfg, "b", 1, "c", 3);
        rule(&mut cfg, "c", 1, "a", 4);
        check(&cfg, false, Some(&["a", "b", "c"]));
        start(&mut cfg, "b", 5);
        check(&cfg, false, Some(&[]));
    }

    #[test]
    fn a_chain_starved_of_its_source_never_scans_downstream() {
        // b waits for a and for d; d waits for b: b and d never scan, a runs free.
        let mut cfg = config(&["a", "b", "d"]);
        rule(&mut cfg, "a", 1, "b", 2);
        rule(&mut cfg, "d", 1, "b", 3);
        rule(&mut cfg, "b", 1, "d", 4);
        check(&cfg, false, Some(&["b", "d"]));
    }

    #[test]
    fn unbounded_producers_are_followed_to_the_cap() {
        // a runs free and feeds b 3 tokens a scan; b needs 2 per scan through the advanced
        // form (weight 2 on the arc into its scan_beg).
        let mut cfg = config(&[]);
        cfg.modules.push(with_scans("a", None, Some("Ta")));
        cfg.modules.push(with_scans("b", Some("Tb"), None));
        place(&mut cfg, "P", 0, 10);
        transition(&mut cfg, "Ta", 11);
        transition(&mut cfg, "Tb", 12);
        arc(&mut cfg, "Ta", 3, "P", 13);
        arc(&mut cfg, "P", 200, "Tb", 14);
        check(&cfg, false, Some(&[]));
    }

    #[test]
    fn an_empty_test_arc_and_transitions_fired_by_programs() {
        // b may start only while Q is empty; Q is filled at start and only a transition no
        // module scans on (`drain`) empties it: dead, unless programs may fire `drain`.
        let mut cfg = config(&[]);
        cfg.modules.push(with_scans("b", Some("Tb"), None));
        place(&mut cfg, "Q", 1, 10);
        transition(&mut cfg, "Tb", 11);
        transition(&mut cfg, "drain", 12);
        arc(&mut cfg, "Q", 0, "Tb", 13);
        arc(&mut cfg, "Q", 1, "drain", 14);
        check(&cfg, false, Some(&["b"]));
        check(&cfg, true, Some(&[]));
    }
}
