//! Mitsuba `serialized` meshes: the compressed triangle-mesh files of
//! Mitsuba 0.5 and Mitsuba 3's `serialized` shape, format versions 3 and 4.
//!
//! # The format
//!
//! A file holds one or more shapes, each an indexed triangle mesh, one after
//! the other; every number is little-endian. A shape is
//!
//! | type            | content                                                   |
//! |-----------------|-----------------------------------------------------------|
//! | u16             | format identifier `0x041C`                                |
//! | u16             | format version: 3 or 4                                    |
//! |                 | the rest of the shape is one zlib stream (RFC 1950) of:   |
//! | u32             | flags (below)                                             |
//! | bytes           | version 4 only: the shape's name, ended by a NUL byte     |
//! | u64             | vertex count `V`                                          |
//! | u64             | triangle count `F`                                        |
//! | `3V` reals      | positions (x, y, z, x, y, z, ...)                         |
//! | `3V` reals      | normals, if flag `0x0001`                                 |
//! | `2V` reals      | texture coordinates (u, v, ...), if flag `0x0002`         |
//! | `3V` reals      | RGB vertex colours, if flag `0x0008`                      |
//! | `3F` u32        | the triangles' vertex indices                             |
//!
//! Flags: `0x0001` normals, `0x0002` texture coordinates, `0x0004` tangents
//! (declared, never written, ignored here as by Mitsuba), `0x0008` vertex
//! colours, `0x0010` the mesh wants face normals (flat shading), `0x1000`
//! the reals are f32, `0x2000` the reals are f64. With neither precision
//! flag the reals are f32 (Mitsuba reads them so); other bits are ignored.
//!
//! The file ends with a table: the byte offset of each shape's header (the
//! first is 0), u32 in a version 3 file and u64 in a version 4 file, then
//! the u32 number of shapes. The width of the offsets follows the version of
//! the shape at offset 0. As in Mitsuba, shape 0 is read at offset 0 without
//! the table (so a one-shape file without a table loads); any other shape is
//! found through the table, and its header must carry the same identifier
//! and version as the first. [`shape_count`] checks the whole table: at
//! least one shape, the first at offset 0, increasing offsets, each at a
//! header like the first.
//!
//! Mitsuba 3's documentation says the indices are u64 when there are more
//! than 2^32 vertices, but neither Mitsuba 0.5 nor Mitsuba 3 writes or reads
//! such indices; this reader refuses that many vertices anyway, so indices
//! are always u32. Version 5, the packed layout written by Mitsuba after
//! 3.9, and the byte-swapped identifier `0x1C04` of early big-endian files
//! are refused with a message saying so.
//!
//! # Limits
//!
//! Every fault is an error naming the shape, the field and what is wrong;
//! no input makes the reader panic, and nothing is allocated by a count
//! from the file before the data behind it has been decompressed:
//!
//! - a file of at most [`MAX_FILE_BYTES`] (checked before reading it);
//! - at most 2^31 vertices and 2^31 triangles a shape; the counts must also
//!   fit what the remaining compressed bytes can hold (deflate expands at
//!   most 1032-fold), and the arrays are read in chunks as they decompress;
//! - the zlib stream must hold exactly what the counts and flags describe:
//!   no less (the end of the stream or of the file is reported with the
//!   vertex or triangle where it came), and no more (a decompression bomb
//!   stops one byte past the described data), and its Adler-32 must match;
//! - a name of at most 64 KiB (non-UTF-8 bytes are replaced, not refused);
//! - positions finite and within ±10^12 (plsr's coordinate limit),
//!   texture coordinates and colours finite as f32, triangle indices below
//!   the vertex count;
//! - normals are made unit length; if any is zero or not finite, all of the
//!   shape's normals are dropped (as plsr's PLY reader does).

use crate::error::FormatError;
use flate2::{Decompress, FlushDecompress, Status};
use glam::{Vec2, Vec3};
use std::io::Read;
use std::path::Path;

/// One shape of a serialized file, in file coordinates.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SerializedMesh {
    /// The shape's name (version 4 files), or `None` (version 3, or an
    /// empty name).
    pub name: Option<String>,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles: indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex unit normals, or empty.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, or empty.
    pub uvs: Vec<Vec2>,
    /// Per-vertex RGB colours, or empty.
    pub colors: Vec<Vec3>,
    /// The file's flag asking for face normals (flat shading) instead of
    /// interpolated vertex normals.
    pub face_normals: bool,
}

/// The largest file [`read_serialized`] reads.
pub const MAX_FILE_BYTES: u64 = 1 << 30;

/// The most vertices or triangles a shape may declare.
const MAX_COUNT: u64 = 1 << 31;

/// Positions beyond this are refused (plsr's limit, [`crate::accel::MAX_COORDINATE`]).
const MAX_COORDINATE: f64 = crate::accel::MAX_COORDINATE as f64;

/// The longest name (bytes, without its NUL) of a version 4 shape.
const MAX_NAME_BYTES: usize = 1 << 16;

/// The format identifier at the start of every shape.
const IDENTIFIER: u16 = 0x041C;

/// The bytes of a shape's uncompressed header (identifier, version).
const HEADER_BYTES: usize = 4;

const FLAG_NORMALS: u32 = 0x0001;
const FLAG_UVS: u32 = 0x0002;
const FLAG_COLORS: u32 = 0x0008;
const FLAG_FACE_NORMALS: u32 = 0x0010;
const FLAG_SINGLE: u32 = 0x1000;
const FLAG_DOUBLE: u32 = 0x2000;

/// Deflate's largest expansion: a 258-byte match coded in two bits.
const MAX_INFLATE_RATIO: u64 = 1032;

/// Output the decompressor may hold back (its 32 KiB window, and more).
const INFLATE_SLACK: u64 = 1 << 16;

/// The decompressed bytes handled at a time while reading an array.
const CHUNK_BYTES: usize = 1 << 16;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Version {
    V3,
    V4,
}

impl Version {
    fn number(self) -> u16 {
        match self {
            Version::V3 => 3,
            Version::V4 => 4,
        }
    }

    /// The bytes of one offset of the file's table.
    fn offset_bytes(self) -> usize {
        match self {
            Version::V3 => 4,
            Version::V4 => 8,
        }
    }
}

/// Reads shape `shape_index` of the serialized file at `path`, which may
/// hold at most [`MAX_FILE_BYTES`]; the error says what is wrong (the
/// caller names the file).
pub fn read_serialized(path: &Path, shape_index: u32) -> Result<SerializedMesh, FormatError> {
    read_serialized_with_limit(path, shape_index, MAX_FILE_BYTES)
}

/// [`read_serialized`] for a file of at most `max_bytes`.
pub fn read_serialized_with_limit(
    path: &Path,
    shape_index: u32,
    max_bytes: u64,
) -> Result<SerializedMesh, FormatError> {
    let too_big = |len: u64| {
        FormatError::Content(format!(
            "the file is {len} bytes long, more than the limit of {max_bytes} bytes"
        ))
    };
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    if len > max_bytes {
        return Err(too_big(len));
    }
    let mut bytes = Vec::new();
    // `take` bounds the read should the file grow after the check.
    file.take(max_bytes.saturating_add(1))
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > max_bytes {
        return Err(too_big(bytes.len() as u64));
    }
    parse_serialized(&bytes, shape_index)
}

/// Parses shape `shape_index` of the bytes of a serialized file.
pub fn parse_serialized(bytes: &[u8], shape_index: u32) -> Result<SerializedMesh, FormatError> {
    let version = shape_header(bytes, 0, "the first shape's header")?;
    let (start, end) = if shape_index == 0 {
        (HEADER_BYTES, bytes.len())
    } else {
        let table = Table::read(bytes, version)?;
        if shape_index >= table.count {
            return Err(format!(
                "shape_index {shape_index} is out of range: the file holds {}",
                shapes(table.count)
            )
            .into());
        }
        let offset = table.offset(bytes, shape_index)?;
        let what = format!("shape {shape_index}'s header (at byte {offset})");
        let own = shape_header(bytes, offset, &what)?;
        if own != version {
            return Err(format!(
                "{what}: format version {}, but the first shape's is {} (which sets \
                 the width of the shape table's offsets)",
                own.number(),
                version.number()
            )
            .into());
        }
        (offset + HEADER_BYTES, table.start)
    };
    let input = bytes.get(start..end).unwrap_or_default();
    decode_shape(input, version)
        .map_err(|m| FormatError::Content(format!("shape {shape_index}: {m}")))
}

/// The number of shapes in the bytes of a serialized file, from its table,
/// which is checked whole: at least one shape, the first at offset 0, the
/// offsets increasing, and each at a header like the first shape's (the
/// shapes' data is not decoded).
pub fn shape_count(bytes: &[u8]) -> Result<u32, FormatError> {
    let version = shape_header(bytes, 0, "the first shape's header")?;
    let table = Table::read(bytes, version)?;
    if table.count == 0 {
        return Err("the shape table at the end of the file claims 0 shapes \
                    (truncated file, or one without a table?)"
            .into());
    }
    let mut previous = None;
    for i in 0..table.count {
        let offset = table.offset(bytes, i)?;
        match previous {
            None if offset != 0 => {
                return Err(format!(
                    "the shape table gives the first shape the offset {offset}, not 0"
                )
                .into())
            }
            Some(p) if offset <= p => {
                return Err(format!(
                    "the shape table gives shape {i} the offset {offset}, not after shape \
                     {}'s offset {p}",
                    i - 1
                )
                .into())
            }
            _ => {}
        }
        let what = format!("shape {i}'s header (at byte {offset})");
        if shape_header(bytes, offset, &what)? != version {
            return Err(format!("{what}: a format version other than the first shape's").into());
        }
        previous = Some(offset);
    }
    Ok(table.count)
}

/// "1 shape", "3 shapes".
fn shapes(n: u32) -> String {
    format!("{n} shape{}", if n == 1 { "" } else { "s" })
}

/// Checks the 4-byte header at `at` (`what` names it in errors) and returns
/// its version.
fn shape_header(bytes: &[u8], at: usize, what: &str) -> Result<Version, FormatError> {
    let Some(&[a, b, c, d]) = bytes.get(at..).and_then(|rest| rest.get(..HEADER_BYTES)) else {
        return Err(format!(
            "{what}: the file ends (it is {} bytes long) before the 4-byte header \
             (truncated file?)",
            bytes.len()
        )
        .into());
    };
    let identifier = u16::from_le_bytes([a, b]);
    if identifier == IDENTIFIER.swap_bytes() {
        return Err(format!(
            "{what}: the format identifier is 0x1C04, a byte-swapped 0x041C: a \
             big-endian file of an early Mitsuba, which Mitsuba itself no longer reads"
        )
        .into());
    }
    if identifier != IDENTIFIER {
        return Err(format!(
            "{what}: the format identifier is 0x{identifier:04X}, not 0x041C \
             (not a Mitsuba serialized mesh)"
        )
        .into());
    }
    match u16::from_le_bytes([c, d]) {
        3 => Ok(Version::V3),
        4 => Ok(Version::V4),
        5 => Err(format!(
            "{what}: format version 5 (the packed layout of Mitsuba after 3.9) is not \
             supported, only versions 3 and 4"
        )
        .into()),
        v => Err(
            format!("{what}: format version {v} is not supported, only versions 3 and 4").into(),
        ),
    }
}

/// The table at the end of a file: shape offsets, then the shape count.
struct Table {
    /// The number of shapes.
    count: u32,
    /// Where the table starts: the end of the shapes' data.
    start: usize,
    /// The bytes of one offset.
    width: usize,
}

impl Table {
    /// Reads the count and checks that the table fits in the file after the
    /// first shape's header.
    fn read(bytes: &[u8], version: Version) -> Result<Table, FormatError> {
        let len = bytes.len();
        let width = version.offset_bytes();
        let count = match len.checked_sub(4).and_then(|at| bytes.get(at..)) {
            Some(&[a, b, c, d]) if len >= HEADER_BYTES + 4 => u32::from_le_bytes([a, b, c, d]),
            _ => {
                return Err(format!(
                    "the file is {len} bytes long, too short for a shape header and \
                     the shape count at its end (truncated file?)"
                )
                .into())
            }
        };
        let table_bytes = u64::from(count) * width as u64 + 4;
        let room = (len - HEADER_BYTES) as u64;
        if table_bytes > room {
            return Err(format!(
                "the shape table at the end of the file claims {}, whose {width}-byte \
                 offsets and count take {table_bytes} bytes, but only {room} bytes follow \
                 the first shape's header (truncated file, or one without a table?)",
                shapes(count)
            )
            .into());
        }
        Ok(Table {
            count,
            start: len - table_bytes as usize,
            width,
        })
    }

    /// The offset of shape `i` (< count), checked to leave room for a header
    /// before the table.
    fn offset(&self, bytes: &[u8], i: u32) -> Result<usize, FormatError> {
        let at = self.start + i as usize * self.width;
        let raw = bytes.get(at..).and_then(|b| b.get(..self.width));
        let offset = match raw {
            Some(&[a, b, c, d]) => u64::from(u32::from_le_bytes([a, b, c, d])),
            Some(&[a, b, c, d, e, f, g, h]) => u64::from_le_bytes([a, b, c, d, e, f, g, h]),
            _ => return Err(format!("the shape table's entry for shape {i} is missing").into()),
        };
        let last = self.start.saturating_sub(HEADER_BYTES);
        if offset > last as u64 {
            return Err(format!(
                "the shape table gives shape {i} the offset {offset}, outside the shapes' \
                 data (which end at byte {}, where the table starts)",
                self.start
            )
            .into());
        }
        Ok(offset as usize)
    }
}

/// Why the decompressed data stopped short.
#[derive(Debug)]
enum Stop {
    /// The zlib stream ended (properly) before the data needed.
    Ended,
    /// The compressed bytes ran out before the zlib stream ended.
    Truncated,
    /// The zlib stream is not valid (or its checksum does not match).
    Corrupt(String),
}

impl Stop {
    /// The message for a stop while reading `at`.
    fn describe(&self, at: &str) -> String {
        match self {
            Stop::Ended => format!("the compressed data ends early, in {at}"),
            Stop::Truncated => {
                format!("the file ends inside the compressed data, in {at} (truncated file?)")
            }
            Stop::Corrupt(m) => format!(
                "the compressed data is corrupt ({m}: a damaged zlib stream or checksum), \
                 found while reading {at}"
            ),
        }
    }
}

/// A zlib stream over a slice, read exactly as far as asked.
struct Inflater<'a> {
    input: &'a [u8],
    z: Decompress,
    ended: bool,
}

impl<'a> Inflater<'a> {
    fn new(input: &'a [u8]) -> Inflater<'a> {
        Inflater {
            input,
            z: Decompress::new(true),
            ended: false,
        }
    }

    /// The compressed bytes not yet consumed.
    fn remaining_input(&self) -> u64 {
        self.input.len() as u64
    }

    /// One call of the decompressor into `out`: the bytes written. Every
    /// call consumes input, writes output or ends the stream; one that
    /// would do none of these is a stop, so loops over it end.
    fn step(&mut self, out: &mut [u8]) -> Result<usize, Stop> {
        let (in_before, out_before) = (self.z.total_in(), self.z.total_out());
        let status = self
            .z
            .decompress(self.input, out, FlushDecompress::None)
            .map_err(|e| Stop::Corrupt(e.to_string()))?;
        let used = usize::try_from(self.z.total_in() - in_before).unwrap_or(usize::MAX);
        let wrote = usize::try_from(self.z.total_out() - out_before).unwrap_or(usize::MAX);
        self.input = self.input.get(used..).unwrap_or_default();
        if status == Status::StreamEnd {
            self.ended = true;
        } else if used == 0 && wrote == 0 {
            return Err(if self.input.is_empty() {
                Stop::Truncated
            } else {
                Stop::Corrupt("the decompressor makes no progress".into())
            });
        }
        Ok(wrote.min(out.len()))
    }

    /// Fills `out` entirely, or says how far it got and why it stopped.
    fn fill(&mut self, out: &mut [u8]) -> Result<(), (usize, Stop)> {
        let mut filled = 0;
        while filled < out.len() {
            if self.ended {
                return Err((filled, Stop::Ended));
            }
            match self.step(&mut out[filled..]) {
                Ok(n) => filled += n,
                Err(stop) => return Err((filled, stop)),
            }
        }
        Ok(())
    }

    /// Checks that the stream ends here, with its checksum: a byte more is
    /// an error, so a stream holding more than described is never inflated.
    fn finish(&mut self) -> Result<(), String> {
        let mut probe = [0u8; 1];
        while !self.ended {
            match self.step(&mut probe) {
                Ok(0) => {}
                Ok(_) => {
                    return Err("the compressed data holds more than the header describes \
                                (after the last triangle)"
                        .into())
                }
                Err(stop) => return Err(stop.describe("its end, after the last triangle")),
            }
        }
        Ok(())
    }
}

/// Reads `count` records of `record_bytes` each, a chunk at a time, and
/// hands each to `each` with its index. `what` and `unit` name the array
/// and its items in errors ("the normals", "vertex").
fn read_records(
    z: &mut Inflater,
    count: u64,
    record_bytes: usize,
    what: &str,
    unit: &str,
    mut each: impl FnMut(u64, &[u8]) -> Result<(), String>,
) -> Result<(), String> {
    // A chunk of at most CHUNK_BYTES (and no more records than `count`).
    let per_chunk = usize::try_from(count)
        .unwrap_or(usize::MAX)
        .min((CHUNK_BYTES / record_bytes).max(1));
    let mut buf = vec![0u8; per_chunk * record_bytes];
    let mut done = 0u64;
    while done < count {
        let n = usize::try_from(count - done).map_or(per_chunk, |left| left.min(per_chunk));
        let chunk = &mut buf[..n * record_bytes];
        if let Err((filled, stop)) = z.fill(chunk) {
            let at = done + (filled / record_bytes) as u64;
            return Err(stop.describe(&format!("{what}, at {unit} {at} of {count}")));
        }
        for (k, record) in chunk.chunks_exact(record_bytes).enumerate() {
            each(done + k as u64, record)?;
        }
        done += n as u64;
    }
    Ok(())
}

/// The `N` reals of a record, f64 or f32 by `double`.
fn reals<const N: usize>(record: &[u8], double: bool) -> [f64; N] {
    let mut v = [0.0; N];
    if double {
        for (x, b) in v.iter_mut().zip(record.chunks_exact(8)) {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            *x = f64::from_le_bytes(a);
        }
    } else {
        for (x, b) in v.iter_mut().zip(record.chunks_exact(4)) {
            let mut a = [0u8; 4];
            a.copy_from_slice(b);
            *x = f64::from(f32::from_le_bytes(a));
        }
    }
    v
}

/// The three u32 of a triangle record.
fn indices(record: &[u8]) -> [u32; 3] {
    let mut t = [0u32; 3];
    for (x, b) in t.iter_mut().zip(record.chunks_exact(4)) {
        let mut a = [0u8; 4];
        a.copy_from_slice(b);
        *x = u32::from_le_bytes(a);
    }
    t
}

/// "(1, 2, 3)".
fn show(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| x.to_string()).collect();
    format!("({})", parts.join(", "))
}

/// `n` scaled to unit length in f32, or `None` if it is zero or not finite.
fn unit(n: [f64; 3]) -> Option<Vec3> {
    let m = n.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if !(m.is_finite() && m > 0.0) {
        return None;
    }
    let s = n.map(|x| x / m);
    let len = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
    let u = Vec3::new(
        (s[0] / len) as f32,
        (s[1] / len) as f32,
        (s[2] / len) as f32,
    );
    (u.is_finite() && u != Vec3::ZERO).then_some(u)
}

/// Reads the NUL-terminated name of a version 4 shape.
fn read_name(z: &mut Inflater) -> Result<Option<String>, String> {
    let mut name = Vec::new();
    let mut byte = [0u8; 1];
    loop {
        z.fill(&mut byte)
            .map_err(|(_, stop)| stop.describe(&format!("the name, after {} bytes", name.len())))?;
        if byte[0] == 0 {
            break;
        }
        if name.len() == MAX_NAME_BYTES {
            return Err(format!(
                "the name has no terminating NUL within its first {MAX_NAME_BYTES} bytes"
            ));
        }
        name.push(byte[0]);
    }
    Ok((!name.is_empty()).then(|| String::from_utf8_lossy(&name).into_owned()))
}

/// Decodes one shape from its compressed data (after the header).
fn decode_shape(input: &[u8], version: Version) -> Result<SerializedMesh, String> {
    let mut z = Inflater::new(input);
    let mut word = [0u8; 4];
    z.fill(&mut word)
        .map_err(|(_, stop)| stop.describe("the flags"))?;
    let flags = u32::from_le_bytes(word);
    if flags & (FLAG_SINGLE | FLAG_DOUBLE) == FLAG_SINGLE | FLAG_DOUBLE {
        return Err(format!(
            "the flags 0x{flags:04X} ask for both single (0x1000) and double (0x2000) precision"
        ));
    }
    let double = flags & FLAG_DOUBLE != 0;
    let (has_normals, has_uvs, has_colors) = (
        flags & FLAG_NORMALS != 0,
        flags & FLAG_UVS != 0,
        flags & FLAG_COLORS != 0,
    );
    let name = match version {
        Version::V3 => None,
        Version::V4 => read_name(&mut z)?,
    };
    let mut counts = [0u8; 16];
    z.fill(&mut counts)
        .map_err(|(_, stop)| stop.describe("the vertex and triangle counts"))?;
    let [v0, v1, v2, v3, v4, v5, v6, v7, t0, t1, t2, t3, t4, t5, t6, t7] = counts;
    let vertex_count = u64::from_le_bytes([v0, v1, v2, v3, v4, v5, v6, v7]);
    let triangle_count = u64::from_le_bytes([t0, t1, t2, t3, t4, t5, t6, t7]);
    for (what, n) in [("vertex", vertex_count), ("triangle", triangle_count)] {
        if n > MAX_COUNT {
            return Err(format!(
                "the {what} count {n} is more than the limit of {MAX_COUNT}"
            ));
        }
    }

    // The counts against what the compressed bytes left can possibly hold.
    let real = if double { 8 } else { 4 };
    let reals_per_vertex =
        3 + 3 * u64::from(has_normals) + 2 * u64::from(has_uvs) + 3 * u64::from(has_colors);
    let needed = vertex_count * reals_per_vertex * real + triangle_count * 12;
    let can_hold = z
        .remaining_input()
        .saturating_mul(MAX_INFLATE_RATIO)
        .saturating_add(INFLATE_SLACK);
    if needed > can_hold {
        return Err(format!(
            "the header declares {vertex_count} vertices and {triangle_count} triangles \
             ({needed} bytes of data with flags 0x{flags:04X}), more than the {} compressed \
             bytes left can hold (deflate expands at most {MAX_INFLATE_RATIO}-fold)",
            z.remaining_input()
        ));
    }

    let real = real as usize;
    let mut mesh = SerializedMesh {
        name,
        face_normals: flags & FLAG_FACE_NORMALS != 0,
        ..SerializedMesh::default()
    };
    read_records(
        &mut z,
        vertex_count,
        3 * real,
        "the positions",
        "vertex",
        |i, r| {
            let p = reals::<3>(r, double);
            if !p.iter().all(|x| x.is_finite()) {
                return Err(format!(
                    "the position of vertex {i} is not finite: {}",
                    show(&p)
                ));
            }
            if p.iter().any(|x| x.abs() > MAX_COORDINATE) {
                return Err(format!(
                    "the position of vertex {i}, {}, lies beyond ±1e12 (plsr's coordinate limit)",
                    show(&p)
                ));
            }
            mesh.positions
                .push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
            Ok(())
        },
    )?;
    if has_normals {
        let mut usable = true;
        read_records(
            &mut z,
            vertex_count,
            3 * real,
            "the normals",
            "vertex",
            |_, r| {
                if usable {
                    match unit(reals::<3>(r, double)) {
                        Some(n) => mesh.normals.push(n),
                        None => usable = false,
                    }
                }
                Ok(())
            },
        )?;
        if !usable {
            mesh.normals = Vec::new();
        }
    }
    if has_uvs {
        read_records(
            &mut z,
            vertex_count,
            2 * real,
            "the texture coordinates",
            "vertex",
            |i, r| {
                let t = reals::<2>(r, double);
                let uv = Vec2::new(t[0] as f32, t[1] as f32);
                if !uv.is_finite() {
                    return Err(format!(
                        "the texture coordinates of vertex {i} are not finite f32 numbers: {}",
                        show(&t)
                    ));
                }
                mesh.uvs.push(uv);
                Ok(())
            },
        )?;
    }
    if has_colors {
        read_records(
            &mut z,
            vertex_count,
            3 * real,
            "the colours",
            "vertex",
            |i, r| {
                let c = reals::<3>(r, double);
                let rgb = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
                if !rgb.is_finite() {
                    return Err(format!(
                        "the colour of vertex {i} is not finite f32 numbers: {}",
                        show(&c)
                    ));
                }
                mesh.colors.push(rgb);
                Ok(())
            },
        )?;
    }
    read_records(
        &mut z,
        triangle_count,
        12,
        "the triangles",
        "triangle",
        |i, r| {
            let t = indices(r);
            if let Some(&bad) = t.iter().find(|&&v| u64::from(v) >= vertex_count) {
                return Err(format!(
                    "triangle {i} uses vertex {bad}, but the shape has {vertex_count} vertices"
                ));
            }
            mesh.triangles.push(t);
            Ok(())
        },
    )?;
    z.finish()?;
    Ok(mesh)
}

#[cfg(test)]
mod tests {
    use super::*;
    use flate2::write::ZlibEncoder;
    use flate2::Compression;
    use std::io::Write;
    use std::time::{Duration, Instant};

    /// A shape to write: the test's own writer of the format.
    #[derive(Debug, Clone)]
    struct Fixture {
        name: String,
        positions: Vec<[f64; 3]>,
        normals: Option<Vec<[f64; 3]>>,
        uvs: Option<Vec<[f64; 2]>>,
        colors: Option<Vec<[f64; 3]>>,
        triangles: Vec<[u32; 3]>,
        double: bool,
        face_normals: bool,
    }

    /// A unit quad in z = 0 with every attribute, in values f32 holds exactly.
    fn quad() -> Fixture {
        Fixture {
            name: "quad".into(),
            positions: vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [1.0, 1.0, 0.0],
                [0.0, 1.0, 0.0],
            ],
            normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
            uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]),
            colors: Some(vec![
                [1.0, 0.5, 0.25],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
                [0.5, 0.5, 0.5],
            ]),
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            double: false,
            face_normals: false,
        }
    }

    /// A tetrahedron without normals, UVs or colours.
    fn tetra() -> Fixture {
        Fixture {
            name: "tetra".into(),
            positions: vec![
                [0.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [0.0, 2.0, 0.0],
                [0.0, 0.0, -2.5],
            ],
            normals: None,
            uvs: None,
            colors: None,
            triangles: vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
            double: false,
            face_normals: true,
        }
    }

    fn flags(f: &Fixture) -> u32 {
        let mut flags = if f.double { FLAG_DOUBLE } else { FLAG_SINGLE };
        if f.normals.is_some() {
            flags |= FLAG_NORMALS;
        }
        if f.uvs.is_some() {
            flags |= FLAG_UVS;
        }
        if f.colors.is_some() {
            flags |= FLAG_COLORS;
        }
        if f.face_normals {
            flags |= FLAG_FACE_NORMALS;
        }
        flags
    }

    fn put_reals(out: &mut Vec<u8>, values: &[f64], double: bool) {
        for &x in values {
            if double {
                out.extend_from_slice(&x.to_le_bytes());
            } else {
                out.extend_from_slice(&(x as f32).to_le_bytes());
            }
        }
    }

    /// The uncompressed data of a shape, with the given flags and counts.
    fn payload_with(
        f: &Fixture,
        version: u16,
        flags: u32,
        vertices: u64,
        triangles: u64,
    ) -> Vec<u8> {
        let mut out = flags.to_le_bytes().to_vec();
        if version == 4 {
            out.extend_from_slice(f.name.as_bytes());
            out.push(0);
        }
        out.extend_from_slice(&vertices.to_le_bytes());
        out.extend_from_slice(&triangles.to_le_bytes());
        put_reals(&mut out, f.positions.as_flattened(), f.double);
        if let Some(n) = &f.normals {
            put_reals(&mut out, n.as_flattened(), f.double);
        }
        if let Some(t) = &f.uvs {
            put_reals(&mut out, t.as_flattened(), f.double);
        }
        if let Some(c) = &f.colors {
            put_reals(&mut out, c.as_flattened(), f.double);
        }
        for t in &f.triangles {
            for i in t {
                out.extend_from_slice(&i.to_le_bytes());
            }
        }
        out
    }

    fn payload(f: &Fixture, version: u16) -> Vec<u8> {
        payload_with(
            f,
            version,
            flags(f),
            f.positions.len() as u64,
            f.triangles.len() as u64,
        )
    }

    fn zlib(data: &[u8]) -> Vec<u8> {
        let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    /// A shape: header, then the compressed payload.
    fn shape(version: u16, payload: &[u8]) -> Vec<u8> {
        let mut out = IDENTIFIER.to_le_bytes().to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend_from_slice(&zlib(payload));
        out
    }

    /// The shapes one after the other, then the table of offsets and count.
    fn file(version: u16, shapes: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for s in shapes {
            offsets.push(out.len() as u64);
            out.extend_from_slice(s);
        }
        for o in offsets {
            if version == 3 {
                out.extend_from_slice(&(o as u32).to_le_bytes());
            } else {
                out.extend_from_slice(&o.to_le_bytes());
            }
        }
        out.extend_from_slice(&(shapes.len() as u32).to_le_bytes());
        out
    }

    fn write(version: u16, fixtures: &[Fixture]) -> Vec<u8> {
        let shapes: Vec<Vec<u8>> = fixtures
            .iter()
            .map(|f| shape(version, &payload(f, version)))
            .collect();
        file(version, &shapes)
    }

    fn v3(a: [f64; 3]) -> Vec3 {
        Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32)
    }

    /// Checks that `m` is `f` read back (normals compared after normalising).
    fn assert_matches(m: &SerializedMesh, f: &Fixture, version: u16) {
        let name = (version == 4 && !f.name.is_empty()).then(|| f.name.clone());
        assert_eq!(m.name, name);
        let p: Vec<Vec3> = f.positions.iter().map(|&p| v3(p)).collect();
        assert_eq!(m.positions, p);
        assert_eq!(m.triangles, f.triangles);
        match &f.normals {
            Some(n) => {
                assert_eq!(m.normals.len(), n.len());
                for (a, b) in m.normals.iter().zip(n) {
                    assert!((*a - v3(*b).normalize()).length() < 1e-6, "{a} vs {b:?}");
                }
            }
            None => assert!(m.normals.is_empty()),
        }
        let uvs: Vec<Vec2> = f
            .uvs
            .iter()
            .flatten()
            .map(|t| Vec2::new(t[0] as f32, t[1] as f32))
            .collect();
        assert_eq!(m.uvs, uvs);
        let colors: Vec<Vec3> = f.colors.iter().flatten().map(|&c| v3(c)).collect();
        assert_eq!(m.colors, colors);
        assert_eq!(m.face_normals, f.face_normals);
    }

    fn content(r: Result<SerializedMesh, FormatError>) -> String {
        match r {
            Err(FormatError::Content(m)) => m,
            Err(FormatError::Io(e)) => panic!("an I/O error, not a content error: {e}"),
            Ok(m) => panic!("parsed, but should have failed: {m:?}"),
        }
    }

    fn assert_content(r: Result<SerializedMesh, FormatError>, needles: &[&str]) {
        let m = content(r);
        for n in needles {
            assert!(m.contains(n), "{m:?} does not say {n:?}");
        }
    }

    /// A one-shape v4 file of `f` with the payload edited by `edit`.
    fn edited(f: &Fixture, edit: impl FnOnce(&mut Vec<u8>)) -> Vec<u8> {
        let mut p = payload(f, 4);
        edit(&mut p);
        file(4, &[shape(4, &p)])
    }

    /// The byte offset in a v4 payload of `f` where the positions start.
    fn data_start(f: &Fixture) -> usize {
        4 + f.name.len() + 1 + 16
    }

    // Round trips.

    #[test]
    fn reads_one_shape_v4_f32_with_all_attributes() {
        let f = quad();
        let bytes = write(4, std::slice::from_ref(&f));
        assert_eq!(shape_count(&bytes).unwrap(), 1);
        assert_matches(&parse_serialized(&bytes, 0).unwrap(), &f, 4);
    }

    #[test]
    fn reads_one_shape_v3_without_name() {
        let f = quad();
        let bytes = write(3, std::slice::from_ref(&f));
        let m = parse_serialized(&bytes, 0).unwrap();
        assert_eq!(m.name, None);
        assert_matches(&m, &f, 3);
    }

    #[test]
    fn reads_f64_data() {
        for version in [3, 4] {
            let mut f = quad();
            f.double = true;
            f.positions[2] = [0.1, 1e-3, -123456.789];
            f.uvs.as_mut().unwrap()[1] = [0.3, 0.7];
            let bytes = write(version, std::slice::from_ref(&f));
            let m = parse_serialized(&bytes, 0).unwrap();
            assert_matches(&m, &f, version);
            assert_eq!(m.positions[2], Vec3::new(0.1, 1e-3, -123456.79));
        }
    }

    #[test]
    fn reads_every_shape_of_several_in_both_versions_and_precisions() {
        for version in [3, 4] {
            for double in [false, true] {
                let mut shapes = vec![quad(), tetra(), quad(), tetra()];
                shapes[2].normals = None;
                shapes[2].name = String::new();
                shapes[3].uvs = Some(vec![[0.5, 0.25]; 4]);
                shapes[3].colors = Some(vec![[0.0, 0.5, 1.0]; 4]);
                for s in &mut shapes {
                    s.double = double;
                }
                let bytes = write(version, &shapes);
                assert_eq!(shape_count(&bytes).unwrap(), 4);
                for (i, f) in shapes.iter().enumerate() {
                    let m = parse_serialized(&bytes, i as u32).unwrap();
                    assert_matches(&m, f, version);
                }
            }
        }
    }

    #[test]
    fn reads_a_file_from_disk() {
        let f = quad();
        let bytes = write(4, &[tetra(), f.clone()]);
        let path = temp_file("reads_a_file_from_disk", &bytes);
        let m = read_serialized(&path, 1).unwrap();
        assert_matches(&m, &f, 4);
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn flags_without_precision_mean_f32() {
        let f = tetra();
        let bytes = edited(&f, |p| {
            p[..4].copy_from_slice(&FLAG_FACE_NORMALS.to_le_bytes())
        });
        assert_matches(&parse_serialized(&bytes, 0).unwrap(), &f, 4);
    }

    #[test]
    fn unknown_flag_bits_are_ignored() {
        let f = tetra();
        let extra = flags(&f) | 0x0004 | 0x0100 | 0x8000_0000;
        let bytes = edited(&f, |p| p[..4].copy_from_slice(&extra.to_le_bytes()));
        assert_matches(&parse_serialized(&bytes, 0).unwrap(), &f, 4);
    }

    #[test]
    fn an_empty_mesh_is_read() {
        let mut f = tetra();
        f.positions.clear();
        f.triangles.clear();
        let m = parse_serialized(&write(4, &[f]), 0).unwrap();
        assert!(m.positions.is_empty() && m.triangles.is_empty());
    }

    #[test]
    fn a_single_shape_without_a_table_reads_as_shape_0_only() {
        let f = quad();
        let bytes = shape(4, &payload(&f, 4));
        assert_matches(&parse_serialized(&bytes, 0).unwrap(), &f, 4);
        // Elsewhere the last four bytes are taken for the count.
        assert!(parse_serialized(&bytes, 1).is_err());
        assert!(shape_count(&bytes).is_err());
    }

    #[test]
    fn names_are_read_lossily_and_empty_ones_are_none() {
        let mut f = tetra();
        f.name = String::new();
        assert_eq!(
            parse_serialized(&write(4, &[f.clone()]), 0).unwrap().name,
            None
        );
        let p = payload(&f, 4);
        let mut named = p[..4].to_vec();
        named.extend_from_slice(b"caf\xE9\0");
        named.extend_from_slice(&p[5..]);
        let m = parse_serialized(&file(4, &[shape(4, &named)]), 0).unwrap();
        assert_eq!(m.name.as_deref(), Some("caf\u{FFFD}"));
    }

    #[test]
    fn normals_are_normalised_or_dropped_when_unusable() {
        let mut f = quad();
        f.normals = Some(vec![
            [0.0, 0.0, 2.0],
            [0.0, 3.0, 4.0],
            [1e-30, 0.0, 0.0],
            [-7.0, 0.0, 0.0],
        ]);
        let m = parse_serialized(&write(4, &[f.clone()]), 0).unwrap();
        assert_eq!(m.normals[0], Vec3::Z);
        assert!((m.normals[1] - Vec3::new(0.0, 0.6, 0.8)).length() < 1e-7);
        assert_eq!(m.normals[2], Vec3::X);
        assert_eq!(m.normals[3], -Vec3::X);
        for bad in [
            [0.0, 0.0, 0.0],
            [f64::NAN, 0.0, 1.0],
            [f64::INFINITY, 0.0, 0.0],
        ] {
            let mut g = f.clone();
            g.normals.as_mut().unwrap()[2] = bad;
            let m = parse_serialized(&write(4, &[g]), 0).unwrap();
            assert!(m.normals.is_empty(), "{bad:?} kept the normals");
            assert_eq!(m.positions.len(), 4);
        }
    }

    // Hostile input.

    #[test]
    fn every_truncation_fails_cleanly() {
        let bytes = write(4, &[quad(), tetra()]);
        for len in 0..bytes.len() {
            // Shape 0 does not need the table, so only a cut before the
            // table's start must fail for it.
            let _ = parse_serialized(&bytes[..len], 0);
            assert!(
                parse_serialized(&bytes[..len], 1).is_err(),
                "cut at {len} parsed"
            );
            assert!(shape_count(&bytes[..len]).is_err(), "cut at {len} counted");
        }
        // Cut inside the compressed data of the only shape (no table).
        let only = shape(4, &payload(&quad(), 4));
        for len in [0, 2, 4, 6, 10, only.len() / 2, only.len() - 1] {
            let r = parse_serialized(&only[..len], 0);
            assert!(r.is_err(), "cut at {len} parsed");
        }
        assert_content(
            parse_serialized(&only[..only.len() / 2], 0),
            &["shape 0", "truncated file?"],
        );
        assert_content(parse_serialized(&only[..2], 0), &["header", "truncated"]);
    }

    #[test]
    fn a_cut_in_an_array_names_the_array_and_vertex() {
        let mut f = quad();
        f.positions = vec![[0.5, 0.5, 0.5]; 1000];
        f.normals = None;
        f.uvs = None;
        f.colors = None;
        f.triangles.clear();
        let p = payload_with(&f, 4, flags(&f), 1000, 0);
        let cut = &p[..data_start(&f) + 12 * 400 + 5];
        // A complete zlib stream that ends early.
        assert_content(
            parse_serialized(&file(4, &[shape(4, cut)]), 0),
            &["ends early", "positions", "vertex 400 of 1000"],
        );
        // A zlib stream cut short.
        let s = shape(4, &p);
        assert_content(
            parse_serialized(&s[..s.len() - 6], 0),
            &["truncated file?", "positions", "of 1000"],
        );
    }

    #[test]
    fn bad_identifiers_and_versions_are_refused() {
        let good = write(4, &[quad()]);
        let mut b = good.clone();
        b[0] = 0x50;
        assert_content(
            parse_serialized(&b, 0),
            &["identifier is 0x0450", "not a Mitsuba"],
        );
        let mut b = good.clone();
        b[..2].copy_from_slice(&[0x04, 0x1C]);
        assert_content(parse_serialized(&b, 0), &["0x1C04", "big-endian"]);
        for (v, say) in [
            (2u16, "version 2"),
            (5, "version 5"),
            (0xFFFF, "version 65535"),
        ] {
            let mut b = good.clone();
            b[2..4].copy_from_slice(&v.to_le_bytes());
            assert_content(parse_serialized(&b, 0), &[say, "only versions 3 and 4"]);
            assert!(shape_count(&b).is_err());
        }
        assert_content(
            parse_serialized(b"ply\nformat ascii 1.0\n", 0),
            &["identifier"],
        );
        assert_content(parse_serialized(&[], 0), &["header", "0 bytes"]);
    }

    #[test]
    fn shape_index_out_of_range() {
        let bytes = write(3, &[quad(), tetra(), quad()]);
        let m = content(parse_serialized(&bytes, 7));
        assert_eq!(m, "shape_index 7 is out of range: the file holds 3 shapes");
        assert_content(
            parse_serialized(&bytes, 3),
            &["shape_index 3 is out of range"],
        );
        assert_content(
            parse_serialized(&write(4, &[quad()]), 1),
            &["the file holds 1 shape"],
        );
        assert_content(
            parse_serialized(&write(4, &[quad()]), u32::MAX),
            &["out of range"],
        );
    }

    #[test]
    fn offsets_outside_the_file_are_refused() {
        for version in [3u16, 4] {
            let bytes = write(version, &[quad(), tetra(), quad()]);
            let w = if version == 3 { 4 } else { 8 };
            let entry = bytes.len() - 4 - 2 * w; // shape 1's offset
            for bad in [
                u64::from(u32::MAX),
                bytes.len() as u64,
                (bytes.len() - 4 - 3 * w - 3) as u64,
            ] {
                let mut b = bytes.clone();
                b[entry..entry + w].copy_from_slice(&bad.to_le_bytes()[..w]);
                assert_content(parse_serialized(&b, 1), &["offset", "outside"]);
                assert_content(
                    match shape_count(&b) {
                        Ok(n) => Ok(SerializedMesh {
                            name: Some(n.to_string()),
                            ..Default::default()
                        }),
                        Err(e) => Err(e),
                    },
                    &["shape 1", "outside"],
                );
                // Shape 0 does not use the table.
                assert!(parse_serialized(&b, 0).is_ok());
            }
            if version == 4 {
                let mut b = bytes.clone();
                b[entry..entry + 8].copy_from_slice(&u64::MAX.to_le_bytes());
                assert_content(
                    parse_serialized(&b, 1),
                    &["18446744073709551615", "outside"],
                );
            }
            // An offset inside the file but not at a shape.
            let mut b = bytes.clone();
            b[entry..entry + w].copy_from_slice(&7u64.to_le_bytes()[..w]);
            assert_content(parse_serialized(&b, 1), &["shape 1's header (at byte 7)"]);
        }
    }

    #[test]
    fn a_table_larger_than_the_file_is_refused() {
        let mut bytes = write(4, &[quad(), tetra()]);
        let n = bytes.len();
        for count in [1000u32, u32::MAX] {
            bytes[n - 4..].copy_from_slice(&count.to_le_bytes());
            assert_content(parse_serialized(&bytes, 1), &["shape table", "claims"]);
            assert!(shape_count(&bytes).is_err());
        }
    }

    #[test]
    fn shape_count_checks_the_whole_table() {
        let bytes = write(4, &[quad(), tetra(), quad()]);
        let entry = |i: usize| bytes.len() - 4 - (3 - i) * 8;
        let count_err = |b: &[u8]| match shape_count(b) {
            Err(FormatError::Content(m)) => m,
            other => panic!("{other:?}"),
        };
        // A table of no shapes.
        let mut b = shape(4, &payload(&quad(), 4));
        b.extend_from_slice(&0u32.to_le_bytes());
        assert!(count_err(&b).contains("claims 0 shapes"));
        assert!(parse_serialized(&b, 0).is_ok());
        assert_eq!(
            content(parse_serialized(&b, 1)),
            "shape_index 1 is out of range: the file holds 0 shapes"
        );
        // The first offset not 0.
        let mut b = bytes.clone();
        let second = b[entry(1)..entry(1) + 8].to_vec();
        b[entry(0)..entry(0) + 8].copy_from_slice(&second);
        assert!(count_err(&b).contains("the first shape the offset"));
        // Offsets not increasing.
        let mut b = bytes.clone();
        b[entry(2)..entry(2) + 8].copy_from_slice(&second);
        assert!(count_err(&b).contains("not after shape 1's offset"));
        // An offset at no header.
        let mut b = bytes.clone();
        b[entry(2)..entry(2) + 8]
            .copy_from_slice(&(u64::from_le_bytes(second.try_into().unwrap()) + 1).to_le_bytes());
        assert!(count_err(&b).contains("shape 2's header"));
    }

    #[test]
    fn shapes_of_mixed_versions_are_refused() {
        let shapes = vec![
            shape(3, &payload(&quad(), 3)),
            shape(4, &payload(&tetra(), 4)),
        ];
        let bytes = file(3, &shapes);
        assert!(parse_serialized(&bytes, 0).is_ok());
        assert_content(
            parse_serialized(&bytes, 1),
            &["format version 4", "first shape's is 3"],
        );
    }

    #[test]
    fn corrupt_zlib_data_is_refused() {
        let bytes = write(4, &[quad()]);
        // The zlib header.
        let mut b = bytes.clone();
        b[4] ^= 0xFF;
        assert_content(
            parse_serialized(&b, 0),
            &["shape 0", "compressed data is corrupt", "the flags"],
        );
        // The checksum at the stream's end (the table follows: 8 + 4 bytes).
        let mut b = bytes.clone();
        let at = b.len() - 12 - 1;
        b[at] ^= 0x01;
        assert_content(parse_serialized(&b, 0), &["shape 0", "corrupt", "checksum"]);
        // Not zlib at all.
        let mut b = IDENTIFIER.to_le_bytes().to_vec();
        b.extend_from_slice(&4u16.to_le_bytes());
        b.extend_from_slice(&[0xAB; 64]);
        assert_content(parse_serialized(&b, 0), &["compressed data is corrupt"]);
        // Every single byte of the compressed data flipped: never a panic,
        // and never a silently different mesh (the checksum catches it).
        let f = quad();
        for i in 4..bytes.len() - 12 {
            let mut b = bytes.clone();
            b[i] ^= 0x5A;
            if let Ok(m) = parse_serialized(&b, 0) {
                assert_matches(&m, &f, 4);
            }
        }
    }

    #[test]
    fn both_precisions_are_refused() {
        let f = quad();
        let bytes = edited(&f, |p| {
            p[..4].copy_from_slice(&(flags(&f) | FLAG_DOUBLE).to_le_bytes())
        });
        assert_content(
            parse_serialized(&bytes, 0),
            &["flags 0x300B", "both single"],
        );
    }

    #[test]
    fn triangle_indices_beyond_the_vertices_are_refused() {
        let mut f = quad();
        f.triangles[1] = [0, 2, 4];
        assert_content(
            parse_serialized(&write(4, &[f]), 0),
            &["shape 0", "triangle 1 uses vertex 4", "4 vertices"],
        );
        let mut f = tetra();
        f.triangles[3] = [u32::MAX, 0, 1];
        assert_content(
            parse_serialized(&write(3, &[f]), 0),
            &["triangle 3 uses vertex 4294967295"],
        );
    }

    #[test]
    fn non_finite_and_huge_positions_are_refused() {
        for (bad, say) in [
            (f64::NAN, "not finite"),
            (f64::INFINITY, "not finite"),
            (f64::NEG_INFINITY, "not finite"),
            (2e12, "beyond ±1e12"),
            (-1.5e12, "beyond ±1e12"),
        ] {
            for double in [false, true] {
                let mut f = quad();
                f.double = double;
                f.positions[3][1] = bad;
                assert_content(
                    parse_serialized(&write(4, &[f]), 0),
                    &["the position of vertex 3", say],
                );
            }
        }
        // Beyond f32's range in an f64 file.
        let mut f = quad();
        f.double = true;
        f.positions[0][0] = 1e300;
        assert_content(
            parse_serialized(&write(4, &[f]), 0),
            &["vertex 0", "beyond ±1e12"],
        );
        // 1e12 itself is allowed.
        let mut f = quad();
        f.positions[0] = [1e12, -1e12, 0.0];
        assert!(parse_serialized(&write(4, &[f]), 0).is_ok());
    }

    #[test]
    fn non_finite_uvs_and_colours_are_refused() {
        let mut f = quad();
        f.uvs.as_mut().unwrap()[2][0] = f64::NAN;
        assert_content(
            parse_serialized(&write(4, &[f]), 0),
            &["texture coordinates of vertex 2"],
        );
        let mut f = quad();
        f.double = true;
        f.colors.as_mut().unwrap()[1][2] = 1e300;
        assert_content(
            parse_serialized(&write(4, &[f]), 0),
            &["colour of vertex 1", "not finite"],
        );
    }

    #[test]
    fn counts_beyond_the_limit_are_refused() {
        let f = quad();
        for (v, t, say) in [
            (MAX_COUNT + 1, 2, "vertex count 2147483649"),
            (4, MAX_COUNT + 1, "triangle count 2147483649"),
            (u64::MAX, 2, "vertex count 18446744073709551615"),
            (4, u64::MAX, "triangle count"),
        ] {
            let bytes = file(4, &[shape(4, &payload_with(&f, 4, flags(&f), v, t))]);
            assert_content(parse_serialized(&bytes, 0), &[say, "limit of 2147483648"]);
        }
    }

    #[test]
    fn counts_the_compressed_data_cannot_hold_are_refused_before_reading() {
        // 2^31 vertices of f64 with everything: ~190 GB from a few bytes.
        let mut f = quad();
        f.double = true;
        let bytes = file(
            4,
            &[shape(
                4,
                &payload_with(&f, 4, flags(&f), MAX_COUNT, MAX_COUNT),
            )],
        );
        let start = Instant::now();
        assert_content(
            parse_serialized(&bytes, 0),
            &["2147483648 vertices", "1032-fold"],
        );
        assert!(start.elapsed() < Duration::from_secs(1));
    }

    #[test]
    fn a_decompression_bomb_stops_at_the_declared_size() {
        // The header declares 4 vertices and 2 triangles; the stream goes on
        // with 1 GiB of zeros in about a megabyte: one sync-flushed segment
        // of 1 MiB of zeros, repeated (its matches reach back only into
        // zeros). The stream never ends properly, but the reader must stop
        // one byte past the declared data.
        let f = quad();
        let mut c = flate2::Compress::new(Compression::best(), true);
        let mut out = Vec::with_capacity(1 << 16);
        let zeros = vec![0u8; 1 << 20];
        let put = |c: &mut flate2::Compress, out: &mut Vec<u8>, data: &[u8]| {
            out.reserve(1 << 16);
            let before = c.total_in();
            c.compress_vec(data, out, flate2::FlushCompress::Sync)
                .unwrap();
            assert_eq!(c.total_in() - before, data.len() as u64);
        };
        put(&mut c, &mut out, &payload(&f, 4));
        put(&mut c, &mut out, &zeros);
        let mark = out.len();
        put(&mut c, &mut out, &zeros);
        let segment = out[mark..].to_vec();
        for _ in 0..1022 {
            out.extend_from_slice(&segment);
        }
        let mut s = IDENTIFIER.to_le_bytes().to_vec();
        s.extend_from_slice(&4u16.to_le_bytes());
        s.extend_from_slice(&out);
        let bytes = file(4, &[s]);
        assert!(bytes.len() < 4 << 20, "{} bytes", bytes.len());
        let start = Instant::now();
        assert_content(
            parse_serialized(&bytes, 0),
            &["more than the header describes"],
        );
        assert!(start.elapsed() < Duration::from_secs(1));
        // The same stream, cut after a few segments, inflates as the zeros
        // it claims (so the bomb is real): a decoder asked for everything
        // gets 4 MiB and more from it.
        let mut d = flate2::Decompress::new(true);
        let mut sink = vec![0u8; 8 << 20];
        let _ = d.decompress(
            &out[..mark + 4 * segment.len()],
            &mut sink,
            flate2::FlushDecompress::None,
        );
        assert!(d.total_out() > 4 << 20, "{}", d.total_out());
    }

    #[test]
    fn trailing_data_in_the_stream_is_refused() {
        let bytes = edited(&quad(), |p| p.push(0));
        assert_content(
            parse_serialized(&bytes, 0),
            &["shape 0", "more than the header describes"],
        );
    }

    #[test]
    fn a_name_without_its_nul_is_refused() {
        let f = quad();
        // The name runs on past the limit.
        let mut p = 0x1000u32.to_le_bytes().to_vec();
        p.extend(std::iter::repeat_n(b'a', MAX_NAME_BYTES + 10));
        assert_content(
            parse_serialized(&file(4, &[shape(4, &p)]), 0),
            &["name has no terminating NUL", "65536"],
        );
        // The stream ends inside the name.
        let p = payload(&f, 4);
        assert_content(
            parse_serialized(&file(4, &[shape(4, &p[..6])]), 0),
            &["ends early", "the name"],
        );
    }

    #[test]
    fn the_file_size_limit_is_checked_before_reading() {
        let bytes = write(4, &[quad()]);
        let path = temp_file("the_file_size_limit", &bytes);
        let n = bytes.len() as u64;
        assert!(read_serialized_with_limit(&path, 0, n).is_ok());
        let m = match read_serialized_with_limit(&path, 0, n - 1) {
            Err(FormatError::Content(m)) => m,
            other => panic!("{other:?}"),
        };
        assert!(
            m.contains(&format!("{n} bytes long, more than the limit of {}", n - 1)),
            "{m}"
        );
        let _ = std::fs::remove_file(&path);
    }

    #[test]
    fn a_missing_file_is_an_io_error() {
        let r = read_serialized(Path::new("/nonexistent/plsr/mesh.serialized"), 0);
        assert!(matches!(r, Err(FormatError::Io(_))));
    }

    #[test]
    fn errors_display_their_message() {
        let e = FormatError::from("bad thing".to_string());
        assert_eq!(e.to_string(), "bad thing");
        let e = FormatError::from(std::io::Error::other("disk gone"));
        assert_eq!(e.to_string(), "disk gone");
        assert!(std::error::Error::source(&e).is_some());
    }

    fn temp_file(tag: &str, bytes: &[u8]) -> std::path::PathBuf {
        let path =
            std::env::temp_dir().join(format!("plsr-serialized-{}-{tag}", std::process::id()));
        std::fs::write(&path, bytes).unwrap();
        path
    }

    // Fuzzing.

    /// xorshift64*: a fixed-seed stream of numbers for the fuzz loop.
    struct Rng(u64);

    impl Rng {
        fn next(&mut self) -> u64 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
        }

        fn below(&mut self, n: usize) -> usize {
            (self.next() % n.max(1) as u64) as usize
        }
    }

    /// Random edits of `b`: flipped bits, random bytes, random u32/u64
    /// values (counts, offsets), cuts, insertions, deletions.
    fn mutate(rng: &mut Rng, b: &mut Vec<u8>) {
        for _ in 0..1 + rng.below(4) {
            let at = rng.below(b.len());
            match rng.below(7) {
                0 if !b.is_empty() => b[at] ^= 1 << rng.below(8),
                1 if !b.is_empty() => b[at] = rng.next() as u8,
                2 => {
                    let v = match rng.below(4) {
                        0 => rng.next(),
                        1 => rng.next() % 16,
                        2 => u64::MAX - rng.next() % 16,
                        _ => (MAX_COUNT as i64 + rng.below(3) as i64 - 1) as u64,
                    };
                    let w = if rng.below(2) == 0 { 4 } else { 8 };
                    for (k, byte) in v.to_le_bytes()[..w].iter().enumerate() {
                        if let Some(x) = b.get_mut(at + k) {
                            *x = *byte;
                        }
                    }
                }
                3 => b.truncate(at),
                4 => {
                    let n = rng.below(16);
                    let extra: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                    b.splice(at..at, extra);
                }
                5 if !b.is_empty() => {
                    let end = (at + rng.below(16)).min(b.len());
                    b.drain(at..end);
                }
                _ => {
                    if !b.is_empty() {
                        b[at] = 0;
                    }
                }
            }
        }
    }

    #[test]
    fn fuzz_random_mutations_never_panic() {
        let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
        let mut fixtures = vec![quad(), tetra(), quad()];
        fixtures[1].double = true;
        fixtures[2].positions = (0..50)
            .map(|i| [i as f64, (i * i) as f64 * 0.01, -1.0])
            .collect();
        fixtures[2].normals = Some(vec![[0.0, 1.0, 0.0]; 50]);
        fixtures[2].uvs = Some(vec![[0.25, 0.75]; 50]);
        fixtures[2].colors = None;
        fixtures[2].triangles = (0..48).map(|i| [i, i + 1, i + 2]).collect();
        let start = Instant::now();
        let mut slowest = Duration::ZERO;
        let mut parsed = 0;
        for case in 0..2000 {
            let version = if case % 2 == 0 { 3 } else { 4 };
            let bytes = if case % 3 == 0 {
                // Mutate the uncompressed data, so that the edits reach
                // the field checks past zlib.
                let shapes: Vec<Vec<u8>> = fixtures
                    .iter()
                    .map(|f| {
                        let mut p = payload(f, version);
                        if rng.below(2) == 0 {
                            mutate(&mut rng, &mut p);
                        }
                        shape(version, &p)
                    })
                    .collect();
                file(version, &shapes)
            } else {
                let mut b = write(version, &fixtures);
                mutate(&mut rng, &mut b);
                b
            };
            let t = Instant::now();
            let _ = shape_count(&bytes);
            for index in 0..4 {
                if parse_serialized(&bytes, index).is_ok() {
                    parsed += 1;
                }
            }
            slowest = slowest.max(t.elapsed());
        }
        assert!(slowest < Duration::from_secs(2), "a case took {slowest:?}");
        assert!(start.elapsed() < Duration::from_secs(60));
        // Some mutations are harmless (the table's unused bytes, the name).
        assert!(parsed > 0);
    }

    // The real file.

    /// Mitsuba's material preview scene (matpreview.serialized, 857057
    /// bytes): version 3, three shapes, f32, normals and UVs.
    const MATPREVIEW: &str = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/realworld/mitsuba/common/meshes/matpreview.serialized"
    );

    #[test]
    fn reads_mitsubas_matpreview_as_mitsuba_does() {
        let bytes = std::fs::read(MATPREVIEW)
            .expect("tests/data/realworld/mitsuba/common/meshes/matpreview.serialized");
        assert_eq!(shape_count(&bytes).unwrap(), 3);
        // Reported by Mitsuba 3.9.1 (scalar_rgb, `serialized` shape with
        // shape_index 0, 1, 2 and the identity to_world): vertex_count(),
        // face_count(), bbox() min and max, and from mi.traverse: the first
        // vertex's position, normal and UV, the first and last faces, and
        // the sum of all face indices. Every shape has vertex normals and
        // texture coordinates.
        #[allow(clippy::type_complexity)]
        let expected: [(
            usize,
            usize,
            [f64; 3],
            [f64; 3],
            [f64; 3],
            [f64; 3],
            [f64; 2],
            [u32; 3],
            [u32; 3],
            u64,
        ); 3] = [
            (
                289,
                512,
                [-1.0024269819259644, -1.0, 0.0],
                [1.1313550472259521, 0.622808575630188, 1.2964400053024292],
                [-0.5048662424087524, 0.5747208595275879, 0.7843790054321289],
                [
                    -0.0005493488279171288,
                    -0.9891029000282288,
                    0.1472255140542984,
                ],
                [0.6446580290794373, 0.8092356324195862],
                [0, 1, 2],
                [285, 288, 286],
                220240,
            ),
            (
                2078,
                3936,
                [
                    -0.9272717833518982,
                    -0.927271842956543,
                    -0.031111598014831543,
                ],
                [0.9272717833518982, 0.927271842956543, 1.6868669986724854],
                [0.667028546333313, 0.27629226446151733, 0.06282293796539307],
                [0.0708649680018425, 0.02935922145843506, 0.9970538020133972],
                [0.15914541482925415, 0.3169771432876587],
                [0, 1, 2],
                [1861, 2077, 1865],
                12272103,
            ),
            (
                29439,
                57152,
                [
                    -1.2199430465698242,
                    -1.2199430465698242,
                    -1.1764949560165405,
                ],
                [1.003021001815796, 1.2199430465698242, 1.0131640434265137],
                [
                    0.047490596771240234,
                    -0.44950318336486816,
                    -0.9026844501495361,
                ],
                [0.0468159019947052, -0.3872535526752472, -0.9207839369773865],
                [0.9039270281791687, 0.8643703460693359],
                [0, 1, 2],
                [29438, 29380, 29428],
                2495575154,
            ),
        ];
        for (i, (v, f, lo, hi, p0, n0, uv0, first, last, sum)) in expected.into_iter().enumerate() {
            let m = parse_serialized(&bytes, i as u32).unwrap();
            assert_eq!(m.name, None);
            assert!(!m.face_normals);
            assert_eq!((m.positions.len(), m.triangles.len()), (v, f), "shape {i}");
            assert_eq!((m.normals.len(), m.uvs.len(), m.colors.len()), (v, v, 0));
            let min = m.positions.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
            let max = m
                .positions
                .iter()
                .fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
            assert_eq!(min, v3(lo), "shape {i}");
            assert_eq!(max, v3(hi), "shape {i}");
            assert_eq!(m.positions[0], v3(p0));
            // Mitsuba normalises the stored normals in f32, as this does in f64.
            assert!((m.normals[0] - v3(n0)).length() < 1e-6);
            assert_eq!(m.uvs[0], Vec2::new(uv0[0] as f32, uv0[1] as f32));
            assert_eq!(m.triangles[0], first);
            assert_eq!(m.triangles[f - 1], last);
            let total: u64 = m.triangles.iter().flatten().map(|&k| u64::from(k)).sum();
            assert_eq!(total, sum);
        }
        assert_content(
            parse_serialized(&bytes, 3),
            &["shape_index 3 is out of range: the file holds 3 shapes"],
        );
        // From disk, too.
        let m = read_serialized(Path::new(MATPREVIEW), 2).unwrap();
        assert_eq!(m.positions.len(), 29439);
    }
}
