//! Typed build parameters, presets and build errors.

use std::fmt;

/// Deepest tree any build may produce; traversal stacks are this deep, so
/// the stack bound follows from the depth bound (validated after build).
pub const MAX_DEPTH_LIMIT: u32 = 64;

/// Most bins per axis a binned sweep may use ([`KdBuildParams::bins`]).
pub const MAX_BINS: u32 = 4096;

/// SAH kd-tree build parameters. Use a preset and adjust fields.
///
/// ```
/// use packtrace::KdBuildParams;
/// let p = KdBuildParams { max_bad_refines: 2, ..KdBuildParams::pbrt() };
/// assert_eq!(p.intersection_cost, 80.0);
/// assert_eq!(KdBuildParams::default(), KdBuildParams::packtrace());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KdBuildParams {
    /// Cost of one traversal step (SAH `C_t`), finite and `> 0`.
    pub traversal_cost: f32,
    /// Cost of one ray/triangle test (SAH `C_i`), finite and `> 0`.
    pub intersection_cost: f32,
    /// Fraction of the cost waived when one side of a split is empty, in
    /// `[0, 1)`; rewards cutting off empty space.
    pub empty_bonus: f32,
    /// Depth limit: a formula in `log2 N` or a fixed depth, capped at
    /// [`MAX_DEPTH_LIMIT`].
    pub max_depth: DepthLimit,
    /// Splits costlier than a leaf allowed on one path before giving up,
    /// at least 1.
    pub max_bad_refines: u32,
    /// Nodes with at most this many triangles become leaves outright.
    pub max_leaf_size: u32,
    /// Nodes with more triangles than this use a binned sweep (`bins`
    /// candidates per axis) instead of the exact sorted-edge sweep.
    pub exact_below: usize,
    /// Bins per axis of the binned sweep (Shevtsov, Soupikov and Kapustin
    /// 2007), in `2..=4096`: `bins - 1` candidate planes per axis.
    pub bins: u32,
    /// Clip straddling triangles to the child cells ("perfect splits").
    pub split_clipping: bool,
    /// Fail with [`BuildError::MemoryBudget`] rather than hold more bytes
    /// at once than this: the reference arrays of the nodes under
    /// construction, their sorted split events, each thread's scratch and
    /// the nodes and leaf indices emitted so far (the build's own ledger,
    /// checked at every node's allocations, plus up to 64 KiB per open
    /// build task; [`KdTree::build_peak_bytes`] reports the peak of a
    /// build without one). With several threads the peak depends on how
    /// their subtrees interleave.
    ///
    /// [`KdTree::build_peak_bytes`]: super::KdTree::build_peak_bytes
    pub memory_budget: Option<usize>,
    /// Threads of the build. `None`: the caller's rayon pool (the global
    /// one, one thread per core, unless the build runs inside
    /// `rayon::ThreadPool::install`); `Some(n)`: a pool of `n >= 1`
    /// threads made for this build. The tree is the same for any count.
    pub threads: Option<usize>,
}

/// How deep a build may go: the SAH stops splitting there.
///
/// ```
/// use packtrace::DepthLimit;
/// assert_eq!(DepthLimit::PBRT.for_triangles(69_451), 29);
/// assert_eq!(DepthLimit::COMPACT.for_triangles(69_451), 22);
/// assert_eq!(DepthLimit::Fixed(12).for_triangles(1 << 20), 12);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DepthLimit {
    /// `round(base + slope * log2 N)` for `N` triangles, at most
    /// [`MAX_DEPTH_LIMIT`]; `base` and `slope` finite and `>= 0`.
    Log2 {
        /// Depth of a one-triangle scene.
        base: f32,
        /// Levels per doubling of the triangle count.
        slope: f32,
    },
    /// This depth for every scene, at most [`MAX_DEPTH_LIMIT`].
    Fixed(u32),
}

impl DepthLimit {
    /// PBRT-v3's `8 + 1.3 log2 N`.
    ///
    /// ```
    /// assert_eq!(packtrace::DepthLimit::PBRT.for_triangles(1 << 20), 34);
    /// ```
    pub const PBRT: DepthLimit = DepthLimit::Log2 {
        base: 8.0,
        slope: 1.3,
    };

    /// `6 + log2 N`, the default preset's: with one bad refine it builds
    /// 3-7x fewer nodes than PBRT's rule on the bunny, Sponza and the
    /// teapot, for an SAH cost 2.4 % higher (bunny) or lower (Sponza,
    /// teapot) and about the same speed (docs/builds.md, "What the
    /// default's termination buys").
    ///
    /// ```
    /// assert_eq!(packtrace::DepthLimit::COMPACT.for_triangles(6320), 19);
    /// ```
    pub const COMPACT: DepthLimit = DepthLimit::Log2 {
        base: 6.0,
        slope: 1.0,
    };

    /// The depth for a mesh of `n` triangles (unchecked: see
    /// [`KdBuildParams::depth_for`] for the validated form).
    ///
    /// ```
    /// assert_eq!(packtrace::DepthLimit::Fixed(100).for_triangles(1), 64);
    /// ```
    #[must_use]
    pub fn for_triangles(self, n: usize) -> u32 {
        match self {
            DepthLimit::Fixed(d) => d.min(MAX_DEPTH_LIMIT),
            DepthLimit::Log2 { base, slope } => {
                let d = f64::from(base) + f64::from(slope) * (n.max(1) as f64).log2();
                // `as` saturates: NaN gives 0, a huge value the cap.
                (d.round() as u32).min(MAX_DEPTH_LIMIT)
            }
        }
    }
}

impl KdBuildParams {
    /// PBRT-v3's constants: traversal 1, intersection 80, empty bonus 0.5,
    /// one triangle per leaf.
    ///
    /// ```
    /// assert_eq!(packtrace::KdBuildParams::pbrt().traversal_cost, 1.0);
    /// ```
    #[must_use]
    pub fn pbrt() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 1.0,
            intersection_cost: 80.0,
            empty_bonus: 0.5,
            max_depth: DepthLimit::PBRT,
            max_bad_refines: 3,
            max_leaf_size: 1,
            exact_below: usize::MAX,
            bins: 128,
            split_clipping: false,
            memory_budget: None,
            threads: None,
        }
    }

    /// Mitsuba 0.6's constants: traversal 15, intersection 20, empty bonus 0.9.
    ///
    /// ```
    /// assert_eq!(packtrace::KdBuildParams::mitsuba().empty_bonus, 0.9);
    /// ```
    #[must_use]
    pub fn mitsuba() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 15.0,
            intersection_cost: 20.0,
            empty_bonus: 0.9,
            max_leaf_size: 1,
            split_clipping: true,
            ..KdBuildParams::pbrt()
        }
    }

    /// Fast build: binned sweep on every node above 64 triangles, shallower
    /// trees. For dynamic scenes where build time matters.
    ///
    /// ```
    /// assert_eq!(packtrace::KdBuildParams::fast_build().exact_below, 64);
    /// ```
    #[must_use]
    pub fn fast_build() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 1.0,
            intersection_cost: 4.0,
            empty_bonus: 0.2,
            max_leaf_size: 2,
            exact_below: 64,
            ..KdBuildParams::pbrt()
        }
    }

    /// The crate's default, chosen by measurement on the protocol's rays
    /// (docs/measurements.md, "Tree statistics of every preset";
    /// ARCHITECTURE.md, "SAH build").
    ///
    /// ```
    /// assert!(packtrace::KdBuildParams::packtrace().empty_bonus > 0.0);
    /// ```
    #[must_use]
    pub fn packtrace() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 1.0,
            // A triangle test priced below a node step (issue 10 item 3,
            // docs/builds.md, "SAH constants for incoherent rays"): on these trees a node
            // step waits on a dependent load and a leaf's tests overlap,
            // so larger leaves pay. Against 1.5 (medians of three passes
            // on all four workloads, scalar and packet8): 0.8 is 1.00-1.06x
            // on every cell of the bunny, Sponza and the teapot, 11-31 %
            // smaller and 5-14 % faster to build; 0.6 and below lose on
            // Sponza's and the teapot's primary and shadow rays.
            intersection_cost: 0.8,
            empty_bonus: 0.5,
            max_leaf_size: 1,
            exact_below: 4096,
            split_clipping: true,
            // Measured against PBRT's depth and three bad refines (docs/builds.md,
            // "What the default's termination buys"): PBRT's levels below `6 + log2 N` and
            // splits that do not pay for themselves carve ever smaller
            // cells around shared vertices; dropping them changes the SAH
            // cost by +2.4 % (bunny) to -8 % (Sponza), leaves 3-7x fewer
            // nodes, builds 1.7-2.7x faster, and traces about as fast
            // (faster on most workloads, Sponza primary 5 % slower, in
            // single passes).
            max_depth: DepthLimit::COMPACT,
            max_bad_refines: 1,
            ..KdBuildParams::pbrt()
        }
    }

    /// The per-frame preset, for scenes rebuilt every frame: a binned
    /// sweep on every node above 32 references, no clipping, larger
    /// leaves and a shallower tree (docs/builds.md).
    ///
    /// ```
    /// assert!(!packtrace::KdBuildParams::dynamic().split_clipping);
    /// ```
    #[must_use]
    pub fn dynamic() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 1.0,
            intersection_cost: 1.5,
            empty_bonus: 0.5,
            max_depth: DepthLimit::Log2 {
                base: 4.0,
                slope: 1.0,
            },
            max_bad_refines: 1,
            max_leaf_size: 2,
            exact_below: 32,
            bins: 32,
            split_clipping: false,
            ..KdBuildParams::pbrt()
        }
    }

    /// Every preset with its name, for tests and benchmarks.
    ///
    /// ```
    /// assert_eq!(packtrace::KdBuildParams::presets().len(), 5);
    /// ```
    #[must_use]
    pub fn presets() -> [(&'static str, KdBuildParams); 5] {
        [
            ("packtrace", KdBuildParams::packtrace()),
            ("dynamic", KdBuildParams::dynamic()),
            ("pbrt", KdBuildParams::pbrt()),
            ("mitsuba", KdBuildParams::mitsuba()),
            ("fast_build", KdBuildParams::fast_build()),
        ]
    }

    /// Check every field's range; the error names the first bad field,
    /// its value and the rule.
    ///
    /// | field | valid |
    /// |---|---|
    /// | `traversal_cost` | finite and `> 0` (at 0, a split that separates nothing costs no more than its parent, so flat cells split forever) |
    /// | `intersection_cost` | finite and `> 0` |
    /// | `empty_bonus` | in `[0, 1)` |
    /// | `max_depth` | `Fixed(d)` with `d` at most [`MAX_DEPTH_LIMIT`]; `Log2` with `base` and `slope` finite and `>= 0` |
    /// | `max_bad_refines` | `>= 1` (0 would forbid every split) |
    /// | `threads` | `None` or `>= 1` |
    /// | `bins` | `2..=4096` |
    /// | `max_leaf_size`, `exact_below`, `split_clipping`, `memory_budget` | any value |
    ///
    /// # Errors
    /// [`BuildError::InvalidParams`] naming the field, and
    /// [`BuildError::DepthLimit`] for a depth over [`MAX_DEPTH_LIMIT`].
    ///
    /// ```
    /// use packtrace::{BuildError, KdBuildParams};
    /// let p = KdBuildParams { traversal_cost: 0.0, ..KdBuildParams::default() };
    /// let e = p.validate().unwrap_err();
    /// assert_eq!(e.to_string(), "invalid kd-tree build parameters: traversal_cost = 0 (must be finite and > 0)");
    /// assert!(KdBuildParams::default().validate().is_ok());
    /// ```
    pub fn validate(&self) -> Result<(), BuildError> {
        let bad = |field: &str, value: &dyn fmt::Display, rule: &str| {
            Err(BuildError::InvalidParams(format!(
                "{field} = {value} ({rule})"
            )))
        };
        let positive = |x: f32| x.is_finite() && x > 0.0;
        if !positive(self.traversal_cost) {
            return bad(
                "traversal_cost",
                &self.traversal_cost,
                "must be finite and > 0",
            );
        }
        if !positive(self.intersection_cost) {
            return bad(
                "intersection_cost",
                &self.intersection_cost,
                "must be finite and > 0",
            );
        }
        if !(0.0..1.0).contains(&self.empty_bonus) {
            return bad("empty_bonus", &self.empty_bonus, "must be in [0, 1)");
        }
        if self.max_bad_refines == 0 {
            return bad("max_bad_refines", &0, "must be >= 1");
        }
        if self.threads == Some(0) {
            return bad("threads", &0, "must be None or >= 1");
        }
        if !(2..=MAX_BINS).contains(&self.bins) {
            return bad("bins", &self.bins, &format!("must be in 2..={MAX_BINS}"));
        }
        match self.max_depth {
            DepthLimit::Fixed(d) if d > MAX_DEPTH_LIMIT => Err(BuildError::DepthLimit(d)),
            DepthLimit::Log2 { base, slope }
                if !(base.is_finite() && base >= 0.0 && slope.is_finite() && slope >= 0.0) =>
            {
                bad(
                    "max_depth",
                    &format!("Log2 {{ base: {base}, slope: {slope} }}"),
                    "base and slope must be finite and >= 0",
                )
            }
            _ => Ok(()),
        }
    }

    /// The depth limit for `n` triangles, after [`KdBuildParams::validate`].
    ///
    /// # Errors
    /// Those of [`KdBuildParams::validate`].
    ///
    /// ```
    /// let p = packtrace::KdBuildParams::pbrt();
    /// assert_eq!(p.depth_for(1 << 20).unwrap(), 34);
    /// ```
    pub fn depth_for(&self, n: usize) -> Result<u32, BuildError> {
        self.validate()?;
        Ok(self.max_depth.for_triangles(n))
    }
}

impl Default for KdBuildParams {
    fn default() -> KdBuildParams {
        KdBuildParams::packtrace()
    }
}

/// Why a kd-tree build failed. Every limit is checked before it can wrap.
#[derive(Clone, Debug, PartialEq)]
pub enum BuildError {
    /// A field of [`KdBuildParams`] is out of range; the text names the
    /// field, its value and the rule, e.g. `traversal_cost = 0 (must be
    /// finite and > 0)` (see [`KdBuildParams::validate`]).
    InvalidParams(String),
    /// The requested depth exceeds [`MAX_DEPTH_LIMIT`].
    DepthLimit(u32),
    /// The tree needs more nodes than a 30-bit child index can address.
    TooManyNodes(usize),
    /// More leaf references than a `u32` offset can address.
    TooManyReferences(usize),
    /// A leaf holds more triangles than a 30-bit count can say.
    LeafTooLarge(usize),
    /// The mesh has more triangles than a leaf count can address (2^30 - 1).
    TooManyTriangles(usize),
    /// The thread pool of [`KdBuildParams::threads`] could not be made
    /// (the operating system's reason).
    ThreadPool(String),
    /// The build would exceed [`KdBuildParams::memory_budget`].
    MemoryBudget {
        /// Bytes the build needed when it stopped.
        needed: usize,
        /// The budget.
        budget: usize,
    },
}

impl fmt::Display for BuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BuildError::InvalidParams(p) => write!(f, "invalid kd-tree build parameters: {p}"),
            BuildError::DepthLimit(d) => {
                write!(f, "max_depth {d} exceeds the limit of {MAX_DEPTH_LIMIT}")
            }
            BuildError::TooManyNodes(n) => {
                write!(f, "kd-tree needs {n} nodes, more than 2^30 can address")
            }
            BuildError::TooManyReferences(n) => {
                write!(f, "kd-tree needs {n} triangle references, more than 2^32")
            }
            BuildError::LeafTooLarge(n) => {
                write!(
                    f,
                    "a leaf of {n} triangles exceeds the 2^30 - 1 count limit"
                )
            }
            BuildError::TooManyTriangles(n) => {
                write!(f, "{n} triangles exceed the kd-tree's limit of 2^30 - 1")
            }
            BuildError::ThreadPool(why) => {
                write!(f, "cannot make the kd-tree build's thread pool: {why}")
            }
            BuildError::MemoryBudget { needed, budget } => write!(
                f,
                "kd-tree build needs at least {needed} bytes, over its memory budget of {budget}"
            ),
        }
    }
}

impl std::error::Error for BuildError {}

#[cfg(test)]
mod tests {
    use super::*;

    /// The message `validate` gives for `p`, or `None` when it accepts it.
    fn message(p: KdBuildParams) -> Option<String> {
        match p.validate() {
            Ok(()) => None,
            Err(BuildError::InvalidParams(m)) => Some(m),
            Err(e) => Some(format!("other error: {e}")),
        }
    }

    #[test]
    fn each_bad_field_is_named_with_its_value_and_rule() {
        let base = KdBuildParams::default();
        let cost = "must be finite and > 0";
        let cases = [
            (
                KdBuildParams {
                    traversal_cost: 0.0,
                    ..base
                },
                format!("traversal_cost = 0 ({cost})"),
            ),
            (
                KdBuildParams {
                    traversal_cost: -0.0,
                    ..base
                },
                format!("traversal_cost = -0 ({cost})"),
            ),
            (
                KdBuildParams {
                    traversal_cost: -1.0,
                    ..base
                },
                format!("traversal_cost = -1 ({cost})"),
            ),
            (
                KdBuildParams {
                    traversal_cost: f32::NAN,
                    ..base
                },
                format!("traversal_cost = NaN ({cost})"),
            ),
            (
                KdBuildParams {
                    traversal_cost: f32::INFINITY,
                    ..base
                },
                format!("traversal_cost = inf ({cost})"),
            ),
            (
                KdBuildParams {
                    intersection_cost: 0.0,
                    ..base
                },
                format!("intersection_cost = 0 ({cost})"),
            ),
            (
                KdBuildParams {
                    intersection_cost: -80.0,
                    ..base
                },
                format!("intersection_cost = -80 ({cost})"),
            ),
            (
                KdBuildParams {
                    intersection_cost: f32::NEG_INFINITY,
                    ..base
                },
                format!("intersection_cost = -inf ({cost})"),
            ),
            (
                KdBuildParams {
                    empty_bonus: 1.0,
                    ..base
                },
                "empty_bonus = 1 (must be in [0, 1))".to_string(),
            ),
            (
                KdBuildParams {
                    empty_bonus: -0.5,
                    ..base
                },
                "empty_bonus = -0.5 (must be in [0, 1))".to_string(),
            ),
            (
                KdBuildParams {
                    empty_bonus: f32::NAN,
                    ..base
                },
                "empty_bonus = NaN (must be in [0, 1))".to_string(),
            ),
            (
                KdBuildParams {
                    max_bad_refines: 0,
                    ..base
                },
                "max_bad_refines = 0 (must be >= 1)".to_string(),
            ),
        ];
        for (p, want) in cases {
            assert_eq!(message(p).as_deref(), Some(want.as_str()), "{p:?}");
            let shown = BuildError::InvalidParams(want.clone()).to_string();
            assert_eq!(shown, format!("invalid kd-tree build parameters: {want}"));
        }
    }

    #[test]
    fn depth_over_the_stack_bound_is_its_own_error() {
        let p = KdBuildParams {
            max_depth: DepthLimit::Fixed(MAX_DEPTH_LIMIT + 1),
            ..KdBuildParams::default()
        };
        assert_eq!(
            p.validate(),
            Err(BuildError::DepthLimit(MAX_DEPTH_LIMIT + 1))
        );
        assert_eq!(
            p.depth_for(10),
            Err(BuildError::DepthLimit(MAX_DEPTH_LIMIT + 1))
        );
    }

    #[test]
    fn depth_formulas_and_bins_are_checked() {
        for (base, slope) in [
            (f32::NAN, 1.0),
            (1.0, f32::INFINITY),
            (-1.0, 1.0),
            (6.0, -0.5),
        ] {
            let p = KdBuildParams {
                max_depth: DepthLimit::Log2 { base, slope },
                ..KdBuildParams::default()
            };
            let m = message(p).unwrap();
            assert!(m.starts_with("max_depth = Log2"), "{m}");
            assert!(
                m.ends_with("(base and slope must be finite and >= 0)"),
                "{m}"
            );
        }
        for bins in [0, 1, MAX_BINS + 1] {
            let p = KdBuildParams {
                bins,
                ..KdBuildParams::default()
            };
            assert_eq!(
                message(p).as_deref(),
                Some(format!("bins = {bins} (must be in 2..=4096)").as_str())
            );
        }
        // Huge formulas are capped at the stack bound, not wrapped.
        let huge = DepthLimit::Log2 {
            base: 1e30,
            slope: 1e30,
        };
        assert_eq!(huge.for_triangles(1 << 20), MAX_DEPTH_LIMIT);
        assert_eq!(DepthLimit::COMPACT.for_triangles(0), 6);
        assert_eq!(DepthLimit::PBRT.for_triangles(69_451), 29);
    }

    #[test]
    fn edges_of_every_range_are_accepted() {
        let base = KdBuildParams::default();
        let ok = [
            KdBuildParams {
                traversal_cost: f32::MIN_POSITIVE,
                intersection_cost: f32::MAX,
                empty_bonus: 0.0,
                max_depth: DepthLimit::Fixed(0),
                max_bad_refines: 1,
                max_leaf_size: 0,
                exact_below: 0,
                ..base
            },
            KdBuildParams {
                empty_bonus: 1.0f32.next_down(),
                max_depth: DepthLimit::Fixed(MAX_DEPTH_LIMIT),
                max_bad_refines: u32::MAX,
                max_leaf_size: u32::MAX,
                exact_below: usize::MAX,
                memory_budget: Some(0),
                ..base
            },
        ];
        for p in ok {
            assert_eq!(p.validate(), Ok(()), "{p:?}");
        }
        for (name, p) in KdBuildParams::presets() {
            assert_eq!(p.validate(), Ok(()), "{name}");
        }
    }
}
