//! Area lights: a set of emissive triangles with one radiance, emitting on one side only, the side of the
//! geometric normal `(p1 − p0) × (p2 − p0)` (Mitsuba's `area` emitter). Triangles are chosen ∝ area, then a
//! point uniformly on the triangle, so the density over the light's surface is `pdf_a = 1/A`.
//!
//! The radiance may be a texture (Mitsuba's `area` with a `radiance` texture, src/emitters/area.cpp: `eval`
//! reads the texture at the point's texture coordinates): every reading of the light — the emission a ray
//! finds ([`AreaLight::le`]), NEE's sample ([`AreaLight::sample_li`]) and a photon's start
//! ([`AreaLight::sample_le_with`]) — evaluates it at the point's uv (`texture::interpolate_uv` of the
//! triangle's corner uvs at the point's barycentrics, the rule `Scene::tex_uv` applies at a hit). Positions
//! stay uniform by area, so every density (`pdf_li`, the photon pass's `p_emit`) is the untextured light's
//! and the MIS weights keep summing to one; Mitsuba instead samples positions ∝ the texture
//! (`Texture::sample_position`, mapped onto the shape by `eval_parameterization`): the same expected image,
//! a different noise. The power used to choose lights ([`AreaLight::power`]) is then `π·A·Y(L̄)`, `L̄` the
//! texture's mean (over its texels; a checkerboard's two colours' average): exact when the uvs cover the
//! texture once and uniformly by area (a rectangle), else only a selection weight, positive wherever the
//! light emits, which is all the estimates need.
//!
//! The surface may instead be one analytic shape (`light::shapes`: Mitsuba's `sphere`, `disk`, `cylinder`),
//! one primitive of the scene: NEE then samples it as Mitsuba does (the sphere by solid angle, the others by
//! area), photons start at a point by area, and a textured radiance is read at the shape's own uv.

use crate::sampling::warp::{square_to_cosine_hemisphere, square_to_uniform_triangle};
use super::{luminance, EmissionSample, LightSample};
use crate::math::{barycentric_point_error, offset_ray_origin, spawn_t_min, triangle_normal_area, Frame, Vec2, Vec3};
use crate::sampling::distribution::Distribution1D;
use super::shapes::AnalyticShape;
use crate::texture::{interpolate_uv, Texture};
use std::f32::consts::{FRAC_1_PI, PI};

#[derive(Clone, Debug)]
struct LightTriangle {
    prim: u32,
    p: [Vec3; 3],
    /// Unit geometric normal (zero for a degenerate triangle, which is never sampled).
    n: Vec3,
}

/// What an area light emits on its front side.
#[derive(Clone, Debug)]
enum Radiance {
    Constant(Vec3),
    /// A texture (its image shared with every other user: `texture::ImageCache`) read at the point's uv.
    Textured(Texture),
}

/// The surface an area light emits from.
#[derive(Clone, Debug)]
enum Surface {
    Triangles {
        triangles: Vec<LightTriangle>,
        /// With a textured radiance, `uvs[i]` are the texture coordinates of triangle `i`'s corners
        /// (`texture::BARYCENTRIC_UVS` for a shape without any); empty otherwise.
        uvs: Vec<[Vec2; 3]>,
        /// Triangle selection ∝ area; `None` if the total area is 0.
        distribution: Option<Distribution1D>,
        /// Density of a sampled point per unit area: `1/A` (triangle ∝ area, then uniform on it); 0 when
        /// nothing can be sampled (no distribution).
        pdf_a: f32,
    },
    /// One analytic shape, primitive `prim` of the scene.
    Analytic { prim: u32, shape: AnalyticShape },
}

/// One emitting shape (all its surface shares the radiance, constant or textured).
#[derive(Clone, Debug)]
pub struct AreaLight {
    radiance: Radiance,
    surface: Surface,
    area: f32,
}

/// Solid-angle density at `p_ref` of a point `p_light` (unit normal `n_light`) sampled with area density
/// `pdf_a`: `pdf_w = pdf_a · d² / cos θ_l` (pbrt-v4 eq. 4.11 / Veach 1997 eq. 8.10). 0 if `p_ref` is behind
/// the emitting side or coincides with `p_light`.
#[must_use]
pub(super) fn pdf_w_from_area(pdf_a: f32, p_ref: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
    let d = p_ref - p_light;
    let dist2 = d.length_squared();
    pdf_w_from_parts(pdf_a, dist2, n_light.dot(d) / dist2.sqrt())
}

/// [`pdf_w_from_area`] from the squared distance `dist2` and `cos_l = cos θ_l` (the cosine at the light,
/// positive on its emitting side), for a caller that has them: 0 unless `dist2` is positive and finite and
/// `cos_l > 0`.
#[inline]
#[must_use]
pub(super) fn pdf_w_from_parts(pdf_a: f32, dist2: f32, cos_l: f32) -> f32 {
    if !(dist2 > 0.0 && dist2.is_finite()) || cos_l.is_nan() || cos_l <= 0.0 {
        return 0.0;
    }
    pdf_a * dist2 / cos_l
}

impl AreaLight {
    /// An area light of `radiance` over `triangles` (global primitive index, vertices). Degenerate
    /// triangles are kept (so their primitive maps to this light) but never sampled.
    #[must_use]
    pub fn new(radiance: Vec3, triangles: Vec<(u32, [Vec3; 3])>) -> Self {
        Self::over_triangles(Radiance::Constant(radiance), triangles, Vec::new())
    }

    /// An area light whose radiance is `texture`, read at the texture coordinates `uvs[i]` of triangle `i`'s
    /// corners interpolated at a point's barycentrics (`texture::BARYCENTRIC_UVS` for a shape without
    /// uvs). One `uvs` entry per triangle.
    #[must_use]
    pub fn textured(texture: Texture, triangles: Vec<(u32, [Vec3; 3])>, uvs: Vec<[Vec2; 3]>) -> Self {
        assert_eq!(uvs.len(), triangles.len(), "one set of corner uvs per triangle");
        Self::over_triangles(Radiance::Textured(texture), triangles, uvs)
    }

    /// An area light of `radiance` on the analytic `shape`, primitive `prim` of the scene.
    #[must_use]
    pub fn analytic(radiance: Vec3, prim: u32, shape: AnalyticShape) -> Self {
        Self::on_shape(Radiance::Constant(radiance), prim, shape)
    }

    /// An area light whose radiance is `texture`, read at the shape's own uv (`light::shapes`), on the
    /// analytic `shape`, primitive `prim` of the scene.
    #[must_use]
    pub fn analytic_textured(texture: Texture, prim: u32, shape: AnalyticShape) -> Self {
        Self::on_shape(Radiance::Textured(texture), prim, shape)
    }

    fn on_shape(radiance: Radiance, prim: u32, shape: AnalyticShape) -> Self {
        let area = shape.area();
        Self { radiance, surface: Surface::Analytic { prim, shape }, area }
    }

    fn over_triangles(radiance: Radiance, triangles: Vec<(u32, [Vec3; 3])>, uvs: Vec<[Vec2; 3]>) -> Self {
        let mut areas = Vec::with_capacity(triangles.len());
        let triangles: Vec<LightTriangle> = triangles
            .into_iter()
            .map(|(prim, p)| {
                let (n, area) = triangle_normal_area(p).unwrap_or((Vec3::ZERO, 0.0));
                areas.push(area);
                LightTriangle { prim, p, n }
            })
            .collect();
        let area = areas.iter().map(|&a| f64::from(a)).sum::<f64>() as f32;
        let distribution = Distribution1D::new(&areas);
        let pdf_a = if distribution.is_some() { 1.0 / area } else { 0.0 };
        Self {
            radiance,
            surface: Surface::Triangles { triangles, uvs, distribution, pdf_a },
            area,
        }
    }

    /// Total area A of the emitting surface.
    #[must_use]
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Emitted radiance (on the front side): the constant, or a texture's mean (`Texture::mean_rgb`).
    #[must_use]
    pub fn radiance(&self) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(c) => *c,
            Radiance::Textured(texture) => texture.mean_rgb(),
        }
    }

    /// The largest radiance it emits anywhere, per channel (0: it emits nothing and may be left out).
    #[must_use]
    pub fn max_radiance(&self) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(c) => *c,
            Radiance::Textured(texture) => texture.max(),
        }
    }

    /// Whether the radiance is a texture.
    #[must_use]
    pub fn is_textured(&self) -> bool {
        matches!(self.radiance, Radiance::Textured(_))
    }

    /// The radiance at barycentrics `(b1, b2)` of triangle `i` of `uvs` (the triangles' corner uvs).
    #[inline]
    fn radiance_on(&self, uvs: &[[Vec2; 3]], i: usize, b1: f32, b2: f32) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(c) => *c,
            Radiance::Textured(texture) => texture.eval_rgb(interpolate_uv(uvs[i], b1, b2)),
        }
    }

    /// The radiance at texture coordinates `uv` (read only when textured).
    #[inline]
    fn radiance_at(&self, uv: Vec2) -> Vec3 {
        match &self.radiance {
            Radiance::Constant(c) => *c,
            Radiance::Textured(texture) => texture.eval_rgb(uv),
        }
    }

    /// Global primitive indices of its surface: its triangles, or its one analytic primitive.
    pub fn prims(&self) -> impl Iterator<Item = u32> + '_ {
        let (triangles, analytic) = match &self.surface {
            Surface::Triangles { triangles, .. } => (triangles.as_slice(), None),
            Surface::Analytic { prim, .. } => (&[][..], Some(*prim)),
        };
        triangles.iter().map(|t| t.prim).chain(analytic)
    }

    /// The analytic shape it emits from, if any.
    #[must_use]
    pub fn analytic_shape(&self) -> Option<&AnalyticShape> {
        match &self.surface {
            Surface::Analytic { shape, .. } => Some(shape),
            Surface::Triangles { .. } => None,
        }
    }

    /// Power Φ = π·A·Y(L), one-sided (method.md §2); with a texture, `L` its mean (module docs).
    #[must_use]
    pub fn power(&self) -> f32 {
        PI * self.area * luminance(self.radiance())
    }

    /// Radiance leaving the light at a point with geometric normal `ng` toward `w_world` (0 on the back
    /// side); `uv` gives the point's texture coordinates (`Scene::tex_uv`), asked only of a textured light.
    #[inline]
    #[must_use]
    pub fn le(&self, ng: Vec3, w_world: Vec3, uv: impl FnOnce() -> Vec2) -> Vec3 {
        if ng.dot(w_world) > 0.0 {
            match &self.radiance {
                Radiance::Constant(c) => *c,
                Radiance::Textured(texture) => texture.eval_rgb(uv()),
            }
        } else {
            Vec3::ZERO
        }
    }

    /// A uniform point on triangle `i`: (triangle, point, barycentrics).
    fn point_on(triangles: &[LightTriangle], i: usize, u_pos: Vec2) -> (&LightTriangle, Vec3, [f32; 3]) {
        let t = &triangles[i];
        let (b1, b2) = square_to_uniform_triangle(u_pos);
        let b = [(1.0 - b1 - b2).max(0.0), b1, b2];
        (t, b[0] * t.p[0] + b[1] * t.p[1] + b[2] * t.p[2], b)
    }

    /// NEE: a point on the light seen from `p_ref`. Triangles: `u.x` chooses the triangle and, remapped,
    /// together with `u.y` the point on it; an analytic shape samples itself (`light::shapes`). `None` if
    /// `p_ref` is behind the sampled point's emitting side or on it.
    #[must_use]
    pub fn sample_li(&self, p_ref: Vec3, u: Vec2) -> Option<LightSample> {
        let (distribution, triangles, uvs, pdf_a) = match &self.surface {
            Surface::Triangles { triangles, uvs, distribution, pdf_a } => (distribution.as_ref()?, triangles, uvs, *pdf_a),
            Surface::Analytic { shape, .. } => {
                let (s, pdf_w) = shape.sample_toward(p_ref, u)?;
                let d = s.p - p_ref;
                let dist = d.length();
                return Some(LightSample {
                    wi_world: d / dist,
                    dist,
                    li: self.radiance_at(s.uv),
                    pdf_w,
                    p_light: s.p,
                    n_light: s.n,
                    delta: false,
                });
            }
        };
        let (i, _, u_rest) = distribution.sample_discrete(u.x);
        let (t, p_light, b) = Self::point_on(triangles, i, Vec2::new(u_rest, u.y));
        // One square root and one division serve the direction, the distance and the pdf's cosine.
        let d = p_light - p_ref;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        let wi_world = d * (1.0 / dist);
        let pdf_w = pdf_w_from_parts(pdf_a, dist2, -t.n.dot(wi_world));
        if !(pdf_w > 0.0 && pdf_w.is_finite()) {
            return None;
        }
        Some(LightSample {
            wi_world,
            dist,
            li: self.radiance_on(uvs, i, b[1], b[2]),
            pdf_w,
            p_light,
            n_light: t.n,
            delta: false,
        })
    }

    /// Solid-angle density with which [`AreaLight::sample_li`] from `p_ref` produces the point `p_light`
    /// of unit geometric normal `n_light` (0 from behind).
    #[must_use]
    pub fn pdf_li(&self, p_ref: Vec3, p_light: Vec3, n_light: Vec3) -> f32 {
        match &self.surface {
            Surface::Triangles { pdf_a, .. } => pdf_w_from_area(*pdf_a, p_ref, p_light, n_light),
            Surface::Analytic { shape, .. } => shape.pdf_toward(p_ref, p_light, n_light),
        }
    }

    /// Density per unit area with which photon emission ([`AreaLight::sample_le_with`]) starts at the
    /// point `p` of the light: `1/A`, except on an elliptic cylinder (`light::shapes::CylinderShape`).
    #[must_use]
    pub fn pdf_a_at(&self, p: Vec3) -> f32 {
        match &self.surface {
            Surface::Triangles { pdf_a, .. } => *pdf_a,
            Surface::Analytic { shape, .. } => shape.pdf_a(p),
        }
    }

    /// Photon emission (method.md §2): triangle ∝ area (`u_tri`), point uniform on it (`u_pos`), direction
    /// cosine-weighted about the normal (`u_dir`). `None` if the light has no area or the direction is
    /// tangent.
    #[must_use]
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, u_tri: f32) -> Option<EmissionSample> {
        self.sample_le_with(u_pos, u_tri, |_, n| {
            let local = square_to_cosine_hemisphere(u_dir);
            if local.z.is_nan() || local.z <= 0.0 {
                return None;
            }
            Some((Frame::from_normal(n).to_world(local).normalize(), local.z * FRAC_1_PI))
        })
    }

    /// Photon emission with a direction rule of the caller's (`photon::emission` aims at the delta
    /// objects): triangle ∝ area (`u_tri`), point uniform on it (`u_pos`) — on an analytic shape a point by
    /// its `sample_area` (`u_pos`; `u_tri` unused) —, then `direction(point, normal)` gives a unit
    /// direction and its solid-angle density (`None`: no photon).
    #[must_use]
    pub fn sample_le_with(&self, u_pos: Vec2, u_tri: f32, direction: impl FnOnce(Vec3, Vec3) -> Option<(Vec3, f32)>) -> Option<EmissionSample> {
        let (p, n, p_error, le, pdf_a) = match &self.surface {
            Surface::Triangles { triangles, uvs, distribution, pdf_a } => {
                let (i, _, _) = distribution.as_ref()?.sample_discrete(u_tri);
                let (t, p, b) = Self::point_on(triangles, i, u_pos);
                (p, t.n, barycentric_point_error(b, t.p), self.radiance_on(uvs, i, b[1], b[2]), *pdf_a)
            }
            Surface::Analytic { shape, .. } => {
                let s = shape.sample_area(u_pos);
                if !(s.pdf_a > 0.0 && s.pdf_a.is_finite()) {
                    return None;
                }
                (s.p, s.n, s.p_error, self.radiance_at(s.uv), s.pdf_a)
            }
        };
        let (dir, pdf_w_dir) = direction(p, n)?;
        let origin = offset_ray_origin(p, p_error, n, dir);
        Some(EmissionSample {
            origin,
            t_min: spawn_t_min(p_error, dir),
            n,
            dir,
            le,
            pdf_a,
            pdf_w_dir,
        })
    }
}

#[cfg(test)]
impl AreaLight {
    /// Its triangles as given to `new` (tests; none for an analytic shape).
    pub(super) fn triangle_list(&self) -> Vec<(u32, [Vec3; 3])> {
        match &self.surface {
            Surface::Triangles { triangles, .. } => triangles.iter().map(|t| (t.prim, t.p)).collect(),
            Surface::Analytic { .. } => Vec::new(),
        }
    }

    /// Whether `p` lies on triangle `prim` of this light (tests; tolerance 1e-4 in barycentrics and height).
    pub(super) fn contains(&self, prim: u32, p: Vec3) -> bool {
        let Surface::Triangles { triangles, .. } = &self.surface else {
            return false;
        };
        triangles.iter().filter(|t| t.prim == prim).any(|t| {
            let (e1, e2, q) = (t.p[1] - t.p[0], t.p[2] - t.p[0], p - t.p[0]);
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            let det = d11 * d22 - d12 * d12;
            let b1 = (d22 * q.dot(e1) - d12 * q.dot(e2)) / det;
            let b2 = (d11 * q.dot(e2) - d12 * q.dot(e1)) / det;
            b1 >= -1e-4 && b2 >= -1e-4 && b1 + b2 <= 1.0 + 1e-4 && t.n.dot(q).abs() < 1e-4
        })
    }
}
