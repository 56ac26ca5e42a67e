//! Dynamics (denavit_core::dynamics): inverse and forward dynamics, mass and Coriolis matrices, link
//! inertias. Single calls read contiguous float64 arrays without copying and reuse a per-thread workspace;
//! batches release the GIL and use every core.

use crate::convert::{check_shape, ArrayIn};
use crate::error::{value_error, IntoPy};
use crate::model::PyModel;
use denavit_core::dynamics::{self, DynamicsData, Inertia, DEFAULT_GRAVITY};
use denavit_core::Model;
use nalgebra::{Vector3, Vector6};
use numpy::{PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::cell::RefCell;
use std::sync::Arc;

thread_local! {
    /// One workspace per thread, resized when a model with another number of joints comes.
    static WS: RefCell<DynamicsData> = RefCell::new(DynamicsData::with_nq(0));
}

fn with_ws<R>(n: usize, f: impl FnOnce(&mut DynamicsData) -> R) -> R {
    WS.with(|w| {
        let mut w = w.borrow_mut();
        if w.nq() != n {
            *w = DynamicsData::with_nq(n);
        }
        f(&mut w)
    })
}

/// A 1-D input of n floats, copied at once under the GIL (cheaper than registering a numpy borrow for a few
/// values); lists, other dtypes and strided arrays go through `numpy.ascontiguousarray`.
struct Vin(Vec<f64>);

impl Vin {
    fn slice(&self) -> &[f64] {
        &self.0
    }
}

fn vin(what: &str, obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vin> {
    if let Ok(a) = obj.downcast::<PyArray1<f64>>() {
        // a copy made at once under the GIL: cheaper than registering a borrow for a few values
        if let Ok(v) = a.to_vec() {
            if v.len() != n {
                return Err(value_error(format!("{what}: expected an array of shape ({n}), got shape [{}]", v.len())));
            }
            return Ok(Vin(v));
        }
    }
    let a = c_contiguous(what, obj, &format!("({n})"))?;
    check_shape(what, a.shape(), &[Some(n)])?;
    let a = a.into_any().downcast_into::<PyArray1<f64>>().map_err(|_| value_error(format!("{what}: expected a 1-D array")))?;
    Ok(Vin(a.readonly().as_array().iter().copied().collect()))
}

/// Any array-like as a C-contiguous float64 numpy array (`numpy.ascontiguousarray`): the one slow path, which
/// also reads Fortran-ordered and strided arrays in their logical order.
fn c_contiguous<'py>(what: &str, obj: &Bound<'py, PyAny>, shape: &str) -> PyResult<Bound<'py, numpy::PyUntypedArray>> {
    let py = obj.py();
    let np = py.import("numpy")?;
    let kwargs = PyDict::new(py);
    kwargs.set_item("dtype", "float64")?;
    np.getattr("ascontiguousarray")
        .and_then(|f| f.call((obj,), Some(&kwargs)))
        .and_then(|a| a.downcast_into::<numpy::PyUntypedArray>().map_err(Into::into))
        .map_err(|_| value_error(format!("{what}: expected an array-like of floats of shape {shape}, got {}", type_name(obj))))
}

/// Values of an array-like of the given shape, in C (row-major) order whatever its memory layout.
fn c_values(what: &str, obj: &Bound<'_, PyAny>, shape: &[Option<usize>]) -> PyResult<Vec<f64>> {
    let desc: Vec<String> = shape.iter().map(|e| e.map_or("N".to_string(), |v| v.to_string())).collect();
    let a = c_contiguous(what, obj, &format!("({})", desc.join(", ")))?;
    check_shape(what, a.shape(), shape)?;
    let a = a.into_any().downcast_into::<numpy::PyArrayDyn<f64>>().map_err(|_| value_error(format!("{what}: expected a float64 array")))?;
    let v = a.readonly().as_array().iter().copied().collect();
    Ok(v)
}

/// A 2-D batch input (N, k): borrowed when C-contiguous float64, else converted.
enum Min<'py> {
    Borrowed(PyReadonlyArray2<'py, f64>),
    Owned(Vec<f64>),
}

impl Min<'_> {
    fn slice(&self) -> &[f64] {
        match self {
            Min::Borrowed(a) => a.as_slice().unwrap_or(&[]),
            Min::Owned(v) => v,
        }
    }
}

/// A (N, k) batch; `count` fixes N when known.
fn min<'py>(what: &str, obj: &Bound<'py, PyAny>, k: usize, count: Option<usize>) -> PyResult<(Min<'py>, usize)> {
    let owned;
    let a = match obj.downcast::<PyArray2<f64>>() {
        Ok(a) if a.is_c_contiguous() => a,
        _ => {
            let c = c_contiguous(what, obj, &format!("(N, {k})"))?;
            check_shape(what, c.shape(), &[count, Some(k)])?;
            owned = c.into_any().downcast_into::<PyArray2<f64>>().map_err(|_| value_error(format!("{what}: expected a 2-D array")))?;
            &owned
        }
    };
    check_shape(what, a.shape(), &[count, Some(k)])?;
    let rows = a.shape()[0];
    match a.try_readonly() {
        Ok(r) if r.as_slice().is_ok() => Ok((Min::Borrowed(r), rows)),
        _ => Ok((Min::Owned(a.readonly().as_array().iter().copied().collect()), rows)),
    }
}

fn type_name(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
}

fn gravity_of(g: Option<&Bound<'_, PyAny>>) -> PyResult<Vector3<f64>> {
    match g {
        None => Ok(Vector3::from(DEFAULT_GRAVITY)),
        Some(g) if g.is_none() => Ok(Vector3::from(DEFAULT_GRAVITY)),
        Some(g) => {
            let v = vin("gravity (m/s^2, world)", g, 3)?;
            Ok(Vector3::from_row_slice(v.slice()))
        }
    }
}

fn wrench_of(f: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vector6<f64>>> {
    match f {
        Some(f) if !f.is_none() => {
            let v = vin("f_ext (wrench [fx, fy, fz, nx, ny, nz] on the tool, tool frame)", f, 6)?;
            Ok(Some(Vector6::from_row_slice(v.slice())))
        }
        _ => Ok(None),
    }
}

fn out1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

fn out_matrix<'py>(py: Python<'py>, m: &nalgebra::DMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let n = m.nrows();
    // nalgebra is column-major: its transpose's storage is the row-major matrix (one array, no reshape)
    Ok(PyArray2::from_owned_array(py, numpy::ndarray::Array2::from_shape_fn((n, n), |(r, c)| m[(r, c)])))
}

/// Inverse dynamics by the recursive Newton-Euler algorithm (Featherstone 2008, ch. 5).
///
/// q, qd, qdd : array-like, shape (n,) — rad (m), rad/s (m/s), rad/s^2 (m/s^2).
/// gravity : array-like, shape (3,), m/s^2 in world (default [0, 0, -9.81]).
/// f_ext : array-like, shape (6,), optional — wrench [fx, fy, fz, nx, ny, nz] (N, N m) applied to the tool by
///     the environment, tool-frame axes, moment about the tool origin (costs -J_tool^T f_ext).
/// Returns tau, shape (n,): N m (revolute) / N (prismatic). Link inertias: Model.with_inertias.
#[pyfunction]
#[pyo3(signature = (model, q, qd, qdd, gravity=None, f_ext=None))]
pub fn rnea<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    qd: &Bound<'py, PyAny>,
    qdd: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let (q, qd, qdd) = (vin("q", q, n)?, vin("qd", qd, n)?, vin("qdd", qdd, n)?);
    let g = gravity_of(gravity)?;
    let w = wrench_of(f_ext)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::rnea(m, ws, q.slice(), qd.slice(), qdd.slice(), &g, w.as_ref()).py()?)))
}

/// Bias forces C(q, qd) qd + g(q) (N m / N), shape (n,): rnea with qdd = 0. q, qd : (n,); gravity : (3,) world.
#[pyfunction]
#[pyo3(signature = (model, q, qd, gravity=None))]
pub fn bias_forces<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, qd: &Bound<'py, PyAny>, gravity: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let (q, qd) = (vin("q", q, n)?, vin("qd", qd, n)?);
    let g = gravity_of(gravity)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::bias_forces(m, ws, q.slice(), qd.slice(), &g).py()?)))
}

/// Gravity torques g(q) (N m / N), shape (n,). q : (n,); gravity : (3,) m/s^2 in world (default [0, 0, -9.81]).
#[pyfunction]
#[pyo3(signature = (model, q, gravity=None))]
pub fn gravity_torques<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, gravity: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let q = vin("q", q, n)?;
    let g = gravity_of(gravity)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::gravity_torques(m, ws, q.slice(), &g).py()?)))
}

/// Joint-space mass matrix M(q), shape (n, n), symmetric positive definite, by the composite rigid body
/// algorithm (Featherstone 2008, ch. 6). q : (n,) rad / m.
#[pyfunction]
pub fn mass_matrix<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let q = vin("q", q, n)?;
    with_ws(n, |ws| out_matrix(py, dynamics::mass_matrix(m, ws, q.slice()).py()?))
}

/// Coriolis matrix C(q, qd), shape (n, n): C qd + g(q) = bias_forces and dM/dt - 2C is skew-symmetric
/// (Christoffel-consistent factorisation). q, qd : (n,).
#[pyfunction]
pub fn coriolis_matrix<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, qd: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let (q, qd) = (vin("q", q, n)?, vin("qd", qd, n)?);
    with_ws(n, |ws| out_matrix(py, dynamics::coriolis_matrix(m, ws, q.slice(), qd.slice()).py()?))
}

fn fd_method(method: &str) -> PyResult<bool> {
    match method {
        "aba" => Ok(true),
        "crba" | "cholesky" => Ok(false),
        _ => Err(value_error(format!("method: expected 'aba' or 'crba', got '{method}'"))),
    }
}

/// Forward dynamics: joint accelerations (n,) for efforts tau, by the articulated-body algorithm
/// (method="aba", Featherstone ch. 7) or a Cholesky solve with the mass matrix (method="crba").
#[pyfunction]
#[pyo3(signature = (model, q, qd, tau, gravity=None, f_ext=None, method="aba"))]
#[allow(clippy::too_many_arguments)]
pub fn forward_dynamics<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    qd: &Bound<'py, PyAny>,
    tau: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
    method: &str,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let aba = fd_method(method)?;
    let m = &model.inner;
    let n = m.nq();
    let (q, qd, tau) = (vin("q", q, n)?, vin("qd", qd, n)?, vin("tau", tau, n)?);
    let g = gravity_of(gravity)?;
    let w = wrench_of(f_ext)?;
    with_ws(n, |ws| {
        let r = if aba {
            dynamics::forward_dynamics(m, ws, q.slice(), qd.slice(), tau.slice(), &g, w.as_ref())
        } else {
            dynamics::forward_dynamics_crba(m, ws, q.slice(), qd.slice(), tau.slice(), &g, w.as_ref())
        };
        Ok(out1(py, r.py()?))
    })
}

/// Kinetic energy 1/2 qd^T M(q) qd (J).
#[pyfunction]
pub fn kinetic_energy(model: &PyModel, q: &Bound<'_, PyAny>, qd: &Bound<'_, PyAny>) -> PyResult<f64> {
    let n = model.inner.nq();
    let (q, qd) = (vin("q", q, n)?, vin("qd", qd, n)?);
    dynamics::kinetic_energy(&model.inner, q.slice(), qd.slice()).py()
}

/// Potential energy -sum m_i g . c_i (J), zero at the world origin.
#[pyfunction]
#[pyo3(signature = (model, q, gravity=None))]
pub fn potential_energy(model: &PyModel, q: &Bound<'_, PyAny>, gravity: Option<&Bound<'_, PyAny>>) -> PyResult<f64> {
    let n = model.inner.nq();
    let q = vin("q", q, n)?;
    dynamics::potential_energy(&model.inner, q.slice(), &gravity_of(gravity)?).py()
}

// ------------------------------------------------------------------------------------------------
// Batches: (N, n) in, GIL released, every core
// ------------------------------------------------------------------------------------------------

/// Batch wrenches: None, one (6,) for every row, or (N, 6).
fn batch_wrench<'py>(f: Option<&Bound<'py, PyAny>>, count: usize) -> PyResult<Option<Min<'py>>> {
    match f {
        Some(f) if !f.is_none() => {
            let what = "f_ext (wrench [f; n] on the tool, tool frame)";
            let ndim = f.getattr("ndim").and_then(|d| d.extract::<usize>()).ok();
            let is_single = match ndim {
                Some(d) => d == 1,
                None => f.len().ok() == Some(6) && f.get_item(0).map(|x| x.extract::<f64>().is_ok()).unwrap_or(false),
            };
            if is_single {
                Ok(Some(Min::Owned(vin(what, f, 6)?.slice().to_vec())))
            } else {
                Ok(Some(min(what, f, 6, Some(count))?.0))
            }
        }
        _ => Ok(None),
    }
}

fn out_rows<'py>(py: Python<'py>, count: usize, n: usize) -> Bound<'py, PyArray2<f64>> {
    PyArray2::<f64>::zeros(py, [count, n], false)
}

/// Batch inverse dynamics: qs, qds, qdds (N, n) -> (N, n); f_ext None, (6,) or (N, 6).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, qdds, gravity=None, f_ext=None))]
pub fn rnea_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    qdds: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let (qd, _) = min("qds", qds, n, Some(count))?;
    let (qdd, _) = min("qdds", qdds, n, Some(count))?;
    let g = gravity_of(gravity)?;
    let w = batch_wrench(f_ext, count)?;
    let out = out_rows(py, count, n);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let (q, qd, qdd, w) = (q.slice(), qd.slice(), qdd.slice(), w.as_ref().map(|w| w.slice()));
        py.allow_threads(|| dynamics::rnea_batch(m, q, qd, qdd, &g, w, o)).py()?;
    }
    Ok(out)
}

/// Batch bias forces: qs, qds (N, n) -> (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, gravity=None))]
pub fn bias_forces_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>, qds: &Bound<'py, PyAny>, gravity: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let (qd, _) = min("qds", qds, n, Some(count))?;
    let g = gravity_of(gravity)?;
    let out = out_rows(py, count, n);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let (q, qd) = (q.slice(), qd.slice());
        py.allow_threads(|| dynamics::bias_forces_batch(m, q, qd, &g, o)).py()?;
    }
    Ok(out)
}

/// Batch gravity torques: qs (N, n) -> (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, gravity=None))]
pub fn gravity_torques_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>, gravity: Option<&Bound<'py, PyAny>>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let g = gravity_of(gravity)?;
    let out = out_rows(py, count, n);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let q = q.slice();
        py.allow_threads(|| dynamics::gravity_torques_batch(m, q, &g, o)).py()?;
    }
    Ok(out)
}

/// Batch mass matrices: qs (N, n) -> (N, n, n).
#[pyfunction]
pub fn mass_matrix_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let out = PyArray3::<f64>::zeros(py, [count, n, n], false);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let q = q.slice();
        py.allow_threads(|| dynamics::mass_matrix_batch(m, q, o)).py()?;
    }
    Ok(out)
}

/// Batch Coriolis matrices: qs, qds (N, n) -> (N, n, n).
#[pyfunction]
pub fn coriolis_matrix_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>, qds: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let (qd, _) = min("qds", qds, n, Some(count))?;
    let out = PyArray3::<f64>::zeros(py, [count, n, n], false);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let (q, qd) = (q.slice(), qd.slice());
        py.allow_threads(|| dynamics::coriolis_matrix_batch(m, q, qd, o)).py()?;
    }
    Ok(out)
}

/// Batch forward dynamics (ABA): qs, qds, taus (N, n) -> (N, n); f_ext None, (6,) or (N, 6).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, taus, gravity=None, f_ext=None))]
pub fn forward_dynamics_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    taus: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let n = m.nq();
    let (q, count) = min("qs", qs, n, None)?;
    let (qd, _) = min("qds", qds, n, Some(count))?;
    let (tau, _) = min("taus", taus, n, Some(count))?;
    let g = gravity_of(gravity)?;
    let w = batch_wrench(f_ext, count)?;
    let out = out_rows(py, count, n);
    {
        let mut o = out.readwrite();
        let o = o.as_slice_mut().map_err(|e| value_error(e.to_string()))?;
        let (q, qd, tau, w) = (q.slice(), qd.slice(), tau.slice(), w.as_ref().map(|w| w.slice()));
        py.allow_threads(|| dynamics::forward_dynamics_batch(m, q, qd, tau, &g, w, o)).py()?;
    }
    Ok(out)
}

// ------------------------------------------------------------------------------------------------
// Link inertias
// ------------------------------------------------------------------------------------------------

/// `Model.with_inertias(masses, coms, inertias, frame="link", about="com", q_ref=None)`: a copy of the
/// model with link inertial parameters. masses (n,) kg; coms (n, 3) m; inertias (n, 3, 3) kg m^2 about
/// each centre of mass (about="com") or about the frame origin (about="origin"); frame="link": each in
/// its joint frame i (the frame moving with link i), frame="world": in world with the robot at q_ref
/// (default zeros).
#[pyfunction]
#[pyo3(signature = (model, masses, coms, inertias, frame="link", about="com", q_ref=None))]
#[allow(clippy::too_many_arguments)]
pub fn model_with_inertias(
    model: &PyModel,
    masses: &Bound<'_, PyAny>,
    coms: &Bound<'_, PyAny>,
    inertias: &Bound<'_, PyAny>,
    frame: &str,
    about: &str,
    q_ref: Option<ArrayIn<'_>>,
) -> PyResult<PyModel> {
    let m = &model.inner;
    let n = m.nq();
    let mv = c_values("masses (kg)", masses, &[Some(n)])?;
    let cv = c_values("coms (centres of mass, m)", coms, &[Some(n), Some(3)])?;
    let iv = c_values("inertias (kg m^2)", inertias, &[Some(n), Some(3), Some(3)])?;
    let mut list = match about {
        "com" => dynamics::inertias_from_slices(&mv, &cv, &iv).py()?,
        "origin" => (0..n)
            .map(|i| {
                let c = Vector3::from_row_slice(&cv[3 * i..3 * i + 3]);
                let t = nalgebra::Matrix3::from_row_slice(&iv[9 * i..9 * i + 9]);
                Inertia::from_origin(mv[i], c, t).map_err(|e| value_error(format!("link {}: {e}", i + 1)))
            })
            .collect::<PyResult<Vec<_>>>()?,
        _ => return Err(value_error(format!("about: expected 'com' or 'origin', got '{about}'"))),
    };
    match frame {
        "link" => {
            if q_ref.is_some() {
                return Err(value_error("q_ref: only used with frame='world'"));
            }
        }
        "world" => {
            let q = match q_ref {
                Some(a) => crate::convert::vector("q_ref", &a, n)?,
                None => vec![0.0; n],
            };
            list = dynamics::inertias_in_world(m, &q, &list).py()?;
        }
        _ => return Err(value_error(format!("frame: expected 'link' or 'world', got '{frame}'"))),
    }
    Ok(PyModel { inner: Arc::new(m.with_inertias(list).py()?) })
}

/// `Model.inertias`: dict with "masses" (n,), "coms" (n, 3), "inertias" (n, 3, 3) (about each centre of
/// mass), every link in its joint frame; `model.with_inertias(**model.inertias)` round-trips.
#[pyfunction]
pub fn model_inertias<'py>(py: Python<'py>, model: &PyModel) -> PyResult<Bound<'py, PyDict>> {
    let list = model.inner.inertias();
    let n = list.len();
    let masses: Vec<f64> = list.iter().map(|i| i.mass()).collect();
    let coms: Vec<f64> = list.iter().flat_map(|i| i.com().iter().copied().collect::<Vec<_>>()).collect();
    let tensors: Vec<f64> = list
        .iter()
        .flat_map(|i| {
            let t = i.inertia_com();
            (0..3).flat_map(move |r| (0..3).map(move |c| t[(r, c)])).collect::<Vec<_>>()
        })
        .collect();
    let d = PyDict::new(py);
    d.set_item("masses", PyArray1::from_vec(py, masses))?;
    d.set_item("coms", PyArray1::from_vec(py, coms).reshape([n, 3])?)?;
    d.set_item("inertias", PyArray1::from_vec(py, tensors).reshape([n, 3, 3])?)?;
    Ok(d)
}

/// Re-express the link inertias of `source` in the joint frames of `target` (another model of the same
/// robot, e.g. its MD-H and ED-H models) and return `target` with them. The joint axes must coincide at
/// q_ref (default zeros).
#[pyfunction]
#[pyo3(signature = (source, target, q_ref=None))]
pub fn transfer_inertias(source: &PyModel, target: &PyModel, q_ref: Option<ArrayIn<'_>>) -> PyResult<PyModel> {
    let n = source.inner.nq();
    let q = match q_ref {
        Some(a) => crate::convert::vector("q_ref", &a, n)?,
        None => vec![0.0; n],
    };
    Ok(PyModel { inner: Arc::new(dynamics::transfer_inertias(&source.inner, &target.inner, &q).py()?) })
}

/// Register the functions of this file, and `Model.with_inertias` / `Model.inertias` on the Model class.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(rnea, m)?)?;
    m.add_function(wrap_pyfunction!(bias_forces, m)?)?;
    m.add_function(wrap_pyfunction!(gravity_torques, m)?)?;
    m.add_function(wrap_pyfunction!(mass_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(coriolis_matrix, m)?)?;
    m.add_function(wrap_pyfunction!(forward_dynamics, m)?)?;
    m.add_function(wrap_pyfunction!(kinetic_energy, m)?)?;
    m.add_function(wrap_pyfunction!(potential_energy, m)?)?;
    m.add_function(wrap_pyfunction!(rnea_batch, m)?)?;
    m.add_function(wrap_pyfunction!(bias_forces_batch, m)?)?;
    m.add_function(wrap_pyfunction!(gravity_torques_batch, m)?)?;
    m.add_function(wrap_pyfunction!(mass_matrix_batch, m)?)?;
    m.add_function(wrap_pyfunction!(coriolis_matrix_batch, m)?)?;
    m.add_function(wrap_pyfunction!(forward_dynamics_batch, m)?)?;
    m.add_function(wrap_pyfunction!(transfer_inertias, m)?)?;
    // Model methods defined here, next to the algorithms (the Model class lives in model.rs): plain Python
    // functions (descriptors, so they bind to the instance) forwarding to the functions above.
    let py = m.py();
    let ns = PyDict::new(py);
    ns.set_item("_with_inertias", wrap_pyfunction!(model_with_inertias, m)?)?;
    ns.set_item("_inertias", wrap_pyfunction!(model_inertias, m)?)?;
    py.run(MODEL_METHODS, Some(&ns), None)?;
    let cls = py.get_type::<PyModel>();
    for name in ["with_inertias", "inertias"] {
        let item = ns.get_item(name)?.ok_or_else(|| value_error(format!("{name} not defined")))?;
        cls.setattr(name, item)?;
    }
    Ok(())
}

const MODEL_METHODS: &std::ffi::CStr = pyo3::ffi::c_str!(
    r#"
def with_inertias(self, masses, coms, inertias, frame="link", about="com", q_ref=None):
    """A copy of the model with link inertial parameters (docs/conventions.md, "Dynamics").

    Parameters
    ----------
    masses : array-like, shape (n,)
        Link masses in kg (>= 0).
    coms : array-like, shape (n, 3)
        Centres of mass in m.
    inertias : array-like, shape (n, 3, 3)
        Rotational inertias in kg m^2: symmetric, positive semi-definite, principal moments obeying the
        triangle inequality; about each centre of mass (``about="com"``) or about the frame origin
        (``about="origin"``, the parallel-axis theorem is applied).
    frame : {"link", "world"}
        ``"link"``: link i in its joint frame i (the frame moving with link i); ``"world"``: every link in
        world with the robot at ``q_ref`` (default zeros), e.g. as exported from CAD at home.
    """
    return _with_inertias(self, masses, coms, inertias, frame, about, q_ref)


def _get_inertias(self):
    return _inertias(self)


inertias = property(_get_inertias, doc="""Link inertial parameters: dict with "masses" (n,) kg, "coms" (n, 3) m
and "inertias" (n, 3, 3) kg m^2 about each centre of mass, every link in its joint frame;
``model.with_inertias(**model.inertias)`` round-trips.""")
"#
);
