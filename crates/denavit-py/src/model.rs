//! `Model`, `Table`, `JointAxes` and `Extraction` as Python classes.

use crate::convert::{check_len, opt_pose, opt_vector, out, pose, pose_out, poses, poses_out, shaped, vector, vectors3};
use crate::error::{at_joint, invalid, of_joint, IntoPy};
use denavit_core::dynamics::{self, Inertia};
use denavit_core::extract::{self as core_extract, ExtractOptions};
use denavit_core::{Convention, Joint, JointKind};
use nalgebra::{DMatrix, Matrix3, Vector3};
use numpy::{PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyTuple};
use std::sync::Arc;

fn kinds_of(kinds: Option<Vec<String>>, n: usize) -> PyResult<Vec<JointKind>> {
    match kinds {
        Some(k) => {
            check_len("joint kinds (one per joint)", n, k.len())?;
            k.iter().map(|k| JointKind::parse(k).py()).collect()
        }
        None => Ok(vec![JointKind::Revolute; n]),
    }
}

/// `x` with `digits` decimals, without a "-0.0" for a value that rounds to zero.
fn fixed(x: f64, digits: usize) -> String {
    let s = format!("{x:.digits$}");
    if s.trim_start_matches('-').chars().all(|c| c == '0' || c == '.') {
        s.trim_start_matches('-').to_string()
    } else {
        s
    }
}

/// `functools.partial(f, **kwargs)`: how `__reduce__` passes keyword arguments to a constructor.
fn partial<'py>(f: Bound<'py, PyAny>, kwargs: &Bound<'py, PyDict>) -> PyResult<Bound<'py, PyAny>> {
    f.py().import("functools")?.getattr("partial")?.call((f,), Some(kwargs))
}

/// The link inertias as arrays: masses (n,), coms (n, 3), inertias (n, 3, 3) about each centre of mass,
/// every link in its joint frame.
#[allow(clippy::type_complexity)]
fn inertia_arrays<'py>(py: Python<'py>, model: &PyModel) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyArray2<f64>>, Bound<'py, PyArray3<f64>>)> {
    let list = model.inner.inertias();
    let n = list.len();
    let masses: Vec<f64> = list.iter().map(|i| i.mass()).collect();
    let coms: Vec<f64> = list.iter().flat_map(|i| i.com().iter().copied().collect::<Vec<_>>()).collect();
    // row-major 3x3: nalgebra's column-major storage of the transpose
    let tensors: Vec<f64> = list.iter().flat_map(|i| i.inertia_com().transpose().as_slice().to_vec()).collect();
    Ok((PyArray1::from_vec(py, masses), out(py, &coms, [n, 3])?, out(py, &tensors, [n, 3, 3])?))
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
    /// offsets : (n,) rad or m (default zeros); lower, upper : (n,) rad or m (default the core's, -pi..pi and
    /// -1..1 m); names : n strings (default j1..jn); T_world_base : (4, 4); T_last_flange : (4, 4) the flange in
    /// the last joint frame; T_flange_tool : (4, 4) the tool in the flange; dh_link_frames : (n, 4, 4) the
    /// standard-DH frame i in joint frame i (what `Table("dh", ...).to_model()` records), for frame="dh" inertias.
    #[staticmethod]
    #[pyo3(signature = (placements, kinds, *, offsets=None, lower=None, upper=None, names=None, T_world_base=None, T_last_flange=None, T_flange_tool=None, name="robot", dh_link_frames=None))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn from_placements(
        placements: &Bound<'_, PyAny>,
        kinds: Vec<String>,
        offsets: Option<&Bound<'_, PyAny>>,
        lower: Option<&Bound<'_, PyAny>>,
        upper: Option<&Bound<'_, PyAny>>,
        names: Option<Vec<String>>,
        T_world_base: Option<&Bound<'_, PyAny>>,
        T_last_flange: Option<&Bound<'_, PyAny>>,
        T_flange_tool: Option<&Bound<'_, PyAny>>,
        name: &str,
        dh_link_frames: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let placements = poses("placements", placements)?;
        let n = placements.len();
        let kinds = kinds_of(Some(kinds), n)?;
        let names = names.unwrap_or_else(|| (1..=n).map(|i| format!("j{i}")).collect());
        check_len("joint names (one per joint)", n, names.len())?;
        let mut joints: Vec<Joint> = (0..n).map(|i| Joint::new(names[i].clone(), kinds[i], placements[i])).collect();
        for (what, values) in [("offsets", offsets), ("lower", lower), ("upper", upper)] {
            if let Some(v) = opt_vector(what, values)? {
                check_len(&format!("{what} (one per joint)"), n, v.len())?;
                for (j, x) in joints.iter_mut().zip(v) {
                    *match what {
                        "offsets" => &mut j.offset,
                        "lower" => &mut j.lower,
                        _ => &mut j.upper,
                    } = x;
                }
            }
        }
        let base = opt_pose("T_world_base", T_world_base)?;
        let flange = opt_pose("T_last_flange", T_last_flange)?;
        let tool = opt_pose("T_flange_tool", T_flange_tool)?;
        let mut m = denavit_core::Model::new(name, base, joints, flange, tool).py()?;
        if let Some(f) = dh_link_frames {
            m = m.with_dh_link_frames(poses("dh_link_frames", f)?).py()?;
        }
        Ok(Self { inner: Arc::new(m) })
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
        poses_out(py, self.inner.joints().iter().map(|j| &j.placement))
    }
    /// (n,) zero offsets (rad / m).
    #[getter]
    fn offsets<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.joints().iter().map(|j| j.offset).collect())
    }
    /// (n,) lower limits (rad / m).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.lower())
    }
    /// (n,) upper limits (rad / m).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_vec(py, self.inner.upper())
    }
    /// (n, 4, 4) the standard-DH frame i in joint frame i for a model built from a DH table, else None.
    #[getter]
    fn dh_link_frames<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray3<f64>>>> {
        self.inner.dh_link_frames().map(|f| poses_out(py, f.iter())).transpose()
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, self.inner.t_world_base())
    }
    /// The flange (mechanical flange, ROS tool0) in the last joint frame.
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_flange<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, self.inner.t_last_flange())
    }
    /// The tool in the flange (identity unless a tool is attached).
    #[getter]
    #[allow(non_snake_case)]
    fn T_flange_tool<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, self.inner.t_flange_tool())
    }
    /// The tool in the last joint frame: T_last_flange @ T_flange_tool.
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_tool<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, self.inner.t_last_tool())
    }
    /// A copy with another base placement.
    #[allow(non_snake_case)]
    fn with_base(&self, T_world_base: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(self.inner.with_base(pose("T_world_base", T_world_base)?).py()?) })
    }
    /// A copy with another tool T_flange_tool (4, 4), in the flange frame (the flange is kept).
    #[allow(non_snake_case)]
    fn with_tool(&self, T_flange_tool: &Bound<'_, PyAny>) -> PyResult<Self> {
        Ok(Self { inner: Arc::new(self.inner.with_tool(pose("T_flange_tool", T_flange_tool)?).py()?) })
    }
    /// A copy of the model with link inertial parameters (docs/conventions.md, "Dynamics").
    ///
    /// Parameters
    /// ----------
    /// masses : array-like, shape (n,)
    ///     Link masses in kg (>= 0).
    /// coms : array-like, shape (n, 3)
    ///     Centres of mass in m.
    /// inertias : array-like, shape (n, 3, 3)
    ///     Rotational inertias in kg m^2: symmetric, positive semi-definite, principal moments obeying the
    ///     triangle inequality; about each centre of mass (``about="com"``) or about the frame origin
    ///     (``about="origin"``, the parallel-axis theorem is applied).
    /// frame : {"link", "dh", "world"}
    ///     ``"link"``: link i in its joint frame i (the model's frame moving with link i: z on joint i's axis,
    ///     origin and x as the model's convention placed it; ``dv.joint_frames`` gives it in world);
    ///     ``"dh"``: link i in standard-DH frame i (joint frame i @ Tz(d_i) Tx(a_i) Rx(alpha_i), the frame
    ///     of published DH inertia tables such as Armstrong et al. 1986 / Corke's Puma 560), for a model built
    ///     from a DH table (``Model.dh_link_frames``); ``"world"``: every link in world with the robot at
    ///     ``q_ref`` (default zeros), e.g. as exported from CAD at home.
    ///
    /// An error about one link says which (``DenavitError.joint``, 1-based).
    #[pyo3(signature = (masses, coms, inertias, frame="link", about="com", q_ref=None))]
    fn with_inertias(
        &self,
        masses: &Bound<'_, PyAny>,
        coms: &Bound<'_, PyAny>,
        inertias: &Bound<'_, PyAny>,
        frame: &str,
        about: &str,
        q_ref: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let m = &self.inner;
        let (world, dh) = match frame {
            "link" => (false, None),
            "dh" => match m.dh_link_frames() {
                Some(f) => (false, Some(f)),
                None => {
                    return Err(invalid(
                        "frame",
                        "'dh' only for a model built from a DH table (Table('dh', ...).to_model(), a dh robot file)",
                        format!("'dh' for model '{}', which has no DH link frames", m.name()),
                    ))
                }
            },
            "world" => (true, None),
            _ => return Err(invalid("frame", "'link', 'dh' or 'world'", format!("'{frame}'"))),
        };
        if !world && q_ref.is_some() {
            return Err(invalid("q_ref", "None with frame='link' (q_ref is the configuration of frame='world' inertias)", "an array"));
        }
        let mv = vector("masses (kg)", masses)?;
        let (cv, _) = shaped("coms (centres of mass, m)", coms, &[None, Some(3)])?;
        let (iv, _) = shaped("inertias (kg m^2)", inertias, &[None, Some(3), Some(3)])?;
        // each argument against the model (one per joint), so that the one of the wrong length is named
        check_len("masses (kg, one per joint)", m.nq(), mv.len())?;
        check_len("coms (centres of mass, one per joint)", m.nq(), cv.len() / 3)?;
        check_len("inertias (one per joint)", m.nq(), iv.len() / 9)?;
        let link = |i: usize| -> Option<(Vector3<f64>, Matrix3<f64>)> {
            Some((Vector3::from_row_slice(cv.get(3 * i..3 * i + 3)?), Matrix3::from_row_slice(iv.get(9 * i..9 * i + 9)?)))
        };
        let mut list = match about {
            // the core's checks and messages ("... of link i ..."); the failing link found again for `joint`
            "com" => dynamics::inertias_from_slices(&mv, &cv, &iv).map_err(|e| {
                let bad = (0..mv.len()).find(|&i| link(i).is_some_and(|(c, t)| Inertia::new(mv[i], c, t).is_err()));
                of_joint(e, bad.map(|i| i + 1))
            })?,
            "origin" => {
                check_len("coms (one per link)", mv.len(), cv.len() / 3)?;
                check_len("inertias (one per link)", mv.len(), iv.len() / 9)?;
                (0..mv.len())
                    .map(|i| {
                        let (c, t) = link(i).unwrap_or_default();
                        Inertia::from_origin(mv[i], c, t).map_err(|e| at_joint(e, "link", i + 1))
                    })
                    .collect::<PyResult<Vec<_>>>()?
            }
            _ => return Err(invalid("about", "'com' or 'origin'", format!("'{about}'"))),
        };
        if world {
            let q = opt_vector("q_ref", q_ref)?.unwrap_or_else(|| vec![0.0; m.nq()]);
            list = dynamics::inertias_in_world(m, &q, &list).py()?;
        }
        if let Some(frames) = dh {
            check_len("link inertias (one per joint)", m.nq(), list.len())?;
            // DH frame i in joint frame i: the inertia re-expressed in the joint frame
            list = list.iter().zip(frames).map(|(i, t_joint_dh)| i.transformed(t_joint_dh)).collect();
        }
        Ok(Self { inner: Arc::new(m.with_inertias(list).py()?) })
    }
    /// Link inertial parameters: dict with "masses" (n,) kg, "coms" (n, 3) m and "inertias" (n, 3, 3) kg m^2
    /// about each centre of mass, every link in its joint frame; ``model.with_inertias(**model.inertias)``
    /// round-trips.
    #[getter]
    fn inertias<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (masses, coms, tensors) = inertia_arrays(py, self)?;
        let d = PyDict::new(py);
        d.set_item("masses", masses)?;
        d.set_item("coms", coms)?;
        d.set_item("inertias", tensors)?;
        Ok(d)
    }
    /// Pickle / copy: `Model.from_placements(...)`, then `with_inertias` when a link has mass or inertia.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let m = &self.inner;
        if m.inertias().iter().any(|i| *i != Inertia::zero()) {
            let mut bare = denavit_core::Model::new(m.name(), *m.t_world_base(), m.joints().to_vec(), *m.t_last_flange(), *m.t_flange_tool()).py()?;
            if let Some(f) = m.dh_link_frames() {
                bare = bare.with_dh_link_frames(f.to_vec()).py()?;
            }
            let bare = Self { inner: Arc::new(bare) };
            let (masses, coms, inertias) = inertia_arrays(py, self)?;
            let args = (bare, masses, coms, inertias);
            return (py.get_type::<Self>().getattr("with_inertias")?, args).into_pyobject(py);
        }
        let kw = PyDict::new(py);
        kw.set_item("offsets", self.offsets(py))?;
        kw.set_item("lower", self.lower(py))?;
        kw.set_item("upper", self.upper(py))?;
        kw.set_item("names", self.names())?;
        kw.set_item("T_world_base", self.T_world_base(py)?)?;
        kw.set_item("T_last_flange", self.T_last_flange(py)?)?;
        kw.set_item("T_flange_tool", self.T_flange_tool(py)?)?;
        kw.set_item("name", m.name())?;
        kw.set_item("dh_link_frames", self.dh_link_frames(py)?)?;
        let f = partial(py.get_type::<Self>().getattr("from_placements")?, &kw)?;
        (f, (self.placements(py)?, self.kinds())).into_pyobject(py)
    }
    /// `Model('kr5', 6 joints RRRRRR, tool at [x, y, z] mm at q = 0, 12.3 kg)`.
    fn __repr__(&self) -> String {
        let m = &self.inner;
        let kinds: String = m.joints().iter().map(|j| if j.kind == JointKind::Revolute { 'R' } else { 'P' }).collect();
        let tool = denavit_core::kinematics::fk_unchecked(m, &vec![0.0; m.nq()]).translation.vector * 1e3;
        let mass: f64 = m.inertias().iter().map(|i| i.mass()).sum();
        let mass = if mass > 0.0 { format!(", {mass:.4} kg") } else { String::new() };
        format!(
            "Model('{}', {} joints {kinds}, tool at [{}, {}, {}] mm at q = 0{mass})",
            m.name(),
            m.nq(),
            fixed(tool.x, 1),
            fixed(tool.y, 1),
            fixed(tool.z, 1)
        )
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
    fn new(
        convention: &str,
        params: &Bound<'_, PyAny>,
        kinds: Option<Vec<String>>,
        T_world_base: Option<&Bound<'_, PyAny>>,
        T_last_tool: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let conv = Convention::parse(convention).py()?;
        let k = conv.columns().len();
        let (v, shape) = shaped(&format!("params of a {} table (columns {})", conv.name(), conv.columns().join(", ")), params, &[None, Some(k)])?;
        let n = shape[0];
        let kinds = kinds_of(kinds, n)?;
        let base = opt_pose("T_world_base", T_world_base)?;
        let tool = opt_pose("T_last_tool", T_last_tool)?;
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
        out(py, &v, [p.nrows(), p.ncols()])
    }
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.kinds.iter().map(|k| k.name()).collect()
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, &self.inner.t_world_base)
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_last_tool<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, &self.inner.t_last_tool)
    }
    /// The model of this table; names / lower / upper default to j1..jn and the core's limits (+-pi, +-1 m).
    #[pyo3(signature = (name="robot", names=None, lower=None, upper=None))]
    fn to_model(&self, name: &str, names: Option<Vec<String>>, lower: Option<&Bound<'_, PyAny>>, upper: Option<&Bound<'_, PyAny>>) -> PyResult<PyModel> {
        let model = self.inner.to_model(name).py()?;
        let (lower, upper) = (opt_vector("lower", lower)?, opt_vector("upper", upper)?);
        if names.is_none() && lower.is_none() && upper.is_none() {
            return Ok(PyModel { inner: Arc::new(model) });
        }
        let names = names.unwrap_or_else(|| model.joints().iter().map(|j| j.name.clone()).collect());
        let (lower, upper) = (lower.unwrap_or_else(|| model.lower()), upper.unwrap_or_else(|| model.upper()));
        Ok(PyModel { inner: Arc::new(self.inner.to_model_with(name, &names, &lower, &upper).py()?) })
    }
    /// (n, 4, 4): the pose of the convention's frame i in the model's joint frame i (i = 1..n; the identity
    /// except for dh, where DH frame i = joint frame i @ Tz(d_i) Tx(a_i) Rx(alpha_i)).
    fn link_frames<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        poses_out(py, self.inner.link_frames().iter())
    }
    /// (n+1, 4, 4): the convention's frames 0..n in world at q.
    fn frames<'py>(&self, py: Python<'py>, q: &Bound<'_, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
        let f = self.inner.frames(&vector("q", q)?).py()?;
        poses_out(py, f.iter())
    }
    /// Pickle / copy: `Table(convention, params, kinds, T_world_base, T_last_tool)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let args = (self.convention(), self.params(py)?, self.kinds(), self.T_world_base(py)?, self.T_last_tool(py)?);
        (py.get_type::<Self>(), args).into_pyobject(py)
    }
    /// The rows with units, as the CLI prints tables: lengths in mm, angles in deg (POE: w unitless).
    fn __repr__(&self) -> String {
        let t = &self.inner;
        let poe = t.convention == Convention::Poe;
        let cols = t.convention.columns();
        let angle = t.convention.angle_columns();
        let units: Vec<(String, f64)> = cols
            .iter()
            .zip(angle)
            .map(|(c, &a)| {
                if a {
                    (format!("{c} [deg]"), 180.0 / std::f64::consts::PI)
                } else if poe && c.starts_with('w') {
                    (c.to_string(), 1.0)
                } else {
                    (format!("{c} [mm]"), 1e3)
                }
            })
            .collect();
        let mut out = format!("Table('{}', {} joints)\n  joint kind", t.convention.name(), t.nq());
        for (h, _) in &units {
            out += &format!(" {h:>12}");
        }
        for i in 0..t.nq() {
            out += &format!("\n  {:>5} {:>4}", i + 1, if t.kinds[i] == JointKind::Revolute { "R" } else { "P" });
            for (k, (_, f)) in units.iter().enumerate() {
                out += &format!(" {:>12}", fixed(t.params[(i, k)] * f, 3));
            }
        }
        out
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
    /// points, directions : (n, 3) in world (m); kinds : n strings; q_ref : (n,) (default zeros); T_world_base,
    /// T_world_tool : (4, 4); lower, upper : (n,) (default the core's joint limits, -pi..pi and -1..1 m).
    #[new]
    #[pyo3(signature = (points, directions, *, kinds=None, q_ref=None, T_world_base=None, T_world_tool=None, lower=None, upper=None))]
    #[allow(non_snake_case, clippy::too_many_arguments)]
    fn new(
        points: &Bound<'_, PyAny>,
        directions: &Bound<'_, PyAny>,
        kinds: Option<Vec<String>>,
        q_ref: Option<&Bound<'_, PyAny>>,
        T_world_base: Option<&Bound<'_, PyAny>>,
        T_world_tool: Option<&Bound<'_, PyAny>>,
        lower: Option<&Bound<'_, PyAny>>,
        upper: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        let points = vectors3("points", points)?;
        let n = points.len();
        let kinds = kinds_of(kinds, n)?;
        let defaults: Vec<Joint> = kinds.iter().map(|&k| Joint::new("", k, denavit_core::spatial::Pose::identity())).collect();
        let inner = denavit_core::JointAxes::new(
            opt_pose("T_world_base", T_world_base)?,
            points,
            vectors3("directions", directions)?,
            kinds,
            opt_vector("q_ref", q_ref)?.unwrap_or_else(|| vec![0.0; n]),
            opt_pose("T_world_tool", T_world_tool)?,
            opt_vector("lower", lower)?.unwrap_or_else(|| defaults.iter().map(|j| j.lower).collect()),
            opt_vector("upper", upper)?.unwrap_or_else(|| defaults.iter().map(|j| j.upper).collect()),
        );
        Ok(Self { inner: inner.py()? })
    }
    #[getter]
    fn nq(&self) -> usize {
        self.inner.nq()
    }
    /// (n, 3) points on the axes (m, world).
    #[getter]
    fn points<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.inner.points.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        out(py, &v, [self.inner.nq(), 3])
    }
    /// (n, 3) unit directions (world).
    #[getter]
    fn directions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let v: Vec<f64> = self.inner.directions.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
        out(py, &v, [self.inner.nq(), 3])
    }
    #[getter]
    fn kinds(&self) -> Vec<&'static str> {
        self.inner.kinds.iter().map(|k| k.name()).collect()
    }
    /// (n,) the reference configuration (rad / m).
    #[getter]
    fn q_ref<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.q_ref)
    }
    /// (n,) lower limits (rad / m).
    #[getter]
    fn lower<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.lower)
    }
    /// (n,) upper limits (rad / m).
    #[getter]
    fn upper<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        PyArray1::from_slice(py, &self.inner.upper)
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_base<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, &self.inner.t_world_base)
    }
    #[getter]
    #[allow(non_snake_case)]
    fn T_world_tool<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        pose_out(py, &self.inner.t_world_tool)
    }
    /// Pickle / copy: `JointAxes(points, directions, kinds=..., q_ref=..., ...)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let kw = PyDict::new(py);
        kw.set_item("kinds", self.kinds())?;
        kw.set_item("q_ref", self.q_ref(py))?;
        kw.set_item("T_world_base", self.T_world_base(py)?)?;
        kw.set_item("T_world_tool", self.T_world_tool(py)?)?;
        kw.set_item("lower", self.lower(py))?;
        kw.set_item("upper", self.upper(py))?;
        (partial(py.get_type::<Self>().into_any(), &kw)?, (self.points(py)?, self.directions(py)?)).into_pyobject(py)
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
    pub relation: String,
    /// Angle between the axes (rad).
    pub angle: f64,
    /// Common-normal length or distance between parallel lines (m).
    pub distance: f64,
    /// Hayati-style misalignment the table cannot represent (rad).
    pub hayati_beta: f64,
}

#[pymethods]
impl PyPair {
    #[new]
    fn new(joint: usize, relation: String, angle: f64, distance: f64, hayati_beta: f64) -> Self {
        Self { joint, relation, angle, distance, hayati_beta }
    }
    /// Pickle / copy: `PairDiagnostic(joint, relation, angle, distance, hayati_beta)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        (py.get_type::<Self>(), (self.joint, &self.relation, self.angle, self.distance, self.hayati_beta)).into_pyobject(py)
    }
    fn __repr__(&self) -> String {
        format!(
            "PairDiagnostic(joint={}, relation='{}', angle={:.6e}, distance={:.6e}, hayati_beta={:.3e})",
            self.joint, self.relation, self.angle, self.distance, self.hayati_beta
        )
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
                .map(|p| PyPair { joint: p.joint, relation: p.relation.name().to_string(), angle: p.angle, distance: p.distance, hayati_beta: p.hayati_beta })
                .collect(),
            max_position_error: e.max_position_error,
            max_rotation_error: e.max_rotation_error,
        }
    }
}

#[pymethods]
impl PyExtraction {
    #[new]
    fn new(table: PyTable, pairs: Vec<PyPair>, max_position_error: f64, max_rotation_error: f64) -> Self {
        Self { table, pairs, max_position_error, max_rotation_error }
    }
    /// Pickle / copy: `Extraction(table, pairs, max_position_error, max_rotation_error)`.
    fn __reduce__<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        (py.get_type::<Self>(), (self.table.clone(), self.pairs.clone(), self.max_position_error, self.max_rotation_error)).into_pyobject(py)
    }
    fn __repr__(&self) -> String {
        format!("Extraction({}, max tool error {:.3e} m / {:.3e} rad)", self.table.__repr__(), self.max_position_error, self.max_rotation_error)
    }
}

/// Axes of `model` at configuration `q` (rad / m).
#[pyfunction]
pub fn axes(model: &PyModel, q: &Bound<'_, PyAny>) -> PyResult<PyJointAxes> {
    Ok(PyJointAxes { inner: denavit_core::axes::axes(&model.inner, &vector("q", q)?).py()? })
}

/// Extract the parameter table of `convention` from joint axes (docs/conventions.md). `fidelity`: measure
/// the table's tool error over 256 configurations (`max_position_error`, `max_rotation_error`; NaN when false).
#[pyfunction]
#[pyo3(signature = (axes, convention, *, parallel_tol=1e-3, intersect_tol=1e-9, max_offset=None, nominal=None, origins=None, fidelity=true))]
#[allow(clippy::too_many_arguments)]
pub fn extract(
    axes: &PyJointAxes,
    convention: &str,
    parallel_tol: f64,
    intersect_tol: f64,
    max_offset: Option<f64>,
    nominal: Option<&PyTable>,
    origins: Option<&Bound<'_, PyAny>>,
    fidelity: bool,
) -> PyResult<PyExtraction> {
    let conv = Convention::parse(convention).py()?;
    let origins = origins.map(|o| vectors3("origins", o)).transpose()?;
    let opt = ExtractOptions { parallel_tol, intersect_tol, max_offset, nominal: nominal.map(|t| t.inner.clone()), origins, fidelity };
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

/// The limits of a joint of `kind` ("revolute" | "prismatic") that states none: (lower, upper) in rad / m.
#[pyfunction]
pub fn default_limits(kind: &str) -> PyResult<(f64, f64)> {
    Ok(JointKind::parse(kind).py()?.default_limits())
}
