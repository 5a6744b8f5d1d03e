//! Tests of the environment map: the Mitsuba mapping convention, (b) Monte Carlo integrals against exact or
//! brute-force references within 5 standard errors, (c) a chi² histogram test of the sampled pixels,
//! emission samples, the shared `.exr`/`.hdr` assets and bad input.

use super::env::{local_dir_to_uv, uv_to_local_dir};
use super::test_util::{assert_within_5_sigma, chi2_test, Mean};
use super::*;
use crate::math::{Mat4, Vec2, Vec3};
use crate::sampler::Sampler;
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

fn random_pixels(w: usize, h: usize, seed: u64, zero_every: usize) -> Vec<Vec3> {
    let mut s = Sampler::for_key(seed, 0, 0);
    (0..w * h)
        .map(|i| {
            if zero_every > 0 && i % zero_every == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 5.0
            }
        })
        .collect()
}

/// Pixel (x, y) of a local direction.
fn pixel_of(env: &EnvMap, d_local: Vec3) -> (usize, usize) {
    let uv = local_dir_to_uv(d_local);
    (
        ((uv.x * env.width() as f32) as usize).min(env.width() - 1),
        ((uv.y * env.height() as f32) as usize).min(env.height() - 1),
    )
}

/// Brute-force `∫ g(ω) dω` by the midpoint rule on an `n × n/2` grid in (u, v), `dω = 2π² sin θ du dv`.
fn sphere_quadrature(n: usize, g: impl Fn(Vec3) -> f64) -> f64 {
    let (nu, nv) = (n, n / 2);
    let mut total = 0.0;
    for j in 0..nv {
        let v = (j as f64 + 0.5) / nv as f64;
        let jac = 2.0 * std::f64::consts::PI * std::f64::consts::PI * (std::f64::consts::PI * v).sin() / (nu * nv) as f64;
        for i in 0..nu {
            let uv = Vec2::new(((i as f64 + 0.5) / nu as f64) as f32, v as f32);
            total += g(uv_to_local_dir(uv)) * jac;
        }
    }
    total
}

#[test]
fn mapping_follows_mitsuba() {
    // W = 10, H = 5: (u, v) = (0.25, 0.5) is the centre of pixel (2, 2), local direction +x.
    let (w, h) = (10, 5);
    let pixels: Vec<Vec3> = (0..w * h).map(|i| Vec3::new(i as f32 + 1.0, 0.5, 2.0)).collect();
    let env = EnvMap::from_pixels(w, h, pixels.clone(), 1.0, Mat4::IDENTITY).unwrap();
    let uv = local_dir_to_uv(Vec3::X);
    assert!((uv - Vec2::new(0.25, 0.5)).length() < 1e-6, "{uv}");
    assert!((uv_to_local_dir(Vec2::new(0.25, 0.5)) - Vec3::X).length() < 1e-6);
    let e = env.eval(Vec3::X);
    assert!(
        (e - env.pixel(2, 2)).length() < 1e-4 * env.pixel(2, 2).length(),
        "{e} vs {}",
        env.pixel(2, 2)
    );
    // u = 0 is −z, u = 0.5 is +z; v = 0 is +y (top row); pixel (7, 2) is the centre of u = 0.75: −x.
    assert!((local_dir_to_uv(-Vec3::Z) - Vec2::new(0.0, 0.5)).length() < 1e-6);
    assert!((local_dir_to_uv(Vec3::Z) - Vec2::new(0.5, 0.5)).length() < 1e-6);
    assert!(local_dir_to_uv(Vec3::Y).y.abs() < 1e-6 && (local_dir_to_uv(-Vec3::Y).y - 1.0).abs() < 1e-6);
    assert!((env.eval(-Vec3::X) - env.pixel(7, 2)).length() < 1e-4 * env.pixel(7, 2).length());
    // Round trip over random directions.
    let mut s = Sampler::for_key(40, 0, 0);
    for _ in 0..1000 {
        let uv = s.next_2d();
        let back = local_dir_to_uv(uv_to_local_dir(uv));
        let du = (back.x - uv.x).abs().min(1.0 - (back.x - uv.x).abs());
        assert!(
            du < 1e-4 / (PI * uv.y).sin().max(1e-3) && (back.y - uv.y).abs() < 1e-4,
            "{uv} -> {back}"
        );
    }
    // to_world rotates the map: pixel (2, 2) now seen from R·(+x).
    let rot = Mat4::from_rotation_y(1.1) * Mat4::from_rotation_z(0.3);
    let rotated = EnvMap::from_pixels(w, h, pixels, 2.0, rot).unwrap();
    assert!((rotated.eval(rot.transform_vector3(Vec3::X)) - 2.0 * env.pixel(2, 2)).length() < 1e-3);
    // The top row alone lights the pole.
    let mut top = vec![Vec3::ZERO; w * h];
    top[..w].fill(Vec3::splat(3.0));
    let top = EnvMap::from_pixels(w, h, top, 1.0, Mat4::IDENTITY).unwrap();
    assert!((top.eval(Vec3::Y) - Vec3::splat(3.0)).length() < 1e-5 && top.eval(-Vec3::Y) == Vec3::ZERO);
}

#[test]
fn single_bright_pixel_is_sampled_in_its_neighbourhood() {
    let (w, h) = (16, 8);
    let mut pixels = vec![Vec3::ZERO; w * h];
    pixels[2 * w + 5] = Vec3::splat(100.0);
    let env = EnvMap::from_pixels(w, h, pixels, 1.0, Mat4::IDENTITY).unwrap();
    let centre = uv_to_local_dir(Vec2::new(5.5 / w as f32, 2.5 / h as f32));
    assert!((env.eval(centre) - Vec3::splat(100.0)).length() < 1e-2);
    // Predicted share of the bright pixel itself: weight (6/8)²·sin θ_2 among the 3×3 block's weights
    // (the [1, 6, 1]/8 filter of the pixel mean of the bilinear interpolant, times sin θ of each row).
    let k = [0.125f64, 0.75, 0.125];
    let sin_row = |y: usize| (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
    let block: f64 = (0..3)
        .flat_map(|a| (0..3).map(move |b| (a, b)))
        .map(|(a, b)| k[a] * k[b] * sin_row(1 + a))
        .sum();
    let p_centre = k[1] * k[1] * sin_row(2) / block;
    let mut s = Sampler::for_key(41, 0, 0);
    let n = 50_000u64;
    let mut in_centre = 0u64;
    // Samples in the outer half of a neighbour, where the interpolant is 0, come back as None.
    let mut none = 0u64;
    for _ in 0..n {
        let Some(ls) = env.sample_li(Vec3::ZERO, s.next_2d()) else {
            none += 1;
            continue;
        };
        let (x, y) = pixel_of(&env, ls.wi_world);
        assert!((4..=6).contains(&x) && (1..=3).contains(&y), "sample in pixel ({x}, {y})");
        assert!(ls.li.max_element() > 0.0);
        in_centre += u64::from((x, y) == (5, 2));
    }
    assert!(none < n / 4, "{none} empty samples");
    let sigma = (n as f64 * p_centre * (1.0 - p_centre)).sqrt();
    assert!(
        (in_centre as f64 - n as f64 * p_centre).abs() <= 5.0 * sigma,
        "{in_centre} vs {}",
        n as f64 * p_centre
    );
    // The pdf is positive wherever eval is (so NEE alone misses nothing).
    for _ in 0..20_000 {
        let d = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
        if env.eval(d).max_element() > 0.0 {
            assert!(env.pdf_li(d) > 0.0, "eval > 0 but pdf 0 at {d}");
        }
    }
}

#[test]
fn mc_integrals_match_exact_and_brute_force_references() {
    // (b) Random map with some black pixels, rotated and scaled.
    let (w, h) = (24, 12);
    let to_world = Mat4::from_rotation_x(0.5) * Mat4::from_rotation_y(-1.2);
    let env = EnvMap::from_pixels(w, h, random_pixels(w, h, 42, 7), 0.8, to_world).unwrap();
    // The closed-form integral agrees with brute-force quadrature of eval.
    let brute = sphere_quadrature(2048, |d| f64::from(luminance(env.eval(to_world.transform_vector3(d)))));
    let exact = f64::from(env.integral_luminance());
    assert!((brute - exact).abs() < 1e-4 * exact, "quadrature {brute} vs closed form {exact}");
    let n_r = Vec3::new(0.3, 0.8, -0.5).normalize();
    let lobe = |d: Vec3| f64::from(luminance(env.eval(d)) * n_r.dot(d).max(0.0));
    let lobe_ref = sphere_quadrature(2048, |d| lobe(to_world.transform_vector3(d)));
    let (mut m_all, mut m_lobe) = (Mean::default(), Mean::default());
    let mut s = Sampler::for_key(43, 0, 0);
    for _ in 0..200_000 {
        let ls = env.sample_li(Vec3::ONE, s.next_2d()).unwrap();
        assert!(ls.dist.is_infinite() && ls.li == env.eval(ls.wi_world));
        m_all.add(f64::from(luminance(ls.li) / ls.pdf_w));
        m_lobe.add(lobe(ls.wi_world) / f64::from(ls.pdf_w));
    }
    assert_within_5_sigma("∫ Le dω", &m_all, exact, 0.0);
    assert_within_5_sigma("∫ Le cos dω", &m_lobe, lobe_ref, 1e-4 * lobe_ref);
    assert!((env.power(2.0) - PI * 4.0 * env.integral_luminance()).abs() < 1e-3);
}

#[test]
fn sampled_pixel_histogram_passes_chi2() {
    // (c) Histogram of the sampled pixels vs weights ∝ Ȳ·sin θ_c (Ȳ = the [1, 6, 1]/8-filtered luminance,
    // computed here independently). Pearson chi², cells expected < 5 pooled; p-value from the
    // Wilson–Hilferty normal approximation of chi²(k); reject below 1e-4. The same samples against the
    // unfiltered luminance·sin θ must be rejected (the test has power).
    let (w, h) = (32, 16);
    // No black pixels here, so that the rejection of the wrong weights is a genuine chi² result.
    let env = EnvMap::from_pixels(w, h, random_pixels(w, h, 44, 0), 1.0, Mat4::IDENTITY).unwrap();
    let lum = |x: i64, y: i64| {
        f64::from(luminance(
            env.pixel(x.rem_euclid(w as i64) as usize, y.clamp(0, h as i64 - 1) as usize),
        ))
    };
    let k = [0.125f64, 0.75, 0.125];
    let mut filtered = vec![0.0f64; w * h];
    let mut plain = vec![0.0f64; w * h];
    for y in 0..h {
        let sin_theta = (std::f64::consts::PI * (y as f64 + 0.5) / h as f64).sin();
        for x in 0..w {
            let mut v = 0.0;
            for (a, ka) in k.iter().enumerate() {
                for (b, kb) in k.iter().enumerate() {
                    v += ka * kb * lum(x as i64 + b as i64 - 1, y as i64 + a as i64 - 1);
                }
            }
            filtered[y * w + x] = v * sin_theta;
            plain[y * w + x] = lum(x as i64, y as i64) * sin_theta;
        }
    }
    let n = 400_000u64;
    let mut counts = vec![0u64; w * h];
    let mut s = Sampler::for_key(45, 0, 0);
    for _ in 0..n {
        let ls = env.sample_li(Vec3::ZERO, s.next_2d()).unwrap();
        let (x, y) = pixel_of(&env, ls.wi_world);
        counts[y * w + x] += 1;
    }
    let expect = |weights: &[f64]| {
        let total: f64 = weights.iter().sum();
        weights.iter().map(|&wt| wt / total * n as f64).collect::<Vec<f64>>()
    };
    let (chi2, dof, p) = chi2_test(&counts, &expect(&filtered));
    let (chi2_wrong, _, p_wrong) = chi2_test(&counts, &expect(&plain));
    println!("env histogram: chi² {chi2} with {dof} dof, p = {p}; against unfiltered weights chi² {chi2_wrong}, p = {p_wrong}");
    assert!(p > 1e-4, "chi² {chi2} with {dof} dof: p = {p}");
    assert!(
        p_wrong < 1e-4,
        "the wrong weights were not rejected: chi² {chi2_wrong}, p = {p_wrong}"
    );
}

#[test]
fn emission_samples_start_on_a_disk_outside_the_scene() {
    let env = EnvMap::from_pixels(8, 4, random_pixels(8, 4, 46, 0), 1.0, Mat4::from_rotation_z(0.4)).unwrap();
    let (c, r) = (Vec3::new(1.0, -2.0, 0.5), 3.0);
    let mut s = Sampler::for_key(47, 0, 0);
    let mut rho2 = Mean::default();
    for _ in 0..50_000 {
        let e = env.sample_le(s.next_2d(), s.next_2d(), c, r).unwrap();
        let omega = -e.dir;
        assert!((e.dir.length() - 1.0).abs() < 1e-5 && e.n == e.dir);
        assert!(
            ((e.origin - c).dot(omega) - r).abs() < 1e-4 * r,
            "the disk is at distance R along ω"
        );
        let radial = (e.origin - c) - r * omega;
        assert!(radial.length() <= r * (1.0 + 1e-5));
        assert_eq!(e.le, env.eval(omega));
        assert!((e.pdf_w_dir - env.pdf_li(omega)).abs() <= 1e-6 * e.pdf_w_dir && (e.pdf_a - 1.0 / (PI * r * r)).abs() < 1e-7);
        rho2.add(f64::from(radial.length_squared()));
    }
    // Uniform on the disk: E[ρ²] = R²/2.
    assert_within_5_sigma("E[ρ²]", &rho2, f64::from(r * r / 2.0), 0.0);
    assert!(env.sample_le(Vec2::splat(0.5), Vec2::splat(0.5), c, 0.0).is_none());
}

#[test]
fn black_map_and_bad_input() {
    let black = EnvMap::from_pixels(4, 2, vec![Vec3::ZERO; 8], 1.0, Mat4::IDENTITY).unwrap();
    assert!(black.sample_li(Vec3::ZERO, Vec2::splat(0.5)).is_none() && black.pdf_li(Vec3::Y) == 0.0 && black.power(1.0) == 0.0);
    let mut bad = vec![Vec3::ONE; 8];
    bad[5] = Vec3::new(1.0, -0.5, 0.0);
    let err = EnvMap::from_pixels(4, 2, bad.clone(), 1.0, Mat4::IDENTITY).unwrap_err();
    assert!(matches!(err, LightError::BadTexel { x: 1, y: 1, .. }), "{err}");
    bad[5] = Vec3::new(f32::NAN, 0.0, 0.0);
    assert!(matches!(
        EnvMap::from_pixels(4, 2, bad, 1.0, Mat4::IDENTITY),
        Err(LightError::BadTexel { x: 1, y: 1, .. })
    ));
    assert!(matches!(
        EnvMap::from_pixels(4, 3, vec![Vec3::ONE; 8], 1.0, Mat4::IDENTITY),
        Err(LightError::Invalid { .. })
    ));
    assert!(matches!(
        EnvMap::from_pixels(0, 0, Vec::new(), 1.0, Mat4::IDENTITY),
        Err(LightError::Invalid { .. })
    ));
    assert!(matches!(
        EnvMap::from_pixels(4, 2, vec![Vec3::ONE; 8], -1.0, Mat4::IDENTITY),
        Err(LightError::Invalid { .. })
    ));
    let shear = Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    assert!(matches!(
        EnvMap::from_pixels(4, 2, vec![Vec3::ONE; 8], 1.0, shear),
        Err(LightError::Invalid { .. })
    ));
}

/// An environment map shipped in `scenes/assets/envmaps/` (provenance in `scenes/assets/PROVENANCE.md`).
fn shipped_envmap(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets/envmaps").join(name)
}

#[test]
fn studio_exr_and_hdr_agree() {
    let exr = EnvMap::load(&shipped_envmap("studio.exr"), 1.0, Mat4::IDENTITY).unwrap();
    let hdr = EnvMap::load(&shipped_envmap("studio.hdr"), 1.0, Mat4::IDENTITY).unwrap();
    assert_eq!((exr.width(), exr.height()), (hdr.width(), hdr.height()));
    let mean = |e: &EnvMap| {
        let mut s = [0.0f64; 3];
        for y in 0..e.height() {
            for x in 0..e.width() {
                let p = e.pixel(x, y);
                s = [s[0] + f64::from(p.x), s[1] + f64::from(p.y), s[2] + f64::from(p.z)];
            }
        }
        s.map(|c| c / (e.width() * e.height()) as f64)
    };
    let (me, mh) = (mean(&exr), mean(&hdr));
    println!(
        "studio {}x{}: mean RGB exr {me:?} hdr {mh:?}; ∫Y dω exr {} hdr {}",
        exr.width(),
        exr.height(),
        exr.integral_luminance(),
        hdr.integral_luminance()
    );
    for c in 0..3 {
        assert!((me[c] - mh[c]).abs() <= 0.02 * me[c], "channel {c}: exr {} hdr {}", me[c], mh[c]);
    }
    let (ie, ih) = (exr.integral_luminance(), hdr.integral_luminance());
    assert!((ie - ih).abs() <= 0.02 * ie, "∫Y dω: exr {ie} hdr {ih}");
}

#[test]
fn corrupt_or_missing_files_are_errors_naming_the_file() {
    let dir = std::env::temp_dir().join(format!("caustica-light-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let exr_bytes = std::fs::read(shipped_envmap("studio.exr")).unwrap();
    let hdr_bytes = std::fs::read(shipped_envmap("studio.hdr")).unwrap();
    let mut garbage = Vec::new();
    let mut s = Sampler::for_key(48, 0, 0);
    garbage.extend((0..4096).map(|_| s.next_u32() as u8));
    let mut bad_header_exr = exr_bytes.clone();
    for b in &mut bad_header_exr[8..200] {
        *b ^= 0x5a;
    }
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("garbage.exr", garbage.clone()),
        ("garbage.hdr", garbage),
        ("empty.exr", Vec::new()),
        ("empty.hdr", Vec::new()),
        ("truncated.exr", exr_bytes[..exr_bytes.len() / 3].to_vec()),
        ("truncated.hdr", hdr_bytes[..hdr_bytes.len() / 3].to_vec()),
        ("scrambled_header.exr", bad_header_exr),
    ];
    for (name, bytes) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let err = EnvMap::load(&path, 1.0, Mat4::IDENTITY).expect_err(name);
        assert!(err.to_string().contains(name), "{name}: {err}");
    }
    let missing = dir.join("missing.exr");
    assert!(matches!(EnvMap::load(&missing, 1.0, Mat4::IDENTITY), Err(LightError::Io { .. })));
    let png = dir.join("map.png");
    std::fs::write(&png, b"x").unwrap();
    assert!(matches!(
        EnvMap::load(&png, 1.0, Mat4::IDENTITY),
        Err(LightError::UnsupportedFormat { .. })
    ));
    std::fs::remove_dir_all(&dir).unwrap();
}
