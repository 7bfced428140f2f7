//! Vendor libraries written in Structured Text (`vendor_src/*.st`), added to a project's
//! sources when loaded: `beremiz`, the SVGHMI types, LOGGER and the Python blocks Beremiz
//! projects use (docs/iec.md, "Vendor libraries"). A type or POU the project declares itself
//! wins over the library's, as a project's own declaration would in Beremiz.

use std::borrow::Cow;

use petriplc_iec_syntax::{self as syntax, ast::Element};

use crate::Sources;

/// The name messages print for the library's file.
const BEREMIZ_FILE: &str = "<library beremiz>";
const BEREMIZ: &str = include_str!("vendor_src/beremiz.st");

/// The source text of library `lib` (lower case), if it is written in Structured Text.
fn source(lib: &str) -> Option<(&'static str, &'static str)> {
    match lib {
        "beremiz" => Some((BEREMIZ_FILE, BEREMIZ)),
        _ => None,
    }
}

/// Whether a PLCopen XML project was written by Beremiz: its fileHeader names Beremiz
/// (as product, company or in its description), or holds the values Beremiz gives a new
/// project (`companyName="Unknown"`, `productName="Unnamed"`, ProjectController.py), or the
/// root element declares the `ns1` prefix Beremiz's XML writer (xmlclass) adds.
pub fn written_by_beremiz(text: &str) -> bool {
    let Some(start) = text.find("<fileHeader") else {
        return false;
    };
    let root = &text[..start];
    let header = &text[start..];
    let header = &header[..header.find('>').unwrap_or(header.len())];
    let attr = |name: &str| {
        let key = format!("{name}=\"");
        header.find(&key).map(|i| {
            let v = &header[i + key.len()..];
            &v[..v.find('"').unwrap_or(v.len())]
        })
    };
    header.to_ascii_lowercase().contains("beremiz")
        || (attr("companyName") == Some("Unknown") && attr("productName") == Some("Unnamed"))
        || root.contains("xmlns:ns1=\"http://www.plcopen.org/xml/tc6")
}

/// Whether `file` is a library's source (its warnings are not the project's).
pub fn is_library_file(map: &syntax::SourceMap, file: syntax::source::FileId) -> bool {
    map.get(file).is_some_and(|f| f.name == BEREMIZ_FILE)
}

/// `sources` with the Structured Text libraries it loads added (a copy), or itself when it
/// loads none.
pub fn with_libraries(sources: &Sources) -> Cow<'_, Sources> {
    let texts: Vec<(&str, &str)> = sources
        .libs()
        .iter()
        .filter_map(|l| source(&l.to_ascii_lowercase()))
        .filter(|(file, _)| !sources.map.files().any(|(_, f)| f.name == *file))
        .collect();
    if texts.is_empty() {
        return Cow::Borrowed(sources);
    }
    let mut s = sources.clone();
    for (file, text) in texts {
        let f = s.map.add(file, text);
        let lib = syntax::parse(f, text, &mut s.diags);
        for e in lib.elements {
            if let Some(e) = not_declared(&s, e) {
                s.lib.elements.push(e);
            }
        }
    }
    Cow::Owned(s)
}

/// `e` without what the project already declares (a type or POU of the same name).
fn not_declared(s: &Sources, e: Element) -> Option<Element> {
    let declared = |name: &syntax::ast::Ident| {
        s.lib.elements.iter().any(|x| match x {
            Element::Pou(p) => p.name.is(&name.name),
            Element::Types(ts) => ts.iter().any(|t| t.name.is(&name.name)),
            _ => false,
        })
    };
    match e {
        Element::Pou(p) if declared(&p.name) => None,
        Element::Types(ts) => {
            let ts: Vec<_> = ts.into_iter().filter(|t| !declared(&t.name)).collect();
            (!ts.is_empty()).then_some(Element::Types(ts))
        }
        e => Some(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn beremiz_projects_are_recognised() {
        let h = |attrs: &str| format!("<project><fileHeader {attrs}/></project>");
        assert!(written_by_beremiz(&h(
            r#"companyName="Unknown" productName="Unnamed" productVersion="1""#
        )));
        assert!(written_by_beremiz(&h(
            r#"companyName="" productName="Beremiz""#
        )));
        assert!(!written_by_beremiz(&h(
            r#"companyName="3S" productName="CODESYS""#
        )));
        assert!(!written_by_beremiz("PROGRAM p END_PROGRAM"));
    }

    /// The library parses and checks cleanly; a project's own LOGGER replaces the library's.
    #[test]
    fn the_library_checks_and_yields_to_the_project() {
        let mut s = Sources::new();
        s.libs = vec!["beremiz".into()];
        s.add_text(
            "p.st",
            "FUNCTION_BLOCK LOGGER VAR_INPUT X : INT; END_VAR END_FUNCTION_BLOCK
PROGRAM p VAR l : LOGGER; h : HMI_INT; e : python_eval; g : python_gear; END_VAR
l(X := h); e(TRIG := TRUE, CODE := '1+1'); g(N := 2, TRIG := TRUE, CODE := '');
h := h + BOOL_TO_INT(e.ACK); END_PROGRAM",
        );
        let checked = crate::check(&s, &crate::Natives::default()).expect("checks");
        assert!(checked.warnings.is_empty(), "{:?}", checked.warnings);
        let loaded = with_libraries(&s);
        assert!(loaded.map.files().any(|(_, f)| f.name == BEREMIZ_FILE));
        // Loading twice adds nothing.
        assert!(matches!(with_libraries(&loaded), Cow::Borrowed(_)));
    }
}
