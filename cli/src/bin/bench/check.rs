//! `--check`: every mode and accelerator against scalar kd8, ray by ray.
//!
//! The reference is the plain scalar kd8 query called ray after ray on
//! this thread. Every engine (kd8, naive, and brute force while triangles x
//! rays stays under [`BRUTE_CHECK_LIMIT`]) then runs in every mode it has
//! through the benchmark's own tracing routine (same chunking, threads and
//! packet write-back as the timed runs), and its per-ray results must equal
//! the reference exactly (`Option<Hit>` for closest hit, `bool` for
//! occlusion).

use crate::Failure;
use crate::trace::{self, Accel, Engine, Input, Mode, Output, Results};
use packtrace::protocol::workload::NO_RAY;
use packtrace::{KdTree, Ray};
use rayon::ThreadPool;

/// Largest triangles x rays for which `--check` also runs brute force.
pub const BRUTE_CHECK_LIMIT: f64 = 2e9;

/// The reference: scalar kd8, one ray after the other on this thread.
pub fn reference(tree: &KdTree, input: &Input) -> Results {
    if input.occlusion {
        Results::Occluded(input.rays.iter().map(|r| tree.occluded(r)).collect())
    } else {
        Results::Closest(input.rays.iter().map(|r| tree.intersect(r)).collect())
    }
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

/// Compare every engine and mode with the reference on one workload.
/// Prints a one-line summary, or the first mismatch in full.
///
/// # Errors
/// [`Failure::Mismatch`] after printing the mismatch.
pub fn check_workload(
    label: &str,
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
            let mut out = Output::new(mode, input);
            trace::trace(engine, mode, input, &mut out, pool);
            let got = out.per_ray(input);
            if let Some(i) = reference.first_difference(&got) {
                eprintln!(
                    "check FAILED: {label}: {}/{} differs from kd8/scalar at ray {i} ({})",
                    accel.name(),
                    mode.name(),
                    packet_of(input.lanes, i),
                );
                if let Some(r) = input.rays.get(i) {
                    eprintln!("    {}", describe_ray(r));
                }
                if i < reference.len() && i < got.len() {
                    eprintln!("  kd8/scalar: {}", reference.describe(i));
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
        "check ok: {label}: {} rays, {} hits; {} agree with kd8/scalar{}",
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
