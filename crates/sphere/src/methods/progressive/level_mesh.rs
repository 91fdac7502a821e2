//! A coarse level of the progressive method as a mesh of its own: its
//! vertices renumbered `0..m` in the mesh's order, with their rings, surface
//! positions, represented areas and points copied out, so that the level's
//! sweeps cost its own size.
//!
//! The rings of the whole mesh have one slot per vertex, alive or not; a
//! level's stars, colouring, sums and per-sweep flags walked all `n` slots,
//! on every level and, on the coarse levels, up to a hundred times (once per
//! sweep). That was the insertion's superlinear part: 19.7 times the time
//! for 10 times the vertices from 1M to 10M. Gathering a level costs its
//! size once. The global L-BFGS steps of the stretch and balanced energies'
//! coarse levels run on the copy too: on the whole mesh's slots 30 steps of a
//! 93-vertex level took 1.9 s of a 200k-vertex `helix_tube` map.
//!
//! The result is the same, bit for bit: the local numbers keep the mesh's
//! order, so the greedy colouring, the order of every sum and every "seen
//! from its smallest corner" test are those of the whole mesh with the
//! removed vertices (empty rings, which add nothing) left out.

use rayon::prelude::*;

use crate::memory_budget::{filled, reserved, ResourceError};

/// One level, numbered `0..vertices.len()` in the order of `vertices`.
#[derive(Debug)]
pub struct LevelMesh {
    /// Vertex `j`'s ring is `ring[start[j]..start[j + 1]]`, in local numbers.
    pub start: Vec<usize>,
    pub ring: Vec<u32>,
    pub surface: Vec<[f64; 3]>,
    pub represented: Option<Vec<f64>>,
    pub points: Vec<[f64; 3]>,
}

impl LevelMesh {
    /// Copies out the level whose vertices are `vertices` (ascending: the
    /// level's alive vertices, whose rings hold only one another).
    /// `local` has one slot per vertex of the whole mesh; the slots of
    /// `vertices` are overwritten with their local numbers.
    ///
    /// # Errors
    /// [`ResourceError::Allocation`] when the system refuses the memory.
    pub fn gather(
        vertices: &[u32],
        local: &mut [u32],
        rings: &[Vec<u32>],
        surface: &[[f64; 3]],
        represented: Option<&[f64]>,
        points: &[[f64; 3]],
    ) -> Result<LevelMesh, ResourceError> {
        debug_assert!(vertices.windows(2).all(|w| w[0] < w[1]));
        let m = vertices.len();
        write_ascending(local, vertices, |j| Some(j as u32));
        let mut start = reserved(m + 1, "a progressive level's ring offsets")?;
        start.push(0);
        for &v in vertices {
            start.push(start[start.len() - 1] + rings[v as usize].len());
        }
        let mut ring = filled(start[m], 0u32, "a progressive level's rings")?;
        // Block by block in parallel (each vertex's list is renumbered on
        // its own): the level's largest copy.
        const BLOCK: usize = 1024;
        let local: &[u32] = local;
        let mut blocks = Vec::with_capacity(m.div_ceil(BLOCK));
        let mut rest = ring.as_mut_slice();
        for first in (0..m).step_by(BLOCK) {
            let end = (first + BLOCK).min(m);
            let (block, tail) = rest.split_at_mut(start[end] - start[first]);
            blocks.push((&vertices[first..end], block));
            rest = tail;
        }
        blocks.into_par_iter().for_each(|(block_vertices, out)| {
            let mut at = 0;
            for &v in block_vertices {
                for &r in &rings[v as usize] {
                    out[at] = local[r as usize];
                    at += 1;
                }
            }
        });
        let level_represented = match represented {
            Some(rho) => Some(picked(rho, vertices, "a progressive level's represented areas")?),
            None => None,
        };
        Ok(LevelMesh {
            start,
            ring,
            surface: picked(surface, vertices, "a progressive level's surface")?,
            represented: level_represented,
            points: picked(points, vertices, "a progressive level's points")?,
        })
    }

    /// The level's number of vertices.
    pub fn n_vertices(&self) -> usize {
        self.start.len() - 1
    }

    /// Local vertex `j`'s ring.
    pub fn ring(&self, j: usize) -> &[u32] {
        &self.ring[self.start[j]..self.start[j + 1]]
    }

    /// Writes the level's points back to the whole mesh's `points`.
    pub fn scatter(&self, vertices: &[u32], points: &mut [[f64; 3]]) {
        write_ascending(points, &vertices[..self.points.len()], |j| Some(self.points[j]));
    }
}

/// Slots per block of [`write_ascending`].
const WRITE_BLOCK: usize = 1 << 14;

/// `out[index[x]] = value(x)` for every `x` where `value` gives a value, in
/// order of `x`. Where `index` is ascending (a level's vertices, a colour
/// class), blocks of `out` take their part of `index` in parallel: the same
/// writes in the same order within each slot. These were serial loops of
/// scattered writes beside parallel work (issue 27: a level's numbering
/// and write-back, the sweeps' moves); elsewhere one loop, as before.
pub fn write_ascending<T: Send>(
    out: &mut [T],
    index: &[u32],
    value: impl Fn(usize) -> Option<T> + Sync,
) {
    let write = |out: &mut [T], base: usize, range: std::ops::Range<usize>| {
        for x in range {
            if let Some(v) = value(x) {
                out[index[x] as usize - base] = v;
            }
        }
    };
    if index.len() < WRITE_BLOCK || !index.is_sorted() {
        write(out, 0, 0..index.len());
        return;
    }
    out.par_chunks_mut(WRITE_BLOCK).enumerate().for_each(|(b, block)| {
        let base = b * WRITE_BLOCK;
        let first = index.partition_point(|&i| (i as usize) < base);
        let end = index.partition_point(|&i| (i as usize) < base + block.len());
        if first < end {
            write(block, base, first..end);
        }
    });
}

/// `values[v]` for each of `vertices`, in order.
fn picked<T: Copy + Send + Sync>(
    values: &[T],
    vertices: &[u32],
    what: &'static str,
) -> Result<Vec<T>, ResourceError> {
    let mut out = reserved(vertices.len(), what)?;
    out.par_extend(vertices.par_iter().map(|&v| values[v as usize]));
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_in_parallel_blocks_are_the_serial_loops() {
        let n = 5 * WRITE_BLOCK + 77;
        // Ascending indices with gaps, some values left out; and the same
        // indices out of order (one loop).
        let index: Vec<u32> = (0..n as u32).filter(|i| i % 3 != 1).collect();
        let value = |x: usize| (x % 7 != 3).then_some(x as u64 * 11);
        // The serial loop: each index's value in turn, the later winning.
        let serial = |index: &[u32]| {
            let mut out = vec![1u64; n];
            for (x, &i) in index.iter().enumerate() {
                if let Some(v) = value(x) {
                    out[i as usize] = v;
                }
            }
            out
        };
        let mut blocks = vec![1u64; n];
        write_ascending(&mut blocks, &index, value);
        assert_eq!(blocks, serial(&index));
        let mut reversed = index.clone();
        reversed.reverse();
        let mut got = vec![1u64; n];
        write_ascending(&mut got, &reversed, value);
        assert_eq!(got, serial(&reversed));
    }
}
