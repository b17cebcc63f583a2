//! The traversal's margin: every cell is entered as if it were a little
//! larger than it is, by an absolute distance in space.
//!
//! Why in space and not in `t`: the triangle test's `t` carries a rounding
//! error proportional to the coordinates it works with (the triangle's
//! corners seen from the ray origin, PBRT-v3 section 3.9.6), not to `t`.
//! A hit at `t = 1e-4` on a triangle 20 units from the world origin has
//! an error of about `1e-6`, one percent of `t`, so the relative `2^-16`
//! widening of every cell distance that this module replaces let a ray
//! whose interval ends at (or starts just below) that hit cull the cell
//! holding it, while brute force reported it (issue 17, class A).
//!
//! The rule: every split plane and every face of the scene box is moved
//! outwards by `eta = MARGIN * M`, where `M` is the largest coordinate
//! magnitude of the ray origin and the scene box. The triangle test keeps
//! the point of the ray at every `t` it returns within `7/8 eta` of the
//! triangle along each axis (taking `t` from f64 where it cannot show that
//! in f32: `off_triangle` in `triangle.rs`), hence within `eta` of a cell
//! that references it; and the rounding of the plane distances themselves
//! (`(split - org) * inv_dir`, a relative error of `3 * 2^-24` of
//! `|split - org| <= 2 M`) is far below the last eighth. So the widened
//! cells always contain every hit the triangle test can report, and the
//! traversal's intervals need no other slack.
//!
//! In the kernels the margin costs nothing per node: the origin is moved
//! once per ray, backwards for the near child's end and forwards for the
//! far child's start (`org_exit`, `org_entry`), so a node step computes two
//! plane distances with one subtraction and one multiplication each, where
//! the relative widening needed one of each plus two multiplications, a
//! `min` and a `max`.

use crate::aabb::Aabb;
use crate::simd::Lane;

pub(crate) use crate::triangle::MARGIN;

/// Origins moved by the margin along each axis, per lane.
///
/// For a plane at `p` on axis `a`, `(p - exit[a]) * inv_dir[a]` is the last
/// `t` at which the ray is still within `eta` of the plane's near side,
/// and `(p - entry[a]) * inv_dir[a]` the first `t` at which it is within
/// `eta` of its far side. The sign bit of the direction decides which way
/// is forward, as it decides near and far.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Shifted<L> {
    /// The origin moved forwards by `eta` (earlier entries).
    pub entry: [L; 3],
    /// The origin moved backwards by `eta` (later exits).
    pub exit: [L; 3],
}

/// The shifted origins of a ray (or of each lane) inside `bounds`.
#[inline(always)]
pub(crate) fn shifted<L: Lane>(bounds: &Aabb, org: &[L; 3], neg: &[L::Mask; 3]) -> Shifted<L> {
    let box_m = bounds.min.abs().max(bounds.max.abs()).max_element();
    // `max_keep`: a NaN origin (an invalid lane) leaves `M` finite; its
    // distances are NaN anyway.
    let m = L::splat(box_m)
        .max_keep(org[0].abs())
        .max_keep(org[1].abs())
        .max_keep(org[2].abs());
    let eta = m * L::splat(MARGIN);
    let zero = L::splat(0.0);
    let fwd = [0, 1, 2].map(|a| L::select(neg[a], zero - eta, eta));
    Shifted {
        entry: [0, 1, 2].map(|a| org[a] + fwd[a]),
        exit: [0, 1, 2].map(|a| org[a] - fwd[a]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    #[test]
    fn origins_move_forwards_for_entries_and_backwards_for_exits() {
        let b = Aabb::new(Vec3A::splat(-2.0), Vec3A::splat(65536.0));
        let s = shifted::<f32>(&b, &[1.0, 1.0, -70000.0], &[false, true, false]);
        // M = 70000 (the origin), eta = 70000 * MARGIN
        let eta = 70000.0f32 * MARGIN;
        assert_eq!(s.entry, [1.0 + eta, 1.0 - eta, -70000.0 + eta]);
        assert_eq!(s.exit, [1.0 - eta, 1.0 + eta, -70000.0 - eta]);
        // The box's magnitude counts when the origin is smaller.
        let s = shifted::<f32>(&b, &[0.0; 3], &[false; 3]);
        assert_eq!(s.entry, [65536.0 * MARGIN; 3]);
        assert_eq!(s.exit, [-65536.0 * MARGIN; 3]);
    }

    #[test]
    fn a_nan_origin_does_not_spread_to_other_axes() {
        let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
        let s = shifted::<f32>(&b, &[f32::NAN, 0.0, 0.0], &[false; 3]);
        assert!(s.entry[0].is_nan());
        assert_eq!(s.entry[1], MARGIN);
    }

    #[test]
    fn lanes_equal_scalars() {
        use crate::simd::F4;
        let b = Aabb::new(Vec3A::splat(-3.0), Vec3A::splat(5.0));
        let o = [
            [1.0f32, -9.0, 0.0, 7.5],
            [0.5, 2.0, -0.0, 1e6],
            [3.0, 3.0, 3.0, -2.0],
        ];
        let n = [
            [false, true, true, false],
            [true, true, false, false],
            [false; 4],
        ];
        let org = o.map(F4::from);
        let neg = n.map(|l| F4::mask_from_bits(l.iter().rev().fold(0, |b, &x| b << 1 | x as u32)));
        let s4 = shifted::<F4>(&b, &org, &neg);
        for i in 0..4 {
            let s1 = shifted::<f32>(
                &b,
                &[o[0][i], o[1][i], o[2][i]],
                &[n[0][i], n[1][i], n[2][i]],
            );
            for a in 0..3 {
                assert_eq!(s4.entry[a].as_array()[i].to_bits(), s1.entry[a].to_bits());
                assert_eq!(s4.exit[a].as_array()[i].to_bits(), s1.exit[a].to_bits());
            }
        }
    }
}
