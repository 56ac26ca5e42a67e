//! The one converter between Python array-likes and the core's slices and poses.
//!
//! It reads values in C (row-major) order and checks the shape it needs to interpret them (a pose is 4 x 4,
//! a batch has n columns); every check of the values themselves (finiteness, lengths against the model,
//! limits, SE(3)) is the core's. A C-contiguous float64 numpy array is read without a conversion object;
//! anything else (lists, other dtypes, Fortran-ordered or strided arrays) goes through `numpy.asarray`.

use crate::error::{invalid, to_py, IntoPy};
use denavit_core::spatial::{pose_from_row_major, Pose};
use denavit_core::Error;
use nalgebra::Vector3;
use numpy::ndarray::{ArrayView, ShapeBuilder};
use numpy::{PyArray, PyArray2, PyArray3, PyArrayDescrMethods, PyArrayDyn, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods, ToPyArray};
use pyo3::prelude::*;

/// Any array-like of floats, converted by numpy.
type ArrayLike<'py> = numpy::PyArrayLike<'py, f64, numpy::IxDyn, numpy::AllowTypeChange>;

fn shape_text(shape: &[usize]) -> String {
    let s: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    if s.len() == 1 {
        format!("({},)", s[0])
    } else {
        format!("({})", s.join(", "))
    }
}

fn describe(obj: &Bound<'_, PyAny>) -> String {
    obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "an object".into())
}

/// Values (C order) and shape of any array-like.
pub fn read(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<usize>)> {
    if let Ok(a) = obj.downcast::<PyArrayDyn<f64>>() {
        if a.is_c_contiguous() {
            if let Ok(v) = a.to_vec() {
                return Ok((v, a.shape().to_vec()));
            }
        }
    }
    converted(what, obj)
}

/// [`read`] through `numpy.asarray(obj, dtype=float64)`, whatever the layout.
fn converted(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<usize>)> {
    // numpy would cast complex to float and drop the imaginary part (a ComplexWarning): refuse it
    if let Ok(a) = obj.downcast::<numpy::PyUntypedArray>() {
        if a.dtype().kind() == b'c' {
            return Err(invalid(
                what,
                "an array-like of real floats",
                format!("a complex array (dtype {})", a.dtype().str().map(|d| d.to_string()).unwrap_or_default()),
            ));
        }
    }
    let a: ArrayLike<'_> = obj.extract().map_err(|e| invalid(what, "an array-like of floats", format!("{} ({})", describe(obj), e.value(obj.py()))))?;
    // as_slice() also succeeds for Fortran-ordered arrays (memory order): only C order is the logical order
    let v = match a.as_slice() {
        Ok(v) if a.is_c_contiguous() => v.to_vec(),
        _ => a.as_array().iter().copied().collect(),
    };
    Ok((v, a.shape().to_vec()))
}

/// Check a shape; `None` entries match any size.
pub fn check_shape(what: &str, shape: &[usize], dims: &[Option<usize>]) -> PyResult<()> {
    if shape.len() == dims.len() && shape.iter().zip(dims).all(|(s, d)| d.is_none_or(|d| d == *s)) {
        return Ok(());
    }
    let want: Vec<String> = dims.iter().map(|d| d.map_or("N".to_string(), |v| v.to_string())).collect();
    let want = match dims {
        [None] => "a 1-D array".to_string(),
        [Some(n)] => format!("an array of shape ({n},)"),
        _ => format!("an array of shape ({})", want.join(", ")),
    };
    Err(invalid(what, want, format!("shape {}", shape_text(shape))))
}

/// Values of an array of the given shape (`None`: any size). An empty list (shape (0,)) is zero rows of a
/// (N, ...) array.
pub fn shaped(what: &str, obj: &Bound<'_, PyAny>, dims: &[Option<usize>]) -> PyResult<(Vec<f64>, Vec<usize>)> {
    let (v, shape) = read(what, obj)?;
    if v.is_empty() && shape == [0] && dims.len() > 1 && dims[0].is_none() {
        let mut s = vec![0];
        s.extend(dims[1..].iter().map(|d| d.unwrap_or(0)));
        return Ok((v, s));
    }
    check_shape(what, &shape, dims)?;
    Ok((v, shape))
}

/// A 1-D array (its length is checked by the core).
pub fn vector(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    // a float64 array copied at once
    if let Ok(a) = obj.downcast::<numpy::PyArray1<f64>>() {
        if let Ok(v) = a.to_vec() {
            return Ok(v);
        }
    }
    let (v, shape) = converted(what, obj)?;
    check_shape(what, &shape, &[None])?;
    Ok(v)
}

/// [`vector`] of up to 16 values (one configuration of one robot) copied into `buf`, not allocated (the
/// per-call hot path: fk, jacobian, rnea); a longer or other input goes through [`vector`].
pub fn configuration<'b>(what: &str, obj: &Bound<'_, PyAny>, buf: &'b mut [f64; 16]) -> PyResult<std::borrow::Cow<'b, [f64]>> {
    if let Ok(a) = obj.downcast::<numpy::PyArray1<f64>>() {
        let n = a.len();
        if n <= buf.len() {
            for (i, b) in buf[..n].iter_mut().enumerate() {
                *b = a.get_owned([i]).unwrap_or(f64::NAN);
            }
            return Ok(std::borrow::Cow::Borrowed(&buf[..n]));
        }
    }
    vector(what, obj).map(std::borrow::Cow::Owned)
}

/// [`vector`] of an optional argument, `None` when absent.
pub fn opt_vector(what: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<f64>>> {
    obj.map(|o| vector(what, o)).transpose()
}

/// `Error::SizeMismatch` unless `got == expected` (for lengths the binding needs before the core sees them).
pub fn check_len(what: &str, expected: usize, got: usize) -> PyResult<()> {
    if expected == got {
        Ok(())
    } else {
        Err(to_py(Error::SizeMismatch { what: what.into(), expected, got }))
    }
}

/// A rigid transform from 16 row-major values (the core's one SE(3) check, `spatial::pose_from_row_major`).
pub fn pose_from_values(what: &str, v: &[f64]) -> PyResult<Pose> {
    let v: &[f64; 16] = v.try_into().map_err(|_| to_py(Error::SizeMismatch { what: format!("{what} (a 4x4 matrix)"), expected: 16, got: v.len() }))?;
    pose_from_row_major(v, what).py()
}

/// A (4, 4) rigid transform.
pub fn pose(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Pose> {
    // the per-call hot path (ik of one target): a C-contiguous float64 (4, 4) copied at once (to_vec takes no
    // borrow: numpy's borrow tracking would cost more than the copy)
    if let Ok(a) = obj.downcast::<PyArray2<f64>>() {
        if a.shape() == [4, 4] {
            if let Ok(v) = a.to_vec() {
                return pose_from_values(what, &v);
            }
        }
    }
    let (v, _) = shaped(what, obj, &[Some(4), Some(4)])?;
    pose_from_values(what, &v)
}

/// An optional (4, 4) rigid transform, identity when absent.
pub fn opt_pose(what: &str, obj: Option<&Bound<'_, PyAny>>) -> PyResult<Pose> {
    obj.map_or_else(|| Ok(Pose::identity()), |o| pose(what, o))
}

/// (N, 4, 4) rigid transforms, element i named `what[i]`.
pub fn poses(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<Pose>> {
    let (v, _) = shaped(what, obj, &[None, Some(4), Some(4)])?;
    v.chunks_exact(16).enumerate().map(|(i, c)| pose_from_values(&format!("{what}[{i}]"), c)).collect()
}

/// (N, 3) points or directions.
pub fn vectors3(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<Vec<Vector3<f64>>> {
    let (v, _) = shaped(what, obj, &[None, Some(3)])?;
    Ok(v.chunks_exact(3).map(Vector3::from_row_slice).collect())
}

/// A batch (N, k): borrowed in place when a C-contiguous float64 numpy array, else converted.
pub enum Rows<'py> {
    Borrowed(PyReadonlyArray2<'py, f64>),
    Owned(Vec<f64>),
}

impl Rows<'_> {
    /// The values, row-major.
    pub fn slice(&self) -> &[f64] {
        match self {
            Rows::Borrowed(a) => a.as_slice().unwrap_or(&[]),
            Rows::Owned(v) => v,
        }
    }
}

/// A batch (N, k) and its number of rows N (that several batches agree is the core's check).
pub fn rows<'py>(what: &str, obj: &Bound<'py, PyAny>, k: usize) -> PyResult<(Rows<'py>, usize)> {
    if let Ok(a) = obj.downcast::<PyArray2<f64>>() {
        if a.is_c_contiguous() {
            check_shape(what, a.shape(), &[None, Some(k)])?;
            if let Ok(r) = a.try_readonly() {
                if r.as_slice().is_ok() {
                    return Ok((Rows::Borrowed(r), a.shape()[0]));
                }
            }
        }
    }
    let (v, shape) = shaped(what, obj, &[None, Some(k)])?;
    Ok((Rows::Owned(v), shape[0]))
}

/// Row-major values as a new numpy array of the given shape (copied into numpy-owned memory: for small
/// results the cheapest hand-over).
pub fn out<'py, Sh: ShapeBuilder>(py: Python<'py>, v: &[f64], shape: Sh) -> PyResult<Bound<'py, PyArray<f64, Sh::Dim>>> {
    let a = ArrayView::from_shape(shape, v).map_err(|e| invalid("result array", "values matching its shape", e.to_string()))?;
    Ok(a.to_pyarray(py))
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

/// A pose as a (4, 4) numpy array.
pub fn pose_out<'py>(py: Python<'py>, t: &Pose) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let mut v = [0.0; 16];
    write_pose(t, &mut v);
    out(py, &v, [4, 4])
}

/// Poses as a (N, 4, 4) numpy array.
pub fn poses_out<'py, 'a>(py: Python<'py>, ts: impl ExactSizeIterator<Item = &'a Pose>) -> PyResult<Bound<'py, PyArray3<f64>>> {
    let n = ts.len();
    let mut v = vec![0.0; 16 * n];
    for (t, o) in ts.zip(v.chunks_exact_mut(16)) {
        write_pose(t, o);
    }
    out(py, &v, [n, 4, 4])
}

/// `threads=` of a batch call: a count 1..=4 per core (None, rayon's pool: RAYON_NUM_THREADS, else every
/// core, is the absent argument). Out of range, or too large for 64 bits, is a one-line error naming it.
pub struct Threads(usize);

impl<'py> FromPyObject<'py> for Threads {
    fn extract_bound(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        let max = denavit_core::parallel::max_threads();
        let wrong = |got: String| invalid("threads", format!("None (RAYON_NUM_THREADS, else every core) or a count 1..={max} (4 per core)"), got);
        match obj.extract::<i64>() {
            Ok(k) if k >= 1 && k as u64 <= max as u64 => Ok(Threads(k as usize)),
            Ok(k) => Err(wrong(k.to_string())),
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => Err(wrong(obj.str().map(|s| s.to_string()).unwrap_or_default())),
            Err(e) => Err(e),
        }
    }
}

/// The thread count of a `threads=` argument (None: rayon's pool).
pub fn threads_of(threads: Option<Threads>) -> Option<usize> {
    threads.map(|t| t.0)
}

/// The result array of a batch: `out` when given (checked: a numpy float64 array of exactly `shape`,
/// C-contiguous, writeable, not one of the inputs), else a new one. `kernel` fills it without the GIL on
/// `threads` threads (`denavit_core::parallel::with_threads`) and the array is returned.
pub fn batch_out<'py, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    shape: D,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
    kernel: impl FnOnce(&mut [f64]) -> denavit_core::Result<()> + Send,
) -> PyResult<Bound<'py, PyArray<f64, D>>> {
    let threads = threads_of(threads);
    let want = || format!("a C-contiguous, writeable float64 numpy array of shape {}", shape_text(shape.slice()));
    let a = match out {
        None => PyArray::<f64, D>::zeros(py, shape.clone(), false),
        Some(o) => {
            let Ok(a) = o.downcast::<PyArray<f64, D>>() else {
                return Err(match o.downcast::<numpy::PyUntypedArray>() {
                    Ok(arr) => {
                        let dtype = arr.dtype().str().map(|d| d.to_string()).unwrap_or_default();
                        let shape = shape_text(arr.shape());
                        // a float64 array refused by its number of dimensions: its shape is what is wrong
                        invalid("out", want(), if dtype == "float64" { format!("shape {shape}") } else { format!("dtype {dtype}, shape {shape}") })
                    }
                    Err(_) => invalid("out", want(), describe(o)),
                });
            };
            if a.shape() != shape.slice() {
                return Err(invalid("out", want(), format!("shape {}", shape_text(a.shape()))));
            }
            if !a.is_c_contiguous() {
                return Err(invalid("out", want(), "an array that is not C-contiguous"));
            }
            a.clone()
        }
    };
    {
        let mut rw = a.try_readwrite().map_err(|e| match e {
            numpy::BorrowError::NotWriteable => invalid("out", want(), "a read-only array"),
            _ => invalid(
                "out",
                "an array not in use elsewhere during the call (not an input of it, nor the out= of a call running in another thread)",
                "an array in use",
            ),
        })?;
        let o = rw.as_slice_mut()?;
        // a new array's pages are zeroed at their first touch, which leaves them in the cache: plain stores
        let fresh = out.is_none();
        let run = || if fresh { denavit_core::stream::with_plain_stores(|| kernel(o)) } else { kernel(o) };
        py.allow_threads(|| denavit_core::parallel::with_threads(threads, run).and_then(|r| r)).py()?;
    }
    Ok(a)
}
