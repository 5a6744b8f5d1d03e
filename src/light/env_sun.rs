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
