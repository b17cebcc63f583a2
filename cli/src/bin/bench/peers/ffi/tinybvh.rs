//! tinybvh-rs 0.1.0-beta.3's ray, made sound: its binding declares a
//! 64-byte `Ray`, but the tinybvh 1.6.8 it compiles has a 128-byte,
//! 64-aligned `Ray` (the hit record gained an aux pointer and user data),
//! so a Rust `Ray` handed to C++ by reference is too small for what C++
//! may write, and `Ray::new` (returned by value from C++) smashes the
//! stack. The first 64 bytes agree (origin and mask, direction and
//! instance, reciprocal direction, then `inst, t, u, v, prim`), so rays
//! live here in 128-byte, 64-aligned slots that C++ sees whole.

use tinybvh_rs::{Intersector, Ray, bvh8_cpu};

/// A built BVH8_CPU, shared by the bench's threads.
pub struct Bvh8(pub bvh8_cpu::BVH);

// SAFETY: tinybvh's `Intersect` reads the BVH and writes only the ray it
// is given; nothing changes the BVH after its build, so threads may trace
// it at once (cxx marks its opaque C++ types neither Send nor Sync).
unsafe impl Sync for Bvh8 {}
// SAFETY: the BVH owns its memory (BVH8_CPU keeps its own copy of the
// triangles) and has no thread affinity.
unsafe impl Send for Bvh8 {}

/// A C++ `tinybvh::Ray`'s 128 bytes, the binding's 64-byte `Ray` first.
#[repr(C, align(64))]
#[derive(Clone, Copy)]
pub struct Slot {
    /// The part the binding knows.
    pub ray: Ray,
    /// The rest of the C++ ray (aux pointer, user data).
    tail: [u8; 64],
}

const _: () = assert!(size_of::<Slot>() == 128 && align_of::<Slot>() == 64);
const _: () = assert!(size_of::<Ray>() == 64);

impl Slot {
    /// A slot holding `ray`.
    pub fn new(ray: Ray) -> Slot {
        Slot { ray, tail: [0; 64] }
    }
}

impl Bvh8 {
    /// `Intersect` on the whole slot: the closest hit lands in
    /// `slot.ray.hit`.
    #[inline]
    pub fn intersect(&self, slot: &mut Slot) {
        // SAFETY: `Slot` is `repr(C)` with the binding's `Ray` at offset 0
        // and 128 bytes aligned to 64: the size and alignment of the C++
        // `Ray` that `Intersect` reads and writes through this reference,
        // so every byte it may touch belongs to the slot, borrowed mutably
        // here.
        let ray = unsafe { &mut *(slot as *mut Slot).cast::<Ray>() };
        self.0.intersect(ray);
    }
}
