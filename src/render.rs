//! The render driver: passes of eye samples over tiles (rayon), an optional photon pass per render
//! pass, Ctrl-C / time-limit handling, and the statistics every render reports (method.md §5).
//!
//! A *pass* renders `pass_spp` samples for every pixel of the crop window. With a sample budget and no
//! time limit there is one pass of `spp` samples and one photon map (the paper's configuration: α = spp).
//! With a time limit, passes run until the time is spent, the last one cut at the limit (its finished
//! tiles kept) so that renders of different estimators take equal time; each pass traces a fresh photon
//! map of the same budget with its own seed (α = `pass_spp`), the density estimate of pass `p` uses the
//! fraction [`area_scale_for_pass`] of its k-NN area (the progressive schedule of method.md §6), and the
//! film averages over passes.
//!
//! A pass's eye samples are traced in *rounds* over the whole frame ([`round`]: one sample per pixel,
//! then rounds of about `round_seconds`; a time-limited pass is one round), each merged into the film
//! when it ends, so that `on_pass` — called after every round — sees the whole frame at the samples per
//! pixel it says, and Ctrl-C keeps the rounds done (the round under way is dropped). The rounds change no
//! bit of a finished image.
//!
//! Sample `s` of pixel `(x, y)` draws from `Sampler::for_pixel(seed, y·width + x, s)` with `s` counted
//! over the whole render, so an image is bit-identical whatever the number of threads.
//!
//! A process may render a [`Share`] of the passes or of the tiles ([`part`]: `render --part`); skipped
//! passes still advance the sample index, so every (pass, tile) it renders is the one the whole render
//! would, and the film's exact sums make the parts add up to the whole bit for bit.

pub mod aov;
pub mod memory;
pub mod part;
pub mod round;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::accel::Accel;
use crate::film::{Film, FilmError};
use self::round::{next_round_spp, trace_round, RoundContext, TileState};
use crate::integrator::{CausticEstimator, PathStats, PathTracer, Q1Range};
use crate::photon::{trace_photons, KdTreeError, PhotonBudget, PhotonMap, PhotonPassStats};
use crate::scene::settings::defaults;
use crate::scene::{Estimator, Scene};

/// Tile edge in pixels.
pub const TILE_SIZE: u32 = 16;

/// What to render; command-line values already merged over the scene file's.
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Total samples per pixel (ignored with a time limit, which renders passes until time is up).
    pub spp: u32,
    /// Samples per pixel of one pass (clamped to `spp` without a time limit).
    pub pass_spp: u32,
    pub time_limit: Option<f64>,
    pub seed: u64,
    pub estimator: Estimator,
    /// Photons per photon pass: emitted (`N` of method.md §2), or a stored target.
    pub photons: PhotonBudget,
    pub knn: u32,
    pub max_radius: f32,
    /// A round's intended length in seconds ([`round`]).
    pub round_seconds: f64,
    /// The AOVs written beside the image (`scene::aov`); the film must have their channels
    /// ([`Film::with_aov_channels`], [`RenderSettings::film`]).
    pub aovs: crate::scene::aov::Aovs,
}

/// Exponent `a` of the progressive area schedule (method.md §6): Knaus & Zwicker's α = 2/3, which
/// balances the asymptotic rates of the kernel bias and the variance of the average of the passes.
pub const PROGRESSIVE_AREA_EXPONENT: f64 = 2.0 / 3.0;

/// The fraction of the k-NN area that the density estimate of pass `pass` (from 0) uses:
/// `s_p = (p + 1)^(a − 1)` with `a` = [`PROGRESSIVE_AREA_EXPONENT`] (method.md §6). `s_0 = 1`, so a
/// render of one pass is the paper's estimate. The rate is that of Knaus & Zwicker's recursion
/// `r²ᵢ₊₁ = r²ᵢ·(i + a)/(i + 1)`, whose product is `Γ(i + a)/(Γ(1 + a)·Γ(i + 1)) ~ i^(a−1)/Γ(1 + a)`; the
/// closed form depends on the pass index alone, so any subset of passes can be rendered on its own.
#[must_use]
pub fn area_scale_for_pass(pass: u32) -> f32 {
    (f64::from(pass) + 1.0).powf(PROGRESSIVE_AREA_EXPONENT - 1.0) as f32
}

impl RenderSettings {
    /// The settings the scene file asks for (already checked by the scene loader), with the defaults of
    /// [`crate::scene::settings::defaults`] where it is silent: one pass of `samples_per_pixel`, no time
    /// limit.
    #[must_use]
    pub fn from_scene(scene: &Scene) -> Self {
        let integ = &scene.integrator;
        let caus = &integ.caustics;
        let pixels = scene.camera.crop().area();
        RenderSettings {
            spp: integ.samples_per_pixel,
            pass_spp: u32::MAX,
            time_limit: None,
            seed: integ.seed,
            estimator: caus.estimator,
            photons: match (caus.photons, caus.caustic_photons) {
                (Some(n), _) => PhotonBudget::Emitted(n),
                (None, Some(m)) => PhotonBudget::Stored(m),
                (None, None) => PhotonBudget::Emitted(defaults::photons(pixels)),
            },
            knn: caus.knn,
            max_radius: caus.max_radius.unwrap_or_else(|| Self::default_max_radius(scene, caus.knn)),
            round_seconds: defaults::ROUND_SECONDS,
            aovs: integ.aovs.clone(),
        }
    }

    /// The search-radius cap of a scene that gives none, for k = `knn` (method.md §3.2): from the pixel
    /// footprint where the delta objects' caustics land ([`defaults::max_radius`]).
    #[must_use]
    pub fn default_max_radius(scene: &Scene, knn: u32) -> f32 {
        let footprint = scene.camera.pixel_footprint_beyond(scene.delta_bounds());
        defaults::max_radius(footprint, knn, scene.bounds.bounding_sphere().1)
    }

    /// The film this render fills: the camera's, with a channel per AOV value.
    pub fn film(&self, camera: &crate::camera::Camera) -> Result<Film, FilmError> {
        Ok(Film::for_camera(camera)?.with_aov_channels(self.aovs.channel_count()))
    }

    /// Samples per pixel of a full pass: `pass_spp`, at least 1 and (without a time limit) at most `spp`.
    #[must_use]
    pub fn effective_pass_spp(&self) -> u32 {
        if self.time_limit.is_some() {
            self.pass_spp.max(1)
        } else {
            self.pass_spp.clamp(1, self.spp.max(1))
        }
    }

    /// The number of passes of a render with a fixed sample count, ⌈spp / pass spp⌉ (the last pass takes
    /// the remainder); `None` with a time limit, where it depends on the time.
    #[must_use]
    pub fn pass_count(&self) -> Option<u32> {
        match self.time_limit {
            Some(_) => None,
            None => Some(self.spp.div_ceil(self.effective_pass_spp())),
        }
    }
}

/// A render that could not run to the end (both are internal limits, not user errors).
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error("photon map: {0}")]
    PhotonMap(#[from] KdTreeError),
    #[error("film: {0}")]
    Film(#[from] FilmError),
}

/// Why the photon pass (or another phase) did not run.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SkippedPhase {
    pub phase: String,
    pub reason: String,
}

/// Figures after each pass, for progress lines and error-vs-time logs.
#[derive(Clone, Debug, Serialize)]
pub struct PassInfo {
    /// The pass the image is at (from 1): counting the one under way when a round of it ended.
    pub pass: u32,
    /// Rounds finished so far, over all passes (a round adds samples to every pixel: [`round`]).
    pub round: u32,
    /// Whether the pass ended with this round (its photon map and all its samples are in the image).
    pub pass_done: bool,
    /// Seconds of rendering so far (photon passes and eye passes), *excluding* the time spent in the
    /// `on_pass` callbacks, so that error-vs-time curves measure the renderer, not their own evaluation.
    pub seconds: f64,
    pub spp: u32,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    /// The render's statistics so far (`spp`, `passes` and `rounds` those of the film as it is).
    #[serde(skip)]
    pub phases: RenderPhaseStats,
}

/// Statistics of a render's phases (method.md §5).
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct RenderPhaseStats {
    pub spp: u32,
    pub passes: u32,
    /// Rounds rendered: after each, the film is the whole frame at the samples per pixel it says ([`round`]).
    pub rounds: u32,
    pub seconds_render: f64,
    pub seconds_photons: f64,
    pub seconds_kdtree: f64,
    pub rays_traced: u64,
    pub knn_queries: u64,
    /// k-NN searches for ΔA alone, by T2 at vertices that skipped their density estimate (method.md §3.1).
    pub knn_area_queries: u64,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    pub photon_bytes: u64,
    pub photon_chains_capped: u64,
    /// The smallest and largest q₁ that reached the MIS function (`mis` only; [`Q1Range`]).
    pub mis_q1_range: Option<[f32; 2]>,
    /// Passes this process rendered (fewer than `passes` when it rendered a share of the passes).
    pub passes_rendered: u32,
    pub partial: bool,
    /// Serialised as an object `{phase: reason}`, the one form of every stats JSON.
    #[serde(serialize_with = "skipped_as_map", deserialize_with = "skipped_from_map")]
    pub skipped: Vec<SkippedPhase>,
}

/// `[{phase, reason}]` as `{phase: reason}`.
fn skipped_as_map<S: serde::Serializer>(skipped: &[SkippedPhase], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_map(skipped.iter().map(|s| (&s.phase, &s.reason)))
}

/// `{phase: reason}` back to `[{phase, reason}]` (a part file's stats are read by `merge`), in the order
/// written.
fn skipped_from_map<'de, D: serde::Deserializer<'de>>(deserializer: D) -> Result<Vec<SkippedPhase>, D::Error> {
    struct Visitor;
    impl<'de> serde::de::Visitor<'de> for Visitor {
        type Value = Vec<SkippedPhase>;
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("an object {phase: reason}")
        }
        fn visit_map<A: serde::de::MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut v = Vec::new();
            while let Some((phase, reason)) = map.next_entry::<String, String>()? {
                v.push(SkippedPhase { phase, reason });
            }
            Ok(v)
        }
    }
    deserializer.deserialize_map(Visitor)
}

/// Which passes and tiles one process renders: all of them, or one part's share (see [`part`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Share {
    All,
    /// The passes `p` with `p mod count == index`, every tile.
    Passes { index: u32, count: u32 },
    /// Every pass, the tiles `t` (scan order of [`Film::tiles`]) with `t mod count == index`.
    Tiles { index: u32, count: u32 },
}

impl Share {
    /// Whether pass `pass` (from 0) is rendered.
    #[must_use]
    pub fn takes_pass(&self, pass: u32) -> bool {
        match *self {
            Share::Passes { index, count } => pass % count.max(1) == index,
            _ => true,
        }
    }

    /// Whether tile `tile` (index in scan order) is rendered.
    #[must_use]
    pub fn takes_tile(&self, tile: usize) -> bool {
        match *self {
            Share::Tiles { index, count } => tile % count.max(1) as usize == index as usize,
            _ => true,
        }
    }
}

/// Whether a caustic photon pass is needed, with the reason when it is not (method.md §1: no delta
/// BSDF means no caustic path; no photon-emitting light means no photon; method.md §2.1: a `max_depth`
/// below 3 leaves no room for a caustic path `L S x`, seen from the camera at depth 1).
pub fn photon_pass_needed(scene: &Scene, estimator: Estimator) -> Result<(), String> {
    if estimator == Estimator::Pt {
        return Err("estimator pt uses no photons".into());
    }
    if crate::photon::longest_chain(1, scene.integrator.max_segments()) == 0 {
        return Err(format!("max_depth {} leaves no room for a caustic path (at least 3 segments)", scene.integrator.max_depth));
    }
    if !scene.has_delta_bsdf() {
        return Err("no delta surface in the scene, so no caustic path exists".into());
    }
    if !scene.lights.lights().iter().any(crate::photon::light_emits_photons) {
        return Err("no area light or environment map emits photons".into());
    }
    Ok(())
}

/// Renders `scene` into `film`. `cancel` is polled per tile and every few photons of a photon pass
/// (Ctrl-C; an interrupted photon pass ends the render, marked partial); the time limit also stops a
/// photon pass (the first pass then renders with the photons traced so far); `on_pass` sees the film after
/// every round (the whole frame: [`round`]) and so after every pass; `on_tile` gets the number of samples
/// of each tile's round (progress bars).
///
/// Time spent inside `on_pass` (error evaluation, logs) is not rendering: it is left out of
/// [`PassInfo::seconds`] and of the time limit, so a render with `--reference` renders as long as one
/// without.
pub fn render(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &RenderSettings,
    film: &mut Film,
    cancel: &AtomicBool,
    on_pass: impl FnMut(&Film, &PassInfo),
    on_tile: &(dyn Fn(u64) + Sync),
) -> Result<RenderPhaseStats, RenderError> {
    render_share(scene, accel, settings, Share::All, film, cancel, on_pass, on_tile)
}

/// [`render`] of the passes and tiles `share` takes (`on_pass` is called after each pass rendered).
#[allow(clippy::too_many_arguments)]
pub fn render_share(
    scene: &Scene,
    accel: &dyn Accel,
    settings: &RenderSettings,
    share: Share,
    film: &mut Film,
    cancel: &AtomicBool,
    mut on_pass: impl FnMut(&Film, &PassInfo),
    on_tile: &(dyn Fn(u64) + Sync),
) -> Result<RenderPhaseStats, RenderError> {
    let start = Instant::now();
    if film.aov_channels() != settings.aovs.channel_count() {
        return Err(FilmError::AovMismatch { film: film.aov_channels(), other: settings.aovs.channel_count() }.into());
    }
    let aov_tracer = aov::AovTracer::new(scene, accel, &settings.aovs);
    let mut stats = RenderPhaseStats::default();
    let mut q1_range = Q1Range::default();
    let photons_needed = photon_pass_needed(scene, settings.estimator);
    if let Err(reason) = &photons_needed {
        stats.skipped.push(SkippedPhase { phase: "caustic photon pass".into(), reason: reason.clone() });
    }
    if !scene.lights.has_env() {
        stats.skipped.push(SkippedPhase { phase: "environment importance sampling".into(), reason: "no environment map in the scene".into() });
    }
    let pass_spp = settings.effective_pass_spp();
    let tiles: Vec<_> = film.tiles(TILE_SIZE).into_iter().enumerate().filter(|(t, _)| share.takes_tile(*t)).map(|(_, tile)| tile).collect();
    let width = u64::from(film.width());
    let mut spp_done: u32 = 0;
    let mut pass: u32 = 0;
    let mut callback_seconds = 0.0f64;
    let mut rounds: u32 = 0;
    loop {
        let this_pass = match settings.time_limit {
            Some(_) => pass_spp,
            None => pass_spp.min(settings.spp.saturating_sub(spp_done)),
        };
        if this_pass == 0 || cancel.load(Ordering::Relaxed) {
            break;
        }
        if !share.takes_pass(pass) {
            spp_done += this_pass;
            pass += 1;
            continue;
        }
        // Photon pass for this render pass.
        let mut map: Option<PhotonMap> = None;
        if photons_needed.is_ok() {
            // Ctrl-C and the time limit stop the photon pass too (polled every few photons).
            let spent_before = callback_seconds;
            let stop = || {
                cancel.load(Ordering::Relaxed) || settings.time_limit.is_some_and(|limit| start.elapsed().as_secs_f64() - spent_before >= limit)
            };
            let (m, ps): (PhotonMap, PhotonPassStats) = trace_photons(scene, accel, settings.photons, settings.seed, u64::from(pass), &stop)?;
            if ps.stopped && (cancel.load(Ordering::Relaxed) || spp_done > 0) {
                // Interrupted, or out of time after at least one whole pass: this pass is not rendered.
                stats.seconds_photons += ps.seconds_trace;
                stats.partial |= cancel.load(Ordering::Relaxed);
                break;
            }
            // Out of time in the first photon pass: the photons traced so far (N = their number) serve
            // the one eye pass, so that a time-limited render always has an image.
            stats.seconds_photons += ps.seconds_trace;
            stats.seconds_kdtree += ps.seconds_kdtree;
            stats.photons_emitted += ps.emitted;
            stats.photons_stored += ps.stored;
            stats.photon_bytes = stats.photon_bytes.max(ps.bytes);
            stats.photon_chains_capped += ps.chains_capped;
            stats.rays_traced += ps.rays;
            map = (ps.emitted > 0).then_some(m);
        }
        let caustics = CausticEstimator::new(settings.estimator, map.as_ref(), settings.knn as usize, settings.max_radius, scene.bounds.bounding_sphere().1)
            .with_area_scale(area_scale_for_pass(pass));
        let tracer = PathTracer::new(scene, accel, caustics, this_pass as f32);
        let ctx = RoundContext { scene, tracer: &tracer, aovs: aov_tracer.as_ref(), seed: settings.seed, width, pass_start: spp_done };
        // With a time limit the eye pass stops at the limit, from the second pass on (the first always
        // completes, so that every pixel has samples): tiles not started by then are left out.
        let deadline = match settings.time_limit {
            Some(limit) if pass > 0 => Some(Instant::now() + Duration::from_secs_f64((limit - (start.elapsed().as_secs_f64() - callback_seconds)).max(0.0))),
            _ => None,
        };
        // The pass's eye samples in rounds over the whole frame ([`round`]); a time-limited pass is one.
        let mut states: Vec<TileState> = tiles.iter().map(|&tile| TileState::new(film, tile)).collect();
        let mut round_done: u32 = 0;
        let mut last_round: Option<(u32, f64)> = None;
        let mut merge_seconds = 0.0f64;
        let mut cut = false;
        loop {
            let round_spp = if settings.time_limit.is_some() { this_pass } else { next_round_spp(this_pass, round_done, last_round, settings.round_seconds, merge_seconds) };
            let (from, to) = (spp_done + round_done, spp_done + round_done + round_spp);
            let t_round = Instant::now();
            let results: Vec<Option<PathStats>> = states
                .par_iter_mut()
                .map(|state| {
                    if cancel.load(Ordering::Relaxed) || deadline.is_some_and(|d| Instant::now() >= d) {
                        return None;
                    }
                    let ps = trace_round(&ctx, state, from, to);
                    on_tile(state.tile().area() * u64::from(round_spp));
                    Some(ps)
                })
                .collect();
            let round_seconds = t_round.elapsed().as_secs_f64();
            // A round left unfinished by Ctrl-C is not merged: the film stays whole, at the rounds before.
            // A (one-round) pass cut by the time limit keeps its finished tiles (the film counts samples per
            // pixel, or their filter weights, so every pixel stays the weighted mean of the samples that
            // reached it); it is the last one, reported to `on_pass` if any tile finished, and its samples
            // are not counted in `spp` (they cover only some pixels).
            let unfinished = results.iter().any(Option::is_none);
            let finished_tiles = results.iter().flatten().count();
            let cancelled = unfinished && cancel.load(Ordering::Relaxed);
            let t_merge = Instant::now();
            if !cancelled {
                let more = !unfinished && round_done + round_spp < this_pass;
                for (state, ps) in states.iter_mut().zip(&results) {
                    if let Some(ps) = ps {
                        state.merge_into(film, more)?;
                        stats.rays_traced += ps.rays;
                        stats.knn_queries += ps.knn_queries;
                        stats.knn_area_queries += ps.knn_area_queries;
                        q1_range.merge(&ps.q1);
                    }
                }
            }
            merge_seconds = t_merge.elapsed().as_secs_f64();
            stats.mis_q1_range = q1_range.get();
            stats.seconds_render += t_round.elapsed().as_secs_f64();
            if cancelled || (unfinished && finished_tiles == 0) {
                stats.partial |= cancelled;
                cut = true;
                break;
            }
            if !unfinished {
                round_done += round_spp;
            }
            last_round = Some((round_spp, round_seconds));
            rounds += 1;
            let pass_over = round_done == this_pass || unfinished;
            if pass_over {
                // The pass is done (or cut by the time limit): counted before it is reported.
                spp_done += round_done;
                round_done = 0;
                pass += 1;
                stats.passes_rendered += 1;
            }
            let info = PassInfo {
                pass: pass + u32::from(round_done > 0),
                round: rounds,
                pass_done: round_done == 0,
                seconds: start.elapsed().as_secs_f64() - callback_seconds,
                spp: spp_done + round_done,
                photons_emitted: stats.photons_emitted,
                photons_stored: stats.photons_stored,
                phases: RenderPhaseStats { spp: spp_done + round_done, passes: pass + u32::from(round_done > 0), rounds, ..stats.clone() },
            };
            let t_callback = Instant::now();
            on_pass(film, &info);
            callback_seconds += t_callback.elapsed().as_secs_f64();
            if unfinished {
                cut = true;
            }
            if pass_over {
                break;
            }
        }
        if cut {
            // Ctrl-C after some rounds of the pass: they are whole frames, counted in spp and in the image's
            // passes, but not in `passes_rendered` (passes whole, all their samples in: what a cut part of a
            // split render reports as its finished share).
            if round_done > 0 {
                spp_done += round_done;
                pass += 1;
            }
            break;
        }
        if let Some(limit) = settings.time_limit {
            if start.elapsed().as_secs_f64() - callback_seconds >= limit {
                break;
            }
        }
    }
    if cancel.load(Ordering::Relaxed) {
        stats.partial = true;
    }
    stats.spp = spp_done;
    stats.passes = pass;
    stats.rounds = rounds;
    Ok(stats)
}

/// A finished render as the library's callers (tests, `converge`) want it.
#[derive(Clone, Debug)]
pub struct RenderedImage {
    /// The crop window's pixels (the film's image).
    pub image: crate::film::Image,
    pub stats: RenderPhaseStats,
    /// Wall-clock seconds of [`render`] (accel build excluded).
    pub seconds: f64,
}

/// Errors of [`render_image`].
#[derive(Debug, thiserror::Error)]
pub enum RenderImageError {
    #[error(transparent)]
    Accel(#[from] crate::error::AccelError),
    #[error(transparent)]
    Render(#[from] RenderError),
    #[error(transparent)]
    Film(#[from] FilmError),
}

/// Builds `backend` over the scene and renders it with `settings` on the current rayon pool, no
/// progress, no cancellation: the one-call form used by tests and reports.
pub fn render_image(scene: &Scene, backend: crate::accel::BackendKind, settings: &RenderSettings) -> Result<RenderedImage, RenderImageError> {
    let accel = crate::accel::build_accel(backend, &scene.geometry())?;
    let mut film = settings.film(&scene.camera)?;
    let cancel = AtomicBool::new(false);
    let t = Instant::now();
    let stats = render(scene, accel.as_ref(), settings, &mut film, &cancel, |_, _| {}, &|_| {})?;
    Ok(RenderedImage { image: film.image(), stats, seconds: t.elapsed().as_secs_f64() })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The stats' `skipped` is an object in JSON, and reads back (a part file carries its stats to `merge`).
    #[test]
    fn phase_stats_round_trip_through_json_with_skipped_phases() {
        let mut stats = RenderPhaseStats { spp: 3, ..RenderPhaseStats::default() };
        stats.skipped.push(SkippedPhase { phase: "caustic photon pass".into(), reason: "no delta surface".into() });
        stats.skipped.push(SkippedPhase { phase: "environment importance sampling".into(), reason: "no env map".into() });
        let json = serde_json::to_string(&stats).unwrap();
        assert!(json.contains(r#""skipped":{"caustic photon pass":"no delta surface","#), "{json}");
        let back: RenderPhaseStats = serde_json::from_str(&json).unwrap();
        assert_eq!(serde_json::to_string(&back).unwrap(), json);
    }

    /// The schedule of method.md §6: s₀ = 1, strictly decreasing, and the rate of Knaus & Zwicker's
    /// recursion r²ᵢ₊₁ = r²ᵢ·(i + a)/(i + 1): the ratio of the two tends to the constant Γ(1 + a).
    #[test]
    fn area_schedule_follows_knaus_zwicker() {
        assert_eq!(area_scale_for_pass(0), 1.0);
        let a = PROGRESSIVE_AREA_EXPONENT;
        let mut kz = 1.0f64;
        let mut previous = 1.0f32;
        let mut ratios = Vec::new();
        for p in 1..=100_000u32 {
            kz *= (f64::from(p) + a) / (f64::from(p) + 1.0);
            let s = area_scale_for_pass(p);
            assert!(s < previous && s > 0.0, "pass {p}: {s} after {previous}");
            previous = s;
            if p == 1_000 || p == 100_000 {
                ratios.push(kz / f64::from(s));
            }
        }
        // Γ(1 + 2/3) = 0.9027...; the product uses (i + a)/(i + 1) from i = 1, hence Γ(2)/Γ(1 + a) times
        // p^(a−1): kz/s → 1/Γ(1 + a) = 1.1078.
        for r in ratios {
            assert!((r - 1.1078).abs() < 0.01, "KZ product / closed form = {r}");
        }
    }
}
