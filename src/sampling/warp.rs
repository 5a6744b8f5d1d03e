//! Warps from the unit square `[0,1)²` to other domains, each as a triplet:
//! `square_to_*` (sample), `*_pdf_*` (density of the sample, in the measure its name states) and
//! `*_to_square` (the inverse map, for round-trip tests and for stratifying in the primary space).
//!
//! Pdfs take the sampled value even when they are constant, so that every triplet reads the same
//! (Mitsuba 3's `warp` module does the same). Directions are unit vectors in a local frame with the pole on +z.

use crate::math::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// `φ = atan2(y, x)` remapped to `[0, 1)` (fraction of a full turn).
#[inline]
fn azimuth_fraction(y: f32, x: f32) -> f32 {
    let mut phi = y.atan2(x) * (1.0 / TAU);
    if phi < 0.0 {
        phi += 1.0;
    }
    // `phi` can round up to exactly 1.0 for tiny negative angles; [0, 1) is the contract.
    if phi >= 1.0 {
        0.0
    } else {
        phi
    }
}

// ---------------------------------------------------------------------------------------------------------
// Concentric disk (Shirley & Chiu 1997, "A Low Distortion Map Between Disk and Square"; pbrt-v4 §A.5.1).

/// `(sin x, cos x)` for `|x| ≤ π/4`, the range the concentric map needs, by their Taylor series to x⁹ and
/// x¹⁰ in Horner form: the truncation error is below x¹¹/11! ≈ 1.7·10⁻⁹ and x¹²/12! ≈ 1.1·10⁻¹⁰ there, so
/// the result is within f32 rounding of the true values (`sin_cos_quarter_is_accurate`). It replaces libm's
/// `sincosf` (its general range reduction and a call), which perf put at 1.8 % of a path-traced sample;
/// callgrind counted −0.8 % of the path tracer's instructions outside Embree (cornell mesh scene).
#[inline]
fn sin_cos_quarter(x: f32) -> (f32, f32) {
    debug_assert!(x.abs() <= FRAC_PI_4 * (1.0 + 1e-6), "sin_cos_quarter({x}) outside [-π/4, π/4]");
    let x2 = x * x;
    let sin = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (1.0 / 362_880.0)))));
    let cos = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40_320.0 + x2 * (-1.0 / 3_628_800.0)))));
    (sin, cos)
}

/// Uniform point on the unit disk by the concentric map, which keeps strata compact. In the sectors around
/// the y axis the angle is `π/2 − φ`, so `(cos, sin)` of it are `(sin φ, cos φ)`: both branches evaluate
/// one angle of at most π/4.
#[must_use]
pub fn square_to_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let uo = 2.0 * u - Vec2::ONE;
    if uo.x == 0.0 && uo.y == 0.0 {
        return Vec2::ZERO;
    }
    if uo.x.abs() > uo.y.abs() {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (uo.y / uo.x));
        uo.x * Vec2::new(cos, sin)
    } else {
        let (sin, cos) = sin_cos_quarter(FRAC_PI_4 * (uo.x / uo.y));
        uo.y * Vec2::new(sin, cos)
    }
}

/// Density of [`square_to_uniform_disk_concentric`] per unit area: `1/π` inside the unit disk.
#[must_use]
pub fn uniform_disk_pdf_a(p: Vec2) -> f32 {
    if p.length_squared() <= 1.0 {
        FRAC_1_PI
    } else {
        0.0
    }
}

/// Inverse of [`square_to_uniform_disk_concentric`] (pbrt-v4 `InvertUniformDiskConcentricSample`).
#[must_use]
pub fn uniform_disk_concentric_to_square(p: Vec2) -> Vec2 {
    let theta = p.y.atan2(p.x); // (−π, π]
    let r = p.length();
    let uo = if theta.abs() < FRAC_PI_4 || theta.abs() > 3.0 * FRAC_PI_4 {
        // Left/right wedges: r = uo.x, θ = π/4 · uo.y/uo.x (mod π).
        let r = r.copysign(p.x);
        let y = if p.x < 0.0 {
            if p.y < 0.0 {
                (PI + theta) * r / FRAC_PI_4
            } else {
                (theta - PI) * r / FRAC_PI_4
            }
        } else {
            theta * r / FRAC_PI_4
        };
        Vec2::new(r, y)
    } else {
        // Top/bottom wedges: r = uo.y, θ = π/2 − π/4 · uo.x/uo.y.
        let r = r.copysign(p.y);
        let x = if p.y < 0.0 {
            -(FRAC_PI_2 + theta) * r / FRAC_PI_4
        } else {
            (FRAC_PI_2 - theta) * r / FRAC_PI_4
        };
        Vec2::new(x, r)
    };
    ((uo + Vec2::ONE) * 0.5).clamp(Vec2::ZERO, Vec2::splat(1.0 - f32::EPSILON * 0.5))
}

// ---------------------------------------------------------------------------------------------------------
// Cosine-weighted hemisphere (Malley's method: lift a uniform disk point to the hemisphere; pbrt-v4 §A.5.3).

/// Direction on the +z hemisphere with density `cos θ / π` per solid angle.
#[must_use]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// `max(cos θ, 0) / π`.
#[must_use]
pub fn cosine_hemisphere_pdf_w(v: Vec3) -> f32 {
    v.z.max(0.0) * FRAC_1_PI
}

/// Inverse of [`square_to_cosine_hemisphere`]: project onto the disk, invert the concentric map.
#[must_use]
pub fn cosine_hemisphere_to_square(v: Vec3) -> Vec2 {
    uniform_disk_concentric_to_square(Vec2::new(v.x, v.y))
}

// ---------------------------------------------------------------------------------------------------------
// Uniform sphere (Archimedes: z is uniform on [−1, 1]; pbrt-v4 §A.5.2).

/// Uniform direction on the unit sphere, density `1/(4π)`.
#[must_use]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    // sin θ = sqrt((1 − z)(1 + z)) = 2·sqrt(u(1 − u)), without cancellation near the poles.
    let r = 2.0 * (u.x * (1.0 - u.x)).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `1/(4π)` for every direction.
#[must_use]
pub fn uniform_sphere_pdf_w(_v: Vec3) -> f32 {
    0.25 * FRAC_1_PI
}

/// Inverse of [`square_to_uniform_sphere`].
#[must_use]
pub fn uniform_sphere_to_square(v: Vec3) -> Vec2 {
    // u.x = (1 − z)/2; near the north pole use (1 − z) = (x² + y²)/(1 + z) to keep precision.
    let ux = if v.z > 0.0 {
        (v.x * v.x + v.y * v.y) / (2.0 * (1.0 + v.z))
    } else {
        0.5 * (1.0 - v.z)
    };
    Vec2::new(ux.min(1.0 - f32::EPSILON * 0.5), azimuth_fraction(v.y, v.x))
}

// ---------------------------------------------------------------------------------------------------------
// Uniform hemisphere (z uniform on [0, 1]).

/// Uniform direction on the +z hemisphere, density `1/(2π)`.
#[must_use]
pub fn square_to_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = ((1.0 - z) * (1.0 + z)).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `1/(2π)` on the +z hemisphere (z ≥ 0), 0 below.
#[must_use]
pub fn uniform_hemisphere_pdf_w(v: Vec3) -> f32 {
    if v.z >= 0.0 {
        0.5 * FRAC_1_PI
    } else {
        0.0
    }
}

/// Inverse of [`square_to_uniform_hemisphere`].
#[must_use]
pub fn uniform_hemisphere_to_square(v: Vec3) -> Vec2 {
    Vec2::new(v.z.clamp(0.0, 1.0 - f32::EPSILON * 0.5), azimuth_fraction(v.y, v.x))
}

// ---------------------------------------------------------------------------------------------------------
// Uniform cone around +z with half-angle θmax, `cos_cutoff = cos θmax` (cos θ uniform on [cos θmax, 1]).

/// Uniform direction in the cone `cos θ ≥ cos_cutoff`, density `1/(2π(1 − cos_cutoff))`.
#[must_use]
pub fn square_to_uniform_cone(u: Vec2, cos_cutoff: f32) -> Vec3 {
    // 1 − cos θ = u.x(1 − cos θmax); sin²θ = (1 − cos θ)(1 + cos θ) avoids cancellation for narrow cones.
    let one_minus_cos = u.x * (1.0 - cos_cutoff);
    let z = 1.0 - one_minus_cos;
    let r = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
    let phi = TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// `1/(2π(1 − cos_cutoff))` inside the cone, 0 outside. A degenerate cone (`cos_cutoff ≥ 1`) is a Dirac
/// direction with no density: 0.
#[must_use]
pub fn uniform_cone_pdf_w(v: Vec3, cos_cutoff: f32) -> f32 {
    let solid_angle = TAU * (1.0 - cos_cutoff);
    if v.z >= cos_cutoff && solid_angle > 0.0 {
        1.0 / solid_angle
    } else {
        0.0
    }
}

/// Inverse of [`square_to_uniform_cone`].
#[must_use]
pub fn uniform_cone_to_square(v: Vec3, cos_cutoff: f32) -> Vec2 {
    // 1 − cos θ = sin²θ/(1 + cos θ), precise near the axis.
    let one_minus_cos = (v.x * v.x + v.y * v.y) / (1.0 + v.z);
    let ux = if cos_cutoff < 1.0 {
        one_minus_cos / (1.0 - cos_cutoff)
    } else {
        0.0
    };
    Vec2::new(ux.clamp(0.0, 1.0 - f32::EPSILON * 0.5), azimuth_fraction(v.y, v.x))
}

// ---------------------------------------------------------------------------------------------------------
// Uniform triangle (the square-root map; Mitsuba 3 `square_to_uniform_triangle`, Arvo 1995).

/// Uniform barycentrics `(b1, b2)` on a triangle, so that `p = (1 − b1 − b2)·p0 + b1·p1 + b2·p2`.
#[must_use]
pub fn square_to_uniform_triangle(u: Vec2) -> (f32, f32) {
    let t = (1.0 - u.x).max(0.0).sqrt();
    (1.0 - t, t * u.y)
}

/// Density of [`square_to_uniform_triangle`] on the barycentric domain `{b1, b2 ≥ 0, b1 + b2 ≤ 1}` (area ½):
/// 2 inside, 0 outside. Per unit area of a triangle of area A the density is `1/A`.
#[must_use]
pub fn uniform_triangle_pdf(b: (f32, f32)) -> f32 {
    if b.0 >= 0.0 && b.1 >= 0.0 && b.0 + b.1 <= 1.0 {
        2.0
    } else {
        0.0
    }
}

/// Inverse of [`square_to_uniform_triangle`].
#[must_use]
pub fn uniform_triangle_to_square(b: (f32, f32)) -> Vec2 {
    let t = 1.0 - b.0;
    // u.x = 1 − t² = b1(2 − b1), without cancellation.
    let ux = b.0 * (2.0 - b.0);
    let uy = if t > 0.0 { b.1 / t } else { 0.0 };
    Vec2::new(ux, uy).clamp(Vec2::ZERO, Vec2::splat(1.0 - f32::EPSILON * 0.5))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use crate::sampling::chi2::{chi2_p_value, Chi2Test, PdfIntegral};

    fn random_squares(n: u64) -> impl Iterator<Item = Vec2> {
        (0..n).map(|i| Sampler::for_key(11, i, 0).next_2d())
    }

    /// Distance between two points of the unit square, modulo 1 in the azimuthal coordinate `y`
    /// when `periodic_y` (φ = 0 and φ = 2π are the same direction).
    fn square_dist(a: Vec2, b: Vec2, periodic_y: bool) -> f32 {
        let dx = (a.x - b.x).abs();
        let mut dy = (a.y - b.y).abs();
        if periodic_y {
            dy = dy.min(1.0 - dy);
        }
        dx.max(dy)
    }

    #[test]
    fn sin_cos_quarter_is_accurate() {
        let mut worst = 0.0f64;
        for i in 0..=100_000 {
            let x = FRAC_PI_4 * (i as f32 / 50_000.0 - 1.0);
            let (s, c) = sin_cos_quarter(x);
            let (s64, c64) = f64::from(x).sin_cos();
            worst = worst.max((f64::from(s) - s64).abs()).max((f64::from(c) - c64).abs());
        }
        // f32's spacing is 6·10⁻⁸ just below 1: within two of it.
        assert!(worst < 1.2e-7, "worst error {worst:e}");
        assert_eq!(sin_cos_quarter(0.0), (0.0, 1.0));
    }

    #[test]
    fn disk_round_trips() {
        for u in random_squares(20_000).chain([Vec2::ZERO, Vec2::splat(0.5), Vec2::new(0.999_999, 0.25), Vec2::new(0.1, 0.9)]) {
            let p = square_to_uniform_disk_concentric(u);
            assert!(p.length() <= 1.0 + 1e-6);
            assert!(uniform_disk_pdf_a(p) > 0.0);
            let back = uniform_disk_concentric_to_square(p);
            // The centre of the square maps to a single point: skip its neighbourhood's φ ambiguity.
            if p.length() > 1e-4 {
                assert!(square_dist(u, back, false) < 2e-4, "u {u} -> {p} -> {back}");
            }
            let p2 = square_to_uniform_disk_concentric(back);
            assert!((p - p2).length() < 1e-5);
        }
    }

    #[test]
    fn direction_warps_round_trip() {
        let cos_cutoff = 0.8f32;
        for u in random_squares(20_000) {
            // (sample, inverse, periodic in y, tolerance)
            let v = square_to_cosine_hemisphere(u);
            assert!((v.length() - 1.0).abs() < 1e-5 && v.z >= 0.0);
            assert!(square_dist(u, cosine_hemisphere_to_square(v), false) < 2e-4, "cosine {u}");
            assert!((square_to_cosine_hemisphere(cosine_hemisphere_to_square(v)) - v).length() < 1e-4);

            let v = square_to_uniform_sphere(u);
            assert!((v.length() - 1.0).abs() < 1e-5);
            assert!(square_dist(u, uniform_sphere_to_square(v), true) < 1e-4, "sphere {u} {v}");
            assert!((square_to_uniform_sphere(uniform_sphere_to_square(v)) - v).length() < 1e-4);

            let v = square_to_uniform_hemisphere(u);
            assert!((v.length() - 1.0).abs() < 1e-5 && v.z >= 0.0);
            assert!(square_dist(u, uniform_hemisphere_to_square(v), true) < 1e-4, "hemisphere {u}");

            let v = square_to_uniform_cone(u, cos_cutoff);
            assert!((v.length() - 1.0).abs() < 1e-5 && v.z >= cos_cutoff - 1e-6);
            assert!(uniform_cone_pdf_w(v, cos_cutoff) > 0.0);
            assert!(square_dist(u, uniform_cone_to_square(v, cos_cutoff), true) < 1e-4, "cone {u}");

            let b = square_to_uniform_triangle(u);
            assert!(uniform_triangle_pdf(b) == 2.0, "triangle {u} -> {b:?}");
            assert!(square_dist(u, uniform_triangle_to_square(b), false) < 1e-4, "triangle {u}");
        }
    }

    #[test]
    fn narrow_cone_keeps_precision() {
        // θmax = 1e-3 rad: 1 − cos θmax ≈ 5e-7, close to f32's resolution near 1.
        let cos_cutoff = (1e-3f64).cos() as f32;
        for u in random_squares(1000) {
            let v = square_to_uniform_cone(u, cos_cutoff);
            let sin_theta = (v.x * v.x + v.y * v.y).sqrt();
            assert!(sin_theta <= 1.001e-3, "{sin_theta}");
            assert!(v.is_finite());
        }
    }

    #[test]
    fn pdfs_are_zero_outside_their_domain() {
        assert_eq!(cosine_hemisphere_pdf_w(-Vec3::Z), 0.0);
        assert_eq!(uniform_hemisphere_pdf_w(Vec3::new(0.0, 0.6, -0.8)), 0.0);
        assert_eq!(uniform_cone_pdf_w(Vec3::X, 0.5), 0.0);
        assert_eq!(uniform_cone_pdf_w(Vec3::Z, 1.0), 0.0);
        assert_eq!(uniform_triangle_pdf((0.7, 0.7)), 0.0);
        assert_eq!(uniform_disk_pdf_a(Vec2::new(1.0, 0.5)), 0.0);
    }

    #[test]
    fn direction_warps_pass_chi2() {
        let test = Chi2Test {
            sample_count: 300_000,
            test_count: 4,
            integral: PdfIntegral::One,
            ..Chi2Test::default()
        };
        let cos_cutoff = 0.6f32;
        let outcomes = [
            (
                "cosine",
                test.run(
                    |s| with_pdf(square_to_cosine_hemisphere(s.next_2d()), cosine_hemisphere_pdf_w),
                    cosine_hemisphere_pdf_w,
                ),
            ),
            (
                "sphere",
                test.run(
                    |s| with_pdf(square_to_uniform_sphere(s.next_2d()), uniform_sphere_pdf_w),
                    uniform_sphere_pdf_w,
                ),
            ),
            (
                "hemisphere",
                test.run(
                    |s| with_pdf(square_to_uniform_hemisphere(s.next_2d()), uniform_hemisphere_pdf_w),
                    uniform_hemisphere_pdf_w,
                ),
            ),
            (
                "cone",
                test.run(
                    |s| {
                        with_pdf(square_to_uniform_cone(s.next_2d(), cos_cutoff), |v| {
                            uniform_cone_pdf_w(v, cos_cutoff)
                        })
                    },
                    |v| uniform_cone_pdf_w(v, cos_cutoff),
                ),
            ),
        ];
        for (name, out) in outcomes {
            assert!(out.passed(), "{name}: {out}");
        }
    }

    fn with_pdf(v: Vec3, pdf: impl Fn(Vec3) -> f32) -> Option<(Vec3, f32)> {
        Some((v, pdf(v)))
    }

    /// χ² over a partition of a 2-D domain into `cells` cells of equal probability.
    fn equal_cells_p_value(counts: &[u64]) -> f64 {
        let n: u64 = counts.iter().sum();
        let expected = n as f64 / counts.len() as f64;
        let stat: f64 = counts.iter().map(|&c| (c as f64 - expected).powi(2) / expected).sum();
        chi2_p_value(stat, counts.len() - 1)
    }

    #[test]
    fn disk_and_triangle_are_uniform() {
        // Disk: uniform ⇔ r² and φ independent and uniform; 8×8 cells in (r², φ/2π) of probability 1/64.
        let mut disk = vec![0u64; 64];
        // Triangle: the 4×4 subdivision into 16 congruent triangles, each of probability 1/16.
        let mut tri = vec![0u64; 32];
        for u in random_squares(200_000) {
            let p = square_to_uniform_disk_concentric(u);
            let i = ((p.length_squared() * 8.0) as usize).min(7);
            let j = ((azimuth_fraction(p.y, p.x) * 8.0) as usize).min(7);
            disk[i * 8 + j] += 1;
            let (b1, b2) = square_to_uniform_triangle(u);
            let (x, y) = (b1 * 4.0, b2 * 4.0);
            let (i, j) = ((x as usize).min(3), (y as usize).min(3));
            let upper = usize::from(x.fract() + y.fract() >= 1.0);
            tri[(i * 4 + j) * 2 + upper] += 1;
        }
        // Cells of the triangle subdivision that exist: lower (i + j ≤ 3) and upper (i + j ≤ 2).
        let tri_cells: Vec<u64> = (0..32).filter(|k| (k / 8) + (k / 2) % 4 + (k % 2) <= 3).map(|k| tri[k]).collect();
        assert_eq!(tri_cells.len(), 16);
        assert_eq!(tri_cells.iter().sum::<u64>(), 200_000, "samples outside the triangle cells");
        let (p_disk, p_tri) = (equal_cells_p_value(&disk), equal_cells_p_value(&tri_cells));
        // Šidák-corrected 1% level for 2 tests.
        let alpha = 1.0 - (1.0 - 0.01f64).powf(0.5);
        assert!(p_disk > alpha, "disk p = {p_disk}");
        assert!(p_tri > alpha, "triangle p = {p_tri}");
    }
}
