//! A path tracer for triangle meshes with Lambertian surfaces and area
//! lights: what the renderer's main job casts, and the incoherent rays
//! where a structure's speed is decided.
//!
//! - **Scene** ([`PathScene`]): a mesh with a diffuse albedo and an
//!   emitted radiance per triangle; emissive triangles are area lights,
//!   emitting on the side their winding faces. Surfaces are two-sided.
//!   Rays that leave the scene see a uniform sky (black for the Cornell
//!   box).
//! - **Estimator** ([`Estimator`]): cosine-weighted bounces, next-event
//!   estimation (one point on the lights per vertex, chosen by power,
//!   uniform in area, with the solid-angle and cosine terms), the two
//!   combined by multiple importance sampling with the power heuristic, so
//!   no light is counted twice; Russian roulette from
//!   [`PathOptions::rr_depth`] bounces on. Secondary rays start at the hit
//!   point moved off the surface ([`offset_origin`](crate::spawn::offset_origin)).
//! - **Tracing**: each tile's paths advance together one depth at a time
//!   (a wavefront per tile); the camera rays go as 8-wide packets of
//!   4 x 2 pixels, the shadow and bounce rays of a depth as one batch
//!   through [`PacketQuery`] in the options' [`Mode`] (one at a time,
//!   4- or 8-wide packets, or the structure's stream). The query is any
//!   structure implementing the traits: the kd-tree, the brute-force
//!   oracle, others to come.
//! - **Progressive** ([`PathTracer`]): each pass adds
//!   [`PathOptions::pass_spp`] samples per pixel to a [`Film`] (sums of
//!   radiance and of its square). A path's random numbers come from its
//!   pixel, sample index and seed only (the protocol's PCG hash), and each
//!   pixel's samples are summed in sample order, so the film is the same
//!   bit for bit for any thread count, tile size, pass size and mode.
//! - **Rays by kind** ([`PathStats`]): camera, shadow and bounce rays
//!   counted and their tracing timed, so each kind's speed can be read.
//!
//! ```
//! use packtrace::protocol::generate::{cornell_albedo, cornell_box_lit, cornell_emission, CORNELL_VIEW};
//! use packtrace::render::path::{PathOptions, PathScene, path_trace};
//! use packtrace::{BruteForce, KdBuildParams, KdTree, Mode, View};
//!
//! let tree = KdTree::build(cornell_box_lit(), &KdBuildParams::default())?;
//! let scene = PathScene::new(tree.mesh(), &cornell_albedo(), &cornell_emission(), glam::Vec3::ZERO)?;
//! let mut opts = PathOptions::new(View::parse(CORNELL_VIEW)?.camera.unwrap(), 16, 16);
//! opts.spp = 4;
//! let kd = path_trace(&tree, &scene, &opts, &|_| {})?;
//! // Exact traversal: the brute-force oracle gives the same image, bit for bit.
//! opts.mode = Mode::Packet8;
//! let brute = path_trace(&BruteForce::new(tree.mesh()), &scene, &opts, &|_| {})?;
//! assert!(kd.film.mean().bit_identical(&brute.film.mean()));
//! assert_eq!(kd.stats.camera.rays, 16 * 16 * 4);
//! assert!(kd.stats.bounce.rays > 0 && kd.stats.shadow.rays > 0);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod batch;
mod integrator;
mod lights;
mod sampler;

use super::target::GREY;
use super::{Image, RenderError, Rgb8, Tiling, blit, check_size, check_tiling, run_tiles, srgb8};
use crate::mesh::Mesh;
use crate::protocol::camera::{Camera, ImagePlane};
use crate::query::{Mode, PacketQuery};
use batch::Batch;
use glam::Vec3;
use lights::Lights;
use std::time::Duration;

/// The mode the path tracer traces its shadow and bounce rays in unless
/// told otherwise: the fastest measured for them
/// (`docs/path_tracing.md`, "Which mode traces the incoherent rays"): the
/// kd-tree's breadth-first stream, one tile's batch at a time, ran the
/// Cornell box's render in 35 % fewer instructions than scalar.
///
/// ```
/// assert_eq!(packtrace::render::path::DEFAULT_MODE, packtrace::Mode::Stream);
/// ```
pub const DEFAULT_MODE: Mode = Mode::Stream;

/// Largest sample count per pixel.
///
/// ```
/// assert_eq!(packtrace::render::path::MAX_SPP, 65536);
/// ```
pub const MAX_SPP: u32 = 1 << 16;

/// Largest [`PathOptions::max_depth`].
///
/// ```
/// assert_eq!(packtrace::render::path::MAX_DEPTH, 1024);
/// ```
pub const MAX_DEPTH: u32 = 1024;

/// Largest number of paths a tile traces at once (tile pixels times
/// samples per pass), which bounds the memory of a worker.
///
/// ```
/// assert_eq!(packtrace::render::path::MAX_BATCH, 1 << 20);
/// ```
pub const MAX_BATCH: u64 = 1 << 20;

/// How light is gathered at a path's vertices. All three estimate the
/// same image (no light counted twice, none missed); they differ in
/// noise, and comparing them is a test of each.
///
/// ```
/// use packtrace::render::path::Estimator;
/// assert_eq!(Estimator::default(), Estimator::Mis);
/// assert_eq!("nee".parse::<Estimator>(), Ok(Estimator::Light));
/// assert_eq!(Estimator::Bsdf.name(), "bsdf");
/// assert!("x".parse::<Estimator>().unwrap_err().contains("mis, nee or bsdf"));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Estimator {
    /// Next-event estimation and bounces that find a light, weighted by
    /// the power heuristic (the default: least noise).
    #[default]
    Mis,
    /// Next-event estimation alone: emission found by a bounce is not
    /// counted (only camera rays see the lights directly).
    Light,
    /// Bounces alone: light is found only by hitting an emitter.
    Bsdf,
}

impl Estimator {
    /// Every estimator.
    pub const ALL: [Estimator; 3] = [Estimator::Mis, Estimator::Light, Estimator::Bsdf];

    /// The estimator's name on the command line: `mis`, `nee`, `bsdf`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Estimator::Mis => "mis",
            Estimator::Light => "nee",
            Estimator::Bsdf => "bsdf",
        }
    }
}

impl std::str::FromStr for Estimator {
    type Err = String;

    fn from_str(s: &str) -> Result<Estimator, String> {
        Estimator::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| format!("unknown estimator `{s}` (expected mis, nee or bsdf)"))
    }
}

/// What to path-trace and how.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Camera;
/// use packtrace::render::path::{DEFAULT_MODE, Estimator, PathOptions};
/// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// let o = PathOptions::new(cam, 64, 48);
/// assert_eq!((o.spp, o.pass_spp, o.max_depth, o.rr_depth), (16, 2, 64, 3));
/// assert_eq!((o.estimator, o.mode, o.tile_size, o.seed), (Estimator::Mis, DEFAULT_MODE, 16, 0));
/// assert_eq!(o.passes(), 8);
/// assert!(o.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathOptions {
    /// The pinhole camera.
    pub camera: Camera,
    /// Image width in pixels (even).
    pub width: u32,
    /// Image height in pixels (even).
    pub height: u32,
    /// Samples per pixel in all, `1..=MAX_SPP`.
    pub spp: u32,
    /// Samples per pixel added by each pass (the last pass may add
    /// fewer), `1..=MAX_SPP`.
    pub pass_spp: u32,
    /// Most bounces of a path: light reflected more than this many times
    /// is lost. Russian roulette ends paths long before the default (64),
    /// `0..=MAX_DEPTH` (0: only the lights themselves are seen).
    pub max_depth: u32,
    /// Bounces before Russian roulette starts.
    pub rr_depth: u32,
    /// How light is gathered.
    pub estimator: Estimator,
    /// How shadow and bounce rays are traced: scalar, packet4, packet8 or
    /// stream (camera rays always go as 8-wide packets of 4 x 2 pixels).
    pub mode: Mode,
    /// Threads that take tiles (the image does not depend on it).
    pub threads: usize,
    /// Tile edge in pixels (even; the image does not depend on it).
    pub tile_size: u32,
    /// Seed of the random numbers: another seed gives an independent
    /// image of the same scene.
    pub seed: u32,
}

impl PathOptions {
    /// 16 samples per pixel in passes of 2, at most 64 bounces, Russian
    /// roulette from the third, [`Estimator::Mis`], [`DEFAULT_MODE`], one
    /// thread per core, 16 x 16 tiles, seed 0.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, render::path::PathOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// assert_eq!(PathOptions::new(cam, 8, 6).height, 6);
    /// ```
    #[must_use]
    pub fn new(camera: Camera, width: u32, height: u32) -> PathOptions {
        PathOptions {
            camera,
            width,
            height,
            spp: 16,
            pass_spp: 2,
            max_depth: 64,
            rr_depth: 3,
            estimator: Estimator::Mis,
            mode: DEFAULT_MODE,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            tile_size: super::DEFAULT_TILE,
            seed: 0,
        }
    }

    /// Number of passes: `spp / pass_spp`, rounded up.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, render::path::PathOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// let o = PathOptions { spp: 20, pass_spp: 8, ..PathOptions::new(cam, 8, 6) };
    /// assert_eq!(o.passes(), 3);
    /// ```
    #[must_use]
    pub fn passes(&self) -> u32 {
        self.spp.div_ceil(self.pass_spp.max(1))
    }

    /// Check the options: the image size as [`RenderOptions`](super::RenderOptions)
    /// checks it, `spp` and `pass_spp` in `1..=MAX_SPP`, `max_depth <=
    /// MAX_DEPTH`, a mode other than the group modes, at least one
    /// thread, an even tile edge, at most [`MAX_BATCH`] paths per tile
    /// and pass, and a valid camera.
    ///
    /// # Errors
    /// The first [`RenderError`] found, in that order.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, Mode, render::path::PathOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// let o = PathOptions { mode: Mode::Group8x8, ..PathOptions::new(cam, 8, 6) };
    /// assert!(o.validate().unwrap_err().to_string().starts_with("mode group8x8: "));
    /// let o = PathOptions { spp: 0, ..PathOptions::new(cam, 8, 6) };
    /// assert_eq!(o.validate().unwrap_err().to_string(), "spp 0 is not in 1..=65536");
    /// ```
    pub fn validate(&self) -> Result<(), RenderError> {
        check_size(self.width, self.height)?;
        let range = |name, value: u32, low: u32, high: u32| {
            if (low..=high).contains(&value) {
                Ok(())
            } else {
                Err(RenderError::Range {
                    name,
                    value: value as u64,
                    low: low as u64,
                    high: high as u64,
                })
            }
        };
        range("spp", self.spp, 1, MAX_SPP)?;
        range("pass spp", self.pass_spp, 1, MAX_SPP)?;
        range("max depth", self.max_depth, 0, MAX_DEPTH)?;
        if self.mode.tile().is_some() {
            return Err(RenderError::PathMode(self.mode));
        }
        check_tiling(self.threads, self.tile_size)?;
        let tile = self.tile_size.min(self.width.max(self.height)) as u64;
        let batch = tile * tile * self.pass_spp.min(self.spp) as u64;
        if batch > MAX_BATCH {
            return Err(RenderError::Range {
                name: "paths per tile and pass (tile size squared times pass spp)",
                value: batch,
                low: 1,
                high: MAX_BATCH,
            });
        }
        self.camera.validate().map_err(RenderError::Camera)
    }

    fn tiling(&self) -> Tiling {
        Tiling {
            width: self.width,
            height: self.height,
            tile_size: self.tile_size,
            threads: self.threads,
        }
    }
}

/// A mesh to path-trace, with its materials: per triangle a diffuse
/// albedo and an emitted radiance (linear RGB), and the radiance of the
/// sky that rays leaving the scene see.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box_lit, cornell_emission};
/// use packtrace::render::path::PathScene;
/// let mesh = cornell_box_lit();
/// let scene = PathScene::new(&mesh, &cornell_albedo(), &cornell_emission(), Vec3::ZERO)?;
/// assert_eq!(scene.light_count(), 2);
/// // Grey everywhere, no lights, lit by a white sky.
/// let sky = PathScene::new(&mesh, &[], &[], Vec3::ONE)?;
/// assert_eq!(sky.light_count(), 0);
/// let e = PathScene::new(&mesh, &[Vec3::ONE], &[], Vec3::ZERO).unwrap_err();
/// assert_eq!(e.to_string(), "1 albedo colours for 32 triangles: give one per triangle, or none");
/// let mut hot = cornell_albedo();
/// hot[3] = Vec3::new(0.5, 1.5, 0.5);
/// let e = PathScene::new(&mesh, &hot, &[], Vec3::ZERO).unwrap_err();
/// assert_eq!(e.to_string(), "triangle 3: albedo [0.5, 1.5, 0.5] is not in [0, 1]: the surface would reflect more light than it receives");
/// # Ok::<(), packtrace::render::RenderError>(())
/// ```
#[derive(Clone, Debug)]
pub struct PathScene<'a> {
    mesh: &'a Mesh,
    albedo: Vec<Vec3>,
    emission: Vec<Vec3>,
    sky: Vec3,
    lights: Lights,
}

impl<'a> PathScene<'a> {
    /// The scene of `mesh` with one albedo per triangle (empty: grey
    /// 0.75) and one emitted radiance per triangle (empty: no lights), and
    /// the sky's radiance.
    ///
    /// # Errors
    /// [`RenderError::Materials`] for a list that is neither empty nor
    /// one colour per triangle; [`RenderError::Material`] for an albedo
    /// component outside `[0, 1]` (or NaN) or an emission component that
    /// is negative or not finite; [`RenderError::Sky`] for such a sky.
    pub fn new(
        mesh: &'a Mesh,
        albedo: &[Vec3],
        emission: &[Vec3],
        sky: Vec3,
    ) -> Result<PathScene<'a>, RenderError> {
        let triangles = mesh.triangle_count();
        for (name, list) in [("albedo", albedo), ("emission", emission)] {
            if !list.is_empty() && list.len() != triangles {
                return Err(RenderError::Materials {
                    name,
                    len: list.len(),
                    triangles,
                });
            }
        }
        let bad = |triangle, reason: String| Err(RenderError::Material { triangle, reason });
        for (i, a) in albedo.iter().enumerate() {
            if !a.to_array().iter().all(|c| (0.0..=1.0).contains(c)) {
                return bad(
                    i,
                    format!(
                        "albedo {a} is not in [0, 1]: the surface would reflect more light than \
                         it receives"
                    ),
                );
            }
        }
        for (i, e) in emission.iter().enumerate() {
            if !e.is_finite() || e.min_element() < 0.0 {
                return bad(i, format!("emission {e} must be finite and not negative"));
            }
        }
        if !sky.is_finite() || sky.min_element() < 0.0 {
            return Err(RenderError::Sky(sky));
        }
        let full = |list: &[Vec3], fill| {
            if list.is_empty() {
                vec![fill; triangles]
            } else {
                list.to_vec()
            }
        };
        let emission = full(emission, Vec3::ZERO);
        Ok(PathScene {
            mesh,
            albedo: full(albedo, GREY),
            lights: Lights::new(mesh, &emission),
            emission,
            sky,
        })
    }

    /// The mesh.
    ///
    /// ```
    /// let m = packtrace::protocol::generate::cornell_box_lit();
    /// let s = packtrace::render::path::PathScene::new(&m, &[], &[], glam::Vec3::ONE).unwrap();
    /// assert_eq!(s.mesh().triangle_count(), 32);
    /// ```
    #[must_use]
    pub fn mesh(&self) -> &Mesh {
        self.mesh
    }

    /// Number of emissive triangles (of positive area), the area lights.
    ///
    /// ```
    /// let m = packtrace::protocol::generate::cornell_box_lit();
    /// let s = packtrace::render::path::PathScene::new(&m, &[], &[], glam::Vec3::ONE).unwrap();
    /// assert_eq!(s.light_count(), 0);
    /// ```
    #[must_use]
    pub fn light_count(&self) -> usize {
        self.lights.len()
    }

    /// The sky's radiance.
    ///
    /// ```
    /// let m = packtrace::protocol::generate::cornell_box_lit();
    /// let s = packtrace::render::path::PathScene::new(&m, &[], &[], glam::Vec3::ONE).unwrap();
    /// assert_eq!(s.sky(), glam::Vec3::ONE);
    /// ```
    #[must_use]
    pub fn sky(&self) -> Vec3 {
        self.sky
    }
}

/// How linear radiance is mapped to the display before the sRGB curve.
///
/// ```
/// use glam::Vec3;
/// use packtrace::render::path::ToneMap;
/// assert_eq!(ToneMap::Clamp.apply(Vec3::new(0.5, 2.0, 0.0), 0.0), Vec3::new(0.5, 1.0, 0.0));
/// assert_eq!(ToneMap::Clamp.apply(Vec3::splat(0.25), 1.0), Vec3::splat(0.5)); // one stop up
/// let f = ToneMap::Filmic.apply(Vec3::new(0.18, 4.0, 100.0), 0.0);
/// assert!(f.x > 0.1 && f.y < 1.0 && f.z <= 1.0);
/// assert_eq!("filmic".parse::<ToneMap>(), Ok(ToneMap::Filmic));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum ToneMap {
    /// Scale by the exposure and clip to `[0, 1]`: radiance as it is,
    /// the lights saturated.
    #[default]
    Clamp,
    /// Scale by the exposure, then Narkowicz's fit of the ACES filmic
    /// curve ("ACES Filmic Tone Mapping Curve", 2015), which rolls bright
    /// values off toward white instead of clipping them.
    Filmic,
}

impl ToneMap {
    /// The tone maps' names on the command line: `clamp`, `filmic`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            ToneMap::Clamp => "clamp",
            ToneMap::Filmic => "filmic",
        }
    }

    /// `linear` times `2^exposure`, mapped to `[0, 1]`.
    #[must_use]
    pub fn apply(self, linear: Vec3, exposure: f32) -> Vec3 {
        let x = linear * exposure.exp2();
        match self {
            ToneMap::Clamp => x.clamp(Vec3::ZERO, Vec3::ONE),
            ToneMap::Filmic => {
                let x = x.max(Vec3::ZERO);
                ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14))
                    .clamp(Vec3::ZERO, Vec3::ONE)
            }
        }
    }
}

impl std::str::FromStr for ToneMap {
    type Err = String;

    fn from_str(s: &str) -> Result<ToneMap, String> {
        [ToneMap::Clamp, ToneMap::Filmic]
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("unknown tone map `{s}` (expected clamp or filmic)"))
    }
}

/// The path tracer's accumulation buffer: per pixel the sum of the
/// samples' radiance and of its square (per channel), and the number of
/// samples per pixel so far.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box_lit, cornell_emission};
/// use packtrace::render::path::{PathOptions, PathScene, path_trace};
/// use packtrace::{Camera, KdBuildParams, KdTree};
/// let tree = KdTree::build(cornell_box_lit(), &KdBuildParams::default())?;
/// let scene = PathScene::new(tree.mesh(), &cornell_albedo(), &cornell_emission(), Vec3::ZERO)?;
/// // Looking up from the floor at the light, which fills the view.
/// let up = Camera::new(Vec3::new(278.0, 10.0, 279.5), Vec3::new(278.0, 548.0, 279.5), Vec3::Z, 5.0)?;
/// let mut opts = PathOptions::new(up, 8, 8);
/// opts.spp = 16;
/// let film = path_trace(&tree, &scene, &opts, &|_| {})?.film;
/// assert_eq!(film.samples(), 16);
/// // Its emission on every sample, and what it reflects (albedo 0.78).
/// let (mean, var) = (film.mean().pixels[27], film.mean_variance()[27]);
/// assert!(mean.cmpge(Vec3::new(17.0, 12.0, 4.0)).all() && mean.x < 17.5, "{mean}");
/// assert!(var.x > 0.0 && var.x.sqrt() < 0.1);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    width: u32,
    height: u32,
    samples: u32,
    sum: Vec<Vec3>,
    sum_sq: Vec<Vec3>,
}

impl Film {
    fn new(width: u32, height: u32) -> Film {
        let n = width as usize * height as usize;
        Film {
            width,
            height,
            samples: 0,
            sum: vec![Vec3::ZERO; n],
            sum_sq: vec![Vec3::ZERO; n],
        }
    }

    /// Width in pixels.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Samples per pixel so far.
    #[must_use]
    pub fn samples(&self) -> u32 {
        self.samples
    }

    /// The image: each pixel's mean radiance (black before any sample).
    #[must_use]
    pub fn mean(&self) -> Image {
        let inv = if self.samples == 0 {
            0.0
        } else {
            1.0 / self.samples as f32
        };
        Image {
            width: self.width,
            height: self.height,
            pixels: self.sum.iter().map(|s| *s * inv).collect(),
        }
    }

    /// Per pixel, the variance of its mean, estimated from its samples:
    /// the sample variance (with Bessel's correction) over the sample
    /// count. Zero with fewer than two samples.
    #[must_use]
    pub fn mean_variance(&self) -> Vec<Vec3> {
        let n = self.samples as f64;
        if self.samples < 2 {
            return vec![Vec3::ZERO; self.sum.len()];
        }
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, s2)| {
                let (s, s2) = (s.as_dvec3(), s2.as_dvec3());
                let var = (s2 - s * s / n) / (n - 1.0);
                (var.max(glam::DVec3::ZERO) / n).as_vec3()
            })
            .collect()
    }

    /// The image as 8-bit sRGB: each pixel's mean radiance through
    /// `tone` at `exposure` stops, then the sRGB curve ([`srgb8`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::generate::{cornell_albedo, cornell_box_lit, cornell_emission};
    /// use packtrace::render::path::{PathOptions, PathScene, ToneMap, path_trace};
    /// use packtrace::{Camera, KdBuildParams, KdTree};
    /// let tree = KdTree::build(cornell_box_lit(), &KdBuildParams::default())?;
    /// let scene = PathScene::new(tree.mesh(), &cornell_albedo(), &cornell_emission(), Vec3::ZERO)?;
    /// let up = Camera::new(Vec3::new(278.0, 10.0, 279.5), Vec3::new(278.0, 548.0, 279.5), Vec3::Z, 5.0)?;
    /// let mut opts = PathOptions::new(up, 4, 4);
    /// opts.spp = 2;
    /// let film = path_trace(&tree, &scene, &opts, &|_| {})?.film;
    /// assert_eq!(film.to_srgb8(0.0, ToneMap::Clamp).pixel(1, 1), [255, 255, 255]); // the light, clipped
    /// let dim = film.to_srgb8(-6.0, ToneMap::Clamp).pixel(1, 1); // six stops down: 17 / 64
    /// assert!(dim[0] > 120 && dim[0] < 160 && dim[2] < dim[1], "{dim:?}");
    /// # Ok::<(), Box<dyn std::error::Error>>(())
    /// ```
    #[must_use]
    pub fn to_srgb8(&self, exposure: f32, tone: ToneMap) -> Rgb8 {
        let img = self.mean();
        Rgb8 {
            width: self.width,
            height: self.height,
            data: img
                .pixels
                .iter()
                .flat_map(|c| {
                    let d = tone.apply(*c, exposure);
                    [srgb8(d.x), srgb8(d.y), srgb8(d.z)]
                })
                .collect(),
        }
    }
}

/// Rays of one kind: how many, and the seconds spent tracing them,
/// summed over the threads (so `rays / seconds` is the speed of one
/// core).
///
/// ```
/// let k = packtrace::render::path::RayKind { rays: 3_000_000, seconds: 1.5 };
/// assert_eq!(k.mrays_per_second(), 2.0);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct RayKind {
    /// Rays traced.
    pub rays: u64,
    /// Seconds spent in the structure's queries for them, summed over
    /// threads.
    pub seconds: f64,
}

impl RayKind {
    /// Millions of rays per second of one thread's tracing time (0 when
    /// no time was measured).
    #[must_use]
    pub fn mrays_per_second(&self) -> f64 {
        if self.seconds > 0.0 {
            self.rays as f64 / self.seconds / 1e6
        } else {
            0.0
        }
    }

    fn add(&mut self, rays: usize, time: Duration) {
        self.rays += rays as u64;
        self.seconds += time.as_secs_f64();
    }
}

impl std::ops::AddAssign for RayKind {
    fn add_assign(&mut self, o: RayKind) {
        self.rays += o.rays;
        self.seconds += o.seconds;
    }
}

/// What a path-traced render traced, by ray kind.
///
/// ```
/// let s = packtrace::render::path::PathStats::default();
/// assert_eq!((s.rays(), s.paths, s.dropped), (0, 0, 0));
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathStats {
    /// Camera rays (one per path), traced as 8-wide packets.
    pub camera: RayKind,
    /// Shadow rays of next-event estimation, traced in the options' mode.
    pub shadow: RayKind,
    /// Bounce rays, traced in the options' mode.
    pub bounce: RayKind,
    /// Paths (pixels times samples).
    pub paths: u64,
    /// Samples whose radiance was not finite, counted as black (none
    /// expected; a sign of a bad scene or a bug).
    pub dropped: u64,
}

impl PathStats {
    /// Every ray traced.
    #[must_use]
    pub fn rays(&self) -> u64 {
        self.camera.rays + self.shadow.rays + self.bounce.rays
    }
}

impl std::ops::AddAssign for PathStats {
    fn add_assign(&mut self, o: PathStats) {
        self.camera += o.camera;
        self.shadow += o.shadow;
        self.bounce += o.bounce;
        self.paths += o.paths;
        self.dropped += o.dropped;
    }
}

/// A progressive path-traced render: each [`PathTracer::pass`] adds
/// [`PathOptions::pass_spp`] samples per pixel to the film, until
/// [`PathOptions::spp`]. `Q` is the structure the rays are traced
/// through.
///
/// ```
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box_lit, cornell_emission, CORNELL_VIEW};
/// use packtrace::render::path::{PathOptions, PathScene, PathTracer};
/// use packtrace::{KdBuildParams, KdTree, View};
/// let tree = KdTree::build(cornell_box_lit(), &KdBuildParams::default())?;
/// let scene = PathScene::new(tree.mesh(), &cornell_albedo(), &cornell_emission(), glam::Vec3::ZERO)?;
/// let mut opts = PathOptions::new(View::parse(CORNELL_VIEW)?.camera.unwrap(), 16, 16);
/// (opts.spp, opts.pass_spp) = (10, 4);
/// let mut pt = PathTracer::new(&tree, &scene, &opts)?;
/// let mut added = Vec::new();
/// while !pt.is_done() {
///     added.push(pt.pass(&|_| {})?);
/// }
/// assert_eq!(added, [4, 4, 2]);
/// assert_eq!(pt.film().samples(), 10);
/// assert_eq!(pt.stats().paths, 16 * 16 * 10);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub struct PathTracer<'a, Q: ?Sized> {
    query: &'a Q,
    scene: &'a PathScene<'a>,
    opts: PathOptions,
    film: Film,
    stats: PathStats,
}

impl<'a, Q: PacketQuery + Sync + ?Sized> PathTracer<'a, Q> {
    /// A render of `scene` through `query`, which must be a structure
    /// built over the scene's mesh (the kd-tree of it, its brute-force
    /// oracle, ...), with an empty film.
    ///
    /// # Errors
    /// [`RenderError`] from [`PathOptions::validate`].
    pub fn new(
        query: &'a Q,
        scene: &'a PathScene<'a>,
        opts: &PathOptions,
    ) -> Result<PathTracer<'a, Q>, RenderError> {
        opts.validate()?;
        Ok(PathTracer {
            query,
            scene,
            opts: *opts,
            film: Film::new(opts.width, opts.height),
            stats: PathStats::default(),
        })
    }

    /// Have all samples been taken?
    #[must_use]
    pub fn is_done(&self) -> bool {
        self.film.samples >= self.opts.spp
    }

    /// Trace one pass: up to `pass_spp` more samples per pixel (none when
    /// done), on `threads` threads; `progress(k)` is called as `k` more
    /// tiles are done ([`PathTracer::tiles`] per pass). Returns the
    /// samples per pixel added.
    ///
    /// # Errors
    /// [`RenderError::ForeignHit`] when the query was not built over the
    /// scene's mesh; the film is then unchanged.
    pub fn pass(&mut self, progress: &(dyn Fn(usize) + Sync)) -> Result<u32, RenderError> {
        let first = self.film.samples;
        let count = self.opts.pass_spp.min(self.opts.spp.saturating_sub(first));
        if count == 0 {
            return Ok(0);
        }
        let work = integrator::Work {
            batch: Batch {
                query: self.query,
                mode: self.opts.mode,
            },
            scene: self.scene,
            opts: &self.opts,
            lens: ImagePlane::new(&self.opts.camera, self.opts.width, self.opts.height),
        };
        let film = &self.film;
        let tiles = run_tiles(self.opts.tiling(), progress, |t| {
            work.tile(t, first, count, film)
        });
        let mut done = Vec::with_capacity(tiles.len());
        for (t, out) in tiles {
            done.push((t, out?));
        }
        for (t, out) in done {
            blit(&mut self.film.sum, self.opts.width, t, &out.sum);
            blit(&mut self.film.sum_sq, self.opts.width, t, &out.sum_sq);
            self.stats += out.stats;
        }
        self.film.samples += count;
        Ok(count)
    }

    /// Tiles per pass: the units of `progress`.
    #[must_use]
    pub fn tiles(&self) -> usize {
        self.opts.tiling().count()
    }

    /// The film so far.
    #[must_use]
    pub fn film(&self) -> &Film {
        &self.film
    }

    /// What was traced so far.
    #[must_use]
    pub fn stats(&self) -> &PathStats {
        &self.stats
    }

    /// The options.
    #[must_use]
    pub fn options(&self) -> &PathOptions {
        &self.opts
    }
}

/// A finished path-traced render: the film and what was traced.
#[derive(Clone, Debug)]
pub struct PathRendered {
    /// The film, with `spp` samples per pixel.
    pub film: Film,
    /// Rays by kind.
    pub stats: PathStats,
}

/// Path-trace `scene` through `query` (a structure built over the scene's
/// mesh) to `opts.spp` samples per pixel: every pass of a
/// [`PathTracer`], `progress` called per tile of each pass.
///
/// # Errors
/// As [`PathTracer::new`] and [`PathTracer::pass`].
pub fn path_trace<Q: PacketQuery + Sync + ?Sized>(
    query: &Q,
    scene: &PathScene<'_>,
    opts: &PathOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<PathRendered, RenderError> {
    let mut pt = PathTracer::new(query, scene, opts)?;
    while !pt.is_done() {
        pt.pass(progress)?;
    }
    Ok(PathRendered {
        film: pt.film,
        stats: pt.stats,
    })
}
