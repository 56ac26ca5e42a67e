//! Inverse kinematics: the honest-success property, reachable and unreachable targets, joint limits,
//! bad input, the Guo et al. sec. V trajectory, path and batch solvers.
#![allow(clippy::unwrap_used)]
mod common;
use common::*;
use denavit_core::{
    Error, Joint, JointKind, Model,
    ik::{IkMethod, IkOptions, IkSolver, Structure, closed_form_branches, closed_form_structure, ik, ik_batch, ik_path, log_rotation},
    kinematics::fk,
    spatial::{Pose, nearest_rotation, pose_error, rx, rz, trans},
};
use nalgebra::{Matrix4, Rotation3, Translation3, Vector3};
use proptest::prelude::*;
use std::f64::consts::PI;

fn lcg_qs(n: usize, count: usize, seed: u64, half_range: f64) -> Vec<Vec<f64>> {
    let mut s = seed;
    (0..count)
        .map(|_| {
            (0..n)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * half_range
                })
                .collect()
        })
        .collect()
}

fn models() -> Vec<Model> {
    vec![tiansui_mdh().to_model("tiansui_mdh").unwrap(), tiansui_edh().to_model("tiansui_edh").unwrap(), kr5_dh().to_model("kr5").unwrap()]
}

/// KR5 with narrower limits (rad): used for the limit tests.
fn kr5_limited() -> Model {
    let m = kr5_dh().to_model("kr5").unwrap();
    let lim = [(-2.9, 2.9), (-1.5, 0.5), (-1.0, 2.5), (-3.0, 3.0), (-2.0, 2.0), (-3.0, 3.0)];
    let joints: Vec<Joint> = m.joints().iter().zip(lim).map(|(j, (lo, hi))| Joint { lower: lo, upper: hi, ..j.clone() }).collect();
    Model::new("kr5_limited", *m.t_world_base(), joints, *m.t_last_flange(), *m.t_flange_tool()).unwrap()
}

fn within_limits(m: &Model, q: &[f64]) -> bool {
    m.joints().iter().zip(q).all(|(j, &v)| v >= j.lower && v <= j.upper)
}

/// Guo et al. sec. V: the initial tool pose 0T (4 decimals in the paper), re-orthonormalised.
fn guo_t0() -> Pose {
    #[rustfmt::skip]
    let m = Matrix4::new(
        -0.7598, 0.4151, 0.5004, -0.3655,
        -0.4391, 0.2399, -0.8658, -0.3712,
        -0.4794, -0.8776, 0.0000, -0.0245,
        0.0, 0.0, 0.0, 1.0,
    );
    let r = nearest_rotation(&m.fixed_view::<3, 3>(0, 0).into());
    Pose::from_parts(Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]), r)
}

fn deg(v: &[f64]) -> Vec<f64> {
    v.iter().map(|x| x.to_radians()).collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// Reported success implies the measured error (recomputed here from the returned q with the public
    /// FK) is within the tolerance asked for; the reported errors are the measured ones; limits hold.
    #[test]
    fn success_is_honest(
        which in 0usize..3,
        q_target in proptest::collection::vec(-PI..PI, 6),
        q0 in proptest::collection::vec(-PI..PI, 6),
        perturb in proptest::collection::vec(-0.3f64..0.3, 6),
        far in proptest::bool::weighted(0.3),
        newton in proptest::bool::ANY,
        respect_limits in proptest::bool::ANY,
        tol_exp_p in -13.0f64..-3.0,
        tol_exp_r in -13.0f64..-3.0,
        max_iterations in 1usize..60,
        restarts in 0usize..4,
        seed in 0u64..1000,
    ) {
        let m = if which == 2 { kr5_limited() } else { models().swap_remove(which) };
        // a reachable target, or one moved off the workspace / rotated away
        let mut target = fk(&m, &q_target).unwrap();
        if far {
            target = trans(perturb[0] * 10.0, perturb[1] * 10.0, perturb[2] * 10.0) * target * rz(perturb[3]);
        }
        let opts = IkOptions {
            method: if newton { IkMethod::Newton } else { IkMethod::Lm },
            tol_position: 10f64.powf(tol_exp_p),
            tol_rotation: 10f64.powf(tol_exp_r),
            max_iterations, restarts, seed, respect_limits, ..Default::default()
        };
        let r = ik(&m, &target, &q0, &opts).unwrap();
        let (p, a) = pose_error(&fk(&m, &r.q).unwrap(), &target);
        prop_assert_eq!(r.position_error, p);
        prop_assert_eq!(r.rotation_error, a);
        if r.success {
            prop_assert!(p <= opts.tol_position && a <= opts.tol_rotation, "success with errors {p:e} m, {a:e} rad");
        } else {
            prop_assert!(p > opts.tol_position || a > opts.tol_rotation || (respect_limits && !within_limits(&m, &r.q)));
        }
        if respect_limits {
            prop_assert!(within_limits(&m, &r.q), "q {:?} outside the limits", r.q);
        }
        prop_assert!(r.restarts <= restarts);
        prop_assert!(r.iterations <= (restarts + 1) * max_iterations);
    }

    /// The SO(3) logarithm inverts the exponential on the whole ball of radius pi.
    #[test]
    fn log_inverts_exp(axis in proptest::collection::vec(-1.0f64..1.0, 3), angle in 0.0f64..PI) {
        let a = Vector3::new(axis[0], axis[1], axis[2]);
        prop_assume!(a.norm() > 1e-3);
        let w = a.normalize() * angle;
        let r = Rotation3::new(w);
        let back = log_rotation(r.matrix());
        prop_assert!((Rotation3::new(back).matrix() - r.matrix()).amax() < 1e-13);
        if angle < PI - 1e-6 {
            prop_assert!((back - w).norm() < 1e-12);
        }
    }
}

#[test]
fn reachable_targets_are_solved_to_1e_10() {
    for m in models() {
        for method in [IkMethod::Lm, IkMethod::Newton] {
            let opts = IkOptions { method, ..Default::default() };
            let mut s = IkSolver::new(&m, opts.clone()).unwrap();
            let qs = lcg_qs(6, 300, 99, PI);
            let mut ok = 0;
            for q in &qs {
                let t = fk(&m, q).unwrap();
                let r = s.solve(&t, &[0.3; 6]).unwrap();
                if r.success {
                    ok += 1;
                    assert!(r.position_error <= 1e-10 && r.rotation_error <= 1e-10);
                }
            }
            // LM with restarts solves every one; plain Newton-Raphson nearly every one
            let need = if method == IkMethod::Lm { 300 } else { 297 };
            assert!(ok >= need, "{} {}: {ok}/300 solved", m.name(), method.name());
        }
    }
}

#[test]
fn unreachable_target_reports_failure_with_the_measured_residual() {
    let m = kr5_dh().to_model("kr5").unwrap();
    // KR5 reaches about 1.4 m from joint 2; a target 5 m away cannot be met
    let target = trans(5.0, 0.0, 0.4);
    for method in [IkMethod::Lm, IkMethod::Newton] {
        let opts = IkOptions { method, restarts: 3, ..Default::default() };
        let r = ik(&m, &target, &[0.3; 6], &opts).unwrap();
        assert!(!r.success);
        let (p, a) = pose_error(&fk(&m, &r.q).unwrap(), &target);
        assert_eq!((r.position_error, r.rotation_error), (p, a));
        assert!(p > 3.0, "residual {p}");
        assert_eq!(r.restarts, 3);
        let e = r.clone().into_result().unwrap_err();
        assert!(matches!(e, Error::NotConverged { .. }));
        assert!(e.to_string().contains("position error"), "{e}");
    }
    // reachable position, but an orientation a planar arm cannot take
    let p2 = denavit_core::builtin_planar2(1.0, 1.0);
    let r = ik(&p2, &(trans(1.0, 1.0, 0.0) * rx(0.5)), &[0.1, 0.5], &IkOptions::default()).unwrap();
    assert!(!r.success && r.rotation_error > 0.1);
}

#[test]
fn joint_limits_are_respected_when_asked() {
    let m = kr5_limited();
    // a configuration outside the limits of joint 2 (lower -1.5, upper 0.5): its pose may still be
    // reachable within the limits by another branch, so check q, not success
    let q_out = [0.2, 1.2, 0.3, 0.1, 0.4, 0.2];
    let target = fk(&m, &q_out).unwrap();
    let free = ik(&m, &target, &[0.2, 1.0, 0.3, 0.1, 0.4, 0.2], &IkOptions { respect_limits: false, ..Default::default() }).unwrap();
    assert!(free.success);
    let held = ik(&m, &target, &[0.2, 1.0, 0.3, 0.1, 0.4, 0.2], &IkOptions::default()).unwrap();
    assert!(within_limits(&m, &held.q), "{:?}", held.q);
    // many random targets inside the limits: every solution within the limits
    let lim: Vec<(f64, f64)> = m.joints().iter().map(|j| (j.lower, j.upper)).collect();
    let mut solved = 0;
    for (k, u) in lcg_qs(6, 100, 5, 0.5).iter().enumerate() {
        let q: Vec<f64> = u.iter().zip(&lim).map(|(u, (lo, hi))| lo + (u + 0.5) * (hi - lo)).collect();
        let t = fk(&m, &q).unwrap();
        let r = ik(&m, &t, &[0.0; 6], &IkOptions { seed: k as u64, ..Default::default() }).unwrap();
        assert!(within_limits(&m, &r.q));
        solved += r.success as usize;
    }
    assert!(solved >= 98, "{solved}/100");
    // a revolute angle outside the limits but 2 pi away from a valid one is wrapped, not clamped
    let q0 = [0.2 + 2.0 * PI, -0.5, 0.3, 0.1, 0.4, 0.2];
    let t = fk(&m, &[0.2, -0.5, 0.3, 0.1, 0.4, 0.2]).unwrap();
    let r = ik(&m, &t, &q0, &IkOptions::default()).unwrap();
    assert!(r.success && r.restarts == 0 && (r.q[0] - 0.2).abs() < 1e-9, "{:?}", r);
}

#[test]
fn bad_input_is_an_error_naming_what_was_expected() {
    let m = kr5_dh().to_model("kr5").unwrap();
    let o = IkOptions::default();
    let t = fk(&m, &[0.1; 6]).unwrap();
    // wrong q0 length
    let e = ik(&m, &t, &[0.0; 5], &o).unwrap_err();
    assert_eq!(e, Error::SizeMismatch { what: "q0".into(), expected: 6, got: 5 });
    assert_eq!(e.to_string(), "wrong size of q0: expected 6, got 5");
    // NaN in q0 or in the target
    assert!(matches!(ik(&m, &t, &[0.0, f64::NAN, 0.0, 0.0, 0.0, 0.0], &o).unwrap_err(), Error::NonFinite { index: 1, .. }));
    let nan = Pose::from_parts(Translation3::new(f64::NAN, 0.0, 0.0), Rotation3::identity());
    let e = ik(&m, &nan, &[0.0; 6], &o).unwrap_err();
    assert!(matches!(e, Error::NonFinite { .. }) && e.to_string().contains("IK goal"), "{e}");
    // a target whose rotation is not orthonormal
    let skew = Pose::from_parts(
        Translation3::new(0.5, 0.0, 0.5),
        Rotation3::from_matrix_unchecked(nalgebra::Matrix3::new(1.0, 0.1, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)),
    );
    let e = ik(&m, &skew, &[0.0; 6], &o).unwrap_err();
    assert!(matches!(e, Error::NotSe3 { .. }) && e.to_string().contains("orthonormal"), "{e}");
    // options
    for bad in [
        IkOptions { tol_position: -1.0, ..Default::default() },
        IkOptions { tol_rotation: f64::NAN, ..Default::default() },
        IkOptions { max_iterations: 0, ..Default::default() },
        IkOptions { damping: 0.0, ..Default::default() },
    ] {
        assert!(matches!(ik(&m, &t, &[0.0; 6], &bad).unwrap_err(), Error::InvalidArgument { .. }));
    }
    // batch: q0s of the wrong size, a bad target among good ones (named by index)
    let e = ik_batch(&m, &[t, t], &[0.0; 7], &o).unwrap_err();
    assert!(matches!(e, Error::SizeMismatch { expected: 12, got: 7, .. }), "{e}");
    let e = ik_path(&m, &[t, nan], &[0.0; 6], &o).unwrap_err();
    assert!(e.to_string().contains("IK goal 1"), "{e}");
    assert!(IkMethod::parse("bfgs").unwrap_err().to_string().contains("expected one of newton, lm"));
}

/// Guo et al. sec. V: from 0T, 100 Newton-Raphson solves along base +Z in 1 mm steps to 1e-10, for the
/// MDH (Table I) and ED-H (Table II) models of TianSui-One. Both models have the same joint variables,
/// so their solutions must agree.
#[test]
fn guo_trajectory_mdh_and_edh() {
    let (mdh, edh) = (tiansui_mdh().to_model("mdh").unwrap(), tiansui_edh().to_model("edh").unwrap());
    let t0 = guo_t0();
    let branch = deg(&[28.65, 30.0, 100.0, 50.0, -1.37, 28.65]);
    let mut sols = vec![];
    for m in [&mdh, &edh] {
        let start = ik(m, &t0, &branch, &IkOptions { method: IkMethod::Newton, restarts: 0, ..Default::default() }).unwrap();
        assert!(start.success && start.iterations <= 6, "{start:?}");
        // the paper's 4-decimal pose is this branch to about 1e-4 rad
        assert!(start.q.iter().zip(&branch).all(|(a, b)| (a - b).abs() < 2e-4), "{:?}", start.q);
        let targets: Vec<Pose> = (1..=100).map(|k| trans(0.0, 0.0, 0.001 * k as f64) * t0).collect();
        for method in [IkMethod::Newton, IkMethod::Lm] {
            let opts = IkOptions { method, ..Default::default() };
            let path = ik_path(m, &targets, &start.q, &opts).unwrap();
            assert!(path.iter().all(|r| r.success && r.restarts == 0 && r.iterations <= 4), "{}", m.name());
            // continuity: 1 mm steps move no joint by more than 0.02 rad on this branch
            let mut prev = start.q.clone();
            for r in &path {
                assert!(r.q.iter().zip(&prev).all(|(a, b)| (a - b).abs() < 0.02));
                prev = r.q.clone();
            }
            // the last pose is 100 mm above 0T
            let last = fk(m, &path[99].q).unwrap();
            assert!((last.translation.vector - t0.translation.vector - Vector3::new(0.0, 0.0, 0.1)).norm() < 1e-10);
            sols.push(path);
        }
    }
    for (k, (a, b)) in sols[0].iter().zip(&sols[2]).enumerate() {
        let d = a.q.iter().zip(&b.q).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
        assert!(d < 1e-9, "MDH and ED-H solutions differ by {d} at step {k}");
    }
}

#[test]
fn batch_matches_path_free_solves_and_is_deterministic() {
    let m = tiansui_mdh().to_model("mdh").unwrap();
    let targets: Vec<Pose> = lcg_qs(6, 200, 3, PI).iter().map(|q| fk(&m, q).unwrap()).collect();
    let opts = IkOptions { tol_position: 1e-9, tol_rotation: 1e-9, ..Default::default() };
    let a = ik_batch(&m, &targets, &[0.3; 6], &opts).unwrap();
    let one_thread = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = one_thread.install(|| ik_batch(&m, &targets, &[0.3; 6], &opts).unwrap());
    assert_eq!(a, b);
    assert!(a.iter().filter(|r| r.success).count() >= 199);
    // per-target starts
    let q0s: Vec<f64> = targets.iter().flat_map(|_| [0.3; 6]).collect();
    assert_eq!(ik_batch(&m, &targets, &q0s, &opts).unwrap(), a);
    // a target solved from q0 in the batch is the single solve's answer (the restarts seed differs)
    for (t, r) in targets.iter().zip(&a).filter(|(_, r)| r.restarts == 0).take(20) {
        assert_eq!(&ik(&m, t, &[0.3; 6], &opts).unwrap(), r);
    }
}

#[test]
fn redundant_and_deficient_chains() {
    // 7 joints: KR5 with an extra revolute joint at the flange (Newton takes the minimum-norm step)
    let k = kr5_dh().to_model("kr5").unwrap();
    let mut joints = k.joints().to_vec();
    joints.push(Joint::new("j7", JointKind::Revolute, trans(0.0, 0.05, 0.1) * rx(0.7)));
    let m7 = Model::new("kr5+1", *k.t_world_base(), joints, *k.t_last_flange(), *k.t_flange_tool()).unwrap();
    let t = fk(&m7, &[0.3, -0.4, 0.5, 0.2, 0.6, -0.3, 0.4]).unwrap();
    for method in [IkMethod::Newton, IkMethod::Lm] {
        let r = ik(&m7, &t, &[0.2, -0.3, 0.4, 0.1, 0.5, -0.2, 0.3], &IkOptions { method, ..Default::default() }).unwrap();
        assert!(r.success, "{method:?} {r:?}");
    }
    // 2 joints: a planar arm reaches in-plane targets with their in-plane orientation
    let p = denavit_core::builtin_planar2(0.7, 0.5);
    let t = fk(&p, &[0.9, -1.4]).unwrap();
    for method in [IkMethod::Newton, IkMethod::Lm] {
        let r = ik(&p, &t, &[0.5, -1.0], &IkOptions { method, ..Default::default() }).unwrap();
        assert!(r.success && (r.q[0] - 0.9).abs() < 1e-9, "{method:?} {r:?}");
    }
}

#[test]
fn restarts_are_deterministic_and_seeded() {
    let m = kr5_dh().to_model("kr5").unwrap();
    let target = trans(3.0, 0.0, 0.4); // unreachable: every restart is used
    let o = IkOptions { restarts: 5, max_iterations: 20, ..Default::default() };
    let a = ik(&m, &target, &[0.0; 6], &o).unwrap();
    assert_eq!(a, ik(&m, &target, &[0.0; 6], &o).unwrap());
    let b = ik(&m, &target, &[0.0; 6], &IkOptions { seed: 1, ..o.clone() }).unwrap();
    assert_ne!(a.q, b.q);
    assert!(a.iterations > 5 && a.restarts == 5);
}

/// A fixed workload for profilers (`cargo test --release --test ik -- --ignored workload`).
#[test]
#[ignore]
fn workload() {
    let m = tiansui_mdh().to_model("mdh").unwrap();
    let targets: Vec<Pose> = lcg_qs(6, 2000, 17, PI).iter().map(|q| fk(&m, q).unwrap()).collect();
    let mut s = IkSolver::new(&m, IkOptions { tol_position: 1e-9, tol_rotation: 1e-9, ..Default::default() }).unwrap();
    let (mut its, t0) = (0, std::time::Instant::now());
    for t in &targets {
        its += s.solve(t, &[0.3; 6]).unwrap().iterations;
    }
    let dt = t0.elapsed().as_secs_f64();
    println!("{} solves, {its} iterations, {:.2} us/solve, {:.0} ns/iteration", targets.len(), dt * 1e6 / 2000.0, dt * 1e9 / its as f64);
}

/// A fixed batch-FK workload for profilers (`cargo test --release --test ik -- --ignored workload_fk`).
#[test]
#[ignore]
fn workload_fk_batch() {
    let m = tiansui_mdh().to_model("mdh").unwrap();
    let qs: Vec<f64> = lcg_qs(6, 100_000, 3, PI).concat();
    let mut out = vec![0.0; 16 * 100_000];
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let t0 = std::time::Instant::now();
    one.install(|| denavit_core::kinematics::fk_batch(&m, &qs, &mut out).unwrap());
    println!("fk batch 100k, 1 thread: {:.2} ms", t0.elapsed().as_secs_f64() * 1e3);
}

/// `m` with the joint limits `deg` (degrees).
fn with_limits(m: Model, deg: [(f64, f64); 6]) -> Model {
    let joints: Vec<Joint> = m.joints().iter().zip(deg).map(|(j, (lo, hi))| Joint { lower: lo.to_radians(), upper: hi.to_radians(), ..j.clone() }).collect();
    Model::new(m.name(), *m.t_world_base(), joints, *m.t_last_flange(), *m.t_flange_tool()).unwrap()
}

/// The 6R built-ins (python/denavit/models/*.toml: the tables and limits) and their closed-form structures.
fn builtins_6r() -> Vec<(Model, Structure)> {
    use denavit_core::{Convention, Table};
    use nalgebra::DMatrix;
    // KR5 as in kr5.toml (KUKA axis senses), rows (d, theta, a, alpha) in m, rad
    let r = |v: f64| v.to_radians();
    #[rustfmt::skip]
    let kr5 = DMatrix::from_row_slice(6, 4, &[
        0.400, 0.0, 0.180, r(-90.0),
        0.0, 0.0, 0.600, 0.0,
        0.0, r(-90.0), 0.120, r(-90.0),
        0.620, 0.0, 0.0, r(90.0),
        0.0, 0.0, 0.0, r(-90.0),
        0.0, 0.0, 0.0, 0.0,
    ]);
    let kr5 = Table::new(Convention::Dh, kr5, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap().to_model("kr5").unwrap();
    let kr5 = with_limits(kr5, [(-155.0, 155.0), (-180.0, 65.0), (-15.0, 158.0), (-350.0, 350.0), (-130.0, 130.0), (-350.0, 350.0)]);
    let puma = with_limits(
        puma560_dh().to_model("puma560").unwrap(),
        [(-160.0, 160.0), (-45.0, 225.0), (-225.0, 45.0), (-110.0, 170.0), (-100.0, 100.0), (-266.0, 266.0)],
    );
    let ur5 = with_limits(ur5_dh().to_model("ur5").unwrap(), [(-360.0, 360.0); 6]);
    let tiansui = tiansui_mdh().to_model("tiansui_mdh").unwrap();
    let tiansui_edh = tiansui_edh().to_model("tiansui_edh").unwrap();
    vec![
        (kr5, Structure::SphericalWrist),
        (puma, Structure::SphericalWrist),
        (ur5, Structure::ThreeParallel),
        (tiansui, Structure::ThreeParallel),
        (tiansui_edh, Structure::ThreeParallel),
    ]
}

/// `count` configurations uniform within the limits (clipped to +-pi), from an LCG.
fn qs_within(m: &Model, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let lim: Vec<(f64, f64)> = m.joints().iter().map(|j| (j.lower.max(-PI), j.upper.min(PI))).collect();
    lcg_qs(6, count, seed, 0.5).iter().map(|u| u.iter().zip(&lim).map(|(u, (lo, hi))| lo + (u + 0.5) * (hi - lo)).collect()).collect()
}

/// Distinct configurations, angles compared modulo 2 pi.
fn distinct(qs: &[Vec<f64>]) -> usize {
    let same = |a: &Vec<f64>, b: &Vec<f64>| a.iter().zip(b).all(|(x, y)| denavit_core::spatial::wrap_angle(x - y).abs() < 1e-6);
    (0..qs.len()).filter(|&i| !qs[..i].iter().any(|b| same(&qs[i], b))).count()
}

/// Every closed-form branch reproduces the target pose (checked by FK), the configuration the target came from
/// is among them, and a generic pose well inside the workspace has 8 distinct branches.
#[test]
fn closed_form_branches_reproduce_the_target() {
    for (m, structure) in builtins_6r() {
        assert_eq!(closed_form_structure(&m), Some(structure), "{}", m.name());
        let mut eight = 0;
        let qs = qs_within(&m, 200, 11);
        for q in &qs {
            let t = fk(&m, q).unwrap();
            let branches = closed_form_branches(&m, &t).unwrap().unwrap();
            assert!(!branches.is_empty() && branches.len() <= 8);
            for b in &branches {
                let (p, a) = pose_error(&fk(&m, b).unwrap(), &t);
                assert!(p < 1e-12 && a < 1e-12, "{}: branch {b:?} of {q:?} is off by {p:e} m, {a:e} rad", m.name());
            }
            assert!(distinct(&[branches.clone(), vec![q.clone()]].concat()) == distinct(&branches), "{}: {q:?} not among its branches", m.name());
            eight += (distinct(&branches) == 8) as usize;
        }
        // a generic pose, where the arm can reach the wrist from behind its shoulder too
        let q = [0.4, 1.0, -2.0, 0.5, 0.8, -0.3];
        let b = closed_form_branches(&m, &fk(&m, &q).unwrap()).unwrap().unwrap();
        assert_eq!(distinct(&b), 8, "{}: {b:?}", m.name());
        println!("{}: {eight}/200 random configurations with 8 distinct branches", m.name());
        assert!(eight >= 100, "{}: {eight}/200 with 8 branches", m.name()); // 119 to 200 of 200 seen
    }
    // not recognised: 2 joints, and a 6R chain whose wrist axes do not meet
    assert!(closed_form_structure(&denavit_core::builtin_planar2(1.0, 1.0)).is_none());
    assert!(closed_form_branches(&denavit_core::builtin_planar2(1.0, 1.0), &Pose::identity()).unwrap().is_none());
    let mut j = kr5_dh().to_model("kr5").unwrap().joints().to_vec();
    j[4].placement = trans(0.0, 0.03, 0.0) * j[4].placement;
    let bent = Model::new("bent", Pose::identity(), j, Pose::identity(), Pose::identity()).unwrap();
    assert!(closed_form_structure(&bent).is_none());
}

/// One attempt returns the closed-form branch nearest to q0 among those within the limits.
#[test]
fn one_attempt_returns_the_branch_nearest_q0() {
    for (m, _) in builtins_6r() {
        for (k, q) in qs_within(&m, 50, 3).iter().enumerate() {
            let t = fk(&m, q).unwrap();
            let q0: Vec<f64> = lcg_qs(6, 1, k as u64, 2.0)[0].iter().zip(m.joints()).map(|(v, j)| v.clamp(j.lower, j.upper)).collect();
            // every placement of each branch by multiples of 2 pi within the limits: the nearest to q0
            let mut best: Option<(f64, Vec<f64>)> = None;
            for b in closed_form_branches(&m, &t).unwrap().unwrap() {
                let mut cand = vec![vec![]];
                for (i, j) in m.joints().iter().enumerate() {
                    let opts: Vec<f64> = (-2..=2).map(|s| b[i] + 2.0 * PI * s as f64).filter(|v| *v >= j.lower && *v <= j.upper).collect();
                    cand = cand.iter().flat_map(|c| opts.iter().map(move |v| [c.clone(), vec![*v]].concat())).collect();
                }
                for c in cand {
                    let d: f64 = c.iter().zip(&q0).map(|(a, b)| (a - b) * (a - b)).sum();
                    if best.as_ref().is_none_or(|(e, _)| d < *e) {
                        best = Some((d, c));
                    }
                }
            }
            let (_, nearest) = best.expect("the target's own configuration is within the limits");
            for method in [IkMethod::Newton, IkMethod::Lm] {
                let r = ik(&m, &t, &q0, &IkOptions { method, restarts: 0, ..Default::default() }).unwrap();
                assert!(r.success, "{} {}: {r:?}", m.name(), method.name());
                let off = r.q.iter().zip(&nearest).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max);
                assert!(off < 1e-8, "{} {}: {:?}, nearest branch {nearest:?}", m.name(), method.name(), r.q);
            }
        }
    }
}

/// One attempt (restarts = 0) from q0 = 0.3 rad on random reachable targets within the limits succeeds at
/// least 97 % of the time on each 6R built-in, for both methods (bench_kinematics.py --ik-one-attempt).
#[test]
fn one_attempt_success_on_builtins() {
    for (m, _) in builtins_6r() {
        let q0: Vec<f64> = m.joints().iter().map(|j| 0.3f64.clamp(j.lower, j.upper)).collect();
        for method in [IkMethod::Newton, IkMethod::Lm] {
            let opts = IkOptions { method, restarts: 0, tol_position: 1e-9, tol_rotation: 1e-9, ..Default::default() };
            let mut s = IkSolver::new(&m, opts).unwrap();
            let qs = qs_within(&m, 500, 7);
            let mut ok = 0;
            for q in &qs {
                let t = fk(&m, q).unwrap();
                let r = s.solve(&t, &q0).unwrap();
                let (p, a) = pose_error(&fk(&m, &r.q).unwrap(), &t);
                assert_eq!(r.success, p <= 1e-9 && a <= 1e-9 && within_limits(&m, &r.q));
                ok += r.success as usize;
            }
            println!("{} {}: {ok}/500", m.name(), method.name());
            assert!(ok >= 485, "{} {}: {ok}/500 solved in one attempt", m.name(), method.name());
        }
    }
}

/// An identified KR5 or UR5 (each joint placement moved by 0.5 mm and turned by 0.5 mrad) keeps its closed-form
/// seeds (from the nearest ideal structure, no longer exact: up to 0.9 mm off) and one attempt still solves, by
/// seed and polish within the polish's budget of 10 evaluations (kr5 298, ur5 300 of 300 seen).
#[test]
fn identified_robots_solve_from_seeds_and_polish() {
    for (which, structure) in [(0, Structure::SphericalWrist), (2, Structure::ThreeParallel)] {
        let (m, _) = builtins_6r().swap_remove(which);
        let d = lcg_qs(6, 6, 17, 1.0);
        let joints: Vec<Joint> = m
            .joints()
            .iter()
            .zip(&d)
            .map(|(j, v)| {
                let dp = Vector3::new(v[0], v[1], v[2]).normalize() * 0.5e-3;
                let dr = Vector3::new(v[3], v[4], v[5]).normalize() * 0.5e-3;
                let moved = Pose::from_parts(Translation3::from(dp), Rotation3::new(dr));
                Joint { placement: j.placement * moved, ..j.clone() }
            })
            .collect();
        let id = Model::new("identified", Pose::identity(), joints, *m.t_last_flange(), Pose::identity()).unwrap();
        assert_eq!(closed_form_structure(&id), Some(structure), "{}", m.name());
        let q0 = [0.3; 6];
        let (mut ok, mut quick) = (0, 0);
        let mut evaluations = vec![];
        let mut seeds_off = 0.0f64;
        let qs = qs_within(&id, 300, 5);
        for q in &qs {
            let t = fk(&id, q).unwrap();
            // the seeds are near, not at, a solution
            for b in closed_form_branches(&id, &t).unwrap().unwrap() {
                seeds_off = seeds_off.max(pose_error(&fk(&id, &b).unwrap(), &t).0);
            }
            let opts = IkOptions { method: IkMethod::Newton, restarts: 0, tol_position: 1e-10, tol_rotation: 1e-10, ..Default::default() };
            let r = ik(&id, &t, &q0, &opts).unwrap();
            ok += r.success as usize;
            quick += (r.success && r.iterations <= 10) as usize;
            evaluations.push(r.iterations);
        }
        evaluations.sort_unstable();
        println!("{}: {ok}/300 solved, {quick} within 10 evaluations (median {}), seeds off by up to {seeds_off:.1e} m", m.name(), evaluations[150]);
        assert!(seeds_off > 1e-5 && seeds_off < 0.05, "{}: seeds off by up to {seeds_off} m", m.name());
        assert!(ok >= 291, "{}: {ok}/300 solved in one attempt", m.name());
        assert!(quick >= 285, "{}: {quick}/300 solved within 10 evaluations", m.name());
    }
}

/// A target out of reach: no closed-form branch, and one attempt reports failure with the measured residual.
#[test]
fn unreachable_targets_fail_honestly_with_a_closed_form() {
    for (m, _) in builtins_6r() {
        let t = fk(&m, &[0.3; 6]).unwrap();
        let far = trans(3.0, 0.0, 0.0) * t;
        assert_eq!(closed_form_branches(&m, &far).unwrap(), Some(vec![]), "{}", m.name());
        let r = ik(&m, &far, &[0.3; 6], &IkOptions { method: IkMethod::Newton, restarts: 0, ..Default::default() }).unwrap();
        assert!(!r.success && r.position_error > 1.0, "{}: {r:?}", m.name());
        assert_eq!(r.position_error, pose_error(&fk(&m, &r.q).unwrap(), &far).0);
    }
}

/// A 7R arm from its joint placements (each followed by the joint's rotation about z), limits in degrees and
/// the flange.
fn arm7(name: &str, placements: [Pose; 7], deg: [(f64, f64); 7], flange: Pose) -> Model {
    let joints: Vec<Joint> = placements
        .iter()
        .zip(deg)
        .enumerate()
        .map(|(i, (p, (lo, hi)))| Joint { lower: lo.to_radians(), upper: hi.to_radians(), ..Joint::new(format!("j{}", i + 1), JointKind::Revolute, *p) })
        .collect();
    Model::new(name, Pose::identity(), joints, flange, Pose::identity()).unwrap()
}

/// The Franka Emika Panda (modified DH of its specification sheet, as tests/data/urdf/panda_style.urdf).
fn panda() -> Model {
    let mdh = |a: f64, d: f64, alpha: f64| rx(alpha) * trans(a, 0.0, 0.0) * trans(0.0, 0.0, d);
    let h = PI / 2.0;
    let r = |v: f64| v.to_degrees();
    arm7(
        "panda",
        [mdh(0.0, 0.333, 0.0), mdh(0.0, 0.0, -h), mdh(0.0, 0.316, h), mdh(0.0825, 0.0, h), mdh(-0.0825, 0.384, -h), mdh(0.0, 0.0, h), mdh(0.088, 0.0, h)],
        [
            (r(-2.8973), r(2.8973)),
            (r(-1.7628), r(1.7628)),
            (r(-2.8973), r(2.8973)),
            (r(-3.0718), r(-0.0698)),
            (r(-2.8973), r(2.8973)),
            (r(-0.0175), r(3.7525)),
            (r(-2.8973), r(2.8973)),
        ],
        trans(0.0, 0.0, 0.107),
    )
}

/// The KUKA LBR iiwa 14 R820 (standard DH: d = 0.36, 0, 0.42, 0, 0.4, 0, 0.126 m; alpha = -90, 90, 90, -90, -90,
/// 90, 0 deg; limits +-170, 120, 170, 120, 170, 120, 175 deg).
fn iiwa14() -> Model {
    let h = PI / 2.0;
    let dh = |d: f64, alpha: f64| trans(0.0, 0.0, d) * rx(alpha);
    arm7(
        "iiwa14",
        [Pose::identity(), dh(0.36, -h), dh(0.0, h), dh(0.42, h), dh(0.0, -h), dh(0.4, -h), dh(0.0, h)],
        [(-170.0, 170.0), (-120.0, 120.0), (-170.0, 170.0), (-120.0, 120.0), (-170.0, 170.0), (-120.0, 120.0), (-175.0, 175.0)],
        dh(0.126, 0.0),
    )
}

/// `count` configurations of a 7R arm uniform within the limits (clipped to +-pi), from an LCG.
fn qs_within7(m: &Model, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let lim: Vec<(f64, f64)> = m.joints().iter().map(|j| (j.lower.max(-PI), j.upper.min(PI))).collect();
    lcg_qs(7, count, seed, 0.5).iter().map(|u| u.iter().zip(&lim).map(|(u, (lo, hi))| lo + (u + 0.5) * (hi - lo)).collect()).collect()
}

/// One attempt (restarts = 0) from q0 = 0.3 rad on random reachable targets solves at least 97 % on the 7R Panda
/// and iiwa, without joint limits and within them, for both methods (bench_kinematics.py --ik-one-attempt);
/// the verdict is the measured error.
#[test]
fn one_attempt_success_on_7r_arms() {
    for m in [panda(), iiwa14()] {
        let q0: Vec<f64> = m.joints().iter().map(|j| 0.3f64.clamp(j.lower, j.upper)).collect();
        let qs = qs_within7(&m, 200, 11);
        for respect_limits in [false, true] {
            for method in [IkMethod::Newton, IkMethod::Lm] {
                let opts = IkOptions { method, restarts: 0, tol_position: 1e-9, tol_rotation: 1e-9, respect_limits, ..Default::default() };
                let mut s = IkSolver::new(&m, opts).unwrap();
                let mut ok = 0;
                for q in &qs {
                    let t = fk(&m, q).unwrap();
                    let r = s.solve(&t, &q0).unwrap();
                    let (p, a) = pose_error(&fk(&m, &r.q).unwrap(), &t);
                    assert_eq!(r.success, p <= 1e-9 && a <= 1e-9 && (!respect_limits || within_limits(&m, &r.q)));
                    assert!(r.iterations <= 100 && r.restarts == 0);
                    ok += r.success as usize;
                }
                println!("{} limits {respect_limits} {}: {ok}/200", m.name(), method.name());
                assert!(ok >= 194, "{} limits {respect_limits} {}: {ok}/200 solved in one attempt", m.name(), method.name());
            }
        }
    }
}

/// An identified Panda or iiwa (each joint placement moved by 0.5 mm and turned by 0.5 mrad) keeps its
/// semi-analytic seeds (on the nearest ideal structure, no longer exact) and one attempt still solves them by seed
/// and polish.
#[test]
fn identified_7r_arms_solve_from_seeds_and_polish() {
    for m in [panda(), iiwa14()] {
        let d = lcg_qs(6, 7, 23, 1.0);
        let joints: Vec<Joint> = m
            .joints()
            .iter()
            .zip(&d)
            .map(|(j, v)| {
                let dp = Vector3::new(v[0], v[1], v[2]).normalize() * 0.5e-3;
                let dr = Vector3::new(v[3], v[4], v[5]).normalize() * 0.5e-3;
                Joint { placement: j.placement * Pose::from_parts(Translation3::from(dp), Rotation3::new(dr)), ..j.clone() }
            })
            .collect();
        let id = Model::new("identified", Pose::identity(), joints, *m.t_last_flange(), Pose::identity()).unwrap();
        let q0: Vec<f64> = id.joints().iter().map(|j| 0.3f64.clamp(j.lower, j.upper)).collect();
        let qs = qs_within7(&id, 200, 5);
        let opts = IkOptions { method: IkMethod::Newton, restarts: 0, tol_position: 1e-10, tol_rotation: 1e-10, ..Default::default() };
        let mut s = IkSolver::new(&id, opts).unwrap();
        let (mut ok, mut quick) = (0, 0);
        for q in &qs {
            let t = fk(&id, q).unwrap();
            let r = s.solve(&t, &q0).unwrap();
            let (p, a) = pose_error(&fk(&id, &r.q).unwrap(), &t);
            assert_eq!(r.success, p <= 1e-10 && a <= 1e-10 && within_limits(&id, &r.q));
            ok += r.success as usize;
            quick += (r.success && r.iterations <= 10) as usize;
        }
        println!("identified {}: {ok}/200 solved, {quick} within 10 evaluations", m.name());
        assert!(ok >= 194, "identified {}: {ok}/200 solved in one attempt", m.name());
        assert!(quick >= 180, "identified {}: {quick}/200 solved within 10 evaluations", m.name());
    }
}

/// A target out of the 7R arms' reach: no seed, and one attempt reports failure with the measured residual
/// within its budget.
#[test]
fn unreachable_targets_fail_honestly_on_7r_arms() {
    for m in [panda(), iiwa14()] {
        for respect_limits in [false, true] {
            let opts = IkOptions { method: IkMethod::Newton, restarts: 0, respect_limits, ..Default::default() };
            let t = trans(2.0, 0.5, 0.4);
            let r = ik(&m, &t, &[0.3, 0.3, 0.3, -0.3, 0.3, 0.3, 0.3], &opts).unwrap();
            let (p, a) = pose_error(&fk(&m, &r.q).unwrap(), &t);
            assert!(!r.success && r.position_error == p && r.rotation_error == a && p > 0.5, "{} {r:?}", m.name());
            assert!(r.iterations <= 100);
        }
    }
}
