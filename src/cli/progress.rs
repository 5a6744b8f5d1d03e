//! The progress line (indicatif), at most 80 columns: a bar, the percentage, the samples per pixel done
//! (of the total, or so far with `--time-limit`), the sample rate in readable units, the elapsed time and
//! the time left, then the last pass's error against `--reference`, cut to the terminal's width. Hidden
//! when stdout is not a terminal or with `--quiet`; without a terminal (a CI log), the same figures as a
//! plain line on stderr every `--log-every` seconds instead (the progress of a 40-minute CI render).
//!
//! With `--time-limit` the bar measures time (its length is the limit in milliseconds), so its ETA is
//! the time left.

use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

use crate::render::{PassInfo, RenderSettings};
use crate::report::error_log::{progress_text, PassError};

pub struct Progress {
    bar: Option<ProgressBar>,
    samples: Arc<AtomicU64>,
    start: Instant,
    /// The time limit in milliseconds (the bar's length then).
    limit_ms: Option<u64>,
    /// Without a terminal: a line every this many milliseconds, and when the last one was due.
    log_every_ms: Option<u64>,
    last_log_ms: AtomicU64,
    total_samples: u64,
    pixels: u64,
    /// The last pass's text (`pass 3 RMSE …`), for the log lines.
    last_pass: std::sync::Mutex<String>,
}

/// A rate with an SI prefix: `950 samples/s`, `12.3 ksamples/s`, `1.23 Msamples/s`.
#[must_use]
pub fn readable_rate(per_second: f64) -> String {
    let (v, prefix) = match per_second {
        r if !r.is_finite() || r < 1e3 => (per_second.max(0.0), ""),
        r if r < 1e6 => (r / 1e3, "k"),
        r if r < 1e9 => (r / 1e6, "M"),
        r => (r / 1e9, "G"),
    };
    let digits = if v < 10.0 && !prefix.is_empty() { 2 } else if v < 100.0 && !prefix.is_empty() { 1 } else { 0 };
    format!("{v:.digits$} {prefix}samples/s")
}

/// `m:ss` (or `h:mm:ss` from an hour on).
#[must_use]
pub fn clock(d: Duration) -> String {
    let s = d.as_secs();
    if s >= 3600 {
        format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
    } else {
        format!("{}:{:02}", s / 60, s % 60)
    }
}

impl Progress {
    /// A line over all samples of the render (or over the time limit).
    #[must_use]
    /// `log_every`: without a terminal, the interval of the plain progress lines (`None`: none).
    pub fn new(show: bool, log_every: Option<Duration>, settings: &RenderSettings, pixels: u64) -> Self {
        Self::with(show, log_every, settings.spp, settings.time_limit, pixels)
    }

    /// [`Progress::new`] from the settings it reads: `spp` samples per pixel, or `time_limit` seconds.
    fn with(show: bool, log_every: Option<Duration>, spp: u32, time_limit: Option<f64>, pixels: u64) -> Self {
        let samples = Arc::new(AtomicU64::new(0));
        let start = Instant::now();
        let limit_ms = time_limit.map(|t| (t * 1e3).round().max(1.0) as u64);
        let pixels = pixels.max(1);
        let mut progress = Self {
            bar: None,
            samples: samples.clone(),
            start,
            limit_ms,
            log_every_ms: log_every.map(|d| (d.as_millis() as u64).max(1)),
            last_log_ms: AtomicU64::new(0),
            total_samples: pixels * u64::from(spp),
            pixels,
            last_pass: std::sync::Mutex::new(String::new()),
        };
        if !show {
            return progress;
        }
        let bar = ProgressBar::new(limit_ms.unwrap_or(pixels * u64::from(spp)));
        bar.set_draw_target(ProgressDrawTarget::stdout());
        let total_spp = spp;
        let timed = limit_ms.is_some();
        let (s_spp, s_rate) = (samples.clone(), samples.clone());
        let style = ProgressStyle::with_template("{bar:16} {percent:>3}% {spp} {rate} {clock} {wide_msg}").map(|style| {
            style
                .with_key("spp", move |_: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let done = s_spp.load(Ordering::Relaxed) / pixels;
                    let _ = if timed { write!(w, "{done} spp") } else { write!(w, "{done}/{total_spp} spp") };
                })
                .with_key("rate", move |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let secs = state.elapsed().as_secs_f64();
                    let rate = if secs > 0.0 { s_rate.load(Ordering::Relaxed) as f64 / secs } else { 0.0 };
                    let _ = write!(w, "{}", readable_rate(rate));
                })
                .with_key("clock", |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{} ETA {}", clock(state.elapsed()), clock(state.eta()));
                })
        });
        if let Ok(style) = style {
            bar.set_style(style);
        }
        progress.bar = Some(bar);
        progress
    }

    /// The plain progress line: done so far (of the total or of the time limit), the rate, the elapsed time
    /// and the time left, and the last pass.
    fn log_line(&self, now_ms: u64) -> String {
        let samples = self.samples.load(Ordering::Relaxed);
        let secs = now_ms as f64 / 1e3;
        let rate = if secs > 0.0 { samples as f64 / secs } else { 0.0 };
        let spp = samples / self.pixels;
        let (fraction, spp_text) = match self.limit_ms {
            Some(limit) => (now_ms as f64 / limit as f64, format!("{spp} spp")),
            None => (samples as f64 / self.total_samples.max(1) as f64, format!("{spp}/{} spp", self.total_samples / self.pixels)),
        };
        let fraction = fraction.clamp(0.0, 1.0);
        let left = if fraction > 0.0 { Duration::from_secs_f64(secs * (1.0 - fraction) / fraction) } else { Duration::ZERO };
        let pass = self.last_pass.lock().map(|p| p.clone()).unwrap_or_default();
        let mut line = format!("progress: {:>3.0}% {spp_text} {} {} ETA {}", 100.0 * fraction, readable_rate(rate), clock(Duration::from_millis(now_ms)), clock(left));
        if !pass.is_empty() {
            let _ = write!(line, " {pass}");
        }
        line
    }

    /// Prints the plain line when one is due (one thread prints; the others see the new time).
    fn maybe_log(&self) {
        let Some(every) = self.log_every_ms else { return };
        let now_ms = self.start.elapsed().as_millis() as u64;
        let last = self.last_log_ms.load(Ordering::Relaxed);
        if now_ms >= last + every && self.last_log_ms.compare_exchange(last, now_ms, Ordering::Relaxed, Ordering::Relaxed).is_ok() {
            eprintln!("{}", self.log_line(now_ms));
        }
    }

    /// A tile of `samples` pixel samples finished.
    pub fn tile_done(&self, samples: u64) {
        self.samples.fetch_add(samples, Ordering::Relaxed);
        self.maybe_log();
        if let Some(b) = &self.bar {
            match self.limit_ms {
                Some(limit) => b.set_position((self.start.elapsed().as_millis() as u64).min(limit)),
                None => b.inc(samples),
            }
        }
    }

    /// A pass finished; `error` is its error against the reference, if there is one.
    pub fn pass_done(&self, info: &PassInfo, error: Option<&PassError>) {
        let mut msg = format!("pass {}", info.pass);
        if let Some(e) = error {
            let _ = write!(msg, " {}", progress_text(e));
        }
        if let Ok(mut last) = self.last_pass.lock() {
            last.clone_from(&msg);
        }
        if let Some(b) = &self.bar {
            b.set_message(msg);
        }
        self.maybe_log();
    }

    pub fn finish(&self) {
        if let Some(b) = &self.bar {
            b.finish_and_clear();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_and_clocks_are_readable() {
        assert_eq!(readable_rate(950.0), "950 samples/s");
        assert_eq!(readable_rate(12_345.0), "12.3 ksamples/s");
        assert_eq!(readable_rate(364_758.188), "365 ksamples/s");
        assert_eq!(readable_rate(1_234_567.0), "1.23 Msamples/s");
        assert_eq!(readable_rate(f64::NAN), "0 samples/s");
        assert_eq!(clock(Duration::from_secs(83)), "1:23");
        assert_eq!(clock(Duration::from_secs(3723)), "1:02:03");
    }

    #[test]
    fn the_log_line_says_what_the_bar_says() {
        let p = Progress::with(false, Some(Duration::from_secs(10)), 64, None, 100);
        p.samples.store(1600, Ordering::Relaxed);
        *p.last_pass.lock().unwrap() = "pass 2".into();
        assert_eq!(p.log_line(4000), "progress:  25% 16/64 spp 400 samples/s 0:04 ETA 0:12 pass 2");
    }
}
