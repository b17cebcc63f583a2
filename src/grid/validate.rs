//! The grids' invariants: well-formed cell arrays, and every cell a
//! triangle meets (exactly, without the pad) lists it.

use super::cells::Cells;
use super::{Grid, HGrid};
use glam::Vec3;
use std::fmt;

/// A broken invariant of a grid.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum GridValidationError {
    /// The offset table is not `cells + 1` ascending entries ending at the
    /// reference count.
    Offsets,
    /// A cell lists a triangle index past the mesh's, or lists triangles
    /// out of ascending order.
    BadReference {
        /// The flat cell index.
        cell: usize,
    },
    /// A cell the triangle meets does not list it.
    Missing {
        /// The triangle.
        prim: u32,
        /// The cell.
        cell: [u32; 3],
        /// The sub-grid (`None`: the top level or a uniform grid).
        sub: Option<usize>,
    },
}

impl fmt::Display for GridValidationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GridValidationError::Offsets => write!(f, "the cell offset table is malformed"),
            GridValidationError::BadReference { cell } => write!(
                f,
                "cell {cell} lists a triangle out of range or out of order"
            ),
            GridValidationError::Missing { prim, cell, sub } => write!(
                f,
                "triangle {prim} meets cell {cell:?}{} but is not listed there",
                sub.map_or(String::new(), |s| format!(" of sub-grid {s}"))
            ),
        }
    }
}

impl std::error::Error for GridValidationError {}

/// Checks one grid's arrays, and that each triangle of `prims` is listed
/// in every cell it meets.
fn check(
    c: &Cells,
    corners: &[[Vec3; 3]],
    prims: &[u32],
    sub: Option<usize>,
) -> Result<(), GridValidationError> {
    let n = c.count();
    if c.offsets.len() != n + 1
        || c.offsets[0] != 0
        || c.offsets.windows(2).any(|w| w[0] > w[1])
        || c.offsets[n] as usize != c.prims.len()
    {
        return Err(GridValidationError::Offsets);
    }
    for cell in 0..n {
        let list = c.cell(cell);
        if list.iter().any(|&p| p as usize >= corners.len())
            || list.windows(2).any(|w| w[0] >= w[1])
        {
            return Err(GridValidationError::BadReference { cell });
        }
    }
    for &prim in prims {
        let v = corners[prim as usize].map(|p| [p.x, p.y, p.z].map(f64::from));
        let c0: [u32; 3] = std::array::from_fn(|a| c.coord(a, v[0][a].min(v[1][a]).min(v[2][a])));
        let c1: [u32; 3] = std::array::from_fn(|a| c.coord(a, v[0][a].max(v[1][a]).max(v[2][a])));
        for z in c0[2]..=c1[2] {
            for y in c0[1]..=c1[1] {
                for x in c0[0]..=c1[0] {
                    let cell = [x, y, z];
                    if c.meets(cell, &v, 0.0) && c.cell(c.index(cell)).binary_search(&prim).is_err()
                    {
                        return Err(GridValidationError::Missing { prim, cell, sub });
                    }
                }
            }
        }
    }
    Ok(())
}

impl Grid {
    /// Checks the grid's invariants: the offset table, every reference in
    /// range and ascending within its cell, and every triangle listed in
    /// every cell it meets.
    ///
    /// # Errors
    /// The first broken invariant found.
    ///
    /// ```
    /// use packtrace::grid::{Grid, GridParams};
    /// let mesh = packtrace::protocol::generate::jittered_sphere(200, 1, 0.1);
    /// assert_eq!(Grid::build(mesh, &GridParams::default()).unwrap().validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), GridValidationError> {
        let all = super::live_triangles(&self.mesh);
        check(&self.cells, self.mesh.corner_slice(), &all, None)
    }
}

impl HGrid {
    /// Checks both levels: the top level as [`Grid::validate`] does, and
    /// each sub-grid against the triangles of its top cell.
    ///
    /// # Errors
    /// The first broken invariant found.
    ///
    /// ```
    /// use packtrace::grid::{HGrid, HGridParams};
    /// let mesh = packtrace::protocol::generate::jittered_sphere(2000, 1, 0.1);
    /// let g = HGrid::build(mesh, &HGridParams::default()).unwrap();
    /// assert!(g.stats().subgrids > 0);
    /// assert_eq!(g.validate(), Ok(()));
    /// ```
    pub fn validate(&self) -> Result<(), GridValidationError> {
        let corners = self.mesh().corner_slice();
        let all = super::live_triangles(self.mesh());
        check(&self.top, corners, &all, None)?;
        for i in 0..self.top.count() {
            if let Some(sub) = self.sub(i) {
                check(sub, corners, self.top.cell(i), Some(i))?;
            }
        }
        Ok(())
    }
}
