//! A closed triangle mesh stored as one cyclic neighbour list per vertex, the
//! form the progressive method edits: a half-edge collapse (Hoppe 1996) and
//! its exact undo touch only the lists of the collapsed vertex's closed ring.
//!
//! `rings[i]` lists the neighbours of `i` counter-clockwise seen from outside,
//! so the faces around `i` are `(i, r[j], r[j + 1])` with the mesh's own
//! orientation. A removed vertex keeps an empty list.

use rayon::prelude::*;

use spherify_mesh::edge_table::vertex_ranges;

use crate::memory_budget::{filled, reserved, ResourceError};

/// Spare slots in each list of [`RingMesh::for_collapses`].
pub const COLLAPSE_ROOM: usize = 4;

/// A half-edge collapse `u -> v`: `u` is removed and its faces become a fan
/// around `v`. `ring` is `u`'s ring at that moment, rotated to start at `v`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Collapse {
    pub u: u32,
    pub v: u32,
    pub ring: Vec<u32>,
}

#[derive(Debug, Clone)]
pub struct RingMesh {
    pub rings: Vec<Vec<u32>>,
    /// Vertices not removed.
    pub n_alive: usize,
}

impl RingMesh {
    /// Builds the rings of a closed, consistently oriented manifold mesh (what
    /// [`crate::GenusZeroMesh`] guarantees). Its large buffers are allocated
    /// fallibly ([`crate::memory_budget`]).
    ///
    /// # Errors
    /// [`ResourceError::Allocation`] when the system refuses their memory.
    pub fn from_faces(n_vertices: usize, faces: &[[u32; 3]]) -> Result<RingMesh, ResourceError> {
        // Each range of vertices (in parallel) gathers its vertices' corners
        // by a scan of all faces in order, so every list is built from the
        // same corners in the same order for any number of ranges (issue 27:
        // the serial gathering was 0.08 s of the 1M-vertex default map).
        RingMesh::by_ranges(n_vertices, faces, &vertex_ranges(n_vertices, faces.len()), 0)
    }

    /// [`RingMesh::from_faces`] with room for [`COLLAPSE_ROOM`] more
    /// neighbours in every list, for the hierarchy's collapses: a collapse
    /// `u -> v` grows `v`'s list by the degree of `u` less three, which made
    /// the serial collapse loop reallocate nearly every target's list (issue
    /// 27, 1M-vertex `tentacles`: that loop 0.38 s without the room, 0.33 s
    /// with it). The room costs 16 bytes a vertex while the rings live; they
    /// are let go before the final sweeps' references, the method's peak.
    ///
    /// # Errors
    /// As [`RingMesh::from_faces`].
    pub fn for_collapses(n_vertices: usize, faces: &[[u32; 3]]) -> Result<RingMesh, ResourceError> {
        let ranges = vertex_ranges(n_vertices, faces.len());
        RingMesh::by_ranges(n_vertices, faces, &ranges, COLLAPSE_ROOM)
    }

    /// [`RingMesh::from_faces`] with the vertex ranges given (they must cover
    /// the vertices in order), each list with room for `room` more.
    fn by_ranges(
        n_vertices: usize,
        faces: &[[u32; 3]],
        ranges: &[std::ops::Range<usize>],
        room: usize,
    ) -> Result<RingMesh, ResourceError> {
        let parts: Vec<Vec<Vec<u32>>> = ranges
            .par_iter()
            .map(|range| rings_of_range(faces, range, room))
            .collect::<Result<_, _>>()?;
        let mut rings = reserved(n_vertices, "the progressive method's rings")?;
        for part in parts {
            rings.extend(part);
        }
        Ok(RingMesh { rings, n_alive: n_vertices })
    }

    pub fn is_alive(&self, v: u32) -> bool {
        !self.rings[v as usize].is_empty()
    }

    #[cfg(test)]
    /// The faces of the current mesh, each once (listed at its smallest vertex).
    pub fn faces(&self) -> Vec<[u32; 3]> {
        faces_of_rings(&self.rings)
    }

    /// Whether `u -> v` keeps the mesh a closed manifold: the link condition
    /// (the only common neighbours of `u` and `v` are the two vertices
    /// opposite the edge; Dey et al. 1999) on a mesh larger than a
    /// tetrahedron, and no neighbour left with fewer than three neighbours.
    pub fn can_collapse(&self, u: u32, v: u32) -> bool {
        let (ru, rv) = (&self.rings[u as usize], &self.rings[v as usize]);
        if self.n_alive <= 4 || ru.len() < 3 {
            return false;
        }
        let Some(at) = ru.iter().position(|&x| x == v) else { return false };
        let k = ru.len();
        let (left, right) = (ru[(at + 1) % k], ru[(at + k - 1) % k]);
        if self.rings[left as usize].len() < 4 || self.rings[right as usize].len() < 4 {
            return false;
        }
        ru.iter().all(|&w| w == v || w == left || w == right || !rv.contains(&w))
    }

    /// Collapses `u` into `v` (which must pass [`RingMesh::can_collapse`]).
    pub fn collapse(&mut self, u: u32, v: u32) -> Collapse {
        let mut ring = std::mem::take(&mut self.rings[u as usize]);
        let at = ring.iter().position(|&x| x == v).expect("v is a neighbour of u");
        ring.rotate_left(at);
        let k = ring.len() - 1; // ring = [v, r1, ..., rk]
        let (r1, rk) = (ring[1], ring[k]);
        // v: [.., r1, u, rk, ..] becomes [.., r1, r2, .., r(k-1), rk, ..].
        let rv = &mut self.rings[v as usize];
        let pos = rv.iter().position(|&x| x == u).expect("u is a neighbour of v");
        rv.splice(pos..=pos, ring[2..k].iter().copied());
        // r1: [.., r2, u, v, ..] and rk: [.., v, u, r(k-1), ..] lose u.
        for r in [r1, rk] {
            let list = &mut self.rings[r as usize];
            let pos = list.iter().position(|&x| x == u).expect("u is a neighbour");
            list.remove(pos);
        }
        // The others see v where they saw u.
        for &r in &ring[2..k] {
            for x in self.rings[r as usize].iter_mut() {
                if *x == u {
                    *x = v;
                }
            }
        }
        self.n_alive -= 1;
        Collapse { u, v, ring }
    }

    /// Asks for the memory that undoing `collapse` will read, in the stage
    /// `stage` of three, each a few steps after the one before so that it
    /// reads what that one fetched: the collapse's ring (0), its vertices'
    /// headers (1), their lists (2). Only a hint: it changes nothing.
    pub fn prefetch_undo(&self, collapse: &Collapse, stage: u8) {
        if stage == 0 {
            prefetch(collapse.ring.as_ptr());
            return;
        }
        for &r in &collapse.ring {
            if stage == 1 {
                prefetch(&self.rings[r as usize]);
            } else {
                prefetch(self.rings[r as usize].as_ptr());
            }
        }
    }

    /// Undoes `collapse`, which must be the last collapse not yet undone among
    /// those touching its closed ring.
    #[cfg(test)]
    pub fn undo(&mut self, collapse: &Collapse) {
        self.undo_taking(&mut collapse.clone());
    }

    /// [`RingMesh::undo`] that moves the collapse's ring into the mesh
    /// instead of copying it, leaving `collapse.ring` empty: the insertion
    /// undoes each collapse once, and a copy was one allocation per vertex
    /// of the mesh (and one more block to free when the hierarchy goes).
    pub fn undo_taking(&mut self, collapse: &mut Collapse) {
        self.undo_around(collapse);
        self.rings[collapse.u as usize] = std::mem::take(&mut collapse.ring);
    }

    /// [`RingMesh::undo`] but for `u`'s own list, which stays empty until the
    /// caller moves the collapse's ring there: the edits of the lists of
    /// `u`'s ring, which read the collapse's ring and leave it as it is.
    pub fn undo_around(&mut self, collapse: &Collapse) {
        let (u, v) = (collapse.u, collapse.v);
        let ring = &collapse.ring;
        let k = ring.len() - 1;
        let (r1, rk) = (ring[1], ring[k]);
        for &r in &ring[2..k] {
            for x in self.rings[r as usize].iter_mut() {
                if *x == v {
                    *x = u;
                }
            }
        }
        // r1 regains u before v; rk after v.
        let list = &mut self.rings[r1 as usize];
        let pos = list.iter().position(|&x| x == v).expect("v is a neighbour of r1");
        list.insert(pos, u);
        let list = &mut self.rings[rk as usize];
        let pos = list.iter().position(|&x| x == v).expect("v is a neighbour of rk");
        list.insert(pos + 1, u);
        // v: the run strictly between r1 and rk becomes u.
        let rv = &mut self.rings[v as usize];
        let start = rv.iter().position(|&x| x == r1).expect("r1 is a neighbour of v");
        rv.rotate_left(start);
        let end = rv.iter().position(|&x| x == rk).expect("rk is a neighbour of v");
        rv.splice(1..end, [u]);
        self.n_alive += 1;
    }
}

/// The faces of a rotation system (face (v, r[j], r[j + 1]) for each ring
/// `r` of a vertex `v`), each once: listed at its smallest vertex.
pub(crate) fn faces_of_rings(rings: &[Vec<u32>]) -> Vec<[u32; 3]> {
    let mut faces = Vec::new();
    for (i, ring) in rings.iter().enumerate() {
        let i = i as u32;
        for j in 0..ring.len() {
            let (b, c) = (ring[j], ring[(j + 1) % ring.len()]);
            if i < b && i < c {
                faces.push([i, b, c]);
            }
        }
    }
    faces
}

/// How far ahead in a list of collapses the serial loops over them (the
/// hierarchy's collapse loop, the insertion's undo loop) ask for memory:
/// they visit vertices all over the mesh, in the order of their scores, and
/// waited on main memory for nearly every one (their rings, their
/// neighbours' rings). The loops themselves are serial, as each collapse is
/// decided on (and each undo applied to) the mesh the earlier ones left.
pub const AHEAD: usize = 16;

/// A hint to load the cache line of `at` (no-op on other architectures).
#[inline(always)]
pub fn prefetch<T>(at: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch reads nothing into the program and never faults,
    // whatever the address; SSE, which it needs, is part of x86_64.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(at.cast::<i8>());
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = at;
}

/// The rings of the vertices in `range`, from the faces in order: for vertex
/// a, face (a, b, c) says "c follows b" in a's ring.
fn rings_of_range(
    faces: &[[u32; 3]],
    range: &std::ops::Range<usize>,
    room: usize,
) -> Result<Vec<Vec<u32>>, ResourceError> {
    let mut start = filled(range.len() + 1, 0u32, "the progressive method's ring offsets")?;
    let mine = |x: u32| range.contains(&(x as usize));
    for f in faces {
        for &a in f.iter().filter(|&&a| mine(a)) {
            start[a as usize - range.start + 1] += 1;
        }
    }
    for i in 0..range.len() {
        start[i + 1] += start[i];
    }
    let mut fill = filled(range.len(), 0u32, "the progressive method's ring offsets")?;
    fill.copy_from_slice(&start[..range.len()]);
    let mut pairs =
        filled(start[range.len()] as usize, [0u32; 2], "the progressive method's ring corners")?;
    for &[a, b, c] in faces {
        for (x, y, z) in [(a, b, c), (b, c, a), (c, a, b)] {
            if mine(x) {
                let slot = &mut fill[x as usize - range.start];
                pairs[*slot as usize] = [y, z];
                *slot += 1;
            }
        }
    }
    let mut rings = reserved(range.len(), "the progressive method's rings")?;
    // Each vertex's list is ordered on its own: in parallel.
    rings.par_extend((0..range.len()).into_par_iter().map(|i| {
        let own = &pairs[start[i] as usize..start[i + 1] as usize];
        let mut ring = Vec::with_capacity(own.len() + room);
        if let Some(&[first, _]) = own.first() {
            let mut current = first;
            for _ in 0..own.len() {
                ring.push(current);
                match own.iter().find(|p| p[0] == current) {
                    Some(p) => current = p[1],
                    None => break,
                }
            }
        }
        ring
    }));
    Ok(rings)
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::edge_table::split_ranges;
    use spherify_mesh::lcg::Lcg;
    use spherify_mesh::solids::icosphere;

    fn sorted_faces(m: &RingMesh) -> Vec<[u32; 3]> {
        let mut f: Vec<[u32; 3]> = m.faces();
        f.sort_unstable();
        f
    }

    fn canonical(faces: &[[u32; 3]]) -> Vec<[u32; 3]> {
        let mut out: Vec<[u32; 3]> = faces
            .iter()
            .map(|&[a, b, c]| {
                let m = a.min(b).min(c);
                if m == a {
                    [a, b, c]
                } else if m == b {
                    [b, c, a]
                } else {
                    [c, a, b]
                }
            })
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn every_split_into_vertex_ranges_gives_the_same_rings() {
        // Renumbered at random, so that each range holds vertices from all
        // over the sphere.
        let mesh = icosphere(3);
        let n = mesh.positions().len();
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut rng = Lcg::new(11);
        for i in (1..n).rev() {
            order.swap(i, rng.below(i + 1));
        }
        let faces: Vec<[u32; 3]> =
            mesh.faces().iter().map(|f| f.map(|v| order[v as usize])).collect();
        let one = RingMesh::by_ranges(n, &faces, &split_ranges(n, 1), 0).unwrap();
        assert_eq!(canonical(&one.faces()), canonical(&faces));
        for parts in [2, 3, 5, n] {
            let split = RingMesh::by_ranges(n, &faces, &split_ranges(n, parts), 0).unwrap();
            assert_eq!(split.rings, one.rings, "{parts} ranges");
        }
        // The hierarchy's rings: the same lists, each with its room.
        let roomy = RingMesh::for_collapses(n, &faces).unwrap();
        assert_eq!(roomy.rings, one.rings);
        assert!(roomy.rings.iter().all(|r| r.capacity() >= r.len() + COLLAPSE_ROOM));
    }

    #[test]
    fn rings_give_back_the_faces_and_collapses_undo_exactly() {
        let mesh = icosphere(2);
        let mut rm = RingMesh::from_faces(mesh.positions().len(), mesh.faces()).unwrap();
        assert_eq!(sorted_faces(&rm), canonical(mesh.faces()));
        let mut done = Vec::new();
        let mut snapshots = vec![sorted_faces(&rm)];
        'outer: while rm.n_alive > 4 {
            for u in 0..rm.rings.len() as u32 {
                if !rm.is_alive(u) {
                    continue;
                }
                for &v in &rm.rings[u as usize].clone() {
                    if rm.can_collapse(u, v) {
                        done.push(rm.collapse(u, v));
                        let faces = sorted_faces(&rm);
                        // Euler: F = 2V - 4 for a closed genus-0 mesh.
                        assert_eq!(faces.len(), 2 * rm.n_alive - 4);
                        snapshots.push(faces);
                        continue 'outer;
                    }
                }
            }
            panic!("no contractible edge with {} vertices", rm.n_alive);
        }
        assert_eq!(rm.n_alive, 4);
        while let Some(c) = done.pop() {
            snapshots.pop();
            rm.undo(&c);
            assert_eq!(&sorted_faces(&rm), snapshots.last().unwrap());
        }
        assert_eq!(sorted_faces(&rm), canonical(mesh.faces()));
    }
}
