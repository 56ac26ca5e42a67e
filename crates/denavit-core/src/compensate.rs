//! Compensation ("filtering" of positions): put an identified model to work on a robot whose controller
//! keeps its nominal model.
//!
//! For a position (a row of a robot program: a tool pose `T` in the robot base's world frame), the
//! identified model tells which joint values `q` really reach it: `FK_identified(q) = T`. A controller
//! that keeps its nominal model must then be sent the pose it would compute for those joint values,
//! `T' = FK_nominal(q)`: solving its nominal inverse kinematics for `T'` it commands `q` (on the same
//! branch), and the robot reaches `T`.
//!
//! Each identified solve starts from the nominal solution of the same position (the branch the program was
//! written for); a solution that leaves it by more than `branch_tol` on any joint is flagged, never kept
//! silently. In `path` mode the nominal solutions are warm-started along the program ([`ik_path`]), and a
//! joint step between consecutive nominal solutions larger than `path_jump` is flagged as a branch flip.

use crate::error::{Error, Result, check_finite, check_len};
use crate::ik::{IkOptions, IkSolver, ik_batch, ik_path};
use crate::kinematics::fk_unchecked;
use crate::model::Model;
use crate::spatial::{Pose, pose_error};
use rayon::prelude::*;

/// Options of [`compensate`]. `Default`: the IK defaults, independent positions, `branch_tol` 0.1 (rad or m),
/// `path_jump` pi/4.
#[derive(Debug, Clone, PartialEq)]
pub struct CompensateOptions {
    /// Options of every IK solve (nominal and identified).
    pub ik: IkOptions,
    /// The positions form a path: warm-start each nominal solve from the previous solution, flag jumps.
    pub path: bool,
    /// Largest `|q_identified - q_nominal|` on any joint (rad / m) that is still the same branch.
    pub branch_tol: f64,
    /// Largest joint step between consecutive nominal solutions of a path that is not a branch flip (rad / m).
    pub path_jump: f64,
}

impl Default for CompensateOptions {
    fn default() -> Self {
        Self { ik: IkOptions::default(), path: false, branch_tol: 0.1, path_jump: std::f64::consts::FRAC_PI_4 }
    }
}

/// The compensation of one position.
#[derive(Debug, Clone, PartialEq)]
pub struct Compensation {
    /// Joint values that reach the position on the identified model (rad / m).
    pub q: Vec<f64>,
    /// Joint values of the nominal model for the position (given, or solved).
    pub q_nominal: Vec<f64>,
    /// `T' = FK_nominal(q)`: the pose to send to a controller that keeps its nominal model.
    pub command: Pose,
    /// The identified solve met the IK tolerances (within the limits if asked).
    pub reached: bool,
    /// The nominal solve met the IK tolerances (true when the nominal joint values were given).
    pub nominal_reached: bool,
    /// `q` left the nominal solution's branch (some joint differs by more than `branch_tol`).
    pub branch_changed: bool,
    /// Path mode: the nominal solution jumped from the previous position's by more than `path_jump`.
    pub path_jump: bool,
    /// `|p_identified(q) - p|` (m, `p` the position's translation) and the rotation angle (rad): the residual
    /// of the identified solve.
    pub position_error: f64,
    /// See `position_error`.
    pub rotation_error: f64,
    /// What the robot would miss without compensation: `FK_identified(q_nominal)` against the position (m).
    pub before_position: f64,
    /// See `before_position` (rad).
    pub before_rotation: f64,
}

fn check_models(nominal: &Model, identified: &Model) -> Result<()> {
    check_len("joints of the identified model (those of the nominal)", nominal.nq(), identified.nq())?;
    for (i, (a, b)) in nominal.joints().iter().zip(identified.joints()).enumerate() {
        if a.kind != b.kind {
            return Err(Error::InvalidArgument {
                what: format!("joint {} of the identified model", i + 1),
                expected: format!("a {} joint, as in the nominal model", a.kind.name()),
                got: b.kind.name().into(),
            });
        }
    }
    Ok(())
}

/// Compensate `positions` (`T_world_tool`, world of both models): see the module docs. `q_nominal`: the
/// nominal joint values of each position (N x n, row-major), when the program was given as joint rows;
/// otherwise they are solved on the nominal model from `q0` (n values).
///
/// ```
/// use denavit_core::{Joint, JointKind, Model, kinematics::fk, spatial::{trans, Pose}};
/// use denavit_core::compensate::{compensate, CompensateOptions};
/// // a planar 3R arm (it reaches a planar pose: x, y and the angle) and the same arm 1 mm longer in link 1
/// let arm = |l1: f64| {
///     let j = vec![Joint::new("j1", JointKind::Revolute, Pose::identity()), Joint::new("j2", JointKind::Revolute, trans(l1, 0.0, 0.0)),
///                  Joint::new("j3", JointKind::Revolute, trans(1.0, 0.0, 0.0))];
///     Model::new("planar3", Pose::identity(), j, trans(0.5, 0.0, 0.0), Pose::identity()).unwrap()
/// };
/// let (nominal, identified) = (arm(1.0), arm(1.001));
/// let t = fk(&nominal, &[0.3, 0.8, -0.4]).unwrap();
/// let c = &compensate(&nominal, &identified, &[t], None, &[0.3, 0.8, -0.4], &CompensateOptions::default()).unwrap()[0];
/// assert!(c.reached && !c.branch_changed && c.before_position > 1e-4);
/// assert!((fk(&identified, &c.q).unwrap().translation.vector - t.translation.vector).norm() < 1e-9);
/// ```
pub fn compensate(
    nominal: &Model,
    identified: &Model,
    positions: &[Pose],
    q_nominal: Option<&[f64]>,
    q0: &[f64],
    opts: &CompensateOptions,
) -> Result<Vec<Compensation>> {
    check_models(nominal, identified)?;
    opts.ik.check()?;
    for (what, v) in [("branch_tol", opts.branch_tol), ("path_jump", opts.path_jump)] {
        if !(v.is_finite() && v > 0.0) {
            return Err(Error::InvalidArgument { what: what.into(), expected: "a finite value > 0".into(), got: v.to_string() });
        }
    }
    let n = nominal.nq();
    check_len("q0", n, q0.len())?;
    check_finite("q0", q0)?;
    let (qn, nominal_ok): (Vec<f64>, Vec<bool>) = match q_nominal {
        Some(q) => {
            check_len("q_nominal (N x n values)", positions.len() * n, q.len())?;
            check_finite("q_nominal", q)?;
            (q.to_vec(), vec![true; positions.len()])
        }
        None => {
            let r = if opts.path { ik_path(nominal, positions, q0, &opts.ik)? } else { ik_batch(nominal, positions, q0, &opts.ik)? };
            (r.iter().flat_map(|x| x.q.iter().copied()).collect(), r.iter().map(|x| x.success).collect())
        }
    };
    for (i, t) in positions.iter().enumerate() {
        crate::spatial::check_pose(format_args!("position {i}"), t)?;
    }
    // the identified solve from the nominal solution: no restarts first (stay on its branch), then the
    // options' restarts if that fails
    let first = IkOptions { restarts: 0, ..opts.ik.clone() };
    let out: Vec<Compensation> = crate::parallel::in_pool(|| {
        positions
            .par_iter()
            .enumerate()
            .map_init(
                || {
                    (
                        IkSolver::new(identified, first.clone()).expect("options checked above"),
                        IkSolver::new(identified, opts.ik.clone()).expect("options checked above"),
                    )
                },
                |(quick, full), (i, t)| {
                    let qn_i = &qn[i * n..(i + 1) * n];
                    // (positions and q checked above; as IkSolver::solve)
                    let seed = crate::ik::mix_seed(opts.ik.seed, 0);
                    let mut r = quick.solve_unchecked(t, qn_i, seed);
                    if !r.success && opts.ik.restarts > 0 {
                        r = full.solve_unchecked(t, qn_i, seed);
                    }
                    let branch_changed = r.q.iter().zip(qn_i).any(|(a, b)| (a - b).abs() > opts.branch_tol);
                    let path_jump = opts.path && i > 0 && qn_i.iter().zip(&qn[(i - 1) * n..i * n]).any(|(a, b)| (a - b).abs() > opts.path_jump);
                    let (bp, br) = pose_error(&fk_unchecked(identified, qn_i), t);
                    Compensation {
                        command: fk_unchecked(nominal, &r.q),
                        q_nominal: qn_i.to_vec(),
                        reached: r.success,
                        nominal_reached: nominal_ok[i],
                        branch_changed,
                        path_jump,
                        position_error: r.position_error,
                        rotation_error: r.rotation_error,
                        before_position: bp,
                        before_rotation: br,
                        q: r.q,
                    }
                },
            )
            .collect()
    })?;
    crate::parallel::check_interrupt()?;
    Ok(out)
}
