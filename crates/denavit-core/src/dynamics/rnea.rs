//! Recursive Newton-Euler inverse dynamics (Featherstone ch. 5, Table 5.1), bias forces and gravity torques.

use super::*;

#[inline]
pub(super) fn rnea_unchecked(
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
        let (n_e, f_e) = wrench_in_last_joint_frame(model, we);
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
    check_rates(qd, None)?;
    check_vec("qdd", model.nq(), qdd)?;
    check_gravity(gravity)?;
    check_wrench(f_ext)?;
    rnea_unchecked(model, ws, q, Some(qd), Some(qdd), gravity, f_ext);
    let w = f_ext.map_or(&[][..], |w| w.as_slice());
    check_result("tau", &ws.tau, joint_label, &[("q", q), ("qd", qd), ("qdd", qdd), ("gravity", gravity.as_slice()), ("f_ext", w)])?;
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
    check_rates(qd, None)?;
    check_gravity(gravity)?;
    rnea_unchecked(model, ws, q, Some(qd), None, gravity, None);
    check_result("bias forces", &ws.tau, joint_label, &[("q", q), ("qd", qd), ("gravity", gravity.as_slice())])?;
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
    check_result("gravity torques", &ws.tau, joint_label, &[("q", q), ("gravity", gravity.as_slice())])?;
    Ok(&ws.tau)
}
