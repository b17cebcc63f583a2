//! The query traits every engine implements (the kd-tree, its naive
//! layout, the brute-force oracle), so hosts, the benchmark and the tests
//! call them alike, and the tracing [`Mode`]s.

use crate::packet::{HitPacket4, HitPacket8, RayPacket4, RayPacket8};
use crate::ray::{Hit, Ray};

/// Closest-hit and occlusion queries of one ray. Every accelerator and the
/// brute-force oracle implement it, so tests treat them alike.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{BruteForce, KdBuildParams, KdTree, Mesh, Ray, RayQuery};
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let tree = KdTree::build(m.clone(), &KdBuildParams::default()).unwrap();
/// let brute = BruteForce::new(&m);
/// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// let engines: [&dyn RayQuery; 2] = [&tree, &brute];
/// assert_eq!(engines[0].intersect(&r), engines[1].intersect(&r));
/// ```
pub trait RayQuery {
    /// Closest hit in `(t_min, t_max]`, ties to the smaller triangle index.
    fn intersect(&self, ray: &Ray) -> Option<Hit>;
    /// Is there any hit in `(t_min, t_max]`?
    fn occluded(&self, ray: &Ray) -> bool;
}

/// Queries of 4- and 8-wide packets and of streams of rays, beside
/// [`RayQuery`]: lane `i` of every answer equals the single-ray query of
/// ray `i`, bit for bit.
///
/// The stream methods trace consecutive rays as packets by default; an
/// engine may trace them any way that keeps that equality.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{BruteForce, KdBuildParams, KdTree, Mesh, NaiveKdTree, Ray, RayPacket4};
/// use packtrace::query::PacketQuery;
/// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
/// let tree = KdTree::build(m.clone(), &KdBuildParams::default()).unwrap();
/// let naive = NaiveKdTree::from_kd(&tree);
/// let brute = BruteForce::new(&m);
/// let r = |x: f32| Ray::new(Vec3::new(x, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
/// let p = RayPacket4::from_rays(&[r(0.1), r(0.2), r(5.0), r(0.3)]);
/// let engines: [&dyn PacketQuery; 3] = [&tree, &naive, &brute];
/// for e in engines {
///     assert_eq!(e.intersect4(&p).mask(), 0b1011);
///     assert_eq!(e.occluded4(&p), 0b1011);
/// }
/// ```
pub trait PacketQuery: RayQuery {
    /// Closest hits of the packet's active lanes.
    fn intersect4(&self, packet: &RayPacket4) -> HitPacket4;
    /// Occlusion of the packet's active lanes: bit `i` set when lane `i`
    /// has any hit.
    fn occluded4(&self, packet: &RayPacket4) -> u32;
    /// Closest hits of an 8-wide packet's active lanes.
    fn intersect8(&self, packet: &RayPacket8) -> HitPacket8;
    /// Occlusion of an 8-wide packet's active lanes.
    fn occluded8(&self, packet: &RayPacket8) -> u32;

    /// Closest hits of a stream of rays, `hits[i]` for `rays[i]`.
    ///
    /// # Panics
    /// If `rays.len() != hits.len()`.
    fn intersect_rays(&self, rays: &[Ray], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit slot per ray");
        for (rs, hs) in rays.chunks(4).zip(hits.chunks_mut(4)) {
            let h = self.intersect4(&RayPacket4::from_slice(rs));
            for (i, slot) in hs.iter_mut().enumerate() {
                *slot = h.hit(i);
            }
        }
    }

    /// Occlusion of a stream of rays, `occluded[i]` for `rays[i]`.
    ///
    /// # Panics
    /// If `rays.len() != occluded.len()`.
    fn occluded_rays(&self, rays: &[Ray], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one slot per ray");
        for (rs, os) in rays.chunks(4).zip(occluded.chunks_mut(4)) {
            let m = self.occluded4(&RayPacket4::from_slice(rs));
            for (i, slot) in os.iter_mut().enumerate() {
                *slot = m >> i & 1 == 1;
            }
        }
    }
}

/// How rays are traced: one at a time ([`RayQuery`]), as 4- or 8-wide
/// packets ([`PacketQuery`]; the protocol's 2 x 2 pixel quads and 4 x 2
/// blocks), as a stream that the engine groups itself
/// ([`PacketQuery::intersect_rays`]), or as screen tiles of 8 x 8 or
/// 16 x 16 rays traced as one ray group ([`crate::group::RayGroup`]).
/// Every mode gives the same answers, bit for bit; the renderer and the
/// benchmark share this one list.
///
/// ```
/// use packtrace::query::Mode;
/// assert_eq!("scalar".parse::<Mode>().unwrap(), Mode::Scalar);
/// assert_eq!(Mode::Packet8.name(), "packet8");
/// assert_eq!(Mode::ALL.len(), 6);
/// assert_eq!(Mode::default(), Mode::Packet8);
/// let e = "simd".parse::<Mode>().unwrap_err();
/// assert_eq!(
///     e.to_string(),
///     "unknown mode `simd` (expected scalar or packet4 or packet8 or stream \
///      or group8x8 or group16x16)"
/// );
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Mode {
    /// One ray at a time, in ray order
    Scalar,
    /// The workload's 4-wide packets
    Packet4,
    /// The workload's 8-wide packets (the fastest width)
    #[default]
    Packet8,
    /// All rays at once through the stream API, which sorts them into
    /// coherent packets itself
    Stream,
    /// Screen tiles of 8 x 8 rays traced as one group with a frustum
    /// ([`crate::group::RayGroup`]; 8 packets of 4 x 2)
    Group8x8,
    /// Screen tiles of 16 x 16 rays traced as one group (32 packets)
    Group16x16,
}

impl Mode {
    /// Every mode, scalar first.
    pub const ALL: [Mode; 6] = [
        Mode::Scalar,
        Mode::Packet4,
        Mode::Packet8,
        Mode::Stream,
        Mode::Group8x8,
        Mode::Group16x16,
    ];

    /// The mode's name on the command line and in JSON.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Mode::Scalar => "scalar",
            Mode::Packet4 => "packet4",
            Mode::Packet8 => "packet8",
            Mode::Stream => "stream",
            Mode::Group8x8 => "group8x8",
            Mode::Group16x16 => "group16x16",
        }
    }

    /// Lanes per packet (1 for scalar; the stream's packet width).
    ///
    /// ```
    /// assert_eq!(packtrace::Mode::Packet4.width(), 4);
    /// ```
    #[must_use]
    pub fn width(self) -> u32 {
        match self {
            Mode::Scalar => 1,
            Mode::Packet4 => 4,
            Mode::Packet8 | Mode::Stream | Mode::Group8x8 | Mode::Group16x16 => 8,
        }
    }

    /// The screen tile of a group mode, in pixels (`None` otherwise).
    ///
    /// ```
    /// use packtrace::Mode;
    /// assert_eq!(Mode::Group16x16.tile(), Some((16, 16)));
    /// assert_eq!(Mode::Packet8.tile(), None);
    /// ```
    #[must_use]
    pub fn tile(self) -> Option<(u32, u32)> {
        match self {
            Mode::Group8x8 => Some((8, 8)),
            Mode::Group16x16 => Some((16, 16)),
            _ => None,
        }
    }
}

impl std::fmt::Display for Mode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A mode name that is not one of [`Mode::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownMode(pub String);

impl std::fmt::Display for UnknownMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = Mode::ALL.iter().map(|m| m.name()).collect();
        write!(
            f,
            "unknown mode `{}` (expected {})",
            self.0,
            names.join(" or ")
        )
    }
}

impl std::error::Error for UnknownMode {}

impl std::str::FromStr for Mode {
    type Err = UnknownMode;

    fn from_str(s: &str) -> Result<Mode, UnknownMode> {
        Mode::ALL
            .into_iter()
            .find(|m| m.name() == s)
            .ok_or_else(|| UnknownMode(s.to_string()))
    }
}
