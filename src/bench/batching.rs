//! Whether Embree's packet and stream queries pay on this machine: the incoherent, shadow and primary ray sets
//! traced one ray per call (`rtcIntersect1` / `rtcOccluded1`), in packets of 4, 8 and 16
//! (`rtcIntersect4/8/16`, `rtcOccluded4/8/16`) and, with Embree 3, as one stream per chunk
//! (`rtcIntersect1M`). The variants are timed in interleaved runs (run 1 of each, then run 2, …) on the
//! same chunks and threads; the answers of every variant are compared with one call per ray.

#[cfg(feature = "embree")]
use rayon::prelude::*;
use rayon::ThreadPool;

use super::rays::RaySets;
use super::BatchingRate;

/// Interleaved timed runs of every variant (more than the other measurements' 3: the ratios between
/// variants are the result, and a shared machine's load moves single runs by ±20 %).
#[cfg(feature = "embree")]
const RUNS: usize = 7;
use crate::mesh::TriangleMesh;

#[cfg(feature = "embree")]
pub(super) fn rates(pool: &ThreadPool, mesh: &TriangleMesh, sets: &RaySets) -> anyhow::Result<Vec<BatchingRate>> {
    use crate::accel::embree::{Batching, EmbreeAccel};
    use super::rays::CHUNK;
    use crate::accel::Hit;
    use crate::math::Ray;
    use std::time::Instant;

    let accel = EmbreeAccel::new(&mesh.positions, &mesh.indices)?;
    let variants = Batching::AVAILABLE;
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
        for (i, &batching) in variants.iter().enumerate() {
            let closest_hits = |rays: &[Ray], out: &mut [Option<Hit>]| accel.intersect_batched(rays, out, batching);
            seconds[i][0].push(timed(pool, &sets.incoherent, &mut closest[i], closest_hits));
            seconds[i][2].push(timed(pool, &sets.primary, &mut primary[i], closest_hits));
            if batching != Batching::Stream {
                let occlusion = |rays: &[Ray], out: &mut [bool]| accel.occluded_batched(rays, out, batching);
                seconds[i][1].push(timed(pool, &sets.shadow, &mut shadow[i], occlusion));
            }
        }
    }
    let single = variants.iter().position(|&b| b == Batching::Single).expect("single rays are always offered");
    Ok(variants
        .iter()
        .enumerate()
        .map(|(i, &batching)| {
            let differ_closest = closest[i].iter().zip(&closest[single]).filter(|(a, b)| a != b).count()
                + primary[i].iter().zip(&primary[single]).filter(|(a, b)| a != b).count();
            let has_shadow = !seconds[i][1].is_empty();
            let differ_shadow = if has_shadow { shadow[i].iter().zip(&shadow[single]).filter(|(a, b)| a != b).count() } else { 0 };
            // Speed-up over single rays: the median of the per-run ratios (run r of both variants ran
            // back to back, under about the same load).
            let speedup = |k: usize| super::median(seconds[single][k].iter().zip(&seconds[i][k]).map(|(s, b)| s / b).collect());
            BatchingRate {
                batching: batching.name(),
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
