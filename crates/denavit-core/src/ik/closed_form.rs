//! Closed-form IK of the two 6R structures of industrial arms, from the joint axis lines: the seeds of
//! [`super::IkSolver`]'s first attempt.
//!
//! The chain is written as a product of exponentials (Brockett 1984; Murray, Li & Sastry 1994, ch. 3) about the
//! joint axis lines at `q = 0` (point `p_i`, unit direction `h_i` in `world`):
//! `T_world_tool(q) = e_1(q_1) ... e_6(q_6) T_world_tool(0)`, `e_i(θ) x = p_i + R(h_i, θ) (x - p_i)`, so a
//! goal `T*` gives `G = T* T_world_tool(0)^-1 = e_1 ... e_6`, solved by geometric subproblems on the lines
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
//! the caller polishes on the true model. An equation without an exact solution gives its nearest angle (the
//! arm stretched towards the goal) when it misses by a relative 1e-6 at most (rounding at a stretched arm or
//! wrist), else no branch (a goal out of reach); a joint left free by a
//! singularity (q1 with the wrist centre on axis 1, q4 / q6 with the wrist axes aligned) takes its value in
//! the start configuration.
//!
//! Each structure is solved in two levels ([`ClosedForm::partials`]: up to 4 sets of three joints; then
//! [`ClosedForm::complete`]: up to 2 branches each), so that the caller can leave unfinished the partial
//! branches far from its start. No allocation and no trigonometric function: the angles are carried as
//! (cos, sin) pairs ([`Cs`]; SP4 and SP1 give them by square roots and divisions) in fixed arrays, and turned
//! into angles by the caller (48 `atan2` for 8 branches would cost more than their closed form).

use crate::axes::axes;
use crate::kinematics::fk_unchecked;
use crate::model::{JointKind, Model};
use crate::spatial::{Pose, any_perpendicular};
use nalgebra::{Matrix3, Point3, Vector3};

type V3 = Vector3<f64>;

/// Largest angle (rad) between axes taken as parallel.
pub(crate) const ANGLE_TOL: f64 = 5e-3;
/// Largest distance, relative to the chain's size (the sum of the distances between consecutive axis points
/// and the tool), between axis lines taken as meeting in one point.
pub(crate) const DISTANCE_TOL: f64 = 5e-3;
/// Smallest sine of the angle between axes that the subproblems need not parallel.
pub(super) const NOT_PARALLEL: f64 = 0.1;

/// How far `|C| / sqrt(A² + B²)` of [`sp4`] may exceed 1 for the nearest angle to stand in for a solution
/// (rounding, or an identified robot a little off its ideal structure, at the edge of its reach); beyond it,
/// none.
const SP4_SLACK: f64 = 1e-6;

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

/// An angle as its cosine and sine (a unit complex number: products add angles).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Cs {
    pub(crate) c: f64,
    pub(crate) s: f64,
}

impl Cs {
    pub(crate) const ZERO: Self = Self { c: 1.0, s: 0.0 };
    #[inline(always)]
    pub(super) fn of(t: f64) -> Self {
        let (s, c) = crate::math::sin_cos(t);
        Self { c, s }
    }
    /// The angle in (-π, π].
    #[inline(always)]
    pub(crate) fn angle(self) -> f64 {
        self.s.atan2(self.c)
    }
    /// The angle in (-π, π] to about 3e-7 rad (a polynomial, a tenth of the time of `atan2`).
    #[inline(always)]
    pub(crate) fn angle_approx(self) -> f64 {
        atan2_approx(self.s, self.c)
    }
    #[inline(always)]
    pub(super) fn neg(self) -> Self {
        Self { c: self.c, s: -self.s }
    }
    /// The sum of the angles.
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        Self { c: self.c * o.c - self.s * o.s, s: self.s * o.c + self.c * o.s }
    }
    /// `self` times the sign `sign` (±1).
    #[inline(always)]
    fn times(self, sign: f64) -> Self {
        Self { c: self.c, s: self.s * sign }
    }
}

/// `atan2(y, x)` to about 3e-7 rad: a degree-15 odd polynomial of atan on [0, 1] (Chebyshev fit) and the
/// octant's symmetries.
#[inline(always)]
fn atan2_approx(y: f64, x: f64) -> f64 {
    const C: [f64; 8] = [
        9.999_999_227_775_81e-1,
        -3.333_223_261_884_783e-1,
        1.997_402_857_781_987e-1,
        -1.404_782_123_129_534e-1,
        1.000_220_525_551_376_7e-1,
        -6.087_448_221_659_648e-2,
        2.533_170_106_166_051e-2,
        -5.021_063_910_921_498e-3,
    ];
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = if ay > ax { (ax, ay) } else { (ay, ax) };
    if hi == 0.0 {
        return 0.0;
    }
    let a = lo / hi;
    let t = a * a;
    let mut p = C[7];
    for k in (0..7).rev() {
        p = p * t + C[k];
    }
    let mut r = a * p;
    if ay > ax {
        r = std::f64::consts::FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = std::f64::consts::PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// The ideal axis lines of a recognised 6R chain at `q = 0` and `T_world_tool(0)^-1` (derived once per model).
#[derive(Debug, Clone)]
pub(crate) struct ClosedForm {
    pub(crate) structure: Structure,
    /// Points on the ideal axis lines (world, m).
    p: [V3; 6],
    /// Unit directions of the ideal axis lines (world).
    h: [V3; 6],
    /// The shared direction of the parallel axes (`h_2`).
    hp: V3,
    /// The sense of each parallel axis along `hp` (±1; 1 for the others).
    sense: [f64; 6],
    /// The point where the meeting axes meet: the wrist centre, or the point of axes 5 and 6.
    c: V3,
    /// A unit vector perpendicular to `h_6`, and one perpendicular to `hp`.
    x6: V3,
    xp: V3,
    /// `T_world_tool(0)^-1`.
    t0_inv: Pose,
}

/// Most branches of a 6R chain.
pub(crate) const MAX_BRANCHES: usize = 8;

/// Most first levels of the branches ([`ClosedForm::partials`]).
pub(crate) const MAX_PARTIALS: usize = 4;

/// The first level of a branch: three joints set ([`ClosedForm::levels`]), the rest to be
/// [`ClosedForm::complete`]d from what they need (`ctx`, `total`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Partial {
    /// The joints set so far (the others zero).
    pub(crate) q: [Cs; 6],
    /// The spherical wrist's `[R_rem h6, R_rem x6]`, or the point `v = H p4` of three parallel axes.
    ctx: [V3; 2],
    /// Three parallel axes: the angle `s2 q2 + s3 q3 + s4 q4`.
    total: Cs,
}

impl Partial {
    pub(crate) const EMPTY: Self = Self { q: [Cs::ZERO; 6], ctx: [V3::new(0.0, 0.0, 0.0); 2], total: Cs::ZERO };
}

/// `R(k, θ) v` (Rodrigues).
#[inline(always)]
pub(super) fn rot(k: &V3, a: Cs, v: &V3) -> V3 {
    v * a.c + k.cross(v) * a.s + k * (k.dot(v) * (1.0 - a.c))
}

/// SP1: `θ` with `R(k, θ) a = b` in the least-squares sense (the angle between the components of `a` and `b`
/// perpendicular to `k`); `None` when one of them is (nearly) along `k` (every `θ` does as well).
#[inline(always)]
pub(super) fn sp1(k: &V3, a: &V3, b: &V3) -> Option<Cs> {
    let (ka, kb) = (k.dot(a), k.dot(b));
    let y = k.dot(&a.cross(b));
    let x = a.dot(b) - ka * kb;
    let r = (x * x + y * y).sqrt();
    (r > 1e-10 * (a.norm_squared() * b.norm_squared()).sqrt()).then(|| Cs { c: x / r, s: y / r })
}

/// The solutions of SP4.
#[derive(Debug, Clone, Copy)]
pub(super) enum Sp4 {
    /// The first 0, 1 or 2 angles (one when the equation has no exact solution: the nearest).
    Angles([Cs; 2], usize),
    /// Every angle solves it (`h^T R(k, θ) p` does not depend on `θ`).
    Any,
}

/// SP4: the angles `θ` with `h^T R(k, θ) p = d` (`k` unit): `A cos θ + B sin θ = C`, i.e. `cos(θ - φ) = C / r`
/// with `(cos φ, sin φ) = (A, B) / r`, `r = sqrt(A² + B²)`; without an exact solution but within [`SP4_SLACK`],
/// the `θ` nearest to one (`θ = φ` or `φ + π`); else none.
#[inline(always)]
pub(super) fn sp4(h: &V3, k: &V3, p: &V3, d: f64) -> Sp4 {
    let kp = k.dot(p);
    let a = h.dot(p) - h.dot(k) * kp; // h · (p - k (k · p))
    let b = h.dot(&k.cross(p));
    let c = d - h.dot(k) * kp;
    let r = (a * a + b * b).sqrt();
    if r <= 1e-12 * (h.norm() * p.norm()).max(1e-300) {
        return Sp4::Any;
    }
    let phi = Cs { c: a / r, s: b / r };
    let x = c / r;
    if x.abs() > 1.0 + SP4_SLACK {
        Sp4::Angles([Cs::ZERO; 2], 0)
    } else if x >= 1.0 {
        Sp4::Angles([phi, phi], 1)
    } else if x <= -1.0 {
        Sp4::Angles([Cs { c: -phi.c, s: -phi.s }, phi], 1)
    } else {
        let t = Cs { c: x, s: (1.0 - x * x).sqrt() };
        Sp4::Angles([phi.add(t), phi.add(t.neg())], 2)
    }
}

/// The angles of an SP4 result, `free` standing in for an unconstrained angle.
#[inline(always)]
pub(super) fn angles(s: Sp4, free: f64) -> ([Cs; 2], usize) {
    match s {
        Sp4::Angles(a, n) => (a, n),
        Sp4::Any => ([Cs::of(free); 2], 1),
    }
}

/// The least-squares point nearest to lines `(p_i, h_i)` (unit `h_i`) and its largest distance from them;
/// `None` when the lines are (nearly) parallel.
pub(super) fn meeting_point(lines: &[(V3, V3)]) -> Option<(V3, f64)> {
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
        let t0 = fk_unchecked(model, &q0);
        let p: [V3; 6] = std::array::from_fn(|i| ax.points[i]);
        let h: [V3; 6] = std::array::from_fn(|i| ax.directions[i]);
        let size = (1..6).map(|i| (p[i] - p[i - 1]).norm()).sum::<f64>() + (t0.translation.vector - p[5]).norm();
        let dist_tol = DISTANCE_TOL * size.max(1e-3);
        let sin = |a: &V3, b: &V3| a.cross(b).norm();
        // the mean direction of parallel axes and each one's sense along it; None if one is not parallel
        let parallel = |idx: &[usize]| -> Option<(V3, [f64; 6])> {
            let mut sense = [1.0; 6];
            let mut sum = V3::zeros();
            for &i in idx {
                if sin(&h[idx[0]], &h[i]) > ANGLE_TOL.sin() {
                    return None;
                }
                sense[i] = h[idx[0]].dot(&h[i]).signum();
                sum += h[i] * sense[i];
            }
            Some((sum.normalize(), sense))
        };
        // distance between two parallel lines of direction d
        let apart = |i: usize, j: usize, d: &V3| {
            let v = p[j] - p[i];
            (v - d * d.dot(&v)).norm()
        };
        let make = |structure, parallel: &[usize], hp: V3, sense: [f64; 6], meeting: &[usize], c: V3| {
            let mut ideal_h = h;
            let mut ideal_p = p;
            for &i in parallel {
                ideal_h[i] = hp * sense[i];
            }
            for &i in meeting {
                ideal_p[i] = c;
            }
            let x6 = any_perpendicular(&ideal_h[5]);
            Self { structure, p: ideal_p, h: ideal_h, hp, sense, c, x6, xp: any_perpendicular(&hp), t0_inv: t0.inverse() }
        };
        // spherical wrist, parallel shoulder
        if let Some((hp, sense)) = parallel(&[1, 2])
            && let Some((w, worst)) = meeting_point(&[(p[3], h[3]), (p[4], h[4]), (p[5], h[5])])
            && worst <= dist_tol
            && sin(&h[0], &hp) >= NOT_PARALLEL
            && sin(&h[3], &h[4]) >= NOT_PARALLEL
            && sin(&h[4], &h[5]) >= NOT_PARALLEL
            && apart(1, 2, &hp) > dist_tol
        {
            return Some(make(Structure::SphericalWrist, &[1, 2], hp, sense, &[3, 4, 5], w));
        }
        // three parallel axes, axes 5 and 6 meeting
        let (hp, sense) = parallel(&[1, 2, 3])?;
        let (c, worst) = meeting_point(&[(p[4], h[4]), (p[5], h[5])])?;
        (worst <= dist_tol
            && sin(&h[0], &hp) >= NOT_PARALLEL
            && sin(&h[4], &hp) >= NOT_PARALLEL
            && sin(&h[4], &h[5]) >= NOT_PARALLEL
            && apart(1, 2, &hp) > dist_tol)
            .then(|| make(Structure::ThreeParallel, &[1, 2, 3], hp, sense, &[4, 5], c))
    }

    /// The branches of `goal` (`T_world_tool`) on the ideal structure into `out`, their number returned
    /// (up to [`MAX_BRANCHES`]); `start` gives the joints left free by a singularity.
    pub(crate) fn branches(&self, goal: &Pose, start: &[f64], out: &mut [[Cs; 6]; MAX_BRANCHES]) -> usize {
        let mut parts = [Partial::EMPTY; MAX_PARTIALS];
        let np = self.partials(goal, start, &mut parts);
        let mut n = 0;
        for part in &parts[..np] {
            let mut leaves = [[Cs::ZERO; 6]; 2];
            let nl = self.complete(part, start, &mut leaves);
            out[n..n + nl].copy_from_slice(&leaves[..nl]);
            n += nl;
        }
        n
    }

    /// The joints a [`Partial`] fixes (the first level of the solution tree) and those [`Self::complete`] adds.
    pub(crate) fn levels(&self) -> ([usize; 3], [usize; 3]) {
        match self.structure {
            Structure::SphericalWrist => ([0, 1, 2], [3, 4, 5]),
            Structure::ThreeParallel => ([0, 4, 5], [1, 2, 3]),
        }
    }

    /// The first level of the branches of `goal` (up to [`MAX_PARTIALS`]): the spherical wrist's arm
    /// (q1, q2, q3), or q1, q5, q6 of three parallel axes; each [`Self::complete`]s to up to 2 branches.
    pub(crate) fn partials(&self, goal: &Pose, start: &[f64], out: &mut [Partial; MAX_PARTIALS]) -> usize {
        let g = goal * self.t0_inv;
        match self.structure {
            Structure::SphericalWrist => self.arms(&g, start, out),
            Structure::ThreeParallel => self.outer(&g, start, out),
        }
    }

    /// The branches (up to 2) that complete `part`, every joint set.
    pub(crate) fn complete(&self, part: &Partial, start: &[f64], out: &mut [[Cs; 6]; 2]) -> usize {
        match self.structure {
            Structure::SphericalWrist => self.wrist(part, start, out),
            Structure::ThreeParallel => self.inner(part, start, out),
        }
    }

    /// `e_i(θ)^-1 x`.
    #[inline(always)]
    fn undo(&self, i: usize, a: Cs, x: &V3) -> V3 {
        self.p[i] + rot(&self.h[i], a.neg(), &(x - self.p[i]))
    }

    /// The planar 2R problem of the parallel axes 2 and 3: `(q2, q3)` with `e_2(q2) e_3(q3) x = v` (in the
    /// plane normal to `h`: the components along `h` are left to the other joints); up to 2 pairs.
    #[inline(always)]
    fn planar(&self, x: &V3, v: &V3, free: (f64, f64), out: &mut [[Cs; 2]; 2]) -> usize {
        let hp = &self.hp;
        let (h2, h3) = (&self.h[1], &self.h[2]);
        let flat = |u: V3| u - hp * hp.dot(&u);
        let u = flat(x - self.p[2]);
        let c = flat(self.p[1] - self.p[2]);
        let goal = flat(v - self.p[1]);
        // |R(h3, q3) u - c| = |goal|: SP3 as SP4
        let (q3s, n) = angles(sp4(&c, h3, &u, (u.norm_squared() + c.norm_squared() - goal.norm_squared()) / 2.0), free.1);
        for k in 0..n {
            let moved = rot(h3, q3s[k], &u) - c; // e_3 x - p_2, flattened
            let q2 = sp1(h2, &moved, &goal).unwrap_or_else(|| Cs::of(free.0));
            out[k] = [q2, q3s[k]];
        }
        n
    }

    /// The arms of a spherical wrist: (q1, q2, q3) placing the wrist centre, and `R_rem = (R1 R2 R3)^T R_G`
    /// applied to h6 and x6 for the wrist.
    fn arms(&self, g: &Pose, start: &[f64], out: &mut [Partial; MAX_PARTIALS]) -> usize {
        let (p, h, w) = (&self.p, &self.h, &self.c);
        let rg = g.rotation.matrix();
        let wd = (g * Point3::from(*w)).coords;
        // the wrist needs R_rem only applied to h6 and x6: rotate R_G h6, R_G x6 back
        let (gh6, gx6) = (rg * h[5], rg * self.x6);
        // q1: h · e_1^-1(w*) = h · w, i.e. h^T R(h1, -q1) (w* - p1) = h · (w - p1)
        let (m1s, n1) = angles(sp4(&self.hp, &h[0], &(wd - p[0]), self.hp.dot(&(w - p[0]))), -start[0]);
        let mut n = 0;
        for &m1 in &m1s[..n1] {
            let q1 = m1.neg();
            let v = self.undo(0, q1, &wd);
            let (h6_1, x6_1) = (rot(&h[0], m1, &gh6), rot(&h[0], m1, &gx6));
            let mut shoulder = [[Cs::ZERO; 2]; 2];
            let n23 = self.planar(w, &v, (start[1], start[2]), &mut shoulder);
            for &[q2, q3] in &shoulder[..n23] {
                // R2 R3 = R(h, s2 q2 + s3 q3)
                let back = q2.times(self.sense[1]).add(q3.times(self.sense[2])).neg();
                let mut q = [Cs::ZERO; 6];
                q[..3].copy_from_slice(&[q1, q2, q3]);
                out[n] = Partial { q, ctx: [rot(&self.hp, back, &h6_1), rot(&self.hp, back, &x6_1)], total: Cs::ZERO };
                n += 1;
            }
        }
        n
    }

    /// The spherical wrist `R(h4, q4) R(h5, q5) R(h6, q6) = R_rem` of an arm, given `[R_rem h6, R_rem x6]`.
    fn wrist(&self, part: &Partial, start: &[f64], out: &mut [[Cs; 6]; 2]) -> usize {
        let (h, rem) = (&self.h, &part.ctx);
        let (q5s, n5) = angles(sp4(&h[3], &h[4], &h[5], h[3].dot(&rem[0])), start[4]);
        for k in 0..n5 {
            let q5 = q5s[k];
            let q4 = sp1(&h[3], &rot(&h[4], q5, &h[5]), &rem[0]).unwrap_or_else(|| Cs::of(start[3]));
            // R6 x6 = R5^T R4^T R_rem x6
            let r6x6 = rot(&h[4], q5.neg(), &rot(&h[3], q4.neg(), &rem[1]));
            let q6 = sp1(&h[5], &self.x6, &r6x6).unwrap_or_else(|| Cs::of(start[5]));
            out[k] = part.q;
            out[k][3..].copy_from_slice(&[q4, q5, q6]);
        }
        n5
    }

    /// The outer joints of three parallel axes: q1, q5, q6, with the point `v = H p4` and the angle
    /// `s2 q2 + s3 q3 + s4 q4` of `H = e_2 e_3 e_4` for the inner ones.
    fn outer(&self, g: &Pose, start: &[f64], out: &mut [Partial; MAX_PARTIALS]) -> usize {
        let (p, h, c, hp, sense) = (&self.p, &self.h, &self.c, &self.hp, &self.sense);
        let rg = g.rotation.matrix();
        let cd = (g * Point3::from(*c)).coords;
        let gh6 = rg * h[5];
        // q1: h · e_1^-1(G c) = h · c
        let (m1s, n1) = angles(sp4(hp, &h[0], &(cd - p[0]), hp.dot(&(c - p[0]))), -start[0]);
        let mut n = 0;
        for &m1 in &m1s[..n1] {
            let q1 = m1.neg();
            // R1 h, and R_G^T R1 h
            let h_1 = rot(&h[0], q1, hp);
            let gt_h1 = rg.tr_mul(&h_1);
            // q5: h^T R1^T R_G h6 = h^T R5 h6
            let (q5s, n5) = angles(sp4(hp, &h[4], &h[5], h_1.dot(&gh6)), start[4]);
            for &q5 in &q5s[..n5] {
                // q6: R6 (R_G^T R1 h) = R5^T h
                let q6 = sp1(&h[5], &gt_h1, &rot(&h[4], q5.neg(), hp)).unwrap_or_else(|| Cs::of(start[5]));
                // e_2 e_3 e_4 = e_1^-1 G e_6^-1 e_5^-1 =: H; a point of axis 4 goes to v = H p4
                let x = self.undo(5, q6, &self.undo(4, q5, &p[3]));
                let v = self.undo(0, q1, &(g * Point3::from(x)).coords);
                // R(h, s2 q2 + s3 q3 + s4 q4) = R1^T R_G R6^T R5^T, applied to xp
                let hx = rot(&h[0], q1.neg(), &(rg * rot(&h[5], q6.neg(), &rot(&h[4], q5.neg(), &self.xp))));
                let total = sp1(hp, &self.xp, &hx).unwrap_or_else(|| Cs::of(sense[1] * start[1] + sense[2] * start[2] + sense[3] * start[3]));
                let mut q = [Cs::ZERO; 6];
                (q[0], q[4], q[5]) = (q1, q5, q6);
                out[n] = Partial { q, ctx: [v, V3::zeros()], total };
                n += 1;
            }
        }
        n
    }

    /// The inner joints q2, q3, q4 of three parallel axes: the planar 2R problem on p4, then q4 from the angle.
    fn inner(&self, part: &Partial, start: &[f64], out: &mut [[Cs; 6]; 2]) -> usize {
        let sense = &self.sense;
        let mut shoulder = [[Cs::ZERO; 2]; 2];
        let n23 = self.planar(&self.p[3], &part.ctx[0], (start[1], start[2]), &mut shoulder);
        for (k, &[q2, q3]) in shoulder[..n23].iter().enumerate() {
            let q4 = part.total.add(q2.times(-sense[1])).add(q3.times(-sense[2])).times(sense[3]);
            out[k] = part.q;
            out[k][1..4].copy_from_slice(&[q2, q3, q4]);
        }
        n23
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_approx_within_3e_7() {
        let mut worst: f64 = 0.0;
        for k in 0..20000 {
            let t = -std::f64::consts::PI + (k as f64 + 0.5) * std::f64::consts::TAU / 20000.0;
            let r = 0.1 + (k % 7) as f64;
            worst = worst.max((atan2_approx(r * t.sin(), r * t.cos()) - t).abs());
        }
        assert!(worst < 3e-7, "{worst}");
        assert_eq!(atan2_approx(0.0, 0.0), 0.0);
    }

    #[test]
    fn subproblems_solve_their_equations() {
        let k = V3::new(0.3, -0.4, 0.5).normalize();
        let (a, t) = (V3::new(0.2, 0.7, -0.1), Cs::of(1.1));
        let b = rot(&k, t, &a);
        let s = sp1(&k, &a, &b).expect("a and b off the axis");
        assert!((s.angle() - 1.1).abs() < 1e-14 && (b - nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(k), 1.1) * a).norm() < 1e-15);
        let h = V3::new(-0.6, 0.2, 0.9);
        let Sp4::Angles(ts, 2) = sp4(&h, &k, &a, h.dot(&b)) else { panic!("two solutions") };
        assert!(ts.iter().any(|x| (x.angle() - 1.1).abs() < 1e-12));
        for x in ts {
            assert!((h.dot(&rot(&k, x, &a)) - h.dot(&b)).abs() < 1e-15);
        }
        assert!(matches!(sp4(&h, &k, &a, 10.0), Sp4::Angles(_, 0)));
        assert!(matches!(sp4(&k, &k, &a, 0.0), Sp4::Any));
    }
}
