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

/// The bytes of the regular file at `path` (see [`read`]).
fn read_regular_file(path: &Path) -> Result<Vec<u8>, MeshError> {
    use std::io::Read;
    let io = |e| MeshError::io(path, e);
    let refuse = |kind: &str| {
        file_error(
            &path.display().to_string(),
            format!("this is {kind}, not a regular file: only regular files are read"),
        )
    };
    let kind = |meta: &std::fs::Metadata| -> Option<&'static str> {
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
    };
    // Checked before opening: opening a FIFO for reading blocks.
    let meta = std::fs::metadata(path).map_err(io)?;
    if meta.is_dir() {
        return Err(io(std::io::Error::from(std::io::ErrorKind::IsADirectory)));
    }
    if let Some(what) = kind(&meta) {
        return Err(refuse(what));
    }
    let file = std::fs::File::open(path).map_err(io)?;
    // Checked again on the open file, in case the path changed in between.
    let meta = file.metadata().map_err(io)?;
    if let Some(what) = kind(&meta) {
        return Err(refuse(what));
    }
    let size = meta.len();
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
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

/// Collects triangles from polygons of any size, fanning larger ones from their
/// first corner, and counts what it did for the note.
#[derive(Default)]
pub(crate) struct Triangles {
    pub faces: Vec<[u32; 3]>,
    polygons: usize,
    fanned: usize,
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
                self.faces.extend(rest.windows(2).map(|w| [first, w[0], w[1]]));
            }
            _ => {}
        }
    }

    /// The note for `notes`, if any polygon was fanned.
    pub(crate) fn note(&self) -> Option<String> {
        (self.polygons > 0).then(|| {
            format!(
                "{} polygons with more than 3 vertices were fan-triangulated into {} triangles",
                self.polygons, self.fanned
            )
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
pub(crate) mod tests {
    use super::*;

    /// A tetrahedron with coordinates that stress round-tripping: non-terminating
    /// binary fractions, huge and tiny magnitudes, a negative zero.
    pub(crate) fn awkward_tetra() -> Mesh {
        let positions = vec![
            [0.1, 1.0 / 3.0, -0.0],
            [1e300, -2.5e-300, 7.0],
            [-123456.789012345, 5e-324, 1.0 + f64::EPSILON],
            [std::f64::consts::PI, -std::f64::consts::E, 1e16],
        ];
        Mesh::new(positions, vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]]).unwrap()
    }

    /// The location of a format error; panics (in tests only) on anything else.
    pub(crate) fn location(result: Result<LoadedMesh, MeshError>) -> Location {
        match result {
            Err(MeshError::Format(e)) => e.location,
            Err(other) => panic!("expected a format error, got {other}"),
            Ok(_) => panic!("expected a format error, got a mesh"),
        }
    }

    pub(crate) fn bits(p: &[[f64; 3]]) -> Vec<[u64; 3]> {
        p.iter().map(|q| q.map(f64::to_bits)).collect()
    }

    #[test]
    fn format_from_extension_is_case_insensitive() {
        assert_eq!(format_from_path(Path::new("a/b.OBJ")).unwrap(), FileFormat::Obj);
        assert_eq!(format_from_path(Path::new("x.Ply")).unwrap(), FileFormat::Ply);
        assert_eq!(format_from_path(Path::new("x.off")).unwrap(), FileFormat::Off);
        assert_eq!(format_from_path(Path::new("x.stl")).unwrap(), FileFormat::Stl);
        for bad in ["x.gltf", "noext"] {
            match format_from_path(Path::new(bad)) {
                Err(MeshError::Format(e)) => {
                    assert_eq!(e.location, Location::File);
                    assert!(e.message.contains(".obj, .off, .ply and .stl"), "{}", e.message);
                }
                other => panic!("{other:?}"),
            }
        }
    }

    #[test]
    fn attributes_the_format_cannot_hold_are_refused() {
        let mesh = awkward_tetra();
        let sphere = VertexAttributes { sphere: Some(vec![[0.0, 0.0, 1.0]; 4]), uv: None };
        let uv = VertexAttributes { sphere: None, uv: Some(vec![[0.5, 0.5]; 4]) };
        let opts = WriteOptions::default();
        for (attrs, format) in [
            (&sphere, FileFormat::Obj),
            (&sphere, FileFormat::Off),
            (&sphere, FileFormat::Stl),
            (&uv, FileFormat::Off),
            (&uv, FileFormat::Stl),
        ] {
            match write_bytes(&mesh, attrs, format, &opts, "out") {
                Err(MeshError::Format(e)) => {
                    assert_eq!(e.location, Location::File);
                    assert!(
                        e.message.contains(".ply holds sphere and uv; .obj holds uv"),
                        "{}",
                        e.message
                    );
                }
                other => panic!("{format:?}: {other:?}"),
            }
        }
        assert!(write_bytes(&mesh, &uv, FileFormat::Obj, &opts, "out").is_ok());
        let short = VertexAttributes { sphere: Some(vec![[0.0; 3]; 3]), uv: None };
        let err = write_bytes(&mesh, &short, FileFormat::Ply, &opts, "out").unwrap_err();
        assert!(matches!(err, MeshError::AttributeLength { what: "sphere", got: 3, expected: 4 }));
    }

    #[test]
    fn stl_refuses_coordinates_its_floats_turn_into_infinity_or_zero() {
        let mesh = awkward_tetra(); // 1e300 and 5e-324
        for binary in [true, false] {
            let options = WriteOptions { stl_binary: binary, ..WriteOptions::default() };
            let err =
                write_bytes(&mesh, &VertexAttributes::default(), FileFormat::Stl, &options, "x")
                    .unwrap_err();
            assert!(
                matches!(err, MeshError::NotRepresentable { vertex: 1, value, .. } if value == 1e300),
                "{err}"
            );
        }
        let tiny = Mesh::new(
            vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 1e-320], [0.0, 0.0, 1.0]],
            awkward_tetra().faces().to_vec(),
        )
        .unwrap();
        let err = write_bytes(
            &tiny,
            &VertexAttributes::default(),
            FileFormat::Stl,
            &WriteOptions::default(),
            "x",
        )
        .unwrap_err();
        assert!(matches!(err, MeshError::NotRepresentable { vertex: 2, .. }), "{err}");
    }

    #[cfg(unix)]
    #[test]
    fn devices_and_directories_are_not_read() {
        let dir = std::env::temp_dir().join(format!("spherify-io-dev-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let link = dir.join("zero.obj");
        let _ = std::fs::remove_file(&link);
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        match read(&link) {
            Err(MeshError::Format(e)) => assert!(e.message.contains("a device"), "{}", e.message),
            other => panic!("{other:?}"),
        }
        let folder = dir.join("folder.obj");
        std::fs::create_dir_all(&folder).unwrap();
        match read(&folder) {
            Err(MeshError::Io { source, .. }) => {
                assert_eq!(source.kind(), std::io::ErrorKind::IsADirectory)
            }
            other => panic!("{other:?}"),
        }
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn write_and_read_through_the_file_system() {
        let dir = std::env::temp_dir().join(format!("spherify-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mesh = awkward_tetra();
        let sphere: Vec<[f64; 3]> = mesh.positions().iter().map(|p| [p[2], p[0], p[1]]).collect();
        let attrs = VertexAttributes { sphere: Some(sphere), uv: Some(vec![[0.25, 0.75]; 4]) };
        let path = dir.join("tetra.ply");
        write(&path, &mesh, &attrs, &WriteOptions::default()).unwrap();
        let loaded = read(&path).unwrap();
        assert_eq!(loaded.mesh, mesh);
        assert_eq!(loaded.attributes, attrs);
        // A refused write leaves the existing file as it was and no temporary file.
        let off = dir.join("tetra.off");
        write(&off, &mesh, &VertexAttributes::default(), &WriteOptions::default()).unwrap();
        let before = std::fs::read(&off).unwrap();
        assert!(write(&off, &mesh, &attrs, &WriteOptions::default()).is_err());
        assert_eq!(std::fs::read(&off).unwrap(), before);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 2);
        let missing = read(&dir.join("missing.obj")).unwrap_err();
        assert!(matches!(missing, MeshError::Io { .. }));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn empty_and_garbage_inputs_are_format_errors() {
        for format in [FileFormat::Obj, FileFormat::Off, FileFormat::Ply, FileFormat::Stl] {
            for bytes in [&b""[..], b"\x00\xff\xfe garbage \n\n", b"# only a comment\n"] {
                let result = read_bytes(bytes, format, "junk");
                assert!(
                    matches!(result, Err(MeshError::Format(_))),
                    "{format:?} {bytes:?}: {result:?}"
                );
            }
        }
    }

    /// Mangled files (truncated, bytes overwritten, digits inserted) must give a
    /// result or an error, never a panic or a hang.
    #[test]
    fn mangled_files_never_panic() {
        let mesh = awkward_tetra();
        let attrs = VertexAttributes { sphere: None, uv: Some(vec![[0.5, 0.25]; 4]) };
        let mut seeds: Vec<(FileFormat, Vec<u8>)> = Vec::new();
        let opts = |ply_encoding, stl_binary| WriteOptions { ply_encoding, stl_binary };
        for (format, options, attrs) in [
            (FileFormat::Obj, opts(PlyEncoding::Ascii, true), &attrs),
            (FileFormat::Off, opts(PlyEncoding::Ascii, true), &VertexAttributes::default()),
            (FileFormat::Ply, opts(PlyEncoding::Ascii, true), &attrs),
            (FileFormat::Ply, opts(PlyEncoding::BinaryLittleEndian, true), &attrs),
            (FileFormat::Ply, opts(PlyEncoding::BinaryBigEndian, true), &attrs),
            (FileFormat::Stl, opts(PlyEncoding::Ascii, true), &VertexAttributes::default()),
            (FileFormat::Stl, opts(PlyEncoding::Ascii, false), &VertexAttributes::default()),
        ] {
            // STL cannot hold 1e300 or 5e-324 (refused since issue 13): a
            // tetrahedron with the same faces and single-precision corners.
            let small;
            let seed_mesh = if format == FileFormat::Stl {
                let p = mesh
                    .positions()
                    .iter()
                    .map(|q| q.map(|x| (x as f32).clamp(-1e30, 1e30) as f64));
                small = Mesh::new(p.collect(), mesh.faces().to_vec()).unwrap();
                &small
            } else {
                &mesh
            };
            seeds.push((format, write_bytes(seed_mesh, attrs, format, &options, "seed").unwrap()));
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut random = move |n: usize| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % n.max(1) as u64) as usize
        };
        const NOISE: &[u8] = b"0123456789-+./ \n\r#eEfvtx\x00\xff";
        for (format, seed) in &seeds {
            for _ in 0..600 {
                let mut bytes = seed.clone();
                for _ in 0..1 + random(4) {
                    let at = random(bytes.len());
                    match random(4) {
                        0 => bytes.truncate(at),
                        1 => bytes.insert(at, NOISE[random(NOISE.len())]),
                        2 => {
                            if let Some(b) = bytes.get_mut(at) {
                                *b = random(256) as u8;
                            }
                        }
                        _ => bytes.splice(at..at, b"99999999999".iter().copied()).for_each(drop),
                    }
                }
                let _ = read_bytes(&bytes, *format, "mangled");
            }
        }
    }

    /// Every mesh of the shared corpus loads with the counts its manifest gives.
    #[test]
    fn shared_corpus_matches_manifest() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes");
        let Ok(manifest) = std::fs::read_to_string(root.join("MANIFEST.json")) else {
            eprintln!("skipping: no mesh corpus at {}", root.display());
            return;
        };
        let entries = manifest_entries(&manifest);
        assert!(entries.len() >= 20, "found only {} manifest entries", entries.len());
        for (path, v, f) in entries {
            let file = root.join(&path);
            match read(&file) {
                Ok(loaded) => {
                    assert_eq!(loaded.mesh.n_vertices(), v, "{path}: vertices");
                    assert_eq!(loaded.mesh.n_faces(), f, "{path}: faces");
                    assert!(
                        loaded.notes.iter().all(|n| !n.contains("fan-triangulated")),
                        "{path}: {:?}",
                        loaded.notes
                    );
                }
                Err(MeshError::Format(e)) if path.starts_with("invalid/") => {
                    eprintln!("{path}: {e}")
                }
                Err(e) => panic!("{path}: {e}"),
            }
        }
    }

    /// (path, V, F) of each manifest entry, by a minimal scan of the JSON: enough
    /// for this file's flat `"key": value` layout without a JSON dependency.
    fn manifest_entries(json: &str) -> Vec<(String, usize, usize)> {
        let value_after = |chunk: &str, key: &str| -> Option<String> {
            let start = chunk.find(&format!("\"{key}\":"))? + key.len() + 3;
            let rest = chunk[start..].trim_start();
            let end = rest.find([',', '\n', '}']).unwrap_or(rest.len());
            Some(rest[..end].trim().trim_matches('"').to_string())
        };
        json.split("\"path\":")
            .skip(1)
            .filter_map(|chunk| {
                let chunk = format!("\"path\":{chunk}");
                let path = value_after(&chunk, "path")?;
                let v = value_after(&chunk, "V")?.parse().ok()?;
                let f = value_after(&chunk, "F")?.parse().ok()?;
                Some((path, v, f))
            })
            .collect()
    }
}
