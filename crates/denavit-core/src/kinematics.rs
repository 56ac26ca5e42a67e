//! Forward kinematics and the geometric Jacobian (docs/conventions.md, "The model").

use crate::error::{check_len, Result};
use crate::model::{Data, JointKind, Model};
use crate::spatial::Pose;
use nalgebra::{Matrix3, Vector3};
use rayon::prelude::*;

/// In which frame a Jacobian's rows are expressed (the reference point is always the tool origin).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianFrame {
    /// `J_world_tool`: axes of the world frame.
    World,
    /// `J_tool_tool`: axes of the tool frame.
    Tool,
}

/// `t · M(s)`: right-multiply a pose by the joint motion `Rz(s)` or `Tz(s)`.
#[inline(always)]
pub(crate) fn apply_motion(t: &mut Pose, kind: JointKind, s: f64) {
    match kind {
        JointKind::Revolute => {
            let (sn, cs) = s.sin_cos();
            apply_rz(t, sn, cs);
        }
        JointKind::Prismatic => {
            let z = t.rotation.matrix().column(2).into_owned();
            t.translation.vector += z * s;
        }
    }
}

/// `t · Rz` given the sine and cosine of the angle.
#[inline(always)]
pub(crate) fn apply_rz(t: &mut Pose, sn: f64, cs: f64) {
    let m = t.rotation.matrix_mut_unchecked();
    for r in 0..3 {
        let (a, b) = (m[(r, 0)], m[(r, 1)]);
        m[(r, 0)] = cs * a + sn * b;
        m[(r, 1)] = cs * b - sn * a;
    }
}

/// Tool pose `T_world_tool(q)` without filling a [`Data`]; `q` must have `model.nq()` entries (unchecked here).
#[inline]
pub fn tool_pose_unchecked(model: &Model, q: &[f64]) -> Pose {
    let mut t = *model.t_world_base();
    for (j, &qi) in model.joints().iter().zip(q) {
        t *= j.placement;
        apply_motion(&mut t, j.kind, qi + j.offset);
    }
    t * model.t_flange_tool()
}

/// Tool pose `T_world_tool(q)`.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::tool_pose};
/// let m = builtin_planar2(1.0, 1.0);
/// let t = tool_pose(&m, &[std::f64::consts::FRAC_PI_2, 0.0]).unwrap();
/// assert!((t.translation.vector - nalgebra::Vector3::new(0.0, 2.0, 0.0)).norm() < 1e-15);
/// ```
pub fn tool_pose(model: &Model, q: &[f64]) -> Result<Pose> {
    model.check_q(q)?;
    Ok(tool_pose_unchecked(model, q))
}

/// Forward kinematics: fill `data.t_world_joint` and `data.t_world_tool` for configuration `q`.
pub fn forward_kinematics(model: &Model, data: &mut Data, q: &[f64]) -> Result<()> {
    model.check_q(q)?;
    fk_unchecked(model, data, q);
    Ok(())
}

#[inline]
pub(crate) fn fk_unchecked(model: &Model, data: &mut Data, q: &[f64]) {
    let mut t = *model.t_world_base();
    for ((j, &qi), out) in model.joints().iter().zip(q).zip(data.t_world_joint.iter_mut()) {
        t *= j.placement;
        apply_motion(&mut t, j.kind, qi + j.offset);
        *out = t;
    }
    data.t_world_tool = t * model.t_flange_tool();
}

/// Geometric Jacobian of the tool at `q` (rows `[v; w]`: linear velocity of the tool origin, angular
/// velocity), in the world or the tool frame; also fills the forward kinematics of `data`.
///
/// ```
/// use denavit_core::{builtin_planar2, Data, kinematics::{jacobian, JacobianFrame}};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut d = Data::new(&m);
/// jacobian(&m, &mut d, &[0.0, 0.0], JacobianFrame::World).unwrap();
/// assert!((d.jacobian[(1, 0)] - 2.0).abs() < 1e-15); // dy/dq1 = l1 + l2
/// ```
pub fn jacobian(model: &Model, data: &mut Data, q: &[f64], frame: JacobianFrame) -> Result<()> {
    model.check_q(q)?;
    jacobian_unchecked(model, data, q, frame);
    Ok(())
}

#[inline]
pub(crate) fn jacobian_unchecked(model: &Model, data: &mut Data, q: &[f64], frame: JacobianFrame) {
    fk_unchecked(model, data, q);
    let p_tool = data.t_world_tool.translation.vector;
    let r_t: Matrix3<f64> = match frame {
        JacobianFrame::World => Matrix3::identity(),
        JacobianFrame::Tool => data.t_world_tool.rotation.matrix().transpose(),
    };
    for (i, (j, t)) in model.joints().iter().zip(&data.t_world_joint).enumerate() {
        let z: Vector3<f64> = t.rotation.matrix().column(2).into_owned();
        let (v, w) = match j.kind {
            JointKind::Revolute => (z.cross(&(p_tool - t.translation.vector)), z),
            JointKind::Prismatic => (z, Vector3::zeros()),
        };
        let (v, w) = match frame {
            JacobianFrame::World => (v, w),
            JacobianFrame::Tool => (r_t * v, r_t * w),
        };
        let mut col = data.jacobian.column_mut(i);
        col.fixed_rows_mut::<3>(0).copy_from(&v);
        col.fixed_rows_mut::<3>(3).copy_from(&w);
    }
}

/// Write a pose as a row-major 4x4 matrix into `out[..16]`.
#[inline(always)]
pub(crate) fn write_pose(t: &Pose, out: &mut [f64]) {
    let r = t.rotation.matrix();
    let p = &t.translation.vector;
    for i in 0..3 {
        out[4 * i] = r[(i, 0)];
        out[4 * i + 1] = r[(i, 1)];
        out[4 * i + 2] = r[(i, 2)];
        out[4 * i + 3] = p[i];
    }
    out[12] = 0.0;
    out[13] = 0.0;
    out[14] = 0.0;
    out[15] = 1.0;
}

/// Batch tool poses: `qs` holds N configurations row-major (N x n), `out` N row-major 4x4 matrices (N x 16).
/// Runs on all cores (rayon). Values must be finite (checked).
pub fn tool_pose_batch(model: &Model, qs: &[f64], out: &mut [f64]) -> Result<()> {
    let n = model.nq().max(1);
    let count = if model.nq() == 0 { out.len() / 16 } else { qs.len() / n };
    check_len("q batch (N*n values)", count * model.nq(), qs.len())?;
    check_len("output (N*16 values)", count * 16, out.len())?;
    crate::error::check_finite("q batch", qs)?;
    const CHUNK: usize = 1024;
    out.par_chunks_mut(16 * CHUNK).enumerate().for_each(|(c, o)| {
        let start = c * CHUNK;
        for (k, ok) in o.chunks_exact_mut(16).enumerate() {
            let q = &qs[(start + k) * model.nq()..(start + k + 1) * model.nq()];
            write_pose(&tool_pose_unchecked(model, q), ok);
        }
    });
    Ok(())
}

/// Batch Jacobians: `out` holds N row-major 6 x n matrices (N x 6n), in the requested frame.
pub fn jacobian_batch(model: &Model, qs: &[f64], frame: JacobianFrame, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    if n == 0 {
        return Ok(());
    }
    let count = qs.len() / n;
    check_len("q batch (N*n values)", count * n, qs.len())?;
    check_len("output (N*6n values)", count * 6 * n, out.len())?;
    crate::error::check_finite("q batch", qs)?;
    out.par_chunks_mut(6 * n * 256).enumerate().for_each_init(
        || Data::new(model),
        |data, (c, o)| {
            for (k, ok) in o.chunks_exact_mut(6 * n).enumerate() {
                let idx = c * 256 + k;
                jacobian_unchecked(model, data, &qs[idx * n..(idx + 1) * n], frame);
                for r in 0..6 {
                    for col in 0..n {
                        ok[r * n + col] = data.jacobian[(r, col)];
                    }
                }
            }
        },
    );
    Ok(())
}
