//! Every Model Checking Contest model of up to 100 000 states, and two of the four unbounded
//! ones, against the contest's answers (the others are in tests/mcc_big.rs, release only).

mod common;

#[test]
fn small_mcc_models_match_the_contest() {
    let mut rows = Vec::new();
    let mut failures = Vec::new();
    for name in common::models() {
        if common::big(&name) {
            continue;
        }
        match std::panic::catch_unwind(|| common::check(&name, 2)) {
            Ok(row) => rows.push(row),
            Err(e) => failures.push(
                e.downcast_ref::<String>()
                    .cloned()
                    .unwrap_or_else(|| format!("{name}: panicked")),
            ),
        }
    }
    println!("{}", rows.join("\n"));
    assert!(failures.is_empty(), "{}", failures.join("\n"));
    assert_eq!(rows.len(), 20, "18 bounded and 2 unbounded models");
}
