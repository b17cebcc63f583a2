//! The scene's frame: its box with the protocol's centre `C` and diagonal
//! `D`, from which the auto camera, the default light, the secondary ray
//! offsets and the random rays are derived.

use crate::aabb::Aabb;
use crate::mesh::Mesh;
use crate::scene::Scene;
use glam::{Affine3A, Vec3};

/// The scene's box with the protocol's `C` (centre) and `D` (diagonal
/// length), in `f32`.
///
/// ```
/// use glam::{Vec3, Vec3A};
/// use packtrace::{Aabb, protocol::SceneFrame};
/// let f = SceneFrame::from_bounds(Aabb::new(Vec3A::ZERO, Vec3A::new(2.0, 4.0, 4.0)));
/// assert_eq!((f.center, f.diagonal), (Vec3::new(1.0, 2.0, 2.0), 6.0));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SceneFrame {
    /// `C = (min + max) / 2`.
    pub center: Vec3,
    /// `D = |max - min|`.
    pub diagonal: f32,
    /// The scene box (corners of the triangles only).
    pub bounds: Aabb,
}

impl SceneFrame {
    /// The frame of a mesh's bounds (the box of its triangles' corners).
    /// An empty mesh gives a non-finite frame.
    ///
    /// ```
    /// use packtrace::protocol::SceneFrame;
    /// let f = SceneFrame::of(&packtrace::protocol::generate::cornell_box());
    /// assert_eq!(f.center, glam::Vec3::new(278.0, 274.4, 279.6));
    /// assert_eq!(f.bounds.max.x, 556.0);
    /// ```
    #[must_use]
    pub fn of(mesh: &Mesh) -> SceneFrame {
        SceneFrame::from_bounds(mesh.bounds())
    }

    /// The frame of a scene of instances: the box of every live
    /// instance's mesh box, its eight corners mapped to world space (the
    /// instance's `to_world`, in `f32`), framed as [`SceneFrame::of`]
    /// frames a mesh's box. One identity instance gives its mesh's frame
    /// exactly; the box lies inside [`Scene::bounds`] (the top level's
    /// conservative box, rounded outwards). The bench's random rays and
    /// the renderer's auto camera and light both use it. An empty scene
    /// gives a non-finite frame.
    ///
    /// ```
    /// use glam::{Affine3A, Vec3};
    /// use packtrace::protocol::{SceneFrame, generate};
    /// use packtrace::{KdBuildParams, KdTree, scene::Scene};
    /// let mut scene = Scene::new();
    /// let tree = KdTree::build(generate::cornell_box(), &KdBuildParams::default())?;
    /// let g = scene.add_geometry("box", tree);
    /// let id = scene.edit().add_instance(g, Affine3A::IDENTITY)?;
    /// assert_eq!(SceneFrame::of_scene(&scene), SceneFrame::of(&generate::cornell_box()));
    /// scene.edit().set_transform(id, Affine3A::from_translation(Vec3::new(0.0, 0.0, 1000.0)))?;
    /// let f = SceneFrame::of_scene(&scene);
    /// assert!((f.center.z - 1279.6).abs() < 0.01);
    /// let b = scene.bounds();
    /// assert!(b.contains(f.bounds.min) && b.contains(f.bounds.max));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn of_scene(scene: &Scene) -> SceneFrame {
        let mut lo = Vec3::INFINITY;
        let mut hi = Vec3::NEG_INFINITY;
        for (_, inst) in scene.instances() {
            let Some(g) = scene.geometry(inst.geometry()) else {
                continue;
            };
            let b = g.mesh().bounds();
            let (min, max) = (Vec3::from(b.min), Vec3::from(b.max));
            if min.cmpgt(max).any() {
                continue;
            }
            let m = inst.transform().to_world();
            let identity = m == Affine3A::IDENTITY;
            for corner in 0..8 {
                let c = Vec3::new(
                    if corner & 1 == 0 { min.x } else { max.x },
                    if corner & 2 == 0 { min.y } else { max.y },
                    if corner & 4 == 0 { min.z } else { max.z },
                );
                let w = if identity { c } else { m.transform_point3(c) };
                lo = lo.min(w);
                hi = hi.max(w);
            }
        }
        SceneFrame::from_bounds(Aabb::new(lo.into(), hi.into()))
    }

    /// The frame of a box.
    ///
    /// ```
    /// use glam::Vec3A;
    /// use packtrace::{Aabb, protocol::SceneFrame};
    /// let f = SceneFrame::from_bounds(Aabb::new(Vec3A::ZERO, Vec3A::new(3.0, 4.0, 0.0)));
    /// assert_eq!(f.diagonal, 5.0);
    /// ```
    #[must_use]
    pub fn from_bounds(bounds: Aabb) -> SceneFrame {
        let (min, max) = (Vec3::from(bounds.min), Vec3::from(bounds.max));
        SceneFrame {
            center: (min + max) * 0.5,
            diagonal: (max - min).length(),
            bounds,
        }
    }
}

/// The protocol's default light `C + D * (0.25, 0.8, 0.35)`.
///
/// ```
/// use glam::{Vec3, Vec3A};
/// use packtrace::{Aabb, protocol::{SceneFrame, default_light}};
/// let f = SceneFrame::from_bounds(Aabb::new(Vec3A::ZERO, Vec3A::new(3.0, 4.0, 0.0)));
/// assert_eq!(default_light(&f), Vec3::new(1.5 + 1.25, 2.0 + 4.0, 1.75));
/// ```
#[must_use]
pub fn default_light(frame: &SceneFrame) -> Vec3 {
    frame.center + frame.diagonal * Vec3::new(0.25, 0.8, 0.35)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::generate;
    use crate::{KdBuildParams, KdTree};
    use glam::{Quat, Vec3A};

    /// Every vertex of every instance, mapped to world space, lies in the
    /// frame's box (up to the rounding of mapping a point instead of a
    /// corner), for rotated, scaled and mirrored instances; the box lies
    /// inside the top level's conservative one.
    #[test]
    fn the_scene_frame_holds_every_instance() {
        let mesh = generate::sphere(300);
        let mut scene = Scene::new();
        let g = scene.add_geometry(
            "ball",
            KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap(),
        );
        let placed = [
            Affine3A::from_scale_rotation_translation(
                Vec3::new(2.0, 0.5, 1.0),
                Quat::from_rotation_z(0.7),
                Vec3::new(10.0, -3.0, 2.0),
            ),
            Affine3A::from_scale(Vec3::new(-1.0, 1.0, 3.0)),
            Affine3A::from_rotation_translation(Quat::from_rotation_x(2.0), Vec3::splat(-7.0)),
        ];
        let mut edit = scene.edit();
        for m in placed {
            edit.add_instance(g, m).unwrap();
        }
        edit.commit();
        let f = SceneFrame::of_scene(&scene);
        let slack = 1e-5 * f.diagonal;
        for m in placed {
            for &p in mesh.positions() {
                let w = Vec3A::from(m.transform_point3(p));
                assert!(
                    w.cmpge(f.bounds.min - slack).all() && w.cmple(f.bounds.max + slack).all(),
                    "{w:?} outside {:?}",
                    f.bounds
                );
            }
        }
        let b = scene.bounds();
        assert!(b.contains(f.bounds.min) && b.contains(f.bounds.max));
    }
}
