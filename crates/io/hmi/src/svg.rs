//! A net drawn as SVG for the HMI page: places as circles with their tokens, transitions as
//! bars, arcs with arrowheads (read arcs dashed with a dot, inhibitor arcs ending in a
//! circle), laid out from the PNML file's positions when it has them and otherwise in layers
//! of our own. Every element carries its label and id in data attributes, so that the page
//! can redraw the tokens in place.

use std::fmt::Write as _;

use petriplc_net::{Arc, ArcDirection, ArcKind, Net};
use petriplc_pnml::{Extras, Layout};

/// The radius of a place.
const PLACE_R: f64 = 16.0;
/// A transition's bar, across the flow and along it.
const BAR_LONG: f64 = 32.0;
const BAR_SHORT: f64 = 8.0;
/// Nodes closer than this (after scaling PNML positions up) would overlap with their labels.
const MIN_GAP: f64 = 72.0;
/// The layered layout's spacing.
const LAYER_DY: f64 = 80.0;
const LAYER_DX: f64 = 110.0;
const MARGIN: f64 = 24.0;
/// A rough width of one character of a 12 px label, to make room for labels.
const CHAR_W: f64 = 7.0;
/// Up to this many tokens are drawn as dots; more as a number (the page does the same).
pub const MAX_DOTS: u64 = 4;

#[derive(Clone, Copy, Debug, PartialEq)]
struct Pt {
    x: f64,
    y: f64,
}

impl Pt {
    fn dist(self, o: Pt) -> f64 {
        (self.x - o.x).hypot(self.y - o.y)
    }
}

/// Where every node is, in drawing coordinates.
struct Geometry {
    places: Vec<Pt>,
    transitions: Vec<Pt>,
    /// Bend points of each arc (by arc index).
    bends: Vec<Vec<Pt>>,
    /// Per transition: the bar lies across a vertical flow (wide) or a horizontal one (tall).
    wide: Vec<bool>,
    /// True when the positions came from the file.
    from_file: bool,
}

/// The SVG of `net`; `prefix` makes the ids of its markers unique within a page that shows
/// several nets.
pub fn draw(net: &Net, layout: &Layout, prefix: &str) -> String {
    let g = geometry(net, layout);
    let mut min = Pt {
        x: f64::INFINITY,
        y: f64::INFINITY,
    };
    let mut max = Pt {
        x: f64::NEG_INFINITY,
        y: f64::NEG_INFINITY,
    };
    let mut grow = |p: Pt, e: Extent| {
        min.x = min.x.min(p.x - e.left);
        min.y = min.y.min(p.y - e.up);
        max.x = max.x.max(p.x + e.right);
        max.y = max.y.max(p.y + e.down);
    };
    let dirs = arc_directions(net, &g);
    let place_labels: Vec<Label> = g
        .places
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let chars = net.place_label(i.into()).chars().count();
            label_at(p, PLACE_R, PLACE_R, &dirs.places[i], chars)
        })
        .collect();
    let transition_labels: Vec<Label> = g
        .transitions
        .iter()
        .enumerate()
        .map(|(i, &p)| {
            let (hw, hh) = bar(g.wide[i]);
            let chars = net.transition_label(i.into()).chars().count();
            label_at(p, hw, hh, &dirs.transitions[i], chars)
        })
        .collect();
    for (&p, l) in g.places.iter().zip(&place_labels) {
        grow(p, l.extent);
    }
    for (&p, l) in g.transitions.iter().zip(&transition_labels) {
        grow(p, l.extent);
    }
    for p in g.bends.iter().flatten() {
        grow(*p, Extent::default());
    }
    if !min.x.is_finite() {
        // A net with no nodes.
        min = Pt { x: 0.0, y: 0.0 };
        max = Pt { x: 40.0, y: 20.0 };
    }
    let (x0, y0) = (min.x - MARGIN, min.y - MARGIN);
    let (w, h) = (max.x - min.x + 2.0 * MARGIN, max.y - min.y + 2.0 * MARGIN);

    let mut s = String::new();
    let _ = write!(
        s,
        r##"<svg xmlns="http://www.w3.org/2000/svg" class="net" viewBox="{} {} {} {}" width="{}" height="{}" role="img" aria-label="net {}" data-net="{}" data-layout="{}" font-family="sans-serif" font-size="12">"##,
        n(x0),
        n(y0),
        n(w),
        n(h),
        n(w),
        n(h),
        esc(&net.name),
        esc(&net.id),
        if g.from_file { "pnml" } else { "layered" }
    );
    let _ = write!(
        s,
        r##"<defs><marker id="{prefix}-arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" markerHeight="7" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#333"/></marker><marker id="{prefix}-read" viewBox="0 0 10 10" refX="5" refY="5" markerWidth="6" markerHeight="6"><circle cx="5" cy="5" r="4" fill="#333"/></marker><marker id="{prefix}-inhibitor" viewBox="0 0 10 10" refX="9" refY="5" markerWidth="7" markerHeight="7"><circle cx="5" cy="5" r="4" fill="#fff" stroke="#333" stroke-width="1.5"/></marker></defs>"##
    );

    s.push_str(r#"<g class="arcs">"#);
    for (i, arc) in net.arcs().iter().enumerate() {
        draw_arc(&mut s, net, &g, i, arc, prefix);
    }
    s.push_str("</g>");

    s.push_str(r#"<g class="transitions">"#);
    for (i, &p) in g.transitions.iter().enumerate() {
        let t = i.into();
        let label = net.transition_label(t);
        let (hw, hh) = bar(g.wide[i]);
        let guard = net.guard_text(t);
        let _ = write!(
            s,
            r##"<g class="transition" data-transition="{}" data-id="{}" data-cx="{}" data-cy="{}"><title>{}{}</title><rect x="{}" y="{}" width="{}" height="{}" fill="#333"/>{}</g>"##,
            esc(label),
            esc(&net.transition(t).id),
            n(p.x),
            n(p.y),
            esc(label),
            if guard.is_empty() || guard == "TRUE" {
                String::new()
            } else {
                format!(" if {}", esc(&guard))
            },
            n(p.x - hw),
            n(p.y - hh),
            n(2.0 * hw),
            n(2.0 * hh),
            transition_labels[i].svg(label)
        );
    }
    s.push_str("</g>");

    s.push_str(r#"<g class="places">"#);
    for (i, &p) in g.places.iter().enumerate() {
        let place = net.place(i.into());
        let label = net.place_label(i.into());
        let tokens = u64::from(place.initial);
        let _ = write!(
            s,
            r##"<g class="place" data-place="{}" data-id="{}" data-index="{i}" data-cx="{}" data-cy="{}" data-tokens="{tokens}"><title>{}</title><circle class="place-circle" cx="{}" cy="{}" r="{PLACE_R}" fill="#fff" stroke="#333" stroke-width="1.5"/><g class="tokens">{}</g>{}</g>"##,
            esc(label),
            esc(&place.id),
            n(p.x),
            n(p.y),
            esc(label),
            n(p.x),
            n(p.y),
            tokens_svg(p.x, p.y, tokens),
            place_labels[i].svg(label)
        );
    }
    s.push_str("</g></svg>");
    s
}

/// How far a node and its label reach from the node's centre.
#[derive(Clone, Copy, Debug, Default)]
struct Extent {
    left: f64,
    right: f64,
    up: f64,
    down: f64,
}

/// Where a node's label is written.
struct Label {
    x: f64,
    y: f64,
    anchor: &'static str,
    extent: Extent,
}

impl Label {
    fn svg(&self, text: &str) -> String {
        format!(
            r##"<text class="label" x="{}" y="{}" text-anchor="{}" fill="#222">{}</text>"##,
            n(self.x),
            n(self.y),
            self.anchor,
            esc(text)
        )
    }
}

/// The label beside a node of half-size (hw, hh), on the side (right, left, below, above:
/// the first of the best) that the node's arcs, leaving in directions `dirs`, run least
/// towards.
fn label_at(c: Pt, hw: f64, hh: f64, dirs: &[Pt], chars: usize) -> Label {
    const SIDES: [(f64, f64); 4] = [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)];
    let crowding = |(sx, sy): (f64, f64)| {
        dirs.iter()
            .map(|d| {
                let len = d.x.hypot(d.y);
                if len < 1e-9 {
                    -1.0
                } else {
                    (d.x * sx + d.y * sy) / len
                }
            })
            .fold(-1.0f64, f64::max)
    };
    let mut best = (0, crowding(SIDES[0]));
    for (k, &side) in SIDES.iter().enumerate().skip(1) {
        // Clearly better only: a near tie keeps the earlier (more readable) side.
        let c = crowding(side);
        if c < best.1 - 0.05 {
            best = (k, c);
        }
    }
    let best = best.0;
    let w = chars as f64 * CHAR_W;
    let body = Extent {
        left: hw,
        right: hw,
        up: hh.max(8.0),
        down: hh.max(8.0),
    };
    match best {
        0 => Label {
            x: c.x + hw + 4.0,
            y: c.y + 4.0,
            anchor: "start",
            extent: Extent {
                right: hw + 4.0 + w,
                ..body
            },
        },
        1 => Label {
            x: c.x - hw - 4.0,
            y: c.y + 4.0,
            anchor: "end",
            extent: Extent {
                left: hw + 4.0 + w,
                ..body
            },
        },
        2 => Label {
            x: c.x,
            y: c.y + hh + 14.0,
            anchor: "middle",
            extent: Extent {
                left: hw.max(w / 2.0),
                right: hw.max(w / 2.0),
                down: hh + 17.0,
                ..body
            },
        },
        _ => Label {
            x: c.x,
            y: c.y - hh - 5.0,
            anchor: "middle",
            extent: Extent {
                left: hw.max(w / 2.0),
                right: hw.max(w / 2.0),
                up: hh + 17.0,
                ..body
            },
        },
    }
}

/// Per node, the directions in which its arcs leave it.
struct Directions {
    places: Vec<Vec<Pt>>,
    transitions: Vec<Vec<Pt>>,
}

fn arc_directions(net: &Net, g: &Geometry) -> Directions {
    let mut d = Directions {
        places: vec![Vec::new(); g.places.len()],
        transitions: vec![Vec::new(); g.transitions.len()],
    };
    for (i, arc) in net.arcs().iter().enumerate() {
        let (p, t) = (
            g.places[arc.place.index()],
            g.transitions[arc.transition.index()],
        );
        // Bends run from the arc's source to its target.
        let bends = &g.bends[i];
        let (near_p, near_t) = match arc.direction {
            ArcDirection::PlaceToTransition => (bends.first(), bends.last()),
            ArcDirection::TransitionToPlace => (bends.last(), bends.first()),
        };
        let to_p = near_p.copied().unwrap_or(t);
        let to_t = near_t.copied().unwrap_or(p);
        d.places[arc.place.index()].push(Pt {
            x: to_p.x - p.x,
            y: to_p.y - p.y,
        });
        d.transitions[arc.transition.index()].push(Pt {
            x: to_t.x - t.x,
            y: to_t.y - t.y,
        });
    }
    d
}

/// The dots (or the number) of `tokens` tokens in a place centred on (x, y). The page's
/// script draws them the same way (`tokensSvg` in hmi.js).
fn tokens_svg(x: f64, y: f64, tokens: u64) -> String {
    const DOTS: [&[(f64, f64)]; 5] = [
        &[],
        &[(0.0, 0.0)],
        &[(-5.0, 0.0), (5.0, 0.0)],
        &[(0.0, -5.0), (-5.0, 4.0), (5.0, 4.0)],
        &[(-5.0, -5.0), (5.0, -5.0), (-5.0, 5.0), (5.0, 5.0)],
    ];
    if tokens > MAX_DOTS {
        return format!(
            r##"<text class="token-count" x="{}" y="{}" text-anchor="middle" font-weight="bold" fill="#1a5fb4">{tokens}</text>"##,
            n(x),
            n(y + 4.0)
        );
    }
    DOTS[tokens as usize]
        .iter()
        .map(|(dx, dy)| {
            format!(
                r##"<circle class="token" cx="{}" cy="{}" r="3.5" fill="#1a5fb4"/>"##,
                n(x + dx),
                n(y + dy)
            )
        })
        .collect()
}

fn draw_arc(s: &mut String, net: &Net, g: &Geometry, i: usize, arc: &Arc, prefix: &str) {
    let p = g.places[arc.place.index()];
    let t = g.transitions[arc.transition.index()];
    let (hw, hh) = bar(g.wide[arc.transition.index()]);
    // Read and inhibitor arcs are drawn from the place to the transition whatever the file
    // says: the mark at their end is what tells them apart.
    let from_place =
        arc.direction == ArcDirection::PlaceToTransition || arc.kind != ArcKind::Normal;
    // The file lists bend points from the arc's source to its target.
    let (source, target) = match arc.direction {
        ArcDirection::PlaceToTransition => (p, t),
        ArcDirection::TransitionToPlace => (t, p),
    };
    let mut pts = vec![source];
    pts.extend(g.bends[i].iter().copied());
    pts.push(target);
    if from_place != (arc.direction == ArcDirection::PlaceToTransition) {
        pts.reverse();
    }
    let last = pts.len() - 1;
    let (place_end, bar_end) = if from_place { (0, last) } else { (last, 0) };
    pts[place_end] = clip_circle(pts[place_end], towards(&pts, place_end));
    pts[bar_end] = clip_rect(pts[bar_end], towards(&pts, bar_end), hw, hh);
    let d: String = pts
        .iter()
        .enumerate()
        .map(|(k, q)| format!("{}{},{}", if k == 0 { "M" } else { " L" }, n(q.x), n(q.y)))
        .collect();
    let (kind, style) = match arc.kind {
        ArcKind::Normal => ("normal", format!(r#"marker-end="url(#{prefix}-arrow)""#)),
        ArcKind::Read => (
            "read",
            format!(r#"stroke-dasharray="5 3" marker-end="url(#{prefix}-read)""#),
        ),
        ArcKind::Inhibitor => (
            "inhibitor",
            format!(r#"marker-end="url(#{prefix}-inhibitor)""#),
        ),
    };
    let _ = write!(
        s,
        r##"<path class="arc {kind}" data-id="{}" data-kind="{kind}" data-place="{}" data-transition="{}" data-dir="{}" d="{d}" fill="none" stroke="#333" stroke-width="1.5" {style}/>"##,
        esc(&arc.id),
        esc(net.place_label(arc.place)),
        esc(net.transition_label(arc.transition)),
        if from_place && arc.kind == ArcKind::Normal {
            "in"
        } else if arc.kind == ArcKind::Normal {
            "out"
        } else {
            "test"
        }
    );
    if arc.weight != 1 {
        let k = pts.len() / 2;
        let (a, b) = (pts[k - 1], pts[k]);
        let _ = write!(
            s,
            r##"<text class="weight" x="{}" y="{}" fill="#222">{}</text>"##,
            n((a.x + b.x) / 2.0 + 5.0),
            n((a.y + b.y) / 2.0 - 3.0),
            arc.weight
        );
    }
}

/// The neighbour of point `k` on a polyline, to clip that end towards.
fn towards(pts: &[Pt], k: usize) -> Pt {
    if k == 0 {
        pts[1]
    } else {
        pts[k - 1]
    }
}

fn clip_circle(c: Pt, to: Pt) -> Pt {
    let d = c.dist(to);
    if d <= PLACE_R {
        return c;
    }
    Pt {
        x: c.x + (to.x - c.x) * PLACE_R / d,
        y: c.y + (to.y - c.y) * PLACE_R / d,
    }
}

fn clip_rect(c: Pt, to: Pt, hw: f64, hh: f64) -> Pt {
    let (dx, dy) = (to.x - c.x, to.y - c.y);
    let d = dx.hypot(dy);
    if d < 1e-9 {
        return c;
    }
    let (ux, uy) = (dx / d, dy / d);
    let tx = if ux.abs() > 1e-9 {
        hw / ux.abs()
    } else {
        f64::INFINITY
    };
    let ty = if uy.abs() > 1e-9 {
        hh / uy.abs()
    } else {
        f64::INFINITY
    };
    let t = tx.min(ty).min(d);
    Pt {
        x: c.x + ux * t,
        y: c.y + uy * t,
    }
}

/// Half the width and half the height of a transition's bar.
fn bar(wide: bool) -> (f64, f64) {
    if wide {
        (BAR_LONG / 2.0, BAR_SHORT / 2.0)
    } else {
        (BAR_SHORT / 2.0, BAR_LONG / 2.0)
    }
}

fn geometry(net: &Net, layout: &Layout) -> Geometry {
    let (places, transitions, bends, from_file) = match file_positions(net, layout) {
        Some((p, t, b)) => (p, t, b, true),
        None => {
            let (p, t) = layered(net);
            (p, t, vec![Vec::new(); net.arcs().len()], false)
        }
    };
    // A bar lies across the flow: wide when its straight arcs run mostly up and down (an
    // arc with bends usually goes round the drawing, against the flow).
    let mut flow = vec![(0.0f64, 0.0f64); transitions.len()];
    let mut bent = vec![(0.0f64, 0.0f64); transitions.len()];
    for (i, arc) in net.arcs().iter().enumerate() {
        let t = transitions[arc.transition.index()];
        let other = bends[i]
            .iter()
            .copied()
            .min_by(|a, b| a.dist(t).total_cmp(&b.dist(t)))
            .unwrap_or(places[arc.place.index()]);
        let f = if bends[i].is_empty() {
            &mut flow[arc.transition.index()]
        } else {
            &mut bent[arc.transition.index()]
        };
        f.0 += (other.x - t.x).abs();
        f.1 += (other.y - t.y).abs();
    }
    for (f, b) in flow.iter_mut().zip(&bent) {
        if *f == (0.0, 0.0) {
            *f = *b;
        }
    }
    Geometry {
        places,
        transitions,
        bends,
        wide: flow.iter().map(|(dx, dy)| dy >= dx).collect(),
        from_file,
    }
}

type Positions = (Vec<Pt>, Vec<Pt>, Vec<Vec<Pt>>);

/// The positions of the file's `<graphics>`, scaled so that nodes are far enough apart;
/// `None` unless every place and transition has one and no two share one.
fn file_positions(net: &Net, layout: &Layout) -> Option<Positions> {
    let node = |id: &str| {
        layout
            .element(id)
            .and_then(|e| positions(e).first().copied())
    };
    let places: Vec<Pt> = net
        .places()
        .iter()
        .map(|p| node(&p.id))
        .collect::<Option<_>>()?;
    let transitions: Vec<Pt> = net
        .transitions()
        .iter()
        .map(|t| node(&t.id))
        .collect::<Option<_>>()?;
    let bends: Vec<Vec<Pt>> = net
        .arcs()
        .iter()
        .map(|a| layout.element(&a.id).map(positions).unwrap_or_default())
        .collect();
    let all: Vec<Pt> = places.iter().chain(&transitions).copied().collect();
    let mut min_d = f64::INFINITY;
    for (i, a) in all.iter().enumerate() {
        for b in &all[i + 1..] {
            min_d = min_d.min(a.dist(*b));
        }
    }
    if min_d < 1.0 {
        return None;
    }
    // Scale up crowded drawings; never down (a sparse drawing is the author's choice).
    let k = if min_d.is_finite() && min_d < MIN_GAP {
        (MIN_GAP / min_d).min(8.0)
    } else {
        1.0
    };
    let scale = |v: Vec<Pt>| -> Vec<Pt> {
        v.into_iter()
            .map(|p| Pt {
                x: p.x * k,
                y: p.y * k,
            })
            .collect()
    };
    Some((
        scale(places),
        scale(transitions),
        bends.into_iter().map(scale).collect(),
    ))
}

/// Every `<position>` of an element's `<graphics>` (a node's centre, an arc's bend points).
fn positions(extras: &Extras) -> Vec<Pt> {
    for child in &extras.children {
        if !child.trim_start().starts_with("<graphics") && !child.contains(":graphics") {
            continue;
        }
        let Ok(doc) = roxmltree::Document::parse(child) else {
            continue;
        };
        let root = doc.root_element();
        if root.tag_name().name() != "graphics" {
            continue;
        }
        return root
            .children()
            .filter(|c| c.is_element() && c.tag_name().name() == "position")
            .filter_map(|c| {
                let num = |a: &str| c.attribute(a)?.trim().parse::<f64>().ok();
                let (x, y) = (num("x")?, num("y")?);
                (x.is_finite() && y.is_finite()).then_some(Pt { x, y })
            })
            .collect();
    }
    Vec::new()
}

/// A layered layout for nets without positions: layers by breadth-first distance along
/// normal arcs from the marked places (then from any node not reached), ordered within a
/// layer by the mean position of their neighbours in the layer above; deterministic.
fn layered(net: &Net) -> (Vec<Pt>, Vec<Pt>) {
    let np = net.places().len();
    let nt = net.transitions().len();
    let total = np + nt;
    // Nodes: places 0..np, transitions np..np+nt.
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); total];
    let mut neighbours: Vec<Vec<usize>> = vec![Vec::new(); total];
    for a in net.arcs() {
        let (p, t) = (a.place.index(), np + a.transition.index());
        neighbours[p].push(t);
        neighbours[t].push(p);
        if a.kind == ArcKind::Normal {
            match a.direction {
                ArcDirection::PlaceToTransition => succ[p].push(t),
                ArcDirection::TransitionToPlace => succ[t].push(p),
            }
        }
    }
    let mut layer = vec![usize::MAX; total];
    let mut queue = std::collections::VecDeque::new();
    for (i, p) in net.places().iter().enumerate() {
        if p.initial > 0 {
            layer[i] = 0;
            queue.push_back(i);
        }
    }
    let mut next_root = 0;
    loop {
        while let Some(v) = queue.pop_front() {
            for &w in &succ[v] {
                if layer[w] == usize::MAX {
                    layer[w] = layer[v] + 1;
                    queue.push_back(w);
                }
            }
        }
        while next_root < total && layer[next_root] != usize::MAX {
            next_root += 1;
        }
        if next_root == total {
            break;
        }
        // A part not reached from the marking: start it one layer below a placed
        // neighbour, or at the top.
        let below = neighbours[next_root]
            .iter()
            .filter(|&&w| layer[w] != usize::MAX)
            .map(|&w| layer[w] + 1)
            .min()
            .unwrap_or(0);
        layer[next_root] = below;
        queue.push_back(next_root);
    }
    let depth = layer.iter().copied().max().map_or(0, |m| m + 1);
    let mut rows: Vec<Vec<usize>> = vec![Vec::new(); depth];
    for (v, &l) in layer.iter().enumerate() {
        rows[l].push(v);
    }
    let mut slot = vec![0.0f64; total];
    for (l, row) in rows.iter_mut().enumerate() {
        let mut keyed: Vec<(f64, usize)> = row
            .iter()
            .map(|&v| {
                let above: Vec<f64> = neighbours[v]
                    .iter()
                    .filter(|&&w| l > 0 && layer[w] == l - 1)
                    .map(|&w| slot[w])
                    .collect();
                let key = if above.is_empty() {
                    f64::INFINITY
                } else {
                    above.iter().sum::<f64>() / above.len() as f64
                };
                (key, v)
            })
            .collect();
        keyed.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        *row = keyed.into_iter().map(|(_, v)| v).collect();
        for (k, &v) in row.iter().enumerate() {
            slot[v] = k as f64;
        }
    }
    let widest = rows.iter().map(Vec::len).max().unwrap_or(0) as f64;
    let mut pos = vec![Pt { x: 0.0, y: 0.0 }; total];
    for (l, row) in rows.iter().enumerate() {
        let offset = (widest - row.len() as f64) / 2.0;
        for (k, &v) in row.iter().enumerate() {
            pos[v] = Pt {
                x: (offset + k as f64) * LAYER_DX,
                y: l as f64 * LAYER_DY,
            };
        }
    }
    let transitions = pos.split_off(np);
    (pos, transitions)
}

/// A coordinate with at most one decimal, without a trailing `.0`.
fn n(v: f64) -> String {
    let r = (v * 10.0).round() / 10.0;
    if r == r.trunc() {
        format!("{}", r as i64)
    } else {
        format!("{r:.1}")
    }
}

/// Text escaped for XML content and attribute values.
pub(crate) fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            // XML 1.0 cannot carry most control characters, even escaped.
            c if (c as u32) < 0x20 && !matches!(c, '\t' | '\n' | '\r') => out.push('\u{FFFD}'),
            c => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use petriplc_pnml::{read_str, ReadOptions};

    fn doc(text: &str) -> petriplc_pnml::Document {
        read_str(text, "test.pnml", &ReadOptions::default()).unwrap()
    }

    fn pnml(body: &str) -> String {
        format!(
            r#"<pnml xmlns="http://www.pnml.org/version-2009/grammar/pnml"><net id="n" type="http://www.pnml.org/version-2009/grammar/ptnet"><page id="pg">{body}</page></net></pnml>"#
        )
    }

    /// Parses the SVG and returns, per element with `attr`, its value and `data-cx`/`data-cy`.
    fn nodes(svg: &str, attr: &str) -> Vec<(String, String, String)> {
        let d = roxmltree::Document::parse(svg).unwrap();
        d.descendants()
            .filter_map(|e| {
                Some((
                    e.attribute(attr)?.to_string(),
                    e.attribute("data-cx")?.to_string(),
                    e.attribute("data-cy")?.to_string(),
                ))
            })
            .collect()
    }

    #[test]
    fn file_positions_are_used_and_crowded_ones_scaled() {
        let d = doc(&pnml(
            r#"<place id="a"><graphics><position x="10" y="20"/></graphics><initialMarking><text>2</text></initialMarking></place>
               <transition id="t"><graphics><position x="10" y="56"/></graphics></transition>
               <place id="b"><graphics><position x="10" y="92"/></graphics></place>
               <arc id="x" source="a" target="t"/><arc id="y" source="t" target="b"><inscription><text>3</text></inscription></arc>"#,
        ));
        let svg = draw(&d.net, &d.layout, "n0");
        assert!(svg.contains(r#"data-layout="pnml""#), "{svg}");
        // 36 apart, doubled to 72.
        assert_eq!(
            nodes(&svg, "data-place"),
            [
                ("a".to_string(), "20".to_string(), "40".to_string()),
                ("b".into(), "20".into(), "184".into())
            ]
        );
        assert_eq!(nodes(&svg, "data-transition")[0].2, "112");
        // Two dots in a, none in b; weight 3 written on its arc.
        assert_eq!(svg.matches(r#"class="token""#).count(), 2);
        assert!(svg.contains(r#"<text class="weight""#) && svg.contains(">3</text>"));
    }

    #[test]
    fn without_positions_the_layers_follow_the_flow_from_the_marking() {
        let d = doc(&pnml(
            r#"<place id="c"/><place id="a"><initialMarking><text>1</text></initialMarking></place>
               <transition id="t1"/><transition id="t2"/><place id="b"/>
               <arc id="x1" source="a" target="t1"/><arc id="x2" source="t1" target="b"/>
               <arc id="x3" source="b" target="t2"/><arc id="x4" source="t2" target="c"/>"#,
        ));
        let svg = draw(&d.net, &d.layout, "n0");
        assert!(svg.contains(r#"data-layout="layered""#), "{svg}");
        let y = |attr: &str, label: &str| -> f64 {
            nodes(&svg, attr)
                .into_iter()
                .find(|n| n.0 == label)
                .unwrap()
                .2
                .parse()
                .unwrap()
        };
        let order = [
            y("data-place", "a"),
            y("data-transition", "t1"),
            y("data-place", "b"),
            y("data-transition", "t2"),
            y("data-place", "c"),
        ];
        assert!(order.windows(2).all(|w| w[0] < w[1]), "{order:?}");
        assert_eq!(svg, draw(&d.net, &d.layout, "n0"));
    }

    #[test]
    fn special_arcs_are_drawn_distinctly_and_many_tokens_as_a_number() {
        let d = doc(&pnml(
            r#"<place id="a"><initialMarking><text>7</text></initialMarking></place><place id="b"/><transition id="t"/>
               <arc id="r" source="a" target="t" type="test"/><arc id="i" source="b" target="t" type="inhibitor"/>"#,
        ));
        let svg = draw(&d.net, &d.layout, "q");
        let doc = roxmltree::Document::parse(&svg).unwrap();
        let arc = |id: &str| {
            doc.descendants()
                .find(|e| e.attribute("data-id") == Some(id) && e.tag_name().name() == "path")
                .unwrap()
        };
        assert_eq!(arc("r").attribute("marker-end"), Some("url(#q-read)"));
        assert!(arc("r").attribute("stroke-dasharray").is_some());
        assert_eq!(arc("i").attribute("marker-end"), Some("url(#q-inhibitor)"));
        assert!(svg.contains(r#"class="token-count""#) && svg.contains(">7</text>"));
    }

    #[test]
    fn text_is_escaped() {
        assert_eq!(esc("a<b>&\"c'\u{1}"), "a&lt;b&gt;&amp;&quot;c&#39;\u{FFFD}");
    }
}
