//! The row-stochastic weight matrix `W` of the spherical Tutte methods (thesis
//! eq. 5.3-5.4, 5.9): relaxation iterates `U = W V` (eq. 5.15), Gotsman solves
//! `W V = diag(alpha) V` (eq. 5.10).

use spherify_sparse::weights::{half_edge_weights, Weights};
use spherify_sparse::CsrMatrix;

use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;

/// What the method needs of the weights before the rows are normalised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Positivity {
    /// Every row sums to a positive number (relaxation: the projection needs a
    /// combination to project; single weights may be negative).
    RowSums,
    /// Every weight is positive (eq. 5.3; Gotsman's theorem needs it).
    EveryWeight,
}

/// `W` as an `n x n` matrix with rows summing to 1, in the order of the
/// half-edges around each vertex. O(E).
///
/// # Errors
/// [`SphereError::InvalidParameter`] naming the vertex or edge whose weights
/// break `positivity`, or a weight formula that is not finite on this mesh.
pub fn row_stochastic(
    mesh: &GenusZeroMesh,
    weights: Weights,
    positivity: Positivity,
) -> Result<CsrMatrix, SphereError> {
    let bad = |value: String| SphereError::InvalidParameter {
        name: "weights",
        value,
        expected: match positivity {
            Positivity::RowSums => "weights with a positive, finite sum around every vertex",
            Positivity::EveryWeight => "positive, finite weights on every edge (eq. 5.3)",
        },
    };
    let he = mesh.half_edges();
    let w = half_edge_weights(mesh.positions(), he, weights).map_err(|e| bad(e.to_string()))?;
    let n = mesh.n_vertices();
    let (mut rows, mut cols, mut values) = (
        Vec::with_capacity(he.n_half_edges()),
        Vec::with_capacity(he.n_half_edges()),
        Vec::with_capacity(he.n_half_edges()),
    );
    for i in 0..n as u32 {
        let first = values.len();
        for h in he.rotation(i) {
            let value = w[h as usize];
            if positivity == Positivity::EveryWeight && (value.is_nan() || value <= 0.0) {
                return Err(bad(format!("{weights:?}: {value} on edge ({i}, {})", he.head(h))));
            }
            rows.push(i);
            cols.push(he.head(h));
            values.push(value);
        }
        let sum: f64 = values[first..].iter().sum();
        if !(sum > 0.0 && sum.is_finite()) {
            return Err(bad(format!("{weights:?}, whose weights around vertex {i} sum to {sum}")));
        }
        values[first..].iter_mut().for_each(|v| *v /= sum);
    }
    Ok(CsrMatrix::from_triplets(n, n, &rows, &cols, &values)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::octahedron;

    #[test]
    fn rows_sum_to_one_over_the_neighbours() {
        let mesh = GenusZeroMesh::new(octahedron()).unwrap();
        let w =
            row_stochastic(&mesh, Weights::Chord { rho: 1.0 }, Positivity::EveryWeight).unwrap();
        for i in 0..6 {
            let (cols, vals) = w.row(i);
            assert_eq!(cols.len(), 4);
            assert!((vals.iter().sum::<f64>() - 1.0).abs() < 1e-15);
            assert!(!cols.contains(&(i as u32)));
        }
    }
}
