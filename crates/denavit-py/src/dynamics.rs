//! Dynamics (denavit_core::dynamics): inverse and forward dynamics, mass and Coriolis matrices, link
//! inertias. Single calls reuse a per-thread workspace (`rnea` copies its vectors to the stack, not the heap);
//! batches release the GIL and use every core.

use crate::convert::{batch_out, check_len, check_shape, configuration, opt_vector, out, read, rows, vector, Rows, Threads};
use crate::error::{invalid, IntoPy};
use crate::model::PyModel;
use denavit_core::dynamics::{self, DynamicsData, DEFAULT_GRAVITY};
use denavit_core::Model;
use nalgebra::{Vector3, Vector6};
use numpy::ndarray::Dim;
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
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

fn gravity_of(g: Option<&Bound<'_, PyAny>>) -> PyResult<Vector3<f64>> {
    match opt_vector("gravity (m/s^2, world)", g)? {
        None => Ok(Vector3::from(DEFAULT_GRAVITY)),
        Some(v) => {
            check_len("gravity (m/s^2, world)", 3, v.len())?;
            Ok(Vector3::from_row_slice(&v))
        }
    }
}

fn wrench_of(f: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vector6<f64>>> {
    let what = "f_ext (wrench [fx, fy, fz, nx, ny, nz] on the tool, tool frame)";
    match opt_vector(what, f)? {
        None => Ok(None),
        Some(v) => {
            check_len(what, 6, v.len())?;
            Ok(Some(Vector6::from_row_slice(&v)))
        }
    }
}

fn out1<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

fn out_matrix<'py>(py: Python<'py>, m: &nalgebra::DMatrix<f64>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    // nalgebra is column-major: its transpose's storage is the row-major matrix
    out(py, m.transpose().as_slice(), [m.nrows(), m.ncols()])
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
    let mut bufs = [[0.0; 16]; 3];
    let [bq, bqd, bqdd] = &mut bufs;
    let (q, qd, qdd) = (configuration("q", q, bq)?, configuration("qd", qd, bqd)?, configuration("qdd", qdd, bqdd)?);
    let g = gravity_of(gravity)?;
    let w = wrench_of(f_ext)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::rnea(m, ws, &q, &qd, &qdd, &g, w.as_ref()).py()?)))
}

/// Bias forces C(q, qd) qd + g(q) (N m / N), shape (n,): rnea with qdd = 0. q, qd : (n,); gravity : (3,) world.
#[pyfunction]
#[pyo3(signature = (model, q, qd, gravity=None))]
pub fn bias_forces<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    qd: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let (q, qd) = (vector("q", q)?, vector("qd", qd)?);
    let g = gravity_of(gravity)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::bias_forces(m, ws, &q, &qd, &g).py()?)))
}

/// Gravity torques g(q) (N m / N), shape (n,). q : (n,); gravity : (3,) m/s^2 in world (default [0, 0, -9.81]).
#[pyfunction]
#[pyo3(signature = (model, q, gravity=None))]
pub fn gravity_torques<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let q = vector("q", q)?;
    let g = gravity_of(gravity)?;
    with_ws(n, |ws| Ok(out1(py, dynamics::gravity_torques(m, ws, &q, &g).py()?)))
}

/// Joint-space mass matrix M(q), shape (n, n), symmetric positive definite, by the composite rigid body
/// algorithm (Featherstone 2008, ch. 6). q : (n,) rad / m.
#[pyfunction]
pub fn mass_matrix<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let q = vector("q", q)?;
    with_ws(n, |ws| out_matrix(py, dynamics::mass_matrix(m, ws, &q).py()?))
}

/// Coriolis matrix C(q, qd), shape (n, n): C qd + g(q) = bias_forces and dM/dt - 2C is skew-symmetric
/// (Christoffel-consistent factorisation). q, qd : (n,).
#[pyfunction]
pub fn coriolis_matrix<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, qd: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m = &model.inner;
    let n = m.nq();
    let (q, qd) = (vector("q", q)?, vector("qd", qd)?);
    with_ws(n, |ws| out_matrix(py, dynamics::coriolis_matrix(m, ws, &q, &qd).py()?))
}

fn fd_method(method: &str) -> PyResult<bool> {
    match method {
        "aba" => Ok(true),
        "crba" | "cholesky" => Ok(false),
        _ => Err(invalid("method", "'aba' or 'crba'", format!("'{method}'"))),
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
    let (q, qd, tau) = (vector("q", q)?, vector("qd", qd)?, vector("tau", tau)?);
    let g = gravity_of(gravity)?;
    let w = wrench_of(f_ext)?;
    with_ws(n, |ws| {
        let r = if aba {
            dynamics::forward_dynamics(m, ws, &q, &qd, &tau, &g, w.as_ref())
        } else {
            dynamics::forward_dynamics_crba(m, ws, &q, &qd, &tau, &g, w.as_ref())
        };
        Ok(out1(py, r.py()?))
    })
}

/// Kinetic energy 1/2 qd^T M(q) qd (J).
#[pyfunction]
pub fn kinetic_energy(model: &PyModel, q: &Bound<'_, PyAny>, qd: &Bound<'_, PyAny>) -> PyResult<f64> {
    let (q, qd) = (vector("q", q)?, vector("qd", qd)?);
    dynamics::kinetic_energy(&model.inner, &q, &qd).py()
}

/// Potential energy -sum m_i g . c_i (J), zero at the world origin.
#[pyfunction]
#[pyo3(signature = (model, q, gravity=None))]
pub fn potential_energy(model: &PyModel, q: &Bound<'_, PyAny>, gravity: Option<&Bound<'_, PyAny>>) -> PyResult<f64> {
    let q = vector("q", q)?;
    dynamics::potential_energy(&model.inner, &q, &gravity_of(gravity)?).py()
}

// ------------------------------------------------------------------------------------------------
// Batches: (N, n) in, GIL released, `out=` reused, `threads=` (docs/speed.md)
// ------------------------------------------------------------------------------------------------

/// Batch wrenches: None, one (6,) for every row, or (N, 6) (the core tells them apart by length).
fn batch_wrench(f: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<f64>>> {
    let what = "f_ext (wrench [f; n] on the tool, tool frame: (6,) or (N, 6))";
    match f {
        Some(f) => {
            let (v, shape) = read(what, f)?;
            if shape.len() != 1 {
                check_shape(what, &shape, &[None, Some(6)])?;
            }
            Ok(Some(v))
        }
        None => Ok(None),
    }
}

/// The inputs of a batch call: `qs` (N, n) and the other (N, n) batches named in `more`, read in order.
struct Batch<'py> {
    count: usize,
    n: usize,
    /// The inputs' names (qs first) and values.
    names: Vec<String>,
    rows: Vec<Rows<'py>>,
}

impl<'py> Batch<'py> {
    fn read(model: &Model, qs: &Bound<'py, PyAny>, more: &[(&str, &Bound<'py, PyAny>)]) -> PyResult<Self> {
        let n = model.nq();
        let (q, count) = rows("qs", qs, n)?;
        let mut all = vec![q];
        let mut names = vec!["qs".to_string()];
        for (what, b) in more {
            all.push(rows(what, b, n)?.0);
            names.push(what.to_string());
        }
        Ok(Self { count, n, names, rows: all })
    }
    /// The k-th input (0: qs).
    fn get(&self, k: usize) -> &[f64] {
        self.rows[k].slice()
    }
    /// Every input, named (for the overlap check of `out=`).
    fn inputs(&self) -> Vec<(&str, &[f64])> {
        self.names.iter().map(String::as_str).zip(self.rows.iter().map(Rows::slice)).collect()
    }
    /// (N, n) output (`out` when given) filled by `kernel` without the GIL on `threads` (`ns_per_value`: its
    /// cost on one core, roughly, for [`batch_out`]).
    fn run(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        threads: Option<Threads>,
        ns_per_value: f64,
        kernel: impl FnOnce(&mut [f64]) -> denavit_core::Result<()> + Send,
    ) -> PyResult<Bound<'py, PyArray2<f64>>> {
        batch_out(py, Dim([self.count, self.n]), out, threads, &self.inputs(), ns_per_value, kernel)
    }
    /// (N, n, n) output (`out` when given) filled by `kernel` without the GIL on `threads`.
    fn run_matrices(
        &self,
        py: Python<'py>,
        out: Option<&Bound<'py, PyAny>>,
        threads: Option<Threads>,
        ns_per_value: f64,
        kernel: impl FnOnce(&mut [f64]) -> denavit_core::Result<()> + Send,
    ) -> PyResult<Bound<'py, PyArray3<f64>>> {
        batch_out(py, Dim([self.count, self.n, self.n]), out, threads, &self.inputs(), ns_per_value, kernel)
    }
}

/// Batch inverse dynamics: qs, qds, qdds (N, n) -> (N, n); f_ext None, (6,) or (N, 6).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, qdds, gravity=None, f_ext=None, *, out=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn rnea_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    qdds: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[("qds", qds), ("qdds", qdds)])?;
    let (g, w) = (gravity_of(gravity)?, batch_wrench(f_ext)?);
    let (q, qd, qdd) = (b.get(0), b.get(1), b.get(2));
    b.run(py, out, threads, 80.0, |o| dynamics::rnea_batch(m, q, qd, qdd, &g, w.as_deref(), o))
}

/// Batch bias forces: qs, qds (N, n) -> (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, gravity=None, *, out=None, threads=None))]
pub fn bias_forces_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[("qds", qds)])?;
    let g = gravity_of(gravity)?;
    let (q, qd) = (b.get(0), b.get(1));
    b.run(py, out, threads, 80.0, |o| dynamics::bias_forces_batch(m, q, qd, &g, o))
}

/// Batch gravity torques: qs (N, n) -> (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, gravity=None, *, out=None, threads=None))]
pub fn gravity_torques_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[])?;
    let g = gravity_of(gravity)?;
    let q = b.get(0);
    b.run(py, out, threads, 80.0, |o| dynamics::gravity_torques_batch(m, q, &g, o))
}

/// Batch mass matrices: qs (N, n) -> (N, n, n).
#[pyfunction]
#[pyo3(signature = (model, qs, *, out=None, threads=None))]
pub fn mass_matrix_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[])?;
    let q = b.get(0);
    b.run_matrices(py, out, threads, 30.0, |o| dynamics::mass_matrix_batch(m, q, o))
}

/// Batch Coriolis matrices: qs, qds (N, n) -> (N, n, n).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, *, out=None, threads=None))]
pub fn coriolis_matrix_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[("qds", qds)])?;
    let (q, qd) = (b.get(0), b.get(1));
    b.run_matrices(py, out, threads, 60.0, |o| dynamics::coriolis_matrix_batch(m, q, qd, o))
}

/// Batch forward dynamics (ABA): qs, qds, taus (N, n) -> (N, n); f_ext None, (6,) or (N, 6).
#[pyfunction]
#[pyo3(signature = (model, qs, qds, taus, gravity=None, f_ext=None, *, out=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn forward_dynamics_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    qds: &Bound<'py, PyAny>,
    taus: &Bound<'py, PyAny>,
    gravity: Option<&Bound<'py, PyAny>>,
    f_ext: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let m: &Model = &model.inner;
    let b = Batch::read(m, qs, &[("qds", qds), ("taus", taus)])?;
    let (g, w) = (gravity_of(gravity)?, batch_wrench(f_ext)?);
    let (q, qd, tau) = (b.get(0), b.get(1), b.get(2));
    b.run(py, out, threads, 300.0, |o| dynamics::forward_dynamics_batch(m, q, qd, tau, &g, w.as_deref(), o))
}

// ------------------------------------------------------------------------------------------------
// Link inertias between models (Model.with_inertias / Model.inertias are in model.rs)
// ------------------------------------------------------------------------------------------------

/// Re-express the link inertias of `source` in the joint frames of `target` (another model of the same
/// robot, e.g. its MD-H and ED-H models) and return `target` with them. The joint axes must coincide at
/// q_ref (default zeros).
#[pyfunction]
#[pyo3(signature = (source, target, q_ref=None))]
pub fn transfer_inertias(source: &PyModel, target: &PyModel, q_ref: Option<&Bound<'_, PyAny>>) -> PyResult<PyModel> {
    let q = opt_vector("q_ref", q_ref)?.unwrap_or_else(|| vec![0.0; source.inner.nq()]);
    Ok(PyModel { inner: Arc::new(dynamics::transfer_inertias(&source.inner, &target.inner, &q).py()?) })
}

/// Register the functions of this file.
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
    Ok(())
}
