//! How much a map from a mesh to the sphere distorts it: angles, conformality,
//! areas, stretch (Sander, Snyder, Gortler and Hoppe 2001, "Texture mapping
//! progressive meshes") and the spread of edge lengths the thesis proposes as a
//! quality parameter (9.3.1).
//!
//! Each face is compared as a pair of flat triangles: the mesh triangle
//! `Q = (x_i, x_j, x_k)` and the triangle `P = (v_i, v_j, v_k)` of its images
//! joined by chords (straight segments through the ball, not great-circle
//! arcs). The points are used as given, so any per-vertex positions can be
//! compared with the mesh, on the sphere or not. Per face, `T` is the linear
//! map taking `P` to `Q`, written in local 2D frames (each triangle laid in
//! its own plane with its first edge on the first axis), with singular values
//! `sigma1 >= sigma2`; `sigma1 sigma2 = area(Q) / area(P)`.
//! The measures are unsigned: a face mirrored by the map counts as
//! undistorted; whether a map is a valid embedding is
//! [`crate::certificate::validity::check_sphere`]'s question.
//!
//! A face is degenerate when either triangle has (numerically) zero area:
//! twice its area at most [`DEGENERATE_RELATIVE`] times its longest edge
//! squared, or a non-finite value. Such faces have no angles or singular
//! values to speak of; they are counted in [`Quality::degenerate_faces`] and
//! left out of every face measure and of the area totals used to normalise.

use rayon::prelude::*;
use spherify_mesh::edge_table::corner_endpoints;
use spherify_mesh::vec3::{cross, dot, norm, sub};
use spherify_mesh::Mesh;

/// A triangle is degenerate when twice its area is at most this times its
/// longest edge squared, i.e. its smallest height is below about 1e-12 of its
/// longest edge: the cross product that measures it carries rounding errors of
/// a few 1e-16 times the edge lengths squared, so thinner triangles have
/// angles and areas that are mostly rounding.
pub const DEGENERATE_RELATIVE: f64 = 1e-12;

/// The distortion measures of [`quality`]; see the Python docstring of
/// `spherify.quality` for the formulas.
#[derive(Debug, Clone, PartialEq)]
pub struct Quality {
    pub n_faces: usize,
    /// Faces left out of the face measures (zero area on either side).
    pub degenerate_faces: usize,
    /// Mean and max over corners of |angle on the mesh - angle on the sphere triangle|, degrees.
    pub angle_mean_deg: f64,
    pub angle_max_deg: f64,
    /// Mean and max over faces of sigma1 / sigma2 (1 for a similarity).
    pub conformal_mean: f64,
    pub conformal_max: f64,
    /// Mean, standard deviation and max |.| over faces of
    /// log((area_P / sum area_P) / (area_Q / sum area_Q)).
    pub area_log_mean: f64,
    pub area_log_std: f64,
    pub area_log_max_abs: f64,
    /// exp of the smallest and largest log area ratio.
    pub area_ratio_min: f64,
    pub area_ratio_max: f64,
    /// Sander et al.'s L2 and L-infinity stretch of the map sphere -> mesh,
    /// normalised so that 1 is the ideal.
    pub stretch_l2: f64,
    pub stretch_linf: f64,
    /// Standard deviation / mean of the chord lengths of the mesh edges on
    /// the sphere (thesis 9.3.1), over every edge, degenerate faces' included.
    pub edge_length_cv: f64,
}

impl Quality {
    /// The floating-point measures by name, in a fixed order (the keys of the
    /// Python dict, beside the counts).
    pub fn fields(&self) -> [(&'static str, f64); 12] {
        [
            ("angle_mean_deg", self.angle_mean_deg),
            ("angle_max_deg", self.angle_max_deg),
            ("conformal_mean", self.conformal_mean),
            ("conformal_max", self.conformal_max),
            ("area_log_mean", self.area_log_mean),
            ("area_log_std", self.area_log_std),
            ("area_log_max_abs", self.area_log_max_abs),
            ("area_ratio_min", self.area_ratio_min),
            ("area_ratio_max", self.area_ratio_max),
            ("stretch_l2", self.stretch_l2),
            ("stretch_linf", self.stretch_linf),
            ("edge_length_cv", self.edge_length_cv),
        ]
    }
}

/// Why [`quality`] cannot measure.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum QualityError {
    #[error("points has {got} rows, but the mesh has {expected} vertices")]
    LengthMismatch { got: usize, expected: usize },
    #[error("point {index} is not finite: {value:?}")]
    NonFinite { index: usize, value: [f64; 3] },
    #[error("all {faces} faces are degenerate (zero area on the mesh or on the sphere): there is no distortion to measure")]
    AllDegenerate { faces: usize },
}

/// One face's share of the measures.
struct FaceStats {
    angle_diff: [f64; 3],
    /// Twice the area of P (sphere side) and of Q (mesh side).
    area_p: f64,
    area_q: f64,
    /// Singular values of T: P -> Q, sigma1 >= sigma2 > 0.
    sigma1: f64,
    sigma2: f64,
}

/// Measures the distortion of `points` (one per vertex) against the mesh.
/// O(F + E), the faces in parallel; the reductions run in a fixed order, so
/// the result is the same on every run.
///
/// Errors: [`QualityError::LengthMismatch`], [`QualityError::NonFinite`],
/// [`QualityError::AllDegenerate`].
pub fn quality(mesh: &Mesh, points: &[[f64; 3]]) -> Result<Quality, QualityError> {
    let stats = every_face_stats(mesh, points)?;
    let good: Vec<&FaceStats> = stats.iter().flatten().collect();
    let n_faces = stats.len();
    if good.is_empty() {
        return Err(QualityError::AllDegenerate { faces: n_faces });
    }
    let m = good.len() as f64;

    let mut angle_sum = 0.0;
    let mut angle_max: f64 = 0.0;
    for d in good.iter().flat_map(|s| s.angle_diff) {
        angle_sum += d;
        angle_max = angle_max.max(d);
    }

    let total_p: f64 = good.iter().map(|s| s.area_p).sum();
    let total_q: f64 = good.iter().map(|s| s.area_q).sum();
    // log of (area_P / total_P) / (area_Q / total_Q).
    let logs: Vec<f64> =
        good.iter().map(|s| (s.area_p / total_p).ln() - (s.area_q / total_q).ln()).collect();
    let log_mean = logs.iter().sum::<f64>() / m;
    let log_var = logs.iter().map(|l| (l - log_mean) * (l - log_mean)).sum::<f64>() / m;
    let (log_min, log_max) =
        logs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &l| (lo.min(l), hi.max(l)));

    let ratios = good.iter().map(|s| s.sigma1 / s.sigma2);
    let (conf_sum, conf_max) = ratios.fold((0.0, 0.0f64), |(sum, max), r| (sum + r, max.max(r)));

    // Scaling P by s multiplies T's singular values by 1 / s; s^2 =
    // total_Q / total_P makes the total areas equal (Sander et al. 2001, 4.1).
    let scale_sq = total_p / total_q;
    let l2_sq = good
        .iter()
        .map(|s| 0.5 * (s.sigma1 * s.sigma1 + s.sigma2 * s.sigma2) * s.area_q)
        .sum::<f64>()
        / total_q
        * scale_sq;
    let linf = good.iter().map(|s| s.sigma1).fold(0.0, f64::max) * scale_sq.sqrt();

    Ok(Quality {
        n_faces,
        degenerate_faces: n_faces - good.len(),
        angle_mean_deg: angle_sum / (3.0 * m),
        angle_max_deg: angle_max,
        conformal_mean: conf_sum / m,
        conformal_max: conf_max,
        area_log_mean: log_mean,
        area_log_std: log_var.sqrt(),
        area_log_max_abs: log_min.abs().max(log_max.abs()),
        area_ratio_min: log_min.exp(),
        area_ratio_max: log_max.exp(),
        stretch_l2: l2_sq.sqrt(),
        stretch_linf: linf,
        edge_length_cv: edge_length_cv(mesh, points),
    })
}

/// The measures of [`quality`] face by face, for pictures that show where a
/// map distorts: NaN for a degenerate face.
#[derive(Debug, Clone, PartialEq)]
pub struct FaceMeasures {
    /// Largest |angle on the mesh - angle on the sphere triangle| of the face, degrees.
    pub angle_max_deg: Vec<f64>,
    /// sigma1 / sigma2.
    pub conformal: Vec<f64>,
    /// log((area_P / sum area_P) / (area_Q / sum area_Q)), the sums over
    /// the non-degenerate faces as in [`quality`].
    pub area_log: Vec<f64>,
    /// sqrt((sigma1^2 + sigma2^2) / 2) after the scaling of [`quality`]'s
    /// stretch (total areas equal): its area-weighted root mean square is
    /// `stretch_l2`.
    pub stretch: Vec<f64>,
}

/// [`FaceMeasures`] of `points` against the mesh. O(F), in parallel.
///
/// Errors: as [`quality`].
pub fn face_measures(mesh: &Mesh, points: &[[f64; 3]]) -> Result<FaceMeasures, QualityError> {
    let stats = every_face_stats(mesh, points)?;
    let good = stats.iter().flatten();
    let (total_p, total_q) = good.fold((0.0, 0.0), |(p, q), s| (p + s.area_p, q + s.area_q));
    if total_p == 0.0 {
        return Err(QualityError::AllDegenerate { faces: stats.len() });
    }
    let scale = (total_p / total_q).sqrt();
    let per = |f: &dyn Fn(&FaceStats) -> f64| -> Vec<f64> {
        stats.iter().map(|s| s.as_ref().map_or(f64::NAN, f)).collect()
    };
    Ok(FaceMeasures {
        angle_max_deg: per(&|s| s.angle_diff.iter().fold(0.0, |m: f64, &d| m.max(d))),
        conformal: per(&|s| s.sigma1 / s.sigma2),
        area_log: per(&|s| (s.area_p / total_p).ln() - (s.area_q / total_q).ln()),
        stretch: per(&|s| scale * (0.5 * (s.sigma1 * s.sigma1 + s.sigma2 * s.sigma2)).sqrt()),
    })
}

/// [`face_stats`] of every face, after checking `points` (one finite point
/// per vertex); in parallel, in face order.
fn every_face_stats(
    mesh: &Mesh,
    points: &[[f64; 3]],
) -> Result<Vec<Option<FaceStats>>, QualityError> {
    let n = mesh.n_vertices();
    if points.len() != n {
        return Err(QualityError::LengthMismatch { got: points.len(), expected: n });
    }
    if let Some((index, value)) =
        points.iter().enumerate().find(|(_, p)| !p.iter().all(|x| x.is_finite()))
    {
        return Err(QualityError::NonFinite { index, value: *value });
    }
    let positions = mesh.positions();
    let stats: Vec<Option<FaceStats>> = mesh
        .faces()
        .par_iter()
        .map(|&[a, b, c]| {
            let tri = |p: &[[f64; 3]]| [p[a as usize], p[b as usize], p[c as usize]];
            face_stats(tri(points), tri(positions))
        })
        .collect();
    Ok(stats)
}

/// Angles, areas and singular values of one face; `None` when degenerate.
/// `p` is the triangle on the sphere (chords), `q` the one on the mesh.
fn face_stats(p: [[f64; 3]; 3], q: [[f64; 3]; 3]) -> Option<FaceStats> {
    let (sine_p, cosines_p, area_p) = flat_triangle(p)?;
    let (sine_q, cosines_q, area_q) = flat_triangle(q)?;
    // Each triangle in its own plane, corner 0 at the origin and edge 01 on
    // the first axis: corner 1 at (l, 0), corner 2 at (s, h) with h > 0.
    // Then T = Q P^-1 is upper triangular, [[a, b], [0, d]].
    let frame = |t: [[f64; 3]; 3], twice_area: f64| {
        let (e1, e2) = (sub(t[1], t[0]), sub(t[2], t[0]));
        let l = norm(e1);
        (l, dot(e1, e2) / l, twice_area / l)
    };
    let (lp, sp, hp) = frame(p, area_p);
    let (lq, sq, hq) = frame(q, area_q);
    let (a, d) = (lq / lp, hq / hp);
    let b = (sq - a * sp) / hp;
    // Singular values of [[a, b], [0, d]]: (m + r, m - r) with
    // m = |(a + d, b)| / 2 and r = |(a - d, b)| / 2. Computing r on its own
    // keeps sigma1 / sigma2 exact to rounding for a near-similarity (the
    // eigenvalues of T^T T would lose half the digits there), and
    // sigma2 = det / sigma1 avoids the cancellation in m - r.
    let sigma1 = 0.5 * (a + d).hypot(b) + 0.5 * (a - d).hypot(b);
    let sigma2 = a * d / sigma1;
    // angle_q - angle_p at corner k with one atan2 instead of two: with
    // (s, c) proportional to (sin, cos) of each angle (positive factors),
    // sin(q - p) ~ s_q c_p - c_q s_p and cos(q - p) ~ c_q c_p + s_q s_p, and
    // the difference lies in (-pi, pi), where atan2 is exact to rounding.
    // The atans were most of the cost of `quality` (a batch measures every map).
    let change = |k: usize| {
        let (cp, cq) = (cosines_p[k], cosines_q[k]);
        (sine_q * cp - cq * sine_p).atan2(cq * cp + sine_q * sine_p)
    };
    // Both triangles' angles sum to pi, so the three changes sum to 0: the
    // third is -(d0 + d1), to rounding, without a third atan2.
    let (d0, d1) = (change(0), change(1));
    let stats = FaceStats {
        angle_diff: [d0.abs().to_degrees(), d1.abs().to_degrees(), (d0 + d1).abs().to_degrees()],
        area_p,
        area_q,
        sigma1,
        sigma2,
    };
    [sigma1, sigma2].iter().all(|x| x.is_finite() && *x > 0.0).then_some(stats)
}

/// The corners' angles as sine and cosines scaled by one positive factor
/// (|cross| and dot of each corner's two edges over the longest edge squared,
/// so at most 1 whatever the mesh's units; |cross| is twice the area at
/// every corner, so one sine serves all three), and twice the area of a flat
/// triangle; `None` when it is degenerate (see [`DEGENERATE_RELATIVE`]).
fn flat_triangle(t: [[f64; 3]; 3]) -> Option<(f64, [f64; 3], f64)> {
    let e = [sub(t[1], t[0]), sub(t[2], t[1]), sub(t[0], t[2])];
    let twice_area = norm(cross(e[0], e[1]));
    let longest = e.iter().map(|&x| dot(x, x)).fold(0.0, f64::max);
    let unit = 1.0 / longest;
    // (A longest edge squared below the normal doubles, ~1e-308, leaves no
    // digits to measure angles with: degenerate too.)
    if !twice_area.is_finite()
        || !longest.is_finite()
        || !unit.is_finite()
        || twice_area <= DEGENERATE_RELATIVE * longest
    {
        return None;
    }
    // Corner k lies between the edge leaving it and the reversed edge
    // arriving: its cosine is -(out . into).
    let cosine = |out: [f64; 3], into: [f64; 3]| -dot(out, into) * unit;
    let cosines = [cosine(e[0], e[2]), cosine(e[1], e[0]), cosine(e[2], e[1])];
    Some((twice_area * unit, cosines, twice_area))
}

/// Coefficient of variation (population standard deviation / mean) of the
/// chord lengths `|v_a - v_b|` over the mesh's undirected edges; 0 when every
/// length is 0.
fn edge_length_cv(mesh: &Mesh, points: &[[f64; 3]]) -> f64 {
    let table = mesh.edge_table();
    let lengths: Vec<f64> = (0..table.n_edges())
        .into_par_iter()
        .filter_map(|e| {
            let (a, b) = corner_endpoints(mesh.faces(), *table.group(e).first()?);
            Some(norm(sub(points[a as usize], points[b as usize])))
        })
        .collect();
    if lengths.is_empty() {
        return 0.0;
    }
    let k = lengths.len() as f64;
    let mean = lengths.iter().sum::<f64>() / k;
    if mean == 0.0 {
        return 0.0;
    }
    let var = lengths.iter().map(|l| (l - mean) * (l - mean)).sum::<f64>() / k;
    var.sqrt() / mean
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `k x k` grid of unit squares in the plane z = 0, two triangles each.
    fn grid(k: u32) -> Mesh {
        let p = (0..=k).flat_map(|j| (0..=k).map(move |i| [i as f64, j as f64, 0.0])).collect();
        let at = |i: u32, j: u32| j * (k + 1) + i;
        let f = (0..k)
            .flat_map(|j| {
                (0..k).flat_map(move |i| {
                    [
                        [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                        [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                    ]
                })
            })
            .collect();
        Mesh::new(p, f).unwrap()
    }

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() < 1e-12
    }

    #[test]
    fn a_similarity_has_no_distortion() {
        let mesh = grid(4);
        // Rotated about z by 30 degrees, scaled by 3 and moved: a similarity.
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let points: Vec<[f64; 3]> = mesh
            .positions()
            .iter()
            .map(|p| [3.0 * (c * p[0] - s * p[1]) + 1.0, 3.0 * (s * p[0] + c * p[1]), 5.0])
            .collect();
        let q = quality(&mesh, &points).unwrap();
        assert!(
            q.angle_max_deg < 1e-12 && close(q.conformal_max, 1.0) && q.area_log_max_abs < 1e-12,
            "{q:?}"
        );
        assert!(close(q.stretch_l2, 1.0) && close(q.stretch_linf, 1.0), "{q:?}");
        assert_eq!((q.n_faces, q.degenerate_faces), (32, 0));
        // Edges of length 1 and the diagonals sqrt 2: 40 + 16.
        let mean = (40.0 + 16.0 * 2f64.sqrt()) / 56.0;
        let var = (40.0 * (1.0 - mean).powi(2) + 16.0 * (2f64.sqrt() - mean).powi(2)) / 56.0;
        assert!(close(q.edge_length_cv, var.sqrt() / mean));
    }

    #[test]
    fn per_face_measures_add_up_to_the_aggregates() {
        let mesh = spherify_mesh::solids::octasphere(2);
        let points: Vec<[f64; 3]> =
            mesh.positions().iter().map(|p| [2.0 * p[0] + 0.3 * p[1], p[1], 0.5 * p[2]]).collect();
        let q = quality(&mesh, &points).unwrap();
        let f = face_measures(&mesh, &points).unwrap();
        let n = f.conformal.len() as f64;
        assert!(close(f.conformal.iter().sum::<f64>() / n, q.conformal_mean));
        assert!(close(f.angle_max_deg.iter().fold(0.0, |m: f64, &d| m.max(d)), q.angle_max_deg));
        assert!(close(f.area_log.iter().sum::<f64>() / n, q.area_log_mean));
        // stretch_l2^2 is the mean of the squares weighted by the mesh areas.
        let areas: Vec<f64> = mesh
            .faces()
            .iter()
            .map(|&[a, b, c]| {
                let p = mesh.positions();
                norm(cross(sub(p[b as usize], p[a as usize]), sub(p[c as usize], p[a as usize])))
            })
            .collect();
        let total: f64 = areas.iter().sum();
        let l2 = (f.stretch.iter().zip(&areas).map(|(s, a)| s * s * a).sum::<f64>() / total).sqrt();
        assert!(close(l2, q.stretch_l2), "{l2} vs {}", q.stretch_l2);
    }

    #[test]
    fn angle_changes_match_the_corner_angles_measured_apart() {
        // Each corner's angle on both sides from acos of its unit edges, in
        // 3D: the mean and max change match quality's (one sine per triangle,
        // the third change from the other two) to rounding.
        let mesh = spherify_mesh::solids::octasphere(3);
        let points: Vec<[f64; 3]> = mesh
            .positions()
            .iter()
            .map(|p| [p[0] + 0.3 * p[1] * p[1], 2.0 * p[1] - 0.2 * p[2], p[2] + 0.4 * p[0] * p[1]])
            .collect();
        let corner = |t: &[[f64; 3]], k: usize| {
            let (u, v) = (sub(t[(k + 1) % 3], t[k]), sub(t[(k + 2) % 3], t[k]));
            (dot(u, v) / (norm(u) * norm(v))).clamp(-1.0, 1.0).acos().to_degrees()
        };
        let (mut sum, mut max, mut count) = (0.0, 0.0f64, 0.0);
        for &[a, b, c] in mesh.faces() {
            let pick = |x: &[[f64; 3]]| [x[a as usize], x[b as usize], x[c as usize]];
            let (p, q) = (pick(&points), pick(mesh.positions()));
            for k in 0..3 {
                let d = (corner(&p, k) - corner(&q, k)).abs();
                sum += d;
                max = max.max(d);
                count += 1.0;
            }
        }
        let q = quality(&mesh, &points).unwrap();
        assert_eq!(q.degenerate_faces, 0);
        let mean = sum / count;
        assert!((q.angle_mean_deg - mean).abs() < 1e-9, "{} vs {mean}", q.angle_mean_deg);
        assert!((q.angle_max_deg - max).abs() < 1e-9, "{} vs {max}", q.angle_max_deg);
        assert!(max > 5.0, "the warp should change angles: {max}");
    }

    #[test]
    fn a_stretch_by_two_matches_the_formulas() {
        // The mesh is the grid stretched by diag(2, 1, 1); the "sphere" points
        // are the grid itself. T = diag(2, 1): sigma = (2, 1) on every face;
        // normalising areas (total ratio 2) scales them to (sqrt 2, 1 / sqrt 2).
        let plain = grid(3);
        let (p, f) = plain.clone().into_parts();
        let mesh = Mesh::new(p.iter().map(|q| [2.0 * q[0], q[1], q[2]]).collect(), f).unwrap();
        let q = quality(&mesh, plain.positions()).unwrap();
        assert!(close(q.conformal_mean, 2.0) && close(q.conformal_max, 2.0), "{q:?}");
        assert!(close(q.stretch_l2, 1.25f64.sqrt()), "{q:?}");
        assert!(close(q.stretch_linf, 2f64.sqrt()), "{q:?}");
        assert!(q.area_log_max_abs < 1e-12 && close(q.area_ratio_min, 1.0));
        // Right angle at the corner (0, 0) of [0, 1, 1+i]: 45 degrees on the
        // grid, atan(1/2) = 26.57 degrees on the stretched mesh.
        assert!(close(q.angle_max_deg, 45.0 - 0.5f64.atan().to_degrees()), "{q:?}");
    }

    #[test]
    fn degenerate_faces_are_counted_and_left_out() {
        let mesh = grid(2);
        let mut points = mesh.positions().to_vec();
        // Vertex 4 (the centre) onto vertex 0: faces using both collapse.
        points[4] = points[0];
        let q = quality(&mesh, &points).unwrap();
        assert_eq!(q.degenerate_faces, 2, "{q:?}");
        for (name, v) in q.fields() {
            assert!(v.is_finite(), "{name} = {v}");
        }
        let all = vec![[1.0, 2.0, 3.0]; mesh.n_vertices()];
        assert_eq!(quality(&mesh, &all), Err(QualityError::AllDegenerate { faces: 8 }));
        assert!(matches!(
            quality(&mesh, &points[1..]),
            Err(QualityError::LengthMismatch { got: 8, expected: 9 })
        ));
        points[3][1] = f64::NAN;
        assert!(matches!(quality(&mesh, &points), Err(QualityError::NonFinite { index: 3, .. })));
    }

    #[test]
    fn distortion_is_symmetric_where_it_should_be() {
        // Swapping mesh and points inverts T: conformal ratios and angle
        // differences stay, the log area ratios change sign.
        let plain = grid(3);
        let (p, f) = plain.clone().into_parts();
        let warped: Vec<[f64; 3]> = p
            .iter()
            .map(|q| [q[0] + 0.2 * q[1] * q[1], q[1] + 0.1 * q[0], 0.3 * q[0] * q[1]])
            .collect();
        let mesh = Mesh::new(warped.clone(), f).unwrap();
        let a = quality(&mesh, plain.positions()).unwrap();
        let b = quality(&plain, &warped).unwrap();
        assert!(
            close(a.conformal_mean, b.conformal_mean) && close(a.angle_mean_deg, b.angle_mean_deg)
        );
        assert!(close(a.area_log_mean, -b.area_log_mean) && close(a.area_log_std, b.area_log_std));
        assert!(a.stretch_l2 >= 1.0 && a.stretch_linf >= 1.0 && a.conformal_mean > 1.0);
    }
}
