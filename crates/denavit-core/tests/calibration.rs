//! Calibration chains: the chain of a convention reproduces the model's kinematics, and the analytic
//! identification Jacobian matches central finite differences (tolerance ~ sqrt of the step).
#![allow(clippy::unwrap_used)] // tests: a failed unwrap is a failed test

mod common;

use denavit_core::calibration::{CalibrationChain, CalibrationFactor, JacobianOut, Motion};
use denavit_core::kinematics::fk;
use denavit_core::spatial::{Pose, rx, rz, trans};
use denavit_core::{Error, JointKind};
use nalgebra::{Matrix3, Matrix6xX, Vector3};
use proptest::prelude::*;

/// The ED-H chain of a table, built here independently of the core, factor by factor as docs/conventions.md writes it per row
/// (prismatic: Rx Tx Ty Rz(theta) Tz(c + q)), tool; joint j optionally scaled by parameter `scale[j]`.
fn edh_chain(t: &denavit_core::Table, with_scales: bool) -> (CalibrationChain, Vec<f64>) {
    let n = t.nq();
    let mut f = vec![CalibrationFactor::Fixed(t.t_world_base)];
    let mut x = Vec::new();
    let mut push = |f: &mut Vec<CalibrationFactor>, axis, value: f64, joint| {
        f.push(CalibrationFactor::param(axis, x.len(), joint));
        x.push(value);
    };
    for i in 0..n {
        let r: Vec<f64> = t.params.row(i).iter().copied().collect();
        push(&mut f, Motion::Rx, r[0], None);
        push(&mut f, Motion::Tx, r[1], None);
        push(&mut f, Motion::Ty, r[2], None);
        match t.kinds[i] {
            JointKind::Revolute => {
                push(&mut f, Motion::Tz, r[3], None);
                push(&mut f, Motion::Rz, r[4], Some(i));
            }
            JointKind::Prismatic => {
                push(&mut f, Motion::Rz, r[4], None);
                push(&mut f, Motion::Tz, r[3], Some(i));
            }
        }
    }
    f.push(CalibrationFactor::Fixed(t.t_last_tool));
    let scales = if with_scales {
        (0..n)
            .map(|_| {
                x.push(0.0);
                Some(x.len() - 1)
            })
            .collect()
    } else {
        vec![None; n]
    };
    (CalibrationChain::new(f, x.len(), n, scales).unwrap(), x)
}

/// Rotation vector of a small rotation: `vee((R - R^T) / 2)` = sin(angle) axis (error O(angle^3); nalgebra's
/// `scaled_axis` takes the angle from acos, which loses half the digits for tiny angles).
fn log_so3(r: &Matrix3<f64>) -> Vector3<f64> {
    Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]) / 2.0
}

/// Central differences of [p; phi] w.r.t. every parameter (phi: world-frame rotation vector).
fn numeric_jacobian(chain: &CalibrationChain, x: &[f64], q: &[f64], h: f64) -> Matrix6xX<f64> {
    let mut j = Matrix6xX::zeros(x.len());
    for k in 0..x.len() {
        let (mut xp, mut xm) = (x.to_vec(), x.to_vec());
        xp[k] += h;
        xm[k] -= h;
        let (tp, tm) = (chain.pose(&xp, q).unwrap(), chain.pose(&xm, q).unwrap());
        let dp = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
        let dr = log_so3(&(tp.rotation.matrix() * tm.rotation.matrix().transpose())) / (2.0 * h);
        for r in 0..3 {
            j[(r, k)] = dp[r];
            j[(r + 3, k)] = dr[r];
        }
    }
    j
}

#[test]
fn edh_chain_reproduces_the_model() {
    for t in [common::tiansui_edh(), common::tiansui_mdh(), common::kr5_dh()] {
        let t = denavit_core::extract::convert(&t, denavit_core::Convention::Edh, &Default::default()).unwrap().table;
        let m = t.to_model("m").unwrap();
        let (chain, x) = edh_chain(&t, false);
        for k in 0..20 {
            let q: Vec<f64> = (0..6).map(|i| ((k * 7 + i * 3) as f64 * 0.37).sin() * 2.0).collect();
            let a = fk(&m, &q).unwrap();
            let b = chain.pose(&x, &q).unwrap();
            assert!((a.to_homogeneous() - b.to_homogeneous()).amax() < 1e-12);
        }
    }
}

#[test]
fn jacobian_matches_finite_differences_on_kr5_with_scales() {
    let t = denavit_core::extract::convert(&common::kr5_dh(), denavit_core::Convention::Edh, &Default::default()).unwrap().table;
    let t = denavit_core::Table { t_world_base: trans(0.3, -0.2, 0.1) * rx(0.4) * rz(-1.0), t_last_tool: trans(0.05, 0.03, 0.1) * rx(0.2), ..t };
    let (chain, mut x) = edh_chain(&t, true);
    let np = x.len();
    for (k, v) in x.iter_mut().enumerate().skip(np - 6) {
        *v = 0.01 * (k as f64 - 30.0);
    }
    let q = [0.3, -1.2, 0.8, 2.0, -0.4, 1.1];
    let mut jac = Matrix6xX::zeros(np);
    chain.pose_jacobian(&x, &q, &mut jac).unwrap();
    let num = numeric_jacobian(&chain, &x, &q, 1e-6);
    let err = (&jac - &num).amax();
    assert!(err < 1e-8, "max |analytic - numeric| = {err:e}");
    // the scale columns are q_j times the joint columns
    for (j, qj) in q.iter().enumerate() {
        let joint_col = 5 * j + 4;
        assert!((jac.column(np - 6 + j) - jac.column(joint_col) * *qj).amax() < 1e-14);
    }
}

#[test]
fn batch_matches_single_evaluations() {
    let t = denavit_core::extract::convert(&common::tiansui_mdh(), denavit_core::Convention::Edh, &Default::default()).unwrap().table;
    let (chain, x) = edh_chain(&t, true);
    let np = chain.n_params();
    let n = 1100; // both the one-thread path (first batch below) and the parallel one
    let qs: Vec<f64> = (0..n * 6).map(|i| (i as f64 * 0.731).sin() * 2.5).collect();
    let (mut poses, mut jac) = (vec![0.0; 16 * n], vec![0.0; 6 * np * n]);
    chain.evaluate_batch(&x, &qs, &mut poses, Some(JacobianOut::full(&mut jac))).unwrap();
    let mut only = vec![0.0; 16 * n];
    chain.evaluate_batch(&x, &qs, &mut only, None).unwrap();
    assert_eq!(poses, only);
    let mut j1 = Matrix6xX::zeros(np);
    let (mut small, mut small_jac) = (vec![0.0; 16 * 100], vec![0.0; 6 * np * 100]);
    chain.evaluate_batch(&x, &qs[..600], &mut small, Some(JacobianOut::full(&mut small_jac))).unwrap();
    assert_eq!(small[..], poses[..1600]);
    assert_eq!(small_jac[..], jac[..6 * np * 100]);
    for i in [0, 31, 32, 99, 600, 1099] {
        let t = chain.pose_jacobian(&x, &qs[6 * i..6 * i + 6], &mut j1).unwrap();
        let h = t.to_homogeneous();
        for r in 0..4 {
            for c in 0..4 {
                assert!((poses[16 * i + 4 * r + c] - h[(r, c)]).abs() < 1e-15);
            }
        }
        for r in 0..6 {
            for c in 0..np {
                assert!((jac[i * 6 * np + r * np + c] - j1[(r, c)]).abs() < 1e-15);
            }
        }
    }
}

#[test]
fn selected_rows_and_columns_are_the_full_jacobians_weighted_bit_for_bit() {
    let t = denavit_core::extract::convert(&common::tiansui_mdh(), denavit_core::Convention::Edh, &Default::default()).unwrap().table;
    let (chain, x) = edh_chain(&t, true);
    let np = chain.n_params();
    let cols = [np - 1, 3, 0, 17, 9];
    let weights = [1.0 / 2e-5, 1.0 / 3e-5, 1.0 / 7e-6, 1.0 / 1e-5, 0.5, 3.0];
    for n in [100, 1100] {
        // one thread and the parallel path
        let qs: Vec<f64> = (0..n * 6).map(|i| (i as f64 * 0.377).cos() * 2.7).collect();
        let (mut poses, mut full) = (vec![0.0; 16 * n], vec![0.0; 6 * np * n]);
        chain.evaluate_batch(&x, &qs, &mut poses, Some(JacobianOut::full(&mut full))).unwrap();
        for rows in [3, 6] {
            let (mut p2, mut part) = (vec![0.0; 16 * n], vec![0.0; rows * cols.len() * n]);
            let sel = JacobianOut { out: &mut part, rows, columns: Some(&cols), weights };
            chain.evaluate_batch(&x, &qs, &mut p2, Some(sel)).unwrap();
            assert_eq!(p2, poses);
            for i in 0..n {
                for r in 0..rows {
                    for (k, &c) in cols.iter().enumerate() {
                        let want = full[i * 6 * np + r * np + c] * weights[r];
                        assert_eq!(part[i * rows * cols.len() + r * cols.len() + k].to_bits(), want.to_bits(), "pose {i}, row {r}, parameter {c}");
                    }
                }
            }
        }
    }
    let mut poses = vec![0.0; 16];
    let mut out = vec![0.0; 6];
    let q = [0.0; 6];
    let err = |columns: &[usize], rows: usize, out: &mut [f64], poses: &mut [f64]| {
        chain.evaluate_batch(&x, &q, poses, Some(JacobianOut { out, rows, columns: Some(columns), weights: [1.0; 6] })).unwrap_err().to_string()
    };
    assert!(err(&[1, 1], 3, &mut out, &mut poses).contains("each parameter at most once"), "{}", err(&[1, 1], 3, &mut out, &mut poses));
    assert!(err(&[1, np], 3, &mut out, &mut poses).contains(&format!("parameter indices below {np}")));
    assert!(err(&[1, 2], 7, &mut out, &mut poses).contains("1 to 6"));
    assert!(err(&[1, 2, 3], 3, &mut out, &mut poses).contains("Jacobian output"));
}

#[test]
fn bad_input_names_what_is_wrong() {
    let c =
        CalibrationChain::new(vec![CalibrationFactor::param(Motion::Rz, 0, Some(0)), CalibrationFactor::param(Motion::Tx, 1, None)], 2, 1, vec![None]).unwrap();
    assert_eq!(c.pose(&[0.0], &[0.0]).unwrap_err(), Error::SizeMismatch { what: "calibration parameters x".into(), expected: 2, got: 1 });
    assert!(c.pose(&[0.0, f64::NAN], &[0.0]).unwrap_err().to_string().contains("calibration parameters x must be finite"));
    assert!(c.pose(&[0.0, 1.0], &[0.0, 1.0]).unwrap_err().to_string().contains("wrong size of q: expected 1, got 2"));
    let mut out = vec![0.0; 16];
    assert!(c.evaluate_batch(&[0.0, 1.0], &[0.0, 1.0], &mut out, None).unwrap_err().to_string().contains("poses output"));
    assert!(
        CalibrationChain::new(vec![CalibrationFactor::param(Motion::Rz, 0, Some(2))], 1, 1, vec![None]).unwrap_err().to_string().contains("joint of factor 1")
    );
    assert!(CalibrationChain::new(vec![], 1, 2, vec![None]).unwrap_err().to_string().contains("joint scale entries"));
    assert!(CalibrationChain::new(vec![], 1, 1, vec![Some(4)]).unwrap_err().to_string().contains("scale parameter of joint 1"));
}

fn axis_strategy() -> impl Strategy<Value = Motion> {
    prop_oneof![Just(Motion::Rx), Just(Motion::Ry), Just(Motion::Rz), Just(Motion::Tx), Just(Motion::Ty), Just(Motion::Tz)]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Random chains (any factor order, fixed poses, shared parameters, joint factors with scales): the
    /// analytic Jacobian equals central differences to 1e-7 (step 1e-6).
    #[test]
    fn random_chains_match_finite_differences(
        spec in proptest::collection::vec((axis_strategy(), 0usize..8, proptest::option::of(0usize..3), -1.0f64..1.0), 1..14),
        xs in proptest::collection::vec(-1.5f64..1.5, 11),
        q in proptest::collection::vec(-3.0f64..3.0, 3),
        fixed in proptest::collection::vec(-1.0f64..1.0, 6),
    ) {
        let mut f: Vec<CalibrationFactor> = spec.iter().map(|&(a, p, j, _)| CalibrationFactor::param(a, p, j)).collect();
        let pose: Pose = trans(fixed[0], fixed[1], fixed[2]) * rx(fixed[3]) * rz(fixed[4]);
        f.insert(spec.len() / 2, CalibrationFactor::Fixed(pose));
        let chain = CalibrationChain::new(f, 11, 3, vec![Some(8), None, Some(10)]).unwrap();
        let mut jac = Matrix6xX::zeros(11);
        chain.pose_jacobian(&xs, &q, &mut jac).unwrap();
        let num = numeric_jacobian(&chain, &xs, &q, 1e-6);
        prop_assert!((&jac - &num).amax() < 1e-7, "max err {:e}", (&jac - &num).amax());
    }
}

/// `Table::parametrize`: the chain at its nominal parameters reproduces the table's model (tool included) in
/// every calibration convention, with Hayati's beta exactly where consecutive axes are near-parallel; standard
/// DH is refused on near-parallel axes (the KR5's joints 2-3) and accepted where there are none (the Puma-like
/// table has none only at the wrist, so a two-joint skew arm is used).
#[test]
fn parametrize_reproduces_the_table_model() {
    use denavit_core::Convention;
    use denavit_core::convention::Measure;
    use denavit_core::extract::{ExtractOptions, convert};
    let tool = trans(0.05, 0.03, 0.10) * rx(0.3);
    for source in [common::kr5_dh(), common::tiansui_mdh(), common::tiansui_edh()] {
        for conv in [Convention::Edh, Convention::Mdh, Convention::Dh] {
            let t = convert(&source, conv, &ExtractOptions::default()).unwrap().table;
            for measure in [Measure::Point, Measure::Pose] {
                let p = match t.parametrize("robot", &Pose::identity(), &tool, measure, true) {
                    Ok(p) => p,
                    Err(e) => {
                        assert!(
                            conv == Convention::Dh && matches!(e, Error::Degenerate { .. }) && e.to_string().contains("standard DH cannot calibrate robot"),
                            "{e}"
                        );
                        continue;
                    }
                };
                let x: Vec<f64> = p.params.iter().map(|q| q.value).collect();
                let betas = p.params.iter().filter(|q| q.name.starts_with("beta_")).count();
                assert_eq!(betas, if conv == Convention::Dh { 0 } else { t.near_parallel_pairs().unwrap().len() });
                let chain = CalibrationChain::new(p.factors.clone(), x.len(), t.nq(), p.scales.clone()).unwrap();
                let model = denavit_core::Table { t_last_tool: tool, ..t.clone() }.to_model("m").unwrap();
                for k in 0..20 {
                    let q: Vec<f64> = (0..t.nq()).map(|j| ((k * 7 + j * 3) as f64 * 0.37).sin() * 2.0).collect();
                    let a = chain.pose(&x, &q).unwrap();
                    let b = fk(&model, &q).unwrap();
                    assert!((a.to_homogeneous() - b.to_homogeneous()).amax() < 1e-12, "{conv:?} {measure:?}");
                }
            }
        }
    }
}
