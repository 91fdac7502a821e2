//! Signed enclosed volume per connected component (divergence theorem:
//! V = sum over faces of det[a, b, c] / 6), used to tell outward from inward.
//!
//! The sums run on coordinates moved to the bounding-box centre and divided by a
//! power of two near the box's half-size. Division by a power of two is exact, so
//! the signs are those of the original mesh, and the sums neither underflow for
//! a mesh 1e-120 across nor overflow for one 1e103 across.

use crate::vec3::finite_bounds;

/// Volumes of the components in normalised units; multiply by `unit^3` for the
/// volume in the mesh's own units.
pub(crate) struct Volumes {
    pub normalized: Vec<f64>,
    pub unit: f64,
}

impl Volumes {
    /// Total signed volume in the mesh's units (may be 0 or infinite when it does
    /// not fit in a double; the normalised values keep the sign).
    pub fn total(&self) -> f64 {
        self.normalized.iter().sum::<f64>() * self.unit.powi(3)
    }
}

/// `component_of[f]` names each face's component (< `n_components`); faces
/// with `flip[f]` count reversed.
pub(crate) fn component_volumes(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    component_of: &[u32],
    n_components: usize,
    flip: Option<&[bool]>,
) -> Volumes {
    let (lo, hi) = finite_bounds(positions);
    let half_size = (0..3).map(|i| hi[i] / 2.0 - lo[i] / 2.0).fold(0.0, f64::max);
    let unit =
        if half_size > 0.0 && half_size.is_finite() { half_size.log2().ceil().exp2() } else { 1.0 };
    // unit is a power of two, so multiplying by its inverse is exact.
    let inverse = 1.0 / unit;
    let centre: Vec<f64> = (0..3).map(|i| lo[i] * inverse / 2.0 + hi[i] * inverse / 2.0).collect();
    let local = |v: u32| {
        let q = positions[v as usize];
        [q[0] * inverse - centre[0], q[1] * inverse - centre[1], q[2] * inverse - centre[2]]
    };
    let mut normalized = vec![0.0; n_components];
    for (f, &[a, b, c]) in faces.iter().enumerate() {
        let (a, b, c) = (local(a), local(b), local(c));
        let det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0])
            + a[2] * (b[0] * c[1] - b[1] * c[0]);
        let signed = if flip.is_some_and(|fl| fl[f]) { -det } else { det };
        if let Some(v) = normalized.get_mut(component_of[f] as usize) {
            *v += signed / 6.0;
        }
    }
    Volumes { normalized, unit }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TETRA: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]];

    #[test]
    fn sign_survives_extreme_scales() {
        for scale in [1e-300, 1e-120, 1.0, 1e103, 1e300] {
            let p: Vec<[f64; 3]> =
                [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
                    .iter()
                    .map(|q| q.map(|x| x * scale))
                    .collect();
            let v = component_volumes(&p, &TETRA, &[0; 4], 1, None);
            assert!(v.normalized[0] > 0.0, "scale {scale}");
            let flipped = component_volumes(&p, &TETRA, &[0; 4], 1, Some(&[true; 4]));
            assert!(flipped.normalized[0] < 0.0, "scale {scale}");
        }
        let p = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let v = component_volumes(&p, &TETRA, &[0; 4], 1, None);
        assert!((v.total() - 1.0 / 6.0).abs() < 1e-15);
    }
}
