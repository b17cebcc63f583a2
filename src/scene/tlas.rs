//! The top level: a binary BVH over the instances' world boxes (Wald,
//! Boulos and Shirley 2007's binned SAH; tinybvh's and obvhs' TLAS), rebuilt
//! from scratch whenever instances move, which takes well under a
//! millisecond per hundred instances (docs/instances.md). A BVH and not a
//! kd-tree here: instances overlap (a kd-tree would reference them from
//! many cells and visit them repeatedly), and a build over boxes needs no
//! clipping.
//!
//! Boxes are tested with the ray's origin moved by the scene's pad
//! (`transform::Pad`), as the kd traversal moves it by its margin
//! (`kdtree/margin.rs`): entries earlier and exits later, so that no
//! rounding in the world-to-object transform culls an instance whose
//! object-space ray hits it.

use crate::aabb::{Aabb, slab};
use crate::kdtree::Stack;
use crate::simd::Lane;

/// How the top level is built: binned SAH (the default) or object median
/// splits (faster to build, slower to trace; docs/instances.md).
///
/// ```
/// assert_eq!(packtrace::scene::TopLevel::default(), packtrace::scene::TopLevel::Sah);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum TopLevel {
    /// Binned SAH over the box centroids, 16 bins per axis.
    #[default]
    Sah,
    /// Split at the median centroid on the box's longest axis.
    Median,
}

/// SAH bins per axis.
const BINS: usize = 16;
/// Depth below which SAH splits are used; then median splits, so that a
/// tree over up to 2^32 instances is at most `SAH_DEPTH + 32` deep.
const SAH_DEPTH: usize = 48;
/// Traversal stack entries: one per level and one more.
const STACK: usize = SAH_DEPTH + 34;
/// Instances per leaf at most.
const MAX_LEAF: usize = 4;

/// A node: a leaf lists `count` instances from `first` in `Tlas::items`;
/// an interior node (`count == 0`) has children `first` and `first + 1`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Node {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
}

/// The BVH: nodes (root first) and instance ids in leaf order.
#[derive(Clone, Debug, Default)]
pub(crate) struct Tlas {
    pub nodes: Vec<Node>,
    pub items: Vec<u32>,
}

impl Tlas {
    /// A BVH over `(instance id, world box)` pairs.
    pub fn build(boxes: &[(u32, Aabb)], how: TopLevel) -> Tlas {
        let mut t = Tlas {
            nodes: Vec::with_capacity(2 * boxes.len()),
            items: Vec::with_capacity(boxes.len()),
        };
        if boxes.is_empty() {
            return t;
        }
        let mut work: Vec<(u32, Aabb, [f32; 3])> = boxes
            .iter()
            .map(|&(id, b)| (id, b, ((b.min + b.max) * 0.5).to_array()))
            .collect();
        t.nodes.push(Node {
            bounds: Aabb::EMPTY,
            first: 0,
            count: 0,
        });
        t.subdivide(0, &mut work, how, 0);
        t
    }

    fn subdivide(
        &mut self,
        node: usize,
        work: &mut [(u32, Aabb, [f32; 3])],
        how: TopLevel,
        depth: usize,
    ) {
        let bounds = work.iter().fold(Aabb::EMPTY, |b, w| union(&b, &w.1));
        self.nodes[node].bounds = bounds;
        let split = if work.len() <= 1 {
            None
        } else {
            match how {
                // Past SAH_DEPTH, median splits bound the depth (and the
                // traversal stacks) whatever the boxes.
                TopLevel::Sah if depth < SAH_DEPTH => sah_split(work, &bounds),
                TopLevel::Sah => Some(median_split(work)),
                TopLevel::Median => Some(median_split(work)),
            }
        };
        let split = match split {
            Some(s) => Some(s),
            // No split pays, but a leaf may not grow past MAX_LEAF.
            None if work.len() > MAX_LEAF => Some(median_split(work)),
            None => None,
        };
        let Some(mid) = split else {
            self.nodes[node].first = self.items.len() as u32;
            self.nodes[node].count = work.len() as u32;
            self.items.extend(work.iter().map(|w| w.0));
            return;
        };
        let first = self.nodes.len();
        self.nodes[node].first = first as u32;
        for _ in 0..2 {
            self.nodes.push(Node {
                bounds: Aabb::EMPTY,
                first: 0,
                count: 0,
            });
        }
        let (lo, hi) = work.split_at_mut(mid);
        self.subdivide(first, lo, how, depth + 1);
        self.subdivide(first + 1, hi, how, depth + 1);
    }
}

fn union(a: &Aabb, b: &Aabb) -> Aabb {
    Aabb::new(a.min.min(b.min), a.max.max(b.max))
}

fn area(b: &Aabb) -> f32 {
    let d = (b.max - b.min).max(glam::Vec3A::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// Sorts `work` by centroid on the longest axis of the centroids' box and
/// returns the middle.
fn median_split(work: &mut [(u32, Aabb, [f32; 3])]) -> usize {
    let axis = longest_centroid_axis(work).0;
    work.sort_unstable_by(|a, b| a.2[axis].total_cmp(&b.2[axis]).then(a.0.cmp(&b.0)));
    work.len() / 2
}

fn longest_centroid_axis(work: &[(u32, Aabb, [f32; 3])]) -> (usize, [f32; 3], [f32; 3]) {
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for w in work {
        for a in 0..3 {
            lo[a] = lo[a].min(w.2[a]);
            hi[a] = hi[a].max(w.2[a]);
        }
    }
    let ext = [0, 1, 2].map(|a| hi[a] - lo[a]);
    let axis = if ext[0] >= ext[1] && ext[0] >= ext[2] {
        0
    } else if ext[1] >= ext[2] {
        1
    } else {
        2
    };
    (axis, lo, hi)
}

/// The cheapest binned SAH split over all three axes, or `None` when a
/// leaf is cheaper (traversal cost 1, one instance 1: an instance costs at
/// least a box test and a transform). Partitions `work` at the split.
fn sah_split(work: &mut [(u32, Aabb, [f32; 3])], bounds: &Aabb) -> Option<usize> {
    let (_, lo, hi) = longest_centroid_axis(work);
    let mut best: Option<(f32, usize, usize)> = None; // cost, axis, bin
    for axis in 0..3 {
        let ext = hi[axis] - lo[axis];
        if ext.is_nan() || ext <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / ext;
        let bin_of = |c: f32| (((c - lo[axis]) * scale) as usize).min(BINS - 1);
        let mut count = [0u32; BINS];
        let mut boxes = [Aabb::EMPTY; BINS];
        for w in work.iter() {
            let b = bin_of(w.2[axis]);
            count[b] += 1;
            boxes[b] = union(&boxes[b], &w.1);
        }
        // Sweep: areas and counts left of each plane, then right.
        let mut left_area = [0.0f32; BINS];
        let mut left_count = [0u32; BINS];
        let (mut b, mut n) = (Aabb::EMPTY, 0);
        for i in 0..BINS - 1 {
            b = union(&b, &boxes[i]);
            n += count[i];
            left_area[i] = area(&b);
            left_count[i] = n;
        }
        let (mut b, mut n) = (Aabb::EMPTY, 0);
        for i in (1..BINS).rev() {
            b = union(&b, &boxes[i]);
            n += count[i];
            let l = left_count[i - 1];
            if l == 0 || n == 0 {
                continue;
            }
            let cost = left_area[i - 1] * l as f32 + area(&b) * n as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i));
            }
        }
    }
    let (cost, axis, bin) = best?;
    let leaf_cost = area(bounds) * work.len() as f32;
    if 1.0 * area(bounds) + cost >= leaf_cost && work.len() <= MAX_LEAF {
        return None;
    }
    let scale = BINS as f32 / (hi[axis] - lo[axis]);
    let lo_axis = lo[axis];
    let left = |w: &(u32, Aabb, [f32; 3])| {
        ((((w.2[axis] - lo_axis) * scale) as usize).min(BINS - 1)) < bin
    };
    // Stable partition by id order within each side keeps the tree a
    // function of the instances alone.
    work.sort_by_key(|w| (!left(w), w.0));
    Some(work.iter().filter(|w| left(w)).count())
}

/// A ray (or lanes) set up for the top level: origins moved by the pad.
pub(crate) struct PaddedRay<L: Lane> {
    entry: [L; 3],
    exit: [L; 3],
    inv_dir: [L; 3],
    neg: [L::Mask; 3],
}

impl<L: Lane> PaddedRay<L> {
    /// `org` moved forwards by the pad for entries and backwards for exits
    /// (`k1 |o| + k0`, `|o|` the largest origin coordinate magnitude).
    #[inline(always)]
    pub fn new(org: &[L; 3], inv_dir: &[L; 3], neg: [L::Mask; 3], k1: f32, k0: f32) -> Self {
        let m = org[0].abs().max_keep(org[1].abs()).max_keep(org[2].abs());
        let pad = m * L::splat(k1) + L::splat(k0);
        let zero = L::splat(0.0);
        let fwd = [0, 1, 2].map(|a| L::select(neg[a], zero - pad, pad));
        PaddedRay {
            entry: [0, 1, 2].map(|a| org[a] + fwd[a]),
            exit: [0, 1, 2].map(|a| org[a] - fwd[a]),
            inv_dir: *inv_dir,
            neg,
        }
    }

    /// The padded slab test of a node's box over `(t_min, t_max)`.
    #[inline(always)]
    pub fn test(&self, b: &Aabb, t_min: L, t_max: L) -> (L::Mask, L) {
        let (m, t0, _) = slab(
            b,
            &self.entry,
            &self.exit,
            &self.inv_dir,
            &self.neg,
            t_min,
            t_max,
        );
        (m, t0)
    }
}

impl Tlas {
    /// The instances of a root that is a leaf (up to `MAX_LEAF`), or
    /// `None` for an empty top level or one with interior nodes.
    #[inline]
    pub fn lone_leaf(&self) -> Option<&[u32]> {
        let root = self.nodes.first()?;
        (root.count > 0).then(|| &self.items[..root.count as usize])
    }

    /// Visits the instances whose padded boxes one ray meets, nearest box
    /// first. `leaf(id)` traces instance `id` and returns the ray's new
    /// `t_max` (`NaN` stops the walk: occlusion found).
    #[inline]
    pub fn walk_ray(
        &self,
        padded: impl FnOnce() -> PaddedRay<f32>,
        t_min: f32,
        mut t_max: f32,
        mut leaf: impl FnMut(u32) -> f32,
    ) {
        // A lone leaf (up to MAX_LEAF instances): no box test, no stack.
        // Each instance's tree clips the ray to its own box, so the test
        // would only repeat that. (`Scene::trace_ray` traces a leaf of one
        // instance without the walk.)
        if let Some(ids) = self.lone_leaf() {
            for &id in ids {
                if leaf(id).is_nan() {
                    return;
                }
            }
            return;
        }
        let Some(root) = self.nodes.first() else {
            return;
        };
        let r = &padded();
        let (m, t0) = r.test(&root.bounds, t_min, t_max);
        if !m {
            return;
        }
        // Uninitialised (`kdtree::Stack`): filling it was a 512-byte
        // memset per ray.
        let mut stack = Stack::<(u32, f32), STACK>::new();
        stack.push((0, t0));
        while let Some((n, t_enter)) = stack.pop() {
            // Deferred boxes that start past the closest hit are skipped.
            if t_enter > t_max {
                continue;
            }
            let node = &self.nodes[n as usize];
            if node.count > 0 {
                for &id in &self.items[node.first as usize..(node.first + node.count) as usize] {
                    t_max = leaf(id);
                    if t_max.is_nan() {
                        return;
                    }
                }
                continue;
            }
            // Both children, the nearer one on top of the stack.
            let (c0, c1) = (node.first, node.first + 1);
            let (m0, t0) = r.test(&self.nodes[c0 as usize].bounds, t_min, t_max);
            let (m1, t1) = r.test(&self.nodes[c1 as usize].bounds, t_min, t_max);
            let mut push = |c: u32, t: f32| stack.push((c, t));
            match (m0, m1) {
                (true, true) if t0 <= t1 => {
                    push(c1, t1);
                    push(c0, t0);
                }
                (true, true) => {
                    push(c0, t0);
                    push(c1, t1);
                }
                (true, false) => push(c0, t0),
                (false, true) => push(c1, t1),
                (false, false) => {}
            }
        }
    }

    /// Visits the instances whose padded boxes any of the `alive` lanes
    /// meets. `leaf(id, lanes, t_max)` traces instance `id` for `lanes`
    /// and lowers the lanes' `t_max` in place (`-inf` for a finished lane);
    /// the walk reads it back only when it has more to test.
    #[inline]
    pub fn walk_packet<L: Lane>(
        &self,
        padded: impl FnOnce() -> PaddedRay<L>,
        t_min: L,
        mut t_max: L,
        mut leaf: impl FnMut(u32, u32, &mut L),
    ) {
        // A lone leaf: no box test (as in `walk_ray`). `t_max` only falls,
        // so the lanes left are those still below it.
        if let Some(ids) = self.lone_leaf() {
            for &id in ids {
                let lanes = L::bits(t_min.le(t_max));
                if lanes == 0 {
                    return;
                }
                leaf(id, lanes, &mut t_max);
            }
            return;
        }
        if self.nodes.is_empty() {
            return;
        }
        let r = &padded();
        let mut stack = Stack::<u32, STACK>::new();
        stack.push(0);
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n as usize];
            // Tested when popped, against the lanes' current bounds.
            let (m, _) = r.test(&node.bounds, t_min, t_max);
            let mut lanes = L::bits(m);
            if lanes == 0 {
                continue;
            }
            if node.count > 0 {
                for &id in &self.items[node.first as usize..(node.first + node.count) as usize] {
                    leaf(id, lanes, &mut t_max);
                    lanes &= L::bits(t_min.le(t_max));
                    if lanes == 0 {
                        break;
                    }
                }
                continue;
            }
            // The child nearer to the lowest active lane goes on top.
            let i = lanes.trailing_zeros() as usize;
            let (c0, c1) = (node.first, node.first + 1);
            let d0 = r.test(&self.nodes[c0 as usize].bounds, t_min, t_max).1;
            let d1 = r.test(&self.nodes[c1 as usize].bounds, t_min, t_max).1;
            let (near, far) = if d0.lane(i) <= d1.lane(i) {
                (c0, c1)
            } else {
                (c1, c0)
            };
            stack.push(far);
            stack.push(near);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3A;

    fn boxes(n: u32) -> Vec<(u32, Aabb)> {
        (0..n)
            .map(|i| {
                let c = Vec3A::new((i * 7 % 13) as f32, (i * 5 % 11) as f32, (i % 3) as f32);
                (i, Aabb::new(c, c + Vec3A::splat(0.5 + (i % 4) as f32)))
            })
            .collect()
    }

    /// Every instance sits in exactly one leaf, and every node's box
    /// contains its children's.
    #[test]
    fn trees_hold_each_instance_once_inside_their_boxes() {
        for how in [TopLevel::Sah, TopLevel::Median] {
            for n in [1, 2, 5, 100, 1000] {
                let b = boxes(n);
                let t = Tlas::build(&b, how);
                let mut seen = t.items.clone();
                seen.sort_unstable();
                assert_eq!(seen, (0..n).collect::<Vec<_>>());
                for node in &t.nodes {
                    if node.count == 0 {
                        for c in [node.first, node.first + 1] {
                            let cb = t.nodes[c as usize].bounds;
                            assert!(node.bounds.min.cmple(cb.min).all());
                            assert!(node.bounds.max.cmpge(cb.max).all());
                        }
                    } else {
                        assert!(node.count as usize <= MAX_LEAF);
                        for &id in &t.items[node.first as usize..(node.first + node.count) as usize]
                        {
                            let ib = b[id as usize].1;
                            assert!(node.bounds.min.cmple(ib.min).all());
                            assert!(node.bounds.max.cmpge(ib.max).all());
                        }
                    }
                }
                assert!(depth(&t, 0) <= SAH_DEPTH + 32, "depth {}", depth(&t, 0));
            }
        }
    }

    fn depth(t: &Tlas, n: usize) -> usize {
        let node = t.nodes[n];
        if node.count > 0 {
            1
        } else {
            1 + depth(t, node.first as usize).max(depth(t, node.first as usize + 1))
        }
    }

    #[test]
    fn identical_boxes_still_build() {
        let b: Vec<_> = (0..50)
            .map(|i| (i, Aabb::new(Vec3A::ZERO, Vec3A::ONE)))
            .collect();
        let t = Tlas::build(&b, TopLevel::Sah);
        assert_eq!(t.items.len(), 50);
        assert!(depth(&t, 0) < 40);
    }

    /// Boxes spaced so that every SAH split peels off one: the depth
    /// stays bounded by the median fallback.
    #[test]
    fn exponentially_spaced_boxes_stay_within_the_stack() {
        let b: Vec<_> = (0..3000u32)
            .map(|i| {
                let x = 1.01f32.powi(i as i32);
                (
                    i,
                    Aabb::new(Vec3A::new(x, 0.0, 0.0), Vec3A::new(x * 1.001, 1.0, 1.0)),
                )
            })
            .collect();
        let t = Tlas::build(&b, TopLevel::Sah);
        assert!(depth(&t, 0) < STACK, "depth {}", depth(&t, 0));
    }
}
