//! Link inertial parameters re-expressed between frames and models (the type itself: [`crate::inertia`]).

use super::*;

impl Inertia {
    /// The 6x6 spatial inertia about the frame origin, Featherstone eq. 2.63, for motion `[ω; v]` and
    /// force `[n; f]`: `[[I_o, m c×], [-m c×, m 1]]`.
    ///
    /// ```
    /// use denavit_core::dynamics::Inertia;
    /// let i = Inertia::point_mass(2.0, nalgebra::Vector3::new(1.0, 0.0, 0.0)).unwrap();
    /// let s = i.spatial_matrix();
    /// assert_eq!(s[(5, 5)], 2.0);
    /// assert!((s - s.transpose()).amax() == 0.0);
    /// ```
    pub fn spatial_matrix(&self) -> Matrix6<f64> {
        Rb::from(self).matrix6()
    }
}

/// Link inertias given in `world` with the robot at `q_ref` (e.g. exported from CAD at the home pose),
/// re-expressed in each joint frame: `I_i = transformed(T_world_joint_i(q_ref)^-1)`.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{inertias_in_world, Inertia}};
/// let m = builtin_planar2(1.0, 1.0);
/// let w = Inertia::point_mass(1.0, nalgebra::Vector3::new(1.5, 0.0, 0.0)).unwrap(); // mid link 2
/// let l = inertias_in_world(&m, &[0.0, 0.0], &[w, w]).unwrap();
/// assert!((l[1].com().x - 0.5).abs() < 1e-15);
/// ```
pub fn inertias_in_world(model: &Model, q_ref: &[f64], inertias_world: &[Inertia]) -> Result<Vec<Inertia>> {
    model.check_q(q_ref)?;
    check_len("link inertias (one per joint)", model.nq(), inertias_world.len())?;
    let mut data = crate::model::Data::new(model);
    crate::kinematics::forward_kinematics(model, &mut data, q_ref)?;
    Ok(inertias_world.iter().zip(&data.t_world_joint).map(|(i, t)| i.transformed(&t.inverse())).collect())
}

/// Re-express the link inertias of `from` in the joint frames of `to`, another model of the same physical
/// robot (e.g. its modified-DH and ED-H models): `I_to,i = transformed(T_to_i^-1 · T_from_i)` at `q_ref`.
///
/// Both models must have the same joint axes, in the same directions, at `q_ref` (then the two joint frames
/// of a link move together and the transform between them is constant); otherwise an error says which
/// axis differs. Returns `to` with the re-expressed inertias attached.
///
/// ```
/// use denavit_core::{builtin_planar2, dynamics::{self, transfer_inertias, DynamicsData, Inertia}};
/// use denavit_core::{Model, spatial::{trans, Pose}};
/// let a = builtin_planar2(1.0, 1.0)
///     .with_inertias(vec![Inertia::point_mass(1.0, nalgebra::Vector3::new(0.5, 0.0, 0.0)).unwrap(); 2]).unwrap();
/// // the same arm with joint frame 2 moved 0.2 m along its axis
/// let mut j = a.joints().to_vec();
/// j[1].placement = trans(1.0, 0.0, 0.2);
/// let b = Model::new("b", *a.t_world_base(), j, trans(1.0, 0.0, -0.2), Pose::identity()).unwrap();
/// let b = transfer_inertias(&a, &b, &[0.0, 0.0]).unwrap();
/// assert!((b.inertias()[1].com().z + 0.2).abs() < 1e-15);
/// ```
pub fn transfer_inertias(from: &Model, to: &Model, q_ref: &[f64]) -> Result<Model> {
    check_len("joints of the target model", from.nq(), to.nq())?;
    from.check_q(q_ref)?;
    let (mut da, mut db) = (crate::model::Data::new(from), crate::model::Data::new(to));
    crate::kinematics::forward_kinematics(from, &mut da, q_ref)?;
    crate::kinematics::forward_kinematics(to, &mut db, q_ref)?;
    let size = 1.0 + da.t_world_joint.iter().map(|t| t.translation.vector.norm()).fold(0.0, f64::max);
    let mut out = Vec::with_capacity(from.nq());
    for (i, ((ta, tb), inertia)) in da.t_world_joint.iter().zip(&db.t_world_joint).zip(from.inertias()).enumerate() {
        let (za, zb) = (ta.rotation.matrix().column(2).into_owned(), tb.rotation.matrix().column(2).into_owned());
        let d = ta.translation.vector - tb.translation.vector;
        let off_axis = (d - zb * zb.dot(&d)).norm();
        let (kind_a, kind_b) = (from.joints()[i].kind, to.joints()[i].kind);
        let same = kind_a == kind_b && (za - zb).norm() < 1e-9 && (kind_a == JointKind::Prismatic || off_axis < 1e-9 * size);
        if !same {
            return Err(Error::InvalidArgument {
                what: format!("joint axis {} of the target model", i + 1),
                expected: "the same joint kind and axis (direction and line) as the source model at q_ref".into(),
                got: format!("|z_from - z_to| = {:.3e}, distance of the origin from the axis = {off_axis:.3e} m", (za - zb).norm()),
            });
        }
        out.push(inertia.transformed(&(tb.inverse() * ta)));
    }
    to.with_inertias(out)
}
