//! What a PNML file holds that the net model does not (graphics, other tools' toolspecific
//! data, unknown labels, the page id), kept as raw XML so that writing a net back keeps it.

use std::collections::BTreeMap;

/// The parts of a file the model does not hold, by element id. Fragments are the original
/// XML text, re-emitted verbatim.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Layout {
    /// The id of the (first top-level) page; nested pages are flattened into it.
    pub page_id: Option<String>,
    /// The net's own extras (other tools' toolspecific data, its name's extras).
    pub net: Extras,
    /// The first page's extras (its name, graphics, toolspecific data).
    pub page: Extras,
    /// Extras of places, transitions and arcs, by element id.
    pub elements: BTreeMap<String, Extras>,
}

/// Raw XML an element carries besides what the model holds.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Extras {
    /// Child elements petriplc does not read: `<graphics>`, other tools' `<toolspecific>`,
    /// labels of other net types.
    pub children: Vec<String>,
    /// For each label petriplc reads (`name`, `initialMarking`, `inscription`), the children
    /// it has besides `<text>` (usually its `<graphics>` offset).
    pub labels: BTreeMap<String, Vec<String>>,
}

impl Extras {
    pub fn is_empty(&self) -> bool {
        self.children.is_empty() && self.labels.values().all(Vec::is_empty)
    }

    /// The extras of label `name`, empty when it has none.
    pub fn label(&self, name: &str) -> &[String] {
        self.labels.get(name).map_or(&[], Vec::as_slice)
    }
}

impl Layout {
    /// The extras of element `id`, if it has any.
    pub fn element(&self, id: &str) -> Option<&Extras> {
        self.elements.get(id)
    }
}
