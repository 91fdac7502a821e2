//! Assembly and product cost of CSR matrices on the 5-point Laplacian of a
//! 1000 x 1000 grid (1M unknowns, ~5M entries): the size and shape of the Tutte
//! systems of thesis ch. 4 on large meshes. Throughput is in stored entries.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spherify_sparse::CsrMatrix;
use std::hint::black_box;

const SIDE: usize = 1000;

/// Triplets of the grid Laplacian (4 on the diagonal, -1 per grid neighbour),
/// emitted per edge and per vertex the way mesh assembly emits them: unsorted
/// within rows, with the diagonal built from repeated contributions.
fn laplacian_triplets(side: usize) -> (Vec<u32>, Vec<u32>, Vec<f64>) {
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    let mut push = |i: usize, j: usize, v: f64| {
        rows.push(i as u32);
        cols.push(j as u32);
        vals.push(v);
    };
    for y in 0..side {
        for x in 0..side {
            let v = y * side + x;
            // Dirichlet boundary: the missing neighbours still count on the diagonal.
            let degree = usize::from(x > 0) + usize::from(x + 1 < side);
            let degree = degree + usize::from(y > 0) + usize::from(y + 1 < side);
            push(v, v, (4 - degree) as f64);
            let mut edge = |w: usize| {
                push(v, v, 1.0);
                push(w, w, 1.0);
                push(v, w, -1.0);
                push(w, v, -1.0);
            };
            if x + 1 < side {
                edge(v + 1);
            }
            if y + 1 < side {
                edge(v + side);
            }
        }
    }
    (rows, cols, vals)
}

fn bench_csr(c: &mut Criterion) {
    let n = SIDE * SIDE;
    let (rows, cols, vals) = laplacian_triplets(SIDE);
    let a = match CsrMatrix::from_triplets(n, n, &rows, &cols, &vals) {
        Ok(a) => a,
        Err(e) => panic!("grid Laplacian assembly failed: {e}"),
    };
    let mut group = c.benchmark_group("csr_grid_laplacian_1M");
    group.sample_size(10);

    group.throughput(Throughput::Elements(rows.len() as u64));
    group.bench_function("from_triplets", |b| {
        b.iter(|| CsrMatrix::from_triplets(n, n, black_box(&rows), &cols, &vals))
    });

    group.throughput(Throughput::Elements(a.nnz() as u64));
    let x: Vec<f64> = (0..n).map(|i| (i % 17) as f64 - 8.0).collect();
    let mut y = vec![0.0; n];
    group.bench_function("mul_vec", |b| b.iter(|| a.mul_vec(black_box(&x), &mut y)));
    group.finish();
}

criterion_group!(benches, bench_csr);
criterion_main!(benches);
