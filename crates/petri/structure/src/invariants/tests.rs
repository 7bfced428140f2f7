//! Unit tests of `invariants.rs`.

use super::*;
use crate::testnet::net;

/// Renders the P-invariants as laws, the T-invariants as firing counts, the structural
/// bounds and the verdict, one line each.
fn check_with(text: &str, limits: Limits, expect: &[&str]) {
    let net = net(text);
    let p = p_invariants(&net, limits);
    let t = t_invariants(&net, limits);
    let mut got: Vec<String> = conservation_laws(&net, &p)
        .into_iter()
        .map(|l| format!("P: {l}"))
        .collect();
    for x in &t.vectors {
        let terms: Vec<String> = x
            .iter()
            .map(|&(i, w)| {
                let name = net.transition_label(TransitionId::from(i));
                if w == 1 {
                    name.to_string()
                } else {
                    format!("{w}·{name}")
                }
            })
            .collect();
        got.push(format!("T: {}", terms.join(" + ")));
    }
    let bounds: Vec<String> = structural_bounds(&net, &p)
        .iter()
        .zip(net.place_ids())
        .map(|(b, q)| {
            let b = b.map_or("-".to_string(), |b| b.to_string());
            format!("{}≤{b}", net.place_label(q))
        })
        .collect();
    got.push(format!("bounds: {}", bounds.join(" ")));
    got.push(format!(
        "structurally bounded: {}",
        structurally_bounded(&net, &p)
    ));
    for (kind, inv) in [("P", &p), ("T", &t)] {
        if let Some(r) = &inv.reason {
            got.push(format!("{kind} incomplete: {r}"));
        }
    }
    assert_eq!(got, expect);
}

fn check(text: &str, expect: &[&str]) {
    check_with(text, Limits::default(), expect)
}

#[test]
fn mutex_has_one_law_per_resource() {
    check(
        "place idle1 1
         place busy1
         place idle2 1
         place busy2
         place lock 1
         trans enter1: idle1 lock -> busy1
         trans leave1: busy1 -> idle1 lock
         trans enter2: idle2 lock -> busy2
         trans leave2: busy2 -> idle2 lock",
        &[
            "P: M(idle1) + M(busy1) = 1",
            "P: M(busy1) + M(busy2) + M(lock) = 1",
            "P: M(idle2) + M(busy2) = 1",
            "T: enter1 + leave1",
            "T: enter2 + leave2",
            "bounds: idle1≤1 busy1≤1 idle2≤1 busy2≤1 lock≤1",
            "structurally bounded: true",
        ],
    );
}

#[test]
fn weights_appear_in_laws_and_bounds() {
    // Two singles make a pair and back: M(single) + 2·M(pair) is constant.
    check(
        "place single 3
         place pair
         trans join: single*2 -> pair
         trans split: pair -> single*2",
        &[
            "P: M(single) + 2·M(pair) = 3",
            "T: join + split",
            "bounds: single≤3 pair≤1",
            "structurally bounded: true",
        ],
    );
}

#[test]
fn a_source_transition_leaves_places_uncovered() {
    check(
        "place a 1
         place b
         trans gen: -> a
         trans move: a -> b",
        &["bounds: a≤- b≤-", "structurally bounded: false"],
    );
}

#[test]
fn read_inhibitor_arcs_and_input_places_do_not_count() {
    // The read and inhibitor arcs change nothing; the input place has no law of its own.
    // Capacities bound places the invariants do not cover.
    check(
        "place go in=Go
         place a 1
         place b
         place log cap=4
         trans t1: a -> b ? go ! log*4
         trans t2: b -> a log ? go",
        &[
            "P: M(a) + M(b) = 1",
            "bounds: go≤1 a≤1 b≤1 log≤4",
            "structurally bounded: false",
        ],
    );
}

#[test]
fn a_self_loop_and_an_isolated_place_are_invariant_alone() {
    check(
        "place a 2
         place alone 7
         trans t: a -> a",
        &[
            "P: M(a) = 2",
            "P: M(alone) = 7",
            "T: t",
            "bounds: a≤2 alone≤7",
            "structurally bounded: true",
        ],
    );
}

#[test]
fn a_shared_place_gives_two_weighted_laws() {
    check(
        "place a 1
         place b
         place c 1
         trans t1: a c -> b*2
         trans t2: b*2 -> a c",
        &[
            "P: 2·M(a) + M(b) = 2",
            "P: M(b) + 2·M(c) = 2",
            "T: t1 + t2",
            "bounds: a≤1 b≤2 c≤1",
            "structurally bounded: true",
        ],
    );
}

#[test]
fn the_row_limit_stops_cleanly_and_keeps_what_is_done() {
    // t alone has 4 × 4 minimal laws a_i + b_j; the x–y loop is a group of its own (one
    // basis vector), so its law is complete whatever the limit does to the a–b group.
    check_with(
        "place a0 1
         place a1 1
         place a2 1
         place a3 1
         place b0
         place b1
         place b2
         place b3
         place x 1
         place y
         trans t: a0 a1 a2 a3 -> b0 b1 b2 b3
         trans f: x -> y
         trans g: y -> x",
        Limits {
            max_rows: 10,
            max_work: u64::MAX,
        },
        &[
            "P: M(x) + M(y) = 1",
            "T: f + g",
            "bounds: a0≤- a1≤- a2≤- a3≤- b0≤- b1≤- b2≤- b3≤- x≤1 y≤1",
            "structurally bounded: false",
            "P incomplete: stopped at 10 intermediate rows after eliminating 0 of 1 distinct transition columns of the incidence matrix; the invariants listed are minimal, but there may be more (raise the row limit)",
        ],
    );
    check_with(
        "place a0 1
         place a1 1
         place b0
         place b1
         trans t: a0 a1 -> b0 b1",
        Limits {
            max_rows: 100,
            max_work: 3,
        },
        &[
            "bounds: a0≤- a1≤- b0≤- b1≤-",
            "structurally bounded: false",
            "P incomplete: stopped after 3 steps after eliminating 0 of 1 distinct transition columns of the incidence matrix; the invariants listed are minimal, but there may be more (raise the work limit)",
        ],
    );
}

#[test]
fn combinations_are_exact_at_64_bits() {
    let mut big = vec![(0, i64::MAX)];
    let mut other = vec![(0, -1)];
    let (a, b) = (1, i128::from(i64::MAX));
    assert_eq!(
        merge(&big, &other, a, b),
        Some(vec![]),
        "i64::MAX·1 + 1·(−1)·i64::MAX = 0"
    );
    big[0].1 = i64::MIN;
    other[0].1 = i64::MIN;
    let two63 = 1i128 << 63;
    assert_eq!(
        merge(&big, &other, two63, two63),
        Some(vec![(0, i128::MIN)])
    );
}
