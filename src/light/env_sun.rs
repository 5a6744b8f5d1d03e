//! A sun's disc as part of an environment map ([`EnvMap::with_sun`](super::EnvMap::with_sun)): uniform
//! radiance inside a narrow cone around a direction (Mitsuba's `sunsky` sun with `complex_sun = false`,
//! `BaseSunskyEmitter::eval_sun`, `sample_sun`, `compute_pdfs`), sampled uniformly within the cone.
//!
//! The standard sun is 0.27° in radius: its solid angle, 2π(1 − cos α) ≈ 6.9·10⁻⁵ sr, is below the f32
//! spacing of cosines near 1 by only a factor of 180, so the cone is tested, sampled and measured through
//! the sine of the angle to its axis (`|axis × d|`, precise for nearly parallel unit vectors) and f64, not
//! through `cos α` in f32.

use crate::math::{Frame, Vec2, Vec3};

/// A uniform disc of radiance `radiance` seen within half angle `half_angle` of the unit `axis` (world space).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvSun {
    axis: Vec3,
    frame: Frame,
    radiance: Vec3,
    /// sin² of the half angle (the cone test: `|axis × d|² ≤ sin²α` with `axis · d > 0`).
    sin2_half: f64,
    /// `1 − cos α` in f64.
    one_minus_cos: f64,
    /// `1/(2π(1 − cos α))`.
    pdf: f32,
}

impl EnvSun {
    /// `None` unless `axis` is finite and non-zero, `half_angle` in (0, π/2) and `radiance` finite with a
    /// positive luminance. A channel may be negative: the Hošek–Wilkie sun near the horizon has a negative
    /// blue in RGB, which Mitsuba keeps ("left un-clamped", its `sunsky` documentation).
    #[must_use]
    pub fn new(axis: Vec3, half_angle: f64, radiance: Vec3) -> Option<EnvSun> {
        let axis = crate::math::normalize_any(axis)?;
        let ok = half_angle > 0.0 && half_angle < std::f64::consts::FRAC_PI_2 && radiance.is_finite() && super::luminance(radiance) > 0.0;
        if !ok {
            return None;
        }
        let one_minus_cos = 2.0 * (0.5 * half_angle).sin().powi(2);
        Some(EnvSun {
            axis,
            frame: Frame::from_normal(axis),
            radiance,
            sin2_half: half_angle.sin().powi(2),
            one_minus_cos,
            pdf: (1.0 / (std::f64::consts::TAU * one_minus_cos)) as f32,
        })
    }

    /// Whether the unit world direction `d` falls on the disc.
    #[must_use]
    pub fn contains(&self, d: Vec3) -> bool {
        let (a, d64) = (self.axis.as_dvec3(), d.as_dvec3());
        a.dot(d64) > 0.0 && a.cross(d64).length_squared() <= self.sin2_half * d64.length_squared()
    }

    /// Radiance arriving from the unit world direction `d`.
    #[must_use]
    pub fn eval(&self, d: Vec3) -> Vec3 {
        if self.contains(d) {
            self.radiance
        } else {
            Vec3::ZERO
        }
    }

    /// Solid-angle density of [`EnvSun::sample`] at `d`.
    #[must_use]
    pub fn pdf(&self, d: Vec3) -> f32 {
        if self.contains(d) {
            self.pdf
        } else {
            0.0
        }
    }

    /// A direction uniform in the cone: `1 − cos θ = u.x (1 − cos α)`, φ = 2π u.y.
    #[must_use]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let one_minus_cos = f64::from(u.x) * self.one_minus_cos;
        let sin_theta = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
        let phi = std::f64::consts::TAU * f64::from(u.y);
        let local = Vec3::new((sin_theta * phi.cos()) as f32, (sin_theta * phi.sin()) as f32, (1.0 - one_minus_cos) as f32);
        self.frame.to_world(local).normalize()
    }

    /// `∫ eval dω = radiance · 2π(1 − cos α)`.
    #[must_use]
    pub fn integral(&self) -> Vec3 {
        self.radiance * (std::f64::consts::TAU * self.one_minus_cos) as f32
    }

    /// The disc's radiance.
    #[must_use]
    pub fn radiance(&self) -> Vec3 {
        self.radiance
    }

    /// The unit direction of the disc's centre.
    #[must_use]
    pub fn axis(&self) -> Vec3 {
        self.axis
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{assert_within_5_sigma, chi2_test, Mean};
    use super::super::{luminance, EnvMap};
    use super::*;
    use crate::math::Mat4;
    use crate::sampler::Sampler;
    use crate::sampling::warp::square_to_uniform_sphere;

    /// A small random map (with black pixels) carrying a 0.27° sun of the given luminance scale, tilted.
    fn map_with_sun(sun_scale: f32) -> (EnvMap, EnvSun) {
        let (w, h) = (32, 16);
        let mut s = Sampler::for_key(5, 0, 0);
        let pixels = (0..w * h).map(|i| if i % 7 == 0 { Vec3::ZERO } else { Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) }).collect();
        let map = EnvMap::from_pixels(w, h, pixels, 1.0, Mat4::from_rotation_x(0.3)).unwrap();
        let sun = EnvSun::new(Vec3::new(0.3, 0.8, 0.2), 0.2679f64.to_radians(), Vec3::new(3.0, 2.0, 1.0) * sun_scale).unwrap();
        (map.with_sun(sun), sun)
    }

    /// `∫ pdf_li dω = 1`, measured in two parts: uniform directions outside the disc, uniform directions
    /// in it; and `E[L/pdf] = ∫ L dω` with the light's own samples (eval and pdf agree, the sun included).
    #[test]
    fn mixture_pdf_integrates_to_one_and_matches_eval() {
        for sun_scale in [1e3, 1e5] {
            let (env, sun) = map_with_sun(sun_scale);
            let mut s = Sampler::for_key(17, 0, 0);
            let (mut outside, mut inside, mut li) = (Mean::default(), Mean::default(), Mean::default());
            let cone = std::f64::consts::TAU * sun.one_minus_cos;
            for _ in 0..200_000 {
                let d = square_to_uniform_sphere(s.next_2d());
                outside.add(if sun.contains(d) { 0.0 } else { 4.0 * std::f64::consts::PI * f64::from(env.pdf_li(d)) });
                let c = sun.sample(s.next_2d());
                inside.add(cone * f64::from(env.pdf_li(c)));
                if let Some(ls) = env.sample_li(Vec3::ZERO, s.next_2d()) {
                    li.add(f64::from(luminance(ls.li)) / f64::from(ls.pdf_w));
                } else {
                    li.add(0.0);
                }
            }
            let mut total = Mean::default();
            total.add(outside.mean() + inside.mean());
            println!("sun ×{sun_scale}: ∫pdf outside {} ± {}, inside {} ± {}", outside.mean(), outside.stderr(), inside.mean(), inside.stderr());
            let err = (outside.mean() + inside.mean() - 1.0).abs();
            assert!(err < 5.0 * (outside.stderr() + inside.stderr()) + 1e-4, "∫ pdf = {}", outside.mean() + inside.mean());
            assert_within_5_sigma("E[Y(L)/pdf]", &li, f64::from(env.integral_luminance()), 1e-4 * f64::from(env.integral_luminance()));
        }
    }

    /// The samples that land on the disc are uniform over it: chi² over 4 rings of equal solid angle × 8
    /// sectors, and their share is the sun's probability plus the map's density over the disc (binomial).
    #[test]
    fn samples_on_the_disc_are_uniform_and_as_frequent_as_the_pdf_says() {
        let (env, sun) = map_with_sun(1e3);
        let mut s = Sampler::for_key(23, 0, 0);
        let n = 400_000u64;
        let (mut counts, mut on_disc) = (vec![0u64; 32], 0u64);
        for _ in 0..n {
            let (wi, _) = env.sample_direction(s.next_2d()).unwrap();
            if !sun.contains(wi) {
                continue;
            }
            on_disc += 1;
            let local = sun.frame.to_local(wi).as_dvec3();
            let one_minus_cos = (local.x * local.x + local.y * local.y) / (1.0 + local.z);
            let ring = ((one_minus_cos / sun.one_minus_cos * 4.0) as usize).min(3);
            let phi = local.y.atan2(local.x).rem_euclid(std::f64::consts::TAU);
            let sector = ((phi / std::f64::consts::TAU * 8.0) as usize).min(7);
            counts[ring * 8 + sector] += 1;
        }
        let expected = vec![on_disc as f64 / 32.0; 32];
        let (chi2, dof, p) = chi2_test(&counts, &expected);
        println!("disc: {on_disc} of {n} samples, chi² {chi2} with {dof} dof, p = {p}");
        assert!(p > 1e-4, "chi² {chi2} with {dof} dof: p = {p}");
        // The disc's share: p_sun + (1 − p_sun)·∫_disc pdf_map, the map's density nearly constant over the disc.
        let map_part = (1.0 - f64::from(env.sun_prob)) * f64::from(env.pdf_map(sun.axis)) * std::f64::consts::TAU * sun.one_minus_cos;
        let share = f64::from(env.sun_prob) + map_part;
        let sigma = (share * (1.0 - share) / n as f64).sqrt();
        let got = on_disc as f64 / n as f64;
        assert!((got - share).abs() < 5.0 * sigma, "disc share {got} against {share} ± {sigma}");
    }
}
