//! The symmetry method for poles and a cut path (thesis 6.2.5, eq. 6.8-6.21).
//!
//! 1. The area-weighted confidence ellipsoid of the face centroids: centre m
//!    (eq. 6.11, 6.13, weights = face areas 6.14) and the eigenvectors of
//!    C = V^T W V (eq. 6.12, 6.15), by [`crate::methods::theta_phi::symmetric_eigen`].
//! 2. Each of the three principal planes through m is scored (below); the
//!    best plane is the candidate symmetry plane (eq. 6.19).
//! 3. R = the vertices within `eps` of that plane (eq. 6.20); H = the subgraph
//!    they induce (eq. 6.21); its largest connected component is kept.
//! 4. Poles by the fast-graph method (6.2.3) inside that component, and the cut
//!    path as a shortest path between them inside it (6.2.5).
//!
//! Scoring a plane with unit normal s through m. The thesis sums the signed
//! distances d_i = s^T (y_i - m) of the centroids (eq. 6.17-6.18),
//! D = sum_i d_i, and takes the plane of least |D|. Two changes, both because
//! a threshold must mean the same on every mesh:
//! * |D| is divided by sum_i |d_i|, giving `balance` in [0, 1]. Raw |D| grows
//!   with the spread along s, so the plane across the thinnest axis would win
//!   on size alone, and no fixed threshold could say "not symmetric".
//! * m is the *area-weighted* mean, so sum_i w_i d_i = 0 for every plane, and
//!   D (unweighted) only measures how unevenly the face *count* is split: on a
//!   uniformly triangulated mesh it is near 0 for every plane, symmetric or
//!   not. We add the area-weighted third moment along s,
//!   `skew` = |sum w_i d_i^3| / sum w_i |d_i|^3 in [0, 1], which vanishes when
//!   the surface is mirror-symmetric in the plane, whatever the triangulation.
//!
//! `score` = max(balance, skew): 0 for a mesh that is mirror-symmetric in the
//! plane, triangulation included. The best plane has the smallest score; ties
//! (within 1e-9) go to the plane across the axis of least variance, which
//! holds the two longest axes and so the longest path between the poles.
//! Moment tests cannot tell a mirror plane from a plane across which a
//! two-fold rotation maps the mesh to itself, and they can miss asymmetries
//! whose moments happen to cancel; the thesis warns of the same (end of 6.2.5).
//!
//! Falling back. The thesis advises another method when no |D| is small
//! enough; here the caller gets the reason and uses the fast-graph method:
//! * [`Fallback::ZeroArea`]: the faces have no area, there is no ellipsoid;
//! * [`Fallback::NotSymmetric`]: the best score exceeds `max_score`;
//! * [`Fallback::ComponentTooSmall`]: the shortest path between the poles
//!   inside the largest component of H has fewer than 4 vertices, too few for
//!   the cut path of k >= 2 that the theta-phi method assumes (6.2.4);
//! * [`Fallback::PolesTooClose`]: that path is shorter than `min_spread`
//!   times the distance between the fast-graph poles. A plane can meet the
//!   surface in several small loops (a helix's tube), and poles on one of
//!   them are close together, which the pole methods of 6.2 set out to avoid.
//!
//! Cost: O(F) for the ellipsoid and the scores, O(N + E) for R and H, two
//! Dijkstra sweeps plus one shortest path on H, O(|H| log |H|) (each allocates
//! O(N) arrays), and the two fast-graph sweeps on the whole mesh for the
//! spread, O(N log N).

use spherify_mesh::dijkstra::{dijkstra_to, EdgeWeights};
use spherify_mesh::vec3::{cross, dot, sub};
use spherify_mesh::Adjacency;

use crate::error::SphereError;
use crate::methods::theta_phi::poles::{self, Poles};
use crate::methods::theta_phi::symmetric_eigen::symmetric_eigen;

/// Default for [`SymmetryParams::max_score`]. On the corpus meshes that are
/// mirror-symmetric by construction (the cow, the fish, a human model, the
/// horse, the scorpion) the best score stays below 0.045; on the hand, the
/// cortex and the octopus it is above 0.06.
pub const DEFAULT_MAX_SCORE: f64 = 0.05;

/// Default for [`SymmetryParams::min_spread`]. The helix tube (whose best
/// plane, a plane of two-fold rotation symmetry, meets the tube in separate
/// small loops) gives 0.05 and an embedding double precision cannot hold;
/// the tentacles shape, the lowest of the others, 0.33; most shapes about 1.
pub const DEFAULT_MIN_SPREAD: f64 = 0.25;

/// Parameters of [`symmetry`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SymmetryParams {
    /// The tolerance of eq. 6.20 in the mesh's units: R = vertices at distance
    /// at most `eps` from the plane. The thesis used eps = 0.3 on its rabbit
    /// without giving the model's size, so there is no scale-free default.
    /// `None` picks the smallest eps for which R holds both ends of every edge
    /// that the plane crosses: then each curve in which the plane meets the
    /// surface lies in one connected piece of H.
    pub eps: Option<f64>,
    /// Fall back when the best plane's score is above this (in [0, 1]).
    pub max_score: f64,
    /// Fall back when the path between the poles inside H is shorter than
    /// this fraction of the distance between the fast-graph poles.
    pub min_spread: f64,
}

impl Default for SymmetryParams {
    fn default() -> Self {
        SymmetryParams { eps: None, max_score: DEFAULT_MAX_SCORE, min_spread: DEFAULT_MIN_SPREAD }
    }
}

/// One principal plane of the confidence ellipsoid, through its centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plane {
    /// Unit normal: an eigenvector of C (eq. 6.15).
    pub normal: [f64; 3],
    /// The eigenvalue of C for `normal` divided by the total area: the
    /// area-weighted variance of the centroids across the plane.
    pub variance: f64,
    /// D of eq. 6.18: the sum of the centroids' signed distances.
    pub signed_sum: f64,
    /// |D| / sum |d_i|, in [0, 1].
    pub balance: f64,
    /// |sum w_i d_i^3| / sum w_i |d_i|^3, in [0, 1].
    pub skew: f64,
    /// max(balance, skew): 0 for a mirror plane.
    pub score: f64,
}

/// Why the symmetry method handed over to the fast-graph method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Fallback {
    ZeroArea,
    NotSymmetric { score: f64, max_score: f64 },
    ComponentTooSmall { component: usize, path: usize },
    PolesTooClose { spread: f64, min_spread: f64 },
}

impl std::fmt::Display for Fallback {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Fallback::ZeroArea => write!(f, "the faces have zero total area, so there is no confidence ellipsoid"),
            Fallback::NotSymmetric { score, max_score } => write!(
                f,
                "no convincing symmetry plane: the best principal plane scores {score:.4} > max_score {max_score}"
            ),
            Fallback::ComponentTooSmall { component, path } => write!(
                f,
                "the vertices near the symmetry plane are too few to hold a cut path: the largest connected piece has {component} vertices and a pole-to-pole path of {path} (at least 4 needed)"
            ),
            Fallback::PolesTooClose { spread, min_spread } => write!(
                f,
                "the poles near the symmetry plane are too close together: the path between them is {spread:.3} of the fast-graph pole distance (min_spread {min_spread})"
            ),
        }
    }
}

/// What the symmetry method found.
#[derive(Debug, Clone, PartialEq)]
pub struct Symmetry {
    /// The area-weighted centroid m (eq. 6.11); NaN for zero area.
    pub centre: [f64; 3],
    /// The three principal planes, by ascending variance; empty for zero area.
    pub planes: Vec<Plane>,
    /// Index into `planes` of the best plane.
    pub chosen: Option<usize>,
    /// The eps of eq. 6.20 that was used (0 when not reached).
    pub eps: f64,
    /// |R|: vertices within eps of the chosen plane.
    pub band: usize,
    /// Vertices in the largest connected component of H.
    pub component: usize,
    /// The poles found inside H (also set when the path was too short).
    pub poles: Option<Poles>,
    /// The length of the path between them inside H over the distance between
    /// the fast-graph poles; NaN when not reached.
    pub spread: f64,
    /// A shortest north-south path inside H; empty on fallback.
    pub path: Vec<u32>,
    pub fallback: Option<Fallback>,
}

/// Face centroids (eq. 6.13) and areas (eq. 6.14).
fn centroids_and_areas(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> (Vec<[f64; 3]>, Vec<f64>) {
    faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            let y = [
                (a[0] + b[0] + c[0]) / 3.0,
                (a[1] + b[1] + c[1]) / 3.0,
                (a[2] + b[2] + c[2]) / 3.0,
            ];
            let n = cross(sub(b, a), sub(c, a));
            (y, 0.5 * dot(n, n).sqrt())
        })
        .unzip()
}

/// The weighted confidence ellipsoid (eq. 6.11-6.15) and the scores of its
/// three principal planes, by ascending variance. `None` for zero total area.
pub fn principal_planes(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
) -> Option<([f64; 3], Vec<Plane>)> {
    let (y, w) = centroids_and_areas(positions, faces);
    let total: f64 = w.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut m = [0.0; 3];
    for (yi, &wi) in y.iter().zip(&w) {
        for k in 0..3 {
            m[k] += wi * yi[k];
        }
    }
    m = m.map(|x| x / total);
    // C / total: the same eigenvectors as eq. 6.12, eigenvalues as variances.
    let mut c = [[0.0; 3]; 3];
    for (yi, &wi) in y.iter().zip(&w) {
        let v = sub(*yi, m);
        for r in 0..3 {
            for s in 0..3 {
                c[r][s] += wi * v[r] * v[s];
            }
        }
    }
    let c = c.map(|row| row.map(|x| x / total));
    let (values, q) = symmetric_eigen(c);
    let planes = (0..3)
        .map(|k| {
            let normal = [q[0][k], q[1][k], q[2][k]];
            let (mut signed, mut unsigned, mut cube, mut abs_cube) = (0.0, 0.0, 0.0, 0.0);
            for (yi, &wi) in y.iter().zip(&w) {
                let d = dot(normal, sub(*yi, m)); // eq. 6.17
                signed += d;
                unsigned += d.abs();
                cube += wi * d * d * d;
                abs_cube += wi * (d * d * d).abs();
            }
            // All centroids in the plane: a mirror plane trivially.
            let ratio = |num: f64, den: f64| if den > 0.0 { num.abs() / den } else { 0.0 };
            let (balance, skew) = (ratio(signed, unsigned), ratio(cube, abs_cube));
            Plane {
                normal,
                variance: values[k],
                signed_sum: signed,
                balance,
                skew,
                score: balance.max(skew),
            }
        })
        .collect();
    Some((m, planes))
}

/// The best plane (eq. 6.19 with the normalised score): least score, ties
/// within 1e-9 to the lowest index (least variance).
fn best_plane(planes: &[Plane]) -> usize {
    let least = planes.iter().map(|p| p.score).fold(f64::INFINITY, f64::min);
    planes.iter().position(|p| p.score <= least + 1e-9).unwrap_or(0)
}

/// The normal of the largest-variance plane other than `chosen`: the longest
/// axis of the ellipsoid that lies in the chosen plane.
fn long_axis_in(planes: &[Plane], chosen: usize) -> [f64; 3] {
    let other = if chosen == 2 { 1 } else { 2 };
    planes[other].normal
}

/// The smallest eps whose band holds both ends of every edge that crosses the
/// plane (ends strictly on opposite sides). The plane meets the surface in
/// such edges and in vertices on the plane (always in the band); along each
/// curve of the intersection, consecutive ones share a triangle, so they are
/// joined by an edge of H or share an end: each curve is connected in H.
fn automatic_eps(graph: &Adjacency, d: &[f64]) -> f64 {
    let mut eps: f64 = 0.0;
    for u in 0..graph.n_vertices() as u32 {
        let du = d[u as usize];
        for &v in graph.neighbors(u) {
            let dv = d[v as usize];
            if v > u && ((du < 0.0 && dv > 0.0) || (du > 0.0 && dv < 0.0)) {
                eps = eps.max(du.abs()).max(dv.abs());
            }
        }
    }
    eps
}

/// H of eq. 6.21 over the same vertex ids: edges of `graph` with both ends in R.
fn induced_subgraph(graph: &Adjacency, in_r: &[bool]) -> Adjacency {
    let mut offsets = Vec::with_capacity(graph.offsets.len());
    let mut neighbors = Vec::new();
    offsets.push(0);
    for v in 0..graph.n_vertices() as u32 {
        if in_r[v as usize] {
            neighbors.extend(graph.neighbors(v).iter().filter(|&&u| in_r[u as usize]));
        }
        offsets.push(neighbors.len());
    }
    Adjacency { offsets, neighbors }
}

/// The vertices of the largest connected component of H (ties: the one with
/// the smallest vertex id); empty when R is.
fn largest_component(h: &Adjacency, in_r: &[bool]) -> Vec<u32> {
    let mut seen = vec![false; in_r.len()];
    let mut best = Vec::new();
    for start in 0..in_r.len() as u32 {
        if !in_r[start as usize] || seen[start as usize] {
            continue;
        }
        seen[start as usize] = true;
        let mut component = vec![start];
        let mut next = 0;
        while let Some(&v) = component.get(next) {
            next += 1;
            for &u in h.neighbors(v) {
                if !seen[u as usize] {
                    seen[u as usize] = true;
                    component.push(u);
                }
            }
        }
        if component.len() > best.len() {
            best = component;
        }
    }
    best
}

/// Refuses an `eps`, `min_spread` or `max_score` outside its range.
fn check_params(params: &SymmetryParams) -> Result<(), SphereError> {
    if let Some(eps) = params.eps {
        if !(eps > 0.0 && eps.is_finite()) {
            return Err(SphereError::InvalidParameter {
                name: "symmetry eps",
                value: format!("{eps}"),
                expected: "a positive finite distance in the mesh's units (or None for automatic)",
            });
        }
    }
    if !(params.min_spread >= 0.0 && params.min_spread.is_finite()) {
        return Err(SphereError::InvalidParameter {
            name: "symmetry min_spread",
            value: format!("{}", params.min_spread),
            expected: "a finite number >= 0",
        });
    }
    if !(params.max_score >= 0.0 && params.max_score <= 1.0) {
        return Err(SphereError::InvalidParameter {
            name: "symmetry max_score",
            value: format!("{}", params.max_score),
            expected: "a number in [0, 1]",
        });
    }
    Ok(())
}

/// Where the two sweeps on the band start: the vertex of `component` farthest
/// along the longest in-plane axis of plane `k` (the smallest id on a tie).
///
/// The thesis starts the two sweeps at an arbitrary vertex. But H is mostly
/// a closed band (where the plane meets the surface), on which every vertex
/// has an antipode, so the start decides where the poles go. Starting at
/// the end of the longest in-plane axis of the ellipsoid puts the poles
/// near the two ends of that axis: far apart in space, not by numbering.
fn start_vertex(
    positions: &[[f64; 3]],
    centre: [f64; 3],
    planes: &[Plane],
    k: usize,
    component: &[u32],
) -> Option<u32> {
    let axis = long_axis_in(planes, k);
    let reach = |v: u32| dot(axis, sub(positions[v as usize], centre));
    component.iter().copied().reduce(|a, b| {
        if reach(b) > reach(a) || (reach(b) == reach(a) && b < a) {
            b
        } else {
            a
        }
    })
}

/// The symmetry method (thesis 6.2.5) on a closed mesh with vertex graph
/// `graph`. Never fails on a valid mesh: when no plane will do, the result
/// says why in `fallback` and the caller picks poles another way. Errors only
/// for an `eps` that is not a positive finite number.
pub fn symmetry(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    graph: &Adjacency,
    params: &SymmetryParams,
) -> Result<Symmetry, SphereError> {
    check_params(params)?;
    let mut result = Symmetry {
        centre: [f64::NAN; 3],
        planes: Vec::new(),
        chosen: None,
        eps: 0.0,
        band: 0,
        component: 0,
        poles: None,
        spread: f64::NAN,
        path: Vec::new(),
        fallback: None,
    };
    let Some((centre, planes)) = principal_planes(positions, faces) else {
        result.fallback = Some(Fallback::ZeroArea);
        return Ok(result);
    };
    let k = best_plane(&planes);
    let plane = planes[k];
    (result.centre, result.planes, result.chosen) = (centre, planes, Some(k));
    if plane.score > params.max_score {
        result.fallback =
            Some(Fallback::NotSymmetric { score: plane.score, max_score: params.max_score });
        return Ok(result);
    }

    // Eq. 6.20 with <= instead of <, so that the automatic eps (attained by
    // a vertex) keeps that vertex.
    let d: Vec<f64> = positions.iter().map(|&x| dot(plane.normal, sub(x, centre))).collect();
    let eps = params.eps.unwrap_or_else(|| automatic_eps(graph, &d));
    let in_r: Vec<bool> = d.iter().map(|x| x.abs() <= eps).collect();
    result.eps = eps;
    result.band = in_r.iter().filter(|&&r| r).count();
    let h = induced_subgraph(graph, &in_r);
    let too_small = |component, path| Fallback::ComponentTooSmall { component, path };
    let component = largest_component(&h, &in_r);
    let size = component.len();
    result.component = size;
    let Some(start) = start_vertex(positions, centre, &result.planes, k, &component) else {
        result.fallback = Some(too_small(0, 0));
        return Ok(result);
    };

    let lengths = EdgeWeights::Length(positions);
    let found = poles::fast_graph(&h, start, lengths);
    let path = found.and_then(|p| dijkstra_to(&h, p.north, p.south, lengths));
    result.poles = found;
    let (length, path) = match path {
        Some((length, path)) if path.len() >= 4 => (length, path),
        Some((_, path)) => {
            result.fallback = Some(too_small(size, path.len()));
            return Ok(result);
        }
        None => {
            result.fallback = Some(too_small(size, 0));
            return Ok(result);
        }
    };
    // Poles close together make the theta-phi map crowd the rest of the mesh
    // into a sliver (6.2: "the idea is to avoid choosing two vertices close
    // to one another"). The fast-graph distance is the yardstick.
    let reference = poles::fast_graph(graph, 0, lengths).map_or(0.0, |p| p.distance);
    result.spread = if reference > 0.0 { length / reference } else { f64::INFINITY };
    if result.spread < params.min_spread {
        result.fallback =
            Some(Fallback::PolesTooClose { spread: result.spread, min_spread: params.min_spread });
        return Ok(result);
    }
    result.path = path;
    Ok(result)
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::{HalfEdgeMesh, Mesh};

    /// The octahedron subdivided `levels` times with midpoints pushed onto the
    /// unit sphere: mirror-symmetric in the three coordinate planes,
    /// triangulation included.
    fn octasphere(levels: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let m = spherify_mesh::solids::octasphere(levels);
        (m.positions().to_vec(), m.faces().to_vec())
    }

    /// Mirror-symmetric in y = 0 only: x and z are bent by even functions of
    /// each other, and y is the middle axis, so no ordering rule finds it.
    fn one_mirror_plane(levels: usize) -> Mesh {
        let (p, f) = octasphere(levels);
        let p = p
            .into_iter()
            .map(|[x, y, z]| [1.6 * x + 0.4 * z * z, y, 0.7 * z + 0.3 * x * x])
            .collect();
        Mesh::new(p, f).unwrap()
    }

    fn run(mesh: &Mesh, params: &SymmetryParams) -> Symmetry {
        let graph = HalfEdgeMesh::new(mesh).unwrap().adjacency();
        symmetry(mesh.positions(), mesh.faces(), &graph, params).unwrap()
    }

    #[test]
    fn finds_the_only_mirror_plane() {
        let mesh = one_mirror_plane(4);
        let sym = run(&mesh, &SymmetryParams::default());
        assert_eq!(sym.fallback, None, "{sym:?}");
        let plane = sym.planes[sym.chosen.unwrap()];
        assert!((plane.normal[1].abs() - 1.0).abs() < 1e-12, "{:?}", plane.normal);
        assert!(plane.score < 1e-12, "{plane:?}");
        assert!(sym.centre[1].abs() < 1e-12);
        // The other two principal planes are clearly not mirror planes.
        for (k, other) in sym.planes.iter().enumerate() {
            if Some(k) != sym.chosen {
                assert!(other.score > 0.05, "{other:?}");
            }
        }
        // Poles and the whole path lie within eps of the plane, in one piece of H.
        let poles = sym.poles.unwrap();
        let y = |v: u32| mesh.positions()[v as usize][1] - sym.centre[1];
        assert!(y(poles.north).abs() <= sym.eps && y(poles.south).abs() <= sym.eps);
        assert!(sym.path.len() >= 4);
        assert_eq!((sym.path[0], *sym.path.last().unwrap()), (poles.north, poles.south));
        let graph = HalfEdgeMesh::new(&mesh).unwrap().adjacency();
        for w in sym.path.windows(2) {
            assert!(graph.neighbors(w[0]).contains(&w[1]));
        }
        assert!(sym.path.iter().all(|&v| y(v).abs() <= sym.eps));
        // The automatic band is narrow: a small fraction of the vertices.
        assert!(sym.band < mesh.n_vertices() / 4, "{} of {}", sym.band, mesh.n_vertices());
        // The poles are near the two ends of the long (x) axis.
        let x = |v: u32| mesh.positions()[v as usize][0];
        assert!(
            x(poles.north).min(x(poles.south)) < -1.0 && x(poles.north).max(x(poles.south)) > 1.0
        );
    }

    #[test]
    fn ellipsoid_cuts_through_the_two_longest_axes() {
        let (p, f) = octasphere(3);
        let p = p.into_iter().map(|[x, y, z]| [0.6 * x, 0.4 * y, z]).collect();
        let mesh = Mesh::new(p, f).unwrap();
        let sym = run(&mesh, &SymmetryParams::default());
        assert_eq!(sym.fallback, None);
        // Every principal plane is a mirror plane; the tie goes to the plane
        // across the thinnest axis (y), which holds z and x.
        let plane = sym.planes[sym.chosen.unwrap()];
        assert!((plane.normal[1] - 1.0).abs() < 1e-12, "{plane:?}");
    }

    #[test]
    fn explicit_eps_bounds_the_band() {
        let mesh = one_mirror_plane(3);
        let wide = run(&mesh, &SymmetryParams { eps: Some(0.3), ..Default::default() });
        let narrow = run(&mesh, &SymmetryParams { eps: Some(0.05), ..Default::default() });
        assert_eq!(wide.eps, 0.3);
        let inside = |eps: f64| {
            mesh.positions().iter().filter(|x| (x[1] - wide.centre[1]).abs() <= eps).count()
        };
        assert_eq!(wide.band, inside(0.3));
        assert_eq!(narrow.band, inside(0.05));
        assert!(narrow.band < wide.band);
        // A band with only the vertices exactly on the plane (the subdivided
        // equator) still holds the cut path.
        let thin = run(&mesh, &SymmetryParams { eps: Some(1e-12), ..Default::default() });
        assert_eq!((thin.band, thin.component, thin.fallback), (32, 32, None));
        let graph = HalfEdgeMesh::new(&mesh).unwrap().adjacency();
        let bad = SymmetryParams { eps: Some(-1.0), ..Default::default() };
        assert!(symmetry(mesh.positions(), mesh.faces(), &graph, &bad).is_err());
    }

    #[test]
    fn too_few_vertices_near_the_plane_fall_back() {
        // The octahedron: each principal plane holds a 4-cycle, whose two
        // farthest vertices are joined by a path of only 3.
        let (p, f) = octasphere(0);
        let sym = run(&Mesh::new(p, f).unwrap(), &SymmetryParams::default());
        assert_eq!(sym.fallback, Some(Fallback::ComponentTooSmall { component: 4, path: 3 }));
        assert!(sym.path.is_empty());
    }

    #[test]
    fn asymmetric_mesh_falls_back() {
        // Three bumps of different heights in general directions.
        let (p, f) = octasphere(3);
        let bumps = [([0.8, 0.5, 0.3], 0.9), ([-0.2, 0.9, -0.4], 0.5), ([-0.6, -0.3, 0.7], 0.3)];
        let p: Vec<[f64; 3]> = p
            .into_iter()
            .map(|x| {
                let mut r = 1.0;
                for (dir, height) in bumps {
                    let dir: [f64; 3] = dir;
                    let cos = dot(x, dir) / dot(dir, dir).sqrt();
                    r += height * cos.max(0.0).powi(8);
                }
                x.map(|c| c * r)
            })
            .collect();
        let mesh = Mesh::new(p, f).unwrap();
        let sym = run(&mesh, &SymmetryParams::default());
        match sym.fallback {
            Some(Fallback::NotSymmetric { score, .. }) => assert!(score > DEFAULT_MAX_SCORE),
            other => panic!("expected NotSymmetric, got {other:?}"),
        }
        assert!(sym.path.is_empty());
        // Accepting any score takes the best plane anyway.
        let lax = run(&mesh, &SymmetryParams { max_score: 1.0, ..Default::default() });
        assert_eq!(lax.fallback, None);
        assert!(lax.spread > DEFAULT_MIN_SPREAD);
        // Demanding a path far longer than the fast-graph distance: too close.
        let far = run(&mesh, &SymmetryParams { max_score: 1.0, min_spread: 10.0, eps: None });
        assert!(matches!(far.fallback, Some(Fallback::PolesTooClose { .. })), "{far:?}");
        assert_eq!(far.spread, lax.spread);
        assert!(far.path.is_empty());
    }

    #[test]
    fn zero_area_falls_back() {
        let p = vec![[0.0; 3]; 4];
        let f = vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];
        let graph = Adjacency::from_faces(4, &f);
        let sym = symmetry(&p, &f, &graph, &SymmetryParams::default()).unwrap();
        assert_eq!(sym.fallback, Some(Fallback::ZeroArea));
    }
}
