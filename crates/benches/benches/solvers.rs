//! Linear solvers on the 5-point Laplacian of the interior block of a square
//! grid with a fixed (Dirichlet) boundary: the shape of the Tutte systems of
//! thesis ch. 4, at 10k, ~100k (316 x 316) and 1M (1000 x 1000) unknowns, two
//! right-hand sides (the x and y of an embedding) solved to a relative
//! residual of 1e-8. Throughput is in unknowns.
//!
//! Criterion times (10 samples each) every solver at 10k, the direct and CG
//! solvers at 100k, and the direct solver at 1M. The rest is too slow for ten
//! samples and runs once, in a table printed first: Gauss-Seidel (thesis 4.5)
//! needs O(side^2) sweeps, so at 100k it is capped at 10,000 sweeps and its
//! cost to 1e-8 extrapolated (once run to the end: 68,609 sweeps, 114 s); CG
//! with IC(0) and with Jacobi at 1M run once to 1e-8. The whole bench takes
//! about 5 minutes on 2 cores. `SOLVERS_REPORT_ONLY=1` prints only that table,
//! `SOLVERS_SKIP_REPORT=1` skips it.

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use spherify_sparse::{solve, CsrMatrix, SolveParams, SolverKind, SparseError};
use std::hint::black_box;
use std::time::{Duration, Instant};

const TOL: f64 = 1e-8;

/// The interior-block Laplacian of a `side x side` grid: 4 on the diagonal, -1
/// per interior neighbour; and two right-hand sides from boundary values
/// cos(angle), sin(angle) around the grid centre (a Tutte map to a circle).
fn grid_system(side: usize) -> (CsrMatrix, Vec<Vec<f64>>) {
    let n = side * side;
    let (mut rows, mut cols, mut vals) = (Vec::new(), Vec::new(), Vec::new());
    let mut rhs = vec![vec![0.0; n]; 2];
    let centre = (side as f64 - 1.0) / 2.0;
    for y in 0..side {
        for x in 0..side {
            let i = y * side + x;
            rows.push(i as u32);
            cols.push(i as u32);
            vals.push(4.0);
            let neighbours = [
                (x as i64 - 1, y as i64),
                (x as i64 + 1, y as i64),
                (x as i64, y as i64 - 1),
                (x as i64, y as i64 + 1),
            ];
            for (nx, ny) in neighbours {
                if (0..side as i64).contains(&nx) && (0..side as i64).contains(&ny) {
                    rows.push(i as u32);
                    cols.push((ny as usize * side + nx as usize) as u32);
                    vals.push(-1.0);
                } else {
                    let angle = (ny as f64 - centre).atan2(nx as f64 - centre);
                    rhs[0][i] += angle.cos();
                    rhs[1][i] += angle.sin();
                }
            }
        }
    }
    match CsrMatrix::from_triplets(n, n, &rows, &cols, &vals) {
        Ok(a) => (a, rhs),
        Err(e) => panic!("grid assembly failed: {e}"),
    }
}

fn params(max_iter: usize) -> SolveParams {
    SolveParams { tol: TOL, max_iter, x0: None }
}

/// One run, printed as a table row.
fn report_one(label: &str, a: &CsrMatrix, rhs: &[Vec<f64>], kind: SolverKind, max_iter: usize) {
    let name = format!("{kind:?}");
    match solve(a, rhs, kind, &params(max_iter)) {
        Ok((_, info)) => println!(
            "{label:>5} {name:<12} {:8.3} s  {:7} iterations  residual {:.1e}",
            info.seconds, info.iterations, info.residual
        ),
        Err(e) => println!("{label:>5} {name:<12} error: {e}"),
    }
}

/// Gauss-Seidel in two capped halves, the second continuing from the first's
/// last iterate, and the sweeps still needed to reach the tolerance
/// extrapolated at the second half's rate. That rate is still faster than the
/// asymptotic one (slow smooth modes take over later), so the estimate is a
/// lower bound: one uncapped run at 100k took 68,609 sweeps and 114 s.
fn report_gauss_seidel_capped(label: &str, a: &CsrMatrix, rhs: &[Vec<f64>], cap: usize) {
    let half = cap / 2;
    let start = Instant::now();
    let first = match solve(a, rhs, SolverKind::GaussSeidel, &params(half)) {
        Err(SparseError::NoConvergence { residual, last, .. }) => (residual, last),
        other => {
            return println!("{label:>5} GaussSeidel  finished within {half} sweeps: {other:?}")
        }
    };
    let more = SolveParams { x0: Some(first.1), ..params(half) };
    let residual = match solve(a, rhs, SolverKind::GaussSeidel, &more) {
        Err(SparseError::NoConvergence { residual, .. }) => residual,
        Ok((_, info)) => info.residual,
        Err(e) => return println!("{label:>5} GaussSeidel  error: {e}"),
    };
    let seconds = start.elapsed().as_secs_f64();
    let rate = (residual / first.0).powf(1.0 / half as f64);
    let needed = 2.0 * half as f64 + (TOL / residual).ln() / rate.ln();
    println!(
        "{label:>5} GaussSeidel  {seconds:8.3} s  {:7} iterations  residual {residual:.1e} \
         (capped; at the second half's rate {rate:.6}/sweep, \
         at least ~{needed:.0} sweeps and ~{:.0} s to {TOL:e})",
        2 * half,
        seconds * needed / (2 * half) as f64
    );
}

/// The runs too slow for criterion's ten samples, once each.
fn report() {
    println!("one-shot runs, 2 right-hand sides, relative residual {TOL:e}:");
    let (a, rhs) = grid_system(316);
    report_gauss_seidel_capped("100k", &a, &rhs, 10_000);
    let (a, rhs) = grid_system(1000);
    report_one("1M", &a, &rhs, SolverKind::CgIc0, 5_000);
    report_one("1M", &a, &rhs, SolverKind::CgJacobi, 5_000);
}

fn bench_solvers(c: &mut Criterion) {
    if std::env::var_os("SOLVERS_SKIP_REPORT").is_none() {
        report();
    }
    if std::env::var_os("SOLVERS_REPORT_ONLY").is_some() {
        return;
    }
    let all =
        [SolverKind::Direct, SolverKind::CgIc0, SolverKind::CgJacobi, SolverKind::GaussSeidel];
    let fast = [SolverKind::Direct, SolverKind::CgIc0, SolverKind::CgJacobi];
    for (label, side, kinds) in
        [("10k", 100, &all[..]), ("100k", 316, &fast[..]), ("1M", 1000, &[SolverKind::Direct][..])]
    {
        let (a, rhs) = grid_system(side);
        let mut group = c.benchmark_group(format!("grid_laplacian_{label}_2rhs"));
        group.sample_size(10);
        group.sampling_mode(SamplingMode::Flat);
        group.warm_up_time(Duration::from_millis(1));
        group.measurement_time(Duration::from_millis(1));
        group.throughput(Throughput::Elements(a.n_rows() as u64));
        for &kind in kinds {
            // Print the iteration count once, since criterion shows only times.
            if let Ok((_, info)) = solve(&a, &rhs, kind, &params(200_000)) {
                println!(
                    "{label} {kind:?}: {} iterations, residual {:.1e}",
                    info.iterations, info.residual
                );
            }
            group.bench_function(format!("{kind:?}"), |b| {
                b.iter(|| solve(black_box(&a), &rhs, kind, &params(200_000)))
            });
        }
        group.finish();
    }
}

criterion_group!(benches, bench_solvers);
criterion_main!(benches);
