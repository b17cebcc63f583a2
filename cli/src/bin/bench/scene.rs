//! Scenes by spec: an OBJ file with its view file, or a generated mesh.

use crate::Failure;
use packtrace::protocol::camera::{View, load_view};
use packtrace::protocol::generate;
use packtrace::{Mesh, load_obj};
use packtrace_cli::chain;
use std::path::Path;

/// A loaded scene.
pub struct Scene {
    /// The JSON `scene`: the file stem, or the `gen:` spec as given.
    pub name: String,
    /// Its triangles.
    pub mesh: Mesh,
    /// Its listed camera and light (none for generated scenes but
    /// `gen:cornell`, which has the Cornell view).
    pub view: View,
}

/// Is `spec` a generated scene?
pub fn is_generated(spec: &str) -> bool {
    spec.starts_with("gen:")
}

/// Check that a scene file exists and its view file parses, or that a
/// generator spec builds (generating is fast next to a run), before any
/// long work starts.
///
/// # Errors
/// [`Failure::Input`] naming the file or spec.
pub fn precheck(spec: &str) -> Result<(), Failure> {
    if is_generated(spec) {
        generate::from_spec(spec).map_err(|e| Failure::Input(e.to_string()))?;
        return Ok(());
    }
    let path = Path::new(spec);
    if !path.is_file() {
        let why = if path.exists() {
            "not a file"
        } else {
            "no such file"
        };
        return Err(Failure::Input(format!("scene {spec}: {why}")));
    }
    load_view(path).map_err(|e| Failure::Input(chain(&e)))?;
    Ok(())
}

/// Load a scene.
///
/// # Errors
/// [`Failure::Input`] for a missing or malformed file or view file, or a
/// bad generator spec (the message names the file or spec).
pub fn load(spec: &str) -> Result<Scene, Failure> {
    if is_generated(spec) {
        let mesh = generate::from_spec(spec).map_err(|e| Failure::Input(e.to_string()))?;
        let view = if spec == "gen:cornell" {
            View::parse(generate::CORNELL_VIEW).map_err(|e| Failure::Input(e.to_string()))?
        } else {
            View::default()
        };
        return Ok(Scene {
            name: spec.to_string(),
            mesh,
            view,
        });
    }
    let path = Path::new(spec);
    let mesh = load_obj(path).map_err(|e| Failure::Input(chain(&e)))?;
    let view = load_view(path).map_err(|e| Failure::Input(chain(&e)))?;
    let name = path
        .file_stem()
        .map_or_else(|| spec.to_string(), |s| s.to_string_lossy().into_owned());
    Ok(Scene { name, mesh, view })
}
