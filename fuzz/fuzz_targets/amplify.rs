//! Hostile sizes for the fuzz targets. libFuzzer's mutations rarely build an input nested
//! 20 000 deep or a name 20 000 characters long, which is what overflows stacks and floods
//! terminals; so a target passes its input through [`amplify`]: when the first byte is odd,
//! the next byte picks a template of the target's language (or the input itself, split at
//! `\0` into a prefix, a middle and a suffix), the two after it a repeat count up to 20 000,
//! and the rest fills the template's middle. `{i}` and `{j}` in a template are the level and
//! the next one, so declarations can chain (F0 holds an F1, which holds an F2, …). The result
//! is at most [`MAX_BYTES`] long, which bounds every target's work by input size.

// Each target uses the templates of its own language.
#![allow(dead_code)]

/// The largest amplified input.
pub const MAX_BYTES: usize = 1 << 20;

/// A template: what comes before the middle at every level, and what after.
pub type Template = (&'static str, &'static str, &'static str);

/// Structured Text shapes: nesting of every kind the parser and checker recurse on, long
/// chains, huge names and numbers, literals a REAL cannot hold.
pub const ST: &[Template] = &[
    (
        "PROGRAM p VAR x : DINT; END_VAR x := ",
        "x",
        "; END_PROGRAM",
    ),
    ("(", "x", ")"),
    ("- ", "x", ""),
    ("NOT ", "x", ""),
    ("ABS(", "x", ")"),
    ("x + ", "x", ""),
    ("x AND ", "x", ""),
    ("IF x THEN ", "x := 1;", " END_IF;"),
    ("CASE x OF 1: ", "x := 1;", " END_CASE;"),
    ("FOR x := 1 TO 2 DO ", "x := 1;", " END_FOR;"),
    ("WHILE x DO ", "x := 1;", " END_WHILE;"),
    ("REPEAT ", "x := 1;", " UNTIL x END_REPEAT;"),
    ("ARRAY[0..1] OF ", "INT", ""),
    ("[", "1", "]"),
    ("(s := ", "1", ")"),
    ("x.s", "", ""),
    ("x[1]", "", ""),
    (
        "TYPE S{i} : STRUCT s : S{j}; END_STRUCT; END_TYPE\n",
        "",
        "",
    ),
    ("TYPE A{i} : ARRAY[0..1] OF A{j}; END_TYPE\n", "", ""),
    (
        "FUNCTION_BLOCK F{i} VAR c : F{j}; END_VAR c(); END_FUNCTION_BLOCK\n",
        "",
        "",
    ),
    (
        "FUNCTION G{i} : INT VAR_INPUT a : INT; END_VAR G{i} := G{j}(a); END_FUNCTION\n",
        "",
        "",
    ),
    ("a", "", ""),
    ("9", "", ""),
    ("'z", "", "'"),
    (
        "",
        "REAL#1.0E39 NaN INF 1.0E400 -1.0E-400 16#FFFFFFFFFFFFFFFFFFFF LREAL#1.8E308",
        "",
    ),
];

/// Instruction List shapes: long folds of the current result, deferred operations nested
/// deep, jumps over jumps, the ST operand shapes.
pub const IL: &[Template] = &[
    (
        "PROGRAM p VAR x : DINT; b : BOOL; END_VAR\nLD x\n",
        "",
        "ST x\nEND_PROGRAM\n",
    ),
    ("ADD 1\n", "", ""),
    ("ADD( x\n", "", ")\n"),
    ("AND( b\n", "", ")\n"),
    ("LD b\nJMPCN l{i}\n", "", "l{i}:\n"),
    ("NOT\n", "", ""),
    ("LD ", "x", "\n"),
    ("LD (", "x", ")\n"),
    ("FOO BAR\n", "", ""),
];

/// PLCopen XML shapes: elements nested deep, arrays and values inside each other, long
/// names, LD networks long and wide.
pub const XML: &[Template] = &[
    ("<project xmlns=\"http://www.plcopen.org/xml/tc6_0201\">", "", "</project>"),
    ("<types>", "", "</types>"),
    ("<array><dimension lower=\"0\" upper=\"1\"/><baseType>", "<INT/>", "</baseType></array>"),
    ("<arrayValue><value>", "<simpleValue value=\"1\"/>", "</value></arrayValue>"),
    ("<contact localId=\"{j}\"><connectionPointIn><connection refLocalId=\"{i}\"/></connectionPointIn><variable>a</variable></contact>", "", ""),
    ("<connection refLocalId=\"1\"/>", "", ""),
    ("<variable name=\"", "v", "\"/>"),
];

/// PNML shapes: pages in pages, long ids, huge numbers, guards nested or chained deep.
pub const PNML: &[Template] = &[
    ("<pnml><net id=\"n\" type=\"http://www.pnml.org/version-2009/grammar/ptnet\"><page id=\"g\">", "", "</page></net></pnml>"),
    ("<page>", "", "</page>"),
    ("<place id=\"p", "", "\"/>"),
    ("<place id=\"p\"><initialMarking><text>9", "", "</text></initialMarking></place>"),
    ("<transition id=\"t\"><toolspecific tool=\"petriplc\" version=\"1\"><guard>(", "B1", ")</guard></toolspecific></transition>"),
    ("B1 AND ", "B1", ""),
    ("NOT ", "B1", ""),
];

fn level(template: &str, i: usize) -> String {
    template
        .replace("{i}", &i.to_string())
        .replace("{j}", &(i + 1).to_string())
}

/// The input as the target reads it: itself, or (first byte odd) amplified by one of
/// `templates` (or by its own `\0`-separated parts when the pick is past them).
pub fn amplify(data: &[u8], templates: &[Template]) -> Vec<u8> {
    let [flag, pick, hi, lo, rest @ ..] = data else {
        return data.to_vec();
    };
    if flag % 2 == 0 {
        return data.to_vec();
    }
    let count = usize::from(u16::from_be_bytes([*hi, *lo])) % 20_001;
    let rest = String::from_utf8_lossy(rest);
    let (pre, mid, suf) = match templates.get(usize::from(*pick)) {
        Some(&(p, m, s)) => (p.to_string(), format!("{m}{rest}"), s.to_string()),
        None => {
            let mut parts = rest.splitn(3, '\0');
            let p = parts.next().unwrap_or("").to_string();
            let m = parts.next().unwrap_or("").to_string();
            (p, m, parts.next().unwrap_or("").to_string())
        }
    };
    let per_level = pre.len() + suf.len() + 8;
    let count = count.min(MAX_BYTES.saturating_sub(mid.len()) / per_level);
    let mut out = String::with_capacity(count * per_level + mid.len());
    for i in 0..count {
        out.push_str(&level(&pre, i));
    }
    out.push_str(&mid);
    for i in (0..count).rev() {
        out.push_str(&level(&suf, i));
    }
    out.into_bytes()
}

/// A rendered IEC diagnostic: `WHERE: error[E014]: …` (or `warning[W…]`), a code of the
/// front end's list.
pub fn is_coded(line: &str) -> bool {
    ["error[E", "warning[W"].iter().any(|tag| {
        line.split_once(&format!(": {tag}"))
            .and_then(|(_, rest)| rest.get(..4))
            .is_some_and(|c| c[..3].bytes().all(|b| b.is_ascii_digit()) && &c[3..] == "]")
    })
}
