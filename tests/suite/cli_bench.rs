//! The `caustica bench` command as a user runs it: the built binary on the shipped bunny.

use std::path::{Path, PathBuf};
use std::process::Command;

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_caustica"))
}

fn temp_path(name: &str) -> PathBuf {
    std::env::temp_dir().join(format!("caustica-cli-bench-{}-{name}", std::process::id()))
}

#[test]
fn bench_on_the_bunny_writes_the_json_report() {
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/assets/models/bunny_lowres.obj");
    let json_path = temp_path("report.json");
    let output = bin()
        .args(["bench", "--rays", "2000", "--threads", "2", "--backends", "bvh", "--json"])
        .arg(&json_path)
        .arg(&bunny)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(output.status.success(), "{stdout}\n{}", String::from_utf8_lossy(&output.stderr));
    assert!(stdout.contains("bunny_lowres.obj") && stdout.contains("bvh"), "{stdout}");

    let text = std::fs::read_to_string(&json_path).unwrap();
    std::fs::remove_file(&json_path).unwrap();
    let report: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(report["threads"], 2);
    let inputs = report["inputs"].as_array().unwrap();
    assert_eq!(inputs.len(), 1);
    let input = &inputs[0];
    assert_eq!(input["file"], bunny.display().to_string());
    assert_eq!(input["triangles"], 3674);
    assert_eq!(input["ray_counts"]["incoherent"], 2000);
    let backends = input["backends"].as_array().unwrap();
    assert_eq!(backends.len(), 1);
    assert_eq!(backends[0]["name"], "bvh");
    assert!(backends[0]["version"].is_null());
    assert!(backends[0]["build_seconds"].as_f64().unwrap() > 0.0);
    for set in ["primary", "incoherent", "shadow"] {
        let mrays = backends[0]["mrays_per_second"][set].as_f64().unwrap();
        assert!(mrays.is_finite() && mrays > 0.0, "{set}: {mrays}");
    }
    // One backend: nothing to compare.
    assert!(input["agreement"].is_null());
    // No temporary file is left next to the report.
    let leftovers = std::fs::read_dir(std::env::temp_dir())
        .unwrap()
        .filter_map(Result::ok)
        .filter(|e| {
            e.file_name()
                .to_string_lossy()
                .starts_with(&format!(".caustica-cli-bench-{}", std::process::id()))
        })
        .count();
    assert_eq!(leftovers, 0);
}

#[test]
fn bench_on_a_missing_file_fails_and_names_it() {
    let missing = temp_path("no-such-mesh.ply");
    let output = bin().args(["bench", "--rays", "10"]).arg(&missing).output().unwrap();
    assert_eq!(output.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(
        stderr.starts_with("error: ") && stderr.contains(&missing.display().to_string()),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
}

#[test]
fn version_names_the_embree_build() {
    let output = bin().arg("--version").output().unwrap();
    assert!(output.status.success());
    let stdout = String::from_utf8_lossy(&output.stdout);
    let expected = match caustica::accel::embree_version() {
        Some(v) => format!("caustica {} (embree {v})", env!("CARGO_PKG_VERSION")),
        None => format!("caustica {} (embree: not compiled in)", env!("CARGO_PKG_VERSION")),
    };
    assert_eq!(stdout.trim(), expected);
}
