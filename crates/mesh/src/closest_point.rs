//! Closest points of a triangle mesh's surface, by a bounding-volume
//! hierarchy of the triangles (registration's ICP, issue 23).
//!
//! Registration asks, dozens of times per call, for the point of B's surface
//! nearest to each of thousands of points of a deformed A. A median-split
//! tree of the triangles' boxes answers each query by branch and bound: the
//! nearer child is searched first, and a box no nearer than the best point
//! found so far is skipped. Unlike a nearest-*vertex* search followed by the
//! faces around that vertex, the answer is the exact closest point of the
//! whole surface (up to rounding), also far from the surface.
//!
//! The closest point of one triangle is Ericson's test of its Voronoi
//! regions ("Real-Time Collision Detection", 2005, 5.1.5). Each query is
//! independent and visits the tree in a fixed order, so the answers are the
//! same bits for any number of threads.

use rayon::prelude::*;

/// Leaves hold at most this many triangles.
const LEAF_SIZE: usize = 4;
/// Most queries a worker answers between two checks of `go_on`.
const CHUNK: usize = 4096;
/// Fewest queries of a chunk: below this a chunk's scheduling costs more
/// than it saves.
const MIN_CHUNK: usize = 64;
/// Chunks per worker thread at least (where the queries allow): the ICP's
/// calls are of 300-3000 queries, which in one chunk of [`CHUNK`] ran on
/// one core of two (issue 23, register's wall time).
const CHUNKS_PER_THREAD: usize = 4;

/// A hint's bound is its triangle's squared distance times `1 + HINT_SLACK`
/// plus the square of [`HINT_FLOOR`] times the largest coordinate: far
/// above the rounding of a squared distance or of a box's (module doc of
/// [`ClosestPoints::closest_from`]).
const HINT_SLACK: f64 = 1e-6;
const HINT_FLOOR: f64 = 1e-12;

#[derive(Debug, Clone, Copy)]
struct Node {
    min: [f64; 3],
    max: [f64; 3],
    /// Leaf: triangles order[start..start + count]; inner: children at
    /// `start` and `start + 1` (count == 0).
    start: u32,
    count: u32,
}

/// A closest point: the face, its barycentric weights on the face's corners
/// (in the face's order) and the point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    pub face: u32,
    pub bary: [f64; 3],
    pub point: [f64; 3],
}

/// The triangles of a mesh in a box tree (module doc).
///
/// Once built, the tree keeps its triangles in the leaves' order (`faces[i]`
/// is the face `order[i]` of the input, `slot` the inverse) and its corners
/// renumbered in the order that walk first meets them, so that a leaf's
/// triangles and their corners lie together in memory: a far query's walk
/// was bound by loading them through two indirections (`perf annotate` of
/// registration's rigid ICP queries: a third of the samples on those
/// loads; issue 23, speed, session 12). Each triangle keeps its corners'
/// values and order, and the walk meets the triangles in the same order,
/// so the answers are the same bits.
#[derive(Debug, Clone)]
pub struct ClosestPoints {
    positions: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    order: Vec<u32>,
    slot: Vec<u32>,
    nodes: Vec<Node>,
    /// The square of [`HINT_FLOOR`] times the largest coordinate's size.
    hint_floor2: f64,
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Ericson's closest point of triangle (a, b, c) to p: barycentric weights
/// on (a, b, c). A degenerate triangle falls to its edges' regions.
pub fn closest_on_triangle(p: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    let ab = sub(b, a);
    let ac = sub(c, a);
    let ap = sub(p, a);
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = sub(p, b);
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = sub(p, c);
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let total = va + vb + vc;
    if total == 0.0 || !total.is_finite() {
        // A degenerate triangle whose regions all failed: its first corner.
        return [1.0, 0.0, 0.0];
    }
    let v = vb / total;
    let w = vc / total;
    [1.0 - v - w, v, w]
}

fn combine(bary: [f64; 3], a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [f64; 3] {
    [
        bary[0] * a[0] + bary[1] * b[0] + bary[2] * c[0],
        bary[0] * a[1] + bary[1] * b[1] + bary[2] * c[1],
        bary[0] * a[2] + bary[1] * b[2] + bary[2] * c[2],
    ]
}

fn box_distance2(node: &Node, p: [f64; 3]) -> f64 {
    let mut d2 = 0.0;
    for ((lo, hi), x) in node.min.iter().zip(&node.max).zip(&p) {
        let d = (lo - x).max(0.0).max(x - hi);
        d2 += d * d;
    }
    d2
}

impl ClosestPoints {
    /// The tree of `faces` (corner ids into `positions`, all in range).
    pub fn new(positions: Vec<[f64; 3]>, faces: Vec<[u32; 3]>) -> Self {
        let centres: Vec<[f64; 3]> = faces
            .iter()
            .map(|f| {
                let (a, b, c) =
                    (positions[f[0] as usize], positions[f[1] as usize], positions[f[2] as usize]);
                [(a[0] + b[0] + c[0]) / 3.0, (a[1] + b[1] + c[1]) / 3.0, (a[2] + b[2] + c[2]) / 3.0]
            })
            .collect();
        let extent = positions.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()));
        let mut tree = ClosestPoints {
            order: (0..faces.len() as u32).collect(),
            slot: Vec::new(),
            nodes: Vec::with_capacity(2 * faces.len() / LEAF_SIZE + 2),
            positions,
            faces,
            hint_floor2: (HINT_FLOOR * extent) * (HINT_FLOOR * extent),
        };
        if !tree.faces.is_empty() {
            tree.nodes.push(Node { min: [0.0; 3], max: [0.0; 3], start: 0, count: 0 });
            tree.build(0, 0, tree.faces.len(), &centres);
        }
        tree.pack();
        tree
    }

    /// The triangles put in the leaves' order and their corners renumbered
    /// in the order of first use (struct doc); corners no triangle uses are
    /// dropped.
    fn pack(&mut self) {
        const UNSEEN: u32 = u32::MAX;
        let mut renumber = vec![UNSEEN; self.positions.len()];
        let mut positions = Vec::with_capacity(self.positions.len());
        let mut faces = Vec::with_capacity(self.faces.len());
        for &t in &self.order {
            let f = self.faces[t as usize];
            faces.push(f.map(|v| {
                let new = &mut renumber[v as usize];
                if *new == UNSEEN {
                    *new = positions.len() as u32;
                    positions.push(self.positions[v as usize]);
                }
                *new
            }));
        }
        let mut slot = vec![0u32; self.order.len()];
        for (i, &t) in self.order.iter().enumerate() {
            slot[t as usize] = i as u32;
        }
        self.positions = positions;
        self.faces = faces;
        self.slot = slot;
    }

    /// The two children of inner node `node` on the walk's `stack` with
    /// their box distances to `p`, the nearer on top (popped first).
    fn push_children(&self, stack: &mut Vec<(u32, f64)>, node: Node, p: [f64; 3]) {
        let (l, r) = (node.start, node.start + 1);
        let dl = box_distance2(&self.nodes[l as usize], p);
        let dr = box_distance2(&self.nodes[r as usize], p);
        if dl <= dr {
            stack.push((r, dr));
            stack.push((l, dl));
        } else {
            stack.push((l, dl));
            stack.push((r, dr));
        }
    }

    /// The corners of input face `face` (in range), in its order.
    fn corners(&self, face: u32) -> [[f64; 3]; 3] {
        let f = self.faces[self.slot[face as usize] as usize];
        f.map(|v| self.positions[v as usize])
    }

    /// The box of the triangles `order[start..end]` (input numbering: the
    /// tree is built before [`pack`](Self::pack)).
    fn bounds(&self, start: usize, end: usize) -> ([f64; 3], [f64; 3]) {
        let mut min = [f64::INFINITY; 3];
        let mut max = [f64::NEG_INFINITY; 3];
        for &t in &self.order[start..end] {
            for &v in &self.faces[t as usize] {
                let p = self.positions[v as usize];
                for ((lo, hi), x) in min.iter_mut().zip(max.iter_mut()).zip(p) {
                    *lo = lo.min(x);
                    *hi = hi.max(x);
                }
            }
        }
        (min, max)
    }

    fn build(&mut self, node: usize, start: usize, end: usize, centres: &[[f64; 3]]) {
        let (min, max) = self.bounds(start, end);
        if end - start <= LEAF_SIZE {
            self.nodes[node] = Node { min, max, start: start as u32, count: (end - start) as u32 };
            return;
        }
        // Split the centres at their median along the box's longest axis.
        let axis =
            (0..3).max_by(|&i, &j| (max[i] - min[i]).total_cmp(&(max[j] - min[j]))).unwrap_or(0);
        let mid = start + (end - start) / 2;
        self.order[start..end].select_nth_unstable_by(mid - start, |&x, &y| {
            centres[x as usize][axis].total_cmp(&centres[y as usize][axis]).then(x.cmp(&y))
        });
        let children = self.nodes.len();
        let empty = Node { min: [0.0; 3], max: [0.0; 3], start: 0, count: 0 };
        self.nodes.push(empty);
        self.nodes.push(empty);
        self.nodes[node] = Node { min, max, start: children as u32, count: 0 };
        self.build(children, start, mid, centres);
        self.build(children + 1, mid, end, centres);
    }

    /// The number of triangles.
    pub fn len(&self) -> usize {
        self.faces.len()
    }

    /// Whether the mesh has no triangles.
    pub fn is_empty(&self) -> bool {
        self.faces.is_empty()
    }

    /// The closest point of the surface to `p` (None for an empty mesh or a
    /// point that is not finite).
    pub fn closest(&self, p: [f64; 3]) -> Option<SurfacePoint> {
        self.closest_from(p, None)
    }

    /// [`closest`](Self::closest), the branch and bound started from a bound
    /// just above the squared distance from `p` to triangle `hint` (the
    /// answer for a nearby query, as an ICP's previous iteration gives),
    /// instead of from infinity: boxes beyond it are skipped from the start.
    /// The same answer to the bit. The walk visits the tree in the same
    /// fixed order; it only skips more boxes, all at least the bound away.
    /// The bound exceeds the answer's squared distance (at most the hint's)
    /// by far more than the rounding of a distance or of a box's, so every
    /// triangle that could be the answer or a rival within that rounding
    /// is met as before, and the best so far agrees with the plain walk's
    /// whenever it is below the bound: the first least-distance triangle of
    /// the walk is the same. A hint out of range is no hint; should nothing
    /// be found below the bound (which only a rounding far beyond the
    /// slack could cause), the plain walk answers.
    pub fn closest_from(&self, p: [f64; 3], hint: Option<u32>) -> Option<SurfacePoint> {
        if self.nodes.is_empty() || !p.iter().all(|x| x.is_finite()) {
            return None;
        }
        let mut best: Option<SurfacePoint> = None;
        let mut best_d2 = f64::INFINITY;
        let hinted = hint.filter(|&h| (h as usize) < self.faces.len());
        if let Some(h) = hinted {
            let [a, b, c] = self.corners(h);
            let e = sub(combine(closest_on_triangle(p, a, b, c), a, b, c), p);
            best_d2 = dot(e, e) * (1.0 + HINT_SLACK) + self.hint_floor2;
        }
        let mut stack: Vec<(u32, f64)> = Vec::with_capacity(64);
        stack.push((0, box_distance2(&self.nodes[0], p)));
        while let Some((index, d2)) = stack.pop() {
            if d2 >= best_d2 {
                continue;
            }
            let node = self.nodes[index as usize];
            if node.count > 0 {
                let range = node.start as usize..(node.start + node.count) as usize;
                for i in range {
                    let f = self.faces[i];
                    let (a, b, c) = (
                        self.positions[f[0] as usize],
                        self.positions[f[1] as usize],
                        self.positions[f[2] as usize],
                    );
                    let bary = closest_on_triangle(p, a, b, c);
                    let q = combine(bary, a, b, c);
                    let e = sub(q, p);
                    let e2 = dot(e, e);
                    // Ties go to the triangle met first: a fixed order.
                    if e2 < best_d2 {
                        best_d2 = e2;
                        best = Some(SurfacePoint { face: self.order[i], bary, point: q });
                    }
                }
                continue;
            }
            self.push_children(&mut stack, node, p);
        }
        if best.is_none() && hinted.is_some() {
            return self.closest_from(p, None);
        }
        best
    }

    /// [`closest`](Self::closest) for many points, in parallel chunks;
    /// `go_on(done, total)` is asked between chunks and None is returned
    /// when it says stop. A point that is not finite gets face `u32::MAX`.
    pub fn closest_many(
        &self,
        points: &[[f64; 3]],
        go_on: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Option<Vec<SurfacePoint>> {
        self.closest_many_from(points, None, go_on)
    }

    /// [`closest_many`](Self::closest_many) with a hint per point
    /// ([`closest_from`](Self::closest_from); `u32::MAX` or out of range: none):
    /// the same answers.
    pub fn closest_many_from(
        &self,
        points: &[[f64; 3]],
        hints: Option<&[u32]>,
        go_on: &(dyn Fn(usize, usize) -> bool + Sync),
    ) -> Option<Vec<SurfacePoint>> {
        let missing = SurfacePoint { face: u32::MAX, bary: [f64::NAN; 3], point: [f64::NAN; 3] };
        // Each query is answered alone, so the chunking changes no bits.
        let size = chunk_size(points.len(), rayon::current_num_threads());
        let hint = |row: usize| hints.and_then(|h| h.get(row).copied());
        let chunks: Vec<Option<Vec<SurfacePoint>>> = points
            .par_chunks(size)
            .enumerate()
            .map(|(k, chunk)| {
                if !go_on(k * size, points.len()) {
                    return None;
                }
                Some(
                    chunk
                        .iter()
                        .enumerate()
                        .map(|(i, &p)| self.closest_from(p, hint(k * size + i)).unwrap_or(missing))
                        .collect(),
                )
            })
            .collect();
        let mut out = Vec::with_capacity(points.len());
        for chunk in chunks {
            out.extend(chunk?);
        }
        Some(out)
    }
}

/// Queries per chunk for `queries` on `threads` workers: about
/// [`CHUNKS_PER_THREAD`] chunks a worker, within [`MIN_CHUNK`]..=[`CHUNK`].
fn chunk_size(queries: usize, threads: usize) -> usize {
    queries.div_ceil(CHUNKS_PER_THREAD * threads.max(1)).clamp(MIN_CHUNK, CHUNK)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcg::Lcg;

    fn brute(tree: &ClosestPoints, p: [f64; 3]) -> f64 {
        tree.faces
            .iter()
            .map(|f| {
                let (a, b, c) = (
                    tree.positions[f[0] as usize],
                    tree.positions[f[1] as usize],
                    tree.positions[f[2] as usize],
                );
                let q = combine(closest_on_triangle(p, a, b, c), a, b, c);
                let e = sub(q, p);
                dot(e, e)
            })
            .fold(f64::INFINITY, f64::min)
    }

    fn random_soup(n: usize, rng: &mut Lcg) -> ClosestPoints {
        let (positions, faces) = soup_arrays(n, rng);
        ClosestPoints::new(positions, faces)
    }

    fn soup_arrays(n: usize, rng: &mut Lcg) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut positions = Vec::new();
        let mut faces = Vec::new();
        for t in 0..n {
            let centre = [rng.next_f64() * 4.0, rng.next_f64() * 4.0, rng.next_f64()];
            for _ in 0..3 {
                positions.push([
                    centre[0] + 0.3 * rng.next_f64(),
                    centre[1] + 0.3 * rng.next_f64(),
                    centre[2] + 0.3 * rng.next_f64(),
                ]);
            }
            let k = 3 * t as u32;
            faces.push([k, k + 1, k + 2]);
        }
        (positions, faces)
    }

    #[test]
    fn agrees_with_brute_force_near_and_far() {
        let mut rng = Lcg::new(7);
        let tree = random_soup(500, &mut rng);
        for k in 0..400 {
            let spread = if k % 2 == 0 { 5.0 } else { 40.0 };
            let p = [
                spread * (rng.next_f64() - 0.3),
                spread * (rng.next_f64() - 0.3),
                spread * (rng.next_f64() - 0.5),
            ];
            let hit = tree.closest(p).expect("a point");
            let e = sub(hit.point, p);
            assert!((dot(e, e) - brute(&tree, p)).abs() <= 1e-12 * (1.0 + dot(e, e)));
            let [a, b, c] = tree.corners(hit.face);
            let q = combine(hit.bary, a, b, c);
            assert!(dot(sub(q, hit.point), sub(q, hit.point)) < 1e-24);
            assert!(hit.bary.iter().all(|&w| (-1e-12..=1.0 + 1e-12).contains(&w)));
        }
    }

    #[test]
    fn a_hint_changes_no_answer() {
        // Hints from a nearby query (an ICP's previous iteration), from far
        // away, out of range: the same answer to the bit, near and far, on
        // a soup and on a closed mesh whose queries often land on shared
        // vertices and edges.
        let mut rng = Lcg::new(9);
        let soup = random_soup(400, &mut rng);
        let sphere = {
            let m = crate::solids::icosphere(3);
            ClosestPoints::new(m.positions().to_vec(), m.faces().to_vec())
        };
        for tree in [&soup, &sphere] {
            for k in 0..600 {
                let spread = [0.5, 3.0, 30.0][k % 3];
                let p = [
                    spread * (rng.next_f64() - 0.3),
                    spread * (rng.next_f64() - 0.3),
                    spread * (rng.next_f64() - 0.5),
                ];
                let plain = tree.closest(p);
                let nearby = [p[0] + 0.01, p[1] - 0.02, p[2] + 0.005];
                let hints = [
                    tree.closest(nearby).map(|h| h.face),
                    plain.map(|h| h.face),
                    Some((rng.next_f64() * tree.len() as f64) as u32),
                    Some(u32::MAX),
                    Some(tree.len() as u32),
                ];
                for hint in hints {
                    assert_eq!(tree.closest_from(p, hint), plain, "{p:?} {hint:?}");
                }
            }
        }
        let points: Vec<[f64; 3]> = (0..3000)
            .map(|_| [rng.next_f64() * 5.0, rng.next_f64() * 5.0, rng.next_f64()])
            .collect();
        let plain = soup.closest_many(&points, &|_, _| true).expect("not stopped");
        let hints: Vec<u32> = plain.iter().rev().map(|h| h.face).collect();
        assert_eq!(soup.closest_many_from(&points, Some(&hints), &|_, _| true), Some(plain));
    }

    /// The walk before the packing (session 11's): the tree's nodes and
    /// order, the triangles read through `order` from the input's faces
    /// and positions.
    fn unpacked_walk(
        tree: &ClosestPoints,
        positions: &[[f64; 3]],
        faces: &[[u32; 3]],
        p: [f64; 3],
    ) -> Option<SurfacePoint> {
        let mut best = None;
        let mut best_d2 = f64::INFINITY;
        let mut stack = vec![(0u32, box_distance2(&tree.nodes[0], p))];
        while let Some((index, d2)) = stack.pop() {
            if d2 >= best_d2 {
                continue;
            }
            let node = tree.nodes[index as usize];
            if node.count > 0 {
                let range = node.start as usize..(node.start + node.count) as usize;
                for &t in &tree.order[range] {
                    let f = faces[t as usize];
                    let (a, b, c) = (
                        positions[f[0] as usize],
                        positions[f[1] as usize],
                        positions[f[2] as usize],
                    );
                    let bary = closest_on_triangle(p, a, b, c);
                    let q = combine(bary, a, b, c);
                    let e = sub(q, p);
                    if dot(e, e) < best_d2 {
                        best_d2 = dot(e, e);
                        best = Some(SurfacePoint { face: t, bary, point: q });
                    }
                }
                continue;
            }
            tree.push_children(&mut stack, node, p);
        }
        best
    }

    #[test]
    fn packing_changes_no_answer() {
        // The packed tree (triangles in leaf order, corners renumbered)
        // against the walk through the input's arrays, to the bit: a soup,
        // a closed mesh whose queries land on shared corners and edges, and
        // a mesh with a corner no face uses.
        let mut rng = Lcg::new(11);
        let mut cases = vec![soup_arrays(300, &mut rng)];
        let m = crate::solids::icosphere(3);
        cases.push((m.positions().to_vec(), m.faces().to_vec()));
        let mut spare = m.positions().to_vec();
        spare.insert(0, [9.0, 9.0, 9.0]);
        cases.push((spare, m.faces().iter().map(|f| f.map(|v| v + 1)).collect()));
        for (positions, faces) in cases {
            let tree = ClosestPoints::new(positions.clone(), faces.clone());
            for k in 0..1500 {
                let spread = [0.5, 3.0, 30.0][k % 3];
                let p = [
                    spread * (rng.next_f64() - 0.3),
                    spread * (rng.next_f64() - 0.3),
                    spread * (rng.next_f64() - 0.5),
                ];
                let packed = tree.closest(p);
                assert_eq!(packed, unpacked_walk(&tree, &positions, &faces, p), "{p:?}");
                let hit = packed.expect("a point");
                let f = faces[hit.face as usize];
                let corners = f.map(|v| positions[v as usize]);
                assert_eq!(tree.corners(hit.face), corners);
            }
        }
    }

    #[test]
    fn triangle_regions() {
        let (a, b, c) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        assert_eq!(closest_on_triangle([-1.0, -1.0, 0.0], a, b, c), [1.0, 0.0, 0.0]);
        assert_eq!(closest_on_triangle([2.0, -0.5, 0.0], a, b, c), [0.0, 1.0, 0.0]);
        assert_eq!(closest_on_triangle([-0.5, 2.0, 3.0], a, b, c), [0.0, 0.0, 1.0]);
        assert_eq!(closest_on_triangle([0.5, -1.0, 0.0], a, b, c), [0.5, 0.5, 0.0]);
        let inside = closest_on_triangle([0.25, 0.25, 2.0], a, b, c);
        assert!((inside[1] - 0.25).abs() < 1e-15 && (inside[2] - 0.25).abs() < 1e-15);
        // A degenerate triangle (all corners equal) gives its corner.
        let d = closest_on_triangle([1.0, 2.0, 3.0], a, a, a);
        assert!((d[0] + d[1] + d[2] - 1.0).abs() < 1e-15);
    }

    #[test]
    fn many_matches_one_by_one_and_stops() {
        let mut rng = Lcg::new(3);
        let tree = random_soup(200, &mut rng);
        let points: Vec<[f64; 3]> = (0..10000)
            .map(|_| [rng.next_f64() * 5.0, rng.next_f64() * 5.0, rng.next_f64()])
            .collect();
        let many = tree.closest_many(&points, &|_, _| true).expect("not stopped");
        for (p, hit) in points.iter().zip(&many) {
            assert_eq!(Some(*hit), tree.closest(*p));
        }
        assert!(tree.closest_many(&points, &|_, _| false).is_none());
        assert_eq!(
            tree.closest_many(&[[f64::NAN, 0.0, 0.0]], &|_, _| true).unwrap()[0].face,
            u32::MAX
        );
        assert!(ClosestPoints::new(vec![], vec![]).closest([0.0; 3]).is_none());
    }

    #[test]
    fn small_calls_split_over_the_workers() {
        // 600 queries on 2 workers: 8 chunks of 75, not one of 600.
        assert_eq!(chunk_size(600, 2), 75);
        assert_eq!(chunk_size(10, 2), MIN_CHUNK);
        assert_eq!(chunk_size(1_000_000, 2), CHUNK);
        assert_eq!(chunk_size(600, 0), 150);
    }
}
