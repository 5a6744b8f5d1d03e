//! Pixel reconstruction filters: Mitsuba 3's `rfilter` plugins (`src/rfilters/*.cpp`), chosen per film.
//!
//! ```toml
//! [sensor.film]
//! width = 256
//! height = 256
//! rfilter = { type = "gaussian", stddev = 0.5 }   # the default when the film has no rfilter
//! ```
//!
//! ```xml
//! <film type="hdrfilm"> … <rfilter type="gaussian"><float name="stddev" value="0.5"/></rfilter> </film>
//! ```
//!
//! | type | parameters (default) | radius | f(x) |
//! |---|---|---|---|
//! | `box` | — | ½ | 1 (the sample's own pixel) |
//! | `tent` | `radius` (1) | `radius` | `max(0, 1 − abs(x)/r)` |
//! | `gaussian` | `stddev` (0.5) | 4σ | `max(0, exp(−x²/2σ²) − exp(−r²/2σ²))` |
//! | `mitchell` | `B`, `C` (⅓, ⅓) | 2 | Mitchell–Netravali's cubic |
//! | `catmullrom` | — | 2 | the cubic with B = 0, C = ½ |
//! | `lanczos` | `lobes` (3) | `lobes` | `sinc(x)·sinc(x/lobes)` |
//!
//! As in Mitsuba (`ImageBlock::put`, `hdrfilm`'s `develop`): a sample at film position `p` (uniform in
//! its pixel) adds `w·L` and `w` to every pixel whose centre `c` lies within the radius on both axes,
//! `w = f(cₓ − pₓ)·f(c_y − p_y)` (not normalised per sample), and a pixel's value is `Σ w·L / Σ w`. The box
//! filter is Mitsuba's special case: the sample goes to its own pixel with weight 1, no filter evaluated.
//! The default, when a film names no filter, is Mitsuba's: the Gaussian of σ = ½ ([`PixelFilter::default`]).
//!
//! Splats read the filter from a table ([`FilterTable`]), as Mitsuba's CPU (scalar) variants do
//! (`ReconstructionFilter::eval_discretized`): `f` at 31 points `i·r/31`, read at `⌊|x|·31/r⌋`, so that
//! images agree with Mitsuba's `scalar_rgb` (its JIT variants evaluate `f` itself; the step of r/31
//! widens the effective filter by about r/62, which moves an edge pixel of a Gaussian-filtered image by
//! ~1 % of the edge's contrast). [`PixelFilter::eval`] is the filter itself. The Gaussian is Mitsuba's
//! windowed form, shifted to reach 0 at the radius (its GPU code; its CPU code fits a polynomial to the
//! same function).

use std::fmt;

use crate::props::{Plugin, PropError, Props};

/// Each filter type as the scene files name it (`rfilter`): its keys, their defaults ([`defaults`]) and
/// checks ([`PixelFilter::checked`]).
pub(crate) const PLUGINS: &[&Plugin<PixelFilter>] = &[
    &Plugin { name: "box", keys: &[], nested: &[], build: |_| Ok(PixelFilter::Box) },
    &Plugin { name: "tent", keys: &["radius"], nested: &[], build: tent },
    &Plugin { name: "gaussian", keys: &["stddev"], nested: &[], build: gaussian },
    &Plugin { name: "mitchell", keys: &["B", "C"], nested: &[], build: mitchell },
    &Plugin { name: "catmullrom", keys: &[], nested: &[], build: |_| Ok(PixelFilter::CatmullRom) },
    &Plugin { name: "lanczos", keys: &["lobes"], nested: &[], build: lanczos },
];

fn tent(p: Props<'_, ()>) -> Result<PixelFilter, PropError> {
    plugin_checked(PixelFilter::Tent { radius: p.float_or("radius", defaults::TENT_RADIUS)? })
}

fn gaussian(p: Props<'_, ()>) -> Result<PixelFilter, PropError> {
    plugin_checked(PixelFilter::Gaussian { stddev: p.float_or("stddev", defaults::GAUSSIAN_STDDEV)? })
}

fn mitchell(p: Props<'_, ()>) -> Result<PixelFilter, PropError> {
    plugin_checked(PixelFilter::Mitchell { b: p.float_or("B", defaults::MITCHELL_B)?, c: p.float_or("C", defaults::MITCHELL_C)? })
}

fn lanczos(p: Props<'_, ()>) -> Result<PixelFilter, PropError> {
    plugin_checked(PixelFilter::Lanczos { lobes: p.u32_or("lobes", defaults::LANCZOS_LOBES)? })
}

/// [`PixelFilter::checked`], its error at the parameter's key.
fn plugin_checked(f: PixelFilter) -> Result<PixelFilter, PropError> {
    f.checked().map_err(|e| PropError::new(e.parameter, e.message))
}

/// The default of each filter's parameters (Mitsuba's, read in each plugin's constructor).
pub mod defaults {
    /// `tent`'s `radius`.
    pub const TENT_RADIUS: f32 = 1.0;
    /// `gaussian`'s `stddev`.
    pub const GAUSSIAN_STDDEV: f32 = 0.5;
    /// `mitchell`'s `B` and `C`.
    pub const MITCHELL_B: f32 = 1.0 / 3.0;
    pub const MITCHELL_C: f32 = 1.0 / 3.0;
    /// `lanczos`'s `lobes`.
    pub const LANCZOS_LOBES: u32 = 3;
}

/// The widest radius accepted, in pixels: a sample splats into up to (2r)² pixels and a tile's buffer
/// grows by r on every side, and a reconstruction filter this wide is a blur, not a reconstruction.
pub const MAX_RADIUS: f32 = 16.0;

/// A pixel reconstruction filter (module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PixelFilter {
    Box,
    Tent { radius: f32 },
    Gaussian { stddev: f32 },
    Mitchell { b: f32, c: f32 },
    CatmullRom,
    Lanczos { lobes: u32 },
}

/// Mitsuba's `hdrfilm` default (`src/render/film.cpp`: a Gaussian when no rfilter is given).
impl Default for PixelFilter {
    fn default() -> Self {
        PixelFilter::Gaussian { stddev: defaults::GAUSSIAN_STDDEV }
    }
}

/// A filter parameter out of range: the parameter's name and why.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{message}")]
pub struct FilterError {
    /// The parameter (`radius`, `stddev`, `B`, `C`, `lobes`).
    pub parameter: &'static str,
    pub message: String,
}

/// Mitchell–Netravali's cubic (`mitchell.cpp`, `catmullrom.cpp`), for `x ≥ 0`.
fn mitchell_netravali(x: f32, b: f32, c: f32) -> f32 {
    let (x2, x3) = (x * x, x * x * x);
    let v = if x < 1.0 {
        (12.0 - 9.0 * b - 6.0 * c) * x3 + (-18.0 + 12.0 * b + 6.0 * c) * x2 + (6.0 - 2.0 * b)
    } else if x < 2.0 {
        (-b - 6.0 * c) * x3 + (6.0 * b + 30.0 * c) * x2 + (-12.0 * b - 48.0 * c) * x + (8.0 * b + 24.0 * c)
    } else {
        0.0
    };
    v / 6.0
}

impl PixelFilter {
    /// The filter checked: a finite radius in (0, [`MAX_RADIUS`]], finite `B` and `C`, at least one lobe.
    pub fn checked(self) -> Result<Self, FilterError> {
        let err = |parameter, message: String| Err(FilterError { parameter, message });
        match self {
            PixelFilter::Tent { radius } if !(radius > 0.0 && radius <= MAX_RADIUS) => {
                err("radius", format!("the tent's radius must be in (0, {MAX_RADIUS}] pixels, not {radius}"))
            }
            PixelFilter::Gaussian { stddev } if !(stddev > 0.0 && 4.0 * stddev <= MAX_RADIUS) => {
                err("stddev", format!("the Gaussian's stddev must be in (0, {}] pixels (radius 4σ ≤ {MAX_RADIUS}), not {stddev}", MAX_RADIUS / 4.0))
            }
            PixelFilter::Mitchell { b, .. } if !b.is_finite() => err("B", format!("B must be finite, not {b}")),
            PixelFilter::Mitchell { c, .. } if !c.is_finite() => err("C", format!("C must be finite, not {c}")),
            PixelFilter::Lanczos { lobes } if lobes == 0 || lobes as f32 > MAX_RADIUS => {
                err("lobes", format!("lanczos needs 1 to {MAX_RADIUS} lobes, not {lobes}"))
            }
            f => Ok(f),
        }
    }

    /// Mitsuba's plugin name.
    #[must_use]
    pub fn name(&self) -> &'static str {
        match self {
            PixelFilter::Box => "box",
            PixelFilter::Tent { .. } => "tent",
            PixelFilter::Gaussian { .. } => "gaussian",
            PixelFilter::Mitchell { .. } => "mitchell",
            PixelFilter::CatmullRom => "catmullrom",
            PixelFilter::Lanczos { .. } => "lanczos",
        }
    }

    /// `true` for the box filter: a sample goes to its own pixel only.
    #[must_use]
    pub fn is_box(&self) -> bool {
        matches!(self, PixelFilter::Box)
    }

    /// The support's half width in pixels: `f(x) = 0` for `|x| ≥ radius`.
    #[must_use]
    pub fn radius(&self) -> f32 {
        match *self {
            PixelFilter::Box => 0.5,
            PixelFilter::Tent { radius } => radius,
            PixelFilter::Gaussian { stddev } => 4.0 * stddev,
            PixelFilter::Mitchell { .. } | PixelFilter::CatmullRom => 2.0,
            PixelFilter::Lanczos { lobes } => lobes as f32,
        }
    }

    /// How many pixels beyond its own a sample can reach on each side: the pixels whose centre lies
    /// within the radius of a point of the pixel, `⌈radius − ½⌉` (Mitsuba's `border_size`); 0 for the box.
    #[must_use]
    pub fn border(&self) -> u32 {
        if self.is_box() {
            0
        } else {
            (self.radius() - 0.5).ceil().max(0.0) as u32
        }
    }

    /// The filter at offset `x` (pixels) from its centre; 0 outside `(−radius, radius)`.
    #[must_use]
    pub fn eval(&self, x: f32) -> f32 {
        let x = x.abs();
        if x >= self.radius() {
            return 0.0;
        }
        match *self {
            PixelFilter::Box => 1.0,
            PixelFilter::Tent { radius } => (1.0 - x / radius).max(0.0),
            PixelFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                let r = 4.0 * stddev;
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
            PixelFilter::Mitchell { b, c } => mitchell_netravali(x, b, c),
            PixelFilter::CatmullRom => mitchell_netravali(x, 0.0, 0.5),
            PixelFilter::Lanczos { lobes } => {
                // `lanczos.cpp`: 1 within f32's epsilon of the centre.
                if x < f32::EPSILON {
                    return 1.0;
                }
                let x1 = std::f32::consts::PI * x;
                let x2 = x1 / lobes as f32;
                (x1.sin() * x2.sin()) / (x1 * x2)
            }
        }
    }
}

/// Mitsuba's `MI_FILTER_RESOLUTION`: the table holds the filter at this many points over the radius.
pub const TABLE_RESOLUTION: usize = 31;

/// A filter tabulated as Mitsuba's `init_discretization` does: `values[i] = f(r·i/31)` for `i < 31`,
/// `values[31] = 0`; [`FilterTable::weight`] is `eval_discretized`.
#[derive(Clone, Debug, PartialEq)]
pub struct FilterTable {
    values: [f32; TABLE_RESOLUTION + 1],
    /// `31 / r`.
    scale: f32,
}

impl FilterTable {
    #[must_use]
    pub fn new(filter: &PixelFilter) -> Self {
        let r = filter.radius();
        let mut values = [0.0; TABLE_RESOLUTION + 1];
        for (i, v) in values.iter_mut().take(TABLE_RESOLUTION).enumerate() {
            *v = filter.eval(r * i as f32 / TABLE_RESOLUTION as f32);
        }
        Self { values, scale: TABLE_RESOLUTION as f32 / r }
    }

    /// The tabulated filter at offset `x`: `values[min(⌊|x|·31/r⌋, 31)]`, 0 from the radius on.
    #[inline]
    #[must_use]
    pub fn weight(&self, x: f32) -> f32 {
        // `as usize` saturates (and maps NaN to 0).
        self.values[((x.abs() * self.scale) as usize).min(TABLE_RESOLUTION)]
    }
}

/// The filter as the partial film's attribute writes it and [`PixelFilter::from_str`] reads it back:
/// the name, then the parameters (f32 in their shortest exact form).
impl fmt::Display for PixelFilter {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        match *self {
            PixelFilter::Box | PixelFilter::CatmullRom => write!(f, "{}", self.name()),
            PixelFilter::Tent { radius } => write!(f, "tent {radius:?}"),
            PixelFilter::Gaussian { stddev } => write!(f, "gaussian {stddev:?}"),
            PixelFilter::Mitchell { b, c } => write!(f, "mitchell {b:?} {c:?}"),
            PixelFilter::Lanczos { lobes } => write!(f, "lanczos {lobes}"),
        }
    }
}

impl std::str::FromStr for PixelFilter {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let words: Vec<&str> = s.split_whitespace().collect();
        let f = |i: usize| -> Result<f32, String> { words.get(i).and_then(|w| w.parse().ok()).ok_or_else(|| format!("filter {s:?}")) };
        let filter = match (words.first().copied(), words.len()) {
            (Some("box"), 1) => PixelFilter::Box,
            (Some("catmullrom"), 1) => PixelFilter::CatmullRom,
            (Some("tent"), 2) => PixelFilter::Tent { radius: f(1)? },
            (Some("gaussian"), 2) => PixelFilter::Gaussian { stddev: f(1)? },
            (Some("mitchell"), 3) => PixelFilter::Mitchell { b: f(1)?, c: f(2)? },
            (Some("lanczos"), 2) => PixelFilter::Lanczos { lobes: words[1].parse().map_err(|_| format!("filter {s:?}"))? },
            _ => return Err(format!("filter {s:?}")),
        };
        filter.checked().map_err(|e| format!("filter {s:?}: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ALL: [PixelFilter; 6] = [
        PixelFilter::Box,
        PixelFilter::Tent { radius: 1.0 },
        PixelFilter::Gaussian { stddev: 0.5 },
        PixelFilter::Mitchell { b: 1.0 / 3.0, c: 1.0 / 3.0 },
        PixelFilter::CatmullRom,
        PixelFilter::Lanczos { lobes: 3 },
    ];

    /// ∫ f over its support (midpoint rule, f64 sum).
    fn integral(f: &PixelFilter) -> f64 {
        let r = f64::from(f.radius());
        let n = 200_000;
        let h = 2.0 * r / f64::from(n);
        (0..n).map(|i| f64::from(f.eval((-r + (f64::from(i) + 0.5) * h) as f32)) * h).sum()
    }

    #[test]
    fn default_is_mitsubas_gaussian() {
        assert_eq!(PixelFilter::default(), PixelFilter::Gaussian { stddev: 0.5 });
        assert_eq!(PixelFilter::default().radius(), 2.0);
        assert_eq!(PixelFilter::default().border(), 2);
    }

    #[test]
    fn radius_and_border_are_mitsubas() {
        let radii: Vec<f32> = ALL.iter().map(PixelFilter::radius).collect();
        assert_eq!(radii, [0.5, 1.0, 2.0, 2.0, 2.0, 3.0]);
        // border_size = ⌈radius − ½⌉ (rfilter.cpp; the box has no border in ImageBlock).
        let borders: Vec<u32> = ALL.iter().map(PixelFilter::border).collect();
        assert_eq!(borders, [0, 1, 2, 2, 2, 3]);
        assert_eq!(PixelFilter::Tent { radius: 1.5 }.border(), 1);
        assert_eq!(PixelFilter::Tent { radius: 1.6 }.border(), 2);
        for f in ALL {
            // Zero at and beyond the radius, nonzero just inside (the filters are nonzero there).
            let r = f.radius();
            assert_eq!(f.eval(r), 0.0, "{f}");
            assert_eq!(f.eval(-r - 0.1), 0.0, "{f}");
            assert_eq!(f.eval(0.0), f.eval(-0.0), "{f}");
            for x in [0.1f32, 0.37, 0.8, 1.3] {
                assert_eq!(f.eval(x), f.eval(-x), "{f} symmetric at {x}");
            }
        }
    }

    /// The integrals: box, tent, Mitchell (any B, C) and Catmull-Rom integrate to 1; the windowed
    /// Gaussian to σ√(2π)·erf(2√2) − 2r·e⁻⁸ (its shift); Lanczos-3 to 0.99... (computed below by a fine
    /// sum of the closed form's integrand in f64, independently of `eval`).
    #[test]
    fn integrals() {
        for f in [ALL[0], ALL[1], ALL[3], ALL[4], PixelFilter::Mitchell { b: 0.2, c: 0.6 }, PixelFilter::Tent { radius: 2.5 }] {
            let expect = if let PixelFilter::Tent { radius } = f { f64::from(radius) } else { 1.0 };
            assert!((integral(&f) - expect).abs() < 1e-4, "{f}: ∫ = {}", integral(&f));
        }
        // Gaussian σ = 0.5: σ√(2π)·erf(4/√2) − 2·(4σ)·exp(−8). erf(2√2) = 0.999936657516334.
        let s = 0.5f64;
        let expect = s * (2.0 * std::f64::consts::PI).sqrt() * 0.999_936_657_516_334 - 2.0 * 4.0 * s * (-8.0f64).exp();
        assert!((integral(&ALL[2]) - expect).abs() < 1e-5, "gaussian ∫ = {} vs {expect}", integral(&ALL[2]));
        // Lanczos: the same integrand in f64.
        let lanczos = |x: f64| {
            if x.abs() < 1e-12 {
                1.0
            } else {
                let a = std::f64::consts::PI * x;
                a.sin() * (a / 3.0).sin() / (a * a / 3.0)
            }
        };
        let n = 200_000;
        let h = 6.0 / f64::from(n);
        let expect: f64 = (0..n).map(|i| lanczos(-3.0 + (f64::from(i) + 0.5) * h) * h).sum();
        assert!((integral(&ALL[5]) - expect).abs() < 1e-5, "lanczos ∫ = {} vs {expect}", integral(&ALL[5]));
    }

    /// Values at chosen points against Mitsuba's formulas written out by hand.
    #[test]
    fn values_match_mitsubas_formulas() {
        let close = |a: f32, b: f64, what: &str| assert!((f64::from(a) - b).abs() < 2e-6, "{what}: {a} vs {b}");
        close(ALL[1].eval(0.25), 0.75, "tent");
        close(PixelFilter::Tent { radius: 2.0 }.eval(1.5), 0.25, "tent r=2");
        let g = |x: f64| (-x * x / 0.5).exp() - (-8.0f64).exp();
        for x in [0.0, 0.3, 1.0, 1.9] {
            close(ALL[2].eval(x as f32), g(x), &format!("gaussian at {x}"));
        }
        // Mitchell B = C = 1/3: f(0) = (6 − 2B)/6 = 8/9; f(1) = (6 − 2B + (12 − 9B − 6C) + (−18 + 12B + 6C))/6 = B/6 = 1/18.
        close(ALL[3].eval(0.0), 8.0 / 9.0, "mitchell 0");
        close(ALL[3].eval(1.0), 1.0 / 18.0, "mitchell 1");
        // Outer piece at 1.5: ((−B − 6C)·3.375 + (6B + 30C)·2.25 + (−12B − 48C)·1.5 + 8B + 24C)/6.
        let (b, c) = (1.0 / 3.0f64, 1.0 / 3.0f64);
        close(ALL[3].eval(1.5), ((-b - 6.0 * c) * 3.375 + (6.0 * b + 30.0 * c) * 2.25 + (-12.0 * b - 48.0 * c) * 1.5 + 8.0 * b + 24.0 * c) / 6.0, "mitchell 1.5");
        // Catmull-Rom interpolates: 1 at 0, 0 at ±1, negative lobe between 1 and 2 (−0.0625 at 1.5).
        close(ALL[4].eval(0.0), 1.0, "catmullrom 0");
        close(ALL[4].eval(1.0), 0.0, "catmullrom 1");
        close(ALL[4].eval(1.5), -0.0625, "catmullrom 1.5");
        // Lanczos: 1 at 0, sinc zeros at the integers, sin(πx)·sin(πx/3)/(π²x²/3) between.
        close(ALL[5].eval(0.0), 1.0, "lanczos 0");
        for k in [1.0f32, 2.0] {
            assert!(ALL[5].eval(k).abs() < 1e-6, "lanczos at {k}: {}", ALL[5].eval(k));
        }
        let x = 1.5f64;
        let a = std::f64::consts::PI * x;
        close(ALL[5].eval(1.5), a.sin() * (a / 3.0).sin() / (a * a / 3.0), "lanczos 1.5");
    }

    /// The table is Mitsuba's `eval_discretized`: steps of r/31 holding the value at their inner end, 0 from
    /// the radius on; so it never lies below a decreasing filter and is within one step of it.
    #[test]
    fn the_table_steps_as_mitsubas() {
        for f in &ALL[1..] {
            let t = FilterTable::new(f);
            let r = f.radius();
            let step = r / TABLE_RESOLUTION as f32;
            assert_eq!(t.weight(0.0), f.eval(0.0), "{f}");
            assert_eq!(t.weight(r), 0.0, "{f}");
            assert_eq!(t.weight(-r * 1.5), 0.0, "{f}");
            for i in 0..TABLE_RESOLUTION {
                let x = step * (i as f32 + 0.5);
                assert_eq!(t.weight(x), f.eval(r * i as f32 / TABLE_RESOLUTION as f32), "{f} at {x}");
                assert_eq!(t.weight(-x), t.weight(x), "{f} at -{x}");
            }
        }
        let g = FilterTable::new(&PixelFilter::default());
        for x in [0.01f32, 0.3, 0.77, 1.5, 1.99] {
            let f = PixelFilter::default();
            assert!(g.weight(x) >= f.eval(x) && g.weight(x) <= f.eval((x - 2.0 / 31.0).max(0.0)), "gaussian at {x}");
        }
    }

    #[test]
    fn text_round_trips_and_checks() {
        for f in ALL.into_iter().chain([PixelFilter::Gaussian { stddev: 0.3 }, PixelFilter::Mitchell { b: 0.1, c: 0.7 }]) {
            assert_eq!(f.to_string().parse::<PixelFilter>(), Ok(f));
        }
        for bad in ["", "gauss 0.5", "gaussian", "gaussian 0", "tent -1", "lanczos 0", "lanczos 1.5", "box 1", "tent 100"] {
            assert!(bad.parse::<PixelFilter>().is_err(), "{bad:?}");
        }
        assert_eq!(PixelFilter::Gaussian { stddev: f32::NAN }.checked().unwrap_err().parameter, "stddev");
        assert_eq!(PixelFilter::Mitchell { b: 0.0, c: f32::INFINITY }.checked().unwrap_err().parameter, "C");
    }
}
