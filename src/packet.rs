//! Ray packets of any SIMD width in structure-of-arrays form (Wald et al.
//! 2001), the packet result, and the SoA slab test: [`RayPacket<L>`] and
//! [`HitPacket<L>`] over a [`Lane`] type, with [`RayPacket4`] (SSE) and
//! [`RayPacket8`] (AVX2 when the CPU has it) as the two widths.

use crate::aabb::{Aabb, slab};
use crate::ray::{Hit, NO_PRIM, Ray, RayError};
use crate::simd::{F4, F8, Lane};
use crate::triangle::{Shear, permutation, shear};
use glam::Vec3;
use std::fmt;

/// The widest packet any lane type has (bounds per-lane scratch arrays).
pub(crate) const MAX_WIDTH: usize = 8;

/// Rays, one per lane, in SoA form. The fields are private so that the
/// invariant the traversal relies on always holds: a lane outside
/// [`RayPacket::active`] carries the empty interval `t_min = +inf,
/// t_max = -inf`, so it can never hit.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{Ray, RayPacket4, RayPacket8};
/// let r = Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 1.0).unwrap();
/// let p = RayPacket4::from_lanes([Some(r), None, Some(r), None]);
/// assert_eq!(p.active(), 0b0101);
/// assert_eq!(p.ray(0), Some(r));
/// assert_eq!(p.ray(1), None);
/// let p8 = RayPacket8::from_slice(&[r; 5]);
/// assert_eq!(p8.active(), 0b1_1111);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct RayPacket<L: Lane> {
    /// Origins, per axis.
    org: [L; 3],
    /// Directions, per axis.
    dir: [L; 3],
    /// Exact reciprocal directions, per axis (`1.0 / dir`, never `rcpps`).
    inv_dir: [L; 3],
    /// Exclusive lower bounds.
    t_min: L,
    /// Inclusive upper bounds.
    t_max: L,
    /// Bit `i` set when lane `i` holds a ray.
    active: u32,
}

/// Four rays: SSE lanes, the protocol's 2 x 2 pixel quads.
pub type RayPacket4 = RayPacket<F4>;
/// Eight rays: AVX lanes when the CPU has AVX2 (chosen at run time), two
/// SSE halves otherwise; the protocol's 4 x 2 pixel blocks.
pub type RayPacket8 = RayPacket<F8>;

/// Why [`RayPacket4::from_soa`] (or [`RayPacket8::from_soa`]) refused its
/// arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PacketError {
    /// The active mask has bits beyond the packet's lanes (the value given).
    ActiveMask(u32),
    /// An active lane holds a ray that [`Ray::new`] refuses.
    Lane {
        /// The first such lane.
        lane: usize,
        /// Why its ray was refused.
        error: RayError,
    },
}

impl fmt::Display for PacketError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PacketError::ActiveMask(m) => {
                write!(f, "active mask {m:#b} has bits beyond the packet's lanes")
            }
            PacketError::Lane { lane, error } => write!(f, "lane {lane}: {error}"),
        }
    }
}

/// A leaf error: the lane's reason is part of the message, so there is no
/// `source()`.
impl std::error::Error for PacketError {}

impl<L: Lane> RayPacket<L> {
    /// Number of lanes.
    pub const WIDTH: usize = L::WIDTH;

    /// Packet with lane `i` set to `f(i)`; `None` lanes are inactive.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayPacket8};
    /// let r = |i: usize| Ray::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::Z, 0.0, 1.0).ok();
    /// let p = RayPacket8::from_fn(|i| if i % 2 == 0 { r(i) } else { None });
    /// assert_eq!(p.active(), 0b0101_0101);
    /// assert_eq!(p.ray(6).unwrap().origin().x, 6.0);
    /// ```
    #[must_use]
    pub fn from_fn(mut f: impl FnMut(usize) -> Option<Ray>) -> RayPacket<L> {
        let mut rays = [None; MAX_WIDTH];
        let mut active = 0;
        for (i, slot) in rays.iter_mut().enumerate().take(L::WIDTH) {
            *slot = f(i);
            active |= (slot.is_some() as u32) << i;
        }
        let lane =
            |g: &dyn Fn(&Ray) -> f32, empty: f32| L::from_fn(|i| rays[i].as_ref().map_or(empty, g));
        RayPacket {
            org: [0, 1, 2].map(|a| lane(&|r: &Ray| r.origin[a], 0.0)),
            dir: [0, 1, 2].map(|a| lane(&|r: &Ray| r.dir[a], 1.0)),
            inv_dir: [0, 1, 2].map(|a| lane(&|r: &Ray| r.inv_dir[a], 1.0)),
            t_min: lane(&|r: &Ray| r.t_min, f32::INFINITY),
            t_max: lane(&|r: &Ray| r.t_max, f32::NEG_INFINITY),
            active,
        }
    }

    /// Packet of the first [`RayPacket::WIDTH`] rays of `rays` (fewer: the
    /// missing lanes are inactive): how streams are cut into packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(RayPacket4::from_slice(&[r, r, r]).active(), 0b0111);
    /// assert_eq!(RayPacket4::from_slice(&[r; 6]).active(), 0b1111);
    /// ```
    #[must_use]
    pub fn from_slice(rays: &[Ray]) -> RayPacket<L> {
        RayPacket::from_fn(|i| rays.get(i).copied())
    }

    /// Bit `i` set when lane `i` holds a ray.
    ///
    /// ```
    /// assert_eq!(packtrace::RayPacket8::from_slice(&[]).active(), 0);
    /// ```
    #[must_use]
    pub fn active(&self) -> u32 {
        self.active
    }

    /// The same packet with only the lanes of `mask` still active: the
    /// others get the empty interval, as every inactive lane has.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// let p = RayPacket4::from_rays(&[r; 4]).with_active(0b0110);
    /// assert_eq!(p.active(), 0b0110);
    /// assert_eq!((p.ray(0), p.ray(1)), (None, Some(r)));
    /// ```
    #[must_use]
    pub fn with_active(&self, mask: u32) -> RayPacket<L> {
        let active = self.active & mask;
        let keep = L::mask_from_bits(active);
        RayPacket {
            t_min: L::select(keep, self.t_min, L::splat(f32::INFINITY)),
            t_max: L::select(keep, self.t_max, L::splat(f32::NEG_INFINITY)),
            active,
            ..*self
        }
    }

    /// How far the active lanes' directions spread: over the three axes,
    /// the largest `max - min` of a direction component, divided by the
    /// largest component magnitude of any active lane (0 for one lane or
    /// parallel rays, 2 for opposite ones). A packet of mixed direction
    /// signs that spreads more than [`MAX_DIR_SPREAD`](crate::kdtree::MAX_DIR_SPREAD)
    /// is traced lane by lane.
    ///
    /// ```
    /// use packtrace::glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let ray = |d: Vec3| Ray::new(Vec3::ZERO, d, 0.0, 1.0).unwrap();
    /// let p = RayPacket4::from_rays(&[ray(Vec3::X), ray(Vec3::NEG_X), ray(Vec3::Y), ray(Vec3::X)]);
    /// assert_eq!(p.dir_spread(), 2.0);
    /// assert_eq!(p.with_active(0b1001).dir_spread(), 0.0);
    /// ```
    #[must_use]
    pub fn dir_spread(&self) -> f32 {
        if self.active == 0 {
            return 0.0;
        }
        // Inactive lanes take the first active lane's value, so the folds
        // run over every lane without branches, and `a < b ? a : b` is one
        // `minss` (every packet of ambient occlusion or random rays asks:
        // the per-lane loop with `f32::min` took 107 instructions per ray,
        // callgrind, bunny packet8 random rays). Like `f32::min`, these
        // folds skip a NaN.
        let first = self.active.trailing_zeros() as usize;
        let active = L::mask_from_bits(self.active);
        let (mut spread, mut scale) = (0.0f32, 0.0f32);
        for d in &self.dir {
            let d = L::select(active, *d, L::splat(d.lane(first)));
            let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
            for i in 0..L::WIDTH {
                let x = d.lane(i);
                lo = if x < lo { x } else { lo };
                hi = if x > hi { x } else { hi };
                scale = if x.abs() > scale { x.abs() } else { scale };
            }
            spread = if hi - lo > spread { hi - lo } else { spread };
        }
        if scale > 0.0 { spread / scale } else { 0.0 }
    }

    /// The ray in lane `i`, if active.
    ///
    /// # Panics
    /// If `i` is not a lane of the packet (`i >= WIDTH`).
    ///
    /// ```
    /// use packtrace::RayPacket4;
    /// assert!(RayPacket4::from_lanes([None; 4]).ray(3).is_none());
    /// ```
    #[must_use]
    pub fn ray(&self, i: usize) -> Option<Ray> {
        assert!(i < L::WIDTH, "lane {i} of a {}-wide packet", L::WIDTH);
        (self.active >> i & 1 == 1).then(|| Ray {
            origin: Vec3::new(
                self.org[0].lane(i),
                self.org[1].lane(i),
                self.org[2].lane(i),
            ),
            dir: Vec3::new(
                self.dir[0].lane(i),
                self.dir[1].lane(i),
                self.dir[2].lane(i),
            ),
            inv_dir: Vec3::new(
                self.inv_dir[0].lane(i),
                self.inv_dir[1].lane(i),
                self.inv_dir[2].lane(i),
            ),
            t_min: self.t_min.lane(i),
            t_max: self.t_max.lane(i),
        })
    }

    /// A packet from SoA lanes without checks, built in SIMD: lane `i` of
    /// `active` equals [`Ray::new_unchecked`] of that lane's values bit for
    /// bit (the same flush of tiny direction components, the same
    /// reciprocal); the other lanes are inactive. How a scene moves lanes
    /// into an instance's space together (`scene/mod.rs`).
    #[inline(always)]
    pub(crate) fn from_lanes_unchecked(
        org: [L; 3],
        dir: [L; 3],
        t_min: L,
        t_max: L,
        active: u32,
    ) -> RayPacket<L> {
        let active = active & ((1u32 << L::WIDTH) - 1);
        let on = L::mask_from_bits(active);
        let (zero, one) = (L::splat(0.0), L::splat(1.0));
        // `flush_tiny` (ray.rs): a subnormal component, or one below
        // `MIN_POSITIVE` of the largest, becomes a zero of its sign.
        // Written out, not with `array::map`, which LLVM leaves outlined
        // (baseline code) when this is inlined into a kernel.
        let a = [dir[0].abs(), dir[1].abs(), dir[2].abs()];
        let max = a[0].max_keep(a[1]).max_keep(a[2]);
        // An `#[inline(always)]` function rather than a closure: LLVM
        // outlined the closure, as baseline code, from the kernels (5 % of
        // an instance's primary packets, perf).
        #[inline(always)]
        fn flushed<L: Lane>(d: L, a: L, max: L, on: L::Mask) -> L {
            let (zero, one, tiny) = (L::splat(0.0), L::splat(1.0), L::splat(f32::MIN_POSITIVE));
            let flush = a.lt(tiny) | (a / max).lt(tiny);
            L::select(on, L::select(flush, d * zero, d), one)
        }
        let dir = [
            flushed(dir[0], a[0], max, on),
            flushed(dir[1], a[1], max, on),
            flushed(dir[2], a[2], max, on),
        ];
        RayPacket {
            org: [
                L::select(on, org[0], zero),
                L::select(on, org[1], zero),
                L::select(on, org[2], zero),
            ],
            inv_dir: [one / dir[0], one / dir[1], one / dir[2]],
            dir,
            t_min: L::select(on, t_min, L::splat(f32::INFINITY)),
            t_max: L::select(on, t_max, L::splat(f32::NEG_INFINITY)),
            active,
        }
    }

    /// A packet from lanes a kernel computed as
    /// [`RayPacket::from_lanes_unchecked`] does (`kdtree/kernel.rs`, the
    /// AVX form of an instance's packet): the caller keeps the invariants
    /// (inactive lanes: zero origin, unit direction, empty interval).
    #[inline(always)]
    pub(crate) fn from_parts_unchecked(
        org: [L; 3],
        dir: [L; 3],
        inv_dir: [L; 3],
        t_min: L,
        t_max: L,
        active: u32,
    ) -> RayPacket<L> {
        RayPacket {
            org,
            dir,
            inv_dir,
            t_min,
            t_max,
            active,
        }
    }

    /// Origins per axis (inactive lanes: zero).
    #[inline(always)]
    pub(crate) fn org(&self) -> &[L; 3] {
        &self.org
    }
    /// Directions per axis.
    #[inline(always)]
    pub(crate) fn dir(&self) -> &[L; 3] {
        &self.dir
    }
    /// Reciprocal directions per axis (inactive lanes: one).
    #[inline(always)]
    pub(crate) fn inv_dir(&self) -> &[L; 3] {
        &self.inv_dir
    }
    /// Lower bounds (inactive lanes: `+inf`).
    #[inline(always)]
    pub(crate) fn t_min(&self) -> L {
        self.t_min
    }
    /// Upper bounds (inactive lanes: `-inf`).
    #[inline(always)]
    pub(crate) fn t_max(&self) -> L {
        self.t_max
    }

    /// Per axis, the active lanes whose direction has its sign bit set.
    #[inline]
    pub(crate) fn neg_bits(&self) -> [u32; 3] {
        self.dir.map(|d| L::sign_bits(d) & self.active)
    }

    /// SoA slab test of all lanes against `b`: (hit mask, entry, exit),
    /// with the scalar test's policy lane by lane (`Aabb::intersect`).
    #[must_use]
    pub(crate) fn slab_lanes(&self, b: &Aabb) -> (u32, L, L) {
        let neg = self.dir.map(|d| L::mask_from_bits(L::sign_bits(d)));
        let (m, t0, t1) = slab(
            b,
            &self.org,
            &self.org,
            &self.inv_dir,
            &neg,
            self.t_min,
            self.t_max,
        );
        (L::bits(m) & self.active, t0, t1)
    }

    /// The triangle test's per-lane shear and axis permutation. Lane by
    /// lane the same IEEE operations as `triangle::shear` of that lane's ray.
    pub(crate) fn shear(&self) -> PacketShear<L> {
        // The dominant axis of all lanes at once, with `permutation`'s
        // tie rule (x before y before z) and its swap for `d[kz] < 0`
        // (a comparison, not the sign bit: `-0.0` does not swap).
        let [ax, ay, az] = self.dir.map(|d| d.abs());
        let x_dom = ay.le(ax) & az.le(ax);
        let y_dom = !x_dom & az.le(ay);
        let z_dom = !(x_dom | y_dom);
        let kz = [x_dom, y_dom, z_dom]
            .iter()
            .position(|&m| L::bits(m) & self.active == self.active);
        let swap = kz.map(|kz| L::bits(self.dir[kz].lt(L::splat(0.0))) & self.active);
        if let (Some(kz), Some(swap)) = (kz, swap)
            && self.active != 0
            && (swap == 0 || swap == self.active)
        {
            let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
            if swap != 0 {
                std::mem::swap(&mut kx, &mut ky);
            }
            let k = [kx, ky, kz];
            let (dx, dy, dz) = (self.dir[k[0]], self.dir[k[1]], self.dir[k[2]]);
            let sh = Shear {
                org: [self.org[k[0]], self.org[k[1]], self.org[k[2]]],
                s: [dx / dz, dy / dz, L::splat(1.0) / dz],
            };
            debug_assert!(
                (0..L::WIDTH)
                    .all(|i| self.active >> i & 1 == 0 || permutation(self.dir_of(i)) == k)
            );
            return PacketShear {
                shear: sh,
                perm: Permutation::Shared(k),
            };
        }
        self.shear_per_lane()
    }

    /// [`RayPacket::shear`] for lanes with different permutations (or no
    /// active lane): each lane's shear computed as the scalar path does.
    #[cold]
    fn shear_per_lane(&self) -> PacketShear<L> {
        let first = (self.active.trailing_zeros() as usize).min(L::WIDTH - 1);
        // Inactive lanes borrow the first active lane's permutation; their
        // intervals stay empty. A second check for a shared permutation
        // stood here: mutation run B showed only packets with no active
        // lane reach it, so it was removed.
        let mut ks = [[0usize; 3]; MAX_WIDTH];
        let mut org = [[0.0f32; MAX_WIDTH]; 3];
        let mut s = [[1.0f32; MAX_WIDTH]; 3];
        for i in 0..L::WIDTH {
            let lane = if self.active >> i & 1 == 1 { i } else { first };
            ks[i] = permutation(self.dir_of(lane));
            let o = Vec3::new(
                self.org[0].lane(i),
                self.org[1].lane(i),
                self.org[2].lane(i),
            );
            let (sh, kr) = shear(&Ray::new_unchecked(o, self.dir_of(i), 0.0, 0.0));
            debug_assert!(self.active >> i & 1 == 0 || kr == ks[i]);
            for a in 0..3 {
                org[a][i] = sh.org[a];
                s[a][i] = sh.s[a];
            }
        }
        PacketShear {
            shear: Shear {
                org: org.map(|o| L::from_fn(|i| o[i])),
                s: s.map(|v| L::from_fn(|i| v[i])),
            },
            perm: Permutation::PerLane(ks),
        }
    }

    fn dir_of(&self, i: usize) -> Vec3 {
        Vec3::new(
            self.dir[0].lane(i),
            self.dir[1].lane(i),
            self.dir[2].lane(i),
        )
    }
}

/// The lanes whose ray [`Ray::new`] accepts, as bits: origin and
/// direction finite, the direction not zero once tiny components are
/// flushed (its largest magnitude at least `f32::MIN_POSITIVE`, as
/// `flush_tiny` keeps the largest component unless it is subnormal), no
/// NaN bound. One pass without a branch per lane.
#[inline]
fn valid_lanes<const W: usize>(
    org: &[[f32; W]; 3],
    dir: &[[f32; W]; 3],
    t_min: &[f32; W],
    t_max: &[f32; W],
) -> u32 {
    // `|x| < inf` is false for NaN and infinities.
    let finite = |x: f32| x.abs() < f32::INFINITY;
    let mut ok = 0;
    for i in 0..W {
        let largest = dir[0][i].abs().max(dir[1][i].abs()).max(dir[2][i].abs());
        let good = finite(org[0][i])
            & finite(org[1][i])
            & finite(org[2][i])
            & finite(dir[0][i])
            & finite(dir[1][i])
            & finite(dir[2][i])
            & (largest >= f32::MIN_POSITIVE)
            & !t_min[i].is_nan()
            & !t_max[i].is_nan();
        ok |= u32::from(good) << i;
    }
    ok
}

/// The constructors that take one array entry per lane.
macro_rules! fixed_width {
    ($lane:ty, $w:literal, $name:literal) => {
        impl RayPacket<$lane> {
            #[doc = concat!("Packet of ", $name, " rays, all active.")]
            ///
            /// ```
            /// use glam::Vec3;
            /// use packtrace::{Ray, RayPacket4, RayPacket8};
            /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
            /// assert_eq!(RayPacket4::from_rays(&[r; 4]).active(), 0b1111);
            /// assert_eq!(RayPacket8::from_rays(&[r; 8]).active(), 0xFF);
            /// ```
            #[must_use]
            pub fn from_rays(rays: &[Ray; $w]) -> Self {
                Self::from_fn(|i| Some(rays[i]))
            }

            #[doc = concat!("Packet from up to ", $name, " rays; `None` lanes are inactive.")]
            ///
            /// ```
            /// use packtrace::{RayPacket4, RayPacket8};
            /// assert_eq!(RayPacket4::from_lanes([None; 4]).active(), 0);
            /// assert_eq!(RayPacket8::from_lanes([None; 8]).active(), 0);
            /// ```
            #[must_use]
            pub fn from_lanes(rays: [Option<Ray>; $w]) -> Self {
                Self::from_fn(|i| rays[i])
            }

            /// Packet from SoA arrays (e.g. a host engine's ray stream),
            /// checked lane by lane as [`Ray::new`] checks a ray; lanes not
            /// in `active` are made empty and not checked. Reciprocals are
            /// computed exactly.
            ///
            /// # Errors
            /// [`PacketError::ActiveMask`] if `active` has bits beyond the
            /// packet's lanes; [`PacketError::Lane`] naming the first
            /// active lane whose ray [`Ray::new`] refuses (zero or
            /// non-finite direction, non-finite origin, NaN bound), with
            /// the reason.
            ///
            /// ```
            /// use packtrace::packet::PacketError;
            /// use packtrace::{RayError, RayPacket4};
            /// let org = [[0.0; 4]; 3];
            /// let mut dir = [[1.0; 4], [0.0; 4], [0.0; 4]];
            /// let (t_min, t_max) = ([0.0; 4], [f32::INFINITY; 4]);
            /// let p = RayPacket4::from_soa(org, dir, t_min, t_max, 0b0011).unwrap();
            /// assert!(p.ray(2).is_none() && p.ray(1).is_some());
            /// dir[0][1] = 0.0; // lane 1's direction is now zero
            /// let e = RayPacket4::from_soa(org, dir, t_min, t_max, 0b0011).unwrap_err();
            /// assert_eq!(e, PacketError::Lane { lane: 1, error: RayError::ZeroDirection });
            /// assert_eq!(e.to_string(), "lane 1: ray direction is the zero vector");
            /// // An inactive lane is not checked.
            /// assert!(RayPacket4::from_soa(org, dir, t_min, t_max, 0b0001).is_ok());
            /// ```
            pub fn from_soa(
                org: [[f32; $w]; 3],
                dir: [[f32; $w]; 3],
                t_min: [f32; $w],
                t_max: [f32; $w],
                active: u32,
            ) -> Result<Self, PacketError> {
                if u64::from(active) >> $w != 0 {
                    return Err(PacketError::ActiveMask(active));
                }
                // Valid rays, the common case: one branch-free check, then
                // the SIMD build. Lane by lane through `Ray::new`, this
                // cost about a third of a primary packet's traversal.
                if active & !valid_lanes(&org, &dir, &t_min, &t_max) == 0 {
                    return Ok(Self::from_soa_unchecked(org, dir, t_min, t_max, active));
                }
                // A bad lane: `Ray::new` names the first and says why.
                let mut lanes = [None; $w];
                for (i, lane) in lanes.iter_mut().enumerate() {
                    if active >> i & 1 == 1 {
                        let o = Vec3::new(org[0][i], org[1][i], org[2][i]);
                        let d = Vec3::new(dir[0][i], dir[1][i], dir[2][i]);
                        let ray = Ray::new(o, d, t_min[i], t_max[i])
                            .map_err(|error| PacketError::Lane { lane: i, error })?;
                        *lane = Some(ray);
                    }
                }
                Ok(Self::from_lanes(lanes))
            }

            /// `from_soa` without checks, for hot loops over rays known to
            /// be valid: as [`Ray::new_unchecked`], an invalid lane never
            /// hits (the ray policy), and bits of `active` beyond the
            /// packet's lanes are ignored.
            ///
            /// ```
            /// use packtrace::RayPacket4;
            /// let p = RayPacket4::from_soa_unchecked(
            ///     [[0.0; 4]; 3],
            ///     [[1.0; 4], [0.0; 4], [0.0; 4]],
            ///     [0.0; 4],
            ///     [f32::INFINITY; 4],
            ///     0b0011,
            /// );
            /// assert!(p.ray(2).is_none() && p.ray(1).is_some());
            /// ```
            #[must_use]
            pub fn from_soa_unchecked(
                org: [[f32; $w]; 3],
                dir: [[f32; $w]; 3],
                t_min: [f32; $w],
                t_max: [f32; $w],
                active: u32,
            ) -> Self {
                // In SIMD, equal lane by lane to `Ray::new_unchecked`
                // (`from_lanes_unchecked`): built lane by lane, this was
                // most of the C API's 18 % extra instructions per packet8
                // primary ray (docs/c-api-design.md).
                let l = <$lane>::from;
                Self::from_lanes_unchecked(
                    [l(org[0]), l(org[1]), l(org[2])],
                    [l(dir[0]), l(dir[1]), l(dir[2])],
                    l(t_min),
                    l(t_max),
                    active,
                )
            }

            /// SoA slab test of all lanes against `b`: (hit mask, entry,
            /// exit), with the scalar test's policy lane by lane
            /// (`Aabb::intersect`).
            ///
            /// ```
            /// use glam::{Vec3, Vec3A};
            /// use packtrace::{Aabb, Ray, RayPacket4};
            /// let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
            /// let hit = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X, 0.0, 9.0).unwrap();
            /// let miss = Ray::new(Vec3::new(-1.0, 5.0, 0.5), Vec3::X, 0.0, 9.0).unwrap();
            /// let p = RayPacket4::from_lanes([Some(hit), Some(miss), None, Some(hit)]);
            /// let (mask, t0, _t1) = p.slab(&b);
            /// assert_eq!(mask, 0b1001);
            /// assert_eq!(t0[0], 1.0);
            /// ```
            #[must_use]
            pub fn slab(&self, b: &Aabb) -> (u32, [f32; $w], [f32; $w]) {
                let (m, t0, t1) = self.slab_lanes(b);
                (m, t0.to_array(), t1.to_array())
            }
        }
    };
}

fixed_width!(F4, 4, "four");
fixed_width!(F8, 8, "eight");

/// The axis order `[kx, ky, kz]` in which a packet's lanes see triangle
/// corners (`kz` the dominant direction axis; Woop et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Permutation {
    /// One order for every active lane, as coherent rays nearly always
    /// have: a corner is three broadcasts.
    Shared([usize; 3]),
    /// An order per lane (mixed dominant axes): a corner is gathered lane
    /// by lane.
    PerLane([[usize; 3]; MAX_WIDTH]),
}

/// The per-packet part of the triangle test: the lanes' shear and the
/// axis order of their corners.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PacketShear<L> {
    /// Per-lane shear constants and permuted origins.
    pub shear: Shear<L>,
    /// How each lane orders a corner's axes.
    pub perm: Permutation,
}

impl<L: Lane> PacketShear<L> {
    /// A triangle corner in each lane's axis order.
    #[inline(always)]
    pub(crate) fn corner(&self, v: &Vec3) -> [L; 3] {
        // Index the coordinates as an array: glam's `Index` is a `match`.
        let v: &[f32; 3] = v.as_ref();
        match self.perm {
            Permutation::Shared(k) => k.map(|a| L::splat(v[a])),
            Permutation::PerLane(ks) => [0, 1, 2].map(|j| L::from_fn(|i| v[ks[i][j]])),
        }
    }
}

/// Results of a packet query, one per lane.
///
/// ```
/// let h = packtrace::HitPacket4::default();
/// assert_eq!(h.hit(0), None);
/// assert_eq!(packtrace::HitPacket8::default().mask(), 0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitPacket<L: Lane> {
    /// Hit distances (`+inf`: no hit).
    t: L,
    /// Triangle indices (`u32::MAX`: no hit).
    prim: L::Index,
    /// Barycentric weights of the second vertex.
    u: L,
    /// Barycentric weights of the third vertex.
    v: L,
}

/// The result of a [`RayPacket4`] query.
pub type HitPacket4 = HitPacket<F4>;
/// The result of a [`RayPacket8`] query.
pub type HitPacket8 = HitPacket<F8>;

impl<L: Lane> Default for HitPacket<L> {
    fn default() -> Self {
        HitPacket {
            t: L::splat(f32::INFINITY),
            prim: L::index_splat(NO_PRIM),
            u: L::splat(0.0),
            v: L::splat(0.0),
        }
    }
}

impl<L: Lane> HitPacket<L> {
    /// The hit of lane `i`, if any.
    ///
    /// # Panics
    /// If `i` is not a lane of the packet.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{KdBuildParams, KdTree, Mesh, Ray, RayPacket8};
    /// let m = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let t = KdTree::build(m, &KdBuildParams::default()).unwrap();
    /// let r = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 9.0).unwrap();
    /// let h = t.intersect8(&RayPacket8::from_slice(&[r; 3]));
    /// assert_eq!(h.hit(2), t.intersect(&r));
    /// assert_eq!(h.hit(3), None);
    /// ```
    #[must_use]
    pub fn hit(&self, i: usize) -> Option<Hit> {
        assert!(i < L::WIDTH, "lane {i} of a {}-wide packet", L::WIDTH);
        let prim = L::index_lane(self.prim, i);
        (prim != NO_PRIM).then(|| Hit {
            t: self.t.lane(i),
            prim,
            u: self.u.lane(i),
            v: self.v.lane(i),
        })
    }

    /// Bit `i` set when lane `i` has a hit.
    ///
    /// ```
    /// assert_eq!(packtrace::HitPacket4::default().mask(), 0);
    /// ```
    #[must_use]
    pub fn mask(&self) -> u32 {
        // `prim < NO_PRIM` (`u32::MAX`) is `prim != NO_PRIM`, as one
        // vector compare and move-mask; the lane-by-lane fold it replaced
        // was scalar code (46 instructions per 8-wide scene query).
        L::bits(L::index_lt(self.prim, L::index_splat(NO_PRIM)))
    }

    /// Lane `i` set to `h` (unchanged for `None`).
    pub(crate) fn set(&mut self, i: usize, h: Option<Hit>) {
        if let Some(h) = h {
            self.t = self.t.with_lane(i, h.t);
            self.prim = L::index_with_lane(self.prim, i, h.prim);
            self.u = self.u.with_lane(i, h.u);
            self.v = self.v.with_lane(i, h.v);
        }
    }

    /// The packet of results from the traversal's per-lane registers.
    /// The lanes' `t` (`+inf` where there is no hit).
    #[inline(always)]
    pub(crate) fn t_lanes(&self) -> L {
        self.t
    }

    #[inline(always)]
    pub(crate) fn from_lanes(t: L, prim: L::Index, u: L, v: L) -> Self {
        HitPacket { t, prim, u, v }
    }

    /// Lanes of `mask` taken from `o`, the others kept.
    #[inline(always)]
    pub(crate) fn merge(&mut self, o: &HitPacket<L>, mask: u32) {
        let m = L::mask_from_bits(mask);
        self.t = L::select(m, o.t, self.t);
        self.prim = L::index_select(m, o.prim, self.prim);
        self.u = L::select(m, o.u, self.u);
        self.v = L::select(m, o.v, self.v);
    }
}

#[cfg(test)]
mod tests {
    /// The SIMD constructor equals `Ray::new_unchecked` lane by lane,
    /// tiny, zero, signed-zero, NaN and infinite components included.
    #[test]
    fn lanes_unchecked_equal_rays_unchecked_bit_for_bit() {
        use crate::simd::F8;
        let vals = [
            1.0f32,
            -2.0,
            0.0,
            -0.0,
            1e-39,
            -1e-39,
            3e-30,
            1e30,
            f32::NAN,
            f32::INFINITY,
            -1e-38,
            7.5,
            1e-45,
            -0.5,
        ];
        for s in 0..vals.len() {
            let v = |k: usize, i: usize| vals[(s + 3 * k + 5 * i) % vals.len()];
            let org = [0, 1, 2].map(|k| F8::from_fn(|i| v(k + 7, i)));
            let dir = [0, 1, 2].map(|k| F8::from_fn(|i| v(k, i)));
            let t_min = F8::from_fn(|i| i as f32 * 0.1);
            let t_max = F8::from_fn(|i| 10.0 - i as f32);
            let active = 0b1011_0111 ^ s as u32;
            let p = RayPacket::from_lanes_unchecked(org, dir, t_min, t_max, active);
            let q = RayPacket::<F8>::from_fn(|i| {
                (active >> i & 1 == 1).then(|| {
                    Ray::new_unchecked(
                        Vec3::new(org[0].lane(i), org[1].lane(i), org[2].lane(i)),
                        Vec3::new(dir[0].lane(i), dir[1].lane(i), dir[2].lane(i)),
                        t_min.lane(i),
                        t_max.lane(i),
                    )
                })
            });
            assert_eq!(p.active, q.active);
            let bits = |p: &RayPacket<F8>| {
                let mut v = Vec::new();
                for k in 0..3 {
                    for i in 0..8 {
                        v.push((p.org[k].lane(i).to_bits(), p.dir[k].lane(i).to_bits()));
                        v.push((p.inv_dir[k].lane(i).to_bits(), 0));
                    }
                }
                for i in 0..8 {
                    v.push((p.t_min.lane(i).to_bits(), p.t_max.lane(i).to_bits()));
                }
                v
            };
            let (a, b) = (bits(&p), bits(&q));
            for (x, y) in a.iter().zip(&b) {
                // NaN payloads may differ; NaN-ness may not.
                let nan = |b: u32| f32::from_bits(b).is_nan();
                assert!(x == y || (nan(x.0) && nan(y.0)), "case {s}: {x:?} vs {y:?}");
            }
        }
    }

    use super::*;
    use glam::Vec3A;

    /// The spread is 0 for parallel lanes, small for a pixel block, about
    /// 2 for opposite lanes, and ignores inactive lanes.
    #[test]
    fn direction_spread_measures_the_active_lanes() {
        let ray = |d: Vec3| Ray::new(Vec3::ZERO, d, 0.0, 1.0).unwrap();
        let parallel = RayPacket8::from_rays(&[ray(Vec3::new(0.3, -0.2, 1.0)); 8]);
        assert_eq!(parallel.dir_spread(), 0.0);
        let block: [Ray; 8] = std::array::from_fn(|i| {
            ray(Vec3::new(
                0.001 * (i % 4) as f32,
                0.001 * (i / 4) as f32,
                -1.0,
            ))
        });
        let s = RayPacket8::from_rays(&block).dir_spread();
        assert!(s > 0.0 && s < 0.01, "{s}");
        let opposite =
            RayPacket4::from_rays(&[ray(Vec3::X), ray(Vec3::NEG_X), ray(Vec3::X), ray(Vec3::X)]);
        assert_eq!(opposite.dir_spread(), 2.0);
        assert_eq!(opposite.with_active(0b1101).dir_spread(), 0.0);
        assert_eq!(opposite.with_active(0).dir_spread(), 0.0);
    }

    /// The branch-free spread equals the plain loop over the active lanes
    /// with `f32::min`/`max`, bit for bit, on random packets (inactive
    /// lanes holding anything, NaN among them).
    #[test]
    fn direction_spread_equals_the_loop_over_active_lanes() {
        fn plain<L: Lane>(p: &RayPacket<L>) -> f32 {
            let (mut spread, mut scale) = (0.0f32, 0.0f32);
            for d in p.dir() {
                let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
                for i in (0..L::WIDTH).filter(|i| p.active() >> i & 1 == 1) {
                    let x = d.lane(i);
                    lo = lo.min(x);
                    hi = hi.max(x);
                    scale = scale.max(x.abs());
                }
                spread = spread.max(hi - lo);
            }
            if scale > 0.0 { spread / scale } else { 0.0 }
        }
        let mut s = 0x9e37_79b9_u32;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s
        };
        for k in 0..2_000 {
            let mut dir = [[0.0f32; 8]; 3];
            for a in &mut dir {
                for x in a.iter_mut() {
                    let r = next();
                    // Mostly ordinary components, some zeros and tiny ones.
                    *x = match r % 16 {
                        0 => 0.0,
                        1 => -0.0,
                        2 => 1e-30,
                        _ => (r >> 8) as f32 / (1 << 23) as f32 * 2.0 - 1.0,
                    };
                }
            }
            let active = next() & 0xFF;
            let rays: [Option<Ray>; 8] = std::array::from_fn(|i| {
                let d = Vec3::new(dir[0][i], dir[1][i], dir[2][i]);
                (active >> i & 1 == 1)
                    .then(|| Ray::new(Vec3::ZERO, d, 0.0, 1.0).ok())
                    .flatten()
            });
            let p8 = RayPacket8::from_lanes(rays);
            assert_eq!(p8.dir_spread().to_bits(), plain(&p8).to_bits(), "case {k}");
            let p4 = RayPacket4::from_lanes([rays[0], rays[1], rays[2], rays[3]]);
            assert_eq!(p4.dir_spread().to_bits(), plain(&p4).to_bits(), "case {k}");
        }
    }

    /// The checked SoA constructor refuses exactly what `Ray::new`
    /// refuses, naming the first bad active lane and the reason; inactive
    /// lanes are not checked; the unchecked one builds the same packet from
    /// valid arrays and keeps a bad lane (which then never hits).
    #[test]
    fn from_soa_names_the_first_bad_lane() {
        let nan = f32::NAN;
        let bad: [(Vec3, Vec3, f32, f32); 5] = [
            (Vec3::ZERO, Vec3::ZERO, 0.0, 1.0),
            (Vec3::ZERO, Vec3::new(1e-40, 0.0, -1e-39), 0.0, 1.0),
            (Vec3::new(nan, 0.0, 0.0), Vec3::X, 0.0, 1.0),
            (Vec3::ZERO, Vec3::new(0.0, f32::INFINITY, 1.0), 0.0, 1.0),
            (Vec3::ZERO, Vec3::X, 0.0, nan),
        ];
        let good = (
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(0.5, -1.0, 0.25),
            0.0,
            10.0,
        );
        for (o, d, t0, t1) in bad {
            let want = Ray::new(o, d, t0, t1).unwrap_err();
            for lane in 0..4 {
                // Lane `lane` bad, the others good; a second bad lane after
                // it is not the one named.
                let ray_at = |i: usize| {
                    if i == lane || i == 3 {
                        (o, d, t0, t1)
                    } else {
                        good
                    }
                };
                let org = [0, 1, 2].map(|a| std::array::from_fn(|i| ray_at(i).0[a]));
                let dir = [0, 1, 2].map(|a| std::array::from_fn(|i| ray_at(i).1[a]));
                let t_min = std::array::from_fn(|i| ray_at(i).2);
                let t_max = std::array::from_fn(|i| ray_at(i).3);
                let e = RayPacket4::from_soa(org, dir, t_min, t_max, 0b1111).unwrap_err();
                // (Debug: a NaN field is unequal to itself.)
                let want_e = PacketError::Lane { lane, error: want };
                assert_eq!(format!("{e:?}"), format!("{want_e:?}"));
                assert_eq!(e.to_string(), format!("lane {lane}: {want}"));
                // Bad lanes switched off: accepted, and equal to unchecked.
                let active = 0b1111 & !(1 << lane) & !(1 << 3);
                let p = RayPacket4::from_soa(org, dir, t_min, t_max, active).unwrap();
                let q = RayPacket4::from_soa_unchecked(org, dir, t_min, t_max, active);
                for i in 0..4 {
                    assert_eq!(p.ray(i), q.ray(i));
                    assert_eq!(p.ray(i).is_some(), active >> i & 1 == 1);
                }
                // Unchecked keeps the bad lane active.
                let q = RayPacket4::from_soa_unchecked(org, dir, t_min, t_max, 0b1111);
                assert_eq!(q.active, 0b1111);
            }
        }
        let (o, d) = ([[0.0; 4]; 3], [[1.0; 4], [0.0; 4], [0.0; 4]]);
        assert_eq!(
            RayPacket4::from_soa(o, d, [0.0; 4], [1.0; 4], 0b10001).unwrap_err(),
            PacketError::ActiveMask(0b10001)
        );
        assert!(RayPacket4::from_soa(o, d, [0.0; 4], [1.0; 4], 0b1111).is_ok());
    }

    /// `valid_lanes` accepts exactly the rays `Ray::new` accepts, on every
    /// awkward value in every field; `from_soa` of the accepted lanes
    /// equals the lane-by-lane build bit for bit.
    #[test]
    fn the_lane_check_equals_ray_new() {
        let vals = [
            0.0f32,
            -0.0,
            1e-40,
            -f32::MIN_POSITIVE,
            f32::MIN_POSITIVE.next_down(),
            1.0,
            -3.5,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let bits = |r: Option<Ray>| {
            r.map(|r| {
                [r.origin(), r.dir(), r.inv_dir()]
                    .map(|v| v.to_array().map(f32::to_bits))
                    .concat()
                    .into_iter()
                    .chain([r.t_min().to_bits(), r.t_max().to_bits()])
                    .collect::<Vec<_>>()
            })
        };
        for (k, &a) in vals.iter().enumerate() {
            for &b in &vals {
                for &c in &vals {
                    let mut org = [[0.5f32; 8]; 3];
                    let mut dir = [[0.0f32; 8]; 3];
                    let (mut t_min, mut t_max) = ([0.0f32; 8], [1.0f32; 8]);
                    dir[0][0] = a;
                    dir[1][0] = b;
                    dir[2][0] = c;
                    org[k % 3][1] = a;
                    dir[2][1] = 1.0;
                    t_min[2] = b;
                    t_max[2] = c;
                    dir[0][2] = 1.0;
                    let got = valid_lanes(&org, &dir, &t_min, &t_max);
                    let mut rays = [None; 8];
                    for (l, ray) in rays.iter_mut().enumerate().take(3) {
                        let v = |x: &[[f32; 8]; 3]| Vec3::new(x[0][l], x[1][l], x[2][l]);
                        *ray = Ray::new(v(&org), v(&dir), t_min[l], t_max[l]).ok();
                        assert_eq!(got >> l & 1 == 1, ray.is_some(), "lane {l}: {a} {b} {c}");
                    }
                    let ok = got & 0b111;
                    let p = RayPacket8::from_soa(org, dir, t_min, t_max, ok).unwrap();
                    let q = RayPacket8::from_lanes(rays);
                    for l in 0..8 {
                        assert_eq!(bits(p.ray(l)), bits(q.ray(l)), "lane {l}: {a} {b} {c}");
                    }
                }
            }
        }
    }

    /// The SoA slab equals the scalar slab lane by lane, bit for bit,
    /// including NaN and infinite inputs.
    #[test]
    fn soa_slab_equals_scalar_slab() {
        let b = Aabb::new(Vec3A::new(-1.0, 0.0, 2.0), Vec3A::new(1.0, 3.0, 4.0));
        let vals = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            3.0,
            2.5,
            f32::INFINITY,
            f32::NAN,
            1e-30,
            -7.0,
        ];
        let mut rays = Vec::new();
        let mut s = 1u32;
        let mut next = || {
            s = s.wrapping_mul(1664525).wrapping_add(1013904223);
            vals[(s >> 16) as usize % vals.len()]
        };
        for _ in 0..4000 {
            let o = Vec3::new(next(), next(), next());
            let d = Vec3::new(next(), next(), next());
            rays.push(Ray::new_unchecked(o, d, 0.0, f32::INFINITY));
        }
        for c in rays.chunks_exact(4) {
            let p = RayPacket4::from_rays(&[c[0], c[1], c[2], c[3]]);
            let (m, t0, t1) = p.slab(&b);
            for i in 0..4 {
                let s = b.intersect(&c[i]);
                assert_eq!(m >> i & 1 == 1, s.is_some(), "{:?}", c[i]);
                if let Some((a, z)) = s {
                    assert_eq!(
                        (a.to_bits(), z.to_bits()),
                        (t0[i].to_bits(), t1[i].to_bits())
                    );
                }
            }
        }
    }

    #[test]
    fn inactive_lanes_have_empty_intervals() {
        let p = RayPacket4::from_lanes([None; 4]);
        let b = Aabb::new(Vec3A::splat(-1e30), Vec3A::splat(1e30));
        assert_eq!(p.slab(&b).0, 0);
    }
}
