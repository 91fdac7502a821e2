//! Nested-dissection ordering of a sparse symmetric matrix's graph, for the
//! sparse Cholesky factor (`crate::direct`).
//!
//! Nested dissection (George 1973) numbers a vertex separator after the two
//! parts it separates, recursively, so that no fill joins the parts: on a
//! planar graph with `O(sqrt n)` separators the factor has `O(n log n)`
//! entries and costs `O(n^1.5)` flops (Lipton, Rose and Tarjan 1979), against
//! the larger fronts minimum-degree orderings leave on big meshes.
//!
//! The separators are BFS level sets, as in George and Liu's automatic nested
//! dissection (1978): a breadth-first search from a pseudo-peripheral vertex
//! (the end of a second sweep) cuts the piece into levels, each of which
//! separates the levels before it from those after; we take the level of
//! least `|S| / (|near| |far|)` that leaves each side a tenth ([`Rule`]) and
//! refine it by Fiduccia-Mattheyses vertex moves
//! ([`fiduccia_mattheyses`]; Ashcraft and Liu 1994), which drop the vertices
//! that touch one side only and trade ragged stretches of the wavefront for
//! shorter ones. On a triangle mesh a level is a closed curve of vertices, a
//! ring on a tube, so this needs neither coordinates nor a multilevel
//! partitioner, costs a few breadth-first sweeps per level of the recursion
//! (`O(n log n)` in all; the refinement touches only the separator's
//! neighbourhood), and the two halves of each piece are ordered in parallel.
//! Small pieces are ordered by approximate minimum degree (faer's AMD) on
//! their own.
//!
//! Why not METIS (the `metis` crate builds it from vendored C sources): its
//! multilevel separators leave less fill (a quarter less than AMD on the
//! helix tube in CHOLMOD, issue 14), but with CHOLMOD the METIS runs took
//! longer end to end than the AMD ones on both 1M shapes measured there
//! (12.8 s against 9.9 s, 27.8 s against 15.3 s), and while it runs METIS
//! replaces the process's SIGTERM and SIGABRT handlers with its own
//! longjmp-based ones (GKlib's `gk_sigtrap`), which a library inside a
//! Python process that others signal must not do.
//!
//! The ordering is deterministic: the parallel halves touch disjoint vertices,
//! and the piece labels they share only tell membership.

mod breadth_first;
mod fiduccia_mattheyses;

use crate::direct::amd_order;
pub(crate) use breadth_first::prefetch_rows_ahead;
use breadth_first::{Known, Levels};
use fiduccia_mattheyses::Split;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

/// Pieces at most this large are ordered by approximate minimum degree,
/// which does better than further dissection there (measured on the 1M
/// shapes: 48 -> 256 saves 1-3% of the factor; 1024-8192, no more).
const LEAF: usize = 256;

/// Pieces larger than this order their two halves on two rayon tasks.
const PARALLEL: usize = 8_192;

/// How [`Dissection::dissect`] picks its levels: the ratio cut, each side
/// keeping at least a tenth of the piece (0.1 against 0.05 and 0.2, and
/// against the smallest level leaving each side a third, the rule before:
/// the smallest factors on the corpus and the 1M shapes, docs/benchmarks.md).
const RULE: Rule = Rule::Ratio(0.1);

/// The balance of [`bisection`], whose halves are factored on two cores at
/// once: there the larger half sets the time (a 45/55 split costs 57% of
/// one core's time at `O(n^1.5)` work, a 33/67 split 70%), and the
/// separator, factored dense, costs little unless it is much larger.
const HALVES: Rule = Rule::Balanced(0.45);

/// How [`separator_level`] weighs a level's size against the balance of
/// the sides it leaves; each rule's share is the least either side keeps.
#[derive(Debug, Clone, Copy)]
enum Rule {
    /// The smallest level.
    Balanced(f64),
    /// The level of least `|S| / (|near| |far|)`: the ratio cut (Wei and
    /// Cheng 1989). On shapes with limbs (the corpus's scorpion, armadillo,
    /// octopus) a small cut at a limb's root then beats a balanced one
    /// through the body, which AMD would not make either: the dense corner
    /// of a separator and the boundaries it leaves its pieces cost more
    /// than the imbalance.
    Ratio(f64),
}

impl Rule {
    /// The least number of vertices either side of a `len`-vertex piece keeps.
    fn least(self, len: usize) -> usize {
        let (Rule::Balanced(share) | Rule::Ratio(share)) = self;
        (share * len as f64) as usize
    }
}

/// The label of a vertex placed in a separator: never a piece's label.
const PLACED: u32 = u32::MAX;

/// The graph of a structurally symmetric matrix in CSR form, diagonal allowed.
struct Dissection<'a> {
    offsets: &'a [usize],
    indices: &'a [u32],
    /// The piece each vertex belongs to now; a breadth-first search moves the
    /// vertices it reaches to a fresh label, so labels double as visit marks.
    label: Vec<AtomicU32>,
    next_label: AtomicU32,
    /// Index of each vertex within its piece, while a small piece is
    /// ordered; while a piece is cut, the separator refinement's locks.
    local: Vec<AtomicU32>,
}

/// The number of levels of a breadth-first search from the far end of a
/// search from vertex 0 (a lower bound on the graph's diameter, and near it
/// on meshes): two sweeps, `O(n)`. 0 for an empty graph.
pub(crate) fn pseudo_diameter(offsets: &[usize], indices: &[u32]) -> usize {
    let n = offsets.len().saturating_sub(1);
    if n == 0 {
        return 0;
    }
    let mut level = vec![u32::MAX; n];
    let sweep = |start: usize, level: &mut [u32]| {
        level.fill(u32::MAX);
        level[start] = 0;
        let mut queue = vec![start as u32];
        let mut head = 0;
        while head < queue.len() {
            let v = queue[head] as usize;
            head += 1;
            for &w in &indices[offsets[v]..offsets[v + 1]] {
                if level[w as usize] == u32::MAX {
                    level[w as usize] = level[v] + 1;
                    queue.push(w);
                }
            }
        }
        let last = queue[queue.len() - 1] as usize;
        (last, level[last] as usize + 1)
    };
    let (far_end, _) = sweep(0, &mut level);
    sweep(far_end, &mut level).1
}

/// A piece of the graph to order: its vertices `vs` (each labelled `label`),
/// to be overwritten by their order, a vertex `hint` of it to search from,
/// and what is `known` of that search already.
struct Piece<'a> {
    vs: &'a mut [u32],
    label: u32,
    hint: u32,
    known: Known,
}

/// What [`Dissection::cut`] made of a piece: the labels of its two sides
/// and their sizes.
struct Cut {
    near: u32,
    far: u32,
    n_near: usize,
    n_separator: usize,
}

/// The first cut of [`nested_dissection`] alone: the vertices of a connected
/// graph in three runs, `near`, `far` and `separator`, in that order, where
/// no edge joins `near` to `far` and neither is empty (`vs[..n_near]`,
/// `vs[n_near..n - n_separator]`, `vs[n - n_separator..]`). `None` for a
/// disconnected graph or one too small or too short to cut (fewer than
/// three levels).
pub(crate) struct Bisection {
    pub(crate) vs: Vec<u32>,
    pub(crate) n_near: usize,
    pub(crate) n_separator: usize,
}

pub(crate) fn bisection(offsets: &[usize], indices: &[u32]) -> Option<Bisection> {
    let n = offsets.len().saturating_sub(1);
    if n <= LEAF {
        return None;
    }
    let work = Dissection {
        offsets,
        indices,
        label: (0..n).map(|_| AtomicU32::new(0)).collect(),
        next_label: AtomicU32::new(1),
        local: (0..n).map(|_| AtomicU32::new(0)).collect(),
    };
    let first = work.fresh();
    let sweep = work.bfs(0, 0, first, n);
    if sweep.queue.len() < n {
        return None;
    }
    let far_end = sweep.queue[n - 1];
    drop(sweep);
    let second = work.fresh();
    let levels = work.bfs(far_end, first, second, n);
    if levels.count() < 3 {
        return None;
    }
    let mut vs = vec![0u32; n];
    let cut = work.cut(&levels, &mut vs, HALVES);
    Some(Bisection { vs, n_near: cut.n_near, n_separator: cut.n_separator })
}

/// A fill-reducing ordering of the `n`-vertex graph whose adjacency is the
/// CSR pattern (`offsets`, `indices`) of a structurally symmetric matrix:
/// `perm[k]` is the vertex eliminated `k`-th. `O(n log n)` time.
pub(crate) fn nested_dissection(offsets: &[usize], indices: &[u32]) -> Vec<u32> {
    let n = offsets.len().saturating_sub(1);
    // The searches below jump between neighbours; numbered in breadth-first
    // order, the graph's neighbours sit close in memory and each piece in a
    // few runs of it (measured: the ordering takes about half the time).
    let (order, first_component, graph) = breadth_first_copy(offsets, indices);
    let work = Dissection {
        offsets: &graph.0,
        indices: &graph.1,
        label: (0..n).map(|_| AtomicU32::new(0)).collect(),
        next_label: AtomicU32::new(1),
        local: (0..n).map(|_| AtomicU32::new(0)).collect(),
    };
    let mut perm: Vec<u32> = (0..n as u32).collect();
    if n > 0 {
        // In the breadth-first numbering a search from vertex 0 meets the
        // vertices of its component in the order 0, 1, 2, ...: the whole
        // graph's first sweep is known without searching.
        let known = Known { head: first_component, end: first_component };
        work.dissect(Piece { vs: &mut perm, label: 0, hint: 0, known });
    }
    drop(work);
    let perm = postorder(&graph.0, &graph.1, perm);
    perm.into_iter().map(|k| order[k as usize]).collect()
}

/// The graph renumbered in breadth-first order (component by component),
/// without self loops: the new-to-old numbering, the size of the first
/// component (vertex 0's), and the new CSR arrays.
fn breadth_first_copy(
    offsets: &[usize],
    indices: &[u32],
) -> (Vec<u32>, usize, (Vec<usize>, Vec<u32>)) {
    const UNSEEN: u32 = u32::MAX;
    let n = offsets.len().saturating_sub(1);
    let mut new_of = vec![UNSEEN; n];
    let mut order = Vec::with_capacity(n);
    let mut first_component = None;
    for root in 0..n {
        if new_of[root] != UNSEEN {
            continue;
        }
        if root > 0 && first_component.is_none() {
            first_component = Some(order.len());
        }
        new_of[root] = order.len() as u32;
        order.push(root as u32);
        let mut head = order.len() - 1;
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            for &w in &indices[offsets[v]..offsets[v + 1]] {
                if new_of[w as usize] == UNSEEN {
                    new_of[w as usize] = order.len() as u32;
                    order.push(w);
                }
            }
        }
    }
    let mut new_offsets = Vec::with_capacity(n + 1);
    let mut new_indices = Vec::with_capacity(indices.len());
    new_offsets.push(0);
    for &v in &order {
        let v = v as usize;
        new_indices.extend(
            indices[offsets[v]..offsets[v + 1]]
                .iter()
                .filter(|&&w| w as usize != v)
                .map(|&w| new_of[w as usize]),
        );
        new_offsets.push(new_indices.len());
    }
    (order, first_component.unwrap_or(n), (new_offsets, new_indices))
}

/// `perm` renumbered in a postorder of its elimination tree, which changes
/// no fill but makes every chain of the tree consecutive columns: faer finds
/// supernodes only among consecutive columns (AMD's orders come postordered;
/// the leaves' AMD orders and the separators' here do not quite).
fn postorder(offsets: &[usize], indices: &[u32], perm: Vec<u32>) -> Vec<u32> {
    const NONE: u32 = u32::MAX;
    let n = perm.len();
    let mut inverse = vec![0u32; n];
    for (k, &v) in perm.iter().enumerate() {
        inverse[v as usize] = k as u32;
    }
    // Elimination tree (Liu 1986), with path compression through `ancestor`.
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for (k, &v) in perm.iter().enumerate() {
        // `perm` jumps about the graph (leaf by leaf, then the separators).
        prefetch_rows_ahead(offsets, indices, &perm, k);
        let k = k as u32;
        for &w in &indices[offsets[v as usize]..offsets[v as usize + 1]] {
            let mut i = inverse[w as usize];
            if i >= k {
                continue;
            }
            while ancestor[i as usize] != NONE && ancestor[i as usize] != k {
                let next = ancestor[i as usize];
                ancestor[i as usize] = k;
                i = next;
            }
            if ancestor[i as usize] == NONE {
                ancestor[i as usize] = k;
                parent[i as usize] = k;
            }
        }
    }
    drop(ancestor);
    // Children in increasing order, then an iterative depth-first walk.
    let mut first_child = vec![NONE; n];
    let mut next_sibling = vec![NONE; n];
    for k in (0..n).rev() {
        let p = parent[k];
        if p != NONE {
            next_sibling[k] = first_child[p as usize];
            first_child[p as usize] = k as u32;
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n as u32).filter(|&k| parent[k as usize] == NONE) {
        stack.push(root);
        while let Some(&top) = stack.last() {
            let child = first_child[top as usize];
            if child == NONE {
                order.push(perm[top as usize]);
                stack.pop();
            } else {
                first_child[top as usize] = next_sibling[child as usize];
                stack.push(child);
            }
        }
    }
    order
}

impl Dissection<'_> {
    fn fresh(&self) -> u32 {
        self.next_label.fetch_add(1, Relaxed)
    }

    fn neighbours(&self, v: u32) -> &[u32] {
        &self.indices[self.offsets[v as usize]..self.offsets[v as usize + 1]]
    }

    /// Orders a piece in place.
    fn dissect(&self, piece: Piece<'_>) {
        let Piece { vs, label: piece, hint, known } = piece;
        let len = vs.len();
        if len <= 1 {
            return;
        }
        // Two sweeps: the far end of a search from anywhere is nearly
        // peripheral, and levels from there cut the piece across its length.
        let first = self.fresh();
        let sweep = self.sweep(hint, piece, first, &vs[..known.end], known.head, len);
        if sweep.len() < len {
            // Disconnected: every component is ordered on its own, one after
            // the other, with no separator. All are found here in one pass
            // (peeling one per call would recurse once per component, and
            // a matrix may have a million of them).
            let mut components = vec![(first, hint, sweep)];
            for &v in vs.iter() {
                if self.label[v as usize].load(Relaxed) == piece {
                    let label = self.fresh();
                    components.push((label, v, self.sweep(v, piece, label, &[], 0, 0)));
                }
            }
            let mut rest: &mut [u32] = vs;
            for (label, hint, members) in components {
                let (head, tail) = std::mem::take(&mut rest).split_at_mut(members.len());
                head.copy_from_slice(&members);
                drop(members);
                // All of the component's search is known: it is `members`.
                let known = Known { head: head.len(), end: head.len() };
                self.dissect(Piece { vs: head, label, hint, known });
                rest = tail;
            }
            return;
        }
        let far_end = sweep[len - 1];
        drop(sweep);
        let second = self.fresh();
        let levels = self.bfs(far_end, first, second, len);
        if len <= LEAF || levels.count() < 3 {
            self.minimum_degree(vs, &levels.queue, second);
            return;
        }
        let Cut { near, far, n_near, n_separator } = self.cut(&levels, vs, RULE);
        // The searches' ends, unless the refinement moved them.
        let label = |v: u32| self.label[v as usize].load(Relaxed);
        let near_hint = if label(far_end) == near { far_end } else { vs[0] };
        let far_hint = levels.queue[len - 1];
        let far_hint = if label(far_hint) == far { far_hint } else { vs[n_near] };
        // The near side's first search starts where this piece's second
        // did, from `far_end`: up to the first level the refinement
        // changed, it meets the same vertices in the same order (a vertex
        // of an unchanged level is as far from `far_end` in the near side as
        // in the piece, through the same unchanged levels), and `cut` wrote
        // those levels first into `vs`. Only the rest is searched again.
        let whole =
            (0..levels.count()).find(|&j| levels.level(j).iter().any(|&v| label(v) != near));
        let near_known = match whole {
            Some(m) if m > 0 => Known { head: levels.starts[m - 1], end: levels.starts[m] },
            _ => Known::default(),
        };
        drop(levels);
        let (near_part, rest) = vs.split_at_mut(n_near);
        let far_part = &mut rest[..len - n_near - n_separator];
        // Both sides search twice: from the near side's root levels would be
        // rings around it, and starting the far side at its last vertex
        // (measured) gave 5% more fill on blobs for little time.
        self.both(
            Piece { vs: near_part, label: near, hint: near_hint, known: near_known },
            Piece { vs: far_part, label: far, hint: far_hint, known: Known::default() },
        );
    }

    /// Cuts a connected piece, searched in `levels` (at least three), at the
    /// level [`separator_level`] picks, refined by Fiduccia-Mattheyses
    /// ([`fiduccia_mattheyses`]): writes the near side, the far side and the
    /// separator into `vs` in that order, the sides in breadth-first order,
    /// and labels the sides afresh (the separator [`PLACED`]).
    fn cut(&self, levels: &Levels, vs: &mut [u32], rule: Rule) -> Cut {
        let len = vs.len();
        let k = separator_level(&levels.starts, len, rule);
        let (near, far, sep) = (self.fresh(), self.fresh(), self.fresh());
        for (v, label) in levels.queue[..levels.starts[k]]
            .iter()
            .map(|v| (v, near))
            .chain(levels.level(k).iter().map(|v| (v, sep)))
            .chain(levels.queue[levels.starts[k + 1]..].iter().map(|v| (v, far)))
        {
            self.label[*v as usize].store(label, Relaxed);
        }
        // The level is a separator as it is; the refinement first drops
        // the vertices that touch one side only (into the other), then
        // trades the rest for shorter rings.
        let mut split = Split {
            labels: [near, far],
            sep,
            sizes: [levels.starts[k], len - levels.starts[k + 1]],
            separator: levels.level(k).to_vec(),
        };
        self.refine_separator(&mut split, rule.least(len));
        let n_near = split.sizes[0];
        let (mut a, mut b) = (0, n_near);
        for &v in &levels.queue {
            let label = self.label[v as usize].load(Relaxed);
            if label == near {
                vs[a] = v;
                a += 1;
            } else if label == far {
                vs[b] = v;
                b += 1;
            }
        }
        for (slot, &v) in vs[b..].iter_mut().zip(&split.separator) {
            *slot = v;
            self.label[v as usize].store(PLACED, Relaxed);
        }
        Cut { near, far, n_near, n_separator: split.separator.len() }
    }

    /// Orders a small piece (`members`, each labelled `piece`) by approximate
    /// minimum degree on its own graph, into `vs`. Edges to the separators
    /// around it are left out: they are eliminated after the whole piece.
    fn minimum_degree(&self, vs: &mut [u32], members: &[u32], piece: u32) {
        let len = members.len();
        for (i, &v) in members.iter().enumerate() {
            self.local[v as usize].store(i as u32, Relaxed);
        }
        let mut offsets = Vec::with_capacity(len + 1);
        let mut indices = Vec::with_capacity(8 * len);
        offsets.push(0u32);
        for &v in members {
            let start = indices.len();
            indices.extend(
                self.neighbours(v)
                    .iter()
                    .filter(|&&w| self.label[w as usize].load(Relaxed) == piece)
                    .map(|&w| self.local[w as usize].load(Relaxed)),
            );
            indices[start..].sort_unstable();
            offsets.push(indices.len() as u32);
        }
        let mut perm = vec![0u32; len];
        let mut inverse = vec![0u32; len];
        let ordered = amd_order(&mut perm, &mut inverse, len, &offsets, &indices);
        if ordered {
            for (slot, &k) in vs.iter_mut().zip(&perm) {
                *slot = members[k as usize];
            }
        } else {
            // Reverse breadth-first order: a narrow band.
            for (slot, &v) in vs.iter_mut().zip(members.iter().rev()) {
                *slot = v;
            }
        }
    }

    /// Orders two independent pieces, in parallel when they are large.
    fn both(&self, a: Piece<'_>, b: Piece<'_>) {
        if a.vs.len() + b.vs.len() > PARALLEL {
            rayon::join(|| self.dissect(a), || self.dissect(b));
        } else {
            self.dissect(a);
            self.dissect(b);
        }
    }
}

/// The level to cut at: the best by `rule` among those that leave each side
/// its least share of the piece, or the one holding the median vertex when
/// none does. Never the first or the last level, so both sides are non-empty.
fn separator_level(starts: &[usize], len: usize, rule: Rule) -> usize {
    let count = starts.len() - 1;
    let least = rule.least(len);
    let size = |k: usize| starts[k + 1] - starts[k];
    let allowed = (1..count - 1).filter(|&k| starts[k] >= least && len - starts[k + 1] >= least);
    let best = match rule {
        Rule::Balanced(_) => allowed.min_by_key(|&k| (size(k), k)),
        Rule::Ratio(_) => {
            let cost =
                |k: usize| size(k) as f64 / (starts[k] as f64 * (len - starts[k + 1]) as f64);
            allowed.min_by(|&a, &b| cost(a).total_cmp(&cost(b)).then(a.cmp(&b)))
        }
    };
    best.unwrap_or_else(|| {
        let median = (1..count).find(|&k| starts[k + 1] > len / 2).unwrap_or(count - 1);
        median.clamp(1, count - 2)
    })
}

#[cfg(test)]
mod tests;
