//! Range checks for values read from a scene file, each reporting the key path of the value it rejects. The
//! checks themselves are those of the plugins' properties (`crate::props`), one rule each.

use super::error::{ErrorContext, SceneError};
use super::spans::join_key;
use crate::math::Vec3;
use crate::props::{self, PropError};

impl ErrorContext {
    /// A finite number.
    pub(crate) fn finite(&self, key: &str, v: f32) -> Result<f32, SceneError> {
        props::finite(v).map_err(|m| self.key_error(key, m))
    }

    /// Three finite numbers.
    pub(crate) fn finite3(&self, key: &str, v: Vec3) -> Result<Vec3, SceneError> {
        props::finite3(v).map_err(|m| self.key_error(key, m))
    }

    /// A plugin's error (its key relative to the plugin at `key`) at its place in the scene file.
    pub(crate) fn prop_error(&self, key: &str, e: PropError) -> SceneError {
        let key = if e.key.is_empty() { key.to_string() } else { join_key(key, &e.key) };
        self.key_error(&key, e.message)
    }
}
