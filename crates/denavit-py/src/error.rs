//! The one place where core errors become Python exceptions (classes defined in `denavit.errors`).

use denavit_core::Error;
use pyo3::prelude::*;
use pyo3::types::PyType;

/// Python exception class `name` from `denavit.errors` (falls back to ValueError).
fn class<'py>(py: Python<'py>, name: &str) -> Bound<'py, PyType> {
    py.import("denavit.errors")
        .and_then(|m| m.getattr(name))
        .and_then(|c| c.downcast_into::<PyType>().map_err(Into::into))
        .unwrap_or_else(|_| py.get_type::<pyo3::exceptions::PyValueError>())
}

/// Convert a core error to the matching Python exception.
pub fn to_py(e: Error) -> PyErr {
    Python::with_gil(|py| {
        let name = match &e {
            Error::NotConverged { .. } => "NotConvergedError",
            Error::Degenerate { .. } => "DegenerateError",
            _ => "DenavitError",
        };
        PyErr::from_type(class(py, name), e.to_string())
    })
}

/// A `DenavitError` with a message.
pub fn value_error(msg: impl Into<String>) -> PyErr {
    Python::with_gil(|py| PyErr::from_type(class(py, "DenavitError"), msg.into()))
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
