//! The Hošek–Wilkie sky and sun in RGB, as Mitsuba 3.9.1's `sunsky` evaluates them in its RGB variants
//! (`include/mitsuba/render/sunsky.h`, `BaseSunskyEmitter::eval`, `eval_sky`, `eval_sun`, and
//! `src/emitters/sunsky.cpp`, `bilinear_interp`, `bezier_interp`, `update_irradiance_data`), from the paper:
//! L. Hošek, A. Wilkie, "An Analytic Model for Full Spectral Sky-Dome Radiance", SIGGRAPH 2012, and "Adding a
//! Solar-Radiance Function to the Hošek–Wilkie Skylight Model", CG&A 2013.
//!
//! The data (`data/sunsky/hosek-wilkie-rgb.bin`, 18,000 bytes, provenance and licences in
//! `data/sunsky/README.md`, written by `scripts/make-sunsky-data`) holds, as little-endian f32:
//! the sky's nine parameters A…I and its mean radiance L_M per turbidity (1…10), ground albedo (0, 1), Bézier
//! control point (6) and RGB channel; and the radiance of the sun's disc per turbidity and sun elevation
//! (2°, 5°, …, 89°), in Mitsuba's RGB units.
//!
//! The model, for a direction at angle θ from the zenith and γ from the sun:
//! `L = L_M · (1 + A·e^{B/(cos θ + 0.01)}) · (C + D·e^{E·γ} + F·cos²γ + G·χ(H, γ) + I·√cos θ)`,
//! `χ(H, γ) = (1 + cos²γ)/(1 + H² − 2H·cos γ)^{3/2}`, each parameter and L_M interpolated linearly in the
//! turbidity, then in the albedo (per channel), then by the quintic Bézier curve of the sun's elevation η
//! through the 6 control points at `x = ∛(2η/π)`. Mitsuba multiplies the sky by its `MI_CIE_Y_NORMALIZATION`.
//! The sun's disc is uniform (Mitsuba's default sun, `complex_sun = false`): its radiance is interpolated
//! linearly in the turbidity and in `(elevation in degrees − 2)/3`, and scaled by the ratio of the standard
//! sun's solid angle to that of the chosen aperture so that its irradiance stays the same.

use std::f64::consts::PI;

/// Turbidity levels (1…10), albedo levels (0 and 1), Bézier control points, RGB channels, sky parameters.
const TURBIDITIES: usize = 10;
const ALBEDOS: usize = 2;
const CONTROL_POINTS: usize = 6;
const CHANNELS: usize = 3;
const PARAMS: usize = 9;
/// Sun elevations of the sun table: 2°, 5°, …, 89° (Mitsuba's `MPDF_ELEVATION_COUNT`).
const SUN_ELEVATIONS: usize = 30;

const SKY_PARAMS_LEN: usize = TURBIDITIES * ALBEDOS * CONTROL_POINTS * CHANNELS * PARAMS;
const SKY_RAD_LEN: usize = TURBIDITIES * ALBEDOS * CONTROL_POINTS * CHANNELS;
const SUN_LEN: usize = TURBIDITIES * SUN_ELEVATIONS * CHANNELS;

static DATA: &[u8] = include_bytes!("../../data/sunsky/hosek-wilkie-rgb.bin");
const _: () = assert!(DATA.len() == 4 * (SKY_PARAMS_LEN + SKY_RAD_LEN + SUN_LEN), "data/sunsky/hosek-wilkie-rgb.bin has the wrong size");

/// Mitsuba's `MI_CIE_Y_NORMALIZATION` (1/∫ȳ), by which its RGB sky radiance is multiplied (the same constant
/// as `scene::xml::cie1931::CIE_Y_NORMALIZATION`).
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_062_5;

/// The standard sun's half aperture, Mitsuba's `SUN_HALF_APERTURE`: half of 0.5358°.
pub(super) const SUN_HALF_APERTURE_DEG: f64 = 0.5 * 0.5358;

/// The `i`-th f32 of the data.
fn at(i: usize) -> f64 {
    let b = &DATA[4 * i..4 * i + 4];
    f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Linear interpolation of a table with a fractional index along an axis of `n` levels: the index is clamped
/// to `[0, n − 1]` (Mitsuba's `take_interp` on a clamped index).
fn lerp_index(index: f64, n: usize) -> (usize, f64) {
    let t = index.clamp(0.0, (n - 1) as f64);
    let i = (t.floor() as usize).min(n - 2);
    (i, t - i as f64)
}

/// The sky of one turbidity, albedo and sun elevation: per channel, the nine parameters and L_M (the
/// sky scale and Mitsuba's CIE normalisation folded in).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Sky {
    params: [[f64; PARAMS]; CHANNELS],
    radiance: [f64; CHANNELS],
}

impl Sky {
    /// `turbidity` ∈ [1, 10], `albedo` ∈ [0, 1]³, `sun_elevation` η ∈ [0, π/2] in radians.
    pub(super) fn new(turbidity: f64, albedo: [f64; 3], sun_elevation: f64, scale: f64) -> Sky {
        let (t0, wt) = lerp_index(turbidity - 1.0, TURBIDITIES);
        // Bézier weights C(5, k)·x^k·(1 − x)^(5 − k), x = ∛(2η/π) just below 1 (Mitsuba clamps it there).
        let x = (2.0 * sun_elevation / PI).cbrt().min(1.0 - f64::from(f32::EPSILON) / 2.0);
        let binomial = [1.0, 5.0, 10.0, 10.0, 5.0, 1.0];
        let bezier: [f64; CONTROL_POINTS] = std::array::from_fn(|k| binomial[k] * x.powi(k as i32) * (1.0 - x).powi(5 - k as i32));
        // The value of (control point k, channel c, item j) of a table of `items` items per channel.
        let value = |base: usize, items: usize, c: usize, j: usize| {
            let level = |t: usize, a: usize| {
                (0..CONTROL_POINTS)
                    .map(|k| bezier[k] * at(base + (((t * ALBEDOS + a) * CONTROL_POINTS + k) * CHANNELS + c) * items + j))
                    .sum::<f64>()
            };
            let of_albedo = |a: usize| (1.0 - wt) * level(t0, a) + wt * level(t0 + 1, a);
            (1.0 - albedo[c]) * of_albedo(0) + albedo[c] * of_albedo(1)
        };
        let params = std::array::from_fn(|c| std::array::from_fn(|j| value(0, PARAMS, c, j)));
        let radiance = std::array::from_fn(|c| scale * CIE_Y_NORMALIZATION * value(SKY_PARAMS_LEN, 1, c, 0));
        Sky { params, radiance }
    }

    /// The sky's RGB radiance at `cos_theta` (cosine of the zenith angle, ≥ 0) and `gamma` (angle to the
    /// sun, radians).
    pub(super) fn eval(&self, cos_theta: f64, gamma: f64) -> [f64; 3] {
        let cos_gamma = gamma.cos();
        let cos2 = cos_gamma * cos_gamma;
        std::array::from_fn(|c| {
            let [a, b, cc, d, e, f, g, i, h] = self.params[c];
            let chi = (1.0 + cos2) / (1.0 + h * h - 2.0 * h * cos_gamma).powf(1.5);
            let zenith = 1.0 + a * (b / (cos_theta + 0.01)).exp();
            let angular = cc + d * (e * gamma).exp() + f * cos2 + g * chi + i * cos_theta.max(0.0).sqrt();
            zenith * angular * self.radiance[c]
        })
    }
}

/// The radiance of the standard sun's disc (half aperture [`SUN_HALF_APERTURE_DEG`]) at `turbidity` for the
/// sun at `sun_elevation` (radians), in Mitsuba's RGB units.
pub(super) fn sun_radiance(turbidity: f64, sun_elevation: f64) -> [f64; 3] {
    let (t0, wt) = lerp_index(turbidity - 1.0, TURBIDITIES);
    let (e0, we) = lerp_index((sun_elevation.to_degrees() - 2.0) / 3.0, SUN_ELEVATIONS);
    let base = SKY_PARAMS_LEN + SKY_RAD_LEN;
    let value = |t: usize, e: usize, c: usize| at(base + (t * SUN_ELEVATIONS + e) * CHANNELS + c);
    std::array::from_fn(|c| {
        let of_turbidity = |t: usize| (1.0 - we) * value(t, e0, c) + we * value(t, e0 + 1, c);
        (1.0 - wt) * of_turbidity(t0) + wt * of_turbidity(t0 + 1)
    })
}

/// The solid angle of a cone of half aperture `half` (radians), `2π(1 − cos half)` written without
/// cancellation.
pub(super) fn cone_solid_angle(half: f64) -> f64 {
    4.0 * PI * (0.5 * half).sin().powi(2)
}
