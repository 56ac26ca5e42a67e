//! Kinetic and potential energy of the chain.

use super::*;

/// Kinetic energy `½ qdᵀ M(q) qd = Σ ½ v_iᵀ I_i v_i` (J). Allocation-free.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{kinetic_energy, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// // stretched arm turning at 1 rad/s: ½ (1·1² + 1·2²)
/// assert!((kinetic_energy(&m, &[0.0, 0.0], &[1.0, 0.0]).unwrap() - 2.5).abs() < 1e-15);
/// ```
pub fn kinetic_energy(model: &Model, q: &[f64], qd: &[f64]) -> Result<f64> {
    model.check_q(q)?;
    check_vec("qd", model.nq(), qd)?;
    check_rates(qd, None)?;
    let (mut w, mut v) = (Vector3::zeros(), Vector3::zeros());
    let mut e = 0.0;
    for (i, (j, inertia)) in model.joints().iter().zip(model.inertias()).enumerate() {
        let x = link_transform(j, q[i] + j.offset);
        (w, v) = x.motion_to_child(&w, &v);
        match j.kind {
            JointKind::Revolute => w.z += qd[i],
            JointKind::Prismatic => v.z += qd[i],
        }
        let (hn, hf) = Rb::from(inertia).apply(&w, &v);
        e += 0.5 * (w.dot(&hn) + v.dot(&hf));
    }
    check_result("the kinetic energy", &[e], |_| "the chain".to_string(), &[("q", q), ("qd", qd)])?;
    Ok(e)
}

/// Potential energy in the gravity field `-Σ m_i gᵀ c_i` (J, zero at the world origin), `gravity` in world.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{potential_energy, Inertia}};
/// let tip = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
/// let m = builtin_planar2(1.0, 1.0).with_inertias(vec![tip; 2]).unwrap();
/// let g = nalgebra::Vector3::new(0.0, -10.0, 0.0);
/// assert!((potential_energy(&m, &[std::f64::consts::FRAC_PI_2, 0.0], &g).unwrap() - 30.0).abs() < 1e-12);
/// ```
pub fn potential_energy(model: &Model, q: &[f64], gravity: &Vector3<f64>) -> Result<f64> {
    model.check_q(q)?;
    check_gravity(gravity)?;
    let mut t = *model.t_world_base();
    let mut e = 0.0;
    for (i, (j, inertia)) in model.joints().iter().zip(model.inertias()).enumerate() {
        t *= j.placement;
        crate::kinematics::apply_motion(&mut t, j.kind, q[i] + j.offset);
        let c = t.transform_point(&(*inertia.com()).into()).coords;
        e -= inertia.mass() * gravity.dot(&c);
    }
    check_result("the potential energy", &[e], |_| "the chain".to_string(), &[("q", q), ("gravity", gravity.as_slice())])?;
    Ok(e)
}
