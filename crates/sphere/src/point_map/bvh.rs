//! A bounding-volume hierarchy of axis-aligned boxes, for point location.
//!
//! The maps h^-1 (thesis 6.6) and the inverse barycentric map (3.3) must find,
//! for each of up to millions of points, the cell (triangle, or pole
//! trapezium) that holds it. Tutte-type embeddings are anything but uniform:
//! most triangles crowd into tiny regions (the exponential squeezing of long
//! limbs), so a uniform grid degenerates; a median-split box tree adapts to
//! the density. Built in O(n log n), queried in O(log n + overlapping boxes).

/// A box in `D` dimensions: `min[i] <= x[i] <= max[i]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb<const D: usize> {
    pub min: [f64; D],
    pub max: [f64; D],
}

impl<const D: usize> Aabb<D> {
    /// The smallest box holding `points`.
    pub fn around(points: &[[f64; D]]) -> Self {
        let mut b = Aabb { min: [f64::INFINITY; D], max: [f64::NEG_INFINITY; D] };
        for p in points {
            b.include(p);
        }
        b
    }

    fn include(&mut self, p: &[f64; D]) {
        for ((lo, hi), &x) in self.min.iter_mut().zip(self.max.iter_mut()).zip(p) {
            *lo = lo.min(x);
            *hi = hi.max(x);
        }
    }

    fn merge(&mut self, other: &Self) {
        self.include(&other.min);
        self.include(&other.max);
    }

    /// Whether `p` lies in the box grown by `slack` on every side.
    pub fn contains(&self, p: &[f64; D], slack: f64) -> bool {
        (0..D).all(|i| p[i] >= self.min[i] - slack && p[i] <= self.max[i] + slack)
    }

    fn centre(&self, axis: usize) -> f64 {
        0.5 * (self.min[axis] + self.max[axis])
    }
}

/// Leaves hold at most this many items.
const LEAF_SIZE: usize = 4;

#[derive(Debug, Clone)]
struct Node<const D: usize> {
    bounds: Aabb<D>,
    /// Leaf: items[start..start + count]; inner node: children at `start`
    /// and `start + 1` (count == 0).
    start: u32,
    count: u32,
}

/// A node's bounds in single precision, rounded outward (so they hold the
/// double bounds), with the node's `start` and `count`: 32 bytes for three
/// dimensions against 56, so that a query's walk down the tree, which is
/// bound by memory, reads half as many cache lines
/// ([`Bvh::for_each_box_containing`]).
#[derive(Debug, Clone, Copy)]
struct CompactNode<const D: usize> {
    min: [f32; D],
    max: [f32; D],
    start: u32,
    count: u32,
}

/// The largest single below or at `x` (`down`) or the smallest above or at
/// it: the outward rounding of a bound.
fn single_outward(x: f64, down: bool) -> f32 {
    let s = x as f32;
    if s.is_infinite() && x.is_finite() {
        // Beyond the singles' range, rounded to an infinity: the outward
        // bound is that infinity on its own side, the largest finite single
        // on the other (a box of huge coordinates must not come out empty).
        return match (x > 0.0, down) {
            (true, true) => f32::MAX,
            (false, false) => f32::MIN,
            _ => s,
        };
    }
    let past = if down { (s as f64) > x } else { (s as f64) < x };
    if !past || !s.is_finite() {
        return s;
    }
    // One step outward: the neighbouring single (a step across zero
    // goes to the smallest subnormal of the other sign).
    let bits = s.to_bits();
    let away_from_zero = (s > 0.0) != down;
    if s == 0.0 {
        let tiny = f32::from_bits(1);
        return if down { -tiny } else { tiny };
    }
    f32::from_bits(if away_from_zero { bits + 1 } else { bits - 1 })
}

impl<const D: usize> CompactNode<D> {
    fn new(node: &Node<D>) -> Self {
        CompactNode {
            min: node.bounds.min.map(|x| single_outward(x, true)),
            max: node.bounds.max.map(|x| single_outward(x, false)),
            start: node.start,
            count: node.count,
        }
    }

    /// [`Aabb::contains`] of the rounded-out bounds: true wherever the double
    /// bounds' test is.
    fn contains(&self, p: &[f64; D], slack: f64) -> bool {
        (0..D).all(|i| p[i] >= self.min[i] as f64 - slack && p[i] <= self.max[i] as f64 + slack)
    }
}

/// The items near the last region a query gathered
/// ([`Bvh::for_each_box_containing_near`]); one per worker.
#[derive(Debug, Clone)]
pub struct NearCache<const D: usize> {
    region: Aabb<D>,
    /// Leaf-order positions of the items whose box meets `region`.
    at: Vec<u32>,
}

impl<const D: usize> Default for NearCache<D> {
    fn default() -> Self {
        // An empty region: the first point gathers.
        NearCache {
            region: Aabb { min: [f64::INFINITY; D], max: [f64::NEG_INFINITY; D] },
            at: Vec::new(),
        }
    }
}

impl<const D: usize> NearCache<D> {
    fn holds(&self, p: &[f64; D]) -> bool {
        (0..D).all(|i| self.region.min[i] <= p[i] && p[i] <= self.region.max[i])
    }
}

/// A box tree over items `0..n`.
#[derive(Debug, Clone)]
pub struct Bvh<const D: usize> {
    nodes: Vec<Node<D>>,
    items: Vec<u32>,
    /// Each item's own box, in the order of `items` (the leaves' order), for
    /// [`Bvh::for_each_box_containing`].
    item_boxes: Vec<Aabb<D>>,
    /// `nodes` in single precision, for the same.
    compact: Vec<CompactNode<D>>,
}

impl<const D: usize> Bvh<D> {
    /// Builds the tree over one box per item.
    pub fn new(boxes: &[Aabb<D>]) -> Self {
        let mut items: Vec<u32> = (0..boxes.len() as u32).collect();
        let mut nodes = Vec::with_capacity(2 * boxes.len() / LEAF_SIZE + 1);
        if !boxes.is_empty() {
            nodes.push(Node { bounds: boxes[0], start: 0, count: 0 });
            // Explicit stack of (node, item range): no recursion depth limit.
            let mut stack = vec![(0usize, 0usize, boxes.len())];
            while let Some((node, lo, hi)) = stack.pop() {
                let mut bounds = boxes[items[lo] as usize];
                for &it in &items[lo + 1..hi] {
                    bounds.merge(&boxes[it as usize]);
                }
                nodes[node].bounds = bounds;
                if hi - lo <= LEAF_SIZE {
                    nodes[node].start = lo as u32;
                    nodes[node].count = (hi - lo) as u32;
                    continue;
                }
                // Split at the median centre along the widest axis of the centres.
                let mut centres = Aabb { min: [f64::INFINITY; D], max: [f64::NEG_INFINITY; D] };
                for &it in &items[lo..hi] {
                    let b = &boxes[it as usize];
                    let c: [f64; D] = std::array::from_fn(|i| b.centre(i));
                    centres.include(&c);
                }
                let axis = (0..D)
                    .max_by(|&a, &b| {
                        (centres.max[a] - centres.min[a])
                            .total_cmp(&(centres.max[b] - centres.min[b]))
                    })
                    .unwrap_or(0);
                let mid = lo + (hi - lo) / 2;
                items[lo..hi].select_nth_unstable_by(mid - lo, |&a, &b| {
                    boxes[a as usize].centre(axis).total_cmp(&boxes[b as usize].centre(axis))
                });
                let left = nodes.len();
                nodes.push(Node { bounds, start: 0, count: 0 });
                nodes.push(Node { bounds, start: 0, count: 0 });
                nodes[node].start = left as u32;
                nodes[node].count = 0;
                stack.push((left, lo, mid));
                stack.push((left + 1, mid, hi));
            }
        }
        let item_boxes = items.iter().map(|&it| boxes[it as usize]).collect();
        let compact = nodes.iter().map(CompactNode::new).collect();
        Bvh { nodes, items, item_boxes, compact }
    }

    /// Calls `visit(item)` for every item in a leaf whose bounds, grown by
    /// `slack`, contain `p`: a superset of the items whose own box does, so the
    /// caller tests each item's shape.
    pub fn for_each_containing(&self, p: &[f64; D], slack: f64, mut visit: impl FnMut(u32)) {
        self.for_each_leaf_containing(p, slack, |range| {
            for &it in &self.items[range] {
                visit(it);
            }
        });
    }

    /// Calls `visit(item)` for every item whose own box, grown by `slack`,
    /// contains `p`, in the order [`Bvh::for_each_containing`] visits them
    /// (it visits these and the other items of their leaves): the items it
    /// leaves out are the ones whose box does not hold `p`, tested on the
    /// boxes stored in leaf order, so the caller's finer test runs on fewer.
    pub fn for_each_box_containing(&self, p: &[f64; D], slack: f64, mut visit: impl FnMut(u32)) {
        // The walk tests the single-precision bounds, which hold the double
        // ones: it reaches every leaf the double walk reaches (and a few
        // more, by a rounding), in the same order, and the items' own boxes
        // (doubles) then decide alone.
        self.walk_compact(
            |node| node.contains(p, slack),
            |range| {
                for (&it, b) in self.items[range.clone()].iter().zip(&self.item_boxes[range]) {
                    if b.contains(p, slack) {
                        visit(it);
                    }
                }
            },
        );
    }

    /// The single-precision tree depth first (the second child before the
    /// first), into the nodes that pass `enters`, handing each leaf's
    /// leaf-order item range to `leaf`: the one walk of
    /// [`Bvh::for_each_box_containing`] and of the near cache's gather, so
    /// that both visit the leaves in the same order.
    fn walk_compact(
        &self,
        enters: impl Fn(&CompactNode<D>) -> bool,
        mut leaf: impl FnMut(std::ops::Range<usize>),
    ) {
        if self.compact.is_empty() {
            return;
        }
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.compact[stack[top] as usize];
            if !enters(node) {
                continue;
            }
            if node.count > 0 {
                leaf(node.start as usize..(node.start + node.count) as usize);
            } else {
                stack[top] = node.start;
                stack[top + 1] = node.start + 1;
                top += 2;
            }
        }
    }

    /// [`Bvh::for_each_box_containing`] through `cache`: the items whose box
    /// meets a small region around a point (`reach` on every side) are
    /// gathered once, in the walk's order, and every later point inside that
    /// region is tested on them alone instead of walking the tree again.
    /// The same items in the same order as the walk: a point `p` of the
    /// region passes a node's test (or an item's) only where the region
    /// does (the same comparisons with the same rounded bounds, and
    /// `min <= p <= max` on every axis), so the gathered items hold every
    /// item the walk from `p` visits, in the order of the same walk, and
    /// the item test then decides alone. Points located in a spatial order
    /// come in clusters (a Gauss-Newton step's probes, a few millionths
    /// apart): those after the first skip the walk (issue 23, speed).
    pub fn for_each_box_containing_near(
        &self,
        p: &[f64; D],
        slack: f64,
        reach: f64,
        cache: &mut NearCache<D>,
        mut visit: impl FnMut(u32),
    ) {
        if !cache.holds(p) {
            cache.region = Aabb {
                min: std::array::from_fn(|i| p[i] - reach),
                max: std::array::from_fn(|i| p[i] + reach),
            };
            cache.at.clear();
            self.gather_meeting(&cache.region, slack, &mut cache.at);
        }
        for &k in &cache.at {
            if self.item_boxes[k as usize].contains(p, slack) {
                visit(self.items[k as usize]);
            }
        }
    }

    /// The leaf-order positions of the items whose own box, grown by
    /// `slack`, meets `region`, in the order of
    /// [`Bvh::for_each_box_containing`]'s walk (the same node tests, passed
    /// wherever some point of `region` would pass them).
    fn gather_meeting(&self, region: &Aabb<D>, slack: f64, out: &mut Vec<u32>) {
        let meets = |min: &[f64; D], max: &[f64; D]| {
            (0..D).all(|i| region.max[i] >= min[i] - slack && region.min[i] <= max[i] + slack)
        };
        self.walk_compact(
            |node| meets(&node.min.map(f64::from), &node.max.map(f64::from)),
            |range| {
                for k in range {
                    let b = &self.item_boxes[k];
                    if meets(&b.min, &b.max) {
                        out.push(k as u32);
                    }
                }
            },
        );
    }

    /// The item ranges of the leaves whose bounds, grown by `slack`, contain
    /// `p`, depth first (the second child before the first).
    fn for_each_leaf_containing(
        &self,
        p: &[f64; D],
        slack: f64,
        mut leaf: impl FnMut(std::ops::Range<usize>),
    ) {
        if self.nodes.is_empty() {
            return;
        }
        // A median split halves the items at every level, so with u32 items
        // the tree is at most 33 levels deep and the stack holds at most one
        // node a level plus one: a fixed array, no allocation a query.
        let mut stack = [0u32; 64];
        let mut top = 1usize;
        while top > 0 {
            top -= 1;
            let node = &self.nodes[stack[top] as usize];
            if !node.bounds.contains(p, slack) {
                continue;
            }
            if node.count > 0 {
                let start = node.start as usize;
                leaf(start..start + node.count as usize);
            } else {
                stack[top] = node.start;
                stack[top + 1] = node.start + 1;
                top += 2;
            }
        }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// Whether the tree holds no items.
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::lcg::Lcg;

    #[test]
    fn finds_exactly_the_boxes_a_brute_force_scan_finds() {
        let mut s = Lcg::new(7);
        let boxes: Vec<Aabb<2>> = (0..500)
            .map(|_| {
                let (x, y) = (s.next_f64(), s.next_f64());
                // Mixed sizes, including long thin boxes.
                let (w, h) = (s.next_f64().powi(3), s.next_f64().powi(6));
                Aabb { min: [x, y], max: [x + w, y + h] }
            })
            .collect();
        let bvh = Bvh::new(&boxes);
        assert_eq!(bvh.len(), 500);
        for _ in 0..300 {
            let p = [s.next_f64() * 1.2, s.next_f64() * 1.2];
            let mut got = Vec::new();
            bvh.for_each_containing(&p, 0.0, |i| {
                if boxes[i as usize].contains(&p, 0.0) {
                    got.push(i)
                }
            });
            let mut filtered = Vec::new();
            bvh.for_each_box_containing(&p, 0.0, |i| filtered.push(i));
            // The same items in the same order.
            assert_eq!(filtered, got);
            got.sort_unstable();
            let want: Vec<u32> =
                (0..500u32).filter(|&i| boxes[i as usize].contains(&p, 0.0)).collect();
            assert_eq!(got, want);
        }
    }

    #[test]
    fn the_near_cache_visits_what_the_walk_visits() {
        // Clusters of points a few reaches wide (some inside the cached
        // region, some just outside it, some on box edges), with a slack:
        // the cached path visits the same items in the same order.
        let mut s = Lcg::new(11);
        let boxes: Vec<Aabb<3>> = (0..2000)
            .map(|_| {
                let c = [s.next_f64(), s.next_f64(), s.next_f64()];
                let size = [s.next_f64().powi(4), s.next_f64().powi(8), s.next_f64().powi(2)];
                Aabb {
                    min: std::array::from_fn(|i| c[i]),
                    max: std::array::from_fn(|i| c[i] + 0.05 * size[i]),
                }
            })
            .collect();
        let bvh = Bvh::new(&boxes);
        let mut cache = NearCache::default();
        let reach = 1e-3;
        for k in 0..400 {
            let base = if k % 5 == 0 {
                // On a box's corner: the comparisons at their edges.
                boxes[(s.next_f64() * 2000.0) as usize].max
            } else {
                [s.next_f64(), s.next_f64(), s.next_f64()]
            };
            for _ in 0..8 {
                let p: [f64; 3] =
                    std::array::from_fn(|i| base[i] + 3.0 * reach * (s.next_f64() - 0.5));
                for slack in [0.0, 1e-10] {
                    let mut walk = Vec::new();
                    bvh.for_each_box_containing(&p, slack, |i| walk.push(i));
                    let mut near = Vec::new();
                    bvh.for_each_box_containing_near(&p, slack, reach, &mut cache, |i| {
                        near.push(i)
                    });
                    assert_eq!(near, walk);
                }
            }
        }
        // Not finite: nothing, as the walk.
        let mut near = Vec::new();
        bvh.for_each_box_containing_near(&[f64::NAN, 0.5, 0.5], 0.0, reach, &mut cache, |i| {
            near.push(i)
        });
        assert!(near.is_empty());
    }

    #[test]
    fn single_bounds_round_outward() {
        let mut s = Lcg::new(3);
        for _ in 0..10_000 {
            let x = (s.next_f64() - 0.5) * 10f64.powi((s.next_f64() * 20.0) as i32 - 10);
            let (lo, hi) = (single_outward(x, true), single_outward(x, false));
            assert!((lo as f64) <= x && x <= (hi as f64), "{x} {lo} {hi}");
            assert!(hi.to_bits().abs_diff(lo.to_bits()) <= 2 || lo < 0.0 && hi > 0.0);
        }
        for x in [0.0, -0.0, 1.0, -1.0, f64::MIN_POSITIVE, 1e-300, -1e-300, 1e39, -1e39, 1e300] {
            let (lo, hi) = (single_outward(x, true), single_outward(x, false));
            assert!((lo as f64) <= x && x <= (hi as f64), "{x} {lo} {hi}");
        }
    }

    #[test]
    fn empty_tree_visits_nothing() {
        let bvh = Bvh::<3>::new(&[]);
        let mut n = 0;
        bvh.for_each_containing(&[0.0; 3], 1.0, |_| n += 1);
        assert_eq!(n, 0);
        assert!(bvh.is_empty());
    }
}
