//! Forward kinematics and Jacobians (single and batch; batches release the GIL and use every core).

use crate::convert::{check_shape, pose_out, values, vector, write_pose, ArrayIn};
use crate::error::{value_error, IntoPy};
use crate::model::PyModel;
use denavit_core::kinematics::{self, JacobianFrame};
use denavit_core::Data;
use numpy::{PyArray2, PyArray3, PyArrayMethods};
use pyo3::prelude::*;

fn frame_of(frame: &str) -> PyResult<JacobianFrame> {
    match frame {
        "world" | "base" => Ok(JacobianFrame::World),
        "tool" => Ok(JacobianFrame::Tool),
        _ => Err(value_error(format!("frame: expected 'world' or 'tool', got '{frame}'"))),
    }
}

/// Tool pose T_world_tool (4, 4) at q (n,) in rad / m.
#[pyfunction]
pub fn fk<'py>(py: Python<'py>, model: &PyModel, q: ArrayIn<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let q = vector("q", &q, model.inner.nq())?;
    Ok(pose_out(py, &kinematics::tool_pose_unchecked(&model.inner, &q)))
}

/// Joint frames T_world_joint (n, 4, 4) at q.
#[pyfunction]
pub fn joint_frames<'py>(py: Python<'py>, model: &PyModel, q: ArrayIn<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let q = vector("q", &q, model.inner.nq())?;
    let mut data = Data::new(&model.inner);
    kinematics::forward_kinematics(&model.inner, &mut data, &q).py()?;
    let n = model.inner.nq();
    let mut v = vec![0.0; 16 * n];
    for (i, t) in data.t_world_joint.iter().enumerate() {
        write_pose(t, &mut v[16 * i..16 * i + 16]);
    }
    numpy::PyArray1::from_vec(py, v).reshape([n, 4, 4])
}

/// Geometric Jacobian (6, n), rows [v; w] of the tool origin, in the 'world' or 'tool' frame.
#[pyfunction]
#[pyo3(signature = (model, q, frame="world"))]
pub fn jacobian<'py>(py: Python<'py>, model: &PyModel, q: ArrayIn<'py>, frame: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let f = frame_of(frame)?;
    let q = vector("q", &q, model.inner.nq())?;
    let mut data = Data::new(&model.inner);
    kinematics::jacobian(&model.inner, &mut data, &q, f).py()?;
    let n = model.inner.nq();
    let v: Vec<f64> = (0..6).flat_map(|r| (0..n).map(move |c| (r, c))).map(|(r, c)| data.jacobian[(r, c)]).collect();
    numpy::PyArray1::from_vec(py, v).reshape([6, n])
}

fn batch_q(model: &PyModel, qs: &ArrayIn<'_>) -> PyResult<(Vec<f64>, usize)> {
    let (v, shape) = values(qs);
    let count = shape.first().copied().unwrap_or(0);
    check_shape("qs", &shape, &[None, Some(model.inner.nq())])?;
    Ok((v, count))
}

/// Tool poses (N, 4, 4) for configurations qs (N, n); runs without the GIL on every core.
#[pyfunction]
pub fn fk_batch<'py>(py: Python<'py>, model: &PyModel, qs: ArrayIn<'py>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let (q, count) = batch_q(model, &qs)?;
    let m = model.inner.clone();
    let out = py.allow_threads(move || {
        let mut out = vec![0.0; 16 * count];
        kinematics::tool_pose_batch(&m, &q, &mut out).map(|_| out)
    });
    numpy::PyArray1::from_vec(py, out.py()?).reshape([count, 4, 4])
}

/// Jacobians (N, 6, n) for configurations qs (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, frame="world"))]
pub fn jacobian_batch<'py>(py: Python<'py>, model: &PyModel, qs: ArrayIn<'py>, frame: &str) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let f = frame_of(frame)?;
    let (q, count) = batch_q(model, &qs)?;
    let m = model.inner.clone();
    let n = m.nq();
    let out = py.allow_threads(move || {
        let mut out = vec![0.0; 6 * n * count];
        kinematics::jacobian_batch(&m, &q, f, &mut out).map(|_| out)
    });
    numpy::PyArray1::from_vec(py, out.py()?).reshape([count, 6, n])
}

/// Register the functions of this file.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(fk, m)?)?;
    m.add_function(wrap_pyfunction!(joint_frames, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian, m)?)?;
    m.add_function(wrap_pyfunction!(fk_batch, m)?)?;
    m.add_function(wrap_pyfunction!(jacobian_batch, m)?)?;
    let _ = write_pose;
    Ok(())
}
