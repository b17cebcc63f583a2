//! Fuzz target: arbitrary bytes -> a triangle soup of up to 64 triangles
//! over up to 64 vertices (any f32 bit pattern, NaN and inf included, or
//! small grid values) and up to 16 rays (checked and unchecked, any bits).
//!
//! Asserts, for every preset and for one set of build parameters taken
//! from the input:
//! - `Mesh::new` refuses exactly the soups with a used non-finite vertex or
//!   an index out of range, with an error naming a bad one (the soup is then
//!   made valid and traced anyway);
//! - `KdBuildParams` that break the documented ranges give a typed error;
//!   every other build passes `validate()` within its depth limit;
//! - `Ray::new` refuses exactly the invalid rays, with an error that
//!   applies; invalid and empty-interval rays never hit;
//! - kd scalar == brute force == naive layout, bit for bit, closest hit and
//!   occlusion; packet lanes == scalar; the stream API == scalar; also for
//!   each ray's closest hit re-traced with `t_max = t`, `next_up(t)`,
//!   `t_min = next_down(t)` and `t_min = t` (issue 17);
//! - every reported hit, brute force's included, lies in its interval with
//!   finite `t`, `u`, `v`.
//!
//! Input layout (a reader that yields zero bytes once the input ends):
//! `[n_vert, n_tri, n_ray, flags]`, then per vertex a tag byte (bit 0: raw
//! f32 bits, else three `i8 / 4`; bit 1: copy the previous vertex), then
//! three index bytes per triangle (taken modulo the vertex count unless
//! flag bit 0 is set), then per ray a tag byte (bit 0/1: raw origin /
//! direction; bit 2: aim at a vertex; bit 3/4: raw `t_min` / `t_max`; bit
//! 5: build it with `Ray::new`), then the build parameters (flag bit 1;
//! bit 2: split clipping; bit 3: a memory budget).
//!
//! The body of the `trace` fuzz target (`fuzz_targets/trace.rs`), kept here so
//! that the main crate's `tests/fuzz_corpora.rs` replays the committed
//! corpora through the same checks on every `cargo test`.

use glam::Vec3;
use packtrace::{
    BruteForce, BuildError, DepthLimit, Hit, KdBuildParams, KdTree, MAX_DEPTH_LIMIT, Mesh,
    MeshError, NaiveKdTree, Ray, RayError, RayPacket4, RayQuery,
};

/// Reads the input front to back; zeros past its end.
struct Bytes<'a> {
    data: &'a [u8],
    pos: usize,
}

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        let b = self.data.get(self.pos).copied().unwrap_or(0);
        self.pos += 1;
        b
    }
    fn raw_f32(&mut self) -> f32 {
        f32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }
    /// Raw bits, or a small grid value (`i8 / 4`).
    fn coord(&mut self, raw: bool) -> f32 {
        if raw {
            self.raw_f32()
        } else {
            f32::from(self.u8() as i8) * 0.25
        }
    }
    fn vec3(&mut self, raw: bool) -> Vec3 {
        Vec3::new(self.coord(raw), self.coord(raw), self.coord(raw))
    }
}

fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
}

/// Would `Ray::new` refuse this ray?
fn invalid(r: &Ray) -> bool {
    !r.origin().is_finite()
        || !r.dir().is_finite()
        || r.dir() == Vec3::ZERO
        || r.t_min().is_nan()
        || r.t_max().is_nan()
}

/// Are these parameters outside the documented ranges?
fn bad_params(p: &KdBuildParams) -> bool {
    let ok = |x: f32| x.is_finite() && x > 0.0;
    let bonus_ok = (0.0..1.0).contains(&p.empty_bonus);
    let depth_ok = match p.max_depth {
        DepthLimit::Log2 { base, slope } => {
            base.is_finite() && base >= 0.0 && slope.is_finite() && slope >= 0.0
        }
        DepthLimit::Fixed(_) => true,
    };
    !ok(p.traversal_cost)
        || !ok(p.intersection_cost)
        || !bonus_ok
        || p.max_bad_refines == 0
        || !(2..=packtrace::MAX_BINS).contains(&p.bins)
        || !depth_ok
}

/// The mesh of the soup, checking `Mesh::new`'s verdict; a refused soup is
/// made valid (non-finite coordinates to 0, indices wrapped) and returned.
fn mesh_of(positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let n = positions.len();
    let bad_index = triangles.iter().flatten().any(|&i| i as usize >= n);
    let bad_vertex = triangles
        .iter()
        .flatten()
        .any(|&i| (i as usize) < n && !positions[i as usize].is_finite());
    match Mesh::new(positions.clone(), triangles.clone()) {
        Ok(m) => {
            assert!(!bad_index && !bad_vertex, "Mesh::new accepted a bad soup");
            m
        }
        Err(e) => {
            match &e {
                MeshError::IndexOutOfRange {
                    triangle,
                    index,
                    vertex_count,
                } => {
                    assert_eq!(*vertex_count, n);
                    assert!(*index as usize >= n);
                    assert!(triangles[*triangle].contains(index));
                }
                MeshError::NonFiniteVertex { vertex, value } => {
                    assert!(!value.is_finite());
                    assert_eq!(
                        positions[*vertex].to_array().map(f32::to_bits),
                        value.to_array().map(f32::to_bits)
                    );
                }
                MeshError::TooManyTriangles(_) => panic!("{e}"),
            }
            assert!(!e.to_string().is_empty());
            let fixed: Vec<Vec3> = positions
                .iter()
                .map(|p| Vec3::from(p.to_array().map(|x| if x.is_finite() { x } else { 0.0 })))
                .collect();
            let tris = if n == 0 {
                Vec::new()
            } else {
                triangles.iter().map(|t| t.map(|i| i % n as u32)).collect()
            };
            Mesh::new(fixed, tris).expect("a repaired soup is valid")
        }
    }
}

/// A reported hit lies in the ray's interval, with finite `t`, `u`, `v`
/// (every path, brute force included).
fn assert_sane(h: Option<Hit>, r: &Ray, path: &str) {
    if let Some(h) = h {
        assert!(
            h.t.is_finite()
                && h.u.is_finite()
                && h.v.is_finite()
                && r.t_min() < h.t
                && h.t <= r.t_max(),
            "{path}: hit {h:?} outside the interval or not finite: {r:?}"
        );
    }
}

/// The intervals around a found hit at `t` (issue 17): `t_max = t`,
/// `t_max = next_up(t)`, `t_min = next_down(t)`, `t_min = t`.
fn around_hit(r: &Ray, t: f32) -> [Ray; 4] {
    let (o, d) = (r.origin(), r.dir());
    [
        Ray::new_unchecked(o, d, r.t_min(), t),
        Ray::new_unchecked(o, d, r.t_min(), t.next_up()),
        Ray::new_unchecked(o, d, t.next_down(), f32::INFINITY),
        Ray::new_unchecked(o, d, t, f32::INFINITY),
    ]
}

/// Trace every ray through one tree and compare all paths.
fn check_tree(tree: &KdTree, rays: &[Ray], actives: &[u32]) {
    tree.validate().expect("a built tree validates");
    let stats = tree.stats();
    assert!(stats.max_depth <= tree.depth_limit());
    assert!(tree.depth_limit() <= MAX_DEPTH_LIMIT);
    let brute = BruteForce::new(tree.mesh());
    let naive = NaiveKdTree::from_kd(tree);
    let mut want = Vec::with_capacity(rays.len());
    for r in rays {
        let b = brute.intersect(r);
        let bo = brute.occluded(r);
        assert_eq!(bo, b.is_some(), "brute occluded vs intersect: {r:?}");
        let empty = r.t_min().partial_cmp(&r.t_max()) != Some(std::cmp::Ordering::Less);
        if invalid(r) || empty {
            assert_eq!(b, None, "invalid or empty ray hits: {r:?}");
        }
        let kd = tree.intersect(r);
        assert_sane(b, r, "brute force");
        assert_sane(kd, r, "kd");
        if bits(kd) != bits(b) {
            let corners =
                |h: Option<packtrace::Hit>| h.map(|h| tree.mesh().corners(h.prim as usize));
            panic!(
                "kd vs brute: kd {kd:?}, brute {b:?}, ray {r:?}, box {:?}, kd triangle {:?}, \
                 brute triangle {:?}, mesh {:?}",
                tree.bounds(),
                corners(kd),
                corners(b),
                (0..tree.mesh().triangle_count())
                    .map(|i| tree.mesh().corners(i))
                    .collect::<Vec<_>>()
            );
        }
        assert_eq!(tree.occluded(r), bo, "kd occluded vs brute: {r:?}");
        assert_eq!(bits(naive.intersect(r)), bits(b), "naive vs brute: {r:?}");
        assert_eq!(naive.occluded(r), bo, "naive occluded vs brute: {r:?}");
        want.push((b, bo));
    }
    for (k, chunk) in rays.chunks(4).enumerate() {
        let active = actives.get(k).copied().unwrap_or(0b1111);
        let lanes: [Option<Ray>; 4] =
            std::array::from_fn(|i| chunk.get(i).copied().filter(|_| active >> i & 1 == 1));
        let p = RayPacket4::from_lanes(lanes);
        for (h, occ) in [
            (tree.intersect4(&p), tree.occluded4(&p)),
            (naive.intersect4(&p), naive.occluded4(&p)),
        ] {
            for i in 0..4 {
                let (w, wo) = match lanes[i] {
                    Some(_) => want[4 * k + i],
                    None => (None, false),
                };
                assert_eq!(bits(h.hit(i)), bits(w), "packet lane {i}: {:?}", lanes[i]);
                assert_eq!(occ >> i & 1 == 1, wo, "occluded4 lane {i}: {:?}", lanes[i]);
            }
        }
    }
    let mut hits = vec![None; rays.len()];
    let mut occ = vec![false; rays.len()];
    tree.intersect_rays(rays, &mut hits);
    tree.occluded_rays(rays, &mut occ);
    for (k, r) in rays.iter().enumerate() {
        assert_eq!(bits(hits[k]), bits(want[k].0), "intersect_rays: {r:?}");
        assert_eq!(occ[k], want[k].1, "occluded_rays: {r:?}");
    }
}

/// The checks on one input; a failed check panics.
pub fn check(data: &[u8]) {
    let mut b = Bytes { data, pos: 0 };
    let n_vert = b.u8() as usize % 65;
    let n_tri = b.u8() as usize % 65;
    let n_ray = b.u8() as usize % 17;
    let flags = b.u8();

    // The soup.
    let mut positions: Vec<Vec3> = Vec::with_capacity(n_vert);
    for _ in 0..n_vert {
        let tag = b.u8();
        let p = match positions.last() {
            Some(&prev) if tag & 2 != 0 => prev,
            _ => b.vec3(tag & 1 != 0),
        };
        positions.push(p);
    }
    let triangles: Vec<[u32; 3]> = (0..n_tri)
        .map(|_| {
            [b.u8(), b.u8(), b.u8()].map(|i| {
                if flags & 1 != 0 || n_vert == 0 {
                    u32::from(i)
                } else {
                    u32::from(i) % n_vert as u32
                }
            })
        })
        .collect();
    let mesh = mesh_of(positions, triangles);

    // The rays.
    let mut rays = Vec::with_capacity(n_ray);
    for _ in 0..n_ray {
        let tag = b.u8();
        let origin = b.vec3(tag & 1 != 0);
        let mut dir = b.vec3(tag & 2 != 0);
        if tag & 4 != 0 && !mesh.is_empty() {
            let t = b.u8() as usize % mesh.triangle_count();
            dir = mesh.corners(t)[b.u8() as usize % 3] - origin;
        }
        let t_min = if tag & 8 != 0 { b.raw_f32() } else { 0.0 };
        let t_max = if tag & 16 != 0 {
            b.raw_f32()
        } else {
            f32::INFINITY
        };
        let unchecked = Ray::new_unchecked(origin, dir, t_min, t_max);
        if tag & 32 != 0 {
            match Ray::new(origin, dir, t_min, t_max) {
                Ok(r) => {
                    assert!(!invalid(&unchecked), "Ray::new accepted {unchecked:?}");
                    rays.push(r);
                }
                Err(e) => {
                    let applies = match e {
                        RayError::NonFiniteOrigin(_) => !origin.is_finite(),
                        RayError::NonFiniteDirection(_) => !dir.is_finite(),
                        // Subnormal components are flushed to zero first (ray policy).
                        RayError::ZeroDirection => unchecked.dir() == Vec3::ZERO,
                        RayError::NanBound { .. } => t_min.is_nan() || t_max.is_nan(),
                    };
                    assert!(applies, "{e:?} for {unchecked:?}");
                    rays.push(unchecked);
                }
            }
        } else {
            rays.push(unchecked);
        }
    }
    // Each valid ray's closest hit re-traced with the interval ending at
    // it or starting just below it.
    let brute = BruteForce::new(&mesh);
    let derived: Vec<Ray> = rays
        .iter()
        .filter(|r| !invalid(r))
        .filter_map(|r| brute.intersect(r).map(|h| around_hit(r, h.t)))
        .flatten()
        .collect();
    rays.extend(derived);
    let n_ray = rays.len();
    let actives: Vec<u32> = (0..n_ray.div_ceil(4))
        .map(|_| u32::from(b.u8() & 15))
        .collect();

    // Every preset, then the input's own parameters.
    for (_, params) in KdBuildParams::presets() {
        let tree = KdTree::build(mesh.clone(), &params).expect("presets always build");
        check_tree(&tree, &rays, &actives);
    }
    if flags & 2 != 0 {
        let depth = b.u8();
        // The update keeps the target compiling when the builder gains
        // parameters.
        #[allow(clippy::needless_update)]
        let params = KdBuildParams {
            traversal_cost: b.raw_f32(),
            intersection_cost: b.raw_f32(),
            empty_bonus: b.raw_f32(),
            max_depth: if depth < 200 {
                DepthLimit::Fixed(u32::from(depth) % 70)
            } else {
                DepthLimit::Log2 {
                    base: b.raw_f32(),
                    slope: b.raw_f32(),
                }
            },
            max_bad_refines: u32::from(b.u8() % 6),
            max_leaf_size: u32::from(b.u8() % 8),
            exact_below: usize::from(b.u8()),
            bins: u32::from(b.u8()) * 17,
            split_clipping: flags & 4 != 0,
            memory_budget: (flags & 8 != 0).then(|| 64 * usize::from(b.u8())),
            ..KdBuildParams::default()
        };
        match KdTree::build(mesh, &params) {
            Ok(tree) => {
                assert!(!bad_params(&params), "accepted {params:?}");
                check_tree(&tree, &rays, &actives);
            }
            Err(BuildError::InvalidParams(_)) => assert!(bad_params(&params)),
            Err(BuildError::DepthLimit(d)) => {
                assert!(d > MAX_DEPTH_LIMIT && params.max_depth == DepthLimit::Fixed(d));
            }
            Err(BuildError::MemoryBudget { needed, budget }) => {
                assert!(params.memory_budget == Some(budget) && needed > budget);
            }
            Err(e) => panic!("unexpected build error for {params:?}: {e}"),
        }
    }
}
