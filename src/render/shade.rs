//! Tracing and shading one block of pixels: the block's primary packet,
//! the shadow packet of its lanes that hit a surface facing the light, its
//! ambient-occlusion packets, and the colour of each lane; the per-tile
//! loops over blocks for images and heat maps. The tile scheduling, the
//! options and the public entry points are in `mod.rs`; what is traced (a
//! kd-tree or a scene) is a [`Target`] (`target.rs`). Group tiles and heat
//! maps are the kd-tree's only.

use super::target::{Target, TreeTarget};
use super::{RayCounts, RenderOptions, Tile, sample_jitter};
use crate::group::{Apex, RayGroup};
use crate::kdtree::TraversalStats;
use crate::packet::{RayPacket, RayPacket8};
use crate::protocol::camera::ImagePlane;
use crate::protocol::sampling::ao_direction;
use crate::protocol::workload::shadow_ray;
use crate::query::Mode;
use crate::ray::Ray;
use crate::simd::{F4, F8, Lane};
use crate::spawn::offset_origin;
use glam::Vec3;

// Shading constants: Lambertian surfaces (grey unless an albedo is given)
// lit by a warm point light without fall-off (any scene scale works) and a
// sky term: ambient light from the camera's up hemisphere, brighter on
// faces turned up than on faces turned down, scaled by the fraction of
// ambient-occlusion rays that escape. Lit faces, faces turned from the
// light and cast shadows then read apart even without AO.
const LIGHT: Vec3 = Vec3::new(0.95, 0.90, 0.80);
const SKY: Vec3 = Vec3::new(0.30, 0.33, 0.38);
const GROUND: Vec3 = Vec3::new(0.15, 0.14, 0.13);
const BACKGROUND_LOW: Vec3 = Vec3::new(0.004, 0.004, 0.006);
const BACKGROUND_HIGH: Vec3 = Vec3::new(0.035, 0.045, 0.065);

/// Where a primary ray hit, and what its secondary rays need.
#[derive(Clone, Copy)]
pub(super) struct Surface {
    /// Start of secondary rays: the hit point moved off the surface by
    /// [`offset_origin`] (Wächter and Binder 2019), on the viewer's side.
    q: Vec3,
    /// Geometric normal facing the viewer.
    n: Vec3,
    /// `dot(n, direction to the light)`.
    cos: f32,
    /// The shadow ray from `q` (the protocol's form: unit direction,
    /// `t_max` just short of the light).
    shadow: Ray,
    /// Diffuse colour of the triangle hit.
    albedo: Vec3,
}

/// Everything a tile worker reads.
pub(super) struct Ctx<'a, T> {
    /// What is traced, with its colours.
    target: &'a T,
    opts: &'a RenderOptions,
    lens: ImagePlane,
    /// `0.25 * D` (the scene's diagonal): reach of AO rays.
    ao_reach: f32,
}

impl<'a, T: Target> Ctx<'a, T> {
    pub(super) fn new(target: &'a T, opts: &'a RenderOptions) -> Ctx<'a, T> {
        Ctx {
            target,
            opts,
            lens: ImagePlane::new(&opts.camera, opts.width, opts.height),
            ao_reach: 0.25 * target.diagonal(),
        }
    }

    /// Closest hits of a block's rays (`None`: no ray), in the options'
    /// mode.
    #[inline]
    fn intersect<const W: usize>(&self, rays: [Option<Ray>; W]) -> [Option<T::Hit>; W] {
        match self.opts.mode {
            Mode::Scalar => rays.map(|r| r.and_then(|r| self.target.intersect(&r))),
            Mode::Packet4 => self.intersect_packets::<F4, W>(&rays),
            // Group modes without group traversal (scenes) trace their
            // primary and shadow rays here, as 8-wide packets.
            Mode::Packet8 | Mode::Group8x8 | Mode::Group16x16 => {
                self.intersect_packets::<F8, W>(&rays)
            }
            Mode::Stream => {
                let (live, index, n) = compact(&rays);
                let mut hits = [None; W];
                self.target.intersect_rays(&live[..n], &mut hits[..n]);
                let mut out = [None; W];
                for (h, &i) in hits[..n].iter().zip(&index[..n]) {
                    out[i] = *h;
                }
                out
            }
        }
    }

    /// [`Ctx::intersect`] as packets of `L::WIDTH` lanes.
    #[inline]
    fn intersect_packets<L: Lane, const W: usize>(
        &self,
        rays: &[Option<Ray>; W],
    ) -> [Option<T::Hit>; W] {
        let mut out = [None; W];
        for base in (0..W).step_by(L::WIDTH) {
            let p = RayPacket::<L>::from_fn(|i| rays.get(base + i).copied().flatten());
            let end = (base + L::WIDTH).min(W);
            self.target.intersect_packet(&p, &mut out[base..end]);
        }
        out
    }

    /// Occlusion mask of a block's rays; nothing is traced when no lane
    /// holds a ray.
    #[inline]
    fn occluded<const W: usize>(&self, rays: [Option<Ray>; W]) -> u32 {
        if rays.iter().all(Option::is_none) {
            return 0;
        }
        match self.opts.mode {
            Mode::Scalar => (0..W).fold(0, |m, i| {
                m | (rays[i].is_some_and(|r| self.target.occluded(&r)) as u32) << i
            }),
            Mode::Packet4 => self.occluded_packets::<F4, W>(&rays),
            // Group modes trace their AO rays here, as 8-wide packets (and
            // every ray, for targets without group traversal).
            Mode::Packet8 | Mode::Group8x8 | Mode::Group16x16 => {
                self.occluded_packets::<F8, W>(&rays)
            }
            Mode::Stream => {
                let (live, index, n) = compact(&rays);
                let mut occ = [false; W];
                self.target.occluded_rays(&live[..n], &mut occ[..n]);
                occ[..n]
                    .iter()
                    .zip(&index[..n])
                    .fold(0, |m, (&o, &i)| m | (o as u32) << i)
            }
        }
    }

    /// [`Ctx::occluded`] as packets of `L::WIDTH` lanes.
    #[inline]
    fn occluded_packets<L: Lane, const W: usize>(&self, rays: &[Option<Ray>; W]) -> u32 {
        (0..W).step_by(L::WIDTH).fold(0, |m, base| {
            let p = RayPacket::<L>::from_fn(|i| rays.get(base + i).copied().flatten());
            m | self.target.occluded_packet(&p) << base
        })
    }

    /// The surface of a primary hit: the geometric normal flipped toward
    /// the viewer, the start `Q` of secondary rays, and the shadow ray.
    /// Shadow and AO rays leave on the viewer's side (a shadow ray is
    /// traced only when the light is on that side too), so one offset
    /// origin serves both (`spawn::spawn_ray` per ray would give the same).
    /// The protocol's workloads keep their own `1e-4 * D` offset
    /// (`protocol::workload::surface_point`); the renderer needs no scene
    /// scale.
    #[inline]
    fn surface(&self, ray: &Ray, hit: &T::Hit) -> Surface {
        let (p, mut n, albedo) = self.target.shading(hit);
        if n.dot(ray.dir) > 0.0 {
            n = -n;
        }
        let q = offset_origin(p, n);
        let shadow = shadow_ray(q, self.opts.light);
        Surface {
            q,
            n,
            cos: n.dot(shadow.dir),
            shadow,
            albedo,
        }
    }

    /// The primary rays of sample `s` of the block whose top-left pixel
    /// is `(x, y)`: `W / 2` pixels wide and 2 high, lanes row by row (a
    /// 2 x 2 quad for `W = 4`, a 4 x 2 block for `W = 8`); pixels at or
    /// beyond `x_end` are inactive lanes (black, never written).
    fn block<const W: usize>(&self, (x, y): (u32, u32), x_end: u32, s: u32) -> Block<W> {
        let width = self.opts.width;
        let pix: [Option<(u32, u32)>; W] = std::array::from_fn(|i| {
            let (px, py) = (x + (i % (W / 2)) as u32, y + (i / (W / 2)) as u32);
            (px < x_end).then_some((px, py))
        });
        let index = pix.map(|p| p.map_or(0, |(px, py)| py * width + px));
        let primary = std::array::from_fn(|i| {
            pix[i].map(|(px, py)| {
                self.lens
                    .ray_at(px, py, sample_jitter(index[i], s, self.opts.spp))
            })
        });
        Block { index, primary }
    }

    /// The surfaces of a block's primary hits, and the shadow rays of the
    /// lanes whose surface faces the light.
    #[allow(clippy::type_complexity)]
    fn surfaces<const W: usize>(
        &self,
        b: &Block<W>,
        hits: &[Option<T::Hit>; W],
    ) -> ([Option<Surface>; W], [Option<Ray>; W]) {
        let surf: [Option<Surface>; W] = std::array::from_fn(|i| {
            b.primary[i].and_then(|r| hits[i].map(|h| self.surface(&r, &h)))
        });
        let shadow = surf.map(|s| s.and_then(|s| (s.cos > 0.0).then_some(s.shadow)));
        (surf, shadow)
    }

    /// Linear colour of sample `s` of a block from its surfaces and
    /// shadow mask, tracing its ambient-occlusion packets.
    fn colour<const W: usize>(
        &self,
        b: &Block<W>,
        surf: &[Option<Surface>; W],
        blocked: u32,
        s: u32,
        rays: &mut RayCounts,
    ) -> [Vec3; W] {
        // AO packets: ray j = s * N + k of every lane that hit.
        let n_ao = self.opts.ao_samples;
        let mut open = [0u32; W];
        for k in 0..n_ao {
            let j = s * n_ao + k;
            let ao: [Option<Ray>; W] = std::array::from_fn(|i| {
                surf[i].map(|sf| {
                    let dir = ao_direction(b.index[i], j, sf.n);
                    Ray::new_unchecked(sf.q, dir, 0.0, self.ao_reach)
                })
            });
            let occ = self.occluded(ao);
            for (i, o) in open.iter_mut().enumerate() {
                *o += (surf[i].is_some() && occ >> i & 1 == 0) as u32;
            }
        }
        rays.ao += (surf.iter().flatten().count() as u64) * n_ao as u64;

        std::array::from_fn(|i| match (b.primary[i], surf[i]) {
            (None, _) => Vec3::ZERO,
            (Some(ray), None) => {
                let up = ray.dir.dot(self.lens.up()) * 0.5 + 0.5;
                BACKGROUND_LOW.lerp(BACKGROUND_HIGH, up.clamp(0.0, 1.0))
            }
            (Some(_), Some(sf)) => {
                let lit = sf.cos > 0.0 && blocked >> i & 1 == 0;
                let direct = if lit { sf.cos } else { 0.0 };
                let open = if n_ao == 0 {
                    1.0
                } else {
                    open[i] as f32 / n_ao as f32
                };
                let sky = GROUND.lerp(SKY, 0.5 + 0.5 * sf.n.dot(self.lens.up()));
                sf.albedo * (LIGHT * direct + sky * open)
            }
        })
    }

    /// Linear colour of sample `s` of the block at `(x, y)` ([`Ctx::block`]):
    /// its primary packet, the shadow packet of the lanes that hit a
    /// surface facing the light, its AO packets.
    fn shade_block<const W: usize>(
        &self,
        at: (u32, u32),
        x_end: u32,
        s: u32,
        rays: &mut RayCounts,
    ) -> [Vec3; W] {
        let b = self.block::<W>(at, x_end, s);
        let hits = self.intersect(b.primary);
        rays.primary += b.primary.iter().flatten().count() as u64;
        let (surf, shadow) = self.surfaces(&b, &hits);
        rays.shadow += shadow.iter().flatten().count() as u64;
        let blocked = self.occluded(shadow);
        self.colour(&b, &surf, blocked, s, rays)
    }

    /// Render one tile: linear colours, tile-local row-major, in blocks
    /// of the mode's packet width (4 x 2 for 8 lanes, 2 x 2 otherwise).
    pub(super) fn render_tile(&self, t: Tile) -> (Vec<Vec3>, RayCounts) {
        if let Some((g, _)) = self.opts.mode.tile()
            && let Some(tree) = self.target.groups()
        {
            let ctx = Ctx {
                target: tree,
                opts: self.opts,
                lens: self.lens,
                ao_reach: self.ao_reach,
            };
            return ctx.render_groups(t, g);
        }
        match self.opts.mode.width() {
            8 => self.render_blocks::<8>(t),
            _ => self.render_blocks::<4>(t),
        }
    }

    fn render_blocks<const W: usize>(&self, t: Tile) -> (Vec<Vec3>, RayCounts) {
        let tw = t.width();
        let mut out = vec![Vec3::ZERO; tw * t.height()];
        let mut rays = RayCounts::default();
        let spp = self.opts.spp;
        let inv = 1.0 / spp as f32;
        for (x, y) in t.blocks(W as u32 / 2) {
            let mut sum = [Vec3::ZERO; W];
            for s in 0..spp {
                let c = self.shade_block::<W>((x, y), t.x1, s, &mut rays);
                for (acc, c) in sum.iter_mut().zip(c) {
                    *acc += c;
                }
            }
            let (lx, ly) = ((x - t.x0) as usize, (y - t.y0) as usize);
            for (i, c) in sum.into_iter().enumerate() {
                let (bx, by) = (i % (W / 2), i / (W / 2));
                if lx + bx < tw {
                    out[(ly + by) * tw + lx + bx] = if spp == 1 { c } else { c * inv };
                }
            }
        }
        (out, rays)
    }
}

/// Group tiles and heat maps: kd-tree only.
impl Ctx<'_, TreeTarget<'_>> {
    /// Linear colours of sample `s` of the 4 x 2 blocks at `at` (one
    /// group tile): the primary rays traced as one group from the eye,
    /// the shadow rays as one group toward the light, then each block's
    /// AO packets and colours as in [`Ctx::shade_block`].
    fn shade_group(
        &self,
        at: &[(u32, u32)],
        x_end: u32,
        s: u32,
        rays: &mut RayCounts,
    ) -> Vec<[Vec3; 8]> {
        let blocks: Vec<Block<8>> = at.iter().map(|&a| self.block::<8>(a, x_end, s)).collect();
        let packets: Vec<RayPacket8> = blocks
            .iter()
            .map(|b| RayPacket8::from_fn(|i| b.primary[i]))
            .collect();
        let hits = match RayGroup::new(&packets, self.opts.camera.eye, Apex::Origin) {
            Ok(g) => self.target.tree.intersect_group(&g),
            Err(_) => packets
                .iter()
                .map(|p| self.target.tree.intersect_packet(p))
                .collect(),
        };
        let mut surfs = Vec::with_capacity(blocks.len());
        let mut shadow_packets = Vec::with_capacity(blocks.len());
        for (b, h) in blocks.iter().zip(&hits) {
            rays.primary += b.primary.iter().flatten().count() as u64;
            let (surf, shadow) = self.surfaces(b, &std::array::from_fn(|i| h.hit(i)));
            rays.shadow += shadow.iter().flatten().count() as u64;
            surfs.push(surf);
            shadow_packets.push(RayPacket8::from_fn(|i| shadow[i]));
        }
        let blocked = match RayGroup::new(&shadow_packets, self.opts.light, Apex::Target) {
            Ok(g) => self.target.tree.occluded_group(&g),
            Err(_) => shadow_packets
                .iter()
                .map(|p| self.target.tree.occluded_packet(p))
                .collect(),
        };
        blocks
            .iter()
            .zip(&surfs)
            .zip(blocked)
            .map(|((b, surf), blocked)| self.colour(b, surf, blocked, s, rays))
            .collect()
    }

    /// [`Ctx::render_tile`] in `g x g` group tiles (cut to the tile).
    fn render_groups(&self, t: Tile, g: u32) -> (Vec<Vec3>, RayCounts) {
        let tw = t.width();
        let mut out = vec![Vec3::ZERO; tw * t.height()];
        let mut rays = RayCounts::default();
        let spp = self.opts.spp;
        let inv = 1.0 / spp as f32;
        for sub in t.sub_tiles(g) {
            let at: Vec<(u32, u32)> = sub.blocks(4).collect();
            let mut sum = vec![[Vec3::ZERO; 8]; at.len()];
            for s in 0..spp {
                let c = self.shade_group(&at, sub.x1, s, &mut rays);
                for (acc, c) in sum.iter_mut().zip(c) {
                    for (a, c) in acc.iter_mut().zip(c) {
                        *a += c;
                    }
                }
            }
            for (&(x, y), sum) in at.iter().zip(sum) {
                let (lx, ly) = ((x - t.x0) as usize, (y - t.y0) as usize);
                for (i, c) in sum.into_iter().enumerate() {
                    let (bx, by) = (i % 4, i / 4);
                    if x + (bx as u32) < sub.x1 {
                        out[(ly + by) * tw + lx + bx] = if spp == 1 { c } else { c * inv };
                    }
                }
            }
        }
        (out, rays)
    }

    /// Traversal cost (nodes, leaves and triangle tests) of the primary
    /// rays through the centres of one tile's pixels.
    pub(super) fn heat_tile(&self, t: Tile) -> Vec<u32> {
        if let Some((g, _)) = self.opts.mode.tile() {
            return self.heat_groups(t, g);
        }
        match self.opts.mode.width() {
            8 => self.heat_blocks::<F8, 8>(t),
            _ => self.heat_blocks::<F4, 4>(t),
        }
    }

    /// Group heat: each `g x g` group tile's work (node steps and leaves
    /// of the whole group, triangle tests and cell clippings of its
    /// packets) shared evenly by its 4 x 2 packets, the same share on
    /// every pixel of the group.
    fn heat_groups(&self, t: Tile, g: u32) -> Vec<u32> {
        let tw = t.width();
        let mut out = vec![0u32; tw * t.height()];
        for sub in t.sub_tiles(g) {
            let at: Vec<(u32, u32)> = sub.blocks(4).collect();
            let packets: Vec<RayPacket8> = at
                .iter()
                .map(|&(x, y)| {
                    RayPacket8::from_fn(|i| {
                        let (px, py) = (x + (i % 4) as u32, y + (i / 4) as u32);
                        (px < sub.x1).then(|| self.lens.ray(px, py))
                    })
                })
                .collect();
            let mut st = TraversalStats::default();
            let mut hits = vec![Default::default(); packets.len()];
            match RayGroup::new(&packets, self.opts.camera.eye, Apex::Origin) {
                Ok(group) => self
                    .target
                    .tree
                    .intersect_group_counted(&group, &mut hits, &mut st),
                Err(_) => {
                    for p in &packets {
                        let _ = self.target.tree.intersect_packet_counted(p, &mut st);
                    }
                }
            }
            // The group's per-packet clipping counts as work too.
            let work = st.nodes + st.leaves + st.triangle_tests + st.cell_tests;
            let share = work / (packets.len().max(1) as u64);
            let share = u32::try_from(share).unwrap_or(u32::MAX);
            for y in sub.y0..sub.y1 {
                for x in sub.x0..sub.x1 {
                    out[(y - t.y0) as usize * tw + (x - t.x0) as usize] = share;
                }
            }
        }
        out
    }

    fn heat_blocks<L: Lane, const W: usize>(&self, t: Tile) -> Vec<u32> {
        let tw = t.width();
        let mut out = vec![0u32; tw * t.height()];
        let cost = |s: &TraversalStats| {
            u32::try_from(s.nodes + s.leaves + s.triangle_tests).unwrap_or(u32::MAX)
        };
        for (x, y) in t.blocks(W as u32 / 2) {
            let pix: [Option<(u32, u32)>; W] = std::array::from_fn(|i| {
                let (px, py) = (x + (i % (W / 2)) as u32, y + (i / (W / 2)) as u32);
                (px < t.x1).then_some((px, py))
            });
            let rays = pix.map(|p| p.map(|(px, py)| self.lens.ray(px, py)));
            let lanes: [u32; W] = match self.opts.mode {
                Mode::Scalar => rays.map(|r| {
                    let mut st = TraversalStats::default();
                    if let Some(r) = r {
                        let _ = self.target.tree.intersect_counted(&r, &mut st);
                    }
                    cost(&st)
                }),
                Mode::Packet4
                | Mode::Packet8
                | Mode::Stream
                | Mode::Group8x8
                | Mode::Group16x16 => {
                    let mut st = TraversalStats::default();
                    let p = RayPacket::<L>::from_fn(|i| rays[i]);
                    let _ = self.target.tree.intersect_packet_counted(&p, &mut st);
                    [cost(&st); W]
                }
            };
            let (lx, ly) = ((x - t.x0) as usize, (y - t.y0) as usize);
            for (i, c) in lanes.into_iter().enumerate() {
                let (bx, by) = (i % (W / 2), i / (W / 2));
                if lx + bx < tw {
                    out[(ly + by) * tw + lx + bx] = c;
                }
            }
        }
        out
    }
}

/// A block's pixels as lanes: the pixel index and the primary ray of each.
struct Block<const W: usize> {
    index: [u32; W],
    primary: [Option<Ray>; W],
}

/// The block's rays without the empty lanes, the lane of each, and their
/// number (the first `n` entries count), on the stack: the stream mode
/// traces every block through it, and three heap buffers per block were
/// an allocation per few rays.
fn compact<const W: usize>(rays: &[Option<Ray>; W]) -> ([Ray; W], [usize; W], usize) {
    let mut live = [Ray::new_unchecked(glam::Vec3::ZERO, glam::Vec3::X, 0.0, 0.0); W];
    let mut index = [0; W];
    let mut n = 0;
    for (i, r) in rays.iter().enumerate() {
        if let Some(r) = r {
            live[n] = *r;
            index[n] = i;
            n += 1;
        }
    }
    (live, index, n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::KdTree;
    use crate::protocol::camera::Camera;
    use crate::render::target::SceneTarget;
    use crate::scene::Scene;

    /// Rays of the renderer's secondary rays that hit the surface they
    /// start from (`same`: the hit is on the primary hit's triangle),
    /// and how many secondary rays there were: 8 AO rays and the shadow
    /// ray of each pixel-centre hit of a 96 x 96 image.
    fn re_hits<T: Target>(
        target: &T,
        camera: Camera,
        light: Vec3,
        same: impl Fn(&T::Hit, &T::Hit) -> bool,
    ) -> (usize, Vec<(u32, u32)>) {
        let opts = RenderOptions::new(camera, light, 96, 96);
        let ctx = Ctx::new(target, &opts);
        let (mut secondary, mut re_hits) = (0, Vec::new());
        for y in 0..96 {
            for x in 0..96 {
                let ray = ctx.lens.ray_at(x, y, (0.5, 0.5));
                let Some(hit) = target.intersect(&ray) else {
                    continue;
                };
                let sf = ctx.surface(&ray, &hit);
                let index = y * 96 + x;
                let ao = (0..8).map(|j| {
                    Ray::new_unchecked(sf.q, ao_direction(index, j, sf.n), 0.0, ctx.ao_reach)
                });
                let shadow = (sf.cos > 0.0).then_some(sf.shadow);
                for r in ao.chain(shadow) {
                    secondary += 1;
                    if let Some(h) = target.intersect(&r)
                        && same(&h, &hit)
                    {
                        re_hits.push((x, y));
                    }
                }
            }
        }
        (secondary, re_hits)
    }

    fn assert_clean(name: &str, (secondary, re_hits): (usize, Vec<(u32, u32)>)) {
        assert!(secondary > 10_000, "{name}: {secondary}");
        assert!(
            re_hits.is_empty(),
            "{name}: {} re-hits: {:?}",
            re_hits.len(),
            &re_hits[..re_hits.len().min(5)]
        );
    }

    /// The renderer's secondary rays leave their surface: from every
    /// primary hit of the Cornell box and of a sphere seen from outside
    /// (both closed toward the rays that leave them), no shadow or AO ray
    /// hits the triangle it starts on.
    #[test]
    fn secondary_rays_never_re_hit_their_own_triangle() {
        use crate::protocol::generate;
        let cornell = generate::cornell_box();
        let view = crate::protocol::camera::View::parse(generate::CORNELL_VIEW).unwrap();
        let sphere = generate::sphere(2_000);
        let eye = Camera::new(Vec3::new(0.4, 0.7, 2.5), Vec3::ZERO, Vec3::Y, 50.0).unwrap();
        for (mesh, camera, light) in [
            (cornell, view.camera.unwrap(), view.light.unwrap()),
            (sphere, eye, Vec3::new(3.0, 4.0, 5.0)),
        ] {
            let tree = KdTree::build(mesh, &crate::KdBuildParams::default()).unwrap();
            let target = TreeTarget::new(&tree, &[]);
            assert_clean(
                "tree",
                re_hits(&target, camera, light, |a, b| a.prim == b.prim),
            );
        }
    }

    /// The same through instances: the Cornell box with scaled, squashed
    /// and rotated spheres (`data/cornell_spheres.scene`), and a mirrored
    /// (negative determinant), rotated, scaled sphere far from the origin
    /// seen from outside: the world hit point and normal of a moved
    /// instance keep its secondary rays off its own triangle.
    #[test]
    fn secondary_rays_never_re_hit_their_own_triangle_in_scenes() {
        use crate::protocol::generate;
        let same = |a: &crate::scene::SceneHit, b: &crate::scene::SceneHit| {
            (a.instance, a.prim) == (b.instance, b.prim)
        };
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
        let scene = crate::protocol::scene_file::load_scene(
            data.join("cornell_spheres.scene"),
            &crate::KdBuildParams::default(),
        )
        .unwrap();
        let view = crate::protocol::camera::View::parse(generate::CORNELL_VIEW).unwrap();
        let target = SceneTarget::new(&scene, &[]);
        let (camera, light) = (view.camera.unwrap(), view.light.unwrap());
        assert_clean("cornell_spheres", re_hits(&target, camera, light, same));

        let mut scene = Scene::new();
        let tree = KdTree::build(generate::sphere(2_000), &crate::KdBuildParams::default());
        let g = scene.add_geometry("ball", tree.unwrap());
        let at = Vec3::new(1000.0, -300.0, 40.0);
        let m = glam::Affine3A::from_translation(at)
            * glam::Affine3A::from_rotation_y(0.7)
            * glam::Affine3A::from_scale(Vec3::new(-3.0, 2.0, 2.5));
        scene.edit().add_instance(g, m).unwrap();
        let eye = Camera::new(at + Vec3::new(1.0, 2.0, 8.0), at, Vec3::Y, 50.0).unwrap();
        let target = SceneTarget::new(&scene, &[]);
        let light = at + Vec3::new(9.0, 12.0, 15.0);
        assert_clean("mirrored ball", re_hits(&target, eye, light, same));
    }
}
