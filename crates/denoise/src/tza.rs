//! OIDN's tensor archives (TZA 2.0), the container of the trained weights.
//!
//! An archive is a 12-byte header (the magic `0x41D7`, major version 2, a
//! minor version, and the offset of the table), the tensors' data, each on
//! a 64-byte boundary, and at the end the table: a count, then for each
//! tensor its name, its dimensions, their layout (`oihw` for a convolution's
//! weights: output channels, input channels, kernel height and width; `x`
//! for a bias), its element type (`h` half, `f` float) and the offset of its
//! data. All integers little-endian.

use std::collections::HashMap;

/// What is wrong with an archive.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TzaError {
    /// The bytes end before what the header or the table says is there.
    #[error("the archive ends at byte {len}, before {what} (bytes {start}..{end})")]
    Truncated {
        /// What was being read.
        what: String,
        /// Its first byte.
        start: u64,
        /// One past its last byte.
        end: u64,
        /// The archive's length.
        len: usize,
    },
    /// Not a TZA archive, or a version this reader does not know.
    #[error("not a TZA 2 archive (magic {magic:#06x}, version {major})")]
    NotTza {
        /// The first two bytes, little-endian.
        magic: u16,
        /// The major version byte.
        major: u8,
    },
    /// A tensor's description is not one OIDN writes.
    #[error("tensor `{name}`: {fault}")]
    BadTensor {
        /// The tensor's name.
        name: String,
        /// What is wrong with it.
        fault: String,
    },
}

/// The element type of a tensor's data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Element {
    /// IEEE 754 binary16.
    Half,
    /// IEEE 754 binary32.
    Float,
}

impl Element {
    fn bytes(self) -> u64 {
        match self {
            Element::Half => 2,
            Element::Float => 4,
        }
    }
}

/// One tensor of an archive: its shape and where its data lies.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    /// Its dimensions, outermost first (`[o, i, h, w]` or `[n]`).
    pub dims: Vec<usize>,
    /// Its element type.
    pub element: Element,
    /// The byte range of its data in the archive.
    offset: usize,
}

impl Tensor {
    /// The number of elements.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Whether it has no elements.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A parsed archive: its tensors by name, over the archive's bytes.
#[derive(Debug, Clone)]
pub struct Archive<'a> {
    bytes: &'a [u8],
    tensors: HashMap<String, Tensor>,
}

/// A cursor over the archive's bytes that never reads past their end.
struct Reader<'a> {
    bytes: &'a [u8],
    at: u64,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: u64, what: &str) -> Result<&'a [u8], TzaError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len() as u64);
        let Some(end) = end else {
            return Err(TzaError::Truncated {
                what: what.to_string(),
                start: self.at,
                end: self.at.saturating_add(n),
                len: self.bytes.len(),
            });
        };
        let slice = &self.bytes[self.at as usize..end as usize];
        self.at = end;
        Ok(slice)
    }

    fn u8(&mut self, what: &str) -> Result<u8, TzaError> {
        Ok(self.take(1, what)?[0])
    }

    fn u16(&mut self, what: &str) -> Result<u16, TzaError> {
        let b = self.take(2, what)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    fn u32(&mut self, what: &str) -> Result<u32, TzaError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self, what: &str) -> Result<u64, TzaError> {
        let b = self.take(8, what)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }
}

/// The magic number at the start of every archive.
const MAGIC: u16 = 0x41D7;

impl<'a> Archive<'a> {
    /// Parses the archive in `bytes`. Every size and offset is checked
    /// against the bytes before it is used; nothing is allocated by a count
    /// the archive states beyond what its bytes can hold.
    pub fn parse(bytes: &'a [u8]) -> Result<Archive<'a>, TzaError> {
        let mut r = Reader { bytes, at: 0 };
        let magic = r.u16("the magic number")?;
        let major = r.u8("the version")?;
        let _minor = r.u8("the version")?;
        if magic != MAGIC || major != 2 {
            return Err(TzaError::NotTza { magic, major });
        }
        r.at = r.u64("the table's offset")?;
        let count = r.u32("the tensor count")?;
        let mut tensors = HashMap::new();
        for _ in 0..count {
            let name_len = r.u16("a tensor's name")?;
            let name = String::from_utf8_lossy(r.take(u64::from(name_len), "a tensor's name")?)
                .into_owned();
            let bad = |fault: String| TzaError::BadTensor {
                name: name.clone(),
                fault,
            };
            let ndims = r.u8("a tensor's rank")?;
            let mut dims = Vec::with_capacity(usize::from(ndims));
            for _ in 0..ndims {
                dims.push(r.u32("a tensor's dimensions")? as usize);
            }
            let layout = r.take(u64::from(ndims), "a tensor's layout")?;
            if !matches!(layout, b"oihw" | b"x") {
                return Err(bad(format!(
                    "layout `{}`, where OIDN writes `oihw` or `x`",
                    String::from_utf8_lossy(layout)
                )));
            }
            let element = match r.u8("a tensor's element type")? {
                b'h' => Element::Half,
                b'f' => Element::Float,
                other => return Err(bad(format!("element type `{}`", other as char))),
            };
            let offset = r.u64("a tensor's offset")?;
            let elements = dims
                .iter()
                .try_fold(1u64, |n, &d| n.checked_mul(d as u64))
                .ok_or_else(|| bad(format!("dimensions {dims:?} overflow")))?;
            let end = elements
                .checked_mul(element.bytes())
                .and_then(|b| b.checked_add(offset))
                .filter(|&e| e <= bytes.len() as u64)
                .ok_or_else(|| {
                    bad(format!(
                        "{elements} elements at byte {offset} run past the archive's {} bytes",
                        bytes.len()
                    ))
                })?;
            debug_assert!(end <= bytes.len() as u64);
            let tensor = Tensor {
                dims,
                element,
                offset: offset as usize,
            };
            if tensors.insert(name.clone(), tensor).is_some() {
                return Err(bad("named twice".into()));
            }
        }
        Ok(Archive { bytes, tensors })
    }

    /// The tensor called `name`.
    pub fn tensor(&self, name: &str) -> Option<&Tensor> {
        self.tensors.get(name)
    }

    /// The names of its tensors, sorted.
    pub fn names(&self) -> Vec<&str> {
        let mut names: Vec<&str> = self.tensors.keys().map(String::as_str).collect();
        names.sort_unstable();
        names
    }

    /// The values of tensor `name` as f32, row-major in its dimensions.
    pub fn values(&self, name: &str) -> Option<Vec<f32>> {
        let t = self.tensors.get(name)?;
        let n = t.len();
        let data = &self.bytes[t.offset..t.offset + n * t.element.bytes() as usize];
        Some(match t.element {
            Element::Half => data
                .chunks_exact(2)
                .map(|b| f16_to_f32(u16::from_le_bytes([b[0], b[1]])))
                .collect(),
            Element::Float => data
                .chunks_exact(4)
                .map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]))
                .collect(),
        })
    }
}

/// An IEEE 754 half (binary16) as f32, exactly (every half is an f32).
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = u32::from(h >> 15) << 31;
    let exponent = u32::from((h >> 10) & 0x1f);
    let mantissa = u32::from(h & 0x3ff);
    let bits = match (exponent, mantissa) {
        (0, 0) => sign,
        // Subnormal: mantissa · 2^-24, renormalised.
        (0, m) => {
            let shift = m.leading_zeros() - 21; // bring the top bit to bit 10
            let m = (m << shift) & 0x3ff;
            sign | ((127 - 15 + 1 - shift) << 23) | (m << 13)
        }
        (0x1f, m) => sign | 0x7f80_0000 | (m << 13),
        (e, m) => sign | ((e + 127 - 15) << 23) | (m << 13),
    };
    f32::from_bits(bits)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_convert_exactly() {
        assert_eq!(f16_to_f32(0x0000), 0.0);
        assert_eq!(f16_to_f32(0x8000).to_bits(), (-0.0f32).to_bits());
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0400), 2f32.powi(-14)); // smallest normal
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24)); // smallest subnormal
        assert_eq!(f16_to_f32(0x03ff), 1023.0 * 2f32.powi(-24)); // largest subnormal
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
        // Every half round-trips through f32 to the same value class.
        for h in 0..=u16::MAX {
            let f = f16_to_f32(h);
            if (h & 0x7c00) != 0x7c00 {
                assert!(f.is_finite() && f.abs() <= 65504.0, "{h:#06x} → {f}");
            }
        }
    }

    /// An archive of the given tensors, written as OIDN writes them.
    fn archive(tensors: &[(&str, &[u32], &str, &[f32])]) -> Vec<u8> {
        let mut out = vec![0u8; 12];
        let mut offsets = Vec::new();
        for (_, _, _, data) in tensors {
            while !out.len().is_multiple_of(64) {
                out.push(0);
            }
            offsets.push(out.len() as u64);
            for v in *data {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        while !out.len().is_multiple_of(64) {
            out.push(0);
        }
        let table = out.len() as u64;
        out[..2].copy_from_slice(&MAGIC.to_le_bytes());
        out[2] = 2;
        out[4..12].copy_from_slice(&table.to_le_bytes());
        out.extend_from_slice(&(tensors.len() as u32).to_le_bytes());
        for ((name, dims, layout, _), offset) in tensors.iter().zip(offsets) {
            out.extend_from_slice(&(name.len() as u16).to_le_bytes());
            out.extend_from_slice(name.as_bytes());
            out.push(dims.len() as u8);
            for d in *dims {
                out.extend_from_slice(&d.to_le_bytes());
            }
            out.extend_from_slice(layout.as_bytes());
            out.push(b'f');
            out.extend_from_slice(&offset.to_le_bytes());
        }
        out
    }

    #[test]
    fn an_archive_reads_back_its_tensors() {
        let w: Vec<f32> = (0..2 * 3 * 9).map(|i| i as f32 * 0.5).collect();
        let bytes = archive(&[
            ("conv.weight", &[2, 3, 3, 3], "oihw", &w),
            ("conv.bias", &[2], "x", &[1.0, -1.0]),
        ]);
        let a = Archive::parse(&bytes).unwrap();
        assert_eq!(a.names(), ["conv.bias", "conv.weight"]);
        assert_eq!(a.tensor("conv.weight").unwrap().dims, [2, 3, 3, 3]);
        assert_eq!(a.values("conv.weight").unwrap(), w);
        assert_eq!(a.values("conv.bias").unwrap(), [1.0, -1.0]);
        assert!(a.values("missing").is_none());
    }

    #[test]
    fn damaged_archives_are_refused_without_reading_past_them() {
        let good = archive(&[("b", &[4], "x", &[1.0, 2.0, 3.0, 4.0])]);
        // Every truncation is an error, never a panic.
        for cut in 0..good.len() {
            assert!(Archive::parse(&good[..cut]).is_err(), "cut at {cut}");
        }
        let mut bad = good.clone();
        bad[0] = 0;
        assert!(matches!(Archive::parse(&bad), Err(TzaError::NotTza { .. })));
        // A tensor claiming more elements than the archive holds.
        let huge = archive(&[("b", &[1 << 30], "x", &[0.0])]);
        let e = Archive::parse(&huge).unwrap_err().to_string();
        assert!(e.contains("run past"), "{e}");
        let odd = archive(&[("b", &[1], "y", &[0.0])]);
        let e = Archive::parse(&odd).unwrap_err().to_string();
        assert!(e.contains("layout `y`"), "{e}");
    }
}
