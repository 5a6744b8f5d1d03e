//! AOVs (arbitrary output variables): what the camera ray's first hit is, written as extra channels of the
//! image, named as Mitsuba 3's `aov` integrator names them (src/integrators/aov.cpp, 3.9.1): a list of
//! `<name>:<type>` pairs, each type giving its channels a suffix.
//!
//! ```toml
//! [integrator]
//! aovs = "albedo:albedo,nn:sh_normal,dd.y:depth"   # channels albedo.R/G/B, nn.X/Y/Z, dd.y.T
//! ```
//! ```xml
//! <integrator type="aov">
//!     <string name="aovs" value="albedo:albedo,nn:sh_normal,dd.y:depth"/>
//!     <integrator type="path"/>
//! </integrator>
//! ```
//! `caustica render --aov albedo,normal,depth` takes the same list, where a type alone names its own
//! channels (`normal` is `sh_normal`: `normal.X`, `normal.Y`, `normal.Z`).
//!
//! | type | channels | value at the first hit (0 where the ray escapes) |
//! |---|---|---|
//! | `albedo` | `.R .G .B` | the BSDF's diffuse reflectance (`Bsdf::diffuse_reflectance`, Mitsuba's `eval_diffuse_reflectance`) |
//! | `depth` | `.T` | the distance from the camera along the ray (Mitsuba's `si.t`; camera rays are unit) |
//! | `position` | `.X .Y .Z` | the world-space hit point |
//! | `uv` | `.U .V` | the texture coordinates at the hit (`Scene::tex_uv`: the mesh's, or the barycentrics where the shape has none, as Mitsuba) |
//! | `geo_normal` | `.X .Y .Z` | the world-space geometric normal `(p1−p0)×(p2−p0)`, normalised |
//! | `sh_normal` | `.X .Y .Z` | the world-space shading normal (interpolated, in the geometric normal's hemisphere) |
//! | `prim_index` | `.I` | the triangle's index within its shape |
//! | `shape_index` | `.I` | the shape's index from 1 in the scene's order (Mitsuba's scalar variants) |
//! | `material_index` | `.I` | caustica's own: the material's index from 1 (`Scene::bsdfs`) |
//!
//! Like the image, every AOV is the filter-weighted mean of its samples in the pixel (Mitsuba's film
//! splats them with the same weights), so the index AOVs are fractional where a pixel sees several
//! surfaces, as Mitsuba warns. Mitsuba's `dp_du`, `dp_dv`, `duv_dx`, `duv_dy` are refused: they need
//! texture coordinates caustica does not have.

use super::settings::check::Invalid;

/// What an AOV records (module table).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AovKind {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    PrimIndex,
    ShapeIndex,
    MaterialIndex,
}

/// (Mitsuba's type name, kind, channel suffixes).
const KINDS: &[(&str, AovKind, &[&str])] = &[
    ("albedo", AovKind::Albedo, &["R", "G", "B"]),
    ("depth", AovKind::Depth, &["T"]),
    ("position", AovKind::Position, &["X", "Y", "Z"]),
    ("uv", AovKind::Uv, &["U", "V"]),
    ("geo_normal", AovKind::GeoNormal, &["X", "Y", "Z"]),
    ("sh_normal", AovKind::ShNormal, &["X", "Y", "Z"]),
    ("prim_index", AovKind::PrimIndex, &["I"]),
    ("shape_index", AovKind::ShapeIndex, &["I"]),
    ("material_index", AovKind::MaterialIndex, &["I"]),
];

/// Mitsuba's types caustica does not produce, with why.
const REFUSED: &[&str] = &["dp_du", "dp_dv", "duv_dx", "duv_dy"];

impl AovKind {
    fn row(self) -> &'static (&'static str, AovKind, &'static [&'static str]) {
        KINDS.iter().find(|(_, k, _)| *k == self).expect("every kind has its row")
    }

    /// Mitsuba's name of the type.
    #[must_use]
    pub fn name(self) -> &'static str {
        self.row().0
    }

    /// The suffixes of its channels (`R`, `X`, `T`…), one per value.
    #[must_use]
    pub fn suffixes(self) -> &'static [&'static str] {
        self.row().2
    }

    /// The type named `name`; `normal` is `sh_normal` (the command line's short name).
    fn parse(name: &str) -> Result<Self, Invalid> {
        let name = if name == "normal" { "sh_normal" } else { name };
        if let Some((_, kind, _)) = KINDS.iter().find(|(n, ..)| *n == name) {
            return Ok(*kind);
        }
        let known = KINDS.iter().map(|(n, ..)| *n).collect::<Vec<_>>().join(", ");
        if REFUSED.contains(&name) {
            return Err(Invalid(format!("AOV type {name:?} is not supported: it needs texture coordinates, which caustica does not have (supported: {known}, normal)")));
        }
        Err(Invalid(format!("unknown AOV type {name:?} (supported: {known}, normal)")))
    }
}

/// One AOV: the prefix of its channels and what it records.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Aov {
    pub name: String,
    pub kind: AovKind,
}

impl Aov {
    /// Its channel names, `<name>.<suffix>`.
    pub fn channels(&self) -> impl Iterator<Item = String> + '_ {
        self.kind.suffixes().iter().map(move |s| format!("{}.{s}", self.name))
    }
}

/// The AOVs of a render, in the order of their channels. Empty: none (the default).
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash)]
pub struct Aovs(Vec<Aov>);

impl Aovs {
    /// Reads a list of `<name>:<type>` pairs or bare types, separated by commas or spaces (Mitsuba's
    /// `string::tokenize`): Mitsuba's `aovs` property, `integrator.aovs` and `--aov`. Refuses an unknown
    /// type, an empty name and two channels of one name (Mitsuba's `Film::prepare` refuses those too).
    pub fn parse(spec: &str) -> Result<Self, Invalid> {
        let mut list = Aovs::default();
        for item in spec.split([',', ' ']).filter(|s| !s.is_empty()) {
            let (name, kind) = match item.split_once(':') {
                Some((name, kind)) => (name, kind),
                None => (item, item),
            };
            if name.is_empty() || kind.is_empty() || kind.contains(':') {
                return Err(Invalid(format!("{item:?}: expected <name>:<type> or a type")));
            }
            list.push(Aov { name: name.to_string(), kind: AovKind::parse(kind)? })?;
        }
        Ok(list)
    }

    /// Adds `aov` after the others; refuses a channel name already taken.
    pub fn push(&mut self, aov: Aov) -> Result<(), Invalid> {
        let taken: Vec<String> = self.channel_names().collect();
        if let Some(c) = aov.channels().find(|c| taken.contains(c)) {
            return Err(Invalid(format!("two channels named {c:?}")));
        }
        self.0.push(aov);
        Ok(())
    }

    /// The list with an AOV of each of `kinds` that it lacks, named by its type (for the denoiser, which
    /// reads `albedo` and `sh_normal`).
    pub fn with_kinds(mut self, kinds: &[AovKind]) -> Result<Self, Invalid> {
        for &kind in kinds {
            if self.find(kind).is_none() {
                self.push(Aov { name: kind.name().to_string(), kind })?;
            }
        }
        Ok(self)
    }

    /// The first AOV of `kind` and the index of its first channel.
    #[must_use]
    pub fn find(&self, kind: AovKind) -> Option<(&Aov, usize)> {
        let mut at = 0;
        for aov in &self.0 {
            if aov.kind == kind {
                return Some((aov, at));
            }
            at += aov.kind.suffixes().len();
        }
        None
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    #[must_use]
    pub fn list(&self) -> &[Aov] {
        &self.0
    }

    /// Channels in all.
    #[must_use]
    pub fn channel_count(&self) -> usize {
        self.0.iter().map(|a| a.kind.suffixes().len()).sum()
    }

    /// Every channel's name, in order.
    pub fn channel_names(&self) -> impl Iterator<Item = String> + '_ {
        self.0.iter().flat_map(Aov::channels)
    }

    /// The list as `--aov` and `integrator.aovs` read it (`name:type,…`).
    #[must_use]
    pub fn spec(&self) -> String {
        self.0.iter().map(|a| format!("{}:{}", a.name, a.kind.name())).collect::<Vec<_>>().join(",")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Mitsuba's names: `dd.y:depth` → `dd.y.T`, `nn:sh_normal` → `nn.X/Y/Z`; a bare type names itself,
    /// `normal` is the shading normal.
    #[test]
    fn channels_are_named_as_mitsuba_names_them() {
        let a = Aovs::parse("dd.y:depth,nn:sh_normal, albedo uv").unwrap();
        let names: Vec<String> = a.channel_names().collect();
        assert_eq!(names, ["dd.y.T", "nn.X", "nn.Y", "nn.Z", "albedo.R", "albedo.G", "albedo.B", "uv.U", "uv.V"]);
        assert_eq!(a.channel_count(), 9);
        assert_eq!(a.find(AovKind::Albedo).map(|(_, at)| at), Some(4));
        let n = Aovs::parse("normal,shape_index,material_index,prim_index,position,geo_normal").unwrap();
        assert_eq!(n.list()[0], Aov { name: "normal".into(), kind: AovKind::ShNormal });
        assert_eq!(n.channel_names().collect::<Vec<_>>()[3..6], ["shape_index.I", "material_index.I", "prim_index.I"]);
        assert_eq!(Aovs::parse(&a.spec()).unwrap(), a);
        assert!(Aovs::parse("").unwrap().is_empty());
    }

    #[test]
    fn bad_lists_are_refused_with_the_reason() {
        let e = |s: &str| Aovs::parse(s).unwrap_err().0;
        assert!(e("nn:sh_normals").contains("unknown AOV type \"sh_normals\""), "{}", e("nn:sh_normals"));
        assert!(e("d:dp_du").contains("texture coordinates"));
        assert!(e(":depth").contains("expected <name>:<type>"));
        assert!(e("a:b:depth").contains("expected"));
        assert!(e("x:depth,x:depth").contains("two channels named \"x.T\""));
        // Another type, the same channel name.
        assert!(e("n:sh_normal,n:position").contains("\"n.X\""));
    }

    /// The denoiser's AOVs are added only where missing, after the others.
    #[test]
    fn with_kinds_adds_what_is_missing() {
        let a = Aovs::parse("nn:sh_normal").unwrap().with_kinds(&[AovKind::Albedo, AovKind::ShNormal]).unwrap();
        assert_eq!(a.channel_names().collect::<Vec<_>>(), ["nn.X", "nn.Y", "nn.Z", "albedo.R", "albedo.G", "albedo.B"]);
    }
}
