//! Calibration chains (`denavit_core::calibration`): tool poses and identification Jacobians in batch.

use crate::convert::{poses, poses_out, vector};
use crate::error::{invalid, IntoPy};
use denavit_core::calibration::{CalibrationChain, CalibrationFactor, JacobianOut, Motion};
use denavit_core::spatial::Pose;
use numpy::{PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use std::sync::Arc;

/// Tool poses (N, 4, 4) and optional Jacobians (N, rows, columns).
type Evaluated<'py> = (Bound<'py, PyArray3<f64>>, Option<Bound<'py, PyArray3<f64>>>);

/// A chain of elementary factors with named parameters (`denavit_core::calibration`; built by `denavit.calibrate`).
///
/// axes : K strings, "rx" | "ry" | "rz" | "tx" | "ty" | "tz" | "fixed"; params : K ints (parameter index,
/// ignored for "fixed"); joints : K ints (0-based joint whose reading adds to the value, -1 for none);
/// fixed : (F, 4, 4) the fixed poses, in the order of the "fixed" entries; n_params, nq : sizes;
/// scales : nq ints, the scale parameter of each joint (-1 for none).
#[pyclass(module = "denavit._core", name = "CalibrationChain", frozen)]
#[derive(Clone)]
pub struct PyChain {
    pub inner: Arc<CalibrationChain>,
    /// The constructor's arguments, for pickling.
    args: Arc<ChainArgs>,
}

struct ChainArgs {
    axes: Vec<String>,
    params: Vec<i64>,
    joints: Vec<i64>,
    fixed: Vec<Pose>,
    scales: Vec<i64>,
}

/// A Python index, -1 for none.
fn index(what: &str, k: usize, v: i64) -> PyResult<Option<usize>> {
    match v {
        -1 => Ok(None),
        v => usize::try_from(v).map(Some).map_err(|_| invalid(format!("{what}[{k}]"), "an index >= 0 or -1 for none", v.to_string())),
    }
}

/// A Python int as a size.
fn size(what: &str, v: i64) -> PyResult<usize> {
    usize::try_from(v).map_err(|_| invalid(what, "an integer >= 0", v.to_string()))
}

#[pymethods]
impl PyChain {
    #[new]
    #[pyo3(signature = (axes, params, joints, fixed, n_params, nq, scales))]
    fn new(axes: Vec<String>, params: Vec<i64>, joints: Vec<i64>, fixed: &Bound<'_, PyAny>, n_params: i64, nq: i64, scales: Vec<i64>) -> PyResult<Self> {
        let k = axes.len();
        if params.len() != k || joints.len() != k {
            return Err(invalid("axes, params, joints", "lists of the same length", format!("lengths {k}, {}, {}", params.len(), joints.len())));
        }
        let fixed = poses("fixed", fixed)?;
        let mut next = fixed.iter();
        let mut factors = Vec::with_capacity(k);
        for i in 0..k {
            if axes[i].eq_ignore_ascii_case("fixed") {
                let count = fixed.len();
                let t = next.next().ok_or_else(|| invalid("fixed", format!("a pose for factor {i} ('fixed')"), format!("{count} fixed poses")))?;
                factors.push(CalibrationFactor::Fixed(*t));
            } else {
                let axis = Motion::parse(&axes[i]).py()?;
                let p = index("params", i, params[i])?.ok_or_else(|| invalid(format!("params[{i}]"), "a parameter index for an elementary factor", "-1"))?;
                factors.push(CalibrationFactor::param(axis, p, index("joints", i, joints[i])?));
            }
        }
        let used = fixed.len() - next.len();
        if used != fixed.len() {
            return Err(invalid("fixed", format!("{used} poses (one per 'fixed' factor)"), format!("{} poses", fixed.len())));
        }
        let sc = scales.iter().enumerate().map(|(j, &s)| index("scales", j, s)).collect::<PyResult<Vec<_>>>()?;
        let inner = Arc::new(CalibrationChain::new(factors, size("n_params", n_params)?, size("nq", nq)?, sc).py()?);
        Ok(Self { inner, args: Arc::new(ChainArgs { axes, params, joints, fixed, scales }) })
    }
    /// Number of parameters.
    #[getter]
    fn n_params(&self) -> usize {
        self.inner.n_params()
    }
    /// Number of joints.
    #[getter]
    fn nq(&self) -> usize {
        self.inner.nq()
    }
    /// Tool poses (N, 4, 4) and, if `jacobian`, identification Jacobians (N, rows, len(columns)), rows [v; w]
    /// in world (derivative of the tool origin, small rotation of the tool) for parameters x (n_params,) and
    /// configurations qs (N, nq). `rows`: the first 3 (tool origin) or all 6; `columns`: the parameters
    /// (indices, each once; default all, in order); `weights` (rows,): each row times its weight (after the
    /// sums: the full Jacobian's entries times the weights, bit for bit). Only what is asked for is written,
    /// without the GIL, on every core.
    #[pyo3(signature = (x, qs, jacobian=true, *, rows=6, columns=None, weights=None))]
    #[allow(clippy::too_many_arguments)]
    fn evaluate<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        qs: &Bound<'py, PyAny>,
        jacobian: bool,
        rows: i64,
        columns: Option<Vec<i64>>,
        weights: Option<&Bound<'py, PyAny>>,
    ) -> PyResult<Evaluated<'py>> {
        let x = vector("x", x)?;
        let (q, count) = crate::convert::rows("qs", qs, self.inner.nq())?;
        let q = q.slice();
        let chain: &CalibrationChain = &self.inner;
        let rows = usize::try_from(rows)
            .ok()
            .filter(|r| (1..=6).contains(r))
            .ok_or_else(|| invalid("rows", "1 to 6 (3: the tool origin's; 6: with the rotation)", rows.to_string()))?;
        let columns = match columns {
            None => None,
            Some(c) => Some(c.iter().enumerate().map(|(k, &v)| size(&format!("columns[{k}]"), v)).collect::<PyResult<Vec<_>>>()?),
        };
        let mut w = [1.0; 6];
        if let Some(v) = weights {
            let v = vector("weights", v)?;
            crate::convert::check_len("weights", rows, v.len())?;
            w[..rows].copy_from_slice(&v);
        }
        let poses = PyArray3::<f64>::zeros(py, [count, 4, 4], false);
        let nc = columns.as_ref().map_or(chain.n_params(), Vec::len);
        let jac = jacobian.then(|| PyArray3::<f64>::zeros(py, [count, rows, nc], false));
        {
            // fresh arrays: never borrowed elsewhere
            let busy = |_| invalid("result arrays", "arrays of this call alone", "an array borrowed elsewhere");
            let mut pw = poses.try_readwrite().map_err(busy)?;
            let po = pw.as_slice_mut()?;
            let mut jw = jac.as_ref().map(|j| j.try_readwrite()).transpose().map_err(busy)?;
            let jo = jw.as_mut().map(|j| j.as_slice_mut()).transpose()?;
            let sel = jo.map(|out| JacobianOut { out, rows, columns: columns.as_deref(), weights: w });
            let long = crate::signals::long(20.0 * (po.len() + sel.as_ref().map_or(0, |j| j.out.len())) as f64);
            crate::signals::without_gil(py, long, || chain.evaluate_batch(&x, q, po, sel))?.py()?;
        }
        Ok((poses, jac))
    }
    /// Pickle / copy: `CalibrationChain(axes, params, joints, fixed, n_params, nq, scales)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let a = &self.args;
        let fixed = poses_out(py, a.fixed.iter())?;
        (py.get_type::<Self>(), (a.axes.clone(), a.params.clone(), a.joints.clone(), fixed, self.inner.n_params(), self.inner.nq(), a.scales.clone()))
            .into_pyobject(py)
    }
    fn __repr__(&self) -> String {
        format!("CalibrationChain({} factors, {} parameters, {} joints)", self.inner.factors().len(), self.inner.n_params(), self.inner.nq())
    }
}

/// Register the classes of this file.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<PyChain>()?;
    m.add_function(wrap_pyfunction!(parametrize, m)?)
}

/// The calibration parametrization of `table` (`dh`, `mdh`, `edh`; `denavit_core::Table::parametrize`)
/// with the flange `T_last_flange` (4, 4) fixed in the convention's last frame and the tool `T_flange_tool`
/// (4, 4) in the flange, for `measure` "point" | "pose", with a
/// scale parameter per joint if `scale`. A dict: `chain` (CalibrationChain), the factors (`axes`, `params`,
/// `joints` (-1: none), `fixed` (F, 4, 4) in the order of the "fixed" entries), the parameters (`names`,
/// `x0`, `units`, `groups`, `along`: translation along a joint axis, `rules`: {name: why the
/// parametrization holds it fixed}), `joint_factors`, `base_end`, `tool_start`, `scales` (-1: none).
#[pyfunction]
#[pyo3(signature = (table, T_last_flange, T_flange_tool, measure="point", scale=false, robot="robot"))]
#[allow(non_snake_case)]
pub fn parametrize(
    py: Python<'_>,
    table: &crate::model::PyTable,
    T_last_flange: &Bound<'_, PyAny>,
    T_flange_tool: &Bound<'_, PyAny>,
    measure: &str,
    scale: bool,
    robot: &str,
) -> PyResult<PyObject> {
    use denavit_core::convention::Measure;
    let flange = crate::convert::pose("T_last_flange", T_last_flange)?;
    let tool = crate::convert::pose("T_flange_tool", T_flange_tool)?;
    let p = table.inner.parametrize(robot, &flange, &tool, Measure::parse(measure).py()?, scale).py()?;
    let (mut axes, mut params, mut joints, mut fixed) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for f in &p.factors {
        match f {
            CalibrationFactor::Fixed(t) => {
                axes.push("fixed".to_string());
                params.push(-1i64);
                joints.push(-1i64);
                fixed.push(*t);
            }
            CalibrationFactor::Elementary { axis, param, joint } => {
                axes.push(axis.name().to_string());
                params.push(*param as i64);
                joints.push(joint.map_or(-1, |j| j as i64));
            }
        }
    }
    let scales: Vec<i64> = p.scales.iter().map(|s| s.map_or(-1, |v| v as i64)).collect();
    let chain = CalibrationChain::new(p.factors.clone(), p.params.len(), table.inner.nq(), p.scales.clone()).py()?;
    let args = ChainArgs { axes: axes.clone(), params: params.clone(), joints: joints.clone(), fixed: fixed.clone(), scales: scales.clone() };
    let d = pyo3::types::PyDict::new(py);
    d.set_item("chain", PyChain { inner: Arc::new(chain), args: Arc::new(args) })?;
    d.set_item("axes", axes)?;
    d.set_item("params", params)?;
    d.set_item("joints", joints)?;
    d.set_item("fixed", poses_out(py, fixed.iter())?)?;
    d.set_item("names", p.params.iter().map(|x| x.name.clone()).collect::<Vec<_>>())?;
    d.set_item("x0", numpy::PyArray1::from_vec(py, p.params.iter().map(|x| x.value).collect::<Vec<_>>()))?;
    d.set_item("units", p.params.iter().map(|x| x.unit).collect::<Vec<_>>())?;
    d.set_item("groups", p.params.iter().map(|x| x.group).collect::<Vec<_>>())?;
    d.set_item("along", p.params.iter().map(|x| x.along_axis).collect::<Vec<_>>())?;
    let rules = pyo3::types::PyDict::new(py);
    for x in &p.params {
        if let Some(why) = &x.fixed {
            rules.set_item(&x.name, why)?;
        }
    }
    d.set_item("rules", rules)?;
    d.set_item("joint_factors", p.joint_factors.clone())?;
    d.set_item("base_end", p.base_end)?;
    d.set_item("tool_start", p.tool_start)?;
    d.set_item("scales", scales)?;
    Ok(d.into_any().unbind())
}
