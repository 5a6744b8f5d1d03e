//! Mitsuba 3 XML scene files → the scene description (`desc`) that TOML scene files deserialise into, so
//! both formats are built by the same code (`build`) and mean the same thing.
//!
//! ```xml
//! <scene version="3.0.0">
//!     <default name="spp" value="64"/>                     <!-- $spp; `-D spp=16` overrides it -->
//!     <integrator type="path">
//!         <integer name="max_depth" value="-1"/>
//!         <integer name="rr_depth" value="5"/>
//!         <string name="caustics_estimator" value="mis"/>  <!-- caustica's extension, see below -->
//!     </integrator>
//!     <sensor type="perspective">
//!         <float name="fov" value="39.3077"/>
//!         <string name="fov_axis" value="smaller"/>
//!         <transform name="to_world"><lookat origin="0, 0, 3.9" target="0, 0, 0" up="0, 1, 0"/></transform>
//!         <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
//!         <film type="hdrfilm">
//!             <integer name="width" value="256"/><integer name="height" value="256"/>
//!             <rfilter type="gaussian"><float name="stddev" value="0.5"/></rfilter>  <!-- the default -->
//!         </film>
//!     </sensor>
//!     <include filename="materials.xml"/>                  <!-- relative to this file's directory -->
//!     <shape type="rectangle">
//!         <transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1"/></transform>
//!         <ref id="white"/>                                  <!-- a <bsdf id="white"> -->
//!     </shape>
//! </scene>
//! ```
//!
//! **What is read.** `<default>`, `$name` in any attribute value, `<include>`, `id` and `<ref id>` (to
//! BSDFs), `name` attributes of nested plugins (ignored: the nesting decides the role); `<transform>` with
//! `translate`, `rotate`, `scale`, `matrix` (16 or 9 numbers) and `lookat`, applied in the order written;
//! `<sensor type="perspective">` with `fov` or `focal_length`, `fov_axis`, `near_clip`, `far_clip`;
//! `thinlens` with these and `aperture_radius`, `focus_distance`; `orthographic` with `near_clip`,
//! `far_clip` (`crate::camera`); `<film type="hdrfilm">`
//! with `width`, `height`, `crop_offset_x/y`, `crop_width/height`; `<rfilter>` of every Mitsuba type with its
//! properties (`box`, `tent` radius, `gaussian` stddev, `mitchell` B/C, `catmullrom`, `lanczos` lobes:
//! `film::filter`); `<sampler>`
//! (`independent`, `stratified`, `multijitter`, `orthogonal`, `ldsampler`: caustica's own deterministic
//! sampler stands in for each) with `sample_count` and `seed`; `<integrator type="path">` with `max_depth`
//! and `rr_depth`; every shape, BSDF and emitter type and property of the TOML format (see [`crate::scene`]),
//! with `<rgb>`, `<float>` and `<spectrum>` colours. A `<spectrum>` (one value, `wavelength:value` pairs, or
//! `filename="….spd"`) becomes the colour Mitsuba 3.9.1's RGB variants make of it (module `spectrum`): a
//! wavelength list is integrated against the CIE 1931 colour matching functions, and one value is grey
//! except as an emitted colour (`radiance`, `intensity`, `irradiance`), where it is the colour of an
//! equal-energy spectrum in sRGB, `value × (1.2048, 0.9483, 0.9089)`. Relative file names (meshes, maps,
//! spectra, includes) are relative to the directory of the scene file given, as Mitsuba resolves them.
//!
//! **Versions.** `version` is three numbers, as Mitsuba 3 reads it; files of Mitsuba 0.4–0.6 (version before
//! 2.0.0, e.g. `"0.5.0"`) are upgraded to 3.x in memory, each file by its own version (`upgrade`): camelCase
//! names become snake_case (`toWorld` → `to_world`, `maxDepth`, `intIOR` …), as Mitsuba 3 does, and beyond
//! Mitsuba 3, `<lookAt>`, `<srgb>`/`#rrggbb` colours and 0.6's copper default of conductors are read as 0.6
//! rendered them. Plugins that exist only in 0.x (`ldrfilm`, …) are refused as any unsupported plugin.
//!
//! **caustica's extension.** The caustic photon map's settings (`[integrator.caustics]` in TOML) are
//! properties of the path integrator prefixed `caustics_`: `<string name="caustics_estimator" value="mis"/>`,
//! `<integer name="caustics_photons" …/>`, `caustics_caustic_photons`, `caustics_knn`, `<float
//! name="caustics_max_radius" …/>`. Mitsuba itself rejects these properties; a file meant for both
//! renderers leaves them out (the default estimator `pt` is Mitsuba's path tracer).
//!
//! **Differences from Mitsuba.** Spectrum plugins (`<spectrum type="blackbody">`, ...) are refused, as
//! Mitsuba's RGB variants cannot render them (its spectral variants can; caustica renders in RGB). None in
//! the film: a film without `<rfilter>` gets Mitsuba's default, the Gaussian of σ = 0.5. Every sensor clips
//! as Mitsuba's does (`near_clip`, `far_clip`: depths along the viewing axis, 0.01 and 10⁴ by default).
//!
//! **Errors.** Anything not supported — an element, a plugin type, a property, an attribute, a `$name`
//! without value — is an error naming the file, the line and the plugin or property; nothing is dropped.

mod bounds;
pub(crate) use bounds::{read_regular, Unreadable, MAX_INCLUDE_BYTES};
mod cie1931;
mod convert;
mod ignored;
mod integrators;
mod params;
mod places;
mod spectrum;
mod tree;
pub(crate) mod unsupported;
mod upgrade;
mod values;
pub(crate) mod write;

use std::collections::BTreeMap;
use std::path::Path;

pub(crate) use convert::ConvertOptions;
pub(crate) use places::Places;

use super::error::SceneError;
use super::note::SceneNote;

/// The description of the XML scene `text` (named `name` in errors) with the places of its keys and the
/// notes on what was read but not used as written; `params` are the `-D` values, `base_dir` (the scene
/// file's directory) resolves includes and file names.
pub(crate) fn read_str(
    text: &str,
    name: &Path,
    base_dir: &Path,
    params: &BTreeMap<String, String>,
    options: ConvertOptions,
) -> Result<(toml::Table, Places, Vec<SceneNote>), SceneError> {
    let mut search = tree::SearchPath::new(base_dir);
    let mut root = tree::read_tree(text, name, &mut search, params)?;
    spectrum::resolve_files(&mut root, &search);
    let unsupported = unsupported::scan(&root, options);
    if !unsupported.is_empty() {
        return Err(SceneError::Unsupported { file: name.to_path_buf(), items: unsupported });
    }
    convert::convert(&root, &search, options)
}
