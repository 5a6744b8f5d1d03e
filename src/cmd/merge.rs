//! `caustica merge PART... -o OUT.exr`: adds the partial films of `render --part` into the image one
//! render would have made (the checks and the sums are `render::part`'s).

use std::path::PathBuf;

use anyhow::Context;

use crate::cmd::render::{check_outputs, write_json_atomic};
use crate::film::{write_exr, write_png, Tonemap};
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
    /// Exposure of the PNG preview, in stops.
    #[arg(long, default_value_t = 0.0)]
    pub exposure: f32,
    /// Tone mapping of the PNG preview.
    #[arg(long, value_enum, default_value_t = Tonemap::Clamp)]
    pub tonemap: Tonemap,
    /// Write the merge's statistics (parts, missing parts, summed work) as JSON here.
    #[arg(long)]
    pub stats: Option<PathBuf>,
    /// Merge even if some parts are missing (the image then has fewer samples, or black tiles); the
    /// missing parts are listed on stderr and in the stats.
    #[arg(long)]
    pub allow_missing: bool,
    /// No summary line.
    #[arg(long, short = 'q')]
    pub quiet: bool,
}

/// Runs `caustica merge`.
pub fn run(args: &MergeArgs) -> anyhow::Result<()> {
    let t = std::time::Instant::now();
    check_outputs(&[("-o/--output", Some(args.output.as_path())), ("--png", args.png.as_deref()), ("--stats", args.stats.as_deref())])?;
    let parts = args.parts.iter().map(|p| read_part(p)).collect::<Result<Vec<_>, _>>()?;
    let (film, mut stats) = merge_parts(parts, args.allow_missing)?;
    let image = film.image();
    write_exr(&args.output, &image)?;
    if let Some(png) = &args.png {
        write_png(png, &image, args.exposure, args.tonemap)?;
    }
    let missing: Vec<String> = stats.missing.iter().map(|i| format!("{i}/{}", stats.parts)).collect();
    if !missing.is_empty() {
        eprintln!("warning: merged without part(s) {}: the image has fewer samples than the render asked for", missing.join(", "));
    }
    stats.seconds_merge = t.elapsed().as_secs_f64();
    if let Some(p) = &args.stats {
        write_json_atomic(p, &stats).with_context(|| format!("--stats {}", p.display()))?;
    }
    if !args.quiet {
        eprintln!(
            "{}: merged {} of {} parts ({} shares), {} spp; parts took {:.2} s in all (longest {:.2} s), merge {:.2} s",
            args.output.display(),
            stats.merged.len(),
            stats.parts,
            stats.share,
            stats.spp,
            stats.seconds_parts_sum,
            stats.seconds_parts_max,
            stats.seconds_merge
        );
    }
    Ok(())
}
