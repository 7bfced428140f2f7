//! Runs a wrapper with matiec: `iec2c` translates the POU, its dependencies and the wrapper
//! to C, gcc compiles that with matiec's C runtime headers and a generated `main` that runs
//! the scans at the fixed cycle and prints the wrapper's columns after each one.

use std::fmt::Write as _;
use std::path::Path;
use std::process::Command;

use super::{Column, Kind, CYCLE_MS, INSTANCE, PROGRAM, SCANS};

/// Scans' rows, and why C stopped early if it did.
pub type Run = (Vec<Vec<String>>, Option<String>);

/// `matiec`: a folder with `iec2c` and `lib/` (matiec's IEC and C library). `work`: an empty
/// folder for the files. `Err` when matiec or gcc refuses (the first error line).
/// `stateless`: a function, whose scans are independent, so a scan that C leaves undefined
/// (the sanitizer stops the program there) is marked `?` and the program runs again from
/// the next scan; a function block's run ends there.
pub fn run(
    matiec: &Path,
    st: &str,
    columns: &[Column],
    stateless: bool,
    work: &Path,
) -> Result<Run, String> {
    let out = work.join("c");
    std::fs::create_dir_all(&out).map_err(|e| e.to_string())?;
    let src = work.join("all.st");
    // Latin-1, byte for byte, as the sources were read.
    let bytes: Vec<u8> = st
        .chars()
        .map(|c| u8::try_from(c).unwrap_or(b'?'))
        .collect();
    std::fs::write(&src, bytes).map_err(|e| e.to_string())?;
    let iec2c = Command::new(matiec.join("iec2c"))
        .arg("-I")
        .arg(matiec.join("lib"))
        .arg("-T")
        .arg(&out)
        .arg(&src)
        .output()
        .map_err(|e| format!("cannot run iec2c: {e}"))?;
    if !iec2c.status.success() {
        let text = String::from_utf8_lossy(&iec2c.stderr).to_string()
            + &String::from_utf8_lossy(&iec2c.stdout);
        let first = text
            .lines()
            .find(|l| l.to_ascii_lowercase().contains("error"))
            .or_else(|| text.lines().next())
            .unwrap_or("no message")
            .replace(&*src.to_string_lossy(), "all.st");
        return Err(format!("matiec refuses: {first}"));
    }
    // One translation unit: matiec's runtime headers, most of gcc's time, are read once.
    let mut main = main_c(columns);
    for u in units(&out)? {
        let name = u.file_name().unwrap().to_string_lossy().to_string();
        main += &format!("#include \"{name}\"\n");
    }
    std::fs::write(out.join("main.c"), main).map_err(|e| e.to_string())?;
    let exe = work.join("prog");
    let cc = Command::new("gcc")
        // Signed overflow wraps in C, as in matiec's own targets and petriplc's default.
        // What C leaves undefined (a shift by the width or more or by a negative count, an
        // index out of bounds, a REAL converted to an integer that cannot hold it, integer
        // division by zero) is caught by the undefined-behaviour sanitizer and reported on
        // standard error in the scan where it happens.
        .args(["-O0", "-fwrapv", "-fno-strict-aliasing", "-w"])
        .args([
            "-fsanitize=undefined,float-cast-overflow",
            "-fno-sanitize=signed-integer-overflow",
            "-fno-sanitize-recover=all",
            "-o",
        ])
        .arg(&exe)
        .arg("-I")
        .arg(runtime(matiec, work)?)
        .arg("-I")
        .arg(&out)
        .arg(out.join("main.c"))
        .arg("-lm")
        .output()
        .map_err(|e| format!("cannot run gcc: {e}"))?;
    if !cc.status.success() {
        let text = String::from_utf8_lossy(&cc.stderr);
        let first = text.lines().find(|l| l.contains("error")).unwrap_or("");
        return Err(format!("gcc refuses matiec's C: {}", first.trim()));
    }
    let mut rows: Vec<Vec<String>> = Vec::new();
    loop {
        let start = rows.len();
        let (mut got, stop) = run_from(&exe, start)?;
        rows.append(&mut got);
        let Some(why) = stop else {
            return Ok((rows, None));
        };
        let k = rows.len();
        if !stateless || k + 1 >= SCANS {
            let why = format!("stopped at scan {k}: {why}");
            if stateless {
                rows.push(vec![format!("?{why}")]);
                return Ok((rows, None));
            }
            return Ok((rows, Some(why)));
        }
        // A function's scans are independent: this one is undefined, the next ones run.
        rows.push(vec![format!("?{why}")]);
    }
}

/// Runs the program from scan `start`: the rows until it ends or stops, and why it stopped
/// before the last scan (the sanitizer's report, or the signal).
fn run_from(exe: &Path, start: usize) -> Result<(Vec<Vec<String>>, Option<String>), String> {
    let run = Command::new("timeout")
        .arg("20")
        .arg(exe)
        .arg(start.to_string())
        .output()
        .map_err(|e| format!("cannot run the program: {e}"))?;
    let rows: Vec<Vec<String>> = String::from_utf8_lossy(&run.stdout)
        .lines()
        .map(|l| l.split(';').map(String::from).collect())
        .collect();
    if run.status.success() && start + rows.len() >= SCANS {
        return Ok((rows, None));
    }
    let stderr = String::from_utf8_lossy(&run.stderr);
    let why = match stderr.lines().find_map(|l| l.split_once("runtime error: ")) {
        Some((_, what)) => format!("undefined in C: {}", what.trim()),
        None => {
            use std::os::unix::process::ExitStatusExt;
            match (run.status.signal(), run.status.code()) {
                (Some(s), _) => format!("signal {s}"),
                (_, Some(124)) => "no end within 20 s".to_string(),
                (_, c) => format!("exit {c:?}"),
            }
        }
    };
    Ok((rows, Some(why)))
}

/// matiec's C runtime headers, copied into `work` with TIME's conversions to and from
/// numbers counting milliseconds, as in CODESYS, TwinCAT and PCWorx, the platforms OSCAT is
/// written for (T_PLC_MS's milliseconds become a TIME with `UDINT_TO_TIME`), and as petriplc
/// does; matiec's own count seconds, which the standard leaves to the implementation. The
/// conversions of dates and times of day are matiec's (seconds).
fn runtime(matiec: &Path, work: &Path) -> Result<std::path::PathBuf, String> {
    let dir = work.join("runtime");
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    for f in std::fs::read_dir(matiec.join("lib/C")).map_err(|e| e.to_string())? {
        let f = f.map_err(|e| e.to_string())?.path();
        let mut text = std::fs::read_to_string(&f).map_err(|e| e.to_string())?;
        if f.ends_with("iec_std_functions.h") {
            let edits = [
                (
                    "/******** [ANY_BIT | ANY_INT]_TO_[TIME | ANY_DATE]   ************/",
                    concat!(
                        "static inline TIME __int_to_time_ms(LINT IN) ",
                        "{return (TIME){IN / 1000, (IN % 1000) * 1000000};}\n",
                        "static inline TIME __real_to_time_ms(LREAL IN) ",
                        "{return __real_to_time(IN / 1000.0);}\n",
                        "static inline LINT __time_to_int_ms(TIME IN) ",
                        "{return IN.tv_sec * 1000LL + IN.tv_nsec / 1000000;}\n",
                        "static inline LREAL __time_to_real_ms(TIME IN) ",
                        "{return __time_to_real(IN) * 1000.0;}\n",
                        "/******** [ANY_BIT | ANY_INT]_TO_[TIME | ANY_DATE]   ************/"
                    ),
                ),
                (
                    "__convert_type(from_TYPENAME, TIME, __int_to_time)",
                    "__convert_type(from_TYPENAME, TIME, __int_to_time_ms)",
                ),
                (
                    "__convert_type(from_TYPENAME, TIME, __real_to_time)",
                    "__convert_type(from_TYPENAME, TIME, __real_to_time_ms)",
                ),
                (
                    "__to_anyint_(TIME)\n__to_anynbit_(TIME)\n",
                    "#undef __iec_\n#define __iec_(to_TYPENAME,from_TYPENAME) \
                     __convert_type(from_TYPENAME, to_TYPENAME, __time_to_int_ms)\n\
                     __to_anyint_(TIME)\n__to_anynbit_(TIME)\n#undef __iec_\n\
                     #define __iec_(to_TYPENAME,from_TYPENAME) \
                     __convert_type(from_TYPENAME, to_TYPENAME, __time_to_int)\n",
                ),
                (
                    "__to_anyreal_(TIME)\n",
                    "#undef __iec_\n#define __iec_(to_TYPENAME,from_TYPENAME) \
                     __convert_type(from_TYPENAME, to_TYPENAME, __time_to_real_ms)\n\
                     __to_anyreal_(TIME)\n#undef __iec_\n\
                     #define __iec_(to_TYPENAME,from_TYPENAME) \
                     __convert_type(from_TYPENAME, to_TYPENAME, __time_to_real)\n",
                ),
            ];
            for (from, to) in edits {
                if text.matches(from).count() != 1 {
                    return Err(format!(
                        "matiec's iec_std_functions.h has no single `{from}`"
                    ));
                }
                text = text.replace(from, to);
            }
        }
        std::fs::write(dir.join(f.file_name().unwrap()), text).map_err(|e| e.to_string())?;
    }
    Ok(dir)
}

/// The translation units iec2c wrote: the configuration's and the resource's (POUS.c is
/// included by the resource's).
fn units(out: &Path) -> Result<Vec<std::path::PathBuf>, String> {
    let mut units: Vec<_> = std::fs::read_dir(out)
        .map_err(|e| e.to_string())?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.extension().is_some_and(|x| x == "c")
                && !p.ends_with("POUS.c")
                && !p.ends_with("main.c")
        })
        .collect();
    units.sort();
    Ok(units)
}

/// The C `main`: scan `k` (from 0) runs at `k × cycle`, as in petriplc's run.
fn main_c(columns: &[Column]) -> String {
    let mut print = String::new();
    for (i, c) in columns.iter().enumerate() {
        if i > 0 {
            print += "    putchar(';');\n";
        }
        let v = format!("W_RES__{INSTANCE}.{}", c.c);
        let _ = writeln!(
            print,
            "    {}",
            match c.kind {
                Kind::Bool => format!("printf(\"%d\", (int){v});"),
                Kind::Signed(_) | Kind::Sub(..) => format!("printf(\"%lld\", (long long){v});"),
                Kind::Unsigned(_) => format!("printf(\"%llu\", (unsigned long long){v});"),
                Kind::Real => format!("printf(\"%.9g\", (double){v});"),
                Kind::Lreal => format!("printf(\"%.17g\", (double){v});"),
                Kind::Time | Kind::Date | Kind::Tod | Kind::Dt =>
                    format!("printf(\"%lld\", (long long){v}.tv_sec * 1000000000LL + {v}.tv_nsec);"),
                Kind::Str(_) => format!("str_cell(&{v});"),
            }
        );
    }
    format!(
        r#"#include <stdlib.h>
#include "iec_std_lib.h"
#include "POUS.h"
TIME __CURRENT_TIME;
BOOL __DEBUG;
extern {PROGRAM} W_RES__{INSTANCE};
void config_init__(void);
void config_run__(unsigned long tick);
static void str_cell(const STRING *s) {{
    putchar('s');
    for (int i = 0; i < s->len; i++) {{
        unsigned char b = s->body[i];
        if (b > 0x20 && b < 0x7f && b != ';' && b != '%') putchar(b);
        else printf("%%%02X", b);
    }}
}}
int main(int argc, char **argv) {{
  unsigned long start = argc > 1 ? strtoul(argv[1], NULL, 10) : 0;
  setvbuf(stdout, NULL, _IOLBF, 0);
  config_init__();
  /* A function's run may start at a later scan: the wrapper's scan counter picks the inputs. */
  W_RES__{INSTANCE}.W_N.value = start;
  for (unsigned long k = start; k < {SCANS}; k++) {{
    long long ns = (long long)k * {CYCLE_MS} * 1000000LL;
    __CURRENT_TIME.tv_sec = ns / 1000000000LL;
    __CURRENT_TIME.tv_nsec = ns % 1000000000LL;
    config_run__(k);
{print}    putchar('\n');
  }}
  return 0;
}}
"#
    )
}
