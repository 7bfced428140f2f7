//! `shutdown`: stops the whole PLC cleanly on the first scan where a point reads true
//! (MatPLC's plcshutdown, whose setting is `quit_pt`).
//!
//! ```text
//! [stop]
//! point = QUIT              # or quit_pt = QUIT
//! ```

use petriplc_config::ModuleDecl;
use petriplc_runtime::image::Handle;
use petriplc_runtime::module::{Control, InitContext, Module, ModuleError, ScanContext};

use crate::common::{self, error};

const KIND: &str = "shutdown";

pub(crate) fn factory(decl: &ModuleDecl) -> Result<Box<dyn Module>, ModuleError> {
    Ok(Box::new(Shutdown::new(decl)?))
}

/// The `shutdown` module.
pub struct Shutdown {
    name: String,
    point: String,
    handle: Option<Handle>,
}

impl Shutdown {
    /// Checks the settings; the point is looked up by `init`.
    pub fn new(decl: &ModuleDecl) -> Result<Shutdown, ModuleError> {
        common::check_decl(decl, KIND, &["point", "quit_pt"])?;
        let point = match (
            common::setting(decl, "point"),
            common::setting(decl, "quit_pt"),
        ) {
            (Some(a), Some(b)) if a != b => {
                return Err(error(
                    &decl.name,
                    format!(
                        "`point = {a}` and `quit_pt = {b}` name different points; keep one \
                         setting"
                    ),
                ))
            }
            (Some(p), _) | (None, Some(p)) if !p.is_empty() => p,
            _ => {
                return Err(error(
                    &decl.name,
                    format!(
                        "no `point` setting; add `point = NAME` (the point that stops the PLC \
                         when true) to section [{}]",
                        decl.name
                    ),
                ))
            }
        };
        Ok(Shutdown {
            name: decl.name.clone(),
            point: point.to_string(),
            handle: None,
        })
    }
}

impl Module for Shutdown {
    fn init(&mut self, ctx: &mut InitContext<'_>) -> Result<(), ModuleError> {
        common::rows(ctx, KIND, &[])?;
        let h = ctx.map.handle(&self.point).map_err(|e| {
            error(
                &self.name,
                format!("the shutdown point: {e}; fix `point` in [{}]", self.name),
            )
        })?;
        self.handle = Some(h);
        Ok(())
    }

    fn scan(&mut self, ctx: &mut ScanContext<'_>) -> Result<Control, ModuleError> {
        let Some(h) = &self.handle else {
            return Err(error(&self.name, "scanned before init"));
        };
        Ok(if ctx.map.get_bool(h) {
            Control::StopPlc
        } else {
            Control::Continue
        })
    }

    fn default_scan_period(&self) -> Option<std::time::Duration> {
        Some(crate::common::DEFAULT_PERIOD)
    }

    fn status(&self) -> String {
        format!("stops the PLC when {} is true", self.point)
    }
}
