//! Rigid transforms: the elementary factors of docs/conventions.md and checked conversion from 4x4 matrices.

use crate::error::{Error, Result, check_finite};
use nalgebra::{Matrix3, Matrix4, Rotation3, Translation3, Unit, Vector3};

/// A rigid transform `T_a_b` (rotation matrix + translation).
pub type Pose = nalgebra::IsometryMatrix3<f64>;

/// `Rx(t)`: rotation about the local x axis.
pub fn rx(t: f64) -> Pose {
    let (s, c) = sin_cos_turns(t);
    rotation(Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c))
}
/// `Ry(t)`: rotation about the local y axis.
pub fn ry(t: f64) -> Pose {
    let (s, c) = sin_cos_turns(t);
    rotation(Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c))
}
/// `Rz(t)`: rotation about the local z axis.
pub fn rz(t: f64) -> Pose {
    let (s, c) = sin_cos_turns(t);
    rotation(Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0))
}

fn rotation(r: Matrix3<f64>) -> Pose {
    Pose::from_parts(Translation3::identity(), Rotation3::from_matrix_unchecked(r))
}

/// `(sin t, cos t)` of a constant angle of a model (a table's alpha, theta offset, a base or tool
/// rotation), exact at the quarter turns: an angle within 4 ulp of a nonzero multiple of 90 deg up to 720
/// deg (`-90 deg` read from a table and converted to radians) is that multiple, its sine and cosine exactly
/// 0 and ±1, as the table means (`f64::sin_cos` gives 6.1e-17 for the cosine of the double nearest pi/2).
/// docs/conventions.md, "Quarter turns". Elsewhere `f64::sin_cos`.
///
/// ```
/// use denavit_core::spatial::sin_cos_turns;
/// assert_eq!(sin_cos_turns(-90f64.to_radians()), (-1.0, 0.0));
/// assert_eq!(sin_cos_turns(std::f64::consts::PI), (0.0, -1.0));
/// assert_eq!(sin_cos_turns(270f64.to_radians()), (-1.0, 0.0));
/// assert_eq!(sin_cos_turns(0.3), 0.3f64.sin_cos());
/// assert_eq!(sin_cos_turns(1.5708), 1.5708f64.sin_cos()); // not a quarter turn: 3.7e-6 rad off
/// ```
pub fn sin_cos_turns(t: f64) -> (f64, f64) {
    let k = (t / std::f64::consts::FRAC_PI_2).round();
    if k != 0.0 && k.abs() <= 8.0 && (t - k * std::f64::consts::FRAC_PI_2).abs() <= 4.0 * f64::EPSILON * t.abs() {
        // k mod 4 (k is an integer of at most 8 in magnitude)
        return match (k as i64).rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        };
    }
    t.sin_cos()
}
/// `Trans(a, b, c)`: translation along the local axes.
pub fn trans(a: f64, b: f64, c: f64) -> Pose {
    Pose::from_parts(Translation3::new(a, b, c), Rotation3::identity())
}

/// The one tolerance of a rigid transform given by a user (a 4x4 matrix, an IK goal, a model's fixed
/// poses): `max |R^T R - I| <= SE3_TOL` and `|det R - 1| <= SE3_TOL` (docs/conventions.md, "Rigid
/// transforms"). Files carry 6 to 17 significant digits, so 1e-9 accepts every honest matrix and rejects
/// scaled or sheared ones.
pub const SE3_TOL: f64 = 1e-9;

/// Below this `|R^T R - I|` and `|det R - 1|` a rotation is orthonormal to rounding and is used as given;
/// above it (and within [`SE3_TOL`]) it is replaced by the nearest rotation, so round-off in a file does
/// not accumulate. Not an acceptance tolerance: it only decides whether the SVD is worth its cost.
const ROUNDING: f64 = 1e-14;

/// Check that `r` is a rotation matrix within [`SE3_TOL`] (values assumed finite) and return it,
/// re-orthonormalised when it is not orthonormal to rounding.
fn checked_rotation(r: &Matrix3<f64>, what: &str) -> Result<Rotation3<f64>> {
    let orth = (r.transpose() * r - Matrix3::identity()).amax();
    let det = r.determinant();
    if orth <= ROUNDING && (det - 1.0).abs() <= ROUNDING {
        return Ok(Rotation3::from_matrix_unchecked(*r));
    }
    if orth > SE3_TOL || (det - 1.0).abs() > SE3_TOL || orth.is_nan() {
        return Err(Error::NotSe3 {
            what: what.to_string(),
            reason: format!("rotation part must be orthonormal with det +1 (tolerance {SE3_TOL:e}), got |R^T R - I| = {orth:.3e}, det = {det:.6}"),
        });
    }
    Ok(nearest_rotation(r))
}

/// Convert a 4x4 homogeneous matrix to a [`Pose`], checking that it is a rigid transform: finite, last
/// row `[0, 0, 0, 1]`, rotation within [`SE3_TOL`] (re-orthonormalised by SVD unless orthonormal to
/// rounding). The one check of every 4x4 accepted as SE(3).
///
/// ```
/// use denavit_core::spatial::{pose_from_matrix, rz};
/// let m = rz(0.3).to_homogeneous();
/// assert_eq!(pose_from_matrix(&m, "tool").unwrap().to_homogeneous(), m);
/// let mut bad = m; bad[(0, 0)] = 2.0;
/// assert!(pose_from_matrix(&bad, "tool").is_err());
/// ```
pub fn pose_from_matrix(m: &Matrix4<f64>, what: &str) -> Result<Pose> {
    // row-major, as numpy holds it: the element is named [row, column], the index is the one of T.ravel()
    for (k, v) in m.transpose().iter().enumerate() {
        if !v.is_finite() {
            return Err(Error::NonFinite { what: format!("{what}[{}, {}]", k / 4, k % 4), index: k, value: *v });
        }
    }
    let bottom = [m[(3, 0)], m[(3, 1)], m[(3, 2)], m[(3, 3)]];
    if bottom != [0.0, 0.0, 0.0, 1.0] {
        return Err(Error::NotSe3 { what: what.to_string(), reason: format!("last row must be [0, 0, 0, 1], got {bottom:?}") });
    }
    let r: Matrix3<f64> = m.fixed_view::<3, 3>(0, 0).into();
    let t = Vector3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]);
    Ok(Pose::from_parts(t.into(), checked_rotation(&r, what)?))
}

/// [`pose_from_matrix`] of 16 values in row-major order (numpy's `T.ravel()`).
///
/// ```
/// use denavit_core::spatial::{pose_from_row_major, trans};
/// let v = [1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0];
/// assert_eq!(pose_from_row_major(&v, "T").unwrap(), trans(0.5, 0.0, 0.0));
/// ```
pub fn pose_from_row_major(v: &[f64; 16], what: &str) -> Result<Pose> {
    pose_from_matrix(&Matrix4::from_row_slice(v), what)
}

/// Check that a [`Pose`] built elsewhere is a rigid transform: finite, rotation within [`SE3_TOL`] (the
/// check of [`pose_from_matrix`], without changing the pose). `what` names the pose in the error and is
/// formatted only for it (a batch passes `format_args!("IK goal {i}")`: a String per target had cost a few
/// percent of a solve).
///
/// ```
/// use denavit_core::spatial::{check_pose, rz};
/// assert!(check_pose("T", &rz(0.3)).is_ok());
/// ```
pub fn check_pose(what: impl std::fmt::Display, p: &Pose) -> Result<()> {
    let r = p.rotation.matrix();
    if p.translation.vector.iter().chain(r.iter()).all(|v| v.is_finite()) && checked_rotation(r, "").is_ok() {
        return Ok(());
    }
    let what = what.to_string();
    check_finite(&what, p.translation.vector.as_slice())?;
    check_finite(&what, r.as_slice())?;
    checked_rotation(r, &what).map(|_| ())
}

/// The rotation matrix nearest to `m` in the Frobenius norm (SVD projection).
pub fn nearest_rotation(m: &Matrix3<f64>) -> Rotation3<f64> {
    let svd = m.svd(true, true);
    let (u, vt) = (svd.u.unwrap_or_else(Matrix3::identity), svd.v_t.unwrap_or_else(Matrix3::identity));
    let mut d = Matrix3::identity();
    if (u * vt).determinant() < 0.0 {
        d[(2, 2)] = -1.0;
    }
    Rotation3::from_matrix_unchecked(u * d * vt)
}

/// A unit vector from a 3-vector, or a `Degenerate` error naming `what` when its length is (near) zero.
pub fn unit(v: &Vector3<f64>, what: &str) -> Result<Unit<Vector3<f64>>> {
    check_finite(what, v.as_slice())?;
    let n = v.norm();
    if n < 1e-12 {
        return Err(Error::Degenerate { reason: format!("{what} must be a non-zero direction, got length {n:.3e}") });
    }
    Ok(Unit::new_unchecked(v / n))
}

/// Frame from an origin, a z axis and an x hint (made perpendicular to z); `fallback` is used when the
/// hint is (nearly) parallel to z.
pub(crate) fn frame_from_zx(origin: &Vector3<f64>, z: &Vector3<f64>, x_hint: &Vector3<f64>, fallback: &Vector3<f64>) -> Pose {
    let x = perpendicular(x_hint, z).or_else(|| perpendicular(fallback, z)).unwrap_or_else(|| any_perpendicular(z));
    let y = z.cross(&x);
    let r = Matrix3::from_columns(&[x, y, *z]);
    Pose::from_parts((*origin).into(), Rotation3::from_matrix_unchecked(r))
}

/// Unit component of `v` perpendicular to the unit vector `z`, if it is not (nearly) zero.
pub(crate) fn perpendicular(v: &Vector3<f64>, z: &Vector3<f64>) -> Option<Vector3<f64>> {
    let p = v - z * z.dot(v);
    // a second projection: when `v` is nearly along `z`, the first leaves a component along `z` of round-off
    // relative to |v|, a large tilt relative to the small |p| ("twice is enough", Gram-Schmidt)
    let p = p - z * z.dot(&p);
    let n = p.norm();
    (n > 1e-9 * v.norm().max(1e-300)).then(|| p / n)
}

/// A deterministic unit vector perpendicular to the unit vector `z`.
pub(crate) fn any_perpendicular(z: &Vector3<f64>) -> Vector3<f64> {
    let e = if z.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    (e - z * z.dot(&e)).normalize()
}

/// Signed angle from `a` to `b` about the unit axis `n` (both taken perpendicular to `n`).
pub(crate) fn signed_angle(a: &Vector3<f64>, b: &Vector3<f64>, n: &Vector3<f64>) -> f64 {
    a.cross(b).dot(n).atan2(a.dot(b))
}

/// Wrap an angle to (-pi, pi].
pub fn wrap_angle(t: f64) -> f64 {
    let w = t.rem_euclid(std::f64::consts::TAU);
    if w > std::f64::consts::PI { w - std::f64::consts::TAU } else { w }
}

/// Position and rotation-angle distance between two poses (metres, radians).
pub fn pose_error(a: &Pose, b: &Pose) -> (f64, f64) {
    let dp = (a.translation.vector - b.translation.vector).norm();
    (dp, rotation_angle(&(a.rotation.inverse() * b.rotation)))
}

/// Rotation angle of `r` in [0, pi], accurate for small angles too (`atan2(|sin|, cos)`, not `acos`).
pub fn rotation_angle(r: &Rotation3<f64>) -> f64 {
    let m = r.matrix();
    let s = Vector3::new(m[(2, 1)] - m[(1, 2)], m[(0, 2)] - m[(2, 0)], m[(1, 0)] - m[(0, 1)]).norm() / 2.0;
    let c = (m.trace() - 1.0) / 2.0;
    s.atan2(c)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::{Joint, JointKind, Model};

    /// One check for every rigid transform: a 4x4, an IK goal and a model's fixed poses accept and
    /// reject alike (a model used to accept any finite matrix as a placement, e.g. a scaled rotation).
    #[test]
    fn one_rigid_transform_check() {
        let good = rx(0.3) * rz(-1.2) * trans(0.1, 0.2, 0.3);
        // orthonormal to rounding: used as given, bit for bit
        assert_eq!(pose_from_matrix(&good.to_homogeneous(), "T").unwrap(), good);
        // off by 1e-11 (a file with 11 digits): accepted and projected onto the rotations
        let mut near = good.to_homogeneous();
        near[(0, 1)] += 1e-11;
        let p = pose_from_matrix(&near, "T").unwrap();
        assert!((p.rotation.matrix().transpose() * p.rotation.matrix() - Matrix3::identity()).amax() <= ROUNDING);
        // scaled (1e-6 > SE3_TOL) or reflected: rejected by the matrix check, the pose check and the model
        let mut scaled = good;
        *scaled.rotation.matrix_mut_unchecked() *= 1.0 + 1e-6;
        let mut reflected = good;
        reflected.rotation.matrix_mut_unchecked().column_mut(2).neg_mut();
        for bad in [scaled, reflected] {
            let e = pose_from_matrix(&bad.to_homogeneous(), "T").unwrap_err().to_string();
            assert!(e.contains("orthonormal with det +1 (tolerance 1e-9)"), "{e}");
            assert_eq!(check_pose("T", &bad).unwrap_err().to_string(), e);
            let j = vec![Joint::new("j1", JointKind::Revolute, bad)];
            assert!(Model::new("m", Pose::identity(), j, Pose::identity(), Pose::identity()).unwrap_err().to_string().contains("orthonormal"));
            assert!(Model::new("m", bad, vec![], Pose::identity(), Pose::identity()).is_err());
            assert!(Model::new("m", Pose::identity(), vec![], bad, Pose::identity()).is_err());
            assert!(Model::new("m", Pose::identity(), vec![], Pose::identity(), bad).is_err());
        }
        let v: [f64; 16] = std::array::from_fn(|k| good.to_homogeneous()[(k / 4, k % 4)]);
        assert_eq!(pose_from_row_major(&v, "T").unwrap(), good);
    }
}
