//! Indices of refraction as Mitsuba's dielectric plugins take them: a number, or a name from Mitsuba's
//! table (`include/mitsuba/render/ior.h`), any case.

use super::Bsdf;
use crate::props::{NumberOrName, PropError, Props};

/// Mitsuba's default interior index (`dielectric`'s `int_ior`): BK7 glass.
pub(super) const BK7: f32 = 1.5046;
/// Mitsuba's default exterior index (`ext_ior`): air.
pub(super) const AIR: f32 = 1.000277;

/// Mitsuba's named indices of refraction (`mitsuba/render/ior.h`).
const IOR_TABLE: &[(&str, f32)] = &[
    ("vacuum", 1.0),
    ("helium", 1.000036),
    ("hydrogen", 1.000132),
    ("air", AIR),
    ("carbon dioxide", 1.00045),
    ("water", 1.3330),
    ("acetone", 1.36),
    ("ethanol", 1.361),
    ("carbon tetrachloride", 1.461),
    ("glycerol", 1.4729),
    ("benzene", 1.501),
    ("silicone oil", 1.52045),
    ("bromine", 1.661),
    ("water ice", 1.31),
    ("fused quartz", 1.458),
    ("pyrex", 1.470),
    ("acrylic glass", 1.49),
    ("polypropylene", 1.49),
    ("bk7", BK7),
    ("sodium chloride", 1.544),
    ("amber", 1.55),
    ("pet", 1.5750),
    ("diamond", 2.419),
];

/// The index of refraction at `key`: a positive finite number or a name from Mitsuba's table; `default`
/// when absent.
pub(super) fn ior_or(p: &Props<'_, Bsdf>, key: &str, default: f32) -> Result<f32, PropError> {
    match p.number_or_name(key)? {
        None => Ok(default),
        Some(NumberOrName::Number(x)) => crate::props::positive(x, "an index of refraction").map_err(|m| PropError::new(key, m)),
        Some(NumberOrName::Name(name)) => IOR_TABLE
            .iter()
            .find(|(n, _)| n.eq_ignore_ascii_case(name))
            .map(|&(_, x)| x)
            .ok_or_else(|| {
                let names: Vec<&str> = IOR_TABLE.iter().map(|(n, _)| *n).collect();
                PropError::new(key, format!("unknown IOR name {name:?}; known: {}", names.join(", ")))
            }),
    }
}

/// `int_ior / ext_ior` with these defaults, refused where the two are equal: Mitsuba's rough dielectric
/// plugins (`roughdielectric`, `roughplastic`) require the indices to "be positive and differ" (an
/// interface of one index has no half vector for refraction).
pub(super) fn relative_eta(p: &Props<'_, Bsdf>, int_default: f32, ext_default: f32) -> Result<f32, PropError> {
    let (int_ior, ext_ior) = (ior_or(p, "int_ior", int_default)?, ior_or(p, "ext_ior", ext_default)?);
    if int_ior == ext_ior {
        return Err(PropError::new("int_ior", format!("int_ior and ext_ior are both {int_ior}: they must differ (as in Mitsuba)")));
    }
    Ok(int_ior / ext_ior)
}
