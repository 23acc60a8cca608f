//! OpenEXR headers: written the same way every time, and the data window
//! checked before a reader trusts it.

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

/// The fault of a single-part EXR file's `dataWindow` (`box2i`: min x, min
/// y, max x, max y, both corners included), if it has one: a maximum below
/// its minimum, or a width or height beyond 2³¹. Some readers take the
/// size's magnitude and read such a file as an image of another size.
/// Files this does not recognise pass: the reader's own checks apply.
pub fn data_window_fault(path: &std::path::Path) -> std::io::Result<Option<String>> {
    let head = head_of(&mut std::fs::File::open(path)?)?;
    let Some((attributes, _)) = attributes(&head) else {
        return Ok(None);
    };
    let Some(window) = attributes
        .iter()
        .find(|a| a.name == b"dataWindow" && a.kind == b"box2i" && a.value.len() == 16)
    else {
        return Ok(None);
    };
    let v = |i: usize| {
        let b = &window.value[4 * i..4 * i + 4];
        i64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let (x0, y0, x1, y1) = (v(0), v(1), v(2), v(3));
    Ok(if x1 < x0 || y1 < y0 {
        Some(format!(
            "the data window's corner ({x1}, {y1}) is below its origin ({x0}, {y0}): no pixels"
        ))
    } else if x1 - x0 + 1 > i64::from(i32::MAX) || y1 - y0 + 1 > i64::from(i32::MAX) {
        Some(format!(
            "the data window ({x0}, {y0}) to ({x1}, {y1}) is more than 2^31 pixels wide or high"
        ))
    } else {
        None
    })
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
        data_window_fault(&p).unwrap()
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
        // A header cut short is not read past its end.
        let h = header([7, 5, 0, 0], 2);
        assert_eq!(fault(&h[..h.len() - 6]), None);
    }
}
