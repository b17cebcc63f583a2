//! The one comparison harness of the integration tests: every engine over
//! one mesh, every ray through every engine, every answer against a
//! reference (brute force unless a suite asks otherwise), bit for bit.
//!
//! Engines ([`Engines`]): brute force (`BruteForce`, the reference), and
//! for every build preset (`KdBuildParams::presets()`, or the trees a suite
//! gives) the kd tree, its naive layout (`NaiveKdTree::from_kd`), its
//! blocked node order (`BlockedKdTree::from_kd`) and its leaves with the
//! triangles inline (`InlineKdTree::from_kd`), each traced
//! - ray by ray (`RayQuery::intersect` / `occluded`),
//! - as packets through `PacketQuery`, for every width in
//!   [`PACKET_WIDTHS`] (adding a width is adding one entry there): a packet
//!   of copies of the ray, and the ray in every lane position alone beside
//!   inactive lanes, beside valid companion rays of the same direction
//!   signs (the packet-wide path) and of the other signs (the per-lane
//!   fallback), and beside zero-direction (invalid) rays
//!   ([`Placements`]); plus any packets a suite lists,
//! - as a stream (`intersect_rays` / `occluded_rays`), starting at every
//!   offset below the widest packet, so every ray sits in every lane.
//!
//! Checks ([`Engines::agree`]): every path's closest hit equals the
//! reference's (bits of `t`, `u`, `v`, the triangle) and so does its
//! occlusion; every reported hit has finite `t`, `u`, `v`, lies in
//! `(t_min, t_max]` and names a non-degenerate triangle of the mesh; the
//! reference's occlusion agrees with its closest hit, and it never hits a
//! ray that `Ray::new` would refuse or whose interval is empty. The
//! companions and zero-direction rays beside a ray are held to the
//! reference as well (until HARDENING finding 12 was fixed they were held
//! to the ray policy only). All mismatches are collected
//! in a [`Report`] with the ray as a Rust literal (`ray_literal`), the
//! packet's lanes, `diagnose`'s triage and the mesh as a literal when it
//! is small.
//!
//! [`Options`] trade coverage for time where a suite traces thousands of
//! cases or big scenes: placements in turn instead of all of them, no
//! zero-direction neighbours (whose packets visit every cell), the scalar
//! traversal as reference for whole images.

use super::{MeshSpec, diagnose, hit_bits, ray_literal};
use glam::Vec3;
use packtrace::query::PacketQuery;
use packtrace::{
    BlockedKdTree, BruteForce, Hit, HitPacket, InlineKdTree, KdBuildParams, KdTree, Mesh,
    NaiveKdTree, Ray, RayPacket4, RayPacket8, RayQuery,
};
use proptest::test_runner::TestCaseError;
use rayon::prelude::*;

// ---------------------------------------------------------------------------
// Packet widths
// ---------------------------------------------------------------------------

/// One packet width of `PacketQuery`: trace `width` lanes (`None` is an
/// inactive lane) and return every lane's answer.
pub struct PacketWidth {
    pub name: &'static str,
    pub width: usize,
    pub trace: fn(&dyn PacketQuery, &[Option<Ray>]) -> Vec<Answer>,
}

/// Every packet width the engines have. A new width (say `intersect8`) is
/// one more entry.
pub const PACKET_WIDTHS: &[PacketWidth] = &[
    PacketWidth {
        name: "packet4",
        width: 4,
        trace: trace4,
    },
    PacketWidth {
        name: "packet8",
        width: 8,
        trace: trace8,
    },
];

fn trace4(engine: &dyn PacketQuery, lanes: &[Option<Ray>]) -> Vec<Answer> {
    let lanes: [Option<Ray>; 4] = lanes.try_into().expect("four lanes");
    let p = RayPacket4::from_lanes(lanes);
    answers(&engine.intersect4(&p), engine.occluded4(&p))
}

fn trace8(engine: &dyn PacketQuery, lanes: &[Option<Ray>]) -> Vec<Answer> {
    let lanes: [Option<Ray>; 8] = lanes.try_into().expect("eight lanes");
    let p = RayPacket8::from_lanes(lanes);
    answers(&engine.intersect8(&p), engine.occluded8(&p))
}

fn answers<L: packtrace::simd::Lane>(hits: &HitPacket<L>, occluded: u32) -> Vec<Answer> {
    (0..L::WIDTH)
        .map(|i| Answer {
            hit: hits.hit(i),
            occluded: occluded >> i & 1 == 1,
        })
        .collect()
}

/// The widest packet: stream offsets `0..MAX_WIDTH` put every ray in every
/// lane.
pub fn max_width() -> usize {
    PACKET_WIDTHS.iter().map(|w| w.width).max().unwrap_or(1)
}

// ---------------------------------------------------------------------------
// Answers and rays
// ---------------------------------------------------------------------------

/// One engine's answer for one ray.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Answer {
    pub hit: Option<Hit>,
    pub occluded: bool,
}

impl Answer {
    /// No hit, not occluded: an inactive lane, a ray that never hits.
    pub const NONE: Answer = Answer {
        hit: None,
        occluded: false,
    };

    pub fn of(engine: &(impl RayQuery + ?Sized), ray: &Ray) -> Answer {
        Answer {
            hit: engine.intersect(ray),
            occluded: engine.occluded(ray),
        }
    }
}

/// Would `Ray::new` refuse this ray (non-finite origin or direction, zero
/// direction after the flush, NaN bound)?
pub fn invalid(r: &Ray) -> bool {
    !r.origin().is_finite()
        || !r.dir().is_finite()
        || r.dir() == Vec3::ZERO
        || r.t_min().is_nan()
        || r.t_max().is_nan()
}

/// Is the interval empty (`t_min < t_max` fails, NaN included)?
pub fn empty_interval(r: &Ray) -> bool {
    r.t_min().partial_cmp(&r.t_max()) != Some(std::cmp::Ordering::Less)
}

/// The ray policy: an invalid ray or an empty interval never hits.
pub fn never_hits(r: &Ray) -> bool {
    invalid(r) || empty_interval(r)
}

/// The zero-direction (invalid) ray beside which the fuzzer found a lane
/// answering differently (docs/testing.md, finding 5), with the zeros' sign
/// bits of `octant` (bit `a` set: `-0.0` on axis `a`), so that beside a
/// ray of that octant the packet takes the packet-wide path.
pub fn zero_ray(octant: usize) -> Ray {
    let z = |a: usize| if octant >> a & 1 == 1 { -0.0 } else { 0.0 };
    Ray::new_unchecked(Vec3::ZERO, Vec3::new(z(0), z(1), z(2)), 0.0, f32::INFINITY)
}

/// The scene centre and radius (half the box diagonal, at least 1e-3,
/// computed without overflow); the unit ball for an empty mesh.
pub fn centre_radius(mesh: &Mesh) -> (Vec3, f32) {
    if mesh.is_empty() {
        return (Vec3::ZERO, 1.0);
    }
    let (lo, hi): (Vec3, Vec3) = (mesh.bounds().min.into(), mesh.bounds().max.into());
    let c = 0.5 * lo + 0.5 * hi;
    let half = 0.5 * hi - 0.5 * lo;
    let r = half.length();
    let r = if r.is_finite() {
        r
    } else {
        half.max_element() * 3f32.sqrt()
    };
    (c, r.clamp(1e-3, f32::MAX / 8.0))
}

/// A valid ray towards the scene whose direction has the sign bits of
/// `octant` (bit `a` set: negative on axis `a`), from `offset` along them.
pub fn companion(octant: usize, centre: Vec3, radius: f32, offset: f32) -> Ray {
    let s = |a: usize| if octant >> a & 1 == 1 { -1.0 } else { 1.0 };
    let d = Vec3::new(s(0), 0.75 * s(1), 0.5 * s(2));
    let o = centre - 2.0 * radius * d + Vec3::new(offset, -offset, 0.5 * offset) * radius;
    let o = if o.is_finite() { o } else { centre };
    Ray::new(o, d, 0.0, f32::INFINITY).expect("a companion ray is valid")
}

/// The octant of a ray's direction: bit `a` is the sign bit of `dir[a]`
/// (as the packet traversal decides the packet-wide path).
pub fn octant(r: &Ray) -> usize {
    (0..3).fold(0, |o, a| {
        o | usize::from(r.dir()[a].is_sign_negative()) << a
    })
}

// ---------------------------------------------------------------------------
// Engines
// ---------------------------------------------------------------------------

/// One tree and its copies in the other layouts.
pub struct Tree {
    pub name: String,
    pub kd: KdTree,
    pub naive: NaiveKdTree,
    pub blocked: BlockedKdTree,
    pub inline: InlineKdTree,
}

/// What the answers are compared with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reference {
    /// Brute force: every triangle tested (the oracle).
    Brute,
    /// The first tree's scalar traversal: for ray sets too large for brute
    /// force (whole images of big scenes); brute force is not traced.
    Scalar,
}

/// Where [`Engines::agree`] puts each ray in packets (besides the packets
/// a suite lists). The placements of a ray, per packet width: a packet of
/// copies of it, then for each lane position the ray alone (the other
/// lanes inactive), beside companions of its signs, beside companions of
/// the other signs and beside zero-direction rays (`1 + 4 * width`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Placements {
    /// Only the listed packets.
    None,
    /// Ray `k` in placement `k % (1 + 4 * width)` only: a set of at least
    /// that many rays uses every placement, at a seventeenth of
    /// [`Placements::Every`]'s cost (for properties that run thousands of
    /// cases and for big scenes).
    Cycle,
    /// Every ray in every placement.
    Every,
}

/// Which paths [`Engines::agree`] traces.
#[derive(Clone, Copy, Debug)]
pub struct Options {
    pub reference: Reference,
    pub placements: Placements,
    /// Placements beside zero-direction rays (docs/testing.md, finding 5). A
    /// zero-direction lane passes every slab test, so such a packet visits
    /// every cell: affordable on small meshes only.
    pub zero_neighbours: bool,
    /// The other layouts too (the naive one, the blocked node order and
    /// the inline leaves).
    pub naive: bool,
    /// Stream offsets `0..stream_offsets` (0: no stream).
    pub stream_offsets: usize,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            reference: Reference::Brute,
            placements: Placements::Every,
            zero_neighbours: true,
            naive: true,
            stream_offsets: max_width(),
        }
    }
}

/// Every engine over one mesh.
pub struct Engines<'m> {
    pub mesh: &'m Mesh,
    pub brute: BruteForce<'m>,
    pub trees: Vec<Tree>,
    /// Other structures over the same mesh (the BVHs), held to the
    /// reference on every path as the trees are ([`Engines::with_structure`]).
    pub structures: Vec<(String, Box<dyn PacketQuery + Sync>)>,
    pub options: Options,
}

impl<'m> Engines<'m> {
    /// Every preset's tree over `mesh`, each validated.
    ///
    /// # Panics
    /// If a build fails or a tree does not validate.
    pub fn new(mesh: &'m Mesh) -> Engines<'m> {
        Engines::try_new(mesh).unwrap_or_else(|e| panic!("{e}"))
    }

    /// [`Engines::new`], the first failed build or validation as text (a
    /// proptest failure to shrink).
    pub fn try_new(mesh: &'m Mesh) -> Result<Engines<'m>, String> {
        Engines::with_params(mesh, &KdBuildParams::presets())
    }

    /// The trees of the given parameter sets, each validated.
    pub fn with_params<S: AsRef<str>>(
        mesh: &'m Mesh,
        params: &[(S, KdBuildParams)],
    ) -> Result<Engines<'m>, String> {
        let mut trees = Vec::new();
        for (name, p) in params {
            let name = name.as_ref();
            let tree =
                KdTree::build(mesh.clone(), p).map_err(|e| format!("{name}: build failed: {e}"))?;
            tree.validate().map_err(|e| format!("{name}: {e}"))?;
            trees.push((name.to_string(), tree));
        }
        Ok(Engines::from_trees(mesh, trees))
    }

    /// Trees a suite built itself (and validated as it needs), over `mesh`.
    pub fn from_trees(mesh: &'m Mesh, trees: Vec<(String, KdTree)>) -> Engines<'m> {
        let trees = trees
            .into_iter()
            .map(|(name, kd)| {
                let blocked = BlockedKdTree::from_kd(&kd)
                    .unwrap_or_else(|e| panic!("{name}: blocked order: {e}"));
                blocked
                    .validate()
                    .unwrap_or_else(|e| panic!("{name}: blocked order: {e}"));
                let inline = InlineKdTree::from_kd(&kd)
                    .unwrap_or_else(|e| panic!("{name}: inline leaves: {e}"));
                inline
                    .validate()
                    .unwrap_or_else(|e| panic!("{name}: inline leaves: {e}"));
                Tree {
                    naive: NaiveKdTree::from_kd(&kd),
                    blocked,
                    inline,
                    name,
                    kd,
                }
            })
            .collect();
        Engines {
            mesh,
            brute: BruteForce::new(mesh),
            trees,
            structures: Vec::new(),
            options: Options::default(),
        }
    }

    /// Adds a structure over the same mesh, traced on every path (scalar,
    /// packets, streams) beside the trees.
    pub fn with_structure(
        mut self,
        name: impl Into<String>,
        s: impl PacketQuery + Sync + 'static,
    ) -> Engines<'m> {
        self.structures.push((name.into(), Box::new(s)));
        self
    }

    /// The scalar paths, named (not the reference itself).
    fn scalar_paths(&self) -> Vec<(String, &(dyn RayQuery + Sync))> {
        let mut v: Vec<(String, &(dyn RayQuery + Sync))> = Vec::new();
        for (i, t) in self.trees.iter().enumerate() {
            if i > 0 || self.options.reference == Reference::Brute {
                v.push((format!("{}/kd", t.name), &t.kd));
            }
            if self.options.naive {
                v.push((format!("{}/naive", t.name), &t.naive));
                v.push((format!("{}/blocked", t.name), &t.blocked));
                v.push((format!("{}/inline", t.name), &t.inline));
            }
        }
        for (name, s) in &self.structures {
            v.push((name.clone(), s.as_ref() as &(dyn RayQuery + Sync)));
        }
        v
    }

    /// The packet and stream paths, named.
    fn packet_paths(&self) -> Vec<(String, &(dyn PacketQuery + Sync))> {
        let mut v: Vec<(String, &(dyn PacketQuery + Sync))> = Vec::new();
        for t in &self.trees {
            v.push((format!("{}/kd", t.name), &t.kd));
            if self.options.naive {
                v.push((format!("{}/naive", t.name), &t.naive));
                v.push((format!("{}/blocked", t.name), &t.blocked));
                v.push((format!("{}/inline", t.name), &t.inline));
            }
        }
        for (name, s) in &self.structures {
            v.push((name.clone(), s.as_ref()));
        }
        v
    }

    fn reference_answer(&self, r: &Ray) -> Answer {
        match self.options.reference {
            Reference::Brute => Answer::of(&self.brute, r),
            Reference::Scalar => Answer::of(&self.trees[0].kd, r),
        }
    }

    fn reference_name(&self) -> String {
        match self.options.reference {
            Reference::Brute => "brute force".to_string(),
            Reference::Scalar => format!("{}/kd scalar (reference)", self.trees[0].name),
        }
    }

    /// Trace every ray through every engine; see the module docs.
    pub fn agree(&self, rays: &[Ray]) -> Report {
        self.agree_packets(rays, &[])
    }

    /// [`Engines::agree`], plus the listed packets: lane `i` of a packet
    /// holds `rays[k]` for `Some(k)`, nothing for `None`; a packet is traced
    /// by every width of its length.
    pub fn agree_packets(&self, rays: &[Ray], packets: &[Vec<Option<usize>>]) -> Report {
        assert!(
            self.options.reference == Reference::Brute || !self.trees.is_empty(),
            "a scalar reference needs a tree"
        );
        let opt = self.options;
        let n = rays.len();
        // The rays, then the helpers placed beside them: companions of
        // every octant, then the zero ray. A helper's lane is held to the
        // reference too (mismatches are reported under the ray whose
        // packet it shared).
        let mut all: Vec<Ray> = rays.to_vec();
        let per_octant = max_width() - 1;
        if opt.placements != Placements::None {
            let (c, radius) = centre_radius(self.mesh);
            for oct in 0..8 {
                for k in 0..per_octant {
                    all.push(companion(oct, c, radius, 0.05 * k as f32));
                }
            }
            for oct in 0..8 {
                all.push(zero_ray(oct));
            }
        }
        let companion_index = |oct: usize, m: usize| n + oct * per_octant + m % per_octant;
        let zero_index = |oct: usize| n + 8 * per_octant + oct;

        let reference = self.reference_name();
        let expected: Vec<Answer> = all.par_iter().map(|r| self.reference_answer(r)).collect();
        let scalar = self.scalar_paths();
        let packet = self.packet_paths();
        // A lane's answer: an inactive lane never hits.
        let want_of = |lane: Option<usize>| lane.map_or(Answer::NONE, |j| expected[j]);
        let mesh = self.mesh;
        let lane_rays = |lanes: &[Option<usize>]| -> Vec<Option<Ray>> {
            lanes.iter().map(|l| l.map(|i| all[i])).collect()
        };

        // Per ray: the reference's own contract, every scalar path, the
        // ray's placements in packets.
        let per_ray: Vec<Vec<Mismatch>> = (0..n)
            .into_par_iter()
            .map(|k| {
                let r = &all[k];
                let want = expected[k];
                let mut out = Vec::new();
                let mut own = Vec::new();
                if want.occluded != want.hit.is_some() {
                    own.push(format!(
                        "occluded = {} but closest hit {:?}",
                        want.occluded, want.hit
                    ));
                }
                if never_hits(r) && want != Answer::NONE {
                    own.push(format!(
                        "hits a ray that is invalid or has an empty interval: {want:?}"
                    ));
                }
                own.extend(insane(mesh, r, want.hit));
                for what in own {
                    out.push(Mismatch::new(
                        k, r, &reference, what, None, want.hit, want.hit,
                    ));
                }
                for (name, e) in &scalar {
                    let got = Answer::of(*e, r);
                    for what in differences(got, want, r, mesh) {
                        let path = format!("{name} scalar");
                        out.push(Mismatch::new(k, r, &path, what, None, got.hit, want.hit));
                    }
                }
                if opt.placements == Placements::None {
                    return out;
                }
                let oct = octant(r);
                for w in PACKET_WIDTHS {
                    // (lanes, how): copies, then the ray in each lane
                    // position of every neighbourhood.
                    let mut placements = vec![(vec![Some(k); w.width], "copies".to_string())];
                    for lane in 0..w.width {
                        let around = |f: &dyn Fn(usize) -> Option<usize>| -> Vec<Option<usize>> {
                            (0..w.width)
                                .map(|i| match i.cmp(&lane) {
                                    std::cmp::Ordering::Equal => Some(k),
                                    std::cmp::Ordering::Less => f(i),
                                    std::cmp::Ordering::Greater => f(i - 1),
                                })
                                .collect()
                        };
                        placements.push((around(&|_| None), format!("alone in lane {lane}")));
                        placements.push((
                            around(&|m| Some(companion_index(oct, m))),
                            format!("in lane {lane} beside rays of its signs"),
                        ));
                        placements.push((
                            around(&|m| Some(companion_index(7 - oct, m))),
                            format!("in lane {lane} beside rays of other signs"),
                        ));
                        if opt.zero_neighbours {
                            placements.push((
                                around(&|_| Some(zero_index(oct))),
                                format!("in lane {lane} beside zero-direction rays"),
                            ));
                        }
                    }
                    if opt.placements == Placements::Cycle {
                        let chosen = placements.swap_remove(k % placements.len());
                        placements = vec![chosen];
                    }
                    for (name, e) in &packet {
                        for (lanes, how) in &placements {
                            let rs = lane_rays(lanes);
                            let got = (w.trace)(*e, &rs);
                            for (i, l) in lanes.iter().enumerate() {
                                let want_i = want_of(*l);
                                let ray_i = l.map_or(*r, |j| all[j]);
                                let of = match l {
                                    Some(j) if *j == k => "the ray",
                                    Some(j) if *j >= zero_index(0) => "a zero-direction ray",
                                    Some(_) => "a companion ray",
                                    None => "an inactive lane",
                                };
                                let found = differences(got[i], want_i, &ray_i, mesh);
                                for what in found {
                                    let path = format!("{name} {} {how}: lane {i} ({of})", w.name);
                                    out.push(Mismatch::new(
                                        k,
                                        &ray_i,
                                        &path,
                                        what,
                                        Some(rs.clone()),
                                        got[i].hit,
                                        want_i.hit,
                                    ));
                                }
                            }
                        }
                    }
                }
                out
            })
            .collect();
        let mut mismatches: Vec<Mismatch> = per_ray.into_iter().flatten().collect();

        // The listed packets.
        let listed: Vec<Vec<Mismatch>> = packets
            .par_iter()
            .enumerate()
            .map(|(q, lanes)| {
                assert!(
                    lanes.iter().flatten().all(|&j| j < n),
                    "listed packet {q} names a ray beyond the {n} given"
                );
                let mut out = Vec::new();
                let rs = lane_rays(lanes);
                for (name, e) in &packet {
                    for w in PACKET_WIDTHS.iter().filter(|w| w.width == lanes.len()) {
                        let got = (w.trace)(*e, &rs);
                        for (i, l) in lanes.iter().enumerate() {
                            let want = want_of(*l);
                            // An inactive lane is shown with the first ray.
                            let ray = l
                                .map(|j| all[j])
                                .or_else(|| rs.iter().flatten().next().copied())
                                .unwrap_or_else(|| zero_ray(0));
                            for what in differences(got[i], want, &ray, mesh) {
                                let path =
                                    format!("{name} {} of listed packet {q}: lane {i}", w.name);
                                out.push(Mismatch::new(
                                    l.unwrap_or(usize::MAX),
                                    &ray,
                                    &path,
                                    what,
                                    Some(rs.clone()),
                                    got[i].hit,
                                    want.hit,
                                ));
                            }
                        }
                    }
                }
                out
            })
            .collect();
        mismatches.extend(listed.into_iter().flatten());

        // The stream API at every offset.
        for (name, e) in &packet {
            for offset in 0..opt.stream_offsets.min(n + 1) {
                let part = &rays[offset..];
                let mut hits = vec![None; part.len()];
                let mut occ = vec![false; part.len()];
                e.intersect_rays(part, &mut hits);
                e.occluded_rays(part, &mut occ);
                for (s, r) in part.iter().enumerate() {
                    let got = Answer {
                        hit: hits[s],
                        occluded: occ[s],
                    };
                    let want = expected[offset + s];
                    for what in differences(got, want, r, mesh) {
                        let path = format!("{name} stream from offset {offset}: slot {s}");
                        mismatches.push(Mismatch::new(
                            offset + s,
                            r,
                            &path,
                            what,
                            None,
                            got.hit,
                            want.hit,
                        ));
                    }
                }
            }
        }

        // The first few mismatches get the triage.
        mismatches.sort_by_key(|m| m.index);
        let want_name = match opt.reference {
            Reference::Brute => "brute",
            Reference::Scalar => "reference",
        };
        for m in mismatches.iter_mut().take(SHOWN) {
            m.detail = Some(diagnose(
                mesh,
                &m.ray,
                &[("got", m.got), (want_name, m.want)],
            ));
        }
        let total = mismatches.len();
        mismatches.truncate(KEPT);
        Report {
            rays: n,
            expected,
            total,
            mismatches,
            mesh: (mesh.triangle_count() <= MESH_LITERAL_UP_TO).then(|| mesh_literal(mesh)),
            labels: Vec::new(),
        }
    }
}

/// [`Engines::new`] and [`Engines::agree`] in one call.
pub fn agree(mesh: &Mesh, rays: &[Ray]) -> Report {
    Engines::new(mesh).agree(rays)
}

/// A hit that breaks the ray policy: non-finite `t`, `u`, `v`, outside
/// `(t_min, t_max]`, or on a degenerate or missing triangle.
pub fn insane(mesh: &Mesh, r: &Ray, hit: Option<Hit>) -> Option<String> {
    let h = hit?;
    if !(h.t.is_finite() && h.u.is_finite() && h.v.is_finite()) {
        return Some(format!("hit {h:?} is not finite"));
    }
    if !(r.t_min() < h.t && h.t <= r.t_max()) {
        return Some(format!(
            "hit {h:?} outside ({:?}, {:?}]",
            r.t_min(),
            r.t_max()
        ));
    }
    if h.prim as usize >= mesh.triangle_count() || mesh.is_degenerate(h.prim as usize) {
        return Some(format!("hit {h:?} on a degenerate or missing triangle"));
    }
    None
}

/// How one path's answer differs from the reference's, and what in it
/// breaks the ray policy.
pub fn differences(got: Answer, want: Answer, r: &Ray, mesh: &Mesh) -> Vec<String> {
    let mut out = Vec::new();
    if hit_bits(got.hit) != hit_bits(want.hit) {
        out.push(format!("closest hit {:?}, want {:?}", got.hit, want.hit));
    }
    if got.occluded != want.occluded {
        out.push(format!("occluded {}, want {}", got.occluded, want.occluded));
    }
    out.extend(insane(mesh, r, got.hit));
    out
}

// ---------------------------------------------------------------------------
// Report
// ---------------------------------------------------------------------------

/// Mismatches described with ray literal, packet lanes and triage.
const SHOWN: usize = 8;
/// Mismatches kept (the count is exact beyond).
const KEPT: usize = 10_000;
/// Meshes up to this many triangles are printed as a literal.
const MESH_LITERAL_UP_TO: usize = 64;

fn mesh_literal(mesh: &Mesh) -> String {
    format!(
        "{:?}",
        MeshSpec {
            positions: mesh.positions().to_vec(),
            triangles: mesh.triangles().to_vec(),
        }
    )
}

/// One path that disagrees with the reference on one ray.
#[derive(Clone, Debug)]
pub struct Mismatch {
    /// Index of the ray in the traced list (`usize::MAX`: an inactive lane
    /// of a listed packet).
    pub index: usize,
    /// The suite's name for the ray, if it gave one.
    pub label: String,
    pub ray: Ray,
    /// The engine and how it was called.
    pub path: String,
    pub what: String,
    /// The packet's lanes, for packet paths.
    pub lanes: Option<Vec<Option<Ray>>>,
    pub got: Option<Hit>,
    pub want: Option<Hit>,
    /// `diagnose`'s triage (the first few mismatches only).
    pub detail: Option<String>,
}

impl Mismatch {
    fn new(
        index: usize,
        ray: &Ray,
        path: &str,
        what: String,
        lanes: Option<Vec<Option<Ray>>>,
        got: Option<Hit>,
        want: Option<Hit>,
    ) -> Mismatch {
        Mismatch {
            index,
            label: String::new(),
            ray: *ray,
            path: path.to_string(),
            what,
            lanes,
            got,
            want,
            detail: None,
        }
    }

    fn describe(&self) -> String {
        let mut s = format!("{}: {}", self.path, self.what);
        if self.index != usize::MAX {
            s += &format!("\n    ray {}", self.index);
        }
        if !self.label.is_empty() {
            s += &format!(" ({})", self.label);
        }
        if self.lanes.is_some() {
            s += &format!(", the lane's ray: {}", ray_literal(&self.ray));
        } else {
            s += &format!(": {}", ray_literal(&self.ray));
        }
        if let Some(lanes) = &self.lanes {
            s += "\n    lanes: [";
            for l in lanes {
                match l {
                    Some(r) => s += &format!("\n      Some({}),", ray_literal(r)),
                    None => s += "\n      None,",
                }
            }
            s += "\n    ]";
        }
        if let Some(d) = &self.detail {
            s += &d.replace("\n  ", "\n    ");
        }
        s
    }
}

/// The outcome of [`Engines::agree`].
#[derive(Debug, Default)]
pub struct Report {
    /// Rays traced (the suite's; helpers not counted).
    pub rays: usize,
    /// The reference's answer for each ray, in order.
    pub expected: Vec<Answer>,
    /// Number of mismatches (all of them, also beyond the kept ones).
    pub total: usize,
    /// The mismatches, ordered by ray (at most `KEPT`).
    pub mismatches: Vec<Mismatch>,
    /// The mesh as a literal, when small.
    pub mesh: Option<String>,
    /// Context lines added by [`Report::merge`].
    pub labels: Vec<String>,
}

impl Report {
    pub fn is_ok(&self) -> bool {
        self.total == 0
    }

    /// Name the rays (`name(k)` for ray `k`) in the mismatch list.
    pub fn name_rays(mut self, name: impl Fn(usize) -> String) -> Report {
        for m in &mut self.mismatches {
            if m.index < self.rays && m.label.is_empty() {
                m.label = name(m.index);
            }
        }
        self
    }

    /// Add another report's mismatches under `label` (several meshes in one
    /// test); `expected` is not merged.
    pub fn merge(&mut self, label: &str, other: Report) {
        self.rays += other.rays;
        self.total += other.total;
        for mut m in other.mismatches {
            m.path = format!("{label}: {}", m.path);
            self.mismatches.push(m);
        }
        if other.total > 0
            && let Some(mesh) = other.mesh
        {
            self.labels.push(format!("{label} mesh: {mesh}"));
        }
    }

    /// The failure text: the count and the first mismatches in full.
    pub fn message(&self, label: &str) -> String {
        let mut s = format!(
            "{label}: {} mismatch(es) over {} ray(s); the first {}:",
            self.total,
            self.rays,
            self.total.min(SHOWN)
        );
        for m in self.mismatches.iter().take(SHOWN) {
            s += &format!("\n  {}", m.describe());
        }
        if let Some(mesh) = &self.mesh {
            s += &format!("\n  mesh: {mesh}");
        }
        for l in &self.labels {
            s += &format!("\n  {l}");
        }
        s
    }

    /// Panic with [`Report::message`] unless every path agreed.
    #[track_caller]
    pub fn assert_ok(&self, label: &str) {
        assert!(self.is_ok(), "{}", self.message(label));
    }

    /// A proptest failure (shrinkable) unless every path agreed.
    pub fn check(&self, label: &str) -> Result<(), TestCaseError> {
        if self.is_ok() {
            Ok(())
        } else {
            Err(TestCaseError::fail(self.message(label)))
        }
    }

    /// The reference's closest hit of ray `k`.
    pub fn hit(&self, k: usize) -> Option<Hit> {
        self.expected[k].hit
    }
}
