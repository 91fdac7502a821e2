//! load + check + orient on the largest corpus mesh (igea.ply, when
//! ../shared/meshes is present) and on a generated 1M-face sphere.
//! The side-by-side comparison with trimesh is benches/load_check_orient.py.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use spherify_mesh::io::{self, FileFormat, VertexAttributes, WriteOptions};
use spherify_mesh::{orient::orient, validate::check, Mesh};
use std::path::PathBuf;

/// A latitude-longitude sphere with `rings` x `segments` quads split into
/// triangles plus two polar fans: 2 * rings * segments faces.
fn uv_sphere(rings: usize, segments: usize) -> Mesh {
    let mut positions = vec![[0.0, 0.0, 1.0]];
    for i in 1..rings {
        let theta = std::f64::consts::PI * i as f64 / rings as f64;
        for j in 0..segments {
            let phi = 2.0 * std::f64::consts::PI * j as f64 / segments as f64;
            positions.push([theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()]);
        }
    }
    positions.push([0.0, 0.0, -1.0]);
    let south = (positions.len() - 1) as u32;
    let at = |i: usize, j: usize| (1 + (i - 1) * segments + j % segments) as u32;
    let mut faces = Vec::new();
    for j in 0..segments {
        faces.push([0, at(1, j), at(1, j + 1)]);
        faces.push([south, at(rings - 1, j + 1), at(rings - 1, j)]);
    }
    for i in 1..rings - 1 {
        for j in 0..segments {
            faces.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            faces.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh::new(positions, faces).expect("the generated sphere is valid")
}

fn pipeline(c: &mut Criterion) {
    let mut group = c.benchmark_group("load_check_orient");
    group.sample_size(10);
    let corpus = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes/igea.ply");
    if corpus.exists() {
        let bytes = std::fs::read(&corpus).expect("igea.ply is readable");
        let loaded = io::read(&corpus).expect("igea.ply loads");
        group.throughput(Throughput::Elements(loaded.mesh.n_faces() as u64));
        group.bench_function("igea.ply", |b| {
            b.iter(|| {
                let loaded = io::read_bytes(&bytes, FileFormat::Ply, "igea.ply").expect("loads");
                let report = check(&loaded.mesh);
                let (oriented, _) = orient(&loaded.mesh).expect("orientable");
                (report.is_sphere_topology, oriented.n_faces())
            })
        });
    } else {
        eprintln!("../shared/meshes is absent: skipping the igea.ply bench");
    }
    let sphere = uv_sphere(708, 708); // 1,002,528 faces
    let bytes = io::write_bytes(
        &sphere,
        &VertexAttributes::default(),
        FileFormat::Ply,
        &WriteOptions::default(),
        "sphere.ply",
    )
    .expect("writes");
    group.throughput(Throughput::Elements(sphere.n_faces() as u64));
    group.bench_function("uv_sphere_1M_faces.ply", |b| {
        b.iter(|| {
            let loaded = io::read_bytes(&bytes, FileFormat::Ply, "sphere.ply").expect("loads");
            let report = check(&loaded.mesh);
            let (oriented, _) = orient(&loaded.mesh).expect("orientable");
            (report.is_sphere_topology, oriented.n_faces())
        })
    });
    group.finish();
}

criterion_group!(benches, pipeline);
criterion_main!(benches);
