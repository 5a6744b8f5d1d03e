//! The path tracer's waves (`PathTracer::trace_wave`, what a `pt` render runs): every path of a wave is the
//! path `PathTracer::li` traces alone, one ray per call, bit for bit, with Embree's packets and with the
//! BVH — for waves of every length up to past a packet, paths that escape at once, and long delta chains.

use caustica::accel::{build_accel, BackendKind};
use caustica::integrator::{CausticEstimator, EyePath, GatherScratch, PathStats, PathTracer, Wave};
use caustica::math::Vec3;
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
            let accel = build_accel(kind, &scene.mesh.positions, &scene.mesh.indices).unwrap();
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
                tracer.trace_wave(&mut paths, &mut wave, &mut stats, &mut [GatherScratch::default()]);
                rays_waved += stats.rays;
                for ((sampler, ray), path) in starts.iter().zip(&paths) {
                    let mut stats = PathStats::default();
                    let alone = tracer.li(*ray, &mut sampler.clone(), mean, &mut stats, &mut GatherScratch::default());
                    rays_alone += stats.rays;
                    assert_eq!(alone.to_array().map(f32::to_bits), path.radiance().to_array().map(f32::to_bits), "{name} {kind:?}, wave of {len}: {alone} alone, {} in the wave", path.radiance());
                }
            }
            assert_eq!(rays_alone, rays_waved, "{name} {kind:?}: rays counted");
            assert!(rays_alone > 1000, "{name}: {rays_alone} rays");
        }
    }
}
