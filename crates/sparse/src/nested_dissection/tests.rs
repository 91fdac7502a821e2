use super::*;
use crate::test_support::grid_laplacian;
use crate::CsrMatrix;

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
