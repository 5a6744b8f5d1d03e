//! Mitsuba's `projector` emitter (`projector.cpp`): a point light at the origin of `to_world` that
//! projects the texture `irradiance` along its +z as a `perspective` camera of the same `fov` would see
//! it on its film (the film's aspect is the texture's: a bitmap's width/height, 1 for a colour or a
//! checkerboard). Its intensity, `π·scale·k·T(uv)/cos³θ` (k the uniform scale of `to_world`), is
//! `light::projector`'s; the irradiance it casts on the plane at distance 1 facing it is `π·scale·T`.
//!
//! A projector's `to_world` must not shear or scale non-uniformly (as a spot's).
//!
//! ```toml
//! [[emitter]]
//! type = "projector"
//! irradiance = { type = "bitmap", filename = "slide.png" }   # or a colour; default 1
//! scale = 2                  # ≥ 0, default 1
//! fov = 30                   # degrees in (0, 180), across `fov_axis` (default x) of the texture's film
//! # focal_length = "50mm"    # instead of fov: 35 mm equivalent, across the diagonal (Mitsuba's default)
//! to_world = { look_at = { origin = [0, 4, 0], target = [0, 0, 0], up = [0, 0, 1] } }
//! ```

use super::{power, similarity_scale, Emitter, Plugin};
use crate::camera::{focal_length_fov, tan_half, FovAxis};
use crate::light::{Frustum, Light, PointLight, ProjectorProfile};
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};
use crate::texture::Texture;

pub(super) const PLUGIN: Plugin = Plugin {
    name: super::PROJECTOR,
    keys: &["irradiance", "scale", "fov", "fov_axis", "focal_length", "to_world"],
    nested: &["to_world"],
    build,
};

/// Mitsuba's default focal length of a projector without `fov` (as of a `perspective` sensor).
const DEFAULT_FOCAL_LENGTH: &str = "50mm";

/// A projector as its file describes it; its light needs the texture ([`Projector::light`]).
#[derive(Clone, Debug)]
pub struct Projector {
    /// The light's position (`to_world`'s origin).
    position: Vec3,
    /// `to_world`'s linear part divided by its uniform scale k (orthonormal).
    frame: Mat3,
    /// Mitsuba's `scale` times k.
    scale_k: f32,
    fov_deg: f32,
    fov_axis: FovAxis,
    /// `irradiance` when it is a colour, the texture's mean when it is a texture (the scene reader binds
    /// the texture).
    pub irradiance: Vec3,
}

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let to_world = p.take_nested("to_world").unwrap_or(Mat4::IDENTITY);
    let irradiance = power(&p, "irradiance")?;
    let scale = p.float_or("scale", 1.0)?;
    if scale < 0.0 {
        return Err(PropError::new("scale", format!("the scale must be ≥ 0, got {scale}")));
    }
    let (fov_deg, fov_axis) = match (p.has("fov"), p.string("focal_length")?) {
        (true, Some(_)) => return Err(PropError::new("focal_length", "give either fov or focal_length, not both (Mitsuba refuses both)")),
        (true, None) => {
            let fov = p.float_or("fov", 0.0)?;
            if !(fov > 0.0 && fov < 180.0) {
                return Err(PropError::new("fov", format!("fov must be in (0, 180) degrees, got {fov}")));
            }
            let axis = p.string("fov_axis")?.unwrap_or("x");
            let axis = FovAxis::from_name(axis)
                .ok_or_else(|| PropError::new("fov_axis", format!("{axis:?} is not one of x, y, diagonal, smaller, larger")))?;
            (fov, axis)
        }
        (false, focal_length) => {
            let text = focal_length.unwrap_or(DEFAULT_FOCAL_LENGTH);
            let fov = focal_length_fov(text)
                .ok_or_else(|| PropError::new("focal_length", format!("{text:?} is not a focal length (a positive number of millimetres, \"50mm\")")))?;
            (fov, FovAxis::Diagonal)
        }
    };
    let linear = Mat3::from_mat4(to_world);
    let k = similarity_scale(linear, "projector").map_err(|m| PropError::new("to_world", m))?;
    let scale_k = scale * k;
    let brightest = std::f32::consts::PI * scale_k * p.texture_max("irradiance").unwrap_or(irradiance).max_element();
    if !brightest.is_finite() {
        return Err(PropError::new("scale", format!("π·scale·(to_world's scale)·irradiance overflows f32 (scale {scale})")));
    }
    let position = to_world.transform_point3(Vec3::ZERO);
    Ok(Emitter::Projector(Projector { position, frame: linear * (1.0 / k), scale_k, fov_deg, fov_axis, irradiance }))
}

impl Projector {
    /// The light projecting `texture` (its `irradiance`: the texture bound to that key, or the colour), or
    /// `None` when it emits nothing (as every emitter of zero power is left out). The film's aspect is the
    /// texture's (Mitsuba's `resolution()`).
    #[must_use]
    pub fn light(&self, texture: Texture) -> Option<Light> {
        if self.scale_k == 0.0 || texture.max().max_element() <= 0.0 {
            return None;
        }
        let (width, height) = texture.resolution();
        let frustum = Frustum::new(self.frame, tan_half(self.fov_deg, self.fov_axis, width as f32, height as f32))?;
        let profile = ProjectorProfile::new(frustum, texture);
        Some(Light::Point(PointLight::projector(self.position, Vec3::splat(self.scale_k), profile)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::math::{Vec2, Vec4};
    use crate::sampler::Sampler;
    use crate::scene::look_at;
    use crate::texture::{Bitmap, FilterType, TextureImage, WrapMode};
    use std::sync::Arc;

    fn build_from(text: &str, to_world: Mat4) -> Result<Projector, PropError> {
        let mut table: toml::Table = text.parse().unwrap();
        table.insert("type".into(), "projector".into());
        let nested = vec![("to_world", to_world)];
        match (PLUGIN.build)(Props::new(&table, PLUGIN.keys, nested))? {
            Emitter::Projector(p) => Ok(p),
            other => panic!("not a projector: {other:?}"),
        }
    }

    /// A 4×2 bitmap with a distinct colour per texel, looked up without interpolation.
    fn bitmap() -> Texture {
        let data: Vec<f32> = (0..8).flat_map(|i| [1.0 + i as f32, 0.5 + 0.25 * i as f32, 9.0 - i as f32]).collect();
        let image = TextureImage::from_linear("texels.exr", 4, 2, 3, data).unwrap();
        Texture::Bitmap(Bitmap::new(Arc::new(image), FilterType::Nearest, WrapMode::Clamp))
    }

    /// Mitsuba's horizontal fov from `parse_fov` (src/render/sensor.cpp), in f64, for the film's aspect.
    fn mitsuba_x_fov(fov: f64, axis: &str, aspect: f64) -> f64 {
        let half_tan = (0.5 * fov.to_radians()).tan();
        match axis {
            "x" => fov,
            "y" => (2.0 * (half_tan * aspect).atan()).to_degrees(),
            _ => (2.0 * (2.0 * half_tan / (1.0 + 1.0 / (aspect * aspect)).sqrt() * 0.5).atan()).to_degrees(),
        }
    }

    /// The radiance arriving at `p` from a projector as Mitsuba's `sample_direction` computes it: the
    /// point in the projector's space, its film coordinate by the inverse of `perspective_projection`
    /// (scale · translate · perspective, near 10⁻⁴, far 10⁴), the texture there times
    /// `π·scale/(z²·(−n·d))`, n = to_world·(0, 0, 1).
    fn mitsuba_li(to_world: Mat4, x_fov: f64, tex: &Texture, scale: f32, p: Vec3) -> Option<Vec3> {
        let (w, h) = tex.resolution();
        let aspect = w as f32 / h as f32;
        let (near, far) = (1e-4f32, 1e4f32);
        let cot = 1.0 / (0.5 * x_fov.to_radians()).tan() as f32;
        let (a, b) = (far / (far - near), -near * far / (far - near));
        let persp = Mat4::from_cols(Vec4::new(cot, 0.0, 0.0, 0.0), Vec4::new(0.0, cot, 0.0, 0.0), Vec4::new(0.0, 0.0, a, 1.0), Vec4::new(0.0, 0.0, b, 0.0));
        let camera_to_sample = Mat4::from_scale(Vec3::new(-0.5, -0.5 * aspect, 1.0)) * Mat4::from_translation(Vec3::new(-1.0, -1.0 / aspect, 0.0)) * persp;
        let local = to_world.inverse().transform_point3(p);
        let uv = camera_to_sample.project_point3(local).truncate();
        if !(local.z > 0.0 && uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()) {
            return None;
        }
        // Points within 10⁻³ of the film's edge may fall either side in f32: not compared.
        if uv.min_element() < 1e-3 || uv.max_element() > 1.0 - 1e-3 {
            return Some(Vec3::NAN);
        }
        let n = to_world.transform_vector3(Vec3::Z);
        let d = (to_world.transform_point3(Vec3::ZERO) - p).normalize();
        Some(tex.eval_rgb(uv) * std::f32::consts::PI * scale / (local.z * local.z * -n.dot(d)))
    }

    /// NEE from the projector is Mitsuba's `sample_direction` for every way of giving the field of view,
    /// a scaled and a mirrored `to_world`, a bitmap (aspect 2) and a colour (aspect 1): points all around
    /// it, lit or not.
    #[test]
    fn nee_is_mitsubas_formula() {
        let origin = Vec3::new(0.5, 2.0, -1.0);
        let aim = look_at(origin, Vec3::new(0.2, 0.0, 0.3), Vec3::new(0.0, 1.0, 0.2)).unwrap();
        let cases: [(&str, Mat4, Option<(f64, &str)>); 5] = [
            ("fov = 50\nscale = 3", aim, Some((50.0, "x"))),
            ("fov = 40\nfov_axis = \"y\"", aim * Mat4::from_scale(Vec3::splat(2.0)), Some((40.0, "y"))),
            ("fov = 60\nfov_axis = \"diagonal\"\nscale = 0.5", aim * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)), Some((60.0, "diagonal"))),
            ("fov = 165", aim, Some((165.0, "x"))),
            ("focal_length = \"35mm\"", aim, None),
        ];
        let mut lit = 0;
        for (text, to_world, fov) in cases {
            let projector = build_from(text, to_world).unwrap();
            let scale = text.lines().find_map(|l| l.strip_prefix("scale = ")).map_or(1.0, |s| s.parse().unwrap());
            for tex in [bitmap(), Texture::Constant(Vec3::new(0.3, 0.6, 0.9))] {
                let (w, h) = tex.resolution();
                let aspect = f64::from(w) / f64::from(h);
                let x_fov = match fov {
                    Some((fov, axis)) => mitsuba_x_fov(fov, axis, aspect),
                    None => mitsuba_x_fov(2.0 * (36f64.hypot(24.0) / 70.0).atan().to_degrees(), "diagonal", aspect),
                };
                let Some(Light::Point(light)) = projector.light(tex.clone()) else { panic!("{text}: no light") };
                let mut s = Sampler::for_key(41, lit as u64, 0);
                for _ in 0..2000 {
                    let p = Vec3::new(-3.0, -1.0, -3.0) + s.next_2d().extend(s.next_1d()) * Vec3::new(6.0, 2.5, 6.0);
                    let ours = light.sample_li(p).map(|ls| ls.li);
                    match (mitsuba_li(to_world, x_fov, &tex, scale, p), ours) {
                        (Some(m), _) if m.is_nan() => {}
                        (Some(m), Some(o)) => {
                            lit += 1;
                            assert!((o - m).abs().max_element() <= 2e-4 * m.max_element(), "{text}, {p:?}: {o:?} vs Mitsuba's {m:?}");
                        }
                        (None, None) => {}
                        (m, o) => panic!("{text}, {p:?}: ours {o:?}, Mitsuba's {m:?}"),
                    }
                }
            }
        }
        assert!(lit > 3000, "too few lit points: {lit}");
    }

    /// The projector's film is the `perspective` camera's: the camera ray through film position (x, y)
    /// of a film the texture's size reads the texture at (x/width, y/height).
    #[test]
    fn film_is_the_cameras() {
        let to_world = look_at(Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO, Vec3::Y).unwrap();
        for (text, axis) in [("fov = 45", FovAxis::X), ("fov = 45\nfov_axis = \"y\"", FovAxis::Y), ("fov = 45\nfov_axis = \"smaller\"", FovAxis::Smaller)] {
            let Some(Light::Point(light)) = build_from(text, to_world).unwrap().light(bitmap()) else { panic!() };
            let camera = Camera::new(to_world, 45.0, axis, 4, 2).unwrap();
            let frustum = light.projector_profile().unwrap().frustum();
            for (x, y) in [(0.5, 0.5), (3.9, 0.1), (2.0, 1.0), (0.25, 1.75)] {
                let (uv, _) = frustum.film_uv(camera.generate_ray(x, y).dir).expect("inside the film");
                assert!((uv - Vec2::new(x / 4.0, y / 2.0)).abs().max_element() < 1e-5, "{text} ({x}, {y}): uv {uv:?}");
            }
        }
    }

    #[test]
    fn bad_values_are_named_by_key() {
        let key = |text: &str, m: Mat4| build_from(text, m).unwrap_err().key;
        assert_eq!(key("fov = 0", Mat4::IDENTITY), "fov");
        assert_eq!(key("fov = 180", Mat4::IDENTITY), "fov");
        assert_eq!(key("fov = 30\nfocal_length = \"50mm\"", Mat4::IDENTITY), "focal_length");
        assert_eq!(key("focal_length = \"wide\"", Mat4::IDENTITY), "focal_length");
        assert_eq!(key("fov = 30\nfov_axis = \"z\"", Mat4::IDENTITY), "fov_axis");
        assert_eq!(key("scale = -1", Mat4::IDENTITY), "scale");
        assert_eq!(key("irradiance = -1", Mat4::IDENTITY), "irradiance");
        assert_eq!(key("scale = 1e38", Mat4::from_scale(Vec3::splat(10.0))), "scale");
        assert_eq!(key("fov = 30", Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0))), "to_world");
        // Nothing emitted: no light.
        assert!(build_from("scale = 0", Mat4::IDENTITY).unwrap().light(bitmap()).is_none());
        assert!(build_from("fov = 30", Mat4::IDENTITY).unwrap().light(Texture::Constant(Vec3::ZERO)).is_none());
    }
}
