//! Inverse kinematics: Newton-Raphson (as used by Guo et al., sec. V) and damped least squares /
//! Levenberg-Marquardt with joint limits; a path solver that warm-starts each goal from the previous
//! solution, and a batch solver on every core.
//!
//! **Error.** At the current configuration `q` with tool pose `T_world_tool(q) = (R, p)` and a goal
//! `(R*, p*)`, the error twist in `world` is `e = [p* - p ; R · log(R^T R*)]` (position difference in m,
//! rotation vector in rad; `log` is the SO(3) logarithm). It is driven to zero with the world-frame
//! geometric Jacobian of [`crate::kinematics::jacobian`] (`J dq ≈ e`, exact to first order).
//!
//! **Success** is decided only from the *measured* final error, never from an internal flag: the tool pose
//! is recomputed from the returned `q` with [`crate::kinematics::fk`] and compared with
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
//! the range; the mirrored one moves back inside. One attempt, random reachable goals
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
//! random reachable goals (benchmarks/bench_kinematics.py --ik-one-attempt), Newton / LM: KR5 92.2 / 65.8 ->
//! 100 / 100 %, UR5 91.6 / 91.4 -> 100 / 100 %, Puma 560 81.8 / 82.4 -> 100 / 100 %, TianSui 87.0 / 90.2 ->
//! 100 / 100 %.
//!
//! **Semi-analytic seeds of 7R arms.** A 7R chain whose axes 1, 2, 3 meet in one point and axes 5, 6 in another
//! (the Franka Emika Panda, the UFactory xArm7, the KUKA LBR iiwa; `redundant` module) is parametrised by q7, as
//! analytic Panda solvers do: q7 is sampled from `q0_7` outwards (1.6 rad apart, within its limits with
//! `respect_limits`, else within ±π of `q0_7`), the 6R left by each sample is solved in closed form (up to 8
//! branches by subproblems SP3, SP4, SP1) and the branches are tried nearest to `q0` first, best-first over the
//! samples, checked by FK and polished by Newton as the 6R seeds are, within attempt 0's `max_iterations`; when
//! every branch of the samples fails (none within the limits, or a goal whose q7 must lie in a narrow
//! interval), the samples halfway between them are solved, down to 0.1 rad apart. The rates this gives in one
//! attempt on 7R arms, and their times, are in docs/speed.md (benchmarks/bench_kinematics.py --ik-one-attempt).
//! Other chains (prismatic joints, other geometries) are solved by Newton or LM alone.
//!
//! **Restarts** are deterministic: attempt 0 starts from `q0`, attempt k >= 1 from a configuration drawn
//! uniformly within the limits (intersected with [-π, π] for revolute and [-1, 1] m for prismatic joints)
//! by a SplitMix64 generator seeded from `seed`, k and the goal's index in a batch or path (0 for a single
//! solve, so a single solve and a batch or path of that one goal give the same answer).
//!
//! **Cost.** An [`IkSolver`] allocates its workspace once; an iteration allocates nothing: one pass of
//! forward kinematics and Jacobian, and for n = 6 fixed-size, fully unrolled 6 x 6 solves (Cholesky for LM,
//! LU with partial pivoting for Newton); other n use the same algorithms on preallocated buffers. The workspace
//! is allocated at the first iteration: a solve met by an exact closed-form seed (the closed form of its
//! branches near `q0`, their ranking and one forward kinematics: about 7 k instructions on the KR5) allocates only its
//! result.
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

use crate::error::{Error, Result, check_finite, check_finite_rows, check_len};
use crate::kinematics::{fk_and_jacobian, fk_unchecked};
use crate::model::{JointKind, Model};
use crate::spatial::{Pose, check_pose, pose_error, rotation_angle};
use nalgebra::{DMatrix, DVectorViewMut, Matrix3, Matrix6, Rotation3, Vector3, Vector6};
use rayon::prelude::*;
use std::f64::consts::{PI, TAU};

mod bounds;
mod closed_form;
mod linalg;
mod options;
mod redundant;
mod solve;

pub(crate) use bounds::*;
pub use closed_form::Structure;
use closed_form::{ClosedForm, Cs, MAX_BRANCHES, MAX_PARTIALS, Partial};
pub use linalg::log_rotation;
use linalg::*;
pub use options::*;
use redundant::{MAX_BRANCHES7, Redundant};
pub use solve::IkSolver;

/// Name an argument in a size / finiteness error of `q`.
fn rename(e: Error, what: &str) -> Error {
    match e {
        Error::SizeMismatch { expected, got, .. } => Error::SizeMismatch { what: what.into(), expected, got },
        Error::NonFinite { index, value, .. } => Error::NonFinite { what: what.into(), index, value },
        other => other,
    }
}

/// Inverse kinematics of one goal `T_world_tool` from `q0` (rad / m); see the module docs for the
/// error, the methods and the success rule. `Err` only for bad input; an unreachable goal gives
/// `Ok` with `success == false` and the measured residual.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk, ik::{ik, IkOptions}, spatial::trans};
/// let m = builtin_planar2(1.0, 1.0);
/// let r = ik(&m, &fk(&m, &[0.3, 1.2]).unwrap(), &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(r.success && r.position_error <= 1e-10);
/// let far = ik(&m, &trans(3.0, 0.0, 0.0), &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(!far.success && (far.position_error - 1.0).abs() < 1e-6); // 3 m away, reach 2 m
/// ```
pub fn ik(model: &Model, goal: &Pose, q0: &[f64], opts: &IkOptions) -> Result<IkResult> {
    IkSolver::new(model, opts.clone())?.solve(goal, q0)
}

/// The structure of `model` that IK solves in closed form for the seeds of its first attempt (module docs,
/// "Closed-form seeds"), or `None`.
///
/// ```
/// use denavit_core::{builtin_planar2, ik::closed_form_structure};
/// assert_eq!(closed_form_structure(&builtin_planar2(1.0, 1.0)), None);
/// ```
pub fn closed_form_structure(model: &Model) -> Option<Structure> {
    model.derived::<Bounds>().closed_form.as_ref().map(|c| c.structure)
}

/// Every closed-form branch of `goal` (`T_world_tool`) on the ideal structure nearest to `model`'s axes
/// (up to 8; each joint wrapped to (-π, π], limits not applied; a joint left free by a singularity is 0), or
/// `None` when the model has no recognised [`Structure`]. On a model with the exact structure each branch
/// reproduces the goal (a reachable one); on an identified model they are the seeds that IK polishes.
pub fn closed_form_branches(model: &Model, goal: &Pose) -> Result<Option<Vec<Vec<f64>>>> {
    check_pose("IK goal", goal)?;
    let Some(cf) = model.derived::<Bounds>().closed_form.as_ref() else { return Ok(None) };
    let mut b = [[Cs::ZERO; 6]; MAX_BRANCHES];
    let count = cf.branches(goal, &[0.0; 6], &mut b);
    Ok(Some(b[..count].iter().map(|q| q.iter().map(|a| a.angle()).collect()).collect()))
}

fn check_goals(goals: &[Pose]) -> Result<()> {
    for (i, t) in goals.iter().enumerate() {
        check_pose(format_args!("IK goal {i}"), t)?;
    }
    Ok(())
}

/// Solve a sequence of goals, each warm-started from the previous solution (from `q0` for the first,
/// and from the last successful solution after a failure). Goal `i` uses restart seed
/// `mix(seed, i)`, so results do not depend on the length of the path.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk, ik::{ik_path, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let goals: Vec<_> = (0..10).map(|k| fk(&m, &[0.3 + 0.01 * k as f64, 1.2]).unwrap()).collect();
/// let r = ik_path(&m, &goals, &[0.3, 1.2], &IkOptions::default()).unwrap();
/// assert!(r.iter().all(|x| x.success && x.restarts == 0));
/// ```
pub fn ik_path(model: &Model, goals: &[Pose], q0: &[f64], opts: &IkOptions) -> Result<Vec<IkResult>> {
    check_goals(goals)?;
    model.check_q(q0).map_err(|e| rename(e, "q0"))?;
    let mut s = IkSolver::new(model, opts.clone())?;
    let mut start = q0.to_vec();
    let mut out = Vec::with_capacity(goals.len());
    for (i, t) in goals.iter().enumerate() {
        crate::parallel::check_interrupt()?;
        let r = s.solve_unchecked(t, &start, mix_seed(opts.seed, i as u64));
        if r.success {
            start.copy_from_slice(&r.q);
        }
        out.push(r);
    }
    Ok(out)
}

/// Solve independent goals on every core (rayon's pool, or as [`crate::parallel::with_threads`] says). `q0s` holds either one start for all (n values) or
/// one per goal (N x n, row-major). Goal `i` uses restart seed `mix(seed, i)`: the results are the
/// same whatever the number of threads.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk, ik::{ik_batch, IkOptions}};
/// let m = builtin_planar2(1.0, 1.0);
/// let goals: Vec<_> = (0..50).map(|k| fk(&m, &[0.05 * k as f64, 1.0]).unwrap()).collect();
/// let r = ik_batch(&m, &goals, &[0.0, 0.5], &IkOptions::default()).unwrap();
/// assert!(r.iter().all(|x| x.success));
/// ```
pub fn ik_batch(model: &Model, goals: &[Pose], q0s: &[f64], opts: &IkOptions) -> Result<Vec<IkResult>> {
    let n = model.nq();
    check_goals(goals)?;
    opts.check()?;
    let shared = q0s.len() == n;
    if !shared {
        check_len("q0s (n values, or N*n for N goals)", goals.len() * n, q0s.len())?;
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
        goals.iter().enumerate().map(|x| solve(&mut s, x)).collect()
    } else {
        crate::parallel::in_pool(|| {
            goals.par_iter().enumerate().map_init(|| IkSolver::new(model, opts.clone()).expect("options checked above"), solve).collect()
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
        let (dp, dr) = pose_error(&fk_unchecked(&m, &p), &fk_unchecked(&m, &q));
        assert!(dp < 1e-14 && dr < 1e-14);
    }
}
