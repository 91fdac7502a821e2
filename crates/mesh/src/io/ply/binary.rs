//! The binary PLY body, either byte order. Elements of scalars only are read
//! at a fixed stride, and the usual face element (`list uchar int|uint`) as
//! 13-byte triangle records; anything else takes the general per-property
//! path. Every error gives the byte offset of the element it is in.

use super::header::{Element, Header, Kind, Property, Role, Scalar};
use super::sink::Sink;
use crate::error::MeshError;
use crate::io::byte_error;

/// Reads `N` bytes at `pos`, if the file has them.
#[inline]
fn take<const N: usize>(data: &[u8], pos: usize) -> Option<[u8; N]> {
    data.get(pos..pos.checked_add(N)?)?.try_into().ok()
}

macro_rules! endian {
    ($t:ty, $bytes:expr, $big:expr) => {
        if $big {
            <$t>::from_be_bytes($bytes)
        } else {
            <$t>::from_le_bytes($bytes)
        }
    };
}

/// One binary scalar at `pos` as f64 (exact for every PLY type).
#[inline]
fn f64_at(t: Scalar, data: &[u8], pos: usize, big: bool) -> Option<f64> {
    Some(match t {
        Scalar::F32 => f64::from(endian!(f32, take::<4>(data, pos)?, big)),
        Scalar::F64 => endian!(f64, take::<8>(data, pos)?, big),
        _ => i64_at(t, data, pos, big)? as f64,
    })
}

/// One binary integer at `pos` (floats are truncated; the header only lets
/// integer types reach here).
#[inline]
fn i64_at(t: Scalar, data: &[u8], pos: usize, big: bool) -> Option<i64> {
    Some(match t {
        Scalar::I8 => i64::from(take::<1>(data, pos)?[0] as i8),
        Scalar::U8 => i64::from(take::<1>(data, pos)?[0]),
        Scalar::I16 => i64::from(endian!(i16, take::<2>(data, pos)?, big)),
        Scalar::U16 => i64::from(endian!(u16, take::<2>(data, pos)?, big)),
        Scalar::I32 => i64::from(endian!(i32, take::<4>(data, pos)?, big)),
        Scalar::U32 => i64::from(endian!(u32, take::<4>(data, pos)?, big)),
        // Not through `f64_at`: mutual recursion would stop both from inlining.
        Scalar::F32 => endian!(f32, take::<4>(data, pos)?, big) as i64,
        Scalar::F64 => endian!(f64, take::<8>(data, pos)?, big) as i64,
    })
}

/// Reads every element of the body; `big` for big endian.
pub(super) fn read_body(
    header: &Header,
    bytes: &[u8],
    big: bool,
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    let mut pos = header.body_start;
    for element in &header.elements {
        read_element(element, bytes, &mut pos, big, out, name)?;
    }
    if pos < bytes.len() {
        out.notes.push(format!(
            "{} bytes after the elements the header declares (from byte {pos}) were ignored",
            bytes.len() - pos
        ));
    }
    Ok(())
}

/// Reads the records of `element` starting at `pos` and moves `pos` past them.
fn read_element(
    element: &Element,
    data: &[u8],
    pos: &mut usize,
    big: bool,
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    if element.props.is_empty() {
        // Takes no bytes, however large its count: do not loop over it.
        return Ok(());
    }
    if let [Property { kind: Kind::List { count: Scalar::U8, item }, role: Role::Indices, .. }] =
        element.props[..]
    {
        if matches!(item, Scalar::I32 | Scalar::U32) {
            return triangle_element(element, data, pos, big, item, out, name);
        }
    }
    let fixed = element.props.iter().all(|p| matches!(p.kind, Kind::Scalar(_)));
    let is_vertex = element.props.iter().any(|p| matches!(p.role, Role::Value(_)));
    if fixed {
        return fixed_element(element, data, pos, big, is_vertex.then_some(out), name);
    }
    let truncated = |k: u64, at: usize| truncated(element, k, at, name);
    let mut values = [0.0f64; 8];
    for k in 0..element.count {
        let start = *pos;
        let mut p = start;
        for prop in &element.props {
            match (prop.kind, prop.role) {
                (Kind::Scalar(t), Role::Value(slot)) => {
                    values[slot] = f64_at(t, data, p, big).ok_or_else(|| truncated(k, start))?;
                    p += t.size();
                }
                (Kind::Scalar(t), _) => p += t.size(),
                (Kind::List { count, item }, role) => {
                    let n = i64_at(count, data, p, big).ok_or_else(|| truncated(k, start))?;
                    p += count.size();
                    let n = usize::try_from(n).map_err(|_| {
                        byte_error(name, start, format!("negative list length {n}"))
                    })?;
                    let end = n.checked_mul(item.size()).and_then(|len| p.checked_add(len));
                    let end =
                        end.filter(|&e| e <= data.len()).ok_or_else(|| truncated(k, start))?;
                    if role == Role::Indices {
                        for j in 0..n {
                            let index = i64_at(item, data, p + j * item.size(), big)
                                .ok_or_else(|| truncated(k, start))?;
                            out.corner(index).map_err(|msg| byte_error(name, start, msg))?;
                        }
                        out.end_face().map_err(|msg| byte_error(name, start, msg))?;
                    }
                    p = end;
                }
            }
        }
        if p > data.len() {
            return Err(truncated(k, start));
        }
        if is_vertex {
            out.vertex(&values).map_err(|bad| {
                byte_error(name, start, format!("vertex coordinate {bad} is not finite"))
            })?;
        }
        *pos = p;
    }
    Ok(())
}

/// The file ended inside element `k`, which starts at byte `at`.
fn truncated(element: &Element, k: u64, at: usize, name: &str) -> MeshError {
    let msg = format!("the file ends inside '{}' element {k} of {}", element.name, element.count);
    byte_error(name, at, msg)
}

/// Fast path for an element of scalars only (fixed stride). The vertex element
/// (`vertices` is the sink) reads just the properties with a role, at precomputed
/// offsets; any other is skipped in one step.
fn fixed_element(
    element: &Element,
    data: &[u8],
    pos: &mut usize,
    big: bool,
    vertices: Option<&mut Sink>,
    name: &str,
) -> Result<(), MeshError> {
    let mut wanted = Vec::with_capacity(8);
    let mut stride = 0;
    for prop in &element.props {
        if let Kind::Scalar(t) = prop.kind {
            if let Role::Value(slot) = prop.role {
                wanted.push((stride, t, slot));
            }
            stride += t.size();
        }
    }
    let available = data.len().saturating_sub(*pos) / stride.max(1);
    if (available as u64) < element.count {
        return Err(truncated(element, available as u64, *pos + available * stride, name));
    }
    // count <= available, so this fits in usize and inside `data`.
    let end = *pos + element.count as usize * stride;
    let Some(out) = vertices else {
        *pos = end;
        return Ok(());
    };
    let mut values = [0.0f64; 8];
    for (k, record) in data.get(*pos..end).unwrap_or_default().chunks_exact(stride).enumerate() {
        for &(offset, t, slot) in &wanted {
            values[slot] = f64_at(t, record, offset, big).unwrap_or(f64::NAN);
        }
        out.vertex(&values).map_err(|bad| {
            byte_error(name, *pos + k * stride, format!("vertex coordinate {bad} is not finite"))
        })?;
    }
    *pos = end;
    Ok(())
}

/// Fast path for the usual face element, `list uchar int|uint vertex_indices` and
/// nothing else: triangles are read as one 13-byte record.
fn triangle_element(
    element: &Element,
    data: &[u8],
    pos: &mut usize,
    big: bool,
    item: Scalar,
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    let signed = item == Scalar::I32;
    let nv = out.nv;
    for k in 0..element.count {
        let start = *pos;
        let n = *data.get(start).ok_or_else(|| truncated(element, k, start, name))? as usize;
        let indices = data
            .get(start + 1..start + 1 + 4 * n)
            .ok_or_else(|| truncated(element, k, start, name))?;
        if let Some(&[a, b, c]) = (n == 3).then(|| triangle(indices, big)).as_ref() {
            let ok = |i: u32| u64::from(i) < nv && !(signed && i > i32::MAX as u32);
            if ok(a) && ok(b) && ok(c) {
                out.triangles.faces.push([a, b, c]);
                *pos = start + 13;
                continue;
            }
        }
        // Polygons and bad indices take the general path, which also words the error.
        for j in 0..n {
            let index = i64_at(item, indices, 4 * j, big).unwrap_or(-1);
            out.corner(index).map_err(|msg| byte_error(name, start, msg))?;
        }
        out.end_face().map_err(|msg| byte_error(name, start, msg))?;
        *pos = start + 1 + 4 * n;
    }
    Ok(())
}

#[inline]
fn triangle(indices: &[u8], big: bool) -> [u32; 3] {
    let word = |j: usize| {
        let bytes = take::<4>(indices, 4 * j).unwrap_or_default();
        endian!(u32, bytes, big)
    };
    [word(0), word(1), word(2)]
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{parse, PYRAMID_FACES, SQUARE_PYRAMID};
    use crate::error::Location;
    use crate::io::tests::{awkward_tetra, location};
    use crate::io::{write_bytes, FileFormat, PlyEncoding, VertexAttributes, WriteOptions};

    /// Appends `x` encoded as the PLY type `ty`.
    fn put(out: &mut Vec<u8>, ty: &str, x: f64, big: bool) {
        macro_rules! enc {
            ($t:ty) => {{
                let v = x as $t;
                out.extend_from_slice(&if big { v.to_be_bytes() } else { v.to_le_bytes() })
            }};
        }
        match ty {
            "char" | "int8" => enc!(i8),
            "uchar" | "uint8" => enc!(u8),
            "short" | "int16" => enc!(i16),
            "ushort" | "uint16" => enc!(u16),
            "int" | "int32" => enc!(i32),
            "uint" | "uint32" => enc!(u32),
            "float" | "float32" => enc!(f32),
            "double" | "float64" => enc!(f64),
            _ => panic!("unknown type {ty}"),
        }
    }

    /// A binary pyramid with shuffled vertex properties, a face scalar before the
    /// index list, and an extra element with lists between vertices and faces.
    fn shuffled_binary(big: bool, count_ty: &str, index_ty: &str) -> Vec<u8> {
        let format = if big { "binary_big_endian" } else { "binary_little_endian" };
        let mut out = format!(
            "ply\nformat {format} 1.0\nelement vertex 5\nproperty double z\nproperty float nx\n\
             property list uchar short junk\nproperty float64 x\nproperty uint8 red\nproperty float32 y\n\
             element material 2\nproperty list ushort double values\nproperty int id\n\
             element face 5\nproperty uchar flags\nproperty list {count_ty} {index_ty} vertex_index\n\
             end_header\n"
        )
        .into_bytes();
        for (k, p) in SQUARE_PYRAMID.iter().enumerate() {
            put(&mut out, "double", p[2], big);
            put(&mut out, "float", 0.25, big);
            put(&mut out, "uchar", k as f64, big);
            for j in 0..k {
                put(&mut out, "short", j as f64, big);
            }
            put(&mut out, "double", p[0], big);
            put(&mut out, "uchar", 200.0, big);
            put(&mut out, "float", p[1], big);
        }
        for m in 0..2 {
            put(&mut out, "ushort", 3.0, big);
            for j in 0..3 {
                put(&mut out, "double", f64::from(j * m), big);
            }
            put(&mut out, "int", -1.0, big);
        }
        let polygons: [&[u32]; 5] = [&[0, 3, 2, 1], &[0, 1, 4], &[1, 2, 4], &[2, 3, 4], &[3, 0, 4]];
        for polygon in polygons {
            put(&mut out, "uchar", 1.0, big);
            put(&mut out, count_ty, polygon.len() as f64, big);
            for &i in polygon {
                put(&mut out, index_ty, f64::from(i), big);
            }
        }
        out
    }

    #[test]
    fn reads_binary_of_both_byte_orders_and_any_list_types() {
        for big in [false, true] {
            for count_ty in ["uchar", "ushort", "int", "uint", "uint8", "int16"] {
                for index_ty in ["int", "uint", "ushort", "char", "int32", "uint16"] {
                    let bytes = shuffled_binary(big, count_ty, index_ty);
                    let loaded = parse(&bytes)
                        .unwrap_or_else(|e| panic!("{big} {count_ty} {index_ty}: {e}"));
                    assert_eq!(loaded.mesh.positions(), &SQUARE_PYRAMID);
                    assert_eq!(loaded.mesh.faces(), &PYRAMID_FACES);
                    // The quad's fan and the skipped element before the faces.
                    assert_eq!(loaded.notes.len(), 2, "{:?}", loaded.notes);
                    assert!(loaded.notes[1].starts_with("ignored the 2 records of element"));
                }
            }
        }
    }

    #[test]
    fn binary_errors_give_the_byte_offset() {
        let bytes = shuffled_binary(false, "uchar", "int");
        let header_len = bytes.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
        let vertex_bytes: usize = (0..5).map(|k| 8 + 4 + 1 + 2 * k + 8 + 1 + 4).sum();
        let material_bytes = 2 * (2 + 24 + 4);
        let faces_start = header_len + vertex_bytes + material_bytes;
        // Truncated inside the last face (each face: flags, count, 3 or 4 ints).
        let truncated = &bytes[..bytes.len() - 2];
        assert_eq!(location(parse(truncated)), Location::Byte((bytes.len() - 14) as u64));
        // Second face's last index out of range.
        let mut bad = bytes.clone();
        let second_face = faces_start + 2 + 16;
        bad[second_face + 2 + 8..second_face + 2 + 12].copy_from_slice(&5i32.to_le_bytes());
        assert_eq!(location(parse(&bad)), Location::Byte(second_face as u64));
        // Negative index.
        bad[second_face + 2 + 8..second_face + 2 + 12].copy_from_slice(&(-2i32).to_le_bytes());
        assert_eq!(location(parse(&bad)), Location::Byte(second_face as u64));
        // A NaN coordinate in the first vertex (z is its first property).
        let mut nan = bytes.clone();
        nan[header_len..header_len + 8].copy_from_slice(&f64::NAN.to_le_bytes());
        assert_eq!(location(parse(&nan)), Location::Byte(header_len as u64));
    }

    #[test]
    fn fast_paths_report_errors_like_the_general_one() {
        let mesh = awkward_tetra();
        let attrs = VertexAttributes::default();
        for (encoding, big) in
            [(PlyEncoding::BinaryLittleEndian, false), (PlyEncoding::BinaryBigEndian, true)]
        {
            let options = WriteOptions { ply_encoding: encoding, ..WriteOptions::default() };
            let bytes = write_bytes(&mesh, &attrs, FileFormat::Ply, &options, "t").unwrap();
            let faces_start = bytes.len() - 4 * 13;
            let vertices_start = faces_start - 4 * 24;
            let index = |v: i32| if big { v.to_be_bytes() } else { v.to_le_bytes() };
            let mut bad = bytes.clone();
            bad[faces_start + 13 + 5..faces_start + 13 + 9].copy_from_slice(&index(4));
            assert_eq!(location(parse(&bad)), Location::Byte(faces_start as u64 + 13));
            bad[faces_start + 13 + 5..faces_start + 13 + 9].copy_from_slice(&index(-1));
            assert_eq!(location(parse(&bad)), Location::Byte(faces_start as u64 + 13));
            // Truncated in the last face, then in the third vertex.
            assert_eq!(
                location(parse(&bytes[..bytes.len() - 1])),
                Location::Byte(bytes.len() as u64 - 13)
            );
            assert_eq!(
                location(parse(&bytes[..vertices_start + 60])),
                Location::Byte(vertices_start as u64 + 48)
            );
            let mut nan = bytes.clone();
            let third_y = vertices_start + 2 * 24 + 8;
            let value = if big { f64::INFINITY.to_be_bytes() } else { f64::INFINITY.to_le_bytes() };
            nan[third_y..third_y + 8].copy_from_slice(&value);
            assert_eq!(location(parse(&nan)), Location::Byte(vertices_start as u64 + 48));
            // A quad and a 2-gon in the fast face layout.
            let mut quad = bytes[..faces_start].to_vec();
            quad.extend_from_slice(&[4]);
            for v in [0, 1, 2, 3] {
                quad.extend_from_slice(&index(v));
            }
            quad.extend_from_slice(&[2]);
            quad.extend_from_slice(&index(0));
            quad.extend_from_slice(&index(1));
            quad.extend_from_slice(&[0; 26]);
            assert_eq!(location(parse(&quad)), Location::Byte(faces_start as u64 + 17));
        }
    }
}
