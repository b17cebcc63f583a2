//! `--check`: every mode and accelerator against scalar kd8, ray by ray.
//!
//! The reference is the plain scalar kd8 query called ray after ray on
//! this thread. Every engine (kd8, naive, the one-instance scene, and brute
//! force while triangles x rays stays under [`BRUTE_CHECK_LIMIT`]) then
//! runs in every mode it has through the benchmark's own tracing routine
//! (same chunking, threads and packet write-back as the timed runs), and
//! its per-ray results must equal the reference exactly (`Option<Hit>` for
//! closest hit, `bool` for occlusion; the instance accel's hits by `t`,
//! `prim`, `u` and `v`).
//!
//! Peer engines (`peers`: Embree, obvhs, tinybvh) cannot agree bit for
//! bit (their triangle tests round differently), so [`check_peer`] holds
//! them to the protocol's agreement rule instead: hit counts within
//! [`HITS_TOLERANCE`] of the rays and summed `t` within
//! [`SUM_T_TOLERANCE`], on rays with the same fingerprint; both scaled up
//! for images smaller than the protocol's ([`size_factor`]).
//!
//! A scene file's reference is the scene's own scalar query; a sample of
//! the rays (at most [`SCENE_BRUTE_LIMIT`] triangle tests) is checked
//! against the brute-force scene oracle (`packtrace::scene::BruteScene`),
//! and every mode against the reference on every ray, instance and
//! geometry included.

use crate::Failure;
use crate::fingerprint::Fingerprint;
use crate::trace::{self, Accel, Engine, Input, Mode, Output, Results};
use packtrace::protocol::workload::NO_RAY;
use packtrace::scene::{BruteScene, Query, Scene, SceneQuery};
use packtrace::{KdTree, Ray};
use rayon::ThreadPool;

/// Largest triangles x rays for which `--check` also runs brute force.
pub const BRUTE_CHECK_LIMIT: f64 = 2e9;

/// Largest triangle tests (world triangles x sampled rays) of the
/// brute-force scene oracle per workload of a scene file.
pub const SCENE_BRUTE_LIMIT: f64 = 5e7;

/// The protocol's agreement on hits: counts differ by at most this share
/// of the rays (0.01 %), at least one ray (at sizes under the protocol's
/// 1024 x 1024, where 0.01 % is under a ray).
pub const HITS_TOLERANCE: f64 = 1e-4;

/// The protocol's agreement on closest hits: summed `t` differ by at most
/// this relative amount.
pub const SUM_T_TOLERANCE: f64 = 1e-4;

/// The side of the image the protocol judges agreement at (1024 x 1024).
pub const PROTOCOL_SIDE: f64 = 1024.0;

/// How much wider the tolerances are for an image of `pixels` pixels than
/// at the protocol's 1024 x 1024: `1024 / sqrt(pixels)`, at least 1.
///
/// Engines disagree on rays that graze an edge or start on one, and edges
/// are lines in the image: their share of the rays grows as one over the
/// image's side (Embree's ao on the Cornell box: 0.004 % of the rays at
/// 1024 x 1024, 0.02 % at 256 x 256).
pub fn size_factor(pixels: u64) -> f64 {
    (PROTOCOL_SIDE / (pixels.max(1) as f64).sqrt()).max(1.0)
}

/// What two engines' runs of one workload are compared by.
#[derive(Clone, Debug, PartialEq)]
pub struct Tally {
    /// The rays' fingerprint (scene, camera, size, light, workload).
    pub fingerprint: Fingerprint,
    /// Rays traced.
    pub rays: usize,
    /// Rays with a hit, or found occluded.
    pub hits: u64,
    /// Summed `t` of the hits (closest-hit workloads).
    pub sum_t: Option<f64>,
    /// Pixels of the image the rays were made for.
    pub pixels: u64,
}

impl Tally {
    /// The tally of `results` on rays of `fingerprint`, made for an image
    /// of `pixels` pixels.
    pub fn of(results: &Results, fingerprint: Fingerprint, pixels: u64) -> Tally {
        Tally {
            fingerprint,
            rays: results.len(),
            hits: results.hits(),
            sum_t: results.sum_t(),
            pixels,
        }
    }
}

/// Why two tallies disagree under the protocol's rule, or `None` when they
/// agree.
pub fn disagreement(reference: &Tally, got: &Tally) -> Option<String> {
    if reference.fingerprint != got.fingerprint {
        return Some(format!(
            "traced other rays (fingerprint {} vs {}): not comparable",
            got.fingerprint.hex(),
            reference.fingerprint.hex()
        ));
    }
    let rays = reference.rays.max(got.rays) as f64;
    let scale = size_factor(reference.pixels);
    let share = HITS_TOLERANCE * scale;
    let allowed = (share * rays).max(1.0);
    let dh = got.hits.abs_diff(reference.hits) as f64;
    if dh > allowed {
        return Some(format!(
            "{} hits vs {} ({dh} apart, more than {allowed:.1} = {:.3} % of {rays} rays)",
            got.hits,
            reference.hits,
            share * 100.0
        ));
    }
    match (reference.sum_t, got.sum_t) {
        (Some(a), Some(b)) => {
            let rel = (b - a).abs() / a.abs().max(f64::MIN_POSITIVE);
            let limit = SUM_T_TOLERANCE * scale;
            (rel > limit)
                .then(|| format!("sum_t {b} vs {a} ({rel:.2e} relative, more than {limit:.1e})"))
        }
        (None, None) => None,
        _ => Some("one is a closest-hit run, the other an occlusion run".into()),
    }
}

/// Compare a peer's tally with scalar kd8's on one workload under the
/// protocol's rule. Prints a one-line summary, or why they disagree.
///
/// # Errors
/// [`Failure::Mismatch`] after printing the disagreement.
pub fn check_peer(label: &str, name: &str, reference: &Tally, got: &Tally) -> Result<(), Failure> {
    if let Some(why) = disagreement(reference, got) {
        eprintln!("check FAILED: {label}: {name} disagrees with kd8/scalar: {why}");
        return Err(Failure::Mismatch);
    }
    let sum_t = match (reference.sum_t, got.sum_t) {
        (Some(a), Some(b)) => format!(", sum_t {b:.6} vs {a:.6}"),
        _ => String::new(),
    };
    eprintln!(
        "check ok: {label}: {name} agrees with kd8/scalar within the protocol's tolerance{}: \
         {} rays, {} hits vs {} rays, {} hits{sum_t}",
        {
            let f = size_factor(reference.pixels);
            if f > 1.0 {
                format!(" (x{f:.1} below 1024x1024)")
            } else {
                String::new()
            }
        },
        got.rays,
        got.hits,
        reference.rays,
        reference.hits
    );
    Ok(())
}

/// The reference: scalar kd8, one ray after the other on this thread.
pub fn reference(tree: &KdTree, input: &Input) -> Results {
    if input.occlusion {
        Results::Occluded(input.rays.iter().map(|r| tree.occluded(r)).collect())
    } else {
        Results::Closest(input.rays.iter().map(|r| tree.intersect(r)).collect())
    }
}

/// A scene file's reference: the scene's scalar query, one ray after the
/// other on this thread.
pub fn scene_reference(scene: &Scene, input: &Input) -> Results {
    if input.occlusion {
        Results::Occluded(input.rays.iter().map(|r| scene.occluded(r)).collect())
    } else {
        Results::SceneClosest(input.rays.iter().map(|r| scene.intersect(r)).collect())
    }
}

/// The rays `--check` gives the brute-force scene oracle: evenly spaced,
/// as many as keep `triangles x rays` within [`SCENE_BRUTE_LIMIT`] (at
/// least one, at most all `rays`).
pub fn oracle_sample(rays: usize, triangles: usize) -> Vec<usize> {
    let budget = (SCENE_BRUTE_LIMIT / triangles.max(1) as f64).floor() as usize;
    let count = budget.clamp(1, rays.max(1)).min(rays);
    (0..count).map(|k| k * rays / count).collect()
}

/// Compare a scene's scalar results with the brute-force scene oracle on
/// [`oracle_sample`]'s rays (`triangles`: the scene's world triangles).
/// Prints a one-line summary, or the first mismatch.
///
/// # Errors
/// [`Failure::Mismatch`] after printing the mismatch.
pub fn check_scene_oracle(
    label: &str,
    scene: &Scene,
    reference: &Results,
    input: &Input,
    triangles: usize,
) -> Result<usize, Failure> {
    let brute = BruteScene::new(scene);
    let q = Query::new();
    let sample = oracle_sample(input.rays.len(), triangles);
    for &i in &sample {
        let r = &input.rays[i];
        let oracle = match reference {
            Results::Occluded(_) => Results::Occluded(vec![brute.occluded_with(r, &q)]),
            _ => Results::SceneClosest(vec![brute.intersect_with(r, &q)]),
        };
        let got = match reference {
            Results::Occluded(o) => Results::Occluded(vec![o[i]]),
            Results::SceneClosest(h) => Results::SceneClosest(vec![h[i]]),
            Results::Closest(_) => unreachable!("a scene's reference"),
        };
        if oracle.first_difference(&got).is_some() {
            eprintln!(
                "check FAILED: {label}: scene/scalar differs from the brute-force scene oracle \
                 at ray {i}"
            );
            eprintln!("    {}", describe_ray(r));
            eprintln!("  brute scene:  {}", oracle.describe(0));
            eprintln!("  scene/scalar: {}", got.describe(0));
            return Err(Failure::Mismatch);
        }
    }
    Ok(sample.len())
}

/// `x` with its bit pattern.
fn bits(x: f32) -> String {
    format!("{x:?} [0x{:08x}]", x.to_bits())
}

/// A ray with exact values.
fn describe_ray(r: &Ray) -> String {
    let v = |v: glam::Vec3| format!("({}, {}, {})", bits(v.x), bits(v.y), bits(v.z));
    format!(
        "origin {}\n    dir    {}\n    t_min  {}\n    t_max  {}",
        v(r.origin()),
        v(r.dir()),
        bits(r.t_min()),
        bits(r.t_max())
    )
}

/// Where ray `i` sits in the packets.
fn packet_of(lanes: &[[u32; 4]], i: usize) -> String {
    lanes
        .iter()
        .enumerate()
        .find_map(|(p, l)| {
            l.iter()
                .position(|&k| k != NO_RAY && k as usize == i)
                .map(|lane| format!("packet {p} lane {lane}"))
        })
        .unwrap_or_else(|| "in no packet".into())
}

/// Compare every engine and mode with the reference (named
/// `reference_name`, e.g. `kd8/scalar`) on one workload. Prints a one-line
/// summary, or the first mismatch in full.
///
/// # Errors
/// [`Failure::Mismatch`] after printing the mismatch.
pub fn check_workload(
    label: &str,
    reference_name: &str,
    reference: &Results,
    engines: &[(Accel, Engine)],
    input: &Input,
    triangles: usize,
    pool: Option<&ThreadPool>,
) -> Result<(), Failure> {
    let brute_tests = triangles as f64 * input.rays.len() as f64;
    let mut agreed = Vec::new();
    let mut skipped = Vec::new();
    for &(accel, engine) in engines {
        if accel == Accel::Brute && brute_tests > BRUTE_CHECK_LIMIT {
            skipped.push(format!(
                "brute ({triangles} triangles x {} rays > {BRUTE_CHECK_LIMIT:e})",
                input.rays.len()
            ));
            continue;
        }
        for mode in Mode::ALL {
            if !accel.runs(mode) {
                continue;
            }
            let mut out = Output::new(&engine, mode, input);
            trace::trace(engine, mode, input, &mut out, pool);
            let got = out.per_ray(input);
            if let Some(i) = reference.first_difference(&got) {
                eprintln!(
                    "check FAILED: {label}: {}/{} differs from {reference_name} at ray {i} ({})",
                    accel.name(),
                    mode.name(),
                    packet_of(input.lanes, i),
                );
                if let Some(r) = input.rays.get(i) {
                    eprintln!("    {}", describe_ray(r));
                }
                if i < reference.len() && i < got.len() {
                    eprintln!("  {reference_name}: {}", reference.describe(i));
                    eprintln!("  {}/{}: {}", accel.name(), mode.name(), got.describe(i));
                } else {
                    eprintln!(
                        "  result counts differ: {} vs {}",
                        reference.len(),
                        got.len()
                    );
                }
                return Err(Failure::Mismatch);
            }
            agreed.push(format!("{}/{}", accel.name(), mode.name()));
        }
    }
    eprintln!(
        "check ok: {label}: {} rays, {} hits; {} agree with {reference_name}{}",
        input.rays.len(),
        reference.hits(),
        agreed.join(" "),
        if skipped.is_empty() {
            String::new()
        } else {
            format!("; skipped {}", skipped.join(", "))
        }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use packtrace::protocol::scene_file::parse_scene;
    use packtrace::protocol::{SceneFrame, workload};
    use packtrace::scene::SceneHit;

    fn tally(rays: usize, hits: u64, sum_t: Option<f64>) -> Tally {
        Tally {
            fingerprint: Fingerprint::of_scene(
                &packtrace::protocol::generate::sphere(20),
                &Default::default(),
                glam::Vec3::ZERO,
            ),
            rays,
            hits,
            sum_t,
            pixels: 1024 * 1024,
        }
    }

    #[test]
    fn smaller_images_widen_the_tolerance_as_one_over_their_side() {
        assert_eq!(size_factor(1024 * 1024), 1.0);
        assert_eq!(size_factor(2048 * 2048), 1.0);
        assert_eq!(size_factor(256 * 256), 4.0);
        assert_eq!(size_factor(0), 1024.0);
        // 55 apart of 243,096 ao rays at 256 x 256 (0.023 %) is within
        // 4 x 0.01 %; at 1024 x 1024 it would not be.
        let small = |hits| Tally {
            pixels: 256 * 256,
            ..tally(243_096, hits, None)
        };
        assert_eq!(disagreement(&small(81_409), &small(81_464)), None);
        let big = tally(243_096, 81_409, None);
        assert!(disagreement(&big, &tally(243_096, 81_464, None)).is_some());
    }

    #[test]
    fn peers_agree_within_the_protocols_tolerance() {
        let r = tally(1_000_000, 500_000, Some(1e6));
        assert_eq!(disagreement(&r, &r), None);
        // 100 hits apart of a million rays is within 0.01 %; 101 is not.
        assert_eq!(
            disagreement(&r, &tally(1_000_000, 500_100, Some(1e6))),
            None
        );
        let e = disagreement(&r, &tally(1_000_000, 500_101, Some(1e6))).unwrap();
        assert!(e.contains("500101 hits vs 500000"), "{e}");
        // Under 10,000 rays one ray apart is allowed, two are not.
        let few = tally(4096, 2000, None);
        assert_eq!(disagreement(&few, &tally(4096, 2001, None)), None);
        assert!(disagreement(&few, &tally(4096, 2002, None)).is_some());
        // Summed t within 1e-4 relative.
        assert_eq!(
            disagreement(&r, &tally(1_000_000, 500_000, Some(1e6 + 99.0))),
            None
        );
        let e = disagreement(&r, &tally(1_000_000, 500_000, Some(1e6 + 101.0))).unwrap();
        assert!(e.contains("relative"), "{e}");
        assert!(disagreement(&r, &tally(1_000_000, 500_000, None)).is_some());
    }

    #[test]
    fn peers_on_other_rays_are_not_compared() {
        let r = tally(100, 50, None);
        let other = Tally {
            fingerprint: r
                .fingerprint
                .workload(packtrace::protocol::workload::Workload::Ao),
            ..r.clone()
        };
        let e = disagreement(&r, &other).unwrap();
        assert!(
            e.contains("other rays") && e.contains("not comparable"),
            "{e}"
        );
        assert!(matches!(
            check_peer("x", "embree/scalar", &r, &other),
            Err(Failure::Mismatch)
        ));
        assert!(check_peer("x", "embree/scalar", &r, &r).is_ok());
    }

    #[test]
    fn the_oracle_sample_is_spread_and_bounded() {
        assert_eq!(oracle_sample(5, 1), [0, 1, 2, 3, 4]);
        let budget = (SCENE_BRUTE_LIMIT / 1e7) as usize;
        let s = oracle_sample(1000, 10_000_000);
        assert_eq!(s.len(), budget);
        assert_eq!(s[1] - s[0], 1000 / budget);
        assert_eq!(oracle_sample(1000, usize::MAX), [0]);
        assert!(oracle_sample(0, 10).is_empty());
    }

    #[test]
    fn the_scene_oracle_finds_a_wrong_reference() {
        let scene = parse_scene(
            "mesh b gen:sphere:200\ninstance b\ninstance b rotate 1 0 0 30 translate 1.5 0 0\n",
            std::path::Path::new("."),
            &Default::default(),
        )
        .unwrap();
        let set = workload::random(&SceneFrame::of_scene(&scene), 300);
        for occlusion in [false, true] {
            let input = Input::scalar(&set, occlusion);
            let reference = scene_reference(&scene, &input);
            assert!(reference.hits() > 0);
            let n = check_scene_oracle("test", &scene, &reference, &input, 400).unwrap();
            assert_eq!(n, 300);
            let wrong = match &reference {
                // Each hit a little further away.
                Results::SceneClosest(h) => Results::SceneClosest(
                    h.iter()
                        .map(|h| h.map(|h| SceneHit { t: h.t * 1.5, ..h }))
                        .collect(),
                ),
                Results::Occluded(o) => Results::Occluded(o.iter().map(|b| !b).collect()),
                Results::Closest(_) => unreachable!(),
            };
            assert!(matches!(
                check_scene_oracle("test", &scene, &wrong, &input, 400),
                Err(Failure::Mismatch)
            ));
        }
    }
}
