//! Offline map tiles: a directory in the slippy-map layout `ZOOM/X/Y.png`, each file decoded
//! to RGBA, and a cache of the decoded (or missing) tiles bounded in size. Tiles are read
//! from the disk only; nothing is ever fetched from a network.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::mercator;

/// One tile: zoom, column, row.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct TileKey {
    /// The zoom.
    pub zoom: u8,
    /// The column (x, from the antimeridian eastwards).
    pub x: u32,
    /// The row (y, from the north).
    pub y: u32,
}

impl TileKey {
    /// The tile's file under `dir`: `dir/ZOOM/X/Y.png`.
    pub fn path(&self, dir: &Path) -> PathBuf {
        dir.join(self.zoom.to_string())
            .join(self.x.to_string())
            .join(format!("{}.png", self.y))
    }
}

/// A decoded image: width, height and RGBA bytes, row by row from the top.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Rgba {
    /// Width, pixels.
    pub width: usize,
    /// Height, pixels.
    pub height: usize,
    /// Four bytes per pixel.
    pub pixels: Vec<u8>,
}

/// Decodes a PNG of any colour type and bit depth to 8-bit RGBA.
pub fn decode_png(bytes: &[u8]) -> Result<Rgba, String> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info().map_err(|e| e.to_string())?;
    let size = reader
        .output_buffer_size()
        .ok_or_else(|| "image too large".to_owned())?;
    let mut buffer = vec![0; size];
    let info = reader.next_frame(&mut buffer).map_err(|e| e.to_string())?;
    let data = &buffer[..info.buffer_size()];
    let (width, height) = (info.width as usize, info.height as usize);
    let pixels: Vec<u8> = match info.color_type {
        png::ColorType::Rgba => data.to_vec(),
        png::ColorType::Rgb => data
            .chunks_exact(3)
            .flat_map(|p| [p[0], p[1], p[2], 255])
            .collect(),
        png::ColorType::GrayscaleAlpha => data
            .chunks_exact(2)
            .flat_map(|p| [p[0], p[0], p[0], p[1]])
            .collect(),
        png::ColorType::Grayscale => data.iter().flat_map(|&g| [g, g, g, 255]).collect(),
        png::ColorType::Indexed => return Err("palette not expanded".to_owned()),
    };
    if pixels.len() != width * height * 4 {
        return Err(format!("{width}x{height}: {} bytes", pixels.len()));
    }
    Ok(Rgba {
        width,
        height,
        pixels,
    })
}

/// Reads and decodes one tile of `dir`; `None` when the file is missing or not a PNG (a
/// missing tile is simply not drawn).
pub fn load_tile(dir: &Path, key: TileKey) -> Option<Rgba> {
    let bytes = std::fs::read(key.path(dir)).ok()?;
    decode_png(&bytes).ok()
}

/// The zooms `dir` has tiles for (its subdirectories named by a zoom, 0 to
/// [`mercator::MAX_ZOOM`]), ascending; empty when it cannot be read.
pub fn available_zooms(dir: &Path) -> Vec<u8> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut zooms: Vec<u8> = entries
        .filter_map(Result::ok)
        .filter(|e| e.path().is_dir())
        .filter_map(|e| e.file_name().to_str()?.parse::<u8>().ok())
        .filter(|&z| z <= mercator::MAX_ZOOM)
        .collect();
    zooms.sort_unstable();
    zooms.dedup();
    zooms
}

/// The zoom to draw when `fit` fits the view best and `available` (ascending) are the zooms
/// there are tiles for: `fit` itself, else the closest coarser one (its tiles drawn larger),
/// else the closest finer one; `None` without tiles.
pub fn choose_zoom(fit: u8, available: &[u8]) -> Option<u8> {
    available
        .iter()
        .rev()
        .find(|&&z| z <= fit)
        .or_else(|| available.iter().find(|&&z| z > fit))
        .copied()
}

/// A cache of at most `capacity` entries that forgets the least recently used first.
#[derive(Debug)]
pub struct BoundedCache<V> {
    capacity: usize,
    clock: u64,
    entries: HashMap<TileKey, (u64, V)>,
}

impl<V> BoundedCache<V> {
    /// An empty cache of at most `capacity` entries (at least one).
    pub fn new(capacity: usize) -> BoundedCache<V> {
        BoundedCache {
            capacity: capacity.max(1),
            clock: 0,
            entries: HashMap::new(),
        }
    }

    /// The entry of `key`, marked as used now.
    pub fn get(&mut self, key: TileKey) -> Option<&V> {
        self.clock += 1;
        let clock = self.clock;
        self.entries.get_mut(&key).map(|(used, v)| {
            *used = clock;
            &*v
        })
    }

    /// Stores `value` for `key`, forgetting the least recently used entry when full.
    pub fn insert(&mut self, key: TileKey, value: V) {
        self.clock += 1;
        if !self.entries.contains_key(&key) && self.entries.len() >= self.capacity {
            let oldest = self
                .entries
                .iter()
                .min_by_key(|(_, (used, _))| *used)
                .map(|(k, _)| *k);
            if let Some(k) = oldest {
                self.entries.remove(&k);
            }
        }
        self.entries.insert(key, (self.clock, value));
    }

    /// Number of entries.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the cache is empty.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn encode(width: u32, height: u32, color: png::ColorType, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, width, height);
        encoder.set_color(color);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(data).unwrap();
        writer.finish().unwrap();
        out
    }

    #[test]
    fn pngs_of_each_colour_type_decode_to_rgba() {
        let rgb = encode(2, 1, png::ColorType::Rgb, &[255, 0, 0, 0, 0, 255]);
        assert_eq!(
            decode_png(&rgb).unwrap(),
            Rgba {
                width: 2,
                height: 1,
                pixels: vec![255, 0, 0, 255, 0, 0, 255, 255],
            }
        );
        let grey = encode(1, 2, png::ColorType::Grayscale, &[7, 200]);
        assert_eq!(
            decode_png(&grey).unwrap().pixels,
            [7, 7, 7, 255, 200, 200, 200, 255]
        );
        let rgba = encode(1, 1, png::ColorType::Rgba, &[1, 2, 3, 4]);
        assert_eq!(decode_png(&rgba).unwrap().pixels, [1, 2, 3, 4]);
        assert!(decode_png(b"not a png").is_err());
    }

    #[test]
    fn tiles_are_read_from_the_slippy_layout_and_missing_ones_are_none() {
        let dir = std::env::temp_dir().join(format!("dima-ground-tiles-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        let key = TileKey {
            zoom: 18,
            x: 144_525,
            y: 157_503,
        };
        assert_eq!(key.path(&dir), dir.join("18/144525/157503.png"));
        std::fs::create_dir_all(key.path(&dir).parent().unwrap()).unwrap();
        std::fs::write(
            key.path(&dir),
            encode(1, 1, png::ColorType::Rgb, &[9, 8, 7]),
        )
        .unwrap();
        assert_eq!(load_tile(&dir, key).unwrap().pixels, [9, 8, 7, 255]);
        assert!(load_tile(&dir, TileKey { y: 157_504, ..key }).is_none());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_zoom_drawn_is_the_fitting_one_else_the_closest_coarser() {
        let available = [15, 17, 18];
        assert_eq!(choose_zoom(18, &available), Some(18));
        assert_eq!(choose_zoom(19, &available), Some(18));
        assert_eq!(choose_zoom(16, &available), Some(15));
        assert_eq!(choose_zoom(12, &available), Some(15), "only finer ones");
        assert_eq!(choose_zoom(12, &[]), None);

        let dir = std::env::temp_dir().join(format!("dima-ground-zooms-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for sub in ["18", "3", "17", "notes", "40"] {
            std::fs::create_dir_all(dir.join(sub)).unwrap();
        }
        std::fs::write(dir.join("5"), b"a file, not a zoom").unwrap();
        assert_eq!(available_zooms(&dir), [3, 17, 18]);
        assert!(available_zooms(&dir.join("missing")).is_empty());
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn the_cache_forgets_the_least_recently_used() {
        let key = |x| TileKey { zoom: 1, x, y: 0 };
        let mut cache = BoundedCache::new(2);
        cache.insert(key(0), "a");
        cache.insert(key(1), "b");
        assert_eq!(cache.get(key(0)), Some(&"a"));
        cache.insert(key(2), "c");
        assert_eq!(cache.len(), 2);
        assert_eq!(cache.get(key(1)), None, "the least recently used went");
        assert_eq!(cache.get(key(0)), Some(&"a"));
        assert_eq!(cache.get(key(2)), Some(&"c"));
        cache.insert(key(2), "c2");
        assert_eq!(cache.len(), 2);
        assert_eq!(cache.get(key(2)), Some(&"c2"));
    }
}
