//! One tile of one pass: its paths traced together, one depth at a time
//! (a wavefront per tile, Laine, Karras and Aila, "Megakernels Considered
//! Harmful", HPG 2013): the camera rays of the tile's samples, then per
//! depth the shading of every live path (emission, a light sample, a
//! bounce), the batch of shadow rays and the batch of bounce rays. Then
//! each pixel's samples are added to the film in sample order.
//!
//! The estimator is the unidirectional path tracer of PBRT-v3 (14.5) on
//! two-sided Lambertian surfaces: cosine-weighted bounces, next-event
//! estimation from one point on the area lights per vertex, the two
//! combined by the power heuristic (Veach and Guibas, "Optimally
//! Combining Sampling Techniques for Monte Carlo Rendering", SIGGRAPH
//! 1995), and Russian roulette on the path's throughput.

use super::batch::Batch;
use super::sampler::Rng;
use super::{Estimator, Film, PathOptions, PathScene, PathStats};
use crate::packet::RayPacket8;
use crate::protocol::camera::ImagePlane;
use crate::protocol::sampling::onb;
use crate::query::PacketQuery;
use crate::ray::{Hit, Ray};
use crate::render::{RenderError, Tile};
use crate::spawn::{hit_point, offset_origin};
use glam::Vec3;
use std::f32::consts::{FRAC_1_PI, PI};
use std::time::Instant;

/// A lane of a camera packet without a path (past the tile's edge).
const NO_PATH: u32 = u32::MAX;

/// Highest survival probability of Russian roulette: a path whose
/// throughput stays near one still ends now and then.
const MAX_SURVIVAL: f32 = 0.95;

/// A shadow ray stops this fraction of its length short of the light, so
/// it does not hit the light's own triangle.
const SHADOW_SHORT: f32 = 1e-4;

/// Everything a tile worker reads.
pub(super) struct Work<'a, Q: ?Sized> {
    pub(super) batch: Batch<'a, Q>,
    pub(super) scene: &'a PathScene<'a>,
    pub(super) opts: &'a PathOptions,
    pub(super) lens: ImagePlane,
}

/// A tile's film after the pass, and what the pass traced.
pub(super) struct TileOut {
    /// Per pixel of the tile, row-major: the radiance summed over all
    /// samples so far.
    pub(super) sum: Vec<Vec3>,
    /// The same of the squared radiance.
    pub(super) sum_sq: Vec<Vec3>,
    pub(super) stats: PathStats,
}

/// One path's state between depths.
#[derive(Clone, Copy)]
struct Path {
    /// Where its radiance goes: `local pixel * samples in the pass +
    /// sample in the pass`.
    slot: u32,
    rng: Rng,
    /// The ray that found the current vertex.
    ray: Ray,
    /// Throughput: the product of `albedo * cos / pdf` along the path
    /// (and of Russian roulette's `1 / q`).
    beta: Vec3,
    radiance: Vec3,
    /// Bounces so far: 0 at the camera ray's hit.
    depth: u32,
    /// Solid-angle density of the bounce that made `ray` (for the MIS
    /// weight of the emission it finds).
    pdf_bsdf: f32,
}

/// What a vertex asks to trace next.
struct Vertex {
    /// A shadow ray toward a light point, with what it adds if unoccluded.
    shadow: Option<(Ray, Vec3)>,
    /// The bounce ray, if the path goes on.
    bounce: Option<Ray>,
}

impl<Q: PacketQuery + ?Sized> Work<'_, Q> {
    /// Samples `first .. first + count` of every pixel of tile `t`, added
    /// to `film`'s sums.
    ///
    /// # Errors
    /// [`RenderError::ForeignHit`] when the query is not the scene mesh's.
    pub(super) fn tile(
        &self,
        t: Tile,
        first: u32,
        count: u32,
        film: &Film,
    ) -> Result<TileOut, RenderError> {
        let (paths, mut stats) = self.trace(t, first, count)?;
        let mut radiance = vec![Vec3::ZERO; paths.len()];
        for p in &paths {
            radiance[p.slot as usize] = if p.radiance.is_finite() {
                p.radiance
            } else {
                stats.dropped += 1;
                Vec3::ZERO
            };
        }
        // Each pixel's samples in sample order: the sums are the same for
        // any split into passes.
        let (tw, th) = (t.width(), t.height());
        let (mut sum, mut sum_sq) = (Vec::with_capacity(tw * th), Vec::with_capacity(tw * th));
        for ly in 0..th {
            for lx in 0..tw {
                let i = (t.y0 as usize + ly) * film.width as usize + t.x0 as usize + lx;
                let (mut s, mut s2) = (film.sum[i], film.sum_sq[i]);
                let local = ly * tw + lx;
                for c in &radiance[local * count as usize..(local + 1) * count as usize] {
                    s += *c;
                    s2 += *c * *c;
                }
                sum.push(s);
                sum_sq.push(s2);
            }
        }
        Ok(TileOut { sum, sum_sq, stats })
    }

    /// The tile's paths of samples `first .. first + count`, traced to
    /// their end.
    fn trace(
        &self,
        t: Tile,
        first: u32,
        count: u32,
    ) -> Result<(Vec<Path>, PathStats), RenderError> {
        let mut stats = PathStats::default();
        let (mut paths, packets) = self.camera_paths(t, first, count);
        stats.paths = paths.len() as u64;

        // Camera rays: 4 x 2 pixel blocks as 8-wide packets (coherent)
        let mut hits = vec![None; paths.len()];
        let clock = Instant::now();
        for (packet, lanes) in &packets {
            let h = self.batch.query.intersect8(packet);
            for (i, &p) in lanes.iter().enumerate() {
                if p != NO_PATH {
                    hits[p as usize] = h.hit(i);
                }
            }
        }
        stats.camera.add(paths.len(), clock.elapsed());

        let mut active: Vec<u32> = (0..paths.len() as u32).collect();
        let (mut shadow, mut unlit, mut lit) = (Vec::new(), Vec::new(), Vec::new());
        let (mut bounce, mut next) = (Vec::new(), Vec::new());
        while !active.is_empty() {
            // Shade every live path's vertex: emission, light sample, bounce
            shadow.clear();
            lit.clear();
            bounce.clear();
            next.clear();
            for (&p, hit) in active.iter().zip(&hits) {
                let path = &mut paths[p as usize];
                let v = self.vertex(path, hit.as_ref())?;
                if let Some((ray, c)) = v.shadow {
                    shadow.push(ray);
                    lit.push((p, c));
                }
                if let Some(ray) = v.bounce {
                    bounce.push(ray);
                    next.push(p);
                }
            }

            // Shadow rays: add the light of those that reach it
            unlit.clear();
            unlit.resize(shadow.len(), false);
            let clock = Instant::now();
            self.batch.occluded(&shadow, &mut unlit);
            stats.shadow.add(shadow.len(), clock.elapsed());
            for (&(p, c), &o) in lit.iter().zip(&unlit) {
                if !o {
                    paths[p as usize].radiance += c;
                }
            }

            // Bounce rays: the next depth's vertices
            hits.clear();
            hits.resize(bounce.len(), None);
            let clock = Instant::now();
            self.batch.intersect(&bounce, &mut hits);
            stats.bounce.add(bounce.len(), clock.elapsed());
            std::mem::swap(&mut active, &mut next);
        }
        Ok((paths, stats))
    }

    /// A path per pixel of the tile and sample, and the camera packets:
    /// per sample, the tile's 4 x 2 blocks, each lane naming its path
    /// ([`NO_PATH`] past the tile's right edge). The first two numbers of
    /// a path's stream jitter its camera ray inside the pixel.
    fn camera_paths(
        &self,
        t: Tile,
        first: u32,
        count: u32,
    ) -> (Vec<Path>, Vec<(RayPacket8, [u32; 8])>) {
        let tw = t.width() as u32;
        let mut paths = Vec::with_capacity(t.width() * t.height() * count as usize);
        let mut packets = Vec::new();
        for s in 0..count {
            for (x, y) in t.blocks(4) {
                let mut lanes = [NO_PATH; 8];
                let mut rays = [None; 8];
                for i in 0..8u32 {
                    let (px, py) = (x + i % 4, y + i / 4);
                    if px >= t.x1 {
                        continue;
                    }
                    let pixel = py * self.opts.width + px;
                    let mut rng = Rng::new(pixel, first + s, self.opts.seed);
                    let jitter = (rng.next(), rng.next());
                    let ray = self.lens.ray_at(px, py, jitter);
                    let local = (py - t.y0) * tw + (px - t.x0);
                    lanes[i as usize] = paths.len() as u32;
                    rays[i as usize] = Some(ray);
                    paths.push(Path {
                        slot: local * count + s,
                        rng,
                        ray,
                        beta: Vec3::ONE,
                        radiance: Vec3::ZERO,
                        depth: 0,
                        pdf_bsdf: 0.0,
                    });
                }
                packets.push((RayPacket8::from_lanes(rays), lanes));
            }
        }
        (paths, packets)
    }

    /// The vertex a path's ray found (`None`: it left the scene): the
    /// emission seen there, weighted for the estimator; then, unless the
    /// path ends here, a shadow ray toward one light point and the bounce
    /// ray, cosine-weighted, after Russian roulette.
    #[inline]
    fn vertex(&self, path: &mut Path, hit: Option<&Hit>) -> Result<Vertex, RenderError> {
        let end = Vertex {
            shadow: None,
            bounce: None,
        };
        let scene = self.scene;
        let Some(hit) = hit else {
            // The sky: not sampled by next-event estimation, so no weight.
            path.radiance += path.beta * scene.sky;
            return Ok(end);
        };
        let mesh = scene.mesh;
        let prim = hit.prim as usize;
        if prim >= mesh.triangle_count() {
            return Err(RenderError::ForeignHit {
                prim: hit.prim,
                triangles: mesh.triangle_count(),
            });
        }
        let dir = path.ray.dir;
        let n_g = mesh.normal(prim);
        // Two-sided surfaces: shade on the side the ray came from.
        let n = if n_g.dot(dir) > 0.0 { -n_g } else { n_g };

        // Emission: lights emit on the side their winding faces
        let le = scene.emission[prim];
        let cos_l = -n_g.dot(dir);
        if le != Vec3::ZERO && cos_l > 0.0 {
            let w = match (path.depth, self.opts.estimator) {
                (0, _) | (_, Estimator::Bsdf) => 1.0,
                (_, Estimator::Light) => 0.0,
                (_, Estimator::Mis) => {
                    let pdf_light = scene.lights.pdf_area(le) * hit.t * hit.t / cos_l;
                    power_heuristic(path.pdf_bsdf, pdf_light)
                }
            };
            path.radiance += path.beta * le * w;
        }
        if path.depth >= self.opts.max_depth {
            return Ok(end);
        }

        let albedo = scene.albedo[prim];
        let q = offset_origin(hit_point(mesh, hit), n);
        let rng = &mut path.rng;

        // Next-event estimation: one point on the lights
        let mut shadow = None;
        if self.opts.estimator != Estimator::Bsdf && !scene.lights.is_empty() {
            let u = [rng.next(), rng.next(), rng.next()];
            let ls = scene.lights.sample(mesh, &scene.emission, u);
            let to = ls.point - q;
            let d = to.length();
            let wi = to / d;
            let (cos_s, cos_l) = (n.dot(wi), -ls.normal.dot(wi));
            if cos_s > 0.0 && cos_l > 0.0 && d > 0.0 {
                let pdf_light = ls.pdf_area * d * d / cos_l;
                let w = match self.opts.estimator {
                    Estimator::Mis => power_heuristic(pdf_light, cos_s * FRAC_1_PI),
                    _ => 1.0,
                };
                let c = path.beta * albedo * FRAC_1_PI * ls.radiance * (cos_s * w / pdf_light);
                let ray = Ray::new_unchecked(q, wi, 0.0, d * (1.0 - SHADOW_SHORT));
                shadow = Some((ray, c));
            }
        }

        // Bounce: cosine-weighted, so the throughput takes the albedo
        let (u1, u2) = (rng.next(), rng.next());
        let wi = cosine_direction(n, u1, u2);
        let cos = n.dot(wi);
        let mut beta = path.beta * albedo;
        let mut goes_on = cos > 0.0 && beta != Vec3::ZERO;
        // Russian roulette from `rr_depth` bounces on
        if goes_on && path.depth >= self.opts.rr_depth {
            let survive = beta.max_element().min(MAX_SURVIVAL);
            goes_on = rng.next() < survive;
            beta /= survive;
        }
        let bounce = goes_on.then(|| {
            let ray = Ray::new_unchecked(q, wi, 0.0, f32::INFINITY);
            path.ray = ray;
            path.beta = beta;
            path.pdf_bsdf = cos * FRAC_1_PI;
            path.depth += 1;
            ray
        });
        Ok(Vertex { shadow, bounce })
    }
}

/// Veach's power heuristic with exponent 2: the weight of the strategy
/// of density `a` against the one of density `b`.
#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    if a.is_infinite() {
        return 1.0;
    }
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 { a2 / (a2 + b2) } else { 0.0 }
}

/// A cosine-distributed direction around the unit normal `n` from two
/// uniforms (Malley's method: a uniform point on the disc, lifted to the
/// hemisphere), in the protocol's basis ([`onb`]), as the AO directions.
#[inline]
fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = 2.0 * PI * u2;
    let (b1, b2) = onb(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    (b1 * (r * phi.cos()) + b2 * (r * phi.sin()) + n * z).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        for (a, b) in [(1.0, 1.0), (0.3, 5.0), (1e-20, 1e3), (7.0, 0.0)] {
            let s = power_heuristic(a, b) + power_heuristic(b, a);
            assert!((s - 1.0).abs() < 1e-6, "{a} {b}");
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
        assert_eq!(power_heuristic(1.0, 1.0), 0.5);
    }

    /// Cosine-weighted: `E[cos] = 2/3`, `E[cos^2] = 1/2` over the
    /// hemisphere, every direction in it and of unit length.
    #[test]
    fn bounces_are_cosine_distributed() {
        let n = Vec3::new(0.3, -0.8, 0.52).normalize();
        let mut rng = Rng::new(1, 2, 3);
        let (mut c1, mut c2, k) = (0.0f64, 0.0f64, 100_000);
        for _ in 0..k {
            let d = cosine_direction(n, rng.next(), rng.next());
            assert!((d.length() - 1.0).abs() < 1e-5);
            let c = n.dot(d) as f64;
            assert!(c >= -1e-6);
            c1 += c;
            c2 += c * c;
        }
        let (c1, c2) = (c1 / k as f64, c2 / k as f64);
        // Standard deviations of cos and cos^2 are below 0.3.
        let tol = 4.0 * 0.3 / (k as f64).sqrt();
        assert!((c1 - 2.0 / 3.0).abs() < tol, "{c1}");
        assert!((c2 - 0.5).abs() < tol, "{c2}");
    }
}
