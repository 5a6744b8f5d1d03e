//! `caustica compare IMAGE REFERENCE [--region name=x0,y0,x1,y1]... [--block 16] [--json out.json]`:
//! prints the error metrics of [`crate::report::compare`] as a table and writes them as JSON.

use std::path::PathBuf;

use super::Outcome;
use crate::film::io::write_json_atomic;
use crate::report::compare::{evaluate, format_table};

/// Arguments of `caustica compare`.
#[derive(clap::Args, Clone, Debug, PartialEq, Eq)]
pub struct CompareArgs {
    /// The image to evaluate (OpenEXR).
    pub image: PathBuf,
    /// The reference image (OpenEXR, same size).
    pub reference: PathBuf,
    /// A region to report separately, `x0,y0,x1,y1` or `name=x0,y0,x1,y1` (exclusive ends; values in
    /// pixels or percentages like `62%`; clipped to the image). Repeatable.
    #[arg(long = "region")]
    pub regions: Vec<String>,
    /// Block size in pixels for the block-mean RMSE.
    #[arg(long, default_value_t = 16)]
    pub block: u32,
    /// Also write the metrics as JSON to this file (`-`: standard output, instead of the table).
    #[arg(long)]
    pub json: Option<PathBuf>,
}

/// Reads both images, computes the metrics, prints the table (on standard error with `--json -`), and
/// writes the JSON if asked.
pub fn run(args: &CompareArgs) -> anyhow::Result<Outcome> {
    if let Some(path) = &args.json {
        super::args::check_output_or_stdout("--json", path)?;
        super::args::check_not_input("--json", path, &[&args.image, &args.reference])?;
    }
    let report = evaluate(&args.image, &args.reference, &args.regions, args.block)?;
    let to_stdout = args.json.as_deref() == Some(std::path::Path::new("-"));
    if to_stdout {
        eprint!("{}", format_table(&report));
    } else {
        print!("{}", format_table(&report));
    }
    if let Some(path) = &args.json {
        write_json_atomic(path, &report)?;
        if !to_stdout {
            println!("wrote {}", path.display());
        }
    }
    Ok(Outcome::Done)
}
