//! The cross-checks of a configuration's tables once read: points against each other and
//! the modules that own them, modules' names and links, and the synchronisation net.

use std::collections::{BTreeMap, HashMap, HashSet};

use super::{declared, Builder, NULL};
use crate::error;
use crate::model::{ArcDecl, Origin, PointDecl};

impl Builder {
    pub(super) fn check_points(&mut self) {
        let mut first: HashMap<&str, &Origin> = HashMap::new();
        let mut diags = Vec::new();
        for p in &self.points {
            if let Some(o) = first.get(p.name.as_str()) {
                diags.push(
                    error::diagnostic(
                        &p.origin,
                        error::DUPLICATE_POINT,
                        format!(
                            "point {} is declared twice (first at {o}): a point has one owner and \
                         one place, so rename or remove one of them",
                            p.name
                        ),
                    )
                    .with_label(
                        (*o).clone(),
                        format!("point {} first declared here", p.name),
                    ),
                );
            } else {
                first.insert(&p.name, &p.origin);
            }
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        for p in &self.points {
            if !modules.contains(p.owner.as_str()) {
                diags.push(error::diagnostic(
                    &p.origin,
                    error::UNKNOWN_OWNER,
                    format!(
                        "the owner of point {}, `{}`, is not a declared module: add `module {} \
                         KIND-or-PATH` to [PLC] or give the point another owner ({})",
                        p.name,
                        p.owner,
                        p.owner,
                        declared("modules", self.modules.iter().map(|m| m.name.as_str()))
                    ),
                ));
            }
        }
        // Placed points by word, to find shared bits in one pass over each word.
        let mut by_word: BTreeMap<u32, Vec<&PointDecl>> = BTreeMap::new();
        for p in &self.points {
            if let Some((w, _)) = p.at {
                by_word.entry(w).or_default().push(p);
            }
        }
        for (word, points) in by_word {
            for (j, b) in points.iter().enumerate() {
                for a in &points[..j] {
                    if mask(a) & mask(b) != 0 && a.name != b.name {
                        diags.push(
                            error::diagnostic(
                                &b.origin,
                                error::OVERLAPPING_POINTS,
                                format!(
                                "point {} (bits {}) overlaps point {} (bits {}, at {}) in word \
                                 {word}: each bit has one writer, so move one of them",
                                b.name,
                                bit_range(b),
                                a.name,
                                bit_range(a),
                                a.origin
                            ),
                            )
                            .with_label(
                                a.origin.clone(),
                                format!("point {} declared here", a.name),
                            ),
                        );
                    }
                }
            }
        }
        self.diags.extend(diags);
    }

    pub(super) fn check_modules(&mut self) {
        let mut first: HashMap<&str, &Origin> = HashMap::new();
        let mut diags = Vec::new();
        for m in &self.modules {
            if m.name.eq_ignore_ascii_case("PLC") || m.name == NULL {
                diags.push(error::diagnostic(
                    &m.origin,
                    error::RESERVED_NAME,
                    format!("`{}` is reserved: give the module another name", m.name),
                ));
            }
            if let Some(o) = first.get(m.name.as_str()) {
                diags.push(
                    error::diagnostic(
                        &m.origin,
                        error::DUPLICATE_MODULE,
                        format!(
                            "module {} is declared twice (first at {o}): module names name their \
                         sections, so rename or remove one of them",
                            m.name
                        ),
                    )
                    .with_label(
                        (*o).clone(),
                        format!("module {} first declared here", m.name),
                    ),
                );
            } else {
                first.insert(&m.name, &m.origin);
            }
        }
        let modules: HashSet<&str> = self.modules.iter().map(|m| m.name.as_str()).collect();
        let known = || declared("modules", self.modules.iter().map(|m| m.name.as_str()));
        for r in &self.synch.rules {
            for name in [&r.from, &r.to] {
                if !modules.contains(name.as_str()) {
                    diags.push(error::diagnostic(
                        &r.origin,
                        error::UNKNOWN_SYNCH_MODULE,
                        format!(
                            "`synch` names `{name}`, which is not a declared module: declare it \
                             with `module {name} KIND-or-PATH` or correct the name ({})",
                            known()
                        ),
                    ));
                }
            }
        }
        for (name, o) in &self.synch.starts {
            if !modules.contains(name.as_str()) {
                diags.push(error::diagnostic(
                    o,
                    error::UNKNOWN_SYNCH_MODULE,
                    format!(
                        "`synch_start` names `{name}`, which is not a declared module: declare \
                         it with `module {name} KIND-or-PATH` or correct the name ({})",
                        known()
                    ),
                ));
            }
        }
        self.diags.extend(diags);
    }

    pub(super) fn check_net(&mut self) {
        let mut diags = Vec::new();
        let mut first: HashMap<&str, (&Origin, &str)> = HashMap::new();
        for (name, o, kind) in &self.nodes {
            if name == NULL {
                diags.push(error::diagnostic(
                    o,
                    error::RESERVED_NAME,
                    format!(
                        "`NULL` is reserved for the null transition: give the {kind} another name"
                    ),
                ));
            } else if let Some((at, was)) = first.get(name.as_str()) {
                diags.push(
                    error::diagnostic(
                        o,
                        error::DUPLICATE_NODE,
                        format!(
                            "`{name}` is already declared as a {was} at {at}: places and \
                         transitions share one set of names, so rename one of them"
                        ),
                    )
                    .with_label((*at).clone(), format!("the {was} `{name}` declared here")),
                );
            } else {
                first.insert(name, (o, *kind));
            }
        }
        let mut arcs = Vec::new();
        for a in &self.arcs {
            let mut kinds = Vec::new();
            for end in [&a.from, &a.to] {
                if end == NULL {
                    diags.push(error::diagnostic(
                        &a.origin,
                        error::UNKNOWN_ARC_END,
                        "an arc cannot touch `NULL` (the null transition never fires anything): \
                         declare a transition and use it",
                    ));
                } else if let Some((_, kind)) = first.get(end.as_str()) {
                    kinds.push(*kind);
                } else {
                    diags.push(error::diagnostic(
                        &a.origin,
                        error::UNKNOWN_ARC_END,
                        format!(
                            "the arc names `{end}`, which is neither a place nor a transition: \
                             declare it with `place {end}` or `transition {end}`"
                        ),
                    ));
                }
            }
            let [from, to] = kinds[..] else { continue };
            if from == to {
                diags.push(error::diagnostic(
                    &a.origin,
                    error::ARC_SAME_KIND,
                    format!(
                        "the arc goes from {from} `{}` to {to} `{}`: an arc joins a place and a \
                         transition",
                        a.from, a.to
                    ),
                ));
            } else if a.weight == 0 && from == "transition" {
                diags.push(error::diagnostic(
                    &a.origin,
                    error::ZERO_WEIGHT_FROM_TRANSITION,
                    format!(
                        "the arc from transition `{}` to place `{}` has weight 0, which only \
                         arcs from a place may have (\"fire only while the place is empty\"): \
                         give it a weight of 1 or more",
                        a.from, a.to
                    ),
                ));
            } else {
                arcs.push(ArcDecl {
                    from: a.from.clone(),
                    to: a.to.clone(),
                    weight: a.weight,
                    origin: a.origin.clone(),
                });
            }
        }
        self.synch.arcs = arcs;
        self.diags.extend(diags);
    }
}

fn mask(p: &PointDecl) -> u64 {
    let bit = p.at.map_or(0, |(_, b)| b);
    ((1u64 << p.bits) - 1) << bit
}

fn bit_range(p: &PointDecl) -> String {
    let bit = p.at.map_or(0, |(_, b)| b);
    if p.bits == 1 {
        format!("{bit}")
    } else {
        format!("{bit}-{}", u32::from(bit) + u32::from(p.bits) - 1)
    }
}
