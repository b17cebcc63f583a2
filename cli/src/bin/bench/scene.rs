//! Scenes by spec: an OBJ file with its view file, a generated mesh, or a
//! scene file of instances (`PATH.scene`, loaded by `run_scene_file`), and
//! the scenes of instances the bench makes from meshes.

use crate::Failure;
use packtrace::glam::Affine3A;
use packtrace::protocol::camera::{View, load_view};
use packtrace::protocol::generate;
use packtrace::scene::{Scene as InstScene, SceneHit};
use packtrace::{Hit, KdTree, Mesh, load_obj};
use packtrace_cli::chain;
use std::path::Path;
use std::sync::Arc;

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

/// Is `spec` a scene file of instances (`*.scene`)?
pub fn is_scene_file(spec: &str) -> bool {
    !is_generated(spec) && Path::new(spec).extension().is_some_and(|x| x == "scene")
}

/// `tree` (shared, not copied or rebuilt) as the one instance, with the
/// identity transform, of a scene: the instance accel.
///
/// # Errors
/// [`Failure::Input`] if the scene refuses the instance (it does not for
/// a tree it holds and the identity).
pub fn one_instance(name: &str, tree: Arc<KdTree>) -> Result<InstScene, Failure> {
    let mut one = InstScene::new();
    let g = one.add_shared_geometry(name, tree);
    let mut edit = one.edit();
    edit.add_instance(g, Affine3A::IDENTITY)
        .map_err(|e| Failure::Input(format!("{name}: {e}")))?;
    edit.commit();
    Ok(one)
}

/// A scene's world triangles as one mesh, instance after instance in id
/// order (each geometry's vertices by its instance's transform), and the
/// first triangle of each instance id (`u32::MAX` for removed ids): what
/// the shadow and ao rays of a scene file take their hits' normals from.
///
/// # Errors
/// [`Failure::Input`] if the world triangles are too many for one mesh or
/// a vertex is not finite in world space.
pub fn flatten(scene: &InstScene) -> Result<(Mesh, Vec<u32>), Failure> {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut first = Vec::new();
    for (id, inst) in scene.instances() {
        let Some(g) = scene.geometry(inst.geometry()) else {
            continue;
        };
        let mesh = g.tree().mesh();
        let to_world = inst.transform().to_world();
        first.resize(id.0 as usize + 1, u32::MAX);
        first[id.0 as usize] = u32::try_from(triangles.len())
            .map_err(|_| Failure::Input("too many world triangles to flatten".into()))?;
        let base = u32::try_from(positions.len())
            .map_err(|_| Failure::Input("too many world vertices to flatten".into()))?;
        positions.extend(
            mesh.positions()
                .iter()
                .map(|&p| to_world.transform_point3(p)),
        );
        triangles.extend(mesh.triangles().iter().map(|t| t.map(|i| base + i)));
    }
    let mesh = Mesh::new(positions, triangles)
        .map_err(|e| Failure::Input(format!("the scene's world triangles: {e}")))?;
    Ok((mesh, first))
}

/// A scene hit as a hit in [`flatten`]'s mesh (`first` from it).
pub fn flat_hit(h: &SceneHit, first: &[u32]) -> Hit {
    Hit {
        t: h.t,
        prim: first[h.instance.0 as usize] + h.prim,
        u: h.u,
        v: h.v,
    }
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
        return Err(Failure::Input(format!(
            "scene {spec}: {why} (--scene takes an OBJ file, a PATH.scene file or a \
             generated scene such as gen:sphere:100k; the shared scenes are in \
             $PACKTRACE_SCENES when set)"
        )));
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

#[cfg(test)]
mod tests {
    use super::*;
    use packtrace::protocol::SceneFrame;
    use packtrace::protocol::camera::Camera;
    use packtrace::protocol::scene_file::{load_scene, parse_scene};
    use packtrace::protocol::workload;
    use packtrace::scene::InstanceId;

    #[test]
    fn flattened_hits_have_the_scenes_normals() {
        let s = parse_scene(
            "mesh ball gen:sphere:300\nmesh small gen:sphere:100\ninstance ball\n\
             instance small scale 2 translate 5 0 0\ninstance ball scale -1 1 1 rotate 0 1 0 40 \
             translate 0 0 6\n",
            Path::new("."),
            &Default::default(),
        )
        .unwrap();
        let (flat, first) = flatten(&s).unwrap();
        let counts: Vec<usize> = s
            .instances()
            .map(|(_, i)| {
                s.geometry(i.geometry())
                    .unwrap()
                    .tree()
                    .mesh()
                    .triangle_count()
            })
            .collect();
        assert_eq!(flat.triangle_count(), counts.iter().sum::<usize>());
        assert_eq!(first, [0, counts[0] as u32, (counts[0] + counts[1]) as u32]);
        // Random rays: every hit's flattened triangle has the scene's
        // normal (up to sign and rounding) and contains the hit point.
        let rays = workload::random(&SceneFrame::of_scene(&s), 2000).rays;
        let mut hits = [0; 3];
        for r in &rays {
            let Some(h) = s.intersect(r) else { continue };
            hits[h.instance.0 as usize] += 1;
            let fh = flat_hit(&h, &first);
            let n = flat.normal(fh.prim as usize);
            let m = s.normal(&h).unwrap();
            assert!(n.dot(m).abs() > 0.999, "{n} {m}");
            let c = flat.corners(fh.prim as usize);
            let p = c[0] * (1.0 - h.u - h.v) + c[1] * h.u + c[2] * h.v;
            let q = r.origin() + h.t * r.dir();
            assert!((p - q).length() < 1e-3 * (1.0 + q.length()), "{p} {q}");
        }
        assert!(hits.iter().all(|&n| n > 0), "{hits:?}");
        let e = InstScene::new();
        assert_eq!(flatten(&e).unwrap().0.triangle_count(), 0);
    }

    #[test]
    fn scene_file_errors_name_each_cause_once() {
        let e =
            parse_scene("mesh a no/such.obj\n", Path::new("."), &Default::default()).unwrap_err();
        let text = chain(&e);
        assert_eq!(text.matches("no/such.obj").count(), 1, "{text}");
        assert!(text.starts_with("scene line 1: "), "{text}");
    }

    #[test]
    fn one_instance_is_the_tree_at_the_identity() {
        let tree = Arc::new(KdTree::build(generate::sphere(100), &Default::default()).unwrap());
        let one = one_instance("ball", Arc::clone(&tree)).unwrap();
        assert_eq!(one.instance_count(), 1);
        let i = one.instance(InstanceId(0)).unwrap();
        assert_eq!(i.transform().to_world(), Affine3A::IDENTITY);
        assert_eq!(Arc::strong_count(&tree), 2, "shared, not copied");
        assert_eq!(one.geometry(i.geometry()).unwrap().name(), "ball");
    }

    /// The example scene and its view: the camera sees into the box, and
    /// its pixels hit the box and a ball.
    #[test]
    fn the_example_scene_file_and_its_view() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data");
        let path = dir.join("cornell_spheres.scene");
        assert!(is_scene_file(path.to_str().unwrap()));
        precheck(path.to_str().unwrap()).unwrap();
        let s = load_scene(&path, &Default::default()).unwrap();
        let view = load_view(&path).unwrap();
        let camera = view.camera.expect("cornell_spheres.view lists a camera");
        assert!(view.light.is_some());
        // The Cornell view of the box alone, for the same scene.
        let cornell = load_view(&dir.join("cornell.obj")).unwrap();
        assert_eq!(view, cornell);
        let primary = workload::primary(&camera, 64, 64).unwrap();
        let mut per_instance = vec![0usize; s.instance_count()];
        for r in &primary.rays {
            if let Some(h) = s.intersect(r) {
                per_instance[h.instance.0 as usize] += 1;
            }
        }
        let hit: usize = per_instance.iter().sum();
        assert!(hit > primary.len() * 9 / 10, "{hit} of {}", primary.len());
        // The box and the hanging ball are in sight. (The two floor balls
        // of data/cornell_spheres.scene sit inside the Cornell box's
        // blocks, so no camera sees them; the mirrored second box is
        // behind the first box's back wall.)
        assert!(per_instance.len() >= 4, "{per_instance:?}");
        assert!(per_instance[0] > 0, "the box: {per_instance:?}");
        assert!(
            per_instance[1..].iter().any(|&n| n > 0),
            "a ball: {per_instance:?}"
        );
        // Without the view file the auto camera frames the world box.
        let auto = Camera::auto(&SceneFrame::of_scene(&s).bounds);
        let auto_hits = workload::primary(&auto, 32, 32)
            .unwrap()
            .rays
            .iter()
            .filter(|r| s.intersect(r).is_some())
            .count();
        assert!(auto_hits > 0);
    }
}
