//! The data flow of a system: the Gauss–Seidel order of its elements and its algebraic loops.
//!
//! **Order.** Elements are nodes, connections are edges producer → consumer. The order is the
//! reverse post-order of a depth-first search that starts from the sources (elements no
//! connection feeds), then from any element not reached (one on a cycle without a source);
//! roots are taken from the last to the first in document order, so that elements with no
//! connection between them keep their document order. In this order every connection runs forward, except the edges that
//! close a cycle (DFS back edges): those are cut, and their consumer steps with the
//! producer's value from the start of the step (a delayed value), as in Jacobi.
//!
//! **Algebraic loops.** Ports are nodes; a connection is an edge output → input, and inside
//! an element an input → output edge where the output depends on the input *directly*
//! (modelDescription `ModelStructure/Outputs/Unknown dependencies`; FMI 2.0.5 §2.2.8: an
//! absent `dependencies` attribute means "depends on all inputs", an empty one "on none").
//! A cycle in this graph is a loop in which every output on it reacts to the input on it
//! within the step: no fixed-step master without iteration can solve it, so the system is
//! refused with the cycle printed. A cycle that passes through an element without direct
//! feedthrough is an ordinary delayed coupling.

use super::check::Link;
use crate::host::description::ModelDescription;

/// The Gauss–Seidel order of `n` elements and, per link, whether it is cut (its consumer
/// steps before its producer).
pub fn order(n: usize, links: &[Link]) -> (Vec<usize>, Vec<bool>) {
    let mut succ: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut has_input = vec![false; n];
    for l in links {
        if !succ[l.from.element].contains(&l.to.element) {
            succ[l.from.element].push(l.to.element);
        }
        has_input[l.to.element] = true;
    }
    // 0 unvisited, 1 on the stack, 2 done.
    let mut state = vec![0u8; n];
    let mut post = Vec::with_capacity(n);
    // Roots from the last to the first: the reversed post-order then keeps unconnected
    // elements (and independent chains) in document order.
    let roots = (0..n)
        .rev()
        .filter(|&e| !has_input[e])
        .chain((0..n).rev())
        .collect::<Vec<_>>();
    for r in roots {
        if state[r] != 0 {
            continue;
        }
        // Iterative DFS: (node, next successor to look at).
        let mut stack = vec![(r, 0usize)];
        state[r] = 1;
        while let Some(&mut (v, ref mut k)) = stack.last_mut() {
            if let Some(&w) = succ[v].get(*k) {
                *k += 1;
                if state[w] == 0 {
                    state[w] = 1;
                    stack.push((w, 0));
                }
            } else {
                state[v] = 2;
                post.push(v);
                stack.pop();
            }
        }
    }
    post.reverse();
    let mut pos = vec![0; n];
    for (i, &e) in post.iter().enumerate() {
        pos[e] = i;
    }
    let cut = links
        .iter()
        .map(|l| pos[l.from.element] >= pos[l.to.element])
        .collect();
    (post, cut)
}

/// Does output variable `out` (1-based index) of `md` depend directly on input `inp`?
pub fn feeds_through(md: &ModelDescription, inp: usize, out: usize) -> bool {
    match md.model_structure.outputs.iter().find(|u| u.index == out) {
        Some(u) => match &u.dependencies {
            None => true,
            Some(deps) => deps.contains(&inp),
        },
        // Not listed (a broken ModelStructure): assume the worst.
        None => true,
    }
}

/// The first algebraic loop, as the names of its ports (`A.y → B.u → B.y → A.u → A.y`), or
/// `None`. `md_of(element)` gives the element's model description.
pub fn algebraic_loop<'a>(
    links: &[Link],
    md_of: impl Fn(usize) -> &'a ModelDescription,
) -> Option<String> {
    // Nodes: link index l stands for the edge from.port → to.port; the graph on links has an
    // edge l → m when m starts at an output of l's consumer that depends on l's input.
    let n = links.len();
    let succ: Vec<Vec<usize>> = links
        .iter()
        .map(|l| {
            (0..n)
                .filter(|&m| {
                    links[m].from.element == l.to.element
                        && feeds_through(md_of(l.to.element), l.to.index, links[m].from.index)
                })
                .collect()
        })
        .collect();
    let mut state = vec![0u8; n];
    for r in 0..n {
        if state[r] != 0 {
            continue;
        }
        let mut stack = vec![(r, 0usize)];
        state[r] = 1;
        while let Some(&mut (v, ref mut k)) = stack.last_mut() {
            if let Some(&w) = succ[v].get(*k) {
                *k += 1;
                if state[w] == 1 {
                    // The cycle: from w on the stack to v, closed by w.
                    let at = stack.iter().position(|&(x, _)| x == w).unwrap_or(0);
                    let mut names: Vec<String> = Vec::new();
                    for &(x, _) in &stack[at..] {
                        names.push(links[x].from.name.clone());
                        names.push(links[x].to.name.clone());
                    }
                    names.push(links[w].from.name.clone());
                    return Some(names.join(" → "));
                }
                if state[w] == 0 {
                    state[w] = 1;
                    stack.push((w, 0));
                }
            } else {
                state[v] = 2;
                stack.pop();
            }
        }
    }
    None
}

/// Per link: the producer ports (as `port_of` indexes them) of the link's consumer whose
/// output depends directly on the link's input (ModelStructure, [`feeds_through`]): where an
/// input's error reaches within the same step.
pub fn feedthrough<'m>(
    links: &[Link],
    port_of: &[usize],
    md_of: impl Fn(usize) -> &'m ModelDescription,
) -> Vec<Vec<usize>> {
    links
        .iter()
        .map(|l| {
            let mut ports: Vec<usize> = links
                .iter()
                .zip(port_of)
                .filter(|(m, _)| {
                    m.from.element == l.to.element
                        && feeds_through(md_of(l.to.element), l.to.index, m.from.index)
                })
                .map(|(_, &p)| p)
                .collect();
            ports.sort_unstable();
            ports.dedup();
            ports
        })
        .collect()
}

/// The error-controlled master's order (`controlled`): the elements whose connected outputs
/// depend directly on a connected input (compliances: shafts, a stage's speed ports, whose
/// efforts follow the flows they are given within the step) step first, each group in
/// `order`'s sequence; the per-link cut for that order. Their efforts reach the bodies
/// interpolated (the chord, `H|Δy'|/8`, instead of the tangent's `H²|y''|/2`), and the
/// flows they take extrapolated are checked through their effect on those efforts.
pub fn compliances_first(
    order: &[usize],
    links: &[Link],
    feedthrough: &[Vec<usize>],
) -> (Vec<usize>, Vec<bool>) {
    let compliant = |e: usize| {
        links
            .iter()
            .zip(feedthrough)
            .any(|(l, f)| l.to.element == e && !f.is_empty())
    };
    let mut first: Vec<usize> = order.iter().copied().filter(|&e| compliant(e)).collect();
    first.extend(order.iter().copied().filter(|&e| !compliant(e)));
    let mut pos = vec![0; first.len()];
    for (i, &e) in first.iter().enumerate() {
        pos[e] = i;
    }
    let cut = links
        .iter()
        .map(|l| pos[l.from.element] >= pos[l.to.element])
        .collect();
    (first, cut)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::host::description::VarType;
    use crate::host::system::check::Port;

    fn link(a: usize, b: usize) -> Link {
        let p = |e: usize, i: usize| Port {
            element: e,
            vr: 0,
            var_type: VarType::Real,
            index: i,
            name: format!("E{e}.v{i}"),
        };
        Link {
            from: p(a, 2),
            to: p(b, 1),
            scale: 1.0,
            offset: 0.0,
            identity: true,
            label: String::new(),
        }
    }

    #[test]
    fn order_follows_the_flow_and_cuts_cycles_at_the_closing_edge() {
        // 2 → 0 → 1, and 1 → 0 closes a cycle: source 2 first, then 0, then 1.
        let links = [link(2, 0), link(0, 1), link(1, 0)];
        let (o, cut) = order(3, &links);
        assert_eq!(o, [2, 0, 1]);
        assert_eq!(cut, [false, false, true]);
        // A pure cycle without a source: the search starts at its last element.
        let (o, cut) = order(2, &[link(1, 0), link(0, 1)]);
        assert_eq!(o, [1, 0]);
        assert_eq!(cut, [false, true]);
        // Two sources feeding one consumer: both before it, in document order.
        let (o, cut) = order(3, &[link(0, 2), link(1, 2)]);
        assert_eq!(o, [0, 1, 2]);
        assert_eq!(cut, [false, false]);
        // The drivetrain of docs/systems.md: motor 0, shaft1 1, gear 2, shaft2 3, load 4, every
        // body ↔ shaft pair coupled both ways; the search starts at the load.
        let chain = [
            link(0, 1),
            link(1, 0),
            link(2, 1),
            link(1, 2),
            link(2, 3),
            link(3, 2),
            link(4, 3),
            link(3, 4),
        ];
        let (o, cut) = order(5, &chain);
        assert_eq!(o, [4, 3, 2, 1, 0]);
        assert_eq!(cut, [true, false, false, true, true, false, false, true]);
        // Unconnected elements keep their document order.
        assert_eq!(order(3, &[]).0, [0, 1, 2]);
    }
}
