//! The vendor libraries' function blocks, by their interfaces (the VM runs them natively:
//! `petriplc_iec::vendor_fbs`): CODESYS Util's analog monitors HYSTERESIS and LIMITALARM,
//! TwinCAT's GETCPUCOUNTER, and the real-time clock RTC of matiec's library (Beremiz's,
//! OpenPLC's).

use crate::ir::{NativeSig, NativeVar, NativeVarKind};
use crate::types::Elem;
use crate::value::Value;

/// Every vendor function block by name (upper case) and the library that provides it.
pub const FUNCTION_BLOCKS: &[(&str, &str)] = &[
    ("HYSTERESIS", "codesys"),
    ("LIMITALARM", "codesys"),
    ("GETCPUCOUNTER", "twincat"),
    ("RTC", "beremiz"),
];

fn var(name: &str, ty: Elem, kind: NativeVarKind) -> NativeVar {
    NativeVar {
        name: name.to_string(),
        ty,
        kind,
        init: Value::Int(0),
    }
}

/// A block's pins of one direction: name, type, kind.
type Pins = &'static [(&'static str, Elem, NativeVarKind)];

/// The interface of vendor function block `name` (upper case).
pub fn signature(name: &str) -> Option<NativeSig> {
    use NativeVarKind::{Input as I, Output as O, State as S};
    if name == "RTC" {
        // IEC 61131-3 1st edition's RTC as matiec declares it (lib/C/iec_std_FB.h): the
        // state is the input seen last and the offset of the set clock from the scan clock.
        let vars = [
            ("IN", Elem::Bool, I),
            ("PDT", Elem::Dt, I),
            ("Q", Elem::Bool, O),
            ("CDT", Elem::Dt, O),
            ("PREV_IN", Elem::Bool, S),
            ("OFFSET", Elem::Time, S),
        ];
        return Some(NativeSig {
            name: name.to_string(),
            vars: vars.iter().map(|(n, t, k)| var(n, *t, *k)).collect(),
        });
    }
    let monitor: Pins = &[
        ("IN", Elem::Int, I),
        ("HIGH", Elem::Int, I),
        ("LOW", Elem::Int, I),
    ];
    let (inputs, outputs): (Pins, Pins) = match name {
        "HYSTERESIS" => (monitor, &[("OUT", Elem::Bool, O)]),
        "LIMITALARM" => (
            monitor,
            &[
                ("O", Elem::Bool, O),
                ("U", Elem::Bool, O),
                ("IL", Elem::Bool, O),
            ],
        ),
        // Tc2_System: the CPU's counter in 100 ns, as two halves.
        "GETCPUCOUNTER" => (
            &[],
            &[
                ("cpuCntLoDW", Elem::Dword, O),
                ("cpuCntHiDW", Elem::Dword, O),
            ],
        ),
        _ => return None,
    };
    Some(NativeSig {
        name: name.to_string(),
        vars: inputs
            .iter()
            .chain(outputs)
            .map(|(n, t, k)| var(n, *t, *k))
            .collect(),
    })
}

/// The function blocks `libs` load, in a fixed order (the VM's natives follow it).
pub fn signatures(libs: &[String]) -> Vec<NativeSig> {
    FUNCTION_BLOCKS
        .iter()
        .filter(|(_, lib)| super::provides(libs, lib))
        .filter_map(|(name, _)| signature(name))
        .collect()
}

/// The library providing function block `name` (any case), if it is a vendor one.
pub fn fb_provider(name: &str) -> Option<&'static str> {
    FUNCTION_BLOCKS
        .iter()
        .find(|(f, _)| f.eq_ignore_ascii_case(name))
        .map(|(_, lib)| *lib)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loaded_with_their_library() {
        assert!(signatures(&[]).is_empty());
        assert!(signatures(&["pcworx".into()]).is_empty());
        assert_eq!(signatures(&["beremiz".into()])[0].name, "RTC");
        let names: Vec<String> = signatures(&["twincat".into()])
            .into_iter()
            .map(|s| s.name)
            .collect();
        assert_eq!(names, ["HYSTERESIS", "LIMITALARM", "GETCPUCOUNTER"]);
        let codesys: Vec<String> = signatures(&["codesys".into()])
            .into_iter()
            .map(|s| s.name)
            .collect();
        assert_eq!(codesys, ["HYSTERESIS", "LIMITALARM"]);
        assert_eq!(fb_provider("hysteresis"), Some("codesys"));
        assert_eq!(fb_provider("TON"), None);
    }
}
