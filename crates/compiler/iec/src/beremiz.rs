//! Recognising a PLCopen XML project Beremiz (or OpenPLC Editor, its fork) wrote: reading one
//! loads the vendor library `beremiz` (its Structured Text is
//! `petriplc_iec_syntax::builtin`, docs/iec.md, "Vendor libraries").

pub use petriplc_iec_syntax::plcopen::written_by_beremiz;

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
