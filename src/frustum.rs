//! The bounding frustum of a ray group: a convex cone with its apex at the
//! group's common origin (pinhole primary rays) or common target (shadow
//! rays toward a point light), bounded by four planes through the apex,
//! the plane through the apex across the main axis, and, when every ray
//! ends, a far cap and the box of the rays' end points. Reshetov,
//! Soupikov and Hurley's MLRTA (2005) steers a tile through a kd-tree
//! with such a frustum; Wald, Boulos and Shirley (2007) use the same
//! bound as interval arithmetic on the group's direction slopes.
//!
//! Everything here is conservative and in `f64`: the cone is built from
//! the exact end points of every ray's segment (`origin + t * dir` at
//! `t_min` and `t_max`, or `dir` itself for an endless ray), whose f64
//! values differ from the real ones by a relative `2^-52`; and a box or a
//! triangle is declared outside only when it is outside by more than the
//! traversal's margin (`kdtree/margin.rs`) widened twice. So a cell or
//! triangle that any ray of the group can reach, as the scalar traversal
//! and the triangle test see it, is never culled.

use crate::packet::RayPacket;
use crate::simd::{Lane, set_bits};
use glam::Vec3;

/// Groups whose direction slopes spread over more than this across the
/// main axis on either side axis get no frustum (about 53 degrees): their
/// frustum would cull little and the group is traced packet by packet.
/// Primary tiles of the protocol camera spread over about 0.01-0.05.
pub(crate) const MAX_SLOPE_SPREAD: f64 = 1.0;

/// Which end of its rays a group's apex is.
///
/// ```
/// use packtrace::group::Apex;
/// assert_ne!(Apex::Origin, Apex::Target);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Apex {
    /// The rays start at (or near) the apex: a pinhole camera's primary
    /// rays. Cells are visited nearest the apex first.
    Origin,
    /// The rays end at (or near) the apex: shadow rays toward a point
    /// light. Cells are visited farthest from the apex first.
    Target,
}

/// A half-space `n . x + c >= 0`.
#[derive(Clone, Copy, Debug, Default)]
struct Plane {
    n: [f64; 3],
    c: f64,
    /// `|n_x| + |n_y| + |n_z|`: how much `n . x` moves when `x` moves by 1
    /// along every axis.
    norm1: f64,
    /// Per axis, whether a box's largest value of `n . x` is at its upper
    /// face (`n >= 0`).
    at_hi: [bool; 3],
}

impl Plane {
    fn new(n: [f64; 3], c: f64) -> Plane {
        Plane {
            n,
            c,
            norm1: n.iter().map(|v| v.abs()).sum(),
            at_hi: n.map(|v| v >= 0.0),
        }
    }

    #[inline(always)]
    fn eval(&self, x: [f64; 3]) -> f64 {
        self.n[0] * x[0] + self.n[1] * x[1] + self.n[2] * x[2] + self.c
    }

    /// The largest value over the box `[lo, hi]`.
    #[inline(always)]
    fn max_over(&self, lo: &[f64; 3], hi: &[f64; 3]) -> f64 {
        let x = [0, 1, 2].map(|a| if self.at_hi[a] { hi[a] } else { lo[a] });
        self.eval(x)
    }
}

/// The largest value of each plane over one (widened) cell: a cell is
/// outside the frustum when one of them is negative. A child cell moves
/// one face, so its values follow from its parent's with one
/// multiply-add per plane ([`Frustum::child_values`]).
pub(crate) type CellValues = [f64; 6];

/// The group's cone (see the module text).
#[derive(Clone, Debug)]
pub(crate) struct Frustum {
    /// The apex.
    pub apex: [f64; 3],
    /// Which end of the rays the apex is.
    pub kind: Apex,
    planes: [Plane; 6],
    count: usize,
    /// The box of every segment's end points, when every ray ends.
    ends: Option<([f64; 3], [f64; 3])>,
    /// The largest coordinate magnitude of any origin (the margin's `M`).
    pub org_mag: f32,
}

impl Frustum {
    /// The cone from `apex` that holds every active lane's segment, or
    /// `None` when no such cone of at most [`MAX_SLOPE_SPREAD`] exists
    /// (rays on both sides of the apex along every axis, a diverging
    /// group) or no lane is active.
    pub fn of_packets<L: Lane>(
        packets: &[RayPacket<L>],
        apex: Vec3,
        kind: Apex,
    ) -> Option<Frustum> {
        let apex = apex.to_array().map(f64::from);
        if !apex.iter().all(|v| v.is_finite()) {
            return None;
        }
        // Main axis: the first active lane's largest direction component,
        // pointing away from the apex (a coherent group shares it; if not,
        // some generator lies behind the apex plane and there is no cone).
        let first = packets.iter().find(|p| p.active() != 0)?;
        let i0 = first.active().trailing_zeros() as usize;
        let d0 = first.dir().map(|d| d.lane(i0));
        let k = (0..3).max_by(|&a, &b| d0[a].abs().total_cmp(&d0[b].abs()))?;
        let away = if kind == Apex::Origin { 1.0 } else { -1.0 };
        let sigma = if f64::from(d0[k]) * away >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let (a, b) = ((k + 1) % 3, (k + 2) % 3);
        // Slopes of every generator: end points seen from the apex, or the
        // direction of an endless ray.
        let mut lo = [f64::INFINITY; 2];
        let mut hi = [f64::NEG_INFINITY; 2];
        let mut u_max = 0.0f64;
        let mut finite = true;
        let mut ends_lo = [f64::INFINITY; 3];
        let mut ends_hi = [f64::NEG_INFINITY; 3];
        let mut org_mag = 0.0f32;
        // One generator `g`: an end point's offset from the apex (which
        // also widens the end points' box and the far cap), or an endless
        // ray's direction. False when it points behind the apex plane.
        let mut take = |g: [f64; 3], is_point: bool| -> bool {
            if is_point {
                for x in 0..3 {
                    ends_lo[x] = ends_lo[x].min(g[x] + apex[x]);
                    ends_hi[x] = ends_hi[x].max(g[x] + apex[x]);
                }
                u_max = u_max.max(sigma * g[k]);
            }
            if g == [0.0; 3] {
                return true; // the apex itself
            }
            let w = sigma * g[k];
            if w.is_nan() || w <= 0.0 {
                return false;
            }
            let inv = 1.0 / g[k];
            for (j, ax) in [a, b].into_iter().enumerate() {
                let s = g[ax] * inv;
                lo[j] = lo[j].min(s);
                hi[j] = hi[j].max(s);
            }
            true
        };
        for p in packets {
            let (po, pd, t0, t1) = (p.org(), p.dir(), p.t_min(), p.t_max());
            for i in set_bits(p.active()) {
                let o = po.map(|v| f64::from(v.lane(i)));
                let d = pd.map(|v| f64::from(v.lane(i)));
                org_mag = org_mag.max(po.iter().fold(0.0f32, |m, v| m.max(v.lane(i).abs())));
                let from_apex = |t: f32| [0, 1, 2].map(|x| o[x] + f64::from(t) * d[x] - apex[x]);
                let t_max = t1.lane(i);
                let ok = take(from_apex(t0.lane(i)), true)
                    && if t_max.is_finite() {
                        take(from_apex(t_max), true)
                    } else {
                        finite = false;
                        take(d, false)
                    };
                if !ok {
                    return None;
                }
            }
        }
        // Every generator was the apex: a group of empty segments there.
        if lo[0] > hi[0] {
            for j in 0..2 {
                lo[j] = 0.0;
                hi[j] = 0.0;
            }
        }
        if (0..2).any(|j| hi[j] - lo[j] > MAX_SLOPE_SPREAD) {
            return None;
        }
        // Widen by far more than the f64 rounding of the slopes.
        for j in 0..2 {
            lo[j] -= 1e-9 * (1.0 + lo[j].abs());
            hi[j] += 1e-9 * (1.0 + hi[j].abs());
        }
        let mut planes = [Plane::default(); 6];
        let mut count = 0;
        let mut push = |p: Plane| {
            planes[count] = p;
            count += 1;
        };
        for (j, ax) in [a, b].into_iter().enumerate() {
            // sigma (x_ax - A_ax) >= lo * sigma (x_k - A_k)
            let mut n = [0.0; 3];
            n[ax] = sigma;
            n[k] = -lo[j] * sigma;
            push(Plane::new(n, -sigma * apex[ax] + lo[j] * sigma * apex[k]));
            // sigma (x_ax - A_ax) <= hi * sigma (x_k - A_k)
            let mut n = [0.0; 3];
            n[ax] = -sigma;
            n[k] = hi[j] * sigma;
            push(Plane::new(n, sigma * apex[ax] - hi[j] * sigma * apex[k]));
        }
        // The apex's plane across the main axis: u = sigma (x_k - A_k) >= 0.
        let mut n = [0.0; 3];
        n[k] = sigma;
        push(Plane::new(n, -sigma * apex[k]));
        // The far cap, when every ray ends: u <= u_max.
        if finite {
            let mut n = [0.0; 3];
            n[k] = -sigma;
            let u_max = u_max * (1.0 + 1e-9) + 1e-30;
            push(Plane::new(n, u_max + sigma * apex[k]));
        }
        Some(Frustum {
            apex,
            kind,
            planes,
            count,
            ends: finite.then_some((ends_lo, ends_hi)),
            org_mag,
        })
    }

    /// [`CellValues`] of the box `[lo, hi]` widened by `eta`, or `None`
    /// when it lies outside the end points' box.
    #[inline]
    pub fn cell_values(&self, lo: &[f32; 3], hi: &[f32; 3], eta: f64) -> Option<CellValues> {
        let lo = lo.map(|v| f64::from(v) - eta);
        let hi = hi.map(|v| f64::from(v) + eta);
        if let Some((elo, ehi)) = &self.ends
            && (0..3).any(|a| hi[a] < elo[a] || lo[a] > ehi[a])
        {
            return None;
        }
        let mut v = [f64::INFINITY; 6];
        for (v, p) in v.iter_mut().zip(&self.planes[..self.count]) {
            *v = p.max_over(&lo, &hi);
        }
        Some(v)
    }

    /// Is a cell with these values outside the frustum?
    #[inline(always)]
    pub fn outside(v: &CellValues) -> bool {
        v.iter().any(|&x| x < 0.0)
    }

    /// The values of a child of the cell (values `v`, extent `(lo, hi)`
    /// on `axis`) split at
    /// `split` on `axis`: the lower child (`below`) moves its upper face
    /// to the plane, the upper child its lower face; both widened by
    /// `eta`. `None` when the child lies outside the end points' box.
    #[inline(always)]
    pub fn child_values(
        &self,
        v: &CellValues,
        (lo, hi): (f32, f32),
        axis: usize,
        split: f32,
        below: bool,
        eta: f64,
    ) -> Option<CellValues> {
        let (old, new) = if below {
            (f64::from(hi) + eta, f64::from(split) + eta)
        } else {
            (f64::from(lo) - eta, f64::from(split) - eta)
        };
        if let Some((elo, ehi)) = &self.ends
            && (if below {
                new < elo[axis]
            } else {
                new > ehi[axis]
            })
        {
            return None;
        }
        let mut out = *v;
        for (o, p) in out.iter_mut().zip(&self.planes[..self.count]) {
            // Only a plane whose maximum sits on the moved face changes.
            if p.at_hi[axis] == below {
                *o += p.n[axis] * (new - old);
            }
        }
        Some(out)
    }

    /// Is the box `[lo, hi]`, widened by `eta` on every side, entirely
    /// outside the cone (or the end points' box)? The whole-box form of
    /// [`Frustum::cell_values`], for tests.
    #[cfg(test)]
    pub fn misses_box(&self, lo: &[f32; 3], hi: &[f32; 3], eta: f64) -> bool {
        self.cell_values(lo, hi, eta)
            .is_none_or(|v| Frustum::outside(&v))
    }

    /// Can no ray of the group hit the triangle? True when all three
    /// corners lie outside one plane by more than `eta` along every axis
    /// (a reported hit lies within the margin of its triangle,
    /// `triangle.rs`), or outside the end points' box by more than `eta`.
    #[inline]
    pub fn misses_triangle(&self, tri: &[Vec3; 3], eta: f64) -> bool {
        let v = tri.map(|c| c.to_array().map(f64::from));
        if let Some((elo, ehi)) = &self.ends
            && (0..3).any(|a| {
                v.iter().all(|c| c[a] + eta < elo[a]) || v.iter().all(|c| c[a] - eta > ehi[a])
            })
        {
            return true;
        }
        self.planes[..self.count].iter().any(|p| {
            let slack = -eta * p.norm1;
            v.iter().all(|&c| p.eval(c) < slack)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::packet::RayPacket8;
    use crate::ray::Ray;

    fn fan(origin: Vec3, spread: f32) -> RayPacket8 {
        RayPacket8::from_fn(|i| {
            let d = Vec3::new(spread * (i as f32 - 3.5), 0.1 * spread, -1.0);
            Ray::new(origin, d, 0.0, f32::INFINITY).ok()
        })
    }

    #[test]
    fn a_fan_from_a_point_bounds_its_rays_and_culls_boxes_outside() {
        let o = Vec3::new(0.0, 0.0, 5.0);
        let f = Frustum::of_packets(&[fan(o, 0.01)], o, Apex::Origin).unwrap();
        // In front of the camera, on the axis: inside.
        assert!(!f.misses_box(&[-0.1, -0.1, -1.0], &[0.1, 0.1, 0.0], 0.0));
        // Behind the camera: outside the apex plane.
        assert!(f.misses_box(&[-1.0, -1.0, 6.0], &[1.0, 1.0, 7.0], 0.0));
        // Far to the side: outside a slope plane.
        assert!(f.misses_box(&[3.0, -0.1, -1.0], &[4.0, 0.1, 0.0], 0.0));
        // The same box widened by its distance is not culled.
        assert!(!f.misses_box(&[3.0, -0.1, -1.0], &[4.0, 0.1, 0.0], 3.0));
        let far_tri = [
            Vec3::new(3.0, 0.0, 0.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(3.0, 1.0, 0.0),
        ];
        assert!(f.misses_triangle(&far_tri, 0.0));
        let big = [
            Vec3::new(-9.0, -9.0, 0.0),
            Vec3::new(9.0, -9.0, 0.0),
            Vec3::new(0.0, 9.0, 0.0),
        ];
        assert!(!f.misses_triangle(&big, 0.0));
    }

    #[test]
    fn child_values_equal_the_child_boxes_values() {
        let o = Vec3::new(0.3, -0.2, 5.0);
        let f = Frustum::of_packets(&[fan(o, 0.05)], o, Apex::Origin).unwrap();
        let (lo, hi) = ([-2.0f32, -1.5, -3.0], [2.5f32, 1.0, 1.0]);
        let eta = 1e-3;
        let v = f.cell_values(&lo, &hi, eta).unwrap();
        for axis in 0..3 {
            for split in [-0.5f32, 0.0, 0.75] {
                let (mut b_hi, mut a_lo) = (hi, lo);
                b_hi[axis] = split;
                a_lo[axis] = split;
                let below = f
                    .child_values(&v, (lo[axis], hi[axis]), axis, split, true, eta)
                    .unwrap();
                let above = f
                    .child_values(&v, (lo[axis], hi[axis]), axis, split, false, eta)
                    .unwrap();
                let want_b = f.cell_values(&lo, &b_hi, eta).unwrap();
                let want_a = f.cell_values(&a_lo, &hi, eta).unwrap();
                for i in 0..f.count {
                    assert!((below[i] - want_b[i]).abs() < 1e-12, "{axis} {split} {i}");
                    assert!((above[i] - want_a[i]).abs() < 1e-12, "{axis} {split} {i}");
                }
                assert_eq!(Frustum::outside(&below), f.misses_box(&lo, &b_hi, eta));
            }
        }
    }

    #[test]
    fn diverging_groups_and_rays_behind_the_apex_get_no_frustum() {
        let o = Vec3::ZERO;
        assert!(Frustum::of_packets(&[fan(o, 1.0)], o, Apex::Origin).is_none());
        // Apex on the wrong side: the rays start behind it.
        assert!(
            Frustum::of_packets(&[fan(o, 0.01)], Vec3::new(0.0, 0.0, -1.0), Apex::Origin).is_none()
        );
        assert!(
            Frustum::of_packets(&[RayPacket8::from_lanes([None; 8])], o, Apex::Origin).is_none()
        );
    }

    #[test]
    fn a_shadow_group_toward_a_light_has_a_far_cap_and_an_end_box() {
        let light = Vec3::new(0.0, 10.0, 0.0);
        let p = RayPacket8::from_fn(|i| {
            let q = Vec3::new(i as f32 * 0.1, 0.0, 0.0);
            let to = light - q;
            Ray::new(q, to.normalize(), 0.0, to.length() * 0.999).ok()
        });
        let f = Frustum::of_packets(&[p], light, Apex::Target).unwrap();
        assert_eq!(f.count, 6);
        // Below the origins: outside the end-point box and the far cap.
        assert!(f.misses_box(&[0.0, -2.0, 0.0], &[1.0, -1.0, 0.0], 0.0));
        // Between the points and the light.
        assert!(!f.misses_box(&[0.0, 4.0, -0.01], &[0.5, 5.0, 0.01], 0.0));
        // Beyond the light.
        assert!(f.misses_box(&[-1.0, 11.0, -1.0], &[1.0, 12.0, 1.0], 0.0));
    }
}
