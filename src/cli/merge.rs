//! `caustica merge PART... -o OUT.exr`: adds the partial films of `render --part` into the image one
//! render would have made (the checks and the sums are `render::part`'s).

use std::path::PathBuf;

use anyhow::Context;

use super::args::{self, PngArgs};
use super::log::{info, warning};
use super::Outcome;
use crate::film::io::write_json_atomic;
use crate::film::{write_exr, write_png};
use crate::render::part::{merge_parts, read_part};

/// Arguments of `caustica merge`.
#[derive(clap::Args, Debug, Clone)]
pub struct MergeArgs {
    /// The part files written by `caustica render --part I/N` (any order).
    #[arg(required = true)]
    pub parts: Vec<PathBuf>,
    /// Output EXR (float32 RGB).
    #[arg(short = 'o', long = "output")]
    pub output: PathBuf,
    /// Also write an sRGB PNG preview here.
    #[arg(long)]
    pub png: Option<PathBuf>,
    #[command(flatten)]
    pub png_args: PngArgs,
    /// Write the merge's statistics (parts, missing parts, summed work) as JSON here (`-`: standard output).
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Merge even if some parts are missing or were interrupted (the image then has fewer samples, or
    /// black tiles); the missing and partial parts are listed on stderr and in the stats.
    #[arg(long)]
    pub allow_missing: bool,
}

/// Runs `caustica merge`.
pub fn run(args: &MergeArgs) -> anyhow::Result<Outcome> {
    let t = std::time::Instant::now();
    let inputs: Vec<&std::path::Path> = args.parts.iter().map(PathBuf::as_path).collect();
    for (flag, path) in [("-o/--output", Some(args.output.as_path())), ("--png", args.png.as_deref()), ("--stats", args.stats.as_deref())] {
        if let Some(path) = path {
            if flag == "--stats" {
                args::check_output_or_stdout(flag, path)?;
            } else {
                args::check_output(flag, path)?;
            }
            args::check_not_input(flag, path, &inputs)?;
        }
    }
    args::check_image_extension("-o/--output", &args.output, "exr", "")?;
    if let Some(p) = &args.png {
        args::check_image_extension("--png", p, "png", "")?;
    }
    let parts = args.parts.iter().map(|p| read_part(p)).collect::<Result<Vec<_>, _>>()?;
    let (film, mut stats) = merge_parts(parts, args.allow_missing)?;
    let image = film.image();
    write_exr(&args.output, &image)?;
    if let Some(png) = &args.png {
        write_png(png, &image, args.png_args.exposure, args.png_args.tonemap)?;
    }
    // What the image really holds (the film's sample counts), not the render's nominal spp.
    let fewer = format!("the image has {:.2} spp of the {} the render asked for (at least {} in every pixel)", stats.spp_merged, stats.spp, stats.spp_merged_min);
    let missing: Vec<String> = stats.missing.iter().map(|i| format!("{i}/{}", stats.parts)).collect();
    if !missing.is_empty() {
        warning!("merged without part(s) {}: {fewer}", missing.join(", "));
    }
    let partial: Vec<String> = stats.partial.iter().map(|i| format!("{i}/{}", stats.parts)).collect();
    if !partial.is_empty() {
        warning!("part(s) {} were interrupted and merged with the passes they finished: {fewer}", partial.join(", "));
    }
    stats.seconds_merge = t.elapsed().as_secs_f64();
    if let Some(p) = &args.stats {
        write_json_atomic(p, &stats).with_context(|| format!("--stats {}", p.display()))?;
    }
    info!(
        "{}: merged {} of {} parts ({} shares), {} spp{}; parts took {:.2} s in all (longest {:.2} s), merge {:.2} s",
        args.output.display(),
        stats.merged.len(),
        stats.parts,
        stats.share,
        stats.spp,
        if stats.spp_merged_min == u64::from(stats.spp) && stats.spp_merged == f64::from(stats.spp) {
            String::new()
        } else {
            format!(" asked, {:.2} merged (at least {} in every pixel)", stats.spp_merged, stats.spp_merged_min)
        },
        stats.seconds_parts_sum,
        stats.seconds_parts_max,
        stats.seconds_merge
    );
    Ok(Outcome::Done)
}
