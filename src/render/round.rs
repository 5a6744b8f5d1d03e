//! Rounds: a pass's eye samples traced over the whole frame a few samples per pixel at a time, so that the
//! film after every round is the whole frame at the samples per pixel it says (Ctrl-C, SIGTERM, a
//! checkpoint or a look at the image in between find no black tiles).
//!
//! A pass of `pass_spp` samples (one photon map, α = `pass_spp`: method.md §6.1) runs in rounds: first one
//! sample per pixel (a whole image soon), then rounds of about `round_seconds` (`render --round-seconds`,
//! [`crate::scene::settings::defaults::ROUND_SECONDS`] by default) each at the rate of the
//! round before (at least one sample, at most what the pass has left), and at least [`MERGE_FACTOR`]
//! times the last round's merge. A time-limited render's passes are short (4 spp by default): each is
//! one round.
//!
//! **The same image as one round.** Everything a tile's samples read from earlier samples of the pass is
//! kept in its [`TileState`] from one round to the next: the pixels' running sums for the gather's
//! roulette, each pixel's memory of recent searches, and the tile buffer, whose f64 sums go on adding the
//! pass's samples in the order one round would. After a round the film gets what the buffer gained since
//! its last merge (`Film::merge_tile_since`, exact), so after the last round the film holds exactly the
//! sums of one merge of the whole pass: a finished render is bit-identical however its passes were cut
//! into rounds (and to the renders before rounds existed). The schedule may depend on timing; the image
//! does not.
//!
//! **AOVs** (`super::aov`): with AOVs each wave's camera rays are traced once more for them, and each
//! sample's values go into the tile buffer with its radiance; without, nothing of it runs.
//!
//! **Cost.** Per pixel (pixels of the crop window, for the pass's duration): the copy of the tile buffer
//! merged last (40 B, 72 B more with a wide filter), the running sum (16 B), and with a photon map the
//! search memory (`GatherMemory`, ~190 B); counted by `render::memory`. Per round, one merge of every tile.

use super::aov::AovTracer;
use crate::film::{Film, Tile, TileBuffer};
use crate::integrator::{EyePath, GatherBuffers, GatherMemory, GatherScratch, PathStats, PathTracer, Wave};
use crate::math::{Vec2, Vec3};
use crate::sampler::Sampler;
use crate::scene::Scene;

/// A round lasts at least this many times the last round's merge (about 60 ns a pixel, single-threaded),
/// so that on a very large film the merges stay within a percent of the time.
pub const MERGE_FACTOR: f64 = 100.0;

/// Samples per pixel of the next round of a pass of `pass_spp` samples of which `done` are traced: 1 for
/// the first round (`last` = `None`); then what takes `round_seconds` (or [`MERGE_FACTOR`] times
/// `merge_seconds`, if longer) at the rate of the last round, which traced `last.0` samples in `last.1`
/// seconds; at least 1 and at most what the pass has left (0 only when the pass is done).
#[must_use]
pub fn next_round_spp(pass_spp: u32, done: u32, last: Option<(u32, f64)>, round_seconds: f64, merge_seconds: f64) -> u32 {
    let left = pass_spp.saturating_sub(done);
    let timed = match last {
        None => 1,
        Some((spp, seconds)) if seconds > 0.0 => {
            let target = round_seconds.max(MERGE_FACTOR * merge_seconds);
            (target * f64::from(spp) / seconds).floor().clamp(1.0, f64::from(u32::MAX)) as u32
        }
        Some(_) => u32::MAX,
    };
    timed.min(left)
}

/// What one tile carries from one round of a pass to the next (see the module documentation).
pub struct TileState {
    tile: Tile,
    /// The pass's samples of the tile so far, in their order.
    pub buf: TileBuffer,
    /// `buf` as it was when last merged into the film (`None` before the first merge).
    pub merged: Option<TileBuffer>,
    /// Per pixel, the sum and count of its finite samples so far in this pass.
    sums: Vec<(Vec3, u32)>,
    /// Per pixel its memory of recent searches (with a photon map, filled by the pass's first samples),
    /// else one unused memory.
    memories: Vec<GatherMemory>,
}

impl TileState {
    /// A tile at the start of a pass.
    #[must_use]
    pub fn new(film: &Film, tile: Tile) -> Self {
        let pixels = tile.area() as usize;
        TileState { tile, buf: film.tile_buffer(tile), merged: None, sums: vec![(Vec3::ZERO, 0); pixels], memories: Vec::new() }
    }

    #[must_use]
    pub fn tile(&self) -> Tile {
        self.tile
    }

    /// The film gets what the buffer gained since the last merge; with `more` rounds to come, the buffer
    /// is kept as merged.
    pub fn merge_into(&mut self, film: &mut Film, more: bool) -> Result<(), crate::film::FilmError> {
        film.merge_tile_since(&self.buf, self.merged.as_ref())?;
        if more {
            match &mut self.merged {
                Some(m) => m.clone_from(&self.buf),
                None => self.merged = Some(self.buf.clone()),
            }
        }
        Ok(())
    }
}

/// What every tile of a round shares: the tracer of the pass and where the pass's samples start.
pub struct RoundContext<'a> {
    pub scene: &'a Scene,
    pub tracer: &'a PathTracer<'a>,
    /// The AOVs' tracer (`None`: no AOV; the film then has no AOV channels).
    pub aovs: Option<&'a AovTracer<'a>>,
    pub seed: u64,
    /// The film's full width (pixel keys of the sampler).
    pub width: u64,
    /// Index of the pass's first sample (sample indices count over the whole render).
    pub pass_start: u32,
}

/// Traces samples `from..to` (indices over the whole render) of every pixel of the tile into its state.
pub fn trace_round(ctx: &RoundContext<'_>, state: &mut TileState, from: u32, to: u32) -> PathStats {
    let (scene, tracer, seed, width) = (ctx.scene, ctx.tracer, ctx.seed, ctx.width);
    let tile = state.tile;
    // Sample `s` of pixel (x, y): its camera ray, its sampler (past the pixel position and, for a thin lens,
    // the lens sample: Mitsuba's order) and its position in the pixel (uniform, as Mitsuba's
    // `render_sample`; where a wide filter weighs it).
    let camera_sample = |x: u32, y: u32, s: u32| {
        let mut sampler = Sampler::for_pixel(seed, u64::from(y) * width + u64::from(x), u64::from(s));
        let j = sampler.next_2d();
        let ray = scene.camera.sample_ray(x as f32 + j.x, y as f32 + j.y, &mut sampler);
        (ray, sampler, j)
    };
    let TileState { buf, sums, memories, .. } = state;
    let mut ps = PathStats::default();
    // With AOVs: each wave's camera rays, their hits and values (`super::aov`), per pixel.
    let (mut aov_rays, mut aov_hits, mut aov_values) = (Vec::new(), Vec::new(), Vec::new());
    let aov_n = ctx.aovs.map_or(0, AovTracer::channels);
    // The gather's buffers (they carry nothing from one search to the next).
    let mut buffers = GatherBuffers::default();
    // The tile's pixels are traced one wave per sample index (`PathTracer::trace_wave`: their rays in
    // Embree packets), on one thread, in the same order in every run.
    let pixels: Vec<(u32, u32)> = (tile.y0..tile.y1).flat_map(|y| (tile.x0..tile.x1).map(move |x| (x, y))).collect();
    let mut wave = Wave::default();
    let mut paths = Vec::with_capacity(pixels.len());
    // Per pixel, the current sample's position in the pixel.
    let mut offsets = vec![Vec2::ZERO; pixels.len()];
    // With a photon map the gather's roulette reads earlier samples (method.md §3.1): the mean of the
    // pixel's finite samples so far in this pass (until it has one, the previous pixel's), and the memory
    // of recent searches. So a pixel's first sample runs alone, in pixel order on the tile's memory, as one
    // path at a time would; then each pixel keeps a copy of that memory (~190 bytes), and its later
    // samples' searches follow one another in it as they did when a pixel's samples ran one after another
    // (without this, a wave's searches run a pixel apart: +46 % searches on teapot-glossy). Without a
    // photon map nothing is read.
    let reads = tracer.reads_earlier_samples();
    // A sample's radiance (and AOV values, if any) into the film and, where finite, into its pixel's sum.
    let mut record = |(x, y): (u32, u32), sum: &mut (Vec3, u32), offset: Vec2, l: Vec3, aov: &[f32]| {
        if l.is_finite() {
            *sum = (sum.0 + l, sum.1 + 1);
        }
        if aov.is_empty() {
            buf.add_at(x, y, offset, l);
        } else {
            buf.add_at_aov(x, y, offset, l, aov);
        }
    };
    let mut from = from;
    if from == ctx.pass_start {
        let mut memory = GatherMemory::default();
        memories.clear();
        if reads {
            memories.reserve(pixels.len());
            let mut mean = Vec3::ZERO;
            for (&(x, y), sum) in pixels.iter().zip(sums.iter_mut()) {
                let (ray, sampler, offset) = camera_sample(x, y, from);
                if let Some(a) = ctx.aovs {
                    aov_rays.clear();
                    aov_rays.push(ray);
                    ps.rays += a.trace(&aov_rays, &mut aov_hits, &mut aov_values);
                }
                let l = tracer.li(ray, sampler, mean, &mut ps, &mut GatherScratch::new(&mut buffers, &mut memory));
                record((x, y), sum, offset, l, &aov_values);
                if sum.1 > 0 {
                    mean = sum.0;
                }
                memories.push(memory);
            }
            from += 1;
        } else {
            memories.push(memory);
        }
    }
    for s in from..to {
        paths.clear();
        aov_rays.clear();
        let mut mean = Vec3::ZERO;
        paths.extend(pixels.iter().zip(sums.iter()).zip(&mut offsets).map(|((&(x, y), &(sum, n)), offset)| {
            if n > 0 {
                mean = sum / n as f32;
            }
            let (ray, sampler, j) = camera_sample(x, y, s);
            *offset = j;
            if aov_n > 0 {
                aov_rays.push(ray);
            }
            EyePath::new(ray, sampler, mean)
        }));
        if let Some(a) = ctx.aovs {
            ps.rays += a.trace(&aov_rays, &mut aov_hits, &mut aov_values);
        }
        tracer.trace_wave(&mut paths, &mut wave, &mut ps, &mut buffers, memories);
        for (i, (((&pixel, sum), path), &offset)) in pixels.iter().zip(sums.iter_mut()).zip(&paths).zip(&offsets).enumerate() {
            record(pixel, sum, offset, path.radiance(), aov_values.get(i * aov_n..(i + 1) * aov_n).unwrap_or_default());
        }
    }
    ps
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One sample first, then 10 s (or MERGE_FACTOR merges) at the last round's rate, cut to the
    /// pass's remainder, never 0 while samples are left.
    #[test]
    fn rounds_take_one_sample_then_the_time() {
        assert_eq!(next_round_spp(64, 0, None, 10.0, 0.0), 1);
        // The whole pass fits in ROUND_SECONDS: the rest in one round.
        assert_eq!(next_round_spp(64, 1, Some((1, 0.1)), 10.0, 0.001), 63);
        // 4 spp took 8 s: 5 spp take 10 s.
        assert_eq!(next_round_spp(1000, 8, Some((4, 8.0)), 10.0, 0.01), 5);
        // The merge took 0.2 s: rounds of 20 s.
        assert_eq!(next_round_spp(1000, 8, Some((4, 8.0)), 10.0, 0.2), 10);
        // One sample takes longer than the round: still one per round.
        assert_eq!(next_round_spp(1000, 100, Some((1, 60.0)), 10.0, 0.0), 1);
        assert_eq!(next_round_spp(64, 64, Some((1, 1.0)), 10.0, 0.0), 0);
        let mut done = 0;
        let mut sizes = Vec::new();
        let mut last = None;
        while done < 100 {
            let n = next_round_spp(100, done, last, 10.0, 0.0);
            sizes.push(n);
            done += n;
            last = Some((n, 0.3 * f64::from(n)));
        }
        assert_eq!(sizes, [1, 33, 33, 33]);
    }
}
