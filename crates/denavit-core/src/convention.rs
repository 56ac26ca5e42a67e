//! Parameter tables of every convention and their builders into a [`Model`] (docs/conventions.md,
//! "Parameter tables").

use crate::error::{Error, Result, check_finite, check_len};
use crate::model::{Joint, JointKind, Model};
use crate::spatial::{Pose, frame_from_zx, rx, rz, trans, unit};
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
    /// use denavit_core::{Convention, Table, JointKind, spatial::Pose, kinematics::tool_pose};
    /// // a planar 2R arm in standard DH: rows (d, theta, a, alpha)
    /// let p = nalgebra::DMatrix::from_row_slice(2, 4, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    /// let t = Table::new(Convention::Dh, p, vec![JointKind::Revolute; 2], Pose::identity(), Pose::identity()).unwrap();
    /// let m = t.to_model("planar").unwrap();
    /// assert!((tool_pose(&m, &[0.0, 0.0]).unwrap().translation.x - 2.0).abs() < 1e-15);
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
        Model::new(name, self.t_world_base, joints, flange, tool)
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
        Model::new(name, self.t_world_base, joints, flange, tool)
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
                        });
                    }
                    let z = w / wn;
                    let origin = z.cross(&v);
                    frame_from_zx(&origin, &z, &Vector3::x(), &Vector3::y())
                }
                JointKind::Prismatic => {
                    if w.norm() > 1e-12 {
                        return Err(Error::InvalidArgument {
                            what: format!("poe screw of prismatic joint {}", i + 1),
                            expected: "w = 0".into(),
                            got: format!("|w| = {}", w.norm()),
                        });
                    }
                    let z = unit(&v, &format!("poe direction v of prismatic joint {}", i + 1))?.into_inner();
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
