//! The five big Model Checking Contest models (0.7 to 6.1 million states), with liveness, and the two unbounded models whose coverability analysis is slow in a debug
//! build. Release builds only: `cargo test --release -p petriplc-reach --test mcc_big`.
#![cfg(not(debug_assertions))]

mod common;

#[test]
fn big_mcc_models_match_the_contest() {
    let mut rows = Vec::new();
    for name in common::models() {
        if common::big(&name) {
            rows.push(common::check(&name, 0));
            println!("{}", rows.last().unwrap());
        }
    }
    assert_eq!(rows.len(), 7, "5 big bounded and 2 unbounded models");
}
