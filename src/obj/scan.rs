//! The line-by-line pass over an OBJ file: every statement the loader
//! needs is checked here and the first problem is reported with its
//! 1-based line, so no error is ever line-less.
//!
//! The pass keeps the file's own numbering: vertex `k` of the file (its
//! `k`-th `v` line) is position `k - 1` of the mesh, and so for texture
//! coordinates and normals. `tobj` renumbers vertices per object (the
//! bunny's 35,947 `v` lines became 34,834 positions), which is why the
//! statements are read here and `tobj` reads only material libraries
//! (`shading.rs`).

use glam::{Vec2, Vec3};
use std::collections::HashMap;

/// "This corner names no texture coordinate / normal".
pub(crate) const NONE: u32 = u32::MAX;

/// A load error before the file name is attached.
pub(crate) enum ParseError {
    Syntax {
        line: usize,
        message: String,
    },
    Index {
        line: usize,
        index: i64,
        vertex_count: usize,
    },
    AttributeIndex {
        line: usize,
        attribute: super::Attribute,
        index: i64,
        count: usize,
    },
    NonFinite {
        line: usize,
        vertex: usize,
        value: Vec3,
        face_line: usize,
    },
    NoTriangles,
    Mesh(crate::mesh::MeshError),
}

impl ParseError {
    pub(crate) fn syntax(line: usize, message: String) -> ParseError {
        ParseError::Syntax { line, message }
    }
}

/// What the pass reads besides positions and faces.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Read {
    /// `v` and `f` only (docs/PROTOCOL.md, "Scenes and the scene frame"); corner texture and normal
    /// indices must be integers but need not name anything.
    Positions,
    /// Also `vt`, `vn`, `usemtl`, `mtllib`; corner texture and normal
    /// indices must name a `vt` / `vn` line above the face.
    Shading,
}

/// The result of the pass.
#[derive(Default)]
pub(crate) struct Scan {
    /// Every `v` line's position (divided by `w`), in file order.
    pub positions: Vec<Vec3>,
    /// The faces fanned into triangles (`v0 vi vi+1`), 0-based file
    /// vertex numbers.
    pub triangles: Vec<[u32; 3]>,
    /// Non-finite vertices (0-based file number) -> (line, value).
    non_finite: HashMap<usize, (usize, Vec3)>,
    /// With [`Read::Shading`]: every `vt` line (`u v`, `v` 0 if absent).
    pub texcoords: Vec<Vec2>,
    /// With [`Read::Shading`]: every `vn` line, as written.
    pub normals: Vec<Vec3>,
    /// With [`Read::Shading`]: per triangle, the corners' 0-based `vt`
    /// numbers ([`NONE`] where a corner names none).
    pub tri_texcoords: Vec<[u32; 3]>,
    /// With [`Read::Shading`]: per triangle, the corners' `vn` numbers.
    pub tri_normals: Vec<[u32; 3]>,
    /// With [`Read::Shading`]: material names in order of first `usemtl`.
    pub material_names: Vec<String>,
    /// With [`Read::Shading`]: per triangle, its material's index in
    /// `material_names` ([`NONE`] before the first `usemtl`).
    pub tri_materials: Vec<u32>,
    /// With [`Read::Shading`]: `mtllib` file names and their lines.
    pub libraries: Vec<(usize, String)>,
    /// With [`Read::Shading`]: each `o` line's name and the first triangle
    /// after it.
    pub objects: Vec<(String, u32)>,
    /// With [`Read::Shading`]: each `g` line's names and the first
    /// triangle after it.
    pub groups: Vec<(String, u32)>,
    /// The current `usemtl`.
    material: u32,
}

/// The values of a `v` line after the keyword: the position (divided by
/// `w` if there is one), or what is wrong.
fn parse_vertex(words: &[&str]) -> Result<Vec3, String> {
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
        // `x y z r g b`: the colour is not used.
        [] | [_, _, _] => Ok(p),
        [w] => {
            let w = number("vertex weight w", w)?;
            if w == 0.0 {
                Err("vertex weight w is 0".to_string())
            } else {
                // Homogeneous coordinates: divide each by w (as tobj does).
                Ok(Vec3::new(p.x / w, p.y / w, p.z / w))
            }
        }
        _ => Err(format!(
            "a vertex takes 3 coordinates and an optional w or r g b, found {} values",
            words.len()
        )),
    }
}

fn number(what: &str, w: &str) -> Result<f32, String> {
    w.parse::<f32>()
        .map_err(|_| format!("{what} `{w}` is not a number"))
}

/// A finite number for a `vt` or `vn` line.
fn finite(what: &str, w: &str) -> Result<f32, String> {
    let x = number(what, w)?;
    if x.is_finite() {
        Ok(x)
    } else {
        Err(format!("{what} `{w}` is not finite"))
    }
}

/// The 0-based item a 1-based or relative (negative) OBJ index names,
/// given `n` items defined so far.
fn resolve_index(index: i64, n: usize) -> Option<usize> {
    match index {
        i if i > 0 => usize::try_from(i - 1).ok().filter(|&v| v < n),
        i if i < 0 => usize::try_from(i.unsigned_abs())
            .ok()
            .and_then(|back| n.checked_sub(back)),
        _ => None,
    }
}

impl Scan {
    /// A `v` line: check it and keep its position.
    fn vertex(&mut self, line: usize, words: &[&str]) -> Result<(), ParseError> {
        let p = parse_vertex(words).map_err(|m| ParseError::syntax(line, m))?;
        if !p.is_finite() {
            self.non_finite.insert(self.positions.len(), (line, p));
        }
        self.positions.push(p);
        Ok(())
    }

    /// A `vt` line: `u [v [w]]`, finite.
    fn texcoord(&mut self, line: usize, words: &[&str]) -> Result<(), ParseError> {
        let bad = |m: String| ParseError::syntax(line, m);
        let t = match words {
            [u] => Vec2::new(finite("texture coordinate", u).map_err(bad)?, 0.0),
            [u, v] | [u, v, _] => Vec2::new(
                finite("texture coordinate", u).map_err(bad)?,
                finite("texture coordinate", v).map_err(bad)?,
            ),
            _ => {
                return Err(bad(format!(
                    "a texture coordinate takes 1 to 3 values, found {}",
                    words.len()
                )));
            }
        };
        self.texcoords.push(t);
        Ok(())
    }

    /// A `vn` line: three finite numbers.
    fn normal(&mut self, line: usize, words: &[&str]) -> Result<(), ParseError> {
        let bad = |m: String| ParseError::syntax(line, m);
        let [x, y, z] = words else {
            return Err(bad(format!(
                "a normal takes 3 values, found {}",
                words.len()
            )));
        };
        self.normals.push(Vec3::new(
            finite("normal component", x).map_err(bad)?,
            finite("normal component", y).map_err(bad)?,
            finite("normal component", z).map_err(bad)?,
        ));
        Ok(())
    }

    /// `usemtl name`: later faces use that material.
    fn use_material(&mut self, name: String) {
        let k = match self.material_names.iter().position(|n| *n == name) {
            Some(k) => k,
            None => {
                self.material_names.push(name);
                self.material_names.len() - 1
            }
        };
        self.material = k as u32;
    }

    /// The 0-based vertex a face index names, given the vertices so far.
    fn resolve(&self, line: usize, index: i64) -> Result<usize, ParseError> {
        let n = self.positions.len();
        resolve_index(index, n).ok_or(ParseError::Index {
            line,
            index,
            vertex_count: n,
        })
    }

    /// An `f` line: check every corner (`v`, `v/vt`, `v//vn`, `v/vt/vn`),
    /// resolve its indices and fan the face into triangles; faces with one
    /// or two corners are points and lines, and give none.
    fn face(&mut self, line: usize, words: &[&str], read: Read) -> Result<(), ParseError> {
        if words.is_empty() {
            return Err(ParseError::syntax(
                line,
                "a face needs vertex indices, found none".to_string(),
            ));
        }
        // Per corner: (vertex, texture coordinate, normal), 0-based.
        let mut corners: Vec<[u32; 3]> = Vec::with_capacity(words.len());
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
            let mut c = [self.resolve(line, index)? as u32, NONE, NONE];
            let attributes = [
                (super::Attribute::TextureCoordinate, self.texcoords.len()),
                (super::Attribute::Normal, self.normals.len()),
            ];
            for (k, (part, (attribute, count))) in parts.iter().skip(1).zip(attributes).enumerate()
            {
                if part.is_empty() {
                    continue;
                }
                let Ok(index) = part.parse::<i64>() else {
                    return Err(bad(&format!(
                        "{attribute} index `{part}` is not an integer"
                    )));
                };
                if read == Read::Shading {
                    let i = resolve_index(index, count).ok_or(ParseError::AttributeIndex {
                        line,
                        attribute,
                        index,
                        count,
                    })?;
                    c[1 + k] = i as u32;
                }
            }
            corners.push(c);
        }
        if corners.len() < 3 {
            return Ok(()); // a point or a line: no triangle
        }
        for c in &corners {
            if let Some(&(vline, value)) = self.non_finite.get(&(c[0] as usize)) {
                return Err(ParseError::NonFinite {
                    line: vline,
                    vertex: c[0] as usize + 1,
                    value,
                    face_line: line,
                });
            }
        }
        for i in 1..corners.len() - 1 {
            let t = [corners[0], corners[i], corners[i + 1]];
            self.triangles.push(t.map(|c| c[0]));
            if read == Read::Shading {
                self.tri_texcoords.push(t.map(|c| c[1]));
                self.tri_normals.push(t.map(|c| c[2]));
                self.tri_materials.push(self.material);
            }
        }
        Ok(())
    }
}

/// Check `bytes` as OBJ text and read what `read` asks for. Statements
/// the loader does not use are skipped (`vp`, `l`, `p`, `o`, `g`, `s`,
/// unknown keywords; with [`Read::Positions`] also `vt`, `vn`, `mtllib`,
/// though `usemtl` must still name a material).
pub(crate) fn scan(bytes: &[u8], read: Read) -> Result<Scan, ParseError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let at = e.valid_up_to();
        let line = 1 + bytes[..at].iter().filter(|&&b| b == b'\n').count();
        ParseError::syntax(line, format!("not UTF-8 text (byte {at} of the file)"))
    })?;
    let mut s = Scan {
        material: NONE,
        ..Scan::default()
    };
    let shading = read == Read::Shading;
    let mut words = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line_no = i + 1;
        words.clear();
        words.extend(line.split_whitespace());
        match words.split_first() {
            Some((&"v", rest)) => s.vertex(line_no, rest)?,
            Some((&"f", rest)) => s.face(line_no, rest, read)?,
            Some((&"usemtl", [])) => {
                return Err(ParseError::syntax(
                    line_no,
                    "`usemtl` needs a material name".to_string(),
                ));
            }
            Some((&"usemtl", rest)) if shading => s.use_material(rest.join(" ")),
            Some((&"vt", rest)) if shading => s.texcoord(line_no, rest)?,
            Some((&"vn", rest)) if shading => s.normal(line_no, rest)?,
            Some((&"mtllib", [])) if shading => {
                return Err(ParseError::syntax(
                    line_no,
                    "`mtllib` needs a file name".to_string(),
                ));
            }
            Some((&"o", rest)) if shading => {
                let first = s.triangles.len() as u32;
                s.objects.push((rest.join(" "), first));
            }
            Some((&"g", rest)) if shading => {
                let first = s.triangles.len() as u32;
                s.groups.push((rest.join(" "), first));
            }
            Some((&"mtllib", rest)) if shading => s
                .libraries
                .extend(rest.iter().map(|name| (line_no, (*name).to_string()))),
            _ => {}
        }
    }
    if s.triangles.is_empty() {
        return Err(ParseError::NoTriangles);
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ok(text: &[u8], read: Read) -> Scan {
        match scan(text, read) {
            Ok(s) => s,
            Err(_) => panic!("valid input {:?}", String::from_utf8_lossy(text)),
        }
    }

    /// Positions keep the file's numbering; faces fan; attributes are
    /// read only when asked for.
    #[test]
    fn the_file_numbering_is_kept_and_faces_fan() {
        let text = b"# c\nv 1 2 3 1 0 0\nv 0 0 0 2\nvt 0.5 1\no x\nv 1 1 1\nv 9 9 9\n\
                     vn 0 0 1\nusemtl red\nf 1/1 2//1 -2/1/1 4\nf 1 2\n";
        let s = ok(text, Read::Positions);
        assert_eq!(s.positions.len(), 4);
        assert_eq!(s.triangles, [[0, 1, 2], [0, 2, 3]]);
        assert!(s.texcoords.is_empty() && s.tri_normals.is_empty());
        let s = ok(text, Read::Shading);
        assert_eq!(s.texcoords, [Vec2::new(0.5, 1.0)]);
        assert_eq!(s.normals, [Vec3::Z]);
        assert_eq!(s.tri_texcoords, [[0, NONE, 0], [0, 0, NONE]]);
        assert_eq!(s.tri_normals, [[NONE, 0, 0], [NONE, 0, NONE]]);
        assert_eq!(s.material_names, ["red"]);
        assert_eq!(s.tri_materials, [0, 0]);
    }

    #[test]
    fn invalid_utf8_names_its_line() {
        let r = scan(b"v 0 0 0\n\nf 1 \xff\n", Read::Positions);
        assert!(matches!(r, Err(ParseError::Syntax { line: 3, .. })));
    }

    /// An attribute index that names nothing is an error only when the
    /// attributes are read.
    #[test]
    fn attribute_indices_must_name_something_when_read() {
        let text = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//2 2//1 3//1\n";
        assert!(scan(text, Read::Positions).is_ok());
        assert!(matches!(
            scan(text, Read::Shading),
            Err(ParseError::AttributeIndex {
                line: 5,
                index: 2,
                count: 1,
                ..
            })
        ));
    }
}
