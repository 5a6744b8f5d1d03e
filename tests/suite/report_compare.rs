//! `caustica compare`: argument parsing, end-to-end run on EXR files, JSON output.

use std::path::{Path, PathBuf};

use caustica::film::{write_exr, Image};
use caustica::math::Vec3;
use caustica::cli::compare::{run, CompareArgs};
use caustica::report::compare::{format_table, CompareReport};

/// The library's evaluation of what `compare` was asked.
fn evaluate(args: &CompareArgs) -> anyhow::Result<CompareReport> {
    caustica::report::compare::evaluate(&args.image, &args.reference, &args.regions, args.block)
}
use clap::Parser;

#[derive(clap::Parser)]
struct Cli {
    #[command(flatten)]
    args: CompareArgs,
}

fn test_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("report_compare-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn parses_arguments() {
    let cli = Cli::try_parse_from([
        "compare",
        "a.exr",
        "b.exr",
        "--region",
        "c=1,2,3,4",
        "--region",
        "0,0,5,5",
        "--json",
        "m.json",
    ])
    .unwrap();
    assert_eq!(cli.args.image, PathBuf::from("a.exr"));
    assert_eq!(cli.args.reference, PathBuf::from("b.exr"));
    assert_eq!(cli.args.regions, vec!["c=1,2,3,4".to_string(), "0,0,5,5".to_string()]);
    assert_eq!(cli.args.block, 16);
    assert_eq!(cli.args.json, Some(PathBuf::from("m.json")));
    assert!(Cli::try_parse_from(["compare", "a.exr"]).is_err());
}

#[test]
fn compares_files_and_writes_json() {
    let dir = test_dir("run");
    // Reference: 8×4 grey 0.5; image: the same, times 1.1 in the left half, and one NaN pixel.
    let reference = Image::from_fn(8, 4, |_, _| Vec3::splat(0.5));
    let mut image = Image::from_fn(8, 4, |x, _| Vec3::splat(if x < 4 { 0.55 } else { 0.5 }));
    image.set(7, 3, Vec3::splat(f32::NAN));
    write_exr(dir.join("img.exr"), &image).unwrap();
    write_exr(dir.join("ref.exr"), &reference).unwrap();
    let json = dir.join("metrics.json");
    let args = CompareArgs {
        image: dir.join("img.exr"),
        reference: dir.join("ref.exr"),
        regions: vec!["left=0,0,50%,100%".into(), "right=4,0,99,99".into()],
        block: 4,
        json: Some(json.clone()),
    };
    run(&args).unwrap();
    let report: CompareReport = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(report, evaluate(&args).unwrap());
    let c = &report.comparison;
    assert_eq!((c.width, c.height, c.block), (8, 4, 4));
    assert_eq!(c.whole.nan_count, 1);
    assert_eq!(c.regions.len(), 2);
    let left = &c.regions[0];
    assert_eq!((left.region.name.as_str(), left.region.x1, left.region.y1), ("left", 4, 4));
    let d = f64::from(0.55f32) - 0.5;
    assert!((left.metrics.rmse - d).abs() < 1e-12);
    assert!((left.metrics.mean_ratio[0] - f64::from(0.55f32) / 0.5).abs() < 1e-12);
    let right = &c.regions[1];
    assert_eq!((right.region.x1, right.metrics.valid_pixels, right.metrics.rmse), (8, 15, 0.0));
    let table = format_table(&report);
    assert!(
        table.contains("left") && table.contains("right") && table.contains("image"),
        "{table}"
    );
    // Only the JSON and the two images: no temp file left.
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 3);
}

#[test]
fn errors_name_the_problem() {
    let dir = test_dir("errors");
    write_exr(dir.join("small.exr"), &Image::new(4, 4)).unwrap();
    write_exr(dir.join("big.exr"), &Image::new(8, 4)).unwrap();
    let mut args = CompareArgs {
        image: dir.join("small.exr"),
        reference: dir.join("big.exr"),
        regions: vec![],
        block: 16,
        json: None,
    };
    let msg = format!("{:#}", evaluate(&args).unwrap_err());
    assert!(msg.contains("4×4") && msg.contains("8×4"), "{msg}");
    args.reference = dir.join("missing.exr");
    let msg = format!("{:#}", evaluate(&args).unwrap_err());
    assert!(msg.contains("missing.exr"), "{msg}");
    args.reference = dir.join("small.exr");
    args.regions = vec!["x=9,9,12,12".into()];
    let msg = format!("{:#}", evaluate(&args).unwrap_err());
    assert!(msg.contains("x=9,9,12,12") || msg.contains("`x`"), "{msg}");
    args.regions = vec![];
    args.json = Some(dir.join("no-such-dir").join("m.json"));
    assert!(run(&args).is_err());
}

#[test]
fn mitsuba_reference_against_a_scaled_copy() {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/reference/cornell-caustics/mitsuba-path-9984spp.exr"));
    let reference = caustica::film::read_exr(path).unwrap();
    let mut scaled = reference.clone();
    for p in scaled.pixels_mut() {
        *p *= 2.0; // exact in f32
    }
    let caustic = caustica::report::metrics::Region::cornell_caustic(256, 256).unwrap();
    let c = caustica::report::metrics::compare(&scaled, &reference, &[caustic], 16).unwrap();
    let m = &c.regions[0].metrics;
    println!(
        "caustic region {:?}: reference mean RGB {:?}",
        c.regions[0].region, m.mean_reference
    );
    assert_eq!(m.pixels, 47 * 21);
    assert_eq!(m.mean_ratio, [2.0; 3]);
    assert_eq!(c.whole.mean_ratio, [2.0; 3]);
    // |I − R| = R everywhere, so MAE = the mean of R over all channels.
    let mean_r = c.whole.mean_reference.iter().sum::<f64>() / 3.0;
    assert!((c.whole.mae - mean_r).abs() < 1e-12 * mean_r);
}
