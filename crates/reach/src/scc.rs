//! Strongly connected components of the reachability graph (Tarjan's algorithm, iterative: the
//! graphs have millions of states), summarised for liveness, reversibility and home markings.
//!
//! A component is bottom (terminal) when no edge leaves it. In Tarjan's algorithm an edge
//! `v → w` leaves `v`'s component exactly when `w` already belongs to a finished component
//! (an edge to a node still on the stack stays inside), so one pass over the edges finds both
//! the components and which of them are bottom.

use crate::space::StateSpace;

pub(crate) struct SccSummary {
    /// Number of components.
    pub sccs: u64,
    /// Number of bottom components.
    pub bottoms: u64,
    /// Every bottom component contains an edge of every transition (L4 liveness: from any
    /// state, every transition can fire again).
    pub live: bool,
}

const NONE: u32 = u32::MAX;

pub(crate) fn analyse(space: &StateSpace) -> SccSummary {
    let n = space.states() as usize;
    let mut index = vec![NONE; n];
    let mut low = vec![0u32; n];
    let mut comp = vec![NONE; n];
    let mut exits = vec![false; n];
    let mut stack: Vec<u32> = Vec::new();
    let mut call: Vec<(u32, u32)> = Vec::new();
    let mut counter = 0u32;
    let mut sum = SccSummary {
        sccs: 0,
        bottoms: 0,
        live: true,
    };
    let transitions = space.rules.transitions();
    let mut seen = vec![false; transitions];
    for root in 0..n {
        if index[root] != NONE {
            continue;
        }
        index[root] = counter;
        low[root] = counter;
        counter += 1;
        stack.push(root as u32);
        call.push((root as u32, 0));
        while let Some(&mut (v, ref mut e)) = call.last_mut() {
            let vs = v as usize;
            let out = space.targets(vs);
            if (*e as usize) < out.len() {
                let w = out[*e as usize] as usize;
                *e += 1;
                if index[w] == NONE {
                    index[w] = counter;
                    low[w] = counter;
                    counter += 1;
                    stack.push(w as u32);
                    call.push((w as u32, 0));
                } else if comp[w] == NONE {
                    low[vs] = low[vs].min(index[w]);
                } else {
                    exits[vs] = true;
                }
                continue;
            }
            call.pop();
            if let Some(&(u, _)) = call.last() {
                let u = u as usize;
                low[u] = low[u].min(low[vs]);
            }
            if low[vs] != index[vs] {
                continue;
            }
            // v is a root: its component is the stack above it.
            let start = stack.iter().rposition(|&x| x == v).expect("root on stack");
            let c = sum.sccs as u32;
            sum.sccs += 1;
            let members = &stack[start..];
            let mut bottom = true;
            for &x in members {
                comp[x as usize] = c;
                bottom &= !exits[x as usize];
            }
            if bottom {
                sum.bottoms += 1;
                if sum.live {
                    sum.live = covers_all(space, members, &mut seen);
                }
            }
            stack.truncate(start);
            if let Some(&(u, _)) = call.last() {
                // The edge parent → v leaves the parent's component.
                exits[u as usize] = true;
            }
        }
    }
    sum
}

/// Whether the states `members` of a bottom component together enable every transition. In a
/// bottom component every enabled transition's edge stays inside, so enabledness is enough.
fn covers_all(space: &StateSpace, members: &[u32], seen: &mut [bool]) -> bool {
    seen.fill(false);
    let mut missing = seen.len();
    let mut m = space.layout.base.clone();
    for &x in members {
        space.decode(space.key(u64::from(x)), &mut m);
        for (t, s) in seen.iter_mut().enumerate() {
            if !*s && space.rules.enabled(t, &m) {
                *s = true;
                missing -= 1;
            }
        }
        if missing == 0 {
            return true;
        }
    }
    missing == 0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testnet::parse;
    use crate::{explore, ExploreOptions};

    /// Explores a net with its graph and renders the component summary.
    fn check(net_text: &str, expect: &str) {
        let net = parse(net_text);
        let opts = ExploreOptions {
            keep_graph: true,
            ..Default::default()
        };
        let s = analyse(&explore(&net, &opts).unwrap());
        assert_eq!(
            format!("sccs {} bottoms {} live {}", s.sccs, s.bottoms, s.live),
            expect
        );
    }

    #[test]
    fn one_cycle() {
        check(
            "a=1 b c ; t: a -> b ; u: b -> c ; v: c -> a",
            "sccs 1 bottoms 1 live true",
        );
    }

    #[test]
    fn chain_of_components_into_two_bottoms() {
        // {a,b} cycle exits to c (deadlock) or to the {d,e} cycle.
        check(
            "a=1 b c d e ; t: a -> b ; u: b -> a ; v: b -> c ; w: a -> d ; x: d -> e ; y: e -> d",
            "sccs 3 bottoms 2 live false",
        );
    }

    #[test]
    fn deep_chain_needs_no_recursion() {
        // 200 000 states in a line: a recursive algorithm would overflow the stack.
        let net = "a=200000 b ; t: a -> b";
        check(net, "sccs 200001 bottoms 1 live false");
    }
}
