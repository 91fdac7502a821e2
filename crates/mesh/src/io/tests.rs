//! Tests of the readers and writers across formats; the per-format files
//! test their own parsers.

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
        let err = write_bytes(&mesh, &VertexAttributes::default(), FileFormat::Stl, &options, "x")
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
            let p =
                mesh.positions().iter().map(|q| q.map(|x| (x as f32).clamp(-1e30, 1e30) as f64));
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

/// Issue 13, item 17: what a reader cannot hold against a file, it notes.
mod notes_of_doubtful_files {
    use super::*;

    fn notes(text: &[u8], format: FileFormat) -> Vec<String> {
        read_bytes(text, format, "x").unwrap().notes
    }

    fn tetra(format: FileFormat, ply_encoding: PlyEncoding) -> Vec<u8> {
        let mesh = crate::solids::tetrahedron();
        let options = WriteOptions { ply_encoding, stl_binary: false };
        write_bytes(&mesh, &VertexAttributes::default(), format, &options, "x").unwrap()
    }

    #[test]
    fn an_ascii_stl_without_endsolid_is_noted() {
        let whole = tetra(FileFormat::Stl, PlyEncoding::Ascii);
        assert!(!notes(&whole, FileFormat::Stl).iter().any(|n| n.contains("endsolid")));
        let text = String::from_utf8(whole).unwrap();
        let cut = &text[..text.rfind("endsolid").unwrap()];
        let found = notes(cut.as_bytes(), FileFormat::Stl);
        assert!(
            found
                .iter()
                .any(|n| n
                    == "no endsolid after the last of 4 facets: the file may have been cut short"),
            "{found:?}"
        );
    }

    #[test]
    fn data_after_the_declared_elements_is_noted() {
        for (format, encoding) in [
            (FileFormat::Off, PlyEncoding::Ascii),
            (FileFormat::Ply, PlyEncoding::Ascii),
            (FileFormat::Ply, PlyEncoding::BinaryLittleEndian),
            (FileFormat::Ply, PlyEncoding::BinaryBigEndian),
        ] {
            let whole = tetra(format, encoding);
            let clean = notes(&whole, format);
            assert!(!clean.iter().any(|n| n.contains("ignored")), "{format:?} {clean:?}");
            let mut more = whole.clone();
            more.extend_from_slice(b"1 2 3\n");
            let found = notes(&more, format);
            assert!(
                found.iter().any(|n| n.contains("after the") && n.contains("ignored")),
                "{format:?} {encoding:?}: {found:?}"
            );
        }
    }

    #[test]
    fn a_huge_polygon_is_named_with_its_triangle_count() {
        // A 2,000-gon cap on a pyramid: one line, 1,998 triangles.
        let n = 2000usize;
        let mut text = String::new();
        for k in 0..n {
            let t = k as f64 / n as f64 * std::f64::consts::TAU;
            text += &format!("v {} {} 0\n", t.cos(), t.sin());
        }
        text += "v 0 0 -1\nf";
        for k in (1..=n).rev() {
            text += &format!(" {k}");
        }
        text += "\n";
        for k in 1..=n {
            text += &format!("f {} {} {}\n", k, k % n + 1, n + 1);
        }
        let found = notes(text.as_bytes(), FileFormat::Obj);
        assert_eq!(
            found,
            vec![
                "1 polygons with more than 3 vertices were fan-triangulated into 1998 triangles; \
                 the largest has 2000 corners and became 1998 triangles"
                    .to_string()
            ]
        );
    }

    /// Issue 26, finding 10: a polygon of more than MAX_POLYGON_CORNERS corners
    /// is refused where it stands, in every format that has polygons.
    #[test]
    fn a_polygon_beyond_the_bound_is_refused_naming_its_line() {
        let n = MAX_POLYGON_CORNERS + 1;
        let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\nf");
        let mut off = String::from("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n");
        off += &format!("{n}");
        for k in 0..n {
            obj += &format!(" {}", k % 3 + 1);
            off += &format!(" {}", k % 3);
        }
        obj += "\n";
        off += "\n";
        let ply = format!(
            "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list int int vertex_indices\nend_header\n\
             0 0 0\n1 0 0\n0 1 0\n{n}{}\n",
            (0..n).map(|k| format!(" {}", k % 3)).collect::<String>()
        );
        for (text, format, line) in [
            (obj.as_bytes(), FileFormat::Obj, Some(4)),
            (off.as_bytes(), FileFormat::Off, Some(6)),
            (ply.as_bytes(), FileFormat::Ply, None),
        ] {
            let err = read_bytes(text, format, "x").unwrap_err();
            let message = err.to_string();
            assert!(message.contains("a polygon may have at most 65536"), "{format:?}: {message}");
            if let Some(line) = line {
                assert_eq!(location(Err(err)), Location::Line(line), "{format:?}");
            }
        }
        // At the bound it is read (and fanned), with the note.
        let at = MAX_POLYGON_CORNERS;
        let mut ok = String::from("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n");
        ok += &format!("{at}");
        for k in 0..at {
            ok += &format!(" {}", k % 3);
        }
        ok += "\n";
        let result = read_bytes(ok.as_bytes(), FileFormat::Off, "x");
        assert!(!matches!(result, Err(MeshError::Format(_))));
    }
}
