//! A model with no joints: every public algorithm gives a valid empty result or an error, never a panic.
#![allow(clippy::unwrap_used)] // tests and benches unwrap: a failure is the test failing
use denavit_core::{
    Convention, Data, JointAxes, JointKind, Model, Table,
    axes::axes,
    calibration::{CalibrationChain, CalibrationFactor, Motion},
    dynamics::{self, DynamicsData},
    extract::{ExtractOptions, convert, extract},
    ik::{IkMethod, IkOptions, IkSolver, ik, ik_batch, ik_path},
    kinematics::{JacobianFrame, fk, fk_batch, forward_kinematics, jacobian, jacobian_batch, jacobian_row_major_unchecked},
    spatial::{Pose, rx, trans},
};
use nalgebra::{DMatrix, Vector3, Vector6};

fn empty() -> Model {
    Model::new("empty", trans(0.1, 0.2, 0.3), vec![], trans(0.0, 0.0, 0.1), rx(0.2)).unwrap()
}

#[test]
fn kinematics_of_a_model_without_joints() {
    let m = empty();
    let t = fk(&m, &[]).unwrap();
    assert_eq!(t, *m.t_world_base() * m.t_last_tool());
    let mut d = Data::new(&m);
    forward_kinematics(&m, &mut d, &[]).unwrap();
    assert_eq!((d.t_world_joint.len(), d.t_world_tool), (0, t));
    for frame in [JacobianFrame::World, JacobianFrame::LocalWorldAligned, JacobianFrame::Base, JacobianFrame::Local] {
        jacobian(&m, &mut d, &[], frame).unwrap();
        assert_eq!(d.jacobian.ncols(), 0);
        jacobian_row_major_unchecked(&m, &[], frame, None, &mut []);
        let mut out = vec![];
        jacobian_batch(&m, &[], frame, None, &mut out).unwrap();
    }
    let mut out = vec![];
    fk_batch(&m, &[], &mut out).unwrap();
    assert!(fk(&m, &[0.0]).is_err());
}

#[test]
fn conventions_of_a_model_without_joints() {
    let m = empty();
    // no axes: the model's axes are empty, and extracting every convention from them gives an empty table
    // with the same tool pose (a user cannot build empty axes: JointAxes::new asks for one)
    let ax = axes(&m, &[]).unwrap();
    assert_eq!((ax.nq(), ax.t_world_tool), (0, fk(&m, &[]).unwrap()));
    assert!(JointAxes::new(Pose::identity(), vec![], vec![], vec![], vec![], Pose::identity(), vec![], vec![]).is_err());
    for c in Convention::ALL {
        let e = extract(&ax, c, &ExtractOptions::default()).unwrap();
        assert_eq!(e.table.nq(), 0);
        assert_eq!(fk(&e.table.to_model("back").unwrap(), &[]).unwrap(), ax.t_world_tool, "{}", c.name());
    }
    for c in Convention::ALL {
        let t = Table::new(c, DMatrix::zeros(0, c.columns().len()), vec![], trans(0.1, 0.2, 0.3), trans(0.0, 0.0, 0.1)).unwrap();
        let m = t.to_model("empty").unwrap();
        assert_eq!(fk(&m, &[]).unwrap(), trans(0.1, 0.2, 0.4), "{}", c.name());
        assert!(t.link_frames().is_empty());
        assert_eq!(t.frames(&[]).unwrap(), vec![t.t_world_base]);
        assert!(t.to_model_with("empty", &[], &[], &[]).is_ok());
        for to in Convention::ALL {
            let e = convert(&t, to, &ExtractOptions::default()).unwrap();
            assert_eq!(e.table.nq(), 0);
            assert_eq!(e.max_position_error, 0.0);
        }
    }
}

#[test]
fn dynamics_of_a_model_without_joints() {
    let m = empty();
    let mut ws = DynamicsData::new(&m);
    let g = Vector3::new(0.0, 0.0, -9.81);
    let f = Vector6::new(1.0, 2.0, 3.0, 0.1, 0.2, 0.3);
    assert!(dynamics::rnea(&m, &mut ws, &[], &[], &[], &g, Some(&f)).unwrap().is_empty());
    assert!(dynamics::bias_forces(&m, &mut ws, &[], &[], &g).unwrap().is_empty());
    assert!(dynamics::gravity_torques(&m, &mut ws, &[], &g).unwrap().is_empty());
    assert_eq!(dynamics::mass_matrix(&m, &mut ws, &[]).unwrap().nrows(), 0);
    assert_eq!(dynamics::coriolis_matrix(&m, &mut ws, &[], &[]).unwrap().nrows(), 0);
    assert!(dynamics::forward_dynamics(&m, &mut ws, &[], &[], &[], &g, Some(&f)).unwrap().is_empty());
    assert!(dynamics::forward_dynamics_crba(&m, &mut ws, &[], &[], &[], &g, Some(&f)).unwrap().is_empty());
    assert_eq!(dynamics::kinetic_energy(&m, &[], &[]).unwrap(), 0.0);
    assert_eq!(dynamics::potential_energy(&m, &[], &g).unwrap(), 0.0);
    let mut out = vec![];
    dynamics::rnea_batch(&m, &[], &[], &[], &g, None, &mut out).unwrap();
    dynamics::bias_forces_batch(&m, &[], &[], &g, &mut out).unwrap();
    dynamics::gravity_torques_batch(&m, &[], &g, &mut out).unwrap();
    dynamics::mass_matrix_batch(&m, &[], &mut out).unwrap();
    dynamics::coriolis_matrix_batch(&m, &[], &[], &mut out).unwrap();
    dynamics::forward_dynamics_batch(&m, &[], &[], &[], &g, None, &mut out).unwrap();
    assert!(dynamics::inertias_from_slices(&[], &[], &[]).unwrap().is_empty());
    assert!(dynamics::inertias_in_world(&m, &[], &[]).unwrap().is_empty());
    assert_eq!(dynamics::transfer_inertias(&m, &m, &[]).unwrap().nq(), 0);
    assert_eq!(m.with_inertias(vec![]).unwrap().nq(), 0);
}

#[test]
fn ik_of_a_model_without_joints() {
    let m = empty();
    let reached = fk(&m, &[]).unwrap();
    let elsewhere = trans(1.0, 0.0, 0.0) * reached;
    for method in [IkMethod::Lm, IkMethod::Newton] {
        let o = IkOptions { method, ..Default::default() };
        let r = ik(&m, &reached, &[], &o).unwrap();
        assert!(r.success && r.q.is_empty());
        assert!(!ik(&m, &elsewhere, &[], &o).unwrap().success);
        assert_eq!(ik_path(&m, &[reached, elsewhere], &[], &o).unwrap().len(), 2);
        assert_eq!(ik_batch(&m, &[reached], &[], &o).unwrap().len(), 1);
        let mut s = IkSolver::new(&m, o).unwrap();
        assert!(s.solve(&reached, &[]).unwrap().success);
    }
}

#[test]
fn calibration_chain_without_joints() {
    let c = CalibrationChain::new(vec![CalibrationFactor::Fixed(trans(0.0, 0.0, 0.5)), CalibrationFactor::param(Motion::Tx, 0, None)], 1, 0, vec![]).unwrap();
    assert_eq!(c.pose(&[0.25], &[]).unwrap(), trans(0.25, 0.0, 0.5));
    let mut jac = nalgebra::Matrix6xX::zeros(1);
    c.pose_jacobian(&[0.25], &[], &mut jac).unwrap();
    let mut poses = vec![];
    c.evaluate_batch(&[0.25], &[], &mut poses, None).unwrap();
    assert!(CalibrationChain::new(vec![], 0, 0, vec![]).is_ok());
}

#[test]
fn extraction_from_axes_never_panics_on_a_single_axis() {
    // the smallest extraction (one axis) in every convention, for completeness next to the empty cases
    let ax = JointAxes::new(
        Pose::identity(),
        vec![Vector3::zeros()],
        vec![Vector3::z()],
        vec![JointKind::Revolute],
        vec![0.0],
        trans(0.0, 0.0, 0.3),
        vec![-1.0],
        vec![1.0],
    )
    .unwrap();
    for c in Convention::ALL {
        let e = extract(&ax, c, &ExtractOptions::default()).unwrap();
        assert_eq!(e.table.nq(), 1);
    }
}
