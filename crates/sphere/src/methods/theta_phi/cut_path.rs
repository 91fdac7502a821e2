//! The cut path of the theta-phi method (thesis 6.2.4): a shortest path from
//! the north to the south pole, made chordless (a chord would lie along a side
//! of the rectangle), lengthened to at least two inner vertices (the thesis
//! assumes k >= 2; the tetrahedron needs more), and kept clear of the poles'
//! other neighbours where it can be, so that the pole fans can be monotone
//! (6.5.1).

use spherify_mesh::dijkstra::{dijkstra, dijkstra_to, EdgeWeights};
use spherify_mesh::Adjacency;
use std::collections::HashMap;

/// A shortest path from n to s (6.2.4) without chords between its inner
/// vertices and with at least two of them (k >= 2).
pub(crate) fn cut_path(
    graph: &Adjacency,
    north: u32,
    south: u32,
    weights: EdgeWeights,
) -> Option<Vec<u32>> {
    let (_, path) = dijkstra_to(graph, north, south, weights)?;
    finish_path(graph, path, weights)
}

/// A simple path from its first to its last vertex made chordless, and
/// lengthened through the whole graph when fewer than 4 vertices remain. A
/// chord joins two path vertices, so a path inside an induced subgraph (the H
/// of the symmetry method, eq. 6.21) stays inside it unless lengthened.
pub(crate) fn finish_path(
    graph: &Adjacency,
    mut path: Vec<u32>,
    weights: EdgeWeights,
) -> Option<Vec<u32>> {
    let (north, south) = (*path.first()?, *path.last()?);
    shortcut_chords(graph, &mut path);
    if path.len() >= 4 {
        return Some(path);
    }
    lengthen(graph, north, south, weights)
}

/// Replaces p_i ... p_j by the edge p_i p_j wherever two inner path vertices
/// more than one step apart are adjacent: such a chord would lie along one side
/// of the rectangle. From the first inner vertex on, each kept vertex jumps to
/// the farthest inner vertex it is adjacent to: one pass, O(path + its
/// neighbours). Shortcutting only drops vertices after the current one, so no
/// earlier vertex gains a chord, and the result is the one restarting from
/// the start after every shortcut would give.
fn shortcut_chords(graph: &Adjacency, path: &mut Vec<u32>) {
    let last = path.len() - 1;
    let index: HashMap<u32, usize> = path.iter().enumerate().map(|(i, &v)| (v, i)).collect();
    let mut kept = Vec::with_capacity(path.len());
    kept.push(path[0]);
    let mut i = 1;
    while i < last {
        kept.push(path[i]);
        let farthest = graph
            .neighbors(path[i])
            .iter()
            .filter_map(|v| index.get(v).copied())
            .filter(|&j| j >= i + 2 && j < last)
            .max();
        i = farthest.unwrap_or(i + 1);
    }
    if last > 0 {
        kept.push(path[last]);
    }
    *path = kept;
}

/// A path n, a, ..., s with at least two inner vertices: through a neighbour a
/// of n not adjacent to s, then a shortest path to s avoiding n; failing that,
/// n, a, b, s with a ~ n, b ~ a, b ~ s.
fn lengthen(graph: &Adjacency, north: u32, south: u32, weights: EdgeWeights) -> Option<Vec<u32>> {
    if let Some(path) = lengthen_clear_of_poles(graph, north, south, weights) {
        return Some(path);
    }
    let n = graph.n_vertices();
    // The graph without the north pole: drop its edges.
    let offsets_ok = graph.neighbors(north).iter().any(|&a| a != south);
    if !offsets_ok {
        return None;
    }
    let mut best: Option<(f64, Vec<u32>)> = None;
    let without_north = remove_vertex(graph, north);
    let from_south = dijkstra(&without_north, south, weights)?;
    for &a in graph.neighbors(north) {
        if a == south || graph.neighbors(a).contains(&south) {
            continue;
        }
        if let Some(mut tail) = from_south.path_to(a) {
            tail.reverse(); // a ... s
            let length = from_south.distances[a as usize];
            let mut path = vec![north];
            path.extend(tail);
            shortcut_chords(graph, &mut path);
            if path.len() >= 4 && best.as_ref().is_none_or(|(l, _)| length < *l) {
                best = Some((length, path));
            }
        }
    }
    if let Some((_, path)) = best {
        return Some(path);
    }
    for &a in graph.neighbors(north) {
        if a == south {
            continue;
        }
        for &b in graph.neighbors(a) {
            if b != north && b != south && graph.neighbors(b).contains(&south) {
                return Some(vec![north, a, b, south]);
            }
        }
    }
    let _ = n;
    None
}

/// The shortest path n, a, ..., b, s in which n is adjacent to no path
/// vertex but a, and s to none but b. A pole next to a further path vertex
/// has neighbours on the rectangle's side, so its phi values cannot increase
/// strictly (6.5.1) and the fan cannot be pinned either (6.38). Such a path
/// runs from a neighbour a of n that is not one of s through vertices next to
/// neither pole to a neighbour b of s that is not one of n; the triangle
/// inequality of edge lengths keeps it from stepping back into N(n) or N(s).
/// None when every vertex is next to a pole (the octahedron).
fn lengthen_clear_of_poles(
    graph: &Adjacency,
    north: u32,
    south: u32,
    weights: EdgeWeights,
) -> Option<Vec<u32>> {
    #[derive(Clone, Copy, PartialEq)]
    enum Role {
        Pole,
        NextToNorth,
        NextToSouth,
        Free,
        Blocked,
    }
    let mut role = vec![Role::Free; graph.n_vertices()];
    role[north as usize] = Role::Pole;
    role[south as usize] = Role::Pole;
    for &a in graph.neighbors(north) {
        if role[a as usize] == Role::Free {
            role[a as usize] = Role::NextToNorth;
        }
    }
    for &b in graph.neighbors(south) {
        role[b as usize] = match role[b as usize] {
            Role::Free => Role::NextToSouth,
            Role::NextToNorth => Role::Blocked,
            other => other,
        };
    }
    let keep = |u: u32, v: u32| {
        let (ru, rv) = (role[u as usize], role[v as usize]);
        let pole_edge = |p: u32, x: Role| {
            (p == north && x == Role::NextToNorth) || (p == south && x == Role::NextToSouth)
        };
        match (ru, rv) {
            (Role::Pole, x) => pole_edge(u, x),
            (x, Role::Pole) => pole_edge(v, x),
            (Role::Blocked, _) | (_, Role::Blocked) => false,
            (Role::NextToNorth, Role::NextToNorth) | (Role::NextToSouth, Role::NextToSouth) => {
                false
            }
            _ => true,
        }
    };
    let mut offsets = Vec::with_capacity(graph.offsets.len());
    let mut neighbors = Vec::with_capacity(graph.neighbors.len());
    offsets.push(0);
    for v in 0..graph.n_vertices() as u32 {
        neighbors.extend(graph.neighbors(v).iter().filter(|&&u| keep(v, u)));
        offsets.push(neighbors.len());
    }
    let clear = Adjacency { offsets, neighbors };
    let (_, mut path) = dijkstra_to(&clear, north, south, weights)?;
    shortcut_chords(graph, &mut path);
    (path.len() >= 4).then_some(path)
}

fn remove_vertex(graph: &Adjacency, removed: u32) -> Adjacency {
    let mut offsets = Vec::with_capacity(graph.offsets.len());
    let mut neighbors = Vec::with_capacity(graph.neighbors.len());
    offsets.push(0);
    for v in 0..graph.n_vertices() as u32 {
        if v != removed {
            neighbors.extend(graph.neighbors(v).iter().filter(|&&u| u != removed));
        }
        offsets.push(neighbors.len());
    }
    Adjacency { offsets, neighbors }
}
