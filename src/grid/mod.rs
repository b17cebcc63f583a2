//! The lectures' other structures beside the kd-tree and the BVHs: the
//! uniform grid ([`Grid`]) with 3D-DDA traversal and mailboxes, and a
//! two-level hierarchical grid ([`HGrid`]) for scenes whose triangles
//! crowd into a small part of their box ("the teapot in a stadium").
//!
//! Both answer the same queries, through the same traits
//! ([`RayQuery`](crate::RayQuery), [`PacketQuery`](crate::PacketQuery)),
//! with brute force's answers bit for bit, so a host switches structure
//! with one line:
//!
//! ```
//! use packtrace::grid::{Grid, GridParams, HGrid, HGridParams};
//! use packtrace::glam::Vec3;
//! use packtrace::{KdBuildParams, KdTree, Mesh, PacketQuery, Ray, RayPacket8};
//!
//! let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
//! let kd = KdTree::build(mesh.clone(), &KdBuildParams::default())?;
//! let grid = Grid::build(mesh.clone(), &GridParams::default())?;
//! let hgrid = HGrid::build(mesh, &HGridParams::default())?;
//! let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
//! let engines: [&dyn PacketQuery; 3] = [&kd, &grid, &hgrid];
//! for e in engines {
//!     assert_eq!(e.intersect(&ray).map(|h| (h.t, h.prim)), Some((1.0, 0)));
//!     assert_eq!(e.intersect8(&RayPacket8::from_slice(&[ray; 3])).mask(), 0b111);
//! }
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - `params`: [`GridParams`] (density `lambda`, overlap rule, mailbox),
//!   [`HGridParams`], [`GridBuildError`];
//! - `cells`: one grid's cells (geometry in `f64`, one offset table and
//!   one index array) and their build; `walk`: the 3D-DDA;
//! - `single`: a ray through either grid; `packet`: coherent grid
//!   traversal of 4- and 8-wide packets (run-time kernels in
//!   `kdtree/kernel/bvh.rs`); `query`: the query traits and streams;
//! - `validate`, [`GridStats`]: invariants and statistics.
//!
//! The design, what was measured and what was rejected: `docs/grids.md`.

mod cells;
pub(crate) mod packet;
mod params;
mod query;
mod single;
mod validate;
mod walk;

pub use params::{
    GRID_MAX_CELLS, GRID_MAX_DENSITY, GridBuildError, GridParams, HGridParams, Overlap,
};
pub use validate::GridValidationError;

use crate::mesh::Mesh;
use cells::{Cells, PAD_REACH, resolution};
use rayon::prelude::*;

/// Cells are at least this many pads wide (bounds the references of a
/// scene far from the world origin, where the pad is large).
const MIN_CELL_PADS: f64 = 4.0;

/// The triangles a grid lists: all but the degenerate ones, which no ray
/// hits (brute force skips them too).
pub(crate) fn live_triangles(mesh: &Mesh) -> Vec<u32> {
    (0..mesh.triangle_count())
        .filter(|&i| !mesh.is_degenerate(i))
        .map(|i| i as u32)
        .collect()
}

/// What every level of a grid shares: the scene's box in `f64`, its
/// coordinate magnitude and the pad every triangle is grown by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Frame {
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// The largest coordinate magnitude of the box, `M`.
    pub m: f64,
    /// `PAD_REACH * MARGIN * M` (`cells.rs`).
    pub pad: f64,
}

impl Frame {
    fn of(mesh: &Mesh) -> Frame {
        if mesh.is_empty() {
            return Frame {
                lo: [0.0; 3],
                hi: [0.0; 3],
                m: 0.0,
                pad: 0.0,
            };
        }
        let b = mesh.bounds();
        let lo = [b.min.x, b.min.y, b.min.z].map(f64::from);
        let hi = [b.max.x, b.max.y, b.max.z].map(f64::from);
        let m = (0..3).fold(0.0f64, |m, a| m.max(lo[a].abs()).max(hi[a].abs()));
        Frame {
            lo,
            hi,
            m,
            pad: PAD_REACH * f64::from(crate::triangle::MARGIN) * m,
        }
    }

    fn extent(&self) -> [f64; 3] {
        std::array::from_fn(|a| self.hi[a] - self.lo[a])
    }
}

/// A uniform grid over a mesh: about `lambda * N` cells shaped like the
/// scene's box, each listing the triangles that meet it, walked front to
/// back by the 3D-DDA (Amanatides and Woo 1987) with early exit and a
/// per-ray mailbox; packets walk it slice by slice (Wald et al. 2006).
///
/// ```
/// use packtrace::grid::{Grid, GridParams};
/// use packtrace::glam::Vec3;
/// use packtrace::{Mesh, Ray};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
/// let grid = Grid::build(mesh, &GridParams::default())?;
/// let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
/// assert_eq!(grid.intersect(&ray).map(|h| h.t), Some(1.0));
/// assert!(grid.validate().is_ok());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct Grid {
    mesh: Mesh,
    pub(crate) cells: Cells,
    pub(crate) frame: Frame,
    params: GridParams,
}

impl Grid {
    /// Builds the grid over `mesh` with `params`.
    ///
    /// # Errors
    /// [`GridBuildError`] for an invalid density, or more triangle
    /// references than `u32` indices reach.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// let g = Grid::build(packtrace::Mesh::default(), &GridParams::default()).unwrap();
    /// assert_eq!(g.stats().references, 0);
    /// ```
    pub fn build(mesh: Mesh, params: &GridParams) -> Result<Grid, GridBuildError> {
        params.validate()?;
        let frame = Frame::of(&mesh);
        let all = live_triangles(&mesh);
        let dims = resolution(
            frame.extent(),
            f64::from(params.density) * all.len() as f64,
            MIN_CELL_PADS * frame.pad,
        );
        let mut cells = Cells::geometry(frame.lo, frame.hi, dims);
        cells.fill(mesh.corner_slice(), &all, frame.pad, params.overlap)?;
        Ok(Grid {
            mesh,
            cells,
            frame,
            params: *params,
        })
    }

    /// The mesh the grid was built over.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// let g = Grid::build(packtrace::Mesh::default(), &GridParams::default()).unwrap();
    /// assert!(g.mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The build parameters.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// let g = Grid::build(packtrace::Mesh::default(), &GridParams::default()).unwrap();
    /// assert_eq!(g.params(), &GridParams::default());
    /// ```
    #[must_use]
    pub fn params(&self) -> &GridParams {
        &self.params
    }

    /// Cells along each axis.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// let g = Grid::build(packtrace::Mesh::default(), &GridParams::default()).unwrap();
    /// assert_eq!(g.dims(), [1, 1, 1]);
    /// ```
    #[must_use]
    pub fn dims(&self) -> [u32; 3] {
        self.cells.dims
    }

    /// The triangles of cell `[x, y, z]`, ascending; `None` outside the
    /// grid.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// use packtrace::glam::Vec3;
    /// let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let g = Grid::build(mesh, &GridParams::default()).unwrap();
    /// assert_eq!(g.cell([0, 0, 0]), Some(&[0u32][..]));
    /// assert_eq!(g.cell([9, 0, 0]), None);
    /// ```
    #[must_use]
    pub fn cell(&self, c: [u32; 3]) -> Option<&[u32]> {
        (0..3)
            .all(|a| c[a] < self.cells.dims[a])
            .then(|| self.cells.cell(self.cells.index(c)))
    }

    /// Build statistics: cells, references, memory.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// use packtrace::glam::Vec3;
    /// let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let s = Grid::build(mesh, &GridParams::default()).unwrap().stats();
    /// // About 4 cells for one triangle (density 4), in the plane z = 0.
    /// assert_eq!((s.triangles, s.dims, s.cells), (1, [2, 2, 1], 4));
    /// assert_eq!(s.references, 4);
    /// ```
    #[must_use]
    pub fn stats(&self) -> GridStats {
        let mut s = GridStats {
            triangles: self.mesh.triangle_count(),
            dims: self.cells.dims,
            ..GridStats::default()
        };
        s.add(&self.cells);
        s.bytes = self.cells.bytes();
        s
    }
}

/// A two-level grid (Jevans and Wyvill 1989, "Adaptive voxel
/// subdivision for ray tracing"): a coarse uniform grid whose crowded
/// cells each hold a uniform grid of their own, built over that cell's
/// triangles and box. It answers "the teapot in a stadium", where a
/// uniform grid sized for the whole scene puts the teapot in a handful of
/// cells. Rays walk the top level and, in a refined cell, that cell's
/// sub-grid over the same span; packets go ray by ray.
///
/// ```
/// use packtrace::grid::{HGrid, HGridParams};
/// use packtrace::glam::Vec3;
/// use packtrace::{Mesh, Ray};
/// let mesh = Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]])?;
/// let g = HGrid::build(mesh, &HGridParams::default())?;
/// let ray = Ray::new(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY)?;
/// assert_eq!(g.intersect(&ray).map(|h| h.prim), Some(0));
/// assert!(g.validate().is_ok());
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug)]
pub struct HGrid {
    mesh: Mesh,
    pub(crate) top: Cells,
    /// `subs[sub_of[c] - 1]` is top cell `c`'s sub-grid (0: none).
    sub_of: Vec<u32>,
    subs: Vec<Cells>,
    pub(crate) frame: Frame,
    pub(crate) params: HGridParams,
}

impl HGrid {
    /// Builds the top level, then (in parallel) a sub-grid in each top
    /// cell with more than `refine_above` references.
    ///
    /// # Errors
    /// [`GridBuildError`] for an invalid density, or more triangle
    /// references than `u32` indices reach.
    ///
    /// ```
    /// use packtrace::grid::{HGrid, HGridParams};
    /// let g = HGrid::build(packtrace::Mesh::default(), &HGridParams::default()).unwrap();
    /// assert_eq!(g.stats().subgrids, 0);
    /// ```
    pub fn build(mesh: Mesh, params: &HGridParams) -> Result<HGrid, GridBuildError> {
        params.validate()?;
        let frame = Frame::of(&mesh);
        let all = live_triangles(&mesh);
        let min_size = MIN_CELL_PADS * frame.pad;
        let dims = resolution(
            frame.extent(),
            f64::from(params.top.density) * all.len() as f64,
            min_size,
        );
        let mut top = Cells::geometry(frame.lo, frame.hi, dims);
        let corners = mesh.corner_slice();
        top.fill(corners, &all, frame.pad, params.top.overlap)?;
        let crowded: Vec<usize> = (0..top.count())
            .filter(|&i| top.cell(i).len() > params.refine_above as usize)
            .collect();
        let built: Vec<Result<Option<Cells>, GridBuildError>> = crowded
            .par_iter()
            .map(|&i| {
                let prims = top.cell(i);
                let c = [
                    i as u32 % dims[0],
                    i as u32 / dims[0] % dims[1],
                    i as u32 / (dims[0] * dims[1]),
                ];
                let (lo, hi) = top.cell_box(c);
                let ext = std::array::from_fn(|a| hi[a] - lo[a]);
                let sub_dims = resolution(
                    ext,
                    f64::from(params.cell.density) * prims.len() as f64,
                    min_size,
                );
                if sub_dims == [1, 1, 1] {
                    return Ok(None);
                }
                let mut sub = Cells::geometry(lo, hi, sub_dims);
                sub.fill(corners, prims, frame.pad, params.cell.overlap)?;
                Ok(Some(sub))
            })
            .collect();
        let mut sub_of = vec![0u32; top.count()];
        let mut subs = Vec::new();
        for (&i, b) in crowded.iter().zip(built) {
            if let Some(sub) = b? {
                subs.push(sub);
                sub_of[i] = subs.len() as u32;
            }
        }
        Ok(HGrid {
            mesh,
            top,
            sub_of,
            subs,
            frame,
            params: *params,
        })
    }

    /// Top cell `i`'s sub-grid, if it has one.
    #[inline(always)]
    pub(crate) fn sub(&self, i: usize) -> Option<&Cells> {
        match self.sub_of[i] {
            0 => None,
            s => Some(&self.subs[s as usize - 1]),
        }
    }

    /// The mesh the grid was built over.
    ///
    /// ```
    /// use packtrace::grid::{HGrid, HGridParams};
    /// let g = HGrid::build(packtrace::Mesh::default(), &HGridParams::default()).unwrap();
    /// assert!(g.mesh().is_empty());
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// The build parameters.
    ///
    /// ```
    /// use packtrace::grid::{HGrid, HGridParams};
    /// let g = HGrid::build(packtrace::Mesh::default(), &HGridParams::default()).unwrap();
    /// assert_eq!(g.params(), &HGridParams::default());
    /// ```
    #[must_use]
    pub fn params(&self) -> &HGridParams {
        &self.params
    }

    /// Build statistics of both levels together: cells, references,
    /// memory, sub-grids.
    ///
    /// ```
    /// use packtrace::grid::{HGrid, HGridParams};
    /// use packtrace::glam::Vec3;
    /// let mesh = packtrace::Mesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![[0, 1, 2]]).unwrap();
    /// let s = HGrid::build(mesh, &HGridParams::default()).unwrap().stats();
    /// assert_eq!((s.cells, s.subgrids), (1, 0));
    /// ```
    #[must_use]
    pub fn stats(&self) -> GridStats {
        let mut s = GridStats {
            triangles: self.mesh.triangle_count(),
            dims: self.top.dims,
            subgrids: self.subs.len(),
            ..GridStats::default()
        };
        s.add(&self.top);
        for sub in &self.subs {
            s.add(sub);
        }
        s.bytes = self.top.bytes()
            + self.subs.iter().map(Cells::bytes).sum::<usize>()
            + self.sub_of.len() * 4;
        s
    }
}

/// A grid's build statistics.
///
/// ```
/// let s = packtrace::grid::GridStats { triangles: 10, references: 25, ..Default::default() };
/// assert_eq!(s.references_per_triangle(), 2.5);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GridStats {
    /// Triangles of the mesh.
    pub triangles: usize,
    /// Cells along each axis (the top level's, for an [`HGrid`]).
    pub dims: [u32; 3],
    /// Cells, every level.
    pub cells: usize,
    /// Cells with no triangle.
    pub empty_cells: usize,
    /// Triangle references, every level.
    pub references: usize,
    /// The most triangles in one cell.
    pub max_per_cell: usize,
    /// Sub-grids (an [`HGrid`]'s refined top cells).
    pub subgrids: usize,
    /// Bytes of the cell arrays.
    pub bytes: usize,
}

impl GridStats {
    /// References per triangle (0 for an empty mesh).
    ///
    /// ```
    /// assert_eq!(packtrace::grid::GridStats::default().references_per_triangle(), 0.0);
    /// ```
    #[must_use]
    pub fn references_per_triangle(&self) -> f64 {
        if self.triangles == 0 {
            0.0
        } else {
            self.references as f64 / self.triangles as f64
        }
    }

    fn add(&mut self, c: &Cells) {
        self.cells += c.count();
        self.references += c.prims.len();
        for i in 0..c.count() {
            let n = c.cell(i).len();
            self.empty_cells += usize::from(n == 0);
            self.max_per_cell = self.max_per_cell.max(n);
        }
    }
}
