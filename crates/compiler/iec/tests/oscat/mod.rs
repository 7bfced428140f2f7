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

/// Every entry of the manifest in the corpus folder `root`. A block's EXTENDS base is added
/// to its dependencies (with the base's own, before them): the manifest lists the POUs a file
/// uses, not the block it extends (VOLTAGE_CONTROL extends FB_CONTROL).
pub fn manifest(root: &Path) -> Vec<Entry> {
    let text = std::fs::read_to_string(root.join("manifest.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let text = |v: &serde_json::Value| v.as_str().unwrap().to_string();
    let all = json.as_array().unwrap();
    // (flavour, POU name in upper case) → the entry defining it.
    let mut defines = std::collections::HashMap::new();
    for (i, e) in all.iter().enumerate() {
        for p in e["pous"].as_array().into_iter().flatten() {
            if let Some(name) = p.get(1).and_then(|n| n.as_str()) {
                defines.insert((text(&e["set"]), name.to_ascii_uppercase()), i);
            }
        }
    }
    let mut entries: Vec<Entry> = all
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
        .collect();
    for i in 0..entries.len() {
        let src = std::fs::read_to_string(root.join(&entries[i].file)).unwrap_or_default();
        let Some(base) = extends(&src) else {
            continue;
        };
        let Some(&b) = defines.get(&(entries[i].set.clone(), base)) else {
            continue;
        };
        let mut deps = entries[b].deps.clone();
        deps.push(entries[b].file.clone());
        deps.retain(|d| !entries[i].deps.contains(d) && *d != entries[i].file);
        deps.append(&mut entries[i].deps);
        entries[i].deps = deps;
    }
    entries
}

/// The block named after `EXTENDS` on a source's first line that has one.
fn extends(src: &str) -> Option<String> {
    let line = src
        .lines()
        .find(|l| l.to_ascii_uppercase().contains(" EXTENDS "))?;
    let words: Vec<&str> = line.split_whitespace().collect();
    let at = words
        .iter()
        .position(|w| w.eq_ignore_ascii_case("EXTENDS"))?;
    Some(words.get(at + 1)?.to_ascii_uppercase())
}
