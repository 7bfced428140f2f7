//! Retentive points in the process image: the values a start restores are written into the
//! global map before any module's first scan, and a map made for a module adopts its own
//! retentive points from the global map before its first `update()` (which would otherwise
//! write the map's init values over them). The runner snapshots them for the retain file
//! with [`read`] under the image lock. Module-private retained data: see
//! `petriplc_retain::data` and [`crate::module::InitContext::retain`].

use crate::image::{GlobalMap, Layout, ModuleMap, PointId};

/// Which of a module's own points [`adopt`] takes from the global map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Adopt {
    /// Its retentive points (a module that starts: the rest start from their init values).
    Retentive,
    /// All of them (a map that writes a few values, e.g. safe values, and must leave the
    /// others as they are).
    All,
}

/// Sets the module's own points (`which`) in `map` to their values in `global`, so that the
/// map's next `update()` writes them back unchanged.
pub fn adopt(map: &mut ModuleMap, global: &GlobalMap, which: Adopt) {
    let layout = map.layout().clone();
    let own: Vec<(PointId, &crate::image::Slot)> = layout
        .points()
        .filter(|(_, s)| s.owner == map.module() && (which == Adopt::All || s.retain))
        .collect();
    if own.is_empty() {
        return;
    }
    let words: Vec<u32> = {
        let g = global.lock();
        own.iter()
            .map(|(_, s)| g.words()[s.word as usize])
            .collect()
    };
    for ((id, slot), word) in own.into_iter().zip(words) {
        if let Ok(h) = map.handle(&slot.name) {
            debug_assert_eq!(h.id(), id);
            // The value is the point's own bits: it always suits the point.
            let _ = map.set(&h, slot.decode(word));
        }
    }
}

/// The retentive points of `layout`, in declaration order.
pub fn points(layout: &Layout) -> Vec<PointId> {
    layout
        .points()
        .filter(|(_, s)| s.retain)
        .map(|(id, _)| id)
        .collect()
}

/// The bits of points `ids` as their owners last wrote them (forces are not retained),
/// appended to `out` with the image's lock held while `also` runs (a caller that must copy
/// other data as of the same instant does it there).
pub fn read<R>(
    global: &GlobalMap,
    layout: &Layout,
    ids: &[PointId],
    out: &mut Vec<u32>,
    also: impl FnOnce() -> R,
) -> R {
    let g = global.lock();
    let words = g.words();
    out.extend(ids.iter().map(|&id| {
        let s = layout.slot(id);
        (words[s.word as usize] & s.field_mask()) >> s.bit
    }));
    also()
}

/// Writes the bits of points into the global map (at start, before any module runs).
pub fn write(global: &GlobalMap, layout: &Layout, values: &[(PointId, u32)]) {
    let mut g = global.lock();
    let words = g.words_mut();
    for &(id, raw) in values {
        let s = layout.slot(id);
        let w = &mut words[s.word as usize];
        *w = (*w & !s.field_mask()) | ((raw << s.bit) & s.field_mask());
    }
}
