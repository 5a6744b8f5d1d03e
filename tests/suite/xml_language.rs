//! The scene language of real Mitsuba files (issue 37, item 3), each feature on a small file written here:
//! `<path>` search paths and includes relative to the including file, comments with `--`, `<ref>` to films,
//! samplers and area emitters declared at the top level, Mitsuba's sensor defaults (50 mm focal length; no
//! sensor at all), integrators read as `path` or replaced by `--estimator`, and properties that change no
//! image accepted with a note.

use crate::common;

use std::path::{Path, PathBuf};

use caustica::camera::FovAxis;
use caustica::scene::{LoadOptions, NoteKind, Scene};
use common::*;

/// A fresh directory for one test's files.
fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-xml-language-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn write(path: &Path, text: &str) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, text).unwrap();
}

fn load(path: &Path) -> Scene {
    Scene::load(path).unwrap_or_else(|e| panic!("{e}"))
}

/// The error of loading `path`, which must fail.
fn error(path: &Path) -> String {
    match Scene::load(path) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film></sensor>"#;

#[test]
fn path_elements_and_includes_find_files_as_mitsuba_does() {
    let d = dir("path");
    std::fs::copy(repo_path("scenes/assets/models/teapot.obj"), {
        std::fs::create_dir_all(d.join("meshes")).unwrap();
        d.join("meshes/teapot.obj")
    })
    .unwrap();
    // The include is found in the including file's directory (parts/), and names a mesh found along the
    // scene's <path>.
    write(&d.join("parts/inner.xml"), r#"<scene version="3.0.0"><shape type="obj"><string name="filename" value="teapot.obj"/></shape></scene>"#);
    write(&d.join("parts/outer.xml"), r#"<scene version="3.0.0"><include filename="inner.xml"/></scene>"#);
    let scene = d.join("scene.xml");
    write(&scene, &format!(r#"<scene version="3.0.0"><path value="meshes"/>{SENSOR}<include filename="parts/outer.xml"/></scene>"#));
    let s = load(&scene);
    assert!(s.triangle_count() > 1000, "the teapot: {} triangles", s.triangle_count());

    // Without the <path>, the mesh is not found, and the error names it.
    write(&scene, &format!(r#"<scene version="3.0.0">{SENSOR}<include filename="parts/outer.xml"/></scene>"#));
    let e = error(&scene);
    assert!(e.contains("teapot.obj"), "{e}");
    // A <path> to a folder that does not exist names it.
    write(&scene, &format!(r#"<scene version="3.0.0"><path value="nowhere"/>{SENSOR}</scene>"#));
    let e = error(&scene);
    assert!(e.contains("scene.xml:1") && e.contains("\"nowhere\" not found"), "{e}");
    // An include found nowhere says where it was looked for.
    write(&scene, &format!(r#"<scene version="3.0.0">{SENSOR}<include filename="missing.xml"/></scene>"#));
    let e = error(&scene);
    assert!(e.contains("\"missing.xml\" not found"), "{e}");
}

#[test]
fn comments_with_double_dashes_parse_and_keep_line_numbers() {
    let d = dir("comments");
    let scene = d.join("scene.xml");
    write(&scene, &format!("<scene version=\"3.0.0\">\n<!-- a -- b --->\n{SENSOR}\n<!---->\n<shape type=\"cube\"><float name=\"bogus\" value=\"1\"/></shape></scene>"));
    let e = error(&scene);
    // The error is on line 7 (the sensor spans lines 3-5, the empty comment is line 6): the comments kept every line.
    assert!(e.contains("scene.xml:7") && e.contains("bogus"), "{e}");
}

#[test]
fn references_to_films_samplers_and_area_emitters() {
    let d = dir("refs");
    let scene = d.join("scene.xml");
    write(
        &scene,
        r#"<scene version="3.0.0">
        <film type="hdrfilm" id="f"><integer name="width" value="10"/><integer name="height" value="4"/></film>
        <sampler type="independent" id="s"><integer name="sample_count" value="3"/></sampler>
        <emitter type="area" id="light"><rgb name="radiance" value="2"/></emitter>
        <sensor type="perspective"><float name="fov" value="40"/><ref id="f"/><ref id="s"/></sensor>
        <shape type="rectangle"><ref id="light"/><transform name="to_world"><translate z="-2"/></transform></shape>
        </scene>"#,
    );
    let s = load(&scene);
    assert_eq!((s.camera.width(), s.camera.height(), s.integrator.samples_per_pixel), (10, 4, 3));
    assert_eq!(s.lights.lights().len(), 1, "the area emitter is attached to the rectangle only");
    // A reference to the wrong kind of element names both.
    write(&scene, r#"<scene version="3.0.0"><bsdf type="diffuse" id="b"/><sensor type="perspective"><ref id="b"/></sensor></scene>"#);
    let e = error(&scene);
    assert!(e.contains("refers to a <bsdf>"), "{e}");
}

#[test]
fn sensor_defaults_are_mitsubas() {
    let d = dir("sensor");
    let scene = d.join("scene.xml");
    // No fov: Mitsuba's 50 mm focal length across the diagonal. Mitsuba 3.9.1 reports x_fov = 38.1848° for
    // `{'type': 'perspective'}` on its default 768×576 film (printed by `mi.load_dict`).
    write(&scene, r#"<scene version="3.0.0"><sensor type="perspective"/><shape type="cube"/></scene>"#);
    let s = load(&scene);
    assert_eq!((s.camera.width(), s.camera.height(), s.camera.fov().expect("a field of view").1), (768, 576, FovAxis::Diagonal));
    let (w, h) = (768.0f64, 576.0f64);
    let half_diag = (f64::from(s.camera.fov().expect("a field of view").0) / 2.0).to_radians().tan();
    let x_fov = 2.0 * (half_diag * w / w.hypot(h)).atan().to_degrees();
    assert!((x_fov - 38.1848).abs() < 1e-3, "x fov {x_fov}");
    // focal_length given.
    write(&scene, r#"<scene version="3.0.0"><sensor type="perspective"><string name="focal_length" value="35mm"/></sensor></scene>"#);
    let s = load(&scene);
    assert!((f64::from(s.camera.fov().expect("a field of view").0) - 2.0 * (36f64.hypot(24.0) / 70.0).atan().to_degrees()).abs() < 1e-4);
    // No sensor at all: Mitsuba 0.6's camera, 45° along x, from below the bounding box along +z.
    write(&scene, r#"<scene version="3.0.0"><shape type="cube"/></scene>"#);
    let s = load(&scene);
    assert_eq!(s.camera.fov(), Some((45.0, FovAxis::X)));
    let distance = 2.0 / (2.0 * 22.5f32.to_radians().tan());
    assert!((s.camera.position() - caustica::math::Vec3::new(0.0, 0.0, -1.0 - distance)).length() < 1e-5, "{:?}", s.camera.position());
}

#[test]
fn integrators_read_as_path_or_replaced_by_the_command_line() {
    let d = dir("integrators");
    let scene = d.join("scene.xml");
    let with = |integrator: &str| format!(r#"<scene version="3.0.0">{integrator}{SENSOR}<shape type="cube"/></scene>"#);
    write(&scene, &with(r#"<integrator type="volpath"><integer name="max_depth" value="7"/><integer name="rr_depth" value="3"/></integrator>"#));
    let s = load(&scene);
    assert_eq!((s.integrator.max_depth, s.integrator.rr_depth), (7, 3));
    assert!(s.notes.iter().any(|n| n.kind == NoteKind::Reading && n.message.contains("volpath")), "{:?}", s.notes);
    write(&scene, &with(r#"<integrator type="direct"><integer name="emitter_samples" value="4"/></integrator>"#));
    assert_eq!(load(&scene).integrator.max_depth, 2);
    write(&scene, &with(r#"<integrator type="aov"><string name="aovs" value="nn:sh_normal"/><integrator type="path"><integer name="max_depth" value="5"/></integrator></integrator>"#));
    let s = load(&scene);
    assert_eq!(s.integrator.max_depth, 5);
    // Its AOVs are written beside the image (tests/suite/aov.rs), not ignored.
    assert_eq!(s.integrator.aovs.channel_names().collect::<Vec<_>>(), ["nn.X", "nn.Y", "nn.Z"]);
    assert!(!s.notes.iter().any(|n| n.message.contains("aovs")), "{:?}", s.notes);
    write(&scene, &with(r#"<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>"#));
    assert!(load(&scene).integrator.hide_emitters);
    write(&scene, &with(r#"<integrator type="moment"><integrator type="path"><boolean name="hide_emitters" value="true"/></integrator></integrator>"#));
    assert!(load(&scene).integrator.hide_emitters);
    write(&scene, &with(r#"<integrator type="path"><integer name="max_depth" value="3"/></integrator>"#));
    assert!(!load(&scene).integrator.hide_emitters);
    // A research integrator: refused, naming the way out; replaced when the command line chooses.
    write(&scene, &with(r#"<integrator type="guided_path"><integer name="budget" value="30"/></integrator>"#));
    let e = error(&scene);
    assert!(e.contains("\"guided_path\"") && e.contains("--estimator"), "{e}");
    let s = Scene::load_with(&scene, &LoadOptions { replace_integrator: true, ..LoadOptions::default() }).unwrap();
    assert_eq!(s.integrator.max_depth, -1);
    assert!(s.notes.iter().any(|n| n.message.contains("replaced")), "{:?}", s.notes);
}

#[test]
fn properties_that_change_no_image_are_noted_not_refused() {
    let d = dir("ignored");
    let scene = d.join("scene.xml");
    write(
        &scene,
        r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/>
        <float name="focus_distance" value="3"/>
        <film type="hdrfilm"><string name="pixel_format" value="rgba"/><boolean name="banner" value="false"/>
        <integer name="width" value="8"/><integer name="height" value="6"/></film>
        <sampler type="stratified"><boolean name="jitter" value="False"/></sampler></sensor>
        <emitter type="constant"><float name="sampling_weight" value="2"/></emitter></scene>"#,
    );
    let s = load(&scene);
    let ignored: Vec<&str> = s.notes.iter().filter(|n| n.kind == NoteKind::Ignored).map(|n| n.message.as_str()).collect();
    for name in ["focus_distance", "pixel_format", "banner", "jitter", "sampling_weight"] {
        assert!(ignored.iter().any(|m| m.contains(name)), "{name} not noted: {ignored:?}");
    }
    // Booleans in any case, as Mitsuba reads them ("False" above); anything else is refused.
    write(&scene, r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/><sampler type="stratified"><boolean name="jitter" value="no"/></sampler></sensor></scene>"#);
    assert!(error(&scene).contains("\"no\" is not true or false"));
    write(&scene, &std::fs::read_to_string(&scene).unwrap().replace("\"no\"", "\"TRUE\""));
    load(&scene);
    // Each note names its file and line.
    assert!(s.notes.iter().all(|n| n.file == scene && n.line > 0));
    // A property that would change the image is still refused.
    write(&scene, r#"<scene version="3.0.0"><sensor type="perspective"><float name="fov" value="40"/><float name="principal_point_offset_x" value="0.1"/></sensor></scene>"#);
    assert!(error(&scene).contains("principal_point_offset_x"));
}

#[test]
fn everything_unsupported_is_reported_at_once() {
    let d = dir("unsupported");
    let scene = d.join("scene.xml");
    write(
        &scene,
        &format!(
            r#"<scene version="3.0.0">
<integrator type="guided_path"/>
{SENSOR}
<texture type="volume" id="checks"/>
<bsdf type="mixturebsdf" id="floor"/>
<shape type="bsplinecurve"/>
<shape type="cube"><bsdf type="diffuse"><float name="roughness" value="0.3"/></bsdf></shape>
<medium type="homogeneous" id="fog"/>
</scene>"#
        ),
    );
    let e = error(&scene);
    assert!(e.contains("uses 6 things caustica cannot render"), "{e}");
    for (line, phrase) in [
        (2, "integrator type \"guided_path\""),
        (6, "texture type \"volume\""),
        (7, "bsdf type \"mixturebsdf\" is not supported yet"),
        (8, "shape type \"bsplinecurve\""),
        (9, "<float name=\"roughness\">: `roughness` does not apply to bsdf type `diffuse` (its keys: reflectance)"),
        (10, "out of caustica's scope"),
    ] {
        assert!(e.contains(&format!("scene.xml:{line}: ")) && e.contains(phrase), "line {line}, {phrase:?}: {e}");
    }
    // What Mitsuba would do with each is said.
    assert!(e.contains("Mitsuba renders a weighted mixture of BSDFs"), "{e}");
    // The command line's estimator replaces the integrator: five remain.
    let e = match Scene::load_with(&scene, &LoadOptions { replace_integrator: true, ..LoadOptions::default() }) {
        Ok(_) => panic!("loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("uses 5 things") && !e.contains("guided_path"), "{e}");
    // `info` and `render` refuse with the same list, exit code 2.
    for args in [vec!["info"], vec!["render", "--spp", "1", "-q", "-o"]] {
        let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_caustica"));
        cmd.args(&args);
        if args[0] == "render" {
            cmd.arg(d.join("out.exr"));
        }
        let out = cmd.arg(&scene).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains("uses 6 things") && stderr.contains("scene.xml:10: "), "{args:?}: {stderr}");
    }
    assert!(!d.join("out.exr").exists());
}
