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
        for (j, &v) in vertices.iter().enumerate() {
            local[v as usize] = j as u32;
        }
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
        for (&q, &v) in self.points.iter().zip(vertices) {
            points[v as usize] = q;
        }
    }
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
