//! Forward kinematics and the geometric Jacobian (docs/conventions.md, "The model").
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
mod avx512;
mod batch;
mod chain;
mod lanes;

use batch::*;
pub use batch::{fk_batch, jacobian_batch};
pub(crate) use chain::Chain;
use chain::*;
use lanes::*;

use crate::error::{Error, Result, check_len};
use crate::math::{sin_cos, sin_cos_lanes, sin_cos_slices};
use crate::model::{Data, Joint, JointKind, Model};
use crate::spatial::Pose;
use nalgebra::{Matrix3, Rotation3, Translation3};

/// In which frame a Jacobian's rows `[v; w]` are expressed, with pinocchio's meanings (`pinocchio::ReferenceFrame`)
/// for a frame F (the tool, or a joint frame): `w` is F's angular velocity and `v` the linear velocity of
///
/// * [`Local`](Self::Local): F's origin, in F's axes (`J_F_F`; pinocchio `LOCAL`);
/// * [`LocalWorldAligned`](Self::LocalWorldAligned): F's origin, in world axes (pinocchio `LOCAL_WORLD_ALIGNED`;
///   the Jacobian of `d p_world_F / dt`, which IK uses);
/// * [`World`](Self::World): the point moving with F that is at the world origin, in world axes (the spatial
///   velocity, pinocchio `WORLD`; column i of a revolute joint is `[o_i × z_i; z_i]`);
/// * [`Base`](Self::Base): F's origin, in the axes of the robot's base frame (`R_world_baseᵀ` times the
///   `LocalWorldAligned` rows; no pinocchio counterpart).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianFrame {
    /// pinocchio `LOCAL`: F's origin, F's axes.
    Local,
    /// pinocchio `LOCAL_WORLD_ALIGNED`: F's origin, world axes.
    LocalWorldAligned,
    /// pinocchio `WORLD`: spatial velocity (reference point the world origin), world axes.
    World,
    /// F's origin, base axes.
    Base,
}

impl JacobianFrame {
    /// Parse `"local"`, `"local_world_aligned"`, `"world"` or `"base"`.
    ///
    /// ```
    /// use denavit_core::kinematics::JacobianFrame;
    /// assert_eq!(JacobianFrame::parse("local_world_aligned").unwrap(), JacobianFrame::LocalWorldAligned);
    /// assert!(JacobianFrame::parse("tool").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "local" => Ok(Self::Local),
            "local_world_aligned" => Ok(Self::LocalWorldAligned),
            "world" => Ok(Self::World),
            "base" => Ok(Self::Base),
            _ => Err(Error::InvalidArgument {
                what: "frame".into(),
                expected: "'local', 'local_world_aligned', 'world' or 'base'".into(),
                got: format!("'{s}'"),
            }),
        }
    }
}

/// `a × b` (with fused multiply-adds).
#[inline(always)]
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1].mul_add(b[2], -(a[2] * b[1])), a[2].mul_add(b[0], -(a[0] * b[2])), a[0].mul_add(b[1], -(a[1] * b[0]))]
}

/// `a · b` (with fused multiply-adds).
#[inline(always)]
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[2].mul_add(b[2], a[1].mul_add(b[1], a[0] * b[0]))
}

/// Jacobian column `[v; w]` of a joint (origin `o`, axis `z`, both in world) for a frame with origin `p`
/// (world) whose axes are `axes` (columns, in world; `None`: world axes), in `frame`'s convention.
#[inline(always)]
fn column(kind: JointKind, o: [f64; 3], z: [f64; 3], p: [f64; 3], frame: JacobianFrame, axes: Option<&[[f64; 3]; 3]>) -> [f64; 6] {
    let (v, w) = match kind {
        JointKind::Revolute if frame == JacobianFrame::World => (cross(o, z), z),
        JointKind::Revolute => (cross(z, [p[0] - o[0], p[1] - o[1], p[2] - o[2]]), z),
        JointKind::Prismatic => (z, [0.0; 3]),
    };
    match axes {
        None => [v[0], v[1], v[2], w[0], w[1], w[2]],
        // R^T v: the rows of R^T are the columns of R
        Some(a) => [dot(a[0], v), dot(a[1], v), dot(a[2], v), dot(a[0], w), dot(a[1], w), dot(a[2], w)],
    }
}

/// The axes (columns, world) a Jacobian in `frame` uses for a frame whose pose in world is `f`.
#[inline(always)]
fn axes_of(model: &Model, frame: JacobianFrame, f: &Frame) -> Option<[[f64; 3]; 3]> {
    match frame {
        JacobianFrame::World | JacobianFrame::LocalWorldAligned => None,
        JacobianFrame::Local => Some([f.col(0), f.col(1), f.col(2)]),
        JacobianFrame::Base => {
            let b = Frame::of(model.t_world_base());
            Some([b.col(0), b.col(1), b.col(2)])
        }
    }
}

/// Check the joint index of a joint-frame Jacobian (0-based, `< n`).
fn check_joint(model: &Model, joint: Option<usize>) -> Result<()> {
    match joint {
        Some(j) if j >= model.nq() => Err(Error::InvalidArgument {
            what: "joint (the frame of the Jacobian)".into(),
            expected: format!("a joint of the model (1..{})", model.nq()),
            got: (j + 1).to_string(),
        }),
        _ => Ok(()),
    }
}

/// `t · M(s)`: right-multiply a pose by the joint motion `Rz(s)` or `Tz(s)`.
#[inline(always)]
pub(crate) fn apply_motion(t: &mut Pose, kind: JointKind, s: f64) {
    match kind {
        JointKind::Revolute => {
            let (sn, cs) = sin_cos(s);
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

/// A pose as four columns of four lanes (x, y, z axes and origin; the fourth lane is padding): the
/// representation of the hot loops. Every column operation is on four lanes, which the compiler maps to
/// SIMD registers; same arithmetic as `Pose * Pose`, up to rounding.
#[derive(Clone, Copy)]
pub(crate) struct Frame {
    c: [[f64; 4]; 4],
}

impl Frame {
    #[inline(always)]
    pub(crate) fn of(t: &Pose) -> Self {
        let m = t.rotation.matrix();
        let v = &t.translation.vector;
        Self { c: [[m[0], m[1], m[2], 0.0], [m[3], m[4], m[5], 0.0], [m[6], m[7], m[8], 0.0], [v[0], v[1], v[2], 0.0]] }
    }
    #[inline(always)]
    pub(crate) fn pose(&self) -> Pose {
        let c = &self.c;
        let r = Matrix3::new(c[0][0], c[1][0], c[2][0], c[0][1], c[1][1], c[2][1], c[0][2], c[1][2], c[2][2]);
        Pose::from_parts(Translation3::new(c[3][0], c[3][1], c[3][2]), Rotation3::from_matrix_unchecked(r))
    }
    /// `self · b`.
    #[inline(always)]
    pub(crate) fn mul(&self, b: &Pose) -> Self {
        let (a, m, v) = (&self.c, b.rotation.matrix(), &b.translation.vector);
        let mut c = [[0.0; 4]; 4];
        for j in 0..3 {
            let (b0, b1, b2) = (m[3 * j], m[3 * j + 1], m[3 * j + 2]);
            for l in 0..4 {
                c[j][l] = a[2][l].mul_add(b2, a[1][l].mul_add(b1, a[0][l] * b0));
            }
        }
        for l in 0..4 {
            c[3][l] = a[2][l].mul_add(v[2], a[1][l].mul_add(v[1], a[0][l].mul_add(v[0], a[3][l])));
        }
        Self { c }
    }
    /// `self · M(s)`: the joint motion `Rz(s)` (given `sin s`, `cos s`) or `Tz(s)`.
    #[inline(always)]
    pub(crate) fn motion(&mut self, kind: JointKind, s: f64, sn: f64, cs: f64) {
        match kind {
            JointKind::Revolute => {
                let (x, y) = (self.c[0], self.c[1]);
                for l in 0..4 {
                    self.c[0][l] = cs.mul_add(x[l], sn * y[l]);
                    self.c[1][l] = cs.mul_add(y[l], -(sn * x[l]));
                }
            }
            JointKind::Prismatic => {
                let z = self.c[2];
                for l in 0..4 {
                    self.c[3][l] = z[l].mul_add(s, self.c[3][l]);
                }
            }
        }
    }
    /// The z axis (third column).
    #[inline(always)]
    pub(crate) fn z(&self) -> [f64; 3] {
        [self.c[2][0], self.c[2][1], self.c[2][2]]
    }
    /// The origin.
    #[inline(always)]
    pub(crate) fn p(&self) -> [f64; 3] {
        [self.c[3][0], self.c[3][1], self.c[3][2]]
    }
    /// Column `j` of the rotation.
    #[inline(always)]
    pub(crate) fn col(&self, j: usize) -> [f64; 3] {
        [self.c[j][0], self.c[j][1], self.c[j][2]]
    }
}

/// The frames of joints 1..=`count` at `q` (unchecked: `q` has `model.nq()` entries, `count <= nq`), each
/// handed to `each(i, frame)`; returns the frame of joint `count`. The sines and cosines of a chain of up to
/// 8 joints come from one call of the lane kernel (vectorised), the same values as one call per joint.
#[inline(always)]
fn walk(model: &Model, q: &[f64], count: usize, mut each: impl FnMut(usize, &Frame)) -> Frame {
    let joints = &model.joints()[..count];
    let mut t = Frame::of(model.t_world_base());
    if joints.len() <= 8 {
        let (s, sn, cs) = joint_angles(joints, q);
        for (i, j) in joints.iter().enumerate() {
            t = t.mul(&j.placement);
            t.motion(j.kind, s[i], sn[i], cs[i]);
            each(i, &t);
        }
    } else {
        for (i, (j, &qi)) in joints.iter().zip(q).enumerate() {
            let s = qi + j.offset;
            let (sn, cs) = sin_cos(s);
            t = t.mul(&j.placement);
            t.motion(j.kind, s, sn, cs);
            each(i, &t);
        }
    }
    t
}

/// The angles `q + offset` of up to 8 joints (the rest 0) and their sines and cosines, from one call of the
/// lane kernel.
#[inline(always)]
fn joint_angles(joints: &[Joint], q: &[f64]) -> ([f64; 8], [f64; 8], [f64; 8]) {
    let mut s = [0.0; 8];
    for ((si, j), &qi) in s.iter_mut().zip(joints).zip(q) {
        *si = qi + j.offset;
    }
    let (sn, cs) = sin_cos_lanes(&s);
    (s, sn, cs)
}

/// Tool pose `T_world_tool(q)` without filling a [`Data`]; `q` must have `model.nq()` entries (unchecked here).
#[inline]
pub fn fk_unchecked(model: &Model, q: &[f64]) -> Pose {
    let (chain, n) = (model.derived::<Chain>(), model.nq());
    if chain.about_x && (1..=8).contains(&n) {
        // the batch kernels' one-pass chain on one configuration: only the products the placements need
        let (_, sn, cs) = joint_angles(model.joints(), q);
        let frame = chain_about_x::<1>(&chain.first, &chain.factors[..n - 1], |i| ([sn[i]], [cs[i]]), |_, _, _| {});
        let c = frame.map(|v| [v[0][0], v[1][0], v[2][0], 0.0]);
        return Frame { c }.mul(model.t_last_tool()).pose();
    }
    fk_walk(model, q)
}

/// [`fk_unchecked`] joint by joint ([`walk`]): any chain, every product of every placement.
fn fk_walk(model: &Model, q: &[f64]) -> Pose {
    walk(model, q, model.nq(), |_, _| {}).mul(model.t_last_tool()).pose()
}

/// Tool pose `T_world_tool(q)`.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::fk};
/// let m = builtin_planar2(1.0, 1.0);
/// let t = fk(&m, &[std::f64::consts::FRAC_PI_2, 0.0]).unwrap();
/// assert!((t.translation.vector - nalgebra::Vector3::new(0.0, 2.0, 0.0)).norm() < 1e-15);
/// ```
pub fn fk(model: &Model, q: &[f64]) -> Result<Pose> {
    model.check_q(q)?;
    Ok(fk_unchecked(model, q))
}

/// Forward kinematics: fill `data.t_world_joint` and `data.t_world_tool` for configuration `q`.
pub fn forward_kinematics(model: &Model, data: &mut Data, q: &[f64]) -> Result<()> {
    model.check_q(q)?;
    forward_kinematics_unchecked(model, data, q);
    Ok(())
}

#[inline]
pub(crate) fn forward_kinematics_unchecked(model: &Model, data: &mut Data, q: &[f64]) {
    let frames = &mut data.t_world_joint;
    let t = walk(model, q, model.nq(), |i, t| frames[i] = t.pose());
    data.t_world_tool = t.mul(model.t_last_tool()).pose();
}

/// Geometric Jacobian of the tool at `q` (rows `[v; w]`, see [`JacobianFrame`]) into `data.jacobian`; also
/// fills the forward kinematics of `data`.
///
/// ```
/// use denavit_core::{builtin_planar2, Data, kinematics::{jacobian, JacobianFrame}};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut d = Data::new(&m);
/// jacobian(&m, &mut d, &[0.0, 0.0], JacobianFrame::LocalWorldAligned).unwrap();
/// assert!((d.jacobian[(1, 0)] - 2.0).abs() < 1e-15); // dy/dq1 = l1 + l2
/// ```
pub fn jacobian(model: &Model, data: &mut Data, q: &[f64], frame: JacobianFrame) -> Result<()> {
    model.check_q(q)?;
    jacobian_unchecked(model, data, q, frame);
    Ok(())
}

#[inline]
pub(crate) fn jacobian_unchecked(model: &Model, data: &mut Data, q: &[f64], frame: JacobianFrame) {
    forward_kinematics_unchecked(model, data, q);
    let tool = Frame::of(&data.t_world_tool);
    let axes = axes_of(model, frame, &tool);
    let jac = data.jacobian.as_mut_slice(); // column-major 6 x n
    for ((j, t), col) in model.joints().iter().zip(&data.t_world_joint).zip(jac.chunks_exact_mut(6)) {
        let f = Frame::of(t);
        col.copy_from_slice(&column(j.kind, f.p(), f.z(), tool.p(), frame, axes.as_ref()));
    }
}

/// Tool pose and `LocalWorldAligned` Jacobian in one pass, without a [`Data`] (the inner loop of IK):
/// `jac` (column-major 6 x n) receives the columns of [`jacobian`] with [`JacobianFrame::LocalWorldAligned`].
#[inline]
pub(crate) fn fk_and_jacobian(model: &Model, q: &[f64], jac: &mut [f64]) -> Pose {
    // park each joint's origin and z axis in its column; the tool origin is known only at the end
    let t = walk(model, q, model.nq(), |i, t| {
        jac[6 * i..6 * i + 3].copy_from_slice(&t.p());
        jac[6 * i + 3..6 * i + 6].copy_from_slice(&t.z());
    });
    let tool = t.mul(model.t_last_tool());
    let tp = tool.p();
    for (j, col) in model.joints().iter().zip(jac.chunks_exact_mut(6)) {
        let c = column(j.kind, [col[0], col[1], col[2]], [col[3], col[4], col[5]], tp, JacobianFrame::LocalWorldAligned, None);
        col.copy_from_slice(&c);
    }
    tool.pose()
}

/// The geometric Jacobian at `q` of the tool (`joint = None`) or of joint frame `joint` (0-based; columns
/// after it are zero), written row-major (6 x n) into `out`, in one pass without a [`Data`] (the tool's is
/// the same as [`jacobian`]). Unchecked: `q` must have n finite values, `joint < n`.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::{jacobian_row_major_unchecked, JacobianFrame}};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut j = [0.0; 12];
/// // joint frame 1 at q = 0: joint 1 moves the origin of frame 2 (at x = 1) along y, joint 2 does not move it
/// jacobian_row_major_unchecked(&m, &[0.0, 0.0], JacobianFrame::LocalWorldAligned, Some(1), &mut j);
/// assert_eq!((j[2], j[3], j[10], j[11]), (1.0, 0.0, 1.0, 1.0)); // dy/dq1, dy/dq2, wz/dq1, wz/dq2
/// ```
pub fn jacobian_row_major_unchecked(model: &Model, q: &[f64], frame: JacobianFrame, joint: Option<usize>, out: &mut [f64]) {
    let n = model.nq();
    let mut stack = [[0.0; 6]; 16];
    let mut heap = Vec::new();
    let oz: &mut [[f64; 6]] = if n <= 16 {
        &mut stack[..n]
    } else {
        heap.resize(n, [0.0; 6]);
        &mut heap
    };
    let cols = joint.map_or(n, |j| j + 1);
    let t = walk(model, q, cols, |i, t| {
        let (p, z) = (t.p(), t.z());
        oz[i] = [p[0], p[1], p[2], z[0], z[1], z[2]];
    });
    let f = if joint.is_none() { t.mul(model.t_last_tool()) } else { t };
    let axes = axes_of(model, frame, &f);
    for (k, (j, ozk)) in model.joints().iter().zip(oz.iter()).enumerate() {
        let col = if k < cols { column(j.kind, [ozk[0], ozk[1], ozk[2]], [ozk[3], ozk[4], ozk[5]], f.p(), frame, axes.as_ref()) } else { [0.0; 6] };
        for (r, v) in col.iter().enumerate() {
            out[r * n + k] = *v;
        }
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
