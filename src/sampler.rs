//! Deterministic random streams.
//!
//! Every random number is a pure function of `(seed, stream key, dimension)`: for eye paths the key is
//! `(pixel, sample index)`, for photons `(pass, photon index)`. Images therefore do not depend on the
//! number of threads or on the order in which tiles are rendered.
//!
//! The generator is a counter-based hash (PCG-style output permutation over a 64-bit mix of the key),
//! cheap enough to call once per dimension.

use crate::math::Vec2;

/// A stream of uniform numbers in `[0, 1)` for one (pixel, sample) or (pass, photon).
#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    dim: u32,
}

/// 64-bit finaliser (splitmix64 / Stafford variant 13).
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Sampler {
    /// Stream for eye sample `sample` of pixel `pixel` (a linear pixel index over the full film).
    #[must_use]
    pub fn for_pixel(seed: u64, pixel: u64, sample: u64) -> Self {
        Self { key: mix64(mix64(seed ^ 0x5eed_0000_0000_0001).wrapping_add(pixel).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ mix64(sample.wrapping_add(0x1234_5678))), dim: 0 }
    }

    /// Stream for photon `photon` of photon pass `pass`.
    #[must_use]
    pub fn for_photon(seed: u64, pass: u64, photon: u64) -> Self {
        Self { key: mix64(mix64(seed ^ 0x9107_0000_0000_0002).wrapping_add(pass).wrapping_mul(0xd1b5_4a32_d192_ed03) ^ mix64(photon.wrapping_add(0x8765_4321))), dim: 0 }
    }

    /// A general stream keyed by any two integers (benchmarks, tests).
    #[must_use]
    pub fn for_key(seed: u64, a: u64, b: u64) -> Self {
        Self { key: mix64(mix64(seed ^ 0x0bad_cafe_0000_0003).wrapping_add(a).wrapping_mul(0x9e37_79b9_7f4a_7c15) ^ mix64(b)), dim: 0 }
    }

    /// The next dimension as a uniform `u32`.
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let d = self.dim;
        self.dim = self.dim.wrapping_add(1);
        (mix64(self.key ^ (u64::from(d).wrapping_mul(0x9e37_79b9_7f4a_7c15))) >> 32) as u32
    }

    /// The next dimension, uniform in `[0, 1)` (24 bits, so never rounds up to 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    /// The next two dimensions.
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }

    /// The dimension the next call will use.
    #[must_use]
    pub fn dimension(&self) -> u32 {
        self.dim
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn deterministic_and_in_range() {
        let mut a = Sampler::for_pixel(7, 1234, 5);
        let mut b = Sampler::for_pixel(7, 1234, 5);
        for _ in 0..1000 {
            let x = a.next_1d();
            assert_eq!(x, b.next_1d());
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn streams_differ_and_are_uniform() {
        // Mean and variance of many streams' first dimension match U(0,1): mean 1/2, var 1/12.
        let n = 200_000u64;
        let (mut s, mut s2) = (0.0f64, 0.0f64);
        for i in 0..n {
            let x = f64::from(Sampler::for_pixel(1, i, 0).next_1d());
            s += x;
            s2 += x * x;
        }
        let mean = s / n as f64;
        let var = s2 / n as f64 - mean * mean;
        // 5 sigma bounds: sd of the mean = sqrt(1/12/n) ≈ 6.5e-4.
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt(), "mean {mean}");
        assert!((var - 1.0 / 12.0).abs() < 2e-3, "var {var}");
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_pixel(1, 0, 1).next_u32());
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_photon(1, 0, 0).next_u32());
    }
}
