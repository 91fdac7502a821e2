//! The boundary of the theta-phi rectangle and the pole fans (thesis 6.4,
//! 6.5.1, eq. 6.31 and 6.36-6.38).
//!
//! The cut mesh's boundary goes onto the rectangle [0, pi] x [0, 2 pi] as in
//! eq. 6.31. The neighbours of each pole must then have strictly increasing
//! phi, or the fold (eq. 6.35) turns the pole's fan over; where they do not,
//! the fan is pinned on a convex arc and the disk embedded again (eq. 6.38).
//!
//! The boundary, the fans and their test are public: a stored theta-phi map
//! is checked against them again when it is restored
//! ([`crate::point_map::restore`]).

use spherify_mesh::HalfEdgeMesh;
use std::f64::consts::PI;

/// The boundary of eq. 6.31: u_n = (0, pi), u_{p_i} = (i h, 0), u_s = (pi, pi),
/// u_{N+i} = ((k + 1 - i) h, 2 pi), h = pi / (k + 1), as (theta, phi).
pub fn rectangle_boundary(boundary: &[u32], k: usize, n_original: usize) -> Vec<Option<[f64; 2]>> {
    let h = PI / (k as f64 + 1.0);
    let mut fixed = vec![None; n_original + k];
    fixed[boundary[0] as usize] = Some([0.0, PI]);
    for i in 1..=k {
        fixed[boundary[i] as usize] = Some([i as f64 * h, 0.0]);
        fixed[boundary[k + 1 + i] as usize] = Some([(k + 1 - i) as f64 * h, 2.0 * PI]);
    }
    fixed[boundary[k + 1] as usize] = Some([PI, PI]);
    fixed
}

/// The neighbours of a pole in the cut mesh, ordered by increasing phi in a
/// valid embedding: P_n = (p_1, v_1, ..., v_l, N+k) for the north pole, and
/// (p_k, ..., N+1) for the south pole (thesis 6.5.1).
pub fn pole_fan(he: &HalfEdgeMesh, pole: u32, south: bool) -> Vec<u32> {
    fan_of_ring(he.vertex_ring(pole), south)
}

/// [`pole_fan`] from the pole's `vertex_ring` in the cut mesh.
pub(crate) fn fan_of_ring(ring: Vec<u32>, south: bool) -> Vec<u32> {
    if south {
        ring.into_iter().rev().collect()
    } else {
        ring
    }
}

/// Whether phi increases strictly along `fan` in `uv` (thesis 6.5.1).
pub fn strictly_increasing_phi(uv: &[[f64; 2]], fan: &[u32]) -> bool {
    fan.windows(2).all(|w| uv[w[0] as usize][1] < uv[w[1] as usize][1])
}

/// Eq. 6.38, made strictly convex: the fan's inner vertices pinned evenly in
/// phi, the pole then cut off from the free vertices (the graph H = G - n of
/// eq. 6.36). The thesis puts them on the straight line theta = h1; but when
/// two of them that are not neighbours in the fan share an edge (a face made of
/// three pole neighbours, found on small random meshes), that edge lies along
/// the straight side and Tutte's theorem gives a triangle of zero area, in
/// exact arithmetic too. So they go on the convex arc
/// theta = h1 (1 - sin(phi / 2) / 2) instead (mirrored for the south pole),
/// which keeps the boundary convex, bulges towards the pole and still meets
/// the rectangle's sides at (h1, 0) and (h1, 2 pi).
pub(crate) fn pin_fan(fixed: &mut [Option<[f64; 2]>], fan: &[u32], k: usize, south: bool) {
    let h1 = PI / (k as f64 + 1.0);
    let inner = &fan[1..fan.len() - 1];
    let h2 = 2.0 * PI / (inner.len() as f64 + 1.0);
    for (j, &v) in inner.iter().enumerate() {
        let phi = (j + 1) as f64 * h2;
        let depth = h1 * (1.0 - 0.5 * (0.5 * phi).sin());
        let theta = if south { PI - depth } else { depth };
        fixed[v as usize] = Some([theta, phi]);
    }
}
