//! `render`: the crate's default run target. Path-traces the Cornell box
//! (or an OBJ scene) with its area lights on all cores, progressively,
//! writes a PNG and prints the speed of each kind of ray; `--direct`
//! renders direct light and ambient occlusion instead (also scene files
//! of instances), `--heatmap` the traversal cost.
//!
//! ```text
//! cargo run --release                      # path-traced Cornell box -> render.png
//! cargo run --release -- --spp 256 --size 1024x1024 --out box.png
//! cargo run --release -- --compare         # bounce and shadow rays in every mode
//! cargo run --release -- --direct --scene S.obj --ao 8 --spp 4 --heatmap heat.png
//! cargo run --release -- --direct --scene data/cornell_spheres.scene --view data/cornell.view
//! ```

use clap::Parser;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use packtrace::protocol::camera::{Camera, View, ViewError, load_view, parse_light};
use packtrace::protocol::generate;
use packtrace::protocol::scene_file::{
    MeshSource, SceneFileError, SceneMesh, load_scene_with_sources,
};
use packtrace::scene::{GeometryId, Scene};
use packtrace_cli::chain;
mod heatmap;
mod path;

use packtrace::Mode;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload::check_image_size;
use packtrace::render::path::{Estimator, ToneMap};
use packtrace::render::{self, RenderError, RenderOptions, Rendered, Rgb8};
use packtrace::{KdBuildParams, KdTree, LoadError, ObjMesh, load_obj, load_obj_with_shading};
use std::error::Error;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Path-trace an OBJ scene (default: the Cornell box) through an SAH
/// kd-tree, or render direct light and ambient occlusion with --direct.
#[derive(Parser, Debug)]
#[command(name = "render", version)]
struct Args {
    /// Wavefront OBJ scene (emissive materials, `Ke` in its .mtl, are
    /// its area lights), or with --direct a scene file (a path ending in
    /// `.scene`: meshes and their instances, e.g. data/cornell_spheres.scene);
    /// its camera comes from NAME.view beside it, or --view [default: the
    /// Cornell box, built in, so it is found from any directory].
    #[arg(long, value_name = "PATH")]
    scene: Option<PathBuf>,

    /// View file (`camera` and `light` lines) to use instead of NAME.view
    /// beside the scene; it must exist.
    #[arg(long, value_name = "FILE")]
    view: Option<PathBuf>,

    /// Camera `ex,ey,ez,tx,ty,tz,ux,uy,uz,fov` (default: the view file's,
    /// else the protocol's auto camera).
    #[arg(
        long,
        value_name = "ex,ey,ez,tx,ty,tz,ux,uy,uz,fov",
        value_parser = parse_camera,
        allow_hyphen_values = true
    )]
    camera: Option<Camera>,

    /// Image size, both even [default: 512x512; 1024x1024 with --direct].
    #[arg(long, value_name = "WxH", value_parser = parse_size)]
    size: Option<(u32, u32)>,

    /// Samples per pixel [default: 16; 1 with --direct, where 1 traces
    /// the pixel centres and more jitter them].
    #[arg(long, value_name = "N")]
    spp: Option<u32>,

    /// How rays are traced: scalar, packet4, packet8, stream; with
    /// --direct also group8x8 / group16x16 (each tile's primary and
    /// shadow rays traced as ray groups). The path tracer traces its
    /// shadow and bounce rays this way (camera rays go as 4x2 packets)
    /// [default: stream, the fastest for them; packet8 with --direct].
    #[arg(long, value_parser = parse_mode)]
    mode: Option<Mode>,

    /// Threads for the tree build and the render (default: all cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,

    /// Output PNG.
    #[arg(long, value_name = "FILE", default_value = "render.png")]
    out: PathBuf,

    /// Also write a traversal-cost heat map (PNG) of the primary rays
    /// through the pixel centres (kd-tree of an OBJ scene only).
    #[arg(long, value_name = "FILE")]
    heatmap: Option<PathBuf>,

    /// Render in every mode too; print each mode's speed and whether the
    /// images are identical (an error if not).
    #[arg(long)]
    compare: bool,

    /// Path tracing: samples per pixel added by each pass of the
    /// progressive render [default: 2].
    #[arg(long, value_name = "N")]
    pass_spp: Option<u32>,

    /// Path tracing: most bounces of a path [default: 64; Russian
    /// roulette ends paths long before].
    #[arg(long, value_name = "N")]
    max_depth: Option<u32>,

    /// Path tracing: bounces before Russian roulette starts [default: 3].
    #[arg(long, value_name = "N")]
    rr_depth: Option<u32>,

    /// Path tracing: mis (light sampling and bounces, weighted by the
    /// power heuristic), nee (light sampling alone) or bsdf (bounces
    /// alone); the same image, with different noise [default: mis].
    #[arg(long, value_parser = parse_estimator)]
    estimator: Option<Estimator>,

    /// Path tracing: seed of the random numbers [default: 0].
    #[arg(long, value_name = "N")]
    seed: Option<u32>,

    /// Path tracing: exposure in stops [default: 0].
    #[arg(long, value_name = "EV", allow_hyphen_values = true)]
    exposure: Option<f32>,

    /// Path tracing: tone map, clamp or filmic [default: clamp].
    #[arg(long, value_parser = parse_tone)]
    tone: Option<ToneMap>,

    /// Path tracing: radiance `r,g,b` of the sky seen by rays that leave
    /// the scene [default: black for a scene with lights, else 1,1,1].
    #[arg(long, value_name = "R,G,B", value_parser = parse_colour)]
    sky: Option<Vec3>,

    /// Path tracing: the structure rays are traced through: kd (the SAH
    /// kd-tree) or brute (the brute-force oracle: every triangle for
    /// every ray; the same image, slowly) [default: kd].
    #[arg(long, value_parser = parse_accel)]
    accel: Option<path::Accel>,

    /// Render direct light from a point light and ambient occlusion
    /// instead of path tracing.
    #[arg(long)]
    direct: bool,

    /// Direct light: point light `x,y,z` (default: the view file's, else
    /// the protocol's default light).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_light_arg, allow_hyphen_values = true)]
    light: Option<Vec3>,

    /// Direct light: ambient-occlusion rays per hit (0: the sky light
    /// reaches every point unoccluded) [default: 2].
    #[arg(long, value_name = "N")]
    ao: Option<u32>,
}

/// Image size of the direct renderer unless `--size` says otherwise.
const DIRECT_SIZE: (u32, u32) = (1024, 1024);

fn parse_estimator(s: &str) -> Result<Estimator, String> {
    s.parse()
}

fn parse_tone(s: &str) -> Result<ToneMap, String> {
    s.parse()
}

fn parse_accel(s: &str) -> Result<path::Accel, String> {
    s.parse()
}

/// `r,g,b`: three finite numbers, none negative.
fn parse_colour(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| t.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|_| format!("`{s}` is not three numbers r,g,b"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|c| c.is_finite() && *c >= 0.0) => Ok(Vec3::new(r, g, b)),
        [_, _, _] => Err(format!("`{s}`: radiance must be finite and not negative")),
        _ => Err(format!("`{s}` is not three numbers r,g,b")),
    }
}

fn parse_camera(s: &str) -> Result<Camera, String> {
    Camera::parse(s).map_err(|e| e.to_string())
}

fn parse_light_arg(s: &str) -> Result<Vec3, String> {
    parse_light(s).map_err(|e| e.to_string())
}

fn parse_mode(s: &str) -> Result<Mode, String> {
    s.parse()
        .map_err(|e: packtrace::query::UnknownMode| e.to_string())
}

/// `WxH` with both numbers positive and even.
fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("`{s}` is not WIDTHxHEIGHT (e.g. 1024x768)"))?;
    let num = |t: &str| {
        t.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{t}` in `{s}` is not a whole number"))
    };
    let (w, h) = (num(w)?, num(h)?);
    check_image_size(w, h).map_err(|e| e.to_string())?;
    Ok((w, h))
}

fn main() -> ExitCode {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            eprintln!("{}", usage_error(&e));
            return ExitCode::from(2);
        }
    };
    match run(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", chain(e.as_ref()));
            ExitCode::FAILURE
        }
    }
}

/// A command-line error as one line: clap's own message (without its
/// usage and tip lines), then the fix: clap's suggestion for a misspelt
/// option, and where the options are listed. A bad value's message
/// already says what the option takes.
fn usage_error(e: &clap::Error) -> String {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    let text = e.to_string();
    let mut line = text
        .lines()
        .find(|l| !l.trim().is_empty())
        .unwrap_or("error: invalid arguments")
        .to_string();
    // A value given but refused: its message says what the option takes.
    let missing = matches!(
        e.get(ContextKind::InvalidValue),
        Some(ContextValue::String(v)) if v.is_empty()
    );
    if matches!(
        e.kind(),
        ErrorKind::InvalidValue | ErrorKind::ValueValidation
    ) && !missing
    {
        return line;
    }
    if let Some(ContextValue::String(s)) = e.get(ContextKind::SuggestedArg) {
        line.push_str(&format!("; did you mean {s}?"));
    }
    line.push_str(" (`render --help` lists the options)");
    line
}

/// Per-triangle colours from the file's materials (`Kd`); grey where a
/// triangle has no material or its material no colour; none at all (grey
/// everywhere) when the file gives no colour.
fn albedo_of(obj: &ObjMesh) -> Vec<Vec3> {
    let n = obj.mesh().triangle_count() as u32;
    if obj.materials().iter().all(|m| m.diffuse.is_none()) {
        return Vec::new();
    }
    (0..n)
        .map(|p| {
            obj.material(p)
                .and_then(|m| m.diffuse)
                .unwrap_or(Vec3::splat(0.75))
        })
        .collect()
}

/// Per-triangle emitted radiance from the file's materials (`Ke`); black
/// where a triangle has none; none at all when the file gives none.
fn emission_of(obj: &ObjMesh) -> Vec<Vec3> {
    let n = obj.mesh().triangle_count() as u32;
    if obj.materials().iter().all(|m| m.emission.is_none()) {
        return Vec::new();
    }
    (0..n)
        .map(|p| {
            obj.material(p)
                .and_then(|m| m.emission)
                .unwrap_or(Vec3::ZERO)
        })
        .collect()
}

/// An OBJ scene: its mesh, and per triangle its albedo and emission from
/// the materials (each empty when the file gives none).
struct ObjScene {
    mesh: packtrace::Mesh,
    albedo: Vec<Vec3>,
    emission: Vec<Vec3>,
}

/// Load an OBJ scene. A missing or broken material library costs the
/// colours and lights, not the picture: a warning, and grey without
/// lights.
fn load_obj_scene(path: &Path) -> Result<ObjScene, Box<dyn Error>> {
    match load_obj_with_shading(path) {
        Ok(obj) => Ok(ObjScene {
            albedo: albedo_of(&obj),
            emission: emission_of(&obj),
            mesh: obj.into_mesh(),
        }),
        Err(e @ LoadError::MaterialLibrary { .. }) => {
            eprintln!("warning: {e}; rendering in grey");
            Ok(ObjScene {
                mesh: load_obj(path)?,
                albedo: Vec::new(),
                emission: Vec::new(),
            })
        }
        Err(e @ LoadError::Io { .. }) => Err(format!(
            "{}; check the path, or omit --scene for the built-in Cornell box",
            chain(&e)
        )
        .into()),
        Err(e) => Err(e.into()),
    }
}

/// Does `path` name a scene file (`.scene`, any case) rather than an OBJ?
fn is_scene_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("scene"))
}

/// A view file named on the command line: unlike `NAME.view` beside a
/// scene, a missing one is an error.
fn load_view_file(path: &Path) -> Result<View, Box<dyn Error>> {
    let text = std::fs::read_to_string(path).map_err(|source| {
        let e = ViewError::Io {
            path: path.to_path_buf(),
            source,
        };
        format!(
            "{}; check the path, or omit --view for NAME.view beside the scene",
            chain(&e)
        )
    })?;
    let view = View::parse(&text).map_err(|e| match e {
        ViewError::ViewLine {
            line, text, reason, ..
        } => ViewError::ViewLine {
            path: Some(path.to_path_buf()),
            line,
            text,
            reason,
        },
        other => other,
    })?;
    Ok(view)
}

/// Per geometry of a scene loaded from a scene file, the colours of its
/// OBJ file's materials ([`albedo_of`]); none (grey) for a `gen:` mesh,
/// an OBJ file without colours, or one whose material library is missing
/// or broken (with a warning, as for an OBJ scene). The scene loader
/// reports each mesh's source and keeps no materials, so each OBJ file is
/// read again here for its shading data.
fn scene_albedo(scene: &Scene, meshes: &[SceneMesh]) -> Vec<Vec<Vec3>> {
    let mut albedo = vec![Vec::new(); scene.geometry_count()];
    for m in meshes {
        let (MeshSource::Obj(path), Some(geo)) = (&m.source, scene.geometry(m.geometry)) else {
            continue;
        };
        let name = &m.name;
        albedo[m.geometry.0 as usize] = match load_obj_with_shading(path) {
            Ok(obj) if obj.mesh().triangle_count() == geo.tree().mesh().triangle_count() => {
                albedo_of(&obj)
            }
            Ok(_) => {
                eprintln!(
                    "warning: mesh `{name}`: the materials do not match its triangles; \
                     rendering it in grey"
                );
                Vec::new()
            }
            Err(e) => {
                eprintln!("warning: {e}; rendering mesh `{name}` in grey");
                Vec::new()
            }
        };
    }
    albedo
}

/// What is rendered: one kd-tree, or a scene of instances, with colours.
enum Target {
    Tree {
        tree: KdTree,
        albedo: Vec<Vec3>,
    },
    Scene {
        scene: Scene,
        albedo: Vec<Vec<Vec3>>,
    },
}

impl Target {
    fn render(
        &self,
        opts: &RenderOptions,
        progress: &(dyn Fn(usize) + Sync),
    ) -> Result<Rendered, RenderError> {
        match self {
            Target::Tree { tree, albedo } => {
                render::render_with_albedo(tree, albedo, opts, progress)
            }
            Target::Scene { scene, albedo } => render::render_scene(scene, albedo, opts, progress),
        }
    }
}

/// A loaded scene, before its kd-tree is built (an OBJ mesh) or after (a
/// scene file builds its trees as it loads), with the view file beside it.
enum Loaded {
    Mesh {
        name: String,
        mesh: packtrace::Mesh,
        albedo: Vec<Vec3>,
        view: View,
    },
    Scene {
        name: String,
        scene: Scene,
        albedo: Vec<Vec<Vec3>>,
        view: View,
    },
}

/// The `--view` file, else the scene's own view (`beside`: the view file
/// beside it, or the built-in Cornell box's), which is then not read.
fn view_of(
    args: &Args,
    beside: impl FnOnce() -> Result<View, ViewError>,
) -> Result<View, Box<dyn Error>> {
    match &args.view {
        Some(path) => load_view_file(path),
        None => Ok(beside()?),
    }
}

/// A scene file's error as one line: the file (unless the message names
/// it), then the message and its causes.
fn scene_error(path: &Path, e: &SceneFileError) -> String {
    match e {
        SceneFileError::Io { .. } => format!(
            "{}; check the path, or omit --scene for the built-in Cornell box",
            chain(e)
        ),
        _ => format!("{}: {}", path.display(), chain(e)),
    }
}

/// Where the view came from, for the summary.
fn view_source(args: &Args) -> &'static str {
    if args.view.is_some() {
        "--view"
    } else {
        "view file"
    }
}

/// The camera: `--camera`, else `view`'s, else the protocol's auto camera
/// of `frame`; with where it came from.
fn resolve_camera(args: &Args, view: &View, frame: &SceneFrame) -> (Camera, &'static str) {
    match (args.camera, view.camera) {
        (Some(c), _) => (c, "--camera"),
        (None, Some(c)) => (c, view_source(args)),
        (None, None) => (view.camera_or_auto(&frame.bounds), "auto"),
    }
}

/// Camera and light: command line, else `view`, else the protocol's auto
/// camera and default light of `frame`. Sets them in `opts` and checks
/// them; returns them with where each came from.
fn resolve_view(
    args: &Args,
    view: &View,
    frame: &SceneFrame,
    opts: &mut RenderOptions,
) -> Result<(Camera, &'static str, Vec3, &'static str), Box<dyn Error>> {
    let from_view = view_source(args);
    let (camera, camera_from) = resolve_camera(args, view, frame);
    let (light, light_from) = match (args.light, view.light) {
        (Some(l), _) => (l, "--light"),
        (None, Some(l)) => (l, from_view),
        (None, None) => (view.light_or_default(frame), "default"),
    };
    opts.camera = camera;
    opts.light = light;
    opts.validate()?;
    Ok((camera, camera_from, light, light_from))
}

/// Renders with more traced rays than this get a progress bar (when stderr
/// is a terminal).
const PROGRESS_RAYS: u64 = 4_000_000;

fn run(args: &Args) -> Result<(), Box<dyn Error>> {
    if args.direct {
        path::refuse_path_options(args)?;
        run_direct(args)
    } else {
        path::run(args)
    }
}

/// The direct renderer: point light, shadow rays, ambient occlusion.
fn run_direct(args: &Args) -> Result<(), Box<dyn Error>> {
    // Options that do not depend on the scene, checked before loading it
    let (width, height) = args.size.unwrap_or(DIRECT_SIZE);
    let mut opts = RenderOptions::new(
        Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0)?,
        Vec3::ZERO,
        width,
        height,
    );
    opts.spp = args.spp.unwrap_or(1);
    opts.ao_samples = args.ao.unwrap_or(2);
    opts.mode = args.mode.unwrap_or(Mode::Packet8);
    if let Some(n) = args.threads {
        opts.threads = n;
    }
    opts.validate()?;

    let scene_file = args.scene.as_deref().filter(|p| is_scene_file(p));
    if let (Some(path), Some(_)) = (scene_file, &args.heatmap) {
        return Err(format!(
            "--heatmap: {} is a scene file; heat maps are of one kd-tree (an OBJ scene) only",
            path.display()
        )
        .into());
    }
    // Trees are built on as many threads as the render uses (rayon's pool).
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build_global();

    // Scene and view file
    let t = Instant::now();
    let loaded = match (&args.scene, scene_file) {
        (_, Some(path)) => {
            let (scene, meshes) = load_scene_with_sources(path, &KdBuildParams::default())
                .map_err(|e| scene_error(path, &e))?;
            let albedo = scene_albedo(&scene, &meshes);
            Loaded::Scene {
                name: path.display().to_string(),
                scene,
                albedo,
                view: view_of(args, || load_view(path))?,
            }
        }
        (Some(path), None) => {
            let ObjScene { mesh, albedo, .. } = load_obj_scene(path)?;
            Loaded::Mesh {
                name: path.display().to_string(),
                mesh,
                albedo,
                view: view_of(args, || load_view(path))?,
            }
        }
        // The generator's Cornell box is data/cornell.obj, .mtl and .view
        // (`generate::tests::cornell_data_files_match_the_code`).
        (None, _) => Loaded::Mesh {
            name: "the built-in Cornell box (data/cornell.obj)".to_string(),
            mesh: generate::from_spec("gen:cornell")?,
            albedo: generate::cornell_albedo(),
            view: view_of(args, || View::parse(generate::CORNELL_VIEW))?,
        },
    };
    let load_s = t.elapsed().as_secs_f64();
    let mut report = String::new();
    let mut line = |k: &str, v: String| report.push_str(&format!("{k:<9} {v}\n"));
    let (target, view) = match loaded {
        Loaded::Mesh {
            name,
            mesh,
            albedo,
            view,
        } => {
            let frame = SceneFrame::of(&mesh);
            let triangles = mesh.triangle_count();
            // Camera and light are checked before the (slow) build.
            let view = resolve_view(args, &view, &frame, &mut opts)?;
            let t = Instant::now();
            let tree = KdTree::build(mesh, &KdBuildParams::default())?;
            let build_s = t.elapsed().as_secs_f64();
            let st = tree.stats();
            line(
                "scene",
                format!("{name}: {triangles} triangles, loaded in {load_s:.3} s"),
            );
            line(
                "kd-tree",
                format!(
                    "built in {build_s:.3} s: {} nodes, {} leaves ({} empty), depth {}, \
                     {:.2} refs/triangle, SAH cost {:.2}, {} bytes",
                    st.nodes,
                    st.leaves,
                    st.empty_leaves,
                    st.max_depth,
                    st.refs_per_triangle,
                    st.sah_cost,
                    st.bytes
                ),
            );
            (Target::Tree { tree, albedo }, view)
        }
        Loaded::Scene {
            name,
            scene,
            albedo,
            view,
        } => {
            let frame = render::scene_frame(&scene);
            let view = resolve_view(args, &view, &frame, &mut opts)?;
            let geometries: Vec<_> = (0..scene.geometry_count() as u32)
                .filter_map(|g| scene.geometry(GeometryId(g)))
                .collect();
            let triangles: usize = geometries
                .iter()
                .map(|g| g.tree().mesh().triangle_count())
                .sum();
            let placed: usize = scene
                .instances()
                .filter_map(|(_, i)| scene.geometry(i.geometry()))
                .map(|g| g.tree().mesh().triangle_count())
                .sum();
            line(
                "scene",
                format!(
                    "{name}: {} meshes ({triangles} triangles), {} instances ({placed} \
                     triangles placed), loaded and built in {load_s:.3} s",
                    geometries.len(),
                    scene.instance_count()
                ),
            );
            let trees: Vec<String> = geometries
                .iter()
                .map(|g| {
                    let st = g.tree().stats();
                    format!(
                        "{}: {} nodes, depth {}, SAH cost {:.2}, {} bytes",
                        g.name(),
                        st.nodes,
                        st.max_depth,
                        st.sah_cost,
                        st.bytes
                    )
                })
                .collect();
            line("kd-trees", trees.join("; "));
            (Target::Scene { scene, albedo }, view)
        }
    };
    let (camera, camera_from, light, light_from) = view;
    line("camera", format!("{camera} ({camera_from})"));
    line(
        "light",
        format!("{},{},{} ({light_from})", light.x, light.y, light.z),
    );

    // Render
    let (out, secs) = timed_render(&target, &opts)?;
    write_png(&args.out, &out.image.to_srgb8())?;

    line(
        "image",
        format!(
            "{}x{}, {} spp, {} AO rays/hit -> {}",
            opts.width,
            opts.height,
            opts.spp,
            opts.ao_samples,
            args.out.display()
        ),
    );
    let r = out.rays;
    line(
        "rays",
        format!(
            "{} primary + {} shadow + {} ao = {}",
            r.primary,
            r.shadow,
            r.ao,
            r.total()
        ),
    );
    let mode = match (&target, opts.mode.tile()) {
        (Target::Scene { .. }, Some(_)) => {
            format!("{} (as packet8: group modes are kd-tree only)", opts.mode)
        }
        _ => opts.mode.to_string(),
    };
    line(
        "render",
        format!(
            "{secs:.3} s, {:.2} Mrays/s, {} threads, {mode}, {} tiles of {}x{}",
            mrays(r.total(), secs),
            opts.threads,
            opts.tile_count(),
            opts.tile_size,
            opts.tile_size
        ),
    );

    // Heat map (OBJ scenes only, checked above)
    if let (Some(path), Target::Tree { tree, .. }) = (&args.heatmap, &target) {
        let heat = render::heat_map(tree, &opts, &|_| {})?;
        write_png(path, &heatmap::heat_image(&heat))?;
        let unit = match opts.mode {
            Mode::Scalar => "per ray",
            Mode::Packet4 => "per 2x2 packet",
            Mode::Packet8 => "per 4x2 packet",
            Mode::Stream => "per 4x2 packet (the stream's width)",
            Mode::Group8x8 | Mode::Group16x16 => {
                "(+ cell clippings) per 4x2 packet, its share of its group's"
            }
        };
        line(
            "heat map",
            format!(
                "{}: {}..{} nodes + leaves + triangle tests {unit} (primary rays)",
                path.display(),
                heat.min(),
                heat.max()
            ),
        );
    }

    // Every mode against scalar
    let mut mismatch = false;
    if args.compare {
        let mut times = Vec::new();
        let mut images = Vec::new();
        for mode in Mode::ALL {
            let (o, s) = if mode == opts.mode {
                (out.clone(), secs)
            } else {
                timed_render(&target, &RenderOptions { mode, ..opts })?
            };
            times.push(s);
            images.push(o.image);
        }
        let same = images.iter().all(|i| images[0].bit_identical(i));
        mismatch = !same;
        let per_mode: Vec<String> = Mode::ALL
            .iter()
            .zip(&times)
            .map(|(m, &t)| {
                format!(
                    "{m} {t:.3} s ({:.2} Mrays/s, {:.2}x scalar)",
                    mrays(r.total(), t),
                    times[0] / t
                )
            })
            .collect();
        line(
            "compare",
            format!(
                "{}; images identical: {}",
                per_mode.join(", "),
                if same { "yes" } else { "NO" }
            ),
        );
    }

    let mut stdout = std::io::stdout().lock();
    stdout.write_all(report.as_bytes())?;
    stdout.flush()?;
    if mismatch {
        return Err("the modes' images differ (a traversal bug)".into());
    }
    Ok(())
}

fn mrays(rays: u64, secs: f64) -> f64 {
    rays as f64 / secs.max(1e-9) / 1e6
}

/// Render with a progress bar on large renders; seconds of the render only.
fn timed_render(target: &Target, opts: &RenderOptions) -> Result<(Rendered, f64), Box<dyn Error>> {
    let est =
        opts.width as u64 * opts.height as u64 * opts.spp as u64 * (2 + opts.ao_samples as u64);
    let bar = ProgressBar::with_draw_target(
        Some(opts.tile_count() as u64),
        if est > PROGRESS_RAYS && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    let style = ProgressStyle::with_template(
        "{msg:>7} [{elapsed_precise}] {wide_bar} {pos}/{len} tiles, eta {eta}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    bar.set_message(opts.mode.name());
    let t = Instant::now();
    let out = target.render(opts, &|n| bar.inc(n as u64))?;
    let secs = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok((out, secs))
}

/// Write an 8-bit RGB PNG, tagged sRGB: to `FILE.tmp` first, then renamed,
/// so an interrupted run never leaves a truncated image under the name.
fn write_png(path: &Path, img: &Rgb8) -> Result<(), Box<dyn Error>> {
    let ctx = |e: &dyn std::fmt::Display| format!("writing {}: {e}", path.display());
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(".tmp");
    let tmp = PathBuf::from(tmp);
    let file = File::create(&tmp).map_err(|e| ctx(&e))?;
    let mut enc = png::Encoder::new(BufWriter::new(file), img.width, img.height);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
    let written = enc
        .write_header()
        .and_then(|mut w| {
            w.write_image_data(&img.data)?;
            w.finish()
        })
        .map_err(|e| ctx(&e))
        .and_then(|()| std::fs::rename(&tmp, path).map_err(|e| ctx(&e)));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    Ok(written?)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The repository's data directory (the binary's crate is `cli/`).
    fn data(file: &str) -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../data")
            .join(file)
    }

    fn args(list: &[&str]) -> Args {
        Args::try_parse_from(std::iter::once("render").chain(list.iter().copied())).unwrap()
    }

    /// A scratch file name, unique to this process and test.
    fn scratch(name: &str) -> PathBuf {
        std::env::temp_dir().join(format!(
            "packtrace-render-unit-{}-{name}",
            std::process::id()
        ))
    }

    #[test]
    fn scene_files_are_told_from_obj_files_by_their_extension() {
        assert!(is_scene_file(Path::new("data/cornell_spheres.scene")));
        assert!(is_scene_file(Path::new("A.SCENE")));
        assert!(!is_scene_file(Path::new("data/cornell.obj")));
        assert!(!is_scene_file(Path::new("scene")));
    }

    #[test]
    fn scene_and_view_parse() {
        let a = args(&[
            "--scene",
            "data/cornell_spheres.scene",
            "--view",
            "data/cornell.view",
            "--mode",
            "group8x8",
        ]);
        assert_eq!(
            a.scene.as_deref(),
            Some(Path::new("data/cornell_spheres.scene"))
        );
        assert_eq!(a.view.as_deref(), Some(Path::new("data/cornell.view")));
        assert_eq!(a.mode, Some(Mode::Group8x8));
        assert!(args(&[]).view.is_none());
        assert!(Args::try_parse_from(["render", "--view"]).is_err());
    }

    /// The example scene renders in every mode to the same image, from
    /// the `--view` camera, the box in its materials' colours and the
    /// generated ball grey.
    #[test]
    fn the_example_scene_renders_in_every_mode() {
        let path = data("cornell_spheres.scene");
        let (scene, meshes) = load_scene_with_sources(&path, &KdBuildParams::default()).unwrap();
        let albedo = scene_albedo(&scene, &meshes);
        assert_eq!(albedo.len(), scene.geometry_count());
        for (g, colours) in albedo.iter().enumerate() {
            let geo = scene.geometry(GeometryId(g as u32)).unwrap();
            match geo.name() {
                "box" => assert_eq!(colours, &generate::cornell_albedo()),
                "ball" => assert!(colours.is_empty()),
                other => panic!("unexpected mesh {other}"),
            }
        }

        let out = scratch("scene.png");
        let (p, v, o) = (
            path.to_str().unwrap(),
            data("cornell.view"),
            out.to_str().unwrap(),
        );
        let a = args(&[
            "--direct",
            "--scene",
            p,
            "--view",
            v.to_str().unwrap(),
            "--size",
            "32x32",
            "--threads",
            "2",
            "--compare",
            "--out",
            o,
        ]);
        let done = run(&a);
        let written = std::fs::metadata(&out).map(|m| m.len());
        let _ = std::fs::remove_file(&out);
        done.unwrap();
        assert!(written.unwrap() > 0);
    }

    #[test]
    fn scene_file_errors_are_clean() {
        let path = data("cornell_spheres.scene");
        let p = path.to_str().unwrap();
        let heat = scratch("heat.png");
        let e = run(&args(&[
            "--direct",
            "--scene",
            p,
            "--heatmap",
            heat.to_str().unwrap(),
            "--size",
            "8x8",
        ]))
        .unwrap_err()
        .to_string();
        assert!(e.contains("heat maps are of one kd-tree"), "{e}");
        assert!(!heat.exists());

        let e = run(&args(&[
            "--direct",
            "--scene",
            p,
            "--view",
            "no/such.view",
            "--size",
            "8x8",
        ]))
        .unwrap_err()
        .to_string();
        assert!(
            e.starts_with("no/such.view: cannot read the view file: ")
                && e.ends_with("; check the path, or omit --view for NAME.view beside the scene"),
            "{e}"
        );

        let bad = scratch("bad.scene");
        std::fs::write(&bad, "mesh a gen:sphere:10\ninstance a scale 0\n").unwrap();
        let e = run(&args(&[
            "--direct",
            "--scene",
            bad.to_str().unwrap(),
            "--size",
            "8x8",
        ]));
        let _ = std::fs::remove_file(&bad);
        let e = e.unwrap_err().to_string();
        assert!(
            e.starts_with(&format!("{}: scene line 2: ", bad.display())),
            "{e}"
        );
        // The transform's message once, not again as the cause.
        assert_eq!(e.matches("singular").count(), 1, "{e}");
    }
}
