//! OpenEXR headers: written the same way every time, and their sizes
//! checked before a reader trusts them.

use std::io::{Read, Seek, SeekFrom, Write};

const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
const MULTI_PART: u32 = 0x1000;
/// The header bytes looked at (a header is a few KiB at most in practice).
const HEAD_BYTES: u64 = 1 << 20;

/// One attribute of a header: its name, type and value, and its whole
/// encoding (name NUL, type NUL, size, value).
struct RawAttribute<'a> {
    name: &'a [u8],
    kind: &'a [u8],
    value: &'a [u8],
    whole: &'a [u8],
}

/// The attributes of a single-part header at the start of `head`, and the
/// offset of the header's end; `None` for a multi-part file or anything
/// this does not recognise.
fn attributes(head: &[u8]) -> Option<(Vec<RawAttribute<'_>>, usize)> {
    if head.len() < 8 || head[..4] != MAGIC {
        return None;
    }
    let version = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if version & MULTI_PART != 0 {
        return None;
    }
    let mut attributes = Vec::new();
    let mut at = 8;
    loop {
        let &first = head.get(at)?; // no end of header within the bytes read
        if first == 0 {
            return Some((attributes, at));
        }
        let start = at;
        let nul = |from: usize| head[from..].iter().position(|&b| b == 0).map(|i| from + i);
        let name_end = nul(at)?;
        let type_end = nul(name_end + 1)?;
        let size_at = type_end + 1;
        let size = head.get(size_at..size_at + 4)?;
        let size =
            usize::try_from(i32::from_le_bytes([size[0], size[1], size[2], size[3]])).ok()?;
        at = (size_at + 4).checked_add(size)?;
        if at > head.len() {
            return None;
        }
        attributes.push(RawAttribute {
            name: &head[start..name_end],
            kind: &head[name_end + 1..type_end],
            value: &head[size_at + 4..at],
            whole: &head[start..at],
        });
    }
}

/// Whether `path` starts with OpenEXR's magic number (`false` when it
/// cannot be read: the reader that opens it says why).
pub fn is_exr(path: &std::path::Path) -> bool {
    let mut magic = [0u8; 4];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut magic))
        .is_ok_and(|()| magic == MAGIC)
}

/// Reads the first bytes of `file`, where its header is.
fn head_of(file: &mut std::fs::File) -> std::io::Result<Vec<u8>> {
    let mut head = Vec::new();
    file.seek(SeekFrom::Start(0))?;
    Read::by_ref(file).take(HEAD_BYTES).read_to_end(&mut head)?;
    Ok(head)
}

/// Puts the header attributes of the single-part EXR file `file` (just
/// written) in name order, in place. The `exr` crate writes them in the
/// order of a `HashMap`, which changes from run to run, so the same image
/// would otherwise give different files. Reordering keeps the header's
/// length, so the offset table after it stays valid. Multi-part files, and
/// anything this does not recognise, are left as they are.
pub fn sort_attributes(file: &mut std::fs::File) -> std::io::Result<()> {
    let head = head_of(file)?;
    let Some((mut attributes, end)) = attributes(&head) else {
        return Ok(());
    };
    attributes.sort_by(|a, b| a.name.cmp(b.name));
    let sorted: Vec<u8> = attributes
        .iter()
        .flat_map(|a| a.whole.iter().copied())
        .collect();
    debug_assert_eq!(sorted.len(), end - 8);
    file.seek(SeekFrom::Start(8))?;
    file.write_all(&sorted)?;
    file.seek(SeekFrom::End(0))?;
    Ok(())
}

/// The fault of a single-part EXR file's header sizes, if it has one:
/// - a `dataWindow` (`box2i`: min x, min y, max x, max y, both corners
///   included) whose maximum is below its minimum, or wider or higher than
///   2³¹ (some readers take the size's magnitude and read such a file as an
///   image of another size);
/// - more sample bytes than the file can hold: its own length times the
///   most its `compression` expands ([`max_expansion`]). Readers allocate
///   for the header's size, so a 1 KiB file claiming 30000×30000 pixels
///   would otherwise cost gigabytes before its data is found missing.
///
/// - a single-part header that does not parse within the file.
///
/// Other files this does not recognise pass: the reader's own checks apply.
pub fn header_fault(path: &std::path::Path) -> std::io::Result<Option<String>> {
    let mut file = std::fs::File::open(path)?;
    let file_len = file.metadata()?.len();
    let head = head_of(&mut file)?;
    let Some((attributes, _)) = attributes(&head) else {
        // A single-part header that does not parse although the whole file
        // was read is malformed. Readers may still take attributes from it
        // (found by fuzzing: past an attribute whose size runs beyond the
        // file, the `exr` crate found a data window of 2·10⁸ pixels).
        let read_whole = (head.len() as u64) < HEAD_BYTES;
        let single_part = head.len() >= 8
            && head[..4] == MAGIC
            && u32::from_le_bytes([head[4], head[5], head[6], head[7]]) & MULTI_PART == 0;
        if read_whole && single_part {
            return Ok(Some(
                "the header does not parse: an attribute runs past the end of the file, or the \
                 header never ends"
                    .into(),
            ));
        }
        return Ok(None);
    };
    // A header may name an attribute twice (found by fuzzing: a second,
    // wider `dataWindow` after a good one), and readers differ in which
    // they take: every copy is checked, against the widest channel list
    // and the compression that expands most.
    let pixel_bytes = attributes
        .iter()
        .filter(|a| a.name == b"channels" && a.kind == b"chlist")
        .filter_map(|a| bytes_per_pixel(a.value))
        .max();
    let expansion = attributes
        .iter()
        .filter(|a| a.name == b"compression" && a.kind == b"compression" && a.value.len() == 1)
        .map(|a| max_expansion(a.value[0]))
        .max()
        .unwrap_or(1);
    let windows = attributes
        .iter()
        .filter(|a| a.name == b"dataWindow" && a.kind == b"box2i");
    for window in windows {
        // Found by fuzzing: a box2i of 18 bytes, whose first 16 the `exr`
        // crate read as a data window of 33,554,440 pixels' width.
        if window.value.len() != 16 {
            return Ok(Some(format!(
                "the header's dataWindow is {} bytes long; a box2i is 16",
                window.value.len()
            )));
        }
        let v = |i: usize| {
            let b = &window.value[4 * i..4 * i + 4];
            i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        };
        let (x0, y0, x1, y1) = (v(0), v(1), v(2), v(3));
        if x1 < x0 || y1 < y0 {
            return Ok(Some(format!(
                "the data window's corner ({x1}, {y1}) is below its origin ({x0}, {y0}): no pixels"
            )));
        }
        let (width, height) = ((x1 - x0 + 1) as u64, (y1 - y0 + 1) as u64);
        if width > i32::MAX as u64 || height > i32::MAX as u64 {
            return Ok(Some(format!(
                "the data window ({x0}, {y0}) to ({x1}, {y1}) is more than 2^31 pixels wide or high"
            )));
        }
        let Some(pixel_bytes) = pixel_bytes else {
            continue;
        };
        let samples = u128::from(width) * u128::from(height) * u128::from(pixel_bytes);
        if samples > u128::from(file_len) * u128::from(expansion) {
            return Ok(Some(format!(
                "the header's {width}×{height} pixels ({samples} bytes of samples) cannot be \
                 in a file of {file_len} bytes (its compression expands at most {expansion}×)"
            )));
        }
    }
    Ok(None)
}

/// The bytes of one pixel's samples in a `chlist` (each channel: its name,
/// NUL, pixel type (0 uint, 1 half, 2 float), pLinear, three reserved
/// bytes, x and y sampling; a NUL ends the list). A subsampled channel
/// counts as a full one: the bound stays an upper one. `None` when the list
/// is not well formed.
fn bytes_per_pixel(list: &[u8]) -> Option<u64> {
    let mut at = 0;
    let mut bytes = 0u64;
    while *list.get(at)? != 0 {
        at += list[at..].iter().position(|&b| b == 0)? + 1;
        let kind = list.get(at..at + 4)?;
        bytes += match u32::from_le_bytes([kind[0], kind[1], kind[2], kind[3]]) {
            1 => 2,
            _ => 4,
        };
        at += 16;
    }
    Some(bytes)
}

/// The most a byte of an EXR file expands to in samples, by its
/// `compression` code: 1 uncompressed; RLE stores a run of up to 128 bytes
/// in 2; zlib (ZIPS, ZIP, PXR24) at most about 1032×; B44 packs 16 halves
/// in at least 3 bytes (floats stay as they are); PIZ, DWAA/DWAB and newer
/// codecs have no small bound, so they get a generous one (2¹⁶×): a
/// constant 8K image still fits, a 1 KiB file cannot claim more than 64 MiB.
pub fn max_expansion(compression: u8) -> u64 {
    match compression {
        0 => 1,
        1 => 64,
        2 | 3 | 5 => 1100,
        6 | 7 => 11,
        _ => 1 << 16,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A single-part header holding only a `dataWindow`.
    fn header(window: [i32; 4], version: u32) -> Vec<u8> {
        let mut h = MAGIC.to_vec();
        h.extend_from_slice(&version.to_le_bytes());
        h.extend_from_slice(b"dataWindow\0box2i\0");
        h.extend_from_slice(&16i32.to_le_bytes());
        for v in window {
            h.extend_from_slice(&v.to_le_bytes());
        }
        h.push(0);
        h
    }

    fn fault(bytes: &[u8]) -> Option<String> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("h.exr");
        std::fs::write(&p, bytes).unwrap();
        header_fault(&p).unwrap()
    }

    /// A header with a data window, three half channels and a compression,
    /// followed by `data` bytes standing for the offset table and pixels.
    fn rgb_header(window: [i32; 4], compression: u8, data: usize) -> Vec<u8> {
        let mut h = header(window, 2);
        h.pop(); // the end of the header, put back below
        let mut list = Vec::new();
        for c in [b"B", b"G", b"R"] {
            list.extend_from_slice(c);
            list.push(0);
            list.extend_from_slice(&1u32.to_le_bytes()); // half
            list.extend_from_slice(&[0, 0, 0, 0]);
            list.extend_from_slice(&1i32.to_le_bytes());
            list.extend_from_slice(&1i32.to_le_bytes());
        }
        list.push(0);
        h.extend_from_slice(b"channels\0chlist\0");
        h.extend_from_slice(&(list.len() as i32).to_le_bytes());
        h.extend_from_slice(&list);
        h.extend_from_slice(b"compression\0compression\0");
        h.extend_from_slice(&1i32.to_le_bytes());
        h.push(compression);
        h.push(0);
        h.resize(h.len() + data, 7);
        h
    }

    #[test]
    fn headers_claiming_more_samples_than_the_file_holds_are_found() {
        // 8×6 half RGB is 288 bytes of samples: uncompressed it needs them.
        assert_eq!(fault(&rgb_header([0, 0, 7, 5], 0, 300)), None);
        let f = fault(&rgb_header([0, 0, 7, 5], 0, 100)).unwrap();
        assert!(f.contains("8×6 pixels (288 bytes"), "{f}");
        // Found by fuzzing: 1 KiB claiming 30000×30000 pixels, ZIP.
        let f = fault(&rgb_header([0, 0, 29_999, 29_999], 3, 1000)).unwrap();
        assert!(f.contains("30000×30000") && f.contains("1100×"), "{f}");
        // A constant 8K panorama in PIZ fits in a few KiB, and passes.
        assert_eq!(fault(&rgb_header([0, 0, 8191, 4095], 4, 4000)), None);
        assert!(max_expansion(0) < max_expansion(1));
        assert!(max_expansion(3) < max_expansion(4));
    }

    #[test]
    fn inverted_or_huge_data_windows_are_found() {
        assert_eq!(fault(&header([0, 0, 7, 5], 2)), None);
        assert_eq!(fault(&header([-4, -4, 3, 1], 2)), None);
        let f = fault(&header([7, 5, 0, 0], 2)).unwrap();
        assert!(f.contains("(0, 0)") && f.contains("(7, 5)"), "{f}");
        assert!(fault(&header([0, 0, 4, -1], 2)).is_some());
        let f = fault(&header([i32::MIN, 0, i32::MAX, 5], 2)).unwrap();
        assert!(f.contains("2^31"), "{f}");
        // Multi-part files and what is not OpenEXR are left to the reader.
        assert_eq!(fault(&header([7, 5, 0, 0], 2 | MULTI_PART)), None);
        assert_eq!(fault(b"not an image"), None);
        // A header cut short is not read past its end, and is a fault.
        let h = header([0, 0, 7, 5], 2);
        let f = fault(&h[..h.len() - 6]).unwrap();
        assert!(f.contains("does not parse"), "{f}");
        // Found by fuzzing: an attribute whose size runs past the file,
        // with a wide data window after it that a reader may take.
        let mut h = header([0, 0, 7, 5], 2);
        h.pop();
        h.extend_from_slice(b"displayWindo\0\0");
        h.extend_from_slice(&65536i32.to_le_bytes());
        h.extend_from_slice(&header([0, 0, 33_554_439, 5], 2)[8..]);
        assert!(fault(&h).unwrap().contains("does not parse"));
        // Found by fuzzing: a second dataWindow of 18 bytes, whose first
        // 16 a reader takes as a window 33,554,440 pixels wide.
        let mut h = rgb_header([0, 0, 7, 5], 3, 600);
        let end = h.len() - 601; // the header's closing zero
        let mut wide = b"dataWindow\0box2i\0".to_vec();
        wide.extend_from_slice(&18i32.to_le_bytes());
        for v in [0i32, 0, 33_554_439, 5] {
            wide.extend_from_slice(&v.to_le_bytes());
        }
        wide.extend_from_slice(b"di");
        h.splice(end..end, wide);
        let f = fault(&h).unwrap();
        assert!(f.contains("dataWindow is 18 bytes long"), "{f}");
    }
}
