//! Values as the trace, `sim` output and messages show them: IEC literals (`'…'` for
//! STRING, `"…"` for WSTRING).

use petriplc_iec_sema::ir::Project;
use petriplc_iec_sema::ops;
use petriplc_iec_sema::types::{Elem, Type, TypeId};
use petriplc_iec_sema::value::Value;

/// A value as the trace and messages show it: BOOL 0/1, integers in decimal, reals and
/// durations as IEC literals, strings in quotes.
pub fn display(project: &Project, ty: TypeId, v: &Value) -> String {
    match (project.types.get(ty), v) {
        (Type::Elem(Elem::Bool), Value::Int(i)) => if *i != 0 { "1" } else { "0" }.to_string(),
        (Type::Elem(e), v) if e.is_real() || e.is_duration() || e.is_date() => {
            String::from_utf8_lossy(&ops::to_text(v, *e)).into_owned()
        }
        // A character as its literal: 'a', "Ω".
        (Type::Elem(Elem::Char), Value::Int(i)) => string_literal(&[*i as u8]),
        (Type::Elem(Elem::Wchar), Value::Int(i)) => wide_literal(&[*i as u16]),
        (Type::Enum { values, .. }, Value::Int(i)) => values
            .iter()
            .find(|(_, x)| *x as i128 == *i)
            .map_or_else(|| i.to_string(), |(n, _)| n.clone()),
        (_, Value::Int(i)) => i.to_string(),
        (_, Value::Real(f)) => ops::format_real(*f, Elem::Lreal),
        (_, Value::Str(s)) => string_literal(s),
        (_, Value::WStr(w)) => wide_literal(w),
        _ => String::new(),
    }
}

/// A string as an IEC literal: `'it$'s'`, with `$$`, `$'`, `$N`, `$T`, `$R` and `$hh` for
/// other control characters.
pub fn string_literal(s: &[u8]) -> String {
    let mut out = String::from("'");
    for &b in s {
        match b {
            b'\'' => out.push_str("$'"),
            b'$' => out.push_str("$$"),
            b'\n' => out.push_str("$N"),
            b'\t' => out.push_str("$T"),
            b'\r' => out.push_str("$R"),
            0x0c => out.push_str("$P"),
            b if b < 0x20 || b == 0x7f => out.push_str(&format!("${b:02X}")),
            b if b < 0x80 => out.push(b as char),
            b => out.push_str(&format!("${b:02X}")),
        }
    }
    out.push('\'');
    out
}

/// A WSTRING as an IEC literal: `"it$"s"`, with `$$`, `$"`, `$N`, `$T`, `$R`, `$P` and
/// `$hhhh` for other control characters and lone surrogates.
pub fn wide_literal(w: &[u16]) -> String {
    let mut out = String::from("\"");
    for c in char::decode_utf16(w.iter().copied()) {
        match c {
            Ok('"') => out.push_str("$\""),
            Ok('$') => out.push_str("$$"),
            Ok('\n') => out.push_str("$N"),
            Ok('\t') => out.push_str("$T"),
            Ok('\r') => out.push_str("$R"),
            Ok('\u{0c}') => out.push_str("$P"),
            Ok(c) if c.is_control() => out.push_str(&format!("${:04X}", u32::from(c))),
            Ok(c) => out.push(c),
            Err(e) => out.push_str(&format!("${:04X}", e.unpaired_surrogate())),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn literals_as_written() {
        assert_eq!(string_literal(b"it's $5\n"), "'it$'s $$5$N'");
        let w: Vec<u16> = "Ω \"€\"\u{1}".encode_utf16().collect();
        assert_eq!(wide_literal(&w), "\"Ω $\"€$\"$0001\"");
        assert_eq!(wide_literal(&[0x41, 0xd800]), "\"A$D800\"");
    }
}
