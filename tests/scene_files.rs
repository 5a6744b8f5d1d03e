//! Scene files: the shipped scenes load, the Cornell box is exactly the reference's numbers, hits become
//! interactions correctly, and every kind of bad input is an error that names the file and the key.

use std::path::{Path, PathBuf};

use caustica::accel::brute::BruteForce;
use caustica::accel::{Accel, Hit};
use caustica::bsdf::Bsdf;
use caustica::light::Light;
use caustica::math::{Ray, Vec3};
use caustica::scene::{Estimator, Scene, SceneError};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes")
}

fn cornell() -> Scene {
    Scene::load(&scenes_dir().join("cornell-caustics.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Triangles `2i` and `2i+1` of the Cornell soup are rectangle `i`.
fn rect_tris(scene: &Scene, i: usize) -> [[Vec3; 3]; 2] {
    [scene.mesh.triangle(2 * i), scene.mesh.triangle(2 * i + 1)]
}

fn ng_of(t: [Vec3; 3]) -> Vec3 {
    (t[1] - t[0]).cross(t[2] - t[0]).normalize()
}

#[test]
fn cornell_matches_the_reference_numbers() {
    let s = cornell();
    // Six rectangles and two spheres of the default tessellation.
    let sphere_tris = 2 * caustica::scene::SPHERE_SEGMENTS as usize * (caustica::scene::SPHERE_RINGS as usize - 1);
    assert_eq!(s.triangle_count(), 12 + 2 * sphere_tris);
    assert_eq!(s.tri_material.len(), s.triangle_count());
    assert_eq!(s.tri_flat.len(), s.triangle_count());
    assert_eq!(s.mesh.normals.as_ref().map(Vec::len), Some(s.mesh.positions.len()));
    // (walls: plane coordinate, expected inward normal, reflectance)
    let white = Vec3::splat(0.8);
    let walls = [
        (Vec3::Y, -1.0, Vec3::Y, white),                    // floor: rotate(x,-90°) then translate(0,-1,0)
        (Vec3::Y, 1.0, -Vec3::Y, white),                    // ceiling
        (Vec3::Z, -1.0, Vec3::Z, white),                    // back
        (Vec3::X, -1.0, Vec3::X, Vec3::new(0.8, 0.1, 0.1)), // left, red
        (Vec3::X, 1.0, -Vec3::X, Vec3::new(0.1, 0.8, 0.1)), // right, green
    ];
    for (i, (axis, coord, normal, refl)) in walls.into_iter().enumerate() {
        let mut corners = Vec::new();
        for (k, t) in rect_tris(&s, i).into_iter().enumerate() {
            assert!(ng_of(t).abs_diff_eq(normal, 1e-6), "wall {i}: normal {}", ng_of(t));
            for p in t {
                assert!((p.dot(axis) - coord).abs() < 1e-6, "wall {i}: {p}");
                assert!((p - axis * p.dot(axis)).abs().max_element() <= 1.0 + 1e-6);
                corners.push(p);
            }
            assert!(s.tri_flat[2 * i + k]);
            assert_eq!(s.bsdfs[s.tri_material[2 * i + k] as usize], Bsdf::Diffuse { reflectance: refl });
        }
        // The wall spans the full [-1,1]² square.
        let area: f32 = rect_tris(&s, i)
            .iter()
            .map(|t| 0.5 * (t[1] - t[0]).cross(t[2] - t[0]).length())
            .sum();
        assert!((area - 4.0).abs() < 1e-5, "wall {i}: area {area}");
    }
    // Light: scale(0.25,0.25,1), rotate(x,90°), translate(0,0.99,0): 0.5×0.5 at y = 0.99 facing down.
    for t in rect_tris(&s, 5) {
        assert!(ng_of(t).abs_diff_eq(-Vec3::Y, 1e-6));
        for p in t {
            assert!(
                (p.y - 0.99).abs() < 1e-6 && (p.x.abs() - 0.25).abs() < 1e-6 && (p.z.abs() - 0.25).abs() < 1e-6,
                "{p}"
            );
        }
    }
    assert_eq!(s.bsdfs[s.tri_material[10] as usize], Bsdf::Diffuse { reflectance: Vec3::ZERO });
    assert_eq!(s.lights.lights().len(), 1);
    match &s.lights.lights()[0] {
        Light::Area(a) => {
            assert_eq!(a.radiance(), Vec3::splat(15.0));
            assert!((a.area() - 0.25).abs() < 1e-6);
        }
        _ => panic!("the Cornell light must be an area light"),
    }
    assert_eq!(s.lights.light_of_prim(10), Some(0));
    assert_eq!(s.lights.light_of_prim(11), Some(0));
    assert_eq!(s.lights.light_of_prim(0), None);
    // Spheres: mirror then glass, smooth, every vertex at the right distance from its centre.
    let mirror = 12;
    let glass = 12 + sphere_tris;
    assert_eq!(
        s.bsdfs[s.tri_material[mirror] as usize],
        Bsdf::Conductor {
            specular_reflectance: Vec3::ONE,
            eta_k: None
        }
    );
    assert_eq!(s.bsdfs[s.tri_material[glass] as usize], Bsdf::Dielectric { eta: 1.5 });
    assert!(!s.tri_flat[mirror] && !s.tri_flat[glass]);
    for (first, c, r) in [
        (mirror, Vec3::new(-0.45, -0.65, -0.3), 0.35f32),
        (glass, Vec3::new(0.4, -0.35, 0.25), 0.3),
    ] {
        for i in first..first + sphere_tris {
            let t = s.mesh.triangle(i);
            for p in t {
                assert!(((p - c).length() - r).abs() < 1e-5);
            }
            assert!(
                ng_of(t).dot((t[0] + t[1] + t[2]) / 3.0 - c) > 0.0,
                "sphere triangle {i} faces inward"
            );
        }
    }
    assert_eq!(s.bsdfs.len(), 6);
    assert!(s.has_delta_bsdf());
    assert_eq!((s.camera.width(), s.camera.height(), s.camera.crop()), (256, 256, (0, 0, 256, 256)));
    assert_eq!(s.integrator.samples_per_pixel, 64);
    assert_eq!(s.integrator.max_depth, -1);
    assert_eq!(s.integrator.caustics.estimator, Estimator::Pt);
    assert!(s.bounds.min.abs_diff_eq(Vec3::splat(-1.0), 1e-6) && s.bounds.max.abs_diff_eq(Vec3::splat(1.0), 1e-6));
}

#[test]
fn interactions_from_hits() {
    let s = cornell();
    let accel = BruteForce::new(&s.mesh.positions, &s.mesh.indices);
    // The centre pixel sees the back wall straight on.
    let ray = s.camera.generate_ray(128.0, 128.0);
    let hit = accel.intersect(&ray).expect("centre ray hits");
    let si = s.interaction(&ray, &hit);
    assert!(si.p.abs_diff_eq(Vec3::new(0.0, 0.0, -1.0), 1e-5), "{}", si.p);
    assert!(si.ng.abs_diff_eq(Vec3::Z, 1e-6) && si.ns == si.ng && si.frame.n == si.ns);
    assert!(si.p_error.max_element() > 0.0 && si.p_error.max_element() < 1e-5);
    assert_eq!(si.prim / 2, 2);
    assert_eq!(
        s.bsdfs[si.material as usize],
        Bsdf::Diffuse {
            reflectance: Vec3::splat(0.8)
        }
    );

    // Rays at the glass sphere from the camera: smooth normal close to the exact sphere normal; a reflected
    // ray and a refracted (inward) ray spawned from the hit do not hit the same triangle again.
    let c = Vec3::new(0.4, -0.35, 0.25);
    let mut hits = 0;
    for k in 0..50 {
        let jitter = Vec3::new((k % 7) as f32 * 0.03 - 0.09, (k / 7) as f32 * 0.03 - 0.09, 0.0);
        let ray = Ray::new(s.camera.position(), (c + jitter - s.camera.position()).normalize());
        let Some(hit) = accel.intersect(&ray) else { continue };
        let si = s.interaction(&ray, &hit);
        let exact = (si.p - c).normalize();
        assert!(si.ns.dot(exact) > 1.0 - 1e-6, "ns {} vs exact {exact}", si.ns);
        assert!(si.ng.dot(exact) > 0.999 && si.ns.dot(si.ng) > 0.0);
        assert!(((si.p - c).length() - 0.3).abs() < 0.3 * 3.1e-4);
        let reflected = ray.dir - 2.0 * ray.dir.dot(si.ns) * si.ns;
        if let Some(h2) = accel.intersect(&si.spawn_ray(reflected)) {
            assert_ne!(h2.prim, si.prim);
        }
        let inward = si.spawn_ray(-si.ns);
        let h2 = accel.intersect(&inward).expect("a ray into a closed sphere hits its far side");
        assert_ne!(h2.prim, si.prim);
        assert!(h2.t > 0.5, "far side at t = {}", h2.t);
        hits += 1;
    }
    assert!(hits > 40);

    // Shadow rays: a floor point sees the light's centre; the ceiling behind the light is occluded by it.
    let floor_ray = Ray::new(Vec3::new(0.0, 0.5, 0.8), -Vec3::Y);
    let hit = accel.intersect(&floor_ray).unwrap();
    let si = s.interaction(&floor_ray, &hit);
    assert!(
        (si.p.y + 1.0).abs() < 1e-6 && si.ng.abs_diff_eq(Vec3::Y, 1e-6),
        "{} {}",
        si.p,
        si.ng
    );
    let light_centre = Vec3::new(0.0, 0.99, 0.0);
    let shadow = si.spawn_ray_to(light_centre);
    assert!(shadow.at(1.0).abs_diff_eq(light_centre, 1e-6));
    assert!(!accel.occluded(&shadow));
    assert!(accel.occluded(&si.spawn_ray_to(Vec3::new(0.0, 1.0, 0.0))));
}

/// The test directory for files a test writes.
fn tmp_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const TETRA_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

fn minimal(rest: &str) -> String {
    format!("[sensor]\nfov = 40\nfilm = {{ width = 8, height = 6 }}\n{rest}")
}

#[test]
fn mesh_normals_transforms_and_orientation() {
    let dir = tmp_dir("scene_mesh");
    std::fs::write(dir.join("tetra.obj"), TETRA_OBJ).unwrap();
    let load = |rest: &str| Scene::from_toml_str(&minimal(rest), &dir, Path::new("t.toml")).unwrap_or_else(|e| panic!("{e}"));
    // Outward-wound tetrahedron without normals: smooth vertex normals are computed and point outward.
    let check_outward = |s: &Scene, sign: f32| {
        let n = s.mesh.normals.as_ref().unwrap();
        let centroid = s.mesh.positions.iter().sum::<Vec3>() / s.mesh.positions.len() as f32;
        for (i, t) in s.mesh.indices.iter().enumerate() {
            let tri = s.mesh.triangle(i);
            let c = (tri[0] + tri[1] + tri[2]) / 3.0;
            let ng = ng_of(tri);
            assert!(sign * ng.dot(c - centroid) > 0.0, "triangle {i} orientation");
            for &k in t {
                assert!(n[k as usize].dot(ng) > 0.0, "vertex normal on the other side of ng");
                assert!((n[k as usize].length() - 1.0).abs() < 1e-5);
            }
        }
    };
    let s = load("[[shape]]\ntype = \"obj\"\nfilename = \"tetra.obj\"\n");
    assert_eq!(s.triangle_count(), 4);
    assert!(s.tri_flat.iter().all(|f| !f));
    check_outward(&s, 1.0);
    // A mirroring transform (negative determinant) keeps ng and the normals together and outward.
    let s = load("[[shape]]\ntype = \"obj\"\nfilename = \"tetra.obj\"\nto_world = [ { scale = [-1, 2, 1] }, { translate = [3, 0, 0] } ]\n");
    assert!(s.mesh.positions.iter().any(|p| (p.x - 2.0).abs() < 1e-6));
    check_outward(&s, 1.0);
    // flip_normals turns the shape inside out.
    let s = load("[[shape]]\ntype = \"obj\"\nfilename = \"tetra.obj\"\nflip_normals = true\n");
    check_outward(&s, -1.0);
    // face_normals: flat; the interaction's ns is then ng.
    let s = load("[[shape]]\ntype = \"obj\"\nfilename = \"tetra.obj\"\nface_normals = true\n");
    assert!(s.tri_flat.iter().all(|&f| f));
    let ray = Ray::new(Vec3::new(0.2, 0.2, 5.0), -Vec3::Z);
    let accel = BruteForce::new(&s.mesh.positions, &s.mesh.indices);
    let si = s.interaction(&ray, &accel.intersect(&ray).unwrap());
    assert_eq!(si.ns, si.ng);
    // The same hit on the smooth mesh: ns differs from ng but stays in its hemisphere.
    let s = load("[[shape]]\ntype = \"obj\"\nfilename = \"tetra.obj\"\n");
    let si = s.interaction(&ray, &accel.intersect(&ray).unwrap());
    assert!(si.ns.dot(si.ng) > 0.0 && si.ns.dot(si.ng) < 0.999);
    // A rotated sphere: normals rotate with it (inverse transpose of a rotation = the rotation).
    let s = load("[[shape]]\ntype = \"sphere\"\nrings = 8\nsegments = 16\nto_world = [ { scale = [1, 2, 1] }, { rotate = { axis = [0, 0, 1], angle = 90 } } ]\n");
    let n = s.mesh.normals.as_ref().unwrap();
    for (p, n) in s.mesh.positions.iter().zip(n) {
        // Ellipsoid x²/4 + y² + z² = 1 (the long axis now along x): normal ∝ (x/4, y, z).
        let expect = Vec3::new(p.x / 4.0, p.y, p.z).normalize();
        assert!(n.dot(expect) > 1.0 - 1e-5, "{n} vs {expect}");
    }
}

#[test]
fn degenerate_hits_do_not_panic() {
    let dir = tmp_dir("scene_degenerate");
    std::fs::write(dir.join("flat.obj"), "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 4\n").unwrap();
    let s = Scene::from_toml_str(
        &minimal("[[shape]]\ntype = \"obj\"\nfilename = \"flat.obj\"\n"),
        &dir,
        Path::new("t.toml"),
    )
    .unwrap();
    let ray = Ray::new(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
    let si = s.interaction(
        &ray,
        &Hit {
            t: 1.0,
            prim: 0,
            u: 0.25,
            v: 0.25,
        },
    );
    assert!(si.ng.is_finite() && si.ns.is_finite() && (si.ng.length() - 1.0).abs() < 1e-6);
    assert!(si.ng.dot(ray.dir) < 0.0);
}

#[test]
fn shipped_scenes_load_or_miss_only_assets_of_other_branches() {
    for name in ["cornell-caustics.toml", "teapot-glossy.toml", "envmap-glass.toml"] {
        let path = scenes_dir().join(name);
        match Scene::load(&path) {
            Ok(s) => assert!(s.triangle_count() > 0 && !s.lights.is_empty(), "{name}"),
            // Missing-file errors come only after every other key was checked (build.rs, phase 2); the assets
            // (teapot, env map) are copied into scenes/assets/ on another branch.
            Err(SceneError::MissingFile { missing, .. }) if name != "cornell-caustics.toml" => {
                assert!(
                    missing.starts_with(scenes_dir().join("assets")) && !missing.exists(),
                    "{name}: {}",
                    missing.display()
                );
            }
            Err(e) => panic!("{name}: {e}"),
        }
    }
}

/// Loads `text` (named `bad.toml`) and returns the error message, which must name the file and `key`.
fn error_of(text: &str, key: &str) -> String {
    let dir = tmp_dir("scene_bad");
    let err = match Scene::from_toml_str(text, &dir, Path::new("bad.toml")) {
        Ok(_) => panic!("accepted:\n{text}"),
        Err(e) => e,
    };
    let msg = err.to_string();
    assert!(msg.starts_with("bad.toml"), "no file name: {msg}");
    assert_eq!(err.key(), Some(key), "{msg}");
    assert!(
        msg.contains(
            &format!(": {} ", if key.is_empty() { "(top level)" } else { key })
                .trim_end()
                .to_string()
        ),
        "{msg}"
    );
    msg
}

fn shape_with(kv: &str) -> String {
    minimal(&format!("[[shape]]\ntype = \"rectangle\"\n{kv}\n"))
}

#[test]
fn bad_keys_and_types_name_the_key() {
    let cases: &[(String, &str, &str)] = &[
        ("colour = 1\n[sensor]\nfov = 40".into(), "colour", "unknown field `colour`"),
        (minimal("colour = 1"), "sensor.colour", "unknown field `colour`"),
        (
            minimal("[[shape]]\ntype = \"cube\"\n[[shape]]\ntype = \"cube\"\ncolour = 1"),
            "shape[1].colour",
            "unknown field `colour`",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", roughness = 0.1 }"),
            "shape[0].bsdf.roughness",
            "unknown field `roughness`",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", alpha = 0.1 }"),
            "shape[0].bsdf.alpha",
            "does not apply to bsdf type `diffuse`",
        ),
        (
            shape_with("radius = 2"),
            "shape[0].radius",
            "does not apply to shape type `rectangle`",
        ),
        (minimal("[[shape]]\ntype = \"torus\""), "shape[0].type", "unknown variant `torus`"),
        ("[sensor]\nfov = \"wide\"".into(), "sensor.fov", "invalid type"),
        (
            "[sensor]\nfov = 40\nfilm.width = \"big\"".into(),
            "sensor.film.width",
            "invalid type",
        ),
        ("[sensor]\nfov = 40\nfilm = { width = -3 }".into(), "sensor.film.width", "-3"),
        (
            shape_with("to_world = [ { scale = 2 }, { translate = [0, \"a\", 0] } ]"),
            "shape[0].to_world[1].translate[1]",
            "invalid type",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", reflectance = \"red\" }"),
            "shape[0].bsdf.reflectance",
            "invalid type",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5] }"),
            "shape[0].bsdf.reflectance",
            "invalid length 2",
        ),
        ("[integrator]\nsamples_per_pixel = 4".into(), "", "missing field `sensor`"),
        ("[sensor]\nfilm = { width = 4, height = 4 }".into(), "sensor", "missing field `fov`"),
        (shape_with("bsdf = { reflectance = 0.5 }"), "shape[0].bsdf", "missing field `type`"),
        (
            minimal("[bsdf.a]\ntype = \"blendbsdf\"\nbsdf_0 = \"a\"\nbsdf_1 = { type = \"diffuse\" }\nweight = \"half\""),
            "bsdf.a.weight",
            "invalid type",
        ),
        (
            shape_with("to_world = [ { translate = [1, 0, 0], rotate = { axis = [0, 1, 0], angle = 3 } } ]"),
            "shape[0].to_world[0]",
            "exactly one of",
        ),
        (
            shape_with("to_world = { rotate = { axis = [0, 0, 0], angle = 3 } }"),
            "shape[0].to_world.rotate.axis",
            "zero vector",
        ),
        (shape_with("to_world = { scale = [1, 0, 1] }"), "shape[0].to_world", "singular"),
        (
            shape_with("to_world = { matrix = [1, 0, 0] }"),
            "shape[0].to_world.matrix",
            "16 numbers",
        ),
        (
            shape_with("emitter = { type = \"area\" }"),
            "shape[0].emitter",
            "missing field `radiance`",
        ),
        (
            minimal("[[emitter]]\ntype = \"envmap\"\nradiance = 2\nfilename = \"x.exr\""),
            "emitter[0].radiance",
            "does not apply to emitter type `envmap`",
        ),
    ];
    for (text, key, phrase) in cases {
        let msg = error_of(text, key);
        assert!(msg.contains(phrase), "expected {phrase:?} in: {msg}");
    }
}

#[test]
fn bad_values_name_the_key() {
    let cases: &[(String, &str, &str)] = &[
        (
            shape_with("bsdf = { type = \"diffuse\", reflectance = nan }"),
            "shape[0].bsdf.reflectance",
            "NaN",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", reflectance = [0.5, -0.1, 0.5] }"),
            "shape[0].bsdf.reflectance",
            "negative",
        ),
        (
            shape_with("bsdf = { type = \"diffuse\", reflectance = [0.5, 0.5, 1.2] }"),
            "shape[0].bsdf.reflectance",
            "> 1",
        ),
        (
            shape_with("bsdf = { type = \"conductor\", specular_reflectance = 1.01 }"),
            "shape[0].bsdf.specular_reflectance",
            "> 1",
        ),
        (
            shape_with("emitter = { type = \"area\", radiance = [1, inf, 1] }"),
            "shape[0].emitter.radiance",
            "infinite",
        ),
        (
            shape_with("emitter = { type = \"area\", radiance = -1 }"),
            "shape[0].emitter.radiance",
            "negative",
        ),
        (
            shape_with("emitter = { type = \"area\", radiance = [1, 1, nan] }"),
            "shape[0].emitter.radiance",
            "NaN",
        ),
        (
            minimal("[[emitter]]\ntype = \"constant\"\nradiance = -0.5"),
            "emitter[0].radiance",
            "negative",
        ),
        (
            shape_with("bsdf = { type = \"roughconductor\", alpha = 0 }"),
            "shape[0].bsdf.alpha",
            "must be > 0",
        ),
        (
            shape_with("bsdf = { type = \"roughconductor\", alpha = -0.2 }"),
            "shape[0].bsdf.alpha",
            "must be > 0",
        ),
        (
            shape_with("bsdf = { type = \"roughconductor\", distribution = \"beckmann\" }"),
            "shape[0].bsdf.distribution",
            "ggx",
        ),
        (
            shape_with("bsdf = { type = \"dielectric\", int_ior = 0 }"),
            "shape[0].bsdf.int_ior",
            "must be > 0",
        ),
        (
            shape_with("bsdf = { type = \"dielectric\", ext_ior = -1.3 }"),
            "shape[0].bsdf.ext_ior",
            "must be > 0",
        ),
        (
            shape_with("bsdf = { type = \"dielectric\", ext_ior = \"unobtainium\" }"),
            "shape[0].bsdf.ext_ior",
            "unknown IOR name",
        ),
        (
            shape_with("bsdf = { type = \"conductor\", eta = 0.2 }"),
            "shape[0].bsdf.eta",
            "both `eta` and `k`",
        ),
        (
            shape_with("bsdf = { type = \"conductor\", eta = [0.2, 0, 1], k = 3 }"),
            "shape[0].bsdf.eta",
            "> 0",
        ),
        (
            shape_with("bsdf = { type = \"blendbsdf\", weight = 1.5, bsdf_0 = { type = \"diffuse\" }, bsdf_1 = { type = \"diffuse\" } }"),
            "shape[0].bsdf.weight",
            "[0, 1]",
        ),
        (
            shape_with("bsdf = { type = \"blendbsdf\", bsdf_0 = { type = \"diffuse\" } }"),
            "shape[0].bsdf",
            "`bsdf_1` is missing",
        ),
        (
            "[sensor]\nfov = 40\nfilm = { width = 0, height = 4 }".into(),
            "sensor.film.width",
            "at least 1×1",
        ),
        (
            "[sensor]\nfov = 40\nfilm = { width = 4, height = 0 }".into(),
            "sensor.film.height",
            "at least 1×1",
        ),
        (
            "[sensor]\nfov = 40\nfilm = { width = 100000, height = 100000 }".into(),
            "sensor.film",
            "too large",
        ),
        ("[sensor]\nfov = 0\n".into(), "sensor.fov", "(0, 180)"),
        ("[sensor]\nfov = 180\n".into(), "sensor.fov", "(0, 180)"),
        ("[sensor]\nfov = -20\n".into(), "sensor.fov", "(0, 180)"),
        ("[sensor]\nfov = nan\n".into(), "sensor.fov", "(0, 180)"),
        (
            "[sensor]\nfov = 40\nfilm = { width = 4, height = 4, crop = [0, 0, 5, 4] }".into(),
            "sensor.film.crop",
            "crop window",
        ),
        (
            "[sensor]\nfov = 40\nto_world = { look_at = { origin = [0, 0, 1], target = [0, 0, 1], up = [0, 1, 0] } }".into(),
            "sensor.to_world.look_at",
            "degenerate",
        ),
        (
            "[sensor]\nfov = 40\nto_world = { look_at = { origin = [0, 0, 1], target = [0, 0, 0], up = [0, 0, 1] } }".into(),
            "sensor.to_world.look_at",
            "parallel",
        ),
        (minimal("[integrator]\nmax_depth = -2"), "integrator.max_depth", "-1 (unlimited)"),
        (
            minimal("[integrator]\nsamples_per_pixel = 0"),
            "integrator.samples_per_pixel",
            "≥ 1",
        ),
        (
            minimal("[integrator.caustics]\nestimator = \"vcm\""),
            "integrator.caustics.estimator",
            "unknown variant `vcm`",
        ),
        (minimal("[integrator.caustics]\nknn = 0"), "integrator.caustics.knn", "≥ 1"),
        (
            minimal("[integrator.caustics]\nmax_radius = 0"),
            "integrator.caustics.max_radius",
            "> 0",
        ),
        (minimal("[[shape]]\ntype = \"sphere\"\nradius = -1"), "shape[0].radius", "> 0"),
        (
            minimal("[[shape]]\ntype = \"sphere\"\ncenter = [0, inf, 0]"),
            "shape[0].center",
            "infinite",
        ),
        (minimal("[[shape]]\ntype = \"sphere\"\nrings = 1"), "shape[0].rings", "at least 2"),
        (
            minimal("[[shape]]\ntype = \"sphere\"\nrings = 100000\nsegments = 100000"),
            "shape[0]",
            "2^26",
        ),
        (minimal("[[shape]]\ntype = \"obj\""), "shape[0]", "needs `filename`"),
        (
            minimal("[[shape]]\ntype = \"obj\"\nfilename = \"a.ply\""),
            "shape[0].filename",
            ".obj file",
        ),
        (
            shape_with(
                "to_world = { translate = [1e30, 0, 0] }\n[[shape]]\ntype = \"cube\"\nto_world = [ { scale = 1e30 }, { scale = 1e30 } ]",
            ),
            "shape[1].to_world",
            "not finite",
        ),
    ];
    for (text, key, phrase) in cases {
        let msg = error_of(text, key);
        assert!(msg.contains(phrase), "expected {phrase:?} in: {msg}");
    }
}

#[test]
fn references_files_and_syntax() {
    // Unknown material names, in a shape and inside a named blend; reference cycles.
    let msg = error_of(&shape_with("bsdf = \"gold\"\n[bsdf.white]\ntype = \"diffuse\""), "shape[0].bsdf");
    assert!(msg.contains("unknown bsdf `gold`") && msg.contains("defined: white"), "{msg}");
    let msg = error_of(
        &minimal("[bsdf.floor]\ntype = \"blendbsdf\"\nbsdf_0 = { type = \"diffuse\" }\nbsdf_1 = \"glossy\""),
        "bsdf.floor.bsdf_1",
    );
    assert!(msg.contains("unknown bsdf `glossy`") && msg.contains("defined: floor"), "{msg}");
    let text = minimal(
        "[bsdf.a]\ntype = \"blendbsdf\"\nbsdf_0 = \"b\"\nbsdf_1 = { type = \"diffuse\" }\n[bsdf.b]\ntype = \"blendbsdf\"\nbsdf_0 = { type = \"diffuse\" }\nbsdf_1 = \"a\"",
    );
    let msg = error_of(&text, "bsdf.b.bsdf_1");
    let msg2 = error_of(&shape_with("bsdf = \"gold\""), "shape[0].bsdf");
    assert!(msg2.contains("none are defined"), "{msg2}");
    assert!(msg.contains("cycle: a → b → a"), "{msg}");

    // A long chain of named blends is cut off instead of overflowing the stack.
    let mut chain = String::new();
    for i in 0..200 {
        chain += &format!(
            "[bsdf.b{i}]\ntype = \"blendbsdf\"\nbsdf_0 = \"b{}\"\nbsdf_1 = {{ type = \"diffuse\" }}\n",
            i + 1
        );
    }
    chain += "[bsdf.b200]\ntype = \"diffuse\"\n";
    let err = Scene::from_toml_str(&minimal(&chain), Path::new("."), Path::new("bad.toml"))
        .err()
        .unwrap();
    assert!(err.to_string().contains("deeper than 64"), "{err}");

    // Missing files: meshes and environment maps, after every other check.
    let msg = error_of(
        &minimal("[[shape]]\ntype = \"obj\"\nfilename = \"nope/teapot.obj\""),
        "shape[0].filename",
    );
    assert!(msg.contains("file not found") && msg.contains("nope/teapot.obj"), "{msg}");
    let msg = error_of(
        &minimal("[[emitter]]\ntype = \"envmap\"\nfilename = \"sky.exr\""),
        "emitter[0].filename",
    );
    assert!(msg.contains("file not found") && msg.contains("sky.exr"), "{msg}");
    let msg = error_of(
        &minimal("[[shape]]\ntype = \"obj\"\nfilename = \"nope.obj\"\nbsdf = { type = \"diffuse\", reflectance = 2 }"),
        "shape[0].bsdf.reflectance",
    );
    assert!(msg.contains("> 1"), "value errors come before missing files: {msg}");
    // A file that exists but is not a mesh.
    let dir = tmp_dir("scene_bad");
    std::fs::write(dir.join("garbage.obj"), "this is not an obj file\nf 1 2 3\n").unwrap();
    let msg = error_of(
        &minimal("[[shape]]\ntype = \"obj\"\nfilename = \"garbage.obj\""),
        "shape[0].filename",
    );
    assert!(msg.contains("cannot load"), "{msg}");

    // Syntax errors carry line and column; key errors carry the line of the key.
    let err = Scene::from_toml_str(
        "[sensor]\nfov = 40\nfilm = { width = 4,, }\n",
        Path::new("."),
        Path::new("bad.toml"),
    )
    .err()
    .unwrap();
    assert!(matches!(err, SceneError::Syntax { line: 3, .. }), "{err}");
    assert!(err.to_string().starts_with("bad.toml:3:"), "{err}");
    let err = Scene::from_toml_str(
        "[sensor]\nfov = 40\n\n[[shape]]\ntype = \"cube\"\nbsdf = { type = \"diffuse\", reflectance = 3 }\n",
        Path::new("."),
        Path::new("bad.toml"),
    )
    .err()
    .unwrap();
    assert!(err.to_string().starts_with("bad.toml:6: shape[0].bsdf.reflectance: "), "{err}");
    let err = Scene::from_toml_str(
        "[sensor]\nfov = 40\nfilm = { width = 4, heigth = 3 }\n",
        Path::new("."),
        Path::new("bad.toml"),
    )
    .err()
    .unwrap();
    assert!(
        err.to_string()
            .starts_with("bad.toml:3: sensor.film.heigth: unknown field `heigth`"),
        "{err}"
    );
    // An unreadable scene file.
    let err = Scene::load(Path::new("/nonexistent/dir/scene.toml")).err().unwrap();
    assert!(
        matches!(err, SceneError::Read { .. }) && err.to_string().contains("/nonexistent/dir/scene.toml"),
        "{err}"
    );
}

#[test]
fn mangled_files_never_panic() {
    // Every prefix (by line) and every single-line deletion of a valid scene either loads or is an error.
    let text = std::fs::read_to_string(scenes_dir().join("cornell-caustics.toml"))
        .unwrap()
        .replace("radius = 0.3", "radius = 0.3\nrings = 4\nsegments = 6");
    let text = text.replace("radius = 0.35", "radius = 0.35\nrings = 4\nsegments = 6");
    let lines: Vec<&str> = text.lines().collect();
    let dir = tmp_dir("scene_bad");
    let mut errors = 0;
    for i in 0..lines.len() {
        let prefix = lines[..i].join("\n");
        let deleted = [&lines[..i], &lines[i + 1..]].concat().join("\n");
        for t in [prefix, deleted] {
            if let Err(e) = Scene::from_toml_str(&t, &dir, Path::new("m.toml")) {
                assert!(e.to_string().starts_with("m.toml"));
                errors += 1;
            }
        }
    }
    // Byte-level truncations (mid-token).
    for cut in (0..text.len()).step_by(7).filter(|&c| text.is_char_boundary(c)) {
        if Scene::from_toml_str(&text[..cut], &dir, Path::new("m.toml")).is_err() {
            errors += 1;
        }
    }
    assert!(errors > 50);
}
