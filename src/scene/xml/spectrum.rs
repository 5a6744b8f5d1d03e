//! `<spectrum>` properties → the RGB colour Mitsuba 3.9.1's RGB variants (`scalar_rgb`, ...) make of them, so
//! that an XML scene means in caustica what it means in Mitsuba's RGB renderer.
//!
//! ```xml
//! <spectrum name="reflectance" value="0.5"/>                                 <!-- one value -->
//! <spectrum name="reflectance" value="400:0.1, 500:0.5, 600:0.8, 700:0.9"/>  <!-- wavelength (nm):value -->
//! <spectrum name="radiance" filename="lamp.spd"/>      <!-- lines "wavelength value", # comments -->
//! ```
//!
//! **Mitsuba's rule** (`Properties::get_texture_impl`, src/core/properties.cpp) depends on how the plugin
//! reads the property ([`ColourUse`]): emitters read their colour with `get_emissive_texture`, the
//! conductors their `eta` and `k` with `get_unbounded_texture`, everything else with `get_texture`.
//! - One value `v`: as an emitted colour, `v` times the sRGB colour of an equal-energy spectrum, which is not
//!   grey in sRGB (white is D65): `v · xyz_to_srgb(1, 1, 1)` ≈ `v · (1.2048, 0.9483, 0.9089)`. Any other
//!   use keeps the plain value `v` (grey).
//! - Wavelength–value pairs (at least two, wavelengths increasing), inline or from a file:
//!   `spectrum_list_to_srgb` (src/core/spectrum.cpp) — the spectrum, linear between the pairs and zero
//!   outside them, times the CIE 1931 colour matching functions (times the D65 illuminant unless emitted),
//!   summed at 1000 wavelengths spread evenly over 360–830 nm, normalised so that a unit spectrum has
//!   luminance 1, then converted XYZ → linear sRGB. Negative components become 0; a reflectance's
//!   components above 1 become 1 (Mitsuba warns of both; caustica clamps silently).
//!
//! Mitsuba 3.0–3.6 decided by nesting instead (`within_emitter` in src/core/xml.cpp: any spectrum inside an
//! `<emitter>`; `eta`, `k`, `int_ior`, `ext_ior` unbounded); for the properties caustica reads, both rules
//! give the same colours.
//!
//! Relative spectrum file names are looked for along the search path, as meshes are ([`resolve_files`]),
//! Mitsuba's spectrum plugins (`<spectrum type="blackbody">`, `regular`, ...) are
//! refused: its RGB variants load them but cannot render them ("not implemented for non-spectral modes").

use std::path::Path;

use toml::Value;

use super::cie1931::{
    CIE1931_X, CIE1931_Y, CIE1931_Z, CIE_D65_NORMALIZATION, CIE_MAX, CIE_MIN, CIE_SAMPLES, CIE_Y_NORMALIZATION, D65,
    XYZ_TO_SRGB,
};
use super::tree::{Element, SearchPath};
use super::values::float_array;
use super::super::error::{cut, shown, SceneError};

/// How the plugin that reads a colour property uses it: the `emitter` and `unbounded` flags of Mitsuba's
/// `Properties::get_texture_impl`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ColourUse {
    /// `get_texture`: a reflectance or transmittance, at most 1.
    Reflectance,
    /// `get_unbounded_texture`: a spectrum that may exceed 1 but is not emitted (a conductor's `eta`, `k`).
    Unbounded,
    /// `get_emissive_texture`: an emitted colour.
    Emission,
}

impl ColourUse {
    /// How `plugin` reads its property `name`. Among the plugins caustica reads, Mitsuba 3.9.1 reads
    /// `radiance` (area, constant), `intensity` (point, spot) and `irradiance` (directional) with
    /// `get_emissive_texture` and the `eta` and `k` of `conductor` and `roughconductor` with
    /// `get_unbounded_texture` (src/emitters/*.cpp, src/bsdfs/conductor.cpp, roughconductor.cpp).
    pub(crate) fn of(plugin: &Element, name: &str) -> ColourUse {
        match (plugin.tag.as_str(), plugin.attr("type").unwrap_or_default(), name) {
            ("emitter", _, "radiance" | "intensity" | "irradiance") => ColourUse::Emission,
            ("bsdf", "conductor" | "roughconductor", "eta" | "k") => ColourUse::Unbounded,
            _ => ColourUse::Reflectance,
        }
    }
}

/// A spectrum as written: one value for all wavelengths, or values at increasing wavelengths (nm).
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Spectrum {
    Uniform(f64),
    Sampled { wavelengths: Vec<f64>, values: Vec<f64> },
}

/// The value of the `<spectrum>` element `el` of `plugin`: a number (grey) or `[r, g, b]`.
pub(crate) fn property_value(el: &Element, plugin: &Element) -> Result<Value, SceneError> {
    if let Some(kind) = el.attr("type") {
        return Err(el.error(match kind {
            "blackbody" => "a blackbody spectrum is not supported: Mitsuba renders it only in its spectral variants \
                            (its RGB variants fail with \"not implemented for non-spectral modes\"); give the \
                            emitted colour as <rgb>"
                .to_string(),
            _ => format!(
                "spectrum plugins (type={}) are not supported; give the colour as <rgb> or as \
                 <spectrum value=\"…\"> (one value or wavelength:value pairs) or filename=\"….spd\"",
                shown(kind)
            ),
        }));
    }
    el.check_attrs(&["name", "value", "filename"])?;
    if let Some(child) = el.children.first() {
        return Err(child.error(format!("{} has no nested elements (without a type)", el.label())));
    }
    let spectrum = match (el.attr("value"), el.attr("filename")) {
        (Some(text), None) => parse_value(text).map_err(|m| el.error(format!("attribute `value`: {m}")))?,
        (None, Some(file)) => {
            // Read as an included file is (a regular file within the bound on one), so that /dev/zero or a
            // FIFO is refused instead of read without end.
            let text = super::bounds::read_regular(Path::new(file), super::bounds::MAX_INCLUDE_BYTES)
                .map_err(|e| el.error(format!("cannot read {}: {e}", cut(file))))?;
            parse_file(&text).map_err(|(line, m)| el.error(format!("{}:{line}: {m}", cut(file))))?
        }
        _ => return Err(el.error("<spectrum> needs either the attribute `value` or `filename`, not both")),
    };
    let name = el.required("name")?;
    Ok(match rgb(&spectrum, ColourUse::of(plugin, name)) {
        Colour::Grey(v) => Value::Float(v),
        Colour::Rgb(c) => float_array(&c),
    })
}

/// Looks for the `filename` of every `<spectrum>` below `el` along the search path (`<path>`s, the scene
/// file's directory, then the directory of the file that names it, as for meshes); a name found nowhere
/// becomes relative to the scene file's directory, where the error names it.
pub(crate) fn resolve_files(el: &mut Element, search: &SearchPath) {
    if el.tag == "spectrum" {
        let own_dir = el.file.parent().map(Path::to_path_buf);
        for (name, value) in &mut el.attrs {
            if name == "filename" {
                let found = search.resolve(value, own_dir.as_deref()).unwrap_or_else(|| search.base_dir().join(&*value));
                *value = found.to_string_lossy().into_owned();
            }
        }
    }
    for child in &mut el.children {
        resolve_files(child, search);
    }
}

/// A finite number.
fn number(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        _ => Err(format!("{} is not a finite number", shown(s))),
    }
}

/// `value="0.5"` or `value="400:0.1, 500:0.5"`: tokens separated by commas and/or spaces, one number or
/// wavelength:value pairs (Mitsuba's `Properties::Spectrum(std::string_view)`).
pub(crate) fn parse_value(text: &str) -> Result<Spectrum, String> {
    let tokens: Vec<&str> = text.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()).collect();
    if let [one] = tokens.as_slice() {
        if !one.contains(':') {
            return Ok(Spectrum::Uniform(number(one)?));
        }
    }
    let mut pairs = Vec::with_capacity(tokens.len());
    for token in tokens {
        match token.split(':').collect::<Vec<_>>().as_slice() {
            [w, v] => pairs.push((number(w)?, number(v)?)),
            _ => return Err(format!("{} is not a wavelength:value pair (or the spectrum's one value)", shown(token))),
        }
    }
    sampled(pairs)
}

/// A spectrum file: one `wavelength value` pair a line (white space between), `#` starts a comment, blank
/// lines are skipped (Mitsuba's `Properties::Spectrum(const fs::path &)`). Errors carry the line (from 1).
pub(crate) fn parse_file(text: &str) -> Result<Spectrum, (usize, String)> {
    let mut pairs = Vec::new();
    let mut last = 0;
    for (i, line) in text.lines().enumerate() {
        let fields: Vec<&str> = line.split('#').next().unwrap_or_default().split_whitespace().collect();
        if fields.is_empty() {
            continue;
        }
        last = i + 1;
        match fields.as_slice() {
            [w, v] => pairs.push((number(w).map_err(|m| (i + 1, m))?, number(v).map_err(|m| (i + 1, m))?)),
            _ => return Err((i + 1, format!("{} is not a line \"wavelength value\"", shown(line.trim())))),
        }
    }
    sampled(pairs).map_err(|m| (last.max(1), m))
}

/// Checks the pairs as Mitsuba does: at least two, wavelengths increasing.
fn sampled(pairs: Vec<(f64, f64)>) -> Result<Spectrum, String> {
    if pairs.len() < 2 {
        return Err(format!("a spectrum needs one value or at least two wavelength:value pairs, got {} pair", pairs.len()));
    }
    if let Some(w) = pairs.windows(2).find(|w| w[1].0 <= w[0].0) {
        return Err(format!("wavelengths must increase ({} nm follows {} nm)", w[1].0, w[0].0));
    }
    let (wavelengths, values) = pairs.into_iter().unzip();
    Ok(Spectrum::Sampled { wavelengths, values })
}

/// A colour of the scene description.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Colour {
    Grey(f64),
    Rgb([f64; 3]),
}

/// The linear-sRGB colour Mitsuba 3.9.1's RGB variants make of `spectrum` read as `colour_use`.
pub(crate) fn rgb(spectrum: &Spectrum, colour_use: ColourUse) -> Colour {
    match (spectrum, colour_use) {
        (Spectrum::Uniform(v), ColourUse::Emission) => Colour::Rgb(equal_energy_rgb().map(|c| v * c)),
        (Spectrum::Uniform(v), _) => Colour::Grey(*v),
        (Spectrum::Sampled { wavelengths, values }, _) => Colour::Rgb(sampled_to_srgb(
            wavelengths,
            values,
            colour_use == ColourUse::Reflectance,
            colour_use != ColourUse::Emission,
        )),
    }
}

/// `xyz_to_srgb(1, 1, 1)` in f32, as Mitsuba computes it for a uniform emitted spectrum: the sRGB colour of
/// the equal-energy spectrum, whose XYZ under its normalisation is (1, 1, 1).
fn equal_energy_rgb() -> [f64; 3] {
    XYZ_TO_SRGB.map(|row| f64::from(row[0] + row[1] + row[2]))
}

/// Linear interpolation in a table of the CIE wavelengths at `w` ∈ [360, 830] nm (Mitsuba's `cie1931_xyz`,
/// `cie_d65`: the table's f32 values, interpolated in the caller's precision).
fn cie_lookup(table: &[f32; CIE_SAMPLES], w: f64) -> f64 {
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let w1 = t - i0 as f64;
    (1.0 - w1) * f64::from(table[i0]) + w1 * f64::from(table[i0 + 1])
}

/// Mitsuba's `spectrum_list_to_srgb` (src/core/spectrum.cpp) in double precision, as
/// `Properties::get_texture_impl` calls it: Riemann sum of spectrum × CMFs (× D65 when `d65`) over 1000
/// evenly spaced wavelengths from 360 to 830 nm, skipping those outside the given wavelengths; XYZ →
/// linear sRGB; negatives → 0, and above 1 → 1 when `bounded`.
pub(crate) fn sampled_to_srgb(wavelengths: &[f64], values: &[f64], bounded: bool, d65: bool) -> [f64; 3] {
    const STEPS: usize = 1000;
    let (first, last) = (wavelengths[0], wavelengths[wavelengths.len() - 1]);
    let mut xyz = [0.0f64; 3];
    for i in 0..STEPS {
        let w = CIE_MIN + (i as f64 / (STEPS - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The last interval whose start is at most w (math::find_interval).
        let k = wavelengths[1..wavelengths.len() - 1].partition_point(|&x| x <= w);
        let (w0, w1, v0, v1) = (wavelengths[k], wavelengths[k + 1], values[k], values[k + 1]);
        let v = ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1);
        let weight = v * if d65 { cie_lookup(&D65, w) * CIE_D65_NORMALIZATION } else { 1.0 };
        for (acc, table) in xyz.iter_mut().zip([&CIE1931_X, &CIE1931_Y, &CIE1931_Z]) {
            *acc += cie_lookup(table, w) * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / STEPS as f64;
    let xyz = xyz.map(|c| c * scale);
    XYZ_TO_SRGB.map(|row| {
        let c = f64::from(row[0]) * xyz[0] + f64::from(row[1]) * xyz[1] + f64::from(row[2]) * xyz[2];
        if bounded {
            c.clamp(0.0, 1.0)
        } else {
            c.max(0.0)
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba 3.9.1's colours, read back with `mi.traverse` from scenes loaded by `mi.load_string` in the
    /// `scalar_rgb` variant: `<bsdf type="diffuse" id="b"><spectrum name="reflectance" value="…"/></bsdf>`
    /// (key `b.reflectance.value`), `<shape type="sphere"><emitter type="area"><spectrum name="radiance"
    /// …/></emitter></shape>` (`….emitter.radiance.value`), `<emitter type="point">` (`intensity.value`),
    /// `<emitter type="directional">` (`irradiance.value`), `<bsdf type="conductor" id="b">` (`b.eta.value`,
    /// `b.k.value`); Mitsuba stores them as f32.
    const LIST: &str = "400:0.1, 500:0.5, 600:0.8, 700:0.9";

    /// The spectrum file whose lines Mitsuba read (`<spectrum filename>` of a diffuse BSDF and of a `constant`
    /// emitter, key `radiance.value`) for the `.spd` numbers below.
    const SPD: &str = include_str!("../../../tests/data/xml/spectra-reflectance.spd");

    fn assert_rgb(name: &str, got: Colour, want: [f64; 3]) {
        let Colour::Rgb(got) = got else { panic!("{name}: {got:?} is not an RGB colour") };
        for c in 0..3 {
            assert!((got[c] - want[c]).abs() <= 1e-6 * want[c].abs().max(1e-3), "{name}: {got:?} vs Mitsuba's {want:?}");
        }
    }

    fn value(text: &str) -> Spectrum {
        parse_value(text).unwrap_or_else(|e| panic!("{text}: {e}"))
    }

    #[test]
    fn colours_match_mitsuba_rgb_variants() {
        use ColourUse::*;
        let r = |text: &str, u| rgb(&value(text), u);
        assert_rgb("reflectance list", r(LIST, Reflectance), [0.8780154585838318, 0.6357789039611816, 0.2703421413898468]);
        assert_eq!(r("0.5", Reflectance), Colour::Grey(0.5), "a reflectance keeps its one value");
        assert_eq!(r("1.5", Unbounded), Colour::Grey(1.5), "so does a conductor's eta");
        assert_rgb("area radiance 1", r("1", Emission), [1.204793930053711, 0.948291003704071, 0.9089160561561584]);
        assert_rgb("point intensity 2.5", r("2.5", Emission), [3.0119848251342773, 2.3707275390625, 2.2722902297973633]);
        assert_rgb("area radiance list", r("400:1, 500:2, 600:3, 700:4", Emission), [4.020614147186279, 2.3136820793151855, 1.2445323467254639]);
        assert_rgb("directional irradiance, flat list", r("360:0.5, 830:0.5", Emission), [0.6024418473243713, 0.4741140902042389, 0.4546334147453308]);
        assert_rgb("conductor eta", r("400:1.5, 550:0.9, 700:0.2", Unbounded), [0.4732967019081116, 0.9254528880119324, 1.33051598072052]);
        assert_rgb("conductor k", r("400:2, 700:4", Unbounded), [3.59898042678833, 2.9524238109588623, 2.261902332305908]);
        // Out of gamut: negatives clamped to 0 (a narrow green band), a reflectance above 1 clamped to 1.
        assert_rgb("narrow band", r("500:0, 520:1, 540:0", Reflectance), [0.0, 0.24629533290863037, 0.0]);
        assert_rgb("reflectance above 1", r("400:1.5, 700:1.5", Reflectance), [1.0, 1.0, 1.0]);
        let spd = parse_file(SPD).unwrap_or_else(|e| panic!("{e:?}"));
        assert_rgb("reflectance from .spd", rgb(&spd, Reflectance), [0.3271156847476959, 0.5519921779632568, 0.21447068452835083]);
        assert_rgb("constant radiance from .spd", rgb(&spd, Emission), [0.4101545214653015, 0.5250528454780579, 0.18747012317180634]);
    }

    #[test]
    fn tables_are_mitsubas() {
        // Mitsuba 3.9.1 (scalar_rgb, f32): mi.cie1931_xyz(555.0), mi.cie1931_xyz(402.5) (between two table
        // entries) and mi.cie_d65(560.0).
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * b.abs();
        for (w, want) in [(555.0, [0.5120500922203064, 1.0, 0.005749999079853296]), (402.5, [0.01875000074505806, 0.0005179999861866236, 0.08902500569820404])] {
            let got = [&CIE1931_X, &CIE1931_Y, &CIE1931_Z].map(|t| cie_lookup(t, w));
            assert!((0..3).all(|c| close(got[c], want[c])), "{w} nm: {got:?} vs Mitsuba's {want:?}");
        }
        assert!(close(cie_lookup(&D65, 560.0) * CIE_D65_NORMALIZATION, 1.010127305984497));
        // The normalisation: a unit spectrum over the whole range has luminance (Y) ≈ 1.
        let y: f64 = (0..1000).map(|i| cie_lookup(&CIE1931_Y, CIE_MIN + i as f64 * (CIE_MAX - CIE_MIN) / 999.0)).sum();
        assert!((y * (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / 1000.0 - 1.0).abs() < 2e-3);
    }

    #[test]
    fn values_and_files_parse_as_in_mitsuba() {
        assert_eq!(value(" 0.25 "), Spectrum::Uniform(0.25));
        assert_eq!(value("400:1 500:2,600:3"), Spectrum::Sampled { wavelengths: vec![400.0, 500.0, 600.0], values: vec![1.0, 2.0, 3.0] });
        for (bad, says) in [
            ("400:1", "at least two"),
            ("500:1, 400:2", "must increase"),
            ("400:1, 400:2", "must increase"),
            ("400:1, 500", "not a wavelength:value pair"),
            ("0.5 0.5", "not a wavelength:value pair"),
            ("400:1:2, 500:1", "not a wavelength:value pair"),
            ("400:x, 500:1", "not a finite number"),
            ("inf", "not a finite number"),
            ("", "at least two"),
        ] {
            let e = parse_value(bad).err().unwrap_or_else(|| panic!("{bad:?} accepted"));
            assert!(e.contains(says), "{bad:?}: {e}");
        }
        assert_eq!(parse_file("400 1\r\n# c\n   \n500 2 # c\n"), Ok(Spectrum::Sampled { wavelengths: vec![400.0, 500.0], values: vec![1.0, 2.0] }));
        assert_eq!(parse_file("400 1\n500\n").err().map(|e| e.0), Some(2));
        assert_eq!(parse_file("400 1\n500 2 3\n").err().map(|e| e.0), Some(2));
        assert_eq!(parse_file("# nothing\n").err().map(|e| e.0), Some(1));
    }
}
