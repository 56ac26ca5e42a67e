//! The one converter between Python array-likes and the core's slices and poses.
//!
//! It reads values in C (row-major) order and checks the shape it needs to interpret them (a pose is 4 x 4,
//! a batch has n columns); every check of the values themselves (finiteness, lengths against the model,
//! limits, SE(3)) is the core's. A C-contiguous, aligned float64 numpy array is read without a conversion
//! object; anything else (lists, other dtypes, Fortran-ordered or strided arrays) goes through `numpy.asarray`.
//!
//! **What Python may hand us.** numpy allows data at any address (`np.frombuffer(buf, offset=3)`), any
//! strides, and several arrays over one buffer that numpy's borrow tracking cannot tell apart (two
//! `frombuffer` views). A Rust slice or reference must be aligned and must not alias a `&mut`, so: an array
//! whose data is not 8-byte aligned is copied before it is read (inputs) or refused (`out=`); an input
//! borrowed in place is checked against `out=` by address range (numpy's `may_share_memory` bounds, exact for
//! the contiguous arrays borrowed here) and an overlap is refused. Datetime and complex arrays are refused
//! (numpy would convert them to numbers without a word).

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

/// Whether a float64 array's data starts at an address a Rust `&f64` may have (8-byte aligned). For a
/// C-contiguous array every element then is (its strides are multiples of 8).
fn aligned<D: numpy::ndarray::Dimension>(a: &Bound<'_, PyArray<f64, D>>) -> bool {
    (a.data() as usize).is_multiple_of(std::mem::align_of::<f64>())
}

/// Whether `obj` is a numpy array whose elements are not all aligned for their type (numpy's ALIGNED flag:
/// the data address and every stride).
fn unaligned_array(obj: &Bound<'_, PyAny>) -> PyResult<bool> {
    if obj.downcast::<numpy::PyUntypedArray>().is_err() {
        return Ok(false);
    }
    Ok(!obj.getattr("flags")?.getattr("aligned")?.extract::<bool>()?)
}

/// Values (C order) and shape of any array-like.
pub fn read(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<usize>)> {
    if let Ok(a) = obj.downcast::<PyArrayDyn<f64>>() {
        if a.is_c_contiguous() && aligned(a) {
            if let Ok(v) = a.to_vec() {
                return Ok((v, a.shape().to_vec()));
            }
        }
    }
    converted(what, obj)
}

/// [`read`] through `numpy.asarray(obj, dtype=float64)`, whatever the layout (an unaligned array copied
/// first: `asarray` would hand back the same memory).
fn converted(what: &str, obj: &Bound<'_, PyAny>) -> PyResult<(Vec<f64>, Vec<usize>)> {
    // numpy would cast complex to float and drop the imaginary part (a ComplexWarning), and datetimes and
    // durations to their counts of ticks: refuse them
    if let Ok(a) = obj.downcast::<numpy::PyUntypedArray>() {
        let kind = match a.dtype().kind() {
            b'c' => Some("a complex array"),
            b'M' => Some("a datetime array"),
            b'm' => Some("a timedelta array"),
            _ => None,
        };
        if let Some(kind) = kind {
            return Err(invalid(
                what,
                "an array-like of real floats",
                format!("{kind} (dtype {})", a.dtype().str().map(|d| d.to_string()).unwrap_or_default()),
            ));
        }
    }
    let copied;
    let obj = if unaligned_array(obj)? {
        copied = obj.call_method0("copy")?;
        &copied
    } else {
        obj
    };
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
        if aligned(a) {
            if let Ok(v) = a.to_vec() {
                return Ok(v);
            }
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
        if n <= buf.len() && aligned(a) && (n < 2 || a.strides()[0] % 8 == 0) {
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
        if a.shape() == [4, 4] && aligned(a) {
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

/// A batch (N, k): borrowed in place when a C-contiguous, aligned float64 numpy array, else converted.
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
        if a.is_c_contiguous() && aligned(a) {
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

/// A Python int argument of any size: `Ok` within 64 bits, else `Err` with its decimal text, so that the
/// function refuses it with a one-line error naming the argument and its range (pyo3 alone would raise a
/// bare OverflowError). Other types are refused as usual (TypeError).
#[derive(Clone)]
pub struct Int(pub Result<i64, String>);

impl<'py> FromPyObject<'py> for Int {
    fn extract_bound(obj: &Bound<'py, PyAny>) -> PyResult<Self> {
        match obj.extract::<i64>() {
            Ok(v) => Ok(Int(Ok(v))),
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyOverflowError>(obj.py()) => Ok(Int(Err(obj.str()?.to_string()))),
            Err(e) => Err(e),
        }
    }
}

/// The thread count of a `threads=` argument (None: rayon's pool).
pub fn threads_of(threads: Option<Threads>) -> Option<usize> {
    threads.map(|t| t.0)
}

/// The result array of a batch: `out` when given (checked: a numpy float64 array of exactly `shape`,
/// C-contiguous, 8-byte aligned, writeable, sharing no memory with the `inputs` (name, values) and not
/// borrowed elsewhere), else a new one. `kernel` fills it without the GIL on `threads` threads
/// (`denavit_core::parallel::with_threads`; interruptible by Ctrl-C when long, [`crate::signals`]: the kernel
/// costs about `ns_per_value` ns per output value on one core) and the array is returned.
pub fn batch_out<'py, D: numpy::ndarray::Dimension>(
    py: Python<'py>,
    shape: D,
    out: Option<&Bound<'py, PyAny>>,
    threads: Option<Threads>,
    inputs: &[(&str, &[f64])],
    ns_per_value: f64,
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
            if !aligned(a) {
                return Err(invalid(
                    "out",
                    format!("{} whose data is 8-byte aligned", want()),
                    format!("an array whose data starts at an address not a multiple of 8 (0x{:x}; e.g. np.frombuffer at an offset)", a.data() as usize),
                ));
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
        // memory shared with an input that numpy's borrow tracking cannot see (two np.frombuffer arrays of one
        // buffer; an input that is `out` itself, or a view of it, was refused by the borrow above), checked by
        // address before any `&mut` to the output exists
        let bytes = |p: *const f64, len: usize| (p as usize, p as usize + len * std::mem::size_of::<f64>());
        let (o0, o1) = bytes(a.data(), a.len());
        for (name, v) in inputs {
            let (i0, i1) = bytes(v.as_ptr(), v.len());
            if o0 < o1 && i0 < i1 && o0 < i1 && i0 < o1 {
                return Err(invalid(
                    "out",
                    format!("{} sharing no memory with {name}", want()),
                    format!("an array that overlaps {name}'s memory (e.g. two np.frombuffer views of one buffer)"),
                ));
            }
        }
        let o = rw.as_slice_mut()?;
        // a new array's pages are zeroed at their first touch, which leaves them in the cache: plain stores
        let fresh = out.is_none();
        let long = crate::signals::long(o.len() as f64 * ns_per_value);
        let run = || if fresh { denavit_core::stream::with_plain_stores(|| kernel(o)) } else { kernel(o) };
        crate::signals::without_gil(py, long, || denavit_core::parallel::with_threads(threads, run).and_then(|r| r))?.py()?;
    }
    Ok(a)
}
