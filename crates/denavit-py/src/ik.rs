//! Inverse kinematics (denavit_core::ik): single solves, warm-started paths and batches (paths and
//! batches release the GIL; batches use every core).

use crate::convert::{check_len, check_shape, opt_vector, out, pose, poses, read, threads_of, vector, Int, Threads};
use crate::error::{invalid, IntoPy};
use crate::model::PyModel;
use denavit_core::ik::{self as core_ik, IkMethod, IkOptions, IkResult};
use numpy::{PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyList, PyTuple};

/// The outcome of one IK solve; the errors are measured at the returned q.
#[pyclass(module = "denavit._core", name = "IkResult", frozen)]
#[derive(Clone)]
pub struct PyIkResult {
    pub inner: IkResult,
}

#[pymethods]
impl PyIkResult {
    #[new]
    fn new(q: &Bound<'_, PyAny>, success: bool, iterations: usize, restarts: usize, position_error: f64, rotation_error: f64) -> PyResult<Self> {
        Ok(Self { inner: IkResult { q: vector("q", q)?, success, iterations, restarts, position_error, rotation_error } })
    }
    /// Pickle / copy: `IkResult(q, success, iterations, restarts, position_error, rotation_error)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let r = &self.inner;
        (py.get_type::<Self>(), (self.q(py), r.success, r.iterations, r.restarts, r.position_error, r.rotation_error)).into_pyobject(py)
    }
    /// (n,) the solution (rad / m), or the best configuration found when success is False.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.q)
    }
    /// position_error <= tol_position and rotation_error <= tol_rotation (and within the limits if asked).
    #[getter]
    fn success(&self) -> bool {
        self.inner.success
    }
    /// Jacobian evaluations, summed over all attempts.
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }
    /// Restarts used (0 when the attempt from q0 succeeded).
    #[getter]
    fn restarts(&self) -> usize {
        self.inner.restarts
    }
    /// |p_tool(q) - p_goal| in m, measured at q.
    #[getter]
    fn position_error(&self) -> f64 {
        self.inner.position_error
    }
    /// Rotation angle between R_tool(q) and R_goal in rad, measured at q.
    #[getter]
    fn rotation_error(&self) -> f64 {
        self.inner.rotation_error
    }
    fn __repr__(&self) -> String {
        let r = &self.inner;
        format!(
            "IkResult(success={}, q={:?}, iterations={}, restarts={}, position_error={:.3e}, rotation_error={:.3e})",
            if r.success { "True" } else { "False" },
            r.q,
            r.iterations,
            r.restarts,
            r.position_error,
            r.rotation_error
        )
    }
}

/// Results of ik_path / ik_batch as arrays (and a sequence of IkResult: len, indexing, iteration).
#[pyclass(module = "denavit._core", name = "IkBatchResult", frozen, sequence)]
pub struct PyIkBatchResult {
    results: Vec<IkResult>,
    n: usize,
}

impl PyIkBatchResult {
    fn column<T: numpy::Element + Copy>(&self, py: Python<'_>, f: impl Fn(&IkResult) -> T) -> Py<PyArray1<T>> {
        let v: Vec<T> = self.results.iter().map(f).collect();
        PyArray1::from_vec(py, v).unbind()
    }
}

#[pymethods]
impl PyIkBatchResult {
    /// results : the IkResult of each goal, in order; nq : joints (the width of `q` when there are none).
    #[new]
    fn new(results: Vec<PyIkResult>, nq: usize) -> PyResult<Self> {
        for (i, r) in results.iter().enumerate() {
            check_len(&format!("q of result {i}"), nq, r.inner.q.len())?;
        }
        Ok(Self { results: results.into_iter().map(|r| r.inner).collect(), n: nq })
    }
    /// Pickle / copy: `IkBatchResult(results, nq)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let items: Vec<PyIkResult> = self.results.iter().map(|r| PyIkResult { inner: r.clone() }).collect();
        (py.get_type::<Self>(), (items, self.n)).into_pyobject(py)
    }
    /// (N, n) solutions (rad / m).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.results.iter().flat_map(|r| r.q.iter().copied()).collect();
        out(py, &v, [self.results.len(), self.n])
    }
    /// (N,) bool.
    #[getter]
    fn success(&self, py: Python<'_>) -> Py<PyArray1<bool>> {
        self.column(py, |r| r.success)
    }
    /// (N,) Jacobian evaluations per goal.
    #[getter]
    fn iterations(&self, py: Python<'_>) -> Py<PyArray1<i64>> {
        self.column(py, |r| r.iterations as i64)
    }
    /// (N,) restarts used per goal.
    #[getter]
    fn restarts(&self, py: Python<'_>) -> Py<PyArray1<i64>> {
        self.column(py, |r| r.restarts as i64)
    }
    /// (N,) measured position errors (m).
    #[getter]
    fn position_error(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.column(py, |r| r.position_error)
    }
    /// (N,) measured rotation errors (rad).
    #[getter]
    fn rotation_error(&self, py: Python<'_>) -> Py<PyArray1<f64>> {
        self.column(py, |r| r.rotation_error)
    }
    fn __len__(&self) -> usize {
        self.results.len()
    }
    fn __getitem__(&self, index: isize) -> PyResult<PyIkResult> {
        let len = self.results.len() as isize;
        let i = if index < 0 { index + len } else { index };
        if i < 0 || i >= len {
            return Err(pyo3::exceptions::PyIndexError::new_err(format!("index {index} out of range for {len} results")));
        }
        Ok(PyIkResult { inner: self.results[i as usize].clone() })
    }
    fn __iter__(&self, py: Python<'_>) -> PyResult<PyObject> {
        let items: Vec<PyIkResult> = self.results.iter().map(|r| PyIkResult { inner: r.clone() }).collect();
        Ok(PyList::new(py, items)?.into_any().try_iter()?.into_any().unbind())
    }
    fn __repr__(&self) -> String {
        let ok = self.results.iter().filter(|r| r.success).count();
        let worst_p = self.results.iter().map(|r| r.position_error).fold(0.0, f64::max);
        let worst_r = self.results.iter().map(|r| r.rotation_error).fold(0.0, f64::max);
        format!("IkBatchResult({ok}/{} solved, worst position_error={worst_p:.3e}, worst rotation_error={worst_r:.3e})", self.results.len())
    }
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn options(
    method: &str,
    tol_position: f64,
    tol_rotation: f64,
    max_iterations: Int,
    restarts: Int,
    seed: Int,
    respect_limits: bool,
    damping: f64,
) -> PyResult<IkOptions> {
    let method = IkMethod::parse(method).py()?;
    // Python ints to the core's unsigned counts; the core checks the ranges it needs (max_iterations
    // 1..=MAX_ITERATIONS, restarts <= MAX_RESTARTS)
    let count = |what: &str, v: Int, max: u64| match v.0 {
        Ok(v) => usize::try_from(v).map_err(|_| invalid(what, "an integer >= 0", v.to_string())),
        Err(text) if text.starts_with('-') => Err(invalid(what, "an integer >= 0", text)),
        Err(text) => Err(invalid(what, format!("at most {max}"), text)),
    };
    let (mi, mr) = (core_ik::MAX_ITERATIONS as u64, core_ik::MAX_RESTARTS as u64);
    let opts = IkOptions {
        method,
        tol_position,
        tol_rotation,
        max_iterations: count("max_iterations", max_iterations, mi)?,
        restarts: count("restarts", restarts, mr)?,
        seed: count("seed", seed, i64::MAX as u64)? as u64,
        respect_limits,
        damping,
    };
    opts.check().py()?;
    Ok(opts)
}

/// Whether solving `goals` IK goals with `opts` runs interruptibly ([`crate::signals`]): when the budget may take
/// about a second (an unreachable goal runs all of it; the cost per joint and iteration is in docs/speed.md), or
/// the goals are many enough that a thread start costs little beside even quick solves. The default budget of
/// one goal (5,100 iterations) is not long.
pub(crate) fn long_solve(model: &denavit_core::Model, opts: &IkOptions, goals: usize) -> bool {
    let worst_ns = 0.2e3 * (opts.max_iterations as f64) * (opts.restarts as f64 + 1.0) * (goals as f64) * (model.nq().max(1) as f64);
    goals >= 1000 || crate::signals::long(worst_ns / 500.0)
}

pub(crate) fn start(model: &PyModel, q0: Option<&Bound<'_, PyAny>>, what: &str) -> PyResult<Vec<f64>> {
    Ok(opt_vector(what, q0)?.unwrap_or_else(|| vec![0.0; model.inner.nq()]))
}

/// Inverse kinematics of one goal T_world_tool (4, 4) from q0 (n,) in rad / m (default zeros).
///
/// Success is decided from the measured final position and rotation errors against tol_position (m) and
/// tol_rotation (rad). method: "lm" (Levenberg-Marquardt) or "newton" (Newton-Raphson).
#[pyfunction]
#[pyo3(signature = (model, T_goal, q0=None, *, method="lm", tol_position=1e-10, tol_rotation=1e-10, max_iterations=Int(Ok(100)), restarts=Int(Ok(50)), seed=Int(Ok(0)), respect_limits=true, damping=0.1))]
#[allow(non_snake_case, clippy::too_many_arguments)]
pub fn ik(
    model: &PyModel,
    T_goal: &Bound<'_, PyAny>,
    q0: Option<&Bound<'_, PyAny>>,
    method: &str,
    tol_position: f64,
    tol_rotation: f64,
    max_iterations: Int,
    restarts: Int,
    seed: Int,
    respect_limits: bool,
    damping: f64,
) -> PyResult<PyIkResult> {
    let opts = options(method, tol_position, tol_rotation, max_iterations, restarts, seed, respect_limits, damping)?;
    let goal = pose("T_goal", T_goal)?;
    let q0 = start(model, q0, "q0")?;
    let m: &denavit_core::Model = &model.inner;
    // an unreachable goal runs every restart (up to a millisecond by default): let other threads run
    // meanwhile, and let Ctrl-C stop a long budget
    let long = long_solve(m, &opts, 1);
    let r = crate::signals::without_gil(T_goal.py(), long, || core_ik::ik(m, &goal, &q0, &opts))?;
    Ok(PyIkResult { inner: r.py()? })
}

/// Solve goals (N, 4, 4) in order, each warm-started from the previous solution (the first from q0).
/// Releases the GIL.
#[pyfunction]
#[pyo3(signature = (model, goals, q0=None, *, method="lm", tol_position=1e-10, tol_rotation=1e-10, max_iterations=Int(Ok(100)), restarts=Int(Ok(50)), seed=Int(Ok(0)), respect_limits=true, damping=0.1))]
#[allow(clippy::too_many_arguments)]
pub fn ik_path(
    py: Python<'_>,
    model: &PyModel,
    goals: &Bound<'_, PyAny>,
    q0: Option<&Bound<'_, PyAny>>,
    method: &str,
    tol_position: f64,
    tol_rotation: f64,
    max_iterations: Int,
    restarts: Int,
    seed: Int,
    respect_limits: bool,
    damping: f64,
) -> PyResult<PyIkBatchResult> {
    let opts = options(method, tol_position, tol_rotation, max_iterations, restarts, seed, respect_limits, damping)?;
    let goals = poses("goals", goals)?;
    let q0 = start(model, q0, "q0")?;
    let m = model.inner.clone();
    let long = long_solve(&m, &opts, goals.len());
    let results = crate::signals::without_gil(py, long, move || core_ik::ik_path(&m, &goals, &q0, &opts))?.py()?;
    Ok(PyIkBatchResult { results, n: model.inner.nq() })
}

/// Solve independent goals (N, 4, 4) from q0s ((N, n), or (n,) for all; default zeros) on every core,
/// without the GIL. Goal i's restarts are seeded from (seed, i): the results do not depend on threads.
#[pyfunction]
#[pyo3(signature = (model, goals, q0s=None, *, method="lm", tol_position=1e-10, tol_rotation=1e-10, max_iterations=Int(Ok(100)), restarts=Int(Ok(50)), seed=Int(Ok(0)), respect_limits=true, damping=0.1, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn ik_batch(
    py: Python<'_>,
    model: &PyModel,
    goals: &Bound<'_, PyAny>,
    q0s: Option<&Bound<'_, PyAny>>,
    method: &str,
    tol_position: f64,
    tol_rotation: f64,
    max_iterations: Int,
    restarts: Int,
    seed: Int,
    respect_limits: bool,
    damping: f64,
    threads: Option<Threads>,
) -> PyResult<PyIkBatchResult> {
    let threads = threads_of(threads);
    let opts = options(method, tol_position, tol_rotation, max_iterations, restarts, seed, respect_limits, damping)?;
    let goals = poses("goals", goals)?;
    let n = model.inner.nq();
    // (n,) for every goal or (N, n): the core tells them apart by length
    let q0s = match q0s {
        Some(a) => {
            let (v, shape) = read("q0s", a)?;
            if shape.len() != 1 {
                check_shape("q0s", &shape, &[None, Some(n)])?;
            }
            v
        }
        None => vec![0.0; n],
    };
    let m = model.inner.clone();
    let long = long_solve(&m, &opts, goals.len());
    let results = crate::signals::without_gil(py, long, move || {
        denavit_core::parallel::with_threads(threads, || core_ik::ik_batch(&m, &goals, &q0s, &opts)).and_then(|r| r)
    })?
    .py()?;
    Ok(PyIkBatchResult { results, n })
}

/// Register the classes and functions of this file.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyIkResult>()?;
    m.add_class::<PyIkBatchResult>()?;
    m.add_function(wrap_pyfunction!(ik, m)?)?;
    m.add_function(wrap_pyfunction!(ik_path, m)?)?;
    m.add_function(wrap_pyfunction!(ik_batch, m)?)?;
    Ok(())
}
