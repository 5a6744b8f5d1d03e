//! The AOVs' values (`scene::aov`) of a camera ray: what its first hit is.
//!
//! The camera rays of a round are traced a second time for their AOVs, in one batch per wave
//! ([`AovTracer::trace`]), and each sample's values go to the film with its radiance and the same filter
//! weights (`film::TileBuffer::add_at_aov`). The path tracer is not touched: its samples, and so the
//! image, are the same bits with or without AOVs, and a render without AOVs does none of this work. The
//! cost with AOVs is one more primary ray per sample (coherent, in packets) and the shading of its hit.

use crate::accel::{Accel, Hit};
use crate::math::{Ray, Vec3};
use crate::scene::aov::{AovKind, Aovs};
use crate::scene::Scene;

/// Traces camera rays for the AOVs of a render.
pub struct AovTracer<'a> {
    scene: &'a Scene,
    accel: &'a dyn Accel,
    aovs: &'a Aovs,
    channels: usize,
}

impl<'a> AovTracer<'a> {
    /// The tracer of `aovs`; `None` when the list is empty (no work at all).
    #[must_use]
    pub fn new(scene: &'a Scene, accel: &'a dyn Accel, aovs: &'a Aovs) -> Option<Self> {
        (!aovs.is_empty()).then(|| AovTracer { scene, accel, aovs, channels: aovs.channel_count() })
    }

    /// Values per sample.
    #[must_use]
    pub fn channels(&self) -> usize {
        self.channels
    }

    /// The values of `rays` (camera rays) into `values`, [`AovTracer::channels`] per ray, traced in one
    /// batch (`hits` is scratch). Returns the number of rays traced.
    pub fn trace(&self, rays: &[Ray], hits: &mut Vec<Option<Hit>>, values: &mut Vec<f32>) -> u64 {
        hits.clear();
        hits.resize(rays.len(), None);
        self.accel.intersect_many(rays, hits);
        values.clear();
        values.resize(rays.len() * self.channels, 0.0);
        for ((ray, hit), out) in rays.iter().zip(hits.iter()).zip(values.chunks_exact_mut(self.channels.max(1))) {
            self.values(ray, hit.as_ref(), out);
        }
        rays.len() as u64
    }

    /// The values of one camera ray whose closest hit is `hit` into `out` (0 where it escapes, as Mitsuba
    /// zeroes an invalid interaction); the table of `scene::aov` says what each is.
    pub fn values(&self, ray: &Ray, hit: Option<&Hit>, out: &mut [f32]) {
        out.fill(0.0);
        let Some(hit) = hit else { return };
        let scene = self.scene;
        let si = scene.interaction(ray, hit);
        let mut at = 0;
        let mut put = |v: &[f32]| {
            out[at..at + v.len()].copy_from_slice(v);
            at += v.len();
        };
        let xyz = |v: Vec3| [v.x, v.y, v.z];
        for aov in self.aovs.list() {
            match aov.kind {
                AovKind::Albedo => {
                    let wo_local = si.frame.to_local(-ray.dir.normalize());
                    put(&xyz(scene.bsdf_at(&si).diffuse_reflectance(wo_local)));
                }
                // The distance along the ray from the camera (Mitsuba's `si.t` of a unit ray).
                AovKind::Depth => put(&[hit.t * ray.dir.length()]),
                AovKind::Position => put(&xyz(si.p)),
                AovKind::Uv => put(&scene.tex_uv(&si).to_array()),
                AovKind::GeoNormal => put(&xyz(si.ng)),
                AovKind::ShNormal => put(&xyz(si.ns)),
                AovKind::PrimIndex => put(&[scene.shape_of(hit.prim).1 as f32]),
                AovKind::ShapeIndex => put(&[(scene.shape_of(hit.prim).0 + 1) as f32]),
                AovKind::MaterialIndex => put(&[(si.material + 1) as f32]),
            }
        }
    }
}
