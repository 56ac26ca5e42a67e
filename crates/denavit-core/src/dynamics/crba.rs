//! The joint-space mass matrix by the composite rigid body algorithm (Featherstone ch. 6, Table 6.2) and the
//! Coriolis matrix.

use super::*;

#[inline]
pub(super) fn crba_unchecked(model: &Model, ws: &mut DynamicsData, q: &[f64]) {
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
    check_result("the mass matrix", ws.mass_matrix.as_slice(), entry_label(model.nq(), false), &[("q", q)])?;
    Ok(&ws.mass_matrix)
}

/// `C(q, qd)` with `Ṁ - 2C` skew-symmetric, from the world-frame form
/// `C = Σ_b J_bᵀ (I_b J̇_b + (v_b ×*) I_b J_b)` (Featherstone sec. 6.1 with eq. 2.67,
/// `d/dt I_b = v_b×* I_b - I_b v_b×`; the construction of Echeandia & Wensing, "A numerical method for
/// computing the Coriolis matrix", 2021). With `m = max(i, j)`:
/// `C_ij = S_iᵀ (IC_m Ṡ_j + BC_m S_j)`, `IC_m = Σ_{b>=m} I_b`, `BC_m = Σ_{b>=m} v_b×* I_b`, all in world.
#[inline]
pub(super) fn coriolis_unchecked(model: &Model, ws: &mut DynamicsData, q: &[f64], qd: &[f64]) {
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
    check_rates(qd, None)?;
    coriolis_unchecked(model, ws, q, qd);
    check_result("the Coriolis matrix", ws.coriolis.as_slice(), entry_label(model.nq(), false), &[("q", q), ("qd", qd)])?;
    Ok(&ws.coriolis)
}
