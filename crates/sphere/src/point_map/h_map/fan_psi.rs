//! The pole line positions psi of h2 (thesis 6.5.1, 6.6.2): along each pole's
//! fan, psi = phi where phi increases strictly (the thesis's vertical
//! trapezia), and otherwise positions that keep every pole cell convex.

use std::collections::{HashMap, HashSet};
use std::f64::consts::PI;

use super::pole_cell::PoleCell;

/// Key of a fan point: a vertex id, or the split point c of a two-pole face.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
enum FanPoint {
    Vertex(u32),
    Split(u32),
}

/// Chooses psi along the fan of pole `side` (6.5.1): phi where phi increases
/// strictly from p_1 to N + k, interpolated between such anchors elsewhere.
pub(super) fn assign_psi(
    cells: &mut [PoleCell],
    faces: &[[u32; 3]],
    poles: [u32; 2],
    side: usize,
) -> Result<(), String> {
    let pole = poles[side];
    let key = |cell: &PoleCell, w: &[f64; 3]| -> FanPoint {
        let face = faces[cell.face as usize];
        match (0..3).find(|&k| w[k] == 1.0) {
            Some(k) => FanPoint::Vertex(face[k]),
            None => FanPoint::Split(cell.face),
        }
    };
    // The fan as links A -> B, one per cell of this pole.
    let mut next: HashMap<FanPoint, usize> = HashMap::new();
    let mut is_target: HashSet<FanPoint> = HashSet::new();
    let mine: Vec<usize> = (0..cells.len())
        .filter(|&i| faces[cells[i].face as usize][cells[i].pole_corner] == pole)
        .collect();
    for &i in &mine {
        let (a, b) = (key(&cells[i], &cells[i].a), key(&cells[i], &cells[i].b));
        if next.insert(a, i).is_some() {
            return Err(format!("the fan of pole {pole} is not a simple path"));
        }
        is_target.insert(b);
    }
    let mut visited = 0;
    let starts: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|&i| !is_target.contains(&key(&cells[i], &cells[i].a)))
        .collect();
    for start in starts {
        // Walk one piece: points q_0 .. q_m and the cells between them.
        let mut chain = vec![start];
        let mut at = key(&cells[start], &cells[start].b);
        while let Some(&i) = next.get(&at) {
            if chain.len() > mine.len() {
                return Err(format!("the fan of pole {pole} has a cycle"));
            }
            chain.push(i);
            at = key(&cells[i], &cells[i].b);
        }
        visited += chain.len();
        let pieces: Vec<&PoleCell> = chain.iter().map(|&i| &cells[i]).collect();
        // The stretch needs the fan's neighbours to run monotonically in phi.
        // Equal steps are allowed only along the rectangle's sides (phi = 0 or
        // 2 pi: a pole next to further path vertices, as in the tetrahedron
        // and the octahedron). Where the fan turns back, or stalls inside the
        // rectangle, the region between the pole line and the fan is not a
        // strip, and no choice of psi is known to tile it.
        let mut phi = vec![pieces[0].ua[1]];
        phi.extend(pieces.iter().map(|c| c.ub[1]));
        let rising = phi.last() > phi.first();
        let on_side = |p: f64| p == 0.0 || p == 2.0 * PI;
        let ok = phi.windows(2).all(|w| {
            let step = if rising { w[1] - w[0] } else { w[0] - w[1] };
            step > 0.0 || (step == 0.0 && on_side(w[0]))
        });
        if !ok {
            return Err(format!(
                "the neighbours of pole {pole} do not run monotonically in phi (the pole is next to the other pole's neighbours or to further cut-path vertices, as on tiny meshes or with a caller's poles), so the stretch h2 of thesis 6.6.2 is not defined; choose other poles"
            ));
        }
        let psi = fan_psi(&pieces).ok_or_else(|| {
            format!("no pole line positions make the fan of pole {pole} one-to-one")
        })?;
        for (j, &i) in chain.iter().enumerate() {
            let cell = &mut cells[i];
            cell.psi_a = psi[j];
            cell.psi_b = psi[j + 1];
            cell.vertical = cell.psi_a == cell.ua[1] && cell.psi_b == cell.ub[1];
        }
    }
    if visited != mine.len() {
        return Err(format!("the fan of pole {pole} has a cycle"));
    }
    Ok(())
}

/// psi for the points q_0 .. q_m of one piece of a pole fan, cell j lying
/// between q_j and q_{j+1}. The ends keep their phi (0 or 2 pi on the
/// rectangle's sides, pi at a split point). The quadrilateral (T_A, A, B, T_B)
/// of a cell is convex when both T_A and T_B lie on the pole's side of the line
/// A B, which bounds each psi to an interval; psi must also run strictly from
/// one end to the other. Where the fan is monotone, psi = phi satisfies all of
/// this (the thesis's vertical trapezia) and is kept; elsewhere psi keeps phi
/// where the bounds allow and otherwise spreads the points evenly over the
/// room left. `None` when the bounds leave no room.
fn fan_psi(chain: &[&PoleCell]) -> Option<Vec<f64>> {
    let m = chain.len();
    let mut phi = vec![chain[0].ua[1]];
    phi.extend(chain.iter().map(|c| c.ub[1]));
    // Work in x = dir * psi, increasing from q_0 to q_m.
    let dir = match phi[m].partial_cmp(&phi[0]) {
        Some(std::cmp::Ordering::Greater) => 1.0,
        Some(std::cmp::Ordering::Less) => -1.0,
        _ => return None,
    };
    let x: Vec<f64> = phi.iter().map(|p| dir * p).collect();
    let mut lo = vec![f64::NEG_INFINITY; m + 1];
    let mut hi = vec![f64::INFINITY; m + 1];
    for (j, cell) in chain.iter().enumerate() {
        // orient2d(A, B, (theta_P, t)) = alpha t + beta must be > 0.
        let (a, b) = (cell.ua, cell.ub);
        let alpha = b[0] - a[0];
        let beta = -alpha * a[1] - (b[1] - a[1]) * (cell.pole_theta - a[0]);
        let slope = alpha * dir;
        for end in [j, j + 1] {
            if slope > 0.0 {
                lo[end] = lo[end].max(-beta / slope);
            } else if slope < 0.0 {
                hi[end] = hi[end].min(-beta / slope);
            } else if beta.is_nan() || beta <= 0.0 {
                return None;
            }
        }
    }
    // upper[j]: the largest x_j may approach so that the rest still fits.
    let mut upper = vec![x[m]; m + 1];
    for j in (1..m).rev() {
        upper[j] = hi[j].min(upper[j + 1]);
    }
    let mut psi = x.clone();
    for j in 1..m {
        let low = lo[j].max(psi[j - 1]);
        let high = upper[j];
        if low.is_nan() || high.is_nan() || low >= high {
            return None;
        }
        if !(x[j] > low && x[j] < high) {
            psi[j] = low + (high - low) / ((m - j) as f64 + 1.0);
        }
    }
    Some(psi.into_iter().map(|p| dir * p).collect())
}
