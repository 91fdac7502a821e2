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
    #[error("{call} of {} vertices needs about {} ({} bytes), but {} ({} bytes) {}; a smaller mesh or more memory is needed", grouped(*n_vertices as u64), human(*needed), grouped(*needed), human(*available), grouped(*available), where_from(bound))]
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
    fn an_allocation_the_system_cannot_make_is_an_error_not_an_abort() {
        let err = reserved::<[f64; 3]>(usize::MAX / 8, "the test's points").unwrap_err();
        assert!(matches!(err, ResourceError::Allocation { what: "the test's points", .. }));
        assert!(err.to_string().starts_with("could not allocate"), "{err}");
        assert_eq!(filled(3, 1u8, "three bytes").unwrap(), vec![1, 1, 1]);
    }
}
