//! What the mqtt module's tests share: a `probe` module that writes the values a test sets
//! into the points it owns, and the registry that adds it to the mqtt kinds.

use std::collections::HashMap;
use std::sync::Mutex;

use petriplc_config::{ModuleDecl, PointValue};
use petriplc_runtime::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};

/// Values the test sets on the points the `probe` module owns (point name → value).
static PROBE: Mutex<Option<HashMap<String, PointValue>>> = Mutex::new(None);

pub fn set(point: &str, v: PointValue) {
    PROBE
        .lock()
        .unwrap()
        .get_or_insert_with(HashMap::new)
        .insert(point.to_string(), v);
}

/// Writes what the test set into the points it owns.
pub struct Probe;

impl Module for Probe {
    fn init(&mut self, _: &mut InitContext<'_>) -> Result<(), ModuleError> {
        Ok(())
    }
    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let values = PROBE.lock().unwrap().clone().unwrap_or_default();
        for (p, v) in values {
            if let Ok(h) = ctx.map.handle(&p) {
                if ctx.map.owns(&h) {
                    ctx.map.set(&h, v).unwrap();
                }
            }
        }
        Ok(Control::Continue)
    }
}

pub fn registry(kind: &str) -> Option<Factory> {
    match kind {
        "probe" => Some(|_: &ModuleDecl| Ok(Box::new(Probe) as Box<dyn Module>)),
        k => petriplc_mqtt::builtin(k),
    }
}
