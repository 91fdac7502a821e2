//! The report of [`check`](super::check): what it found, as flags, counts and
//! capped lists of offending indices, and as one readable sentence per problem.

/// How many offending indices a report lists per kind of problem.
pub const LIST_CAP: usize = 100;

/// A list of offending items, capped at [`LIST_CAP`], with the true total.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Capped<T> {
    pub items: Vec<T>,
    pub total: usize,
}

impl<T> Capped<T> {
    pub(super) fn push(&mut self, item: T) {
        if self.items.len() < LIST_CAP {
            self.items.push(item);
        }
        self.total += 1;
    }

    pub fn is_empty(&self) -> bool {
        self.total == 0
    }
}

impl<T: std::fmt::Debug> Capped<T> {
    fn examples(&self) -> String {
        let shown: Vec<String> = self.items.iter().take(5).map(|x| format!("{x:?}")).collect();
        let more = if self.total > shown.len() { ", ..." } else { "" };
        format!("{}{}", shown.join(", "), more)
    }
}

/// Everything [`check`](super::check) finds out about a triangle mesh.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeshReport {
    pub n_vertices: usize,
    pub n_faces: usize,
    pub n_edges: usize,
    /// Closed, connected, manifold, genus 0, every vertex used, no face repeating a vertex.
    pub is_sphere_topology: bool,
    /// Every edge has exactly two faces.
    pub closed: bool,
    /// No non-manifold edge and no non-manifold vertex.
    pub manifold: bool,
    pub connected: bool,
    /// Connected components of the surface (unreferenced vertices not counted).
    pub n_components: usize,
    /// V - E + F with V the referenced vertices (thesis Cor. 2.7, eq. 2.20).
    pub euler_characteristic: i64,
    /// Total genus from eq. 2.20 with boundaries, when the mesh is manifold.
    pub genus: Option<i64>,
    /// Edges with one face.
    pub boundary_edges: usize,
    /// Boundary loops as vertex cycles in the direction of their faces.
    pub boundary_loops: Capped<Vec<u32>>,
    /// Edges with more than two faces.
    pub nonmanifold_edges: Capped<[u32; 2]>,
    /// Vertices whose faces form more than one fan.
    pub nonmanifold_vertices: Capped<u32>,
    /// Faces that repeat a vertex or have exactly zero area (exact predicate).
    pub degenerate_faces: Capped<u32>,
    /// Faces with the same vertex set as an earlier face (either orientation).
    pub duplicate_faces: Capped<u32>,
    pub unreferenced_vertices: Capped<u32>,
    /// Vertices with a NaN or infinite coordinate (only from [`check_raw`](super::check_raw)).
    pub non_finite_vertices: Capped<u32>,
    /// Faces with an index outside 0..n_vertices (only from [`check_raw`](super::check_raw)).
    pub out_of_range_faces: Capped<u32>,
    /// Every two-face edge is used once in each direction.
    pub consistently_oriented: bool,
    /// Two-face edges used twice in the same direction.
    pub inconsistent_edges: Capped<[u32; 2]>,
    /// Closed, consistently oriented and every component encloses positive volume.
    pub outward: bool,
    /// Signed enclosed volume (meaningful when closed and consistently oriented).
    pub signed_volume: f64,
    /// One sentence per problem found; empty for a clean genus-0 mesh.
    pub problems: Vec<String>,
    /// Informational remarks (e.g. from the file reader: polygons triangulated).
    pub notes: Vec<String>,
}

impl MeshReport {
    /// Records faces with indices outside `0..n_vertices` (from
    /// [`check_raw`](super::check_raw)), first among the problems.
    pub(super) fn add_out_of_range(&mut self, out_of_range: Capped<u32>, n_vertices: usize) {
        if !out_of_range.is_empty() {
            self.problems.insert(
                0,
                format!(
                    "{} faces refer to vertices outside 0..{} (faces {})",
                    out_of_range.total,
                    n_vertices,
                    out_of_range.examples()
                ),
            );
            self.is_sphere_topology = false;
        }
        self.out_of_range_faces = out_of_range;
    }

    /// Fills `problems` from the findings; `repeated_index` is the number of
    /// faces that repeat a vertex (the rest of the degenerate ones have zero
    /// area), `seam_copies` the number of boundary vertices at exactly the
    /// position of another boundary vertex (a seam split by an exporter).
    ///
    /// Longer than most functions on purpose: it is one flat list of
    /// independent sentences, in the order the report shows them; split, the
    /// one list would be spread over several functions.
    pub(super) fn describe_problems(&mut self, repeated_index: usize, seam_copies: usize) {
        let mut p = Vec::new();
        if !self.non_finite_vertices.is_empty() {
            p.push(format!(
                "{} a NaN or infinite coordinate: vertices {}",
                count(self.non_finite_vertices.total, "vertex has", "vertices have"),
                self.non_finite_vertices.examples()
            ));
        }
        if !self.nonmanifold_edges.is_empty() {
            p.push(format!(
                "{} non-manifold (shared by more than two faces): {}",
                count_is(self.nonmanifold_edges.total, "edge", "edges"),
                self.nonmanifold_edges.examples()
            ));
        }
        if !self.nonmanifold_vertices.is_empty() {
            p.push(format!(
                "{} non-manifold (their faces form more than one fan): vertices {}",
                count_is(self.nonmanifold_vertices.total, "vertex", "vertices"),
                self.nonmanifold_vertices.examples()
            ));
        }
        if self.boundary_edges > 0 {
            let seam = if seam_copies > 0 {
                format!(
                    "; {} of their vertices sit exactly on another boundary vertex: a seam \
                     the file splits, which welding (sp.weld, --weld) closes",
                    seam_copies
                )
            } else {
                String::new()
            };
            p.push(format!(
                "the mesh is open: {} in {} (holes){seam}",
                count(self.boundary_edges, "boundary edge", "boundary edges"),
                count(self.boundary_loops.total, "boundary loop", "boundary loops")
            ));
        }
        if self.n_components > 1 {
            p.push(format!("the mesh has {} connected components", self.n_components));
        }
        if self.manifold
            && self.euler_characteristic
                != 2 * self.n_components as i64 - self.boundary_loops.total as i64
        {
            let genus = self.genus.map(|g| format!("genus {g}: ")).unwrap_or_default();
            p.push(format!(
                "{genus}Euler characteristic V - E + F = {} (a sphere has 2)",
                self.euler_characteristic
            ));
        }
        if !self.degenerate_faces.is_empty() {
            p.push(format!(
                "{} degenerate ({} repeating a vertex, {} with exactly zero area): faces {}",
                count_is(self.degenerate_faces.total, "face", "faces"),
                repeated_index,
                self.degenerate_faces.total - repeated_index,
                self.degenerate_faces.examples()
            ));
        }
        if !self.duplicate_faces.is_empty() {
            p.push(format!(
                "{} the vertices of an earlier face: faces {}",
                count(self.duplicate_faces.total, "face repeats", "faces repeat"),
                self.duplicate_faces.examples()
            ));
        }
        if !self.unreferenced_vertices.is_empty() {
            p.push(format!(
                "{} not used by any face: vertices {}",
                count_is(self.unreferenced_vertices.total, "vertex", "vertices"),
                self.unreferenced_vertices.examples()
            ));
        }
        if !self.inconsistent_edges.is_empty() {
            p.push(format!(
                "the faces are not consistently oriented: {} used twice in the same direction, e.g. {} (orient fixes this)",
                count_is(self.inconsistent_edges.total, "edge", "edges"),
                self.inconsistent_edges.examples()
            ));
        } else if self.closed && self.consistently_oriented && !self.outward {
            // orient decides "outward" by the sign of this volume: when it is
            // not a number, or zero, there is nothing it could fix (issue 13,
            // item 18).
            if !self.signed_volume.is_finite() {
                p.push(format!(
                    "the faces' orientation cannot be decided: their signed volume is {} \
                     (coordinates that are not finite, or so large that the volume \
                     overflows); orient cannot fix this",
                    self.signed_volume
                ));
            } else if self.signed_volume == 0.0 {
                p.push(
                    "the mesh encloses no volume (signed volume 0): it is degenerate, for \
                     example all its vertices at one point or on one plane, and has no \
                     outward side for orient to find"
                        .to_string(),
                );
            } else {
                p.push(format!(
                    "the faces point inward (signed volume {:.6e}); orient fixes this",
                    self.signed_volume
                ));
            }
        }
        self.problems = p;
    }
}

/// "1 face" / "3 faces", "1 vertex" / "2 vertices".
fn count(n: usize, singular: &str, plural: &str) -> String {
    format!("{n} {}", if n == 1 { singular } else { plural })
}

/// "1 face is" / "3 faces are".
fn count_is(n: usize, singular: &str, plural: &str) -> String {
    format!("{} {}", count(n, singular, plural), if n == 1 { "is" } else { "are" })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sentences_count_in_singular_and_plural() {
        assert_eq!(count_is(1, "face", "faces"), "1 face is");
        assert_eq!(count_is(3, "face", "faces"), "3 faces are");
        let mut listed = Capped::default();
        for f in 0..7u32 {
            listed.push(f);
        }
        assert_eq!(listed.examples(), "0, 1, 2, 3, 4, ...");
        let mut r = MeshReport { is_sphere_topology: true, ..Default::default() };
        r.nonmanifold_vertices = listed.clone();
        r.describe_problems(0, 0);
        r.add_out_of_range(listed, 4);
        assert!(!r.is_sphere_topology);
        assert_eq!(
            r.problems,
            [
                "7 faces refer to vertices outside 0..4 (faces 0, 1, 2, 3, 4, ...)",
                "7 vertices are non-manifold (their faces form more than one fan): \
                 vertices 0, 1, 2, 3, 4, ..."
            ]
        );
    }
}
