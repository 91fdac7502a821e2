//! The size of the authalic steps' sparse Cholesky factor (issue 22, item 3:
//! where the authalic energy's memory goes): the matrix of
//! `progressive::authalic_newton`'s Levenberg-Marquardt step has two
//! unknowns per vertex and a 2x2 block for every pair of vertices sharing a
//! face, the pattern of J^T J. This builds a matrix of exactly that pattern
//! (values of a diagonally dominant Laplacian, so it is positive definite;
//! the factor's size depends on the pattern alone) and prints
//! `spherify_sparse::ordering_report` for it:
//!
//! ```text
//! cargo run --release -p spherify-sphere --example authalic_fill -- mesh.ply [more meshes...]
//! ```

use spherify_sparse::CsrMatrix;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("| mesh | vertices | unknowns | A nonzeros | ordering | L stored | L nonzeros | numeric s |");
    println!("|---|---:|---:|---:|---|---:|---:|---:|");
    for path in std::env::args().skip(1) {
        let loaded = spherify_mesh::io::read(Path::new(&path))?;
        let (faces, n) = (loaded.mesh.faces().to_vec(), loaded.mesh.n_vertices());
        // Each vertex's neighbours through its faces (itself included).
        let mut near: Vec<Vec<u32>> = (0..n as u32).map(|v| vec![v]).collect();
        for f in &faces {
            for &a in f {
                near[a as usize].extend(f.iter().copied().filter(|&b| b != a));
            }
        }
        for list in &mut near {
            list.sort_unstable();
            list.dedup();
        }
        let (a, _) = CsrMatrix::from_rows(2 * n, 2 * n, |r, entries| {
            let v = r / 2;
            for &w in &near[v] {
                for c in 0..2 {
                    let col = 2 * w + c;
                    let value = if col as usize == r { 2.0 * near[v].len() as f64 } else { -1.0 };
                    entries.push((col, value));
                }
            }
        })?;
        let name =
            Path::new(&path).file_stem().map_or(path.clone(), |s| s.to_string_lossy().into());
        for s in spherify_sparse::ordering_report(&a)? {
            println!(
                "| {name} | {n} | {} | {} | {} | {} | {} | {:.2} |",
                2 * n,
                a.values().len(),
                s.name,
                s.stored,
                s.nnz,
                s.numeric_seconds
            );
        }
    }
    Ok(())
}
