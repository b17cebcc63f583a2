//! Triangle meshes: positions, index triples, and the per-triangle data the
//! kernels read (corner positions, bounds, degeneracy).

use crate::aabb::Aabb;
use glam::{DVec3, Vec3, Vec3A};
use std::fmt;

/// A triangle mesh, validated on construction.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Mesh;
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// assert_eq!(m.triangle_count(), 1);
/// assert_eq!(m.bounds().max, glam::Vec3A::new(1.0, 1.0, 0.0));
/// ```
#[derive(Clone, Debug)]
pub struct Mesh {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    /// Corner positions per triangle, so kernels read one record, not two.
    corners: Vec<[Vec3; 3]>,
    tri_bounds: Vec<Aabb>,
    degenerate: Vec<bool>,
    bounds: Aabb,
}

/// Why [`Mesh::new`] refused its input.
#[derive(Clone, Debug, PartialEq)]
pub enum MeshError {
    /// A triangle names a vertex that does not exist.
    IndexOutOfRange {
        /// Triangle number (0-based).
        triangle: usize,
        /// The bad vertex index.
        index: u32,
        /// Number of vertices given.
        vertex_count: usize,
    },
    /// A vertex used by a triangle has a NaN or infinite coordinate.
    NonFiniteVertex {
        /// Vertex number (0-based).
        vertex: usize,
        /// Its value.
        value: Vec3,
    },
    /// More triangles than a `u32` index can name (the last value is
    /// reserved for "no triangle").
    TooManyTriangles(usize),
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::IndexOutOfRange {
                triangle,
                index,
                vertex_count,
            } => write!(
                f,
                "triangle {triangle} uses vertex {index}, but there are only {vertex_count} vertices"
            ),
            MeshError::NonFiniteVertex { vertex, value } => {
                write!(f, "vertex {vertex} is not finite: {value}")
            }
            MeshError::TooManyTriangles(n) => {
                write!(f, "{n} triangles exceed the limit of {}", u32::MAX - 1)
            }
        }
    }
}

impl std::error::Error for MeshError {}

/// Is the triangle's area zero? Evaluated in f64, where the products of
/// f32 differences are exact for the coordinates meshes use, so exactly
/// collinear corners are caught.
fn zero_area(c: &[Vec3; 3]) -> bool {
    let p: [DVec3; 3] = c.map(|v| v.as_dvec3());
    (p[1] - p[0]).cross(p[2] - p[0]) == DVec3::ZERO
}

impl Mesh {
    /// Build a mesh. Vertices no triangle uses are ignored (they need not be
    /// finite and do not count in the bounds, as docs/PROTOCOL.md says).
    /// Zero-area triangles are kept (indices stay stable) but are never hit.
    ///
    /// # Errors
    /// [`MeshError::IndexOutOfRange`], [`MeshError::NonFiniteVertex`],
    /// [`MeshError::TooManyTriangles`].
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Mesh, MeshError};
    /// let e = Mesh::new(vec![Vec3::ZERO], vec![[0, 1, 2]]).unwrap_err();
    /// assert!(matches!(e, MeshError::IndexOutOfRange { index: 1, .. }));
    /// assert!(Mesh::new(vec![], vec![]).unwrap().is_empty());
    /// ```
    pub fn new(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Result<Mesh, MeshError> {
        Mesh::check(&positions, &triangles)?;
        Ok(Mesh::assemble(positions, triangles))
    }

    /// A mesh whose indices and vertices are valid by construction (the
    /// generators'), so no error can arise; debug builds re-check.
    pub(crate) fn from_valid(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        debug_assert_eq!(Mesh::check(&positions, &triangles), Ok(()));
        Mesh::assemble(positions, triangles)
    }

    /// The first reason [`Mesh::new`] would refuse its input.
    fn check(positions: &[Vec3], triangles: &[[u32; 3]]) -> Result<(), MeshError> {
        if triangles.len() >= u32::MAX as usize {
            return Err(MeshError::TooManyTriangles(triangles.len()));
        }
        for (t, tri) in triangles.iter().enumerate() {
            for &i in tri {
                let p = positions
                    .get(i as usize)
                    .ok_or(MeshError::IndexOutOfRange {
                        triangle: t,
                        index: i,
                        vertex_count: positions.len(),
                    })?;
                if !p.is_finite() {
                    return Err(MeshError::NonFiniteVertex {
                        vertex: i as usize,
                        value: *p,
                    });
                }
            }
        }
        Ok(())
    }

    /// Per-triangle data of checked input (indices in range).
    fn assemble(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
        let mut corners = Vec::with_capacity(triangles.len());
        let mut tri_bounds = Vec::with_capacity(triangles.len());
        let mut degenerate = Vec::with_capacity(triangles.len());
        let mut bounds = Aabb::EMPTY;
        for tri in &triangles {
            let c = tri.map(|i| positions[i as usize]);
            let mut b = Aabb::EMPTY;
            for p in c {
                b.grow(Vec3A::from(p));
            }
            bounds = bounds.union(&b);
            degenerate.push(zero_area(&c));
            corners.push(c);
            tri_bounds.push(b);
        }
        Mesh {
            positions,
            triangles,
            corners,
            tri_bounds,
            degenerate,
            bounds,
        }
    }

    /// Number of triangles.
    ///
    /// ```
    /// assert_eq!(packtrace::Mesh::default().triangle_count(), 0);
    /// ```
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangles.len()
    }

    /// True when the mesh has no triangles.
    ///
    /// ```
    /// assert!(packtrace::Mesh::default().is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.triangles.is_empty()
    }

    /// Vertex positions as given.
    ///
    /// ```
    /// assert!(packtrace::Mesh::default().positions().is_empty());
    /// ```
    #[must_use]
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Vertex index triples.
    ///
    /// ```
    /// assert!(packtrace::Mesh::default().triangles().is_empty());
    /// ```
    #[must_use]
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Corner positions of triangle `i`.
    ///
    /// # Panics
    /// If `i >= triangle_count()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[2, 1, 0]]).unwrap();
    /// assert_eq!(m.corners(0)[0], Vec3::Y);
    /// ```
    #[must_use]
    pub fn corners(&self, i: usize) -> &[Vec3; 3] {
        &self.corners[i]
    }

    /// Bounding box of triangle `i`.
    ///
    /// # Panics
    /// If `i >= triangle_count()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// assert_eq!(m.triangle_bounds(0).min, glam::Vec3A::ZERO);
    /// ```
    #[must_use]
    pub fn triangle_bounds(&self, i: usize) -> &Aabb {
        &self.tri_bounds[i]
    }

    /// Is triangle `i` of zero area (and so never hit)?
    ///
    /// # Panics
    /// If `i >= triangle_count()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], vec![[0, 1, 2]]).unwrap();
    /// assert!(m.is_degenerate(0));
    /// ```
    #[must_use]
    pub fn is_degenerate(&self, i: usize) -> bool {
        self.degenerate[i]
    }

    /// Box of all triangle corners ([`Aabb::EMPTY`] for an empty mesh).
    ///
    /// ```
    /// assert!(packtrace::Mesh::default().bounds().is_empty());
    /// ```
    #[must_use]
    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// Geometric normal of triangle `i` (`normalize(cross(v1 - v0, v2 - v0))`,
    /// docs/PROTOCOL.md, "The workloads"); zero for a degenerate triangle.
    ///
    /// # Panics
    /// If `i >= triangle_count()`.
    ///
    /// ```
    /// use glam::Vec3;
    /// let m = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// assert_eq!(m.normal(0), Vec3::Z);
    /// ```
    #[must_use]
    pub fn normal(&self, i: usize) -> Vec3 {
        let c = &self.corners[i];
        (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero()
    }

    pub(crate) fn corner_slice(&self) -> &[[Vec3; 3]] {
        &self.corners
    }
}

impl Default for Mesh {
    /// The empty mesh.
    fn default() -> Mesh {
        Mesh {
            positions: Vec::new(),
            triangles: Vec::new(),
            corners: Vec::new(),
            tri_bounds: Vec::new(),
            degenerate: Vec::new(),
            bounds: Aabb::EMPTY,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_finite_used_vertex_but_ignores_unused_one() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::splat(f32::NAN)];
        assert!(Mesh::new(p.clone(), vec![[0, 1, 2]]).is_ok());
        let e = Mesh::new(p, vec![[0, 1, 3]]).unwrap_err();
        assert!(matches!(e, MeshError::NonFiniteVertex { vertex: 3, .. }));
        assert!(e.to_string().contains("vertex 3"));
    }

    #[test]
    fn bounds_ignore_unused_vertices() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::splat(100.0)];
        let m = Mesh::new(p, vec![[0, 1, 2]]).unwrap();
        assert_eq!(m.bounds().max, Vec3A::new(1.0, 1.0, 0.0));
    }

    #[test]
    fn degenerate_detection() {
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO];
        let m = Mesh::new(p, vec![[0, 1, 2], [0, 3, 1], [0, 0, 0]]).unwrap();
        assert!(!m.is_degenerate(0));
        assert!(m.is_degenerate(1));
        assert!(m.is_degenerate(2));
    }
}
