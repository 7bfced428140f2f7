//! petriplc's own `<toolspecific>` data: the known elements per element kind, the net's
//! step, evolution and signal declarations.

use petriplc_net::{Evolution, SignalDirection, SignalType, StepRule};

use super::{shown, Kind, Once, Reader, SignalUse};
use crate::diag;
use crate::vocab;
use crate::xml::Element;

impl Reader<'_> {
    /// The signal a place's `<output>` or `<input>` names; `None` (reported) when empty.
    pub(super) fn signal_name(&mut self, item: &Element, text: &str, id: &str) -> Option<String> {
        if text.is_empty() {
            let msg = format!(
                "place `{}`: `<{}>` is empty; write the signal's name",
                shown(id),
                item.name
            );
            self.error(diag::PETRIPLC_VALUE, item.start, Some(id), msg);
            return None;
        }
        Some(text.to_string())
    }

    /// The children of one of our toolspecific blocks that are known for `kind`; reports the
    /// others, a repeated once-only element and an unsupported version.
    pub(super) fn tool_items<'e>(
        &mut self,
        ts: &'e Element,
        kind: Kind,
        id: &str,
        known: &[&str],
        once: &mut Once,
    ) -> Vec<&'e Element> {
        if let Some(v) = ts.attr("version").filter(|v| v.trim() != vocab::VERSION) {
            let msg = format!(
                "{} `{}`: petriplc toolspecific data of version `{}` is not understood; this \
                 petriplc reads version {}",
                kind.noun(),
                shown(id),
                shown(v),
                vocab::VERSION
            );
            self.error(diag::PETRIPLC_VALUE, ts.start, Some(id), msg);
            return Vec::new();
        }
        let mut items = Vec::new();
        for item in &ts.children {
            if !known.contains(&item.name.as_str()) {
                let list: Vec<String> = known.iter().map(|k| format!("<{k}>")).collect();
                let msg = format!(
                    "{} `{}`: `<{}>` is not a petriplc element of {} {}; known here: {}",
                    kind.noun(),
                    shown(id),
                    shown(&item.name),
                    if kind == Kind::Arc { "an" } else { "a" },
                    kind.noun(),
                    list.join(", ")
                );
                self.error(diag::UNKNOWN_PETRIPLC, item.start, Some(id), msg);
            } else if item.name == "signal" || self.once(once, item, kind, id) {
                items.push(item);
            }
        }
        items
    }

    pub(super) fn net_tool(&mut self, ts: &Element, id: &str, once: &mut Once) {
        for item in self.tool_items(ts, Kind::Net, id, vocab::NET_ITEMS, once) {
            let text = item.text.trim();
            match item.name.as_str() {
                "step" => match StepRule::parse(text) {
                    Some(s) => self.step = Some(s),
                    None => self.bad_value(item, id, text, "maximal-step, sequential"),
                },
                "evolve" => match Evolution::parse(text) {
                    Some(e) => self.evolve = Some(e),
                    None => self.bad_value(item, id, text, "one-pass, until-stable"),
                },
                _ => self.signal_declaration(item, id),
            }
        }
    }

    fn bad_value(&mut self, item: &Element, id: &str, value: &str, known: &str) {
        let msg = format!(
            "net `{}`: `<{}>` is `{}`; use one of: {known}",
            shown(id),
            item.name,
            shown(value)
        );
        self.error(diag::PETRIPLC_VALUE, item.start, Some(id), msg);
    }

    fn signal_declaration(&mut self, item: &Element, id: &str) {
        for (attr, _) in &item.attrs {
            if !vocab::SIGNAL_ATTRS.contains(&attr.as_str()) {
                let msg = format!(
                    "net `{}`: `<signal>` has an unknown attribute `{}`; known: name, direction, type",
                    shown(id),
                    shown(attr)
                );
                self.error(diag::UNKNOWN_PETRIPLC, item.start, Some(id), msg);
            }
        }
        let name = item.attr("name").map(str::trim).unwrap_or("");
        let direction = match item.attr("direction").map(str::trim) {
            Some("input") => Some(SignalDirection::Input),
            Some("output") => Some(SignalDirection::Output),
            other => {
                let msg = format!(
                    "net `{}`: signal `{}` needs direction=\"input\" or direction=\"output\"{}",
                    shown(id),
                    shown(name),
                    other
                        .map(|d| format!(", not `{}`", shown(d)))
                        .unwrap_or_default()
                );
                self.error(diag::PETRIPLC_VALUE, item.start, Some(id), msg);
                None
            }
        };
        let ty = match item.attr("type").map(str::trim) {
            None | Some("bool") => Some(SignalType::Bool),
            Some("int") => Some(SignalType::Int),
            Some(other) => {
                let msg = format!(
                    "net `{}`: signal `{}` has type `{}`; use type=\"bool\" or type=\"int\"",
                    shown(id),
                    shown(name),
                    shown(other)
                );
                self.error(diag::PETRIPLC_VALUE, item.start, Some(id), msg);
                None
            }
        };
        if name.is_empty() {
            let msg = format!("net `{}`: a `<signal>` has no name=\"…\"", shown(id));
            self.error(diag::PETRIPLC_VALUE, item.start, Some(id), msg);
            return;
        }
        if let (Some(direction), Some(ty)) = (direction, ty) {
            self.signals.push((name.to_string(), direction, ty));
            self.uses.push(SignalUse {
                stage: 0,
                name: name.to_string(),
                direction,
                declared: Some(ty),
                at: item.start,
                element: id.to_string(),
            });
        }
    }
}
