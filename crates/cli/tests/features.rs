//! A binary built without some of its cargo features (crates/cli/Cargo.toml) still knows
//! the module kinds and commands it left out, and says which feature brings each back.
//! These tests describe the build they run in: with every feature (the default) they check
//! that nothing is refused; `cargo test -p petriplc --no-default-features --test features`
//! checks the refusals.

use assert_cmd::Command;
use predicates::prelude::*;

const MIXER: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../examples/mixer/plc.conf");

fn petriplc() -> Command {
    Command::cargo_bin("petriplc").unwrap()
}

/// `petriplc run` of the mixer for a tenth of a second (its Modbus server, vitrine and HMI are
/// built-in kinds from three features).
fn mixer() -> assert_cmd::assert::Assert {
    petriplc()
        .args(["run", MIXER, "--for", "100ms", "--plc-id"])
        .arg(format!("test-features-{}", std::process::id()))
        .args(["--set", "modbus:listen=127.0.0.1:0"])
        .args(["--set", "hmi:listen=127.0.0.1:0"])
        .assert()
}

#[cfg(not(any(feature = "modbus", feature = "vitrine", feature = "hmi")))]
#[test]
fn a_module_kind_left_out_names_its_feature_and_nothing_starts() {
    mixer()
        .code(2)
        .stderr(predicate::str::contains(
            "module modbus: `modbus_server` is a built-in module kind, but this petriplc was \
             built without its `modbus` feature",
        ))
        .stderr(predicate::str::contains("--features modbus"))
        .stderr(predicate::str::contains("--features vitrine"))
        .stderr(predicate::str::contains("--features hmi"))
        .stderr(predicate::str::contains("nothing was started"));
}

#[cfg(all(feature = "modbus", feature = "vitrine", feature = "hmi"))]
#[test]
fn no_module_kind_is_refused_for_a_feature_in_the_full_build() {
    mixer()
        .success()
        .stderr(predicate::str::contains("--features").not());
}

#[cfg(not(feature = "opcua"))]
#[test]
fn user_without_opcua_names_the_feature() {
    petriplc()
        .args(["user", "remove", "users.txt", "someone"])
        .assert()
        .code(2)
        .stderr(predicate::str::contains(
            "built without its `opcua` feature; rebuild with `cargo build --release -p \
             petriplc --features opcua`",
        ));
}
