//! Fiduccia-Mattheyses refinement of a vertex separator: the level-set
//! separators of [`super::Dissection::cut`] follow the breadth-first
//! search's wavefront, which is ragged and longer than the shortest ring
//! around the piece; moving separator vertices one at a time into a side
//! shortens it.
//!
//! Moving a separator vertex `v` into side `t` takes its neighbours on the
//! other side into the separator (they would touch `t` otherwise): the
//! separator changes by `|N(v) on the other side| - 1`, so the gain of the
//! move is `1 - |N(v) on the other side|` (Ashcraft and Liu, "A partition
//! improvement algorithm for generalized nested dissection", 1994; the
//! vertex-separator refinement of METIS, Karypis and Kumar, "A fast and high
//! quality multilevel scheme for partitioning irregular graphs", 1998). As in
//! Fiduccia and Mattheyses (1982), each pass takes the move of largest gain
//! (negative gains too: climbing out of a local minimum), locks the moved
//! vertex, and at the end rolls back to the smallest separator it met; a
//! move that would leave the shrinking side below the balance bound is not
//! taken. Passes repeat while they shrink the separator.
//!
//! Only the separator's neighbourhood is touched: a pass costs about its
//! moves times the squared degree, nothing per vertex of the piece.

use super::Dissection;
use std::sync::atomic::Ordering::Relaxed;

/// Passes at most (each one that does not shrink the separator ends the
/// refinement): the first takes most of the gain.
const PASSES: usize = 3;

/// Pieces at least this large are refined in full; smaller ones take one
/// pass that stops at its first move that does not shrink the separator
/// (which drops the vertices touching one side only). Measured on the 1M
/// helix and blob: the same fill, and most of the refinement's time saved
/// (most pieces of the recursion are small).
const THOROUGH: usize = 4096;

/// Moves a pass makes past its best separator before it gives up: 1% of
/// the piece, at least 15 and at most 100 (the limit of METIS's
/// `FM_2WayNodeRefine`): a small piece's separator is short, and most
/// pieces of the recursion are small.
fn patience(len: usize) -> usize {
    (len / 100).clamp(15, 100)
}

/// A piece cut in two: the labels of its near side, far side and separator,
/// how many vertices each side has, and the separator's vertices. No edge
/// joins a vertex labelled `near` to one labelled `far`.
pub(super) struct Split {
    pub(super) labels: [u32; 2],
    pub(super) sep: u32,
    pub(super) sizes: [usize; 2],
    pub(super) separator: Vec<u32>,
}

/// One move of a pass, to undo it: `v` went from the separator to side
/// `to`, and `pulled[from..]` (up to the next move's) from the other side
/// into the separator.
struct Move {
    v: u32,
    to: usize,
    from: usize,
}

impl Dissection<'_> {
    /// Refines `split` in place: the separator never grows, and neither
    /// side falls below `least` vertices that it did not start below.
    pub(super) fn refine_separator(&self, split: &mut Split, least: usize) {
        let least = least.min(split.sizes[0]).min(split.sizes[1]).max(1);
        let mut queue = Buckets { buckets: Vec::new(), lowest: 0 };
        let len = split.sizes[0] + split.sizes[1] + split.separator.len();
        let (passes, patience) = if len >= THOROUGH { (PASSES, patience(len)) } else { (1, 0) };
        for _ in 0..passes {
            if !self.pass(split, least, patience, &mut queue) {
                break;
            }
        }
    }

    /// The number of `v`'s neighbours labelled `label`.
    fn count_labelled(&self, v: u32, label: u32) -> i64 {
        self.neighbours(v)
            .iter()
            .filter(|&&w| self.label[w as usize].load(Relaxed) == label)
            .count() as i64
    }

    /// One pass; whether it shrank the separator.
    ///
    /// One function on purpose: the moves, their gains and the roll-back to
    /// the best prefix of the pass share the pass's log of moves.
    fn pass(&self, split: &mut Split, least: usize, patience: usize, queue: &mut Buckets) -> bool {
        let labels = split.labels;
        let sep = split.sep;
        let label = |v: u32| self.label[v as usize].load(Relaxed);
        // The neighbours a move of `v` to side `to` would pull: its cost.
        let pulls = |v: u32, to: usize| self.count_labelled(v, labels[1 - to]) as usize;
        // Entries go stale as their vertices' neighbourhoods change; each
        // change pushes a fresh one, and a popped entry whose cost is no
        // longer the vertex's is dropped.
        queue.clear();
        for &v in &split.separator {
            for to in 0..2 {
                queue.push(pulls(v, to), v, to);
            }
        }
        // A vertex moved in this pass is locked: its `local` slot holds the
        // pass's stamp, a label never used before (the slots of a piece
        // being cut hold nothing else: `local` serves the leaves, and a
        // leaf is never cut).
        let stamp = self.fresh();
        let locked = |v: u32| self.local[v as usize].load(Relaxed) == stamp;
        let mut moves: Vec<Move> = Vec::new();
        let mut pulled: Vec<u32> = Vec::new();
        let mut entered: Vec<u32> = Vec::new();
        let start = split.separator.len();
        let imbalance = |sizes: [usize; 2]| sizes[0].abs_diff(sizes[1]);
        let (mut size, mut sizes) = (start, split.sizes);
        let (mut best, mut best_moves) = ((start, imbalance(sizes)), 0);
        while let Some((taken, v, to)) = queue.pop() {
            if label(v) != sep || locked(v) || pulls(v, to) != taken {
                continue;
            }
            let from = 1 - to;
            if sizes[from] < least + taken {
                continue;
            }
            // The move: v to side `to`, its neighbours on the other side
            // into the separator.
            self.label[v as usize].store(labels[to], Relaxed);
            self.local[v as usize].store(stamp, Relaxed);
            moves.push(Move { v, to, from: pulled.len() });
            for &w in self.neighbours(v) {
                if label(w) == labels[from] {
                    self.label[w as usize].store(sep, Relaxed);
                    pulled.push(w);
                    entered.push(w);
                }
            }
            sizes[to] += 1;
            sizes[from] -= taken;
            size = size + taken - 1;
            // Fresh gains of the separator vertices whose neighbourhoods changed.
            let first = moves.last().map_or(0, |m| m.from);
            for &u in std::iter::once(&v).chain(&pulled[first..]) {
                for &x in std::iter::once(&u).chain(self.neighbours(u)) {
                    if label(x) == sep && !locked(x) {
                        for t in 0..2 {
                            queue.push(pulls(x, t), x, t);
                        }
                    }
                }
            }
            let now = (size, imbalance(sizes));
            if now < best {
                (best, best_moves) = (now, moves.len());
            } else if moves.len() - best_moves > patience {
                break;
            }
        }
        // Roll back to the best separator met.
        while moves.len() > best_moves {
            let Some(m) = moves.pop() else { break };
            for &w in &pulled[m.from..] {
                self.label[w as usize].store(labels[1 - m.to], Relaxed);
                sizes[1 - m.to] += 1;
            }
            sizes[m.to] -= 1;
            pulled.truncate(m.from);
            self.label[m.v as usize].store(sep, Relaxed);
        }
        split.sizes = sizes;
        // The separator now: the old one and what entered, in that order,
        // once each (a mark label tells the ones already kept).
        split.separator.extend(entered);
        let kept = self.fresh();
        split.separator.retain(|&v| {
            let keep = label(v) == sep;
            if keep {
                self.label[v as usize].store(kept, Relaxed);
            }
            keep
        });
        for &v in &split.separator {
            self.label[v as usize].store(sep, Relaxed);
        }
        best.0 < start
    }
}

/// Candidate moves, cheapest first: bucket `c` holds the moves that pull
/// `c` vertices into the separator (gain `1 - c`). Costs are small integers
/// (a mesh vertex has about six neighbours), so a bucket queue pushes and
/// pops in constant time where a binary heap took about half of the
/// refinement's time. Within a bucket the first pushed comes first
/// (deterministic; on the 1M blob it left 5% fewer flops than last-first).
struct Buckets {
    /// Each bucket's moves, and how many of them were popped.
    buckets: Vec<(Vec<(u32, u8)>, usize)>,
    /// No bucket below this one holds anything.
    lowest: usize,
}

impl Buckets {
    fn clear(&mut self) {
        for (moves, head) in &mut self.buckets {
            moves.clear();
            *head = 0;
        }
        self.lowest = self.buckets.len();
    }

    fn push(&mut self, cost: usize, v: u32, to: usize) {
        if cost >= self.buckets.len() {
            self.buckets.resize_with(cost + 1, Default::default);
        }
        self.buckets[cost].0.push((v, to as u8));
        self.lowest = self.lowest.min(cost);
    }

    fn pop(&mut self) -> Option<(usize, u32, usize)> {
        while let Some((moves, head)) = self.buckets.get_mut(self.lowest) {
            if let Some(&(v, to)) = moves.get(*head) {
                *head += 1;
                return Some((self.lowest, v, to as usize));
            }
            self.lowest += 1;
        }
        None
    }
}
