//! Calibration chains: the tool pose as a product of elementary factors with named parameters, and its
//! analytic identification Jacobian. The parameter names and factor orders of each convention are
//! documented in `python/denavit/calibrate.py`, which builds the chains.
//!
//! A [`CalibrationChain`] is `T_world_tool(q; x) = F_1 · F_2 · ... · F_K`, each factor either a fixed pose or an
//! elementary motion `Rx, Ry, Rz` (rad) or `Tx, Ty, Tz` (m) about / along a local axis by
//!
//! ```text
//! s_k = x[param_k] + q[joint_k] · (1 + x[scale_of_joint_k])        (joint term and scale optional)
//! ```
//!
//! so a joint's zero offset is the parameter of its joint factor, and a joint scale (gear-ratio error) is a
//! parameter too. Any convention (standard / modified DH with or without a Hayati angle, ED-H, base and
//! tool frames) is such a chain; the Python layer builds it from the nominal model and names the parameters.
//!
//! The identification Jacobian `d[p; phi] / dx` of the tool origin `p` and the tool orientation (rows
//! `[v; w]`, `w` the small rotation in world) is, for the parameter of factor `k`, exactly a column of a
//! geometric Jacobian: with `F` the frame *before* factor `k` (origin `o`, local axis `u` expressed in world
//! `u_w = R_F u`), a rotation gives `[u_w × (p − o); u_w]` and a translation `[u_w; 0]` (Hollerbach & Wampler
//! 1996, "The calibration index and taxonomy for robot kinematic calibration methods", sec. 3; the same
//! column as the joint Jacobian of kinematics/mod.rs). A scale parameter's column is `q_j` times its joint
//! factor's column. One forward pass gives every column.
//!
//! ```
//! use denavit_core::calibration::{Motion, CalibrationChain, CalibrationFactor};
//! // planar 2R: Rz(x0 + q0) Tx(x1) Rz(x2 + q1) Tx(x3)
//! let f = vec![
//!     CalibrationFactor::param(Motion::Rz, 0, Some(0)), CalibrationFactor::param(Motion::Tx, 1, None),
//!     CalibrationFactor::param(Motion::Rz, 2, Some(1)), CalibrationFactor::param(Motion::Tx, 3, None),
//! ];
//! let chain = CalibrationChain::new(f, 4, 2, vec![None, None]).unwrap();
//! let x = [0.0, 1.0, 0.0, 1.0];
//! let mut jac = nalgebra::Matrix6xX::zeros(4);
//! let t = chain.pose_jacobian(&x, &[0.0, std::f64::consts::FRAC_PI_2], &mut jac).unwrap();
//! assert!((t.translation.vector - nalgebra::Vector3::new(1.0, 1.0, 0.0)).norm() < 1e-15);
//! assert!((jac[(0, 1)] - 1.0).abs() < 1e-15); // d p_x / d x1 (first link length)
//! assert!((jac[(0, 3)]).abs() < 1e-15 && (jac[(1, 3)] - 1.0).abs() < 1e-15); // second link points along y
//! ```

use crate::error::{Error, Result, check_finite, check_finite_rows, check_len};
use crate::spatial::Pose;
use nalgebra::{Matrix6xX, Vector3};
use rayon::prelude::*;

/// An elementary motion of a calibration factor: a rotation or translation along one local axis (Rx ... Tz).
/// Not a joint axis (`axes::JointAxes`): the name of what moves, as docs/conventions.md's glossary says.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Motion {
    /// Rotation about local x (rad).
    Rx,
    /// Rotation about local y (rad).
    Ry,
    /// Rotation about local z (rad).
    Rz,
    /// Translation along local x (m).
    Tx,
    /// Translation along local y (m).
    Ty,
    /// Translation along local z (m).
    Tz,
}

impl Motion {
    /// Parse `"rx" | "ry" | "rz" | "tx" | "ty" | "tz"` (case-insensitive).
    ///
    /// ```
    /// use denavit_core::calibration::Motion;
    /// assert_eq!(Motion::parse("Ry").unwrap(), Motion::Ry);
    /// assert!(Motion::parse("rw").unwrap_err().to_string().contains("expected one of rx, ry, rz, tx, ty, tz"));
    /// ```
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().as_str() {
            "rx" => Ok(Self::Rx),
            "ry" => Ok(Self::Ry),
            "rz" => Ok(Self::Rz),
            "tx" => Ok(Self::Tx),
            "ty" => Ok(Self::Ty),
            "tz" => Ok(Self::Tz),
            _ => Err(Error::UnknownName { kind: "elementary factor".into(), got: s.into(), expected: "rx, ry, rz, tx, ty, tz".into() }),
        }
    }
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Rx => "rx",
            Self::Ry => "ry",
            Self::Rz => "rz",
            Self::Tx => "tx",
            Self::Ty => "ty",
            Self::Tz => "tz",
        }
    }
    /// True for `Rx`, `Ry`, `Rz`.
    pub fn is_rotation(self) -> bool {
        matches!(self, Self::Rx | Self::Ry | Self::Rz)
    }
    /// 0, 1, 2 for x, y, z.
    fn index(self) -> usize {
        match self {
            Self::Rx | Self::Tx => 0,
            Self::Ry | Self::Ty => 1,
            Self::Rz | Self::Tz => 2,
        }
    }
}

/// One factor of a chain.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationFactor {
    /// A constant pose (e.g. a nominal rotation around which small angles are identified).
    Fixed(Pose),
    /// `Rx/Ry/Rz/Tx/Ty/Tz(x[param] + q[joint] · (1 + x[scale]))`.
    Elementary {
        /// Local axis and kind.
        axis: Motion,
        /// Index of the parameter in `x`.
        param: usize,
        /// The joint (0-based) whose reading adds to the value, if any.
        joint: Option<usize>,
    },
}

impl CalibrationFactor {
    /// An elementary factor.
    pub fn param(axis: Motion, param: usize, joint: Option<usize>) -> Self {
        Self::Elementary { axis, param, joint }
    }
}

/// A calibration chain: factors, the number of parameters, the number of joints and the optional scale
/// parameter of each joint.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationChain {
    factors: Vec<CalibrationFactor>,
    n_params: usize,
    nq: usize,
    scales: Vec<Option<usize>>,
}

/// `t · Rx/Ry/Rz/Tx/Ty/Tz(s)` in place.
#[inline(always)]
fn apply(t: &mut Pose, axis: Motion, s: f64) {
    if axis.is_rotation() {
        let (sn, cs) = crate::math::sin_cos(s);
        // columns (a, b) of R rotate: R · Rot(s) about the third axis c of (a, b, c) right-handed
        let (a, b) = match axis {
            Motion::Rx => (1, 2),
            Motion::Ry => (2, 0),
            _ => (0, 1),
        };
        let m = t.rotation.matrix_mut_unchecked();
        for r in 0..3 {
            let (ra, rb) = (m[(r, a)], m[(r, b)]);
            m[(r, a)] = cs * ra + sn * rb;
            m[(r, b)] = cs * rb - sn * ra;
        }
    } else {
        let u = t.rotation.matrix().column(axis.index()).into_owned();
        t.translation.vector += u * s;
    }
}

impl CalibrationChain {
    /// A checked chain: every parameter index `< n_params`, every joint `< nq`, one scale entry per joint.
    ///
    /// ```
    /// use denavit_core::calibration::{Motion, CalibrationChain, CalibrationFactor};
    /// let e = CalibrationChain::new(vec![CalibrationFactor::param(Motion::Rz, 3, Some(0))], 2, 1, vec![None]).unwrap_err();
    /// assert!(e.to_string().contains("parameter index of factor 1"));
    /// ```
    pub fn new(factors: Vec<CalibrationFactor>, n_params: usize, nq: usize, scales: Vec<Option<usize>>) -> Result<Self> {
        check_len("joint scale entries (one per joint)", nq, scales.len())?;
        for (k, f) in factors.iter().enumerate() {
            match f {
                CalibrationFactor::Fixed(p) => {
                    check_finite(&format!("fixed pose of factor {}", k + 1), p.translation.vector.as_slice())?;
                    check_finite(&format!("fixed pose of factor {}", k + 1), p.rotation.matrix().as_slice())?;
                }
                CalibrationFactor::Elementary { param, joint, .. } => {
                    if *param >= n_params {
                        return Err(Error::InvalidArgument {
                            what: format!("parameter index of factor {}", k + 1),
                            expected: format!("< {n_params}"),
                            got: param.to_string(),
                        });
                    }
                    if let Some(j) = joint
                        && *j >= nq
                    {
                        return Err(Error::InvalidArgument { what: format!("joint of factor {}", k + 1), expected: format!("< {nq}"), got: j.to_string() });
                    }
                }
            }
        }
        for (j, s) in scales.iter().enumerate() {
            if let Some(s) = s
                && *s >= n_params
            {
                return Err(Error::InvalidArgument {
                    what: format!("scale parameter of joint {}", j + 1),
                    expected: format!("< {n_params}"),
                    got: s.to_string(),
                });
            }
        }
        Ok(Self { factors, n_params, nq, scales })
    }
    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.n_params
    }
    /// Number of joints.
    pub fn nq(&self) -> usize {
        self.nq
    }
    /// The factors.
    pub fn factors(&self) -> &[CalibrationFactor] {
        &self.factors
    }

    fn check(&self, x: &[f64], q: &[f64]) -> Result<()> {
        check_len("calibration parameters x", self.n_params, x.len())?;
        check_finite("calibration parameters x", x)?;
        check_len("q", self.nq, q.len())?;
        check_finite("q", q)
    }

    /// Value of an elementary factor and `d value / d x[scale]` (the joint reading, when scaled).
    #[inline(always)]
    fn value(&self, x: &[f64], q: &[f64], param: usize, joint: Option<usize>) -> (f64, f64) {
        match joint {
            None => (x[param], 0.0),
            Some(j) => match self.scales[j] {
                None => (x[param] + q[j], 0.0),
                Some(s) => (x[param] + q[j] * (1.0 + x[s]), q[j]),
            },
        }
    }

    /// The tool pose (product of all factors).
    pub fn pose(&self, x: &[f64], q: &[f64]) -> Result<Pose> {
        self.check(x, q)?;
        Ok(self.pose_unchecked(x, q))
    }

    fn pose_unchecked(&self, x: &[f64], q: &[f64]) -> Pose {
        let mut t = Pose::identity();
        for f in &self.factors {
            match f {
                CalibrationFactor::Fixed(p) => t *= p,
                CalibrationFactor::Elementary { axis, param, joint } => apply(&mut t, *axis, self.value(x, q, *param, *joint).0),
            }
        }
        t
    }

    /// The tool pose and the identification Jacobian `jac` (6 x n_params, rows `[v; w]` in world: the
    /// derivative of the tool origin and the tool's small rotation). Parameters used by no factor get zero
    /// columns.
    pub fn pose_jacobian(&self, x: &[f64], q: &[f64], jac: &mut Matrix6xX<f64>) -> Result<Pose> {
        self.check(x, q)?;
        if jac.ncols() != self.n_params {
            return Err(Error::SizeMismatch { what: "Jacobian columns".into(), expected: self.n_params, got: jac.ncols() });
        }
        let mut frames = Vec::with_capacity(self.factors.len());
        let t = self.forward(x, q, &mut frames);
        jac.fill(0.0);
        self.columns(&frames, &t.translation.vector, |col, v, w| {
            let mut c = jac.column_mut(col);
            for r in 0..3 {
                c[r] += v[r];
                c[r + 3] += w[r];
            }
        });
        Ok(t)
    }

    /// Forward pass recording, for each elementary factor, (axis in world, origin, kind, param, d/d scale, scale).
    #[inline]
    fn forward(&self, x: &[f64], q: &[f64], frames: &mut Vec<Recorded>) -> Pose {
        frames.clear();
        let mut t = Pose::identity();
        for f in &self.factors {
            match f {
                CalibrationFactor::Fixed(p) => t *= p,
                CalibrationFactor::Elementary { axis, param, joint } => {
                    let (s, ds) = self.value(x, q, *param, *joint);
                    let u = t.rotation.matrix().column(axis.index()).into_owned();
                    let scale = joint.and_then(|j| self.scales[j]);
                    frames.push(Recorded { u, o: t.translation.vector, rotation: axis.is_rotation(), param: *param, ds, scale });
                    apply(&mut t, *axis, s);
                }
            }
        }
        t
    }

    /// Call `add(column, v, w)` for every parameter contribution.
    #[inline]
    fn columns(&self, frames: &[Recorded], p: &Vector3<f64>, mut add: impl FnMut(usize, &Vector3<f64>, &Vector3<f64>)) {
        for r in frames {
            let (v, w) = if r.rotation { (r.u.cross(&(p - r.o)), r.u) } else { (r.u, Vector3::zeros()) };
            add(r.param, &v, &w);
            if let Some(s) = r.scale {
                add(s, &(v * r.ds), &(w * r.ds));
            }
        }
    }

    /// One configuration: the pose row-major into `pose` (16) and the Jacobian entries `sel` picks row-major
    /// into `jac` (rows x columns).
    #[inline]
    fn pose_jacobian_into(&self, x: &[f64], q: &[f64], frames: &mut Vec<Recorded>, sel: &Selection, pose: &mut [f64], jac: &mut [f64]) {
        let (rows, nc) = (sel.rows, sel.slot_count);
        let t = self.forward(x, q, frames);
        crate::kinematics::write_pose(&t, pose);
        jac.fill(0.0);
        self.columns(frames, &t.translation.vector, |col, v, w| {
            let c = sel.slot[col];
            if c == usize::MAX {
                return;
            }
            for r in 0..rows.min(3) {
                jac[r * nc + c] += v[r];
            }
            for r in 3..rows {
                jac[r * nc + c] += w[r - 3];
            }
        });
        // the weights after the sums: each entry is the full Jacobian's times its row's weight
        for (r, row) in jac.chunks_exact_mut(nc.max(1)).take(rows).enumerate() {
            if sel.weights[r] != 1.0 {
                row.iter_mut().for_each(|v| *v *= sel.weights[r]);
            }
        }
    }

    /// Batch: `qs` holds N configurations row-major (N x nq); `poses` receives N row-major 4x4 matrices
    /// (N x 16); `jac`, if given, the part of the N identification Jacobians it asks for (see
    /// [`JacobianOut`]). Runs on all cores from [`PARALLEL_MIN`] configurations on.
    ///
    /// ```
    /// use denavit_core::calibration::{Motion, CalibrationChain, CalibrationFactor, JacobianOut};
    /// let c = CalibrationChain::new(vec![CalibrationFactor::param(Motion::Rz, 0, Some(0)), CalibrationFactor::param(Motion::Tx, 1, None)], 2, 1, vec![None]).unwrap();
    /// let (mut poses, mut jac) = (vec![0.0; 32], vec![0.0; 24]);
    /// c.evaluate_batch(&[0.0, 2.0], &[0.0, 1.0], &mut poses, Some(JacobianOut::full(&mut jac))).unwrap();
    /// assert!((poses[16 + 3] - 2.0 * 1f64.cos()).abs() < 1e-15);
    /// // the tool origin's rows of the link length's column, weighted by 1 / sigma
    /// let mut part = vec![0.0; 6];
    /// let sel = JacobianOut { out: &mut part, rows: 3, columns: Some(&[1]), weights: [1e4; 6] };
    /// c.evaluate_batch(&[0.0, 2.0], &[0.0, 1.0], &mut poses, Some(sel)).unwrap();
    /// assert_eq!(part[3..], [1e4 * 1f64.cos(), 1e4 * 1f64.sin(), 0.0]);
    /// ```
    pub fn evaluate_batch(&self, x: &[f64], qs: &[f64], poses: &mut [f64], jac: Option<JacobianOut<'_>>) -> Result<()> {
        check_len("calibration parameters x", self.n_params, x.len())?;
        check_finite("calibration parameters x", x)?;
        let count = qs.len().checked_div(self.nq).unwrap_or(poses.len() / 16);
        check_len("q batch (N*n values)", count * self.nq, qs.len())?;
        check_finite_rows("q", qs, self.nq)?;
        check_len("poses output (N*16 values)", count * 16, poses.len())?;
        let mut jac = match jac {
            Some(j) => {
                let sel = Selection::of(&j, self.n_params)?;
                check_len("Jacobian output (N*rows*columns values)", count * sel.rows * sel.slot_count, j.out.len())?;
                // nothing to write: the poses alone
                (sel.rows * sel.slot_count > 0).then_some((j.out, sel))
            }
            None => None,
        };
        if count < PARALLEL_MIN {
            // small batches: one thread (waking a pool costs more than the work, and far more on a busy machine)
            let mut frames = Vec::with_capacity(self.factors.len());
            for (i, pk) in poses.chunks_exact_mut(16).enumerate() {
                let q = &qs[i * self.nq..(i + 1) * self.nq];
                match &mut jac {
                    None => crate::kinematics::write_pose(&self.pose_unchecked(x, q), pk),
                    Some((out, sel)) => {
                        let per = sel.rows * sel.slot_count;
                        self.pose_jacobian_into(x, q, &mut frames, sel, pk, &mut out[per * i..per * (i + 1)]);
                    }
                }
            }
            return Ok(());
        }
        const CHUNK: usize = 32;
        crate::parallel::in_pool(|| match jac {
            None => poses.par_chunks_mut(16 * CHUNK).enumerate().for_each(|(c, o)| {
                if crate::parallel::interrupted() {
                    return;
                }
                for (k, ok) in o.chunks_exact_mut(16).enumerate() {
                    let i = c * CHUNK + k;
                    crate::kinematics::write_pose(&self.pose_unchecked(x, &qs[i * self.nq..(i + 1) * self.nq]), ok);
                }
            }),
            Some((out, sel)) => {
                let per = sel.rows * sel.slot_count;
                poses.par_chunks_mut(16 * CHUNK).zip(out.par_chunks_mut(per * CHUNK)).enumerate().for_each_init(
                    || Vec::with_capacity(self.factors.len()),
                    |frames, (c, (po, jo))| {
                        if crate::parallel::interrupted() {
                            return;
                        }
                        for (k, (pk, jk)) in po.chunks_exact_mut(16).zip(jo.chunks_exact_mut(per)).enumerate() {
                            let i = c * CHUNK + k;
                            self.pose_jacobian_into(x, &qs[i * self.nq..(i + 1) * self.nq], frames, &sel, pk, jk);
                        }
                    },
                )
            }
        })?;
        crate::parallel::check_interrupt()
    }
}

/// The part of the identification Jacobians a batch writes ([`CalibrationChain::evaluate_batch`]): for each
/// configuration a row-major `rows x columns` block of `out`, rows `0..rows` of `[v; w]` (3: the tool
/// origin's; 6: with the small rotation), the columns of the parameters `columns` in this order (`None`:
/// all, in order), row `r` times `weights[r]`. The weights multiply the summed entries, so each value is the
/// full Jacobian's entry times its row's weight, bit for bit; only what is asked for is written (a
/// calibration's weighted rows straight into its least-squares matrix, without a full Jacobian in between).
pub struct JacobianOut<'a> {
    /// N blocks of `rows x columns` values.
    pub out: &'a mut [f64],
    /// 1..=6.
    pub rows: usize,
    /// Parameter indices, each at most once; `None`: all.
    pub columns: Option<&'a [usize]>,
    /// Finite weights of the rows (those beyond `rows` unused).
    pub weights: [f64; 6],
}

impl<'a> JacobianOut<'a> {
    /// The whole Jacobians, unweighted: N row-major `6 x n_params` matrices.
    pub fn full(out: &'a mut [f64]) -> Self {
        Self { out, rows: 6, columns: None, weights: [1.0; 6] }
    }
}

/// A [`JacobianOut`] checked against the chain: the output column of each parameter (`usize::MAX`: not
/// written).
struct Selection {
    rows: usize,
    slot: Vec<usize>,
    slot_count: usize,
    weights: [f64; 6],
}

impl Selection {
    fn of(j: &JacobianOut<'_>, n_params: usize) -> Result<Self> {
        let bad = |what: &str, expected: &str, got: String| Err(Error::InvalidArgument { what: what.into(), expected: expected.into(), got });
        if !(1..=6).contains(&j.rows) {
            return bad("Jacobian rows", "1 to 6", j.rows.to_string());
        }
        check_finite("Jacobian row weights", &j.weights[..j.rows])?;
        let mut slot = vec![usize::MAX; n_params];
        let Some(columns) = j.columns else {
            slot.iter_mut().enumerate().for_each(|(k, s)| *s = k);
            return Ok(Self { rows: j.rows, slot, slot_count: n_params, weights: j.weights });
        };
        for (k, &c) in columns.iter().enumerate() {
            match slot.get_mut(c) {
                None => return bad("Jacobian columns", &format!("parameter indices below {n_params}"), c.to_string()),
                Some(s) if *s != usize::MAX => return bad("Jacobian columns", "each parameter at most once", format!("{c} twice")),
                Some(s) => *s = k,
            }
        }
        Ok(Self { rows: j.rows, slot, slot_count: columns.len(), weights: j.weights })
    }
}

/// Batches smaller than this are evaluated on the calling thread.
pub const PARALLEL_MIN: usize = 512;

/// What the forward pass records for one elementary factor.
#[derive(Debug, Clone, Copy)]
struct Recorded {
    u: Vector3<f64>,
    o: Vector3<f64>,
    rotation: bool,
    param: usize,
    ds: f64,
    scale: Option<usize>,
}
