//! The protocol's pinhole camera, its primary rays, and view files
//! (docs/PROTOCOL.md, "Camera and primary rays").
//!
//! A view file `NAME.view` sits beside `NAME.obj` and lists the scene's
//! camera and light:
//!
//! ```text
//! # comment
//! camera ex,ey,ez,tx,ty,tz,ux,uy,uz,fov
//! light lx,ly,lz
//! ```
//!
//! Both lines are optional; a scene without a camera uses
//! [`Camera::auto`], one without a light uses
//! [`crate::protocol::default_light`].

use super::frame::SceneFrame;
use crate::aabb::Aabb;
use crate::ray::Ray;
use glam::Vec3;
use std::fmt;
use std::path::{Path, PathBuf};

/// Why a camera, light or view file was refused. Every message names the
/// text, file, line or value at fault.
///
/// ```
/// use packtrace::protocol::camera::{Camera, ViewError};
/// let e = Camera::parse("0,0,0, 0,0,-1, 0,1,0, fortyfive").unwrap_err();
/// assert!(matches!(e, ViewError::Camera { .. }));
/// assert!(e.to_string().contains("`fortyfive`"));
/// ```
#[derive(Debug)]
pub enum ViewError {
    /// A camera could not be parsed, or describes no valid camera.
    Camera {
        /// The camera as given (protocol form).
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A light position could not be parsed or is not finite.
    Light {
        /// The light as given.
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A line of a view file is invalid.
    ViewLine {
        /// The view file (`None` for text parsed from memory).
        path: Option<PathBuf>,
        /// Line number, 1-based.
        line: usize,
        /// The line as written.
        text: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A view file exists but could not be read.
    Io {
        /// The view file.
        path: PathBuf,
        /// What the OS said.
        source: std::io::Error,
    },
}

impl fmt::Display for ViewError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ViewError::Camera { text, reason } => write!(f, "invalid camera `{text}`: {reason}"),
            ViewError::Light { text, reason } => write!(f, "invalid light `{text}`: {reason}"),
            ViewError::ViewLine {
                path,
                line,
                text,
                reason,
            } => {
                let file = path
                    .as_ref()
                    .map_or_else(|| "<memory>".to_string(), |p| p.display().to_string());
                write!(f, "{file}:{line}: {reason} (line: `{text}`)")
            }
            ViewError::Io { path, .. } => {
                write!(f, "{}: cannot read the view file", path.display())
            }
        }
    }
}

/// `Display` and `source()` never repeat each other: an I/O error's OS
/// message is only the source.
impl std::error::Error for ViewError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            ViewError::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

/// Parse exactly `N` comma-separated finite `f32` values (whitespace
/// around each is ignored). The error says which component is wrong.
fn parse_numbers<const N: usize>(s: &str) -> Result<[f32; N], String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    if parts.len() != N {
        return Err(format!(
            "expected {N} comma-separated numbers, found {}",
            parts.len()
        ));
    }
    let mut out = [0.0f32; N];
    for (k, (slot, part)) in out.iter_mut().zip(&parts).enumerate() {
        let v: f32 = part
            .parse()
            .map_err(|_| format!("component {} of {N}, `{part}`, is not a number", k + 1))?;
        if !v.is_finite() {
            return Err(format!(
                "component {} of {N}, `{part}`, is not finite",
                k + 1
            ));
        }
        *slot = v;
    }
    Ok(out)
}

/// Parse a light position `x,y,z` (three finite numbers, whitespace
/// tolerant), as on a view file's `light` line or a command line.
///
/// # Errors
/// [`ViewError::Light`] naming the text and the bad component.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::camera::parse_light;
/// assert_eq!(parse_light(" 1, 2.5 ,-3 ").unwrap(), Vec3::new(1.0, 2.5, -3.0));
/// assert!(parse_light("1,2").unwrap_err().to_string().contains("`1,2`"));
/// ```
pub fn parse_light(s: &str) -> Result<Vec3, ViewError> {
    parse_numbers::<3>(s)
        .map(Vec3::from_array)
        .map_err(|reason| ViewError::Light {
            text: s.trim().to_string(),
            reason,
        })
}

/// A pinhole camera: `eye` looks at `target`, `up` fixes the roll, `fov_deg`
/// is the vertical field of view in degrees.
///
/// The fields are public; [`Camera::new`] and [`Camera::parse`] check them
/// with [`Camera::validate`]. Rays of an invalid camera are not finite.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::camera::Camera;
/// let cam = Camera::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 45.0).unwrap();
/// // the centre of a 2 x 2 image's pixel grid looks straight ahead
/// let r = cam.primary_ray(0, 0, 2, 2);
/// assert_eq!(r.origin(), cam.eye);
/// assert!(r.dir().z < 0.0 && r.dir().x < 0.0 && r.dir().y > 0.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    /// Eye (ray origin).
    pub eye: Vec3,
    /// Point the camera looks at.
    pub target: Vec3,
    /// Up hint; need not be unit or orthogonal to the view direction.
    pub up: Vec3,
    /// Vertical field of view in degrees, in `(0, 180)`.
    pub fov_deg: f32,
}

/// The per-image constants of the protocol's camera formula (`f, r, u, h,
/// a` and the image size), computed once per image; rays through any
/// sub-pixel position.
///
/// ```
/// use glam::Vec3;
/// use packtrace::protocol::camera::{Camera, ImagePlane};
/// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
/// let plane = ImagePlane::new(&cam, 4, 2);
/// assert_eq!(plane.ray(1, 0), cam.primary_ray(1, 0, 4, 2));
/// assert_eq!(plane.ray_at(1, 0, (0.5, 0.5)), plane.ray(1, 0));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct ImagePlane {
    eye: Vec3,
    f: Vec3,
    r: Vec3,
    u: Vec3,
    h: f32,
    a: f32,
    w: f32,
    hgt: f32,
}

impl ImagePlane {
    /// The protocol's per-image constants, in `f32`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::{Camera, ImagePlane};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
    /// let _ = ImagePlane::new(&cam, 640, 480);
    /// ```
    #[must_use]
    pub fn new(cam: &Camera, width: u32, height: u32) -> ImagePlane {
        let f = (cam.target - cam.eye).normalize();
        let r = f.cross(cam.up).normalize();
        let u = r.cross(f);
        let h = (cam.fov_deg * std::f32::consts::PI / 360.0).tan();
        let (w, hgt) = (width as f32, height as f32);
        ImagePlane {
            eye: cam.eye,
            f,
            r,
            u,
            h,
            a: w / hgt,
            w,
            hgt,
        }
    }

    /// The image's unit up vector `u = cross(r, f)`.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::{Camera, ImagePlane};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
    /// assert_eq!(ImagePlane::new(&cam, 2, 2).up(), Vec3::Y);
    /// ```
    #[must_use]
    pub fn up(&self) -> Vec3 {
        self.u
    }

    /// The primary ray through the centre of pixel `(x, y)` (docs/PROTOCOL.md,
    /// "Camera and primary rays").
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::{Camera, ImagePlane};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
    /// assert_eq!(ImagePlane::new(&cam, 2, 2).ray(0, 0).origin(), Vec3::ZERO);
    /// ```
    #[inline]
    #[must_use]
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        self.ray_at(x, y, (0.5, 0.5))
    }

    /// The ray through `(x + jx, y + jy)`, `jx, jy` in `[0, 1)`: the protocol
    /// formula with `x + 0.5` replaced by `x + jx` (supersampling).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::{Camera, ImagePlane};
    /// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
    /// let p = ImagePlane::new(&cam, 2, 2);
    /// // the top-left corner of the image: 45 degrees left and up
    /// let r = p.ray_at(0, 0, (0.0, 0.0));
    /// assert!((r.dir() - Vec3::new(-1.0, 1.0, -1.0).normalize()).length() < 1e-6);
    /// ```
    #[inline]
    #[must_use]
    pub fn ray_at(&self, x: u32, y: u32, (jx, jy): (f32, f32)) -> Ray {
        let sx = (2.0 * (x as f32 + jx) / self.w - 1.0) * self.h * self.a;
        let sy = (1.0 - 2.0 * (y as f32 + jy) / self.hgt) * self.h;
        let dir = (self.f + sx * self.r + sy * self.u).normalize();
        Ray::new_unchecked(self.eye, dir, 0.0, f32::INFINITY)
    }
}

impl Camera {
    /// A checked camera.
    ///
    /// # Errors
    /// [`ViewError::Camera`] as [`Camera::validate`] says.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::Camera;
    /// assert!(Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0).is_ok());
    /// // looking straight up with up = +y: no defined roll
    /// assert!(Camera::new(Vec3::ZERO, Vec3::Y, Vec3::Y, 60.0).is_err());
    /// ```
    pub fn new(eye: Vec3, target: Vec3, up: Vec3, fov_deg: f32) -> Result<Camera, ViewError> {
        let cam = Camera {
            eye,
            target,
            up,
            fov_deg,
        };
        cam.validate()?;
        Ok(cam)
    }

    /// Check that the protocol formula gives finite rays: all values
    /// finite, `eye != target`, `up` not zero and not parallel to the view
    /// direction (`|cross(f, up)| > 1e-6 |up|`, i.e. more than about 1e-6
    /// radians apart), `0 < fov_deg < 180`.
    ///
    /// # Errors
    /// [`ViewError::Camera`] with the camera in protocol form and the
    /// reason.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::Camera;
    /// let mut cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 60.0).unwrap();
    /// cam.fov_deg = 180.0;
    /// assert!(cam.validate().unwrap_err().to_string().contains("field of view"));
    /// ```
    pub fn validate(&self) -> Result<(), ViewError> {
        let fail = |reason: String| {
            Err(ViewError::Camera {
                text: self.to_string(),
                reason,
            })
        };
        if !(self.eye.is_finite() && self.target.is_finite() && self.up.is_finite()) {
            return fail("eye, target and up must be finite".into());
        }
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return fail(format!(
                "field of view {} is not in (0, 180) degrees",
                self.fov_deg
            ));
        }
        let f = (self.target - self.eye).normalize_or_zero();
        if f == Vec3::ZERO {
            return fail("eye and target coincide (no view direction)".into());
        }
        if self.up == Vec3::ZERO {
            return fail("up is the zero vector".into());
        }
        let side = f.cross(self.up);
        if side.length() <= 1e-6 * self.up.length() || side.normalize_or_zero() == Vec3::ZERO {
            return fail(format!(
                "up {} is parallel to the view direction {f}",
                self.up
            ));
        }
        Ok(())
    }

    /// Parse the protocol form `ex,ey,ez,tx,ty,tz,ux,uy,uz,fov`: exactly ten
    /// finite numbers separated by commas, whitespace around each ignored.
    ///
    /// # Errors
    /// [`ViewError::Camera`] naming the text and the bad component, or
    /// the reason the camera is invalid ([`Camera::validate`]).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::Camera;
    /// let cam = Camera::parse("0,1,3.9, 0,1,0, 0,1,0, 39.3").unwrap();
    /// assert_eq!(cam.eye, Vec3::new(0.0, 1.0, 3.9));
    /// assert_eq!(cam.fov_deg, 39.3);
    /// assert!(Camera::parse("0,1,3.9,0,1,0,0,1,0").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Camera, ViewError> {
        let v = parse_numbers::<10>(s).map_err(|reason| ViewError::Camera {
            text: s.trim().to_string(),
            reason,
        })?;
        Camera::new(
            Vec3::new(v[0], v[1], v[2]),
            Vec3::new(v[3], v[4], v[5]),
            Vec3::new(v[6], v[7], v[8]),
            v[9],
        )
    }

    /// The protocol's auto camera for a scene box: `target = C`,
    /// `eye = C + 0.9 * D * normalize(0.3, 0.4, 1.0)`, `up = +y`,
    /// `fov = 45`, with `C` the box centre and `D` its diagonal (computed as
    /// [`SceneFrame::from_bounds`] does).
    ///
    /// An empty box gives a non-finite camera and a single point one with
    /// `eye == target`; [`Camera::validate`] rejects both.
    ///
    /// ```
    /// use glam::{Vec3, Vec3A};
    /// use packtrace::{Aabb, protocol::camera::Camera};
    /// let cam = Camera::auto(&Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0)));
    /// assert_eq!(cam.target, Vec3::ZERO);
    /// assert!((cam.eye.length() - 0.9 * 12f32.sqrt()).abs() < 1e-5);
    /// assert!(cam.validate().is_ok());
    /// ```
    #[must_use]
    pub fn auto(bounds: &Aabb) -> Camera {
        let frame = SceneFrame::from_bounds(*bounds);
        let c = frame.center;
        Camera {
            eye: c + 0.9 * frame.diagonal * Vec3::new(0.3, 0.4, 1.0).normalize(),
            target: c,
            up: Vec3::Y,
            fov_deg: 45.0,
        }
    }

    /// The primary ray of pixel `(x, y)` of a `width x height` image
    /// (`y = 0` is the top row), exactly the protocol formula in `f32`:
    /// origin `eye`, unit direction, `t_min = 0`, `t_max = +inf`.
    ///
    /// The pixel need not lie inside the image. For a camera that fails
    /// [`Camera::validate`] the ray is not finite (and never hits).
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::Camera;
    /// let cam = Camera::new(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y, 90.0).unwrap();
    /// let r = cam.primary_ray(1, 0, 2, 2);
    /// // h = tan(45 deg) = 1, a = 1: sx = 0.5, sy = 0.5
    /// let expect = Vec3::new(0.5, 0.5, -1.0).normalize();
    /// assert!((r.dir() - expect).length() < 1e-6);
    /// assert_eq!((r.t_min(), r.t_max()), (0.0, f32::INFINITY));
    /// ```
    #[must_use]
    pub fn primary_ray(&self, x: u32, y: u32, width: u32, height: u32) -> Ray {
        ImagePlane::new(self, width, height).ray(x, y)
    }
}

impl fmt::Display for Camera {
    /// The protocol form `ex,ey,ez,tx,ty,tz,ux,uy,uz,fov` (shortest
    /// round-trip numbers, so [`Camera::parse`] gives the camera back).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (e, t, u) = (self.eye, self.target, self.up);
        write!(
            f,
            "{},{},{},{},{},{},{},{},{},{}",
            e.x, e.y, e.z, t.x, t.y, t.z, u.x, u.y, u.z, self.fov_deg
        )
    }
}

/// The contents of a view file: the scene's listed camera and light.
///
/// ```
/// use packtrace::protocol::camera::View;
/// let v = View::parse("# bunny\ncamera 0,0,1, 0,0,0, 0,1,0, 45\n").unwrap();
/// assert!(v.camera.is_some() && v.light.is_none());
/// ```
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct View {
    /// The listed camera, if any.
    pub camera: Option<Camera>,
    /// The listed light position, if any.
    pub light: Option<Vec3>,
}

impl View {
    /// Parse view-file text: `camera ...` and `light x,y,z` lines, each at
    /// most once; `#` starts a comment; blank lines are ignored; any other
    /// line is an error. Keywords are lower case, separated from their
    /// value by whitespace.
    ///
    /// # Errors
    /// [`ViewError::ViewLine`] (with `path: None`) naming the line number,
    /// the line and the reason.
    ///
    /// ```
    /// use glam::Vec3;
    /// use packtrace::protocol::camera::View;
    /// let v = View::parse("light 1,2,3  # above\n\n").unwrap();
    /// assert_eq!(v.light, Some(Vec3::new(1.0, 2.0, 3.0)));
    /// let e = View::parse("\nlamp 1,2,3\n").unwrap_err();
    /// assert!(e.to_string().starts_with("<memory>:2:"));
    /// ```
    pub fn parse(text: &str) -> Result<View, ViewError> {
        let mut view = View::default();
        for (i, raw) in text.lines().enumerate() {
            let fail = |reason: String| ViewError::ViewLine {
                path: None,
                line: i + 1,
                text: raw.trim_end().to_string(),
                reason,
            };
            let line = raw.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let (key, value) = line
                .split_once(char::is_whitespace)
                .map_or((line, ""), |(k, v)| (k, v.trim()));
            match key {
                "camera" => {
                    if view.camera.is_some() {
                        return Err(fail("second `camera` line".into()));
                    }
                    view.camera = Some(Camera::parse(value).map_err(|e| fail(e.to_string()))?);
                }
                "light" => {
                    if view.light.is_some() {
                        return Err(fail("second `light` line".into()));
                    }
                    view.light = Some(parse_light(value).map_err(|e| fail(e.to_string()))?);
                }
                _ => {
                    return Err(fail(format!(
                        "unknown keyword `{key}` (expected `camera` or `light`)"
                    )));
                }
            }
        }
        Ok(view)
    }

    /// The listed camera, else the auto camera of `bounds`.
    ///
    /// ```
    /// use glam::Vec3A;
    /// use packtrace::{Aabb, protocol::camera::{Camera, View}};
    /// let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    /// assert_eq!(View::default().camera_or_auto(&b), Camera::auto(&b));
    /// ```
    #[must_use]
    pub fn camera_or_auto(&self, bounds: &Aabb) -> Camera {
        self.camera.unwrap_or_else(|| Camera::auto(bounds))
    }

    /// The listed light, else the protocol's default light of the scene.
    ///
    /// ```
    /// use glam::{Vec3, Vec3A};
    /// use packtrace::{Aabb, protocol::camera::View, protocol::{SceneFrame, default_light}};
    /// let frame = SceneFrame::from_bounds(Aabb::new(Vec3A::ZERO, Vec3A::ONE));
    /// assert_eq!(View::default().light_or_default(&frame), default_light(&frame));
    /// ```
    #[must_use]
    pub fn light_or_default(&self, frame: &SceneFrame) -> Vec3 {
        self.light
            .unwrap_or_else(|| crate::protocol::frame::default_light(frame))
    }
}

/// The view file of a scene: `NAME.view` beside `NAME.obj` (the OBJ path
/// with its extension replaced). A missing view file is an empty
/// [`View`] (auto camera, default light).
///
/// # Errors
/// [`ViewError::Io`] if the view file exists but cannot be read,
/// [`ViewError::ViewLine`] naming the file and line of a bad line.
///
/// ```
/// use packtrace::protocol::camera::{View, load_view};
/// // no such view file: nothing listed
/// assert_eq!(load_view(std::path::Path::new("no/such/scene.obj")).unwrap(), View::default());
/// ```
pub fn load_view(obj_path: &Path) -> Result<View, ViewError> {
    let path = obj_path.with_extension("view");
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(View::default()),
        Err(source) => return Err(ViewError::Io { path, source }),
    };
    View::parse(&text).map_err(|e| match e {
        ViewError::ViewLine {
            line, text, reason, ..
        } => ViewError::ViewLine {
            path: Some(path.clone()),
            line,
            text,
            reason,
        },
        other => other,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A scratch folder of its own for one test, removed when dropped
    /// (the harness runs tests on parallel threads: a folder shared by
    /// two tests is removed under the other's feet).
    struct Scratch(std::path::PathBuf);

    impl Scratch {
        fn new(test: &str) -> Scratch {
            let dir =
                std::env::temp_dir().join(format!("packtrace-view-{}-{test}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            Scratch(dir)
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }

    /// An unreadable view file: the path in the message, the OS's reason
    /// only as the source. Other errors have no source.
    #[test]
    fn view_errors_do_not_repeat_their_source() {
        use std::error::Error;
        let scratch = Scratch::new("unreadable");
        let dir = &scratch.0;
        std::fs::create_dir_all(dir.join("x.view")).unwrap();
        // A directory where the view file should be: exists, unreadable.
        let e = load_view(&dir.join("x.obj")).unwrap_err();
        assert!(matches!(e, ViewError::Io { .. }), "{e:?}");
        let source = e.source().expect("the OS error");
        assert!(
            e.to_string().ends_with("x.view: cannot read the view file"),
            "{e}"
        );
        assert!(!e.to_string().contains(&source.to_string()));
        assert!(Camera::parse("1,2").unwrap_err().source().is_none());
    }

    /// Directions of the 4 x 2 image of eye (1, 2, 3), target (0, 0.5, -1),
    /// up (0, 1, 0), fov 60, hand-computed in f64 (python3) from the
    /// protocol formulas, in pixel order.
    const EXPECTED_4X2: [[f64; 3]; 8] = [
        [
            -0.8065144385950005,
            -0.05214251265820867,
            -0.5889105354054042,
        ],
        [
            -0.49245637495665123,
            -0.06536409880641772,
            -0.8678791697879257,
        ],
        [
            0.02610660388508024,
            -0.06536409880641772,
            -0.9975199144983584,
        ],
        [
            0.43449601739304544,
            -0.052142512658208656,
            -0.8991631494024156,
        ],
        [
            -0.7711578718557915,
            -0.45285026903591025,
            -0.44748426844856826,
        ],
        [
            -0.4481345729570782,
            -0.5676778548015792,
            -0.6905919617896333,
        ],
        [
            0.07042840588465331,
            -0.5676778548015792,
            -0.8202327065000662,
        ],
        [
            0.4698525841322544,
            -0.45285026903591025,
            -0.7577368824455798,
        ],
    ];

    #[test]
    fn primary_rays_of_a_4x2_image_match_f64_reference() {
        let cam = Camera::parse("1,2,3, 0,0.5,-1, 0,1,0, 60").unwrap();
        for y in 0..2 {
            for x in 0..4 {
                let r = cam.primary_ray(x, y, 4, 2);
                let e = EXPECTED_4X2[(y * 4 + x) as usize];
                assert_eq!(r.origin, Vec3::new(1.0, 2.0, 3.0));
                assert_eq!((r.t_min, r.t_max), (0.0, f32::INFINITY));
                for (a, want) in e.iter().enumerate() {
                    let got = r.dir[a] as f64;
                    assert!(
                        (got - want).abs() < 1e-6,
                        "pixel ({x},{y}) axis {a}: {got} vs {want}"
                    );
                }
            }
        }
    }

    #[test]
    fn auto_camera_matches_f64_reference() {
        // box (-1,0,2)..(3,1,4): C = (1, 0.5, 3), D = sqrt(21)
        let b = Aabb::new(
            glam::Vec3A::new(-1.0, 0.0, 2.0),
            glam::Vec3A::new(3.0, 1.0, 4.0),
        );
        let cam = Camera::auto(&b);
        assert_eq!(cam.target, Vec3::new(1.0, 0.5, 3.0));
        assert_eq!((cam.up, cam.fov_deg), (Vec3::Y, 45.0));
        // python3: C + 0.9*sqrt(21)*(0.3,0.4,1)/sqrt(1.25)
        let e = [2.1066706827236366, 1.9755609102981821, 6.6889022757454555];
        for (a, want) in e.iter().enumerate() {
            assert!((cam.eye[a] as f64 - want).abs() < 1e-5, "{}", cam.eye);
        }
    }

    #[test]
    fn parse_is_whitespace_tolerant_and_round_trips() {
        let cam = Camera::parse("  -0.0168 ,0.125,\t0.26,-0.0168,0.11,-0.0015,0,1,0,45 ").unwrap();
        assert_eq!(cam.eye, Vec3::new(-0.0168, 0.125, 0.26));
        assert_eq!(Camera::parse(&cam.to_string()).unwrap(), cam);
    }

    #[test]
    fn parse_errors_name_the_bad_text() {
        let msg = |s: &str| Camera::parse(s).unwrap_err().to_string();
        assert!(msg("1,2,3").contains("found 3"));
        assert!(msg("0,0,1,0,0,0,0,1,0,45,7").contains("found 11"));
        assert!(msg("0,0,1,0,0,0,0,1,0,nan").contains("`nan`"));
        assert!(msg("0,0,1,0,0,0,0,1,0,inf").contains("not finite"));
        assert!(msg("0,0,1,0,0,0,0,1,0,").contains("component 10"));
        assert!(msg("0,x,1,0,0,0,0,1,0,45").contains("component 2 of 10, `x`"));
    }

    #[test]
    fn invalid_cameras_are_refused() {
        let bad = [
            ("0,0,0,0,0,0,0,1,0,45", "coincide"),
            ("0,0,0,0,1,0,0,1,0,45", "parallel"),
            ("0,0,0,0,-5,0,0,2,0,45", "parallel"),
            ("0,0,0,0,0,1,0,0,0,45", "zero vector"),
            ("0,0,0,0,0,1,0,1,0,0", "field of view"),
            ("0,0,0,0,0,1,0,1,0,180", "field of view"),
            ("0,0,0,0,0,1,0,1,0,-10", "field of view"),
        ];
        for (s, why) in bad {
            let m = Camera::parse(s).unwrap_err().to_string();
            assert!(m.contains(why), "{s}: {m}");
        }
        let mut cam = Camera::parse("0,0,0,0,0,1,0,1,0,45").unwrap();
        cam.eye.x = f32::NAN;
        assert!(cam.validate().unwrap_err().to_string().contains("finite"));
        // up nearly (but not quite) parallel is fine
        assert!(Camera::parse("0,0,0,0,0,1,0.001,0,1,45").is_ok());
    }

    #[test]
    fn view_parse_errors_name_line_and_keyword() {
        let e = View::parse("camera 0,0,1,0,0,0,0,1,0,45\ncamera 0,0,1,0,0,0,0,1,0,45\n")
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("<memory>:2:") && e.contains("second `camera`"),
            "{e}"
        );
        let e = View::parse("# c\nlight 1,2\n").unwrap_err().to_string();
        assert!(e.starts_with("<memory>:2:") && e.contains("`1,2`"), "{e}");
        let e = View::parse("camera\n").unwrap_err().to_string();
        assert!(e.contains("<memory>:1:"), "{e}");
        let e = View::parse("Camera 0,0,1,0,0,0,0,1,0,45")
            .unwrap_err()
            .to_string();
        assert!(e.contains("unknown keyword `Camera`"), "{e}");
        assert_eq!(
            View::parse("\n  # only comments\n\n").unwrap(),
            View::default()
        );
    }

    #[test]
    fn load_view_names_the_file() {
        let scratch = Scratch::new("names-the-file");
        let dir = &scratch.0;
        let obj = dir.join("scene.obj");
        std::fs::write(dir.join("scene.view"), "light 1,2,3\nbogus\n").unwrap();
        let e = load_view(&obj).unwrap_err().to_string();
        assert!(e.contains("scene.view:2:") && e.contains("bogus"), "{e}");
        std::fs::write(dir.join("scene.view"), "light 1,2,3\n").unwrap();
        assert_eq!(
            load_view(&obj).unwrap().light,
            Some(Vec3::new(1.0, 2.0, 3.0))
        );
    }

    /// Every view file of the shared scenes (and the crate's own data)
    /// parses, with the values they list. With `PACKTRACE_SCENES` set,
    /// the shared files are read and must equal the copies below (a
    /// missing or different file fails: a set variable names the files
    /// the test needs); unset, the copies are parsed.
    #[test]
    fn shared_view_files_parse() {
        let files = [
            (
                "bunny.view",
                "camera -0.0168,0.125,0.26,-0.0168,0.11,-0.0015,0,1,0,45\n",
            ),
            (
                "cornell_box.view",
                "camera 0,1,3.9,0,1,0,0,1,0,39.3\nlight -0.005,1.97,-0.03\n",
            ),
            ("sponza.view", "camera -14,2.5,0,10,4.5,0,0,1,0,60\n"),
            ("teapot.view", "camera 2.8,4.0,6.8,0.217,1.4,0,0,1,0,40\n"),
        ];
        let shared = std::env::var_os("PACKTRACE_SCENES").map(std::path::PathBuf::from);
        for (name, copy) in files {
            let v = View::parse(copy).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert!(v.camera.is_some(), "{name}");
            if let Some(dir) = &shared {
                let path = dir.join(name);
                let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
                    panic!(
                        "PACKTRACE_SCENES={} but {} cannot be read: {e}",
                        dir.display(),
                        path.display()
                    )
                });
                let got = View::parse(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
                assert_eq!(got, v, "{}: differs from the copy here", path.display());
            }
        }
        let v = View::parse(files[1].1).unwrap();
        assert_eq!(v.light, Some(Vec3::new(-0.005, 1.97, -0.03)));
        assert_eq!(v.camera.unwrap().fov_deg, 39.3);
        let v = View::parse(files[0].1).unwrap();
        assert_eq!(v.camera.unwrap().target, Vec3::new(-0.0168, 0.11, -0.0015));
        let own = concat!(env!("CARGO_MANIFEST_DIR"), "/data/cornell.view");
        let v = View::parse(&std::fs::read_to_string(own).unwrap()).unwrap();
        assert!(v.camera.is_some() && v.light.is_some());
    }
}
