//! Parameter tables of every convention and their builders into a [`Model`] (docs/conventions.md,
//! "Parameter tables").

use crate::error::{Error, Result, check_finite, check_len};
use crate::model::{Joint, JointKind, Model};
use crate::spatial::{Pose, frame_from_zx, rx, rz, trans};
use nalgebra::{DMatrix, Vector3};

/// A kinematic convention.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Convention {
    /// Standard (distal) DH: `Rz(theta+q) Tz(d) Tx(a) Rx(alpha)`; columns `d, theta, a, alpha`.
    Dh,
    /// Modified (proximal, Craig) DH: `Rx(alpha) Tx(a) Rz(theta+q) Tz(d)`; columns `alpha, a, theta, d`.
    Mdh,
    /// ED-H (Guo et al. eq. 1-2): `Rx(alpha) Trans(a, b, c) Rz(theta+q)`; columns `alpha, a, b, c, theta`.
    Edh,
    /// Product of exponentials (Lynch & Park eq. 4.14): space screws `wx, wy, wz, vx, vy, vz` and home pose M.
    Poe,
}

impl Convention {
    /// All conventions.
    pub const ALL: [Convention; 4] = [Convention::Dh, Convention::Mdh, Convention::Edh, Convention::Poe];

    /// Parse a name: `dh`, `mdh`, `edh`, `poe`.
    ///
    /// ```
    /// use denavit_core::Convention;
    /// assert_eq!(Convention::parse("EDH").unwrap(), Convention::Edh);
    /// assert!(Convention::parse("hayati").unwrap_err().to_string().contains("expected one of dh, mdh, edh, poe"));
    /// ```
    pub fn parse(s: &str) -> Result<Self> {
        match s.to_ascii_lowercase().replace(['-', '_'], "").as_str() {
            "dh" | "sdh" | "standarddh" => Ok(Self::Dh),
            "mdh" | "modifieddh" | "craig" => Ok(Self::Mdh),
            "edh" | "enhanceddh" => Ok(Self::Edh),
            "poe" => Ok(Self::Poe),
            _ => Err(Error::UnknownName { kind: "convention".into(), got: s.into(), expected: "dh, mdh, edh, poe".into() }),
        }
    }
    /// Short name (`dh`, `mdh`, `edh`, `poe`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Dh => "dh",
            Self::Mdh => "mdh",
            Self::Edh => "edh",
            Self::Poe => "poe",
        }
    }
    /// Column names of the parameter table, in order.
    pub fn columns(self) -> &'static [&'static str] {
        match self {
            Self::Dh => &["d", "theta", "a", "alpha"],
            Self::Mdh => &["alpha", "a", "theta", "d"],
            Self::Edh => &["alpha", "a", "b", "c", "theta"],
            Self::Poe => &["wx", "wy", "wz", "vx", "vy", "vz"],
        }
    }
    /// Which columns are angles (radians inside, degrees at the edges if asked).
    pub fn angle_columns(self) -> &'static [bool] {
        match self {
            Self::Dh => &[false, true, false, true],
            Self::Mdh => &[true, false, true, false],
            Self::Edh => &[true, false, false, false, true],
            Self::Poe => &[false; 6],
        }
    }
}

/// A parameter table: one row per joint in the convention's column order, plus the base and tool poses.
///
/// `t_last_tool` is the tool in the convention's last frame (frame n), which is the flange
/// (docs/conventions.md, "Frames: base, joint i, flange, tool"), for `dh`, `mdh`, `edh`, and the home pose
/// `M = T_base_tool(q = 0)` for `poe`.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Which convention the rows follow.
    pub convention: Convention,
    /// n x k parameters (metres, radians).
    pub params: DMatrix<f64>,
    /// Joint kinds.
    pub kinds: Vec<JointKind>,
    /// `T_world_base`.
    pub t_world_base: Pose,
    /// Tool in the last frame (`dh`, `mdh`, `edh`), or home pose M (`poe`).
    pub t_last_tool: Pose,
}

impl Table {
    /// A checked table.
    pub fn new(convention: Convention, params: DMatrix<f64>, kinds: Vec<JointKind>, t_world_base: Pose, t_last_tool: Pose) -> Result<Self> {
        check_len(&format!("{} table columns ({})", convention.name(), convention.columns().join(", ")), convention.columns().len(), params.ncols())?;
        check_len("joint kinds (one per table row)", params.nrows(), kinds.len())?;
        for i in 0..params.nrows() {
            let row: Vec<f64> = params.row(i).iter().copied().collect();
            check_finite(&format!("{} table row {} (joint {})", convention.name(), i + 1, i + 1), &row)?;
        }
        Ok(Self { convention, params, kinds, t_world_base, t_last_tool })
    }

    /// Number of joints.
    pub fn nq(&self) -> usize {
        self.params.nrows()
    }

    /// The model this table describes, with default joint names `j1..jn`, default limits.
    ///
    /// ```
    /// use denavit_core::{Convention, Table, JointKind, spatial::Pose, kinematics::fk};
    /// // a planar 2R arm in standard DH: rows (d, theta, a, alpha)
    /// let p = nalgebra::DMatrix::from_row_slice(2, 4, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    /// let t = Table::new(Convention::Dh, p, vec![JointKind::Revolute; 2], Pose::identity(), Pose::identity()).unwrap();
    /// let m = t.to_model("planar").unwrap();
    /// assert!((fk(&m, &[0.0, 0.0]).unwrap().translation.x - 2.0).abs() < 1e-15);
    /// ```
    pub fn to_model(&self, name: &str) -> Result<Model> {
        let joints: Vec<Joint> = self
            .placements()?
            .into_iter()
            .enumerate()
            .map(|(i, (placement, offset))| {
                let mut j = Joint::new(format!("j{}", i + 1), self.kinds[i], placement);
                j.offset = offset;
                j
            })
            .collect();
        let (flange, tool) = self.flange_and_tool()?;
        self.with_link_frames(Model::new(name, self.t_world_base, joints, flange, tool)?)
    }

    /// The model with the given names and limits (one each per joint).
    pub fn to_model_with(&self, name: &str, names: &[String], lower: &[f64], upper: &[f64]) -> Result<Model> {
        let n = self.nq();
        check_len("joint names", n, names.len())?;
        check_len("lower limits", n, lower.len())?;
        check_len("upper limits", n, upper.len())?;
        let joints: Vec<Joint> = self
            .placements()?
            .into_iter()
            .enumerate()
            .map(|(i, (placement, offset))| Joint { name: names[i].clone(), kind: self.kinds[i], placement, offset, lower: lower[i], upper: upper[i] })
            .collect();
        let (flange, tool) = self.flange_and_tool()?;
        self.with_link_frames(Model::new(name, self.t_world_base, joints, flange, tool)?)
    }

    /// A DH table's model records its link frames ([`Model::dh_link_frames`]).
    fn with_link_frames(&self, m: Model) -> Result<Model> {
        if self.convention == Convention::Dh { m.with_dh_link_frames(self.link_frames()) } else { Ok(m) }
    }

    fn row(&self, i: usize) -> Vec<f64> {
        self.params.row(i).iter().copied().collect()
    }

    /// Per joint: (placement, offset).
    fn placements(&self) -> Result<Vec<(Pose, f64)>> {
        let n = self.nq();
        let mut out = Vec::with_capacity(n);
        match self.convention {
            Convention::Dh => {
                for i in 0..n {
                    let prev = if i > 0 { self.dh_link(i - 1) } else { Pose::identity() };
                    let r = self.row(i); // d, theta, a, alpha
                    match self.kinds[i] {
                        JointKind::Revolute => out.push((prev, r[1])),
                        JointKind::Prismatic => out.push((prev * rz(r[1]), r[0])),
                    }
                }
            }
            Convention::Mdh => {
                for i in 0..n {
                    let r = self.row(i); // alpha, a, theta, d
                    match self.kinds[i] {
                        JointKind::Revolute => out.push((rx(r[0]) * trans(r[1], 0.0, r[3]), r[2])),
                        JointKind::Prismatic => out.push((rx(r[0]) * trans(r[1], 0.0, 0.0) * rz(r[2]), r[3])),
                    }
                }
            }
            Convention::Edh => {
                for i in 0..n {
                    let r = self.row(i); // alpha, a, b, c, theta
                    match self.kinds[i] {
                        JointKind::Revolute => out.push((rx(r[0]) * trans(r[1], r[2], r[3]), r[4])),
                        JointKind::Prismatic => out.push((rx(r[0]) * trans(r[1], r[2], 0.0) * rz(r[4]), r[3])),
                    }
                }
            }
            Convention::Poe => {
                let mut prev = Pose::identity();
                for f in self.poe_home_frames()? {
                    out.push((prev.inverse() * f, 0.0));
                    prev = f;
                }
            }
        }
        Ok(out)
    }

    /// DH: `Tz(d_i) Tx(a_i) Rx(alpha_i)` of row `i` (0-based; prismatic: `Tx(a_i) Rx(alpha_i)`, the joint
    /// variable and `d_i` being in the joint motion), i.e. DH frame *i* in joint frame *i* (1-based).
    fn dh_link(&self, i: usize) -> Pose {
        let r = self.row(i); // d, theta, a, alpha
        match self.kinds[i] {
            JointKind::Revolute => trans(0.0, 0.0, r[0]) * trans(r[2], 0.0, 0.0) * rx(r[3]),
            JointKind::Prismatic => trans(r[2], 0.0, 0.0) * rx(r[3]),
        }
    }

    /// `(T_last_flange, T_flange_tool)` of the model (docs/conventions.md, "Frames: base, joint i, flange,
    /// tool"): `dh`: the flange is DH frame n (the last row's link transform in joint frame n), the tool the
    /// table's; `mdh`, `edh`: the flange is joint frame n, the tool the table's; `poe`: the flange is the home
    /// pose M's frame, no tool.
    fn flange_and_tool(&self) -> Result<(Pose, Pose)> {
        let n = self.nq();
        Ok(match self.convention {
            Convention::Dh if n > 0 => (self.dh_link(n - 1), self.t_last_tool),
            Convention::Poe => {
                let last = if n > 0 { self.poe_home_frames()?[n - 1] } else { Pose::identity() };
                (last.inverse() * self.t_last_tool, Pose::identity())
            }
            _ => (Pose::identity(), self.t_last_tool),
        })
    }

    /// Pose of the convention's frame *i* in the model's joint frame *i*, i = 1..n (frames move together):
    /// `dh`: DH frame *i* = joint frame *i* · `Tz(d_i) Tx(a_i) Rx(alpha_i)` (prismatic `Tx(a_i) Rx(alpha_i)`);
    /// `mdh`, `edh`, `poe`: the identity (joint frame *i* is the convention's frame *i*). Inertias given in
    /// the convention's frame *i* are re-expressed in joint frame *i* by this pose.
    ///
    /// ```
    /// use denavit_core::{Convention, Table, JointKind, spatial::{trans, Pose}};
    /// let p = nalgebra::DMatrix::from_row_slice(1, 4, &[0.2, 0.0, 0.5, 0.0]);
    /// let t = Table::new(Convention::Dh, p, vec![JointKind::Revolute], Pose::identity(), Pose::identity()).unwrap();
    /// assert_eq!(t.link_frames(), vec![trans(0.0, 0.0, 0.2) * trans(0.5, 0.0, 0.0)]);
    /// ```
    pub fn link_frames(&self) -> Vec<Pose> {
        (0..self.nq()).map(|i| if self.convention == Convention::Dh { self.dh_link(i) } else { Pose::identity() }).collect()
    }

    /// POE: joint frames at home in the base frame (docs/conventions.md): origin at the foot of the base
    /// origin on the axis (prismatic: the previous frame's origin), z along the screw axis, x from base x.
    fn poe_home_frames(&self) -> Result<Vec<Pose>> {
        let mut frames = Vec::with_capacity(self.nq());
        let mut prev_origin = Vector3::zeros();
        for i in 0..self.nq() {
            let r = self.row(i);
            let w = Vector3::new(r[0], r[1], r[2]);
            let v = Vector3::new(r[3], r[4], r[5]);
            let f = match self.kinds[i] {
                JointKind::Revolute => {
                    let wn = w.norm();
                    if (wn - 1.0).abs() > 1e-9 || w.dot(&v).abs() > 1e-9 * (1.0 + v.norm()) {
                        return Err(Error::InvalidArgument {
                            what: format!("poe screw of revolute joint {}", i + 1),
                            expected: "|w| = 1 and w . v = 0 (a pure rotation)".into(),
                            got: format!("|w| = {wn}, w . v = {}", w.dot(&v)),
                        }
                        .at_joint(i + 1));
                    }
                    let z = w / wn;
                    let origin = z.cross(&v);
                    frame_from_zx(&origin, &z, &Vector3::x(), &Vector3::y())
                }
                JointKind::Prismatic => {
                    // as |w| = 1 for a revolute joint: a v of another length would scale the joint value
                    // (Lynch & Park's screw (0, v), |v| = 1), so it is refused rather than normalised
                    let vn = v.norm();
                    if w.norm() > 1e-12 || (vn - 1.0).abs() > 1e-9 {
                        return Err(Error::InvalidArgument {
                            what: format!("poe screw of prismatic joint {}", i + 1),
                            expected: "w = 0 and |v| = 1 (a pure translation, v a unit direction)".into(),
                            got: format!("|w| = {}, |v| = {vn}", w.norm()),
                        }
                        .at_joint(i + 1));
                    }
                    let z = v / vn;
                    frame_from_zx(&prev_origin, &z, &Vector3::x(), &Vector3::y())
                }
            };
            prev_origin = f.translation.vector;
            frames.push(f);
        }
        Ok(frames)
    }

    /// The frames 0..n of the convention in world at configuration `q` (`dh`: DH frames 0..n;
    /// `mdh`, `edh`: base and joint frames 1..n; `poe`: base and the model's joint frames).
    pub fn frames(&self, q: &[f64]) -> Result<Vec<Pose>> {
        check_len("q", self.nq(), q.len())?;
        let model = self.to_model("frames")?;
        let mut data = crate::model::Data::new(&model);
        crate::kinematics::forward_kinematics(&model, &mut data, q)?;
        let mut frames = vec![self.t_world_base];
        match self.convention {
            Convention::Dh => {
                // DH frame i = joint frame i · Tz(d_i) Tx(a_i) Rx(alpha_i) (revolute) / Tx(a_i) Rx(alpha_i) (prismatic)
                frames.extend(data.t_world_joint.iter().zip(self.link_frames()).map(|(t, l)| t * l));
            }
            _ => frames.extend(data.t_world_joint.iter().copied()),
        }
        Ok(frames)
    }
}

/// `x` rounded to `digits` significant digits (printed in its shortest form: 0, 2.9, 0.0523).
fn significant(x: f64, digits: i32) -> f64 {
    if x == 0.0 || !x.is_finite() {
        return x;
    }
    let scale = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    (x * scale).round() / scale
}

/// What a calibration measures at each configuration: the tool point (3 values) or the whole tool pose (6).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Measure {
    /// Tool points: the tool is 3 translations.
    Point,
    /// Tool poses: the tool is 3 translations and 3 small rotations.
    Pose,
}

impl Measure {
    /// Parse `"point"` / `"pose"`.
    pub fn parse(s: &str) -> Result<Self> {
        match s {
            "point" => Ok(Self::Point),
            "pose" => Ok(Self::Pose),
            _ => Err(Error::UnknownName { kind: "measure".into(), got: s.into(), expected: "point, pose".into() }),
        }
    }
}

/// One parameter of a calibration parametrization.
#[derive(Debug, Clone, PartialEq)]
pub struct Parameter {
    /// Name, e.g. `alpha_0`, `a_1`, `d_2`, `offset_3`, `beta_1`, `base_tx`, `tool_z`, `scale_2` (docs/conventions.md).
    pub name: String,
    /// Nominal value (m, rad, or a ratio).
    pub value: f64,
    /// `"length"`, `"angle"` or `"ratio"`.
    pub unit: &'static str,
    /// `"base"`, `"link"`, `"offset"`, `"tool"` or `"scale"`.
    pub group: &'static str,
    /// True for a translation along the joint axis it follows (`c_i`, `d_i`): the first to drop when unidentifiable.
    pub along_axis: bool,
    /// Why the parametrization itself holds this parameter fixed (e.g. `d_i` of near-parallel MDH axes).
    pub fixed: Option<String>,
}

/// A calibration parametrization of a table: the chain factors and the named parameters
/// (docs/conventions.md, "Calibration parameters"). Scale parameters, when asked for, come last.
#[derive(Debug, Clone, PartialEq)]
pub struct Parametrization {
    /// `T_world_tool = F_1 · ... · F_K`.
    pub factors: Vec<crate::calibration::CalibrationFactor>,
    /// The parameters, in the order of their indices.
    pub params: Vec<Parameter>,
    /// Index into `factors` of each joint's factor (the one its reading moves).
    pub joint_factors: Vec<usize>,
    /// `factors[..base_end]` form the base.
    pub base_end: usize,
    /// `factors[tool_start..]` form the tool in the flange (the factors between the last joint factor and
    /// `tool_start`, dh's link n and the fixed flange, form the flange).
    pub tool_start: usize,
    /// The scale parameter of each joint, if any.
    pub scales: Vec<Option<usize>>,
}

impl Table {
    /// Consecutive axes `(i, i+1)` (1-based `i`) of this table's model at q = 0 that are within
    /// [`crate::axes::NEAR_PARALLEL_SIN`] of parallel or anti-parallel, with their angle (rad).
    pub fn near_parallel_pairs(&self) -> Result<Vec<(usize, f64)>> {
        let model = self.to_model("pairs")?;
        let ax = crate::axes::axes(&model, &vec![0.0; self.nq()])?;
        Ok((1..self.nq())
            .filter_map(|i| {
                let s = ax.directions[i - 1].cross(&ax.directions[i]).norm();
                (s < crate::axes::NEAR_PARALLEL_SIN).then(|| (i, s.min(1.0).asin()))
            })
            .collect())
    }

    /// The calibration parametrization of this table (`dh`, `mdh`, `edh`) with the flange `t_last_flange`
    /// (fixed, in the convention's last frame) and the tool `t_flange_tool` in the flange (docs/conventions.md,
    /// "Frames"; `robot` names the robot in messages): base `Tx Ty Tz · R0 · Rx Ry Rz` (R0 the nominal base
    /// rotation), one link per row in the convention's factor order with the joint's reading added to its
    /// joint factor, and the tool `Tx Ty Tz · Rt [· Rx Ry Rz]` (rotations for pose measurements). Where
    /// consecutive axes are near-parallel, `mdh` and `edh` links get Hayati's tilt `beta` about y
    /// (Hayati & Mirmirani 1985) and `mdh` holds `d_i` fixed; `dh` is refused there. `scale` adds a scale
    /// parameter per joint (`q -> q (1 + scale)`).
    ///
    /// ```
    /// use denavit_core::{Convention, Table, JointKind, spatial::Pose, convention::Measure};
    /// let p = nalgebra::DMatrix::from_row_slice(2, 4, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    /// let t = Table::new(Convention::Dh, p, vec![JointKind::Revolute; 2], Pose::identity(), Pose::identity()).unwrap();
    /// // planar 2R: parallel axes, so standard DH is refused and ED-H is the way
    /// assert!(t.parametrize("planar", &Pose::identity(), &Pose::identity(), Measure::Point, false).is_err());
    /// ```
    pub fn parametrize(&self, robot: &str, t_last_flange: &Pose, t_flange_tool: &Pose, measure: Measure, scale: bool) -> Result<Parametrization> {
        use crate::calibration::{CalibrationFactor, Motion};
        let n = self.nq();
        let near = self.near_parallel_pairs()?;
        let is_near = |i: usize| near.iter().any(|&(k, _)| k == i);
        if self.convention == Convention::Dh && !near.is_empty() {
            let list: Vec<String> = near.iter().map(|&(i, a)| format!("{}-{} ({} deg)", i, i + 1, significant(a.to_degrees(), 3))).collect();
            return Err(Error::Degenerate {
                reason: format!(
                    "standard DH cannot calibrate {robot}: axes {} are parallel within {} deg; a DH link can tilt the next axis only about their common normal \
                     (alpha); a tilt about the other perpendicular direction (Hayati's beta) sends the common normal, hence d, to infinity, so the fit cannot \
                     represent the robot or diverges (Hayati & Mirmirani 1985): use convention 'mdh' (Hayati angle beta) or 'edh'",
                    list.join(", "),
                    significant(crate::axes::NEAR_PARALLEL_SIN.asin().to_degrees(), 2)
                ),
            });
        }
        if self.convention == Convention::Poe {
            return Err(Error::InvalidArgument {
                what: "calibration convention".into(),
                expected: "dh, mdh or edh (product-of-exponentials calibration is not available yet: use edh)".into(),
                got: "poe".into(),
            });
        }
        let mut factors: Vec<CalibrationFactor> = Vec::new();
        let mut params: Vec<Parameter> = Vec::new();
        let mut joint_factors = Vec::with_capacity(n);
        let mut add =
            |factors: &mut Vec<CalibrationFactor>, axis: Motion, name: String, value: f64, group: &'static str, joint: Option<usize>, along_axis: bool| {
                factors.push(CalibrationFactor::param(axis, params.len(), joint));
                let unit = if axis.is_rotation() { "angle" } else { "length" };
                params.push(Parameter { name, value, unit, group, along_axis, fixed: None });
            };
        let b = &self.t_world_base;
        for (k, a) in [Motion::Tx, Motion::Ty, Motion::Tz].into_iter().enumerate() {
            add(&mut factors, a, format!("base_t{}", ["x", "y", "z"][k]), b.translation.vector[k], "base", None, false);
        }
        factors.push(CalibrationFactor::Fixed(Pose::from_parts(nalgebra::Translation3::identity(), b.rotation)));
        for (k, a) in [Motion::Rx, Motion::Ry, Motion::Rz].into_iter().enumerate() {
            add(&mut factors, a, format!("base_r{}", ["x", "y", "z"][k]), 0.0, "base", None, false);
        }
        let base_end = factors.len();
        let mut fixed_rules: Vec<(String, String)> = Vec::new();
        for k in 0..n {
            let i = k + 1;
            let r = self.row(k);
            let rev = self.kinds[k] == JointKind::Revolute;
            match self.convention {
                Convention::Edh => {
                    // Rx(alpha) Tx(a) Ty(b) Tz(c) [Ry(beta)] Rz(theta + q)  |  prismatic: ... [Ry(beta)] Rz(theta) Tz(c + q)
                    add(&mut factors, Motion::Rx, format!("alpha_{k}"), r[0], "link", None, false);
                    add(&mut factors, Motion::Tx, format!("a_{k}"), r[1], "link", None, false);
                    add(&mut factors, Motion::Ty, format!("b_{k}"), r[2], "link", None, false);
                    if rev {
                        add(&mut factors, Motion::Tz, format!("c_{k}"), r[3], "link", None, true);
                        if is_near(k) {
                            add(&mut factors, Motion::Ry, format!("beta_{k}"), 0.0, "link", None, false);
                        }
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Rz, format!("offset_{i}"), r[4], "offset", Some(k), false);
                    } else {
                        if is_near(k) {
                            add(&mut factors, Motion::Ry, format!("beta_{k}"), 0.0, "link", None, false);
                        }
                        add(&mut factors, Motion::Rz, format!("theta_{i}"), r[4], "link", None, false);
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Tz, format!("offset_{i}"), r[3], "offset", Some(k), false);
                    }
                }
                Convention::Mdh => {
                    // Rx(alpha) Tx(a) [Ry(beta)] Tz(d) Rz(theta + q)  |  prismatic: ... Rz(theta) Tz(d + q)
                    add(&mut factors, Motion::Rx, format!("alpha_{k}"), r[0], "link", None, false);
                    add(&mut factors, Motion::Tx, format!("a_{k}"), r[1], "link", None, false);
                    if is_near(k) {
                        add(&mut factors, Motion::Ry, format!("beta_{k}"), 0.0, "link", None, false);
                    }
                    if rev {
                        add(&mut factors, Motion::Tz, format!("d_{i}"), r[3], "link", None, true);
                        if is_near(i) {
                            fixed_rules.push((
                                format!("d_{i}"),
                                format!(
                                    "axes {i} and {} are near-parallel: their common normal, hence the position of frame {i} along axis {i}, is undefined; \
                                     Hayati's beta_{i} is used instead and d_{i} is fixed (Hayati & Mirmirani 1985)",
                                    i + 1
                                ),
                            ));
                        }
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Rz, format!("offset_{i}"), r[2], "offset", Some(k), false);
                    } else {
                        add(&mut factors, Motion::Rz, format!("theta_{i}"), r[2], "link", None, false);
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Tz, format!("offset_{i}"), r[3], "offset", Some(k), false);
                    }
                }
                _ => {
                    // Rz(theta + q) Tz(d) Tx(a) Rx(alpha)  |  prismatic: Rz(theta) Tz(d + q) Tx(a) Rx(alpha)
                    if rev {
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Rz, format!("offset_{i}"), r[1], "offset", Some(k), false);
                        add(&mut factors, Motion::Tz, format!("d_{i}"), r[0], "link", None, true);
                    } else {
                        add(&mut factors, Motion::Rz, format!("theta_{i}"), r[1], "link", None, false);
                        joint_factors.push(factors.len());
                        add(&mut factors, Motion::Tz, format!("offset_{i}"), r[0], "offset", Some(k), false);
                    }
                    add(&mut factors, Motion::Tx, format!("a_{i}"), r[2], "link", None, false);
                    add(&mut factors, Motion::Rx, format!("alpha_{i}"), r[3], "link", None, false);
                }
            }
        }
        // the nominal flange, fixed in the convention's last frame: the tool parameters are the tool in the flange
        factors.push(CalibrationFactor::Fixed(*t_last_flange));
        let tool_start = factors.len();
        for (k, a) in [Motion::Tx, Motion::Ty, Motion::Tz].into_iter().enumerate() {
            add(&mut factors, a, format!("tool_{}", ["x", "y", "z"][k]), t_flange_tool.translation.vector[k], "tool", None, false);
        }
        factors.push(CalibrationFactor::Fixed(Pose::from_parts(nalgebra::Translation3::identity(), t_flange_tool.rotation)));
        if measure == Measure::Pose {
            for (k, a) in [Motion::Rx, Motion::Ry, Motion::Rz].into_iter().enumerate() {
                add(&mut factors, a, format!("tool_r{}", ["x", "y", "z"][k]), 0.0, "tool", None, false);
            }
        }
        let mut scales = vec![None; n];
        if scale {
            for (k, s) in scales.iter_mut().enumerate() {
                *s = Some(params.len());
                params.push(Parameter { name: format!("scale_{}", k + 1), value: 0.0, unit: "ratio", group: "scale", along_axis: false, fixed: None });
            }
        }
        for (name, why) in fixed_rules {
            if let Some(p) = params.iter_mut().find(|p| p.name == name) {
                p.fixed = Some(why);
            }
        }
        Ok(Parametrization { factors, params, joint_factors, base_end, tool_start, scales })
    }
}
