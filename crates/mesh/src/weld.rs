//! Merging vertices that sit at exactly the same position.
//!
//! Exporters often split a closed surface along its texture seams: each side
//! of a seam gets its own copy of the seam's vertices, so that each copy can
//! carry its own texture coordinate. The file then describes an open surface
//! with holes along the seams, which no spherical map accepts, although
//! nothing is missing: the two sides meet exactly. [`weld`] merges such
//! copies (bitwise-equal coordinates; `-0.0` and `0.0` are one position, as
//! in the STL reader, which welds every file this way), and
//! [`coincident_vertices`] counts them, so that the report of an open mesh
//! can say that welding would close it.

use crate::mesh::Mesh;
use rayon::prelude::*;

/// A position as bits that compare equal exactly when the coordinates do.
fn key(p: &[f64; 3]) -> [u64; 3] {
    p.map(|x| if x == 0.0 { 0 } else { x.to_bits() })
}

/// A mesh after [`weld`], and where its vertices came from.
#[derive(Debug, Clone)]
pub struct Welded {
    pub mesh: Mesh,
    /// For each vertex of `mesh`, the input vertex it is: the first (smallest
    /// index) of the copies it merges. Increasing, so the vertices keep their
    /// order.
    pub kept: Vec<u32>,
}

/// `mesh` with every group of vertices at one position merged into the first
/// of them, faces renumbered. Faces are kept as they are, so a face with two
/// corners at one position repeats a vertex afterwards (the report calls it
/// degenerate). O(n log n), the sort in parallel.
pub fn weld(mesh: &Mesh) -> Welded {
    let positions = mesh.positions();
    let n = positions.len();
    let mut order: Vec<u32> = (0..n as u32).collect();
    order.par_sort_unstable_by_key(|&v| (key(&positions[v as usize]), v));
    // Each vertex's representative: the first vertex at its position (the
    // sort puts it first among its equals).
    let mut representative = vec![0u32; n];
    for group in order.chunk_by(|&a, &b| key(&positions[a as usize]) == key(&positions[b as usize]))
    {
        for &v in group {
            representative[v as usize] = group[0];
        }
    }
    let mut new_id = vec![u32::MAX; n];
    let mut kept = Vec::with_capacity(n);
    for v in 0..n {
        if representative[v] as usize == v {
            new_id[v] = kept.len() as u32;
            kept.push(v as u32);
        }
    }
    let welded_positions: Vec<[f64; 3]> = kept.iter().map(|&v| positions[v as usize]).collect();
    let faces: Vec<[u32; 3]> = mesh
        .faces()
        .iter()
        .map(|f| f.map(|v| new_id[representative[v as usize] as usize]))
        .collect();
    // The input was a valid Mesh: finite positions, faces in range and non-empty.
    let mesh = Mesh::new(welded_positions, faces).expect("welding keeps a mesh valid");
    Welded { mesh, kept }
}

/// How many of `vertices` share their exact position with another of them.
pub fn coincident_vertices(positions: &[[f64; 3]], vertices: &[u32]) -> usize {
    let mut keys: Vec<[u64; 3]> = vertices.iter().map(|&v| key(&positions[v as usize])).collect();
    keys.sort_unstable();
    keys.chunk_by(|a, b| a == b).filter(|group| group.len() > 1).map(<[_]>::len).sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solids;
    use crate::validate::check;

    /// The octahedron split along a seam: the four faces with x > 0 get
    /// their own copies of the vertices on the plane x = 0.
    fn split_octahedron() -> (Mesh, Mesh) {
        let closed = solids::octahedron();
        let mut positions = closed.positions().to_vec();
        let mut copies = std::collections::HashMap::new();
        let faces: Vec<[u32; 3]> = closed
            .faces()
            .iter()
            .map(|f| {
                let right = f.iter().any(|&v| closed.positions()[v as usize][0] > 0.0);
                f.map(|v| {
                    if right && closed.positions()[v as usize][0] == 0.0 {
                        *copies.entry(v).or_insert_with(|| {
                            positions.push(closed.positions()[v as usize]);
                            positions.len() as u32 - 1
                        })
                    } else {
                        v
                    }
                })
            })
            .collect();
        (closed, Mesh::new(positions, faces).unwrap())
    }

    #[test]
    fn a_seam_split_by_an_exporter_closes_again() {
        let (closed, split) = split_octahedron();
        let report = check(&split);
        assert!(!report.closed && report.boundary_edges > 0);
        assert!(report.problems.iter().any(|p| p.contains("sit exactly on another")), "{report:?}");
        let welded = weld(&split);
        assert_eq!(welded.mesh, closed);
        assert_eq!(welded.kept, (0..closed.n_vertices() as u32).collect::<Vec<_>>());
        assert!(check(&welded.mesh).is_sphere_topology);
    }

    #[test]
    fn signed_zeros_are_one_position_and_near_misses_are_not() {
        let positions = vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [-0.0, 0.0, -0.0],
            [1.0 + f64::EPSILON, 0.0, 0.0],
            [0.0, 1.0, 0.0],
        ];
        let mesh = Mesh::new(positions, vec![[0, 1, 4], [2, 3, 4]]).unwrap();
        let welded = weld(&mesh);
        assert_eq!(welded.kept, vec![0, 1, 3, 4]);
        assert_eq!(welded.mesh.faces(), &[[0, 1, 3], [0, 2, 3]]);
        assert_eq!(coincident_vertices(mesh.positions(), &[0, 1, 2, 3, 4]), 2);
        assert_eq!(coincident_vertices(mesh.positions(), &[1, 3]), 0);
    }

    #[test]
    fn a_mesh_without_copies_is_unchanged() {
        let mesh = solids::octahedron();
        let welded = weld(&mesh);
        assert_eq!(welded.mesh, mesh);
        assert_eq!(welded.kept.len(), mesh.n_vertices());
    }
}
