//! The `iec` module's `VAR RETAIN` variables (and FB instances declared RETAIN) kept in the
//! PLC's retain file as module-private retained data, beside the retentive points.
//!
//! Each retentive variable is one value named by its path (`main.count`, `RETAIN_GLOBAL`,
//! `main.ctr`) with its IEC type as signature (`INT`, `ARRAY[1..4] OF REAL`, `CTU`); its
//! bytes are the engine's memory slots (little-endian u64 words). A stored value is given
//! back before the first scan; one stored under another type, or of another size (a
//! FUNCTION_BLOCK or STRUCT whose declaration changed), is refused and the module does not
//! start. After each scan only the values that changed are handed to the runner, which
//! commits them with the scan's outputs and persists them off the scan path.

use std::path::Path;

use petriplc_iec::vm::{Engine, Machine};
use petriplc_retain::Retained;
use petriplc_runtime::module::{InitContext, ModuleError};

use crate::common::error;

/// One retentive variable of the running program.
pub(crate) struct Kept {
    addr: u32,
    len: u32,
    handle: Retained,
    /// The slots last handed to the runner (or restored).
    last: Vec<u64>,
    /// Given back from the retain file at this start.
    restored: bool,
}

impl Kept {
    /// Whether slot `addr` belongs to this variable and was given back from the file.
    pub(crate) fn restored_at(&self, addr: u32) -> bool {
        self.restored && (self.addr..self.addr + self.len).contains(&addr)
    }
}

/// Whether the program `file` (relative to `conf`'s folder) declares anything RETAIN: known
/// before it is compiled, so that the PLC opens its retain file before any module starts.
/// A word `RETAIN` or TwinCAT's `PERSISTENT` anywhere (`VAR RETAIN`, `VAR_GLOBAL RETAIN`,
/// PLCopen's `retain="true"`) counts; `NON_RETAIN`/`nonretain` do not. A folder or a
/// `.plcproj` counts when any of its files does. An unreadable file is reported by `init`.
pub(crate) fn declares_retain(conf: &str, file: &str) -> bool {
    let base = Path::new(conf).parent().unwrap_or(Path::new("."));
    let path = base.join(file);
    if petriplc_iec::project::is_project(&path) {
        let mut sources = petriplc_iec::Sources::new();
        if sources.add_path(&path).is_err() {
            return false;
        }
        return sources
            .map
            .files()
            .any(|(_, f)| mentions_retain(f.text.as_bytes()));
    }
    let Ok(text) = petriplc_files::read(&path, petriplc_files::IEC_SOURCE) else {
        return false;
    };
    mentions_retain(&text)
}

/// Whether `text` holds the word RETAIN or PERSISTENT (any case).
fn mentions_retain(text: &[u8]) -> bool {
    let word = |i: usize| {
        text.get(i)
            .is_some_and(|b| b.is_ascii_alphanumeric() || *b == b'_')
    };
    [&b"RETAIN"[..], b"PERSISTENT"].iter().any(|w| {
        (0..(text.len() + 1).saturating_sub(w.len())).any(|i| {
            text[i..i + w.len()].eq_ignore_ascii_case(w)
                && !word(i + w.len())
                && (i == 0 || !word(i - 1))
        })
    })
}

fn bytes(slots: &[u64]) -> Vec<u8> {
    slots.iter().flat_map(|s| s.to_le_bytes()).collect()
}

/// Registers every retentive variable of `engine` and writes the stored values into
/// `machine`; every problem at once.
pub(crate) fn restore(
    module: &str,
    ctx: &InitContext<'_>,
    engine: &Engine,
    machine: &mut Machine,
) -> Result<Vec<Kept>, ModuleError> {
    let mut kept = Vec::new();
    let mut problems = Vec::new();
    for r in engine.retained() {
        let handle = match ctx.retain(&r.path, &r.type_name) {
            Ok(h) => h,
            Err(e) => {
                let prefix = format!("module {module}: ");
                problems.push(e.0.strip_prefix(&prefix).unwrap_or(&e.0).to_string());
                continue;
            }
        };
        let mut last: Vec<u64> = (r.addr..r.addr + r.len).map(|a| machine.slot(a)).collect();
        let stored = handle.get();
        let restored = stored.is_some();
        if let Some(stored) = stored {
            if stored.len() != last.len() * 8 {
                problems.push(format!(
                    "the retain file holds `{}` ({}) in {} bytes and the program now keeps it \
                     in {}: the declaration of {} changed, and its stored value is not \
                     reinterpreted. Restore the old declaration to keep the value, or rename \
                     the variable to start it from its initial value",
                    r.path,
                    r.type_name,
                    stored.len(),
                    last.len() * 8,
                    r.type_name
                ));
                continue;
            }
            for (i, chunk) in stored.chunks_exact(8).enumerate() {
                let raw = u64::from_le_bytes(chunk.try_into().expect("8 bytes"));
                machine.set_slot(r.addr + i as u32, raw);
                last[i] = raw;
            }
            log::debug!("{module}: `{}` restored from the retain file", r.path);
        }
        kept.push(Kept {
            addr: r.addr,
            len: r.len,
            handle,
            last,
            restored,
        });
    }
    if problems.is_empty() {
        Ok(kept)
    } else {
        Err(error(module, problems.join("\n")))
    }
}

/// After a scan: hands the values that changed to the runner.
pub(crate) fn stage(kept: &mut [Kept], machine: &Machine) {
    for k in kept {
        let changed = (0..k.len).any(|i| machine.slot(k.addr + i) != k.last[i as usize]);
        if changed {
            for i in 0..k.len {
                k.last[i as usize] = machine.slot(k.addr + i);
            }
            k.handle.set(bytes(&k.last));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn retain_and_persistent_are_seen_in_files_and_folders() {
        assert!(mentions_retain(b"VAR RETAIN x : INT; END_VAR"));
        assert!(mentions_retain(b"VAR PERSISTENT x : INT; END_VAR"));
        assert!(mentions_retain(b"RETAIN"));
        assert!(!mentions_retain(b"VAR NON_RETAIN x : INT; END_VAR"));
        assert!(!mentions_retain(b"VAR retained : INT; END_VAR"));
        let d = tempfile::tempdir().unwrap();
        let conf = d.path().join("plc.conf").display().to_string();
        std::fs::create_dir_all(d.path().join("src/sub")).unwrap();
        std::fs::write(d.path().join("src/a.st"), "PROGRAM a END_PROGRAM").unwrap();
        assert!(!declares_retain(&conf, "src"));
        std::fs::write(
            d.path().join("src/sub/g.st"),
            "VAR_GLOBAL PERSISTENT n : INT; END_VAR",
        )
        .unwrap();
        assert!(declares_retain(&conf, "src"));
    }
}
