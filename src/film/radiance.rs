//! Reading Radiance HDR (`.hdr`, RGBE) images as linear RGB.
//!
//! Radiance's own tools write header lines before the `#?RADIANCE` magic
//! line when they process a file (Paul Debevec's Memorial Church map starts
//! with `VIEW= …`); decoders that expect the magic first refuse them. The
//! magic is looked for in the first 4 KiB and the header read from there.

use crate::error::Result;
use glam::Vec3;
use plsr_base::Vocabulary;
use std::path::Path;

/// How far into a file the magic line may start.
const MAGIC_WITHIN: usize = 4096;

/// Reads `path` as Radiance HDR: width, height and the pixels, row-major
/// from the top row.
pub fn read_radiance_hdr(path: &Path) -> Result<(u32, u32, Vec<Vec3>)> {
    let fail = |m: String| crate::Error::input(path, "", m);
    let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {e}")))?;
    let start = bytes
        .windows(2)
        .take(MAGIC_WITHIN)
        .position(|w| w == b"#?")
        .ok_or_else(|| fail("not a Radiance HDR file: no `#?RADIANCE` line at its start".into()))?;
    let decoder = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(&bytes[start..]))
        .map_err(|e| fail(format!("cannot read as Radiance HDR: {e}")))?;
    check_size(decoder.metadata(), bytes.len() as u64).map_err(fail)?;
    let image = image::DynamicImage::from_decoder(decoder)
        .map_err(|e| fail(format!("cannot read as Radiance HDR: {e}")))?
        .to_rgb32f();
    let (w, h) = image.dimensions();
    Ok((
        w,
        h,
        image
            .pixels()
            .map(|p| Vec3::new(p[0], p[1], p[2]))
            .collect(),
    ))
}

/// The most pixels a byte of a Radiance HDR file holds: run-length
/// encoded rows store a run of up to 127 values of one component in 2
/// bytes, so four components of 127 pixels take 8 bytes.
const MAX_PIXELS_PER_BYTE: u64 = 16;

/// Refuses a header whose size the file cannot hold, or whose pixels (12
/// bytes each once decoded) would not fit in the free memory, before the
/// decoder allocates for it.
fn check_size(
    header: image::codecs::hdr::HdrMetadata,
    file_len: u64,
) -> std::result::Result<(), String> {
    let (w, h) = (u64::from(header.width), u64::from(header.height));
    let pixels = w * h;
    if pixels > MAX_PIXELS_PER_BYTE * file_len {
        return Err(format!(
            "the header says {w}×{h} pixels, which a file of {file_len} bytes cannot hold"
        ));
    }
    let bytes = pixels * 12;
    if let Some(free) = crate::memory::available_bytes().filter(|&free| bytes > free) {
        return Err(format!(
            "the header says {w}×{h} pixels: {} once decoded, more than the {} free",
            crate::memory::human_bytes(bytes),
            crate::memory::human_bytes(free)
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn header_lines_before_the_magic_are_skipped() {
        let dir = tempfile::tempdir().unwrap();
        // A 2×1 flat (uncompressed) RGBE image: (1, 0.5, 0.25) and (2, 2, 2).
        let mut file =
            b"VIEW= -vtv -vh 90\n#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n".to_vec();
        file.extend_from_slice(&[128, 64, 32, 129, 128, 128, 128, 130]);
        let path = dir.path().join("viewed.hdr");
        std::fs::write(&path, &file).unwrap();
        let (w, h, px) = read_radiance_hdr(&path).unwrap();
        assert_eq!((w, h), (2, 1));
        // RGBE keeps 8 bits of mantissa: equal within a part in 256.
        assert!(
            px[0].abs_diff_eq(Vec3::new(1.0, 0.5, 0.25), 1.0 / 128.0),
            "{px:?}"
        );
        assert!(
            px[1].abs_diff_eq(Vec3::new(2.0, 2.0, 2.0), 1.0 / 64.0),
            "{px:?}"
        );
        // A header claiming more pixels than the file holds is refused
        // before anything is allocated for them.
        std::fs::write(
            &path,
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 30000 +X 30000\n\x02\x02",
        )
        .unwrap();
        let e = read_radiance_hdr(&path).unwrap_err().to_string();
        assert!(
            e.contains("30000×30000") && e.contains("cannot hold"),
            "{e}"
        );
        std::fs::write(&path, b"P6\n2 1\n255\n").unwrap();
        let e = read_radiance_hdr(&path).unwrap_err().to_string();
        assert!(e.contains("viewed.hdr") && e.contains("#?RADIANCE"), "{e}");
    }
}
