//! `CoreSphereMap`: the core's `Embedding` held for `spherify.SphereMap`.
//!
//! The certificate (`valid`, `tp_valid`) is read from the core result and
//! never accepted back from Python: `to_surface` asks the point map built
//! from that same result whether h^-1 is defined.

use std::sync::{Arc, OnceLock};

use numpy::{IntoPyArray, PyArray1, PyArray2, PyReadonlyArrayDyn};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use spherify_mesh::Mesh;
use spherify_sphere::memory_budget::{self, Application};
use spherify_sphere::point_map::PointMap;
use spherify_sphere::{Details, Embedding, GenusZeroMesh, SphereError};

use crate::convert::{rows, to_numpy};
use crate::errors::{mesh_error, point_map_error, resource_error};
use crate::mesh::CoreMesh;

/// A map of a mesh onto the sphere, with its certificate.
#[pyclass(frozen, module = "spherify._core")]
pub struct CoreSphereMap {
    /// The oriented mesh the map belongs to.
    mesh: Arc<Mesh>,
    /// The faces as the caller gave them (before orientation): `to_sphere`
    /// and `to_surface` speak in their corner order.
    caller: Arc<Mesh>,
    embedding: Embedding,
    reoriented_faces: usize,
    /// Built on first use (O(F log F)).
    point_map: OnceLock<PointMap>,
    /// The mesh's checked topology and half-edges, built on first use and
    /// shared by every map made from this one ([`CoreSphereMap::with_embedding`]):
    /// registration moves one map through 10 rounds and 3 pull stages, and
    /// each call checked and linked the same mesh again.
    topology: Arc<OnceLock<Arc<GenusZeroMesh>>>,
    /// For a map whose landmarks were laid out on a refined mesh: per vertex
    /// of `mesh`, a face of the input mesh (caller's faces) and barycentric
    /// weights in its corner order.
    refinement: Option<Arc<Refinement>>,
}

/// The map back from a refined mesh to the input: per refined vertex, an
/// input face and barycentric weights in that face's corner order.
#[derive(Debug, Clone)]
pub struct Refinement {
    /// The input mesh as the caller gave it (before any refinement).
    pub input: Arc<Mesh>,
    pub faces: Vec<u32>,
    pub barycentric: Vec<[f64; 3]>,
}

impl CoreSphereMap {
    /// `caller`: the mesh as the caller gave it (its faces' corner order is
    /// the one the point map speaks); `mesh`: the same mesh oriented.
    pub fn new(
        mesh: Arc<Mesh>,
        caller: Arc<Mesh>,
        embedding: Embedding,
        reoriented_faces: usize,
    ) -> CoreSphereMap {
        CoreSphereMap {
            mesh,
            caller,
            embedding,
            reoriented_faces,
            point_map: OnceLock::new(),
            topology: Arc::new(OnceLock::new()),
            refinement: None,
        }
    }

    /// The same map recording that its mesh refines the input's.
    pub fn with_refinement(mut self, refinement: Refinement) -> CoreSphereMap {
        self.refinement = Some(Arc::new(refinement));
        self
    }

    /// A map of the same meshes with other points (improved, pinned or moved
    /// from this one's): the caller's corner order and the count of turned
    /// faces carry over; the certificate is `embedding`'s own.
    pub fn with_embedding(&self, embedding: Embedding) -> CoreSphereMap {
        let mut map = CoreSphereMap::new(
            Arc::clone(&self.mesh),
            Arc::clone(&self.caller),
            embedding,
            self.reoriented_faces,
        );
        map.refinement = self.refinement.clone();
        map.topology = Arc::clone(&self.topology);
        map
    }

    /// A handle on the mesh's topology ([`genus_zero`]), to be called
    /// without the GIL.
    pub fn topology(&self) -> Arc<OnceLock<Arc<GenusZeroMesh>>> {
        Arc::clone(&self.topology)
    }

    /// The map back to the input, for a map on a refined mesh.
    pub fn refinement(&self) -> Option<&Refinement> {
        self.refinement.as_deref()
    }

    /// The mesh as the caller gave it.
    pub fn caller_mesh(&self) -> Arc<Mesh> {
        Arc::clone(&self.caller)
    }

    /// The oriented mesh, shared.
    pub fn shared_mesh(&self) -> Arc<Mesh> {
        Arc::clone(&self.mesh)
    }

    /// The core's result, certificate included (read-only).
    pub fn embedding(&self) -> &Embedding {
        &self.embedding
    }

    /// The memory policy's check of `app` on `points` points of this map
    /// (the locator already built): a ResourceError before they are copied.
    fn check_points(&self, app: Application, points: usize) -> PyResult<()> {
        let (n, f) = (self.mesh.n_vertices(), self.mesh.n_faces());
        let need = memory_budget::application_need(app, n, f, points);
        memory_budget::check(&need).map_err(resource_error)
    }

    /// Built with the GIL released, outside the `OnceLock`: a thread that
    /// waits on the lock may hold the GIL, which the builder would need back
    /// inside the lock. Two threads racing both build; one result is kept.
    /// Checked first by the memory policy (a ResourceError, not an abort).
    pub(crate) fn point_map(&self, py: Python<'_>) -> PyResult<&PointMap> {
        if let Some(map) = self.point_map.get() {
            return Ok(map);
        }
        let (n, f) = (self.mesh.n_vertices(), self.mesh.n_faces());
        memory_budget::check(&memory_budget::application_need(Application::PointMap, n, f, 0))
            .map_err(resource_error)?;
        let built = crate::pool::detach(py, || {
            PointMap::new(Arc::clone(&self.mesh), &self.embedding)
                .in_corner_order_of(self.caller.faces())
        })?;
        Ok(self.point_map.get_or_init(|| built))
    }
}

#[pymethods]
impl CoreSphereMap {
    /// The oriented mesh (shared with the core, not copied).
    #[getter]
    fn mesh(&self) -> CoreMesh {
        CoreMesh { mesh: Arc::clone(&self.mesh) }
    }

    #[getter]
    fn method(&self) -> &'static str {
        self.embedding.method.as_str()
    }

    /// (n, 3) float64: a new copy on every call.
    fn points<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        to_numpy(py, &self.embedding.result.points)
    }

    /// `(faces (n,) int64, barycentric (n, 3) float64)` for a map laid out
    /// on a refined mesh (one row per vertex of `mesh`; the input's faces and
    /// their corner order), or None.
    #[getter(refinement)]
    #[allow(clippy::type_complexity)]
    fn refinement_arrays<'py>(
        &self,
        py: Python<'py>,
    ) -> Option<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray2<f64>>)> {
        self.refinement.as_ref().map(|r| {
            let faces: Vec<i64> = r.faces.iter().map(|&f| f as i64).collect();
            (PyArray1::from_vec(py, faces), to_numpy(py, &r.barycentric))
        })
    }

    /// The mesh the caller gave before the landmark layout refined it (the
    /// faces `refinement` names), or None for a map on the input mesh.
    #[getter]
    fn refinement_input(&self) -> Option<CoreMesh> {
        self.refinement.as_ref().map(|r| CoreMesh { mesh: Arc::clone(&r.input) })
    }

    #[getter]
    fn iterations(&self) -> usize {
        self.embedding.result.iterations
    }

    #[getter]
    fn status(&self) -> &'static str {
        self.embedding.result.status.name()
    }

    #[getter]
    fn converged(&self) -> bool {
        self.embedding.result.converged()
    }

    #[getter]
    fn message(&self) -> &str {
        &self.embedding.result.message
    }

    /// [(stage, seconds)] in order.
    #[getter]
    fn seconds(&self) -> Vec<(&'static str, f64)> {
        self.embedding.result.seconds.clone()
    }

    /// Faces whose corner order was reversed to orient the mesh outward.
    #[getter]
    fn reoriented_faces(&self) -> usize {
        self.reoriented_faces
    }

    /// The exact tests of thesis 3.4 on the points, as a `SphereReport`.
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        crate::sphere::report_to_py(py, &self.embedding.certificate)
    }

    #[getter]
    fn valid(&self) -> bool {
        self.embedding.certificate.valid
    }

    /// The north and south poles (theta-phi maps only; None otherwise).
    #[getter]
    fn poles(&self) -> Option<(u32, u32)> {
        match &self.embedding.details {
            Details::ThetaPhi(tp) => Some((tp.poles.north, tp.poles.south)),
            _ => None,
        }
    }

    /// theta_phi_array(name) -> a theta-phi map's array: "cut_path",
    /// "theta_phi", "cut_vertices", "cut_faces" or "cut_original". A new copy
    /// on every call; MeshError for another name or another kind of map.
    fn theta_phi_array<'py>(&self, py: Python<'py>, name: &str) -> PyResult<Bound<'py, PyAny>> {
        let array = match &self.embedding.details {
            Details::ThetaPhi(tp) => crate::theta_phi::array(py, tp, name),
            _ => None,
        };
        array.ok_or_else(|| {
            mesh_error(format!("no theta-phi array {name:?} in a {} map", self.method()))
        })
    }

    /// The theta-phi rectangle is certified flip-free (theta-phi maps only;
    /// None otherwise).
    #[getter]
    fn tp_valid(&self) -> Option<bool> {
        match &self.embedding.details {
            Details::ThetaPhi(tp) => Some(tp.tp_valid),
            _ => None,
        }
    }

    /// What the method computed besides the points, in brief: for theta-phi
    /// the refinement, pole-fan and rectangle facts (`theta_phi::details`), for
    /// radial the centre and the kernel LP's account; empty otherwise. Fresh
    /// arrays on every call.
    fn details<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        match &self.embedding.details {
            Details::ThetaPhi(tp) => crate::theta_phi::details(py, tp, &d)?,
            Details::Radial { center, kernel } => {
                d.set_item("center", center.to_vec())?;
                if let Some(k) = kernel {
                    d.set_item("kernel_depth", k.depth)?;
                    d.set_item("lp_pivots", k.pivots)?;
                }
            }
            Details::None => {}
        }
        Ok(d)
    }

    /// Why h^-1 is not defined for this map, or None.
    #[getter]
    fn not_bijective(&self, py: Python<'_>) -> PyResult<Option<String>> {
        Ok(self.point_map(py)?.not_bijective().map(str::to_string))
    }

    /// to_sphere(face_ids (k,) int64, bary (k, 3) float64) -> (k, 3) float64.
    fn to_sphere<'py>(
        &self,
        py: Python<'py>,
        face_ids: PyReadonlyArrayDyn<'_, i64>,
        bary: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let ids = face_ids.as_array();
        if ids.ndim() != 1 {
            return Err(mesh_error(format!(
                "face_ids must have shape (k,), got {:?}",
                ids.shape()
            )));
        }
        let map = self.point_map(py)?;
        self.check_points(Application::ToSphere, ids.len())?;
        let ids: Vec<i64> = ids.iter().copied().collect();
        let bary = rows::<f64, 3>(&bary, "bary")?;
        // Through progress::run so that Ctrl-C stops a long batch.
        let points =
            crate::progress::run(py, None, |go_on| map.to_sphere_with(&ids, &bary, go_on))?
                .map_err(point_map_error)?;
        Ok(to_numpy(py, &points))
    }

    /// to_surface(points (k, 3) float64) -> (face_ids (k,) int64, bary (k, 3),
    /// xyz (k, 3), error (k,) float64): faces and corners in the caller's
    /// order; error bounds the distance of xyz from the exact preimage.
    #[allow(clippy::type_complexity)]
    fn to_surface<'py>(
        &self,
        py: Python<'py>,
        points: PyReadonlyArrayDyn<'_, f64>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray2<f64>>,
        Bound<'py, PyArray1<f64>>,
    )> {
        let map = self.point_map(py)?;
        // Before the rows are copied: a (k, 3) array's elements over 3.
        self.check_points(Application::ToSurface, points.as_array().len() / 3)?;
        let points = rows::<f64, 3>(&points, "points")?;
        let out = crate::progress::run(py, None, |go_on| map.to_surface_with(&points, go_on))?
            .map_err(point_map_error)?;
        let faces: Vec<i64> = out.faces.into_iter().map(i64::from).collect();
        Ok((
            faces.into_pyarray(py),
            to_numpy(py, &out.bary),
            to_numpy(py, &out.xyz),
            out.error.into_pyarray(py),
        ))
    }
}

/// The [`GenusZeroMesh`] of `mesh` from the map's `topology` handle
/// ([`CoreSphereMap::topology`]), built there on first use.
///
/// # Errors
/// The mesh is not a sphere's topology (not for a map's own mesh, which was
/// checked when the map was made).
pub fn genus_zero(
    topology: &OnceLock<Arc<GenusZeroMesh>>,
    mesh: Arc<Mesh>,
) -> Result<Arc<GenusZeroMesh>, SphereError> {
    if let Some(built) = topology.get() {
        return Ok(Arc::clone(built));
    }
    let built = Arc::new(GenusZeroMesh::new(mesh).map_err(SphereError::from)?);
    Ok(Arc::clone(topology.get_or_init(|| built)))
}
