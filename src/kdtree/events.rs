//! Split candidates sorted once (Wald & Havran 2006, "On building fast
//! kd-trees for ray tracing, and on doing that in O(N log N)", section 4.2).
//!
//! An exact-sweep node keeps, per axis, the edges ("events") of its
//! references' boxes sorted by position. Finding the best split is one
//! sweep over them; splitting the node keeps each one-sided reference's
//! events in order (a filter, O(n)) and sorts only the events of the
//! straddlers, whose boxes the split clipped, before merging them in. The
//! per-node sort of the earlier sweep (O(n log n) per node, O(N log^2 N)
//! in all) is gone: the events are sorted once, where a node first needs
//! them (the root, or the first node below the binned levels).
//!
//! Without clipping, a straddler's box in a child is its box cut at the
//! split, so even its events stay in place: only its edge beyond the split
//! moves to the split's position, the last below and the first above
//! ([`Events::split`]'s `unclipped`).
//!
//! The sweep counts exactly as the sorting sweep did (the tests build
//! both and compare every node), so the trees are unchanged.

use super::clip::{NONE, PrimRef};

/// One box edge of one reference on one axis, packed into a `u64` so that
/// integer order is position order: the order-preserving key of the
/// position in the high 32 bits, then the reference's index in its node
/// (30 bits) and the kind of edge (2 bits).
pub(crate) type Event = u64;

/// The box's upper edge (`hi`, the box not flat on this axis).
const END: u64 = 0;
/// The box flat on this axis: `lo == hi`.
const PLANAR: u64 = 1;
/// The box's lower edge (`lo`, the box not flat on this axis).
const START: u64 = 2;

/// Nodes with this many references or more have no room for their
/// indices in an [`Event`] and use the binned sweep.
pub(crate) const MAX_REFS: usize = 1 << 30;

/// The order-preserving integer key of an `f32`: keys compare as
/// `f32::total_cmp` compares the values. `-0.0` becomes `+0.0` first, so
/// that positions equal as floats share one key (the sweep groups by key).
#[inline]
pub(crate) fn key(x: f32) -> u32 {
    let b = (x + 0.0).to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// The value of a [`key`].
#[inline]
pub(crate) fn value(k: u32) -> f32 {
    f32::from_bits(if k >> 31 == 1 { k & !(1 << 31) } else { !k })
}

#[inline]
fn event(pos: f32, index: u32, kind: u64) -> Event {
    (u64::from(key(pos)) << 32) | (u64::from(index) << 2) | kind
}

/// The kind of edge (END, PLANAR, START) as an index.
#[inline]
fn kind(e: Event) -> usize {
    (e & 3) as usize
}

#[inline]
fn index(e: Event) -> usize {
    ((e as u32) >> 2) as usize
}

/// `e` with its reference index replaced by `i`.
#[inline]
fn renumbered(e: Event, i: u32) -> Event {
    (e & 0xFFFF_FFFF_0000_0003) | (u64::from(i) << 2)
}

/// A node's events, per axis, sorted by position (integer order of the
/// high 32 bits; events at one position are in no particular order). One
/// allocation per node: axis `k` is `data[start[k]..start[k + 1]]`.
#[derive(Default)]
pub(crate) struct Events {
    data: Vec<Event>,
    start: [usize; 4],
}

/// Buffers of one thread's splits, reused from node to node: the
/// straddlers' events per child and axis, and spent nodes' event arrays
/// for the children to come (malloc and free were a fifth of the deep
/// `pbrt` build's time without them).
#[derive(Default)]
pub(crate) struct EventBuffers {
    below: [Vec<Event>; 3],
    above: [Vec<Event>; 3],
    spare: Vec<Vec<Event>>,
    /// Bytes of the spare arrays (their capacity), for the build's ledger.
    spare_bytes: usize,
}

/// Spent event arrays a thread keeps for reuse.
const SPARE: usize = 64;

impl EventBuffers {
    /// Keep `ev`'s array for a later node.
    pub(crate) fn recycle(&mut self, ev: Events) {
        if self.spare.len() < SPARE {
            self.spare_bytes += ev.bytes();
            self.spare.push(ev.data);
        }
    }

    /// An array, reused when one is spare: its old events are still in
    /// it (a caller clears it or overwrites what it reads).
    fn array(&mut self) -> Vec<Event> {
        let v = self.spare.pop().unwrap_or_default();
        self.spare_bytes -= v.capacity() * size_of::<Event>();
        v
    }

    /// Bytes these buffers hold: the spare arrays and the straddlers'.
    pub(crate) fn bytes(&self) -> usize {
        let held = self.below.iter().chain(&self.above).map(Vec::capacity);
        self.spare_bytes + held.sum::<usize>() * size_of::<Event>()
    }
}

/// Push the events of reference `r` (index `i`) on axis `a`.
#[inline]
fn push_edges(out: &mut Vec<Event>, r: &PrimRef, i: u32, a: usize) {
    if r.lo[a] == r.hi[a] {
        out.push(event(r.lo[a], i, PLANAR));
    } else {
        out.push(event(r.lo[a], i, START));
        out.push(event(r.hi[a], i, END));
    }
}

impl Events {
    /// The events of `refs` (fewer than [`MAX_REFS`]), sorted.
    pub(crate) fn of(refs: &[PrimRef], buffers: &mut EventBuffers) -> Events {
        debug_assert!(refs.len() < MAX_REFS);
        let mut ev = Events {
            data: {
                let mut data = buffers.array();
                data.clear();
                data
            },
            start: [0; 4],
        };
        for a in 0..3 {
            for (i, r) in refs.iter().enumerate() {
                push_edges(&mut ev.data, r, i as u32, a);
            }
            ev.start[a + 1] = ev.data.len();
            ev.data[ev.start[a]..].sort_unstable();
        }
        ev
    }

    /// The events of axis `axis`.
    pub(crate) fn axis(&self, axis: usize) -> &[Event] {
        &self.data[self.start[axis]..self.start[axis + 1]]
    }

    /// The events of the two children of a split: `sides` (one entry per
    /// reference of this node) says where each reference went, `below` /
    /// `above` are the children's references (a straddler's box clipped to
    /// its child). `None` for a child that needs no events (a leaf).
    ///
    /// `unclipped` is the split `(axis, s)` when the build does not clip
    /// (`split_clipping` off): a straddler's box in a child is then its
    /// box cut at `s` on the split axis and unchanged on the other two, so
    /// its events on those axes keep their places, and on the split axis
    /// only its edge beyond `s` moves to `s` (the largest position below,
    /// the smallest above). Nothing is re-sorted: the events equal, as
    /// sorted multisets, those rebuilt from the straddlers' cut boxes and
    /// merged in (the path for clipped straddlers), so the trees are the
    /// same.
    pub(crate) fn split(
        &self,
        sides: &[[u32; 2]],
        (below, above): (&[PrimRef], &[PrimRef]),
        (want_below, want_above): (bool, bool),
        unclipped: Option<(usize, f32)>,
        new: &mut EventBuffers,
    ) -> (Option<Events>, Option<Events>) {
        for v in new.below.iter_mut().chain(new.above.iter_mut()) {
            v.clear();
        }
        // Which straddler events stay in each child, per axis and kind
        // (END, PLANAR, START): none when the straddlers were clipped.
        let mut keep = [[[false; 3]; 3]; 2];
        if let Some((axis, s)) = unclipped {
            keep[0] = std::array::from_fn(|k| [k != axis, k != axis, true]);
            keep[1] = std::array::from_fn(|k| [true, k != axis, k != axis]);
            // The straddlers' edges at `s`: all at one position, so
            // already sorted.
            for &[b, a] in sides {
                if b != NONE && a != NONE {
                    new.below[axis].push(event(s, b, END));
                    new.above[axis].push(event(s, a, START));
                }
            }
        } else {
            // The straddlers' new events, sorted: few, so this sort is
            // cheap.
            for &[b, a] in sides {
                if b != NONE && a != NONE {
                    for k in 0..3 {
                        if want_below {
                            push_edges(&mut new.below[k], &below[b as usize], b, k);
                        }
                        if want_above {
                            push_edges(&mut new.above[k], &above[a as usize], a, k);
                        }
                    }
                }
            }
            for v in new.below.iter_mut().chain(new.above.iter_mut()) {
                v.sort_unstable();
            }
        }
        let data_below = want_below.then(|| new.array());
        let data_above = want_above.then(|| new.array());
        match (data_below, data_above) {
            // Monomorphised on `unclipped`: the clipping path's filter
            // does not look up `keep` (3 % more instructions in the
            // default build when it did).
            (Some(b), Some(a)) => {
                let (news, both) = ((&new.below, &new.above), (b, a));
                let (b, a) = if unclipped.is_some() {
                    self.children::<true>(sides, news, &keep, both)
                } else {
                    self.children::<false>(sides, news, &keep, both)
                };
                (Some(b), Some(a))
            }
            (b, a) => {
                let child = |side: usize, new, d| {
                    let keep = (side, &keep[side]);
                    if unclipped.is_some() {
                        self.child::<true>(sides, new, keep, d)
                    } else {
                        self.child::<false>(sides, new, keep, d)
                    }
                };
                (
                    b.map(|d| child(0, &new.below, d)),
                    a.map(|d| child(1, &new.above, d)),
                )
            }
        }
    }

    /// Bytes of the array (its capacity), for the build's ledger.
    pub(crate) fn bytes(&self) -> usize {
        self.data.capacity() * size_of::<Event>()
    }

    /// The events of child `side` (0 below, 1 above): the one-sided
    /// references' events, and the straddlers' that `keep` (per axis and
    /// kind) says stay (`KEEP`: any may), kept in order and renumbered,
    /// `new` merged in.
    fn child<const KEEP: bool>(
        &self,
        sides: &[[u32; 2]],
        new: &[Vec<Event>; 3],
        (side, keep): (usize, &[[bool; 3]; 3]),
        mut data: Vec<Event>,
    ) -> Events {
        let other = 1 - side;
        // Written branch-free: every event is stored, and the write
        // position advances only for the events this child keeps (the
        // branch on the side was mispredicted about every other event);
        // the spare slot takes the last write.
        sized_for(&mut data, self.data.len(), new);
        let mut start = [0; 4];
        let mut w = 0;
        for k in 0..3 {
            for &e in self.axis(k) {
                let s = sides[index(e)];
                data[w] = renumbered(e, s[side]);
                w += usize::from(s[other] == NONE || (KEEP && s[side] != NONE && keep[k][kind(e)]));
            }
            merge_back(&mut data, (start[k], &mut w), &new[k]);
            start[k + 1] = w;
        }
        data.truncate(w);
        Events { data, start }
    }

    /// [`Events::child`] for both children in one pass over this node's
    /// events: each event and its reference's sides are read once, not
    /// once per child (the two passes were a fifth of the default build's
    /// samples, bunny, `perf`).
    fn children<const KEEP: bool>(
        &self,
        sides: &[[u32; 2]],
        (new_below, new_above): (&[Vec<Event>; 3], &[Vec<Event>; 3]),
        [keep_below, keep_above]: &[[[bool; 3]; 3]; 2],
        (mut below, mut above): (Vec<Event>, Vec<Event>),
    ) -> (Events, Events) {
        sized_for(&mut below, self.data.len(), new_below);
        sized_for(&mut above, self.data.len(), new_above);
        let (mut start_below, mut start_above) = ([0; 4], [0; 4]);
        let (mut wb, mut wa) = (0, 0);
        for k in 0..3 {
            let (kb, ka) = (&keep_below[k], &keep_above[k]);
            for &e in self.axis(k) {
                let [b, a] = sides[index(e)];
                let both = b != NONE && a != NONE;
                below[wb] = renumbered(e, b);
                wb += usize::from(a == NONE || (KEEP && both && kb[kind(e)]));
                above[wa] = renumbered(e, a);
                wa += usize::from(b == NONE || (KEEP && both && ka[kind(e)]));
            }
            merge_back(&mut below, (start_below[k], &mut wb), &new_below[k]);
            merge_back(&mut above, (start_above[k], &mut wa), &new_above[k]);
            start_below[k + 1] = wb;
            start_above[k + 1] = wa;
        }
        below.truncate(wb);
        above.truncate(wa);
        (
            Events {
                data: below,
                start: start_below,
            },
            Events {
                data: above,
                start: start_above,
            },
        )
    }
}

/// `data` sized for a child's events: at most the parent's `kept` plus
/// the straddlers' `new`, and one spare slot for the branch-free filter's
/// last write. A spare array's old events are not cleared: the filter
/// writes every slot before anything reads it. Zeroing the whole array
/// was 7 % of the default build's instructions by callgrind (bunny), which
/// counts glibc's `memset` high: the change saved 1.7 %. Only the part
/// beyond the old length is zeroed now.
fn sized_for(data: &mut Vec<Event>, kept: usize, new: &[Vec<Event>; 3]) {
    let total = kept + new.iter().map(Vec::len).sum::<usize>();
    data.resize(total + 1, 0);
}

/// Merge the sorted `new` events into the sorted run `data[base..*w]`,
/// from the back, in place; `*w` moves past them.
#[inline]
fn merge_back(data: &mut [Event], (base, w): (usize, &mut usize), new: &[Event]) {
    let (mut i, mut j) = (*w - base, new.len());
    *w += new.len();
    while j > 0 {
        if i > 0 && data[base + i - 1] >> 32 > new[j - 1] >> 32 {
            data[base + i + j - 1] = data[base + i - 1];
            i -= 1;
        } else {
            data[base + i + j - 1] = new[j - 1];
            j -= 1;
        }
    }
}

/// The cheapest split of the sweep over one axis's sorted `events` of `n`
/// references, strictly inside `(lo, hi)`: `(position, cost, (nb, na))`,
/// the first (lowest) position among equal costs. Every distinct edge
/// position is a candidate; `cost(s, nb, na)` prices it with `nb`
/// references below
/// (boxes reaching below `s`, and boxes flat in the plane: they go below)
/// and `na` above (boxes reaching above `s`). Splits that give both
/// children every reference are no candidates.
pub(crate) fn sweep(
    events: &[Event],
    n: usize,
    (lo, hi): (f32, f32),
    cost: impl Fn(f32, usize, usize) -> f32,
) -> Option<(f32, f32, (usize, usize))> {
    // Events seen so far, by kind (END, PLANAR, START).
    let mut seen = [0usize; 3];
    let mut best: Option<(f32, f32, (usize, usize))> = None;
    // One candidate per position. Measured and rejected: a branch-free
    // sweep pricing every event as if it ended its position's group (the
    // loop per group mispredicts where vertex coordinates repeat): 15-30 %
    // slower builds, the extra pricing costs more than the mispredictions.
    let mut i = 0;
    while i < events.len() {
        let at = events[i] >> 32;
        // Starts strictly below this position.
        let starts_below = seen[START as usize];
        // Count the events at this position.
        while i < events.len() && events[i] >> 32 == at {
            seen[(events[i] & 3) as usize] += 1;
            i += 1;
        }
        let s = value(at as u32);
        if s <= lo || s >= hi {
            continue;
        }
        // Below: started below `s`, or flat at or below it. Above: every
        // box not ended (or flat) at or below `s`.
        let nb = starts_below + seen[PLANAR as usize];
        let na = n - seen[END as usize] - seen[PLANAR as usize];
        if nb == n && na == n {
            continue;
        }
        let c = cost(s, nb, na);
        if best.is_none_or(|(_, bc, _)| c < bc) {
            best = Some((s, c, (nb, na)));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn r(lo: [f32; 3], hi: [f32; 3]) -> PrimRef {
        PrimRef { prim: 0, lo, hi }
    }

    #[test]
    fn keys_sort_as_total_cmp_and_give_the_values_back() {
        let xs = [
            f32::NEG_INFINITY,
            f32::MIN,
            -1.0,
            -1.0e-45,
            0.0,
            1.0e-45,
            1.0,
            2.5,
            f32::MAX,
            f32::INFINITY,
        ];
        for w in xs.windows(2) {
            assert!(key(w[0]) < key(w[1]), "{} {}", w[0], w[1]);
        }
        for &x in &xs {
            assert_eq!(value(key(x)).to_bits(), x.to_bits());
        }
        // Both zeros share a key: the sweep groups them as one position.
        assert_eq!(key(-0.0), key(0.0));
    }

    #[test]
    fn events_pack_position_index_and_kind() {
        let e = event(2.5, 7, START);
        assert_eq!(value((e >> 32) as u32), 2.5);
        assert_eq!(index(e), 7);
        assert_eq!(e & 3, START);
        let moved = renumbered(e, (MAX_REFS - 1) as u32);
        assert_eq!(index(moved), MAX_REFS - 1);
        assert_eq!(moved >> 32, e >> 32);
        assert_eq!(moved & 3, START);
    }

    #[test]
    fn the_sweep_counts_by_the_classification_rule() {
        // [0,1], [1,2], flat at 1, [0.5,1.5] on x.
        let refs = [
            r([0.0; 3], [1.0; 3]),
            r([1.0; 3], [2.0; 3]),
            r([1.0, 0.0, 0.0], [1.0, 2.0, 2.0]),
            r([0.5; 3], [1.5; 3]),
        ];
        let ev = Events::of(&refs, &mut EventBuffers::default());
        // At 0.5: [0,1] below; all four above ([0,1] straddles).
        // At 1: [0,1], the flat box and [0.5,1.5] below; [1,2] and
        // [0.5,1.5] above. At 1.5: all four below, [1,2] above.
        let candidates = [(0.5, 1, 4), (1.0, 3, 2), (1.5, 4, 1)];
        for want in candidates {
            // Free exactly at `want`: the sweep finds it there.
            let best = sweep(ev.axis(0), refs.len(), (0.0, 2.0), |s, nb, na| {
                if (s, nb, na) == want { 0.0 } else { 1.0 + s }
            });
            assert_eq!(best, Some((want.0, 0.0, (want.1, want.2))), "{want:?}");
        }
        // Equal costs: the lowest position wins; none inside: no split.
        assert_eq!(
            sweep(ev.axis(0), 4, (0.0, 2.0), |_, _, _| 1.0),
            Some((0.5, 1.0, (1, 4)))
        );
        assert_eq!(sweep(ev.axis(0), 4, (1.5, 2.0), |_, _, _| 1.0), None);
    }

    #[test]
    fn splitting_keeps_the_children_sorted_and_renumbered() {
        let refs = [
            r([0.0; 3], [1.0; 3]),
            r([2.0; 3], [3.0; 3]),
            r([0.5; 3], [2.5; 3]),
        ];
        let ev = Events::of(&refs, &mut EventBuffers::default());
        let mut new = EventBuffers::default();
        // Split x at 1.5: ref 0 below, ref 1 above, ref 2 both (clipped).
        let below = [refs[0], r([0.5; 3], [1.5, 2.5, 2.5])];
        let above = [refs[1], r([1.5, 0.5, 0.5], [2.5; 3])];
        let sides = [[0, NONE], [NONE, 0], [1, 1]];
        // The straddler's boxes are its box cut at x = 1.5: the clipping
        // path (re-sorted) and the unclipped one (kept in place) agree,
        // for both children at once and for each alone.
        for unclipped in [None, Some((0, 1.5))] {
            for want in [(true, true), (true, false), (false, true)] {
                let (b, a) = ev.split(&sides, (&below, &above), want, unclipped, &mut new);
                assert_eq!((b.is_some(), a.is_some()), want);
                for (child, refs) in [(b, &below[..]), (a, &above[..])] {
                    let Some(child) = child else { continue };
                    for k in 0..3 {
                        let exp = Events::of(refs, &mut EventBuffers::default());
                        let mut got = child.axis(k).to_vec();
                        let mut exp = exp.axis(k).to_vec();
                        assert!(got.windows(2).all(|w| w[0] >> 32 <= w[1] >> 32));
                        got.sort_unstable();
                        exp.sort_unstable();
                        assert_eq!(got, exp, "axis {k}, {unclipped:?}, {want:?}");
                    }
                }
            }
        }
    }
}
