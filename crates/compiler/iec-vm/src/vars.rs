//! Variables by path: a reference into a machine's memory, the retentive variables and
//! their saved values, and the path syntax (`prog.fb.x`, `prog.a[1, 2]`).

use petriplc_iec_sema::ir::VarClass;
use petriplc_iec_sema::types::TypeId;

/// A variable in a machine's memory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VarRef {
    pub addr: u32,
    pub ty: TypeId,
    pub class: VarClass,
}

/// A retentive variable: where it is and what it is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Retained {
    pub path: String,
    pub addr: u32,
    pub len: u32,
    pub type_name: String,
}

/// The values of the retentive variables, by path and type, for the PLC's retentive store.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct RetainImage {
    pub entries: Vec<(String, String, Vec<u64>)>,
}

/// One step of a variable's path: a name, or the subscripts of an element.
pub(crate) enum Segment {
    Name(String),
    Index(Vec<i64>),
}

/// `a.b[1, 2].c` as its steps; `None` for a subscript that is not an integer or a `[`
/// without its `]`.
pub(crate) fn split_path(path: &str) -> Option<Vec<Segment>> {
    let mut out = Vec::new();
    let mut rest = path.trim();
    while !rest.is_empty() {
        if let Some(r) = rest.strip_prefix('.') {
            rest = r;
            continue;
        }
        if let Some(r) = rest.strip_prefix('[') {
            let end = r.find(']')?;
            let idx: Option<Vec<i64>> =
                r[..end].split(',').map(|s| s.trim().parse().ok()).collect();
            out.push(Segment::Index(idx?));
            rest = &r[end + 1..];
            continue;
        }
        let end = rest.find(['.', '[']).unwrap_or(rest.len());
        out.push(Segment::Name(rest[..end].trim().to_string()));
        rest = &rest[end..];
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(path: &str, expect: &str) {
        let got = match split_path(path) {
            None => "none".to_string(),
            Some(segs) => segs
                .iter()
                .map(|s| match s {
                    Segment::Name(n) => n.clone(),
                    Segment::Index(i) => format!("{i:?}"),
                })
                .collect::<Vec<_>>()
                .join(" "),
        };
        assert_eq!(got, expect, "{path}");
    }

    #[test]
    fn paths() {
        check("main.x", "main x");
        check(" main.a[1, -2].b ", "main a [1, -2] b");
        check("main.a[1][2]", "main a [1] [2]");
        check("main.a[x]", "none");
        check("main.a[1", "none");
        check("", "");
    }
}
