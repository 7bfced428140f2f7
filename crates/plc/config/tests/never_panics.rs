//! Arbitrary text never makes the reader panic, and whatever it accepts keeps the model's
//! promises (one writer per point, every owner declared).

use std::collections::HashSet;
use std::path::Path;

use proptest::prelude::*;

use petriplc_config::parse_str;

/// Words and fragments of configuration syntax, so random lines often get deep into the
/// parser rather than failing on the first character.
fn fragment() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("[PLC]".to_string()),
        Just("[m]".to_string()),
        Just("\n".to_string()),
        Just("\n".to_string()),
        Just("point".to_string()),
        Just("module".to_string()),
        Just("place".to_string()),
        Just("transition".to_string()),
        Just("arc".to_string()),
        Just("synch".to_string()),
        Just("synch_start".to_string()),
        Just("*include x.conf".to_string()),
        Just("m:".to_string()),
        Just("=".to_string()),
        Just("at".to_string()),
        Just("init".to_string()),
        // Values that no point may hold, and sizes past every limit.
        Just("nan".to_string()),
        Just("-inf".to_string()),
        Just("1e39".to_string()),
        Just("99999999999999999999999".to_string()),
        Just("safe".to_string()),
        Just("NULL".to_string()),
        Just("scan_period".to_string()),
        Just("scan_beg".to_string()),
        Just("\"".to_string()),
        Just("#".to_string()),
        Just("\\".to_string()),
        "[a-z]{1,3}",
        "[iuf]?[0-9]{1,3}",
        "[0-9]{1,6}\\.[0-9]{1,3}",
        "-?\\(?[0-9]{0,2}\\)?-?>",
        "[ \t]{1,2}",
        "\\PC{1,4}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn fragments_never_panic(parts in prop::collection::vec(fragment(), 0..80)) {
        let text = parts.join(" ");
        check(&text);
    }

    #[test]
    fn any_text_never_panics(text in "\\PC*") {
        check(&text);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Extreme sizes and values: names and numbers thousands of characters long, values a
    /// float cannot hold, thousands of rows; every problem a coded diagnostic on its line.
    #[test]
    fn hostile_sizes_never_panic(
        n in prop_oneof![1usize..100, 1_000usize..20_000],
        value in prop::sample::select(vec![
            "NaN", "inf", "-inf", "1e39", "1e400", "-0", "99999999999999999999999", "0x", "T#9999999999999d",
        ]),
        shape in 0u8..5,
    ) {
        let text = match shape {
            0 => format!("[PLC]\nmodule m shutdown\npoint {} \"d\" m\n", "p".repeat(n)),
            1 => format!("[PLC]\nmodule m shutdown\npoint p \"d\" m f32 init {value}\n"),
            2 => format!("[PLC]\nmodule m shutdown\npoint p \"d\" m u16 init {}\n", "9".repeat(n)),
            3 => format!("[PLC]\nmodule m shutdown\n{}", (0..n).map(|i| format!("point p{i} \"d\" m\n")).collect::<String>()),
            _ => format!("[PLC]\nmodule m shutdown\nplace {}\n[m]\nscan_period = {value}\n", "q".repeat(n)),
        };
        check(&text);
    }

    /// Chains of `*include` of any length, some in a circle: every chain read or refused
    /// (C002 for a circle, C009 past the depth limit), never a stack overflow.
    #[test]
    fn include_chains_of_any_length(n in prop_oneof![1usize..70, 100usize..3_000], back in any::<Option<usize>>()) {
        let dir = tempfile::tempdir().unwrap();
        for i in 0..n {
            let text = match (i + 1 < n, back) {
                (true, _) => format!("*include c{}.conf\n", i + 1),
                (false, Some(b)) => format!("*include c{}.conf\n", b % n),
                (false, None) => "[PLC]\nmodule m shutdown\n".into(),
            };
            std::fs::write(dir.path().join(format!("c{i}.conf")), text).unwrap();
        }
        match petriplc_config::read_file(&dir.path().join("c0.conf")) {
            Ok(_) => prop_assert!(n <= petriplc_config::raw::MAX_INCLUDE_DEPTH && back.is_none()),
            Err(e) => {
                let codes = e.codes();
                prop_assert!(codes == vec!["C002"] || codes == vec!["C009"], "{e}");
                prop_assert_eq!(codes[0] == "C009", n > petriplc_config::raw::MAX_INCLUDE_DEPTH);
            }
        }
    }
}

fn check(text: &str) {
    let lines = text.lines().count().max(1);
    match parse_str(text, "p.conf", Path::new("/nonexistent-dir")) {
        Ok(c) => {
            let modules: HashSet<&str> = c.modules.iter().map(|m| m.name.as_str()).collect();
            let mut names = HashSet::new();
            for p in &c.points {
                assert!(modules.contains(p.owner.as_str()), "{text}");
                assert!(names.insert(&p.name), "{text}");
                assert!((1..=32).contains(&p.bits), "{text}");
                if let Some((_, bit)) = p.at {
                    assert!(u32::from(bit) + u32::from(p.bits) <= 32, "{text}");
                }
                if let petriplc_config::PointValue::Float(f) = p.init {
                    assert!(f.is_finite(), "{text}");
                }
            }
        }
        Err(e) => {
            assert!(!e.diagnostics.is_empty());
            for d in &e.diagnostics {
                assert_eq!(d.span.file, "p.conf");
                assert!((1..=lines).contains(&d.span.line), "{d} in\n{text}");
            }
        }
    }
}
