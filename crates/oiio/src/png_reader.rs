//! plsr's own PNG reader, for the common PNGs: 8- or 16-bit grey, RGB or
//! palette colour, with no alpha and no EXIF block.
//!
//! Loading OpenImageIO costs about 0.3 s of symbol lookups in its ~260
//! libraries, more than merging a small bracket stack; a PNG of these
//! kinds decodes the same in pure Rust (the `png` crate), so
//! [`crate::ImageReader`] reads it here and never loads OpenImageIO. The
//! values are those OpenImageIO gives: the stored levels, no gamma
//! applied, palettes expanded to RGB. Files this reader declines
//! ([`PngRows::open`] returns `Ok(None)`: alpha or `tRNS`, which
//! OpenImageIO premultiplies; fewer than 8 bits; an `eXIf` chunk; Adam7
//! interlacing) go to OpenImageIO as before.
//!
//! Rows stream in order, as OpenImageIO's do. An image of at most
//! [`KEEP_BYTES`] is kept once decoded, so a caller that reads it twice
//! (the bracket merge reads each file in two passes) decodes it once; a
//! larger one is decoded again from the start when rows before the last
//! one read are asked for.

use crate::{Error, ImageInfo, PixelType, Result, Sample};
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// Decoded images up to this size (bytes) are kept for re-reading.
pub const KEEP_BYTES: usize = 16 << 20;

/// An open PNG file, read row by row.
pub struct PngRows {
    path: PathBuf,
    info: ImageInfo,
    /// Text chunks (`tEXt`, `zTXt`, `iTXt`): keyword and text.
    text: Vec<(String, String)>,
    /// The decoder, positioned at row `next_row`.
    decoder: Option<png::Reader<BufReader<File>>>,
    next_row: usize,
    /// The size up to which a decoded image is kept ([`KEEP_BYTES`]).
    keep_bytes: usize,
    /// The whole image (the file's bytes per sample, big-endian for 16
    /// bits), once decoded, when it is at most [`KEEP_BYTES`].
    kept: Option<Vec<u8>>,
}

impl std::fmt::Debug for PngRows {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PngRows")
            .field("path", &self.path)
            .field("info", &self.info)
            .field("next_row", &self.next_row)
            .finish_non_exhaustive()
    }
}

/// Whether `path` is named as a PNG file.
pub fn is_png(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

impl PngRows {
    /// Opens `path` and reads its header: `Ok(None)` when the file is not
    /// one this reader handles (see the module's doc), an error when it is
    /// not a valid PNG.
    pub fn open(path: &Path) -> Result<Option<PngRows>> {
        let reader = decoder(path)?;
        let header = reader.info();
        check_size_against_file(path, header)?;
        let channels = match header.color_type {
            png::ColorType::Grayscale => 1,
            png::ColorType::Rgb | png::ColorType::Indexed => 3,
            png::ColorType::GrayscaleAlpha | png::ColorType::Rgba => return Ok(None),
        };
        let bits = match header.bit_depth {
            png::BitDepth::Eight => 8,
            png::BitDepth::Sixteen => 16,
            _ if header.color_type == png::ColorType::Indexed => 8,
            _ => return Ok(None),
        };
        if header.trns.is_some() || header.exif_metadata.is_some() || header.interlaced {
            return Ok(None);
        }
        let text = header
            .uncompressed_latin1_text
            .iter()
            .map(|t| (t.keyword.clone(), t.text.clone()))
            .chain(
                header
                    .compressed_latin1_text
                    .iter()
                    .filter_map(|t| Some((t.keyword.clone(), t.get_text().ok()?))),
            )
            .chain(
                header
                    .utf8_text
                    .iter()
                    .filter_map(|t| Some((t.keyword.clone(), t.get_text().ok()?))),
            )
            .collect();
        let info = ImageInfo {
            width: header.width as usize,
            height: header.height as usize,
            channels,
            format: if bits == 16 {
                PixelType::U16
            } else {
                PixelType::U8
            },
            bits,
        };
        Ok(Some(PngRows {
            path: path.to_path_buf(),
            info,
            text,
            decoder: Some(reader),
            next_row: 0,
            keep_bytes: KEEP_BYTES,
            kept: None,
        }))
    }

    /// Size, channels and depth.
    pub fn info(&self) -> &ImageInfo {
        &self.info
    }

    /// A text chunk's value, by keyword.
    pub fn text(&self, keyword: &str) -> Option<&str> {
        self.text
            .iter()
            .find(|(k, _)| k == keyword)
            .map(|(_, v)| v.as_str())
    }

    /// Bytes per stored row.
    fn row_bytes(&self) -> usize {
        self.info.width * self.info.channels * (self.info.bits as usize / 8)
    }

    /// Reads rows `y0..y1` converted to `T` into `out` (sized by the caller,
    /// [`crate::ImageReader::read_rows`] checks it).
    pub fn read_rows<T: Sample>(&mut self, y0: usize, y1: usize, out: &mut [T]) -> Result<()> {
        let row_values = self.info.width * self.info.channels;
        let row_bytes = self.row_bytes();
        let keep = row_bytes * self.info.height <= self.keep_bytes;
        if keep && self.kept.is_none() {
            let mut all = Vec::with_capacity(row_bytes * self.info.height);
            self.rewind_if_past(0)?;
            for _ in 0..self.info.height {
                all.extend_from_slice(self.next()?);
            }
            self.decoder = None;
            self.kept = Some(all);
        }
        let sixteen = self.info.bits == 16;
        if let Some(all) = &self.kept {
            for (y, dst) in (y0..y1).zip(out.chunks_exact_mut(row_values)) {
                convert(&all[y * row_bytes..(y + 1) * row_bytes], sixteen, dst);
            }
            return Ok(());
        }
        self.rewind_if_past(y0)?;
        while self.next_row < y0 {
            self.next()?;
        }
        for dst in out.chunks_exact_mut(row_values) {
            let row = self.next()?;
            convert(row, sixteen, dst);
        }
        Ok(())
    }

    /// Reopens the file when row `y` has already gone by.
    fn rewind_if_past(&mut self, y: usize) -> Result<()> {
        if self.decoder.is_none() || self.next_row > y {
            self.decoder = Some(decoder(&self.path)?);
            self.next_row = 0;
        }
        Ok(())
    }

    /// The next row's bytes.
    fn next(&mut self) -> Result<&[u8]> {
        let path = &self.path;
        let y = self.next_row;
        let decoder = self.decoder.as_mut().ok_or_else(|| Error::Read {
            file: path.clone(),
            message: "the PNG decoder is closed".into(),
        })?;
        let row = decoder
            .next_row()
            .map_err(|e| Error::Read {
                file: path.clone(),
                message: format!("row {y}: {e}"),
            })?
            .ok_or_else(|| Error::Read {
                file: path.clone(),
                message: format!("the image data ends before row {y}"),
            })?;
        self.next_row += 1;
        Ok(row.data())
    }
}

/// Deflate stores at most about 1032 bytes per compressed byte (a run of
/// 258-byte matches); this leaves room for zlib's and PNG's framing.
const MAX_DEFLATE_RATIO: u64 = 1040;

/// Refuses a header whose image cannot be in a file of this size: its
/// filtered rows (a filter byte and the stored samples each) would need
/// a better ratio than deflate reaches. A 50-byte file claiming
/// 30000×30000 pixels is caught here, before anyone allocates for it.
fn check_size_against_file(path: &Path, header: &png::Info) -> Result<()> {
    let file_bytes = std::fs::metadata(path).map(|m| m.len()).unwrap_or(u64::MAX);
    let bits_per_pixel = header.color_type.samples() as u64 * header.bit_depth as u8 as u64;
    let row = (u64::from(header.width) * bits_per_pixel).div_ceil(8) + 1;
    let stored = row.saturating_mul(u64::from(header.height));
    if stored > file_bytes.saturating_mul(MAX_DEFLATE_RATIO) + 4096 {
        return Err(Error::Read {
            file: path.to_path_buf(),
            message: format!(
                "the header says {}×{} pixels, {} bytes of image data, which a file of \
                 {file_bytes} bytes cannot hold (truncated, or a damaged or hostile header)",
                header.width, header.height, stored
            ),
        });
    }
    Ok(())
}

/// Opens `path` and reads the PNG header (palettes expanded to RGB); the
/// error names the file and what is wrong with it.
fn decoder(path: &Path) -> Result<png::Reader<BufReader<File>>> {
    let file = File::open(path).map_err(|e| Error::Read {
        file: path.to_path_buf(),
        message: e.to_string(),
    })?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    // Only rows (one at a time) are allocated by the decoder; the
    // caller's buffers are sized and checked by the caller.
    decoder.set_limits(png::Limits { bytes: 1 << 30 });
    decoder.set_transformations(png::Transformations::EXPAND);
    decoder.read_info().map_err(|e| Error::Read {
        file: path.to_path_buf(),
        message: format!("not a readable PNG file: {e}"),
    })
}

/// Converts one stored row (8-bit, or 16-bit big-endian) to `T`, scaling
/// as OpenImageIO does (0–1 for the full range of the stored type).
fn convert<T: Sample>(src: &[u8], sixteen: bool, dst: &mut [T]) {
    if sixteen {
        let level = |i: usize| u16::from_be_bytes([src[2 * i], src[2 * i + 1]]);
        for (i, d) in dst.iter_mut().enumerate() {
            *d = T::from_u16(level(i));
        }
    } else {
        for (d, &s) in dst.iter_mut().zip(src) {
            *d = T::from_u8(s);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{ImageReader, Source};

    /// Writes a PNG with the `png` crate's encoder.
    fn write_png(
        path: &Path,
        (w, h): (u32, u32),
        color: png::ColorType,
        depth: png::BitDepth,
        palette: Option<Vec<u8>>,
        data: &[u8],
    ) {
        let file = std::io::BufWriter::new(File::create(path).unwrap());
        let mut e = png::Encoder::new(file, w, h);
        e.set_color(color);
        e.set_depth(depth);
        if let Some(p) = palette {
            e.set_palette(p);
        }
        e.add_text_chunk("Comment".into(), "made for a test".into())
            .unwrap();
        let mut writer = e.write_header().unwrap();
        writer.write_image_data(data).unwrap();
        writer.finish().unwrap();
    }

    /// Pseudo-random bytes (a fixed LCG).
    fn bytes(n: usize, seed: u32) -> Vec<u8> {
        let mut x = seed;
        (0..n)
            .map(|_| {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                (x >> 24) as u8
            })
            .collect()
    }

    fn is_native(r: &ImageReader) -> bool {
        matches!(r.source, Source::Png(_))
    }

    /// plsr's reader and OpenImageIO's (libpng) give the same size, depth
    /// and values, as u8, u16 and f32.
    fn agrees_with_openimageio(path: &Path) {
        let mut ours = ImageReader::open(path).unwrap();
        let mut theirs = ImageReader::open_with_oiio(path).unwrap();
        assert!(is_native(&ours), "{}", path.display());
        assert_eq!(ours.info(), theirs.info(), "{}", path.display());
        fn same<T: Sample + PartialEq + std::fmt::Debug>(
            path: &Path,
            a: &mut ImageReader,
            b: &mut ImageReader,
        ) {
            let (a, b) = (a.read_all::<T>().unwrap(), b.read_all::<T>().unwrap());
            assert_eq!(a.len(), b.len());
            if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
                panic!(
                    "{}: value {i}: {:?} against {:?}",
                    path.display(),
                    a[i],
                    b[i]
                );
            }
        }
        same::<u8>(path, &mut ours, &mut theirs);
        same::<u16>(path, &mut ours, &mut theirs);
        same::<f32>(path, &mut ours, &mut theirs);
        assert_eq!(
            ours.string_attribute("Comment").as_deref(),
            Some("made for a test")
        );
    }

    #[test]
    fn common_pngs_read_as_openimageio_reads_them() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (37u32, 23u32);
        let n = (w * h) as usize;
        let rgb8 = dir.path().join("rgb8.png");
        write_png(
            &rgb8,
            (w, h),
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &bytes(n * 3, 1),
        );
        agrees_with_openimageio(&rgb8);
        let rgb16 = dir.path().join("rgb16.png");
        write_png(
            &rgb16,
            (w, h),
            png::ColorType::Rgb,
            png::BitDepth::Sixteen,
            None,
            &bytes(n * 6, 2),
        );
        agrees_with_openimageio(&rgb16);
        let grey = dir.path().join("grey.png");
        write_png(
            &grey,
            (w, h),
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            None,
            &bytes(n, 3),
        );
        agrees_with_openimageio(&grey);
        // A 4-bit palette of 16 colours: expanded to 8-bit RGB.
        let indexed = dir.path().join("indexed.png");
        let packed = bytes((w as usize).div_ceil(2) * h as usize, 4);
        write_png(
            &indexed,
            (w, h),
            png::ColorType::Indexed,
            png::BitDepth::Four,
            Some(bytes(48, 5)),
            &packed,
        );
        agrees_with_openimageio(&indexed);
    }

    #[test]
    fn rows_read_again_or_out_of_order_are_right_whether_kept_or_not() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (19usize, 41usize);
        let p = dir.path().join("rows.png");
        let data = bytes(w * h * 3, 7);
        write_png(
            &p,
            (w as u32, h as u32),
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &data,
        );
        for keep in [KEEP_BYTES, 0] {
            let mut r = ImageReader::open(&p).unwrap();
            if let Source::Png(png) = &mut r.source {
                png.keep_bytes = keep;
            }
            let mut band = vec![0u8; 5 * w * 3];
            for y0 in [30, 2, 2, 36, 0] {
                r.read_rows(y0, y0 + 5, &mut band).unwrap();
                assert_eq!(
                    band,
                    data[y0 * w * 3..(y0 + 5) * w * 3],
                    "keep {keep}, rows {y0}.."
                );
            }
        }
    }

    #[test]
    fn pngs_with_alpha_or_few_bits_go_to_openimageio() {
        let dir = tempfile::tempdir().unwrap();
        let rgba = dir.path().join("rgba.png");
        write_png(
            &rgba,
            (4, 3),
            png::ColorType::Rgba,
            png::BitDepth::Eight,
            None,
            &bytes(48, 8),
        );
        let r = ImageReader::open(&rgba).unwrap();
        assert!(!is_native(&r));
        assert_eq!(r.info().channels, 4);
        let bits2 = dir.path().join("grey2.png");
        write_png(
            &bits2,
            (8, 3),
            png::ColorType::Grayscale,
            png::BitDepth::Two,
            None,
            &bytes(6, 9),
        );
        assert!(!is_native(&ImageReader::open(&bits2).unwrap()));
    }

    #[test]
    fn a_header_larger_than_its_file_can_hold_is_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("huge.png");
        // A valid 1×1 PNG whose IHDR then claims 30000×30000 (CRC fixed).
        write_png(
            &p,
            (1, 1),
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &[1, 2, 3],
        );
        let mut bytes = std::fs::read(&p).unwrap();
        bytes[16..20].copy_from_slice(&30000u32.to_be_bytes());
        bytes[20..24].copy_from_slice(&30000u32.to_be_bytes());
        let crc = crc32(&bytes[12..29]);
        bytes[29..33].copy_from_slice(&crc.to_be_bytes());
        std::fs::write(&p, &bytes).unwrap();
        let e = ImageReader::open(&p).unwrap_err().to_string();
        assert!(e.contains("huge.png") && e.contains("30000×30000"), "{e}");
        // A real image of that ratio is well within deflate's reach.
        let flat = dir.path().join("flat.png");
        write_png(
            &flat,
            (2000, 1000),
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &vec![7; 6_000_000],
        );
        assert!(std::fs::metadata(&flat).unwrap().len() < 40_000);
        assert_eq!(
            ImageReader::open(&flat)
                .unwrap()
                .read_all::<u8>()
                .unwrap()
                .len(),
            6_000_000
        );
    }

    /// CRC-32 of PNG chunks (ISO 3309), bit by bit.
    fn crc32(data: &[u8]) -> u32 {
        let mut c = 0xffff_ffffu32;
        for &b in data {
            c ^= u32::from(b);
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xedb8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }

    #[test]
    fn a_truncated_png_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("cut.png");
        write_png(
            &p,
            (64, 64),
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            None,
            &bytes(64 * 64 * 3, 10),
        );
        let full = std::fs::read(&p).unwrap();
        std::fs::write(&p, &full[..full.len() / 2]).unwrap();
        let mut r = ImageReader::open(&p).unwrap();
        let e = r.read_all::<u8>().unwrap_err().to_string();
        assert!(e.contains("cut.png"), "{e}");
        std::fs::write(&p, &full[..20]).unwrap();
        let e = ImageReader::open(&p).unwrap_err().to_string();
        assert!(e.contains("cut.png") && e.contains("PNG"), "{e}");
    }
}
