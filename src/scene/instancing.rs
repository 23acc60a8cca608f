//! Shapes defined once and placed many times (Mitsuba's `shapegroup` and
//! `instance`, plsr's `group` key and `[[instances]]`): each group's meshes
//! are stored once, in the group's own space, with one Embree BVH; each
//! instance is an Embree instance of it under an affine transform.
//!
//! A hit on an instance reports the instance ([`crate::accel::Hit::instance`])
//! and the group's own mesh and triangle; the integrators interpolate the
//! mesh's attributes in the group's space and bring them to the world with
//! [`Instance::normal`], [`Instance::vector`] and [`Instance::geometric`].

use super::Mesh;
use glam::{Affine3A, Mat3, Vec3};

/// Where groups of meshes are placed: the groups and their instances.
#[derive(Debug, Clone, Default)]
pub struct Instancing {
    /// The groups, in their own space.
    pub groups: Vec<MeshGroup>,
    /// The instances, each placing one group.
    pub instances: Vec<Instance>,
}

/// Meshes placed together by [`Instance`]s (never drawn on their own).
#[derive(Debug, Clone)]
pub struct MeshGroup {
    /// Its name, for messages.
    pub name: String,
    /// Its meshes, in the group's own space (no emission, no PLS).
    pub meshes: Vec<Mesh>,
}

/// One placement of a [`MeshGroup`].
#[derive(Debug, Clone)]
pub struct Instance {
    /// Index of the group in [`Instancing::groups`].
    pub group: u32,
    /// The group's space to the world.
    pub to_world: Affine3A,
    /// Object identity for the film's object layer (the scene file's
    /// instance index, after the shapes').
    pub object_id: u32,
    /// The inverse transpose of `to_world`'s linear part: normals.
    normal_matrix: Mat3,
    /// `|det|` times the normal matrix: a triangle's `(p1 − p0) × (p2 − p0)`
    /// in the world, turned to the same side of the surface under a mirror
    /// (as a mirrored mesh's winding is reversed, `shapes::transform_mesh`).
    geometric: Mat3,
}

impl Instance {
    /// An instance of group `group` placed by `to_world`; `None` when the
    /// transform is singular or not finite.
    pub fn new(group: u32, to_world: Affine3A, object_id: u32) -> Option<Instance> {
        let linear = Mat3::from(to_world.matrix3);
        let det = linear.determinant();
        if !det.is_finite() || det == 0.0 || !to_world.is_finite() {
            return None;
        }
        let normal_matrix = linear.inverse().transpose();
        Some(Instance {
            group,
            to_world,
            object_id,
            normal_matrix,
            geometric: normal_matrix * det.abs(),
        })
    }

    /// A point of the group's space in the world.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        self.to_world.transform_point3(p)
    }

    /// A direction of the group's space (a tangent) in the world.
    #[inline]
    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.to_world.transform_vector3(v)
    }

    /// A unit normal of the group's space in the world (unit length; zero
    /// stays zero).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        (self.normal_matrix * n).normalize_or_zero()
    }

    /// A triangle's unnormalised geometric normal in the world: as if its
    /// transformed vertices had been crossed, and for a mirroring
    /// transform turned round, to stay on the side of the surface it was
    /// on (as a mirrored mesh's winding is reversed).
    #[inline]
    pub fn geometric(&self, ng: Vec3) -> Vec3 {
        self.geometric * ng
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normals_follow_the_transformed_triangle() {
        let (p0, p1, p2) = (
            Vec3::new(0.1, 0.2, 0.3),
            Vec3::new(1.0, -0.4, 0.2),
            Vec3::new(0.3, 0.9, -0.5),
        );
        let ng = (p1 - p0).cross(p2 - p0);
        // A shear, a scale and a mirror (negative determinant).
        for m in [
            Affine3A::from_cols_array(&[
                1.0, 0.3, 0.0, 0.2, 2.0, 0.1, 0.0, -0.4, 0.5, 3.0, 1.0, -2.0,
            ]),
            Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0)),
        ] {
            let i = Instance::new(0, m, 0).unwrap();
            let (q0, q1, q2) = (i.point(p0), i.point(p1), i.point(p2));
            let crossed = (q1 - q0).cross(q2 - q0);
            let want = crossed * m.matrix3.determinant().signum();
            assert!((i.geometric(ng) - want).length() < 1e-4 * want.length());
            // The normal is perpendicular to the transformed edges.
            let n = i.normal(ng.normalize());
            assert!(n.dot(q1 - q0).abs() < 1e-5 && n.dot(q2 - q0).abs() < 1e-5);
        }
        assert!(Instance::new(0, Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)), 0).is_none());
    }
}
