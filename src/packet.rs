//! 4-wide ray packets in structure-of-arrays form (Wald et al. 2001), the
//! packet result, and the SoA slab test.

use crate::aabb::{Aabb, slab};
use crate::ray::{Hit, NO_PRIM, Ray, RayError};
use crate::simd::{F4, Lane};
use crate::triangle::{Shear, permutation, shear};
use glam::Vec3;
use std::fmt;

/// Four rays, one per lane, in SoA form. Lanes not in `active` carry the
/// empty interval `t_min = +inf, t_max = -inf`, so they can never hit.
///
/// ```
/// use glam::Vec3;
/// use packtrace::{Ray, RayPacket4};
/// let r = Ray::new(Vec3::ZERO, Vec3::Z, 0.0, 1.0).unwrap();
/// let p = RayPacket4::from_lanes([Some(r), None, Some(r), None]);
/// assert_eq!(p.active, 0b0101);
/// assert_eq!(p.ray(0), Some(r));
/// assert_eq!(p.ray(1), None);
/// ```
#[derive(Clone, Copy, Debug)]
pub struct RayPacket4 {
    /// Origins, per axis.
    pub org: [F4; 3],
    /// Directions, per axis.
    pub dir: [F4; 3],
    /// Exact reciprocal directions, per axis (`1.0 / dir`, never `rcpps`).
    pub inv_dir: [F4; 3],
    /// Exclusive lower bounds.
    pub t_min: F4,
    /// Inclusive upper bounds.
    pub t_max: F4,
    /// Bit `i` set when lane `i` holds a ray.
    pub active: u32,
}

/// Why [`RayPacket4::from_soa`] refused its arrays.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PacketError {
    /// The active mask has bits above lane 3 (the value given).
    ActiveMask(u32),
    /// An active lane holds a ray that [`Ray::new`] refuses.
    Lane {
        /// The first such lane (0 to 3).
        lane: usize,
        /// Why its ray was refused.
        error: RayError,
    },
}

impl fmt::Display for PacketError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PacketError::ActiveMask(m) => {
                write!(
                    f,
                    "active mask {m:#b} has bits above lane 3 of a 4-wide packet"
                )
            }
            PacketError::Lane { lane, error } => write!(f, "lane {lane}: {error}"),
        }
    }
}

/// A leaf error: the lane's reason is part of the message, so there is no
/// `source()`.
impl std::error::Error for PacketError {}

impl RayPacket4 {
    /// Packet of four rays, all active.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(RayPacket4::from_rays(&[r; 4]).active, 0b1111);
    /// ```
    #[must_use]
    pub fn from_rays(rays: &[Ray; 4]) -> RayPacket4 {
        RayPacket4::from_lanes(rays.map(Some))
    }

    /// Packet of the first four rays of `rays` (fewer: the missing lanes
    /// are inactive): how streams are cut into packets.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Ray, RayPacket4};
    /// let r = Ray::new(Vec3::ZERO, Vec3::X, 0.0, 1.0).unwrap();
    /// assert_eq!(RayPacket4::from_slice(&[r, r, r]).active, 0b0111);
    /// assert_eq!(RayPacket4::from_slice(&[r; 6]).active, 0b1111);
    /// ```
    #[must_use]
    pub fn from_slice(rays: &[Ray]) -> RayPacket4 {
        RayPacket4::from_lanes(std::array::from_fn(|i| rays.get(i).copied()))
    }

    /// Packet from up to four rays; `None` lanes are inactive.
    ///
    /// ```
    /// use packtrace::RayPacket4;
    /// assert_eq!(RayPacket4::from_lanes([None; 4]).active, 0);
    /// ```
    #[must_use]
    pub fn from_lanes(rays: [Option<Ray>; 4]) -> RayPacket4 {
        let lane = |f: &dyn Fn(&Ray) -> f32, empty: f32| {
            F4::from(rays.map(|r| r.as_ref().map_or(empty, f)))
        };
        let mut active = 0;
        for (i, r) in rays.iter().enumerate() {
            active |= (r.is_some() as u32) << i;
        }
        RayPacket4 {
            org: [0, 1, 2].map(|a| lane(&|r: &Ray| r.origin[a], 0.0)),
            dir: [0, 1, 2].map(|a| lane(&|r: &Ray| r.dir[a], 1.0)),
            inv_dir: [0, 1, 2].map(|a| lane(&|r: &Ray| r.inv_dir[a], 1.0)),
            t_min: lane(&|r: &Ray| r.t_min, f32::INFINITY),
            t_max: lane(&|r: &Ray| r.t_max, f32::NEG_INFINITY),
            active,
        }
    }

    /// Packet from SoA arrays (e.g. a host engine's ray stream), checked
    /// lane by lane as [`Ray::new`] checks a ray; lanes not in `active`
    /// are made empty and not checked. Reciprocals are computed exactly.
    ///
    /// # Errors
    /// [`PacketError::ActiveMask`] if `active` has bits above lane 3;
    /// [`PacketError::Lane`] naming the first active lane whose ray
    /// [`Ray::new`] refuses (zero or non-finite direction, non-finite
    /// origin, NaN bound), with the reason.
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
        org: [[f32; 4]; 3],
        dir: [[f32; 4]; 3],
        t_min: [f32; 4],
        t_max: [f32; 4],
        active: u32,
    ) -> Result<RayPacket4, PacketError> {
        if active > 0b1111 {
            return Err(PacketError::ActiveMask(active));
        }
        let mut lanes = [None; 4];
        for (i, lane) in lanes.iter_mut().enumerate() {
            if active >> i & 1 == 1 {
                let o = Vec3::new(org[0][i], org[1][i], org[2][i]);
                let d = Vec3::new(dir[0][i], dir[1][i], dir[2][i]);
                let ray = Ray::new(o, d, t_min[i], t_max[i])
                    .map_err(|error| PacketError::Lane { lane: i, error })?;
                *lane = Some(ray);
            }
        }
        Ok(RayPacket4::from_lanes(lanes))
    }

    /// [`RayPacket4::from_soa`] without checks, for hot loops over rays
    /// known to be valid: as [`Ray::new_unchecked`], an invalid lane never
    /// hits (the ray policy), and bits of `active` above lane 3 are
    /// ignored.
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
        org: [[f32; 4]; 3],
        dir: [[f32; 4]; 3],
        t_min: [f32; 4],
        t_max: [f32; 4],
        active: u32,
    ) -> RayPacket4 {
        let lanes: [Option<Ray>; 4] = std::array::from_fn(|i| {
            (active >> i & 1 == 1).then(|| {
                Ray::new_unchecked(
                    Vec3::new(org[0][i], org[1][i], org[2][i]),
                    Vec3::new(dir[0][i], dir[1][i], dir[2][i]),
                    t_min[i],
                    t_max[i],
                )
            })
        });
        RayPacket4::from_lanes(lanes)
    }

    /// The ray in lane `i`, if active.
    ///
    /// # Panics
    /// If `i >= 4`.
    ///
    /// ```
    /// use packtrace::RayPacket4;
    /// assert!(RayPacket4::from_lanes([None; 4]).ray(3).is_none());
    /// ```
    #[must_use]
    pub fn ray(&self, i: usize) -> Option<Ray> {
        assert!(i < 4, "lane {i} of a 4-wide packet");
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

    /// Per axis, the active lanes whose direction has its sign bit set.
    #[inline]
    pub(crate) fn neg_bits(&self) -> [u32; 3] {
        self.dir.map(|d| d.to_bitmask() & self.active)
    }

    /// SoA slab test of all lanes against `b`: (hit mask, entry, exit), with
    /// the scalar test's policy lane by lane (`Aabb::intersect`).
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
    pub fn slab(&self, b: &Aabb) -> (u32, [f32; 4], [f32; 4]) {
        let neg = self.dir.map(|d| F4::mask_from_bits(d.to_bitmask()));
        let (m, t0, t1) = slab(
            b,
            &self.org,
            &self.org,
            &self.inv_dir,
            &neg,
            self.t_min,
            self.t_max,
        );
        (m.to_bitmask() & self.active, t0.to_array(), t1.to_array())
    }

    /// The triangle test's per-lane shear and axis permutation. Lane by
    /// lane the same IEEE operations as `triangle::shear` of that lane's ray.
    pub(crate) fn shear(&self) -> PacketShear {
        // The dominant axis of all lanes at once, with `permutation`'s
        // tie rule (x before y before z) and its swap for `d[kz] < 0`
        // (a comparison, not the sign bit: `-0.0` does not swap).
        let [ax, ay, az] = self.dir.map(|d| d.abs());
        let x_dom = ax.simd_ge(ay) & ax.simd_ge(az);
        let y_dom = !x_dom & ay.simd_ge(az);
        let z_dom = !(x_dom | y_dom);
        let kz = [x_dom, y_dom, z_dom]
            .iter()
            .position(|m| m.to_bitmask() & self.active == self.active);
        let swap = kz.map(|kz| self.dir[kz].simd_lt(F4::splat(0.0)).to_bitmask() & self.active);
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
                s: [dx / dz, dy / dz, F4::splat(1.0) / dz],
            };
            debug_assert!((0..4).all(|i| self.active >> i & 1 == 0
                || permutation(Vec3::new(
                    self.dir[0].lane(i),
                    self.dir[1].lane(i),
                    self.dir[2].lane(i)
                )) == k));
            return PacketShear {
                shear: sh,
                perm: Permutation::Shared(k),
            };
        }
        let first = (self.active.trailing_zeros() as usize).min(3);
        let dir_of = |i: usize| {
            Vec3::new(
                self.dir[0].lane(i),
                self.dir[1].lane(i),
                self.dir[2].lane(i),
            )
        };
        // Inactive lanes borrow the first active lane's permutation, so they
        // do not break a shared one; their intervals stay empty.
        let ks: [[usize; 3]; 4] = std::array::from_fn(|i| {
            permutation(dir_of(if self.active >> i & 1 == 1 { i } else { first }))
        });
        // Here the active lanes' permutations differ (the test above takes
        // every packet whose active lanes share one, with the same rule as
        // `permutation`), or no lane is active. A second check for a
        // shared permutation stood here: mutation run B showed only
        // packets with no active lane reach it, so it was removed.
        let mut org = [[0.0f32; 4]; 3];
        let mut s = [[1.0f32; 4]; 3];
        for (i, k) in ks.iter().enumerate() {
            let r = Ray::new_unchecked(
                Vec3::new(
                    self.org[0].lane(i),
                    self.org[1].lane(i),
                    self.org[2].lane(i),
                ),
                dir_of(i),
                0.0,
                0.0,
            );
            let (sh, kr) = shear(&r);
            debug_assert!(self.active >> i & 1 == 0 || kr == *k);
            for a in 0..3 {
                org[a][i] = sh.org[a];
                s[a][i] = sh.s[a];
            }
        }
        PacketShear {
            shear: Shear {
                org: org.map(F4::from),
                s: s.map(F4::from),
            },
            perm: Permutation::PerLane(ks),
        }
    }
}

/// The axis order `[kx, ky, kz]` in which a packet's lanes see triangle
/// corners (`kz` the dominant direction axis; Woop et al. 2013).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Permutation {
    /// One order for every active lane, as coherent rays nearly always
    /// have: a corner is three broadcasts.
    Shared([usize; 3]),
    /// An order per lane (mixed dominant axes): a corner is gathered lane
    /// by lane.
    PerLane([[usize; 3]; 4]),
}

/// The per-packet part of the triangle test: the lanes' shear and the
/// axis order of their corners.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PacketShear {
    /// Per-lane shear constants and permuted origins.
    pub shear: Shear<F4>,
    /// How each lane orders a corner's axes.
    pub perm: Permutation,
}

impl PacketShear {
    /// A triangle corner in each lane's axis order.
    #[inline(always)]
    pub(crate) fn corner(&self, v: &Vec3) -> [F4; 3] {
        // Index the coordinates as an array: glam's `Index` is a `match`.
        let v: &[f32; 3] = v.as_ref();
        match self.perm {
            Permutation::Shared(k) => k.map(|a| F4::splat(v[a])),
            Permutation::PerLane(ks) => {
                [0, 1, 2].map(|j| F4::from([v[ks[0][j]], v[ks[1][j]], v[ks[2][j]], v[ks[3][j]]]))
            }
        }
    }
}

/// Results of a 4-wide query, one per lane; `prim == u32::MAX` is a miss.
///
/// ```
/// let h = packtrace::HitPacket4::default();
/// assert_eq!(h.hit(0), None);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HitPacket4 {
    /// Hit distances.
    pub t: [f32; 4],
    /// Triangle indices (`u32::MAX`: no hit).
    pub prim: [u32; 4],
    /// Barycentric weights of the second vertex.
    pub u: [f32; 4],
    /// Barycentric weights of the third vertex.
    pub v: [f32; 4],
}

impl Default for HitPacket4 {
    fn default() -> HitPacket4 {
        HitPacket4 {
            t: [f32::INFINITY; 4],
            prim: [NO_PRIM; 4],
            u: [0.0; 4],
            v: [0.0; 4],
        }
    }
}

impl HitPacket4 {
    /// The hit of lane `i`, if any.
    ///
    /// # Panics
    /// If `i >= 4`.
    ///
    /// ```
    /// let mut h = packtrace::HitPacket4::default();
    /// h.prim[2] = 7;
    /// h.t[2] = 1.5;
    /// assert_eq!(h.hit(2).unwrap().prim, 7);
    /// ```
    #[must_use]
    pub fn hit(&self, i: usize) -> Option<Hit> {
        (self.prim[i] != NO_PRIM).then_some(Hit {
            t: self.t[i],
            prim: self.prim[i],
            u: self.u[i],
            v: self.v[i],
        })
    }

    /// Bit `i` set when lane `i` has a hit.
    ///
    /// ```
    /// assert_eq!(packtrace::HitPacket4::default().mask(), 0);
    /// ```
    #[must_use]
    pub fn mask(&self) -> u32 {
        (0..4).fold(0, |m, i| m | ((self.prim[i] != NO_PRIM) as u32) << i)
    }

    pub(crate) fn set(&mut self, i: usize, h: Option<Hit>) {
        if let Some(h) = h {
            self.t[i] = h.t;
            self.prim[i] = h.prim;
            self.u[i] = h.u;
            self.v[i] = h.v;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

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
