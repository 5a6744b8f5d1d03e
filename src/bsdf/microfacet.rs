//! Microfacet distributions as Mitsuba 3 names them (include/mitsuba/render/microfacet.h): `beckmann` (its
//! default) and `ggx` (Trowbridge–Reitz), isotropic or anisotropic (`alpha_u` along the shading frame's x,
//! `alpha_v` along its y), each sampled through the distribution of visible normals (`sample_visible = true`,
//! Mitsuba's default) or through `D(m)·cos θm`.
//!
//! Everything is written for the upper hemisphere (`v.z > 0`, the caller mirrors or rejects the rest).
//!
//! Anisotropy is a stretch of the microsurface (Heitz 2014, "Understanding the Masking-Shadowing Function",
//! §5.3): `(x, y) → (x/α_u, y/α_v)` maps the anisotropic distribution onto the α = 1 one, so every formula
//! below reads `tan²θ/α²` as `((mx/α_u)² + (my/α_v)²)/mz²` for `D`, and `α² tan²θ` as
//! `((α_u vx)² + (α_v vy)²)/vz²` for `Λ(v)`. Where `α_u == α_v` the isotropic expressions are evaluated as
//! they were written before anisotropy (the same operations, so isotropic results are unchanged bit for bit).
//!
//! - `D`: GGX `1/(π α² cos⁴θ (1 + tan²θ/α²)²)` (Walter et al. 2007, eq. 33); Beckmann
//!   `exp(−tan²θ/α²)/(π α² cos⁴θ)` (Walter 2007 eq. 25); `α²` in front is `α_u α_v`.
//! - Smith masking `G1(v) = 1/(1 + Λ(v))` with the exact `Λ` of each distribution, divided by `cos θv` so that
//!   nothing divides by a cosine: GGX `2/(cos θ + sqrt(cos²θ + α² sin²θ))` (Walter 2007 eq. 34);
//!   Beckmann, `a = cot θ/α`, `Λ = (erf(a) − 1)/2 + exp(−a²)/(2a√π)` (Walter 2007 eq. 27 before its rational
//!   fit; Heitz 2014 eq. 72), hence
//!   `G1/cos θ = 1/(cos θ·(1 + erf a)/2 + α sin θ·exp(−a²)/(2√π))`. Mitsuba evaluates Beckmann's `G1` with
//!   Walter's rational fit (< 0.35% relative error) but samples the exact visible normals; the exact form is
//!   used here so that the pdf is exactly the density of the sampler (χ²-tested).
//! - Visible normals `D_wo(m) = G1(wo)·max(0, wo·m)·D(m)/cos θo` (Heitz 2018, eq. 2): GGX by Heitz 2018
//!   ("Sampling the GGX Distribution of Visible Normals", JCGT 7(4)); Beckmann in slope space after Heitz &
//!   d'Eon 2014 ("Importance Sampling Microfacet-Based BSDFs using the Distribution of Visible Normals",
//!   algorithm 1: stretch, sample the α = 1 slopes, rotate, unstretch), the slope CDF inverted by
//!   bracketed Newton iteration in f64. Both stretch `wo` by `(α_u, α_v)` and unstretch the normal.
//! - Plain `D(m)·cos θm`: `tan²θ = −α² ln(1 − u)` (Beckmann) or `α² u/(1 − u)` (GGX) (Walter 2007 eqs. 28, 35);
//!   anisotropic, the azimuth first, `tan φ = (α_v/α_u)·tan 2πu₂` in the quadrant of `2πu₂`, and then `θ` with
//!   the roughness of that azimuth, `1/α² = cos²φ/α_u² + sin²φ/α_v²` (Mitsuba's `MicrofacetDistribution::sample`).
//!
//! The keys (Mitsuba's `MicrofacetDistribution(const Properties &)`), read by [`from_props`]:
//!
//! ```toml
//! distribution = "ggx"          # or "beckmann" (the default)
//! alpha = 0.2                   # default 0.1; or both of:
//! alpha_u = 0.05                # roughness along the shading frame's tangent
//! alpha_v = 0.3                 # … and bitangent
//! sample_visible = true         # the default
//! ```

use super::Bsdf;
use crate::math::{Vec2, Vec3};
use crate::props::{PropError, Props};
use std::f32::consts::{PI, TAU};

/// Smallest roughness evaluated (Mitsuba clamps to the same): below it `D` leaves f32's useful range.
pub(crate) const MIN_ALPHA: f32 = 1e-4;

/// Which normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MicrofacetType {
    Beckmann,
    Ggx,
}

impl MicrofacetType {
    /// Mitsuba's name (`distribution` property).
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            MicrofacetType::Beckmann => "beckmann",
            MicrofacetType::Ggx => "ggx",
        }
    }
}

/// A microfacet distribution and how it is sampled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub kind: MicrofacetType,
    /// Roughness along the shading frame's tangent (x) and bitangent (y), each clamped to [`MIN_ALPHA`] when
    /// evaluated; equal for an isotropic distribution.
    pub alpha_u: f32,
    pub alpha_v: f32,
    /// Sample visible normals (Mitsuba's `sample_visible`, default true) or `D(m)·cos θm`.
    pub sample_visible: bool,
}

impl Microfacet {
    /// Whether the roughness differs along the tangent and the bitangent.
    #[must_use]
    pub fn is_anisotropic(&self) -> bool {
        self.alpha_u != self.alpha_v
    }

    /// The texturable roughness of the microfacet plugins (`bsdf::params`): `alpha` (both axes), or
    /// `alpha_u` and `alpha_v` apart.
    pub(super) fn visit_params(&mut self, v: &mut dyn super::ParamVisitor) {
        v.param("alpha", super::ParamMut::FloatPair(&mut self.alpha_u, &mut self.alpha_v));
        v.param("alpha_u", super::ParamMut::Float(&mut self.alpha_u));
        v.param("alpha_v", super::ParamMut::Float(&mut self.alpha_v));
    }
}

/// Mitsuba's default roughness (`alpha`) of its microfacet plugins.
const DEFAULT_ALPHA: f32 = 0.1;

/// The distribution the keys of the module docs describe (Mitsuba's `MicrofacetDistribution(props)`):
/// `distribution` (default `default_kind`), `alpha` or both `alpha_u` and `alpha_v` (> 0; default 0.1), and
/// `sample_visible` (default true).
pub(super) fn from_props(p: &Props<'_, Bsdf>, default_kind: MicrofacetType) -> Result<Microfacet, PropError> {
    let kind = match p.string("distribution")? {
        None => default_kind,
        Some(name) if name.eq_ignore_ascii_case("beckmann") => MicrofacetType::Beckmann,
        Some(name) if name.eq_ignore_ascii_case("ggx") => MicrofacetType::Ggx,
        Some(other) => {
            return Err(PropError::new("distribution", format!("unknown distribution {other:?} (\"beckmann\" or \"ggx\")")))
        }
    };
    let (alpha_u, alpha_v) = match (p.has("alpha"), p.has("alpha_u"), p.has("alpha_v")) {
        (true, false, false) | (false, false, false) => {
            let alpha = p.positive_or("alpha", DEFAULT_ALPHA, "the roughness alpha")?;
            (alpha, alpha)
        }
        (false, true, true) => (
            p.positive_or("alpha_u", DEFAULT_ALPHA, "the roughness alpha_u")?,
            p.positive_or("alpha_v", DEFAULT_ALPHA, "the roughness alpha_v")?,
        ),
        (true, ..) => {
            let key = if p.has("alpha_u") { "alpha_u" } else { "alpha_v" };
            return Err(PropError::new(key, "give either `alpha` or both `alpha_u` and `alpha_v`, not both (as Mitsuba)"));
        }
        (false, u, _) => {
            let (given, missing) = if u { ("alpha_u", "alpha_v") } else { ("alpha_v", "alpha_u") };
            return Err(PropError::new(given, format!("`{given}` needs `{missing}` too (an anisotropic roughness takes both)")));
        }
    };
    let sample_visible = p.bool_or("sample_visible", true)?;
    Ok(Microfacet { kind, alpha_u, alpha_v, sample_visible })
}

impl Microfacet {
    /// An isotropic distribution of roughness `alpha`.
    #[must_use]
    pub fn isotropic(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Self {
        Self { kind, alpha_u: alpha, alpha_v: alpha, sample_visible }
    }

    /// `(α_u, α_v)` clamped to [`MIN_ALPHA`] (Mitsuba's `configure`).
    #[inline]
    pub(super) fn alphas(&self) -> (f32, f32) {
        let clamp = |a: f32| if a >= MIN_ALPHA { a } else { MIN_ALPHA };
        (clamp(self.alpha_u), clamp(self.alpha_v))
    }

    /// Whether the (clamped) roughness is the same along both axes.
    #[inline]
    #[must_use]
    pub fn is_isotropic(&self) -> bool {
        let (au, av) = self.alphas();
        au == av
    }

    /// The same distribution with both roughness values (after clamping) scaled by `s`: Mitsuba's
    /// `scale_alpha`.
    #[must_use]
    pub(super) fn scaled(&self, s: f32) -> Self {
        let (au, av) = self.alphas();
        Self { alpha_u: au * s, alpha_v: av * s, ..*self }
    }

    /// `D(m)`, 0 for `m.z ≤ 0`.
    #[must_use]
    pub fn d(&self, m: Vec3) -> f32 {
        if m.z <= 0.0 {
            return 0.0;
        }
        let (au, av) = self.alphas();
        match (self.kind, au == av) {
            // 1/(π α² ((mx² + my²)/α² + mz²)²) for a unit m.
            (MicrofacetType::Ggx, true) => {
                let a2 = au * au;
                let t = (m.x * m.x + m.y * m.y) / a2 + m.z * m.z;
                1.0 / (PI * a2 * t * t)
            }
            // 1/(π α_u α_v ((mx/α_u)² + (my/α_v)² + mz²)²).
            (MicrofacetType::Ggx, false) => {
                let (x, y) = (m.x / au, m.y / av);
                let t = x * x + y * y + m.z * m.z;
                1.0 / (PI * (au * av) * t * t)
            }
            // exp(−(mx² + my²)/(α² mz²))/(π α² mz⁴), in f64 (mz⁴ underflows f32 long before D vanishes);
            // anisotropic exp(−((mx/α_u)² + (my/α_v)²)/mz²)/(π α_u α_v mz⁴).
            (MicrofacetType::Beckmann, iso) => {
                let mz2 = f64::from(m.z) * f64::from(m.z);
                let (exponent, a2) = if iso {
                    let a2 = f64::from(au * au);
                    let xy2 = f64::from(m.x) * f64::from(m.x) + f64::from(m.y) * f64::from(m.y);
                    (xy2 / (a2 * mz2), a2)
                } else {
                    let (x, y) = (f64::from(m.x) / f64::from(au), f64::from(m.y) / f64::from(av));
                    ((x * x + y * y) / mz2, f64::from(au) * f64::from(av))
                };
                ((-exponent).exp() / (std::f64::consts::PI * a2 * mz2 * mz2)) as f32
            }
        }
    }

    /// `G1(v, m)/cos θv` for `v·m > 0`, 0 otherwise; `v.z > 0` is required (see the module docs).
    #[must_use]
    pub fn g1_over_cos(&self, v: Vec3, m: Vec3) -> f32 {
        if v.dot(m) <= 0.0 {
            return 0.0;
        }
        self.g1_over_cos_unmasked(v)
    }

    /// `G1(v, m)/cos θv` without the `v·m > 0` test: it depends on `v` alone, so an evaluation at one fixed
    /// `wo` for many `wi` computes it once (`super::at_wo`).
    #[must_use]
    pub(super) fn g1_over_cos_unmasked(&self, v: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let iso = au == av;
        match self.kind {
            MicrofacetType::Ggx => {
                // α² sin²θ, anisotropic (α_u vx)² + (α_v vy)².
                let xy_alpha2 = if iso {
                    au * au * (v.x * v.x + v.y * v.y)
                } else {
                    let (x, y) = (au * v.x, av * v.y);
                    x * x + y * y
                };
                2.0 / (v.z + (v.z * v.z + xy_alpha2).sqrt())
            }
            MicrofacetType::Beckmann => {
                // q = α sin θ, anisotropic sqrt((α_u vx)² + (α_v vy)²).
                let q = if iso {
                    f64::from(au) * f64::from(v.x * v.x + v.y * v.y).sqrt()
                } else {
                    let (x, y) = (f64::from(au) * f64::from(v.x), f64::from(av) * f64::from(v.y));
                    (x * x + y * y).sqrt()
                };
                let c = f64::from(v.z);
                let a = c / q; // cot θ / α; +∞ at normal incidence (erf → 1, exp → 0)
                let denom = 0.5 * c * (1.0 + libm::erf(a)) + q * (-a * a).exp() / (2.0 * std::f64::consts::PI.sqrt());
                (1.0 / denom) as f32
            }
        }
    }

    /// Density of [`Self::sample_normal`] per solid angle of `m`, given `wo` (`wo.z > 0`):
    /// `D_wo(m) = G1(wo)·max(0, wo·m)·D(m)/cos θo` or `D(m)·cos θm`.
    #[must_use]
    pub fn pdf_normal(&self, wo: Vec3, m: Vec3) -> f32 {
        if self.sample_visible {
            self.g1_over_cos(wo, m) * wo.dot(m).max(0.0) * self.d(m)
        } else {
            self.d(m) * m.z.max(0.0)
        }
    }

    /// A microfacet normal for `wo` (`wo.z > 0`), distributed as [`Self::pdf_normal`].
    #[must_use]
    pub fn sample_normal(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let (au, av) = self.alphas();
        if self.sample_visible {
            return match self.kind {
                MicrofacetType::Ggx => ggx_visible_normal(au, av, wo, u),
                MicrofacetType::Beckmann => beckmann_visible_normal(au, av, wo, u),
            };
        }
        // The azimuth, and α² along it.
        let (sp, cp, a2) = if au == av {
            let (sp, cp) = (TAU * u.y).sin_cos();
            (sp, cp, f64::from(au) * f64::from(au))
        } else {
            let (au, av) = (f64::from(au), f64::from(av));
            let tmp = av / au * (std::f64::consts::TAU * f64::from(u.y)).tan();
            // cos φ > 0 where 2πu₂ is in (−π/2, π/2): u₂ < 1/4 or u₂ > 3/4.
            let cp = (1.0 / tmp.mul_add(tmp, 1.0).sqrt()).copysign((f64::from(u.y) - 0.5).abs() - 0.25);
            let sp = cp * tmp;
            let a2 = 1.0 / ((cp / au).powi(2) + (sp / av).powi(2));
            (sp as f32, cp as f32, a2)
        };
        let u1 = f64::from(u.x);
        let tan2 = match self.kind {
            MicrofacetType::Beckmann => -a2 * (-u1).ln_1p(),
            MicrofacetType::Ggx => a2 * u1 / (1.0 - u1),
        };
        let cos = 1.0 / (1.0 + tan2).sqrt();
        let sin = (tan2 / (1.0 + tan2)).sqrt();
        Vec3::new((sin as f32) * cp, (sin as f32) * sp, cos as f32)
    }
}

/// GGX visible normal for `wo` on the +z side (Heitz 2018, listing in §4: stretch to the hemisphere
/// configuration, sample the projected half-disk, unstretch).
fn ggx_visible_normal(alpha_u: f32, alpha_v: f32, wo: Vec3, u: Vec2) -> Vec3 {
    // §3.2: the view direction in the hemisphere configuration.
    let vh = Vec3::new(alpha_u * wo.x, alpha_v * wo.y, wo.z).normalize();
    // §4.1: orthonormal basis (special case when vh is the pole).
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    // §4.2: uniform point on the disk, warped onto the visible projected half-disk.
    let r = u.x.sqrt();
    let (sin_phi, cos_phi) = (TAU * u.y).sin_cos();
    let p1 = r * cos_phi;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
    // §4.3: reprojection onto the hemisphere.
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    // §3.4: back to the ellipsoid configuration.
    Vec3::new(alpha_u * nh.x, alpha_v * nh.y, nh.z.max(0.0)).normalize()
}

/// Solves `cdf(x) = target` for a continuous increasing `cdf` on `[lo, hi]` (`cdf` returns the value and
/// its derivative): Newton steps, falling back to bisection whenever a step leaves the bracket.
fn invert_cdf(cdf: impl Fn(f64) -> (f64, f64), target: f64, mut lo: f64, mut hi: f64) -> f64 {
    let mut x = 0.5 * (lo + hi);
    let tolerance = 1e-15 * cdf(hi).0;
    for _ in 0..100 {
        let (value, slope) = cdf(x);
        let err = value - target;
        if err.abs() <= tolerance {
            break;
        }
        if err < 0.0 {
            lo = x;
        } else {
            hi = x;
        }
        if err == 0.0 || hi - lo <= 1e-12 * (1.0 + x.abs()) {
            break;
        }
        let newton = x - err / slope;
        x = if newton > lo && newton < hi && slope > 0.0 { newton } else { 0.5 * (lo + hi) };
    }
    x
}

const SQRT_PI: f64 = 1.772_453_850_905_516;
/// Slopes beyond ±10 have probability < e⁻¹⁰⁰ under Beckmann's Gaussian slope distribution.
const SLOPE_LIMIT: f64 = 10.0;

/// Beckmann visible normal for `wo` on the +z side (Heitz & d'Eon 2014, algorithm 1).
fn beckmann_visible_normal(alpha_u: f32, alpha_v: f32, wo: Vec3, u: Vec2) -> Vec3 {
    // 1. Stretch wo to the α = 1 configuration.
    let (alpha_u, alpha_v) = (f64::from(alpha_u), f64::from(alpha_v));
    let w = glam::DVec3::new(alpha_u * f64::from(wo.x), alpha_v * f64::from(wo.y), f64::from(wo.z)).normalize();
    let sin = (w.x * w.x + w.y * w.y).sqrt();
    // 2. Slopes of the α = 1 distribution of visible normals for incidence θ (wo in the xz-plane).
    //    P22(x, y) = exp(−x² − y²)/π is separable and only x is projected: y ~ exp(−y²)/√π, and x has the
    //    density ∝ (cot θ − x)·exp(−x²) on x < cot θ, whose CDF is
    //    F(x) = cot θ·(√π/2)(1 + erf x) + exp(−x²)/2 (derivative (cot θ − x)·exp(−x²)).
    let (u1, u2) = (f64::from(u.x), f64::from(u.y));
    //    (1 + erf x is written erfc(−x): no cancellation in the left tail.)
    let gauss = |x: f64| (0.5 * libm::erfc(-x), (-x * x).exp() / SQRT_PI);
    let slope_y = invert_cdf(gauss, u2, -SLOPE_LIMIT, SLOPE_LIMIT);
    let cot = w.z / sin;
    let slope_x = if cot.is_finite() && cot < 1e8 {
        let f = |x: f64| (cot * 0.5 * SQRT_PI * libm::erfc(-x) + 0.5 * (-x * x).exp(), (cot - x) * (-x * x).exp());
        let hi = cot.min(SLOPE_LIMIT);
        invert_cdf(f, u1 * f(hi).0, -SLOPE_LIMIT, hi)
    } else {
        // Normal incidence: the projection weight is constant, x is Gaussian like y.
        invert_cdf(gauss, u1, -SLOPE_LIMIT, SLOPE_LIMIT)
    };
    // 3. Rotate by wo's azimuth, 4. unstretch, 5. the normal of the slope.
    let (cos_phi, sin_phi) = if sin > 0.0 { (w.x / sin, w.y / sin) } else { (1.0, 0.0) };
    let x = alpha_u * (cos_phi * slope_x - sin_phi * slope_y);
    let y = alpha_v * (sin_phi * slope_x + cos_phi * slope_y);
    glam::DVec3::new(-x, -y, 1.0).normalize().as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::chi2::{integrate_sphere, Chi2Test, PdfIntegral};

    const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];
    const KINDS: [MicrofacetType; 2] = [MicrofacetType::Beckmann, MicrofacetType::Ggx];

    fn dir(theta_deg: f32, phi: f32) -> Vec3 {
        let (st, ct) = theta_deg.to_radians().sin_cos();
        Vec3::new(st * phi.cos(), st * phi.sin(), ct)
    }

    fn mf(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Microfacet {
        Microfacet::isotropic(kind, alpha, sample_visible)
    }

    /// Anisotropic roughness pairs (α_u, α_v) the tests sweep.
    const ANISO: [(f32, f32); 3] = [(0.05, 0.3), (0.5, 0.1), (0.2, 1.0)];

    fn aniso(kind: MicrofacetType, (alpha_u, alpha_v): (f32, f32), sample_visible: bool) -> Microfacet {
        Microfacet { kind, alpha_u, alpha_v, sample_visible }
    }

    #[test]
    fn distributions_and_visible_normals_are_normalised() {
        for kind in KINDS {
            for alpha in ALPHAS {
                let m = mf(kind, alpha, true);
                // ∫ D(m) cos θm dm = 1 (Walter 2007 eq. 4).
                let projected = integrate_sphere(|n| m.d(n) * n.z.max(0.0));
                assert!((projected - 1.0).abs() < 1e-4, "{kind:?} α {alpha}: ∫D cos = {projected}");
                // ∫ D_wo(m) dm = 1 (Heitz 2018 eq. 2): the exact Λ of each distribution.
                for theta in [0.0f32, 30.0, 60.0, 85.0] {
                    let wo = dir(theta, 0.4);
                    let visible = integrate_sphere(|n| m.pdf_normal(wo, n));
                    assert!((visible - 1.0).abs() < 1e-3, "{kind:?} α {alpha} θo {theta}: ∫D_wo = {visible}");
                }
            }
            for alphas in ANISO {
                let m = aniso(kind, alphas, true);
                let projected = integrate_sphere(|n| m.d(n) * n.z.max(0.0));
                assert!((projected - 1.0).abs() < 1e-4, "{kind:?} α {alphas:?}: ∫D cos = {projected}");
                for (theta, phi) in [(0.0f32, 0.0f32), (40.0, 0.4), (70.0, 1.3), (85.0, 2.5)] {
                    let wo = dir(theta, phi);
                    let visible = integrate_sphere(|n| m.pdf_normal(wo, n));
                    assert!((visible - 1.0).abs() < 1e-3, "{kind:?} α {alphas:?} θo {theta} φo {phi}: ∫D_wo = {visible}");
                }
            }
        }
    }

    /// The anisotropic `D` and `G1` against their textbook forms in polar angles (Heitz 2014 eqs. 80, 86
    /// with the projected roughness `α(φ)² = cos²φ α_u² + sin²φ α_v²`), and nearly equal roughness values
    /// against the isotropic expressions.
    #[test]
    fn anisotropic_forms_match_the_polar_formulas() {
        use std::f64::consts::PI as PI64;
        for kind in KINDS {
            for (au, av) in ANISO {
                let m = aniso(kind, (au, av), true);
                let (au, av) = (f64::from(au), f64::from(av));
                for (theta, phi) in [(5.0f32, 0.3f32), (30.0, 1.1), (60.0, 2.0), (80.0, 4.0)] {
                    let v = dir(theta, phi);
                    let (t, p) = (f64::from(theta).to_radians(), f64::from(phi));
                    let tan2 = t.tan().powi(2);
                    // D: tan²θ/α² → tan²θ·(cos²φ/α_u² + sin²φ/α_v²).
                    let e = tan2 * ((p.cos() / au).powi(2) + (p.sin() / av).powi(2));
                    let want_d = match kind {
                        MicrofacetType::Beckmann => (-e).exp() / (PI64 * au * av * t.cos().powi(4)),
                        MicrofacetType::Ggx => 1.0 / (PI64 * au * av * t.cos().powi(4) * (1.0 + e).powi(2)),
                    };
                    let got_d = f64::from(m.d(v));
                    assert!((got_d - want_d).abs() <= 1e-5 * want_d + 1e-30, "{kind:?} ({au}, {av}) θ {theta}: D {got_d} vs {want_d}");
                    // G1 with α(φ).
                    let alpha_phi = ((p.cos() * au).powi(2) + (p.sin() * av).powi(2)).sqrt();
                    let a = 1.0 / (alpha_phi * t.tan());
                    let want_g = match kind {
                        MicrofacetType::Beckmann => 2.0 / (1.0 + libm::erf(a) + (-a * a).exp() / (a * SQRT_PI)),
                        MicrofacetType::Ggx => 2.0 / (1.0 + (1.0 + 1.0 / (a * a)).sqrt()),
                    };
                    let got_g = f64::from(m.g1_over_cos(v, Vec3::Z) * v.z);
                    assert!((got_g - want_g).abs() <= 1e-5, "{kind:?} ({au}, {av}) θ {theta}: G1 {got_g} vs {want_g}");
                }
            }
            // α_u and α_v one ulp apart take the anisotropic path, equal ones the isotropic: the same values.
            let (iso, near) = (mf(kind, 0.3, true), Microfacet { alpha_v: 0.3f32.next_up(), ..mf(kind, 0.3, true) });
            assert!(iso.is_isotropic() && !near.is_isotropic());
            for (theta, phi) in [(20.0f32, 0.5f32), (75.0, 2.0)] {
                let v = dir(theta, phi);
                let (a, b) = (iso.d(v), near.d(v));
                assert!((a - b).abs() <= 1e-5 * a, "{kind:?}: D {a} vs {b}");
                let (a, b) = (iso.g1_over_cos(v, Vec3::Z), near.g1_over_cos(v, Vec3::Z));
                assert!((a - b).abs() <= 1e-5 * a, "{kind:?}: G1 {a} vs {b}");
            }
        }
    }

    #[test]
    fn beckmann_g1_matches_the_tangent_form() {
        // G1 = 2/(1 + erf(a) + exp(−a²)/(a√π)), a = 1/(α tan θ) (Walter 2007 eq. 27), and Walter's
        // rational fit (which Mitsuba evaluates) within its stated 0.35%.
        for alpha in ALPHAS {
            for theta in [0.0f32, 10.0, 45.0, 80.0, 89.0] {
                let v = dir(theta, 1.0);
                let got = f64::from(mf(MicrofacetType::Beckmann, alpha, true).g1_over_cos(v, Vec3::Z) * v.z);
                let a = 1.0 / (f64::from(alpha) * f64::from(theta).to_radians().tan());
                let exact = if a.is_finite() { 2.0 / (1.0 + libm::erf(a) + (-a * a).exp() / (a * SQRT_PI)) } else { 1.0 };
                assert!((got - exact).abs() < 1e-5, "α {alpha} θ {theta}: {got} vs {exact}");
                let fit = if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a * a) / (1.0 + 2.276 * a + 2.577 * a * a) };
                assert!((got - fit).abs() <= 0.0035 * fit + 1e-6, "α {alpha} θ {theta}: {got} vs fit {fit}");
            }
        }
    }

    /// χ² of the normal samplers themselves (the BSDF tests check the reflected directions).
    #[test]
    fn chi2_normal_samplers() {
        let mut failed = Vec::new();
        let cases = KINDS.len() * 2 * 5 * 3;
        for kind in KINDS {
            for visible in [true, false] {
                for alphas in [(0.1, 0.1), (0.5, 0.5), (1.0, 1.0), (0.05, 0.4), (0.7, 0.15)] {
                    for theta in [0.0f32, 50.0, 85.0] {
                        let m = aniso(kind, alphas, visible);
                        let wo = dir(theta, 0.3);
                        let test = Chi2Test {
                            sample_count: 200_000,
                            test_count: cases,
                            integral: PdfIntegral::One,
                            ..Chi2Test::default()
                        };
                        let out = test.run(
                            |s| {
                                let n = m.sample_normal(wo, s.next_2d());
                                Some((n, m.pdf_normal(wo, n)))
                            },
                            |n| m.pdf_normal(wo, n),
                        );
                        if !out.passed() {
                            failed.push(format!("{kind:?} visible {visible} α {alphas:?} θo {theta}: {out}"));
                        }
                    }
                }
            }
        }
        assert!(failed.is_empty(), "{}", failed.join("\n"));
    }

    #[test]
    fn samplers_stay_finite_at_extremes() {
        for kind in KINDS {
            for visible in [true, false] {
                for alphas in [(0.0f32, 0.0f32), (1e-7, 1e-7), (1e-4, 1e-4), (0.05, 0.05), (1.0, 1.0), (3.0, 3.0), (1e-7, 0.5), (3.0, 0.01)] {
                    for z in [1e-30f32, 1e-7, 1e-3, 1.0] {
                        let wo = Vec3::new((1.0 - z * z).sqrt(), 0.0, z);
                        for u in [Vec2::new(0.0, 0.0), Vec2::new(0.5, 0.5), Vec2::new(0.999_999, 0.25), Vec2::new(0.3, 0.999_999), Vec2::new(0.7, 0.75)] {
                                let n = aniso(kind, alphas, visible).sample_normal(wo, u);
                            assert!(n.is_finite() && n.z >= 0.0 && (n.length() - 1.0).abs() < 1e-4, "{kind:?} {alphas:?} {z} {u}: {n}");
                        }
                    }
                }
            }
        }
    }
}
