//! The path-traced render, `render`'s default: the scene and its area
//! lights, progressive passes under a progress bar, the summary by ray
//! kind, and `--compare`, which traces the bounce and shadow rays in
//! every mode.

use super::{
    Args, PROGRESS_RAYS, heatmap, is_scene_file, load_obj_scene, mrays, resolve_camera, view_of,
    write_png,
};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use packtrace::protocol::SceneFrame;
use packtrace::protocol::camera::{Camera, View, load_view};
use packtrace::protocol::generate;
use packtrace::render::path::{
    DEFAULT_MODE, Film, PathOptions, PathScene, PathStats, PathTracer, RayKind,
};
use packtrace::render::{self, RenderOptions};
use packtrace::{BruteForce, KdBuildParams, KdTree, Mesh, Mode, PacketQuery};
use std::error::Error;
use std::io::{IsTerminal, Write};
use std::time::Instant;

/// Image size unless `--size` says otherwise.
const SIZE: (u32, u32) = (512, 512);

/// The modes `--compare` traces the bounce and shadow rays in.
const MODES: [Mode; 4] = [Mode::Scalar, Mode::Packet4, Mode::Packet8, Mode::Stream];

/// The structure the path tracer's rays go through.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Accel {
    /// The SAH kd-tree.
    Kd,
    /// The brute-force oracle.
    Brute,
}

impl std::str::FromStr for Accel {
    type Err = String;

    fn from_str(s: &str) -> Result<Accel, String> {
        match s {
            "kd" => Ok(Accel::Kd),
            "brute" => Ok(Accel::Brute),
            // `bench`'s names, so the user finds where they are traced.
            "embree" | "embree-coherent" | "obvhs" | "tinybvh" => Err(format!(
                "`{s}` is a peer engine of the benchmark, not of render (which traces kd or \
                 brute): run `bench --accel {s}` (docs/benchmarking.md)"
            )),
            "kd8" | "kd8-blocked" | "kd8-inline" | "naive" | "instance" | "scene" => Err(format!(
                "`{s}` is a structure of `bench --accel`; render traces kd (the kd8 tree) or brute"
            )),
            _ => Err(format!("unknown structure `{s}` (expected kd or brute)")),
        }
    }
}

/// With `--direct`, the path tracer's options are an error, not ignored.
pub fn refuse_path_options(args: &Args) -> Result<(), String> {
    let given = [
        ("--pass-spp", args.pass_spp.is_some()),
        ("--max-depth", args.max_depth.is_some()),
        ("--rr-depth", args.rr_depth.is_some()),
        ("--estimator", args.estimator.is_some()),
        ("--seed", args.seed.is_some()),
        ("--exposure", args.exposure.is_some()),
        ("--tone", args.tone.is_some()),
        ("--sky", args.sky.is_some()),
        ("--accel", args.accel.is_some()),
    ];
    match given.iter().find(|(_, set)| *set) {
        Some((name, _)) => Err(format!(
            "{name} is an option of the path tracer: drop it, or drop --direct"
        )),
        None => Ok(()),
    }
}

/// Without `--direct`, the direct renderer's options are an error.
fn refuse_direct_options(args: &Args) -> Result<(), String> {
    if args.light.is_some() {
        return Err(
            "--light sets the point light of the direct renderer: add --direct, or \
                    light the scene with emissive materials (`Ke` in its .mtl)"
                .to_string(),
        );
    }
    if args.ao.is_some() {
        return Err(
            "--ao sets the ambient-occlusion rays of the direct renderer: add --direct".to_string(),
        );
    }
    Ok(())
}

/// The mesh, kept by the structure built over it.
enum Built {
    Kd(KdTree),
    Brute(Mesh),
}

impl Built {
    fn mesh(&self) -> &Mesh {
        match self {
            Built::Kd(t) => t.mesh(),
            Built::Brute(m) => m,
        }
    }
}

/// One render: the film, the rays, the wall-clock seconds.
struct Run {
    film: Film,
    stats: PathStats,
    secs: f64,
}

pub fn run(args: &Args) -> Result<(), Box<dyn Error>> {
    refuse_direct_options(args)?;
    let accel = args.accel.unwrap_or(Accel::Kd);
    // Options that do not depend on the scene, checked before loading it
    let (width, height) = args.size.unwrap_or(SIZE);
    let mut opts = PathOptions::new(
        Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0)?,
        width,
        height,
    );
    opts.spp = args.spp.unwrap_or(opts.spp);
    opts.pass_spp = args.pass_spp.unwrap_or(opts.pass_spp);
    opts.max_depth = args.max_depth.unwrap_or(opts.max_depth);
    opts.rr_depth = args.rr_depth.unwrap_or(opts.rr_depth);
    opts.estimator = args.estimator.unwrap_or_default();
    opts.seed = args.seed.unwrap_or(0);
    opts.mode = args.mode.unwrap_or(DEFAULT_MODE);
    if let Some(n) = args.threads {
        opts.threads = n;
    }
    opts.validate()?;
    let exposure = args.exposure.unwrap_or(0.0);
    if !exposure.is_finite() {
        return Err(format!("--exposure {exposure}: give a finite number of stops").into());
    }
    let tone = args.tone.unwrap_or_default();
    if let Some(path) = args.scene.as_deref().filter(|p| is_scene_file(p)) {
        return Err(format!(
            "{}: the path tracer renders one OBJ mesh; render scene files of instances with \
             --direct",
            path.display()
        )
        .into());
    }
    if args.heatmap.is_some() && accel == Accel::Brute {
        return Err("--heatmap counts the kd-tree's traversal: drop --accel brute".into());
    }
    // Trees are built on as many threads as the render uses (rayon's pool).
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build_global();

    // Scene, materials and view
    let t = Instant::now();
    let (name, mesh, albedo, emission, view) = match &args.scene {
        // The light 1 mm below the ceiling, so rays see it (as published it
        // lies in the ceiling's plane; `generate::cornell_box_lit`).
        None => (
            "the built-in Cornell box (data/cornell.obj with its light lowered 1 mm)".to_string(),
            generate::cornell_box_lit(),
            generate::cornell_albedo(),
            generate::cornell_emission(),
            view_of(args, || View::parse(generate::CORNELL_VIEW))?,
        ),
        Some(path) => {
            let obj = load_obj_scene(path)?;
            let view = view_of(args, || load_view(path))?;
            let name = path.display().to_string();
            (name, obj.mesh, obj.albedo, obj.emission, view)
        }
    };
    let load_s = t.elapsed().as_secs_f64();
    let frame = SceneFrame::of(&mesh);
    let (camera, camera_from) = resolve_camera(args, &view, &frame);
    opts.camera = camera;
    opts.validate()?;

    let mut report = String::new();
    let mut line = |k: &str, v: String| report.push_str(&format!("{k:<9} {v}\n"));
    let triangles = mesh.triangle_count();

    // The structure
    let t = Instant::now();
    let built = match accel {
        Accel::Kd => Built::Kd(KdTree::build(mesh, &KdBuildParams::default())?),
        Accel::Brute => Built::Brute(mesh),
    };
    let build_s = t.elapsed().as_secs_f64();
    let mut scene = PathScene::new(built.mesh(), &albedo, &emission, Vec3::ZERO)?;
    let sky = match args.sky {
        Some(sky) => sky,
        None if scene.light_count() == 0 => Vec3::ONE,
        None => Vec3::ZERO,
    };
    if sky != Vec3::ZERO {
        scene = PathScene::new(built.mesh(), &albedo, &emission, sky)?;
    }
    line(
        "scene",
        format!("{name}: {triangles} triangles, loaded in {load_s:.3} s"),
    );
    match &built {
        Built::Kd(tree) => {
            let st = tree.stats();
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
        }
        Built::Brute(_) => line(
            "brute",
            "the brute-force oracle: every triangle for every ray".to_string(),
        ),
    }
    line("camera", format!("{camera} ({camera_from})"));
    let lights = match (scene.light_count(), args.sky) {
        (0, None) => "none (no `Ke` in the materials): a white sky lights the scene".to_string(),
        (n, _) => format!("{n} emissive triangles"),
    };
    line(
        "lights",
        format!("{lights}; sky {},{},{}", sky.x, sky.y, sky.z),
    );

    // Render
    let first = match &built {
        Built::Kd(tree) => trace(tree, &scene, &opts)?,
        Built::Brute(mesh) => trace(&BruteForce::new(mesh), &scene, &opts)?,
    };
    write_png(&args.out, &first.film.to_srgb8(exposure, tone))?;
    line(
        "image",
        format!(
            "{}x{}, {} spp in {} passes, {} estimator, roulette after {} bounces, at most {} \
             -> {} ({}, exposure {exposure:+})",
            opts.width,
            opts.height,
            opts.spp,
            opts.passes(),
            opts.estimator.name(),
            opts.rr_depth,
            opts.max_depth,
            args.out.display(),
            tone.name()
        ),
    );
    let st = &first.stats;
    line(
        "rays",
        format!(
            "{} camera + {} shadow + {} bounce = {} ({:.2} per path)",
            st.camera.rays,
            st.shadow.rays,
            st.bounce.rays,
            st.rays(),
            st.rays() as f64 / st.paths.max(1) as f64
        ),
    );
    line("tracing", kinds(st, opts.mode));
    let traced = st.camera.seconds + st.shadow.seconds + st.bounce.seconds;
    line(
        "render",
        format!(
            "{:.3} s on {} threads: {:.2} Mrays/s overall (tracing and shading), {:.0} % of \
             the threads' time in the queries",
            first.secs,
            opts.threads,
            mrays(st.rays(), first.secs),
            100.0 * traced / (first.secs * opts.threads as f64).max(1e-9)
        ),
    );
    if st.dropped > 0 {
        line(
            "warning",
            format!(
                "{} samples had no finite radiance and were counted as black",
                st.dropped
            ),
        );
    }

    // Heat map of the camera rays through the pixel centres (kd-tree only)
    if let (Some(path), Built::Kd(tree)) = (&args.heatmap, &built) {
        let mut o = RenderOptions::new(camera, Vec3::ZERO, opts.width, opts.height);
        o.mode = opts.mode;
        o.threads = opts.threads;
        let heat = render::heat_map(tree, &o, &|_| {})?;
        write_png(path, &heatmap::heat_image(&heat))?;
        line(
            "heat map",
            format!(
                "{}: {}..{} nodes + leaves + triangle tests {} (camera rays through the pixel \
                 centres)",
                path.display(),
                heat.min(),
                heat.max(),
                if opts.mode == Mode::Scalar {
                    "per ray".to_string()
                } else {
                    format!("per {}-ray packet", opts.mode.width())
                }
            ),
        );
    }

    // Every mode of the bounce and shadow rays
    let mut mismatch = false;
    if args.compare {
        let mut lines = Vec::new();
        for mode in MODES {
            let o = PathOptions { mode, ..opts };
            let r = match (&built, mode == opts.mode) {
                (_, true) => None,
                (Built::Kd(tree), _) => Some(trace(tree, &scene, &o)?),
                (Built::Brute(mesh), _) => Some(trace(&BruteForce::new(mesh), &scene, &o)?),
            };
            let r = r.as_ref().unwrap_or(&first);
            mismatch |= r.film != first.film;
            lines.push(format!(
                "{:<8} {:.3} s, {}",
                mode.name(),
                r.secs,
                kinds(&r.stats, mode)
            ));
        }
        line(
            "compare",
            format!(
                "images identical: {}\n{}",
                if mismatch { "NO" } else { "yes" },
                lines
                    .iter()
                    .map(|l| format!("          {l}"))
                    .collect::<Vec<_>>()
                    .join("\n")
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

/// Each kind's speed: `camera X Mrays/s (packet8), shadow ..., bounce ...`.
fn kinds(st: &PathStats, mode: Mode) -> String {
    let k = |name: &str, r: &RayKind, how: &str| {
        format!("{name} {:.2} Mrays/s ({how})", r.mrays_per_second())
    };
    format!(
        "{}, {}, {}: per thread, time in the queries only",
        k("camera", &st.camera, "packet8"),
        k("shadow", &st.shadow, mode.name()),
        k("bounce", &st.bounce, mode.name())
    )
}

/// Every pass of the render through `query`, under a progress bar on
/// large renders (when stderr is a terminal).
fn trace<Q: PacketQuery + Sync>(
    query: &Q,
    scene: &PathScene<'_>,
    opts: &PathOptions,
) -> Result<Run, Box<dyn Error>> {
    let mut pt = PathTracer::new(query, scene, opts)?;
    let passes = opts.passes();
    let est = opts.width as u64 * opts.height as u64 * opts.spp as u64 * 8;
    let bar = ProgressBar::with_draw_target(
        Some(passes as u64 * pt.tiles() as u64),
        if est > PROGRESS_RAYS && std::io::stderr().is_terminal() {
            ProgressDrawTarget::stderr()
        } else {
            ProgressDrawTarget::hidden()
        },
    );
    let style = ProgressStyle::with_template(
        "{msg} [{elapsed_precise}] {wide_bar} {percent:>3}%, eta {eta}",
    )
    .unwrap_or_else(|_| ProgressStyle::default_bar());
    bar.set_style(style);
    let t = Instant::now();
    let mut pass = 0;
    while !pt.is_done() {
        pass += 1;
        bar.set_message(format!(
            "{} pass {pass}/{passes}, {}/{} spp",
            opts.mode.name(),
            pt.film().samples(),
            opts.spp
        ));
        pt.pass(&|n| bar.inc(n as u64))?;
    }
    let secs = t.elapsed().as_secs_f64();
    bar.finish_and_clear();
    Ok(Run {
        film: pt.film().clone(),
        stats: *pt.stats(),
        secs,
    })
}
