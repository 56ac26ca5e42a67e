//! numpy <-> nalgebra conversions with shape checks that name the argument.

use crate::error::{value_error, IntoPy};
use denavit_core::spatial::{pose_from_matrix, pose_from_row_major, Pose};
use nalgebra::{Matrix4, Vector3};
use numpy::{PyArray2, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::prelude::*;

/// Any array-like of floats as a contiguous numpy array (lists accepted).
pub type ArrayIn<'py> = numpy::PyArrayLike<'py, f64, numpy::IxDyn, numpy::AllowTypeChange>;

/// Values and shape of an array-like.
pub fn values(a: &ArrayIn<'_>) -> (Vec<f64>, Vec<usize>) {
    let ro: &PyReadonlyArrayDyn<f64> = a;
    let shape = ro.shape().to_vec();
    // as_slice() also succeeds for Fortran-ordered arrays (memory order); only C order is logical order
    let v = match ro.as_slice() {
        Ok(s) if ro.is_c_contiguous() => s.to_vec(),
        _ => ro.as_array().iter().copied().collect(),
    };
    (v, shape)
}

/// Check a shape; `None` entries match anything.
pub fn check_shape(what: &str, shape: &[usize], expected: &[Option<usize>]) -> PyResult<()> {
    let ok = shape.len() == expected.len() && shape.iter().zip(expected).all(|(s, e)| e.is_none() || *e == Some(*s));
    if ok {
        return Ok(());
    }
    let exp: Vec<String> = expected.iter().map(|e| e.map_or("N".to_string(), |v| v.to_string())).collect();
    Err(value_error(format!("{what}: expected an array of shape ({}), got shape {:?}", exp.join(", "), shape)))
}

/// A 1-D array of n values: a contiguous float64 numpy array is read directly (no conversion object),
/// anything else (lists, other dtypes, strided views) through [`ArrayIn`].
pub fn vector_fast(what: &str, obj: &Bound<'_, PyAny>, n: usize) -> PyResult<Vec<f64>> {
    if let Ok(a) = obj.downcast::<numpy::PyArray1<f64>>() {
        if let Ok(v) = a.to_vec() {
            if v.len() != n {
                return Err(value_error(format!("{what}: expected an array of shape ({n}), got shape [{}]", v.len())));
            }
            check_finite(what, &v)?;
            return Ok(v);
        }
    }
    let a: ArrayIn<'_> = obj.extract()?;
    vector(what, &a, n)
}

/// A (rows, cols) numpy array copied from row-major values: one numpy-owned array, no reshape and no
/// container object (the cheapest way to hand a small result to Python).
pub fn matrix_out<'py>(py: Python<'py>, v: &[f64], rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<f64>>> {
    use numpy::ToPyArray;
    let a = numpy::ndarray::ArrayView2::from_shape((rows, cols), v).map_err(|e| value_error(e.to_string()))?;
    Ok(a.to_pyarray(py))
}

/// A 1-D array of length n.
pub fn vector(what: &str, a: &ArrayIn<'_>, n: usize) -> PyResult<Vec<f64>> {
    let (v, shape) = values(a);
    check_shape(what, &shape, &[Some(n)])?;
    check_finite(what, &v)?;
    Ok(v)
}

/// Every value finite, else an error naming the first bad index.
pub fn check_finite(what: &str, v: &[f64]) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(value_error(format!("{what} must be finite, got {} at flat index {i}", v[i]))),
        None => Ok(()),
    }
}

/// A 4x4 rigid transform from an array-like.
pub fn pose(what: &str, a: &ArrayIn<'_>) -> PyResult<Pose> {
    let (v, shape) = values(a);
    check_shape(what, &shape, &[Some(4), Some(4)])?;
    pose_from_matrix(&Matrix4::from_row_slice(&v), what).py()
}

/// A 4x4 rigid transform from a row-major slice of 16 values (the core's one SE(3) check).
pub fn pose_from_slice(what: &str, v: &[f64]) -> PyResult<Pose> {
    let v: &[f64; 16] = v.try_into().map_err(|_| value_error(format!("{what}: expected 16 values (a 4x4 matrix), got {}", v.len())))?;
    pose_from_row_major(v, what).py()
}

/// A 4x4 rigid transform from any array-like, reading a contiguous float64 (4, 4) array in place.
pub fn pose_fast(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Pose> {
    if let Ok(a) = obj.downcast::<PyArray2<f64>>() {
        if a.is_c_contiguous() {
            if let Ok(v) = a.to_vec() {
                if v.len() == 16 && a.shape() == [4, 4] {
                    return pose_from_slice(what, &v);
                }
            }
        }
    }
    let a: ArrayIn<'_> = obj.extract()?;
    let (v, shape) = values(&a);
    check_shape(what, &shape, &[Some(4), Some(4)])?;
    pose_from_slice(what, &v)
}

/// A 3-vector.
#[allow(dead_code)]
pub fn vec3(what: &str, a: &ArrayIn<'_>) -> PyResult<Vector3<f64>> {
    let v = vector(what, a, 3)?;
    Ok(Vector3::new(v[0], v[1], v[2]))
}

/// A pose as a (4, 4) numpy array.
pub fn pose_out<'py>(py: Python<'py>, t: &Pose) -> Bound<'py, PyArray2<f64>> {
    let mut v = vec![0.0; 16];
    write_pose(t, &mut v);
    numpy::PyArray1::from_vec(py, v).reshape([4, 4]).expect("16 values make a 4x4 array")
}

/// Write a pose row-major into 16 values.
pub fn write_pose(t: &Pose, out: &mut [f64]) {
    let m = t.to_homogeneous();
    for r in 0..4 {
        for c in 0..4 {
            out[4 * r + c] = m[(r, c)];
        }
    }
}

/// Row-major values as a numpy array of the given shape.
#[allow(dead_code)]
pub fn array_out<'py>(py: Python<'py>, v: Vec<f64>, shape: &[usize]) -> PyResult<Bound<'py, numpy::PyArrayDyn<f64>>> {
    numpy::PyArray1::from_vec(py, v).reshape(shape.to_vec())
}
