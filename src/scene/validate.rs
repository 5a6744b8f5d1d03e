//! Range checks for values read from a scene file, each reporting the key path of the value it rejects.

use super::error::{ErrorContext, SceneError};
use crate::math::Vec3;

/// Why a number is not acceptable as a finite value (`None` if it is finite).
fn non_finite(v: f32) -> Option<&'static str> {
    if v.is_nan() {
        Some("is NaN")
    } else if v.is_infinite() {
        Some("is infinite")
    } else {
        None
    }
}

impl ErrorContext {
    /// A finite number.
    pub(crate) fn finite(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        match non_finite(v) {
            Some(why) => Err(self.key_error(key, format!("the value {why}; it must be a finite number"))),
            None => Ok(v),
        }
    }

    /// A finite number > 0.
    pub(crate) fn positive(&self, key: &str, v: f32, what: &str) -> Result<f32, SceneError> {
        self.finite(key, v)?;
        if v > 0.0 {
            Ok(v)
        } else {
            Err(self.key_error(key, format!("{what} must be > 0, got {v}")))
        }
    }

    /// A finite number in [lo, hi].
    pub(crate) fn in_range(&self, key: &str, v: f32, lo: f32, hi: f32, what: &str) -> Result<f32, SceneError> {
        self.finite(key, v)?;
        if (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(self.key_error(key, format!("{what} must be in [{lo}, {hi}], got {v}")))
        }
    }

    /// Three finite numbers.
    pub(crate) fn finite3(&self, key: &str, v: Vec3) -> Result<Vec3, SceneError> {
        for i in 0..3 {
            if let Some(why) = non_finite(v[i]) {
                return Err(self.key_error(key, format!("component {i} {why}; it must be a finite number")));
            }
        }
        Ok(v)
    }

    /// An RGB reflectance: every component finite and in [0, 1].
    pub(crate) fn reflectance(&self, key: &str, v: Vec3) -> Result<Vec3, SceneError> {
        for i in 0..3 {
            let c = v[i];
            let why = match non_finite(c) {
                Some(why) => why.to_string(),
                None if c < 0.0 => format!("is negative ({c})"),
                None if c > 1.0 => format!("is {c} > 1 (a reflectance above 1 creates energy)"),
                None => continue,
            };
            return Err(self.key_error(key, format!("reflectance component {i} {why}; each component must be in [0, 1]")));
        }
        Ok(v)
    }

    /// An RGB radiance: every component finite and ≥ 0.
    pub(crate) fn radiance(&self, key: &str, v: Vec3) -> Result<Vec3, SceneError> {
        for i in 0..3 {
            let c = v[i];
            let why = match non_finite(c) {
                Some(why) => why.to_string(),
                None if c < 0.0 => format!("is negative ({c})"),
                None => continue,
            };
            return Err(self.key_error(key, format!("radiance component {i} {why}; each component must be finite and ≥ 0")));
        }
        Ok(v)
    }
}
