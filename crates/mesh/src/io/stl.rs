//! STL, ascii and binary. STL is a triangle soup in single precision: every
//! triangle carries its own three corners and a normal (ignored on read, recomputed
//! on write). The reader welds corners whose coordinates are bitwise equal (after
//! turning -0.0 into 0.0) into shared vertices, numbered in order of first
//! appearance, and says so in a note. Corners that are merely close stay apart:
//! that would be silent vertex merging (STYLE "Avoid").
//!
//! Ascii coordinates are parsed straight to `f32` like binary ones, so both
//! encodings of the same mesh load identically.

use super::text::{self, next_token, take_float, Lines};
use super::{byte_error, finish, line_error, LoadedMesh, Triangles, VertexAttributes};
use crate::error::MeshError;
use crate::Mesh;
use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};
use std::io::Write;

const HEADER: usize = 80;
const TRIANGLE: usize = 50;

/// Parses an STL file held in memory, binary or ascii.
pub(crate) fn read(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let count =
        bytes.get(HEADER..HEADER + 4).and_then(|b| b.try_into().ok()).map(u32::from_le_bytes);
    // The size test decides: ascii files rarely match it by accident, while binary
    // files often start with "solid" despite the specification.
    let needed = count.map(|c| (HEADER + 4) as u64 + TRIANGLE as u64 * u64::from(c));
    if needed == Some(bytes.len() as u64) {
        return read_binary(bytes, name);
    }
    let looks_ascii = text::skip_space(bytes).starts_with(b"solid");
    match (looks_ascii, count, needed) {
        (true, _, _) => read_ascii(bytes, name).map_err(|e| {
            // A binary file whose header starts with "solid" but whose size is
            // wrong is better described by its size than by an ascii parse error.
            match (count, needed) {
                (Some(c), Some(n)) if bytes.contains(&0) => size_error(name, c, n, bytes.len()),
                _ => e,
            }
        }),
        (false, Some(c), Some(n)) => Err(size_error(name, c, n, bytes.len())),
        _ => Err(byte_error(
            name,
            0,
            "not an STL file: too short for binary STL and no ascii 'solid' header",
        )),
    }
}

fn size_error(name: &str, count: u32, needed: u64, len: usize) -> MeshError {
    let msg = format!(
        "binary STL header announces {count} triangles, which take {needed} bytes, but the file has {len} bytes"
    );
    byte_error(name, HEADER, msg)
}

fn read_binary(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let body = bytes.get(HEADER + 4..).unwrap_or_default();
    let n = body.len() / TRIANGLE;
    let mut welder = Welder::with_capacity(n / 2 + 1);
    let mut faces = Vec::with_capacity(n);
    for (t, record) in body.chunks_exact(TRIANGLE).enumerate() {
        let mut face = [0u32; 3];
        for (c, slot) in face.iter_mut().enumerate() {
            let at = 12 + 12 * c;
            let mut p = [0.0f32; 3];
            for (k, x) in p.iter_mut().enumerate() {
                let word = record.get(at + 4 * k..at + 4 * k + 4).and_then(|b| b.try_into().ok());
                *x = f32::from_le_bytes(word.unwrap_or_default());
            }
            if let Some(bad) = p.iter().find(|x| !x.is_finite()) {
                let offset = HEADER + 4 + t * TRIANGLE + at;
                return Err(byte_error(
                    name,
                    offset,
                    format!("vertex coordinate {bad} is not finite"),
                ));
            }
            *slot = welder.index(p);
        }
        faces.push(face);
    }
    let corners = faces.len() * 3;
    let positions = welder.positions;
    let notes = vec![weld_note(corners, positions.len())];
    finish(name, positions, faces, VertexAttributes::default(), notes)
}

fn read_ascii(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let mut welder = Welder::with_capacity(bytes.len() / 200);
    let mut triangles = Triangles::with_capacity(bytes.len() / 250);
    let mut corners = Vec::with_capacity(3);
    let mut corner_count = 0usize;
    // Whether an endsolid follows the last facet: without it the file may
    // have been cut short after a complete facet (issue 13, item 17).
    let mut ended = false;
    let mut lines = Lines::new(bytes);
    for (number, line) in &mut lines {
        let mut rest = line;
        match next_token(&mut rest) {
            Some(b"endsolid") => ended = true,
            None | Some(b"solid" | b"facet" | b"outer" | b"endfacet") => {}
            Some(b"vertex") => {
                let mut p = [0.0f32; 3];
                for slot in &mut p {
                    *slot = take_float::<f32>(&mut rest).ok_or_else(|| {
                        let msg =
                            format!("vertex needs 3 numbers, found {}", text::show_next(rest));
                        line_error(name, number, msg)
                    })?;
                    if !slot.is_finite() {
                        return Err(line_error(
                            name,
                            number,
                            format!("vertex coordinate {slot} is not finite"),
                        ));
                    }
                }
                corners.push(welder.index(p));
            }
            Some(b"endloop") => {
                if corners.len() < 3 {
                    let msg = format!(
                        "a facet needs at least 3 vertices, this one has {}",
                        corners.len()
                    );
                    return Err(line_error(name, number, msg));
                }
                corner_count += corners.len();
                triangles.push(&corners);
                corners.clear();
                ended = false;
            }
            Some(other) => {
                let msg = format!("unexpected {} in an ascii STL file", text::show(Some(other)));
                return Err(line_error(name, number, msg));
            }
        }
    }
    if !corners.is_empty() {
        return Err(line_error(name, lines.line(), "the file ends inside a facet (no endloop)"));
    }
    let mut notes = vec![weld_note(corner_count, welder.positions.len())];
    notes.extend(triangles.note());
    if !ended && !triangles.faces.is_empty() {
        notes.push(format!(
            "no endsolid after the last of {} facets: the file may have been cut short",
            triangles.faces.len()
        ));
    }
    finish(name, welder.positions, triangles.faces, VertexAttributes::default(), notes)
}

fn weld_note(corners: usize, vertices: usize) -> String {
    format!("welded {corners} coincident corners into {vertices} vertices (STL stores each triangle's corners separately; only bitwise-equal coordinates were merged)")
}

/// Maps each distinct corner position to a vertex id, in order of first appearance.
struct Welder {
    ids: HashMap<[u32; 3], u32, BuildHasherDefault<MixHasher>>,
    positions: Vec<[f64; 3]>,
}

impl Welder {
    fn with_capacity(n: usize) -> Self {
        Welder {
            ids: HashMap::with_capacity_and_hasher(n, Default::default()),
            positions: Vec::with_capacity(n),
        }
    }

    #[inline]
    fn index(&mut self, p: [f32; 3]) -> u32 {
        // -0.0 == 0.0 but their bits differ: weld them as the same point.
        let key = p.map(|x| if x == 0.0 { 0 } else { x.to_bits() });
        let next = self.positions.len() as u32;
        let id = *self.ids.entry(key).or_insert(next);
        if id == next {
            self.positions.push(p.map(|x| f64::from(if x == 0.0 { 0.0 } else { x })));
        }
        id
    }
}

/// A small multiplicative hasher: the keys are float bit patterns from our own
/// parser, so the DoS resistance of the default SipHash buys nothing and costs
/// about half the welding time.
#[derive(Default)]
struct MixHasher(u64);

impl Hasher for MixHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        for chunk in bytes.chunks(8) {
            let mut word = [0u8; 8];
            word[..chunk.len()].copy_from_slice(chunk);
            self.write_u64(u64::from_le_bytes(word));
        }
    }

    #[inline]
    fn write_u64(&mut self, x: u64) {
        self.0 = (self.0.rotate_left(23) ^ x).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    #[inline]
    fn write_u32(&mut self, x: u32) {
        self.write_u64(u64::from(x));
    }

    #[inline]
    fn write_usize(&mut self, x: usize) {
        self.write_u64(x as u64);
    }

    #[inline]
    fn finish(&self) -> u64 {
        // Final avalanche so both the low bits (bucket) and the high bits (tag) vary.
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^ (h >> 33)
    }
}

/// Writes STL: binary (`binary == true`) or ascii. STL stores `f32` coordinates,
/// so positions are rounded to single precision, and it keeps no shared vertices:
/// reading the file back welds bitwise-equal corners, which restores the mesh
/// exactly when its coordinates are `f32`-representable and distinct.
pub(crate) fn write<W: Write>(out: &mut W, mesh: &Mesh, binary: bool) -> std::io::Result<()> {
    let p = mesh.positions();
    let corner = |v: u32| p.get(v as usize).map_or([0.0; 3], |q| q.map(|x| x as f32));
    if binary {
        let mut header = [b' '; HEADER];
        let label = b"binary STL written by spherify";
        header[..label.len()].copy_from_slice(label);
        out.write_all(&header)?;
        let count = u32::try_from(mesh.n_faces()).map_err(|_| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "binary STL holds at most 2^32-1 triangles",
            )
        })?;
        out.write_all(&count.to_le_bytes())?;
        let mut record = [0u8; TRIANGLE];
        for face in mesh.faces() {
            let c = face.map(corner);
            let values = std::iter::once(normal(&c)).chain(c);
            for (k, x) in values.flatten().enumerate() {
                record[4 * k..4 * k + 4].copy_from_slice(&x.to_le_bytes());
            }
            out.write_all(&record)?;
        }
        return Ok(());
    }
    out.write_all(b"solid spherify\n")?;
    for face in mesh.faces() {
        let c = face.map(corner);
        let n = normal(&c);
        out.write_all(b"  facet normal")?;
        write_point(out, &n)?;
        out.write_all(b"\n    outer loop\n")?;
        for q in &c {
            out.write_all(b"      vertex")?;
            write_point(out, q)?;
            out.write_all(b"\n")?;
        }
        out.write_all(b"    endloop\n  endfacet\n")?;
    }
    out.write_all(b"endsolid spherify\n")
}

fn write_point<W: Write>(out: &mut W, p: &[f32; 3]) -> std::io::Result<()> {
    for &x in p {
        out.write_all(b" ")?;
        text::write_f32(out, x)?;
    }
    Ok(())
}

/// Unit normal of a triangle (zero when degenerate), for readers that use it.
fn normal(c: &[[f32; 3]; 3]) -> [f32; 3] {
    let d = |i: usize, k: usize| f64::from(c[i][k]) - f64::from(c[0][k]);
    let (u, v) = ([d(1, 0), d(1, 1), d(1, 2)], [d(2, 0), d(2, 1), d(2, 2)]);
    let n = [u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]];
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if len > 0.0 && len.is_finite() {
        n.map(|x| (x / len) as f32)
    } else {
        [0.0; 3]
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{bits, location};
    use super::super::{read_bytes, write_bytes, FileFormat, WriteOptions};
    use super::*;
    use crate::error::Location;

    fn parse(bytes: &[u8]) -> Result<LoadedMesh, MeshError> {
        read_bytes(bytes, FileFormat::Stl, "test.stl")
    }

    const TETRA: [[f64; 3]; 4] =
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    const TETRA_FACES: [[u32; 3]; 4] = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
    /// Faces whose corners appear in index order, so that welding on read gives
    /// back the same numbering.
    const ORDERED_FACES: [[u32; 3]; 4] = [[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]];

    fn ascii_tetra() -> String {
        let mut text = String::from("solid tetra made by hand\n");
        for face in TETRA_FACES {
            text += "  facet normal 0 0 0\n    outer loop\n";
            for v in face {
                let p = TETRA[v as usize];
                // Negative zeros must weld with positive ones.
                let z = if v == 0 { "-0.0" } else { "0" };
                let show = |x: f64| if x == 0.0 { z.to_string() } else { format!("{x:e}") };
                text += &format!("      vertex {} {} {}\n", show(p[0]), show(p[1]), show(p[2]));
            }
            text += "    endloop\n  endfacet\n";
        }
        text + "endsolid tetra\n"
    }

    #[test]
    fn ascii_corners_are_welded_in_first_appearance_order() {
        let loaded = parse(ascii_tetra().as_bytes()).unwrap();
        assert_eq!(loaded.mesh.positions(), &[TETRA[0], TETRA[2], TETRA[1], TETRA[3]]);
        assert_eq!(bits(loaded.mesh.positions())[0], [0, 0, 0], "-0.0 is stored as 0.0");
        assert_eq!(loaded.mesh.faces(), &[[0, 1, 2], [0, 2, 3], [2, 1, 3], [0, 3, 1]]);
        assert!(
            loaded.notes[0].starts_with("welded 12 coincident corners into 4 vertices"),
            "{:?}",
            loaded.notes
        );
    }

    #[test]
    fn binary_with_a_solid_header_is_read_as_binary() {
        let mesh = Mesh::new(TETRA.to_vec(), ORDERED_FACES.to_vec()).unwrap();
        let mut bytes =
            write_bytes(&mesh, &Default::default(), FileFormat::Stl, &WriteOptions::default(), "t")
                .unwrap();
        bytes[..20].copy_from_slice(b"solid but binary....");
        let loaded = parse(&bytes).unwrap();
        assert_eq!(loaded.mesh.positions(), &TETRA);
        assert_eq!(loaded.mesh.faces(), &ORDERED_FACES);
        // One byte too many: the size no longer matches, and the zero bytes show it is
        // not ascii, so the error names the count at byte 80.
        bytes.push(0);
        assert_eq!(location(parse(&bytes)), Location::Byte(80));
        bytes[..5].copy_from_slice(b"xxxxx");
        assert_eq!(location(parse(&bytes)), Location::Byte(80));
        // A NaN in the second triangle's first corner.
        bytes.pop();
        bytes[84 + 50 + 12..84 + 50 + 16].copy_from_slice(&f32::NAN.to_le_bytes());
        assert_eq!(location(parse(&bytes)), Location::Byte(84 + 50 + 12));
    }

    #[test]
    fn round_trips_f32_coordinates_exactly_in_both_encodings() {
        let positions = vec![
            [0.1f32 as f64, 1e-30f32 as f64, -3.5],
            [f64::from(f32::MAX), (1.0f32 / 3.0) as f64, 2.0],
            [-7.25, f64::from(f32::MIN_POSITIVE), 1e20f32 as f64],
            [123456.78f32 as f64, -0.3f32 as f64, 0.0],
        ];
        let mesh = Mesh::new(positions, ORDERED_FACES.to_vec()).unwrap();
        for stl_binary in [true, false] {
            let options = WriteOptions { stl_binary, ..WriteOptions::default() };
            let bytes =
                write_bytes(&mesh, &Default::default(), FileFormat::Stl, &options, "t").unwrap();
            let loaded = parse(&bytes).unwrap();
            assert_eq!(
                bits(loaded.mesh.positions()),
                bits(mesh.positions()),
                "binary: {stl_binary}"
            );
            assert_eq!(loaded.mesh.faces(), mesh.faces());
            assert_eq!(loaded.attributes, VertexAttributes::default());
        }
    }

    #[test]
    fn malformed_ascii_is_reported_by_line() {
        let good = ascii_tetra();
        let cases = [
            ("outer loop", "outr loop", 3, true),
            ("      vertex -0.0 -0.0 -0.0\n", "      vertex 0 0\n", 4, true),
            ("      vertex -0.0 -0.0 -0.0\n", "      vertex 0 nan 0\n", 4, true),
            ("      vertex -0.0 -0.0 -0.0\n", "      vertex 1 2 3e\n", 4, true),
            ("      vertex -0.0 -0.0 -0.0\n", "", 6, true),
        ];
        for (from, to, line, first_only) in cases {
            let text = if first_only { good.replacen(from, to, 1) } else { good.replace(from, to) };
            assert_eq!(location(parse(text.as_bytes())), Location::Line(line), "{to:?}");
        }
        let unfinished = good.split("    endloop").next().unwrap_or_default();
        assert_eq!(location(parse(unfinished.as_bytes())), Location::Line(6));
        assert!(matches!(parse(b"solid empty\nendsolid empty\n"), Err(MeshError::Format(_))));
    }
}
