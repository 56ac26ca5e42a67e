//! The one error type of the core. Every variant says what was expected, what came and where.

/// Every failure of `denavit-core`.
///
/// ```
/// use denavit_core::Error;
/// let e = Error::SizeMismatch { what: "q".into(), expected: 6, got: 7 };
/// assert_eq!(e.to_string(), "wrong size of q: expected 6, got 7");
/// ```
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// An array or list has the wrong length.
    #[error("wrong size of {what}: expected {expected}, got {got}")]
    SizeMismatch { what: String, expected: usize, got: usize },
    /// A value is NaN or infinite.
    #[error("{what} must be finite, got {value} at index {index}")]
    NonFinite { what: String, index: usize, value: f64 },
    /// A 4x4 matrix that should be a rigid transform is not.
    #[error("{what} is not a rigid transform (SE(3)): {reason}")]
    NotSe3 { what: String, reason: String },
    /// An argument is outside what is allowed.
    #[error("invalid {what}: expected {expected}, got {got}")]
    InvalidArgument { what: String, expected: String, got: String },
    /// Degenerate geometry (zero-length axis, coincident points, ...).
    #[error("degenerate input: {reason}")]
    Degenerate { reason: String },
    /// A name that is not known.
    #[error("unknown {kind} '{got}': expected one of {expected}")]
    UnknownName { kind: String, got: String, expected: String },
    /// A computed result is NaN or infinite although every input was finite: the inputs (or the model's
    /// parameters) are too large for double precision (e.g. joint velocities of 1e160, whose square overflows).
    #[error("{what} is not finite ({value} at {at}): {cause}")]
    Overflow { what: String, at: String, value: f64, cause: String },
    /// An iterative solver stopped before meeting its tolerance.
    #[error("not converged after {iterations} iterations: position error {position_error:.3e} m, rotation error {rotation_error:.3e} rad")]
    NotConverged { iterations: usize, position_error: f64, rotation_error: f64 },
    /// The computation was stopped by [`crate::parallel::interrupt`] (Ctrl-C in the binding).
    #[error("interrupted")]
    Interrupted,
    /// An error about one joint (1-based `joint`) of a model or table; the message is `source`'s, which names it.
    #[error("{source}")]
    AtJoint { joint: usize, source: Box<Error> },
}

impl Error {
    /// This error as one about joint `joint` (1-based), so that a caller reads the joint instead of the message.
    pub(crate) fn at_joint(self, joint: usize) -> Self {
        Error::AtJoint { joint, source: Box::new(self) }
    }

    /// The joint (1-based) the error is about, when known.
    ///
    /// ```
    /// use denavit_core::{Convention, JointKind, Table, spatial::Pose};
    /// use nalgebra::DMatrix;
    /// let zero_screw = DMatrix::zeros(1, 6);
    /// let bad = Table::new(Convention::Poe, zero_screw, vec![JointKind::Revolute], Pose::identity(), Pose::identity());
    /// assert_eq!(bad.unwrap().to_model("bad").unwrap_err().joint(), Some(1));
    /// ```
    pub fn joint(&self) -> Option<usize> {
        match self {
            Error::AtJoint { joint, .. } => Some(*joint),
            _ => None,
        }
    }
}

/// Result alias of the core.
pub type Result<T> = std::result::Result<T, Error>;

/// Check that every value is finite.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<()> {
    if all_finite(values) {
        return Ok(());
    }
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what: what.to_string(), index, value: values[index] }),
        None => Ok(()),
    }
}

/// [`check_finite`] of row `row` of a batch: the first non-finite value named by its row and its index in
/// the row (`"q (row 63) must be finite, got NaN at index 2"`); formats the message only on failure.
#[inline]
pub(crate) fn check_row(what: &str, row: usize, values: &[f64]) -> Result<()> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(Error::NonFinite { what: format!("{what} (row {row})"), index, value: values[index] }),
        None => Ok(()),
    }
}

/// [`check_row`] of every row of `n` values of a batch (one vectorised pass when all are finite).
pub(crate) fn check_finite_rows(what: &str, values: &[f64], n: usize) -> Result<()> {
    if all_finite(values) {
        return Ok(());
    }
    values.chunks(n.max(1)).enumerate().try_for_each(|(row, v)| check_row(what, row, v))
}

/// Whether every value is finite, in one branch-free pass that vectorises (`x * 0` is NaN exactly for an
/// infinite or NaN `x`): the batch kernels check their inputs with it at memory speed.
#[inline]
pub(crate) fn all_finite(values: &[f64]) -> bool {
    let mut acc = [0.0f64; 8];
    let mut blocks = values.chunks_exact(8);
    for b in &mut blocks {
        for l in 0..8 {
            acc[l] += b[l] * 0.0;
        }
    }
    blocks.remainder().iter().all(|v| v.is_finite()) && acc.iter().all(|a| *a == 0.0)
}

/// Check a length.
pub(crate) fn check_len(what: &str, expected: usize, got: usize) -> Result<()> {
    if expected == got { Ok(()) } else { Err(Error::SizeMismatch { what: what.to_string(), expected, got }) }
}
