//! Mitsuba's `shapegroup` and `instance` (src/shapes/shapegroup.cpp, src/shapes/instance.cpp,
//! src/render/shapegroup.cpp): a shape group holds shapes, each with its own BSDF, in the group's object
//! space, and is not rendered itself; an `instance` shape places a group by its `to_world` (any invertible
//! affine map: non-uniform scales and mirrors included). Every group's triangles are stored once, after the
//! flat soup (`Scene::prototypes`), whatever the number of its instances; a group no instance names is
//! checked but not loaded.
//!
//! ```toml
//! [shapegroup.tree]                     # the group's id
//! shape = [
//!   { type = "obj", filename = "trunk.obj", bsdf = "bark" },
//!   { type = "sphere", center = [0, 2, 0], radius = 1, bsdf = { type = "diffuse", reflectance = [0.1, 0.5, 0.1] } },
//! ]
//!
//! [[shape]]
//! type = "instance"
//! shapegroup = "tree"                   # the group's id (XML: <ref id="tree"/>)
//! to_world = [ { scale = [1, 2, 1] }, { translate = [4, 0, 0] } ]
//! ```
//!
//! The rules Mitsuba 3.9.1 enforces, refused here with the key that breaks them: a group's shape may not
//! emit ("Instancing of emitters is not supported"), be an instance ("Nested instancing is not permitted")
//! or a group ("Nested ShapeGroup is not permitted"); an instance names exactly one group, which must exist
//! ("A reference to a 'shapegroup' must be specified!"); it takes no BSDF, emitter or `flip_normals` of its
//! own (its group's shapes have theirs).

use std::collections::BTreeMap;

use glam::Affine3A;

use super::desc::ShapeDesc;
use super::error::{ErrorContext, SceneError};
use super::spans::join_key;
use super::transform::{invertible_linear_part, to_world_matrix};

/// The shape type of an instance.
pub(crate) const INSTANCE: &str = "instance";
/// The shape type of a group in Mitsuba XML (a `[shapegroup.<id>]` table in TOML).
pub(crate) const SHAPEGROUP: &str = "shapegroup";
/// The keys an instance takes.
pub(crate) const INSTANCE_KEYS: &[&str] = &["to_world", "shapegroup"];

/// An instance shape at `key` → its group's index in `groups` (the ids in order) and its `to_world`.
pub(super) fn plan_instance(ctx: &ErrorContext, key: &str, d: &ShapeDesc, groups: &BTreeMap<String, usize>) -> Result<(u32, Affine3A), SceneError> {
    let own = |k: &str, given: bool| if given { Err(ctx.key_error(&join_key(key, k), format!("an instance takes no {k}: the shapes of its shapegroup have their own"))) } else { Ok(()) };
    own("bsdf", d.bsdf.is_some())?;
    own("emitter", d.emitter.is_some())?;
    own("flip_normals", d.flip_normals.is_some())?;
    if let Some(k) = d.plugin.props.keys().find(|k| !INSTANCE_KEYS.contains(&k.as_str())) {
        return Err(ctx.key_error(&join_key(key, k), format!("an instance takes the keys {}", INSTANCE_KEYS.join(", "))));
    }
    let group_key = join_key(key, "shapegroup");
    let name = match d.plugin.props.get("shapegroup") {
        None => return Err(ctx.key_error(key, "an instance needs `shapegroup`, the id of the shapegroup it places (Mitsuba: \"A reference to a 'shapegroup' must be specified!\")")),
        Some(toml::Value::String(s)) => s,
        Some(v) => return Err(ctx.key_error(&group_key, format!("a shapegroup's id (a string) is expected, not {}", v.type_str()))),
    };
    let Some(&group) = groups.get(name) else {
        let known: Vec<&str> = groups.keys().map(String::as_str).collect();
        let known = if known.is_empty() { "the scene has none".to_string() } else { format!("the scene's are {}", known.join(", ")) };
        return Err(ctx.key_error(&group_key, format!("no shapegroup has the id {name:?} ({known})")));
    };
    let to_world_key = join_key(key, "to_world");
    let m = to_world_matrix(ctx, &to_world_key, d.to_world.as_ref())?;
    invertible_linear_part(ctx, &to_world_key, m)?;
    let to_world = Affine3A::from_mat4(m);
    if crate::accel::Instance::new(0, to_world).is_none() {
        return Err(ctx.key_error(&to_world_key, "the transform has no finite inverse"));
    }
    Ok((group as u32, to_world))
}

/// The checks of a group's shape at `key` (Mitsuba's `ShapeGroup` constructor).
pub(super) fn check_group_shape(ctx: &ErrorContext, key: &str, d: &ShapeDesc) -> Result<(), SceneError> {
    if d.plugin.kind == INSTANCE {
        return Err(ctx.key_error(&join_key(key, "type"), "a shapegroup cannot hold an instance (Mitsuba: \"Nested instancing is not permitted\")"));
    }
    if d.plugin.kind == SHAPEGROUP {
        return Err(ctx.key_error(&join_key(key, "type"), "a shapegroup cannot hold a shapegroup (Mitsuba: \"Nested ShapeGroup is not permitted\")"));
    }
    if d.emitter.is_some() {
        return Err(ctx.key_error(&join_key(key, "emitter"), "a shape in a shapegroup cannot emit (Mitsuba: \"Instancing of emitters is not supported\")"));
    }
    Ok(())
}

/// A `[[shape]]` of type `shapegroup` in TOML, where groups are tables of their own.
pub(super) fn refuse_group_as_shape(ctx: &ErrorContext, key: &str) -> SceneError {
    ctx.key_error(&join_key(key, "type"), "a shapegroup is a table of its own, `[shapegroup.<id>]` with `shape = [...]`, placed by shapes of type \"instance\"")
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use crate::accel::{build_accel, Accel, BackendKind, FLAT};
    use crate::math::{Ray, Vec3};
    use crate::scene::Scene;

    const HEAD: &str = "[sensor]\nfilm = { width = 8, height = 8 }\nto_world = { look_at = { origin = [0, 0, 9], target = [0, 0, 0], up = [0, 1, 0] } }\n[bsdf.glass]\ntype = \"dielectric\"\n";
    const SHAPES: [&str; 2] = [
        "type = \"sphere\"\ncenter = [0.3, 0, 0]\nradius = 0.8\nrings = 16\nsegments = 32\nbsdf = \"glass\"",
        "type = \"cube\"\nto_world = { scale = [0.3, 0.2, 0.6] }\nbsdf = { type = \"diffuse\", reflectance = 0.3 }",
    ];
    /// Placements: non-uniform scales, rotations and a mirror.
    const PLACES: [&str; 3] = [
        "[ { scale = [1, 0.5, 2] }, { rotate = { axis = [0, 1, 1], angle = 30 } }, { translate = [-2, 0, 0] } ]",
        "[ { scale = [-1, 1, 1] }, { translate = [2, 1, 0] } ]",
        "[ { rotate = { axis = [1, 0, 0], angle = 75 } }, { scale = [0.5, 1.5, 0.7] }, { translate = [0, -2, 1] } ]",
    ];

    fn load(text: &str) -> Result<Scene, String> {
        Scene::from_toml_str(text, Path::new("."), Path::new("s.toml")).map_err(|e| e.to_string())
    }

    /// An instanced scene shades as the same shapes placed one by one: the same points, geometric and
    /// shading normals, materials, through both the oracle and the BVH; its prototypes are stored once.
    #[test]
    fn instances_shade_as_the_shapes_placed_flat() {
        let mut instanced = format!("{HEAD}[shapegroup.g]\nshape = [\n");
        for s in SHAPES {
            instanced += &format!("{{ {} }},\n", s.replace('\n', ", "));
        }
        instanced += "]\n[[shape]]\ntype = \"rectangle\"\nto_world = { translate = [0, 0, -3] }\n";
        let mut flat = format!("{HEAD}[[shape]]\ntype = \"rectangle\"\nto_world = {{ translate = [0, 0, -3] }}\n");
        for place in PLACES {
            instanced += &format!("[[shape]]\ntype = \"instance\"\nshapegroup = \"g\"\nto_world = {place}\n");
            for s in SHAPES {
                // The shape's own transform first, then the instance's.
                let own = s.lines().find_map(|l| l.strip_prefix("to_world = ")).map(|t| format!("{t}, ")).unwrap_or_default();
                let rest: Vec<&str> = s.lines().filter(|l| !l.starts_with("to_world")).collect();
                flat += &format!("[[shape]]\n{}\nto_world = [ {own}{} ]\n", rest.join("\n"), place.trim_start_matches('[').trim_end_matches(']'));
            }
        }
        let (a, b) = (load(&instanced).unwrap(), load(&flat).unwrap());
        assert_eq!((a.instances.len(), a.prototypes.len()), (3, 1));
        // The group's triangles once in the instanced scene, three times in the flat one.
        assert_eq!(3 * (a.triangle_count() - 2) + 2, b.triangle_count());
        // The instances' boxes are their prototype's box placed: they hold the placed triangles.
        let holds = |big: crate::math::Aabb, small: crate::math::Aabb| big.min.cmple(small.min + 1e-5).all() && big.max.cmpge(small.max - 1e-5).all();
        assert!(holds(a.bounds, b.bounds), "{:?} {:?}", a.bounds, b.bounds);
        assert!(holds(a.delta_bounds(), b.delta_bounds()) && !a.delta_bounds().is_empty());
        let oracle_b = crate::accel::brute::BruteForce::new(&b.mesh.positions, &b.mesh.indices);
        let backends: Vec<Box<dyn Accel>> = vec![Box::new(crate::accel::brute::BruteForce::from_geometry(&a.geometry())), build_accel(BackendKind::Bvh, &a.geometry()).unwrap()];
        let mut sampler = crate::sampler::Sampler::for_key(7, 0, 0);
        let (mut compared, mut on_instances) = (0, 0);
        for _ in 0..3000 {
            let mut v = || 2.0 * sampler.next_1d() - 1.0;
            let origin = Vec3::new(4.0 * v(), 4.0 * v(), 8.0);
            let ray = Ray::new(origin, Vec3::new(2.5 * v(), 2.5 * v(), v()) - origin);
            let want = oracle_b.intersect(&ray).map(|h| b.interaction(&ray, &h));
            for accel in &backends {
                let got = accel.intersect(&ray).map(|h| a.interaction(&ray, &h));
                let (Some(g), Some(w)) = (got, want) else {
                    assert_eq!(got.is_some(), want.is_some(), "{ray:?}");
                    continue;
                };
                if (g.p - w.p).length() > 1e-3 {
                    continue; // a grazing ray meeting another triangle by rounding
                }
                compared += 1;
                on_instances += usize::from(g.inst != FLAT);
                assert!(g.ng.dot(w.ng) > 0.9999 && g.ns.dot(w.ns) > 0.999, "{g:?}\n{w:?}");
                assert_eq!(a.materials[g.material as usize].facts().has_delta, b.materials[w.material as usize].facts().has_delta);
                assert!(g.p_error.cmpge(Vec3::ZERO).all() && g.p_error.max_element() < 1e-4);
                // The derivatives a normal or bump map reads lie in the world tangent plane.
                let f = a.hit_frame(&g);
                assert!(f.dp_du.dot(g.ng).abs() <= 1e-3 * f.dp_du.length() && f.dp_dv.dot(g.ng).abs() <= 1e-3 * f.dp_dv.length());
            }
        }
        assert!(compared > 1500 && on_instances > 1000, "{compared} compared, {on_instances} on instances");
    }

    /// Mitsuba's refusals, each at its key.
    #[test]
    fn refusals_name_their_key() {
        let group = "[shapegroup.g]\nshape = [ { type = \"cube\" } ]\n";
        for (text, key, says) in [
            (format!("{HEAD}[[shape]]\ntype = \"instance\"\nshapegroup = \"h\"\n{group}"), "shape[0].shapegroup", "no shapegroup has the id \"h\""),
            (format!("{HEAD}[[shape]]\ntype = \"instance\"\n{group}"), "shape[0]", "needs `shapegroup`"),
            (format!("{HEAD}[[shape]]\ntype = \"instance\"\nshapegroup = \"g\"\nbsdf = \"glass\"\n{group}"), "shape[0].bsdf", "takes no bsdf"),
            (format!("{HEAD}[[shape]]\ntype = \"instance\"\nshapegroup = \"g\"\nto_world = {{ scale = [1, 0, 1] }}\n{group}"), "shape[0].to_world", ""),
            (format!("{HEAD}[shapegroup.g]\nshape = [ {{ type = \"cube\", emitter = {{ type = \"area\", radiance = 1 }} }} ]\n"), "shapegroup.g.shape[0].emitter", "Instancing of emitters is not supported"),
            (format!("{HEAD}[shapegroup.g]\nshape = [ {{ type = \"instance\", shapegroup = \"g\" }} ]\n"), "shapegroup.g.shape[0].type", "Nested instancing"),
            (format!("{HEAD}[[shape]]\ntype = \"shapegroup\"\n"), "shape[0].type", "[shapegroup.<id>]"),
            // An instance far from the origin for its size, as a flat shape would be (`precision`).
            (format!("{HEAD}[[shape]]\ntype = \"instance\"\nshapegroup = \"g\"\nto_world = {{ translate = [1e6, 0, 0] }}\n{group}"), "shape[0]", "the instance lies 1.0000e6 from the origin"),
        ] {
            let e = load(&text).err().unwrap_or_else(|| panic!("loads: {text}"));
            assert!(e.contains(key) && e.contains(says), "{key}: {e}");
        }
        // A group no instance places is checked, not loaded.
        let s = load(&format!("{HEAD}{group}[[shape]]\ntype = \"rectangle\"\n")).unwrap();
        assert_eq!((s.triangle_count(), s.instances.len()), (2, 0));
    }

    /// Mitsuba XML: a shapegroup of two shapes placed twice, with the refusals at their lines.
    #[test]
    fn xml_shapegroups_and_instances() {
        let xml = |body: &str| {
            let text = format!("<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"8\"/><integer name=\"height\" value=\"8\"/></film></sensor>\n{body}</scene>");
            Scene::from_xml_str(&text, Path::new("."), Path::new("s.xml"), &Default::default()).map_err(|e| e.to_string())
        };
        let group = "<shape type=\"shapegroup\" id=\"g\">\n<shape type=\"cube\"/>\n<shape type=\"rectangle\"><bsdf type=\"dielectric\"/></shape>\n</shape>\n";
        let s = xml(&format!("{group}<shape type=\"instance\"><ref id=\"g\"/></shape>\n<shape type=\"instance\"><ref id=\"g\"/><transform name=\"to_world\"><scale value=\"-1 2 1\"/></transform></shape>\n")).unwrap();
        assert_eq!((s.instances.len(), s.prototypes.clone(), s.flat_triangles, s.triangle_count()), (2, vec![0..14], 0, 14));
        assert!(s.has_delta_bsdf() && !s.delta_bounds().is_empty());
        for (body, says) in [
            ("<shape type=\"shapegroup\" id=\"g\">\n<shape type=\"cube\">\n<emitter type=\"area\"/></shape></shape>\n<shape type=\"instance\"><ref id=\"g\"/></shape>\n", "s.xml:5: <emitter type=\"area\">: a shape in a shapegroup cannot emit"),
            ("<bsdf type=\"diffuse\" id=\"d\"/>\n<shape type=\"instance\"><ref id=\"d\"/></shape>\n", "s.xml:4: <ref id=\"d\">: refers to a <bsdf>"),
            ("<shape type=\"instance\"><ref id=\"none\"/></shape>\n", "s.xml:3: <ref id=\"none\">: no element has id"),
            ("<shape type=\"instance\"/>\n", "needs `shapegroup`"),
        ] {
            let e = xml(body).err().unwrap_or_else(|| panic!("loads: {body}"));
            assert!(e.contains(says), "{says}: {e}");
        }
    }
}
