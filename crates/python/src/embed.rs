//! `embed` and `methods`: every spherical method through the core's one
//! entry point, `spherify_sphere::embed`. The method's options are read by the
//! file named after it; nothing here decides anything about a method.

use std::str::FromStr;
use std::sync::Arc;

use numpy::PyReadonlyArrayDyn;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use spherify_mesh::io::PlyEncoding;
use spherify_sparse::weights::Weights;
use spherify_sparse::SolverKind;
use spherify_sphere::memory_budget;
use spherify_sphere::method_options::{OptionDefault, OptionKind, OptionValue};
use spherify_sphere::methods::theta_phi::{PoleChoice, ThetaPhiParams};
use spherify_sphere::point_map::from_points::from_points as core_from_points;
use spherify_sphere::{
    embed as core_embed, improve_embedding, pin_or_refine_embedding, GenusZeroMesh, Method,
    MethodName, SphereError,
};

use crate::convert::rows;
use crate::errors::{mesh_error, sphere_error};
use crate::mesh::CoreMesh;
use crate::options::Options;
use crate::sphere_map::{CoreSphereMap, Refinement};

/// methods() -> list of the method names `embed` accepts, from the core.
#[pyfunction]
pub fn methods() -> Vec<&'static str> {
    MethodName::ALL.iter().map(|m| m.as_str()).collect()
}

/// choices() -> the names of the core's closed choices, for the CLI and the
/// docs: methods, weights (all, and those theta-phi accepts), pole choices,
/// solvers and PLY encodings.
#[pyfunction]
pub fn choices(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("methods", methods())?;
    d.set_item("weights", Weights::NAMES.to_vec())?;
    d.set_item("theta_phi_weights", ThetaPhiParams::WEIGHTS.to_vec())?;
    d.set_item("poles", PoleChoice::NAMES.to_vec())?;
    d.set_item("solvers", SolverKind::NAMES.to_vec())?;
    d.set_item("ply_encodings", PlyEncoding::NAMES.to_vec())?;
    d.set_item(
        "energies",
        spherify_sphere::methods::progressive::distortion_energy::Energy::NAMES.to_vec(),
    )?;
    Ok(d)
}

fn option_value(py: Python<'_>, value: OptionValue) -> PyResult<Bound<'_, PyAny>> {
    Ok(match value {
        OptionValue::Count(n) => n.into_pyobject(py)?.into_any(),
        OptionValue::Number(x) => x.into_pyobject(py)?.into_any(),
        OptionValue::Flag(b) => pyo3::types::PyBool::new(py, b).to_owned().into_any(),
        OptionValue::Name(s) => s.into_pyobject(py)?.into_any(),
    })
}

/// method_options() -> {method: [option, ...]}: the core's one table of
/// every method's keyword options (and `improve`'s), each a dict with `name`,
/// `kind` (count, number, flag, name, name_or_vertex_pair, name_or_point,
/// points), `minimum` (counts), `choices` (names), `default` (a value, or
/// None when the method decides), `default_by` ({name of `depends_on`:
/// value} where the default depends on another option), `requires` ((option,
/// name) or None) and `help`. Python's API, the batch and the CLI read it.
#[pyfunction]
pub fn method_options(py: Python<'_>) -> PyResult<Bound<'_, PyDict>> {
    let table = PyDict::new(py);
    for method in MethodName::ALL.into_iter().chain([MethodName::Improve]) {
        let rows = PyList::empty(py);
        for option in method.options() {
            let d = PyDict::new(py);
            d.set_item("name", option.name)?;
            d.set_item("kind", option.kind.name())?;
            if let OptionKind::Count { minimum } = option.kind {
                d.set_item("minimum", minimum)?;
            }
            d.set_item("choices", option.kind.choices().to_vec())?;
            let (default, depends_on, default_by) = match option.default {
                OptionDefault::Value(v) => (Some(option_value(py, v)?), None, None),
                OptionDefault::Unset => (None, None, None),
                OptionDefault::Depends { on, values } => {
                    let by = PyDict::new(py);
                    for (name, value) in values {
                        by.set_item(name, option_value(py, value)?)?;
                    }
                    (None, Some(on), Some(by))
                }
            };
            d.set_item("default", default)?;
            d.set_item("depends_on", depends_on)?;
            d.set_item("default_by", default_by)?;
            d.set_item("requires", option.requires)?;
            d.set_item("help", option.help)?;
            rows.append(d)?;
        }
        table.set_item(method.as_str(), rows)?;
    }
    Ok(table)
}

/// The core's `Method` for `name` with the options given (read by the file
/// named after the method).
pub(crate) fn method(name: MethodName, options: &Options<'_>) -> PyResult<Method> {
    match name {
        MethodName::Radial => crate::radial::method(options),
        MethodName::Relaxation => crate::relaxation::relaxation(options),
        MethodName::Alexa => crate::relaxation::alexa(options),
        MethodName::Gotsman => crate::gotsman::method(options),
        MethodName::ThetaPhi => crate::theta_phi::method(options),
        MethodName::Progressive => crate::progressive::method(options),
        MethodName::Improve => {
            Err(mesh_error("\"improve\" is not a method of embed: call improve on a map"))
        }
        // from_str never names it: embed does not run it.
        MethodName::Points => {
            Err(mesh_error("points maps come from SphereMap.from_points, not from embed"))
        }
    }
}

/// embed(mesh, method, options: dict | None, progress: callable | None,
/// landmark_ids: (k,) int64 | None, landmark_points: (k, 3) float64 | None)
/// -> CoreSphereMap.
///
/// Validates and orients the mesh once (`GenusZeroMesh`), runs the method,
/// pins the landmarks when given (`spherify_sphere::pin_or_refine_embedding`:
/// on a refined mesh, recorded in `refinement`, where the drag stalls) and
/// certifies the points, all in the core with the GIL released. `progress`
/// receives `(done, total)` from the stages that report; Ctrl-C stops them.
#[pyfunction]
#[pyo3(signature = (mesh, method, options=None, progress=None, landmark_ids=None, landmark_points=None))]
pub fn embed(
    py: Python<'_>,
    mesh: &CoreMesh,
    method: &str,
    options: Option<&Bound<'_, PyDict>>,
    progress: Option<&Bound<'_, PyAny>>,
    landmark_ids: Option<PyReadonlyArrayDyn<'_, i64>>,
    landmark_points: Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<CoreSphereMap> {
    let name = MethodName::from_str(method).map_err(|e| mesh_error(e.to_string()))?;
    let options = Options::new(py, name, options)?;
    let method = self::method(name, &options)?;
    options.finish()?;
    let given = crate::landmarks::given(landmark_ids, landmark_points)?;
    let mesh_arg = mesh;
    let shared = Arc::clone(&mesh.mesh);
    // Detachable: Ctrl-C inside one long factorisation answers at once.
    let result = crate::progress::run_detachable(py, progress, move |report| {
        let (n, f) = (shared.n_vertices(), shared.n_faces());
        memory_budget::check(&memory_budget::embed_need(&method, n, f, given.is_some()))?;
        let mesh = GenusZeroMesh::new(shared).map_err(SphereError::from)?;
        // Landmarks are checked before the method runs: a bad set costs nothing.
        let landmarks =
            given.as_ref().map(|g| crate::landmarks::landmarks(&mesh, g)).transpose()?;
        let mut embedding = core_embed(&mesh, &method, report)?;
        let mut refined = None;
        if let Some(landmarks) = landmarks {
            let params = crate::landmarks::pin_params(&method);
            (embedding, refined) =
                pin_or_refine_embedding(&mesh, &embedding, &landmarks, &params, report)?;
        }
        Ok::<_, SphereError>((mesh, embedding, refined))
    })?;
    let (mesh, embedding, refined) = result.map_err(|e| sphere_error(py, e))?;
    let caller = Arc::clone(&mesh_arg.mesh);
    Ok(match refined {
        None => CoreSphereMap::new(mesh.shared_mesh(), caller, embedding, mesh.reoriented_faces()),
        Some(refined) => refined_map(caller, None, embedding, refined),
    })
}

/// A map on the refined mesh of a landmark layout. The refined mesh is built
/// from the oriented input: its faces are its own corner order, and it
/// reorients nothing. `input`: the mesh as the caller first gave it;
/// `before`: the map back of an input that was itself refined.
fn refined_map(
    input: Arc<spherify_mesh::Mesh>,
    before: Option<&Refinement>,
    embedding: spherify_sphere::Embedding,
    refined: spherify_sphere::methods::progressive::landmarks::Refined,
) -> CoreSphereMap {
    let earlier = before.map(|r| (r.faces.as_slice(), r.barycentric.as_slice()));
    let (faces, barycentric) = refined.layout.barycentric(input.faces(), earlier);
    let shared = refined.mesh.shared_mesh();
    CoreSphereMap::new(Arc::clone(&shared), shared, embedding, 0).with_refinement(Refinement {
        input,
        faces,
        barycentric,
    })
}

/// improve(sphere_map, options: dict | None, progress, landmark_ids,
/// landmark_points) -> CoreSphereMap.
///
/// Lowers a distortion energy of a valid map with flip-free moves (thesis
/// 9.3.2), pins the landmarks when given (then lowers the energy again with
/// them held) and certifies the result, in the core with the GIL released. A
/// map that is not a valid GC-embedding raises MapError.
#[pyfunction]
#[pyo3(signature = (sphere_map, options=None, progress=None, landmark_ids=None, landmark_points=None))]
pub fn improve(
    py: Python<'_>,
    sphere_map: &CoreSphereMap,
    options: Option<&Bound<'_, PyDict>>,
    progress: Option<&Bound<'_, PyAny>>,
    landmark_ids: Option<PyReadonlyArrayDyn<'_, i64>>,
    landmark_points: Option<PyReadonlyArrayDyn<'_, f64>>,
) -> PyResult<CoreSphereMap> {
    let options = Options::new(py, MethodName::Improve, options)?;
    let params = crate::progressive::improve_params(&options)?;
    let max_vertices = options.optional_count("max_vertices")?;
    options.finish()?;
    let given = crate::landmarks::given(landmark_ids, landmark_points)?;
    let shared = sphere_map.shared_mesh();
    let start = sphere_map.embedding().clone();
    let result = crate::progress::run_detachable(py, progress, move |report| {
        let (n, f) = (shared.n_vertices(), shared.n_faces());
        memory_budget::check(&memory_budget::improve_need(&params, n, f))?;
        let mesh = GenusZeroMesh::new(shared).map_err(SphereError::from)?;
        let landmarks =
            given.as_ref().map(|g| crate::landmarks::landmarks(&mesh, g)).transpose()?;
        let mut embedding = improve_embedding(&mesh, &start, &params, report)?;
        let mut refined = None;
        if let Some(landmarks) = landmarks {
            let pin = crate::landmarks::pin_params_for(params.energy, max_vertices);
            (embedding, refined) =
                pin_or_refine_embedding(&mesh, &embedding, &landmarks, &pin, report)?;
        }
        Ok::<_, SphereError>((mesh, embedding, refined))
    })?;
    let (_, embedding, refined) = result.map_err(|e| sphere_error(py, e))?;
    Ok(match refined {
        None => sphere_map.with_embedding(embedding),
        Some(refined) => {
            let before = sphere_map.refinement();
            let input = before.map_or_else(|| sphere_map.caller_mesh(), |r| Arc::clone(&r.input));
            refined_map(input, before, embedding, refined)
        }
    })
}

/// from_points(mesh, points (n, 3) float64) -> CoreSphereMap.
///
/// A map made elsewhere: the core validates and orients the mesh, projects
/// the points onto the unit sphere and certifies them (3.4), with the GIL
/// released. The certificate is the core's; nothing about it comes from Python.
#[pyfunction]
pub fn from_points(
    py: Python<'_>,
    mesh: &CoreMesh,
    points: PyReadonlyArrayDyn<'_, f64>,
) -> PyResult<CoreSphereMap> {
    let points = rows::<f64, 3>(&points, "points")?;
    let caller = Arc::clone(&mesh.mesh);
    let shared = Arc::clone(&mesh.mesh);
    let result = crate::pool::detach(py, || {
        let need =
            memory_budget::certify_need("from_points", shared.n_vertices(), shared.n_faces());
        memory_budget::check(&need)?;
        let mesh = GenusZeroMesh::new(shared).map_err(SphereError::from)?;
        let embedding = core_from_points(&mesh, &points)?;
        Ok::<_, SphereError>((mesh, embedding))
    })?;
    let (mesh, embedding) = result.map_err(|e| sphere_error(py, e))?;
    Ok(CoreSphereMap::new(mesh.shared_mesh(), caller, embedding, mesh.reoriented_faces()))
}
