//! Cross-cutting BSDF tests: χ² of every sampler (several incident angles and roughness values), sampled
//! pdf == `pdf_w()`, sample weight == f·|cos|/pdf, reciprocity, one- and two-sidedness, energy (white furnace,
//! sampled albedo == integrated albedo), and no NaN at grazing angles. The reflecting BSDFs are tested
//! wrapped in `twosided` (so incident angles below the surface are covered) and alone (black from behind).

use crate::bsdf::{Blend, Conductor, Dielectric, Diffuse, Mask, Null, PPlastic, Phong, Plastic, RoughConductor, RoughDielectric, RoughPlastic, TwoSided, Ward, WardVariant};
use super::*;
use crate::sampler::Sampler;
use crate::sampling::chi2::{integrate_sphere, Chi2Outcome, Chi2Test, PdfIntegral};

const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];
/// Incident polar angles in degrees; > 90° is below the surface (two-sided reflection).
const KINDS: [MicrofacetType; 2] = [MicrofacetType::Beckmann, MicrofacetType::Ggx];
const THETAS: [f32; 6] = [0.0, 30.0, 60.0, 85.0, 120.0, 150.0];
const AU_ETA: Vec3 = Vec3::new(0.143, 0.374, 1.442);
const AU_K: Vec3 = Vec3::new(3.983, 2.385, 1.603);

fn dir(theta_deg: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta_deg.to_radians().sin_cos();
    Vec3::new(st * phi.cos(), st * phi.sin(), ct)
}

fn wo_at(theta_deg: f32) -> Vec3 {
    // An azimuth that is not a cell edge of the χ² grid.
    dir(theta_deg, 0.3)
}

fn two(b: Bsdf) -> Bsdf {
    Bsdf::TwoSided(TwoSided(Box::new(b)))
}

/// Two-sided Lambertian.
fn diffuse(r: f32) -> Bsdf {
    two(Bsdf::Diffuse(Diffuse {
        reflectance: Vec3::splat(r),
    }))
}

/// Two-sided GGX rough conductor (visible normals).
fn rough(alpha: f32, eta_k: Option<(Vec3, Vec3)>) -> Bsdf {
    rough_with(MicrofacetType::Ggx, alpha, true, eta_k)
}

/// Two-sided rough conductor.
fn rough_with(kind: MicrofacetType, alpha: f32, sample_visible: bool, eta_k: Option<(Vec3, Vec3)>) -> Bsdf {
    two(Bsdf::RoughConductor(RoughConductor {
        distribution: Microfacet::isotropic(kind, alpha, sample_visible),
        specular_reflectance: Vec3::ONE,
        eta_k,
    }))
}

fn blend(weight: f32, b0: Bsdf, b1: Bsdf) -> Bsdf {
    Bsdf::Blend(Blend {
        weight,
        bsdf_0: Box::new(b0),
        bsdf_1: Box::new(b1),
    })
}

/// Two-sided perfect mirror.
fn mask(opacity: f32, b: Bsdf) -> Bsdf {
    Bsdf::Mask(Mask { opacity, bsdf: Box::new(b) })
}

fn mirror() -> Bsdf {
    two(Bsdf::Conductor(Conductor {
        specular_reflectance: Vec3::new(0.9, 0.8, 0.7),
        eta_k: None,
    }))
}

/// χ² of the non-delta part of `bsdf`'s sampler at `wo`; delta samples count as "no direction".
fn chi2(test: &Chi2Test, bsdf: &Bsdf, wo: Vec3) -> Chi2Outcome {
    test.run(
        |s| {
            let u_lobe = s.next_1d();
            let u_dir = s.next_2d();
            bsdf.sample(wo, u_lobe, u_dir, TransportMode::Radiance)
                .filter(|b| !b.delta)
                .map(|b| (b.wi_local, b.pdf_w))
        },
        |wi| bsdf.pdf_w(wo, wi),
    )
}

/// Number of χ² tests in this file (6 diffuse + 2×4×6 rough conductor with visible normals + 2×2×3 without
/// + 2×3×4 anisotropic + 2×6×5 rough glass + 2×3×3 rough plastic + 6×2 + 6 + 3 blends + 4 plastic + 2×6 + 3
/// masks + 7×3 + 3 perturbed frames + 4×3 phong + 3×3 + 2×2 ward + 25 principled + 2×4×3 pplastic + 5×4
/// principledthin): the family the Šidák correction accounts for.
const CHI2_FAMILY: usize = 326;

/// A coloured plastic of polypropylene's index.
fn plastic() -> Bsdf {
    Bsdf::Plastic(Plastic::new(1.49, Vec3::new(0.8, 0.5, 0.2), Vec3::ONE, false))
}

fn run_chi2_suite(cases: &[(String, Bsdf, Vec3, PdfIntegral)], sample_count: usize) {
    let test = Chi2Test {
        sample_count,
        test_count: CHI2_FAMILY,
        ..Chi2Test::default()
    };
    let mut failed = Vec::new();
    let mut lowest: Option<(f64, String)> = None;
    for (name, bsdf, wo, integral) in cases {
        let out = chi2(
            &Chi2Test {
                integral: *integral,
                ..test.clone()
            },
            bsdf,
            *wo,
        );
        if !out.passed() {
            failed.push(format!("{name}: {out}"));
        }
        if lowest.as_ref().is_none_or(|(p, _)| out.p_value < *p) {
            lowest = Some((out.p_value, format!("{name}: {out}")));
        }
    }
    if let Some((_, out)) = lowest {
        eprintln!("{} χ² tests, the lowest p-value: {out}", cases.len());
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

#[test]
fn chi2_diffuse() {
    let cases: Vec<_> = THETAS
        .iter()
        .map(|&t| (format!("diffuse θo {t}"), diffuse(0.5), wo_at(t), PdfIntegral::One))
        .collect();
    run_chi2_suite(&cases, 300_000);
}

fn chi2_roughconductor(alpha: f32) {
    let cases: Vec<_> = KINDS
        .iter()
        .flat_map(|&kind| THETAS.iter().map(move |&t| (kind, t)))
        // Samples reflected below the horizon are lost: ∫pdf ≤ 1 (= 1 only in the limit α → 0, θo → 0).
        .map(|(kind, t)| {
            (
                format!("roughconductor {} α {alpha} θo {t}", kind.name()),
                rough_with(kind, alpha, true, Some((AU_ETA, AU_K))),
                wo_at(t),
                PdfIntegral::AtMostOne,
            )
        })
        .collect();
    run_chi2_suite(&cases, 400_000);
}

#[test]
fn chi2_roughconductor_alpha_0_05() {
    chi2_roughconductor(ALPHAS[0]);
}

#[test]
fn chi2_roughconductor_alpha_0_2() {
    chi2_roughconductor(ALPHAS[1]);
}

#[test]
fn chi2_roughconductor_alpha_0_6() {
    chi2_roughconductor(ALPHAS[2]);
}

#[test]
fn chi2_roughconductor_alpha_1() {
    chi2_roughconductor(ALPHAS[3]);
}

#[test]
fn chi2_roughconductor_without_visible_normals() {
    let mut cases = Vec::new();
    for kind in KINDS {
        for alpha in [0.1, 0.6] {
            for t in [20.0, 70.0, 150.0] {
                cases.push((
                    format!("roughconductor {} α {alpha} θo {t}, D·cos sampling", kind.name()),
                    rough_with(kind, alpha, false, None),
                    wo_at(t),
                    PdfIntegral::AtMostOne,
                ));
            }
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_roughconductor_anisotropic() {
    let mut cases = Vec::new();
    for kind in KINDS {
        for (alpha_u, alpha_v, sample_visible) in [(0.05, 0.4, true), (0.6, 0.1, true), (0.3, 0.08, false)] {
            for (t, phi) in [(0.0, 0.3), (45.0, 0.3), (70.0, 1.9), (150.0, 4.0)] {
                let distribution = Microfacet { kind, alpha_u, alpha_v, sample_visible };
                cases.push((
                    format!("roughconductor {} α ({alpha_u}, {alpha_v}) visible {sample_visible} θo {t} φo {phi}", kind.name()),
                    two(Bsdf::RoughConductor(RoughConductor { distribution, specular_reflectance: Vec3::ONE, eta_k: Some((AU_ETA, AU_K)) })),
                    dir(t, phi),
                    PdfIntegral::AtMostOne,
                ));
            }
        }
    }
    run_chi2_suite(&cases, 300_000);
}

/// Rough glass of relative index `eta`, white.
fn rough_glass(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, sample_visible: bool, eta: f32) -> Bsdf {
    Bsdf::RoughDielectric(RoughDielectric {
        distribution: Microfacet { kind, alpha_u, alpha_v, sample_visible },
        eta,
        specular_reflectance: Vec3::ONE,
        specular_transmittance: Vec3::ONE,
    })
}

/// The rough-glass configurations of the χ² tests: (α_u, α_v, sample_visible, η).
const GLASSES: [(f32, f32, bool, f32); 6] =
    [(0.05, 0.05, true, 1.5), (0.3, 0.3, true, 1.5), (0.1, 0.5, true, 1.33), (0.3, 0.3, false, 1.5), (0.6, 0.2, false, 1.5), (0.2, 0.2, true, 1.0 / 1.5)];
/// Incident angles for rough glass: outside (< 90°) and inside (> 90°), where total internal reflection starts
/// at 180° − 41.8° for η = 1.5.
const GLASS_THETAS: [f32; 5] = [0.0, 35.0, 75.0, 125.0, 160.0];

fn chi2_roughdielectric(kind: MicrofacetType) {
    let mut cases = Vec::new();
    for (alpha_u, alpha_v, visible, eta) in GLASSES {
        for t in GLASS_THETAS {
            cases.push((
                format!("roughdielectric {} α ({alpha_u}, {alpha_v}) visible {visible} η {eta} θo {t}", kind.name()),
                rough_glass(kind, alpha_u, alpha_v, visible, eta),
                dir(t, 0.3 + t.to_radians()),
                // Lost samples (reflected below the surface, refracted back): ∫pdf ≤ 1.
                PdfIntegral::AtMostOne,
            ));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_roughdielectric_ggx() {
    chi2_roughdielectric(MicrofacetType::Ggx);
}

#[test]
fn chi2_roughdielectric_beckmann() {
    chi2_roughdielectric(MicrofacetType::Beckmann);
}

/// A coloured rough plastic of polypropylene's index.
fn rough_plastic(kind: MicrofacetType, alpha: f32, sample_visible: bool) -> Bsdf {
    Bsdf::RoughPlastic(RoughPlastic::new(Microfacet::isotropic(kind, alpha, sample_visible), 1.49, Vec3::new(0.8, 0.5, 0.2), Vec3::ONE, false))
}

#[test]
fn chi2_roughplastic() {
    let mut cases = Vec::new();
    for kind in KINDS {
        for (alpha, visible) in [(0.05, true), (0.3, true), (0.2, false)] {
            for t in [0.0, 45.0, 80.0] {
                cases.push((
                    format!("roughplastic {} α {alpha} visible {visible} θo {t}", kind.name()),
                    two(rough_plastic(kind, alpha, visible)),
                    wo_at(t),
                    PdfIntegral::AtMostOne,
                ));
            }
        }
    }
    run_chi2_suite(&cases, 300_000);
}

/// Mitsuba's `pplastic` (RGB form): a coloured base, polypropylene's index, isotropic or anisotropic.
fn pplastic(kind: MicrofacetType, alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Bsdf {
    let md = Microfacet { kind, alpha_u, alpha_v, sample_visible };
    Bsdf::PPlastic(PPlastic::new(md, 1.49, Vec3::new(0.8, 0.5, 0.2), Vec3::ONE))
}

#[test]
fn chi2_pplastic() {
    let mut cases = Vec::new();
    for kind in KINDS {
        for (au, av, visible) in [(0.05, 0.05, true), (0.3, 0.3, true), (0.2, 0.2, false), (0.1, 0.4, true)] {
            for t in [0.0, 45.0, 80.0] {
                cases.push((
                    format!("pplastic {} α {au}/{av} visible {visible} θo {t}", kind.name()),
                    two(pplastic(kind, au, av, visible)),
                    wo_at(t),
                    PdfIntegral::AtMostOne,
                ));
            }
        }
    }
    run_chi2_suite(&cases, 300_000);
}

/// Mitsuba 0.6's `phong`, coloured, with 0.6's energy scale of 1.
fn phong(exponent: f32, diffuse: Vec3, specular: Vec3) -> Bsdf {
    Bsdf::Phong(Phong::new(exponent, diffuse, specular, 1.0))
}

/// Mitsuba 0.6's `ward`, coloured.
fn ward(variant: WardVariant, alpha_u: f32, alpha_v: f32) -> Bsdf {
    Bsdf::Ward(Ward::new(variant, alpha_u, alpha_v, Vec3::new(0.5, 0.3, 0.2), Vec3::new(0.3, 0.4, 0.2), 1.0))
}

#[test]
fn chi2_phong() {
    let mut cases = Vec::new();
    for n in [1.0, 10.0, 60.0, 400.0] {
        for t in [0.0, 45.0, 80.0] {
            // Mostly the glossy lobe (w ≈ 0.63), whose directions below the surface are lost.
            let b = two(phong(n, Vec3::new(0.2, 0.1, 0.1), Vec3::new(0.3, 0.3, 0.2)));
            cases.push((format!("phong n {n} θo {t}"), b, wo_at(t), PdfIntegral::AtMostOne));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_ward() {
    let mut cases = Vec::new();
    for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.1, 0.4)] {
        for t in [0.0, 45.0, 80.0] {
            cases.push((format!("ward balanced α ({au}, {av}) θo {t}"), two(ward(WardVariant::Balanced, au, av)), wo_at(t), PdfIntegral::AtMostOne));
        }
    }
    // The sampler is the same for every variant (only f differs); the other two, anisotropic, seen from
    // another azimuth.
    for v in [WardVariant::Ward, WardVariant::WardDuer] {
        for t in [30.0, 70.0] {
            cases.push((format!("ward {v:?} α (0.4, 0.1) θo {t} φo 1.1"), two(ward(v, 0.4, 0.1)), dir(t, 1.1), PdfIntegral::AtMostOne));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_blend_diffuse_roughconductor() {
    let mut cases = Vec::new();
    for t in THETAS {
        for alpha in [0.05, 0.2] {
            let b = blend(0.3, diffuse(0.8), rough_with(KINDS[(alpha > 0.1) as usize], alpha, true, None));
            cases.push((
                format!("diffuse+roughconductor(α {alpha}) w 0.3, θo {t}"),
                b,
                wo_at(t),
                PdfIntegral::AtMostOne,
            ));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_blends_with_delta_components() {
    let mut cases = Vec::new();
    for t in THETAS {
        // A delta component: its samples (probability 0.3) are the χ² "no direction" cell.
        cases.push((
            format!("diffuse+mirror w 0.3, θo {t}"),
            blend(0.3, diffuse(0.8), mirror()),
            wo_at(t),
            PdfIntegral::AtMostOne,
        ));
    }
    // Nested: diffuse + (roughconductor + glass).
    let nested = blend(0.5, diffuse(0.5), blend(0.4, rough(0.3, None), Bsdf::Dielectric(Dielectric { eta: 1.5 })));
    for t in [10.0, 70.0, 160.0] {
        cases.push((format!("nested blend θo {t}"), nested.clone(), wo_at(t), PdfIntegral::AtMostOne));
    }
    // plastic: the coating's delta reflection (probability p_s(θo)) and the cosine-weighted base.
    for t in [0.0, 30.0, 60.0, 85.0] {
        cases.push((format!("plastic θo {t}"), plastic(), wo_at(t), PdfIntegral::AtMostOne));
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn chi2_detects_a_wrong_microfacet_pdf() {
    // The rough-conductor sampler judged against the pdf of *full* (not visible) normal sampling,
    // D(h)·cos θh/(4|wo·h|) (Walter 2007 eq. 14), which a mix-up would produce: the harness must reject it.
    let (alpha, wo) = (0.6, wo_at(60.0));
    let b = rough(alpha, None);
    let wrong = |wi: Vec3| {
        if wi.z <= 0.0 {
            return 0.0;
        }
        let h = (wo + wi).normalize();
        Microfacet::isotropic(MicrofacetType::Ggx, alpha, true)
        .d(h)
            * h.z
            / (4.0 * wo.dot(h))
    };
    let out = Chi2Test {
        sample_count: 200_000,
        ..Chi2Test::default()
    }
    .run(
        |s| {
            let (u_lobe, u_dir) = (s.next_1d(), s.next_2d());
            b.sample(wo, u_lobe, u_dir, TransportMode::Radiance)
                .map(|x| (x.wi_local, wrong(x.wi_local)))
        },
        wrong,
    );
    assert!(!out.passed() && out.p_value < 1e-6, "{out}");
}

#[test]
fn chi2_mask() {
    // The pass-through (probability 1 − α) and any delta lobe of the nested BSDF are the "no direction" cell.
    let mut cases = Vec::new();
    for t in THETAS {
        cases.push((format!("mask 0.6 twosided diffuse, θo {t}"), mask(0.6, two(diffuse(0.8))), wo_at(t), PdfIntegral::AtMostOne));
        cases.push((format!("mask 0.3 twosided roughconductor, θo {t}"), mask(0.3, two(rough(0.2, None))), wo_at(t), PdfIntegral::AtMostOne));
    }
    for t in [0.0, 45.0, 80.0] {
        cases.push((format!("mask 0.5 diffuse+mirror, θo {t}"), mask(0.5, blend(0.3, diffuse(0.8), mirror())), wo_at(t), PdfIntegral::AtMostOne));
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn mask_passes_one_minus_opacity_straight_through_and_null_everything() {
    for t in THETAS {
        let wo = wo_at(t);
        for alpha in [0.0, 0.25, 1.0] {
            let m = mask(alpha, two(diffuse(1.0)));
            // Furnace: α of the white base plus 1 − α passed through.
            let (albedo, se) = sampled_albedo(&m, wo, 100_000);
            assert!((albedo - Vec3::ONE).abs().max_element() < 5.0 * se.max_element() + 1e-5, "α {alpha} θo {t}: {albedo}");
            let through = m.sample(wo, 0.999_9, Vec2::new(0.3, 0.7), TransportMode::Radiance);
            if alpha < 1.0 {
                let s = through.unwrap();
                assert_eq!((s.wi_local, s.weight, s.pdf_w, s.delta), (-wo, Vec3::ONE, 1.0 - alpha, true));
            } else {
                assert!(through.is_none_or(|s| !s.delta), "α = 1 never passes through");
            }
            let wi = wo_at(40.0 + t / 4.0);
            assert_eq!(m.f(wo, wi, TransportMode::Radiance), alpha * two(diffuse(1.0)).f(wo, wi, TransportMode::Radiance));
        }
        let s = Bsdf::Null(Null).sample(wo, 0.5, Vec2::new(0.1, 0.2), TransportMode::Importance).unwrap();
        assert_eq!((s.wi_local, s.weight, s.pdf_w, s.delta), (-wo, Vec3::ONE, 1.0, true));
        assert_eq!(Bsdf::Null(Null).f_pdf(wo, wo_at(30.0), TransportMode::Radiance), (Vec3::ZERO, 0.0));
    }
}

/// Every non-delta BSDF configuration the consistency tests sweep.
fn non_delta_zoo() -> Vec<Bsdf> {
    let mut v = vec![
        diffuse(0.7),
        two(Bsdf::Diffuse(Diffuse {
            reflectance: Vec3::new(0.9, 0.5, 0.1),
        })),
    ];
    for alpha in ALPHAS {
        for kind in KINDS {
            v.push(rough_with(kind, alpha, true, None));
            v.push(two(Bsdf::RoughConductor(RoughConductor {
                distribution: Microfacet::isotropic(kind, alpha, alpha < 0.5),
                specular_reflectance: Vec3::new(0.9, 0.8, 0.6),
                eta_k: Some((AU_ETA, AU_K)),
            })));
        }
    }
    for kind in KINDS {
        v.push(two(Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet { kind, alpha_u: 0.08, alpha_v: 0.5, sample_visible: kind == MicrofacetType::Ggx },
            specular_reflectance: Vec3::new(0.9, 0.8, 0.6),
            eta_k: Some((AU_ETA, AU_K)),
        })));
    }
    v.push(blend(0.3, diffuse(0.8), rough(0.2, Some((AU_ETA, AU_K)))));
    v.push(blend(0.3, diffuse(0.8), mirror()));
    v.push(mask(0.6, two(diffuse(0.8))));
    v.push(mask(0.4, two(rough(0.3, Some((AU_ETA, AU_K))))));
    v.push(two(plastic()));
    v.push(two(rough_plastic(MicrofacetType::Beckmann, 0.1, true)));
    v.push(two(rough_plastic(MicrofacetType::Ggx, 0.4, false)));
    v.push(two(pplastic(MicrofacetType::Beckmann, 0.1, 0.1, true)));
    v.push(two(pplastic(MicrofacetType::Ggx, 0.1, 0.4, false)));
    v.push(two(phong(30.0, Vec3::new(0.5, 0.3, 0.1), Vec3::new(0.3, 0.4, 0.2))));
    v.push(two(phong(1.0, Vec3::splat(0.1), Vec3::splat(0.8))));
    v.push(two(phong(500.0, Vec3::ZERO, Vec3::ONE)));
    for variant in [WardVariant::Ward, WardVariant::WardDuer, WardVariant::Balanced] {
        v.push(two(ward(variant, 0.08, 0.5)));
    }
    v.push(two(ward(WardVariant::Balanced, 0.2, 0.2)));
    v.push(blend(
        0.5,
        diffuse(0.5),
        blend(0.4, rough(0.3, None), Bsdf::Dielectric(Dielectric { eta: 1.5 })),
    ));
    v
}

#[test]
fn sample_reports_pdf_w_and_weight_consistently() {
    for (k, bsdf) in non_delta_zoo().iter().enumerate() {
        for i in 0..20_000u64 {
            let mut s = Sampler::for_key(31, k as u64, i);
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let Some(smp) = bsdf.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) else {
                continue;
            };
            let wi = smp.wi_local;
            assert!((wi.length() - 1.0).abs() < 1e-5 && smp.weight.is_finite() && smp.weight.min_element() >= 0.0);
            if smp.delta {
                assert!(smp.pdf_w > 0.0 && smp.pdf_w <= 1.0);
                continue;
            }
            // Reflection only: wi on wo's side.
            assert!(wi.z * wo.z > 0.0, "{bsdf:?}: wo {wo} wi {wi}");
            // The same code computes both: bit-identical.
            assert_eq!(smp.pdf_w, bsdf.pdf_w(wo, wi), "{bsdf:?}");
            let want = bsdf.f(wo, wi, TransportMode::Radiance) * wi.z.abs() / smp.pdf_w;
            assert!(
                (smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6),
                "{bsdf:?}: {} vs {want}",
                smp.weight
            );
        }
    }
}

#[test]
fn reciprocity_and_two_sidedness() {
    let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    for (k, bsdf) in non_delta_zoo().iter().enumerate() {
        let mut s = Sampler::for_key(32, k as u64, 0);
        for _ in 0..5_000 {
            let wo = crate::sampling::warp::square_to_uniform_hemisphere(s.next_2d());
            let wi = crate::sampling::warp::square_to_uniform_hemisphere(s.next_2d());
            let a = bsdf.f(wo, wi, TransportMode::Radiance);
            let b = bsdf.f(wi, wo, TransportMode::Radiance);
            assert!(
                (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1e-3),
                "{bsdf:?}: f(wo,wi) {a} f(wi,wo) {b}"
            );
            // Mode does not matter for reflection.
            assert_eq!(a, bsdf.f(wo, wi, TransportMode::Importance));
            // Two-sided: the mirrored configuration reflects identically.
            assert_eq!(a, bsdf.f(flip(wo), flip(wi), TransportMode::Radiance));
            assert_eq!(bsdf.pdf_w(wo, wi), bsdf.pdf_w(flip(wo), flip(wi)));
            // Nothing crosses the surface.
            assert_eq!(bsdf.f(wo, flip(wi), TransportMode::Radiance), Vec3::ZERO);
            assert_eq!(bsdf.pdf_w(flip(wo), wi), 0.0);
        }
    }
}

/// Monte Carlo albedo from the sampler: mean weight and its standard error (None counts as 0).
fn sampled_albedo(bsdf: &Bsdf, wo: Vec3, n: u64) -> (Vec3, Vec3) {
    let (mut sum, mut sum2) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
    for i in 0..n {
        let mut s = Sampler::for_key(33, i, 0);
        if let Some(smp) = bsdf.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) {
            let w = smp.weight.as_dvec3();
            sum += w;
            sum2 += w * w;
        }
    }
    let mean = sum / n as f64;
    let var = (sum2 / n as f64 - mean * mean).max(glam::DVec3::ZERO);
    let se = var / n as f64;
    (mean.as_vec3(), glam::DVec3::new(se.x.sqrt(), se.y.sqrt(), se.z.sqrt()).as_vec3())
}

#[test]
fn white_furnace_diffuse() {
    for t in THETAS {
        let (albedo, _) = sampled_albedo(&diffuse(1.0), wo_at(t), 50_000);
        // Every weight is R = 1 up to rounding.
        assert!((albedo - Vec3::ONE).abs().max_element() < 1e-5, "θo {t}: {albedo}");
        let integral = integrate_sphere(|wi| diffuse(1.0).f(wo_at(t), wi, TransportMode::Radiance).x * wi.z.abs());
        assert!((integral - 1.0).abs() < 1e-5, "θo {t}: ∫f cos = {integral}");
    }
}

#[test]
fn roughconductor_energy() {
    for (alpha, kind) in ALPHAS.iter().flat_map(|&a| KINDS.iter().map(move |&k| (a, k))) {
        for t in THETAS {
            let bsdf = rough_with(kind, alpha, true, None);
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&bsdf, wo, 200_000);
            let integral = integrate_sphere(|wi| bsdf.f(wo, wi, TransportMode::Radiance).x * wi.z.abs()) as f32;
            // The sampler's estimate is unbiased: agrees with the integrated albedo within 5σ (+ quadrature error).
            assert!(
                (albedo.x - integral).abs() <= 5.0 * se.x + 2e-3 * integral,
                "{kind:?} α {alpha} θo {t}: sampled {albedo} ± {se} vs ∫ {integral}"
            );
            // Energy: a white rough conductor does not create energy (weight = G1(wi) ≤ 1 per sample).
            assert!(
                albedo.max_element() <= 1.0 && integral <= 1.0 + 1e-3,
                "α {alpha} θo {t}: {albedo} {integral}"
            );
        }
    }
    // Little energy lost to single scattering at low roughness near normal incidence.
    for t in [0.0, 30.0] {
        let (albedo, _) = sampled_albedo(&rough(0.2, None), wo_at(t), 100_000);
        assert!(albedo.x >= 0.9 && albedo.x <= 1.0, "θo {t}: {albedo}");
    }
}

/// White furnace of 0.6's `phong` and `balanced` `ward` (diffuse + specular = 1, two-sided): the sampler's
/// mean is the integrated albedo and neither creates energy (Phong loses some towards grazing angles, as
/// 0.6's model does; `ward-duer`, which can exceed 1 there, is in `ward`'s own tests).
#[test]
fn phong_and_balanced_ward_furnace() {
    let mut cases = Vec::new();
    for n in [0.0, 5.0, 80.0] {
        cases.push((format!("phong n {n}"), two(phong(n, Vec3::splat(0.4), Vec3::splat(0.6)))));
    }
    for (au, av) in [(0.05, 0.05), (0.5, 0.5), (0.1, 0.4)] {
        let w = Ward::new(WardVariant::Balanced, au, av, Vec3::splat(0.3), Vec3::splat(0.7), 1.0);
        cases.push((format!("ward α ({au}, {av})"), two(Bsdf::Ward(w))));
    }
    for (name, bsdf) in &cases {
        for t in THETAS {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(bsdf, wo, 100_000);
            let integral = integrate_sphere(|wi| bsdf.f(wo, wi, TransportMode::Radiance).x * wi.z.abs()) as f32;
            assert!((albedo.x - integral).abs() <= 5.0 * se.x + 2e-3 * integral, "{name} θo {t}: sampled {albedo} ± {se} vs ∫ {integral}");
            assert!(albedo.x <= 1.0 + 5.0 * se.x && integral <= 1.0 + 2e-3, "{name} θo {t}: {albedo} {integral}");
        }
    }
}

#[test]
fn blend_energy_is_the_weighted_sum() {
    let (d, rc) = (Vec3::new(0.8, 0.6, 0.4), rough(0.2, Some((AU_ETA, AU_K))));
    let b = blend(0.3, two(Bsdf::Diffuse(Diffuse { reflectance: d })), rc.clone());
    for t in [0.0, 45.0, 80.0, 130.0] {
        let wo = wo_at(t);
        let (albedo, se) = sampled_albedo(&b, wo, 200_000);
        let channel = |c: usize| integrate_sphere(|wi| rc.f(wo, wi, TransportMode::Radiance)[c] * wi.z.abs()) as f32;
        let rc_albedo = Vec3::new(channel(0), channel(1), channel(2));
        let want = 0.7 * d + 0.3 * rc_albedo;
        assert!(
            ((albedo - want).abs() - 5.0 * se - 2e-3 * want).max_element() <= 0.0,
            "θo {t}: {albedo} ± {se} vs {want}"
        );
    }
    // Diffuse + mirror: 0.7·R_d + 0.3·R_mirror.
    let b = blend(0.3, two(Bsdf::Diffuse(Diffuse { reflectance: d })), mirror());
    for t in [20.0, 100.0] {
        let (albedo, se) = sampled_albedo(&b, wo_at(t), 200_000);
        let want = 0.7 * d + 0.3 * Vec3::new(0.9, 0.8, 0.7);
        assert!(
            ((albedo - want).abs() - 5.0 * se).max_element() <= 1e-6,
            "θo {t}: {albedo} ± {se} vs {want}"
        );
    }
}

#[test]
fn blend_delta_sample_reports_selection_probability() {
    let b = blend(0.3, diffuse(0.8), mirror());
    let wo = wo_at(40.0);
    // u_lobe ≥ 0.7 selects the mirror.
    let s = b.sample(wo, 0.85, Vec2::new(0.3, 0.3), TransportMode::Radiance).expect("mirror");
    assert!(s.delta && (s.pdf_w - 0.3).abs() < 1e-7 && s.weight == Vec3::new(0.9, 0.8, 0.7));
    let s = b.sample(wo, 0.2, Vec2::new(0.3, 0.3), TransportMode::Radiance).expect("diffuse");
    assert!(!s.delta && (s.pdf_w - 0.7 * s.wi_local.z / std::f32::consts::PI).abs() < 1e-6);
    // Glass inside a blend: the Fresnel choice happens with the rescaled u_lobe.
    let g = blend(0.5, diffuse(0.5), Bsdf::Dielectric(Dielectric { eta: 1.5 }));
    let (r, ..) = fresnel_dielectric(1.0, 1.5);
    let s = g
        .sample(Vec3::Z, 0.5 + 0.5 * 0.5 * r, Vec2::ZERO, TransportMode::Radiance)
        .expect("reflection");
    assert!(s.delta && s.wi_local.z > 0.0 && (s.pdf_w - 0.5 * r).abs() < 1e-7);
    let s = g.sample(Vec3::Z, 0.99, Vec2::ZERO, TransportMode::Radiance).expect("refraction");
    assert!(s.delta && s.wi_local.z < 0.0 && (s.pdf_w - 0.5 * (1.0 - r)).abs() < 1e-6);
}

#[test]
fn delta_flags() {
    assert!(!diffuse(1.0).has_delta() && diffuse(1.0).has_non_delta());
    assert!(!rough(0.1, None).has_delta() && rough(0.1, None).has_non_delta());
    let dm = blend(0.3, diffuse(1.0), mirror());
    assert!(dm.has_delta() && dm.has_non_delta());
    // A component with zero weight is never sampled.
    assert!(!blend(0.0, diffuse(1.0), mirror()).has_delta());
    assert!(!blend(1.0, diffuse(1.0), mirror()).has_non_delta());
    assert!(!diffuse(0.0).has_non_delta() && !diffuse(0.0).has_delta(), "a black lobe scatters nothing");
    assert!(!blend(0.5, diffuse(0.0), mirror()).has_non_delta());
    assert!(blend(1.0, diffuse(1.0), mirror()).has_delta());
    // A mask passes light through where it is not opaque; null everywhere.
    assert!(mask(0.5, diffuse(1.0)).has_delta() && mask(0.5, diffuse(1.0)).has_non_delta() && mask(0.5, diffuse(1.0)).transmits());
    assert!(!mask(1.0, diffuse(1.0)).has_delta() && !mask(1.0, diffuse(1.0)).transmits());
    assert!(!mask(0.0, diffuse(1.0)).has_non_delta());
    let null = Bsdf::Null(Null);
    assert!(null.has_delta() && !null.has_non_delta() && null.transmits());
    assert!(phong(30.0, Vec3::ZERO, Vec3::splat(0.1)).has_non_delta() && !phong(30.0, Vec3::ZERO, Vec3::ZERO).has_non_delta());
    assert!(!ward(WardVariant::Ward, 0.1, 0.1).has_delta() && ward(WardVariant::Ward, 0.1, 0.1).has_non_delta());
}

/// `chooses_lobe` is false exactly where `sample` ignores `u_lobe` (the path tracer then spares the sampler a
/// dimension): the same sample for any `u_lobe` there, and some `u_lobe` that changes the sample elsewhere.
#[test]
fn chooses_lobe_exactly_where_u_lobe_is_read() {
    let dielectric = Bsdf::Dielectric(Dielectric { eta: 1.5 });
    let cases = [
        (diffuse(0.8), false),
        (two(diffuse(0.8)), false),
        (rough(0.2, None), false),
        (two(rough(0.2, None)), false),
        (mirror(), false),
        (dielectric.clone(), true),
        (blend(0.5, diffuse(1.0), mirror()), true),
        (two(blend(0.5, diffuse(1.0), rough(0.3, None))), true),
        (mask(0.5, two(diffuse(0.8))), true),
        (Bsdf::Null(Null), false),
        (phong(20.0, Vec3::splat(0.4), Vec3::splat(0.5)), true),
        (two(ward(WardVariant::Balanced, 0.2, 0.2)), true),
    ];
    let key = |s: Option<BsdfSample>| s.map(|s| (s.wi_local, s.weight, s.pdf_w, s.delta));
    for (bsdf, chooses) in cases {
        assert_eq!(bsdf.chooses_lobe(), chooses, "{bsdf:?}");
        let mut sampler = Sampler::for_key(7, 0, 0);
        let mut read = false;
        for _ in 0..200 {
            let (wo, u_dir) = (wo_at(10.0 + 70.0 * sampler.next_1d()), sampler.next_2d());
            let wo = if sampler.next_1d() < 0.5 { wo } else { Vec3::new(wo.x, wo.y, -wo.z) };
            let first = key(bsdf.sample(wo, 0.0, u_dir, TransportMode::Radiance));
            read |= [0.3, 0.6, 0.97].iter().any(|&u| key(bsdf.sample(wo, u, u_dir, TransportMode::Radiance)) != first);
        }
        assert_eq!(read, chooses, "{bsdf:?}: u_lobe read {read}");
    }
}

#[test]
fn never_nan_at_grazing_or_degenerate_input() {
    let mut zoo = non_delta_zoo();
    zoo.extend([
        mirror(),
        Bsdf::Conductor(Conductor {
            specular_reflectance: Vec3::ONE,
            eta_k: Some((AU_ETA, AU_K)),
        }),
        Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE }),
        Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(MicrofacetType::Beckmann, 0.3, true),
            specular_reflectance: Vec3::ONE,
            eta_k: None,
        }),
        Bsdf::Dielectric(Dielectric { eta: 1.5 }),
        Bsdf::Dielectric(Dielectric { eta: 1.0 }),
        Bsdf::Dielectric(Dielectric { eta: 1.0 / 1.33 }),
        rough(0.0, None),
        rough(1e-7, Some((AU_ETA, AU_K))),
        rough_with(MicrofacetType::Beckmann, 0.0, true, None),
        rough_with(MicrofacetType::Beckmann, 1e-7, false, Some((AU_ETA, AU_K))),
        rough_with(MicrofacetType::Beckmann, 2.0, true, None),
        blend(0.0, diffuse(1.0), rough(0.5, None)),
        blend(1.0, diffuse(1.0), Bsdf::Dielectric(Dielectric { eta: 1.5 })),
        rough_glass(MicrofacetType::Ggx, 0.0, 0.0, true, 1.5),
        rough_glass(MicrofacetType::Beckmann, 1e-7, 0.3, true, 1.0 / 1.33),
        rough_glass(MicrofacetType::Beckmann, 2.0, 2.0, false, 1.5),
        rough_glass(MicrofacetType::Ggx, 0.2, 0.2, true, 1.0),
        blend(0.5, diffuse(0.5), rough_glass(MicrofacetType::Ggx, 0.1, 0.1, true, 1.5)),
        rough_plastic(MicrofacetType::Beckmann, 1e-7, true),
        rough_plastic(MicrofacetType::Ggx, 3.0, false),
        phong(0.0, Vec3::splat(0.5), Vec3::splat(0.5)),
        phong(1e5, Vec3::splat(0.5), Vec3::splat(0.5)),
        phong(-3.0, Vec3::ZERO, Vec3::ONE),
        phong(30.0, Vec3::ZERO, Vec3::ZERO),
        ward(WardVariant::WardDuer, 1e-4, 1e-4),
        ward(WardVariant::Ward, 0.0, 2.0),
        ward(WardVariant::Balanced, 3.0, 3.0),
        principled("roughness = 0\nspec_trans = 1\neta = 1"),
        principled("roughness = 0\nanisotropic = 1\nclearcoat = 1\nclearcoat_gloss = 1\nmetallic = 0.5\nspec_trans = 0.5\nflatness = 1\nsheen = 1\nsheen_tint = 1\nspec_tint = 1"),
        principled("base_color = 0\nspecular = 0\nspec_trans = 1"),
        principled("roughness = 1\nanisotropic = 1\nspec_trans = 0.3\neta = 0.6"),
        principled("main_specular_sampling_rate = 0\ndiffuse_reflectance_sampling_rate = 0\nclearcoat_sampling_rate = 0"),
        principledthin("roughness = 0\nspec_trans = 1\neta = 1\nanisotropic = 1\nspec_tint = 1\nbase_color = 0"),
        principledthin("roughness = 1\nspec_trans = 0.5\ndiff_trans = 2\nsheen = 1\nsheen_tint = 1\nflatness = 1\neta = 0.1"),
        principledthin("spec_trans = 0.5\ndiff_trans = 1\nspecular_reflectance_sampling_rate = 0\nspecular_transmittance_sampling_rate = 0\ndiffuse_reflectance_sampling_rate = 0\ndiffuse_transmittance_sampling_rate = 0"),
    ]);
    let tiny = [0.0f32, 1e-45, 1e-38, 1e-30, 1e-20, 1e-8, 1e-4];
    let mut wos = Vec::new();
    for z in tiny {
        for sign in [1.0f32, -1.0] {
            wos.push(Vec3::new((1.0 - z * z).sqrt(), 0.0, sign * z));
        }
    }
    wos.extend([Vec3::Z, -Vec3::Z, Vec3::X, Vec3::Y]);
    let us = [
        Vec2::ZERO,
        Vec2::new(0.5, 0.5),
        Vec2::splat(ONE_MINUS_EPSILON),
        Vec2::new(0.0, ONE_MINUS_EPSILON),
        Vec2::new(0.25, 0.0),
    ];
    for bsdf in &zoo {
        for &wo in &wos {
            for &wi in &wos {
                let (f, p) = (bsdf.f(wo, wi, TransportMode::Radiance), bsdf.pdf_w(wo, wi));
                assert!(
                    f.is_finite() && f.min_element() >= 0.0 && p.is_finite() && p >= 0.0,
                    "{bsdf:?} {wo} {wi}: {f} {p}"
                );
            }
            for u_lobe in [0.0, 0.5, ONE_MINUS_EPSILON] {
                for &u in &us {
                    for mode in [TransportMode::Radiance, TransportMode::Importance] {
                        let s = bsdf.sample(wo, u_lobe, u, mode);
                        if wo.z == 0.0 {
                            assert!(s.is_none(), "{bsdf:?}: tangent wo must not scatter");
                        }
                        if let Some(s) = s {
                            assert!(
                                s.wi_local.is_finite() && s.weight.is_finite() && s.pdf_w.is_finite() && s.pdf_w > 0.0,
                                "{bsdf:?} {wo}: {s:?}"
                            );
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn fused_f_pdf_is_bit_identical_to_separate_calls() {
    let gold = Some((Vec3::new(0.143, 0.374, 1.442), Vec3::new(3.983, 2.385, 1.603)));
    let cases = [
        diffuse(0.7),
        rough(0.05, None),
        rough(0.3, gold),
        rough_with(MicrofacetType::Beckmann, 0.3, true, gold),
        rough_with(MicrofacetType::Beckmann, 0.3, false, None),
        Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE }),
        blend(0.5, diffuse(0.5), rough(0.1, None)),
        blend(0.3, diffuse(0.5), mirror()),
        mirror(),
        Bsdf::Dielectric(Dielectric { eta: 1.5 }),
        rough_glass(MicrofacetType::Ggx, 0.2, 0.2, true, 1.5),
        rough_glass(MicrofacetType::Beckmann, 0.1, 0.4, false, 1.33),
        rough_plastic(MicrofacetType::Ggx, 0.2, true),
        phong(30.0, Vec3::splat(0.5), Vec3::splat(0.3)),
        ward(WardVariant::Balanced, 0.1, 0.3),
    ];
    let mut s = Sampler::for_key(11, 0, 0);
    for bsdf in &cases {
        for _ in 0..2000 {
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let wi = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let (f, pdf) = bsdf.f_pdf(wo, wi, TransportMode::Radiance);
            assert_eq!(f, bsdf.f(wo, wi, TransportMode::Radiance), "{bsdf:?}");
            assert_eq!(pdf.to_bits(), bsdf.pdf_w(wo, wi).to_bits(), "{bsdf:?}");
        }
    }
}

#[test]
fn one_sided_bsdfs_are_black_from_behind_and_twosided_mirrors_them() {
    let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    let one_sided = [
        Bsdf::Diffuse(Diffuse { reflectance: Vec3::splat(0.7) }),
        Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(MicrofacetType::Beckmann, 0.3, true),
            specular_reflectance: Vec3::ONE,
            eta_k: Some((AU_ETA, AU_K)),
        }),
        Bsdf::Conductor(Conductor {
            specular_reflectance: Vec3::ONE,
            eta_k: None,
        }),
        blend(0.4, Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE }), Bsdf::Conductor(Conductor { specular_reflectance: Vec3::ONE, eta_k: None })),
        phong(20.0, Vec3::splat(0.4), Vec3::splat(0.5)),
        ward(WardVariant::WardDuer, 0.2, 0.1),
    ];
    let mut s = Sampler::for_key(34, 0, 0);
    for b in &one_sided {
        let t = two(b.clone());
        for _ in 0..2000 {
            let wo = crate::sampling::warp::square_to_uniform_hemisphere(s.next_2d());
            let wi = crate::sampling::warp::square_to_uniform_hemisphere(s.next_2d());
            let (u_lobe, u) = (s.next_1d(), s.next_2d());
            // Behind: nothing.
            assert_eq!(b.f(flip(wo), flip(wi), TransportMode::Radiance), Vec3::ZERO, "{b:?}");
            assert_eq!(b.pdf_w(flip(wo), flip(wi)), 0.0, "{b:?}");
            assert!(b.sample(flip(wo), u_lobe, u, TransportMode::Radiance).is_none(), "{b:?}");
            // Two-sided: in front the inner BSDF bit for bit, behind its mirror image.
            assert_eq!(t.f_pdf(wo, wi, TransportMode::Radiance), b.f_pdf(wo, wi, TransportMode::Radiance));
            assert_eq!(t.f_pdf(flip(wo), flip(wi), TransportMode::Radiance), b.f_pdf(wo, wi, TransportMode::Radiance));
            let (front, back) = (
                b.sample(wo, u_lobe, u, TransportMode::Radiance),
                t.sample(flip(wo), u_lobe, u, TransportMode::Radiance),
            );
            assert_eq!(front.map(|x| (flip(x.wi_local), x.weight, x.pdf_w)), back.map(|x| (x.wi_local, x.weight, x.pdf_w)));
        }
    }
}

/// The `albedo` AOV (Mitsuba's `eval_diffuse_reflectance`): a diffuse or plastic surface's diffuse
/// reflectance on either side of a two-sided BSDF, 0 for a mirror, π·f(wo, n) for a rough conductor, the
/// blend of a blend's components, 0 for a one-sided BSDF seen from below.
#[test]
fn diffuse_reflectance_follows_mitsubas_eval_diffuse_reflectance() {
    let (front, back) = (wo_at(30.0), -wo_at(30.0));
    let grey = Vec3::splat(0.4);
    assert_eq!(diffuse(0.4).diffuse_reflectance(front), grey);
    assert_eq!(diffuse(0.4).diffuse_reflectance(back), grey);
    assert_eq!(mirror().diffuse_reflectance(front), Vec3::ZERO);
    assert_eq!(plastic().diffuse_reflectance(front), Vec3::new(0.8, 0.5, 0.2));
    let r = rough(0.3, None);
    let expected = r.f(front, Vec3::Z, TransportMode::Radiance) * std::f32::consts::PI;
    assert!(expected.max_element() > 0.0);
    assert_eq!(r.diffuse_reflectance(front), expected);
    assert_eq!(r.diffuse_reflectance(back), expected, "two-sided: the front's");
    let b = blend(0.25, diffuse(0.4), mirror());
    assert!((b.diffuse_reflectance(front) - grey * 0.75).abs().max_element() < 1e-7);
    let one_sided = Bsdf::RoughConductor(RoughConductor { distribution: Microfacet::isotropic(MicrofacetType::Ggx, 0.3, true), specular_reflectance: Vec3::ONE, eta_k: None });
    assert_eq!(one_sided.diffuse_reflectance(back), Vec3::ZERO);
    assert_eq!(diffuse(0.4).diffuse_reflectance(Vec3::new(1.0, 0.0, 0.0)), Vec3::ZERO, "a tangent wo scatters nothing");
}

// ---- normalmap and bumpmap: the nested BSDF in a perturbed frame (super::perturbed) ----

/// A perturbed normal well off the unperturbed one (about 30°), and a tangent that is not the local x axis.
fn tilted() -> crate::bsdf::Perturbation {
    crate::bsdf::Perturbation { n: Vec3::new(0.45, -0.2, 0.85), tangent: Vec3::new(0.6, 0.8, 0.0) }
}

fn normalmap(inner: Bsdf, at: crate::bsdf::Perturbation, shadowing: bool) -> Bsdf {
    Bsdf::NormalMap(crate::bsdf::NormalMap(crate::bsdf::Perturbed { bsdf: Box::new(inner), flip_invalid_normals: true, use_shadowing_function: shadowing, at }))
}

fn bumpmap(inner: Bsdf, at: crate::bsdf::Perturbation) -> Bsdf {
    let perturbed = crate::bsdf::Perturbed { bsdf: Box::new(inner), flip_invalid_normals: true, use_shadowing_function: true, at };
    Bsdf::BumpMap(crate::bsdf::BumpMap { perturbed, scale: 1.0 })
}

/// The perturbed BSDFs the tests sweep: one-sided and two-sided lobes, isotropic and anisotropic, a blend
/// with a delta lobe, with and without the shadow terminator.
fn perturbed_zoo() -> Vec<(String, Bsdf)> {
    let diffuse1 = Bsdf::Diffuse(Diffuse { reflectance: Vec3::new(0.9, 0.6, 0.3) });
    let aniso = Bsdf::RoughConductor(RoughConductor {
        distribution: Microfacet { kind: MicrofacetType::Ggx, alpha_u: 0.08, alpha_v: 0.5, sample_visible: true },
        specular_reflectance: Vec3::ONE,
        eta_k: Some((AU_ETA, AU_K)),
    });
    vec![
        ("normalmap(diffuse)".into(), normalmap(diffuse1.clone(), tilted(), true)),
        ("normalmap(diffuse), no shadowing".into(), normalmap(diffuse1.clone(), tilted(), false)),
        ("twosided(normalmap(roughconductor ggx 0.3))".into(), two(normalmap(rough(0.3, None), tilted(), true))),
        ("normalmap(anisotropic roughconductor)".into(), normalmap(aniso.clone(), tilted(), true)),
        ("bumpmap(twosided(anisotropic))".into(), bumpmap(two(aniso), tilted())),
        ("normalmap(roughplastic)".into(), normalmap(rough_plastic(MicrofacetType::Beckmann, 0.2, true), tilted(), true)),
        ("normalmap(blend(diffuse, mirror))".into(), normalmap(blend(0.4, diffuse(0.8), mirror()), tilted(), true)),
    ]
}

#[test]
fn chi2_perturbed_frames() {
    let mut cases = Vec::new();
    for (name, bsdf) in perturbed_zoo() {
        // (75°, φ π) flips the normal (wo on the other side of it).
        for (t, phi) in [(0.0, 0.3), (40.0, 0.3), (75.0, std::f32::consts::PI), (120.0, 2.0)] {
            // From below, only the two-sided ones scatter (the others are black there: tested elsewhere).
            if t > 90.0 && !(name.contains("twosided") || name.contains("blend")) {
                continue;
            }
            cases.push((format!("{name} θo {t} φo {phi}"), bsdf.clone(), dir(t, phi), PdfIntegral::AtMostOne));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

#[test]
fn perturbed_samples_report_pdf_w_and_weight_consistently() {
    for (k, (name, bsdf)) in perturbed_zoo().iter().enumerate() {
        let mut delta = 0;
        for i in 0..20_000u64 {
            let mut s = Sampler::for_key(34, k as u64, i);
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let Some(smp) = bsdf.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) else {
                continue;
            };
            let wi = smp.wi_local;
            assert!((wi.length() - 1.0).abs() < 1e-5 && smp.weight.is_finite() && smp.weight.min_element() >= 0.0, "{name}");
            if smp.delta {
                delta += 1;
                assert!(smp.pdf_w > 0.0 && smp.pdf_w <= 1.0);
                continue;
            }
            assert_eq!(smp.pdf_w, bsdf.pdf_w(wo, wi), "{name}");
            let want = bsdf.f(wo, wi, TransportMode::Radiance) * wi.z.abs() / smp.pdf_w;
            assert!((smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6), "{name}: {} vs {want}", smp.weight);
            let (f, pdf) = bsdf.f_pdf(wo, wi, TransportMode::Radiance);
            assert_eq!((f, pdf), (bsdf.f(wo, wi, TransportMode::Radiance), smp.pdf_w), "{name}");
        }
        assert_eq!(delta > 0, name.contains("mirror"), "{name}");
    }
}

#[test]
fn perturbed_furnace_sampled_albedo_is_the_integrated_albedo() {
    // A white diffuse under a tilted normal: the sampler's mean weight is ∫ f |cos θi| dωi (its lost samples
    // are exactly the directions the value is zero at), at most 1, and 1 for the unperturbed frame.
    let white = Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE });
    for (at, shadowing) in [(tilted(), false), (tilted(), true), (crate::bsdf::Perturbation::default(), true)] {
        let bsdf = normalmap(white.clone(), at, shadowing);
        for t in [0.0, 30.0, 60.0, 85.0] {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&bsdf, wo, 200_000);
            let integral = integrate_sphere(|wi| bsdf.f(wo, wi, TransportMode::Radiance).x * wi.z.abs()) as f32;
            assert!((albedo.x - integral).abs() <= 4.0 * se.x + 1e-4, "{at:?} θo {t}: sampled {albedo} vs ∫ {integral} (σ {se})");
            assert!(integral <= 1.0 + 1e-4, "{at:?} θo {t}: ∫f cos = {integral}");
            if at == crate::bsdf::Perturbation::default() {
                assert!((integral - 1.0).abs() < 1e-4 && (albedo.x - 1.0).abs() < 1e-5, "identity θo {t}: {albedo}, ∫ {integral}");
            }
        }
    }
}

#[test]
fn perturbation_rules_follow_mitsuba() {
    use crate::bsdf::{FrameRule, HitFrame};
    use crate::math::Frame;
    // A hit whose local frame is not Mitsuba's: its ∂p/∂u along the local bitangent.
    let frame = Frame::from_normal(Vec3::new(0.0, 0.6, 0.8));
    let hit = HitFrame { frame, ng: frame.n, dp_du: 2.0 * frame.t, dp_dv: -3.0 * frame.s };
    assert_eq!(hit.tangent(), Vec2::new(0.0, 1.0));
    let normal = |rgb: Vec3| FrameRule::NormalMap.perturbation(|| rgb, || unreachable!(), &hit);
    // (½, ½, 1) is the unperturbed normal; +x in Mitsuba's frame (along ∂p/∂u) is the local +y here.
    assert!((normal(Vec3::new(0.5, 0.5, 1.0)).n - Vec3::Z).length() < 1e-6);
    let p = normal(Vec3::new(1.0, 0.5, 0.5));
    assert!((p.n - Vec3::Y).length() < 1e-6 && (p.tangent - Vec3::Y).length() < 1e-6, "{p:?}");
    // A height whose gradient is (g_u, g_v) on a plane with ∂p/∂u = x, ∂p/∂v = y: the normal (−g_u, −g_v, 1).
    let flat = HitFrame { frame: Frame::from_normal(Vec3::Z), ng: Vec3::Z, dp_du: Vec3::X, dp_dv: Vec3::Y };
    let bump = |scale: f32, g: Vec2| FrameRule::Height { scale }.perturbation(|| unreachable!(), || g, &flat);
    assert!((bump(2.0, Vec2::new(0.1, -0.3)).n - Vec3::new(-0.2, 0.6, 1.0).normalize()).length() < 1e-6);
    assert_eq!(bump(1.0, Vec2::ZERO).n, Vec3::Z);
    // The flip of an invalid normal: wo on the other side of the perturbed normal sees it mirrored in x, y.
    let b = normalmap(Bsdf::Diffuse(Diffuse { reflectance: Vec3::ONE }), crate::bsdf::Perturbation { n: Vec3::new(0.8, 0.0, 0.6), tangent: Vec3::X }, false);
    let wo = Vec3::new(-0.9, 0.0, 0.3).normalize();
    // Flipped: n = (−0.8, 0, 0.6); wi along it has cos θ′i = 1.
    let wi = Vec3::new(-0.8, 0.0, 0.6);
    let f = b.f(wo, wi, TransportMode::Radiance).x;
    assert!((f - std::f32::consts::FRAC_1_PI / 0.6).abs() < 1e-5, "{f}");
}

/// Mitsuba's `principled` from a scene file's table (TOML lines), through its plugin's constructor.
fn principled(table: &str) -> Bsdf {
    super::principled::tests::parse(table)
}

/// The `principled` configurations of the χ², consistency and reciprocity tests: (name, table, incident
/// angles θo, > 90° below the surface where a transmitting share makes it scatter).
const PRINCIPLED: [(&str, &str, &[f32]); 7] = [
    ("diffuse + sheen + flatness", "base_color = [0.8, 0.4, 0.2]\nroughness = 0.7\nsheen = 0.5\nflatness = 0.3", &[0.0, 40.0, 80.0]),
    ("metallic rough", "base_color = [0.9, 0.6, 0.3]\nmetallic = 1.0\nroughness = 0.3", &[0.0, 40.0, 80.0]),
    ("anisotropic", "base_color = 0.5\nmetallic = 0.6\nroughness = 0.4\nanisotropic = 0.8\nspec_tint = 0.5", &[10.0, 45.0, 80.0]),
    ("glass-like spec_trans", "base_color = [0.9, 0.9, 0.7]\nspec_trans = 0.9\nroughness = 0.2\neta = 1.5", &[0.0, 35.0, 75.0, 125.0, 160.0]),
    ("clearcoat", "base_color = [0.2, 0.4, 0.8]\nclearcoat = 0.8\nclearcoat_gloss = 0.6\nroughness = 0.5\nsheen = 0.7\nsheen_tint = 0.5\nspecular = 0.8", &[0.0, 40.0, 80.0]),
    (
        "every lobe (Mitsuba's example)",
        "base_color = 1.0\nmetallic = 0.7\nspecular = 0.6\nroughness = 0.2\nspec_tint = 0.4\nanisotropic = 0.5\nsheen = 0.3\nsheen_tint = 0.2\nclearcoat = 0.6\nclearcoat_gloss = 0.3\nspec_trans = 0.4",
        &[0.0, 35.0, 75.0, 125.0, 160.0],
    ),
    (
        "sampling rates",
        "base_color = [0.3, 0.6, 0.9]\nroughness = 0.35\nspec_trans = 0.5\nclearcoat = 1.0\nclearcoat_gloss = 0.8\neta = 1.33\ndiffuse_reflectance_sampling_rate = 0.5\nmain_specular_sampling_rate = 2.0\nclearcoat_sampling_rate = 3.0",
        &[20.0, 70.0, 140.0],
    ),
];

#[test]
fn chi2_principled() {
    let mut cases = Vec::new();
    for (name, table, thetas) in PRINCIPLED {
        for &t in thetas {
            // Lost samples (reflected below, refracted back, incompatible microfacets): ∫pdf ≤ 1.
            cases.push((format!("principled {name} θo {t}"), principled(table), dir(t, 0.3 + t.to_radians()), PdfIntegral::AtMostOne));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

/// Every configuration in both modes from directions all over the sphere: the reported pdf is `pdf_w`, bit
/// for bit, the weight `f·|cos θi|/pdf_w`; the sampled albedo is the integrated one; nothing scatters from
/// behind without a transmitting share.
#[test]
fn principled_samples_report_pdf_w_weight_and_albedo_consistently() {
    for (k, (name, table, thetas)) in PRINCIPLED.iter().enumerate() {
        let b = principled(table);
        for i in 0..20_000u64 {
            let mut s = Sampler::for_key(35, k as u64, i);
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), mode) else { continue };
                let wi = smp.wi_local;
                assert!(!smp.delta && (wi.length() - 1.0).abs() < 1e-5, "{name}");
                assert!(b.transmits() || (wo.z > 0.0 && wi.z > 0.0), "{name}: {wo} → {wi}");
                assert_eq!(smp.pdf_w.to_bits(), b.pdf_w(wo, wi).to_bits(), "{name}: {wo} → {wi}");
                let want = b.f(wo, wi, mode) * wi.z.abs() / smp.pdf_w;
                assert!((smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6), "{name}: {} vs {want}", smp.weight);
            }
        }
        // The sampler's mean weight is ∫f·|cos θi| (5σ + the quadrature's error on these lobes).
        for &t in thetas.iter().filter(|&&t| t < 90.0) {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&b, wo, 200_000);
            for c in 0..3 {
                let integral = integrate_sphere(|wi| b.f(wo, wi, TransportMode::Radiance)[c] * wi.z.abs()) as f32;
                assert!((albedo[c] - integral).abs() <= 5.0 * se[c] + 5e-3 * integral, "{name} θo {t} channel {c}: sampled {} vs ∫ {integral}", albedo[c]);
            }
        }
    }
}

/// What is true of Mitsuba's model (it is not energy-conserving in general: the diffuse lobe ignores what the
/// specular one took, and the retro-reflection and sheen add): a white metal is GGX with `F = 1`, which
/// loses energy only to masking (albedo ≤ 1, near 1 when smooth and seen from above); a white spec_trans glass
/// in importance mode keeps at most what arrives; reflection is reciprocal on either side, and refraction
/// is reciprocal between the modes (Veach 1997 eq. 5.21).
#[test]
fn principled_energy_and_reciprocity() {
    for roughness in [0.3f32, 0.6, 1.0] {
        let metal = principled(&format!("base_color = 1.0\nmetallic = 1.0\nroughness = {roughness}"));
        let glass = principled(&format!("base_color = 1.0\nspec_trans = 1.0\nroughness = {roughness}"));
        for t in [0.0f32, 30.0, 60.0, 85.0] {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&metal, wo, 100_000);
            assert!(albedo.x <= 1.0 + 3.0 * se.x && (albedo.x - albedo.z).abs() < 1e-6, "metal r {roughness} θo {t}: {albedo}");
            if t == 0.0 && roughness <= 0.3 {
                assert!(albedo.x > 0.97, "metal r {roughness} θo {t}: {albedo}");
            }
            for wo in [wo, -wo] {
                let (mut sum, n) = (0.0f64, 100_000u64);
                for i in 0..n {
                    let mut s = Sampler::for_key(36, i, 0);
                    if let Some(smp) = glass.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Importance) {
                        sum += f64::from(smp.weight.x);
                    }
                }
                let albedo = sum / n as f64;
                assert!(albedo <= 1.0 + 5e-3 && albedo > 0.3, "glass r {roughness} wo {wo}: {albedo}");
            }
        }
    }
    let mut s = Sampler::for_key(37, 0, 0);
    for (name, table, _) in PRINCIPLED {
        let b = principled(table);
        for _ in 0..5000 {
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let wi = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let (a, c) = if wo.z * wi.z > 0.0 {
                (b.f(wo, wi, TransportMode::Radiance), b.f(wi, wo, TransportMode::Radiance))
            } else {
                (b.f(wo, wi, TransportMode::Importance), b.f(wi, wo, TransportMode::Radiance))
            };
            // Refraction from a grazing wo reaches the microfacet's critical angle on the other side, where the
            // two evaluations' `1 − F` in f32 differ most (as for `roughdielectric`): measured ≤ 0.7 % on
            // values below 10⁻³.
            assert!((a - c).abs().max_element() <= 1e-3 * a.max_element() + 1e-5, "{name} {wo} {wi}: {a} vs {c}");
        }
    }
}

/// Mitsuba's `principledthin` from a scene file's table (TOML lines), through its plugin's constructor.
fn principledthin(table: &str) -> Bsdf {
    super::principledthin::tests::parse(table)
}

/// The incident angles of the `principledthin` χ² tests: the sheet is the same from either side, so both.
const THIN_THETAS: [f32; 4] = [0.0, 40.0, 80.0, 130.0];

#[test]
fn chi2_principledthin() {
    let mut cases = Vec::new();
    for (name, table) in super::principledthin::tests::SETS {
        for t in THIN_THETAS {
            // Lost samples (reflected below, incompatible microfacets): ∫pdf ≤ 1.
            cases.push((format!("principledthin {name} θo {t}"), principledthin(table), dir(t, 0.3 + t.to_radians()), PdfIntegral::AtMostOne));
        }
    }
    run_chi2_suite(&cases, 300_000);
}

/// Every set from directions all over the sphere: the reported pdf is `pdf_w` bit for bit, the weight
/// `f·|cos θi|/pdf_w`, the sampled albedo the integrated one; the sheet is symmetric (`f(−wo, −wi) = f(wo,
/// wi)`), reciprocal in reflection and the same in both modes.
#[test]
fn principledthin_samples_report_pdf_w_weight_and_albedo_consistently() {
    for (k, (name, table)) in super::principledthin::tests::SETS.iter().enumerate() {
        let b = principledthin(table);
        for i in 0..20_000u64 {
            let mut s = Sampler::for_key(38, k as u64, i);
            let wo = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let Some(smp) = b.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance) else { continue };
            let wi = smp.wi_local;
            assert!(!smp.delta && (wi.length() - 1.0).abs() < 1e-5, "{name}");
            assert_eq!(smp.pdf_w.to_bits(), b.pdf_w(wo, wi).to_bits(), "{name}: {wo} → {wi}");
            let want = b.f(wo, wi, TransportMode::Radiance) * wi.z.abs() / smp.pdf_w;
            assert!((smp.weight - want).abs().max_element() <= 1e-5 * want.max_element().max(1e-6), "{name}: {} vs {want}", smp.weight);
            let f = b.f(wo, wi, TransportMode::Radiance);
            assert_eq!(f, b.f(wo, wi, TransportMode::Importance), "{name}");
            assert_eq!(f, b.f(-wo, -wi, TransportMode::Radiance), "{name}");
            // Reflection is reciprocal; the specular transmission is not where one of the pair sees the
            // microfacet's front (Mitsuba's `mac_mic_compatibility` is not symmetric across the sheet).
            let back = b.f(wi, wo, TransportMode::Radiance);
            if wo.z * wi.z > 0.0 {
                assert!((f - back).abs().max_element() <= 1e-3 * f.max_element() + 1e-6, "{name} {wo} {wi}: {f} vs {back}");
            }
        }
        for t in [0.0f32, 40.0, 80.0] {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&b, wo, 200_000);
            for c in 0..3 {
                let integral = integrate_sphere(|wi| b.f(wo, wi, TransportMode::Radiance)[c] * wi.z.abs()) as f32;
                assert!((albedo[c] - integral).abs() <= 5.0 * se[c] + 5e-3 * integral, "{name} θo {t} channel {c}: sampled {} vs ∫ {integral}", albedo[c]);
            }
        }
    }
}

/// Furnaces of the sheet: a white pure diffuse transmitter (`diff_trans = 2`) passes everything, every sample
/// weighing 1; a white specular sheet of η = 2 (where the transmission's roughness is the reflection's) splits
/// a white rough mirror's scattering between its two sides, `F` and `1 − F` at the same microfacet, so its
/// albedo is at most that mirror's (≤ 1; less where a turned-over direction sees the microfacet's front, which
/// Mitsuba's transmission drops); with `roughness = 0` (no retro-reflection) the white
/// diffuse reflection and transmission together keep at most what arrives and at least what Burley's
/// grazing factors leave.
#[test]
fn principledthin_furnace() {
    let transmitter = principledthin("base_color = 1.0\ndiff_trans = 2.0");
    for t in THETAS {
        let wo = wo_at(t);
        for i in 0..1000u64 {
            let mut s = Sampler::for_key(39, i, 0);
            let smp = transmitter.sample(wo, s.next_1d(), s.next_2d(), TransportMode::Radiance).unwrap();
            assert!(smp.wi_local.z * wo.z < 0.0 && (smp.weight - Vec3::ONE).abs().max_element() < 1e-5, "θo {t}: {smp:?}");
        }
    }
    for roughness in [0.3f32, 0.6, 1.0] {
        let sheet = principledthin(&format!("base_color = 1.0\nspec_trans = 1.0\neta = 2.0\nroughness = {roughness}"));
        let mirror = Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(MicrofacetType::Ggx, (roughness * roughness).max(0.001), true),
            specular_reflectance: Vec3::ONE,
            eta_k: None,
        });
        for t in [0.0f32, 30.0, 60.0, 85.0] {
            let wo = wo_at(t);
            let (albedo, se) = sampled_albedo(&sheet, wo, 100_000);
            let want = integrate_sphere(|wi| mirror.f(wo, wi, TransportMode::Radiance).x * wi.z.abs()) as f32;
            assert!(albedo.x <= want + 5.0 * se.x + 5e-3 * want && albedo.x > 0.5 * want, "r {roughness} θo {t}: {albedo} vs mirror {want}");
            assert!((albedo.x - albedo.z).abs() < 1e-6, "r {roughness} θo {t}: {albedo}");
        }
    }
    let diffuse_sheet = principledthin("base_color = 1.0\nroughness = 0.0\ndiff_trans = 0.6");
    for t in [0.0f32, 30.0, 60.0, 85.0] {
        let (albedo, se) = sampled_albedo(&diffuse_sheet, wo_at(t), 100_000);
        // Burley's two factors (1 − F/2) are each ≥ ½: at least the transmitted 0.3 and a quarter of the 0.7.
        assert!(albedo.x <= 1.0 + 3.0 * se.x && albedo.x >= 0.3 + 0.7 / 4.0 - 3.0 * se.x, "θo {t}: {albedo}");
    }
}
