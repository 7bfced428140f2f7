//! The process images `benches/update.rs` and `examples/update-ratio.rs` measure `update()` on.

use petriplc_config::{ModuleDecl, Origin, PlcConfig, PointDecl, PointKind, PointValue};
use petriplc_runtime::image::Layout;

pub const MODULES: [&str; 4] = ["m0", "m1", "m2", "m3"];

/// `n` 32-bit points (one word each) owned by four modules, either interleaved (word i by
/// module i % 4: the worst shape for the owned runs) or in four contiguous blocks.
pub fn layout(n: usize, interleaved: bool) -> Layout {
    let module = |name: &str| ModuleDecl::new(name, "bench");
    let points = (0..n)
        .map(|i| PointDecl {
            name: format!("p{i}"),
            description: String::new(),
            owner: MODULES[if interleaved { i % 4 } else { i * 4 / n }].into(),
            at: None,
            kind: PointKind::Unsigned,
            bits: 32,
            init: PointValue::Unsigned(0),
            retain: false,
            origin: Origin::default(),
        })
        .collect();
    Layout::new(&PlcConfig {
        modules: MODULES.iter().map(|m| module(m)).collect(),
        points,
        ..Default::default()
    })
    .expect("layout")
}
