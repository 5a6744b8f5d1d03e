//! Deterministic random streams.
//!
//! Every random number is a pure function of `(seed, stream key, dimension)`: for eye paths the key is
//! `(pixel, sample index)`, for photons `(pass, photon index)`. Images therefore do not depend on the
//! number of threads or on the order in which tiles are rendered.
//!
//! Two kinds of stream:
//! - **Eye samples and photons** ([`Sampler::for_pixel`], [`Sampler::for_photon`]) draw from
//!   Owen-scrambled Sobol points, padded: each call (`next_1d` or `next_2d`) is one *dimension* with its
//!   own 2-D point set over the pixel's samples (over the pass's photons) — the first two Sobol dimensions
//!   (a (0,2)-sequence), its index shuffled and its coordinates scrambled by hashes of `(seed, pixel or
//!   pass, dimension)` (Burley 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4): nested uniform
//!   scrambling in its hash form, §3, and the index shuffle of §4). So the samples of one pixel are
//!   stratified in every dimension (any `2^m` consecutive samples from 0 form a (0,m,2)-net of each
//!   dimension's pair), while each sample on its own is uniform and its dimensions independent: the
//!   estimate keeps its expected value and its error falls faster than with independent numbers where the
//!   integrand is smooth (pixel area, light points, BSDF directions). pbrt-v4's `PaddedSobolSampler` is
//!   the same construction. The scrambles work on reversed bits, so the hot path is written with the
//!   reversals cancelled (`fused_points_equal_the_textbook_composition` checks it bit for bit).
//! - **Keyed streams** ([`Sampler::for_key`]: tests, benchmarks) are a counter-based hash (PCG-style
//!   output permutation over a 64-bit mix of the key): independent numbers, one per dimension.

use crate::math::Vec2;

/// A stream of uniform numbers in `[0, 1)` for one (pixel, sample) or (pass, photon).
#[derive(Clone, Debug)]
pub struct Sampler {
    key: u64,
    dim: u32,
    /// `Some(i.reverse_bits())` for point `i` of the Owen-scrambled Sobol points whose scrambles hash from
    /// `key` (kept reversed, the form the index shuffle takes); `None`: independent hashed numbers.
    sobol_index_reversed: Option<u32>,
}

/// 64-bit finaliser (splitmix64 / Stafford variant 13).
#[inline]
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Laine and Karras's permutation with Burley 2020's constants (§3): adding the seed and xoring with
/// multiples by even constants make bit `j` of the result a function of the seed and of bits `0..=j` of
/// `v` only, flipping bit `j` or not; every step is invertible, so the map is a bijection. Applied to a
/// fraction's bits reversed (bit 31 first becomes bit 0), it is Owen's nested uniform scrambling: each bit
/// of the fraction is flipped by a hash of the seed and of the bits before it.
#[inline]
fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v = v.wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v
}

/// The direction numbers of the Sobol sequence's second dimension (primitive polynomial x + 1):
/// `v₀ = ½`, `vⱼ = vⱼ₋₁ ⊕ (vⱼ₋₁ >> 1)` as 32-bit fractions (Joe & Kuo's m = 1, 3, 5, 15, …).
const fn sobol_dim1_directions() -> [u32; 32] {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut j = 1;
    while j < 32 {
        v[j] = v[j - 1] ^ (v[j - 1] >> 1);
        j += 1;
    }
    v
}

/// The second Sobol dimension of point `i`, `⊕ⱼ bitⱼ(i)·vⱼ`, **bit-reversed** (the form the scramble
/// takes), one byte of `i` per table: entry `[b][n]` is the reversed sum of the directions of the set bits
/// of byte `n` placed at byte `b`.
static SOBOL_DIM1_REVERSED_BYTES: [[u32; 256]; 4] = {
    let v = sobol_dim1_directions();
    let mut t = [[0u32; 256]; 4];
    let mut b = 0;
    while b < 4 {
        let mut n = 0;
        while n < 256 {
            let mut x = 0u32;
            let mut bit = 0;
            while bit < 8 {
                if n & (1 << bit) != 0 {
                    x ^= v[8 * b + bit];
                }
                bit += 1;
            }
            t[b][n] = x.reverse_bits();
            n += 1;
        }
        b += 1;
    }
    t
};

/// `reverse_bits` of the second Sobol dimension of point `i` (the table lookups of
/// [`SOBOL_DIM1_REVERSED_BYTES`]).
#[inline]
fn sobol_dim1_reversed(i: u32) -> u32 {
    let t = &SOBOL_DIM1_REVERSED_BYTES;
    let [b0, b1, b2, b3] = i.to_le_bytes();
    t[0][usize::from(b0)] ^ t[1][usize::from(b1)] ^ t[2][usize::from(b2)] ^ t[3][usize::from(b3)]
}

/// The top 24 bits of a 32-bit fraction as an `f32` in `[0, 1)` (exact, so never rounds up to 1).
#[inline]
fn unit_f32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Multiplier that spreads dimension numbers over the key space.
const DIM_SPREAD: u64 = 0x9e37_79b9_7f4a_7c15;

impl Sampler {
    /// Stream for eye sample `sample` of pixel `pixel` (a linear pixel index over the full film): the
    /// pixel's Owen-scrambled Sobol points (module docs).
    #[must_use]
    pub fn for_pixel(seed: u64, pixel: u64, sample: u64) -> Self {
        Self::sobol(mix64(mix64(seed ^ 0x5eed_0000_0000_0001).wrapping_add(pixel).wrapping_mul(DIM_SPREAD)), sample)
    }

    /// Stream for photon `photon` of photon pass `pass`: the pass's Owen-scrambled Sobol points, so the
    /// photons of a pass are stratified over the lights' points and directions as a pixel's samples are
    /// over the pixel.
    #[must_use]
    pub fn for_photon(seed: u64, pass: u64, photon: u64) -> Self {
        Self::sobol(mix64(mix64(seed ^ 0x9107_0000_0000_0002).wrapping_add(pass).wrapping_mul(0xd1b5_4a32_d192_ed03)), photon)
    }

    /// Point `index` of the Owen-scrambled Sobol points whose scrambles hash from `set` (a pixel, a photon
    /// pass). Indices `2³²` apart share a Sobol index and are told apart by the key.
    fn sobol(set: u64, index: u64) -> Self {
        Self { key: set ^ mix64(index >> 32), dim: 0, sobol_index_reversed: Some((index as u32).reverse_bits()) }
    }

    /// A general stream keyed by any two integers (benchmarks, tests).
    #[must_use]
    pub fn for_key(seed: u64, a: u64, b: u64) -> Self {
        Self { key: mix64(mix64(seed ^ 0x0bad_cafe_0000_0003).wrapping_add(a).wrapping_mul(DIM_SPREAD) ^ mix64(b)), dim: 0, sobol_index_reversed: None }
    }

    /// The hash of the next dimension (and the step to the one after).
    #[inline]
    fn next_hash(&mut self) -> u64 {
        let d = self.dim;
        self.dim = self.dim.wrapping_add(1);
        mix64(self.key ^ u64::from(d).wrapping_mul(DIM_SPREAD))
    }

    /// The shuffled Sobol index of this point in the dimension of hash `h` — the point's index under a
    /// nested uniform scramble (Burley 2020 §4: `owen(i)` = reversed Laine–Karras of the reversed index),
    /// which maps every aligned block of `2^m` indices onto an aligned block, so the first `2^m` samples
    /// are still a (0,m,2)-net — and the seeds of its two coordinates' scrambles.
    #[inline]
    fn shuffled(i_reversed: u32, h: u64) -> (u32, u32, u32) {
        let shuffle_seed = (h.wrapping_mul(DIM_SPREAD) >> 32) as u32;
        (laine_karras(i_reversed, shuffle_seed).reverse_bits(), (h >> 32) as u32, h as u32)
    }

    /// The next dimension as a uniform `u32` (for an eye sample or a photon: the Owen-scrambled first
    /// Sobol coordinate of the shuffled index `s`, `owen(vdc(s)) = reverse(LK(s))` since the van der
    /// Corput fraction of `s` is `s` reversed).
    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let h = self.next_hash();
        match self.sobol_index_reversed {
            None => (h >> 32) as u32,
            Some(i_reversed) => {
                let (s, seed_x, _) = Self::shuffled(i_reversed, h);
                laine_karras(s, seed_x).reverse_bits()
            }
        }
    }

    /// The next dimension, uniform in `[0, 1)` (24 bits, so never rounds up to 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        unit_f32(self.next_u32())
    }

    /// The next dimension as a number independent of every other sample's numbers: for an eye sample or a
    /// photon a hash of the stream's key, the dimension and the point's index, not a stratified coordinate
    /// (otherwise `next_1d`). For a decision whose probability depends on the stream's other samples: the
    /// gather's roulette reads the pixel's earlier samples (method.md §3.1), and a stratified dimension is
    /// anti-correlated across a pixel's samples, so `u < p` need not have probability `p` given them. Such
    /// a number must also be drawn whether it decides anything or not: a draw that depends on other samples
    /// shifts this sample's later dimensions (the cause of a measured +7.5 % on the cornell ceiling).
    #[inline]
    pub fn next_independent_1d(&mut self) -> f32 {
        let Some(i_reversed) = self.sobol_index_reversed else { return self.next_1d() };
        let h = self.next_hash();
        unit_f32((mix64(h ^ u64::from(i_reversed).wrapping_mul(DIM_SPREAD)) >> 32) as u32)
    }

    /// Two uniform numbers in `[0, 1)²`: for an eye sample or a photon one dimension, a 2-D Sobol point
    /// with both coordinates Owen-scrambled; otherwise two independent dimensions.
    #[inline(always)]
    pub fn next_2d(&mut self) -> Vec2 {
        match self.sobol_index_reversed {
            None => {
                let x = self.next_1d();
                Vec2::new(x, self.next_1d())
            }
            Some(i_reversed) => {
                let h = self.next_hash();
                let (s, seed_x, seed_y) = Self::shuffled(i_reversed, h);
                // Both coordinates' bits turned back in one 64-bit reversal: rev₆₄(a·2³² + b) = rev(b)·2³² + rev(a).
                let scrambled = (u64::from(laine_karras(s, seed_x)) << 32 | u64::from(laine_karras(sobol_dim1_reversed(s), seed_y))).reverse_bits();
                Vec2::new(unit_f32(scrambled as u32), unit_f32((scrambled >> 32) as u32))
            }
        }
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

    /// Owen scrambling of a 32-bit fraction, as Burley 2020 writes it: `reverse ∘ LK ∘ reverse`.
    fn owen_scramble(x: u32, seed: u32) -> u32 {
        laine_karras(x.reverse_bits(), seed).reverse_bits()
    }

    /// Sobol point `i` of the first two dimensions, from the direction numbers bit by bit: the van der
    /// Corput radical inverse and `⊕ⱼ bitⱼ(i)·vⱼ`.
    fn sobol_2d(i: u32) -> [u32; 2] {
        let v = sobol_dim1_directions();
        let y = (0..32).filter(|j| i >> j & 1 == 1).fold(0, |y, j| y ^ v[j]);
        [i.reverse_bits(), y]
    }

    /// The sampler's fused form (reversals cancelled, reversed tables) gives bit for bit the textbook
    /// composition: shuffle the index, take the Sobol point, scramble each coordinate.
    #[test]
    fn fused_points_equal_the_textbook_composition() {
        for set in [0u64, 7, 0xdead_beef_0000_0001] {
            for index in (0..300u64).chain([65_535, 65_536, 1 << 24, (1 << 32) - 1, (1 << 32) + 5]) {
                let mut fast = Sampler::sobol(set, index);
                let key = set ^ mix64(index >> 32);
                for d in 0..8u32 {
                    let h = mix64(key ^ u64::from(d).wrapping_mul(DIM_SPREAD));
                    let s = owen_scramble(index as u32, (h.wrapping_mul(DIM_SPREAD) >> 32) as u32);
                    let [x, y] = sobol_2d(s);
                    let (x, y) = (owen_scramble(x, (h >> 32) as u32), owen_scramble(y, h as u32));
                    if d % 2 == 0 {
                        assert_eq!(fast.next_2d(), Vec2::new(unit_f32(x), unit_f32(y)), "set {set} index {index} dim {d}");
                    } else {
                        assert_eq!(fast.next_u32(), x, "set {set} index {index} dim {d}");
                    }
                }
            }
        }
    }

    #[test]
    fn deterministic_and_in_range() {
        for mut a in [Sampler::for_pixel(7, 1234, 5), Sampler::for_photon(7, 1234, 5)] {
            let mut b = a.clone();
            for _ in 0..1000 {
                let x = a.next_1d();
                assert_eq!(x, b.next_1d());
                assert!((0.0..1.0).contains(&x));
                let p = a.next_2d();
                assert_eq!(p, b.next_2d());
                assert!((0.0..1.0).contains(&p.x) && (0.0..1.0).contains(&p.y));
            }
        }
    }

    #[test]
    fn streams_differ_and_are_uniform() {
        // Mean and variance of many streams' first dimension match U(0,1): mean 1/2, var 1/12 — across
        // pixels for eye samples (each pixel has its own scramble), across photons for photon streams.
        let n = 200_000u64;
        for stream in [|i| Sampler::for_pixel(1, i, 0), |i| Sampler::for_photon(1, 0, i)] {
            let (mut s, mut s2) = (0.0f64, 0.0f64);
            for i in 0..n {
                let x = f64::from(stream(i).next_1d());
                s += x;
                s2 += x * x;
            }
            let mean = s / n as f64;
            let var = s2 / n as f64 - mean * mean;
            // 5 sigma bounds: sd of the mean = sqrt(1/12/n) ≈ 6.5e-4.
            assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0 / n as f64).sqrt(), "mean {mean}");
            assert!((var - 1.0 / 12.0).abs() < 2e-3, "var {var}");
        }
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_pixel(1, 0, 1).next_u32());
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_pixel(1, 1, 0).next_u32());
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_pixel(2, 0, 0).next_u32());
        assert_ne!(Sampler::for_pixel(1, 0, 0).next_u32(), Sampler::for_photon(1, 0, 0).next_u32());
        // Samples 2³² apart share the Sobol index but not the numbers.
        assert_ne!(Sampler::for_pixel(1, 0, 3).next_u32(), Sampler::for_pixel(1, 0, 3 + (1 << 32)).next_u32());
    }

    /// The Sobol sequence's second dimension starts 0, ½, ¾, ¼, ⅝, ⅛, ⅜, ⅞ (Joe & Kuo), and the first is
    /// the van der Corput sequence.
    #[test]
    fn sobol_points_are_the_published_ones() {
        let y: Vec<f64> = (0..8).map(|i| f64::from(sobol_2d(i)[1]) / 4_294_967_296.0).collect();
        assert_eq!(y, [0.0, 0.5, 0.75, 0.25, 0.625, 0.125, 0.375, 0.875]);
        let x: Vec<f64> = (0..8).map(|i| f64::from(sobol_2d(i)[0]) / 4_294_967_296.0).collect();
        assert_eq!(x, [0.0, 0.5, 0.25, 0.75, 0.125, 0.625, 0.375, 0.875]);
    }

    /// Owen scrambling permutes the cells of every level: inputs that agree on their first `m` bits give
    /// outputs that agree on their first `m` bits, and the `2^m` cells map one-to-one.
    #[test]
    fn owen_scrambling_is_nested_and_bijective() {
        let mut s = Sampler::for_key(3, 0, 0);
        for _ in 0..20 {
            let seed = s.next_u32();
            for m in [1u32, 4, 10, 16] {
                let mut seen = vec![false; 1 << m];
                for cell in 0..(1u32 << m) {
                    let top = |x: u32| x >> (32 - m);
                    let a = owen_scramble(cell << (32 - m), seed);
                    let b = owen_scramble((cell << (32 - m)) | (s.next_u32() >> m), seed);
                    assert_eq!(top(a), top(b), "m {m}: low bits changed the cell");
                    assert!(!std::mem::replace(&mut seen[top(a) as usize], true), "m {m}: two cells map to one");
                }
            }
        }
    }

    /// The raw 32-bit point of an eye sample's next 2-D dimension (what `next_2d` rounds to f32).
    fn next_2d_bits(s: &mut Sampler) -> [u32; 2] {
        let p = s.next_2d();
        [(p.x * 16_777_216.0) as u32, (p.y * 16_777_216.0) as u32]
    }

    /// Stratification, the point of the scrambled Sobol points: for every dimension of a pixel, the first
    /// `2^m` samples are a (0,m,2)-net — each of the `2^m` cells `2^a × 2^(m−a)` of every shape holds exactly
    /// one point — and their 1-D dimensions hit each of `2^m` intervals once. Independent numbers fail this
    /// almost surely (at m = 4, the chance that 16 uniform points land one per interval is 16!/16¹⁶ ≈ 10⁻⁶).
    #[test]
    fn each_dimension_of_a_pixel_is_stratified() {
        for pixel in [0u64, 1, 977, 1 << 40] {
            for m in [1u32, 2, 4, 6, 8] {
                let n = 1u32 << m;
                // Dimensions alternate 1-D and 2-D as the path tracer draws them.
                let draws: Vec<Vec<[u32; 2]>> = (0..n)
                    .map(|i| {
                        let mut s = Sampler::for_pixel(11, pixel, u64::from(i));
                        (0..6).map(|d| if d % 2 == 0 { next_2d_bits(&mut s) } else { [s.next_u32() >> 8, 0] }).collect()
                    })
                    .collect();
                for d in 0..6 {
                    if d % 2 == 0 {
                        for a in 0..=m {
                            let mut seen = vec![false; n as usize];
                            for p in draws.iter().map(|v| v[d]) {
                                let cell = ((p[0] >> (24 - a)) << (m - a)) | (p[1] >> (24 - (m - a)));
                                assert!(!std::mem::replace(&mut seen[cell as usize], true), "pixel {pixel} dim {d}: two of {n} points in one 2^{a}×2^{} cell", m - a);
                            }
                        }
                    } else {
                        let mut seen = vec![false; n as usize];
                        for p in draws.iter().map(|v| v[d]) {
                            assert!(!std::mem::replace(&mut seen[(p[0] >> (24 - m)) as usize], true), "pixel {pixel} dim {d}: two of {n} in one interval");
                        }
                    }
                }
            }
        }
    }

    /// Padding must not correlate dimensions: over the samples of one pixel, the correlation between the
    /// coordinates of different dimensions is that of independent numbers (|ρ| ≲ 3/√n). Without the index
    /// shuffle, dimensions scrambled from the same Sobol points are visibly tied.
    #[test]
    fn dimensions_of_a_pixel_are_uncorrelated() {
        let n = 4096u64;
        let mut worst = 0.0f64;
        for pixel in 0..4u64 {
            let draws: Vec<[f64; 6]> = (0..n)
                .map(|i| {
                    let mut s = Sampler::for_pixel(5, pixel, i);
                    let (a, b, c) = (s.next_2d(), s.next_1d(), s.next_2d());
                    [a.x, a.y, b, c.x, c.y, s.next_1d()].map(f64::from)
                })
                .collect();
            for i in 0..6 {
                for j in (i + 1)..6 {
                    let (mut sij, mut si, mut sj, mut sii, mut sjj) = (0.0, 0.0, 0.0, 0.0, 0.0);
                    for v in &draws {
                        sij += v[i] * v[j];
                        si += v[i];
                        sj += v[j];
                        sii += v[i] * v[i];
                        sjj += v[j] * v[j];
                    }
                    let nn = n as f64;
                    let cov = sij / nn - si / nn * sj / nn;
                    let rho = cov / ((sii / nn - (si / nn).powi(2)) * (sjj / nn - (sj / nn).powi(2))).sqrt();
                    worst = worst.max(rho.abs());
                }
            }
        }
        // 4.5σ over 60 pairs with σ = 1/√4096.
        assert!(worst < 4.5 / (n as f64).sqrt(), "largest |correlation| {worst}");
    }

    /// A discontinuous integrand (a disk's indicator, the shape of a shadow edge) keeps its mean: over many
    /// pixels, the 16-sample estimates average to π/4 within the noise, and each pixel's estimate is less
    /// noisy than 16 independent numbers would give (the variance of the stratified estimate falls faster).
    #[test]
    fn stratified_estimates_keep_their_mean_and_lose_variance() {
        let (pixels, spp) = (20_000u64, 16u64);
        let f = |p: Vec2| f64::from(u8::from(p.x * p.x + p.y * p.y < 1.0));
        let exact = std::f64::consts::FRAC_PI_4;
        let (mut sum, mut sum2) = (0.0f64, 0.0f64);
        for pixel in 0..pixels {
            let mut e = 0.0;
            for s in 0..spp {
                let mut sampler = Sampler::for_pixel(9, pixel, s);
                sampler.next_1d();
                e += f(sampler.next_2d());
            }
            e /= spp as f64;
            sum += e;
            sum2 += (e - exact) * (e - exact);
        }
        let mean = sum / pixels as f64;
        let var = sum2 / pixels as f64;
        let var_independent = exact * (1.0 - exact) / spp as f64;
        assert!((mean - exact).abs() < 5.0 * (var / pixels as f64).sqrt(), "mean {mean}, exact {exact}");
        assert!(var < 0.5 * var_independent, "variance {var} against {var_independent} for independent numbers");
    }

    /// `next_independent_1d` is uniform (χ² over 64 bins, p > 10⁻⁴) and not stratified across a pixel's
    /// samples: the four samples of a pixel fall in four different quarters of [0, 1) with probability
    /// 4!/4⁴ = 0.094 for independent numbers, and always for the stratified `next_1d` (checked too). It
    /// consumes one dimension, so the dimensions after it are those after a `next_1d`.
    #[test]
    fn independent_numbers_are_uniform_and_unstratified() {
        use crate::sampling::chi2::chi2_p_value;
        let (pixels, spp) = (25_000u64, 4u64);
        let mut bins = [0u64; 64];
        let (mut distinct_independent, mut distinct_stratified) = (0u64, 0u64);
        for pixel in 0..pixels {
            let (mut quarters_i, mut quarters_s) = (0u8, 0u8);
            for s in 0..spp {
                let mut a = Sampler::for_pixel(5, pixel, s);
                let mut b = a.clone();
                a.next_1d();
                let u = a.next_independent_1d();
                assert!((0.0..1.0).contains(&u));
                bins[(u * 64.0) as usize] += 1;
                quarters_i |= 1 << (u * 4.0) as u8;
                b.next_1d();
                quarters_s |= 1 << (b.next_1d() * 4.0) as u8;
                assert_eq!(a.next_2d(), b.next_2d(), "the next dimension is the same after either draw");
            }
            distinct_independent += u64::from(quarters_i == 0b1111);
            distinct_stratified += u64::from(quarters_s == 0b1111);
        }
        let n = (pixels * spp) as f64;
        let chi2: f64 = bins.iter().map(|&o| (o as f64 - n / 64.0).powi(2) / (n / 64.0)).sum();
        assert!(chi2_p_value(chi2, 63) > 1e-4, "chi2 {chi2} over 63 dof");
        assert_eq!(distinct_stratified, pixels, "next_1d stratifies a pixel's four samples");
        let p = distinct_independent as f64 / pixels as f64;
        let expected = 24.0 / 256.0;
        let sigma = (expected * (1.0 - expected) / pixels as f64).sqrt();
        assert!((p - expected).abs() < 5.0 * sigma, "four distinct quarters in {p} of pixels, {expected} expected");
    }
}
