//! The farthest pair of a point set, exactly (thesis eq. 6.1-6.2), in
//! O(N log N) on the shapes meshes have, round ones included, where the
//! thesis's double loop is O(N^2).
//!
//! Why not a farthest-point search in a tree of boxes: on a round shape the
//! best pair is within about 1e-10 of the largest length any box allows, and a
//! box's corner bound overshoots by about the box's size, so a query from x
//! keeps a whole cap of boxes around x's antipode (O(N^1.5) in all; slower
//! than the double loop at 10^5 points on a sphere).
//!
//! What is done instead: write every point as c + r u, with c a centre (the
//! midpoint of a long pair), r >= 0 and u a unit direction. By the law of
//! cosines |x - y|^2 = r_x^2 + r_y^2 - 2 r_x r_y (u_x . u_y), so a pair at
//! least D long needs
//!
//! ```text
//!     |u_x + u_y|^2 = 2 (1 + u_x . u_y) <= ((r_x + r_y)^2 - D^2) / (r_x r_y),
//! ```
//!
//! The right side grows with r_y wherever r_y >= r_x (its derivative in r_y
//! has the sign of r_y^2 - r_x^2 + D^2). Every pair is searched for from both
//! ends, and from the end nearer the centre the largest r_y of a group of
//! points bounds it for all of them. So the partners of x that can beat D
//! have directions near x's antipodal direction -u_x: a search in a k-d tree
//! of the directions whose nodes know their largest r, and whose box bound
//! (the nearest point of a box) is tight. On a round shape, small boxes have
//! a small spread of r, the radius near -u_x is about 1e-5, and a query
//! visits O(log N) nodes.
//!
//! Exactness: each pair the searches return is compared with the best by its
//! own squared length, as the double loop did (ties to the smallest index
//! pair). The searches may return too many pairs, never too few: D is taken a
//! relative 1e-12 short of the best (a squared length is a sum of three
//! rounded squares), and the radius is widened by a slack that covers the
//! rounding of c, r and u, which grows with how far the points lie from the
//! origin compared to their size. Points very near c have poorly known
//! directions; they are compared with every candidate directly.

use rayon::prelude::*;

use super::dist2;

/// Points per leaf of the direction tree.
const LEAF_SIZE: usize = 8;

/// Relative shortening of D against the rounding of a squared length.
const LENGTH_SLACK: f64 = 1e-12;

/// Points closer to the centre than this fraction of r_max are compared
/// directly: their directions are too uncertain for the search.
const CENTRAL: f64 = 1e-2;

/// Points per parallel task of the searches.
const CHUNK: usize = 4096;

/// The best pair so far: lower index, higher index, squared length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Pair {
    pub lo: u32,
    pub hi: u32,
    pub length2: f64,
}

impl Pair {
    /// Takes the pair of `x` and `y` at squared length `d` if it beats this
    /// one: longer, or as long with the smaller (lower, higher) index pair.
    /// "Beats" is a total order, so the best of many searches does not
    /// depend on their order.
    fn offer(&mut self, x: u32, y: u32, d: f64) {
        let (lo, hi) = (x.min(y), x.max(y));
        if x != y && (d > self.length2 || (d == self.length2 && (lo, hi) < (self.lo, self.hi))) {
            *self = Pair { lo, hi, length2: d };
        }
    }

    fn better(mut self, other: Pair) -> Pair {
        self.offer(other.lo, other.hi, other.length2);
        self
    }
}

/// One point as the search sees it: its unit direction from the centre,
/// its distance from the centre, its position and its index.
#[derive(Debug, Clone, Copy)]
struct Item {
    direction: [f64; 3],
    reach: f64,
    position: [f64; 3],
    index: u32,
}

/// A node of the k-d tree: the bounding box of `items[start..end]`'s
/// directions, the largest distance of those points from the centre, and its
/// two children (`None` for a leaf).
struct Node {
    low: [f64; 3],
    high: [f64; 3],
    reach: f64,
    start: usize,
    end: usize,
    children: Option<(usize, usize)>,
}

/// A k-d tree over the directions of some points, each node's points
/// contiguous in `items` (so a leaf is one cache-friendly run).
struct DirectionTree {
    items: Vec<Item>,
    nodes: Vec<Node>,
}

impl DirectionTree {
    fn new(items: Vec<Item>) -> Self {
        let mut tree = DirectionTree { items, nodes: Vec::new() };
        if !tree.items.is_empty() {
            tree.build(0, tree.items.len());
        }
        tree
    }

    /// Adds the node for `items[start..end]` and its subtree; returns its index.
    fn build(&mut self, start: usize, end: usize) -> usize {
        let (mut low, mut high, mut reach) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3], 0.0f64);
        for item in &self.items[start..end] {
            for k in 0..3 {
                low[k] = low[k].min(item.direction[k]);
                high[k] = high[k].max(item.direction[k]);
            }
            reach = reach.max(item.reach);
        }
        let id = self.nodes.len();
        self.nodes.push(Node { low, high, reach, start, end, children: None });
        if end - start > LEAF_SIZE {
            // Split the widest side at the median.
            let axis = (0..3)
                .max_by(|&a, &b| (high[a] - low[a]).total_cmp(&(high[b] - low[b])))
                .unwrap_or(0);
            let middle = (start + end) / 2;
            self.items[start..end].select_nth_unstable_by(middle - start, |a, b| {
                a.direction[axis].total_cmp(&b.direction[axis])
            });
            let left = self.build(start, middle);
            let right = self.build(middle, end);
            self.nodes[id].children = Some((left, right));
        }
        id
    }

    /// Calls `visit` with every point whose direction lies within
    /// `radius(reach)` of `target`, where `reach` is the largest distance
    /// from the centre in the point's node (and possibly with a few more: a
    /// leaf is visited whole).
    fn within(
        &self,
        target: [f64; 3],
        radius: impl Fn(f64) -> f64,
        stack: &mut Vec<usize>,
        mut visit: impl FnMut(&Item),
    ) {
        stack.clear();
        stack.push(0);
        while let Some(id) = stack.pop() {
            let node = &self.nodes[id];
            let gap2: f64 = (0..3)
                .map(|k| {
                    let gap = (node.low[k] - target[k]).max(target[k] - node.high[k]).max(0.0);
                    gap * gap
                })
                .sum();
            if gap2.sqrt() > radius(node.reach) {
                continue;
            }
            match node.children {
                Some((left, right)) => {
                    stack.push(left);
                    stack.push(right);
                }
                None => self.items[node.start..node.end].iter().for_each(&mut visit),
            }
        }
    }
}

/// The farthest pair of `positions` (ties: the smallest index pair), given a
/// pair `start` already found and a `centre` (the midpoint of a long pair
/// prunes best).
///
/// About 90 lines, a third of them the rounding analysis: both searches (the
/// central points and the tree) share the bounds computed at the top, which
/// a split would only pass around.
pub(crate) fn farthest_pair(positions: &[[f64; 3]], start: Pair, centre: [f64; 3]) -> Pair {
    let offset = |p: [f64; 3]| [p[0] - centre[0], p[1] - centre[1], p[2] - centre[2]];
    let reach: Vec<f64> = positions.iter().map(|&p| dist2(offset(p), [0.0; 3]).sqrt()).collect();
    let r_max = reach.iter().fold(0.0f64, |m, &r| m.max(r));
    if r_max == 0.0 {
        return start; // every point is the centre: no pair is longer than 0
    }
    // Rounding: every computed offset is within `blur` of the true one (a
    // subtraction of coordinates up to `magnitude`), so r is too, and a
    // direction at distance r from the centre is within about 2 blur / r.
    let magnitude = positions
        .iter()
        .chain(std::iter::once(&centre))
        .flat_map(|p| p.iter())
        .fold(0.0f64, |m, &x| m.max(x.abs()));
    let blur = 4.0 * f64::EPSILON * (magnitude + r_max);
    let r_central = CENTRAL * r_max;
    // Both directions of a pair are each off by at most 2 blur / r_central.
    let direction_slack = 4.0 * blur / r_central + 1e-15;
    let short = |pair: &Pair| pair.length2.sqrt() * (1.0 - LENGTH_SLACK);

    // Any partner of a better pair is at least D - r_max from the centre.
    let floor = short(&start) - r_max - 2.0 * blur;
    let (central, searched): (Vec<u32>, Vec<u32>) = (0..positions.len() as u32)
        .filter(|&i| reach[i as usize] >= floor)
        .partition(|&i| reach[i as usize] < r_central);
    let items: Vec<Item> = searched
        .iter()
        .map(|&i| {
            let (v, r) = (offset(positions[i as usize]), reach[i as usize]);
            let direction = [v[0] / r, v[1] / r, v[2] / r];
            Item { direction, reach: r, position: positions[i as usize], index: i }
        })
        .collect();
    drop(searched);
    let tree = DirectionTree::new(items);

    // Every pair with a point near the centre: that point against every
    // candidate (they are few, or none).
    let mut best = start;
    for &x in &central {
        let (p, r_x) = (positions[x as usize], reach[x as usize]);
        if r_x + r_max + 2.0 * blur >= short(&best) {
            for &y in &central {
                best.offer(x, y, dist2(p, positions[y as usize]));
            }
            for y in &tree.items {
                best.offer(x, y.index, dist2(p, y.position));
            }
        }
    }

    // Every other pair: each candidate x searches the tree around its
    // antipodal direction. In the tree's order, so that consecutive searches
    // walk the same nodes; in parallel, each task with its own best, merged
    // by the total order of `offer`.
    let search = |x: &Item, best: &mut Pair, stack: &mut Vec<usize>| {
        let d = short(best);
        let (p, r_x) = (x.position, x.reach);
        if r_x + r_max + 2.0 * blur < d {
            return; // x pairs at best with a point r_max from the centre
        }
        let u = x.direction;
        let target = [-u[0], -u[1], -u[2]];
        // The bound from the law of cosines, for the node's largest r_y
        // taken `blur` larger (see the module's comment), widened by its
        // error: r_x is off by up to blur, and the bound's slope in r_x,
        // (r_x^2 - r_y^2 + D^2) / (r_x^2 r_y), is at most
        // (r_x^2 + r_y^2 + D^2) / (r_x^2 r_y) in size; its own rounding is
        // a few ulps of (r_x + r_y)^2 / (r_x r_y).
        let radius = |reach: f64| {
            let ry = reach + blur;
            let bound = ((r_x + ry) * (r_x + ry) - d * d) / (r_x * ry);
            let slack = (r_x * r_x + ry * ry + d * d) / (r_x * r_x * ry) * 2.0 * blur
                + 8.0 * f64::EPSILON * (r_x + ry) * (r_x + ry) / (r_x * ry);
            (bound.max(0.0) + slack).sqrt() + direction_slack
        };
        let mut offer = |y: &Item| best.offer(x.index, y.index, dist2(p, y.position));
        tree.within(target, radius, stack, &mut offer);
    };
    tree.items
        .par_chunks(CHUNK)
        .map(|chunk| {
            let (mut local, mut stack) = (best, Vec::new());
            for x in chunk {
                search(x, &mut local, &mut stack);
            }
            local
        })
        .reduce(|| best, Pair::better)
}
