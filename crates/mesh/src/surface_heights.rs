//! The height of a surface over its neighbourhood at a few scales: the
//! descriptor of registration's descriptor pairs (issue 23;
//! `spherify._descriptors`' module doc, which these functions compute in the
//! core).
//!
//! For a point q of the surface with unit outward normal n and a scale r,
//!
//! ```text
//! h_r(q) = n . (q - c_r(q)),   c_r(q) the area-weighted mean of the surface
//!                              around q with Gaussian weights
//!                              exp(-|x - q|^2 / 2 r^2) out to 2 r,
//! ```
//!
//! counting only the surface on q's side (a sample whose normal turns away
//! from n is left out). It is a difference of Gaussians, the mean curvature
//! smoothed at scale r times r^2 to first order: the invariant feature that
//! feature-augmented ICP appends to the coordinates (Sharp, Lee and Wehe
//! 2002, "ICP registration using invariant features"; Johnson and Kang 1999).
//!
//! The surface is represented by area-weighted samples about a spacing
//! apart ([`surface_samples`]): each face split into m^2 equal sub-triangles
//! (m its longest edge over the spacing, rounded up, at most [`MAX_SPLIT`]),
//! each represented by its centroid, then lumped into grid cells of the
//! spacing (areas summed, area-weighted centroids, normals summed), so two
//! meshes of one surface at any resolution estimate the same integral.
//!
//! Every sum runs in a fixed order (the samples in the order below, the
//! neighbours in [`CellGrid`]'s), one query at a time, so the values do not
//! depend on the threads, and the arithmetic is written as numpy's was in
//! `spherify._descriptors` (session 10) so that both give the same values up
//! to the last bits of `exp`.

use rayon::prelude::*;

use crate::cell_grid::CellGrid;
use crate::vec3::{cross, dot, norm, sub};

/// Subdivisions of a face along an edge, at most (a face longer than this
/// many spacings is sampled more coarsely than the rest).
pub const MAX_SPLIT: usize = 64;

/// Queries per parallel chunk (each query is computed alone: the chunking
/// changes no bits).
const CHUNK: usize = 256;

/// Points of a surface with their areas and unit outward normals.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SurfaceSamples {
    pub points: Vec<[f64; 3]>,
    pub area: Vec<f64>,
    pub normals: Vec<[f64; 3]>,
    /// A face each point lies near: the face of the first of its cell's
    /// samples (within a cell's diagonal of the point; a closest-point
    /// search's hint).
    pub faces: Vec<u32>,
}

/// The surface's faces, made once for samples at several spacings: corners,
/// outward cross products (the whole surface turned out if its signed volume
/// is negative), areas, centroids and longest edges.
#[derive(Debug, Clone)]
pub struct SampledSurface {
    corners: Vec<[[f64; 3]; 3]>,
    cross: Vec<[f64; 3]>,
    area: Vec<f64>,
    centroid: Vec<[f64; 3]>,
    longest: Vec<f64>,
}

impl SampledSurface {
    /// The surface of `faces` over `vertices` (indices in range).
    pub fn new(vertices: &[[f64; 3]], faces: &[[u32; 3]]) -> SampledSurface {
        let corners: Vec<[[f64; 3]; 3]> =
            faces.iter().map(|f| f.map(|v| vertices[v as usize])).collect();
        let mut crosses: Vec<[f64; 3]> =
            corners.iter().map(|c| cross(sub(c[1], c[0]), sub(c[2], c[0]))).collect();
        // Outwards (a mesh may come turned in): the sign of 6 x the volume.
        let volume: f64 = crosses.iter().zip(&corners).map(|(x, c)| dot(*x, c[0])).sum();
        if volume < 0.0 {
            for x in &mut crosses {
                *x = x.map(|v| -v);
            }
        }
        // (sqrt is monotonic and correctly rounded: the longest of the
        // lengths is the root of the longest square, to the bit.)
        let longest = corners
            .iter()
            .map(|c| norm(sub(c[1], c[0])).max(norm(sub(c[2], c[1]))).max(norm(sub(c[0], c[2]))))
            .collect();
        let area = crosses.iter().map(|x| 0.5 * norm(*x)).collect();
        let centroid = corners
            .iter()
            .map(|c| [0, 1, 2].map(|k| (c[0][k] + c[1][k] + c[2][k]) / 3.0))
            .collect();
        SampledSurface { corners, cross: crosses, area, centroid, longest }
    }

    /// Samples about `spacing` apart (the module doc), in cells of ascending
    /// key. O(area / spacing^2 + faces).
    pub fn samples(&self, spacing: f64) -> SurfaceSamples {
        let split: Vec<usize> = self
            .longest
            .iter()
            .map(|&l| {
                let m = (l / spacing).ceil();
                if m.is_nan() {
                    1
                } else {
                    m.clamp(1.0, MAX_SPLIT as f64) as usize
                }
            })
            .collect();
        // The samples: whole faces first, then by split m ascending, each
        // face's sub-triangles in turn (numpy's order in session 10).
        let mut points = Vec::new();
        let mut weights = Vec::new();
        let mut normals = Vec::new();
        let mut faces = Vec::new();
        for (f, &m) in split.iter().enumerate() {
            if m == 1 {
                points.push(self.centroid[f]);
                weights.push(self.area[f]);
                normals.push(self.cross[f]);
                faces.push(f as u32);
            }
        }
        let mut counts = [0usize; MAX_SPLIT + 1];
        for &m in &split {
            counts[m] += 1;
        }
        for (m, _) in counts.iter().enumerate().skip(2).filter(|(_, &c)| c > 0) {
            // The centroids of the m^2 sub-triangles, barycentric (1 - u - v,
            // u, v): the upright ones at (i + 1/3, j + 1/3) / m, i + j <= m - 1,
            // the turned ones at (i + 2/3, j + 2/3) / m, i + j <= m - 2.
            let mf = m as f64;
            let mut uv = Vec::with_capacity(m * m);
            for (offset, limit) in [(1.0 / 3.0, m - 1), (2.0 / 3.0, m - 2)] {
                for i in 0..m {
                    for j in 0..m {
                        if i + j <= limit {
                            uv.push(((i as f64 + offset) / mf, (j as f64 + offset) / mf));
                        }
                    }
                }
            }
            let squares = (m * m) as f64;
            for (f, _) in split.iter().enumerate().filter(|(_, &s)| s == m) {
                let c = &self.corners[f];
                let share = self.area[f] / squares;
                let normal = self.cross[f].map(|x| x / squares);
                for &(u, v) in &uv {
                    let b = [1.0 - u - v, u, v];
                    points
                        .push([0, 1, 2].map(|k| b[0] * c[0][k] + b[1] * c[1][k] + b[2] * c[2][k]));
                    weights.push(share);
                    normals.push(normal);
                    faces.push(f as u32);
                }
            }
        }
        lump(&points, &weights, &normals, &faces, spacing)
    }
}

/// The samples lumped into grid cells of side `spacing` ([`CellGrid`]'s
/// cells): each cell's area summed, its area-weighted centroid and its unit
/// summed normal, in the order of the cells' keys (cells whose normals
/// cancel left out). Each cell sums its samples in their order.
fn lump(
    points: &[[f64; 3]],
    weights: &[f64],
    normals: &[[f64; 3]],
    faces: &[u32],
    spacing: f64,
) -> SurfaceSamples {
    let mut out = SurfaceSamples::default();
    for rows in CellGrid::new(points, spacing).cells() {
        let mut total = 0.0;
        let mut moment = [0.0; 3];
        let mut summed = [0.0; 3];
        for &i in rows {
            let i = i as usize;
            let w = weights[i];
            total += w;
            for c in 0..3 {
                moment[c] += w * points[i][c];
                summed[c] += normals[i][c];
            }
        }
        let length = norm(summed);
        if total > 0.0 && length > 0.0 {
            out.points.push(moment.map(|x| x / total));
            out.area.push(total);
            out.normals.push(summed.map(|x| x / length));
            out.faces.push(faces[rows[0] as usize]);
        }
    }
    out
}

/// [`SampledSurface::samples`] of the surface (`vertices`, `faces`).
pub fn surface_samples(vertices: &[[f64; 3]], faces: &[[u32; 3]], spacing: f64) -> SurfaceSamples {
    SampledSurface::new(vertices, faces).samples(spacing)
}

/// The module doc's h_r at `queries` (points of the surface with their unit
/// outward `normals`) for each r of `scales`, the surface sampled
/// `source_spacing` r apart: one row of `scales.len()` values per query (0
/// where a query's neighbourhood is empty). Run on rayon's threads, one
/// query at a time.
pub fn surface_heights(
    surface: &SampledSurface,
    queries: &[[f64; 3]],
    normals: &[[f64; 3]],
    scales: &[f64],
    source_spacing: f64,
) -> Vec<Vec<f64>> {
    let mut out = vec![vec![0.0; scales.len()]; queries.len()];
    for (k, &r) in scales.iter().enumerate() {
        let samples = surface.samples(source_spacing * r);
        let grid = CellGrid::new(&samples.points, 2.0 * r);
        let cut = 4.0 * r * r;
        let rate = -0.5 / (r * r);
        let column: Vec<f64> = queries
            .par_chunks(CHUNK)
            .zip(normals.par_chunks(CHUNK))
            .flat_map_iter(|(qs, ns)| {
                qs.iter()
                    .zip(ns)
                    .map(|(&q, &n)| height(&grid, &samples, q, n, cut, rate))
                    .collect::<Vec<f64>>()
            })
            .collect();
        for (row, h) in out.iter_mut().zip(column) {
            row[k] = h;
        }
    }
    out
}

/// One query's height at one scale: the weighted mean of n . (q - p) over
/// the samples p within the cut on q's side.
fn height(
    grid: &CellGrid,
    samples: &SurfaceSamples,
    q: [f64; 3],
    n: [f64; 3],
    cut: f64,
    rate: f64,
) -> f64 {
    let mut total = 0.0;
    let mut along_sum = 0.0;
    grid.for_each_near(q, |p| {
        let x = samples.points[p];
        let gap = sub(q, x);
        let d2 = dot(gap, gap);
        let along = dot(n, gap);
        let agree = dot(n, samples.normals[p]);
        if d2 <= cut && agree > 0.0 {
            let w = samples.area[p] * (d2 * rate).exp();
            total += w;
            along_sum += w * along;
        }
    });
    if total > 0.0 {
        along_sum / total
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::solids;

    fn sphere(level: usize) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        // Turned off the axes, so that no sample sits on a cell's side by
        // symmetry (where rounding alone would choose the cell).
        let m = solids::icosphere(level);
        let (c, s) = (0.3f64.cos(), 0.3f64.sin());
        let (c2, s2) = (0.7f64.cos(), 0.7f64.sin());
        let turn = |p: &[f64; 3]| {
            let q = [c * p[0] - s * p[1], s * p[0] + c * p[1], p[2]];
            [q[0], c2 * q[1] - s2 * q[2], s2 * q[1] + c2 * q[2]]
        };
        (m.positions().iter().map(turn).collect(), m.faces().to_vec())
    }

    /// The plain definition: every sample, no grid.
    fn reference(samples: &SurfaceSamples, q: [f64; 3], n: [f64; 3], r: f64) -> f64 {
        let (mut total, mut sum) = (0.0, 0.0);
        for (p, x) in samples.points.iter().enumerate() {
            let gap = sub(q, *x);
            let d2 = dot(gap, gap);
            if d2 <= 4.0 * r * r && dot(n, samples.normals[p]) > 0.0 {
                let w = samples.area[p] * (-d2 / (2.0 * r * r)).exp();
                total += w;
                sum += w * dot(n, gap);
            }
        }
        if total > 0.0 {
            sum / total
        } else {
            0.0
        }
    }

    #[test]
    fn samples_keep_the_area_and_point_out() {
        let (v, f) = sphere(3);
        let surface = SampledSurface::new(&v, &f);
        let whole: f64 = surface.area.iter().sum();
        for spacing in [0.02, 0.1, 0.5] {
            let s = surface.samples(spacing);
            let area: f64 = s.area.iter().sum();
            assert!((area - whole).abs() < 1e-12 * whole);
            for ((p, n), &f) in s.points.iter().zip(&s.normals).zip(&s.faces) {
                // The face is within a cell's diagonal (and the face's size).
                let c = surface.centroid[f as usize];
                let d = dot(sub(*p, c), sub(*p, c)).sqrt();
                assert!(d <= 3f64.sqrt() * spacing + surface.longest[f as usize], "{d}");
                assert!(dot(*p, *n) > 0.0);
                assert!((dot(*n, *n) - 1.0).abs() < 1e-12);
            }
        }
        // Turned in: the same normals.
        let turned: Vec<[u32; 3]> = f.iter().map(|t| [t[2], t[1], t[0]]).collect();
        let a = surface_samples(&v, &f, 0.1);
        let b = surface_samples(&v, &turned, 0.1);
        assert_eq!(a.normals.len(), b.normals.len());
        for (x, y) in a.normals.iter().zip(&b.normals) {
            assert!((0..3).all(|c| (x[c] - y[c]).abs() < 1e-9), "{x:?} against {y:?}");
        }
    }

    #[test]
    fn heights_equal_the_plain_sum_and_are_positive_on_a_ball() {
        let (v, f) = sphere(3);
        let surface = SampledSurface::new(&v, &f);
        let queries: Vec<[f64; 3]> = v.iter().step_by(7).copied().collect();
        let normals = queries.clone();
        let scales = [0.1, 0.3];
        let h = surface_heights(&surface, &queries, &normals, &scales, 0.75);
        for (k, &r) in scales.iter().enumerate() {
            let samples = surface.samples(0.75 * r);
            for (i, (&q, &n)) in queries.iter().zip(&normals).enumerate() {
                let want = reference(&samples, q, n, r);
                assert!((h[i][k] - want).abs() <= 1e-14, "{} against {}", h[i][k], want);
                // A convex surface rises over its neighbourhood.
                assert!(h[i][k] > 0.0);
            }
        }
        // The same values on one thread.
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let h1 = one.install(|| surface_heights(&surface, &queries, &normals, &scales, 0.75));
        assert_eq!(h, h1);
    }

    /// Every face split in four in its plane (the same surface, finer).
    fn split_flat(v: &[[f64; 3]], f: &[[u32; 3]]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
        let mut v = v.to_vec();
        let mut mid = std::collections::HashMap::new();
        let mut at = |a: u32, b: u32, v: &mut Vec<[f64; 3]>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (x, y) = (v[a as usize], v[b as usize]);
                v.push([0, 1, 2].map(|c| 0.5 * (x[c] + y[c])));
                (v.len() - 1) as u32
            })
        };
        let mut out = Vec::new();
        for &[a, b, c] in f {
            let (ab, bc, ca) = (at(a, b, &mut v), at(b, c, &mut v), at(c, a, &mut v));
            out.extend([[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]);
        }
        (v, out)
    }

    #[test]
    fn heights_hardly_depend_on_the_resolution() {
        // The same surface as 80 and as 5120 triangles: the heights agree.
        let (coarse_v, coarse_f) = sphere(1);
        let (mut v, mut f) = (coarse_v.clone(), coarse_f.clone());
        for _ in 0..3 {
            (v, f) = split_flat(&v, &f);
        }
        // At the vertices, the tips of a convex surface: positive heights.
        let queries: Vec<[f64; 3]> = coarse_v.clone();
        let normals: Vec<[f64; 3]> = coarse_v.clone();
        let scales = [0.1, 0.3];
        let a = surface_heights(
            &SampledSurface::new(&coarse_v, &coarse_f),
            &queries,
            &normals,
            &scales,
            0.75,
        );
        let b = surface_heights(&SampledSurface::new(&v, &f), &queries, &normals, &scales, 0.75);
        for (x, y) in a.iter().zip(&b) {
            for k in 0..2 {
                assert!(
                    x[k] > 0.0 && (x[k] - y[k]).abs() < 0.1 * y[k],
                    "{} against {}",
                    x[k],
                    y[k]
                );
            }
        }
    }
}
