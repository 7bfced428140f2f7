//! Calls that come back to a POU still running: refused where the code says so (E107), and
//! left to a run-time guard where only a call through an interface could close the circle.
//!
//! Every POU's frame is static (the engine lays out memory before it runs), so a POU must not
//! be entered again while it runs. A cycle of direct calls always re-enters: E107. A cycle
//! through an interface's dispatch (a node visiting the next node through `I_Node`, a
//! collection asking its inner collection for `_Count`) re-enters only if the instances at
//! run time make it: CODESYS and TwinCAT accept it, so petriplc does too, with W050, and each
//! POU of the cycle is guarded ([`crate::ir::Project::guarded`]): entering one still running
//! stops the scan with a fault at the call.

use std::collections::BTreeSet;

use petriplc_iec_syntax::diag;
use petriplc_iec_syntax::source::Span;

use crate::check::Checker;
use crate::ir::PouId;

impl Checker<'_> {
    /// E107 for cycles of direct calls; W050 and a guard for cycles through an interface.
    pub fn check_recursion(&mut self) {
        let n = self.pous.len();
        let mut graph: Vec<Vec<(PouId, Span)>> = vec![Vec::new(); n];
        for (from, to, span) in &self.calls {
            if let Some(f) = from {
                graph[*f as usize].push((*to, *span));
            }
        }
        for scc in strongly_connected(&graph) {
            let first = scc[0];
            let cyclic = scc.len() > 1 || graph[first as usize].iter().any(|(t, _)| *t == first);
            if !cyclic {
                continue;
            }
            let inside: BTreeSet<PouId> = scc.iter().copied().collect();
            // The call that closes the circle: the first (in source order) into the POU named.
            let dispatch = scc.iter().copied().find(|&p| self.is_dispatch(p));
            let target = dispatch.unwrap_or(first);
            let span = self
                .calls
                .iter()
                .find(|(f, t, _)| *t == target && f.is_some_and(|f| inside.contains(&f)))
                .map_or(self.pous[target as usize].span, |c| c.2);
            let name = self.pous[target as usize].name.clone();
            match dispatch {
                None => self.error(
                    diag::RECURSION,
                    span,
                    format!(
                        "this call makes {name} call itself again; IEC 61131-3 does not allow recursion"
                    ),
                ),
                Some(_) => {
                    let others: Vec<&str> = scc
                        .iter()
                        .filter(|&&p| p != target)
                        .map(|&p| self.pous[p as usize].name.as_str())
                        .collect();
                    let msg = format!(
                        "this call through {name} may come back to {} while it is running: petriplc's frames are static, so if the instances make it re-enter, the scan stops with the fault `recursion` (CODESYS and TwinCAT would recurse); make sure the chain of instances ends, or walk it in a loop",
                        others.join(", ")
                    );
                    self.diags.warning(diag::RECURSION_THROUGH_INTERFACE, span, msg);
                    self.guarded.extend(scc);
                }
            }
        }
    }

    /// Whether `p` is the checker's dispatch of an interface's method or accessor.
    fn is_dispatch(&self, p: PouId) -> bool {
        self.oop
            .members
            .get(&p)
            .is_some_and(|m| self.is_interface(m.owner))
    }
}

/// The strongly connected components of `graph` (Tarjan's algorithm, iterative so that a
/// deep call chain cannot overflow the stack), each sorted, in an order fixed by the graph.
fn strongly_connected(graph: &[Vec<(PouId, Span)>]) -> Vec<Vec<PouId>> {
    let n = graph.len();
    const NONE: usize = usize::MAX;
    let mut index = vec![NONE; n];
    let mut low = vec![0usize; n];
    let mut on_stack = vec![false; n];
    let mut stack: Vec<usize> = Vec::new();
    let mut out = Vec::new();
    let mut next = 0usize;
    for start in 0..n {
        if index[start] != NONE {
            continue;
        }
        let mut work: Vec<(usize, usize)> = vec![(start, 0)];
        index[start] = next;
        low[start] = next;
        next += 1;
        stack.push(start);
        on_stack[start] = true;
        while let Some(&(v, i)) = work.last() {
            if let Some(&(w, _)) = graph[v].get(i) {
                if let Some(top) = work.last_mut() {
                    top.1 += 1;
                }
                let w = w as usize;
                if index[w] == NONE {
                    index[w] = next;
                    low[w] = next;
                    next += 1;
                    stack.push(w);
                    on_stack[w] = true;
                    work.push((w, 0));
                } else if on_stack[w] {
                    low[v] = low[v].min(index[w]);
                }
                continue;
            }
            work.pop();
            if let Some(&(u, _)) = work.last() {
                low[u] = low[u].min(low[v]);
            }
            if low[v] == index[v] {
                let mut scc = Vec::new();
                while let Some(w) = stack.pop() {
                    on_stack[w] = false;
                    scc.push(w as PouId);
                    if w == v {
                        break;
                    }
                }
                scc.sort_unstable();
                out.push(scc);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(edges: &[(u32, u32)], n: usize, expect: &[&[u32]]) {
        let span = Span::default();
        let mut g = vec![Vec::new(); n];
        for &(a, b) in edges {
            g[a as usize].push((b, span));
        }
        let mut got: Vec<Vec<u32>> = strongly_connected(&g)
            .into_iter()
            .filter(|c| c.len() > 1 || edges.contains(&(c[0], c[0])))
            .collect();
        got.sort();
        assert_eq!(got, expect);
    }

    #[test]
    fn components_are_the_cycles() {
        check(&[(0, 1), (1, 2)], 3, &[]);
        check(&[(0, 1), (1, 0), (1, 2)], 3, &[&[0, 1]]);
        check(&[(2, 2), (0, 1)], 3, &[&[2]]);
        check(
            &[(0, 1), (1, 2), (2, 0), (3, 4), (4, 3), (2, 3)],
            5,
            &[&[0, 1, 2], &[3, 4]],
        );
    }
}
