//! Mitsuba's `near_clip` and `far_clip`. Mitsuba's perspective camera starts a primary ray where its depth
//! along the viewing axis is `near_clip` and ends it at depth `far_clip`; caustica's camera has no clip
//! planes (rays start at the camera and are unbounded). A scene may still give them where they change
//! nothing — where every visible point's depth lies in [near_clip, far_clip] — and is refused otherwise,
//! so that a file renders the same image in both programs.
//!
//! A point at distance `d` from the camera seen through the film makes an angle θ with the viewing axis of
//! at most θ_max (the angle of the film's corner rays), so its depth `d·cos θ` lies in `[d·cos θ_max, d]`.
//! With `d_min` the distance from the camera to the nearest triangle (to an instance's world box, a
//! lower bound, for instanced shapes) and `d_max` the distance to the
//! farthest corner of the scene's bounds, no visible point is clipped when
//! `near_clip ≤ d_min·cos θ_max` and `far_clip ≥ d_max`.

use super::error::{ErrorContext, SceneError};
use crate::camera::Camera;
use crate::math::{Aabb, Vec3};
use crate::mesh::TriangleMesh;

/// Checks `near_clip`/`far_clip` (when given) against the scene, as explained in the module docs.
pub(crate) fn check(
    ctx: &ErrorContext,
    camera: &Camera,
    mesh: &TriangleMesh,
    flat: usize,
    instance_boxes: &[Aabb],
    bounds: Aabb,
    near: Option<f32>,
    far: Option<f32>,
) -> Result<(), SceneError> {
    if near.is_none() && far.is_none() {
        return Ok(());
    }
    let (near_key, far_key) = ("sensor.near_clip", "sensor.far_clip");
    if let Some(n) = near {
        ctx.positive(near_key, n, "near_clip")?;
    }
    if let Some(f) = far {
        ctx.positive(far_key, f, "far_clip")?;
        if let Some(n) = near.filter(|&n| f <= n) {
            return Err(ctx.key_error(far_key, format!("far_clip ({f}) must be greater than near_clip ({n})")));
        }
    }
    if flat == 0 && instance_boxes.is_empty() {
        return Ok(());
    }
    let origin = camera.position();
    let (w, h) = (camera.width() as f32, camera.height() as f32);
    let axis = camera.generate_ray(0.5 * w, 0.5 * h).dir;
    let cos_max = [(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)]
        .iter()
        .map(|&(x, y)| camera.generate_ray(x, y).dir.dot(axis))
        .fold(1.0f32, f32::min);
    if let Some(n) = near {
        let d_min = (0..flat)
            .map(|i| point_triangle_distance(origin, mesh.triangle(i)))
            .chain(instance_boxes.iter().map(|b| (b.min - origin).max(origin - b.max).max(Vec3::ZERO).length()))
            .fold(f32::INFINITY, f32::min);
        let limit = d_min * cos_max;
        if n > limit {
            return Err(ctx.key_error(
                near_key,
                format!(
                    "caustica has no clip planes, and near_clip = {n} could hide geometry {d_min} from the camera \
                     (it must be ≤ {limit} here to cut nothing); remove it or make it smaller"
                ),
            ));
        }
    }
    if let Some(f) = far {
        let d_max = (0..8)
            .map(|c| {
                let corner = Vec3::new(
                    if c & 1 == 0 { bounds.min.x } else { bounds.max.x },
                    if c & 2 == 0 { bounds.min.y } else { bounds.max.y },
                    if c & 4 == 0 { bounds.min.z } else { bounds.max.z },
                );
                corner.distance(origin)
            })
            .fold(0.0f32, f32::max);
        if f < d_max {
            return Err(ctx.key_error(
                far_key,
                format!(
                    "caustica has no clip planes, and far_clip = {f} could hide geometry up to {d_max} from the camera \
                     (it must be ≥ {d_max} here to cut nothing); remove it or make it larger"
                ),
            ));
        }
    }
    Ok(())
}

/// Distance from `p` to the triangle `[a, b, c]` (closest point by Voronoi regions, Ericson,
/// *Real-Time Collision Detection* §5.1.5).
fn point_triangle_distance(p: Vec3, [a, b, c]: [Vec3; 3]) -> f32 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return p.distance(a);
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return p.distance(b);
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return p.distance(a + ab * (d1 / (d1 - d3)));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return p.distance(c);
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return p.distance(a + ac * (d2 / (d2 - d6)));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return p.distance(b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))));
    }
    let denom = va + vb + vc;
    if denom == 0.0 || !denom.is_finite() {
        // Degenerate (collinear) triangle: the nearest of its edges.
        return segment_distance(p, a, b).min(segment_distance(p, b, c)).min(segment_distance(p, a, c));
    }
    let (v, w) = (vb / denom, vc / denom);
    p.distance(a + ab * v + ac * w)
}

/// Distance from `p` to the segment `[a, b]`.
fn segment_distance(p: Vec3, a: Vec3, b: Vec3) -> f32 {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 { ((p - a).dot(ab) / len2).clamp(0.0, 1.0) } else { 0.0 };
    p.distance(a + ab * t)
}

#[cfg(test)]
mod tests {
    use super::point_triangle_distance;
    use crate::math::Vec3;

    #[test]
    fn distances_to_a_triangle() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!((point_triangle_distance(Vec3::new(0.25, 0.25, 2.0), t) - 2.0).abs() < 1e-6);
        assert!((point_triangle_distance(Vec3::new(-1.0, -1.0, 0.0), t) - 2f32.sqrt()).abs() < 1e-6);
        assert!((point_triangle_distance(Vec3::new(0.5, -1.0, 0.0), t) - 1.0).abs() < 1e-6);
        assert!((point_triangle_distance(Vec3::new(1.0, 1.0, 0.0), t) - 0.5f32.sqrt()).abs() < 1e-6);
    }
}
