//! The process image end to end: module maps exchanging values through `update()` over real
//! POSIX shared memory, ownership, bit-exact masking, threads and a second process.

use std::sync::atomic::{AtomicU32, Ordering};

use petriplc_config::{Location, ModuleDecl, Origin, PlcConfig, PointDecl, PointKind, PointValue};
use petriplc_runtime::image::{GlobalMap, ImageError, Layout, ModuleMap};
use proptest::prelude::*;

/// A plc id no other test (or concurrent test run) uses.
fn plc_id(test: &str) -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!(
        "t{}-{test}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    )
}

fn module(name: &str) -> ModuleDecl {
    ModuleDecl::new(name, "test")
}

fn point(name: &str, owner: &str, kind: PointKind, bits: u8, at: Option<(u32, u8)>) -> PointDecl {
    PointDecl {
        name: name.into(),
        description: String::new(),
        owner: owner.into(),
        at,
        kind,
        bits,
        init: match kind {
            PointKind::Float => PointValue::Float(0.0),
            _ => PointValue::Unsigned(0),
        },
        retain: false,
        origin: Origin::default(),
    }
}

fn config(modules: &[&str], points: Vec<PointDecl>) -> PlcConfig {
    PlcConfig {
        modules: modules.iter().map(|m| module(m)).collect(),
        points,
        ..Default::default()
    }
}

fn basic() -> Layout {
    let mut n = point("n", "a", PointKind::Signed, 12, None);
    n.init = PointValue::Signed(-5);
    Layout::new(&config(
        &["a", "b", "display"],
        vec![
            point("x", "a", PointKind::Unsigned, 1, None),
            point("y", "b", PointKind::Unsigned, 1, None),
            n,
            point("f", "b", PointKind::Float, 32, None),
            point("c", "b", PointKind::Unsigned, 8, None),
        ],
    ))
    .unwrap()
}

#[test]
fn modules_exchange_values_only_through_update() {
    let layout = basic();
    let global = GlobalMap::create(&plc_id("exchange"), &layout).unwrap();
    let mut a = ModuleMap::new(&layout, "a", Location::Local).unwrap();
    let mut b = ModuleMap::new(&layout, "b", Location::Local).unwrap();
    let (x, n, f) = (
        a.handle("x").unwrap(),
        a.handle("n").unwrap(),
        a.handle("f").unwrap(),
    );
    assert_eq!(b.get_i32(&n), -5, "init values before any update");

    a.set_bool(&x, true).unwrap();
    a.set_i32(&n, -2048).unwrap();
    b.set_f32(&f, 2.5).unwrap();
    b.update(&global);
    assert!(!b.get_bool(&x), "a has not updated yet");
    a.update(&global);
    assert_eq!(a.get_f32(&f), 2.5, "b's update came in with a's");
    assert!(!b.get_bool(&x), "b has not updated since");
    b.update(&global);
    assert!(b.get_bool(&x));
    assert_eq!(b.get_i32(&n), -2048, "sign-extended from 12 bits");
    assert_eq!(b.get_u32(&n), 0x800);
    assert_eq!(b.get(&n), PointValue::Signed(-2048));

    // A module's own writes survive an update that brings others' in.
    a.set_bool(&x, false).unwrap();
    a.update(&global);
    assert!(!a.get_bool(&x));
    let id = layout.point("x").unwrap();
    assert_eq!(global.read_point(&layout, id), PointValue::Unsigned(0));
    let id = layout.point("f").unwrap();
    assert_eq!(global.read_point(&layout, id), PointValue::Float(2.5));
}

#[test]
fn a_module_cannot_write_what_it_does_not_own() {
    let layout = basic();
    let mut a = ModuleMap::new(&layout, "a", Location::Local).unwrap();
    let mut display = ModuleMap::new(&layout, "display", Location::Local).unwrap();
    let y = a.handle("y").unwrap();
    match a.set_bool(&y, true) {
        Err(ImageError::NotOwner {
            point,
            owner,
            module,
        }) => assert_eq!((&*point, &*owner, &*module), ("y", "b", "a")),
        other => panic!("expected NotOwner, got {other:?}"),
    }
    assert!(!a.get_bool(&y));
    let x = display.handle("x").unwrap();
    let e = display.set_bool(&x, true).unwrap_err().to_string();
    assert_eq!(
        e,
        "module `display` may not write point `x`: it is owned by `a`"
    );
    assert!(!a.owns(&y) && a.owns(&x));
}

#[test]
fn values_are_checked_against_the_point() {
    let layout = basic();
    let mut a = ModuleMap::new(&layout, "a", Location::Local).unwrap();
    let mut b = ModuleMap::new(&layout, "b", Location::Local).unwrap();
    let (x, n, c, f) = (
        a.handle("x").unwrap(),
        a.handle("n").unwrap(),
        b.handle("c").unwrap(),
        b.handle("f").unwrap(),
    );
    assert!(matches!(
        a.set_u32(&x, 2),
        Err(ImageError::OutOfRange { .. })
    ));
    assert!(a.set_i32(&n, 2047).is_ok());
    assert!(a.set_i32(&n, 2048).is_err());
    assert!(a.set_i32(&n, -2049).is_err());
    assert!(a.set_u32(&n, 2047).is_ok());
    assert!(b.set_u32(&c, 255).is_ok());
    let e = b.set_u32(&c, 256).unwrap_err().to_string();
    assert_eq!(e, "point `c` (unsigned, 8 bits) cannot hold 256");
    assert!(b.set_i32(&c, -1).is_err());
    assert!(matches!(
        b.set_u32(&f, 1),
        Err(ImageError::WrongKind { .. })
    ));
    assert!(b.set_bool(&f, true).is_err());
    assert!(a.set_f32(&x, 1.0).is_err());
    assert_eq!(b.get_u32(&c), 255, "failed writes change nothing");
}

#[test]
fn unknown_names_and_modules_are_explained() {
    let layout = basic();
    let a = ModuleMap::new(&layout, "a", Location::Local).unwrap();
    let e = a.handle("z").unwrap_err().to_string();
    assert!(e.starts_with("no point named `z`"), "{e}");
    let e = ModuleMap::new(&layout, "nobody", Location::Local)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`nobody`") && e.contains("a, b, display"), "{e}");
    let e = ModuleMap::new(&layout, "a", Location::Isolate).unwrap_err();
    assert!(matches!(e, ImageError::Unsupported { .. }), "{e}");
}

#[test]
fn masking_is_bit_exact_within_a_shared_word() {
    // Three owners interleaved in one word, plus a neighbour word, all fixed.
    let mut points = Vec::new();
    for bit in 0..32u8 {
        let owner = ["a", "b", "c"][usize::from(bit) % 3];
        points.push(point(
            &format!("w0b{bit}"),
            owner,
            PointKind::Unsigned,
            1,
            Some((0, bit)),
        ));
    }
    points.push(point("w1lo", "a", PointKind::Unsigned, 16, Some((1, 0))));
    points.push(point("w1hi", "b", PointKind::Unsigned, 16, Some((1, 16))));
    let layout = Layout::new(&config(&["a", "b", "c"], points)).unwrap();
    let global = GlobalMap::create(&plc_id("mask"), &layout).unwrap();
    let mut maps: Vec<ModuleMap> = ["a", "b", "c"]
        .iter()
        .map(|m| ModuleMap::new(&layout, m, Location::Local).unwrap())
        .collect();
    let masks: Vec<u32> = maps.iter().map(|m| m.mask()[0]).collect();
    assert_eq!(masks[0] | masks[1] | masks[2], u32::MAX);
    assert_eq!(masks[0] & masks[1], 0);

    // Every module sets all its bits, one after another; each must only add its own.
    let mut expect = 0u32;
    for (i, m) in maps.iter_mut().enumerate() {
        for bit in 0..32 {
            let h = m.handle(&format!("w0b{bit}")).unwrap();
            if m.owns(&h) {
                m.set_bool(&h, true).unwrap();
            }
        }
        m.update(&global);
        expect |= masks[i];
        assert_eq!(global.lock().words()[0], expect);
    }
    // A module whose private copy is stale (it has not seen the others' bits) clears only
    // its own bits.
    let b = &mut maps[1];
    for bit in 0..32 {
        let h = b.handle(&format!("w0b{bit}")).unwrap();
        if b.owns(&h) {
            b.set_bool(&h, false).unwrap();
        }
    }
    let hi = b.handle("w1hi").unwrap();
    b.set_u32(&hi, 0xBEEF).unwrap();
    b.update(&global);
    assert_eq!(global.lock().words()[0], !masks[1]);
    assert_eq!(global.lock().words()[1], 0xBEEF_0000);
    maps[0].update(&global);
    let lo = maps[0].handle("w1lo").unwrap();
    assert_eq!(maps[0].get_u32(&hi), 0xBEEF);
    assert_eq!(maps[0].get_u32(&lo), 0);
}

#[test]
fn shared_modules_write_the_global_map_directly_but_masked() {
    let layout = basic();
    let global = GlobalMap::create(&plc_id("shared"), &layout).unwrap();
    let mut a = ModuleMap::new(&layout, "a", Location::Shared).unwrap();
    let mut b = ModuleMap::new(&layout, "b", Location::Local).unwrap();
    let (x, y) = (a.handle("x").unwrap(), a.handle("y").unwrap());
    a.set_bool(&x, true).unwrap();
    a.update(&global); // attaches
    assert!(global.read_point(&layout, x.id()) == PointValue::Unsigned(1));
    a.set_bool(&x, false).unwrap();
    assert_eq!(
        global.read_point(&layout, x.id()),
        PointValue::Unsigned(0),
        "written through at once"
    );
    assert!(a.set_bool(&y, true).is_err());
    b.set_bool(&y, true).unwrap();
    b.update(&global);
    assert!(a.get_bool(&y), "reads the global map");
    a.update(&global); // does nothing, but is allowed
    assert!(a.get_bool(&y) && !a.get_bool(&x));
}

#[test]
fn a_forced_point_reads_forced_for_everyone_but_its_owner_until_released() {
    let layout = basic();
    let global = GlobalMap::create(&plc_id("force"), &layout).unwrap();
    let mut a = ModuleMap::new(&layout, "a", Location::Local).unwrap();
    let mut b = ModuleMap::new(&layout, "b", Location::Local).unwrap();
    let mut display = ModuleMap::new(&layout, "display", Location::Local).unwrap();
    let (x, n, c, f) = (
        a.handle("x").unwrap(),
        a.handle("n").unwrap(),
        a.handle("c").unwrap(),
        a.handle("f").unwrap(),
    );
    a.set_bool(&x, false).unwrap();
    a.set_i32(&n, 7).unwrap();
    a.update(&global);

    // A module that owns nothing forces points of two other owners, sharing words with
    // unforced points.
    display.force(&x, PointValue::Unsigned(1)).unwrap();
    display.force(&n, PointValue::Signed(-3)).unwrap();
    display.force(&f, PointValue::Float(1.5)).unwrap();
    assert!(!display.is_forced(&x), "requests wait for the next update");
    display.update(&global);
    assert!(display.is_forced(&x) && display.is_forced(&n) && !display.is_forced(&c));
    assert_eq!(global.read_point(&layout, x.id()), PointValue::Unsigned(1));
    assert!(display.get_bool(&x));
    assert_eq!(
        global.read_point(&layout, n.id()),
        PointValue::Signed(-3),
        "displays reading the global map see the force too"
    );

    // The owner goes on writing: others still read the forced value, the owner its own.
    a.set_bool(&x, false).unwrap();
    a.set_i32(&n, 9).unwrap();
    a.update(&global);
    b.set_u32(&c, 200).unwrap();
    b.update(&global);
    assert!(b.get_bool(&x) && b.is_forced(&x));
    assert_eq!(b.get_i32(&n), -3);
    assert_eq!(
        b.get_u32(&c),
        200,
        "unforced bits of the word are untouched"
    );
    assert_eq!(b.get_f32(&f), 0.0, "the owner (b) reads its own value...");
    assert!(!a.get_bool(&x) && a.get_i32(&n) == 9, "...and so does a");
    assert!(a.is_forced(&x), "though it knows the point is forced");

    // Values are checked as for set; an isolated map cannot force (tested in isolate.rs).
    assert!(display.force(&c, PointValue::Unsigned(256)).is_err());
    assert!(display.force(&x, PointValue::Float(1.0)).is_err());

    // Released by another module: the owner's value is back at once.
    b.unforce(&x).unwrap();
    b.unforce(&n).unwrap();
    b.update(&global);
    assert!(!b.is_forced(&x));
    assert!(!b.get_bool(&x));
    display.update(&global);
    assert!(!display.get_bool(&x));
    assert_eq!(display.get_i32(&n), 9);
    assert_eq!(display.get_f32(&f), 1.5, "still forced");
    b.set_f32(&f, 4.0).unwrap();
    b.update(&global);
    display.update(&global);
    assert_eq!(display.get_f32(&f), 1.5);
    display.unforce(&f).unwrap();
    display.update(&global);
    assert_eq!(display.get_f32(&f), 4.0);
    assert!(!display.is_forced(&f));
}

#[test]
fn shared_maps_force_at_once() {
    let layout = basic();
    let global = GlobalMap::create(&plc_id("forceshared"), &layout).unwrap();
    let mut a = ModuleMap::new(&layout, "a", Location::Shared).unwrap();
    let mut display = ModuleMap::new(&layout, "display", Location::Shared).unwrap();
    a.update(&global);
    display.update(&global);
    let x = a.handle("x").unwrap();
    display.force(&x, PointValue::Unsigned(1)).unwrap();
    assert!(display.is_forced(&x) && a.is_forced(&x));
    a.set_bool(&x, false).unwrap();
    assert!(display.get_bool(&x), "a shared reader sees the force");
    assert!(!a.get_bool(&x), "the owner its own value");
    assert_eq!(global.read_point(&layout, x.id()), PointValue::Unsigned(1));
    display.unforce(&x).unwrap();
    assert!(!display.get_bool(&x));
}

#[test]
fn two_threads_updating_one_word_never_lose_a_bit() {
    let mut points = Vec::new();
    for bit in 0..32u8 {
        let owner = if bit % 2 == 0 { "even" } else { "odd" };
        points.push(point(
            &format!("b{bit}"),
            owner,
            PointKind::Unsigned,
            1,
            None,
        ));
    }
    let layout = Layout::new(&config(&["even", "odd"], points)).unwrap();
    assert_eq!(layout.words(), 1);
    let global = GlobalMap::create(&plc_id("threads"), &layout).unwrap();
    const ROUNDS: u32 = 20_000;

    let workers: Vec<_> = ["even", "odd"]
        .into_iter()
        .map(|name| {
            let (layout, global) = (layout.clone(), global.clone());
            std::thread::spawn(move || {
                let mut m = ModuleMap::new(&layout, name, Location::Local).unwrap();
                let mine: Vec<_> = (0..32)
                    .map(|b| m.handle(&format!("b{b}")).unwrap())
                    .filter(|h| m.owns(h))
                    .collect();
                let pattern = |m: &ModuleMap| {
                    mine.iter()
                        .enumerate()
                        .fold(0u32, |acc, (i, h)| acc | (u32::from(m.get_bool(h)) << i))
                };
                for round in 1..=ROUNDS {
                    let want = round.wrapping_mul(0x9E37) & 0xFFFF;
                    for (i, h) in mine.iter().enumerate() {
                        m.set_bool(h, want >> i & 1 == 1).unwrap();
                    }
                    m.update(&global);
                    // A second update reads back what the global map now holds for our bits:
                    // a lost write by the other thread would show here.
                    m.update(&global);
                    assert_eq!(pattern(&m), want, "{name}: round {round}");
                }
                pattern(&m)
            })
        })
        .collect();
    let finals: Vec<u32> = workers.into_iter().map(|w| w.join().unwrap()).collect();
    let last = ROUNDS.wrapping_mul(0x9E37) & 0xFFFF;
    assert_eq!(finals, vec![last, last]);
    let spread =
        |v: u32, offset: u32| (0..16).fold(0, |acc, i| acc | ((v >> i & 1) << (2 * i + offset)));
    assert_eq!(global.lock().words()[0], spread(last, 0) | spread(last, 1));
}

const CHILD_ENV: &str = "PETRIPLC_IMAGE_TEST_CHILD";

fn two_process_layout() -> Layout {
    Layout::new(&config(
        &["parent", "child"],
        vec![
            point("to_child", "parent", PointKind::Unsigned, 16, None),
            point("to_parent", "child", PointKind::Signed, 16, None),
            point("child_done", "child", PointKind::Unsigned, 1, None),
        ],
    ))
    .unwrap()
}

/// Runs only as the child of `another_process_sees_the_same_map` (a plain `cargo test`
/// passes at once).
#[test]
fn child_process_entry() {
    let Ok(id) = std::env::var(CHILD_ENV) else {
        return;
    };
    let layout = two_process_layout();
    let global = GlobalMap::open(&id).unwrap();
    global.check_layout(&layout).unwrap();
    let mut m = ModuleMap::new(&layout, "child", Location::Local).unwrap();
    m.update(&global);
    let got = m.get_u32(&m.handle("to_child").unwrap());
    assert_eq!(got, 4321, "the parent's value, through the shared memory");
    m.set_i32(&m.handle("to_parent").unwrap(), -1234).unwrap();
    m.set_bool(&m.handle("child_done").unwrap(), true).unwrap();
    m.update(&global);
}

#[test]
fn another_process_sees_the_same_map() {
    let id = plc_id("fork");
    let layout = two_process_layout();
    let global = GlobalMap::create(&id, &layout).unwrap();
    let mut m = ModuleMap::new(&layout, "parent", Location::Local).unwrap();
    m.set_u32(&m.handle("to_child").unwrap(), 4321).unwrap();
    m.update(&global);

    let out = std::process::Command::new(std::env::current_exe().unwrap())
        .args([
            "child_process_entry",
            "--exact",
            "--nocapture",
            "--test-threads=1",
        ])
        .env(CHILD_ENV, &id)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "child failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let (to_parent, done) = (
        m.handle("to_parent").unwrap(),
        m.handle("child_done").unwrap(),
    );
    assert!(!m.get_bool(&done), "not before our update");
    m.update(&global);
    assert!(m.get_bool(&done));
    assert_eq!(m.get_i32(&to_parent), -1234);
}

#[test]
fn one_plc_id_one_image() {
    let id = plc_id("twice");
    let layout = basic();
    let first = GlobalMap::create(&id, &layout).unwrap();
    let e = GlobalMap::create(&id, &layout).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, ImageError::AlreadyRunning { .. }), "{msg}");
    assert!(msg.contains("already exists") && msg.contains(&id), "{msg}");

    let opened = GlobalMap::open(&id).unwrap();
    assert_eq!(opened.words(), layout.words());
    opened.check_layout(&layout).unwrap();
    let other = Layout::new(&config(
        &["a"],
        vec![point("x", "a", PointKind::Unsigned, 1, None)],
    ))
    .unwrap();
    assert!(matches!(
        opened.check_layout(&other),
        Err(ImageError::LayoutMismatch { .. })
    ));

    drop(first);
    let e = GlobalMap::open(&id).unwrap_err().to_string();
    assert!(
        e.contains("no PLC with id") && e.contains("--plc-id"),
        "{e}"
    );
    // The opener's mapping outlives the name.
    assert_eq!(opened.words(), layout.words());
    let again = GlobalMap::create(&id, &layout).unwrap();
    assert!(GlobalMap::unlink(&id).unwrap());
    assert!(!GlobalMap::unlink(&id).unwrap());
    drop(again);
}

#[test]
fn bad_plc_ids_are_refused() {
    let layout = basic();
    for bad in ["", "a/b", "with space"] {
        assert!(matches!(
            GlobalMap::create(bad, &layout),
            Err(ImageError::BadPlcId { .. })
        ));
    }
}

#[derive(Clone, Debug)]
enum Op {
    Write { point: usize, value: u32 },
    Update { module: usize },
}

const OWNERS: [&str; 3] = ["m0", "m1", "m2"];

fn kind_of(k: u8) -> PointKind {
    match k {
        0 => PointKind::Unsigned,
        1 => PointKind::Signed,
        _ => PointKind::Float,
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// After a module's update the global map holds the last value it wrote to each of its
    /// points, and once everyone has updated twice every module sees every last value.
    #[test]
    fn update_publishes_every_owners_last_write(
        decls in prop::collection::vec((1u8..=32, 0usize..3, 0u8..3), 1..40),
        ops in prop::collection::vec(
            prop_oneof![
                3 => (0usize..40, any::<u32>()).prop_map(|(point, value)| Op::Write { point, value }),
                1 => (0usize..3).prop_map(|module| Op::Update { module }),
            ],
            0..120,
        ),
        shared in any::<bool>(),
    ) {
        let points: Vec<PointDecl> = decls
            .iter()
            .enumerate()
            .map(|(i, &(bits, owner, kind))| {
                let kind = kind_of(kind);
                let bits = if kind == PointKind::Float { 32 } else { bits };
                point(&format!("p{i}"), OWNERS[owner], kind, bits, None)
            })
            .collect();
        let layout = Layout::new(&config(&OWNERS, points)).unwrap();
        let global = GlobalMap::create(&plc_id("prop"), &layout).unwrap();
        let mut maps: Vec<ModuleMap> = OWNERS
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let loc = if shared && i == 2 { Location::Shared } else { Location::Local };
                ModuleMap::new(&layout, m, loc).unwrap()
            })
            .collect();
        let handles: Vec<_> = (0..decls.len())
            .map(|i| maps[0].handle(&format!("p{i}")).unwrap())
            .collect();
        let mut model = vec![0u32; decls.len()];

        for op in ops {
            match op {
                Op::Write { point, value } => {
                    let Some(h) = handles.get(point) else { continue };
                    let owner = decls[point].1;
                    let m = &mut maps[owner];
                    let raw = if h.bits() == 32 { value } else { value & ((1 << h.bits()) - 1) };
                    match h.kind() {
                        PointKind::Unsigned => m.set_u32(h, raw).unwrap(),
                        PointKind::Signed => {
                            let shift = 32 - u32::from(h.bits());
                            m.set_i32(h, ((raw << shift) as i32) >> shift).unwrap()
                        }
                        PointKind::Float => m.set_f32(h, f32::from_bits(raw)).unwrap(),
                    }
                    model[point] = raw;
                    let other = (owner + 1) % 3;
                    prop_assert!(maps[other].set_u32(h, 0).is_err());
                }
                Op::Update { module } => {
                    maps[module].update(&global);
                    let mut words = Vec::new();
                    global.snapshot(&mut words);
                    for (i, h) in handles.iter().enumerate() {
                        if decls[i].1 == module {
                            let s = layout.slot(h.id());
                            let got = (words[s.word as usize] & s.field_mask()) >> s.bit;
                            prop_assert_eq!(got, model[i], "point p{} after m{}'s update", i, module);
                        }
                    }
                }
            }
        }
        for _ in 0..2 {
            for m in maps.iter_mut() {
                m.update(&global);
            }
        }
        for m in &maps {
            for (i, h) in handles.iter().enumerate() {
                prop_assert_eq!(m.get_u32(h), model[i], "p{} seen by {}", i, m.module());
            }
        }
    }
}
