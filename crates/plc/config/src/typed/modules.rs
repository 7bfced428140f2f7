//! Each declared module's settings: its section's settings checked against what its kind
//! reads, defaults applied, and the module's declaration completed.

use std::collections::{BTreeMap, HashSet};

use super::{declared, first_settings, Builder, NULL};
use crate::error;
use crate::model::{Location, ModuleDecl, OnFailure, Section};

impl Builder {
    pub(super) fn module_settings(
        &mut self,
        sections: &BTreeMap<String, Section>,
    ) -> Vec<ModuleDecl> {
        let transitions: HashSet<&str> = self
            .synch
            .transitions
            .iter()
            .map(|(n, _)| n.as_str())
            .collect();
        let mut diags = Vec::new();
        let mut out = Vec::new();
        let empty = Section::default();
        let mut done = HashSet::new();
        for m in &self.modules {
            // A second module of one name is already an error; its settings are the first's.
            if !done.insert(m.name.as_str()) {
                continue;
            }
            let section = sections.get(&m.name).unwrap_or(&empty);
            let settings = first_settings(section);
            let mut decl = ModuleDecl {
                args: m.args.clone(),
                origin: m.origin.clone(),
                ..ModuleDecl::new(m.name.clone(), m.kind.clone())
            };
            // In file order, so the messages come out in the order the lines were written.
            let mut seen = HashSet::new();
            for (key, s) in &section.pairs {
                if !seen.insert(key) {
                    continue;
                }
                let mut bad = |code, msg: String| {
                    diags.push(error::diagnostic(
                        &s.origin,
                        code,
                        format!("`{key} = {}` for module {}: {msg}", s.value, m.name),
                    ))
                };
                let v = s.value.as_str();
                match key.as_str() {
                    "scan_period" => match petriplc_net::time::parse_duration(v) {
                        Ok(d) => decl.scan_period = Some(d),
                        Err(e) => bad(error::BAD_SCAN_PERIOD, e.to_string()),
                    },
                    "location" => match v {
                        "local" => decl.location = Location::Local,
                        "shared" => decl.location = Location::Shared,
                        "isolate" => decl.location = Location::Isolate,
                        _ => bad(
                            error::BAD_LOCATION,
                            "write `local` (the default), `shared` or `isolate`".into(),
                        ),
                    },
                    "priority" => match v.parse::<u8>() {
                        Ok(p @ 1..=99) => decl.priority = Some(p),
                        _ => bad(
                            error::BAD_PRIORITY,
                            "write a real-time priority from 1 to 99, or leave it out for \
                             normal scheduling"
                                .into(),
                        ),
                    },
                    "on_failure" => match v {
                        "stop" => decl.on_failure = OnFailure::Stop,
                        "restart" => decl.on_failure = OnFailure::Restart,
                        "ignore" => decl.on_failure = OnFailure::Ignore,
                        _ => bad(
                            error::BAD_ON_FAILURE,
                            "write `stop` (the default), `restart` or `ignore`".into(),
                        ),
                    },
                    "restart_delay" | "restart_delay_max" => {
                        match petriplc_net::time::parse_duration(v) {
                            Ok(d) if key == "restart_delay" => decl.restart.delay = d,
                            Ok(d) if !d.is_zero() => decl.restart.delay_max = d,
                            Ok(_) => bad(
                                error::BAD_RESTART,
                                "the longest delay between restarts must be longer than 0 \
                                 (e.g. `T#10s`)"
                                    .into(),
                            ),
                            Err(e) => bad(error::BAD_RESTART, e.to_string()),
                        }
                    }
                    "watchdog" => match petriplc_net::time::parse_duration(v) {
                        Ok(d) if !d.is_zero() => decl.watchdog = Some(d),
                        Ok(_) => bad(
                            error::BAD_WATCHDOG,
                            "a watchdog must be longer than 0 (e.g. `T#100ms`); remove the \
                             line for none"
                                .into(),
                        ),
                        Err(e) => bad(error::BAD_WATCHDOG, e.to_string()),
                    },
                    "restart_limit" => match v.parse::<u32>() {
                        Ok(n) => decl.restart.limit = n,
                        Err(_) => bad(
                            error::BAD_RESTART,
                            "write how many restarts in a row are allowed (a whole number; \
                             0 for no limit)"
                                .into(),
                        ),
                    },
                    "scan_beg" | "scan_end" => {
                        let t = if v == NULL {
                            None
                        } else if transitions.contains(v) {
                            Some(v.to_string())
                        } else {
                            bad(
                                error::UNKNOWN_SCAN_TRANSITION,
                                format!(
                                    "`{v}` is not a declared transition: declare it with \
                                     `transition {v}` in [PLC], or write NULL ({})",
                                    declared(
                                        "transitions",
                                        self.synch.transitions.iter().map(|(n, _)| n.as_str())
                                    )
                                ),
                            );
                            None
                        };
                        if key == "scan_beg" {
                            decl.scan_beg = t;
                        } else {
                            decl.scan_end = t;
                        }
                    }
                    _ => {}
                }
            }
            if decl.on_failure != OnFailure::Restart {
                for key in ["restart_delay", "restart_delay_max", "restart_limit"] {
                    if let Some(s) = settings.get(key) {
                        diags.push(error::diagnostic(
                            &s.origin,
                            error::BAD_RESTART,
                            format!(
                                "`{key} = {}` for module {}: nothing reads it, because the \
                                 module's on_failure is not `restart`; set `on_failure = \
                                 restart` or remove the line",
                                s.value, m.name
                            ),
                        ));
                    }
                }
            }
            if decl.restart.delay > decl.restart.delay_max {
                let s = settings
                    .get("restart_delay")
                    .or(settings.get("restart_delay_max"));
                if let Some(s) = s {
                    diags.push(error::diagnostic(
                        &s.origin,
                        error::BAD_RESTART,
                        format!(
                            "module {}: restart_delay ({:?}) is longer than restart_delay_max \
                             ({:?}): the delay starts at restart_delay and doubles up to \
                             restart_delay_max",
                            m.name, decl.restart.delay, decl.restart.delay_max
                        ),
                    ));
                }
            }
            decl.settings = settings;
            out.push(decl);
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        for (name, section) in sections {
            if name == "PLC" || modules.contains(name.as_str()) {
                continue;
            }
            if name.eq_ignore_ascii_case("PLC") {
                let o = section
                    .pairs
                    .iter()
                    .map(|(_, s)| &s.origin)
                    .chain(section.rows.iter().map(|r| &r.origin))
                    .min_by_key(|o| (o.file.clone(), o.line))
                    .cloned()
                    .unwrap_or_default();
                diags.push(error::diagnostic(
                    &o,
                    error::SECTION_CASE,
                    format!("section [{name}] would be ignored: section names are case-sensitive, write [PLC]"),
                ));
                continue;
            }
            let similar = self
                .modules
                .iter()
                .find(|m| m.name.eq_ignore_ascii_case(name))
                .map(|m| format!(" (did you mean {}?)", m.name))
                .unwrap_or_default();
            for (key, s) in &section.pairs {
                diags.push(error::diagnostic(
                    &s.origin,
                    error::UNDECLARED_MODULE_SETTING,
                    format!(
                        "`{key}` is set for `{name}`, but no module {name} is declared{similar}: \
                         add `module {name} KIND-or-PATH` to [PLC], or remove the setting"
                    ),
                ));
            }
            for row in &section.rows {
                diags.push(error::diagnostic(
                    &row.origin,
                    error::UNDECLARED_MODULE_SETTING,
                    format!(
                        "a `{}` row in section [{name}], but no module {name} is declared\
                         {similar}: add `module {name} KIND-or-PATH` to [PLC], or remove the row",
                        row.table
                    ),
                ));
            }
        }
        self.diags.extend(diags);
        out
    }
}
