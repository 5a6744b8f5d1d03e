//! Error over time: the image after every pass of a render compared with a reference (RMSE and relMSE of
//! [`super::metrics`], for the whole image and for named regions), kept as rows for an error log (CSV),
//! the stats JSON and the progress line. Used by `caustica render --reference` and `caustica converge`.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::{bail, Context as _};
use serde::Serialize;

use super::metrics::{compare, MetricsError, Region};
use crate::film::{read_exr, Image};
use crate::render::PassInfo;

/// Block size of the block RMSE computed alongside (not logged; [`compare`] needs one).
const BLOCK: u32 = 16;

/// The error of one region after a pass.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RegionError {
    pub name: String,
    pub rmse: f64,
    pub relmse: f64,
    /// Relative mean bias of the region: `Y(mean image) / Y(mean reference) − 1` (its noise averages out
    /// over the region's pixels, so a progressive render's kernel bias shows here).
    pub bias: f64,
}

/// The figures of one pass: time and work so far, and the errors against the reference.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PassError {
    pub pass: u32,
    /// Rendering seconds so far (error evaluation excluded; see [`PassInfo::seconds`]).
    pub seconds: f64,
    pub spp: u32,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub rmse: f64,
    pub relmse: f64,
    pub regions: Vec<RegionError>,
}

impl PassError {
    /// The RMSE of `region` (`None`: the whole image), if that region is tracked.
    #[must_use]
    pub fn rmse_of(&self, region: Option<&str>) -> Option<f64> {
        match region {
            None => Some(self.rmse),
            Some(name) => self.regions.iter().find(|r| r.name == name).map(|r| r.rmse),
        }
    }

    /// The relMSE of `region` (`None`: the whole image), if that region is tracked.
    #[must_use]
    pub fn relmse_of(&self, region: Option<&str>) -> Option<f64> {
        match region {
            None => Some(self.relmse),
            Some(name) => self.regions.iter().find(|r| r.name == name).map(|r| r.relmse),
        }
    }
}

/// A reference image, the regions to report, and the rows recorded so far.
#[derive(Clone, Debug)]
pub struct ErrorTracker {
    reference: Image,
    regions: Vec<Region>,
    rows: Vec<PassError>,
}

impl ErrorTracker {
    /// Reads the reference EXR and parses `--region` specs against its size. Errors name the file / flag.
    pub fn load(reference: &Path, region_specs: &[String]) -> anyhow::Result<Self> {
        let image = read_exr(reference).with_context(|| format!("--reference {}", reference.display()))?;
        Self::new(image, region_specs)
    }

    /// A tracker over an image already in memory.
    pub fn new(reference: Image, region_specs: &[String]) -> anyhow::Result<Self> {
        let mut regions: Vec<Region> = Vec::with_capacity(region_specs.len());
        for (i, spec) in region_specs.iter().enumerate() {
            let mut r = Region::parse(spec, reference.width(), reference.height()).context("--region")?;
            if !spec.contains('=') {
                // An unnamed region is named by its position, as its name becomes a CSV column.
                r.name = format!("region{}", i + 1);
            }
            if regions.iter().any(|q| q.name == r.name) {
                bail!("--region {spec:?}: the name {:?} is used twice", r.name);
            }
            if r.name.contains(',') || r.name.contains('"') {
                bail!("--region {spec:?}: a region name cannot contain ',' or '\"' (it becomes a CSV column)");
            }
            regions.push(r);
        }
        Ok(Self { reference, regions, rows: Vec::new() })
    }

    /// Fails with a message naming `reference_name` when the render's size differs from the reference's.
    pub fn check_size(&self, width: u32, height: u32, reference_name: &Path) -> anyhow::Result<()> {
        let (rw, rh) = (self.reference.width(), self.reference.height());
        if (rw, rh) != (width, height) {
            bail!(
                "--reference {}: the reference is {rw}×{rh} but the render is {width}×{height} (use the same --width/--height/--crop as the reference)",
                reference_name.display()
            );
        }
        Ok(())
    }

    #[must_use]
    pub fn reference(&self) -> &Image {
        &self.reference
    }

    #[must_use]
    pub fn regions(&self) -> &[Region] {
        &self.regions
    }

    #[must_use]
    pub fn rows(&self) -> &[PassError] {
        &self.rows
    }

    /// The same reference and regions with `rows` as the recorded rows (to format saved rows).
    #[must_use]
    pub fn with_rows(mut self, rows: Vec<PassError>) -> Self {
        self.rows = rows;
        self
    }

    /// Compares `image` (the film after the pass `info`) with the reference and keeps the row.
    pub fn record(&mut self, image: &Image, info: &PassInfo) -> Result<&PassError, MetricsError> {
        let c = compare(image, &self.reference, &self.regions, BLOCK)?;
        self.rows.push(PassError {
            pass: info.pass,
            seconds: info.seconds,
            spp: info.spp,
            photons_emitted: info.photons_emitted,
            photons_stored: info.photons_stored,
            rmse: c.whole.rmse,
            relmse: c.whole.relmse,
            regions: c.regions.iter().map(|r| RegionError { name: r.region.name.clone(), rmse: r.metrics.rmse, relmse: r.metrics.relmse, bias: r.metrics.luminance_ratio - 1.0 }).collect(),
        });
        Ok(self.rows.last().expect("just pushed"))
    }

    /// The CSV header; with `estimator` a leading `estimator` column.
    #[must_use]
    pub fn csv_header(&self, with_estimator: bool) -> String {
        let mut s = String::new();
        if with_estimator {
            s.push_str("estimator,");
        }
        s.push_str("pass,seconds,spp,photons_emitted,photons_stored,rmse,relmse");
        for r in &self.regions {
            let _ = write!(s, ",{0}_rmse,{0}_relmse,{0}_bias", r.name);
        }
        s.push('\n');
        s
    }

    /// The recorded rows as CSV lines (no header), each prefixed with `estimator` if given.
    #[must_use]
    pub fn csv_rows(&self, estimator: Option<&str>) -> String {
        let mut s = String::new();
        for row in &self.rows {
            if let Some(e) = estimator {
                let _ = write!(s, "{e},");
            }
            let _ = write!(s, "{},{:.6},{},{},{},{:.9e},{:.9e}", row.pass, row.seconds, row.spp, row.photons_emitted, row.photons_stored, row.rmse, row.relmse);
            for r in &row.regions {
                let _ = write!(s, ",{:.9e},{:.9e},{:.9e}", r.rmse, r.relmse, r.bias);
            }
            s.push('\n');
        }
        s
    }

    /// Header and rows: the whole `--error-log` file.
    #[must_use]
    pub fn csv(&self) -> String {
        self.csv_header(false) + &self.csv_rows(None)
    }
}

/// A short summary of a row for a progress line: `rmse 1.2e-2 relmse 3.4e-3 floor 5.6e-2`.
#[must_use]
pub fn progress_text(row: &PassError) -> String {
    let mut s = format!("rmse {:.3e} relmse {:.3e}", row.rmse, row.relmse);
    for r in &row.regions {
        let _ = write!(s, " {} {:.3e}", r.name, r.rmse);
    }
    s
}
