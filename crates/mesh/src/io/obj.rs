//! Wavefront OBJ: `v`, `vt` and `f` records; everything else (normals, groups,
//! materials, lines, points) is skipped. Faces may use `a`, `a/b`, `a//c` or `a/b/c`
//! corners and negative (relative) indices.
//!
//! OBJ keeps texture coordinates per face corner; spherify keeps one uv per vertex.
//! The `vt` data becomes [`VertexAttributes::uv`] only when that loses nothing
//! (every corner names a `vt` and each vertex always names the same one).
//! A texture atlas is written with one `vt` per face corner
//! ([`write_per_corner`], for `sp.texture`).

use super::text::{self, next_token, skip_space, take_float, trim_end, Lines};
use super::{
    finish, line_error, polygon_too_large, LoadedMesh, Triangles, VertexAttributes,
    MAX_POLYGON_CORNERS,
};
use crate::error::MeshError;
use crate::Mesh;
use std::io::Write;

/// Marks a vertex that no face corner has given a `vt` yet.
const NO_VT: u32 = u32::MAX;

/// Records that are valid OBJ but carry nothing spherify uses: skipped silently.
#[rustfmt::skip]
const KNOWN: &[&[u8]] = &[
    b"vn", b"vp", b"o", b"g", b"s", b"usemtl", b"mtllib", b"cstype", b"deg",
    b"bmat", b"step", b"parm", b"trim", b"hole", b"scrv", b"sp",
    b"end", b"con", b"mg", b"bevel", b"c_interp", b"d_interp", b"lod", b"maplib", b"usemap",
    b"shadow_obj", b"trace_obj", b"ctech", b"stech",
];

/// Valid OBJ records of geometry other than faces (points, polylines,
/// free-form curves and surfaces): skipped, with a note, since the mesh read
/// is then not all the file describes.
const OTHER_GEOMETRY: &[&[u8]] = &[b"p", b"l", b"curv", b"curv2", b"surf"];

/// Parses an OBJ file held in memory.
pub(crate) fn read(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    // A UTF-8 byte order mark (Windows editors write one) is not part of the
    // first statement: left in, it hid the first vertex (issue 13, item 17).
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    let mut reader = Reader::new(name, bytes.len());
    let mut lines = Lines::new(bytes);
    let mut joined = Vec::new();
    while let Some((number, line)) = lines.next() {
        if trim_end(line).last() == Some(&b'\\') {
            // Line continuation is rare: only here do we copy, into one reused buffer.
            joined.clear();
            let mut current = line;
            while let Some(head) = trim_end(current).strip_suffix(b"\\") {
                joined.extend_from_slice(head);
                joined.push(b' ');
                match lines.next() {
                    Some((_, next)) => current = next,
                    None => {
                        current = b"";
                        break;
                    }
                }
            }
            joined.extend_from_slice(current);
            reader.line(number, &joined)?;
        } else {
            reader.line(number, line)?;
        }
    }
    reader.finish()
}

struct Reader<'n> {
    name: &'n str,
    /// Upper bound on how many `v` records the file can hold (each takes at least
    /// 8 bytes), so that a forward reference cannot make us allocate beyond it.
    max_vertices: u64,
    positions: Vec<[f64; 3]>,
    texcoords: Vec<[f64; 2]>,
    triangles: Triangles,
    corners: Vec<u32>,
    corner_vt: Vec<u32>,
    /// Per vertex, the `vt` its corners use (or `NO_VT`); sized lazily.
    vertex_vt: Vec<u32>,
    any_vt: bool,
    uv_possible: bool,
    uv_conflict: bool,
    /// Every corner names `vt` index == `v` index (what our writer produces).
    vt_is_identity: bool,
    /// Lines whose positive indices pointed past the records read so far:
    /// (line, largest `v`, largest `vt`), checked once the whole file is read.
    forward: Vec<(u64, u64, u64)>,
    unknown: usize,
    first_unknown: Option<(u64, String)>,
    other_geometry: usize,
    first_other_geometry: Option<(u64, String)>,
}

impl<'n> Reader<'n> {
    fn new(name: &'n str, n_bytes: usize) -> Self {
        Reader {
            name,
            max_vertices: (n_bytes as u64 / 8 + 1).min(u64::from(u32::MAX)),
            positions: Vec::with_capacity(n_bytes / 80),
            texcoords: Vec::new(),
            triangles: Triangles::with_capacity(n_bytes / 40),
            corners: Vec::with_capacity(8),
            corner_vt: Vec::with_capacity(8),
            vertex_vt: Vec::new(),
            any_vt: false,
            uv_possible: true,
            uv_conflict: false,
            vt_is_identity: true,
            forward: Vec::new(),
            unknown: 0,
            first_unknown: None,
            other_geometry: 0,
            first_other_geometry: None,
        }
    }

    #[inline]
    fn line(&mut self, number: u64, line: &[u8]) -> Result<(), MeshError> {
        let mut rest = line;
        let Some(keyword) = next_token(&mut rest) else { return Ok(()) };
        match keyword {
            b"v" => self.vertex(number, rest),
            b"f" => self.face(number, rest),
            b"vt" => self.texcoord(number, rest),
            _ if keyword.starts_with(b"#") || KNOWN.contains(&keyword) => Ok(()),
            _ if OTHER_GEOMETRY.contains(&keyword) => {
                self.other_geometry += 1;
                if self.first_other_geometry.is_none() {
                    self.first_other_geometry = Some((number, text::show(Some(keyword))));
                }
                Ok(())
            }
            _ => {
                self.unknown += 1;
                if self.first_unknown.is_none() {
                    self.first_unknown = Some((number, text::show(Some(keyword))));
                }
                Ok(())
            }
        }
    }

    #[inline]
    fn vertex(&mut self, number: u64, mut rest: &[u8]) -> Result<(), MeshError> {
        let mut p = [0.0; 3];
        for (axis, slot) in p.iter_mut().enumerate() {
            let value = take_float::<f64>(&mut rest).ok_or_else(|| {
                let found = text::show_next(rest);
                line_error(
                    self.name,
                    number,
                    format!("vertex needs 3 numbers; coordinate {} is {found}", axis + 1),
                )
            })?;
            if !value.is_finite() {
                return Err(line_error(
                    self.name,
                    number,
                    format!("vertex coordinate {value} is not finite"),
                ));
            }
            *slot = value;
        }
        // A fourth value (w) or vertex colours may follow: not used.
        self.positions.push(p);
        Ok(())
    }

    fn texcoord(&mut self, number: u64, mut rest: &[u8]) -> Result<(), MeshError> {
        let bad = |rest: &[u8]| {
            line_error(
                self.name,
                number,
                format!("vt needs numbers, found {}", text::show_next(rest)),
            )
        };
        let u = take_float::<f64>(&mut rest).ok_or_else(|| bad(rest))?;
        // v is optional in OBJ and defaults to 0.
        let v = if skip_space(rest).is_empty() {
            0.0
        } else {
            take_float::<f64>(&mut rest).ok_or_else(|| bad(rest))?
        };
        self.texcoords.push([u, v]);
        Ok(())
    }

    /// Resolves a 1-based or negative OBJ index against `count` records read so far.
    /// Returns the 0-based index; a positive index beyond `count` is allowed up to
    /// `limit` and checked at the end of the file.
    #[inline]
    fn resolve(
        &self,
        token: &[u8],
        count: usize,
        limit: u64,
        number: u64,
        what: &str,
    ) -> Result<u32, MeshError> {
        let index = text::parse_i64(token).ok_or_else(|| {
            line_error(
                self.name,
                number,
                format!("{what} index {} is not an integer", text::show(Some(token))),
            )
        })?;
        let resolved = if index > 0 {
            index as u64 - 1
        } else if index < 0 && index.unsigned_abs() <= count as u64 {
            count as u64 - index.unsigned_abs()
        } else {
            let why = if index == 0 {
                "OBJ indices start at 1"
            } else {
                "it points before the first record"
            };
            return Err(line_error(
                self.name,
                number,
                format!("{what} index {index} is invalid: {why}"),
            ));
        };
        if resolved >= limit.min(u64::from(u32::MAX)) {
            return Err(line_error(
                self.name,
                number,
                format!(
                    "{what} index {index} is out of range: the file cannot hold that many records"
                ),
            ));
        }
        Ok(resolved as u32)
    }

    #[inline]
    fn face(&mut self, number: u64, mut rest: &[u8]) -> Result<(), MeshError> {
        self.corners.clear();
        self.corner_vt.clear();
        let (nv, nvt) = (self.positions.len(), self.texcoords.len());
        let mut any_missing_vt = false;
        while let Some(token) = next_token(&mut rest) {
            if token.starts_with(b"#") {
                break;
            }
            if self.corners.len() == MAX_POLYGON_CORNERS {
                let msg = polygon_too_large(format!("more than {MAX_POLYGON_CORNERS}"));
                return Err(line_error(self.name, number, msg));
            }
            // Fast path for the most common corner, a plain positive index.
            if let Some(index) = text::parse_u64(token).filter(|&i| i > 0 && i <= self.max_vertices)
            {
                self.corners.push((index - 1) as u32);
                any_missing_vt = true;
                continue;
            }
            let mut parts = token.splitn(3, |&b| b == b'/');
            let v_token = parts.next().unwrap_or(token);
            let v = self.resolve(v_token, nv, self.max_vertices, number, "vertex")?;
            self.corners.push(v);
            match parts.next() {
                Some(t) if !t.is_empty() => {
                    let vt = self.resolve(t, nvt, u64::from(u32::MAX), number, "texture")?;
                    self.corner_vt.push(vt);
                }
                _ => any_missing_vt = true,
            }
            if let Some(n) = parts.next().filter(|n| !n.is_empty()) {
                // Normals are not used, but a malformed index is still a malformed file.
                if text::parse_i64(n).is_none() {
                    let msg = format!("normal index {} is not an integer", text::show(Some(n)));
                    return Err(line_error(self.name, number, msg));
                }
            }
        }
        if self.corners.len() < 3 {
            let msg =
                format!("a face needs at least 3 vertices, this one has {}", self.corners.len());
            return Err(line_error(self.name, number, msg));
        }
        let max_v = self.corners.iter().map(|&v| u64::from(v) + 1).max().unwrap_or(0);
        let max_vt = self.corner_vt.iter().map(|&t| u64::from(t) + 1).max().unwrap_or(0);
        if max_v > nv as u64 || max_vt > nvt as u64 {
            self.forward.push((number, max_v, max_vt));
        }
        self.track_uv(any_missing_vt);
        self.triangles.push(&self.corners);
        Ok(())
    }

    /// Keeps a per-vertex uv possible only while every corner agrees with it.
    #[inline]
    fn track_uv(&mut self, any_missing_vt: bool) {
        if !self.corner_vt.is_empty() {
            self.any_vt = true;
        }
        if any_missing_vt {
            self.uv_possible = false;
        }
        if !self.uv_possible || self.uv_conflict {
            return;
        }
        for (&v, &t) in self.corners.iter().zip(&self.corner_vt) {
            self.vt_is_identity &= v == t;
            let v = v as usize;
            if v >= self.vertex_vt.len() {
                // Bounded by `max_vertices`, i.e. by the file size.
                self.vertex_vt.resize(v + 1, NO_VT);
            }
            match self.vertex_vt.get_mut(v) {
                Some(slot) if *slot == NO_VT => *slot = t,
                Some(slot) if *slot != t => self.uv_conflict = true,
                _ => {}
            }
        }
    }

    fn finish(mut self) -> Result<LoadedMesh, MeshError> {
        let (nv, nvt) = (self.positions.len() as u64, self.texcoords.len() as u64);
        for &(number, max_v, max_vt) in &self.forward {
            if max_v > nv {
                let msg =
                    format!("vertex index {max_v} is out of range: the file has {nv} vertices");
                return Err(line_error(self.name, number, msg));
            }
            if max_vt > nvt {
                let msg = format!(
                    "texture index {max_vt} is out of range: the file has {nvt} vt records"
                );
                return Err(line_error(self.name, number, msg));
            }
        }
        let mut notes = Vec::new();
        let uv = self.per_vertex_uv(&mut notes);
        notes.extend(self.triangles.note());
        if let Some((number, keyword)) = &self.first_other_geometry {
            notes.push(format!(
                "ignored {} point, line and free-form records (p, l, curv, curv2, surf; the \
                 first, {keyword}, at line {number}): spherify reads the faces only",
                self.other_geometry
            ));
        }
        if let Some((number, keyword)) = &self.first_unknown {
            notes.push(format!(
                "ignored {} lines with unknown OBJ records (the first, {keyword}, at line {number})",
                self.unknown
            ));
        }
        let attributes = VertexAttributes { sphere: None, uv };
        finish(self.name, self.positions, self.triangles.faces, attributes, notes)
    }

    fn per_vertex_uv(&mut self, notes: &mut Vec<String>) -> Option<Vec<[f64; 2]>> {
        let nv = self.positions.len();
        if !self.any_vt {
            if !self.texcoords.is_empty() {
                notes.push(format!(
                    "ignored {} vt records: no face refers to them",
                    self.texcoords.len()
                ));
            }
            return None;
        }
        if !self.uv_possible || self.uv_conflict {
            let why = if self.uv_conflict {
                "some vertex uses different vt records in different faces (a uv seam)"
            } else {
                "some face corners have no vt index"
            };
            notes.push(format!(
                "ignored the texture coordinates: {why}; spherify keeps one uv per vertex"
            ));
            return None;
        }
        if self.vt_is_identity && self.texcoords.len() == nv {
            return Some(std::mem::take(&mut self.texcoords));
        }
        let mut unused = 0usize;
        let uv = (0..nv)
            .map(|v| match self.vertex_vt.get(v).and_then(|&t| self.texcoords.get(t as usize)) {
                Some(&uv) => uv,
                None => {
                    unused += 1;
                    [0.0, 0.0]
                }
            })
            .collect();
        if unused > 0 {
            notes.push(format!("{unused} vertices used by no face were given uv (0, 0)"));
        }
        Some(uv)
    }
}

/// Writes `v` lines with round-trip precision, `vt` lines when uv is given, and
/// 1-based `f` lines (`a/a` corners with uv, as the vt list parallels the vertices).
pub(crate) fn write<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    uv: Option<&[[f64; 2]]>,
) -> std::io::Result<()> {
    writeln!(
        out,
        "# {} vertices, {} triangles; written by spherify",
        mesh.n_vertices(),
        mesh.n_faces()
    )?;
    write_rows(out, b"v", mesh.positions(), text::write_f64)?;
    if let Some(uv) = uv {
        write_rows(out, b"vt", uv, text::write_f64)?;
    }
    for &[a, b, c] in mesh.faces() {
        let (a, b, c) = (u64::from(a) + 1, u64::from(b) + 1, u64::from(c) + 1);
        if uv.is_some() {
            writeln!(out, "f {a}/{a} {b}/{b} {c}/{c}")?;
        } else {
            writeln!(out, "f {a} {b} {c}")?;
        }
    }
    Ok(())
}

/// One `tag x y ...` line per row (`v`, `vt`), each number written by `number`.
fn write_rows<W: Write, const K: usize>(
    out: &mut W,
    tag: &[u8],
    rows: &[[f64; K]],
    number: fn(&mut W, f64) -> std::io::Result<()>,
) -> std::io::Result<()> {
    for row in rows {
        out.write_all(tag)?;
        for &x in row {
            out.write_all(b" ")?;
            number(out, x)?;
        }
        out.write_all(b"\n")?;
    }
    Ok(())
}

/// Writes a textured OBJ: a comment naming the layout (`label`), with
/// `material_library` its `mtllib` line and `usemtl texture`, the `v` lines,
/// one `vt` line per face corner (`corners`: three per face, in face order)
/// and `f a/t b/t c/t` lines, numbers as C's `%.17g`. A texture atlas cuts
/// the sphere into pieces, so one uv per vertex ([`write`]) cannot hold it.
pub(crate) fn write_per_corner<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    corners: &[[f64; 2]],
    label: &str,
    material_library: Option<&str>,
) -> std::io::Result<()> {
    writeln!(out, "# spherify: {label} texture coordinates, one vt per face corner")?;
    if let Some(library) = material_library {
        writeln!(out, "mtllib {library}\nusemtl texture")?;
    }
    write_rows(out, b"v", mesh.positions(), text::write_f64_g17)?;
    write_rows(out, b"vt", corners, text::write_f64_g17)?;
    for (k, &[a, b, c]) in mesh.faces().iter().enumerate() {
        let (a, b, c) = (u64::from(a) + 1, u64::from(b) + 1, u64::from(c) + 1);
        let t = 3 * k as u64;
        writeln!(out, "f {a}/{} {b}/{} {c}/{}", t + 1, t + 2, t + 3)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::tests::{awkward_tetra, bits, location};
    use super::super::{read_bytes, write_bytes, FileFormat, WriteOptions};
    use super::*;
    use crate::error::Location;

    fn parse(text: &str) -> Result<LoadedMesh, MeshError> {
        read_bytes(text.as_bytes(), FileFormat::Obj, "test.obj")
    }

    #[test]
    fn per_corner_texture_coordinates_are_written_and_read_back() {
        let mesh = awkward_tetra();
        // Corner k of face f at (f + k / 4, -0.5): no vertex keeps one uv.
        let corners: Vec<[f64; 2]> = (0..3 * mesh.n_faces())
            .map(|i| [(i / 3) as f64 + (i % 3) as f64 / 4.0, -0.5])
            .collect();
        let mut out = Vec::new();
        write_per_corner(&mut out, &mesh, &corners, "cube", Some("t.mtl")).unwrap();
        let text = String::from_utf8(out).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(
            lines[..3],
            [
                "# spherify: cube texture coordinates, one vt per face corner",
                "mtllib t.mtl",
                "usemtl texture"
            ]
        );
        assert_eq!(lines[3], "v 0.10000000000000001 0.33333333333333331 -0");
        assert_eq!(lines[3 + mesh.n_vertices() + 1], "vt 0.25 -0.5");
        assert_eq!(*lines.last().unwrap(), "f 1/10 4/11 3/12");
        let loaded = parse(&text).unwrap();
        assert_eq!(bits(loaded.mesh.positions()), bits(mesh.positions()));
        assert_eq!(loaded.mesh.faces(), mesh.faces());
        assert!(loaded.attributes.uv.is_none());
    }

    #[test]
    fn reads_vertices_faces_and_skips_other_records() {
        let text =
            "# a tetrahedron\r\nmtllib x.mtl\r\no tet\r\nv 0 0 0\r\nv 1 0 0 1.0 0.5 0.5 0.5\r\n\
                    v 0 1 0\r\nv 0 0 1\r\nvn 0 0 1\r\ng side\r\ns off\r\nusemtl red\r\n\
                    f 1 3 2\r\nf 1//1 2//1 4//1\r\nf -3 -2 -1 # relative\r\n\
                    l 1 2\r\np 3\r\nf 1 4 3\r\n";
        let loaded = parse(text).unwrap();
        assert_eq!(
            loaded.mesh.positions(),
            &[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]
        );
        assert_eq!(loaded.mesh.faces(), &[[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]);
        assert_eq!(loaded.attributes.uv, None);
        // Only the point and the line are worth a note: geometry not read.
        assert_eq!(loaded.notes.len(), 1, "{:?}", loaded.notes);
        assert!(loaded.notes[0].starts_with("ignored 2 point, line"), "{:?}", loaded.notes);
    }

    #[test]
    fn texture_coordinates_become_per_vertex_uv_when_consistent() {
        let text =
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0.5 0.5\nvt 0.1 0.2\nvt 0.3\nvt 0.9 0.9\n\
                    f 1/4/1 3/3/1 2/2/1\nf 1/4 2/2 4/1\nf 2/2 -2/-2 -1/-4\nf 1/4/1 4/1/1 3/3/1\n";
        let loaded = parse(text).unwrap();
        assert_eq!(
            loaded.attributes.uv,
            Some(vec![[0.9, 0.9], [0.1, 0.2], [0.3, 0.0], [0.5, 0.5]])
        );
        // A uv seam (vertex 1 with two vt records) cannot be one uv per vertex.
        let seam = text.replace("f 1/4 2/2 4/1", "f 1/1 2/2 4/1");
        let loaded = parse(&seam).unwrap();
        assert_eq!(loaded.attributes.uv, None);
        assert!(loaded.notes.iter().any(|n| n.contains("seam")), "{:?}", loaded.notes);
        let partial = text.replace("f 1/4 2/2 4/1", "f 1 2/2 4/1");
        assert!(parse(&partial).unwrap().notes.iter().any(|n| n.contains("no vt index")));
    }

    #[test]
    fn polygons_are_fan_triangulated_with_a_note() {
        let text = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nf 1 2 3 4\nf 1 2 3 4 5\nf 1 2 5\n";
        let loaded = parse(text).unwrap();
        assert_eq!(
            loaded.mesh.faces(),
            &[[0, 1, 2], [0, 2, 3], [0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 1, 4]]
        );
        assert_eq!(
            loaded.notes,
            vec!["2 polygons with more than 3 vertices were fan-triangulated into 5 triangles"
                .to_string()]
        );
    }

    #[test]
    fn continuation_lines_forward_references_and_unknown_records() {
        let text = "v 0 0 0\nf 1 \\\n 2 3\nfoo bar\nv 1 0 0\nv 0 1 0\n";
        let loaded = parse(text).unwrap();
        assert_eq!(loaded.mesh.faces(), &[[0, 1, 2]]);
        assert!(loaded.notes.iter().any(|n| n.contains("'foo', at line 4")), "{:?}", loaded.notes);
    }

    #[test]
    fn points_lines_and_free_form_geometry_are_noted_and_the_rest_is_silent() {
        let text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\ng a\ns 1\nusemtl m\nf 1 2 3\n\
                    l 1 2\np 3\nl 2 3\n";
        let loaded = parse(text).unwrap();
        assert_eq!(loaded.mesh.faces(), &[[0, 1, 2]]);
        assert_eq!(
            loaded.notes,
            vec!["ignored 3 point, line and free-form records (p, l, curv, curv2, surf; the \
                  first, 'l', at line 9): spherify reads the faces only"
                .to_string()]
        );
        let silent = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\no x\ng a\nf 1//1 2//1 3//1\n");
        assert_eq!(silent.unwrap().notes, Vec::<String>::new());
    }

    #[test]
    fn malformed_lines_are_reported_by_number() {
        let base = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
        let cases = [
            ("f 1 2 3\nv 1 2 x\n", 5),
            ("v 1 2\n", 4),
            ("v 1 2 3abc\n", 4),
            ("v nan 0 0\n", 4),
            ("v 0 inf 0\n", 4),
            ("f 1 2\n", 4),
            ("\nf 1 0 2\n", 5),
            ("f 1 2 -4\n", 4),
            ("f 1 2 4\n", 4),
            ("f 1 2 99999999999\n", 4),
            ("f 1 2 3/x\n", 4),
            ("f 1 2 3//n\n", 4),
            ("f 1 2 3/4\n", 4),
            ("f 1 2 a\n", 4),
        ];
        for (tail, line) in cases {
            let result = parse(&format!("{base}{tail}"));
            assert_eq!(location(result), Location::Line(line), "{tail:?}");
        }
        assert!(matches!(parse("v 0 0 0\n"), Err(MeshError::Format(_))));
    }

    #[test]
    fn round_trip_is_bit_exact_with_and_without_uv() {
        let mesh = awkward_tetra();
        let uv = vec![[0.1, 0.2], [1.0 / 3.0, -0.0], [5e-324, 1e300], [0.5, 0.5]];
        for uv in [None, Some(uv)] {
            let attrs = VertexAttributes { sphere: None, uv: uv.clone() };
            let bytes =
                write_bytes(&mesh, &attrs, FileFormat::Obj, &WriteOptions::default(), "t").unwrap();
            let loaded = read_bytes(&bytes, FileFormat::Obj, "t").unwrap();
            assert_eq!(bits(loaded.mesh.positions()), bits(mesh.positions()));
            assert_eq!(loaded.mesh.faces(), mesh.faces());
            let got = loaded
                .attributes
                .uv
                .map(|t| t.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>());
            let want = uv.map(|t| t.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>());
            assert_eq!(got, want);
            assert!(loaded.notes.is_empty(), "{:?}", loaded.notes);
        }
    }

    #[test]
    fn a_utf8_byte_order_mark_is_skipped() {
        let plain = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n".to_vec();
        let mut marked = b"\xEF\xBB\xBF".to_vec();
        marked.extend_from_slice(&plain);
        let (a, b) = (read(&plain, "a.obj").unwrap(), read(&marked, "b.obj").unwrap());
        assert_eq!(b.mesh.positions(), a.mesh.positions());
        assert_eq!(b.mesh.faces(), a.mesh.faces());
    }
}
