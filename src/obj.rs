//! Wavefront OBJ loading through `tobj`, as BENCH_PROTOCOL "Scene" says:
//! triangles in file order, polygons fan-triangulated, positions only.

use crate::mesh::{Mesh, MeshError};
use glam::Vec3;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why an OBJ file could not be turned into a [`Mesh`]. Every variant names
/// the file.
#[derive(Debug)]
pub enum LoadError {
    /// The file could not be opened or read.
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// `tobj` could not parse the file.
    Parse {
        /// The file.
        path: PathBuf,
        /// What `tobj` said.
        message: String,
    },
    /// The file parsed but holds no triangle.
    NoTriangles {
        /// The file.
        path: PathBuf,
    },
    /// The geometry is invalid (bad index, NaN or infinite vertex).
    Mesh {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: MeshError,
    },
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadError::Io { path, source } => write!(f, "{}: {source}", path.display()),
            LoadError::Parse { path, message } => {
                write!(f, "{}: not a valid OBJ file: {message}", path.display())
            }
            LoadError::NoTriangles { path } => {
                write!(f, "{}: the file holds no triangle", path.display())
            }
            LoadError::Mesh { path, source } => write!(f, "{}: {source}", path.display()),
        }
    }
}

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
/// fan-triangulated (`v0 vi vi+1`).
///
/// # Errors
/// [`LoadError::Io`] for a missing or unreadable file, [`LoadError::Parse`]
/// for malformed content, [`LoadError::NoTriangles`] for a file without
/// faces, [`LoadError::Mesh`] for an index out of range or a non-finite
/// vertex.
///
/// ```
/// let e = packtrace::load_obj("no/such/file.obj").unwrap_err();
/// assert!(matches!(e, packtrace::LoadError::Io { .. }));
/// assert!(e.to_string().contains("no/such/file.obj"));
/// ```
pub fn load_obj(path: impl AsRef<Path>) -> Result<Mesh, LoadError> {
    let path = path.as_ref();
    let bytes = std::fs::read(path).map_err(|source| LoadError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_obj(&bytes).map_err(|e| e.at(path))
}

/// A load error before the file name is attached.
pub(crate) enum ParseError {
    Parse(String),
    NoTriangles,
    Mesh(MeshError),
}

impl ParseError {
    fn at(self, path: &Path) -> LoadError {
        let path = path.to_path_buf();
        match self {
            ParseError::Parse(message) => LoadError::Parse { path, message },
            ParseError::NoTriangles => LoadError::NoTriangles { path },
            ParseError::Mesh(source) => LoadError::Mesh { path, source },
        }
    }
}

/// Parse OBJ text held in memory (used by `load_obj` and the fuzz target).
///
/// # Errors
/// As [`load_obj`], with `<memory>` as the file name.
///
/// ```
/// let m = packtrace::parse_obj_bytes(b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
/// assert_eq!(m.triangles(), &[[0, 1, 2], [0, 2, 3]]);
/// ```
pub fn parse_obj_bytes(bytes: &[u8]) -> Result<Mesh, LoadError> {
    parse_obj(bytes).map_err(|e| e.at(Path::new("<memory>")))
}

/// The positions-and-faces view of OBJ text that `tobj` is given: texture
/// and normal data (`vt`, `vn`, `vp`), points (`p`) and lines (`l`) become
/// blank lines, face corners keep only their position index (`7/3/2` ->
/// `7`). Only positions matter (BENCH_PROTOCOL "Scene"); this also keeps
/// tobj from panicking on out-of-range attribute indices, and from
/// turning a three-point `l` line into a triangle. Line numbers are kept.
fn positions_only(bytes: &[u8]) -> Result<String, ParseError> {
    let text = std::str::from_utf8(bytes)
        .map_err(|e| ParseError::Parse(format!("not UTF-8 text at byte {}", e.valid_up_to())))?;
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("vt" | "vn" | "vp" | "l" | "p") => {}
            Some("f") => {
                out.push('f');
                for corner in words {
                    out.push(' ');
                    out.push_str(corner.split('/').next().unwrap_or(corner));
                }
            }
            _ => out.push_str(line),
        }
        out.push('\n');
    }
    Ok(out)
}

fn parse_obj(bytes: &[u8]) -> Result<Mesh, ParseError> {
    let text = positions_only(bytes)?;
    let bytes = text.as_bytes();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    let mut reader = std::io::BufReader::new(bytes);
    // Materials are irrelevant (positions only): never open .mtl files.
    let (models, _) =
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed))
            .map_err(|e| ParseError::Parse(e.to_string()))?;
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for m in &models {
        let base = positions.len() as u64;
        let p = &m.mesh.positions;
        positions.extend(p.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])));
        for t in m.mesh.indices.chunks_exact(3) {
            // An index past u32 cannot name a vertex: Mesh::new reports it.
            let idx = |k: usize| u32::try_from(base + t[k] as u64).unwrap_or(u32::MAX);
            triangles.push([idx(0), idx(1), idx(2)]);
        }
    }
    if triangles.is_empty() {
        return Err(ParseError::NoTriangles);
    }
    Mesh::new(positions, triangles).map_err(ParseError::Mesh)
}
