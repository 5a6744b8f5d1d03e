//! Properties that Mitsuba reads and that change nothing in caustica's image: accepted, left out of the
//! description, and listed by `caustica info` (each with why it changes nothing), so a file written for
//! Mitsuba loads as it is without anything being dropped silently.
//!
//! ```xml
//! <film type="hdrfilm">
//!     <string name="pixel_format" value="rgba"/>   <!-- the output's format: ignored, noted -->
//! </film>
//! ```

use super::tree::Element;

/// (element tag, plugin type or `*` for any, property, why it changes no image).
const IGNORED: &[(&str, &str, &str, &str)] = &[
    ("film", "*", "pixel_format", FORMAT),
    ("film", "*", "component_format", FORMAT),
    ("film", "*", "file_format", FORMAT),
    ("film", "*", "banner", FORMAT),
    ("film", "*", "attach_log", FORMAT),
    ("film", "*", "high_quality_edges", "Mitsuba 0.x's edge sampling for wide filters (Mitsuba 3 ignores it too)"),
    ("sensor", "perspective", "focus_distance", "a pinhole camera is in focus at every distance"),
    ("sensor", "*", "shutter_open", SHUTTER),
    ("sensor", "*", "shutter_close", SHUTTER),
    ("sensor", "*", "shutter_open_time", SHUTTER),
    ("sampler", "*", "jitter", PATTERN),
    ("sampler", "*", "strength", PATTERN),
    ("sampler", "*", "scramble", PATTERN),
    ("sampler", "*", "dimension", PATTERN),
    ("integrator", "*", "samples_per_pass", "how the work is split into passes (caustica: --pass-spp)"),
    ("integrator", "*", "timeout", "a time limit on the render (caustica: --time-limit)"),
    ("integrator", "*", "strict_normals", "caustica's path tracer shades every vertex with its shading normal"),
    ("integrator", "direct", "emitter_samples", SAMPLES),
    ("integrator", "direct", "bsdf_samples", SAMPLES),
    ("integrator", "direct", "shading_samples", SAMPLES),
    ("emitter", "*", "sampling_weight", "how often the light is chosen for next-event estimation: the noise, not the image"),
];

const FORMAT: &str = "how Mitsuba writes its output file (caustica writes RGB float32 OpenEXR)";
const SHUTTER: &str = "nothing in the scene moves, so the shutter interval changes no image";
const PATTERN: &str = "the sampling pattern (caustica's own deterministic sampler stands in for each)";
const SAMPLES: &str = "samples per shading point: the noise, not the image";

/// Why property `name` of `plugin` changes no image in caustica, when it does not.
pub(crate) fn why(plugin: &Element, name: &str) -> Option<&'static str> {
    let kind = plugin.attr("type").unwrap_or_default();
    IGNORED
        .iter()
        .find(|(tag, ty, prop, _)| *tag == plugin.tag && (*ty == "*" || *ty == kind) && *prop == name)
        .map(|(.., why)| *why)
}
