//! The small linear algebra of the IK steps: the rotation logarithm, the pose error as a twist, and the
//! damped (LM) and Newton steps of a 6 x n Jacobian.

use super::*;

/// SO(3) logarithm: the rotation vector (unit axis × angle in [0, π]) of a rotation matrix.
///
/// ```
/// use denavit_core::ik::log_rotation;
/// use nalgebra::{Rotation3, Vector3};
/// let w = Vector3::new(0.1, -0.2, 0.3);
/// assert!((log_rotation(Rotation3::new(w).matrix()) - w).norm() < 1e-15);
/// ```
pub fn log_rotation(r: &Matrix3<f64>) -> Vector3<f64> {
    log_with_angle(r, rotation_angle(&Rotation3::from_matrix_unchecked(*r)))
}

/// [`log_rotation`] given the angle `theta` of `r` (as computed by [`rotation_angle`]).
#[inline]
pub(super) fn log_with_angle(r: &Matrix3<f64>, theta: f64) -> Vector3<f64> {
    let v = Vector3::new(r[(2, 1)] - r[(1, 2)], r[(0, 2)] - r[(2, 0)], r[(1, 0)] - r[(0, 1)]); // 2 sin(t) axis
    let s = v.norm() / 2.0;
    let c = (r.trace() - 1.0) / 2.0;
    if c >= 0.0 || s > 1e-3 {
        if s == 0.0 {
            return Vector3::zeros();
        }
        return v * (theta / (2.0 * s));
    }
    // near pi: the axis from the symmetric part (R + R^T)/2 = c I + (1 - c) a a^T
    let d = [r[(0, 0)], r[(1, 1)], r[(2, 2)]];
    let i = if d[0] >= d[1] && d[0] >= d[2] {
        0
    } else if d[1] >= d[2] {
        1
    } else {
        2
    };
    let ai = ((d[i] - c) / (1.0 - c)).max(0.0).sqrt();
    let mut a = Vector3::zeros();
    for j in 0..3 {
        a[j] = if j == i { ai } else { (r[(i, j)] + r[(j, i)]) / (2.0 * (1.0 - c) * ai) };
    }
    let a = a.normalize();
    if a.dot(&v) < 0.0 { -a * theta } else { a * theta }
}

/// Error twist and measured errors of a current pose against the goal.
#[inline]
pub(super) fn twist(cur: &Pose, goal: &Pose, e: &mut [f64; 6]) -> (f64, f64) {
    let dp = goal.translation.vector - cur.translation.vector;
    let rel: Rotation3<f64> = cur.rotation.inverse() * goal.rotation; // as in spatial::pose_error
    let theta = rotation_angle(&rel);
    let w = cur.rotation * log_with_angle(rel.matrix(), theta);
    e[..3].copy_from_slice(dp.as_slice());
    e[3..].copy_from_slice(w.as_slice());
    ((cur.translation.vector - goal.translation.vector).norm(), theta)
}

/// Solve `a x = b` in place by nalgebra's Cholesky factorisation, `a` (n x n, symmetric positive definite,
/// so either storage order) taken from the workspace `work` without a copy and handed back; false if `a` is
/// not positive definite (the workspace is then reallocated: the rare, rejected step).
#[inline(always)]
pub(super) fn cholesky_solve(work: &mut Vec<f64>, b: &mut [f64], n: usize) -> bool {
    let mut v = std::mem::take(work);
    let len = v.len();
    v.truncate(n * n);
    let Some(c) = DMatrix::from_vec(n, n, v).cholesky() else {
        *work = vec![0.0; len];
        return false;
    };
    c.solve_mut(&mut DVectorViewMut::from_slice(&mut b[..n], n));
    *work = c.unpack_dirty().data.into();
    work.resize(len, 0.0);
    true
}

/// `A = J^T J + lambda I` (n x n, row-major) and `g = J^T e`; `jac` is column-major 6 x n.
#[inline(always)]
pub(super) fn normal_equations(jac: &[f64], e: &[f64; 6], lambda: f64, a: &mut [f64], g: &mut [f64], n: usize) {
    for i in 0..n {
        let ci = &jac[6 * i..6 * i + 6];
        g[i] = ci.iter().zip(e).map(|(x, y)| x * y).sum();
        for k in 0..=i {
            let ck = &jac[6 * k..6 * k + 6];
            let v: f64 = ci.iter().zip(ck).map(|(x, y)| x * y).sum();
            a[i * n + k] = v;
            a[k * n + i] = v;
        }
        a[i * n + i] += lambda;
    }
}

/// The damped Gauss-Newton step for a 6-joint chain: `(J^T J + lambda I) x = J^T e` by nalgebra's Cholesky
/// on the stack (`jac` column-major 6 x 6); false if the matrix is not positive definite.
#[inline(always)]
pub(super) fn lm_step6(jac: &[f64], e: &[f64; 6], lambda: f64, x: &mut [f64]) -> bool {
    let j = Matrix6::from_column_slice(jac);
    let mut a = j.tr_mul(&j);
    for i in 0..6 {
        a[(i, i)] += lambda;
    }
    let Some(c) = a.cholesky() else { return false };
    let mut g = j.tr_mul(&Vector6::from(*e));
    c.solve_mut(&mut g);
    x[..6].copy_from_slice(g.as_slice());
    true
}

/// Solve `J x = e` for a square 6 x 6 `J` (`jac` column-major) by Gaussian elimination with partial pivoting
/// (LU with row interchanges, Golub & Van Loan 2013, Algorithm 3.4.1, on the stack, fully unrolled: a third
/// of the time of nalgebra's generic LU here); false if a pivot is below 1e-13 times the largest entry of
/// `J` (numerically singular) or not finite.
#[inline(always)]
pub(super) fn newton_step6(jac: &[f64], e: &[f64; 6], x: &mut [f64]) -> bool {
    let mut a = [[0.0; 6]; 6]; // rows
    let mut scale: f64 = 0.0;
    for c in 0..6 {
        for r in 0..6 {
            let v = jac[6 * c + r];
            a[r][c] = v;
            scale = scale.max(v.abs());
        }
    }
    let tiny = 1e-13 * scale;
    let mut b = *e;
    for k in 0..6 {
        let mut p = k;
        for r in k + 1..6 {
            if a[r][k].abs() > a[p][k].abs() {
                p = r;
            }
        }
        let pivot = a[p][k].abs();
        if pivot.is_nan() || pivot <= tiny {
            return false;
        }
        if p != k {
            a.swap(k, p);
            b.swap(k, p);
        }
        let inv = 1.0 / a[k][k];
        for r in k + 1..6 {
            let f = a[r][k] * inv;
            for c in k + 1..6 {
                a[r][c] -= f * a[k][c];
            }
            b[r] -= f * b[k];
        }
    }
    for k in (0..6).rev() {
        let mut v = b[k];
        for c in k + 1..6 {
            v -= a[k][c] * x[c];
        }
        x[k] = v / a[k][k];
    }
    x[..6].iter().all(|v| v.is_finite())
}
