//! A mesh file's attributes beside positions, normals and uvs (per-vertex colours, per-face weights), named
//! and converted as Mitsuba 3.9.1's PLY reader does (src/shapes/ply.h `find_other_fields`, ply.cpp), for
//! the `mesh_attribute` texture.
//!
//! Naming, per element (`vertex` → `vertex_…`, `face` → `face_…`):
//! - `r`, `g`, `b` (or `red`, `green`, `blue`), with `a` (`alpha`) if present, make `…color` (3 or 4 values,
//!   in that order wherever the file declares them);
//! - other consecutive properties `{prefix}_{postfix}` with one prefix and one-letter postfixes in one of
//!   the sequences `x y z w`, `r g b a`, `0 1 2 3`, `1 2 3 4` make `…{prefix}` (`…{prefix}_color` for `r g b a`),
//!   kept when they are 1 or 3 properties; a prefix seen before, a sequence out of order, 2 or 4 properties, a
//!   name without `_` or with a longer postfix are ignored (Mitsuba warns). Positions, normals, uvs and
//!   the face's index list are not attributes.
//!
//! ```text
//! property float color_0, color_1, color_2   →  vertex_color (3 values)
//! property uchar red, green, blue             →  vertex_color (3 values)
//! property float weight_0    (in `face`)      →  face_weight (1 value)
//! property float albedo_r, albedo_g, albedo_b →  vertex_albedo_color
//! ```
//!
//! Values (Mitsuba's `Struct` conversion with the flags its PLY header reader gives integer properties,
//! measured on Mitsuba 3.9.1): floating-point values as they are; `uchar` values as the integer
//! (255 stays 255: Mitsuba 3.9.1 neither scales 8-bit colours to [0, 1] nor decodes them from sRGB, and
//! warns that colours should be in [0, 1]); every other integer type divided by its largest value
//! (`char` 127, `short` 32767, `ushort` 65535, `int` 2³¹ − 1, `uint` 2³² − 1) and then decoded from sRGB
//! to linear (`srgb_to_linear`, negative values on its linear segment).

use ply_rs_bw::ply::ScalarType;

/// One attribute of a mesh: `dim` values per vertex (`vertex_…`) or per triangle (`face_…`; a polygon's
/// triangles repeat its value).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    pub name: String,
    pub dim: u8,
    pub values: Vec<f32>,
}

/// The attributes of a mesh file: the names of all it has, and the values of those asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attributes {
    pub names: Vec<String>,
    pub kept: Vec<MeshAttribute>,
}

impl Attributes {
    /// The attribute `name`, if kept.
    #[must_use]
    pub fn get(&self, name: &str) -> Option<&MeshAttribute> {
        self.kept.iter().find(|a| a.name == name)
    }
}

/// An attribute's name and the element's properties it reads (their positions in the element), in order.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AttributeFields {
    pub name: String,
    pub fields: Vec<usize>,
}

/// The postfix sequences, by position: `POSTFIXES[level]` holds the `level`-th letter of each sequence.
const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];

/// The attributes an element's properties `names` make (module documentation); `kind` is `"vertex_"` or
/// `"face_"`, `reserved` the properties that are not attributes (positions, normals, uvs, index lists).
#[must_use]
pub fn group_fields(kind: &str, names: &[&str], reserved: &[&str]) -> Vec<AttributeFields> {
    let mut out = Vec::new();
    let find = |n: &str| names.iter().position(|m| *m == n);
    let colour = match (find("r"), find("g"), find("b")) {
        (Some(r), Some(g), Some(b)) => Some(([r, g, b], find("a"))),
        _ => match (find("red"), find("green"), find("blue")) {
            (Some(r), Some(g), Some(b)) => Some(([r, g, b], find("alpha"))),
            _ => None,
        },
    };
    if let Some((rgb, alpha)) = colour {
        out.push(AttributeFields { name: format!("{kind}color"), fields: rgb.into_iter().chain(alpha).collect() });
    }

    // The other properties, in order: runs of one prefix and a postfix sequence.
    struct Run<'n> {
        prefix: &'n str,
        sequence: usize,
        fields: Vec<usize>,
    }
    let mut seen: Vec<&str> = Vec::new();
    let mut run: Option<Run<'_>> = None;
    fn flush<'n>(kind: &str, run: &mut Option<Run<'n>>, seen: &mut Vec<&'n str>, out: &mut Vec<AttributeFields>) {
        let Some(r) = run.take() else { return };
        if r.fields.len() == 1 || r.fields.len() == 3 {
            let colour = if r.sequence == 1 { "_color" } else { "" };
            out.push(AttributeFields { name: format!("{kind}{}{colour}", r.prefix), fields: r.fields });
            seen.push(r.prefix);
        }
    }
    let mut skipping: Option<&str> = None;
    for (i, name) in names.iter().enumerate() {
        if reserved.contains(name) || ["r", "g", "b", "a"].contains(name) {
            continue;
        }
        let Some((prefix, postfix)) = name.rsplit_once('_') else {
            flush(kind, &mut run, &mut seen, &mut out);
            continue;
        };
        let &[letter] = postfix.as_bytes() else {
            flush(kind, &mut run, &mut seen, &mut out);
            continue;
        };
        if skipping.is_some_and(|p| name.starts_with(p)) {
            continue;
        }
        skipping = None;
        if run.as_ref().is_some_and(|r| r.prefix != prefix) {
            flush(kind, &mut run, &mut seen, &mut out);
        }
        match &mut run {
            None => {
                if seen.contains(&prefix) {
                    skipping = Some(prefix);
                    continue;
                }
                let Some(sequence) = POSTFIXES[0].iter().position(|&c| c == letter) else { continue };
                run = Some(Run { prefix, sequence, fields: vec![i] });
            }
            Some(r) => {
                if POSTFIXES.get(r.fields.len()).is_some_and(|p| p[r.sequence] == letter) {
                    r.fields.push(i);
                } else {
                    // A sequence out of order: the attribute is dropped, with the rest of its prefix.
                    skipping = Some(r.prefix);
                    run = None;
                }
            }
        }
    }
    flush(kind, &mut run, &mut seen, &mut out);
    // (Mitsuba refuses a second attribute of one name; the first is kept here.)
    let mut kept = std::collections::HashSet::new();
    out.retain(|a| kept.insert(a.name.clone()));
    out
}

/// A property's value as an attribute value (module documentation): `value` as read (an integer exactly,
/// a double rounded), `t` the property's type.
#[must_use]
pub fn attribute_value(value: f64, t: &ScalarType) -> f32 {
    let largest = match t {
        ScalarType::Float | ScalarType::Double | ScalarType::UChar => return value as f32,
        ScalarType::Char => f64::from(i8::MAX),
        ScalarType::Short => f64::from(i16::MAX),
        ScalarType::UShort => f64::from(u16::MAX),
        ScalarType::Int => f64::from(i32::MAX),
        ScalarType::UInt => f64::from(u32::MAX),
    };
    crate::texture::srgb_to_linear(value / largest) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(kind: &str, props: &[&str]) -> Vec<(String, Vec<usize>)> {
        group_fields(kind, props, &["x", "y", "z", "nx", "ny", "nz", "u", "v"]).into_iter().map(|a| (a.name, a.fields)).collect()
    }

    #[test]
    fn attributes_are_named_as_mitsubas_ply_reader_names_them() {
        let v = |s: &str| s.to_string();
        assert_eq!(names("vertex_", &["x", "y", "z", "red", "green", "blue"]), [(v("vertex_color"), vec![3, 4, 5])]);
        assert_eq!(names("vertex_", &["x", "b", "g", "r", "a", "y"]), [(v("vertex_color"), vec![3, 2, 1, 4])]);
        assert_eq!(names("face_", &["color_0", "color_1", "color_2", "weight_0"]), [(v("face_color"), vec![0, 1, 2]), (v("face_weight"), vec![3])]);
        assert_eq!(names("vertex_", &["x", "albedo_r", "albedo_g", "albedo_b", "q_1"]), [(v("vertex_albedo_color"), vec![1, 2, 3]), (v("vertex_q"), vec![4])]);
        // Positions between fields do not end an attribute (they are skipped, as Mitsuba skips them).
        assert_eq!(names("vertex_", &["n_x", "y", "n_y", "n_z"]), [(v("vertex_n"), vec![0, 2, 3])]);
        // Two or four fields, a name without `_`, a long postfix, a bad start and a repeated prefix are ignored.
        assert!(names("vertex_", &["t_x", "t_y", "quality", "k_ab", "k_q", "w_0", "w_1", "w_2", "w_3"]).is_empty());
        assert_eq!(names("vertex_", &["s_0", "other", "s_0", "s_1", "s_2"]), [(v("vertex_s"), vec![0])]);
        // A sequence out of order drops its attribute.
        assert_eq!(names("vertex_", &["c_x", "c_z", "c_y", "d_0"]), [(v("vertex_d"), vec![3])]);
    }

    #[test]
    fn values_convert_as_mitsuba_3_9_1_reads_them() {
        // Measured with Mitsuba 3.9.1 (scalar_rgb, `mi.traverse(mesh)["vertex_color"]`); its sRGB curve is an
        // approximation within a few parts per million of the exact one used here.
        let close = |a: f32, b: f32| (a - b).abs() <= 5e-6 * b.abs();
        assert_eq!(attribute_value(128.0, &ScalarType::UChar), 128.0);
        assert_eq!(attribute_value(0.25, &ScalarType::Float), 0.25);
        assert!(close(attribute_value(32768.0, &ScalarType::UShort), 0.214_048_09));
        assert!(close(attribute_value(5000.0, &ScalarType::UShort), 0.006_729_608));
        assert_eq!(attribute_value(127.0, &ScalarType::Char), 1.0);
        assert!(close(attribute_value(-128.0, &ScalarType::Char), -0.078_008_82));
        assert!(close(attribute_value(1.0, &ScalarType::Int), 3.604_189_5e-11));
    }
}
