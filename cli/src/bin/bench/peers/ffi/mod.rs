//! The bench's only `unsafe` code: the calls into the peers' C and C++
//! libraries, each behind a safe function whose arguments make the call
//! sound (every block says why under `// SAFETY:`). `.ci/run` checks that
//! no other file of the cli package has `unsafe`.

#[cfg(feature = "embree")]
pub mod embree;
// tinybvh-rs has BVH8_CPU's traversal only when AVX2 is on at compile time.
#[cfg(all(feature = "tinybvh", target_feature = "avx2"))]
pub mod tinybvh;
