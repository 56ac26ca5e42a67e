#![allow(dead_code)]
use denavit_core::{spatial::Pose, Convention, JointKind, Table};
use nalgebra::DMatrix;
use std::f64::consts::FRAC_PI_2;

/// TianSui-One, modified DH, Guo et al. Table I (m, rad).
pub fn tiansui_mdh() -> Table {
    let p = DMatrix::from_row_slice(6, 4, &[
        0.0, 0.0, 0.0, 0.0,
        FRAC_PI_2, 0.0, -FRAC_PI_2, 0.1485,
        0.0, -0.406, 0.0, 0.0,
        0.0, -0.386, FRAC_PI_2, 0.002,
        -FRAC_PI_2, 0.0, 0.0, 0.128,
        FRAC_PI_2, 0.0, 0.0, 0.0,
    ]);
    Table::new(Convention::Mdh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// TianSui-One, ED-H, Guo et al. Table II (m, rad): columns alpha, a, b, c, theta.
pub fn tiansui_edh() -> Table {
    let p = DMatrix::from_row_slice(6, 5, &[
        0.0, 0.0, 0.0, 0.0, 0.0,
        FRAC_PI_2, 0.0, 0.0, 0.1485, -FRAC_PI_2,
        0.0, -0.406, 0.0, 0.0, 0.0,
        0.0, -0.386, 0.0, -0.126, FRAC_PI_2,
        -FRAC_PI_2, 0.0, -0.128, 0.0, 0.0,
        FRAC_PI_2, 0.0, 0.128, 0.0, 0.0,
    ]);
    Table::new(Convention::Edh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// KUKA KR5, standard DH, Hayat et al. Table III "specified" (m, rad): columns d, theta, a, alpha.
pub fn kr5_dh() -> Table {
    let p = DMatrix::from_row_slice(6, 4, &[
        0.400, 0.0, 0.180, FRAC_PI_2,
        0.0, 0.0, 0.600, 0.0,
        0.0, 0.0, 0.120, FRAC_PI_2,
        0.620, 0.0, 0.0, FRAC_PI_2,
        0.0, 0.0, 0.0, FRAC_PI_2,
        0.0, 0.0, 0.0, 0.0,
    ]);
    Table::new(Convention::Dh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}
