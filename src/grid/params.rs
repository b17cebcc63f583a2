//! Typed build parameters of the grids and their build errors.

use std::fmt;

/// The largest density a build accepts: cells per triangle.
pub const GRID_MAX_DENSITY: f32 = 64.0;

/// The most cells one grid (or one sub-grid) may have.
pub const GRID_MAX_CELLS: u64 = 1 << 26;

/// Which cells a triangle is entered in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Overlap {
    /// Every cell its (padded) bounding box meets: the lectures' rule,
    /// cheapest to build.
    Boxes,
    /// Only the cells the (padded) triangle itself meets: the separating
    /// axis test of Akenine-Möller (2001) on the box's candidates. Fewer
    /// references for large and diagonal triangles.
    #[default]
    Triangles,
}

/// Build parameters of a uniform [`Grid`](crate::grid::Grid).
///
/// ```
/// use packtrace::grid::{GridParams, Overlap};
/// let p = GridParams { density: 2.0, overlap: Overlap::Boxes, ..GridParams::default() };
/// assert!(p.validate().is_ok());
/// assert!(GridParams { density: 0.0, ..p }.validate().is_err());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GridParams {
    /// `lambda`, cells per triangle: the grid has about `lambda * N` cells
    /// for `N` triangles (Cleary and Wyvill 1988; the lectures' rule),
    /// shaped like the scene's box. In `(0, GRID_MAX_DENSITY]`.
    pub density: f32,
    /// Which cells a triangle is entered in.
    pub overlap: Overlap,
    /// Skip a triangle a ray has already tested in an earlier cell
    /// (a small per-ray table of triangle indices, so the grid stays
    /// immutable and shareable between threads). The answers are the same
    /// either way; only the work differs.
    pub mailbox: bool,
}

impl Default for GridParams {
    /// Density 4 with exact triangle overlap and mailboxes (measured:
    /// `docs/grids.md`).
    fn default() -> Self {
        GridParams {
            density: 4.0,
            overlap: Overlap::Triangles,
            mailbox: true,
        }
    }
}

impl GridParams {
    /// Checks the parameters.
    ///
    /// # Errors
    /// [`GridBuildError::Density`] when `density` is not in
    /// `(0, GRID_MAX_DENSITY]`.
    ///
    /// ```
    /// use packtrace::grid::GridParams;
    /// assert!(GridParams::default().validate().is_ok());
    /// ```
    pub fn validate(&self) -> Result<(), GridBuildError> {
        if !(self.density > 0.0 && self.density <= GRID_MAX_DENSITY) {
            return Err(GridBuildError::Density(self.density));
        }
        Ok(())
    }
}

/// Build parameters of a two-level [`HGrid`](crate::grid::HGrid).
///
/// ```
/// use packtrace::grid::HGridParams;
/// let p = HGridParams::default();
/// assert!(p.validate().is_ok());
/// assert!(p.top.density < p.cell.density);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HGridParams {
    /// The top level: a coarse uniform grid over the whole scene.
    pub top: GridParams,
    /// The sub-grid of a crowded top cell, built over that cell's
    /// triangles and box with this density.
    pub cell: GridParams,
    /// A top cell with more references than this gets a sub-grid.
    pub refine_above: u32,
}

impl Default for HGridParams {
    /// A top level of one cell per 8 triangles, sub-grids of density 4 in
    /// cells of more than 16 triangles (measured: `docs/grids.md`).
    fn default() -> Self {
        HGridParams {
            top: GridParams {
                density: 0.125,
                ..GridParams::default()
            },
            cell: GridParams::default(),
            refine_above: 16,
        }
    }
}

impl HGridParams {
    /// Checks both levels' parameters.
    ///
    /// # Errors
    /// [`GridBuildError::Density`] when either density is out of range.
    ///
    /// ```
    /// use packtrace::grid::{GridParams, HGridParams};
    /// let bad = HGridParams { cell: GridParams { density: -1.0, ..GridParams::default() }, ..HGridParams::default() };
    /// assert!(bad.validate().is_err());
    /// ```
    pub fn validate(&self) -> Result<(), GridBuildError> {
        self.top.validate()?;
        self.cell.validate()
    }
}

/// Why a grid could not be built.
#[derive(Clone, Debug, PartialEq)]
pub enum GridBuildError {
    /// The density is not in `(0, GRID_MAX_DENSITY]`.
    Density(f32),
    /// More triangle references than a `u32` index holds.
    TooManyReferences(u64),
}

impl fmt::Display for GridBuildError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GridBuildError::Density(d) => write!(
                f,
                "grid density {d} is not in (0, {GRID_MAX_DENSITY}] cells per triangle"
            ),
            GridBuildError::TooManyReferences(n) => write!(
                f,
                "the grid would hold {n} triangle references, more than a u32 indexes"
            ),
        }
    }
}

impl std::error::Error for GridBuildError {}
