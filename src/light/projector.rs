//! The beam of Mitsuba 3's `projector` emitter (`projector.cpp`): a point light at the origin of its
//! `to_world` that projects a texture along its local +z through a perspective frustum, as a
//! `perspective` camera would see the texture on its film (the reciprocal of `crate::camera`).
//!
//! In the projector's own frame (orthonormal: `to_world` without its uniform scale k), the film lies on
//! the plane z = 1 and spans `[−tan_x, tan_x] × [−tan_y, tan_y]`; a local direction `l` (l.z > 0) meets it
//! at `(l.x, l.y)/l.z` and reads the texture at Mitsuba's `perspective_projection` coordinates
//! `u = ½ − l.x/(2·l.z·tan_x)`, `v = ½ − l.y/(2·l.z·tan_y)` (u to the film's right, v down, both flipped
//! from +x and +y as for the camera); outside `[0, 1]²` no light leaves.
//!
//! Radiant intensity (Mitsuba's `sample_direction`/`eval_direction`): the radiance arriving at a point of
//! local coordinates `p` from the projector is `π·scale·T(uv)/(p.z²·cos θ_n)`, θ_n between `to_world`'s
//! image of +z (length k) and the direction to the point, which with `p.z = r·cos θ/k` is the intensity
//! `I(ω) = π·scale·k·T(uv(ω))/cos³θ` (θ to the axis) over r². The 1/cos³θ undoes the film plane's
//! foreshortening: the irradiance on the plane z = 1 facing the projector is `π·scale·k·T` everywhere
//! ("a projection of a constant texture onto a plane is truly constant"). Its power, `∫I dω`, is
//! `π·scale·k·A·∫T du dv` (dω = cos³θ dA on that plane), A = `4·tan_x·tan_y` the film's area; ∫T du dv is
//! taken as the texture's mean (exact for `nearest`, the texels' mean for bilinear lookups, close enough
//! for choosing lights ∝ power).
//!
//! Photons leave by [`ProjectorProfile::sample_direction`]: a film point uniform on the rectangle, so
//! `pdf_ω = |q|³/A` at the film point `q = (x, y, 1)` (Mitsuba samples the texture's distribution instead;
//! both are unbiased, this one needs no distribution per texture).

use crate::math::{Mat3, Vec2, Vec3};
use crate::texture::Texture;

/// A projector's frustum: its frame and its film's extent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// Orthonormal columns: the world images of the local x, y, z axes (possibly mirrored).
    frame: Mat3,
    /// Half-extents of the film at z = 1 (local): `tan` of half the field of view along x and y.
    tan_half: Vec2,
}

impl Frustum {
    /// A frustum along `frame`'s third column: `frame` orthonormal (the caller has divided out the uniform
    /// scale), `tan_half` the film's half-extents at z = 1 (both > 0 and finite). `None` otherwise.
    #[must_use]
    pub fn new(frame: Mat3, tan_half: Vec2) -> Option<Self> {
        let cols = [frame.x_axis, frame.y_axis, frame.z_axis];
        let orthonormal = cols.iter().all(|c| (c.length_squared() - 1.0).abs() < 1e-4)
            && [(0, 1), (0, 2), (1, 2)].iter().all(|&(i, j)| cols[i].dot(cols[j]).abs() < 1e-4);
        let tan_ok = tan_half.min_element() > 0.0 && tan_half.is_finite();
        (orthonormal && tan_ok).then_some(Self { frame, tan_half })
    }

    /// Unit axis (world space): the projector's local +z.
    #[must_use]
    pub fn axis(&self) -> Vec3 {
        self.frame.z_axis
    }

    /// The film's half-extents at z = 1.
    #[must_use]
    pub fn tan_half(&self) -> Vec2 {
        self.tan_half
    }

    /// The film's area at z = 1, A = `4·tan_x·tan_y`.
    #[must_use]
    pub fn film_area(&self) -> f32 {
        4.0 * self.tan_half.x * self.tan_half.y
    }

    /// The texture coordinate where the unit world direction `w` crosses the film, with `cos θ` to the
    /// axis; `None` behind the projector or outside the film (Mitsuba: `uv ∈ [0, 1]²` and z > 0).
    #[must_use]
    pub fn film_uv(&self, w: Vec3) -> Option<(Vec2, f32)> {
        let l = self.frame.transpose() * w;
        if !(l.z > 0.0) {
            return None;
        }
        let uv = Vec2::new(0.5 - 0.5 * l.x / (l.z * self.tan_half.x), 0.5 - 0.5 * l.y / (l.z * self.tan_half.y));
        (uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()).then_some((uv, l.z))
    }

    /// The frustum's solid angle, `4·asin(sin α·sin β)` for the half-angles α, β of a rectangular pyramid.
    #[must_use]
    pub fn solid_angle(&self) -> f32 {
        let (sa, sb) = (self.tan_half.x / self.tan_half.x.hypot(1.0), self.tan_half.y / self.tan_half.y.hypot(1.0));
        4.0 * (sa * sb).asin()
    }

    /// A direction leaving through a film point uniform on the film (`u` is the texture coordinate it
    /// crosses), and its solid-angle density `|q|³/A`.
    #[must_use]
    pub fn sample_direction(&self, u: Vec2) -> (Vec3, f32) {
        let q = Vec3::new(self.tan_half.x * (1.0 - 2.0 * u.x), self.tan_half.y * (1.0 - 2.0 * u.y), 1.0);
        let len = q.length();
        ((self.frame * q).normalize(), len * len * len / self.film_area())
    }

    /// The density of [`Frustum::sample_direction`] at the unit direction `w` (0 outside).
    #[must_use]
    pub fn pdf_direction(&self, w: Vec3) -> f32 {
        match self.film_uv(w) {
            Some((_, cos)) => 1.0 / (cos * cos * cos * self.film_area()),
            None => 0.0,
        }
    }
}

/// A projector's frustum and texture: the textured profile of a [`super::PointLight`].
#[derive(Clone, Debug)]
pub struct ProjectorProfile {
    frustum: Frustum,
    /// The texture on the film (Mitsuba's `irradiance`).
    texture: Texture,
}

impl ProjectorProfile {
    #[must_use]
    pub fn new(frustum: Frustum, texture: Texture) -> Self {
        Self { frustum, texture }
    }

    #[must_use]
    pub fn frustum(&self) -> &Frustum {
        &self.frustum
    }

    #[must_use]
    pub fn texture(&self) -> &Texture {
        &self.texture
    }

    /// The directional factor of the intensity along the unit direction `w`: `T(uv)/cos³θ` inside the
    /// frustum, 0 outside (the light's intensity is this times `π·scale·k`).
    #[must_use]
    pub fn weight(&self, w: Vec3) -> Vec3 {
        match self.frustum.film_uv(w) {
            Some((uv, cos)) => self.texture.eval_rgb(uv) / (cos * cos * cos),
            None => Vec3::ZERO,
        }
    }

    /// `∫ weight dω` per channel: `A·∫T du dv`, the texture's mean standing for its integral.
    #[must_use]
    pub fn solid_angle_integral(&self) -> Vec3 {
        self.frustum.film_area() * self.texture.mean_rgb()
    }
}
