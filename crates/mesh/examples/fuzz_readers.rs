//! Mutation fuzzing of the mesh readers (issue 13, "fuzzing that stays").
//!
//! Seeds: the shared test shapes written in every format and encoding, plus
//! every mesh file under `--corpus DIR` (optional; files above 2 MB are
//! skipped to keep an input cheap). Each input is a seed mutated one to eight
//! times (truncation, byte overwrites, inserted noise or digits, a spliced or
//! repeated chunk, a header number made huge), parsed with `read_bytes`, and,
//! when it parses, validated and oriented. A panic, or an input that takes
//! longer than `--slow` seconds, is a finding; findings are written to
//! `--out DIR` (default: the system's temporary folder) and make the exit
//! status 1.
//!
//! ```text
//! cargo run --release -p spherify-mesh --example fuzz_readers -- --inputs 1000000 --corpus ../shared/meshes
//! ```
//!
//! CI runs a bounded number of inputs in the debug build (`.ci/run`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use spherify_mesh::io::{
    read_bytes, write_bytes, FileFormat, PlyEncoding, VertexAttributes, WriteOptions,
};
use spherify_mesh::lcg::Lcg;
use spherify_mesh::{orient, solids, validate, Mesh};

struct Args {
    inputs: u64,
    seed: u64,
    corpus: Option<PathBuf>,
    slow: f64,
    out: PathBuf,
}

fn parse_args() -> Result<Args, String> {
    let mut args =
        Args { inputs: 10_000, seed: 1, corpus: None, slow: 5.0, out: std::env::temp_dir() };
    let mut it = std::env::args().skip(1);
    while let Some(flag) = it.next() {
        let value = it.next().ok_or_else(|| format!("{flag} needs a value"))?;
        let number = |v: &str| v.parse::<u64>().map_err(|e| format!("{flag} {v}: {e}"));
        match flag.as_str() {
            "--inputs" => args.inputs = number(&value)?,
            "--seed" => args.seed = number(&value)?,
            "--corpus" => args.corpus = Some(PathBuf::from(value)),
            "--slow" => args.slow = value.parse().map_err(|e| format!("--slow {value}: {e}"))?,
            "--out" => args.out = PathBuf::from(value),
            other => return Err(format!("unknown option {other}")),
        }
    }
    Ok(args)
}

/// The seeds: generated shapes in every format, then the corpus files.
fn seeds(corpus: Option<&Path>) -> Vec<(FileFormat, Vec<u8>)> {
    let shapes: Vec<Mesh> = vec![solids::octahedron(), solids::octasphere(1)];
    let uv = |m: &Mesh| VertexAttributes {
        sphere: Some(m.positions().to_vec()),
        uv: Some(m.positions().iter().map(|p| [p[0], p[1]]).collect()),
    };
    let mut out = Vec::new();
    for mesh in &shapes {
        for (format, ply_encoding, stl_binary) in [
            (FileFormat::Obj, PlyEncoding::Ascii, false),
            (FileFormat::Off, PlyEncoding::Ascii, false),
            (FileFormat::Ply, PlyEncoding::Ascii, false),
            (FileFormat::Ply, PlyEncoding::BinaryLittleEndian, false),
            (FileFormat::Ply, PlyEncoding::BinaryBigEndian, false),
            (FileFormat::Stl, PlyEncoding::Ascii, false),
            (FileFormat::Stl, PlyEncoding::Ascii, true),
        ] {
            let attributes = match format {
                FileFormat::Ply => uv(mesh),
                FileFormat::Obj => VertexAttributes { sphere: None, uv: uv(mesh).uv },
                _ => VertexAttributes::default(),
            };
            let options = WriteOptions { ply_encoding, stl_binary };
            if let Ok(bytes) = write_bytes(mesh, &attributes, format, &options, "seed") {
                out.push((format, bytes));
            }
        }
    }
    if let Some(root) = corpus {
        let mut stack = vec![root.to_path_buf()];
        while let Some(dir) = stack.pop() {
            let Ok(entries) = std::fs::read_dir(&dir) else { continue };
            for entry in entries.flatten() {
                let path = entry.path();
                if path.is_dir() {
                    stack.push(path);
                    continue;
                }
                let Ok(format) = spherify_mesh::io::format_from_path(&path) else { continue };
                let small = entry.metadata().map(|m| m.len() <= 2 << 20).unwrap_or(false);
                if let (true, Ok(bytes)) = (small, std::fs::read(&path)) {
                    out.push((format, bytes));
                }
            }
        }
    }
    out
}

const NOISE: &[u8] = b"0123456789-+.eE/ \n\r\t#fvtxl\x00\xff";
const HUGE: &[&[u8]] = &[b"4294967295", b"99999999999999999999", b"-1", b"1e309", b"nan", b"0"];

/// One mutation of `bytes`.
fn mutate(bytes: &mut Vec<u8>, rng: &mut Lcg, donor: &[u8]) {
    let pick = |rng: &mut Lcg, n: usize| rng.below(n.max(1));
    let n = bytes.len();
    match pick(rng, 7) {
        0 => bytes.truncate(pick(rng, n + 1)),
        1 if n > 0 => {
            let at = pick(rng, n);
            bytes[at] = rng.below(256) as u8;
        }
        2 => {
            let at = pick(rng, n + 1);
            bytes.insert(at, NOISE[pick(rng, NOISE.len())]);
        }
        3 if n > 0 => {
            // Repeat a chunk (long lines, many elements).
            let start = pick(rng, n);
            let len = pick(rng, (n - start).min(4096) + 1);
            let chunk = bytes[start..start + len].to_vec();
            let at = pick(rng, n + 1);
            bytes.splice(at..at, chunk.into_iter().cycle().take(len * (1 + pick(rng, 8))));
        }
        4 if !donor.is_empty() => {
            // Splice in part of another seed (mixed formats).
            let start = pick(rng, donor.len());
            let len = pick(rng, (donor.len() - start).min(4096) + 1);
            let at = pick(rng, n + 1);
            bytes.splice(at..at, donor[start..start + len].iter().copied());
        }
        5 => {
            // Replace a run of digits with a huge or hostile number.
            let digits: Vec<usize> = (0..n).filter(|&i| bytes[i].is_ascii_digit()).collect();
            if let Some(&at) = digits.get(pick(rng, digits.len())) {
                let end = (at..n).find(|&i| !bytes[i].is_ascii_digit()).unwrap_or(n);
                bytes.splice(at..end, HUGE[pick(rng, HUGE.len())].iter().copied());
            }
        }
        _ if n > 0 => {
            let at = pick(rng, n);
            bytes.remove(at);
        }
        _ => bytes.push(NOISE[pick(rng, NOISE.len())]),
    }
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("fuzz_readers: {e}");
            std::process::exit(2);
        }
    };
    let seeds = seeds(args.corpus.as_deref());
    // Findings are reported, not printed by the default panic hook per input.
    std::panic::set_hook(Box::new(|_| {}));
    let mut rng = Lcg::new(args.seed);
    let started = Instant::now();
    let (mut parsed, mut refused, mut findings, mut slowest) = (0u64, 0u64, 0u64, 0.0f64);
    for i in 0..args.inputs {
        let (format, seed) = &seeds[i as usize % seeds.len()];
        let donor = &seeds[rng.below(seeds.len())].1;
        let mut bytes = seed.clone();
        for _ in 0..1 + rng.below(8) {
            mutate(&mut bytes, &mut rng, donor);
        }
        let t = Instant::now();
        let outcome = std::panic::catch_unwind(|| match read_bytes(&bytes, *format, "fuzz") {
            Ok(loaded) => {
                let _ = validate::check(&loaded.mesh);
                let _ = orient::orient(&loaded.mesh);
                true
            }
            Err(_) => false,
        });
        let seconds = t.elapsed().as_secs_f64();
        slowest = slowest.max(seconds);
        match outcome {
            Ok(true) => parsed += 1,
            Ok(false) => refused += 1,
            Err(_) => findings += 1,
        }
        if outcome.is_err() || seconds > args.slow {
            let what = if outcome.is_err() { "panic" } else { "slow" };
            let file = args.out.join(format!("fuzz-{what}-{}-{i}.{format:?}", args.seed));
            let _ = std::fs::write(&file, &bytes);
            eprintln!("finding: {what} ({seconds:.2} s) on input {i}, saved as {}", file.display());
            if outcome.is_ok() {
                findings += 1;
            }
        }
    }
    println!(
        "fuzz_readers: {} inputs from {} seeds in {:.1} s: {parsed} parsed, {refused} refused, \
         {findings} findings (panics or slower than {} s); slowest input {:.3} s",
        args.inputs,
        seeds.len(),
        started.elapsed().as_secs_f64(),
        args.slow,
        slowest
    );
    std::process::exit(i32::from(findings > 0));
}
