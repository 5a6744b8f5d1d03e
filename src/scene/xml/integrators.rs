//! Mitsuba's integrator types and how caustica renders the image each one estimates. On a scene without
//! participating media (caustica refuses media), the volumetric and differentiable path tracers estimate
//! the image `path` does; `direct` is `path` with `max_depth = 2` (the emitters seen and one bounce of
//! direct light); `aov`, `moment` and `stokes` wrap integrators, whose image is rendered: `aov`'s
//! `aovs` are written beside it (`integrator.aovs`, module `scene::aov`), the extra channels of `moment`
//! and `stokes` are not. The rest are refused,
//! unless the command line chose the estimator (`--estimator`), which replaces them.
//!
//! `hide_emitters` follows `path`'s rule for every type read as `path` (`integrator::path`). Mitsuba's
//! `volpath` and `direct` have rules of their own (src/integrators/volpath.cpp, direct.cpp) that give the
//! same image except on camera paths through a `null` surface or a `mask` hole (where `path` also drops
//! what the path collected before it escapes, and shows an area emitter it scatters from).
//!
//! ```xml
//! <integrator type="volpath"><integer name="max_depth" value="8"/></integrator>   <!-- read as path -->
//! <integrator type="aov"><string name="aovs" value="nn:sh_normal"/><integrator type="path"/></integrator>
//! ```

/// How an integrator type is read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Reading {
    /// As `path`; `max_depth` is the depth the type fixes (else the property's, or the default).
    Path { max_depth: Option<i64> },
    /// The nested `<integrator>` is read instead.
    Inner,
    /// Refused, with why.
    Refused(&'static str),
}

/// (type, reading, why it gives `path`'s image).
const TYPES: &[(&str, Reading, &str)] = &[
    ("path", Reading::Path { max_depth: None }, "the path tracer"),
    ("volpath", Reading::Path { max_depth: None }, NO_MEDIA),
    ("volpathmis", Reading::Path { max_depth: None }, NO_MEDIA),
    ("prbvolpath", Reading::Path { max_depth: None }, NO_MEDIA),
    ("prb", Reading::Path { max_depth: None }, DIFFERENTIABLE),
    ("prb_basic", Reading::Path { max_depth: None }, DIFFERENTIABLE),
    ("prb_projective", Reading::Path { max_depth: None }, DIFFERENTIABLE),
    ("ptracer", Reading::Path { max_depth: None }, "a particle tracer estimates the same image from the lights"),
    ("direct", Reading::Path { max_depth: Some(2) }, DIRECT),
    ("direct_projective", Reading::Path { max_depth: Some(2) }, DIRECT),
    ("aov", Reading::Inner, ""),
    ("moment", Reading::Inner, ""),
    // Polarisation is out of caustica's scope; in Mitsuba's RGB variants `stokes` adds Stokes channels
    // to its nested integrator's image, which is what is rendered.
    ("stokes", Reading::Inner, ""),
    ("depth", Reading::Refused("it renders depth, not radiance"), ""),
];

const NO_MEDIA: &str = "without participating media it estimates the path tracer's image";
const DIFFERENTIABLE: &str = "a differentiable path tracer: its primal image is the path tracer's";
const DIRECT: &str = "direct illumination is the path tracer's image with max_depth 2";

/// How integrator type `kind` is read.
pub(crate) fn reading(kind: &str) -> Reading {
    TYPES.iter().find(|(t, ..)| *t == kind).map_or(
        Reading::Refused("caustica renders Mitsuba's path, volpath, volpathmis, prb, prbvolpath, ptracer, direct, aov, moment and stokes integrators"),
        |(_, r, _)| *r,
    )
}

/// Why type `kind` (read as path) gives the path tracer's image.
pub(crate) fn why(kind: &str) -> &'static str {
    TYPES.iter().find(|(t, ..)| *t == kind).map_or("", |(.., w)| *w)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn types_read_as_path_inner_or_refused() {
        assert_eq!(reading("volpath"), Reading::Path { max_depth: None });
        assert_eq!(reading("direct"), Reading::Path { max_depth: Some(2) });
        assert_eq!(reading("aov"), Reading::Inner);
        assert_eq!(reading("stokes"), Reading::Inner);
        assert!(matches!(reading("depth"), Reading::Refused(w) if w.contains("depth")));
        assert!(matches!(reading("my_research_integrator"), Reading::Refused(_)));
    }
}
