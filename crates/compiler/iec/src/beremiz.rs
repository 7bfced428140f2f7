//! Recognising a PLCopen XML project Beremiz (or OpenPLC Editor, its fork) wrote, or the
//! Structured Text they generate from one: reading one loads the vendor library `beremiz`
//! (its Structured Text is `petriplc_iec_syntax::builtin`, docs/iec.md, "Vendor libraries").

use petriplc_iec_syntax::ast::{Element, Library};
pub use petriplc_iec_syntax::plcopen::written_by_beremiz;

/// Whether a Structured Text source is what OpenPLC Editor or Beremiz generate from a
/// project (OpenPLC's `.st` export, a Beremiz build's `generated_plc.st`): a CONFIGURATION
/// with the names they give every project, `Config0` holding `Res0` (OpenPLC Editor) or
/// `config` holding `resource1` (Beremiz).
pub fn generated_by_beremiz(lib: &Library) -> bool {
    lib.elements.iter().any(|e| match e {
        Element::Configuration(c) => c.resources.iter().any(|r| {
            (c.name.is("Config0") && r.name.is("Res0"))
                || (c.name.is("config") && r.name.is("resource1"))
        }),
        _ => false,
    })
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

    /// OpenPLC's `.st` export loads the library: its PID is matiec's (AUTO, X0, TR, CYCLE).
    #[test]
    fn openplc_and_beremiz_st_exports_are_recognised() {
        let st = |config: &str, resource: &str| {
            let mut s = Sources::new();
            s.add_text(
                "p.st",
                &format!(
                    "PROGRAM program0 VAR c : PID; y : REAL; END_VAR
c(AUTO := TRUE, PV := 1.0, SP := 2.0, X0 := 0.0, KP := 2.0, TR := 1.0, TD := 0.0, CYCLE := T#20ms);
y := c.XOUT; END_PROGRAM
CONFIGURATION {config} RESOURCE {resource} ON PLC
TASK task0(INTERVAL := T#20ms, PRIORITY := 0);
PROGRAM instance0 WITH task0 : program0;
END_RESOURCE END_CONFIGURATION"
                ),
            );
            s
        };
        for (c, r) in [("Config0", "Res0"), ("config", "resource1")] {
            let s = st(c, r);
            assert_eq!(s.libs(), ["beremiz"], "{c}/{r}");
            crate::check(&s, &crate::Natives::default()).expect("checks");
        }
        let other = st("plant", "cpu");
        assert!(other.libs().is_empty());
        assert!(crate::check(&other, &crate::Natives::default()).is_err());
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
