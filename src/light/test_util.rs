//! What the light tests share: a running mean with its standard error, a chi² test whose p-value uses the
//! Wilson–Hilferty normal approximation of the chi² distribution (accurate to ~1e-3 in the tail for ≥ 30
//! degrees of freedom, which is all these tests use), the checkerboard the textured delta lights project,
//! and the check that a delta light's photons carry through a patch what NEE sees there.

use super::{luminance, PointLight};
use crate::math::{Frame, Mat3, Vec2, Vec3};
use crate::sampler::Sampler;
use crate::texture::{Checkerboard, Texture};

/// A checkerboard of 3 × 2 repeats, one colour brighter than 1 in blue: what the textured delta lights'
/// tests project (projector, textured spot).
pub(super) fn checker() -> Texture {
    Texture::Checkerboard(Checkerboard { color0: Vec3::new(1.0, 0.5, 0.2), color1: Vec3::new(0.1, 0.3, 2.0), to_uv: Mat3::from_scale(Vec2::new(3.0, 2.0)) })
}

/// The power `light`'s photons carry through a patch equals the irradiance NEE sees integrated over it
/// (the two sides of a caustic estimate must agree): photon starts, aimed at a sphere around the patch and
/// unaimed, against a 400² midpoint quadrature of `li·|cos|` from `sample_li`. The patch is the
/// 1.2 × 0.8 rectangle centred on `c` in the plane of normal `n`; the quadrature's cells straddle texture
/// and beam edges, hence 0.5 % slack. `seed` keys the sampler.
pub(super) fn assert_photons_through_patch_match_nee(light: &PointLight, c: Vec3, n: Vec3, seed: u64) {
    let f = Frame::from_normal(n);
    let (hx, hy) = (0.6f32, 0.4f32);
    let mut nee = 0.0f64;
    let m = 400;
    for i in 0..m {
        for j in 0..m {
            let p = c + f.s * hx * (2.0 * (i as f32 + 0.5) / m as f32 - 1.0) + f.t * hy * (2.0 * (j as f32 + 0.5) / m as f32 - 1.0);
            if let Some(ls) = light.sample_li(p) {
                nee += f64::from(luminance(ls.li) * n.dot(ls.wi_world).abs());
            }
        }
    }
    nee *= f64::from(4.0 * hx * hy) / f64::from(m * m);
    assert!(nee > 0.0);
    let through = |o: Vec3, d: Vec3| {
        let t = (c - o).dot(n) / d.dot(n);
        let q = o + t * d - c;
        t > 0.0 && q.dot(f.s).abs() <= hx && q.dot(f.t).abs() <= hy
    };
    let radius = (hx * hx + hy * hy).sqrt();
    for aimed in [true, false] {
        let mut mean = Mean::default();
        let mut s = Sampler::for_key(seed, u64::from(aimed), 0);
        for _ in 0..400_000 {
            let es = if aimed { light.sample_le_toward(s.next_2d(), c, radius) } else { light.sample_le(s.next_2d()) };
            let x = es.filter(|es| through(es.origin, es.dir)).map_or(0.0, |es| {
                f64::from(luminance(es.le)) * f64::from(es.n.dot(es.dir).abs()) / (f64::from(es.pdf_a) * f64::from(es.pdf_w_dir))
            });
            mean.add(x);
        }
        assert_within_5_sigma(if aimed { "aimed photons" } else { "unaimed photons" }, &mean, nee, 5e-3 * nee);
    }
}

/// Running mean of i.i.d. samples and the standard error of that mean.
#[derive(Default)]
pub(super) struct Mean {
    n: u64,
    sum: f64,
    sum2: f64,
}

impl Mean {
    pub(super) fn add(&mut self, x: f64) {
        self.n += 1;
        self.sum += x;
        self.sum2 += x * x;
    }

    pub(super) fn mean(&self) -> f64 {
        self.sum / self.n as f64
    }

    /// Standard error of the mean, from the sample variance.
    pub(super) fn stderr(&self) -> f64 {
        let n = self.n as f64;
        let var = (self.sum2 / n - self.mean().powi(2)).max(0.0) * n / (n - 1.0);
        (var / n).sqrt()
    }
}

/// Asserts `|estimate − reference| ≤ 5 standard errors + slack`.
pub(super) fn assert_within_5_sigma(what: &str, m: &Mean, reference: f64, slack: f64) {
    let err = (m.mean() - reference).abs();
    println!(
        "{what}: MC {} ± {} vs reference {reference}: {:.2} σ",
        m.mean(),
        m.stderr(),
        err / m.stderr()
    );
    assert!(
        err <= 5.0 * m.stderr() + slack,
        "{what}: MC {} ± {} vs reference {reference} ({:.2} σ)",
        m.mean(),
        m.stderr(),
        err / m.stderr()
    );
}

/// Complementary error function (Numerical Recipes `erfcc`, fractional error < 1.2e-7).
fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07 + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 {
        r
    } else {
        2.0 - r
    }
}

/// Pearson's chi² of `observed` counts against `expected` counts. Cells expected below 5 are pooled into
/// one cell (pbrt-v4's chi² test does the same). Returns `(chi², degrees of freedom, p-value)`; the
/// p-value is `P(X ≥ chi²)` under the Wilson–Hilferty approximation `(X/k)^(1/3) ~ N(1 − 2/(9k), 2/(9k))`.
/// A sample in a cell of zero expectation gives p = 0.
pub(super) fn chi2_test(observed: &[u64], expected: &[f64]) -> (f64, usize, f64) {
    assert_eq!(observed.len(), expected.len());
    let mut chi2 = 0.0;
    let mut cells = 0usize;
    let (mut pooled_o, mut pooled_e) = (0.0f64, 0.0f64);
    for (&o, &e) in observed.iter().zip(expected) {
        if e == 0.0 {
            if o > 0 {
                return (f64::INFINITY, 0, 0.0);
            }
            continue;
        }
        if e < 5.0 {
            pooled_o += o as f64;
            pooled_e += e;
            continue;
        }
        chi2 += (o as f64 - e).powi(2) / e;
        cells += 1;
    }
    if pooled_e > 0.0 {
        chi2 += (pooled_o - pooled_e).powi(2) / pooled_e;
        cells += 1;
    }
    let k = (cells - 1) as f64;
    let z = ((chi2 / k).cbrt() - (1.0 - 2.0 / (9.0 * k))) / (2.0 / (9.0 * k)).sqrt();
    (chi2, cells - 1, 0.5 * erfc(z / std::f64::consts::SQRT_2))
}

#[test]
fn erfc_and_chi2_sanity() {
    assert!((erfc(0.0) - 1.0).abs() < 1e-7);
    assert!((erfc(1.0) - 0.157_299_207).abs() < 1e-7);
    assert!((erfc(-1.0) - 1.842_700_793).abs() < 1e-7);
    // chi² = k = 100 gives p = Q(50, 50) = 0.481192 (exact, by the incomplete gamma series); a huge chi² gives p ≈ 0.
    let expected = vec![100.0; 101];
    let mut observed = vec![100u64; 101];
    observed[0] = 200; // chi² = 100 (+ the pair below keeps the total honest)
    let (chi2, dof, p) = chi2_test(&observed, &expected);
    assert_eq!(dof, 100);
    assert!((chi2 - 100.0).abs() < 1e-9 && (p - 0.481_192).abs() < 1e-3, "{chi2} {p}");
    observed[1] = 400;
    assert!(chi2_test(&observed, &expected).2 < 1e-12);
}
