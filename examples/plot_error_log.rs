//! Plots an `--error-log` CSV of `caustica render --reference` as a log-log PNG against rendering time:
//! the whole image's RMSE, and for every region its RMSE and the magnitude of its relative mean bias
//! (the `<region>_bias` column; docs/method.md §6.1).
//!
//! `cargo run --release --example plot_error_log -- LOG.csv OUT.png [TITLE]`

use std::path::PathBuf;

use anyhow::{bail, Context as _};
use caustica::report::plot::{error_plot, Series};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() < 2 || args.len() > 3 {
        bail!("usage: plot_error_log LOG.csv OUT.png [TITLE]");
    }
    let (log, out) = (PathBuf::from(&args[0]), PathBuf::from(&args[1]));
    let title = args.get(2).cloned().unwrap_or_else(|| log.display().to_string());
    let text = std::fs::read_to_string(&log).with_context(|| format!("{}", log.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().context("empty error log")?.split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name);
    let seconds = col("seconds").context("no `seconds` column")?;
    // (label, column, take the magnitude)
    let mut wanted: Vec<(String, usize, bool)> = vec![("RMSE, whole image".into(), col("rmse").context("no `rmse` column")?, false)];
    for h in &header {
        if let Some(region) = h.strip_suffix("_rmse") {
            wanted.push((format!("RMSE, {region}"), col(h).expect("listed"), false));
            if let Some(b) = col(&format!("{region}_bias")) {
                wanted.push((format!("|relative mean bias|, {region}"), b, true));
            }
        }
    }
    let mut series: Vec<Series> = wanted.iter().map(|(label, _, _)| Series { label: label.clone(), points: Vec::new() }).collect();
    for (n, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        let get = |i: usize| -> anyhow::Result<f64> {
            cells.get(i).with_context(|| format!("row {}: too few columns", n + 2))?.parse::<f64>().with_context(|| format!("row {}, column {}", n + 2, i + 1))
        };
        let t = get(seconds)?;
        for (s, (_, c, magnitude)) in series.iter_mut().zip(&wanted) {
            let v = get(*c)?;
            s.points.push((t, if *magnitude { v.abs() } else { v }));
        }
    }
    let (_svg, png) = error_plot(&title, "error", &series)?;
    std::fs::write(&out, png).with_context(|| format!("{}", out.display()))?;
    Ok(())
}
