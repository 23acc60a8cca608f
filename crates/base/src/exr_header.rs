//! OpenEXR headers written the same way every time.

/// Puts the header attributes of the single-part EXR file `file` (just
/// written) in name order, in place. The `exr` crate writes them in the
/// order of a `HashMap`, which changes from run to run, so the same image
/// would otherwise give different files. Reordering keeps the header's
/// length, so the offset table after it stays valid. Multi-part files, and
/// anything this does not recognise, are left as they are.
pub fn sort_attributes(file: &mut std::fs::File) -> std::io::Result<()> {
    use std::io::{Read, Seek, SeekFrom, Write};
    const MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];
    const MULTI_PART: u32 = 0x1000;
    let mut head = Vec::new();
    file.seek(SeekFrom::Start(0))?;
    Read::by_ref(file).take(1 << 20).read_to_end(&mut head)?;
    if head.len() < 8 || head[..4] != MAGIC {
        return Ok(());
    }
    let version = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if version & MULTI_PART != 0 {
        return Ok(());
    }
    // Each attribute: name NUL, type NUL, size (i32, little-endian), value.
    let mut attributes: Vec<(&[u8], &[u8])> = Vec::new();
    let mut at = 8;
    loop {
        let Some(&first) = head.get(at) else {
            return Ok(()); // no end of header within the first MiB
        };
        if first == 0 {
            break;
        }
        let start = at;
        let nul = |from: usize| head[from..].iter().position(|&b| b == 0).map(|i| from + i);
        let Some(name_end) = nul(at) else {
            return Ok(());
        };
        let Some(type_end) = nul(name_end + 1) else {
            return Ok(());
        };
        let size_at = type_end + 1;
        let Some(size) = head.get(size_at..size_at + 4) else {
            return Ok(());
        };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let Ok(size) = usize::try_from(size) else {
            return Ok(());
        };
        at = size_at + 4 + size;
        if at > head.len() {
            return Ok(());
        }
        attributes.push((&head[start..name_end], &head[start..at]));
    }
    attributes.sort_by(|a, b| a.0.cmp(b.0));
    let sorted: Vec<u8> = attributes
        .iter()
        .flat_map(|a| a.1.iter().copied())
        .collect();
    debug_assert_eq!(sorted.len(), at - 8);
    file.seek(SeekFrom::Start(8))?;
    file.write_all(&sorted)?;
    file.seek(SeekFrom::End(0))?;
    Ok(())
}
