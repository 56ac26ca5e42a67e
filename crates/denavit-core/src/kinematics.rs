//! Forward kinematics and the geometric Jacobian (docs/conventions.md, "The model").
#![allow(clippy::needless_range_loop)] // index loops mirror the formulas (and unroll)

use crate::error::{Error, Result, check_len};
use crate::math::{sin_cos, sin_cos_lanes};
use crate::model::{Data, JointKind, Model};
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
    /// `self · M(s)`: the joint motion `Rz(s)` or `Tz(s)`.
    #[inline(always)]
    pub(crate) fn motion(&mut self, kind: JointKind, s: f64) {
        match kind {
            JointKind::Revolute => {
                let (sn, cs) = sin_cos(s);
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
    let mut t = Frame::of(model.t_world_base());
    for ((j, &qi), ozi) in model.joints().iter().zip(q).zip(oz.iter_mut()).take(cols) {
        t = t.mul(&j.placement);
        t.motion(j.kind, qi + j.offset);
        let (p, z) = (t.p(), t.z());
        *ozi = [p[0], p[1], p[2], z[0], z[1], z[2]];
    }
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

/// Configurations evaluated together by the batch kernels (structure of arrays).
const LANES: usize = 8;

/// Rows of a batch per parallel work item.
const CHUNK: usize = 1024;

/// Batch tool poses: `qs` holds N configurations row-major (N x n), `out` N row-major 4x4 matrices (N x 16).
/// Runs on rayon's pool (or as [`crate::parallel::with_threads`] says), `LANES` configurations at a time in
/// structure-of-arrays form so that every operation is a SIMD one, with fused multiply-adds. Values must be
/// finite (checked). Same values as [`tool_pose`] up to the sign of zeros.
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
    let factors = sparse_factors(model);
    let n = model.nq();
    crate::parallel::for_each_chunk(out, 16 * CHUNK, |c, o| {
        let start = c * CHUNK;
        for (b, ob) in o.chunks_mut(16 * LANES).enumerate() {
            let first = start + b * LANES;
            let valid = ob.len() / 16;
            if valid == LANES {
                tool_pose_lanes(model, &factors, &qs[first * n..(first + LANES) * n], ob);
            } else {
                let mut q = vec![0.0; LANES * n];
                q[..valid * n].copy_from_slice(&qs[first * n..(first + valid) * n]);
                let mut block = [0.0; 16 * LANES];
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
/// this roughly halves the work of a batch; skipping exact zeros does not change the result (the fused
/// sums run in the order of [`Frame::mul`], so the values are those of the single-configuration path).
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

/// The joints' placements and, last, the tool, as [`Sparse`] factors.
fn sparse_factors(model: &Model) -> Vec<Sparse> {
    model.joints().iter().map(|j| Sparse::of(&j.placement)).chain([Sparse::of(model.t_last_tool())]).collect()
}

type Lanes = [[[f64; LANES]; 3]; 4];

/// `d = c · b` for `LANES` frames at once (`c[column][row][lane]`).
#[inline(always)]
fn mul_lanes(c: &Lanes, b: &Sparse, d: &mut Lanes) {
    for j in 0..4 {
        let t = &b.terms[j];
        for r in 0..3 {
            let acc = if j == 3 { c[3][r] } else { [0.0; LANES] };
            // straight-line code per count (the model's counts repeat every block: a predicted branch)
            d[j][r] = match b.count[j] {
                0 => acc,
                1 => std::array::from_fn(|l| c[t[0].0][r][l].mul_add(t[0].1, acc[l])),
                2 => std::array::from_fn(|l| c[t[1].0][r][l].mul_add(t[1].1, c[t[0].0][r][l].mul_add(t[0].1, acc[l]))),
                _ => std::array::from_fn(|l| c[t[2].0][r][l].mul_add(t[2].1, c[t[1].0][r][l].mul_add(t[1].1, c[t[0].0][r][l].mul_add(t[0].1, acc[l])))),
            };
        }
    }
}

/// The base frame in every lane.
#[inline(always)]
fn base_lanes(model: &Model) -> Lanes {
    let mut c = [[[0.0; LANES]; 3]; 4];
    let f = Frame::of(model.t_world_base());
    for (j, cj) in c.iter_mut().enumerate() {
        for (r, cjr) in cj.iter_mut().enumerate() {
            *cjr = [f.c[j][r]; LANES];
        }
    }
    c
}

/// `c <- c · placement_i · M(q_i)` for `LANES` configurations (`qs`: LANES x n row-major); `d` is scratch.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn advance_lanes(c: &mut Lanes, d: &mut Lanes, factor: &Sparse, kind: JointKind, offset: f64, qs: &[f64], n: usize, i: usize) {
    mul_lanes(c, factor, d);
    let s: [f64; LANES] = std::array::from_fn(|l| qs[l * n + i] + offset);
    match kind {
        JointKind::Revolute => {
            let (sn, cs) = sin_cos_lanes(&s);
            for r in 0..3 {
                let (x, y) = (d[0][r], d[1][r]);
                c[0][r] = std::array::from_fn(|l| cs[l].mul_add(x[l], sn[l] * y[l]));
                c[1][r] = std::array::from_fn(|l| cs[l].mul_add(y[l], -(sn[l] * x[l])));
                c[2][r] = d[2][r];
                c[3][r] = d[3][r];
            }
        }
        JointKind::Prismatic => {
            for r in 0..3 {
                c[0][r] = d[0][r];
                c[1][r] = d[1][r];
                c[2][r] = d[2][r];
                c[3][r] = std::array::from_fn(|l| d[2][r][l].mul_add(s[l], d[3][r][l]));
            }
        }
    }
}

/// Tool poses of `LANES` configurations (`qs`: LANES x n row-major) into `out` (LANES x 16 row-major).
#[inline(always)]
fn tool_pose_lanes(model: &Model, factors: &[Sparse], qs: &[f64], out: &mut [f64]) {
    let n = model.nq();
    // c[column][row][lane]: columns x, y, z axes and origin
    let mut c = base_lanes(model);
    let mut d = [[[0.0; LANES]; 3]; 4];
    for (i, joint) in model.joints().iter().enumerate() {
        advance_lanes(&mut c, &mut d, &factors[i], joint.kind, joint.offset, qs, n, i);
    }
    mul_lanes(&c, &factors[n], &mut d);
    for (l, o) in out.chunks_exact_mut(16).enumerate() {
        for r in 0..3 {
            for j in 0..4 {
                o[4 * r + j] = d[j][r][l];
            }
        }
        o[12..].copy_from_slice(&[0.0, 0.0, 0.0, 1.0]);
    }
}

/// Joint origins and z axes of `LANES` configurations: `[o_x, o_y, o_z, z_x, z_y, z_z][lane]`.
type OriginAxis = [[f64; LANES]; 6];

/// Jacobians (as [`jacobian_row_major_unchecked`]) of `LANES` configurations (`qs`: LANES x n row-major) into
/// `out` (LANES x 6n row-major); `oz` is scratch for n joints.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn jacobian_lanes(model: &Model, factors: &[Sparse], qs: &[f64], frame: JacobianFrame, joint: Option<usize>, oz: &mut [OriginAxis], out: &mut [f64]) {
    let n = model.nq();
    let cols = joint.map_or(n, |j| j + 1);
    let mut c = base_lanes(model);
    let mut d = [[[0.0; LANES]; 3]; 4];
    for (i, (j, ozi)) in model.joints().iter().zip(oz.iter_mut()).enumerate().take(cols) {
        advance_lanes(&mut c, &mut d, &factors[i], j.kind, j.offset, qs, n, i);
        *ozi = [c[3][0], c[3][1], c[3][2], c[2][0], c[2][1], c[2][2]];
    }
    if joint.is_none() {
        mul_lanes(&c, &factors[n], &mut d);
        c = d;
    }
    let base = axes_of(model, JacobianFrame::Base, &Frame::of(model.t_world_base()));
    for (k, (j, ozk)) in model.joints().iter().zip(oz.iter()).enumerate() {
        for (l, ol) in out.chunks_exact_mut(6 * n).enumerate() {
            let col = if k < cols {
                let p = [c[3][0][l], c[3][1][l], c[3][2][l]];
                let axes = match frame {
                    JacobianFrame::Local => {
                        Some([[c[0][0][l], c[0][1][l], c[0][2][l]], [c[1][0][l], c[1][1][l], c[1][2][l]], [c[2][0][l], c[2][1][l], c[2][2][l]]])
                    }
                    JacobianFrame::Base => base,
                    _ => None,
                };
                column(j.kind, [ozk[0][l], ozk[1][l], ozk[2][l]], [ozk[3][l], ozk[4][l], ozk[5][l]], p, frame, axes.as_ref())
            } else {
                [0.0; 6]
            };
            for (r, v) in col.iter().enumerate() {
                ol[r * n + k] = *v;
            }
        }
    }
}

/// Batch Jacobians of the tool (`joint = None`) or of joint frame `joint` (0-based): `out` holds N row-major
/// 6 x n matrices (N x 6n), in `frame`; the values of [`jacobian_row_major_unchecked`] (up to the sign of
/// zeros), `LANES` configurations at a time as in [`tool_pose_batch`].
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
    crate::error::check_finite("q batch", qs)?;
    let factors = sparse_factors(model);
    crate::parallel::try_for_each_chunk_init(
        out,
        6 * n * CHUNK,
        || vec![[[0.0; LANES]; 6]; n],
        |oz, c, o| {
            let start = c * CHUNK;
            for (b, ob) in o.chunks_mut(6 * n * LANES).enumerate() {
                let first = start + b * LANES;
                let valid = ob.len() / (6 * n);
                if valid == LANES {
                    jacobian_lanes(model, &factors, &qs[first * n..(first + LANES) * n], frame, joint, oz, ob);
                } else {
                    let mut q = vec![0.0; LANES * n];
                    q[..valid * n].copy_from_slice(&qs[first * n..(first + valid) * n]);
                    let mut block = vec![0.0; 6 * n * LANES];
                    jacobian_lanes(model, &factors, &q, frame, joint, oz, &mut block);
                    ob.copy_from_slice(&block[..6 * n * valid]);
                }
            }
            Ok(())
        },
    )
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
