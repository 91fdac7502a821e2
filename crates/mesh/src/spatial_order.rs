//! An order of points along a space-filling curve, so that queries against
//! a spatial tree that come one after another touch the same nodes.
//!
//! Registration locates hundreds of thousands of points a call (closest
//! points on a surface, points of a sphere map's triangles), in the order of
//! the mesh's vertex ids, which jumps across the shape: each query then
//! walks its tree through memory the one before did not touch, and the walk
//! waits on memory. Answering the queries in Morton (Z-)order of their
//! positions (Morton 1966; the ordering of Karras's linear BVHs, 2012) keeps
//! the nodes near the root and of the neighbourhood in the cache. Each
//! query's answer depends on that query alone, so the order changes no bit
//! of any answer; the answers are written back to the queries' own rows.

use crate::vec3::finite_bounds;

/// Bits per axis of the Morton code (3 x 21 = 63 bits).
const BITS: u32 = 21;

/// Spreads the low 21 bits of `x` to every third bit.
fn spread(x: u64) -> u64 {
    let mut x = x & 0x1f_ffff;
    x = (x | x << 32) & 0x1f_0000_0000_ffff;
    x = (x | x << 16) & 0x1f_0000_ff00_00ff;
    x = (x | x << 8) & 0x100f_00f0_0f00_f00f;
    x = (x | x << 4) & 0x10c3_0c30_c30c_30c3;
    x = (x | x << 2) & 0x1249_2492_4924_9249;
    x
}

/// The rows of `points` in the Morton order of their positions within their
/// bounding box (ties, and points that are not finite, which go first, in
/// row order). O(n log n).
pub fn spatial_order(points: &[[f64; 3]]) -> Vec<u32> {
    let (lo, hi) = finite_bounds(points);
    let cells = ((1u64 << BITS) - 1) as f64;
    let scale: [f64; 3] =
        std::array::from_fn(|i| if hi[i] > lo[i] { cells / (hi[i] - lo[i]) } else { 0.0 });
    let mut keyed: Vec<(u64, u32)> = points
        .iter()
        .enumerate()
        .map(|(row, p)| {
            let code = if p.iter().all(|x| x.is_finite()) {
                (0..3).fold(0u64, |code, i| {
                    let cell = ((p[i] - lo[i]) * scale[i]).clamp(0.0, cells) as u64;
                    code | spread(cell) << i
                })
            } else {
                0
            };
            (code, row as u32)
        })
        .collect();
    keyed.sort_unstable();
    keyed.into_iter().map(|(_, row)| row).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcg::Lcg;

    #[test]
    fn spread_puts_each_bit_three_apart() {
        for b in 0..BITS {
            assert_eq!(spread(1 << b), 1 << (3 * b));
        }
        assert_eq!(spread(0x1f_ffff), 0x1249_2492_4924_9249);
    }

    #[test]
    fn is_a_permutation_that_keeps_neighbours_close() {
        let mut s = Lcg::new(11);
        let mut points: Vec<[f64; 3]> =
            (0..5000).map(|_| [s.next_f64(), s.next_f64(), s.next_f64()]).collect();
        points.push([f64::NAN, 0.0, 0.0]);
        let order = spatial_order(&points);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..points.len() as u32).collect::<Vec<_>>());
        assert_eq!(order[0], 5000, "the point that is not finite goes first");
        // Consecutive points of the order are far closer than of the rows.
        let step = |rows: &mut dyn Iterator<Item = usize>| {
            let rows: Vec<usize> = rows.filter(|&r| r < 5000).collect();
            rows.windows(2)
                .map(|w| {
                    let (a, b) = (points[w[0]], points[w[1]]);
                    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
                })
                .sum::<f64>()
                / rows.len() as f64
        };
        let curve = step(&mut order.iter().map(|&r| r as usize));
        let rows = step(&mut (0..5000));
        assert!(curve < 0.2 * rows, "{curve} {rows}");
    }
}
