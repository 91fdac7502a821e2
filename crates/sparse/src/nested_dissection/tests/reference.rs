//! The ordering as it was before it was made faster (commit 9b089ca),
//! kept only to check that the fast one returns the same permutation and
//! the same bisection on every input: comments and all reasoning are in
//! `super::super` and `super::super::fiduccia_mattheyses`.
#![allow(dead_code)]

use crate::direct::amd_order;
use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

const LEAF: usize = 256;

const PARALLEL: usize = 8_192;

const RULE: Rule = Rule::Ratio(0.1);

const HALVES: Rule = Rule::Balanced(0.45);

#[derive(Debug, Clone, Copy)]
enum Rule {
    Balanced(f64),
    Ratio(f64),
}

impl Rule {
    fn least(self, len: usize) -> usize {
        let (Rule::Balanced(share) | Rule::Ratio(share)) = self;
        (share * len as f64) as usize
    }
}

const PLACED: u32 = u32::MAX;

struct Dissection<'a> {
    offsets: &'a [usize],
    indices: &'a [u32],
    label: Vec<AtomicU32>,
    next_label: AtomicU32,
    local: Vec<AtomicU32>,
}

struct Piece<'a> {
    vs: &'a mut [u32],
    label: u32,
    hint: u32,
}

struct Levels {
    queue: Vec<u32>,
    starts: Vec<usize>,
}

impl Levels {
    fn count(&self) -> usize {
        self.starts.len() - 1
    }

    fn level(&self, k: usize) -> &[u32] {
        &self.queue[self.starts[k]..self.starts[k + 1]]
    }
}

struct Cut {
    near: u32,
    far: u32,
    n_near: usize,
    n_separator: usize,
}

pub(super) struct Bisection {
    pub(super) vs: Vec<u32>,
    pub(super) n_near: usize,
    pub(super) n_separator: usize,
}

pub(super) fn bisection(offsets: &[usize], indices: &[u32]) -> Option<Bisection> {
    let n = offsets.len().saturating_sub(1);
    if n <= LEAF {
        return None;
    }
    let work = Dissection {
        offsets,
        indices,
        label: (0..n).map(|_| AtomicU32::new(0)).collect(),
        next_label: AtomicU32::new(1),
        local: (0..n).map(|_| AtomicU32::new(0)).collect(),
    };
    let first = work.fresh();
    let sweep = work.bfs(0, 0, first, n);
    if sweep.queue.len() < n {
        return None;
    }
    let far_end = sweep.queue[n - 1];
    drop(sweep);
    let second = work.fresh();
    let levels = work.bfs(far_end, first, second, n);
    if levels.count() < 3 {
        return None;
    }
    let mut vs = vec![0u32; n];
    let cut = work.cut(&levels, &mut vs, HALVES);
    Some(Bisection { vs, n_near: cut.n_near, n_separator: cut.n_separator })
}

pub(super) fn nested_dissection(offsets: &[usize], indices: &[u32]) -> Vec<u32> {
    let n = offsets.len().saturating_sub(1);
    let (order, graph) = breadth_first_copy(offsets, indices);
    let work = Dissection {
        offsets: &graph.0,
        indices: &graph.1,
        label: (0..n).map(|_| AtomicU32::new(0)).collect(),
        next_label: AtomicU32::new(1),
        local: (0..n).map(|_| AtomicU32::new(0)).collect(),
    };
    let mut perm: Vec<u32> = (0..n as u32).collect();
    if n > 0 {
        work.dissect(Piece { vs: &mut perm, label: 0, hint: 0 });
    }
    drop(work);
    let perm = postorder(&graph.0, &graph.1, perm);
    perm.into_iter().map(|k| order[k as usize]).collect()
}

fn breadth_first_copy(offsets: &[usize], indices: &[u32]) -> (Vec<u32>, (Vec<usize>, Vec<u32>)) {
    const UNSEEN: u32 = u32::MAX;
    let n = offsets.len().saturating_sub(1);
    let mut new_of = vec![UNSEEN; n];
    let mut order = Vec::with_capacity(n);
    for root in 0..n {
        if new_of[root] != UNSEEN {
            continue;
        }
        new_of[root] = order.len() as u32;
        order.push(root as u32);
        let mut head = order.len() - 1;
        while head < order.len() {
            let v = order[head] as usize;
            head += 1;
            for &w in &indices[offsets[v]..offsets[v + 1]] {
                if new_of[w as usize] == UNSEEN {
                    new_of[w as usize] = order.len() as u32;
                    order.push(w);
                }
            }
        }
    }
    let mut new_offsets = Vec::with_capacity(n + 1);
    let mut new_indices = Vec::with_capacity(indices.len());
    new_offsets.push(0);
    for &v in &order {
        let v = v as usize;
        new_indices.extend(
            indices[offsets[v]..offsets[v + 1]]
                .iter()
                .filter(|&&w| w as usize != v)
                .map(|&w| new_of[w as usize]),
        );
        new_offsets.push(new_indices.len());
    }
    (order, (new_offsets, new_indices))
}

fn postorder(offsets: &[usize], indices: &[u32], perm: Vec<u32>) -> Vec<u32> {
    const NONE: u32 = u32::MAX;
    let n = perm.len();
    let mut inverse = vec![0u32; n];
    for (k, &v) in perm.iter().enumerate() {
        inverse[v as usize] = k as u32;
    }
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for (k, &v) in perm.iter().enumerate() {
        let k = k as u32;
        for &w in &indices[offsets[v as usize]..offsets[v as usize + 1]] {
            let mut i = inverse[w as usize];
            if i >= k {
                continue;
            }
            while ancestor[i as usize] != NONE && ancestor[i as usize] != k {
                let next = ancestor[i as usize];
                ancestor[i as usize] = k;
                i = next;
            }
            if ancestor[i as usize] == NONE {
                ancestor[i as usize] = k;
                parent[i as usize] = k;
            }
        }
    }
    drop(ancestor);
    let mut first_child = vec![NONE; n];
    let mut next_sibling = vec![NONE; n];
    for k in (0..n).rev() {
        let p = parent[k];
        if p != NONE {
            next_sibling[k] = first_child[p as usize];
            first_child[p as usize] = k as u32;
        }
    }
    let mut order = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n as u32).filter(|&k| parent[k as usize] == NONE) {
        stack.push(root);
        while let Some(&top) = stack.last() {
            let child = first_child[top as usize];
            if child == NONE {
                order.push(perm[top as usize]);
                stack.pop();
            } else {
                first_child[top as usize] = next_sibling[child as usize];
                stack.push(child);
            }
        }
    }
    order
}

impl Dissection<'_> {
    fn fresh(&self) -> u32 {
        self.next_label.fetch_add(1, Relaxed)
    }

    fn neighbours(&self, v: u32) -> &[u32] {
        &self.indices[self.offsets[v as usize]..self.offsets[v as usize + 1]]
    }

    fn bfs(&self, start: u32, from: u32, to: u32, capacity: usize) -> Levels {
        let mut queue = Vec::with_capacity(capacity);
        let mut starts = vec![0];
        self.label[start as usize].store(to, Relaxed);
        queue.push(start);
        let mut head = 0;
        while head < queue.len() {
            let end = queue.len();
            for i in head..end {
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

    fn dissect(&self, piece: Piece<'_>) {
        let Piece { vs, label: piece, hint } = piece;
        let len = vs.len();
        if len <= 1 {
            return;
        }
        let first = self.fresh();
        let sweep = self.bfs(hint, piece, first, len);
        if sweep.queue.len() < len {
            let mut components = vec![(first, hint, sweep.queue)];
            for &v in vs.iter() {
                if self.label[v as usize].load(Relaxed) == piece {
                    let label = self.fresh();
                    components.push((label, v, self.bfs(v, piece, label, 0).queue));
                }
            }
            let mut rest: &mut [u32] = vs;
            for (label, hint, members) in components {
                let (head, tail) = std::mem::take(&mut rest).split_at_mut(members.len());
                head.copy_from_slice(&members);
                drop(members);
                self.dissect(Piece { vs: head, label, hint });
                rest = tail;
            }
            return;
        }
        let far_end = sweep.queue[len - 1];
        drop(sweep);
        let second = self.fresh();
        let levels = self.bfs(far_end, first, second, len);
        if len <= LEAF || levels.count() < 3 {
            self.minimum_degree(vs, &levels.queue, second);
            return;
        }
        let Cut { near, far, n_near, n_separator } = self.cut(&levels, vs, RULE);
        let label = |v: u32| self.label[v as usize].load(Relaxed);
        let near_hint = if label(far_end) == near { far_end } else { vs[0] };
        let far_hint = levels.queue[len - 1];
        let far_hint = if label(far_hint) == far { far_hint } else { vs[n_near] };
        drop(levels);
        let (near_part, rest) = vs.split_at_mut(n_near);
        let far_part = &mut rest[..len - n_near - n_separator];
        self.both(
            Piece { vs: near_part, label: near, hint: near_hint },
            Piece { vs: far_part, label: far, hint: far_hint },
        );
    }

    fn cut(&self, levels: &Levels, vs: &mut [u32], rule: Rule) -> Cut {
        let len = vs.len();
        let k = separator_level(&levels.starts, len, rule);
        let (near, far, sep) = (self.fresh(), self.fresh(), self.fresh());
        for (v, label) in levels.queue[..levels.starts[k]]
            .iter()
            .map(|v| (v, near))
            .chain(levels.level(k).iter().map(|v| (v, sep)))
            .chain(levels.queue[levels.starts[k + 1]..].iter().map(|v| (v, far)))
        {
            self.label[*v as usize].store(label, Relaxed);
        }
        let mut split = Split {
            labels: [near, far],
            sep,
            sizes: [levels.starts[k], len - levels.starts[k + 1]],
            separator: levels.level(k).to_vec(),
        };
        self.refine_separator(&mut split, rule.least(len));
        let n_near = split.sizes[0];
        let (mut a, mut b) = (0, n_near);
        for &v in &levels.queue {
            let label = self.label[v as usize].load(Relaxed);
            if label == near {
                vs[a] = v;
                a += 1;
            } else if label == far {
                vs[b] = v;
                b += 1;
            }
        }
        for (slot, &v) in vs[b..].iter_mut().zip(&split.separator) {
            *slot = v;
            self.label[v as usize].store(PLACED, Relaxed);
        }
        Cut { near, far, n_near, n_separator: split.separator.len() }
    }

    fn minimum_degree(&self, vs: &mut [u32], members: &[u32], piece: u32) {
        let len = members.len();
        for (i, &v) in members.iter().enumerate() {
            self.local[v as usize].store(i as u32, Relaxed);
        }
        let mut offsets = Vec::with_capacity(len + 1);
        let mut indices = Vec::with_capacity(8 * len);
        offsets.push(0u32);
        for &v in members {
            let start = indices.len();
            indices.extend(
                self.neighbours(v)
                    .iter()
                    .filter(|&&w| self.label[w as usize].load(Relaxed) == piece)
                    .map(|&w| self.local[w as usize].load(Relaxed)),
            );
            indices[start..].sort_unstable();
            offsets.push(indices.len() as u32);
        }
        let mut perm = vec![0u32; len];
        let mut inverse = vec![0u32; len];
        let ordered = amd_order(&mut perm, &mut inverse, len, &offsets, &indices);
        if ordered {
            for (slot, &k) in vs.iter_mut().zip(&perm) {
                *slot = members[k as usize];
            }
        } else {
            for (slot, &v) in vs.iter_mut().zip(members.iter().rev()) {
                *slot = v;
            }
        }
    }

    fn both(&self, a: Piece<'_>, b: Piece<'_>) {
        if a.vs.len() + b.vs.len() > PARALLEL {
            rayon::join(|| self.dissect(a), || self.dissect(b));
        } else {
            self.dissect(a);
            self.dissect(b);
        }
    }
}

fn separator_level(starts: &[usize], len: usize, rule: Rule) -> usize {
    let count = starts.len() - 1;
    let least = rule.least(len);
    let size = |k: usize| starts[k + 1] - starts[k];
    let allowed = (1..count - 1).filter(|&k| starts[k] >= least && len - starts[k + 1] >= least);
    let best = match rule {
        Rule::Balanced(_) => allowed.min_by_key(|&k| (size(k), k)),
        Rule::Ratio(_) => {
            let cost =
                |k: usize| size(k) as f64 / (starts[k] as f64 * (len - starts[k + 1]) as f64);
            allowed.min_by(|&a, &b| cost(a).total_cmp(&cost(b)).then(a.cmp(&b)))
        }
    };
    best.unwrap_or_else(|| {
        let median = (1..count).find(|&k| starts[k + 1] > len / 2).unwrap_or(count - 1);
        median.clamp(1, count - 2)
    })
}

const PASSES: usize = 3;

const THOROUGH: usize = 4096;

fn patience(len: usize) -> usize {
    (len / 100).clamp(15, 100)
}

struct Split {
    labels: [u32; 2],
    sep: u32,
    sizes: [usize; 2],
    separator: Vec<u32>,
}

struct Move {
    v: u32,
    to: usize,
    from: usize,
}

impl Dissection<'_> {
    fn refine_separator(&self, split: &mut Split, least: usize) {
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

    fn count_labelled(&self, v: u32, label: u32) -> i64 {
        self.neighbours(v)
            .iter()
            .filter(|&&w| self.label[w as usize].load(Relaxed) == label)
            .count() as i64
    }

    fn pass(&self, split: &mut Split, least: usize, patience: usize, queue: &mut Buckets) -> bool {
        let labels = split.labels;
        let sep = split.sep;
        let label = |v: u32| self.label[v as usize].load(Relaxed);
        let pulls = |v: u32, to: usize| self.count_labelled(v, labels[1 - to]) as usize;
        queue.clear();
        for &v in &split.separator {
            for to in 0..2 {
                queue.push(pulls(v, to), v, to);
            }
        }
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

struct Buckets {
    buckets: Vec<(Vec<(u32, u8)>, usize)>,
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
