//! The one ray/triangle routine: watertight intersection (Woop, Benthin and
//! Wald, "Watertight Ray/Triangle Intersection", JCGT 2013), generic over
//! the lane type.
//!
//! Brute force and the scalar kd traversal call it with one lane (`f32`),
//! the packet traversal with four ([`crate::simd::F4`]); every lane runs the
//! same IEEE operations, so packet and scalar results agree bit for bit.
//!
//! Edges are inclusive: a ray through a shared edge or vertex hits at least
//! one of the triangles sharing it (no cracks). A triangle seen edge-on
//! (`det == 0`) is never hit, and neither is a degenerate (zero-area) one.
//!
//! A hit whose distance is within the conservative rounding bound of `t`
//! (PBRT-v3, section 3.9.6) is rejected: it cannot be told apart from the
//! ray origin. A lane whose f32 arithmetic leaves the normal range is
//! redone in f64 (`exact_lane`), so a reported hit always has a finite
//! `t` in `(t_min, t_max]` and finite barycentrics. The kd traversal's
//! margin (`kdtree/margin.rs`) covers this routine's rounding, so brute
//! force, scalar and packet traversal agree exactly.

use crate::ray::Ray;
use crate::simd::Lane;
use glam::Vec3;

/// Per-ray part of the test: the axis permutation `(kx, ky, kz)` that makes
/// `kz` the dominant direction axis, and the shear `(Sx, Sy, Sz)`
/// (Woop et al. 2013, section 3). `org` is the origin already permuted.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shear<L> {
    pub org: [L; 3],
    pub s: [L; 3],
}

/// Result of one test: lanes with a hit in `(t_min, t_max]`, and per lane
/// the distance and the barycentrics of the second and third vertex.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriHit<L: Lane> {
    pub mask: L::Mask,
    pub t: L,
    pub u: L,
    pub v: L,
}

/// The permutation `[kx, ky, kz]` for direction `d`: `kz` is the axis of
/// largest `|d|`; `kx, ky` are swapped when `d[kz] < 0` to keep the winding.
#[inline]
pub(crate) fn permutation(d: Vec3) -> [usize; 3] {
    let a = d.abs();
    let kz = if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    [kx, ky, kz]
}

/// `v` with its components in the order `k`.
#[inline(always)]
pub(crate) fn permute(v: Vec3, k: [usize; 3]) -> [f32; 3] {
    // Array indexing: glam's `Index` for `Vec3` is a `match`.
    let a: &[f32; 3] = v.as_ref();
    [a[k[0]], a[k[1]], a[k[2]]]
}

/// The shear of one ray and its permutation.
#[inline]
pub(crate) fn shear(ray: &Ray) -> (Shear<f32>, [usize; 3]) {
    let k = permutation(ray.dir);
    let d = permute(ray.dir, k);
    let sh = Shear {
        org: permute(ray.origin, k),
        s: [d[0] / d[2], d[1] / d[2], 1.0 / d[2]],
    };
    (sh, k)
}

/// Intersect a ray (or packet) with a triangle whose vertices `a, b, c` are
/// given in the ray's permuted axis order. Lanes in the returned mask have a
/// hit with `t_min < t <= t_max` and `|t|` above the rounding bound
/// [`t_error_bound`].
#[inline(always)]
pub(crate) fn intersect<L: Lane>(
    sh: &Shear<L>,
    a: [L; 3],
    b: [L; 3],
    c: [L; 3],
    t_min: L,
    t_max: L,
) -> TriHit<L> {
    // Translate to the ray origin, then shear so the ray is the +z axis.
    let (az, bz, cz) = (a[2] - sh.org[2], b[2] - sh.org[2], c[2] - sh.org[2]);
    let ax = (a[0] - sh.org[0]) - sh.s[0] * az;
    let ay = (a[1] - sh.org[1]) - sh.s[1] * az;
    let bx = (b[0] - sh.org[0]) - sh.s[0] * bz;
    let by = (b[1] - sh.org[1]) - sh.s[1] * bz;
    let cx = (c[0] - sh.org[0]) - sh.s[0] * cz;
    let cy = (c[1] - sh.org[1]) - sh.s[1] * cz;

    // Scaled barycentrics: 2D edge functions at the origin.
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;

    // An edge function of exactly 0 may be a rounding artefact on a shared
    // edge: redo those lanes in f64, which is exact for these products
    // (paper, section 4).
    let zero = L::splat(0.0);
    let on_edge = u.eq(zero) | v.eq(zero) | w.eq(zero);
    if L::any(on_edge) {
        let bits = L::bits(on_edge);
        for i in 0..L::WIDTH {
            if bits >> i & 1 == 0 {
                continue;
            }
            let f = |x: L| x.lane(i) as f64;
            let (ax, ay, bx, by, cx, cy) = (f(ax), f(ay), f(bx), f(by), f(cx), f(cy));
            u = u.with_lane(i, to_f32_keep_sign(cx * by - cy * bx));
            v = v.with_lane(i, to_f32_keep_sign(ax * cy - ay * cx));
            w = w.with_lane(i, to_f32_keep_sign(bx * ay - by * ax));
        }
    }

    // Inside iff all three have the same sign (no back-face culling).
    let neg = u.lt(zero) | v.lt(zero) | w.lt(zero);
    let pos = u.gt(zero) | v.gt(zero) | w.gt(zero);
    let det = u + v + w;
    let mut mask = !(neg & pos) & !det.eq(zero);
    if !L::any(mask) {
        return TriHit {
            mask,
            t: zero,
            u: zero,
            v: zero,
        };
    }

    // Distance: scaled z of the hit point over det.
    let t_scaled = u * (sh.s[2] * az) + v * (sh.s[2] * bz) + w * (sh.s[2] * cz);
    let inv_det = L::splat(1.0) / det;
    let mut t = t_scaled * inv_det;
    let (mut hit_u, mut hit_v) = (v * inv_det, w * inv_det);

    // Lanes whose f32 arithmetic left the normal range (a `det` or a
    // scaled `t` that is subnormal, infinite or NaN, an infinite `t`:
    // coordinates beyond about 1e12 or below 1e-13, or a tiny direction)
    // are redone in f64 from the same inputs, so that no path reports a hit
    // at infinity or misses one to overflow (issue 17, class B). Never
    // taken on ordinary scenes.
    let (abs_det, abs_t_scaled) = (det.abs(), t_scaled.abs());
    let (min, max) = (L::splat(f32::MIN_POSITIVE), L::splat(f32::MAX));
    let in_range = min.le(abs_det)
        & abs_det.le(max)
        & min.le(abs_t_scaled)
        & abs_t_scaled.le(max)
        & t.abs().le(max);
    let redo = mask & !in_range;
    let decided = mask & !redo;
    if L::any(decided) {
        // Vague points: the traversal finds a hit only if the point at its
        // `t` lies within the margin of a cell holding the triangle
        // (`kdtree/margin.rs`). `off_triangle` bounds the distance from
        // that point to the triangle; where it could exceed 7/8 of the
        // margin (slivers seen along their length), the lane keeps its
        // f32 inside decision (watertight edges, `u`, `v`) and takes `t`
        // from f64: the ray's exact crossing of the triangle's plane, or
        // where that decision was wrong by rounding (the exact ray passes
        // just outside), the depth of the boundary point nearest to the
        // ray (`LaneF64::t_on_triangle`, docs/testing.md finding 13).
        // Redoing the whole lane in f64 left cracks between a sliver on
        // that route and its neighbour on the f32 route
        // (`tests/watertight.rs`, jittered sliver sphere). On the
        // protocol's rays this runs for 0 of 100,000 hit candidates on the
        // bunny and the teapot and 0.1-0.4 % on Sponza (docs/testing.md
        // finding 12).
        let vague = decided
            & vague_point(
                &sh.org,
                &a,
                [ax, bx, cx],
                [ay, by, cy],
                [az, bz, cz],
                inv_det,
            );
        let mut bound = t_error_bound(
            sh.s[2],
            [ax, bx, cx],
            [ay, by, cy],
            [az, bz, cz],
            [u, v, w],
            inv_det,
        );
        let vague_bits = L::bits(vague);
        if vague_bits != 0 {
            for i in 0..L::WIDTH {
                if vague_bits >> i & 1 == 0 {
                    continue;
                }
                let (sh1, a1, b1, c1) = one_lane(sh, &a, &b, &c, i);
                let l = lane_f64(&sh1, a1, b1, c1);
                // A zero f64 `det` (an f32 `det` that was rounding noise)
                // gives an infinite or NaN `t`: NaN fails the interval.
                let ti = l.t_on_triangle() as f32;
                t = t.with_lane(i, if ti.is_finite() { ti } else { f32::NAN });
                bound = bound.with_lane(i, l.bound as f32);
            }
        }
        // The self-hit rule: a hit within PBRT's bound on `t`'s error of
        // the origin (the f64 one on the f64 route) is dropped.
        let near_origin = t.abs().le(bound);
        mask = mask & !(near_origin & decided);
    }
    let redo_bits = L::bits(redo);
    if redo_bits != 0 {
        for i in 0..L::WIDTH {
            if redo_bits >> i & 1 == 0 {
                continue;
            }
            let (sh1, a1, b1, c1) = one_lane(sh, &a, &b, &c, i);
            match exact_lane(&sh1, a1, b1, c1) {
                Some((ti, ui, vi)) => {
                    t = t.with_lane(i, ti);
                    hit_u = hit_u.with_lane(i, ui);
                    hit_v = hit_v.with_lane(i, vi);
                }
                // NaN: fails the interval test below.
                None => t = t.with_lane(i, f32::NAN),
            }
        }
    }
    mask = mask & t.gt(t_min) & t.le(t_max);
    TriHit {
        mask,
        t,
        u: hit_u,
        v: hit_v,
    }
}

/// One lane's test in f64 from the f32 inputs: the edge functions `e`
/// (scaled barycentrics), their sum `det`, the distance `t` and its error
/// bound (PBRT-v3's, with the f32 rounding constants, so the self-hit rule
/// is no looser than on the f32 route).
struct LaneF64 {
    e: [f64; 3],
    det: f64,
    t: f64,
    bound: f64,
    /// The corners relative to the origin, sheared (`x`, `y`: offsets from
    /// the ray's point at the same depth `z`).
    corners: [[f64; 3]; 3],
    /// The shear's `1 / dir[kz]`: depth `z` is at `t = s_z * z`.
    s_z: f64,
}

impl LaneF64 {
    /// Do the f64 edge functions have mixed signs (the exact ray misses)?
    fn mixed_signs(&self) -> bool {
        let neg = self.e.iter().any(|&x| x < 0.0);
        let pos = self.e.iter().any(|&x| x > 0.0);
        neg && pos
    }

    /// The `t` of a point on the triangle at which the ray passes within
    /// rounding of it, for a lane whose f32 inside decision said hit: the
    /// exact crossing of the plane where the f64 edge functions agree, and
    /// otherwise (the f32 decision was wrong by rounding: a ray aimed at a
    /// vertex or along an edge, most often grazing) the depth of the
    /// triangle's boundary point nearest to the ray seen along it. The
    /// plane crossing of such a grazing ray can lie far off the triangle
    /// (docs/testing.md finding 13: 1e-4 outside the mesh box, so the tree
    /// missed the hit brute force reported); the nearest boundary point
    /// lies within the f32 decision's rounding of the ray. NaN or infinite
    /// for a zero `det` (the ray in the triangle's plane), as before.
    fn t_on_triangle(&self) -> f64 {
        if self.det == 0.0 || !self.mixed_signs() {
            return self.t;
        }
        // Nearest point of each edge to the ray (the sheared origin, x = y
        // = 0), by 2D distance; its depth interpolated along the edge.
        let [a, b, c] = self.corners;
        let mut best = (f64::INFINITY, f64::NAN);
        for (p, q) in [(a, b), (b, c), (c, a)] {
            let (dx, dy) = (q[0] - p[0], q[1] - p[1]);
            let len2 = dx * dx + dy * dy;
            let along = if len2 > 0.0 {
                (-(p[0] * dx + p[1] * dy) / len2).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let (x, y) = (p[0] + along * dx, p[1] + along * dy);
            let dist2 = x * x + y * y;
            if dist2 < best.0 {
                best = (dist2, p[2] + along * (q[2] - p[2]));
            }
        }
        self.s_z * best.1
    }
}

#[cold]
#[inline(never)]
fn lane_f64(sh: &Shear<f32>, a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> LaneF64 {
    let o = sh.org.map(f64::from);
    let s = sh.s.map(f64::from);
    let sheared = |p: [f32; 3]| {
        let z = f64::from(p[2]) - o[2];
        [
            (f64::from(p[0]) - o[0]) - s[0] * z,
            (f64::from(p[1]) - o[1]) - s[1] * z,
            z,
        ]
    };
    let (a, b, c) = (sheared(a), sheared(b), sheared(c));
    let e = [
        c[0] * b[1] - c[1] * b[0],
        a[0] * c[1] - a[1] * c[0],
        b[0] * a[1] - b[1] * a[0],
    ];
    let det = e[0] + e[1] + e[2];
    let t = (e[0] * (s[2] * a[2]) + e[1] * (s[2] * b[2]) + e[2] * (s[2] * c[2])) / det;
    let max3 = |x: [f64; 3]| x[0].abs().max(x[1].abs()).max(x[2].abs());
    let max_zt = max3([s[2] * a[2], s[2] * b[2], s[2] * c[2]]);
    let (max_xt, max_yt, max_e) = (max3([a[0], b[0], c[0]]), max3([a[1], b[1], c[1]]), max3(e));
    let g = |n: f32| f64::from(gamma(n));
    let delta_z = g(3.0) * max_zt;
    let delta_x = g(5.0) * (max_xt + max_zt);
    let delta_y = g(5.0) * (max_yt + max_zt);
    let delta_e = 2.0 * (g(2.0) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let bound = 3.0 * (g(3.0) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / det.abs();
    LaneF64 {
        e,
        det,
        t,
        bound,
        corners: [a, b, c],
        s_z: s[2],
    }
}

/// Lane `i` of a packet's shear and corners, for the per-lane f64 routes.
#[inline]
fn one_lane<L: Lane>(
    sh: &Shear<L>,
    a: &[L; 3],
    b: &[L; 3],
    c: &[L; 3],
    i: usize,
) -> (Shear<f32>, [f32; 3], [f32; 3], [f32; 3]) {
    let lane = |p: &[L; 3]| p.map(|x| x.lane(i));
    let sh = Shear {
        org: lane(&sh.org),
        s: lane(&sh.s),
    };
    (sh, lane(a), lane(b), lane(c))
}

/// One lane of [`intersect`] in f64, for inputs whose f32 arithmetic over-
/// or underflows: `(t, u, v)` of a hit that is finite in f32 and beyond the
/// t error bound, or `None`. Edge functions of exactly zero are on the
/// edge, as in f32.
#[cold]
#[inline(never)]
fn exact_lane(sh: &Shear<f32>, a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> Option<(f32, f32, f32)> {
    let l = lane_f64(sh, a, b, c);
    // Mixed signs: outside. Without them a zero `det` means all three are
    // zero (a degenerate triangle, or the ray in its plane): `t` is then
    // NaN and refused below. `det` is always finite (products of f32
    // values fit in f64), so no other check is needed; mutation run B
    // found the former `det == 0 || !det.is_finite()` checks equivalent.
    if l.mixed_signs() {
        return None;
    }
    let t32 = l.t as f32;
    (t32.is_finite() && l.t.abs() > l.bound)
        .then(|| (t32, (l.e[1] / l.det) as f32, (l.e[2] / l.det) as f32))
}

/// `x` rounded to `f32`, except that a nonzero `x` too small for `f32` becomes
/// the smallest subnormal of its sign rather than `±0`: a zero edge function
/// means "on the edge" and would turn a clear miss into a hit.
#[inline]
fn to_f32_keep_sign(x: f64) -> f32 {
    let y = x as f32;
    if y == 0.0 && x != 0.0 {
        f32::from_bits(1).copysign(x as f32)
    } else {
        y
    }
}

/// The traversal's margin as a share of the coordinate magnitude `M`
/// (`kdtree/margin.rs`): `2^-16`, 256 ulps of `M`. The triangle test keeps
/// the point at every `t` it reports within 7/8 of it of the triangle,
/// taking `t` from f64 where it cannot show that in f32 (see
/// [`off_triangle`]). A bound on `t`'s own error instead (PBRT's, or a
/// sharper one from the convex combination) sent 22 % of Sponza's primary
/// hits and most grazing ones there at this margin; a `2^-12` margin that
/// made them rare cost 14-24 % more instructions on the bunny's primary
/// rays (cells overlap more), all measured with callgrind.
pub(crate) const MARGIN: f32 = 1.0 / 65536.0;

/// `gamma(n) = n eps / (1 - n eps)`: the relative error bound of `n`
/// rounded operations (Higham; PBRT-v3, section 3.9.1), `eps = 2^-24`.
const fn gamma(n: f32) -> f32 {
    let eps = f32::EPSILON * 0.5;
    n * eps / (1.0 - n * eps)
}

/// The largest magnitude of three lanes' values, per lane.
#[inline(always)]
fn max_abs3<L: Lane>(v: [L; 3]) -> L {
    v[0].abs().max_keep(v[1].abs()).max_keep(v[2].abs())
}

/// Conservative bound on the rounding error of the computed `t`
/// (PBRT-v3, section 3.9.6, derived for this same sheared test). A hit with
/// `|t| <= bound` cannot be told apart from the ray origin, so it is
/// rejected on every path (the ray policy, docs/exactness.md).
#[inline(always)]
fn t_error_bound<L: Lane>(sz: L, x: [L; 3], y: [L; 3], z: [L; 3], e: [L; 3], inv_det: L) -> L {
    let max_zt = max_abs3([sz * z[0], sz * z[1], sz * z[2]]);
    let (max_xt, max_yt, max_e) = (max_abs3(x), max_abs3(y), max_abs3(e));
    let delta_z = L::splat(gamma(3.0)) * max_zt;
    let delta_x = L::splat(gamma(5.0)) * (max_xt + max_zt);
    let delta_y = L::splat(gamma(5.0)) * (max_yt + max_zt);
    let delta_e = L::splat(2.0)
        * (L::splat(gamma(2.0)) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    L::splat(3.0)
        * (L::splat(gamma(3.0)) * max_e * max_zt + delta_e * max_zt + delta_z * max_e)
        * inv_det.abs()
}

/// Lanes whose hit point f32 cannot keep within 7/8 of the traversal's
/// margin, `MARGIN * M` (`M` the largest coordinate magnitude of the
/// origin and the scene box, so at least `m`, that of the origin and the
/// corner `a`; the other two corners cost 2 % of a packet's instructions
/// and changed nothing measurable): where [`off_triangle`] exceeds that.
#[inline(always)]
fn vague_point<L: Lane>(
    org: &[L; 3],
    a: &[L; 3],
    x: [L; 3],
    y: [L; 3],
    z: [L; 3],
    inv_det: L,
) -> L::Mask {
    let m = max_abs3(*org).max_keep(max_abs3(*a));
    off_triangle(x, y, z, inv_det).gt(L::splat(MARGIN * 0.875) * m)
}

/// Bound on the distance, along each axis, from the point of the ray at
/// the computed `t` to the triangle: what the traversal's margin must
/// cover (`x`, `y` sheared, `z` unscaled, all relative to the origin).
///
/// Why not `t`'s error: a grazing ray's `t` may be far off (PBRT's bound
/// grows as `1 / sin` of the angle) while the point only slides within
/// the triangle's plane. Exactly, the computed `t` is `sum(b_i z_i)`
/// (plus `gamma(10)` of `max |z|` for its rounding) with `b_i = e_i / det`
/// from the computed edge functions: the depth of the triangle's point
/// `Q = sum(b_i p_i)`. The ray's point at that depth differs from `Q` by
/// `Q`'s sheared `x`, `y`. The computed coordinates are off by at most
/// `delta_x = gamma(5) (max |x| + max |z|)` (the shear), against which the
/// `b_i` place the origin exactly, but for the edge functions' own
/// rounding, `r <= 2 gamma(2) max|x| max|y|` each: so `|Q_x| <= 3 r max|x|
/// / |det| + delta_x`, and alike for `y`. Small for every well-shaped
/// triangle at any angle; large for slivers seen along their length
/// (`max|x| max|y|` far above `det`).
#[inline(always)]
fn off_triangle<L: Lane>(x: [L; 3], y: [L; 3], z: [L; 3], inv_det: L) -> L {
    let (max_x, max_y, max_z) = (max_abs3(x), max_abs3(y), max_abs3(z));
    let max_xy = max_x.max_keep(max_y);
    let edge_rounding = L::splat(6.0 * gamma(2.0)) * max_x * max_y * max_xy * inv_det.abs();
    edge_rounding + L::splat(gamma(5.0)) * (max_xy + max_z) + L::splat(gamma(10.0)) * max_z
}

/// Scalar convenience: intersect `ray` with triangle `(v0, v1, v2)` over
/// its whole interval. Returns `(t, u, v)`.
#[inline]
pub(crate) fn intersect_ray(ray: &Ray, tri: &[Vec3; 3]) -> Option<(f32, f32, f32)> {
    let (sh, k) = shear(ray);
    let h = intersect(
        &sh,
        permute(tri[0], k),
        permute(tri[1], k),
        permute(tri[2], k),
        ray.t_min,
        ray.t_max,
    );
    h.mask.then_some((h.t, h.u, h.v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::simd::F4;
    use glam::DVec3;

    fn tri() -> [Vec3; 3] {
        [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ]
    }

    #[test]
    fn hits_center_with_barycentrics() {
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, 10.0);
        let (t, u, v) = intersect_ray(&r, &tri()).unwrap();
        assert_eq!((t, u, v), (1.0, 0.25, 0.25));
        // back side too (no culling)
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, -1.0), Vec3::Z, 0.0, 10.0);
        assert_eq!(intersect_ray(&r, &tri()).map(|h| h.0), Some(1.0));
    }

    #[test]
    fn interval_is_exclusive_below_inclusive_above() {
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, 1.0);
        assert!(intersect_ray(&r, &tri()).is_some());
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 1.0, 2.0);
        assert!(intersect_ray(&r, &tri()).is_none());
    }

    #[test]
    fn edges_and_vertices_count_edge_on_and_degenerate_do_not() {
        for p in [(0.5, 0.5), (0.0, 0.0), (1.0, 0.0), (0.0, 0.5)] {
            let r = Ray::new_unchecked(Vec3::new(p.0, p.1, 1.0), Vec3::NEG_Z, 0.0, 10.0);
            assert!(intersect_ray(&r, &tri()).is_some(), "{p:?}");
        }
        // in the triangle's plane
        let r = Ray::new_unchecked(Vec3::new(-1.0, 0.25, 0.0), Vec3::X, 0.0, 10.0);
        assert!(intersect_ray(&r, &tri()).is_none());
        // collinear vertices
        let d = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        let r = Ray::new_unchecked(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, 0.0, 10.0);
        assert!(intersect_ray(&r, &d).is_none());
    }

    #[test]
    fn a_ray_leaving_the_surface_does_not_rehit_it() {
        // Origins on the triangle, many directions: rounding gives t ~ 1e-8
        // (or exactly 0) without the bound; with it, never a hit.
        for i in 0..200 {
            let f = i as f32 * 0.618_034;
            let o = Vec3::new(
                0.1 + 0.3 * f.fract(),
                0.2 + 0.5 * (f * 1.7).fract() * 0.5,
                0.0,
            );
            let d = Vec3::new((f * 3.1).sin(), (f * 2.3).cos(), 0.05 + (f * 1.3).fract());
            for dir in [d, -d] {
                let r = Ray::new_unchecked(o, dir, 0.0, 10.0);
                assert!(intersect_ray(&r, &tri()).is_none(), "{o} {dir}");
            }
        }
        // A far hit is untouched by the bound.
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, 1e-3), Vec3::NEG_Z, 0.0, 10.0);
        assert!(intersect_ray(&r, &tri()).is_some());
    }

    #[test]
    fn underflowing_edge_functions_keep_their_sign() {
        assert_eq!(to_f32_keep_sign(-9.1e-72).to_bits(), 0x8000_0001);
        assert_eq!(to_f32_keep_sign(9.1e-72).to_bits(), 0x0000_0001);
        assert_eq!(to_f32_keep_sign(0.0).to_bits(), 0);
        assert_eq!(to_f32_keep_sign(-0.0).to_bits(), 0x8000_0000);
        assert_eq!(to_f32_keep_sign(1.5), 1.5);
    }

    /// An edge function that f32 rounds to exactly zero (its two products
    /// round to the same value) but is `-2^-46` exactly: the ray passes
    /// just outside edge `bc`, so a triangle whose other two edge
    /// functions are positive is missed (its neighbour across `bc` takes
    /// the hit), and one whose other two are negative is hit. Only the f64
    /// redo of zero edge functions (PBRT-v3, section 3.9.4) tells them
    /// apart; on the f32 values alone both would be hits on the edge.
    #[test]
    fn a_zero_edge_function_is_redone_in_f64() {
        let e = 2f32.powi(-23);
        let (b, c) = ([-1.0, -(1.0 + e), 1.0], [1.0 + e, 1.0 + 2.0 * e, 1.0]);
        // The premise: f32 rounds both products to 1 + 2^-22.
        assert_eq!(c[0] * b[1] - c[1] * b[0], 0.0);
        let exact = f64::from(c[0]) * f64::from(b[1]) - f64::from(c[1]) * f64::from(b[0]);
        assert_eq!(exact, -(2f64.powi(-46)));
        let down_z = Shear {
            org: [0.0f32; 3],
            s: [0.0, 0.0, 1.0],
        };
        for (a, hit) in [([1.0, -1.0, 1.0], false), ([-1.0, 1.0, 1.0], true)] {
            // The same triangle from each corner: the zero edge function is
            // `u`, then `w`, then `v`.
            for (p, q, r) in [(a, b, c), (b, c, a), (c, a, b)] {
                let h = intersect::<f32>(&down_z, p, q, r, 0.0, f32::INFINITY);
                assert_eq!(h.mask, hit, "{p:?} {q:?} {r:?}");
                if hit {
                    assert_eq!(h.t, 1.0);
                }
            }
        }
    }

    #[test]
    fn nan_rays_never_hit() {
        let r = Ray::new_unchecked(Vec3::new(f32::NAN, 0.25, 1.0), Vec3::NEG_Z, 0.0, 10.0);
        assert!(intersect_ray(&r, &tri()).is_none());
        let r = Ray::new_unchecked(Vec3::new(0.25, 0.25, 1.0), Vec3::ZERO, 0.0, 10.0);
        assert!(intersect_ray(&r, &tri()).is_none());
    }

    #[test]
    fn four_lanes_equal_four_scalars_bitwise() {
        let t = tri();
        let rays: Vec<Ray> = (0..4)
            .map(|i| {
                let o = Vec3::new(0.1 + 0.3 * i as f32, 0.2, 1.0 + i as f32);
                Ray::new_unchecked(o, Vec3::new(-0.1, 0.05, -1.0), 0.0, 100.0)
            })
            .collect();
        // same permutation for all four (z dominant)
        let k = permutation(rays[0].dir);
        let lanes = |f: &dyn Fn(&Ray) -> f32| {
            F4::from([f(&rays[0]), f(&rays[1]), f(&rays[2]), f(&rays[3])])
        };
        let shears: Vec<Shear<f32>> = rays.iter().map(|r| shear(r).0).collect();
        let sh = Shear {
            org: [0, 1, 2].map(|j| lanes(&|r: &Ray| permute(r.origin, k)[j])),
            s: [0, 1, 2].map(|j| {
                F4::from([
                    shears[0].s[j],
                    shears[1].s[j],
                    shears[2].s[j],
                    shears[3].s[j],
                ])
            }),
        };
        let v = |p: Vec3| permute(p, k).map(F4::splat);
        let h = intersect(
            &sh,
            v(t[0]),
            v(t[1]),
            v(t[2]),
            F4::splat(0.0),
            F4::splat(100.0),
        );
        for (i, r) in rays.iter().enumerate() {
            let s = intersect_ray(r, &t);
            assert_eq!(h.mask.to_bitmask() >> i & 1 == 1, s.is_some());
            if let Some((ts, us, vs)) = s {
                assert_eq!(h.t.as_array()[i].to_bits(), ts.to_bits());
                assert_eq!(h.u.as_array()[i].to_bits(), us.to_bits());
                assert_eq!(h.v.as_array()[i].to_bits(), vs.to_bits());
            }
        }
    }

    // -----------------------------------------------------------------
    // The hit point's distance to the triangle (`off_triangle`)
    // -----------------------------------------------------------------

    /// `intersect`'s sheared corners and `1 / det` for one ray.
    fn sheared(ray: &Ray, tri: &[Vec3; 3]) -> ([f32; 3], [f32; 3], [f32; 3], f32) {
        let (sh, k) = shear(ray);
        let p = tri.map(|v| permute(v, k));
        let z = p.map(|q| q[2] - sh.org[2]);
        let x = [0, 1, 2].map(|i| (p[i][0] - sh.org[0]) - sh.s[0] * z[i]);
        let y = [0, 1, 2].map(|i| (p[i][1] - sh.org[1]) - sh.s[1] * z[i]);
        let e = [
            x[2] * y[1] - y[2] * x[1],
            x[0] * y[2] - y[0] * x[2],
            x[1] * y[0] - y[1] * x[0],
        ];
        (x, y, z, 1.0 / (e[0] + e[1] + e[2]))
    }

    /// The closest point of triangle `abc` to `p`, in f64 (Ericson,
    /// Real-Time Collision Detection, section 5.1.5).
    fn closest_point(p: DVec3, a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
        let (ab, ac, ap) = (b - a, c - a, p - a);
        let (d1, d2) = (ab.dot(ap), ac.dot(ap));
        if d1 <= 0.0 && d2 <= 0.0 {
            return a;
        }
        let bp = p - b;
        let (d3, d4) = (ab.dot(bp), ac.dot(bp));
        if d3 >= 0.0 && d4 <= d3 {
            return b;
        }
        let vc = d1 * d4 - d3 * d2;
        if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            return a + ab * (d1 / (d1 - d3));
        }
        let cp = p - c;
        let (d5, d6) = (ab.dot(cp), ac.dot(cp));
        if d6 >= 0.0 && d5 <= d6 {
            return c;
        }
        let vb = d5 * d2 - d1 * d6;
        if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            return a + ac * (d2 / (d2 - d6));
        }
        let va = d3 * d6 - d5 * d4;
        if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
            return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
        }
        let denom = 1.0 / (va + vb + vc);
        a + ab * (vb * denom) + ac * (vc * denom)
    }

    /// Where a reported hit's point lies: its distance from the triangle
    /// (f64, exact closest point), the margin's 7/8 as a length (what the
    /// traversal needs it within; `M` from the origin and the first
    /// corner), `off_triangle`'s bound, and whether that sends the lane to
    /// f64.
    struct HitPoint {
        dist: f64,
        margin: f64,
        off: f32,
        vague: bool,
    }

    impl HitPoint {
        fn of(ray: &Ray, tri: &[Vec3; 3], t: f32) -> HitPoint {
            let d = |x: Vec3| x.as_dvec3();
            let p = d(ray.origin) + d(ray.dir) * f64::from(t);
            let [a, b, c] = tri.map(d);
            let m = [ray.origin, tri[0]]
                .iter()
                .map(|x| x.abs().max_element())
                .fold(0.0, f32::max);
            let (x, y, z, inv_det) = sheared(ray, tri);
            let off = off_triangle(x, y, z, inv_det);
            HitPoint {
                dist: (p - closest_point(p, a, b, c)).length(),
                margin: f64::from(MARGIN * 0.875 * m) * 3f64.sqrt(),
                off,
                vague: off > MARGIN * 0.875 * m,
            }
        }
    }

    /// A deterministic stream of numbers in [0, 1).
    fn unit_stream(seed: u64) -> impl FnMut() -> f32 {
        let mut x = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
        move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// Every hit's point lies within the margin's 7/8 of the triangle (what
    /// the traversal relies on), and on the f32 route within
    /// `off_triangle` (the bound holds): triangles from well shaped to
    /// 10^5:1 slivers, at scales 1 to 1e4 and offsets to 1e5, seen from
    /// any side, rays aimed at a random point inside.
    #[test]
    fn hit_points_stay_within_the_margin_of_the_triangle() {
        let mut r = unit_stream(17);
        let (mut f32_route, mut f64_route) = (0, 0);
        for case in 0..20_000 {
            let scale = 10f32.powi(case % 5);
            let offset =
                Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * 2e5 * (case % 3 == 0) as u8 as f32;
            let mut v = || offset + Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * scale;
            let (a, b) = (v(), v());
            let sliver = 10f32.powi(case % 6 - 1).max(1.0);
            let c = a.lerp(b, 0.3) + (v() - offset) / sliver;
            let tri = [a, b, c];
            let (u, w) = (r(), r());
            let (u, w) = if u + w > 1.0 {
                (1.0 - u, 1.0 - w)
            } else {
                (u, w)
            };
            let target = a + (b - a) * u + (c - a) * w;
            let org =
                target + Vec3::new(r() - 0.5, r() - 0.5, r() - 0.5) * scale * 10f32.powi(case % 4);
            let Ok(ray) = Ray::new(org, target - org, 0.0, f32::INFINITY) else {
                continue;
            };
            let Some((t, _, _)) = intersect_ray(&ray, &tri) else {
                continue;
            };
            let h = HitPoint::of(&ray, &tri, t);
            let (dist, margin) = (h.dist, h.margin);
            assert!(
                dist <= margin,
                "case {case}: {dist} off the triangle, margin {margin}"
            );
            let off = h.off;
            if !h.vague {
                f32_route += 1;
                let bound = f64::from(off) * 3f64.sqrt();
                assert!(
                    dist <= bound,
                    "case {case}: {dist} off the triangle, bound {bound}"
                );
            } else {
                f64_route += 1;
            }
        }
        // Both routes were exercised.
        assert!(
            f32_route > 5_000 && f64_route > 50,
            "{f32_route} {f64_route}"
        );
    }

    /// docs/testing.md finding 13: rays aimed exactly at a vertex or an edge
    /// point, grazing the triangle's plane, where the f32 inside decision
    /// may be wrong by rounding: every hit's point still lies within the
    /// margin's 7/8 of the triangle (the plane crossing of such a ray could
    /// lie 1e-4 off it).
    #[test]
    fn grazing_rays_aimed_at_vertices_and_edges_hit_near_the_triangle() {
        let mut r = unit_stream(29);
        let (mut hits, mut vague) = (0, 0);
        for case in 0..40_000 {
            let grid = |x: f32| (x * 12.0).round() / 4.0 - 1.5;
            let mut v = || Vec3::new(grid(r()), grid(r()), grid(r()));
            let tri = [v(), v(), v()];
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
            if n.length_squared() == 0.0 {
                continue;
            }
            // A vertex or a point on an edge, approached from about 4-8
            // units away, nearly in the triangle's plane (1e-2 to 1e-5 rad).
            let target = match case % 3 {
                0 => tri[case / 3 % 3],
                _ => tri[0].lerp(tri[1 + case % 2], [0.5, 0.25, 0.75][case / 3 % 3]),
            };
            let along = n.any_orthonormal_vector().lerp(n.cross(Vec3::X), r());
            let tilt = 10f32.powi(-2 - (case as i32 / 9) % 4) * (r() - 0.5);
            let dir = along.normalize_or_zero() + n.normalize() * tilt;
            let org = target - dir * (4.0 + 4.0 * r());
            let Ok(ray) = Ray::new(org, target - org, 0.0, f32::INFINITY) else {
                continue;
            };
            let Some((t, _, _)) = intersect_ray(&ray, &tri) else {
                continue;
            };
            hits += 1;
            let h = HitPoint::of(&ray, &tri, t);
            let (dist, margin) = (h.dist, h.margin);
            assert!(
                dist <= margin,
                "case {case}: {tri:?}, {ray:?}: t = {t}, {dist} off the triangle, margin {margin}"
            );
            vague += u32::from(h.vague);
        }
        // Grazing hits, and many of them on the f64 route.
        assert!(hits > 10_000 && vague > 500, "{hits} {vague}");
    }

    /// Well-shaped triangles stay on the fast route at any angle, grazing
    /// included; a long sliver seen along its length (docs/testing.md finding
    /// 12's) does not.
    #[test]
    fn only_slivers_seen_along_their_length_leave_the_f32_route() {
        let route = |ray: &Ray, tri: &[Vec3; 3]| {
            let (sh, k) = shear(ray);
            let (x, y, z, inv_det) = sheared(ray, tri);
            let a = permute(tri[0], k);
            let m = ray
                .origin
                .abs()
                .max_element()
                .max(tri[0].abs().max_element());
            (
                vague_point(&sh.org, &a, x, y, z, inv_det),
                off_triangle(x, y, z, inv_det),
                m,
            )
        };
        for degrees in [0.5f32, 1.0, 5.0, 30.0, 90.0] {
            for distance in [1.0f32, 30.0, 1000.0] {
                let tri = [
                    Vec3::new(-1.0, 0.0, -1.0),
                    Vec3::new(1.0, 0.0, -1.0),
                    Vec3::new(0.0, 0.0, 1.0),
                ];
                let a = degrees.to_radians();
                let dir = Vec3::new(0.3 * a.cos(), -a.sin(), a.cos());
                let ray = Ray::new(
                    Vec3::new(0.1, 0.0, 0.1) - dir * distance,
                    dir,
                    0.0,
                    f32::INFINITY,
                )
                .unwrap();
                assert!(intersect_ray(&ray, &tri).is_some());
                let (vague, off, m) = route(&ray, &tri);
                assert!(!vague, "{degrees} deg from {distance}");
                // With room to spare: a quarter of the threshold.
                assert!(
                    off <= MARGIN * 0.875 * m / 4.0,
                    "{degrees} deg from {distance}: {off}"
                );
            }
        }
        let sliver = [
            Vec3::new(0.25, 0.25, -0.5),
            Vec3::new(-1.0, 0.0, 0.0),
            Vec3::new(6781.3574, 0.0, 3.9871304),
        ];
        let ray = Ray::new(
            Vec3::new(-3392.1812, -5087.02, -3389.6863),
            Vec3::new(1.0, 0.75, 0.5),
            0.0,
            f32::INFINITY,
        )
        .unwrap();
        assert!(route(&ray, &sliver).0);
    }

    /// The self-hit bound is exactly PBRT-v3's (section 3.9.6), on the f32
    /// route and the f64 one, term by term: inputs of distinct sizes, signs
    /// and positions of the maxima, and cases where the edge functions',
    /// the shear's and the depth's terms dominate in turn, so that no
    /// factor can change unseen (the agreement suites cannot see it: every
    /// path applies the same rule).
    #[test]
    fn the_self_hit_bound_is_pbrts_term_by_term() {
        // Higham's gamma for f32's unit roundoff 2^-24: `n u` and `1 - n u`
        // are exact in f32 and the quotient correctly rounded, so `gamma`
        // equals the f64 value rounded once (an ulp or two above `n u`).
        for n in [2.0f32, 3.0, 5.0, 10.0] {
            let u = f64::from(n) * 2f64.powi(-24);
            assert_eq!(gamma(n), (u / (1.0 - u)) as f32, "gamma({n})");
            assert!(gamma(n) > n * 2f32.powi(-24));
        }
        let g = |n: f32| f64::from(gamma(n));
        let max3 = |v: [f64; 3]| v.iter().fold(0.0f64, |m, c| m.max(c.abs()));
        // PBRT's bound from sheared x, y, unscaled z, the z scale, the edge
        // functions and det.
        let pbrt = |x: [f64; 3], y: [f64; 3], z: [f64; 3], sz: f64, e: [f64; 3], det: f64| {
            let (mx, my, me) = (max3(x), max3(y), max3(e));
            let mz = max3(z.map(|c| c * sz));
            let (dx, dy, dz) = (g(5.0) * (mx + mz), g(5.0) * (my + mz), g(3.0) * mz);
            let de = 2.0 * (g(2.0) * mx * my + dy * mx + dx * my);
            3.0 * (g(3.0) * me * mz + de * mz + dz * me) / det.abs()
        };
        // (x, y, z, z scale, edge functions, 1 / det)
        type Case = ([f32; 3], [f32; 3], [f32; 3], f32, [f32; 3], f32);
        let cases: [Case; 4] = [
            // Everything of comparable size.
            (
                [2.0, -1.5, 0.5],
                [-0.25, 3.0, 1.0],
                [4.0, -5.0, 2.0],
                0.7,
                [-11.0, 3.0, 2.5],
                0.13,
            ),
            // Depth small: the edge functions' term dominates.
            (
                [-7.0, 2.0, 6.5],
                [1.0, -9.0, 3.0],
                [0.01, 0.02, -0.03],
                1.3,
                [0.5, -40.0, 20.0],
                -0.5,
            ),
            // Depth large: the shear's and the depth's terms dominate.
            (
                [0.02, -0.01, 0.03],
                [-0.04, 0.01, 0.02],
                [300.0, -900.0, 500.0],
                0.9,
                [0.001, 0.004, -0.002],
                4.0,
            ),
            // x far above y.
            (
                [100.0, -300.0, 50.0],
                [0.5, 0.25, -0.75],
                [2.0, 3.0, -1.0],
                1.1,
                [60.0, -7.0, 30.0],
                0.02,
            ),
        ];
        for (x, y, z, sz, e, inv_det) in cases {
            let d = |v: [f32; 3]| v.map(f64::from);
            let want = pbrt(
                d(x),
                d(y),
                d(z),
                f64::from(sz),
                d(e),
                1.0 / f64::from(inv_det),
            );
            let got = f64::from(t_error_bound(sz, x, y, z, e, inv_det));
            assert!(
                (got - want).abs() <= 1e-5 * want,
                "f32 route: {got} vs {want}"
            );
        }
        // The f64 route, from corners and a shear: the same formula on its
        // own f64 edge functions, and those, `det` and `t` exact for these
        // small integers and powers of two; each corner in turn first, so
        // that every corner's term is the largest once.
        let sh = Shear {
            org: [0.5f32, -1.0, 2.0],
            s: [0.25f32, -0.5, 0.75],
        };
        let corners = [
            [3.0f32, 1.0, 6.0],
            [-2.0f32, 4.0, 10.0],
            [1.0f32, -3.0, 4.0],
        ];
        for first in 0..3 {
            let (a, b, c) = (
                corners[first],
                corners[(first + 1) % 3],
                corners[(first + 2) % 3],
            );
            let l = lane_f64(&sh, a, b, c);
            let sheared = |p: [f32; 3]| {
                let z = f64::from(p[2]) - 2.0;
                [
                    (f64::from(p[0]) - 0.5) - 0.25 * z,
                    (f64::from(p[1]) + 1.0) + 0.5 * z,
                    z,
                ]
            };
            let (pa, pb, pc) = (sheared(a), sheared(b), sheared(c));
            let e = [
                pc[0] * pb[1] - pc[1] * pb[0],
                pa[0] * pc[1] - pa[1] * pc[0],
                pb[0] * pa[1] - pb[1] * pa[0],
            ];
            let det = e[0] + e[1] + e[2];
            let t = 0.75 * (e[0] * pa[2] + e[1] * pb[2] + e[2] * pc[2]) / det;
            assert_eq!((l.e, l.det, l.t), (e, det, t));
            let (xs, ys, zs) = (
                [pa[0], pb[0], pc[0]],
                [pa[1], pb[1], pc[1]],
                [pa[2], pb[2], pc[2]],
            );
            let want = pbrt(xs, ys, zs, 0.75, e, det);
            assert!(
                (l.bound - want).abs() <= 1e-12 * want,
                "f64 route, corner {first} first: {} vs {want}",
                l.bound
            );
        }
    }

    /// The overflow route's own decisions, at coordinates around 1e20
    /// (where f32 products overflow): inside with either orientation, on
    /// an edge with either orientation (edges count), outside, degenerate,
    /// at the origin (the self-hit rule) and beyond f32's range, with the
    /// exact `t`, `u`, `v`.
    #[test]
    fn the_overflow_route_decides_as_the_f32_route_does() {
        let (s, z) = (1e20f32, 5e20f32);
        let down_z = Shear {
            org: [0.0f32; 3],
            s: [0.0, 0.0, 1.0],
        };
        let hit = |a: [f32; 2], b: [f32; 2], c: [f32; 2], depth: f32, sh: &Shear<f32>| {
            exact_lane(
                sh,
                [a[0], a[1], depth],
                [b[0], b[1], depth],
                [c[0], c[1], depth],
            )
        };
        let (a, b, c) = ([-s, -s], [s, -s], [0.0, s]);
        assert_eq!(hit(a, b, c, z, &down_z), Some((z, 0.25, 0.5)));
        assert_eq!(hit(a, c, b, z, &down_z), Some((z, 0.5, 0.25)));
        // The origin on edge ab, then on edge ca.
        let (a, b, c) = ([-s, 0.0], [s, 0.0], [0.0, 2.0 * s]);
        assert_eq!(hit(a, b, c, z, &down_z), Some((z, 0.5, 0.0)));
        assert_eq!(hit(a, c, b, z, &down_z), Some((z, 0.0, 0.5)));
        // Outside; degenerate (collinear through the origin's line, all
        // edge functions zero, and beside it, mixed signs).
        assert_eq!(
            hit([s, s], [3.0 * s, s], [2.0 * s, 3.0 * s], z, &down_z),
            None
        );
        assert_eq!(
            hit([s, 0.0], [2.0 * s, 0.0], [3.0 * s, 0.0], z, &down_z),
            None
        );
        assert_eq!(hit([s, s], [2.0 * s, s], [3.0 * s, s], z, &down_z), None);
        // At the origin's depth: within the t bound, refused.
        assert_eq!(hit([-s, -s], [s, -s], [0.0, s], 0.0, &down_z), None);
        // A hit beyond f32's range (a tiny direction): refused.
        let tiny_dir = Shear {
            org: [0.0f32; 3],
            s: [0.0, 0.0, 1e30],
        };
        assert_eq!(hit([-s, -s], [s, -s], [0.0, s], z, &tiny_dir), None);
        assert_eq!(
            hit([-s, -s], [s, -s], [0.0, s], 1e-20, &tiny_dir),
            Some((1e10, 0.25, 0.5))
        );
    }

    /// The route's rule is exactly "`off_triangle` above 7/8 of `MARGIN *
    /// m`", and `off_triangle` is exactly the sum its derivation gives
    /// (edge functions' rounding, the shear's, the depth's), checked term
    /// by term in f64 where each term dominates in turn.
    #[test]
    fn the_route_rule_and_the_bound_are_as_documented() {
        let g = |n: f32| f64::from(gamma(n));
        let cases = [
            // A sliver: the edge functions' rounding dominates.
            (
                [0.0f32, 3.0, 3.001],
                [0.0f32, 3.0, 2.999],
                [10.0f32, 11.0, 12.0],
                0.5f32,
            ),
            // Small and far: the shear's and the depth's rounding dominate.
            (
                [-0.01, 0.01, 0.0],
                [-0.01, -0.01, 0.01],
                [1000.0, 1000.5, 999.0],
                2500.0,
            ),
            // Wide and near.
            ([-2.0, 2.0, 0.0], [-1.0, -1.0, 3.0], [0.1, 0.2, 0.3], 0.05),
        ];
        for (x, y, z, inv_det) in cases {
            let max3 = |v: [f32; 3]| v.iter().fold(0.0f64, |m, c| m.max(f64::from(c.abs())));
            let (mx, my, mz) = (max3(x), max3(y), max3(z));
            let want = 6.0 * g(2.0) * mx * my * mx.max(my) * f64::from(inv_det)
                + g(5.0) * (mx.max(my) + mz)
                + g(10.0) * mz;
            let got = f64::from(off_triangle(x, y, z, inv_det));
            assert!((got - want).abs() <= 1e-5 * want, "{got} vs {want}");
            // The rule, on both sides of the threshold: m from the origin
            // or from the corner, whichever is larger.
            for m in [
                got / f64::from(MARGIN * 0.875) * 0.999,
                got / f64::from(MARGIN * 0.875) * 1.001,
            ] {
                let m = m as f32;
                let want = got > f64::from(MARGIN * 0.875 * m);
                assert_eq!(
                    vague_point(&[m, 0.0, 0.0], &[0.0, -m / 2.0, 0.0], x, y, z, inv_det),
                    want
                );
                assert_eq!(
                    vague_point(&[0.0, 0.0, m / 4.0], &[0.0, 0.0, -m], x, y, z, inv_det),
                    want
                );
            }
        }
    }
}
