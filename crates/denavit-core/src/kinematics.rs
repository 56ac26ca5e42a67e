//! Forward kinematics and the geometric Jacobian (docs/conventions.md, "The model").
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

#[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
mod avx512;

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
pub fn tool_pose_unchecked(model: &Model, q: &[f64]) -> Pose {
    let (chain, n) = (model.chain(), model.nq());
    if chain.about_x && (1..=8).contains(&n) {
        // the batch kernels' one-pass chain on one configuration: only the products the placements need
        let (_, sn, cs) = joint_angles(model.joints(), q);
        let frame = chain_about_x::<1>(&chain.first, &chain.factors[..n - 1], |i| ([sn[i]], [cs[i]]), |_, _, _| {});
        let c = frame.map(|v| [v[0][0], v[1][0], v[2][0], 0.0]);
        return Frame { c }.mul(model.t_last_tool()).pose();
    }
    tool_pose_walk(model, q)
}

/// [`tool_pose_unchecked`] joint by joint ([`walk`]): any chain, every product of every placement.
fn tool_pose_walk(model: &Model, q: &[f64]) -> Pose {
    walk(model, q, model.nq(), |_, _| {}).mul(model.t_last_tool()).pose()
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
    fk_unchecked(model, data, q);
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
pub(crate) fn tool_pose_and_jacobian(model: &Model, q: &[f64], jac: &mut [f64]) -> Pose {
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

/// Configurations per structure-of-arrays block of the batch kernels: every step of the chain is a loop over
/// the block's configurations with a straight-line body, which the compiler vectorises at the machine's full
/// width (4 or 8 lanes) with fused multiply-adds; a block's frames (6 KB) stay in the L1 cache.
const BLOCK: usize = 64;

/// Rows of a batch per parallel work item (a multiple of [`BLOCK`]).
const CHUNK: usize = 1024;

/// One quantity of a block's configurations.
type V = [f64; BLOCK];

/// The last rows of a batch up to this many go through the single-configuration path one by one (the same
/// values bit for bit) instead of a block padded to [`BLOCK`] rows: a one-row batch had cost a whole block.
const TAIL_ROWS: usize = 16;

/// What [`block_of`] made of a block's joint values.
enum Rows<'a> {
    /// The block to compute (`BLOCK` rows of joint values).
    Block(&'a [f64]),
    /// Each row written by the single-configuration path.
    Written,
    /// A joint value is not finite.
    NotFinite,
}

/// The block of joint values `qb` (`BLOCK` rows of `n`, or the batch's last rows): `qb` itself when whole;
/// the last rows padded with zeros into `padded`; or, up to [`TAIL_ROWS`] rows, each row of `out` written
/// by `one(q_row, out_row)`.
#[inline(always)]
fn block_of<'a>(qb: &'a [f64], n: usize, padded: &'a mut Vec<f64>, out: &mut [f64], one: impl Fn(&[f64], &mut [f64])) -> Rows<'a> {
    let rows = qb.len() / n;
    if rows == BLOCK {
        return Rows::Block(qb);
    }
    if rows > TAIL_ROWS {
        padded.resize(BLOCK * n, 0.0);
        padded[..qb.len()].copy_from_slice(qb);
        return Rows::Block(padded);
    }
    // (the batch's error names the first non-finite value of all rows: this block's own is dropped)
    match small_batch(qb, n, out, out.len() / rows, one) {
        Ok(()) => Rows::Written,
        Err(_) => Rows::NotFinite,
    }
}

/// Rows through the single-configuration path (`qs`: rows of `n`; `out`: rows of `per_row`), each row of
/// `out` written by `one(q_row, out_row)` once all are known finite: a whole batch of up to [`TAIL_ROWS`]
/// rows, without a block's workspace or the chain's factors (a one-row batch had spent half its time
/// allocating them), and the last rows of a bigger one ([`block_of`]).
fn small_batch(qs: &[f64], n: usize, out: &mut [f64], per_row: usize, one: impl Fn(&[f64], &mut [f64])) -> Result<()> {
    crate::error::check_finite_rows("q", qs, n)?;
    for (q, o) in qs.chunks_exact(n).zip(out.chunks_exact_mut(per_row)) {
        one(q, o);
    }
    Ok(())
}

/// A block's frames: `c[column][row][configuration]`, the columns the x, y, z axes and the origin.
type Frames = [[V; 3]; 4];

/// The rotation of a constant factor of the chain, by its exact zeros and ones.
const ROT_IDENTITY: u8 = 0;
/// A rotation about x (x column `e_x`, first row `e_xᵀ`): what a DH or modified DH placement `Rx(alpha)` gives.
const ROT_ABOUT_X: u8 = 1;
/// Any other rotation.
const ROT_GENERAL: u8 = 2;
/// A quarter turn about x, its entries exactly 0 and ±1 (a DH table's alpha = ±90 deg, spatial::rx): in the
/// one-pass chains a renaming of the axes; the joint-by-joint [`step`]s treat it as `ROT_ABOUT_X`.
const ROT_QUARTER_X: u8 = 3;

/// The joint motion that follows a factor: `Rz(s)`, `Tz(s)`, or none (the tool).
const MOTION_RZ: u8 = 0;
const MOTION_TZ: u8 = 1;
const MOTION_NONE: u8 = 2;

/// A constant factor of the chain (a placement or the tool) with the shape of its rotation and which
/// components of its origin are not zero. The kernels skip the terms whose factor is an exact zero or one:
/// that changes no value (the remaining fused sums run in the order of [`Frame::mul`], so the batch values
/// are those of the single-configuration path up to the sign of zeros) and roughly halves the work of a DH
/// chain.
#[derive(Clone, Copy)]
struct Factor {
    /// Columns x, y, z of the rotation, then the origin.
    b: [[f64; 3]; 4],
    rot: u8,
    /// Bit k set: origin component k is not zero.
    origin: u8,
}

impl Factor {
    fn of(t: &Pose) -> Self {
        let f = Frame::of(t);
        let b: [[f64; 3]; 4] = std::array::from_fn(|j| [f.c[j][0], f.c[j][1], f.c[j][2]]);
        let about_x = b[0] == [1.0, 0.0, 0.0] && b[1][0] == 0.0 && b[2][0] == 0.0;
        let rot = if about_x && b[1] == [0.0, 1.0, 0.0] && b[2] == [0.0, 0.0, 1.0] {
            ROT_IDENTITY
        } else if about_x && b[1][1] == 0.0 && b[2][2] == 0.0 && b[1][2].abs() == 1.0 && b[2][1] == -b[1][2] {
            ROT_QUARTER_X
        } else if about_x {
            ROT_ABOUT_X
        } else {
            ROT_GENERAL
        };
        let origin = (0..3).filter(|&k| b[3][k] != 0.0).map(|k| 1u8 << k).sum();
        Self { b, rot, origin }
    }
}

/// A model's chain prepared for the batch kernels: the frame of the first joint before its motion
/// (`T_world_base · placement_1`, the same for every configuration, so computed once), then the placements
/// of joints 2..n and the tool as [`Factor`]s. Each model keeps its own ([`Model::chain`]).
#[derive(Clone)]
pub(crate) struct Chain {
    first: Frame,
    factors: Vec<Factor>,
    /// For [`revolute_about_x`]: every joint is revolute and every placement rotates about x only (DH,
    /// modified DH, ED-H tables).
    about_x: bool,
}

impl Chain {
    pub(crate) fn of(model: &Model) -> Self {
        let base = Frame::of(model.t_world_base());
        let joints = model.joints();
        let first = joints.first().map_or(base, |j| base.mul(&j.placement));
        let factors: Vec<Factor> = joints.iter().skip(1).map(|j| Factor::of(&j.placement)).chain([Factor::of(model.t_last_tool())]).collect();
        let placements = &factors[..factors.len() - 1];
        let about_x = joints.iter().all(|j| j.kind == JointKind::Revolute) && placements.iter().all(|f| f.rot != ROT_GENERAL);
        Self { first, factors, about_x }
    }
}

/// Configurations per group of the one-pass chains: the lanes of one vector register.
#[cfg(target_feature = "avx512f")]
const LANES: usize = 8;
#[cfg(not(target_feature = "avx512f"))]
const LANES: usize = 4;

/// One quantity of a group of configurations (a vector register).
type G = [f64; LANES];

/// The lanes of group `g` of a block's quantity.
#[inline(always)]
fn lanes(v: &V, g: usize) -> G {
    std::array::from_fn(|i| v[g * LANES + i])
}

/// `a * b + c` lane by lane, fused.
#[inline(always)]
fn fma<const L: usize>(a: &[f64; L], b: &[f64; L], c: &[f64; L]) -> [f64; L] {
    std::array::from_fn(|i| a[i].mul_add(b[i], c[i]))
}

/// `a * b + c` lane by lane with a constant `b`, fused.
#[inline(always)]
fn fma_by<const L: usize>(a: &[f64; L], b: f64, c: &[f64; L]) -> [f64; L] {
    std::array::from_fn(|i| a[i].mul_add(b, c[i]))
}

/// A vector of groups negated.
#[inline(always)]
fn negated<const L: usize>(a: &[[f64; L]; 3]) -> [[f64; L]; 3] {
    a.map(|v| v.map(|x| -x))
}

/// The tool frames of a block for a chain of `N` revolute joints whose placements 2..N rotate about x only
/// (`factors`: those placements; `tool`: the tool's factor; `sn`, `cs`: the sines and cosines of the joint
/// angles, per joint), the whole chain in one pass over the configurations, a group of [`LANES`] at a time,
/// the frame in registers (the joint-by-joint [`step`]s store and reload it at every joint), each group's
/// frames handed to `put(group, frames)`.
#[inline(always)]
fn revolute_about_x<const N: usize>(first: &Frame, factors: &[Factor], tool: &Factor, sn: &[V], cs: &[V], mut put: impl FnMut(usize, &[[G; 3]; 4])) {
    let (factors, sn, cs) = (&factors[..N - 1], &sn[..N], &cs[..N]);
    for g in 0..BLOCK / LANES {
        let frame = chain_about_x(first, factors, |i| (lanes(&sn[i], g), lanes(&cs[i], g)), |_, _, _| {});
        put(g, &times_factor(frame, tool));
    }
}

/// `frame · f` for a constant factor (the tool) in registers, for both batch chains: the arithmetic of
/// [`step`] with `MOTION_NONE`, the terms the factor's exact zeros and ones make vanish left out.
#[inline(always)]
fn times_factor<const L: usize>(frame: [[[f64; L]; 3]; 4], f: &Factor) -> [[[f64; L]; 3]; 4] {
    let [x, y, z, mut p] = frame;
    let (a, b) = ([x, y, z], &f.b);
    let scaled = |v: &[f64; L], k: f64| v.map(|x| x * k);
    let dense = |j: usize| -> [[f64; L]; 3] { std::array::from_fn(|r| fma_by(&a[2][r], b[j][2], &fma_by(&a[1][r], b[j][1], &scaled(&a[0][r], b[j][0])))) };
    let yz = |j: usize| -> [[f64; L]; 3] { std::array::from_fn(|r| fma_by(&a[2][r], b[j][2], &scaled(&a[1][r], b[j][1]))) };
    let [x, y, z] = match f.rot {
        ROT_IDENTITY => a,
        ROT_ABOUT_X | ROT_QUARTER_X => [a[0], yz(1), yz(2)],
        _ => [dense(0), dense(1), dense(2)],
    };
    for k in 0..3 {
        if f.origin & (1 << k) != 0 {
            p = std::array::from_fn(|r| fma_by(&a[k][r], b[3][k], &p[r]));
        }
    }
    [x, y, z, p]
}

/// The body of [`revolute_about_x`] for group `g` of a block: the frame of the last joint (x, y, z axes
/// and origin, rows of groups), each joint's z axis and origin handed to `each(joint, z, p)` on the way.
/// The arithmetic of [`step`] with `ROT_ABOUT_X` without the terms a placement's exact zeros and ones
/// make vanish, chosen joint by joint (its rotation class and origin components): the same values up to
/// the sign of zeros. The choices are the same for every group, so their branches are predicted.
#[inline(always)]
fn chain_about_x<const L: usize>(
    first: &Frame,
    factors: &[Factor],
    sin_cos: impl Fn(usize) -> ([f64; L], [f64; L]),
    mut each: impl FnMut(usize, &[[f64; L]; 3], &[[f64; L]; 3]),
) -> [[[f64; L]; 3]; 4] {
    let f = &first.c;
    // joint 1: the first frame, the same for every configuration, turned
    let (s, k) = sin_cos(0);
    let mut x: [[f64; L]; 3] = std::array::from_fn(|r| fma_by(&k, f[0][r], &s.map(|v| v * f[1][r])));
    let mut y: [[f64; L]; 3] = std::array::from_fn(|r| fma_by(&k, f[1][r], &s.map(|v| -(v * f[0][r]))));
    let mut z: [[f64; L]; 3] = std::array::from_fn(|r| [f[2][r]; L]);
    let mut p: [[f64; L]; 3] = std::array::from_fn(|r| [f[3][r]; L]);
    each(0, &z, &p);
    for (i, fi) in factors.iter().enumerate() {
        let b = &fi.b;
        let a = [x, y, z];
        for k in 0..3 {
            if fi.origin & (1 << k) != 0 {
                p = std::array::from_fn(|r| fma_by(&a[k][r], b[3][k], &p[r]));
            }
        }
        // the y axis turned about x; z in place
        let y1 = match fi.rot {
            ROT_IDENTITY => y,
            // (y, z) -> (z, -y) for +90 deg, (-z, y) for -90 deg
            ROT_QUARTER_X if b[1][2] > 0.0 => {
                z = negated(&a[1]);
                a[2]
            }
            ROT_QUARTER_X => {
                z = a[1];
                negated(&a[2])
            }
            _ => {
                z = std::array::from_fn(|r| fma_by(&a[2][r], b[2][2], &a[1][r].map(|v| v * b[2][1])));
                std::array::from_fn(|r| fma_by(&a[2][r], b[1][2], &a[1][r].map(|v| v * b[1][1])))
            }
        };
        let (s, k) = sin_cos(i + 1);
        y = std::array::from_fn(|r| fma(&k, &y1[r], &std::array::from_fn(|l| -(s[l] * x[r][l]))));
        x = std::array::from_fn(|r| fma(&k, &x[r], &std::array::from_fn(|l| s[l] * y1[r][l])));
        each(i + 1, &z, &p);
    }
    [x, y, z, p]
}

/// The frames of [`jacobian_about_x`]'s const parameter, as [`JacobianFrame`].
const FRAME_LWA: u8 = 0;
const FRAME_WORLD: u8 = 1;
const FRAME_BASE: u8 = 2;
const FRAME_LOCAL: u8 = 3;

const fn frame_of(f: u8) -> JacobianFrame {
    match f {
        FRAME_WORLD => JacobianFrame::World,
        FRAME_BASE => JacobianFrame::Base,
        FRAME_LOCAL => JacobianFrame::Local,
        _ => JacobianFrame::LocalWorldAligned,
    }
}

/// The tool Jacobians of a block (into `jac[r * N + k]`: row r, column k; the frame `FRAME`) for the chains
/// of [`revolute_about_x`], in one pass over the configurations: the chain of a group in registers, each
/// joint's origin and z axis kept as the chain passes it, then per configuration of the group the tool
/// (`tool`, as [`Frame::mul`]) and the columns (as [`column`]: the values of
/// [`jacobian_row_major_unchecked`] up to the sign of zeros), stored lane by lane. `base`: the base frame's axes (for `FRAME_BASE`).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
fn jacobian_about_x<const N: usize, const FRAME: u8>(
    first: &Frame,
    factors: &[Factor],
    tool: &Factor,
    base: &[[f64; 3]; 3],
    sn: &[V],
    cs: &[V],
    jac: &mut [V],
) {
    let (factors, sn, cs, jac, b) = (&factors[..N - 1], &sn[..N], &cs[..N], &mut jac[..6 * N], &tool.b);
    let frame = frame_of(FRAME);
    for g in 0..BLOCK / LANES {
        let (mut og, mut zg) = ([[[0.0; LANES]; 3]; N], [[[0.0; LANES]; 3]; N]);
        let frame_g = chain_about_x(
            first,
            factors,
            |i| (lanes(&sn[i], g), lanes(&cs[i], g)),
            |i, zi, pi| {
                zg[i] = *zi;
                og[i] = *pi;
            },
        );
        for m in 0..LANES {
            let l = g * LANES + m;
            let lane = |v: &[G; 3]| -> [f64; 3] { std::array::from_fn(|r| v[r][m]) };
            let (o, zs): ([[f64; 3]; N], [[f64; 3]; N]) = (std::array::from_fn(|i| lane(&og[i])), std::array::from_fn(|i| lane(&zg[i])));
            let [x, y, z, p] = frame_g.each_ref().map(lane);
            let a = [x, y, z];
            let tp: [f64; 3] = std::array::from_fn(|r| a[2][r].mul_add(b[3][2], a[1][r].mul_add(b[3][1], a[0][r].mul_add(b[3][0], p[r]))));
            let axes: Option<[[f64; 3]; 3]> = match FRAME {
                FRAME_LOCAL => Some(std::array::from_fn(|j| std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r].mul_add(b[j][1], a[0][r] * b[j][0]))))),
                FRAME_BASE => Some(*base),
                _ => None,
            };
            for k in 0..N {
                let col = column(JointKind::Revolute, o[k], zs[k], tp, frame, axes.as_ref());
                for r in 0..6 {
                    jac[r * N + k][l] = col[r];
                }
            }
        }
    }
}

/// Write a block's Jacobians (`jac[i][configuration]`, `i` the index in the row-major 6 x n matrix) as
/// row-major matrices (`out`: up to BLOCK x 6n): four configurations at a time by transposes in AVX
/// shuffles where the build has AVX, the rest value by value.
#[inline(always)]
fn write_jacobians<const N: usize>(jac: &[V], out: &mut [f64]) {
    let per = 6 * N;
    let done = write_jacobians_avx::<N>(jac, out);
    for (l, o) in out.chunks_exact_mut(per).enumerate().skip(done) {
        for (i, v) in o.iter_mut().enumerate() {
            *v = jac[i][l];
        }
    }
}

/// [`write_jacobians`] with streaming stores ([`crate::stream`]): two configurations at a time, each
/// configuration's 6n values (an even count) stored in order as pairs, from 2x2 transposes in 128-bit
/// registers.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn write_jacobians_streamed<const N: usize>(jac: &[V], out: &mut [f64]) {
    use safe_arch::{load_unaligned_m128d as load, unpack_high_m128d as hi, unpack_low_m128d as lo};
    let (per, jac) = (6 * N, &jac[..6 * N]);
    let done = 2 * (out.len() / (2 * per));
    let mut pairs = out.chunks_exact_mut(2 * per);
    for (g, o) in (&mut pairs).enumerate() {
        let l0 = 2 * g;
        let load2 = |i: usize| jac[i][l0..].first_chunk::<2>().map_or(safe_arch::zeroed_m128d(), load);
        let (first, second) = o.split_at_mut(per);
        crate::stream::pairs(first, per / 2, |i| lo(load2(2 * i), load2(2 * i + 1)));
        crate::stream::pairs(second, per / 2, |i| hi(load2(2 * i), load2(2 * i + 1)));
    }
    for (l, o) in pairs.into_remainder().chunks_exact_mut(per).enumerate() {
        for (i, v) in o.iter_mut().enumerate() {
            *v = jac[i][done + l];
        }
    }
}

/// The groups of four configurations of [`write_jacobians`]; returns the number of configurations written.
#[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx"))]
#[inline(always)]
fn write_jacobians_avx<const N: usize>(jac: &[V], out: &mut [f64]) -> usize {
    use safe_arch::{cast_to_m128d_from_m256d as low, extract_m128d_from_m256d as high, store_unaligned_m128d as store2};
    use safe_arch::{load_unaligned_m256d as load, permute2z_m256d as join, store_unaligned_m256d as store};
    use safe_arch::{unpack_hi_m256d as hi, unpack_lo_m256d as lo};
    let (per, jac) = (6 * N, &jac[..6 * N]);
    let mut groups = out.chunks_exact_mut(4 * per);
    for (g, o) in (&mut groups).enumerate() {
        let l0 = 4 * g;
        let load4 = |i: usize| jac[i][l0..].first_chunk::<4>().map_or(safe_arch::zeroed_m256d(), load);
        for r in 0..6 {
            let i0 = N * r;
            let mut k = 0;
            // columns k..k+4 of row r of the four configurations: a 4x4 transpose
            while k + 4 <= N {
                let (a, b, c, d) = (load4(i0 + k), load4(i0 + k + 1), load4(i0 + k + 2), load4(i0 + k + 3));
                let (ab0, ab1, cd0, cd1) = (lo(a, b), hi(a, b), lo(c, d), hi(c, d));
                let rows = [join::<0x20>(ab0, cd0), join::<0x20>(ab1, cd1), join::<0x31>(ab0, cd0), join::<0x31>(ab1, cd1)];
                for (i, v) in rows.into_iter().enumerate() {
                    if let Some(d) = o[per * i + i0 + k..].first_chunk_mut::<4>() {
                        store(d, v);
                    }
                }
                k += 4;
            }
            // two columns: the unpacks' halves
            while k + 2 <= N {
                let (a, b) = (load4(i0 + k), load4(i0 + k + 1));
                let (ab0, ab1) = (lo(a, b), hi(a, b));
                let pairs = [low(ab0), low(ab1), high::<1>(ab0), high::<1>(ab1)];
                for (i, v) in pairs.into_iter().enumerate() {
                    if let Some(d) = o[per * i + i0 + k..].first_chunk_mut::<2>() {
                        store2(d, v);
                    }
                }
                k += 2;
            }
            if k < N {
                for i in 0..4 {
                    o[per * i + i0 + k] = jac[i0 + k][l0 + i];
                }
            }
        }
    }
    4 * (out.len() / (4 * per))
}

/// Without AVX: none (the caller writes every configuration value by value).
#[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx")))]
#[inline(always)]
fn write_jacobians_avx<const N: usize>(_: &[V], _: &mut [f64]) -> usize {
    0
}

/// `c <- c · b · M(s)` for a block (`sn`, `cs`: the sines and cosines of `s` for `MOTION_RZ`): the
/// arithmetic of [`Frame::mul`] without the terms `ROT` and `ORIGIN` say are exact zeros or ones, then of
/// [`Frame::motion`].
#[inline(never)]
fn step<const ROT: u8, const ORIGIN: u8, const MOTION: u8>(c: &mut Frames, b: &[[f64; 3]; 4], s: &V, sn: &V, cs: &V) {
    for l in 0..BLOCK {
        let a: [[f64; 3]; 4] = std::array::from_fn(|j| std::array::from_fn(|r| c[j][r][l]));
        let dense = |j: usize| -> [f64; 3] { std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r].mul_add(b[j][1], a[0][r] * b[j][0]))) };
        let yz = |j: usize| -> [f64; 3] { std::array::from_fn(|r| a[2][r].mul_add(b[j][2], a[1][r] * b[j][1])) };
        let (mut x, mut y, z) = match ROT {
            ROT_IDENTITY => (a[0], a[1], a[2]),
            ROT_ABOUT_X => (a[0], yz(1), yz(2)),
            _ => (dense(0), dense(1), dense(2)),
        };
        let mut p = a[3];
        for k in 0..3 {
            if ORIGIN & (1 << k) != 0 {
                p = std::array::from_fn(|r| a[k][r].mul_add(b[3][k], p[r]));
            }
        }
        match MOTION {
            MOTION_RZ => {
                let (x0, y0) = (x, y);
                x = std::array::from_fn(|r| cs[l].mul_add(x0[r], sn[l] * y0[r]));
                y = std::array::from_fn(|r| cs[l].mul_add(y0[r], -(sn[l] * x0[r])));
            }
            MOTION_TZ => p = std::array::from_fn(|r| z[r].mul_add(s[l], p[r])),
            _ => {}
        }
        for r in 0..3 {
            c[0][r][l] = x[r];
            c[1][r][l] = y[r];
            c[2][r][l] = z[r];
            c[3][r][l] = p[r];
        }
    }
}

/// [`step`] for a factor known only at run time.
fn step_factor(c: &mut Frames, f: &Factor, motion: u8, s: &V, sn: &V, cs: &V) {
    macro_rules! by_origin {
        ($rot:expr, $motion:expr) => {
            match f.origin {
                0 => step::<$rot, 0, $motion>(c, &f.b, s, sn, cs),
                1 => step::<$rot, 1, $motion>(c, &f.b, s, sn, cs),
                2 => step::<$rot, 2, $motion>(c, &f.b, s, sn, cs),
                3 => step::<$rot, 3, $motion>(c, &f.b, s, sn, cs),
                4 => step::<$rot, 4, $motion>(c, &f.b, s, sn, cs),
                5 => step::<$rot, 5, $motion>(c, &f.b, s, sn, cs),
                6 => step::<$rot, 6, $motion>(c, &f.b, s, sn, cs),
                _ => step::<$rot, 7, $motion>(c, &f.b, s, sn, cs),
            }
        };
    }
    macro_rules! by_rot {
        ($motion:expr) => {
            match f.rot {
                ROT_IDENTITY => by_origin!(ROT_IDENTITY, $motion),
                ROT_ABOUT_X | ROT_QUARTER_X => by_origin!(ROT_ABOUT_X, $motion),
                _ => by_origin!(ROT_GENERAL, $motion),
            }
        };
    }
    match motion {
        MOTION_RZ => by_rot!(MOTION_RZ),
        MOTION_TZ => by_rot!(MOTION_TZ),
        _ => by_rot!(MOTION_NONE),
    }
}

/// The workspace of a block: its frames, the joint values and their sines and cosines, and (for the
/// Jacobian, `per_row` values per configuration) the block's results, written here (in the L1 cache) and
/// then copied to the caller's array at once: element by element into memory that is not in the cache, the
/// Jacobian's scattered stores would wait on the memory, 8 bytes at a time.
struct Block {
    c: Frames,
    /// `s[joint][configuration]`: the joint values plus the offsets; `sn`, `cs` their sines and cosines.
    s: Vec<V>,
    sn: Vec<V>,
    cs: Vec<V>,
    stage: Vec<f64>,
    /// Whether the block's results go out with streaming stores ([`crate::stream::wanted`] of the batch's output).
    stream: bool,
}

impl Block {
    fn new(n: usize, per_row: usize, stream: bool) -> Box<Self> {
        let v = || vec![[0.0; BLOCK]; n.max(1)];
        Box::new(Self { c: [[[0.0; BLOCK]; 3]; 4], s: v(), sn: v(), cs: v(), stage: vec![0.0; per_row * BLOCK], stream })
    }
}

/// The joint values of a block of configurations (`qb`: BLOCK x n row-major; `N` > 0 promises n == N, so
/// that the transposition of `qb` has a constant stride) plus the offsets into `s[joint][configuration]`.
/// False if a value of `qb` is not finite.
#[inline(always)]
#[must_use]
fn load_block<const N: usize>(model: &Model, qb: &[f64], s: &mut [V]) -> bool {
    let n = if N > 0 { N } else { model.nq() };
    let (qb, joints, s) = (&qb[..BLOCK * n], &model.joints()[..n], &mut s[..n]);
    // the transposition, once per block, and the finiteness check in the same pass (`x * 0` is NaN
    // exactly for an infinite or NaN `x`)
    let mut bad = [0.0f64; BLOCK];
    for l in 0..BLOCK {
        for i in 0..n {
            let v = qb[l * n + i];
            bad[l] += v * 0.0;
            s[i][l] = v + joints[i].offset;
        }
    }
    bad.iter().all(|b| *b == 0.0)
}

/// The joint angles of a block (as [`load_block`]) and their sines and cosines, every joint's in one pass (no
/// short remainder per joint), for the one-pass chains of revolute joints. False if a value of `qb` is not
/// finite: looked for only when an angle falls out of the sine kernel's reduced range, as a non-finite one does
/// (no check in the transposition: `fk_batch` 1e5 one core 5.56 -> 5.48 ms).
#[inline(always)]
#[must_use]
fn load_angles<const N: usize>(model: &Model, qb: &[f64], w: &mut Block) -> bool {
    let n = if N > 0 { N } else { model.nq() };
    let (qb, joints, s) = (&qb[..BLOCK * n], &model.joints()[..n], &mut w.s[..n]);
    for l in 0..BLOCK {
        for i in 0..n {
            s[i][l] = qb[l * n + i] + joints[i].offset;
        }
    }
    sin_cos_slices(s.as_flattened(), w.sn[..n].as_flattened_mut(), w.cs[..n].as_flattened_mut()) || qb.iter().all(|v| v.is_finite())
}

/// The joint frames of a block of configurations (`qb`: BLOCK x n row-major; `N` > 0 promises n == N, so
/// that the transposition of `qb` has a constant stride), joints 1..=`cols`, each handed to
/// `each(i, frames)`; `w.c` ends as the frame of joint `cols`. False (and nothing computed) if a value of
/// `qb` is not finite.
#[inline(always)]
#[must_use]
fn walk_block<const N: usize>(model: &Model, chain: &Chain, qb: &[f64], cols: usize, w: &mut Block, mut each: impl FnMut(usize, &Frames)) -> bool {
    if !load_block::<N>(model, qb, &mut w.s) {
        return false;
    }
    for (i, j) in model.joints().iter().enumerate().take(cols) {
        let s = &w.s[i];
        let motion = if j.kind == JointKind::Revolute {
            sin_cos_slices(s, &mut w.sn[0], &mut w.cs[0]);
            MOTION_RZ
        } else {
            MOTION_TZ
        };
        if i == 0 {
            // the first joint's frame before its motion is the same for every configuration
            for (ck, fk) in w.c.iter_mut().zip(&chain.first.c) {
                for (ckr, v) in ck.iter_mut().zip(fk) {
                    ckr.fill(*v);
                }
            }
            step_factor(&mut w.c, &IDENTITY, motion, s, &w.sn[0], &w.cs[0]);
        } else {
            step_factor(&mut w.c, &chain.factors[i - 1], motion, s, &w.sn[0], &w.cs[0]);
        }
        each(i, &w.c);
    }
    true
}

/// The identity as a [`Factor`].
const IDENTITY: Factor = Factor { b: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0; 3]], rot: ROT_IDENTITY, origin: 0 };

/// Write a block's frames as row-major 4x4 matrices (`out`: up to BLOCK x 16), four configurations at a
/// time by 4x4 transposes.
#[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
#[inline(always)]
fn write_block(c: &Frames, out: &mut [f64]) {
    let base = 4 * (out.len() / 64);
    let mut groups = out.chunks_exact_mut(64);
    #[cfg(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx"))]
    for (g, o) in (&mut groups).enumerate() {
        // the transposes in AVX shuffles (the compiler's own code moved the values one by one): per row r
        // of four configurations, the unpacks pair (x, y) and (z, p) of configurations 0/2 and 1/3, the
        // 128-bit permutes join the pairs into the four rows, each stored whole
        use safe_arch::{load_unaligned_m256d as load, permute2z_m256d as join, store_unaligned_m256d as store};
        use safe_arch::{unpack_hi_m256d as hi, unpack_lo_m256d as lo};
        let l0 = 4 * g;
        let load4 = |j: usize, r: usize| c[j][r][l0..].first_chunk::<4>().map_or(safe_arch::zeroed_m256d(), load);
        for r in 0..3 {
            let (x, y, z, p) = (load4(0, r), load4(1, r), load4(2, r), load4(3, r));
            let (xy0, xy1, zp0, zp1) = (lo(x, y), hi(x, y), lo(z, p), hi(z, p));
            let rows = [join::<0x20>(xy0, zp0), join::<0x20>(xy1, zp1), join::<0x31>(xy0, zp0), join::<0x31>(xy1, zp1)];
            for (i, row) in rows.into_iter().enumerate() {
                if let Some(d) = o[16 * i + 4 * r..].first_chunk_mut::<4>() {
                    store(d, row);
                }
            }
        }
        for i in 0..4 {
            o[16 * i + 12..16 * i + 16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        }
    }
    #[cfg(not(all(any(target_arch = "x86", target_arch = "x86_64"), target_feature = "avx")))]
    for (g, o) in (&mut groups).enumerate() {
        let l0 = 4 * g;
        for r in 0..3 {
            // m[j][i]: column j, row r of configuration l0 + i
            let m: [[f64; 4]; 4] = std::array::from_fn(|j| std::array::from_fn(|i| c[j][r][l0 + i]));
            for i in 0..4 {
                o[16 * i + 4 * r..16 * i + 4 * r + 4].copy_from_slice(&[m[0][i], m[1][i], m[2][i], m[3][i]]);
            }
        }
        for i in 0..4 {
            o[16 * i + 12..16 * i + 16].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
        }
    }
    for (i, o) in groups.into_remainder().chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = c[j][r][base + i];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// [`write_block`] with streaming stores ([`crate::stream`]), two configurations at a time by 2x2
/// transposes in 128-bit registers (no lane-crossing shuffles), each configuration's 16 values stored in
/// order so that its cache lines fill whole in the write-combining buffers.
#[cfg(all(target_arch = "x86_64", not(target_feature = "avx512f")))]
#[inline(always)]
fn write_block_streamed(c: &Frames, out: &mut [f64]) {
    use safe_arch::{load_unaligned_m128d as load, m128d, set_m128d as set, unpack_high_m128d as hi, unpack_low_m128d as lo};
    let base = 2 * (out.len() / 32);
    let mut pairs = out.chunks_exact_mut(32);
    for (g, o) in (&mut pairs).enumerate() {
        let l0 = 2 * g;
        let load2 = |j: usize, r: usize| c[j][r][l0..].first_chunk::<2>().map_or(safe_arch::zeroed_m128d(), load);
        // rows[i][r]: row r of configuration l0 + i as two halves, then the bottom row
        let mut rows = [[(safe_arch::zeroed_m128d(), safe_arch::zeroed_m128d()); 4]; 2];
        for r in 0..3 {
            let (x, y, z, p) = (load2(0, r), load2(1, r), load2(2, r), load2(3, r));
            rows[0][r] = (lo(x, y), lo(z, p));
            rows[1][r] = (hi(x, y), hi(z, p));
        }
        let bottom: (m128d, m128d) = (safe_arch::zeroed_m128d(), set(1.0, 0.0));
        rows[0][3] = bottom;
        rows[1][3] = bottom;
        // configuration k / 8, row (k % 8) / 2, its first or second half
        crate::stream::pairs(o, 16, |k| {
            let (a, b) = rows[k / 8][(k % 8) / 2];
            if k % 2 == 0 { a } else { b }
        });
    }
    for (i, o) in pairs.into_remainder().chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = c[j][r][base + i];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// Tool poses of the rows of one chunk (`q`: rows x n, `out`: rows x 16), a block at a time, the last
/// block padded.
#[inline(never)]
fn tool_pose_chunk<const N: usize>(model: &Model, chain: &Chain, q: &[f64], w: &mut Block, out: &mut [f64]) -> bool {
    let n = model.nq();
    let tool = &chain.factors[n - 1];
    let mut padded = Vec::new();
    let mut writer = Writer::new(out, w.stream);
    for (k, qb) in q.chunks(BLOCK * n).enumerate() {
        let (row, rows) = (k * BLOCK, qb.len() / n);
        let qb = match block_of(qb, n, &mut padded, &mut out[16 * row..16 * (row + rows)], |qr, o| write_pose(&tool_pose_unchecked(model, qr), o)) {
            Rows::Block(qb) => qb,
            Rows::Written => continue,
            Rows::NotFinite => return false,
        };
        match chain.about_x {
            true if N > 0 => {
                if !load_angles::<N>(model, qb, w) {
                    return false;
                }
                let (first, f, sn, cs) = (&chain.first, &chain.factors, &w.sn, &w.cs);
                revolute_about_x::<N>(first, f, tool, sn, cs, |g, frame| writer.put(&mut w.c, out, row, rows, g, frame));
                writer.block_done(&w.c, out, row, rows);
            }
            _ => {
                if !walk_block::<N>(model, chain, qb, n, w, |_, _| {}) {
                    return false;
                }
                // the tool group by group, as in the one-pass chain
                for g in 0..BLOCK / LANES {
                    let frame: [[G; 3]; 4] = std::array::from_fn(|j| std::array::from_fn(|r| lanes(&w.c[j][r], g)));
                    writer.put(&mut w.c, out, row, rows, g, &times_factor(frame, tool));
                }
                writer.block_done(&w.c, out, row, rows);
            }
        }
    }
    writer.finish(out);
    true
}

/// Where a chunk's tool poses go, straight into the caller's array as whole rows in order (a copy through
/// an L1 stage cost a fifth of the time): with AVX-512, eight at a time in whole cache lines
/// ([`avx512::Lines`]); else a block's frames are gathered in the block's workspace and written four at a
/// time ([`write_block`], or [`write_block_streamed`] for an output bigger than the cache).
struct Writer {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
    lines: avx512::Lines,
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
    stream: bool,
}

impl Writer {
    fn new(out: &[f64], stream: bool) -> Self {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        return Self { lines: avx512::Lines::new(out, stream) };
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        {
            let _ = out;
            Self { stream }
        }
    }

    /// The frames of group `g` of the block of rows `row..row + rows` (the group's lanes past the block's
    /// rows are padding); `c`: the block's frames.
    #[inline(always)]
    #[allow(unused_variables)]
    fn put(&mut self, c: &mut Frames, out: &mut [f64], row: usize, rows: usize, g: usize, frame: &[[G; 3]; 4]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        if LANES * g < rows {
            self.lines.put(out, row + LANES * g, frame, (rows - LANES * g).min(LANES));
        }
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        for (cj, fj) in c.iter_mut().zip(frame) {
            for (cr, fr) in cj.iter_mut().zip(fj) {
                cr[g * LANES..(g + 1) * LANES].copy_from_slice(fr);
            }
        }
    }

    /// The block of rows `row..row + rows` is computed (its frames in `c` where [`Writer::put`] keeps them).
    #[inline(always)]
    #[allow(unused_variables)]
    fn block_done(&mut self, c: &Frames, out: &mut [f64], row: usize, rows: usize) {
        #[cfg(not(all(target_arch = "x86_64", target_feature = "avx512f")))]
        {
            let ob = &mut out[16 * row..16 * (row + rows)];
            #[cfg(target_arch = "x86_64")]
            if self.stream {
                write_block_streamed(c, ob);
                return;
            }
            write_block(c, ob);
        }
    }

    #[inline(always)]
    #[allow(unused_variables)]
    fn finish(self, out: &mut [f64]) {
        #[cfg(all(target_arch = "x86_64", target_feature = "avx512f"))]
        self.lines.finish(out);
    }
}

/// The first non-finite value of a batch of rows of `n` (after a chunk found one: the error names the first
/// of all, by its row and its index in the row).
fn non_finite(qs: &[f64], n: usize) -> Error {
    match crate::error::check_finite_rows("q", qs, n) {
        Err(e) => e,
        Ok(()) => Error::InvalidArgument { what: "q batch".into(), expected: "finite values".into(), got: "a non-finite value".into() },
    }
}

/// Batch tool poses: `qs` holds N configurations row-major (N x n), `out` N row-major 4x4 matrices (N x 16).
/// Runs on rayon's pool (or as [`crate::parallel::with_threads`] says), [`BLOCK`] configurations at a time
/// in structure-of-arrays form so that every operation is a SIMD one, with fused multiply-adds. Values must
/// be finite (checked block by block in the pass that reads them; after an error `out` is partly written).
/// Same values as [`tool_pose`] up to the sign of zeros.
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::{tool_pose, tool_pose_batch}};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs: Vec<f64> = (0..40).map(|k| 0.1 * k as f64).collect(); // 20 configurations
/// let mut out = vec![0.0; 20 * 16];
/// tool_pose_batch(&m, &qs, &mut out).unwrap();
/// assert_eq!(out[16 * 7 + 3], tool_pose(&m, &qs[14..16]).unwrap().translation.x);
/// ```
pub fn tool_pose_batch(model: &Model, qs: &[f64], out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = qs.len().checked_div(n).unwrap_or(out.len() / 16);
    check_len("q batch (N*n values)", count * n, qs.len())?;
    check_len("output (N*16 values)", count * 16, out.len())?;
    if n == 0 {
        let t = tool_pose_unchecked(model, &[]);
        out.chunks_exact_mut(16).for_each(|o| write_pose(&t, o));
        return Ok(());
    }
    if count <= TAIL_ROWS {
        return small_batch(qs, n, out, 16, |q, o| write_pose(&tool_pose_unchecked(model, q), o));
    }
    let chain = model.chain();
    let stream = crate::stream::wanted(out);
    crate::parallel::try_for_each_chunk_init(
        out,
        16 * CHUNK,
        || Block::new(n, 0, stream),
        |w, k, o| {
            let q = &qs[k * CHUNK * n..(k * CHUNK + o.len() / 16) * n];
            let finite = match n {
                6 => tool_pose_chunk::<6>(model, chain, q, w, o),
                7 => tool_pose_chunk::<7>(model, chain, q, w, o),
                _ => tool_pose_chunk::<0>(model, chain, q, w, o),
            };
            if stream {
                crate::stream::fence();
            }
            if finite { Ok(()) } else { Err(non_finite(qs, n)) }
        },
    )
}

/// The workspace of the batch Jacobian: a block's frames and its joints' origins and z axes (`oz[joint]`:
/// `[o_x, o_y, o_z, z_x, z_y, z_z][configuration]`).
struct JacobianWork {
    block: Box<Block>,
    oz: Vec<[V; 6]>,
    /// The block's Jacobians of [`jacobian_about_x`] (`jac[row * n + column][configuration]`).
    jac: Vec<V>,
}

/// Jacobians (as [`jacobian_row_major_unchecked`]) of the rows of one chunk (`q`: rows x n, `out`: rows x 6n).
#[inline(never)]
fn jacobian_chunk<const N: usize>(
    model: &Model,
    chain: &Chain,
    q: &[f64],
    frame: JacobianFrame,
    joint: Option<usize>,
    w: &mut JacobianWork,
    out: &mut [f64],
) -> bool {
    let n = model.nq();
    let cols = joint.map_or(n, |j| j + 1);
    let b = Frame::of(model.t_world_base());
    let base = [b.col(0), b.col(1), b.col(2)];
    let mut padded = Vec::new();
    for (qb, ob) in q.chunks(BLOCK * n).zip(out.chunks_mut(6 * n * BLOCK)) {
        let qb = match block_of(qb, n, &mut padded, ob, |qr, o| jacobian_row_major_unchecked(model, qr, frame, joint, o)) {
            Rows::Block(qb) => qb,
            Rows::Written => continue,
            Rows::NotFinite => return false,
        };
        if let (true, true, None) = (chain.about_x, N > 0, joint) {
            let b = &mut *w.block;
            if !load_angles::<N>(model, qb, b) {
                return false;
            }
            let (first, f, tool, sn, cs, jac) = (&chain.first, &chain.factors, &chain.factors[n - 1], &b.sn, &b.cs, &mut w.jac);
            match frame {
                JacobianFrame::LocalWorldAligned => jacobian_about_x::<N, FRAME_LWA>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::World => jacobian_about_x::<N, FRAME_WORLD>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::Base => jacobian_about_x::<N, FRAME_BASE>(first, f, tool, &base, sn, cs, jac),
                JacobianFrame::Local => jacobian_about_x::<N, FRAME_LOCAL>(first, f, tool, &base, sn, cs, jac),
            }
            #[cfg(target_arch = "x86_64")]
            if b.stream {
                write_jacobians_streamed::<N>(jac, ob);
                continue;
            }
            write_jacobians::<N>(jac, ob);
            continue;
        }
        let (b, oz) = (&mut *w.block, &mut w.oz);
        if !walk_block::<N>(model, chain, qb, cols, b, |i, c| oz[i] = [c[3][0], c[3][1], c[3][2], c[2][0], c[2][1], c[2][2]]) {
            return false;
        }
        if joint.is_none() {
            step_factor(&mut b.c, &chain.factors[n - 1], MOTION_NONE, &b.sn[0], &b.sn[0], &b.cs[0]);
        }
        let (c, stage) = (&b.c, &mut b.stage[..ob.len()]);
        let rows = ob.len() / (6 * n);
        for (k, j) in model.joints().iter().enumerate() {
            let ozk = &oz[k.min(cols - 1)];
            for l in 0..rows {
                let col = if k < cols {
                    let (o, z) = ([ozk[0][l], ozk[1][l], ozk[2][l]], [ozk[3][l], ozk[4][l], ozk[5][l]]);
                    let p = [c[3][0][l], c[3][1][l], c[3][2][l]];
                    let (v, w) = match j.kind {
                        JointKind::Revolute if frame == JacobianFrame::World => (cross(o, z), z),
                        JointKind::Revolute => (cross(z, [p[0] - o[0], p[1] - o[1], p[2] - o[2]]), z),
                        JointKind::Prismatic => (z, [0.0; 3]),
                    };
                    let axes = match frame {
                        JacobianFrame::Local => {
                            Some([[c[0][0][l], c[0][1][l], c[0][2][l]], [c[1][0][l], c[1][1][l], c[1][2][l]], [c[2][0][l], c[2][1][l], c[2][2][l]]])
                        }
                        JacobianFrame::Base => Some(base),
                        _ => None,
                    };
                    match axes {
                        None => [v[0], v[1], v[2], w[0], w[1], w[2]],
                        // R^T v: the rows of R^T are the columns of R
                        Some(a) => [dot(a[0], v), dot(a[1], v), dot(a[2], v), dot(a[0], w), dot(a[1], w), dot(a[2], w)],
                    }
                } else {
                    [0.0; 6]
                };
                for (r, v) in col.iter().enumerate() {
                    stage[6 * n * l + r * n + k] = *v;
                }
            }
        }
        ob.copy_from_slice(stage);
    }
    true
}

/// Batch Jacobians of the tool (`joint = None`) or of joint frame `joint` (0-based): `out` holds N row-major
/// 6 x n matrices (N x 6n), in `frame`; the values of [`jacobian_row_major_unchecked`] (up to the sign of
/// zeros), [`BLOCK`] configurations at a time as in [`tool_pose_batch`].
///
/// ```
/// use denavit_core::{builtin_planar2, kinematics::{jacobian_batch, jacobian_row_major_unchecked, JacobianFrame}};
/// let m = builtin_planar2(1.0, 1.0);
/// let qs: Vec<f64> = (0..22).map(|k| 0.1 * k as f64).collect(); // 11 configurations
/// let mut out = vec![0.0; 11 * 12];
/// jacobian_batch(&m, &qs, JacobianFrame::World, None, &mut out).unwrap();
/// let mut one = [0.0; 12];
/// jacobian_row_major_unchecked(&m, &qs[20..22], JacobianFrame::World, None, &mut one);
/// assert_eq!(&out[120..], &one);
/// ```
pub fn jacobian_batch(model: &Model, qs: &[f64], frame: JacobianFrame, joint: Option<usize>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    check_joint(model, joint)?;
    if n == 0 {
        return Ok(());
    }
    let count = qs.len() / n;
    check_len("q batch (N*n values)", count * n, qs.len())?;
    check_len("output (N*6n values)", count * 6 * n, out.len())?;
    if count <= TAIL_ROWS {
        return small_batch(qs, n, out, 6 * n, |q, o| jacobian_row_major_unchecked(model, q, frame, joint, o));
    }
    let chain = model.chain();
    let stream = crate::stream::wanted(out);
    crate::parallel::try_for_each_chunk_init(
        out,
        6 * n * CHUNK,
        || JacobianWork { block: Block::new(n, 6 * n, stream), oz: vec![[[0.0; BLOCK]; 6]; n], jac: vec![[0.0; BLOCK]; 6 * n] },
        |w, k, o| {
            let q = &qs[k * CHUNK * n..(k * CHUNK + o.len() / (6 * n)) * n];
            let finite = match n {
                6 => jacobian_chunk::<6>(model, chain, q, frame, joint, w, o),
                7 => jacobian_chunk::<7>(model, chain, q, frame, joint, w, o),
                _ => jacobian_chunk::<0>(model, chain, q, frame, joint, w, o),
            };
            if stream {
                crate::stream::fence();
            }
            if finite { Ok(()) } else { Err(non_finite(qs, n)) }
        },
    )
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    /// Outputs from the streaming threshold on are written with streaming stores (an aligned output) and
    /// equal, bit for bit, the plain stores' values (the same output one value off the alignment).
    #[test]
    fn streamed_outputs_equal_plain_ones() {
        use crate::spatial::Pose;
        use crate::{Convention, JointKind, Table};
        const H: f64 = std::f64::consts::FRAC_PI_2;
        // the KR5 of Hayat et al. (d, theta, a, alpha), and a 7th joint repeating the last row
        let kr5 = [0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, 0.0, 0.12, -H, 0.62, 0.0, 0.0, H, 0.0, 0.0, 0.0, -H, 0.115, 0.0, 0.0, 0.0];
        for n in [6, 7] {
            let p: Vec<f64> = (0..4 * n).map(|k| kr5[k.min(4 * 6 - 1 - (3 - k % 4))]).collect();
            let table = nalgebra::DMatrix::from_row_slice(n, 4, &p);
            let m = Table::new(Convention::Dh, table, vec![JointKind::Revolute; n], Pose::identity(), Pose::identity()).unwrap().to_model("m").unwrap();
            // an odd count past the threshold: the last block partial (more rows than the single path takes),
            // an unpaired last configuration
            let count = crate::stream::threshold() / (16 * 8) + 2 * super::BLOCK + super::TAIL_ROWS + 17;
            let qs: Vec<f64> = (0..count * n).map(|k| ((k as f64) * 0.618).sin() * 3.0).collect();
            for per in [16, 6 * n] {
                let buf = vec![0.0; per * count + 2];
                let start = buf.as_ptr().align_offset(16);
                let (mut streamed, mut plain) = (buf.clone(), buf);
                let (streamed, plain) = (&mut streamed[start..start + per * count], &mut plain[start + 1..start + 1 + per * count]);
                assert_eq!(crate::stream::wanted(streamed), cfg!(target_arch = "x86_64"));
                assert!(!crate::stream::wanted(plain));
                assert!(!crate::stream::with_plain_stores(|| crate::stream::wanted(streamed)));
                let run = |out: &mut [f64]| {
                    if per == 16 {
                        super::tool_pose_batch(&m, &qs, out)
                    } else {
                        super::jacobian_batch(&m, &qs, super::JacobianFrame::LocalWorldAligned, None, out)
                    }
                };
                crate::parallel::with_threads(Some(2), || run(streamed)).unwrap().unwrap();
                crate::parallel::with_threads(Some(1), || run(plain)).unwrap().unwrap();
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert!(bits(streamed) == bits(plain), "n = {n}, {per} values per configuration");
            }
        }
    }

    /// The one-pass kernel of DH-like chains (6 and 7 joints, offsets in x and z only or in all three
    /// components), the identity tool skipped, and the joint-by-joint kernel of a chain with a prismatic
    /// joint: every row of a batch (whole blocks, then a padded block or last rows through the single path)
    /// equal to the single-configuration path (`==`: up to the sign of zeros), including a row beyond the
    /// fast sine's range.
    #[test]
    fn batch_kernels_equal_the_single_path() {
        use crate::spatial::{Pose, rx, ry, trans};
        use crate::{Convention, JointKind, Table};
        const H: f64 = std::f64::consts::FRAC_PI_2;
        let r = JointKind::Revolute;
        let base = trans(0.1, -0.2, 0.3) * rx(0.2);
        let cases = [
            // d, theta, a, alpha: offsets in x and z; a tool turned about a general axis
            (Convention::Dh, vec![0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, -H, 0.12, -H], trans(0.01, 0.02, 0.1) * rx(0.3) * ry(-0.4)),
            (Convention::Dh, vec![0.4, 0.0, 0.18, -H, 0.0, 0.0, 0.6, 0.0, 0.0, -H, 0.12, -H], Pose::identity()),
            // alpha, a, theta, d: Rx(alpha) Tx(a) Tz(d) has an offset in y as well
            (Convention::Mdh, vec![0.0, 0.0, 0.0, 0.3, H, 0.1, -H, 0.15, 0.0, -0.4, 0.0, 0.0, 0.3, -0.39, 0.5, 0.1], trans(0.0, 0.0, 0.1)),
        ];
        let mut state = 7u64;
        let mut rand = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((state >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 6.0
        };
        for (convention, params, tool) in cases {
            let rows = params.len() / 4;
            for n in [6, 7] {
                // repeat the rows to n joints
                let p: Vec<f64> = (0..n).flat_map(|i| params[4 * (i % rows)..4 * (i % rows) + 4].to_vec()).collect();
                let table = nalgebra::DMatrix::from_row_slice(n, 4, &p);
                let mut kinds = vec![r; n];
                for prismatic in [false, true] {
                    if prismatic {
                        kinds[2] = JointKind::Prismatic;
                    }
                    let m = Table::new(convention, table.clone(), kinds.clone(), base, tool).unwrap().to_model("m").unwrap();
                    // the last rows: a padded block, or few enough for the single path (a one-row batch too)
                    for count in [2 * super::BLOCK + super::TAIL_ROWS + 9, 3 * super::BLOCK + 5, 1] {
                        let mut qs: Vec<f64> = (0..count * n).map(|_| rand()).collect();
                        if count > 70 {
                            qs[n * 70 + 1] = 3.0e5;
                        }
                        let mut out = vec![0.0; 16 * count];
                        crate::parallel::with_threads(Some(1), || super::tool_pose_batch(&m, &qs, &mut out)).unwrap().unwrap();
                        // the same values at every offset from a cache line (whole lines cut from two matrices' values)
                        let mut shifted = vec![f64::NAN; 16 * count + 8];
                        for offset in 0..8 {
                            let o = &mut shifted[offset..offset + 16 * count];
                            crate::parallel::with_threads(Some(1), || super::tool_pose_batch(&m, &qs, o)).unwrap().unwrap();
                            assert_eq!(o, &out, "{convention:?} n = {n} prismatic {prismatic}: the output {offset} values into the buffer");
                        }
                        for (q, o) in qs.chunks(n).zip(out.chunks(16)) {
                            let mut one = [0.0; 16];
                            // the joint-by-joint path (every product of every placement), and the single call
                            super::write_pose(&super::tool_pose_walk(&m, q), &mut one);
                            assert_eq!(o, &one, "{convention:?} n = {n} prismatic {prismatic} q = {q:?}");
                            let mut single = [0.0; 16];
                            super::write_pose(&super::tool_pose(&m, q).unwrap(), &mut single);
                            assert_eq!(single, one, "{convention:?} n = {n} prismatic {prismatic} q = {q:?}");
                        }
                        // the Jacobians (the one-pass kernel for the tool of a revolute chain, the joint-by-joint
                        // one for a joint frame), in every frame
                        for frame in
                            [super::JacobianFrame::LocalWorldAligned, super::JacobianFrame::World, super::JacobianFrame::Base, super::JacobianFrame::Local]
                        {
                            for joint in [None, Some(n - 3)] {
                                let mut jac = vec![0.0; 6 * n * count];
                                let run = || super::jacobian_batch(&m, &qs, frame, joint, &mut jac);
                                crate::parallel::with_threads(Some(1), run).unwrap().unwrap();
                                for (q, o) in qs.chunks(n).zip(jac.chunks(6 * n)) {
                                    let mut one = vec![0.0; 6 * n];
                                    super::jacobian_row_major_unchecked(&m, q, frame, joint, &mut one);
                                    assert_eq!(o, &one, "{convention:?} n = {n} prismatic {prismatic} {frame:?} {joint:?} q = {q:?}");
                                }
                            }
                        }
                    }
                    assert_eq!(super::Chain::of(&m).about_x, !prismatic);
                }
            }
        }
    }

    #[test]
    fn fused_jacobian_matches_data_jacobian() {
        use crate::spatial::{rx, trans};
        use crate::{Data, Joint, JointKind, Model};
        let joints = vec![
            Joint::new("a", JointKind::Revolute, rx(0.3) * trans(0.1, 0.2, 0.3)),
            Joint::new("b", JointKind::Prismatic, rx(-1.1) * trans(0.0, 0.4, 0.1)),
            Joint::new("c", JointKind::Revolute, rx(0.7) * trans(0.3, 0.0, -0.2)),
        ];
        let m = Model::new("m", trans(0.1, 0.0, 0.2) * rx(0.2), joints, trans(0.0, 0.1, 0.2), rx(0.4)).unwrap();
        let q = [0.4, 0.2, -0.9];
        let mut d = Data::new(&m);
        super::jacobian(&m, &mut d, &q, super::JacobianFrame::LocalWorldAligned).unwrap();
        let mut jac = vec![0.0; 18];
        let t = super::tool_pose_and_jacobian(&m, &q, &mut jac);
        assert_eq!(jac.as_slice(), d.jacobian.as_slice());
        assert_eq!(t, d.t_world_tool);
        // the row-major form of the bindings, in both frames
        for frame in [super::JacobianFrame::World, super::JacobianFrame::LocalWorldAligned, super::JacobianFrame::Base, super::JacobianFrame::Local] {
            super::jacobian(&m, &mut d, &q, frame).unwrap();
            let mut rm = vec![0.0; 18];
            super::jacobian_row_major_unchecked(&m, &q, frame, None, &mut rm);
            for r in 0..6 {
                for c in 0..3 {
                    assert!((rm[r * 3 + c] - d.jacobian[(r, c)]).abs() < 1e-15, "{r} {c}");
                }
            }
        }
    }
}
