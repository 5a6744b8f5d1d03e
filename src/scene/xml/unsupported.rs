//! Everything a Mitsuba scene uses that caustica cannot render, found at once: every unsupported tag,
//! plugin type and property, each with its file and line and what Mitsuba would do with it. `read_str`
//! runs this scan before converting, so `caustica info` and `render` refuse a scene with the whole list
//! (exit code 2), not one item per attempt. Properties that change no image (`ignored`) are not listed.
//! What is supported comes from the one list of plugin types and keys (`scene::plugins`) and the XML
//! reader's own lists (sensors, films, samplers, integrators).

use std::fmt;
use std::path::PathBuf;

use super::convert::{texture_key, ConvertOptions, CAUSTICS_PREFIX, SAMPLER_TYPES};
use super::ignored;
use super::integrators::{self, Reading};
use super::tree::Element;
use super::values::PROPERTY_TAGS;
use super::super::error::{cut, shown};
use super::super::plugins::{self, Role};

/// One thing caustica cannot render.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Unsupported {
    pub file: PathBuf,
    pub line: usize,
    /// The element, as errors name it (`<bsdf type="principled">`).
    pub element: String,
    /// What is unsupported, and what Mitsuba would do with it.
    pub message: String,
}

impl fmt::Display for Unsupported {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}: {}", self.file.display(), self.line, self.element, self.message)
    }
}

const LATER_MATERIALS: &str = "not supported yet (textures and materials are the next part of caustica's Mitsuba support)";
const OUT_OF_SCOPE: &str = "out of caustica's scope";

/// Mitsuba plugin types caustica lacks: (tag, type, what Mitsuba renders with it, when caustica will).
const MITSUBA_TYPES: &[(&str, &str, &str, &str)] = &[
    ("bsdf", "mixturebsdf", "a weighted mixture of BSDFs", LATER_MATERIALS),
    ("bsdf", "hair", "a hair fibre scattering model", OUT_OF_SCOPE),
    ("bsdf", "measured", "a measured (tabulated) BSDF", OUT_OF_SCOPE),
    ("bsdf", "measured_polarized", "a measured polarized BSDF", OUT_OF_SCOPE),
    ("bsdf", "polarizer", "a linear polarizer", OUT_OF_SCOPE),
    ("bsdf", "retarder", "a polarization retarder", OUT_OF_SCOPE),
    ("bsdf", "circular", "a circular polarizer", OUT_OF_SCOPE),
    ("shape", "bsplinecurve", "curves (hair, fur)", OUT_OF_SCOPE),
    ("shape", "linearcurve", "curves (hair, fur)", OUT_OF_SCOPE),
    ("shape", "sdfgrid", "a signed distance field", OUT_OF_SCOPE),
    ("emitter", "sky", "a sky (in 0.6 only; Mitsuba 3 dropped it: `sunsky` with `sun_scale` 0 is Mitsuba 3's sky)", OUT_OF_SCOPE),
    ("emitter", "sun", "a sun (in 0.6 only; Mitsuba 3 dropped it: `sunsky` with `sky_scale` 0 is Mitsuba 3's sun)", OUT_OF_SCOPE),
    ("sensor", "radiancemeter", "a radiance meter (one ray)", OUT_OF_SCOPE),
    ("sensor", "irradiancemeter", "an irradiance meter", OUT_OF_SCOPE),
    ("film", "specfilm", "a film of spectral channels", OUT_OF_SCOPE),
    ("texture", "volume", "a volume grid as a texture", OUT_OF_SCOPE),
];

/// Tags caustica has no element for: (tag, what Mitsuba does with it, when caustica will).
const MITSUBA_TAGS: &[(&str, &str, &str)] = &[
    ("medium", "a participating medium (fog, smoke, subsurface)", OUT_OF_SCOPE),
    ("phase", "a phase function of a participating medium", OUT_OF_SCOPE),
    ("volume", "a volume grid of a participating medium", OUT_OF_SCOPE),
];

/// Everything below `root` (includes spliced, parameters substituted) that caustica cannot render.
pub(crate) fn scan(root: &Element, options: ConvertOptions) -> Vec<Unsupported> {
    let mut found = Vec::new();
    for el in &root.children {
        visit(el, options, &mut found);
    }
    found
}

fn push(found: &mut Vec<Unsupported>, el: &Element, message: String) {
    found.push(Unsupported { file: el.file.as_ref().clone(), line: el.line, element: el.label(), message });
}

fn visit(el: &Element, options: ConvertOptions, found: &mut Vec<Unsupported>) {
    let tag = el.tag.as_str();
    if let Some((_, what, when)) = MITSUBA_TAGS.iter().find(|(t, ..)| *t == tag) {
        push(found, el, format!("<{tag}> is {when}; Mitsuba renders {what}"));
        return;
    }
    let kind = el.attr("type").unwrap_or_default();
    let keys: Option<Vec<&str>> = match tag {
        "bsdf" => plugins::keys(Role::Bsdf, kind),
        "shape" => plugins::keys(Role::Shape, kind),
        "emitter" => plugins::keys(Role::Emitter, kind),
        "rfilter" => plugins::keys(Role::RFilter, kind),
        "texture" => plugins::keys(Role::Texture, kind),
        "sensor" => plugins::keys(Role::Sensor, kind),
        "film" => (kind == "hdrfilm")
            .then(|| vec!["width", "height", "crop_offset_x", "crop_offset_y", "crop_width", "crop_height"]),
        "sampler" => SAMPLER_TYPES.contains(&kind).then(|| vec!["sample_count", "seed"]),
        "integrator" => return integrator(el, options, found),
        _ => return,
    };
    let Some(keys) = keys else {
        let message = match MITSUBA_TYPES.iter().find(|(t, k, ..)| *t == tag && *k == kind) {
            Some((.., what, when)) => format!("{tag} type {} is {when}; Mitsuba renders {what}", shown(kind)),
            None => format!("{tag} type {} is not a Mitsuba plugin caustica renders", shown(kind)),
        };
        push(found, el, message);
        return;
    };
    for child in &el.children {
        let is_property = PROPERTY_TAGS.contains(&child.tag.as_str()) || child.tag == "transform";
        if is_property {
            let name = child.attr("name").unwrap_or_default();
            if !keys.contains(&name) && ignored::why(el, name).is_none() {
                push(found, child, plugins::not_applicable(&cut(name), tag, &cut(kind), &keys));
            }
        } else {
            // Textures go on BSDF properties, an area emitter's radiance and a projector's irradiance.
            if child.tag == "texture" && tag != "bsdf" && !(tag == "emitter" && (kind == "area" || kind == "projector" || kind == "spot")) {
                push(found, child, format!("a texture on a {tag} is {LATER_MATERIALS}; Mitsuba varies the {tag}'s property over the surface"));
                continue;
            }
            let name = texture_key(kind, child.attr("name")).unwrap_or_default();
            if child.tag == "texture" && !keys.contains(&name) {
                push(found, child, plugins::not_applicable(&cut(name), tag, &cut(kind), &keys));
            }
            visit(child, options, found);
        }
    }
}

fn integrator(el: &Element, options: ConvertOptions, found: &mut Vec<Unsupported>) {
    let kind = el.attr("type").unwrap_or_default();
    match integrators::reading(kind) {
        Reading::Path { .. } => {
            for child in el.children.iter().filter(|c| PROPERTY_TAGS.contains(&c.tag.as_str())) {
                let name = child.attr("name").unwrap_or_default();
                let read = matches!(name, "max_depth" | "rr_depth" | "hide_emitters") || name.starts_with(CAUSTICS_PREFIX);
                if !read && ignored::why(el, name).is_none() {
                    let keys = ["max_depth", "rr_depth", "hide_emitters", "caustics_*"];
                    push(found, child, plugins::not_applicable(&cut(name), "integrator", &cut(kind), &keys));
                }
            }
        }
        Reading::Inner => {
            for child in el.children.iter().filter(|c| c.tag == "integrator") {
                integrator(child, options, found);
            }
        }
        Reading::Refused(why) if !options.replace_integrator => {
            push(found, el, format!("integrator type {} is not supported: {why}; `--estimator pt|pm|mis` replaces it by caustica's path tracer", shown(kind)));
        }
        Reading::Refused(_) => {}
    }
}
