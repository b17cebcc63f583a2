//! Hand-written bindings for the dozen calls of Embree 3's C API
//! (`embree3/rtcore*.h`, 3.13) the bench needs, and safe wrappers: a
//! device, a committed triangle scene, and `rtcIntersect1/4/8`,
//! `rtcOccluded1/4/8` on ray records laid out as the headers lay them out
//! (`RTCRayHit`, `RTCRayHit4`, `RTCRayHit8`; sizes asserted below).
//!
//! No existing crate fitted: the published `embree` crates bind Embree 4
//! (whose `rtcIntersect` arguments differ), and bindgen would need
//! libclang at build time for a dozen declarations.

use std::ffi::{CString, c_char, c_int, c_uint, c_void};
use std::sync::atomic::{AtomicIsize, Ordering};

/// `RTCDevice`, `RTCScene`, `RTCGeometry`: opaque handles.
type Handle = *mut c_void;

/// `RTC_INVALID_GEOMETRY_ID`.
pub const INVALID_ID: u32 = u32::MAX;
const GEOMETRY_TYPE_TRIANGLE: c_int = 0;
const BUFFER_TYPE_INDEX: c_int = 0;
const BUFFER_TYPE_VERTEX: c_int = 1;
const FORMAT_UINT3: c_int = 0x5003;
const FORMAT_FLOAT3: c_int = 0x9003;
const DEVICE_PROPERTY_VERSION_MAJOR: c_int = 1;
const DEVICE_PROPERTY_VERSION_MINOR: c_int = 2;
const DEVICE_PROPERTY_VERSION_PATCH: c_int = 3;
const DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED: c_int = 33;
/// `RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT` (Embree's default).
pub const FLAG_INCOHERENT: u32 = 0;
/// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`.
pub const FLAG_COHERENT: u32 = 1;

/// `RTCRay`: one ray; `tfar` becomes the hit distance, or `-inf` when
/// `rtcOccluded1` finds it occluded.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct Ray1 {
    pub org: [f32; 3],
    pub tnear: f32,
    pub dir: [f32; 3],
    pub time: f32,
    pub tfar: f32,
    pub mask: u32,
    pub id: u32,
    pub flags: u32,
}

/// `RTCHit`: one hit (`geom_id` is [`INVALID_ID`] on a miss).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default)]
pub struct Hit1 {
    pub ng: [f32; 3],
    pub u: f32,
    pub v: f32,
    pub prim_id: u32,
    pub geom_id: u32,
    pub inst_id: [u32; 1],
}

/// `RTCRayHit`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct RayHit1 {
    pub ray: Ray1,
    pub hit: Hit1,
}

/// `RTCRay4` / `RTCRay8` (structure of arrays). Aligned to 32 for both
/// widths: the 4-wide layout (192 bytes) is a multiple of 32, so the
/// over-alignment changes no offset.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct RayN<const N: usize> {
    pub org_x: [f32; N],
    pub org_y: [f32; N],
    pub org_z: [f32; N],
    pub tnear: [f32; N],
    pub dir_x: [f32; N],
    pub dir_y: [f32; N],
    pub dir_z: [f32; N],
    pub time: [f32; N],
    pub tfar: [f32; N],
    pub mask: [u32; N],
    pub id: [u32; N],
    pub flags: [u32; N],
}

/// `RTCHit4` / `RTCHit8`.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug)]
pub struct HitN<const N: usize> {
    pub ng_x: [f32; N],
    pub ng_y: [f32; N],
    pub ng_z: [f32; N],
    pub u: [f32; N],
    pub v: [f32; N],
    pub prim_id: [u32; N],
    pub geom_id: [u32; N],
    pub inst_id: [[u32; N]; 1],
}

/// `RTCRayHit4` / `RTCRayHit8`.
#[repr(C)]
#[derive(Clone, Copy, Debug)]
pub struct RayHitN<const N: usize> {
    pub ray: RayN<N>,
    pub hit: HitN<N>,
}

// The headers' sizes (RTC_MAX_INSTANCE_LEVEL_COUNT = 1, no RTC_MIN_WIDTH).
const _: () = assert!(size_of::<Ray1>() == 48 && size_of::<Hit1>() == 32);
const _: () = assert!(size_of::<RayHit1>() == 80);
const _: () = assert!(size_of::<RayN<4>>() == 192 && size_of::<HitN<4>>() == 128);
const _: () = assert!(size_of::<RayHitN<4>>() == 320 && size_of::<RayHitN<8>>() == 640);
const _: () = assert!(size_of::<RayN<8>>() == 384 && size_of::<HitN<8>>() == 256);
const _: () = assert!(size_of::<Context>() == 24);

/// `RTCIntersectContext` as `rtcInitIntersectContext` fills it.
#[repr(C)]
pub struct Context {
    flags: u32,
    filter: *const c_void,
    inst_id: [u32; 1],
}

impl Context {
    /// A context with `flags` ([`FLAG_INCOHERENT`] or [`FLAG_COHERENT`]),
    /// no filter, no instance.
    pub fn new(flags: u32) -> Context {
        Context {
            flags,
            filter: std::ptr::null(),
            inst_id: [INVALID_ID],
        }
    }
}

/// `RTCMemoryMonitorFunction`.
type MemoryMonitor = extern "C" fn(user: *mut c_void, bytes: isize, post: bool) -> bool;

#[link(name = "embree3")]
unsafe extern "C" {
    fn rtcNewDevice(config: *const c_char) -> Handle;
    fn rtcReleaseDevice(device: Handle);
    fn rtcGetDeviceError(device: Handle) -> c_int;
    fn rtcGetDeviceProperty(device: Handle, prop: c_int) -> isize;
    fn rtcSetDeviceMemoryMonitorFunction(device: Handle, f: MemoryMonitor, user: *mut c_void);
    fn rtcNewScene(device: Handle) -> Handle;
    fn rtcReleaseScene(scene: Handle);
    fn rtcCommitScene(scene: Handle);
    fn rtcAttachGeometry(scene: Handle, geometry: Handle) -> c_uint;
    fn rtcNewGeometry(device: Handle, kind: c_int) -> Handle;
    fn rtcReleaseGeometry(geometry: Handle);
    fn rtcCommitGeometry(geometry: Handle);
    fn rtcSetNewGeometryBuffer(
        geometry: Handle,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        stride: usize,
        count: usize,
    ) -> *mut c_void;
    fn rtcIntersect1(scene: Handle, context: *mut Context, rayhit: *mut RayHit1);
    fn rtcOccluded1(scene: Handle, context: *mut Context, ray: *mut Ray1);
    fn rtcIntersect4(valid: *const i32, scene: Handle, context: *mut Context, rh: *mut c_void);
    fn rtcOccluded4(valid: *const i32, scene: Handle, context: *mut Context, ray: *mut c_void);
    fn rtcIntersect8(valid: *const i32, scene: Handle, context: *mut Context, rh: *mut c_void);
    fn rtcOccluded8(valid: *const i32, scene: Handle, context: *mut Context, ray: *mut c_void);
}

/// Counts the bytes Embree allocates (its memory monitor callback).
extern "C" fn count_bytes(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user` is the `AtomicIsize` inside the `Box` the `Device`
    // owns; Embree calls this only while the device lives.
    let total = unsafe { &*(user as *const AtomicIsize) };
    total.fetch_add(bytes, Ordering::Relaxed);
    true
}

/// An Embree device.
pub struct Device {
    handle: Handle,
    /// Bytes allocated so far (the memory monitor's running total); boxed
    /// so that its address stays put for the callback.
    allocated: Box<AtomicIsize>,
}

impl Device {
    /// A device with Embree's `threads=N` (its build uses that many).
    ///
    /// # Errors
    /// When Embree refuses the device (e.g. a CPU below SSE2).
    pub fn new(threads: usize) -> Result<Device, String> {
        let config = CString::new(format!("threads={threads}")).expect("no NUL");
        // SAFETY: a NUL-terminated config string that outlives the call.
        let handle = unsafe { rtcNewDevice(config.as_ptr()) };
        if handle.is_null() {
            return Err("rtcNewDevice failed".into());
        }
        let device = Device {
            handle,
            allocated: Box::new(AtomicIsize::new(0)),
        };
        let user = &*device.allocated as *const AtomicIsize as *mut c_void;
        // SAFETY: a live device; `user` points into a Box freed only after
        // the device is released (`Drop`).
        unsafe { rtcSetDeviceMemoryMonitorFunction(device.handle, count_bytes, user) };
        device.check("rtcSetDeviceMemoryMonitorFunction")?;
        Ok(device)
    }

    /// Embree's error code after `what`, as an error.
    fn check(&self, what: &str) -> Result<(), String> {
        // SAFETY: a live device.
        match unsafe { rtcGetDeviceError(self.handle) } {
            0 => Ok(()),
            code => Err(format!("Embree error {code} in {what}")),
        }
    }

    /// `major.minor.patch`.
    pub fn version(&self) -> String {
        // SAFETY: a live device; reading properties has no precondition.
        let p = |k| unsafe { rtcGetDeviceProperty(self.handle, k) };
        format!(
            "{}.{}.{}",
            p(DEVICE_PROPERTY_VERSION_MAJOR),
            p(DEVICE_PROPERTY_VERSION_MINOR),
            p(DEVICE_PROPERTY_VERSION_PATCH)
        )
    }

    /// Does this Embree build trace 8-wide packets natively (AVX)?
    pub fn native_ray8(&self) -> bool {
        // SAFETY: as in `version`.
        unsafe { rtcGetDeviceProperty(self.handle, DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0 }
    }

    /// Bytes Embree holds now.
    pub fn allocated(&self) -> usize {
        self.allocated.load(Ordering::Relaxed).max(0) as usize
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the device's last reference here (a `Scene` owns its
        // device and releases itself first).
        unsafe { rtcReleaseDevice(self.handle) };
    }
}

/// A scene of one triangle geometry (id 0), built with Embree's default
/// build quality (medium), and the device it lives on.
pub struct Scene {
    handle: Handle,
    // Dropped after `Drop::drop` has released the scene.
    device: Device,
}

// SAFETY: a committed Embree scene is immutable, and Embree documents
// rtcIntersect*/rtcOccluded* as callable from any number of threads at
// once on it.
unsafe impl Send for Scene {}
// SAFETY: as above.
unsafe impl Sync for Scene {}

impl Scene {
    /// Copy `positions` and `triangles` (vertex indices into `positions`,
    /// checked by the caller's `Mesh`) into Embree buffers and attach them
    /// as one triangle geometry. Not committed yet: see [`Scene::commit`].
    ///
    /// # Errors
    /// When Embree reports an error (out of memory).
    pub fn new(
        device: Device,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
    ) -> Result<Scene, String> {
        // SAFETY: a live device; the handles are released on every path.
        unsafe {
            let handle = rtcNewScene(device.handle);
            if handle.is_null() {
                return Err("rtcNewScene failed".into());
            }
            let scene = Scene { handle, device };
            let device = &scene.device;
            let geometry = rtcNewGeometry(device.handle, GEOMETRY_TYPE_TRIANGLE);
            device.check("rtcNewGeometry")?;
            // Embree's vertex buffer is read 16 bytes at a time: its
            // buffers are padded for that, the copies below write only
            // `count * stride` bytes.
            let vertices = rtcSetNewGeometryBuffer(
                geometry,
                BUFFER_TYPE_VERTEX,
                0,
                FORMAT_FLOAT3,
                12,
                positions.len(),
            ) as *mut [f32; 3];
            let indices = rtcSetNewGeometryBuffer(
                geometry,
                BUFFER_TYPE_INDEX,
                0,
                FORMAT_UINT3,
                12,
                triangles.len(),
            ) as *mut [u32; 3];
            if let Err(e) = device.check("rtcSetNewGeometryBuffer") {
                rtcReleaseGeometry(geometry);
                return Err(e);
            }
            // Embree returned buffers of `len` items of 12 bytes each.
            std::ptr::copy_nonoverlapping(positions.as_ptr(), vertices, positions.len());
            std::ptr::copy_nonoverlapping(triangles.as_ptr(), indices, triangles.len());
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(scene.handle, geometry);
            rtcReleaseGeometry(geometry);
            device.check("rtcAttachGeometry")?;
            Ok(scene)
        }
    }

    /// Build the BVH (`rtcCommitScene`) with flush-to-zero and
    /// denormals-are-zero on, as Embree asks.
    ///
    /// # Errors
    /// When Embree reports an error.
    pub fn commit(&self) -> Result<(), String> {
        let _ftz = FlushToZero::on();
        // SAFETY: a live scene, committed once, from this thread.
        unsafe { rtcCommitScene(self.handle) };
        self.device.check("rtcCommitScene")
    }

    /// The device.
    pub fn device(&self) -> &Device {
        &self.device
    }

    /// `rtcIntersect1`: the closest hit of one ray.
    #[inline]
    pub fn intersect1(&self, context: &mut Context, ray: &mut RayHit1) {
        // SAFETY: a committed scene, a valid context, an aligned record
        // Embree may write.
        unsafe { rtcIntersect1(self.handle, context, ray) };
    }

    /// `rtcOccluded1`: is one ray occluded (`tfar` set to `-inf`)?
    #[inline]
    pub fn occluded1(&self, context: &mut Context, ray: &mut Ray1) {
        // SAFETY: as in `intersect1`.
        unsafe { rtcOccluded1(self.handle, context, ray) };
    }

    /// `rtcIntersect4` or `rtcIntersect8` on one packet, lanes enabled by
    /// `valid` (-1 on, 0 off).
    ///
    /// # Panics
    /// For a width other than 4 or 8.
    #[inline]
    pub fn intersect_n<const N: usize>(
        &self,
        context: &mut Context,
        valid: &[i32; N],
        packet: &mut RayHitN<N>,
    ) {
        let call = match N {
            4 => rtcIntersect4,
            8 => rtcIntersect8,
            _ => panic!("Embree packets are 4 or 8 wide here"),
        };
        let packet = (packet as *mut RayHitN<N>).cast();
        // SAFETY: `call` takes packets of width N (matched above); the
        // mask and the packet are aligned records of that width.
        unsafe { call(valid.as_ptr(), self.handle, context, packet) };
    }

    /// `rtcOccluded4` or `rtcOccluded8` on one packet.
    ///
    /// # Panics
    /// As [`Scene::intersect_n`].
    #[inline]
    pub fn occluded_n<const N: usize>(
        &self,
        context: &mut Context,
        valid: &[i32; N],
        packet: &mut RayN<N>,
    ) {
        let call = match N {
            4 => rtcOccluded4,
            8 => rtcOccluded8,
            _ => panic!("Embree packets are 4 or 8 wide here"),
        };
        let packet = (packet as *mut RayN<N>).cast();
        // SAFETY: as in `intersect_n`.
        unsafe { call(valid.as_ptr(), self.handle, context, packet) };
    }
}

impl Drop for Scene {
    fn drop(&mut self) {
        // SAFETY: the scene's only reference.
        unsafe { rtcReleaseScene(self.handle) };
    }
}

/// Flush-to-zero and denormals-are-zero on this thread (MXCSR) until
/// dropped, as Embree asks of every thread that builds or traces: its
/// kernels assume denormals never reach them.
pub struct FlushToZero {
    #[cfg(target_arch = "x86_64")]
    saved: u32,
}

impl FlushToZero {
    /// Switch both on; the old state comes back on drop.
    #[allow(deprecated)] // _mm_getcsr/_mm_setcsr: no stable replacement
    pub fn on() -> FlushToZero {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
            // FTZ (bit 15) and DAZ (bit 6).
            const FTZ_DAZ: u32 = 0x8040;
            // SAFETY: SSE is part of x86_64; only the FTZ and DAZ bits of
            // this thread's MXCSR change.
            let saved = unsafe { _mm_getcsr() };
            // SAFETY: as above.
            unsafe { _mm_setcsr(saved | FTZ_DAZ) };
            FlushToZero { saved }
        }
        #[cfg(not(target_arch = "x86_64"))]
        FlushToZero {}
    }
}

impl Drop for FlushToZero {
    #[allow(deprecated)]
    fn drop(&mut self) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: restores this thread's MXCSR as it was.
        unsafe {
            std::arch::x86_64::_mm_setcsr(self.saved)
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flush_to_zero_comes_and_goes() {
        let tiny = std::hint::black_box(f32::MIN_POSITIVE);
        assert!((tiny / 4.0) > 0.0, "denormal without FTZ");
        {
            let _g = FlushToZero::on();
            assert_eq!(std::hint::black_box(tiny) / 4.0, 0.0, "flushed");
        }
        assert!((std::hint::black_box(tiny) / 4.0) > 0.0, "restored");
    }

    #[test]
    fn one_triangle_hit_and_missed_in_every_width() {
        let scene = Scene::new(
            Device::new(1).unwrap(),
            &[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            &[[0, 1, 2]],
        )
        .unwrap();
        scene.commit().unwrap();
        assert!(scene.device().allocated() > 0);
        let ray = |x: f32| Ray1 {
            org: [x, 0.25, 1.0],
            dir: [0.0, 0.0, -1.0],
            tfar: f32::INFINITY,
            mask: u32::MAX,
            ..Default::default()
        };
        let mut ctx = Context::new(FLAG_INCOHERENT);
        let miss = Hit1 {
            geom_id: INVALID_ID,
            ..Default::default()
        };
        let mut rh = [
            RayHit1 {
                ray: ray(0.25),
                hit: miss,
            },
            RayHit1 {
                ray: ray(2.0),
                hit: miss,
            },
        ];
        for r in &mut rh {
            scene.intersect1(&mut ctx, r);
        }
        assert_eq!((rh[0].hit.geom_id, rh[0].hit.prim_id), (0, 0));
        // Not exactly 1: Embree divides by a refined reciprocal whose last
        // bit depends on the kernel its dispatch picked (1.0 with AVX-512
        // on Zen 4, 0.99999994 with AVX2 on Zen 3).
        let t = rh[0].ray.tfar;
        assert!((t - 1.0).abs() <= 4.0 * f32::EPSILON, "t = {t}");
        assert_eq!(rh[1].hit.geom_id, INVALID_ID);
        let mut occ = [ray(0.25), ray(2.0)];
        for r in &mut occ {
            scene.occluded1(&mut ctx, r);
        }
        assert_eq!(occ[0].tfar, f32::NEG_INFINITY);
        assert_eq!(occ[1].tfar, f32::INFINITY);
        let mut p = RayN::<4> {
            org_x: [0.25, 2.0, 0.25, 0.25],
            org_y: [0.25; 4],
            org_z: [1.0; 4],
            tnear: [0.0; 4],
            dir_x: [0.0; 4],
            dir_y: [0.0; 4],
            dir_z: [-1.0; 4],
            time: [0.0; 4],
            tfar: [f32::INFINITY; 4],
            mask: [u32::MAX; 4],
            id: [0; 4],
            flags: [0; 4],
        };
        // Lane 3 inactive: untouched.
        scene.occluded_n(&mut ctx, &[-1, -1, -1, 0], &mut p);
        assert_eq!(
            p.tfar,
            [
                f32::NEG_INFINITY,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::INFINITY
            ]
        );
    }
}
