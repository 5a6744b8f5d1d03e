//! Small statistics shared by the light tests: a running mean with its standard error, and a chi² test whose
//! p-value uses the Wilson–Hilferty normal approximation of the chi² distribution (accurate to ~1e-3 in
//! the tail for ≥ 30 degrees of freedom, which is all these tests use). The lead may port these to the
//! project's shared chi² harness.

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
