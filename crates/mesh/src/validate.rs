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
use crate::weld::coincident_vertices;

mod report;

pub use report::{Capped, MeshReport, LIST_CAP};

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
    report.add_out_of_range(out_of_range, positions.len());
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
    let seam_copies = if edges.boundary_corners.is_empty() {
        0
    } else {
        let mut ends: Vec<u32> = edges
            .boundary_corners
            .iter()
            .flat_map(|&c| {
                let (a, b) = corner_endpoints(faces, c);
                [a, b]
            })
            .collect();
        ends.sort_unstable();
        ends.dedup();
        coincident_vertices(positions, &ends)
    };
    r.signed_volume = volumes.total();
    r.outward = r.closed && r.consistently_oriented && volumes.normalized.iter().all(|&v| v > 0.0);
    r.is_sphere_topology = r.closed
        && r.manifold
        && r.n_components == 1
        && r.euler_characteristic == 2
        && repeated_index == 0
        && r.unreferenced_vertices.is_empty();
    r.describe_problems(repeated_index, seam_copies);
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
            for (j, &u) in face[..k].iter().enumerate() {
                if u == v && union(&mut parent, (3 * f + j) as u32, (3 * f + k) as u32) {
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
    for v in (0..n).filter(|&v| referenced[v]) {
        let root = find(&mut parent, v as u32) as usize;
        if label[root] == NONE {
            label[root] = count;
            count += 1;
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
