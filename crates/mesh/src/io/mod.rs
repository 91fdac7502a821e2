//! Reading and writing mesh files: OBJ, OFF, PLY (ascii, binary little and big
//! endian) and STL (ascii and binary). The format is chosen by file extension.
//!
//! Readers take the whole file as bytes (one `std::fs::read`), so the per-format
//! parsers are plain functions of a byte slice: fast, easy to test, and unable to
//! block halfway. Polygons are fan-triangulated from their first corner and the
//! caller is told so in [`LoadedMesh::notes`]; nothing else is changed silently
//! (STL, which has no shared vertices, is welded exactly and says so too).
//!
//! Writes go to a temporary file beside the target and are renamed into place,
//! so a failed write never leaves a half-written or lost output file.

mod atomic;
mod obj;
mod off;
mod ply;
mod stl;
mod text;

pub use atomic::{
    is_stale_temporary, remove_stale_temporaries, temp_path, temporary_owner, PendingWrite,
};
pub use ply::PlyEncoding;

use crate::error::{FormatError, Location, MeshError};
use crate::Mesh;
use std::io::Write;
use std::path::Path;

/// Optional per-vertex data stored alongside positions, each one entry per vertex.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct VertexAttributes {
    /// Points on the unit sphere (PLY `sphere_x sphere_y sphere_z`).
    pub sphere: Option<Vec<[f64; 3]>>,
    /// Texture coordinates (OBJ `vt`, PLY `u v`).
    pub uv: Option<Vec<[f64; 2]>>,
}

/// A mesh read from a file, with the attributes the file held and notes about
/// anything the reader did to it (triangulation, welding, ignored records).
#[derive(Debug, Clone)]
pub struct LoadedMesh {
    /// The validated positions and triangles.
    pub mesh: Mesh,
    /// Per-vertex attributes found in the file.
    pub attributes: VertexAttributes,
    /// Human-readable remarks, one sentence each; empty when the file was read as is.
    pub notes: Vec<String>,
}

/// A mesh file format.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FileFormat {
    /// Wavefront `.obj` (text).
    Obj,
    /// Object File Format `.off` (text).
    Off,
    /// Stanford `.ply` (ascii or binary).
    Ply,
    /// Stereolithography `.stl` (ascii or binary, single precision).
    Stl,
}

/// Choices for the writers whose format has more than one encoding.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteOptions {
    /// Encoding of `.ply` files (binary little endian by default).
    pub ply_encoding: PlyEncoding,
    /// Write `.stl` as binary (default) rather than ascii.
    pub stl_binary: bool,
}

impl Default for WriteOptions {
    fn default() -> Self {
        WriteOptions { ply_encoding: PlyEncoding::BinaryLittleEndian, stl_binary: true }
    }
}

const SUPPORTED: &str = "supported extensions are .obj, .off, .ply and .stl";

/// The format of a file from its extension (case-insensitive).
pub fn format_from_path(path: &Path) -> Result<FileFormat, MeshError> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("obj") => Ok(FileFormat::Obj),
        Some("off") => Ok(FileFormat::Off),
        Some("ply") => Ok(FileFormat::Ply),
        Some("stl") => Ok(FileFormat::Stl),
        Some(other) => Err(file_error(
            &path.display().to_string(),
            format!("unknown mesh file extension '.{other}': {SUPPORTED}"),
        )),
        None => Err(file_error(
            &path.display().to_string(),
            format!("the file name has no extension to tell its format: {SUPPORTED}"),
        )),
    }
}

/// Reads a mesh file; the format comes from the extension. A missing or
/// unreadable file gives [`MeshError::Io`], a malformed one [`MeshError::Format`].
///
/// Only regular files are read (symbolic links are followed): a FIFO would
/// block the call until some writer appears, and a device such as
/// `/dev/zero` never ends. Those give a [`MeshError::Format`] saying so. What
/// is read is bounded by the size the file had when it was opened.
pub fn read(path: &Path) -> Result<LoadedMesh, MeshError> {
    let format = format_from_path(path)?;
    let bytes = read_regular_file(path)?;
    read_bytes(&bytes, format, &path.display().to_string())
}

/// What is at `path` (symbolic links followed), in words, when it is neither
/// a regular file nor a folder: "a FIFO (named pipe)", "a device", "a socket"
/// or "not a regular file". `None` for a regular file, a folder or nothing
/// at all, which the open that follows reads or refuses with the system's
/// reason. Looked at with `stat`, which does not open it: opening a FIFO for
/// reading waits for a writer.
pub fn special_kind(path: &Path) -> Option<&'static str> {
    let meta = std::fs::metadata(path).ok()?;
    if meta.is_dir() {
        return None;
    }
    file_kind(&meta)
}

/// Refuses to read `path` when it is a special file ([`special_kind`]): a
/// [`MeshError::Format`] saying what it is. A regular file, a folder or a
/// missing path passes: the open that follows says why it cannot be read.
pub fn require_regular_file(path: &Path) -> Result<(), MeshError> {
    match special_kind(path) {
        Some(what) => Err(not_regular(path, what)),
        None => Ok(()),
    }
}

/// The refusal of a special file at `path` for reading.
fn not_regular(path: &Path, what: &str) -> MeshError {
    file_error(
        &path.display().to_string(),
        format!("this is {what}, not a regular file: only regular files are read"),
    )
}

/// What a file of this metadata is, in words, unless it is a regular file.
fn file_kind(meta: &std::fs::Metadata) -> Option<&'static str> {
    let t = meta.file_type();
    if t.is_file() {
        return None;
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return Some("a FIFO (named pipe)");
        }
        if t.is_char_device() || t.is_block_device() {
            return Some("a device");
        }
        if t.is_socket() {
            return Some("a socket");
        }
    }
    Some("not a regular file")
}

/// The bytes of the regular file at `path` (see [`read`]).
fn read_regular_file(path: &Path) -> Result<Vec<u8>, MeshError> {
    use std::io::Read;
    let io = |e| MeshError::io(path, e);
    // Checked before opening: opening a FIFO for reading blocks.
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_dir() {
        return Err(io(std::io::Error::from(std::io::ErrorKind::IsADirectory)));
    }
    if let Some(what) = file_kind(&meta) {
        return Err(not_regular(path, what));
    }
    let file = std::fs::File::open(path).map_err(io)?;
    // Checked again on the open file, in case the path changed in between.
    let meta = file.metadata().map_err(io)?;
    if let Some(what) = file_kind(&meta) {
        return Err(not_regular(path, what));
    }
    let size = meta.len();
    // Reserved fallibly: a file larger than the memory the process can get
    // (a 100 GB sparse file, a mesh bigger than the machine) would otherwise
    // abort the process, Python and all, instead of raising.
    let mut bytes = Vec::new();
    usize::try_from(size).ok().and_then(|size| bytes.try_reserve_exact(size).ok()).ok_or_else(
        || {
            io(std::io::Error::new(
                std::io::ErrorKind::OutOfMemory,
                format!("the file is {size} bytes, more than this process can hold in memory"),
            ))
        },
    )?;
    file.take(size).read_to_end(&mut bytes).map_err(io)?;
    Ok(bytes)
}

/// Parses the contents of a mesh file held in memory. `name` is only used in
/// error messages (usually the path).
pub fn read_bytes(bytes: &[u8], format: FileFormat, name: &str) -> Result<LoadedMesh, MeshError> {
    match format {
        FileFormat::Obj => obj::read(bytes, name),
        FileFormat::Off => off::read(bytes, name),
        FileFormat::Ply => ply::read(bytes, name),
        FileFormat::Stl => stl::read(bytes, name),
    }
}

/// Writes a mesh file, choosing the format from the extension. The data goes to a
/// temporary file in the same directory that is renamed over `path` only once it
/// is complete and synced, so an existing file survives any failure.
///
/// Attributes must fit the format (`.ply` holds sphere and uv, `.obj` holds uv,
/// `.off` and `.stl` hold neither). `.stl` stores single-precision coordinates and
/// one separate copy of each corner: reading it back welds bitwise-equal corners.
pub fn write(
    path: &Path,
    mesh: &Mesh,
    attributes: &VertexAttributes,
    options: &WriteOptions,
) -> Result<(), MeshError> {
    let format = format_from_path(path)?;
    check_attributes(mesh, attributes, format, &path.display().to_string())?;
    check_representable(mesh, format, &path.display().to_string())?;
    atomic::write_file(path, |out| encode(out, mesh, attributes, format, options))
}

/// Writes a textured OBJ atomically: texture coordinates per face corner
/// (`corners`, three per face in face order; an atlas cuts the sphere into
/// pieces, which one uv per vertex cannot hold), a comment naming the layout
/// (`label`) and, with `material_library`, the `mtllib` / `usemtl texture`
/// lines of its MTL file (which the caller writes).
pub fn write_textured_obj(
    path: &Path,
    mesh: &Mesh,
    corners: &[[f64; 2]],
    label: &str,
    material_library: Option<&str>,
) -> Result<(), MeshError> {
    if corners.len() != 3 * mesh.n_faces() {
        return Err(file_error(
            &path.display().to_string(),
            format!(
                "{} texture corners for {} triangles: one per face corner is needed",
                corners.len(),
                mesh.n_faces()
            ),
        ));
    }
    atomic::write_file(path, |out| {
        obj::write_per_corner(out, mesh, corners, label, material_library)
    })
}

/// Writes `bytes` to `path` with the same atomic writer as [`write()`]
/// (temporary beside it, sync, rename; links followed, mode kept, stale
/// temporaries of dead writers removed): for files other than meshes that
/// must not be left half-written, such as the `.npz` beside a mapped mesh.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), MeshError> {
    atomic::write_bytes(path, bytes)
}

/// The bytes [`write()`] would put in a file of the given format. `name` is only
/// used in error messages.
pub fn write_bytes(
    mesh: &Mesh,
    attributes: &VertexAttributes,
    format: FileFormat,
    options: &WriteOptions,
    name: &str,
) -> Result<Vec<u8>, MeshError> {
    check_attributes(mesh, attributes, format, name)?;
    check_representable(mesh, format, name)?;
    let mut out = Vec::new();
    encode(&mut out, mesh, attributes, format, options)
        .map_err(|source| MeshError::Io { path: name.to_string(), source })?;
    Ok(out)
}

fn encode<W: Write>(
    out: &mut W,
    mesh: &Mesh,
    attributes: &VertexAttributes,
    format: FileFormat,
    options: &WriteOptions,
) -> std::io::Result<()> {
    match format {
        FileFormat::Obj => obj::write(out, mesh, attributes.uv.as_deref()),
        FileFormat::Off => off::write(out, mesh),
        FileFormat::Ply => ply::write(out, mesh, attributes, options.ply_encoding),
        FileFormat::Stl => stl::write(out, mesh, options.stl_binary),
    }
}

/// Refuses coordinates that STL's `f32` would turn into infinity or zero: the
/// file could not be read back (infinity), or would silently merge vertices
/// (zero). Values that merely round are fine: STL is single precision.
fn check_representable(mesh: &Mesh, format: FileFormat, name: &str) -> Result<(), MeshError> {
    if format != FileFormat::Stl {
        return Ok(());
    }
    let lost = |x: f64| {
        let y = x as f32;
        y.is_infinite() || (y == 0.0 && x != 0.0)
    };
    for (vertex, p) in mesh.positions().iter().enumerate() {
        if let Some(&value) = p.iter().find(|&&x| lost(x)) {
            return Err(MeshError::NotRepresentable {
                path: name.to_string(),
                vertex,
                value,
                format: ".stl",
            });
        }
    }
    Ok(())
}

/// Refuses attributes the format cannot store (rather than dropping them
/// silently) and attributes whose length does not match the vertex count.
fn check_attributes(
    mesh: &Mesh,
    attributes: &VertexAttributes,
    format: FileFormat,
    name: &str,
) -> Result<(), MeshError> {
    let n = mesh.n_vertices();
    if let Some(sphere) = &attributes.sphere {
        if sphere.len() != n {
            return Err(MeshError::AttributeLength {
                what: "sphere",
                got: sphere.len(),
                expected: n,
            });
        }
    }
    if let Some(uv) = &attributes.uv {
        if uv.len() != n {
            return Err(MeshError::AttributeLength { what: "uv", got: uv.len(), expected: n });
        }
    }
    let label = match format {
        FileFormat::Obj => ".obj",
        FileFormat::Off => ".off",
        FileFormat::Ply => ".ply",
        FileFormat::Stl => ".stl",
    };
    let sphere_ok = format == FileFormat::Ply;
    let uv_ok = matches!(format, FileFormat::Ply | FileFormat::Obj);
    let refused = if attributes.sphere.is_some() && !sphere_ok {
        Some("per-vertex sphere positions")
    } else if attributes.uv.is_some() && !uv_ok {
        Some("per-vertex uv coordinates")
    } else {
        None
    };
    match refused {
        Some(what) => Err(file_error(
            name,
            format!("a {label} file cannot hold {what}: .ply holds sphere and uv; .obj holds uv"),
        )),
        None => Ok(()),
    }
}

fn file_error(name: &str, message: String) -> MeshError {
    FormatError::new(name, Location::File, message).into()
}

/// A format error at a 1-based line.
pub(crate) fn line_error(name: &str, line: u64, message: impl Into<String>) -> MeshError {
    FormatError::new(name, Location::Line(line), message).into()
}

/// A format error at a 0-based byte offset.
pub(crate) fn byte_error(name: &str, offset: usize, message: impl Into<String>) -> MeshError {
    FormatError::new(name, Location::Byte(offset as u64), message).into()
}

/// Polygons with more corners than this are named in the fan note.
pub(crate) const HUGE_POLYGON: usize = 1000;

/// The most corners a polygon of a mesh file may have (issue 26, finding 10):
/// a fan of more triangles from one corner is no surface anyone meant, and a
/// single 100 MB line of corners would otherwise become 52 million
/// triangles. Readers refuse a larger polygon as soon as they have read one
/// corner too many (OFF from its declared count), before it is stored.
pub(crate) const MAX_POLYGON_CORNERS: usize = 65_536;

/// The message for a polygon that has more than [`MAX_POLYGON_CORNERS`] corners.
pub(crate) fn polygon_too_large(corners: impl std::fmt::Display) -> String {
    format!(
        "a face has {corners} corners; a polygon may have at most {MAX_POLYGON_CORNERS} \
         (split it into smaller faces)"
    )
}

/// Collects triangles from polygons of any size, fanning larger ones from their
/// first corner, and counts what it did for the note.
#[derive(Default)]
pub(crate) struct Triangles {
    pub faces: Vec<[u32; 3]>,
    polygons: usize,
    fanned: usize,
    /// Corners of the largest polygon fanned.
    largest: usize,
}

impl Triangles {
    pub(crate) fn with_capacity(n: usize) -> Self {
        Triangles { faces: Vec::with_capacity(n), ..Default::default() }
    }

    /// Adds a polygon of at least 3 corners (callers reject smaller ones with
    /// their own location).
    #[inline]
    pub(crate) fn push(&mut self, corners: &[u32]) {
        match *corners {
            [a, b, c] => self.faces.push([a, b, c]),
            [first, ref rest @ ..] if rest.len() >= 2 => {
                self.polygons += 1;
                self.fanned += rest.len() - 1;
                self.largest = self.largest.max(rest.len() + 1);
                self.faces.extend(rest.windows(2).map(|w| [first, w[0], w[1]]));
            }
            _ => {}
        }
    }

    /// The note for `notes`, if any polygon was fanned; a polygon of more
    /// than [`HUGE_POLYGON`] corners is named, since one line of the file
    /// then becomes that many triangles (issue 13, item 17).
    pub(crate) fn note(&self) -> Option<String> {
        (self.polygons > 0).then(|| {
            let mut note = format!(
                "{} polygons with more than 3 vertices were fan-triangulated into {} triangles",
                self.polygons, self.fanned
            );
            if self.largest > HUGE_POLYGON {
                note += &format!(
                    "; the largest has {} corners and became {} triangles",
                    self.largest,
                    self.largest - 2
                );
            }
            note
        })
    }
}

/// Builds the validated mesh at the end of a read. The parsers check coordinates
/// and indices where they know the line or byte, so what can still fail here is an
/// empty file; that is reported as a format error of the file.
pub(crate) fn finish(
    name: &str,
    positions: Vec<[f64; 3]>,
    faces: Vec<[u32; 3]>,
    attributes: VertexAttributes,
    notes: Vec<String>,
) -> Result<LoadedMesh, MeshError> {
    let mesh = Mesh::new(positions, faces).map_err(|e| match e {
        MeshError::NoVertices => file_error(name, "the file holds no vertices".to_string()),
        MeshError::NoFaces => file_error(name, "the file holds no faces".to_string()),
        other => file_error(name, other.to_string()),
    })?;
    Ok(LoadedMesh { mesh, attributes, notes })
}

#[cfg(test)]
pub(crate) mod tests;
