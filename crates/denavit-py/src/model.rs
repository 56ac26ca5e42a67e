//! `Model`, `Table`, `JointAxes` and `Extraction` as Python classes.

use crate::convert::{check_shape, pose, pose_out, values, vector, write_pose, ArrayIn};
use crate::error::{value_error, IntoPy};
use denavit_core::extract::{self as core_extract, ExtractOptions};
use denavit_core::spatial::Pose;
use denavit_core::{Convention, Joint, JointKind};
use nalgebra::{DMatrix, Vector3};
use numpy::{PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;
use std::sync::Arc;

fn kinds_from(what: &str, kinds: Vec<String>, n: usize) -> PyResult<Vec<JointKind>> {
    if kinds.len() != n {
        return Err(value_error(format!("{what}: expected {n} joint kinds, got {}", kinds.len())));
    }
    kinds.iter().map(|k| JointKind::parse(k).py()).collect()
}

fn opt_vector(what: &str, a: Option<ArrayIn<'_>>, n: usize, default: impl Fn(usize) -> f64) -> PyResult<Vec<f64>> {
    match a {
        Some(a) => {
            let (v, shape) = values(&a);
            check_shape(what, &shape, &[Some(n)])?;
            if v.iter().any(|x| x.is_nan()) {
                return Err(value_error(format!("{what} must not contain NaN")));
            }
            Ok(v)
        }
        None => Ok((0..n).map(default).collect()),
    }
}

fn default_limit(kinds: &[JointKind], upper: bool) -> impl Fn(usize) -> f64 + '_ {
    move |i| {
        let l = match kinds[i] {
            JointKind::Revolute => std::f64::consts::PI,
            JointKind::Prismatic => 1.0,
        };
        if upper {
            l
        } else {
            -l
        }
    }
}

/// An immutable serial-chain model (docs/conventions.md, "The model").
#[pyclass(module = "denavit._core", name = "Model", frozen)]
#[derive(Clone)]
pub struct PyModel {
    pub inner: Arc<denavit_core::Model>,
}

#[pymethods]
impl PyModel {
    /// Build from joint placements.
    ///
    /// placements : (n, 4, 4) T_{i-1}_i0 in metres; kinds : n strings ("revolute"/"prismatic");
    /// offsets, lower, upper : (n,) rad or m; names : n strings; T_world_base : (4, 4);
    /// T_last_flange : (4, 4) the flange in the last joint frame; T_flange_tool : (4, 4) the tool in the flange.
    #[staticmethod]
    #[pyo3(signature = (placements, kinds, *, offsets=None, lower=None, upper=None, names=None, T_world_base=None, T_last_flange=None, T_flange_tool=None, name="robot"))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn from_placements(
        placements: ArrayIn<'_>,
        kinds: Vec<String>,
        offsets: Option<ArrayIn<'_>>,
        lower: Option<ArrayIn<'_>>,
        upper: Option<ArrayIn<'_>>,
        names: Option<Vec<String>>,
        T_world_base: Option<ArrayIn<'_>>,
        T_last_flange: Option<ArrayIn<'_>>,
        T_flange_tool: Option<ArrayIn<'_>>,
        name: &str,
    ) -> PyResult<Self> {
        let (v, shape) = values(&placements);
        let n = shape.first().copied().unwrap_or(0);
        check_shape("placements", &shape, &[Some(n), Some(4), Some(4)])?;
        let kinds = kinds_from("kinds", kinds, n)?;
        let offsets = opt_vector("offsets", offsets, n, |_| 0.0)?;
        crate::convert::check_finite("offsets", &offsets)?;
        let lower = opt_vector("lower", lower, n, default_limit(&kinds, false))?;
        let upper = opt_vector("upper", upper, n, default_limit(&kinds, true))?;
        let names = names.unwrap_or_else(|| (1..=n).map(|i| format!("j{i}")).collect());
        if names.len() != n {
            return Err(value_error(format!("names: expected {n} joint names, got {}", names.len())));
        }
        let mut joints = Vec::with_capacity(n);
        for i in 0..n {
            let p = crate::convert::pose_from_slice(&format!("placements[{i}] (joint {})", i + 1), &v[16 * i..16 * i + 16])?;
            joints.push(Joint { name: names[i].clone(), kind: kinds[i], placement: p, offset: offsets[i], lower: lower[i], upper: upper[i] });
        }
        let base = T_world_base.map(|a| pose("T_world_base", &a)).transpose()?.unwrap_or_else(Pose::identity);
        let flange = T_last_flange.map(|a| pose("T_last_flange", &a)).transpose()?.unwrap_or_else(Pose::identity);
        let tool = T_flange_tool.map(|a| pose("T_flange_tool", &a)).transpose()?.unwrap_or_else(Pose::identity);
        Ok(Self { inner: Arc::new(denavit_core::Model::new(name, base, joints, flange, tool).py()?) })
    }

    /// Number of joints.
    #[getter]
    fn nq(&self) -> usize {
        self.inner.nq()
    }
    #[getter]
    fn name(&self) -> String {
        self.inner.name().to_string()
    }
    /// Joint names.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner.joints().iter().map(|j| j.name.clone()).collect()
    }
    /// Joint kinds ("revolute" / "prismatic").
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.joints().iter().map(|j| j.kind.name()).collect()
    }
    /// (n, 4, 4) joint placements T_{i-1}_i0.
    #[getter]
    fn placements<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let n = self.inner.nq();
        let mut v = vec![0.0; 16 * n];
        for (i, j) in self.inner.joints().iter().enumerate() {
            write_pose(&j.placement, &mut v[16 * i..16 * i + 16]);
        }
        numpy::PyArray1::from_vec(py, v).reshape([n, 4, 4])
    }
    /// (n,) zero offsets.
    #[getter]
    fn offsets(&self) -> Vec<f64> {
        self.inner.joints().iter().map(|j| j.offset).collect()
    }
    /// (n,) lower limits.
    #[getter]
    fn lower(&self) -> Vec<f64> {
        self.inner.lower()
    }
    /// (n,) upper limits.
    #[getter]
    fn upper(&self) -> Vec<f64> {
        self.inner.upper()
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, self.inner.t_world_base())
    }
    /// The flange (mechanical flange, ROS tool0) in the last joint frame.
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_flange<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, self.inner.t_last_flange())
    }
    /// The tool in the flange (identity unless a tool is attached).
    #[getter]
    #[allow(non_snake_case)]
    fn T_flange_tool<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, self.inner.t_flange_tool())
    }
    /// The tool in the last joint frame: T_last_flange @ T_flange_tool.
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_tool<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, self.inner.t_last_tool())
    }
    /// A copy with another base placement.
    #[allow(non_snake_case)]
    fn with_base(&self, T_world_base: ArrayIn<'_>) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(self.inner.with_base(pose("T_world_base", &T_world_base)?).py()?) })
    }
    /// A copy with another tool T_flange_tool (4, 4), in the flange frame (the flange is kept).
    #[allow(non_snake_case)]
    fn with_tool(&self, T_flange_tool: ArrayIn<'_>) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(self.inner.with_tool(pose("T_flange_tool", &T_flange_tool)?).py()?) })
    }
    fn __repr__(&self) -> String {
        format!("Model('{}', {} joints: {})", self.inner.name(), self.inner.nq(), self.names().join(", "))
    }
}

/// A parameter table of one convention (docs/conventions.md, "Parameter tables").
#[pyclass(module = "denavit._core", name = "Table", frozen)]
#[derive(Clone)]
pub struct PyTable {
    pub inner: denavit_core::Table,
}

#[pymethods]
impl PyTable {
    /// convention : "dh" | "mdh" | "edh" | "poe"; params : (n, k) in the convention's column order (m, rad);
    /// kinds : n strings; T_world_base : (4, 4); T_last_tool : (4, 4) tool in the last frame (poe: home pose M).
    #[new]
    #[pyo3(signature = (convention, params, kinds=None, T_world_base=None, T_last_tool=None))]
    #[allow(non_snake_case)]
    fn new(convention: &str, params: ArrayIn<'_>, kinds: Option<Vec<String>>, T_world_base: Option<ArrayIn<'_>>, T_last_tool: Option<ArrayIn<'_>>) -> PyResult<Self> {
        let conv = Convention::parse(convention).py()?;
        let (v, shape) = values(&params);
        let k = conv.columns().len();
        let n = shape.first().copied().unwrap_or(0);
        check_shape(&format!("params of a {} table (columns {})", conv.name(), conv.columns().join(", ")), &shape, &[Some(n), Some(k)])?;
        let kinds = match kinds {
            Some(k) => kinds_from("kinds", k, n)?,
            None => vec![JointKind::Revolute; n],
        };
        let base = T_world_base.map(|a| pose("T_world_base", &a)).transpose()?.unwrap_or_else(Pose::identity);
        let tool = T_last_tool.map(|a| pose("T_last_tool", &a)).transpose()?.unwrap_or_else(Pose::identity);
        Ok(Self { inner: denavit_core::Table::new(conv, DMatrix::from_row_slice(n, k, &v), kinds, base, tool).py()? })
    }
    #[getter]
    fn convention(&self) -> &'static str {
        self.inner.convention.name()
    }
    /// Column names in order.
    #[getter]
    fn columns(&self) -> Vec<&'static str> {
        self.inner.convention.columns().to_vec()
    }
    /// Which columns are angles.
    #[getter]
    fn angle_columns(&self) -> Vec<bool> {
        self.inner.convention.angle_columns().to_vec()
    }
    /// (n, k) parameters (m, rad).
    #[getter]
    fn params<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let p = &self.inner.params;
        let v: Vec<f64> = (0..p.nrows()).flat_map(|i| (0..p.ncols()).map(move |j| p[(i, j)])).collect();
        numpy::PyArray1::from_vec(py, v).reshape([p.nrows(), p.ncols()])
    }
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.kinds.iter().map(|k| k.name()).collect()
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, &self.inner.t_world_base)
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_tool<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, &self.inner.t_last_tool)
    }
    /// The model of this table; names / lower / upper default to j1..jn and +-pi (+-1 m).
    #[pyo3(signature = (name="robot", names=None, lower=None, upper=None))]
    fn to_model(&self, name: &str, names: Option<Vec<String>>, lower: Option<ArrayIn<'_>>, upper: Option<ArrayIn<'_>>) -> PyResult<PyModel> {
        let n = self.inner.nq();
        let names = names.unwrap_or_else(|| (1..=n).map(|i| format!("j{i}")).collect());
        let lower = opt_vector("lower", lower, n, default_limit(&self.inner.kinds, false))?;
        let upper = opt_vector("upper", upper, n, default_limit(&self.inner.kinds, true))?;
        Ok(PyModel { inner: Arc::new(self.inner.to_model_with(name, &names, &lower, &upper).py()?) })
    }
    /// (n, 4, 4): the pose of the convention's frame i in the model's joint frame i (i = 1..n; the identity
    /// except for dh, where DH frame i = joint frame i @ Tz(d_i) Tx(a_i) Rx(alpha_i)).
    fn link_frames<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let f = self.inner.link_frames();
        let mut v = vec![0.0; 16 * f.len()];
        for (i, t) in f.iter().enumerate() {
            write_pose(t, &mut v[16 * i..16 * i + 16]);
        }
        numpy::PyArray1::from_vec(py, v).reshape([f.len(), 4, 4])
    }
    /// (n+1, 4, 4): the convention's frames 0..n in world at q.
    fn frames<'py>(&self, py: Python<'py>, q: ArrayIn<'_>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let q = vector("q", &q, self.inner.nq())?;
        let f = self.inner.frames(&q).py()?;
        let mut v = vec![0.0; 16 * f.len()];
        for (i, t) in f.iter().enumerate() {
            write_pose(t, &mut v[16 * i..16 * i + 16]);
        }
        numpy::PyArray1::from_vec(py, v).reshape([f.len(), 4, 4])
    }
    fn __repr__(&self) -> String {
        format!("Table('{}', {} joints)", self.inner.convention.name(), self.inner.nq())
    }
}

/// Joint axis lines in world at a reference configuration (docs/conventions.md, "Joint axes").
#[pyclass(module = "denavit._core", name = "JointAxes", frozen)]
#[derive(Clone)]
pub struct PyJointAxes {
    pub inner: denavit_core::JointAxes,
}

#[pymethods]
impl PyJointAxes {
    /// points, directions : (n, 3) in world (m); kinds : n strings; q_ref : (n,); T_world_base,
    /// T_world_tool : (4, 4); lower, upper : (n,).
    #[new]
    #[pyo3(signature = (points, directions, *, kinds=None, q_ref=None, T_world_base=None, T_world_tool=None, lower=None, upper=None))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn new(
        points: ArrayIn<'_>,
        directions: ArrayIn<'_>,
        kinds: Option<Vec<String>>,
        q_ref: Option<ArrayIn<'_>>,
        T_world_base: Option<ArrayIn<'_>>,
        T_world_tool: Option<ArrayIn<'_>>,
        lower: Option<ArrayIn<'_>>,
        upper: Option<ArrayIn<'_>>,
    ) -> PyResult<Self> {
        let (p, ps) = values(&points);
        let n = ps.first().copied().unwrap_or(0);
        check_shape("points", &ps, &[Some(n), Some(3)])?;
        crate::convert::check_finite("points", &p)?;
        let (d, ds) = values(&directions);
        check_shape("directions", &ds, &[Some(n), Some(3)])?;
        crate::convert::check_finite("directions", &d)?;
        let kinds = match kinds {
            Some(k) => kinds_from("kinds", k, n)?,
            None => vec![JointKind::Revolute; n],
        };
        let q_ref = opt_vector("q_ref", q_ref, n, |_| 0.0)?;
        let lower = opt_vector("lower", lower, n, default_limit(&kinds, false))?;
        let upper = opt_vector("upper", upper, n, default_limit(&kinds, true))?;
        let base = T_world_base.map(|a| pose("T_world_base", &a)).transpose()?.unwrap_or_else(Pose::identity);
        let tool = T_world_tool.map(|a| pose("T_world_tool", &a)).transpose()?.unwrap_or_else(Pose::identity);
        let v3 = |v: &[f64], i: usize| Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
        Ok(Self {
            inner: denavit_core::JointAxes::new(
                base,
                (0..n).map(|i| v3(&p, i)).collect(),
                (0..n).map(|i| v3(&d, i)).collect(),
                kinds,
                q_ref,
                tool,
                lower,
                upper,
            )
            .py()?,
        })
    }
    #[getter]
    fn nq(&self) -> usize {
        self.inner.nq()
    }
    /// (n, 3) points on the axes (m, world).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.inner.points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        numpy::PyArray1::from_vec(py, v).reshape([self.inner.nq(), 3])
    }
    /// (n, 3) unit directions (world).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.inner.directions.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        numpy::PyArray1::from_vec(py, v).reshape([self.inner.nq(), 3])
    }
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.kinds.iter().map(|k| k.name()).collect()
    }
    #[getter]
    fn q_ref(&self) -> Vec<f64> {
        self.inner.q_ref.clone()
    }
    #[getter]
    fn lower(&self) -> Vec<f64> {
        self.inner.lower.clone()
    }
    #[getter]
    fn upper(&self) -> Vec<f64> {
        self.inner.upper.clone()
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, &self.inner.t_world_base)
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_tool<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        pose_out(py, &self.inner.t_world_tool)
    }
    fn __repr__(&self) -> String {
        format!("JointAxes({} axes)", self.inner.nq())
    }
}

/// One consecutive pair of axes as seen by an extraction.
#[pyclass(module = "denavit._core", name = "PairDiagnostic", frozen, get_all)]
#[derive(Clone)]
pub struct PyPair {
    /// 1-based index i of the pair (i, i+1).
    pub joint: usize,
    /// "skew" | "intersecting" | "parallel" | "coincident".
    pub relation: &'static str,
    /// Angle between the axes (rad).
    pub angle: f64,
    /// Common-normal length or distance between parallel lines (m).
    pub distance: f64,
    /// Hayati-style misalignment the table cannot represent (rad).
    pub hayati_beta: f64,
}

#[pymethods]
impl PyPair {
    fn __repr__(&self) -> String {
        format!("PairDiagnostic(joint={}, relation='{}', angle={:.6e}, distance={:.6e}, hayati_beta={:.3e})", self.joint, self.relation, self.angle, self.distance, self.hayati_beta)
    }
}

/// The result of an extraction: the table and what it cannot represent.
#[pyclass(module = "denavit._core", name = "Extraction", frozen, get_all)]
#[derive(Clone)]
pub struct PyExtraction {
    pub table: PyTable,
    pub pairs: Vec<PyPair>,
    /// Largest tool-position error (m) of the table's model against the axes (sampled configurations).
    pub max_position_error: f64,
    /// Largest tool-rotation error (rad).
    pub max_rotation_error: f64,
}

impl From<core_extract::Extraction> for PyExtraction {
    fn from(e: core_extract::Extraction) -> Self {
        Self {
            table: PyTable { inner: e.table },
            pairs: e
                .pairs
                .iter()
                .map(|p| PyPair { joint: p.joint, relation: p.relation.name(), angle: p.angle, distance: p.distance, hayati_beta: p.hayati_beta })
                .collect(),
            max_position_error: e.max_position_error,
            max_rotation_error: e.max_rotation_error,
        }
    }
}

#[pymethods]
impl PyExtraction {
    fn __repr__(&self) -> String {
        format!("Extraction({}, max tool error {:.3e} m / {:.3e} rad)", self.table.__repr__(), self.max_position_error, self.max_rotation_error)
    }
}

fn options(parallel_tol: f64, intersect_tol: f64, max_offset: Option<f64>, nominal: Option<&PyTable>, origins: Option<ArrayIn<'_>>, n: usize) -> PyResult<ExtractOptions> {
    let origins = match origins {
        Some(o) => {
            let (v, s) = values(&o);
            check_shape("origins", &s, &[Some(n), Some(3)])?;
            crate::convert::check_finite("origins", &v)?;
            Some((0..n).map(|i| Vector3::new(v[3 * i], v[3 * i + 1], v[3 * i + 2])).collect())
        }
        None => None,
    };
    Ok(ExtractOptions { parallel_tol, intersect_tol, max_offset, nominal: nominal.map(|t| t.inner.clone()), origins })
}

/// Axes of `model` at configuration `q` (rad / m).
#[pyfunction]
pub fn axes(model: &PyModel, q: ArrayIn<'_>) -> PyResult<PyJointAxes> {
    let q = vector("q", &q, model.inner.nq())?;
    Ok(PyJointAxes { inner: denavit_core::axes::axes(&model.inner, &q).py()? })
}

/// Extract the parameter table of `convention` from joint axes (docs/conventions.md).
#[pyfunction]
#[pyo3(signature = (axes, convention, *, parallel_tol=1e-3, intersect_tol=1e-9, max_offset=None, nominal=None, origins=None))]
pub fn extract(axes: &PyJointAxes, convention: &str, parallel_tol: f64, intersect_tol: f64, max_offset: Option<f64>, nominal: Option<&PyTable>, origins: Option<ArrayIn<'_>>) -> PyResult<PyExtraction> {
    let conv = Convention::parse(convention).py()?;
    let opt = options(parallel_tol, intersect_tol, max_offset, nominal, origins, axes.inner.nq())?;
    Ok(core_extract::extract(&axes.inner, conv, &opt).py()?.into())
}

/// The convention named `name` (any accepted spelling: "dh", "SDH", "mdh", "craig", "modified-dh", "edh",
/// "poe", ...): a dict with its canonical `name`, its `columns` in order and which of them are angles
/// (`angle_columns`). The one parser of convention names (docs/conventions.md).
#[pyfunction]
pub fn convention_info(py: Python<'_>, name: &str) -> PyResult<PyObject> {
    let c = Convention::parse(name).py()?;
    let d = pyo3::types::PyDict::new(py);
    d.set_item("name", c.name())?;
    d.set_item("columns", c.columns().to_vec())?;
    d.set_item("angle_columns", c.angle_columns().to_vec())?;
    Ok(d.into_any().unbind())
}

/// Canonical names of every convention, in order ("dh", "mdh", "edh", "poe").
#[pyfunction]
pub fn conventions() -> Vec<&'static str> {
    Convention::ALL.iter().map(|c| c.name()).collect()
}
