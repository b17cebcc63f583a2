//! The renderer: the path tracer by default, the direct renderer with
//! `--direct`; the same image for any thread count and mode (with and
//! without AO); clean one-line errors from the binary that name the fix;
//! PNGs that decode to the requested size; heat maps that reflect the
//! real traversal cost.

use glam::Vec3;
use packtrace::Mode;
use packtrace::protocol::SceneFrame;
use packtrace::render::{self, HeatMap, RenderOptions};
use packtrace::{Camera, KdBuildParams, KdTree, Mesh, load_obj, load_view};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

const BIN: &str = env!("CARGO_BIN_EXE_render");

fn manifest_dir() -> &'static Path {
    // The repository's root (the parent of `cli/`): data/, README.md.
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("cli/ has a parent")
}

/// A scratch directory, removed when dropped.
struct Scratch(PathBuf);

impl Scratch {
    fn new(name: &str) -> Scratch {
        let d =
            std::env::temp_dir().join(format!("packtrace-render-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&d).expect("create scratch dir");
        Scratch(d)
    }

    fn path(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Run the binary from the crate root (so the default scene resolves).
fn run(args: &[&str]) -> Output {
    Command::new(BIN)
        .args(args)
        .current_dir(manifest_dir())
        .env("RUST_BACKTRACE", "1")
        .output()
        .expect("run the render binary")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The run succeeded; its stdout.
fn ok(args: &[&str]) -> String {
    let out = run(args);
    assert!(
        out.status.success(),
        "render {args:?} failed: {}",
        text(&out.stderr)
    );
    text(&out.stdout)
}

/// The run failed cleanly: non-zero status, one line on stderr, no panic.
/// Returns that line.
fn fails(args: &[&str]) -> String {
    let out = run(args);
    let err = text(&out.stderr);
    assert!(!out.status.success(), "render {args:?} succeeded");
    assert!(
        !err.contains("panicked") && !err.to_lowercase().contains("backtrace"),
        "render {args:?} panicked: {err}"
    );
    let lines: Vec<&str> = err.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "render {args:?}: not one line: {err}");
    assert!(lines[0].starts_with("error"), "{}", lines[0]);
    lines[0].to_string()
}

/// Decode a PNG: (width, height, RGB8 bytes).
fn decode(path: &Path) -> (u32, u32, Vec<u8>) {
    let file = std::fs::File::open(path).expect("open png");
    let mut reader = png::Decoder::new(std::io::BufReader::new(file))
        .read_info()
        .expect("png header");
    let mut buf = vec![0; reader.output_buffer_size().expect("buffer size")];
    let info = reader.next_frame(&mut buf).expect("png data");
    assert_eq!(
        (info.color_type, info.bit_depth),
        (png::ColorType::Rgb, png::BitDepth::Eight)
    );
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

#[test]
fn image_is_identical_for_any_threads_and_mode_with_and_without_ao() {
    let dir = Scratch::new("identical");
    let mut by_ao = Vec::new();
    for ao in ["0", "4"] {
        let mut files = Vec::new();
        for mode in ["packet4", "scalar", "packet8", "stream"] {
            for threads in ["1", "2"] {
                let out = dir.path(&format!("{mode}-{threads}-{ao}.png"));
                let out_s = out.to_str().unwrap();
                #[rustfmt::skip]
                ok(&["--direct", "--size", "64x64", "--ao", ao, "--mode", mode, "--threads", threads, "--out", out_s]);
                files.push((out.clone(), std::fs::read(&out).expect("read png")));
            }
        }
        for (path, bytes) in &files[1..] {
            assert!(
                *bytes == files[0].1,
                "{} differs from {}",
                path.display(),
                files[0].0.display()
            );
        }
        by_ao.push(files.swap_remove(0).1);
    }
    // AO changes the picture (so the comparison above is not vacuous).
    assert_ne!(by_ao[0], by_ao[1]);
}

#[test]
fn library_images_agree_across_modes_threads_tiles_and_samples() {
    let scene = manifest_dir().join("data/cornell.obj");
    let mesh = load_obj(&scene).unwrap();
    let view = load_view(&scene).unwrap();
    let frame = SceneFrame::of(&mesh);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
    let mut opts = RenderOptions::new(
        view.camera_or_auto(&frame.bounds),
        view.light_or_default(&frame),
        48,
        40,
    );
    opts.spp = 3;
    opts.ao_samples = 5;
    let mut base = None;
    for mode in Mode::ALL {
        for (threads, tile) in [(1, 16), (2, 4), (3, 48)] {
            let o = RenderOptions {
                mode,
                threads,
                tile_size: tile,
                ..opts
            };
            let r = render::render(&tree, &o, &|_| {}).unwrap();
            assert_eq!(r.rays.primary, 48 * 40 * 3);
            assert_eq!(r.rays.ao % 5, 0);
            match &base {
                None => base = Some(r),
                Some(b) => {
                    assert!(r.image.bit_identical(&b.image), "{mode} {threads} {tile}");
                    assert_eq!(r.rays, b.rays, "{mode} {threads} {tile}");
                }
            }
        }
    }
}

#[test]
fn progress_is_reported_for_every_tile() {
    use std::sync::atomic::{AtomicUsize, Ordering};
    let tree = KdTree::build(
        packtrace::protocol::generate::cornell_box(),
        &KdBuildParams::default(),
    )
    .unwrap();
    let cam = Camera::parse("278,273,-800,278,273,0,0,1,0,39.3077").unwrap();
    let mut opts = RenderOptions::new(cam, Vec3::new(278.0, 538.8, 279.5), 40, 36);
    opts.tile_size = 8;
    opts.threads = 2;
    let done = AtomicUsize::new(0);
    render::render(&tree, &opts, &|n| {
        done.fetch_add(n, Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(done.load(Ordering::Relaxed), opts.tile_count());
    assert_eq!(opts.tile_count(), 5 * 5);
}

/// The default scene is built in: `render` with no `--scene`, run from a
/// directory without `data/`, path-traces it, and with `--direct` gives
/// the image of `--direct --scene data/cornell.obj` pixel for pixel;
/// `--help` names the camera's ten numbers.
#[test]
fn the_default_scene_is_found_from_any_directory() {
    let dir = Scratch::new("default-scene");
    let render_in = |args: &[&str]| {
        let out = Command::new(BIN)
            .args(args)
            .current_dir(&dir.0)
            .output()
            .expect("run the render binary");
        assert!(out.status.success(), "{}", text(&out.stderr));
        text(&out.stdout)
    };
    #[rustfmt::skip]
    let path = render_in(&["--size", "16x16", "--spp", "2", "--out", "path.png"]);
    assert!(path.contains("built-in Cornell box"), "{path}");
    assert!(path.contains("2 emissive triangles"), "{path}");
    assert_eq!(decode(&dir.path("path.png")).0, 16);
    let direct = render_in(&["--direct", "--size", "32x32", "--out", "default.png"]);
    assert!(direct.contains("built-in Cornell box"));
    let file = dir.path("file.png");
    ok(&[
        "--direct",
        "--scene",
        "data/cornell.obj",
        "--size",
        "32x32",
        "--out",
        file.to_str().unwrap(),
    ]);
    assert_eq!(decode(&dir.path("default.png")), decode(&file));
    assert!(ok(&["--help"]).contains("--camera <ex,ey,ez,tx,ty,tz,ux,uy,uz,fov>"));
}

#[test]
fn missing_scene_is_a_clean_error() {
    let dir = Scratch::new("missing");
    let out = dir.path("x.png");
    let line = fails(&[
        "--scene",
        "no/such/scene.obj",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(line.contains("no/such/scene.obj"), "{line}");
    // The OS's reason, once: `error: no/such/scene.obj: cannot read the
    // file: No such file or directory (os error 2)`.
    let reason = std::fs::read("no/such/scene.obj").unwrap_err().to_string();
    assert_eq!(line.matches(&reason).count(), 1, "{line}");
    // ...and what to do about it.
    assert!(
        line.ends_with("omit --scene for the built-in Cornell box"),
        "{line}"
    );
    assert!(!out.exists());
    let direct = fails(&["--direct", "--scene", "no/such/scene.obj"]);
    assert!(
        direct.ends_with("omit --scene for the built-in Cornell box"),
        "{direct}"
    );
}

#[test]
fn malformed_obj_is_a_clean_error() {
    let dir = Scratch::new("malformed");
    let out = dir.path("x.png");
    let cases = [
        (
            "bad-number.obj",
            &b"v 1 2 3 a b\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 2 3 4\n"[..],
        ),
        ("bad-index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
        ("no-faces.obj", b"v 0 0 0\nv 1 0 0\n"),
        ("binary.obj", b"\x00\x01\xff\xfegarbage\n"),
    ];
    for (name, content) in cases {
        let scene = dir.path(name);
        std::fs::write(&scene, content).unwrap();
        let line = fails(&[
            "--scene",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        assert!(line.contains(name), "{name}: {line}");
    }
    // A malformed view file beside a good scene is an error too.
    let scene = dir.path("tri.obj");
    std::fs::write(&scene, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    std::fs::write(dir.path("tri.view"), "camera 1,2,3\n").unwrap();
    let line = fails(&[
        "--scene",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(line.contains("tri.view:1"), "{line}");
    assert!(!out.exists());
}

#[test]
fn bad_options_are_clean_errors() {
    let dir = Scratch::new("options");
    let out = dir.path("x.png");
    let o = out.to_str().unwrap();
    for (args, expect) in [
        (vec!["--size", "63x64"], "even"),
        (vec!["--size", "64"], "WIDTHxHEIGHT"),
        (vec!["--size", "0x64"], "even"),
        (vec!["--size", "64xsixty"], "sixty"),
        (vec!["--size", "20000x2"], "at most"),
        (vec!["--spp", "0"], "spp 0"),
        (vec!["--direct", "--spp", "0"], "spp 0"),
        (vec!["--spp", "-1"], "-1"),
        (vec!["--direct", "--ao", "99999"], "ao 99999"),
        (vec!["--threads", "0"], "thread"),
        (vec!["--direct", "--threads", "0"], "thread"),
        (vec!["--mode", "simd"], "simd"),
        (vec!["--camera", "1,2,3"], "camera"),
        (vec!["--camera", "0,0,0,0,0,0,0,1,0,45"], "coincide"),
        (vec!["--light", "1,2,x"], "light"),
        (vec!["--frobnicate"], "frobnicate"),
    ] {
        let mut a = args.clone();
        a.extend(["--out", o]);
        let line = fails(&a);
        assert!(line.contains(expect), "{args:?}: {line}");
    }
    assert!(!out.exists());
    // An output path that cannot be written.
    let line = fails(&["--size", "8x8", "--spp", "1", "--out", "/no/such/dir/x.png"]);
    assert!(line.contains("/no/such/dir/x.png"), "{line}");
}

/// Options that do not fit the renderer, or values it does not know, end
/// the run with one line that names the fix.
#[test]
fn path_tracing_options_errors_name_the_fix() {
    let dir = Scratch::new("path-options");
    let out = dir.path("x.png");
    let heat = dir.path("heat.png");
    let o = out.to_str().unwrap();
    #[rustfmt::skip]
    let cases = [
        (vec!["--mode", "group8x8"], "the group modes trace coherent screen tiles: use them with the direct renderer"),
        (vec!["--mode", "packet16"], "expected scalar or packet4"),
        (vec!["--accel", "bvh8"], "unknown structure `bvh8` (expected kd or brute)"),
        (vec!["--direct", "--accel", "brute"], "--accel is an option of the path tracer: drop it, or drop --direct"),
        (vec!["--direct", "--seed", "3"], "--seed is an option of the path tracer: drop it, or drop --direct"),
        (vec!["--estimator", "bdpt"], "expected mis, nee or bsdf"),
        (vec!["--tone", "gamma"], "expected clamp or filmic"),
        (vec!["--light", "1,2,3"], "add --direct"),
        (vec!["--ao", "4"], "add --direct"),
        (vec!["--scene", "data/cornell_spheres.scene"], "render scene files of instances with --direct"),
        (vec!["--accel", "brute", "--heatmap", heat.to_str().unwrap()], "drop --accel brute"),
        (vec!["--sky", "1,2"], "r,g,b"),
        (vec!["--sky", "1,-2,0"], "not negative"),
        (vec!["--exposure", "nan"], "finite number of stops"),
        (vec!["--pass-spp", "0"], "pass spp 0 is not in 1..=65536"),
        (vec!["--max-depth", "5000"], "max depth 5000 is not in 0..=1024"),
        (vec!["--spp", "70000"], "spp 70000 is not in 1..=65536"),
    ];
    for (args, expect) in cases {
        let mut a = args.clone();
        a.extend(["--out", o]);
        let line = fails(&a);
        assert!(line.contains(expect), "{args:?}: {line}");
    }
    assert!(!out.exists() && !heat.exists());
}

/// Unknown options and engines, and missing files, end the run with one
/// line that names the fix: the option clap suggests and where the
/// options are listed; where `bench`'s engines are traced; what to do
/// about a path that does not exist.
#[test]
fn unknown_options_engines_and_missing_files_name_the_fix() {
    let dir = Scratch::new("unknown");
    let out = dir.path("x.png");
    let o = out.to_str().unwrap();
    let help = "(`render --help` lists the options)";
    // (arguments, the line contains, the line ends pointing to --help)
    #[rustfmt::skip]
    let cases = [
        (vec!["--frobnicate", "--out", o], "unexpected argument '--frobnicate' found", true),
        (vec!["--spd", "3", "--out", o], "unexpected argument '--spd' found; did you mean --spp?", true),
        (vec!["--out", o, "cornell.obj"], "unexpected argument 'cornell.obj' found", true),
        (vec!["--out", o, "--scene"], "a value is required for '--scene <PATH>' but none was supplied", true),
        (vec!["--accel", "embree", "--out", o], "`embree` is a peer engine of the benchmark, not of render (which traces kd or brute): run `bench --accel embree`", false),
        (vec!["--accel", "obvhs", "--out", o], "run `bench --accel obvhs`", false),
        (vec!["--accel", "tinybvh", "--out", o], "run `bench --accel tinybvh`", false),
        (vec!["--accel", "kd8", "--out", o], "`kd8` is a structure of `bench --accel`; render traces kd (the kd8 tree) or brute", false),
        (vec!["--accel", "bvh8", "--out", o], "unknown structure `bvh8` (expected kd or brute)", false),
        (vec!["--mode", "simd", "--out", o], "unknown mode `simd` (expected scalar or packet4", false),
        (vec!["--scene", "no/such/box.obj", "--out", o], "check the path, or omit --scene for the built-in Cornell box", false),
        (vec!["--direct", "--scene", "no/such/box.scene", "--out", o], "check the path, or omit --scene for the built-in Cornell box", false),
        (vec!["--view", "no/such/box.view", "--out", o], "check the path, or omit --view for NAME.view beside the scene", false),
        (vec!["--direct", "--view", "no/such/box.view", "--out", o], "check the path, or omit --view", false),
    ];
    for (args, expect, points_to_help) in cases {
        let line = fails(&args);
        assert!(line.contains(expect), "{args:?}: {line}");
        assert_eq!(line.ends_with(help), points_to_help, "{args:?}: {line}");
    }
    assert!(!out.exists());
}

/// `render` path-traces by default: its summary gives each ray kind's
/// count and speed, `--compare` traces the bounce and shadow rays in
/// every mode to the same image, the brute-force oracle gives the same
/// PNG, and the light is seen, saturated, at the top of the image.
#[test]
fn path_tracing_is_the_default_and_reports_each_ray_kind() {
    let dir = Scratch::new("path");
    let (kd, brute) = (dir.path("kd.png"), dir.path("brute.png"));
    #[rustfmt::skip]
    let stdout = ok(&["--size", "32x32", "--spp", "4", "--pass-spp", "3", "--threads", "2",
        "--compare", "--out", kd.to_str().unwrap()]);
    for needle in [
        "the built-in Cornell box (data/cornell.obj with its light lowered 1 mm): 32 triangles",
        "kd-tree   built in",
        "lights    2 emissive triangles; sky 0,0,0",
        "32x32, 4 spp in 2 passes, mis estimator, roulette after 3 bounces, at most 64",
        "4096 camera + ",
        " shadow + ",
        " bounce = ",
        "camera ",
        "Mrays/s (packet8), shadow ",
        "Mrays/s (stream), bounce ",
        "on 2 threads",
        "images identical: yes",
        "packet4 ",
        "stream ",
    ] {
        assert!(stdout.contains(needle), "no `{needle}` in\n{stdout}");
    }
    #[rustfmt::skip]
    ok(&["--size", "32x32", "--spp", "4", "--accel", "brute", "--mode", "packet8",
        "--out", brute.to_str().unwrap()]);
    let (w, h, px) = decode(&kd);
    assert_eq!((w, h), (32, 32));
    assert_eq!(decode(&brute).2, px);
    let at = |x: u32, y: u32| {
        let i = 3 * (y * w + x) as usize;
        [px[i], px[i + 1], px[i + 2]]
    };
    assert_eq!(at(16, 4), [255, 255, 255], "the light");
    let (left, right) = (at(2, 16), at(29, 16));
    assert!(left[0] > 2 * left[1], "left wall {left:?}");
    assert!(right[1] > right[0] + 20, "right wall {right:?}");
}

/// An OBJ scene path-traces with its `Ke` materials as lights; without
/// any (`data/cornell.obj` keeps the published data, no emission), a
/// white sky lights it.
#[test]
fn obj_scenes_are_lit_by_their_emissive_materials_or_the_sky() {
    let dir = Scratch::new("obj-lights");
    let out = dir.path("x.png");
    let o = out.to_str().unwrap();
    #[rustfmt::skip]
    let sky = ok(&["--scene", "data/cornell.obj", "--size", "16x16", "--spp", "2", "--out", o]);
    assert!(
        sky.contains("none (no `Ke` in the materials): a white sky lights the scene; sky 1,1,1"),
        "{sky}"
    );
    let obj = dir.path("lamp.obj");
    std::fs::write(
        &obj,
        "mtllib lamp.mtl\nv -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nv -1 -1 2\nv 1 -1 2\nv 1 1 2\n\
         v -1 1 2\nusemtl floor\nf 1 2 3\nf 1 3 4\nusemtl lamp\nf 5 7 6\nf 5 8 7\n",
    )
    .unwrap();
    std::fs::write(
        dir.path("lamp.mtl"),
        "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl lamp\nKd 0 0 0\nKe 4 4 4\n",
    )
    .unwrap();
    #[rustfmt::skip]
    let lamp = ok(&["--scene", obj.to_str().unwrap(), "--camera", "0,-3,1,0,0,1,0,0,1,60",
        "--size", "16x16", "--spp", "2", "--out", o]);
    assert!(
        lamp.contains("lights    2 emissive triangles; sky 0,0,0"),
        "{lamp}"
    );
}

#[test]
fn pngs_decode_with_the_requested_size_and_summary_is_complete() {
    let dir = Scratch::new("png");
    let (out, heat) = (dir.path("img.png"), dir.path("heat.png"));
    #[rustfmt::skip]
    let stdout = ok(&["--direct", "--size", "48x32", "--spp", "2", "--ao", "2", "--out", out.to_str().unwrap(),
        "--heatmap", heat.to_str().unwrap(), "--compare", "--threads", "2"]);
    let (w, h, pixels) = decode(&out);
    assert_eq!((w, h), (48, 32));
    // lit walls and dark corners: not a flat image
    assert!(pixels.iter().any(|&b| b > 150) && pixels.iter().any(|&b| b < 40));
    let (hw, hh, _) = decode(&heat);
    // the legend strip below the map: 13 font pixels of one image pixel
    // at this width (src/bin/render/heatmap.rs)
    assert_eq!((hw, hh), (48, 32 + 13));
    for needle in [
        "the built-in Cornell box (data/cornell.obj): 32 triangles",
        "nodes",
        "refs/triangle",
        "SAH cost",
        "bytes",
        "48x32, 2 spp, 2 AO rays/hit",
        "(view file)",
        "primary +",
        "Mrays/s, 2 threads, packet8",
        "x scalar",
        "images identical: yes",
        "heat map",
    ] {
        assert!(stdout.contains(needle), "no `{needle}` in\n{stdout}");
    }
    // 48 * 32 * 2 primary rays
    assert!(stdout.contains("3072 primary"), "{stdout}");
}

/// Heat map of `mesh` seen by its auto camera (or `camera`), 64 x 64.
fn heat_of(mesh: Mesh, camera: Option<Camera>, mode: Mode) -> HeatMap {
    let frame = SceneFrame::of(&mesh);
    let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
    let cam = camera.unwrap_or_else(|| Camera::auto(&frame.bounds));
    let mut opts = RenderOptions::new(cam, frame.center + Vec3::Y * frame.diagonal, 64, 64);
    opts.mode = mode;
    render::heat_map(&tree, &opts, &|_| {}).unwrap()
}

/// One triangle far larger than the view: every ray hits it.
fn big_triangle() -> Mesh {
    Mesh::new(
        vec![
            Vec3::new(-100.0, -100.0, 0.0),
            Vec3::new(100.0, -100.0, 0.0),
            Vec3::new(0.0, 100.0, 0.0),
        ],
        vec![[0, 1, 2]],
    )
    .unwrap()
}

#[test]
fn heat_map_scale_reflects_the_real_counters() {
    let cam = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    for mode in Mode::ALL {
        let tri = heat_of(big_triangle(), Some(cam), mode);
        if mode.tile().is_some() {
            // A group: one leaf for the whole group, and per packet one
            // cell clipping and one triangle test, shared by its n
            // packets: (1 + 2n) / n = 2 each.
            assert_eq!((tri.min(), tri.max()), (2, 2), "{mode}");
            let sphere = heat_of(packtrace::protocol::generate::sphere(100_000), None, mode);
            assert!(sphere.max() >= 10 * tri.max(), "{mode}: {}", sphere.max());
            // Every pixel of a group tile carries the same share.
            for y in (0..64).step_by(8) {
                for x in (0..64).step_by(8) {
                    let first = sphere.counts[y * 64 + x];
                    for p in 0..64 {
                        assert_eq!(sphere.counts[(y + p / 8) * 64 + x + p % 8], first, "{mode}");
                    }
                }
            }
            continue;
        }
        // one leaf and one triangle test per ray (or packet)
        assert_eq!((tri.min(), tri.max()), (2, 2), "{mode}");
        let sphere = heat_of(packtrace::protocol::generate::sphere(100_000), None, mode);
        assert!(sphere.max() >= 10 * tri.max(), "{mode}: {}", sphere.max());
        // rays that miss the scene box cost nothing
        assert_eq!(sphere.min(), 0, "{mode}");
        // packets cost at least what their dearest ray costs alone
        if mode != Mode::Scalar {
            let scalar = heat_of(
                packtrace::protocol::generate::sphere(100_000),
                None,
                Mode::Scalar,
            );
            for (p, s) in sphere.counts.iter().zip(&scalar.counts) {
                assert!(p >= s, "packet {p} < ray {s}");
            }
        }
    }
}

/// A scene test (`tests/common/scenes.rs` of the library): listed as
/// ignored by a plain `cargo test`, fails when run without its scene.
#[test]
#[ignore = "needs PACKTRACE_SCENES=<shared scenes dir>; run with: cargo test -- --include-ignored"]
fn heat_map_of_the_bunny_is_far_above_one_triangle() {
    let dir = std::env::var_os("PACKTRACE_SCENES")
        .expect("this scene test needs PACKTRACE_SCENES, the shared scenes' directory");
    let scene = Path::new(&dir).join("bunny.obj");
    assert!(
        scene.is_file(),
        "PACKTRACE_SCENES is set but {} is missing",
        scene.display()
    );
    let mesh = load_obj(&scene).unwrap();
    let view = load_view(&scene).unwrap();
    let bunny = heat_of(mesh, view.camera, Mode::Packet4);
    let cam = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    let tri = heat_of(big_triangle(), Some(cam), Mode::Packet4);
    assert!(bunny.max() >= 20 * tri.max(), "bunny max {}", bunny.max());
}

/// The embedding example has one copy, in the README's packet section
/// (compiled as a doc test through `lib.rs`); docs/rendering.md and the
/// `render` module docs link to it instead of repeating it.
#[test]
fn embedding_example_lives_only_in_the_readme() {
    let read = |p: &str| std::fs::read_to_string(manifest_dir().join(p)).unwrap();
    let (readme, md, src) = (
        read("README.md"),
        read("docs/rendering.md"),
        read("src/render/mod.rs"),
    );
    let section = &readme[readme.find("### Packets").expect("README packet section")..];
    let start = section.find("```rust\n").expect("code block") + "```rust\n".len();
    let example = &section[start..start + section[start..].find("```").expect("block end")];
    for needle in ["thread::scope", "intersect8", "occluded8"] {
        assert!(example.contains(needle), "README example lacks {needle}");
    }
    let doc: String = src
        .lines()
        .filter_map(|l| l.strip_prefix("//!"))
        .collect::<Vec<_>>()
        .join("\n");
    for (name, text) in [
        ("docs/rendering.md", md.as_str()),
        ("src/render/mod.rs docs", doc.as_str()),
    ] {
        assert!(
            text.contains("README.md#packets"),
            "{name} links to the README"
        );
        assert!(
            !text.contains("thread::scope"),
            "{name} repeats the example"
        );
    }
    assert!(md.contains("cargo run --release") && md.contains("cargo test"));
}

/// The default image has the Cornell box's colours (red wall on the left,
/// green on the right); an OBJ whose material library is missing still
/// renders, in grey, with a warning naming the library.
#[test]
fn colours_come_from_the_materials_and_a_missing_library_only_warns() {
    let dir = Scratch::new("colours");
    let png = dir.path("default.png");
    ok(&[
        "--direct",
        "--size",
        "64x64",
        "--out",
        png.to_str().unwrap(),
    ]);
    let (w, _, px) = decode(&png);
    let at = |x: u32, y: u32| {
        let i = 3 * (y * w + x) as usize;
        [px[i], px[i + 1], px[i + 2]]
    };
    let (left, right) = (at(3, 32), at(60, 32));
    assert!(left[0] > 2 * left[1], "left wall {left:?}");
    assert!(right[1] > right[0] + 40, "right wall {right:?}");

    let text_obj = std::fs::read_to_string(manifest_dir().join("data/cornell.obj")).unwrap();
    let obj = dir.path("box.obj");
    std::fs::write(
        &obj,
        text_obj.replace("mtllib cornell.mtl", "mtllib gone.mtl"),
    )
    .unwrap();
    let grey = dir.path("grey.png");
    let out = run(&[
        "--direct",
        "--scene",
        obj.to_str().unwrap(),
        "--size",
        "64x64",
        "--out",
        grey.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let err = text(&out.stderr);
    assert!(
        err.contains("warning:") && err.contains("gone.mtl") && err.contains("rendering in grey"),
        "{err}"
    );
    let (w, _, px) = decode(&grey);
    let i = 3 * (32 * w + 3) as usize;
    let left = [px[i], px[i + 1], px[i + 2]];
    assert!(left[0].abs_diff(left[1]) < 20, "grey left wall {left:?}");
}
