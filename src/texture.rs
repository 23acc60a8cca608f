//! Image textures: a material parameter that varies over a surface by its
//! UV coordinates.
//!
//! Conventions (those of OBJ and OpenGL): `u` runs left to right across the
//! image and `v` from the *bottom* row (`v = 0`) to the top row (`v = 1`).
//! How a texture is looked up ([`Sampling`]): the surface's UV first goes
//! through an affine map (`to_uv`, Mitsuba's parameter of that name), then
//! the lookup is bilinear between texel centres or takes the nearest texel,
//! and coordinates outside `[0, 1)` repeat, mirror or clamp to the edge
//! (bilinear, repeating, no map by default). Colour textures (base colour)
//! are decoded from sRGB to linear RGB on load; data textures (roughness,
//! metallic) are read as stored (8-bit values map to `[0, 1]`), and a
//! scalar parameter reads the red channel. Floating-point images (OpenEXR,
//! Radiance HDR) are linear already and never decoded.
//!
//! A checkerboard ([`ImageTexture::checkerboard`], Mitsuba's
//! `checkerboard`) is a 2 × 2 texture looked up by the nearest texel.
//!
//! ```toml
//! [[materials]]
//! name = "painted"
//! type = "principled"
//! base_color_map = "textures/paint.png"    # sRGB
//! roughness_map = "textures/rough.png"     # linear, red channel
//! ```

use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
use plsr_base::Vocabulary;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A texture image that could not be loaded. Its text names the image; the
/// scene reader adds the scene file and field.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// The path is not a readable regular file.
    #[error("{}: texture file {fault}", path.display())]
    NotAFile {
        /// The image.
        path: PathBuf,
        /// What the path is instead.
        fault: crate::input::NotAFile,
    },
    /// The decoder refused the file.
    #[error("{}: cannot read texture: {source}", path.display())]
    Decode {
        /// The image.
        path: PathBuf,
        /// The decoder's error.
        source: image::ImageError,
    },
    /// The image has no pixels.
    #[error("{}: the texture is empty", .0.display())]
    Empty(PathBuf),
    /// Some texel is not finite.
    #[error("{}: the texture has non-finite values", .0.display())]
    NonFinite(PathBuf),
    /// Its texels, as the header sizes them, would not fit in the free
    /// memory.
    #[error(
        "{}: the header says {width}×{height} texels: {needed} once decoded, more than the {free} free",
        path.display()
    )]
    TooLarge {
        /// The image.
        path: PathBuf,
        /// Its width in texels, as its header says.
        width: u32,
        /// Its height.
        height: u32,
        /// The bytes decoding needs, in words ("3.2 GiB").
        needed: String,
        /// The free memory, in words.
        free: String,
    },
}

/// The bytes decoding a texel costs at its peak: the decoder's RGB floats
/// and the texture's own (12 bytes each).
const DECODED_BYTES_PER_TEXEL: u64 = 24;

/// How a texture's stored values map to linear values.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// sRGB-encoded colour (8-bit photos, paintings): decoded to linear.
    Srgb,
    /// Data stored linearly (roughness, metallic maps).
    Linear,
}

/// How texels are combined at a lookup.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Filter {
    /// Bilinear between the four nearest texel centres.
    #[default]
    Bilinear,
    /// The texel the point falls in.
    Nearest,
}

/// What lies outside the image's `[0, 1)²`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wrap {
    /// The image again (tiling).
    #[default]
    Repeat,
    /// The image mirrored, every other tile.
    Mirror,
    /// The edge texels, stretched.
    Clamp,
}

/// How a texture is looked up.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Sampling {
    /// Bilinear or nearest.
    pub filter: Filter,
    /// Outside `[0, 1)`: along `u` (the image's width), then along `v`
    /// (its height), as glTF's `wrapS` and `wrapT`.
    pub wrap: [Wrap; 2],
    /// An affine map of the surface's UV, `[[a, b, c], [d, e, f]]`: the
    /// lookup is at `(a·u + b·v + c, d·u + e·v + f)`; `None` is the
    /// identity.
    pub to_uv: Option<[[f32; 3]; 2]>,
}

/// An RGB image sampled by UV, linear values.
#[derive(Debug, Clone, PartialEq)]
pub struct ImageTexture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// The texels, row-major from the top row.
    texels: TexelStore,
    /// How it is looked up.
    pub sampling: Sampling,
}

/// How a texture holds its texels.
#[derive(Debug, Clone, PartialEq)]
enum TexelStore {
    /// Linear RGB, 12 bytes a texel (HDR images, computed textures).
    Linear(Vec<Vec3>),
    /// 8-bit RGBA as the image file stores it, 4 bytes a texel, shared by
    /// every texture made of one image and decoded at each lookup.
    Packed {
        /// The image's texels.
        texels: Arc<[[u8; 4]]>,
        /// What a texel means.
        decode: PackedDecode,
        /// The bytes' values under `decode.srgb` (one of [`BYTE_TABLES`]),
        /// found once here rather than at every lookup.
        table: &'static [f32; 256],
    },
}

/// What the texels of a packed (8-bit) image mean to one texture: the
/// value looked up is `scale · decoded(channels) + offset`, `decoded` the
/// stored byte through the sRGB curve or linearly to `[0, 1]`. Bilinear
/// filtering commutes with this affine map, so filtering the decoded
/// texels gives what filtering the stored ones and then decoding would.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedDecode {
    /// The stored channel (0 R, 1 G, 2 B, 3 A) each of the three values
    /// reads.
    pub channels: [u8; 3],
    /// Whether the stored values are sRGB-encoded (colour) or linear
    /// (data: roughness, normals, alpha).
    pub srgb: bool,
    /// Multiplies the decoded values (a glTF factor).
    pub scale: Vec3,
    /// Added after the scale.
    pub offset: Vec3,
}

impl PackedDecode {
    /// Colour: RGB through the sRGB curve, times `scale`.
    pub fn srgb_color(scale: Vec3) -> PackedDecode {
        PackedDecode {
            channels: [0, 1, 2],
            srgb: true,
            scale,
            offset: Vec3::ZERO,
        }
    }

    /// One stored channel, linear, times `scale`, in all three values.
    pub fn channel(channel: u8, scale: f32) -> PackedDecode {
        PackedDecode {
            channels: [channel; 3],
            srgb: false,
            scale: Vec3::splat(scale),
            offset: Vec3::ZERO,
        }
    }
}

/// The 256 bytes' values: linear (`b / 255`) and through the sRGB curve.
struct ByteTables {
    linear: [f32; 256],
    srgb: [f32; 256],
}

static BYTE_TABLES: std::sync::LazyLock<ByteTables> = std::sync::LazyLock::new(|| ByteTables {
    linear: std::array::from_fn(|b| b as f32 / 255.0),
    srgb: std::array::from_fn(|b| srgb_to_linear(b as f32 / 255.0)),
});

/// sRGB transfer function, decoded: encoded value in `[0, 1]` to linear.
#[inline]
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

impl ImageTexture {
    /// A texture from linear texels, row-major from the top row.
    pub fn from_texels(width: u32, height: u32, texels: Vec<Vec3>) -> ImageTexture {
        assert_eq!(texels.len(), (width * height) as usize, "texel count");
        assert!(width > 0 && height > 0, "empty texture");
        ImageTexture {
            width,
            height,
            texels: TexelStore::Linear(texels),
            sampling: Sampling::default(),
        }
    }

    /// A texture reading the 8-bit RGBA image `texels` (row-major from the
    /// top row, shared with other textures of the same image) as `decode`
    /// says: 4 bytes a texel however many textures read it.
    pub fn packed(
        width: u32,
        height: u32,
        texels: Arc<[[u8; 4]]>,
        decode: PackedDecode,
    ) -> ImageTexture {
        assert_eq!(
            texels.len(),
            width as usize * height as usize,
            "texel count"
        );
        assert!(width > 0 && height > 0, "empty texture");
        let tables = &*BYTE_TABLES;
        let table = if decode.srgb {
            &tables.srgb
        } else {
            &tables.linear
        };
        ImageTexture {
            width,
            height,
            texels: TexelStore::Packed {
                texels,
                decode,
                table,
            },
            sampling: Sampling::default(),
        }
    }

    /// Bytes held per texel (shared images counted in full).
    pub fn bytes_per_texel(&self) -> usize {
        match &self.texels {
            TexelStore::Linear(_) => std::mem::size_of::<Vec3>(),
            TexelStore::Packed { .. } => 4,
        }
    }

    /// Texel `i` (row-major), decoded.
    #[inline(always)]
    fn at(&self, i: usize) -> Vec3 {
        match &self.texels {
            TexelStore::Linear(t) => t[i],
            TexelStore::Packed {
                texels,
                decode,
                table,
            } => {
                let p = texels[i];
                let [r, g, b] = decode.channels.map(|c| table[p[c as usize & 3] as usize]);
                Vec3::new(r, g, b) * decode.scale + decode.offset
            }
        }
    }

    /// Every texel, decoded, row-major.
    fn decoded(&self) -> impl Iterator<Item = Vec3> + '_ {
        (0..self.width as usize * self.height as usize).map(|i| self.at(i))
    }

    /// Mitsuba's `checkerboard`: `color0` where the fractional parts of `u`
    /// and `v` are both below ½ or both above, `color1` elsewhere (a 2 × 2
    /// texture looked up by the nearest texel, repeating).
    pub fn checkerboard(color0: Vec3, color1: Vec3) -> ImageTexture {
        // Row 0 is the top (v in [½, 1)): u < ½ there is color1.
        let mut t = ImageTexture::from_texels(2, 2, vec![color1, color0, color0, color1]);
        t.sampling.filter = Filter::Nearest;
        t
    }

    /// The texture looked up as `sampling` says.
    pub fn with_sampling(mut self, sampling: Sampling) -> ImageTexture {
        self.sampling = sampling;
        self
    }

    /// Loads a PNG, JPEG, BMP or Radiance HDR file. The error message names the file and the
    /// decoder's complaint; callers add the scene field.
    pub fn load(
        path: &Path,
        encoding: Encoding,
    ) -> std::result::Result<ImageTexture, TextureError> {
        let at = path.to_path_buf();
        crate::input::check_regular_file(path).map_err(|fault| TextureError::NotAFile {
            path: at.clone(),
            fault,
        })?;
        let decode_error = |source| TextureError::Decode {
            path: at.clone(),
            source,
        };
        // The header's size first: a small file (a PNG of zeros compresses
        // 1000:1) can claim gigabytes of texels.
        let (width, height) = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(image::ImageError::IoError)
            .and_then(|r| r.into_dimensions())
            .map_err(decode_error)?;
        let needed = u64::from(width) * u64::from(height) * DECODED_BYTES_PER_TEXEL;
        if let Some(free) = crate::memory::available_bytes().filter(|&free| needed > free) {
            return Err(TextureError::TooLarge {
                path: at,
                width,
                height,
                needed: crate::memory::human_bytes(needed),
                free: crate::memory::human_bytes(free),
            });
        }
        let image = image::open(path).map_err(decode_error)?;
        // Floating-point images hold linear values already.
        let float = matches!(
            image.color(),
            image::ColorType::Rgb32F | image::ColorType::Rgba32F
        );
        let rgb = image.to_rgb32f();
        let (width, height) = rgb.dimensions();
        if width == 0 || height == 0 {
            return Err(TextureError::Empty(at));
        }
        let decode = |c: f32| match encoding {
            Encoding::Srgb if !float => srgb_to_linear(c.clamp(0.0, 1.0)),
            _ => c,
        };
        let texels = rgb
            .pixels()
            .map(|p| Vec3::new(decode(p[0]), decode(p[1]), decode(p[2])))
            .collect::<Vec<_>>();
        if texels.iter().any(|t| !t.is_finite()) {
            return Err(TextureError::NonFinite(at));
        }
        Ok(ImageTexture {
            width,
            height,
            texels: TexelStore::Linear(texels),
            sampling: Sampling::default(),
        })
    }

    /// The texture with every texel replaced by `f(texel)` (decoding data
    /// maps such as normal maps).
    pub fn map(mut self, f: impl Fn(Vec3) -> Vec3) -> ImageTexture {
        if let TexelStore::Linear(t) = &mut self.texels {
            for t in t.iter_mut() {
                *t = f(*t);
            }
            return self;
        }
        let texels = self.decoded().map(f).collect();
        self.texels = TexelStore::Linear(texels);
        self
    }

    /// The mean texel (linear RGB).
    pub fn mean(&self) -> Vec3 {
        let sum = self
            .decoded()
            .fold(glam::DVec3::ZERO, |s, t| s + t.as_dvec3());
        let n = self.width as usize * self.height as usize;
        (sum / n.max(1) as f64).as_vec3()
    }

    /// The largest value of any channel (for range checks of parameters).
    pub fn max_value(&self) -> f32 {
        self.decoded()
            .fold(f32::NEG_INFINITY, |m, t| m.max(t.max_element()))
    }

    fn texel(&self, x: i64, y: i64) -> Vec3 {
        let wrap = |i: i64, n: u32, mode: Wrap| -> usize {
            let n = n as i64;
            (match mode {
                Wrap::Repeat => i.rem_euclid(n),
                Wrap::Mirror => {
                    let m = i.rem_euclid(2 * n);
                    if m >= n {
                        2 * n - 1 - m
                    } else {
                        m
                    }
                }
                Wrap::Clamp => i.clamp(0, n - 1),
            }) as usize
        };
        let [wrap_u, wrap_v] = self.sampling.wrap;
        self.at(wrap(y, self.height, wrap_v) * self.width as usize + wrap(x, self.width, wrap_u))
    }

    /// The bilinearly filtered value at `uv` (repeating outside `[0, 1)`).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Vec3 {
        let uv = match self.sampling.to_uv {
            None => uv,
            Some([[a, b, c], [d, e, f]]) => {
                Vec2::new(a * uv.x + b * uv.y + c, d * uv.x + e * uv.y + f)
            }
        };
        if self.sampling.filter == Filter::Nearest {
            let x = (uv.x * self.width as f32).floor();
            let y = ((1.0 - uv.y) * self.height as f32).floor();
            if !(x.is_finite() && y.is_finite()) {
                return self.at(0);
            }
            return self.texel(x as i64, y as i64);
        }
        // Continuous texel coordinates; texel (i, j) has its centre at
        // (i + ½, j + ½), and row 0 is the top (v = 1).
        let x = uv.x * self.width as f32 - 0.5;
        let y = (1.0 - uv.y) * self.height as f32 - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return self.at(0);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = self.texel(x0, y0) * (1.0 - fx) + self.texel(x0 + 1, y0) * fx;
        let bottom = self.texel(x0, y0 + 1) * (1.0 - fx) + self.texel(x0 + 1, y0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }
}

impl ImageTexture {
    /// The derivatives `(∂T/∂u, ∂T/∂v)` of the bilinear lookup at `uv`
    /// (per unit of the surface's texture coordinates, through `to_uv`):
    /// the bilinear interpolant's own slopes, constant across a cell, as
    /// Mitsuba's `bitmap` differentiates for `bumpmap`. Zero for nearest
    /// lookups (a step function).
    pub fn eval_gradient(&self, uv: Vec2) -> [Vec3; 2] {
        let ([a, b, c], [d, e, f]) = match self.sampling.to_uv {
            None => ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
            Some([r0, r1]) => (r0, r1),
        };
        let st = Vec2::new(a * uv.x + b * uv.y + c, d * uv.x + e * uv.y + f);
        if self.sampling.filter == Filter::Nearest {
            return [Vec3::ZERO; 2];
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let x = st.x * w - 0.5;
        let y = (1.0 - st.y) * h - 0.5;
        if !(x.is_finite() && y.is_finite()) {
            return [Vec3::ZERO; 2];
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let (t00, t10) = (self.texel(x0, y0), self.texel(x0 + 1, y0));
        let (t01, t11) = (self.texel(x0, y0 + 1), self.texel(x0 + 1, y0 + 1));
        // Slopes per texel along x (right) and y (down the rows).
        let dx = (t10 - t00) * (1.0 - fy) + (t11 - t01) * fy;
        let dy = (t01 - t00) * (1.0 - fx) + (t11 - t10) * fx;
        // Per unit of the looked-up (s, t): x = s·w − ½, y = (1 − t)·h − ½.
        let (ds, dt) = (dx * w, -dy * h);
        [ds * a + dt * d, ds * b + dt * e]
    }
}

/// Loads a texture for a scene field, turning failures into input errors.
pub fn load_for(
    scene_file: &Path,
    field: &str,
    path: &Path,
    encoding: Encoding,
) -> Result<ImageTexture> {
    ImageTexture::load(path, encoding).map_err(|m| Error::input(scene_file, field, m.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker() -> ImageTexture {
        // Top row red, green; bottom row blue, white.
        ImageTexture::from_texels(2, 2, vec![Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE])
    }

    /// A PNG of an 8-bit RGB header claiming `w × h` pixels and one empty
    /// IDAT chunk: tens of bytes.
    fn png_header(w: u32, h: u32) -> Vec<u8> {
        let chunk = |kind: &[u8], data: &[u8]| {
            let mut c = (data.len() as u32).to_be_bytes().to_vec();
            c.extend_from_slice(kind);
            c.extend_from_slice(data);
            let mut crc = flate2::Crc::new();
            crc.update(kind);
            crc.update(data);
            c.extend_from_slice(&crc.sum().to_be_bytes());
            c
        };
        let mut ihdr = w.to_be_bytes().to_vec();
        ihdr.extend_from_slice(&h.to_be_bytes());
        ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend(chunk(b"IHDR", &ihdr));
        png.extend(chunk(b"IDAT", &[]));
        png.extend(chunk(b"IEND", &[]));
        png
    }

    #[test]
    fn a_texture_header_beyond_the_free_memory_is_refused_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("huge.png");
        // 2^20 × 2^20 texels: 24 TiB decoded, more than any machine here.
        std::fs::write(&path, png_header(1 << 20, 1 << 20)).unwrap();
        let e = ImageTexture::load(&path, Encoding::Srgb).unwrap_err();
        assert!(matches!(e, TextureError::TooLarge { .. }), "{e}");
        let message = e.to_string();
        assert!(
            message.contains("huge.png") && message.contains("1048576×1048576"),
            "{message}"
        );
        // A small header of the same kind goes on to the decoder, which
        // finds the data missing.
        std::fs::write(&path, png_header(4, 4)).unwrap();
        let e = ImageTexture::load(&path, Encoding::Srgb).unwrap_err();
        assert!(matches!(e, TextureError::Decode { .. }), "{e}");
    }

    #[test]
    fn the_gradient_is_the_bilinear_lookups_slope() {
        // A ramp along u and a ramp down v, through a to_uv map.
        let texels = (0..16)
            .map(|i| Vec3::new((i % 4) as f32 * 0.1, (i / 4) as f32 * 0.2, 0.0))
            .collect();
        let t = ImageTexture::from_texels(4, 4, texels).with_sampling(Sampling {
            to_uv: Some([[2.0, 0.5, 0.0], [0.0, 1.0, 0.0]]),
            ..Sampling::default()
        });
        let uv = Vec2::new(0.2, 0.4);
        let [du, dv] = t.eval_gradient(uv);
        let h = 1e-3;
        let fd = |d: Vec2| (t.eval(uv + d * h) - t.eval(uv - d * h)) / (2.0 * h);
        assert!(
            (du - fd(Vec2::X)).abs().max_element() < 1e-2,
            "{du} vs {}",
            fd(Vec2::X)
        );
        assert!(
            (dv - fd(Vec2::Y)).abs().max_element() < 1e-2,
            "{dv} vs {}",
            fd(Vec2::Y)
        );
        assert!(du.x > 0.0 && dv.y < 0.0, "rows run down: {du} {dv}");
        let nearest = t.clone().with_sampling(Sampling {
            filter: Filter::Nearest,
            ..t.sampling
        });
        assert_eq!(nearest.eval_gradient(uv), [Vec3::ZERO; 2]);
    }

    #[test]
    fn texel_centres_return_their_texel_and_v_runs_upwards() {
        let t = checker();
        assert_eq!(t.eval(Vec2::new(0.25, 0.75)), Vec3::X); // top left
        assert_eq!(t.eval(Vec2::new(0.75, 0.75)), Vec3::Y); // top right
        assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Vec3::Z); // bottom left
        assert_eq!(t.eval(Vec2::new(0.75, 0.25)), Vec3::ONE); // bottom right
    }

    #[test]
    fn lookups_are_bilinear_and_repeat() {
        let t = checker();
        let mid = t.eval(Vec2::new(0.5, 0.75));
        assert!((mid - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6, "{mid}");
        assert_eq!(
            t.eval(Vec2::new(1.25, -0.25)),
            t.eval(Vec2::new(0.25, 0.75))
        );
    }

    #[test]
    fn nearest_lookups_wrap_modes_and_uv_maps() {
        let nearest = |wrap| {
            checker().with_sampling(Sampling {
                filter: Filter::Nearest,
                wrap: [wrap; 2],
                to_uv: None,
            })
        };
        let t = nearest(Wrap::Repeat);
        // Anywhere in a texel: that texel, no blending.
        assert_eq!(t.eval(Vec2::new(0.49, 0.51)), Vec3::X);
        assert_eq!(t.eval(Vec2::new(0.51, 0.51)), Vec3::Y);
        assert_eq!(t.eval(Vec2::new(1.1, 0.9)), Vec3::X);
        // Mirror: the tile to the right is flipped left to right.
        let m = nearest(Wrap::Mirror);
        assert_eq!(m.eval(Vec2::new(1.1, 0.9)), Vec3::Y);
        assert_eq!(m.eval(Vec2::new(1.9, 0.9)), Vec3::X);
        assert_eq!(m.eval(Vec2::new(-0.1, 0.1)), Vec3::Z);
        // Clamp: the edge texel beyond the edge.
        let c = nearest(Wrap::Clamp);
        assert_eq!(c.eval(Vec2::new(7.0, 0.9)), Vec3::Y);
        assert_eq!(c.eval(Vec2::new(-3.0, -3.0)), Vec3::Z);
        // A map of UV: scaled by 2, the texture repeats twice.
        let s = nearest(Wrap::Repeat).with_sampling(Sampling {
            filter: Filter::Nearest,
            wrap: [Wrap::Repeat; 2],
            to_uv: Some([[2.0, 0.0, 0.0], [0.0, 2.0, 0.0]]),
        });
        assert_eq!(s.eval(Vec2::new(0.3, 0.3)), t.eval(Vec2::new(0.6, 0.6)));
        // Bilinear clamping blends nothing beyond the edge.
        let b = checker().with_sampling(Sampling {
            wrap: [Wrap::Clamp; 2],
            ..Sampling::default()
        });
        assert_eq!(b.eval(Vec2::new(0.0, 0.75)), Vec3::X);
        // Each axis has its own mode (glTF's wrapS, wrapT).
        let axes = |wrap| {
            checker().with_sampling(Sampling {
                filter: Filter::Nearest,
                wrap,
                to_uv: None,
            })
        };
        let clamp_u = axes([Wrap::Clamp, Wrap::Repeat]);
        assert_eq!(clamp_u.eval(Vec2::new(0.3, -0.1)), Vec3::X);
        assert_eq!(clamp_u.eval(Vec2::new(7.0, 0.9)), Vec3::Y);
        let clamp_v = axes([Wrap::Repeat, Wrap::Clamp]);
        assert_eq!(clamp_v.eval(Vec2::new(1.3, -0.1)), Vec3::Z);
        assert_eq!(clamp_v.eval(Vec2::new(1.3, 5.0)), Vec3::X);
    }

    #[test]
    fn a_checkerboard_is_mitsubas() {
        // Mitsuba: color0 where frac(u) > ½ and frac(v) > ½ agree.
        let (c0, c1) = (Vec3::splat(0.2), Vec3::splat(0.4));
        let t = ImageTexture::checkerboard(c0, c1);
        for (u, v) in [
            (0.1, 0.2),
            (0.7, 0.9),
            (3.6, -0.2),
            (-0.3, 0.4),
            (0.2, 0.8),
            (0.8, 0.1),
        ] {
            let (mu, mv) = (u - f32::floor(u) > 0.5, v - f32::floor(v) > 0.5);
            let want = if mu == mv { c0 } else { c1 };
            assert_eq!(t.eval(Vec2::new(u, v)), want, "({u}, {v})");
        }
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        // 8-bit 188 is about linear 0.5.
        assert!((srgb_to_linear(188.0 / 255.0) - 0.5029).abs() < 1e-3);
        assert!((srgb_to_linear(0.04) - 0.04 / 12.92).abs() < 1e-9);
    }

    #[test]
    fn packed_texels_look_up_as_their_decoded_floats() {
        // A 3 × 2 RGBA image, read as sRGB colour times a factor, as one
        // channel, and as a normal map's affine decoding: each lookup of
        // the packed texture equals the same lookup of the texels decoded
        // into floats first, with 4 bytes held per texel.
        let bytes: Vec<[u8; 4]> = (0..6u8)
            .map(|i| [i * 40, 250 - i * 30, 17 * i, 255 - 50 * i])
            .collect();
        let shared: Arc<[[u8; 4]]> = bytes.clone().into();
        let decodes = [
            PackedDecode::srgb_color(Vec3::new(0.9, 0.5, 1.0)),
            PackedDecode::channel(3, 0.7),
            PackedDecode {
                channels: [0, 1, 2],
                srgb: false,
                scale: Vec3::new(1.2, 1.2, 2.0),
                offset: Vec3::new(-0.6, -0.6, -1.0),
            },
        ];
        for decode in decodes {
            let floats: Vec<Vec3> = bytes
                .iter()
                .map(|p| {
                    let [r, g, b] = decode.channels.map(|c| {
                        let v = p[c as usize] as f32 / 255.0;
                        if decode.srgb {
                            srgb_to_linear(v)
                        } else {
                            v
                        }
                    });
                    Vec3::new(r, g, b) * decode.scale + decode.offset
                })
                .collect();
            for filter in [Filter::Bilinear, Filter::Nearest] {
                let sampling = Sampling {
                    filter,
                    wrap: [Wrap::Repeat, Wrap::Mirror],
                    to_uv: None,
                };
                let packed =
                    ImageTexture::packed(3, 2, shared.clone(), decode).with_sampling(sampling);
                let float = ImageTexture::from_texels(3, 2, floats.clone()).with_sampling(sampling);
                assert_eq!(packed.bytes_per_texel(), 4);
                for uv in [(0.1, 0.2), (0.5, 0.5), (0.93, 0.71), (-0.3, 1.4)] {
                    let uv = Vec2::new(uv.0, uv.1);
                    let (p, f) = (packed.eval(uv), float.eval(uv));
                    assert!(
                        (p - f).abs().max_element() < 1e-6,
                        "{decode:?} {uv}: {p} vs {f}"
                    );
                }
                assert!((packed.mean() - float.mean()).abs().max_element() < 1e-6);
            }
        }
    }
}
