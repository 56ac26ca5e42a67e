//! Joint axis lines, the robot's geometric truth (docs/conventions.md, "Joint axes").

use crate::error::{Error, Result, check_finite, check_len};
use crate::kinematics::forward_kinematics;
use crate::model::{Data, JointKind, Model};
use crate::spatial::{Pose, unit};
use nalgebra::Vector3;

/// ED-H takes the common normal of two axes whenever `|z_i x z_{i+1}|` exceeds this (about 45 ulps): below it
/// the angle between unit vectors is round-off and the pair is exactly parallel for every purpose.
pub const EXACT_PARALLEL_SIN: f64 = 1e-14;

/// Above this `|z_i x z_{i+1}|` (about 2.9 degrees) axes are never treated as parallel, however far their
/// common normal lies (docs/conventions.md).
pub const NEAR_PARALLEL_SIN: f64 = 0.05;

/// Joint axis lines in `world` observed at configuration `q_ref`, with the base frame and the tool pose.
#[derive(Debug, Clone, PartialEq)]
pub struct JointAxes {
    /// `T_world_base`: the reference base frame.
    pub t_world_base: Pose,
    /// A point on each axis (world, metres). ED-H places frame origins here.
    pub points: Vec<Vector3<f64>>,
    /// Unit direction of each axis (world); positive joint motion turns counter-clockwise about it.
    pub directions: Vec<Vector3<f64>>,
    /// Joint kinds.
    pub kinds: Vec<JointKind>,
    /// The configuration at which the axes were observed (rad or m).
    pub q_ref: Vec<f64>,
    /// `T_world_tool` at `q_ref`.
    pub t_world_tool: Pose,
    /// Lower joint limits.
    pub lower: Vec<f64>,
    /// Upper joint limits.
    pub upper: Vec<f64>,
}

impl JointAxes {
    /// Checked axes: directions are normalised; a zero-length direction is an error naming the joint.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        t_world_base: Pose,
        points: Vec<Vector3<f64>>,
        directions: Vec<Vector3<f64>>,
        kinds: Vec<JointKind>,
        q_ref: Vec<f64>,
        t_world_tool: Pose,
        lower: Vec<f64>,
        upper: Vec<f64>,
    ) -> Result<Self> {
        let n = points.len();
        if n == 0 {
            return Err(Error::InvalidArgument { what: "joint axes".into(), expected: "at least one axis".into(), got: "none".into() });
        }
        check_len("axis directions", n, directions.len())?;
        check_len("joint kinds", n, kinds.len())?;
        check_len("q_ref", n, q_ref.len())?;
        check_len("lower limits", n, lower.len())?;
        check_len("upper limits", n, upper.len())?;
        check_finite("q_ref", &q_ref)?;
        for (i, (l, u)) in lower.iter().zip(&upper).enumerate() {
            if l.is_nan() || u.is_nan() || l > u {
                return Err(Error::InvalidArgument {
                    what: format!("limits of axis {}", i + 1),
                    expected: "lower <= upper".into(),
                    got: format!("[{l}, {u}]"),
                });
            }
        }
        let mut dirs = Vec::with_capacity(n);
        for (i, (p, d)) in points.iter().zip(&directions).enumerate() {
            check_finite(&format!("point of axis {}", i + 1), p.as_slice())?;
            let u = unit(d, &format!("direction of axis {}", i + 1))?.into_inner();
            // a direction already unit to rounding is kept bit for bit: a pickled or copied JointAxes reads back the same
            dirs.push(if (d.norm() - 1.0).abs() <= 4.0 * f64::EPSILON { *d } else { u });
        }
        Ok(Self { t_world_base, points, directions: dirs, kinds, q_ref, t_world_tool, lower, upper })
    }

    /// Number of axes.
    pub fn nq(&self) -> usize {
        self.points.len()
    }
}

/// The axes of `model` at configuration `q`: origin and z axis of each joint frame.
///
/// ```
/// use denavit_core::{builtin_planar2, axes::axes};
/// let a = axes(&builtin_planar2(1.0, 1.0), &[0.0, 0.0]).unwrap();
/// assert_eq!(a.points[1].x, 1.0);
/// ```
pub fn axes(model: &Model, q: &[f64]) -> Result<JointAxes> {
    let mut data = Data::new(model);
    forward_kinematics(model, &mut data, q)?;
    Ok(JointAxes {
        t_world_base: *model.t_world_base(),
        points: data.t_world_joint.iter().map(|t| t.translation.vector).collect(),
        directions: data.t_world_joint.iter().map(|t| t.rotation.matrix().column(2).into_owned()).collect(),
        kinds: model.joints().iter().map(|j| j.kind).collect(),
        q_ref: q.to_vec(),
        t_world_tool: data.t_world_tool,
        lower: model.lower(),
        upper: model.upper(),
    })
}
