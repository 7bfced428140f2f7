//! The rules of docs/semantics.md, one small net per rule: each test builds its net with
//! `NetBuilder` from a short description, runs it, and compares the rendered trace with the
//! expected text, so a failure shows the whole run next to what the rule says it must be.

use std::fmt::Write as _;
use std::time::Duration;

use petriplc_net::guard::parse;
use petriplc_net::time::{format_seconds, parse_duration};
use petriplc_net::{
    ArcKind, ArcSpec, Evolution, Marking, Net, NetBuilder, PlaceSpec, ScanOptions, Scanner,
    SignalDirection, SignalType, StepRule, TransitionId, TransitionSpec,
};

/// Builds a net from one element per line:
///
/// ```text
/// place ID [TOKENS] [cap N] [in SIGNAL] [out SIGNAL]
/// trans ID [if GUARD…]
/// arc FROM TO [xWEIGHT] [read|inhibit] [after DURATION]
/// signal NAME in|out bool|int
/// step maximal-step|sequential
/// evolve one-pass|until-stable
/// ```
fn build(text: &str) -> Net {
    let mut b = NetBuilder::new("test", "test");
    for (n, line) in text
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .enumerate()
    {
        let (head, rest) = line.split_once(' ').unwrap_or((line, ""));
        let words: Vec<&str> = rest.split_whitespace().collect();
        match head {
            "place" => {
                let mut p = PlaceSpec {
                    id: words[0].into(),
                    name: words[0].into(),
                    ..Default::default()
                };
                let mut i = 1;
                while i < words.len() {
                    match words[i] {
                        "cap" => p.capacity = Some(words[i + 1].parse().unwrap()),
                        "in" => p.input = Some(words[i + 1].into()),
                        "out" => p.output = Some(words[i + 1].into()),
                        tokens => {
                            p.initial = tokens.parse().unwrap();
                            i += 1;
                            continue;
                        }
                    }
                    i += 2;
                }
                b.place(p);
            }
            "trans" => {
                let (id, guard) = rest.split_once(" if ").unwrap_or((rest, ""));
                let id = id.trim();
                b.transition(TransitionSpec {
                    id: id.into(),
                    name: id.into(),
                    guard: parse(guard).unwrap(),
                });
            }
            "arc" => {
                let mut a = ArcSpec {
                    id: format!("a{n}"),
                    source: words[0].into(),
                    target: words[1].into(),
                    kind: ArcKind::Normal,
                    weight: 1,
                    delay: None,
                };
                let mut more = words[2..].iter();
                while let Some(w) = more.next() {
                    match *w {
                        "read" => a.kind = ArcKind::Read,
                        "inhibit" => a.kind = ArcKind::Inhibitor,
                        "after" => a.delay = Some(parse_duration(more.next().unwrap()).unwrap()),
                        w => a.weight = w.strip_prefix('x').unwrap().parse().unwrap(),
                    }
                }
                b.arc(a);
            }
            "signal" => {
                let dir = if words[1] == "in" {
                    SignalDirection::Input
                } else {
                    SignalDirection::Output
                };
                let ty = if words[2] == "int" {
                    SignalType::Int
                } else {
                    SignalType::Bool
                };
                b.signal(words[0], dir, ty);
            }
            "step" => {
                b.step(StepRule::parse(rest).unwrap());
            }
            "evolve" => {
                b.evolve(Evolution::parse(rest).unwrap());
            }
            _ => panic!("bad net line {line:?}"),
        }
    }
    b.build().unwrap_or_else(|e| panic!("{e:?}"))
}

/// `{p1, p3:2}`: the marked places, with their count when above 1.
fn show_marking(net: &Net, m: &Marking) -> String {
    let marked: Vec<String> = net
        .place_ids()
        .filter(|&p| m[p] > 0)
        .map(|p| match m[p] {
            1 => net.place_label(p).to_string(),
            k => format!("{}:{k}", net.place_label(p)),
        })
        .collect();
    format!("{{{}}}", marked.join(", "))
}

fn show_fired(net: &Net, fired: &[TransitionId]) -> String {
    if fired.is_empty() {
        return "-".into();
    }
    fired
        .iter()
        .map(|&t| net.transition_label(t))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `net` scan by scan and renders the trace. The script has one instruction per line:
///
/// ```text
/// scans N [every DURATION]    (default period 10 ms, first scan at t = 0)
/// max-passes N
/// at K: SIGNAL=VALUE …        (set before scan K, kept until changed)
/// ```
///
/// A scan is shown as `#K Ts [inputs set]: fired -> marking [| outputs] [(N passes)]` when it
/// is the first or the last, inputs were set, something fired or it failed; an error ends
/// the run.
fn trace(net: &Net, script: &str) -> String {
    let mut options = ScanOptions::of(net);
    let mut scans = 0;
    let mut period = Duration::from_millis(10);
    let mut sets: Vec<(usize, Vec<(String, i64)>)> = Vec::new();
    for line in script.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words[0] {
            "scans" => {
                scans = words[1].parse().unwrap();
                if words.get(2) == Some(&"every") {
                    period = parse_duration(words[3]).unwrap();
                }
            }
            "max-passes" => options.max_passes = words[1].parse().unwrap(),
            "at" => {
                let k = words[1].trim_end_matches(':').parse().unwrap();
                let values = words[2..]
                    .iter()
                    .map(|a| {
                        let (s, v) = a.split_once('=').unwrap();
                        (s.to_string(), v.parse().unwrap())
                    })
                    .collect();
                sets.push((k, values));
            }
            _ => panic!("bad script line {line:?}"),
        }
    }
    let mut scanner = Scanner::new(net, options);
    let mut signals = vec![0i64; net.signals().len()];
    let mut out = String::new();
    for k in 0..scans {
        let mut shown_inputs = String::new();
        for (_, values) in sets.iter().filter(|(at, _)| *at == k) {
            for (name, v) in values {
                let s = net
                    .signal_by_name(name)
                    .unwrap_or_else(|| panic!("no signal {name}"));
                signals[s.index()] = *v;
                write!(shown_inputs, " {name}={v}").unwrap();
            }
        }
        let now = period * k as u32;
        let result = scanner.scan(now, &mut signals);
        let head = format!("#{k} {}s{shown_inputs}", format_seconds(now));
        if let Err(e) = result {
            writeln!(out, "{head}: error: {e}").unwrap();
            break;
        }
        if k == 0 || k + 1 == scans || !shown_inputs.is_empty() || !scanner.fired().is_empty() {
            write!(
                out,
                "{head}: {} -> {}",
                show_fired(net, scanner.fired()),
                show_marking(net, scanner.marking())
            )
            .unwrap();
            let outputs: Vec<String> = net
                .outputs()
                .map(|s| format!("{}={}", net.signal(s).name, signals[s.index()]))
                .collect();
            if !outputs.is_empty() {
                write!(out, " | {}", outputs.join(" ")).unwrap();
            }
            if options.evolve == Evolution::UntilStable {
                write!(out, " ({} passes)", scanner.passes()).unwrap();
            }
            out.push('\n');
        }
    }
    out
}

/// Compares line by line, ignoring the indentation of `expect`.
fn assert_trace(got: &str, expect: &str) {
    let expect: String = expect
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty())
        .map(|l| format!("{l}\n"))
        .collect();
    assert_eq!(
        got, expect,
        "\n--- got ---\n{got}--- expected ---\n{expect}"
    );
}

mod interleaving {
    //! Analysis semantics (`Net::is_enabled`, `Net::fire`): one transition at a time, guards
    //! and delays ignored.

    use super::*;

    /// Tries each transition of `sequence` in turn from the initial marking: a line per try,
    /// `t fires -> marking` or `t disabled`.
    fn check(net: &str, sequence: &str, expect: &str) {
        let net = build(net);
        let mut m = net.initial_marking();
        let mut out = format!("M0 {}\n", show_marking(&net, &m));
        for label in sequence.split_whitespace() {
            let t = net.transition_by_id(label).unwrap();
            if !net.is_enabled(&m, t) {
                writeln!(out, "{label} disabled").unwrap();
                continue;
            }
            match net.fire(&mut m, t) {
                Ok(()) => writeln!(out, "{label} fires -> {}", show_marking(&net, &m)).unwrap(),
                Err(e) => writeln!(
                    out,
                    "{label} error: {e}; marking stays {}",
                    show_marking(&net, &m)
                )
                .unwrap(),
            }
        }
        assert_trace(&out, expect);
    }

    #[test]
    fn preset_is_consumed_and_postset_produced() {
        check(
            "place p1 3
             place p2
             trans t
             arc p1 t x2
             arc t p2 x3",
            "t t",
            "M0 {p1:3}
             t fires -> {p1, p2:3}
             t disabled",
        );
    }

    #[test]
    fn read_arc_needs_tokens_but_consumes_none() {
        check(
            "place s 2
             place p1 1
             place p2
             trans t
             arc s t x2 read
             arc p1 t
             arc t p2
             trans drain
             arc s drain",
            "t drain t",
            "M0 {s:2, p1}
             t fires -> {s:2, p2}
             drain fires -> {s, p2}
             t disabled",
        );
    }

    #[test]
    fn inhibitor_arc_blocks_from_its_weight_on() {
        // The inhibitor of weight 2 allows 0 and 1 token in `stop`, not 2.
        check(
            "place p 3
             place stop 1
             trans t
             arc p t
             arc stop t x2 inhibit
             trans more
             arc more stop",
            "t more t",
            "M0 {p:3, stop}
             t fires -> {p:2, stop}
             more fires -> {p:2, stop:2}
             t disabled",
        );
    }

    #[test]
    fn capacity_counts_own_consumption() {
        // `loop` takes the token of the full place `c` and puts it back: allowed, because
        // marking − own consumption + production = 1 ≤ 1. `fill` would make it 2.
        check(
            "place a 2
             place c 1 cap 1
             trans fill
             arc a fill
             arc fill c
             trans loop
             arc c loop
             arc loop c",
            "fill loop",
            "M0 {a:2, c}
             fill disabled
             loop fires -> {a:2, c}",
        );
    }

    #[test]
    fn guards_and_delays_are_ignored() {
        check(
            "place p 1
             place q
             trans t if FALSE
             arc p t after T#1h
             arc t q",
            "t",
            "M0 {p}
             t fires -> {q}",
        );
    }

    #[test]
    fn incidence_is_production_minus_consumption() {
        let net = build(
            "place a 1
             place b
             place r
             trans t
             arc a t x2
             arc t a
             arc t b x3
             arc r t read
             arc b t inhibit",
        );
        let t = TransitionId(0);
        let c: Vec<i64> = net.place_ids().map(|p| net.incidence(p, t)).collect();
        // Read and inhibitor arcs change nothing, so they count 0.
        assert_eq!(c, [-1, 3, 0]);
    }

    #[test]
    fn an_unbounded_place_overflows_instead_of_blocking() {
        // No capacity means no capacity condition: the transition is enabled, and firing
        // fails on the u32 token counter, leaving the marking untouched.
        let net = build(
            "place src 1
             place big
             trans t
             arc src t
             arc t big",
        );
        let mut m = net.initial_marking();
        m.0[1] = u32::MAX;
        let t = TransitionId(0);
        assert!(net.is_enabled(&m, t));
        let e = net.fire(&mut m, t).unwrap_err();
        assert_eq!(e.to_string(), "place big: more than 4294967295 tokens");
        assert_eq!(m.0, [1, u32::MAX]);
    }
}

mod step_rules {
    //! How the transitions of one pass are chosen: `maximal-step` (seed 003's
    //! `filter_possible_firings`) against `sequential` (seed 004's generated C), with
    //! priority by declaration order (seed 004: the lowest index wins).

    use super::*;

    /// Runs the net (written without a `step` line) under both step rules and renders
    /// both traces one after the other.
    fn check(net: &str, script: &str, expect: &str) {
        let mut got = String::new();
        for rule in ["maximal-step", "sequential"] {
            got.push_str(&format!("{rule}\n"));
            got.push_str(&trace(&build(&format!("step {rule}\n{net}")), script));
        }
        assert_trace(&got, expect);
    }

    #[test]
    fn conflict_goes_to_the_first_declared_transition() {
        // `zeta` is declared before `alpha`: the order of declaration decides, not the name.
        check(
            "place p 1
             place a
             place z
             trans zeta
             arc p zeta
             arc zeta z
             trans alpha
             arc p alpha
             arc alpha a",
            "scans 2",
            "maximal-step
             #0 0s: zeta -> {z}
             #1 0.01s: - -> {z}
             sequential
             #0 0s: zeta -> {z}
             #1 0.01s: - -> {z}",
        );
    }

    #[test]
    fn enough_tokens_for_both_fires_both() {
        check(
            "place p 2
             place a
             place b
             trans t1
             arc p t1
             arc t1 a
             trans t2
             arc p t2
             arc t2 b",
            "scans 1",
            "maximal-step
             #0 0s: t1 t2 -> {a, b}
             sequential
             #0 0s: t1 t2 -> {a, b}",
        );
    }

    #[test]
    fn a_chain_advances_one_place_per_maximal_step() {
        // Produced tokens are visible only at the next pass under maximal-step; the
        // sequential rule lets t2 use the token t1 has just put in p2.
        check(
            "place p1 1
             place p2
             place p3
             trans t1
             arc p1 t1
             arc t1 p2
             trans t2
             arc p2 t2
             arc t2 p3",
            "scans 3",
            "maximal-step
             #0 0s: t1 -> {p2}
             #1 0.01s: t2 -> {p3}
             #2 0.02s: - -> {p3}
             sequential
             #0 0s: t1 t2 -> {p3}
             #2 0.02s: - -> {p3}",
        );
    }

    #[test]
    fn sequential_depends_on_declaration_order() {
        // The same chain declared downstream first: t2 is tried before t1 has fired, so the
        // sequential rule needs two scans too.
        check(
            "place p1 1
             place p2
             place p3
             trans t2
             arc p2 t2
             arc t2 p3
             trans t1
             arc p1 t1
             arc t1 p2",
            "scans 3",
            "maximal-step
             #0 0s: t1 -> {p2}
             #1 0.01s: t2 -> {p3}
             #2 0.02s: - -> {p3}
             sequential
             #0 0s: t1 -> {p2}
             #1 0.01s: t2 -> {p3}
             #2 0.02s: - -> {p3}",
        );
    }

    #[test]
    fn capacity_counts_tokens_produced_earlier_in_the_step() {
        // t1 and t2 both feed c (capacity 1) from different places: only t1 joins the step.
        check(
            "place a 1
             place b 1
             place c cap 1
             trans t1
             arc a t1
             arc t1 c
             trans t2
             arc b t2
             arc t2 c
             trans out
             arc c out",
            "scans 4",
            "maximal-step
             #0 0s: t1 -> {b, c}
             #1 0.01s: out -> {b}
             #2 0.02s: t2 -> {c}
             #3 0.03s: out -> {}
             sequential
             #0 0s: t1 out -> {b}
             #1 0.01s: t2 out -> {}
             #3 0.03s: - -> {}",
        );
    }

    #[test]
    fn consumption_by_another_transition_does_not_free_capacity_in_the_step() {
        // c is full; `take` empties it in the same pass in which `put` would refill it. Under
        // maximal-step `put` is judged on the start marking (c full) and waits a pass; the
        // sequential rule sees c empty by then.
        check(
            "place a 1
             place c 1 cap 1
             place d
             trans take
             arc c take
             arc take d
             trans put
             arc a put
             arc put c",
            "scans 2",
            "maximal-step
             #0 0s: take -> {a, d}
             #1 0.01s: put -> {c, d}
             sequential
             #0 0s: take put -> {c, d}
             #1 0.01s: take -> {d:2}",
        );
    }

    #[test]
    fn sipn_capacity_one_waits_for_the_output_place_to_empty() {
        // Seed 002 (SIPN): a transition fires only when its output places are empty. With
        // capacity 1 on every place of a ring, a token cannot move onto a marked place.
        check(
            "place p1 1 cap 1
             place p2 1 cap 1
             place p3 cap 1
             trans t1
             arc p1 t1
             arc t1 p2
             trans t2
             arc p2 t2
             arc t2 p3
             trans t3
             arc p3 t3
             arc t3 p1",
            "scans 3",
            "maximal-step
             #0 0s: t2 -> {p1, p3}
             #1 0.01s: t1 -> {p2, p3}
             #2 0.02s: t3 -> {p1, p2}
             sequential
             #0 0s: t2 -> {p1, p3}
             #1 0.01s: t1 t3 -> {p1, p2}
             #2 0.02s: t2 -> {p1, p3}",
        );
    }

    #[test]
    fn read_arc_sees_tokens_taken_earlier_in_the_step() {
        // `take` (first) consumes s; `look` reads s, judged on the marking left by `take`.
        // Declared the other way round, `look` reads first and both fire.
        check(
            "place s 1
             place a
             place b
             trans take
             arc s take
             arc take a
             trans look
             arc s look read
             arc look b",
            "scans 1",
            "maximal-step
             #0 0s: take -> {a}
             sequential
             #0 0s: take -> {a}",
        );
        check(
            "place s 1
             place a
             place b
             trans look
             arc s look read
             arc look b
             trans take
             arc s take
             arc take a",
            "scans 1",
            "maximal-step
             #0 0s: look take -> {a, b}
             sequential
             #0 0s: look take -> {a, b}",
        );
    }

    #[test]
    fn inhibitor_arc_sees_tokens_taken_earlier_in_the_step() {
        // `take` empties s first, so `quiet` (inhibited by a token in s) joins the same step.
        check(
            "place s 1
             place a
             place q
             trans take
             arc s take
             arc take a
             trans quiet
             arc s quiet inhibit
             arc quiet q",
            "scans 1",
            "maximal-step
             #0 0s: take quiet -> {a, q}
             sequential
             #0 0s: take quiet -> {a, q}",
        );
    }

    #[test]
    fn self_loop_on_a_full_place_is_allowed() {
        // Seed 004's postset check "with respect to the preset if self-loops are connected".
        check(
            "place c 1 cap 1
             place n
             trans spin
             arc c spin
             arc spin c
             arc spin n",
            "scans 2",
            "maximal-step
             #0 0s: spin -> {c, n}
             #1 0.01s: spin -> {c, n:2}
             sequential
             #0 0s: spin -> {c, n}
             #1 0.01s: spin -> {c, n:2}",
        );
    }
}

mod inputs_and_outputs {
    //! Reading inputs and writing outputs around the evolution: input places mirror their
    //! signal clamped to [0, capacity] (seed 004's `max(min(INPUT,CAPACITY),0)`), guards read
    //! input signals, bool outputs are the OR of their places, int outputs show one marking.

    use super::*;

    fn check(net: &str, script: &str, expect: &str) {
        assert_trace(&trace(&build(net), script), expect);
    }

    #[test]
    fn bool_input_place_mirrors_its_signal_clamped_to_one() {
        check(
            "place in in B
             place idle 1
             trans go
             arc in go read
             arc idle go
             arc go idle",
            "scans 4
             at 0: B=0
             at 1: B=1
             at 2: B=7
             at 3: B=-1",
            "#0 0s B=0: - -> {idle}
             #1 0.01s B=1: go -> {in, idle}
             #2 0.02s B=7: go -> {in, idle}
             #3 0.03s B=-1: - -> {idle}",
        );
    }

    #[test]
    fn int_input_place_mirrors_its_signal_clamped_to_its_capacity() {
        // `enough` tests Level ≥ 3 with a read arc, `full` is inhibited at Level ≥ 5.
        check(
            "signal Level in int
             place lvl cap 5 in Level
             place e
             place f
             trans enough
             arc lvl enough x3 read
             arc enough e
             trans notfull
             arc lvl notfull x5 inhibit
             arc notfull f",
            "scans 4
             at 0: Level=2
             at 1: Level=3
             at 2: Level=9
             at 3: Level=-4",
            "#0 0s Level=2: notfull -> {lvl:2, f}
             #1 0.01s Level=3: enough notfull -> {lvl:3, e, f:2}
             #2 0.02s Level=9: enough -> {lvl:5, e:2, f:2}
             #3 0.03s Level=-4: notfull -> {e:2, f:3}",
        );
    }

    #[test]
    fn int_input_place_without_capacity_takes_any_non_negative_value() {
        check(
            "signal Count in int
             place c in Count
             trans zero
             arc c zero inhibit",
            "scans 2
             at 0: Count=123456
             at 1: Count=-1",
            "#0 0s Count=123456: - -> {c:123456}
             #1 0.01s Count=-1: zero -> {}",
        );
    }

    #[test]
    fn guards_read_input_signals_of_the_same_scan() {
        check(
            "signal Level in int
             place p 1
             place q
             trans fwd if Start AND NOT Stop
             arc p fwd
             arc fwd q
             trans back if Level >= 3 OR Reset
             arc q back
             arc back p",
            "scans 7
             at 0: Start=1 Stop=1
             at 1: Stop=0
             at 2: Level=2
             at 3: Level=3
             at 4: Start=0 Level=0
             at 5: Start=1
             at 6: Reset=1",
            "#0 0s Start=1 Stop=1: - -> {p}
             #1 0.01s Stop=0: fwd -> {q}
             #2 0.02s Level=2: - -> {q}
             #3 0.03s Level=3: back -> {p}
             #4 0.04s Start=0 Level=0: - -> {p}
             #5 0.05s Start=1: fwd -> {q}
             #6 0.06s Reset=1: back -> {p}",
        );
    }

    #[test]
    fn bool_output_is_the_or_of_its_places_and_int_output_a_marking() {
        // Outputs are computed after the evolution, so they show the marking the scan
        // reached, and `Busy` stays TRUE while the token moves from a to b.
        check(
            "signal Count out int
             place a 1 out Busy
             place b out Busy
             place done 1 out Count
             trans ab if Go
             arc a ab
             arc ab b
             trans bd if Go
             arc b bd
             arc bd done",
            "scans 3
             at 0: Go=0
             at 1: Go=1",
            "#0 0s Go=0: - -> {a, done} | Count=1 Busy=1
             #1 0.01s Go=1: ab -> {b, done} | Count=1 Busy=1
             #2 0.02s: bd -> {done:2} | Count=2 Busy=0",
        );
    }

    #[test]
    fn inputs_are_read_before_and_outputs_written_after_the_net_evolves() {
        // In one scan the input place is refreshed, `on` copies it into `lamp`, and the output
        // already shows the result: from sensor to lamp in one scan.
        check(
            "place in in Sensor
             place lamp cap 1 out Lamp
             trans on
             arc in on read
             arc lamp on inhibit
             arc on lamp
             trans off
             arc in off inhibit
             arc lamp off",
            "scans 3
             at 0: Sensor=1
             at 2: Sensor=0",
            "#0 0s Sensor=1: on -> {in, lamp} | Lamp=1
             #2 0.02s Sensor=0: off -> {} | Lamp=0",
        );
    }
}

mod evolution {
    //! `one-pass` against `until-stable` (seed 004's Algorithm 1, seed 002's "firing until
    //! stable"), and the bound on passes that turns a cycling net into `ScanError::Unstable`.

    use super::*;

    fn check(net: &str, script: &str, expect: &str) {
        assert_trace(&trace(&build(net), script), expect);
    }

    const CHAIN: &str = "place p1 1
                         place p2
                         place p3
                         place p4
                         trans t1 if Go
                         arc p1 t1
                         arc t1 p2
                         trans t2
                         arc p2 t2
                         arc t2 p3
                         trans t3
                         arc p3 t3
                         arc t3 p4";

    #[test]
    fn until_stable_passes_until_nothing_fires() {
        // Three firing passes and the fourth that finds nothing to fire.
        check(
            &format!("evolve until-stable\n{CHAIN}"),
            "scans 3
             at 1: Go=1",
            "#0 0s: - -> {p1} (1 passes)
             #1 0.01s Go=1: t1 t2 t3 -> {p4} (4 passes)
             #2 0.02s: - -> {p4} (1 passes)",
        );
    }

    #[test]
    fn one_pass_takes_a_scan_per_step() {
        check(
            &format!("evolve one-pass\n{CHAIN}"),
            "scans 5
             at 1: Go=1",
            "#0 0s: - -> {p1}
             #1 0.01s Go=1: t1 -> {p2}
             #2 0.02s: t2 -> {p3}
             #3 0.03s: t3 -> {p4}
             #4 0.04s: - -> {p4}",
        );
    }

    #[test]
    fn until_stable_with_sequential_needs_one_pass_more_to_see_it_is_stable() {
        check(
            &format!("evolve until-stable\nstep sequential\n{CHAIN}"),
            "scans 2
             at 1: Go=1",
            "#0 0s: - -> {p1} (1 passes)
             #1 0.01s Go=1: t1 t2 t3 -> {p4} (2 passes)",
        );
    }

    #[test]
    fn bound_counts_the_pass_that_finds_the_marking_stable() {
        // The chain needs 3 firing passes and a 4th to see that nothing fires.
        let net = format!("evolve until-stable\n{CHAIN}");
        check(
            &net,
            "scans 1
             max-passes 4
             at 0: Go=1",
            "#0 0s Go=1: t1 t2 t3 -> {p4} (4 passes)",
        );
        check(
            &net,
            "scans 1
             max-passes 3
             at 0: Go=1",
            "#0 0s Go=1: error: the net is unstable at t=0s: still firing after 3 passes of one scan \
             (transitions cycling: t2, t3); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
    }

    const CYCLE: &str = "evolve until-stable
                         place start 1
                         place a
                         place b
                         trans boot if Go
                         arc start boot
                         arc boot a
                         trans ab
                         arc a ab
                         arc ab b
                         trans ba
                         arc b ba
                         arc ba a";

    #[test]
    fn unstable_names_the_cycling_transitions_not_the_transient_ones() {
        // `boot` fires once, then ab and ba swap the token forever.
        check(
            CYCLE,
            "scans 2
             at 1: Go=1",
            "#0 0s: - -> {start} (1 passes)
             #1 0.01s Go=1: error: the net is unstable at t=0.01s: still firing after 1000 passes of one scan \
             (transitions cycling: ab, ba); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
    }

    #[test]
    fn unstable_respects_max_passes() {
        // With a bound of 2 the first pass (boot) is in the first half and is left out.
        check(
            CYCLE,
            "scans 1
             max-passes 2
             at 0: Go=1",
            "#0 0s Go=1: error: the net is unstable at t=0s: still firing after 2 passes of one scan \
             (transitions cycling: ab); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
        check(
            CYCLE,
            "scans 1
             max-passes 7
             at 0: Go=1",
            "#0 0s Go=1: error: the net is unstable at t=0s: still firing after 7 passes of one scan \
             (transitions cycling: ab, ba); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
    }

    #[test]
    fn unstable_names_every_transition_of_a_long_cycle() {
        // `fill` moves one token per pass for 40 passes, then `empty` moves all 40 back: a
        // 41-pass cycle in which `empty` fires once. Both keep the net from settling.
        check(
            "evolve until-stable
             place a 40
             place b
             trans fill
             arc a fill
             arc fill b
             trans empty
             arc b empty x40
             arc empty a x40",
            "scans 1",
            "#0 0s: error: the net is unstable at t=0s: still firing after 1000 passes of one scan \
             (transitions cycling: fill, empty); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
    }

    #[test]
    fn an_unbounded_generator_is_unstable() {
        check(
            "evolve until-stable
             place n
             trans gen if Go
             arc gen n",
            "scans 2
             max-passes 10
             at 1: Go=1",
            "#0 0s: - -> {} (1 passes)
             #1 0.01s Go=1: error: the net is unstable at t=0.01s: still firing after 10 passes of one scan \
             (transitions cycling: gen); break the cycle with a guard or an inhibitor arc, or use --evolve one-pass",
        );
    }
}

mod timers {
    //! Delayed arcs (seed 002's arc delays, seed 003's TON per timed place): an arc holds once
    //! its place has held its weight continuously for the delay, timers sampling the marking
    //! at the start of every pass at the scan's time.

    use super::*;

    fn check(net: &str, script: &str, expect: &str) {
        assert_trace(&trace(&build(net), script), expect);
    }

    #[test]
    fn delay_first_holds_at_the_scan_where_it_has_elapsed() {
        // Token present from t = 0, 10 ms period: 0.5 s have elapsed at scan #50.
        check(
            "place p 1
             place q
             trans t
             arc p t after 0.5
             arc t q",
            "scans 60",
            "#0 0s: - -> {p}
             #50 0.5s: t -> {q}
             #59 0.59s: - -> {q}",
        );
    }

    #[test]
    fn a_token_produced_in_a_scan_starts_its_timer_at_the_next_scan() {
        // `arrive` puts the token in p at scan #0; the timer first sees it at scan #1
        // (t = 0.01 s), so the delay holds at 0.51 s.
        check(
            "place s 1
             place p
             place q
             trans arrive
             arc s arrive
             arc arrive p
             trans t
             arc p t after T#500ms
             arc t q",
            "scans 60",
            "#0 0s: arrive -> {p}
             #51 0.51s: t -> {q}
             #59 0.59s: - -> {q}",
        );
    }

    #[test]
    fn until_stable_samples_timers_at_every_pass() {
        // The same net evolving until stable: pass 2 of scan #0 samples p at t = 0, so the
        // delay holds one scan earlier than with one-pass.
        check(
            "evolve until-stable
             place s 1
             place p
             place q
             trans arrive
             arc s arrive
             arc arrive p
             trans t
             arc p t after T#500ms
             arc t q",
            "scans 51",
            "#0 0s: arrive -> {p} (2 passes)
             #50 0.5s: t -> {q} (2 passes)",
        );
    }

    #[test]
    fn timer_restarts_when_the_place_empties() {
        // The token leaves p at #3 and is back at the end of #4: the timer restarts at #5.
        check(
            "place p 1
             place away
             place q
             trans leave if Out
             arc p leave
             arc leave away
             trans back if In
             arc away back
             arc back p
             trans t
             arc p t after 0.1
             arc t q",
            "scans 20
             at 3: Out=1
             at 4: Out=0 In=1
             at 5: In=0",
            "#0 0s: - -> {p}
             #3 0.03s Out=1: leave -> {away}
             #4 0.04s Out=0 In=1: back -> {p}
             #5 0.05s In=0: - -> {p}
             #15 0.15s: t -> {q}
             #19 0.19s: - -> {q}",
        );
    }

    #[test]
    fn read_arc_delay_on_an_input_place_debounces() {
        // The button must be held 50 ms: the glitch at #2..#3 restarts the timer, the press
        // from #5 on fires at #10.
        check(
            "place button in B
             place idle 1
             place pressed
             trans press
             arc button press read after T#50ms
             arc idle press
             arc press pressed",
            "scans 12
             at 2: B=1
             at 4: B=0
             at 5: B=1",
            "#0 0s: - -> {idle}
             #2 0.02s B=1: - -> {button, idle}
             #4 0.04s B=0: - -> {idle}
             #5 0.05s B=1: - -> {button, idle}
             #10 0.1s: press -> {button, pressed}
             #11 0.11s: - -> {button, pressed}",
        );
    }

    #[test]
    fn weighted_delay_needs_the_whole_weight_for_the_delay() {
        // The arc needs 2 tokens for 30 ms: the clock starts when the second has arrived
        // (produced in #1, seen at #2, t = 0.02 s), not with the first, so it holds at 0.05 s.
        check(
            "place p
             place q
             trans add if Add
             arc add p
             trans t
             arc p t x2 after T#30ms
             arc t q",
            "scans 8
             at 0: Add=1
             at 2: Add=0",
            "#0 0s Add=1: add -> {p}
             #1 0.01s: add -> {p:2}
             #2 0.02s Add=0: - -> {p:2}
             #5 0.05s: t -> {q}
             #7 0.07s: - -> {q}",
        );
    }

    #[test]
    fn time_going_backwards_is_an_error() {
        let net = build("place p 1");
        let mut s = Scanner::new(&net, ScanOptions::of(&net));
        let mut signals = [];
        s.scan(Duration::from_millis(20), &mut signals).unwrap();
        // The same time again is fine (two scans in the same clock tick).
        s.scan(Duration::from_millis(20), &mut signals).unwrap();
        let e = s.scan(Duration::from_millis(10), &mut signals).unwrap_err();
        assert_eq!(
            e.to_string(),
            "time went backwards: a scan at 0.01s after one at 0.02s"
        );
    }
}

mod overflow {
    //! A place without capacity has no capacity condition; passing `u32::MAX` tokens is
    //! `ScanError::Overflow` under both step rules, and the marking is left as it was.

    use super::*;

    fn check(step: StepRule, expect: &str) {
        let net = build(&format!(
            "step {step}
             place src 1
             place big 4294967295
             trans t
             arc src t
             arc t big"
        ));
        let mut s = Scanner::new(&net, ScanOptions::of(&net));
        let e = s.scan(Duration::from_millis(30), &mut []).unwrap_err();
        let got = format!("{e}; marking {:?}", s.marking().0);
        assert_eq!(got, expect);
    }

    #[test]
    fn maximal_step_reports_overflow() {
        check(
            StepRule::MaximalStep,
            "at t=0.03s: place big: more than 4294967295 tokens; marking [1, 4294967295]",
        );
    }

    #[test]
    fn sequential_reports_overflow() {
        check(
            StepRule::Sequential,
            "at t=0.03s: place big: more than 4294967295 tokens; marking [1, 4294967295]",
        );
    }
}

mod blockers {
    //! `Scanner::blockers`: why a transition cannot fire now, one reason per failed condition.

    use super::*;

    /// Runs the script, then lists each transition's blockers at the time of the last scan.
    fn check(net: &str, script: &str, expect: &str) {
        let net = build(net);
        let mut scanner = Scanner::new(&net, ScanOptions::of(&net));
        let mut signals = vec![0i64; net.signals().len()];
        let mut now = Duration::ZERO;
        for line in script.lines().map(str::trim).filter(|l| !l.is_empty()) {
            let (t, sets) = line.split_once(':').unwrap_or((line, ""));
            now = parse_duration(t).unwrap();
            for a in sets.split_whitespace() {
                let (name, v) = a.split_once('=').unwrap();
                signals[net.signal_by_name(name).unwrap().index()] = v.parse().unwrap();
            }
            scanner.scan(now, &mut signals).unwrap();
        }
        let mut out = format!("marking {}\n", show_marking(&net, scanner.marking()));
        for t in net.transition_ids() {
            let b: Vec<String> = scanner
                .blockers(t, now, &signals)
                .iter()
                .map(ToString::to_string)
                .collect();
            let b = if b.is_empty() {
                "can fire".to_string()
            } else {
                b.join("; ")
            };
            writeln!(out, "{}: {b}", net.transition_label(t)).unwrap();
        }
        assert_trace(&out, expect);
    }

    #[test]
    fn each_condition_explains_itself() {
        check(
            "place p 1
             place two 1
             place stop 2
             place full 1 cap 1
             place slow 1
             place out
             trans guarded if A AND NOT B
             arc p guarded
             trans hungry
             arc two hungry x2
             arc p hungry read
             trans stopped
             arc stop stopped x2 inhibit
             trans overfill
             arc p overfill
             arc overfill full
             trans waiting
             arc slow waiting after 0.5
             arc waiting out
             trans free
             arc p free read
             arc free out
             trans many
             arc two many x3
             arc stop many inhibit",
            "0
             0.2: B=1",
            "marking {p, two, stop:2, full, slow, out:2}
             guarded: guard `A AND NOT B` is false
             hungry: two holds 1, needs 2
             stopped: stop holds 2, inhibitor allows fewer than 2
             overfill: full would hold 2, capacity 1
             waiting: slow must hold its tokens 0.3s longer
             free: can fire
             many: two holds 1, needs 3; stop holds 2, inhibitor allows fewer than 1",
        );
    }

    #[test]
    fn an_unbounded_place_is_never_a_capacity_blocker() {
        // Firing would overflow the token counter, which is an error when it happens, not a
        // reason to wait.
        check(
            "place p 1
             place q 4294967295
             trans t
             arc p t
             arc t q",
            "",
            "marking {p, q:4294967295}
             t: can fire",
        );
    }
}

mod determinism {
    //! The same net, inputs and times give the same trace: no hash order, no clock, no
    //! randomness; a cloned scanner continues exactly like the original.

    use super::*;

    const NET: &str = "place a 2 cap 3 out X
                       place b cap 2
                       place c
                       trans t1 if I0
                       arc a t1
                       arc t1 b
                       trans t2 if I1 OR NOT I0
                       arc a t2
                       arc t2 c
                       trans t3
                       arc b t3 after T#20ms
                       arc t3 a
                       trans t4 if I1
                       arc c t4
                       arc b t4 inhibit
                       arc t4 a";

    fn check(step: &str) {
        let net = build(&format!("step {step}\n{NET}"));
        // Inputs from a fixed linear congruential sequence.
        let mut x: u32 = 12345;
        let mut script = String::from("scans 200\n");
        for k in 0..200 {
            x = x.wrapping_mul(1_103_515_245).wrapping_add(12_345);
            writeln!(script, "at {k}: I0={} I1={}", (x >> 16) & 1, (x >> 17) & 1).unwrap();
        }
        let first = trace(&net, &script);
        assert_eq!(first, trace(&net, &script));
        assert_eq!(
            first,
            trace(&build(&format!("step {step}\n{NET}")), &script)
        );
        assert!(
            first.lines().filter(|l| !l.contains(": - ->")).count() > 20,
            "the net should be busy:\n{first}"
        );

        // A clone taken mid-run continues like the original.
        let mut s = Scanner::new(&net, ScanOptions::of(&net));
        let mut signals = vec![0i64; net.signals().len()];
        let input = |k: u64, signals: &mut Vec<i64>| {
            signals[net.signal_by_name("I0").unwrap().index()] = i64::from(k % 3 == 0);
            signals[net.signal_by_name("I1").unwrap().index()] = i64::from(k % 5 < 2);
        };
        for k in 0..50u64 {
            input(k, &mut signals);
            s.scan(Duration::from_millis(10 * k), &mut signals).unwrap();
        }
        let mut c = s.clone();
        let mut signals_c = signals.clone();
        for k in 50..150u64 {
            input(k, &mut signals);
            input(k, &mut signals_c);
            s.scan(Duration::from_millis(10 * k), &mut signals).unwrap();
            c.scan(Duration::from_millis(10 * k), &mut signals_c)
                .unwrap();
            assert_eq!(
                (s.marking(), s.fired(), &signals),
                (c.marking(), c.fired(), &signals_c)
            );
        }
    }

    #[test]
    fn maximal_step_runs_are_identical() {
        check("maximal-step");
    }

    #[test]
    fn sequential_runs_are_identical() {
        check("sequential");
    }
}
