//! plsr's own OpenEXR writer, for small scanline images with the header
//! attributes plsr writes.
//!
//! Loading OpenImageIO costs about 0.3 s of symbol lookups in its ~260
//! libraries, more than merging a small bracket stack; so
//! [`crate::ImageWriter`] writes an OpenEXR file of at most [`MAX_BYTES`]
//! of samples with the `exr` crate instead, when everything asked for has
//! the same meaning there ([`ExrBuffer::new`] returns `None` otherwise and
//! OpenImageIO writes the file, streaming it):
//! - 1, 3 or 4 channels (`Y`; `R G B`; `R G B A`, OpenImageIO's names),
//!   stored as half or float;
//! - `compression` `none`, `rle`, `zips`, `zip` (the default) or `piz`;
//! - `ExposureTime` and `FNumber` (floats), written as OpenEXR's
//!   `expTime` and `aperture` as OpenImageIO writes them; `Software`,
//!   `Exif:ISOSpeedRatings` and `plsr:*` attributes of any type, under
//!   their own names.
//!
//! The rows are kept until [`ExrBuffer::write`], which writes the whole
//! file (attributes in name order, so the same image gives the same
//! bytes). Unlike OpenImageIO, it adds no `capDate` with the time of
//! writing.

use crate::{AttrValue, Attribute, PixelType, Sample};
use exr::prelude::{self as exrp, AnyChannel, AnyChannels, FlatSamples, WritableImage};
use std::io::Write;
use std::path::Path;

/// Images whose samples take more than this as `f32` (bytes; about 5.6
/// megapixels of RGB) go to OpenImageIO, which streams them to disk
/// instead of keeping them.
pub const MAX_BYTES: usize = 64 << 20;

/// An OpenEXR image being filled row by row.
#[derive(Debug)]
pub struct ExrBuffer {
    width: usize,
    height: usize,
    half: bool,
    /// One plane per channel, row-major, in the channels' order.
    planes: Vec<Vec<f32>>,
    compression: exrp::Compression,
    attributes: exrp::LayerAttributes,
}

/// Whether `path` is named as an OpenEXR file.
fn is_exr(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"))
}

impl ExrBuffer {
    /// A buffer for `path`, or `None` when the file is not one this writer
    /// handles (see the module's doc).
    pub fn new(
        path: &Path,
        width: usize,
        height: usize,
        channels: usize,
        stored: PixelType,
        attributes: &[Attribute],
    ) -> Option<ExrBuffer> {
        if !matches!(stored, PixelType::Half | PixelType::F32) {
            return None;
        }
        let samples = width.checked_mul(height)?.checked_mul(channels)?;
        if !is_exr(path) || !matches!(channels, 1 | 3 | 4) || samples.checked_mul(4)? > MAX_BYTES {
            return None;
        }
        let mut compression = exrp::Compression::ZIP16;
        let mut header = exrp::LayerAttributes::default();
        for (name, value) in attributes {
            match (name.as_str(), value) {
                ("compression", AttrValue::Str(c)) => {
                    compression = match c.as_str() {
                        "none" => exrp::Compression::Uncompressed,
                        "rle" => exrp::Compression::RLE,
                        "zips" => exrp::Compression::ZIP1,
                        "zip" => exrp::Compression::ZIP16,
                        "piz" => exrp::Compression::PIZ,
                        _ => return None,
                    }
                }
                ("ExposureTime", AttrValue::Float(t)) => header.exposure = Some(*t),
                ("FNumber", AttrValue::Float(n)) => header.aperture = Some(*n),
                (n, v)
                    if n == "Software" || n == "Exif:ISOSpeedRatings" || n.starts_with("plsr:") =>
                {
                    let value = match v {
                        AttrValue::Float(f) => exrp::AttributeValue::F32(*f),
                        AttrValue::Int(i) => exrp::AttributeValue::I32(*i),
                        AttrValue::Str(s) => exrp::AttributeValue::Text(
                            exrp::Text::from_slice_unchecked(s.as_bytes()),
                        ),
                    };
                    header
                        .other
                        .insert(exrp::Text::from_slice_unchecked(n.as_bytes()), value);
                }
                _ => return None,
            }
        }
        Some(ExrBuffer {
            width,
            height,
            half: stored == PixelType::Half,
            planes: vec![vec![0.0; width * height]; channels],
            compression,
            attributes: header,
        })
    }

    /// Stores rows `y0..y1` from `data` (interleaved; checked by the caller).
    pub fn write_rows<T: Sample>(&mut self, y0: usize, data: &[T]) {
        let n = self.planes.len();
        let start = y0 * self.width;
        for (i, pixel) in data.chunks_exact(n).enumerate() {
            for (plane, &v) in self.planes.iter_mut().zip(pixel) {
                plane[start + i] = v.to_f32();
            }
        }
    }

    /// Encodes the image into `file` (a new, empty file).
    pub fn write(self, file: &mut std::fs::File) -> Result<(), String> {
        let names: &[&str] = match self.planes.len() {
            1 => &["Y"],
            3 => &["R", "G", "B"],
            _ => &["R", "G", "B", "A"],
        };
        let half = self.half;
        let list: exrp::SmallVec<[AnyChannel<FlatSamples>; 4]> = self
            .planes
            .into_iter()
            .zip(names)
            .map(|(plane, name)| {
                let samples = if half {
                    FlatSamples::F16(plane.into_iter().map(exrp::f16::from_f32).collect())
                } else {
                    FlatSamples::F32(plane)
                };
                AnyChannel::new(*name, samples)
            })
            .collect();
        let encoding = exrp::Encoding {
            compression: self.compression,
            blocks: exrp::Blocks::ScanLines,
            line_order: exrp::LineOrder::Increasing,
        };
        let layer = exrp::Layer::new(
            (self.width, self.height),
            self.attributes,
            encoding,
            AnyChannels::sort(list),
        );
        let mut w = std::io::BufWriter::new(&mut *file);
        exrp::Image::from_layer(layer)
            .write()
            .to_buffered(&mut w)
            .map_err(|e| format!("cannot write OpenEXR: {e}"))?;
        w.flush().map_err(|e| e.to_string())?;
        drop(w);
        plsr_base::exr_header::sort_attributes(file).map_err(|e| e.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{write_image, ImageReader, ImageWriter, Sink};

    fn attributes(compression: &str) -> Vec<Attribute> {
        vec![
            ("compression".into(), AttrValue::Str(compression.into())),
            ("Software".into(), AttrValue::Str("plsr test".into())),
            ("plsr:note".into(), AttrValue::Str("héllo, 写真".into())),
            ("plsr:scale".into(), AttrValue::Float(2.5)),
            ("plsr:count".into(), AttrValue::Int(-7)),
            ("ExposureTime".into(), AttrValue::Float(0.125)),
            ("FNumber".into(), AttrValue::Float(5.6)),
            ("Exif:ISOSpeedRatings".into(), AttrValue::Int(400)),
        ]
    }

    fn is_native(w: &ImageWriter) -> bool {
        matches!(w.sink, Some(Sink::Exr(..)))
    }

    /// Pseudo-random HDR values over many stops (a fixed LCG).
    fn values(n: usize) -> Vec<f32> {
        let mut x = 12345u32;
        (0..n)
            .map(|_| {
                x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                ((x >> 8) as f32 / (1 << 24) as f32 * 24.0 - 12.0).exp2()
            })
            .collect()
    }

    /// What OpenImageIO reads back: values and the attributes plsr uses.
    fn read_back(path: &Path) -> (crate::ImageInfo, Vec<f32>, Vec<Option<String>>, crate::Exif) {
        let mut r = ImageReader::open(path).unwrap();
        let strings = ["Software", "plsr:note", "compression"]
            .iter()
            .map(|n| r.string_attribute(n))
            .collect();
        assert_eq!(
            r.float_attribute("plsr:scale"),
            Some(2.5),
            "{}",
            path.display()
        );
        (r.info().clone(), r.read_all().unwrap(), strings, r.exif())
    }

    #[test]
    fn openimageio_reads_back_what_it_would_have_written() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (29, 17);
        for channels in [1, 3, 4] {
            let data = values(w * h * channels);
            for stored in [PixelType::F32, PixelType::Half] {
                for compression in ["none", "rle", "zips", "zip", "piz"] {
                    let ours = dir
                        .path()
                        .join(format!("ours-{channels}-{compression}.exr"));
                    let theirs = dir
                        .path()
                        .join(format!("theirs-{channels}-{compression}.exr"));
                    let attrs = attributes(compression);
                    let mut writer =
                        ImageWriter::create(&ours, w, h, channels, stored, &attrs).unwrap();
                    assert!(is_native(&writer));
                    // In two bands, as the merge writes.
                    writer.write_rows(0, 5, &data[..5 * w * channels]).unwrap();
                    writer.write_rows(5, h, &data[5 * w * channels..]).unwrap();
                    writer.finish().unwrap();
                    // OpenImageIO's own file of the same image.
                    write_with_openimageio(&theirs, (w, h, channels), stored, &attrs, &data);
                    let a = read_back(&ours);
                    let b = read_back(&theirs);

                    assert_eq!(a, b, "{channels} channels, {stored:?}, {compression}");
                    assert_eq!(a.3.exposure_time, Some(0.125));
                    assert_eq!(a.3.f_number, Some(5.6f32 as f64));
                    if stored == PixelType::F32 {
                        assert_eq!(a.1, data);
                    }
                }
            }
        }
    }

    /// Writes through the shim, whatever the format.
    fn write_with_openimageio(
        path: &Path,
        (w, h, c): (usize, usize, usize),
        stored: PixelType,
        attrs: &[Attribute],
        data: &[f32],
    ) {
        let mut writer = ImageWriter::create_with_oiio(path, w, h, c, stored, attrs).unwrap();
        writer.write_rows(0, h, data).unwrap();
        writer.finish().unwrap();
    }

    #[test]
    fn the_same_image_gives_the_same_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let data = values(64 * 48 * 3);
        let attrs = attributes("zip");
        let a = dir.path().join("a.exr");
        let b = dir.path().join("b.exr");
        write_image(&a, 64, 48, 3, PixelType::Half, &attrs, &data).unwrap();
        write_image(&b, 64, 48, 3, PixelType::Half, &attrs, &data).unwrap();
        assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
    }

    #[test]
    fn what_it_cannot_write_the_same_goes_to_openimageio() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.exr");
        let native = |c: usize, stored: PixelType, attrs: &[Attribute], w: usize| {
            is_native(&ImageWriter::create(&p, w, 4, c, stored, attrs).unwrap())
        };
        let dwaa = [("compression".to_string(), AttrValue::Str("dwaa".into()))];
        let other = [(
            "oiio:ColorSpace".to_string(),
            AttrValue::Str("Linear".into()),
        )];
        assert!(native(3, PixelType::F32, &[], 4));
        assert!(!native(2, PixelType::F32, &[], 4));
        assert!(!native(3, PixelType::U16, &[], 4));
        assert!(!native(3, PixelType::F32, &dwaa, 4));
        assert!(!native(3, PixelType::F32, &other, 4));
        assert!(!native(3, PixelType::F32, &[], MAX_BYTES / 4 / 3 / 4 + 1));
        assert!(!is_native(
            &ImageWriter::create(&dir.path().join("x.tif"), 4, 4, 3, PixelType::F32, &[]).unwrap()
        ));
        // Nothing is left behind by writers dropped unfinished.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn an_unwritable_folder_is_an_error_at_creation() {
        let e = ImageWriter::create(
            Path::new("/nonexistent/x.exr"),
            4,
            4,
            3,
            PixelType::F32,
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("/nonexistent/x.exr"), "{e}");
    }
}
