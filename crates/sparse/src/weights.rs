//! Edge weights for Tutte-type embeddings (thesis 4.4).
//!
//! A weight `w[h]` belongs to half-edge `h = (i -> j)`: it is the coefficient of
//! neighbour `j` in the row of vertex `i`. Rows are normalised by the solver's
//! matrix assembly (thesis eq. 4.24 divides by wdeg(i), eq. 4.48), so only ratios
//! within a row matter.

use spherify_mesh::vec3::{cross, dot, norm, sub};
use spherify_mesh::{HalfEdgeMesh, UnknownName};

/// Which weights to use.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Weights {
    /// Tutte's weights: 1 for every neighbour (thesis eq. 4.45).
    Uniform,
    /// Chord-length weights |x_i - x_j|^rho (thesis eq. 4.46-4.48); rho = 0 is
    /// `Uniform`. Symmetric, so the system is symmetric positive definite.
    Chord { rho: f64 },
    /// Floater's mean-value weights (tan(a/2) + tan(b/2)) / |x_i - x_j|, with a and
    /// b the angles at i on either side of the edge (Floater 2003). Always
    /// positive, shape-preserving, not symmetric.
    MeanValue,
    /// Cotangent weights (cot a + cot b) / 2 with a and b the angles opposite the
    /// edge (Pinkall-Polthier). Symmetric but negative for obtuse pairs, where
    /// Tutte's theorem no longer guarantees an embedding.
    Cotangent,
}

/// A weight that came out NaN or infinite: degenerate geometry (zero-length
/// edge, zero-area triangle) where the chosen weights are undefined.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the {kind} weight of edge ({a}, {b}) is {value}: the mesh has a zero-length edge or a zero-area triangle there")]
pub struct BadWeight {
    pub kind: &'static str,
    pub a: u32,
    pub b: u32,
    pub value: f64,
}

impl Weights {
    /// The name of each kind of weights, in declaration order: what
    /// [`Weights::name`] gives and [`Weights::from_name`] takes.
    pub const NAMES: [&'static str; 4] = ["uniform", "chord", "mean_value", "cotangent"];

    /// The weights called `name` (one of [`Weights::NAMES`], exactly), with
    /// exponent `rho` for `"chord"` (ignored by the others; not checked here,
    /// the caller decides what a usable `rho` is).
    pub fn from_name(name: &str, rho: f64) -> Result<Weights, UnknownName> {
        let all =
            [Weights::Uniform, Weights::Chord { rho }, Weights::MeanValue, Weights::Cotangent];
        UnknownName::position("weights", name, &Self::NAMES).map(|k| all[k])
    }

    /// The name of these weights, without `rho`.
    pub const fn name(&self) -> &'static str {
        match self {
            Weights::Uniform => "uniform",
            Weights::Chord { .. } => "chord",
            Weights::MeanValue => "mean_value",
            Weights::Cotangent => "cotangent",
        }
    }

    /// The weights in words, for error messages.
    fn label(&self) -> &'static str {
        match self {
            Weights::Uniform => "uniform",
            Weights::Chord { .. } => "chord-length",
            Weights::MeanValue => "mean-value",
            Weights::Cotangent => "cotangent",
        }
    }
}

/// Weight of every half-edge; boundary half-edges (no face) get the weight of
/// their one triangle only where the formula needs triangles. O(E).
pub fn half_edge_weights(
    positions: &[[f64; 3]],
    he: &HalfEdgeMesh,
    weights: Weights,
) -> Result<Vec<f64>, BadWeight> {
    let p = |v: u32| positions[v as usize];
    // Third vertex of the face of h, if h has a face.
    let apex = |h: u32| he.face(h).map(|_| he.head(he.next(h)));
    let mut w = vec![0.0; he.n_half_edges()];
    for h in 0..he.n_half_edges() as u32 {
        let (i, j) = (he.tail(h), he.head(h));
        let t = he.twin(h);
        let value = match weights {
            Weights::Uniform => 1.0,
            Weights::Chord { rho } => norm(sub(p(j), p(i))).powf(rho),
            Weights::MeanValue => {
                let eij = sub(p(j), p(i));
                // Angle at i between edge ij and the face's other edge at i.
                let half_tan = |k: u32| tan_half_angle(eij, sub(p(k), p(i)));
                let sides: f64 = [apex(h), apex(t)].into_iter().flatten().map(half_tan).sum();
                sides / norm(eij)
            }
            Weights::Cotangent => {
                // Angle at the apex k, opposite edge ij.
                let cot_at = |k: u32| cot_angle(sub(p(i), p(k)), sub(p(j), p(k)));
                0.5 * [apex(h), apex(t)].into_iter().flatten().map(cot_at).sum::<f64>()
            }
        };
        if !value.is_finite() {
            return Err(BadWeight { kind: weights.label(), a: i, b: j, value });
        }
        w[h as usize] = value;
    }
    Ok(w)
}

/// tan(theta / 2) for the angle theta between a and b, as |a x b| / (|a||b| + a.b),
/// which stays accurate for small and for nearly straight angles.
fn tan_half_angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    norm(cross(a, b)) / (norm(a) * norm(b) + dot(a, b))
}

/// cot(theta) for the angle between a and b.
fn cot_angle(a: [f64; 3], b: [f64; 3]) -> f64 {
    dot(a, b) / norm(cross(a, b))
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::Mesh;

    /// Regular hexagon fan around a centre vertex 0 in the plane z = 0.
    fn hexagon() -> (Mesh, HalfEdgeMesh) {
        let mut p = vec![[0.0, 0.0, 0.0]];
        for k in 0..6 {
            let a = std::f64::consts::PI / 3.0 * k as f64;
            p.push([a.cos(), a.sin(), 0.0]);
        }
        let f: Vec<[u32; 3]> = (0..6).map(|k| [0, 1 + k, 1 + (k + 1) % 6]).collect();
        let mesh = Mesh::new(p, f).unwrap();
        let he = HalfEdgeMesh::new(&mesh).unwrap();
        (mesh, he)
    }

    fn weights_from_centre(mesh: &Mesh, he: &HalfEdgeMesh, w: Weights) -> Vec<f64> {
        let all = half_edge_weights(mesh.positions(), he, w).unwrap();
        he.rotation(0).map(|h| all[h as usize]).collect()
    }

    #[test]
    fn equilateral_fan_has_equal_weights() {
        let (mesh, he) = hexagon();
        for (w, expected) in [
            (Weights::Uniform, 1.0),
            (Weights::Chord { rho: -1.0 }, 1.0),
            // Two 60-degree angles: 2 tan(30 deg) / 1.
            (Weights::MeanValue, 2.0 * (std::f64::consts::PI / 6.0).tan()),
            // Two 60-degree opposite angles: (cot 60 + cot 60) / 2.
            (Weights::Cotangent, 1.0 / 3f64.sqrt()),
        ] {
            for x in weights_from_centre(&mesh, &he, w) {
                assert!((x - expected).abs() < 1e-12, "{w:?}: {x} vs {expected}");
            }
        }
    }

    #[test]
    fn names_round_trip() {
        for name in Weights::NAMES {
            let weights = Weights::from_name(name, 0.5).unwrap();
            assert_eq!(weights.name(), name);
        }
        assert_eq!(Weights::from_name("chord", -1.0), Ok(Weights::Chord { rho: -1.0 }));
        let err = Weights::from_name("harmonic", 1.0).unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown weights 'harmonic'; expected one of: uniform, chord, mean_value, cotangent"
        );
    }

    #[test]
    fn zero_length_edge_is_an_error() {
        let p = vec![[0.0; 3], [0.0; 3], [0.0, 1.0, 0.0]];
        let mesh = Mesh::new(p, vec![[0, 1, 2]]).unwrap();
        let he = HalfEdgeMesh::new(&mesh).unwrap();
        let err =
            half_edge_weights(mesh.positions(), &he, Weights::Chord { rho: -1.0 }).unwrap_err();
        assert!(!err.value.is_finite());
        assert!(half_edge_weights(mesh.positions(), &he, Weights::Uniform).is_ok());
    }
}
