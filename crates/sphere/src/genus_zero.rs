//! The one door every spherical method comes in by (STYLE 5): a closed,
//! connected, manifold genus-0 mesh whose faces are consistently oriented and
//! face outward (thesis Prop. 2.8, Alg. 2.9), with its half-edge connectivity
//! built once, when a method first asks for it.
//!
//! [`GenusZeroMesh::new`] runs the validation of `spherify_mesh::validate`
//! and repairs the orientation when the faces are inconsistent or face
//! inward. The methods of [`crate::embed`] take the result and never check
//! topology again. The half-edges wait for [`GenusZeroMesh::half_edges`]: the
//! default (progressive) method never reads them, and they are 84 bytes per
//! vertex that it would otherwise hold through its whole run (issue 27).

use std::sync::{Arc, OnceLock};

use spherify_mesh::mesh::built_once;
use spherify_mesh::orient::orient;
use spherify_mesh::{validate, HalfEdgeMesh, Mesh, TopologyError, TopologyProblem};

/// A mesh every spherical method accepts. Cheap to share: the positions and
/// faces are behind an `Arc`, so wrapping a mesh that needs no reorientation
/// copies nothing.
#[derive(Debug, Clone)]
pub struct GenusZeroMesh {
    mesh: Arc<Mesh>,
    half_edges: OnceLock<HalfEdgeMesh>,
    neighbourhoods: OnceLock<Arc<Neighbourhoods>>,
    reoriented_faces: usize,
}

/// The vertex rings (counter-clockwise seen from outside) and their greedy
/// colour classes, as the flip-free moves take them. Made on the first
/// `move_towards` or `pull_towards` of a mesh and kept with it: registration's
/// warp calls them 13 times on one mesh, and each call made them anew.
#[derive(Debug)]
pub struct Neighbourhoods {
    pub rings: Vec<Vec<u32>>,
    pub classes: Vec<Vec<u32>>,
}

impl GenusZeroMesh {
    /// Validates `mesh` and orients it consistently outward. O(F log d).
    ///
    /// # Errors
    /// [`TopologyError`] (with the full validation report) when the mesh is not
    /// closed, connected, manifold and of genus 0.
    pub fn new(mesh: impl Into<Arc<Mesh>>) -> Result<GenusZeroMesh, TopologyError> {
        let mesh = mesh.into();
        let report = validate::check(&mesh);
        if !report.is_sphere_topology {
            return Err(TopologyError {
                problem: TopologyProblem::NotSphere,
                report: Box::new(report),
            });
        }
        let (mesh, reoriented_faces) = if report.consistently_oriented && report.outward {
            (mesh, 0)
        } else {
            let (oriented, info) = orient(&mesh)?;
            (Arc::new(oriented), info.flipped_faces)
        };
        Ok(GenusZeroMesh {
            mesh,
            half_edges: OnceLock::new(),
            neighbourhoods: OnceLock::new(),
            reoriented_faces,
        })
    }

    /// The oriented mesh: faces counter-clockwise seen from outside.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The oriented mesh, shared.
    pub fn shared_mesh(&self) -> Arc<Mesh> {
        Arc::clone(&self.mesh)
    }

    /// The half-edge connectivity, built on the first call. O(F log d).
    ///
    /// # Panics
    /// Never on a mesh that [`GenusZeroMesh::new`] accepted: the validation
    /// checks every requirement `HalfEdgeMesh::new` has (closed, manifold at
    /// edges and vertices, no repeated or unreferenced vertex) and the
    /// orientation is made consistent before.
    ///
    /// Through [`built_once`]: the build reads the edge table, which is made
    /// in parallel.
    pub fn half_edges(&self) -> &HalfEdgeMesh {
        built_once(&self.half_edges, || {
            HalfEdgeMesh::new(&self.mesh).expect("a validated, oriented genus-0 mesh")
        })
    }

    /// Where the [`Neighbourhoods`] are kept once made
    /// (`methods::progressive::neighbourhoods_of` makes them).
    pub(crate) fn neighbourhoods_cell(&self) -> &OnceLock<Arc<Neighbourhoods>> {
        &self.neighbourhoods
    }

    pub fn positions(&self) -> &[[f64; 3]] {
        self.mesh.positions()
    }

    pub fn faces(&self) -> &[[u32; 3]] {
        self.mesh.faces()
    }

    pub fn n_vertices(&self) -> usize {
        self.mesh.n_vertices()
    }

    pub fn n_faces(&self) -> usize {
        self.mesh.n_faces()
    }

    /// Faces whose corner order [`GenusZeroMesh::new`] reversed (0 when the
    /// mesh was already consistent and outward).
    pub fn reoriented_faces(&self) -> usize {
        self.reoriented_faces
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::{OCTAHEDRON_FACES, OCTAHEDRON_POSITIONS};

    fn octahedron() -> Mesh {
        Mesh::new(OCTAHEDRON_POSITIONS.to_vec(), OCTAHEDRON_FACES.to_vec()).unwrap()
    }

    #[test]
    fn an_outward_mesh_is_shared_not_copied() {
        let mesh = Arc::new(octahedron());
        let g = GenusZeroMesh::new(Arc::clone(&mesh)).unwrap();
        assert!(Arc::ptr_eq(&mesh, &g.shared_mesh()));
        assert_eq!(g.reoriented_faces(), 0);
        assert_eq!(g.half_edges().n_faces(), 8);
    }

    #[test]
    fn an_inward_mesh_is_turned_outward() {
        let faces: Vec<[u32; 3]> = OCTAHEDRON_FACES.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let g =
            GenusZeroMesh::new(Mesh::new(OCTAHEDRON_POSITIONS.to_vec(), faces).unwrap()).unwrap();
        assert_eq!(g.reoriented_faces(), 8);
        assert_eq!(g.faces(), octahedron().faces());
    }

    /// `half_edges` builds on demand and panics if the build fails: every
    /// mesh `new` accepts must be one `HalfEdgeMesh::new` accepts.
    #[test]
    fn every_accepted_mesh_has_half_edges() {
        let p = OCTAHEDRON_POSITIONS.to_vec();
        let f = OCTAHEDRON_FACES.to_vec();
        let flip = |[a, b, c]: [u32; 3]| [a, c, b];
        let mut one_flipped = f.clone();
        one_flipped[3] = flip(one_flipped[3]);
        let half_flipped: Vec<[u32; 3]> =
            f.iter().enumerate().map(|(i, &t)| if i % 2 == 0 { flip(t) } else { t }).collect();
        let mut duplicated = f.clone();
        duplicated.push(f[0]);
        let mut extra_vertex = p.clone();
        extra_vertex.push([2.0, 2.0, 2.0]);
        // Two octahedra sharing vertex 0: a pinched (non-manifold) vertex.
        let mut pinched_p = p.clone();
        pinched_p.extend(p[1..].iter().map(|q| [q[0] + 3.0, q[1], q[2]]));
        let mut pinched_f = f.clone();
        pinched_f
            .extend(f.iter().map(|t| t.map(|v| if v == 0 { 0 } else { v + p.len() as u32 - 1 })));
        let cases = [
            (p.clone(), f.clone(), true),
            (p.clone(), one_flipped, true),
            (p.clone(), half_flipped, true),
            (p.clone(), duplicated, false),
            (extra_vertex, f.clone(), false),
            (pinched_p, pinched_f, false),
        ];
        for (i, (positions, faces, accepted)) in cases.into_iter().enumerate() {
            let n_faces = faces.len();
            let Ok(mesh) = Mesh::new(positions, faces) else {
                assert!(!accepted, "case {i}");
                continue;
            };
            match GenusZeroMesh::new(mesh) {
                Ok(g) => {
                    assert!(accepted, "case {i} accepted");
                    assert!(HalfEdgeMesh::new(g.mesh()).is_ok(), "case {i}");
                    assert_eq!(g.half_edges().n_faces(), n_faces, "case {i}");
                }
                Err(_) => assert!(!accepted, "case {i} refused"),
            }
        }
    }

    #[test]
    fn an_open_mesh_is_refused_with_its_report() {
        let mut faces = OCTAHEDRON_FACES.to_vec();
        faces.pop();
        let err = GenusZeroMesh::new(Mesh::new(OCTAHEDRON_POSITIONS.to_vec(), faces).unwrap())
            .unwrap_err();
        assert_eq!(err.problem, TopologyProblem::NotSphere);
        assert!(!err.report.closed);
    }
}
