//! One entry point for every spherical method: [`embed`] takes a validated
//! [`GenusZeroMesh`] and a [`Method`] with its parameters, runs the method,
//! and certifies the points with the exact tests of thesis 3.4. The
//! certificate is computed here, from the points that are returned, and
//! travels with them in the one result type, [`Embedding`].

use std::fmt;
use std::str::FromStr;
use std::time::Instant;

use crate::certificate::validity::{check_sphere, SphereReport};
use crate::embedding::SphereEmbedding;
use crate::error::SphereError;
use crate::genus_zero::GenusZeroMesh;
use crate::methods::alexa::{alexa_with_progress, AlexaParams};
use crate::methods::gotsman::{gotsman_with_progress, GotsmanParams};
use crate::methods::progressive::improve::{improve, ImproveParams};
use crate::methods::progressive::landmarks::{
    pin_landmarks, pin_or_lay_out, Landmarks, PinParams, Refined,
};
use crate::methods::progressive::move_towards::{move_towards_from, TowardsParams};
use crate::methods::progressive::target_pull::{pull_towards_from, PullParams};
use crate::methods::progressive::{progressive, require_valid_start, ProgressiveParams};
use crate::methods::radial::kernel::KernelPoint;
use crate::methods::radial::{radial_map, Center};
use crate::methods::relaxation::{relaxation_with_progress, RelaxationParams};
use crate::methods::theta_phi::{theta_phi_with_progress, ThetaPhi, ThetaPhiParams};

/// A spherical method and its parameters.
#[derive(Debug, Clone)]
pub enum Method {
    /// Radial projection (thesis 3.5) from a centre.
    Radial(Center),
    /// Iterative relaxation (5.2).
    Relaxation(RelaxationParams),
    /// Alexa's method (5.3).
    Alexa(AlexaParams),
    /// Gotsman, Gu and Sheffer's spherical Tutte system (5.1).
    Gotsman(GotsmanParams),
    /// The theta-phi method (ch. 6).
    ThetaPhi(ThetaPhiParams),
    /// Progressive meshes with exact insertion and flip-free optimisation (9.3.3).
    Progressive(ProgressiveParams),
}

/// The name of a [`Method`], without parameters: what `sp.methods()` lists.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MethodName {
    Radial,
    Relaxation,
    Alexa,
    Gotsman,
    ThetaPhi,
    Progressive,
    /// Not a method of [`embed`]: a map lowered by [`improve_embedding`].
    Improve,
    /// Not a method [`embed`] runs: points made elsewhere, certified by
    /// [`crate::point_map::from_points::from_points`]. So it is not in [`MethodName::ALL`]
    /// and has no parameters.
    Points,
}

impl MethodName {
    /// Every method [`embed`] runs, in the order the documentation lists them.
    pub const ALL: [MethodName; 6] = [
        MethodName::Radial,
        MethodName::Relaxation,
        MethodName::Alexa,
        MethodName::Gotsman,
        MethodName::ThetaPhi,
        MethodName::Progressive,
    ];

    pub fn as_str(self) -> &'static str {
        match self {
            MethodName::Radial => "radial",
            MethodName::Relaxation => "relaxation",
            MethodName::Alexa => "alexa",
            MethodName::Gotsman => "gotsman",
            MethodName::ThetaPhi => "theta_phi",
            MethodName::Progressive => "progressive",
            MethodName::Improve => "improve",
            MethodName::Points => "points",
        }
    }

    /// The method with its default parameters; `None` for
    /// [`MethodName::Points`], which [`embed`] does not run.
    pub fn with_defaults(self) -> Option<Method> {
        Some(match self {
            MethodName::Radial => Method::Radial(Center::default()),
            MethodName::Relaxation => Method::Relaxation(RelaxationParams::default()),
            MethodName::Alexa => Method::Alexa(AlexaParams::default()),
            MethodName::Gotsman => Method::Gotsman(GotsmanParams::default()),
            MethodName::ThetaPhi => Method::ThetaPhi(ThetaPhiParams::default()),
            MethodName::Progressive => Method::Progressive(ProgressiveParams::default()),
            MethodName::Points | MethodName::Improve => return None,
        })
    }
}

impl fmt::Display for MethodName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A method name that [`MethodName::from_str`] does not know.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown method {name:?}; available: {}", available())]
pub struct UnknownMethod {
    pub name: String,
}

fn available() -> String {
    MethodName::ALL.iter().map(|m| m.as_str()).collect::<Vec<_>>().join(", ")
}

impl FromStr for MethodName {
    type Err = UnknownMethod;

    fn from_str(name: &str) -> Result<MethodName, UnknownMethod> {
        MethodName::ALL
            .into_iter()
            .find(|m| m.as_str() == name)
            .ok_or_else(|| UnknownMethod { name: name.to_string() })
    }
}

impl Method {
    pub fn name(&self) -> MethodName {
        match self {
            Method::Radial(_) => MethodName::Radial,
            Method::Relaxation(_) => MethodName::Relaxation,
            Method::Alexa(_) => MethodName::Alexa,
            Method::Gotsman(_) => MethodName::Gotsman,
            Method::ThetaPhi(_) => MethodName::ThetaPhi,
            Method::Progressive(_) => MethodName::Progressive,
        }
    }
}

/// What a method computed besides the points, where it computed more.
#[derive(Debug, Clone)]
pub enum Details {
    None,
    Radial {
        /// The point `m` of eq. 3.17.
        center: [f64; 3],
        /// The kernel LP's account, for [`Center::Kernel`].
        kernel: Option<KernelPoint>,
    },
    ThetaPhi(Box<ThetaPhi>),
}

/// A map of a mesh onto the sphere, and the proof of what it is.
#[derive(Debug, Clone)]
pub struct Embedding {
    pub method: MethodName,
    /// The points (one per vertex of the mesh, in its order) and how the
    /// method ended.
    pub result: SphereEmbedding,
    /// The exact tests of thesis 3.4 on `result.points`: `valid` means the
    /// points with minor-arc edges form a GC-embedding, a bijection.
    pub certificate: SphereReport,
    pub details: Details,
}

impl Embedding {
    /// Certifies a method's points for `mesh`, timing the check as the stage
    /// `"certify"`.
    pub(crate) fn certified(
        mesh: &GenusZeroMesh,
        method: MethodName,
        mut result: SphereEmbedding,
        details: Details,
    ) -> Embedding {
        let started = Instant::now();
        let certificate = check_sphere(mesh.faces(), &result.points);
        result.seconds.push(("certify", started.elapsed().as_secs_f64()));
        Embedding { method, result, certificate, details }
    }

    /// Whether h^-1 is defined: the theta-phi rectangle is certified, or the
    /// points form a valid GC-embedding.
    pub fn bijective(&self) -> bool {
        match &self.details {
            Details::ThetaPhi(tp) => tp.tp_valid,
            _ => self.certificate.valid,
        }
    }
}

/// Maps `mesh` onto the unit sphere with `method`, then certifies the points.
///
/// `progress(done, total)` hears from the long stages that report (the exact
/// graph poles of theta-phi); returning `false` stops them with
/// [`SphereError::Cancelled`]. Every method also polls `progress(0, 0)` from
/// its loops, at most a fraction of a second apart on large meshes except
/// inside one sparse factorisation: a poll reports nothing (`done` 0 is never
/// progress) and only asks whether to go on.
///
/// # Errors
/// Whatever the method reports: bad parameters, a radial centre outside the
/// kernel, a failed solve, a non-converged run under `strict`, a cancellation.
pub fn embed(
    mesh: &GenusZeroMesh,
    method: &Method,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Embedding, SphereError> {
    crate::certificate::geometry_range::check_geometry(mesh)?;
    let (result, details) = match method {
        Method::Radial(center) => {
            let r = radial_map(mesh, *center)?;
            (r.embedding, Details::Radial { center: r.center, kernel: r.kernel })
        }
        Method::Relaxation(params) => {
            (relaxation_with_progress(mesh, params, progress)?, Details::None)
        }
        Method::Alexa(params) => (alexa_with_progress(mesh, params, progress)?, Details::None),
        Method::Gotsman(params) => (gotsman_with_progress(mesh, params, progress)?, Details::None),
        Method::ThetaPhi(params) => {
            let (points, tp) = theta_phi_with_progress(mesh, params, progress)?;
            (points, Details::ThetaPhi(Box::new(tp)))
        }
        Method::Progressive(params) => (progressive(mesh, params, progress)?, Details::None),
    };
    Ok(Embedding::certified(mesh, method.name(), result, details))
}

/// Lowers a distortion energy of `start`'s points with flip-free moves
/// ([`improve`]) and certifies the result. The improved map is a plain
/// GC-embedding (method [`MethodName::Improve`]): a theta-phi start's map h
/// does not describe the moved points.
///
/// # Errors
/// [`SphereError::InvalidStart`] when `start`'s points are not a valid
/// GC-embedding; bad parameters; cancellation.
pub fn improve_embedding(
    mesh: &GenusZeroMesh,
    start: &Embedding,
    params: &ImproveParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Embedding, SphereError> {
    require_valid_start(&start.certificate)?;
    let mut result = improve(mesh, &start.result.points, params, progress)?;
    result.message = format!("improved from {}: {}", start.method, result.message);
    let improved = Embedding::certified(mesh, MethodName::Improve, result, Details::None);
    if improved.certificate.valid {
        return Ok(improved);
    }
    // Flip-free moves cannot change the covering degree in exact arithmetic,
    // but the area sum is rounded: on a start at the double-precision floor
    // it could read otherwise. Never give back a map less valid than the start.
    let mut kept = start.result.clone();
    kept.message = format!(
        "kept the {} map unchanged: the improved points did not pass the certificate ({} faces \
         not positive, covering degree {})",
        start.method,
        improved.certificate.flipped_faces.len(),
        improved.certificate.covering_degree
    );
    kept.iterations = 0;
    Ok(Embedding::certified(mesh, MethodName::Improve, kept, Details::None))
}

/// The map `start` with its landmarks pinned exactly to their targets
/// ([`pin_landmarks`]) and certified. The method's name is kept, but not what
/// it computed besides the points: a theta-phi start becomes a plain
/// GC-embedding ([`MethodName::Improve`]), since its map h no longer
/// describes the moved points. The stage `"landmarks"` is added to the
/// start's seconds.
///
/// # Errors
/// [`SphereError::InvalidStart`] when `start` is not a valid GC-embedding
/// (`MapError` in Python); [`SphereError::LandmarkConflict`]; cancellation.
pub fn pin_embedding(
    mesh: &GenusZeroMesh,
    start: &Embedding,
    landmarks: &Landmarks,
    params: &PinParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Embedding, SphereError> {
    require_valid_start(&start.certificate)?;
    let (pinned, _) = pin_landmarks(mesh, &start.result.points, landmarks, params, progress)?;
    let mut result = start.result.clone();
    result.seconds.retain(|(stage, _)| *stage != "certify");
    result.seconds.extend(pinned.seconds);
    result.points = pinned.points;
    result.message = format!("{}; {}", start.result.message, pinned.message);
    let (method, details) = match &start.details {
        Details::ThetaPhi(_) => (MethodName::Improve, Details::None),
        other => (start.method, other.clone()),
    };
    Ok(Embedding::certified(mesh, method, result, details))
}

/// [`pin_embedding`], except that where the drag stalls the landmarks are
/// laid out constructively on a refined mesh
/// ([`crate::methods::progressive::landmarks::path_layout`]): the map is
/// then certified on that mesh, returned with it.
///
/// # Errors
/// As [`pin_embedding`], less the stalled drag.
pub fn pin_or_refine_embedding(
    mesh: &GenusZeroMesh,
    start: &Embedding,
    landmarks: &Landmarks,
    params: &PinParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<(Embedding, Option<Refined>), SphereError> {
    require_valid_start(&start.certificate)?;
    let (pinned, refined) =
        pin_or_lay_out(mesh, &start.result.points, landmarks, params, progress)?;
    let mut result = start.result.clone();
    result.seconds.retain(|(stage, _)| *stage != "certify");
    result.seconds.extend(pinned.seconds);
    result.points = pinned.points;
    result.message = format!("{}; {}", start.result.message, pinned.message);
    let (method, details) = match (&start.details, &refined) {
        (Details::ThetaPhi(_), _) | (_, Some(_)) => (MethodName::Improve, Details::None),
        (other, None) => (start.method, other.clone()),
    };
    let on = refined.as_ref().map_or(mesh, |r| &r.mesh);
    Ok((Embedding::certified(on, method, result, details), refined))
}

/// [`crate::methods::progressive::move_towards::move_towards`] from
/// `start`'s points, certified as a plain GC-embedding
/// ([`MethodName::Improve`]). The start is not tested again: `start` carries
/// its certificate.
///
/// # Errors
/// As [`crate::methods::progressive::move_towards::move_towards`].
pub fn move_towards_embedding(
    mesh: &GenusZeroMesh,
    start: &Embedding,
    targets: &[[f64; 3]],
    weights: &[f64],
    fixed: &[i64],
    params: &TowardsParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Embedding, SphereError> {
    let result = move_towards_from(
        mesh,
        &start.result.points,
        Some(&start.certificate),
        targets,
        weights,
        fixed,
        params,
        progress,
    )?;
    Ok(Embedding::certified(mesh, MethodName::Improve, result, Details::None))
}

/// [`crate::methods::progressive::target_pull::pull_towards`] from
/// `start`'s points, certified as a plain GC-embedding
/// ([`MethodName::Improve`]). The start is not tested again: `start` carries
/// its certificate.
///
/// # Errors
/// As [`crate::methods::progressive::target_pull::pull_towards`].
#[allow(clippy::too_many_arguments)]
pub fn pull_towards_embedding(
    mesh: &GenusZeroMesh,
    start: &Embedding,
    rest: Option<&[[f64; 3]]>,
    targets: &[[f64; 3]],
    weights: &[f64],
    fixed: &[i64],
    params: &PullParams,
    progress: &(dyn Fn(usize, usize) -> bool + Sync),
) -> Result<Embedding, SphereError> {
    let result = pull_towards_from(
        mesh,
        &start.result.points,
        Some(&start.certificate),
        rest,
        targets,
        weights,
        fixed,
        params,
        progress,
    )?;
    Ok(Embedding::certified(mesh, MethodName::Improve, result, Details::None))
}

#[cfg(test)]
mod tests {
    use super::*;
    use spherify_mesh::solids::{octahedron, octasphere};

    #[test]
    fn names_round_trip_and_unknown_names_list_the_methods() {
        for name in MethodName::ALL {
            assert_eq!(name.as_str().parse::<MethodName>(), Ok(name));
            assert_eq!(name.with_defaults().map(|m| m.name()), Some(name));
        }
        assert!(MethodName::Points.with_defaults().is_none());
        assert!("points".parse::<MethodName>().is_err());
        let err = "tutte".parse::<MethodName>().unwrap_err();
        assert_eq!(
            err.to_string(),
            "unknown method \"tutte\"; available: radial, relaxation, alexa, gotsman, theta_phi, progressive"
        );
    }

    #[test]
    fn every_method_maps_a_round_mesh_and_the_certificate_is_the_exact_test() {
        let mesh = GenusZeroMesh::new(octasphere(2)).unwrap();
        for name in MethodName::ALL {
            let e = embed(&mesh, &name.with_defaults().unwrap(), &|_, _| true).unwrap();
            assert_eq!(e.method, name);
            assert_eq!(e.result.points.len(), mesh.n_vertices());
            assert!(e.certificate.valid, "{name}: {}", e.result.message);
            assert_eq!(e.certificate, check_sphere(mesh.faces(), &e.result.points));
            assert!(e.bijective());
            assert_eq!(e.result.seconds.last().map(|s| s.0), Some("certify"));
        }
    }

    #[test]
    fn every_method_but_radial_stops_when_a_poll_says_so() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let mesh = GenusZeroMesh::new(octasphere(2)).unwrap();
        for name in MethodName::ALL {
            if name == MethodName::Radial {
                continue; // one pass, nothing to poll
            }
            // Stop at the first poll: the method ends there with Cancelled,
            // not at its end.
            let polls = AtomicUsize::new(0);
            let stop_after = 0;
            let progress = |done: usize, _total: usize| {
                done != 0 || polls.fetch_add(1, Ordering::SeqCst) < stop_after
            };
            let err = embed(&mesh, &name.with_defaults().unwrap(), &progress).unwrap_err();
            assert!(matches!(err, SphereError::Cancelled { .. }), "{name}: {err}");
            assert_eq!(polls.load(Ordering::SeqCst), stop_after + 1, "{name}");
        }
    }

    #[test]
    fn theta_phi_refuses_cotangent_weights_in_the_core() {
        use spherify_sparse::weights::Weights;
        let mesh = GenusZeroMesh::new(octahedron()).unwrap();
        let method =
            Method::ThetaPhi(ThetaPhiParams { weights: Weights::Cotangent, ..Default::default() });
        let err = embed(&mesh, &method, &|_, _| true).unwrap_err();
        assert!(matches!(err, SphereError::InvalidParameter { name: "weights", .. }), "{err}");
    }
}
