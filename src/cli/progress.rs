//! The progress bar (indicatif): samples/s and time left; hidden when stdout is not a terminal or with
//! `--quiet`.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

use crate::render::{PassInfo, RenderSettings};
use crate::report::error_log::{progress_text, PassError};

pub struct Progress {
    bar: Option<ProgressBar>,
}

impl Progress {
    /// A bar over all samples of the render (or over the time limit).
    #[must_use]
    pub fn new(show: bool, settings: &RenderSettings, pixels: u64) -> Self {
        if !show {
            return Self { bar: None };
        }
        let bar = match settings.time_limit {
            None => ProgressBar::new(pixels * u64::from(settings.spp)),
            Some(_) => ProgressBar::no_length(),
        };
        bar.set_draw_target(ProgressDrawTarget::stdout());
        let template = if settings.time_limit.is_some() {
            "{spinner} {elapsed_precise} {human_pos} samples ({per_sec}) {msg}"
        } else {
            "{bar:40} {percent:>3}% {elapsed_precise} left {eta_precise} ({per_sec} samples) {msg}"
        };
        if let Ok(style) = ProgressStyle::with_template(template) {
            bar.set_style(style);
        }
        Self { bar: Some(bar) }
    }

    /// A tile of `samples` pixel samples finished.
    pub fn tile_done(&self, samples: u64) {
        if let Some(b) = &self.bar {
            b.inc(samples);
        }
    }

    /// A pass finished; `error` is its error against the reference, if there is one.
    pub fn pass_done(&self, info: &PassInfo, error: Option<&PassError>) {
        if let Some(b) = &self.bar {
            match error {
                Some(e) => b.set_message(format!("pass {} ({} spp) {}", info.pass, info.spp, progress_text(e))),
                None => b.set_message(format!("pass {} ({} spp)", info.pass, info.spp)),
            }
        }
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}
