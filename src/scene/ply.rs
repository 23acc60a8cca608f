//! PLY meshes (Stanford polygon files): ASCII and binary (little- and
//! big-endian) encodings, as scanners and Mitsuba's `ply` shape produce.
//!
//! Read: the `vertex` element's `x y z`, its normals `nx ny nz` and texture
//! coordinates (`u v`, `s t` or `texture_u texture_v`) when present, and
//! the `face` element's index list (`vertex_indices` or `vertex_index`),
//! polygons split into fans. Colours and other three-component
//! properties become named attributes, grouped as Mitsuba's `ply` shape
//! groups them (see [`PlyAttribute`]). Every other element and property is
//! skipped.
//! Errors name the file and what is wrong (with the header line).

use crate::error::FormatError;
use glam::{Vec2, Vec3};
use std::path::Path;

/// A PLY mesh in file coordinates.
#[derive(Debug, Clone, Default)]
pub struct PlyMesh {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles (polygons fan-triangulated).
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex unit normals, or empty.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates, or empty.
    pub uvs: Vec<Vec2>,
    /// Three-component attributes of vertices and faces (colours first).
    pub attributes: Vec<PlyAttribute>,
}

/// A three-component property group of the vertices or faces, named as
/// Mitsuba names it: `r g b` or `red green blue` (an alpha after them is
/// dropped) are `vertex_color` / `face_color`; `P_x P_y P_z`, `P_0 P_1 P_2`
/// or `P_1 P_2 P_3` are `vertex_P`, and `P_r P_g P_b` `vertex_P_color`.
/// Integer components are divided by their type's maximum and decoded from
/// sRGB (as Mitsuba's loader does); floating-point ones are taken as they
/// are (linear).
#[derive(Debug, Clone, PartialEq)]
pub struct PlyAttribute {
    /// `vertex_…` or `face_…`.
    pub name: String,
    /// One value per vertex, or per triangle for a face attribute (a
    /// polygon's value repeated over its fan).
    pub values: Vec<Vec3>,
}

impl PlyMesh {
    /// The attribute called `name`, if the file has it.
    pub fn attribute(&self, name: &str) -> Option<&PlyAttribute> {
        self.attributes.iter().find(|a| a.name == name)
    }
}

/// The most vertices or faces a file may declare (beyond, the counts are
/// taken for a corrupt header rather than allocated).
const MAX_COUNT: u64 = 1 << 31;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Scalar> {
        Some(match s {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// The largest value of an integer type (what a normalised component
    /// is divided by); `None` for floating point.
    fn integer_max(self) -> Option<f64> {
        match self {
            Scalar::I8 => Some(i8::MAX as f64),
            Scalar::U8 => Some(u8::MAX as f64),
            Scalar::I16 => Some(i16::MAX as f64),
            Scalar::U16 => Some(u16::MAX as f64),
            Scalar::I32 => Some(i32::MAX as f64),
            Scalar::U32 => Some(u32::MAX as f64),
            Scalar::F32 | Scalar::F64 => None,
        }
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Debug, Clone)]
enum Property {
    Scalar(String, Scalar),
    /// A list: count type, item type.
    List(String, Scalar, Scalar),
}

#[derive(Debug, Clone)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// Reads values in the file's encoding.
struct Reader<'a> {
    encoding: Encoding,
    bytes: &'a [u8],
    at: usize,
    /// ASCII: the remaining whitespace-separated tokens.
    tokens: std::str::SplitAsciiWhitespace<'a>,
}

impl Reader<'_> {
    fn value(&mut self, t: Scalar) -> Result<f64, FormatError> {
        if self.encoding == Encoding::Ascii {
            let tok = self.tokens.next().ok_or("the data ends early")?;
            return tok
                .parse::<f64>()
                .map_err(|_| FormatError::Content(format!("{tok:?} is not a number")));
        }
        let n = t.size();
        let b = self
            .bytes
            .get(self.at..self.at + n)
            .ok_or("the data ends early (truncated file?)")?;
        self.at += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.encoding == Encoding::Big {
            a[..n].reverse();
        }
        Ok(match t {
            Scalar::I8 => a[0] as i8 as f64,
            Scalar::U8 => a[0] as f64,
            Scalar::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Scalar::F64 => f64::from_le_bytes(a),
        })
    }
}

/// Reads a PLY file; the error says what is wrong (the caller names the
/// file).
pub fn read_ply(path: &Path) -> Result<PlyMesh, FormatError> {
    let bytes = std::fs::read(path)?;
    parse_ply(&bytes)
}

/// Parses the bytes of a PLY file.
pub fn parse_ply(bytes: &[u8]) -> Result<PlyMesh, FormatError> {
    let (lines, at) = header_lines(bytes)?;
    if lines.first().map(String::as_str) != Some("ply") {
        return Err("not a PLY file (the first line is not `ply`)".into());
    }
    let (encoding, elements) = parse_header(&lines)?;
    let body = &bytes[at..];
    let text = if encoding == Encoding::Ascii {
        std::str::from_utf8(body).map_err(|_| "the ASCII data is not text")?
    } else {
        ""
    };
    let mut r = Reader {
        encoding,
        bytes: body,
        at: 0,
        tokens: text.split_ascii_whitespace(),
    };
    let mut mesh = PlyMesh::default();
    for e in &elements {
        read_element(&mut r, e, &mut mesh)?;
    }
    check_mesh(&mut mesh)?;
    Ok(mesh)
}

/// The header's lines (trimmed, without `end_header`) and the offset of
/// the body after it.
fn header_lines(bytes: &[u8]) -> Result<(Vec<String>, usize), FormatError> {
    let mut at = 0;
    let mut lines = Vec::new();
    loop {
        let end = bytes[at..]
            .iter()
            .position(|&b| b == b'\n')
            .ok_or("no `end_header` line: not a PLY file, or a truncated one")?;
        let line = std::str::from_utf8(&bytes[at..at + end])
            .map_err(|_| format!("header line {}: not text", lines.len() + 1))?
            .trim_end_matches('\r')
            .trim();
        at += end + 1;
        if line == "end_header" {
            break;
        }
        lines.push(line.to_string());
    }
    Ok((lines, at))
}

/// The header after its `ply` line: the encoding and the elements with
/// their properties.
fn parse_header(lines: &[String]) -> Result<(Encoding, Vec<Element>), FormatError> {
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    for (i, line) in lines.iter().enumerate().skip(1) {
        let bad = |why: &str| format!("header line {}: {why}: {line:?}", i + 1);
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["format", f, "1.0"] => {
                encoding = Some(match *f {
                    "ascii" => Encoding::Ascii,
                    "binary_little_endian" => Encoding::Little,
                    "binary_big_endian" => Encoding::Big,
                    _ => return Err(FormatError::Content(bad("unknown format"))),
                })
            }
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["element", name, count] => {
                let count: u64 = count.parse().map_err(|_| bad("bad element count"))?;
                if count > MAX_COUNT {
                    return Err(FormatError::Content(bad("too many items")));
                }
                // Found by fuzzing: a second `element vertex` without the
                // first one's texture coordinates left them short.
                if elements.iter().any(|e| e.name == *name) {
                    return Err(FormatError::Content(bad("the element is declared twice")));
                }
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", c, t, name] => {
                let (c, t) = (
                    Scalar::parse(c).ok_or_else(|| bad("unknown type"))?,
                    Scalar::parse(t).ok_or_else(|| bad("unknown type"))?,
                );
                elements
                    .last_mut()
                    .ok_or_else(|| bad("a property before any element"))?
                    .properties
                    .push(Property::List(name.to_string(), c, t));
            }
            ["property", t, name] => {
                let t = Scalar::parse(t).ok_or_else(|| bad("unknown type"))?;
                elements
                    .last_mut()
                    .ok_or_else(|| bad("a property before any element"))?
                    .properties
                    .push(Property::Scalar(name.to_string(), t));
            }
            _ => return Err(FormatError::Content(bad("not understood"))),
        }
    }
    let encoding = encoding.ok_or("no `format` line in the header")?;
    Ok((encoding, elements))
}

/// The three-component groups among an element's scalar properties (see
/// [`PlyAttribute`]): each group's name without the element prefix and
/// its three property slots.
fn attribute_groups(e: &Element) -> Vec<(String, [usize; 3])> {
    let names: Vec<Option<&str>> = e
        .properties
        .iter()
        .map(|p| match p {
            Property::Scalar(n, _) => Some(n.as_str()),
            Property::List(..) => None,
        })
        .collect();
    let mut groups = Vec::new();
    let mut k = 0;
    while k + 2 < names.len() {
        let run = [names[k], names[k + 1], names[k + 2]];
        let found = if let [Some(a), Some(b), Some(c)] = run {
            if [a, b, c] == ["r", "g", "b"] || [a, b, c] == ["red", "green", "blue"] {
                Some("color".to_string())
            } else {
                [
                    (["_x", "_y", "_z"], ""),
                    (["_r", "_g", "_b"], "_color"),
                    (["_0", "_1", "_2"], ""),
                    (["_1", "_2", "_3"], ""),
                ]
                .iter()
                .find_map(|(suffixes, tail)| {
                    let prefix = a.strip_suffix(suffixes[0])?;
                    (!prefix.is_empty()
                        && b.strip_suffix(suffixes[1]) == Some(prefix)
                        && c.strip_suffix(suffixes[2]) == Some(prefix))
                    .then(|| format!("{prefix}{tail}"))
                })
            }
        } else {
            None
        };
        match found {
            Some(name) => {
                groups.push((name, [k, k + 1, k + 2]));
                k += 3;
            }
            None => k += 1,
        }
    }
    groups
}

/// Reads every item of element `e` from `r`: vertices (positions, normals,
/// texture coordinates) and faces (fan-triangulated) go into `mesh`, any
/// other element is read past.
fn read_element(r: &mut Reader, e: &Element, mesh: &mut PlyMesh) -> Result<(), FormatError> {
    let slot = |n: &str| {
        e.properties
            .iter()
            .position(|p| matches!(p, Property::Scalar(m, _) if m == n))
    };
    let is_vertex = e.name == "vertex";
    let (pos, nrm, uv) = if is_vertex {
        let pos = [slot("x"), slot("y"), slot("z")];
        if pos.iter().any(Option::is_none) {
            return Err("the vertex element has no x, y and z".into());
        }
        let nrm = [slot("nx"), slot("ny"), slot("nz")];
        let uv = [("u", "v"), ("s", "t"), ("texture_u", "texture_v")]
            .iter()
            .find_map(|(a, b)| Some([slot(a)?, slot(b)?]));
        (
            pos.map(Option::unwrap),
            nrm.iter()
                .all(Option::is_some)
                .then(|| nrm.map(Option::unwrap)),
            uv,
        )
    } else {
        ([0; 3], None, None)
    };
    let faces = e.name == "face";
    let list = e.properties.iter().position(
        |p| matches!(p, Property::List(n, _, _) if n == "vertex_indices" || n == "vertex_index"),
    );
    if faces && list.is_none() {
        return Err("the face element has no vertex_indices list".into());
    }
    let groups = if is_vertex || faces {
        attribute_groups(e)
    } else {
        Vec::new()
    };
    let first_attribute = mesh.attributes.len();
    for (name, _) in &groups {
        mesh.attributes.push(PlyAttribute {
            name: format!("{}_{name}", if is_vertex { "vertex" } else { "face" }),
            values: Vec::new(),
        });
    }
    let component = |values: &[f64], slot: usize| -> f32 {
        let v = values[slot];
        match &e.properties[slot] {
            Property::Scalar(_, t) => match t.integer_max() {
                Some(max) => crate::texture::srgb_to_linear((v / max) as f32),
                None => v as f32,
            },
            Property::List(..) => 0.0,
        }
    };
    // An element of no properties holds no bytes, however many items it
    // claims (found by fuzzing: two billion of them looped for minutes).
    if e.properties.is_empty() {
        return Ok(());
    }
    let mut values = vec![0.0f64; e.properties.len()];
    let mut polygon: Vec<u32> = Vec::new();
    for item in 0..e.count {
        let triangles_before = mesh.triangles.len();
        let err = |m: String| FormatError::Content(format!("{} {item}: {m}", e.name));
        let at = |f: FormatError| err(f.to_string());
        for (k, p) in e.properties.iter().enumerate() {
            match p {
                Property::Scalar(_, t) => values[k] = r.value(*t).map_err(at)?,
                Property::List(_, c, t) => {
                    let n = r.value(*c).map_err(at)?;
                    if !((0.0..=1e6).contains(&n) && n.fract() == 0.0) {
                        return Err(err(format!("bad list length {n}")));
                    }
                    let keep = faces && Some(k) == list;
                    polygon.clear();
                    for _ in 0..n as usize {
                        let v = r.value(*t).map_err(at)?;
                        if keep {
                            if !((0.0..u32::MAX as f64).contains(&v) && v.fract() == 0.0) {
                                return Err(err(format!("bad vertex index {v}")));
                            }
                            polygon.push(v as u32);
                        }
                    }
                    if keep {
                        for j in 1..polygon.len().saturating_sub(1) {
                            mesh.triangles
                                .push([polygon[0], polygon[j], polygon[j + 1]]);
                        }
                    }
                }
            }
        }
        if is_vertex {
            let v = |i: usize| values[i] as f32;
            mesh.positions
                .push(Vec3::new(v(pos[0]), v(pos[1]), v(pos[2])));
            if let Some(n) = nrm {
                mesh.normals.push(Vec3::new(v(n[0]), v(n[1]), v(n[2])));
            }
            if let Some([a, b]) = uv {
                mesh.uvs.push(Vec2::new(v(a), v(b)));
            }
        }
        // A vertex's value once; a face's once per triangle of its fan.
        let repeat = if is_vertex {
            1
        } else {
            mesh.triangles.len() - triangles_before
        };
        for (g, (_, slots)) in groups.iter().enumerate() {
            let value = Vec3::from(slots.map(|k| component(&values, k)));
            let a = &mut mesh.attributes[first_attribute + g].values;
            a.extend(std::iter::repeat_n(value, repeat));
        }
    }
    Ok(())
}

/// Checks the mesh read: faces name existing vertices, positions are
/// finite; normals are made unit length, or dropped if any is unusable.
fn check_mesh(mesh: &mut PlyMesh) -> Result<(), FormatError> {
    let n = mesh.positions.len() as u64;
    if let Some(t) = mesh
        .triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as u64 >= n))
    {
        return Err(format!("a face uses vertex {} of {n}", t.iter().max().unwrap()).into());
    }
    if mesh.positions.iter().any(|p| !p.is_finite()) {
        return Err("a vertex position is not a finite number".into());
    }
    for a in &mesh.attributes {
        if let Some(i) = a.values.iter().position(|v| !v.is_finite()) {
            return Err(format!("{} of item {i} is not a finite number", a.name).into());
        }
    }
    // Normals: unit length where given, or none at all if any is unusable.
    if mesh
        .normals
        .iter()
        .any(|n| !n.is_finite() || n.length_squared() == 0.0)
    {
        mesh.normals.clear();
    }
    for n in &mut mesh.normals {
        *n = n.normalize();
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    const ASCII: &str = "ply\nformat ascii 1.0\ncomment a quad\nelement vertex 4\n\
        property float x\nproperty float y\nproperty float z\nproperty float nx\n\
        property float ny\nproperty float nz\nproperty float u\nproperty float v\n\
        element face 1\nproperty list uchar int vertex_indices\nend_header\n\
        0 0 0 0 0 2 0 0\n1 0 0 0 0 1 1 0\n1 1 0 0 0 1 1 1\n0 1 0 0 0 1 0 1\n4 0 1 2 3\n";

    #[test]
    fn ascii_and_binary_encodings_read_the_same_mesh() {
        let a = parse_ply(ASCII.as_bytes()).unwrap();
        assert_eq!(a.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(a.positions[2], Vec3::new(1.0, 1.0, 0.0));
        assert_eq!(a.normals[0], Vec3::Z);
        assert_eq!(a.uvs[3], Vec2::new(0.0, 1.0));
        for big in [false, true] {
            let header = ASCII
                .split("end_header\n")
                .next()
                .unwrap()
                .replace(
                    "format ascii 1.0",
                    if big {
                        "format binary_big_endian 1.0"
                    } else {
                        "format binary_little_endian 1.0"
                    },
                )
                .replace(
                    "uchar int vertex_indices",
                    "uchar int vertex_indices\nelement extra 1\nproperty list uchar double junk",
                );
            let mut bytes = format!("{header}end_header\n").into_bytes();
            let f = |x: f32, out: &mut Vec<u8>| {
                out.extend(if big {
                    x.to_be_bytes()
                } else {
                    x.to_le_bytes()
                })
            };
            for line in ASCII.split("end_header\n").nth(1).unwrap().lines().take(4) {
                for x in line.split_whitespace() {
                    f(x.parse().unwrap(), &mut bytes);
                }
            }
            bytes.push(4);
            for i in 0..4i32 {
                bytes.extend(if big {
                    i.to_be_bytes()
                } else {
                    i.to_le_bytes()
                });
            }
            bytes.push(1);
            bytes.extend(if big {
                5f64.to_be_bytes()
            } else {
                5f64.to_le_bytes()
            });
            let b = parse_ply(&bytes).unwrap();
            assert_eq!(
                (b.positions.clone(), b.triangles.clone()),
                (a.positions.clone(), a.triangles.clone())
            );
            assert_eq!(
                (b.normals.clone(), b.uvs.clone()),
                (a.normals.clone(), a.uvs.clone())
            );
        }
    }

    #[test]
    fn colours_and_grouped_properties_become_attributes() {
        // uchar colours with alpha on the vertices, float `color_0..2` and
        // a `dir_x..z` group on a quad face (two triangles), a lone `w`.
        let text = "ply\nformat ascii 1.0\nelement vertex 4\n\
            property float x\nproperty float y\nproperty float z\n\
            property uchar red\nproperty uchar green\nproperty uchar blue\nproperty uchar alpha\n\
            element face 1\nproperty list uchar int vertex_indices\n\
            property float color_0\nproperty float color_1\nproperty float color_2\n\
            property float w\nproperty double dir_x\nproperty double dir_y\nproperty double dir_z\n\
            end_header\n\
            0 0 0 255 0 0 255\n1 0 0 0 255 0 255\n1 1 0 0 0 188 255\n0 1 0 10 10 10 0\n\
            4 0 1 2 3 0.25 0.5 2.0 9 1 2 3\n";
        let m = parse_ply(text.as_bytes()).unwrap();
        let names: Vec<&str> = m.attributes.iter().map(|a| a.name.as_str()).collect();
        assert_eq!(names, ["vertex_color", "face_color", "face_dir"]);
        let vc = &m.attribute("vertex_color").unwrap().values;
        assert_eq!(vc[0], Vec3::X);
        assert_eq!(vc[1], Vec3::Y);
        // 188/255 decoded from sRGB.
        assert!((vc[2].z - crate::texture::srgb_to_linear(188.0 / 255.0)).abs() < 1e-7);
        assert!((vc[2].z - 0.5029).abs() < 1e-3, "{}", vc[2].z);
        assert_eq!(vc[3], Vec3::splat(10.0f32 / 255.0 / 12.92));
        // Floating-point components are linear, one per triangle.
        let fc = &m.attribute("face_color").unwrap().values;
        assert_eq!(fc, &vec![Vec3::new(0.25, 0.5, 2.0); 2]);
        assert_eq!(
            m.attribute("face_dir").unwrap().values[1],
            Vec3::new(1.0, 2.0, 3.0)
        );
        let nan = text.replace("0.25 0.5 2.0", "0.25 nan 2.0");
        let e = parse_ply(nan.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("face_color of item 0"), "{e}");
    }

    #[test]
    fn bad_files_say_what_is_wrong() {
        for (text, says) in [
            ("solid cube\n", "no `end_header`"),
            ("pl\nend_header\n", "not a PLY file"),
            ("ply\nformat ascii 2.0\nend_header\n", "header line 2: not understood"),
            ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n", "no x, y and z"),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0\n",
                "vertex 0: the data ends early",
            ),
            (
                "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\n\
                 element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 2\n",
                "a face uses vertex 2 of 1",
            ),
            ("ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n\x00\x00", "truncated"),
        ] {
            let e = parse_ply(text.as_bytes()).unwrap_err();
            assert!(e.to_string().contains(says), "{text:?}: {e}");
        }
    }
}
