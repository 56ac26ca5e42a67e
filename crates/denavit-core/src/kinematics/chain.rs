//! A model's chain prepared for the batch kernels: its constant factors classified by their exact zeros and
//! ones ([`Factor`], [`Chain`]), kept with the model (`Model::derived`).

use super::*;

/// A block's frames: `c[column][row][configuration]`, the columns the x, y, z axes and the origin.
pub(super) type Frames = [[V; 3]; 4];

/// The rotation of a constant factor of the chain, by its exact zeros and ones.
pub(super) const ROT_IDENTITY: u8 = 0;
/// A rotation about x (x column `e_x`, first row `e_xᵀ`): what a DH or modified DH placement `Rx(alpha)` gives.
pub(super) const ROT_ABOUT_X: u8 = 1;
/// Any other rotation.
pub(super) const ROT_GENERAL: u8 = 2;
/// A quarter turn about x, its entries exactly 0 and ±1 (a DH table's alpha = ±90 deg, spatial::rx): in the
/// one-pass chains a renaming of the axes; the joint-by-joint [`step`]s treat it as `ROT_ABOUT_X`.
pub(super) const ROT_QUARTER_X: u8 = 3;

/// The joint motion that follows a factor: `Rz(s)`, `Tz(s)`, or none (the tool).
pub(super) const MOTION_RZ: u8 = 0;
pub(super) const MOTION_TZ: u8 = 1;
pub(super) const MOTION_NONE: u8 = 2;

/// A constant factor of the chain (a placement or the tool) with the shape of its rotation and which
/// components of its origin are not zero. The kernels skip the terms whose factor is an exact zero or one:
/// that changes no value (the remaining fused sums run in the order of [`Frame::mul`], so the batch values
/// are those of the single-configuration path up to the sign of zeros) and roughly halves the work of a DH
/// chain.
#[derive(Clone, Copy)]
pub(super) struct Factor {
    /// Columns x, y, z of the rotation, then the origin.
    pub(super) b: [[f64; 3]; 4],
    pub(super) rot: u8,
    /// Bit k set: origin component k is not zero.
    pub(super) origin: u8,
}

impl Factor {
    fn of(t: &Pose) -> Self {
        let f = Frame::of(t);
        let b: [[f64; 3]; 4] = std::array::from_fn(|j| [f.c[j][0], f.c[j][1], f.c[j][2]]);
        let about_x = b[0] == [1.0, 0.0, 0.0] && b[1][0] == 0.0 && b[2][0] == 0.0;
        let rot = if about_x && b[1] == [0.0, 1.0, 0.0] && b[2] == [0.0, 0.0, 1.0] {
            ROT_IDENTITY
        } else if about_x && b[1][1] == 0.0 && b[2][2] == 0.0 && b[1][2].abs() == 1.0 && b[2][1] == -b[1][2] {
            ROT_QUARTER_X
        } else if about_x {
            ROT_ABOUT_X
        } else {
            ROT_GENERAL
        };
        let origin = (0..3).filter(|&k| b[3][k] != 0.0).map(|k| 1u8 << k).sum();
        Self { b, rot, origin }
    }
}

/// A model's chain prepared for the batch kernels: the frame of the first joint before its motion
/// (`T_world_base · placement_1`, the same for every configuration, so computed once), then the placements
/// of joints 2..n and the tool as [`Factor`]s. Each model keeps its own (`Model::derived`).
#[derive(Clone)]
pub(crate) struct Chain {
    pub(super) first: Frame,
    pub(super) factors: Vec<Factor>,
    /// For [`revolute_about_x`]: every joint is revolute and every placement rotates about x only (DH,
    /// modified DH, ED-H tables).
    pub(super) about_x: bool,
}

impl crate::model::Derive for Chain {
    const SLOT: usize = 0;
    fn derive(model: &Model) -> Self {
        Self::of(model)
    }
}

impl Chain {
    pub(crate) fn of(model: &Model) -> Self {
        let base = Frame::of(model.t_world_base());
        let joints = model.joints();
        let first = joints.first().map_or(base, |j| base.mul(&j.placement));
        let factors: Vec<Factor> = joints.iter().skip(1).map(|j| Factor::of(&j.placement)).chain([Factor::of(model.t_last_tool())]).collect();
        let placements = &factors[..factors.len() - 1];
        let about_x = joints.iter().all(|j| j.kind == JointKind::Revolute) && placements.iter().all(|f| f.rot != ROT_GENERAL);
        Self { first, factors, about_x }
    }
}
