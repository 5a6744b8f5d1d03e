//! Piecewise-constant 1-D and 2-D distributions sampled by inverting their CDF (pbrt-v4 `PiecewiseConstant1D`
//! and `PiecewiseConstant2D`, `util/sampling.h`): light selection ∝ power, triangle selection ∝ area, and
//! environment-map importance sampling (marginal over rows, conditional per row).
//!
//! The CDF is accumulated and stored in `f64`. Every probability the module reports (`pmf`, `pdf`, and the
//! values returned with a sample) is read off that same CDF, so the reported density is the density of the
//! sampling routine. A zero-weight bin has `cdf[i + 1] == cdf[i]` exactly and can never be sampled.

use crate::math::{next_float_down, next_float_up, Vec2};

/// Largest `f32` below 1.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// `u` clamped into `[0, 1)`; NaN maps to 0.
#[inline]
fn clamp_unit(u: f32) -> f32 {
    if u >= 0.0 {
        u.min(ONE_MINUS_EPSILON)
    } else {
        0.0
    }
}

/// CDFs of at most this many entries (16 bins) are inverted by counting instead of binary search.
const SMALL_CDF: usize = 17;

/// A piecewise-constant distribution over `n` bins (discrete) or over `[0, 1)` split into `n` equal cells
/// (continuous).
#[derive(Clone, Debug)]
pub struct Distribution1D {
    /// Normalised CDF: `n + 1` entries, `cdf[0] = 0`, `cdf[n] = 1`, non-decreasing.
    cdf: Vec<f64>,
    /// Sum of the weights.
    sum: f64,
}

impl Distribution1D {
    /// Bytes of its table.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        (self.cdf.len() * size_of::<f64>()) as u64
    }

    /// Builds the distribution of `weights`. `None` if there are no weights, any weight is negative or not
    /// finite, or they are all zero.
    #[must_use]
    pub fn new(weights: &[f32]) -> Option<Self> {
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        Self::from_f64(weights.iter().map(|&w| f64::from(w)))
    }

    /// Builds from non-negative finite `f64` weights (checked by the callers).
    fn from_f64(weights: impl ExactSizeIterator<Item = f64>) -> Option<Self> {
        let mut cdf = Vec::with_capacity(weights.len() + 1);
        cdf.push(0.0);
        let mut acc = 0.0f64;
        for w in weights {
            debug_assert!(w.is_finite() && w >= 0.0);
            acc += w;
            cdf.push(acc);
        }
        if cdf.len() < 2 || !(acc > 0.0 && acc.is_finite()) {
            return None;
        }
        // Correctly rounded division is monotone: equal entries (zero-weight bins) stay equal, and
        // cdf[n] = acc/acc = 1 exactly.
        for c in &mut cdf {
            *c /= acc;
        }
        Some(Self { cdf, sum: acc })
    }

    /// Number of bins.
    #[must_use]
    pub fn len(&self) -> usize {
        self.cdf.len() - 1
    }

    /// Always `false`: [`Distribution1D::new`] refuses empty weights.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Sum of the weights it was built from.
    #[must_use]
    pub fn sum(&self) -> f32 {
        self.sum as f32
    }

    /// Width of bin `i` in the CDF as `f32`; never rounds a sampleable bin down to zero.
    #[inline]
    fn width(&self, i: usize) -> f32 {
        let w = self.cdf[i + 1] - self.cdf[i];
        let w32 = w as f32;
        if w32 == 0.0 && w > 0.0 {
            f32::MIN_POSITIVE
        } else {
            w32
        }
    }

    /// Probability of bin `i` (0 outside `0..len()`).
    #[must_use]
    pub fn pmf(&self, i: usize) -> f32 {
        if i < self.len() {
            self.width(i)
        } else {
            0.0
        }
    }

    /// Chooses a bin: returns `(i, pmf(i), u_remapped)` where `u_remapped ∈ [0, 1)` is `u`'s position inside
    /// bin `i`'s CDF interval, uniform and independent of the choice (so it can be reused as a fresh sample).
    /// Never returns a bin of zero weight.
    #[must_use]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        if self.cdf.len() == 2 {
            // One bin (one light, a one-triangle light): cdf = [0, 1], so the search below would give
            // bin 0 and u itself (exact in f64); the same result without the search and the division.
            return (0, self.width(0), clamp_unit(u));
        }
        let (i, du) = self.invert(u);
        (i, self.width(i), (du as f32).min(ONE_MINUS_EPSILON))
    }

    /// Bin `i` with `cdf[i] ≤ u < cdf[i+1]` and the position of `u` in it, in `f64`.
    #[inline]
    fn invert(&self, u: f32) -> (usize, f64) {
        let u = f64::from(clamp_unit(u));
        // cdf[0] = 0 ≤ u and cdf[n] = 1 > u, so the partition point is in 1..=n. The CDF is monotone, so the
        // partition point is the number of entries ≤ u: for a few bins (a light's triangles) counted without
        // branches, since a binary search's branches on a random u are mispredicted half the time.
        let i = if self.cdf.len() == 3 {
            // Two bins (a rectangle's two triangles): cdf[0] = 0 ≤ u < 1 = cdf[2], so the count is 1 + (cdf[1] ≤ u).
            usize::from(self.cdf[1] <= u)
        } else if self.cdf.len() <= SMALL_CDF {
            self.cdf.iter().map(|&c| usize::from(c <= u)).sum::<usize>() - 1
        } else {
            self.cdf.partition_point(|&c| c <= u) - 1
        };
        let (c0, c1) = (self.cdf[i], self.cdf[i + 1]);
        debug_assert!(c0 <= u && u < c1);
        (i, ((u - c0) / (c1 - c0)).min(1.0))
    }

    /// Cell of `x ∈ [0, 1]` (the last cell includes 1). `x·n` is exact in `f64` for `n < 2²⁹`.
    #[inline]
    fn cell_of(&self, x: f32) -> usize {
        ((f64::from(x) * self.len() as f64) as usize).min(self.len() - 1)
    }

    /// Samples `x ∈ [0, 1)` with density `pdf(x)`; returns `(x, pdf(x), cell)`. The density is never 0.
    #[must_use]
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let (i, du) = self.invert(u);
        let n = self.len();
        let mut x = ((((i as f64) + du) / n as f64) as f32).min(ONE_MINUS_EPSILON);
        // Rounding to f32 can move x across a cell border; move it back so that pdf(x) is the pdf of cell i.
        // Every cell holds f32 values for n ≤ 2²⁴, so a few steps suffice.
        debug_assert!(n <= 1 << 24, "cells narrower than the f32 spacing near 1");
        for _ in 0..64 {
            match self.cell_of(x).cmp(&i) {
                std::cmp::Ordering::Greater => x = next_float_down(x),
                std::cmp::Ordering::Less => x = next_float_up(x),
                std::cmp::Ordering::Equal => break,
            }
        }
        (x, self.width(i) * n as f32, i)
    }

    /// Density of [`Distribution1D::sample_continuous`] at `x` (0 outside `[0, 1]`).
    #[must_use]
    pub fn pdf(&self, x: f32) -> f32 {
        if !(0.0..=1.0).contains(&x) {
            return 0.0;
        }
        self.width(self.cell_of(x)) * self.len() as f32
    }
}

/// A piecewise-constant distribution over `[0, 1)²` split into `width × height` cells, row-major
/// (`weights[y·width + x]`): a marginal distribution over rows (`uv.y`) and one conditional per row (`uv.x`).
#[derive(Clone, Debug)]
pub struct Distribution2D {
    marginal: Distribution1D,
    /// `None` for rows of zero weight (the marginal never selects them).
    conditional: Vec<Option<Distribution1D>>,
    width: usize,
}

impl Distribution2D {
    /// Bytes of its tables (the marginal and every row's).
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        let rows: u64 = self.conditional.iter().flatten().map(Distribution1D::memory_bytes).sum();
        self.marginal.memory_bytes() + rows + (self.conditional.len() * size_of::<Option<Distribution1D>>()) as u64
    }

    /// `None` if `weights.len() != width·height`, a dimension is 0, any weight is negative or not finite, or
    /// all weights are zero.
    #[must_use]
    pub fn new(weights: &[f32], width: usize, height: usize) -> Option<Self> {
        if width == 0 || height == 0 || width.checked_mul(height) != Some(weights.len()) {
            return None;
        }
        if weights.iter().any(|w| !w.is_finite() || *w < 0.0) {
            return None;
        }
        let rows = weights.chunks_exact(width);
        let row_sums: Vec<f64> = rows.clone().map(|r| r.iter().map(|&w| f64::from(w)).sum()).collect();
        let marginal = Distribution1D::from_f64(row_sums.into_iter())?;
        let conditional = rows.map(Distribution1D::new).collect();
        Some(Self {
            marginal,
            conditional,
            width,
        })
    }

    /// Samples `uv ∈ [0, 1)²` (x = column, y = row); returns `(uv, pdf(uv))` with the density w.r.t. the unit
    /// square, never 0.
    #[must_use]
    pub fn sample_continuous(&self, u: Vec2) -> (Vec2, f32) {
        let (y, pdf_y, row) = self.marginal.sample_continuous(u.y);
        let Some(cond) = &self.conditional[row] else {
            // The marginal gives rows of zero weight a zero-width CDF interval.
            debug_assert!(false, "sampled a row of zero weight");
            return (Vec2::new(0.0, y), 0.0);
        };
        let (x, pdf_x, _) = cond.sample_continuous(u.x);
        (Vec2::new(x, y), pdf_y * pdf_x)
    }

    /// Density of [`Distribution2D::sample_continuous`] at `uv` w.r.t. the unit square (0 outside it).
    #[must_use]
    pub fn pdf(&self, uv: Vec2) -> f32 {
        if !(0.0..=1.0).contains(&uv.y) {
            return 0.0;
        }
        match &self.conditional[self.marginal.cell_of(uv.y)] {
            Some(cond) => self.marginal.pdf(uv.y) * cond.pdf(uv.x),
            None => 0.0,
        }
    }

    /// Number of columns.
    #[must_use]
    pub fn width(&self) -> usize {
        self.width
    }

    /// Number of rows.
    #[must_use]
    pub fn height(&self) -> usize {
        self.marginal.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    #[test]
    fn rejects_bad_weights() {
        assert!(Distribution1D::new(&[]).is_none());
        assert!(Distribution1D::new(&[0.0, 0.0]).is_none());
        assert!(Distribution1D::new(&[1.0, -0.5]).is_none());
        assert!(Distribution1D::new(&[1.0, f32::NAN]).is_none());
        assert!(Distribution1D::new(&[1.0, f32::INFINITY]).is_none());
        assert!(Distribution2D::new(&[1.0, 2.0, 3.0], 2, 2).is_none());
        assert!(Distribution2D::new(&[], 0, 0).is_none());
        assert!(Distribution2D::new(&[0.0; 4], 2, 2).is_none());
        // Row sums overflowing f32 are fine: they are accumulated in f64.
        assert!(Distribution2D::new(&[f32::MAX; 4], 2, 2).is_some());
    }

    #[test]
    fn pmf_sums_to_one_and_matches_the_weights() {
        let w = [0.0, 1.0, 3.0, 0.0, 0.5, 2.0, 0.0, 1e-6];
        let d = Distribution1D::new(&w).unwrap();
        let sum: f32 = w.iter().sum();
        assert!((d.sum() - sum).abs() < 1e-6);
        let total: f64 = (0..d.len()).map(|i| f64::from(d.pmf(i))).sum();
        assert!((total - 1.0).abs() < 1e-6, "{total}");
        for (i, &wi) in w.iter().enumerate() {
            assert!((d.pmf(i) - wi / sum).abs() <= 1e-6 * (wi / sum), "bin {i}");
        }
        assert_eq!(d.pmf(w.len()), 0.0);
    }

    #[test]
    fn discrete_frequencies_match_within_5_sigma_and_zero_bins_are_never_sampled() {
        let w = [0.0, 1.0, 3.0, 0.0, 0.5, 2.0, 0.0, 0.01];
        let d = Distribution1D::new(&w).unwrap();
        let n = 400_000u64;
        let mut counts = [0u64; 8];
        let mut remap_sum = [0.0f64; 8];
        let mut sampler = Sampler::for_key(11, 0, 0);
        for _ in 0..n {
            let (i, pmf, ur) = d.sample_discrete(sampler.next_1d());
            assert!(w[i] > 0.0 && pmf == d.pmf(i) && (0.0..1.0).contains(&ur));
            counts[i] += 1;
            remap_sum[i] += f64::from(ur);
        }
        for i in 0..8 {
            let p = f64::from(d.pmf(i));
            let expected = n as f64 * p;
            let sigma = (n as f64 * p * (1.0 - p)).sqrt();
            assert!(
                (counts[i] as f64 - expected).abs() <= 5.0 * sigma.max(1e-9),
                "bin {i}: {} vs {expected}",
                counts[i]
            );
            if counts[i] > 0 {
                // The remapped u is uniform inside the bin: mean 1/2, sd of the mean sqrt(1/12/count).
                let mean = remap_sum[i] / counts[i] as f64;
                assert!(
                    (mean - 0.5).abs() <= 5.0 * (1.0 / 12.0 / counts[i] as f64).sqrt(),
                    "bin {i}: remap mean {mean}"
                );
            }
        }
    }

    /// The counting inversion of small CDFs finds the bin binary search finds, at every CDF entry, next to
    /// it and in between, with runs of zero bins; it covers the sizes on both sides of [`SMALL_CDF`].
    #[test]
    fn small_cdfs_invert_as_binary_search_does() {
        let mut s = Sampler::for_key(5, 0, 0);
        for n in 1..=SMALL_CDF + 2 {
            let w: Vec<f32> = (0..n).map(|i| if i % 3 == 1 { 0.0 } else { 0.1 + s.next_1d() }).collect();
            let Some(d) = Distribution1D::new(&w) else { continue };
            let mut us: Vec<f32> = d.cdf.iter().flat_map(|&c| {
                let c = c as f32;
                [c, f32::from_bits(c.to_bits().saturating_sub(1)), f32::from_bits(c.to_bits() + 1)]
            }).collect();
            us.extend((0..200).map(|_| s.next_1d()));
            for u in us.into_iter().filter(|u| (0.0..1.0).contains(u)) {
                let x = f64::from(u);
                let want = d.cdf.partition_point(|&c| c <= x) - 1;
                assert_eq!(d.invert(u).0, want, "n {n}, u {u}");
            }
        }
    }

    #[test]
    fn boundaries_of_u_never_select_a_zero_bin() {
        let d = Distribution1D::new(&[1.0, 0.0, 1.0]).unwrap();
        assert_eq!(d.sample_discrete(0.5).0, 2);
        assert_eq!(d.sample_discrete(next_float_down(0.5)).0, 0);
        assert_eq!(d.sample_discrete(0.0).0, 0);
        assert_eq!(d.sample_discrete(1.0).0, 2);
        assert_eq!(d.sample_discrete(f32::NAN).0, 0);
        let d = Distribution1D::new(&[0.0, 0.0, 1.0, 0.0]).unwrap();
        for u in [0.0, 0.3, ONE_MINUS_EPSILON, 1.0, -1.0] {
            let (i, pmf, ur) = d.sample_discrete(u);
            assert_eq!((i, pmf), (2, 1.0));
            assert!((0.0..1.0).contains(&ur));
            let (x, pdf, cell) = d.sample_continuous(u);
            assert_eq!(cell, 2);
            assert!((0.5..0.75).contains(&x) && pdf == 4.0 && d.pdf(x) == 4.0, "u {u}: x {x} pdf {pdf}");
        }
    }

    #[test]
    fn continuous_pdf_is_consistent_positive_and_integrates_to_one() {
        // Many cells with random weights and runs of zeros; u at and next to every CDF boundary.
        let mut s = Sampler::for_key(3, 1, 2);
        let w: Vec<f32> = (0..3001).map(|i| if i % 7 < 3 { 0.0 } else { s.next_1d() * 10.0 }).collect();
        let d = Distribution1D::new(&w).unwrap();
        let mut us: Vec<f32> = d
            .cdf
            .iter()
            .flat_map(|&c| [c as f32, next_float_down(c as f32), next_float_up(c as f32)])
            .collect();
        us.extend((0..20_000).map(|_| s.next_1d()));
        for u in us {
            let (x, pdf, cell) = d.sample_continuous(u);
            assert!((0.0..1.0).contains(&x), "u {u}: x {x}");
            assert!(pdf > 0.0 && w[cell] > 0.0, "u {u}: zero-pdf sample");
            assert_eq!(pdf, d.pdf(x), "u {u}: x {x}");
        }
        // Midpoint rule, 4 points per cell: exact for a piecewise-constant density.
        let k = 4 * d.len();
        let integral: f64 = (0..k).map(|j| f64::from(d.pdf((j as f32 + 0.5) / k as f32))).sum::<f64>() / k as f64;
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        assert_eq!(d.pdf(-0.1), 0.0);
        assert_eq!(d.pdf(1.1), 0.0);
    }

    #[test]
    fn distribution_2d_frequencies_pdf_and_zero_cells() {
        let (width, height) = (5usize, 4usize);
        #[rustfmt::skip]
        let w = [
            1.0, 0.0, 2.0, 0.0, 0.5,
            0.0, 0.0, 0.0, 0.0, 0.0,
            3.0, 1.0, 0.0, 0.0, 0.1,
            0.0, 0.0, 0.0, 4.0, 0.0f32,
        ];
        let d = Distribution2D::new(&w, width, height).unwrap();
        assert_eq!((d.width(), d.height()), (width, height));
        let sum: f32 = w.iter().sum();
        // pdf(uv) = w / sum · (width·height) at every cell centre.
        for y in 0..height {
            for x in 0..width {
                let uv = Vec2::new((x as f32 + 0.5) / width as f32, (y as f32 + 0.5) / height as f32);
                let expected = w[y * width + x] / sum * (width * height) as f32;
                assert!((d.pdf(uv) - expected).abs() <= 1e-5 * expected.max(1.0), "cell ({x},{y})");
            }
        }
        // ∫ pdf = 1 (midpoint rule, 3×3 points per cell: exact).
        let (kx, ky) = (3 * width, 3 * height);
        let mut integral = 0.0f64;
        for j in 0..ky {
            for i in 0..kx {
                integral += f64::from(d.pdf(Vec2::new((i as f32 + 0.5) / kx as f32, (j as f32 + 0.5) / ky as f32)));
            }
        }
        integral /= (kx * ky) as f64;
        assert!((integral - 1.0).abs() < 1e-5, "{integral}");
        // Sampling frequencies per cell within 5σ; never a zero cell; returned pdf == pdf().
        let n = 300_000u64;
        let mut counts = vec![0u64; width * height];
        let mut sampler = Sampler::for_key(5, 0, 0);
        for _ in 0..n {
            let (uv, pdf) = d.sample_continuous(sampler.next_2d());
            assert!((0.0..1.0).contains(&uv.x) && (0.0..1.0).contains(&uv.y));
            assert!(pdf > 0.0);
            assert_eq!(pdf, d.pdf(uv));
            let cell = (uv.y * height as f32) as usize * width + (uv.x * width as f32) as usize;
            assert!(w[cell] > 0.0, "zero cell {cell} sampled");
            counts[cell] += 1;
        }
        for (cell, &c) in counts.iter().enumerate() {
            let p = f64::from(w[cell] / sum);
            let sigma = (n as f64 * p * (1.0 - p)).sqrt();
            assert!(
                (c as f64 - n as f64 * p).abs() <= 5.0 * sigma.max(1e-9),
                "cell {cell}: {c} vs {}",
                n as f64 * p
            );
        }
    }
}
