//! Stanford PLY, ascii and binary (both byte orders).
//!
//! The header is parsed into a list of elements and typed properties; each
//! property that spherify uses gets a [`Role`], everything else is skipped by its
//! size (binary) or its token count (ascii), so elements and properties may come
//! in any order and unknown ones (edges, materials, lists) do no harm. Before any
//! allocation the element counts are checked against the bytes that follow: a
//! header announcing 10^12 vertices in a 1 KB file fails at once.

use super::text::{self, Lines};
use super::{byte_error, finish, line_error, LoadedMesh, PlyEncoding, Triangles, VertexAttributes};
use crate::error::MeshError;
use crate::mesh::MAX_VERTICES;
use crate::Mesh;
use std::io::Write;

/// A PLY scalar type.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Scalar {
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

    fn size(self) -> usize {
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
enum Role {
    Ignore,
    /// Slot in the per-vertex value array: 0..3 position, 3..6 sphere, 6..8 uv.
    Value(usize),
    /// The face element's vertex index list.
    Indices,
}

#[derive(Debug, Clone, Copy)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    kind: Kind,
    name: String,
    role: Role,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    props: Vec<Property>,
    line: u64,
}

struct Header {
    encoding: PlyEncoding,
    elements: Vec<Element>,
    body_start: usize,
    body_line: u64,
}

/// Parses a PLY file held in memory.
pub(crate) fn read(bytes: &[u8], name: &str) -> Result<LoadedMesh, MeshError> {
    let mut header = parse_header(bytes, name)?;
    let (nv, nf, layout) = assign_roles(&mut header, name)?;
    check_counts(&header, bytes.len(), name)?;
    if nv > MAX_VERTICES as u64 {
        let n_vertices = usize::try_from(nv).unwrap_or(usize::MAX);
        return Err(MeshError::TooManyVertices { n_vertices, max: MAX_VERTICES });
    }
    let mut out = Sink::new(nv, nf, layout);
    let body = bytes.get(header.body_start..).unwrap_or_default();
    match header.encoding {
        PlyEncoding::Ascii => {
            let mut tokens = Tokens { rest: body, line: header.body_line };
            for element in &header.elements {
                ascii_element(element, &mut tokens, &mut out, name)?;
            }
        }
        PlyEncoding::BinaryLittleEndian | PlyEncoding::BinaryBigEndian => {
            let big = header.encoding == PlyEncoding::BinaryBigEndian;
            let mut pos = header.body_start;
            for element in &header.elements {
                binary_element(element, bytes, &mut pos, big, &mut out, name)?;
            }
        }
    }
    out.into_mesh(name)
}

fn parse_header(bytes: &[u8], name: &str) -> Result<Header, MeshError> {
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
                encoding = Some(match next() {
                    Some(b"ascii") => PlyEncoding::Ascii,
                    Some(b"binary_little_endian") => PlyEncoding::BinaryLittleEndian,
                    Some(b"binary_big_endian") => PlyEncoding::BinaryBigEndian,
                    other => return Err(err(format!("unknown PLY format {}", text::show(other)))),
                });
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
fn assign_roles(header: &mut Header, name: &str) -> Result<(u64, u64, Layout), MeshError> {
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
fn check_counts(header: &Header, file_len: usize, name: &str) -> Result<(), MeshError> {
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

/// Which optional vertex attributes the file has.
#[derive(Debug, Default, Clone, Copy)]
struct Layout {
    sphere: bool,
    uv: bool,
}

/// Where parsed values go.
struct Sink {
    nv: u64,
    layout: Layout,
    positions: Vec<[f64; 3]>,
    sphere: Vec<[f64; 3]>,
    uv: Vec<[f64; 2]>,
    triangles: Triangles,
    corners: Vec<u32>,
}

impl Sink {
    fn new(nv: u64, nf: u64, layout: Layout) -> Self {
        // Both counts were checked against the file size, so these allocations are
        // bounded by it.
        let n = nv as usize;
        Sink {
            nv,
            layout,
            positions: Vec::with_capacity(n),
            sphere: Vec::with_capacity(if layout.sphere { n } else { 0 }),
            uv: Vec::with_capacity(if layout.uv { n } else { 0 }),
            triangles: Triangles::with_capacity(nf as usize),
            corners: Vec::with_capacity(8),
        }
    }

    /// Stores one vertex; returns the offending value if a position is not finite.
    #[inline]
    fn vertex(&mut self, v: &[f64; 8]) -> Result<(), f64> {
        if let Some(&bad) = v[..3].iter().find(|x| !x.is_finite()) {
            return Err(bad);
        }
        self.positions.push([v[0], v[1], v[2]]);
        if self.layout.sphere {
            self.sphere.push([v[3], v[4], v[5]]);
        }
        if self.layout.uv {
            self.uv.push([v[6], v[7]]);
        }
        Ok(())
    }

    /// Adds a corner index; the message says what is wrong with a bad one.
    #[inline]
    fn corner(&mut self, index: i64) -> Result<(), String> {
        if index < 0 || index as u64 >= self.nv {
            return Err(format!(
                "vertex index {index} is out of range: the file has {} vertices",
                self.nv
            ));
        }
        self.corners.push(index as u32);
        Ok(())
    }

    fn end_face(&mut self) -> Result<(), String> {
        if self.corners.len() < 3 {
            return Err(format!(
                "a face needs at least 3 vertices, this one has {}",
                self.corners.len()
            ));
        }
        self.triangles.push(&self.corners);
        self.corners.clear();
        Ok(())
    }

    fn into_mesh(self, name: &str) -> Result<LoadedMesh, MeshError> {
        let attributes = VertexAttributes {
            sphere: self.layout.sphere.then_some(self.sphere),
            uv: self.layout.uv.then_some(self.uv),
        };
        let notes = self.triangles.note().into_iter().collect();
        finish(name, self.positions, self.triangles.faces, attributes, notes)
    }
}

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
fn binary_f64(t: Scalar, data: &[u8], pos: usize, big: bool) -> Option<f64> {
    Some(match t {
        Scalar::F32 => f64::from(endian!(f32, take::<4>(data, pos)?, big)),
        Scalar::F64 => endian!(f64, take::<8>(data, pos)?, big),
        _ => binary_i64(t, data, pos, big)? as f64,
    })
}

/// One binary integer at `pos` (floats are truncated; the header only lets
/// integer types reach here).
#[inline]
fn binary_i64(t: Scalar, data: &[u8], pos: usize, big: bool) -> Option<i64> {
    Some(match t {
        Scalar::I8 => i64::from(take::<1>(data, pos)?[0] as i8),
        Scalar::U8 => i64::from(take::<1>(data, pos)?[0]),
        Scalar::I16 => i64::from(endian!(i16, take::<2>(data, pos)?, big)),
        Scalar::U16 => i64::from(endian!(u16, take::<2>(data, pos)?, big)),
        Scalar::I32 => i64::from(endian!(i32, take::<4>(data, pos)?, big)),
        Scalar::U32 => i64::from(endian!(u32, take::<4>(data, pos)?, big)),
        // Not through `binary_f64`: mutual recursion would stop both from inlining.
        Scalar::F32 => endian!(f32, take::<4>(data, pos)?, big) as i64,
        Scalar::F64 => endian!(f64, take::<8>(data, pos)?, big) as i64,
    })
}

fn binary_element(
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
            return binary_triangles(element, data, pos, big, item, out, name);
        }
    }
    let fixed = element.props.iter().all(|p| matches!(p.kind, Kind::Scalar(_)));
    let is_vertex = element.props.iter().any(|p| matches!(p.role, Role::Value(_)));
    if fixed {
        return binary_fixed(element, data, pos, big, is_vertex.then_some(out), name);
    }
    let truncated = |k: u64, at: usize| truncated(element, k, at, name);
    let mut values = [0.0f64; 8];
    for k in 0..element.count {
        let start = *pos;
        let mut p = start;
        for prop in &element.props {
            match (prop.kind, prop.role) {
                (Kind::Scalar(t), Role::Value(slot)) => {
                    values[slot] =
                        binary_f64(t, data, p, big).ok_or_else(|| truncated(k, start))?;
                    p += t.size();
                }
                (Kind::Scalar(t), _) => p += t.size(),
                (Kind::List { count, item }, role) => {
                    let n = binary_i64(count, data, p, big).ok_or_else(|| truncated(k, start))?;
                    p += count.size();
                    let n = usize::try_from(n).map_err(|_| {
                        byte_error(name, start, format!("negative list length {n}"))
                    })?;
                    let end = n.checked_mul(item.size()).and_then(|len| p.checked_add(len));
                    let end =
                        end.filter(|&e| e <= data.len()).ok_or_else(|| truncated(k, start))?;
                    if role == Role::Indices {
                        for j in 0..n {
                            let index = binary_i64(item, data, p + j * item.size(), big)
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
fn binary_fixed(
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
            values[slot] = binary_f64(t, record, offset, big).unwrap_or(f64::NAN);
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
fn binary_triangles(
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
            let index = binary_i64(item, indices, 4 * j, big).unwrap_or(-1);
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

/// Whitespace-separated tokens of an ascii body, counting lines as it goes.
struct Tokens<'a> {
    rest: &'a [u8],
    line: u64,
}

impl<'a> Tokens<'a> {
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        let mut i = 0;
        while let Some(&b) = self.rest.get(i) {
            if b == b'\n' {
                self.line += 1;
            } else if !text::is_space(b) {
                break;
            }
            i += 1;
        }
        let rest = self.rest.get(i..).unwrap_or_default();
        let end = rest.iter().position(|&b| b == b'\n' || text::is_space(b)).unwrap_or(rest.len());
        let (token, tail) = rest.split_at(end);
        self.rest = tail;
        (!token.is_empty()).then_some(token)
    }
}

fn ascii_element<'a>(
    element: &Element,
    tokens: &mut Tokens<'a>,
    out: &mut Sink,
    name: &str,
) -> Result<(), MeshError> {
    if element.props.is_empty() {
        return Ok(());
    }
    let is_vertex = element.props.iter().any(|p| matches!(p.role, Role::Value(_)));
    let mut values = [0.0f64; 8];
    for k in 0..element.count {
        let next = |tokens: &mut Tokens<'a>| -> Result<&'a [u8], MeshError> {
            let line = tokens.line;
            tokens.next().ok_or_else(|| {
                let msg = format!(
                    "the file ends inside '{}' element {k} of {}",
                    element.name, element.count
                );
                line_error(name, line, msg)
            })
        };
        let mut first_line = None;
        for prop in &element.props {
            let token = next(tokens)?;
            first_line.get_or_insert(tokens.line);
            let bad_number = |tokens: &Tokens| {
                line_error(
                    name,
                    tokens.line,
                    format!("{} is not a number", text::show(Some(token))),
                )
            };
            match (prop.kind, prop.role) {
                (Kind::Scalar(_), Role::Value(slot)) => {
                    values[slot] = text::parse_f64(token).ok_or_else(|| bad_number(tokens))?;
                }
                (Kind::Scalar(_), _) => {}
                (Kind::List { .. }, role) => {
                    let n = text::parse_u64(token).ok_or_else(|| bad_number(tokens))?;
                    let line = tokens.line;
                    for _ in 0..n {
                        let item = next(tokens)?;
                        if role == Role::Indices {
                            let index = text::parse_i64(item).ok_or_else(|| {
                                line_error(
                                    name,
                                    tokens.line,
                                    format!("{} is not an integer", text::show(Some(item))),
                                )
                            })?;
                            out.corner(index).map_err(|msg| line_error(name, line, msg))?;
                        }
                    }
                    if role == Role::Indices {
                        out.end_face().map_err(|msg| line_error(name, line, msg))?;
                    }
                }
            }
        }
        if is_vertex {
            let line = first_line.unwrap_or(tokens.line);
            out.vertex(&values).map_err(|bad| {
                line_error(name, line, format!("vertex coordinate {bad} is not finite"))
            })?;
        }
    }
    Ok(())
}

/// Writes a PLY file: doubles for `x y z`, then `sphere_x sphere_y sphere_z` and
/// `u v` when given, and faces as `list uchar int vertex_indices` (`uint` past 2^31
/// vertices).
pub(crate) fn write<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    attributes: &VertexAttributes,
    encoding: PlyEncoding,
) -> std::io::Result<()> {
    let format = match encoding {
        PlyEncoding::Ascii => "ascii",
        PlyEncoding::BinaryLittleEndian => "binary_little_endian",
        PlyEncoding::BinaryBigEndian => "binary_big_endian",
    };
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
    use super::super::tests::{awkward_tetra, bits, location};
    use super::super::{read_bytes, write_bytes, FileFormat, WriteOptions};
    use super::*;
    use crate::error::Location;

    fn parse(bytes: &[u8]) -> Result<LoadedMesh, MeshError> {
        read_bytes(bytes, FileFormat::Ply, "test.ply")
    }

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

    const SQUARE_PYRAMID: [[f64; 3]; 5] =
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0], [0.5, 0.5, 1.0]];
    const PYRAMID_FACES: [[u32; 3]; 6] =
        [[0, 3, 2], [0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]];

    #[test]
    fn reads_ascii_with_extra_properties_elements_and_a_quad() {
        let text = "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info nothing\r\n\
            element vertex 5\r\nproperty float x\r\nproperty float y\r\nproperty float z\r\n\
            property uchar red\r\nproperty list uchar float extra\r\n\
            element edge 2\r\nproperty list int int ends\r\nproperty uchar tag\r\n\
            element face 5\r\nproperty list uchar int vertex_indices\r\nproperty float quality\r\n\
            end_header\r\n\
            0 0 0 1 0\r\n1 0 0 2 2 0.5 0.5\r\n1 1 0 3 0\r\n0 1 0 4 1 7\r\n0.5 0.5 1 5 0\r\n\
            2 0 1 9\r\n2 1 2 9\r\n\
            4 0 3 2 1 0.1\r\n3 0 1 4 0.2\r\n3 1 2 4 0.3\r\n3 2 3 4 0.4\r\n3 3 0 4 0.5\r\n";
        let loaded = parse(text.as_bytes()).unwrap();
        assert_eq!(loaded.mesh.positions(), &SQUARE_PYRAMID);
        assert_eq!(loaded.mesh.faces(), &PYRAMID_FACES);
        assert_eq!(loaded.attributes, VertexAttributes::default());
        assert_eq!(
            loaded.notes,
            vec!["1 polygons with more than 3 vertices were fan-triangulated into 2 triangles"
                .to_string()]
        );
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
                    assert_eq!(loaded.notes.len(), 1);
                }
            }
        }
    }

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

    const ASCII_TRI: &str =
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
        property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

    #[test]
    fn malformed_headers_and_ascii_data_are_reported_by_line() {
        assert!(parse(ASCII_TRI.as_bytes()).is_ok());
        let cases = [
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
            ("1 0 0\n", "1 x 0\n", 11),
            ("0 1 0\n", "0 1 inf\n", 12),
            ("3 0 1 2", "3 0 1 3", 13),
            ("3 0 1 2", "3 0 1 -1", 13),
            ("3 0 1 2", "2 0 1 2", 13),
            ("3 0 1 2", "3 0 1 z", 13),
            ("3 0 1 2\n", "3 0\n\n\n\n", 13),
        ];
        for (from, to, line) in cases {
            let text = ASCII_TRI.replacen(from, to, 1);
            assert_eq!(location(parse(text.as_bytes())), Location::Line(line), "{from} -> {to}");
        }
        let no_end = ASCII_TRI.split("end_header").next().unwrap_or_default();
        assert_eq!(location(parse(no_end.as_bytes())), Location::Line(8));
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
