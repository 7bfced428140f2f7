//! The harness that runs an OSCAT function or function block scan by scan, the same way in
//! petriplc and in matiec-compiled C: a wrapper PROGRAM (generated here from the POU's
//! interface as petriplc's checker sees it) feeds the POU seeded pseudo-random inputs of its
//! parameter types on every scan and copies its outputs into its own variables, which are
//! printed after every scan in one canonical text form (`Cell`), so that both runs compare
//! cell by cell. The recording format (`recording.rs`) keeps matiec's rows for CI.
#![allow(dead_code)]

pub mod adapt;
pub mod c;
pub mod recording;

use petriplc_iec::sema::ir::{PouKind, Project, VarClass};
use petriplc_iec::sema::types::{Elem, Type, TypeId};
use petriplc_iec::sema::value::Value;

/// Scans each POU runs.
pub const SCANS: usize = 40;
/// The task's fixed cycle in milliseconds: both runs' clocks advance by it every scan.
pub const CYCLE_MS: i64 = 10;
/// The generator's seed (each POU's stream is this mixed with the POU's name).
pub const SEED: u64 = 0x6f73_6361_745f_6d74;
/// Changed whenever the generated wrappers change, so a stale recording is refused.
pub const GENERATOR: u32 = 1;

/// SplitMix64: small, fast, and the same on every platform.
pub struct Rng(u64);

impl Rng {
    pub fn for_pou(name: &str) -> Self {
        let mut h = SEED;
        for b in name.to_ascii_uppercase().bytes() {
            h = (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3);
        }
        Rng(h)
    }

    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `lo..=hi`.
    pub fn range(&mut self, lo: i128, hi: i128) -> i128 {
        let span = (hi - lo + 1) as u128;
        lo + ((u128::from(self.next()) << 64 | u128::from(self.next())) % span) as i128
    }
}

/// What a parameter's values are, for generating, printing and comparing them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    Bool,
    Signed(u32),
    Unsigned(u32),
    /// A subrange, with its bounds.
    Sub(i128, i128),
    Real,
    Lreal,
    /// TIME, DATE, TIME_OF_DAY, DATE_AND_TIME: nanoseconds (since 1970 or midnight).
    Time,
    Date,
    Tod,
    Dt,
    /// STRING[len].
    Str(u32),
}

impl Kind {
    pub fn of(project: &Project, ty: TypeId) -> Result<Kind, String> {
        Ok(match project.types.get(ty) {
            Type::Elem(e) => match e {
                Elem::Bool => Kind::Bool,
                Elem::Sint => Kind::Signed(8),
                Elem::Int => Kind::Signed(16),
                Elem::Dint => Kind::Signed(32),
                Elem::Lint => Kind::Signed(64),
                Elem::Usint | Elem::Byte => Kind::Unsigned(8),
                Elem::Uint | Elem::Word => Kind::Unsigned(16),
                Elem::Udint | Elem::Dword => Kind::Unsigned(32),
                Elem::Ulint | Elem::Lword => Kind::Unsigned(64),
                Elem::Real => Kind::Real,
                Elem::Lreal => Kind::Lreal,
                Elem::Time => Kind::Time,
                Elem::Date => Kind::Date,
                Elem::Tod => Kind::Tod,
                Elem::Dt => Kind::Dt,
                Elem::Ltime => return Err("LTIME parameter".into()),
                Elem::Char | Elem::Wchar => return Err("CHAR or WCHAR parameter".into()),
            },
            Type::Subrange { lo, hi, .. } => Kind::Sub(*lo, *hi),
            Type::Str { len, wide: false } => Kind::Str(*len),
            Type::Str { wide: true, .. } => return Err("WSTRING parameter".into()),
            Type::Array { .. } => return Err("ARRAY parameter".into()),
            Type::Struct { name, .. } => return Err(format!("structure parameter ({name})")),
            Type::Enum { name, .. } => return Err(format!("enumeration parameter ({name})")),
            Type::Fb(_) => return Err("function block parameter".into()),
            Type::Ref { .. } => return Err("reference parameter".into()),
            #[allow(unreachable_patterns)]
            _ => return Err("parameter of an unsupported type".into()),
        })
    }

    /// The IEC type name the wrapper declares.
    fn iec(self, project: &Project, ty: TypeId) -> String {
        match self {
            Kind::Str(len) => format!("STRING[{len}]"),
            Kind::Sub(lo, hi) => {
                let base = match project.types.get(ty) {
                    Type::Subrange { base, .. } => elem_name(*base),
                    _ => "DINT",
                };
                format!("{base} ({lo}..{hi})")
            }
            _ => match project.types.get(ty) {
                Type::Elem(e) => elem_name(*e).to_string(),
                _ => unreachable!(),
            },
        }
    }

    /// A pseudo-random value as an IEC literal, in ranges where C's result is defined.
    fn literal(self, rng: &mut Rng) -> String {
        match self {
            Kind::Bool => if rng.next() & 1 == 1 { "TRUE" } else { "FALSE" }.into(),
            Kind::Signed(bits) => {
                let max = (1i128 << (bits - 1)) - 1;
                // Mostly small (counts, indices, digits), sometimes anything.
                match rng.next() % 8 {
                    0..=3 => rng.range(-10, 10),
                    4..=5 => rng.range(-1000, 1000).clamp(-max - 1, max),
                    _ => rng.range(-max - 1, max),
                }
                .to_string()
            }
            Kind::Unsigned(bits) => {
                let max = (1i128 << bits) - 1;
                match rng.next() % 8 {
                    0..=3 => rng.range(0, 10),
                    4..=5 => rng.range(0, 1000).min(max),
                    _ => rng.range(0, max),
                }
                .to_string()
            }
            Kind::Sub(lo, hi) => rng.range(lo, hi).to_string(),
            Kind::Real | Kind::Lreal => real_literal(rng),
            Kind::Time => {
                // Multiples of the cycle mostly (timers that expire within the run).
                let ms = match rng.next() % 4 {
                    0..=2 => rng.range(0, 30) * CYCLE_MS as i128,
                    _ => rng.range(0, 100_000),
                };
                format!("T#{ms}ms")
            }
            Kind::Date => {
                let (y, m, d) = civil(rng.range(DAY_LO, DAY_HI) as i64);
                format!("D#{y:04}-{m:02}-{d:02}")
            }
            Kind::Tod => {
                let s = rng.range(0, 86_399) as i64;
                format!("TOD#{:02}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
            }
            Kind::Dt => {
                let (y, m, d) = civil(rng.range(DAY_LO, DAY_HI) as i64);
                let s = rng.range(0, 86_399) as i64;
                format!(
                    "DT#{y:04}-{m:02}-{d:02}-{:02}:{:02}:{:02}",
                    s / 3600,
                    s / 60 % 60,
                    s % 60
                )
            }
            Kind::Str(len) => {
                const CHARS: &[u8] =
                    b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789 .,:-+_#/()=";
                let n = rng.range(0, i128::from(len.min(12))) as usize;
                let s: String = (0..n)
                    .map(|_| CHARS[rng.range(0, CHARS.len() as i128 - 1) as usize] as char)
                    .collect();
                format!("'{s}'")
            }
        }
    }
}

/// Days since 1970 of 1990-01-01 and 2037-12-31: dates every calendar function handles.
const DAY_LO: i128 = 7305;
const DAY_HI: i128 = 24_836;

/// Year, month, day of a day count since 1970-01-01 (Howard Hinnant's civil_from_days).
fn civil(z: i64) -> (i64, i64, i64) {
    let z = z + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    (yoe + era * 400 + i64::from(m <= 2), m, d)
}

/// A REAL as a decimal literal that is exact in single precision (an integer of at most 20
/// bits times a power of two), so both compilers read the very same number.
fn real_literal(rng: &mut Rng) -> String {
    let x = match rng.next() % 8 {
        0..=2 => rng.range(-10, 10) as f64,
        3..=5 => rng.range(-(1 << 16), 1 << 16) as f64 / 256.0,
        6 => rng.range(-(1 << 20), 1 << 20) as f64 / f64::from(1u32 << rng.range(0, 20) as u32),
        _ => rng.range(-(1 << 20), 1 << 20) as f64 * 64.0,
    };
    let text = format!("{x}");
    if text.contains('.') {
        text
    } else {
        format!("{text}.0")
    }
}

/// The type's name in the wrappers given to matiec: TOD and DT spelt out, as the recording
/// was made with; the checker's own names otherwise.
fn elem_name(e: Elem) -> &'static str {
    match e {
        Elem::Tod => "TIME_OF_DAY",
        Elem::Dt => "DATE_AND_TIME",
        e => e.name(),
    }
}

/// One column the wrapper prints after every scan.
#[derive(Clone, Debug)]
pub struct Column {
    /// The wrapper's variable, element or field (upper case, as matiec's C names it).
    pub var: String,
    /// The same in matiec's C, from the program instance.
    pub c: String,
    pub kind: Kind,
}

/// The parts of a parameter the wrapper feeds and prints: the whole variable, or each
/// element of a one-dimensional array, or each field of a structure, of elementary types.
fn parts(project: &Project, ty: TypeId, var: &str) -> Result<Vec<(String, String, Kind)>, String> {
    match project.types.get(ty) {
        Type::Array { dims, elem } => {
            let [(lo, hi)] = dims.as_slice() else {
                return Err("array of more than one dimension".into());
            };
            if hi - lo >= 256 {
                return Err(format!("array of {} elements", hi - lo + 1));
            }
            let kind = Kind::of(project, *elem)?;
            Ok((*lo..=*hi)
                .map(|i| {
                    (
                        format!("{var}[{i}]"),
                        format!("{var}.value.table[{}]", i - lo),
                        kind,
                    )
                })
                .collect())
        }
        Type::Struct { fields, .. } => fields
            .iter()
            .map(|f| {
                let name = f.name.to_ascii_uppercase();
                Ok((
                    format!("{var}.{name}"),
                    format!("{var}.value.{name}"),
                    Kind::of(project, f.ty)?,
                ))
            })
            .collect(),
        _ => Ok(vec![(
            var.to_string(),
            format!("{var}.value"),
            Kind::of(project, ty)?,
        )]),
    }
}

/// The generated wrapper of one POU.
pub struct Wrapper {
    /// A FUNCTION: no state from one scan to the next.
    pub stateless: bool,
    /// The PROGRAM and its CONFIGURATION, plain IEC 61131-3 that both compilers take.
    pub st: String,
    pub columns: Vec<Column>,
}

/// The wrapper program's name and its instance in the configuration.
pub const PROGRAM: &str = "MATIEC_WRAP";
pub const INSTANCE: &str = "W_INST";

/// Generates the wrapper of `pou` in a checked project of it and its dependencies, or says
/// why it cannot be generated.
/// `type_names`: a parameter's declared type name (upper-case parameter name), if it was
/// declared by name.
pub fn wrapper(
    project: &Project,
    pou: &str,
    type_names: &dyn Fn(&str) -> Option<String>,
) -> Result<Wrapper, String> {
    let id = project
        .pou_by_name(pou)
        .ok_or_else(|| format!("no POU {pou}"))?;
    let p = project.pou(id);
    let mut rng = Rng::for_pou(&p.name);
    let mut decls = String::new();
    let mut inputs = Vec::new(); // (wrapper var, kind, parts of its parameter)
    let mut args = Vec::new();
    let mut after = String::new();
    let mut columns = Vec::new();
    let is_fn = p.kind == PouKind::Function;
    for v in &p.vars {
        let param = matches!(
            v.class,
            VarClass::Input | VarClass::Output | VarClass::InOut
        );
        let result = v.class == VarClass::Result;
        if !param && !result {
            continue;
        }
        let name = v.name.to_ascii_uppercase();
        let w = match v.class {
            VarClass::Input => format!("WI_{name}"),
            VarClass::InOut => format!("WX_{name}"),
            VarClass::Output => format!("WO_{name}"),
            _ => "WR".to_string(),
        };
        let parts = parts(project, v.ty, &w).map_err(|e| format!("{e}: {}", v.name))?;
        // The declared type's name where it has one (an array or structure type must be the
        // very type of the parameter), else the type written out.
        let ty = match type_names(&name) {
            Some(t) => t,
            None if parts.len() == 1 && parts[0].0 == w => parts[0].2.iec(project, v.ty),
            None => return Err(format!("anonymous array or structure type of {}", v.name)),
        };
        decls += &format!("    {w} : {ty};\n");
        let columns_of = |parts: &[(String, String, Kind)]| -> Vec<Column> {
            parts
                .iter()
                .map(|(var, c, kind)| Column {
                    var: var.clone(),
                    c: c.clone(),
                    kind: *kind,
                })
                .collect()
        };
        match v.class {
            VarClass::Input => {
                args.push(format!("{name} := {w}"));
                inputs.extend(
                    parts
                        .iter()
                        .map(|(var, _, k)| (var.clone(), *k, parts.len())),
                );
            }
            VarClass::InOut => {
                args.push(format!("{name} := {w}"));
                inputs.extend(
                    parts
                        .iter()
                        .map(|(var, _, k)| (var.clone(), *k, parts.len())),
                );
                columns.extend(columns_of(&parts));
            }
            VarClass::Output => {
                if is_fn {
                    args.push(format!("{name} => {w}"));
                } else {
                    after += &format!("  {w} := W_U.{name};\n");
                }
                columns.extend(columns_of(&parts));
            }
            _ => {
                let mut c = columns_of(&parts);
                c.append(&mut columns);
                columns = c;
            }
        }
    }
    if columns.is_empty() {
        return Err("no outputs".into());
    }
    let name = &p.name;
    let call = if is_fn {
        if p.result.is_some() {
            format!("  WR := {name}({});\n", args.join(", "))
        } else {
            format!("  {name}({});\n", args.join(", "))
        }
    } else {
        decls += &format!("    W_U : {name};\n");
        format!("  W_U({});\n{after}", args.join(", "))
    };
    let mut feed = String::new();
    for scan in 0..SCANS {
        if inputs.is_empty() {
            break;
        }
        feed += &format!("  {scan}:");
        for (w, kind, parts) in &inputs {
            // An array's elements only now and then: they are many, and the C they become
            // is slow to compile; between those scans the POU works on what it left there.
            if *parts > 16 && scan % 20 != 0 {
                continue;
            }
            feed += &format!(" {w} := {};", kind.literal(&mut rng));
        }
        feed += "\n";
    }
    if !feed.is_empty() {
        feed = format!("CASE W_N OF\n{feed}END_CASE;\n");
    }
    // OSCAT's clock (T_PLC_MS, T_PLC_US) reads these two globals: the wrapper advances them
    // by the fixed cycle, so both runs see the same time.
    let st = format!(
        "PROGRAM {PROGRAM}\nVAR_EXTERNAL\n    PLC_SYS_TICK_CNT : DINT;\nEND_VAR\nVAR\n    W_N : DINT;\n{decls}END_VAR\n\
         PLC_SYS_TICK_CNT := W_N * {CYCLE_MS};\n{feed}W_N := W_N + 1;\n{call}\
         END_PROGRAM\n\n\
         CONFIGURATION W_CONF\n\
         VAR_GLOBAL\n    PLC_TICKS_PER_SEC : INT := 1000;\n    PLC_SYS_TICK_CNT : DINT;\nEND_VAR\n\
         RESOURCE W_RES ON PLC\n\
         TASK W_TASK(INTERVAL := T#{CYCLE_MS}ms, PRIORITY := 0);\n\
         PROGRAM {INSTANCE} WITH W_TASK : {PROGRAM};\nEND_RESOURCE\nEND_CONFIGURATION\n"
    );
    Ok(Wrapper {
        stateless: is_fn,
        st,
        columns,
    })
}

/// One printed value.
pub fn cell(kind: Kind, v: &Value) -> String {
    match (kind, v) {
        (Kind::Real, Value::Real(f)) => real_cell(f64::from(*f as f32), 9),
        (Kind::Lreal, Value::Real(f)) => real_cell(*f, 17),
        (Kind::Str(_), Value::Str(s)) => str_cell(s),
        (_, Value::Int(i)) => i.to_string(),
        (_, other) => format!("?{other:?}"),
    }
}

/// `%.{digits}g` as C prints it, close enough to parse back: the comparison is numeric.
fn real_cell(f: f64, digits: usize) -> String {
    if f.is_nan() {
        "nan".into()
    } else if f.is_infinite() {
        if f > 0.0 { "inf" } else { "-inf" }.into()
    } else {
        format!("{f:.*e}", digits - 1)
    }
}

/// A string's bytes: printable ASCII as it is, others (and `;`, `%`) as `%XX`.
pub fn str_cell(s: &[u8]) -> String {
    let mut out = String::from("s");
    for &b in s {
        if (0x21..0x7f).contains(&b) && b != b';' && b != b'%' {
            out.push(b as char);
        } else {
            out.push_str(&format!("%{b:02X}"));
        }
    }
    out
}

/// Whether two cells of a column agree: REAL within a relative 1e-5 (matiec's C computes
/// REAL expressions in double where a literal or a math function makes them double, and
/// rounds to float at each assignment; petriplc rounds every operation to float), LREAL
/// within 1e-12, everything else exactly.
pub fn same(kind: Kind, c: &str, p: &str) -> bool {
    if c == p {
        return true;
    }
    let tol = match kind {
        Kind::Real => 1e-5,
        Kind::Lreal => 1e-12,
        _ => return false,
    };
    let num = |s: &str| -> Option<f64> {
        match s.trim_start_matches('-') {
            "nan" => Some(f64::NAN),
            _ => s.parse().ok(),
        }
    };
    match (num(c), num(p)) {
        (Some(a), Some(b)) => {
            (a.is_nan() && b.is_nan())
                || a == b
                || (a - b).abs() <= tol * a.abs().max(b.abs())
                || (a - b).abs() <= tol * 1e-3
        }
        _ => false,
    }
}
