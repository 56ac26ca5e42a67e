//! Closed-form IK of the two 6R structures of industrial arms, from the joint axis lines: the seeds of
//! [`super::IkSolver`]'s first attempt.
//!
//! The chain is written as a product of exponentials (Brockett 1984; Murray, Li & Sastry 1994, ch. 3) about the
//! joint axis lines at `q = 0` (point `p_i`, unit direction `h_i` in `world`):
//! `T_world_tool(q) = e_1(q_1) ... e_6(q_6) T_world_tool(0)`, `e_i(θ) x = p_i + R(h_i, θ) (x - p_i)`, so a
//! target `T*` gives `G = T* T_world_tool(0)^-1 = e_1 ... e_6`, solved by geometric subproblems on the lines
//! (Paden 1986, Kahan; the decompositions of Elias & Wen 2022, "IK-Geo", arXiv 2211.05737):
//! * **SP1**: the rotation `θ` about `k` that takes `a` to `b` (`R(k, θ) a = b`);
//! * **SP4**: the rotations `θ` about `k` with `h^T R(k, θ) p = d` (0, 1 or 2; SP3, a rotation to a given
//!   distance, is SP4 with `h` the other point).
//!
//! Two structures are recognised ([`ClosedForm::new`]), each giving up to 8 branches:
//! * **spherical wrist, parallel shoulder** (KUKA KR5, Puma 560): axes 4, 5, 6 meet in the wrist centre `w`,
//!   axes 2 and 3 are parallel (direction `h`), axis 1 is not parallel to them. `w* = G w` does not depend on
//!   q4..q6; rotations about axes 2, 3 keep the component along `h`, so `h · e_1^-1(w*) = h · w` (SP4: q1, 2
//!   branches); the distance of `e_3 w` from axis 2 (SP3: q3, 2 branches), then q2 (SP1); the wrist's rotation
//!   `R_4 R_5 R_6 = (R_1 R_2 R_3)^T R_G`: q5 by SP4 on `h_4`, q4 and q6 by SP1 (2 branches).
//! * **three parallel axes** (UR5, TianSui-One): axes 2, 3, 4 parallel (direction `h`), axes 5 and 6 meet in
//!   `c`, axis 1 and axis 5 not parallel to `h`. `e_5`, `e_6` keep `c`, and `e_2 e_3 e_4` keep the component
//!   along `h`: `h · e_1^-1(G c) = h · c` (SP4: q1); `h^T R_1^T R_G h_6 = h^T R_5 h_6` (SP4: q5);
//!   `R_6 (R_G^T R_1 h) = R_5^T h` (SP1: q6); then the planar 2R problem of axes 2, 3 on a point of axis 4
//!   (SP3, SP1) and `q2 + q3 + q4` from the rotation about `h` (SP1).
//!
//! A robot whose axes are near such a structure (an identified robot: axes off by up to [`ANGLE_TOL`] rad
//! and [`DISTANCE_TOL`] times its size) is solved on the *nearest ideal structure*: parallel directions
//! replaced by their mean, meeting lines by the point nearest to them; the branches are then seeds that
//! the caller polishes on the true model. An equation without an exact solution (a target out of reach of
//! the ideal structure) gives its nearest angle (the arm stretched towards it); a joint left free by a
//! singularity (q1 with the wrist centre on axis 1, q4 / q6 with the wrist axes aligned) takes its value in
//! the start configuration.
//!
//! No allocation: the branches are written into a fixed array.

use crate::axes::axes;
use crate::kinematics::tool_pose_unchecked;
use crate::model::{JointKind, Model};
use crate::spatial::{Pose, any_perpendicular};
use nalgebra::{Matrix3, Point3, Rotation3, Unit, Vector3};

type V3 = Vector3<f64>;

/// Largest angle (rad) between axes taken as parallel, and smallest sine of the angle between axes that must
/// not be parallel is `NOT_PARALLEL`.
pub(crate) const ANGLE_TOL: f64 = 5e-3;
/// Largest distance, relative to the chain's size (the sum of the distances between consecutive axis points
/// and the tool), between axis lines taken as meeting in one point.
pub(crate) const DISTANCE_TOL: f64 = 5e-3;
/// Smallest sine of the angle between axes that the subproblems need not parallel.
const NOT_PARALLEL: f64 = 0.1;

/// The two structures solved in closed form.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Structure {
    /// Axes 4, 5, 6 meet in one point; axes 2 and 3 are parallel, axis 1 is not parallel to them.
    SphericalWrist,
    /// Axes 2, 3, 4 are parallel, axis 1 and axis 5 are not parallel to them; axes 5 and 6 meet in one point.
    ThreeParallel,
}

impl Structure {
    /// `"spherical wrist"` or `"three parallel axes"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::SphericalWrist => "spherical wrist",
            Self::ThreeParallel => "three parallel axes",
        }
    }
}

/// The ideal axis lines of a recognised 6R chain at `q = 0` and `T_world_tool(0)^-1` (derived once per model).
#[derive(Debug, Clone)]
pub(crate) struct ClosedForm {
    pub(crate) structure: Structure,
    /// Points on the ideal axis lines (world, m).
    p: [V3; 6],
    /// Unit directions of the ideal axis lines (world).
    h: [V3; 6],
    /// The shared direction of the parallel axes (`h_2` for both structures).
    hp: V3,
    /// The point where the meeting axes meet: the wrist centre, or the point of axes 5 and 6.
    c: V3,
    /// `T_world_tool(0)^-1`.
    t0_inv: Pose,
}

/// Most branches of a 6R chain.
pub(crate) const MAX_BRANCHES: usize = 8;

/// `R(k, θ) v` (Rodrigues).
#[inline(always)]
fn rot(k: &V3, (s, c): (f64, f64), v: &V3) -> V3 {
    v * c + k.cross(v) * s + k * (k.dot(v) * (1.0 - c))
}

#[inline(always)]
fn rot_m(k: &V3, t: f64) -> Matrix3<f64> {
    *Rotation3::from_axis_angle(&Unit::new_unchecked(*k), t).matrix()
}

/// SP1: `θ` with `R(k, θ) a = b` in the least-squares sense (the angle between the components of `a` and `b`
/// perpendicular to `k`); `None` when one of them is (nearly) along `k` (every `θ` does as well).
#[inline(always)]
fn sp1(k: &V3, a: &V3, b: &V3) -> Option<f64> {
    let (ka, kb) = (k.dot(a), k.dot(b));
    let y = k.dot(&a.cross(b));
    let x = a.dot(b) - ka * kb;
    let na = (a.norm_squared() - ka * ka).max(0.0);
    let nb = (b.norm_squared() - kb * kb).max(0.0);
    (na * nb > 1e-20 * (a.norm_squared() * b.norm_squared()).max(1e-300)).then(|| y.atan2(x))
}

/// The solutions of SP4.
#[derive(Debug, Clone, Copy)]
enum Sp4 {
    /// The first 0, 1 or 2 angles (one when the equation has no exact solution: the nearest).
    Angles([f64; 2], usize),
    /// Every angle solves it (`h^T R(k, θ) p` does not depend on `θ`).
    Any,
}

/// How far `|C| / sqrt(A² + B²)` of [`sp4`] may exceed 1 for the nearest angle to stand in for a solution
/// (rounding, or an identified robot a little off its ideal structure, at the edge of its reach); beyond it,
/// none.
const SP4_SLACK: f64 = 1e-6;

/// SP4: the angles `θ` with `h^T R(k, θ) p = d` (`k` unit): `A cos θ + B sin θ = C`; without an exact
/// solution but within [`SP4_SLACK`], the `θ` nearest to one (the maximum or minimum of the left side); else none.
#[inline(always)]
fn sp4(h: &V3, k: &V3, p: &V3, d: f64) -> Sp4 {
    let kp = k.dot(p);
    let pp = p - k * kp;
    let a = h.dot(&pp);
    let b = h.dot(&k.cross(p));
    let c = d - h.dot(k) * kp;
    let r = a.hypot(b);
    if r <= 1e-12 * (h.norm() * p.norm()).max(1e-300) {
        return Sp4::Any;
    }
    let phi = b.atan2(a);
    let x = c / r;
    if x.abs() > 1.0 + SP4_SLACK {
        Sp4::Angles([0.0, 0.0], 0)
    } else if x >= 1.0 {
        Sp4::Angles([phi, phi], 1)
    } else if x <= -1.0 {
        Sp4::Angles([phi + std::f64::consts::PI, 0.0], 1)
    } else {
        let t = x.acos();
        Sp4::Angles([phi + t, phi - t], 2)
    }
}

/// The angles of an SP4 result, `free` standing in for an unconstrained angle.
#[inline(always)]
fn angles(s: Sp4, free: f64) -> ([f64; 2], usize) {
    match s {
        Sp4::Angles(a, n) => (a, n),
        Sp4::Any => ([free, free], 1),
    }
}

/// The least-squares point nearest to lines `(p_i, h_i)` (unit `h_i`) and its largest distance from them;
/// `None` when the lines are (nearly) parallel.
fn meeting_point(lines: &[(V3, V3)]) -> Option<(V3, f64)> {
    let mut a = Matrix3::zeros();
    let mut b = V3::zeros();
    for (p, h) in lines {
        let m = Matrix3::identity() - h * h.transpose();
        a += m;
        b += m * p;
    }
    let x = a.try_inverse()? * b;
    let worst = lines.iter().map(|(p, h)| ((x - p) - h * h.dot(&(x - p))).norm()).fold(0.0, f64::max);
    Some((x, worst))
}

impl ClosedForm {
    /// The closed form of `model` when its axes at `q = 0` have (within the tolerances) one of the
    /// [`Structure`]s, else `None` (not 6 revolute joints, or another geometry).
    pub(crate) fn new(model: &Model) -> Option<Self> {
        if model.nq() != 6 || model.joints().iter().any(|j| j.kind != JointKind::Revolute) {
            return None;
        }
        let q0 = [0.0; 6];
        let ax = axes(model, &q0).ok()?;
        let t0 = tool_pose_unchecked(model, &q0);
        let p: [V3; 6] = std::array::from_fn(|i| ax.points[i]);
        let h: [V3; 6] = std::array::from_fn(|i| ax.directions[i]);
        let size = (1..6).map(|i| (p[i] - p[i - 1]).norm()).sum::<f64>() + (t0.translation.vector - p[5]).norm();
        let dist_tol = DISTANCE_TOL * size.max(1e-3);
        let sin = |a: &V3, b: &V3| a.cross(b).norm();
        // the mean direction of parallel axes, each keeping its own sense; None if one is not parallel
        let parallel = |idx: &[usize]| -> Option<(V3, [f64; 6])> {
            let mut sign = [1.0; 6];
            let mut sum = V3::zeros();
            for &i in idx {
                let s = h[idx[0]].dot(&h[i]).signum();
                if sin(&h[idx[0]], &h[i]) > ANGLE_TOL.sin() {
                    return None;
                }
                sign[i] = s;
                sum += h[i] * s;
            }
            Some((sum.normalize(), sign))
        };
        // distance between two parallel lines of direction d
        let apart = |i: usize, j: usize, d: &V3| {
            let v = p[j] - p[i];
            (v - d * d.dot(&v)).norm()
        };
        let mut ideal_h = h;
        let mut ideal_p = p;
        // spherical wrist, parallel shoulder
        if let Some((hp, sign)) = parallel(&[1, 2]) {
            let meet = meeting_point(&[(p[3], h[3]), (p[4], h[4]), (p[5], h[5])]);
            if let Some((w, worst)) = meet {
                if worst <= dist_tol
                    && sin(&h[0], &hp) >= NOT_PARALLEL
                    && sin(&h[3], &h[4]) >= NOT_PARALLEL
                    && sin(&h[4], &h[5]) >= NOT_PARALLEL
                    && apart(1, 2, &hp) > dist_tol
                {
                    for i in 1..3 {
                        ideal_h[i] = hp * sign[i];
                    }
                    for pi in &mut ideal_p[3..6] {
                        *pi = w;
                    }
                    return Some(Self { structure: Structure::SphericalWrist, p: ideal_p, h: ideal_h, hp: ideal_h[1], c: w, t0_inv: t0.inverse() });
                }
            }
        }
        // three parallel axes, axes 5 and 6 meeting
        let (hp, sign) = parallel(&[1, 2, 3])?;
        let (c, worst) = meeting_point(&[(p[4], h[4]), (p[5], h[5])])?;
        if worst <= dist_tol
            && sin(&h[0], &hp) >= NOT_PARALLEL
            && sin(&h[4], &hp) >= NOT_PARALLEL
            && sin(&h[4], &h[5]) >= NOT_PARALLEL
            && apart(1, 2, &hp) > dist_tol
        {
            for i in 1..4 {
                ideal_h[i] = hp * sign[i];
            }
            ideal_p[4] = c;
            ideal_p[5] = c;
            return Some(Self { structure: Structure::ThreeParallel, p: ideal_p, h: ideal_h, hp: ideal_h[1], c, t0_inv: t0.inverse() });
        }
        None
    }

    /// The branches of `target` (`T_world_tool`) on the ideal structure into `out`, their number returned
    /// (up to [`MAX_BRANCHES`]); `start` gives the joints left free by a singularity. Angles as computed (not
    /// wrapped).
    pub(crate) fn branches(&self, target: &Pose, start: &[f64], out: &mut [[f64; 6]; MAX_BRANCHES]) -> usize {
        let g = target * self.t0_inv;
        match self.structure {
            Structure::SphericalWrist => self.spherical_wrist(&g, start, out),
            Structure::ThreeParallel => self.three_parallel(&g, start, out),
        }
    }

    /// `e_i(θ)^-1 x`.
    #[inline(always)]
    fn undo(&self, i: usize, t: f64, x: &V3) -> V3 {
        self.p[i] + rot(&self.h[i], (-t.sin(), t.cos()), &(x - self.p[i]))
    }

    /// The planar 2R problem of the parallel axes 2 and 3: `(q2, q3)` with `e_2(q2) e_3(q3) x = v` (in the
    /// plane normal to `h`: the components along `h` are left to the other joints); up to 2 pairs.
    #[inline(always)]
    fn planar(&self, x: &V3, v: &V3, free: (f64, f64), out: &mut [[f64; 2]; 2]) -> usize {
        let hp = &self.hp;
        let (h2, h3) = (&self.h[1], &self.h[2]);
        let flat = |u: V3| u - hp * hp.dot(&u);
        let u = flat(x - self.p[2]);
        let c = flat(self.p[1] - self.p[2]);
        let target = flat(v - self.p[1]);
        let d2 = target.norm_squared();
        // |R(h3, q3) u - c| = |target|: SP3 as SP4
        let (q3s, n) = angles(sp4(&c, h3, &u, (u.norm_squared() + c.norm_squared() - d2) / 2.0), free.1);
        for k in 0..n {
            let q3 = q3s[k];
            let moved = rot(h3, q3.sin_cos(), &u) - c; // e_3 x - p_2, flattened
            let q2 = sp1(h2, &moved, &target).unwrap_or(free.0);
            out[k] = [q2, q3];
        }
        n
    }

    fn spherical_wrist(&self, g: &Pose, start: &[f64], out: &mut [[f64; 6]; MAX_BRANCHES]) -> usize {
        let (p, h, w) = (&self.p, &self.h, &self.c);
        let rg = g.rotation.matrix();
        let wd = (g * Point3::from(*w)).coords;
        // q1: h · e_1^-1(w*) = h · w, i.e. h^T R(h1, -q1) (w* - p1) = h · (w - p1)
        let (q1s, n1) = angles(sp4(&self.hp, &h[0], &(wd - p[0]), self.hp.dot(&(w - p[0]))), -start[0]);
        let mut n = 0;
        for &m1 in &q1s[..n1] {
            let q1 = -m1;
            let v = self.undo(0, q1, &wd);
            let mut shoulder = [[0.0; 2]; 2];
            let n23 = self.planar(w, &v, (start[1], start[2]), &mut shoulder);
            for &[q2, q3] in &shoulder[..n23] {
                let r123 = rot_m(&h[0], q1) * rot_m(&h[1], q2) * rot_m(&h[2], q3);
                let rrem = r123.transpose() * rg;
                n += self.wrist(&rrem, [q1, q2, q3], start, &mut out[n..]);
            }
        }
        n
    }

    /// The spherical wrist `R(h4, q4) R(h5, q5) R(h6, q6) = rrem`: up to 2 branches after `head`.
    #[inline(always)]
    fn wrist(&self, rrem: &Matrix3<f64>, head: [f64; 3], start: &[f64], out: &mut [[f64; 6]]) -> usize {
        let h = &self.h;
        let target6 = rrem * h[5];
        let (q5s, n5) = angles(sp4(&h[3], &h[4], &h[5], h[3].dot(&target6)), start[4]);
        let x = any_perpendicular(&h[5]);
        for k in 0..n5 {
            let q5 = q5s[k];
            let r5 = rot_m(&h[4], q5);
            let q4 = sp1(&h[3], &(r5 * h[5]), &target6).unwrap_or(start[3]);
            let r6 = (rot_m(&h[3], q4) * r5).transpose() * rrem;
            let q6 = sp1(&h[5], &x, &(r6 * x)).unwrap_or(start[5]);
            out[k] = [head[0], head[1], head[2], q4, q5, q6];
        }
        n5
    }

    fn three_parallel(&self, g: &Pose, start: &[f64], out: &mut [[f64; 6]; MAX_BRANCHES]) -> usize {
        let (p, h, c, hp) = (&self.p, &self.h, &self.c, &self.hp);
        let rg = g.rotation.matrix();
        let cd = (g * Point3::from(*c)).coords;
        // q1: h · e_1^-1(G c) = h · c
        let (q1s, n1) = angles(sp4(hp, &h[0], &(cd - p[0]), hp.dot(&(c - p[0]))), -start[0]);
        let mut n = 0;
        for &m1 in &q1s[..n1] {
            let q1 = -m1;
            let r1 = rot_m(&h[0], q1);
            // q5: h^T R1^T R_G h6 = h^T R5 h6
            let d = hp.dot(&(r1.transpose() * rg * h[5]));
            let (q5s, n5) = angles(sp4(hp, &h[4], &h[5], d), start[4]);
            for &q5 in &q5s[..n5] {
                let r5 = rot_m(&h[4], q5);
                // q6: R6 (R_G^T R1 h) = R5^T h
                let q6 = sp1(&h[5], &(rg.transpose() * r1 * hp), &(r5.transpose() * hp)).unwrap_or(start[5]);
                let r6 = rot_m(&h[5], q6);
                // e_2 e_3 e_4 = e_1^-1 G e_6^-1 e_5^-1 =: H; a point of axis 4 goes to v = H p4
                let x = self.undo(5, q6, &self.undo(4, q5, &p[3]));
                let v = self.undo(0, q1, &(g * Point3::from(x)).coords);
                let rh = r1.transpose() * rg * r6.transpose() * r5.transpose(); // R(h, q2 + q3 + q4)
                let y = any_perpendicular(hp);
                let s = |i: usize| h[i].dot(hp).signum();
                let total = sp1(hp, &y, &(rh * y)).unwrap_or(s(1) * start[1] + s(2) * start[2] + s(3) * start[3]);
                let mut shoulder = [[0.0; 2]; 2];
                let n23 = self.planar(&p[3], &v, (start[1], start[2]), &mut shoulder);
                for &[q2, q3] in &shoulder[..n23] {
                    // R(h2, q2) R(h3, q3) R(h4, q4) = R(h, s2 q2 + s3 q3 + s4 q4), s_i = ±1 the sense of h_i along h
                    let q4 = s(3) * (total - s(1) * q2 - s(2) * q3);
                    out[n] = [q1, q2, q3, q4, q5, q6];
                    n += 1;
                }
            }
        }
        n
    }
}
