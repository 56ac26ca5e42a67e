//! Forward kinematics and Jacobians (single and batch; batches release the GIL and use every core).

use crate::convert::{check_shape, matrix_out, values, vector_fast, write_pose, ArrayIn};
use crate::error::{value_error, IntoPy};
use crate::model::PyModel;
use denavit_core::kinematics::{self, JacobianFrame};
use denavit_core::Data;
use numpy::{PyArray2, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;

fn frame_of(frame: &str) -> PyResult<JacobianFrame> {
    match frame {
        "world" => Ok(JacobianFrame::World),
        "base" => Ok(JacobianFrame::Base),
        "tool" => Ok(JacobianFrame::Tool),
        _ => Err(value_error(format!("frame: expected 'world', 'base' or 'tool', got '{frame}'"))),
    }
}

/// Tool pose T_world_tool (4, 4) at q (n,) in rad / m.
#[pyfunction]
pub fn fk<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let q = vector_fast("q", q, model.inner.nq())?;
    let mut v = [0.0; 16];
    write_pose(&kinematics::tool_pose_unchecked(&model.inner, &q), &mut v);
    matrix_out(py, &v, 4, 4)
}

/// Joint frames T_world_joint (n, 4, 4) at q.
#[pyfunction]
pub fn joint_frames<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let q = vector_fast("q", q, model.inner.nq())?;
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
pub fn jacobian<'py>(py: Python<'py>, model: &PyModel, q: &Bound<'py, PyAny>, frame: &str) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let f = frame_of(frame)?;
    let q = vector_fast("q", q, model.inner.nq())?;
    let n = model.inner.nq();
    let out = PyArray2::<f64>::zeros(py, [6, n], false);
    {
        let mut rw = out.readwrite();
        kinematics::jacobian_row_major_unchecked(&model.inner, &q, f, rw.as_slice_mut()?);
    }
    Ok(out)
}

fn batch_q(model: &PyModel, qs: &ArrayIn<'_>) -> PyResult<(Vec<f64>, usize)> {
    let (v, shape) = values(qs);
    let count = shape.first().copied().unwrap_or(0);
    check_shape("qs", &shape, &[None, Some(model.inner.nq())])?;
    Ok((v, count))
}

/// Run `kernel(model, qs, out)` without the GIL, reading a C-contiguous float64 `qs` (N, n) in place and
/// writing straight into a new numpy array of shape (N, per...); other inputs are converted first.
fn batch<'py, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    model: &PyModel,
    qs: &Bound<'py, PyAny>,
    shape_of: impl Fn(usize) -> D,
    kernel: impl Fn(&denavit_core::Model, &[f64], &mut [f64]) -> denavit_core::Result<()> + Send + Sync,
) -> PyResult<Bound<'py, numpy::PyArray<f64, D>>> {
    let n = model.inner.nq();
    let m: &denavit_core::Model = &model.inner;
    if let Ok(a) = qs.downcast::<PyArray2<f64>>() {
        if a.is_c_contiguous() {
            let ro = a.readonly();
            check_shape("qs", ro.shape(), &[None, Some(n)])?;
            let out = numpy::PyArray::<f64, D>::zeros(py, shape_of(ro.shape()[0]), false);
            {
                let q = ro.as_slice()?;
                let mut rw = out.readwrite();
                let o = rw.as_slice_mut()?;
                py.allow_threads(|| kernel(m, q, o)).py()?;
            }
            return Ok(out);
        }
    }
    let qs: ArrayIn<'_> = qs.extract()?;
    let (q, count) = batch_q(model, &qs)?;
    let out = numpy::PyArray::<f64, D>::zeros(py, shape_of(count), false);
    {
        let mut rw = out.readwrite();
        let o = rw.as_slice_mut()?;
        py.allow_threads(|| kernel(m, &q, o)).py()?;
    }
    Ok(out)
}

/// Tool poses (N, 4, 4) for configurations qs (N, n); runs without the GIL on every core.
#[pyfunction]
pub fn fk_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    batch(py, model, qs, |count| numpy::ndarray::Dim([count, 4, 4]), kinematics::tool_pose_batch)
}

/// Jacobians (N, 6, n) for configurations qs (N, n).
#[pyfunction]
#[pyo3(signature = (model, qs, frame="world"))]
pub fn jacobian_batch<'py>(py: Python<'py>, model: &PyModel, qs: &Bound<'py, PyAny>, frame: &str) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let f = frame_of(frame)?;
    let n = model.inner.nq();
    batch(py, model, qs, |count| numpy::ndarray::Dim([count, 6, n]), move |m, q, o| kinematics::jacobian_batch(m, q, f, o))
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
