//! Tests of the nested-dissection ordering: a permutation, its fill, its
//! determinism, and the reference it was made faster from.

use super::*;
use crate::test_support::grid_laplacian;
use crate::CsrMatrix;

/// The ordering before it was made faster, to compare with.
mod reference;

fn order(a: &CsrMatrix) -> Vec<u32> {
    nested_dissection(a.row_offsets(), a.col_indices())
}

fn is_permutation(perm: &[u32]) -> bool {
    let mut seen = vec![false; perm.len()];
    perm.iter().all(|&v| !std::mem::replace(&mut seen[v as usize], true))
}

/// Nonzeros of the Cholesky factor of the pattern of `a` under `perm`
/// (elimination by sets: the reach of each column), for small matrices.
fn fill(a: &CsrMatrix, perm: &[u32]) -> usize {
    let n = a.n_rows();
    let mut inverse = vec![0usize; n];
    for (k, &v) in perm.iter().enumerate() {
        inverse[v as usize] = k;
    }
    let mut cols: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); n];
    for i in 0..n {
        for &j in a.row(i).0 {
            let (p, q) = (inverse[i], inverse[j as usize]);
            if p > q {
                cols[q].insert(p);
            }
        }
    }
    let mut total = 0;
    for k in 0..n {
        let below: Vec<usize> = cols[k].iter().copied().collect();
        total += below.len() + 1;
        if let Some((&parent, rest)) = below.split_first() {
            let merged: Vec<usize> = rest.to_vec();
            cols[parent].extend(merged);
        }
    }
    total
}

#[test]
fn orders_every_vertex_once() {
    for (w, h) in [(1, 1), (1, 2), (3, 1), (7, 9), (40, 3), (60, 60)] {
        let a = grid_laplacian(w, h);
        let perm = order(&a);
        assert_eq!(perm.len(), a.n_rows());
        assert!(is_permutation(&perm), "{w} x {h}");
    }
}

#[test]
fn disconnected_pieces_and_isolated_vertices() {
    // Two 10 x 10 grids side by side with no coupling, and a diagonal-only block.
    let g = grid_laplacian(10, 10);
    let (mut rows, mut cols, mut vals) = (vec![], vec![], vec![]);
    for shift in [0u32, 100] {
        for i in 0..100 {
            let (c, v) = g.row(i);
            for (&j, &x) in c.iter().zip(v) {
                rows.push(i as u32 + shift);
                cols.push(j + shift);
                vals.push(x);
            }
        }
    }
    for i in 200..230 {
        rows.push(i);
        cols.push(i);
        vals.push(1.0);
    }
    let a = CsrMatrix::from_triplets(230, 230, &rows, &cols, &vals).unwrap();
    assert!(is_permutation(&order(&a)));
}

#[test]
fn a_million_components_need_no_deep_recursion() {
    // A diagonal matrix: every vertex its own component.
    let n = 1_000_000;
    let offsets: Vec<usize> = (0..=n).collect();
    let indices: Vec<u32> = (0..n as u32).collect();
    let perm = nested_dissection(&offsets, &indices);
    assert!(is_permutation(&perm));
}

#[test]
fn fills_far_less_than_the_band() {
    // On a square grid the natural order is a band as wide as the grid's
    // side (fill ~ n^1.5); nested dissection's is ~ n log n.
    let a = grid_laplacian(60, 60);
    let natural: Vec<u32> = (0..a.n_rows() as u32).collect();
    let nd = fill(&a, &order(&a));
    let band = fill(&a, &natural);
    assert!(nd * 3 < band, "nested dissection {nd} against band {band}");
}

#[test]
fn pseudo_diameter_of_grids() {
    // A w x h grid's diameter is w + h - 2 edges, w + h - 1 levels; the
    // two sweeps find it from any corner, and vertex 0 is one.
    for (w, h) in [(1, 1), (5, 1), (7, 9), (100, 3)] {
        let a = grid_laplacian(w, h);
        assert_eq!(pseudo_diameter(a.row_offsets(), a.col_indices()), w + h - 1);
    }
    assert_eq!(pseudo_diameter(&[0], &[]), 0);
}

#[test]
fn deterministic() {
    let a = grid_laplacian(150, 140);
    assert_eq!(order(&a), order(&a));
}

/// A small deterministic generator (SplitMix64) for the random graphs below.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// CSR arrays (sorted, no duplicates, no self loops) of the undirected graph
/// with these edges on `n` vertices.
fn csr(n: usize, edges: &[(usize, usize)]) -> (Vec<usize>, Vec<u32>) {
    let mut rows: Vec<Vec<u32>> = vec![Vec::new(); n];
    for &(a, b) in edges {
        if a != b {
            rows[a].push(b as u32);
            rows[b].push(a as u32);
        }
    }
    let mut offsets = vec![0];
    let mut indices = Vec::new();
    for mut row in rows {
        row.sort_unstable();
        row.dedup();
        indices.extend(row);
        offsets.push(indices.len());
    }
    (offsets, indices)
}

/// A triangulated `w x h` grid with a random diagonal in each cell, a
/// random share of its edges dropped (so it may fall apart), and a few
/// random long edges: mesh-like graphs with defects.
fn random_graph(rng: &mut Rng) -> (Vec<usize>, Vec<u32>) {
    let (w, h) = (3 + rng.below(60), 3 + rng.below(60));
    let id = |x: usize, y: usize| y * w + x;
    let drop_per_mille = [0, 0, 20, 100][rng.below(4)];
    let mut edges = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let mut candidates = Vec::new();
            if x + 1 < w {
                candidates.push(id(x + 1, y));
            }
            if y + 1 < h {
                candidates.push(id(x, y + 1));
            }
            if x + 1 < w && y + 1 < h {
                candidates.push(id(x + 1, y + 1));
            }
            if x > 0 && y + 1 < h && rng.below(2) == 0 {
                candidates.push(id(x - 1, y + 1));
            }
            for c in candidates {
                if rng.below(1000) >= drop_per_mille {
                    edges.push((id(x, y), c));
                }
            }
        }
    }
    for _ in 0..rng.below(4) {
        edges.push((rng.below(w * h), rng.below(w * h)));
    }
    csr(w * h, &edges)
}

fn work<'a>(offsets: &'a [usize], indices: &'a [u32]) -> Dissection<'a> {
    let n = offsets.len() - 1;
    Dissection {
        offsets,
        indices,
        label: (0..n).map(|_| AtomicU32::new(0)).collect(),
        next_label: AtomicU32::new(1),
        local: (0..n).map(|_| AtomicU32::new(0)).collect(),
    }
}

/// Whether no edge joins `a` to `b`.
fn separated(offsets: &[usize], indices: &[u32], a: &[u32], b: &[u32]) -> bool {
    let mut in_b = vec![false; offsets.len() - 1];
    for &v in b {
        in_b[v as usize] = true;
    }
    a.iter().all(|&v| {
        indices[offsets[v as usize]..offsets[v as usize + 1]].iter().all(|&w| !in_b[w as usize])
    })
}

#[test]
fn cuts_separate_within_the_balance_bound_and_never_grow_the_level() {
    let mut rng = Rng(14);
    let mut refined = 0;
    for _ in 0..200 {
        let (offsets, indices) = random_graph(&mut rng);
        let n = offsets.len() - 1;
        let work = work(&offsets, &indices);
        let piece = work.fresh();
        let levels = work.bfs(rng.below(n) as u32, 0, piece, n);
        let len = levels.queue.len();
        if levels.count() < 3 {
            continue;
        }
        for rule in [RULE, HALVES, Rule::Balanced(0.33)] {
            // Label the searched component afresh for each cut.
            let label = work.fresh();
            for &v in &levels.queue {
                work.label[v as usize].store(label, Relaxed);
            }
            let k = separator_level(&levels.starts, len, rule);
            let level = levels.starts[k + 1] - levels.starts[k];
            let before = levels.starts[k].min(len - levels.starts[k + 1]);
            let mut vs = vec![0; len];
            let cut = work.cut(&levels, &mut vs, rule);
            let (near, rest) = vs.split_at(cut.n_near);
            let (far, separator) = rest.split_at(len - cut.n_near - cut.n_separator);
            assert!(separated(&offsets, &indices, near, far));
            assert!(!near.is_empty() && !far.is_empty());
            assert!(cut.n_separator <= level, "{} > {level}", cut.n_separator);
            let least = rule.least(len).min(before).max(1);
            assert!(near.len().min(far.len()) >= least, "{} {} {least}", near.len(), far.len());
            // Every vertex of the component once, with its side's label.
            let mut sorted = vs.clone();
            sorted.sort_unstable();
            let mut component = levels.queue.clone();
            component.sort_unstable();
            assert_eq!(sorted, component);
            assert!(near.iter().all(|&v| work.label[v as usize].load(Relaxed) == cut.near));
            assert!(far.iter().all(|&v| work.label[v as usize].load(Relaxed) == cut.far));
            assert!(separator.iter().all(|&v| work.label[v as usize].load(Relaxed) == PLACED));
            refined += usize::from(cut.n_separator < level);
        }
    }
    // The refinement did something on most of them.
    assert!(refined > 150, "{refined}");
}

#[test]
fn refinement_straightens_a_ragged_separator() {
    // On a 40 x 40 grid (4-neighbour), the separator {x = 19 or x = 20}
    // is twice as thick as it needs: refinement keeps one column.
    let (w, h) = (40, 40);
    let a = grid_laplacian(h, w);
    let (offsets, indices) = (a.row_offsets(), a.col_indices());
    let work = work(offsets, indices);
    let (near, far, sep) = (work.fresh(), work.fresh(), work.fresh());
    let mut split = Split { labels: [near, far], sep, sizes: [0, 0], separator: Vec::new() };
    for v in 0..w * h {
        let x = v % w;
        let label = match x {
            0..=18 => near,
            19 | 20 => sep,
            _ => far,
        };
        work.label[v].store(label, Relaxed);
        match x {
            0..=18 => split.sizes[0] += 1,
            19 | 20 => split.separator.push(v as u32),
            _ => split.sizes[1] += 1,
        }
    }
    work.refine_separator(&mut split, 600);
    assert_eq!(split.separator.len(), h);
    assert_eq!(split.sizes[0] + split.sizes[1] + h, w * h);
    let side = |label: u32| -> Vec<u32> {
        (0..(w * h) as u32).filter(|&v| work.label[v as usize].load(Relaxed) == label).collect()
    };
    assert!(separated(offsets, indices, &side(near), &side(far)));
    assert_eq!(side(sep).len(), h);
}

#[test]
fn random_graphs_order_to_permutations_and_bisect_cleanly() {
    let mut rng = Rng(1978);
    for _ in 0..100 {
        let (offsets, indices) = random_graph(&mut rng);
        let n = offsets.len() - 1;
        let perm = nested_dissection(&offsets, &indices);
        assert_eq!(perm.len(), n);
        assert!(is_permutation(&perm));
        if let Some(b) = bisection(&offsets, &indices) {
            assert!(is_permutation(&b.vs) && b.vs.len() == n);
            let (near, rest) = b.vs.split_at(b.n_near);
            let far = &rest[..n - b.n_near - b.n_separator];
            assert!(!near.is_empty() && !far.is_empty());
            assert!(separated(&offsets, &indices, near, far));
        }
    }
}

/// Asserts that the ordering and the first cut of the graph are those of
/// [`reference`], the implementation before the searches were made faster:
/// the speed-ups must change no permutation, hence no factor or result.
fn same_as_reference(offsets: &[usize], indices: &[u32], what: &str) {
    assert_eq!(
        nested_dissection(offsets, indices),
        reference::nested_dissection(offsets, indices),
        "ordering of {what}"
    );
    let old = reference::bisection(offsets, indices).map(|b| (b.vs, b.n_near, b.n_separator));
    let new = bisection(offsets, indices).map(|b| (b.vs, b.n_near, b.n_separator));
    assert_eq!(new, old, "bisection of {what}");
}

/// A triangulated tube, `around` vertices around and `along` rings long,
/// each quad split by a random diagonal.
fn tube(around: usize, along: usize, rng: &mut Rng) -> Vec<(usize, usize)> {
    let id = |i: usize, j: usize| j * around + i % around;
    let mut edges = Vec::new();
    for j in 0..along {
        for i in 0..around {
            edges.push((id(i, j), id(i + 1, j)));
            if j + 1 < along {
                edges.push((id(i, j), id(i, j + 1)));
                if rng.below(2) == 0 {
                    edges.push((id(i, j), id(i + 1, j + 1)));
                } else {
                    edges.push((id(i + 1, j), id(i, j + 1)));
                }
            }
        }
    }
    edges
}

/// The edges renumbered by a random permutation of the `n` vertices (a
/// mesh's numbering is not breadth-first), with a self loop on every
/// vertex when `diagonal` (a matrix's pattern has one).
fn shuffled(
    n: usize,
    edges: &[(usize, usize)],
    diagonal: bool,
    rng: &mut Rng,
) -> (Vec<usize>, Vec<u32>) {
    let mut new: Vec<usize> = (0..n).collect();
    for i in (1..n).rev() {
        new.swap(i, rng.below(i + 1));
    }
    let mut edges: Vec<(usize, usize)> = edges.iter().map(|&(a, b)| (new[a], new[b])).collect();
    let (offsets, indices) = csr(n, &edges);
    if !diagonal {
        return (offsets, indices);
    }
    edges.clear();
    let mut rows: Vec<Vec<u32>> = (0..n).map(|v| vec![v as u32]).collect();
    for v in 0..n {
        rows[v].extend(&indices[offsets[v]..offsets[v + 1]]);
        rows[v].sort_unstable();
    }
    let mut with = (vec![0], Vec::new());
    for row in rows {
        with.1.extend(row);
        with.0.push(with.1.len());
    }
    with
}

#[test]
fn grids_order_as_the_reference_did() {
    for (w, h) in [(1, 1), (2, 1), (7, 9), (17, 16), (60, 60), (400, 12), (25, 90), (190, 210)] {
        let a = grid_laplacian(w, h);
        same_as_reference(a.row_offsets(), a.col_indices(), &format!("grid {w} x {h}"));
    }
}

#[test]
fn random_graphs_order_as_the_reference_did() {
    let mut rng = Rng(2024);
    for case in 0..150 {
        let (offsets, indices) = random_graph(&mut rng);
        same_as_reference(&offsets, &indices, &format!("random graph {case}"));
        // The same graph in a scattered numbering, with self loops.
        let n = offsets.len() - 1;
        let edges: Vec<(usize, usize)> = (0..n)
            .flat_map(|v| indices[offsets[v]..offsets[v + 1]].iter().map(move |&w| (v, w as usize)))
            .collect();
        let (offsets, indices) = shuffled(n, &edges, case % 2 == 0, &mut rng);
        same_as_reference(&offsets, &indices, &format!("shuffled random graph {case}"));
    }
}

#[test]
fn tubes_and_disconnected_meshes_order_as_the_reference_did() {
    let mut rng = Rng(7);
    // Long and short tubes, large enough to be cut in parallel and refined
    // in full, numbered ring by ring and scattered.
    for (around, along) in [(12, 700), (40, 40), (90, 300), (300, 30)] {
        let n = around * along;
        let edges = tube(around, along, &mut rng);
        let (offsets, indices) = csr(n, &edges);
        same_as_reference(&offsets, &indices, &format!("tube {around} x {along}"));
        let (offsets, indices) = shuffled(n, &edges, true, &mut rng);
        same_as_reference(&offsets, &indices, &format!("shuffled tube {around} x {along}"));
    }
    // Three tubes and isolated vertices, apart and interleaved.
    let mut edges = Vec::new();
    let mut n = 0;
    for (around, along) in [(30, 200), (8, 50), (50, 90)] {
        edges.extend(tube(around, along, &mut rng).into_iter().map(|(a, b)| (a + n, b + n)));
        n += around * along;
    }
    n += 100;
    let (offsets, indices) = csr(n, &edges);
    same_as_reference(&offsets, &indices, "three tubes");
    let (offsets, indices) = shuffled(n, &edges, true, &mut rng);
    same_as_reference(&offsets, &indices, "three tubes, shuffled");
}
