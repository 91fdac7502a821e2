//! The progressive method (thesis 9.3.3) against theta-phi (ch. 6) on the same
//! meshes: a bumpy sphere (round, where theta-phi is at home) and a thin
//! helical tube (a long limb, where only the progressive map keeps its
//! triangles above double precision), at about 10k and 40k vertices. Compare
//! the ratio of the two on one machine in one run; absolute times depend on
//! the load. Ten samples each; about a minute on 2 cores.

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode};
use spherify_mesh::solids::{bumpy, helix};
use spherify_sphere::methods::progressive::{progressive, ProgressiveParams};
use spherify_sphere::methods::theta_phi::{theta_phi, ThetaPhiParams};
use spherify_sphere::GenusZeroMesh;
use std::hint::black_box;

fn bench(c: &mut Criterion) {
    let meshes = [
        ("bumpy-10k", bumpy(5)),
        ("bumpy-40k", bumpy(6)),
        ("helix-10k", helix(16, 640, 0.1, 3.0, 0.8)),
        ("helix-40k", helix(32, 1280, 0.1, 3.0, 0.8)),
    ];
    let mut group = c.benchmark_group("sphere-map");
    group.sample_size(10).sampling_mode(SamplingMode::Flat);
    for (name, mesh) in meshes {
        let mesh = GenusZeroMesh::new(mesh).expect("a closed genus-0 solid");
        let params = ProgressiveParams::default();
        group.bench_function(format!("progressive/{name}"), |b| {
            b.iter(|| black_box(progressive(&mesh, &params, &|_, _| true).expect("maps")))
        });
        let params = ThetaPhiParams::default();
        group.bench_function(format!("theta_phi/{name}"), |b| {
            b.iter(|| black_box(theta_phi(&mesh, &params).expect("maps")))
        });
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
