//! Instance transforms: checked once, inverted once, and applied to rays
//! in one fixed order of f32 operations by every path (scalar, packet
//! lanes, the brute-force scene oracle), so that all of them trace the
//! very same object-space ray.
//!
//! The world-to-object map is stored as f32, `x' = A x + b`; that stored
//! map *is* the instance (its exact real inverse places the mesh in the
//! world). A ray keeps its parameter: `o' + t d'` is the object-space
//! point of `o + t d`, so `t`, `u`, `v` need no conversion and hits of
//! different instances compare directly (PBRT-v3 section 2.8; the lecture
//! notes' two-level structures, `../shared/seeds`).

use crate::aabb::Aabb;
use crate::ray::Ray;
use crate::simd::Lane;
use crate::triangle::MARGIN;
use glam::{Affine3A, DMat3, DVec3, Mat3A, Vec3, Vec3A};
use std::fmt;

/// The largest accepted condition number `||A|| * ||A^-1||` (infinity
/// norms) of a transform's linear part, `2^20`: past it, f32 keeps about
/// one significant digit of an object-space ray, and the world boxes that
/// must stay conservative grow past the scene (`Pad`).
pub const MAX_CONDITION: f64 = 1_048_576.0;

/// Why a transform was refused.
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// use packtrace::scene::{Transform, TransformError};
/// let flat = Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0));
/// assert!(matches!(Transform::new(flat), Err(TransformError::Singular { .. })));
/// let nan = Affine3A::from_translation(Vec3::new(f32::NAN, 0.0, 0.0));
/// assert_eq!(Transform::new(nan), Err(TransformError::NonFinite));
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TransformError {
    /// An entry of the matrix or the translation is NaN or infinite.
    NonFinite,
    /// The linear part is singular or too close to it: its condition
    /// number (infinite when the determinant is zero or the inverse
    /// overflows f32) is above [`MAX_CONDITION`].
    Singular {
        /// `||A|| * ||A^-1||` in the infinity norm.
        condition: f64,
    },
}

impl fmt::Display for TransformError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            TransformError::NonFinite => write!(f, "transform has a NaN or infinite entry"),
            TransformError::Singular { condition } => write!(
                f,
                "transform is singular or nearly so (condition number {condition:.3e}, \
                 at most {MAX_CONDITION:.0} accepted)"
            ),
        }
    }
}

impl std::error::Error for TransformError {}

/// An instance's object-to-world transform, with the world-to-object map
/// computed once (in f64, rounded to f32).
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// use packtrace::scene::Transform;
/// let m = Affine3A::from_scale_rotation_translation(
///     Vec3::splat(2.0), Default::default(), Vec3::new(1.0, 0.0, 0.0));
/// let t = Transform::new(m)?;
/// assert_eq!(t.to_world(), m);
/// assert_eq!(t.to_object().transform_point3(Vec3::new(3.0, 2.0, 0.0)), Vec3::new(1.0, 1.0, 0.0));
/// assert_eq!(t.condition(), 1.0);
/// # Ok::<(), packtrace::scene::TransformError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    to_world: Affine3A,
    /// `A` (world to object) by columns: `cols[c][r]` is `A`'s row `r`,
    /// column `c`. Columns, so that one ray is transformed in SIMD
    /// registers (`ray_to_object`); the lane code reads the rows from them.
    cols: [Vec3A; 3],
    /// `b`, the world-to-object translation.
    b: Vec3A,
    /// The exact inverse of the stored `A` (f64), which maps object
    /// boxes and normals.
    a_inv: DMat3,
    /// `||A||` and `||A^-1||` in the infinity norm.
    norm: f64,
    inv_norm: f64,
}

/// Infinity norm (largest row sum) of a 3 x 3 matrix given by columns.
fn norm_inf(m: &DMat3) -> f64 {
    (0..3)
        .map(|r| (0..3).map(|c| m.col(c)[r].abs()).sum::<f64>())
        .fold(0.0, f64::max)
}

/// Row `r` of `A` times `v`: `(a[r][0] v.x + a[r][1] v.y) + a[r][2] v.z`.
/// A function, not a closure or `array::map`: inside a kernel LLVM left
/// those outlined, as baseline code (perf, an instance's primary packets).
#[inline(always)]
fn row<L: Lane>(c: &[Vec3A; 3], r: usize, v: &[L; 3]) -> L {
    L::splat(c[0][r]) * v[0] + L::splat(c[1][r]) * v[1] + L::splat(c[2][r]) * v[2]
}

impl Transform {
    /// The identity.
    ///
    /// ```
    /// let t = packtrace::scene::Transform::IDENTITY;
    /// assert_eq!(t.to_world(), packtrace::glam::Affine3A::IDENTITY);
    /// ```
    pub const IDENTITY: Transform = Transform {
        to_world: Affine3A::IDENTITY,
        cols: [Vec3A::X, Vec3A::Y, Vec3A::Z],
        b: Vec3A::ZERO,
        a_inv: DMat3::IDENTITY,
        norm: 1.0,
        inv_norm: 1.0,
    };

    /// A checked transform from object to world space.
    ///
    /// # Errors
    /// [`TransformError::NonFinite`] for a NaN or infinite entry;
    /// [`TransformError::Singular`] when the linear part is not invertible
    /// in f32 or its condition number exceeds [`MAX_CONDITION`].
    pub fn new(to_world: Affine3A) -> Result<Transform, TransformError> {
        let m = to_world.matrix3;
        let c = to_world.translation;
        if !(m.is_finite() && c.is_finite()) {
            return Err(TransformError::NonFinite);
        }
        let singular = |condition| Err(TransformError::Singular { condition });
        let m64 = DMat3::from_cols(
            m.x_axis.as_dvec3(),
            m.y_axis.as_dvec3(),
            m.z_axis.as_dvec3(),
        );
        let det = m64.determinant();
        if det == 0.0 || !det.is_finite() {
            return singular(f64::INFINITY);
        }
        // A = M^-1 and b = -A c, in f64, rounded once to f32.
        let a64 = m64.inverse();
        let b64 = -(a64 * c.as_dvec3());
        let a32 = Mat3A::from_cols(
            a64.x_axis.as_vec3().into(),
            a64.y_axis.as_vec3().into(),
            a64.z_axis.as_vec3().into(),
        );
        let b32 = b64.as_vec3();
        if !(a32.is_finite() && b32.is_finite()) {
            return singular(f64::INFINITY);
        }
        // From here on the stored f32 map is the instance: its own exact
        // inverse (f64) maps boxes and normals.
        let a_stored = DMat3::from_cols(
            Vec3::from(a32.x_axis).as_dvec3(),
            Vec3::from(a32.y_axis).as_dvec3(),
            Vec3::from(a32.z_axis).as_dvec3(),
        );
        let det_a = a_stored.determinant();
        if det_a == 0.0 || !det_a.is_finite() {
            return singular(f64::INFINITY);
        }
        let a_inv = a_stored.inverse();
        let (norm, inv_norm) = (norm_inf(&a_stored), norm_inf(&a_inv));
        let condition = norm * inv_norm;
        if condition.is_nan() || condition > MAX_CONDITION {
            return singular(condition);
        }
        Ok(Transform {
            to_world,
            cols: [a32.x_axis, a32.y_axis, a32.z_axis],
            b: b32.into(),
            a_inv,
            norm,
            inv_norm,
        })
    }

    /// The object-to-world transform it was made from.
    ///
    /// ```
    /// use packtrace::glam::{Affine3A, Vec3};
    /// let m = Affine3A::from_translation(Vec3::X);
    /// assert_eq!(packtrace::scene::Transform::new(m).unwrap().to_world(), m);
    /// ```
    #[must_use]
    pub fn to_world(&self) -> Affine3A {
        self.to_world
    }

    /// The stored world-to-object map (what rays are transformed with).
    ///
    /// ```
    /// use packtrace::glam::{Affine3A, Vec3};
    /// let t = packtrace::scene::Transform::new(Affine3A::from_translation(Vec3::X)).unwrap();
    /// assert_eq!(t.to_object().translation, Vec3::NEG_X.into());
    /// ```
    #[must_use]
    pub fn to_object(&self) -> Affine3A {
        let [c0, c1, c2] = self.cols;
        Affine3A::from_mat3_translation(
            glam::Mat3::from_cols(c0.into(), c1.into(), c2.into()),
            self.b.into(),
        )
    }

    /// `||A|| * ||A^-1||`, the condition number of the linear part
    /// (infinity norm; 1 for rotations about an axis and uniform scales).
    ///
    /// ```
    /// use packtrace::glam::{Affine3A, Vec3};
    /// let t = packtrace::scene::Transform::new(Affine3A::from_scale(Vec3::new(1.0, 4.0, 1.0))).unwrap();
    /// assert_eq!(t.condition(), 4.0);
    /// ```
    #[must_use]
    pub fn condition(&self) -> f64 {
        self.norm * self.inv_norm
    }

    /// The columns of `A` and `b` (a kernel's own form of
    /// [`Transform::lanes_to_object`], `kdtree/kernel.rs`).
    #[inline(always)]
    pub(crate) fn linear_and_offset(&self) -> (&[Vec3A; 3], Vec3A) {
        (&self.cols, self.b)
    }

    /// `A p + b`, in the one order every path uses.
    #[inline(always)]
    fn point<L: Lane>(&self, p: &[L; 3]) -> [L; 3] {
        let (c, b) = (&self.cols, self.b);
        [
            row(c, 0, p) + L::splat(b.x),
            row(c, 1, p) + L::splat(b.y),
            row(c, 2, p) + L::splat(b.z),
        ]
    }

    /// `A d`, in the one order every path uses.
    #[inline(always)]
    fn vector<L: Lane>(&self, d: &[L; 3]) -> [L; 3] {
        let c = &self.cols;
        [row(c, 0, d), row(c, 1, d), row(c, 2, d)]
    }

    /// Origin and direction of lanes (or of one ray, `L = f32`) in object
    /// space. Lane `i` equals the scalar result bit for bit: the same
    /// multiplications and additions in the same order, no fused ones.
    #[inline(always)]
    pub(crate) fn lanes_to_object<L: Lane>(&self, org: &[L; 3], dir: &[L; 3]) -> ([L; 3], [L; 3]) {
        (self.point(org), self.vector(dir))
    }

    /// `ray` in object space, with the interval `(ray.t_min, t_max]`
    /// (the parameter is the same in both spaces).
    ///
    /// The three rows at once, by columns in SIMD registers: component `r`
    /// is `((a[r][0] o.x + a[r][1] o.y) + a[r][2] o.z) + b[r]`, the same
    /// operations in the same order as [`Transform::lanes_to_object`], so
    /// bit-equal to it (a unit test holds them equal); a third of the
    /// instructions of the row-by-row form.
    #[inline]
    pub(crate) fn ray_to_object(&self, ray: &Ray, t_max: f32) -> Ray {
        let [c0, c1, c2] = self.cols;
        let (o, d) = (ray.origin, ray.dir);
        let o = c0 * Vec3A::splat(o.x) + c1 * Vec3A::splat(o.y) + c2 * Vec3A::splat(o.z) + self.b;
        let d = c0 * Vec3A::splat(d.x) + c1 * Vec3A::splat(d.y) + c2 * Vec3A::splat(d.z);
        Ray::new_unchecked(o.into(), d.into(), ray.t_min, t_max)
    }

    /// The world box of an object box: the image of its corners under the
    /// exact inverse of the stored map, in f64, rounded outwards.
    pub(crate) fn world_bounds(&self, object: &Aabb) -> Aabb {
        if object.min.cmpgt(object.max).any() {
            return Aabb::EMPTY;
        }
        let (lo, hi) = (object.min.as_dvec3(), object.max.as_dvec3());
        let b = Vec3::from(self.b).as_dvec3();
        let mut wlo = DVec3::INFINITY;
        let mut whi = DVec3::NEG_INFINITY;
        for corner in 0..8 {
            let p = DVec3::new(
                if corner & 1 == 0 { lo.x } else { hi.x },
                if corner & 2 == 0 { lo.y } else { hi.y },
                if corner & 4 == 0 { lo.z } else { hi.z },
            );
            let w = self.a_inv * (p - b);
            wlo = wlo.min(w);
            whi = whi.max(w);
        }
        let down = |x: f64| (x as f32).next_down();
        let up = |x: f64| (x as f32).next_up();
        Aabb::new(
            Vec3A::new(down(wlo.x), down(wlo.y), down(wlo.z)),
            Vec3A::new(up(whi.x), up(whi.y), up(whi.z)),
        )
    }

    /// An object-space normal in world space (the inverse transpose,
    /// `A^T n`), normalised; a zero normal stays zero.
    pub(crate) fn normal_to_world(&self, n: Vec3) -> Vec3 {
        // Component c of `A^T n` is column c of `A` dotted with `n`.
        let [c0, c1, c2] = self.cols.map(Vec3::from);
        let w = Vec3::new(
            c0.x * n.x + c0.y * n.y + c0.z * n.z,
            c1.x * n.x + c1.y * n.y + c1.z * n.z,
            c2.x * n.x + c2.y * n.y + c2.z * n.z,
        );
        w.normalize_or_zero()
    }

    /// This transform's share of the scene's box padding ([`Pad`]) for an
    /// instance whose object box is `object` and world box `world`.
    pub(crate) fn pad(&self, object: &Aabb, world: &Aabb) -> Pad {
        // u = 2^-24; gamma_n = n u / (1 - n u) bounds n rounded operations.
        let u = f64::from(f32::EPSILON) / 2.0;
        let gamma = |n: f64| n * u / (1.0 - n * u);
        let (g3, g4, margin) = (gamma(3.0), gamma(4.0), f64::from(MARGIN));
        let mag = |b: &Aabb| f64::from(b.min.abs().max(b.max.abs()).max_element());
        let kappa = self.condition();
        let b = f64::from(self.b.abs().max_element());
        let s = mag(world);
        // World distance between the ray's point at a hit's t and the
        // exact image of the object-space point there (PBRT-v3 3.9):
        //   ||A^-1|| (g4 (||A|| ||o|| + ||b||) + t g3 ||A|| ||d||)   ray rounding
        // + ||A^-1|| MARGIN max(||o'||, |object box|)                  the hit's slack
        // with t ||d|| <= ||o|| + |world box| + (the same distance).
        Pad {
            per_origin: kappa * (g4 + g3 + margin),
            constant: self.inv_norm * b * (g4 + margin)
                + kappa * g3 * s
                + self.inv_norm * margin * mag(object),
            magnitude: s.max(f64::from(self.to_world.translation.abs().max_element())),
        }
    }
}

/// How far the top level widens every box around a ray: by
/// `per_origin * |o| + constant` (largest coordinate magnitude `|o|`), so
/// that rounding in the world-to-object transform and the triangle test's
/// slack never cull an instance the object-space ray hits. Twice the
/// largest bound of any instance, plus the slab test's own rounding.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Pad {
    pub per_origin: f64,
    pub constant: f64,
    /// The largest world coordinate magnitude involved.
    pub magnitude: f64,
}

impl Pad {
    /// The larger of two instances' bounds.
    pub fn max(self, o: Pad) -> Pad {
        Pad {
            per_origin: self.per_origin.max(o.per_origin),
            constant: self.constant.max(o.constant),
            magnitude: self.magnitude.max(o.magnitude),
        }
    }

    /// The scene's factors in f32, rounded up: twice the bound, plus
    /// `8 u (|o| + S)` for the slab test's own rounding.
    pub fn factors(self) -> (f32, f32) {
        let u = f64::from(f32::EPSILON) / 2.0;
        let k1 = 2.0 * self.per_origin + 8.0 * u;
        let k0 = 2.0 * self.constant + 8.0 * u * self.magnitude;
        ((k1 as f32).next_up(), (k0 as f32).next_up())
    }
}

/// One node of a transform hierarchy for [`flatten`]: a local transform
/// relative to its parent, and the geometry placed there (if any).
///
/// ```
/// use packtrace::glam::{Affine3A, Vec3};
/// use packtrace::scene::{HierarchyNode, flatten};
/// let nodes = [
///     HierarchyNode { parent: None, local: Affine3A::from_translation(Vec3::X), geometry: None },
///     HierarchyNode { parent: Some(0), local: Affine3A::from_translation(Vec3::Y), geometry: Some(7) },
/// ];
/// let flat = flatten(&nodes)?;
/// assert_eq!(flat, vec![(7, Affine3A::from_translation(Vec3::new(1.0, 1.0, 0.0)))]);
/// # Ok::<(), packtrace::scene::HierarchyError>(())
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HierarchyNode {
    /// The parent's index, which must come before this node (`None`: a root).
    pub parent: Option<usize>,
    /// Transform from this node's space to its parent's.
    pub local: Affine3A,
    /// A geometry id to instance with the node's world transform.
    pub geometry: Option<u32>,
}

/// Why [`flatten`] refused a hierarchy.
///
/// ```
/// use packtrace::glam::Affine3A;
/// use packtrace::scene::{HierarchyError, HierarchyNode, flatten};
/// let n = HierarchyNode { parent: Some(0), local: Affine3A::IDENTITY, geometry: None };
/// assert_eq!(flatten(&[n]), Err(HierarchyError::ParentNotBefore { node: 0, parent: 0 }));
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HierarchyError {
    /// A node's parent is not an earlier node (which also rules out cycles).
    ParentNotBefore {
        /// The node.
        node: usize,
        /// Its parent index.
        parent: usize,
    },
}

impl fmt::Display for HierarchyError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let HierarchyError::ParentNotBefore { node, parent } = self;
        write!(
            f,
            "hierarchy node {node} names parent {parent}, which does not come before it"
        )
    }
}

impl std::error::Error for HierarchyError {}

/// Flattens a transform hierarchy into `(geometry, world transform)`
/// pairs, one per node with a geometry, in node order (lecture notes 004:
/// a small scene graph becomes a flat list of instances). Transforms are
/// composed in f32 from the root down; check each with
/// [`Transform::new`] (which `SceneEdit::add_instance` does).
///
/// # Errors
/// [`HierarchyError::ParentNotBefore`] when a node's parent is not an
/// earlier node.
pub fn flatten(nodes: &[HierarchyNode]) -> Result<Vec<(u32, Affine3A)>, HierarchyError> {
    let mut world: Vec<Affine3A> = Vec::with_capacity(nodes.len());
    let mut out = Vec::new();
    for (i, n) in nodes.iter().enumerate() {
        let w = match n.parent {
            None => n.local,
            Some(p) if p < i => world[p] * n.local,
            Some(p) => return Err(HierarchyError::ParentNotBefore { node: i, parent: p }),
        };
        world.push(w);
        if let Some(g) = n.geometry {
            out.push((g, w));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::F4;
    use glam::Quat;

    fn rotated() -> Transform {
        Transform::new(Affine3A::from_scale_rotation_translation(
            Vec3::new(1.5, 0.5, 2.0),
            Quat::from_euler(glam::EulerRot::XYZ, 0.3, -1.1, 2.0),
            Vec3::new(3.0, -2.0, 7.0),
        ))
        .unwrap()
    }

    #[test]
    fn lanes_equal_the_scalar_transform_bit_for_bit() {
        let t = rotated();
        let o = [
            [1.0f32, -3.0, 1e4, 0.1],
            [2.0, 0.5, -7.0, 1e-3],
            [0.0, 9.0, 3.0, -2.5],
        ];
        let d = [
            [0.3f32, -1.0, 0.0, 2.0],
            [1.0, 0.2, 0.0, -0.0],
            [-0.5, 0.1, 1.0, 3.0],
        ];
        let (o4, d4) = t.lanes_to_object(&o.map(F4::from), &d.map(F4::from));
        for i in 0..4 {
            let (o1, d1) =
                t.lanes_to_object(&[o[0][i], o[1][i], o[2][i]], &[d[0][i], d[1][i], d[2][i]]);
            for a in 0..3 {
                assert_eq!(o4[a].lane(i).to_bits(), o1[a].to_bits());
                assert_eq!(d4[a].lane(i).to_bits(), d1[a].to_bits());
            }
        }
    }

    /// The scalar query's SIMD-by-columns transform equals the lane
    /// (row) form bit for bit, including the flush of tiny components.
    #[test]
    fn the_column_form_equals_the_row_form_bit_for_bit() {
        let mirrored = Transform::new(Affine3A::from_cols_array(&[
            -1.0, 0.0, 0.0, 0.3, 1e-3, 0.0, 0.0, 0.2, 4.0, 1e5, -2.0, 0.5,
        ]))
        .unwrap();
        for t in [rotated(), mirrored, Transform::IDENTITY] {
            for (o, d) in [
                (Vec3::new(1.0, -3.0, 1e4), Vec3::new(0.3, -1.0, 0.0)),
                (Vec3::new(0.1, 1e-3, -2.5), Vec3::new(1e-39, 0.0, -0.0)),
                (Vec3::new(0.1, 1e-3, -2.5), Vec3::new(3e-38, 1.0, -0.0)),
                (Vec3::new(-7.0, 9.0, 3.0), Vec3::new(-0.5, 0.1, 1.0)),
                (Vec3::new(1e6, -1e6, 0.0), Vec3::new(2.0, 1e-30, -3.0)),
            ] {
                let world = Ray::new_unchecked(o, d, 0.5, 9.0);
                let r = t.ray_to_object(&world, 7.0);
                let (o1, d1) = t.lanes_to_object(&o.to_array(), &world.dir.to_array());
                let want = Ray::new_unchecked(Vec3::from(o1), Vec3::from(d1), 0.5, 7.0);
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(r.origin), bits(want.origin), "{o:?}");
                assert_eq!(bits(r.dir), bits(want.dir), "{d:?}");
                assert_eq!(bits(r.inv_dir), bits(want.inv_dir), "{d:?}");
                assert_eq!((r.t_min, r.t_max), (0.5, 7.0));
            }
        }
    }

    #[test]
    fn world_bounds_contain_every_mapped_corner() {
        let t = rotated();
        let b = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(3.0, 0.5, 2.0));
        let w = t.world_bounds(&b);
        for c in 0..8 {
            let p = Vec3::new(
                if c & 1 == 0 { -1.0 } else { 3.0 },
                if c & 2 == 0 { 0.0 } else { 0.5 },
                2.0,
            );
            let q = Vec3A::from(t.to_world().transform_point3(p));
            assert!(q.cmpge(w.min - 1e-4).all() && q.cmple(w.max + 1e-4).all());
        }
        assert_eq!(t.world_bounds(&Aabb::EMPTY), Aabb::EMPTY);
    }

    #[test]
    fn singular_and_ill_conditioned_transforms_are_refused() {
        let m = |x: f32| Affine3A::from_scale(Vec3::new(1.0, x, 1.0));
        assert!(Transform::new(m(1e-3)).is_ok());
        assert!(matches!(
            Transform::new(m(1e-7)),
            Err(TransformError::Singular { condition }) if condition > MAX_CONDITION
        ));
        assert_eq!(
            Transform::new(m(0.0)),
            Err(TransformError::Singular {
                condition: f64::INFINITY
            })
        );
        // Inverse overflows f32.
        assert!(Transform::new(Affine3A::from_scale(Vec3::splat(1e-39))).is_err());
        let e = Transform::new(m(0.0)).unwrap_err().to_string();
        assert!(e.contains("singular"), "{e}");
    }

    #[test]
    fn mirrored_transforms_map_normals_by_the_inverse_transpose() {
        let t = Transform::new(Affine3A::from_scale(Vec3::new(-1.0, 2.0, 1.0))).unwrap();
        assert_eq!(t.normal_to_world(Vec3::X), Vec3::NEG_X);
        // A plane y = x in object space becomes y = 2x: normal (2, -1)/sqrt 5.
        let n = t.normal_to_world(Vec3::new(1.0, -1.0, 0.0).normalize());
        assert!((n - Vec3::new(-2.0, -1.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn hierarchies_compose_parent_first() {
        let r = Affine3A::from_rotation_z(std::f32::consts::FRAC_PI_2);
        let nodes = [
            HierarchyNode {
                parent: None,
                local: r,
                geometry: Some(0),
            },
            HierarchyNode {
                parent: Some(0),
                local: Affine3A::from_translation(Vec3::X),
                geometry: Some(1),
            },
        ];
        let f = flatten(&nodes).unwrap();
        assert_eq!(f[0], (0, r));
        let p = f[1].1.transform_point3(Vec3::ZERO);
        assert!((p - Vec3::Y).length() < 1e-6);
    }
}
