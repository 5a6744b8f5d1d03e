//! Scene files of Mitsuba 0.4–0.6 (`<scene version="0.5.0">`) upgraded in memory to Mitsuba 3's format, one
//! file at a time by its own `version` (an included file carries its own), so the later stages read 3.x:
//!
//! ```xml
//! <scene version="0.5.0">                                 <!-- read as -->
//!     <integrator type="path">
//!         <integer name="maxDepth" value="8"/>            <!-- <integer name="max_depth" …/> -->
//!     </integrator>
//!     <sensor type="perspective">
//!         <string name="fovAxis" value="y"/>              <!-- fov_axis; `fov` is unchanged -->
//!         <transform name="toWorld">                      <!-- to_world -->
//!             <lookAt origin="0, 1, 5" target="0, 1, 0" up="0, 1, 0"/>   <!-- <lookat …/> -->
//!         </transform>
//!         <film type="hdrfilm"><boolean name="banner" value="false"/></film>   <!-- banner dropped -->
//!     </sensor>
//!     <bsdf type="diffuse" id="red">
//!         <srgb name="diffuseReflectance" value="#b02020"/>   <!-- <rgb name="reflectance" value="0.43…, 0.014…, 0.014…"/> -->
//!     </bsdf>
//!     <bsdf type="conductor" id="copper"/>                <!-- gets <string name="material" value="Cu"/> -->
//!     <bsdf type="dielectric" id="glass">
//!         <float name="intIOR" value="1.5"/>              <!-- int_ior (extIOR → ext_ior, …) -->
//!     </bsdf>
//! </scene>
//! ```
//!
//! **Versions.** As Mitsuba 3 reads the attribute (`util::Version` in `include/mitsuba/core/util.h`): three
//! numbers separated by periods or spaces (`"0.5.0"`, `"3 0 0"`); two or four numbers are an error, and no
//! version is refused for being too old or too new. Files older than 2.0.0 are upgraded (`transform_upgrade`
//! in Mitsuba 3's `src/core/parser.cpp`), the others are read as written. Mitsuba's `std::stoul` also takes
//! a sign or trailing letters in a number (`"3.0.0a"`); caustica requires digits.
//!
//! **Mitsuba 3's rules** (`upgrade_from_v1`, parser.cpp; `upgrade_tree` of the former `src/core/xml.cpp`
//! before 3.7):
//! - every `name` is converted from camelCase to snake_case: an upper-case letter after a lower-case one
//!   starts a new word, it and the upper-case letters right after it are lowered (`toWorld` → `to_world`,
//!   `intIOR` → `int_ior`, `cropOffsetX` → `crop_offset_x`, `alphaU` → `alpha_u`, `sampleCount`,
//!   `rrDepth`, `specularReflectance`, `fovAxis` …). Mitsuba 3 converts the names of properties, which are
//!   those of property elements, `<transform>`s, nested plugins and `<ref>`s; it exempts the parameters of
//!   `<default name>`, and the `type`, `id` and values are never touched (`fov`, `hdrfilm` stay);
//! - `diffuse_reflectance` of a `<bsdf type="diffuse">` becomes `reflectance` (other BSDFs keep it);
//! - `<float>` properties `uoffset`, `voffset`, `uscale`, `vscale` (of a texture) become a
//!   `<transform name="to_uv">`.
//!
//! Mitsuba 3 renames no plugin (`ldrfilm`, `ptracer`, `sky`, … of 0.6 stay and are refused later, as
//! Mitsuba 3 refuses them; 0.6's `sunsky` is read as Mitsuba 3's, as Mitsuba 3 reads it) and no other
//! property (0.6's `banner`, `strictNormals`, … stay too).
//!
//! **Beyond Mitsuba 3**, for what Mitsuba 0.6 rendered and Mitsuba 3.9 refuses or renders differently:
//! - `<lookAt>` → `<lookat>` (0.6 read both spellings; Mitsuba 3 renamed it until 3.6, then its new parser
//!   dropped the rule and 3.9 refuses `<lookAt>`);
//! - `<srgb value="…">` → `<rgb>` with the sRGB transfer curve removed (0.6's `Spectrum::fromSRGB`: v/12.92
//!   up to 0.04045, else ((v + 0.055)/1.055)^2.4), and an HTML colour `#rrggbb` in `<rgb>` (0.6 read it as
//!   linear, each byte / 255) or `<srgb>` as numbers; Mitsuba 3 has no `<srgb>` and no `#` colours;
//! - a `conductor` or `roughconductor` with none of `material`, `eta`, `k` gets `material` "Cu": 0.6's
//!   default metal was copper, Mitsuba 3's is "none", a perfect mirror. (One of `eta`, `k` alone took the
//!   other from copper in 0.6 and from a mirror in Mitsuba 3; that stays as Mitsuba 3 reads it.)
//! - a film's `<boolean name="banner" value="false"/>` is dropped: without the banner (0.6's default drew
//!   Mitsuba's logo into the image) 0.6 wrote what Mitsuba 3 writes. `value="true"` stays, and is refused;
//! - `to_uv` is `scale` then `translate`, as 0.6 mapped texture coordinates (`uv·scale + offset`,
//!   `Texture2D` in `src/librender/texture.cpp`); Mitsuba 3 composes the other way round and shifts by
//!   `scale·offset` when both are given.
//!
//! **Parameters** are substituted before the upgrade, as Mitsuba 3 does: the tree builder substitutes each
//! element as it reads it (`params`), so a `name` or colour written with a `$parameter` is upgraded by its
//! value. **Not upgraded:** 0.6's `intent` attribute of colours stays (Mitsuba 3 refuses it, and so does
//! caustica).
//!
//! Upgraded elements keep their file and line; an element the upgrade adds (`to_uv`, `material`) has the
//! place of the element(s) it stands for, so errors point into the original file (naming the 3.x names).

use super::super::error::{shown, SceneError};
use super::tree::Element;

/// Files of an older version are upgraded (Mitsuba 3: `version < util::Version(2, 0, 0)`).
const FIRST_CURRENT: Version = Version([2, 0, 0]);

/// The texture-coordinate properties of Mitsuba 0.x that become `to_uv`.
const UV: [&str; 4] = ["uoffset", "voffset", "uscale", "vscale"];

/// A scene file's version: major, minor, patch.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct Version([u64; 3]);

impl Version {
    /// Three numbers separated by periods and/or spaces (Mitsuba's `string::tokenize(value, " .")`, which
    /// skips empty pieces); `None` otherwise.
    fn parse(text: &str) -> Option<Self> {
        let parts: Vec<&str> = text.split(['.', ' ']).filter(|p| !p.is_empty()).collect();
        let number = |p: &str| if p.bytes().all(|b| b.is_ascii_digit()) { p.parse::<u64>().ok() } else { None };
        match parts.as_slice() {
            [a, b, c] => Some(Self([number(a)?, number(b)?, number(c)?])),
            _ => None,
        }
    }
}

/// Checks the `version` of a file's root element `root` and upgrades the file's elements if it is older
/// than 2.0.0.
pub(crate) fn upgrade_file(root: &mut Element) -> Result<(), SceneError> {
    let text = root.required("version")?;
    let version = Version::parse(text).ok_or_else(|| {
        root.error(format!(
            "scene version {} is not a version number (three numbers, e.g. \"3.0.0\"; files of Mitsuba 0.x, \"0.6.0\", are upgraded)",
            shown(text)
        ))
    })?;
    if version < FIRST_CURRENT {
        upgrade(root);
    }
    Ok(())
}

/// Upgrades `el` and its descendants: the element itself, then its children, then the rules that look at
/// the (upgraded) children.
fn upgrade(el: &mut Element) {
    if el.tag == "lookAt" {
        el.tag = "lookat".to_string();
    }
    if el.tag != "default" {
        if let Some((_, name)) = el.attrs.iter_mut().find(|(n, _)| n == "name") {
            *name = snake_case(name);
        }
    }
    colour(el);
    for child in &mut el.children {
        upgrade(child);
    }
    let kind = el.attr("type").unwrap_or_default().to_string();
    match (el.tag.as_str(), kind.as_str()) {
        ("bsdf", "diffuse") => {
            for child in &mut el.children {
                if let Some((_, name)) = child.attrs.iter_mut().find(|(n, v)| n == "name" && v == "diffuse_reflectance") {
                    *name = "reflectance".to_string();
                }
            }
        }
        ("bsdf", "conductor" | "roughconductor") => {
            if !el.children.iter().any(|c| matches!(c.attr("name"), Some("material" | "eta" | "k"))) {
                let material = new_element("string", &[("name", "material"), ("value", "Cu")], el);
                el.children.push(material);
            }
        }
        ("film", _) => {
            el.children.retain(|c| !(c.tag == "boolean" && c.attr("name") == Some("banner") && c.attr("value") == Some("false")));
        }
        _ => {}
    }
    uv_transform(el);
}

/// `name` in snake_case, as Mitsuba 3's `camel_to_underscore_case` (parser.cpp) converts it.
fn snake_case(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        if i > 0 && chars[i - 1].is_ascii_lowercase() && chars[i].is_ascii_uppercase() {
            out.push('_');
            out.push(chars[i].to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(chars[i]);
        }
        i += 1;
    }
    out
}

/// A new element with `attrs`, placed where `at` is.
fn new_element(tag: &str, attrs: &[(&str, &str)], at: &Element) -> Element {
    Element {
        tag: tag.to_string(),
        attrs: attrs.iter().map(|(n, v)| ((*n).to_string(), (*v).to_string())).collect(),
        children: Vec::new(),
        file: at.file.clone(),
        line: at.line,
    }
}

/// `<srgb>` → `<rgb>` with linear values, `#rrggbb` → numbers (Mitsuba 0.6's `ERGB` / `ESRGB` cases of
/// `SceneHandler::endElement`, src/librender/scenehandler.cpp). A value this cannot read stays as written.
fn colour(el: &mut Element) {
    let srgb = el.tag == "srgb";
    if !srgb && el.tag != "rgb" {
        return;
    }
    let Some(value) = el.attr("value") else { return };
    let hex = value.trim().starts_with('#');
    if !(srgb || hex) {
        return;
    }
    let Some(mut rgb) = colour_numbers(value) else { return };
    if srgb {
        for v in &mut rgb {
            *v = srgb_to_linear(*v);
        }
    }
    let text = rgb.iter().map(f64::to_string).collect::<Vec<_>>().join(", ");
    el.tag = "rgb".to_string();
    if let Some((_, v)) = el.attrs.iter_mut().find(|(n, _)| n == "value") {
        *v = text;
    }
}

/// The numbers of a 0.6 colour value: `#rrggbb` (each byte / 255), one number (gray) or three, separated
/// by commas and/or spaces.
fn colour_numbers(value: &str) -> Option<Vec<f64>> {
    let tokens: Vec<&str> = value.split([',', ' ']).filter(|t| !t.is_empty()).collect();
    match tokens.as_slice() {
        [t] if t.len() == 7 && t.starts_with('#') => {
            let hex = &t[1..];
            if !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
                return None;
            }
            let encoded = u32::from_str_radix(hex, 16).ok()?;
            Some([16, 8, 0].iter().map(|s| f64::from((encoded >> s) & 0xff) / 255.0).collect())
        }
        [_] | [_, _, _] => tokens.iter().map(|t| t.parse::<f64>().ok()).collect(),
        _ => None,
    }
}

/// The linear value of an sRGB-encoded one (Mitsuba 0.6's `fromSRGBComponent`, src/libcore/spectrum.cpp).
fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The `<float>` children `uoffset`, `voffset`, `uscale`, `vscale` of `el` → `<transform name="to_uv">`
/// with `<scale x="uscale" y="vscale"/>` (if a scale is given) then `<translate x="uoffset"
/// y="voffset"/>` (if an offset is given); absent ones are 1 and 0. The values are copied as written. A
/// second element of the same name stays, to be refused.
fn uv_transform(el: &mut Element) {
    let mut found: [Option<Element>; 4] = Default::default();
    let mut kept = Vec::with_capacity(el.children.len());
    for child in std::mem::take(&mut el.children) {
        let slot = UV.iter().position(|n| child.attr("name") == Some(n));
        match slot {
            Some(i) if child.tag == "float" && child.attr("value").is_some() && found[i].is_none() => found[i] = Some(child),
            _ => kept.push(child),
        }
    }
    el.children = kept;
    let Some(first) = found.iter().flatten().min_by_key(|c| c.line).cloned() else { return };
    let value = |i: usize, default: &str| found[i].as_ref().and_then(|c| c.attr("value")).unwrap_or(default).to_string();
    let mut transform = new_element("transform", &[("name", "to_uv")], &first);
    if found[2].is_some() || found[3].is_some() {
        let scale = new_element("scale", &[("x", &value(2, "1")), ("y", &value(3, "1"))], &first);
        transform.children.push(scale);
    }
    if found[0].is_some() || found[1].is_some() {
        let translate = new_element("translate", &[("x", &value(0, "0")), ("y", &value(1, "0"))], &first);
        transform.children.push(translate);
    }
    el.children.push(transform);
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::path::Path;

    use super::super::tree::{read_tree, Element};
    use super::*;

    fn params() -> BTreeMap<String, String> {
        BTreeMap::new()
    }

    /// The scene `xml` (read by the parser, upgraded) written back compactly, without the root's version.
    fn read(xml: &str) -> String {
        let root = read_tree(xml, Path::new("t.xml"), &mut super::super::tree::SearchPath::new(Path::new(".")), &params()).unwrap_or_else(|e| panic!("{e}"));
        root.children.iter().map(show).collect()
    }

    fn show(el: &Element) -> String {
        let attrs: String = el.attrs.iter().map(|(n, v)| format!(" {n}=\"{v}\"")).collect();
        if el.children.is_empty() {
            format!("<{}{attrs}/>", el.tag)
        } else {
            format!("<{}{attrs}>{}</{}>", el.tag, el.children.iter().map(show).collect::<String>(), el.tag)
        }
    }

    fn v05(body: &str) -> String {
        read(&format!("<scene version=\"0.5.0\">{body}</scene>"))
    }

    #[test]
    fn versions_are_three_numbers_and_only_those_before_2_are_upgraded() {
        assert_eq!(Version::parse("0.5.0"), Some(Version([0, 5, 0])));
        assert_eq!(Version::parse("3 0 0"), Some(Version([3, 0, 0])));
        assert_eq!(Version::parse("3..0.0"), Some(Version([3, 0, 0])));
        for bad in ["3.0", "3", "3.0.0.1", "a.0.0", "3.0.0a", "-1.0.0", ""] {
            assert_eq!(Version::parse(bad), None, "{bad:?}");
        }
        let body = "<integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator>";
        for (version, name) in [("0.6.0", "max_depth"), ("1.9.9", "max_depth"), ("2.0.0", "maxDepth"), ("3.0.0", "maxDepth"), ("9.1.0", "maxDepth")] {
            let out = read(&format!("<scene version=\"{version}\">{body}</scene>"));
            assert!(out.contains(&format!("name=\"{name}\"")), "{version}: {out}");
        }
        let e = read_tree("<scene version=\"3.0\"/>", Path::new("t.xml"), &mut super::super::tree::SearchPath::new(Path::new(".")), &params()).err().expect("refused");
        assert!(e.to_string().contains("\"3.0\" is not a version number"), "{e}");
    }

    #[test]
    fn names_become_snake_case_except_defaults() {
        assert_eq!(snake_case("toWorld"), "to_world");
        assert_eq!(snake_case("intIOR"), "int_ior");
        assert_eq!(snake_case("cropOffsetX"), "crop_offset_x");
        assert_eq!(snake_case("alphaU"), "alpha_u");
        assert_eq!(snake_case("rrDepth"), "rr_depth");
        // Mitsuba 3.9.1 loads `aBcD` as `a_bc_d` (its former xml.cpp skipped a letter: `a_bcD`).
        assert_eq!(snake_case("aBcD"), "a_bc_d");
        assert_eq!(snake_case("aBCd"), "a_bcd");
        assert_eq!(snake_case("Radius"), "Radius");
        assert_eq!(snake_case("max_depth"), "max_depth");
        let out = v05(
            "<default name=\"myCount\" value=\"4\"/><default name=\"someName\" value=\"innerRadius\"/>\
             <sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/><string name=\"fovAxis\" value=\"smallerOne\"/>\
             <transform name=\"toWorld\"><translate x=\"1\"/></transform>\
             <sampler type=\"ldsampler\"><integer name=\"sampleCount\" value=\"$myCount\"/></sampler></sensor>\
             <shape type=\"sphere\"><ref name=\"interiorMedium\" id=\"fogMedium\"/><float name=\"$someName\" value=\"1\"/></shape>",
        );
        // The parameters' names keep their case; they are substituted before the upgrade, as Mitsuba 3 does.
        assert_eq!(
            out,
            "<sensor type=\"perspective\"><float name=\"fov\" value=\"30\"/><string name=\"fov_axis\" value=\"smallerOne\"/>\
             <transform name=\"to_world\"><translate x=\"1\"/></transform>\
             <sampler type=\"ldsampler\"><integer name=\"sample_count\" value=\"4\"/></sampler></sensor>\
             <shape type=\"sphere\"><ref name=\"interior_medium\" id=\"fogMedium\"/><float name=\"inner_radius\" value=\"1\"/></shape>"
        );
    }

    #[test]
    fn diffuse_reflectance_is_the_reflectance_of_diffuse_only() {
        let out = v05(
            "<bsdf type=\"diffuse\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf>\
             <bsdf type=\"plastic\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf>\
             <bsdf type=\"twosided\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"diffuseReflectance\"/></bsdf></bsdf>",
        );
        assert_eq!(
            out,
            "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf>\
             <bsdf type=\"plastic\"><rgb name=\"diffuse_reflectance\" value=\"0.5\"/></bsdf>\
             <bsdf type=\"twosided\"><bsdf type=\"diffuse\"><texture type=\"bitmap\" name=\"reflectance\"/></bsdf></bsdf>"
        );
    }

    #[test]
    fn uv_offsets_and_scales_become_to_uv_scale_then_translate() {
        let out = v05(
            "<default name=\"v\" value=\"0.25\"/><texture type=\"bitmap\"><float name=\"uscale\" value=\"2\"/>\
             <string name=\"filename\" value=\"a.png\"/><float name=\"voffset\" value=\"$v\"/></texture>\
             <texture type=\"bitmap\"><float name=\"uoffset\" value=\"0.5\"/></texture>",
        );
        assert_eq!(
            out,
            "<texture type=\"bitmap\"><string name=\"filename\" value=\"a.png\"/>\
             <transform name=\"to_uv\"><scale x=\"2\" y=\"1\"/><translate x=\"0\" y=\"0.25\"/></transform></texture>\
             <texture type=\"bitmap\"><transform name=\"to_uv\"><translate x=\"0.5\" y=\"0\"/></transform></texture>"
        );
        // Mitsuba 3 files keep them (and the later stages refuse them).
        let out = read("<scene version=\"3.0.0\"><texture type=\"bitmap\"><float name=\"uscale\" value=\"2\"/></texture></scene>");
        assert!(out.contains("uscale"), "{out}");
    }

    #[test]
    fn lookat_is_spelt_in_lower_case() {
        let out = v05("<sensor type=\"perspective\"><transform name=\"toWorld\"><lookAt origin=\"0,0,1\" target=\"0,0,0\"/></transform></sensor>");
        assert_eq!(out, "<sensor type=\"perspective\"><transform name=\"to_world\"><lookat origin=\"0,0,1\" target=\"0,0,0\"/></transform></sensor>");
    }

    #[test]
    fn srgb_and_hex_colours_become_linear_rgb_numbers() {
        let out = v05(
            "<bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"#ff8000\"/></bsdf>\
             <bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"0.5, 0.02 1\"/></bsdf>\
             <bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"0.5\"/></bsdf>\
             <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"#ff8000\"/></bsdf>\
             <bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.25 0.5 1\"/></bsdf>\
             <default name=\"c\" value=\"#ff8000\"/><bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"$c\"/></bsdf>\
             <bsdf type=\"diffuse\"><srgb name=\"reflectance\" value=\"#ff80\"/></bsdf>",
        );
        let lin = |v: f64| ((v + 0.055) / 1.055).powf(2.4);
        let expected = [
            format!("<rgb name=\"reflectance\" value=\"1, {}, 0\"/>", lin(128.0 / 255.0)),
            format!("<rgb name=\"reflectance\" value=\"{}, {}, 1\"/>", lin(0.5), 0.02 / 12.92),
            format!("<rgb name=\"reflectance\" value=\"{}\"/>", lin(0.5)),
            format!("<rgb name=\"reflectance\" value=\"1, {}, 0\"/>", 128.0 / 255.0),
            "<rgb name=\"reflectance\" value=\"0.25 0.5 1\"/>".to_string(),
            format!("<rgb name=\"reflectance\" value=\"1, {}, 0\"/>", lin(128.0 / 255.0)),
            "<srgb name=\"reflectance\" value=\"#ff80\"/>".to_string(),
        ];
        let expected: String = expected.iter().map(|c| format!("<bsdf type=\"diffuse\">{c}</bsdf>")).collect();
        assert_eq!(out, expected);
        assert!((lin(0.5) - 0.214_041_140_482_232_5).abs() < 1e-12);
    }

    #[test]
    fn conductors_without_a_metal_are_copper() {
        let out = v05(
            "<bsdf type=\"conductor\"/>\
             <bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/></bsdf>\
             <bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>\
             <bsdf type=\"conductor\"><rgb name=\"eta\" value=\"0.2\"/><rgb name=\"k\" value=\"3\"/></bsdf>",
        );
        assert_eq!(
            out,
            "<bsdf type=\"conductor\"><string name=\"material\" value=\"Cu\"/></bsdf>\
             <bsdf type=\"roughconductor\"><float name=\"alpha\" value=\"0.2\"/><string name=\"material\" value=\"Cu\"/></bsdf>\
             <bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/></bsdf>\
             <bsdf type=\"conductor\"><rgb name=\"eta\" value=\"0.2\"/><rgb name=\"k\" value=\"3\"/></bsdf>"
        );
        assert_eq!(read("<scene version=\"3.0.0\"><bsdf type=\"conductor\"/></scene>"), "<bsdf type=\"conductor\"/>");
    }

    #[test]
    fn a_banner_turned_off_is_dropped() {
        let out = v05(
            "<sensor type=\"perspective\"><film type=\"hdrfilm\"><boolean name=\"banner\" value=\"false\"/>\
             <integer name=\"width\" value=\"8\"/></film></sensor>\
             <sensor type=\"perspective\"><film type=\"hdrfilm\"><boolean name=\"banner\" value=\"true\"/></film></sensor>",
        );
        assert_eq!(
            out,
            "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/></film></sensor>\
             <sensor type=\"perspective\"><film type=\"hdrfilm\"><boolean name=\"banner\" value=\"true\"/></film></sensor>"
        );
    }

    /// Each file is upgraded by its own version: a 3.x file including a 0.5 file, and the other way round.
    #[test]
    fn included_files_are_upgraded_by_their_own_version() {
        let dir = std::env::temp_dir().join(format!("caustica-upgrade-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp dir");
        let old = "<scene version=\"0.6.0\"><bsdf type=\"diffuse\" id=\"a\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf></scene>";
        let new = "<scene version=\"3.0.0\"><bsdf type=\"plastic\" id=\"b\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf></scene>";
        std::fs::write(dir.join("old.xml"), old).expect("write");
        std::fs::write(dir.join("new.xml"), new).expect("write");
        let main = |version: &str, include: &str| {
            let text = format!("<scene version=\"{version}\"><include filename=\"{include}\"/><float name=\"someValue\" value=\"1\"/></scene>");
            let root = read_tree(&text, &dir.join("main.xml"), &mut super::super::tree::SearchPath::new(&dir), &params()).unwrap_or_else(|e| panic!("{e}"));
            root.children.iter().map(show).collect::<String>()
        };
        assert_eq!(
            main("3.0.0", "old.xml"),
            "<bsdf type=\"diffuse\" id=\"a\"><rgb name=\"reflectance\" value=\"0.5\"/></bsdf><float name=\"someValue\" value=\"1\"/>"
        );
        assert_eq!(
            main("0.5.0", "new.xml"),
            "<bsdf type=\"plastic\" id=\"b\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf><float name=\"some_value\" value=\"1\"/>"
        );
        // The included file's elements keep their file and line.
        let text = "<scene version=\"3.0.0\">\n<include filename=\"old.xml\"/>\n</scene>";
        let root = read_tree(text, &dir.join("main.xml"), &mut super::super::tree::SearchPath::new(&dir), &params()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((root.children[0].file.as_path(), root.children[0].line), (dir.join("old.xml").as_path(), 1));
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Errors found after the upgrade point at the element in the original file, by its 3.x name.
    #[test]
    fn errors_after_the_upgrade_name_the_original_line() {
        let text = |film: &str| {
            format!(
                "<scene version=\"0.5.0\">\n<sensor type=\"perspective\">\n<float name=\"fov\" value=\"40\"/>\n\
                 <film type=\"{film}\"/>\n</sensor>\n<shape type=\"sphere\">\n<float name=\"maxRadius\" value=\"1\"/>\n</shape>\n</scene>"
            )
        };
        let load = |film: &str| crate::scene::Scene::from_xml_str(&text(film), Path::new("."), Path::new("old.xml"), &BTreeMap::new());
        let e = load("ldrfilm").err().expect("ldrfilm refused").to_string();
        assert!(e.contains("old.xml:4") && e.contains("ldrfilm"), "{e}");
        let e = load("hdrfilm").err().expect("an unknown property refused").to_string();
        assert!(e.contains("old.xml:7") && e.contains("\"max_radius\""), "{e}");
    }
}
