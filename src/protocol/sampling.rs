//! The protocol's deterministic sampling: its PCG hash, hashed uniforms,
//! the orthonormal basis around a normal, and cosine-distributed ambient
//! occlusion directions. Workloads, generated scenes and the renderer
//! share these, so their rays are the protocol's bit for bit.

use glam::Vec3;
use std::f32::consts::PI;

/// The protocol's PCG hash (wrapping `u32` arithmetic).
///
/// ```
/// use packtrace::protocol::sampling::hash;
/// assert_eq!(hash(0), 129708002);
/// assert_eq!(hash(1), 2831084092);
/// ```
#[inline]
#[must_use]
pub fn hash(v: u32) -> u32 {
    let s = v.wrapping_mul(747796405).wrapping_add(2891336453);
    let w = ((s >> ((s >> 28) + 4)) ^ s).wrapping_mul(277803737);
    (w >> 22) ^ w
}

/// A hash value as a float in `[0, 1)`: its top 24 bits times `2^-24`.
///
/// ```
/// use packtrace::protocol::sampling::{hash, unit};
/// assert_eq!(unit(0), 0.0);
/// assert_eq!(unit(u32::MAX), 1.0 - 1.0 / 16777216.0);
/// assert_eq!(unit(hash(0)), 0.030199944972991943);
/// ```
#[inline]
#[must_use]
pub fn unit(h: u32) -> f32 {
    (h >> 8) as f32 * (1.0 / 16777216.0)
}

/// Orthonormal basis `(b1, b2)` completing the unit normal `n`, so that
/// `(b1, b2, n)` is right-handed (Duff et al., "Building an Orthonormal
/// Basis, Revisited", JCGT 2017), exactly as the protocol writes it.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::sampling::onb;
/// let (b1, b2) = onb(Vec3::Z);
/// assert_eq!((b1, b2), (Vec3::X, Vec3::Y));
/// let (b1, b2) = onb(Vec3::NEG_Z);
/// assert!(b1.dot(b2).abs() < 1e-7 && (b1.cross(b2) - Vec3::NEG_Z).length() < 1e-7);
/// ```
#[inline]
#[must_use]
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let b1 = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let b2 = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (b1, b2)
}

/// The direction of ambient-occlusion sample `k` of pixel `p` around the
/// unit normal `n` (protocol, `ao`): cosine-distributed over the
/// hemisphere of `n`. The protocol uses `k < 16` (key `p * 16 + k`); the
/// renderer's further samples mix `k / 16` into the key, so the first 16
/// are the protocol's exactly.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::sampling::ao_direction;
/// let d = ao_direction(12345, 2, Vec3::Y);
/// assert!(d.y > 0.0 && (d.length() - 1.0).abs() < 1e-6);
/// assert!(ao_direction(99, 40, Vec3::Y).y >= 0.0);
/// ```
#[inline]
#[must_use]
pub fn ao_direction(p: u32, k: u32, n: Vec3) -> Vec3 {
    let key = p.wrapping_mul(16).wrapping_add(k & 15) ^ (k >> 4).wrapping_mul(0x9E37_79B9);
    let s = hash(key);
    let u1 = unit(s);
    let u2 = unit(hash(s));
    let rr = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (lx, ly, lz) = (rr * phi.cos(), rr * phi.sin(), (1.0 - u1).max(0.0).sqrt());
    let (b1, b2) = onb(n);
    (b1 * lx + b2 * ly + n * lz).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The protocol's formula for `k < 16`, written out as the protocol
    /// states it (key `p * 16 + k`).
    fn protocol_ao(p: u32, k: u32, n: Vec3) -> Vec3 {
        let s = hash(p.wrapping_mul(16).wrapping_add(k));
        let (u1, u2) = (unit(s), unit(hash(s)));
        let (rr, phi) = (u1.sqrt(), 2.0 * PI * u2);
        let (lx, ly, lz) = (rr * phi.cos(), rr * phi.sin(), (1.0 - u1).max(0.0).sqrt());
        let (b1, b2) = onb(n);
        (b1 * lx + b2 * ly + n * lz).normalize()
    }

    #[test]
    fn ao_directions_beyond_16_extend_the_protocol() {
        let n = Vec3::new(-0.3, 0.2, -0.9).normalize();
        for p in [0, 1, 77, 1 << 20] {
            for j in 0..16 {
                assert_eq!(ao_direction(p, j, n), protocol_ao(p, j, n));
            }
            // later rounds differ from the first and stay in the hemisphere
            for j in 16..64 {
                let d = ao_direction(p, j, n);
                assert!(d.dot(n) >= 0.0 && (d.length() - 1.0).abs() < 1e-5);
                assert_ne!(d, ao_direction(p, j % 16, n));
            }
        }
    }
}
