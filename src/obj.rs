//! Wavefront OBJ loading through `tobj`, as BENCH_PROTOCOL "Scene" says:
//! triangles in file order, polygons fan-triangulated, positions only.
//!
//! The loader reads the file in two steps. A line-by-line pass of its own
//! (`positions_only`) checks every statement it needs (`v`, `f`,
//! `usemtl`) and reports the first problem with the file name and the
//! 1-based line number; it hands `tobj` a cleaned copy with the same line
//! numbering (vertex lines with their coordinates, faces with absolute
//! position indices, everything else blank). `tobj` then does the actual
//! loading and triangulation. Anything `tobj` could reject has already
//! been reported with its line, so a line-less [`LoadError::Parse`] from
//! `tobj` would be a bug in the pass, not in the file.

use crate::mesh::{Mesh, MeshError};
use glam::Vec3;
use std::collections::HashMap;
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
    /// are not UTF-8.
    Parse {
        /// The file.
        path: PathBuf,
        /// The line (1-based). `None` only if `tobj` rejects a file this
        /// loader's own pass accepted, which would be a loader bug.
        line: Option<usize>,
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
            LoadError::Parse { line, .. } => *line,
            LoadError::IndexOutOfRange { line, .. } | LoadError::NonFiniteVertex { line, .. } => {
                Some(*line)
            }
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
            LoadError::Parse {
                line: Some(line),
                message,
                ..
            } => write!(f, "{path}:{line}: {message}"),
            LoadError::Parse {
                line: None,
                message,
                ..
            } => write!(f, "{path}: not a valid OBJ file: {message}"),
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
/// let e = packtrace::load_obj("no/such/file.obj").unwrap_err();
/// assert!(matches!(e, packtrace::LoadError::Io { .. }));
/// assert_eq!(e.to_string(), "no/such/file.obj: cannot read the file");
/// // The OS error is the source, not repeated in the message.
/// let os = std::error::Error::source(&e).unwrap().downcast_ref::<std::io::Error>().unwrap();
/// assert_eq!(os.kind(), std::io::ErrorKind::NotFound);
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
enum ParseError {
    Syntax {
        line: Option<usize>,
        message: String,
    },
    Index {
        line: usize,
        index: i64,
        vertex_count: usize,
    },
    NonFinite {
        line: usize,
        vertex: usize,
        value: Vec3,
        face_line: usize,
    },
    NoTriangles,
    Mesh(MeshError),
}

impl ParseError {
    fn syntax(line: usize, message: String) -> ParseError {
        ParseError::Syntax {
            line: Some(line),
            message,
        }
    }

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

/// The values of a `v` line after the keyword: the position (divided by
/// `w` if there is one), or what is wrong.
fn parse_vertex(words: &[&str]) -> Result<Vec3, String> {
    let number = |what: &str, w: &str| {
        w.parse::<f32>()
            .map_err(|_| format!("{what} `{w}` is not a number"))
    };
    let [x, y, z, rest @ ..] = words else {
        return Err(format!(
            "a vertex needs 3 coordinates, found {}",
            words.len()
        ));
    };
    let p = Vec3::new(
        number("vertex coordinate", x)?,
        number("vertex coordinate", y)?,
        number("vertex coordinate", z)?,
    );
    match rest {
        // `x y z r g b`: the colour is not used (tobj skips a colour it
        // cannot parse, so no check here either).
        [] | [_, _, _] => Ok(p),
        [w] => {
            let w = number("vertex weight w", w)?;
            if w == 0.0 {
                Err("vertex weight w is 0".to_string())
            } else {
                // What tobj does: divide each coordinate by w.
                Ok(Vec3::new(p.x / w, p.y / w, p.z / w))
            }
        }
        _ => Err(format!(
            "a vertex takes 3 coordinates and an optional w or r g b, found {} values",
            words.len()
        )),
    }
}

/// The state of the line-by-line pass.
struct Scan {
    /// The cleaned text for tobj, one line per input line.
    out: String,
    /// Vertices (`v` lines) so far.
    vertex_count: usize,
    /// Non-finite vertices (0-based file number) -> (line, value).
    non_finite: HashMap<usize, (usize, Vec3)>,
    /// Triangles the faces so far fan into.
    triangles: usize,
}

impl Scan {
    /// A `v` line: check it, record a non-finite position, pass on
    /// `v x y z [w]` (a colour is dropped: tobj refuses to export colours
    /// some vertices lack).
    fn vertex(&mut self, line: usize, words: &[&str]) -> Result<(), ParseError> {
        let p = parse_vertex(words).map_err(|m| ParseError::syntax(line, m))?;
        if !p.is_finite() {
            self.non_finite.insert(self.vertex_count, (line, p));
        }
        self.vertex_count += 1;
        self.out.push('v');
        let keep = if words.len() == 4 { 4 } else { 3 };
        for w in words.iter().take(keep) {
            self.out.push(' ');
            self.out.push_str(w);
        }
        Ok(())
    }

    /// The 0-based vertex a face index names, given the vertices so far.
    fn resolve(&self, line: usize, index: i64) -> Result<usize, ParseError> {
        let n = self.vertex_count;
        let resolved = match index {
            i if i > 0 => usize::try_from(i - 1).ok().filter(|&v| v < n),
            i if i < 0 => usize::try_from(i.unsigned_abs())
                .ok()
                .and_then(|back| n.checked_sub(back)),
            _ => None,
        };
        resolved.ok_or(ParseError::Index {
            line,
            index,
            vertex_count: n,
        })
    }

    /// An `f` line: check every corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`),
    /// resolve position indices, and pass on `f a b c ...` with absolute
    /// 1-based indices; faces with one or two corners become blank lines.
    fn face(&mut self, line: usize, words: &[&str]) -> Result<(), ParseError> {
        if words.is_empty() {
            return Err(ParseError::syntax(
                line,
                "a face needs vertex indices, found none".to_string(),
            ));
        }
        let mut corners = Vec::with_capacity(words.len());
        for &corner in words {
            let parts: Vec<&str> = corner.split('/').collect();
            let bad =
                |what: &str| ParseError::syntax(line, format!("face corner `{corner}`: {what}"));
            if parts.len() > 3 {
                return Err(bad("more than 3 indices (v/vt/vn)"));
            }
            let Some(&v) = parts.first().filter(|v| !v.is_empty()) else {
                return Err(bad("no vertex index"));
            };
            let index = v
                .parse::<i64>()
                .map_err(|_| bad(&format!("`{v}` is not a vertex index")))?;
            for (part, what) in parts.iter().skip(1).zip(["texture", "normal"]) {
                if !part.is_empty() && part.parse::<i64>().is_err() {
                    return Err(bad(&format!("{what} index `{part}` is not an integer")));
                }
            }
            corners.push(self.resolve(line, index)?);
        }
        if corners.len() < 3 {
            return Ok(()); // a point or a line: no triangle
        }
        for &c in &corners {
            if let Some(&(vline, value)) = self.non_finite.get(&c) {
                return Err(ParseError::NonFinite {
                    line: vline,
                    vertex: c + 1,
                    value,
                    face_line: line,
                });
            }
        }
        self.triangles += corners.len() - 2;
        self.out.push('f');
        for c in corners {
            self.out.push(' ');
            self.out.push_str(&(c + 1).to_string());
        }
        Ok(())
    }
}

/// The line-by-line pass: check the text and return the positions-and-faces
/// view of it that `tobj` is given, with the same line numbers. `v` lines
/// keep `x y z [w]`; face corners become absolute position indices
/// (`7/3/2` -> `7`, `-1` -> the last vertex); every other line is blank.
/// Only positions matter (BENCH_PROTOCOL "Scene"); this also keeps tobj
/// from panicking on out-of-range attribute indices and from turning a
/// three-point `l` line into a triangle. Every error tobj could report is
/// found here first, with its line.
fn positions_only(bytes: &[u8]) -> Result<String, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        ParseError::syntax(line, format!("not UTF-8 text (byte {at} of the file)"))
    })?;
    let mut scan = Scan {
        out: String::with_capacity(text.len()),
        vertex_count: 0,
        non_finite: HashMap::new(),
        triangles: 0,
    };
    let mut words = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        words.clear();
        words.extend(line.split_whitespace());
        match words.split_first() {
            Some((&"v", rest)) => scan.vertex(line_no, rest)?,
            Some((&"f", rest)) => scan.face(line_no, rest)?,
            Some((&"usemtl", [])) => {
                return Err(ParseError::syntax(
                    line_no,
                    "`usemtl` needs a material name".to_string(),
                ));
            }
            _ => {}
        }
        scan.out.push('\n');
    }
    if scan.triangles == 0 {
        return Err(ParseError::NoTriangles);
    }
    Ok(scan.out)
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
        tobj::load_obj_buf(&mut reader, &opts, |_| Err(tobj::LoadError::OpenFileFailed)).map_err(
            |e| ParseError::Syntax {
                line: None,
                message: e.to_string(),
            },
        )?;
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

    /// The cleaned text tobj sees keeps the line numbering.
    #[test]
    fn positions_only_keeps_lines_and_normalises() {
        let text =
            b"# c\nv 1 2 3 1 0 0\nv 0 0 0 2\nvt 0 0\no x\nv 1 1 1\nf 1/1 2//3 -1/2/3\nf 1 2\n";
        let Ok(out) = positions_only(text) else {
            panic!("valid input");
        };
        assert_eq!(out, "\nv 1 2 3\nv 0 0 0 2\n\n\nv 1 1 1\nf 1 2 3\n\n");
    }

    #[test]
    fn invalid_utf8_names_its_line() {
        let r = positions_only(b"v 0 0 0\n\nf 1 \xff\n");
        assert!(matches!(r, Err(ParseError::Syntax { line: Some(3), .. })));
    }
}
