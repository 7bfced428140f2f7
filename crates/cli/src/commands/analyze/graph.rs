//! Drawing the reachability graph: DOT text, and SVG through Graphviz's `dot`.

use std::io::Write as _;
use std::process::{Command, Stdio};

use anyhow::{bail, Context};
use petriplc_net::{Marking, Net, TransitionId};

/// The graph as the explorer hands it over: states numbered from 0, state 0 initial.
pub struct GraphView<'a> {
    pub states: u64,
    pub marking: &'a dyn Fn(u64) -> Marking,
    pub successors: &'a dyn Fn(u64) -> Vec<(TransitionId, u64)>,
}

/// Escapes a string for a double-quoted DOT label.
fn quote(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

/// A state's label: its marked places, `p` for one token, `p:3` for more, `∅` for none.
fn state_label(net: &Net, m: &Marking) -> String {
    let parts: Vec<String> = net
        .place_ids()
        .filter(|&p| m[p] > 0)
        .map(|p| {
            let name = net.place_label(p);
            if m[p] == 1 {
                name.to_string()
            } else {
                format!("{name}:{}", m[p])
            }
        })
        .collect();
    if parts.is_empty() {
        "∅".to_string()
    } else {
        parts.join(" ")
    }
}

/// DOT text for the whole graph: the initial state doubled, deadlocks filled.
pub fn to_dot(net: &Net, g: &GraphView<'_>) -> String {
    let mut out = String::new();
    out.push_str(&format!("digraph \"{}\" {{\n", quote(&net.id)));
    out.push_str("  rankdir=LR;\n  node [shape=box, style=rounded, fontname=\"Helvetica\"];\n");
    out.push_str("  edge [fontname=\"Helvetica\", fontsize=10];\n");
    for s in 0..g.states {
        let succ = (g.successors)(s);
        let mut attrs = format!("label=\"{}\"", quote(&state_label(net, &(g.marking)(s))));
        if s == 0 {
            attrs.push_str(", peripheries=2");
        }
        if succ.is_empty() {
            attrs.push_str(", style=\"rounded,filled\", fillcolor=\"#f4cccc\"");
        }
        out.push_str(&format!("  s{s} [{attrs}];\n"));
    }
    for s in 0..g.states {
        for (t, d) in (g.successors)(s) {
            out.push_str(&format!(
                "  s{s} -> s{d} [label=\"{}\"];\n",
                quote(net.transition_label(t))
            ));
        }
    }
    out.push_str("}\n");
    out
}

/// Lays the DOT text out as SVG with Graphviz.
pub fn to_svg(dot: &str) -> anyhow::Result<String> {
    let mut child = match Command::new("dot")
        .arg("-Tsvg")
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
    {
        Ok(c) => c,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("--svg needs Graphviz's `dot` (Debian: apt-get install graphviz); --dot writes the graph without it")
        }
        Err(e) => return Err(e).context("cannot run Graphviz's `dot`"),
    };
    child
        .stdin
        .take()
        .context("no pipe to `dot`")?
        .write_all(dot.as_bytes())
        .context("cannot send the graph to `dot`")?;
    let out = child.wait_with_output().context("`dot` did not finish")?;
    if !out.status.success() {
        bail!(
            "`dot` failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    String::from_utf8(out.stdout).context("`dot` wrote something that is not UTF-8")
}
