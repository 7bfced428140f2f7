//! Properties on random nets (2–10 places, some with capacities, up to 2 boolean input
//! places, 1–10 transitions with normal, read and inhibitor arcs of weight 1–3): every
//! P-invariant has yᵀC = 0 and keeps y·M along random runs, every T-invariant has Cx = 0,
//! supports are minimal, weights have gcd 1; on tiny nets the invariants match a brute-force
//! enumeration; guard satisfiability matches brute force over a range that the finite-search
//! argument shows is enough.

use petriplc_net::guard::{CmpOp, Expr, Operand};
use petriplc_net::{
    ArcKind, ArcSpec, Net, NetBuilder, PlaceId, PlaceSpec, SignalDirection, SignalId, SignalType,
    TransitionId, TransitionSpec,
};
use petriplc_structure::{p_invariants, satisfiable, t_invariants, Invariants, Limits};
use proptest::collection::vec;
use proptest::prelude::*;

#[derive(Clone, Copy, Debug)]
enum Kind {
    Consume,
    Produce,
    Read,
    Inhibit,
}

/// Places (initial, capacity), input places, and per transition its arcs (place, kind,
/// weight); places past the internal ones are input places.
#[derive(Clone, Debug)]
struct Desc {
    places: Vec<(u32, Option<u32>)>,
    inputs: usize,
    transitions: Vec<Vec<(usize, Kind, u32)>>,
}

fn arb_desc(
    places: std::ops::RangeInclusive<usize>,
    transitions: std::ops::RangeInclusive<usize>,
    max_weight: u32,
    special: bool,
) -> impl Strategy<Value = Desc> {
    (places, 0usize..=2, transitions).prop_flat_map(move |(np, ni, nt)| {
        let ni = if special { ni } else { 0 };
        let kind = if special {
            prop_oneof![
                3 => Just(Kind::Consume),
                3 => Just(Kind::Produce),
                1 => Just(Kind::Read),
                1 => Just(Kind::Inhibit)
            ]
            .boxed()
        } else {
            prop_oneof![Just(Kind::Consume), Just(Kind::Produce)].boxed()
        };
        let cap = if special {
            proptest::option::weighted(0.2, 1u32..=4).boxed()
        } else {
            Just(None).boxed()
        };
        (
            vec((0u32..=3, cap), np),
            Just(ni),
            vec(vec((0..np + ni, kind, 1u32..=max_weight), 0..=5), nt),
        )
            .prop_map(|(places, inputs, transitions)| Desc {
                places: places
                    .into_iter()
                    .map(|(m, c)| (c.map_or(m, |c| m.min(c)), c))
                    .collect(),
                inputs,
                transitions,
            })
    })
}

fn build(d: &Desc) -> Net {
    let mut b = NetBuilder::new("random", "random");
    for (i, &(initial, capacity)) in d.places.iter().enumerate() {
        b.place(PlaceSpec {
            id: format!("p{i}"),
            name: format!("p{i}"),
            initial,
            capacity,
            ..Default::default()
        });
    }
    for k in 0..d.inputs {
        b.place(PlaceSpec {
            id: format!("in{k}"),
            name: format!("in{k}"),
            input: Some(format!("I{k}")),
            ..Default::default()
        });
    }
    for (t, arcs) in d.transitions.iter().enumerate() {
        b.transition(TransitionSpec {
            id: format!("t{t}"),
            name: format!("t{t}"),
            guard: Expr::Const(true),
        });
        for (i, &(p, kind, weight)) in arcs.iter().enumerate() {
            let internal = p < d.places.len();
            let place = if internal {
                format!("p{p}")
            } else {
                format!("in{}", p - d.places.len())
            };
            // Only read and inhibitor arcs may touch an input place.
            let kind = match (kind, internal) {
                (Kind::Consume | Kind::Read, false) => Kind::Read,
                (Kind::Produce | Kind::Inhibit, false) => Kind::Inhibit,
                (k, true) => k,
            };
            let (source, target, kind) = match kind {
                Kind::Consume => (place, format!("t{t}"), ArcKind::Normal),
                Kind::Produce => (format!("t{t}"), place, ArcKind::Normal),
                Kind::Read => (place, format!("t{t}"), ArcKind::Read),
                Kind::Inhibit => (place, format!("t{t}"), ArcKind::Inhibitor),
            };
            b.arc(ArcSpec {
                id: format!("a{t}_{i}"),
                source,
                target,
                kind,
                weight,
                delay: None,
            });
        }
    }
    b.build().expect("random nets are valid by construction")
}

/// yᵀC for a P-vector (over places) or Cx for a T-vector, as a dense integer vector.
fn p_product(net: &Net, y: &[(usize, u64)]) -> Vec<i128> {
    net.transition_ids()
        .map(|t| {
            y.iter()
                .map(|&(p, w)| i128::from(w) * i128::from(net.incidence(PlaceId::from(p), t)))
                .sum()
        })
        .collect()
}

fn t_product(net: &Net, x: &[(usize, u64)]) -> Vec<i128> {
    net.place_ids()
        .map(|p| {
            x.iter()
                .map(|&(t, w)| i128::from(w) * i128::from(net.incidence(p, TransitionId::from(t))))
                .sum()
        })
        .collect()
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Sorted sparse vectors with positive weights of gcd 1, sorted as a list, no support
/// inside another's.
fn check_shape(inv: &Invariants) -> Result<(), TestCaseError> {
    prop_assert!(inv.complete, "{:?}", inv.reason);
    let mut sorted = inv.vectors.clone();
    sorted.sort();
    prop_assert_eq!(&sorted, &inv.vectors);
    for v in &inv.vectors {
        prop_assert!(!v.is_empty());
        prop_assert!(v.windows(2).all(|w| w[0].0 < w[1].0), "{:?}", v);
        prop_assert!(v.iter().all(|&(_, w)| w > 0));
        prop_assert_eq!(v.iter().fold(0, |g, &(_, w)| gcd(g, w)), 1, "{:?}", v);
    }
    for (i, a) in inv.vectors.iter().enumerate() {
        for (j, b) in inv.vectors.iter().enumerate() {
            if i != j {
                let within = a.iter().all(|(p, _)| b.iter().any(|(q, _)| p == q));
                prop_assert!(!within, "support of {:?} lies in that of {:?}", a, b);
            }
        }
    }
    Ok(())
}

/// A deterministic pseudo-random sequence from a proptest-chosen seed.
fn next(seed: &mut u64) -> u64 {
    *seed ^= *seed << 13;
    *seed ^= *seed >> 7;
    *seed ^= *seed << 17;
    *seed
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    #[test]
    fn invariants_are_invariant(d in arb_desc(2..=10, 1..=10, 3, true), seed in 1u64..) {
        let net = build(&d);
        let p = p_invariants(&net, Limits::default());
        let t = t_invariants(&net, Limits::default());
        check_shape(&p)?;
        check_shape(&t)?;
        for y in &p.vectors {
            prop_assert!(p_product(&net, y).iter().all(|&v| v == 0), "yᵀC ≠ 0 for {:?}", y);
            prop_assert!(y.iter().all(|&(q, _)| net.place(PlaceId::from(q)).input.is_none()));
        }
        for x in &t.vectors {
            prop_assert!(t_product(&net, x).iter().all(|&v| v == 0), "Cx ≠ 0 for {:?}", x);
        }
        // y·M stays y·M0 along a random interleaving run.
        let value = |y: &[(usize, u64)], m: &[u32]| -> u128 {
            y.iter().map(|&(q, w)| u128::from(w) * u128::from(m[q])).sum()
        };
        let m0 = net.initial_marking();
        let mut m = m0.clone();
        let mut seed = seed;
        for _ in 0..30 {
            let enabled: Vec<TransitionId> =
                net.transition_ids().filter(|&t| net.is_enabled(&m, t)).collect();
            if enabled.is_empty() {
                break;
            }
            let t = enabled[(next(&mut seed) % enabled.len() as u64) as usize];
            if net.fire(&mut m, t).is_err() {
                break;
            }
            for y in &p.vectors {
                prop_assert_eq!(value(y, &m.0), value(y, &m0.0));
            }
        }
    }

    /// On tiny nets, against every vector with weights 0–3: each semiflow found by brute
    /// force has a returned invariant inside its support, and each returned invariant with
    /// weights ≤ 3 is one of the brute-force semiflows of minimal support.
    #[test]
    fn tiny_nets_match_brute_force(d in arb_desc(2..=4, 1..=4, 2, false)) {
        let net = build(&d);
        let n_p = net.places().len();
        let n_t = net.transitions().len();
        for (inv, n, product) in [
            (p_invariants(&net, Limits::default()), n_p, p_product as fn(&Net, &[(usize, u64)]) -> Vec<i128>),
            (t_invariants(&net, Limits::default()), n_t, t_product),
        ] {
            check_shape(&inv)?;
            let mut brute: Vec<Vec<(usize, u64)>> = Vec::new();
            for code in 1..4u64.pow(n as u32) {
                let v: Vec<(usize, u64)> = (0..n)
                    .map(|i| (i, code / 4u64.pow(i as u32) % 4))
                    .filter(|&(_, w)| w > 0)
                    .collect();
                if product(&net, &v).iter().all(|&x| x == 0) {
                    brute.push(v);
                }
            }
            let support = |v: &[(usize, u64)]| v.iter().map(|x| x.0).collect::<Vec<_>>();
            let within = |a: &[usize], b: &[usize]| a.iter().all(|i| b.contains(i));
            for b in &brute {
                prop_assert!(
                    inv.vectors.iter().any(|f| within(&support(f), &support(b))),
                    "semiflow {:?} has no returned invariant in its support {:?}", b, inv.vectors
                );
            }
            for f in inv.vectors.iter().filter(|f| f.iter().all(|&(_, w)| w <= 3)) {
                prop_assert!(brute.contains(f), "{:?} is not a semiflow", f);
                prop_assert!(
                    brute.iter().all(|b| !within(&support(b), &support(f)) || support(b) == support(f)),
                    "{:?} is not of minimal support", f
                );
            }
        }
    }
}

/// x, y are integers; b, c booleans.
fn guard_net() -> Net {
    let mut b = NetBuilder::new("g", "g");
    b.signal("x", SignalDirection::Input, SignalType::Int)
        .signal("y", SignalDirection::Input, SignalType::Int)
        .signal("b", SignalDirection::Input, SignalType::Bool)
        .signal("c", SignalDirection::Input, SignalType::Bool);
    b.build().unwrap()
}

fn arb_expr() -> impl Strategy<Value = Expr<SignalId>> {
    // Sparse literals leave gaps that hold one, two or more integers.
    let operand = prop_oneof![
        3 => (0u32..2).prop_map(|s| Operand::Signal(SignalId(s))),
        1 => (2u32..4).prop_map(|s| Operand::Signal(SignalId(s))),
        3 => prop::sample::select(vec![-6i64, -2, 0, 1, 3, 6]).prop_map(Operand::Literal),
    ];
    let op = prop_oneof![
        Just(CmpOp::Eq),
        Just(CmpOp::Ne),
        Just(CmpOp::Lt),
        Just(CmpOp::Le),
        Just(CmpOp::Gt),
        Just(CmpOp::Ge),
    ];
    let leaf = prop_oneof![
        1 => any::<bool>().prop_map(Expr::Const),
        2 => (0u32..4).prop_map(|s| Expr::Signal(SignalId(s))),
        5 => (operand.clone(), op, operand).prop_map(|(a, o, b)| Expr::Cmp(a, o, b)),
    ];
    // Conjunctions of (possibly negated) atoms are where the integer ranges get tight.
    let literal = prop_oneof![
        leaf.clone(),
        leaf.clone().prop_map(|e| Expr::Not(Box::new(e)))
    ];
    let conjunction = vec(literal, 2..=5).prop_map(|atoms| {
        atoms
            .into_iter()
            .reduce(|a, b| Expr::And(Box::new(a), Box::new(b)))
            .expect("at least two atoms")
    });
    let tree = leaf.prop_recursive(4, 24, 2, |inner| {
        prop_oneof![
            inner.clone().prop_map(|e| Expr::Not(Box::new(e))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Expr::And(Box::new(a), Box::new(b))),
            (inner.clone(), inner.clone()).prop_map(|(a, b)| Expr::Or(Box::new(a), Box::new(b))),
            (inner.clone(), inner).prop_map(|(a, b)| Expr::Xor(Box::new(a), Box::new(b))),
        ]
    });
    prop_oneof![tree, conjunction]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    /// Literals lie in −6…6 and at most two integer signals are compared, so by the argument
    /// in `satisfy.rs` every satisfiable guard has a model with integers in −8…8: brute force
    /// over −9…9 decides it.
    #[test]
    fn satisfiable_matches_brute_force(e in arb_expr()) {
        let net = guard_net();
        let mut model = None;
        'search: for x in -9..=9 {
            for y in -9..=9 {
                for b in 0..=1 {
                    for c in 0..=1 {
                        let v = [x, y, b, c];
                        if e.eval(&|s: &SignalId| v[s.index()]) {
                            model = Some(v);
                            break 'search;
                        }
                    }
                }
            }
        }
        match satisfiable(&e, &net) {
            Some(w) => {
                let mut v = [0i64; 4];
                for &(s, x) in &w {
                    v[s.index()] = x;
                }
                prop_assert!(v[2] <= 1 && v[2] >= 0 && v[3] <= 1 && v[3] >= 0, "booleans are 0/1");
                prop_assert!(e.eval(&|s: &SignalId| v[s.index()]), "witness {:?} is not a model", w);
                prop_assert!(model.is_some(), "brute force found no model, we found {:?}", w);
            }
            None => prop_assert!(model.is_none(), "missed the model {:?}", model),
        }
    }
}
