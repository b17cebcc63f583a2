//! The protocol's four workloads as ray sets: `primary`, `shadow`, `ao` and
//! `random` (docs/PROTOCOL.md, "Ray order and packets" and "The workloads").
//!
//! A [`RaySet`] holds the rays in the protocol's *ray order* (the order
//! `sum_t` is accumulated in, and the order scalar tracing uses) and the
//! 4-wide packets as lane -> ray index, so the scalar and the packet paths
//! trace exactly the same rays.
//!
//! ```
//! use glam::Vec3;
//! use packtrace::protocol::camera::Camera;
//! use packtrace::protocol::{workload, SceneFrame, default_light};
//! use packtrace::{KdBuildParams, KdTree};
//!
//! let mesh = packtrace::protocol::generate::sphere(200);
//! let frame = SceneFrame::of(&mesh);
//! let tree = KdTree::build(mesh, &KdBuildParams::default())?;
//! let cam = Camera::auto(&frame.bounds);
//! let primary = workload::primary(&cam, 8, 8)?;
//! let hits: Vec<_> = primary.rays.iter().map(|r| tree.intersect(r)).collect();
//! let shadow = workload::shadow(&primary, &hits, tree.mesh(), &frame, default_light(&frame));
//! assert_eq!(shadow.len(), hits.iter().flatten().count());
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::camera::{Camera, ImagePlane, ViewError};
use super::frame::SceneFrame;
use super::sampling::{ao_direction, hash, unit};
use crate::group::Apex;
use crate::mesh::Mesh;
use crate::packet::{RayPacket4, RayPacket8};
use crate::ray::{Hit, Ray};
use glam::Vec3;
use std::f32::consts::PI;
use std::fmt;
use std::str::FromStr;

/// Lane value of [`RaySet::packets`] for an inactive lane.
///
/// ```
/// assert_eq!(packtrace::protocol::workload::NO_RAY, u32::MAX);
/// ```
pub const NO_RAY: u32 = u32::MAX;

/// Ambient-occlusion samples per primary hit (`S` of the protocol).
///
/// ```
/// assert_eq!(packtrace::protocol::workload::AO_SAMPLES, 4);
/// ```
pub const AO_SAMPLES: u32 = 4;

/// Largest `width * height` [`primary`] accepts: `AO_SAMPLES` rays per
/// pixel must still have `u32` indices below [`NO_RAY`].
///
/// ```
/// assert_eq!(packtrace::protocol::workload::MAX_PIXELS, 1 << 30);
/// ```
pub const MAX_PIXELS: u64 = 1 << 30;

/// Why a workload name, an image size or a camera was refused.
///
/// ```
/// use packtrace::protocol::{Workload, WorkloadError};
/// let e = "diffuse".parse::<Workload>().unwrap_err();
/// assert!(matches!(e, WorkloadError::UnknownWorkload(_)));
/// assert!(e.to_string().contains("`diffuse`"));
/// ```
#[derive(Debug)]
pub enum WorkloadError {
    /// An image size the protocol does not allow (zero, odd, or too large
    /// for `u32` ray indices).
    ImageSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// What is wrong with it.
        reason: String,
    },
    /// A workload name that is not one of the protocol's.
    UnknownWorkload(String),
    /// The camera describes no valid camera ([`Camera::validate`]).
    Camera(ViewError),
}

impl fmt::Display for WorkloadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            WorkloadError::ImageSize {
                width,
                height,
                reason,
            } => write!(f, "image size {width}x{height}: {reason}"),
            WorkloadError::UnknownWorkload(name) => write!(
                f,
                "unknown workload `{name}` (expected primary, shadow, ao or random)"
            ),
            WorkloadError::Camera(e) => e.fmt(f),
        }
    }
}

impl std::error::Error for WorkloadError {}

/// The protocol's image-size rule, the one check every caller uses: both
/// sides even and non-zero (2 x 2 packets), at most [`MAX_PIXELS`] pixels.
///
/// # Errors
/// [`WorkloadError::ImageSize`] naming the rule broken.
///
/// ```
/// use packtrace::protocol::workload::check_image_size;
/// assert!(check_image_size(1024, 768).is_ok());
/// assert!(check_image_size(3, 4).unwrap_err().to_string().contains("even"));
/// ```
pub fn check_image_size(width: u32, height: u32) -> Result<(), WorkloadError> {
    let size_error = |reason: &str| WorkloadError::ImageSize {
        width,
        height,
        reason: reason.to_string(),
    };
    if width == 0 || height == 0 || width % 2 == 1 || height % 2 == 1 {
        return Err(size_error(
            "width and height must be even and non-zero (pixels are traced in 2x2 packets)",
        ));
    }
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(size_error("more than 2^30 pixels"));
    }
    Ok(())
}

/// One of the protocol's workloads.
///
/// ```
/// use packtrace::protocol::workload::Workload;
/// let w: Workload = "ao".parse().unwrap();
/// assert_eq!(w, Workload::Ao);
/// assert!(w.is_occlusion());
/// assert_eq!(Workload::ALL.map(|w| w.name()), ["primary", "shadow", "ao", "random"]);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Workload {
    /// One camera ray per pixel, closest hit.
    Primary,
    /// One ray per primary hit toward the light, any hit.
    Shadow,
    /// Four cosine-distributed rays per primary hit within `0.25 D`, any hit.
    Ao,
    /// `W * H` rays from random points of the scene box, closest hit.
    Random,
}

impl Workload {
    /// All four, in the protocol's order.
    pub const ALL: [Workload; 4] = [
        Workload::Primary,
        Workload::Shadow,
        Workload::Ao,
        Workload::Random,
    ];

    /// The protocol's name (`primary`, `shadow`, `ao`, `random`).
    ///
    /// ```
    /// assert_eq!(packtrace::protocol::workload::Workload::Shadow.name(), "shadow");
    /// ```
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Workload::Primary => "primary",
            Workload::Shadow => "shadow",
            Workload::Ao => "ao",
            Workload::Random => "random",
        }
    }

    /// Is the query an any-hit (occlusion) query? True for `shadow` and
    /// `ao`, whose `sum_t` is reported as `null`.
    ///
    /// ```
    /// use packtrace::protocol::workload::Workload;
    /// assert!(!Workload::Primary.is_occlusion() && Workload::Shadow.is_occlusion());
    /// ```
    #[must_use]
    pub fn is_occlusion(self) -> bool {
        matches!(self, Workload::Shadow | Workload::Ao)
    }
}

impl fmt::Display for Workload {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Workload {
    type Err = WorkloadError;

    /// Parse a protocol name (exact, lower case).
    fn from_str(s: &str) -> Result<Workload, WorkloadError> {
        Workload::ALL
            .into_iter()
            .find(|w| w.name() == s)
            .ok_or_else(|| WorkloadError::UnknownWorkload(s.to_string()))
    }
}

/// Rays in ray order plus their 4-wide and 8-wide packets.
///
/// `packets[i][lane]` (and `packets8[i][lane]`) is an index into `rays`,
/// or [`NO_RAY`] for an inactive lane. Every ray is in exactly one lane of
/// each packet list; no packet is all inactive.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::camera::Camera;
/// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// let set = packtrace::protocol::workload::primary(&cam, 4, 2).unwrap();
/// assert_eq!(set.len(), 8);
/// assert_eq!(set.packets, vec![[0, 1, 4, 5], [2, 3, 6, 7]]);
/// assert_eq!(set.packet(1).ray(2), Some(set.rays[6]));
/// assert_eq!(set.packets8, vec![[0, 1, 2, 3, 4, 5, 6, 7]]);
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RaySet {
    /// The rays in the protocol's ray order.
    pub rays: Vec<Ray>,
    /// 4-wide packets: lane -> index into `rays`, [`NO_RAY`] when inactive.
    pub packets: Vec<[u32; 4]>,
    /// 8-wide packets, the same way.
    pub packets8: Vec<[u32; 8]>,
    /// For primary and shadow rays, the 4 x 2 pixel block of each 8-wide
    /// packet as `[x / 4, y / 2]`; empty otherwise.
    pub blocks8: Vec<[u32; 2]>,
    /// The point the rays share and which end of them it is: the eye for
    /// primary rays, the light for shadow rays; `None` for ao and random
    /// rays. Group modes build their frustums from it.
    pub apex: Option<(Vec3, Apex)>,
}

impl RaySet {
    /// Number of rays.
    ///
    /// ```
    /// assert_eq!(packtrace::protocol::workload::RaySet::default().len(), 0);
    /// ```
    #[must_use]
    pub fn len(&self) -> usize {
        self.rays.len()
    }

    /// True when there is no ray.
    ///
    /// ```
    /// assert!(packtrace::protocol::workload::RaySet::default().is_empty());
    /// ```
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.rays.is_empty()
    }

    /// Packet `i` as an SoA [`RayPacket4`].
    ///
    /// # Panics
    /// If `i` is out of range, or a lane's index is neither [`NO_RAY`] nor
    /// a ray of the set.
    ///
    /// ```
    /// use packtrace::protocol::{workload::random, SceneFrame};
    /// let frame = SceneFrame::of(&packtrace::protocol::generate::sphere(100));
    /// let set = random(&frame, 6);
    /// assert_eq!(set.packets, vec![[0, 1, 2, 3], [4, 5, u32::MAX, u32::MAX]]);
    /// assert_eq!(set.packet(1).active(), 0b0011);
    /// ```
    #[must_use]
    pub fn packet(&self, i: usize) -> RayPacket4 {
        RayPacket4::from_lanes(
            self.packets[i].map(|k| (k != NO_RAY).then(|| self.rays[k as usize])),
        )
    }

    /// 8-wide packet `i` as an SoA [`RayPacket8`].
    ///
    /// # Panics
    /// If `i` is out of range, or a lane's index is neither [`NO_RAY`] nor
    /// a ray of the set.
    ///
    /// ```
    /// use packtrace::protocol::{workload::random, SceneFrame};
    /// let frame = SceneFrame::of(&packtrace::protocol::generate::sphere(100));
    /// let set = random(&frame, 10);
    /// assert_eq!(set.packets8.len(), 2);
    /// assert_eq!(set.packet8(1).active(), 0b0011);
    /// ```
    #[must_use]
    pub fn packet8(&self, i: usize) -> RayPacket8 {
        RayPacket8::from_lanes(
            self.packets8[i].map(|k| (k != NO_RAY).then(|| self.rays[k as usize])),
        )
    }

    /// The 8-wide packets grouped into screen tiles of `w x h` pixels
    /// (`w` a multiple of 4, `h` of 2), tiles row by row, packets in set
    /// order within a tile; without blocks (random rays), runs of
    /// `w * h / 8` consecutive packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::Camera;
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// let set = packtrace::protocol::workload::primary(&cam, 16, 4).unwrap();
    /// // Blocks: 4 per row, 2 rows; 8 x 4 tiles hold 2 x 2 blocks.
    /// assert_eq!(set.tiles(8, 4), vec![vec![0, 1, 4, 5], vec![2, 3, 6, 7]]);
    /// ```
    #[must_use]
    pub fn tiles(&self, w: u32, h: u32) -> Vec<Vec<u32>> {
        let (bw, bh) = ((w / 4).max(1), (h / 2).max(1));
        if self.blocks8.len() != self.packets8.len() {
            let n = (bw * bh) as usize;
            return (0..self.packets8.len() as u32)
                .collect::<Vec<_>>()
                .chunks(n)
                .map(<[u32]>::to_vec)
                .collect();
        }
        let mut keyed: Vec<([u32; 2], u32)> = self
            .blocks8
            .iter()
            .enumerate()
            .map(|(i, &[x, y])| ([y / bh, x / bw], i as u32))
            .collect();
        keyed.sort_by_key(|&(k, i)| (k, i));
        let mut out: Vec<Vec<u32>> = Vec::new();
        let mut last = None;
        for (k, i) in keyed {
            if last != Some(k) {
                out.push(Vec::new());
                last = Some(k);
            }
            if let Some(t) = out.last_mut() {
                t.push(i);
            }
        }
        out
    }

    /// Append a ray; returns its index.
    fn push(&mut self, r: Ray) -> u32 {
        self.rays.push(r);
        (self.rays.len() - 1) as u32
    }

    /// Append a packet unless all its lanes are inactive.
    fn push_packet(&mut self, lanes: [u32; 4]) {
        if lanes.iter().any(|&k| k != NO_RAY) {
            self.packets.push(lanes);
        }
    }

    /// Append an 8-wide packet unless all its lanes are inactive.
    fn push_packet8(&mut self, lanes: [u32; 8]) {
        if lanes.iter().any(|&k| k != NO_RAY) {
            self.packets8.push(lanes);
        }
    }
}

/// The protocol's primary rays of a `width x height` image: ray order is
/// pixel order `p = y * width + x`; packets are the 2 x 2 pixel quads
/// `(x,y) (x+1,y) (x,y+1) (x+1,y+1)` for even `x, y`, row of quads by row
/// of quads; 8-wide packets the 4 x 2 blocks at `x` divisible by 4 (lanes
/// 0-3 the upper row, 4-7 the lower; pixels beyond the image inactive).
///
/// # Errors
/// [`WorkloadError::ImageSize`] as [`check_image_size`] says;
/// [`WorkloadError::Camera`] for an invalid camera ([`Camera::validate`]).
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::camera::Camera;
/// use packtrace::protocol::workload::primary;
/// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// let set = primary(&cam, 4, 4).unwrap();
/// assert_eq!(set.rays[5], cam.primary_ray(1, 1, 4, 4));
/// assert_eq!(set.packets[2], [8, 9, 12, 13]);
/// assert!(primary(&cam, 3, 4).is_err());
/// ```
pub fn primary(camera: &Camera, width: u32, height: u32) -> Result<RaySet, WorkloadError> {
    check_image_size(width, height)?;
    camera.validate().map_err(WorkloadError::Camera)?;
    let basis = ImagePlane::new(camera, width, height);
    let mut set = RaySet {
        rays: Vec::with_capacity(width as usize * height as usize),
        packets: Vec::with_capacity(width as usize * height as usize / 4),
        packets8: Vec::with_capacity(width as usize * height as usize / 8 + height as usize),
        blocks8: Vec::with_capacity(width as usize * height as usize / 8 + height as usize),
        apex: Some((camera.eye, Apex::Origin)),
    };
    // Rays in pixel order
    for y in 0..height {
        for x in 0..width {
            set.rays.push(basis.ray(x, y));
        }
    }
    // Quads, row of quads by row of quads
    for y in (0..height).step_by(2) {
        for x in (0..width).step_by(2) {
            let p = y * width + x;
            set.packets.push([p, p + 1, p + width, p + width + 1]);
        }
        // 4 x 2 blocks of the same two rows
        for x in (0..width).step_by(4) {
            set.packets8.push(std::array::from_fn(|l| {
                let (px, py) = (x + l as u32 % 4, y + l as u32 / 4);
                if px < width { py * width + px } else { NO_RAY }
            }));
            set.blocks8.push([x / 4, y / 2]);
        }
    }
    Ok(set)
}

/// Start point `Q = P + n * (1e-4 * D)` and unit normal `n` (facing the
/// incoming ray) of the secondary rays of a primary hit at
/// `P = origin + t * dir` (protocol, "Workloads"). The renderer starts its
/// shadow and ambient-occlusion rays here too.
///
/// # Panics
/// If the hit names a triangle not in `mesh`.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{Hit, Mesh, Ray};
/// use packtrace::protocol::{workload::surface_point, SceneFrame};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
/// let hit = Hit { t: 1.0, prim: 0, u: 0.25, v: 0.25 };
/// let (q, n) = surface_point(&r, &hit, &mesh, &SceneFrame::of(&mesh));
/// assert_eq!(n, Vec3::Z);
/// assert!(q.z > 0.0 && q.z < 1e-3);
/// ```
#[inline]
#[must_use]
pub fn surface_point(ray: &Ray, hit: &Hit, mesh: &Mesh, frame: &SceneFrame) -> (Vec3, Vec3) {
    let p = ray.origin + hit.t * ray.dir;
    let mut n = mesh.normal(hit.prim as usize);
    if n.dot(ray.dir) > 0.0 {
        n = -n;
    }
    (p + n * (1e-4 * frame.diagonal), n)
}

/// The protocol's shadow ray from `q` toward `light`: unit direction,
/// `t_max = |light - q| * (1 - 1e-4)`. A light exactly at `q` gives a NaN
/// ray (never occluded).
///
/// ```
/// use glam::Vec3;
/// let r = packtrace::protocol::workload::shadow_ray(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0));
/// assert_eq!((r.dir(), r.t_max()), (Vec3::Z, 2.0 * (1.0 - 1e-4)));
/// ```
#[inline]
#[must_use]
pub fn shadow_ray(q: Vec3, light: Vec3) -> Ray {
    let to_light = light - q;
    Ray::new_unchecked(
        q,
        to_light.normalize(),
        0.0,
        to_light.length() * (1.0 - 1e-4),
    )
}

/// Secondary rays derived from primary hits: `make(pixel, Q, n, k)` for
/// `k in 0..per_hit`, packets inheriting the primary packets (one per `k`).
fn secondary(
    primary: &RaySet,
    hits: &[Option<Hit>],
    mesh: &Mesh,
    frame: &SceneFrame,
    per_hit: u32,
    make: impl Fn(u32, Vec3, Vec3, u32) -> Ray,
) -> RaySet {
    assert_eq!(primary.len(), hits.len(), "one primary hit slot per ray");
    let count = hits.iter().flatten().count() * per_hit as usize;
    let mut set = RaySet {
        rays: Vec::with_capacity(count),
        packets: Vec::with_capacity(primary.packets.len() * per_hit as usize),
        packets8: Vec::with_capacity(primary.packets8.len() * per_hit as usize),
        blocks8: Vec::new(),
        apex: None,
    };
    // Rays in pixel order, sample k after pixel; first index per pixel
    let mut first = vec![NO_RAY; hits.len()];
    for (p, (ray, hit)) in primary.rays.iter().zip(hits).enumerate() {
        if let Some(hit) = hit {
            let (q, n) = surface_point(ray, hit, mesh, frame);
            first[p] = set.rays.len() as u32;
            for k in 0..per_hit {
                set.push(make(p as u32, q, n, k));
            }
        }
    }
    // Packets: lane -> sample k of the lane's pixel
    let sample = |p: u32, k: u32| match first.get(p as usize) {
        Some(&f) if f != NO_RAY => f + k,
        _ => NO_RAY,
    };
    for lanes in &primary.packets {
        for k in 0..per_hit {
            set.push_packet(lanes.map(|p| sample(p, k)));
        }
    }
    let blocks = per_hit == 1 && primary.blocks8.len() == primary.packets8.len();
    for (i, lanes) in primary.packets8.iter().enumerate() {
        for k in 0..per_hit {
            let before = set.packets8.len();
            set.push_packet8(lanes.map(|p| sample(p, k)));
            if blocks && set.packets8.len() > before {
                set.blocks8.push(primary.blocks8[i]);
            }
        }
    }
    set
}

/// The protocol's shadow rays: one per primary hit, from
/// `Q = P + n * (1e-4 * D)` toward `light`, `t_max = |L - Q| * (1 - 1e-4)`.
///
/// `primary` must be in pixel order (as [`primary`] makes it) and
/// `hits[i]` the closest hit of `primary.rays[i]` in `mesh`. Ray order is
/// pixel order; each ray takes its pixel's lane of its pixel's packet, a
/// lane whose primary ray missed is [`NO_RAY`], and packets without any
/// hit are left out. A light exactly at `Q` gives a NaN ray (never
/// occluded).
///
/// # Panics
/// If `hits.len() != primary.len()` or a hit names a triangle not in `mesh`.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{Hit, Mesh, Ray};
/// use packtrace::protocol::workload::{shadow, RaySet, NO_RAY};
/// use packtrace::protocol::SceneFrame;
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
/// let primary = RaySet { rays: vec![r, r], packets: vec![[0, 1, NO_RAY, NO_RAY]], ..Default::default() };
/// let hits = [None, Some(Hit { t: 1.0, prim: 0, u: 0.25, v: 0.25 })];
/// let frame = SceneFrame::of(&mesh);
/// let s = shadow(&primary, &hits, &mesh, &frame, Vec3::new(0.25, 0.25, 5.0));
/// assert_eq!(s.packets, vec![[NO_RAY, 0, NO_RAY, NO_RAY]]);
/// assert_eq!(s.rays[0].dir(), Vec3::Z);
/// assert!(s.rays[0].origin().z > 0.0);
/// ```
#[must_use]
pub fn shadow(
    primary: &RaySet,
    hits: &[Option<Hit>],
    mesh: &Mesh,
    frame: &SceneFrame,
    light: Vec3,
) -> RaySet {
    let mut set = secondary(primary, hits, mesh, frame, 1, |_, q, _, _| {
        shadow_ray(q, light)
    });
    set.apex = Some((light, Apex::Target));
    set
}

/// The protocol's ambient-occlusion rays: [`AO_SAMPLES`] per primary hit,
/// from `Q` in [`ao_direction`]`(p, k, n)`, `t_max = 0.25 * D`.
///
/// `primary` must be in pixel order (as [`primary`] makes it; the ray
/// index is the pixel index `p`) and `hits[i]` the closest hit of
/// `primary.rays[i]`. Ray order: pixel order, sample `k` after pixel.
/// Packets: for each primary packet and each `k`, the packet holding
/// sample `k` of its pixels (quad-major, `k` minor); a lane whose primary
/// ray missed is [`NO_RAY`], packets without any hit are left out.
///
/// # Panics
/// If `hits.len() != primary.len()` or a hit names a triangle not in `mesh`.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{Hit, Mesh, Ray};
/// use packtrace::protocol::workload::{ao, RaySet, NO_RAY};
/// use packtrace::protocol::SceneFrame;
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let r = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
/// let primary = RaySet { rays: vec![r, r], packets: vec![[0, 1, NO_RAY, NO_RAY]], ..Default::default() };
/// let hit = Some(Hit { t: 1.0, prim: 0, u: 0.25, v: 0.25 });
/// let set = ao(&primary, &[None, hit], &mesh, &SceneFrame::of(&mesh));
/// assert_eq!(set.len(), 4);
/// assert_eq!(set.packets[3], [NO_RAY, 3, NO_RAY, NO_RAY]);
/// assert!(set.rays.iter().all(|r| r.dir().z > 0.0));
/// ```
#[must_use]
pub fn ao(primary: &RaySet, hits: &[Option<Hit>], mesh: &Mesh, frame: &SceneFrame) -> RaySet {
    let t_max = 0.25 * frame.diagonal;
    secondary(primary, hits, mesh, frame, AO_SAMPLES, |p, q, n, k| {
        Ray::new_unchecked(q, ao_direction(p, k, n), 0.0, t_max)
    })
}

/// The protocol's random rays: ray `i` starts at a hashed point of the
/// scene box and points in a hashed direction uniform on the sphere,
/// `t_min = 0`, `t_max = +inf`. Packets group rays `4i .. 4i+3`, 8-wide
/// ones `8i .. 8i+7` (the last may have [`NO_RAY`] lanes). The protocol
/// uses `count = W * H`.
///
/// # Panics
/// If `count >= u32::MAX` (ray indices are `u32`).
///
/// ```
/// use packtrace::protocol::{workload::random, SceneFrame};
/// let frame = SceneFrame::of(&packtrace::protocol::generate::sphere(100));
/// let set = random(&frame, 1000);
/// assert!(set.rays.iter().all(|r| frame.bounds.contains(r.origin().into())));
/// assert_eq!(set.packets.len(), 250);
/// ```
#[must_use]
pub fn random(frame: &SceneFrame, count: usize) -> RaySet {
    assert!(count < NO_RAY as usize, "{count} rays exceed u32 indices");
    let (min, max) = (Vec3::from(frame.bounds.min), Vec3::from(frame.bounds.max));
    let extent = max - min;
    let mut set = RaySet {
        rays: Vec::with_capacity(count),
        packets: Vec::with_capacity(count.div_ceil(4)),
        packets8: Vec::with_capacity(count.div_ceil(8)),
        blocks8: Vec::new(),
        apex: None,
    };
    for i in 0..count as u32 {
        let s: [u32; 5] = std::array::from_fn(|j| hash(i.wrapping_mul(8).wrapping_add(j as u32)));
        let z = 1.0 - 2.0 * unit(s[0]);
        let rr = (1.0 - z * z).max(0.0).sqrt();
        let phi = 2.0 * PI * unit(s[1]);
        let dir = Vec3::new(rr * phi.cos(), rr * phi.sin(), z);
        let origin = min + Vec3::new(unit(s[2]), unit(s[3]), unit(s[4])) * extent;
        set.push(Ray::new_unchecked(origin, dir, 0.0, f32::INFINITY));
    }
    for first in (0..count as u32).step_by(4) {
        let lanes = std::array::from_fn(|l| {
            let k = first + l as u32;
            if (k as usize) < count { k } else { NO_RAY }
        });
        set.push_packet(lanes);
    }
    for first in (0..count as u32).step_by(8) {
        let lanes = std::array::from_fn(|l| {
            let k = first + l as u32;
            if (k as usize) < count { k } else { NO_RAY }
        });
        set.push_packet8(lanes);
    }
    set
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kdtree::{KdBuildParams, KdTree};
    use crate::protocol::sampling::onb;

    /// Values computed independently in python3 with `& 0xffffffff`
    /// masking: (v, hash(v), unit(hash(v))).
    const HASHES: [(u32, u32, f64); 8] = [
        (0, 129708002, 0.030199944972991943),
        (1, 2831084092, 0.6591631174087524),
        (2, 2055130248, 0.4784972667694092),
        (15, 798401024, 0.1858922243118286),
        (16, 980210444, 0.2282230257987976),
        (12345, 4099845390, 0.9545696377754211),
        (0xffff_ffff, 3861530882, 0.8990827202796936),
        (1048575 * 16 + 3, 1576920933, 0.3671554923057556),
    ];

    #[test]
    fn hash_and_unit_match_independent_values() {
        for (v, h, u) in HASHES {
            assert_eq!(hash(v), h, "hash({v})");
            assert_eq!(unit(hash(v)) as f64, u, "unit(hash({v}))");
        }
        assert_eq!(unit(0xff), 0.0);
        assert_eq!(unit(0x100), 1.0 / 16777216.0);
    }

    #[test]
    fn ao_seed_wraps_for_huge_pixel_indices() {
        // p * 16 + k wraps: pixel 2^28 sample 1 uses hash(1)
        let n = Vec3::Z;
        assert_eq!(ao_direction(1 << 28, 1, n), ao_direction(0, 1, n));
    }

    #[test]
    fn onb_is_orthonormal_and_right_handed() {
        let mut normals = vec![
            Vec3::Z,
            Vec3::NEG_Z,
            Vec3::X,
            Vec3::NEG_X,
            Vec3::Y,
            Vec3::NEG_Y,
            Vec3::new(1.0, 1.0, 0.0).normalize(),
        ];
        normals.push(Vec3::new(0.6, 0.8, -0.0)); // n.z = -0.0: sign -1
        normals.push(Vec3::new(1e-4, 0.0, -1.0).normalize());
        normals.push(Vec3::new(0.0, 1e-4, 1.0).normalize());
        for i in 0..20000u32 {
            // uniform on the sphere, as the random workload draws them
            let z = 1.0 - 2.0 * unit(hash(3 * i));
            let rr = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * PI * unit(hash(3 * i + 1));
            normals.push(Vec3::new(rr * phi.cos(), rr * phi.sin(), z));
        }
        for n in normals {
            let (b1, b2) = onb(n);
            let tol = 1e-5;
            assert!((b1.length() - 1.0).abs() < tol, "{n} {b1}");
            assert!((b2.length() - 1.0).abs() < tol, "{n} {b2}");
            assert!(b1.dot(b2).abs() < tol, "{n}");
            assert!(b1.dot(n).abs() < tol && b2.dot(n).abs() < tol, "{n}");
            assert!((b1.cross(b2) - n).length() < 2.0 * tol, "{n}");
        }
    }

    #[test]
    fn workload_names_round_trip() {
        for w in Workload::ALL {
            assert_eq!(w.name().parse::<Workload>().unwrap(), w);
            assert_eq!(w.to_string(), w.name());
        }
        let e = "AO".parse::<Workload>().unwrap_err().to_string();
        assert!(e.contains("`AO`"), "{e}");
    }

    fn camera() -> Camera {
        Camera::parse("0,0,4, 0,0,0, 0,1,0, 40").unwrap()
    }

    #[test]
    fn primary_packet_layout() {
        let set = primary(&camera(), 4, 2).unwrap();
        assert_eq!(set.packets, vec![[0, 1, 4, 5], [2, 3, 6, 7]]);
        let set = primary(&camera(), 6, 4).unwrap();
        assert_eq!(set.packets.len(), 6);
        assert_eq!(set.packets[4], [14, 15, 20, 21]);
        for (p, r) in set.rays.iter().enumerate() {
            let (x, y) = (p as u32 % 6, p as u32 / 6);
            assert_eq!(*r, camera().primary_ray(x, y, 6, 4));
        }
        // every ray in exactly one lane
        let mut seen = vec![0; set.len()];
        for l in set.packets.iter().flatten() {
            seen[*l as usize] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1));
        for (w, h) in [(0, 2), (2, 0), (5, 2), (4, 3), (1 << 16, 1 << 16)] {
            assert!(matches!(
                primary(&camera(), w, h),
                Err(WorkloadError::ImageSize { .. })
            ));
        }
        let mut bad = camera();
        bad.fov_deg = 0.0;
        assert!(matches!(
            primary(&bad, 2, 2),
            Err(WorkloadError::Camera(ViewError::Camera { .. }))
        ));
    }

    #[test]
    fn random_rays_start_in_the_box_with_unit_directions() {
        let mesh = crate::protocol::generate::cornell_box();
        let frame = SceneFrame::of(&mesh);
        let set = random(&frame, 10_001);
        assert_eq!(set.len(), 10_001);
        assert_eq!(set.packets.len(), 2501);
        assert_eq!(set.packets[2500], [10_000, NO_RAY, NO_RAY, NO_RAY]);
        let mut octants = [0u32; 8];
        for r in &set.rays {
            assert!(frame.bounds.contains(r.origin.into()), "{r:?}");
            assert!((r.dir.length() - 1.0).abs() < 1e-6, "{r:?}");
            assert_eq!((r.t_min, r.t_max), (0.0, f32::INFINITY));
            let o = (r.dir.x > 0.0) as usize
                | ((r.dir.y > 0.0) as usize) << 1
                | ((r.dir.z > 0.0) as usize) << 2;
            octants[o] += 1;
        }
        // uniform directions: every octant near 1/8
        assert!(
            octants.iter().all(|&c| (1000..1500).contains(&c)),
            "{octants:?}"
        );
        // the first ray, from the protocol by hand (python3 reference)
        let s: Vec<f32> = (0..5).map(|j| unit(hash(j))).collect();
        let z = 1.0 - 2.0 * s[0];
        assert_eq!(set.rays[0].dir.z, z);
        assert_eq!(random(&frame, 0), RaySet::default());
    }

    /// A closed sphere seen from outside, with the kd-tree's hits.
    fn sphere_scene(w: u32, h: u32) -> (KdTree, SceneFrame, RaySet, Vec<Option<Hit>>) {
        let mesh = crate::protocol::generate::sphere(2000);
        let frame = SceneFrame::of(&mesh);
        let tree = KdTree::build(mesh, &KdBuildParams::default()).unwrap();
        let set = primary(&Camera::parse("0.3,0.2,3, 0,0,0, 0,1,0, 45").unwrap(), w, h).unwrap();
        let hits: Vec<_> = set.rays.iter().map(|r| tree.intersect(r)).collect();
        (tree, frame, set, hits)
    }

    #[test]
    fn shadow_rays_point_to_the_light_and_start_off_the_surface() {
        let (tree, frame, set, hits) = sphere_scene(32, 32);
        let n_hits = hits.iter().flatten().count();
        assert!(n_hits > 100 && n_hits < set.len(), "{n_hits}");
        let light = Vec3::new(0.5, 3.0, 2.0);
        let sh = shadow(&set, &hits, tree.mesh(), &frame, light);
        assert_eq!(sh.len(), n_hits);
        let (mut k, mut lit_count) = (0, 0);
        for (p, hit) in hits.iter().enumerate() {
            let Some(hit) = hit else { continue };
            let r = sh.rays[k];
            k += 1;
            let surf = set.rays[p].at(hit.t);
            let off = r.origin - surf;
            // Q = P + n * 1e-4 D, n facing the camera
            assert!((off.length() - 1e-4 * frame.diagonal).abs() < 1e-6, "{p}");
            assert!(off.dot(set.rays[p].dir) < 0.0, "{p}");
            assert!((r.dir - (light - r.origin).normalize()).length() < 1e-6);
            assert!((r.dir.length() - 1.0).abs() < 1e-6);
            let end = r.at(r.t_max);
            let d = (light - r.origin).length();
            assert!((end - light).length() < 2e-4 * d, "{p}");
            assert!(r.t_max < d);
            // Q is outside the convex sphere: a ray leaving on the lit side
            // never hits it; one heading well into the surface always does
            // (a grazing one may pass the edge of the face it left)
            let cos = tree.mesh().normal(hit.prim as usize).dot(r.dir);
            if !(-0.3..=0.0).contains(&cos) {
                assert_eq!(tree.occluded(&r), cos < 0.0, "{p} cos {cos}");
            }
            lit_count += (cos > 0.0) as usize;
        }
        assert!(lit_count > 50 && lit_count < n_hits - 50, "{lit_count}");
        // packets follow the quads; lanes of missed pixels are inactive
        assert_eq!(
            sh.packets.len(),
            set.packets
                .iter()
                .filter(|q| q.iter().any(|&p| hits[p as usize].is_some()))
                .count()
        );
        let mut index_of = vec![NO_RAY; set.len()];
        let mut k = 0;
        for (p, h) in hits.iter().enumerate() {
            if h.is_some() {
                index_of[p] = k;
                k += 1;
            }
        }
        let expect: Vec<[u32; 4]> = set
            .packets
            .iter()
            .map(|q| q.map(|p| index_of[p as usize]))
            .filter(|q| q.iter().any(|&i| i != NO_RAY))
            .collect();
        assert_eq!(sh.packets, expect);
    }

    #[test]
    fn ao_rays_leave_the_surface_into_its_hemisphere() {
        let (tree, frame, set, hits) = sphere_scene(16, 16);
        let a = ao(&set, &hits, tree.mesh(), &frame);
        let n_hits = hits.iter().flatten().count();
        assert_eq!(a.len(), 4 * n_hits);
        let mut k = 0;
        for (p, hit) in hits.iter().enumerate() {
            let Some(hit) = hit else { continue };
            let mut n = tree.mesh().normal(hit.prim as usize);
            if n.dot(set.rays[p].dir) > 0.0 {
                n = -n;
            }
            for s in 0..4 {
                let r = a.rays[k];
                k += 1;
                assert_eq!(r.dir, ao_direction(p as u32, s, n));
                assert!(r.dir.dot(n) >= 0.0);
                assert!((r.dir.length() - 1.0).abs() < 1e-6);
                assert_eq!((r.t_min, r.t_max), (0.0, 0.25 * frame.diagonal));
            }
        }
        // packet j*4+k of the quads holds sample k of the quad's pixels
        let first = |p: u32| hits[..p as usize].iter().flatten().count() as u32 * 4;
        let mut expect = Vec::new();
        for q in &set.packets {
            for s in 0..4 {
                let lanes = q.map(|p| {
                    if hits[p as usize].is_some() {
                        first(p) + s
                    } else {
                        NO_RAY
                    }
                });
                if lanes.iter().any(|&l| l != NO_RAY) {
                    expect.push(lanes);
                }
            }
        }
        assert_eq!(a.packets, expect);
    }

    #[test]
    fn ao_directions_are_cosine_distributed() {
        // E[cos] = 2/3 for a cosine-weighted hemisphere
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let m: f64 = (0..40000u32)
            .map(|i| ao_direction(i / 4, i % 4, n).dot(n) as f64)
            .sum::<f64>()
            / 40000.0;
        assert!((m - 2.0 / 3.0).abs() < 0.01, "{m}");
    }
}
