//! Calibration chains (`denavit_core::calibration`): tool poses and identification Jacobians in batch.

use crate::convert::{check_shape, pose_from_slice, values, ArrayIn};
use crate::error::{value_error, IntoPy};
use denavit_core::calibration::{Axis, Chain, Factor};
use numpy::{PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use std::sync::Arc;

/// Tool poses (N, 4, 4) and optional Jacobians (N, 6, n_params).
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
    pub inner: Arc<Chain>,
}

fn index(what: &str, k: usize, v: i64) -> PyResult<Option<usize>> {
    match v {
        -1 => Ok(None),
        v if v >= 0 => Ok(Some(v as usize)),
        v => Err(value_error(format!("{what}[{k}]: expected an index >= 0 or -1 for none, got {v}"))),
    }
}

#[pymethods]
impl PyChain {
    #[new]
    #[pyo3(signature = (axes, params, joints, fixed, n_params, nq, scales))]
    fn new(axes: Vec<String>, params: Vec<i64>, joints: Vec<i64>, fixed: ArrayIn<'_>, n_params: usize, nq: usize, scales: Vec<i64>) -> PyResult<Self> {
        let k = axes.len();
        if params.len() != k || joints.len() != k {
            return Err(value_error(format!("axes, params, joints: expected the same length, got {k}, {}, {}", params.len(), joints.len())));
        }
        let (fv, fs) = values(&fixed);
        let nf = fs.first().copied().unwrap_or(0);
        if !fv.is_empty() || fs.len() == 3 {
            check_shape("fixed", &fs, &[Some(nf), Some(4), Some(4)])?;
        }
        let mut used = 0;
        let mut factors = Vec::with_capacity(k);
        for i in 0..k {
            if axes[i].eq_ignore_ascii_case("fixed") {
                if used >= nf {
                    return Err(value_error(format!("fixed: factor {i} is 'fixed' but only {nf} fixed poses were given")));
                }
                factors.push(Factor::Fixed(pose_from_slice(&format!("fixed[{used}]"), &fv[16 * used..16 * used + 16])?));
                used += 1;
            } else {
                let axis = Axis::parse(&axes[i]).py()?;
                let p = index("params", i, params[i])?.ok_or_else(|| value_error(format!("params[{i}]: an elementary factor needs a parameter index, got -1")))?;
                factors.push(Factor::param(axis, p, index("joints", i, joints[i])?));
            }
        }
        if used != nf {
            return Err(value_error(format!("fixed: {nf} poses given but {used} factors are 'fixed'")));
        }
        let scales = scales.iter().enumerate().map(|(j, &s)| index("scales", j, s)).collect::<PyResult<Vec<_>>>()?;
        Ok(Self { inner: Arc::new(Chain::new(factors, n_params, nq, scales).py()?) })
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
    /// Tool poses (N, 4, 4) and, if `jacobian`, identification Jacobians (N, 6, n_params), rows [v; w] in
    /// world (derivative of the tool origin, small rotation of the tool), for parameters x (n_params,) and
    /// configurations qs (N, nq). Runs without the GIL on every core.
    #[pyo3(signature = (x, qs, jacobian=true))]
    fn evaluate<'py>(&self, py: Python<'py>, x: ArrayIn<'py>, qs: ArrayIn<'py>, jacobian: bool) -> PyResult<Evaluated<'py>> {
        let (xv, xs) = values(&x);
        check_shape("x", &xs, &[Some(self.inner.n_params())])?;
        let (q, qshape) = values(&qs);
        check_shape("qs", &qshape, &[None, Some(self.inner.nq())])?;
        let count = qshape[0];
        let chain = self.inner.clone();
        let np = chain.n_params();
        let (poses, jac) = py.allow_threads(move || {
            let mut poses = vec![0.0; 16 * count];
            let mut jac = if jacobian { vec![0.0; 6 * np * count] } else { Vec::new() };
            chain.evaluate_batch(&xv, &q, &mut poses, jacobian.then_some(jac.as_mut_slice())).map(|_| (poses, jac))
        }).py()?;
        let poses = numpy::PyArray1::from_vec(py, poses).reshape([count, 4, 4])?;
        let jac = if jacobian { Some(numpy::PyArray1::from_vec(py, jac).reshape([count, 6, np])?) } else { None };
        Ok((poses, jac))
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
/// with the tool `T_last_tool` (4, 4) in the convention's last frame, for `measure` "point" | "pose", with a
/// scale parameter per joint if `scale`. A dict: `chain` (CalibrationChain), the factors (`axes`, `params`,
/// `joints` (-1: none), `fixed` (F, 4, 4) in the order of the "fixed" entries), the parameters (`names`,
/// `x0`, `units`, `groups`, `along`: translation along a joint axis, `rules`: {name: why the
/// parametrization holds it fixed}), `joint_factors`, `base_end`, `tool_start`, `scales` (-1: none).
#[pyfunction]
#[pyo3(signature = (table, T_last_tool, measure="point", scale=false, robot="robot"))]
#[allow(non_snake_case)]
pub fn parametrize(py: Python<'_>, table: &crate::model::PyTable, T_last_tool: ArrayIn<'_>, measure: &str, scale: bool, robot: &str) -> PyResult<PyObject> {
    use denavit_core::convention::Measure;
    let tool = crate::convert::pose("T_last_tool", &T_last_tool)?;
    let p = table.inner.parametrize(robot, &tool, Measure::parse(measure).py()?, scale).py()?;
    let mut axes = Vec::new();
    let mut params = Vec::new();
    let mut joints = Vec::new();
    let mut fixed = Vec::new();
    for f in &p.factors {
        match f {
            Factor::Fixed(t) => {
                axes.push("fixed");
                params.push(-1i64);
                joints.push(-1i64);
                let mut v = [0.0; 16];
                crate::convert::write_pose(t, &mut v);
                fixed.extend_from_slice(&v);
            }
            Factor::Elementary { axis, param, joint } => {
                axes.push(axis.name());
                params.push(*param as i64);
                joints.push(joint.map_or(-1, |j| j as i64));
            }
        }
    }
    let nf = fixed.len() / 16;
    let chain = Chain::new(p.factors.clone(), p.params.len(), table.inner.nq(), p.scales.clone()).py()?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("chain", PyChain { inner: Arc::new(chain) })?;
    d.set_item("axes", axes)?;
    d.set_item("params", params)?;
    d.set_item("joints", joints)?;
    d.set_item("fixed", numpy::PyArray1::from_vec(py, fixed).reshape([nf, 4, 4])?)?;
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
    d.set_item("scales", p.scales.iter().map(|s| s.map_or(-1, |v| v as i64)).collect::<Vec<_>>())?;
    Ok(d.into_any().unbind())
}
