//! Drives modules in-process, scan by scan, the way the runner does (a real process image in
//! shared memory, one map per module, `update()` around each scan) but with time passed in:
//! for the modules' tests and tools that step a PLC deterministically.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Duration;

use petriplc_config::{parse_str, PlcConfig, PointValue};

use crate::image::{GlobalMap, Layout, ModuleMap};
use crate::module::{Control, Factory, InitContext, Module, ModuleError, ScanContext};

/// Finds the factory of a module kind (e.g. `petriplc_modules::builtin`).
pub type Registry = fn(&str) -> Option<Factory>;

/// A plc id no other test (or concurrent test run) uses.
pub fn plc_id() -> String {
    static N: AtomicU32 = AtomicU32::new(0);
    format!(
        "mod{}-{}",
        std::process::id(),
        N.fetch_add(1, Ordering::Relaxed)
    )
}

/// The folder `examples/DIR` of this repository.
pub fn examples(dir: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../examples")
        .join(dir)
}

/// Reads configuration text as if it were a file `test.conf` in `dir`; panics on an error.
pub fn config(text: &str, dir: &Path) -> PlcConfig {
    parse_str(text, "test.conf", dir).unwrap_or_else(|e| panic!("{e}"))
}

/// Modules driven in-process by [`Plc::tick`].
pub struct Plc {
    pub layout: Layout,
    pub plc_id: String,
    global: GlobalMap,
    pub modules: Vec<(String, Box<dyn Module>, ModuleMap)>,
    scans: u64,
}

/// Makes every module of `text` (read as a file in `dir`) and initialises it; the first
/// factory or init error is returned. The shared memory is unlinked when `Plc` drops.
pub fn start(text: &str, dir: &Path, registry: Registry) -> Result<Plc, ModuleError> {
    let cfg = config(text, dir);
    let layout = Layout::new(&cfg).unwrap_or_else(|e| panic!("{e}"));
    let plc_id = plc_id();
    let global = GlobalMap::create(&plc_id, &layout).unwrap_or_else(|e| panic!("{e}"));
    let mut modules = Vec::new();
    for decl in &cfg.modules {
        let factory =
            registry(&decl.kind).unwrap_or_else(|| panic!("no built-in kind {}", decl.kind));
        let mut module = factory(decl)?;
        let mut map = ModuleMap::new(&layout, &decl.name, decl.location).unwrap();
        module.init(&mut InitContext {
            decl,
            config: &cfg,
            map: &mut map,
            base_dir: dir,
            plc_id: &plc_id,
            restored_points: &[],
        })?;
        modules.push((decl.name.clone(), module, map));
    }
    Ok(Plc {
        layout,
        plc_id,
        global,
        modules,
        scans: 0,
    })
}

/// The error `start` gives, as text.
pub fn start_err(text: &str, dir: &Path, registry: Registry) -> String {
    match start(text, dir, registry) {
        Ok(_) => panic!("started without an error"),
        Err(e) => e.to_string(),
    }
}

impl Plc {
    /// One scan of every module at `now`, in declaration order, each framed by `update()`s.
    pub fn tick(&mut self, now: Duration) -> Result<Vec<Control>, ModuleError> {
        let mut controls = Vec::new();
        for (_, module, map) in &mut self.modules {
            map.update(&self.global);
            controls.push(module.scan(&mut ScanContext {
                now,
                scan: self.scans,
                map,
            })?);
            map.update(&self.global);
        }
        self.scans += 1;
        Ok(controls)
    }

    /// A point's value in the global map.
    pub fn get(&self, point: &str) -> PointValue {
        let id = self
            .layout
            .point(point)
            .unwrap_or_else(|| panic!("no point {point}"));
        self.global.read_point(&self.layout, id)
    }

    /// A bool or integer point's value.
    pub fn value(&self, point: &str) -> i64 {
        match self.get(point) {
            PointValue::Unsigned(v) => i64::from(v),
            PointValue::Signed(v) => i64::from(v),
            PointValue::Float(v) => panic!("{point} is a float point ({v})"),
        }
    }

    /// A module's status line.
    pub fn status(&self, module: &str) -> String {
        let (_, m, _) = self.modules.iter().find(|m| m.0 == module).unwrap();
        m.status()
    }

    /// Closes every module.
    pub fn close(&mut self) {
        for (_, m, _) in &mut self.modules {
            m.close();
        }
    }
}

/// `n` milliseconds.
pub fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}
