//! Orientation repair (thesis 2.4, Alg. 2.9), without the manual seed face.
//!
//! Alg. 2.9 propagates the orientation of a seed face f* that the user must know
//! to be correct. Here the seed is simply the lowest-numbered face of each
//! connected component: propagation across shared edges makes the component
//! consistent with it, and afterwards the sign of the enclosed volume tells
//! whether the whole component faces inward, in which case every face of it is
//! reversed. The result is a consistent, outward orientation with no user input.

use crate::edge_table::{corner_endpoints, NONE};
use crate::error::{TopologyError, TopologyProblem};
use crate::mesh::Mesh;
use crate::validate;
use crate::volume::component_volumes;

/// What [`orient`] changed.
#[derive(Debug, Clone, PartialEq)]
pub struct OrientInfo {
    /// Faces whose vertex order was reversed.
    pub flipped_faces: usize,
    /// Connected components found.
    pub components: usize,
    /// Closed components that faced inward as a whole and were turned outward.
    pub components_turned_outward: usize,
}

/// Returns the mesh with every face consistent with its neighbours and every
/// closed component enclosing positive volume. Open components are made
/// consistent but not turned (an open surface has no inside). Needs every edge
/// to have at most two faces and no face to repeat a vertex; a non-orientable
/// surface is reported with the face where propagation contradicted itself.
/// O(F log d).
///
/// The steps of Alg. 2.9 stay in one function, each commented: they share
/// the per-face flip flags and the partner table that propagation fills.
pub fn orient(mesh: &Mesh) -> Result<(Mesh, OrientInfo), TopologyError> {
    let faces = mesh.faces();
    let fail = |problem| TopologyError { problem, report: Box::new(validate::check(mesh)) };
    for (f, &[a, b, c]) in faces.iter().enumerate() {
        if a == b || b == c || a == c {
            return Err(fail(TopologyProblem::RepeatedIndex { face: f as u32 }));
        }
    }
    let table = mesh.edge_table();
    // partner[c]: the other corner on c's edge when the edge has two faces.
    let mut partner = vec![NONE; 3 * faces.len()];
    let mut closed_face = vec![true; faces.len()];
    for e in 0..table.n_edges() {
        match table.group(e) {
            [c] => closed_face[(*c / 3) as usize] = false,
            [c, d] => {
                partner[*c as usize] = *d;
                partner[*d as usize] = *c;
            }
            group => {
                let (a, b) = corner_endpoints(faces, group[0]);
                return Err(fail(TopologyProblem::NonManifoldEdge {
                    a: a.min(b),
                    b: a.max(b),
                    faces: group.len(),
                }));
            }
        }
    }

    // Propagation with a last-in-first-out list of faces, as in Alg. 2.9 step 4.
    let mut flip = vec![false; faces.len()];
    let mut component = vec![NONE; faces.len()];
    let mut n_components = 0u32;
    let mut stack = Vec::new();
    for seed in 0..faces.len() {
        if component[seed] != NONE {
            continue;
        }
        component[seed] = n_components;
        stack.push(seed as u32);
        while let Some(f) = stack.pop() {
            for k in 0..3 {
                let c = 3 * f + k;
                let d = partner[c as usize];
                if d == NONE {
                    continue;
                }
                let g = d / 3;
                // Same direction on the shared edge means opposite orientations.
                let same_direction = corner_endpoints(faces, c) == corner_endpoints(faces, d);
                let wanted = flip[f as usize] ^ same_direction;
                if component[g as usize] == NONE {
                    component[g as usize] = n_components;
                    flip[g as usize] = wanted;
                    stack.push(g);
                } else if flip[g as usize] != wanted {
                    return Err(fail(TopologyProblem::NotOrientable { face: g }));
                }
            }
        }
        n_components += 1;
    }

    // Turn inward-facing closed components outward (signed volume < 0).
    let volume =
        component_volumes(mesh.positions(), faces, &component, n_components as usize, Some(&flip));
    let mut closed = vec![true; n_components as usize];
    for (f, &c) in component.iter().enumerate() {
        closed[c as usize] &= closed_face[f];
    }
    let turn: Vec<bool> =
        volume.normalized.iter().zip(&closed).map(|(&v, &c)| c && v < 0.0).collect();
    for (f, fl) in flip.iter_mut().enumerate() {
        *fl ^= turn[component[f] as usize];
    }
    let info = OrientInfo {
        flipped_faces: flip.iter().filter(|&&x| x).count(),
        components: n_components as usize,
        components_turned_outward: turn.iter().filter(|&&x| x).count(),
    };
    // Already consistent and outward: keep the mesh (and its cached edge table).
    let oriented =
        if info.flipped_faces == 0 { mesh.clone() } else { mesh.with_flipped_faces(&flip) };
    Ok((oriented, info))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cube_like_octahedron(faces: Vec<[u32; 3]>) -> Mesh {
        Mesh::new(crate::solids::OCTAHEDRON_POSITIONS.to_vec(), faces).unwrap()
    }

    const OCTA: [[u32; 3]; 8] = crate::solids::OCTAHEDRON_FACES;

    #[test]
    fn repairs_random_flips_and_inward_meshes() {
        for mask in 0u32..256 {
            let faces: Vec<[u32; 3]> = OCTA
                .iter()
                .enumerate()
                .map(|(i, &[a, b, c])| if mask >> i & 1 == 1 { [a, c, b] } else { [a, b, c] })
                .collect();
            let (fixed, info) = orient(&cube_like_octahedron(faces)).unwrap();
            assert_eq!(fixed.faces(), &OCTA[..], "mask {mask}");
            assert_eq!(info.flipped_faces, mask.count_ones() as usize);
            let report = validate::check(&fixed);
            assert!(report.consistently_oriented && report.outward);
        }
    }

    #[test]
    fn tiny_and_huge_meshes_turn_outward() {
        for scale in [1e-120, 1e103] {
            let p: Vec<[f64; 3]> =
                crate::solids::OCTAHEDRON_POSITIONS.iter().map(|q| q.map(|x| x * scale)).collect();
            let inward: Vec<[u32; 3]> = OCTA.iter().map(|&[a, b, c]| [a, c, b]).collect();
            let (fixed, info) = orient(&Mesh::new(p, inward).unwrap()).unwrap();
            assert_eq!(info.components_turned_outward, 1, "scale {scale}");
            assert!(validate::check(&fixed).outward, "scale {scale}");
        }
    }
}
