//! Recognising a PLCopen XML project Beremiz (or OpenPLC Editor, its fork) wrote: reading one
//! loads the vendor library `beremiz` (its Structured Text is
//! `petriplc_iec_syntax::builtin`, docs/iec.md, "Vendor libraries").

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Sources;

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
    }
}
