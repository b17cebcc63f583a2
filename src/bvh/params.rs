//! Typed build parameters of the BVHs, their presets and build errors.

use std::fmt;

/// Deepest binary tree a build may make: the 8-wide tree collapsed from it
/// is no deeper, so the traversals' fixed stacks (64 entries for
/// [`Bvh2`](super::Bvh2), `7 * 64 + 1` for [`Bvh8`](super::Bvh8)) always
/// suffice. A build forces balanced (count-median) splits where the SAH
/// would go deeper (`build.rs`), so every mesh builds.
pub const BVH_MAX_DEPTH: u32 = 64;

/// Most bins per axis of the binned SAH sweep ([`BvhBuildParams::bins`]).
pub const BVH_MAX_BINS: u32 = 256;

/// How a binary node's triangles are split in two.
///
/// ```
/// use packtrace::bvh::Split;
/// assert_eq!(Split::default(), Split::Sah);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Split {
    /// Binned surface area heuristic (Wald 2007, "On fast construction of
    /// SAH-based bounding volume hierarchies"): `bins` candidate planes per
    /// axis over the centroids' box, the cheapest split or a leaf.
    #[default]
    Sah,
    /// The lectures' split (Bridson's notes): at the median centroid along
    /// the longest axis of the centroids' box, down to `max_leaf_size`.
    Median,
}

/// BVH build parameters. Use a preset and adjust fields.
///
/// ```
/// use packtrace::bvh::{BvhBuildParams, Split};
/// let p = BvhBuildParams { bins: 16, ..BvhBuildParams::sah() };
/// assert_eq!(p.split, Split::Sah);
/// assert_eq!(BvhBuildParams::default(), BvhBuildParams::sah());
/// assert_eq!(BvhBuildParams::median().split, Split::Median);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BvhBuildParams {
    /// How nodes are split.
    pub split: Split,
    /// Bins per axis of the SAH sweep, in `2..=`[`BVH_MAX_BINS`]. A node
    /// of `n` triangles uses `min(bins, 4 + n / 20)` of them (Embree's
    /// rule), so small nodes bin cheaply.
    pub bins: u32,
    /// Cost of one traversal step (SAH `C_t`), finite and `> 0`.
    pub traversal_cost: f32,
    /// Cost of one leaf block test (SAH `C_i`), finite and `> 0`. The SAH
    /// counts a leaf of `n` triangles as `ceil(n / block)` block tests.
    pub intersection_cost: f32,
    /// Triangles tested together in the SAH's leaf cost: 4 for the 8-wide
    /// tree's SIMD blocks, 1 for the binary tree's one-at-a-time leaves; in
    /// `1..=8`.
    pub block: u32,
    /// Nodes with at most this many triangles may become leaves (the SAH
    /// decides); larger ones are always split. In `1..=`[`BVH_MAX_LEAF`].
    pub max_leaf_size: u32,
    /// The 8-wide tree only: subtrees of the binary tree with at most this
    /// many triangles become one leaf (blocks of four); 0 keeps the binary
    /// tree's leaves. In `0..=`[`BVH_MAX_LEAF`].
    pub merge_below: u32,
    /// Threads of the build. `None`: the caller's rayon pool; `Some(n)`: a
    /// pool of `n >= 1` threads made for this build. The tree is the same
    /// for any count.
    pub threads: Option<usize>,
}

/// The largest [`BvhBuildParams::max_leaf_size`]: a leaf of the 8-wide
/// tree holds at most 8 blocks of 4 triangles (`node.rs`).
pub const BVH_MAX_LEAF: u32 = 32;

impl Default for BvhBuildParams {
    fn default() -> Self {
        BvhBuildParams::sah()
    }
}

impl BvhBuildParams {
    /// Binned SAH with 32 bins, leaves of up to 4 triangles (one SIMD
    /// block) costed in blocks of 4: the 8-wide tree's default. Leaves of
    /// up to 8 took 2-6% more instructions per ray on the bunny and Sponza
    /// (callgrind, `docs/bvh.md`).
    ///
    /// ```
    /// assert_eq!(packtrace::bvh::BvhBuildParams::sah().bins, 32);
    /// ```
    #[must_use]
    pub fn sah() -> Self {
        BvhBuildParams {
            split: Split::Sah,
            bins: 32,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            block: 4,
            max_leaf_size: 4,
            merge_below: 0,
            threads: None,
        }
    }

    /// Median splits down to leaves of at most 4 triangles (Bridson's
    /// lecture notes): the baseline the SAH is measured against.
    ///
    /// ```
    /// assert_eq!(packtrace::bvh::BvhBuildParams::median().max_leaf_size, 4);
    /// ```
    #[must_use]
    pub fn median() -> Self {
        BvhBuildParams {
            split: Split::Median,
            max_leaf_size: 4,
            ..BvhBuildParams::sah()
        }
    }

    /// Binned SAH for a binary tree that tests its leaves one triangle at a
    /// time (`block = 1`, leaves of up to 4 triangles): the default of
    /// [`Bvh2::build`](super::Bvh2::build)'s callers who want its best tree.
    ///
    /// ```
    /// assert_eq!(packtrace::bvh::BvhBuildParams::sah_binary().block, 1);
    /// ```
    #[must_use]
    pub fn sah_binary() -> Self {
        BvhBuildParams {
            block: 1,
            max_leaf_size: 4,
            ..BvhBuildParams::sah()
        }
    }

    /// Every preset with its name, for tests and the benchmark.
    ///
    /// ```
    /// assert_eq!(packtrace::bvh::BvhBuildParams::presets().len(), 3);
    /// ```
    #[must_use]
    pub fn presets() -> [(&'static str, BvhBuildParams); 3] {
        [
            ("sah", BvhBuildParams::sah()),
            ("sah_binary", BvhBuildParams::sah_binary()),
            ("median", BvhBuildParams::median()),
        ]
    }

    /// Checks every field's range.
    ///
    /// # Errors
    /// [`BvhBuildError::InvalidParams`] naming the first field out of
    /// range, its value and the rule.
    ///
    /// ```
    /// use packtrace::bvh::BvhBuildParams;
    /// let p = BvhBuildParams { bins: 1, ..BvhBuildParams::sah() };
    /// assert_eq!(
    ///     p.validate().unwrap_err().to_string(),
    ///     "invalid BVH build parameters: bins = 1 (must be in 2..=256)"
    /// );
    /// ```
    pub fn validate(&self) -> Result<(), BvhBuildError> {
        let bad = |s: String| Err(BvhBuildError::InvalidParams(s));
        if !(2..=BVH_MAX_BINS).contains(&self.bins) {
            return bad(format!(
                "bins = {} (must be in 2..={BVH_MAX_BINS})",
                self.bins
            ));
        }
        for (name, c) in [
            ("traversal_cost", self.traversal_cost),
            ("intersection_cost", self.intersection_cost),
        ] {
            if !(c.is_finite() && c > 0.0) {
                return bad(format!("{name} = {c} (must be finite and > 0)"));
            }
        }
        if !(1..=8).contains(&self.block) {
            return bad(format!("block = {} (must be in 1..=8)", self.block));
        }
        if !(1..=BVH_MAX_LEAF).contains(&self.max_leaf_size) {
            return bad(format!(
                "max_leaf_size = {} (must be in 1..={BVH_MAX_LEAF})",
                self.max_leaf_size
            ));
        }
        if self.merge_below > BVH_MAX_LEAF {
            return bad(format!(
                "merge_below = {} (must be in 0..={BVH_MAX_LEAF})",
                self.merge_below
            ));
        }
        if self.threads == Some(0) {
            return bad("threads = 0 (must be None or >= 1)".to_string());
        }
        Ok(())
    }
}

/// Why a BVH build failed.
///
/// ```
/// use packtrace::bvh::{Bvh8, BvhBuildError, BvhBuildParams};
/// let p = BvhBuildParams { threads: Some(0), ..BvhBuildParams::sah() };
/// let e = Bvh8::build(packtrace::Mesh::default(), &p).unwrap_err();
/// assert!(matches!(e, BvhBuildError::InvalidParams(_)));
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BvhBuildError {
    /// A field of [`BvhBuildParams`] is out of range; the text names the
    /// field, its value and the rule (see [`BvhBuildParams::validate`]).
    InvalidParams(String),
    /// The mesh has more triangles than a node's 28-bit leaf index can
    /// address (the value is the count).
    TooManyTriangles(usize),
    /// The thread pool of [`BvhBuildParams::threads`] could not be made
    /// (the operating system's reason).
    ThreadPool(String),
}

impl fmt::Display for BvhBuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BvhBuildError::InvalidParams(p) => write!(f, "invalid BVH build parameters: {p}"),
            BvhBuildError::TooManyTriangles(n) => write!(
                f,
                "{n} triangles exceed the BVH's limit of {}",
                super::node::MAX_TRIANGLES
            ),
            BvhBuildError::ThreadPool(why) => {
                write!(f, "cannot make the BVH build's thread pool: {why}")
            }
        }
    }
}

impl std::error::Error for BvhBuildError {}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_validate_and_each_rule_fires() {
        for (name, p) in BvhBuildParams::presets() {
            assert_eq!(p.validate(), Ok(()), "{name}");
        }
        let base = BvhBuildParams::sah();
        let cases = [
            (BvhBuildParams { bins: 257, ..base }, "bins = 257"),
            (
                BvhBuildParams {
                    traversal_cost: 0.0,
                    ..base
                },
                "traversal_cost = 0",
            ),
            (
                BvhBuildParams {
                    intersection_cost: f32::NAN,
                    ..base
                },
                "intersection_cost = NaN",
            ),
            (BvhBuildParams { block: 0, ..base }, "block = 0"),
            (
                BvhBuildParams {
                    max_leaf_size: 33,
                    ..base
                },
                "max_leaf_size = 33",
            ),
        ];
        for (p, want) in cases {
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(want), "{e}");
        }
    }
}
