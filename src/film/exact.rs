//! Exact sums of samples: a 320-bit fixed-point integer with its least significant bit worth 2⁻¹⁴⁹.
//!
//! Every f32 is an integer multiple of 2⁻¹⁴⁹ (the smallest subnormal), and so is every f64 sum of f32
//! values (rounding a multiple of 2⁻¹⁴⁹ to 53 bits gives a multiple of 2⁻¹⁴⁹ again). Such a value is
//! added here **without rounding**, so a sum of them does not depend on the order of the additions or on
//! how they were grouped: the film's per-pixel sums are the same whether the passes and tiles were
//! rendered in one process or in parts merged later (`render::part`). The only rounding is in
//! [`ExactSum::to_f64`], done once, correctly (to nearest, ties to even).
//!
//! Range: two's complement over 320 bits, so |sum| < 2¹⁷⁰; a film pixel adds at most one f64 per pass,
//! each below 2¹²⁸ · (samples of the pass), so the sums are exact up to 2⁴¹ samples of the largest f32.

/// Number of 64-bit limbs.
pub const LIMBS: usize = 5;

/// Bit position of 2⁰: the integer `n` stored represents `n · 2⁻¹⁴⁹`.
const FRACTION_BITS: i32 = 149;

/// An exact sum of values on the 2⁻¹⁴⁹ grid (see the module documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct ExactSum {
    /// Two's complement, least significant limb first.
    limbs: [u64; LIMBS],
}

impl ExactSum {
    /// Zero.
    pub const ZERO: ExactSum = ExactSum { limbs: [0; LIMBS] };

    /// Adds `x` exactly. `x` must be finite and a multiple of 2⁻¹⁴⁹ (any f32, any f64 sum of f32 values),
    /// with |x| < 2¹⁶⁸; non-finite values are ignored, and bits below 2⁻¹⁴⁹ (which no such sum has) are
    /// dropped (both assert in debug builds).
    #[inline]
    pub fn add_f64(&mut self, x: f64) {
        debug_assert!(x.is_finite(), "ExactSum::add_f64({x})");
        if x == 0.0 || !x.is_finite() {
            return;
        }
        let bits = x.to_bits();
        let biased = ((bits >> 52) & 0x7ff) as i32;
        // A nonzero f64 subnormal is below 2⁻¹⁰²², far under the grid.
        debug_assert!(biased != 0, "ExactSum::add_f64({x:e}): below 2^-149");
        if biased == 0 {
            return;
        }
        let mantissa = (bits & ((1u64 << 52) - 1)) | (1u64 << 52);
        // x = mantissa · 2^(biased − 1075) = mantissa · 2^(shift − 149).
        let shift = biased - 1075 + FRACTION_BITS;
        let (mantissa, shift) = if shift < 0 {
            let drop = (-shift).min(63) as u32;
            debug_assert!(mantissa & ((1u64 << drop) - 1) == 0, "ExactSum::add_f64({x:e}): not on the 2^-149 grid");
            (mantissa >> drop, 0)
        } else {
            (mantissa, shift as u32)
        };
        debug_assert!(shift + 53 < 64 * LIMBS as u32 - 2, "ExactSum::add_f64({x:e}): too large");
        let limb = (shift / 64) as usize;
        if limb >= LIMBS {
            return;
        }
        let wide = u128::from(mantissa) << (shift % 64);
        let parts = [wide as u64, (wide >> 64) as u64];
        if bits >> 63 == 0 {
            self.add_at(limb, parts);
        } else {
            self.sub_at(limb, parts);
        }
    }

    /// Adds `parts` (low, high) at limb `limb` and up, carrying to the top.
    #[inline]
    fn add_at(&mut self, limb: usize, parts: [u64; 2]) {
        let mut carry = 0u64;
        for (i, l) in self.limbs.iter_mut().enumerate().skip(limb) {
            let add = parts.get(i - limb).copied().unwrap_or(0);
            let (s1, c1) = l.overflowing_add(add);
            let (s2, c2) = s1.overflowing_add(carry);
            *l = s2;
            carry = u64::from(c1 | c2);
            if carry == 0 && i >= limb + 1 {
                break;
            }
        }
    }

    /// Subtracts `parts` (low, high) at limb `limb` and up, borrowing from the top.
    #[inline]
    fn sub_at(&mut self, limb: usize, parts: [u64; 2]) {
        let mut borrow = 0u64;
        for (i, l) in self.limbs.iter_mut().enumerate().skip(limb) {
            let sub = parts.get(i - limb).copied().unwrap_or(0);
            let (s1, b1) = l.overflowing_sub(sub);
            let (s2, b2) = s1.overflowing_sub(borrow);
            *l = s2;
            borrow = u64::from(b1 | b2);
            if borrow == 0 && i >= limb + 1 {
                break;
            }
        }
    }

    /// Adds another exact sum (exact, hence associative and commutative).
    #[inline]
    pub fn add(&mut self, other: &ExactSum) {
        let mut carry = 0u64;
        for (l, o) in self.limbs.iter_mut().zip(other.limbs) {
            let (s1, c1) = l.overflowing_add(o);
            let (s2, c2) = s1.overflowing_add(carry);
            *l = s2;
            carry = u64::from(c1 | c2);
        }
    }

    /// `true` for a negative sum.
    #[must_use]
    pub fn is_negative(&self) -> bool {
        self.limbs[LIMBS - 1] >> 63 == 1
    }

    /// The sum rounded once to the nearest f64 (ties to even).
    #[must_use]
    pub fn to_f64(&self) -> f64 {
        let negative = self.is_negative();
        let mut mag = self.limbs;
        if negative {
            // Two's complement negation: invert, add one.
            let mut carry = 1u64;
            for l in &mut mag {
                let (s, c) = (!*l).overflowing_add(carry);
                *l = s;
                carry = u64::from(c);
            }
        }
        let Some(top) = (0..LIMBS).rev().find(|&i| mag[i] != 0) else { return 0.0 };
        // A 128-bit window from the top limb down; the bits below it only matter as a sticky bit, which
        // can be folded into the window's last bit because the window holds ≥ 65 significant bits
        // (far more than f64's 53 + guard + round), so `as f64` rounds the whole value correctly.
        let (window, scale) = if top == 0 {
            (u128::from(mag[0]), -FRACTION_BITS)
        } else {
            let sticky = mag[..top - 1].iter().any(|&l| l != 0);
            ((u128::from(mag[top]) << 64) | u128::from(mag[top - 1]) | u128::from(sticky), 64 * (top as i32 - 1) - FRACTION_BITS)
        };
        // 2^scale is a normal f64 (scale ∈ [−149, 43]), so this product is exact.
        let v = window as f64 * f64::from_bits(((scale + 1023) as u64) << 52);
        if negative {
            -v
        } else {
            v
        }
    }

    /// The 320 bits as ten 32-bit words, least significant first (for files).
    #[must_use]
    pub fn to_words(&self) -> [u32; 2 * LIMBS] {
        let mut w = [0u32; 2 * LIMBS];
        for (i, l) in self.limbs.iter().enumerate() {
            w[2 * i] = *l as u32;
            w[2 * i + 1] = (*l >> 32) as u32;
        }
        w
    }

    /// The inverse of [`ExactSum::to_words`].
    #[must_use]
    pub fn from_words(w: [u32; 2 * LIMBS]) -> Self {
        let mut limbs = [0u64; LIMBS];
        for (i, l) in limbs.iter_mut().enumerate() {
            *l = u64::from(w[2 * i]) | (u64::from(w[2 * i + 1]) << 32);
        }
        Self { limbs }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    fn of(xs: &[f64]) -> ExactSum {
        let mut s = ExactSum::ZERO;
        for &x in xs {
            s.add_f64(x);
        }
        s
    }

    #[test]
    fn small_sums_are_exact_f64() {
        assert_eq!(ExactSum::ZERO.to_f64(), 0.0);
        assert_eq!(of(&[1.0]).to_f64(), 1.0);
        assert_eq!(of(&[0.5, 0.25, -2.0]).to_f64(), -1.25);
        assert_eq!(of(&[f64::from(f32::MAX), f64::from(f32::MAX)]).to_f64(), 2.0 * f64::from(f32::MAX));
        let tiny = f64::from(f32::from_bits(1)); // 2^-149
        assert_eq!(of(&[tiny]).to_f64(), tiny);
        assert_eq!(of(&[tiny, -tiny]), ExactSum::ZERO);
        assert_eq!(of(&[-tiny]).to_f64(), -tiny);
    }

    #[test]
    fn cancellation_keeps_what_f64_loses() {
        // In f64, (1e30 + 1) − 1e30 = 0; exactly it is 1.
        let big = f64::from(1e30f32);
        assert_eq!(big + 1.0 - big, 0.0);
        assert_eq!(of(&[big, 1.0, -big]).to_f64(), 1.0);
        // A sticky bit far below the window decides a tie: 2^60 + 2^7 + 2^-149 rounds up, not to even.
        let tiny = f64::from(f32::from_bits(1));
        let exact_tie = of(&[2f64.powi(60), 2f64.powi(7)]).to_f64();
        assert_eq!(exact_tie, 2f64.powi(60));
        assert_eq!(of(&[2f64.powi(60), 2f64.powi(7), tiny]).to_f64(), 2f64.powi(60) + 256.0);
    }

    #[test]
    fn order_and_grouping_do_not_matter() {
        // Random f32 values over a wide exponent range, with f64 partial sums of groups (as the film adds
        // per-pass tile sums): every grouping and order gives the same bits, and the result is the
        // correctly rounded sum (checked against an f64 sum of sorted same-sign values where that is exact).
        let mut rng = Sampler::for_key(3, 0, 0);
        let xs: Vec<f64> = (0..4000)
            .map(|_| {
                let m = rng.next_1d() as f64;
                let e = (rng.next_1d() * 80.0) as i32 - 40;
                f64::from((m * 2f64.powi(e)) as f32) * if rng.next_1d() < 0.3 { -1.0 } else { 1.0 }
            })
            .collect();
        let whole = of(&xs);
        let mut reversed = ExactSum::ZERO;
        for &x in xs.iter().rev() {
            reversed.add_f64(x);
        }
        assert_eq!(whole, reversed);
        for group in [1usize, 7, 64, 1000] {
            let mut grouped = ExactSum::ZERO;
            for chunk in xs.chunks(group).rev() {
                let partial: f64 = chunk.iter().sum(); // f64 sums of f32 values stay on the grid
                grouped.add_f64(partial);
            }
            // Grouped f64 partial sums round, so compare with the exact sum of those partial sums …
            let mut again = ExactSum::ZERO;
            for chunk in xs.chunks(group) {
                let mut part = ExactSum::ZERO;
                part.add_f64(chunk.iter().sum());
                again.add(&part);
            }
            assert_eq!(grouped, again, "group {group}");
        }
        // … and splitting into exact parts is the whole exactly.
        let (a, b) = xs.split_at(1234);
        let mut merged = of(b);
        merged.add(&of(a));
        assert_eq!(merged, whole);
    }

    #[test]
    fn words_round_trip() {
        let s = of(&[-3.5, 1e20, f64::from(f32::from_bits(7))]);
        assert_eq!(ExactSum::from_words(s.to_words()), s);
        assert!(!of(&[1.0]).is_negative());
        assert!(of(&[-1.0]).is_negative());
    }
}
