//! Times the stages of load + check + orient on one file:
//! `cargo run --release -p spherify-mesh --example profile_check -- PATH`.
use spherify_mesh::{edge_table::EdgeTable, io, orient::orient, validate::check};
use std::time::Instant;

fn main() {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: profile_check MESH");
        std::process::exit(2);
    };
    let rounds: usize = std::env::var("ROUNDS").ok().and_then(|r| r.parse().ok()).unwrap_or(3);
    for _ in 0..rounds {
        let t = Instant::now();
        let loaded = match io::read(std::path::Path::new(&path)) {
            Ok(l) => l,
            Err(e) => {
                eprintln!("{e}");
                std::process::exit(1);
            }
        };
        let t_load = t.elapsed();
        let t = Instant::now();
        let table = EdgeTable::new(loaded.mesh.n_vertices(), loaded.mesh.faces());
        let t_table = t.elapsed();
        let t = Instant::now();
        let report = check(&loaded.mesh);
        let t_check = t.elapsed();
        let t = Instant::now();
        let oriented = orient(&loaded.mesh).map(|(m, _)| m.n_faces());
        let t_orient = t.elapsed();
        println!(
            "load {t_load:?} edge_table {t_table:?} ({} edges) check {t_check:?} orient {t_orient:?} sphere={} {:?}",
            table.n_edges(),
            report.is_sphere_topology,
            oriented.is_ok()
        );
    }
}
