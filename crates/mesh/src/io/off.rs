//! Object File Format: a header keyword, the counts `nv nf ne`, then one vertex
//! per line and one polygon per line (`n i1 ... in`, 0-based).
//!
//! The `C`, `N` and `ST` variants only append colours, normals or texture
//! coordinates to each vertex line; spherify reads the first three numbers and
//! ignores the rest, as it ignores colours after a face's indices. Dimension
//! variants (`4OFF`, `nOFF`) and binary OFF are refused with a clear message.
//! A first line that joins the keyword and the vertex count (`OFF490 518 0`,
//! as in the ModelNet data sets) is read as `OFF 490 518 0`.

use super::text::{self, next_token, take_float, Lines};
use super::{
    finish, line_error, polygon_too_large, LoadedMesh, Triangles, VertexAttributes,
    MAX_POLYGON_CORNERS,
};
use crate::error::MeshError;
use crate::mesh::MAX_VERTICES;
use crate::Mesh;
use std::io::Write;

/// Fewest bytes a vertex line can take (`0 0 0\n`) and a triangle line
/// (`3 0 1 2\n`): used to refuse impossible counts before allocating.
const MIN_VERTEX_BYTES: u128 = 6;
const MIN_FACE_BYTES: u128 = 8;

/// Parses an OFF file held in memory: the header and its counts, then the
/// vertices, then the faces.
pub(crate) fn read(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let mut lines = Lines::new(bytes);
    let (nv, nf) = header(&mut lines, name)?;
    let positions = vertices(&mut lines, name, nv)?;
    let mut triangles = Triangles::with_capacity(nf as usize);
    let mut corners = Vec::with_capacity(8);
    for k in 0..nf {
        let (number, mut rest) = next_content(&mut lines).ok_or_else(|| {
            line_error(name, lines.line(), format!("the file ends after {k} of {nf} faces"))
        })?;
        read_face(&mut rest, nv, &mut corners).map_err(|msg| line_error(name, number, msg))?;
        triangles.push(&corners);
    }
    let mut notes: Vec<String> = triangles.note().into_iter().collect();
    if let Some((number, _)) = next_content(&mut lines) {
        notes.push(format!(
            "data after the {nv} vertices and {nf} faces the header declares (from line \
             {number}) was ignored"
        ));
    }
    finish(name, positions, triangles.faces, VertexAttributes::default(), notes)
}

/// The keyword line and the vertex and face counts, checked against the bytes
/// that follow before anything is allocated.
fn header(lines: &mut Lines<'_>, name: &str) -> Result<(u64, u64), MeshError> {
    let Some((number, mut rest)) = next_content(lines) else {
        return Err(line_error(name, 1, "empty file: expected the OFF header"));
    };
    let line = rest;
    let token = next_token(&mut rest).unwrap_or_default();
    // ModelNet's OFF files join the keyword and the vertex count on their
    // first line ("OFF490 518 0"): the digits start the counts.
    let joined = token
        .windows(3)
        .position(|w| w == b"OFF")
        .map(|at| at + 3)
        .filter(|&end| token.get(end).is_some_and(u8::is_ascii_digit));
    let keyword = joined.map_or(token, |end| &token[..end]);
    check_keyword(keyword).map_err(|msg| line_error(name, number, msg))?;
    if let Some(end) = joined {
        // (`token` is a slice of `line`: its offset there, then past the keyword.)
        rest = &line[token.as_ptr() as usize - line.as_ptr() as usize + end..];
    }
    let mut peek = rest;
    if next_token(&mut peek).is_some_and(|t| t.eq_ignore_ascii_case(b"BINARY")) {
        return Err(line_error(
            name,
            number,
            "binary OFF is not supported; convert it to ascii OFF or PLY",
        ));
    }
    // The counts may follow the keyword on the same line.
    let after = text::skip_space(rest);
    let (number, mut counts) = if after.is_empty() || after.starts_with(b"#") {
        next_content(lines).ok_or_else(|| {
            line_error(name, number, "the file ends before the vertex and face counts")
        })?
    } else {
        (number, rest)
    };
    let mut count = |what: &str| {
        let token = next_token(&mut counts);
        token.and_then(text::parse_u64).ok_or_else(|| {
            line_error(
                name,
                number,
                format!("expected the {what} count, found {}", text::show(token)),
            )
        })
    };
    let nv = count("vertex")?;
    let nf = count("face")?;
    let remaining = lines.remaining().len() as u128;
    if u128::from(nv) * MIN_VERTEX_BYTES + u128::from(nf) * MIN_FACE_BYTES > remaining + 1 {
        let msg = format!(
            "the header announces {nv} vertices and {nf} faces, but only {remaining} bytes follow"
        );
        return Err(line_error(name, number, msg));
    }
    if nv > MAX_VERTICES as u64 {
        return Err(MeshError::TooManyVertices {
            n_vertices: usize::try_from(nv).unwrap_or(usize::MAX),
            max: MAX_VERTICES,
        });
    }
    Ok((nv, nf))
}

/// `nv` vertex lines of three finite coordinates.
fn vertices(lines: &mut Lines<'_>, name: &str, nv: u64) -> Result<Vec<[f64; 3]>, MeshError> {
    // Safe now: both counts are bounded by the file size.
    let mut positions = Vec::with_capacity(nv as usize);
    for k in 0..nv {
        let (number, mut rest) = next_content(lines).ok_or_else(|| {
            line_error(name, lines.line(), format!("the file ends after {k} of {nv} vertices"))
        })?;
        let mut p = [0.0; 3];
        for (axis, slot) in p.iter_mut().enumerate() {
            let value = take_float::<f64>(&mut rest).ok_or_else(|| {
                let found = text::show_next(rest);
                line_error(
                    name,
                    number,
                    format!("vertex needs 3 numbers; coordinate {} is {found}", axis + 1),
                )
            })?;
            if !value.is_finite() {
                return Err(line_error(
                    name,
                    number,
                    format!("vertex coordinate {value} is not finite"),
                ));
            }
            *slot = value;
        }
        positions.push(p);
    }
    Ok(positions)
}

/// Accepts `OFF` with any of the prefixes `ST`, `C`, `N` (in that order).
fn check_keyword(keyword: &[u8]) -> Result<(), String> {
    let found = text::show(Some(keyword));
    let Some(prefix) = keyword.strip_suffix(b"OFF") else {
        return Err(format!("not an OFF file: the first line starts with {found}, expected OFF"));
    };
    if prefix.contains(&b'4') || prefix.contains(&b'n') {
        return Err(format!("{found} (OFF of other than 3 dimensions) is not supported"));
    }
    let rest = prefix.strip_prefix(b"ST").unwrap_or(prefix);
    let rest = rest.strip_prefix(b"C").unwrap_or(rest);
    let rest = rest.strip_prefix(b"N").unwrap_or(rest);
    if rest.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "unknown OFF variant {found}; expected OFF, COFF, NOFF, STOFF or a combination"
        ))
    }
}

/// Reads `n i1 ... in` into `corners`; anything after the indices (a colour) is ignored.
#[inline]
fn read_face(rest: &mut &[u8], nv: u64, corners: &mut Vec<u32>) -> Result<(), String> {
    corners.clear();
    let token = next_token(rest);
    let n = token.and_then(text::parse_u64).ok_or_else(|| {
        format!("a face starts with its number of vertices, found {}", text::show(token))
    })?;
    if n < 3 {
        return Err(format!("a face needs at least 3 vertices, this one has {n}"));
    }
    if n > MAX_POLYGON_CORNERS as u64 {
        return Err(polygon_too_large(n));
    }
    for _ in 0..n {
        let token = next_token(rest);
        let index = token
            .and_then(text::parse_u64)
            .ok_or_else(|| format!("expected {n} vertex indices, found {}", text::show(token)))?;
        if index >= nv {
            return Err(format!(
                "vertex index {index} is out of range: the file has {nv} vertices"
            ));
        }
        // nv <= MAX_VERTICES (checked at the header), so the index fits.
        corners.push(index as u32);
    }
    Ok(())
}

/// The next line that is neither blank nor a comment.
#[inline]
fn next_content<'a>(lines: &mut Lines<'a>) -> Option<(u64, &'a [u8])> {
    lines.find(|(_, line)| {
        let line = text::skip_space(line);
        !line.is_empty() && !line.starts_with(b"#")
    })
}

/// Writes `OFF`, the counts, one `x y z` line per vertex (round-trip precision)
/// and one `3 a b c` line per triangle.
pub(crate) fn write<W: Write>(out: &mut W, mesh: &Mesh) -> std::io::Result<()> {
    writeln!(out, "OFF\n{} {} 0", mesh.n_vertices(), mesh.n_faces())?;
    for p in mesh.positions() {
        text::write_f64(out, p[0])?;
        out.write_all(b" ")?;
        text::write_f64(out, p[1])?;
        out.write_all(b" ")?;
        text::write_f64(out, p[2])?;
        out.write_all(b"\n")?;
    }
    for [a, b, c] in mesh.faces() {
        writeln!(out, "3 {a} {b} {c}")?;
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
        read_bytes(text.as_bytes(), FileFormat::Off, "test.off")
    }

    #[test]
    fn reads_a_commented_file_with_a_quad_and_face_colours() {
        let text = "OFF\n# a pyramid\n\n5 5 8\n0 0 0\n1 0 0\n1 1 0\n0 1 0   # corner\n0.5 0.5 1\n\
                    4 0 3 2 1 255 0 0\n3 0 1 4\n3 1 2 4 0.5 0.5 0.5 1\n3 2 3 4\n3 3 0 4\n";
        let loaded = parse(text).unwrap();
        assert_eq!(loaded.mesh.n_vertices(), 5);
        assert_eq!(loaded.mesh.positions()[4], [0.5, 0.5, 1.0]);
        assert_eq!(
            loaded.mesh.faces(),
            &[[0, 3, 2], [0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]]
        );
        assert_eq!(
            loaded.notes,
            vec!["1 polygons with more than 3 vertices were fan-triangulated into 2 triangles"
                .to_string()]
        );
    }

    #[test]
    fn accepts_variants_and_counts_on_the_header_line() {
        let coff = "COFF 3 1 0\r\n0 0 0 255 0 0 255\r\n1 0 0 0 255 0 255\r\n0 1 0 0 0 255 255\r\n3 0 1 2\r\n";
        assert_eq!(parse(coff).unwrap().mesh.faces(), &[[0, 1, 2]]);
        let stnoff = "STCNOFF\n3 1\n0 0 0 0 0 1 1 1 1 1 0.5 0.5\n1 0 0 0 0 1 1 1 1 1 0 0\n\
                      0 1 0 0 0 1 1 1 1 1 1 1\n3 0 1 2\n";
        assert_eq!(parse(stnoff).unwrap().mesh.positions()[1], [1.0, 0.0, 0.0]);
        // ModelNet's joined first line; the keyword still has to be OFF's.
        let joined = "OFF3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(parse(joined).unwrap().mesh.faces(), &[[0, 1, 2]]);
        assert_eq!(parse(&joined.replacen("OFF3", "COFF3", 1)).unwrap().mesh.n_faces(), 1);
        for bad in ["XOFF3 1 0", "OFF3x 1 0", "OFF3"] {
            let text = joined.replacen("OFF3 1 0", bad, 1);
            assert!(parse(&text).is_err(), "{bad}");
        }
    }

    #[test]
    fn malformed_files_are_reported_by_line() {
        let good = "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n# end\n";
        assert!(parse(good).is_ok());
        let cases = [
            ("OFF", "PLY", 1),
            ("OFF", "4OFF", 1),
            ("OFF", "OFF BINARY", 1),
            ("3 1 0", "3 x 0", 2),
            ("1 0 0\n", "1 0 a\n", 4),
            ("1 0 0\n", "1 0 nan\n", 4),
            ("3 0 1 2", "2 0 1 2", 6),
            ("3 0 1 2", "3 0 1 3", 6),
            ("3 0 1 2", "3 0 1 -1", 6),
            ("3 0 1 2", "4 0 1 2", 6),
            ("3 0 1 2", "", 7),
        ];
        for (from, to, line) in cases {
            let text = good.replacen(from, to, 1);
            assert_eq!(location(parse(&text)), Location::Line(line), "{text:?}");
        }
    }

    #[test]
    fn absurd_counts_fail_before_allocating() {
        let start = std::time::Instant::now();
        let text = "OFF\n1000000000000 2000000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(location(parse(text)), Location::Line(2));
        let text = "OFF\n3 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(location(parse(text)), Location::Line(2));
        assert!(start.elapsed().as_secs_f64() < 0.5);
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let mesh = awkward_tetra();
        let attrs = VertexAttributes::default();
        let bytes =
            write_bytes(&mesh, &attrs, FileFormat::Off, &WriteOptions::default(), "t").unwrap();
        let loaded = read_bytes(&bytes, FileFormat::Off, "t").unwrap();
        assert_eq!(bits(loaded.mesh.positions()), bits(mesh.positions()));
        assert_eq!(loaded.mesh.faces(), mesh.faces());
        assert!(loaded.notes.is_empty());
    }
}
