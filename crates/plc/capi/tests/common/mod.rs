//! A PLC created inside the test process (what `petriplc run` would set up), for modules
//! under test to attach to.

#![allow(dead_code)] // Each test file uses its own part of this.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use petriplc_config::PlcConfig;
use petriplc_runtime::image::{GlobalMap, Layout, ModuleMap};
use petriplc_runtime::synch::{SharedSynch, SynchNet};

/// A running PLC: its shared memory lives (and is unlinked) with this value.
pub struct TestPlc {
    pub id: String,
    pub config_path: PathBuf,
    pub config: PlcConfig,
    pub layout: Layout,
    pub net: SynchNet,
    pub global: GlobalMap,
    pub synch: SharedSynch,
    pub dir: tempfile::TempDir,
}

/// A plc id no other test, test process or earlier run uses at the same time.
pub fn unique_id(test: &str) -> String {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    format!(
        "capi-{}-{}-{test}",
        std::process::id(),
        NEXT.fetch_add(1, Ordering::Relaxed)
    )
}

impl TestPlc {
    /// Parses `text` (also written to a file, for module processes to read) and creates the
    /// PLC's image and synchronisation marking.
    pub fn start(test: &str, text: &str) -> TestPlc {
        let dir = tempfile::tempdir().unwrap();
        let config_path = dir.path().join("plc.conf");
        std::fs::write(&config_path, text).unwrap();
        let config = petriplc_config::parse_str(text, &config_path.to_string_lossy(), dir.path())
            .unwrap_or_else(|e| panic!("test configuration:\n{e}"));
        let layout = Layout::new(&config).unwrap();
        let net = SynchNet::from_config(&config).unwrap();
        let id = unique_id(test);
        let global = GlobalMap::create(&id, &layout).unwrap();
        let synch = SharedSynch::create(&id, &net).unwrap();
        TestPlc {
            id,
            config_path,
            config,
            layout,
            net,
            global,
            synch,
            dir,
        }
    }

    /// The map of a module the test itself plays.
    pub fn module_map(&self, module: &str) -> ModuleMap {
        let decl = self
            .config
            .modules
            .iter()
            .find(|m| m.name == module)
            .unwrap();
        ModuleMap::new(&self.layout, module, decl.location).unwrap()
    }
}
