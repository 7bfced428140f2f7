//! Helpers shared by the code generation tests: the examples as nets, and validation of
//! PLCopen XML with xmllint against the TC6 v2.01 schema in testdata/schemas/plcopen.
#![allow(dead_code)]

pub mod random;

use std::io::Write;
use std::process::{Command, Stdio};

use petriplc_net::Net;
use petriplc_pnml::{Naming, ReadOptions};

pub const SCHEMA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../testdata/schemas/plcopen/tc6_xml_v201.xsd"
);
pub const EXAMPLES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../examples");

/// A fixed creation time, so generated files are reproducible in tests.
pub const CREATED: &str = "2026-01-01T00:00:00";

/// The examples, by name, with the naming convention each is written in.
pub const EXAMPLE_NETS: &[(&str, &str, bool)] = &[
    ("mixer", "mixer/mixer.pnml", true),
    ("tank", "mixer/tank.pnml", false),
    ("blink", "blink/blink.pnml", false),
    ("philosophers", "philosophers/philosophers.pnml", false),
    ("keyboard", "keyboard/keyboard.pnml", false),
    ("busy-beaver", "busy-beaver/busy-beaver.pnml", false),
];

/// Reads example `name` (see [`EXAMPLE_NETS`]).
pub fn example(name: &str) -> Net {
    let &(_, path, sipn) = EXAMPLE_NETS
        .iter()
        .find(|e| e.0 == name)
        .unwrap_or_else(|| panic!("no example {name}"));
    let options = ReadOptions {
        naming: if sipn { Naming::Sipn } else { Naming::Plain },
    };
    petriplc_pnml::read_file(
        std::path::Path::new(&format!("{EXAMPLES}/{path}")),
        &options,
    )
    .unwrap_or_else(|e| panic!("{path}: {e}"))
    .net
}

/// Validates a PLCopen XML document against tc6_xml_v201.xsd.
pub fn xmllint(doc: &str) -> Result<(), String> {
    let child = Command::new("xmllint")
        .args(["--noout", "--schema", SCHEMA, "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => panic!(
            "cannot run xmllint ({e}); these tests validate generated PLCopen XML: \
             apt-get install libxml2-utils"
        ),
    };
    child
        .stdin
        .take()
        .expect("stdin is piped")
        .write_all(doc.as_bytes())
        .expect("xmllint reads its input");
    let out = child.wait_with_output().expect("xmllint runs");
    if out.status.success() {
        Ok(())
    } else {
        Err(format!(
            "xmllint --schema {SCHEMA}:\n{}",
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}

/// Nets that leave a block of the generated code with nothing to do: no places, no
/// transitions, no outputs, no inputs, a transition that moves no token. Generated code must
/// still be valid (no empty statement lists, no label without an instruction) and mean
/// what the simulator does.
pub fn degenerate_nets() -> Vec<(&'static str, Net)> {
    use petriplc_testnet::net;
    vec![
        ("empty", net("")),
        ("signals only", net("s B in bool\ns Y out bool")),
        ("places only", net("p a 1 >A\np b 0")),
        (
            "no outputs",
            net("s B in bool\np a 1\np b 0\nt go a -> b if B\nt back b -> a"),
        ),
        ("no inputs, one place", net("p a 0 >A\nt fill -> a")),
        (
            "moves no token",
            net("s B in bool\np a 1 >A\nt look ?a -> if B"),
        ),
        (
            "timer, no outputs",
            net("p a 1\np b 0 cap=1\nt t1 a@20ms -> b\nt t2 b -> a"),
        ),
    ]
}
