//! matiec's copy of an OSCAT POU's sources, changed where matiec's stricter reading of the
//! standard refuses what does not change the meaning:
//! - The PCWorx export declares every type in one file, and some structures there have
//!   STRING fields, which matiec's grammar (the second edition's) has no room for; matiec gets
//!   only the declarations the POU uses (transitively), so a POU that uses none of those
//!   structures compiles.
//! - matiec takes no derived string type (`oscat_STRING10 : STRING[10]`) in a declaration:
//!   its name is replaced by `STRING[10]`, and by `STRING` as a function's result type, where
//!   matiec takes no length (a result longer than the declared one would then differ; none
//!   was seen).
//! - OSCAT's PCWorx flavour declares functions that PCWorx lacks and matiec has (TIME_TO_REAL,
//!   UDINT_TO_TIME…): petriplc takes a declaration over the standard function (W001), matiec's
//!   C defines both; matiec's copy calls OSCAT's one `…_OSCAT` ([`rename_word`]).
//! - An instance named as its function block (`T_PLC_US : T_PLC_US;`), which matiec refuses
//!   as ambiguous, is renamed `T_PLC_US_INST` in that file.

use std::collections::HashSet;

fn words(s: &str) -> impl Iterator<Item = String> + '_ {
    s.split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
        .map(str::to_ascii_uppercase)
}

/// `text` without its `(* … *)` comments (OSCAT's do not nest).
fn uncommented(text: &str) -> String {
    let mut out = String::new();
    let mut rest = text;
    while let Some(i) = rest.find("(*") {
        out.push_str(&rest[..i]);
        out.push(' ');
        rest = match rest[i + 2..].find("*)") {
            Some(j) => &rest[i + 2 + j + 2..],
            None => "",
        };
    }
    out.push_str(rest);
    out
}

/// The declarations of a types file: each with its name and text (`name : … ;`).
fn declarations(types: &str) -> Vec<(String, String)> {
    let text = uncommented(types);
    let mut out = Vec::new();
    let mut inside = false;
    let mut depth = 0i32;
    let mut cur = String::new();
    for token in split_keep(&text) {
        let upper = token.to_ascii_uppercase();
        match upper.as_str() {
            "TYPE" if !inside => {
                inside = true;
                cur.clear();
            }
            "END_TYPE" => {
                if !cur.trim().is_empty() {
                    out.push(std::mem::take(&mut cur));
                }
                inside = false;
            }
            _ if inside => {
                match upper.as_str() {
                    "STRUCT" => depth += 1,
                    "END_STRUCT" => depth -= 1,
                    _ => {}
                }
                cur.push_str(token);
                if token == ";" && depth == 0 {
                    out.push(std::mem::take(&mut cur));
                }
            }
            _ => {}
        }
    }
    out.into_iter()
        .filter_map(|d| {
            let name = words(&d).next()?;
            Some((name, d))
        })
        .collect()
}

/// Words, `;`, and the text between them, in order (concatenated they are `text`).
fn split_keep(text: &str) -> Vec<&str> {
    let mut out = Vec::new();
    let mut start = 0;
    let bytes = text.as_bytes();
    let word = |b: u8| b.is_ascii_alphanumeric() || b == b'_';
    let mut i = 0;
    while i < bytes.len() {
        let j = if word(bytes[i]) {
            let mut j = i;
            while j < bytes.len() && word(bytes[j]) {
                j += 1;
            }
            j
        } else if bytes[i] == b';' {
            i + 1
        } else {
            let mut j = i;
            while j < bytes.len() && !word(bytes[j]) && bytes[j] != b';' {
                j += 1;
            }
            j
        };
        if start < i {
            out.push(&text[start..i]);
        }
        out.push(&text[i..j]);
        start = j;
        i = j;
    }
    out
}

/// The derived string types of a types file: upper-case name and length.
pub fn string_types(types: &str) -> Vec<(String, u32)> {
    declarations(types)
        .iter()
        .filter_map(|(name, text)| {
            let w: Vec<String> = words(text).collect();
            match w.as_slice() {
                [_, s, n] if s == "STRING" => Some((name.clone(), n.parse().ok()?)),
                _ => None,
            }
        })
        .collect()
}

/// `text` with each derived string type of `strings` written out.
pub fn write_strings(text: &str, strings: &[(String, u32)]) -> String {
    if strings.is_empty() {
        return text.to_string();
    }
    let mut out = String::new();
    let mut last: Vec<String> = Vec::new(); // the last three significant tokens
    for t in split_keep(text) {
        let upper = t.to_ascii_uppercase();
        match strings.iter().find(|s| s.0 == upper) {
            Some((_, n)) => {
                let result = last.len() == 3 && last[0] == "FUNCTION" && last[2] == ":";
                if result {
                    out.push_str("STRING");
                } else {
                    out.push_str(&format!("STRING[{n}]"));
                }
            }
            None => out.push_str(t),
        }
        if !t.trim().is_empty() {
            last.push(upper.trim().to_string());
            if last.len() > 3 {
                last.remove(0);
            }
        }
    }
    out
}

/// The types file cut to the declarations `used` (the other sources' text) needs, without
/// its derived string types (written out where they are used: [`write_strings`]).
pub fn prune_types(types: &str, used: &str) -> String {
    let strings = string_types(types);
    let decls: Vec<(String, String)> = declarations(types)
        .into_iter()
        .filter(|(n, _)| !strings.iter().any(|s| &s.0 == n))
        .map(|(n, t)| (n, write_strings(&t, &strings)))
        .collect();
    let mut need: HashSet<String> = words(&uncommented(used)).collect();
    let mut keep = vec![false; decls.len()];
    loop {
        let mut changed = false;
        for (i, (name, text)) in decls.iter().enumerate() {
            if !keep[i] && need.contains(name) {
                keep[i] = true;
                need.extend(words(text));
                changed = true;
            }
        }
        if !changed {
            break;
        }
    }
    let kept: Vec<&str> = decls
        .iter()
        .zip(&keep)
        .filter(|(_, k)| **k)
        .map(|((_, t), _)| t.trim())
        .collect();
    if kept.is_empty() {
        String::new()
    } else {
        format!("TYPE\n  {}\nEND_TYPE\n", kept.join("\n  "))
    }
}

/// `file` with every instance named as its function block renamed.
pub fn rename_instances(file: &str) -> String {
    let text = uncommented(file);
    let tokens = split_keep(&text);
    let mut same = HashSet::new();
    let significant: Vec<&str> = tokens
        .iter()
        .copied()
        .filter(|t| !t.trim().is_empty())
        .collect();
    for w in significant.windows(4) {
        if w[1].trim() == ":"
            && w[3] == ";"
            && w[0].eq_ignore_ascii_case(w[2])
            && w[0].chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        {
            same.insert(w[0].to_ascii_uppercase());
        }
    }
    if same.is_empty() {
        return file.to_string();
    }
    // Every use becomes the new name; the declaration's type goes back to the block's.
    let mut out = String::new();
    let mut after_colon = None::<String>;
    let mut member = false;
    for t in split_keep(file) {
        let upper = t.to_ascii_uppercase();
        let was_member = std::mem::replace(&mut member, t.trim_end().ends_with('.'));
        // `inst.OUT`: an output named as the block is not the instance.
        if same.contains(&upper) && !was_member {
            if after_colon.as_deref() == Some(upper.as_str()) {
                out.push_str(t);
                after_colon = None;
                continue;
            }
            out.push_str(t);
            out.push_str("_INST");
            after_colon = Some(upper);
            continue;
        }
        if after_colon.is_some() && !t.trim().is_empty() && t.trim() != ":" {
            after_colon = None;
        }
        out.push_str(t);
    }
    out
}

/// `text` with the word `from` (any case) replaced by `to`.
pub fn rename_word(text: &str, from: &str, to: &str) -> String {
    split_keep(text)
        .into_iter()
        .map(|t| if t.eq_ignore_ascii_case(from) { to } else { t })
        .collect()
}
