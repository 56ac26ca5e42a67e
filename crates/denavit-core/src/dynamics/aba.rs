//! Forward dynamics: the articulated body algorithm (Featherstone ch. 7, Table 7.1) and the Cholesky solve
//! with the mass matrix.

use super::*;

#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn aba_unchecked(
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
        let (n_e, f_e) = wrench_in_last_joint_frame(model, we);
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
    check_fd_result(ws, q, qd, tau, gravity, f_ext)?;
    Ok(&ws.qdd)
}

/// The accelerations of a forward dynamics call finite, or [`Error::Overflow`] naming the input to blame.
pub(super) fn check_fd_result(ws: &DynamicsData, q: &[f64], qd: &[f64], tau: &[f64], g: &Vector3<f64>, f_ext: Option<&Vector6<f64>>) -> Result<()> {
    let w = f_ext.map_or(&[][..], |w| w.as_slice());
    check_result("qdd", &ws.qdd, joint_label, &[("q", q), ("qd", qd), ("tau", tau), ("gravity", g.as_slice()), ("f_ext", w)])
}

pub(super) fn check_fd_args(
    model: &Model,
    ws: &DynamicsData,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    g: &Vector3<f64>,
    f_ext: Option<&Vector6<f64>>,
) -> Result<()> {
    ws.check(model)?;
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    check_rates(qd, None)?;
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
    check_fd_result(ws, q, qd, tau, gravity, f_ext)?;
    Ok(&ws.qdd)
}

pub(super) fn fd_crba_unchecked(
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
