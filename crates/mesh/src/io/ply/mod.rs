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

use super::{LoadedMesh, PlyEncoding};
use crate::error::MeshError;
use crate::mesh::MAX_VERTICES;

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

/// Fixtures shared by the tests of the PLY modules.
#[cfg(test)]
mod fixtures {
    use crate::error::MeshError;
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
}
