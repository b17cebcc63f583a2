//! One uniform grid's cells: the geometry in `f64` and the compact
//! arrays (one offset table, one index array; no per-cell vectors), and
//! their build over a set of triangles.
//!
//! Why `f64`: the grid shares the triangle test's margin rule
//! (`kdtree/margin.rs`): a hit the test reports lies within `7/8 eta` of
//! its triangle, `eta = MARGIN * M`. The build pads every triangle by
//! `pad >= eta` for every ray whose origin is within `PAD_REACH` times the
//! scene's magnitude, so the cell a hit point lies in always references
//! the triangle; in `f64` the grid's own arithmetic (cell coordinates,
//! plane distances) errs by some `1e-16 M`, far inside the last eighth,
//! and coordinates up to `f32::MAX` neither overflow nor lose cells.

use super::params::{GRID_MAX_CELLS, GridBuildError, Overlap};
use glam::Vec3;

/// Rays whose origin magnitude is up to this many times the scene's find
/// every cell they need on the walk itself; farther ones also search
/// the cells around it (`Cells::reach`).
pub(crate) const PAD_REACH: f64 = 16.0;

/// A uniform grid of cells over a box: where each cell's triangles are.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct Cells {
    /// The box's low corner.
    pub lo: [f64; 3],
    /// A cell's size along each axis.
    pub size: [f64; 3],
    /// `1 / size`.
    pub inv: [f64; 3],
    /// Cells along each axis.
    pub dims: [u32; 3],
    /// Cell `c`'s triangles are `prims[offsets[c]..offsets[c + 1]]`.
    pub offsets: Vec<u32>,
    /// Triangle indices, cell after cell, ascending within a cell.
    pub prims: Vec<u32>,
}

/// The cells along each axis for about `budget` cells over extents `ext`,
/// shaped like the box: `dims[a] ~ ext[a] * s` with
/// `prod(dims) ~ budget`. A flat axis (or one thinner than a cell would
/// be) gets one cell and leaves the budget to the others.
pub(crate) fn resolution(ext: [f64; 3], budget: f64, min_size: f64) -> [u32; 3] {
    let budget = budget.clamp(1.0, GRID_MAX_CELLS as f64);
    let mut free = ext.map(|e| e > 0.0);
    let mut dims = [1u32; 3];
    loop {
        let axes: Vec<usize> = (0..3).filter(|&a| free[a]).collect();
        if axes.is_empty() {
            break;
        }
        let vol: f64 = axes.iter().map(|&a| ext[a]).product();
        let s = (budget / vol).powf(1.0 / axes.len() as f64);
        let thin: Vec<usize> = axes.iter().copied().filter(|&a| ext[a] * s < 1.0).collect();
        if thin.is_empty() {
            for &a in &axes {
                dims[a] = (ext[a] * s).round().clamp(1.0, 4096.0) as u32;
            }
            break;
        }
        for a in thin {
            free[a] = false;
        }
    }
    for a in 0..3 {
        if min_size > 0.0 {
            let most = (ext[a] / min_size).floor().max(1.0);
            dims[a] = dims[a].min(most.min(4096.0) as u32);
        }
    }
    dims
}

impl Cells {
    /// The geometry of `dims` cells over `[lo, hi]` (no triangles yet).
    pub(crate) fn geometry(lo: [f64; 3], hi: [f64; 3], dims: [u32; 3]) -> Cells {
        let size: [f64; 3] = std::array::from_fn(|a| {
            let ext = hi[a] - lo[a];
            if ext > 0.0 {
                ext / f64::from(dims[a])
            } else {
                1.0
            }
        });
        Cells {
            lo,
            size,
            inv: size.map(|s| 1.0 / s),
            dims,
            offsets: Vec::new(),
            prims: Vec::new(),
        }
    }

    /// The number of cells.
    #[inline]
    pub(crate) fn count(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// The cell along axis `a` holding coordinate `x`; points outside the
    /// box belong to the border cell nearest them.
    #[inline(always)]
    pub(crate) fn coord(&self, a: usize, x: f64) -> u32 {
        let c = ((x - self.lo[a]) * self.inv[a]).floor();
        if c >= f64::from(self.dims[a]) {
            self.dims[a] - 1
        } else if c > 0.0 {
            c as u32
        } else {
            0
        }
    }

    /// The plane between cells `i - 1` and `i` along axis `a`.
    #[inline(always)]
    pub(crate) fn plane(&self, a: usize, i: u32) -> f64 {
        self.lo[a] + f64::from(i) * self.size[a]
    }

    /// The flat index of cell `c`.
    #[inline(always)]
    pub(crate) fn index(&self, c: [u32; 3]) -> usize {
        (c[2] as usize * self.dims[1] as usize + c[1] as usize) * self.dims[0] as usize
            + c[0] as usize
    }

    /// Cell `i`'s triangles.
    #[inline(always)]
    pub(crate) fn cell(&self, i: usize) -> &[u32] {
        &self.prims[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Cell `c`'s box.
    pub(crate) fn cell_box(&self, c: [u32; 3]) -> ([f64; 3], [f64; 3]) {
        (
            std::array::from_fn(|a| self.plane(a, c[a])),
            std::array::from_fn(|a| self.plane(a, c[a] + 1)),
        )
    }

    /// How many cells around the walk's own a ray with margin `eta` must
    /// also search along each axis: none while the build's `pad` covers
    /// it (every ray whose origin is within `PAD_REACH` scene magnitudes).
    #[inline(always)]
    pub(crate) fn reach(&self, eta: f64, pad: f64) -> [u32; 3] {
        if eta <= pad {
            return [0; 3];
        }
        std::array::from_fn(|a| {
            let k = ((eta - pad) * self.inv[a]).ceil();
            if k >= f64::from(self.dims[a]) {
                self.dims[a]
            } else {
                k as u32
            }
        })
    }

    /// Fills the cells with the triangles `prims` of `corners`, each padded
    /// by `pad`, by `overlap`'s rule. Deterministic: each cell lists its
    /// triangles in the order of `prims`, for any thread count.
    ///
    /// Each triangle's cells are found once, in parallel chunks (the
    /// overlap test is most of the build), then placed by a counting sort
    /// on the cell. Counting first and testing every triangle again to
    /// place it, with the test set up per cell, took 0.112 s on Sponza
    /// (one thread); this and [`Sat`] take 0.019-0.030 s (measured
    /// together, `docs/grids.md`).
    ///
    /// # Errors
    /// [`GridBuildError::TooManyReferences`] past `u32` indices.
    pub(crate) fn fill(
        &mut self,
        corners: &[[Vec3; 3]],
        prims: &[u32],
        pad: f64,
        overlap: Overlap,
    ) -> Result<(), GridBuildError> {
        use rayon::prelude::*;
        let n = self.count();
        let refs: Vec<Vec<(u32, u32)>> = prims
            .par_chunks(4096)
            .map(|chunk| {
                let mut out = Vec::with_capacity(chunk.len() * 4);
                self.each_reference(corners, chunk, pad, overlap, |cell, prim| {
                    out.push((cell as u32, prim));
                });
                out
            })
            .collect();
        let total: u64 = refs.iter().map(|r| r.len() as u64).sum();
        if total > u64::from(u32::MAX) {
            return Err(GridBuildError::TooManyReferences(total));
        }
        // Counting sort on the cell, stable: `offsets[c]` is cell `c`'s
        // first slot.
        let mut offsets = vec![0u32; n + 1];
        for &(cell, _) in refs.iter().flatten() {
            offsets[cell as usize + 1] += 1;
        }
        for c in 0..n {
            offsets[c + 1] += offsets[c];
        }
        let mut next = offsets.clone();
        let mut out = vec![0u32; total as usize];
        for &(cell, prim) in refs.iter().flatten() {
            out[next[cell as usize] as usize] = prim;
            next[cell as usize] += 1;
        }
        self.offsets = offsets;
        self.prims = out;
        Ok(())
    }

    /// Calls `f(cell, prim)` for each reference, triangle after triangle.
    fn each_reference(
        &self,
        corners: &[[Vec3; 3]],
        prims: &[u32],
        pad: f64,
        overlap: Overlap,
        mut f: impl FnMut(usize, u32),
    ) {
        // Every cell grown by the pad has the same half size.
        let half: [f64; 3] = std::array::from_fn(|a| 0.5 * self.size[a] + pad);
        for &prim in prims {
            let v = corners[prim as usize].map(|p| [p.x, p.y, p.z].map(f64::from));
            let lo: [f64; 3] = std::array::from_fn(|a| v[0][a].min(v[1][a]).min(v[2][a]) - pad);
            let hi: [f64; 3] = std::array::from_fn(|a| v[0][a].max(v[1][a]).max(v[2][a]) + pad);
            let c0: [u32; 3] = std::array::from_fn(|a| self.coord(a, lo[a]));
            let c1: [u32; 3] = std::array::from_fn(|a| self.coord(a, hi[a]));
            // A box of one cell needs no finer test.
            let sat = (overlap == Overlap::Triangles && c0 != c1).then(|| Sat::new(&v, half));
            for z in c0[2]..=c1[2] {
                for y in c0[1]..=c1[1] {
                    for x in c0[0]..=c1[0] {
                        let c = [x, y, z];
                        if let Some(sat) = &sat {
                            let centre = std::array::from_fn(|a| {
                                self.lo[a] + (f64::from(c[a]) + 0.5) * self.size[a]
                            });
                            if !sat.meets(centre) {
                                continue;
                            }
                        }
                        f(self.index(c), prim);
                    }
                }
            }
        }
    }

    /// Does triangle `v` meet cell `c` grown by `pad`? The separating axis
    /// test (Akenine-Möller 2001, "Fast 3D triangle-box overlap testing"):
    /// the box's three axes are covered by the candidate range; here the
    /// triangle's normal and the nine edge-cross-axis directions. It errs
    /// towards "meets" by a relative `1e-9`, far above `f64`'s rounding.
    pub(crate) fn meets(&self, c: [u32; 3], v: &[[f64; 3]; 3], pad: f64) -> bool {
        let (lo, hi) = self.cell_box(c);
        let centre: [f64; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let half: [f64; 3] = std::array::from_fn(|a| 0.5 * (hi[a] - lo[a]) + pad);
        let p = v.map(|q| std::array::from_fn::<f64, 3, _>(|a| q[a] - centre[a]));
        let sub = |x: [f64; 3], y: [f64; 3]| -> [f64; 3] { std::array::from_fn(|a| x[a] - y[a]) };
        let cross = |x: [f64; 3], y: [f64; 3]| -> [f64; 3] {
            [
                x[1] * y[2] - x[2] * y[1],
                x[2] * y[0] - x[0] * y[2],
                x[0] * y[1] - x[1] * y[0],
            ]
        };
        let dot = |x: [f64; 3], y: [f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        // Separated along `axis`: the triangle's projection clears the
        // box's by more than the tolerance.
        let separated = |axis: [f64; 3]| -> bool {
            let r = half[0] * axis[0].abs() + half[1] * axis[1].abs() + half[2] * axis[2].abs();
            let d = [dot(axis, p[0]), dot(axis, p[1]), dot(axis, p[2])];
            let (mn, mx) = (d[0].min(d[1]).min(d[2]), d[0].max(d[1]).max(d[2]));
            let tol = 1e-9 * (r + mn.abs().max(mx.abs()));
            mn > r + tol || mx < -r - tol
        };
        let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
        if separated(cross(e[0], e[1])) {
            return false;
        }
        for edge in e {
            for a in 0..3 {
                let mut u = [0.0; 3];
                u[a] = 1.0;
                if separated(cross(u, edge)) {
                    return false;
                }
            }
        }
        true
    }

    /// Bytes of the cell arrays.
    pub(crate) fn bytes(&self) -> usize {
        (self.offsets.len() + self.prims.len()) * 4
    }
}

/// The build's separating axis test of one triangle against cells of one
/// size (Akenine-Möller 2001), set up once per triangle: its normal and
/// the nine edge-cross-axis directions, the triangle's extent along each
/// and each cell's projected half size. A cell then costs a dot product
/// and two compares per axis ([`Cells::meets`], which `validate` uses,
/// sets the same test up per cell). It errs towards "meets" by a relative
/// `1e-9` of the coordinates, far above `f64`'s rounding.
struct Sat {
    axes: [[f64; 3]; 10],
    lo: [f64; 10],
    hi: [f64; 10],
    /// The grown cell's half extent along each axis, plus the tolerance.
    r: [f64; 10],
}

impl Sat {
    fn new(v: &[[f64; 3]; 3], half: [f64; 3]) -> Sat {
        let sub = |x: [f64; 3], y: [f64; 3]| -> [f64; 3] { std::array::from_fn(|a| x[a] - y[a]) };
        let cross = |x: [f64; 3], y: [f64; 3]| -> [f64; 3] {
            [
                x[1] * y[2] - x[2] * y[1],
                x[2] * y[0] - x[0] * y[2],
                x[0] * y[1] - x[1] * y[0],
            ]
        };
        let e = [sub(v[1], v[0]), sub(v[2], v[1]), sub(v[0], v[2])];
        let mut axes = [[0.0; 3]; 10];
        axes[0] = cross(e[0], e[1]);
        for (k, edge) in e.iter().enumerate() {
            for a in 0..3 {
                let mut u = [0.0; 3];
                u[a] = 1.0;
                axes[1 + 3 * k + a] = cross(u, *edge);
            }
        }
        let dot = |x: &[f64; 3], y: &[f64; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        let mag = v.iter().flatten().fold(0.0f64, |m, x| m.max(x.abs()))
            + half[0].max(half[1]).max(half[2]);
        let mut s = Sat {
            axes,
            lo: [0.0; 10],
            hi: [0.0; 10],
            r: [0.0; 10],
        };
        for (k, ax) in axes.iter().enumerate() {
            let d = [dot(ax, &v[0]), dot(ax, &v[1]), dot(ax, &v[2])];
            s.lo[k] = d[0].min(d[1]).min(d[2]);
            s.hi[k] = d[0].max(d[1]).max(d[2]);
            let norm1 = ax[0].abs() + ax[1].abs() + ax[2].abs();
            s.r[k] = half[0] * ax[0].abs()
                + half[1] * ax[1].abs()
                + half[2] * ax[2].abs()
                + 1e-9 * norm1 * mag * 4.0;
        }
        s
    }

    /// Does the triangle meet the grown cell centred at `c`?
    #[inline]
    fn meets(&self, c: [f64; 3]) -> bool {
        for (k, ax) in self.axes.iter().enumerate() {
            let d = ax[0] * c[0] + ax[1] * c[1] + ax[2] * c[2];
            if self.lo[k] - d > self.r[k] || self.hi[k] - d < -self.r[k] {
                return false;
            }
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolution_follows_the_box_and_the_budget() {
        let d = resolution([1.0, 1.0, 1.0], 1000.0, 0.0);
        assert_eq!(d, [10, 10, 10]);
        let d = resolution([4.0, 1.0, 1.0], 256.0, 0.0);
        assert_eq!(d, [16, 4, 4]);
        // A flat box spends the budget on its two axes.
        let d = resolution([1.0, 1.0, 0.0], 100.0, 0.0);
        assert_eq!(d, [10, 10, 1]);
        // Cells no smaller than `min_size`.
        let d = resolution([1.0, 1.0, 1.0], 1e6, 0.25);
        assert_eq!(d, [4, 4, 4]);
    }

    #[test]
    fn coordinates_outside_the_box_clamp_to_border_cells() {
        let c = Cells::geometry([0.0; 3], [4.0; 3], [4, 4, 4]);
        assert_eq!(c.coord(0, -1.0), 0);
        assert_eq!(c.coord(0, 9.0), 3);
        assert_eq!(c.coord(0, 4.0), 3);
        assert_eq!(c.coord(0, 2.0), 2);
        assert_eq!(c.coord(0, 1.999), 1);
    }

    #[test]
    fn the_separating_axis_test_drops_cells_a_diagonal_triangle_misses() {
        let mut c = Cells::geometry([0.0; 3], [4.0; 3], [4, 4, 4]);
        let tri = [[
            Vec3::new(0.0, 0.0, 0.5),
            Vec3::new(4.0, 0.0, 0.5),
            Vec3::new(0.0, 4.0, 0.5),
        ]];
        c.fill(&tri, &[0], 1e-6, Overlap::Boxes).unwrap();
        let boxes = c.prims.len();
        c.fill(&tri, &[0], 1e-6, Overlap::Triangles).unwrap();
        // The box covers the bottom layer's 4 x 4 cells; the triangle
        // (x + y <= 4) only the 13 cells whose low corner has i + j <= 4.
        assert_eq!(boxes, 16);
        assert_eq!(c.prims.len(), 13);
        assert!(c.meets(
            [0, 0, 0],
            &[[0.0, 0.0, 0.5], [4.0, 0.0, 0.5], [0.0, 4.0, 0.5]],
            0.0
        ));
        assert!(!c.meets(
            [3, 3, 0],
            &[[0.0, 0.0, 0.5], [4.0, 0.0, 0.5], [0.0, 4.0, 0.5]],
            0.0
        ));
    }
}
