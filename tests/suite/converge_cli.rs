//! `caustica converge` and `caustica render --reference --error-log` end to end on a tiny render of
//! scenes/cornell-caustics.toml (32×32), plus the time-to-error interpolation.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use caustica::report::converge::time_to_error;

const BIN: &str = env!("CARGO_BIN_EXE_caustica");

fn scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell-caustics.toml")
}

fn test_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("caustica-converge-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn run(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().expect("runs caustica")
}

/// A 32×32 reference with a seed none of the tests uses.
fn reference(dir: &Path) -> PathBuf {
    let r = dir.join("ref.exr");
    let out = run(&["render", scene().to_str().unwrap(), "--width", "32", "--height", "32", "--spp", "64", "--seed", "999", "-q", "-o", r.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    r
}

/// Parses a CSV file into its header and rows.
fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines.next().unwrap().split(',').map(str::to_owned).collect::<Vec<_>>();
    let rows = lines.map(|l| l.split(',').map(str::to_owned).collect::<Vec<_>>()).collect();
    (header, rows)
}

#[test]
fn converge_writes_monotone_errors_plots_and_images() {
    let dir = test_dir("converge");
    let r = reference(&dir);
    let out_dir = dir.join("out");
    let out = run(&[
        "converge",
        scene().to_str().unwrap(),
        "--reference",
        r.to_str().unwrap(),
        "--width",
        "32",
        "--height",
        "32",
        "--time-budget",
        "0.4",
        "--pass-spp",
        "2",
        "--photons",
        "20000",
        "--region",
        "caustic=62%,86%,80%,94%",
        "-q",
        "-o",
        out_dir.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("time to reach a rmse"), "{stdout}");

    let (header, rows) = read_csv(&out_dir.join("errors.csv"));
    assert_eq!(header[..8], ["estimator", "pass", "seconds", "spp", "photons_emitted", "photons_stored", "rmse", "relmse"]);
    assert!(header.contains(&"caustic_rmse".to_string()));
    for est in ["pt", "pm", "mis"] {
        let mine: Vec<&Vec<String>> = rows.iter().filter(|r| r[0] == est).collect();
        assert!(!mine.is_empty(), "no rows for {est}");
        let times: Vec<f64> = mine.iter().map(|r| r[2].parse().unwrap()).collect();
        assert!(times.windows(2).all(|w| w[1] > w[0]), "{est}: time not increasing: {times:?}");
        let spp: Vec<u32> = mine.iter().map(|r| r[3].parse().unwrap()).collect();
        // Whole passes of 2 spp; the last pass may be cut at the budget (its samples cover only some
        // pixels and are not counted in spp).
        let steps: Vec<u32> = spp.windows(2).map(|w| w[1] - w[0]).collect();
        let (last, whole) = steps.split_last().map_or((2, &[][..]), |(l, w)| (*l, w));
        assert!(spp[0] == 2 && whole.iter().all(|&d| d == 2) && (last == 2 || last == 0), "{est}: spp {spp:?}");
        for r in &mine {
            let rmse: f64 = r[6].parse().unwrap();
            assert!(rmse.is_finite() && rmse > 0.0);
        }
        let photons: u64 = mine.last().unwrap()[4].parse().unwrap();
        assert_eq!(photons == 0, est == "pt", "{est}: photons {photons}");
        for ext in ["exr", "png"] {
            assert!(out_dir.join(format!("{est}.{ext}")).is_file());
        }
    }
    for f in ["error.svg", "error.png", "error-caustic.svg", "error-caustic.png", "side-by-side.png", "side-by-side-caustic.png", "time-to-error.csv", "time-to-error.json", "summary.json"] {
        let p = out_dir.join(f);
        assert!(std::fs::metadata(&p).map(|m| m.len() > 0).unwrap_or(false), "{} missing or empty", p.display());
    }
    let svg = std::fs::read_to_string(out_dir.join("error.svg")).unwrap();
    assert!(svg.starts_with("<svg") && svg.contains("mis"));
    let png = std::fs::read(out_dir.join("error.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn render_error_log_has_one_row_per_pass() {
    let dir = test_dir("errorlog");
    let r = reference(&dir);
    let log = dir.join("log.csv");
    let stats = dir.join("stats.json");
    let out = run(&[
        "render",
        scene().to_str().unwrap(),
        "--width",
        "32",
        "--height",
        "32",
        "--spp",
        "6",
        "--pass-spp",
        "2",
        "--estimator",
        "mis",
        "--photons",
        "20000",
        "--reference",
        r.to_str().unwrap(),
        "--error-log",
        log.to_str().unwrap(),
        "--region",
        "caustic=62%,86%,80%,94%",
        "--stats",
        stats.to_str().unwrap(),
        "-q",
        "-o",
        dir.join("img.exr").to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (header, rows) = read_csv(&log);
    assert_eq!(header, ["pass", "seconds", "spp", "photons_emitted", "photons_stored", "rmse", "relmse", "caustic_rmse", "caustic_relmse", "caustic_bias"]);
    assert_eq!(rows.len(), 3, "6 spp in passes of 2");
    for (i, row) in rows.iter().enumerate() {
        assert_eq!(row[0], (i + 1).to_string());
        assert_eq!(row[2], (2 * (i + 1)).to_string());
    }
    let json: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats).unwrap()).unwrap();
    let last_rmse: f64 = rows[2][5].parse().unwrap();
    let e = &json["error"];
    assert_eq!(e["pass"], 3);
    assert!((e["rmse"].as_f64().unwrap() - last_rmse).abs() <= 1e-9 * last_rmse.max(1.0));
    assert_eq!(e["regions"][0]["name"], "caustic");
}

#[test]
fn mismatched_reference_is_a_clear_error() {
    let dir = test_dir("mismatch");
    let r = reference(&dir);
    let out = run(&["render", scene().to_str().unwrap(), "--width", "16", "--height", "32", "--spp", "1", "--reference", r.to_str().unwrap(), "-q", "-o", dir.join("img.exr").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--reference") && err.contains("32×32") && err.contains("16×32"), "{err}");
    assert!(!dir.join("img.exr").exists(), "nothing is rendered with a bad reference");

    let out = run(&["converge", scene().to_str().unwrap(), "--width", "16", "--height", "32", "--reference", r.to_str().unwrap(), "-o", dir.join("c").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--reference"));

    let missing = dir.join("missing.exr");
    let out = run(&["converge", scene().to_str().unwrap(), "--reference", missing.to_str().unwrap(), "-o", dir.join("c").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.exr"));

    let out = run(&["converge", scene().to_str().unwrap(), "--reference", r.to_str().unwrap(), "--time-budget=0", "-o", dir.join("c").to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--time-budget"));
}

#[test]
fn time_to_error_interpolates_in_log_log() {
    // e = 1/t: between (1, 1) and (4, 0.25) the target 0.5 is reached at t = 2 exactly in log-log.
    let pts = [(1.0, 1.0), (4.0, 0.25), (16.0, 0.0625)];
    assert!((time_to_error(&pts, 0.5).unwrap() - 2.0).abs() < 1e-12);
    assert_eq!(time_to_error(&pts, 2.0), Some(1.0), "reached at the first pass");
    assert_eq!(time_to_error(&pts, 0.01), None, "never reached");
    // The first crossing counts, even if the error rises again.
    let noisy = [(1.0, 1.0), (2.0, 0.4), (3.0, 0.6), (4.0, 0.3)];
    assert!(time_to_error(&noisy, 0.5).unwrap() < 2.0);
}
