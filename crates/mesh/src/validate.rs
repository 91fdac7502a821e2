//! Mesh validation: everything that stands between a file and a sphere map.
//!
//! Thesis Prop. 2.8 says a triangle mesh is homeomorphic to the sphere when it is
//! 2-manifold, its graph is connected and V - E + F = 2. Real files break those
//! conditions in many ways at once, so [`check`] reports all of them, each with the
//! offending indices (capped at [`LIST_CAP`], with the total count) and one
//! readable sentence in `problems`. Everything is O(F log d) (d: largest degree):
//! the edge table is a bucket sort, the rest is linear passes and union-find.

use crate::edge_table::{corner_endpoints, EdgeTable, NONE};
use crate::mesh::Mesh;
use crate::predicates::collinear3;
use crate::volume::component_volumes;

/// How many offending indices a report lists per kind of problem.
pub const LIST_CAP: usize = 100;

/// A list of offending items, capped at [`LIST_CAP`], with the true total.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Capped<T> {
    pub items: Vec<T>,
    pub total: usize,
}

impl<T> Capped<T> {
    fn push(&mut self, item: T) {
        if self.items.len() < LIST_CAP {
            self.items.push(item);
        }
        self.total += 1;
    }

    pub fn is_empty(&self) -> bool {
        self.total == 0
    }
}

impl<T: std::fmt::Debug> Capped<T> {
    fn examples(&self) -> String {
        let shown: Vec<String> = self.items.iter().take(5).map(|x| format!("{x:?}")).collect();
        let more = if self.total > shown.len() { ", ..." } else { "" };
        format!("{}{}", shown.join(", "), more)
    }
}

/// Everything [`check`] finds out about a triangle mesh.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeshReport {
    pub n_vertices: usize,
    pub n_faces: usize,
    pub n_edges: usize,
    /// Closed, connected, manifold, genus 0, every vertex used, no face repeating a vertex.
    pub is_sphere_topology: bool,
    /// Every edge has exactly two faces.
    pub closed: bool,
    /// No non-manifold edge and no non-manifold vertex.
    pub manifold: bool,
    pub connected: bool,
    /// Connected components of the surface (unreferenced vertices not counted).
    pub n_components: usize,
    /// V - E + F with V the referenced vertices (thesis Cor. 2.7, eq. 2.20).
    pub euler_characteristic: i64,
    /// Total genus from eq. 2.20 with boundaries, when the mesh is manifold.
    pub genus: Option<i64>,
    /// Edges with one face.
    pub boundary_edges: usize,
    /// Boundary loops as vertex cycles in the direction of their faces.
    pub boundary_loops: Capped<Vec<u32>>,
    /// Edges with more than two faces.
    pub nonmanifold_edges: Capped<[u32; 2]>,
    /// Vertices whose faces form more than one fan.
    pub nonmanifold_vertices: Capped<u32>,
    /// Faces that repeat a vertex or have exactly zero area (exact predicate).
    pub degenerate_faces: Capped<u32>,
    /// Faces with the same vertex set as an earlier face (either orientation).
    pub duplicate_faces: Capped<u32>,
    pub unreferenced_vertices: Capped<u32>,
    /// Vertices with a NaN or infinite coordinate (only from [`check_raw`]).
    pub non_finite_vertices: Capped<u32>,
    /// Faces with an index outside 0..n_vertices (only from [`check_raw`]).
    pub out_of_range_faces: Capped<u32>,
    /// Every two-face edge is used once in each direction.
    pub consistently_oriented: bool,
    /// Two-face edges used twice in the same direction.
    pub inconsistent_edges: Capped<[u32; 2]>,
    /// Closed, consistently oriented and every component encloses positive volume.
    pub outward: bool,
    /// Signed enclosed volume (meaningful when closed and consistently oriented).
    pub signed_volume: f64,
    /// One sentence per problem found; empty for a clean genus-0 mesh.
    pub problems: Vec<String>,
    /// Informational remarks (e.g. from the file reader: polygons triangulated).
    pub notes: Vec<String>,
}

/// Validates a mesh whose arrays are already known to be finite and in range.
pub fn check(mesh: &Mesh) -> MeshReport {
    let (table, elements) =
        rayon::join(|| mesh.edge_table(), || element_pass(mesh.positions(), mesh.faces()));
    check_faces(mesh.positions(), mesh.faces(), table, elements)
}

/// Validates raw arrays that may hold non-finite coordinates and out-of-range or
/// negative indices: those are reported, the bad faces are left out of the
/// topological analysis, and face ids in the report refer to the input.
pub fn check_raw(positions: &[[f64; 3]], faces: &[[i64; 3]]) -> MeshReport {
    let n = positions.len() as i64;
    let mut kept = Vec::with_capacity(faces.len());
    let mut kept_ids = Vec::with_capacity(faces.len());
    let mut out_of_range = Capped::default();
    for (f, c) in faces.iter().enumerate() {
        if c.iter().all(|&i| (0..n).contains(&i)) {
            kept.push([c[0] as u32, c[1] as u32, c[2] as u32]);
            kept_ids.push(f as u32);
        } else {
            out_of_range.push(f as u32);
        }
    }
    let (table, elements) =
        rayon::join(|| EdgeTable::new(positions.len(), &kept), || element_pass(positions, &kept));
    let mut report = check_faces(positions, &kept, &table, elements);
    let remap =
        |list: &mut Capped<u32>| list.items.iter_mut().for_each(|f| *f = kept_ids[*f as usize]);
    remap(&mut report.degenerate_faces);
    remap(&mut report.duplicate_faces);
    report.n_faces = faces.len();
    if !out_of_range.is_empty() {
        report.problems.insert(
            0,
            format!(
                "{} faces refer to vertices outside 0..{} (faces {})",
                out_of_range.total,
                positions.len(),
                out_of_range.examples()
            ),
        );
        report.is_sphere_topology = false;
    }
    report.out_of_range_faces = out_of_range;
    report
}

/// The analysis behind [`check`] and [`check_raw`]; the edge table and the
/// element pass are independent, so callers compute them in parallel.
fn check_faces(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    table: &EdgeTable,
    elements: ElementFindings,
) -> MeshReport {
    let n = positions.len();
    let mut r = MeshReport { n_vertices: n, n_faces: faces.len(), ..Default::default() };
    r.n_edges = table.n_edges();
    let ((edges, nonmanifold_vertices), (n_components, volumes)) = rayon::join(
        || rayon::join(|| edge_pass(faces, table), || count_fans(n, faces, table)),
        || {
            let (count, component_of) = components(n, faces, &elements.referenced);
            (count, component_volumes(positions, faces, &component_of, count, None))
        },
    );
    r.unreferenced_vertices = elements.unreferenced;
    r.non_finite_vertices = elements.non_finite;
    r.degenerate_faces = elements.degenerate;
    r.boundary_edges = edges.boundary_corners.len();
    r.inconsistent_edges = edges.inconsistent;
    r.nonmanifold_edges = edges.nonmanifold;
    r.duplicate_faces = edges.duplicates;
    r.nonmanifold_vertices = nonmanifold_vertices;
    r.n_components = n_components;
    r.connected = n_components == 1;
    r.closed = r.boundary_edges == 0 && r.nonmanifold_edges.is_empty();
    r.consistently_oriented = r.inconsistent_edges.is_empty() && r.nonmanifold_edges.is_empty();
    r.manifold = r.nonmanifold_edges.is_empty() && r.nonmanifold_vertices.is_empty();
    r.boundary_loops = boundary_loops(n, faces, &edges.boundary_corners);

    let n_referenced = elements.referenced.iter().filter(|&&x| x).count() as i64;
    r.euler_characteristic = n_referenced - r.n_edges as i64 + faces.len() as i64;
    let twice_genus =
        2 * r.n_components as i64 - r.boundary_loops.total as i64 - r.euler_characteristic;
    let repeated_index = elements.repeated_index;
    if r.manifold && repeated_index == 0 && twice_genus >= 0 && twice_genus % 2 == 0 {
        r.genus = Some(twice_genus / 2);
    }
    r.signed_volume = volumes.total();
    r.outward = r.closed && r.consistently_oriented && volumes.normalized.iter().all(|&v| v > 0.0);
    r.is_sphere_topology = r.closed
        && r.manifold
        && r.n_components == 1
        && r.euler_characteristic == 2
        && repeated_index == 0
        && r.unreferenced_vertices.is_empty();
    describe_problems(&mut r, repeated_index);
    r
}

/// Per-vertex and per-face findings that need no connectivity.
struct ElementFindings {
    referenced: Vec<bool>,
    unreferenced: Capped<u32>,
    non_finite: Capped<u32>,
    degenerate: Capped<u32>,
    repeated_index: usize,
}

fn element_pass(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> ElementFindings {
    let mut out = ElementFindings {
        referenced: vec![false; positions.len()],
        unreferenced: Capped::default(),
        non_finite: Capped::default(),
        degenerate: Capped::default(),
        repeated_index: 0,
    };
    for (fi, &[a, b, c]) in faces.iter().enumerate() {
        out.referenced[a as usize] = true;
        out.referenced[b as usize] = true;
        out.referenced[c as usize] = true;
        let repeats = a == b || b == c || a == c;
        out.repeated_index += repeats as usize;
        if repeats
            || collinear3(positions[a as usize], positions[b as usize], positions[c as usize])
        {
            out.degenerate.push(fi as u32);
        }
    }
    for (v, p) in positions.iter().enumerate() {
        if !out.referenced[v] {
            out.unreferenced.push(v as u32);
        }
        if p.iter().any(|x| !x.is_finite()) {
            out.non_finite.push(v as u32);
        }
    }
    out
}

/// What the edge groups say: boundary, non-manifold and inconsistent edges,
/// and duplicate faces (which share all three edges with their twin).
struct EdgeFindings {
    boundary_corners: Vec<u32>,
    inconsistent: Capped<[u32; 2]>,
    nonmanifold: Capped<[u32; 2]>,
    duplicates: Capped<u32>,
}

fn edge_pass(faces: &[[u32; 3]], table: &EdgeTable) -> EdgeFindings {
    let mut out = EdgeFindings {
        boundary_corners: Vec::new(),
        inconsistent: Capped::default(),
        nonmanifold: Capped::default(),
        duplicates: Capped::default(),
    };
    // Third vertex of the face of corner c.
    let apex = |c: u32| faces[(c / 3) as usize][((c + 2) % 3) as usize];
    for e in 0..table.n_edges() {
        let group = table.group(e);
        let (a, b) = corner_endpoints(faces, group[0]);
        let key = [a.min(b), a.max(b)];
        match *group {
            [c] => out.boundary_corners.push(c),
            // The common case, kept tight: two faces, c < d.
            [c, d] => {
                if corner_endpoints(faces, d) == (a, b) {
                    out.inconsistent.push(key);
                }
                if apex(c) == apex(d) && first_edge_of_face(faces, d) {
                    out.duplicates.push(d / 3);
                }
            }
            _ => {
                out.nonmanifold.push(key);
                for (i, &c) in group.iter().enumerate() {
                    let f = (c / 3) as usize;
                    let earlier = group[..i].iter().any(|&d| {
                        let g = (d / 3) as usize;
                        g < f && sorted(faces[g]) == sorted(faces[f])
                    });
                    // A face is a duplicate once, not once per shared edge: count
                    // it on the edge where its corner is the lowest-numbered one.
                    if earlier && first_edge_of_face(faces, c) {
                        out.duplicates.push(f as u32);
                    }
                }
            }
        }
    }
    out.duplicates.items.sort_unstable();
    out
}

fn sorted(mut f: [u32; 3]) -> [u32; 3] {
    f.sort_unstable();
    f
}

/// True for the corner of a face whose undirected edge has the smallest key, so
/// that per-face findings made while scanning edges are counted once.
fn first_edge_of_face(faces: &[[u32; 3]], c: u32) -> bool {
    let f = faces[(c / 3) as usize];
    let key = |k: usize| {
        let (a, b) = (f[k], f[(k + 1) % 3]);
        (a.min(b), a.max(b))
    };
    let mine = key((c % 3) as usize);
    (0..3).filter(|&k| f[k] != f[(k + 1) % 3]).all(|k| key(k) >= mine)
}

/// Non-manifold vertices: the faces around a vertex form fans, joined across every
/// edge they share; more than one fan means two surface sheets touch at the vertex
/// (thesis 2.3, condition (b)). Union-find on corners.
fn count_fans(n: usize, faces: &[[u32; 3]], table: &EdgeTable) -> Capped<u32> {
    // Corner slot 3f+k stands for face f at vertex faces[f][k].
    let mut parent: Vec<u32> = (0..faces.len() as u32 * 3).collect();
    let mut fans = vec![0i64; n];
    for (f, face) in faces.iter().enumerate() {
        for (k, &v) in face.iter().enumerate() {
            fans[v as usize] += 1;
            // A face repeating a vertex is one piece of surface at that vertex.
            for j in 0..k {
                if face[j] == v && union(&mut parent, (3 * f + j) as u32, (3 * f + k) as u32) {
                    fans[v as usize] -= 1;
                }
            }
        }
    }
    // Corner c runs from slot c's vertex to the next slot's vertex in its face.
    let slot_at = |c: u32, v: u32| {
        if corner_endpoints(faces, c).0 == v {
            c
        } else {
            c - c % 3 + (c + 1) % 3
        }
    };
    for e in 0..table.n_edges() {
        let group = table.group(e);
        let (a, b) = corner_endpoints(faces, group[0]);
        for &c in &group[1..] {
            for v in [a, b] {
                if union(&mut parent, slot_at(group[0], v), slot_at(c, v)) {
                    fans[v as usize] -= 1;
                }
            }
        }
    }
    let mut nonmanifold = Capped::default();
    for (v, &count) in fans.iter().enumerate() {
        if count > 1 {
            nonmanifold.push(v as u32);
        }
    }
    nonmanifold
}

fn find(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let up = parent[parent[x as usize] as usize];
        parent[x as usize] = up;
        x = up;
    }
    x
}

/// Joins the sets of `a` and `b`; true when they were apart.
fn union(parent: &mut [u32], a: u32, b: u32) -> bool {
    let (ra, rb) = (find(parent, a), find(parent, b));
    if ra == rb {
        return false;
    }
    // Smaller root wins: deterministic, and good enough with path halving.
    let (lo, hi) = (ra.min(rb), ra.max(rb));
    parent[hi as usize] = lo;
    true
}

/// Connected components of the referenced vertices: their number and each
/// face's component.
fn components(n: usize, faces: &[[u32; 3]], referenced: &[bool]) -> (usize, Vec<u32>) {
    let mut parent: Vec<u32> = (0..n as u32).collect();
    for &[a, b, c] in faces {
        union(&mut parent, a, b);
        union(&mut parent, b, c);
    }
    let mut label = vec![NONE; n];
    let mut count = 0u32;
    for v in 0..n {
        if referenced[v] {
            let root = find(&mut parent, v as u32) as usize;
            if label[root] == NONE {
                label[root] = count;
                count += 1;
            }
        }
    }
    let component_of = faces.iter().map(|f| label[find(&mut parent, f[0]) as usize]).collect();
    (count as usize, component_of)
}

/// Boundary loops: chains of one-face edges, followed in their face's direction.
fn boundary_loops(n: usize, faces: &[[u32; 3]], boundary_corners: &[u32]) -> Capped<Vec<u32>> {
    let mut loops = Capped::default();
    if boundary_corners.is_empty() {
        return loops;
    }
    // Outgoing boundary corners per vertex (CSR); more than one only at
    // non-manifold vertices, where any continuation closes some loop.
    let mut offsets = vec![0usize; n + 1];
    for &c in boundary_corners {
        offsets[corner_endpoints(faces, c).0 as usize + 1] += 1;
    }
    for v in 0..n {
        offsets[v + 1] += offsets[v];
    }
    let mut fill = offsets.clone();
    let mut outgoing = vec![0u32; boundary_corners.len()];
    for &c in boundary_corners {
        let tail = corner_endpoints(faces, c).0 as usize;
        outgoing[fill[tail]] = c;
        fill[tail] += 1;
    }
    let mut next_unused = offsets.clone();
    for start in 0..n {
        while next_unused[start] < offsets[start + 1] {
            let mut cycle = Vec::new();
            let mut v = start;
            while next_unused[v] < offsets[v + 1] {
                let c = outgoing[next_unused[v]];
                next_unused[v] += 1;
                cycle.push(v as u32);
                v = corner_endpoints(faces, c).1 as usize;
                if v == start {
                    break;
                }
            }
            loops.push(cycle);
        }
    }
    loops
}

/// "1 face" / "3 faces", "1 vertex" / "2 vertices".
fn count(n: usize, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

/// "1 face is" / "3 faces are".
fn count_is(n: usize, singular: &str, plural: &str) -> String {
    format!("{} {}", count(n, singular, plural), if n == 1 { "is" } else { "are" })
}

fn describe_problems(r: &mut MeshReport, repeated_index: usize) {
    let mut p = Vec::new();
    if !r.non_finite_vertices.is_empty() {
        p.push(format!(
            "{} a NaN or infinite coordinate: vertices {}",
            count(r.non_finite_vertices.total, "vertex has", "vertices have"),
            r.non_finite_vertices.examples()
        ));
    }
    if !r.nonmanifold_edges.is_empty() {
        p.push(format!(
            "{} non-manifold (shared by more than two faces): {}",
            count_is(r.nonmanifold_edges.total, "edge", "edges"),
            r.nonmanifold_edges.examples()
        ));
    }
    if !r.nonmanifold_vertices.is_empty() {
        p.push(format!(
            "{} non-manifold (their faces form more than one fan): vertices {}",
            count_is(r.nonmanifold_vertices.total, "vertex", "vertices"),
            r.nonmanifold_vertices.examples()
        ));
    }
    if r.boundary_edges > 0 {
        p.push(format!(
            "the mesh is open: {} in {} (holes)",
            count(r.boundary_edges, "boundary edge", "boundary edges"),
            count(r.boundary_loops.total, "boundary loop", "boundary loops")
        ));
    }
    if r.n_components > 1 {
        p.push(format!("the mesh has {} connected components", r.n_components));
    }
    if r.manifold
        && r.euler_characteristic != 2 * r.n_components as i64 - r.boundary_loops.total as i64
    {
        let genus = r.genus.map(|g| format!("genus {g}: ")).unwrap_or_default();
        p.push(format!(
            "{genus}Euler characteristic V - E + F = {} (a sphere has 2)",
            r.euler_characteristic
        ));
    }
    if !r.degenerate_faces.is_empty() {
        p.push(format!(
            "{} degenerate ({} repeating a vertex, {} with exactly zero area): faces {}",
            count_is(r.degenerate_faces.total, "face", "faces"),
            repeated_index,
            r.degenerate_faces.total - repeated_index,
            r.degenerate_faces.examples()
        ));
    }
    if !r.duplicate_faces.is_empty() {
        p.push(format!(
            "{} the vertices of an earlier face: faces {}",
            count(r.duplicate_faces.total, "face repeats", "faces repeat"),
            r.duplicate_faces.examples()
        ));
    }
    if !r.unreferenced_vertices.is_empty() {
        p.push(format!(
            "{} not used by any face: vertices {}",
            count_is(r.unreferenced_vertices.total, "vertex", "vertices"),
            r.unreferenced_vertices.examples()
        ));
    }
    if !r.inconsistent_edges.is_empty() {
        p.push(format!(
            "the faces are not consistently oriented: {} used twice in the same direction, e.g. {} (orient fixes this)",
            count_is(r.inconsistent_edges.total, "edge", "edges"),
            r.inconsistent_edges.examples()
        ));
    } else if r.closed && r.consistently_oriented && !r.outward {
        p.push(format!(
            "the faces point inward (signed volume {:.6e}); orient fixes this",
            r.signed_volume
        ));
    }
    r.problems = p;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mesh(p: Vec<[f64; 3]>, f: Vec<[u32; 3]>) -> Mesh {
        Mesh::new(p, f).unwrap()
    }

    fn tetra_positions() -> Vec<[f64; 3]> {
        vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
    }

    const TETRA: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

    #[test]
    fn clean_tetrahedron() {
        let r = check(&mesh(tetra_positions(), TETRA.to_vec()));
        assert!(r.is_sphere_topology && r.closed && r.manifold && r.connected);
        assert!(r.consistently_oriented && r.outward, "{r:?}");
        assert_eq!((r.euler_characteristic, r.genus, r.n_edges), (2, Some(0), 6));
        assert!(r.problems.is_empty(), "{:?}", r.problems);
        assert!((r.signed_volume - 1.0 / 6.0).abs() < 1e-12);
    }

    #[test]
    fn inward_and_inconsistent() {
        let inward: Vec<[u32; 3]> = TETRA.iter().map(|&[a, b, c]| [a, c, b]).collect();
        let r = check(&mesh(tetra_positions(), inward));
        assert!(r.is_sphere_topology && r.consistently_oriented && !r.outward);
        assert_eq!(r.problems.len(), 1);
        let mut one_flipped = TETRA.to_vec();
        one_flipped[3] = [1, 3, 2];
        let r = check(&mesh(tetra_positions(), one_flipped));
        assert!(!r.consistently_oriented && !r.outward);
        assert_eq!(r.inconsistent_edges.total, 3);
    }

    #[test]
    fn open_disconnected_and_unreferenced() {
        let mut p = tetra_positions();
        p.push([5.0, 5.0, 5.0]);
        let r = check(&mesh(p, TETRA[..3].to_vec()));
        assert!(!r.closed && !r.is_sphere_topology);
        assert_eq!(r.boundary_edges, 3);
        assert_eq!(r.boundary_loops.total, 1);
        assert_eq!(r.boundary_loops.items[0].len(), 3);
        assert_eq!(r.unreferenced_vertices.items, vec![4]);
        assert_eq!(r.genus, Some(0));
        let mut p = tetra_positions();
        p.extend(tetra_positions().iter().map(|q| [q[0] + 3.0, q[1], q[2]]));
        let mut f = TETRA.to_vec();
        f.extend(TETRA.iter().map(|&[a, b, c]| [a + 4, b + 4, c + 4]));
        let r = check(&mesh(p, f));
        assert_eq!((r.n_components, r.connected, r.euler_characteristic), (2, false, 4));
        assert!(!r.is_sphere_topology && r.outward);
    }

    #[test]
    fn non_manifold_edge_and_vertex() {
        // Two tetrahedra sharing edge (0, 1).
        let p = vec![
            [0.0; 3],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
            [0.0, -1.0, 0.0],
            [0.0, 0.0, -1.0],
        ];
        let f = vec![
            [0, 2, 1],
            [0, 1, 3],
            [0, 3, 2],
            [1, 2, 3],
            [0, 1, 4],
            [0, 5, 1],
            [0, 4, 5],
            [1, 5, 4],
        ];
        let r = check(&mesh(p, f));
        assert_eq!(r.nonmanifold_edges.items, vec![[0, 1]]);
        assert!(r.nonmanifold_vertices.is_empty());
        assert!(!r.manifold && !r.is_sphere_topology && r.genus.is_none());
        // Two tetrahedra sharing vertex 0.
        let mut p = tetra_positions();
        p.extend([[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]]);
        let mut f = TETRA.to_vec();
        f.extend([[0, 5, 4], [0, 4, 6], [0, 6, 5], [4, 5, 6]]);
        let r = check(&mesh(p, f));
        assert_eq!(r.nonmanifold_vertices.items, vec![0]);
        assert!(r.nonmanifold_edges.is_empty() && r.closed && !r.manifold);
        assert_eq!(r.euler_characteristic, 3);
    }

    #[test]
    fn degenerate_duplicate_and_raw_problems() {
        let mut p = tetra_positions();
        p.push([0.5, 0.5, 0.0]); // on the segment from vertex 1 to vertex 2
        let mut f = TETRA.to_vec();
        f.push([1, 4, 2]);
        f.push([0, 1, 3]);
        f.push([0, 0, 3]);
        let r = check(&mesh(p.clone(), f));
        assert_eq!(r.degenerate_faces.items, vec![4, 6]);
        assert_eq!(r.duplicate_faces.items, vec![5]);
        let mut raw_p = p;
        raw_p[2][0] = f64::NAN;
        let raw_f = vec![[0i64, 2, 1], [0, 1, 7], [0, 1, 3], [0, 3, 2], [1, 2, 3], [-1, 0, 1]];
        let r = check_raw(&raw_p, &raw_f);
        assert_eq!(r.out_of_range_faces.items, vec![1, 5]);
        assert_eq!(r.non_finite_vertices.items, vec![2]);
        assert!(!r.is_sphere_topology);
        assert_eq!(r.n_faces, 6);
    }
}
