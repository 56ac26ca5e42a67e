//! Forward kinematics and Jacobians (single and batch; batches release the GIL, take `out=` and `threads=`).

use crate::convert::{batch_out, configuration, pose_out, poses_out, rows, vector, Threads};
use crate::error::{invalid, IntoPy};
use crate::model::PyModel;
use denavit_core::kinematics::{self, JacobianFrame};
use denavit_core::Data;
use numpy::ndarray::Dim;
use numpy::{PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;

/// The frame of a Jacobian: the tool (None) or a joint frame, by 1-based index (pinocchio's joint ids,
/// "joint i" of docs/conventions.md) or by joint name; 0-based for the core.
fn joint_of(model: &denavit_core::Model, joint: Option<&Bound<'_, PyAny>>) -> PyResult<Option<usize>> {
    let Some(j) = joint else { return Ok(None) };
    let n = model.nq();
    let names: Vec<&str> = model.joints().iter().map(|j| j.name.as_str()).collect();
    let expected = || format!("None (the tool), a joint number 1..{n} or a joint name ({})", names.join(", "));
    if let Ok(name) = j.extract::<String>() {
        return match names.iter().position(|x| *x == name) {
            Some(i) => Ok(Some(i)),
            None => Err(invalid("joint", expected(), format!("'{name}'"))),
        };
    }
    match j.extract::<i64>() {
        Ok(i) if i >= 1 && (i as usize) <= n => Ok(Some(i as usize - 1)),
        Ok(i) => Err(invalid("joint", expected(), i.to_string())),
        Err(_) => Err(invalid("joint", expected(), j.get_type().name().map(|t| t.to_string()).unwrap_or_default())),
    }
}

/// Tool pose T_world_tool (4, 4) at q (n,) in rad / m.
#[pyfunction]
pub fn fk<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut buf = [0.0; 16];
    pose_out(py, &kinematics::fk(&model.inner, &configuration("q", q, &mut buf)?).py()?)
}

/// Joint frames T_world_joint (n, 4, 4) at q.
#[pyfunction]
pub fn joint_frames<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let mut data = Data::new(&model.inner);
    kinematics::forward_kinematics(&model.inner, &mut data, &vector("q", q)?).py()?;
    poses_out(py, data.t_world_joint.iter())
}

/// Geometric Jacobian (6, n), rows [v; w], of the tool or of joint frame `joint` (1-based or a name), in
/// frame 'local_world_aligned' (default), 'local', 'world' or 'base' (pinocchio's meanings; docs/speed.md).
#[pyfunction]
#[pyo3(signature = (model, q, frame="local_world_aligned", joint=None))]
pub fn jacobian<'py>(
    py: Python<'py>,
    model: &PyModel,
    q: &Bound<'py, PyAny>,
    frame: &str,
    joint: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let f = JacobianFrame::parse(frame).py()?;
    let j = joint_of(&model.inner, joint)?;
    let mut buf = [0.0; 16];
    let q = configuration("q", q, &mut buf)?;
    model.inner.check_q(&q).py()?;
    let out = PyArray2::<f64>::zeros(py, [6, model.inner.nq()], false);
    {
        let mut rw = out.readwrite();
        kinematics::jacobian_row_major_unchecked(&model.inner, &q, f, j, rw.as_slice_mut()?);
    }
    Ok(out)
}

/// Tool poses (N, 4, 4) for configurations qs (N, n), into `out` when given; without the GIL on `threads`.
#[pyfunction]
#[pyo3(signature = (model, qs, *, out=None, threads=None))]
pub fn fk_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &denavit_core::Model = &model.inner;
    let (q, count) = rows("qs", qs, m.nq())?;
    let q = q.slice();
    batch_out(py, Dim([count, 4, 4]), out, threads, &[("qs", q)], 1.0, |o| kinematics::fk_batch(m, q, o))
}

/// Jacobians (N, 6, n) for configurations qs (N, n) (frame, joint as in `jacobian`), into `out` when given.
#[pyfunction]
#[pyo3(signature = (model, qs, frame="local_world_aligned", joint=None, *, out=None, threads=None))]
#[allow(clippy::too_many_arguments)]
pub fn jacobian_batch<'py>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    frame: &str,
    joint: Option<&Bound<'py, PyAny>>,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let f = JacobianFrame::parse(frame).py()?;
    let m: &denavit_core::Model = &model.inner;
    let j = joint_of(m, joint)?;
    let (q, count) = rows("qs", qs, m.nq())?;
    let q = q.slice();
    batch_out(py, Dim([count, 6, m.nq()]), out, threads, &[("qs", q)], 1.0, |o| kinematics::jacobian_batch(m, q, f, j, o))
}

/// Register the functions of this file.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fk, m)?)?;
    m.add_function(wrap_pyfunction!(joint_frames, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(fk_batch, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian_batch, m)?)?;
    Ok(())
}
