//! The scene's frame: its box with the protocol's centre `C` and diagonal
//! `D`, from which the auto camera, the default light, the secondary ray
//! offsets and the random rays are derived.

use crate::aabb::Aabb;
use crate::mesh::Mesh;
use crate::scene::Scene;
use glam::Vec3;

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

    /// The frame of a scene of instances: its world box
    /// ([`Scene::bounds`], the union of the instances' conservative world
    /// boxes), framed as [`SceneFrame::of`] frames a mesh's box. An empty
    /// scene gives a non-finite frame.
    ///
    /// ```
    /// use glam::{Affine3A, Vec3};
    /// use packtrace::protocol::{SceneFrame, generate};
    /// use packtrace::{KdBuildParams, KdTree, scene::Scene};
    /// let mut scene = Scene::new();
    /// let tree = KdTree::build(generate::cornell_box(), &KdBuildParams::default())?;
    /// let g = scene.add_geometry("box", tree);
    /// scene.edit().add_instance(g, Affine3A::from_translation(Vec3::new(0.0, 0.0, 1000.0)))?;
    /// let f = SceneFrame::of_scene(&scene);
    /// assert_eq!(f, SceneFrame::from_bounds(scene.bounds()));
    /// assert!((f.center.z - 1279.6).abs() < 0.01);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn of_scene(scene: &Scene) -> SceneFrame {
        SceneFrame::from_bounds(scene.bounds())
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
