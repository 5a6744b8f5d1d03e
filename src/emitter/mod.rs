//! Emitter plugins: one file per Mitsuba emitter type, each with its keys, defaults and checks (read from
//! [`Props`] by its constructor), as the shapes (`crate::shape`) and BSDFs (`crate::bsdf`) have theirs.
//!
//! | type | keys | becomes |
//! |---|---|---|
//! | `area` | `radiance` (a colour or a texture) | the area light of the shape it is attached to |
//! | `envmap` | `filename`, `scale`, `to_world` | an environment map, loaded with the scene's files |
//! | `constant` | `radiance` | a uniform environment |
//! | `point` | `intensity`, `position` or `to_world` | a point light |
//! | `spot` | `intensity`, `cutoff_angle`, `beam_width`, `texture` (a texture over the beam), `to_world` | a point light with a beam profile |
//! | `projector` | `irradiance` (a colour or a texture), `scale`, `fov`, `fov_axis`, `focal_length`, `to_world` | a point light with a textured frustum |
//! | `directional` | `irradiance`, `direction` or `to_world` | a directional light |
//! | `sunsky` | `sun_direction` or `latitude`, `longitude`, `timezone`, `year`, `month`, `day`, `hour`, `minute`, `second`; `turbidity`, `albedo`, `sun_scale`, `sky_scale`, `sun_aperture`, `complex_sun`, `to_world` | an environment map of the Hošek–Wilkie sky carrying the sun's disc |
//!
//! An emitter's `to_world` is its nested value ([`Props::take_nested`]): the scene reader turns it into a
//! matrix (`scene::transform`) before the constructor runs. A new emitter type is a file here and its line in
//! [`PLUGINS`]; what it becomes at run time is a [`crate::light::Light`].

mod area;
mod constant;
mod directional;
mod envmap;
mod point;
mod projector;
mod spot;
mod sunsky;
mod sunsky_model;
mod sunsky_position;
#[cfg(test)]
mod tests_sunsky;

pub use projector::Projector;
pub use spot::Spot;

use crate::light::Light;
use crate::math::{Mat3, Mat4, Vec3};
use crate::props::{PropError, Props};

/// An emitter type as the scene files name it; its nested value is its `to_world` matrix.
pub(crate) type Plugin = crate::props::Plugin<Emitter, Mat4>;

/// Every emitter type.
pub(crate) const PLUGINS: &[&Plugin] =
    &[&area::PLUGIN, &envmap::PLUGIN, &constant::PLUGIN, &point::PLUGIN, &spot::PLUGIN, &projector::PLUGIN, &directional::PLUGIN, &sunsky::PLUGIN];

/// The emitter type attached to shapes (every other type stands alone).
pub(crate) const AREA: &str = "area";

/// The stand-alone emitter types whose keys may be textures (a projector's `irradiance`, a spot's `texture`).
pub(crate) const PROJECTOR: &str = "projector";
pub(crate) const SPOT: &str = "spot";

/// An emitter as its file describes it.
#[derive(Clone, Debug)]
pub enum Emitter {
    /// `area`: the radiance of the shape's surface (a texture's mean when textured; the scene reader binds
    /// the texture itself).
    Area { radiance: Vec3 },
    /// `envmap`: the image at `filename` (relative to the scene file), loaded with the scene's other files.
    Env { filename: String, scale: f32, to_world: Mat4 },
    /// `constant`: the same radiance from every direction.
    Constant { radiance: Vec3 },
    /// `projector`: its light once the scene reader has its texture ([`Projector::light`]).
    Projector(Projector),
    /// `spot`: its light once the scene reader has its texture, if it has one ([`Spot::light`]).
    Spot(Spot),
    /// `point`, `directional`, `sunsky`: the light itself, built whole by the constructor (no file or texture
    /// for the scene reader to bind); `None` when it emits nothing (left out of the scene, as every emitter of
    /// zero power is).
    Built(Option<Light>),
}

/// The emitter type Mitsuba names `name`.
pub(crate) fn plugin(name: &str) -> Option<&'static Plugin> {
    crate::props::find(PLUGINS, name)
}

/// A non-negative colour at `key`, default 1 (Mitsuba's default radiance, intensity and irradiance).
fn power(p: &Props<'_, Mat4>, key: &str) -> Result<Vec3, PropError> {
    p.radiance_or(key, Vec3::ONE)
}

/// Refuses `key` together with `to_world` (Mitsuba refuses both); returns them.
fn either_or_to_world(p: &mut Props<'_, Mat4>, key: &str) -> Result<(Option<Vec3>, Option<Mat4>), PropError> {
    let given = p.vec3(key)?;
    let to_world = p.take_nested("to_world");
    if given.is_some() && to_world.is_some() {
        return Err(PropError::new(key, format!("give either `{key}` or `to_world`, not both (Mitsuba refuses both)")));
    }
    Ok((given, to_world))
}

/// The uniform scale k of `m` if it is a rotation (or mirror) times k: orthogonal columns of one length
/// (relative tolerance 10⁻⁴). A spot or projector measures its beam's angles in its own frame, and a shear
/// or a non-uniform scale would distort the beam; the message names the `kind` of emitter.
fn similarity_scale(m: Mat3, kind: &str) -> Result<f32, String> {
    let cols = [m.x_axis, m.y_axis, m.z_axis];
    let len2 = cols.map(Vec3::length_squared);
    let s2 = (len2[0] + len2[1] + len2[2]) / 3.0;
    let tol = 1e-4 * s2;
    let equal = len2.iter().all(|l| (l - s2).abs() <= 2.0 * tol);
    let orthogonal = [(0, 1), (0, 2), (1, 2)].iter().all(|&(i, j)| cols[i].dot(cols[j]).abs() <= tol);
    if s2 > 0.0 && s2.is_finite() && equal && orthogonal {
        Ok(s2.sqrt())
    } else {
        Err(format!("a {kind}'s transform may rotate, mirror, scale uniformly and translate, but not shear or scale non-uniformly (its beam would be distorted)"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn build(text: &str, to_world: Option<Mat4>) -> Result<Emitter, PropError> {
        let mut table: toml::Table = text.parse().unwrap();
        let kind = table.remove("type").unwrap();
        let plugin = plugin(kind.as_str().unwrap()).unwrap();
        let nested = to_world.map(|m| ("to_world", m)).into_iter().collect();
        (plugin.build)(Props::new(&table, plugin.keys, nested))
    }

    #[test]
    fn defaults_are_mitsubas() {
        assert!(matches!(build("type = \"area\"", None), Ok(Emitter::Area { radiance }) if radiance == Vec3::ONE));
        assert!(matches!(build("type = \"constant\"", None), Ok(Emitter::Constant { radiance }) if radiance == Vec3::ONE));
        let Ok(Emitter::Built(Some(Light::Point(p)))) = build("type = \"point\"", None) else { panic!() };
        assert_eq!(p.position(), Vec3::ZERO);
        let Ok(Emitter::Built(Some(Light::Point(p)))) = build("type = \"point\"", Some(Mat4::from_translation(Vec3::X))) else { panic!() };
        assert_eq!(p.position(), Vec3::X);
        assert!(matches!(build("type = \"directional\"\nirradiance = 0", None), Ok(Emitter::Built(None))));
    }

    #[test]
    fn bad_values_are_named_by_key() {
        let e = build("type = \"point\"\nposition = [0, 0, 1]", Some(Mat4::IDENTITY)).unwrap_err();
        assert_eq!(e.key, "position");
        assert_eq!(build("type = \"spot\"\ncutoff_angle = 0", None).unwrap_err().key, "cutoff_angle");
        assert_eq!(build("type = \"spot\"\nbeam_width = 30", None).unwrap_err().key, "beam_width");
        assert_eq!(build("type = \"spot\"", Some(Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)))).unwrap_err().key, "to_world");
        assert_eq!(build("type = \"envmap\"", None).unwrap_err().message, "emitter type `envmap` needs `filename`");
        assert_eq!(build("type = \"envmap\"\nfilename = \"a.exr\"\nscale = -1", None).unwrap_err().key, "scale");
        assert_eq!(build("type = \"directional\"\ndirection = [0, 0, 0]", None).unwrap_err().key, "direction");
        assert_eq!(build("type = \"area\"\nradiance = -1", None).unwrap_err().key, "radiance");
    }
}
