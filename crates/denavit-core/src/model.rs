//! The immutable serial-chain [`Model`] and its [`Data`] workspace (docs/conventions.md, "The model").

use crate::error::{Error, Result, check_finite, check_len};
use crate::inertia::Inertia;
use crate::spatial::{Pose, check_pose};
use nalgebra::Matrix6xX;
use std::sync::OnceLock;

/// How a joint moves along the z axis of its own frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JointKind {
    /// `Rz(q + offset)`.
    Revolute,
    /// `Tz(q + offset)`.
    Prismatic,
}

impl JointKind {
    /// Parse `"revolute"` / `"prismatic"` (also `"R"` / `"P"`).
    ///
    /// ```
    /// use denavit_core::JointKind;
    /// assert_eq!(JointKind::parse("R").unwrap(), JointKind::Revolute);
    /// assert!(JointKind::parse("ball").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "revolute" | "r" => Ok(Self::Revolute),
            "prismatic" | "p" => Ok(Self::Prismatic),
            _ => Err(Error::UnknownName { kind: "joint kind".into(), got: s.into(), expected: "revolute, prismatic".into() }),
        }
    }
    /// The limits of a joint that states none: (-pi, pi] rad for revolute, [-1, 1] m for prismatic.
    ///
    /// ```
    /// use denavit_core::JointKind;
    /// assert_eq!(JointKind::Prismatic.default_limits(), (-1.0, 1.0));
    /// ```
    pub fn default_limits(self) -> (f64, f64) {
        match self {
            Self::Revolute => (-std::f64::consts::PI, std::f64::consts::PI),
            Self::Prismatic => (-1.0, 1.0),
        }
    }
    /// The name used in files: `"revolute"` or `"prismatic"`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Revolute => "revolute",
            Self::Prismatic => "prismatic",
        }
    }
}

/// One joint: its fixed placement in the previous joint frame, its motion, zero offset and limits.
#[derive(Debug, Clone, PartialEq)]
pub struct Joint {
    /// Name (unique within a model).
    pub name: String,
    /// Revolute or prismatic about / along local z.
    pub kind: JointKind,
    /// `T_{i-1}_i0`: placement of this joint's frame in the previous joint frame at zero motion.
    pub placement: Pose,
    /// Zero offset: the motion is `M(q + offset)` (rad or m).
    pub offset: f64,
    /// Lower limit of `q` (rad or m).
    pub lower: f64,
    /// Upper limit of `q` (rad or m).
    pub upper: f64,
}

impl Joint {
    /// A joint with the given placement, no offset and limits (-pi, pi] for revolute, [-1, 1] m for prismatic.
    pub fn new(name: impl Into<String>, kind: JointKind, placement: Pose) -> Self {
        let (lower, upper) = kind.default_limits();
        Self { name: name.into(), kind, placement, offset: 0.0, lower, upper }
    }
}

/// An immutable serial chain:
/// `T_world_tool(q) = T_world_base · Π [placement_i · M_i(q_i + offset_i)] · T_last_flange · T_flange_tool`
/// (docs/conventions.md, "Frames: base, joint i, flange, tool").
///
/// `T_last_flange` is the mechanical flange (ROS `tool0`; DH frame n of a DH robot) in the last joint
/// frame, fixed by the robot; `T_flange_tool` is what is attached to the flange (identity without a tool),
/// replaced by [`Model::with_tool`]. Their product `T_last_tool` is stored for the hot paths.
///
/// Each link may carry inertial parameters ([`Inertia`], expressed in its joint frame, the frame moving
/// with link *i*); [`Model::new`] gives zero-mass links, [`Model::with_inertias`] attaches them.
///
/// ```
/// use denavit_core::{Model, Joint, JointKind, spatial::{trans, Pose}};
/// let j = vec![Joint::new("j1", JointKind::Revolute, Pose::identity()),
///              Joint::new("j2", JointKind::Revolute, trans(1.0, 0.0, 0.0))];
/// let m = Model::new("planar", Pose::identity(), j, trans(1.0, 0.0, 0.0), trans(0.0, 0.0, 0.1)).unwrap();
/// assert_eq!(m.nq(), 2);
/// assert_eq!(*m.t_last_tool(), trans(1.0, 0.0, 0.1));
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct Model {
    name: String,
    t_world_base: Pose,
    joints: Vec<Joint>,
    t_last_flange: Pose,
    t_flange_tool: Pose,
    /// `T_last_flange · T_flange_tool`, the last factor of the kinematic loops.
    t_last_tool: Pose,
    inertias: Vec<Inertia>,
    /// `T_joint_dh[i]`: standard-DH frame i in joint frame i, for a model built from a DH table
    /// ([`crate::Table::to_model`]; DH frame i = joint frame i · Tz(d_i) Tx(a_i) Rx(alpha_i)).
    dh_link_frames: Option<Vec<Pose>>,
    /// Values the algorithms derive from the joints on first use and keep ([`Derive`]).
    derived: Derived,
}

/// A value an algorithm derives from a [`Model`] (its joints, base and tool), computed on first use and kept
/// with the model: IK's per-joint bounds and wrist flips (`ik::Bounds`; finding the flips anew had cost a
/// spherical-wrist arm's solve 16 FK), the chain as the kinematic kernels take it (`kinematics::Chain`, its
/// placements' exact zeros and ones). The model knows none of these types: each algorithm implements `Derive`
/// for its own, with a slot of its own ([`DERIVED_SLOTS`]), so the model depends on no algorithm.
pub(crate) trait Derive: std::any::Any + Send + Sync + Sized {
    /// This type's slot, `< DERIVED_SLOTS`, one per type.
    const SLOT: usize;
    /// The value for `model`.
    fn derive(model: &Model) -> Self;
}

/// How many [`Derive`] types there are (`kinematics::Chain` 0, `ik::Bounds` 1).
pub(crate) const DERIVED_SLOTS: usize = 2;

/// The kept [`Derive`] values. Not part of the model's value: models compare equal whatever has been
/// computed; copies share what was computed (a copy changes no joint, base or tool without [`Model::new`]).
#[derive(Clone, Default)]
struct Derived([OnceLock<std::sync::Arc<dyn std::any::Any + Send + Sync>>; DERIVED_SLOTS]);

impl PartialEq for Derived {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl std::fmt::Debug for Derived {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("(derived)")
    }
}

impl Model {
    /// Build a model, checking the poses (one rigid-transform check), limits and unique names.
    pub fn new(name: impl Into<String>, t_world_base: Pose, joints: Vec<Joint>, t_last_flange: Pose, t_flange_tool: Pose) -> Result<Self> {
        check_pose("T_world_base", &t_world_base)?;
        check_pose("T_last_flange", &t_last_flange)?;
        check_pose("T_flange_tool", &t_flange_tool)?;
        for (i, j) in joints.iter().enumerate() {
            check_pose(format_args!("placement of joint {} ('{}')", i + 1, j.name), &j.placement)?;
            check_finite(&format!("offset of joint {} ('{}')", i + 1, j.name), &[j.offset])?;
            if j.lower.is_nan() || j.upper.is_nan() || j.lower > j.upper {
                return Err(Error::InvalidArgument {
                    what: format!("limits of joint {} ('{}')", i + 1, j.name),
                    expected: "lower <= upper".into(),
                    got: format!("[{}, {}]", j.lower, j.upper),
                });
            }
            if joints[..i].iter().any(|k| k.name == j.name) {
                return Err(Error::InvalidArgument {
                    what: format!("name of joint {}", i + 1),
                    expected: "names unique within the model".into(),
                    got: format!("'{}' used twice", j.name),
                });
            }
        }
        let inertias = vec![Inertia::zero(); joints.len()];
        Ok(Self {
            name: name.into(),
            t_world_base,
            joints,
            t_last_flange,
            t_flange_tool,
            t_last_tool: t_last_flange * t_flange_tool,
            inertias,
            dh_link_frames: None,
            derived: Derived::default(),
        })
    }
    /// The value of type `T` derived from this model ([`Derive`]), computed on its first use.
    #[inline]
    pub(crate) fn derived<T: Derive>(&self) -> &T {
        let slot = self.derived.0[T::SLOT].get_or_init(|| std::sync::Arc::new(T::derive(self)));
        match slot.downcast_ref::<T>() {
            Some(v) => v,
            None => unreachable!("one Derive type per slot"),
        }
    }
    /// A copy whose link *i* carries `inertias[i]`, expressed in joint frame *i* (the frame moving with
    /// link *i*, docs/conventions.md); one inertia per joint. The tool is part of the last link.
    ///
    /// ```
    /// use denavit_core::{builtin_planar2, dynamics::Inertia};
    /// use nalgebra::{Matrix3, Vector3};
    /// let m = builtin_planar2(1.0, 1.0);
    /// let link = Inertia::new(2.0, Vector3::new(0.5, 0.0, 0.0), Matrix3::from_diagonal_element(0.01)).unwrap();
    /// let m = m.with_inertias(vec![link; 2]).unwrap();
    /// assert_eq!(m.inertias()[1].mass(), 2.0);
    /// assert!(m.with_inertias(vec![link]).unwrap_err().to_string().contains("expected 2, got 1"));
    /// ```
    pub fn with_inertias(&self, inertias: Vec<Inertia>) -> Result<Self> {
        check_len("link inertias (one per joint)", self.nq(), inertias.len())?;
        Ok(Self { inertias, ..self.clone() })
    }
    /// Inertial parameters of the links, base to tip (link *i* in joint frame *i*; zero mass unless attached).
    pub fn inertias(&self) -> &[Inertia] {
        &self.inertias
    }
    /// The model's name.
    pub fn name(&self) -> &str {
        &self.name
    }
    /// Number of joints.
    pub fn nq(&self) -> usize {
        self.joints.len()
    }
    /// The joints, base to tip.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }
    /// `T_world_base`.
    pub fn t_world_base(&self) -> &Pose {
        &self.t_world_base
    }
    /// `T_last_flange`: the flange (mechanical flange, ROS `tool0`) in the last joint frame (identity for a
    /// model without joints: the flange is then the base).
    pub fn t_last_flange(&self) -> &Pose {
        &self.t_last_flange
    }
    /// `T_flange_tool`: the tool in the flange (identity unless a tool is attached).
    pub fn t_flange_tool(&self) -> &Pose {
        &self.t_flange_tool
    }
    /// `T_last_tool = T_last_flange · T_flange_tool`: the tool in the last joint frame.
    pub fn t_last_tool(&self) -> &Pose {
        &self.t_last_tool
    }
    /// A copy with another base placement (the link inertias are kept).
    pub fn with_base(&self, t_world_base: Pose) -> Result<Self> {
        let m = Self::new(self.name.clone(), t_world_base, self.joints.clone(), self.t_last_flange, self.t_flange_tool)?;
        Ok(Self { inertias: self.inertias.clone(), dh_link_frames: self.dh_link_frames.clone(), ..m })
    }
    /// A copy with another tool `T_flange_tool` (in the flange; the flange and the link inertias are kept).
    ///
    /// ```
    /// use denavit_core::{builtin_planar2, kinematics::fk, spatial::{trans, Pose}};
    /// let m = builtin_planar2(1.0, 1.0).with_tool(trans(0.0, 0.5, 0.0)).unwrap();
    /// let p = fk(&m, &[0.0, 0.0]).unwrap().translation.vector;
    /// assert_eq!((p.x, p.y), (2.0, 0.5));
    /// assert_eq!(*m.with_tool(Pose::identity()).unwrap().t_last_tool(), trans(1.0, 0.0, 0.0));
    /// ```
    pub fn with_tool(&self, t_flange_tool: Pose) -> Result<Self> {
        let m = Self::new(self.name.clone(), self.t_world_base, self.joints.clone(), self.t_last_flange, t_flange_tool)?;
        Ok(Self { inertias: self.inertias.clone(), dh_link_frames: self.dh_link_frames.clone(), ..m })
    }
    /// The standard-DH link frames `T_joint_dh[i]` (DH frame i in joint frame i) when the model was built
    /// from a DH table, else `None`: the frames of DH-frame inertias (`Inertia::transformed` by them).
    ///
    /// ```
    /// use denavit_core::{builtin_planar2, Convention, Table, JointKind, spatial::{trans, Pose}};
    /// let p = nalgebra::DMatrix::from_row_slice(1, 4, &[0.2, 0.0, 0.5, 0.0]);
    /// let t = Table::new(Convention::Dh, p, vec![JointKind::Revolute], Pose::identity(), Pose::identity()).unwrap();
    /// assert_eq!(t.to_model("m").unwrap().dh_link_frames(), Some(&[trans(0.0, 0.0, 0.2) * trans(0.5, 0.0, 0.0)][..]));
    /// assert_eq!(builtin_planar2(1.0, 1.0).dh_link_frames(), None);
    /// ```
    pub fn dh_link_frames(&self) -> Option<&[Pose]> {
        self.dh_link_frames.as_deref()
    }
    /// A copy that records `frames` as its standard-DH link frames (one rigid transform per joint).
    pub fn with_dh_link_frames(&self, frames: Vec<Pose>) -> Result<Self> {
        check_len("DH link frames (one per joint)", self.nq(), frames.len())?;
        for (i, f) in frames.iter().enumerate() {
            check_pose(format_args!("DH link frame {}", i + 1), f)?;
        }
        Ok(Self { dh_link_frames: Some(frames), ..self.clone() })
    }
    /// Check that `q` has one finite value per joint.
    pub fn check_q(&self, q: &[f64]) -> Result<()> {
        check_len("q", self.nq(), q.len())?;
        check_finite("q", q)
    }
    /// Lower limits.
    pub fn lower(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.lower).collect()
    }
    /// Upper limits.
    pub fn upper(&self) -> Vec<f64> {
        self.joints.iter().map(|j| j.upper).collect()
    }
}

/// Preallocated results of the algorithms for one model (pinocchio's `Data`).
#[derive(Debug, Clone)]
pub struct Data {
    /// `T_world_joint[i]`: joint frame i+1 in world, after the motion.
    pub t_world_joint: Vec<Pose>,
    /// `T_world_tool`.
    pub t_world_tool: Pose,
    /// Geometric Jacobian, rows `[v; w]` (linear velocity of the tool origin, angular velocity).
    pub jacobian: Matrix6xX<f64>,
}

impl Data {
    /// A workspace sized for `model`.
    pub fn new(model: &Model) -> Self {
        Self { t_world_joint: vec![Pose::identity(); model.nq()], t_world_tool: Pose::identity(), jacobian: Matrix6xX::zeros(model.nq()) }
    }
}
