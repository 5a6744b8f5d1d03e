//! The packets of tev's TCP protocol (encoding only): what `render --display-server` sends to the
//! [tev](https://github.com/Tom94/tev) viewer. Layout as tev's `IpcPacket` writes and reads them
//! (tev `include/tev/Ipc.h`, `src/Ipc.cpp`, `setCreateImage` / `setUpdateImage` /
//! `interpretAsUpdateImage`):
//!
//! ```text
//! packet       = u32 length (of the whole packet, these 4 bytes included) · u8 type · fields
//! string       = its bytes · 0
//! bool         = u8 (1 true, 0 false)
//! CreateImage  (type 4): bool grab_focus · string name · i32 width · i32 height · i32 n · n × string channel
//! UpdateImageV3 (type 6): bool grab_focus · string name · i32 n · n × string channel · i32 x · i32 y
//!              · i32 width · i32 height · n × i64 offset · n × i64 stride · floats
//! CloseImage   (type 2): string name
//! ```
//!
//! All numbers little-endian. In an update, channel `c` of pixel `i` of the `width × height` rectangle at
//! `(x, y)` is float number `offset[c] + i·stride[c]` of the data; here the data is RGB interleaved
//! (offsets 0, 1, 2, stride 3). An image is sent as rectangles of at most [`TILE`]² pixels, so that no
//! packet exceeds ~200 KB whatever the image's size (pbrt-v4's `DisplayItem` sends tiles of 128² for the
//! same reason, `src/pbrt/util/display.cpp`).

use crate::film::Image;

/// tev's packet types (`IpcPacket::EType`).
pub const CLOSE_IMAGE: u8 = 2;
pub const CREATE_IMAGE: u8 = 4;
pub const UPDATE_IMAGE_V3: u8 = 6;

/// Edge of the rectangles an image is sent in (pbrt-v4's tile size).
pub const TILE: u32 = 128;

/// The channels of the images sent.
pub const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// A packet being written: the length is kept up to date in its first four bytes.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8, capacity: usize) -> Self {
        let mut bytes = Vec::with_capacity(capacity);
        bytes.extend_from_slice(&[0; 4]);
        bytes.push(kind);
        Packet(bytes)
    }

    fn bool(&mut self, v: bool) -> &mut Self {
        self.0.push(u8::from(v));
        self
    }

    /// A string, NUL-terminated; an inner NUL (which would end it early in tev) becomes a space.
    fn string(&mut self, s: &str) -> &mut Self {
        self.0.extend(s.bytes().map(|b| if b == 0 { b' ' } else { b }));
        self.0.push(0);
        self
    }

    fn i32(&mut self, v: i32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn i64(&mut self, v: i64) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn f32(&mut self, v: f32) -> &mut Self {
        self.0.extend_from_slice(&v.to_le_bytes());
        self
    }

    fn finish(mut self) -> Vec<u8> {
        let len = u32::try_from(self.0.len()).unwrap_or(u32::MAX);
        self.0[..4].copy_from_slice(&len.to_le_bytes());
        self.0
    }
}

/// Sizes as tev's i32 (images are far smaller than 2³¹ pixels a side: `check::resolution`).
fn i32_of(v: u32) -> i32 {
    i32::try_from(v).unwrap_or(i32::MAX)
}

/// CreateImage: a new, black `width × height` image called `name` with channels R, G, B (an image of the
/// same name is replaced); `grab_focus` selects it in the viewer.
#[must_use]
pub fn create_image(name: &str, grab_focus: bool, width: u32, height: u32) -> Vec<u8> {
    let mut p = Packet::new(CREATE_IMAGE, 32 + name.len());
    p.bool(grab_focus).string(name).i32(i32_of(width)).i32(i32_of(height)).i32(CHANNELS.len() as i32);
    for c in CHANNELS {
        p.string(c);
    }
    p.finish()
}

/// CloseImage: removes the image called `name` from the viewer.
#[must_use]
pub fn close_image(name: &str) -> Vec<u8> {
    let mut p = Packet::new(CLOSE_IMAGE, 8 + name.len());
    p.string(name);
    p.finish()
}

/// A rectangle of an image: `width × height` pixels from `(x, y)`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Tile {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

/// The [`TILE`]-sized rectangles covering a `width × height` image, row by row from the top left.
pub fn tiles(width: u32, height: u32) -> impl Iterator<Item = Tile> {
    (0..height.div_ceil(TILE)).flat_map(move |ty| {
        (0..width.div_ceil(TILE)).map(move |tx| {
            let (x, y) = (tx * TILE, ty * TILE);
            Tile { x, y, width: TILE.min(width - x), height: TILE.min(height - y) }
        })
    })
}

/// UpdateImageV3: the pixels of `tile` of `image` into the image called `name` (R, G, B interleaved).
/// `tile` must lie inside the image ([`tiles`] gives such rectangles).
#[must_use]
pub fn update_image(name: &str, grab_focus: bool, image: &Image, tile: Tile) -> Vec<u8> {
    let n = CHANNELS.len();
    let pixels = tile.width as usize * tile.height as usize;
    let mut p = Packet::new(UPDATE_IMAGE_V3, 64 + name.len() + 4 * n * pixels);
    p.bool(grab_focus).string(name).i32(n as i32);
    for c in CHANNELS {
        p.string(c);
    }
    p.i32(i32_of(tile.x)).i32(i32_of(tile.y)).i32(i32_of(tile.width)).i32(i32_of(tile.height));
    for c in 0..n {
        p.i64(c as i64);
    }
    for _ in 0..n {
        p.i64(n as i64);
    }
    let row = image.width() as usize;
    for y in tile.y..tile.y + tile.height {
        let start = y as usize * row + tile.x as usize;
        for px in &image.pixels()[start..start + tile.width as usize] {
            p.f32(px.x).f32(px.y).f32(px.z);
        }
    }
    p.finish()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;

    /// The bytes of a CreateImage packet, written out by hand from tev's `setCreateImage`.
    #[test]
    fn create_image_is_laid_out_as_tev_reads_it() {
        let p = create_image("ab", true, 3, 2);
        let mut want: Vec<u8> = vec![0, 0, 0, 0, 4, 1, b'a', b'b', 0];
        want.extend_from_slice(&3i32.to_le_bytes());
        want.extend_from_slice(&2i32.to_le_bytes());
        want.extend_from_slice(&3i32.to_le_bytes());
        want.extend_from_slice(b"R\0G\0B\0");
        let len = want.len() as u32;
        want[..4].copy_from_slice(&len.to_le_bytes());
        assert_eq!(p, want);
        assert_eq!(close_image("a\0b"), vec![9, 0, 0, 0, 2, b'a', b' ', b'b', 0]);
    }

    /// An update's header, offsets and strides as tev's `interpretAsUpdateImage` reads them, and the
    /// pixels of the tile (not of the whole image) interleaved.
    #[test]
    fn update_image_sends_the_tile_interleaved() {
        let image = Image::from_fn(3, 2, |x, y| Vec3::new(x as f32, y as f32, 10.0 + x as f32 + 3.0 * y as f32));
        let tile = Tile { x: 1, y: 0, width: 2, height: 2 };
        let p = update_image("i", false, &image, tile);
        let mut want: Vec<u8> = vec![0, 0, 0, 0, 6, 0, b'i', 0];
        want.extend_from_slice(&3i32.to_le_bytes());
        want.extend_from_slice(b"R\0G\0B\0");
        for v in [1i32, 0, 2, 2] {
            want.extend_from_slice(&v.to_le_bytes());
        }
        for v in [0i64, 1, 2, 3, 3, 3] {
            want.extend_from_slice(&v.to_le_bytes());
        }
        for (x, y) in [(1u32, 0u32), (2, 0), (1, 1), (2, 1)] {
            for v in [x as f32, y as f32, 10.0 + x as f32 + 3.0 * y as f32] {
                want.extend_from_slice(&v.to_le_bytes());
            }
        }
        let len = want.len() as u32;
        want[..4].copy_from_slice(&len.to_le_bytes());
        assert_eq!(p, want);
    }

    #[test]
    fn tiles_cover_the_image_once() {
        for (w, h) in [(1, 1), (128, 128), (129, 300), (500, 7)] {
            let mut covered = vec![0u8; w as usize * h as usize];
            for t in tiles(w, h) {
                assert!(t.width >= 1 && t.width <= TILE && t.height >= 1 && t.height <= TILE, "{t:?}");
                for y in t.y..t.y + t.height {
                    for x in t.x..t.x + t.width {
                        covered[(y * w + x) as usize] += 1;
                    }
                }
            }
            assert!(covered.iter().all(|&c| c == 1), "{w}x{h}");
        }
        assert_eq!(tiles(129, 300).count(), 2 * 3);
        // The largest packet: a full tile, ~200 KB.
        let big = Image::new(300, 300);
        assert!(tiles(300, 300).map(|t| update_image("x", false, &big, t).len()).max().unwrap() < 200_000);
    }
}
