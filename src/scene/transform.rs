//! `to_world` transforms: parsing, composition order, and the checks a shape or camera needs.
//!
//! A `to_world` is one transform table or a list of them. Each table holds exactly one of
//!
//! | key | value | matrix |
//! |---|---|---|
//! | `translate` | `[x, y, z]` | T(x, y, z) |
//! | `rotate` | `{ axis = [x, y, z], angle = deg }` | right-handed rotation by `angle` degrees about `axis` (Mitsuba 3: the axis as written, see `rotation_as_mitsuba`) |
//! | `scale` | `s` or `[sx, sy, sz]` | S |
//! | `look_at` | `{ origin, target, up }` | Mitsuba's `look_at`: columns (left, up′, dir, origin), left = up × dir |
//! | `matrix` | 16 numbers, row-major | as written (the last row must be `0 0 0 1`) |
//!
//! **Order: the first element of a list is applied first to the object.** The list `[A, B, C]` is the
//! matrix `C·B·A`, exactly like Mitsuba's XML where nested transform elements are applied in the order
//! written (each one left-multiplies the ones before it). The Cornell floor "translate(0,-1,0)·rotate(x,-90°)"
//! is therefore written `[ { rotate = { axis = [1,0,0], angle = -90 } }, { translate = [0,-1,0] } ]`.

use super::desc::{ToWorld, TransformOp};
use super::error::{ErrorContext, SceneError};
use super::spans::{join_index, join_key};
use crate::math::{Mat3, Mat4, Vec3, Vec4};

/// The matrix of an optional `to_world` at `key` (identity when absent). Every number must be finite and
/// the result affine.
pub(crate) fn to_world_matrix(ctx: &ErrorContext, key: &str, to_world: Option<&ToWorld>) -> Result<Mat4, SceneError> {
    let m = match to_world {
        None => Mat4::IDENTITY,
        Some(ToWorld::One(op)) => op_matrix(ctx, key, op)?,
        Some(ToWorld::List(ops)) => {
            let mut m = Mat4::IDENTITY;
            for (i, op) in ops.iter().enumerate() {
                // The first listed is applied first: each later element left-multiplies.
                m = op_matrix(ctx, &join_index(key, i), op)? * m;
            }
            m
        }
    };
    if !m.is_finite() {
        return Err(ctx.key_error(key, "the composed transform is not finite (overflow)"));
    }
    Ok(m)
}

/// [`to_world_matrix`] of a `to_world` value as a plugin's table holds it (a shape's, an emitter's).
pub(crate) fn to_world_value(ctx: &ErrorContext, key: &str, value: &toml::Value) -> Result<Mat4, SceneError> {
    use serde::Deserialize;
    let to_world = ToWorld::deserialize(value.clone()).map_err(|e| ctx.key_error(key, e.to_string()))?;
    to_world_matrix(ctx, key, Some(&to_world))
}

/// The linear part of an affine `to_world`, checked invertible; returns it with its determinant.
pub(crate) fn invertible_linear_part(ctx: &ErrorContext, key: &str, m: Mat4) -> Result<(Mat3, f32), SceneError> {
    crate::math::invertible_linear_part(m).map_err(|message| ctx.key_error(key, message))
}

fn op_matrix(ctx: &ErrorContext, key: &str, op: &TransformOp) -> Result<Mat4, SceneError> {
    let present: Vec<&str> = [
        ("translate", op.translate.is_some()),
        ("rotate", op.rotate.is_some()),
        ("scale", op.scale.is_some()),
        ("look_at", op.look_at.is_some()),
        ("matrix", op.matrix.is_some()),
    ]
    .iter()
    .filter(|(_, p)| *p)
    .map(|(n, _)| *n)
    .collect();
    if present.len() != 1 {
        let msg = if present.is_empty() {
            "a transform table needs exactly one of translate, rotate, scale, look_at, matrix; it has none".to_string()
        } else {
            format!(
                "a transform table holds exactly one of translate, rotate, scale, look_at, matrix; this one has {} (use a list to combine them)",
                present.join(", ")
            )
        };
        return Err(ctx.key_error(key, msg));
    }
    if let Some(t) = op.translate {
        let t = ctx.finite3(&join_key(key, "translate"), Vec3::from(t))?;
        return Ok(Mat4::from_translation(t));
    }
    if let Some(r) = &op.rotate {
        let key = join_key(key, "rotate");
        let axis = ctx.finite3(&join_key(&key, "axis"), Vec3::from(r.axis))?;
        let angle = ctx.finite(&join_key(&key, "angle"), r.angle)?;
        if axis == Vec3::ZERO {
            return Err(ctx.key_error(&join_key(&key, "axis"), "the rotation axis is the zero vector"));
        }
        return Ok(rotation_as_mitsuba(axis, angle.to_radians()));
    }
    if let Some(s) = op.scale {
        let s = ctx.finite3(&join_key(key, "scale"), s.0)?;
        return Ok(Mat4::from_scale(s));
    }
    if let Some(l) = &op.look_at {
        let key = join_key(key, "look_at");
        let origin = ctx.finite3(&join_key(&key, "origin"), Vec3::from(l.origin))?;
        let target = ctx.finite3(&join_key(&key, "target"), Vec3::from(l.target))?;
        let up = ctx.finite3(&join_key(&key, "up"), Vec3::from(l.up))?;
        return look_at(origin, target, up).ok_or_else(|| {
            ctx.key_error(
                &key,
                "degenerate look_at: target equals origin, or up is zero or parallel to the viewing direction",
            )
        });
    }
    let values = op.matrix.as_deref().unwrap_or_default();
    let key = join_key(key, "matrix");
    if values.len() != 16 {
        return Err(ctx.key_error(&key, format!("a matrix needs 16 numbers (row-major), got {}", values.len())));
    }
    for (i, &v) in values.iter().enumerate() {
        ctx.finite(&join_index(&key, i), v)?;
    }
    let mut cols = [0.0f32; 16];
    cols.copy_from_slice(values);
    // Row-major in the file, column-major in glam.
    let m = Mat4::from_cols_array(&cols).transpose();
    if m.row(3) != Vec4::new(0.0, 0.0, 0.0, 1.0) {
        return Err(ctx.key_error(
            &key,
            "the last row of a to_world matrix must be 0 0 0 1 (projective transforms are not supported)",
        ));
    }
    Ok(m)
}

/// Mitsuba's `Transform4f::look_at`: maps the local frame (x = left, y = up, z = viewing direction) to
/// world space, origin to `origin`. `None` if degenerate.
#[must_use]
pub fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Option<Mat4> {
    let dir = crate::math::normalize_any(target - origin)?;
    let left = crate::math::normalize_any(crate::math::normalize_any(up)?.cross(dir))?;
    let new_up = dir.cross(left);
    Some(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// The rotation by `angle` radians about `axis` as Mitsuba 3 makes it (`Transform4f::rotate`, Dr.Jit's
/// `rotate`): Rodrigues' formula `R = cos·I + (1 − cos)·a·aᵀ + sin·[a]×` with the axis **as written**, not
/// normalised. A unit axis gives the rotation; any other also scales and shears, and Mitsuba renders the
/// scene so (its `mitsuba-data/scenes/hello.xml` rotates about (0, 1, 1): the teapot comes out 7.5 %
/// brighter than about the unit axis, in Mitsuba and in caustica alike).
fn rotation_as_mitsuba(a: Vec3, angle: f32) -> Mat4 {
    let (s, c) = angle.sin_cos();
    let k = 1.0 - c;
    Mat4::from_cols(
        Vec4::new(c + a.x * a.x * k, a.y * a.x * k + a.z * s, a.z * a.x * k - a.y * s, 0.0),
        Vec4::new(a.x * a.y * k - a.z * s, c + a.y * a.y * k, a.z * a.y * k + a.x * s, 0.0),
        Vec4::new(a.x * a.z * k + a.y * s, a.y * a.z * k - a.x * s, c + a.z * a.z * k, 0.0),
        Vec4::W,
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::desc::SceneFile;
    use crate::scene::spans::SpanIndex;

    /// The matrix of `to_world = <value>` in a minimal sensor table.
    fn matrix_of(value: &str) -> Result<Mat4, SceneError> {
        let text = format!("[sensor]\nfov = 40\nto_world = {value}\n");
        let ctx = ErrorContext {
            file: "t.toml".into(),
            spans: SpanIndex::new(&text),
            places: None,
        };
        let file: SceneFile = toml::from_str(&text).map_err(|e| ctx.toml_error(&e))?;
        to_world_matrix(&ctx, "sensor.to_world", file.sensor.as_ref().and_then(|s| s.to_world.as_ref()))
    }

    #[test]
    fn list_applies_its_first_element_first() {
        // A unit axis: glam's rotation; a longer one is used as written, as in Mitsuba 3.
        for (axis, angle) in [(Vec3::X, 0.7f32), (Vec3::new(0.0, 0.6, 0.8), -2.0), (Vec3::new(0.48, 0.6, 0.64), 1.0)] {
            assert!(rotation_as_mitsuba(axis, angle).abs_diff_eq(Mat4::from_axis_angle(axis, angle), 1e-6));
        }
        let m = rotation_as_mitsuba(Vec3::new(0.0, 2.0, 0.0), std::f32::consts::FRAC_PI_2);
        // cos·I + (1−cos)·a·aᵀ + sin·[a]×, a = (0, 2, 0), angle 90°: y is scaled by 4, x → -2z.
        assert!(m.transform_vector3(Vec3::Y).abs_diff_eq(Vec3::new(0.0, 4.0, 0.0), 1e-6));
        assert!(m.transform_vector3(Vec3::X).abs_diff_eq(Vec3::new(0.0, 0.0, -2.0), 1e-6));
        // Mitsuba 3.9.1's `ScalarTransform4f().rotate([0.3, 1, 1], 15).matrix`, printed row by row.
        let mitsuba = [[0.968992, -0.248597, 0.269041], [0.269041, 1.0, -0.0435715], [-0.248597, 0.11172, 1.0]];
        let m = rotation_as_mitsuba(Vec3::new(0.3, 1.0, 1.0), 15f32.to_radians());
        for (r, row) in mitsuba.iter().enumerate() {
            for (c, v) in row.iter().enumerate() {
                assert!((m.col(c)[r] - v).abs() < 2e-6, "({r}, {c}): {} vs {v}", m.col(c)[r]);
            }
        }
        // Cornell floor: "translate(0,-1,0)·rotate(x,-90°)" = [rotate, translate].
        let m = matrix_of("[ { rotate = { axis = [1, 0, 0], angle = -90 } }, { translate = [0, -1, 0] } ]").unwrap();
        let expect = Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0)) * Mat4::from_rotation_x((-90.0f32).to_radians());
        assert!(m.abs_diff_eq(expect, 1e-6));
        // The rectangle's corner (1, 1, 0) lands at (1, -1, -1); its normal +z turns to +y.
        assert!(m
            .transform_point3(Vec3::new(1.0, 1.0, 0.0))
            .abs_diff_eq(Vec3::new(1.0, -1.0, -1.0), 1e-6));
        assert!(m.transform_vector3(Vec3::Z).abs_diff_eq(Vec3::Y, 1e-6));
        // The other order is a different transform.
        let swapped = matrix_of("[ { translate = [0, -1, 0] }, { rotate = { axis = [1, 0, 0], angle = -90 } } ]").unwrap();
        assert!(!swapped.abs_diff_eq(m, 1e-3));
        // A single table is that one transform; scale accepts a number or a triple.
        assert_eq!(matrix_of("{ scale = 2 }").unwrap(), Mat4::from_scale(Vec3::splat(2.0)));
        assert_eq!(
            matrix_of("{ scale = [1, 2, 3] }").unwrap(),
            Mat4::from_scale(Vec3::new(1.0, 2.0, 3.0))
        );
    }

    #[test]
    fn matrix_is_row_major_and_look_at_is_mitsubas() {
        let m = matrix_of("{ matrix = [1, 0, 0, 5,  0, 1, 0, 6,  0, 0, 1, 7,  0, 0, 0, 1] }").unwrap();
        assert_eq!(m.transform_point3(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
        assert!(matrix_of("{ matrix = [1, 0, 0, 0,  0, 1, 0, 0,  0, 0, 1, 0,  0, 0, 1, 0] }").is_err());
        let m = matrix_of("{ look_at = { origin = [0, 0, 3.9], target = [0, 0, 0], up = [0, 1, 0] } }").unwrap();
        // Columns: left = up × dir, up, dir = normalize(target − origin), origin.
        assert!(m.x_axis.truncate().abs_diff_eq(-Vec3::X, 1e-6));
        assert!(m.y_axis.truncate().abs_diff_eq(Vec3::Y, 1e-6));
        assert!(m.z_axis.truncate().abs_diff_eq(-Vec3::Z, 1e-6));
        assert_eq!(m.w_axis.truncate(), Vec3::new(0.0, 0.0, 3.9));
    }
}
