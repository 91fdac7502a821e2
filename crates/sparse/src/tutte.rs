//! Generalised 2D Tutte embedding of a disk (thesis 4.3, Tutte 1963, Floater 1997).
//!
//! The boundary loop is pinned to a convex polygon and every interior vertex is
//! placed at the weighted average of its neighbours:
//! sum_j w_ij (u_i - u_j) = 0 for interior i (thesis eq. 4.25-4.27 with the rows
//! multiplied by wdeg(i), i.e. the symmetric form B = D A of eq. 4.53). With
//! positive weights and a convex boundary the result is a straight-line embedding
//! without flipped triangles (thesis Thm. 4.5-4.7) in exact arithmetic; after the
//! floating-point solve every triangle is checked again with an exact predicate.

use rayon::prelude::*;
use spherify_mesh::predicates::{orient2d, Sign};
use spherify_mesh::{validate, HalfEdgeMesh, Mesh, TopologyError, TopologyProblem};

use crate::csr::CsrMatrix;
use crate::error::SparseError;
use crate::solve::{solve, SolveInfo, SolveParams};
use crate::weights::{half_edge_weights, BadWeight, Weights};
use crate::SolverKind;

/// Where the boundary loop goes.
#[derive(Debug, Clone, PartialEq)]
pub enum BoundaryShape {
    /// Regular polygon on the unit circle (thesis eq. 4.22).
    Circle,
    /// Unit circle, spaced by boundary edge length.
    CircleByLength,
    /// A convex polygon given by the caller, one point per boundary vertex in the
    /// order of [`boundary_loop`], counter-clockwise.
    Polygon(Vec<[f64; 2]>),
}

/// Everything [`tutte`] needs to know.
#[derive(Debug, Clone)]
pub struct TutteParams {
    pub weights: Weights,
    pub boundary: BoundaryShape,
    pub solver: SolverKind,
    pub solve: SolveParams,
}

impl Default for TutteParams {
    fn default() -> Self {
        TutteParams {
            weights: Weights::Uniform,
            boundary: BoundaryShape::Circle,
            solver: SolverKind::Auto,
            solve: SolveParams::default(),
        }
    }
}

/// A 2D embedding and its certificate.
#[derive(Debug, Clone)]
pub struct TutteEmbedding {
    /// One point per vertex.
    pub uv: Vec<[f64; 2]>,
    /// The boundary loop, in the order its points were placed.
    pub boundary: Vec<u32>,
    pub info: SolveInfo,
    /// Faces whose exact orientation in the plane is clockwise, and exactly zero.
    pub inverted: InvertedFaces,
    /// Edges (counted per direction) with a negative weight (cotangent weights only).
    pub negative_weights: usize,
}

/// Faces that are not strictly counter-clockwise in the plane.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct InvertedFaces {
    pub flipped: Vec<u32>,
    pub degenerate: Vec<u32>,
}

impl InvertedFaces {
    pub fn is_empty(&self) -> bool {
        self.flipped.is_empty() && self.degenerate.is_empty()
    }
}

/// Why a Tutte embedding could not be computed.
#[derive(Debug, Clone, thiserror::Error)]
pub enum TutteError {
    #[error(transparent)]
    Topology(#[from] TopologyError),
    #[error(
        "the boundary polygon has {got} points, but the boundary loop has {expected} vertices"
    )]
    BoundaryLength { got: usize, expected: usize },
    #[error("the boundary polygon has a non-finite coordinate at point {index}")]
    BoundaryNotFinite { index: usize },
    #[error("the boundary polygon is not convex and counter-clockwise: {reason}")]
    BoundaryNotConvex { reason: String },
    #[error(transparent)]
    Weight(#[from] BadWeight),
    /// Conjugate gradients need a symmetric matrix, and mean-value weights do
    /// not give one.
    #[error("the {solver} solver needs symmetric weights, but mean-value weights are not symmetric: use the direct (auto) or Gauss-Seidel solver")]
    SolverNeedsSymmetricWeights { solver: SolverKind },
    /// An iterative solver ran out of iterations; `uv` is its last iterate
    /// with the fixed vertices in place, for inspection or a restart.
    #[error("the {solver} solver did not converge in {iterations} iterations (relative residual {residual:e})")]
    NoConvergence { solver: SolverKind, iterations: usize, residual: f64, uv: Vec<[f64; 2]> },
    #[error(transparent)]
    Solve(#[from] SparseError),
}

/// The boundary loop of a disk, counter-clockwise: in the direction of the
/// boundary edges of its faces (faces are counter-clockwise, so the disk lies
/// to the left). Raises `NotDisk` unless there is exactly one loop and
/// V - E + F = 1 (thesis Cor. 2.7 b).
pub fn boundary_loop(mesh: &Mesh, he: &HalfEdgeMesh) -> Result<Vec<u32>, TopologyError> {
    let loops = he.boundary_loops();
    let euler = he.n_vertices() as i64 - he.n_edges() as i64 + he.n_faces() as i64;
    if loops.len() != 1 || euler != 1 {
        return Err(TopologyError {
            problem: TopologyProblem::NotDisk { loops: loops.len(), euler },
            report: Box::new(validate::check(mesh)),
        });
    }
    // Boundary half-edges run against their faces' direction: reverse them.
    let mut cycle = loops.into_iter().next().unwrap_or_default();
    cycle.reverse();
    // Start at the smallest vertex id so the result does not depend on storage order.
    if let Some(start) = cycle.iter().enumerate().min_by_key(|(_, &v)| v).map(|(i, _)| i) {
        cycle.rotate_left(start);
    }
    Ok(cycle)
}

/// Tutte embedding of a disk-topology mesh with the given weights and boundary.
pub fn tutte(mesh: &Mesh, params: &TutteParams) -> Result<TutteEmbedding, TutteError> {
    if params.weights == Weights::MeanValue
        && matches!(params.solver, SolverKind::CgIc0 | SolverKind::CgJacobi)
    {
        return Err(TutteError::SolverNeedsSymmetricWeights { solver: params.solver });
    }
    let he = HalfEdgeMesh::new(mesh)?;
    let boundary = boundary_loop(mesh, &he)?;
    let points = boundary_points(mesh.positions(), &boundary, &params.boundary)?;
    let weights = half_edge_weights(mesh.positions(), &he, params.weights)?;
    let negative_weights = weights.iter().filter(|&&w| w < 0.0).count();
    let mut fixed = vec![None; mesh.n_vertices()];
    for (&v, &p) in boundary.iter().zip(&points) {
        fixed[v as usize] = Some(p);
    }
    let (uv, info) = embed_with_fixed(&he, &weights, &fixed, params.solver, &params.solve)?;
    let inverted = inverted_faces(mesh.faces(), &uv);
    Ok(TutteEmbedding { uv, boundary, info, inverted, negative_weights })
}

/// The general solve behind [`tutte`]: vertices with `fixed[v] = Some(p)` stay at
/// `p`, every other vertex satisfies sum_j w_ij (u_i - u_j) = 0 with the
/// half-edge weights `w` (row of the tail, column of the head). The x and y
/// systems share one matrix and are solved together.
pub fn embed_with_fixed(
    he: &HalfEdgeMesh,
    weights: &[f64],
    fixed: &[Option<[f64; 2]>],
    solver: SolverKind,
    params: &SolveParams,
) -> Result<(Vec<[f64; 2]>, SolveInfo), TutteError> {
    let system = FixedSystem::assemble(he, weights, fixed)?;
    let mut uv = system.fixed_positions(fixed);
    if system.free.is_empty() {
        let info =
            SolveInfo { solver: SolverKind::Direct, iterations: 0, residual: 0.0, seconds: 0.0 };
        return Ok((uv, info));
    }
    let (solution, info) = match solve(&system.matrix, &system.rhs, solver, params) {
        Ok(solved) => solved,
        Err(SparseError::NoConvergence { iterations, residual, last }) => {
            scatter(&mut uv, &system.free, &last);
            return Err(TutteError::NoConvergence { solver, iterations, residual, uv });
        }
        Err(other) => return Err(other.into()),
    };
    scatter(&mut uv, &system.free, &solution);
    Ok((uv, info))
}

/// The linear system of a Tutte embedding with some vertices fixed: one row
/// sum_j w_ij (u_i - u_j) = 0 per free vertex i (thesis eq. 4.27 in the form
/// B = D A of eq. 4.53), and two right-hand sides (x and y) carrying the fixed
/// neighbours.
#[derive(Debug, Clone)]
pub struct FixedSystem {
    pub matrix: CsrMatrix,
    pub rhs: Vec<Vec<f64>>,
    /// The vertex of each unknown, in order.
    pub free: Vec<u32>,
}

impl FixedSystem {
    /// Assembles the system; weights are per half-edge (row of the tail).
    pub fn assemble(
        he: &HalfEdgeMesh,
        weights: &[f64],
        fixed: &[Option<[f64; 2]>],
    ) -> Result<FixedSystem, TutteError> {
        FixedSystem::assemble_rows(&fixed[..he.n_vertices()], |i, edges| {
            edges.extend(he.rotation(i).map(|h| (he.head(h), weights[h as usize])));
        })
    }

    /// Assembles the system from each free vertex's edges: `edges(i, out)`
    /// appends (j, w_ij) for every neighbour j of vertex i to `out`, in the
    /// order the row's sums are to run (for [`FixedSystem::assemble`],
    /// rotation order). The same edges in the same order give the same
    /// system bit for bit, however they are found. `fixed` has one entry per
    /// vertex.
    pub fn assemble_rows<E>(fixed: &[Option<[f64; 2]>], edges: E) -> Result<FixedSystem, TutteError>
    where
        E: Fn(u32, &mut Vec<(u32, f64)>) + Sync,
    {
        let n = fixed.len();
        let mut unknown = vec![u32::MAX; n];
        let mut free = Vec::new();
        for v in 0..n {
            if fixed[v].is_none() {
                unknown[v] = free.len() as u32;
                free.push(v as u32);
            }
        }
        // Row by row in parallel; each row's sums run in the order given, as
        // they always have, so the system is the same bit for bit. The row's
        // edges are listed in `entries` and overwritten in place by its
        // off-diagonal entries (at most one per edge).
        let (matrix, fixed_sums) = CsrMatrix::from_rows(free.len(), free.len(), |row, entries| {
            let i = free[row];
            edges(i, entries);
            let (mut diagonal, mut x, mut y) = (0.0, 0.0, 0.0);
            let mut kept = 0;
            for e in 0..entries.len() {
                let (j, w) = entries[e];
                diagonal += w;
                match fixed[j as usize] {
                    Some(p) => {
                        x += w * p[0];
                        y += w * p[1];
                    }
                    None => {
                        entries[kept] = (unknown[j as usize], -w);
                        kept += 1;
                    }
                }
            }
            entries.truncate(kept);
            entries.push((row as u32, diagonal));
            [x, y]
        })?;
        let rhs = vec![
            fixed_sums.iter().map(|s| s[0]).collect(),
            fixed_sums.iter().map(|s| s[1]).collect(),
        ];
        Ok(FixedSystem { matrix, rhs, free })
    }

    /// Positions with the fixed vertices in place and the free ones at the origin.
    pub fn fixed_positions(&self, fixed: &[Option<[f64; 2]>]) -> Vec<[f64; 2]> {
        fixed.iter().map(|p| p.unwrap_or([0.0, 0.0])).collect()
    }

    /// Writes solutions (x, y) of the free vertices into `uv`.
    pub fn scatter(&self, uv: &mut [[f64; 2]], solution: &[Vec<f64>]) {
        scatter(uv, &self.free, solution)
    }
}

/// Writes the x and y solutions of the free vertices into `uv`.
fn scatter(uv: &mut [[f64; 2]], free: &[u32], solution: &[Vec<f64>]) {
    if let [x, y] = solution {
        for (k, &v) in free.iter().enumerate() {
            uv[v as usize] = [x[k], y[k]];
        }
    }
}

/// Faces that are clockwise or degenerate in the plane, decided exactly, in
/// increasing order. The faces are checked in parallel blocks (theta-phi
/// checks every face after each refinement step).
pub fn inverted_faces(faces: &[[u32; 3]], uv: &[[f64; 2]]) -> InvertedFaces {
    const FACES_PER_TASK: usize = 16_384;
    let blocks: Vec<InvertedFaces> = faces
        .par_chunks(FACES_PER_TASK)
        .enumerate()
        .map(|(block, chunk)| {
            let mut out = InvertedFaces::default();
            for (k, &[a, b, c]) in chunk.iter().enumerate() {
                let f = (block * FACES_PER_TASK + k) as u32;
                match orient2d(uv[a as usize], uv[b as usize], uv[c as usize]) {
                    Sign::Positive => {}
                    Sign::Negative => out.flipped.push(f),
                    Sign::Zero => out.degenerate.push(f),
                }
            }
            out
        })
        .collect();
    let mut out = InvertedFaces::default();
    for block in blocks {
        out.flipped.extend(block.flipped);
        out.degenerate.extend(block.degenerate);
    }
    out
}

/// Points for the boundary loop: a circle (evenly or by edge length) or the
/// caller's polygon, which must be convex and counter-clockwise.
fn boundary_points(
    positions: &[[f64; 3]],
    boundary: &[u32],
    shape: &BoundaryShape,
) -> Result<Vec<[f64; 2]>, TutteError> {
    let m = boundary.len();
    let on_circle = |t: &[f64]| t.iter().map(|&a| [a.cos(), a.sin()]).collect::<Vec<_>>();
    match shape {
        BoundaryShape::Circle => {
            let step = std::f64::consts::TAU / m as f64;
            Ok(on_circle(&(0..m).map(|k| step * k as f64).collect::<Vec<_>>()))
        }
        BoundaryShape::CircleByLength => {
            let length = |k: usize| {
                let (a, b) =
                    (positions[boundary[k] as usize], positions[boundary[(k + 1) % m] as usize]);
                ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
            };
            let lengths: Vec<f64> = (0..m).map(length).collect();
            let total: f64 = lengths.iter().sum();
            if total.is_nan() || total <= 0.0 || lengths.iter().any(|&l| l <= 0.0) {
                // Zero-length boundary edges would stack two vertices on one point.
                return Err(TutteError::BoundaryNotConvex {
                    reason: "the boundary has a zero-length edge, so spacing by length would merge two points".into(),
                });
            }
            let mut angle = 0.0;
            let mut t = Vec::with_capacity(m);
            for l in &lengths {
                t.push(std::f64::consts::TAU * angle / total);
                angle += l;
            }
            Ok(on_circle(&t))
        }
        BoundaryShape::Polygon(points) => {
            if points.len() != m {
                return Err(TutteError::BoundaryLength { got: points.len(), expected: m });
            }
            if let Some(index) = points.iter().position(|p| !(p[0].is_finite() && p[1].is_finite()))
            {
                return Err(TutteError::BoundaryNotFinite { index });
            }
            check_convex(points)?;
            Ok(points.clone())
        }
    }
}

/// A convex, counter-clockwise polygon that winds once: no clockwise turn
/// (exact), no repeated point, and total turning of one full circle. Collinear
/// points on a side are allowed (the theta-phi rectangle has them).
pub fn check_convex(points: &[[f64; 2]]) -> Result<(), TutteError> {
    let m = points.len();
    let fail = |reason: String| Err(TutteError::BoundaryNotConvex { reason });
    if m < 3 {
        return fail(format!("it has {m} points; a polygon needs at least 3"));
    }
    let mut turning = 0.0;
    let mut strictly_left = 0;
    for k in 0..m {
        let (a, b, c) = (points[(k + m - 1) % m], points[k], points[(k + 1) % m]);
        if a == b {
            return fail(format!("points {} and {k} coincide", (k + m - 1) % m));
        }
        match orient2d(a, b, c) {
            Sign::Negative => return fail(format!("it turns clockwise at point {k}")),
            Sign::Positive => strictly_left += 1,
            Sign::Zero => {
                // Collinear: must go on, not double back.
                let forward = (b[0] - a[0]) * (c[0] - b[0]) + (b[1] - a[1]) * (c[1] - b[1]);
                if forward <= 0.0 {
                    return fail(format!("it doubles back at point {k}"));
                }
            }
        }
        let (u, v) = ([b[0] - a[0], b[1] - a[1]], [c[0] - b[0], c[1] - b[1]]);
        turning += (u[0] * v[1] - u[1] * v[0]).atan2(u[0] * v[0] + u[1] * v[1]);
    }
    if strictly_left < 3 {
        return fail("all points lie on one line".into());
    }
    // The turning is a whole number of turns; anything but one means it winds twice or more.
    if (turning / std::f64::consts::TAU - 1.0).abs() > 0.25 {
        return fail(format!(
            "it winds {:.0} times around its inside",
            turning / std::f64::consts::TAU
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An n x n grid of squares, each split into two triangles, with a bump in z
    /// so that the weights differ: a disk with 4n boundary vertices.
    fn grid(n: usize) -> Mesh {
        let mut p = Vec::new();
        for i in 0..=n {
            for j in 0..=n {
                let (x, y) = (i as f64 / n as f64, j as f64 / n as f64);
                p.push([x, y * (1.0 + x), (3.0 * x).sin() * y]);
            }
        }
        let at = |i: usize, j: usize| (i * (n + 1) + j) as u32;
        let mut f = Vec::new();
        for i in 0..n {
            for j in 0..n {
                f.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
                f.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
            }
        }
        Mesh::new(p, f).unwrap()
    }

    #[test]
    fn every_positive_weight_gives_a_flip_free_embedding() {
        let mesh = grid(12);
        for weights in [
            Weights::Uniform,
            Weights::Chord { rho: -1.0 },
            Weights::Chord { rho: 1.0 },
            Weights::MeanValue,
        ] {
            for boundary in [BoundaryShape::Circle, BoundaryShape::CircleByLength] {
                let params =
                    TutteParams { weights, boundary: boundary.clone(), ..TutteParams::default() };
                let e = tutte(&mesh, &params).unwrap();
                assert!(e.inverted.is_empty(), "{weights:?} {boundary:?}: {:?}", e.inverted);
                assert_eq!(e.boundary.len(), 48);
                for &v in &e.boundary {
                    let [x, y] = e.uv[v as usize];
                    assert!((x * x + y * y - 1.0).abs() < 1e-12);
                }
                assert!(e.info.residual < 1e-9);
            }
        }
    }

    #[test]
    fn uniform_weights_put_each_interior_vertex_at_its_neighbours_centroid() {
        let mesh = grid(8);
        let he = HalfEdgeMesh::new(&mesh).unwrap();
        let e = tutte(&mesh, &TutteParams::default()).unwrap();
        for v in 0..mesh.n_vertices() as u32 {
            if he.is_boundary_vertex(v) {
                continue;
            }
            let ring = he.vertex_ring(v);
            let mut c = [0.0, 0.0];
            for &u in &ring {
                c[0] += e.uv[u as usize][0] / ring.len() as f64;
                c[1] += e.uv[u as usize][1] / ring.len() as f64;
            }
            let [x, y] = e.uv[v as usize];
            assert!((x - c[0]).abs() < 1e-10 && (y - c[1]).abs() < 1e-10);
        }
    }

    #[test]
    fn solvers_agree() {
        let mesh = grid(10);
        let run = |solver| {
            let params = TutteParams {
                solver,
                weights: Weights::Chord { rho: -1.0 },
                ..TutteParams::default()
            };
            tutte(&mesh, &params).unwrap().uv
        };
        let reference = run(SolverKind::Direct);
        for solver in
            [SolverKind::Auto, SolverKind::CgJacobi, SolverKind::CgIc0, SolverKind::GaussSeidel]
        {
            let uv = run(solver);
            let worst = uv
                .iter()
                .zip(&reference)
                .map(|(a, b)| (a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
                .fold(0.0, f64::max);
            assert!(worst < 1e-8, "{solver:?} differs by {worst}");
        }
    }

    #[test]
    fn user_polygon_must_be_convex_and_the_right_length() {
        let mesh = grid(2); // 8 boundary vertices
        let square: Vec<[f64; 2]> =
            vec![[0., 0.], [1., 0.], [2., 0.], [2., 1.], [2., 2.], [1., 2.], [0., 2.], [0., 1.]];
        let params = |points: Vec<[f64; 2]>| TutteParams {
            boundary: BoundaryShape::Polygon(points),
            ..TutteParams::default()
        };
        let e = tutte(&mesh, &params(square.clone())).unwrap();
        assert!(e.inverted.is_empty());
        let mut dented = square.clone();
        dented[1] = [1.0, 0.5];
        assert!(matches!(tutte(&mesh, &params(dented)), Err(TutteError::BoundaryNotConvex { .. })));
        let mut clockwise = square.clone();
        clockwise.reverse();
        assert!(matches!(
            tutte(&mesh, &params(clockwise)),
            Err(TutteError::BoundaryNotConvex { .. })
        ));
        assert!(matches!(
            tutte(&mesh, &params(square[..7].to_vec())),
            Err(TutteError::BoundaryLength { got: 7, expected: 8 })
        ));
    }

    #[test]
    fn closed_and_annulus_meshes_are_not_disks() {
        let tetra = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
        .unwrap();
        let err = tutte(&tetra, &TutteParams::default()).unwrap_err();
        assert!(matches!(
            err,
            TutteError::Topology(TopologyError {
                problem: TopologyProblem::NotDisk { loops: 0, euler: 2 },
                ..
            })
        ));
        // The message says what the mesh has, not only what a disk would.
        assert!(err.to_string().contains("it has 0 boundary loops and Euler characteristic 2"));
        // The grid without its middle square's two triangles: two boundary loops.
        let mesh = grid(3);
        let faces: Vec<[u32; 3]> =
            mesh.faces().iter().enumerate().filter(|(f, _)| *f / 2 != 4).map(|(_, &f)| f).collect();
        let annulus = Mesh::new(mesh.positions().to_vec(), faces).unwrap();
        let err = tutte(&annulus, &TutteParams::default()).unwrap_err();
        assert!(err.to_string().contains("it has 2 boundary loops and Euler characteristic 0"));
    }

    #[test]
    fn gauss_seidel_out_of_iterations_returns_the_last_iterate() {
        let mesh = grid(10);
        let mut params = TutteParams { solver: SolverKind::GaussSeidel, ..TutteParams::default() };
        params.solve.max_iter = 2;
        match tutte(&mesh, &params) {
            Err(err @ TutteError::NoConvergence { .. }) => {
                // The solver by the name the caller gives it.
                assert!(err.to_string().starts_with("the gauss_seidel solver did not converge"));
                let TutteError::NoConvergence { iterations, uv, .. } = err else { unreachable!() };
                assert!(iterations >= 2);
                assert_eq!(uv.len(), mesh.n_vertices());
            }
            other => panic!("expected NoConvergence, got {other:?}"),
        }
    }
}
