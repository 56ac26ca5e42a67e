//! Dynamics: RNE, CRBA, Coriolis matrix, ABA against each other, against energy, against a closed form,
//! and TianSui-One in modified-DH and ED-H frames (Guo et al. sec. IV.B); bad input.
#![allow(clippy::unwrap_used)] // tests and benches unwrap: a failure is the test failing
mod common;
use common::*;
use denavit_core::{
    Data, Error, Joint, JointKind, Model,
    dynamics::{self, DynamicsData, Inertia},
    kinematics::{JacobianFrame, jacobian},
    spatial::{Pose, rx, ry, rz, trans},
};
use nalgebra::{DMatrix, DVector, Matrix3, Vector3, Vector6};
use proptest::prelude::*;

/// SplitMix64: a deterministic generator so every random chain is reproducible from its seed.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E3779B97F4A7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }
    /// Uniform in [lo, hi).
    fn uni(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    fn rot(&mut self) -> Pose {
        rz(self.uni(-3.1, 3.1)) * ry(self.uni(-1.5, 1.5)) * rx(self.uni(-3.1, 3.1))
    }
    fn vec3(&mut self, s: f64) -> Vector3<f64> {
        Vector3::new(self.uni(-s, s), self.uni(-s, s), self.uni(-s, s))
    }
    /// A solid ellipsoid of random mass and semi-axes, rotated and displaced: a physically valid link.
    fn inertia(&mut self) -> Inertia {
        let m = self.uni(0.2, 5.0);
        let (a, b, c) = (self.uni(0.02, 0.3), self.uni(0.02, 0.3), self.uni(0.02, 0.3));
        let d = Matrix3::from_diagonal(&Vector3::new(b * b + c * c, a * a + c * c, a * a + b * b)) * (m / 5.0);
        let r = *self.rot().rotation.matrix();
        Inertia::new(m, self.vec3(0.3), r * d * r.transpose()).unwrap()
    }
}

/// A random chain of `n` joints (a fraction of them prismatic) with random link inertias, base and tool.
fn random_model(seed: u64, n: usize) -> Model {
    let mut g = Rng(seed);
    let joints: Vec<Joint> = (0..n)
        .map(|i| {
            let kind = if g.next() < 0.2 { JointKind::Prismatic } else { JointKind::Revolute };
            let p = Pose::from_parts(g.vec3(0.4).into(), g.rot().rotation);
            let mut j = Joint::new(format!("j{}", i + 1), kind, p);
            j.offset = g.uni(-0.5, 0.5);
            j
        })
        .collect();
    let base = Pose::from_parts(g.vec3(0.5).into(), g.rot().rotation);
    let tool = Pose::from_parts(g.vec3(0.2).into(), g.rot().rotation);
    let inertias = (0..n).map(|_| g.inertia()).collect();
    Model::new("random", base, joints, tool, Pose::identity()).unwrap().with_inertias(inertias).unwrap()
}

/// A random state (q, qd, qdd).
fn random_state(seed: u64, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let mut g = Rng(seed ^ 0xDEADBEEF);
    let q = (0..n).map(|_| g.uni(-3.0, 3.0)).collect();
    let qd = (0..n).map(|_| g.uni(-2.0, 2.0)).collect();
    let qdd = (0..n).map(|_| g.uni(-3.0, 3.0)).collect();
    (q, qd, qdd)
}

fn g0() -> Vector3<f64> {
    Vector3::from(dynamics::DEFAULT_GRAVITY)
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

fn scale(v: &[f64]) -> f64 {
    1.0 + v.iter().map(|x| x.abs()).fold(0.0, f64::max)
}

fn rnea(m: &Model, q: &[f64], qd: &[f64], qdd: &[f64], g: &Vector3<f64>, f: Option<&Vector6<f64>>) -> Vec<f64> {
    let mut ws = DynamicsData::new(m);
    dynamics::rnea(m, &mut ws, q, qd, qdd, g, f).unwrap().to_vec()
}

fn mass(m: &Model, q: &[f64]) -> DMatrix<f64> {
    let mut ws = DynamicsData::new(m);
    dynamics::mass_matrix(m, &mut ws, q).unwrap().clone()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// RNE with zero acceleration = C(q, qd) qd + g(q) = bias forces.
    #[test]
    fn rnea_zero_acceleration_is_gravity_plus_coriolis(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, _) = random_state(seed, n);
        let mut ws = DynamicsData::new(&m);
        let tau = dynamics::rnea(&m, &mut ws, &q, &qd, &vec![0.0; n], &g0(), None).unwrap().to_vec();
        let g = dynamics::gravity_torques(&m, &mut ws, &q, &g0()).unwrap().to_vec();
        let b = dynamics::bias_forces(&m, &mut ws, &q, &qd, &g0()).unwrap().to_vec();
        let c = dynamics::coriolis_matrix(&m, &mut ws, &q, &qd).unwrap().clone();
        let cqd = &c * DVector::from_row_slice(&qd);
        let sum: Vec<f64> = (0..n).map(|i| cqd[i] + g[i]).collect();
        prop_assert!(max_abs_diff(&tau, &sum) < 1e-12 * scale(&tau), "rnea {tau:?} vs C qd + g {sum:?}");
        prop_assert!(max_abs_diff(&tau, &b) < 1e-13 * scale(&tau));
    }

    /// Column k of M(q) = RNE with qdd = e_k, qd = 0, no gravity; M symmetric positive definite.
    #[test]
    fn mass_matrix_columns_are_unit_acceleration_torques(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, _, _) = random_state(seed, n);
        let mm = mass(&m, &q);
        for k in 0..n {
            let mut e = vec![0.0; n];
            e[k] = 1.0;
            let col = rnea(&m, &q, &vec![0.0; n], &e, &Vector3::zeros(), None);
            let got: Vec<f64> = mm.column(k).iter().copied().collect();
            prop_assert!(max_abs_diff(&col, &got) < 1e-12 * scale(&col), "column {k}: {got:?} vs {col:?}");
        }
        prop_assert!((&mm - mm.transpose()).amax() == 0.0, "M is symmetric by construction");
        let ev = mm.clone().symmetric_eigenvalues();
        prop_assert!(ev.min() > 0.0, "M positive definite, eigenvalues {ev:?}");
        prop_assert!(mm.clone().cholesky().is_some());
    }

    /// Forward dynamics (ABA and Cholesky with M) inverts inverse dynamics, with gravity and a tool wrench.
    #[test]
    fn forward_dynamics_inverts_inverse_dynamics(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, qdd) = random_state(seed, n);
        let f = Vector6::new(3.0, -2.0, 5.0, 0.4, -0.3, 0.2);
        let tau = rnea(&m, &q, &qd, &qdd, &g0(), Some(&f));
        let mut ws = DynamicsData::new(&m);
        let aba = dynamics::forward_dynamics(&m, &mut ws, &q, &qd, &tau, &g0(), Some(&f)).unwrap().to_vec();
        let chol = dynamics::forward_dynamics_crba(&m, &mut ws, &q, &qd, &tau, &g0(), Some(&f)).unwrap().to_vec();
        prop_assert!(max_abs_diff(&aba, &qdd) < 1e-10, "ABA {aba:?} vs {qdd:?}");
        prop_assert!(max_abs_diff(&chol, &qdd) < 1e-10, "Cholesky {chol:?} vs {qdd:?}");
        prop_assert!(max_abs_diff(&aba, &chol) < 1e-10);
    }

    /// d/dt (T + V) = qdᵀ τ along q(t) = q + qd t + qdd t²/2 (central differences, h = 1e-4: error ~ h^2).
    #[test]
    fn energy_rate_equals_joint_power(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, qdd) = random_state(seed, n);
        let energy = |t: f64, g: &Vector3<f64>| {
            let qt: Vec<f64> = (0..n).map(|i| q[i] + qd[i] * t + 0.5 * qdd[i] * t * t).collect();
            let qdt: Vec<f64> = (0..n).map(|i| qd[i] + qdd[i] * t).collect();
            dynamics::kinetic_energy(&m, &qt, &qdt).unwrap() + dynamics::potential_energy(&m, &qt, g).unwrap()
        };
        for g in [Vector3::zeros(), g0()] {
            let h = 1e-4;
            let rate = (energy(h, &g) - energy(-h, &g)) / (2.0 * h);
            let tau = rnea(&m, &q, &qd, &qdd, &g, None);
            let power: f64 = tau.iter().zip(&qd).map(|(t, v)| t * v).sum();
            prop_assert!((rate - power).abs() < 1e-6 * (1.0 + power.abs() + energy(0.0, &g).abs()), "dE/dt {rate} vs power {power}");
        }
        // and ½ qdᵀ M qd = T
        let mm = mass(&m, &q);
        let v = DVector::from_row_slice(&qd);
        let t = 0.5 * v.dot(&(&mm * &v));
        prop_assert!((t - dynamics::kinetic_energy(&m, &q, &qd).unwrap()).abs() < 1e-12 * (1.0 + t));
    }

    /// Ṁ - 2C is skew-symmetric (equivalently C + Cᵀ = Ṁ), Ṁ by central differences along q + qd t.
    #[test]
    fn mdot_minus_two_c_is_skew(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, _) = random_state(seed, n);
        let h = 1e-5;
        let at = |t: f64| mass(&m, &(0..n).map(|i| q[i] + qd[i] * t).collect::<Vec<_>>());
        let mdot = (at(h) - at(-h)) / (2.0 * h);
        let mut ws = DynamicsData::new(&m);
        let c = dynamics::coriolis_matrix(&m, &mut ws, &q, &qd).unwrap().clone();
        let nn = &mdot - &c * 2.0;
        let tol = 1e-7 * (1.0 + mdot.amax());
        prop_assert!((&nn + nn.transpose()).amax() < tol, "Ṁ - 2C not skew: {}", (&nn + nn.transpose()).amax());
    }

    /// A tool wrench f applied to the robot costs -J_toolᵀ f.
    #[test]
    fn tool_wrench_is_jacobian_transpose(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, qdd) = random_state(seed, n);
        let f = Vector6::new(1.0, -4.0, 2.5, 0.3, 0.7, -0.2);
        let with = rnea(&m, &q, &qd, &qdd, &g0(), Some(&f));
        let without = rnea(&m, &q, &qd, &qdd, &g0(), None);
        let mut d = Data::new(&m);
        jacobian(&m, &mut d, &q, JacobianFrame::Local).unwrap();
        let jtf = d.jacobian.transpose() * f;
        for i in 0..n {
            prop_assert!((with[i] - without[i] + jtf[i]).abs() < 1e-12 * scale(&with));
        }
    }

    /// Moving the whole robot (base) and rotating gravity with it changes nothing.
    #[test]
    fn torques_are_invariant_under_a_change_of_world(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, qdd) = random_state(seed, n);
        let t = trans(0.3, -1.0, 2.0) * rx(0.4) * rz(-1.1);
        let moved = m.with_base(t * m.t_world_base()).unwrap();
        let g = t.rotation * g0();
        let a = rnea(&m, &q, &qd, &qdd, &g0(), None);
        let b = rnea(&moved, &q, &qd, &qdd, &g, None);
        prop_assert!(max_abs_diff(&a, &b) < 1e-12 * scale(&a));
    }

    /// Batch forms = single calls (per-row wrenches too).
    #[test]
    fn batch_equals_single(seed in any::<u64>(), n in 1usize..8, count in 1usize..600) {
        let m = random_model(seed, n);
        let mut qs = vec![]; let mut qds = vec![]; let mut qdds = vec![]; let mut ws6 = vec![];
        for r in 0..count {
            let (q, qd, qdd) = random_state(seed.wrapping_add(r as u64), n);
            qs.extend(q); qds.extend(qd); qdds.extend(qdd);
            ws6.extend([r as f64 * 0.01, 1.0, -2.0, 0.1, 0.0, 0.3]);
        }
        let mut tau = vec![0.0; count * n];
        dynamics::rnea_batch(&m, &qs, &qds, &qdds, &g0(), Some(&ws6), &mut tau).unwrap();
        let mut qdd_out = vec![0.0; count * n];
        dynamics::forward_dynamics_batch(&m, &qs, &qds, &tau, &g0(), Some(&ws6), &mut qdd_out).unwrap();
        let mut mm = vec![0.0; count * n * n];
        dynamics::mass_matrix_batch(&m, &qs, &mut mm).unwrap();
        let mut cc = vec![0.0; count * n * n];
        dynamics::coriolis_matrix_batch(&m, &qs, &qds, &mut cc).unwrap();
        let mut bb = vec![0.0; count * n];
        dynamics::bias_forces_batch(&m, &qs, &qds, &g0(), &mut bb).unwrap();
        let mut gg = vec![0.0; count * n];
        dynamics::gravity_torques_batch(&m, &qs, &g0(), &mut gg).unwrap();
        let mut ws = DynamicsData::new(&m);
        for r in (0..count).step_by(37) {
            let sl = |v: &[f64]| v[r * n..(r + 1) * n].to_vec();
            let w = Vector6::from_row_slice(&ws6[6 * r..6 * r + 6]);
            let t1 = dynamics::rnea(&m, &mut ws, &sl(&qs), &sl(&qds), &sl(&qdds), &g0(), Some(&w)).unwrap().to_vec();
            // the batch runs a lane-parallel kernel of another (classical) form: equal to rounding
            prop_assert!(max_abs_diff(&t1, &sl(&tau)) < 1e-12 * scale(&t1), "{t1:?} vs {:?}", sl(&tau));
            prop_assert!(max_abs_diff(&sl(&qdd_out), &sl(&qdds)) < 1e-10);
            let m1 = dynamics::mass_matrix(&m, &mut ws, &sl(&qs)).unwrap().clone();
            let m1t = m1.transpose();
            prop_assert_eq!(m1t.as_slice(), &mm[r * n * n..(r + 1) * n * n]);
            let c1 = dynamics::coriolis_matrix(&m, &mut ws, &sl(&qs), &sl(&qds)).unwrap().clone();
            let c1t = c1.transpose();
            prop_assert_eq!(c1t.as_slice(), &cc[r * n * n..(r + 1) * n * n]);
            let b1 = dynamics::bias_forces(&m, &mut ws, &sl(&qs), &sl(&qds), &g0()).unwrap().to_vec();
            prop_assert!(max_abs_diff(&b1, &sl(&bb)) < 1e-12 * scale(&b1));
            let g1 = dynamics::gravity_torques(&m, &mut ws, &sl(&qs), &g0()).unwrap().to_vec();
            prop_assert!(max_abs_diff(&g1, &sl(&gg)) < 1e-12 * scale(&g1));
        }
    }

    /// Inertia::transformed: round trip, and a body re-expressed in a frame moved along the chain gives the
    /// same torques (the model's joint frame i moved by a fixed pose, inertia and child placement compensated).
    #[test]
    fn reexpressed_inertias_give_the_same_torques(seed in any::<u64>(), n in 1usize..8) {
        let m = random_model(seed, n);
        let (q, qd, qdd) = random_state(seed, n);
        let mut g = Rng(seed ^ 77);
        // new joint frames: slide along and turn about each joint axis (keeps the axis), T_old_new
        let shifts: Vec<Pose> = (0..n).map(|_| trans(0.0, 0.0, g.uni(-0.3, 0.3)) * rz(g.uni(-3.0, 3.0))).collect();
        let mut joints = m.joints().to_vec();
        for i in 0..n {
            // T_{i-1}_i0' = S_{i-1}^-1 T_{i-1}_i0 S_i
            let prev = if i == 0 { Pose::identity() } else { shifts[i - 1].inverse() };
            joints[i].placement = prev * joints[i].placement * shifts[i];
        }
        let flange = shifts[n - 1].inverse() * m.t_last_flange();
        let m2 = Model::new("shifted", *m.t_world_base(), joints, flange, *m.t_flange_tool()).unwrap();
        let inertias: Vec<Inertia> = m.inertias().iter().zip(&shifts).map(|(i, s)| i.transformed(&s.inverse())).collect();
        let m2 = m2.with_inertias(inertias.clone()).unwrap();
        let f = Vector6::new(0.5, 1.0, -1.5, 0.1, 0.2, 0.3);
        let a = rnea(&m, &q, &qd, &qdd, &g0(), Some(&f));
        let b = rnea(&m2, &q, &qd, &qdd, &g0(), Some(&f));
        prop_assert!(max_abs_diff(&a, &b) < 1e-10 * scale(&a), "{a:?} vs {b:?}");
        let back = inertias[0].transformed(&shifts[0]);
        prop_assert!((back.inertia_com() - m.inertias()[0].inertia_com()).amax() < 1e-14);
        prop_assert!((back.com() - m.inertias()[0].com()).norm() < 1e-14);
        // transfer_inertias finds the same
        let m3 = dynamics::transfer_inertias(&m, &m2, &vec![0.0; n]).unwrap();
        for (x, y) in m3.inertias().iter().zip(m2.inertias()) {
            prop_assert!((x.inertia_origin() - y.inertia_origin()).amax() < 1e-12 && (x.com() - y.com()).norm() < 1e-12);
        }
    }
}

/// The two-link planar arm in closed form (Spong, Hutchinson & Vidyasagar, *Robot Modeling and Control*,
/// sec. 7.4.2; derived again here).
///
/// Joint 1 at the origin, joint 2 at distance l1 along link 1's x axis, both axes along world z; gravity
/// g0 along world -y (in the plane of motion). Link i has mass m_i, centre of mass at (lc_i, 0, z_i) in its
/// joint frame (z_i only lifts it out of the plane) and a full inertia tensor about it whose zz entry is
/// Izz_i. With c1 = lc1 (cos q1, sin q1), c2 = l1 (cos q1, sin q1) + lc2 (cos q12, sin q12):
///
/// T = ½ m1 |ċ1|² + ½ Izz1 q̇1² + ½ m2 |ċ2|² + ½ Izz2 (q̇1 + q̇2)²   (only ω_z = q̇ exists; Ixz, Iyz enter
///     angular momentum about x, y, never the z torques)
/// V = g0 (m1 lc1 sin q1 + m2 (l1 sin q1 + lc2 sin q12))
///
/// M11 = Izz1 + Izz2 + m1 lc1² + m2 (l1² + lc2² + 2 l1 lc2 cos q2)
/// M12 = Izz2 + m2 (lc2² + l1 lc2 cos q2),  M22 = Izz2 + m2 lc2²
/// h = m2 l1 lc2 sin q2  (∂M11/∂q2 = -2h, ∂M12/∂q2 = -h)
/// τ1 = M11 q̈1 + M12 q̈2 - h (2 q̇1 q̇2 + q̇2²) + (m1 lc1 + m2 l1) g0 cos q1 + m2 lc2 g0 cos q12
/// τ2 = M12 q̈1 + M22 q̈2 + h q̇1² + m2 lc2 g0 cos q12
#[test]
fn two_link_planar_arm_matches_closed_form() {
    let (l1, l2) = (0.7, 0.45);
    let (m1, m2, lc1, lc2, g0) = (2.3, 1.1, 0.33, 0.21, 9.81);
    let tensor = |d: Vector3<f64>, t: Pose| {
        let r = t.rotation.matrix();
        r * Matrix3::from_diagonal(&d) * r.transpose()
    };
    let i1 = tensor(Vector3::new(0.05, 0.04, 0.03), rx(0.3) * ry(0.2));
    let i2 = tensor(Vector3::new(0.02, 0.025, 0.015), ry(-0.4) * rz(0.9));
    let (izz1, izz2) = (i1[(2, 2)], i2[(2, 2)]);
    let model = denavit_core::builtin_planar2(l1, l2)
        .with_inertias(vec![Inertia::new(m1, Vector3::new(lc1, 0.0, 0.08), i1).unwrap(), Inertia::new(m2, Vector3::new(lc2, 0.0, -0.05), i2).unwrap()])
        .unwrap();
    let g = Vector3::new(0.0, -g0, 0.0);
    let mut ws = DynamicsData::new(&model);
    let mut r = Rng(42);
    for _ in 0..200 {
        let (q1, q2) = (r.uni(-3.2, 3.2), r.uni(-3.2, 3.2));
        let (qd1, qd2, qdd1, qdd2) = (r.uni(-3.0, 3.0), r.uni(-3.0, 3.0), r.uni(-5.0, 5.0), r.uni(-5.0, 5.0));
        let (c2, s2, c1, c12) = (q2.cos(), q2.sin(), q1.cos(), (q1 + q2).cos());
        let m11 = izz1 + izz2 + m1 * lc1 * lc1 + m2 * (l1 * l1 + lc2 * lc2 + 2.0 * l1 * lc2 * c2);
        let m12 = izz2 + m2 * (lc2 * lc2 + l1 * lc2 * c2);
        let m22 = izz2 + m2 * lc2 * lc2;
        let h = m2 * l1 * lc2 * s2;
        let tau1 = m11 * qdd1 + m12 * qdd2 - h * (2.0 * qd1 * qd2 + qd2 * qd2) + (m1 * lc1 + m2 * l1) * g0 * c1 + m2 * lc2 * g0 * c12;
        let tau2 = m12 * qdd1 + m22 * qdd2 + h * qd1 * qd1 + m2 * lc2 * g0 * c12;
        let tau = dynamics::rnea(&model, &mut ws, &[q1, q2], &[qd1, qd2], &[qdd1, qdd2], &g, None).unwrap();
        assert!((tau[0] - tau1).abs() < 1e-12 && (tau[1] - tau2).abs() < 1e-12, "{tau:?} vs [{tau1}, {tau2}]");
        let mm = dynamics::mass_matrix(&model, &mut ws, &[q1, q2]).unwrap();
        assert!((mm[(0, 0)] - m11).abs() < 1e-12 && (mm[(0, 1)] - m12).abs() < 1e-12 && (mm[(1, 1)] - m22).abs() < 1e-12);
        // C of the Christoffel symbols: [[-h q̇2, -h (q̇1 + q̇2)], [h q̇1, 0]]
        let c = dynamics::coriolis_matrix(&model, &mut ws, &[q1, q2], &[qd1, qd2]).unwrap();
        let expected = [[-h * qd2, -h * (qd1 + qd2)], [h * qd1, 0.0]];
        for (i, row) in expected.iter().enumerate() {
            for (j, e) in row.iter().enumerate() {
                assert!((c[(i, j)] - e).abs() < 1e-12, "C[{i},{j}] = {} vs {e}", c[(i, j)]);
            }
        }
    }
}

/// A prismatic joint lifting a mass vertically: τ = m (q̈ + g), whatever the velocity.
#[test]
fn vertical_prismatic_joint() {
    let j = Joint::new("lift", JointKind::Prismatic, Pose::identity());
    let model = Model::new("lift", Pose::identity(), vec![j], Pose::identity(), Pose::identity())
        .unwrap()
        .with_inertias(vec![Inertia::new(4.0, Vector3::new(0.1, 0.2, 0.3), Matrix3::from_diagonal_element(0.1)).unwrap()])
        .unwrap();
    let mut ws = DynamicsData::new(&model);
    let tau = dynamics::rnea(&model, &mut ws, &[0.3], &[2.0], &[1.5], &g0(), None).unwrap();
    assert!((tau[0] - 4.0 * (1.5 + 9.81)).abs() < 1e-13);
}

/// Illustrative inertial parameters of TianSui-One (NOT published by Guo et al.: plausible values for a
/// 6-axis cobot of this size, used only to compare conventions), each link in its **ED-H** joint frame
/// (frames on the body, Guo et al. sec. III): (mass kg, com m, inertia about com kg m^2 row-major).
/// Kept equal to the inertials of python/denavit/models/tiansui_edh.toml.
pub fn tiansui_inertias_edh() -> Vec<Inertia> {
    let rows: [(f64, [f64; 3], [f64; 9]); 6] = [
        (3.70, [0.0, -0.010, -0.020], [0.0103, 0.0, 0.0, 0.0, 0.0103, 0.0, 0.0, 0.0, 0.0067]),
        (8.39, [-0.203, 0.0, 0.120], [0.0150, 0.0, 0.0015, 0.0, 0.1340, 0.0, 0.0015, 0.0, 0.1330]),
        (2.28, [-0.193, 0.0, 0.012], [0.0041, 0.0, -0.0005, 0.0, 0.0312, 0.0, -0.0005, 0.0, 0.0305]),
        (1.22, [0.0, 0.010, 0.003], [0.0022, 0.0001, 0.0, 0.0001, 0.0021, 0.0002, 0.0, 0.0002, 0.0020]),
        (1.22, [0.0, -0.010, 0.003], [0.0022, -0.0001, 0.0, -0.0001, 0.0021, -0.0002, 0.0, -0.0002, 0.0020]),
        (0.19, [0.0, 0.0, -0.020], [0.00010, 0.0, 0.0, 0.0, 0.00010, 0.0, 0.0, 0.0, 0.00013]),
    ];
    rows.iter().map(|(m, c, i)| Inertia::new(*m, Vector3::from(*c), Matrix3::from_row_slice(i)).unwrap()).collect()
}

/// Guo et al. sec. IV.B: one physical TianSui-One gives the same torques in MD-H and ED-H frames. The
/// inertials are given once, in the ED-H frames, and re-expressed in the MD-H frames with
/// `Inertia::transformed(T_mdh_i^-1 · T_edh_i)` at q = 0 (the frames differ only for joints 4 and 5).
#[test]
fn tiansui_mdh_and_edh_frames_give_the_same_torques() {
    let edh = tiansui_edh().to_model("edh").unwrap().with_inertias(tiansui_inertias_edh()).unwrap();
    let mdh0 = tiansui_mdh().to_model("mdh").unwrap();
    let (mut de, mut dm) = (Data::new(&edh), Data::new(&mdh0));
    denavit_core::kinematics::forward_kinematics(&edh, &mut de, &[0.0; 6]).unwrap();
    denavit_core::kinematics::forward_kinematics(&mdh0, &mut dm, &[0.0; 6]).unwrap();
    let mut inertias = vec![];
    for i in 0..6 {
        let t_mdh_edh = dm.t_world_joint[i].inverse() * de.t_world_joint[i];
        // frames 1-3 and 6 coincide; 4 and 5 differ by a shift of 0.128 m along the joint axis
        let shift = t_mdh_edh.translation.vector;
        let rot = denavit_core::spatial::rotation_angle(&t_mdh_edh.rotation);
        assert!(rot < 1e-12 && shift.x.abs() < 1e-12 && shift.y.abs() < 1e-12, "joint {}: {t_mdh_edh:?}", i + 1);
        let expected = if i == 3 || i == 4 { 0.128 } else { 0.0 };
        assert!((shift.z.abs() - expected).abs() < 1e-12, "joint {}: shift {}", i + 1, shift.z);
        inertias.push(edh.inertias()[i].transformed(&t_mdh_edh));
    }
    let mdh = mdh0.with_inertias(inertias).unwrap();
    // transfer_inertias does the same
    let mdh2 = dynamics::transfer_inertias(&edh, &mdh0, &[0.0; 6]).unwrap();
    for (a, b) in mdh.inertias().iter().zip(mdh2.inertias()) {
        assert!((a.com() - b.com()).norm() < 1e-15 && (a.inertia_com() - b.inertia_com()).amax() < 1e-15);
    }
    let (mut we, mut wm) = (DynamicsData::new(&edh), DynamicsData::new(&mdh));
    let f = Vector6::new(2.0, -1.0, 10.0, 0.2, -0.4, 0.1);
    let mut worst: f64 = 0.0;
    for seed in 0..500u64 {
        let (q, qd, qdd) = random_state(seed, 6);
        let a = dynamics::rnea(&edh, &mut we, &q, &qd, &qdd, &g0(), Some(&f)).unwrap().to_vec();
        let b = dynamics::rnea(&mdh, &mut wm, &q, &qd, &qdd, &g0(), Some(&f)).unwrap().to_vec();
        worst = worst.max(max_abs_diff(&a, &b));
        let ma = dynamics::mass_matrix(&edh, &mut we, &q).unwrap().clone();
        let mb = dynamics::mass_matrix(&mdh, &mut wm, &q).unwrap();
        worst = worst.max((ma - mb).amax());
        let fa = dynamics::forward_dynamics(&edh, &mut we, &q, &qd, &a, &g0(), Some(&f)).unwrap().to_vec();
        assert!(max_abs_diff(&fa, &qdd) < 1e-10);
    }
    assert!(worst < 1e-10, "MD-H vs ED-H torques differ by {worst:e}");
    // the attached inertias differ in frames 4, 5 only (the point of sec. IV.B: ED-H frames sit on the body)
    for i in 0..6 {
        let d = (edh.inertias()[i].com() - mdh.inertias()[i].com()).norm();
        assert_eq!(d > 0.1, i == 3 || i == 4, "link {}", i + 1);
    }
}

#[test]
fn bad_inertias_are_rejected_with_clear_messages() {
    let err = |r: Result<Inertia, Error>| r.unwrap_err().to_string();
    let i3 = Matrix3::identity() * 0.1;
    let e = err(Inertia::new(-2.0, Vector3::zeros(), i3));
    assert!(e.contains("invalid mass") && e.contains("-2 kg"), "{e}");
    let e = err(Inertia::new(f64::NAN, Vector3::zeros(), i3));
    assert!(e.contains("mass (kg) must be finite"), "{e}");
    let mut asym = i3;
    asym[(0, 1)] = 0.01;
    let e = err(Inertia::new(1.0, Vector3::zeros(), asym));
    assert!(e.contains("symmetric") && e.contains("|I - I^T| = 1.000e-2"), "{e}");
    let e = err(Inertia::new(1.0, Vector3::zeros(), Matrix3::from_diagonal(&Vector3::new(0.1, -0.1, 0.1))));
    assert!(e.contains("positive semi-definite"), "{e}");
    let e = err(Inertia::new(1.0, Vector3::zeros(), Matrix3::from_diagonal(&Vector3::new(0.1, 0.1, 0.3))));
    assert!(e.contains("triangle inequality") && e.contains("3.000000e-1 > 2.000000e-1"), "{e}");
    let e = err(Inertia::new(1.0, Vector3::new(0.0, f64::INFINITY, 0.0), i3));
    assert!(e.contains("centre of mass (m) must be finite"), "{e}");
    // the triangle inequality's boundary (a thin rod) and a point mass are valid
    assert!(Inertia::new(1.0, Vector3::zeros(), Matrix3::from_diagonal(&Vector3::new(0.0, 0.1, 0.1))).is_ok());
    assert!(Inertia::point_mass(0.0, Vector3::zeros()).is_ok());
    // rotated tensors keep passing the checks
    let r = (rz(0.3) * rx(1.1)).rotation;
    let rot = r.matrix() * Matrix3::from_diagonal(&Vector3::new(0.0, 0.1, 0.1)) * r.matrix().transpose();
    assert!(Inertia::new(1.0, Vector3::zeros(), rot).is_ok());
    // about the origin: the parallel-axis term is removed before the checks
    let e = err(Inertia::from_origin(1.0, Vector3::new(1.0, 0.0, 0.0), i3));
    assert!(e.contains("positive semi-definite"), "{e}");
    // flat arrays name the link
    let e = dynamics::inertias_from_slices(&[1.0, -1.0], &[0.0; 6], &[0.0; 18]).unwrap_err().to_string();
    assert!(e.contains("invalid mass of link 2"), "{e}");
    let e = dynamics::inertias_from_slices(&[1.0], &[0.0; 2], &[0.0; 9]).unwrap_err().to_string();
    assert!(e.contains("wrong size of centres of mass (n x 3 values): expected 3, got 2"), "{e}");
}

#[test]
fn shape_errors_and_singular_models() {
    let m = random_model(3, 4);
    let mut ws = DynamicsData::new(&m);
    let z4 = [0.0; 4];
    let e = dynamics::rnea(&m, &mut ws, &[0.0; 3], &z4, &z4, &g0(), None).unwrap_err().to_string();
    assert_eq!(e, "wrong size of q: expected 4, got 3");
    let e = dynamics::rnea(&m, &mut ws, &z4, &z4, &[0.0; 5], &g0(), None).unwrap_err().to_string();
    assert_eq!(e, "wrong size of qdd: expected 4, got 5");
    let e = dynamics::rnea(&m, &mut ws, &z4, &[0.0, f64::NAN, 0.0, 0.0], &z4, &g0(), None).unwrap_err().to_string();
    assert_eq!(e, "qd must be finite, got NaN at index 1");
    let e = dynamics::rnea(&m, &mut ws, &z4, &z4, &z4, &Vector3::new(0.0, 0.0, f64::INFINITY), None).unwrap_err().to_string();
    assert!(e.contains("gravity"), "{e}");
    let mut small = DynamicsData::with_nq(3);
    let e = dynamics::mass_matrix(&m, &mut small, &z4).unwrap_err().to_string();
    assert!(e.contains("DynamicsData") && e.contains("expected 4, got 3"), "{e}");
    let e = m.with_inertias(vec![Inertia::zero(); 3]).unwrap_err().to_string();
    assert_eq!(e, "wrong size of link inertias (one per joint): expected 4, got 3");
    // batches
    let mut out = vec![0.0; 8];
    let e = dynamics::rnea_batch(&m, &[0.0; 8], &[0.0; 8], &[0.0; 7], &g0(), None, &mut out).unwrap_err().to_string();
    assert!(e.contains("qdd batch") && e.contains("expected 8, got 7"), "{e}");
    let e = dynamics::rnea_batch(&m, &[0.0; 8], &[0.0; 8], &[0.0; 8], &g0(), Some(&[0.0; 7]), &mut out).unwrap_err().to_string();
    assert!(e.contains("external tool wrenches"), "{e}");
    let mut qs = vec![0.0; 8];
    qs[6] = f64::NAN;
    let e = dynamics::gravity_torques_batch(&m, &qs, &g0(), &mut out).unwrap_err().to_string();
    assert_eq!(e, "q (row 1) must be finite, got NaN at index 2");
    let e = dynamics::mass_matrix_batch(&m, &[0.0; 8], &mut out).unwrap_err().to_string();
    assert!(e.contains("output matrices") && e.contains("expected 32, got 8"), "{e}");
    // a massless last link: forward dynamics reports the singular mass matrix
    let mut inertias = m.inertias().to_vec();
    inertias[3] = Inertia::zero();
    let m0 = m.with_inertias(inertias).unwrap();
    let e = dynamics::forward_dynamics(&m0, &mut ws, &z4, &z4, &z4, &g0(), None).unwrap_err();
    assert!(matches!(e, Error::Degenerate { .. }) && e.to_string().contains("joint 4"), "{e}");
    let e = dynamics::forward_dynamics_crba(&m0, &mut ws, &z4, &z4, &z4, &g0(), None).unwrap_err();
    assert!(matches!(e, Error::Degenerate { .. }) && e.to_string().contains("not positive definite"), "{e}");
    // transfer between models with different axes
    let other = random_model(4, 4);
    let e = dynamics::transfer_inertias(&m, &other, &z4).unwrap_err().to_string();
    assert!(e.contains("joint axis 1 of the target model"), "{e}");
}

#[test]
fn inertias_in_world_and_combined() {
    let m = random_model(9, 3);
    let q = [0.3, -0.2, 0.5];
    let mut d = Data::new(&m);
    denavit_core::kinematics::forward_kinematics(&m, &mut d, &q).unwrap();
    let world: Vec<Inertia> = m.inertias().iter().zip(&d.t_world_joint).map(|(i, t)| i.transformed(t)).collect();
    let back = dynamics::inertias_in_world(&m, &q, &world).unwrap();
    for (a, b) in back.iter().zip(m.inertias()) {
        assert!((a.com() - b.com()).norm() < 1e-14 && (a.inertia_com() - b.inertia_com()).amax() < 1e-14);
    }
    // a payload merged into the last link = the same payload as an external gravity wrench
    let payload = Inertia::new(2.0, Vector3::new(0.05, 0.0, 0.1), Matrix3::from_diagonal_element(0.01)).unwrap();
    let mut inertias = m.inertias().to_vec();
    inertias[2] = inertias[2].combined(&payload);
    let heavy = m.with_inertias(inertias).unwrap();
    let mut ws = DynamicsData::new(&m);
    let a = dynamics::gravity_torques(&heavy, &mut ws, &q, &g0()).unwrap().to_vec();
    // weight of the payload at its centre, as a wrench at the tool (tool axes, moment about the tool origin)
    let t_world_last = d.t_world_joint[2];
    let t_world_tool = t_world_last * m.t_last_tool();
    let c_world = t_world_last.transform_point(&(*payload.com()).into());
    let force_w = g0() * 2.0;
    let moment_w = (c_world.coords - t_world_tool.translation.vector).cross(&force_w);
    let r = t_world_tool.rotation.inverse();
    let f = force_w_tool(&r, &force_w, &moment_w);
    let b = dynamics::rnea(&m, &mut ws, &q, &[0.0; 3], &[0.0; 3], &g0(), Some(&f)).unwrap().to_vec();
    assert!(max_abs_diff(&a, &b) < 1e-12, "{a:?} vs {b:?}");
}

fn force_w_tool(r: &nalgebra::Rotation3<f64>, f: &Vector3<f64>, n: &Vector3<f64>) -> Vector6<f64> {
    let (f, n) = (r * f, r * n);
    Vector6::new(f.x, f.y, f.z, n.x, n.y, n.z)
}
/// The batch kernel special-cases identity and Rx placements (every DH-family table): batch = single calls on
/// the papers' robots, one with a prismatic joint too.
#[test]
fn batch_equals_single_on_dh_family_models() {
    let mut kr5p = kr5_dh();
    kr5p.kinds[2] = JointKind::Prismatic;
    let models = [tiansui_mdh(), tiansui_edh(), kr5_dh(), kr5p];
    for (k, table) in models.iter().enumerate() {
        let m0 = table.to_model("m").unwrap();
        let mut g = Rng(k as u64);
        let m = m0.with_inertias((0..6).map(|_| g.inertia()).collect()).unwrap();
        let count = 37;
        let (mut qs, mut qds, mut qdds) = (vec![], vec![], vec![]);
        for r in 0..count {
            let (a, b, c) = random_state(r as u64 + 100 * k as u64, 6);
            qs.extend(a);
            qds.extend(b);
            qdds.extend(c);
        }
        let f = [1.0, 2.0, -3.0, 0.1, -0.2, 0.3];
        let mut out = vec![0.0; 6 * count];
        dynamics::rnea_batch(&m, &qs, &qds, &qdds, &g0(), Some(&f), &mut out).unwrap();
        let mut ws = DynamicsData::new(&m);
        for r in 0..count {
            let sl = |v: &[f64]| v[6 * r..6 * r + 6].to_vec();
            let t = dynamics::rnea(&m, &mut ws, &sl(&qs), &sl(&qds), &sl(&qdds), &g0(), Some(&Vector6::from_row_slice(&f))).unwrap().to_vec();
            assert!(max_abs_diff(&t, &sl(&out)) < 1e-12 * scale(&t), "model {k} row {r}: {t:?} vs {:?}", sl(&out));
        }
    }
}

/// Finite inputs too large for double precision gave NaN torques and accelerations, which only the CLI caught
/// (issue 16: qd = 1e160, whose square is 1e320): every dynamics entry point, single and batch, refuses joint
/// rates beyond `MAX_RATE` naming the argument, the row and the joint; a result that is not finite all the same
/// (masses of 1e300) is `Error::Overflow` naming the result, where, and what to blame.
#[test]
fn overflowing_inputs_are_an_error_naming_the_argument_not_nan() {
    let m = random_model(7, 4);
    let g = g0();
    let (q, mut qd, qdd) = random_state(7, 4);
    qd[1] = 1e160;
    let mut ws = DynamicsData::new(&m);
    let refused = |e: Error, what: &str| {
        let msg = e.to_string();
        assert!(matches!(e, Error::InvalidArgument { .. }), "{msg}");
        assert_eq!(msg, format!("invalid {what} at joint 2: expected joint rates whose squares are finite (|qd| <= 1.3408e154 rad/s or m/s), got 1e160"));
    };
    refused(dynamics::rnea(&m, &mut ws, &q, &qd, &qdd, &g, None).unwrap_err(), "qd");
    refused(dynamics::bias_forces(&m, &mut ws, &q, &qd, &g).unwrap_err(), "qd");
    let tau = [1.0; 4];
    refused(dynamics::forward_dynamics(&m, &mut ws, &q, &qd, &tau, &g, None).unwrap_err(), "qd");
    refused(dynamics::forward_dynamics_crba(&m, &mut ws, &q, &qd, &tau, &g, None).unwrap_err(), "qd");
    refused(dynamics::coriolis_matrix(&m, &mut ws, &q, &qd).unwrap_err(), "qd");
    refused(dynamics::kinetic_energy(&m, &q, &qd).unwrap_err(), "qd");
    // batches: the row is named (the batch kernel had given finite round-off garbage, 1e161 N m, for this row)
    let rows = 9;
    let qs: Vec<f64> = (0..rows).flat_map(|_| q.clone()).collect();
    let qds: Vec<f64> = (0..rows).flat_map(|r| if r == 6 { qd.clone() } else { vec![0.1; 4] }).collect();
    let qdds = vec![0.2; rows * 4];
    let mut out = vec![0.0; rows * 4];
    refused(dynamics::rnea_batch(&m, &qs, &qds, &qdds, &g, None, &mut out).unwrap_err(), "qd (row 6)");
    refused(dynamics::bias_forces_batch(&m, &qs, &qds, &g, &mut out).unwrap_err(), "qd (row 6)");
    refused(dynamics::forward_dynamics_batch(&m, &qs, &qds, &vec![1.0; rows * 4], &g, None, &mut out).unwrap_err(), "qd (row 6)");
    let mut out2 = vec![0.0; rows * 16];
    refused(dynamics::coriolis_matrix_batch(&m, &qs, &qds, &mut out2).unwrap_err(), "qd (row 6)");
    // large but representable rates still compute
    qd[1] = 1e100;
    assert!(dynamics::rnea(&m, &mut ws, &q, &qd, &qdd, &g, None).unwrap().iter().all(|v| v.is_finite()));
    // a model whose masses overflow: every result names itself, where, and blames the model, not an input
    let huge = Inertia::point_mass(1e300, Vector3::new(1e10, 0.0, 0.0)).unwrap();
    let mh = m.with_inertias(vec![huge; 4]).unwrap();
    let mut wh = DynamicsData::new(&mh);
    let overflow = |e: Error, start: &str| {
        let msg = e.to_string();
        assert!(
            matches!(e, Error::Overflow { .. })
                && msg.starts_with(start)
                && msg.ends_with("the inputs are moderate: the model's parameters (inertias, lengths) overflow double precision"),
            "{msg}"
        );
    };
    overflow(dynamics::mass_matrix(&mh, &mut wh, &q).unwrap_err(), "the mass matrix is not finite (");
    overflow(dynamics::mass_matrix_batch(&mh, &qs, &mut out2).unwrap_err(), "the mass matrix (row 0) is not finite (");
    overflow(dynamics::gravity_torques(&mh, &mut wh, &q, &g).unwrap_err(), "gravity torques is not finite (");
    overflow(dynamics::gravity_torques_batch(&mh, &qs, &g, &mut out).unwrap_err(), "gravity torques (row 0) is not finite (");
    overflow(dynamics::rnea(&mh, &mut wh, &q, &[0.1; 4], &qdd, &g, None).unwrap_err(), "tau is not finite (");
    overflow(dynamics::rnea_batch(&mh, &qs, &vec![0.1; rows * 4], &qdds, &g, None, &mut out).unwrap_err(), "tau (row 0) is not finite (");
    overflow(dynamics::potential_energy(&mh, &q, &g).unwrap_err(), "the potential energy is not finite (");
}
