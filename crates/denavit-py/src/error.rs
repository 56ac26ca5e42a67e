//! The one place where core errors become Python exceptions (classes defined in `denavit.errors`): the
//! exception carries the variant's fields as attributes and `kind`, the variant's name.

use denavit_core::Error;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyType};

/// Python exception class `name` from `denavit.errors` (falls back to ValueError).
fn class<'py>(py: Python<'py>, name: &str) -> Bound<'py, PyType> {
    py.import("denavit.errors")
        .and_then(|m| m.getattr(name))
        .and_then(|c| c.downcast_into::<PyType>().map_err(Into::into))
        .unwrap_or_else(|_| py.get_type::<pyo3::exceptions::PyValueError>())
}

/// Set each named variable as an item of the dict, under its own name.
macro_rules! fields {
    ($d:expr; $($f:ident),*) => {{
        $( $d.set_item(stringify!($f), $f)?; )*
    }};
}

/// The exception of a core error, its message prefixed with `context` when given; `joint` (1-based) when the
/// binding knows which joint or link the error is about.
fn exception(e: &Error, context: Option<&str>, joint: Option<usize>) -> PyErr {
    if let Error::AtJoint { joint: j, source } = e {
        return exception(source, context, joint.or(Some(*j)));
    }
    Python::with_gil(|py| {
        let built = || -> PyResult<PyErr> {
            let d = PyDict::new(py);
            // (variant, Python class); the core's UnknownName `kind` (what kind of name: "convention", "joint
            // kind") is `what` in Python, where `kind` names the variant
            let (kind, class_name) = match e {
                Error::SizeMismatch { what, expected, got } => {
                    fields!(d; what, expected, got);
                    ("SizeMismatch", "DenavitError")
                }
                Error::NonFinite { what, index, value } => {
                    fields!(d; what, index, value);
                    ("NonFinite", "DenavitError")
                }
                Error::NotSe3 { what, reason } => {
                    fields!(d; what, reason);
                    ("NotSe3", "DenavitError")
                }
                Error::InvalidArgument { what, expected, got } => {
                    fields!(d; what, expected, got);
                    ("InvalidArgument", "DenavitError")
                }
                Error::Degenerate { reason } => {
                    fields!(d; reason);
                    ("Degenerate", "DegenerateError")
                }
                Error::UnknownName { kind: what, got, expected } => {
                    fields!(d; what, got, expected);
                    ("UnknownName", "DenavitError")
                }
                Error::Overflow { what, at, value, cause } => {
                    fields!(d; what, at, value, cause);
                    ("Overflow", "DenavitError")
                }
                Error::NotConverged { iterations, position_error, rotation_error } => {
                    fields!(d; iterations, position_error, rotation_error);
                    ("NotConverged", "NotConvergedError")
                }
                _ => ("Other", "DenavitError"),
            };
            fields!(d; kind, joint);
            let message = match context {
                Some(c) => format!("{c}: {e}"),
                None => e.to_string(),
            };
            Ok(PyErr::from_value(class(py, class_name).call((message,), Some(&d))?))
        };
        built().unwrap_or_else(|err| err)
    })
}

/// Convert a core error to the matching Python exception (an interrupted computation: KeyboardInterrupt).
pub fn to_py(e: Error) -> PyErr {
    if e == Error::Interrupted {
        return pyo3::exceptions::PyKeyboardInterrupt::new_err("interrupted");
    }
    exception(&e, None, None)
}

/// A core error about joint (or link) `joint` (1-based): the message starts with `label joint`.
pub fn at_joint(e: Error, label: &str, joint: usize) -> PyErr {
    exception(&e, Some(&format!("{label} {joint}")), Some(joint))
}

/// A core error whose message already names the joint (or link) `joint` (1-based), when known.
pub fn of_joint(e: Error, joint: Option<usize>) -> PyErr {
    exception(&e, None, joint)
}

/// An `InvalidArgument` error (what was expected, what came).
pub fn invalid(what: impl Into<String>, expected: impl Into<String>, got: impl Into<String>) -> PyErr {
    to_py(Error::InvalidArgument { what: what.into(), expected: expected.into(), got: got.into() })
}

/// `Result<T, core::Error>` -> `PyResult<T>`.
pub trait IntoPy<T> {
    fn py(self) -> PyResult<T>;
}
impl<T> IntoPy<T> for Result<T, Error> {
    fn py(self) -> PyResult<T> {
        self.map_err(to_py)
    }
}
