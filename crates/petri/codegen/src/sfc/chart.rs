//! The SFC's drawing: rows and columns of steps, transitions, divergences and jumps laid
//! out from the graph, and each element written as PLCopen XML with its position and
//! connections.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::Graph;
use crate::lower::Program;
use crate::text::xml;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Pt(i64, i64);

const X0: i64 = 20;
const Y0: i64 = 20;
const ROW: i64 = 150;
const STEP_H: i64 = 30;
const STEP_Y: i64 = 20;
const TRANS_Y: i64 = 34;
const JUMP_Y: i64 = 66;
const DIV_Y: i64 = 100;
const ACTION_GAP: i64 = 30;

fn step_width(name: &str) -> i64 {
    (10 * name.chars().count() as i64 + 20).max(80) / 2 * 2
}

fn action_width(name: &str) -> i64 {
    (10 * name.chars().count() as i64 + 20).max(80) / 2 * 2
}

/// A step's action block: its local id, and each action's id with the output it drives.
type Actions = (usize, Vec<(usize, String)>);

/// Geometry and local ids of every element.
pub(super) struct Chart {
    /// Nodes in drawing order: by row, then by discovery.
    order: Vec<usize>,
    col: Vec<i64>,
    left: i64,
    colw: i64,
    right: i64,
    node_id: Vec<usize>,
    conv_id: Vec<usize>,
    div_id: Vec<usize>,
    jump_id: Vec<usize>,
    /// Per step: the action block's id and its actions' ids with the output they drive.
    actions: Vec<Option<Actions>>,
}

impl Chart {
    pub(super) fn new(g: &Graph, p: &Program) -> Chart {
        let n = g.np + g.nt;
        let mut order: Vec<usize> = (0..n).filter(|&m| g.preorder[m] != usize::MAX).collect();
        order.sort_by_key(|&m| (g.rank[m], g.preorder[m]));

        // Columns: a node continues the column of the link it is the first branch of;
        // other branches open columns to the right. A long link keeps its column clear.
        let mut col = vec![0i64; n];
        let mut used: BTreeSet<(usize, i64)> = BTreeSet::new();
        used.insert((0, 0));
        for &m in order.iter().filter(|&&m| m != g.init) {
            let fp = g.forward_preds(m);
            let first_of = fp
                .iter()
                .filter(|&&q| {
                    g.succ[q]
                        .iter()
                        .find(|&&s| !g.back.contains(&(q, s)))
                        .is_some_and(|&s| s == m)
                })
                .map(|&q| col[q])
                .min();
            let start =
                first_of.unwrap_or_else(|| fp.iter().map(|&q| col[q]).min().unwrap_or(0) + 1);
            // A branch of a divergence runs down in the node's own column from the
            // divergence's row, so that stretch must be free too.
            let free = |c: i64| {
                !used.contains(&(g.rank[m], c))
                    && fp
                        .iter()
                        .filter(|&&q| g.has_div(q))
                        .all(|&q| (g.rank[q] + 1..g.rank[m]).all(|r| !used.contains(&(r, c))))
            };
            let mut c = start;
            while !free(c) {
                c += 1;
            }
            col[m] = c;
            used.insert((g.rank[m], c));
            for &q in fp.iter().filter(|&&q| g.has_div(q)) {
                for r in g.rank[q] + 1..g.rank[m] {
                    used.insert((r, c));
                }
            }
            // A single link down runs in this node's column to the row of its target.
            if !g.has_div(m) {
                for &s in &g.succ[m] {
                    if !g.back.contains(&(m, s)) {
                        for r in g.rank[m] + 1..g.rank[s] {
                            used.insert((r, c));
                        }
                    }
                }
            }
        }
        let ncols = order.iter().map(|&m| col[m]).max().unwrap_or(0) + 1;

        let mut half = 40;
        let mut reach = 40;
        for i in 0..g.np {
            let w = step_width(&p.places[i].ident);
            half = half.max(w / 2);
            let aw = p
                .outputs
                .iter()
                .filter(|o| o.places.contains(&i))
                .map(|o| action_width(&o.ident))
                .max()
                .map_or(0, |aw| aw + ACTION_GAP);
            reach = reach.max(w / 2 + aw);
        }
        let left = X0 + half + 20;
        let colw = half + reach + 60;
        let right = left + (ncols - 1) * colw + reach + 30;

        let mut next = 0;
        let mut id = || {
            next += 1;
            next
        };
        let mut node_id = vec![0; n];
        let mut conv_id = vec![0; n];
        let mut div_id = vec![0; n];
        let mut jump_id = vec![0; n];
        let mut actions = vec![None; g.np];
        for &m in &order {
            if g.has_conv(m) {
                conv_id[m] = id();
            }
            node_id[m] = id();
            if g.is_step(m) {
                let outs: Vec<String> = p
                    .outputs
                    .iter()
                    .filter(|o| o.places.contains(&m))
                    .map(|o| o.ident.clone())
                    .collect();
                if !outs.is_empty() {
                    let block = id();
                    actions[m] = Some((block, outs.into_iter().map(|o| (id(), o)).collect()));
                }
            }
            if g.has_div(m) {
                div_id[m] = id();
            }
            if g.jump(m).is_some() {
                jump_id[m] = id();
            }
        }
        Chart {
            order,
            col,
            left,
            colw,
            right,
            node_id,
            conv_id,
            div_id,
            jump_id,
            actions,
        }
    }

    fn x(&self, node: usize) -> i64 {
        self.left + self.col[node] * self.colw
    }

    fn base(&self, g: &Graph, node: usize) -> i64 {
        Y0 + g.rank[node] as i64 * ROW
    }

    fn in_pt(&self, g: &Graph, node: usize) -> Pt {
        let y = if g.is_step(node) { STEP_Y } else { TRANS_Y };
        Pt(self.x(node), self.base(g, node) + y)
    }

    fn out_pt(&self, g: &Graph, node: usize) -> Pt {
        let y = if g.is_step(node) {
            STEP_Y + STEP_H
        } else {
            TRANS_Y + 2
        };
        Pt(self.x(node), self.base(g, node) + y)
    }

    /// Height of the divergence after, and the convergence before, a node: a single line
    /// for a selection (around a step), a double one for parallel branches (around a
    /// transition).
    fn line_h(g: &Graph, node: usize) -> i64 {
        if g.is_step(node) {
            1
        } else {
            3
        }
    }

    /// Where input `k` of the convergence before `node` is.
    fn conv_in_x(&self, g: &Graph, node: usize, k: usize) -> i64 {
        let q = g.preds(node)[k];
        if g.has_div(q) {
            // Two divergence branches may meet here; keep them apart.
            self.x(node) + 12 + 16 * k as i64
        } else {
            self.out_pt(g, q).0
        }
    }

    /// Where branch `j` of the divergence after `node` is.
    fn branch_x(&self, g: &Graph, node: usize, j: usize) -> i64 {
        let m = g.succ[node][j];
        if g.has_conv(m) {
            let k = g.preds(m).iter().position(|&q| q == node).expect("linked");
            self.conv_in_x(g, m, k)
        } else {
            self.x(m)
        }
    }

    fn div_y(&self, g: &Graph, node: usize) -> i64 {
        self.base(g, node) + DIV_Y
    }

    /// The producing end of the link `from → to`: element id, formal parameter, point.
    fn source(&self, g: &Graph, from: usize, to: usize) -> (usize, Option<String>, Pt) {
        if g.has_div(from) {
            let j = g.succ[from].iter().position(|&s| s == to).expect("linked");
            (
                self.div_id[from],
                Some(j.to_string()),
                Pt(
                    self.branch_x(g, from, j),
                    self.div_y(g, from) + Self::line_h(g, from),
                ),
            )
        } else {
            (self.node_id[from], None, self.out_pt(g, from))
        }
    }

    /// The points of a link from `out` to `inp`, consumer first, as PLCopen lists them.
    fn route(&self, inp: Pt, out: Pt) -> Vec<Pt> {
        if inp.0 == out.0 || inp.1 == out.1 {
            vec![inp, out]
        } else if out.1 < inp.1 {
            let mid = inp.1 - 8.min((inp.1 - out.1) / 2);
            vec![inp, Pt(inp.0, mid), Pt(out.0, mid), out]
        } else {
            // A link up to a transition drawn above its step goes round on the right.
            vec![
                inp,
                Pt(inp.0, inp.1 - 8),
                Pt(self.right, inp.1 - 8),
                Pt(self.right, out.1 + 8),
                Pt(out.0, out.1 + 8),
                out,
            ]
        }
    }

    pub(super) fn render(&self, g: &Graph, p: &Program, conditions: &[String]) -> String {
        let mut w = String::new();
        for &m in &self.order {
            let preds = g.preds(m);
            if g.has_conv(m) {
                let tag = if g.is_step(m) {
                    "selectionConvergence"
                } else {
                    "simultaneousConvergence"
                };
                let h = Self::line_h(g, m);
                let y = self.base(g, m);
                let xs: Vec<i64> = (0..preds.len()).map(|k| self.conv_in_x(g, m, k)).collect();
                let lo = xs.iter().copied().chain([self.x(m)]).min().unwrap_or(0);
                let hi = xs.iter().copied().chain([self.x(m)]).max().unwrap_or(0);
                open(
                    &mut w,
                    tag,
                    self.conv_id[m],
                    &[("height", h), ("width", hi - lo)],
                    "",
                );
                position(&mut w, "position", Pt(lo, y), 14);
                for (k, &q) in preds.iter().enumerate() {
                    let inp = Pt(xs[k], y);
                    self.connection_in(&mut w, g, q, m, inp, Pt(xs[k] - lo, 0));
                }
                point_out(&mut w, "connectionPointOut", None, Pt(self.x(m) - lo, h));
                let _ = writeln!(w, "            </{tag}>");
            }
            if g.is_step(m) {
                self.step(&mut w, g, p, m, &preds);
            } else {
                self.transition(&mut w, g, m, &preds, &conditions[m - g.np]);
            }
            if g.has_div(m) {
                let tag = if g.is_step(m) {
                    "selectionDivergence"
                } else {
                    "simultaneousDivergence"
                };
                let h = Self::line_h(g, m);
                let y = self.div_y(g, m);
                let xs: Vec<i64> = (0..g.succ[m].len())
                    .map(|j| self.branch_x(g, m, j))
                    .collect();
                let lo = xs.iter().copied().chain([self.x(m)]).min().unwrap_or(0);
                let hi = xs.iter().copied().chain([self.x(m)]).max().unwrap_or(0);
                open(
                    &mut w,
                    tag,
                    self.div_id[m],
                    &[("height", h), ("width", hi - lo)],
                    "",
                );
                position(&mut w, "position", Pt(lo, y), 14);
                let inp = Pt(self.x(m), y);
                let out = self.out_pt(g, m);
                write_in(
                    &mut w,
                    Pt(inp.0 - lo, 0),
                    self.node_id[m],
                    None,
                    &self.route(inp, out),
                );
                for (j, &x) in xs.iter().enumerate() {
                    point_out(
                        &mut w,
                        "connectionPointOut",
                        Some(&j.to_string()),
                        Pt(x - lo, h),
                    );
                }
                let _ = writeln!(w, "            </{tag}>");
            }
            if let Some(target) = g.jump(m) {
                let x = self.x(m);
                let y = self.base(g, m) + JUMP_Y;
                let name = xml(&p.places[target].ident);
                open(
                    &mut w,
                    "jumpStep",
                    self.jump_id[m],
                    &[("height", 13), ("width", 12)],
                    &format!(" targetName=\"{name}\""),
                );
                position(&mut w, "position", Pt(x - 6, y), 14);
                let out = self.out_pt(g, m);
                write_in(
                    &mut w,
                    Pt(6, 0),
                    self.node_id[m],
                    None,
                    &self.route(Pt(x, y), out),
                );
                let _ = writeln!(w, "            </jumpStep>");
            }
        }
        w
    }

    /// The `connectionPointIn` of a consumer at `inp` (relative `rel`) for the link
    /// `from → to`.
    fn connection_in(&self, w: &mut String, g: &Graph, from: usize, to: usize, inp: Pt, rel: Pt) {
        let (id, formal, out) = self.source(g, from, to);
        write_in(w, rel, id, formal.as_deref(), &self.route(inp, out));
    }

    fn step(&self, w: &mut String, g: &Graph, p: &Program, m: usize, preds: &[usize]) {
        let name = &p.places[m].ident;
        let sw = step_width(name);
        let inp = self.in_pt(g, m);
        let pos = Pt(inp.0 - sw / 2, inp.1);
        let initial = if m == g.init {
            " initialStep=\"true\""
        } else {
            ""
        };
        open(
            w,
            "step",
            self.node_id[m],
            &[("height", STEP_H), ("width", sw)],
            &format!(" name=\"{}\"{initial}", xml(name)),
        );
        position(w, "position", pos, 14);
        match preds {
            [] => {}
            [q] => self.connection_in(w, g, *q, m, inp, Pt(sw / 2, 0)),
            _ => write_in(
                w,
                Pt(sw / 2, 0),
                self.conv_id[m],
                None,
                &self.route(inp, Pt(self.x(m), self.base(g, m) + Self::line_h(g, m))),
            ),
        }
        if !g.succ[m].is_empty() {
            point_out(w, "connectionPointOut", Some(""), Pt(sw / 2, STEP_H));
        }
        if self.actions[m].is_some() {
            point_out(w, "connectionPointOutAction", Some(""), Pt(sw, STEP_H / 2));
        }
        let _ = writeln!(w, "            </step>");
        if let Some((block, acts)) = &self.actions[m] {
            let aw = acts
                .iter()
                .map(|(_, o)| action_width(o))
                .max()
                .unwrap_or(80);
            let h = 30 * acts.len() as i64;
            let at = Pt(pos.0 + sw + ACTION_GAP, pos.1);
            open(
                w,
                "actionBlock",
                *block,
                &[("height", h), ("width", aw)],
                "",
            );
            position(w, "position", at, 14);
            let from = Pt(pos.0 + sw, pos.1 + STEP_H / 2);
            let to = Pt(at.0, at.1 + STEP_H / 2);
            write_in(
                w,
                Pt(0, STEP_H / 2),
                self.node_id[m],
                None,
                &self.route(to, from),
            );
            for (i, (id, output)) in acts.iter().enumerate() {
                let _ = writeln!(w, "              <action localId=\"{id}\" qualifier=\"N\">");
                position(w, "relPosition", Pt(0, 30 * i as i64), 16);
                let _ = writeln!(w, "                <reference name=\"{}\"/>", xml(output));
                let _ = writeln!(w, "              </action>");
            }
            let _ = writeln!(w, "            </actionBlock>");
        }
    }

    fn transition(&self, w: &mut String, g: &Graph, m: usize, preds: &[usize], cond: &str) {
        let inp = self.in_pt(g, m);
        // IEC resolves a selection divergence left to right; the attribute says the same for
        // tools that read it: declaration order, 1 first.
        let priority = match preds {
            [q] if g.has_div(*q) => {
                let j = g.succ[*q].iter().position(|&s| s == m).expect("linked");
                format!(" priority=\"{}\"", j + 1)
            }
            _ => String::new(),
        };
        open(
            w,
            "transition",
            self.node_id[m],
            &[("height", 2), ("width", 20)],
            &priority,
        );
        position(w, "position", Pt(inp.0 - 10, inp.1), 14);
        match preds {
            [q] => self.connection_in(w, g, *q, m, inp, Pt(10, 0)),
            _ => write_in(
                w,
                Pt(10, 0),
                self.conv_id[m],
                None,
                &self.route(inp, Pt(self.x(m), self.base(g, m) + Self::line_h(g, m))),
            ),
        }
        point_out(w, "connectionPointOut", None, Pt(10, 2));
        let _ = writeln!(w, "              <condition>");
        let _ = writeln!(w, "                <inline name=\"\">");
        let _ = writeln!(
            w,
            "                  <ST>\n                    <xhtml:p><![CDATA[{}]]></xhtml:p>\n                  </ST>",
            cond.replace("]]>", "]]]]><![CDATA[>")
        );
        let _ = writeln!(w, "                </inline>");
        let _ = writeln!(w, "              </condition>");
        let _ = writeln!(w, "            </transition>");
    }
}

fn open(w: &mut String, tag: &str, id: usize, size: &[(&str, i64)], extra: &str) {
    let _ = write!(w, "            <{tag} localId=\"{id}\"");
    for (k, v) in size {
        let _ = write!(w, " {k}=\"{v}\"");
    }
    let _ = writeln!(w, "{extra}>");
}

fn position(w: &mut String, tag: &str, p: Pt, indent: usize) {
    let _ = writeln!(
        w,
        "{:indent$}<{tag} x=\"{}\" y=\"{}\"/>",
        "",
        p.0,
        p.1,
        indent = indent
    );
}

fn point_out(w: &mut String, tag: &str, formal: Option<&str>, rel: Pt) {
    match formal {
        Some(f) => {
            let _ = writeln!(w, "              <{tag} formalParameter=\"{}\">", xml(f));
        }
        None => {
            let _ = writeln!(w, "              <{tag}>");
        }
    }
    position(w, "relPosition", rel, 16);
    let _ = writeln!(w, "              </{tag}>");
}

fn write_in(w: &mut String, rel: Pt, from: usize, formal: Option<&str>, points: &[Pt]) {
    let _ = writeln!(w, "              <connectionPointIn>");
    position(w, "relPosition", rel, 16);
    match formal {
        Some(f) => {
            let _ = writeln!(
                w,
                "                <connection refLocalId=\"{from}\" formalParameter=\"{}\">",
                xml(f)
            );
        }
        None => {
            let _ = writeln!(w, "                <connection refLocalId=\"{from}\">");
        }
    }
    for &pt in points {
        position(w, "position", pt, 18);
    }
    let _ = writeln!(w, "                </connection>");
    let _ = writeln!(w, "              </connectionPointIn>");
}
