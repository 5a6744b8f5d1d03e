//! The limit on how far from the origin a shape may lie for f32 coordinates to hold it.
//!
//! An f32 keeps 24 significant bits, so a coordinate of magnitude `L` is only known to `L·2⁻²⁴`, and the
//! hit point rebuilt from barycentrics to `γ₇·L` (`math::barycentric_point_error`). The ray-origin offset
//! and `spawn_t_min` follow that bound, so they stay correct far away, but a shape whose size is no longer
//! large against it is rendered wrong: measured on `cornell-caustics` translated along x, the image mean is
//! unchanged at 1e4 (the spheres lie 1.0e4 times their size from the origin), 0.3% dark at 3e4, 3% at 1e5
//! and 27% at 1e6, with the spheres black. Rather than render such a shape wrong without a word, the
//! loader refuses a shape that lies more than [`MAX_OFFSET_PER_SIZE`] times its own size from the origin.

use crate::math::Aabb;
use crate::mesh::TriangleMesh;

/// A shape may lie at most this many times its own size (bounding-box diagonal) from the origin
/// (largest coordinate magnitude of its bounding box): 2¹⁴, which leaves 10 of f32's 24 bits for the
/// shape's own detail.
pub const MAX_OFFSET_PER_SIZE: f32 = 16384.0;

/// `Err(message)` if the placed mesh lies too far from the origin for its size (see the module docs).
pub(crate) fn check_offset(mesh: &TriangleMesh) -> Result<(), String> {
    check_box(mesh.bounds())
}

/// `Err(message)` if a shape whose world box is `b` lies too far from the origin for its size: a placed mesh
/// ([`check_offset`]) or an instance, whose prototype is held in object space but shaded in world space
/// (`Scene::interaction`: the point's error bound grows with its distance from the origin as a flat shape's).
pub(crate) fn check_box(b: Aabb) -> Result<(), String> {
    if b.is_empty() {
        return Ok(());
    }
    let offset = b.min.abs().max(b.max.abs()).max_element();
    let size = b.extent().length();
    if offset <= MAX_OFFSET_PER_SIZE * size {
        return Ok(());
    }
    Err(format!(
        "the shape lies {offset:.4e} from the origin, {:.3e} times its size ({size:.3e}); f32 coordinates cannot \
         hold it there (limit: {MAX_OFFSET_PER_SIZE} times its size, i.e. within {:.3e} of the origin): move the \
         scene towards the origin",
        offset / size,
        MAX_OFFSET_PER_SIZE * size,
    ))
}

/// `Err(message)` if the camera lies too far from the origin for the scene's size: its rays' origins would
/// be rounded to more than the scene's detail (the same limit as [`check_offset`], against the size of the
/// whole scene).
pub(crate) fn check_camera(position: crate::math::Vec3, scene: crate::math::Aabb) -> Result<(), String> {
    if scene.is_empty() {
        return Ok(());
    }
    let offset = position.abs().max_element();
    let size = scene.extent().length();
    if offset <= MAX_OFFSET_PER_SIZE * size {
        return Ok(());
    }
    Err(format!(
        "the camera lies {offset:.4e} from the origin, {:.3e} times the scene's size ({size:.3e}); f32 coordinates \
         cannot resolve the scene from there (limit: {MAX_OFFSET_PER_SIZE} times the scene's size, i.e. within {:.3e} \
         of the origin)",
        offset / size,
        MAX_OFFSET_PER_SIZE * size,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::shapes;

    fn sphere_at(x: f32) -> TriangleMesh {
        shapes::sphere(Vec3::new(x, 0.0, 0.0), 0.5, 8, 16)
    }

    #[test]
    fn a_shape_near_its_own_size_is_accepted_far_away_refused() {
        // The sphere's diagonal is √3; the limit is 16384·√3 ≈ 2.8e4.
        assert!(check_offset(&sphere_at(0.0)).is_ok());
        assert!(check_offset(&sphere_at(2.0e4)).is_ok());
        let err = check_offset(&sphere_at(1.0e6)).unwrap_err();
        assert!(err.contains("limit: 16384 times its size") && err.contains("2.838e4"), "{err}");
        // Scale invariant: the same configuration scaled by 1e-3 is treated alike.
        assert!(check_offset(&shapes::sphere(Vec3::new(1.0e3, 0.0, 0.0), 0.5e-3, 8, 16)).is_err());
        assert!(check_offset(&TriangleMesh::default()).is_ok());
    }
}
