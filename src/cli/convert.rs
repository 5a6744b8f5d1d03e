//! `caustica convert IN -o OUT`: a scene from Mitsuba 3 XML to TOML or back, the formats given by the
//! file names (`.xml`, `.toml`). The converter is the library's (`scene::convert_scene`).

use std::path::PathBuf;

use anyhow::{bail, Context as _};

use super::log::info;
use super::Outcome;
use crate::film::io::write_atomic;
use crate::scene::{convert_scene, is_xml};

/// Arguments of `caustica convert`.
#[derive(clap::Args, Debug, Clone)]
pub struct ConvertArgs {
    /// The scene to convert: TOML, or Mitsuba 3 XML (.xml).
    pub input: PathBuf,
    /// Where to write it: `.xml` for Mitsuba 3 XML, `.toml` for TOML.
    #[arg(short = 'o', long = "output", value_name = "OUT")]
    pub output: PathBuf,
    #[command(flatten)]
    pub params: super::args::SceneParams,
}

pub fn run(args: &ConvertArgs) -> anyhow::Result<Outcome> {
    let ext = args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !is_xml(&args.output) && ext.as_deref() != Some("toml") {
        bail!("-o {}: the output's name must end in .xml (Mitsuba 3 XML) or .toml", args.output.display());
    }
    let text = convert_scene(&args.input, &args.output, &args.params.map())?;
    write_atomic(&args.output, |w| w.write_all(text.as_bytes())).with_context(|| format!("writing {}", args.output.display()))?;
    info!("wrote {}", args.output.display());
    Ok(Outcome::Done)
}
