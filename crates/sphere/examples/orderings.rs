//! Fill, flops and time of the sparse Cholesky orderings on the theta-phi
//! system of each mesh given (issue 14; the tables of docs/benchmarks.md):
//!
//! ```text
//! cargo run --release -p spherify-sphere --example orderings -- mesh.ply [more meshes...]
//! ```
//!
//! For every mesh, theta-phi runs once (default parameters), and the free
//! block of its cut mesh's Tutte matrix, the matrix theta-phi factors, is
//! factored with AMD, with our nested dissection, and as
//! `spherify_sparse::Factorization` chooses (the smaller predicted factor
//! up to 200k unknowns; above, two halves on two cores and a dense corner).
//! One markdown row per factor: values faer stores for L (relaxed
//! supernodes included), true nonzeros of L, flops (`sum_j c_j^2`), each
//! against AMD, and the seconds of ordering + symbolic analysis and of the
//! numeric factorisation (`spherify_sparse::ordering_report`).
//! `REPS=k` repeats the factorisations k times and prints every repeat.

use spherify_sphere::methods::theta_phi::rectangle::rectangle_system;
use spherify_sphere::methods::theta_phi::{theta_phi, ThetaPhiParams};
use spherify_sphere::GenusZeroMesh;
use std::path::Path;

fn main() {
    let reps: usize = std::env::var("REPS").ok().and_then(|s| s.parse().ok()).unwrap_or(1);
    println!(
        "| mesh | unknowns | ordering | L stored | L nonzeros | flops | stored / AMD | nonzeros / AMD | flops / AMD | order+symbolic s | numeric s |"
    );
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|");
    for path in std::env::args().skip(1) {
        if let Err(e) = report(&path, reps) {
            eprintln!("{path}: {e}");
        }
    }
}

fn report(path: &str, reps: usize) -> Result<(), Box<dyn std::error::Error>> {
    let loaded = spherify_mesh::io::read(Path::new(path))?;
    let mesh = GenusZeroMesh::new(loaded.mesh)?;
    let params = ThetaPhiParams::default();
    let (_, details) = theta_phi(&mesh, &params)?;
    let system = rectangle_system(&mesh, &details, params.weights)?;
    drop(details);
    let name = Path::new(path).file_stem().map_or(path.into(), |s| s.to_string_lossy());
    let n = system.matrix.n_rows();
    for _ in 0..reps {
        let rows = spherify_sparse::ordering_report(&system.matrix)?;
        let amd = rows[0].clone();
        for r in rows {
            println!(
                "| {name} | {} | {} | {} | {} | {:.3e} | {:.3} | {:.3} | {:.3} | {:.3} | {:.3} |",
                grouped(n),
                r.name,
                grouped(r.stored),
                grouped(r.nnz),
                r.flops,
                r.stored as f64 / amd.stored as f64,
                r.nnz as f64 / amd.nnz as f64,
                r.flops / amd.flops,
                r.order_seconds,
                r.numeric_seconds
            );
        }
    }
    Ok(())
}

/// `n` with thousands separators.
fn grouped(n: usize) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}
