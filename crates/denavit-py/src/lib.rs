//! `denavit._core`: the thin PyO3 binding of `denavit-core`. Conversions and checks live in `convert`,
//! error mapping in `error`; one file per concept of the core.

use pyo3::prelude::*;

mod calibration;
mod compensate;
mod convert;
mod dynamics;
mod error;
mod ik;
mod kinematics;
mod model;
mod signals;

#[pymodule]
fn _core(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<model::PyModel>()?;
    m.add_class::<model::PyTable>()?;
    m.add_class::<model::PyJointAxes>()?;
    m.add_class::<model::PyExtraction>()?;
    m.add_class::<model::PyPair>()?;
    m.add_function(wrap_pyfunction!(model::axes, m)?)?;
    m.add_function(wrap_pyfunction!(model::extract, m)?)?;
    m.add_function(wrap_pyfunction!(model::convention_info, m)?)?;
    m.add_function(wrap_pyfunction!(model::conventions, m)?)?;
    m.add_function(wrap_pyfunction!(model::default_limits, m)?)?;
    m.add("NEAR_PARALLEL_SIN", denavit_core::extract::NEAR_PARALLEL_SIN)?;
    m.add("EXACT_PARALLEL_SIN", denavit_core::extract::EXACT_PARALLEL_SIN)?;
    kinematics::register(m)?;
    ik::register(m)?;
    dynamics::register(m)?;
    calibration::register(m)?;
    compensate::register(m)?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
