//! Mesh sources: built-in shapes and Wavefront OBJ files (through tobj).
//!
//! Built-in shapes, in their own coordinates before the shape's transform:
//! - `rectangle`: the square `[-1, 1]²` in the `z = 0` plane, normal `+z`.
//! - `sphere`: an icosphere of `radius` around `center`, normals outwards
//!   (`flip_normals = true` turns them inwards, e.g. for an enclosure).
//! - `disk`: the unit disk in the `z = 0` plane, normal `+z`, as a fan of
//!   `segments` triangles (Mitsuba's `disk`).
//! - `cube`: the cube `[-1, 1]³`, normals outwards, 12 triangles (Mitsuba's
//!   `cube`).

use crate::error::FormatError;
use crate::error::{Error, Result};
use glam::Vec2;
use glam::{Mat4, Vec3};
use plsr_base::Vocabulary;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// Vertex positions and counter-clockwise triangles.
pub type TriangleSoup = (Vec<Vec3>, Vec<[u32; 3]>);

/// The square `[-1, 1]²` at `z = 0`, facing `+z`, as two triangles.
pub fn rectangle() -> TriangleSoup {
    let p = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    (p, vec![[0, 1, 2], [0, 2, 3]])
}

/// The unit disk at `z = 0`, facing `+z`: a fan of `segments` triangles
/// round its centre, with Mitsuba's polar texture coordinates `(r, φ/2π)`
/// (`φ` from `+x` towards `+y`). Each triangle has its own centre vertex
/// (at its middle azimuth) and the rim's first vertex is repeated at
/// `φ = 2π`, so that coordinates interpolate without wrapping round.
pub fn disk(segments: u32) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec2>) {
    let n = segments as usize;
    let mut p = Vec::with_capacity(2 * n + 1);
    let mut uv = Vec::with_capacity(2 * n + 1);
    for i in 0..=segments {
        let turns = i as f32 / segments as f32;
        let (sin, cos) = (std::f32::consts::TAU * turns).sin_cos();
        let rim = if i == segments {
            p[0]
        } else {
            Vec3::new(cos, sin, 0.0)
        };
        p.push(rim);
        uv.push(Vec2::new(1.0, turns));
    }
    for i in 0..segments {
        p.push(Vec3::ZERO);
        uv.push(Vec2::new(0.0, (i as f32 + 0.5) / segments as f32));
    }
    let t = (0..segments)
        .map(|i| [segments + 1 + i, i, i + 1])
        .collect();
    (p, t, uv)
}

/// The unit cylinder `x² + y² = 1, 0 ≤ z ≤ 1`, open at both ends (no
/// caps), facing outwards: `segments` quads round the axis, with Mitsuba's
/// texture coordinates `(φ/2π, z)` and outward vertex normals. The seam
/// column is repeated at `u = 1`, so coordinates interpolate without
/// wrapping round.
pub fn cylinder(segments: u32) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec3>, Vec<Vec2>) {
    let n = segments as usize;
    let (mut p, mut normals, mut uv) = (
        Vec::with_capacity(2 * n + 2),
        Vec::with_capacity(2 * n + 2),
        Vec::with_capacity(2 * n + 2),
    );
    for i in 0..=segments {
        let turns = i as f32 / segments as f32;
        let (sin, cos) = if i == segments {
            (0.0, 1.0)
        } else {
            (std::f32::consts::TAU * turns).sin_cos()
        };
        for z in [0.0, 1.0] {
            p.push(Vec3::new(cos, sin, z));
            normals.push(Vec3::new(cos, sin, 0.0));
            uv.push(Vec2::new(turns, z));
        }
    }
    let mut t = Vec::with_capacity(2 * n);
    for i in 0..segments {
        let (a, b) = (2 * i, 2 * i + 2);
        // Counter-clockwise seen from outside: bottom i, bottom i+1, top i+1.
        t.push([a, b, b + 1]);
        t.push([a, b + 1, a + 1]);
    }
    (p, t, normals, uv)
}

/// Mitsuba's `coordinate_system(n)` (Duff et al. 2017): two unit vectors
/// `(s, t)` completing unit `n` to an orthonormal frame, the same as
/// Mitsuba's for the same `n` (the cylinder's `u = 0` lies along `s`).
pub fn coordinate_system(n: Vec3) -> (Vec3, Vec3) {
    let sign = if n.z >= 0.0 { 1.0f32 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// The cube `[-1, 1]³`, facing outwards: four vertices per face (so that
/// each face has its own texture coordinates, `[0, 1]²`), two triangles each.
pub fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec2>) {
    let (mut p, mut t, mut uv) = (Vec::new(), Vec::new(), Vec::new());
    // Each face: its outward normal `n` and two edges `a`, `b` with a × b = n.
    for n in [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z] {
        let a = if n.x != 0.0 { Vec3::Y } else { Vec3::X }
            * if n.x + n.y + n.z > 0.0 { 1.0 } else { -1.0 };
        let b = n.cross(a);
        let base = p.len() as u32;
        for (u, v) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
            p.push(n + (2.0 * u - 1.0) * a + (2.0 * v - 1.0) * b);
            uv.push(Vec2::new(u, v));
        }
        t.push([base, base + 1, base + 2]);
        t.push([base, base + 2, base + 3]);
    }
    (p, t, uv)
}

/// Angle-weighted vertex normals (Thürmer and Wüthrich 1998): each
/// triangle adds its unit normal, weighted by its angle at the vertex, to
/// the vertex. Vertices at the same position share one normal, so a mesh
/// split along texture seams stays smooth across them. A vertex of only
/// degenerate triangles gets `+z`.
pub fn angle_weighted_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let key = |p: Vec3| p.to_array().map(|x| if x == 0.0 { 0 } else { x.to_bits() });
    let mut slot: HashMap<[u32; 3], usize> = HashMap::new();
    let index: Vec<usize> = positions
        .iter()
        .map(|p| {
            let n = slot.len();
            *slot.entry(key(*p)).or_insert(n)
        })
        .collect();
    let mut sums = vec![Vec3::ZERO; slot.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let Some(n) = (b - a).cross(c - a).try_normalize() else {
            continue;
        };
        for (k, (p, q, r)) in [(a, b, c), (b, c, a), (c, a, b)].into_iter().enumerate() {
            let angle = (q - p).angle_between(r - p);
            if angle.is_finite() {
                sums[index[t[k] as usize]] += angle * n;
            }
        }
    }
    index
        .iter()
        .map(|&i| sums[i].try_normalize().unwrap_or(Vec3::Z))
        .collect()
}

/// An icosphere: an icosahedron subdivided `subdivisions` times, projected
/// onto the sphere; outward-facing triangles (20·4^subdivisions of them).
pub fn icosphere(center: Vec3, radius: f32, subdivisions: u32) -> TriangleSoup {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut p: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|v| Vec3::from_array(*v).normalize())
    .collect();
    let mut tris: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, p: &mut Vec<Vec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                p.push(((p[a as usize] + p[b as usize]) * 0.5).normalize());
                (p.len() - 1) as u32
            })
        };
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut p);
            let bc = midpoint(b, c, &mut p);
            let ca = midpoint(c, a, &mut p);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let p = p.into_iter().map(|v| center + radius * v).collect();
    (p, tris)
}

/// An [`icosphere`] with Mitsuba's spherical texture coordinates
/// `(φ/2π, θ/π)` at its vertices (`φ` the azimuth from `+x` towards `+y`,
/// `θ` the angle from `+z`). Triangles across the seam `φ = 0` get copies
/// of their vertices at `u + 1`, and a vertex on a pole one copy per
/// triangle at the mean `u` of the other two, so that coordinates
/// interpolate without wrapping round; exact coordinates at a hit come from
/// [`crate::scene::uv_map::UvMap::Sphere`].
pub fn icosphere_with_uvs(
    center: Vec3,
    radius: f32,
    subdivisions: u32,
) -> (Vec<Vec3>, Vec<[u32; 3]>, Vec<Vec2>) {
    let (p, t) = icosphere(Vec3::ZERO, 1.0, subdivisions);
    let uv_of = |q: Vec3| {
        Vec2::new(
            crate::scene::uv_map::azimuth_turns(q),
            q.z.clamp(-1.0, 1.0).acos() * std::f32::consts::FRAC_1_PI,
        )
    };
    let on_pole = |q: Vec3| q.x.hypot(q.y) < 1e-6;
    let mut out_p: Vec<Vec3> = p.iter().map(|&q| center + radius * q).collect();
    let mut out_uv: Vec<Vec2> = p.iter().map(|&q| uv_of(q)).collect();
    // Copies of a vertex by (index, bits of its u).
    let mut copies: HashMap<(u32, u32), u32> = HashMap::new();
    let mut tris = Vec::with_capacity(t.len());
    for tri in t {
        let mut u = tri.map(|i| out_uv[i as usize].x);
        let poles = tri.map(|i| on_pole(p[i as usize]));
        let off_pole: Vec<f32> = (0..3).filter(|&k| !poles[k]).map(|k| u[k]).collect();
        let (lo, hi) = off_pole
            .iter()
            .fold((f32::MAX, f32::MIN), |(a, b), &x| (a.min(x), b.max(x)));
        if hi - lo > 0.5 {
            for k in 0..3 {
                if !poles[k] && u[k] < 0.5 {
                    u[k] += 1.0;
                }
            }
        }
        let mean =
            (0..3).filter(|&k| !poles[k]).map(|k| u[k]).sum::<f32>() / off_pole.len().max(1) as f32;
        let mut out = tri;
        for k in 0..3 {
            if poles[k] {
                u[k] = mean;
            }
            let i = tri[k];
            if u[k] != out_uv[i as usize].x {
                let v = out_uv[i as usize].y;
                out[k] = *copies.entry((i, u[k].to_bits())).or_insert_with(|| {
                    out_p.push(out_p[i as usize]);
                    out_uv.push(Vec2::new(u[k], v));
                    (out_p.len() - 1) as u32
                });
            }
        }
        tris.push(out);
    }
    (out_p, tris, out_uv)
}

/// Reverses the winding of every triangle (flips geometric normals).
pub fn flip_winding(triangles: &mut [[u32; 3]]) {
    for t in triangles {
        t.swap(1, 2);
    }
}

/// Applies an affine transform to positions; a transform that mirrors
/// (negative determinant) also reverses the winding, so that geometric normals
/// keep pointing to the same side of the surface.
pub fn transform_mesh(m: &Mat4, positions: &mut [Vec3], triangles: &mut [[u32; 3]]) {
    for p in positions.iter_mut() {
        *p = m.transform_point3(*p);
    }
    if m.determinant() < 0.0 {
        flip_winding(triangles);
    }
}

/// One object of an OBJ file, with the index of its MTL material.
#[derive(Debug, Clone)]
pub struct ObjObject {
    /// Object or group name.
    pub name: String,
    /// Vertex positions (file units).
    pub positions: Vec<Vec3>,
    /// Triangles (polygons are fan-triangulated by tobj).
    pub triangles: Vec<[u32; 3]>,
    /// Per-vertex unit normals (`vn`), or empty when the file has none.
    pub normals: Vec<Vec3>,
    /// Per-vertex texture coordinates (`vt`), or empty.
    pub uvs: Vec<Vec2>,
    /// Index into [`ObjFile::materials`].
    pub material: Option<usize>,
}

/// An MTL material as plsr reads it.
#[derive(Debug, Clone)]
pub struct ObjMaterial {
    /// `newmtl` name.
    pub name: String,
    /// `Kd`, diffuse albedo.
    pub diffuse: Option<Vec3>,
    /// `Ke`, emitted radiance.
    pub emission: Option<Vec3>,
    /// `Ks`, specular albedo (Blinn–Phong).
    pub specular: Option<Vec3>,
    /// `Ns`, Phong exponent.
    pub shininess: Option<f32>,
    /// `Pr`, roughness (PBR extension).
    pub roughness: Option<f32>,
    /// `Pm`, metallic (PBR extension).
    pub metallic: Option<f32>,
    /// `map_Kd`, base colour texture, resolved against the OBJ's folder.
    pub diffuse_map: Option<PathBuf>,
    /// `map_Pr`, roughness texture.
    pub roughness_map: Option<PathBuf>,
    /// `map_Pm`, metallic texture.
    pub metallic_map: Option<PathBuf>,
}

/// The contents of an OBJ file and its MTL library.
#[derive(Debug, Clone)]
pub struct ObjFile {
    /// Objects, in file order.
    pub objects: Vec<ObjObject>,
    /// MTL materials, in library order.
    pub materials: Vec<ObjMaterial>,
    /// The MTL libraries read (resolved against the OBJ's folder).
    pub libraries: Vec<PathBuf>,
}

/// The largest MTL library read (they are a few KiB in practice).
const MAX_MTL_BYTES: u64 = 64 << 20;

/// Checks what tobj's MTL reader assumes of a library: text (no NUL or
/// other control bytes), a `newmtl` before any other statement, three
/// numbers after `Ka`, `Kd`, `Ks` and `Ke`, one after `Ns`, `Ni` and `d`.
/// The error names the line.
fn check_mtl(path: &Path) -> std::result::Result<(), FormatError> {
    let len = std::fs::metadata(path)?.len();
    if len > MAX_MTL_BYTES {
        return Err(format!(
            "{len} bytes, more than an MTL library may have ({MAX_MTL_BYTES} bytes)"
        )
        .into());
    }
    let bytes = std::fs::read(path)?;
    if let Some(i) = bytes
        .iter()
        .position(|&b| b < 0x20 && !matches!(b, b'\t' | b'\n' | b'\r' | 0x0c))
    {
        return Err(format!(
            "not a text MTL library (control byte 0x{:02x} at offset {i})",
            bytes[i]
        )
        .into());
    }
    let text = String::from_utf8_lossy(&bytes);
    // Every statement belongs to the material a `newmtl` before it starts
    // (random text passed the byte check above and rendered with no word
    // of it). A library of comments alone, as exporters write for a mesh
    // without materials, is fine.
    let first = text.lines().enumerate().find(|(_, l)| {
        let l = l.trim();
        !l.is_empty() && !l.starts_with('#')
    });
    if let Some((n, line)) = first {
        if line.split_whitespace().next() != Some("newmtl") {
            return Err(format!(
                "line {}: not an MTL library: `{}` comes before any `newmtl`",
                n + 1,
                line.trim().chars().take(40).collect::<String>()
            )
            .into());
        }
    }
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let (count, what) = match words.next() {
            Some("Ka" | "Kd" | "Ks" | "Ke") => (3, "three numbers (r g b)"),
            Some("Ns" | "Ni" | "d") => (1, "a number"),
            _ => continue,
        };
        let numbers = words
            .take(count)
            .filter(|w| w.parse::<f32>().is_ok())
            .count();
        if numbers < count {
            let key = line.split_whitespace().next().unwrap_or("");
            return Err(format!(
                "line {}: `{key}` needs {what}, got `{}`",
                n + 1,
                line.trim()
            )
            .into());
        }
    }
    Ok(())
}

/// Checks what tobj's OBJ reader assumes of a file, so that its errors
/// name the line (tobj's say only "face parse error") and so that no index
/// reaches its unchecked arithmetic (a texture index of 0 or past the start
/// overflows there): three numbers after `v` (then nothing, a weight `w`
/// that is not zero, or an RGB colour), two after `vt`, three after `vn`;
/// faces and lines of at least one corner, each `v`, `v/vt`, `v//vn` or
/// `v/vt/vn` with indices that name an existing element (1-based, or
/// negative: counted back from the line; texture and normal indices are
/// ignored, as tobj does, in a file without any).
fn check_obj(text: &str) -> std::result::Result<(), FormatError> {
    // Totals first: a positive index may name an element defined later.
    let mut total = [0usize; 3];
    for line in text.lines() {
        match line.split_whitespace().next() {
            Some("v") => total[0] += 1,
            Some("vt") => total[1] += 1,
            Some("vn") => total[2] += 1,
            _ => {}
        }
    }
    let mut so_far = [0usize; 3];
    // tobj needs a colour on every vertex or on none: the lines of the
    // first vertex with one and the first without.
    let (mut coloured, mut plain) = (None, None);
    const WHAT: [&str; 3] = ["position", "texture coordinate", "normal"];
    for (n, line) in text.lines().enumerate() {
        let at = |message: String| format!("line {}: {message}", n + 1);
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let numbers = |words: std::str::SplitWhitespace, count: usize, what: &str| {
            let given: Vec<&str> = words.take(count).collect();
            if given.len() < count || given.iter().any(|w| w.parse::<f32>().is_err()) {
                Err(at(format!(
                    "`{key}` needs {count} numbers ({what}), got `{}`",
                    line.trim()
                )))
            } else {
                Ok(())
            }
        };
        match key {
            "v" => {
                numbers(words.clone(), 3, "x y z")?;
                let rest: Vec<&str> = words.skip(3).collect();
                if rest.len() == 3 {
                    coloured.get_or_insert(n + 1);
                } else {
                    plain.get_or_insert(n + 1);
                }
                let ok = match rest[..] {
                    [] => true,
                    [w] => w.parse::<f32>().is_ok_and(|w| w != 0.0),
                    [r, g, b] => [r, g, b].iter().all(|c| c.parse::<f32>().is_ok()),
                    _ => false,
                };
                if !ok {
                    return Err(FormatError::Content(at(format!(
                        "`v` takes x y z, then a non-zero weight w or a colour r g b; got `{}`",
                        line.trim()
                    ))));
                }
                so_far[0] += 1;
            }
            "vt" => {
                numbers(words, 2, "u v")?;
                so_far[1] += 1;
            }
            "vn" => {
                numbers(words, 3, "x y z")?;
                so_far[2] += 1;
            }
            "f" | "l" => {
                // Faces of one or two corners are points and lines, which
                // are skipped; a face of none is an error.
                let corners: Vec<&str> = words.collect();
                if corners.is_empty() {
                    return Err(FormatError::Content(at(format!("`{key}` without corners"))));
                }
                for (c, corner) in corners.iter().enumerate() {
                    let parts: Vec<&str> = corner.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(FormatError::Content(at(format!(
                            "corner {} `{corner}` is not v, v/vt, v//vn or v/vt/vn",
                            c + 1
                        ))));
                    }
                    for (k, part) in parts.iter().enumerate() {
                        // Texture and normal indices of a file that has no
                        // texture coordinates (normals) are ignored.
                        if part.is_empty() || (k > 0 && total[k] == 0) {
                            continue;
                        }
                        let fault = match part.parse::<i64>() {
                            Err(_) => Some("is not a whole number".to_string()),
                            Ok(0) => Some("is 0 (indices start at 1)".to_string()),
                            Ok(i) if i > 0 && i as u64 > total[k] as u64 => {
                                Some(format!("is past the file's {} {}s", total[k], WHAT[k]))
                            }
                            Ok(i) if i < 0 && i.unsigned_abs() > so_far[k] as u64 => Some(format!(
                                "counts back past the {} {}s before this line",
                                so_far[k], WHAT[k]
                            )),
                            Ok(_) => None,
                        };
                        if let Some(fault) = fault {
                            return Err(FormatError::Content(at(format!(
                                "corner {} `{corner}`: {} index {part} {fault}",
                                c + 1,
                                WHAT[k]
                            ))));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    if let (Some(c), Some(p)) = (coloured, plain) {
        return Err(format!(
            "line {p}: a vertex without a colour, but line {c} gives one: give r g b on every `v` line or on none"
        ).into());
    }
    Ok(())
}

/// Loads an OBJ file and its MTL libraries. Errors name `scene_file` and
/// `field`, the scene field that referred to the OBJ, and the OBJ or MTL file
/// at fault.
pub fn load_obj(path: &Path, scene_file: &Path, field: &str) -> Result<ObjFile> {
    let fail = |message: String| Error::input(scene_file, field, message);
    crate::input::check_regular_file(path).map_err(|m| {
        fail(format!(
            "{}: OBJ file {m} (paths are relative to the scene file)",
            path.display()
        ))
    })?;
    // Read as text leniently: OBJ files from older tools carry Latin-1
    // comments and names, which tobj's UTF-8 line reader refuses.
    let text = crate::input::read_text_lenient(path)
        .map_err(|e| fail(format!("{}: {e}", path.display())))?;
    check_obj(&text).map_err(|m| fail(format!("{}: {m}", path.display())))?;
    // The OBJ's files (MTL libraries, textures) must lie in its folder
    // (`super::confined`).
    let parent = path.parent().filter(|p| !p.as_os_str().is_empty());
    let base = parent
        .unwrap_or(Path::new("."))
        .canonicalize()
        .map_err(|e| {
            fail(format!(
                "{}: its folder cannot be read: {e}",
                path.display()
            ))
        })?;
    let base = base.as_path();
    // tobj does not say which MTL library is missing: check them first.
    let libraries = check_mtl_libraries(&text, base, path, &fail)?;
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) = tobj::load_obj_buf(
        &mut std::io::Cursor::new(text.as_bytes()),
        &options,
        |lib| {
            // Only the libraries checked above are read.
            let lib = super::confined::confined_path(base, &lib.to_string_lossy(), "an OBJ's")
                .map_err(|_| tobj::LoadError::OpenFileFailed)?;
            let text = crate::input::read_text_lenient(&lib)
                .map_err(|_| tobj::LoadError::OpenFileFailed)?;
            tobj::load_mtl_buf(&mut std::io::Cursor::new(text.as_bytes()))
        },
    )
    .map_err(|e| fail(format!("{}: cannot read OBJ: {e}", path.display())))?;
    let materials = match materials {
        // An OBJ without `mtllib` gives an empty list: its objects get the
        // shape's material.
        Ok(m) => m,
        Err(e) => {
            return Err(fail(format!(
                "{}: cannot read its MTL library: {e}",
                path.display()
            )))
        }
    };
    let mut objects = Vec::with_capacity(models.len());
    for m in models {
        objects.extend(obj_object(m, path, &fail)?);
    }
    // Every MTL entry is checked, used or not: bad input is an error wherever it is.
    let materials = materials
        .into_iter()
        .map(|m| obj_material(m, base, path, &fail))
        .collect::<Result<Vec<_>>>()?;
    Ok(ObjFile {
        objects,
        materials,
        libraries,
    })
}

/// The MTL libraries an OBJ's `mtllib` lines name (relative to `base`),
/// each checked to be a readable file that tobj can parse safely.
fn check_mtl_libraries(
    text: &str,
    base: &Path,
    path: &Path,
    fail: &dyn Fn(String) -> Error,
) -> Result<Vec<PathBuf>> {
    let mut libraries = Vec::new();
    for line in text.lines() {
        if let Some(libs) = line.trim_start().strip_prefix("mtllib ") {
            for lib in libs.split_whitespace() {
                let mtl = super::confined::confined_path(base, lib, "an OBJ's")
                    .map_err(|m| fail(format!("{}: mtllib {lib:?} {m}", path.display())))?;
                // tobj panics on some malformed lines and says only
                // "material parse error" on others: check them first.
                check_mtl(&mtl).map_err(|m| fail(format!("{}: {m}", mtl.display())))?;
                libraries.push(mtl);
            }
        }
    }
    Ok(libraries)
}

/// One object of an OBJ file as read by tobj, checked; `None` if it has
/// no triangles.
fn obj_object(
    m: tobj::Model,
    path: &Path,
    fail: &dyn Fn(String) -> Error,
) -> Result<Option<ObjObject>> {
    let mesh = m.mesh;
    let positions: Vec<Vec3> = mesh
        .positions
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]))
        .collect();
    if positions.iter().any(|p| !p.is_finite()) {
        return Err(fail(format!(
            "{}: object `{}` has a non-finite vertex position",
            path.display(),
            m.name
        )));
    }
    let normals: Vec<Vec3> = mesh
        .normals
        .chunks_exact(3)
        .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero())
        .collect();
    let uvs: Vec<Vec2> = mesh
        .texcoords
        .chunks_exact(2)
        .map(|c| Vec2::new(c[0], c[1]))
        .collect();
    // With single_index, attributes are per vertex; a file that gives
    // them for some faces only is read without them.
    let normals = if normals.len() == positions.len()
        && normals.iter().all(|n| n.is_finite() && *n != Vec3::ZERO)
    {
        normals
    } else {
        Vec::new()
    };
    let uvs = if uvs.len() == positions.len() && uvs.iter().all(|t| t.is_finite()) {
        uvs
    } else {
        Vec::new()
    };
    let triangles: Vec<[u32; 3]> = mesh
        .indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    if let Some(t) = triangles
        .iter()
        .find(|t| t.iter().any(|&i| i as usize >= positions.len()))
    {
        return Err(fail(format!(
            "{}: object `{}`: face {t:?} refers to a missing vertex",
            path.display(),
            m.name
        )));
    }
    if triangles.is_empty() {
        return Ok(None);
    }
    Ok(Some(ObjObject {
        name: m.name,
        positions,
        triangles,
        normals,
        uvs,
        material: mesh.material_id,
    }))
}

/// One MTL material as read by tobj, checked (Kd, Ke, Ks, Ns, Pr, Pm) and
/// with its texture paths relative to `base`.
fn obj_material(
    m: tobj::Material,
    base: &Path,
    path: &Path,
    fail: &dyn Fn(String) -> Error,
) -> Result<ObjMaterial> {
    let diffuse = m.diffuse.map(Vec3::from_array);
    let emission = m.emissive.map(Vec3::from_array);
    if let Some(kd) =
        diffuse.filter(|kd| !kd.is_finite() || kd.min_element() < 0.0 || kd.max_element() > 1.0)
    {
        return Err(fail(format!(
            "{}: MTL material `{}`: Kd must be in [0, 1], got {kd}",
            path.display(),
            m.name
        )));
    }
    if let Some(ke) = emission.filter(|ke| !ke.is_finite() || ke.min_element() < 0.0) {
        return Err(fail(format!(
            "{}: MTL material `{}`: Ke must be finite and not negative, got {ke}",
            path.display(),
            m.name
        )));
    }
    let bad = |key: &str, what: String| {
        fail(format!(
            "{}: MTL material `{}`: {key} {what}",
            path.display(),
            m.name
        ))
    };
    let specular = m.specular.map(Vec3::from_array);
    if let Some(ks) =
        specular.filter(|ks| !ks.is_finite() || ks.min_element() < 0.0 || ks.max_element() > 1.0)
    {
        return Err(bad("Ks", format!("must be in [0, 1], got {ks}")));
    }
    if let Some(ns) = m.shininess.filter(|ns| !ns.is_finite() || *ns < 0.0) {
        return Err(bad(
            "Ns",
            format!("must be finite and not negative, got {ns}"),
        ));
    }
    let unit = |key: &str| -> Result<Option<f32>> {
        match m.unknown_param.get(key) {
            None => Ok(None),
            Some(v) => match v.trim().parse::<f32>() {
                Ok(x) if (0.0..=1.0).contains(&x) => Ok(Some(x)),
                _ => Err(bad(key, format!("must be a number in [0, 1], got `{v}`"))),
            },
        }
    };
    let roughness = unit("Pr")?;
    let metallic = unit("Pm")?;
    // A map's options come first (`map_Kd -s 2 2 1 tex.png`): the file is
    // the last word, inside the OBJ's folder.
    let map = |key: &str, name: Option<&String>| -> Result<Option<PathBuf>> {
        let Some(n) = name else { return Ok(None) };
        let file = n.split_whitespace().last().unwrap_or(n);
        super::confined::confined_path(base, file, "an OBJ's")
            .map(Some)
            .map_err(|e| bad(key, format!("{file:?} {e}")))
    };
    Ok(ObjMaterial {
        name: m.name.clone(),
        diffuse,
        emission,
        specular,
        shininess: m.shininess,
        roughness,
        metallic,
        diffuse_map: map("map_Kd", m.diffuse_texture.as_ref())?,
        roughness_map: map("map_Pr", m.unknown_param.get("map_Pr"))?,
        metallic_map: map("map_Pm", m.unknown_param.get("map_Pm"))?,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sphere's vertex coordinates are Mitsuba's `(φ/2π, θ/π)` of
    /// their position (up to a whole turn in `u` on the seam, any `u` on a
    /// pole) and never wrap round within a triangle.
    #[test]
    fn icosphere_coordinates_are_spherical_and_do_not_wrap() {
        let (p, t, uv) = icosphere_with_uvs(Vec3::new(1.0, 2.0, 3.0), 2.0, 3);
        assert_eq!(t.len(), 20 * 64);
        let mut seam_copies = 0;
        for (q, c) in p.iter().zip(&uv) {
            let d = (*q - Vec3::new(1.0, 2.0, 3.0)) / 2.0;
            assert!(
                ((std::f32::consts::PI * c.y).cos() - d.z).abs() < 1e-5,
                "{c} at {d}"
            );
            if d.x.hypot(d.y) > 1e-6 {
                let phi = crate::scene::uv_map::azimuth_turns(d);
                let off = c.x - phi;
                assert!(off.abs() < 1e-5 || (off - 1.0).abs() < 1e-5, "{c} vs {phi}");
                seam_copies += (off > 0.5) as usize;
            }
        }
        assert!(seam_copies > 0);
        for tri in &t {
            let [a, b, c] = tri.map(|i| uv[i as usize].x);
            assert!(a.max(b).max(c) - a.min(b).min(c) < 0.5, "{a} {b} {c}");
        }
    }

    /// The open unit cylinder: its area `2π` (to the polygon's), outward
    /// normals and faces, `(φ/2π, z)` at its vertices; and Mitsuba's
    /// `coordinate_system`, which puts the cylinder's `u = 0`: axis `+x`
    /// gives `s = −z`, `+y` gives `s = +x`, `−z` gives `s = +x, t = −y`.
    #[test]
    fn cylinder_is_open_outward_and_parameterised_as_mitsubas() {
        let (p, t, n, uv) = cylinder(64);
        let mut area = 0.0;
        for tri in &t {
            let [a, b, c] = tri.map(|i| p[i as usize]);
            let face = (b - a).cross(c - a);
            area += 0.5 * face.length();
            let centre = (a + b + c) / 3.0;
            assert!(
                face.dot(Vec3::new(centre.x, centre.y, 0.0)) > 0.0,
                "inward face"
            );
        }
        let polygon = 128.0 * (std::f32::consts::PI / 64.0).sin();
        assert!((area - polygon).abs() < 1e-4, "{area} vs {polygon}");
        for ((q, n), c) in p.iter().zip(&n).zip(&uv) {
            assert!((*n - Vec3::new(q.x, q.y, 0.0)).length() < 1e-6);
            assert_eq!(c.y, q.z);
            let phi = crate::scene::uv_map::azimuth_turns(*q);
            assert!(
                (c.x - phi).abs() < 1e-6 || (c.x - 1.0).abs() < 1e-6,
                "{c} at {q}"
            );
        }
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-6;
        assert!(close(coordinate_system(Vec3::X).0, -Vec3::Z));
        assert!(close(coordinate_system(Vec3::Y).0, Vec3::X));
        let (s, t) = coordinate_system(-Vec3::Z);
        assert!(close(s, Vec3::X) && close(t, -Vec3::Y), "{s} {t}");
        for axis in [
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(-0.6, 0.0, -0.8),
        ] {
            let (s, t) = coordinate_system(axis);
            assert!(s.dot(t).abs() < 1e-6 && s.dot(axis).abs() < 1e-6 && t.dot(axis).abs() < 1e-6);
            assert!(close(s.cross(t), axis), "right-handed");
        }
    }

    #[test]
    fn disk_and_cube_have_their_area_and_face_outwards() {
        let area = |p: &[Vec3], t: &[[u32; 3]]| -> (f32, Vec<Vec3>) {
            let mut total = 0.0;
            let mut normals = Vec::new();
            for tri in t {
                let [a, b, c] = tri.map(|i| p[i as usize]);
                let n = (b - a).cross(c - a);
                total += 0.5 * n.length();
                normals.push(n.normalize());
            }
            (total, normals)
        };
        let (p, t, uv) = disk(128);
        let (a, n) = area(&p, &t);
        assert!((a - std::f32::consts::PI).abs() < 2e-3, "{a}");
        assert!(n.iter().all(|n| (*n - Vec3::Z).length() < 1e-5));
        assert_eq!(uv.len(), p.len());
        // Polar coordinates: u the radius, v the azimuth (turns), within a
        // triangle no wrap round.
        for (q, c) in p.iter().zip(&uv) {
            assert!((c.x - q.truncate().length()).abs() < 1e-6, "{q} {c}");
        }
        for tri in &t {
            let [a, b, c] = tri.map(|i| uv[i as usize].y);
            assert!(a.max(b).max(c) - a.min(b).min(c) < 1.5 / 128.0);
        }
        let (p, t, uv) = cube();
        let (a, n) = area(&p, &t);
        assert!((a - 24.0).abs() < 1e-4, "{a}");
        for (tri, n) in t.iter().zip(&n) {
            let centre = tri.iter().map(|&i| p[i as usize]).sum::<Vec3>() / 3.0;
            // Outward: the normal is the axis the centroid lies along.
            assert!(n.dot(centre) > 0.3, "{n} at {centre}");
            assert!((n.abs().max_element() - 1.0).abs() < 1e-6);
        }
        assert!(p.iter().all(|q| q.abs().max_element() == 1.0));
        assert!(uv.iter().all(|u| u.x >= 0.0 && u.y <= 1.0));
        // Closed: every edge is shared by exactly two triangles, once each way.
        let mut edges = std::collections::HashMap::new();
        let key = |v: Vec3| v.to_array().map(|x| x as i32);
        for tri in &t {
            for k in 0..3 {
                let (a, b) = (key(p[tri[k] as usize]), key(p[tri[(k + 1) % 3] as usize]));
                *edges.entry((a, b)).or_insert(0) += 1;
            }
        }
        for (&(a, b), &count) in &edges {
            // Diagonals of faces appear inside a face; their reverse too.
            assert_eq!(edges.get(&(b, a)), Some(&count), "{a:?}–{b:?}");
        }
    }

    #[test]
    fn angle_weighted_normals_of_a_cube_and_a_sphere() {
        let (p, t, _) = cube();
        let n = angle_weighted_normals(&p, &t);
        for (q, n) in p.iter().zip(&n) {
            // Every corner: three faces at 90° each.
            assert!((*n - *q / 3f32.sqrt()).length() < 1e-6, "{q}: {n}");
        }
        let (p, t) = icosphere(Vec3::ZERO, 2.0, 3);
        let n = angle_weighted_normals(&p, &t);
        let worst = p
            .iter()
            .zip(&n)
            .map(|(q, n)| q.normalize().angle_between(*n))
            .fold(0.0f32, f32::max);
        assert!(worst < 0.01, "{worst} rad from radial");
    }

    #[test]
    fn icosphere_is_closed_and_outward() {
        let (p, t) = icosphere(Vec3::new(1.0, 2.0, 3.0), 2.0, 2);
        assert_eq!(t.len(), 20 * 16);
        // Closed: every edge is shared by exactly two triangles, in opposite directions.
        let mut edges = HashMap::new();
        for tri in &t {
            for k in 0..3 {
                *edges.entry((tri[k], tri[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        for (&(a, b), &n) in &edges {
            assert_eq!(n, 1);
            assert_eq!(edges.get(&(b, a)), Some(&1));
        }
        for tri in &t {
            let [a, b, c] = tri.map(|i| p[i as usize]);
            let n = (b - a).cross(c - a);
            assert!(n.dot(a - Vec3::new(1.0, 2.0, 3.0)) > 0.0);
        }
    }

    #[test]
    fn mirroring_keeps_normals_on_the_same_side() {
        let (mut p, mut t) = rectangle();
        transform_mesh(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)), &mut p, &mut t);
        let [a, b, c] = t[0].map(|i| p[i as usize]);
        assert!((b - a).cross(c - a).z > 0.0);
    }
}
