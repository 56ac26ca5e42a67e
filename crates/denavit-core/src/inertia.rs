//! Link inertial parameters (Featherstone ch. 2.13): a spatial type below the model, which carries one per
//! link ([`crate::Model::inertias`]). Their re-expression between frames and models, which needs the model's
//! kinematics, is in `dynamics` (`inertias_in_world`, `transfer_inertias`).

use crate::error::{Error, Result, check_finite, check_len};
use crate::spatial::Pose;
use nalgebra::{Matrix3, Vector3};

/// Relative tolerance on the symmetry of a user-given inertia tensor.
pub const SYMMETRY_TOL: f64 = 1e-12;

/// Relative tolerance (to the trace) on positive semi-definiteness and the triangle inequality.
pub const INERTIA_TOL: f64 = 1e-12;

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
    pub(crate) mass: f64,
    com: Vector3<f64>,
    inertia_com: Matrix3<f64>,
    // derived: first moment m c and the rotational inertia about the frame origin (Featherstone eq. 2.63)
    pub(crate) h: Vector3<f64>,
    pub(crate) inertia_origin: Matrix3<f64>,
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
pub(crate) fn parallel_axis(mass: f64, c: &Vector3<f64>) -> Matrix3<f64> {
    (Matrix3::identity() * c.norm_squared() - c * c.transpose()) * mass
}

/// Check a user-given rotational inertia about the centre of mass; returns it symmetrised.
pub(crate) fn check_tensor(i: &Matrix3<f64>) -> Result<Matrix3<f64>> {
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

pub(crate) fn fmt_matrix(m: &Matrix3<f64>) -> String {
    let rows: Vec<String> = (0..3).map(|r| format!("[{:.6e}, {:.6e}, {:.6e}]", m[(r, 0)], m[(r, 1)], m[(r, 2)])).collect();
    format!("[{}]", rows.join(", "))
}

/// Prefix the `what` of an inertia error with the link it belongs to.
pub(crate) fn for_link(e: Error, link: usize) -> Error {
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
