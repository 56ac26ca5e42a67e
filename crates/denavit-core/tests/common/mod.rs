#![allow(dead_code)]
use denavit_core::{Convention, JointKind, Table, spatial::Pose};
use nalgebra::DMatrix;
use std::f64::consts::FRAC_PI_2;

/// TianSui-One, modified DH, Guo et al. Table I (m, rad).
pub fn tiansui_mdh() -> Table {
    let p = DMatrix::from_row_slice(
        6,
        4,
        &[
            0.0, 0.0, 0.0, 0.0, FRAC_PI_2, 0.0, -FRAC_PI_2, 0.1485, 0.0, -0.406, 0.0, 0.0, 0.0, -0.386, FRAC_PI_2, 0.002, -FRAC_PI_2, 0.0, 0.0, 0.128,
            FRAC_PI_2, 0.0, 0.0, 0.0,
        ],
    );
    Table::new(Convention::Mdh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// TianSui-One, ED-H, Guo et al. Table II (m, rad): columns alpha, a, b, c, theta.
pub fn tiansui_edh() -> Table {
    let p = DMatrix::from_row_slice(
        6,
        5,
        &[
            0.0, 0.0, 0.0, 0.0, 0.0, FRAC_PI_2, 0.0, 0.0, 0.1485, -FRAC_PI_2, 0.0, -0.406, 0.0, 0.0, 0.0, 0.0, -0.386, 0.0, -0.126, FRAC_PI_2, -FRAC_PI_2, 0.0,
            -0.128, 0.0, 0.0, FRAC_PI_2, 0.0, 0.128, 0.0, 0.0,
        ],
    );
    Table::new(Convention::Edh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// KUKA KR5, standard DH, Hayat et al. Table III "specified" (m, rad): columns d, theta, a, alpha.
pub fn kr5_dh() -> Table {
    let p = DMatrix::from_row_slice(
        6,
        4,
        &[
            0.400, 0.0, 0.180, FRAC_PI_2, 0.0, 0.0, 0.600, 0.0, 0.0, 0.0, 0.120, FRAC_PI_2, 0.620, 0.0, 0.0, FRAC_PI_2, 0.0, 0.0, 0.0, FRAC_PI_2, 0.0, 0.0,
            0.0, 0.0,
        ],
    );
    Table::new(Convention::Dh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// Universal Robots UR5 (CB-series), standard DH; Universal Robots, "DH parameters for calculations of
/// kinematics and dynamics": d1 = 89.159, a2 = -425, a3 = -392.25, d4 = 109.15, d5 = 94.65, d6 = 82.3 mm;
/// alpha = 90, 0, 0, 90, -90, 0 deg. Rows (d, theta, a, alpha) in m, rad; no tool.
pub fn ur5_dh() -> Table {
    use std::f64::consts::FRAC_PI_2 as H;
    #[rustfmt::skip]
    let p = DMatrix::from_row_slice(6, 4, &[
        0.089159, 0.0, 0.0, H,
        0.0, 0.0, -0.425, 0.0,
        0.0, 0.0, -0.39225, 0.0,
        0.10915, 0.0, 0.0, H,
        0.09465, 0.0, 0.0, -H,
        0.0823, 0.0, 0.0, 0.0,
    ]);
    Table::new(Convention::Dh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}

/// Unimation Puma 560, standard DH (Corke 1996, mdl_puma560): rows (d, theta, a, alpha) in m, rad; no tool.
pub fn puma560_dh() -> Table {
    use std::f64::consts::FRAC_PI_2 as H;
    #[rustfmt::skip]
    let p = DMatrix::from_row_slice(6, 4, &[
        0.0, 0.0, 0.0, H,
        0.0, 0.0, 0.4318, 0.0,
        0.15005, 0.0, 0.0203, -H,
        0.4318, 0.0, 0.0, H,
        0.0, 0.0, 0.0, -H,
        0.0, 0.0, 0.0, 0.0,
    ]);
    Table::new(Convention::Dh, p, vec![JointKind::Revolute; 6], Pose::identity(), Pose::identity()).unwrap()
}
