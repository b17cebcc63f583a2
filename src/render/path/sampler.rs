//! Each path's random numbers: one stream per pixel, sample and seed, so
//! a path draws the same numbers whichever thread, tile order, batch or
//! [`Mode`](crate::query::Mode) traces it, and the image is the same bit
//! for bit.
//!
//! The stream is the protocol's PCG hash ([`hash`]) used as PCG's output
//! permutation over a 32-bit LCG state (Jarzynski and Olano, "Hash
//! Functions for GPU Rendering", JCGT 2020): the LCG has full period
//! `2^32`, the permutation decorrelates neighbouring states. The stream
//! starts at a hash of the pixel, the sample and the seed.

use crate::protocol::sampling::{hash, unit};

/// The LCG step of the PCG hash: `state * MUL + INC`.
const MUL: u32 = 747_796_405;
const INC: u32 = 2_891_336_453;

/// The random numbers of one path, in `[0, 1)`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rng {
    state: u32,
}

impl Rng {
    /// The stream of sample `sample` of pixel `pixel` (`y * width + x`)
    /// under `seed`.
    #[inline]
    pub(super) fn new(pixel: u32, sample: u32, seed: u32) -> Rng {
        Rng {
            state: hash(hash(pixel ^ hash(seed)).wrapping_add(sample)),
        }
    }

    /// The next number, `[0, 1)` in steps of `2^-24` ([`unit`]).
    #[inline]
    pub(super) fn next(&mut self) -> f32 {
        let out = hash(self.state);
        self.state = self.state.wrapping_mul(MUL).wrapping_add(INC);
        unit(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Uniform on `[0, 1)`: mean and variance of many draws within a few
    /// standard errors of 1/2 and 1/12, streams of neighbouring pixels,
    /// samples and seeds uncorrelated at lag 0.
    #[test]
    fn streams_are_uniform_and_independent() {
        let (mut sum, mut sum_sq, mut n) = (0.0f64, 0.0f64, 0.0f64);
        let mut cross = 0.0f64;
        for pixel in 0..256 {
            for sample in 0..64 {
                let mut a = Rng::new(pixel, sample, 0);
                let mut b = Rng::new(pixel + 1, sample, 0);
                let mut c = Rng::new(pixel, sample, 1);
                for _ in 0..8 {
                    let (x, y, z) = (a.next() as f64, b.next() as f64, c.next() as f64);
                    assert!((0.0..1.0).contains(&x));
                    sum += x;
                    sum_sq += x * x;
                    cross += (x - 0.5) * (y - 0.5) + (x - 0.5) * (z - 0.5);
                    n += 1.0;
                }
            }
        }
        let mean = sum / n;
        let var = sum_sq / n - mean * mean;
        // Standard errors: sqrt(1/12 / n) for the mean, about 0.3 / sqrt(n)
        // for the variance, 1/12 * sqrt(2 / n) for the summed covariances.
        assert!((mean - 0.5).abs() < 4.0 * (1.0 / 12.0 / n).sqrt(), "{mean}");
        assert!((var - 1.0 / 12.0).abs() < 4.0 * 0.3 / n.sqrt(), "{var}");
        assert!((cross / n).abs() < 4.0 / 12.0 * (2.0 / n).sqrt(), "{cross}");
        // The same key gives the same stream.
        let (mut a, mut b) = (Rng::new(7, 3, 9), Rng::new(7, 3, 9));
        assert!((0..100).all(|_| a.next() == b.next()));
    }
}
