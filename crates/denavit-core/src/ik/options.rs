//! What an IK solve is asked ([`IkOptions`], [`IkMethod`], the budget limits) and what it returns ([`IkResult`]).

use super::*;

/// The iterative method of [`ik`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum IkMethod {
    /// Newton-Raphson (Guo et al. sec. V).
    Newton,
    /// Levenberg-Marquardt / damped least squares.
    Lm,
}

impl IkMethod {
    /// Parse `"newton"` (also `"nr"`) or `"lm"` (also `"dls"`).
    ///
    /// ```
    /// use denavit_core::ik::IkMethod;
    /// assert_eq!(IkMethod::parse("LM").unwrap(), IkMethod::Lm);
    /// assert!(IkMethod::parse("bfgs").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "newton" | "nr" | "newton-raphson" => Ok(Self::Newton),
            "lm" | "dls" | "levenberg-marquardt" => Ok(Self::Lm),
            _ => Err(Error::UnknownName { kind: "IK method".into(), got: s.into(), expected: "newton, lm".into() }),
        }
    }
    /// `"newton"` or `"lm"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Newton => "newton",
            Self::Lm => "lm",
        }
    }
}

/// The most iterations one IK attempt may take (docs/cli.md, Limits): far beyond convergence (LM and Newton
/// converge in tens), and a budget that still ends in seconds on an unreachable goal of a 6R arm (docs/speed.md).
pub const MAX_ITERATIONS: usize = 1_000_000;
/// The most restarts one IK solve may take (docs/cli.md, Limits).
pub const MAX_RESTARTS: usize = 1_000_000;

/// Options of the IK solvers. `Default`: LM, tolerances 1e-10 m and 1e-10 rad, 100 iterations per
/// attempt, 50 restarts, seed 0, limits respected, initial damping μ = 0.1.
///
/// ```
/// use denavit_core::ik::{IkOptions, IkMethod};
/// let o = IkOptions { method: IkMethod::Newton, tol_position: 1e-6, ..Default::default() };
/// assert!(o.check().is_ok());
/// assert!(IkOptions { tol_rotation: f64::NAN, ..Default::default() }.check().is_err());
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct IkOptions {
    /// The iterative method.
    pub method: IkMethod,
    /// Largest accepted distance between the tool origin and the goal position (m).
    pub tol_position: f64,
    /// Largest accepted rotation angle between the tool and the goal orientation (rad).
    pub tol_rotation: f64,
    /// Jacobian evaluations per attempt (attempt 0's include the polish of the closed-form seeds).
    pub max_iterations: usize,
    /// Further attempts from random configurations after the one from `q0` fails.
    pub restarts: usize,
    /// Seed of the restart configurations.
    pub seed: u64,
    /// Keep every `q_i` within `[lower_i, upper_i]` (and require it for success).
    pub respect_limits: bool,
    /// Initial μ of LM's damping `λ = μ |e|^2` (1 / m² for the position rows, 1 / rad² for rotation).
    pub damping: f64,
}

impl Default for IkOptions {
    fn default() -> Self {
        Self { method: IkMethod::Lm, tol_position: 1e-10, tol_rotation: 1e-10, max_iterations: 100, restarts: 50, seed: 0, respect_limits: true, damping: 0.1 }
    }
}

impl IkOptions {
    /// Check that the tolerances are finite and >= 0, `max_iterations >= 1` and `damping` finite and > 0.
    pub fn check(&self) -> Result<()> {
        for (what, v) in [("tol_position (m)", self.tol_position), ("tol_rotation (rad)", self.tol_rotation)] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::InvalidArgument { what: what.into(), expected: "a finite value >= 0".into(), got: v.to_string() });
            }
        }
        if self.max_iterations == 0 {
            return Err(Error::InvalidArgument { what: "max_iterations".into(), expected: ">= 1".into(), got: "0".into() });
        }
        if self.max_iterations > MAX_ITERATIONS {
            return Err(Error::InvalidArgument {
                what: "max_iterations".into(),
                expected: format!("at most {MAX_ITERATIONS} (per attempt)"),
                got: self.max_iterations.to_string(),
            });
        }
        if self.restarts > MAX_RESTARTS {
            return Err(Error::InvalidArgument { what: "restarts".into(), expected: format!("at most {MAX_RESTARTS}"), got: self.restarts.to_string() });
        }
        if !(self.damping.is_finite() && self.damping > 0.0) {
            return Err(Error::InvalidArgument { what: "damping".into(), expected: "a finite value > 0".into(), got: self.damping.to_string() });
        }
        Ok(())
    }
}

/// The outcome of one IK solve; the errors are measured at the returned `q`.
#[derive(Debug, Clone, PartialEq)]
pub struct IkResult {
    /// The solution (rad / m), or the best configuration found when `success` is false.
    pub q: Vec<f64>,
    /// `position_error <= tol_position && rotation_error <= tol_rotation` (and within limits if asked).
    pub success: bool,
    /// Jacobian evaluations, summed over all attempts (a closed-form seed that meets the tolerance as it is,
    /// checked by forward kinematics alone, counts as one).
    pub iterations: usize,
    /// Restarts used (0 when the attempt from `q0` succeeded).
    pub restarts: usize,
    /// `|p_tool(q) - p_goal|` (m).
    pub position_error: f64,
    /// Rotation angle between `R_tool(q)` and `R_goal` (rad).
    pub rotation_error: f64,
}

impl IkResult {
    /// `Ok(self)` when successful, else [`Error::NotConverged`] with the measured residual.
    pub fn into_result(self) -> Result<Self> {
        if self.success {
            Ok(self)
        } else {
            Err(Error::NotConverged { iterations: self.iterations, position_error: self.position_error, rotation_error: self.rotation_error })
        }
    }
}
