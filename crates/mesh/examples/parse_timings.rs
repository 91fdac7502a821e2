//! Parse timings of the larger corpus files of `../shared/meshes`, in their own
//! formats and in every format and encoding spherify writes:
//! `cargo run --release -p spherify-mesh --example parse_timings [-- MESH_DIR]`.
use spherify_mesh::io::{
    format_from_path, read, read_bytes, write_bytes, FileFormat, PlyEncoding, VertexAttributes,
    WriteOptions,
};
use std::path::{Path, PathBuf};

fn main() {
    let root = std::env::args()
        .nth(1)
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/meshes"));
    let igea = match read(&root.join("igea.ply")) {
        Ok(loaded) => loaded,
        Err(e) => {
            eprintln!("parse_timings needs the corpus: {e}");
            std::process::exit(2);
        }
    };
    let mut inputs = Vec::new();
    for name in ["igea.ply", "horse.ply", "scorpion.ply", "armadillo.obj", "sword.obj"] {
        let bytes = std::fs::read(root.join(name)).expect("corpus file readable");
        inputs.push((name.to_string(), format_from_path(Path::new(name)).unwrap(), bytes));
    }
    // The same large mesh in every format and encoding spherify writes.
    let none = VertexAttributes::default();
    for (label, format, ply_encoding, stl_binary) in [
        ("igea as obj", FileFormat::Obj, PlyEncoding::Ascii, true),
        ("igea as off", FileFormat::Off, PlyEncoding::Ascii, true),
        ("igea as ascii ply", FileFormat::Ply, PlyEncoding::Ascii, true),
        ("igea as binary stl", FileFormat::Stl, PlyEncoding::Ascii, true),
        ("igea as ascii stl", FileFormat::Stl, PlyEncoding::Ascii, false),
    ] {
        let options = WriteOptions { ply_encoding, stl_binary };
        let bytes = write_bytes(&igea.mesh, &none, format, &options, label).unwrap();
        inputs.push((label.to_string(), format, bytes));
    }
    for (name, format, bytes) in inputs {
        let mut best = f64::INFINITY;
        for _ in 0..20 {
            let start = std::time::Instant::now();
            let loaded = read_bytes(&bytes, format, &name).unwrap();
            best = best.min(start.elapsed().as_secs_f64());
            assert!(loaded.mesh.n_faces() > 0);
        }
        let mb = bytes.len() as f64 / 1e6;
        println!("{name}: {mb:.2} MB in {:.2} ms ({:.0} MB/s)", best * 1e3, mb / best);
    }
}
