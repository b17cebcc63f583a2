//! Wavefront OBJ loading. [`load_obj`] gives the [`Mesh`] the benchmark
//! protocol reads (docs/PROTOCOL.md, "Scenes"): triangles in file order,
//! polygons fan-triangulated, positions only. [`load_obj_with_shading`]
//! also keeps what a renderer shades with: per-corner normals and texture
//! coordinates and per-triangle materials ([`ObjMesh`]).
//!
//! Both keep the file's numbering: position `k` of the mesh is the file's
//! `(k + 1)`-th `v` line (so a host can index its own per-vertex data
//! through [`Mesh::triangles`]), and the same for `vt` and `vn`.
//!
//! The statements are read by the loader's own line pass (`scan`), which
//! checks each one and reports the first problem with the file name and
//! the 1-based line. `tobj` renumbers vertices per object and, in 4.0.5,
//! panics on some attribute indices (docs/testing.md, finding 6), so it reads
//! only the material libraries (`.mtl`) named by `mtllib`.

mod scan;
mod shading;

pub use shading::{
    Material, ObjMesh, ObjPart, interpolate, load_obj_with_shading, parse_obj_bytes_with_shading,
};

use crate::mesh::{Mesh, MeshError};
use glam::Vec3;
use scan::{ParseError, Read, scan};
use std::fmt;
use std::path::{Path, PathBuf};

/// Why an OBJ file could not be turned into a [`Mesh`]. Every variant names
/// the file ([`LoadError::path`]); every error found in a particular line
/// names that line too ([`LoadError::line`], 1-based as in text editors).
///
/// The `Display` form is `file:line: what is wrong`, for example
/// `scene.obj:12: vertex 7 has a non-finite coordinate (x = inf), used by
/// the face on line 20`.
///
/// ```
/// use packtrace::{LoadError, parse_obj_bytes};
/// let e = parse_obj_bytes(b"v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err();
/// assert!(matches!(e, LoadError::IndexOutOfRange { line: 3, index: 3, vertex_count: 2, .. }));
/// assert_eq!(e.line(), Some(3));
/// assert_eq!(
///     e.to_string(),
///     "<memory>:3: face index 3 names no vertex: 2 vertices are defined above this line"
/// );
/// ```
#[derive(Debug)]
pub enum LoadError {
    /// The file could not be opened or read.
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A malformed line: a number that does not parse, a `v` line with the
    /// wrong number of values or `w = 0`, a face corner without a position
    /// index, a face without corners, a `usemtl` without a name, bytes that
    /// are not UTF-8; with [`load_obj_with_shading`] also a `vt` or `vn`
    /// line with the wrong number of values or a value that is not a
    /// finite number, and an `mtllib` without a file name.
    Parse {
        /// The file.
        path: PathBuf,
        /// The line (1-based).
        line: usize,
        /// What is wrong with the line.
        message: String,
    },
    /// A face index names no vertex: index 0, an index past the vertices
    /// defined above the face, or a relative (negative) index that reaches
    /// before the first vertex.
    IndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// The face's line (1-based).
        line: usize,
        /// The index as written (negative for a relative index).
        index: i64,
        /// How many vertices are defined above the face's line.
        vertex_count: usize,
    },
    /// With [`load_obj_with_shading`]: a face corner's texture coordinate
    /// or normal index names no `vt` / `vn` line above the face (index 0,
    /// past the last one, or relative and before the first).
    AttributeIndexOutOfRange {
        /// The file.
        path: PathBuf,
        /// The face's line (1-based).
        line: usize,
        /// Which index.
        attribute: Attribute,
        /// The index as written (negative for a relative index).
        index: i64,
        /// How many of that attribute are defined above the face's line.
        count: usize,
    },
    /// A face uses a vertex with a NaN or infinite coordinate (after the
    /// optional `w` division). A vertex no face uses may be non-finite.
    NonFiniteVertex {
        /// The file.
        path: PathBuf,
        /// The vertex's `v` line (1-based).
        line: usize,
        /// The vertex number as in the file (1-based: the first `v` line is
        /// vertex 1).
        vertex: usize,
        /// Its position.
        value: Vec3,
        /// The line of the first face that uses it (1-based).
        face_line: usize,
    },
    /// The file parsed but holds no triangle (faces with one or two
    /// corners are points and lines, and are ignored).
    NoTriangles {
        /// The file.
        path: PathBuf,
    },
    /// With [`load_obj_with_shading`]: a material library named by an
    /// `mtllib` line could not be read or is not valid MTL.
    MaterialLibrary {
        /// The OBJ file.
        path: PathBuf,
        /// The `mtllib` line (1-based).
        line: usize,
        /// The library's path (the name resolved against the OBJ file's
        /// folder).
        library: PathBuf,
        /// What went wrong (the OS error or tobj's).
        message: String,
    },
    /// The triangles do not make a valid [`Mesh`] (more than `u32` can
    /// index). Index and vertex problems are reported with their line as
    /// [`LoadError::IndexOutOfRange`] and [`LoadError::NonFiniteVertex`].
    Mesh {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: MeshError,
    },
}

impl LoadError {
    /// The file the error is about (`<memory>` for [`parse_obj_bytes`]).
    ///
    /// ```
    /// let e = packtrace::load_obj("no/such/file.obj").unwrap_err();
    /// assert_eq!(e.path(), std::path::Path::new("no/such/file.obj"));
    /// ```
    pub fn path(&self) -> &Path {
        match self {
            LoadError::Io { path, .. }
            | LoadError::Parse { path, .. }
            | LoadError::IndexOutOfRange { path, .. }
            | LoadError::AttributeIndexOutOfRange { path, .. }
            | LoadError::MaterialLibrary { path, .. }
            | LoadError::NonFiniteVertex { path, .. }
            | LoadError::NoTriangles { path }
            | LoadError::Mesh { path, .. } => path,
        }
    }

    /// The 1-based line at fault, if the error is about one line (for
    /// [`LoadError::NonFiniteVertex`], the vertex's `v` line).
    ///
    /// ```
    /// let e = packtrace::parse_obj_bytes(b"v 0 0 0\nv 1 x 0\n").unwrap_err();
    /// assert_eq!(e.line(), Some(2));
    /// assert_eq!(e.to_string(), "<memory>:2: vertex coordinate `x` is not a number");
    /// assert_eq!(packtrace::parse_obj_bytes(b"").unwrap_err().line(), None);
    /// ```
    pub fn line(&self) -> Option<usize> {
        match self {
            LoadError::Parse { line, .. }
            | LoadError::IndexOutOfRange { line, .. }
            | LoadError::AttributeIndexOutOfRange { line, .. }
            | LoadError::MaterialLibrary { line, .. }
            | LoadError::NonFiniteVertex { line, .. } => Some(*line),
            LoadError::Io { .. } | LoadError::NoTriangles { .. } | LoadError::Mesh { .. } => None,
        }
    }
}

/// `1 vertex`, `2 vertices`.
fn vertices(n: usize) -> String {
    if n == 1 {
        "1 vertex is".to_string()
    } else {
        format!("{n} vertices are")
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let path = self.path().display();
        match self {
            LoadError::Io { .. } => write!(f, "{path}: cannot read the file"),
            LoadError::Parse { line, message, .. } => write!(f, "{path}:{line}: {message}"),
            LoadError::AttributeIndexOutOfRange {
                line,
                attribute,
                index,
                count,
                ..
            } => {
                let defined = match count {
                    1 => format!("1 {attribute} is"),
                    n => format!("{n} {attribute}s are"),
                };
                write!(
                    f,
                    "{path}:{line}: {attribute} index {index} names none: \
                     {defined} defined above this line"
                )
            }
            LoadError::MaterialLibrary {
                line,
                library,
                message,
                ..
            } => write!(
                f,
                "{path}:{line}: material library {}: {message}",
                library.display()
            ),
            LoadError::IndexOutOfRange {
                line,
                index,
                vertex_count,
                ..
            } => {
                write!(f, "{path}:{line}: ")?;
                let defined = vertices(*vertex_count);
                match index {
                    0 => write!(f, "face index 0 is invalid (OBJ indices start at 1)"),
                    i if *i < 0 => write!(
                        f,
                        "relative face index {i} reaches before the first vertex: \
                         {defined} defined above this line"
                    ),
                    i => write!(
                        f,
                        "face index {i} names no vertex: {defined} defined above this line"
                    ),
                }
            }
            LoadError::NonFiniteVertex {
                line,
                vertex,
                value,
                face_line,
                ..
            } => {
                let (axis, v) = ["x", "y", "z"]
                    .into_iter()
                    .zip(value.to_array())
                    .find(|(_, v)| !v.is_finite())
                    .unwrap_or(("x", value.x));
                write!(
                    f,
                    "{path}:{line}: vertex {vertex} has a non-finite coordinate ({axis} = {v}), \
                     used by the face on line {face_line}"
                )
            }
            LoadError::NoTriangles { .. } => write!(f, "{path}: the file holds no triangle"),
            LoadError::Mesh { .. } => write!(f, "{path}: the faces do not make a valid mesh"),
        }
    }
}

/// `Display` says what failed at this level and `source()` gives the
/// cause (the OS error, the mesh error), never both: a chain printer
/// shows each once (`bench` and `render` print `error: a: b`).
impl std::error::Error for LoadError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            LoadError::Io { source, .. } => Some(source),
            LoadError::Mesh { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Load an OBJ file as one mesh: all objects in file order, each face
/// fan-triangulated (`v0 vi vi+1`). Only positions are read: `vt`, `vn`,
/// `vp`, `l`, `p`, `o`, `g`, `s`, `mtllib` and unknown statements are
/// ignored, as are the texture and normal indices of face corners (they
/// must be integers, but need not name anything). Faces with one or two
/// corners are ignored. A face may only use vertices defined above it.
/// The mesh keeps the file's numbering: `positions()[k]` is the file's
/// vertex `k + 1`, including vertices no face uses (which [`Mesh`]
/// ignores). For normals, texture coordinates and materials use
/// [`load_obj_with_shading`].
///
/// # Errors
/// Each error names the file; those about one line name the line too:
/// - [`LoadError::Io`]: the file is missing or unreadable.
/// - [`LoadError::Parse`] (with the line): bytes that are not UTF-8, a
///   vertex coordinate or `w` that is not a number, a `v` line with other
///   than 3, 4 (`x y z w`) or 6 (`x y z r g b`) values, `w = 0`, a face
///   corner without a position index or with an index that is not an
///   integer, a face line without corners, `usemtl` without a name.
/// - [`LoadError::IndexOutOfRange`] (with the line): face index 0, past
///   the vertices defined so far, or relative and before the first vertex.
/// - [`LoadError::NonFiniteVertex`] (with the vertex's line, the file's
///   vertex number and the face line that uses it): a NaN or infinite
///   coordinate (`1e39` overflows to infinity) in a vertex a face uses.
/// - [`LoadError::NoTriangles`]: no face with three or more corners.
/// - [`LoadError::Mesh`]: more triangles than a `u32` index can name.
///
/// ```
/// // Vertex 2 is unused and stays: the mesh's numbering is the file's.
/// let m = packtrace::parse_obj_bytes(b"v 0 0 0\nv 5 5 5\nv 1 0 0\nv 0 1 0\nf 1 3 4\n")?;
/// assert_eq!(m.positions().len(), 4);
/// assert_eq!(m.triangles(), &[[0, 2, 3]]);
///
/// let e = packtrace::load_obj("no/such/file.obj").unwrap_err();
/// assert!(matches!(e, packtrace::LoadError::Io { .. }));
/// assert_eq!(e.to_string(), "no/such/file.obj: cannot read the file");
/// // The OS error is the source, not repeated in the message.
/// let os = std::error::Error::source(&e).unwrap().downcast_ref::<std::io::Error>().unwrap();
/// assert_eq!(os.kind(), std::io::ErrorKind::NotFound);
/// # Ok::<(), packtrace::LoadError>(())
/// ```
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh, LoadError> {
    let path = path.as_ref();
    parse_obj(&read(path)?).map_err(|e| e.at(path))
}

/// The file's bytes, or [`LoadError::Io`] naming it.
fn read(path: &Path) -> Result<Vec<u8>, LoadError> {
    std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Which per-corner attribute an index names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Attribute {
    /// A texture coordinate (`vt`), the second index of `v/vt/vn`.
    TextureCoordinate,
    /// A normal (`vn`), the third index of `v/vt/vn`.
    Normal,
}

impl fmt::Display for Attribute {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Attribute::TextureCoordinate => "texture coordinate",
            Attribute::Normal => "normal",
        })
    }
}

impl ParseError {
    /// The public error, with the file name.
    fn at(self, path: &Path) -> LoadError {
        let path = path.to_path_buf();
        match self {
            ParseError::Syntax { line, message } => LoadError::Parse {
                path,
                line,
                message,
            },
            ParseError::Index {
                line,
                index,
                vertex_count,
            } => LoadError::IndexOutOfRange {
                path,
                line,
                index,
                vertex_count,
            },
            ParseError::AttributeIndex {
                line,
                attribute,
                index,
                count,
            } => LoadError::AttributeIndexOutOfRange {
                path,
                line,
                attribute,
                index,
                count,
            },
            ParseError::NonFinite {
                line,
                vertex,
                value,
                face_line,
            } => LoadError::NonFiniteVertex {
                path,
                line,
                vertex,
                value,
                face_line,
            },
            ParseError::NoTriangles => LoadError::NoTriangles { path },
            ParseError::Mesh(source) => LoadError::Mesh { path, source },
        }
    }
}

/// Parse OBJ text held in memory (used by `load_obj` and the fuzz target).
///
/// # Errors
/// As [`load_obj`] (except [`LoadError::Io`]), with `<memory>` as the file
/// name.
///
/// ```
/// use packtrace::{LoadError, parse_obj_bytes};
/// let m = parse_obj_bytes(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
/// assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3]]);
///
/// let e = parse_obj_bytes(b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 3 1 2\n").unwrap_err();
/// assert!(matches!(e, LoadError::NonFiniteVertex { line: 3, vertex: 3, face_line: 4, .. }));
/// assert_eq!(
///     e.to_string(),
///     "<memory>:3: vertex 3 has a non-finite coordinate (x = NaN), used by the face on line 4"
/// );
/// ```
pub fn parse_obj_bytes(bytes: &[u8]) -> Result<Mesh, LoadError> {
    parse_obj(bytes).map_err(|e| e.at(Path::new("<memory>")))
}

fn parse_obj(bytes: &[u8]) -> Result<Mesh, ParseError> {
    let s = scan(bytes, Read::Positions)?;
    Mesh::new(s.positions, s.triangles).map_err(ParseError::Mesh)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each level says its own part once: the message names the file and
    /// what failed, the source gives the cause.
    #[test]
    fn errors_do_not_repeat_their_source() {
        let io = load_obj("no/such/file.obj").unwrap_err();
        let mesh = LoadError::Mesh {
            path: PathBuf::from("big.obj"),
            source: MeshError::TooManyTriangles(1 << 33),
        };
        for (e, own) in [
            (&io, "no/such/file.obj: cannot read the file"),
            (&mesh, "big.obj: the faces do not make a valid mesh"),
        ] {
            let source = std::error::Error::source(e).expect("has a source");
            assert_eq!(e.to_string(), own);
            assert!(!e.to_string().contains(&source.to_string()));
        }
    }
}
