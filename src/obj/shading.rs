//! What a renderer shades with, from the OBJ file: per-corner normals and
//! texture coordinates in the file's own numbering, per-triangle
//! materials with their diffuse colour (`Kd`) and emitted radiance (`Ke`),
//! read by `tobj` from the `mtllib` files, and barycentric interpolation
//! from a [`Hit`].

use super::scan::{NONE, Read, Scan, scan};
use super::{LoadError, ParseError};
use crate::mesh::Mesh;
use crate::ray::Hit;
use glam::{Vec2, Vec3};
use std::ops::{Add, Mul};
use std::path::Path;

/// Interpolate per-corner values at a hit: `(1 - u - v) a + u b + v c`,
/// the weights of [`Hit::u`] and [`Hit::v`] (the same that give the hit
/// point from the triangle's corners).
///
/// ```
/// use packtrace::glam::Vec2;
/// use packtrace::{Hit, obj::interpolate};
/// let hit = Hit { t: 1.0, prim: 0, u: 0.25, v: 0.5 };
/// let uv = interpolate([Vec2::ZERO, Vec2::X, Vec2::Y], &hit);
/// assert_eq!(uv, Vec2::new(0.25, 0.5));
/// assert_eq!(interpolate([1.0, 3.0, 5.0], &hit), 0.25 + 0.75 + 2.5);
/// ```
#[must_use]
pub fn interpolate<T>(corners: [T; 3], hit: &Hit) -> T
where
    T: Copy + Mul<f32, Output = T> + Add<Output = T>,
{
    corners[0] * (1.0 - hit.u - hit.v) + corners[1] * hit.u + corners[2] * hit.v
}

/// A material named by `usemtl`, with what its library says about it.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// The name after `usemtl`.
    pub name: String,
    /// The diffuse colour (`Kd`, linear RGB as written) from the `mtllib`
    /// files; `None` if no library defines the material or it has no
    /// `Kd`, or the file was parsed from memory.
    pub diffuse: Option<Vec3>,
    /// The emitted radiance (`Ke`, linear RGB as written) from the
    /// `mtllib` files: what makes a triangle an area light for the path
    /// tracer (`render::path`); `None` as for `diffuse`.
    pub emission: Option<Vec3>,
}

/// A named part of an OBJ file (an `o` object or a `g` group): the
/// triangles from its statement to the next statement of its kind (or the
/// end of the file).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ObjPart {
    /// The name(s) after `o` or `g`, as written (several group names are
    /// kept together, separated by one space; empty if none is given).
    pub name: String,
    /// The triangle indices it covers (empty if no face follows it).
    pub triangles: std::ops::Range<u32>,
}

/// An OBJ file's mesh with its shading data ([`load_obj_with_shading`]).
///
/// The mesh is exactly [`load_obj`](crate::load_obj)'s (same triangles,
/// same file numbering). A triangle has normals (texture coordinates) when
/// all three of its corners name a `vn` (`vt`); a face that names them
/// for some corners only gives triangles without them.
///
/// ```
/// use packtrace::glam::{Vec2, Vec3};
/// use packtrace::{KdBuildParams, KdTree, Ray, parse_obj_bytes_with_shading};
/// let obj = parse_obj_bytes_with_shading(b"\
/// v 0 0 0\nv 1 0 0\nv 0 1 0\n\
/// vt 0 0\nvt 1 0\nvt 0 1\n\
/// vn 0 0 1\nvn 1 0 1\n\
/// usemtl red\n\
/// f 1/1/1 2/2/2 3/3/1\n")?;
/// assert_eq!(obj.normal_indices(0), Some([0, 1, 0]));
///
/// let tree = KdTree::build(obj.mesh().clone(), &KdBuildParams::default())?;
/// let hit = tree
///     .intersect(&Ray::new(Vec3::new(0.5, 0.25, 1.0), Vec3::NEG_Z, 0.0, 9.0)?)
///     .unwrap();
/// assert_eq!(obj.texcoord(&hit), Some(Vec2::new(0.5, 0.25)));
/// // Half way from (0, 0, 1) to (1, 0, 1), normalised.
/// let n = obj.shading_normal(&hit);
/// assert!((n - Vec3::new(0.5, 0.0, 1.0).normalize()).length() < 1e-6);
/// assert_eq!(obj.material(hit.prim).unwrap().name, "red");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct ObjMesh {
    mesh: Mesh,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
    tri_texcoords: Vec<[u32; 3]>,
    tri_normals: Vec<[u32; 3]>,
    materials: Vec<Material>,
    tri_materials: Vec<u32>,
    objects: Vec<ObjPart>,
    groups: Vec<ObjPart>,
}

impl ObjMesh {
    /// The file's `o` objects in file order, with their triangle ranges
    /// (triangles before the first `o` belong to none). A host that needs
    /// them apart can build one tree per range.
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\
    ///     o a\nf 1 2 3\nf 1 2 3\no b\nf 1 2 3\n")?;
    /// let parts: Vec<_> = obj.objects().iter().map(|o| (o.name.as_str(), o.triangles.clone())).collect();
    /// assert_eq!(parts, [("a", 0..2), ("b", 2..3)]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn objects(&self) -> &[ObjPart] {
        &self.objects
    }

    /// The file's `g` groups in file order, as [`ObjMesh::objects`].
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n\
    ///     f 1 2 3\ng wall left\nf 1 2 3\n")?;
    /// assert_eq!(obj.groups()[0].name, "wall left");
    /// assert_eq!(obj.groups()[0].triangles, 1..2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn groups(&self) -> &[ObjPart] {
        &self.groups
    }

    /// The triangles, as [`load_obj`](crate::load_obj) gives them.
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.mesh().triangle_count(), 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The mesh alone (to build a tree from it).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// let tree = packtrace::KdTree::build(obj.into_mesh(), &Default::default())?;
    /// assert_eq!(tree.mesh().triangle_count(), 2);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn into_mesh(self) -> Mesh {
        self.mesh
    }

    /// Every `vt` line of the file, in order (`u v`; `v` is 0 when the
    /// line gives only `u`).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.texcoords()[1], packtrace::glam::Vec2::X);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn texcoords(&self) -> &[Vec2] {
        &self.texcoords
    }

    /// Every `vn` line of the file, in order, as written (not
    /// normalised).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.normals(), &[packtrace::glam::Vec3::new(0.0, 0.0, 2.0)]);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// The materials in order of their first `usemtl`.
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.materials()[0].name, "m");
    /// assert_eq!(obj.materials()[0].diffuse, None); // parsed from memory: no library read
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn materials(&self) -> &[Material] {
        &self.materials
    }

    /// The 0-based `vt` numbers of triangle `prim`'s corners, if all three
    /// name one (`None` also for a `prim` past the last triangle).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.texcoord_indices(0), Some([0, 1, 2]));
    /// assert_eq!(obj.texcoord_indices(1), None);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn texcoord_indices(&self, prim: u32) -> Option<[u32; 3]> {
        complete(self.tri_texcoords.get(prim as usize)?)
    }

    /// The 0-based `vn` numbers of triangle `prim`'s corners, if all three
    /// name one.
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.normal_indices(0), Some([0, 0, 0]));
    /// assert_eq!(obj.normal_indices(1), None);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn normal_indices(&self, prim: u32) -> Option<[u32; 3]> {
        complete(self.tri_normals.get(prim as usize)?)
    }

    /// The material of triangle `prim` (`None` before the file's first
    /// `usemtl`).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// assert_eq!(obj.material(1).map(|m| m.name.as_str()), Some("m"));
    /// assert!(obj.material(2).is_none());
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn material(&self, prim: u32) -> Option<&Material> {
        let &k = self.tri_materials.get(prim as usize)?;
        self.materials.get(k as usize)
    }

    /// The texture coordinate at a hit, interpolated from the corners
    /// (`None` if the triangle has none).
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// let hit = packtrace::Hit { t: 1.0, prim: 0, u: 0.5, v: 0.25 };
    /// assert_eq!(obj.texcoord(&hit), Some(packtrace::glam::Vec2::new(0.5, 0.25)));
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn texcoord(&self, hit: &Hit) -> Option<Vec2> {
        let i = self.texcoord_indices(hit.prim)?;
        Some(interpolate(i.map(|k| self.texcoords[k as usize]), hit))
    }

    /// The unit shading normal at a hit: the corners' normals interpolated
    /// and normalised, or the geometric normal ([`Mesh::normal`]) where the
    /// triangle has no normals or they cancel out. It points wherever the
    /// file's normals point; flip it toward the viewer if you need to.
    ///
    /// ```
    /// let obj = packtrace::parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 2\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nf 1 2 3\n")?;
    /// let hit = packtrace::Hit { t: 1.0, prim: 0, u: 0.5, v: 0.25 };
    /// assert_eq!(obj.shading_normal(&hit), packtrace::glam::Vec3::Z);
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    ///
    /// # Panics
    /// If `hit.prim` is not a triangle of this mesh.
    #[must_use]
    pub fn shading_normal(&self, hit: &Hit) -> Vec3 {
        self.normal_indices(hit.prim)
            .and_then(|i| interpolate(i.map(|k| self.normals[k as usize]), hit).try_normalize())
            .unwrap_or_else(|| self.mesh.normal(hit.prim as usize))
    }
}

/// The corner numbers if all three are present.
fn complete(c: &[u32; 3]) -> Option<[u32; 3]> {
    c.iter().all(|&k| k != NONE).then_some(*c)
}

/// Load an OBJ file with its shading data: the mesh of
/// [`load_obj`](crate::load_obj), the `vt` and `vn` lines and each face
/// corner's indices into them, and the materials named by `usemtl` with
/// their diffuse colour and emission from the libraries named by `mtllib` (resolved
/// against the OBJ file's folder and read with `tobj`).
///
/// # Errors
/// Everything [`load_obj`](crate::load_obj) reports, and:
/// - [`LoadError::Parse`]: a `vt` line with other than 1 to 3 values, a
///   `vn` line with other than 3, a value there that is not a finite
///   number, an `mtllib` line without a file name.
/// - [`LoadError::AttributeIndexOutOfRange`]: a corner's texture or normal
///   index names no `vt` / `vn` line above the face.
/// - [`LoadError::MaterialLibrary`]: an `mtllib` file is missing,
///   unreadable or not valid MTL, or gives a non-finite `Kd` or `Ke`.
///
/// ```
/// let e = packtrace::load_obj_with_shading("no/such/file.obj").unwrap_err();
/// assert_eq!(e.to_string(), "no/such/file.obj: cannot read the file");
/// ```
pub fn load_obj_with_shading(path: impl AsRef<Path>) -> Result<ObjMesh, LoadError> {
    let path = path.as_ref();
    let s = scan(&super::read(path)?, Read::Shading).map_err(|e| e.at(path))?;
    let folder = path.parent().unwrap_or(Path::new(""));
    let mut colours = std::collections::HashMap::new();
    for (line, name) in &s.libraries {
        let library = folder.join(name);
        let fail = |message: String| LoadError::MaterialLibrary {
            path: path.to_path_buf(),
            line: *line,
            library: library.clone(),
            message,
        };
        let text = std::fs::read(&library).map_err(|e| fail(e.to_string()))?;
        let (materials, _) =
            tobj::load_mtl_buf(&mut text.as_slice()).map_err(|e| fail(e.to_string()))?;
        for m in materials {
            let colour = |key: &str, c: Option<[f32; 3]>| match c.map(Vec3::from_array) {
                Some(c) if !c.is_finite() => Err(fail(format!(
                    "material `{}`: {key} {c} is not finite",
                    m.name
                ))),
                c => Ok(c),
            };
            let kd = colour("Kd", m.diffuse)?;
            let ke = colour("Ke", m.emissive)?;
            if kd.is_some() || ke.is_some() {
                // The first library to define a name wins, as in tobj.
                colours.entry(m.name).or_insert((kd, ke));
            }
        }
    }
    assemble(s, |name| colours.get(name).copied().unwrap_or_default()).map_err(|e| e.at(path))
}

/// [`load_obj_with_shading`] for OBJ text held in memory: `mtllib` lines
/// are checked but no library is read, so every material's `diffuse` is
/// `None`.
///
/// # Errors
/// As [`load_obj_with_shading`] (except [`LoadError::Io`] and
/// [`LoadError::MaterialLibrary`]), with `<memory>` as the file name.
///
/// ```
/// use packtrace::{LoadError, obj::Attribute, parse_obj_bytes_with_shading};
/// let e = parse_obj_bytes_with_shading(b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//2 3//1\n")
///     .unwrap_err();
/// assert!(matches!(
///     e,
///     LoadError::AttributeIndexOutOfRange { line: 5, attribute: Attribute::Normal, index: 2, count: 1, .. }
/// ));
/// assert_eq!(
///     e.to_string(),
///     "<memory>:5: normal index 2 names none: 1 normal is defined above this line"
/// );
/// ```
pub fn parse_obj_bytes_with_shading(bytes: &[u8]) -> Result<ObjMesh, LoadError> {
    let at = |e: ParseError| e.at(Path::new("<memory>"));
    let s = scan(bytes, Read::Shading).map_err(at)?;
    assemble(s, |_| (None, None)).map_err(at)
}

/// The [`ObjMesh`] of a shading scan, with each material's diffuse colour
/// and emission from `colours`.
#[allow(clippy::type_complexity)]
fn assemble(
    s: Scan,
    colours: impl Fn(&str) -> (Option<Vec3>, Option<Vec3>),
) -> Result<ObjMesh, ParseError> {
    let materials = s
        .material_names
        .into_iter()
        .map(|name| {
            let (diffuse, emission) = colours(&name);
            Material {
                diffuse,
                emission,
                name,
            }
        })
        .collect();
    let end = s.triangles.len() as u32;
    let parts = |starts: Vec<(String, u32)>| -> Vec<ObjPart> {
        let ends: Vec<u32> = starts.iter().skip(1).map(|p| p.1).chain([end]).collect();
        starts
            .into_iter()
            .zip(ends)
            .map(|((name, first), last)| ObjPart {
                name,
                triangles: first..last,
            })
            .collect()
    };
    let (objects, groups) = (parts(s.objects), parts(s.groups));
    Ok(ObjMesh {
        mesh: Mesh::new(s.positions, s.triangles).map_err(ParseError::Mesh)?,
        objects,
        groups,
        texcoords: s.texcoords,
        normals: s.normals,
        tri_texcoords: s.tri_texcoords,
        tri_normals: s.tri_normals,
        materials,
        tri_materials: s.tri_materials,
    })
}
