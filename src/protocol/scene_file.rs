//! Scene files: a small text format listing meshes (OBJ files or `gen:`
//! specs) and their instances, for the renderer, the bench and hosts
//! (issue 16). One statement per line; `#` starts a comment.
//!
//! ```text
//! # two spheres in the Cornell box
//! mesh box cornell.obj                       # relative to this file
//! mesh ball gen:sphere:2000
//! instance box
//! instance ball scale 80 translate 185 80 170 mask 0x2
//! instance ball scale 60 rotate 0 1 0 30 translate 370 60 380
//! instance box matrix 1 0 0 0  0 1 0 0  0 0 1 600   # 3 x 4, row by row
//! ```
//!
//! An `instance` line names a mesh and applies its transform steps in the
//! order written, the first to the object first: `scale S` or
//! `scale X Y Z`, `rotate AX AY AZ DEGREES` (about an axis through the
//! origin), `translate X Y Z`, and `matrix` with twelve numbers (the rows
//! of a 3 x 4 affine matrix); `mask M` (decimal or `0x` hex) sets the
//! instance's mask. Each mesh is built into its kd-tree once, whatever
//! number of instances use it.

use crate::kdtree::{BuildError, KdBuildParams, KdTree};
use crate::obj::{LoadError, load_obj};
use crate::protocol::generate::{self, SpecError};
use crate::scene::{GeometryId, Scene, SceneError};
use glam::{Affine3A, Mat3, Quat, Vec3};
use std::collections::HashMap;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a scene file could not be loaded; every variant names the line.
///
/// ```
/// use packtrace::protocol::scene_file::{SceneFileError, parse_scene};
/// let e = parse_scene("instance teapot\n", ".".as_ref(), &Default::default()).unwrap_err();
/// assert_eq!(e.to_string(), "scene line 1: no mesh `teapot` declared before this line");
/// ```
#[derive(Debug)]
pub enum SceneFileError {
    /// The scene file itself could not be read.
    Io {
        /// The file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
    /// A malformed line: an unknown keyword, a wrong number of values, a
    /// value that is not a number, a mesh name declared twice.
    Syntax {
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// An `instance` line names a mesh not declared above it.
    UnknownMesh {
        /// 1-based line number.
        line: usize,
        /// The name.
        name: String,
    },
    /// A mesh's OBJ file is missing or malformed.
    Obj {
        /// 1-based line number.
        line: usize,
        /// The loader's error (naming the OBJ file).
        source: LoadError,
    },
    /// A `gen:` spec is not valid.
    Spec {
        /// 1-based line number.
        line: usize,
        /// The generator's error.
        source: SpecError,
    },
    /// A mesh's kd-tree could not be built.
    Build {
        /// 1-based line number.
        line: usize,
        /// The builder's error.
        source: BuildError,
    },
    /// The scene refused an instance (a singular or non-finite transform).
    Scene {
        /// 1-based line number.
        line: usize,
        /// The scene's error.
        source: SceneError,
    },
}

impl fmt::Display for SceneFileError {
    /// Each variant says its own part; the cause (the OS error, the OBJ
    /// loader's, the builder's, the scene's) comes through `source()`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneFileError::Io { path, .. } => {
                write!(f, "{}: cannot read the scene file", path.display())
            }
            SceneFileError::Syntax { line, message } => write!(f, "scene line {line}: {message}"),
            SceneFileError::UnknownMesh { line, name } => {
                write!(
                    f,
                    "scene line {line}: no mesh `{name}` declared before this line"
                )
            }
            SceneFileError::Obj { line, .. } => {
                write!(f, "scene line {line}: cannot load the mesh")
            }
            SceneFileError::Spec { line, .. } => {
                write!(f, "scene line {line}: bad generated-mesh spec")
            }
            SceneFileError::Build { line, .. } => {
                write!(f, "scene line {line}: cannot build the mesh's kd-tree")
            }
            SceneFileError::Scene { line, .. } => {
                write!(f, "scene line {line}: instance refused")
            }
        }
    }
}

impl std::error::Error for SceneFileError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SceneFileError::Io { source, .. } => Some(source),
            SceneFileError::Obj { source, .. } => Some(source),
            SceneFileError::Spec { source, .. } => Some(source),
            SceneFileError::Build { source, .. } => Some(source),
            SceneFileError::Scene { source, .. } => Some(source),
            SceneFileError::Syntax { .. } | SceneFileError::UnknownMesh { .. } => None,
        }
    }
}

/// Where a scene file's mesh came from, as [`load_scene_with_sources`]
/// reports it (so a host can read the OBJ file's materials, say, without
/// parsing the scene file again).
///
/// ```
/// use packtrace::protocol::scene_file::{MeshSource, parse_scene_with_sources};
/// let (_, sources) = parse_scene_with_sources(
///     "mesh ball gen:sphere:100\n", "dir".as_ref(), &Default::default())?;
/// assert_eq!(sources[0].name, "ball");
/// assert_eq!(sources[0].source, MeshSource::Generated("gen:sphere:100".into()));
/// # Ok::<(), packtrace::protocol::scene_file::SceneFileError>(())
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshSource {
    /// An OBJ file, its path joined to the scene file's directory.
    Obj(PathBuf),
    /// A `gen:` spec (`protocol::generate::from_spec`).
    Generated(String),
}

/// One `mesh` line of a scene file: the geometry it became, its name and
/// its source.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneMesh {
    /// The geometry in the loaded scene.
    pub geometry: GeometryId,
    /// The name the file gives it.
    pub name: String,
    /// Where its triangles came from.
    pub source: MeshSource,
}

/// Loads a scene file; mesh paths are relative to the file's directory,
/// and every mesh is built with `params`.
///
/// # Errors
/// [`SceneFileError`]: the file cannot be read, a line is malformed, an
/// instance names an undeclared mesh, an OBJ file is missing or
/// malformed, a kd-tree cannot be built, or a transform is singular or
/// non-finite.
///
/// ```
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
/// let scene = packtrace::protocol::scene_file::load_scene(dir.join("cornell_spheres.scene"), &Default::default())?;
/// assert_eq!(scene.geometry_count(), 2);
/// assert!(scene.instance_count() >= 3);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn load_scene(path: impl AsRef<Path>, params: &KdBuildParams) -> Result<Scene, SceneFileError> {
    load_scene_with_sources(path, params).map(|(scene, _)| scene)
}

/// [`load_scene`], also reporting each mesh's geometry, name and source
/// in the order of the file's `mesh` lines.
///
/// # Errors
/// As [`load_scene`].
///
/// ```
/// use packtrace::protocol::scene_file::{MeshSource, load_scene_with_sources};
/// let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
/// let (scene, meshes) = load_scene_with_sources(dir.join("cornell_spheres.scene"), &Default::default())?;
/// assert_eq!(meshes.len(), scene.geometry_count());
/// assert!(meshes.iter().any(|m| m.source == MeshSource::Obj(dir.join("cornell.obj"))));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn load_scene_with_sources(
    path: impl AsRef<Path>,
    params: &KdBuildParams,
) -> Result<(Scene, Vec<SceneMesh>), SceneFileError> {
    let path = path.as_ref();
    let text = std::fs::read_to_string(path).map_err(|source| SceneFileError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_scene_with_sources(&text, path.parent().unwrap_or(Path::new(".")), params)
}

/// Parses scene-file text; mesh paths are relative to `dir`.
///
/// # Errors
/// As [`load_scene`].
///
/// ```
/// use packtrace::protocol::scene_file::parse_scene;
/// let s = parse_scene(
///     "mesh ball gen:sphere:200\ninstance ball translate 3 0 0\ninstance ball scale 2 mask 0x4\n",
///     ".".as_ref(),
///     &Default::default(),
/// )?;
/// assert_eq!(s.instance_count(), 2);
/// assert_eq!(s.instances().nth(1).unwrap().1.mask(), 4);
/// # Ok::<(), packtrace::protocol::scene_file::SceneFileError>(())
/// ```
pub fn parse_scene(
    text: &str,
    dir: &Path,
    params: &KdBuildParams,
) -> Result<Scene, SceneFileError> {
    parse_scene_with_sources(text, dir, params).map(|(scene, _)| scene)
}

/// [`parse_scene`], also reporting each mesh's source
/// ([`load_scene_with_sources`]).
///
/// # Errors
/// As [`load_scene`].
///
/// ```
/// use packtrace::protocol::scene_file::parse_scene_with_sources;
/// let (scene, meshes) = parse_scene_with_sources(
///     "mesh a gen:sphere:50\nmesh b gen:sphere:60\ninstance b\n", ".".as_ref(), &Default::default())?;
/// assert_eq!((scene.geometry_count(), meshes[1].name.as_str()), (2, "b"));
/// # Ok::<(), packtrace::protocol::scene_file::SceneFileError>(())
/// ```
pub fn parse_scene_with_sources(
    text: &str,
    dir: &Path,
    params: &KdBuildParams,
) -> Result<(Scene, Vec<SceneMesh>), SceneFileError> {
    let mut scene = Scene::new();
    let mut sources = Vec::new();
    let mut meshes: HashMap<String, GeometryId> = HashMap::new();
    let mut instances: Vec<(usize, GeometryId, Affine3A, Option<u32>)> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let syntax = |message: String| SceneFileError::Syntax { line, message };
        let words: Vec<&str> = raw
            .split('#')
            .next()
            .unwrap_or("")
            .split_whitespace()
            .collect();
        match words.as_slice() {
            [] => {}
            ["mesh", name, source] => {
                if meshes.contains_key(*name) {
                    return Err(syntax(format!("mesh `{name}` is declared twice")));
                }
                let (mesh, from) = if source.starts_with("gen:") {
                    let mesh = generate::from_spec(source)
                        .map_err(|source| SceneFileError::Spec { line, source })?;
                    (mesh, MeshSource::Generated(source.to_string()))
                } else {
                    let path = dir.join(source);
                    let mesh =
                        load_obj(&path).map_err(|source| SceneFileError::Obj { line, source })?;
                    (mesh, MeshSource::Obj(path))
                };
                let tree = KdTree::build(mesh, params)
                    .map_err(|source| SceneFileError::Build { line, source })?;
                let geometry = scene.add_geometry(name, tree);
                meshes.insert(name.to_string(), geometry);
                sources.push(SceneMesh {
                    geometry,
                    name: name.to_string(),
                    source: from,
                });
            }
            ["mesh", ..] => {
                return Err(syntax(
                    "expected `mesh NAME PATH` (or a `gen:` spec)".into(),
                ));
            }
            ["instance", name, steps @ ..] => {
                let g = *meshes
                    .get(*name)
                    .ok_or_else(|| SceneFileError::UnknownMesh {
                        line,
                        name: name.to_string(),
                    })?;
                let (m, mask) = transform_steps(steps).map_err(syntax)?;
                instances.push((line, g, m, mask));
            }
            [word, ..] => {
                return Err(syntax(format!(
                    "unknown statement `{word}` (expected `mesh` or `instance`)"
                )));
            }
        }
    }
    let mut edit = scene.edit();
    for (line, g, m, mask) in instances {
        let scene_err = |source| SceneFileError::Scene { line, source };
        let id = edit.add_instance(g, m).map_err(scene_err)?;
        if let Some(mask) = mask {
            edit.set_mask(id, mask).map_err(scene_err)?;
        }
    }
    edit.commit();
    Ok((scene, sources))
}

/// The transform and mask of an instance line's steps.
fn transform_steps(words: &[&str]) -> Result<(Affine3A, Option<u32>), String> {
    let mut m = Affine3A::IDENTITY;
    let mut mask = None;
    let mut rest = words;
    let numbers = |rest: &[&str], n: usize, what: &str| -> Result<Vec<f32>, String> {
        if rest.len() < n {
            return Err(format!("`{what}` needs {n} numbers"));
        }
        rest[..n]
            .iter()
            .map(|w| {
                w.parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| format!("`{w}` is not a finite number (in `{what}`)"))
            })
            .collect()
    };
    while let [step, tail @ ..] = rest {
        let (step_m, used) = match *step {
            "translate" => {
                let v = numbers(tail, 3, step)?;
                (Affine3A::from_translation(Vec3::new(v[0], v[1], v[2])), 3)
            }
            "scale" => {
                // One number (uniform) or three.
                let three = tail.len() >= 3 && tail[..3].iter().all(|w| w.parse::<f32>().is_ok());
                if three {
                    let v = numbers(tail, 3, step)?;
                    (Affine3A::from_scale(Vec3::new(v[0], v[1], v[2])), 3)
                } else {
                    let v = numbers(tail, 1, step)?;
                    (Affine3A::from_scale(Vec3::splat(v[0])), 1)
                }
            }
            "rotate" => {
                let v = numbers(tail, 4, step)?;
                let axis = Vec3::new(v[0], v[1], v[2]);
                if axis.length_squared() == 0.0 {
                    return Err("`rotate` needs a non-zero axis".into());
                }
                let q = Quat::from_axis_angle(axis.normalize(), v[3].to_radians());
                (Affine3A::from_quat(q), 4)
            }
            "matrix" => {
                let v = numbers(tail, 12, step)?;
                let rows =
                    Mat3::from_cols_array(&[v[0], v[4], v[8], v[1], v[5], v[9], v[2], v[6], v[10]]);
                (
                    Affine3A::from_mat3_translation(rows, Vec3::new(v[3], v[7], v[11])),
                    12,
                )
            }
            "mask" => {
                let w = tail.first().ok_or("`mask` needs a value")?;
                let parsed = match w.strip_prefix("0x") {
                    Some(hex) => u32::from_str_radix(hex, 16),
                    None => w.parse::<u32>(),
                };
                mask = Some(parsed.map_err(|_| format!("`{w}` is not a 32-bit mask"))?);
                rest = &tail[1..];
                continue;
            }
            other => {
                return Err(format!(
                    "unknown transform step `{other}` (expected translate, scale, rotate, \
                     matrix or mask)"
                ));
            }
        };
        m = step_m * m;
        rest = &tail[used..];
    }
    Ok((m, mask))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::error::Error;

    /// The error and its causes, as the binaries print them.
    fn chain(e: &dyn std::error::Error) -> String {
        let mut s = e.to_string();
        let mut cause = e.source();
        while let Some(c) = cause {
            s += &format!(": {c}");
            cause = c.source();
        }
        s
    }

    fn parse(text: &str) -> Result<Scene, SceneFileError> {
        parse_scene(text, Path::new("."), &KdBuildParams::default())
    }

    #[test]
    fn steps_apply_in_the_order_written() {
        let (m, mask) = transform_steps(&[
            "scale",
            "2",
            "rotate",
            "0",
            "0",
            "1",
            "90",
            "translate",
            "1",
            "0",
            "0",
        ])
        .unwrap();
        let p = m.transform_point3(Vec3::X);
        assert!((p - Vec3::new(1.0, 2.0, 0.0)).length() < 1e-6, "{p}");
        assert_eq!(mask, None);
        let (m, _) = transform_steps(&["scale", "1", "2", "3"]).unwrap();
        assert_eq!(m.transform_point3(Vec3::ONE), Vec3::new(1.0, 2.0, 3.0));
        let (m, mask) = transform_steps(&[
            "matrix", "1", "0", "0", "5", "0", "2", "0", "6", "0", "0", "3", "7", "mask", "0xff",
        ])
        .unwrap();
        assert_eq!(m.transform_point3(Vec3::ONE), Vec3::new(6.0, 8.0, 10.0));
        assert_eq!(mask, Some(255));
    }

    #[test]
    fn bad_lines_name_their_line_and_problem() {
        let e = |t: &str| parse(t).unwrap_err().to_string();
        assert_eq!(
            e("mesh a gen:sphere:100\n\nfrobnicate\n"),
            "scene line 3: unknown statement `frobnicate` (expected `mesh` or `instance`)"
        );
        assert!(e("mesh a gen:sphere:100\ninstance a translate 1 2\n").contains("needs 3 numbers"));
        assert!(e("mesh a gen:sphere:100\ninstance a scale nan\n").contains("not a finite number"));
        assert!(e("mesh a gen:sphere:100\nmesh a gen:sphere:100\n").contains("declared twice"));
        assert!(e("mesh a gen:sphere:100\ninstance a wobble\n").contains("unknown transform step"));
        assert!(e("mesh a gen:sphere:100\ninstance a mask zz\n").contains("32-bit mask"));
        assert!(e("mesh a gen:cube:3\n").starts_with("scene line 1: "));
        assert!(e("mesh a\n").contains("expected `mesh NAME PATH`"));
    }

    #[test]
    fn a_missing_obj_and_a_singular_transform_are_errors() {
        let e = parse("mesh a no/such/file.obj\n").unwrap_err();
        assert!(matches!(e, SceneFileError::Obj { line: 1, .. }), "{e}");
        assert!(chain(&e).contains("no/such/file.obj"), "{}", chain(&e));
        assert!(
            !e.to_string().contains("no/such/file.obj"),
            "{e}: said twice"
        );
        let e = parse("mesh a gen:sphere:100\ninstance a scale 1 0 1\n").unwrap_err();
        assert!(
            matches!(e, SceneFileError::Scene { line: 2, .. }) && chain(&e).contains("singular"),
            "{}",
            chain(&e)
        );
        let e = load_scene("no/such.scene", &KdBuildParams::default()).unwrap_err();
        assert_eq!(e.to_string(), "no/such.scene: cannot read the scene file");
        assert!(e.source().is_some());
    }
}
