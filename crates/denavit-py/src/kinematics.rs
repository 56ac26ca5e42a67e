//! Forward kinematics and Jacobians (single and batch; batches release the GIL and use every core).

use crate::convert::{batch_out, pose_out, poses_out, rows, vector};
use crate::error::{invalid, IntoPy};
use crate::model::PyModel;
use denavit_core::kinematics::{self, JacobianFrame};
use denavit_core::Data;
use numpy::ndarray::Dim;
use numpy::{PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;

fn frame_of(frame: &str) -> PyResult<JacobianFrame> {
    match frame {
        "world" => Ok(JacobianFrame::World),
        "base" => Ok(JacobianFrame::Base),
        "tool" => Ok(JacobianFrame::Tool),
        _ => Err(invalid("frame", "'world', 'base' or 'tool'", format!("'{frame}'"))),
    }
}

/// Tool pose T_world_tool (4, 4) at q (n,) in rad / m.
#[pyfunction]
pub fn fk<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    pose_out(py, &kinematics::tool_pose(&model.inner, &vector("q", q)?).py()?)
}

/// Joint frames T_world_joint (n, 4, 4) at q.
#[pyfunction]
pub fn joint_frames<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let mut data = Data::new(&model.inner);
    kinematics::forward_kinematics(&model.inner, &mut data, &vector("q", q)?).py()?;
    poses_out(py, data.t_world_joint.iter())
}

/// Geometric Jacobian (6, n), rows [v; w] of the tool origin, in the 'world', 'base' or 'tool' frame.
#[pyfunction]
#[pyo3(signature = (model, q, frame="world"))]
pub fn jacobian<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, frame: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let f = frame_of(frame)?;
    let q = vector("q", q)?;
    model.inner.check_q(&q).py()?;
    let out = PyArray2::<f64>::zeros(py, [6, model.inner.nq()], false);
    {
        let mut rw = out.readwrite();
        kinematics::jacobian_row_major_unchecked(&model.inner, &q, f, rw.as_slice_mut()?);
    }
    Ok(out)
}

/// Tool poses (N, 4, 4) for configurations qs (N, n); runs without the GIL on every core.
#[pyfunction]
pub fn fk_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let m: &denavit_core::Model = &model.inner;
    let (q, count) = rows("qs", qs, m.nq())?;
    let q = q.slice();
    batch_out(py, Dim([count, 4, 4]), |o| kinematics::tool_pose_batch(m, q, o))
}

/// Jacobians (N, 6, n) for configurations qs (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, frame="world"))]
pub fn jacobian_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>, frame: &str) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let f = frame_of(frame)?;
    let m: &denavit_core::Model = &model.inner;
    let (q, count) = rows("qs", qs, m.nq())?;
    let q = q.slice();
    batch_out(py, Dim([count, 6, m.nq()]), |o| kinematics::jacobian_batch(m, q, f, o))
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
