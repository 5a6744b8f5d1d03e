//! Whether Embree's packet and stream queries pay on this machine: the incoherent, shadow and primary ray sets
//! traced one ray per call (`rtcIntersect1` / `rtcOccluded1`), in packets of 4, 8 and 16
//! (`rtcIntersect4/8/16`, `rtcOccluded4/8/16`) and, with Embree 3, as one stream per chunk
//! (`rtcIntersect1M`); and, one ray per call, on the same scene built without `RTC_SCENE_FLAG_ROBUST` (as
//! Mitsuba 3 builds its own; `EmbreeAccel::without_robust`), which shows what the renderer's watertight
//! Embree costs on the scene. The variants are timed in interleaved runs (run 1 of each, then run 2, …) on
//! the same chunks and threads; the answers of every variant are compared with one call per ray (for the
//! scene without ROBUST, whose triangle test rounds differently, by the primitive hit and the occlusion).

#[cfg(feature = "embree")]
use rayon::prelude::*;
use rayon::ThreadPool;

use super::rays::RaySets;
use super::BatchingRate;

/// Interleaved timed runs of every variant (more than the other measurements' 3: the ratios between
/// variants are the result, and a shared machine's load moves single runs by ±20 %).
#[cfg(feature = "embree")]
const RUNS: usize = 7;

/// The name of the single-ray variant on the scene built without ROBUST.
#[cfg(feature = "embree")]
const NO_ROBUST: &str = "norobust";
use crate::mesh::TriangleMesh;

#[cfg(feature = "embree")]
pub(super) fn rates(pool: &ThreadPool, mesh: &TriangleMesh, sets: &RaySets) -> anyhow::Result<Vec<BatchingRate>> {
    use crate::accel::embree::{Batching, EmbreeAccel};
    use super::rays::CHUNK;
    use crate::accel::Hit;
    use crate::math::Ray;
    use std::time::Instant;

    let robust = EmbreeAccel::new(&mesh.positions, &mesh.indices)?;
    let fast = EmbreeAccel::without_robust(&mesh.positions, &mesh.indices)?;
    // (scene, batching, name): the renderer's scene in every batching, then single rays without ROBUST.
    let variants: Vec<(&EmbreeAccel, Batching, &'static str)> =
        Batching::AVAILABLE.iter().map(|&b| (&robust, b, b.name())).chain([(&fast, Batching::Single, NO_ROBUST)]).collect();
    let mut closest: Vec<Vec<Option<Hit>>> = variants.iter().map(|_| vec![None; sets.incoherent.len()]).collect();
    let mut primary: Vec<Vec<Option<Hit>>> = variants.iter().map(|_| vec![None; sets.primary.len()]).collect();
    let mut shadow: Vec<Vec<bool>> = variants.iter().map(|_| vec![false; sets.shadow.len()]).collect();
    let mut seconds: Vec<[Vec<f64>; 3]> = variants.iter().map(|_| [Vec::new(), Vec::new(), Vec::new()]).collect();
    // Seconds to answer `rays` into `out`, chunk by chunk on the pool's threads.
    fn timed<T: Send>(pool: &ThreadPool, rays: &[Ray], out: &mut [T], query: impl Fn(&[Ray], &mut [T]) + Sync) -> f64 {
        let start = Instant::now();
        pool.install(|| out.par_chunks_mut(CHUNK).zip(rays.par_chunks(CHUNK)).for_each(|(out, rays)| query(rays, out)));
        start.elapsed().as_secs_f64()
    }
    for _ in 0..RUNS {
        for (i, &(accel, batching, _)) in variants.iter().enumerate() {
            let closest_hits = |rays: &[Ray], out: &mut [Option<Hit>]| accel.intersect_batched(rays, out, batching);
            seconds[i][0].push(timed(pool, &sets.incoherent, &mut closest[i], closest_hits));
            seconds[i][2].push(timed(pool, &sets.primary, &mut primary[i], closest_hits));
            if batching != Batching::Stream {
                let occlusion = |rays: &[Ray], out: &mut [bool]| accel.occluded_batched(rays, out, batching);
                seconds[i][1].push(timed(pool, &sets.shadow, &mut shadow[i], occlusion));
            }
        }
    }
    let single = variants.iter().position(|&(_, b, _)| b == Batching::Single).expect("single rays are always offered");
    Ok(variants
        .iter()
        .enumerate()
        .map(|(i, &(_, _, name))| {
            // Bit for bit within the renderer's scene; without ROBUST, by the primitive hit (or none).
            let same = |a: &Option<Hit>, b: &Option<Hit>| if name == NO_ROBUST { a.map(|h| h.prim) == b.map(|h| h.prim) } else { a == b };
            let differ_closest = closest[i].iter().zip(&closest[single]).filter(|(a, b)| !same(a, b)).count()
                + primary[i].iter().zip(&primary[single]).filter(|(a, b)| !same(a, b)).count();
            let has_shadow = !seconds[i][1].is_empty();
            let differ_shadow = if has_shadow { shadow[i].iter().zip(&shadow[single]).filter(|(a, b)| a != b).count() } else { 0 };
            // Speed-up over single rays: the median of the per-run ratios (run r of both variants ran
            // back to back, under about the same load).
            let speedup = |k: usize| super::median(seconds[single][k].iter().zip(&seconds[i][k]).map(|(s, b)| s / b).collect());
            BatchingRate {
                batching: name,
                incoherent: super::mrays(sets.incoherent.len(), super::median(seconds[i][0].clone())),
                shadow: has_shadow.then(|| super::mrays(sets.shadow.len(), super::median(seconds[i][1].clone()))),
                incoherent_vs_single: speedup(0),
                primary: super::mrays(sets.primary.len(), super::median(seconds[i][2].clone())),
                primary_vs_single: speedup(2),
                shadow_vs_single: has_shadow.then(|| speedup(1)),
                differ: differ_closest + differ_shadow,
            }
        })
        .collect())
}

/// Without the `embree` feature there is nothing to batch.
#[cfg(not(feature = "embree"))]
pub(super) fn rates(_pool: &ThreadPool, _mesh: &TriangleMesh, _sets: &RaySets) -> anyhow::Result<Vec<BatchingRate>> {
    Err(crate::error::AccelError::EmbreeNotCompiled.into())
}
