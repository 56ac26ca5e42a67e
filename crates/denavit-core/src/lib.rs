//! `denavit-core`: one kinematic model of a serial robot for every convention (standard DH, modified DH,
//! ED-H, product of exponentials), its extraction from joint axis lines, and fast kinematics.
//!
//! Conventions, factor orders and sign rules: `docs/conventions.md` (the single source of truth).
//!
//! ```
//! use denavit_core::{builtin_planar2, kinematics::fk};
//! let m = builtin_planar2(1.0, 1.0);
//! assert!((fk(&m, &[0.0, 0.0]).unwrap().translation.x - 2.0).abs() < 1e-15);
//! ```

pub mod axes;
pub mod calibration;
pub mod compensate;
pub mod convention;
pub mod dynamics;
pub mod error;
pub mod extract;
pub mod ik;
pub mod inertia;
pub mod kinematics;
pub mod math;
pub mod model;
pub mod parallel;
pub mod spatial;
pub mod stream;

pub use axes::JointAxes;
pub use convention::{Convention, Table};
pub use error::{Error, Result};
pub use model::{Data, Joint, JointKind, Model};

/// A planar 2R arm with link lengths `l1`, `l2` (metres) along x, its flange at the end of link 2, no tool:
/// used in doc examples and tests.
pub fn builtin_planar2(l1: f64, l2: f64) -> Model {
    use spatial::{Pose, trans};
    let joints = vec![Joint::new("j1", JointKind::Revolute, Pose::identity()), Joint::new("j2", JointKind::Revolute, trans(l1, 0.0, 0.0))];
    Model::new("planar2", Pose::identity(), joints, trans(l2, 0.0, 0.0), Pose::identity()).expect("a valid model")
}
