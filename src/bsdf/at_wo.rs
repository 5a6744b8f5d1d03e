//! A BSDF evaluated at one fixed `wo` for many `wi`: the density estimate (method.md §3) evaluates
//! `f(x, ωₒ, ωₚ)` (and, for `mis`, the BSDF sampler's `pdf_w`, method.md §4) for up to k photons at the
//! same `ωₒ`. [`BsdfAtWo::new`] does the work that depends on `wo` alone once — validity checks, the
//! two-sided mirroring, the blend's dispatch, the diffuse value `R/π` and the Smith term `G1(wo)/cos θo`
//! — and [`BsdfAtWo::f_pdf`] the rest per `wi`.
//!
//! It returns exactly (bit for bit) what [`Bsdf::f_pdf`] returns: the same operations in the same order,
//! only hoisted. Shapes other than a diffuse or rough-conductor lobe, or a blend of two such lobes, under
//! at most one `twosided`, fall back to [`Bsdf::f_pdf`] per `wi`.
//!
//! [`BsdfAtWo::f_pdf_many`] evaluates a batch of `wi` (structure of arrays): diffuse lobes and GGX lobes
//! without Fresnel (`GgxAtWo`), alone or blended, run a branch-free loop specialised to the lobe pair,
//! which the compiler vectorises (four photons per SSE instruction: the square roots and divisions of
//! the half vector, `D` and `G1` are most of a density estimate's per-photon time); other shapes call
//! [`BsdfAtWo::f_pdf`] per `wi`. Same bits either way.

use super::roughconductor::GgxAtWo;
use super::{blend, flip_z, roughconductor, valid_wo, Blend, Bsdf, Diffuse, Microfacet, RoughConductor, TransportMode, TwoSided};
use crate::math::Vec3;
use std::f32::consts::FRAC_1_PI;

/// One non-delta lobe with its `wo`-only factors (the `wo` it was prepared for has `wo.z > 0`).
#[derive(Clone, Copy, Debug)]
enum Lobe<'a> {
    /// `R/π` (the value for `wi.z > 0`).
    Diffuse { f: Vec3 },
    RoughConductor {
        distribution: &'a Microfacet,
        specular_reflectance: Vec3,
        eta_k: Option<(Vec3, Vec3)>,
        /// `G1(wo)/cos θo` before the `wo·h > 0` test.
        g1o_unmasked: f32,
    },
}

impl<'a> Lobe<'a> {
    /// The lobe of `bsdf` at `wo` (`wo.z > 0`), if it is a diffuse or rough-conductor BSDF.
    fn new(bsdf: &'a Bsdf, wo: Vec3) -> Option<Self> {
        match bsdf {
            Bsdf::Diffuse(Diffuse { reflectance }) => Some(Lobe::Diffuse { f: *reflectance * FRAC_1_PI }),
            Bsdf::RoughConductor(RoughConductor { distribution, specular_reflectance, eta_k }) => Some(Lobe::RoughConductor {
                distribution,
                specular_reflectance: *specular_reflectance,
                eta_k: *eta_k,
                g1o_unmasked: distribution.g1_over_cos_unmasked(wo),
            }),
            _ => None,
        }
    }

    /// `(f, pdf_w)` at `(wo, wi)`, `wo.z > 0`, `wi` finite with `wi.z ≠ 0` (as `diffuse::f`/`pdf_w` and
    /// `roughconductor::f_pdf`).
    #[inline]
    fn f_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match *self {
            Lobe::Diffuse { f } => {
                if wi.z > 0.0 {
                    (f, wi.z * FRAC_1_PI)
                } else {
                    (Vec3::ZERO, 0.0)
                }
            }
            Lobe::RoughConductor { distribution, specular_reflectance, eta_k, g1o_unmasked } => {
                roughconductor::f_pdf_upper(distribution, specular_reflectance, eta_k, wo, wi, g1o_unmasked)
            }
        }
    }
}

/// A lobe whose evaluation has no branches: the batch loop of [`BsdfAtWo::f_pdf_many`].
#[derive(Clone, Copy, Debug)]
enum Lane {
    Diffuse { f: Vec3 },
    Ggx(GgxAtWo),
}

impl Lobe<'_> {
    fn lane(&self, wo: Vec3) -> Option<Lane> {
        match *self {
            Lobe::Diffuse { f } => Some(Lane::Diffuse { f }),
            Lobe::RoughConductor { distribution, specular_reflectance, eta_k, g1o_unmasked } => {
                GgxAtWo::new(distribution, specular_reflectance, eta_k, wo, g1o_unmasked).map(Lane::Ggx)
            }
        }
    }
}

/// `diffuse::f`/`pdf_w` for `wo.z > 0` (as [`Lobe::f_pdf`]), without branches.
#[inline(always)]
fn diffuse_lane(f: Vec3, wi: Vec3) -> (Vec3, f32) {
    if wi.z > 0.0 {
        (f, wi.z * FRAC_1_PI)
    } else {
        (Vec3::ZERO, 0.0)
    }
}

/// Runs `$body` with `$l` bound to the lane evaluation of `$lane` (a closure `Vec3 → (Vec3, f32)`), one
/// copy of `$body` per kind of lane, so that each loop is compiled for its lobes.
macro_rules! with_lane {
    ($lane:expr, |$l:ident| $body:expr) => {
        match $lane {
            Lane::Diffuse { f } => {
                let $l = move |wi: Vec3| diffuse_lane(f, wi);
                $body
            }
            Lane::Ggx(ggx) => {
                let $l = move |wi: Vec3| ggx.f_pdf(wi);
                $body
            }
        }
    };
}

#[derive(Clone, Copy, Debug)]
enum Shape<'a> {
    /// `wo` in the tangent plane or not finite: nothing scatters.
    Zero,
    /// The general path: [`Bsdf::f_pdf`] per `wi`.
    Generic(&'a Bsdf),
    One(Lobe<'a>),
    /// `blend` with its clamped weight `w` and both lobes.
    Blend { w: f32, lobe_0: Lobe<'a>, lobe_1: Lobe<'a> },
}

/// A BSDF prepared for evaluation at one `wo_local` (module docs).
#[derive(Clone, Copy, Debug)]
pub struct BsdfAtWo<'a> {
    shape: Shape<'a>,
    /// `wo` as the lobes see it (mirrored to +z under a two-sided BSDF).
    wo: Vec3,
    /// Whether `wi` is mirrored too (two-sided BSDF seen from below).
    flip: bool,
    mode: TransportMode,
}

impl<'a> BsdfAtWo<'a> {
    #[must_use]
    pub fn new(bsdf: &'a Bsdf, wo_local: Vec3, mode: TransportMode) -> Self {
        let generic = BsdfAtWo { shape: Shape::Generic(bsdf), wo: wo_local, flip: false, mode };
        if !valid_wo(wo_local) {
            return BsdfAtWo { shape: Shape::Zero, ..generic };
        }
        let (inner, wo, flip) = match bsdf {
            Bsdf::TwoSided(TwoSided(inner)) if wo_local.z < 0.0 => (&**inner, flip_z(wo_local), true),
            Bsdf::TwoSided(TwoSided(inner)) => (&**inner, wo_local, false),
            other => (other, wo_local, false),
        };
        if wo.z <= 0.0 {
            // One-sided lobes seen from below (or a configuration the generic path handles).
            return generic;
        }
        let shape = match inner {
            Bsdf::Blend(Blend { weight, bsdf_0, bsdf_1 }) => match (Lobe::new(bsdf_0, wo), Lobe::new(bsdf_1, wo)) {
                (Some(lobe_0), Some(lobe_1)) => Shape::Blend { w: blend::clamp_weight(*weight), lobe_0, lobe_1 },
                _ => return generic,
            },
            other => match Lobe::new(other, wo) {
                Some(lobe) => Shape::One(lobe),
                None => return generic,
            },
        };
        BsdfAtWo { shape, wo, flip, mode }
    }

    /// Exactly `bsdf.f_pdf(wo_local, wi_local, mode)` of the BSDF and `wo_local` this was prepared for.
    #[inline]
    #[must_use]
    pub fn f_pdf(&self, wi_local: Vec3) -> (Vec3, f32) {
        match self.shape {
            Shape::Zero => (Vec3::ZERO, 0.0),
            Shape::Generic(bsdf) => bsdf.f_pdf(self.wo, wi_local, self.mode),
            _ if !wi_local.is_finite() || wi_local.z == 0.0 => (Vec3::ZERO, 0.0),
            Shape::One(lobe) => lobe.f_pdf(self.wo, self.wi(wi_local)),
            Shape::Blend { w, lobe_0, lobe_1 } => {
                // As blend::f_pdf: (1 − w)·(f₀, p₀) then + w·(f₁, p₁), each term only when its weight is > 0.
                let wi = self.wi(wi_local);
                let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
                if w < 1.0 {
                    let (f0, p0) = lobe_0.f_pdf(self.wo, wi);
                    f += (1.0 - w) * f0;
                    pdf += (1.0 - w) * p0;
                }
                if w > 0.0 {
                    let (f1, p1) = lobe_1.f_pdf(self.wo, wi);
                    f += w * f1;
                    pdf += w * p1;
                }
                (f, pdf)
            }
        }
    }

    /// Exactly `bsdf.f(wo_local, wi_local, mode)` (for the lobes handled here `f` is `f_pdf`'s first half:
    /// `roughconductor::f` is defined so, and a blend sums its components' `f` in the same order).
    #[inline]
    #[must_use]
    pub fn f(&self, wi_local: Vec3) -> Vec3 {
        match self.shape {
            Shape::Generic(bsdf) => bsdf.f(self.wo, wi_local, self.mode),
            _ => self.f_pdf(wi_local).0,
        }
    }

    /// `f_pdf` of every `wi_local = (x[j], y[j], z[j])`, bit for bit, into `f` (RGB arrays) and `pdf`
    /// (module docs). All slices have the same length.
    pub fn f_pdf_many(&self, wi_local: [&[f32]; 3], f: [&mut [f32]; 3], pdf: &mut [f32]) {
        let n = pdf.len();
        assert!(wi_local.iter().all(|a| a.len() == n) && f.iter().all(|a| a.len() == n), "f_pdf_many: slices of different lengths");
        let wo = self.wo;
        let one = |lobe: &Lobe<'_>| lobe.lane(wo);
        match self.shape {
            Shape::One(lobe) => {
                if let Some(lane) = one(&lobe) {
                    with_lane!(lane, |eval| return self.run(eval, wi_local, f, pdf));
                }
            }
            Shape::Blend { w, lobe_0, lobe_1 } => {
                if let (Some(lane_0), Some(lane_1)) = (one(&lobe_0), one(&lobe_1)) {
                    with_lane!(lane_0, |eval_0| with_lane!(lane_1, |eval_1| {
                        return self.run(move |wi| blend_lanes(w, eval_0(wi), eval_1(wi)), wi_local, f, pdf);
                    }));
                }
            }
            Shape::Zero | Shape::Generic(_) => {}
        }
        for j in 0..n {
            let (v, p) = self.f_pdf(Vec3::new(wi_local[0][j], wi_local[1][j], wi_local[2][j]));
            (f[0][j], f[1][j], f[2][j], pdf[j]) = (v.x, v.y, v.z, p);
        }
    }

    /// The batch loop over one lane evaluation (`f_pdf`'s checks and mirroring, without branches).
    #[inline(always)]
    fn run(&self, eval: impl Fn(Vec3) -> (Vec3, f32), wi_local: [&[f32]; 3], f: [&mut [f32]; 3], pdf: &mut [f32]) {
        let [x, y, z] = wi_local;
        let [fr, fg, fb] = f;
        let n = pdf.len();
        let (x, y, z, fr, fg, fb) = (&x[..n], &y[..n], &z[..n], &mut fr[..n], &mut fg[..n], &mut fb[..n]);
        for j in 0..n {
            let w = Vec3::new(x[j], y[j], z[j]);
            let valid = w.x.is_finite() & w.y.is_finite() & w.z.is_finite() & (w.z != 0.0);
            let (v, p) = eval(self.wi(w));
            let (v, p) = if valid { (v, p) } else { (Vec3::ZERO, 0.0) };
            (fr[j], fg[j], fb[j], pdf[j]) = (v.x, v.y, v.z, p);
        }
    }

    #[inline]
    fn wi(&self, wi_local: Vec3) -> Vec3 {
        if self.flip {
            flip_z(wi_local)
        } else {
            wi_local
        }
    }
}

/// As `blend::f_pdf` and [`BsdfAtWo::f_pdf`]: `(1 − w)·(f₀, p₀)` then `+ w·(f₁, p₁)`, each term only when
/// its weight is > 0 (both are computed; `w` is the same for the whole batch).
#[inline(always)]
fn blend_lanes(w: f32, (f0, p0): (Vec3, f32), (f1, p1): (Vec3, f32)) -> (Vec3, f32) {
    let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
    if w < 1.0 {
        f += (1.0 - w) * f0;
        pdf += (1.0 - w) * p0;
    }
    if w > 0.0 {
        f += w * f1;
        pdf += w * p1;
    }
    (f, pdf)
}

#[cfg(test)]
mod tests {
    use crate::bsdf::{Conductor, Dielectric};
    use super::*;
    use crate::bsdf::MicrofacetType;
    use crate::sampler::Sampler;

    fn rough(kind: MicrofacetType, alpha: f32, eta_k: Option<(Vec3, Vec3)>) -> Bsdf {
        Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(kind, alpha, kind == MicrofacetType::Ggx),
            specular_reflectance: Vec3::new(0.9, 0.8, 0.7),
            eta_k,
        })
    }

    /// Every shape (prepared and fallback) gives bit-for-bit `Bsdf::f_pdf` and `Bsdf::f`, on both sides,
    /// for random and degenerate directions.
    #[test]
    fn matches_the_bsdf_bit_for_bit() {
        let diffuse = Bsdf::Diffuse(Diffuse { reflectance: Vec3::new(0.5, 0.25, 0.125) });
        let gold = Some((Vec3::new(0.2, 0.4, 1.4), Vec3::new(3.6, 2.4, 1.8)));
        let ggx_drawn_by_d_cos = Bsdf::RoughConductor(RoughConductor {
            distribution: Microfacet::isotropic(MicrofacetType::Ggx, 0.2, false),
            specular_reflectance: Vec3::ONE,
            eta_k: None,
        });
        let lobes = [diffuse.clone(), rough(MicrofacetType::Ggx, 0.005, None), rough(MicrofacetType::Beckmann, 0.3, gold), ggx_drawn_by_d_cos];
        let mut bsdfs = Vec::new();
        for a in &lobes {
            bsdfs.push(a.clone());
            for b in &lobes {
                for weight in [0.0, 0.3, 1.0] {
                    bsdfs.push(Bsdf::Blend(Blend { weight, bsdf_0: Box::new(a.clone()), bsdf_1: Box::new(b.clone()) }));
                }
            }
        }
        bsdfs.push(Bsdf::Dielectric(Dielectric { eta: 1.5 }));
        bsdfs.push(Bsdf::Blend(Blend {
            weight: 0.5,
            bsdf_0: Box::new(diffuse.clone()),
            bsdf_1: Box::new(Bsdf::Conductor(Conductor { specular_reflectance: Vec3::ONE, eta_k: None })),
        }));
        let all: Vec<Bsdf> = bsdfs.iter().cloned().chain(bsdfs.iter().map(|b| Bsdf::TwoSided(TwoSided(Box::new(b.clone()))))).collect();
        let mut s = Sampler::for_key(3, 0, 0);
        let mut dir = || {
            let v = Vec3::new(2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0, 2.0 * s.next_1d() - 1.0);
            v.normalize()
        };
        let mut wos: Vec<Vec3> = (0..40).map(|_| dir()).collect();
        wos.extend([Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(f32::NAN, 0.0, 1.0)]);
        let mut wis: Vec<Vec3> = (0..60).map(|_| dir()).collect();
        wis.extend([Vec3::X, Vec3::Z, -Vec3::Z, Vec3::new(0.0, f32::INFINITY, 1.0)]);
        for bsdf in &all {
            for &wo in &wos {
                let at = BsdfAtWo::new(bsdf, wo, TransportMode::Radiance);
                for wi in wis.iter().copied().chain([crate::bsdf::reflect_z(wo), -wo]) {
                    let (f, p) = bsdf.f_pdf(wo, wi, TransportMode::Radiance);
                    let (g, q) = at.f_pdf(wi);
                    let same = |a: Vec3, b: Vec3| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits);
                    assert!(same(f, g) && p.to_bits() == q.to_bits(), "{bsdf:?} wo {wo} wi {wi}: {f} {p} vs {g} {q}");
                    let fv = bsdf.f(wo, wi, TransportMode::Radiance);
                    assert!(same(fv, at.f(wi)), "{bsdf:?} wo {wo} wi {wi}: f {fv} vs {}", at.f(wi));
                }
                // The batch: every wi at once.
                let batch: Vec<Vec3> = wis.iter().copied().chain([crate::bsdf::reflect_z(wo), -wo]).collect();
                let xyz = [0, 1, 2].map(|a| batch.iter().map(|v| v[a]).collect::<Vec<f32>>());
                let (mut fr, mut fg, mut fb, mut pdf) = (vec![0.0; batch.len()], vec![0.0; batch.len()], vec![0.0; batch.len()], vec![0.0; batch.len()]);
                at.f_pdf_many([&xyz[0], &xyz[1], &xyz[2]], [&mut fr, &mut fg, &mut fb], &mut pdf);
                for (j, &wi) in batch.iter().enumerate() {
                    let (f, p) = bsdf.f_pdf(wo, wi, TransportMode::Radiance);
                    let got = [fr[j], fg[j], fb[j], pdf[j]].map(f32::to_bits);
                    assert_eq!([f.x, f.y, f.z, p].map(f32::to_bits), got, "{bsdf:?} wo {wo} wi {wi}: batch");
                }
            }
        }
    }
}
