//! Batch forms (rayon, row-major (N, n) slices), and inverse dynamics of several states at once in
//! structure-of-arrays lanes.

use super::*;
use crate::error::check_row;

pub(super) const CHUNK: usize = 256;

/// Number of rows of a row-major (N, n) batch, checking the other batches and the output.
pub(super) fn batch_rows(model: &Model, inputs: &[(&str, &[f64])], out_what: &str, out_per_row: usize, out_len: usize) -> Result<usize> {
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

/// External wrenches of a batch: none, one `[f; n]` for every row (6 values), or one per row (N*6).
pub(super) fn wrench_of(f_ext: Option<&[f64]>, count: usize) -> Result<Option<&[f64]>> {
    match f_ext {
        None => Ok(None),
        Some(w) if w.len() == 6 => {
            check_finite("external tool wrench [f; n]", w)?;
            Ok(Some(w))
        }
        // one per row: a non-finite value named by its row, as the joint values are
        Some(w) if w.len() == 6 * count => {
            crate::error::check_finite_rows("external tool wrenches [f; n]", w, 6)?;
            Ok(Some(w))
        }
        Some(w) => Err(Error::SizeMismatch { what: format!("external tool wrenches (6 or N*6 values, N = {count})"), expected: 6 * count, got: w.len() }),
    }
}

#[inline]
pub(super) fn wrench_row(w: Option<&[f64]>, row: usize) -> Option<Vector6<f64>> {
    w.map(|w| if w.len() == 6 { Vector6::from_row_slice(w) } else { Vector6::from_row_slice(&w[6 * row..6 * row + 6]) })
}

/// Run `f(ws, row, out_row)` over all rows in parallel, one workspace per thread.
pub(super) fn par_rows<F>(model: &Model, out: &mut [f64], per_row: usize, f: F) -> Result<()>
where
    F: Fn(&mut DynamicsData, usize, &mut [f64]) -> Result<()> + Sync + Send,
{
    if per_row == 0 {
        return Ok(());
    }
    crate::parallel::try_for_each_chunk_init(
        out,
        per_row * CHUNK,
        || DynamicsData::new(model),
        |ws, c, chunk| {
            for (k, o) in chunk.chunks_exact_mut(per_row).enumerate() {
                f(ws, c * CHUNK + k, o)?;
            }
            Ok(())
        },
    )
}

/// Number of states the batch inverse dynamics advances together (structure of arrays: every operation
/// runs on W lanes, which the compiler turns into SIMD; the shared model constants are loaded once).
pub(super) const LANES: usize = 4;

pub(super) type Lane = [f64; LANES];

/// A 3-vector per lane.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct V3l {
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
pub(super) enum Rot {
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
pub(super) fn placement_classes(model: &Model) -> Vec<(Rot, bool)> {
    model.joints().iter().map(|j| (Rot::of(j.placement.rotation.matrix()), j.placement.translation.vector == Vector3::zeros())).collect()
}

/// Per-thread storage of the lane kernel: per link the joint's cos/sin (revolute) or displacement
/// (prismatic), and the net force and moment of the link.
#[derive(Debug, Clone)]
pub(super) struct LaneData {
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
pub(super) fn rnea_lanes(
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

/// Row `r` of an optional (N, n) row-major input, or nothing.
fn row_of(v: Option<&[f64]>, r: usize, n: usize) -> &[f64] {
    v.map_or(&[][..], |v| &v[r * n..(r + 1) * n])
}

/// Batch inverse dynamics with the lane kernel: rows in groups of [`LANES`] (the last group padded by
/// repeating its last row), chunks of rows in parallel.
#[allow(clippy::too_many_arguments)]
pub(super) fn rnea_batch_lanes(
    model: &Model,
    count: usize,
    qs: &[f64],
    qds: Option<&[f64]>,
    qdds: Option<&[f64]>,
    g: &Vector3<f64>,
    f_ext: Option<&[f64]>,
    out: &mut [f64],
) -> Result<()> {
    let n = model.nq();
    if n == 0 || count == 0 {
        return Ok(());
    }
    let g_base = gravity_in_base(model, g);
    let classes = placement_classes(model);
    crate::parallel::try_for_each_chunk_init(
        out,
        n * CHUNK,
        || LaneData::new(n),
        |ld, c, chunk| {
            let start = c * CHUNK;
            let rows_here = chunk.len() / n;
            for r in start..start + rows_here {
                check_row("q", r, &qs[r * n..(r + 1) * n])?;
                if let Some(v) = qds {
                    check_row("qd", r, &v[r * n..(r + 1) * n])?;
                    check_rates(&v[r * n..(r + 1) * n], Some(r))?;
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
            for (i, o) in chunk.chunks_exact(n).enumerate() {
                if o.iter().all(|v| v.is_finite()) {
                    continue; // the common case: one pass, nothing built
                }
                let r = start + i;
                let we = f_ext.map_or(&[][..], |w| if w.len() == 6 { w } else { &w[r * 6..(r + 1) * 6] });
                let what = format!(
                    "{} (row {r})",
                    if qds.is_none() {
                        "gravity torques"
                    } else if qdds.is_none() {
                        "bias forces"
                    } else {
                        "tau"
                    }
                );
                let inputs = [("q", &qs[r * n..(r + 1) * n]), ("qd", row_of(qds, r, n)), ("qdd", row_of(qdds, r, n)), ("gravity", g.as_slice()), ("f_ext", we)];
                check_result(&what, o, joint_label, &inputs)?;
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

pub(super) fn copy_matrix_row_major(m: &DMatrix<f64>, o: &mut [f64]) {
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
        check_result(format_args!("the mass matrix (row {r})"), o, entry_label(n, true), &[("q", q)])
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
        check_rates(qd, Some(r))?;
        coriolis_unchecked(model, ws, q, qd);
        copy_matrix_row_major(&ws.coriolis, o);
        check_result(format_args!("the Coriolis matrix (row {r})"), o, entry_label(n, true), &[("q", q), ("qd", qd)])
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
pub fn forward_dynamics_batch(
    model: &Model,
    qs: &[f64],
    qds: &[f64],
    taus: &[f64],
    gravity: &Vector3<f64>,
    f_ext: Option<&[f64]>,
    out: &mut [f64],
) -> Result<()> {
    let n = model.nq();
    let count = batch_rows(model, &[("q", qs), ("qd", qds), ("tau", taus)], "output accelerations", n, out.len())?;
    check_gravity(gravity)?;
    let w = wrench_of(f_ext, count)?;
    par_rows(model, out, n, |ws, r, o| {
        let (q, qd, tau) = (&qs[r * n..(r + 1) * n], &qds[r * n..(r + 1) * n], &taus[r * n..(r + 1) * n]);
        check_row("q", r, q)?;
        check_row("qd", r, qd)?;
        check_rates(qd, Some(r))?;
        check_row("tau", r, tau)?;
        let we = wrench_row(w, r);
        aba_unchecked(model, ws, q, qd, tau, gravity, we.as_ref())?;
        o.copy_from_slice(&ws.qdd);
        let w = we.as_ref().map_or(&[][..], |w| w.as_slice());
        check_result(format_args!("qdd (row {r})"), o, joint_label, &[("q", q), ("qd", qd), ("tau", tau), ("gravity", gravity.as_slice()), ("f_ext", w)])
    })
}
