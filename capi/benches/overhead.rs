//! What calling through the C API costs over the Rust API, on the
//! protocol's packet8 primary rays and on a stream of random (incoherent)
//! rays: the same tree, the same rays, the same process, repetitions of
//! the two sides alternated (A B B A ...) so that a machine's drift under
//! load falls on both alike.
//!
//! ```text
//! cargo bench -p packtrace-c --bench overhead -- [SCENE.obj] [--size N] [--reps R]
//! ```
//!
//! - Rust side: `KdTree::intersect8` on the workload's prebuilt
//!   `RayPacket8`s (the protocol benchmark's timed work), and
//!   `KdTree::intersect_rays` on the random rays.
//! - Rust host side: the same packets built by a Rust host from the C
//!   side's structure-of-arrays rays with `RayPacket8::from_soa` (checked,
//!   as the C call checks), traced with `intersect8`, and the hits written
//!   back into the arrays (`tfar`, `prim_id`, `u`, `v`; no normal): what a
//!   Rust host with its rays in arrays pays, against which the C call's
//!   own cost is measured.
//! - C side: `packtrace_intersect8` on `PacktraceRayHit8` structs and
//!   `packtrace_intersect_stream` on `PacktraceRayHit` structs holding the
//!   same rays, called through an opaque function pointer (no inlining,
//!   as from a C host). The structs are refilled before each repetition,
//!   outside the timed region (a host fills them anyway); the call checks
//!   the rays, traces, and writes `tfar` and the hit record (with the
//!   geometric normal) per lane.
//!
//! Every C answer is compared with the Rust answer, bit for bit, once.
//! For instruction counts, run one repetition under callgrind and read the
//! inclusive counts of `overhead::rust_packet8`, `rust_soa_packet8`, `c_packet8`,
//! `rust_stream`, `c_stream` (docs/c-api.md has the command).

use packtrace::protocol::camera::{Camera, load_view};
use packtrace::protocol::workload::{NO_RAY, primary, random};
use packtrace::protocol::{SceneFrame, generate};
use packtrace::{Hit, HitPacket8, KdBuildParams, KdTree, Mesh, Ray, RayPacket8, load_obj};
use packtrace_c::{
    PACKTRACE_INVALID_ID, PacktraceRay, PacktraceRayHit, PacktraceRayHit8, PacktraceStatus,
    PacktraceTree, packtrace_intersect_stream, packtrace_intersect8, packtrace_tree_new,
    packtrace_tree_release,
};
use std::hint::black_box;
use std::path::PathBuf;
use std::time::Instant;

type Intersect8 = extern "C" fn(
    *const std::ffi::c_int,
    *const PacktraceTree,
    *mut PacktraceRayHit8,
) -> PacktraceStatus;
type Stream =
    extern "C" fn(*const PacktraceTree, *mut PacktraceRayHit, usize, usize) -> PacktraceStatus;

fn c_ray(r: &Ray) -> PacktraceRay {
    PacktraceRay {
        org_x: r.origin().x,
        org_y: r.origin().y,
        org_z: r.origin().z,
        tnear: r.t_min(),
        dir_x: r.dir().x,
        dir_y: r.dir().y,
        dir_z: r.dir().z,
        time: 0.0,
        tfar: r.t_max(),
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

#[inline(never)]
fn rust_packet8(tree: &KdTree, packets: &[RayPacket8], out: &mut [HitPacket8]) {
    for (p, o) in packets.iter().zip(out) {
        *o = tree.intersect8(p);
    }
}

#[inline(never)]
fn rust_soa_packet8(tree: &KdTree, valid: &[[i32; 8]], work: &mut [PacktraceRayHit8]) {
    for (v, rh) in valid.iter().zip(work) {
        let r = &mut rh.ray;
        let active = v
            .iter()
            .enumerate()
            .fold(0, |m, (i, &x)| m | u32::from(x == -1) << i);
        let packet = RayPacket8::from_soa(
            [r.org_x, r.org_y, r.org_z],
            [r.dir_x, r.dir_y, r.dir_z],
            r.tnear,
            r.tfar,
            active,
        )
        .expect("valid rays");
        let hits = tree.intersect8(&packet);
        for i in 0..8 {
            match hits.hit(i) {
                Some(h) => {
                    r.tfar[i] = h.t;
                    rh.hit.prim_id[i] = h.prim;
                    rh.hit.u[i] = h.u;
                    rh.hit.v[i] = h.v;
                }
                None => rh.hit.prim_id[i] = PACKTRACE_INVALID_ID,
            }
        }
    }
}

#[inline(never)]
fn c_packet8(
    f: Intersect8,
    tree: *const PacktraceTree,
    valid: &[[i32; 8]],
    work: &mut [PacktraceRayHit8],
) {
    for (v, rh) in valid.iter().zip(work) {
        let s = f(v.as_ptr(), tree, rh);
        debug_assert_eq!(s, PacktraceStatus::Ok);
    }
}

#[inline(never)]
fn rust_stream(tree: &KdTree, rays: &[Ray], hits: &mut [Option<Hit>]) {
    tree.intersect_rays(rays, hits);
}

#[inline(never)]
fn c_stream(f: Stream, tree: *const PacktraceTree, work: &mut [PacktraceRayHit]) {
    let s = f(
        tree,
        work.as_mut_ptr(),
        work.len(),
        size_of::<PacktraceRayHit>(),
    );
    assert_eq!(s, PacktraceStatus::Ok);
}

fn same(h: Option<Hit>, tfar: f32, prim: u32, u: f32, v: f32) -> bool {
    match h {
        None => prim == PACKTRACE_INVALID_ID,
        Some(h) => {
            (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits())
                == (tfar.to_bits(), prim, u.to_bits(), v.to_bits())
        }
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut scene: Option<PathBuf> = None;
    let (mut size, mut reps) = (1024u32, 9usize);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--size" => size = args.next().and_then(|s| s.parse().ok()).expect("--size N"),
            "--reps" => reps = args.next().and_then(|s| s.parse().ok()).expect("--reps R"),
            "--bench" => {}
            s if s.starts_with("--") => panic!("unknown option {s}"),
            s => scene = Some(s.into()),
        }
    }
    let scene = scene.or_else(|| {
        let p = PathBuf::from(std::env::var_os("PACKTRACE_SCENES")?).join("sponza.obj");
        p.exists().then_some(p)
    });
    let (name, mesh, camera): (String, Mesh, Option<Camera>) = match &scene {
        Some(p) => (
            p.display().to_string(),
            load_obj(p).expect("the scene loads"),
            load_view(p).expect("the view file reads").camera,
        ),
        None => (
            "gen:scalable:100k".into(),
            generate::scalable(100_000),
            None,
        ),
    };
    let frame = SceneFrame::of(&mesh);
    let camera = camera.unwrap_or_else(|| Camera::auto(&frame.bounds));
    let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).expect("builds");
    let mut c_tree: *mut PacktraceTree = std::ptr::null_mut();
    let s = packtrace_tree_new(
        mesh.positions().as_ptr().cast(),
        mesh.positions().len(),
        12,
        mesh.triangles().as_ptr().cast(),
        mesh.triangle_count(),
        12,
        std::ptr::null(),
        &mut c_tree,
    );
    assert_eq!(s, PacktraceStatus::Ok);
    let intersect8: Intersect8 = black_box(packtrace_intersect8);
    let stream: Stream = black_box(packtrace_intersect_stream);

    // Packet8 primary rays: the Rust packets and the C structs of the same lanes.
    let set = primary(&camera, size, size).expect("a valid image size");
    let packets: Vec<RayPacket8> = (0..set.packets8.len()).map(|i| set.packet8(i)).collect();
    let mut valid = Vec::with_capacity(packets.len());
    let mut c_packets = Vec::with_capacity(packets.len());
    for lanes in &set.packets8 {
        let mut rh = PacktraceRayHit8::default();
        let mut v = [0; 8];
        for (l, &k) in lanes.iter().enumerate() {
            if k == NO_RAY {
                continue;
            }
            v[l] = -1;
            let r = c_ray(&set.rays[k as usize]);
            rh.ray.org_x[l] = r.org_x;
            rh.ray.org_y[l] = r.org_y;
            rh.ray.org_z[l] = r.org_z;
            rh.ray.dir_x[l] = r.dir_x;
            rh.ray.dir_y[l] = r.dir_y;
            rh.ray.dir_z[l] = r.dir_z;
            rh.ray.tnear[l] = r.tnear;
            rh.ray.tfar[l] = r.tfar;
        }
        valid.push(v);
        c_packets.push(rh);
    }
    // Random rays as one stream.
    let rset = random(&frame, (size * size) as usize);
    let c_rays: Vec<PacktraceRayHit> = rset
        .rays
        .iter()
        .map(|r| PacktraceRayHit {
            ray: c_ray(r),
            hit: Default::default(),
        })
        .collect();

    let mut out8 = vec![HitPacket8::default(); packets.len()];
    let mut work8 = c_packets.clone();
    let mut host8 = c_packets.clone();
    let mut hits = vec![None; rset.rays.len()];
    let mut work = c_rays.clone();
    let (mut t8, mut h8, mut c8, mut ts, mut cs) = (vec![], vec![], vec![], vec![], vec![]);
    for rep in 0..reps + 1 {
        // A B, then B A: each side goes first every other repetition.
        for side in [rep % 2, 1 - rep % 2] {
            work8.copy_from_slice(&c_packets);
            host8.copy_from_slice(&c_packets);
            work.copy_from_slice(&c_rays);
            let t = Instant::now();
            if side == 0 {
                rust_packet8(&tree, &packets, &mut out8);
                t8.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                rust_soa_packet8(&tree, &valid, &mut host8);
                h8.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                rust_stream(&tree, &rset.rays, &mut hits);
                ts.push(t.elapsed().as_secs_f64());
            } else {
                c_packet8(intersect8, c_tree, &valid, &mut work8);
                c8.push(t.elapsed().as_secs_f64());
                let t = Instant::now();
                c_stream(stream, c_tree, &mut work);
                cs.push(t.elapsed().as_secs_f64());
            }
        }
        if rep == 0 {
            // The first repetition warms up and checks every answer.
            for (i, lanes) in set.packets8.iter().enumerate() {
                for (l, &k) in lanes.iter().enumerate() {
                    if k != NO_RAY {
                        let (r, h) = (&work8[i].ray, &work8[i].hit);
                        let ok = same(out8[i].hit(l), r.tfar[l], h.prim_id[l], h.u[l], h.v[l]);
                        assert!(
                            ok,
                            "packet {i} lane {l}: the C API differs from the Rust API"
                        );
                        let (r, h) = (&host8[i].ray, &host8[i].hit);
                        let ok = same(out8[i].hit(l), r.tfar[l], h.prim_id[l], h.u[l], h.v[l]);
                        assert!(
                            ok,
                            "packet {i} lane {l}: the Rust host's SoA answer differs"
                        );
                    }
                }
            }
            for (i, (h, c)) in hits.iter().zip(&work).enumerate() {
                let ok = same(*h, c.ray.tfar, c.hit.prim_id, c.hit.u, c.hit.v);
                assert!(ok, "stream ray {i}: the C API differs from the Rust API");
            }
            t8.clear();
            h8.clear();
            c8.clear();
            ts.clear();
            cs.clear();
        }
    }
    assert_eq!(packtrace_tree_release(c_tree), PacktraceStatus::Ok);
    if reps == 0 {
        return;
    }
    let rays = (size * size) as f64;
    println!(
        "{name}, {size} x {size}, {reps} alternating repetitions, medians; every C answer equals the Rust answer"
    );
    println!(
        "workload                       Rust Mrays/s   C API Mrays/s   C API time / Rust time"
    );
    let c8 = median(c8);
    for (what, r, c) in [
        ("packet8 primary (prebuilt)", median(t8), c8),
        ("packet8 primary (SoA host)", median(h8), c8),
        ("stream random", median(ts), median(cs)),
    ] {
        println!(
            "{what:<30} {:>12.2} {:>15.2} {:>16.3}",
            rays / r / 1e6,
            rays / c / 1e6,
            c / r
        );
    }
}
