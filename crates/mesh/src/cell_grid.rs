//! Points sorted by the cell of a uniform grid, for every pair of a query and
//! a point in the 27 cells around the query's (registration's descriptor
//! pairs, issue 23: `surface_heights` and `feature_nearest`).
//!
//! Every point within one cell side of a query lies in those 27 cells. The
//! pairs come in a fixed order (the neighbour cells with x outermost and z
//! innermost, each running -1, 0, 1; the points of a cell by increasing row),
//! which the sums and minima over them keep, so their bits do not depend on
//! the threads. This is the order of `spherify._descriptors.Grid.pairs`.

/// Rows `0..keys.len()` ordered by key, rows of one key by increasing row
/// (a stable sort), with the keys in `0..cells`: a counting sort where
/// `cells` is at most [`DENSE_PER_POINT`] times the rows (or
/// [`DENSE_FLOOR`]), else a comparison sort. Returns the order and, for
/// the counting sort, where each key's rows start (`cells + 1` entries).
fn order_by_key(keys: &[i64], cells: Option<usize>) -> (Vec<u32>, Option<Vec<u32>>) {
    if let Some(cells) = cells.filter(|&c| c <= (DENSE_PER_POINT * keys.len()).max(DENSE_FLOOR)) {
        let mut first = vec![0u32; cells + 1];
        for &k in keys {
            first[k as usize + 1] += 1;
        }
        for c in 0..cells {
            first[c + 1] += first[c];
        }
        let mut next = first.clone();
        let mut order = vec![0u32; keys.len()];
        for (row, &k) in keys.iter().enumerate() {
            order[next[k as usize] as usize] = row as u32;
            next[k as usize] += 1;
        }
        return (order, Some(first));
    }
    let mut sorted: Vec<(i64, u32)> = keys.iter().zip(0u32..).map(|(&k, i)| (k, i)).collect();
    sorted.sort_unstable();
    (sorted.into_iter().map(|(_, i)| i).collect(), None)
}

/// A uniform grid of side `cell` over a set of points.
#[derive(Debug, Clone)]
pub struct CellGrid {
    cell: f64,
    /// The smallest and largest occupied cell on each axis.
    low: [i64; 3],
    high: [i64; 3],
    /// The occupied cells' keys, ascending, and where their points start in
    /// `order` (`starts[k]..starts[k + 1]`).
    keys: Vec<i64>,
    starts: Vec<usize>,
    /// The points' rows, by cell and then by row.
    order: Vec<u32>,
    span: [i64; 3],
    /// Where the first point of each cell of the box (occupied or not) is
    /// in `order`, one more entry at the end: a cell's points, and those of
    /// a run of cells along z, are one slice of `order` found in O(1)
    /// (None where the box has too many cells; then `keys` are searched).
    first: Option<Vec<u32>>,
}

/// The box's cells at most, for [`CellGrid`]'s dense table: this many
/// times the points, and at least [`DENSE_FLOOR`].
const DENSE_PER_POINT: usize = 16;
const DENSE_FLOOR: usize = 1 << 16;

/// The cell of a coordinate (`floor(x / cell)`; a NaN is cell 0, which the
/// callers' distance tests then leave out).
fn cell_of(x: f64, cell: f64) -> i64 {
    (x / cell).floor() as i64
}

/// The smallest and largest cell index along each axis (`i64::MAX` and
/// `i64::MIN` where there is no cell).
fn cell_bounds(at: &[[i64; 3]]) -> ([i64; 3], [i64; 3]) {
    let mut low = [i64::MAX; 3];
    let mut high = [i64::MIN; 3];
    for a in at {
        for c in 0..3 {
            low[c] = low[c].min(a[c]);
            high[c] = high[c].max(a[c]);
        }
    }
    (low, high)
}

impl CellGrid {
    /// The grid of side `cell` (positive) over `points` (finite).
    pub fn new(points: &[[f64; 3]], cell: f64) -> CellGrid {
        let at: Vec<[i64; 3]> =
            points.iter().map(|p| [0, 1, 2].map(|c| cell_of(p[c], cell))).collect();
        let (mut low, mut high) = cell_bounds(&at);
        if at.is_empty() {
            low = [0; 3];
            high = [-1; 3];
        }
        let span = [0, 1, 2].map(|c| (high[c] - low[c] + 1).max(1));
        let mut grid = CellGrid {
            cell,
            low,
            high,
            keys: Vec::new(),
            starts: Vec::new(),
            order: Vec::new(),
            span,
            first: None,
        };
        let keyed: Vec<i64> = at.iter().map(|a| grid.key(*a)).collect();
        let cells = span.iter().try_fold(1usize, |acc, &s| acc.checked_mul(s as usize));
        let (order, first) = order_by_key(&keyed, cells);
        for (k, &i) in order.iter().enumerate() {
            let key = keyed[i as usize];
            if grid.keys.last() != Some(&key) {
                grid.keys.push(key);
                grid.starts.push(k);
            }
        }
        grid.starts.push(order.len());
        grid.first = first;
        grid.order = order;
        grid
    }

    /// The rows of each occupied cell (by increasing row), the cells in
    /// ascending key.
    pub fn cells(&self) -> impl Iterator<Item = &[u32]> + '_ {
        self.starts.windows(2).map(|w| &self.order[w[0]..w[1]])
    }

    fn key(&self, a: [i64; 3]) -> i64 {
        ((a[0] - self.low[0]) * self.span[1] + (a[1] - self.low[1])) * self.span[2]
            + (a[2] - self.low[2])
    }

    /// Calls `visit(row)` for every point in the 27 cells around the cell
    /// of `q`, in the module doc's order.
    pub fn for_each_near(&self, q: [f64; 3], mut visit: impl FnMut(usize)) {
        let at = [0, 1, 2].map(|c| cell_of(q[c], self.cell));
        for dx in -1..=1i64 {
            let x = at[0].saturating_add(dx);
            if x < self.low[0] || x > self.high[0] {
                continue;
            }
            for dy in -1..=1i64 {
                let y = at[1].saturating_add(dy);
                if y < self.low[1] || y > self.high[1] {
                    continue;
                }
                if let Some(first) = &self.first {
                    // The cells z - 1, z, z + 1 (within the box) are one
                    // run of keys, so one slice of `order`, in their order.
                    let z0 = at[2].saturating_sub(1).max(self.low[2]);
                    let z1 = at[2].saturating_add(1).min(self.high[2]);
                    if z0 > z1 {
                        continue;
                    }
                    let (k0, k1) = (self.key([x, y, z0]) as usize, self.key([x, y, z1]) as usize);
                    for &row in &self.order[first[k0] as usize..first[k1 + 1] as usize] {
                        visit(row as usize);
                    }
                    continue;
                }
                for dz in -1..=1i64 {
                    let z = at[2].saturating_add(dz);
                    if z < self.low[2] || z > self.high[2] {
                        continue;
                    }
                    if let Ok(k) = self.keys.binary_search(&self.key([x, y, z])) {
                        for &row in &self.order[self.starts[k]..self.starts[k + 1]] {
                            visit(row as usize);
                        }
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lcg::Lcg;

    #[test]
    fn every_point_within_a_cell_is_visited_once_in_row_order_per_cell() {
        let mut rng = Lcg::new(7);
        let points: Vec<[f64; 3]> = (0..500)
            .map(|_| [rng.next_f64() * 2.0 - 1.0, rng.next_f64(), rng.next_f64() * 0.5])
            .collect();
        let cell = 0.13;
        let grid = CellGrid::new(&points, cell);
        for _ in 0..200 {
            let q = [
                rng.next_f64() * 2.4 - 1.2,
                rng.next_f64() * 1.2 - 0.1,
                rng.next_f64() * 0.7 - 0.1,
            ];
            let mut seen = Vec::new();
            grid.for_each_near(q, |r| seen.push(r));
            let mut unique = seen.clone();
            unique.sort_unstable();
            unique.dedup();
            assert_eq!(unique.len(), seen.len());
            for (r, p) in points.iter().enumerate() {
                let d2: f64 = (0..3).map(|c| (p[c] - q[c]) * (p[c] - q[c])).sum();
                if d2 <= cell * cell {
                    assert!(seen.contains(&r), "point {r} within a cell of {q:?} not visited");
                }
            }
        }
        // The dense table and the search of the keys: the same rows in the
        // same order.
        let mut searched = grid.clone();
        searched.first = None;
        for _ in 0..100 {
            let q = [
                rng.next_f64() * 2.4 - 1.2,
                rng.next_f64() * 1.2 - 0.1,
                rng.next_f64() * 0.7 - 0.1,
            ];
            let (mut x, mut y) = (Vec::new(), Vec::new());
            grid.for_each_near(q, |r| x.push(r));
            searched.for_each_near(q, |r| y.push(r));
            assert_eq!(x, y);
        }
        assert!(grid.first.is_some());
        // Far away: nothing.
        let mut none = 0;
        grid.for_each_near([100.0, 0.0, 0.0], |_| none += 1);
        grid.for_each_near([f64::NAN, f64::NAN, f64::NAN], |_| {});
        assert_eq!(none, 0);
    }
}
