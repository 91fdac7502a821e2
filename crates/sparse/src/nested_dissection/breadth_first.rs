//! The breadth-first searches of [`super::Dissection`], which take most of
//! the ordering's own time: each piece is searched twice (the far end of a
//! search from anywhere is nearly peripheral, and the levels of a search from
//! there cut the piece across its length).
//!
//! They change no result: the searches are bound by memory latency, so they
//! prefetch the adjacency of vertices queued ahead, and a search whose
//! start is already known (the near side's first search repeats the first
//! levels of its parent's second) goes on from there.

use super::Dissection;
use std::sync::atomic::Ordering::Relaxed;

/// How many vertices of a search's queue ahead of the one being searched
/// have their adjacency fetched into the cache early (their offsets twice
/// as far ahead). The searches are bound by memory latency, not work: in the
/// first cut's two sweeps over a million unknowns in the mesh's own
/// numbering, the load of each queued vertex's neighbour list missed the
/// cache (three quarters of the samples), and prefetching them halved the
/// time (0.105 s to 0.053 s); the halves' ordering went from 0.36 to
/// 0.29 s on one core. Prefetching the neighbours' labels too was slower.
const AHEAD: usize = 8;

/// Asks for `x`'s cache line ahead of its use: a hint only, which changes
/// no result.
#[inline(always)]
fn prefetch<T>(x: &T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch of any address only hints the cache (it cannot
    // fault), and this one is of a live reference; `_mm_prefetch` needs sse,
    // which every x86_64 has.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(
            (x as *const T).cast::<i8>(),
        )
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = x;
}

/// The start of a piece's first breadth-first search from its hint, found
/// by an earlier search that passed the same way: `vs[..end]` is the
/// search's queue so far (`vs[0]` the hint) and the vertices before `head`
/// have had their neighbours searched. Searching on from there ends where
/// the whole search would, in the same order.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Known {
    pub(super) head: usize,
    pub(super) end: usize,
}

/// A breadth-first search's vertices in visiting order, and where each level starts.
pub(super) struct Levels {
    pub(super) queue: Vec<u32>,
    pub(super) starts: Vec<usize>,
}

impl Levels {
    pub(super) fn count(&self) -> usize {
        self.starts.len() - 1
    }

    pub(super) fn level(&self, k: usize) -> &[u32] {
        &self.queue[self.starts[k]..self.starts[k + 1]]
    }
}

/// Prefetches what reading the rows (CSR `offsets`, `indices`) of the
/// vertices [`AHEAD`] of `order[i]` will touch: their neighbour lists, and
/// their offsets before that. For every walk over rows in an order that
/// jumps about the graph: the searches' queues, the elimination tree's
/// `perm`, a half's rows in the first cut's order.
#[inline(always)]
pub(crate) fn prefetch_rows_ahead(offsets: &[usize], indices: &[u32], order: &[u32], i: usize) {
    if let Some(&u) = order.get(i + 2 * AHEAD) {
        prefetch(&offsets[u as usize]);
    }
    if let Some(&u) = order.get(i + AHEAD) {
        if let Some(first) = indices.get(offsets[u as usize]) {
            prefetch(first);
        }
    }
}

impl Dissection<'_> {
    /// [`prefetch_rows_ahead`] in this graph.
    fn prefetch_ahead(&self, queue: &[u32], i: usize) {
        prefetch_rows_ahead(self.offsets, self.indices, queue, i);
    }

    /// The vertices a breadth-first search from `start` through the
    /// vertices labelled `from` reaches, in its order, relabelled `to`; the
    /// search goes on from what is known of it (`known`, empty when nothing
    /// is, else starting with `start`; its vertices before `head` searched).
    pub(super) fn sweep(
        &self,
        start: u32,
        from: u32,
        to: u32,
        known: &[u32],
        head: usize,
        capacity: usize,
    ) -> Vec<u32> {
        let mut queue = Vec::with_capacity(capacity);
        let mut head = head;
        if known.is_empty() {
            queue.push(start);
            head = 0;
        } else {
            debug_assert_eq!(known[0], start);
            queue.extend_from_slice(known);
        }
        for &v in &queue {
            self.label[v as usize].store(to, Relaxed);
        }
        while head < queue.len() {
            self.prefetch_ahead(&queue, head);
            let v = queue[head];
            head += 1;
            for &w in self.neighbours(v) {
                if self.label[w as usize].load(Relaxed) == from {
                    self.label[w as usize].store(to, Relaxed);
                    queue.push(w);
                }
            }
        }
        queue
    }

    /// Breadth-first search from `start` through the vertices labelled
    /// `from`, relabelling those it reaches `to`.
    pub(super) fn bfs(&self, start: u32, from: u32, to: u32, capacity: usize) -> Levels {
        let mut queue = Vec::with_capacity(capacity);
        let mut starts = vec![0];
        self.label[start as usize].store(to, Relaxed);
        queue.push(start);
        let mut head = 0;
        while head < queue.len() {
            let end = queue.len();
            for i in head..end {
                self.prefetch_ahead(&queue, i);
                for &w in self.neighbours(queue[i]) {
                    if self.label[w as usize].load(Relaxed) == from {
                        self.label[w as usize].store(to, Relaxed);
                        queue.push(w);
                    }
                }
            }
            head = end;
            starts.push(end);
        }
        Levels { queue, starts }
    }
}
