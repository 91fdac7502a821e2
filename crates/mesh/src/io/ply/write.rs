//! The PLY writer: one header layout, ascii or binary in either byte order.

use crate::io::text;
use crate::io::{PlyEncoding, VertexAttributes};
use crate::Mesh;
use std::io::Write;

/// Writes a PLY file: doubles for `x y z`, then `sphere_x sphere_y sphere_z` and
/// `u v` when given, and faces as `list uchar int vertex_indices` (`uint` past 2^31
/// vertices).
pub(crate) fn write<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    attributes: &VertexAttributes,
    encoding: PlyEncoding,
) -> std::io::Result<()> {
    let format = encoding.as_str();
    let sphere = attributes.sphere.as_deref();
    let uv = attributes.uv.as_deref();
    let index_type = if mesh.n_vertices() > i32::MAX as usize { "uint" } else { "int" };
    let mut header = format!("ply\nformat {format} 1.0\ncomment written by spherify\n");
    header += &format!(
        "element vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        mesh.n_vertices()
    );
    if sphere.is_some() {
        header += "property double sphere_x\nproperty double sphere_y\nproperty double sphere_z\n";
    }
    if uv.is_some() {
        header += "property double u\nproperty double v\n";
    }
    header += &format!(
        "element face {}\nproperty list uchar {index_type} vertex_indices\nend_header\n",
        mesh.n_faces()
    );
    out.write_all(header.as_bytes())?;
    let big = encoding == PlyEncoding::BinaryBigEndian;
    let mut row: Vec<f64> = Vec::with_capacity(8);
    for (v, p) in mesh.positions().iter().enumerate() {
        row.clear();
        row.extend_from_slice(p);
        row.extend(sphere.and_then(|s| s.get(v)).into_iter().flatten());
        row.extend(uv.and_then(|t| t.get(v)).into_iter().flatten());
        if encoding == PlyEncoding::Ascii {
            for (k, &x) in row.iter().enumerate() {
                out.write_all(if k == 0 { b"" } else { b" " })?;
                text::write_f64(out, x)?;
            }
            out.write_all(b"\n")?;
        } else {
            for &x in &row {
                out.write_all(&if big { x.to_be_bytes() } else { x.to_le_bytes() })?;
            }
        }
    }
    for face in mesh.faces() {
        if encoding == PlyEncoding::Ascii {
            writeln!(out, "3 {} {} {}", face[0], face[1], face[2])?;
        } else {
            out.write_all(&[3u8])?;
            for &i in face {
                out.write_all(&if big { i.to_be_bytes() } else { i.to_le_bytes() })?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::parse;
    use crate::io::tests::{awkward_tetra, bits};
    use crate::io::{write_bytes, FileFormat, PlyEncoding, VertexAttributes, WriteOptions};

    #[test]
    fn round_trip_is_bit_exact_in_every_encoding() {
        let mesh = awkward_tetra();
        let sphere: Vec<[f64; 3]> =
            vec![[0.0, 0.0, 1.0], [0.6, 0.8, -0.0], [1.0 / 3.0, 0.1, 0.2], [-1.0, 0.0, 0.0]];
        let uv = vec![[0.1, 0.2], [1.0 / 3.0, -0.0], [5e-324, 1e300], [0.5, 0.5]];
        for encoding in
            [PlyEncoding::Ascii, PlyEncoding::BinaryLittleEndian, PlyEncoding::BinaryBigEndian]
        {
            for (s, t) in [
                (None, None),
                (Some(sphere.clone()), None),
                (Some(sphere.clone()), Some(uv.clone())),
            ] {
                let attrs = VertexAttributes { sphere: s, uv: t };
                let options = WriteOptions { ply_encoding: encoding, ..WriteOptions::default() };
                let bytes = write_bytes(&mesh, &attrs, FileFormat::Ply, &options, "t").unwrap();
                let loaded = parse(&bytes).unwrap();
                assert_eq!(bits(loaded.mesh.positions()), bits(mesh.positions()), "{encoding:?}");
                assert_eq!(loaded.mesh.faces(), mesh.faces());
                assert_eq!(
                    loaded.attributes.sphere.as_deref().map(bits),
                    attrs.sphere.as_deref().map(bits)
                );
                let uv_bits =
                    |t: &[[f64; 2]]| t.iter().map(|p| p.map(f64::to_bits)).collect::<Vec<_>>();
                assert_eq!(
                    loaded.attributes.uv.as_deref().map(uv_bits),
                    attrs.uv.as_deref().map(uv_bits)
                );
                assert!(loaded.notes.is_empty());
            }
        }
    }
}
