//! The connectivity of the cut disk (thesis 6.3) read from the sphere mesh's
//! half-edges, without building the disk's own.
//!
//! Cutting along the path relabels the corners of the faces on one side of
//! it (each inner path vertex p_i gets a duplicate N + k - i there) and
//! changes nothing else: every face keeps its index and its corner order.
//! So a vertex off the path has the same faces around it in the disk as on
//! the sphere, in the same cyclic order, and only the labels of its
//! neighbours on the path may differ (the label in the disk is the one in
//! the face the half-edge belongs to). What [`spherify_mesh::HalfEdgeMesh`]
//! adds is where each rotation starts: its first outgoing half-edge of a
//! vertex is the one of the lowest edge in (smaller, larger endpoint) order,
//! which is the edge to the neighbour with the smallest label; a boundary
//! vertex starts at its boundary half-edge. Reading rotations this way gives
//! the rows of the rectangle system, and the pole fans, in exactly the
//! order the disk's half-edges give them (the module tests compare both),
//! and saves building a second half-edge structure of the whole mesh
//! (0.2 s at a million vertices).

use spherify_mesh::cut::CutMesh;
use spherify_mesh::HalfEdgeMesh;

/// The cut disk's rotations, read from the sphere mesh's half-edges.
pub(crate) struct CutRotations<'a> {
    /// Half-edges of the sphere mesh that was cut.
    he: &'a HalfEdgeMesh,
    sphere_faces: &'a [[u32; 3]],
    cut_faces: &'a [[u32; 3]],
    /// Sphere vertices that have a duplicate in the disk (the inner path
    /// vertices): only their labels can differ between faces.
    duplicated: Vec<bool>,
}

impl<'a> CutRotations<'a> {
    /// `he` and `sphere_faces`: the sphere mesh; `cut`: that mesh cut open
    /// along `cut.path` (`spherify_mesh::cut::cut_open_with`).
    pub(crate) fn new(
        he: &'a HalfEdgeMesh,
        sphere_faces: &'a [[u32; 3]],
        cut: &'a CutMesh,
    ) -> CutRotations<'a> {
        let mut duplicated = vec![false; he.n_vertices()];
        for &v in &cut.original[he.n_vertices().min(cut.original.len())..] {
            if let Some(slot) = duplicated.get_mut(v as usize) {
                *slot = true;
            }
        }
        CutRotations { he, sphere_faces, cut_faces: cut.mesh.faces(), duplicated }
    }

    /// The disk's label of the head of sphere half-edge `h`: the corner of
    /// `h`'s face that stood for it.
    #[inline]
    fn head_label(&self, h: u32) -> u32 {
        let j = self.he.head(h);
        if !self.duplicated[j as usize] {
            return j;
        }
        let Some(f) = self.he.face(h) else { return j };
        let (sphere, cut) = (self.sphere_faces[f as usize], self.cut_faces[f as usize]);
        (0..3).find(|&c| sphere[c] == j).map_or(j, |c| cut[c])
    }

    /// Appends the neighbours of vertex `i` in the disk, each with weight 1,
    /// in the order of the disk's rotation of `i`. `i` must be a sphere
    /// vertex off the cut path (every free vertex of the rectangle system).
    pub(crate) fn uniform_edges(&self, i: u32, out: &mut Vec<(u32, f64)>) {
        let start = out.len();
        out.extend(self.he.rotation(i).map(|h| (self.head_label(h), 1.0)));
        // The disk's rotation starts at the neighbour with the smallest label.
        let first = (start..out.len()).min_by_key(|&e| out[e].0).unwrap_or(start);
        out[start..].rotate_left(first - start);
    }

    /// The disk's `vertex_ring` of a vertex on the cut that has no
    /// duplicate (a pole): its neighbours counter-clockwise from one side of
    /// the cut to the other, both copies of its path neighbour included.
    /// `None` if its faces in the disk do not form one fan.
    pub(crate) fn boundary_ring(&self, v: u32) -> Option<Vec<u32>> {
        // Each face (v, a, b), counter-clockwise, links a to b in the ring.
        let mut links: Vec<(u32, u32)> = Vec::new();
        for h in self.he.rotation(v) {
            let face = self.cut_faces[self.he.face(h)? as usize];
            let c = face.iter().position(|&x| x == v)?;
            links.push((face[(c + 1) % 3], face[(c + 2) % 3]));
        }
        links.sort_unstable();
        let follows = |a: u32| {
            let i = links.partition_point(|&(x, _)| x < a);
            links.get(i).filter(|&&(x, _)| x == a).map(|&(_, b)| b)
        };
        let mut heads: Vec<u32> = links.iter().map(|&(_, b)| b).collect();
        heads.sort_unstable();
        // The ring starts at the one vertex that follows no other.
        let mut starts = links.iter().map(|&(a, _)| a).filter(|a| heads.binary_search(a).is_err());
        let (first, None) = (starts.next()?, starts.next()) else { return None };
        let mut ring = vec![first];
        while let Some(b) = follows(ring[ring.len() - 1]) {
            if ring.len() > links.len() {
                return None;
            }
            ring.push(b);
        }
        (ring.len() == links.len() + 1).then_some(ring)
    }
}

#[cfg(test)]
mod tests;
