//! Maps meshes with the progressive authalic method and prints, per mesh,
//! the certificate and the mean |log area ratio| measured two ways: on the
//! chord triangles (as `sp.quality` and `benches/progressive.py` do) and on
//! the spherical triangles (the definition; the two differ where
//! triangles are large on the sphere, on coarse meshes).
//!
//!     cargo run --release -p spherify-sphere --example authalic_corpus -- a.obj b.ply

use std::path::Path;
use std::time::Instant;

use spherify_mesh::vec3::triangle_area;
use spherify_sphere::distortion_energy::Energy;
use spherify_sphere::metrics::{face_measures, quality};
use spherify_sphere::progressive::{progressive, ProgressiveParams};
use spherify_sphere::validity::signed_area;
use spherify_sphere::{check_sphere, GenusZeroMesh};

fn mean_abs(values: impl Iterator<Item = f64>) -> f64 {
    let (sum, count) =
        values.filter(|x| !x.is_nan()).fold((0.0, 0usize), |s, x| (s.0 + x.abs(), s.1 + 1));
    sum / count.max(1) as f64
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    println!("| mesh | V | valid | min area | angle | log area (chord) | log area (spherical) | stretch | s |");
    println!("|---|---|---|---|---|---|---|---|---|");
    for path in std::env::args().skip(1) {
        let loaded = spherify_mesh::io::read(Path::new(&path))?;
        let mesh = GenusZeroMesh::new(loaded.mesh)?;
        let started = Instant::now();
        let params = ProgressiveParams::for_energy(Energy::Authalic);
        let e = progressive(&mesh, &params, &|_, _| true)?;
        let seconds = started.elapsed().as_secs_f64();
        eprintln!("{path}: {}", e.message);
        let p = &e.points;
        let report = check_sphere(mesh.faces(), p);
        let q = quality(mesh.mesh(), p)?;
        let chord = mean_abs(face_measures(mesh.mesh(), p)?.area_log.into_iter());
        let s = mesh.positions();
        let surface: Vec<f64> = mesh
            .faces()
            .iter()
            .map(|&[a, b, c]| triangle_area(s[a as usize], s[b as usize], s[c as usize]))
            .collect();
        let total: f64 = surface.iter().sum();
        let spherical = mean_abs(mesh.faces().iter().zip(&surface).map(|(&[a, b, c], &area)| {
            let e = signed_area(p[a as usize], p[b as usize], p[c as usize]);
            if area > 0.0 {
                (e / (4.0 * std::f64::consts::PI) / (area / total)).ln()
            } else {
                f64::NAN
            }
        }));
        let name = Path::new(&path).file_stem().map(|s| s.to_string_lossy().into_owned());
        println!(
            "| {} | {} | {} | {:.1e} | {:.1} | {:.3} | {:.3} | {:.3} | {:.2} |",
            name.unwrap_or_default(),
            mesh.n_vertices(),
            if report.valid { "valid" } else { "NOT valid" },
            report.min_area_ratio,
            q.angle_mean_deg,
            chord,
            spherical,
            q.stretch_l2,
            seconds
        );
    }
    Ok(())
}
