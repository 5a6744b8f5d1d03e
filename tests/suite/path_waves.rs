//! The path tracer's waves (`PathTracer::trace_wave`, what a `pt` render runs): every path of a wave is the
//! path `PathTracer::li` traces alone, one ray per call, bit for bit, with Embree's packets and with the
//! BVH — for waves of every length up to past a packet, paths that escape at once, and long delta chains.

use caustica::accel::{build_accel, BackendKind};
use caustica::integrator::{CausticEstimator, EyePath, GatherBuffers, GatherMemory, GatherState, PathStats, PathTracer, Wave};
use caustica::math::Vec3;
use caustica::photon::{trace_photons, PhotonBudget};
use caustica::sampler::Sampler;
use caustica::scene::Estimator;

use crate::common;

fn backends() -> Vec<BackendKind> {
    let mut kinds = vec![BackendKind::Bvh];
    if cfg!(feature = "embree") {
        kinds.push(BackendKind::Embree);
    }
    kinds
}

#[test]
fn a_wave_traces_each_path_as_li_does() {
    for name in ["cornell-caustics.toml", "teapot-glossy.toml"] {
        let scene = common::load_scene(name);
        for kind in backends() {
            let accel = build_accel(kind, &scene.geometry()).unwrap();
            // `pt`: no photon map, so no search whose order the wave changes.
            let tracer = PathTracer::new(&scene, accel.as_ref(), CausticEstimator::new(Estimator::Pt, None, 50, f32::INFINITY, 1.0), 1.0);
            let (width, height) = (scene.camera.width(), scene.camera.height());
            let mut wave = Wave::default();
            let (mut rays_alone, mut rays_waved) = (0u64, 0u64);
            let mut pixel = 0u64;
            for len in (1..=20).chain([37, 64, 150]) {
                let starts: Vec<(Sampler, caustica::math::Ray)> = (0..len)
                    .map(|i| {
                        // Pixels spread over the film (some see the sky or the light at once), several samples each.
                        pixel = (pixel + 7919) % (u64::from(width) * u64::from(height));
                        let mut sampler = Sampler::for_pixel(5, pixel, i % 3);
                        let j = sampler.next_2d();
                        let (x, y) = ((pixel % u64::from(width)) as f32, (pixel / u64::from(width)) as f32);
                        (sampler.clone(), scene.camera.generate_ray(x + j.x, y + j.y))
                    })
                    .collect();
                let mean = Vec3::splat(0.3);
                let mut paths: Vec<EyePath> = starts.iter().map(|(s, ray)| EyePath::new(*ray, s.clone(), mean)).collect();
                let mut stats = PathStats::default();
                tracer.trace_wave(&mut paths, &mut wave, &mut stats, &mut GatherBuffers::default(), &mut [GatherMemory::default()]);
                rays_waved += stats.rays;
                for ((sampler, ray), path) in starts.iter().zip(&paths) {
                    let mut stats = PathStats::default();
                    let alone = tracer.li(*ray, sampler.clone(), mean, &mut stats, &mut GatherState::default().scratch());
                    rays_alone += stats.rays;
                    assert_eq!(alone.to_array().map(f32::to_bits), path.radiance().to_array().map(f32::to_bits), "{name} {kind:?}, wave of {len}: {alone} alone, {} in the wave", path.radiance());
                }
            }
            assert_eq!(rays_alone, rays_waved, "{name} {kind:?}: rays counted");
            assert!(rays_alone > 1000, "{name}: {rays_alone} rays");
        }
    }
}

/// With a photon map (`mis`, so T1's searches and T2's searches for ΔA both run), paths that each keep
/// their own memory of recent searches (`GatherMemory`, as the render keeps one per pixel) trace in a wave
/// exactly as alone, bit for bit and search for search, though the wave's paths share one set of buffers
/// (`GatherBuffers`) and their searches interleave: the buffers carry nothing from one search to the next.
#[test]
fn a_wave_with_a_photon_map_traces_each_path_as_li_does_with_its_own_memory() {
    for name in ["cornell-caustics.toml", "teapot-glossy.toml"] {
        let scene = common::load_scene(name);
        let accel = build_accel(BackendKind::Bvh, &scene.geometry()).unwrap();
        let (map, _) = trace_photons(&scene, accel.as_ref(), PhotonBudget::Stored(20_000), 3, 0, &|| false).unwrap();
        let caustics = CausticEstimator::new(Estimator::Mis, Some(&map), 50, 0.05 * scene.bounds.bounding_sphere().1, scene.bounds.bounding_sphere().1);
        let tracer = PathTracer::new(&scene, accel.as_ref(), caustics, 4.0);
        let (width, height) = (scene.camera.width(), scene.camera.height());
        let start = |pixel: u64, sample: u64| {
            let mut sampler = Sampler::for_pixel(9, pixel, sample);
            let j = sampler.next_2d();
            let (x, y) = ((pixel % u64::from(width)) as f32, (pixel / u64::from(width)) as f32);
            (scene.camera.generate_ray(x + j.x, y + j.y), sampler)
        };
        // Pixels spread over the film, each with a memory left by its first sample traced alone, as the
        // render's first samples are.
        let pixels: Vec<u64> = (0..256u64).map(|i| (i * 7919) % (u64::from(width) * u64::from(height))).collect();
        let mut state = GatherState::default();
        let memories: Vec<GatherMemory> = pixels
            .iter()
            .map(|&p| {
                let (ray, sampler) = start(p, 0);
                tracer.li(ray, sampler, Vec3::splat(0.3), &mut PathStats::default(), &mut state.scratch());
                state.memory
            })
            .collect();
        let mean = Vec3::splat(0.3);
        let mut wave_memories = memories.clone();
        let mut paths: Vec<EyePath> = pixels.iter().map(|&p| { let (ray, sampler) = start(p, 1); EyePath::new(ray, sampler, mean) }).collect();
        let mut waved = PathStats::default();
        tracer.trace_wave(&mut paths, &mut Wave::default(), &mut waved, &mut GatherBuffers::default(), &mut wave_memories);
        let mut alone_stats = PathStats::default();
        for ((&p, memory), path) in pixels.iter().zip(&memories).zip(&paths) {
            let (ray, sampler) = start(p, 1);
            let mut own = GatherState { memory: *memory, ..GatherState::default() };
            let alone = tracer.li(ray, sampler, mean, &mut alone_stats, &mut own.scratch());
            assert_eq!(alone.to_array().map(f32::to_bits), path.radiance().to_array().map(f32::to_bits), "{name}, pixel {p}: {alone} alone, {} in the wave", path.radiance());
        }
        assert_eq!(alone_stats, waved, "{name}: rays, searches and q1 counted");
        assert!(waved.knn_queries > 20, "{name}: {} searches", waved.knn_queries);
    }
}
