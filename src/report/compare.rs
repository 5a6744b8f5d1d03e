//! What `caustica compare IMAGE REFERENCE [--region name=x0,y0,x1,y1]... [--block 16] [--json out.json]`
//! computes: error metrics of a render against a reference (both OpenEXR, same size), printed as a table and
//! optionally written as JSON (atomically). The metrics are defined in [`super::metrics`].
//!
//! Region values are pixel indices or percentages of the image size, e.g. the cornell-caustics
//! reference's caustic region is `--region caustic=62%,86%,80%,94%`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use super::metrics::{compare, Comparison, Metrics, Region};
use crate::film::read_exr;

/// The JSON document written by `--json`.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CompareReport {
    pub image: PathBuf,
    pub reference: PathBuf,
    #[serde(flatten)]
    pub comparison: Comparison,
}

/// Reads both images, parses the region specs against the image's size, and compares.
pub fn evaluate(image_path: &Path, reference_path: &Path, region_specs: &[String], block: u32) -> anyhow::Result<CompareReport> {
    let image = read_exr(image_path)?;
    let reference = read_exr(reference_path)?;
    let regions = region_specs
        .iter()
        .map(|spec| Region::parse(spec, image.width(), image.height()))
        .collect::<Result<Vec<_>, _>>()
        .with_context(|| format!("{}: bad --region", image_path.display()))?;
    let comparison = compare(&image, &reference, &regions, block)
        .with_context(|| format!("comparing {} with {}", image_path.display(), reference_path.display()))?;
    Ok(CompareReport {
        image: image_path.to_owned(),
        reference: reference_path.to_owned(),
        comparison,
    })
}

/// A readable table of a report: one row for the whole image and one per region.
#[must_use]
pub fn format_table(report: &CompareReport) -> String {
    let c = &report.comparison;
    let mut s = String::new();
    let _ = writeln!(s, "image:     {} ({}×{})", report.image.display(), c.width, c.height);
    let _ = writeln!(s, "reference: {}", report.reference.display());
    let _ = writeln!(
        s,
        "relMSE ε = {}; block RMSE over {}×{}-pixel block means; NaN/Inf pixels excluded",
        c.relmse_epsilon, c.block, c.block
    );
    let _ = writeln!(
        s,
        "{:<14} {:>17} {:>8} {:>10} {:>10} {:>10} {:>10} {:>26} {:>20} {:>6} {:>6}",
        "region", "window", "pixels", "RMSE", "relMSE", "MAE", "blockRMSE", "mean image (R G B)", "ratio (R G B)", "NaN", "Inf"
    );
    let whole = Region::whole(c.width, c.height);
    let rows = std::iter::once((&whole, &c.whole)).chain(c.regions.iter().map(|r| (&r.region, &r.metrics)));
    for (region, m) in rows {
        let _ = writeln!(s, "{}", format_row(region, m));
    }
    s
}

fn format_row(region: &Region, m: &Metrics) -> String {
    let window = region.rect.to_string();
    let mean = format!("{:.5} {:.5} {:.5}", m.mean_image[0], m.mean_image[1], m.mean_image[2]);
    let ratio = format!("{:.4} {:.4} {:.4}", m.mean_ratio[0], m.mean_ratio[1], m.mean_ratio[2]);
    format!(
        "{:<14} {:>17} {:>8} {:>10.4e} {:>10.4e} {:>10.4e} {:>10.4e} {:>26} {:>20} {:>6} {:>6}",
        region.name, window, m.pixels, m.rmse, m.relmse, m.mae, m.block_rmse, mean, ratio, m.nan_count, m.inf_count
    )
}
