//! The images textures read, each decoded once: textures naming the same file with the same decoding
//! options share one [`TextureImage`] (an `Arc`), and two option sets that decode to the same texels
//! (`raw` on a float image) share it too. The cache bounds the memory its images take, with the decoder's
//! buffer while one is read, checked from the file's header before anything is allocated.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::decode::{self, Header};
use super::texels::{stored_bytes, StorageFormat, TextureImage};
use super::TextureError;

/// The images loaded so far and the memory limit they share.
#[derive(Debug)]
pub struct ImageCache {
    /// By canonical path and the options as asked.
    by_request: HashMap<(PathBuf, bool, StorageFormat), Arc<TextureImage>>,
    /// By canonical path and what decoding did (sRGB decoded, rounded to half): one copy of equal texels.
    by_result: HashMap<(PathBuf, bool, bool), Arc<TextureImage>>,
    limit: u64,
    used: u64,
}

/// The memory limit of [`ImageCache::default`] where the machine's cannot be read: 16 GiB.
pub const FALLBACK_LIMIT_BYTES: u64 = 16 << 30;

impl Default for ImageCache {
    /// A cache whose images may take half the memory this process may use ([`crate::sys::memory_bound`]:
    /// physical memory, the cgroup's limit, `ulimit -v`), or [`FALLBACK_LIMIT_BYTES`] where none is known.
    fn default() -> Self {
        let limit = crate::sys::memory_bound().map_or(FALLBACK_LIMIT_BYTES, |(bytes, _)| bytes / 2);
        Self::new(limit)
    }
}

impl ImageCache {
    /// A cache whose images (texels kept, plus the decoder's buffer while one is read) may take at most
    /// `limit_bytes`.
    #[must_use]
    pub fn new(limit_bytes: u64) -> Self {
        ImageCache { by_request: HashMap::new(), by_result: HashMap::new(), limit: limit_bytes, used: 0 }
    }

    /// The memory limit.
    #[must_use]
    pub fn limit_bytes(&self) -> u64 {
        self.limit
    }

    /// The bytes of texels the cached images take, each image once.
    #[must_use]
    pub fn memory_bytes(&self) -> u64 {
        self.used
    }

    /// How many distinct images are held.
    #[must_use]
    pub fn len(&self) -> usize {
        self.by_result.len()
    }

    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.by_result.is_empty()
    }

    /// The image of `path` decoded with `raw` and `format`, read now or found among those read before.
    pub fn load(&mut self, path: &Path, raw: bool, format: StorageFormat) -> Result<Arc<TextureImage>, TextureError> {
        let canonical = std::fs::canonicalize(path).map_err(|source| TextureError::Io { path: path.to_path_buf(), source })?;
        let request = (canonical.clone(), raw, format);
        if let Some(image) = self.by_request.get(&request) {
            return Ok(Arc::clone(image));
        }
        let (limit, used) = (self.limit, self.used);
        let mut budget = |h: &Header| {
            let kept = stored_bytes(h.width, h.height, if h.grey { 1 } else { 3 });
            let bytes = kept.saturating_add(h.decoder_bytes);
            let available = limit.saturating_sub(used);
            if bytes > available {
                return Err(TextureError::TooLarge { path: path.to_path_buf(), width: h.width, height: h.height, bytes, available, limit });
            }
            Ok(())
        };
        let decoded = decode::read(path, &mut budget)?;
        let image = TextureImage::from_decoded(path, decoded, raw, format)?;
        let result = (canonical, image.source().srgb_decoded, image.source().half);
        let image = match self.by_result.get(&result) {
            Some(same) => Arc::clone(same),
            None => {
                let image = Arc::new(image);
                self.used += image.memory_bytes();
                self.by_result.insert(result, Arc::clone(&image));
                image
            }
        };
        self.by_request.insert(request, Arc::clone(&image));
        Ok(image)
    }
}
