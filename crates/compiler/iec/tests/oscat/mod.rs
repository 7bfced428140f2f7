//! The OSCAT corpus's manifest (`../shared/corpora/oscat/manifest.json`), read by the
//! conformance tests: each file with its flavour, the files defining what it uses (in
//! dependency order) and where it was taken from.
#![allow(dead_code)]

use std::path::Path;

/// One manifest entry.
pub struct Entry {
    /// The flavour: `oscat_basic`, `oscat_building`, `tcoscat`.
    pub set: String,
    pub file: String,
    pub deps: Vec<String>,
    /// `repository@commit:path` of the original.
    pub source: String,
    /// The POUs the file defines: kind (`FUNCTION`, `FUNCTION_BLOCK`…) and name.
    pub pous: Vec<(String, String)>,
}

/// Every entry of the manifest in the corpus folder `root`.
pub fn manifest(root: &Path) -> Vec<Entry> {
    let text = std::fs::read_to_string(root.join("manifest.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let text = |v: &serde_json::Value| v.as_str().unwrap().to_string();
    json.as_array()
        .unwrap()
        .iter()
        .map(|e| Entry {
            set: text(&e["set"]),
            file: text(&e["file"]),
            deps: e["deps"].as_array().unwrap().iter().map(text).collect(),
            source: text(&e["source"]),
            pous: e["pous"]
                .as_array()
                .map(|ps| ps.iter().map(|p| (text(&p[0]), text(&p[1]))).collect())
                .unwrap_or_default(),
        })
        .collect()
}
