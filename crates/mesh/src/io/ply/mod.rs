//! Stanford PLY, ascii and binary (both byte orders).
//!
//! The header is parsed into a list of elements and typed properties; each
//! property that spherify uses gets a role, everything else is skipped by its
//! size (binary) or its token count (ascii), so elements and properties may come
//! in any order and unknown ones (edges, materials, lists) do no harm. Before any
//! allocation the element counts are checked against the bytes that follow: a
//! header announcing 10^12 vertices in a 1 KB file fails at once.
//!
//! * `header`: the header, property roles and the count check;
//! * `binary`, `ascii`: the two body readers, which fill a `sink::Sink`;
//! * `write`: the writer.

mod ascii;
mod binary;
mod header;
mod sink;
mod write;

pub(crate) use write::write;

use super::LoadedMesh;
use crate::error::{MeshError, UnknownName};
use crate::mesh::MAX_VERTICES;
use std::fmt;
use std::str::FromStr;

/// How a PLY file stores its data.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyEncoding {
    /// Human-readable text; large and slow, but easy to inspect.
    Ascii,
    /// Binary, little endian: the compact default.
    #[default]
    BinaryLittleEndian,
    /// Binary, big endian.
    BinaryBigEndian,
}

impl PlyEncoding {
    /// Every encoding, in the order of [`PlyEncoding::NAMES`].
    pub const ALL: [PlyEncoding; 3] =
        [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian, PlyEncoding::BinaryBigEndian];

    /// The names of [`PlyEncoding::ALL`]: the words of the PLY `format` line,
    /// which are also the names the bindings accept.
    pub const NAMES: [&'static str; 3] = ["ascii", "binary_little_endian", "binary_big_endian"];

    /// The name of this encoding, as in the PLY `format` line.
    pub const fn as_str(self) -> &'static str {
        match self {
            PlyEncoding::Ascii => "ascii",
            PlyEncoding::BinaryLittleEndian => "binary_little_endian",
            PlyEncoding::BinaryBigEndian => "binary_big_endian",
        }
    }
}

impl FromStr for PlyEncoding {
    type Err = UnknownName;

    /// One of [`PlyEncoding::NAMES`], exactly.
    fn from_str(name: &str) -> Result<Self, UnknownName> {
        UnknownName::position("PLY encoding", name, &Self::NAMES).map(|k| Self::ALL[k])
    }
}

impl fmt::Display for PlyEncoding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Parses a PLY file held in memory.
pub(crate) fn read(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let mut header = header::parse_header(bytes, name)?;
    let (nv, nf, layout) = header::assign_roles(&mut header, name)?;
    header::check_counts(&header, bytes.len(), name)?;
    if nv > MAX_VERTICES as u64 {
        let n_vertices = usize::try_from(nv).unwrap_or(usize::MAX);
        return Err(MeshError::TooManyVertices { n_vertices, max: MAX_VERTICES });
    }
    let mut out = sink::Sink::new(nv, nf, layout);
    // Other elements (an `edge` list, materials) are valid PLY and skipped:
    // said, since the mesh returned is then not all the file holds.
    for element in header.elements.iter().filter(|e| e.count > 0) {
        if element.name != "vertex" && element.name != "face" {
            out.notes.push(format!(
                "ignored the {} records of element '{}' (header line {}): spherify reads \
                 the vertex and face elements only",
                element.count, element.name, element.line
            ));
        }
    }
    let body = bytes.get(header.body_start..).unwrap_or_default();
    match header.encoding {
        PlyEncoding::Ascii => ascii::read_body(&header, body, &mut out, name)?,
        PlyEncoding::BinaryLittleEndian => {
            binary::read_body(&header, bytes, false, &mut out, name)?
        }
        PlyEncoding::BinaryBigEndian => binary::read_body(&header, bytes, true, &mut out, name)?,
    }
    out.into_mesh(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn other_elements_are_skipped_with_a_note() {
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n\
                    property float y\nproperty float z\nproperty uchar red\nelement face 1\n\
                    property list uchar int vertex_indices\nelement edge 2\nproperty int vertex1\n\
                    property int vertex2\nelement material 0\nproperty uchar red\nend_header\n\
                    0 0 0 9\n1 0 0 9\n0 1 0 9\n3 0 1 2\n0 1\n1 2\n";
        let loaded = read(text.as_bytes(), "t.ply").unwrap();
        assert_eq!(loaded.mesh.faces(), &[[0, 1, 2]]);
        // The empty element and the extra vertex property say nothing.
        assert_eq!(
            loaded.notes,
            vec!["ignored the 2 records of element 'edge' (header line 10): spherify reads \
                  the vertex and face elements only"
                .to_string()]
        );
    }

    #[test]
    fn encoding_names_round_trip() {
        for (encoding, name) in PlyEncoding::ALL.into_iter().zip(PlyEncoding::NAMES) {
            assert_eq!(encoding.as_str(), name);
            assert_eq!(encoding.to_string(), name);
            assert_eq!(name.parse::<PlyEncoding>(), Ok(encoding));
        }
        let err = "binary".parse::<PlyEncoding>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown PLY encoding 'binary'; expected one of: \
             ascii, binary_little_endian, binary_big_endian"
        );
        assert!("ASCII".parse::<PlyEncoding>().is_err());
    }
}

/// Fixtures shared by the tests of the PLY modules.
#[cfg(test)]
mod fixtures {
    use crate::error::{Location, MeshError};
    use crate::io::tests::location;
    use crate::io::{read_bytes, FileFormat, LoadedMesh};

    pub(super) fn parse(bytes: &[u8]) -> Result<LoadedMesh, MeshError> {
        read_bytes(bytes, FileFormat::Ply, "test.ply")
    }

    pub(super) const SQUARE_PYRAMID: [[f64; 3]; 5] =
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];
    pub(super) const PYRAMID_FACES: [[u32; 3]; 6] =
        [[0, 3, 2], [0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];

    /// One triangle, the smallest valid ascii file.
    pub(super) const ASCII_TRI: &str =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
        property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

    /// Checks that [`ASCII_TRI`] with `from` replaced by `to` fails at `line`,
    /// for each `(from, to, line)`.
    pub(super) fn assert_fails_at_lines(cases: &[(&str, &str, u64)]) {
        assert!(parse(ASCII_TRI.as_bytes()).is_ok());
        for &(from, to, line) in cases {
            let text = ASCII_TRI.replacen(from, to, 1);
            assert_eq!(location(parse(text.as_bytes())), Location::Line(line), "{from} -> {to}");
        }
    }
}
