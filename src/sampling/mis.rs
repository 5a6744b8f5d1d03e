//! THE multiple-importance-sampling weight of the project: Veach's power heuristic with β = 2
//! (Veach 1997, eq. 9.13; the paper's eq. 1), in the overflow-safe ratio form of method.md §4.
//!
//! Every MIS weight in the renderer (NEE vs BSDF sampling, photon density estimation vs BSDF sampling)
//! comes from here, so the two sides of a pair always use the same edge cases and sum to one.

/// Power-heuristic weight of the technique with density `q_this` against one other technique with
/// density `q_other` (both in the same measure, already multiplied by their sample counts):
/// `q_this² / (q_this² + q_other²)`. method.md §4 asks for the ratio form `1 / (1 + (q_other/q_this)²)`
/// because squares of f32 densities spanning many decades (1e-30 … 1e30, subnormals, ∞) overflow or
/// underflow; here the squares are taken in f64, where no finite f32 square does either, which gives
/// the same value with one division (the gather evaluates this for every photon: it is hot).
///
/// Edge cases (method.md §4), in this order of precedence:
/// - `q_other == 0` → 1 (only this technique can produce the sample; also when both are 0),
/// - `q_this == 0` → 0,
/// - both infinite → ½,
/// - a ratio that overflows or underflows → its limit (0 or 1), which the arithmetic gives by itself.
///
/// Densities are non-negative; NaN or negative inputs are a bug upstream (debug assertion). In release
/// builds a NaN input yields a weight in [0, 1] without propagating NaN.
#[must_use]
#[inline]
pub fn power_heuristic(q_this: f32, q_other: f32) -> f32 {
    debug_assert!(
        q_this >= 0.0 && q_other >= 0.0,
        "MIS densities must be non-negative and not NaN: {q_this}, {q_other}"
    );
    // Finite f32 densities squared in f64 can neither overflow (< 1.2e77) nor underflow to 0
    // (> 1e-90), so q_this²/(q_this² + q_other²) is the ratio form's value with one division
    // instead of two. The same arithmetic gives the edge cases' limits where it can (q_this == 0 → 0,
    // q_other == ∞ → 0); the rest are selects below, not branches, so a loop over a batch of photons
    // compiles to vector instructions (`CausticEstimator::gather`).
    let (a, b) = (f64::from(q_this), f64::from(q_other));
    let w = (a * a / (a * a + b * b)) as f32;
    // q_this == ∞: ∞/∞ above; the limit is ½ against ∞ and 1 against anything finite.
    let w = if q_this == f32::INFINITY { if q_other == f32::INFINITY { 0.5 } else { 1.0 } } else { w };
    // q_other == 0 takes precedence over everything (0/0 above when both are 0).
    let w = if q_other == 0.0 { 1.0 } else { w };
    // A NaN input gives NaN: clamp it to a valid weight (release builds).
    if w.is_nan() {
        0.0
    } else {
        w
    }
}

/// The two power-heuristic weights `(w1, w2)` of a pair of techniques from ONE evaluation:
/// `w1 = power_heuristic(q1, q2)`, `w2 = 1 − w1`. In f32 arithmetic `w1 + w2 == 1` exactly for every
/// `w1 ∈ [0, 1]` (for `w1 ≥ ½` the subtraction is exact by Sterbenz' lemma; below ½ the rounding error of
/// `1 − w1` is at most 2⁻²⁵, and the sum rounds back to 1), so nothing is counted twice or lost.
#[must_use]
#[inline]
pub fn mis_weight_pair(q1: f32, q2: f32) -> (f32, f32) {
    let w1 = power_heuristic(q1, q2);
    (w1, 1.0 - w1)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    /// Extreme and ordinary densities, including subnormals, the largest finite value and ∞.
    fn extremes() -> Vec<f32> {
        let mut v = vec![
            0.0,
            f32::from_bits(1),
            1e-44,
            1e-40,
            f32::MIN_POSITIVE,
            1e-30,
            1e-20,
            1e-10,
            1e-3,
            0.5,
            1.0,
            2.0,
            1e3,
            1e10,
            1e19,
            1e20,
            1e30,
            1e38,
            f32::MAX,
            f32::INFINITY,
        ];
        // Neighbours of the values where the ratio² overflows/underflows (ratio ≈ 1.8e19, 1e-19 … 1e-23).
        v.extend([1.8e19f32, 1.9e19, 3.0e-20, 1e-23]);
        v
    }

    fn random_density(s: &mut Sampler) -> f32 {
        // Log-uniform over 1e-40 … 1e38 (subnormals included).
        10f32.powf(-40.0 + 78.0 * s.next_1d())
    }

    #[test]
    fn pair_sums_to_one_exactly_and_never_nan() {
        let ex = extremes();
        let mut pairs: Vec<(f32, f32)> = ex.iter().flat_map(|&a| ex.iter().map(move |&b| (a, b))).collect();
        let mut s = Sampler::for_key(3, 0, 0);
        pairs.extend((0..200_000).map(|_| (random_density(&mut s), random_density(&mut s))));
        for (q1, q2) in pairs {
            let (w1, w2) = mis_weight_pair(q1, q2);
            assert!(!w1.is_nan() && !w2.is_nan(), "{q1} {q2}");
            assert!((0.0..=1.0).contains(&w1) && (0.0..=1.0).contains(&w2), "{q1} {q2}: {w1} {w2}");
            assert_eq!(w1 + w2, 1.0, "{q1} {q2}: {w1} + {w2}");
            // Swapping the roles gives the complementary weight (up to one rounding of 1 − w).
            let (v1, _) = mis_weight_pair(q2, q1);
            if q1 != 0.0 && q2 != 0.0 {
                assert!((v1 - w2).abs() <= 2.0 * f32::EPSILON, "{q1} {q2}: {v1} vs {w2}");
            }
        }
    }

    #[test]
    fn edge_cases() {
        assert_eq!(power_heuristic(0.0, 0.0), 1.0);
        assert_eq!(power_heuristic(1.0, 0.0), 1.0);
        assert_eq!(power_heuristic(f32::INFINITY, 0.0), 1.0);
        assert_eq!(power_heuristic(0.0, 1e-44), 0.0);
        assert_eq!(power_heuristic(0.0, f32::INFINITY), 0.0);
        assert_eq!(power_heuristic(f32::INFINITY, f32::INFINITY), 0.5);
        assert_eq!(power_heuristic(f32::INFINITY, 1e30), 1.0);
        assert_eq!(power_heuristic(1e30, f32::INFINITY), 0.0);
        // Ratio 1e60 (∞ in f32): limit 0. Ratio² 1e40 (∞ in f32): the f64 squares give the exact
        // weight 1e-40, a subnormal f32, not NaN.
        assert_eq!(power_heuristic(1e-30, 1e30), 0.0);
        let w = power_heuristic(1.0, 1e20);
        assert!((0.0..=1.0001e-40).contains(&w) && w > 0.0, "{w:e}");
        // Ratio² underflows: limit 1.
        assert_eq!(power_heuristic(1e30, 1e-30), 1.0);
        assert_eq!(power_heuristic(1.0, 1e-25), 1.0);
        // Subnormal against subnormal: an ordinary ratio.
        assert_eq!(power_heuristic(f32::from_bits(2), f32::from_bits(1)), 0.8);
        assert_eq!(mis_weight_pair(0.0, 0.0), (1.0, 0.0));
        assert_eq!(mis_weight_pair(0.0, 2.0), (0.0, 1.0));
    }

    #[test]
    fn symmetric_pair_gives_one_half() {
        for q in extremes().into_iter().filter(|&q| q > 0.0) {
            assert_eq!(mis_weight_pair(q, q), (0.5, 0.5), "{q}");
        }
    }

    #[test]
    fn monotone_in_each_argument() {
        let mut qs = extremes();
        let mut s = Sampler::for_key(4, 0, 0);
        qs.extend((0..300).map(|_| random_density(&mut s)));
        qs.sort_by(f32::total_cmp);
        for &other in &qs {
            let mut prev_this = -1.0f32;
            let mut prev_other = 2.0f32;
            for &q in &qs {
                let w = power_heuristic(q, other);
                // Non-decreasing in q_this (except the q_other == 0 rule, constant 1).
                assert!(w >= prev_this, "q_this {q}, q_other {other}: {w} < {prev_this}");
                prev_this = w;
                if other > 0.0 && q > 0.0 {
                    let w = power_heuristic(other, q);
                    assert!(w <= prev_other, "q_this {other}, q_other {q}: {w} > {prev_other}");
                    prev_other = w;
                }
            }
        }
    }

    #[test]
    fn agrees_with_the_naive_formula_where_it_does_not_overflow() {
        let mut s = Sampler::for_key(5, 0, 0);
        for _ in 0..200_000 {
            // Within 1e-15 … 1e15 the squares fit in f32 (and certainly in f64).
            let q1 = 10f32.powf(-15.0 + 30.0 * s.next_1d());
            let q2 = 10f32.powf(-15.0 + 30.0 * s.next_1d());
            let naive32 = q1 * q1 / (q1 * q1 + q2 * q2);
            let naive64 = {
                let (a, b) = (f64::from(q1), f64::from(q2));
                a * a / (a * a + b * b)
            };
            let w = power_heuristic(q1, q2);
            assert!(
                (f64::from(w) - naive64).abs() <= 4.0 * f64::from(f32::EPSILON) * naive64.max(1e-30),
                "{q1} {q2}: {w} vs {naive64}"
            );
            assert!(
                (w - naive32).abs() <= 4.0 * f32::EPSILON * naive32.max(1e-30) + 1e-37,
                "{q1} {q2}: {w} vs {naive32}"
            );
        }
    }
}
