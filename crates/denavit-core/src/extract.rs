//! From joint axis lines to the parameters of every convention, by line geometry
//! (docs/conventions.md, "From axes to parameters"; Hayat et al. sec. II.B; Guo et al. sec. III.A).

use crate::axes::JointAxes;
use crate::convention::{Convention, Table};
use crate::error::{Error, Result, check_finite, check_len};
use crate::kinematics::fk_unchecked;
use crate::model::JointKind;
use crate::spatial::{Pose, any_perpendicular, perpendicular, pose_error, rx, signed_angle, wrap_angle};
use nalgebra::{DMatrix, Matrix3, Rotation3, Vector3};

/// The parallel-axis thresholds are properties of the joint axes, defined with them (re-exported here, where
/// the extractions use them).
pub use crate::axes::{EXACT_PARALLEL_SIN, NEAR_PARALLEL_SIN};

/// How two consecutive joint axes relate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Relation {
    /// Neither parallel nor intersecting: a unique common normal of non-zero length.
    Skew,
    /// They meet in a point (common normal shorter than `intersect_tol`).
    Intersecting,
    /// Parallel within `parallel_tol` (or their common normal's feet lie beyond `max_offset`).
    Parallel,
    /// Parallel and on the same line.
    Coincident,
}

impl Relation {
    /// Lower-case name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Skew => "skew",
            Self::Intersecting => "intersecting",
            Self::Parallel => "parallel",
            Self::Coincident => "coincident",
        }
    }
}

/// Options of the extraction (defaults in docs/conventions.md).
#[derive(Debug, Clone, PartialEq)]
pub struct ExtractOptions {
    /// Axes with `|z_i x z_{i+1}|` below this are parallel (default 1e-3).
    pub parallel_tol: f64,
    /// Axes whose common normal is shorter than this (metres) intersect (default 1e-9).
    pub intersect_tol: f64,
    /// Feet of a common normal farther than this from the axis points mean "parallel" (default: 2 x robot size).
    pub max_offset: Option<f64>,
    /// A table of the same convention whose frames break sign ties and fix the last frame.
    pub nominal: Option<Table>,
    /// ED-H frame origins, one point per axis (default: the axes' points). With a nominal as well, pairs parallel
    /// within `parallel_tol` take the nominal's x (docs/conventions.md).
    pub origins: Option<Vec<Vector3<f64>>>,
    /// Measure the table's tool error against the exact ED-H model of the axes over [`FIDELITY_SAMPLES`]
    /// configurations (default true); false skips it (the errors are then NaN): a cost paid only when asked.
    pub fidelity: bool,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        Self { parallel_tol: 1e-3, intersect_tol: 1e-9, max_offset: None, nominal: None, origins: None, fidelity: true }
    }
}

/// Geometry of one pair of consecutive axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PairDiagnostic {
    /// 1-based index of the first axis of the pair (pair i, i+1).
    pub joint: usize,
    /// How the axes relate.
    pub relation: Relation,
    /// Angle between the axis directions (rad, 0..pi).
    pub angle: f64,
    /// Common-normal length, or the distance between parallel lines (m).
    pub distance: f64,
    /// Hayati-style misalignment the table cannot represent (rotation about y, rad); 0 when exact.
    pub hayati_beta: f64,
}

/// The result of an extraction: the table and what it can and cannot represent.
#[derive(Debug, Clone, PartialEq)]
pub struct Extraction {
    /// The parameter table.
    pub table: Table,
    /// One entry per consecutive pair of axes.
    pub pairs: Vec<PairDiagnostic>,
    /// Largest tool-position error (m) of the table's model against the axes, over `q_ref` and
    /// [`FIDELITY_SAMPLES`] deterministic configurations within the limits ([`sample_configurations`]).
    pub max_position_error: f64,
    /// Largest tool-rotation error (rad), same configurations.
    pub max_rotation_error: f64,
}

struct PairGeom {
    relation: Relation,
    angle: f64,
    distance: f64,
    foot0: Vector3<f64>,
    foot1: Vector3<f64>,
}

fn analyze(p0: &Vector3<f64>, z0: &Vector3<f64>, p1: &Vector3<f64>, z1: &Vector3<f64>, opt: &ExtractOptions, max_offset: f64) -> PairGeom {
    let c = normal_direction(z0, z1);
    let s = c.norm();
    let angle = s.atan2(z0.dot(z1));
    let w = p1 - p0;
    if s > opt.parallel_tol {
        // closest points by cross products (no 1 - cos^2 cancellation for small angles)
        let den = s * s;
        let t0 = w.cross(z1).dot(&c) / den;
        let t1 = w.cross(z0).dot(&c) / den;
        if (t0.abs() <= max_offset && t1.abs() <= max_offset) || s >= NEAR_PARALLEL_SIN {
            let foot0 = p0 + z0 * t0;
            let foot1 = p1 + z1 * t1;
            let distance = (foot1 - foot0).norm();
            let relation = if distance < opt.intersect_tol { Relation::Intersecting } else { Relation::Skew };
            return PairGeom { relation, angle, distance, foot0, foot1 };
        }
    }
    let perp = w - z0 * z0.dot(&w);
    let distance = perp.norm();
    let relation = if distance < opt.intersect_tol { Relation::Coincident } else { Relation::Parallel };
    PairGeom { relation, angle, distance, foot0: *p0, foot1: *p1 }
}

/// `z0 x z1` computed as `z0 x (z1 - z0)`: the difference of nearly parallel unit vectors is exact, so the
/// result stays perpendicular to both to round-off relative to its own (small) length.
fn normal_direction(z0: &Vector3<f64>, z1: &Vector3<f64>) -> Vector3<f64> {
    z0.cross(&(z1 - z0))
}

/// Projection of `x` onto the line (p, z).
fn project(x: &Vector3<f64>, p: &Vector3<f64>, z: &Vector3<f64>) -> Vector3<f64> {
    p + z * z.dot(&(x - p))
}

/// `x` or `-x`: closer to the nominal x if given, else pointing along `toward` (when that is not negligible).
fn orient(x: Vector3<f64>, nominal: Option<&Vector3<f64>>, toward: &Vector3<f64>, tol: f64) -> Vector3<f64> {
    let flip = match nominal {
        Some(r) => x.dot(r) < 0.0,
        None => x.dot(toward) < -tol,
    };
    if flip { -x } else { x }
}

/// For axes that meet, `x` or `-x` (both are common normals): the one that keeps the joint's table angle
/// within +-90 degrees, i.e. closer to `prev`, the previous frame's x turned about `z` by the joint's reference
/// value (a revolute joint's; zero for a prismatic one), so that a table read back from its own axes (a DH
/// table written as URDF and read again) keeps its signs.
fn smaller_angle(x: Vector3<f64>, prev: &Vector3<f64>, z: &Vector3<f64>, kind: JointKind, q_ref: f64) -> Vector3<f64> {
    let turn = if kind == JointKind::Revolute { q_ref } else { 0.0 };
    let r = Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(*z), turn);
    if x.dot(&(r * prev)) < -1e-9 { -x } else { x }
}

/// An orthonormal frame with the given origin and x axis, and z as close as possible to `z` (the part of
/// `z` along x, the Hayati tilt, is dropped and returned as the angle beta).
fn frame(origin: &Vector3<f64>, x: &Vector3<f64>, z: &Vector3<f64>) -> (Pose, f64) {
    let zp = z - x * x.dot(z);
    let zu = match zp.try_normalize(1e-300) {
        Some(v) => v,
        None => any_perpendicular(x),
    };
    let beta = x.dot(z).atan2(zu.dot(z));
    let y = zu.cross(x);
    let r = Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[*x, y, zu]));
    (Pose::from_parts((*origin).into(), r), beta)
}

fn col(t: &Pose, k: usize) -> Vector3<f64> {
    t.rotation.matrix().column(k).into_owned()
}

/// Extract the parameter table of `convention` from joint axes (docs/conventions.md).
///
/// ```
/// use denavit_core::{builtin_planar2, axes::axes, extract::{extract, ExtractOptions}, Convention};
/// let m = builtin_planar2(1.0, 0.5);
/// let ex = extract(&axes(&m, &[0.0, 0.0]).unwrap(), Convention::Dh, &ExtractOptions::default()).unwrap();
/// assert!((ex.table.params[(0, 2)] - 1.0).abs() < 1e-12); // a1 = 1 m
/// assert!(ex.max_position_error < 1e-12);
/// ```
pub fn extract(ax: &JointAxes, convention: Convention, opt: &ExtractOptions) -> Result<Extraction> {
    let n = ax.nq();
    check_options(ax, convention, opt)?;
    let base_origin = ax.t_world_base.translation.vector;
    let tool_origin = ax.t_world_tool.translation.vector;
    let size = ax.points.iter().chain(std::iter::once(&tool_origin)).map(|p| (p - base_origin).norm()).fold(0.0_f64, f64::max);
    let max_offset = opt.max_offset.unwrap_or(2.0 * size + 1e-3);
    let (p, z) = (&ax.points, &ax.directions);
    let geoms: Vec<PairGeom> = (0..n.saturating_sub(1)).map(|k| analyze(&p[k], &z[k], &p[k + 1], &z[k + 1], opt, max_offset)).collect();
    let nominal_frames = match &opt.nominal {
        Some(t) => Some(t.frames(&ax.q_ref)?),
        None => None,
    };
    let steps = FrameSteps { ax, opt, geoms: &geoms, nominal_frames: nominal_frames.as_deref() };
    let mut betas = vec![0.0; n.saturating_sub(1)];

    let table = match convention {
        Convention::Poe => poe_from_axes(ax, opt)?,
        _ if n == 0 => {
            Table::new(convention, DMatrix::zeros(0, convention.columns().len()), vec![], ax.t_world_base, ax.t_world_base.inverse() * ax.t_world_tool)?
        }
        Convention::Mdh => {
            let frames = steps.mdh_frames(&mut betas);
            Table::new(convention, mdh_params(ax, &frames), ax.kinds.clone(), frames[0], frames[n].inverse() * ax.t_world_tool)?
        }
        Convention::Dh => {
            let frames = steps.dh_frames(&mut betas);
            Table::new(convention, dh_params(ax, &frames), ax.kinds.clone(), frames[0], frames[n].inverse() * ax.t_world_tool)?
        }
        Convention::Edh => edh_from_axes(ax, opt, &geoms, nominal_frames.as_deref())?,
    };

    let pairs = geoms
        .iter()
        .enumerate()
        .map(|(k, g)| PairDiagnostic {
            joint: k + 1,
            relation: g.relation,
            angle: g.angle,
            distance: g.distance,
            hayati_beta: if matches!(convention, Convention::Dh | Convention::Mdh) { betas[k] } else { 0.0 },
        })
        .collect();
    let (max_position_error, max_rotation_error) = if opt.fidelity { fidelity(ax, &table, opt)? } else { (f64::NAN, f64::NAN) };
    Ok(Extraction { table, pairs, max_position_error, max_rotation_error })
}

/// The options checked against the axes and the convention: tolerances >= 0, `parallel_tol` the sine of an
/// angle, a nominal of the same convention and joint count, one finite ED-H origin per axis.
fn check_options(ax: &JointAxes, convention: Convention, opt: &ExtractOptions) -> Result<()> {
    let n = ax.nq();
    for (what, v) in [("parallel_tol", Some(opt.parallel_tol)), ("intersect_tol", Some(opt.intersect_tol)), ("max_offset", opt.max_offset)] {
        if let Some(v) = v.filter(|v| v.is_nan() || *v < 0.0) {
            return Err(Error::InvalidArgument { what: what.into(), expected: "a value >= 0".into(), got: v.to_string() });
        }
    }
    if opt.parallel_tol >= 1.0 {
        // |z_i x z_i+1| is at most 1: every pair would be "parallel"
        return Err(Error::InvalidArgument {
            what: "parallel_tol".into(),
            expected: "the sine of an angle, below 1".into(),
            got: opt.parallel_tol.to_string(),
        });
    }
    if let Some(nom) = &opt.nominal {
        check_len("joints of the nominal table", n, nom.nq())?;
        if nom.convention != convention {
            return Err(crate::Error::InvalidArgument {
                what: "nominal table".into(),
                expected: format!("a {} table", convention.name()),
                got: format!("a {} table", nom.convention.name()),
            });
        }
    }
    if let Some(o) = &opt.origins {
        check_len("ED-H origins (one per axis)", n, o.len())?;
        for (i, p) in o.iter().enumerate() {
            check_finite(&format!("ED-H origin {}", i + 1), p.as_slice())?;
        }
    }
    Ok(())
}

/// The part of `v` perpendicular to `z`, else of `fallback`, else any perpendicular (unit).
fn perp_or(v: &Vector3<f64>, fallback: &Vector3<f64>, z: &Vector3<f64>) -> Vector3<f64> {
    perpendicular(v, z).or_else(|| perpendicular(fallback, z)).unwrap_or_else(|| any_perpendicular(z))
}

/// What the DH and MDH frame constructions share: the axes, the options, the geometry of each pair of
/// consecutive axes and the nominal's frames at `q_ref` (which break sign ties).
struct FrameSteps<'a> {
    ax: &'a JointAxes,
    opt: &'a ExtractOptions,
    geoms: &'a [PairGeom],
    nominal_frames: Option<&'a [Pose]>,
}

impl FrameSteps<'_> {
    /// The nominal's frame k's x axis.
    fn nom_x(&self, k: usize) -> Option<Vector3<f64>> {
        self.nominal_frames.map(|f| col(&f[k], 0))
    }

    /// Offset along the axis the nominal table gives to an otherwise free origin (row k, column `column`),
    /// with the joint's reference value added for prismatic joints.
    fn nominal_d(&self, k: usize, column: usize) -> f64 {
        let ax = self.ax;
        self.opt.nominal.as_ref().map_or(0.0, |t| t.params[(k, column)] + if ax.kinds[k] == JointKind::Prismatic { ax.q_ref[k] } else { 0.0 })
    }

    /// The first frame, on axis 1 (both DH and MDH): its origin the base origin's foot on the axis, its x the
    /// nominal's (else the base's) made perpendicular to the axis.
    fn first_frame(&self) -> Pose {
        let (ax, z) = (self.ax, &self.ax.directions);
        let (base_x, base_y) = (col(&ax.t_world_base, 0), col(&ax.t_world_base, 1));
        let x0 = perp_or(&self.nom_x(0).unwrap_or(base_x), &base_y, &z[0]);
        frame(&project(&ax.t_world_base.translation.vector, &ax.points[0], &z[0]), &x0, &z[0]).0
    }

    /// MDH frames F_0..F_n; F_k (k >= 1) on axis k. Writes each pair's Hayati tilt into `betas`.
    fn mdh_frames(&self, betas: &mut [f64]) -> Vec<Pose> {
        let (ax, opt, tol) = (self.ax, self.opt, self.opt.intersect_tol);
        let (n, p, z) = (ax.nq(), &ax.points, &ax.directions);
        let base_x = col(&ax.t_world_base, 0);
        let (tool_x, tool_y) = (col(&ax.t_world_tool, 0), col(&ax.t_world_tool, 1));
        let mut frames = vec![self.first_frame()];
        for k in 0..n {
            let prev = frames[k];
            let h = project(&prev.translation.vector, &p[k], &z[k]);
            let (o, x) = if k + 1 < n {
                let g = &self.geoms[k];
                match g.relation {
                    Relation::Intersecting if opt.nominal.is_none() => {
                        let x = normal_direction(&z[k], &z[k + 1]).normalize();
                        (g.foot0, smaller_angle(x, &col(&prev, 0), &z[k], ax.kinds[k], ax.q_ref[k]))
                    }
                    Relation::Skew | Relation::Intersecting => {
                        let x = normal_direction(&z[k], &z[k + 1]).normalize();
                        (g.foot0, orient(x, self.nom_x(k + 1).as_ref(), &(g.foot1 - g.foot0), tol))
                    }
                    Relation::Parallel => {
                        let o = h + z[k] * self.nominal_d(k, 3);
                        let x = perp_or(&(p[k + 1] - o), &col(&prev, 0), &z[k]);
                        (o, orient(x, self.nom_x(k + 1).as_ref(), &(p[k + 1] - o), tol))
                    }
                    Relation::Coincident => {
                        (h + z[k] * self.nominal_d(k, 3), orient(perp_or(&col(&prev, 0), &base_x, &z[k]), self.nom_x(k + 1).as_ref(), &Vector3::zeros(), tol))
                    }
                }
            } else {
                let d_last = opt.nominal.as_ref().map_or(0.0, |t| t.params[(n - 1, 3)]);
                let d_last = if ax.kinds[k] == JointKind::Prismatic { d_last + ax.q_ref[k] } else { d_last };
                (h + z[k] * d_last, perp_or(&self.nom_x(n).unwrap_or(tool_x), &tool_y, &z[k]))
            };
            let (f, _) = frame(&o, &x, &z[k]);
            if k + 1 < n {
                betas[k] = x.dot(&z[k + 1]).asin();
            }
            frames.push(f);
        }
        frames
    }

    /// DH frames D_0..D_n; D_{k-1} has z along axis k; D_n along axis n. Writes each pair's Hayati tilt into
    /// `betas`.
    fn dh_frames(&self, betas: &mut [f64]) -> Vec<Pose> {
        let (ax, opt, tol) = (self.ax, self.opt, self.opt.intersect_tol);
        let (n, p, z) = (ax.nq(), &ax.points, &ax.directions);
        let base_x = col(&ax.t_world_base, 0);
        let (tool_x, tool_y) = (col(&ax.t_world_tool, 0), col(&ax.t_world_tool, 1));
        let mut frames = vec![self.first_frame()];
        for k in 1..=n {
            let prev = frames[k - 1];
            let (op, xp, zp) = (prev.translation.vector, col(&prev, 0), col(&prev, 2));
            let (o, x, zt) = if k < n {
                let g = &self.geoms[k - 1];
                match g.relation {
                    Relation::Intersecting if opt.nominal.is_none() => {
                        let x = normal_direction(&z[k - 1], &z[k]).normalize();
                        (g.foot1, smaller_angle(x, &xp, &zp, ax.kinds[k - 1], ax.q_ref[k - 1]), z[k])
                    }
                    Relation::Skew | Relation::Intersecting => {
                        let x = normal_direction(&z[k - 1], &z[k]).normalize();
                        (g.foot1, orient(x, self.nom_x(k).as_ref(), &(g.foot1 - g.foot0), tol), z[k])
                    }
                    Relation::Parallel => {
                        let on = op + zp * self.nominal_d(k - 1, 0);
                        let o = project(&on, &p[k], &z[k]);
                        let x = perp_or(&(o - on), &xp, &zp);
                        (o, orient(x, self.nom_x(k).as_ref(), &(o - on), tol), z[k])
                    }
                    Relation::Coincident => {
                        let o = project(&(op + zp * self.nominal_d(k - 1, 0)), &p[k], &z[k]);
                        (o, orient(perp_or(&xp, &base_x, &zp), self.nom_x(k).as_ref(), &Vector3::zeros(), tol), z[k])
                    }
                }
            } else {
                let (d_n, a_n, alpha_n) = opt.nominal.as_ref().map_or((0.0, 0.0, 0.0), |t| (t.params[(n - 1, 0)], t.params[(n - 1, 2)], t.params[(n - 1, 3)]));
                let d_n = if ax.kinds[n - 1] == JointKind::Prismatic { d_n + ax.q_ref[n - 1] } else { d_n };
                let x = perp_or(&self.nom_x(n).unwrap_or(tool_x), &tool_y, &zp);
                let y = zp.cross(&x);
                (op + zp * d_n + x * a_n, x, zp * alpha_n.cos() - y * alpha_n.sin())
            };
            let (f, beta) = frame(&o, &x, &zt);
            if k < n {
                betas[k - 1] = beta;
            }
            frames.push(f);
        }
        frames
    }
}

/// The MDH rows (alpha, a, theta, d) between consecutive frames F_0..F_n, less the joints' reference values.
fn mdh_params(ax: &JointAxes, frames: &[Pose]) -> DMatrix<f64> {
    let n = ax.nq();
    let mut params = DMatrix::zeros(n, 4);
    for k in 1..=n {
        let (fp, fc) = (&frames[k - 1], &frames[k]);
        let (xp, zp, xc, zc) = (col(fp, 0), col(fp, 2), col(fc, 0), col(fc, 2));
        let delta = fc.translation.vector - fp.translation.vector;
        let alpha = zp.cross(&zc).dot(&xp).atan2(zp.dot(&zc));
        let theta = signed_angle(&xp, &xc, &zc);
        let (mut th, mut d) = (theta, delta.dot(&zc));
        match ax.kinds[k - 1] {
            JointKind::Revolute => th = wrap_angle(theta - ax.q_ref[k - 1]),
            JointKind::Prismatic => d -= ax.q_ref[k - 1],
        }
        params.set_row(k - 1, &nalgebra::RowVector4::new(alpha, delta.dot(&xp), th, d).columns(0, 4));
    }
    params
}

/// The DH rows (d, theta, a, alpha) between consecutive frames D_0..D_n, less the joints' reference values.
fn dh_params(ax: &JointAxes, frames: &[Pose]) -> DMatrix<f64> {
    let n = ax.nq();
    let mut params = DMatrix::zeros(n, 4);
    for k in 1..=n {
        let (fp, fc) = (&frames[k - 1], &frames[k]);
        let (xp, zp, xc, zc) = (col(fp, 0), col(fp, 2), col(fc, 0), col(fc, 2));
        let delta = fc.translation.vector - fp.translation.vector;
        let theta = signed_angle(&xp, &xc, &zp);
        let alpha = zp.cross(&zc).dot(&xc).atan2(zp.dot(&zc));
        let (mut th, mut d) = (theta, delta.dot(&zp));
        match ax.kinds[k - 1] {
            JointKind::Revolute => th = wrap_angle(theta - ax.q_ref[k - 1]),
            JointKind::Prismatic => d -= ax.q_ref[k - 1],
        }
        params.set_row(k - 1, &nalgebra::RowVector4::new(d, th, delta.dot(&xc), alpha).columns(0, 4));
    }
    params
}

fn edh_from_axes(ax: &JointAxes, opt: &ExtractOptions, geoms: &[PairGeom], nominal_frames: Option<&[Pose]>) -> Result<Table> {
    let n = ax.nq();
    if n == 0 {
        return Table::new(Convention::Edh, DMatrix::zeros(0, 5), vec![], ax.t_world_base, ax.t_world_base.inverse() * ax.t_world_tool);
    }
    let (p, z) = (&ax.points, &ax.directions);
    let nom_x = |k: usize| nominal_frames.map(|f| col(&f[k], 0));
    let origins: Vec<Vector3<f64>> = (0..n).map(|k| project(opt.origins.as_ref().map_or(&p[k], |o| &o[k]), &p[k], &z[k])).collect();
    let base_origin = ax.t_world_base.translation.vector;
    let (base_x, base_y) = (col(&ax.t_world_base, 0), col(&ax.t_world_base, 1));
    let (tool_x, tool_y) = (col(&ax.t_world_tool, 0), col(&ax.t_world_tool, 1));
    let x0 = perp_or(&nom_x(0).unwrap_or(base_x), &base_y, &z[0]);
    let mut frames = vec![frame(&base_origin, &x0, &z[0]).0];
    for k in 0..n {
        let x = if k + 1 < n {
            let c = normal_direction(&z[k], &z[k + 1]);
            let toward = origins[k + 1] - origins[k];
            let nominal_x = nom_x(k + 1).filter(|_| opt.origins.is_some() && c.norm() <= opt.parallel_tol).and_then(|v| perpendicular(&v, &z[k]));
            if let Some(xn) = nominal_x {
                // against a nominal with its on-body origins (Guo et al.: identified axes, the nominal's frames),
                // a pair parallel within parallel_tol takes the nominal's x (the common normal of a pair parallel
                // within its noise follows the noise); the tilt, below parallel_tol, is dropped (the table's tool
                // error says how much). Without origins ED-H stays exact.
                xn
            } else if c.norm() > EXACT_PARALLEL_SIN {
                orient(c.normalize(), nom_x(k + 1).as_ref(), &toward, opt.intersect_tol)
            } else if geoms[k].relation == Relation::Coincident {
                orient(perp_or(&col(&frames[k], 0), &base_x, &z[k]), nom_x(k + 1).as_ref(), &Vector3::zeros(), opt.intersect_tol)
            } else {
                orient(perp_or(&toward, &col(&frames[k], 0), &z[k]), nom_x(k + 1).as_ref(), &toward, opt.intersect_tol)
            }
        } else {
            perp_or(&nom_x(n).unwrap_or(tool_x), &tool_y, &z[k])
        };
        frames.push(frame(&origins[k], &x, &z[k]).0);
    }
    let mut params = DMatrix::zeros(n, 5);
    for k in 1..=n {
        let (fp, fc) = (&frames[k - 1], &frames[k]);
        let (xp, zp, xc, zc) = (col(fp, 0), col(fp, 2), col(fc, 0), col(fc, 2));
        let alpha = zp.cross(&zc).dot(&xp).atan2(zp.dot(&zc));
        let r2 = fp.rotation * rx(alpha).rotation;
        let abc = r2.inverse() * (fc.translation.vector - fp.translation.vector);
        let theta = signed_angle(&xp, &xc, &zc);
        let (mut th, mut c) = (theta, abc.z);
        match ax.kinds[k - 1] {
            JointKind::Revolute => th = wrap_angle(theta - ax.q_ref[k - 1]),
            JointKind::Prismatic => c -= ax.q_ref[k - 1],
        }
        params.set_row(k - 1, &nalgebra::RowDVector::from_row_slice(&[alpha, abc.x, abc.y, c, th]));
    }
    Table::new(Convention::Edh, params, ax.kinds.clone(), frames[0], frames[n].inverse() * ax.t_world_tool)
}

/// POE at q = 0: through the exact ED-H model of the axes (docs/conventions.md).
fn poe_from_axes(ax: &JointAxes, opt: &ExtractOptions) -> Result<Table> {
    let plain = ExtractOptions { nominal: None, ..opt.clone() };
    let geoms: Vec<PairGeom> = (0..ax.nq().saturating_sub(1))
        .map(|k| analyze(&ax.points[k], &ax.directions[k], &ax.points[k + 1], &ax.directions[k + 1], &plain, f64::INFINITY))
        .collect();
    let model = edh_from_axes(ax, &plain, &geoms, None)?.to_model("edh")?;
    let home = crate::axes::axes(&model, &vec![0.0; ax.nq()])?;
    let b_inv = ax.t_world_base.inverse();
    let mut params = DMatrix::zeros(ax.nq(), 6);
    for k in 0..ax.nq() {
        let zb = b_inv.rotation * home.directions[k];
        let pb = b_inv * nalgebra::Point3::from(home.points[k]);
        let row = match ax.kinds[k] {
            JointKind::Revolute => {
                let v = -zb.cross(&pb.coords);
                [zb.x, zb.y, zb.z, v.x, v.y, v.z]
            }
            JointKind::Prismatic => [0.0, 0.0, 0.0, zb.x, zb.y, zb.z],
        };
        params.set_row(k, &nalgebra::RowDVector::from_row_slice(&row));
    }
    Table::new(Convention::Poe, params, ax.kinds.clone(), ax.t_world_base, b_inv * home.t_world_tool)
}

/// How many configurations (besides `q_ref`) the tool-error report of an extraction samples.
pub const FIDELITY_SAMPLES: usize = 256;

/// Deterministic configurations within the limits (a Halton sequence; infinite limits clamp to +-pi or +-1 m).
pub fn sample_configurations(lower: &[f64], upper: &[f64], count: usize) -> Vec<Vec<f64>> {
    const PRIMES: [u32; 16] = [2, 3, 5, 7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43, 47, 53];
    (1..=count)
        .map(|i| {
            lower
                .iter()
                .zip(upper)
                .enumerate()
                .map(|(j, (&lo, &hi))| {
                    let (lo, hi) = (lo.max(-std::f64::consts::PI * 4.0), hi.min(std::f64::consts::PI * 4.0));
                    let base = PRIMES[j % PRIMES.len()] as f64;
                    let (mut f, mut r, mut k) = (1.0, 0.0, i as f64 + (j / PRIMES.len()) as f64 * 7.0);
                    while k > 0.0 {
                        f /= base;
                        r += f * (k % base);
                        k = (k / base).floor();
                    }
                    lo + (hi - lo) * r
                })
                .collect()
        })
        .collect()
}

/// Max tool error of the table's model against the axes (at `q_ref`) and against the exact ED-H model of
/// the axes (over the sampled configurations).
fn fidelity(ax: &JointAxes, table: &Table, opt: &ExtractOptions) -> Result<(f64, f64)> {
    let model = table.to_model("candidate")?;
    let at_ref = pose_error(&fk_unchecked(&model, &ax.q_ref), &ax.t_world_tool);
    let (mut ep, mut er) = at_ref;
    // every convention, ED-H too: against a nominal with on-body origins, ED-H drops a near-parallel pair's
    // tilt (below parallel_tol), and the error that leaves away from q_ref is the one to report
    let plain = ExtractOptions { nominal: None, ..opt.clone() };
    let geoms: Vec<PairGeom> = (0..ax.nq().saturating_sub(1))
        .map(|k| analyze(&ax.points[k], &ax.directions[k], &ax.points[k + 1], &ax.directions[k + 1], &plain, f64::INFINITY))
        .collect();
    let exact = edh_from_axes(ax, &plain, &geoms, None)?.to_model("exact")?;
    for q in sample_configurations(&ax.lower, &ax.upper, FIDELITY_SAMPLES) {
        let (p, r) = pose_error(&fk_unchecked(&model, &q), &fk_unchecked(&exact, &q));
        ep = ep.max(p);
        er = er.max(r);
    }
    Ok((ep, er))
}

/// Convert a table to another convention through its axes at q = 0, with the FK-parity check of the result.
pub fn convert(table: &Table, to: Convention, opt: &ExtractOptions) -> Result<Extraction> {
    let model = table.to_model("source")?;
    let ax = crate::axes::axes(&model, &vec![0.0; model.nq()])?;
    extract(&ax, to, opt)
}
