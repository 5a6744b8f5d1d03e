//! Mitsuba's `spot` emitter (`spot.cpp`): `intensity` (W/sr at the centre, default 1) from the origin of
//! `to_world`, shining along its +z (a `look_at` aims it), full inside `beam_width` and falling off to zero
//! at `cutoff_angle` (degrees); with a `texture` (a bitmap or checkerboard: Mitsuba requires one that varies
//! over uv), the intensity along each direction is also multiplied by the texture at Mitsuba's
//! `direction_to_uv`, `uv = ½ + (x, y)/(2·z·tan cutoff)` in the spot's frame (`light::SpotTexture`: the
//! projector's film rule), so a slide is projected square onto the cone's base.
//!
//! A spot's `to_world` must not shear or scale non-uniformly (rotations, uniform scales, mirrors and
//! translations only): Mitsuba measures the beam's angles in the spot's own frame, and such a transform
//! would make the beam elliptical. A textured spot's cutoff must be below 90° (the film at z = 1 holds
//! the cone only then).
//!
//! ```toml
//! [[emitter]]
//! type = "spot"
//! intensity = 50
//! cutoff_angle = 25      # (0, 180], default 20
//! beam_width = 15        # [0, cutoff_angle], default ¾ of the cutoff
//! texture = { type = "bitmap", filename = "slide.png" }   # optional; a texture, not a colour
//! to_world = { look_at = { origin = [0, 5, 0], target = [0, 0, 0], up = [0, 0, 1] } }
//! ```

use super::{power, similarity_scale, Emitter, Plugin};
use crate::light::{Light, PointLight, SpotProfile, SpotTexture};
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};
use crate::texture::Texture;

/// Mitsuba's default `cutoff_angle` of a spot, degrees.
const SPOT_CUTOFF_DEG: f32 = 20.0;
/// Mitsuba's default `beam_width` as a fraction of the cutoff angle.
const SPOT_BEAM_FRACTION: f32 = 0.75;

pub(super) const PLUGIN: Plugin = Plugin {
    name: super::SPOT,
    keys: &["intensity", "cutoff_angle", "beam_width", "texture", "to_world"],
    nested: &["to_world"],
    build,
};

/// A spot as its file describes it; its light needs the texture, when it has one ([`Spot::light`]).
#[derive(Clone, Debug)]
pub struct Spot {
    position: Vec3,
    intensity: Vec3,
    profile: SpotProfile,
    /// `to_world`'s linear part divided by its uniform scale (orthonormal).
    frame: Mat3,
    /// Whether `texture` is given (the scene reader binds it).
    pub textured: bool,
}

fn build(mut p: Props<'_, Mat4>) -> Result<Emitter, PropError> {
    let to_world = p.take_nested("to_world").unwrap_or(Mat4::IDENTITY);
    let intensity = power(&p, "intensity")?;
    let cutoff = p.float_or("cutoff_angle", SPOT_CUTOFF_DEG)?;
    if !(cutoff > 0.0 && cutoff <= 180.0) {
        return Err(PropError::new("cutoff_angle", format!("the cutoff angle must be in (0, 180] degrees, got {cutoff}")));
    }
    let beam = p.float_or("beam_width", SPOT_BEAM_FRACTION * cutoff)?;
    if !(0.0..=cutoff).contains(&beam) {
        return Err(PropError::new("beam_width", format!("the beam width must be in [0, cutoff_angle = {cutoff}] degrees, got {beam}")));
    }
    let textured = p.has("texture") || p.is_textured("texture");
    if textured {
        // Mitsuba: "The parameter 'texture' must be spatially varying (e.g. bitmap type)!"
        p.require_texture("texture", "a texture varying over uv, such as a bitmap (Mitsuba refuses a constant)")?;
        p.radiance_or("texture", Vec3::ONE)?;
        if cutoff >= 90.0 {
            return Err(PropError::new("texture", format!("a textured spot's cutoff_angle must be below 90 degrees (its uv are x/(z·tan cutoff)), got {cutoff}")));
        }
    }
    let linear = Mat3::from_mat4(to_world);
    let k = similarity_scale(linear, "spot").map_err(|m| PropError::new("to_world", m))?;
    let profile = SpotProfile::new(linear * Vec3::Z, cutoff, beam)
        .ok_or_else(|| PropError::new("to_world", "the transform maps the spot's axis +z to a zero vector"))?;
    let position = to_world.transform_point3(Vec3::ZERO);
    Ok(Emitter::Spot(Spot { position, intensity, profile, frame: linear * (1.0 / k), textured }))
}

impl Spot {
    /// The light, its beam multiplied by `texture` when the spot has one, or `None` when it emits nothing
    /// (as every emitter of zero power is left out).
    #[must_use]
    pub fn light(&self, texture: Option<Texture>) -> Option<Light> {
        if self.intensity == Vec3::ZERO {
            return None;
        }
        Some(Light::Point(match texture {
            None => PointLight::new(self.position, self.intensity, Some(self.profile)),
            Some(t) => {
                if t.max().max_element() <= 0.0 {
                    return None;
                }
                let texture = SpotTexture::new(&self.profile, self.frame, t)?;
                PointLight::textured_spot(self.position, self.intensity, self.profile, texture)
            }
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;
    use crate::scene::look_at;
    use crate::texture::{Bitmap, FilterType, TextureImage, WrapMode};
    use std::sync::Arc;

    fn spot(text: &str, to_world: Mat4, texture: Option<Texture>) -> Result<Option<Light>, PropError> {
        let table: toml::Table = text.parse().unwrap();
        match (PLUGIN.build)(Props::new(&table, PLUGIN.keys, vec![("to_world", to_world)]))? {
            Emitter::Spot(s) => Ok(s.light(texture)),
            other => panic!("not a spot: {other:?}"),
        }
    }

    /// A 4×2 bitmap with a distinct colour per texel, looked up without interpolation.
    fn bitmap() -> Texture {
        let data: Vec<f32> = (0..8).flat_map(|i| [1.0 + i as f32, 0.5 + 0.25 * i as f32, 9.0 - i as f32]).collect();
        let image = TextureImage::from_linear("texels.exr", 4, 2, 3, data).unwrap();
        Texture::Bitmap(Bitmap::new(Arc::new(image), FilterType::Nearest, WrapMode::Clamp))
    }

    /// The radiance arriving at `p` from a textured spot as Mitsuba's `sample_direction` computes it (in
    /// f64): `local = to_world⁻¹·(p − origin)`, the falloff of its normalised direction, `uv = ½ + ½·(x,
    /// y)/(z·tan cutoff)`, `I·T(uv)·falloff/r²`; and that without the falloff.
    fn mitsuba_li(to_world: Mat4, intensity: f64, cutoff: f64, beam: f64, tex: &Texture, p: Vec3) -> Option<(Vec3, Vec3)> {
        let m = to_world.as_dmat4();
        let origin = m.transform_point3(glam::DVec3::ZERO);
        let d = p.as_dvec3() - origin;
        let local = m.inverse().transform_vector3(d);
        let l = local.normalize();
        let (c, b) = (cutoff.to_radians(), beam.to_radians());
        if !(l.z > c.cos()) {
            return None;
        }
        let falloff = if l.z >= b.cos() { 1.0 } else { (c - l.z.acos()) / (c - b) };
        let uv = glam::DVec2::new(0.5 + 0.5 * local.x / (local.z * c.tan()), 0.5 + 0.5 * local.y / (local.z * c.tan()));
        // Points within 10⁻³ of a texel edge may fall either side in f32: not compared.
        let texel = uv * glam::DVec2::new(4.0, 2.0);
        if (texel - texel.round()).abs().min_element() < 1e-3 {
            return Some((Vec3::NAN, Vec3::NAN));
        }
        let full = tex.eval_rgb(uv.as_vec2()).as_dvec3() * intensity / d.length_squared();
        Some(((full * falloff).as_vec3(), full.as_vec3()))
    }

    /// NEE from a textured spot is Mitsuba's `sample_direction` for aimed, scaled and mirrored transforms
    /// and narrow and wide beams, at points all around it, lit or not.
    #[test]
    fn nee_is_mitsubas_formula() {
        let origin = Vec3::new(0.5, 2.0, -1.0);
        let aim = look_at(origin, Vec3::new(0.2, 0.0, 0.3), Vec3::new(0.0, 1.0, 0.2)).unwrap();
        let cases: [(f64, f64, f64, Mat4); 4] = [
            (3.0, 30.0, 20.0, aim),
            (1.0, 50.0, 10.0, aim * Mat4::from_scale(Vec3::splat(2.0))),
            (0.5, 15.0, 15.0, aim * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0))),
            (2.0, 80.0, 0.0, aim),
        ];
        let mut lit = 0;
        for (k, (intensity, cutoff, beam, to_world)) in cases.into_iter().enumerate() {
            let text = format!("intensity = {intensity}\ncutoff_angle = {cutoff}\nbeam_width = {beam}");
            let Some(Light::Point(light)) = spot(&text, to_world, Some(bitmap())).unwrap() else { panic!("{text}: no light") };
            let mut s = Sampler::for_key(42, k as u64, 0);
            for _ in 0..4000 {
                let p = Vec3::new(-3.0, -1.0, -3.0) + s.next_2d().extend(s.next_1d()) * Vec3::new(6.0, 2.5, 6.0);
                let ours = light.sample_li(p).map(|ls| ls.li);
                // The falloff's f32 acos near the cutoff: 10⁻³ of the value without the falloff.
                match (mitsuba_li(to_world, intensity, cutoff, beam, &bitmap(), p), ours) {
                    (Some((m, _)), _) if m.is_nan() => {}
                    (Some((m, full)), Some(o)) => {
                        lit += 1;
                        assert!((o - m).abs().max_element() <= 1e-3 * full.max_element(), "{text}, {p:?}: {o:?} vs Mitsuba's {m:?}");
                    }
                    (None, None) => {}
                    (Some((m, full)), None) if m.max_element() <= 1e-3 * full.max_element() => {}
                    (m, o) => panic!("{text}, {p:?}: ours {o:?}, Mitsuba's {m:?}"),
                }
            }
        }
        assert!(lit > 2000, "too few lit points: {lit}");
    }

    #[test]
    fn bad_values_are_named_by_key() {
        let key = |text: &str| spot(text, Mat4::IDENTITY, None).unwrap_err().key;
        assert_eq!(key("cutoff_angle = 0"), "cutoff_angle");
        assert_eq!(key("beam_width = 30"), "beam_width");
        // A colour is not a texture (Mitsuba: "must be spatially varying").
        assert_eq!(key("texture = 0.5"), "texture");
        let table: toml::Table = "cutoff_angle = 90".parse().unwrap();
        let textured = crate::props::Textured { mean: Vec3::ONE, mean_1: 1.0, max: Vec3::ONE, min: Vec3::ZERO };
        let props = Props::new(&table, PLUGIN.keys, vec![("to_world", Mat4::IDENTITY)]).with_textures(vec![("texture", textured)]);
        assert_eq!((PLUGIN.build)(props).unwrap_err().key, "texture");
        // Nothing emitted: no light.
        assert!(spot("intensity = 0", Mat4::IDENTITY, Some(bitmap())).unwrap().is_none());
        assert!(spot("", Mat4::IDENTITY, Some(Texture::Constant(Vec3::ZERO))).unwrap().is_none());
    }
}
