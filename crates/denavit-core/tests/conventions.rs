//! Conventions: the papers' tables, and params -> axes -> params round trips (docs/conventions.md).
#![allow(clippy::unwrap_used)] // tests and benches unwrap: a failure is the test failing
mod common;
use common::*;
use denavit_core::{
    Convention, Data, Joint, JointKind, Model, Table,
    axes::axes,
    extract::{ExtractOptions, FIDELITY_SAMPLES, NEAR_PARALLEL_SIN, Relation, extract, sample_configurations},
    kinematics::{fk, forward_kinematics},
    spatial::{Pose, pose_error, rx, ry, rz, trans},
};
use nalgebra::Vector3;
use proptest::prelude::*;

fn max_err(a: &Model, b: &Model, qs: &[Vec<f64>]) -> f64 {
    qs.iter()
        .map(|q| {
            let (p, r) = pose_error(&fk(a, q).unwrap(), &fk(b, q).unwrap());
            p.max(r)
        })
        .fold(0.0, f64::max)
}

fn random_qs(n: usize, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut s = seed;
    (0..count)
        .map(|_| {
            (0..n)
                .map(|_| {
                    s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                    ((s >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * std::f64::consts::PI
                })
                .collect()
        })
        .collect()
}

#[test]
fn tiansui_mdh_and_edh_same_tool_pose_different_frames_4_5() {
    let mdh = tiansui_mdh().to_model("mdh").unwrap();
    let edh = tiansui_edh().to_model("edh").unwrap();
    let qs = random_qs(6, 200, 7);
    assert!(max_err(&mdh, &edh, &qs) < 1e-12);
    let (mut dm, mut de) = (Data::new(&mdh), Data::new(&edh));
    for q in &qs {
        forward_kinematics(&mdh, &mut dm, q).unwrap();
        forward_kinematics(&edh, &mut de, q).unwrap();
        for i in [3, 4] {
            let d = (dm.t_world_joint[i].translation.vector - de.t_world_joint[i].translation.vector).norm();
            assert!((d - 0.128).abs() < 1e-12, "joint frame {} origins differ by {d}", i + 1);
        }
        // frames 1-3 and 6 coincide
        for i in [0, 1, 2, 5] {
            let (p, r) = pose_error(&dm.t_world_joint[i], &de.t_world_joint[i]);
            assert!(p < 1e-12 && r < 1e-12);
        }
    }
}

#[test]
fn kr5_dh_home_position() {
    // At the KR5 zero configuration the DH chain of Hayat Table III puts the flange at
    // x = a1 + a2·0 ... computed by hand: frame chain with all theta = 0.
    let m = kr5_dh().to_model("kr5").unwrap();
    let t = fk(&m, &[0.0; 6]).unwrap();
    // Rz(0)Tz(.4)Tx(.18)Rx(90) · Tx(.6) · Tx(.12)Rx(90) · Tz(.62)Rx(90) · Rx(90)
    // x = 0.18 + 0.6 + 0.12 = 0.9; after Rx(90) twice the z of link 4 points along -y... : y = -0.62·(-1)? see below
    let expected = trans(0.0, 0.0, 0.4)
        * trans(0.18, 0.0, 0.0)
        * rx(std::f64::consts::FRAC_PI_2)
        * trans(0.6, 0.0, 0.0)
        * trans(0.12, 0.0, 0.0)
        * rx(std::f64::consts::FRAC_PI_2)
        * trans(0.0, 0.0, 0.62)
        * rx(std::f64::consts::FRAC_PI_2)
        * rx(std::f64::consts::FRAC_PI_2);
    let (p, r) = pose_error(&t, &expected);
    assert!(p < 1e-15 && r < 1e-15);
    assert!((t.translation.vector - nalgebra::Vector3::new(0.9, 0.0, 0.4 - 0.62)).norm() < 1e-12);
}

/// A random chain with special pairs: `pattern[k]` 0 = generic, 1 = parallel, 2 = intersecting,
/// 3 = near-parallel (1e-6 rad), 4 = coincident-parallel.
fn chain(seed: Vec<f64>, pattern: Vec<u8>, prismatic: Vec<bool>) -> Model {
    let mut joints = vec![];
    for (k, &pat) in pattern.iter().enumerate() {
        let s = &seed[k * 6..k * 6 + 6];
        let placement = match pat {
            0 => rz(s[0]) * trans(s[1], s[2], s[3]) * rx(s[4]) * ry(s[5]),
            1 => rz(s[0]) * trans(s[1], s[2], s[3]) * rz(s[4]),
            2 => rz(s[0]) * trans(0.0, 0.0, s[3]) * rx(s[4] + 0.3) * ry(s[5]),
            3 => rz(s[0]) * trans(s[1], s[2], s[3]) * rx(1e-6 * s[4].signum()) * ry(1e-6 * s[5]),
            _ => rz(s[0]) * trans(0.0, 0.0, s[3]),
        };
        let kind = if prismatic[k] { JointKind::Prismatic } else { JointKind::Revolute };
        let mut j = Joint::new(format!("j{k}"), kind, if k == 0 { rx(s[4]) * trans(s[1], s[2], 0.0) } else { placement });
        j.offset = s[5] * 0.1;
        joints.push(j);
    }
    let tool = trans(0.05, -0.02, 0.1) * rx(0.4) * rz(0.2);
    Model::new("random", trans(0.1, 0.2, -0.3) * rz(0.5) * rx(0.2), joints, tool, Pose::identity()).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]
    #[test]
    fn round_trip_every_convention(
        seed in proptest::collection::vec(-1.2f64..1.2, 36),
        pattern in proptest::collection::vec(0u8..5, 6),
        prismatic in proptest::collection::vec(proptest::bool::weighted(0.15), 6),
    ) {
        let pattern_has_near_parallel = pattern[1..].contains(&3);
        let model = chain(seed, pattern, prismatic);
        let qs = random_qs(6, 20, 11);
        let ax = axes(&model, &[0.0; 6]).unwrap();
        let exact_pairs = !pattern_has_near_parallel;
        for conv in Convention::ALL {
            if !exact_pairs && matches!(conv, Convention::Dh | Convention::Mdh) { continue; }
            let exact_opts = ExtractOptions { parallel_tol: 1e-12, max_offset: Some(f64::INFINITY), ..Default::default() };
            let ex = extract(&ax, conv, &exact_opts).unwrap();
            let back = ex.table.to_model("back").unwrap();
            let e = max_err(&model, &back, &qs);
            prop_assert!(e < 1e-12, "{}: FK differs by {e:e}; pairs {:?}", conv.name(), ex.pairs);
            prop_assert!(ex.max_position_error < 1e-12);
            // and the table round trip: table -> model -> axes -> table gives the same parameters
            let again = extract(&axes(&back, &[0.0; 6]).unwrap(), conv, &exact_opts).unwrap();
            prop_assert!((&again.table.params - &ex.table.params).amax() < 1e-9, "{}: {} vs {}", conv.name(), again.table.params, ex.table.params);
        }
        // ED-H and POE stay exact with the default (1e-3) parallel tolerance; DH/MDH report their error
        for conv in Convention::ALL {
            let ex = extract(&ax, conv, &ExtractOptions::default()).unwrap();
            let back = ex.table.to_model("back").unwrap();
            let e = max_err(&model, &back, &qs);
            match conv {
                Convention::Edh | Convention::Poe => prop_assert!(e < 1e-12),
                _ => {
                    let exact = ex.max_position_error < 1e-13 && ex.max_rotation_error < 1e-13;
                    if exact { prop_assert!(e < 1e-12, "{} {e:e}", conv.name()); }
                    // the reported error is the measured one, on the configurations the report names
                    let mut samples = sample_configurations(&ax.lower, &ax.upper, FIDELITY_SAMPLES);
                    samples.push(ax.q_ref.clone());
                    let measured = samples.iter().map(|q| pose_error(&fk(&model, q).unwrap(), &fk(&back, q).unwrap()).0).fold(0.0, f64::max);
                    prop_assert!((measured - ex.max_position_error).abs() < 1e-12, "{} measured {measured:e} reported {:e}", conv.name(), ex.max_position_error);
                    // offsets stay within the robot's size
                    // offsets stay within the robot's size for near-parallel pairs, and within size / NEAR_PARALLEL_SIN
                    // (the farthest a common normal can lie for axes the tolerance does not treat as parallel)
                    let size = ax.points.iter().chain(std::iter::once(&ax.t_world_tool.translation.vector))
                        .map(|p| (p - ax.t_world_base.translation.vector).norm()).fold(0.0, f64::max);
                    let (dcol, acol) = if conv == Convention::Dh { (0, 2) } else { (3, 1) };
                    let largest = ex.table.params.column(dcol).amax().max(ex.table.params.column(acol).amax());
                    prop_assert!(largest <= 4.0 * size / NEAR_PARALLEL_SIN + 1e-3, "{} offset {largest} for size {size}", conv.name());
                }
            }
        }
    }
}

#[test]
fn near_parallel_dh_has_no_absurd_offsets() {
    // KR5 with joint 3's axis tilted by 2e-5 rad (a 0.02 mm error over 1 m): plain common-normal DH
    // would put d of several km; the parallel tolerance keeps it at the robot's size.
    let t = kr5_dh();
    let m = t.to_model("kr5").unwrap();
    let mut joints = m.joints().to_vec();
    joints[2].placement = joints[2].placement * ry(2e-5) * rx(1e-5);
    let tilted = Model::new("kr5-tilted", *m.t_world_base(), joints, *m.t_last_flange(), *m.t_flange_tool()).unwrap();
    let ax = axes(&tilted, &[0.0; 6]).unwrap();
    let ex = extract(&ax, Convention::Dh, &ExtractOptions { nominal: Some(t.clone()), ..Default::default() }).unwrap();
    assert_eq!(ex.pairs[1].relation, Relation::Parallel);
    let lengths = ex.table.params.column(0).amax().max(ex.table.params.column(2).amax());
    assert!(lengths < 1.0, "{}", ex.table.params);
    assert!(ex.pairs[1].hayati_beta.abs() > 1e-6);
    // the reported tool error is the measured one and is of the order of beta x reach
    assert!(ex.max_position_error > 1e-7 && ex.max_position_error < 1e-3, "{}", ex.max_position_error);
    let plain = extract(&ax, Convention::Dh, &ExtractOptions { parallel_tol: 0.0, max_offset: Some(f64::INFINITY), ..Default::default() }).unwrap();
    assert!(plain.table.params.column(0).amax() > 100.0, "plain common normal gives d = {}", plain.table.params.column(0).amax());
    // ED-H stays exact
    let edh = extract(&ax, Convention::Edh, &ExtractOptions::default()).unwrap();
    let back = edh.table.to_model("edh").unwrap();
    assert!(max_err(&tilted, &back, &random_qs(6, 50, 3)) < 1e-12);
}

#[test]
fn nominal_reproduces_published_tables() {
    for t in [kr5_dh(), tiansui_mdh(), tiansui_edh()] {
        let m = t.to_model("m").unwrap();
        let q = [0.3, -0.2, 0.5, 0.1, -0.7, 0.9];
        let ex = extract(&axes(&m, &q).unwrap(), t.convention, &ExtractOptions { nominal: Some(t.clone()), ..Default::default() }).unwrap();
        let diff = (&ex.table.params - &t.params).amax();
        assert!(diff < 1e-12, "{}: {}\nvs\n{}", t.convention.name(), ex.table.params, t.params);
        let (p, r) = pose_error(&ex.table.t_last_tool, &t.t_last_tool);
        assert!(p < 1e-12 && r < 1e-12);
    }
}

/// Without a nominal, a pair of intersecting axes has two common normals; the extraction takes the one that
/// keeps the joint's table angle within +-90 degrees at the reference configuration. So the published tables
/// whose other choices are the extraction's own (a >= 0 along common normals) come back as published from
/// their axes alone: the KR5 (Hayat et al.) and the Puma 560 (Corke 1996), as a DH table written to URDF and
/// read again must. (Before, the KR5's joint 5 came back as alpha +90, theta 180.)
#[test]
fn intersecting_axes_without_a_nominal_keep_the_published_signs() {
    for (name, t) in [("kr5", kr5_dh()), ("puma560", puma560_dh())] {
        let m = t.to_model(name).unwrap();
        for q in [[0.0; 6], [0.3, -0.2, 0.5, 0.1, -0.7, 0.9], [2.0, -2.5, 3.0, -3.0, 2.2, -1.9]] {
            for conv in [Convention::Dh, Convention::Mdh] {
                let ex = extract(&axes(&m, &q).unwrap(), conv, &ExtractOptions::default()).unwrap();
                if conv == Convention::Dh {
                    let diff = (&ex.table.params - &t.params).amax();
                    assert!(diff < 1e-12, "{name} at q = {q:?}: {}\nvs\n{}", ex.table.params, t.params);
                }
                for (k, row) in ex.table.params.row_iter().enumerate().take(5) {
                    if ex.pairs[k].relation == Relation::Intersecting {
                        let theta = row[if conv == Convention::Dh { 1 } else { 2 }];
                        assert!(theta.abs() <= std::f64::consts::FRAC_PI_2 + 1e-12, "{name} {} joint {}: theta {theta}", conv.name(), k + 1);
                    }
                }
            }
        }
    }
}

#[test]
fn zero_axis_is_an_error() {
    let e = denavit_core::JointAxes::new(
        Pose::identity(),
        vec![nalgebra::Vector3::zeros(); 2],
        vec![nalgebra::Vector3::z(), nalgebra::Vector3::zeros()],
        vec![JointKind::Revolute; 2],
        vec![0.0; 2],
        Pose::identity(),
        vec![-1.0; 2],
        vec![1.0; 2],
    )
    .unwrap_err();
    assert!(e.to_string().contains("direction of axis 2 must be a non-zero direction"), "{e}");
}

/// The flange is DH frame n (ROS `tool0`), and a tool is given in it: on the UR5 the flange is 82.3 mm (d6)
/// beyond the last joint frame. (Before, `with_tool` replaced the whole pose after the last joint frame, so
/// the "flange" of `with_tool(I)` was joint frame 6 and a tool point landed d6 short.)
#[test]
fn flange_is_dh_frame_n_and_the_tool_is_in_the_flange() {
    let tool = trans(0.05, 0.03, 0.1) * rx(0.2);
    let t = Table { t_last_tool: tool, ..ur5_dh() };
    let m = t.to_model("ur5").unwrap();
    assert_eq!(*m.t_last_flange(), trans(0.0, 0.0, 0.0823));
    assert_eq!(*m.t_flange_tool(), tool);
    let bare = m.with_tool(Pose::identity()).unwrap();
    assert_eq!(*bare.t_last_flange(), *m.t_last_flange());
    let p = Vector3::new(0.05, 0.03, 0.1);
    let pointed = m.with_tool(trans(p.x, p.y, p.z)).unwrap();
    for k in 0..50 {
        let q: Vec<f64> = (0..6).map(|j| 3.0 * (1.3 * k as f64 + 0.7 * j as f64).sin()).collect();
        let flange = *t.frames(&q).unwrap().last().unwrap();
        let close = |a: &Pose, b: &Pose| {
            let (dp, dr) = pose_error(a, b);
            assert!(dp < 1e-15 && dr < 1e-15, "{dp:e} m {dr:e} rad at {q:?}");
        };
        close(&fk(&bare, &q).unwrap(), &flange);
        close(&fk(&m, &q).unwrap(), &(flange * tool));
        let at = fk(&pointed, &q).unwrap().translation.vector;
        assert!((at - flange.transform_point(&p.into()).coords).norm() < 1e-15);
    }
}

/// MDH / ED-H: the flange is joint frame n; POE: the flange is the home pose M's frame, no tool.
#[test]
fn flange_of_every_convention() {
    for t in [tiansui_mdh(), tiansui_edh()] {
        let t = Table { t_last_tool: trans(0.0, 0.0, 0.1), ..t };
        let m = t.to_model("m").unwrap();
        assert_eq!((*m.t_last_flange(), *m.t_flange_tool()), (Pose::identity(), trans(0.0, 0.0, 0.1)));
    }
    let dh = kr5_dh();
    let poe = extract(&axes(&dh.to_model("kr5").unwrap(), &[0.0; 6]).unwrap(), Convention::Poe, &ExtractOptions::default()).unwrap().table;
    let m = poe.to_model("poe").unwrap();
    assert_eq!(*m.t_flange_tool(), Pose::identity());
    let (dp, dr) = pose_error(&fk(&m, &[0.0; 6]).unwrap(), &(poe.t_world_base * poe.t_last_tool));
    assert!(dp < 1e-15 && dr < 1e-15);
}

/// `Table::link_frames`: the convention's frame i is joint frame i times link_frames[i], in every convention.
#[test]
fn link_frames_place_the_convention_frames_in_the_joint_frames() {
    let kr5 = kr5_dh();
    let ax = axes(&kr5.to_model("kr5").unwrap(), &[0.0; 6]).unwrap();
    let poe = extract(&ax, Convention::Poe, &ExtractOptions::default()).unwrap().table;
    for t in [ur5_dh(), kr5, tiansui_mdh(), tiansui_edh(), poe] {
        let m = t.to_model("m").unwrap();
        let links = t.link_frames();
        assert_eq!(links.len(), t.nq());
        if t.convention != Convention::Dh {
            assert!(links.iter().all(|l| *l == Pose::identity()));
        }
        let q: Vec<f64> = (0..t.nq()).map(|j| 3.0 * (0.9 + 1.7 * j as f64).sin()).collect();
        let mut d = Data::new(&m);
        forward_kinematics(&m, &mut d, &q).unwrap();
        let frames = t.frames(&q).unwrap();
        for i in 0..t.nq() {
            let (dp, dr) = pose_error(&(d.t_world_joint[i] * links[i]), &frames[i + 1]);
            assert!(dp < 1e-15 && dr < 1e-15, "{} frame {}", t.convention.name(), i + 1);
        }
    }
}

/// The KR5's ED-H table (the nominal), the KR5 with joint 3's placement turned by `ry(tilt)`, and that robot's
/// axes at q = 0.
fn kr5_joint_3_tilted(tilt: f64) -> (denavit_core::Table, Model, denavit_core::JointAxes) {
    let m = kr5_dh().to_model("kr5").unwrap();
    let nominal = extract(&axes(&m, &[0.0; 6]).unwrap(), Convention::Edh, &ExtractOptions::default()).unwrap().table;
    let mut joints = m.joints().to_vec();
    joints[2].placement *= ry(tilt);
    let tilted = Model::new("kr5-tilted", *m.t_world_base(), joints, *m.t_last_flange(), *m.t_flange_tool()).unwrap();
    let ax = axes(&tilted, &[0.0; 6]).unwrap();
    (nominal, tilted, ax)
}

/// The ED-H frame origins of a table at q = 0 (identify's on-body origins).
fn on_body_origins(t: &denavit_core::Table) -> Vec<Vector3<f64>> {
    (0..t.nq()).map(|k| t.frames(&vec![0.0; t.nq()]).unwrap()[k + 1].translation.vector).collect()
}

#[test]
fn edh_x_of_a_near_parallel_pair_follows_the_nominal() {
    // KR5 axes 2-3 parallel; joint 3 tilted by 1e-10 rad (the round-off of measured data written to 10 digits):
    // the common normal of the pair points anywhere (theta_2 = 45.6 deg was seen); against the nominal with its
    // on-body origins (identify's ED-H) the pair's x is the nominal's, and every parameter is the nominal's to the
    // size of the tilt.
    let (nominal, _, ax) = kr5_joint_3_tilted(1e-10);
    let plain = extract(&ax, Convention::Edh, &ExtractOptions::default()).unwrap();
    assert!((&plain.table.params - &nominal.params).amax() > 0.1, "{}", plain.table.params);
    // without origins (a conversion, a calibrated table) ED-H stays exact: the common normal
    let exact = extract(&ax, Convention::Edh, &ExtractOptions { nominal: Some(nominal.clone()), ..Default::default() }).unwrap();
    assert!((&exact.table.params - &nominal.params).amax() > 0.1, "{}", exact.table.params);
    let origins = on_body_origins(&nominal);
    let ex = extract(&ax, Convention::Edh, &ExtractOptions { nominal: Some(nominal.clone()), origins: Some(origins), ..Default::default() }).unwrap();
    let diff = (&ex.table.params - &nominal.params).amax();
    assert!(diff < 1e-9, "{}\nvs\n{}", ex.table.params, nominal.params);
}

#[test]
fn edh_against_a_nominal_reports_the_tool_error_of_the_dropped_tilt() {
    // KR5 with joint 3 tilted by 2e-4 rad (below the 1e-3 parallel tolerance): identify's ED-H (the nominal's
    // frames and on-body origins) drops the tilt; the reported tool error is the one measured against the
    // tilted robot itself over the report's configurations (it had been the error at q_ref alone, 20x less)
    let (nominal, tilted, ax) = kr5_joint_3_tilted(2e-4);
    let origins = on_body_origins(&nominal);
    let ex = extract(&ax, Convention::Edh, &ExtractOptions { nominal: Some(nominal), origins: Some(origins), ..Default::default() }).unwrap();
    let back = ex.table.to_model("back").unwrap();
    let mut samples = sample_configurations(&ax.lower, &ax.upper, FIDELITY_SAMPLES);
    samples.push(ax.q_ref.clone());
    let measured = samples.iter().map(|q| pose_error(&fk(&tilted, q).unwrap(), &fk(&back, q).unwrap()).0).fold(0.0, f64::max);
    assert!(measured > 1e-5, "the dropped tilt moves the tool by {measured:e} m");
    assert!((measured - ex.max_position_error).abs() < 1e-12, "measured {measured:e}, reported {:e}", ex.max_position_error);
}

#[test]
fn a_parallel_tolerance_of_one_or_more_is_refused() {
    // |z_i x z_i+1| <= 1: a tolerance of 1 or more would call every pair parallel
    let ax = axes(&kr5_dh().to_model("kr5").unwrap(), &[0.0; 6]).unwrap();
    for tol in [1.0, 2.0, f64::INFINITY] {
        let e = extract(&ax, Convention::Dh, &ExtractOptions { parallel_tol: tol, ..Default::default() }).unwrap_err();
        assert!(e.to_string().contains("the sine of an angle, below 1"), "{e}");
    }
    assert!(extract(&ax, Convention::Dh, &ExtractOptions { parallel_tol: 0.999, ..Default::default() }).is_ok());
}
