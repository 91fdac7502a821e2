//! The PLY header: elements, their typed properties, and which of those
//! properties spherify reads ([`Role`]). Element counts are checked against the
//! bytes that follow before anything is allocated.

use crate::error::MeshError;
use crate::io::text::{self, Lines};
use crate::io::{byte_error, line_error, PlyEncoding};

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    pub(super) fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// What spherify does with a property's values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Role {
    Ignore,
    /// Slot in the per-vertex value array: 0..3 position, 3..6 sphere, 6..8 uv.
    Value(usize),
    /// The face element's vertex index list.
    Indices,
}

#[derive(Debug, Clone, Copy)]
pub(super) enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
pub(super) struct Property {
    pub(super) kind: Kind,
    pub(super) name: String,
    pub(super) role: Role,
}

#[derive(Debug)]
pub(super) struct Element {
    pub(super) name: String,
    pub(super) count: u64,
    pub(super) props: Vec<Property>,
    pub(super) line: u64,
}

pub(super) struct Header {
    pub(super) encoding: PlyEncoding,
    pub(super) elements: Vec<Element>,
    pub(super) body_start: usize,
    pub(super) body_line: u64,
}

/// Which optional vertex attributes the file has.
#[derive(Debug, Default, Clone, Copy)]
pub(super) struct Layout {
    pub(super) sphere: bool,
    pub(super) uv: bool,
}

pub(super) fn parse_header(bytes: &[u8], name: &str) -> Result<Header, MeshError> {
    let mut lines = Lines::new(bytes);
    if !matches!(lines.next(), Some((_, l)) if text::trim_end(l) == b"ply") {
        return Err(line_error(name, 1, "not a PLY file: the first line must be 'ply'"));
    }
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some((number, line)) = lines.next() else {
            return Err(line_error(name, lines.line(), "the header has no end_header line"));
        };
        let err = |msg: String| line_error(name, number, msg);
        let mut rest = line;
        let keyword = text::next_token(&mut rest);
        let mut next = || text::next_token(&mut rest);
        match keyword {
            None | Some(b"comment") | Some(b"obj_info") => {}
            Some(b"format") => {
                let token = next();
                let known = token.and_then(|t| std::str::from_utf8(t).ok()?.parse().ok());
                encoding = Some(
                    known
                        .ok_or_else(|| err(format!("unknown PLY format {}", text::show(token))))?,
                );
                match next() {
                    Some(b"1.0") | Some(b"1") => {}
                    other => {
                        return Err(err(format!("unsupported PLY version {}", text::show(other))))
                    }
                }
            }
            Some(b"element") => {
                let element_name = next().ok_or_else(|| err("element needs a name".into()))?;
                let token = next();
                let count = token.and_then(text::parse_u64).ok_or_else(|| {
                    err(format!(
                        "element count must be a non-negative integer, found {}",
                        text::show(token)
                    ))
                })?;
                let name = String::from_utf8_lossy(element_name).into_owned();
                elements.push(Element { name, count, props: Vec::new(), line: number });
            }
            Some(b"property") => {
                let element =
                    elements.last_mut().ok_or_else(|| err("property before any element".into()))?;
                let scalar = |token: Option<&[u8]>| {
                    token
                        .and_then(Scalar::from_name)
                        .ok_or_else(|| err(format!("unknown property type {}", text::show(token))))
                };
                let first = next();
                let kind = if first == Some(b"list") {
                    let count = scalar(next())?;
                    let item = scalar(next())?;
                    if !count.is_integer() {
                        return Err(err("a list's count type must be an integer type".into()));
                    }
                    Kind::List { count, item }
                } else {
                    Kind::Scalar(scalar(first)?)
                };
                let prop_name = next().ok_or_else(|| err("property needs a name".into()))?;
                let name = String::from_utf8_lossy(prop_name).into_owned();
                element.props.push(Property { kind, name, role: Role::Ignore });
            }
            Some(b"end_header") => break,
            Some(other) => {
                return Err(err(format!(
                    "unknown header line starting with {}",
                    text::show(Some(other))
                )))
            }
        }
    }
    let encoding = encoding.ok_or_else(|| line_error(name, 2, "the header has no format line"))?;
    let body_start = bytes.len() - lines.remaining().len();
    Ok(Header { encoding, elements, body_start, body_line: lines.line() + 1 })
}

/// Marks the properties spherify reads; returns the vertex and face counts and
/// which of sphere / uv are present.
pub(super) fn assign_roles(
    header: &mut Header,
    name: &str,
) -> Result<(u64, u64, Layout), MeshError> {
    let mut layout = Layout::default();
    let mut nv = None;
    let mut nf = None;
    for element in &mut header.elements {
        let err = |msg: String| line_error(name, element.line, msg);
        match element.name.as_str() {
            "vertex" if nv.is_none() => {
                nv = Some(element.count);
                let props = &mut element.props;
                for (slot, axis) in ["x", "y", "z"].into_iter().enumerate() {
                    if !set_role(props, axis, slot) {
                        return Err(err(format!(
                            "the vertex element has no scalar property '{axis}'"
                        )));
                    }
                }
                let sphere = ["sphere_x", "sphere_y", "sphere_z"];
                if sphere.iter().all(|n| has_scalar(props, n)) {
                    layout.sphere =
                        sphere.into_iter().enumerate().all(|(k, n)| set_role(props, n, 3 + k));
                }
                let pairs = [
                    ["u", "v"],
                    ["s", "t"],
                    ["texture_u", "texture_v"],
                    ["texture_s", "texture_t"],
                ];
                if let Some([u, v]) =
                    pairs.into_iter().find(|pair| pair.iter().all(|n| has_scalar(props, n)))
                {
                    layout.uv = set_role(props, u, 6) && set_role(props, v, 7);
                }
            }
            "face" if nf.is_none() => {
                nf = Some(element.count);
                let list = element.props.iter_mut().find(|p| {
                    (p.name == "vertex_indices" || p.name == "vertex_index")
                        && matches!(p.kind, Kind::List { .. })
                });
                let Some(list) = list else {
                    return Err(err(
                        "the face element has no list property 'vertex_indices'".into()
                    ));
                };
                if let Kind::List { item, .. } = list.kind {
                    if !item.is_integer() {
                        return Err(err("vertex indices must have an integer type".into()));
                    }
                }
                list.role = Role::Indices;
            }
            "vertex" | "face" => {
                return Err(err(format!("a second '{}' element is not supported", element.name)));
            }
            _ => {}
        }
    }
    let nv = nv.ok_or_else(|| line_error(name, 1, "the header declares no 'vertex' element"))?;
    let nf = nf.ok_or_else(|| {
        line_error(name, 1, "the header declares no 'face' element (point clouds and triangle strips are not supported)")
    })?;
    Ok((nv, nf, layout))
}

fn has_scalar(props: &[Property], name: &str) -> bool {
    props.iter().any(|p| p.name == name && matches!(p.kind, Kind::Scalar(_)))
}

/// Gives the scalar property `name` the value slot `slot`; false if there is none.
fn set_role(props: &mut [Property], name: &str, slot: usize) -> bool {
    match props.iter_mut().find(|p| p.name == name && matches!(p.kind, Kind::Scalar(_))) {
        Some(p) => {
            p.role = Role::Value(slot);
            true
        }
        None => false,
    }
}

/// Refuses element counts that the rest of the file cannot hold, before anything is
/// allocated: each element needs at least its fixed-size fields (binary) or one
/// token plus a separator per property (ascii).
pub(super) fn check_counts(header: &Header, file_len: usize, name: &str) -> Result<(), MeshError> {
    let available = (file_len - header.body_start.min(file_len)) as u128;
    let mut needed: u128 = 0;
    for element in &header.elements {
        let per_item: u128 = match header.encoding {
            PlyEncoding::Ascii => 2 * element.props.len() as u128,
            _ => element
                .props
                .iter()
                .map(|p| match p.kind {
                    Kind::Scalar(t) => t.size() as u128,
                    Kind::List { count, .. } => count.size() as u128,
                })
                .sum(),
        };
        let before = needed;
        needed += per_item * u128::from(element.count);
        let slack = u128::from(header.encoding == PlyEncoding::Ascii);
        if needed > available + slack {
            let msg = format!(
                "the header announces {} '{}' elements, but the {available} bytes after the header \
                 cannot hold them",
                element.count, element.name
            );
            return Err(match header.encoding {
                PlyEncoding::Ascii => line_error(name, element.line, msg),
                _ => {
                    // Where the data runs out, exact when the elements before are
                    // fixed-size (the usual truncated file); per_item > 0 here.
                    let k = (available - before.min(available)) / per_item.max(1);
                    let at = header.body_start as u128 + before + k * per_item;
                    let msg = format!("the file ends inside '{}' element {k}: {msg}", element.name);
                    byte_error(name, usize::try_from(at).unwrap_or(file_len), msg)
                }
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::super::fixtures::{assert_fails_at_lines, parse, ASCII_TRI};
    use crate::error::{Location, MeshError};
    use crate::io::tests::location;

    #[test]
    fn reads_uv_under_its_other_names() {
        for (u, v) in
            [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")]
        {
            let text = format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty float {v}\nproperty float x\n\
                 property float y\nproperty float z\nproperty float {u}\nelement face 1\n\
                 property list uchar uint vertex_indices\nend_header\n\
                 0.5 0 0 0 0.25\n0 1 0 0 1\n1 0 1 0 0\n3 0 1 2\n"
            );
            let loaded = parse(text.as_bytes()).unwrap();
            assert_eq!(loaded.attributes.uv, Some(vec![[0.25, 0.5], [1.0, 0.0], [0.0, 1.0]]));
            assert_eq!(loaded.attributes.sphere, None);
        }
    }

    #[test]
    fn malformed_headers_are_reported_by_line() {
        assert_fails_at_lines(&[
            ("ply\n", "plx\n", 1),
            ("format ascii 1.0", "format ascii 2.0", 2),
            ("format ascii 1.0", "format text 1.0", 2),
            ("element vertex 3", "element vertex -3", 3),
            ("property float y", "property quad y", 5),
            ("property float z", "propertyz float z", 6),
            ("property float z", "property float w", 3),
            ("list uchar int vertex_indices", "list uchar int corners", 7),
            ("list uchar int", "list float int", 8),
            ("end_header\n", "end_headr\n", 9),
        ]);
        let no_end = ASCII_TRI.split("end_header").next().unwrap_or_default();
        assert_eq!(location(parse(no_end.as_bytes())), Location::Line(8));
    }

    #[test]
    fn absurd_counts_fail_fast_without_allocating() {
        let start = std::time::Instant::now();
        for format in ["ascii", "binary_little_endian"] {
            for (nv, nf) in
                [("1000000000000", "1"), ("3", "1000000000000"), ("18446744073709551615", "1")]
            {
                let text = ASCII_TRI
                    .replace("ascii", format)
                    .replace("vertex 3", &format!("vertex {nv}"))
                    .replace("face 1", &format!("face {nf}"));
                assert!(
                    matches!(parse(text.as_bytes()), Err(MeshError::Format(_))),
                    "{format} {nv} {nf}"
                );
            }
        }
        // An element without properties takes no bytes: its count must not be looped over.
        let empty =
            ASCII_TRI.replace("element face", "element nothing 1000000000000000\nelement face");
        assert!(parse(empty.as_bytes()).is_ok());
        assert!(start.elapsed().as_secs_f64() < 0.5);
    }
}
