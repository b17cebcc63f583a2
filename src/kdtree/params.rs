//! Typed build parameters, presets and build errors.

use std::fmt;

/// Deepest tree any build may produce; traversal stacks are this deep, so
/// the stack bound follows from the depth bound (validated after build).
pub const MAX_DEPTH_LIMIT: u32 = 64;

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
    /// Cost of one traversal step (SAH `C_t`).
    pub traversal_cost: f32,
    /// Cost of one ray/triangle test (SAH `C_i`).
    pub intersection_cost: f32,
    /// Fraction of the cost waived when one side of a split is empty, in
    /// `[0, 1)`; rewards cutting off empty space.
    pub empty_bonus: f32,
    /// Depth limit; `None` means `8 + 1.3 log2 N` (PBRT), capped at
    /// [`MAX_DEPTH_LIMIT`].
    pub max_depth: Option<u32>,
    /// Splits costlier than a leaf allowed on one path before giving up.
    pub max_bad_refines: u32,
    /// Nodes with at most this many triangles become leaves outright.
    pub max_leaf_size: u32,
    /// Nodes with more triangles than this use a 128-bin sweep instead of
    /// the exact sorted-edge sweep.
    pub exact_below: usize,
    /// Clip straddling triangles to the child cells ("perfect splits").
    pub split_clipping: bool,
    /// Fail with [`BuildError::MemoryBudget`] rather than use more bytes of
    /// references, nodes and leaf indices than this.
    pub memory_budget: Option<usize>,
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
            max_depth: None,
            max_bad_refines: 3,
            max_leaf_size: 1,
            exact_below: usize::MAX,
            split_clipping: false,
            memory_budget: None,
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
    /// (README, "Build parameters").
    ///
    /// ```
    /// assert!(packtrace::KdBuildParams::packtrace().empty_bonus > 0.0);
    /// ```
    #[must_use]
    pub fn packtrace() -> KdBuildParams {
        KdBuildParams {
            traversal_cost: 1.0,
            intersection_cost: 1.5,
            empty_bonus: 0.5,
            max_leaf_size: 1,
            exact_below: 4096,
            split_clipping: true,
            ..KdBuildParams::pbrt()
        }
    }

    /// Every preset with its name, for tests and benchmarks.
    ///
    /// ```
    /// assert_eq!(packtrace::KdBuildParams::presets().len(), 4);
    /// ```
    #[must_use]
    pub fn presets() -> [(&'static str, KdBuildParams); 4] {
        [
            ("packtrace", KdBuildParams::packtrace()),
            ("pbrt", KdBuildParams::pbrt()),
            ("mitsuba", KdBuildParams::mitsuba()),
            ("fast_build", KdBuildParams::fast_build()),
        ]
    }

    /// The depth limit for `n` triangles.
    ///
    /// # Errors
    /// [`BuildError::InvalidParams`] for NaN, negative or out-of-range costs,
    /// and [`BuildError::DepthLimit`] for a depth over [`MAX_DEPTH_LIMIT`].
    ///
    /// ```
    /// let p = packtrace::KdBuildParams::pbrt();
    /// assert_eq!(p.depth_for(1 << 20).unwrap(), 34);
    /// ```
    pub fn depth_for(&self, n: usize) -> Result<u32, BuildError> {
        let ok = |x: f32| x.is_finite() && x >= 0.0;
        let valid = ok(self.traversal_cost)
            && ok(self.intersection_cost)
            && self.intersection_cost > 0.0
            && (0.0..1.0).contains(&self.empty_bonus)
            && self.max_bad_refines > 0;
        if !valid {
            return Err(BuildError::InvalidParams(format!("{self:?}")));
        }
        match self.max_depth {
            Some(d) if d > MAX_DEPTH_LIMIT => Err(BuildError::DepthLimit(d)),
            Some(d) => Ok(d),
            None => {
                let d = 8.0 + 1.3 * (n.max(1) as f64).log2();
                Ok((d.round() as u32).min(MAX_DEPTH_LIMIT))
            }
        }
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
    /// A cost is NaN, negative or out of range; the text shows the params.
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
            BuildError::MemoryBudget { needed, budget } => write!(
                f,
                "kd-tree build needs at least {needed} bytes, over its memory budget of {budget}"
            ),
        }
    }
}

impl std::error::Error for BuildError {}
