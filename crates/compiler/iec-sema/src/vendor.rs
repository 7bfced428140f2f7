//! Vendor libraries: optional packages of the functions and function blocks CODESYS/TwinCAT
//! and PCWorx programs call beside the standard library (`TIME()`, `GET_CHAR`,
//! `X_TO_STRING(value, format)`, `HYSTERESIS`…) and Beremiz projects use, loaded by name
//! (`--lib codesys`; declarations written in Structured Text are `petriplc_iec_syntax::builtin`'s,
//! added by `sources.rs`). This
//! module is the catalogue (which library provides which) and the meaning of those that are
//! not plain operators: PCWorx's printf-style formats (`format.rs`), the function blocks'
//! interfaces (`fbs.rs`). The checker types the calls in `expr/vendor.rs`. SIZEOF, ADR and
//! MEMCPY go with the pointers, always available (`expr/reference.rs`, `memory.rs`).

mod fbs;
mod format;
mod sources;

pub use fbs::{fb_provider, signature, signatures, FUNCTION_BLOCKS};
pub use format::printf;
pub use sources::with_sources;

/// The libraries, by the name `--lib` and `libs =` take.
pub const LIBRARIES: &[&str] = &["codesys", "twincat", "pcworx", "beremiz"];

/// Every vendor function by name (upper case) and the library that provides it (docs/iec.md,
/// "Vendor libraries", says what each does).
pub const FUNCTIONS: &[(&str, &str)] = &[
    ("TIME", "codesys"),
    ("F_TOASC", "twincat"),
    ("F_TOCHR", "twincat"),
    ("GET_CHAR", "pcworx"),
    ("MUL_T_AI", "pcworx"),
    ("DIV_T_AI", "pcworx"),
];

/// The library providing `name` (any case), if it is a vendor function.
pub fn provider(name: &str) -> Option<&'static str> {
    FUNCTIONS
        .iter()
        .find(|(f, _)| f.eq_ignore_ascii_case(name))
        .map(|(_, lib)| *lib)
}

/// Whether `name` (any case) is a vendor library.
pub fn is_library(name: &str) -> bool {
    LIBRARIES.iter().any(|l| l.eq_ignore_ascii_case(name))
}

/// The vendor's name for messages: `CODESYS`, `PCWorx`.
pub fn title(lib: &str) -> &'static str {
    match lib {
        "codesys" => "CODESYS/TwinCAT",
        "twincat" => "TwinCAT",
        "pcworx" => "PCWorx",
        "beremiz" => "Beremiz",
        _ => "vendor",
    }
}

/// Whether `lib`'s functions are available when `loaded` are: TwinCAT 3 is built on
/// CODESYS 3, so loading `twincat` also gives CODESYS's functions.
pub fn provides(loaded: &[String], lib: &str) -> bool {
    loaded.iter().any(|l| {
        let l = l.to_ascii_lowercase();
        l == lib || (lib == "codesys" && l == "twincat")
    })
}

/// The vendor libraries a dialect loads by default (`iec` none; `codesys`, `twincat`,
/// `pcworx` their own), for the dialect setting to call.
pub fn vendor_libs_for(dialect: &str) -> Vec<String> {
    let libs: &[&str] = match dialect.to_ascii_lowercase().as_str() {
        "codesys" => &["codesys"],
        "twincat" => &["codesys", "twincat"],
        "pcworx" => &["pcworx"],
        _ => &[],
    };
    libs.iter().map(|s| s.to_string()).collect()
}

/// The unknown names among `libs`, with the message to show for the first.
pub fn check_names(libs: &[String]) -> Result<(), String> {
    match libs.iter().find(|l| !is_library(l)) {
        Some(bad) => Err(format!(
            "unknown vendor library `{bad}`; the libraries are {}",
            LIBRARIES.join(", ")
        )),
        None => Ok(()),
    }
}

#[cfg(test)]
mod check_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn catalogue() {
        assert_eq!(provider("get_char"), Some("pcworx"));
        assert_eq!(provider("TIME"), Some("codesys"));
        assert_eq!(provider("LEN"), None);
        assert_eq!(provider("F_ToAsc"), Some("twincat"));
        assert!(provides(&["TwinCAT".into()], "codesys"));
        assert!(!provides(&["codesys".into()], "pcworx"));
        assert!(!provides(&["codesys".into()], "twincat"));
        assert_eq!(vendor_libs_for("TwinCAT"), ["codesys", "twincat"]);
        assert!(vendor_libs_for("iec").is_empty());
        assert_eq!(
            check_names(&["pcworx".into(), "siemens".into()]).unwrap_err(),
            "unknown vendor library `siemens`; the libraries are codesys, twincat, pcworx, beremiz"
        );
        assert!(check_names(&["PCWORX".into()]).is_ok());
    }
}
