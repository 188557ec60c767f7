//! Linear floating-point RGB images and their files: OpenEXR and Radiance HDR keep the linear
//! values; PNG is written through a documented tone map.
//!
//! Tone map for PNG (see [`ToneMap`]): `srgb_encode(clamp(c · 2^exposure, 0, 1))`, the sRGB
//! transfer curve of IEC 61966-2-1 applied per channel with no other curve, so an image with
//! values in [0,1] and exposure 0 is written exactly as sRGB would show it.

use glam::Vec3;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}: {message}")]
    Io { path: PathBuf, message: String },
    #[error("{path}: unsupported image extension (use .exr, .hdr or .png)")]
    UnsupportedExtension { path: PathBuf },
    #[error("{path}: the image has zero size")]
    Empty { path: PathBuf },
}

/// A linear RGB image, row-major from the top-left pixel.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<Vec3>,
}

/// How linear radiance becomes 8-bit sRGB.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ToneMap {
    /// Stops: every value is multiplied by 2^exposure before encoding.
    pub exposure: f32,
}

impl Default for ToneMap {
    fn default() -> Self {
        Self { exposure: 0.0 }
    }
}

impl Image {
    pub fn new(width: u32, height: u32) -> Self {
        Self::filled(width, height, Vec3::ZERO)
    }

    pub fn filled(width: u32, height: u32, value: Vec3) -> Self {
        Self { width, height, pixels: vec![value; width as usize * height as usize] }
    }

    pub fn from_fn(width: u32, height: u32, f: impl Fn(u32, u32) -> Vec3) -> Self {
        let pixels = (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| f(x, y)).collect();
        Self { width, height, pixels }
    }

    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    pub fn get(&self, x: u32, y: u32) -> Vec3 {
        self.pixels[(y * self.width + x) as usize]
    }

    pub fn set(&mut self, x: u32, y: u32, v: Vec3) {
        self.pixels[(y * self.width + x) as usize] = v;
    }

    /// Mean of all pixels.
    pub fn mean(&self) -> Vec3 {
        let sum: glam::DVec3 = self.pixels.iter().map(|p| p.as_dvec3()).sum();
        (sum / self.pixels.len().max(1) as f64).as_vec3()
    }

    /// Bilinear lookup with `u, v` in [0,1]², wrapping in u and clamping in v (the convention
    /// of equirectangular maps; textures use [`Image::sample_repeat`]).
    pub fn sample_bilinear(&self, u: f32, v: f32, wrap_v: bool) -> Vec3 {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = u * w as f32 - 0.5;
        let y = v * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        // Inside the image (nearly every fetch) no division: `rem_euclid` only for the border
        // texels and tiled uvs. Four fetches × two divisions were 5 % of a path-traced frame.
        let wrap = |i: i64, n: i64| if (0..n).contains(&i) { i } else { i.rem_euclid(n) };
        let fetch = |xi: i64, yi: i64| {
            let xi = wrap(xi, w);
            let yi = if wrap_v { wrap(yi, h) } else { yi.clamp(0, h - 1) };
            self.pixels[(yi * w + xi) as usize]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = fetch(x0, y0).lerp(fetch(x0 + 1, y0), fx);
        let bottom = fetch(x0, y0 + 1).lerp(fetch(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }

    /// Bilinear texture lookup, repeating in both directions.
    pub fn sample_repeat(&self, u: f32, v: f32) -> Vec3 {
        self.sample_bilinear(u, v, true)
    }

    /// Reads an `.exr`, `.hdr` or `.png` (sRGB-decoded to linear) file.
    pub fn read(path: &Path) -> Result<Image, ImageError> {
        Self::read_decoded(path, true)
    }

    /// Reads a data texture (a normal map): its channels raw, an 8-bit PNG's not sRGB-decoded.
    pub fn read_raw(path: &Path) -> Result<Image, ImageError> {
        Self::read_decoded(path, false)
    }

    fn read_decoded(path: &Path, decode_srgb: bool) -> Result<Image, ImageError> {
        let (dynamic, ext) = Self::decode(path)?;
        let srgb = decode_srgb && matches!(ext.as_str(), "png" | "jpg" | "jpeg");
        let rgb = dynamic.into_rgb32f();
        let (width, height) = rgb.dimensions();
        let pixels = rgb
            .pixels()
            .map(|p| {
                let c = Vec3::new(p.0[0], p.0[1], p.0[2]);
                if srgb { Vec3::new(srgb_decode(c.x), srgb_decode(c.y), srgb_decode(c.z)) } else { c }
            })
            .collect();
        Ok(Image { width, height, pixels })
    }

    /// Reads a coverage (alpha) texture: the file's alpha channel where it has one, else its
    /// first channel, raw (data, not sRGB-decoded), in every channel of the result.
    pub fn read_coverage(path: &Path) -> Result<Image, ImageError> {
        let (dynamic, _) = Self::decode(path)?;
        let alpha = dynamic.color().has_alpha();
        let rgba = dynamic.into_rgba32f();
        let (width, height) = rgba.dimensions();
        let pixels = rgba.pixels().map(|p| Vec3::splat(if alpha { p.0[3] } else { p.0[0] })).collect();
        Ok(Image { width, height, pixels })
    }

    /// The decoded file (checked: extension, size, EXR headers, non-empty) and its extension.
    fn decode(path: &Path) -> Result<(::image::DynamicImage, String), ImageError> {
        let io = |message: String| ImageError::Io { path: path.to_owned(), message };
        let ext = extension(path);
        if !matches!(ext.as_str(), "exr" | "hdr" | "png" | "jpg" | "jpeg") {
            return Err(ImageError::UnsupportedExtension { path: path.to_owned() });
        }
        // A regular file under the image limit (not /dev/zero, not a FIFO).
        crate::bounded_read::check_file(path, "image", crate::bounded_read::limit::IMAGE).map_err(|e| io(e.reason()))?;
        if ext == "exr" {
            check_exr_headers(path).map_err(io)?;
        }
        // The decoders are third-party code: a panic on a crafted file is an error naming it.
        let decoded = crate::catch_panic::catch(|| {
            ::image::ImageReader::open(path)
                .map_err(|e| e.to_string())?
                .with_guessed_format()
                .map_err(|e| e.to_string())?
                .decode()
                .map_err(|e| e.to_string())
        });
        let dynamic = decoded.map_err(|m| io(format!("the image decoder failed on this file (internal panic: {m})")))?.map_err(io)?;
        if dynamic.width() == 0 || dynamic.height() == 0 {
            return Err(ImageError::Empty { path: path.to_owned() });
        }
        Ok((dynamic, ext))
    }

    /// Writes by extension: `.exr` (linear f32), `.hdr` (linear RGBE) or `.png` (tone-mapped).
    pub fn write(&self, path: &Path, tone: ToneMap) -> Result<(), ImageError> {
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::Empty { path: path.to_owned() });
        }
        let io = |message: String| ImageError::Io { path: path.to_owned(), message };
        let encode = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            let other = |e: &dyn std::fmt::Display| std::io::Error::other(e.to_string());
            match extension(path).as_str() {
                "exr" => {
                    // Scanline blocks, ZIP compression, increasing line order: the most widely
                    // readable lossless form (the `image` crate's encoder writes 64² RLE tiles in
                    // random line order, which NVIDIA's `flip` tool cannot load).
                    use exr::prelude::{Encoding, Layer, LayerAttributes, SpecificChannels, Vec2, WritableImage};
                    let width = self.width as usize;
                    let channels = SpecificChannels::rgb(|p: Vec2<usize>| {
                        let c = self.pixels[p.y() * width + p.x()];
                        (c.x, c.y, c.z)
                    });
                    let layer = Layer::new((width, self.height as usize), LayerAttributes::default(), Encoding::SMALL_LOSSLESS, channels);
                    exr::image::Image::from_layer(layer).write().to_buffered(w).map_err(|e| other(&e))
                }
                "hdr" => {
                    let data: Vec<f32> = self.pixels.iter().flat_map(|p| p.to_array()).collect();
                    let buf = ::image::Rgb32FImage::from_raw(self.width, self.height, data)
                        .ok_or_else(|| std::io::Error::other("pixel count does not match the size"))?;
                    buf.write_to(w, ::image::ImageFormat::Hdr).map_err(|e| other(&e))
                }
                _ => self.to_srgb8(tone).write_to(w, ::image::ImageFormat::Png).map_err(|e| other(&e)),
            }
        };
        if !matches!(extension(path).as_str(), "exr" | "hdr" | "png") {
            return Err(ImageError::UnsupportedExtension { path: path.to_owned() });
        }
        // Temporary file, flush, sync, rename: a failure leaves the previous file untouched.
        crate::atomic_file::write_atomic(path, encode).map_err(|e| io(format!("cannot {}: {}", e.step, e.source)))
    }

    /// Writes an `.exr` holding this image as its R, G, B channels and `extra` channel groups
    /// (AOVs) beside them, named `group.channel` (e.g. `albedo.R`, `normal.X`, `depth.Z`): one
    /// part with dotted channel names, the layout tev, Blender and denoisers' tools read as
    /// layers. Each extra channel holds `width × height` values in scanline order.
    pub fn write_exr_with_channels(&self, path: &Path, extra: &[(String, Vec<f32>)]) -> Result<(), ImageError> {
        let io = |message: String| ImageError::Io { path: path.to_owned(), message };
        if extension(path) != "exr" {
            return Err(io("extra channels (AOVs) need an .exr output".into()));
        }
        let n = self.pixels.len();
        if self.width == 0 || self.height == 0 {
            return Err(ImageError::Empty { path: path.to_owned() });
        }
        if let Some((name, _)) = extra.iter().find(|(_, v)| v.len() != n) {
            return Err(io(format!("channel {name} does not hold one value per pixel")));
        }
        use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec, WritableImage};
        let mut channels: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
        for (k, name) in ["R", "G", "B"].iter().enumerate() {
            channels.push(AnyChannel::new(*name, FlatSamples::F32(self.pixels.iter().map(|p| p[k]).collect())));
        }
        for (name, values) in extra {
            channels.push(AnyChannel::new(name.as_str(), FlatSamples::F32(values.clone())));
        }
        let size = (self.width as usize, self.height as usize);
        let layer = Layer::new(size, LayerAttributes::default(), Encoding::SMALL_LOSSLESS, AnyChannels::sort(channels));
        let encode = |w: &mut std::io::BufWriter<std::fs::File>| -> std::io::Result<()> {
            exr::image::Image::from_layer(layer).write().to_buffered(w).map_err(|e| std::io::Error::other(e.to_string()))
        };
        crate::atomic_file::write_atomic(path, encode).map_err(|e| io(format!("cannot {}: {}", e.step, e.source)))
    }

    /// The tone-mapped 8-bit sRGB image (see the module doc for the curve).
    pub fn to_srgb8(&self, tone: ToneMap) -> ::image::RgbImage {
        let scale = tone.exposure.exp2();
        let data: Vec<u8> = self
            .pixels
            .iter()
            .flat_map(|p| {
                let c = *p * scale;
                [c.x, c.y, c.z].map(|v| (srgb_encode(if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) }) * 255.0 + 0.5) as u8)
            })
            .collect();
        ::image::RgbImage::from_raw(self.width, self.height, data).expect("size matches pixels")
    }
}

fn extension(path: &Path) -> String {
    path.extension().and_then(|e| e.to_str()).unwrap_or("").to_ascii_lowercase()
}

/// The sRGB transfer function (linear → encoded), for values in [0,1].
pub fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

/// The inverse sRGB transfer function (encoded → linear), for values in [0,1].
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.040_45 { v / 12.92 } else { ((v + 0.055) / 1.055).powf(2.4) }
}

/// Most bytes one EXR layer (or one of its blocks) may decode to: 16384² pixels of four f32
/// channels, the largest frame glimpse renders.
const EXR_MAX_BYTES: u64 = 16384 * 16384 * 16;

/// An EXR's headers, read and sized before its pixels are decoded: the decoder allocates each
/// block's output from the header's sizes, so a crafted header made it ask for 36 GiB at once
/// (found by the fuzz test), which aborts the process instead of returning an error.
fn check_exr_headers(path: &Path) -> Result<(), String> {
    use exr::meta::BlockDescription;
    let meta = crate::catch_panic::catch(|| exr::meta::MetaData::read_from_file(path, false))
        .map_err(|m| format!("the EXR header reader failed on this file (internal panic: {m})"))?
        .map_err(|e| format!("bad EXR header: {e}"))?;
    for h in meta.headers.iter() {
        if h.deep {
            return Err("deep EXR images are not supported".into());
        }
        let (w, ht) = (h.layer_size.0 as u64, h.layer_size.1 as u64);
        let bytes_per_pixel = h.channels.bytes_per_pixel as u64;
        let block_pixels = match h.blocks {
            BlockDescription::ScanLines => Some(h.compression.scan_lines_per_block() as u64 * w),
            BlockDescription::Tiles(t) => (t.tile_size.0 as u64).checked_mul(t.tile_size.1 as u64),
        };
        let layer = w.checked_mul(ht).and_then(|p| p.checked_mul(bytes_per_pixel));
        let block = block_pixels.and_then(|p| p.checked_mul(bytes_per_pixel));
        if layer.is_none_or(|b| b > EXR_MAX_BYTES) || block.is_none_or(|b| b > EXR_MAX_BYTES) {
            return Err(format!(
                "an EXR layer of {w}x{ht} pixels of {bytes_per_pixel} bytes is over the reader's limit of {EXR_MAX_BYTES} bytes per layer and block"
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient() -> Image {
        Image::from_fn(7, 5, |x, y| Vec3::new(x as f32 * 0.37, y as f32 * 1.5 + 0.01, 100.0 / (1.0 + x as f32)))
    }

    /// A fresh folder, removed when the test ends (also when it fails).
    fn temp_dir(name: &str) -> tempfile::TempDir {
        tempfile::Builder::new().prefix(&format!("glimpse-{name}-")).tempdir().unwrap()
    }

    #[test]
    fn exr_round_trip_is_exact() {
        let dir = temp_dir("img");
        let img = gradient();
        let p = dir.path().join("a.exr");
        img.write(&p, ToneMap::default()).unwrap();
        assert_eq!(Image::read(&p).unwrap(), img);
    }

    #[test]
    fn hdr_round_trip_keeps_rgbe_precision() {
        let dir = temp_dir("img");
        let img = gradient();
        let p = dir.path().join("a.hdr");
        img.write(&p, ToneMap::default()).unwrap();
        let back = Image::read(&p).unwrap();
        // RGBE shares one exponent per pixel, so the error is relative to the pixel's largest channel.
        let worst =
            img.pixels.iter().zip(&back.pixels).map(|(a, b)| (*a - *b).abs().max_element() / a.max_element()).fold(0.0f32, f32::max);
        println!("RGBE error relative to the largest channel, worst {worst:.4}");
        assert!(worst < 0.01, "RGBE keeps 8 mantissa bits");
    }

    #[test]
    fn png_tone_map_is_srgb() {
        let img = Image::from_fn(3, 1, |x, _| Vec3::splat([0.0, 0.5, 4.0][x as usize]));
        let ldr = img.to_srgb8(ToneMap::default());
        assert_eq!(ldr.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(ldr.get_pixel(1, 0).0, [188, 188, 188], "0.5 linear is 188 in sRGB");
        assert_eq!(ldr.get_pixel(2, 0).0, [255, 255, 255]);
        let darker = img.to_srgb8(ToneMap { exposure: -3.0 });
        assert_eq!(darker.get_pixel(2, 0).0, [188, 188, 188], "4 · 2^-3 = 0.5");
        assert!((srgb_decode(srgb_encode(0.2)) - 0.2).abs() < 1e-6);
    }

    #[test]
    fn a_failed_write_keeps_the_previous_file() {
        let tmp = temp_dir("img-fail");
        let dir = tmp.path();
        for ext in ["png", "hdr", "exr"] {
            let p = dir.join(format!("old.{ext}"));
            gradient().write(&p, ToneMap::default()).unwrap();
            let before = std::fs::read(&p).unwrap();
            // A path that is a folder: encoding succeeds, the final rename fails.
            let blocked = dir.join(format!("folder.{ext}"));
            std::fs::create_dir_all(&blocked).unwrap();
            let e = gradient().write(&blocked, ToneMap::default()).unwrap_err().to_string();
            println!("{e}");
            assert!(e.contains(&format!("folder.{ext}")), "{e}");
            assert_eq!(std::fs::read(&p).unwrap(), before);
        }
        let leftovers: Vec<_> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .filter(|e| e.file_name().to_string_lossy().contains(crate::atomic_file::TEMP_MARKER))
            .collect();
        assert!(leftovers.is_empty(), "temporary files left: {leftovers:?}");
        let e = gradient().write(Path::new("/nonexistent-dir/x.png"), ToneMap::default()).unwrap_err().to_string();
        assert!(e.contains("/nonexistent-dir/x.png"), "{e}");
    }

    #[test]
    fn unsupported_extension_and_missing_file_name_the_path() {
        let e = Image::read(Path::new("/nonexistent/x.exr")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/x.exr"), "{e}");
        let e = gradient().write(Path::new("/tmp/x.bmpx"), ToneMap::default()).unwrap_err().to_string();
        assert!(e.contains("unsupported"), "{e}");
    }
}
