//! The memory policy of spherify (issue 26, item 1), stated once: a call
//! whose memory grows with its input is checked before it starts, and a
//! request that cannot fit is an error naming the call, the size and the
//! bytes, never an abort in the allocator.
//!
//! * [`Need`]: what a call will take at its peak, from the measured bytes per
//!   vertex of each method and energy ([`embed_need`], [`improve_need`],
//!   [`certify_need`]), with a margin.
//! * [`available`]: what the process can still get: the address space left
//!   under its `RLIMIT_AS` (the soft limit less `VmSize`, which counts thread
//!   stacks and the allocator's arenas as the limit does) and the machine's
//!   `MemAvailable` plus `SwapFree`, the smaller of the two.
//! * [`check`]: the need against what is available; [`ResourceError::Shortfall`]
//!   when it does not fit, before anything is allocated.
//! * [`filled`] and [`reserved`]: the large per-vertex buffers of the default
//!   path allocated fallibly, so that a need the estimate put too low is still
//!   an error ([`ResourceError::Allocation`]) and not an abort.
//!
//! The bindings call [`check`] before they validate a mesh and map
//! `ResourceError` (and the sparse crate's `SparseError::OutOfMemory`) to the
//! Python `ResourceError`, also a `MemoryError`. A check reads only what the
//! system says about memory; it never changes what a method computes.

use crate::embed::Method;
use crate::methods::progressive::distortion_energy::Energy;
use crate::methods::progressive::improve::ImproveParams;

/// Peak growth of a call per vertex: `base` bytes per vertex at and below
/// [`REFERENCE_VERTICES`], plus `per_doubling` for every doubling of the
/// vertex count above it (a sparse factor fills in by about log n; of the
/// measured calls only the authalic energy's peak grew that way).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    pub base: f64,
    pub per_doubling: f64,
}

/// The vertex count at which the rates' `base` was measured.
pub const REFERENCE_VERTICES: f64 = 100_000.0;

/// Measured peaks are multiplied by this before they are compared with what
/// is available: the peak moves a little with the shape (the fill of a
/// factor, the depth of the hierarchy) and with the allocator's arenas.
pub const MARGIN: f64 = 1.25;

/// Added to every need: the thread each call runs its work on (its stack and
/// its allocator arena: 67 MB of address space measured, and glibc maps 128 MB
/// while it aligns a new arena) and the arenas the worker threads open for
/// the factorising methods (82-95 MB measured).
pub const FIXED_BYTES: u64 = 192 << 20;

impl Rate {
    /// Bytes per vertex at `n` vertices, before the margin.
    pub fn per_vertex(self, n: usize) -> f64 {
        let doublings = (n as f64 / REFERENCE_VERTICES).log2().max(0.0);
        self.base + self.per_doubling * doublings
    }
}

/// Peak growth of `sp.embed` per vertex: validation, orientation, the
/// method, its certificate and the returned map together (how they were
/// measured: the constants below and docs/reliability.md, "Memory").
pub fn embed_rate(method: &Method) -> Rate {
    match method {
        Method::Progressive(p) => progressive_rate(p.energy),
        Method::ThetaPhi(_) => THETA_PHI,
        Method::Gotsman(_) => GOTSMAN,
        Method::Relaxation(_) | Method::Alexa(_) => RELAXATION,
        Method::Radial(_) => RADIAL,
    }
}

/// The progressive method's rate for each energy.
pub fn progressive_rate(energy: Energy) -> Rate {
    match energy {
        Energy::Isometric => PROGRESSIVE,
        // Their global L-BFGS steps keep 2 x 6 curvature pairs and a sparse
        // factor of the preconditioner besides the sweeps' buffers.
        Energy::Stretch
        | Energy::CoarseStretch
        | Energy::Balanced
        | Energy::BalancedWeighted(_)
        | Energy::CoarseBalanced => PROGRESSIVE_GLOBAL_STEPS,
        Energy::Conformal => PROGRESSIVE_CONFORMAL,
        Energy::Authalic => PROGRESSIVE_AUTHALIC,
    }
}

// The measured rates, bytes per vertex (docs/reliability.md, "Memory"): on
// `bumpy_blob` at 100k and 400k vertices (Gotsman at 30k and 60k), in a fresh
// process, the larger of the address space's growth (VmSize sampled every
// 3 ms, less the call's own thread) and the resident set's growth (VmHWM),
// rounded up. The factorising methods' fixed part (about 90 MB of arenas
// opened by the worker threads) is in FIXED_BYTES.
/// Progressive, isometric energy: 746 and 739 measured.
const PROGRESSIVE: Rate = Rate { base: 760.0, per_doubling: 0.0 };
/// Stretch and balanced energies (their global L-BFGS steps: curvature
/// pairs and the preconditioner's sparse factor): address space 3,790-3,870
/// per vertex at 100k less the call's thread (about 670), resident 1,810-1,850;
/// at 400k (balanced) 2,370 and 1,960.
const PROGRESSIVE_GLOBAL_STEPS: Rate = Rate { base: 3_200.0, per_doubling: 100.0 };
/// Conformal energy (the global conformal start's two factorisations): 1,056
/// per vertex between 100k and 400k, on 95 MB.
const PROGRESSIVE_CONFORMAL: Rate = Rate { base: 1_300.0, per_doubling: 0.0 };
/// Authalic energy (the Gauss-Newton steps' factorisations): 2,463 at 100k,
/// 2,966 at 400k.
const PROGRESSIVE_AUTHALIC: Rate = Rate { base: 2_500.0, per_doubling: 250.0 };
/// Theta-phi: 1,060 per vertex between 100k and 400k on 82 MB; 1,011 to 1,213
/// resident from 300k to 10M in docs/benchmarks.md.
const THETA_PHI: Rate = Rate { base: 1_400.0, per_doubling: 0.0 };
/// Gotsman's Newton iteration (its sparse LU): 22,508 at 30k, 22,816 at 60k.
const GOTSMAN: Rate = Rate { base: 23_000.0, per_doubling: 0.0 };
/// Relaxation and Alexa: 468 and 315 resident (no new address space).
const RELAXATION: Rate = Rate { base: 500.0, per_doubling: 0.0 };
/// Radial projection: 262 resident.
const RADIAL: Rate = Rate { base: 300.0, per_doubling: 0.0 };
/// Certifying given points (`from_points`, a stored map restored):
/// validation, half-edges and the exact test; 276 resident.
const CERTIFY: Rate = Rate { base: 300.0, per_doubling: 0.0 };

/// What a call will take at its peak.
#[derive(Debug, Clone, PartialEq)]
pub struct Need {
    /// The call, as the error names it ("embed with method progressive").
    pub call: String,
    pub n_vertices: usize,
    pub bytes: u64,
}

impl Need {
    /// `rate` at the size of a mesh of `n_vertices` and `n_faces`, with the
    /// margin and the fixed part. The size is the larger of the vertex count
    /// and what the faces imply for a genus-0 mesh (`F = 2 V - 4`), so a
    /// face list far longer than its vertices is not under-counted.
    pub fn new(call: String, rate: Rate, n_vertices: usize, n_faces: usize) -> Need {
        let size = n_vertices.max(n_faces / 2 + 2);
        let bytes = MARGIN * rate.per_vertex(size) * size as f64;
        Need {
            call,
            n_vertices,
            bytes: FIXED_BYTES.saturating_add(bytes.min(u64::MAX as f64) as u64),
        }
    }
}

/// What `embed` with `method` needs for a mesh of this size, with landmarks
/// pinned afterwards or not.
pub fn embed_need(method: &Method, n_vertices: usize, n_faces: usize, landmarks: bool) -> Need {
    let mut call = format!("embed with method {}", method.name());
    if let Method::Progressive(p) = method {
        call.push_str(&format!(" (energy {})", p.energy.name()));
    }
    let mut rate = embed_rate(method);
    if landmarks {
        // Pinning runs the energy's sweeps again on a copy of the points.
        let pin = PROGRESSIVE;
        rate = Rate {
            base: rate.base.max(pin.base),
            per_doubling: rate.per_doubling.max(pin.per_doubling),
        };
        call.push_str(" with landmarks");
    }
    Need::new(call, rate, n_vertices, n_faces)
}

/// What `improve` with `params` needs for a mesh of this size.
pub fn improve_need(params: &ImproveParams, n_vertices: usize, n_faces: usize) -> Need {
    let call = format!("improve (energy {})", params.energy.name());
    Need::new(call, progressive_rate(params.energy), n_vertices, n_faces)
}

/// What certifying given points needs (`SphereMap.from_points`, `load_map`,
/// unpickling): validation, half-edges and the exact test.
pub fn certify_need(call: &str, n_vertices: usize, n_faces: usize) -> Need {
    Need::new(call.to_string(), CERTIFY, n_vertices, n_faces)
}

/// The calls that work on a made map or mesh (the applications, the point
/// map, the measures, the readers), each with its measured peak growth: so
/// many bytes per vertex of the mesh or map it is given and so many per item
/// it makes or takes (a point, a pixel, a grid sample, an output vertex).
/// The calls whose work is in the core are checked by the bindings before
/// they start; those whose work is numpy's ask the core through
/// `_core.check_application` with the same names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Application {
    /// Building a map's point locator (the first `to_surface`, `to_sphere` or fit).
    PointMap,
    /// `SphereMap.to_surface` of some points (the locator built).
    ToSurface,
    /// `SphereMap.to_sphere` of some surface points.
    ToSphere,
    /// `harmonics.fit`: samples of the Gauss-Legendre grid.
    HarmonicsFit,
    /// `Harmonics.evaluate`: sphere points.
    HarmonicsEvaluate,
    /// `quality` and `face_quality` of a mesh and its points.
    Quality,
    /// `check` (and `check_raw`) of a mesh.
    Check,
    /// `orient` of a mesh (validation, then the faces made consistent).
    Orient,
    /// `tutte` of a disk (the Laplacian, its solver, the boundary).
    Tutte,
    /// `load` of a mesh file: per byte of the file.
    Load,
    /// `remesh` / `remesh_map`: output vertices (icosphere, to_surface, certificate).
    Remesh,
    /// `geometry_image`: pixels.
    GeometryImage,
    /// `from_geometry_image`: pixels.
    FromGeometryImage,
    /// `texture.uv` with each projection: vertices of the map (the
    /// octahedral projection tries every octant for the faces it must).
    TextureUvCube,
    TextureUvEquirectangular,
    TextureUvOctahedral,
    /// `UVLayout.bake`: pixels of the atlas.
    Bake,
    /// `morph`: vertices of A and of B.
    Morph,
    /// `register` (and so `morph` with a registration): vertices of A and of B.
    Register,
    /// `correspond`: vertices of the maps and points of the common grid.
    Correspond,
}

/// Peak growth of an [`Application`], before the margin: bytes per vertex (of
/// the mesh or maps it is given), bytes per item (what it makes or takes),
/// and bytes per item of the band it works on at a time (the images made in
/// bands of rows: at most [`BAND_PIXELS`] items; 0 for the calls that work
/// on all their items at once, whose `per_item` says it all).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ApplicationRate {
    pub per_vertex: f64,
    pub per_item: f64,
    pub per_band_item: f64,
}

impl Application {
    /// Every application, in the order of docs/reliability.md's table.
    pub const ALL: [Application; 20] = [
        Application::PointMap,
        Application::ToSurface,
        Application::ToSphere,
        Application::HarmonicsFit,
        Application::HarmonicsEvaluate,
        Application::Quality,
        Application::Check,
        Application::Orient,
        Application::Tutte,
        Application::Load,
        Application::Remesh,
        Application::GeometryImage,
        Application::FromGeometryImage,
        Application::TextureUvCube,
        Application::TextureUvEquirectangular,
        Application::TextureUvOctahedral,
        Application::Bake,
        Application::Morph,
        Application::Register,
        Application::Correspond,
    ];

    /// The name errors give and `_core.check_application` takes.
    pub fn name(self) -> &'static str {
        match self {
            Application::PointMap => "point locator",
            Application::ToSurface => "to_surface",
            Application::ToSphere => "to_sphere",
            Application::HarmonicsFit => "harmonics.fit",
            Application::HarmonicsEvaluate => "Harmonics.evaluate",
            Application::Quality => "quality",
            Application::Check => "check",
            Application::Orient => "orient",
            Application::Tutte => "tutte",
            Application::Load => "load",
            Application::Remesh => "remesh",
            Application::GeometryImage => "geometry_image",
            Application::FromGeometryImage => "from_geometry_image",
            Application::TextureUvCube => "texture.uv cube",
            Application::TextureUvEquirectangular => "texture.uv equirectangular",
            Application::TextureUvOctahedral => "texture.uv octahedral",
            Application::Bake => "UVLayout.bake",
            Application::Morph => "morph",
            Application::Register => "register",
            Application::Correspond => "correspond",
        }
    }

    /// What one item is, as the error counts them.
    pub fn item(self) -> &'static str {
        match self {
            Application::ToSurface
            | Application::ToSphere
            | Application::HarmonicsEvaluate
            | Application::Correspond => "points",
            Application::HarmonicsFit => "grid samples",
            Application::Load => "bytes of file",
            Application::Remesh => "output vertices",
            Application::GeometryImage | Application::FromGeometryImage | Application::Bake => {
                "pixels"
            }
            Application::PointMap
            | Application::Quality
            | Application::Check
            | Application::Orient
            | Application::Tutte
            | Application::TextureUvCube
            | Application::TextureUvEquirectangular
            | Application::TextureUvOctahedral
            | Application::Morph
            | Application::Register => "items",
        }
    }

    /// The application named `name` (see [`Application::name`]).
    pub fn from_name(name: &str) -> Option<Application> {
        Application::ALL.into_iter().find(|a| a.name() == name)
    }

    /// The measured rate (docs/reliability.md, "Memory"; `benches/memory_rates.py`
    /// measures them: resident growth, `VmHWM`, in a fresh process at two sizes,
    /// the larger taken and rounded up).
    pub fn rate(self) -> ApplicationRate {
        let (per_vertex, per_item, per_band_item) = match self {
            // Measured at 100k and 400k (vertices, points, pixels or samples):
            // 169 and 193 per vertex.
            Application::PointMap => (200.0, 0.0, 0.0),
            // 155 and 144 per point (the four returned arrays, the core's copy
            // of the points and its located rows).
            Application::ToSurface => (0.0, 160.0, 0.0),
            // 96 and 90.
            Application::ToSphere => (0.0, 100.0, 0.0),
            // 108 per grid sample at both (the samples' surface points; the
            // transform's tables are O(lmax^2)); the locator is checked apart.
            Application::HarmonicsFit => (0.0, 120.0, 0.0),
            // 103 and 120 per point.
            Application::HarmonicsEvaluate => (0.0, 130.0, 0.0),
            // 129 and 181 per vertex (per-face measures, sorted for medians).
            Application::Quality => (200.0, 0.0, 0.0),
            // 109 at both.
            Application::Check => (120.0, 0.0, 0.0),
            // 212 and 168 per vertex (icospheres of 400k and 1.6M vertices,
            // every other face reversed). Before this check, orient of a 3M
            // mesh with 320 MiB to spare aborted the process.
            Application::Orient => (250.0, 0.0, 0.0),
            // 1,120 and 1,212 per vertex (the same icospheres less a face,
            // default options).
            Application::Tutte => (1_300.0, 0.0, 0.0),
            // Per byte of the file: the bytes read whole, then the parsed
            // arrays (see LOAD_BYTES_PER_FILE_BYTE).
            Application::Load => (0.0, LOAD_BYTES_PER_FILE_BYTE, 0.0),
            // 507 and 548 per output vertex: the icosphere made, located on
            // the surface and certified as a map of its own; and the map's
            // locator, per vertex of the map.
            Application::Remesh => (200.0, 560.0, 0.0),
            // Made in bands of rows: the image (24 per pixel) and the
            // locator; a band of a million pixels is in the fixed part.
            Application::GeometryImage => {
                (200.0, GEOMETRY_IMAGE_PER_PIXEL, GEOMETRY_IMAGE_PER_BAND_PIXEL)
            }
            // 233 and 215 per pixel (the glued pixel ids, the faces).
            Application::FromGeometryImage => (0.0, 240.0, 0.0),
            // 862 and 810 per vertex of the map.
            Application::TextureUvCube => (900.0, 0.0, 0.0),
            // 518 and 508.
            Application::TextureUvEquirectangular => (550.0, 0.0, 0.0),
            // 3,916 and 3,769: every octant's projection of the faces that need it.
            Application::TextureUvOctahedral => (4_000.0, 0.0, 0.0),
            // Made in bands of rows like the geometry image: the atlas alone.
            Application::Bake => (0.0, BAKE_PER_PIXEL, BAKE_PER_BAND_PIXEL),
            // Per vertex of A and B together: a registration's (morph's
            // default aligns through one) and the frames' arrays after it.
            Application::Morph => (REGISTRATION_PER_VERTEX, 0.0, 0.0),
            Application::Register => (REGISTRATION_PER_VERTEX, 0.0, 0.0),
            // The largest registration to the reference (as register), and
            // per sample of every shape: its surface points and Procrustes'
            // copies (correspond with rotations measured 842 and 699 per
            // vertex of the pair).
            Application::Correspond => (REGISTRATION_PER_VERTEX, 100.0, 0.0),
        };
        ApplicationRate { per_vertex, per_item, per_band_item }
    }
}

/// A registration's peak per vertex of A and B together (`register`, and
/// `morph` and `correspond`, which register): the warp (the default)
/// measured 1,236-1,245 at 100k + 100k and 947-1,181 at 400k + 400k (the
/// descriptor pairs and the scaffold's refinements since it was 1,050 and
/// 625); rotation 768 and 680.
const REGISTRATION_PER_VERTEX: f64 = 1_300.0;

/// `load`'s peak per byte of the file (the file is read whole, then parsed):
/// 1.0-1.5 measured on binary PLY and OBJ, 1.9 on binary STL (50 bytes a
/// face, welded), of icospheres of 100k and 400k vertices.
const LOAD_BYTES_PER_FILE_BYTE: f64 = 2.5;
/// Pixels in a band of rows of `geometry_image` and `UVLayout.bake`
/// (`_BAND_PIXELS` of `_geometry_image.py` and `texture.py`).
pub const BAND_PIXELS: usize = 1 << 18;
/// `geometry_image` per pixel of the image (its (n, n, 3) float64) ...
const GEOMETRY_IMAGE_PER_PIXEL: f64 = 30.0;
/// ... and per pixel of the band being located: 221 and 208 per pixel when
/// the image is one band (100k and 400k pixels).
const GEOMETRY_IMAGE_PER_BAND_PIXEL: f64 = 230.0;
/// `UVLayout.bake` per pixel of the atlas ...
const BAKE_PER_PIXEL: f64 = 30.0;
/// ... and per pixel of the band: 156 and 161 per pixel in one band (the
/// directions, the checkerboard's colours).
const BAKE_PER_BAND_PIXEL: f64 = 170.0;

/// What `app` needs on a mesh (or maps) of `n_vertices` and `n_faces` with
/// `items` of its items, margin and fixed part included. The call is named
/// with its items ("geometry_image (16,785,409 pixels)").
pub fn application_need(app: Application, n_vertices: usize, n_faces: usize, items: usize) -> Need {
    let rate = app.rate();
    let size = n_vertices.max(n_faces / 2 + 2);
    let band = rate.per_band_item * items.min(BAND_PIXELS) as f64;
    let bytes = MARGIN * (rate.per_vertex * size as f64 + rate.per_item * items as f64 + band);
    let mut call = app.name().to_string();
    if rate.per_item > 0.0 {
        call.push_str(&format!(" ({} {})", grouped(items as u64), app.item()));
    }
    Need { call, n_vertices, bytes: FIXED_BYTES.saturating_add(bytes.min(u64::MAX as f64) as u64) }
}

/// Which bound [`available`] found tighter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bound {
    /// The soft `RLIMIT_AS` of the process, less its current `VmSize`.
    AddressSpace { limit: u64, in_use: u64 },
    /// `MemAvailable` plus `SwapFree` of `/proc/meminfo`.
    Memory,
}

/// What the process can still get, and which bound said so; `None` where the
/// system says neither (not Linux, no `/proc`): then nothing is refused up
/// front, and only the fallible allocations stand between a call and an abort.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Available {
    pub bytes: u64,
    pub bound: Bound,
}

/// Reads the bounds from `/proc`; see [`Available`].
pub fn available() -> Option<Available> {
    let address_space = address_space_limit().and_then(|limit| {
        let in_use = proc_kb("/proc/self/status", "VmSize:")?;
        Some(Available {
            bytes: limit.saturating_sub(in_use),
            bound: Bound::AddressSpace { limit, in_use },
        })
    });
    let memory = proc_kb("/proc/meminfo", "MemAvailable:").map(|free| Available {
        bytes: free.saturating_add(proc_kb("/proc/meminfo", "SwapFree:").unwrap_or(0)),
        bound: Bound::Memory,
    });
    match (address_space, memory) {
        (Some(a), Some(m)) => Some(if a.bytes <= m.bytes { a } else { m }),
        (a, m) => a.or(m),
    }
}

/// The soft `RLIMIT_AS` from `/proc/self/limits` ("Max address space"), in
/// bytes; `None` when unlimited or unreadable.
fn address_space_limit() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/limits").ok()?;
    let line = text.lines().find(|l| l.starts_with("Max address space"))?;
    line["Max address space".len()..].split_whitespace().next()?.parse().ok()
}

/// The value of `key` (in kB) in a `/proc` file of `key value kB` lines, in bytes.
fn proc_kb(path: &str, key: &str) -> Option<u64> {
    let text = std::fs::read_to_string(path).ok()?;
    let line = text.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kb.saturating_mul(1024))
}

/// How a call was refused for memory.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ResourceError {
    /// The estimate of the call does not fit in what is available.
    #[error("{call}{} needs about {} ({} bytes), but {} ({} bytes) {}; a smaller mesh or more memory is needed", of_vertices(*n_vertices), human(*needed), grouped(*needed), human(*available), grouped(*available), where_from(bound))]
    Shortfall { call: String, n_vertices: usize, needed: u64, available: u64, bound: Bound },
    /// An allocation the estimate allowed was refused by the system.
    #[error("could not allocate {} ({} bytes) for {what}: the system refused the memory", human(*bytes), grouped(*bytes))]
    Allocation { what: &'static str, bytes: u64 },
}

impl ResourceError {
    /// The bytes asked for.
    pub fn bytes(&self) -> u64 {
        match self {
            ResourceError::Shortfall { needed, .. } => *needed,
            ResourceError::Allocation { bytes, .. } => *bytes,
        }
    }

    /// The bytes that were available, where they were measured.
    pub fn available(&self) -> Option<u64> {
        match self {
            ResourceError::Shortfall { available, .. } => Some(*available),
            ResourceError::Allocation { .. } => None,
        }
    }
}

/// " of 2,000 vertices", or nothing for a call that is given no mesh
/// (`Harmonics.evaluate`, a file not yet read).
fn of_vertices(n_vertices: usize) -> String {
    if n_vertices == 0 {
        String::new()
    } else {
        format!(" of {} vertices", grouped(n_vertices as u64))
    }
}

fn where_from(bound: &Bound) -> String {
    match bound {
        Bound::AddressSpace { limit, in_use } => format!(
            "are left under the process's address-space limit (RLIMIT_AS {}, {} in use)",
            human(*limit),
            human(*in_use)
        ),
        Bound::Memory => "are available on the machine (MemAvailable plus SwapFree)".to_string(),
    }
}

/// 10000000 as "10,000,000".
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::with_capacity(digits.len() + digits.len() / 3);
    for (i, d) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(d);
    }
    out
}

/// Bytes for people, in the units of `ulimit -v` and of "a 4 GB limit"
/// (`4 << 30`): "9.7 GiB", "640 MiB".
fn human(bytes: u64) -> String {
    let b = bytes as f64;
    if b >= (1u64 << 30) as f64 {
        format!("{:.1} GiB", b / (1u64 << 30) as f64)
    } else if b >= (1u64 << 20) as f64 {
        format!("{:.0} MiB", b / (1u64 << 20) as f64)
    } else {
        format!("{:.0} KiB", b / 1024.0)
    }
}

/// Refuses `need` when it does not fit in what is [`available`] now.
///
/// # Errors
/// [`ResourceError::Shortfall`] naming the call, the vertex count, the bytes
/// needed and the bytes available.
pub fn check(need: &Need) -> Result<(), ResourceError> {
    match available() {
        Some(a) if need.bytes > a.bytes => Err(ResourceError::Shortfall {
            call: need.call.clone(),
            n_vertices: need.n_vertices,
            needed: need.bytes,
            available: a.bytes,
            bound: a.bound,
        }),
        _ => Ok(()),
    }
}

/// `n` copies of `value`, the memory reserved fallibly.
///
/// # Errors
/// [`ResourceError::Allocation`] naming `what` and the bytes.
pub fn filled<T: Clone>(n: usize, value: T, what: &'static str) -> Result<Vec<T>, ResourceError> {
    let mut v = reserved(n, what)?;
    v.resize(n, value);
    Ok(v)
}

/// An empty vector with room for exactly `n` items, reserved fallibly.
///
/// # Errors
/// [`ResourceError::Allocation`] naming `what` and the bytes.
pub fn reserved<T>(n: usize, what: &'static str) -> Result<Vec<T>, ResourceError> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| ResourceError::Allocation {
        what,
        bytes: (n as u64).saturating_mul(std::mem::size_of::<T>() as u64),
    })?;
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::embed::MethodName;

    #[test]
    fn every_method_needs_more_than_its_points_and_grows_with_the_mesh() {
        for name in MethodName::ALL {
            let method = name.with_defaults().unwrap();
            let small = embed_need(&method, 1_000, 1_996, false);
            let large = embed_need(&method, 10_000_000, 19_999_996, false);
            assert!(small.bytes >= FIXED_BYTES, "{name}");
            assert!(large.bytes > 24 * 10_000_000 + FIXED_BYTES, "{name}: {}", large.bytes);
            assert!(large.bytes > small.bytes, "{name}");
            assert!(large.call.contains(name.as_str()));
        }
    }

    #[test]
    fn a_face_list_longer_than_its_vertices_counts_as_the_larger_mesh() {
        let method = MethodName::Progressive.with_defaults().unwrap();
        let few = embed_need(&method, 4, 4, false);
        let many_faces = embed_need(&method, 4, 2_000_000, false);
        assert!(many_faces.bytes > few.bytes + 1_000_000 * 100);
    }

    #[test]
    fn a_need_beyond_what_is_available_is_refused_naming_the_call_and_the_bytes() {
        let need =
            Need { call: "embed with method theta_phi".into(), n_vertices: 7, bytes: u64::MAX };
        match check(&need) {
            // Without /proc nothing is refused up front.
            Ok(()) => assert!(available().is_none()),
            Err(err) => {
                assert_eq!(err.bytes(), u64::MAX);
                let text = err.to_string();
                assert!(
                    text.starts_with("embed with method theta_phi of 7 vertices needs about"),
                    "{text}"
                );
                assert!(text.contains("(18,446,744,073,709,551,615 bytes)"), "{text}");
            }
        }
        let fits = Need { call: "x".into(), n_vertices: 7, bytes: 1 };
        assert_eq!(check(&fits), Ok(()));
    }

    #[test]
    fn every_application_is_named_once_and_grows_with_its_size() {
        for app in Application::ALL {
            assert_eq!(Application::from_name(app.name()), Some(app));
            let rate = app.rate();
            let small = application_need(app, 1_000, 1_996, 1_000);
            let large = application_need(app, 10_000_000, 19_999_996, 10_000_000);
            assert!(small.bytes >= FIXED_BYTES, "{}", app.name());
            assert!(large.bytes > small.bytes, "{}", app.name());
            // Something grows with the mesh or with the items, at more than
            // the 24 bytes of a point or pixel (a file's byte is held at least
            // once while it is read).
            let floor = if app == Application::Load { 1.0 } else { 24.0 };
            assert!(rate.per_vertex + rate.per_item >= floor, "{}", app.name());
            assert!(large.call.starts_with(app.name()));
        }
        assert_eq!(Application::from_name("texture.uv"), None);
    }

    #[test]
    fn a_banded_image_counts_one_band_and_the_whole_image() {
        let image = |pixels| application_need(Application::GeometryImage, 0, 0, pixels).bytes;
        let one_band = image(BAND_PIXELS) - image(BAND_PIXELS / 2);
        let beyond = image(4 * BAND_PIXELS) - image(3 * BAND_PIXELS);
        // Beyond one band only the image grows.
        assert!(beyond < one_band, "{beyond} {one_band}");
        let text = check(&application_need(Application::GeometryImage, 7, 10, usize::MAX / 64))
            .map(|()| String::new())
            .unwrap_or_else(|e| e.to_string());
        assert!(text.is_empty() || text.starts_with("geometry_image ("), "{text}");
    }

    #[test]
    fn an_allocation_the_system_cannot_make_is_an_error_not_an_abort() {
        let err = reserved::<[f64; 3]>(usize::MAX / 8, "the test's points").unwrap_err();
        assert!(matches!(err, ResourceError::Allocation { what: "the test's points", .. }));
        assert!(err.to_string().starts_with("could not allocate"), "{err}");
        assert_eq!(filled(3, 1u8, "three bytes").unwrap(), vec![1, 1, 1]);
    }
}
