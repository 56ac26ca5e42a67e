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
//! run on every core (rayon; `crate::parallel::with_threads` chooses), one workspace per thread.
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
//!
//! # Files (by concern, as pinocchio's algorithm headers)
//!
//! `inertia` (link inertial parameters), `rnea` (inverse dynamics, bias and gravity terms), `crba` (mass and
//! Coriolis matrices), `aba` (forward dynamics), `energy`, `batch` (the (N, n) forms); this file holds the
//! spatial algebra and the workspace they share.

mod aba;
mod batch;
mod crba;
mod energy;
mod inertia;
mod rnea;

pub use crate::inertia::*;
pub use aba::*;
pub use batch::*;
pub use crba::*;
pub use energy::*;
pub use inertia::*;
pub use rnea::*;

use crate::error::{Error, Result, check_finite, check_len};
use crate::math::{sin_cos, sin_cos_lanes};
use crate::model::{Joint, JointKind, Model};
use nalgebra::{DMatrix, Matrix3, Matrix6, Vector3, Vector6};

/// Default gravity in `world`: `[0, 0, -9.81]` m/s^2 (world z up).
pub const DEFAULT_GRAVITY: [f64; 3] = [0.0, 0.0, -9.81];

// ---------------------------------------------------------------------------------------------------
// Spatial algebra (Featherstone ch. 2), on pairs of 3-vectors
// ---------------------------------------------------------------------------------------------------

/// `r v`, written out (small fixed sizes: no loops, no bounds checks).
#[inline(always)]
fn mv(r: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(r.m11 * v.x + r.m12 * v.y + r.m13 * v.z, r.m21 * v.x + r.m22 * v.y + r.m23 * v.z, r.m31 * v.x + r.m32 * v.y + r.m33 * v.z)
}

/// `rᵀ v`, written out.
#[inline(always)]
fn mtv(r: &Matrix3<f64>, v: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(r.m11 * v.x + r.m21 * v.y + r.m31 * v.z, r.m12 * v.x + r.m22 * v.y + r.m32 * v.z, r.m13 * v.x + r.m23 * v.y + r.m33 * v.z)
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

/// The largest joint rate (rad/s, m/s) the dynamics takes: `sqrt(f64::MAX)`, beyond which its square, and so the
/// velocity-product (centrifugal, Coriolis) terms, overflow double precision.
pub const MAX_RATE: f64 = 1.340_780_792_994_259_6e154;

/// Joint rates `qd` within [`MAX_RATE`], or [`Error::InvalidArgument`] naming the argument ("qd", or
/// "qd (row 6)" for `row` 6 of a batch: the name is built only for the error) and the joint: with qd = 1e160
/// the torques had come out NaN (or, in the batch kernel's other order of operations, finite round-off
/// garbage).
pub(super) fn check_rates(qd: &[f64], row: Option<usize>) -> Result<()> {
    match qd.iter().position(|x| x.abs() > MAX_RATE) {
        Some(i) => Err(Error::InvalidArgument {
            what: match row {
                Some(r) => format!("qd (row {r}) at joint {}", i + 1),
                None => format!("qd at joint {}", i + 1),
            },
            expected: format!("joint rates whose squares are finite (|qd| <= {MAX_RATE:.4e} rad/s or m/s)"),
            got: format!("{:e}", qd[i]),
        }),
        None => Ok(()),
    }
}

/// A result of the dynamics must be finite: with finite inputs (and rates within [`MAX_RATE`]) a NaN or infinity can
/// only come from an overflow of double precision (accelerations of 1e300, masses of 1e300), and it becomes [`Error::Overflow`] naming the result
/// (`what`, formatted only for the error: a batch passes `format_args!` with its row), where the
/// first non-finite value is (`label(k)` for flat index `k`: "joint 2", "entry (1, 3)", ...) and the largest
/// of the `inputs` (the argument and joint to blame), instead of a NaN handed to the caller.
pub(super) fn check_result(what: impl std::fmt::Display, out: &[f64], label: impl Fn(usize) -> String, inputs: &[(&str, &[f64])]) -> Result<()> {
    let Some(k) = out.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let mut big: Option<(&str, usize, f64)> = None;
    for (name, v) in inputs {
        for (i, x) in v.iter().enumerate() {
            if big.is_none_or(|b| x.abs() > b.2) {
                big = Some((name, i, x.abs()));
            }
        }
    }
    let cause = match big {
        Some((name, i, x)) if x > 1e100 => format!("the input {name} at joint {} is {x:e}: too large for double precision", i + 1),
        _ => "the inputs are moderate: the model's parameters (inertias, lengths) overflow double precision".to_string(),
    };
    Err(Error::Overflow { what: what.to_string(), at: label(k), value: out[k], cause })
}

/// The label of flat index `k` of a vector over the joints: "joint k+1".
pub(super) fn joint_label(k: usize) -> String {
    format!("joint {}", k + 1)
}

/// The label of flat index `k` of an n x n matrix, row-major (batch outputs) or column-major (nalgebra's
/// storage): "entry (row, column)", 1-based.
pub(super) fn entry_label(n: usize, row_major: bool) -> impl Fn(usize) -> String {
    move |k| {
        let (r, c) = if row_major { (k / n, k % n) } else { (k % n, k / n) };
        format!("entry ({}, {})", r + 1, c + 1)
    }
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
fn wrench_in_last_joint_frame(model: &Model, w: &Vector6<f64>) -> (Vector3<f64>, Vector3<f64>) {
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
