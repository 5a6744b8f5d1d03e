//! Figures for reports, drawn with plotters: a log-log plot of error against time (one line per
//! estimator) as SVG and PNG, and a labelled side-by-side PNG of images.
//!
//! Text is drawn with DejaVu Sans embedded in the binary (`assets/fonts/`, Bitstream Vera licence), so
//! neither fontconfig nor system fonts are needed. PNGs are encoded here and returned as bytes; the
//! caller writes them atomically.

use std::sync::Once;

use anyhow::{anyhow, bail};
use plotters::coord::combinators::{BindKeyPoints, LogCoord, WithKeyPoints};
use plotters::coord::Shift;
use plotters::prelude::*;

use crate::film::io::display_rgb8;
use crate::film::{Image, Tonemap};

/// The font family name the embedded font is registered under.
const FONT: &str = "sans-serif";
static FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

fn register_font() {
    REGISTER.call_once(|| {
        // The font is part of the binary and known to parse; a failure would only lose the labels.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    });
}

/// One line of an error plot: a label and (seconds, error) points in time order.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
}

/// Line colours by series index (colour-blind-safe Okabe–Ito hues).
const COLOURS: [RGBColor; 6] =
    [RGBColor(0, 114, 178), RGBColor(213, 94, 0), RGBColor(0, 158, 115), RGBColor(204, 121, 167), RGBColor(230, 159, 0), RGBColor(86, 180, 233)];

/// Pixel size of the plots.
pub const PLOT_SIZE: (u32, u32) = (800, 560);

/// The log-log error plot as an SVG document and PNG bytes. Points with a non-positive or non-finite
/// coordinate cannot be shown on log axes and are left out.
pub fn error_plot(title: &str, y_label: &str, series: &[Series]) -> anyhow::Result<(String, Vec<u8>)> {
    register_font();
    let clean: Vec<Series> = series
        .iter()
        .map(|s| Series { label: s.label.clone(), points: s.points.iter().copied().filter(|&(t, e)| t.is_finite() && e.is_finite() && t > 0.0 && e > 0.0).collect() })
        .collect();
    let all: Vec<(f64, f64)> = clean.iter().flat_map(|s| s.points.iter().copied()).collect();
    if all.is_empty() {
        bail!("{title}: no point with positive time and error to plot");
    }
    let range = |v: Box<dyn Iterator<Item = f64> + '_>| -> (f64, f64) {
        let (lo, hi) = v.fold((f64::INFINITY, 0.0f64), |(lo, hi), x| (lo.min(x), hi.max(x)));
        // Some room around the data, and a non-empty range when all values are equal.
        (lo / 1.25, hi * 1.25)
    };
    let xr = range(Box::new(all.iter().map(|p| p.0)));
    let yr = range(Box::new(all.iter().map(|p| p.1)));

    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, PLOT_SIZE).into_drawing_area();
        draw_error_plot(&root, title, y_label, &clean, xr, yr)?;
        root.present().map_err(|e| anyhow!("{title}: SVG: {e}"))?;
    }
    let (w, h) = PLOT_SIZE;
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, PLOT_SIZE).into_drawing_area();
        draw_error_plot(&root, title, y_label, &clean, xr, yr)?;
        root.present().map_err(|e| anyhow!("{title}: bitmap: {e}"))?;
    }
    Ok((svg, encode_png(&rgb, w, h)?))
}

/// A log axis over `[lo, hi]` labelled at [`log_ticks`], with a faint grid line at the densest ticks that
/// fit [`MAX_GRID_LINES`].
fn log_axis(lo: f64, hi: f64) -> WithKeyPoints<LogCoord<f64>> {
    (lo..hi).log_scale().with_key_points(log_ticks(lo, hi, MAX_TICKS)).with_light_points(log_ticks(lo, hi, MAX_GRID_LINES))
}

fn draw_error_plot<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    y_label: &str,
    series: &[Series],
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| anyhow!("{title}: {e}");
    root.fill(&WHITE).map_err(err)?;
    let mut chart = ChartBuilder::on(root)
        .caption(title, (FONT, 22))
        .margin(16)
        .x_label_area_size(48)
        .y_label_area_size(80)
        .build_cartesian_2d(log_axis(x0, x1), log_axis(y0, y1))
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("render time (s)")
        .y_desc(y_label)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        .draw()
        .map_err(err)?;
    for (i, s) in series.iter().enumerate() {
        let colour = COLOURS[i % COLOURS.len()];
        chart
            .draw_series(LineSeries::new(s.points.iter().copied(), colour.stroke_width(2)))
            .map_err(err)?
            .label(s.label.as_str())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], colour.stroke_width(3)));
        chart.draw_series(s.points.iter().map(|&p| Circle::new(p, 3, colour.filled()))).map_err(err)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 16))
        .draw()
        .map_err(err)?;
    Ok(())
}

/// The most labelled ticks on an axis of the error plot (labels up to ~7 characters in 800 × 560 pixels).
const MAX_TICKS: usize = 10;
/// The most lines of the faint grid between the labelled ticks.
const MAX_GRID_LINES: usize = 60;

/// Mantissas of the ticks of a log axis, in tenths (sparsest set first): 1·10ᵏ; 1, 3; 1, 2, 5; 1, 2, 3, 5;
/// 1…9; then steps of 0.5, 0.2 and 0.1, so that an axis spanning less than a decade still gets ticks.
fn mantissa_sets() -> [Vec<u32>; 8] {
    let step = |d: u32| (10..100).step_by(d as usize).collect::<Vec<u32>>();
    [vec![10], vec![10, 30], vec![10, 20, 50], vec![10, 20, 30, 50], step(10), step(5), step(2), step(1)]
}

/// The values `m/10 · 10ᵏ` (m from `mantissas`, in tenths) within `[lo, hi]`, every `stride`-th decade.
fn ticks_of(lo: f64, hi: f64, mantissas: &[u32], stride: i32) -> Vec<f64> {
    let (k0, k1) = (lo.log10().floor() as i32, hi.log10().floor() as i32);
    let mut ticks = Vec::new();
    for k in (k0..=k1).filter(|k| k.rem_euclid(stride) == 0) {
        for &m in mantissas {
            let v = f64::from(m) * 10f64.powi(k - 1);
            if v >= lo && v <= hi {
                ticks.push(v);
            }
        }
    }
    ticks
}

/// The ticks of a log axis over `[lo, hi]` (0 < lo < hi): the densest set of [`mantissa_sets`] that puts
/// at most `max` ticks there — every power of ten, or every n-th, when even those are too many; at least
/// two where `max` allows (every n-th tick of a denser set, for a narrow range and a small `max`). Each is
/// distinct, in increasing order, and labelled distinctly by [`tick_label`]. (plotters' own log ticks repeat
/// each power of ten below the top one, have none in a range without a power of ten, and their labels at
/// two decimals repeated: "0.00" for 0.001, 0.002 and 0.003.)
#[must_use]
pub fn log_ticks(lo: f64, hi: f64, max: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > lo) {
        return Vec::new();
    }
    let max = max.max(1);
    let mut best = ticks_of(lo, hi, &[10], 1);
    if best.len() > max {
        let stride = best.len().div_ceil(max) as i32;
        return ticks_of(lo, hi, &[10], stride);
    }
    for set in &mantissa_sets()[1..] {
        let ticks = ticks_of(lo, hi, set, 1);
        if ticks.len() <= max && ticks.len() > best.len() {
            best = ticks;
        }
    }
    if best.len() < 2 {
        // A narrow range and few ticks allowed: every n-th of the first set with two or more there.
        if let Some(ticks) = mantissa_sets().iter().map(|set| ticks_of(lo, hi, set, 1)).find(|t| t.len() >= 2) {
            let stride = ticks.len().div_ceil(max);
            best = ticks.into_iter().step_by(stride).collect();
        }
    }
    best
}

/// The label of a tick `m·10ᵏ` of [`log_ticks`] (m with at most one decimal): plain digits from 0.001 to
/// 99999 ("0.002", "0.15", "20"), `m`e`k` beyond ("2e-5", "1.5e6"). Exact, so distinct ticks get distinct
/// labels.
#[must_use]
pub fn tick_label(v: f64) -> String {
    if !(v.is_finite() && v > 0.0) {
        return format!("{v}");
    }
    let mut k = (v.log10() + 1e-9).floor() as i32;
    let mut tenths = (v / 10f64.powi(k - 1)).round() as u32;
    if tenths >= 100 {
        tenths /= 10;
        k += 1;
    }
    let mantissa_decimals = i32::from(tenths % 10 != 0);
    if (-3..5).contains(&k) {
        let decimals = (mantissa_decimals - k).max(0) as usize;
        format!("{v:.decimals$}")
    } else if mantissa_decimals == 1 {
        format!("{}.{}e{k}", tenths / 10, tenths % 10)
    } else {
        format!("{}e{k}", tenths / 10)
    }
}

/// One panel of a side-by-side figure: a caption (one or more lines) above an image.
#[derive(Clone, Debug)]
pub struct Panel<'a> {
    pub label: String,
    pub image: &'a Image,
}

/// Height of one caption line above the panels, in pixels.
const LINE_HEIGHT: u32 = 22;
/// Gap between panels, in pixels.
const GAP: u32 = 4;
/// Panels narrower than this are enlarged by a whole factor (nearest neighbour, every pixel a block)
/// until the narrowest reaches it, so that small crops and their captions stay readable.
const MIN_PANEL_WIDTH: u32 = 240;

/// The whole factor that brings the narrowest panel to [`MIN_PANEL_WIDTH`] (1 if it is already as wide).
fn panel_scale(panels: &[Panel<'_>]) -> u32 {
    let narrowest = panels.iter().map(|p| p.image.width()).min().unwrap_or(1).max(1);
    MIN_PANEL_WIDTH.div_ceil(narrowest).clamp(1, 16)
}

/// The panels in a row, each tone-mapped (`exposure` stops, `tonemap`) under its caption, as PNG bytes.
/// Panels of different heights are top-aligned on a black background; small panels are enlarged by a
/// whole factor (see [`MIN_PANEL_WIDTH`]).
pub fn side_by_side(panels: &[Panel<'_>], exposure: f32, tonemap: Tonemap) -> anyhow::Result<Vec<u8>> {
    register_font();
    if panels.is_empty() {
        bail!("side-by-side figure: no image");
    }
    let scale = panel_scale(panels);
    let lines = panels.iter().map(|p| p.label.lines().count()).max().unwrap_or(1).max(1) as u32;
    let caption_height = lines * LINE_HEIGHT + 6;
    let w: u32 = panels.iter().map(|p| p.image.width() * scale).sum::<u32>() + GAP * (panels.len() as u32 - 1);
    let h: u32 = panels.iter().map(|p| p.image.height() * scale).max().unwrap_or(1) + caption_height;
    let mut rgb = vec![0u8; (w as usize) * (h as usize) * 3];
    let mut x_off = 0u32;
    for p in panels {
        for y in 0..p.image.height() * scale {
            for x in 0..p.image.width() * scale {
                let c = display_rgb8(p.image.get(x / scale, y / scale), exposure, tonemap);
                let i = (((y + caption_height) as usize) * (w as usize) + (x + x_off) as usize) * 3;
                rgb[i..i + 3].copy_from_slice(&c);
            }
        }
        x_off += p.image.width() * scale + GAP;
    }
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        let mut x_off = 0i32;
        for p in panels {
            // Shrink the text of narrow panels so that the caption fits (≈ 0.55 em per character).
            let longest = p.label.lines().map(|l| l.chars().count()).max().unwrap_or(1).max(1) as f64;
            let size = (f64::from((p.image.width() * scale).saturating_sub(8)) / (0.55 * longest)).clamp(8.0, 18.0);
            let style = TextStyle::from((FONT, size).into_font()).color(&WHITE);
            for (i, line) in p.label.lines().enumerate() {
                root.draw_text(line, &style, (x_off + 4, 4 + (i as i32) * LINE_HEIGHT as i32)).map_err(|e| anyhow!("side-by-side caption: {e}"))?;
            }
            x_off += (p.image.width() * scale + GAP) as i32;
        }
        root.present().map_err(|e| anyhow!("side-by-side figure: {e}"))?;
    }
    encode_png(&rgb, w, h)
}

/// RGB8 pixels to PNG bytes.
fn encode_png(rgb: &[u8], w: u32, h: u32) -> anyhow::Result<Vec<u8>> {
    use ::image::ImageEncoder as _;
    let mut out = Vec::new();
    ::image::codecs::png::PngEncoder::new(&mut out).write_image(rgb, w, h, ::image::ExtendedColorType::Rgb8).map_err(|e| anyhow!("PNG encoding: {e}"))?;
    Ok(out)
}


#[cfg(test)]
mod tests {
    use super::*;

    /// Over ranges from a ninth of a decade to thirty decades: increasing ticks within the range, at most
    /// the maximum, at least two, and labels that are distinct and read back as their ticks.
    #[test]
    fn ticks_and_their_labels_are_distinct() {
        let mut lo = 1.7e-9;
        while lo < 1e6 {
            for ratio in [1.3, 1.5625, 3.0, 9.0, 12.0, 150.0, 1e4, 1e30] {
                let hi = lo * ratio;
                for max in [MAX_TICKS, MAX_GRID_LINES, 3] {
                    let ticks = log_ticks(lo, hi, max);
                    assert!(!ticks.is_empty() && ticks.len() <= max, "{lo}..{hi}: {ticks:?}");
                    assert!(ticks.windows(2).all(|w| w[0] < w[1]) && ticks.iter().all(|&t| t >= lo && t <= hi), "{lo}..{hi}: {ticks:?}");
                    assert!(ticks.len() >= 2, "{lo}..{hi} (max {max}): {ticks:?}");
                    let labels: Vec<String> = ticks.iter().map(|&t| tick_label(t)).collect();
                    let mut distinct = labels.clone();
                    distinct.dedup();
                    assert_eq!(distinct, labels, "{lo}..{hi}");
                    for (t, l) in ticks.iter().zip(&labels) {
                        let back: f64 = l.parse().unwrap();
                        assert!((back - t).abs() <= 1e-9 * t, "{t} labelled {l}");
                    }
                }
            }
            lo *= 1.37;
        }
    }

    /// The ranges that repeated labels before: a short render's time axis (0.0008 s to 0.06 s: "0.00" for
    /// 0.001, 0.002, 0.003; "0.01" for 0.005 and twice for 0.01, which plotters also ticked twice) and a
    /// sub-decade error axis that had no tick at all.
    #[test]
    fn the_ranges_that_repeated_labels() {
        let t = log_ticks(0.0008, 0.06, MAX_TICKS);
        let labels: Vec<String> = t.iter().map(|&v| tick_label(v)).collect();
        assert_eq!(labels, ["0.001", "0.002", "0.003", "0.005", "0.01", "0.02", "0.03", "0.05"]);
        let labels: Vec<String> = log_ticks(0.3, 0.9, MAX_TICKS).iter().map(|&v| tick_label(v)).collect();
        assert_eq!(labels, ["0.3", "0.4", "0.5", "0.6", "0.7", "0.8", "0.9"]);
        // Thirty decades: every fourth power of ten.
        let labels: Vec<String> = log_ticks(1e-12, 1e18, MAX_TICKS).iter().map(|&v| tick_label(v)).collect();
        assert_eq!(labels, ["1e-12", "1e-8", "1e-4", "1", "10000", "1e8", "1e12", "1e16"]);
        assert_eq!(tick_label(1.5e-5), "1.5e-5");
        assert_eq!(tick_label(0.15), "0.15");
        assert_eq!(tick_label(25.0), "25");
    }
}
