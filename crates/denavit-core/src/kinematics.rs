//! Forward kinematics and the geometric Jacobian (docs/conventions.md, "The model").
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

use crate::error::{Result, check_len};
use crate::math::{sin_cos, sin_cos_lanes};
use crate::model::{Data, JointKind, Model};
use crate::spatial::Pose;
use nalgebra::{Matrix3, Rotation3, Translation3};
use rayon::prelude::*;

/// In which frame a Jacobian's rows are expressed (the reference point is always the tool origin).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JacobianFrame {
    /// `J_world_tool`: axes of the world frame.
    World,
    /// `J_base_tool`: axes of the robot's base frame (`R_world_baseᵀ J_world_tool`).
    Base,
    /// `J_tool_tool`: axes of the tool frame.
    Tool,
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
                c[j][l] = a[0][l] * b0 + a[1][l] * b1 + a[2][l] * b2;
            }
        }
        for l in 0..4 {
            c[3][l] = a[0][l] * v[0] + a[1][l] * v[1] + a[2][l] * v[2] + a[3][l];
        }
        Self { c }
    }
    /// `self · M(s)`: the joint motion `Rz(s)` or `Tz(s)`.
    #[inline(always)]
    pub(crate) fn motion(&mut self, kind: JointKind, s: f64) {
        match kind {
            JointKind::Revolute => {
                let (sn, cs) = sin_cos(s);
                let (x, y) = (self.c[0], self.c[1]);
                for l in 0..4 {
                    self.c[0][l] = cs * x[l] + sn * y[l];
                    self.c[1][l] = cs * y[l] - sn * x[l];
                }
            }
            JointKind::Prismatic => {
                let z = self.c[2];
                for l in 0..4 {
                    self.c[3][l] += z[l] * s;
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

/// Tool pose `T_world_tool(q)` without filling a [`Data`]; `q` must have `model.nq()` entries (unchecked here).
#[inline]
pub fn tool_pose_unchecked(model: &Model, q: &[f64]) -> Pose {
    let mut t = Frame::of(model.t_world_base());
    for (j, &qi) in model.joints().iter().zip(q) {
        t = t.mul(&j.placement);
        t.motion(j.kind, qi + j.offset);
    }
    t.mul(model.t_last_tool()).pose()
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
    let mut t = Frame::of(model.t_world_base());
    for ((j, &qi), out) in model.joints().iter().zip(q).zip(data.t_world_joint.iter_mut()) {
        t = t.mul(&j.placement);
        t.motion(j.kind, qi + j.offset);
        *out = t.pose();
    }
    data.t_world_tool = t.mul(model.t_last_tool()).pose();
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
    let tool = Frame::of(&data.t_world_tool);
    let tp = tool.p();
    // the frame whose axes the rows use, None for world
    let axes = match frame {
        JacobianFrame::World => None,
        JacobianFrame::Base => Some(Frame::of(model.t_world_base())),
        JacobianFrame::Tool => Some(tool),
    };
    let n = model.nq();
    let jac = data.jacobian.as_mut_slice(); // column-major 6 x n
    for (i, (j, t)) in model.joints().iter().zip(&data.t_world_joint).enumerate().take(n) {
        let f = Frame::of(t);
        let (z, fp) = (f.z(), f.p());
        let (v, w) = match j.kind {
            JointKind::Revolute => {
                let d = [tp[0] - fp[0], tp[1] - fp[1], tp[2] - fp[2]];
                ([z[1] * d[2] - z[2] * d[1], z[2] * d[0] - z[0] * d[2], z[0] * d[1] - z[1] * d[0]], z)
            }
            JointKind::Prismatic => (z, [0.0; 3]),
        };
        let col = &mut jac[6 * i..6 * i + 6];
        match &axes {
            None => {
                col[..3].copy_from_slice(&v);
                col[3..].copy_from_slice(&w);
            }
            Some(a) => {
                // R^T v: rows of R^T are the columns of R
                for k in 0..3 {
                    let c = a.col(k);
                    col[k] = c[0] * v[0] + c[1] * v[1] + c[2] * v[2];
                    col[3 + k] = c[0] * w[0] + c[1] * w[1] + c[2] * w[2];
                }
            }
        }
    }
}

/// Tool pose and world-frame Jacobian in one pass, without a [`Data`] (the inner loop of IK):
/// `jac` (column-major 6 x n) receives the columns of [`jacobian`] with [`JacobianFrame::World`].
#[inline]
pub(crate) fn tool_pose_and_jacobian(model: &Model, q: &[f64], jac: &mut [f64]) -> Pose {
    let mut t = Frame::of(model.t_world_base());
    for ((j, &qi), col) in model.joints().iter().zip(q).zip(jac.chunks_exact_mut(6)) {
        t = t.mul(&j.placement);
        t.motion(j.kind, qi + j.offset);
        // park the joint's origin and z axis in its column; the tool origin is known only at the end
        col[..3].copy_from_slice(&t.p());
        col[3..].copy_from_slice(&t.z());
    }
    let tool = t.mul(model.t_last_tool());
    let tp = tool.p();
    for (j, col) in model.joints().iter().zip(jac.chunks_exact_mut(6)) {
        let z = [col[3], col[4], col[5]];
        match j.kind {
            JointKind::Revolute => {
                let d = [tp[0] - col[0], tp[1] - col[1], tp[2] - col[2]];
                col[0] = z[1] * d[2] - z[2] * d[1];
                col[1] = z[2] * d[0] - z[0] * d[2];
                col[2] = z[0] * d[1] - z[1] * d[0];
            }
            JointKind::Prismatic => {
                col[..3].copy_from_slice(&z);
                col[3..].fill(0.0);
            }
        }
    }
    tool.pose()
}

/// The geometric Jacobian at `q` written row-major (6 x n) into `out`, in one pass without a [`Data`]
/// (same values as [`jacobian`]); `q` must have n finite values (unchecked).
pub fn jacobian_row_major_unchecked(model: &Model, q: &[f64], frame: JacobianFrame, out: &mut [f64]) {
    let n = model.nq();
    let mut stack = [0.0; 6 * 16];
    let mut heap = Vec::new();
    let jac: &mut [f64] = if n <= 16 {
        &mut stack[..6 * n]
    } else {
        heap.resize(6 * n, 0.0);
        &mut heap
    };
    let tool = tool_pose_and_jacobian(model, q, jac);
    let axes = match frame {
        JacobianFrame::World => None,
        JacobianFrame::Base => Some(*model.t_world_base().rotation.matrix()),
        JacobianFrame::Tool => Some(*tool.rotation.matrix()),
    };
    for (c, col) in jac.chunks_exact(6).enumerate() {
        match &axes {
            None => {
                for k in 0..6 {
                    out[k * n + c] = col[k];
                }
            }
            Some(r) => {
                // R^T v, R^T w
                for k in 0..3 {
                    out[k * n + c] = r[(0, k)] * col[0] + r[(1, k)] * col[1] + r[(2, k)] * col[2];
                    out[(3 + k) * n + c] = r[(0, k)] * col[3] + r[(1, k)] * col[4] + r[(2, k)] * col[5];
                }
            }
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

/// Configurations evaluated together by the batch forward kinematics (structure of arrays).
const LANES: usize = 8;

/// Batch tool poses: `qs` holds N configurations row-major (N x n), `out` N row-major 4x4 matrices (N x 16).
/// Runs on all cores (rayon), `LANES` configurations at a time in structure-of-arrays form so that every
/// operation is a SIMD one. Values must be finite (checked). Same values as [`tool_pose`] up to the
/// sign of zeros.
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
    let n = model.nq().max(1);
    let count = if model.nq() == 0 { out.len() / 16 } else { qs.len() / n };
    check_len("q batch (N*n values)", count * model.nq(), qs.len())?;
    check_len("output (N*16 values)", count * 16, out.len())?;
    crate::error::check_finite("q batch", qs)?;
    const CHUNK: usize = 1024;
    let n = model.nq();
    let factors: Vec<Sparse> = model.joints().iter().map(|j| Sparse::of(&j.placement)).chain([Sparse::of(model.t_last_tool())]).collect();
    out.par_chunks_mut(16 * CHUNK).enumerate().for_each(|(c, o)| {
        let start = c * CHUNK;
        let mut block = [0.0; 16 * LANES];
        for (b, ob) in o.chunks_mut(16 * LANES).enumerate() {
            let first = start + b * LANES;
            let valid = ob.len() / 16;
            if valid == LANES {
                tool_pose_lanes(model, &factors, &qs[first * n..(first + LANES) * n], ob);
            } else {
                let mut q = vec![0.0; LANES * n];
                q[..valid * n].copy_from_slice(&qs[first * n..(first + valid) * n]);
                tool_pose_lanes(model, &factors, &q, &mut block);
                ob.copy_from_slice(&block[..16 * valid]);
            }
        }
    });
    Ok(())
}

/// A constant factor of the chain (placement or tool) with its exact zeros dropped: column `j` of the
/// product `c · b` is the sum over `terms[j]` of `c[k] * b[k][j]` (plus `c`'s origin for the origin
/// column). Placements built from `Rx(alpha)` and translations along one or two axes are mostly zeros, so
/// this roughly halves the work of a batch; skipping exact zeros does not change the result.
#[derive(Clone, Copy)]
struct Sparse {
    terms: [[(usize, f64); 3]; 4],
    count: [usize; 4],
}

impl Sparse {
    fn of(b: &Pose) -> Self {
        let (m, v) = (b.rotation.matrix(), &b.translation.vector);
        let mut s = Self { terms: [[(0, 0.0); 3]; 4], count: [0; 4] };
        for j in 0..4 {
            for k in 0..3 {
                let x = if j < 3 { m[3 * j + k] } else { v[k] };
                if x != 0.0 {
                    s.terms[j][s.count[j]] = (k, x);
                    s.count[j] += 1;
                }
            }
        }
        s
    }
}

type Lanes = [[[f64; LANES]; 3]; 4];

/// `c · b` for `LANES` frames at once (`c[column][row][lane]`).
#[inline(always)]
fn mul_lanes(c: &Lanes, b: &Sparse) -> Lanes {
    let mut d = [[[0.0; LANES]; 3]; 4];
    for j in 0..4 {
        let terms = &b.terms[j][..b.count[j]];
        for r in 0..3 {
            let mut acc = if j == 3 { c[3][r] } else { [0.0; LANES] };
            for &(k, x) in terms {
                for l in 0..LANES {
                    acc[l] += c[k][r][l] * x;
                }
            }
            d[j][r] = acc;
        }
    }
    d
}

/// Tool poses of `LANES` configurations (`qs`: LANES x n row-major) into `out` (LANES x 16 row-major);
/// `factors` are the joints' placements and, last, the tool, as [`Sparse`].
#[inline(always)]
fn tool_pose_lanes(model: &Model, factors: &[Sparse], qs: &[f64], out: &mut [f64]) {
    let n = model.nq();
    // c[column][row][lane]: columns x, y, z axes and origin
    let mut c = [[[0.0; LANES]; 3]; 4];
    let f = Frame::of(model.t_world_base());
    for (j, cj) in c.iter_mut().enumerate() {
        for (r, cjr) in cj.iter_mut().enumerate() {
            *cjr = [f.c[j][r]; LANES];
        }
    }
    for (i, joint) in model.joints().iter().enumerate() {
        c = mul_lanes(&c, &factors[i]);
        let mut s = [0.0; LANES];
        for (l, sl) in s.iter_mut().enumerate() {
            *sl = qs[l * n + i] + joint.offset;
        }
        match joint.kind {
            JointKind::Revolute => {
                let (sn, cs) = sin_cos_lanes(&s);
                for r in 0..3 {
                    let (x, y) = (c[0][r], c[1][r]);
                    for l in 0..LANES {
                        c[0][r][l] = cs[l] * x[l] + sn[l] * y[l];
                        c[1][r][l] = cs[l] * y[l] - sn[l] * x[l];
                    }
                }
            }
            JointKind::Prismatic => {
                for r in 0..3 {
                    for l in 0..LANES {
                        c[3][r][l] += c[2][r][l] * s[l];
                    }
                }
            }
        }
    }
    c = mul_lanes(&c, &factors[n]);
    for (l, o) in out.chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = c[j][r][l];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
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
    out.par_chunks_mut(6 * n * 256).enumerate().for_each(|(c, o)| {
        for (k, ok) in o.chunks_exact_mut(6 * n).enumerate() {
            let idx = c * 256 + k;
            jacobian_row_major_unchecked(model, &qs[idx * n..(idx + 1) * n], frame, ok);
        }
    });
    Ok(())
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
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
        super::jacobian(&m, &mut d, &q, super::JacobianFrame::World).unwrap();
        let mut jac = vec![0.0; 18];
        let t = super::tool_pose_and_jacobian(&m, &q, &mut jac);
        assert_eq!(jac.as_slice(), d.jacobian.as_slice());
        assert_eq!(t, d.t_world_tool);
        // the row-major form of the bindings, in both frames
        for frame in [super::JacobianFrame::World, super::JacobianFrame::Base, super::JacobianFrame::Tool] {
            super::jacobian(&m, &mut d, &q, frame).unwrap();
            let mut rm = vec![0.0; 18];
            super::jacobian_row_major_unchecked(&m, &q, frame, &mut rm);
            for r in 0..6 {
                for c in 0..3 {
                    assert!((rm[r * 3 + c] - d.jacobian[(r, c)]).abs() < 1e-15, "{r} {c}");
                }
            }
        }
    }
}
