//! `render`: the crate's default run target. Loads an OBJ scene, builds the
//! kd-tree, renders it with packet tracing on all cores, writes a PNG and
//! prints how fast it went.
//!
//! ```text
//! cargo run --release                      # the Cornell box -> render.png
//! cargo run --release -- --scene S.obj --ao 8 --spp 4 --heatmap heat.png
//! cargo run --release -- --compare         # every mode against scalar, same threads
//! ```

use clap::Parser;
use glam::Vec3;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use packtrace::protocol::camera::{Camera, View, load_view, parse_light};
use packtrace::protocol::generate;
use packtrace_cli::chain;
mod heatmap;

use packtrace::Mode;
use packtrace::protocol::SceneFrame;
use packtrace::protocol::workload::check_image_size;
use packtrace::render::{self, RenderOptions, Rendered, Rgb8};
use packtrace::{KdBuildParams, KdTree, LoadError, ObjMesh, load_obj, load_obj_with_shading};
use std::error::Error;
use std::fs::File;
use std::io::{BufWriter, IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

/// Render an OBJ scene with SIMD ray packets through an SAH kd-tree.
#[derive(Parser, Debug)]
#[command(name = "render", version)]
struct Args {
    /// Wavefront OBJ scene; its camera and light come from NAME.view beside
    /// it [default: the Cornell box of data/cornell.obj, built in, so it is
    /// found from any directory].
    #[arg(long, value_name = "PATH")]
    scene: Option<PathBuf>,

    /// Camera `ex,ey,ez,tx,ty,tz,ux,uy,uz,fov` (default: the view file's,
    /// else the protocol's auto camera).
    #[arg(
        long,
        value_name = "ex,ey,ez,tx,ty,tz,ux,uy,uz,fov",
        value_parser = parse_camera,
        allow_hyphen_values = true
    )]
    camera: Option<Camera>,

    /// Point light `x,y,z` (default: the view file's, else the protocol's
    /// default light).
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_light_arg, allow_hyphen_values = true)]
    light: Option<Vec3>,

    /// Image size, both even.
    #[arg(long, value_name = "WxH", default_value = "1024x1024", value_parser = parse_size)]
    size: (u32, u32),

    /// Samples per pixel (1: pixel centres; more: hashed jitter).
    #[arg(long, value_name = "N", default_value_t = 1)]
    spp: u32,

    /// Ambient-occlusion rays per hit (0: the sky light reaches every
    /// point unoccluded).
    #[arg(long, value_name = "N", default_value_t = 2)]
    ao: u32,

    /// Tracing mode: scalar, packet4, packet8 (4x2 blocks; the fastest),
    /// stream, or group8x8 / group16x16 (each tile's primary and shadow
    /// rays traced as ray groups).
    #[arg(long, default_value = "packet8", value_parser = parse_mode)]
    mode: Mode,

    /// Threads for the tree build and the render (default: all cores).
    #[arg(long, value_name = "N")]
    threads: Option<usize>,

    /// Output PNG.
    #[arg(long, value_name = "FILE", default_value = "render.png")]
    out: PathBuf,

    /// Also write a traversal-cost heat map (PNG) of the primary rays.
    #[arg(long, value_name = "FILE")]
    heatmap: Option<PathBuf>,

    /// Render in every mode too; print each mode's speed-up over scalar
    /// and whether the images are identical (an error if not).
    #[arg(long)]
    compare: bool,
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
            // One line: clap's own message, without its usage and tip lines.
            let text = e.to_string();
            let line = text.lines().find(|l| !l.trim().is_empty());
            eprintln!("{}", line.unwrap_or("error: invalid arguments"));
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

/// Renders with more traced rays than this get a progress bar (when stderr
/// is a terminal).
const PROGRESS_RAYS: u64 = 4_000_000;

fn run(args: &Args) -> Result<(), Box<dyn Error>> {
    // Options that do not depend on the scene, checked before loading it
    let mut opts = RenderOptions::new(
        Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0)?,
        Vec3::ZERO,
        args.size.0,
        args.size.1,
    );
    opts.spp = args.spp;
    opts.ao_samples = args.ao;
    opts.mode = args.mode;
    if let Some(n) = args.threads {
        opts.threads = n;
    }
    opts.validate()?;

    // Scene and view file
    let t = Instant::now();
    let (mesh, albedo, view, scene) = match &args.scene {
        Some(path) => {
            // A missing or broken material library costs the colours, not
            // the picture: warn and render grey.
            let (mesh, albedo) = match load_obj_with_shading(path) {
                Ok(obj) => {
                    let albedo = albedo_of(&obj);
                    (obj.into_mesh(), albedo)
                }
                Err(e @ LoadError::MaterialLibrary { .. }) => {
                    eprintln!("warning: {e}; rendering in grey");
                    (load_obj(path)?, Vec::new())
                }
                Err(e) => return Err(e.into()),
            };
            (mesh, albedo, load_view(path)?, path.display().to_string())
        }
        // The generator's Cornell box is data/cornell.obj, .mtl and .view
        // (`generate::tests::cornell_data_files_match_the_code`).
        None => (
            generate::from_spec("gen:cornell")?,
            generate::cornell_albedo(),
            View::parse(generate::CORNELL_VIEW)?,
            "the built-in Cornell box (data/cornell.obj)".to_string(),
        ),
    };
    let load_s = t.elapsed().as_secs_f64();
    let frame = SceneFrame::of(&mesh);
    let triangles = mesh.triangle_count();

    // Camera and light: command line, else view file, else protocol
    let (camera, camera_from) = match (args.camera, view.camera) {
        (Some(c), _) => (c, "--camera"),
        (None, Some(c)) => (c, "view file"),
        (None, None) => (view.camera_or_auto(&frame.bounds), "auto"),
    };
    let (light, light_from) = match (args.light, view.light) {
        (Some(l), _) => (l, "--light"),
        (None, Some(l)) => (l, "view file"),
        (None, None) => (view.light_or_default(&frame), "default"),
    };
    opts.camera = camera;
    opts.light = light;
    opts.validate()?;

    // Tree, built on as many threads as the render uses (rayon's pool)
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(opts.threads)
        .build_global();
    let t = Instant::now();
    let tree = KdTree::build(mesh, &KdBuildParams::default())?;
    let build_s = t.elapsed().as_secs_f64();
    let st = tree.stats();

    // Render
    let (out, secs) = timed_render(&tree, &albedo, &opts)?;
    write_png(&args.out, &out.image.to_srgb8())?;

    let mut report = String::new();
    let mut line = |k: &str, v: String| report.push_str(&format!("{k:<9} {v}\n"));
    line(
        "scene",
        format!("{scene}: {triangles} triangles, loaded in {load_s:.3} s"),
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
    line("camera", format!("{camera} ({camera_from})"));
    line(
        "light",
        format!("{},{},{} ({light_from})", light.x, light.y, light.z),
    );
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
    line(
        "render",
        format!(
            "{secs:.3} s, {:.2} Mrays/s, {} threads, {}, {} tiles of {}x{}",
            mrays(r.total(), secs),
            opts.threads,
            opts.mode,
            opts.tile_count(),
            opts.tile_size,
            opts.tile_size
        ),
    );

    // Heat map
    if let Some(path) = &args.heatmap {
        let heat = render::heat_map(&tree, &opts, &|_| {})?;
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
                timed_render(&tree, &albedo, &RenderOptions { mode, ..opts })?
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
fn timed_render(
    tree: &KdTree,
    albedo: &[Vec3],
    opts: &RenderOptions,
) -> Result<(Rendered, f64), Box<dyn Error>> {
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
    let out = render::render_with_albedo(tree, albedo, opts, &|n| bar.inc(n as u64))?;
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
