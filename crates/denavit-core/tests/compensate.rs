//! Compensation: exact models leave positions unchanged, a known error model is undone to 1e-9 m, and
//! unreachable positions, branch changes and path jumps are flagged.

#![allow(clippy::unwrap_used)] // tests: a failed unwrap is a failed test

mod common;

use denavit_core::compensate::{CompensateOptions, compensate};
use denavit_core::ik::{IkOptions, ik};
use denavit_core::kinematics::fk;
use denavit_core::spatial::{Pose, pose_error, trans};
use denavit_core::{Joint, Model, Table, builtin_planar2};

/// Deterministic configurations of the KR5 whose tool stays 0.1 m or more from the first axis (the shoulder
/// singularity, where the nominal and identified solutions may leave each other's branch).
fn configurations(n: usize, count: usize) -> Vec<Vec<f64>> {
    let m = common::kr5_dh().to_model("kr5").unwrap();
    (0..)
        .map(|k| (0..n).map(|j| ((k * 13 + j * 7 + 1) as f64 * 0.61).sin() * 1.2).collect::<Vec<f64>>())
        .filter(|q| fk(&m, q).unwrap().translation.vector.xy().norm() > 0.1)
        .take(count)
        .collect()
}

/// The KR5 (Hayat Table III, DH) with every parameter perturbed by up to 0.5 mm / 0.05 deg.
fn kr5_pair() -> (Model, Model) {
    let nominal = common::kr5_dh();
    let mut p = nominal.params.clone();
    for i in 0..p.nrows() {
        for j in 0..p.ncols() {
            let s = ((i * 5 + j * 3 + 2) as f64 * 1.37).sin();
            p[(i, j)] += if nominal.convention.angle_columns()[j] { s * 0.05f64.to_radians() } else { s * 0.5e-3 };
        }
    }
    let identified = Table { params: p, ..nominal.clone() };
    (nominal.to_model("nominal").unwrap(), identified.to_model("identified").unwrap())
}

#[test]
fn exact_models_leave_positions_unchanged() {
    let (m, _) = kr5_pair();
    let qs = configurations(6, 40);
    let positions: Vec<Pose> = qs.iter().map(|q| fk(&m, q).unwrap()).collect();
    let flat: Vec<f64> = qs.concat();
    let out = compensate(&m, &m, &positions, Some(&flat), &[0.0; 6], &CompensateOptions::default()).unwrap();
    for (c, (t, q)) in out.iter().zip(positions.iter().zip(&qs)) {
        assert!(c.reached && !c.branch_changed && !c.path_jump);
        let (dp, dr) = pose_error(&c.command, t);
        assert!(dp < 1e-12 && dr < 1e-12, "{dp} {dr}");
        assert!(c.q.iter().zip(q).all(|(a, b)| (a - b).abs() < 1e-12));
        assert!(c.before_position < 1e-12);
    }
}

#[test]
fn a_known_error_model_is_undone() {
    let (nominal, identified) = kr5_pair();
    // a program given as the nominal joint values of each position (independent positions), and a smooth path
    // solved on the nominal model along the way
    let rows = configurations(6, 60);
    let path: Vec<Vec<f64>> = (0..60).map(|k| (0..6).map(|j| 0.3 + 0.8 * ((k as f64) * 0.02 + j as f64).sin()).collect()).collect();
    for (qs, is_path) in [(&rows, false), (&path, true)] {
        let positions: Vec<Pose> = qs.iter().map(|q| fk(&nominal, q).unwrap()).collect();
        let flat = qs.concat();
        let given = if is_path { None } else { Some(flat.as_slice()) };
        let opts = CompensateOptions { path: is_path, ..Default::default() };
        let out = compensate(&nominal, &identified, &positions, given, &qs[0], &opts).unwrap();
        for (c, t) in out.iter().zip(&positions) {
            assert!(c.reached && c.nominal_reached && !c.branch_changed && !c.path_jump, "{c:?}");
            assert!(c.before_position > 1e-4, "the error model moves the tool: {}", c.before_position);
            // the robot (= identified) runs what a nominal controller makes of the command
            let q_cmd = ik(&nominal, &c.command, &c.q, &IkOptions { restarts: 0, ..Default::default() }).unwrap();
            assert!(q_cmd.success);
            let (dp, dr) = pose_error(&fk(&identified, &q_cmd.q).unwrap(), t);
            assert!(dp < 1e-9 && dr < 1e-9, "{dp} {dr}");
        }
    }
}

#[test]
fn unreachable_positions_and_branch_changes_are_flagged() {
    let nominal = builtin_planar2(1.0, 1.0);
    let reach = fk(&nominal, &[0.3, 0.8]).unwrap();
    let far = trans(5.0, 0.0, 0.0) * reach;
    let opts = CompensateOptions { ik: IkOptions { restarts: 5, ..Default::default() }, ..Default::default() };
    let out = compensate(&nominal, &nominal, &[reach, far], None, &[0.3, 0.8], &opts).unwrap();
    assert!(out[0].reached && !out[1].reached && !out[1].nominal_reached);
    // a planar 3R arm reaches a pose elbow-down or elbow-up; the identified elbow cannot bend the nominal
    // solution's way, so its solution leaves the branch
    let planar3 = |lower: f64| {
        let mut j: Vec<Joint> = (0..3)
            .map(|i| Joint::new(format!("j{i}"), denavit_core::JointKind::Revolute, if i == 0 { Pose::identity() } else { trans(1.0, 0.0, 0.0) }))
            .collect();
        j[1].lower = lower;
        Model::new("planar3", Pose::identity(), j, trans(0.5, 0.0, 0.0), Pose::identity()).unwrap()
    };
    let (nominal3, identified3) = (planar3(-std::f64::consts::PI), planar3(0.0));
    let elbow_down = [0.9, -0.8, 0.4];
    let t = fk(&nominal3, &elbow_down).unwrap();
    let out = compensate(
        &nominal3,
        &identified3,
        &[t],
        Some(&elbow_down),
        &[0.0; 3],
        &CompensateOptions { ik: IkOptions { restarts: 50, ..Default::default() }, ..Default::default() },
    )
    .unwrap();
    assert!(out[0].reached && out[0].branch_changed, "{:?}", out[0]);
    assert!(out[0].q[1] > 0.0);
    // a path whose nominal solutions jump
    let q = [0.3, 0.8, 0.35, 0.8, 0.35 + 1.6, -0.8];
    let ts: Vec<Pose> = q.chunks(2).map(|c| fk(&nominal, c).unwrap()).collect();
    let out = compensate(&nominal, &nominal, &ts, Some(&q), &[0.0, 0.0], &CompensateOptions { path: true, ..opts }).unwrap();
    assert_eq!(out.iter().map(|c| c.path_jump).collect::<Vec<_>>(), [false, false, true]);
}

#[test]
fn bad_input_is_an_error() {
    let (m, _) = kr5_pair();
    let two = builtin_planar2(1.0, 1.0);
    let t = fk(&m, &[0.0; 6]).unwrap();
    let e = compensate(&m, &two, &[t], None, &[0.0; 6], &CompensateOptions::default()).unwrap_err();
    assert!(e.to_string().contains("expected 6, got 2"), "{e}");
    let e = compensate(&m, &m, &[t], None, &[0.0; 6], &CompensateOptions { branch_tol: -1.0, ..Default::default() }).unwrap_err();
    assert!(e.to_string().contains("branch_tol"), "{e}");
    let e = compensate(&m, &m, &[t], Some(&[0.0; 5]), &[0.0; 6], &CompensateOptions::default()).unwrap_err();
    assert!(e.to_string().contains("q_nominal"), "{e}");
}
