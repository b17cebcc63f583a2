//! The area lights of a path-traced scene: its emissive triangles, chosen
//! in proportion to their power (luminance times area) and sampled
//! uniformly by area (PBRT-v3, 13.6.4 and 14.2).

use crate::mesh::Mesh;
use glam::Vec3;

/// Luminance of linear Rec. 709 RGB.
#[inline]
pub(super) fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

/// The emissive triangles and their power distribution.
#[derive(Clone, Debug, Default)]
pub(super) struct Lights {
    /// The emissive triangles of positive area.
    prims: Vec<u32>,
    /// Running sum of their power, normalised: the last entry is 1.
    cdf: Vec<f32>,
    /// Their summed power (luminance times area).
    power: f32,
}

/// A point on a light.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightSample {
    pub(super) point: Vec3,
    /// The light's unit normal: it emits on this side.
    pub(super) normal: Vec3,
    pub(super) radiance: Vec3,
    /// Density of the point per unit area (power choice times uniform
    /// area sampling).
    pub(super) pdf_area: f32,
}

impl Lights {
    /// The lights of `mesh` with per-triangle radiance `emission` (one per
    /// triangle, or empty for none).
    pub(super) fn new(mesh: &Mesh, emission: &[Vec3]) -> Lights {
        let (mut prims, mut sums) = (Vec::new(), Vec::new());
        let mut total = 0.0f64;
        for (i, &e) in emission.iter().enumerate() {
            let c = mesh.corners(i);
            let area = 0.5 * (c[1] - c[0]).cross(c[2] - c[0]).length();
            let power = luminance(e) as f64 * area as f64;
            if power > 0.0 && !mesh.is_degenerate(i) {
                total += power;
                prims.push(i as u32);
                sums.push(total);
            }
        }
        let mut cdf: Vec<f32> = sums.iter().map(|s| (s / total) as f32).collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        Lights {
            prims,
            cdf,
            power: total as f32,
        }
    }

    /// No light to sample.
    #[inline]
    pub(super) fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }

    /// Number of emissive triangles.
    pub(super) fn len(&self) -> usize {
        self.prims.len()
    }

    /// Density per unit area of [`Lights::sample`] choosing a point on a
    /// triangle of radiance `radiance`.
    #[inline]
    pub(super) fn pdf_area(&self, radiance: Vec3) -> f32 {
        luminance(radiance) / self.power
    }

    /// A point on the lights from three uniforms: `u[0]` picks the
    /// triangle by power, `u[1], u[2]` the point, uniform in area
    /// (`b0 = 1 - sqrt(u1)`, `b1 = u2 sqrt(u1)`). Only called when there is
    /// a light.
    #[inline]
    pub(super) fn sample(&self, mesh: &Mesh, emission: &[Vec3], u: [f32; 3]) -> LightSample {
        let k = self
            .cdf
            .partition_point(|&c| c <= u[0])
            .min(self.prims.len() - 1);
        let prim = self.prims[k] as usize;
        let c = mesh.corners(prim);
        let su = u[1].sqrt();
        let (b0, b1) = (1.0 - su, u[2] * su);
        let radiance = emission[prim];
        LightSample {
            point: c[0] * b0 + c[1] * b1 + c[2] * (1.0 - b0 - b1),
            normal: mesh.normal(prim),
            radiance,
            pdf_area: self.pdf_area(radiance),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two lights of the same radiance, areas 1 and 3: chosen one time in
    /// four and three in four, every point on its triangle, the density
    /// one over the total area.
    #[test]
    fn lights_are_chosen_by_power_and_sampled_on_their_triangle() {
        let mesh = Mesh::new(
            vec![
                Vec3::ZERO,
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 5.0),
                Vec3::new(6.0, 0.0, 5.0),
                Vec3::new(0.0, 1.0, 5.0),
                Vec3::new(9.0, 9.0, 9.0),
                Vec3::new(9.0, 9.0, 9.0),
                Vec3::new(9.0, 9.0, 9.0),
            ],
            vec![[0, 1, 2], [3, 4, 5], [6, 7, 8]],
        )
        .unwrap();
        let e = vec![Vec3::ONE, Vec3::ONE, Vec3::ONE];
        let lights = Lights::new(&mesh, &e);
        assert_eq!(lights.len(), 2, "the degenerate one is no light");
        let mut second = 0;
        let n = 4000;
        for i in 0..n {
            let u = [(i as f32 + 0.5) / n as f32, (i * 7 % 13) as f32 / 13.0, 0.3];
            let s = lights.sample(&mesh, &e, u);
            assert!((s.pdf_area - 1.0 / 4.0).abs() < 1e-6);
            assert_eq!(s.normal, Vec3::Z);
            if s.point.z == 5.0 {
                second += 1;
                assert!(s.point.x / 6.0 + s.point.y <= 1.0 + 1e-6);
            } else {
                assert!(s.point.x / 2.0 + s.point.y <= 1.0 + 1e-6);
            }
        }
        assert_eq!(second, 3 * n / 4);
        assert!(Lights::new(&mesh, &[]).is_empty());
    }
}
