//! Which stored values a configuration takes back at start. Values are matched by name: a
//! retentive point gets its stored value if the point has the type and width it was stored
//! with; a point that changed type or width is refused (its value is never reinterpreted);
//! a new retentive point starts from its init value; a stored point that is no longer
//! retentive is dropped, with a note. A file written for another PLC id, or one none of
//! whose retained points is retentive here, is refused as another configuration's.

use std::path::Path;

use petriplc_config::PointKind;

use crate::{type_name, Identity, RetainError, Snapshot, Value};

/// A retentive point of the configuration that starts.
#[derive(Clone, Copy, Debug)]
pub struct Wanted<'a> {
    pub name: &'a str,
    pub kind: PointKind,
    pub bits: u8,
}

/// What a start takes back.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Restored {
    /// Per wanted point, in order: its stored bits, or `None` (it starts from its init value).
    pub points: Vec<Option<u32>>,
    /// Lines for the log: points new to the file, stored points dropped.
    pub notes: Vec<String>,
}

/// Matches `snapshot` (read from `path`) against the retentive points of the configuration
/// of PLC `me`.
pub fn points(
    path: &Path,
    snapshot: &Snapshot,
    me: &Identity,
    wanted: &[Wanted<'_>],
) -> Result<Restored, RetainError> {
    if snapshot.identity.plc_id != me.plc_id {
        return Err(RetainError::OtherPlc {
            path: path.to_path_buf(),
            stored: snapshot.identity.plc_id.clone(),
            plc_id: me.plc_id.clone(),
            config: snapshot.identity.config.clone(),
        });
    }
    let stored: Vec<(&str, PointKind, u8, u32)> = snapshot
        .entries
        .iter()
        .filter_map(|e| match e.value {
            Value::Point { kind, bits, raw } => Some((e.name.as_str(), kind, bits, raw)),
            Value::Data { .. } => None,
        })
        .collect();
    let known = |name: &str| wanted.iter().any(|w| w.name == name);
    if !stored.is_empty() && !stored.iter().any(|s| known(s.0)) {
        let mut names: Vec<&str> = stored.iter().map(|s| s.0).take(5).collect();
        if stored.len() > names.len() {
            names.push("…");
        }
        return Err(RetainError::OtherConfiguration {
            path: path.to_path_buf(),
            config: snapshot.identity.config.clone(),
            count: stored.len(),
            names: names.join(", "),
        });
    }
    let mut out = Restored::default();
    let mut new = Vec::new();
    for w in wanted {
        match stored.iter().find(|s| s.0 == w.name) {
            Some(&(_, kind, bits, raw)) => {
                if (kind, bits) != (w.kind, w.bits) {
                    return Err(RetainError::TypeChanged {
                        path: path.to_path_buf(),
                        point: w.name.to_string(),
                        stored: type_name(kind, bits),
                        now: type_name(w.kind, w.bits),
                    });
                }
                out.points.push(Some(raw));
            }
            None => {
                new.push(w.name);
                out.points.push(None);
            }
        }
    }
    if !new.is_empty() && !stored.is_empty() {
        out.notes.push(format!(
            "retain file {}: {} not stored yet, starting from the init value: {}",
            path.display(),
            plural(new.len(), "retentive point"),
            new.join(", ")
        ));
    }
    let dropped: Vec<&str> = stored.iter().map(|s| s.0).filter(|n| !known(n)).collect();
    if !dropped.is_empty() {
        out.notes.push(format!(
            "retain file {}: {} stored but no longer retentive in the configuration, dropped \
             at the next write: {}",
            path.display(),
            plural(dropped.len(), "point"),
            dropped.join(", ")
        ));
    }
    Ok(out)
}

fn plural(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

#[cfg(test)]
mod tests {
    use std::time::SystemTime;

    use super::*;
    use crate::Entry;

    fn snap(plc_id: &str, points: &[(&str, PointKind, u8, u32)]) -> Snapshot {
        Snapshot {
            seq: 3,
            written: SystemTime::UNIX_EPOCH,
            identity: Identity {
                plc_id: plc_id.into(),
                config: "/old/plc.conf".into(),
            },
            entries: points
                .iter()
                .map(|&(name, kind, bits, raw)| Entry {
                    name: name.into(),
                    value: Value::Point { kind, bits, raw },
                })
                .collect(),
        }
    }

    fn check(stored: &Snapshot, wanted: &[(&str, PointKind, u8)], expect: &str) {
        let me = Identity {
            plc_id: "line".into(),
            config: "/new/plc.conf".into(),
        };
        let wanted: Vec<Wanted> = wanted
            .iter()
            .map(|&(name, kind, bits)| Wanted { name, kind, bits })
            .collect();
        let got = match points(Path::new("r.retain"), stored, &me, &wanted) {
            Ok(r) => format!("{:?} {}", r.points, r.notes.join(" | ")),
            Err(e) => e.to_string(),
        };
        assert_eq!(got.trim_end(), expect);
    }

    use PointKind::{Signed as I, Unsigned as U};

    #[test]
    fn values_come_back_by_name() {
        let s = snap("line", &[("count", U, 16, 7), ("old", U, 1, 1)]);
        check(
            &s,
            &[("total", I, 32), ("count", U, 16)],
            "[None, Some(7)] retain file r.retain: 1 retentive point not stored yet, starting \
             from the init value: total | retain file r.retain: 1 point stored but no longer \
             retentive in the configuration, dropped at the next write: old",
        );
        check(&s, &[("count", U, 16), ("old", U, 1)], "[Some(7), Some(1)]");
        check(&snap("line", &[]), &[("count", U, 16)], "[None]");
    }

    #[test]
    fn a_changed_type_another_plc_or_configuration_is_refused() {
        let s = snap("line", &[("count", U, 16, 7)]);
        check(
            &s,
            &[("count", U, 32)],
            "retain file r.retain: point `count` was stored as u16 and is u32 in the \
             configuration: its stored value is not reinterpreted. Change the point back to u16 \
             to keep the value, or rename the point to start it from its init value",
        );
        check(
            &s,
            &[("count", I, 16)],
            "retain file r.retain: point `count` was stored as u16 and is i16 in the \
             configuration: its stored value is not reinterpreted. Change the point back to u16 \
             to keep the value, or rename the point to start it from its init value",
        );
        check(
            &snap("other", &[("count", U, 16, 7)]),
            &[("count", U, 16)],
            "retain file r.retain belongs to PLC `other` (written for /old/plc.conf), not to \
             this PLC `line`: give this PLC its own file with `retain_file` in [PLC] (or `--set \
             PLC:retain_file=FILE`), or remove that file if its values are not wanted",
        );
        check(
            &s,
            &[("level", U, 16)],
            "retain file r.retain was written by another configuration (/old/plc.conf): none \
             of its 1 retained points (count) is a retentive point here. Point `retain_file` at \
             this configuration's own file, or remove that file to start from the init values",
        );
    }
}
