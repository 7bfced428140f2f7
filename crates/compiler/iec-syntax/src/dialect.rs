//! Which vendor's IEC 61131-3 a project is written in, where vendors disagree: the standard
//! (and matiec), CODESYS 3, TwinCAT 3 (CODESYS's language with Beckhoff's libraries) or
//! PCWorx. What every vendor accepts is accepted in all dialects; the dialect only decides
//! what differs (docs/iec.md, "Dialects and vendor code").

use std::fmt;
use std::str::FromStr;

/// A vendor's reading of IEC 61131-3.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// The standard (third edition), as matiec, OpenPLC and Beremiz read it.
    #[default]
    Iec,
    /// CODESYS 3: the standard function blocks' CODESYS input names (CTU's `RESET`,
    /// CTD's `LOAD`).
    Codesys,
    /// TwinCAT 3: CODESYS's language.
    Twincat,
    /// Phoenix Contact PCWorx / PLCnext Engineer.
    Pcworx,
}

impl Dialect {
    pub const ALL: [Dialect; 4] = [
        Dialect::Iec,
        Dialect::Codesys,
        Dialect::Twincat,
        Dialect::Pcworx,
    ];

    /// The name written in `--dialect` and `dialect = …`.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Iec => "iec",
            Dialect::Codesys => "codesys",
            Dialect::Twincat => "twincat",
            Dialect::Pcworx => "pcworx",
        }
    }

    /// CODESYS and TwinCAT share the language (and the standard library's names).
    pub fn is_codesys_family(self) -> bool {
        matches!(self, Dialect::Codesys | Dialect::Twincat)
    }

    /// The dialect a file shows it is written in: a TwinCAT 3 file by its extension
    /// (`.TcPOU`, `.TcDUT`, `.TcGVL`, `.TcIO`, `.TcTTO`, `.plcproj`) or its XML's
    /// `<TcPlcObject`; `None` when the file does not say.
    pub fn detect(name: &str, text: &str) -> Option<Dialect> {
        let lower = name.to_ascii_lowercase();
        let twincat_ext = [
            ".tcpou", ".tcdut", ".tcgvl", ".tcio", ".tctto", ".tctleo", ".plcproj",
        ];
        if twincat_ext.iter().any(|e| lower.ends_with(e)) {
            return Some(Dialect::Twincat);
        }
        let mut end = text.len().min(4096);
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        // Beckhoff's own attributes (`{attribute 'TcRpcEnable'}`, `'TcTypeSystem'`…) are
        // written by TwinCAT only.
        if text[..end].contains("<TcPlcObject") || text.contains("{attribute 'Tc") {
            return Some(Dialect::Twincat);
        }
        None
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A dialect name that is not one of [`Dialect::ALL`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownDialect(pub String);

impl fmt::Display for UnknownDialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<&str> = Dialect::ALL.iter().map(|d| d.name()).collect();
        write!(
            f,
            "unknown dialect `{}`; write one of {}",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownDialect {}

impl FromStr for Dialect {
    type Err = UnknownDialect;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Dialect::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownDialect(s.trim().to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_names_are_explained() {
        for d in Dialect::ALL {
            assert_eq!(d.name().parse::<Dialect>(), Ok(d));
        }
        assert_eq!("TwinCAT".parse::<Dialect>(), Ok(Dialect::Twincat));
        assert_eq!(
            "step7".parse::<Dialect>().unwrap_err().to_string(),
            "unknown dialect `step7`; write one of iec, codesys, twincat, pcworx"
        );
    }

    #[test]
    fn twincat_files_are_recognised() {
        assert_eq!(Dialect::detect("a/FB_X.TcPOU", ""), Some(Dialect::Twincat));
        assert_eq!(
            Dialect::detect(
                "x.xml",
                "<?xml version=\"1.0\"?>\n<TcPlcObject Version=\"1.1.0.1\">"
            ),
            Some(Dialect::Twincat)
        );
        assert_eq!(
            Dialect::detect("x.st", "{attribute 'TcRpcEnable'}\nPROGRAM p END_PROGRAM"),
            Some(Dialect::Twincat)
        );
        assert_eq!(
            Dialect::detect(
                "x.st",
                "{attribute 'qualified_only'}\nPROGRAM p END_PROGRAM"
            ),
            None
        );
    }
}
