//! AOVs and denoising (issue 41, items 4 and 5): `render --aov` and Mitsuba's `<integrator type="aov">`
//! write the first hit's values as extra EXR channels named as Mitsuba names them, without changing a bit
//! of the image; `render --denoise` writes the image denoised by Open Image Denoise beside the raw one,
//! closer to the reference. Every case runs the binary as a child process.
//!
//! The denoising case needs OIDN in `build/oidn/lib` (`scripts/setup-oidn`, which `make test` runs first):
//! it is not skipped where OIDN is missing, it fails saying so.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use caustica::film::read_exr;
use caustica::report::metrics::{region_metrics, Region};

use super::common::{reference_path, repo_path};

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

/// A fresh, empty directory for one case.
fn case_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("aov").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(dir: &Path, args: &[&str]) -> Output {
    Command::new(BIN).args(args).current_dir(dir).env_remove("CAUSTICA_OIDN").output().expect("run caustica")
}

fn ok(out: &Output) {
    assert!(out.status.success(), "caustica failed: {}", String::from_utf8_lossy(&out.stderr));
}

/// Every channel of an EXR's first layer, by name.
fn channels(path: &Path) -> BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let layer = &image.layer_data[0];
    layer.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect()
}

/// `--aov` adds Mitsuba's channels (R, G, B first, as caustica writes them, then the AOVs in EXR's order)
/// with first-hit values, and R, G, B are the same bits as the render without AOVs.
#[test]
fn aov_channels_are_mitsubas_and_leave_the_image_unchanged() {
    let dir = case_dir("cli");
    let scene = repo_path("scenes/cornell-caustics.toml");
    let base = ["render", scene.to_str().unwrap(), "--width", "48", "--height", "48", "--spp", "4", "--estimator", "pt", "--threads", "2", "-q"];
    ok(&run(&dir, &[&base[..], &["-o", "plain.exr"]].concat()));
    ok(&run(&dir, &[&base[..], &["-o", "aov.exr", "--aov", "albedo,normal,depth,position,uv,nn:geo_normal,prim_index,shape_index,material_index"]].concat()));
    let (plain, aov) = (channels(&dir.join("plain.exr")), channels(&dir.join("aov.exr")));
    assert_eq!(plain.keys().collect::<Vec<_>>(), ["B", "G", "R"]);
    let names: Vec<&str> = aov.keys().map(String::as_str).collect();
    let want = [
        "B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "depth.T", "material_index.I", "nn.X", "nn.Y", "nn.Z", "normal.X", "normal.Y", "normal.Z", "position.X",
        "position.Y", "position.Z", "prim_index.I", "shape_index.I", "uv.U", "uv.V",
    ];
    assert_eq!(names, want);
    for c in ["R", "G", "B"] {
        let same = plain[c].iter().zip(&aov[c]).all(|(a, b)| a.to_bits() == b.to_bits());
        assert!(same, "channel {c} differs with AOVs");
    }
    // Pixels that see a surface have a positive distance, unit normals (means of unit vectors: at most 1
    // long), albedos in [0, 1] and indices from 1; pixels that see nothing (above the box) have 0s.
    let n = 48 * 48;
    let mut seen = 0;
    for i in 0..n {
        let depth = aov["depth.T"][i];
        assert!(depth >= 0.0 && depth.is_finite(), "depth {depth}");
        let len = |p: &str| (aov[&format!("{p}.X")][i].powi(2) + aov[&format!("{p}.Y")][i].powi(2) + aov[&format!("{p}.Z")][i].powi(2)).sqrt();
        assert!(len("normal") <= 1.0 + 1e-5 && len("nn") <= 1.0 + 1e-5);
        for c in ["R", "G", "B"] {
            assert!((0.0..=1.0).contains(&aov[&format!("albedo.{c}")][i]));
        }
        if depth == 0.0 {
            assert_eq!((len("normal"), aov["shape_index.I"][i], aov["material_index.I"][i]), (0.0, 0.0, 0.0));
        } else {
            seen += 1;
        }
    }
    assert!(seen > n * 9 / 10, "{seen} of {n} pixels see a surface");
    // Somewhere a pixel sees one surface alone: its normal is a unit vector and its shape index whole.
    let whole = (0..n).filter(|&i| aov["shape_index.I"][i] >= 1.0 && aov["shape_index.I"][i].fract() == 0.0).count();
    assert!(whole > n / 2, "{whole} of {n} pixels see one shape");
}

/// Mitsuba's `aov` integrator: its `aovs` list names the channels; the nested integrator renders the image.
#[test]
fn the_aov_integrator_of_an_xml_scene_writes_its_channels() {
    let dir = case_dir("xml");
    std::fs::write(
        dir.join("scene.xml"),
        r#"<scene version="3.0.0">
    <integrator type="aov">
        <string name="aovs" value="dd.y:depth,nn:sh_normal,albedo:albedo"/>
        <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    </integrator>
    <sensor type="perspective">
        <float name="fov" value="30"/>
        <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film>
        <sampler type="independent"><integer name="sample_count" value="2"/></sampler>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></shape>
    <emitter type="constant"/>
</scene>"#,
    )
    .unwrap();
    ok(&run(&dir, &["render", "scene.xml", "-o", "out.exr", "-q"]));
    let c = channels(&dir.join("out.exr"));
    assert_eq!(c.keys().map(String::as_str).collect::<Vec<_>>(), ["B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "dd.y.T", "nn.X", "nn.Y", "nn.Z"]);
    // The centre pixels see the unit sphere's nearest point, 3 from the camera, facing it, with its colour.
    let centre = 8 * 16 + 8;
    assert!((c["dd.y.T"][centre] - 3.0).abs() < 0.02, "depth {}", c["dd.y.T"][centre]);
    assert!(c["nn.Z"][centre] > 0.99, "normal z {}", c["nn.Z"][centre]);
    assert_eq!([c["albedo.R"][centre], c["albedo.G"][centre], c["albedo.B"][centre]], [0.2, 0.4, 0.6]);
    // A corner sees the sky: 0 in every AOV.
    assert_eq!((c["dd.y.T"][0], c["nn.Z"][0], c["albedo.G"][0]), (0.0, 0.0, 0.0));
}

/// `--denoise` on cornell-caustics at 16 spp: the denoised image is closer to the 9,984-spp reference than
/// the raw one, which is kept as it is without `--denoise`.
#[test]
fn denoising_brings_a_noisy_render_closer_to_the_reference() {
    let dir = case_dir("denoise");
    let scene = repo_path("scenes/cornell-caustics.toml");
    let out = run(&dir, &["render", scene.to_str().unwrap(), "--spp", "16", "--estimator", "pt", "-o", "c.exr", "--denoise", "-q"]);
    ok(&out);
    let reference = read_exr(reference_path()).unwrap();
    let rmse = |name: &str| {
        let image = read_exr(dir.join(name)).unwrap();
        region_metrics(&image, &reference, &Region::whole(image.width(), image.height()), 16).unwrap().rmse
    };
    let (raw, denoised) = (rmse("c.exr"), rmse("c.denoised.exr"));
    eprintln!("cornell-caustics 16 spp: RMSE raw {raw:.4}, denoised {denoised:.4}");
    assert!(denoised < 0.8 * raw, "denoised RMSE {denoised} not below 0.8 × raw {raw}");
    // The raw image has the albedo and normal AOVs the denoiser read.
    assert!(channels(&dir.join("c.exr")).contains_key("sh_normal.X"));
}

/// Without OIDN, `--denoise` is refused before anything is rendered, saying what to install (exit 2); a
/// part cannot keep AOV channels, and says so.
#[test]
fn denoise_without_oidn_and_aovs_of_a_part_are_clear_errors() {
    let dir = case_dir("errors");
    let scene = repo_path("scenes/cornell-caustics.toml");
    let out = run(&dir, &["render", scene.to_str().unwrap(), "--spp", "100000", "--denoise", "--oidn", "/nonexistent/oidn", "-o", "c.exr"]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("/nonexistent/oidn") && err.contains("scripts/setup-oidn"), "{err}");
    assert!(!dir.join("c.exr").exists());
    let out = run(&dir, &["render", scene.to_str().unwrap(), "--spp", "4", "--part", "0/2", "--aov", "depth"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("not kept in partial films"));
    let out = run(&dir, &["render", scene.to_str().unwrap(), "--aov", "d:dp_du"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("texture coordinates"));
}
