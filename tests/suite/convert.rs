//! `caustica convert` (`scene::convert_scene`): every shipped TOML scene → Mitsuba XML → TOML describes
//! the same scene as the original — the same settings, materials, triangles (vertices bit for bit) and
//! lights — and renders the same image bit for bit (`mis`, same seed), through the XML too; and the XML
//! written from the round-tripped TOML is the XML written from the original (a fixed point). The XML
//! twins Mitsuba wrote (`tests/data/xml/`) convert to TOML that builds their scene. (`emitter-texture.toml`:
//! textures inside emitters, inline and referenced.)

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use crate::common::{backend, repo_path};

use caustica::film::Image;
use caustica::photon::PhotonBudget;
use caustica::render::{render_image, RenderSettings};
use caustica::scene::{convert_scene, Estimator, Scene};

const SCENES: &[&str] = &[
    "scenes/cornell-caustics.toml",
    "scenes/envmap-glass.toml",
    "scenes/teapot-glossy.toml",
    "scenes/teapot-glossy-small-light.toml",
    "tests/data/glossy-mirror.toml",
    "tests/data/mirror-box.toml",
    "tests/data/mirror-ceiling.toml",
    "tests/data/materials/emitter-texture.toml",
];

fn tmp(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("convert");
    std::fs::create_dir_all(&d).expect("tmp dir");
    d.join(name)
}

/// Converts `input` to `output` (written) and returns the text.
fn convert(input: &Path, output: &Path) -> String {
    let text = convert_scene(input, output, &BTreeMap::new()).unwrap_or_else(|e| panic!("{e}"));
    std::fs::write(output, &text).expect("write");
    text
}

fn tiny_render(path: &Path) -> Image {
    let mut scene = Scene::load(path).unwrap_or_else(|e| panic!("{e}"));
    scene.camera.set_resolution(40, 30).expect("resolution");
    let mut s = RenderSettings::from_scene(&scene);
    s.spp = 2;
    s.seed = 5;
    s.estimator = Estimator::Mis;
    s.photons = PhotonBudget::Emitted(20_000);
    render_image(&scene, backend(), &s).unwrap_or_else(|e| panic!("{e}")).image
}

fn bits(i: &Image) -> Vec<[u32; 3]> {
    i.pixels().iter().map(|p| p.to_array().map(f32::to_bits)).collect()
}

/// Everything after the first comment line (which names the source file).
fn body(xml: &str) -> &str {
    &xml[xml.find("-->").expect("comment")..]
}

#[test]
fn toml_to_xml_to_toml_is_the_same_scene_and_image() {
    for rel in SCENES {
        let name = Path::new(rel).file_stem().unwrap().to_string_lossy().into_owned();
        let original = repo_path(rel);
        let xml_path = tmp(&format!("{name}.xml"));
        let xml = convert(&original, &xml_path);
        let toml_path = tmp(&format!("{name}.roundtrip.toml"));
        convert(&xml_path, &toml_path);
        let xml_again = convert(&toml_path, &tmp(&format!("{name}.again.xml")));
        assert_eq!(body(&xml), body(&xml_again), "{rel}: XML of the round-tripped TOML differs");
        let (a, b) = (Scene::load(&original).unwrap(), Scene::load(&toml_path).unwrap());
        assert_eq!(a.integrator, b.integrator, "{rel}: settings");
        assert_eq!(a.materials, b.materials, "{rel}: materials");
        assert_eq!(a.tri_material, b.tri_material, "{rel}: materials per triangle");
        assert_eq!(a.mesh.indices, b.mesh.indices, "{rel}: triangles");
        assert!(a.mesh.positions.iter().zip(&b.mesh.positions).all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits)), "{rel}: vertices");
        assert_eq!(a.lights.lights().len(), b.lights.lights().len(), "{rel}: lights");
        let reference = bits(&tiny_render(&original));
        assert_eq!(reference, bits(&tiny_render(&xml_path)), "{rel}: the XML renders another image");
        assert_eq!(reference, bits(&tiny_render(&toml_path)), "{rel}: the round-tripped TOML renders another image");
    }
}

#[test]
fn mitsuba_written_xml_converts_to_toml_that_builds_its_scene() {
    for rel in ["tests/data/xml/cornell-caustics.xml", "tests/data/xml/hand-cornell.xml", "tests/data/xml/envmap-glass.xml"] {
        let input = repo_path(rel);
        let name = Path::new(rel).file_stem().unwrap().to_string_lossy().into_owned();
        let out = tmp(&format!("{name}.from-xml.toml"));
        convert(&input, &out);
        assert_eq!(bits(&tiny_render(&input)), bits(&tiny_render(&out)), "{rel}: its TOML renders another image");
    }
}

/// Bad command lines: exit 2, the message names the flag or the file, and no output file is left.
#[test]
fn convert_errors_exit_2_and_write_nothing() {
    let bin = env!("CARGO_BIN_EXE_caustica");
    let scene = repo_path("scenes/cornell-caustics.toml");
    let cases: [(Vec<String>, &str); 3] = [
        (vec![scene.display().to_string(), "-o".into(), tmp("out.obj").display().to_string()], "must end in .xml"),
        (vec![tmp("missing.toml").display().to_string(), "-o".into(), tmp("missing.xml").display().to_string()], "missing.toml"),
        (vec![repo_path("tests/data/xml/hand-cornell.xml").display().to_string(), "-o".into(), tmp("params.toml").display().to_string(), "-D".into(), "nope=1".into()], "nope"),
    ];
    for (args, expected) in cases {
        let out = std::process::Command::new(bin).arg("convert").args(&args).output().expect("runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(expected), "{args:?}: {stderr:?} does not name {expected:?}");
        assert!(!Path::new(&args[2]).exists(), "{args:?}: an output was written");
    }
}
