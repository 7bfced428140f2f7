//! Helpers shared by the integration tests: where the test data is (testdata/), xmllint, and
//! random valid nets.

// Each test crate uses a different part of these helpers.
#![allow(dead_code)]

pub mod nets;

use std::io::Write;
use std::process::{Command, Stdio};

/// The PNML grammars (testdata/schemas/pnml).
pub const SCHEMAS: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../testdata/schemas/pnml"
);
/// petriplc's own grammar for nets with read arcs.
pub const READ_SCHEMA: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../../docs/schemas/readinhibitorptnet.pntd"
);

/// Validates `doc` against the RELAX NG grammar `schema` with xmllint; the error is
/// xmllint's report.
pub fn xmllint(schema: &str, doc: &str) -> Result<(), String> {
    let child = Command::new("xmllint")
        .args(["--noout", "--relaxng", schema, "-"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn();
    let mut child = match child {
        Ok(c) => c,
        Err(e) => panic!(
            "cannot run xmllint ({e}); these tests validate what petriplc writes against the \
             PNML grammars: apt-get install libxml2-utils"
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
            "xmllint --relaxng {schema}:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ))
    }
}
