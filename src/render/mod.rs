//! The renderers' image-independent core: tiles handed out to threads,
//! the direct renderer (2 x 2 primary packets, shading with shadow and
//! ambient-occlusion packets), traversal-cost heat maps, and the path
//! tracer ([`path`]), which shares the tiles. It returns plain float and
//! byte buffers; writing files is the `render` binary's business.
//!
//! To embed the tree in a host tracer instead (build once, trace packets
//! from your own threads), see the README's section "Packets"
//! (`README.md#packets`), whose example is compiled as a doc test.
//!
//! # The renderer
//!
//! [`render`] cuts the image into tiles of [`RenderOptions::tile_size`]
//! pixels (many more tiles than threads) and hands them out through one
//! atomic counter, so a thread that finishes a cheap tile takes the next
//! one (dynamic load balancing, no lock anywhere). Every pixel is computed
//! on its own from its coordinates and sample indices, so the image is the
//! same, bit for bit, for any thread count, tile size and [`Mode`].
//!
//! Per 2 x 2 pixel quad and sample: one primary packet (lanes
//! `(x,y) (x+1,y) (x,y+1) (x+1,y+1)`, docs/PROTOCOL.md, "Ray order and packets"), one
//! shadow packet of the lanes that hit and face the light, and
//! `ao_samples` occlusion packets of the lanes that hit.
//!
//! ```
//! use glam::Vec3;
//! use packtrace::Mode;
//! use packtrace::render::{RenderOptions, render};
//! use packtrace::{Camera, KdBuildParams, KdTree};
//!
//! let tree = KdTree::build(packtrace::protocol::generate::sphere(500), &KdBuildParams::default())?;
//! let cam = Camera::new(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 45.0)?;
//! let mut opts = RenderOptions::new(cam, Vec3::new(3.0, 4.0, 5.0), 32, 32);
//! opts.ao_samples = 2;
//! let packet = render(&tree, &opts, &|_| {})?;
//! opts.mode = Mode::Scalar;
//! opts.threads = 1;
//! let scalar = render(&tree, &opts, &|_| {})?;
//! assert_eq!(packet.image.to_srgb8(), scalar.image.to_srgb8());
//! assert_eq!(packet.rays, scalar.rays);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use crate::kdtree::KdTree;
use crate::protocol::camera::{Camera, ViewError};
use crate::protocol::frame::SceneFrame;
use crate::protocol::sampling::{hash, unit};
use crate::protocol::workload::{WorkloadError, check_image_size};
use crate::query::Mode;
use crate::scene::Scene;

pub mod path;
mod shade;
mod target;

use glam::Vec3;
use shade::Ctx;
use std::fmt;
use std::sync::atomic::{AtomicUsize, Ordering};
use target::{SceneTarget, Target, TreeTarget};

/// Default tile edge in pixels (even, so tiles hold whole 2 x 2 quads).
///
/// ```
/// assert_eq!(packtrace::render::DEFAULT_TILE, 16);
/// ```
pub const DEFAULT_TILE: u32 = 16;

/// Largest image width or height [`render`] accepts.
///
/// ```
/// assert_eq!(packtrace::render::MAX_SIDE, 16384);
/// ```
pub const MAX_SIDE: u32 = 16384;

/// Largest `width * height` [`render`] accepts (64 Mpixels: 768 MiB of
/// linear floats).
///
/// ```
/// assert_eq!(packtrace::render::MAX_IMAGE_PIXELS, 8192 * 8192);
/// ```
pub const MAX_IMAGE_PIXELS: u64 = 1 << 26;

/// Largest sample count per pixel, and largest AO ray count per hit.
///
/// ```
/// assert_eq!(packtrace::render::MAX_SAMPLES, 1024);
/// ```
pub const MAX_SAMPLES: u32 = 1024;

/// Why [`render`], [`render_scene`] or [`heat_map`] refused its options.
/// Every message names the value at fault.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Camera;
/// use packtrace::render::{RenderError, RenderOptions};
/// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// let e = RenderOptions::new(cam, Vec3::ONE, 33, 32).validate().unwrap_err();
/// assert!(matches!(e, RenderError::ImageSize { .. }));
/// assert!(e.to_string().contains("33x32"));
/// ```
#[derive(Debug)]
pub enum RenderError {
    /// Width or height zero, odd, or too large.
    ImageSize {
        /// Width in pixels.
        width: u32,
        /// Height in pixels.
        height: u32,
        /// What is wrong with it.
        reason: String,
    },
    /// A sample count outside `1..=MAX_SAMPLES` (`spp`) or
    /// `0..=MAX_SAMPLES` (`ao`).
    Samples {
        /// Which count: `spp` or `ao`.
        name: &'static str,
        /// The count given.
        value: u32,
    },
    /// Zero threads.
    Threads,
    /// A tile edge that is zero or odd.
    TileSize(u32),
    /// The camera gives no finite rays.
    Camera(ViewError),
    /// The light position is not finite.
    Light(Vec3),
    /// A per-triangle albedo list whose length is not the mesh's triangle
    /// count, or with a colour that is not finite.
    Albedo {
        /// The list's length.
        len: usize,
        /// The mesh's triangle count.
        triangles: usize,
    },
    /// A path-tracing option outside its range ([`path::PathOptions`]).
    Range {
        /// The option.
        name: &'static str,
        /// The value given.
        value: u64,
        /// The smallest value allowed.
        low: u64,
        /// The largest value allowed.
        high: u64,
    },
    /// A mode the path tracer does not trace its rays in: the group modes
    /// trace coherent screen tiles, which a path's bounces are not.
    PathMode(Mode),
    /// A path-tracing material list whose length is not the mesh's
    /// triangle count.
    Materials {
        /// Which list: `albedo` or `emission`.
        name: &'static str,
        /// The list's length.
        len: usize,
        /// The mesh's triangle count.
        triangles: usize,
    },
    /// A triangle's path-tracing material out of range: an albedo outside
    /// `[0, 1]` (a surface reflecting more than it receives) or an
    /// emission that is negative or not finite.
    Material {
        /// The triangle.
        triangle: usize,
        /// What is wrong.
        reason: String,
    },
    /// A sky radiance that is negative or not finite.
    Sky(Vec3),
    /// The query traced for the path tracer answered with a triangle its
    /// scene's mesh does not have: it was built from another mesh.
    ForeignHit {
        /// The triangle index the query gave.
        prim: u32,
        /// The scene mesh's triangle count.
        triangles: usize,
    },
    /// [`render_scene`]'s colours: neither one list per geometry nor
    /// none (`geometry: None`), or geometry `geometry`'s list neither
    /// empty nor one finite colour per triangle of its mesh.
    SceneAlbedo {
        /// The geometry whose list is wrong; `None`: the number of lists.
        geometry: Option<u32>,
        /// The number of lists, or of the geometry's colours.
        len: usize,
        /// The scene's geometry count, or the geometry's triangle count.
        expected: usize,
    },
}

impl fmt::Display for RenderError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RenderError::ImageSize {
                width,
                height,
                reason,
            } => write!(f, "image size {width}x{height}: {reason}"),
            RenderError::Samples { name, value } => {
                let (low, what) = if *name == "spp" {
                    (1, "samples per pixel")
                } else {
                    (0, "AO rays per hit")
                };
                write!(f, "{name} {value} is not in {low}..={MAX_SAMPLES} {what}")
            }
            RenderError::Threads => write!(f, "thread count 0: at least one thread is needed"),
            RenderError::TileSize(t) => {
                write!(f, "tile size {t}: must be even and at least 2 pixels")
            }
            RenderError::Camera(e) => write!(f, "{e}"),
            RenderError::Light(l) => write!(f, "light position {l} is not finite"),
            RenderError::Albedo { len, triangles } => write!(
                f,
                "{len} albedo colours for {triangles} triangles: give one finite colour per \
                 triangle, or none"
            ),
            RenderError::Range {
                name,
                value,
                low,
                high,
            } => write!(f, "{name} {value} is not in {low}..={high}"),
            RenderError::PathMode(m) => write!(
                f,
                "mode {m}: the path tracer traces its bounce and shadow rays as scalar, packet4, \
                 packet8 or stream (the group modes trace coherent screen tiles: use them with \
                 the direct renderer)"
            ),
            RenderError::Materials {
                name,
                len,
                triangles,
            } => write!(
                f,
                "{len} {name} colours for {triangles} triangles: give one per triangle, or none"
            ),
            RenderError::Material { triangle, reason } => {
                write!(f, "triangle {triangle}: {reason}")
            }
            RenderError::Sky(c) => write!(f, "sky radiance {c} must be finite and not negative"),
            RenderError::ForeignHit { prim, triangles } => write!(
                f,
                "the query hit triangle {prim} but the scene's mesh has {triangles} triangles: \
                 trace the structure built from the scene's mesh"
            ),
            RenderError::SceneAlbedo {
                geometry: None,
                len,
                expected,
            } => write!(
                f,
                "{len} albedo lists for {expected} geometries: give one list per geometry \
                 (an empty list is grey), or none"
            ),
            RenderError::SceneAlbedo {
                geometry: Some(g),
                len,
                expected,
            } => write!(
                f,
                "geometry {g}: {len} albedo colours for {expected} triangles: give one finite \
                 colour per triangle, or none"
            ),
        }
    }
}

impl std::error::Error for RenderError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            // Transparent: the message is the camera error's own.
            RenderError::Camera(e) => std::error::Error::source(e),
            _ => None,
        }
    }
}

/// What to render and how.
///
/// ```
/// use glam::Vec3;
/// use packtrace::Camera;
/// use packtrace::Mode;
/// use packtrace::render::RenderOptions;
/// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// let o = RenderOptions::new(cam, Vec3::ONE, 64, 48);
/// assert_eq!((o.spp, o.ao_samples, o.mode, o.tile_size), (1, 0, Mode::Packet8, 16));
/// assert!(o.threads >= 1);
/// assert!(o.validate().is_ok());
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// The pinhole camera (docs/PROTOCOL.md, "Camera and primary rays").
    pub camera: Camera,
    /// The point light's position.
    pub light: Vec3,
    /// Image width in pixels (even).
    pub width: u32,
    /// Image height in pixels (even).
    pub height: u32,
    /// Samples per pixel: 1 traces pixel centres exactly; more jitters each
    /// sample inside the pixel with [`sample_jitter`].
    pub spp: u32,
    /// Ambient-occlusion rays per primary hit (0: none, constant ambient).
    pub ao_samples: u32,
    /// Scalar or packet tracing.
    pub mode: Mode,
    /// Threads that take tiles (the image does not depend on it).
    pub threads: usize,
    /// Tile edge in pixels (even; the image does not depend on it).
    pub tile_size: u32,
}

impl RenderOptions {
    /// Options with 1 sample per pixel, no AO, packet tracing, one thread
    /// per core and [`DEFAULT_TILE`] tiles.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, render::RenderOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// assert_eq!(RenderOptions::new(cam, Vec3::ONE, 8, 6).width, 8);
    /// ```
    #[must_use]
    pub fn new(camera: Camera, light: Vec3, width: u32, height: u32) -> RenderOptions {
        RenderOptions {
            camera,
            light,
            width,
            height,
            spp: 1,
            ao_samples: 0,
            mode: Mode::Packet8,
            threads: std::thread::available_parallelism().map_or(1, |n| n.get()),
            tile_size: DEFAULT_TILE,
        }
    }

    /// Check the options: width and height even, non-zero, at most
    /// [`MAX_SIDE`] and [`MAX_IMAGE_PIXELS`] in all; `1 <= spp` and
    /// `ao_samples <= MAX_SAMPLES`; at least one thread; an even tile edge;
    /// a valid camera ([`Camera::validate`]) and a finite light.
    ///
    /// # Errors
    /// The first [`RenderError`] found, in that order.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, render::RenderOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// let mut o = RenderOptions::new(cam, Vec3::ONE, 8, 6);
    /// o.spp = 0;
    /// assert!(o.validate().unwrap_err().to_string().starts_with("spp 0"));
    /// ```
    pub fn validate(&self) -> Result<(), RenderError> {
        check_size(self.width, self.height)?;
        if !(1..=MAX_SAMPLES).contains(&self.spp) {
            return Err(RenderError::Samples {
                name: "spp",
                value: self.spp,
            });
        }
        if self.ao_samples > MAX_SAMPLES {
            return Err(RenderError::Samples {
                name: "ao",
                value: self.ao_samples,
            });
        }
        check_tiling(self.threads, self.tile_size)?;
        self.camera.validate().map_err(RenderError::Camera)?;
        if !self.light.is_finite() {
            return Err(RenderError::Light(self.light));
        }
        Ok(())
    }

    /// Number of tiles the image is cut into (row-major, the last column
    /// and row possibly narrower, always of even size).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::{Camera, render::RenderOptions};
    /// let cam = Camera::new(Vec3::Z, Vec3::ZERO, Vec3::Y, 45.0).unwrap();
    /// // 40 x 20 in 16 x 16 tiles: 3 columns, 2 rows
    /// assert_eq!(RenderOptions::new(cam, Vec3::ONE, 40, 20).tile_count(), 6);
    /// ```
    #[must_use]
    pub fn tile_count(&self) -> usize {
        self.tiling().count()
    }

    /// Tile `i` as `(x0, y0, x1, y1)`, half-open.
    #[cfg(test)]
    fn tile(&self, i: usize) -> Tile {
        self.tiling().tile(i)
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

/// An image cut into tiles for [`run_tiles`]: the direct renderer's and
/// the path tracer's.
#[derive(Clone, Copy, Debug)]
struct Tiling {
    width: u32,
    height: u32,
    tile_size: u32,
    threads: usize,
}

impl Tiling {
    /// Number of tiles, row-major, the last column and row possibly
    /// narrower.
    fn count(&self) -> usize {
        let t = self.tile_size.max(1);
        self.width.div_ceil(t) as usize * self.height.div_ceil(t) as usize
    }

    /// Tile `i`, half-open.
    fn tile(&self, i: usize) -> Tile {
        let t = self.tile_size;
        let cols = self.width.div_ceil(t) as usize;
        let (x0, y0) = ((i % cols) as u32 * t, (i / cols) as u32 * t);
        Tile {
            x0,
            y0,
            x1: (x0 + t).min(self.width),
            y1: (y0 + t).min(self.height),
        }
    }
}

/// The image size rule of every renderer: the protocol's (even, non-zero),
/// then the renderer's own memory caps.
fn check_size(w: u32, h: u32) -> Result<(), RenderError> {
    let size = |reason: &str| {
        Err(RenderError::ImageSize {
            width: w,
            height: h,
            reason: reason.to_string(),
        })
    };
    if let Err(WorkloadError::ImageSize { reason, .. }) = check_image_size(w, h) {
        return size(&reason);
    }
    if w > MAX_SIDE || h > MAX_SIDE {
        return size(&format!("width and height must be at most {MAX_SIDE}"));
    }
    if w as u64 * h as u64 > MAX_IMAGE_PIXELS {
        return size(&format!(
            "more than {MAX_IMAGE_PIXELS} pixels (8192x8192) in all"
        ));
    }
    Ok(())
}

/// At least one thread, and an even tile edge.
fn check_tiling(threads: usize, tile_size: u32) -> Result<(), RenderError> {
    if threads == 0 {
        return Err(RenderError::Threads);
    }
    if tile_size == 0 || tile_size % 2 == 1 {
        return Err(RenderError::TileSize(tile_size));
    }
    Ok(())
}

/// A rectangle of pixels, half-open, of even width and height.
#[derive(Clone, Copy, Debug)]
struct Tile {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Tile {
    fn width(&self) -> usize {
        (self.x1 - self.x0) as usize
    }

    fn height(&self) -> usize {
        (self.y1 - self.y0) as usize
    }

    /// The tile cut into `g x g` sub-tiles (the last ones narrower),
    /// row by row: the group tiles of the group modes.
    fn sub_tiles(self, g: u32) -> impl Iterator<Item = Tile> {
        (self.y0..self.y1).step_by(g as usize).flat_map(move |y0| {
            (self.x0..self.x1).step_by(g as usize).map(move |x0| Tile {
                x0,
                y0,
                x1: (x0 + g).min(self.x1),
                y1: (y0 + g).min(self.y1),
            })
        })
    }

    /// The top-left pixels of the tile's `w` x 2 blocks, row by row (the
    /// last block of a row may reach past the tile).
    fn blocks(self, w: u32) -> impl Iterator<Item = (u32, u32)> {
        (self.y0..self.y1)
            .step_by(2)
            .flat_map(move |y| (self.x0..self.x1).step_by(w as usize).map(move |x| (x, y)))
    }
}

/// Rays traced by a render, by kind.
///
/// ```
/// let r = packtrace::render::RayCounts { primary: 4, shadow: 3, ao: 8 };
/// assert_eq!(r.total(), 15);
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    /// Camera rays: `width * height * spp`.
    pub primary: u64,
    /// Shadow rays: one per primary hit whose surface faces the light.
    pub shadow: u64,
    /// Ambient-occlusion rays: `ao_samples` per primary hit.
    pub ao: u64,
}

impl RayCounts {
    /// All rays.
    ///
    /// ```
    /// assert_eq!(packtrace::render::RayCounts::default().total(), 0);
    /// ```
    #[must_use]
    pub fn total(&self) -> u64 {
        self.primary + self.shadow + self.ao
    }
}

impl std::ops::AddAssign for RayCounts {
    fn add_assign(&mut self, o: RayCounts) {
        self.primary += o.primary;
        self.shadow += o.shadow;
        self.ao += o.ao;
    }
}

/// An 8-bit RGB image, rows top to bottom, 3 bytes per pixel.
///
/// ```
/// let img = packtrace::render::Rgb8 { width: 2, height: 1, data: vec![0; 6] };
/// assert_eq!(img.data.len(), 3 * (img.width * img.height) as usize);
/// ```
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgb8 {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `R G B` bytes, row-major.
    pub data: Vec<u8>,
}

impl Rgb8 {
    /// The pixel at `(x, y)`.
    ///
    /// # Panics
    /// If `(x, y)` lies outside the image.
    ///
    /// ```
    /// let img = packtrace::render::Rgb8 { width: 2, height: 1, data: vec![0, 0, 0, 9, 8, 7] };
    /// assert_eq!(img.pixel(1, 0), [9, 8, 7]);
    /// ```
    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        assert!(
            x < self.width && y < self.height,
            "pixel ({x}, {y}) outside"
        );
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

/// A rendered image in linear RGB, rows top to bottom.
///
/// ```
/// use glam::Vec3;
/// let img = packtrace::render::Image { width: 1, height: 1, pixels: vec![Vec3::new(0.0, 0.5, 1.0)] };
/// assert_eq!(img.to_srgb8().data, vec![0, 188, 255]);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Linear radiance per pixel, row-major (`y = 0` is the top row).
    pub pixels: Vec<Vec3>,
}

impl Image {
    /// The image as 8-bit sRGB ([`srgb8`] per channel).
    ///
    /// ```
    /// use glam::Vec3;
    /// let img = packtrace::render::Image { width: 1, height: 1, pixels: vec![Vec3::ONE] };
    /// assert_eq!(img.to_srgb8().data, vec![255; 3]);
    /// ```
    #[must_use]
    pub fn to_srgb8(&self) -> Rgb8 {
        Rgb8 {
            width: self.width,
            height: self.height,
            data: self
                .pixels
                .iter()
                .flat_map(|c| [srgb8(c.x), srgb8(c.y), srgb8(c.z)])
                .collect(),
        }
    }

    /// Are the two images the same bit for bit (sizes and every float)?
    ///
    /// ```
    /// use glam::Vec3;
    /// let a = packtrace::render::Image { width: 1, height: 1, pixels: vec![Vec3::ZERO] };
    /// let mut b = a.clone();
    /// assert!(a.bit_identical(&b));
    /// b.pixels[0].x = -0.0;
    /// assert!(!a.bit_identical(&b));
    /// ```
    #[must_use]
    pub fn bit_identical(&self, other: &Image) -> bool {
        let bits = |v: &Vec3| v.to_array().map(f32::to_bits);
        (self.width, self.height) == (other.width, other.height)
            && self.pixels.len() == other.pixels.len()
            && self
                .pixels
                .iter()
                .zip(&other.pixels)
                .all(|(a, b)| bits(a) == bits(b))
    }
}

/// A linear channel value as an 8-bit sRGB byte: clamped to `[0, 1]` (NaN
/// is 0), the sRGB transfer curve, rounded.
///
/// ```
/// use packtrace::render::srgb8;
/// assert_eq!((srgb8(0.0), srgb8(1.0), srgb8(2.0), srgb8(f32::NAN)), (0, 255, 255, 0));
/// assert_eq!(srgb8(0.2159), 128); // sRGB 128 is linear 0.2159
/// ```
#[must_use]
pub fn srgb8(linear: f32) -> u8 {
    let c = if linear.is_nan() {
        0.0
    } else {
        linear.clamp(0.0, 1.0)
    };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// Result of [`render`]: the image and the rays it took.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The image.
    pub image: Image,
    /// Rays traced, by kind (the same in both modes).
    pub rays: RayCounts,
}

/// Sub-pixel position of sample `s` of pixel index `p = y * width + x`:
/// `(0.5, 0.5)` (the centre) when `spp == 1`, else two hashed uniforms in
/// `[0, 1)` from [`hash`] of `p` and `s`.
///
/// ```
/// use packtrace::render::sample_jitter;
/// assert_eq!(sample_jitter(7, 0, 1), (0.5, 0.5));
/// let (jx, jy) = sample_jitter(7, 3, 4);
/// assert!((0.0..1.0).contains(&jx) && (0.0..1.0).contains(&jy));
/// assert_eq!(sample_jitter(7, 3, 4), (jx, jy));
/// assert_ne!(sample_jitter(7, 2, 4), (jx, jy));
/// ```
#[inline]
#[must_use]
pub fn sample_jitter(p: u32, s: u32, spp: u32) -> (f32, f32) {
    if spp == 1 {
        return (0.5, 0.5);
    }
    let h = hash(hash(p ^ 0xA511_E9B3).wrapping_add(s));
    (unit(h), unit(hash(h)))
}

/// Run `work` on every tile with `tiling.threads` threads taking tiles
/// from one atomic counter; results in tile order.
fn run_tiles<T: Send>(
    tiling: Tiling,
    progress: &(dyn Fn(usize) + Sync),
    work: impl Fn(Tile) -> T + Sync,
) -> Vec<(Tile, T)> {
    let n = tiling.count();
    let next = AtomicUsize::new(0);
    let worker = || {
        let mut mine = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= n {
                break mine;
            }
            let t = tiling.tile(i);
            mine.push((i, t, work(t)));
            progress(1);
        }
    };
    let threads = tiling.threads.clamp(1, n.max(1));
    let mut done: Vec<(usize, Tile, T)> = if threads == 1 {
        worker()
    } else {
        std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads).map(|_| s.spawn(worker)).collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        })
    };
    done.sort_unstable_by_key(|d| d.0);
    done.into_iter().map(|(_, t, r)| (t, r)).collect()
}

/// Copy a tile-local buffer into its place in a row-major image.
fn blit<T: Copy>(dst: &mut [T], width: u32, t: Tile, src: &[T]) {
    let tw = t.width();
    for (row, line) in src.chunks_exact(tw).enumerate() {
        let start = (t.y0 as usize + row) * width as usize + t.x0 as usize;
        dst[start..start + tw].copy_from_slice(line);
    }
}

/// Render `tree` as `opts` says, on `opts.threads` threads. `progress(k)`
/// is called (from the worker threads) each time `k` more tiles are done,
/// [`RenderOptions::tile_count`] in all.
///
/// Shading: grey Lambertian surfaces ([`render_with_albedo`] colours
/// them) with the geometric normal flipped toward the viewer; a point
/// light without fall-off seen through a shadow ray from `Q`, the hit
/// point moved off the surface with [`offset_origin`](crate::spawn::offset_origin) (traced only when
/// the surface faces the light); and sky light, from a cool sky above the
/// camera's up vector and a dark ground below (`mix(ground, sky, (1 + n.up)
/// / 2)`), scaled by the fraction of `ao_samples` cosine-distributed rays
/// from `Q` ([`ao_direction`](crate::protocol::sampling::ao_direction)) that escape within a quarter of the scene's
/// diagonal. Misses show a dark gradient. Samples are averaged in sample
/// order.
///
/// # Errors
/// [`RenderError`] from [`RenderOptions::validate`].
///
/// ```
/// use glam::Vec3;
/// use packtrace::render::{RenderOptions, render};
/// use packtrace::{Camera, KdBuildParams, KdTree};
/// let tree = KdTree::build(packtrace::protocol::generate::sphere(200), &KdBuildParams::default())?;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 45.0)?;
/// let out = render(&tree, &RenderOptions::new(cam, Vec3::new(0.0, 0.0, 5.0), 16, 16), &|_| {})?;
/// assert_eq!(out.rays.primary, 256);
/// // The centre of the image sees the sphere lit head-on; a corner sees the background.
/// let img = out.image.to_srgb8();
/// assert!(img.pixel(8, 8)[0] > 200 && img.pixel(0, 0)[0] < 100);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn render(
    tree: &KdTree,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rendered, RenderError> {
    render_with_albedo(tree, &[], opts, progress)
}

/// [`render`] with a diffuse colour (linear RGB) per triangle of the
/// tree's mesh, e.g. from an OBJ file's materials
/// ([`ObjMesh::material`](crate::ObjMesh::material)); an empty list means
/// grey everywhere.
///
/// # Errors
/// [`RenderError`] from [`RenderOptions::validate`];
/// [`RenderError::Albedo`] if `albedo` is neither empty nor one finite
/// colour per triangle.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box, CORNELL_VIEW};
/// use packtrace::render::{RenderOptions, render_with_albedo};
/// use packtrace::{KdBuildParams, KdTree, View};
/// let tree = KdTree::build(cornell_box(), &KdBuildParams::default())?;
/// let view = View::parse(CORNELL_VIEW)?;
/// let opts = RenderOptions::new(view.camera.unwrap(), view.light.unwrap(), 32, 32);
/// let img = render_with_albedo(&tree, &cornell_albedo(), &opts, &|_| {})?.image.to_srgb8();
/// // The red wall on the left, the green one on the right.
/// let (left, right) = (img.pixel(1, 16), img.pixel(30, 16));
/// assert!(left[0] > 2 * left[1] && right[1] > right[0] + 50, "{left:?} {right:?}");
///
/// let e = render_with_albedo(&tree, &[Vec3::ONE], &opts, &|_| {}).unwrap_err();
/// assert_eq!(e.to_string(), "1 albedo colours for 32 triangles: give one finite colour per triangle, or none");
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn render_with_albedo(
    tree: &KdTree,
    albedo: &[Vec3],
    opts: &RenderOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rendered, RenderError> {
    opts.validate()?;
    let triangles = tree.mesh().triangle_count();
    if !albedo.is_empty() && (albedo.len() != triangles || !albedo.iter().all(|c| c.is_finite())) {
        return Err(RenderError::Albedo {
            len: albedo.len(),
            triangles,
        });
    }
    Ok(render_target(
        &TreeTarget::new(tree, albedo),
        opts,
        progress,
    ))
}

/// Render a [`Scene`] of instances as [`render_with_albedo`] renders a
/// kd-tree, with a diffuse colour (linear RGB) per triangle of each
/// geometry: `albedo[g]` for the mesh of geometry `g`
/// ([`GeometryId`](crate::scene::GeometryId)`(g)`), an empty list for a
/// grey geometry, and an empty `albedo` for grey everywhere. Every
/// instance is traced (the ray mask is all ones, no filter).
///
/// Shading is [`render`]'s, with the instance's world-space hit point
/// (the object-space point from the barycentrics mapped by the
/// instance's object-to-world transform) and geometric normal
/// ([`Scene::normal`]); an identity instance is shaded from its
/// object-space point and normal as they are, so a scene of one identity
/// instance of a mesh gives the bare kd-tree's image bit for bit. AO rays
/// reach a quarter of the diagonal of [`scene_frame`]'s box.
///
/// Modes: scalar, packets, streams as for a kd-tree, every mode the same
/// image bit for bit. The group modes ([`Mode::Group8x8`],
/// [`Mode::Group16x16`]) are the kd-tree's: a scene renders them as
/// [`Mode::Packet8`] does (the same image). [`heat_map`] is kd-tree only.
///
/// # Errors
/// [`RenderError`] from [`RenderOptions::validate`];
/// [`RenderError::SceneAlbedo`] if `albedo` is neither empty nor one list
/// per geometry, or a geometry's list is neither empty nor one finite
/// colour per triangle of its mesh.
///
/// ```
/// use glam::{Affine3A, Vec3};
/// use packtrace::protocol::generate::{cornell_albedo, cornell_box, sphere, CORNELL_VIEW};
/// use packtrace::render::{RenderOptions, render_scene};
/// use packtrace::scene::Scene;
/// use packtrace::{KdBuildParams, KdTree, Mode, View};
///
/// let mut scene = Scene::new();
/// let room = scene.add_geometry("room", KdTree::build(cornell_box(), &KdBuildParams::default())?);
/// let ball = scene.add_geometry("ball", KdTree::build(sphere(500), &KdBuildParams::default())?);
/// let mut edit = scene.edit();
/// edit.add_instance(room, Affine3A::IDENTITY)?;
/// let at = Affine3A::from_translation(Vec3::new(278.0, 100.0, 280.0));
/// edit.add_instance(ball, at * Affine3A::from_scale(Vec3::splat(100.0)))?;
/// edit.commit();
///
/// let view = View::parse(CORNELL_VIEW)?;
/// let mut opts = RenderOptions::new(view.camera.unwrap(), view.light.unwrap(), 32, 32);
/// opts.ao_samples = 2;
/// // The room in its colours, the ball grey.
/// let albedo = vec![cornell_albedo(), Vec::new()];
/// let packets = render_scene(&scene, &albedo, &opts, &|_| {})?;
/// opts.mode = Mode::Scalar;
/// let scalar = render_scene(&scene, &albedo, &opts, &|_| {})?;
/// assert!(packets.image.bit_identical(&scalar.image));
/// assert_eq!(packets.rays, scalar.rays);
///
/// let e = render_scene(&scene, &[Vec::new()], &opts, &|_| {}).unwrap_err();
/// assert_eq!(
///     e.to_string(),
///     "1 albedo lists for 2 geometries: give one list per geometry (an empty list is grey), or none"
/// );
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn render_scene(
    scene: &Scene,
    albedo: &[Vec<Vec3>],
    opts: &RenderOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<Rendered, RenderError> {
    opts.validate()?;
    let geometries = scene.geometry_count();
    if !albedo.is_empty() && albedo.len() != geometries {
        return Err(RenderError::SceneAlbedo {
            geometry: None,
            len: albedo.len(),
            expected: geometries,
        });
    }
    for (g, colours) in albedo.iter().enumerate() {
        let triangles = scene
            .geometry(crate::scene::GeometryId(g as u32))
            .map_or(0, |geo| geo.tree().mesh().triangle_count());
        if !colours.is_empty()
            && (colours.len() != triangles || !colours.iter().all(|c| c.is_finite()))
        {
            return Err(RenderError::SceneAlbedo {
                geometry: Some(g as u32),
                len: colours.len(),
                expected: triangles,
            });
        }
    }
    Ok(render_target(
        &SceneTarget::new(scene, albedo),
        opts,
        progress,
    ))
}

/// The box [`render_scene`] measures a scene by, as a [`SceneFrame`]
/// (its centre and diagonal, for an auto camera and a default light as
/// well): [`SceneFrame::of_scene`], the frame the bench's random rays use
/// too. For one identity instance it is the mesh's [`SceneFrame::of`]; it
/// lies inside [`Scene::bounds`] (which is rounded outwards).
///
/// ```
/// use glam::{Affine3A, Vec3};
/// use packtrace::protocol::{SceneFrame, generate::sphere};
/// use packtrace::render::scene_frame;
/// use packtrace::scene::Scene;
/// use packtrace::{KdBuildParams, KdTree};
/// let mut scene = Scene::new();
/// let ball = scene.add_geometry("ball", KdTree::build(sphere(200), &KdBuildParams::default())?);
/// scene.edit().add_instance(ball, Affine3A::IDENTITY)?;
/// assert_eq!(scene_frame(&scene), SceneFrame::of(&sphere(200)));
/// scene.edit().add_instance(ball, Affine3A::from_translation(Vec3::new(10.0, 0.0, 0.0)))?;
/// let f = scene_frame(&scene);
/// assert!((f.center - Vec3::new(5.0, 0.0, 0.0)).length() < 1e-5);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[must_use]
pub fn scene_frame(scene: &Scene) -> SceneFrame {
    SceneFrame::of_scene(scene)
}

/// Render `target` (options already checked).
fn render_target<T: Target>(
    target: &T,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Rendered {
    let ctx = Ctx::new(target, opts);
    let tiles = run_tiles(opts.tiling(), progress, |t| ctx.render_tile(t));
    let mut pixels = vec![Vec3::ZERO; opts.width as usize * opts.height as usize];
    let mut rays = RayCounts::default();
    for (t, (buf, r)) in &tiles {
        blit(&mut pixels, opts.width, *t, buf);
        rays += *r;
    }
    Rendered {
        image: Image {
            width: opts.width,
            height: opts.height,
            pixels,
        },
        rays,
    }
}

/// Per-pixel traversal cost of the primary rays through the pixel centres.
///
/// The cost of a ray is interior nodes visited + leaves visited + triangle
/// tests, from the `*_counted` traversal entry points. In [`Mode::Scalar`]
/// each pixel gets its own ray's cost; in the packet modes the counters
/// are per packet, so each pixel of a 2 x 2 quad ([`Mode::Packet4`]) or a
/// 4 x 2 block ([`Mode::Packet8`], and [`Mode::Stream`], counted as
/// 8-wide blocks) gets the whole cost of its packet (what tracing that
/// block cost). Blocks never straddle a tile edge, so an 8-wide heat map
/// is the same for every tile size that is a multiple of 4 (a quad's for
/// every even one).
///
/// ```
/// use packtrace::render::HeatMap;
/// let h = HeatMap { width: 2, height: 1, counts: vec![3, 40] };
/// assert_eq!((h.min(), h.max()), (3, 40));
/// ```
///
/// The `render` binary draws it in false colour with a legend
/// (`cli/src/bin/render/heatmap.rs`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HeatMap {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Cost per pixel, row-major.
    pub counts: Vec<u32>,
}

/// Compute the [`HeatMap`] of the primary rays of `opts` (pixel centres;
/// `spp` and `ao_samples` are ignored) on `opts.threads` threads, calling
/// `progress` as [`render`] does. Kd-trees only: a [`Scene`]'s queries
/// have no counted entry points, so scenes have no heat map.
///
/// # Errors
/// [`RenderError`] from [`RenderOptions::validate`].
///
/// ```
/// use glam::Vec3;
/// use packtrace::render::{RenderOptions, heat_map};
/// use packtrace::{Camera, KdBuildParams, KdTree, Mesh};
/// // One triangle: a hit costs one leaf and one triangle test.
/// let m = Mesh::new(vec![Vec3::new(-9.0, -9.0, 0.0), Vec3::new(9.0, -9.0, 0.0), Vec3::new(0.0, 9.0, 0.0)], vec![[0, 1, 2]])?;
/// let tree = KdTree::build(m, &KdBuildParams::default())?;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 2.0), Vec3::ZERO, Vec3::Y, 45.0)?;
/// let h = heat_map(&tree, &RenderOptions::new(cam, Vec3::Z, 8, 8), &|_| {})?;
/// assert_eq!(h.max(), 2);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn heat_map(
    tree: &KdTree,
    opts: &RenderOptions,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<HeatMap, RenderError> {
    opts.validate()?;
    let target = TreeTarget::new(tree, &[]);
    let ctx = Ctx::new(&target, opts);
    let tiles = run_tiles(opts.tiling(), progress, |t| ctx.heat_tile(t));
    let mut counts = vec![0u32; opts.width as usize * opts.height as usize];
    for (t, buf) in &tiles {
        blit(&mut counts, opts.width, *t, buf);
    }
    Ok(HeatMap {
        width: opts.width,
        height: opts.height,
        counts,
    })
}

impl HeatMap {
    /// Smallest cost (0 for an empty map).
    ///
    /// ```
    /// let h = packtrace::render::HeatMap { width: 0, height: 0, counts: vec![] };
    /// assert_eq!(h.min(), 0);
    /// ```
    #[must_use]
    pub fn min(&self) -> u32 {
        self.counts.iter().copied().min().unwrap_or(0)
    }

    /// Largest cost (0 for an empty map).
    ///
    /// ```
    /// let h = packtrace::render::HeatMap { width: 1, height: 1, counts: vec![7] };
    /// assert_eq!(h.max(), 7);
    /// ```
    #[must_use]
    pub fn max(&self) -> u32 {
        self.counts.iter().copied().max().unwrap_or(0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::protocol::camera::ImagePlane;

    /// `RenderError::Camera` is transparent: the camera error's message,
    /// and its source (none), not the camera error again.
    #[test]
    fn camera_errors_are_transparent() {
        let inner = Camera::parse("1,2").unwrap_err();
        let e = RenderError::Camera(Camera::parse("1,2").unwrap_err());
        assert_eq!(e.to_string(), inner.to_string());
        assert!(std::error::Error::source(&e).is_none());
    }
    use crate::kdtree::KdBuildParams;

    /// At the pixel centre the renderer's rays are the protocol's, bit for
    /// bit.
    #[test]
    fn centre_rays_are_the_protocol_rays() {
        let cam = Camera::parse("278,273,-800,278,273,0,0,1,0,39.3077").unwrap();
        let lens = ImagePlane::new(&cam, 20, 14);
        for y in 0..14 {
            for x in 0..20 {
                let a = lens.ray(x, y);
                let b = cam.primary_ray(x, y, 20, 14);
                assert_eq!(
                    a.dir.to_array().map(f32::to_bits),
                    b.dir.to_array().map(f32::to_bits)
                );
                assert_eq!((a.origin, a.t_min, a.t_max), (b.origin, b.t_min, b.t_max));
            }
        }
    }

    #[test]
    fn tiles_cover_the_image_once_with_even_sizes() {
        let cam = Camera::parse("0,0,5,0,0,0,0,1,0,45").unwrap();
        let mut opts = RenderOptions::new(cam, Vec3::ONE, 38, 22);
        opts.tile_size = 8;
        let mut seen = vec![0u8; 38 * 22];
        for i in 0..opts.tile_count() {
            let t = opts.tile(i);
            assert!(t.width().is_multiple_of(2) && t.height().is_multiple_of(2) && t.width() > 0);
            for (x, y) in t.blocks(2) {
                for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                    seen[((y + dy) * 38 + x + dx) as usize] += 1;
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
        // 4 x 2 blocks: the pixels inside the tile, once each.
        let mut seen = vec![0u8; 38 * 22];
        for i in 0..opts.tile_count() {
            let t = opts.tile(i);
            for (x, y) in t.blocks(4) {
                for (dx, dy) in (0..8).map(|l| (l % 4, l / 4)) {
                    if x + dx < t.x1 {
                        seen[((y + dy) * 38 + x + dx) as usize] += 1;
                    }
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1));
    }

    #[test]
    fn results_do_not_depend_on_tiles_or_threads() {
        let tree = KdTree::build(
            crate::protocol::generate::cornell_box(),
            &KdBuildParams::default(),
        )
        .unwrap();
        let cam = Camera::parse("278,273,-800,278,273,0,0,1,0,39.3077").unwrap();
        let mut opts = RenderOptions::new(cam, Vec3::new(278.0, 538.8, 279.5), 30, 26);
        opts.ao_samples = 3;
        opts.spp = 2;
        opts.threads = 1;
        opts.tile_size = 30;
        let base = render(&tree, &opts, &|_| {}).unwrap();
        let first = opts;
        let heat = |mode: Mode, tile: u32| {
            let o = RenderOptions {
                mode,
                tile_size: tile,
                ..first
            };
            heat_map(&tree, &o, &|_| {}).unwrap()
        };
        let (heat4, heat8) = (heat(Mode::Packet4, 30), heat(Mode::Packet8, 32));
        for (tile, threads) in [(2, 3), (6, 2), (64, 4)] {
            opts.tile_size = tile;
            opts.threads = threads;
            let r = render(&tree, &opts, &|_| {}).unwrap();
            assert!(r.image.bit_identical(&base.image));
            assert_eq!(r.rays, base.rays);
            // Per-packet costs follow the grouping: 2 x 2 quads never
            // straddle an even tile edge, 4 x 2 blocks only keep theirs
            // when the tile size is a multiple of 4.
            assert_eq!(heat(Mode::Packet4, tile), heat4);
            if tile % 4 == 0 {
                assert_eq!(heat(Mode::Packet8, tile), heat8);
            }
        }
        assert_eq!(heat(Mode::Packet8, 4), heat8);
    }

    /// The Cornell box (in its colours, AO, 2 spp) and a sphere seen
    /// from outside (grey): one identity instance of the mesh renders the
    /// bare kd-tree's image bit for bit, with the same ray counts, in
    /// every mode (the group modes as packet8 for the scene).
    #[test]
    fn one_identity_instance_renders_as_the_bare_tree() {
        use crate::protocol::generate;
        use crate::scene::Scene;
        let view = crate::protocol::camera::View::parse(generate::CORNELL_VIEW).unwrap();
        let sphere_cam = Camera::new(Vec3::new(0.4, 0.7, 2.5), Vec3::ZERO, Vec3::Y, 50.0).unwrap();
        let cases = [
            (
                generate::cornell_box(),
                generate::cornell_albedo(),
                view.camera.unwrap(),
                view.light.unwrap(),
            ),
            (
                generate::sphere(2_000),
                Vec::new(),
                sphere_cam,
                Vec3::new(3.0, 4.0, 5.0),
            ),
        ];
        for (mesh, albedo, camera, light) in cases {
            let tree = KdTree::build(mesh.clone(), &KdBuildParams::default()).unwrap();
            let mut scene = Scene::new();
            let g = scene.add_geometry(
                "mesh",
                KdTree::build(mesh, &KdBuildParams::default()).unwrap(),
            );
            scene
                .edit()
                .add_instance(g, glam::Affine3A::IDENTITY)
                .unwrap();
            let mut opts = RenderOptions::new(camera, light, 48, 40);
            opts.ao_samples = 3;
            opts.spp = 2;
            opts.threads = 2;
            let lists = vec![albedo.clone()];
            for mode in Mode::ALL {
                opts.mode = mode;
                let bare = render_with_albedo(&tree, &albedo, &opts, &|_| {}).unwrap();
                let inst = render_scene(&scene, &lists, &opts, &|_| {}).unwrap();
                assert!(inst.image.bit_identical(&bare.image), "{mode}");
                assert_eq!(inst.rays, bare.rays, "{mode}");
                assert!(bare.rays.shadow > 0 && bare.rays.ao > 0, "{mode}");
            }
        }
    }

    /// `data/cornell_spheres.scene` (scaled, rotated, mirrored instances)
    /// renders the same image, bit for bit, and the same ray counts in
    /// every mode, thread count and tile size; the balls show (the image
    /// is not the bare box's) in grey, the walls in their colours.
    #[test]
    fn the_example_scene_renders_the_same_in_every_mode() {
        use crate::protocol::generate;
        let data = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
        let scene = crate::protocol::scene_file::load_scene(
            data.join("cornell_spheres.scene"),
            &KdBuildParams::default(),
        )
        .unwrap();
        let box_id = (0..scene.geometry_count() as u32)
            .find(|&g| {
                let geo = scene.geometry(crate::scene::GeometryId(g)).unwrap();
                geo.name() == "box"
            })
            .unwrap();
        let mut albedo = vec![Vec::new(); scene.geometry_count()];
        albedo[box_id as usize] = generate::cornell_albedo();
        let view = crate::protocol::camera::View::parse(generate::CORNELL_VIEW).unwrap();
        let mut opts = RenderOptions::new(view.camera.unwrap(), view.light.unwrap(), 64, 64);
        opts.ao_samples = 2;
        opts.threads = 1;
        opts.mode = Mode::Scalar;
        let base = render_scene(&scene, &albedo, &opts, &|_| {}).unwrap();
        for (mode, threads, tile) in [
            (Mode::Packet4, 2, 16),
            (Mode::Packet8, 3, 8),
            (Mode::Stream, 2, 64),
            (Mode::Group8x8, 2, 16),
            (Mode::Group16x16, 1, 6),
        ] {
            let o = RenderOptions {
                mode,
                threads,
                tile_size: tile,
                ..opts
            };
            let r = render_scene(&scene, &albedo, &o, &|_| {}).unwrap();
            assert!(r.image.bit_identical(&base.image), "{mode}");
            assert_eq!(r.rays, base.rays, "{mode}");
        }
        let tree = KdTree::build(generate::cornell_box(), &KdBuildParams::default()).unwrap();
        let bare = render_with_albedo(&tree, &generate::cornell_albedo(), &opts, &|_| {}).unwrap();
        let (a, b) = (base.image.to_srgb8(), bare.image.to_srgb8());
        let differ = (0..64 * 64).filter(|i| a.data[3 * i..3 * i + 3] != b.data[3 * i..3 * i + 3]);
        assert!(differ.count() > 200);
        // The red wall is red in both.
        let wall = a.pixel(1, 32);
        assert!(wall[0] > 2 * wall[1] && wall == b.pixel(1, 32), "{wall:?}");
    }

    #[test]
    fn scene_albedo_errors_name_the_geometry() {
        use crate::protocol::generate;
        use crate::scene::Scene;
        let mut scene = Scene::new();
        for spec in [8, 20] {
            let t = KdTree::build(generate::sphere(spec), &KdBuildParams::default()).unwrap();
            let g = scene.add_geometry("s", t);
            scene
                .edit()
                .add_instance(g, glam::Affine3A::IDENTITY)
                .unwrap();
        }
        let n1 = scene
            .geometry(crate::scene::GeometryId(1))
            .unwrap()
            .tree()
            .mesh()
            .triangle_count();
        let cam = Camera::parse("0,0,5,0,0,0,0,1,0,45").unwrap();
        let opts = RenderOptions::new(cam, Vec3::ONE, 8, 8);
        let err = |albedo: &[Vec<Vec3>]| {
            render_scene(&scene, albedo, &opts, &|_| {})
                .unwrap_err()
                .to_string()
        };
        assert_eq!(
            err(&vec![vec![Vec3::ONE]; 3]),
            "3 albedo lists for 2 geometries: give one list per geometry (an empty list is grey), \
             or none"
        );
        assert_eq!(
            err(&[Vec::new(), vec![Vec3::ONE; 2]]),
            format!(
                "geometry 1: 2 albedo colours for {n1} triangles: give one finite colour per \
                 triangle, or none"
            )
        );
        let mut nan = vec![Vec3::ONE; n1];
        nan[0].y = f32::NAN;
        assert!(err(&[Vec::new(), nan]).starts_with("geometry 1: "));
        assert!(render_scene(&scene, &[], &opts, &|_| {}).is_ok());
        assert!(render_scene(&scene, &[vec![], vec![]], &opts, &|_| {}).is_ok());
        // Bad options first.
        let bad = RenderOptions { spp: 0, ..opts };
        assert!(matches!(
            render_scene(&scene, &[], &bad, &|_| {}),
            Err(RenderError::Samples { .. })
        ));
    }
}
