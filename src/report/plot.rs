//! Figures for reports, drawn with plotters: a log-log plot of error against time (one line per
//! estimator) as SVG and PNG, and a labelled side-by-side PNG of images.
//!
//! Text is drawn with DejaVu Sans embedded in the binary (`assets/fonts/`, Bitstream Vera licence), so
//! neither fontconfig nor system fonts are needed. PNGs are encoded here and returned as bytes; the
//! caller writes them atomically.

use std::sync::Once;

use anyhow::{anyhow, bail};
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
        .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())
        .map_err(err)?;
    chart
        .configure_mesh()
        .x_desc("render time (s)")
        .y_desc(y_label)
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .x_label_formatter(&|v| if x1 / x0 < 4.0 || is_1235(*v) { format_tick(*v) } else { String::new() })
        .y_label_formatter(&|v| format!("{v:.1e}"))
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

/// Whether `v` is 1, 2, 3 or 5 times a power of ten (the time axis labels only those ticks when it spans
/// a wide range, as plotters puts a tick at every 1…9 × 10ᵏ and their labels would overlap).
fn is_1235(v: f64) -> bool {
    if !(v.is_finite() && v > 0.0) {
        return false;
    }
    let m = v / 10f64.powf(v.log10().floor());
    [1.0, 2.0, 3.0, 5.0, 10.0].iter().any(|k| (m - k).abs() < 1e-3 * k)
}

/// Tick labels of the time axis: plain numbers, few digits.
fn format_tick(v: f64) -> String {
    if v >= 10.0 {
        format!("{v:.0}")
    } else if v >= 1.0 {
        format!("{v:.1}")
    } else {
        format!("{v:.2}")
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
