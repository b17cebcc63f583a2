//! The host's ray structs turned into the library's rays and packets
//! (checked by the ray policy), and answers written back the way Embree
//! writes them: `tfar` the hit's `t` and the hit record, or `tfar = -inf`
//! for an occluded ray.

use crate::status::Error;
use crate::types::{
    PACKTRACE_INVALID_ID, PacktraceHit, PacktraceHit4, PacktraceHit8, PacktraceRay, PacktraceRay4,
    PacktraceRay8,
};
use packtrace::glam::Vec3;
use packtrace::{Ray, RayPacket4, RayPacket8};

/// One ray's answer as the host sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Found {
    pub(crate) t: f32,
    pub(crate) u: f32,
    pub(crate) v: f32,
    pub(crate) prim: u32,
    pub(crate) geom: u32,
    pub(crate) inst: u32,
    /// The unit geometric normal (world space for a scene).
    pub(crate) ng: Vec3,
}

/// The ray of a host struct, checked.
///
/// # Errors
/// `PACKTRACE_STATUS_INVALID_RAY` with the ray policy's reason.
pub(crate) fn ray(r: &PacktraceRay) -> Result<Ray, Error> {
    Ok(Ray::new(
        Vec3::new(r.org_x, r.org_y, r.org_z),
        Vec3::new(r.dir_x, r.dir_y, r.dir_z),
        r.tnear,
        r.tfar,
    )?)
}

/// The stream's `i`th ray, checked; the message names it.
pub(crate) fn stream_ray(r: &PacktraceRay, i: usize) -> Result<Ray, Error> {
    ray(r).map_err(|e| Error::new(e.status, format!("ray {i}: {}", e.message)))
}

/// Writes an intersect query's answer into the host's ray and hit.
#[inline]
pub(crate) fn write_hit(ray: &mut PacktraceRay, hit: &mut PacktraceHit, f: Option<Found>) {
    match f {
        Some(f) => {
            ray.tfar = f.t;
            *hit = PacktraceHit {
                ng_x: f.ng.x,
                ng_y: f.ng.y,
                ng_z: f.ng.z,
                u: f.u,
                v: f.v,
                prim_id: f.prim,
                geom_id: f.geom,
                inst_id: f.inst,
            };
        }
        None => {
            hit.prim_id = PACKTRACE_INVALID_ID;
            hit.geom_id = PACKTRACE_INVALID_ID;
            hit.inst_id = PACKTRACE_INVALID_ID;
        }
    }
}

/// Writes an occluded query's answer (Embree's `tfar = -inf`).
#[inline]
pub(crate) fn write_occluded(ray: &mut PacktraceRay, occluded: bool) {
    if occluded {
        ray.tfar = f32::NEG_INFINITY;
    }
}

/// The active lanes of an Embree-style `valid` array: 0 inactive, -1
/// active.
///
/// # Errors
/// `PACKTRACE_STATUS_INVALID_ARGUMENT` for any other value.
#[inline]
pub(crate) fn active(valid: &[i32]) -> Result<u32, Error> {
    let mut bits = 0;
    for (i, &v) in valid.iter().enumerate() {
        match v {
            0 => {}
            -1 => bits |= 1 << i,
            _ => return Err(bad_valid(i, v)),
        }
    }
    Ok(bits)
}

#[cold]
fn bad_valid(i: usize, v: i32) -> Error {
    Error::invalid(format!(
        "valid[{i}] is {v}: a lane is active with -1 and inactive with 0 (as in Embree)"
    ))
}

/// A packet width's host structs and library packet.
pub(crate) trait Width {
    /// The library's packet.
    type Packet;
    /// The host's hit struct.
    type Hits;
    /// Lanes.
    const W: usize;
    /// The packet of the lanes of `active`, checked.
    fn packet(&self, active: u32) -> Result<Self::Packet, Error>;
    /// Lane `i`'s mask.
    fn mask(&self, i: usize) -> u32;
    /// Writes lane `i`'s intersect answer.
    fn write_hit(&mut self, hits: &mut Self::Hits, i: usize, f: Option<Found>);
    /// Writes lane `i`'s occlusion.
    fn write_occluded(&mut self, i: usize, occluded: bool);
}

macro_rules! width {
    ($ray:ty, $hits:ty, $packet:ty, $w:literal) => {
        impl Width for $ray {
            type Packet = $packet;
            type Hits = $hits;
            const W: usize = $w;

            #[inline]
            fn packet(&self, active: u32) -> Result<$packet, Error> {
                let (org, dir) = (
                    [self.org_x, self.org_y, self.org_z],
                    [self.dir_x, self.dir_y, self.dir_z],
                );
                // Checked in one branch-free pass, built in SIMD; a bad
                // lane is named (`RayPacket::from_soa`).
                Ok(<$packet>::from_soa(
                    org, dir, self.tnear, self.tfar, active,
                )?)
            }

            #[inline]
            fn mask(&self, i: usize) -> u32 {
                self.mask[i]
            }

            #[inline]
            fn write_hit(&mut self, hits: &mut $hits, i: usize, f: Option<Found>) {
                match f {
                    Some(f) => {
                        self.tfar[i] = f.t;
                        hits.ng_x[i] = f.ng.x;
                        hits.ng_y[i] = f.ng.y;
                        hits.ng_z[i] = f.ng.z;
                        hits.u[i] = f.u;
                        hits.v[i] = f.v;
                        hits.prim_id[i] = f.prim;
                        hits.geom_id[i] = f.geom;
                        hits.inst_id[i] = f.inst;
                    }
                    None => {
                        hits.prim_id[i] = PACKTRACE_INVALID_ID;
                        hits.geom_id[i] = PACKTRACE_INVALID_ID;
                        hits.inst_id[i] = PACKTRACE_INVALID_ID;
                    }
                }
            }

            #[inline]
            fn write_occluded(&mut self, i: usize, occluded: bool) {
                if occluded {
                    self.tfar[i] = f32::NEG_INFINITY;
                }
            }
        }
    };
}

width!(PacktraceRay4, PacktraceHit4, RayPacket4, 4);
width!(PacktraceRay8, PacktraceHit8, RayPacket8, 8);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::status::PacktraceStatus;

    #[test]
    fn valid_arrays_take_zero_and_minus_one_only() {
        assert_eq!(active(&[0, -1, -1, 0]).unwrap(), 0b0110);
        let e = active(&[0, 1, -1, 0]).unwrap_err();
        assert_eq!(e.status, PacktraceStatus::InvalidArgument);
        assert_eq!(
            e.message,
            "valid[1] is 1: a lane is active with -1 and inactive with 0 (as in Embree)"
        );
    }

    #[test]
    fn a_bad_lane_is_named() {
        let mut r = PacktraceRay8 {
            dir_z: [1.0; 8],
            ..Default::default()
        };
        r.org_y[5] = f32::NAN;
        assert!(r.packet(0b0001_1111).is_ok());
        let e = r.packet(0b0010_0000).unwrap_err();
        assert_eq!(e.status, PacktraceStatus::InvalidRay);
        assert_eq!(e.message, "lane 5: ray origin [0, NaN, 0] is not finite");
    }
}
