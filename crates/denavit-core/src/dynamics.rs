//! Rigid-body dynamics: link inertial parameters, recursive Newton-Euler inverse dynamics, the mass
//! matrix, Coriolis and gravity terms, forward dynamics, and their batch forms.
//!
//! All algorithms follow R. Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008 (cited below
//! as "Featherstone"), specialised to a serial chain with the joints of docs/conventions.md.
//!
//! # Frames, units and orders
//!
//! * Link *i* is the body moved by joint *i*; its inertial parameters ([`Inertia`]) are expressed in
//!   **joint frame *i*** (the frame moving with link *i*, docs/conventions.md "The model"). The tool is
//!   rigidly attached to the last link; the base (link 0) is fixed in `world`, so `world` is inertial.
//! * Gravity is a vector in `world` (m/s^2), e.g. [`DEFAULT_GRAVITY`] `= [0, 0, -9.81]`.
//! * Internally spatial vectors are Featherstone's: motion `[ω; v]` (angular first, `v` the velocity of the
//!   body point at the frame origin) and force `[n; f]` (moment about the frame origin first).
//! * The **external tool wrench** of the public API is ordered `[f; n]` (force, then moment about the tool
//!   origin), both in **tool-frame axes**, matching the rows `[v; w]` of
//!   [`crate::kinematics::jacobian`]. It is the wrench the environment applies **to** the tool (a payload's
//!   weight, a contact force), so holding it costs `τ = -J_tool_toolᵀ · f_ext` (Featherstone sec. 5.3, the
//!   `f^x` of eq. 5.9; pinocchio's `fext`).
//! * Joint efforts `τ` are N·m for revolute and N for prismatic joints; `q`, `qd`, `qdd` in rad (m), rad/s
//!   (m/s), rad/s^2 (m/s^2). A joint's motion is `M(q + offset)`, so velocities and accelerations are
//!   those of `q`.
//!
//! # Workspace
//!
//! Every single-call algorithm takes a preallocated [`DynamicsData`] (pinocchio's `Data`) and does not
//! allocate; results are returned as borrows of its fields. Batch forms take row-major `(N, n)` slices and
//! run on every core (rayon), one workspace per thread.
//!
//! ```
//! use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
//! use nalgebra::{Matrix3, Vector3};
//! // two 1 kg point masses at the link tips, gravity along -y (the arm moves in the xy plane)
//! let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
//! let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
//! let mut ws = DynamicsData::new(&m);
//! let g = Vector3::new(0.0, -9.81, 0.0);
//! let tau = dynamics::gravity_torques(&m, &mut ws, &[0.0, 0.0], &g).unwrap();
//! assert!((tau[0] - 9.81 * (1.0 + 2.0)).abs() < 1e-12 && (tau[1] - 9.81).abs() < 1e-12);
//! ```

use crate::error::{check_finite, check_len, Error, Result};
use crate::math::{sin_cos, sin_cos_lanes};
use crate::model::{Joint, JointKind, Model};
use crate::spatial::Pose;
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3, Vector6};
use rayon::prelude::*;

/// Default gravity in `world`: `[0, 0, -9.81]` m/s^2 (world z up).
pub const DEFAULT_GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];

/// Relative tolerance on the symmetry of a user-given inertia tensor.
pub const SYMMETRY_TOL: f64 = 1e-12;

/// Relative tolerance (to the trace) on positive semi-definiteness and the triangle inequality.
pub const INERTIA_TOL: f64 = 1e-12;

// ---------------------------------------------------------------------------------------------------
// Inertial parameters
// ---------------------------------------------------------------------------------------------------

/// Inertial parameters of one rigid link: mass, centre of mass and rotational inertia about the centre of
/// mass, all expressed in one frame fixed to the link (for a [`Model`], joint frame *i*).
///
/// Construction is checked ([`Inertia::new`]): mass finite and `>= 0`; the tensor finite, symmetric (within
/// [`SYMMETRY_TOL`] relative), positive semi-definite, and its principal moments obey the triangle
/// inequality `I_a <= I_b + I_c` (any real mass distribution does; within [`INERTIA_TOL`] of the trace).
///
/// ```
/// use denavit_core::dynamics::Inertia;
/// use nalgebra::{Matrix3, Vector3};
/// let rod = Inertia::new(2.0, Vector3::new(0.5, 0.0, 0.0), Matrix3::from_diagonal(&Vector3::new(0.0, 1.0 / 6.0, 1.0 / 6.0))).unwrap();
/// // about the frame origin (the rod's end): m L^2 / 3 = 2/3 (parallel-axis theorem)
/// assert!((rod.inertia_origin()[(2, 2)] - 2.0 / 3.0).abs() < 1e-15);
/// assert!(Inertia::new(-1.0, Vector3::zeros(), Matrix3::zeros()).unwrap_err().to_string().contains("mass"));
/// ```
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Inertia {
    mass: f64,
    com: Vector3<f64>,
    inertia_com: Matrix3<f64>,
    // derived: first moment m c and the rotational inertia about the frame origin (Featherstone eq. 2.63)
    h: Vector3<f64>,
    inertia_origin: Matrix3<f64>,
}

impl Default for Inertia {
    fn default() -> Self {
        Self::zero()
    }
}

impl Inertia {
    /// A massless link (the default of [`Model::new`]).
    pub fn zero() -> Self {
        Self::unchecked(0.0, Vector3::zeros(), Matrix3::zeros())
    }

    /// Checked inertial parameters.
    ///
    /// * `mass`: kg, finite, `>= 0`.
    /// * `com`: centre of mass in the link frame (m), shape (3,).
    /// * `inertia_com`: rotational inertia about the centre of mass, in the link frame's axes (kg m^2), 3x3.
    ///
    /// The tensor is symmetrised after the checks.
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// use nalgebra::{Matrix3, Vector3};
    /// let bad = Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, 3.0)); // 3 > 1 + 1
    /// let e = Inertia::new(1.0, Vector3::zeros(), bad).unwrap_err().to_string();
    /// assert!(e.contains("triangle inequality"), "{e}");
    /// ```
    pub fn new(mass: f64, com: Vector3<f64>, inertia_com: Matrix3<f64>) -> Result<Self> {
        check_finite("mass (kg)", &[mass])?;
        if mass < 0.0 {
            return Err(Error::InvalidArgument { what: "mass".into(), expected: "a mass >= 0 kg".into(), got: format!("{mass} kg") });
        }
        check_finite("centre of mass (m)", com.as_slice())?;
        Ok(Self::unchecked(mass, com, check_tensor(&inertia_com)?))
    }

    /// Checked inertial parameters from the rotational inertia about the **frame origin** (kg m^2, frame
    /// axes), as some tables give it: `I_com = I_origin - m (|c|^2 1 - c c^T)` (parallel-axis theorem).
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// use nalgebra::{Matrix3, Vector3};
    /// let a = Inertia::new(3.0, Vector3::new(0.1, 0.2, 0.3), Matrix3::from_diagonal(&Vector3::new(0.1, 0.2, 0.25))).unwrap();
    /// let b = Inertia::from_origin(3.0, Vector3::new(0.1, 0.2, 0.3), *a.inertia_origin()).unwrap();
    /// assert!((a.inertia_com() - b.inertia_com()).amax() < 1e-15);
    /// ```
    pub fn from_origin(mass: f64, com: Vector3<f64>, inertia_origin: Matrix3<f64>) -> Result<Self> {
        check_finite("mass (kg)", &[mass])?;
        check_finite("centre of mass (m)", com.as_slice())?;
        check_finite("inertia tensor about the frame origin (kg m^2)", inertia_origin.as_slice())?;
        Self::new(mass, com, inertia_origin - parallel_axis(mass, &com))
    }

    /// A point mass `mass` (kg) at `com` (m).
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// let p = Inertia::point_mass(2.0, nalgebra::Vector3::new(0.0, 0.0, 1.0)).unwrap();
    /// assert_eq!(p.inertia_origin()[(0, 0)], 2.0);
    /// ```
    pub fn point_mass(mass: f64, com: Vector3<f64>) -> Result<Self> {
        Self::new(mass, com, Matrix3::zeros())
    }

    fn unchecked(mass: f64, com: Vector3<f64>, inertia_com: Matrix3<f64>) -> Self {
        let inertia_origin = inertia_com + parallel_axis(mass, &com);
        Self { mass, com, inertia_com, h: com * mass, inertia_origin }
    }

    /// Mass (kg).
    pub fn mass(&self) -> f64 {
        self.mass
    }
    /// Centre of mass in the link frame (m).
    pub fn com(&self) -> &Vector3<f64> {
        &self.com
    }
    /// Rotational inertia about the centre of mass, link-frame axes (kg m^2).
    pub fn inertia_com(&self) -> &Matrix3<f64> {
        &self.inertia_com
    }
    /// Rotational inertia about the link-frame origin, link-frame axes (kg m^2).
    pub fn inertia_origin(&self) -> &Matrix3<f64> {
        &self.inertia_origin
    }

    /// The 6x6 spatial inertia about the frame origin, Featherstone eq. 2.63, for motion `[ω; v]` and
    /// force `[n; f]`: `[[I_o, m c×], [-m c×, m 1]]`.
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// let i = Inertia::point_mass(2.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
    /// let s = i.spatial_matrix();
    /// assert_eq!(s[(5, 5)], 2.0);
    /// assert!((s - s.transpose()).amax() == 0.0);
    /// ```
    pub fn spatial_matrix(&self) -> Matrix6<f64> {
        Rb::from(self).matrix6()
    }

    /// The same physical body expressed in another frame `a` fixed to it: `self` is given in frame `b`,
    /// `t_a_b` is the pose of `b` in `a`; the result is in `a` (`c_a = T_a_b c_b`,
    /// `I_com,a = R_a_b I_com,b R_a_bᵀ`; the inertia about the new origin follows from the parallel-axis
    /// theorem, Featherstone eq. 2.66).
    ///
    /// ```
    /// use denavit_core::{dynamics::Inertia, spatial::{trans, rz}};
    /// use nalgebra::{Matrix3, Vector3};
    /// let i_b = Inertia::new(1.5, Vector3::new(0.1, 0.0, 0.0), Matrix3::from_diagonal(&Vector3::new(0.01, 0.02, 0.025))).unwrap();
    /// let t_a_b = trans(0.0, 0.0, 0.3) * rz(0.7);
    /// let i_a = i_b.transformed(&t_a_b);
    /// assert!((i_a.transformed(&t_a_b.inverse()).com() - i_b.com()).norm() < 1e-15);
    /// ```
    pub fn transformed(&self, t_a_b: &Pose) -> Self {
        let r = t_a_b.rotation.matrix();
        let i = r * self.inertia_com * r.transpose();
        let com = t_a_b.transform_point(&self.com.into()).coords;
        Self::unchecked(self.mass, com, (i + i.transpose()) * 0.5)
    }

    /// Two bodies rigidly joined (both expressed in the same frame), e.g. a link and its payload.
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// use nalgebra::Vector3;
    /// let a = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
    /// let b = Inertia::point_mass(1.0, Vector3::new(-1.0, 0.0, 0.0)).unwrap();
    /// let s = a.combined(&b);
    /// assert_eq!(s.mass(), 2.0);
    /// assert!(s.com().norm() < 1e-15 && (s.inertia_com()[(2, 2)] - 2.0).abs() < 1e-15);
    /// ```
    pub fn combined(&self, other: &Inertia) -> Inertia {
        let mass = self.mass + other.mass;
        if mass == 0.0 {
            let i = self.inertia_com + other.inertia_com;
            return Self::unchecked(0.0, Vector3::zeros(), i);
        }
        let com = (self.h + other.h) / mass;
        let io = self.inertia_origin + other.inertia_origin;
        let ic = io - parallel_axis(mass, &com);
        Self::unchecked(mass, com, (ic + ic.transpose()) * 0.5)
    }
}

/// `m (|c|^2 1 - c cᵀ)`: the parallel-axis term (Featherstone eq. 2.63, `m c× c×ᵀ`).
fn parallel_axis(mass: f64, c: &Vector3<f64>) -> Matrix3<f64> {
    (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * mass
}

/// Check a user-given rotational inertia about the centre of mass; returns it symmetrised.
fn check_tensor(i: &Matrix3<f64>) -> Result<Matrix3<f64>> {
    check_finite("inertia tensor (kg m^2)", i.as_slice())?;
    let scale = i.amax();
    let asym = (i - i.transpose()).amax();
    if asym > SYMMETRY_TOL * scale {
        return Err(Error::InvalidArgument {
            what: "inertia tensor".into(),
            expected: format!("a symmetric 3x3 matrix (|I - I^T| <= {SYMMETRY_TOL:e} * max|I|)"),
            got: format!("|I - I^T| = {asym:.3e} with max|I| = {scale:.3e}: {}", fmt_matrix(i)),
        });
    }
    let s = (i + i.transpose()) * 0.5;
    let mut ev: Vec<f64> = s.symmetric_eigenvalues().iter().copied().collect();
    ev.sort_by(f64::total_cmp);
    let tol = INERTIA_TOL * ev.iter().map(|e| e.abs()).sum::<f64>();
    if ev[0] < -tol {
        return Err(Error::InvalidArgument {
            what: "inertia tensor".into(),
            expected: "a positive semi-definite matrix (principal moments >= 0)".into(),
            got: format!("principal moments ({:.6e}, {:.6e}, {:.6e}) kg m^2", ev[0], ev[1], ev[2]),
        });
    }
    if ev[2] > ev[0] + ev[1] + tol {
        return Err(Error::InvalidArgument {
            what: "inertia tensor".into(),
            expected: "principal moments satisfying the triangle inequality (each <= the sum of the other two), as every real mass distribution does".into(),
            got: format!("principal moments ({:.6e}, {:.6e}, {:.6e}) kg m^2: {:.6e} > {:.6e}", ev[0], ev[1], ev[2], ev[2], ev[0] + ev[1]),
        });
    }
    Ok(s)
}

fn fmt_matrix(m: &Matrix3<f64>) -> String {
    let rows: Vec<String> = (0..3).map(|r| format!("[{:.6e}, {:.6e}, {:.6e}]", m[(r, 0)], m[(r, 1)], m[(r, 2)])).collect();
    format!("[{}]", rows.join(", "))
}

/// Prefix the `what` of an inertia error with the link it belongs to.
fn for_link(e: Error, link: usize) -> Error {
    match e {
        Error::InvalidArgument { what, expected, got } => Error::InvalidArgument { what: format!("{what} of link {link}"), expected, got },
        Error::NonFinite { what, index, value } => Error::NonFinite { what: format!("{what} of link {link}"), index, value },
        other => other,
    }
}

/// One [`Inertia`] per link from flat arrays: `masses` (n,) kg, `coms` (n, 3) m row-major, `tensors`
/// (n, 3, 3) kg m^2 row-major (about each centre of mass, in the frame's axes). Errors name the link (1-based).
///
/// ```
/// use denavit_core::dynamics::inertias_from_slices;
/// let i = inertias_from_slices(&[1.0, 2.0], &[0.0; 6], &[0.1, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.1,
///                                                       0.1, 0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, 0.5]);
/// assert!(i.unwrap_err().to_string().contains("inertia tensor of link 2"));
/// ```
pub fn inertias_from_slices(masses: &[f64], coms: &[f64], tensors: &[f64]) -> Result<Vec<Inertia>> {
    let n = masses.len();
    check_len("centres of mass (n x 3 values)", 3 * n, coms.len())?;
    check_len("inertia tensors (n x 3 x 3 values)", 9 * n, tensors.len())?;
    (0..n)
        .map(|i| {
            let c = Vector3::from_row_slice(&coms[3 * i..3 * i + 3]);
            let t = Matrix3::from_row_slice(&tensors[9 * i..9 * i + 9]);
            Inertia::new(masses[i], c, t).map_err(|e| for_link(e, i + 1))
        })
        .collect()
}

/// Link inertias given in `world` with the robot at `q_ref` (e.g. exported from CAD at the home pose),
/// re-expressed in each joint frame: `I_i = transformed(T_world_joint_i(q_ref)^-1)`.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{inertias_in_world, Inertia}};
/// let m = builtin_planar2(1.0, 1.0);
/// let w = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.5, 0.0, 0.0)).unwrap(); // mid link 2
/// let l = inertias_in_world(&m, &[0.0, 0.0], &[w, w]).unwrap();
/// assert!((l[1].com().x - 0.5).abs() < 1e-15);
/// ```
pub fn inertias_in_world(model: &Model, q_ref: &[f64], inertias_world: &[Inertia]) -> Result<Vec<Inertia>> {
    model.check_q(q_ref)?;
    check_len("link inertias (one per joint)", model.nq(), inertias_world.len())?;
    let mut data = crate::model::Data::new(model);
    crate::kinematics::forward_kinematics(model, &mut data, q_ref)?;
    Ok(inertias_world.iter().zip(&data.t_world_joint).map(|(i, t)| i.transformed(&t.inverse())).collect())
}

/// Re-express the link inertias of `from` in the joint frames of `to`, another model of the same physical
/// robot (e.g. its modified-DH and ED-H models): `I_to,i = transformed(T_to_i^-1 · T_from_i)` at `q_ref`.
///
/// Both models must have the same joint axes, in the same directions, at `q_ref` (then the two joint frames
/// of a link move together and the transform between them is constant); otherwise an error says which
/// axis differs. Returns `to` with the re-expressed inertias attached.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, transfer_inertias, DynamicsData, Inertia}};
/// use denavit_core::{Model, spatial::{trans, Pose}};
/// let a = builtin_planar2(1.0, 1.0)
///     .with_inertias(vec![Inertia::point_mass(1.0, nalgebra::Vector3::new(0.5, 0.0, 0.0)).unwrap(); 2]).unwrap();
/// // the same arm with joint frame 2 moved 0.2 m along its axis
/// let mut j = a.joints().to_vec();
/// j[1].placement = trans(1.0, 0.0, 0.2);
/// let b = Model::new("b", *a.t_world_base(), j, trans(1.0, 0.0, -0.2), Pose::identity()).unwrap();
/// let b = transfer_inertias(&a, &b, &[0.0, 0.0]).unwrap();
/// assert!((b.inertias()[1].com().z + 0.2).abs() < 1e-15);
/// ```
pub fn transfer_inertias(from: &Model, to: &Model, q_ref: &[f64]) -> Result<Model> {
    check_len("joints of the target model", from.nq(), to.nq())?;
    from.check_q(q_ref)?;
    let (mut da, mut db) = (crate::model::Data::new(from), crate::model::Data::new(to));
    crate::kinematics::forward_kinematics(from, &mut da, q_ref)?;
    crate::kinematics::forward_kinematics(to, &mut db, q_ref)?;
    let size = 1.0 + da.t_world_joint.iter().map(|t| t.translation.vector.norm()).fold(0.0, f64::max);
    let mut out = Vec::with_capacity(from.nq());
    for (i, ((ta, tb), inertia)) in da.t_world_joint.iter().zip(&db.t_world_joint).zip(from.inertias()).enumerate() {
        let (za, zb) = (ta.rotation.matrix().column(2).into_owned(), tb.rotation.matrix().column(2).into_owned());
        let d = ta.translation.vector - tb.translation.vector;
        let off_axis = (d - zb * zb.dot(&d)).norm();
        let (kind_a, kind_b) = (from.joints()[i].kind, to.joints()[i].kind);
        let same = kind_a == kind_b && (za - zb).norm() < 1e-9 && (kind_a == JointKind::Prismatic || off_axis < 1e-9 * size);
        if !same {
            return Err(Error::InvalidArgument {
                what: format!("joint axis {} of the target model", i + 1),
                expected: "the same joint kind and axis (direction and line) as the source model at q_ref".into(),
                got: format!("|z_from - z_to| = {:.3e}, distance of the origin from the axis = {off_axis:.3e} m", (za - zb).norm()),
            });
        }
        out.push(inertia.transformed(&(tb.inverse() * ta)));
    }
    to.with_inertias(out)
}

// ---------------------------------------------------------------------------------------------------
// Spatial algebra (Featherstone ch. 2), on pairs of 3-vectors
// ---------------------------------------------------------------------------------------------------

/// `r v`, written out (small fixed sizes: no loops, no bounds checks).
#[inline(always)]
fn mv(r: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        r.m11 * v.x + r.m12 * v.y + r.m13 * v.z,
        r.m21 * v.x + r.m22 * v.y + r.m23 * v.z,
        r.m31 * v.x + r.m32 * v.y + r.m33 * v.z,
    )
}

/// `rᵀ v`, written out.
#[inline(always)]
fn mtv(r: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        r.m11 * v.x + r.m21 * v.y + r.m31 * v.z,
        r.m12 * v.x + r.m22 * v.y + r.m32 * v.z,
        r.m13 * v.x + r.m23 * v.y + r.m33 * v.z,
    )
}

/// `a × b`, written out.
#[inline(always)]
fn cross(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x)
}

/// `a × e_z = (a_y, -a_x, 0)`.
#[inline(always)]
fn cross_z(a: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(a.y, -a.x, 0.0)
}

/// Rigid-body inertia as (mass, first moment `h = m c`, rotational inertia about the origin).
#[derive(Debug, Clone, Copy)]
struct Rb {
    m: f64,
    h: Vector3<f64>,
    io: Matrix3<f64>,
}

impl Default for Rb {
    fn default() -> Self {
        Self { m: 0.0, h: Vector3::zeros(), io: Matrix3::zeros() }
    }
}

impl From<&Inertia> for Rb {
    #[inline(always)]
    fn from(i: &Inertia) -> Self {
        Self { m: i.mass, h: i.h, io: i.inertia_origin }
    }
}

impl Rb {
    /// `I · [w; v]` -> `[n; f]` (Featherstone eq. 2.63).
    #[inline(always)]
    fn apply(&self, w: &Vector3<f64>, v: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        (mv(&self.io, w) + cross(&self.h, v), v * self.m - cross(&self.h, w))
    }
    /// The same inertia in the parent's coordinates, `X* I X` with `X` the motion transform parent -> child
    /// (Featherstone eq. 2.66), without forming 6x6 matrices.
    #[inline(always)]
    fn in_parent(&self, x: &Xf) -> Rb {
        let (r, p, m) = (&x.r, &x.p, self.m);
        let h = mv(r, &self.h);
        // R io Rᵀ (symmetric: 6 entries), then the translation by p with a× b× = b aᵀ - (a·b) 1:
        // -(h× p× + p× h×) - m p× p× = -(p hᵀ + h pᵀ) - m p pᵀ + (2 h·p + m |p|²) 1
        let t = r * self.io;
        let e = |i: usize, j: usize| t[(i, 0)] * r[(j, 0)] + t[(i, 1)] * r[(j, 1)] + t[(i, 2)] * r[(j, 2)];
        let d = 2.0 * h.dot(p) + m * p.norm_squared();
        let o = |i: usize, j: usize| -(p[i] * h[j] + h[i] * p[j]) - m * p[i] * p[j];
        let (a00, a11, a22) = (e(0, 0) + o(0, 0) + d, e(1, 1) + o(1, 1) + d, e(2, 2) + o(2, 2) + d);
        let (a01, a02, a12) = (e(0, 1) + o(0, 1), e(0, 2) + o(0, 2), e(1, 2) + o(1, 2));
        let io = Matrix3::new(a00, a01, a02, a01, a11, a12, a02, a12, a22);
        Rb { m, h: h + p * m, io }
    }
    #[inline(always)]
    fn add(&mut self, o: &Rb) {
        self.m += o.m;
        self.h += o.h;
        self.io += o.io;
    }
    fn matrix6(&self) -> Matrix6<f64> {
        let hx = self.h.cross_matrix();
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&self.io);
        m.fixed_view_mut::<3, 3>(0, 3).copy_from(&hx);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-hx));
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&(Matrix3::identity() * self.m));
        m
    }
}

/// A link transform: `r` = rotation of the child frame in the parent, `p` = child origin in the parent
/// (the pose `T_{i-1}_i`).
#[derive(Debug, Clone, Copy)]
struct Xf {
    r: Matrix3<f64>,
    p: Vector3<f64>,
}

impl Default for Xf {
    fn default() -> Self {
        Self { r: Matrix3::identity(), p: Vector3::zeros() }
    }
}

impl Xf {
    /// Motion vector from parent to child coordinates (Featherstone eq. 2.24).
    #[inline(always)]
    fn motion_to_child(&self, w: &Vector3<f64>, v: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        (mtv(&self.r, w), mtv(&self.r, &(v + cross(w, &self.p))))
    }
    /// Force vector from child to parent coordinates (Featherstone eq. 2.25, `Xᵀ`).
    #[inline(always)]
    fn force_to_parent(&self, n: &Vector3<f64>, f: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
        let fp = mv(&self.r, f);
        (mv(&self.r, n) + cross(&self.p, &fp), fp)
    }
    /// The 6x6 motion transform parent -> child `[[E, 0], [-E p×, E]]`, `E = rᵀ`.
    fn matrix6(&self) -> Matrix6<f64> {
        let e = self.r.transpose();
        let mut m = Matrix6::zeros();
        m.fixed_view_mut::<3, 3>(0, 0).copy_from(&e);
        m.fixed_view_mut::<3, 3>(3, 3).copy_from(&e);
        m.fixed_view_mut::<3, 3>(3, 0).copy_from(&(-(e * self.p.cross_matrix())));
        m
    }
}

/// `T_{i-1}_i(q) = placement_i · M_i(s)`, `s = q_i + offset_i`.
#[inline(always)]
fn link_transform(j: &Joint, s: f64) -> Xf {
    let r0 = j.placement.rotation.matrix();
    let p0 = j.placement.translation.vector;
    match j.kind {
        JointKind::Revolute => {
            let (sn, cs) = sin_cos(s);
            let r = Matrix3::new(
                r0.m11 * cs + r0.m12 * sn,
                r0.m12 * cs - r0.m11 * sn,
                r0.m13,
                r0.m21 * cs + r0.m22 * sn,
                r0.m22 * cs - r0.m21 * sn,
                r0.m23,
                r0.m31 * cs + r0.m32 * sn,
                r0.m32 * cs - r0.m31 * sn,
                r0.m33,
            );
            Xf { r, p: p0 }
        }
        JointKind::Prismatic => Xf { r: *r0, p: p0 + r0.column(2) * s },
    }
}

/// Featherstone's spatial cross products as 6x6 matrices: `crm(v)` on motion, `crf(v) = -crm(v)ᵀ` on force.
fn crm(v: &Vector6<f64>) -> Matrix6<f64> {
    let (wx, vx) = (v.fixed_rows::<3>(0).cross_matrix(), v.fixed_rows::<3>(3).cross_matrix());
    let mut m = Matrix6::zeros();
    m.fixed_view_mut::<3, 3>(0, 0).copy_from(&wx);
    m.fixed_view_mut::<3, 3>(3, 3).copy_from(&wx);
    m.fixed_view_mut::<3, 3>(3, 0).copy_from(&vx);
    m
}

#[inline(always)]
fn six(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector6<f64> {
    Vector6::new(a.x, a.y, a.z, b.x, b.y, b.z)
}

#[inline(always)]
fn halves(v: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
    (v.fixed_rows::<3>(0).into_owned(), v.fixed_rows::<3>(3).into_owned())
}

/// Index of the joint's motion subspace `S = e_k` in `[ω; v]` coordinates of its own frame.
#[inline(always)]
fn axis_index(kind: JointKind) -> usize {
    match kind {
        JointKind::Revolute => 2,
        JointKind::Prismatic => 5,
    }
}

// ---------------------------------------------------------------------------------------------------
// Workspace
// ---------------------------------------------------------------------------------------------------

/// Preallocated workspace and results of the dynamics algorithms for a model with `n` joints (pinocchio's
/// `Data`). Sized at construction; the single-call algorithms do not allocate.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::DynamicsData};
/// let ws = DynamicsData::new(&builtin_planar2(1.0, 1.0));
/// assert_eq!(ws.nq(), 2);
/// assert_eq!(ws.mass_matrix.nrows(), 2);
/// ```
#[derive(Debug, Clone)]
pub struct DynamicsData {
    /// Joint efforts of the last inverse-dynamics call (N m / N), shape (n,).
    pub tau: Vec<f64>,
    /// Joint accelerations of the last forward-dynamics call (rad/s^2, m/s^2), shape (n,).
    pub qdd: Vec<f64>,
    /// Joint-space mass matrix of the last [`mass_matrix`] call, n x n.
    pub mass_matrix: DMatrix<f64>,
    /// Coriolis matrix of the last [`coriolis_matrix`] call, n x n.
    pub coriolis: DMatrix<f64>,
    x: Vec<Xf>,
    f: Vec<(Vector3<f64>, Vector3<f64>)>,
    ic: Vec<Rb>,
    ia: Vec<Matrix6<f64>>,
    pa: Vec<Vector6<f64>>,
    c: Vec<Vector6<f64>>,
    uu: Vec<Vector6<f64>>,
    dd: Vec<f64>,
    u: Vec<f64>,
    s_w: Vec<Vector6<f64>>,
    sd_w: Vec<Vector6<f64>>,
    i_w: Vec<Matrix6<f64>>,
    b_w: Vec<Matrix6<f64>>,
    chol: DMatrix<f64>,
}

impl DynamicsData {
    /// A workspace sized for `model`.
    pub fn new(model: &Model) -> Self {
        Self::with_nq(model.nq())
    }

    /// A workspace for any model with `n` joints.
    pub fn with_nq(n: usize) -> Self {
        Self {
            tau: vec![0.0; n],
            qdd: vec![0.0; n],
            mass_matrix: DMatrix::zeros(n, n),
            coriolis: DMatrix::zeros(n, n),
            x: vec![Xf::default(); n],
            f: vec![(Vector3::zeros(), Vector3::zeros()); n],
            ic: vec![Rb::default(); n],
            ia: vec![Matrix6::zeros(); n],
            pa: vec![Vector6::zeros(); n],
            c: vec![Vector6::zeros(); n],
            uu: vec![Vector6::zeros(); n],
            dd: vec![0.0; n],
            u: vec![0.0; n],
            s_w: vec![Vector6::zeros(); n],
            sd_w: vec![Vector6::zeros(); n],
            i_w: vec![Matrix6::zeros(); n],
            b_w: vec![Matrix6::zeros(); n],
            chol: DMatrix::zeros(n, n),
        }
    }

    /// Number of joints this workspace is sized for.
    pub fn nq(&self) -> usize {
        self.tau.len()
    }

    fn check(&self, model: &Model) -> Result<()> {
        check_len("joints of the DynamicsData workspace (make it with DynamicsData::new(model))", model.nq(), self.nq())
    }
}

fn check_vec(what: &str, n: usize, v: &[f64]) -> Result<()> {
    check_len(what, n, v.len())?;
    check_finite(what, v)
}

fn check_gravity(g: &Vector3<f64>) -> Result<()> {
    check_finite("gravity (m/s^2, world)", g.as_slice())
}

fn check_wrench(w: Option<&Vector6<f64>>) -> Result<()> {
    match w {
        Some(w) => check_finite("external tool wrench [f; n] (N, N m, tool frame)", w.as_slice()),
        None => Ok(()),
    }
}

/// The external tool wrench `[f; n]` (tool axes, moment about the tool origin) as a Featherstone force
/// `[n; f]` in the last joint frame, about its origin.
#[inline(always)]
fn wrench_in_flange(model: &Model, w: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let t = model.t_last_tool();
    let r = t.rotation.matrix();
    let f = r * w.fixed_rows::<3>(0);
    let n = r * w.fixed_rows::<3>(3) + t.translation.vector.cross(&f);
    (n, f)
}

/// Gravity in base coordinates.
#[inline(always)]
fn gravity_in_base(model: &Model, g: &Vector3<f64>) -> Vector3<f64> {
    model.t_world_base().rotation.matrix().tr_mul(g)
}

// ---------------------------------------------------------------------------------------------------
// Recursive Newton-Euler (Featherstone ch. 5, Table 5.1)
// ---------------------------------------------------------------------------------------------------

#[inline]
fn rnea_unchecked(
    model: &Model,
    ws: &mut DynamicsData,
    q: &[f64],
    qd: Option<&[f64]>,
    qdd: Option<&[f64]>,
    g: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) {
    let n = model.nq();
    if n == 0 {
        return;
    }
    // base acceleration -g: gravity as a fictitious upward acceleration (Featherstone sec. 5.3)
    let (mut w, mut v) = (Vector3::zeros(), Vector3::zeros());
    let (mut aw, mut av) = (Vector3::zeros(), -gravity_in_base(model, g));
    let joints = model.joints();
    let inertias = model.inertias();
    for (i, ((j, inertia), (xo, fo))) in joints.iter().zip(inertias).zip(ws.x.iter_mut().zip(ws.f.iter_mut())).enumerate() {
        let x = link_transform(j, q[i] + j.offset);
        (w, v) = x.motion_to_child(&w, &v);
        (aw, av) = x.motion_to_child(&aw, &av);
        let qdi = qd.map_or(0.0, |s| s[i]);
        let qddi = qdd.map_or(0.0, |s| s[i]);
        match j.kind {
            JointKind::Revolute => {
                w.z += qdi;
                // a += S qdd + v ×m (S qd)
                aw += cross_z(&w) * qdi;
                aw.z += qddi;
                av += cross_z(&v) * qdi;
            }
            JointKind::Prismatic => {
                v.z += qdi;
                av += cross_z(&w) * qdi;
                av.z += qddi;
            }
        }
        let rb = Rb::from(inertia);
        let (hn, hf) = rb.apply(&w, &v);
        let (fn_, ff) = rb.apply(&aw, &av);
        // f = I a + v ×* I v
        *xo = x;
        *fo = (fn_ + cross(&w, &hn) + cross(&v, &hf), ff + cross(&w, &hf));
    }
    if let Some(we) = f_ext {
        let (n_e, f_e) = wrench_in_flange(model, we);
        ws.f[n - 1].0 -= n_e;
        ws.f[n - 1].1 -= f_e;
    }
    for i in (0..n).rev() {
        let (fn_, ff) = ws.f[i];
        ws.tau[i] = match joints[i].kind {
            JointKind::Revolute => fn_.z,
            JointKind::Prismatic => ff.z,
        };
        if i > 0 {
            let (np, fp) = ws.x[i].force_to_parent(&fn_, &ff);
            ws.f[i - 1].0 += np;
            ws.f[i - 1].1 += fp;
        }
    }
}

/// Inverse dynamics by the recursive Newton-Euler algorithm (Featherstone ch. 5, Table 5.1):
/// `τ = M(q) qdd + C(q, qd) qd + g(q) - J_toolᵀ f_ext`.
///
/// * `q`, `qd`, `qdd`: shape (n,), rad / m and their derivatives.
/// * `gravity`: m/s^2 in `world` (e.g. [`DEFAULT_GRAVITY`]).
/// * `f_ext`: optional wrench `[f; n]` (N, N m) applied **to** the tool by the environment, tool-frame
///   axes, moment about the tool origin.
///
/// Returns `τ` (N m / N), shape (n,), borrowed from `ws.tau`. Allocation-free.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::{Vector3, Vector6};
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// // spinning joint 1 at 1 rad/s with the arm stretched: no torque is needed (no gravity, no acceleration)
/// let tau = dynamics::rnea(&m, &mut ws, &[0.0, 0.0], &[1.0, 0.0], &[0.0, 0.0], &Vector3::zeros(), None).unwrap();
/// assert!(tau[0].abs() < 1e-15);
/// // a 1 N push along +y at the tool: joint 1 must resist with -2 N m
/// let push = Vector6::new(0.0, 1.0, 0.0, 0.0, 0.0, 0.0);
/// let tau = dynamics::rnea(&m, &mut ws, &[0.0, 0.0], &[0.0; 2], &[0.0; 2], &Vector3::zeros(), Some(&push)).unwrap();
/// assert!((tau[0] + 2.0).abs() < 1e-15);
/// ```
pub fn rnea<'a>(
    model: &Model,
    ws: &'a mut DynamicsData,
    q: &[f64],
    qd: &[f64],
    qdd: &[f64],
    gravity: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<&'a [f64]> {
    ws.check(model)?;
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    check_vec("qdd", model.nq(), qdd)?;
    check_gravity(gravity)?;
    check_wrench(f_ext)?;
    rnea_unchecked(model, ws, q, Some(qd), Some(qdd), gravity, f_ext);
    Ok(&ws.tau)
}

/// Bias forces `C(q, qd) qd + g(q)`: [`rnea`] with `qdd = 0` and no external wrench (Featherstone sec. 6.1).
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::Vector3;
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// // joint 2 feels the centrifugal force of link 2 swinging about joint 1: m l1 l2 sin(q2) qd1^2
/// let b = dynamics::bias_forces(&m, &mut ws, &[0.0, 0.5], &[2.0, 0.0], &Vector3::zeros()).unwrap();
/// assert!((b[1] - 0.5f64.sin() * 4.0).abs() < 1e-14);
/// ```
pub fn bias_forces<'a>(model: &Model, ws: &'a mut DynamicsData, q: &[f64], qd: &[f64], gravity: &Vector3<f64>) -> Result<&'a [f64]> {
    ws.check(model)?;
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    check_gravity(gravity)?;
    rnea_unchecked(model, ws, q, Some(qd), None, gravity, None);
    Ok(&ws.tau)
}

/// Gravity torques `g(q)`: [`rnea`] with `qd = qdd = 0`.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData}};
/// let m = builtin_planar2(1.0, 1.0); // massless links: no gravity torque
/// let mut ws = DynamicsData::new(&m);
/// let g = nalgebra::Vector3::new(0.0, -9.81, 0.0);
/// assert_eq!(dynamics::gravity_torques(&m, &mut ws, &[0.3, 0.2], &g).unwrap(), &[0.0, 0.0]);
/// ```
pub fn gravity_torques<'a>(model: &Model, ws: &'a mut DynamicsData, q: &[f64], gravity: &Vector3<f64>) -> Result<&'a [f64]> {
    ws.check(model)?;
    model.check_q(q)?;
    check_gravity(gravity)?;
    rnea_unchecked(model, ws, q, None, None, gravity, None);
    Ok(&ws.tau)
}

// ---------------------------------------------------------------------------------------------------
// Composite rigid body algorithm (Featherstone ch. 6, Table 6.2)
// ---------------------------------------------------------------------------------------------------

#[inline]
fn crba_unchecked(model: &Model, ws: &mut DynamicsData, q: &[f64]) {
    let n = model.nq();
    let joints = model.joints();
    for (i, (j, inertia)) in joints.iter().zip(model.inertias()).enumerate() {
        ws.x[i] = link_transform(j, q[i] + j.offset);
        ws.ic[i] = Rb::from(inertia);
    }
    for i in (0..n).rev() {
        // F = IC_i S_i, as a force [n; f] in frame i
        let ic = ws.ic[i];
        let (mut fn_, mut ff) = match joints[i].kind {
            JointKind::Revolute => (ic.io.column(2).into_owned(), Vector3::z().cross(&ic.h)),
            JointKind::Prismatic => (ic.h.cross(&Vector3::z()), Vector3::new(0.0, 0.0, ic.m)),
        };
        let pick = |kind: JointKind, n: &Vector3<f64>, f: &Vector3<f64>| match kind {
            JointKind::Revolute => n.z,
            JointKind::Prismatic => f.z,
        };
        ws.mass_matrix[(i, i)] = pick(joints[i].kind, &fn_, &ff);
        for k in (0..i).rev() {
            (fn_, ff) = ws.x[k + 1].force_to_parent(&fn_, &ff);
            let mij = pick(joints[k].kind, &fn_, &ff);
            ws.mass_matrix[(i, k)] = mij;
            ws.mass_matrix[(k, i)] = mij;
        }
        if i > 0 {
            let parent = ic.in_parent(&ws.x[i]);
            ws.ic[i - 1].add(&parent);
        }
    }
}

/// Joint-space mass matrix `M(q)` by the composite rigid body algorithm (Featherstone ch. 6, Table 6.2).
///
/// `q`: shape (n,). Returns the symmetric n x n matrix (kg m^2, kg, kg m), borrowed from
/// `ws.mass_matrix`. Allocation-free.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::Vector3;
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// let mm = dynamics::mass_matrix(&m, &mut ws, &[0.0, 0.0]).unwrap();
/// assert!((mm[(0, 0)] - 5.0).abs() < 1e-15 && (mm[(0, 1)] - 2.0).abs() < 1e-15 && (mm[(1, 1)] - 1.0).abs() < 1e-15);
/// ```
pub fn mass_matrix<'a>(model: &Model, ws: &'a mut DynamicsData, q: &[f64]) -> Result<&'a DMatrix<f64>> {
    ws.check(model)?;
    model.check_q(q)?;
    crba_unchecked(model, ws, q);
    Ok(&ws.mass_matrix)
}

// ---------------------------------------------------------------------------------------------------
// Coriolis matrix
// ---------------------------------------------------------------------------------------------------

/// `C(q, qd)` with `Ṁ - 2C` skew-symmetric, from the world-frame form
/// `C = Σ_b J_bᵀ (I_b J̇_b + (v_b ×*) I_b J_b)` (Featherstone sec. 6.1 with eq. 2.67,
/// `d/dt I_b = v_b×* I_b - I_b v_b×`; the construction of Echeandia & Wensing, "A numerical method for
/// computing the Coriolis matrix", 2021). With `m = max(i, j)`:
/// `C_ij = S_iᵀ (IC_m Ṡ_j + BC_m S_j)`, `IC_m = Σ_{b>=m} I_b`, `BC_m = Σ_{b>=m} v_b×* I_b`, all in world.
#[inline]
fn coriolis_unchecked(model: &Model, ws: &mut DynamicsData, q: &[f64], qd: &[f64]) {
    let n = model.nq();
    let joints = model.joints();
    let t0 = model.t_world_base();
    let mut world = Xf { r: *t0.rotation.matrix(), p: t0.translation.vector };
    let mut vel = Vector6::zeros();
    for (i, (j, inertia)) in joints.iter().zip(model.inertias()).enumerate() {
        let x = link_transform(j, q[i] + j.offset);
        world = Xf { r: world.r * x.r, p: world.p + world.r * x.p };
        let z = world.r.column(2).into_owned();
        let s = match j.kind {
            JointKind::Revolute => six(&z, &world.p.cross(&z)),
            JointKind::Prismatic => six(&Vector3::zeros(), &z),
        };
        vel += s * qd[i];
        let iw = Rb::from(inertia).in_parent(&world).matrix6();
        let cm = crm(&vel);
        ws.s_w[i] = s;
        ws.sd_w[i] = cm * s;
        ws.b_w[i] = -(cm.transpose() * iw);
        ws.i_w[i] = iw;
    }
    for i in (0..n.saturating_sub(1)).rev() {
        let (ic, bc) = (ws.i_w[i + 1], ws.b_w[i + 1]);
        ws.i_w[i] += ic;
        ws.b_w[i] += bc;
    }
    for m in 0..n {
        let (ic, bc, sm) = (&ws.i_w[m], &ws.b_w[m], &ws.s_w[m]);
        // column m, rows i <= m: C_im = S_i · (IC_m Ṡ_m + BC_m S_m)
        let y = ic * ws.sd_w[m] + bc * sm;
        for i in 0..=m {
            ws.coriolis[(i, m)] = ws.s_w[i].dot(&y);
        }
        // row m, columns j < m: C_mj = (IC_m S_m) · Ṡ_j + (BC_mᵀ S_m) · S_j
        let a = ic * sm;
        let b = bc.tr_mul(sm);
        for jj in 0..m {
            ws.coriolis[(m, jj)] = a.dot(&ws.sd_w[jj]) + b.dot(&ws.s_w[jj]);
        }
    }
}

/// Coriolis/centrifugal matrix `C(q, qd)` such that `C qd + g(q) = bias_forces(q, qd)` and
/// `Ṁ - 2C` is skew-symmetric (the Christoffel-consistent factorisation; Featherstone sec. 6.1,
/// Echeandia & Wensing 2021).
///
/// `q`, `qd`: shape (n,). Returns n x n (N m s / rad ...), borrowed from `ws.coriolis`. Allocation-free.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::{DVector, Vector3};
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// let (q, qd) = ([0.3, 0.8], [1.0, -2.0]);
/// let cqd = dynamics::coriolis_matrix(&m, &mut ws, &q, &qd).unwrap() * DVector::from_row_slice(&qd);
/// let b = dynamics::bias_forces(&m, &mut ws, &q, &qd, &Vector3::zeros()).unwrap();
/// assert!((cqd[0] - b[0]).abs() < 1e-13 && (cqd[1] - b[1]).abs() < 1e-13);
/// ```
pub fn coriolis_matrix<'a>(model: &Model, ws: &'a mut DynamicsData, q: &[f64], qd: &[f64]) -> Result<&'a DMatrix<f64>> {
    ws.check(model)?;
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    coriolis_unchecked(model, ws, q, qd);
    Ok(&ws.coriolis)
}

// ---------------------------------------------------------------------------------------------------
// Forward dynamics: articulated body algorithm (Featherstone ch. 7, Table 7.1) and Cholesky with M
// ---------------------------------------------------------------------------------------------------

#[inline]
#[allow(clippy::too_many_arguments)]
fn aba_unchecked(
    model: &Model,
    ws: &mut DynamicsData,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<()> {
    let n = model.nq();
    if n == 0 {
        return Ok(());
    }
    let joints = model.joints();
    let z = Vector3::z();
    let (mut w, mut v) = (Vector3::zeros(), Vector3::zeros());
    for (i, (j, inertia)) in joints.iter().zip(model.inertias()).enumerate() {
        let x = link_transform(j, q[i] + j.offset);
        (w, v) = x.motion_to_child(&w, &v);
        let c = match j.kind {
            JointKind::Revolute => {
                w.z += qd[i];
                six(&w.cross(&z), &v.cross(&z)) * qd[i]
            }
            JointKind::Prismatic => {
                v.z += qd[i];
                six(&Vector3::zeros(), &w.cross(&z)) * qd[i]
            }
        };
        let rb = Rb::from(inertia);
        let (hn, hf) = rb.apply(&w, &v);
        ws.x[i] = x;
        ws.c[i] = c;
        ws.ia[i] = rb.matrix6();
        ws.pa[i] = six(&(w.cross(&hn) + v.cross(&hf)), &w.cross(&hf));
    }
    if let Some(we) = f_ext {
        let (n_e, f_e) = wrench_in_flange(model, we);
        ws.pa[n - 1] -= six(&n_e, &f_e);
    }
    for i in (0..n).rev() {
        let k = axis_index(joints[i].kind);
        let ia = ws.ia[i];
        let uu = ia.column(k).into_owned();
        let d = uu[k];
        let scale = ia.amax();
        if d.is_nan() || d <= 1e-12 * scale || !d.is_finite() {
            return Err(Error::Degenerate {
                reason: format!(
                    "joint {} ('{}') moves no inertia (articulated inertia about its axis {d:.3e}): the mass matrix is singular; attach link inertias (Model.with_inertias / Model::with_inertias, or [joints.inertia] in a robot file)",
                    i + 1,
                    joints[i].name
                ),
            });
        }
        let u = tau[i] - ws.pa[i][k];
        ws.uu[i] = uu;
        ws.dd[i] = d;
        ws.u[i] = u;
        if i > 0 {
            let ia_a = ia - uu * (uu.transpose() / d);
            let pa_a = ws.pa[i] + ia_a * ws.c[i] + uu * (u / d);
            let xm = ws.x[i].matrix6();
            ws.ia[i - 1] += xm.tr_mul(&(ia_a * xm));
            let (pn, pf) = halves(&pa_a);
            let (np, fp) = ws.x[i].force_to_parent(&pn, &pf);
            ws.pa[i - 1] += six(&np, &fp);
        }
    }
    let (mut aw, mut av) = (Vector3::zeros(), -gravity_in_base(model, g));
    for (i, j) in joints.iter().enumerate() {
        (aw, av) = ws.x[i].motion_to_child(&aw, &av);
        let (cw, cv) = halves(&ws.c[i]);
        aw += cw;
        av += cv;
        let qdd = (ws.u[i] - ws.uu[i].dot(&six(&aw, &av))) / ws.dd[i];
        ws.qdd[i] = qdd;
        match j.kind {
            JointKind::Revolute => aw.z += qdd,
            JointKind::Prismatic => av.z += qdd,
        }
    }
    Ok(())
}

/// Forward dynamics by the articulated-body algorithm (Featherstone ch. 7, Table 7.1): the `qdd` with
/// `rnea(q, qd, qdd, gravity, f_ext) = tau`.
///
/// * `q`, `qd`, `tau`: shape (n,); `gravity` in `world`; `f_ext` as in [`rnea`].
///
/// Returns `qdd`, borrowed from `ws.qdd`. Allocation-free. Errors with `Degenerate` when a joint moves
/// no inertia (singular mass matrix, e.g. massless end links).
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::Vector3;
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// let g = Vector3::new(0.0, -9.81, 0.0);
/// let tau = dynamics::rnea(&m, &mut ws, &[0.1, 0.2], &[0.3, 0.4], &[0.5, 0.6], &g, None).unwrap().to_vec();
/// let qdd = dynamics::forward_dynamics(&m, &mut ws, &[0.1, 0.2], &[0.3, 0.4], &tau, &g, None).unwrap();
/// assert!((qdd[0] - 0.5).abs() < 1e-12 && (qdd[1] - 0.6).abs() < 1e-12);
/// ```
pub fn forward_dynamics<'a>(
    model: &Model,
    ws: &'a mut DynamicsData,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    gravity: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<&'a [f64]> {
    check_fd_args(model, ws, q, qd, tau, gravity, f_ext)?;
    aba_unchecked(model, ws, q, qd, tau, gravity, f_ext)?;
    Ok(&ws.qdd)
}

fn check_fd_args(model: &Model, ws: &DynamicsData, q: &[f64], qd: &[f64], tau: &[f64], g: &Vector3<f64>, f_ext: Option<&Vector6<f64>>) -> Result<()> {
    ws.check(model)?;
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    check_vec("tau", model.nq(), tau)?;
    check_gravity(g)?;
    check_wrench(f_ext)
}

/// Forward dynamics by solving `M(q) qdd = tau - bias(q, qd) + J_toolᵀ f_ext` with the mass matrix of
/// [`mass_matrix`] and an in-place Cholesky factorisation (Featherstone sec. 6.1). Same arguments and
/// result as [`forward_dynamics`] (which is the faster O(n) path); kept to cross-check it.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, DynamicsData, Inertia}};
/// use nalgebra::Vector3;
/// let tip = Inertia::point_mass(1.0, Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut ws = DynamicsData::new(&m);
/// let g = Vector3::new(0.0, -9.81, 0.0);
/// let a = dynamics::forward_dynamics(&m, &mut ws, &[0.1, 0.2], &[0.3, 0.4], &[1.0, 2.0], &g, None).unwrap().to_vec();
/// let b = dynamics::forward_dynamics_crba(&m, &mut ws, &[0.1, 0.2], &[0.3, 0.4], &[1.0, 2.0], &g, None).unwrap();
/// assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
/// ```
pub fn forward_dynamics_crba<'a>(
    model: &Model,
    ws: &'a mut DynamicsData,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    gravity: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<&'a [f64]> {
    check_fd_args(model, ws, q, qd, tau, gravity, f_ext)?;
    fd_crba_unchecked(model, ws, q, qd, tau, gravity, f_ext)?;
    Ok(&ws.qdd)
}

fn fd_crba_unchecked(
    model: &Model,
    ws: &mut DynamicsData,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<()> {
    let n = model.nq();
    rnea_unchecked(model, ws, q, Some(qd), None, g, f_ext);
    crba_unchecked(model, ws, q);
    for ((o, t), b) in ws.qdd.iter_mut().zip(tau).zip(&ws.tau) {
        *o = t - b;
    }
    ws.chol.copy_from(&ws.mass_matrix);
    let scale = (0..n).map(|i| ws.chol[(i, i)].abs()).fold(0.0, f64::max);
    // in-place Cholesky L Lᵀ (lower triangle), then two triangular solves
    let l = &mut ws.chol;
    for j in 0..n {
        let mut d = l[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 1e-13 * scale || !d.is_finite() {
            return Err(Error::Degenerate {
                reason: format!(
                    "the mass matrix is not positive definite (pivot {d:.3e} at joint {}): a joint moves no inertia; attach link inertias (Model.with_inertias / Model::with_inertias, or [joints.inertia] in a robot file)",
                    j + 1
                ),
            });
        }
        let d = d.sqrt();
        l[(j, j)] = d;
        for i in j + 1..n {
            let mut s = l[(i, j)];
            for k in 0..j {
                s -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = s / d;
        }
    }
    let x = &mut ws.qdd;
    for i in 0..n {
        let mut s = x[i];
        for k in 0..i {
            s -= l[(i, k)] * x[k];
        }
        x[i] = s / l[(i, i)];
    }
    for i in (0..n).rev() {
        let mut s = x[i];
        for k in i + 1..n {
            s -= l[(k, i)] * x[k];
        }
        x[i] = s / l[(i, i)];
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------------
// Energy
// ---------------------------------------------------------------------------------------------------

/// Kinetic energy `½ qdᵀ M(q) qd = Σ ½ v_iᵀ I_i v_i` (J). Allocation-free.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{kinetic_energy, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// // stretched arm turning at 1 rad/s: ½ (1·1² + 1·2²)
/// assert!((kinetic_energy(&m, &[0.0, 0.0], &[1.0, 0.0]).unwrap() - 2.5).abs() < 1e-15);
/// ```
pub fn kinetic_energy(model: &Model, q: &[f64], qd: &[f64]) -> Result<f64> {
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    let (mut w, mut v) = (Vector3::zeros(), Vector3::zeros());
    let mut e = 0.0;
    for (i, (j, inertia)) in model.joints().iter().zip(model.inertias()).enumerate() {
        let x = link_transform(j, q[i] + j.offset);
        (w, v) = x.motion_to_child(&w, &v);
        match j.kind {
            JointKind::Revolute => w.z += qd[i],
            JointKind::Prismatic => v.z += qd[i],
        }
        let (hn, hf) = Rb::from(inertia).apply(&w, &v);
        e += 0.5 * (w.dot(&hn) + v.dot(&hf));
    }
    Ok(e)
}

/// Potential energy in the gravity field `-Σ m_i gᵀ c_i` (J, zero at the world origin), `gravity` in world.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{potential_energy, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let g = nalgebra::Vector3::new(0.0, -10.0, 0.0);
/// assert!((potential_energy(&m, &[std::f64::consts::FRAC_PI_2, 0.0], &g).unwrap() - 30.0).abs() < 1e-12);
/// ```
pub fn potential_energy(model: &Model, q: &[f64], gravity: &Vector3<f64>) -> Result<f64> {
    model.check_q(q)?;
    check_gravity(gravity)?;
    let mut t = *model.t_world_base();
    let mut e = 0.0;
    for (i, (j, inertia)) in model.joints().iter().zip(model.inertias()).enumerate() {
        t *= j.placement;
        crate::kinematics::apply_motion(&mut t, j.kind, q[i] + j.offset);
        let c = t.transform_point(&(*inertia.com()).into()).coords;
        e -= inertia.mass() * gravity.dot(&c);
    }
    Ok(e)
}

// ---------------------------------------------------------------------------------------------------
// Batch forms (rayon, row-major (N, n) slices)
// ---------------------------------------------------------------------------------------------------

const CHUNK: usize = 256;

/// Number of rows of a row-major (N, n) batch, checking the other batches and the output.
fn batch_rows(model: &Model, inputs: &[(&str, &[f64])], out_what: &str, out_per_row: usize, out_len: usize) -> Result<usize> {
    let n = model.nq();
    if n == 0 {
        return Ok(0);
    }
    let (name0, first) = inputs[0];
    let count = first.len() / n;
    check_len(&format!("{name0} batch (N*n values, n = {n})"), count * n, first.len())?;
    for (name, v) in &inputs[1..] {
        check_len(&format!("{name} batch (N*n values, N = {count}, n = {n})"), count * n, v.len())?;
    }
    check_len(&format!("{out_what} (N*{out_per_row} values, N = {count})"), count * out_per_row, out_len)?;
    Ok(count)
}

/// Finite check of one batch row; formats the message only on failure.
#[inline]
fn check_row(what: &str, row: usize, v: &[f64]) -> Result<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(Error::NonFinite { what: format!("{what} (row {row})"), index: i, value: v[i] }),
        None => Ok(()),
    }
}

/// External wrenches of a batch: none, one `[f; n]` for every row (6 values), or one per row (N*6).
fn wrench_of(f_ext: Option<&[f64]>, count: usize) -> Result<Option<&[f64]>> {
    match f_ext {
        None => Ok(None),
        Some(w) if w.len() == 6 || w.len() == 6 * count => {
            check_finite("external tool wrenches [f; n]", w)?;
            Ok(Some(w))
        }
        Some(w) => Err(Error::SizeMismatch { what: format!("external tool wrenches (6 or N*6 values, N = {count})"), expected: 6 * count, got: w.len() }),
    }
}

#[inline]
fn wrench_row(w: Option<&[f64]>, row: usize) -> Option<Vector6<f64>> {
    w.map(|w| if w.len() == 6 { Vector6::from_row_slice(w) } else { Vector6::from_row_slice(&w[6 * row..6 * row + 6]) })
}

/// Run `f(ws, row, out_row)` over all rows in parallel, one workspace per thread.
fn par_rows<F>(model: &Model, out: &mut [f64], per_row: usize, f: F) -> Result<()>
where
    F: Fn(&mut DynamicsData, usize, &mut [f64]) -> Result<()> + Sync + Send,
{
    if per_row == 0 {
        return Ok(());
    }
    out.par_chunks_mut(per_row * CHUNK).enumerate().try_for_each_init(
        || DynamicsData::new(model),
        |ws, (c, chunk)| {
            for (k, o) in chunk.chunks_exact_mut(per_row).enumerate() {
                f(ws, c * CHUNK + k, o)?;
            }
            Ok(())
        },
    )
}

// ---------------------------------------------------------------------------------------------------
// Inverse dynamics of W states at once (batches)
// ---------------------------------------------------------------------------------------------------

/// Number of states the batch inverse dynamics advances together (structure of arrays: every operation
/// runs on W lanes, which the compiler turns into SIMD; the shared model constants are loaded once).
const LANES: usize = 4;

type Lane = [f64; LANES];

/// A 3-vector per lane.
#[derive(Debug, Clone, Copy, Default)]
struct V3l {
    x: Lane,
    y: Lane,
    z: Lane,
}

macro_rules! lanes {
    ($l:ident => $e:expr) => {{
        let mut o = [0.0; LANES];
        for $l in 0..LANES {
            o[$l] = $e;
        }
        o
    }};
}

impl V3l {
    #[inline(always)]
    fn splat(v: &Vector3<f64>) -> Self {
        Self { x: [v.x; LANES], y: [v.y; LANES], z: [v.z; LANES] }
    }
    #[inline(always)]
    fn add(&self, b: &V3l) -> V3l {
        V3l { x: lanes!(l => self.x[l] + b.x[l]), y: lanes!(l => self.y[l] + b.y[l]), z: lanes!(l => self.z[l] + b.z[l]) }
    }
    #[inline(always)]
    fn sub(&self, b: &V3l) -> V3l {
        V3l { x: lanes!(l => self.x[l] - b.x[l]), y: lanes!(l => self.y[l] - b.y[l]), z: lanes!(l => self.z[l] - b.z[l]) }
    }
    #[inline(always)]
    fn scale(&self, s: f64) -> V3l {
        V3l { x: lanes!(l => self.x[l] * s), y: lanes!(l => self.y[l] * s), z: lanes!(l => self.z[l] * s) }
    }
    /// `self × b`.
    #[inline(always)]
    fn cross(&self, b: &V3l) -> V3l {
        V3l {
            x: lanes!(l => self.y[l] * b.z[l] - self.z[l] * b.y[l]),
            y: lanes!(l => self.z[l] * b.x[l] - self.x[l] * b.z[l]),
            z: lanes!(l => self.x[l] * b.y[l] - self.y[l] * b.x[l]),
        }
    }
    /// `self × b`, `b` shared by the lanes.
    #[inline(always)]
    fn cross_s(&self, b: &Vector3<f64>) -> V3l {
        V3l {
            x: lanes!(l => self.y[l] * b.z - self.z[l] * b.y),
            y: lanes!(l => self.z[l] * b.x - self.x[l] * b.z),
            z: lanes!(l => self.x[l] * b.y - self.y[l] * b.x),
        }
    }
    /// `rᵀ self`, `r` shared.
    #[inline(always)]
    fn rt(&self, r: &Matrix3<f64>) -> V3l {
        V3l {
            x: lanes!(l => r.m11 * self.x[l] + r.m21 * self.y[l] + r.m31 * self.z[l]),
            y: lanes!(l => r.m12 * self.x[l] + r.m22 * self.y[l] + r.m32 * self.z[l]),
            z: lanes!(l => r.m13 * self.x[l] + r.m23 * self.y[l] + r.m33 * self.z[l]),
        }
    }
    /// `r self`, `r` shared.
    #[inline(always)]
    fn r(&self, r: &Matrix3<f64>) -> V3l {
        V3l {
            x: lanes!(l => r.m11 * self.x[l] + r.m12 * self.y[l] + r.m13 * self.z[l]),
            y: lanes!(l => r.m21 * self.x[l] + r.m22 * self.y[l] + r.m23 * self.z[l]),
            z: lanes!(l => r.m31 * self.x[l] + r.m32 * self.y[l] + r.m33 * self.z[l]),
        }
    }
    /// `rᵀ self` for a classified rotation.
    #[inline(always)]
    fn rt_rot(&self, r: &Rot) -> V3l {
        match r {
            Rot::Identity => *self,
            Rot::Rx(c, s) => V3l { x: self.x, y: lanes!(l => c * self.y[l] + s * self.z[l]), z: lanes!(l => c * self.z[l] - s * self.y[l]) },
            Rot::General(m) => self.rt(m),
        }
    }
    /// `r self` for a classified rotation.
    #[inline(always)]
    fn r_rot(&self, r: &Rot) -> V3l {
        match r {
            Rot::Identity => *self,
            Rot::Rx(c, s) => V3l { x: self.x, y: lanes!(l => c * self.y[l] - s * self.z[l]), z: lanes!(l => s * self.y[l] + c * self.z[l]) },
            Rot::General(m) => self.r(m),
        }
    }
    /// `Rz(t)ᵀ self` given cos, sin per lane.
    #[inline(always)]
    fn rz_t(&self, c: &Lane, s: &Lane) -> V3l {
        V3l { x: lanes!(l => c[l] * self.x[l] + s[l] * self.y[l]), y: lanes!(l => c[l] * self.y[l] - s[l] * self.x[l]), z: self.z }
    }
    /// `Rz(t) self`.
    #[inline(always)]
    fn rz(&self, c: &Lane, s: &Lane) -> V3l {
        V3l { x: lanes!(l => c[l] * self.x[l] - s[l] * self.y[l]), y: lanes!(l => s[l] * self.x[l] + c[l] * self.y[l]), z: self.z }
    }
}

/// A joint placement's rotation, classified once per batch so the kernel skips multiplications by 0 and 1:
/// the identity, `Rx(alpha)` (every DH-family placement), or general.
#[derive(Debug, Clone, Copy)]
enum Rot {
    Identity,
    Rx(f64, f64),
    General(Matrix3<f64>),
}

impl Rot {
    fn of(r: &Matrix3<f64>) -> Self {
        let x_fixed = r.m11 == 1.0 && r.m12 == 0.0 && r.m13 == 0.0 && r.m21 == 0.0 && r.m31 == 0.0;
        if x_fixed && r.m22 == 1.0 && r.m33 == 1.0 && r.m23 == 0.0 && r.m32 == 0.0 {
            Rot::Identity
        } else if x_fixed && r.m22 == r.m33 && r.m23 == -r.m32 {
            Rot::Rx(r.m22, r.m32)
        } else {
            Rot::General(*r)
        }
    }
}

/// Per joint of a batch: the placement rotation class and whether its translation is zero.
fn placement_classes(model: &Model) -> Vec<(Rot, bool)> {
    model.joints().iter().map(|j| (Rot::of(j.placement.rotation.matrix()), j.placement.translation.vector == Vector3::zeros())).collect()
}

/// Per-thread storage of the lane kernel: per link the joint's cos/sin (revolute) or displacement
/// (prismatic), and the net force and moment of the link.
#[derive(Debug, Clone)]
struct LaneData {
    cs: Vec<(Lane, Lane)>,
    f: Vec<(V3l, V3l)>,
    tau: Vec<Lane>,
}

impl LaneData {
    fn new(n: usize) -> Self {
        Self { cs: vec![([0.0; LANES], [0.0; LANES]); n], f: vec![(V3l::default(), V3l::default()); n], tau: vec![[0.0; LANES]; n] }
    }
}

/// Recursive Newton-Euler on `LANES` rows of a batch at once, in the classical (Luh, Walker & Paul 1980;
/// Craig 2005 sec. 6.5) form that propagates only `ω`, `ω̇` and the linear acceleration of each frame
/// origin (the linear velocity is not needed); link forces about the frame origin (Featherstone eq. 2.63):
/// `F = m a + ω̇ × h + ω × (ω × h)`, `N = I_o ω̇ + ω × (I_o ω) + h × a`, with `h = m c`. Each joint transform is
/// split into the shared placement and the per-lane motion. Agrees with [`rnea`] to rounding.
#[allow(clippy::too_many_arguments)]
#[inline]
fn rnea_lanes(
    model: &Model,
    classes: &[(Rot, bool)],
    ld: &mut LaneData,
    rows: &[usize; LANES],
    qs: &[f64],
    qds: Option<&[f64]>,
    qdds: Option<&[f64]>,
    g_base: &Vector3<f64>,
    f_ext: Option<&[f64]>,
) {
    let n = model.nq();
    let joints = model.joints();
    let mut w = V3l::default();
    let mut wd = V3l::default();
    let mut a = V3l::splat(&-g_base);
    for (i, ((j, inertia), (cs_out, f_out))) in joints.iter().zip(model.inertias()).zip(ld.cs.iter_mut().zip(ld.f.iter_mut())).enumerate() {
        let s = lanes!(l => qs[rows[l] * n + i] + j.offset);
        let qd = match qds {
            Some(v) => lanes!(l => v[rows[l] * n + i]),
            None => [0.0; LANES],
        };
        let qdd = match qdds {
            Some(v) => lanes!(l => v[rows[l] * n + i]),
            None => [0.0; LANES],
        };
        let (r0, p0_zero) = &classes[i];
        let p0 = &j.placement.translation.vector;
        // to the placement frame (shared transform): a' = r0ᵀ (a + ω̇ × p0 + ω × (ω × p0))
        let a_p = if *p0_zero { a.rt_rot(r0) } else { a.add(&wd.cross_s(p0)).add(&w.cross(&w.cross_s(p0))).rt_rot(r0) };
        let w_p = w.rt_rot(r0);
        let wd_p = wd.rt_rot(r0);
        match j.kind {
            JointKind::Revolute => {
                let (sn, c) = sin_cos_lanes(&s);
                let w_r = w_p.rz_t(&c, &sn);
                // ω = Rzᵀ ω' + qd z;  ω̇ = Rzᵀ ω̇' + (Rzᵀ ω') × qd z + qdd z
                w = V3l { z: lanes!(l => w_r.z[l] + qd[l]), ..w_r };
                let wd_r = wd_p.rz_t(&c, &sn);
                wd = V3l { x: lanes!(l => wd_r.x[l] + w_r.y[l] * qd[l]), y: lanes!(l => wd_r.y[l] - w_r.x[l] * qd[l]), z: lanes!(l => wd_r.z[l] + qdd[l]) };
                a = a_p.rz_t(&c, &sn);
                *cs_out = (c, sn);
            }
            JointKind::Prismatic => {
                // origin moved by s along z': a = a' + ω̇' × s z + ω' × (ω' × s z) + 2 ω' × qd z + qdd z
                let dz = V3l { x: [0.0; LANES], y: [0.0; LANES], z: s };
                let wxd = w_p.cross(&dz);
                let mut acc = a_p.add(&wd_p.cross(&dz)).add(&w_p.cross(&wxd));
                for l in 0..LANES {
                    acc.x[l] += 2.0 * w_p.y[l] * qd[l];
                    acc.y[l] -= 2.0 * w_p.x[l] * qd[l];
                    acc.z[l] += qdd[l];
                }
                w = w_p;
                wd = wd_p;
                a = acc;
                *cs_out = (s, [0.0; LANES]);
            }
        }
        let rb = Rb::from(inertia);
        let wh = w.cross_s(&rb.h);
        let f = a.scale(rb.m).add(&wd.cross_s(&rb.h)).add(&w.cross(&wh));
        let iw = w.rt(&rb.io); // io symmetric: ioᵀ ω = io ω
        let nn = wd.rt(&rb.io).add(&w.cross(&iw)).sub(&a.cross_s(&rb.h));
        *f_out = (nn, f);
    }
    if let Some(we) = f_ext {
        let t = model.t_last_tool();
        let (r, p) = (t.rotation.matrix(), &t.translation.vector);
        let row = |l: usize| if we.len() == 6 { 0 } else { 6 * rows[l] };
        let fe = V3l { x: lanes!(l => we[row(l)]), y: lanes!(l => we[row(l) + 1]), z: lanes!(l => we[row(l) + 2]) }.r(r);
        let ne = V3l { x: lanes!(l => we[row(l) + 3]), y: lanes!(l => we[row(l) + 4]), z: lanes!(l => we[row(l) + 5]) }.r(r);
        let ne = ne.sub(&fe.cross_s(p));
        let last = &mut ld.f[n - 1];
        *last = (last.0.sub(&ne), last.1.sub(&fe));
    }
    for i in (0..n).rev() {
        let (nn, f) = ld.f[i];
        ld.tau[i] = match joints[i].kind {
            JointKind::Revolute => nn.z,
            JointKind::Prismatic => f.z,
        };
        if i > 0 {
            let j = &joints[i];
            let (r0, p0_zero) = &classes[i];
            let p0 = &j.placement.translation.vector;
            let (c, sn) = &ld.cs[i];
            let (f_p, n_p) = match j.kind {
                JointKind::Revolute => {
                    let f_p = f.rz(c, sn).r_rot(r0);
                    let n_p = nn.rz(c, sn).r_rot(r0);
                    (f_p, if *p0_zero { n_p } else { n_p.sub(&f_p.cross_s(p0)) })
                }
                JointKind::Prismatic => {
                    // p = p0 + s z0: n_parent = r0 n + p × (r0 f)
                    let f_p = f.r_rot(r0);
                    let z0 = j.placement.rotation.matrix().column(2).into_owned();
                    let d = V3l { x: lanes!(l => z0.x * c[l]), y: lanes!(l => z0.y * c[l]), z: lanes!(l => z0.z * c[l]) };
                    (f_p, nn.r_rot(r0).sub(&f_p.cross_s(p0)).add(&d.cross(&f_p)))
                }
            };
            let parent = &mut ld.f[i - 1];
            *parent = (parent.0.add(&n_p), parent.1.add(&f_p));
        }
    }
}

/// Batch inverse dynamics with the lane kernel: rows in groups of [`LANES`] (the last group padded by
/// repeating its last row), chunks of rows in parallel.
#[allow(clippy::too_many_arguments)]
fn rnea_batch_lanes(model: &Model, count: usize, qs: &[f64], qds: Option<&[f64]>, qdds: Option<&[f64]>, g: &Vector3<f64>, f_ext: Option<&[f64]>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    if n == 0 || count == 0 {
        return Ok(());
    }
    let g_base = gravity_in_base(model, g);
    let classes = placement_classes(model);
    out.par_chunks_mut(n * CHUNK).enumerate().try_for_each_init(
        || LaneData::new(n),
        |ld, (c, chunk)| {
            let start = c * CHUNK;
            let rows_here = chunk.len() / n;
            for r in start..start + rows_here {
                check_row("q", r, &qs[r * n..(r + 1) * n])?;
                if let Some(v) = qds {
                    check_row("qd", r, &v[r * n..(r + 1) * n])?;
                }
                if let Some(v) = qdds {
                    check_row("qdd", r, &v[r * n..(r + 1) * n])?;
                }
            }
            for g0 in (0..rows_here).step_by(LANES) {
                let rows: [usize; LANES] = std::array::from_fn(|l| start + (g0 + l).min(rows_here - 1));
                rnea_lanes(model, &classes, ld, &rows, qs, qds, qdds, &g_base, f_ext);
                for l in 0..LANES.min(rows_here - g0) {
                    let o = &mut chunk[(g0 + l) * n..(g0 + l + 1) * n];
                    for (k, t) in o.iter_mut().zip(&ld.tau) {
                        *k = t[l];
                    }
                }
            }
            Ok(())
        },
    )
}

/// Batch [`rnea`]: `qs`, `qds`, `qdds` row-major (N, n); `f_ext` none, one wrench `[f; n]` (6) or one per
/// row (N, 6); `out` (N, n). Runs on every core.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let qs = [0.0, 0.0, 0.1, 0.2];
/// let mut out = [0.0; 4];
/// dynamics::rnea_batch(&m, &qs, &[0.0; 4], &[1.0, 0.0, 1.0, 0.0], &nalgebra::Vector3::zeros(), None, &mut out).unwrap();
/// assert!((out[0] - 5.0).abs() < 1e-14);
/// ```
pub fn rnea_batch(model: &Model, qs: &[f64], qds: &[f64], qdds: &[f64], gravity: &Vector3<f64>, f_ext: Option<&[f64]>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = batch_rows(model, &[("q", qs), ("qd", qds), ("qdd", qdds)], "output torques", n, out.len())?;
    check_gravity(gravity)?;
    let w = wrench_of(f_ext, count)?;
    rnea_batch_lanes(model, count, qs, Some(qds), Some(qdds), gravity, w, out)
}

/// Batch [`bias_forces`]: `qs`, `qds` (N, n) -> `out` (N, n).
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut out = [1.0; 2];
/// dynamics::bias_forces_batch(&m, &[0.0; 2], &[1.0; 2], &nalgebra::Vector3::zeros(), &mut out).unwrap();
/// assert_eq!(out, [0.0; 2]);
/// ```
pub fn bias_forces_batch(model: &Model, qs: &[f64], qds: &[f64], gravity: &Vector3<f64>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = batch_rows(model, &[("q", qs), ("qd", qds)], "output torques", n, out.len())?;
    check_gravity(gravity)?;
    rnea_batch_lanes(model, count, qs, Some(qds), None, gravity, None, out)
}

/// Batch [`gravity_torques`]: `qs` (N, n) -> `out` (N, n).
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut out = [1.0; 2];
/// dynamics::gravity_torques_batch(&m, &[0.0; 2], &nalgebra::Vector3::new(0.0, -9.81, 0.0), &mut out).unwrap();
/// assert_eq!(out, [0.0; 2]);
/// ```
pub fn gravity_torques_batch(model: &Model, qs: &[f64], gravity: &Vector3<f64>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = batch_rows(model, &[("q", qs)], "output torques", n, out.len())?;
    check_gravity(gravity)?;
    rnea_batch_lanes(model, count, qs, None, None, gravity, None, out)
}

fn copy_matrix_row_major(m: &DMatrix<f64>, o: &mut [f64]) {
    let n = m.nrows();
    for r in 0..n {
        for c in 0..n {
            o[r * n + c] = m[(r, c)];
        }
    }
}

/// Batch [`mass_matrix`]: `qs` (N, n) -> `out` (N, n, n) row-major.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut out = [0.0; 4];
/// dynamics::mass_matrix_batch(&m, &[0.0, 0.0], &mut out).unwrap();
/// assert!((out[0] - 5.0).abs() < 1e-15 && (out[3] - 1.0).abs() < 1e-15);
/// ```
pub fn mass_matrix_batch(model: &Model, qs: &[f64], out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    batch_rows(model, &[("q", qs)], "output matrices", n * n, out.len())?;
    par_rows(model, out, n * n, |ws, r, o| {
        let q = &qs[r * n..(r + 1) * n];
        check_row("q", r, q)?;
        crba_unchecked(model, ws, q);
        copy_matrix_row_major(&ws.mass_matrix, o);
        Ok(())
    })
}

/// Batch [`coriolis_matrix`]: `qs`, `qds` (N, n) -> `out` (N, n, n) row-major.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics};
/// let m = builtin_planar2(1.0, 1.0);
/// let mut out = [1.0; 4];
/// dynamics::coriolis_matrix_batch(&m, &[0.0; 2], &[1.0; 2], &mut out).unwrap();
/// assert_eq!(out, [0.0; 4]);
/// ```
pub fn coriolis_matrix_batch(model: &Model, qs: &[f64], qds: &[f64], out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    batch_rows(model, &[("q", qs), ("qd", qds)], "output matrices", n * n, out.len())?;
    par_rows(model, out, n * n, |ws, r, o| {
        let (q, qd) = (&qs[r * n..(r + 1) * n], &qds[r * n..(r + 1) * n]);
        check_row("q", r, q)?;
        check_row("qd", r, qd)?;
        coriolis_unchecked(model, ws, q, qd);
        copy_matrix_row_major(&ws.coriolis, o);
        Ok(())
    })
}

/// Batch [`forward_dynamics`] (ABA): `qs`, `qds`, `taus` (N, n), `f_ext` as in [`rnea_batch`] -> `out` (N, n).
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let mut out = [0.0; 2];
/// dynamics::forward_dynamics_batch(&m, &[0.0; 2], &[0.0; 2], &[5.0, 2.0], &nalgebra::Vector3::zeros(), None, &mut out).unwrap();
/// assert!((out[0] - 1.0).abs() < 1e-14 && out[1].abs() < 1e-14);
/// ```
pub fn forward_dynamics_batch(model: &Model, qs: &[f64], qds: &[f64], taus: &[f64], gravity: &Vector3<f64>, f_ext: Option<&[f64]>, out: &mut [f64]) -> Result<()> {
    let n = model.nq();
    let count = batch_rows(model, &[("q", qs), ("qd", qds), ("tau", taus)], "output accelerations", n, out.len())?;
    check_gravity(gravity)?;
    let w = wrench_of(f_ext, count)?;
    par_rows(model, out, n, |ws, r, o| {
        let (q, qd, tau) = (&qs[r * n..(r + 1) * n], &qds[r * n..(r + 1) * n], &taus[r * n..(r + 1) * n]);
        check_row("q", r, q)?;
        check_row("qd", r, qd)?;
        check_row("tau", r, tau)?;
        let we = wrench_row(w, r);
        aba_unchecked(model, ws, q, qd, tau, gravity, we.as_ref())?;
        o.copy_from_slice(&ws.qdd);
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use crate::model::{Joint, JointKind};
    use crate::spatial::{rx, trans};

    /// The joint frames of the dynamics kernel are those of kinematics, bit for bit (one sin/cos kernel:
    /// the two hand-written ones differed in the last bit on about 30 % of angles).
    #[test]
    fn link_transforms_equal_kinematics_bit_for_bit() {
        let j = Joint::new("j", JointKind::Revolute, rx(0.7) * trans(0.1, -0.2, 0.3));
        let mut s = -40.0;
        while s < 40.0 {
            let x = super::link_transform(&j, s);
            let mut t = j.placement;
            crate::kinematics::apply_motion(&mut t, j.kind, s);
            assert_eq!(x.r, *t.rotation.matrix(), "angle {s}");
            assert_eq!(x.p, t.translation.vector, "angle {s}");
            s += 0.001_234_567;
        }
    }
}
