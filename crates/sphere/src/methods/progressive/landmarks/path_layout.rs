//! A landmark-exact map built constructively, for sets the flip-free drag
//! cannot reach (issue 23): Kraevoy and Sheffer's "Matchmaker" (2003), with
//! the path tracing of Praun, Sweldens and Schröder, "Consistent mesh
//! parameterizations" (2001).
//!
//! 1. The targets are triangulated on the sphere: their convex hull is the
//!    spherical Delaunay triangulation T. When the hull does not hold the
//!    origin well inside (k < 4, or a set in one hemisphere), auxiliary
//!    landmarks are added: free vertices, pinned at octahedron directions far
//!    from every target. They are not the caller's landmarks and move freely
//!    afterwards.
//! 2. T's edges are traced on the mesh as vertex-disjoint shortest paths
//!    (Dijkstra on edge lengths), a spanning tree first, then the rest, each
//!    leaving and entering its landmarks in the sector T's cyclic order asks
//!    for (read from the mesh's rotation system: pure combinatorics). After
//!    each path every edge that joins two path vertices without being a path
//!    edge is split (Praun et al. 2001, section 3.3): free space stays
//!    connected, every sector keeps a free vertex, and no edge ends up joining
//!    two vertices of one side of a patch.
//! 3. Each T-triangle's patch is a disk bounded by three paths. The flat
//!    facet of the hull is the gnomonic image of its spherical triangle: a
//!    path's vertices go on the facet's straight side (by arc length along the
//!    path), the interior by a Tutte embedding with uniform weights (one
//!    linear system for all patches: a free vertex has neighbours in its own
//!    patch only), and every point is normalised. With a convex boundary, no
//!    dividing edge and positive weights the planar map is one-to-one
//!    (Floater 2003, "One-to-one piecewise linear mappings over
//!    triangulations"); radial projection keeps the sign of det[a, b, c]
//!    (each facet's plane keeps the origin on its inner side), and the facets
//!    tile the sphere, so the map is a GC-embedding in exact arithmetic; the
//!    caller certifies the stored doubles.
//!
//! Edge splits append vertices (the input's ids keep their numbers); each
//! vertex is recorded as a convex combination of at most three vertices of
//! one input face, so the refined mesh lies on the input surface.

use std::cmp::Reverse;
use std::collections::{BinaryHeap, HashSet};

use spherify_mesh::predicates::{det3_sign, Sign};
use spherify_mesh::vec3::{add, cross, dot, norm, scale, sub};
use spherify_sparse::tutte::FixedSystem;
use spherify_sparse::{solve, SolveParams, SolverKind};

use super::super::ring_mesh::faces_of_rings;
use super::{angle, Landmarks};
use crate::embedding::normalize;
use crate::error::SphereError;
use crate::memory_budget::{check, progressive_rate, Need};
use crate::methods::progressive::distortion_energy::Energy;

/// A vertex of the refined mesh as a point of the input surface: up to three
/// input vertices (unused slots have weight 0) and convex weights.
pub type Origin = [(u32, f64); 3];

/// What [`path_layout`] builds.
#[derive(Debug, Clone)]
pub struct PathLayout {
    /// Faces of the refined mesh, counter-clockwise seen from outside.
    pub faces: Vec<[u32; 3]>,
    /// Where each refined vertex lies on the input surface; the first
    /// `n_input` are the input's vertices themselves.
    pub origin: Vec<Origin>,
    /// One point on the unit sphere per refined vertex.
    pub points: Vec<[f64; 3]>,
    /// Auxiliary landmarks added to make T cover the sphere (vertex ids).
    pub auxiliary: Vec<u32>,
    /// The number of T's triangles (patches).
    pub patches: usize,
}

impl PathLayout {
    /// Refined vertex positions on the input surface `positions`.
    pub fn positions(&self, positions: &[[f64; 3]]) -> Vec<[f64; 3]> {
        self.origin.iter().map(|o| position(o, positions)).collect()
    }

    /// Per refined vertex: a face of the original mesh holding it and its
    /// barycentric coordinates in that face's corner order. `faces` are the
    /// original faces (any orientation: only their vertex sets are read);
    /// `earlier`, when the mesh laid out was itself refined from the
    /// original, is its own map back (a face and weights per vertex), which
    /// this one is composed with. Each refined triangle lies in one triangle
    /// of the mesh it refines, so the weights of a vertex always fall on the
    /// corners of one original face.
    pub fn barycentric(
        &self,
        faces: &[[u32; 3]],
        earlier: Option<(&[u32], &[[f64; 3]])>,
    ) -> (Vec<u32>, Vec<[f64; 3]>) {
        let n = faces.iter().flatten().map(|&v| v as usize + 1).max().unwrap_or(0);
        let mut around: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (f, face) in faces.iter().enumerate() {
            for &v in face {
                around[v as usize].push(f as u32);
            }
        }
        self.origin
            .iter()
            .map(|o| {
                let mut used: Vec<(u32, f64)> = Vec::with_capacity(3);
                let mut add_weight = |v: u32, w: f64| {
                    if w <= 0.0 {
                        return;
                    }
                    match used.iter_mut().find(|s| s.0 == v) {
                        Some(slot) => slot.1 += w,
                        None => used.push((v, w)),
                    }
                };
                for &(u, w) in o.iter().filter(|&&(_, w)| w > 0.0) {
                    match earlier {
                        None => add_weight(u, w),
                        Some((ef, eb)) => {
                            let corners = faces[ef[u as usize] as usize];
                            for j in 0..3 {
                                add_weight(corners[j], w * eb[u as usize][j]);
                            }
                        }
                    }
                }
                let face = around[used[0].0 as usize]
                    .iter()
                    .copied()
                    .find(|&f| used.iter().all(|(v, _)| faces[f as usize].contains(v)))
                    .unwrap_or(around[used[0].0 as usize][0]);
                let corners = faces[face as usize];
                let mut bary = [0.0; 3];
                for (v, w) in used {
                    if let Some(j) = corners.iter().position(|&c| c == v) {
                        bary[j] += w;
                    }
                }
                (face, bary)
            })
            .unzip()
    }
}

fn position(o: &Origin, positions: &[[f64; 3]]) -> [f64; 3] {
    let mut p = [0.0; 3];
    for &(v, w) in o {
        if w > 0.0 {
            p = add(p, scale(positions[v as usize], w));
        }
    }
    p
}

/// The error of a layout that could not be completed (it should not happen:
/// the module's invariants rule it out; it is reported rather than hidden).
fn failed(ids: Vec<usize>, reason: String) -> SphereError {
    SphereError::LandmarkConflict { ids, reason: format!("the path layout failed: {reason}") }
}

/// Smallest distance of the hull's facet planes from the origin accepted:
/// a facet nearer the centre would make its gnomonic image nearly flat.
const MIN_FACET_DEPTH: f64 = 1e-3;
/// Auxiliary directions closer than this (radians) to a target are left out.
const AUX_CLEARANCE: f64 = 0.35;
/// The refined mesh may hold at most this many times the input's vertices,
/// or the input's plus [`MAX_ADDED`], whichever is more; beyond, the set is
/// refused. Paths that must wind round each other to realise a badly
/// scrambled order split the corridors between them again at every pass:
/// 64 landmarks each moved 45 degrees its own way took a 1,744-vertex
/// `tentacles` to 9.6M vertices in 197 s and a 22k-vertex `sword` to 7.5M,
/// while a 1,002-vertex `bumpy_blob` needed 69k and the corpus's `blub`
/// (112 vertices) 93k. A map thousands of times finer than its mesh serves no
/// one, so the caller hears which landmarks are out of order instead.
const MAX_GROWTH: usize = 16;
const MAX_ADDED: usize = 200_000;

/// The convex hull of unit vectors as counter-clockwise triangles (outward
/// normals), or `None` when it is degenerate. Brute force over triples
/// (k is at most a few hundred); coplanar points (co-circular targets) are
/// fanned from their smallest index, so the triangulation is unique.
pub(crate) fn hull(p: &[[f64; 3]]) -> Option<Vec<[usize; 3]>> {
    let k = p.len();
    if k < 4 {
        return None;
    }
    let mut faces = Vec::new();
    for i in 0..k {
        for j in i + 1..k {
            for l in j + 1..k {
                let n = cross(sub(p[j], p[i]), sub(p[l], p[i]));
                let eps = 1e-12 * norm(n);
                let (mut pos, mut neg) = (false, false);
                let mut flat = Vec::new();
                for (m, &q) in p.iter().enumerate() {
                    if m == i || m == j || m == l {
                        continue;
                    }
                    let s = dot(n, sub(q, p[i]));
                    if s > eps {
                        pos = true;
                    } else if s < -eps {
                        neg = true;
                    } else {
                        flat.push(m);
                    }
                    if pos && neg {
                        break;
                    }
                }
                if pos && neg {
                    continue;
                }
                let outward = if pos { scale(n, -1.0) } else { n };
                if flat.is_empty() {
                    faces.push(if pos { [i, l, j] } else { [i, j, l] });
                    continue;
                }
                // A polygon of co-circular points: once, from its three smallest.
                if flat.iter().any(|&m| m < l) {
                    continue;
                }
                let mut poly = vec![i, j, l];
                poly.extend(flat);
                let c = poly.iter().fold([0.0; 3], |s, &m| add(s, p[m]));
                let (e1, e2) = {
                    let e1 = normalize(sub(p[poly[0]], scale(c, 1.0 / poly.len() as f64)))?;
                    (e1, cross(normalize(outward)?, e1))
                };
                poly.sort_by(|&a, &b| {
                    let (x, y) = (sub(p[a], c), sub(p[b], c));
                    dot(x, e2).atan2(dot(x, e1)).total_cmp(&dot(y, e2).atan2(dot(y, e1)))
                });
                let start = poly.iter().position(|&m| m == i)?;
                poly.rotate_left(start);
                for w in poly[1..].windows(2) {
                    faces.push([poly[0], w[0], w[1]]);
                }
            }
        }
    }
    // A triangulated sphere with every point a vertex has 2k - 4 faces.
    (faces.len() == 2 * k - 4).then_some(faces)
}

/// The hull's triangles when every facet keeps the origin well inside.
fn covering(p: &[[f64; 3]]) -> Option<Vec<[usize; 3]>> {
    let faces = hull(p)?;
    let deep = faces.iter().all(|&[a, b, c]| {
        let n = cross(sub(p[b], p[a]), sub(p[c], p[a]));
        normalize(n).is_some_and(|u| dot(u, p[a]) > MIN_FACET_DEPTH)
    });
    deep.then_some(faces)
}

/// A mesh as a rotation system: per vertex its neighbours counter-clockwise
/// (face (v, r[j], r[j + 1]) is counter-clockwise), so edge splits are a few
/// list edits.
struct Rotation {
    rings: Vec<Vec<u32>>,
    origin: Vec<Origin>,
    position: Vec<[f64; 3]>,
    /// The start map, refined with the mesh: a split vertex goes to the
    /// middle of its edge's arc, which keeps a valid map valid (both halves
    /// of each split triangle keep their orientation).
    sphere: Vec<[f64; 3]>,
}

impl Rotation {
    fn after(&self, u: u32, v: u32) -> u32 {
        let r = &self.rings[u as usize];
        let j = r.iter().position(|&x| x == v).expect("v is a neighbour of u");
        r[(j + 1) % r.len()]
    }

    /// Splits edge (u, v) at its midpoint; returns the new vertex.
    fn split(&mut self, u: u32, v: u32) -> u32 {
        let w = self.after(u, v); // face (u, v, w)
        let x = self.after(v, u); // face (v, u, x)
        let m = self.rings.len() as u32;
        let replace = |r: &mut Vec<u32>, old: u32, new: u32| {
            let j = r.iter().position(|&y| y == old).expect("neighbour");
            r[j] = new;
        };
        let insert_between = |r: &mut Vec<u32>, a: u32| {
            // m goes right after `a` (the face (., a, b) becomes two).
            let j = r.iter().position(|&y| y == a).expect("neighbour");
            r.insert(j + 1, m);
        };
        replace(&mut self.rings[u as usize], v, m);
        replace(&mut self.rings[v as usize], u, m);
        insert_between(&mut self.rings[w as usize], u);
        insert_between(&mut self.rings[x as usize], v);
        self.rings.push(vec![u, x, v, w]);
        self.origin.push(midpoint(&self.origin[u as usize], &self.origin[v as usize]));
        self.position.push(scale(add(self.position[u as usize], self.position[v as usize]), 0.5));
        let (a, b) = (self.sphere[u as usize], self.sphere[v as usize]);
        self.sphere.push(normalize(add(a, b)).unwrap_or(a));
        m
    }

    fn faces(&self) -> Vec<[u32; 3]> {
        faces_of_rings(&self.rings)
    }
}

/// Half of two origins: both lie in one closed input face (every refined
/// triangle lies in one), so the union has at most three vertices.
fn midpoint(a: &Origin, b: &Origin) -> Origin {
    let mut out: Origin = [(0, 0.0); 3];
    let mut used = 0;
    for &(v, w) in a.iter().chain(b.iter()) {
        if w <= 0.0 {
            continue;
        }
        if let Some(slot) = out[..used].iter_mut().find(|s| s.0 == v) {
            slot.1 += 0.5 * w;
        } else if used < 3 {
            out[used] = (v, 0.5 * w);
            used += 1;
        }
    }
    out
}

/// The traced state: which vertices are taken, which edges are paths.
struct Traced {
    taken: Vec<bool>,
    path_edges: HashSet<(u32, u32)>,
}

impl Traced {
    fn is_path_edge(&self, a: u32, b: u32) -> bool {
        self.path_edges.contains(&(a.min(b), a.max(b)))
    }
}

/// Splits every edge at `around` joining two taken vertices that is not a
/// path edge (a chord); the new vertices are free.
fn split_chords(rot: &mut Rotation, traced: &mut Traced, around: &[u32]) -> usize {
    let mut splits = 0;
    for &x in around {
        loop {
            let chord = rot.rings[x as usize]
                .iter()
                .copied()
                .find(|&y| traced.taken[y as usize] && !traced.is_path_edge(x, y));
            let Some(y) = chord else { break };
            rot.split(x, y);
            traced.taken.push(false);
            splits += 1;
        }
    }
    splits
}

/// The free neighbours of landmark `a` where a path towards T-neighbour `b`
/// may leave: between the traced paths that come before and after `b` in
/// T's counter-clockwise order at `a` (all free neighbours when none is
/// traced yet).
fn sector(
    rot: &Rotation,
    traced: &Traced,
    a_vertex: u32,
    t_ring: &[usize],
    first: &[Option<u32>],
    b: usize,
) -> Vec<u32> {
    let ring = &rot.rings[a_vertex as usize];
    let m = t_ring.len();
    let jb = t_ring.iter().position(|&x| x == b).expect("b is a T-neighbour");
    let next = (1..m).map(|s| t_ring[(jb + s) % m]).find_map(|t| first[t]);
    let prev = (1..m).map(|s| t_ring[(jb + m - s) % m]).find_map(|t| first[t]);
    let (Some(next), Some(prev)) = (next, prev) else {
        return ring.iter().copied().filter(|&v| !traced.taken[v as usize]).collect();
    };
    let ip = ring.iter().position(|&v| v == prev).expect("path leaves through a neighbour");
    let n = ring.len();
    let mut out = Vec::new();
    for s in 1..n {
        let v = ring[(ip + s) % n];
        if v == next {
            break;
        }
        if !traced.taken[v as usize] {
            out.push(v);
        }
    }
    out
}

/// Shortest path through free vertices from any of `starts` to any of
/// `ends` (3D edge lengths, plus the first and last hop from the landmarks).
fn shortest(
    rot: &Rotation,
    traced: &Traced,
    from: u32,
    starts: &[u32],
    to: u32,
    ends: &[u32],
) -> Option<Vec<u32>> {
    let n = rot.rings.len();
    let mut dist = vec![f64::INFINITY; n];
    let mut parent = vec![u32::MAX; n];
    let mut is_end = vec![false; n];
    for &e in ends {
        is_end[e as usize] = true;
    }
    let len = |a: u32, b: u32| norm(sub(rot.position[a as usize], rot.position[b as usize]));
    let key = |d: f64| Reverse(d.to_bits());
    let mut heap = BinaryHeap::new();
    for &s in starts {
        let d = len(from, s);
        if d < dist[s as usize] {
            dist[s as usize] = d;
            heap.push((key(d), Reverse(s)));
        }
    }
    let mut best: Option<(f64, u32)> = None;
    while let Some((Reverse(bits), Reverse(v))) = heap.pop() {
        let d = f64::from_bits(bits);
        if d > dist[v as usize] {
            continue;
        }
        if best.is_some_and(|(b, _)| d >= b) {
            break;
        }
        if is_end[v as usize] {
            let total = d + len(v, to);
            if best.is_none_or(|(b, _)| total < b) {
                best = Some((total, v));
            }
        }
        for &w in &rot.rings[v as usize] {
            if traced.taken[w as usize] {
                continue;
            }
            let nd = d + len(v, w);
            if nd < dist[w as usize] {
                dist[w as usize] = nd;
                parent[w as usize] = v;
                heap.push((key(nd), Reverse(w)));
            }
        }
    }
    let (_, mut v) = best?;
    let mut path = vec![to, v];
    while parent[v as usize] != u32::MAX {
        v = parent[v as usize];
        path.push(v);
    }
    path.push(from);
    path.reverse();
    Some(path)
}

/// Landmark vertex ids (the caller's, then the auxiliary ones), their
/// targets, T's triangles (indices into both) and the auxiliary count.
type Triangulated = (Vec<u32>, Vec<[f64; 3]>, Vec<[usize; 3]>, usize);

/// Picks auxiliary landmarks when the targets alone do not triangulate the
/// sphere: octahedron directions (in a fixed tilted frame) far from every
/// target, each at the free vertex whose start point is nearest.
fn with_auxiliary(start: &[[f64; 3]], landmarks: &Landmarks) -> Result<Triangulated, SphereError> {
    let mut ids = landmarks.ids.clone();
    let mut targets = landmarks.targets.clone();
    if let Some(t) = covering(&targets) {
        return Ok((ids, targets, t, 0));
    }
    let frames: [[f64; 3]; 4] =
        [[0.3, 0.5, 0.2], [1.1, -0.4, 0.7], [-0.6, 0.9, 1.3], [0.2, 1.7, -0.8]];
    for (attempt, angles) in frames.iter().enumerate() {
        ids.truncate(landmarks.len());
        targets.truncate(landmarks.len());
        let clearance = AUX_CLEARANCE / (1 + attempt) as f64;
        let (sa, ca) = angles[0].sin_cos();
        let (sb, cb) = angles[1].sin_cos();
        let (sc, cc) = angles[2].sin_cos();
        // Columns of a rotation: three turns, fixed, so the result is too.
        let rx = |v: [f64; 3]| [v[0], ca * v[1] - sa * v[2], sa * v[1] + ca * v[2]];
        let ry = |v: [f64; 3]| [cb * v[0] + sb * v[2], v[1], -sb * v[0] + cb * v[2]];
        let rz = |v: [f64; 3]| [cc * v[0] - sc * v[1], sc * v[0] + cc * v[1], v[2]];
        let axes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for axis in axes {
            for sign in [1.0, -1.0] {
                let d = rz(ry(rx(scale(axis, sign))));
                if targets.iter().any(|&t| angle(t, d) < clearance) {
                    continue;
                }
                let taken: HashSet<u32> = ids.iter().copied().collect();
                let near =
                    (0..start.len() as u32).filter(|v| !taken.contains(v)).min_by(|&a, &b| {
                        angle(start[a as usize], d)
                            .total_cmp(&angle(start[b as usize], d))
                            .then(a.cmp(&b))
                    });
                if let Some(v) = near {
                    ids.push(v);
                    targets.push(d);
                }
            }
        }
        if let Some(t) = covering(&targets) {
            let added = ids.len() - landmarks.len();
            return Ok((ids, targets, t, added));
        }
    }
    Err(failed(
        landmarks.ids.iter().map(|&i| i as usize).collect(),
        "no auxiliary landmarks made the targets' hull hold the centre".into(),
    ))
}

/// The caller's landmarks (vertex ids, sorted) on a triangle of `tris`
/// that is not positive at the start points: the ones out of order. `ids`
/// may end with auxiliary landmarks (from index `n_user` on), left out.
fn out_of_order(start: &[[f64; 3]], ids: &[u32], tris: &[[usize; 3]], n_user: usize) -> Vec<usize> {
    let at = |j: usize| start[ids[j] as usize];
    let mut out: Vec<usize> = tris
        .iter()
        .filter(|&&[a, b, c]| det3_sign(at(a), at(b), at(c)) != Sign::Positive)
        .flat_map(|t| t.iter().copied())
        .filter(|&j| j < n_user)
        .map(|j| ids[j] as usize)
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// How many of the caller's landmarks are out of order at their start
/// points: on a triangle of T (the targets' hull) that is not positive
/// there. A drag keeps the landmarks' cyclic order only approximately, so
/// it passes a few of them (measured in docs/correspondence.md: every
/// registration with 8 pairs), but a set whose order is scrambled
/// throughout mostly stalls, after long. 0 when T needs auxiliary
/// landmarks (few landmarks: the drag is tried first).
pub fn out_of_order_count(start: &[[f64; 3]], landmarks: &Landmarks) -> usize {
    covering(&landmarks.targets)
        .map_or(0, |tris| out_of_order(start, &landmarks.ids, &tris, landmarks.len()).len())
}

/// Builds the map of the module documentation. `rings` is the input mesh's
/// rotation system (face (v, r[j], r[j + 1]) counter-clockwise), `positions`
/// its vertices, `start` a valid map of it (read only to choose auxiliary
/// vertices and the order of tracing). `go_on()` is polled.
///
/// # Errors
/// [`SphereError::Cancelled`]; [`SphereError::LandmarkConflict`] if a step
/// that cannot fail in exact arithmetic failed; [`SphereError::Resource`]
/// when the refined mesh grows past what the memory policy can map (checked
/// each time it doubles: heavily scrambled sets refine far more than the
/// input, 22k vertices to 7.5M on `sword` with 64 landmarks);
/// [`SphereError::LandmarkConflict`] when it grows past `max_vertices`
/// (`None`: [`MAX_GROWTH`] times the input's vertices or [`MAX_ADDED`] more).
pub fn path_layout(
    rings: &[Vec<u32>],
    positions: &[[f64; 3]],
    start: &[[f64; 3]],
    landmarks: &Landmarks,
    max_vertices: Option<usize>,
    go_on: &(dyn Fn() -> bool + Sync),
) -> Result<PathLayout, SphereError> {
    let n = rings.len();
    let limit = max_vertices.unwrap_or((MAX_GROWTH * n).max(n + MAX_ADDED));
    let cancelled = || SphereError::Cancelled { stage: "landmark layout", done: 0, total: 1 };
    let (ids, targets, tris, _) = with_auxiliary(start, landmarks)?;
    let k = ids.len();
    let mut rot = Rotation {
        rings: rings.to_vec(),
        origin: (0..n as u32).map(|v| [(v, 1.0), (0, 0.0), (0, 0.0)]).collect(),
        position: positions.to_vec(),
        sphere: start.to_vec(),
    };
    let mut traced = Traced { taken: vec![false; n], path_edges: HashSet::new() };
    for &v in &ids {
        traced.taken[v as usize] = true;
    }
    split_chords(&mut rot, &mut traced, &ids);

    // T's rotation at each landmark: counter-clockwise neighbours.
    let mut next_at: Vec<Vec<(usize, usize)>> = vec![Vec::new(); k];
    for &[a, b, c] in &tris {
        next_at[a].push((b, c));
        next_at[b].push((c, a));
        next_at[c].push((a, b));
    }
    let mut t_ring: Vec<Vec<usize>> = Vec::with_capacity(k);
    for (a, next) in next_at.iter().enumerate() {
        let mut ring = vec![next.iter().map(|&(b, _)| b).min().ok_or_else(|| {
            failed(vec![ids[a] as usize], "a target is not a vertex of the hull".into())
        })?];
        while ring.len() < next.len() {
            let last = *ring.last().expect("nonempty");
            let &(_, c) = next.iter().find(|&&(b, _)| b == last).expect("closed fan");
            ring.push(c);
        }
        t_ring.push(ring);
    }
    let mut edges: Vec<(usize, usize)> = tris
        .iter()
        .flat_map(|&[a, b, c]| [(a, b), (b, c), (c, a)])
        .filter(|&(a, b)| a < b)
        .collect();
    let weight = |(a, b): (usize, usize)| angle(start[ids[a] as usize], start[ids[b] as usize]);
    edges.sort_by(|&x, &y| weight(x).total_cmp(&weight(y)).then(x.cmp(&y)));
    // Kruskal: the spanning tree first (its complement is one region), then
    // the rest, each closing one face of T.
    let mut root: Vec<usize> = (0..k).collect();
    fn find(root: &mut [usize], mut x: usize) -> usize {
        while root[x] != x {
            root[x] = root[root[x]];
            x = root[x];
        }
        x
    }
    let (mut tree, mut rest) = (Vec::new(), Vec::new());
    for e in edges {
        let (ra, rb) = (find(&mut root, e.0), find(&mut root, e.1));
        if ra != rb {
            root[ra] = rb;
            tree.push(e);
        } else {
            rest.push(e);
        }
    }
    // first[a][t]: the neighbour of landmark a's vertex its path to T-vertex t leaves by.
    let mut first: Vec<Vec<Option<u32>>> = vec![vec![None; k]; k];
    let mut paths: Vec<(usize, usize, Vec<u32>)> = Vec::new();
    let mut next_check = 2 * n;
    for (a, b) in tree.into_iter().chain(rest) {
        if !go_on() {
            return Err(cancelled());
        }
        let (va, vb) = (ids[a], ids[b]);
        let starts = sector(&rot, &traced, va, &t_ring[a], &first[a], b);
        let ends = sector(&rot, &traced, vb, &t_ring[b], &first[b], a);
        let path = shortest(&rot, &traced, va, &starts, vb, &ends).ok_or_else(|| {
            failed(vec![va as usize, vb as usize], "no free path between their sectors".into())
        })?;
        first[a][b] = Some(path[1]);
        first[b][a] = Some(path[path.len() - 2]);
        for w in path.windows(2) {
            traced.path_edges.insert((w[0].min(w[1]), w[0].max(w[1])));
        }
        for &v in &path {
            traced.taken[v as usize] = true;
        }
        split_chords(&mut rot, &mut traced, &path);
        paths.push((a, b, path));
        if rot.rings.len() > limit {
            let asked = if max_vertices.is_some() { " (max_vertices)" } else { "" };
            return Err(SphereError::LandmarkConflict {
                ids: out_of_order(start, &ids, &tris, landmarks.len()),
                reason: format!(
                    "their order on the sphere is too far from the targets' order: laying \
                     them out would refine the {n}-vertex mesh to {} vertices, past its \
                     limit of {limit}{asked}; move them less, or in steps",
                    rot.rings.len()
                ),
            });
        }
        if rot.rings.len() >= next_check {
            // The refined mesh is what the layout solves and then relaxes
            // with the landmarks held: asked of the memory policy before it
            // grows further, as every other allocation of a map's size is.
            let size = rot.rings.len();
            check(&Need::new(
                "embed with landmarks (the landmark layout's refined mesh)".into(),
                progressive_rate(Energy::Isometric),
                size,
                2 * size - 4,
            ))?;
            next_check = 2 * size;
        }
    }

    // Path vertices on the hull's straight sides, by length along the path.
    let total = rot.rings.len();
    let mut fixed: Vec<Option<[f64; 3]>> = vec![None; total];
    for (a, b, path) in &paths {
        let lengths: Vec<f64> = path
            .windows(2)
            .map(|w| norm(sub(rot.position[w[0] as usize], rot.position[w[1] as usize])))
            .collect();
        let sum: f64 = lengths.iter().sum();
        let mut along = 0.0;
        for (j, &v) in path.iter().enumerate() {
            let t = if sum > 0.0 { along / sum } else { j as f64 / (path.len() - 1) as f64 };
            fixed[v as usize] = Some(add(scale(targets[*a], 1.0 - t), scale(targets[*b], t)));
            if j < lengths.len() {
                along += lengths[j];
            }
        }
    }
    for (j, &v) in ids.iter().enumerate() {
        fixed[v as usize] = Some(targets[j]);
    }
    let points = tutte_on_hull(&rot, &fixed)?;
    let mut points: Vec<[f64; 3]> = points
        .into_iter()
        .map(|p| normalize(p).ok_or_else(|| failed(vec![], "a point at the centre".into())))
        .collect::<Result<_, _>>()?;
    for (j, &v) in ids.iter().enumerate() {
        points[v as usize] = targets[j];
    }
    Ok(PathLayout {
        faces: rot.faces(),
        origin: rot.origin,
        points,
        auxiliary: ids[landmarks.len()..].to_vec(),
        patches: tris.len(),
    })
}

/// Floater's mean value weights (2003, "Mean value coordinates") of the ring
/// of a vertex at `p` in the start map, its ring projected onto the plane
/// tangent at `p` (gnomonic). Positive for a ring whose kernel holds `p`,
/// which a valid map guarantees; `None` (uniform weights instead) where
/// rounding or a ring beyond the hemisphere leaves one not positive.
///
/// Uniform weights squash long limbs exponentially (a Tutte map of a tube
/// is harmonic): measured on a tentacled shape, faces rounded to det 0.
/// Weights read from the start map, which keeps areas in proportion,
/// reproduce it where the boundary agrees and spread the moves smoothly.
fn mean_value_weights(p: [f64; 3], ring: &[u32], sphere: &[[f64; 3]]) -> Option<Vec<f64>> {
    let m = ring.len();
    let mut d = Vec::with_capacity(m);
    for &j in ring {
        let q = sphere[j as usize];
        let h = dot(q, p);
        if h <= 0.0 {
            return None;
        }
        d.push(sub(scale(q, 1.0 / h), p));
    }
    let half_tan: Vec<f64> = (0..m)
        .map(|j| {
            let (a, b) = (d[j], d[(j + 1) % m]);
            let theta = norm(cross(a, b)).atan2(dot(a, b));
            (0.5 * theta).tan()
        })
        .collect();
    let w: Vec<f64> =
        (0..m).map(|j| (half_tan[(j + m - 1) % m] + half_tan[j]) / norm(d[j])).collect();
    let ok = w.iter().all(|&x| x > 0.0 && x.is_finite())
        && (0..m).all(|j| dot(p, cross(d[j], d[(j + 1) % m])) > 0.0);
    ok.then_some(w)
}

/// The Tutte embedding of every free vertex (mean value weights of the
/// start map) with the path vertices fixed on the hull's facets: x, y and z
/// share one matrix.
fn tutte_on_hull(rot: &Rotation, fixed: &[Option<[f64; 3]>]) -> Result<Vec<[f64; 3]>, SphereError> {
    let solver_error = |e: String| failed(vec![], format!("the patches' Tutte solve: {e}"));
    let edges = |i: u32, out: &mut Vec<(u32, f64)>| {
        let ring = &rot.rings[i as usize];
        match mean_value_weights(rot.sphere[i as usize], ring, &rot.sphere) {
            Some(w) => out.extend(ring.iter().copied().zip(w)),
            None => out.extend(ring.iter().map(|&j| (j, 1.0))),
        }
    };
    let xy: Vec<Option<[f64; 2]>> = fixed.iter().map(|p| p.map(|p| [p[0], p[1]])).collect();
    let z: Vec<Option<[f64; 2]>> = fixed.iter().map(|p| p.map(|p| [p[2], 0.0])).collect();
    let system = FixedSystem::assemble_rows(&xy, edges).map_err(|e| solver_error(e.to_string()))?;
    let z_system =
        FixedSystem::assemble_rows(&z, edges).map_err(|e| solver_error(e.to_string()))?;
    let mut out: Vec<[f64; 3]> = fixed.iter().map(|p| p.unwrap_or([0.0; 3])).collect();
    if system.free.is_empty() {
        return Ok(out);
    }
    let rhs = vec![system.rhs[0].clone(), system.rhs[1].clone(), z_system.rhs[0].clone()];
    let params = SolveParams { tol: 1e-14, ..SolveParams::default() };
    let (solution, _) = solve(&system.matrix, &rhs, SolverKind::Auto, &params)
        .map_err(|e| solver_error(e.to_string()))?;
    for (row, &v) in system.free.iter().enumerate() {
        out[v as usize] = [solution[0][row], solution[1][row], solution[2][row]];
    }
    Ok(out)
}
