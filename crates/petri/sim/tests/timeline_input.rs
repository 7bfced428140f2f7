//! Any text as a timeline: parsed without a panic, and a timeline that is accepted never
//! holds a value that is not finite (the PLC refuses NaN and infinities at every boundary).

use petriplc_sim::{NonFinite, Timeline};
use proptest::prelude::*;

fn cell() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|f| f.to_string()),
        any::<i64>().prop_map(|i| i.to_string()),
        "(?i)(nan|[+-]?inf(inity)?|1e3[0-9]{2}|-0|true|false|T#[0-9]{1,3}ms|)",
        "[0-9.eE+-]{0,30}",
        ".{0,12}",
    ]
}

fn timeline() -> impl Strategy<Value = String> {
    (
        prop::collection::vec("[A-Za-z][A-Za-z0-9_]{0,6}", 1..4),
        prop::collection::vec((0u32..100, prop::collection::vec(cell(), 0..5)), 0..20),
    )
        .prop_map(|(names, rows)| {
            let mut t = format!("time,{}\n", names.join(","));
            for (time, cells) in rows {
                t.push_str(&format!("{time},{}\n", cells.join(",")));
            }
            t
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(500))]
    #[test]
    fn accepted_timelines_hold_only_finite_values(text in prop_oneof![timeline(), ".{0,300}"]) {
        let _ = Timeline::parse(&text, "t.csv");
        if let Ok(tl) = Timeline::parse_decimal(&text, "t.csv") {
            for c in 0..tl.columns().len() {
                for &(_, v) in tl.decimal_changes(c).unwrap_or_default() {
                    prop_assert!(v.is_finite(), "{v} in\n{text}");
                }
            }
        }
        // Accepting them is a choice the configuration makes, for tests.
        let _ = Timeline::parse_decimal_with(&text, "t.csv", NonFinite::Accept);
    }
}
