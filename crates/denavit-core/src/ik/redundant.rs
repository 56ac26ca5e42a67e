//! Semi-analytic IK of 7R arms with a spherical shoulder and two meeting wrist axes (Franka Emika Panda, UFactory
//! xArm7, KUKA LBR iiwa): the seeds of [`super::IkSolver`]'s first attempt on such arms.
//!
//! The arm is parametrised by its last joint, as analytic Panda solvers do (He & Liu 2021, "Analytical inverse
//! kinematics for Franka Emika Panda", taking q7 as the redundancy parameter): for a fixed `q7` the rest is a 6R
//! chain solved in closed form by the subproblems of [`super::closed_form`] (Elias & Wen 2022, "IK-Geo"). Axes 1,
//! 2, 3 meet in the shoulder `S`, axes 5 and 6 in the point `W`; written as a product of exponentials about the
//! axis lines at `q = 0` (module `closed_form`), a goal gives `G' = G e_7(q7)^-1 = e_1 ... e_6` and
//! * `e_5`, `e_6` keep `W` and `e_1 e_2 e_3` rotate about `S`, so `|G' W - S| = |e_4(q4) W - S|` (SP3: q4, 2
//!   branches);
//! * `R_G'^T (G' W - S) = R_6^T R_5^T R_4^T (e_4 W - S)` (SP4 then SP1: q5, q6, 2 branches);
//! * `R_1 R_2 R_3 = R_G' R_6^T R_5^T R_4^T` (the spherical shoulder: q2 by SP4, q1 and q3 by SP1, 2 branches).
//!
//! Up to 8 branches per sample of `q7`. The caller samples `q7` from its start value outwards and tries the
//! branches nearest to the start first. A robot within the tolerances of this structure (an identified one) is
//! solved on the nearest ideal structure and the caller polishes the seeds on the true model.

use super::closed_form::{Cs, DISTANCE_TOL, NOT_PARALLEL, angles, meeting_point, rot, sp1, sp4};
use crate::axes::axes;
use crate::kinematics::fk_unchecked;
use crate::model::{JointKind, Model};
use crate::spatial::{Pose, any_perpendicular};
use nalgebra::{Matrix3, Vector3};

type V3 = Vector3<f64>;

/// Most branches per sample of `q7`.
pub(crate) const MAX_BRANCHES7: usize = 8;

/// The ideal axis lines of a recognised 7R arm at `q = 0` (derived once per model).
#[derive(Debug, Clone)]
pub(crate) struct Redundant {
    /// Points on the ideal axis lines (world, m).
    p: [V3; 7],
    /// Unit directions of the axis lines (world).
    h: [V3; 7],
    /// The shoulder (axes 1, 2, 3) and the point of axes 5 and 6.
    s: V3,
    w: V3,
    /// A unit vector perpendicular to `h_3`.
    x3: V3,
    /// `T_world_tool(0)^-1`.
    t0_inv: Pose,
}

/// What the samples of one goal share: `G = T* T_world_tool(0)^-1`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Target7 {
    rg: Matrix3<f64>,
    tg: V3,
}

impl Redundant {
    /// The structure of `model` when it is a 7R chain whose axes 1, 2, 3 meet in one point and axes 5, 6 in
    /// another (within the tolerances of the 6R closed forms), else `None`.
    pub(crate) fn new(model: &Model) -> Option<Self> {
        if model.nq() != 7 || model.joints().iter().any(|j| j.kind != JointKind::Revolute) {
            return None;
        }
        let q0 = [0.0; 7];
        let ax = axes(model, &q0).ok()?;
        let t0 = fk_unchecked(model, &q0);
        let mut p: [V3; 7] = std::array::from_fn(|i| ax.points[i]);
        let h: [V3; 7] = std::array::from_fn(|i| ax.directions[i]);
        let size = (1..7).map(|i| (p[i] - p[i - 1]).norm()).sum::<f64>() + (t0.translation.vector - p[6]).norm();
        let dist_tol = DISTANCE_TOL * size.max(1e-3);
        let sin = |a: &V3, b: &V3| a.cross(b).norm();
        let (s, worst_s) = meeting_point(&[(p[0], h[0]), (p[1], h[1]), (p[2], h[2])])?;
        let (w, worst_w) = meeting_point(&[(p[4], h[4]), (p[5], h[5])])?;
        // distance of a point from axis 4's line
        let off4 = |x: &V3| {
            let v = x - p[3];
            (v - h[3] * h[3].dot(&v)).norm()
        };
        let ok = worst_s <= dist_tol
            && worst_w <= dist_tol
            && sin(&h[0], &h[1]) >= NOT_PARALLEL
            && sin(&h[1], &h[2]) >= NOT_PARALLEL
            && sin(&h[4], &h[5]) >= NOT_PARALLEL
            && (w - s).norm() > dist_tol
            && off4(&s) > dist_tol
            && off4(&w) > dist_tol;
        if !ok {
            return None;
        }
        for i in 0..3 {
            p[i] = s;
        }
        p[4] = w;
        p[5] = w;
        Some(Self { p, h, s, w, x3: any_perpendicular(&h[2]), t0_inv: t0.inverse() })
    }

    /// `G` of `goal`.
    pub(crate) fn goal(&self, goal: &Pose) -> Target7 {
        let g = goal * self.t0_inv;
        Target7 { rg: *g.rotation.matrix(), tg: g.translation.vector }
    }

    /// The branches (up to [`MAX_BRANCHES7`]) of the goal with `q7` fixed, into `out` (`out[k][6]` is `q7`);
    /// `start` gives the joints left free by a singularity.
    pub(crate) fn branches(&self, g: &Target7, q7: f64, start: &[f64], out: &mut [[Cs; 7]; MAX_BRANCHES7]) -> usize {
        let (p, h, s, w) = (&self.p, &self.h, &self.s, &self.w);
        let c7 = Cs::of(q7);
        // G' = G e_7^-1: R_G' v = R_G R(h7, -q7) v, G' x = G (p7 + R(h7, -q7) (x - p7))
        let rgp = |v: &V3| g.rg * rot(&h[6], c7.neg(), v);
        let gw = g.rg * (p[6] + rot(&h[6], c7.neg(), &(w - p[6]))) + g.tg;
        let d = gw - s;
        // q4: |p4 + R(h4, q4) u - S| = |d|, u = W - p4, c = p4 - S: c . R u = (|d|² - |u|² - |c|²) / 2
        let u = w - p[3];
        let c = p[3] - s;
        let (q4s, n4) = angles(sp4(&c, &h[3], &u, (d.norm_squared() - u.norm_squared() - c.norm_squared()) / 2.0), start[3]);
        // R_G'^T (G' W - S)
        let b = g.rg.tr_mul(&d);
        let b = rot(&h[6], c7, &b);
        let mut n = 0;
        for &q4 in &q4s[..n4] {
            // a = R4^T (e_4 W - S) = u + R4^T c
            let a = u + rot(&h[3], q4.neg(), &c);
            // R(h6, -q6) R(h5, -q5) a = b
            let (m5s, n5) = angles(sp4(&h[5], &h[4], &a, h[5].dot(&b)), -start[4]);
            for &m5 in &m5s[..n5] {
                let a5 = rot(&h[4], m5, &a);
                let m6 = sp1(&h[5], &a5, &b).unwrap_or_else(|| Cs::of(-start[5]));
                let (q5, q6) = (m5.neg(), m6.neg());
                // M = R_G' R6^T R5^T R4^T, applied to h3 and x3
                let mv = |v: &V3| rgp(&rot(&h[5], m6, &rot(&h[4], m5, &rot(&h[3], q4.neg(), v))));
                let (mh3, mx3) = (mv(&h[2]), mv(&self.x3));
                // q2: h1 . R(h2, q2) h3 = h1 . M h3
                let (q2s, n2) = angles(sp4(&h[0], &h[1], &h[2], h[0].dot(&mh3)), start[1]);
                for &q2 in &q2s[..n2] {
                    let q1 = sp1(&h[0], &rot(&h[1], q2, &h[2]), &mh3).unwrap_or_else(|| Cs::of(start[0]));
                    // R(h3, q3) x3 = R2^T R1^T M x3
                    let back = rot(&h[1], q2.neg(), &rot(&h[0], q1.neg(), &mx3));
                    let q3 = sp1(&h[2], &self.x3, &back).unwrap_or_else(|| Cs::of(start[2]));
                    out[n] = [q1, q2, q3, q4, q5, q6, c7];
                    n += 1;
                }
            }
        }
        n
    }
}
