//! Each material (BSDF type) against Mitsuba 3.9.1 itself: one small scene per type in `tests/data/materials/`
//! (`<type>.toml`), rendered by caustica and compared with Mitsuba's `path` render `<type>-ref.exr` (64×48,
//! 16,384 spp, scalar_rgb, box filter; written by `scripts/make-material-references`, provenance in the
//! folder's README). Scenes with a delta lobe are rendered by `pt` and by `mis` (its photon map and the
//! density estimate combined by MIS must give Mitsuba's image too); others by `pt`.
//!
//! Noise model as in `mitsuba_features`: our pixel variance from the film, the reference's modelled as
//! `κ·s²ᵢ/16384` with κ = 2. Bounds for `pt`: whole image within 2 % and 4σ + 0.5 %; each 8×8 block within
//! 4.5σ + 0.5 %. `mis` adds the density estimate's kernel bias (docs/method.md, "The k-th photon" and the
//! measured caustic-region bias of +0.5–0.8 %), which is large here because most of the floor's direct
//! light comes through a pane: measured on `thindielectric` at 512 spp, whole image +0.9 % and the worst
//! 8×8 block +3.1 % with the default 100,000 photons per pass, +0.5 % and +1.9 % with 2,000,000 (the bias
//! falls with the photon count, as a consistent estimator's must); `pt` at 2,048 spp: 0.9998 and every
//! block within 2.1 %. The `mis` test renders 1,000,000 photons per pass and allows 3 % per block, which
//! still catches a wrong weight of a pane's lobe (its reflectance alone is 8 % of what passes).

use crate::common;

use caustica::film::read_exr;
use caustica::photon::PhotonBudget;
use caustica::render::RenderSettings;
use caustica::scene::{Estimator, Scene};
use common::*;

const REF_SPP: f64 = 16384.0;
const PT_BOUNDS: MitsubaBounds = MitsubaBounds { ref_spp: REF_SPP, kappa: 2.0, slack: 0.005, whole_rel: Some(0.02) };
const MIS_BOUNDS: MitsubaBounds = MitsubaBounds { slack: 0.03, ..PT_BOUNDS };
const MIS_PHOTONS: u64 = 1_000_000;

/// Renders `tests/data/materials/<name>.toml` with `estimator` at `spp` and compares it with its reference.
fn matches_mitsuba(name: &str, estimator: Estimator, spp: u32) {
    let scene = Scene::load(&repo_path(&format!("tests/data/materials/{name}.toml"))).unwrap_or_else(|e| panic!("{e}"));
    let reference = read_exr(repo_path(&format!("tests/data/materials/{name}-ref.exr"))).unwrap_or_else(|e| panic!("the reference: {e}"));
    assert_eq!((reference.width(), reference.height()), (scene.camera.width(), scene.camera.height()));
    let mut s = RenderSettings::from_scene(&scene);
    s.spp = spp;
    s.seed = 7;
    s.estimator = estimator;
    let bounds = if estimator == Estimator::Pt {
        PT_BOUNDS
    } else {
        s.photons = PhotonBudget::Emitted(MIS_PHOTONS);
        MIS_BOUNDS
    };
    let r = render_with_variance(&scene, backend(), &s);
    assert_matches_mitsuba(&format!("{name} ({estimator:?})"), &r, &reference, &bounds);
}

#[test]
fn thindielectric_pt_matches_mitsuba() {
    matches_mitsuba("thindielectric", Estimator::Pt, 256);
}

#[test]
fn thindielectric_mis_matches_mitsuba() {
    matches_mitsuba("thindielectric", Estimator::Mis, 64);
}

#[test]
fn plastic_pt_matches_mitsuba() {
    // The coating mirrors a small light onto the back wall: `pt` finds that caustic only by BSDF samples
    // that hit the light, heavy-tailed noise that its sample variance underestimates at 256 spp (one block
    // read 4.2 % low, 5σ; at 4,096 spp 1.0 %, and the whole image 1.0001).
    matches_mitsuba("plastic", Estimator::Pt, 1024);
}

#[test]
fn plastic_mis_matches_mitsuba() {
    matches_mitsuba("plastic", Estimator::Mis, 64);
}

#[test]
fn roughdielectric_pt_matches_mitsuba() {
    // Measured: whole image 0.9999 (0.02σ) at 512 spp, 0.9985 at 4,096 spp with every block within 2.7 %.
    matches_mitsuba("roughdielectric", Estimator::Pt, 512);
}

#[test]
fn roughdielectric_mis_matches_mitsuba() {
    // Light through rough glass is the noisy part (σ 1.1 % of the image at 64 spp): measured 0.9866 (1.2σ),
    // and 0.9983 at 1,024 spp.
    matches_mitsuba("roughdielectric", Estimator::Mis, 64);
}

/// A caustic seen only through a frosted screen (docs/method.md §1.1): its paths cross the surface at the
/// screen, so T2 takes them whole in `pm` and `mis`; before that rule `pm` rendered 1.7 % and `mis` 2.1 % of
/// the image. Compared by means (the whole image, and the caustic's 16×16 pixels) rather than by 8×8 blocks:
/// the dim blocks around the caustic (0.2–0.4 % of its brightness) are lit by rare paths through the
/// sphere's rim whose sample variance is far from their spread at these counts (`pt` at 2,048 spp read 1.72
/// and 0.79 of Mitsuba in two of them), and one dim block reads 0.980 of Mitsuba in every estimator at
/// every count (not investigated: the same in `pt`, so not the caustic weights). Measured with the CLI
/// (256 spp, seed 7; whole image, caustic): `pt` 1.020, 1.018; `pm` and `mis` 1.002, 1.000.
#[test]
fn frosted_caustic_means_match_mitsuba() {
    let scene = Scene::load(&repo_path("tests/data/materials/frosted-caustic.toml")).unwrap_or_else(|e| panic!("{e}"));
    let reference = LumImage::from_image(&read_exr(repo_path("tests/data/materials/frosted-caustic-ref.exr")).unwrap_or_else(|e| panic!("{e}")));
    for estimator in [Estimator::Pt, Estimator::Pm, Estimator::Mis] {
        let mut s = RenderSettings::from_scene(&scene);
        s.spp = 256;
        s.seed = 7;
        s.estimator = estimator;
        let r = render_with_variance(&scene, backend(), &s);
        for (name, ours, theirs) in [("whole image", r.lum.whole(), reference.whole()), ("caustic", r.lum.region(24, 16, 40, 32), reference.region(24, 16, 40, 32))] {
            let ratio = ours.mean / theirs.mean;
            let sigma = ours.sigma() / theirs.mean;
            assert!((ratio - 1.0).abs() < 0.02 + 4.0 * sigma, "frosted-caustic ({estimator:?}), {name}: {ratio} of Mitsuba (σ {sigma})");
        }
    }
}

#[test]
fn roughplastic_pt_matches_mitsuba() {
    // Measured: 0.9996 (0.16σ) at 512 spp; 1.0004 at 16,384 spp.
    matches_mitsuba("roughplastic", Estimator::Pt, 512);
}

#[test]
fn roughplastic_mis_matches_mitsuba() {
    // Measured: 1.0012 (1.3σ), the glass cube's caustic on the rough plastic floor gathered from photons.
    matches_mitsuba("roughplastic", Estimator::Mis, 64);
}

#[test]
fn textures_pt_match_mitsuba() {
    matches_mitsuba("textures", Estimator::Pt, 512);
}

#[test]
fn textures_mis_match_mitsuba() {
    // The caustic of the glass sphere lands on the checkerboard: the photons and the density estimate see
    // the texture at their hits.
    matches_mitsuba("textures", Estimator::Mis, 64);
}

#[test]
fn normalmap_pt_matches_mitsuba() {
    // Measured at 1,024 spp: whole image 1.00001, every 8×8 block within 2.2 % (the worst under the mirror's
    // caustic, which `pt` finds only through BSDF samples that hit the light).
    matches_mitsuba("normalmap", Estimator::Pt, 1024);
}

#[test]
fn normalmap_mis_matches_mitsuba() {
    // The normal-mapped mirror's rippled caustic on the floor: photons leave it through the perturbed frame.
    // Measured at 64 spp: whole image 0.9997, every block within 2.5 %.
    matches_mitsuba("normalmap", Estimator::Mis, 64);
}

#[test]
fn emitter_texture_pt_matches_mitsuba() {
    // Textured area lights: the camera sees them, NEE samples them and BSDF samples hit them.
    matches_mitsuba("emitter-texture", Estimator::Pt, 512);
}

#[test]
fn emitter_texture_mis_matches_mitsuba() {
    // The glass sphere's caustic of the PFM light: photons carry the texture at their start, and T2's weight
    // at a light point is the density of the photon that would have left it (positions uniform by area).
    matches_mitsuba("emitter-texture", Estimator::Mis, 64);
}

#[test]
fn shape_lights_pt_match_mitsuba() {
    // Area emitters on a sphere (NEE by solid angle), an elliptic disk and a cylinder with a checkerboard on
    // its uvs, against Mitsuba's analytic emitters.
    matches_mitsuba("shape-lights", Estimator::Pt, 512);
}

#[test]
fn shape_lights_mis_match_mitsuba() {
    // The glass sphere's caustic from the photons of the three analytic lights, and T2's density at a point
    // of each.
    matches_mitsuba("shape-lights", Estimator::Mis, 64);
}

#[test]
fn analytic_shapes_pt_match_mitsuba() {
    // Analytic spheres, disks and cylinders (src/accel/analytic.rs): a close-up mirror sphere reflecting
    // checks, a glossy sphere, a disk and a cylinder under non-uniform scales with checkerboards on their
    // uvs, a flipped disk, a glass sphere's caustic.
    matches_mitsuba("analytic", Estimator::Pt, 512);
}

#[test]
fn analytic_shapes_mis_match_mitsuba() {
    // The glass sphere's caustic and the mirror sphere's reflections from photons through analytic shapes.
    matches_mitsuba("analytic", Estimator::Mis, 64);
}

#[test]
fn disk_and_cylinder_pt_match_mitsuba() {
    // Disks and cylinders (analytic; the light disk tessellated) against Mitsuba's: a disk light, Mitsuba's
    // uvs on both (a checkerboard), a cylinder placed by p0, p1 and radius.
    matches_mitsuba("shapes", Estimator::Pt, 512);
}

#[test]
fn disk_and_cylinder_mis_match_mitsuba() {
    // The glass cylinder's caustic on the floor, from photons and from BSDF-sampled paths.
    matches_mitsuba("shapes", Estimator::Mis, 64);
}

#[test]
fn instancing_pt_matches_mitsuba() {
    // One shapegroup placed four times (turned, non-uniformly scaled, mirrored, tilted): the two-level
    // acceleration and the placed shading frames against Mitsuba's instances.
    matches_mitsuba("instancing", Estimator::Pt, 512);
}

#[test]
fn instancing_mis_matches_mitsuba() {
    // The instanced glass spheres' caustics: photons and BSDF-sampled caustic paths through instances.
    matches_mitsuba("instancing", Estimator::Mis, 64);
}

#[test]
fn thinlens_pt_matches_mitsuba() {
    // Depth of field: cubes before, on and behind the focal plane, a chequered floor across it; the lens
    // sample is the sample's second 2-D dimension, as Mitsuba draws it.
    matches_mitsuba("thinlens", Estimator::Pt, 512);
}

#[test]
fn orthographic_pt_matches_mitsuba() {
    // A scaled view 5 units wide; near_clip cuts a panel in front of the camera plane, far_clip the floor's
    // far end.
    matches_mitsuba("orthographic", Estimator::Pt, 512);
}

#[test]
fn perspective_clip_pt_matches_mitsuba() {
    // near_clip cuts a panel in front of the camera, far_clip (a depth along the viewing axis) the floor's far
    // end and a cube across it.
    matches_mitsuba("perspective-clip", Estimator::Pt, 512);
}

#[test]
fn mesh_attribute_pt_matches_mitsuba() {
    // A PLY's 8-bit vertex colours (interpolated), its per-face colours and a per-face blend weight.
    matches_mitsuba("mesh-attribute", Estimator::Pt, 512);
}

#[test]
fn mesh_attribute_mis_matches_mitsuba() {
    // The glass sphere's caustic on the per-face coloured floor: photons stored there and T2 paths read
    // the attribute at their hits.
    matches_mitsuba("mesh-attribute", Estimator::Mis, 64);
}

/// A shape whose material reads a mesh attribute it lacks is an error naming the shape, the attribute and
/// the ones it has.
#[test]
fn a_missing_mesh_attribute_names_the_shape_and_the_attribute() {
    let text = "[sensor]\nfov = 40\n[[shape]]\ntype = \"ply\"\nfilename = \"textures/colours.ply\"\n\
bsdf = { type = \"diffuse\", reflectance = { type = \"mesh_attribute\", name = \"vertex_albedo\" } }\n";
    let dir = repo_path("tests/data/materials");
    let e = Scene::from_toml_str(text, &dir, std::path::Path::new("t.toml")).err().expect("accepted").to_string();
    for part in ["shape[0]", "the ply shape \"textures/colours.ply\" has no attribute `vertex_albedo`", "it has vertex_color, face_color, face_weight"] {
        assert!(e.contains(part), "{part:?} in {e}");
    }
}

/// A textured property that the BSDF type cannot texture, a texture where only a constant is read, and a
/// reference to a texture that does not exist are errors at their keys.
#[test]
fn texture_errors_name_their_keys() {
    let base = "[sensor]\nfov = 40\n[[shape]]\ntype = \"rectangle\"\n";
    let cases = [
        ("bsdf = { type = \"conductor\", eta = { type = \"checkerboard\" }, k = 1 }", "shape[0].bsdf.eta", "cannot take a texture here (the properties it can texture: specular_reflectance)"),
        ("bsdf = { type = \"dielectric\", int_ior = { type = \"checkerboard\" } }", "shape[0].bsdf.int_ior", "this property cannot be a texture"),
        ("bsdf = { type = \"diffuse\", reflectance = { texture = \"wood\" } }", "shape[0].bsdf.reflectance.texture", "unknown texture `wood`"),
        ("bsdf = { type = \"diffuse\", reflectance = { type = \"bitmap\", filename = \"missing.png\" } }", "shape[0].bsdf.reflectance.filename", "missing.png"),
        ("emitter = { type = \"area\", radiance = { texture = \"sky\" } }", "shape[0].emitter.radiance.texture", "unknown texture `sky`"),
        // An RGB colour must lie in [0, 1] (a single number is Mitsuba's unbounded `uniform`, accepted).
        ("emitter = { type = \"area\", radiance = { type = \"checkerboard\", color0 = [2, 0, 0] } }", "shape[0].emitter.radiance.color0", "must be in [0, 1]"),
        ("bsdf = { type = \"roughconductor\", alpha = { type = \"checkerboard\", color0 = 0, color1 = 0 } }", "shape[0].bsdf.alpha", "the texture's mean: the roughness alpha must be > 0"),
        ("bsdf = { type = \"normalmap\", normalmap = [0.5, 0.5, 1], bsdf = { type = \"diffuse\" } }", "shape[0].bsdf.normalmap", "must be a texture"),
        ("bsdf = { type = \"normalmap\", bsdf = { type = \"diffuse\" } }", "shape[0].bsdf.normalmap", "missing"),
        ("bsdf = { type = \"diffuse\", reflectance = { type = \"mesh_attribute\", name = \"vertex_color\" } }", "shape[0]", "the rectangle shape has no attribute `vertex_color`, which its material reads (a `mesh_attribute` texture); it has none"),
        ("bsdf = { type = \"diffuse\", reflectance = { type = \"mesh_attribute\", name = \"color\" } }", "shape[0].bsdf.reflectance.name", "must start with \"vertex_\" or \"face_\""),
        ("emitter = { type = \"area\", radiance = { type = \"mesh_attribute\", name = \"vertex_color\" } }", "shape[0].emitter.radiance", "as an emitter's radiance"),
        ("bsdf = { type = \"bumpmap\", texture = { type = \"checkerboard\" }, scale = { type = \"checkerboard\" }, bsdf = { type = \"diffuse\" } }", "shape[0].bsdf.scale", "cannot take a texture here"),
    ];
    for (bsdf, key, message) in cases {
        let text = format!("{base}{bsdf}\n");
        let e = Scene::from_toml_str(&text, std::path::Path::new("."), std::path::Path::new("t.toml")).err().unwrap_or_else(|| panic!("{bsdf}: accepted"));
        let shown = e.to_string();
        assert!(shown.contains(key) && shown.contains(message), "{bsdf}:\n{shown}");
    }
}

#[test]
fn mask_and_null_pt_match_mitsuba() {
    matches_mitsuba("mask", Estimator::Pt, 512);
}

#[test]
fn mask_and_null_mis_match_mitsuba() {
    // Photons pass through the cut-outs and the null pane as through a delta surface; the glass sphere's
    // caustic falls through the holes.
    matches_mitsuba("mask", Estimator::Mis, 64);
}

/// Mitsuba's `hide_emitters` (not a material, but the same comparison): the sky and the light the camera
/// sees are hidden, what reaches them through a mirror, glass or a pass-through followed by a scattering is
/// not (`PathTracer::hide_unscattered`; `tests/data/materials/hide-emitters.toml`).
#[test]
fn hide_emitters_pt_matches_mitsuba() {
    matches_mitsuba("hide-emitters", Estimator::Pt, 256);
}

#[test]
fn hide_emitters_mis_matches_mitsuba() {
    // The photon map's caustics (the glass sphere's) are collected by paths that scattered: shown.
    matches_mitsuba("hide-emitters", Estimator::Mis, 64);
}

#[test]
fn pplastic_pt_matches_mitsuba() {
    // As `plastic`'s: the floor's specular lobe throws the light onto the back wall, which `pt` finds only by
    // BSDF samples that hit the light (the wall's top blocks read ±5 % from one seed to the next at 4,096 spp;
    // the whole image 1.0004).
    matches_mitsuba("pplastic", Estimator::Pt, 1024);
}

#[test]
fn pplastic_mis_matches_mitsuba() {
    matches_mitsuba("pplastic", Estimator::Mis, 64);
}

#[test]
fn principled_pt_matches_mitsuba() {
    // Rough metal with a textured roughness, a clearcoat, a glass-like spec_trans sphere, an anisotropic
    // panel and a floor with sheen, flatness and a textured base colour.
    matches_mitsuba("principled", Estimator::Pt, 512);
}

#[test]
fn principled_mis_matches_mitsuba() {
    // The glass cube's caustic on the principled floor, gathered from photons.
    matches_mitsuba("principled", Estimator::Mis, 64);
}

#[test]
fn principledthin_pt_matches_mitsuba() {
    // A sheen/flatness floor with a textured base colour, a leaf transmitting diffusely, a frosted sheet
    // with a textured roughness (the wall seen through it) and Mitsuba's documentation example.
    matches_mitsuba("principledthin", Estimator::Pt, 512);
}

#[test]
fn principledthin_mis_matches_mitsuba() {
    // The glass sphere's caustic on the principledthin floor, gathered from photons.
    matches_mitsuba("principledthin", Estimator::Mis, 64);
}

#[test]
fn spot_texture_pt_matches_mitsuba() {
    // A textured spot: NEE reads the texture at Mitsuba's direction_to_uv, times the falloff; a bitmap
    // projected obliquely through a mirrored (look_at) frame, a checkerboard with a hard edge.
    matches_mitsuba("spot-texture", Estimator::Pt, 512);
}

#[test]
fn spot_texture_mis_matches_mitsuba() {
    // The glass sphere's caustic is the checkerboard spot's photons (which carry the texture).
    matches_mitsuba("spot-texture", Estimator::Mis, 64);
}

#[test]
fn everything_pt_matches_mitsuba() {
    // Issue 38's scene with every new material and texture type (everything.toml's header lists them;
    // Mitsuba 0.6's phong and ward have no Mitsuba 3 image to match).
    matches_mitsuba("everything", Estimator::Pt, 256);
}

#[test]
fn everything_mis_matches_mitsuba() {
    // The photon pass over the same materials (thindielectric and the mask's pass-through are delta lobes).
    matches_mitsuba("everything", Estimator::Mis, 64);
}

#[test]
fn projector_pt_matches_mitsuba() {
    // Mitsuba's projector: NEE reads the texture where the point projects onto its film, times
    // π·scale·k/(z²·cos θ); a bitmap's aspect sets the film, a focal length its field of view.
    matches_mitsuba("projector", Estimator::Pt, 512);
}

#[test]
fn projector_mis_matches_mitsuba() {
    // The photon pass with projectors in the light set: their photons (through the film or the cone toward
    // the glass sphere) carry their intensity; the glass sphere's caustic is the area light's.
    matches_mitsuba("projector", Estimator::Mis, 64);
}

#[test]
fn anisotropy_pt_matches_mitsuba() {
    // Anisotropic roughness along Mitsuba's tangent (∂p/∂u): with the frame around the normal alone this
    // scene's image was 7–8 % brighter than Mitsuba's (RMSE 0.095 at 1,024 spp).
    matches_mitsuba("anisotropy", Estimator::Pt, 1024);
}

#[test]
fn anisotropy_mis_matches_mitsuba() {
    // The glass sphere's caustic on the anisotropic floor: photons gathered through the same frame.
    matches_mitsuba("anisotropy", Estimator::Mis, 64);
}

#[test]
fn sunsky_pt_matches_mitsuba() {
    // Mitsuba's `sunsky` (decision 35): the Hošek–Wilkie sky baked into an environment map, the sun an exact
    // disc the map carries; the sun's position from a date and a place, the frame turned by `to_world`.
    // Measured: 0.9999 (0.15σ) at 512 spp; at 1,024 spp 0.9998–0.9999 per channel, the sky's rows 0.9999.
    matches_mitsuba("sunsky", Estimator::Pt, 512);
}

#[test]
fn sunsky_mis_matches_mitsuba() {
    // `mis` with the sunsky in its light set (no delta surface here: the photon pass finds nothing to store).
    // Measured: 0.9993 (0.38σ).
    matches_mitsuba("sunsky", Estimator::Mis, 64);
}

#[test]
fn sunsky_caustic_pt_matches_mitsuba() {
    // A 6° sun through a glass sphere: path tracing finds its caustic by BSDF samples that hit the disc.
    // Measured: 0.9995 (0.32σ), worst 8×8 block 2.6σ beyond the slack.
    matches_mitsuba("sunsky-caustic", Estimator::Pt, 1024);
}

#[test]
fn sunsky_caustic_mis_matches_mitsuba() {
    // The same caustic from the photons of the sunsky's sun (its cone) and sky (the map), density-estimated.
    // Measured: 1.0027 (0.51σ), worst block 0.6σ beyond the 3 % slack.
    matches_mitsuba("sunsky-caustic", Estimator::Mis, 64);
}
