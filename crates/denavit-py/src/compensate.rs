//! Compensation of positions (denavit_core::compensate): batch, without the GIL, on every core.

use crate::convert::{check_len, out, poses, poses_out, shaped, Int};
use crate::error::IntoPy;
use crate::ik::{options, start};
use crate::model::PyModel;
use denavit_core::compensate::{self as core_comp, CompensateOptions};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::PyTuple;

/// The compensation of N positions (denavit_core::compensate): per position the identified model's joint
/// values, the nominal ones, the pose to send to a nominal controller, and the flags.
#[pyclass(module = "denavit._core", name = "Compensation", frozen)]
pub struct PyCompensation {
    rows: Vec<core_comp::Compensation>,
    n: usize,
}

impl PyCompensation {
    fn floats<'py>(&self, py: Python<'py>, f: impl Fn(&core_comp::Compensation) -> f64) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.rows.iter().map(f).collect())
    }
    fn flags<'py>(&self, py: Python<'py>, f: impl Fn(&core_comp::Compensation) -> bool) -> Bound<'py, PyArray1<bool>> {
        PyArray1::from_vec(py, self.rows.iter().map(f).collect())
    }
    fn joints<'py>(&self, py: Python<'py>, f: impl Fn(&core_comp::Compensation) -> &[f64]) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.rows.iter().flat_map(|r| f(r).iter().copied()).collect();
        out(py, &v, [self.rows.len(), self.n])
    }
}

#[pymethods]
impl PyCompensation {
    /// The per-position arrays of the getters, N rows each (q, q_nominal (N, n); commands (N, 4, 4); the rest (N,)).
    #[new]
    #[allow(clippy::too_many_arguments)]
    fn new(
        q: &Bound<'_, PyAny>,
        q_nominal: &Bound<'_, PyAny>,
        commands: &Bound<'_, PyAny>,
        reached: Vec<bool>,
        nominal_reached: Vec<bool>,
        branch_changed: Vec<bool>,
        path_jump: Vec<bool>,
        position_error: Vec<f64>,
        rotation_error: Vec<f64>,
        before_position: Vec<f64>,
        before_rotation: Vec<f64>,
    ) -> PyResult<Self> {
        let (qv, qs) = shaped("q", q, &[None, None])?;
        let (count, n) = (qs[0], qs[1]);
        let (qn, _) = shaped("q_nominal", q_nominal, &[Some(count), Some(n)])?;
        let commands = poses("commands", commands)?;
        check_len("commands (one per position)", count, commands.len())?;
        for (what, len) in
            [("reached", reached.len()), ("nominal_reached", nominal_reached.len()), ("branch_changed", branch_changed.len()), ("path_jump", path_jump.len())]
        {
            check_len(&format!("{what} (one per position)"), count, len)?;
        }
        for (what, len) in [
            ("position_error", position_error.len()),
            ("rotation_error", rotation_error.len()),
            ("before_position", before_position.len()),
            ("before_rotation", before_rotation.len()),
        ] {
            check_len(&format!("{what} (one per position)"), count, len)?;
        }
        let rows = (0..count)
            .map(|i| core_comp::Compensation {
                q: qv[i * n..(i + 1) * n].to_vec(),
                q_nominal: qn[i * n..(i + 1) * n].to_vec(),
                command: commands[i],
                reached: reached[i],
                nominal_reached: nominal_reached[i],
                branch_changed: branch_changed[i],
                path_jump: path_jump[i],
                position_error: position_error[i],
                rotation_error: rotation_error[i],
                before_position: before_position[i],
                before_rotation: before_rotation[i],
            })
            .collect();
        Ok(Self { rows, n })
    }
    /// Pickle / copy: `Compensation(q, q_nominal, commands, reached, ..., before_rotation)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let r = &self.rows;
        let b = |f: fn(&core_comp::Compensation) -> bool| r.iter().map(f).collect::<Vec<_>>();
        let x = |f: fn(&core_comp::Compensation) -> f64| r.iter().map(f).collect::<Vec<_>>();
        let args = (
            self.q(py)?,
            self.q_nominal(py)?,
            self.commands(py)?,
            b(|c| c.reached),
            b(|c| c.nominal_reached),
            b(|c| c.branch_changed),
            b(|c| c.path_jump),
            x(|c| c.position_error),
            x(|c| c.rotation_error),
            x(|c| c.before_position),
            x(|c| c.before_rotation),
        );
        (py.get_type::<Self>(), args).into_pyobject(py)
    }
    fn __len__(&self) -> usize {
        self.rows.len()
    }
    /// (N, n) joint values that reach each position on the identified model (rad / m).
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.joints(py, |r| &r.q)
    }
    /// (N, n) the nominal model's joint values of each position (given or solved).
    #[getter]
    fn q_nominal<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        self.joints(py, |r| &r.q_nominal)
    }
    /// (N, 4, 4) T' = FK_nominal(q): the poses to send to a controller that keeps its nominal model.
    #[getter]
    fn commands<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        poses_out(py, self.rows.iter().map(|r| &r.command))
    }
    /// (N,) the identified solve met the IK tolerances.
    #[getter]
    fn reached<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.flags(py, |r| r.reached)
    }
    /// (N,) the nominal solve met the IK tolerances (True where the nominal joint values were given).
    #[getter]
    fn nominal_reached<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.flags(py, |r| r.nominal_reached)
    }
    /// (N,) q left the nominal solution's branch (a joint differs by more than branch_tol).
    #[getter]
    fn branch_changed<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.flags(py, |r| r.branch_changed)
    }
    /// (N,) path mode: the nominal solution jumped by more than path_jump from the previous position's.
    #[getter]
    fn path_jump<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<bool>> {
        self.flags(py, |r| r.path_jump)
    }
    /// (N,) residual of the identified solve: tool position (m).
    #[getter]
    fn position_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.floats(py, |r| r.position_error)
    }
    /// (N,) residual of the identified solve: tool rotation (rad).
    #[getter]
    fn rotation_error<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.floats(py, |r| r.rotation_error)
    }
    /// (N,) what the robot would miss uncompensated: |p_identified(q_nominal) - p| (m, p the position's translation).
    #[getter]
    fn before_position<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.floats(py, |r| r.before_position)
    }
    /// (N,) the same for the rotation (rad).
    #[getter]
    fn before_rotation<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.floats(py, |r| r.before_rotation)
    }
    fn __repr__(&self) -> String {
        let bad = self.rows.iter().filter(|r| !r.reached || r.branch_changed || r.path_jump).count();
        format!("Compensation({} positions, {} flagged)", self.rows.len(), bad)
    }
}

/// Compensate positions (N, 4, 4) `T_world_tool` for a controller that keeps `nominal` while the robot is
/// `identified` (denavit_core::compensate). `q_nominal` (N, n): the program's nominal joint values, if it
/// was given as joint rows (else solved on the nominal model from q0). `path`: warm-start along the program
/// and flag jumps larger than `path_jump`; `branch_tol` (rad / m): largest joint change that keeps the branch.
/// IK options as in `ik_batch`. Releases the GIL; every core.
#[pyfunction]
#[pyo3(signature = (nominal, identified, positions, q_nominal=None, q0=None, *, path=false, branch_tol=0.1, path_jump=std::f64::consts::FRAC_PI_4, method="lm", tol_position=1e-10, tol_rotation=1e-10, max_iterations=Int(Ok(100)), restarts=Int(Ok(50)), seed=Int(Ok(0)), respect_limits=true, damping=0.1))]
#[allow(clippy::too_many_arguments)]
pub fn compensate(
    py: Python<'_>,
    nominal: &PyModel,
    identified: &PyModel,
    positions: &Bound<'_, PyAny>,
    q_nominal: Option<&Bound<'_, PyAny>>,
    q0: Option<&Bound<'_, PyAny>>,
    path: bool,
    branch_tol: f64,
    path_jump: f64,
    method: &str,
    tol_position: f64,
    tol_rotation: f64,
    max_iterations: Int,
    restarts: Int,
    seed: Int,
    respect_limits: bool,
    damping: f64,
) -> PyResult<PyCompensation> {
    let ik = options(method, tol_position, tol_rotation, max_iterations, restarts, seed, respect_limits, damping)?;
    let positions = poses("positions", positions)?;
    let n = nominal.inner.nq();
    let qn = q_nominal.map(|a| shaped("q_nominal", a, &[Some(positions.len()), Some(n)]).map(|(v, _)| v)).transpose()?;
    let q0 = start(nominal, q0, "q0")?;
    let (a, b) = (nominal.inner.clone(), identified.inner.clone());
    let opts = CompensateOptions { ik, path, branch_tol, path_jump };
    let long = crate::ik::long_solve(&b, &opts.ik, 2 * positions.len());
    let rows = crate::signals::without_gil(py, long, move || core_comp::compensate(&a, &b, &positions, qn.as_deref(), &q0, &opts))?.py()?;
    Ok(PyCompensation { rows, n })
}

/// Register the compensation.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyCompensation>()?;
    m.add_function(wrap_pyfunction!(compensate, m)?)
}
