//! The rotations read from the sphere's half-edges against those of the cut
//! disk's own half-edges, on meshes whose labels are shuffled so that the
//! smallest neighbour of a vertex is often one of the duplicates.
use super::*;
use crate::methods::theta_phi::cut_path::cut_path;
use crate::methods::theta_phi::pole_fans::rectangle_boundary;
use spherify_mesh::cut::cut_open_with;
use spherify_mesh::dijkstra::EdgeWeights;
use spherify_mesh::lcg::Lcg;
use spherify_mesh::{solids, Mesh};
use spherify_sparse::tutte::FixedSystem;

/// `mesh` with its vertices renumbered by a random permutation.
fn shuffled(mesh: &Mesh, rng: &mut Lcg) -> Mesh {
    let n = mesh.n_vertices();
    let mut order: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        order.swap(i, (rng.next_f64() * (i + 1) as f64) as usize % (i + 1));
    }
    let mut positions = vec![[0.0; 3]; n];
    for (v, &new) in order.iter().enumerate() {
        positions[new as usize] = mesh.positions()[v];
    }
    let faces = mesh.faces().iter().map(|f| f.map(|v| order[v as usize])).collect();
    Mesh::new(positions, faces).unwrap()
}

fn meshes() -> Vec<Mesh> {
    let mut rng = Lcg::new(31);
    let mut out = vec![solids::tetrahedron(), solids::octahedron(), solids::icosphere(2)];
    for base in [solids::icosphere(3), solids::bumpy(3), solids::octasphere(3)] {
        out.push(shuffled(&base, &mut rng));
        out.push(base);
    }
    out
}

#[test]
fn rows_and_pole_rings_equal_the_cut_disks_own() {
    let mut rng = Lcg::new(5);
    let mut checked = 0;
    for mesh in meshes() {
        let he = HalfEdgeMesh::new(&mesh).unwrap();
        let graph = he.adjacency();
        let n = mesh.n_vertices();
        for _ in 0..6 {
            let north = (rng.next_f64() * n as f64) as u32 % n as u32;
            let south = (rng.next_f64() * n as f64) as u32 % n as u32;
            if north == south {
                continue;
            }
            let lengths = EdgeWeights::Length(mesh.positions());
            let Some(path) = cut_path(&graph, north, south, lengths) else { continue };
            let cut = cut_open_with(&mesh, &he, &path).unwrap();
            let cut_he = HalfEdgeMesh::new(&cut.mesh).unwrap();
            let rotations = CutRotations::new(&he, mesh.faces(), &cut);
            let on_path: Vec<bool> = (0..n as u32).map(|v| path.contains(&v)).collect();
            let mut edges = Vec::new();
            for v in (0..n as u32).filter(|&v| !on_path[v as usize]) {
                edges.clear();
                rotations.uniform_edges(v, &mut edges);
                let expected: Vec<(u32, f64)> =
                    cut_he.rotation(v).map(|h| (cut_he.head(h), 1.0)).collect();
                assert_eq!(edges, expected, "vertex {v}");
            }
            for pole in [path[0], path[path.len() - 1]] {
                assert_eq!(rotations.boundary_ring(pole), Some(cut_he.vertex_ring(pole)));
            }
            // The whole system, bit for bit.
            let k = path.len() - 2;
            let fixed = rectangle_boundary(&cut.boundary, k, n);
            let ones = vec![1.0; cut_he.n_half_edges()];
            let expected = FixedSystem::assemble(&cut_he, &ones, &fixed).unwrap();
            let system =
                FixedSystem::assemble_rows(&fixed, |i, out| rotations.uniform_edges(i, out))
                    .unwrap();
            assert_eq!(system.matrix, expected.matrix);
            assert_eq!(system.free, expected.free);
            for (a, b) in system.rhs.iter().zip(&expected.rhs) {
                assert!(a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()));
            }
            checked += 1;
        }
    }
    assert!(checked > 40, "only {checked} cuts checked");
}
