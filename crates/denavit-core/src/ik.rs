//! Inverse kinematics: Newton-Raphson (as used by Guo et al., sec. V) and damped least squares /
//! Levenberg-Marquardt with joint limits; a path solver that warm-starts each target from the previous
//! solution, and a batch solver on every core.
//!
//! **Error.** At the current configuration `q` with tool pose `T_world_tool(q) = (R, p)` and a target
//! `(R*, p*)`, the error twist in `world` is `e = [p* - p ; R · log(R^T R*)]` (position difference in m,
//! rotation vector in rad; `log` is the SO(3) logarithm). It is driven to zero with the world-frame
//! geometric Jacobian of [`crate::kinematics::jacobian`] (`J dq ≈ e`, exact to first order).
//!
//! **Success** is decided only from the *measured* final error, never from an internal flag: the tool pose
//! is recomputed from the returned `q` with [`crate::kinematics::tool_pose`] and compared with
//! [`crate::spatial::pose_error`]; `success` is `position_error <= tol_position && rotation_error <=
//! tol_rotation` (and every `q_i` within its limits when `respect_limits`). The reported errors are those
//! measured values, so `success` implies the errors are within the tolerance the user asked for.
//!
//! **Methods.**
//! * [`IkMethod::Newton`]: Newton-Raphson `q <- q + α J^-1 e` (Guo et al. sec. V; Gauss-Newton
//!   `(J^T J)^-1 J^T e` for n < 6 and the minimum-norm step `J^T (J J^T)^-1 e` for n > 6; a singular
//!   Jacobian falls back to a slightly damped step) with backtracking on `|e|^2` (Nocedal & Wright 2006,
//!   Algorithm 3.1): α = 1, 1/2, 1/4, the first that lowers the error; if none does, the full step is taken
//!   anyway (Newton's jump out of a basin; the attempt keeps its best configuration). Every trial point
//!   counts as an iteration. An attempt with 8 steps in a row without a new best gives way to the next
//!   restart; the last attempt (with `restarts = 0`, the only one) uses its whole budget.
//! * [`IkMethod::Lm`]: Levenberg-Marquardt (Levenberg 1944, Marquardt 1963; damped least squares,
//!   Wampler 1986): `(J^T J + λ I) dq = J^T e`, a step is accepted only if it lowers `|e|^2`. The damping
//!   is `λ = μ |e|^2` (Fan & Yuan 2005: quadratic convergence to a zero residual), μ starting at
//!   `damping` and updated by the gain ratio ρ of the actual to the predicted decrease (Nielsen 1999;
//!   Madsen, Nielsen & Tingleff 2004, Algorithm 3.16): accepted, `μ *= max(1/3, 1 - (2ρ - 1)^3)`, ν = 2;
//!   rejected, `μ *= ν`, `ν *= 2`. An attempt that has not halved `|e|^2` within 10 iterations gives way to
//!   the next restart (a local minimum), except the last attempt, which uses its whole budget. A joint held
//!   at a limit that the step would push further out is left out of the step (its Jacobian column zeroed,
//!   an active set as in Bertsekas 1982), so the other joints do the work.
//!
//! **Joint limits** (`respect_limits`): after every step each `q_i` is projected into `[lower_i, upper_i]`,
//! first by moves that keep the tool pose: a revolute joint is shifted by a multiple of 2π when that brings it
//! into the range, and a spherical wrist (joints i..i+2 whose flip `θ_i + π, -θ_(i+1), θ_(i+2) + π` gives the same
//! pose, found numerically) with a joint still outside is flipped when the flipped wrist is within its limits
//! (one attempt on the Puma 560: Newton 73.2 -> 81.8 %, LM 77.6 -> 82.4 %). What is still outside is clamped (the start and LM, whose active set holds joints at a limit) or, in Newton's trial
//! points, mirrored at the limit it crossed and then clamped (reflective Newton methods for bounds: Coleman
//! & Li 1996): a clamped Newton iterate tends to stay at the limit, converging towards an IK branch outside
//! the range; the mirrored one moves back inside. One attempt, random reachable targets
//! (benchmarks/bench_kinematics.py): KR5 87.0 -> 92.2 %, Puma 560 68.6 -> 73.2 % (for LM, mirroring lowered
//! the Puma's rate, 77.6 -> 65.8 %, so LM keeps clamping).
//!
//! **Closed-form seeds.** A 6R chain whose joint axes (at `q = 0`) have one of the two structures of industrial
//! arms ([`Structure`]: a spherical wrist behind two parallel shoulder axes, as on the KUKA KR5 and the Puma 560;
//! three parallel axes with axes 5 and 6 meeting, as on the UR5 and the TianSui-One) is solved in closed form
//! first, by Paden-Kahan subproblems on its axis lines (`closed_form` module; Elias & Wen 2022, "IK-Geo";
//! Murray, Li & Sastry 1994, ch. 3): up to 8 branches, found once per model ([`closed_form_structure`]) with a
//! tolerance (5 mrad, 0.5 % of the chain's size), so that an identified robot is solved on the nearest ideal
//! structure. Attempt 0 places each branch near `q0` (each revolute joint by the multiple of 2π nearest to
//! `q0_i`, or the next one when that is within its limits), drops those outside the limits (with
//! `respect_limits`), and tries them nearest to `q0` first (squared distance in joint space; found best-first, so
//! that the branches of arms far from `q0` are not computed): each is checked by forward kinematics and, if not
//! within the tolerance as it is, polished on the model by a Newton attempt of at most 10 Jacobian evaluations,
//! until one meets the tolerance: an exact branch at once, a branch of an identified robot (axes 0.5 mm /
//! 0.5 mrad off) in 3 (the median). If none does, the iterative attempt from `q0` follows with the rest
//! of attempt 0's `max_iterations`. This is part of every method's
//! first attempt: the method is the iteration of the fallback and the restarts; success is still judged
//! from the measured error alone. One iterative attempt could not reach another IK branch (the KR5 and Puma
//! converging to a branch outside the limits) or stalled at the stretched elbow (UR5, TianSui); one attempt on
//! random reachable targets (benchmarks/bench_kinematics.py --ik-one-attempt), Newton / LM: KR5 92.2 / 65.8 ->
//! 100 / 100 %, UR5 91.6 / 91.4 -> 100 / 100 %, Puma 560 81.8 / 82.4 -> 100 / 100 %, TianSui 87.0 / 90.2 ->
//! 100 / 100 %. Other chains (7 joints, prismatic joints, other geometries) are solved as before.
//!
//! **Restarts** are deterministic: attempt 0 starts from `q0`, attempt k >= 1 from a configuration drawn
//! uniformly within the limits (intersected with [-π, π] for revolute and [-1, 1] m for prismatic joints)
//! by a SplitMix64 generator seeded from `seed`, k and the target's index in a batch or path (0 for a single
//! solve, so a single solve and a batch or path of that one target give the same answer).
//!
//! **Cost.** An [`IkSolver`] allocates its workspace once; an iteration allocates nothing: one pass of
//! forward kinematics and Jacobian, and for n = 6 fixed-size, fully unrolled 6 x 6 solves (Cholesky for LM,
//! LU with partial pivoting for Newton); other n use the same algorithms on preallocated buffers. The workspace
//! is allocated at the first iteration: a solve met by an exact closed-form seed (the closed form of its
//! branches near `q0`, their ranking and one forward kinematics: about 7 k instructions on the KR5) allocates only its
//! result.
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

use crate::error::{Error, Result, check_finite, check_finite_rows, check_len};
use crate::kinematics::{tool_pose_and_jacobian, tool_pose_unchecked};
use crate::model::{JointKind, Model};
use crate::spatial::{Pose, check_pose, pose_error, rotation_angle};
use nalgebra::{DMatrix, DVectorViewMut, Matrix3, Matrix6, Rotation3, Vector3, Vector6};
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

mod closed_form;
pub use closed_form::Structure;
use closed_form::{ClosedForm, Cs, MAX_BRANCHES, MAX_PARTIALS, Partial};

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
/// converge in tens), and a budget that still ends (an unreachable target of a 6R arm, 1 us an iteration).
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
    /// Largest accepted distance between the tool origin and the target position (m).
    pub tol_position: f64,
    /// Largest accepted rotation angle between the tool and the target orientation (rad).
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
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            return Err(Error::InvalidArgument {
                what: "max_iterations".into(),
                expected: format!("1..={MAX_ITERATIONS} (per attempt)"),
                got: self.max_iterations.to_string(),
            });
        }
        if self.restarts > MAX_RESTARTS {
            return Err(Error::InvalidArgument { what: "restarts".into(), expected: format!("0..={MAX_RESTARTS}"), got: self.restarts.to_string() });
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
    /// `|p_tool(q) - p_target|` (m).
    pub position_error: f64,
    /// Rotation angle between `R_tool(q)` and `R_target` (rad).
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

/// SO(3) logarithm: the rotation vector (unit axis × angle in [0, π]) of a rotation matrix.
///
/// ```
/// use denavit_core::ik::log_rotation;
/// use nalgebra::{Rotation3, Vector3};
/// let w = Vector3::new(0.1, -0.2, 0.3);
/// assert!((log_rotation(Rotation3::new(w).matrix()) - w).norm() < 1e-15);
/// ```
pub fn log_rotation(r: &Matrix3<f64>) -> Vector3<f64> {
    log_with_angle(r, rotation_angle(&Rotation3::from_matrix_unchecked(*r)))
}

/// [`log_rotation`] given the angle `theta` of `r` (as computed by [`rotation_angle`]).
#[inline]
fn log_with_angle(r: &Matrix3<f64>, theta: f64) -> Vector3<f64> {
    let v = Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]); // 2 sin(t) axis
    let s = v.norm() / 2.0;
    let c = (r.trace() - 1.0) / 2.0;
    if c >= 0.0 || s > 1e-3 {
        if s == 0.0 {
            return Vector3::zeros();
        }
        return v * (theta / (2.0 * s));
    }
    // near pi: the axis from the symmetric part (R + R^T)/2 = c I + (1 - c) a a^T
    let d = [r[(0, 0)], r[(1, 1)], r[(2, 2)]];
    let i = if d[0] >= d[1] && d[0] >= d[2] {
        0
    } else if d[1] >= d[2] {
        1
    } else {
        2
    };
    let ai = ((d[i] - c) / (1.0 - c)).max(0.0).sqrt();
    let mut a = Vector3::zeros();
    for j in 0..3 {
        a[j] = if j == i { ai } else { (r[(i, j)] + r[(j, i)]) / (2.0 * (1.0 - c) * ai) };
    }
    let a = a.normalize();
    if a.dot(&v) < 0.0 { -a * theta } else { a * theta }
}

/// SplitMix64 (Steele, Lea & Flood 2014): a small deterministic generator for restarts.
#[derive(Debug, Clone)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Seed of target `index` of a batch or path.
pub(crate) fn mix_seed(seed: u64, index: u64) -> u64 {
    SplitMix64(seed ^ index.wrapping_mul(0xD1B5_4A32_D192_ED03)).next_u64()
}

/// Per-joint data used by the projection and the restarts, and the model's wrist flips; derived from the
/// joints once per model ([`Model::ik_bounds`]).
#[derive(Debug, Clone)]
pub(crate) struct Bounds {
    lower: Vec<f64>,
    upper: Vec<f64>,
    revolute: Vec<bool>,
    offset: Vec<f64>,
    sample_lo: Vec<f64>,
    sample_hi: Vec<f64>,
    /// The first joints of the wrist flips ([`wrist_flips`]).
    flips: Vec<usize>,
    /// The closed form of a recognised 6R structure (the seeds of the first attempt).
    closed_form: Option<ClosedForm>,
}

impl Bounds {
    pub(crate) fn new(model: &Model) -> Self {
        let n = model.nq();
        let mut b = Self {
            lower: Vec::with_capacity(n),
            upper: Vec::with_capacity(n),
            revolute: Vec::with_capacity(n),
            offset: Vec::with_capacity(n),
            sample_lo: Vec::with_capacity(n),
            sample_hi: Vec::with_capacity(n),
            flips: wrist_flips(model),
            closed_form: ClosedForm::new(model),
        };
        for j in model.joints() {
            let (lo, hi, rev) = (j.lower, j.upper, j.kind == JointKind::Revolute);
            let w = if rev { PI } else { 1.0 };
            let (a, bb) = (lo.max(-w), hi.min(w));
            let (a, bb) = if a <= bb {
                (a, bb)
            } else if lo > w {
                (lo, hi.min(lo + 2.0 * w))
            } else {
                (lo.max(hi - 2.0 * w), hi)
            };
            b.lower.push(lo);
            b.upper.push(hi);
            b.revolute.push(rev);
            b.offset.push(j.offset);
            b.sample_lo.push(a);
            b.sample_hi.push(bb);
        }
        b
    }

    #[inline]
    fn fits(&self, i: usize, v: f64) -> bool {
        v >= self.lower[i] && v <= self.upper[i]
    }

    /// `v`, or `v` shifted by a multiple of 2π into the range of revolute joint `i` when that exists.
    #[inline]
    fn wrap(&self, i: usize, v: f64) -> f64 {
        if self.fits(i, v) || !self.revolute[i] || !self.lower[i].is_finite() {
            return v;
        }
        let shifted = v - TAU * ((v - self.lower[i]) / TAU).floor();
        if self.fits(i, shifted) { shifted } else { v }
    }

    /// Project `q` into the limits, first by moves that keep the tool pose: a revolute joint outside its range
    /// is shifted by a multiple of 2π when that brings it in; a wrist ([`wrist_flips`]) with a joint still
    /// outside is flipped when the flipped wrist is within its limits. What is still outside is clamped,
    /// after `reflect` has mirrored it at the limit it crossed (`2 upper - q`, `2 lower - q`, as in reflective
    /// Newton methods for bounds: Coleman & Li 1996).
    #[inline]
    fn project(&self, q: &mut [f64], reflect: bool) {
        let mut inside = true;
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = self.wrap(i, *qi);
            inside &= self.fits(i, *qi);
        }
        if inside {
            return;
        }
        for &i in &self.flips {
            if (i..i + 3).all(|k| self.fits(k, q[k])) {
                continue;
            }
            let f = [self.wrap(i, q[i] + PI), self.wrap(i + 1, -q[i + 1] - 2.0 * self.offset[i + 1]), self.wrap(i + 2, q[i + 2] + PI)];
            if (0..3).all(|k| self.fits(i + k, f[k])) {
                q[i..i + 3].copy_from_slice(&f);
            }
        }
        for (i, qi) in q.iter_mut().enumerate() {
            let (lo, hi) = (self.lower[i], self.upper[i]);
            if self.fits(i, *qi) {
                continue;
            }
            if reflect {
                *qi = if *qi > hi { 2.0 * hi - *qi } else { 2.0 * lo - *qi };
            }
            *qi = qi.clamp(lo, hi);
        }
    }

    /// Place angle `v` of revolute joint `i` near `q0_i`: shifted by the multiple of 2π nearest to `q0_i` and,
    /// when `respect_limits`, then by ±2π if that brings it within its range; `None` if it is still outside
    /// (with `respect_limits`).
    #[inline]
    fn place_joint(&self, i: usize, v: f64, q0_i: f64, respect_limits: bool) -> Option<f64> {
        let d = v - q0_i;
        let v = q0_i + (d - TAU * (d / TAU).round()); // the nearest to q0_i (fmod is slow)
        if !respect_limits || self.fits(i, v) {
            return Some(v);
        }
        // the other side of q0 first (the nearer of v ± 2π to q0)
        let (a, b) = if v > q0_i { (v - TAU, v + TAU) } else { (v + TAU, v - TAU) };
        [a, b].into_iter().find(|&x| self.fits(i, x))
    }

    fn within(&self, q: &[f64]) -> bool {
        q.iter().enumerate().all(|(i, &v)| v >= self.lower[i] && v <= self.upper[i])
    }

    fn sample(&self, rng: &mut SplitMix64, q: &mut [f64]) {
        for (i, qi) in q.iter_mut().enumerate() {
            *qi = self.sample_lo[i] + (self.sample_hi[i] - self.sample_lo[i]) * rng.uniform();
        }
    }
}

/// The wrists of `model`: the joints `i` such that revolute joints `i, i+1, i+2` reach every pose of theirs twice,
/// `θ_i + π, -θ_(i+1), θ_(i+2) + π` (θ = q + offset) giving the tool pose of `θ_i, θ_(i+1), θ_(i+2)`: a spherical
/// wrist (three axes through one point, the middle one perpendicular to the others; Paul 1981, ch. 3, the
/// "flip" of the wrist). Found numerically: the flip moves the tool by less than 1e-12 (m and rad, relative to
/// the chain's size) at two pseudo-random configurations (an identity of the chain holds at every configuration;
/// a chain without it fails at almost every one).
fn wrist_flips(model: &Model) -> Vec<usize> {
    let n = model.nq();
    let joints = model.joints();
    let size = 1.0 + joints.iter().map(|j| j.placement.translation.vector.norm()).sum::<f64>() + model.t_last_tool().translation.vector.norm();
    let mut rng = SplitMix64(0x5EED_F11B);
    let mut q = vec![0.0; n];
    (0..n.saturating_sub(2))
        .filter(|&i| {
            joints[i..i + 3].iter().all(|j| j.kind == JointKind::Revolute)
                && (0..2).all(|_| {
                    for v in q.iter_mut() {
                        *v = PI * (2.0 * rng.uniform() - 1.0);
                    }
                    let before = tool_pose_unchecked(model, &q);
                    q[i] += PI;
                    q[i + 1] = -q[i + 1] - 2.0 * joints[i + 1].offset;
                    q[i + 2] += PI;
                    let (dp, dr) = pose_error(&tool_pose_unchecked(model, &q), &before);
                    dp <= 1e-12 * size && dr <= 1e-12
                })
        })
        .collect()
}

/// Error twist and measured errors of a current pose against the target.
#[inline]
fn twist(cur: &Pose, target: &Pose, e: &mut [f64; 6]) -> (f64, f64) {
    let dp = target.translation.vector - cur.translation.vector;
    let rel: Rotation3<f64> = cur.rotation.inverse() * target.rotation; // as in spatial::pose_error
    let theta = rotation_angle(&rel);
    let w = cur.rotation * log_with_angle(rel.matrix(), theta);
    e[..3].copy_from_slice(dp.as_slice());
    e[3..].copy_from_slice(w.as_slice());
    ((cur.translation.vector - target.translation.vector).norm(), theta)
}

/// Solve `a x = b` in place by nalgebra's Cholesky factorisation, `a` (n x n, symmetric positive definite,
/// so either storage order) taken from the workspace `work` without a copy and handed back; false if `a` is
/// not positive definite (the workspace is then reallocated: the rare, rejected step).
#[inline(always)]
fn cholesky_solve(work: &mut Vec<f64>, b: &mut [f64], n: usize) -> bool {
    let mut v = std::mem::take(work);
    let len = v.len();
    v.truncate(n * n);
    let Some(c) = DMatrix::from_vec(n, n, v).cholesky() else {
        *work = vec![0.0; len];
        return false;
    };
    c.solve_mut(&mut DVectorViewMut::from_slice(&mut b[..n], n));
    *work = c.unpack_dirty().data.into();
    work.resize(len, 0.0);
    true
}

/// `A = J^T J + lambda I` (n x n, row-major) and `g = J^T e`; `jac` is column-major 6 x n.
#[inline(always)]
fn normal_equations(jac: &[f64], e: &[f64; 6], lambda: f64, a: &mut [f64], g: &mut [f64], n: usize) {
    for i in 0..n {
        let ci = &jac[6 * i..6 * i + 6];
        g[i] = ci.iter().zip(e).map(|(x, y)| x * y).sum();
        for k in 0..=i {
            let ck = &jac[6 * k..6 * k + 6];
            let v: f64 = ci.iter().zip(ck).map(|(x, y)| x * y).sum();
            a[i * n + k] = v;
            a[k * n + i] = v;
        }
        a[i * n + i] += lambda;
    }
}

/// The damped Gauss-Newton step for a 6-joint chain: `(J^T J + lambda I) x = J^T e` by nalgebra's Cholesky
/// on the stack (`jac` column-major 6 x 6); false if the matrix is not positive definite.
#[inline(always)]
fn lm_step6(jac: &[f64], e: &[f64; 6], lambda: f64, x: &mut [f64]) -> bool {
    let j = Matrix6::from_column_slice(jac);
    let mut a = j.tr_mul(&j);
    for i in 0..6 {
        a[(i, i)] += lambda;
    }
    let Some(c) = a.cholesky() else { return false };
    let mut g = j.tr_mul(&Vector6::from(*e));
    c.solve_mut(&mut g);
    x[..6].copy_from_slice(g.as_slice());
    true
}

/// Solve `J x = e` for a square 6 x 6 `J` (`jac` column-major) by Gaussian elimination with partial pivoting
/// (LU with row interchanges, Golub & Van Loan 2013, Algorithm 3.4.1, on the stack, fully unrolled: a third
/// of the time of nalgebra's generic LU here); false if a pivot is below 1e-13 times the largest entry of
/// `J` (numerically singular) or not finite.
#[inline(always)]
fn newton_step6(jac: &[f64], e: &[f64; 6], x: &mut [f64]) -> bool {
    let mut a = [[0.0; 6]; 6]; // rows
    let mut scale: f64 = 0.0;
    for c in 0..6 {
        for r in 0..6 {
            let v = jac[6 * c + r];
            a[r][c] = v;
            scale = scale.max(v.abs());
        }
    }
    let tiny = 1e-13 * scale;
    let mut b = *e;
    for k in 0..6 {
        let mut p = k;
        for r in k + 1..6 {
            if a[r][k].abs() > a[p][k].abs() {
                p = r;
            }
        }
        let pivot = a[p][k].abs();
        if pivot.is_nan() || pivot <= tiny {
            return false;
        }
        if p != k {
            a.swap(k, p);
            b.swap(k, p);
        }
        let inv = 1.0 / a[k][k];
        for r in k + 1..6 {
            let f = a[r][k] * inv;
            for c in k + 1..6 {
                a[r][c] -= f * a[k][c];
            }
            b[r] -= f * b[k];
        }
    }
    for k in (0..6).rev() {
        let mut v = b[k];
        for c in k + 1..6 {
            v -= a[k][c] * x[c];
        }
        x[k] = v / a[k][k];
    }
    x[..6].iter().all(|v| v.is_finite())
}

/// Iterations after which an LM attempt must have halved its squared error, else it gives way to the next
/// restart (never in the last attempt, which uses its whole budget).
const STALL_EVERY: usize = 10;

/// Newton steps without a new best error after which an attempt gives way to the next restart (never in the
/// last attempt).
const STALL_NEWTON: usize = 8;

/// A closed-form seed that meets the tolerance as it is: the configuration and its measured position and
/// rotation errors.
type MetSeed = ([f64; 6], f64, f64);

/// Jacobian evaluations of the Newton polish of one closed-form seed (within attempt 0's `max_iterations`): an
/// exact seed needs none (it is met as it is, checked by forward kinematics), a seed of an identified robot (axes
/// 0.5 mm / 0.5 mrad off the ideal structure) 3 (the median).
const POLISH: usize = 10;

/// Step lengths 1, 1/2, 1/4 tried by Newton's backtracking.
const BACKTRACK: usize = 3;

/// How far from success a measured error is (< = 1 means within the tolerance).
#[inline]
fn score(pos: f64, rot: f64, o: &IkOptions) -> f64 {
    (pos / o.tol_position.max(1e-300)).max(rot / o.tol_rotation.max(1e-300))
}

/// A reusable IK workspace for one model (no allocation in the iterations).
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose, ik::{IkSolver, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let target = tool_pose(&m, &[0.4, 0.9]).unwrap();
/// // a planar arm cannot meet an arbitrary orientation, but this target is reachable
/// let mut s = IkSolver::new(&m, IkOptions::default()).unwrap();
/// let r = s.solve(&target, &[0.0, 0.5]).unwrap();
/// assert!(r.success && r.position_error <= 1e-10 && r.rotation_error <= 1e-10);
/// ```
#[derive(Debug, Clone)]
pub struct IkSolver<'m> {
    model: &'m Model,
    opts: IkOptions,
    bounds: &'m Bounds,
    /// Whether the workspace below is allocated ([`Self::workspace`]).
    ready: bool,
    jac_eval: Vec<f64>,
    q: Vec<f64>,
    q_trial: Vec<f64>,
    q_best: Vec<f64>,
    q_cur: Vec<f64>,
    q_jump: Vec<f64>,
    jac: Vec<f64>,
    jac_jump: Vec<f64>,
    a: Vec<f64>,
    g: Vec<f64>,
}

impl<'m> IkSolver<'m> {
    /// A workspace for `model` with checked options.
    pub fn new(model: &'m Model, opts: IkOptions) -> Result<Self> {
        opts.check()?;
        Ok(Self {
            model,
            opts,
            bounds: model.ik_bounds(),
            ready: false,
            jac_eval: Vec::new(),
            q: Vec::new(),
            q_trial: Vec::new(),
            q_best: Vec::new(),
            q_cur: Vec::new(),
            q_jump: Vec::new(),
            jac: Vec::new(),
            jac_jump: Vec::new(),
            a: Vec::new(),
            g: Vec::new(),
        })
    }

    /// Allocate the iterations' workspace on first use (a single solve met by an exact closed-form seed needs
    /// none: ten allocations were a third of its time).
    #[inline]
    fn workspace(&mut self) {
        if self.ready {
            return;
        }
        let n = self.model.nq();
        let m = n.max(6);
        for v in [&mut self.q, &mut self.q_trial, &mut self.q_best, &mut self.q_cur, &mut self.q_jump] {
            *v = vec![0.0; n];
        }
        for v in [&mut self.jac_eval, &mut self.jac, &mut self.jac_jump] {
            *v = vec![0.0; 6 * n];
        }
        self.a = vec![0.0; m * m];
        self.g = vec![0.0; m];
        self.ready = true;
    }

    /// The options in use.
    pub fn options(&self) -> &IkOptions {
        &self.opts
    }

    /// Solve for `target` (`T_world_tool`) from `q0`; `Err` only for bad input (size, NaN, non-SE(3)).
    pub fn solve(&mut self, target: &Pose, q0: &[f64]) -> Result<IkResult> {
        check_pose("IK target", target)?;
        self.model.check_q(q0).map_err(|e| rename(e, "q0"))?;
        let r = self.solve_unchecked(target, q0, mix_seed(self.opts.seed, 0));
        crate::parallel::check_interrupt()?;
        Ok(r)
    }

    /// Jacobian and error at `q`.
    #[inline]
    fn evaluate(&mut self, which_trial: bool, target: &Pose, e: &mut [f64; 6]) -> (f64, f64) {
        let q = if which_trial { &self.q_trial } else { &self.q };
        let tool = tool_pose_and_jacobian(self.model, q, &mut self.jac_eval);
        twist(&tool, target, e)
    }

    /// One attempt from `self.q`; leaves the attempt's best configuration in `self.q`.
    /// `last`: no attempt follows, so this one uses its whole iteration budget (a stalled attempt is
    /// abandoned early only when a restart can take over).
    /// `budget`: the Jacobian evaluations it may use (`max_iterations`, less what the seeds used in attempt 0).
    fn attempt(&mut self, target: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        match self.opts.method {
            IkMethod::Lm => self.attempt_lm(target, last, budget),
            IkMethod::Newton => self.attempt_newton(target, last, budget),
        }
    }

    fn attempt_lm(&mut self, target: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        let n = self.model.nq();
        let mut e = [0.0; 6];
        let (mut pos, mut rot) = self.evaluate(false, target, &mut e);
        let mut it = 1;
        if score(pos, rot, &self.opts) <= 1.0 || n == 0 {
            return (it, pos, rot);
        }
        self.jac.copy_from_slice(&self.jac_eval);
        let mut cost: f64 = e.iter().map(|v| v * v).sum();
        // damping lambda = mu |e|^2 (Fan & Yuan 2005: quadratic convergence to a zero residual), mu updated by
        // the gain ratio rho = (F(q) - F(q + h)) / (L(0) - L(h)) of the actual to the predicted decrease
        // (Nielsen 1999; Madsen, Nielsen & Tingleff 2004, eq. 3.15 and Algorithm 3.16): accepted (rho > 0):
        // mu *= max(1/3, 1 - (2 rho - 1)^3), nu = 2; rejected: mu *= nu, nu *= 2.
        let mut mu = self.opts.damping;
        let mut nu = 2.0;
        let mut checkpoint = cost;
        let mut jte = vec![0.0; n]; // J^T e (n <= 6 stays on the stack in practice: a small allocation per attempt)
        // (an interrupt ends the attempt: the caller reports Error::Interrupted)
        while it < budget && !crate::parallel::interrupted() {
            if !last && it % STALL_EVERY == 0 {
                // a local minimum or a crawl: leave it to the next restart
                if cost > 0.5 * checkpoint {
                    break;
                }
                checkpoint = cost;
            }
            for (i, c) in self.jac.chunks_exact(6).enumerate() {
                jte[i] = c.iter().zip(&e).map(|(x, y)| x * y).sum();
            }
            let lambda = (mu * cost).max(f64::MIN_POSITIVE);
            let mut ok = self.lm_solve(&e, lambda);
            if ok && self.blocked_by_limits() {
                // joints held at a limit that the step pushes outwards: solve again without them
                self.without_blocked(|s| ok = s.lm_solve(&e, lambda));
            }
            if !ok {
                mu *= nu;
                nu *= 2.0;
                if !(mu * cost).is_finite() || mu * cost > 1e30 {
                    break;
                }
                continue;
            }
            for i in 0..n {
                self.q_trial[i] = self.q[i] + self.g[i];
            }
            if self.opts.respect_limits {
                self.bounds.project(&mut self.q_trial, false);
            }
            let mut et = [0.0; 6];
            let (p, r) = self.evaluate(true, target, &mut et);
            it += 1;
            let cost_t: f64 = et.iter().map(|v| v * v).sum();
            // predicted decrease of |e|^2: 2 L(0) - 2 L(h) = h^T (lambda h + J^T e)
            let predicted: f64 = (0..n).map(|i| self.g[i] * (lambda * self.g[i] + jte[i])).sum();
            if cost_t < cost {
                let rho = (cost - cost_t) / predicted.max(f64::MIN_POSITIVE);
                std::mem::swap(&mut self.q, &mut self.q_trial);
                self.jac.copy_from_slice(&self.jac_eval);
                (e, cost, pos, rot) = (et, cost_t, p, r);
                if score(pos, rot, &self.opts) <= 1.0 {
                    break;
                }
                mu = (mu * (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0)).max(1e-12);
                nu = 2.0;
            } else {
                mu *= nu;
                nu *= 2.0;
                if !(mu * cost).is_finite() || mu * cost > 1e30 {
                    break;
                }
            }
        }
        (it, pos, rot)
    }

    /// The damped step `(J^T J + lambda I) g = J^T e` into `self.g[..n]` from `self.jac`.
    fn lm_solve(&mut self, e: &[f64; 6], lambda: f64) -> bool {
        let n = self.model.nq();
        if n == 6 {
            lm_step6(&self.jac, e, lambda, &mut self.g)
        } else {
            normal_equations(&self.jac, e, lambda, &mut self.a[..n * n], &mut self.g[..n], n);
            cholesky_solve(&mut self.a, &mut self.g, n)
        }
    }

    /// Whether joint `i` sits at a limit (where the projection clamped it) and the LM step `self.g` pushes it
    /// further out.
    #[inline]
    fn blocked(&self, i: usize) -> bool {
        let (q, b) = (&self.q, &self.bounds);
        (q[i] <= b.lower[i] && self.g[i] < 0.0) || (q[i] >= b.upper[i] && self.g[i] > 0.0)
    }

    /// Whether any joint is [`Self::blocked`] (only when limits are respected).
    fn blocked_by_limits(&self) -> bool {
        self.opts.respect_limits && (0..self.model.nq()).any(|i| self.blocked(i))
    }

    /// Recompute the LM step with `solve` on the Jacobian whose columns of the blocked joints are zero (an
    /// active set, as in projected Newton methods for bound constraints: Bertsekas 1982), then hold those
    /// joints: the other joints do the work instead of a step the projection would cancel. (Tried for
    /// Newton too: it lowered the 7-joint success rate, so Newton keeps the plain projection.)
    fn without_blocked(&mut self, solve: impl FnOnce(&mut Self)) {
        let n = self.model.nq();
        let blocked: Vec<bool> = (0..n).map(|i| self.blocked(i)).collect();
        self.jac_jump.copy_from_slice(&self.jac);
        for (i, c) in self.jac.chunks_exact_mut(6).enumerate() {
            if blocked[i] {
                c.fill(0.0);
            }
        }
        solve(self);
        std::mem::swap(&mut self.jac, &mut self.jac_jump);
        for i in 0..n {
            if blocked[i] {
                self.g[i] = 0.0;
            }
        }
    }

    /// The Newton step into `self.g[..n]` from the last evaluated Jacobian and `e`.
    fn newton_step(&mut self, e: &[f64; 6]) {
        let n = self.model.nq();
        let jac = &self.jac[..]; // column-major 6 x n, at the current iterate
        let solved = if n == 6 {
            newton_step6(jac, e, &mut self.g)
        } else if n < 6 {
            normal_equations(jac, e, 0.0, &mut self.a[..n * n], &mut self.g[..n], n);
            cholesky_solve(&mut self.a, &mut self.g, n)
        } else {
            // minimum-norm step: dq = J^T y, (J J^T) y = e
            let a = &mut self.a[..36];
            for r in 0..6 {
                for c in 0..=r {
                    let v: f64 = (0..n).map(|k| jac[6 * k + r] * jac[6 * k + c]).sum();
                    a[r * 6 + c] = v;
                    a[c * 6 + r] = v;
                }
            }
            let mut y = *e;
            let ok = cholesky_solve(&mut self.a, &mut y, 6);
            for k in 0..n {
                self.g[k] = (0..6).map(|r| jac[6 * k + r] * y[r]).sum();
            }
            ok
        };
        if !solved {
            // singular: a slightly damped least-squares step
            let lambda = 1e-8 * (1.0 + jac.iter().map(|v| v * v).sum::<f64>());
            normal_equations(jac, e, lambda, &mut self.a[..n * n], &mut self.g[..n], n);
            if !cholesky_solve(&mut self.a, &mut self.g, n) {
                self.g[..n].fill(0.0);
            }
        }
    }

    fn attempt_newton(&mut self, target: &Pose, last: bool, budget: usize) -> (usize, f64, f64) {
        let n = self.model.nq();
        let mut e = [0.0; 6];
        let (mut pos, mut rot) = self.evaluate(false, target, &mut e);
        let mut it = 1;
        let mut best = (score(pos, rot, &self.opts), pos, rot);
        if best.0 <= 1.0 || n == 0 {
            return (it, pos, rot);
        }
        // the iterate (q_cur, its Jacobian in jac, its error e); self.q keeps the attempt's best configuration
        self.jac.copy_from_slice(&self.jac_eval);
        self.q_cur.copy_from_slice(&self.q);
        let mut cost: f64 = e.iter().map(|v| v * v).sum();
        let mut stalled = 0;
        'attempt: while it < budget && !crate::parallel::interrupted() {
            self.newton_step(&e);
            // backtracking on |e|^2 (Nocedal & Wright 2006, Algorithm 3.1, halving): steps 1, 1/2, 1/4; when
            // none lowers the error the full step is taken anyway (Newton's jump out of a basin)
            let mut alpha = 1.0;
            let mut moved = false;
            let mut jump = None;
            for k in 0..BACKTRACK {
                for i in 0..n {
                    self.q_trial[i] = self.q_cur[i] + alpha * self.g[i];
                }
                if self.opts.respect_limits {
                    self.bounds.project(&mut self.q_trial, true);
                }
                if self.q_trial.iter().any(|v| !v.is_finite()) {
                    break 'attempt;
                }
                let mut et = [0.0; 6];
                let (p, r) = self.evaluate(true, target, &mut et);
                it += 1;
                let cost_t: f64 = et.iter().map(|v| v * v).sum();
                if cost_t < cost {
                    std::mem::swap(&mut self.q_cur, &mut self.q_trial);
                    self.jac.copy_from_slice(&self.jac_eval);
                    (e, cost, pos, rot) = (et, cost_t, p, r);
                    moved = true;
                    break;
                }
                if k == 0 {
                    self.q_jump.copy_from_slice(&self.q_trial);
                    self.jac_jump.copy_from_slice(&self.jac_eval);
                    jump = Some((et, cost_t, p, r));
                }
                if it >= budget {
                    break;
                }
                alpha *= 0.5;
            }
            if !moved {
                let Some(j) = jump else { break };
                std::mem::swap(&mut self.q_cur, &mut self.q_jump);
                std::mem::swap(&mut self.jac, &mut self.jac_jump);
                (e, cost, pos, rot) = j;
            }
            let s = score(pos, rot, &self.opts);
            if s < best.0 {
                best = (s, pos, rot);
                self.q.copy_from_slice(&self.q_cur);
                stalled = 0;
                if s <= 1.0 {
                    break;
                }
            } else {
                stalled += 1;
                if !last && stalled >= STALL_NEWTON {
                    break;
                }
            }
        }
        (it, best.1, best.2)
    }

    /// The closed-form seeds of a recognised structure ([`Structure`]): the branches placed near `q0` (each
    /// joint by [`Bounds::place_joint`]; those outside the limits dropped when `respect_limits`), nearest to
    /// `q0` first, each checked by FK and, if not within the tolerance as it is, polished by a Newton attempt on
    /// the model, until one meets the tolerance. Returns the Jacobian evaluations, the best score (its
    /// configuration in `self.q_best`) and, for a seed met as it is, its measured errors; `None` without a
    /// closed form.
    ///
    /// The order is found best-first on the closed form's two levels ([`ClosedForm::levels`]): a first level
    /// (three joints) is completed to its branches only when its own distance from `q0`, a lower bound of its
    /// branches', is below that of every branch found so far, so the branches of arms far from `q0` are not
    /// computed. Distances come from the angles to 3e-7 rad ([`closed_form::Cs::angle_approx`]: `atan2` costs
    /// about as much as the closed form of a branch); a branch is tried with its exact angles.
    fn attempt_seeds(&mut self, target: &Pose, q0: &[f64]) -> Option<(usize, f64, Option<MetSeed>)> {
        let bounds: &'m Bounds = self.bounds;
        let cf = bounds.closed_form.as_ref()?;
        let respect = self.opts.respect_limits;
        let (first, second) = cf.levels();
        // the first levels within the limits, by their distance from q0
        let mut parts = [Partial::EMPTY; MAX_PARTIALS];
        let np = cf.partials(target, q0, &mut parts);
        let mut part_order = [(0.0f64, 0); MAX_PARTIALS];
        let mut kept = 0;
        'parts: for (k, part) in parts[..np].iter().enumerate() {
            let mut d = 0.0;
            for &i in &first {
                let Some(v) = bounds.place_joint(i, part.q[i].angle_approx(), q0[i], respect) else { continue 'parts };
                d += (v - q0[i]) * (v - q0[i]);
            }
            if !d.is_finite() {
                continue;
            }
            let mut j = kept;
            while j > 0 && part_order[j - 1].0 > d {
                part_order[j] = part_order[j - 1];
                j -= 1;
            }
            part_order[j] = (d, k);
            kept += 1;
        }
        // the branches found, their distances, and whether tried
        let mut found = [(0.0f64, [Cs::ZERO; 6], false); MAX_BRANCHES];
        let (mut nf, mut next) = (0, 0);
        let mut total = 0;
        let mut best = f64::INFINITY;
        loop {
            let nearest = (0..nf).filter(|&c| !found[c].2).min_by(|&a, &b| found[a].0.total_cmp(&found[b].0));
            if next < kept && nearest.is_none_or(|c| part_order[next].0 < found[c].0) {
                // a first level that may hold a nearer branch: complete it
                let (pd, k) = part_order[next];
                next += 1;
                let mut leaves = [[Cs::ZERO; 6]; 2];
                let nl = cf.complete(&parts[k], q0, &mut leaves);
                'leaves: for leaf in &leaves[..nl] {
                    let mut d = pd;
                    for &i in &second {
                        let Some(v) = bounds.place_joint(i, leaf[i].angle_approx(), q0[i], respect) else { continue 'leaves };
                        d += (v - q0[i]) * (v - q0[i]);
                    }
                    if d.is_finite() {
                        found[nf] = (d, *leaf, false);
                        nf += 1;
                    }
                }
                continue;
            }
            let Some(c) = nearest else { break };
            found[c].2 = true;
            let budget = POLISH.min(self.opts.max_iterations - total);
            if budget == 0 {
                break;
            }
            // the exact angles, placed again (a joint at a limit may fall outside by them)
            let mut q = [0.0; 6];
            let mut placed = true;
            for i in 0..6 {
                match bounds.place_joint(i, found[c].1[i].angle(), q0[i], respect) {
                    Some(v) => q[i] = v,
                    None => placed = false,
                }
            }
            if !placed {
                continue;
            }
            // an exact seed is checked by the verdict's own measurement (forward kinematics alone, counted as one
            // evaluation), which then stands as the verdict
            let (pos, rot) = pose_error(&tool_pose_unchecked(self.model, &q), target);
            if score(pos, rot, &self.opts) <= 1.0 {
                return Some((total + 1, 1.0, Some((q, pos, rot))));
            }
            self.workspace();
            self.q.copy_from_slice(&q);
            let (it, pos, rot) = self.attempt_newton(target, false, budget);
            total += it;
            let s = score(pos, rot, &self.opts);
            if s < best {
                best = s;
                self.q_best.copy_from_slice(&self.q);
                if s <= 1.0 {
                    break;
                }
            }
        }
        Some((total, best, None))
    }

    /// Solve without checking the input; `seed` drives the restarts.
    pub(crate) fn solve_unchecked(&mut self, target: &Pose, q0: &[f64], seed: u64) -> IkResult {
        let n = self.model.nq();
        let mut total = 0;
        let mut best_score = f64::INFINITY;
        let mut restarts = 0;
        let mut seeded = false;
        if let Some((it, s, exact)) = self.attempt_seeds(target, q0) {
            if let Some((q, position_error, rotation_error)) = exact {
                // met by a seed as it is (within the limits by construction): its measurement is the verdict
                let within = !self.opts.respect_limits || self.bounds.within(&q);
                let success = position_error <= self.opts.tol_position && rotation_error <= self.opts.tol_rotation && within;
                return IkResult { q: q.to_vec(), success, iterations: it, restarts: 0, position_error, rotation_error };
            }
            (total, best_score, seeded) = (it, s, s.is_finite());
        }
        self.workspace();
        for attempt in 0..=self.opts.restarts {
            if best_score <= 1.0 || crate::parallel::interrupted() {
                break;
            }
            if attempt == 0 {
                self.q.copy_from_slice(q0);
            } else {
                let mut rng = SplitMix64(mix_seed(seed, attempt as u64));
                self.bounds.sample(&mut rng, &mut self.q);
            }
            if self.opts.respect_limits {
                self.bounds.project(&mut self.q, false);
            }
            let budget = if attempt == 0 { self.opts.max_iterations - total } else { self.opts.max_iterations };
            if budget == 0 {
                continue; // the seeds used attempt 0's budget
            }
            let (it, pos, rot) = self.attempt(target, attempt == self.opts.restarts, budget);
            total += it;
            restarts = attempt;
            let s = score(pos, rot, &self.opts);
            if s < best_score || (attempt == 0 && !seeded) {
                best_score = s;
                self.q_best.copy_from_slice(&self.q);
            }
            if s <= 1.0 {
                break;
            }
        }
        // the honest verdict: measure the returned configuration with the public FK and error functions
        let q = self.q_best[..n].to_vec();
        let (position_error, rotation_error) = pose_error(&tool_pose_unchecked(self.model, &q), target);
        let within = !self.opts.respect_limits || self.bounds.within(&q);
        let success = position_error <= self.opts.tol_position && rotation_error <= self.opts.tol_rotation && within;
        IkResult { q, success, iterations: total, restarts, position_error, rotation_error }
    }
}

/// Name an argument in a size / finiteness error of `q`.
fn rename(e: Error, what: &str) -> Error {
    match e {
        Error::SizeMismatch { expected, got, .. } => Error::SizeMismatch { what: what.into(), expected, got },
        Error::NonFinite { index, value, .. } => Error::NonFinite { what: what.into(), index, value },
        other => other,
    }
}

/// Inverse kinematics of one target `T_world_tool` from `q0` (rad / m); see the module docs for the
/// error, the methods and the success rule. `Err` only for bad input; an unreachable target gives
/// `Ok` with `success == false` and the measured residual.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose, ik::{ik, IkOptions}, spatial::trans};
/// let m = builtin_planar2(1.0, 1.0);
/// let r = ik(&m, &tool_pose(&m, &[0.3, 1.2]).unwrap(), &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(r.success && r.position_error <= 1e-10);
/// let far = ik(&m, &trans(3.0, 0.0, 0.0), &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(!far.success && (far.position_error - 1.0).abs() < 1e-6); // 3 m away, reach 2 m
/// ```
pub fn ik(model: &Model, target: &Pose, q0: &[f64], opts: &IkOptions) -> Result<IkResult> {
    IkSolver::new(model, opts.clone())?.solve(target, q0)
}

/// The structure of `model` that IK solves in closed form for the seeds of its first attempt (module docs,
/// "Closed-form seeds"), or `None`.
///
/// ```
/// use denavit_core::{builtin_planar2, ik::closed_form_structure};
/// assert_eq!(closed_form_structure(&builtin_planar2(1.0, 1.0)), None);
/// ```
pub fn closed_form_structure(model: &Model) -> Option<Structure> {
    model.ik_bounds().closed_form.as_ref().map(|c| c.structure)
}

/// Every closed-form branch of `target` (`T_world_tool`) on the ideal structure nearest to `model`'s axes
/// (up to 8; each joint wrapped to (-π, π], limits not applied; a joint left free by a singularity is 0), or
/// `None` when the model has no recognised [`Structure`]. On a model with the exact structure each branch
/// reproduces the target (a reachable one); on an identified model they are the seeds that IK polishes.
pub fn closed_form_branches(model: &Model, target: &Pose) -> Result<Option<Vec<Vec<f64>>>> {
    check_pose("IK target", target)?;
    let Some(cf) = model.ik_bounds().closed_form.as_ref() else { return Ok(None) };
    let mut b = [[Cs::ZERO; 6]; MAX_BRANCHES];
    let count = cf.branches(target, &[0.0; 6], &mut b);
    Ok(Some(b[..count].iter().map(|q| q.iter().map(|a| a.angle()).collect()).collect()))
}

fn check_targets(targets: &[Pose]) -> Result<()> {
    for (i, t) in targets.iter().enumerate() {
        check_pose(format_args!("IK target {i}"), t)?;
    }
    Ok(())
}

/// Solve a sequence of targets, each warm-started from the previous solution (from `q0` for the first,
/// and from the last successful solution after a failure). Target `i` uses restart seed
/// `mix(seed, i)`, so results do not depend on the length of the path.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose, ik::{ik_path, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let targets: Vec<_> = (0..10).map(|k| tool_pose(&m, &[0.3 + 0.01 * k as f64, 1.2]).unwrap()).collect();
/// let r = ik_path(&m, &targets, &[0.3, 1.2], &IkOptions::default()).unwrap();
/// assert!(r.iter().all(|x| x.success && x.restarts == 0));
/// ```
pub fn ik_path(model: &Model, targets: &[Pose], q0: &[f64], opts: &IkOptions) -> Result<Vec<IkResult>> {
    check_targets(targets)?;
    model.check_q(q0).map_err(|e| rename(e, "q0"))?;
    let mut s = IkSolver::new(model, opts.clone())?;
    let mut start = q0.to_vec();
    let mut out = Vec::with_capacity(targets.len());
    for (i, t) in targets.iter().enumerate() {
        crate::parallel::check_interrupt()?;
        let r = s.solve_unchecked(t, &start, mix_seed(opts.seed, i as u64));
        if r.success {
            start.copy_from_slice(&r.q);
        }
        out.push(r);
    }
    Ok(out)
}

/// Solve independent targets on every core (rayon's pool, or as [`crate::parallel::with_threads`] says). `q0s` holds either one start for all (n values) or
/// one per target (N x n, row-major). Target `i` uses restart seed `mix(seed, i)`: the results are the
/// same whatever the number of threads.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose, ik::{ik_batch, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let targets: Vec<_> = (0..50).map(|k| tool_pose(&m, &[0.05 * k as f64, 1.0]).unwrap()).collect();
/// let r = ik_batch(&m, &targets, &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(r.iter().all(|x| x.success));
/// ```
pub fn ik_batch(model: &Model, targets: &[Pose], q0s: &[f64], opts: &IkOptions) -> Result<Vec<IkResult>> {
    let n = model.nq();
    check_targets(targets)?;
    opts.check()?;
    let shared = q0s.len() == n;
    if !shared {
        check_len("q0s (n values, or N*n for N targets)", targets.len() * n, q0s.len())?;
    }
    if shared {
        check_finite("q0s", q0s)?;
    } else {
        check_finite_rows("q0s", q0s, n)?;
    }
    let solve = |s: &mut IkSolver, (i, t): (usize, &Pose)| {
        let q0 = if shared { q0s } else { &q0s[i * n..(i + 1) * n] };
        s.solve_unchecked(t, q0, mix_seed(opts.seed, i as u64))
    };
    let results = if crate::parallel::serial() {
        let mut s = IkSolver::new(model, opts.clone())?;
        targets.iter().enumerate().map(|x| solve(&mut s, x)).collect()
    } else {
        crate::parallel::in_pool(|| {
            targets.par_iter().enumerate().map_init(|| IkSolver::new(model, opts.clone()).expect("options checked above"), solve).collect()
        })?
    };
    crate::parallel::check_interrupt()?;
    Ok(results)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;

    #[test]
    fn log_near_pi_and_identity() {
        assert_eq!(log_rotation(&Matrix3::identity()), Vector3::zeros());
        for axis in [Vector3::new(1.0, 2.0, -0.5), Vector3::x(), Vector3::new(0.0, -1.0, 1e-9)] {
            let a = axis.normalize();
            for t in [PI, PI - 1e-9, PI - 1e-4, 3.0, 1e-12, 0.5] {
                let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(a), t);
                let w = log_rotation(r.matrix());
                let back = Rotation3::new(w);
                assert!((back.matrix() - r.matrix()).amax() < 1e-12, "t = {t}");
                assert!((w.norm() - t).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn solvers_agree() {
        // J: a well-conditioned 6 x 6 matrix, column-major
        let mut jac = [0.0; 36];
        for c in 0..6 {
            for r in 0..6 {
                jac[6 * c + r] = if r == c { 2.0 + r as f64 } else { 0.1 * (r as f64 - c as f64) };
            }
        }
        let e = [1.0, -2.0, 0.5, 0.3, -0.7, 1.1];
        let mut x = [0.0; 6];
        assert!(newton_step6(&jac, &e, &mut x));
        // J x = e
        for r in 0..6 {
            let v: f64 = (0..6).map(|c| jac[6 * c + r] * x[c]).sum();
            assert!((v - e[r]).abs() < 1e-14);
        }
        // the normal equations give the same x (lambda = 0), fixed and dynamic sizes alike
        let mut g = [0.0; 6];
        assert!(lm_step6(&jac, &e, 0.0, &mut g));
        let (mut a2, mut g2) = (vec![0.0; 36], vec![0.0; 6]);
        normal_equations(&jac, &e, 0.0, &mut a2, &mut g2, 6);
        assert!(cholesky_solve(&mut a2, &mut g2, 6));
        assert_eq!(a2.len(), 36);
        for i in 0..6 {
            assert!((g[i] - x[i]).abs() < 1e-12 && (g2[i] - x[i]).abs() < 1e-12);
        }
        // a singular J is reported, and a matrix that is not positive definite
        jac.copy_within(12..18, 18);
        assert!(!newton_step6(&jac, &e, &mut x));
        let mut not_pd = vec![1.0, 2.0, 2.0, 1.0];
        assert!(!cholesky_solve(&mut not_pd, &mut [1.0, 1.0], 2));
        assert_eq!(not_pd.len(), 4);
    }

    #[test]
    fn projection_wraps_revolute_then_clamps_or_reflects() {
        let m = crate::builtin_planar2(1.0, 1.0);
        let b = Bounds::new(&m);
        for reflect in [false, true] {
            let mut q = vec![3.5, -10.0];
            b.project(&mut q, reflect);
            assert!((q[0] - (3.5 - TAU)).abs() < 1e-15);
            assert!((q[1] - (-10.0 + 2.0 * TAU)).abs() < 1e-14);
        }
        // a range narrower than 2 pi: clamped, or mirrored at the limit crossed (clamped if that overshoots)
        let mut j = m.joints().to_vec();
        (j[0].lower, j[0].upper, j[1].lower, j[1].upper) = (-1.0, 1.0, -0.5, 0.5);
        let m = Model::new("narrow", *m.t_world_base(), j, *m.t_last_flange(), *m.t_flange_tool()).expect("a valid model");
        let b = Bounds::new(&m);
        let (mut clamped, mut reflected) = (vec![1.25, -2.0], vec![1.25, -2.0]);
        b.project(&mut clamped, false);
        b.project(&mut reflected, true);
        assert_eq!(clamped, vec![1.0, -0.5]);
        assert_eq!(reflected, vec![0.75, 0.5]);
    }

    /// A spherical wrist behind a shoulder joint (axes z, then x-turned by -90 and 90 deg through one point, an
    /// offset on the middle joint) has one flip, at joint 1; moving the middle axis off the point removes it.
    #[test]
    fn wrist_flips_found_on_spherical_wrists_only() {
        use crate::Joint;
        use crate::spatial::{rx, trans};
        let wrist = |shift: f64| {
            let mut joints = vec![
                Joint::new("s", JointKind::Revolute, Pose::identity()),
                Joint::new("w1", JointKind::Revolute, trans(0.3, 0.0, 0.2)),
                Joint::new("w2", JointKind::Revolute, trans(0.0, shift, 0.0) * rx(-PI / 2.0)),
                Joint::new("w3", JointKind::Revolute, rx(PI / 2.0)),
            ];
            joints[2].offset = 0.4;
            (joints[1].lower, joints[1].upper, joints[2].lower, joints[2].upper) = (-2.0, 2.0, -0.5, 2.5);
            Model::new("wrist", Pose::identity(), joints, trans(0.0, 0.0, 0.1), Pose::identity()).expect("a valid model")
        };
        let m = wrist(0.0);
        assert_eq!(wrist_flips(&m), vec![1]);
        assert!(wrist_flips(&wrist(0.05)).is_empty());
        assert!(wrist_flips(&crate::builtin_planar2(1.0, 1.0)).is_empty());
        // a wrist outside its limits is flipped into them (same pose), not clamped
        let b = Bounds::new(&m);
        let q = vec![0.2, 1.0 - PI, -2.0, 0.5];
        let mut p = q.clone();
        b.project(&mut p, false);
        let flipped = [0.2, 1.0, 2.0 - 0.8, 0.5 + PI - TAU];
        assert!(p.iter().zip(flipped).all(|(a, b)| (a - b).abs() < 1e-15), "{p:?}");
        let (dp, dr) = pose_error(&tool_pose_unchecked(&m, &p), &tool_pose_unchecked(&m, &q));
        assert!(dp < 1e-14 && dr < 1e-14);
    }
}
