//! glTF 2.0 import: a glTF quad placed in a scene renders bit for bit as the
//! equivalent plsr rectangle; node transforms, texture coordinates (v
//! flipped), metallic-roughness channels and factors, cameras and point
//! lights are read as glTF defines them; `.gltf` and `.glb` render alike;
//! bad files are refused naming the file and the fault.

use plsr_testkit as common;

use common::films::assert_close;
use glam::{Vec2, Vec3};
use plsr::film::Film;
use plsr::render::{render, RenderOptions};
use plsr::scene::gltf_scene::{read_gltf, LUMENS_PER_WATT};
use plsr::scene::Scene;
use std::path::Path;

/// The image of the scene file `path`, with the default render options.
pub(super) fn render_file(path: &Path) -> Film {
    let scene = Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0
}

/// The quad `[-1, 1]²` at z = 0 facing +z, as plsr's rectangle makes it:
/// positions, texture coordinates (glTF's, v down) and two triangles.
fn quad_buffer() -> Vec<u8> {
    let p: [[f32; 3]; 4] = [[-1., -1., 0.], [1., -1., 0.], [1., 1., 0.], [-1., 1., 0.]];
    let mut b = Vec::new();
    for v in p {
        for x in v {
            b.extend_from_slice(&x.to_le_bytes());
        }
    }
    for v in p {
        // plsr's rectangle: u = (x+1)/2, v = (y+1)/2; glTF's v runs down.
        let (u, w) = (0.5 * (v[0] + 1.0), 1.0 - 0.5 * (v[1] + 1.0));
        b.extend_from_slice(&u.to_le_bytes());
        b.extend_from_slice(&w.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// The glTF JSON of the quad: `uri` for its buffer (`None` for a GLB's
/// own), a node moving it, a material with a base-colour texture and
/// metallic-roughness texture, a camera and a point light.
fn quad_json(uri: Option<&str>, material: &str) -> String {
    let uri = uri
        .map(|u| format!(", \"uri\": \"{u}\""))
        .unwrap_or_default();
    format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [
    {{"type": "point", "color": [1, 0.5, 0.25], "intensity": 683}},
    {{"type": "directional"}}
  ]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [0, 1, 2, 3]}}],
  "nodes": [
    {{"mesh": 0, "translation": [0, 0.5, -1], "scale": [2, 2, 2], "name": "quad"}},
    {{"camera": 0, "translation": [0, 1, 4]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 0}}}}, "translation": [1, 2, 3]}},
    {{"extensions": {{"KHR_lights_punctual": {{"light": 1}}}}}}
  ],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.7, "aspectRatio": 1.5, "znear": 0.1}}}}],
  "meshes": [{{"name": "quad", "primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
  {material},
  "buffers": [{{"byteLength": 92{uri}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ]
}}"#
    )
}

/// A material with a base-colour texture (`tex.png`) and a normal texture
/// (`nrm.png`, scale 0.6).
const TEXTURED: &str = r#""materials": [{"name": "paint", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0.25, "roughnessFactor": 0.5}, "normalTexture": {"index": 1, "scale": 0.6}}],
  "textures": [{"source": 0}, {"source": 1}], "images": [{"uri": "tex.png"}, {"uri": "nrm.png"}]"#;

/// A material with a metallic-roughness texture (`mr.png`), factors, a
/// normal texture and emission.
const MR: &str = r#""materials": [{"name": "mr", "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1, 1], "metallicRoughnessTexture": {"index": 0}, "metallicFactor": 0.5, "roughnessFactor": 0.75}, "normalTexture": {"index": 0}, "emissiveFactor": [1, 2, 3]}],
  "textures": [{"source": 0}], "images": [{"uri": "mr.png"}]"#;

/// A 2×2 RGB PNG: top row red, green; bottom row blue, white (at 8 bits).
fn write_png(path: &Path, texels: [[u8; 3]; 4]) {
    let img = image::RgbImage::from_fn(2, 2, |x, y| image::Rgb(texels[(y * 2 + x) as usize]));
    img.save(path).unwrap();
}

fn write_quad(dir: &Path, material: &str) {
    std::fs::write(dir.join("quad.bin"), quad_buffer()).unwrap();
    std::fs::write(dir.join("quad.gltf"), quad_json(Some("quad.bin"), material)).unwrap();
    write_png(
        &dir.join("tex.png"),
        [[200, 30, 30], [30, 200, 30], [30, 30, 200], [250, 250, 250]],
    );
    write_png(
        &dir.join("nrm.png"),
        [
            [128, 128, 255],
            [200, 100, 230],
            [60, 180, 220],
            [150, 40, 200],
        ],
    );
    write_png(
        &dir.join("mr.png"),
        [[0, 255, 0], [0, 128, 255], [0, 0, 64], [0, 64, 128]],
    );
}

/// The same quad as a binary glTF (GLB): JSON chunk, then BIN chunk.
fn write_glb(path: &Path, material: &str) {
    let mut json = quad_json(None, material).into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let mut bin = quad_buffer();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut glb = Vec::new();
    glb.extend_from_slice(b"glTF");
    glb.extend_from_slice(&2u32.to_le_bytes());
    glb.extend_from_slice(&(total as u32).to_le_bytes());
    glb.extend_from_slice(&(json.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"JSON");
    glb.extend_from_slice(&json);
    glb.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    glb.extend_from_slice(b"BIN\0");
    glb.extend_from_slice(&bin);
    std::fs::write(path, glb).unwrap();
}

const SCENE_HEAD: &str = r#"
[render]
spp = 4
max_depth = 3

[camera]
position = [0, 1, 4]
look_at = [0, 0.5, 0]
up = [0, 1, 0]
vfov = 40
resolution = [24, 16]

[[lights]]
type = "point"
position = [1, 3, 3]
intensity = [20, 20, 20]
"#;

#[test]
fn a_gltf_quad_renders_as_the_plsr_rectangle() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), TEXTURED);
    // The glTF placed in a scene, moved again by the shape's transform.
    let placed = dir.path().join("placed.toml");
    std::fs::write(
        &placed,
        format!(
            "{SCENE_HEAD}\n[[shapes]]\ntype = \"gltf\"\nfile = \"quad.gltf\"\ntransform.translate = [0, 0, 0.5]\n"
        ),
    )
    .unwrap();
    // Its twin: node (translate 0, 0.5, -1; scale 2), then the shape's.
    let twin = dir.path().join("twin.toml");
    std::fs::write(
        &twin,
        format!(
            "{SCENE_HEAD}\n[[materials]]\nname = \"paint\"\ntype = \"principled\"\n\
             base_color_map = \"tex.png\"\nmetallic = 0.25\nroughness = 0.5\nenergy_conserving = true\n\
             normal_map = \"nrm.png\"\nnormal_scale = 0.6\nnormal_valid_reflection = true\n\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"paint\"\n\
             transform.matrix = [[2, 0, 0, 0], [0, 2, 0, 0.5], [0, 0, 2, -0.5], [0, 0, 0, 1]]\n"
        ),
    )
    .unwrap();
    let a = render_file(&placed);
    let b = render_file(&twin);
    assert!(a.color.iter().any(|c| c.max_element() > 0.0));
    // The glTF's 8-bit images are decoded at each lookup (scale · value +
    // offset), the rectangle's once into floats: equal to rounding.
    for ((name, x), (_, y)) in plsr_testkit::films::layers(&a)
        .into_iter()
        .zip(plsr_testkit::films::layers(&b))
    {
        for (i, (p, q)) in x.iter().zip(&y).enumerate() {
            assert!(
                (p - q).abs() <= 1e-4 * p.abs().max(q.abs()) + 1e-6,
                "glTF quad against the rectangle: layer {name} element {i}: {p} vs {q}"
            );
        }
    }
}

#[test]
fn gltf_contents_are_read_as_gltf_defines_them() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), MR);
    let g = read_gltf(&dir.path().join("quad.gltf")).unwrap();
    assert_eq!(g.objects.len(), 1);
    let o = &g.objects[0];
    // Node: scale 2, then translate (0, 0.5, -1).
    assert_eq!(o.positions[0], Vec3::new(-2.0, -1.5, -1.0));
    assert_eq!(o.positions[2], Vec3::new(2.0, 2.5, -1.0));
    // v flipped: the quad's top-left corner (-1, 1) has glTF uv (0, 0).
    assert_eq!(o.uvs[3], Vec2::new(0.0, 1.0));
    // Metallic in blue, roughness in green, times their factors; the base
    // colour is its factor.
    let m = &g.materials[o.material.unwrap()];
    let (r, mt) = (
        m.textures.roughness.as_ref().unwrap(),
        m.textures.metallic.as_ref().unwrap(),
    );
    // Texel centres: (0.25, 0.75) is the top-left texel.
    let at = |x: f32, y: f32| Vec2::new(x, y);
    assert!((r.eval(at(0.25, 0.75)).x - 0.75).abs() < 1e-6); // G 255 × 0.75
    assert!((mt.eval(at(0.25, 0.75)).x - 0.0).abs() < 1e-6); // B 0
    assert!((r.eval(at(0.75, 0.75)).x - 0.75 * 128.0 / 255.0).abs() < 1e-6);
    assert!((mt.eval(at(0.75, 0.75)).x - 0.5).abs() < 1e-6); // B 255 × 0.5
    assert!((mt.eval(at(0.25, 0.25)).x - 0.5 * 64.0 / 255.0).abs() < 1e-6);
    assert_eq!(m.bsdf.albedo(), Vec3::new(0.5, 0.25, 1.0));
    assert_eq!(g.extras[0].emission, Vec3::new(1.0, 2.0, 3.0));
    // The normal texture, decoded: 2c − 1 (scale 1).
    let n = m.textures.normal.as_ref().unwrap();
    assert_eq!(n.eval(at(0.25, 0.75)), Vec3::new(-1.0, 1.0, -1.0));
    assert!(
        (n.eval(at(0.75, 0.75)) - Vec3::new(-1.0, 2.0 * 128.0 / 255.0 - 1.0, 1.0)).length() < 1e-6
    );
    assert!(
        !g.notes.iter().any(|n| n.contains("normal")),
        "{:?}",
        g.notes
    );
    // The camera looks down its -z with +y up; the point light's 683 cd
    // are 1 W/sr; the directional light is skipped with a note.
    let c = g.cameras[0];
    assert_eq!(c.position, Vec3::new(0.0, 1.0, 4.0));
    assert_eq!(c.forward, -Vec3::Z);
    assert!((c.vfov_deg - 0.7f32.to_degrees()).abs() < 1e-4);
    assert_eq!(c.aspect, Some(1.5));
    let l = g.point_lights[0];
    assert_eq!(l.position, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(
        l.intensity,
        Vec3::new(1.0, 0.5, 0.25) * 683.0 / LUMENS_PER_WATT
    );
    assert!(
        g.notes.iter().any(|n| n.contains("directional")),
        "{:?}",
        g.notes
    );
}

#[test]
fn gltf_and_glb_render_directly_and_alike() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), TEXTURED);
    let glb = dir.path().join("quad.glb");
    // The GLB's image is the same file, referenced by its uri.
    write_glb(&glb, TEXTURED);
    let contents = plsr::scene::file::load_contents(&dir.path().join("quad.gltf")).unwrap();
    // The file's camera, its aspect ratio, its point light.
    let cam = &contents.description.camera;
    assert_eq!((cam.width(), cam.height()), (960, 640));
    assert_eq!(contents.description.point_lights.len(), 1);
    assert!(contents.notes.iter().any(|n| n.contains("directional")));
    let small = |p: &Path| {
        let scene = Scene::load(p).unwrap();
        let job = plsr::render::RenderJob {
            spp: 1,
            ..scene.default_job()
        };
        render(&scene, &job, &RenderOptions::default(), &|_, _| true)
            .unwrap()
            .0
    };
    assert_close(
        ".gltf against .glb",
        &small(&dir.path().join("quad.gltf")),
        &small(&glb),
        0.0,
    );
}

#[test]
fn bad_gltf_files_are_refused_clearly() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), TEXTURED);
    let scene = |file: &str| {
        let p = dir.path().join("s.toml");
        std::fs::write(
            &p,
            format!("{SCENE_HEAD}\n[[shapes]]\ntype = \"gltf\"\nfile = \"{file}\"\n"),
        )
        .unwrap();
        match plsr::scene::file::load(&p) {
            Ok(_) => panic!("{file} accepted"),
            Err(e) => e.to_string(),
        }
    };
    let e = scene("missing.gltf");
    assert!(
        e.contains("shapes[0].file") && e.contains("missing.gltf"),
        "{e}"
    );
    std::fs::write(dir.path().join("junk.gltf"), "{ not json").unwrap();
    let e = scene("junk.gltf");
    assert!(
        e.contains("shapes[0].file") && e.contains("not a readable glTF"),
        "{e}"
    );
    // An index past the vertices.
    let json =
        quad_json(Some("quad.bin"), TEXTURED).replace("\"count\": 6", "\"count\": 6, \"max\": [9]");
    std::fs::write(dir.path().join("short.bin"), &quad_buffer()[..80]).unwrap();
    std::fs::write(
        dir.path().join("short.gltf"),
        json.replace("quad.bin", "short.bin"),
    )
    .unwrap();
    let e = scene("short.gltf");
    assert!(
        e.contains("shapes[0].file") && e.contains("short.gltf"),
        "{e}"
    );
    // A missing texture names the image.
    std::fs::remove_file(dir.path().join("tex.png")).unwrap();
    let e = scene("quad.gltf");
    assert!(
        e.contains("quad.gltf")
            && e.contains("images[0].uri \"tex.png\"")
            && e.contains("not found"),
        "{e}"
    );
    // Directly: the same messages, naming the file.
    let e = plsr::scene::file::load(&dir.path().join("junk.gltf"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("junk.gltf") && e.contains("not a readable glTF"),
        "{e}"
    );
}

/// A glTF reads its own files and nothing else: buffer and image URIs that
/// are absolute, climb out with `..`, use another scheme, link out of the
/// folder or name a FIFO are refused naming the URI, before anything is
/// read; sizes a file states (GLB length, accessor count and range) are
/// checked against the bytes there before anything is allocated; `data:`
/// and percent-encoded URIs are read.
#[test]
fn gltf_files_stay_inside_the_assets_folder() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("asset");
    std::fs::create_dir(&dir).unwrap();
    write_quad(&dir, TEXTURED);
    std::fs::write(root.path().join("outside.bin"), quad_buffer()).unwrap();
    let error_of = |name: &str, json: String| {
        let path = dir.join(name);
        std::fs::write(&path, json).unwrap();
        match read_gltf(&path) {
            Ok(_) => panic!("{name} accepted"),
            Err(e) => e.to_string(),
        }
    };
    let with_buffer = |uri: &str| quad_json(Some(uri), TEXTURED);
    for (uri, fault) in [
        ("../outside.bin", "climbs out with `..`"),
        ("/etc/passwd", "is an absolute path"),
        ("/dev/zero", "is an absolute path"),
        ("file:///etc/passwd", "`file:` URIs are not read"),
        ("http://example.com/quad.bin", "`http:` URIs are not read"),
        ("sub/../../outside.bin", "climbs out with `..`"),
    ] {
        let e = error_of("bad.gltf", with_buffer(uri));
        assert!(
            e.contains(&format!("buffers[0].uri {uri:?}")) && e.contains(fault),
            "{uri}: {e}"
        );
    }
    // A link inside the folder to a file outside it.
    std::os::unix::fs::symlink(root.path().join("outside.bin"), dir.join("link.bin")).unwrap();
    let e = error_of("bad.gltf", with_buffer("link.bin"));
    assert!(e.contains("outside a glTF's folder"), "{e}");
    // A FIFO would block a read: refused unopened.
    let fifo = dir.join("fifo.bin");
    let made = std::process::Command::new("mkfifo").arg(&fifo).status();
    if made.is_ok_and(|s| s.success()) {
        let e = error_of("bad.gltf", with_buffer("fifo.bin"));
        assert!(e.contains("not a regular file"), "{e}");
    }
    // Images follow the same rule.
    let json = quad_json(
        Some("quad.bin"),
        &TEXTURED.replace("\"tex.png\"", "\"../tex.png\""),
    );
    let e = error_of("bad.gltf", json);
    assert!(e.contains("images[0].uri \"../tex.png\""), "{e}");

    // Sizes are checked before anything is allocated from them.
    let json =
        quad_json(Some("quad.bin"), TEXTURED).replace("\"count\": 6", "\"count\": 2147483648");
    let e = error_of("bad.gltf", json);
    assert!(e.contains("accessors[2].count 2147483648"), "{e}");
    let json = quad_json(Some("quad.bin"), TEXTURED).replace("\"count\": 6", "\"count\": 7");
    let e = error_of("bad.gltf", json);
    assert!(e.contains("accessors[2]") && e.contains("run past"), "{e}");
    let json =
        quad_json(Some("quad.bin"), TEXTURED).replace("\"byteLength\": 92", "\"byteLength\": 93");
    let e = error_of("bad.gltf", json);
    assert!(e.contains("buffers[0].byteLength 93"), "{e}");
    write_glb(&dir.join("quad.glb"), TEXTURED);
    let mut glb = std::fs::read(dir.join("quad.glb")).unwrap();
    glb[8..12].copy_from_slice(&0xFFFF_FFF0u32.to_le_bytes());
    std::fs::write(dir.join("huge.glb"), &glb).unwrap();
    let e = read_gltf(&dir.join("huge.glb")).unwrap_err().to_string();
    assert!(e.contains("length 4294967280"), "{e}");

    // What is allowed: a buffer as a data: URI and a percent-encoded name
    // give the same quad as the plain file.
    let plain = read_gltf(&dir.join("quad.gltf")).unwrap();
    let data = format!(
        "data:application/octet-stream;base64,{}",
        base64(&quad_buffer())
    );
    std::fs::write(dir.join("data.gltf"), with_buffer(&data)).unwrap();
    std::fs::write(dir.join("my quad.bin"), quad_buffer()).unwrap();
    std::fs::write(dir.join("spaced.gltf"), with_buffer("my%20quad.bin")).unwrap();
    for name in ["data.gltf", "spaced.gltf"] {
        let other = read_gltf(&dir.join(name)).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(
            other.objects[0].positions, plain.objects[0].positions,
            "{name}"
        );
        assert_eq!(other.objects[0].uvs, plain.objects[0].uvs, "{name}");
    }
    let bad = with_buffer("data:application/octet-stream;base64,AAAA*AAA");
    let e = error_of("bad.gltf", bad);
    assert!(
        e.contains("buffers[0].uri") && e.contains("not base64"),
        "{e}"
    );
}

/// Standard base64 with padding, for writing `data:` URIs.
fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A quad `[-1, 1]²` at z = 0 as glTF, with texture coordinates as plsr's
/// rectangle has them, normals +z when `normals`, tangents `(0, 1, 0, w)`
/// (along world +y) when `w` is given, and a material whose normal texture
/// is `nrm.png`.
fn tangent_quad_json(normals: bool, w: Option<f32>) -> (String, Vec<u8>) {
    let mut b = quad_buffer(); // positions 0..48, uvs 48..80, indices 80..92
    let mut attributes = String::from(r#""POSITION": 0, "TEXCOORD_0": 1"#);
    let mut views = String::new();
    let mut accessors = String::new();
    if normals {
        let at = b.len();
        for _ in 0..4 {
            for x in [0f32, 0.0, 1.0] {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        attributes += r#", "NORMAL": 3"#;
        views += &format!(r#", {{"buffer": 0, "byteOffset": {at}, "byteLength": 48}}"#);
        accessors += r#", {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3"}"#;
    }
    if let Some(w) = w {
        let at = b.len();
        for _ in 0..4 {
            for x in [0f32, 1.0, 0.0, w] {
                b.extend_from_slice(&x.to_le_bytes());
            }
        }
        let view = if normals { 4 } else { 3 };
        attributes += &format!(r#", "TANGENT": {view}"#);
        views += &format!(r#", {{"buffer": 0, "byteOffset": {at}, "byteLength": 64}}"#);
        accessors += &format!(
            r#", {{"bufferView": {view}, "componentType": 5126, "count": 4, "type": "VEC4"}}"#
        );
    }
    let json = format!(
        r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{{attributes}}}, "indices": 2, "material": 0}}]}}],
  "materials": [{{"name": "bumpy", "pbrMetallicRoughness": {{"metallicFactor": 0}}, "normalTexture": {{"index": 0}}}}],
  "textures": [{{"source": 0}}], "images": [{{"uri": "nrm.png"}}],
  "buffers": [{{"byteLength": {len}, "uri": "quad.bin"}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}{views}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-1, -1, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}{accessors}
  ]
}}"#,
        len = b.len()
    );
    (json, b)
}

#[test]
fn gltf_tangents_orient_the_normal_map() {
    // A flat normal texture tilted along its x (red) and y (green). The
    // normal layer, seen from above, shows the frame the map was applied in.
    let dir = tempfile::tempdir().unwrap();
    let rgb = [166u8, 200, 255];
    image::RgbImage::from_pixel(2, 2, image::Rgb(rgb))
        .save(dir.path().join("nrm.png"))
        .unwrap();
    let c = |k: u8| 2.0 * (k as f32 / 255.0) - 1.0;
    let (x, y, z) = (c(rgb[0]), c(rgb[1]), c(rgb[2]));
    let frame = |t: Vec3, b: Vec3| (t * x + b * y + Vec3::Z * z).normalize();
    let normal_at_centre = |normals: bool, w: Option<f32>, transform: &str| {
        let (json, bin) = tangent_quad_json(normals, w);
        std::fs::write(dir.path().join("quad.gltf"), json).unwrap();
        std::fs::write(dir.path().join("quad.bin"), bin).unwrap();
        let scene = dir.path().join("scene.toml");
        std::fs::write(
            &scene,
            format!(
                "[render]\nspp = 1\n[camera]\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\n\
                 up = [0, 1, 0]\nvfov = 53.130102\nresolution = [16, 16]\n\n\
                 [environment]\nradiance = [1, 1, 1]\n\n\
                 [[shapes]]\ntype = \"gltf\"\nfile = \"quad.gltf\"\n{transform}\n"
            ),
        )
        .unwrap();
        let film = render_file(&scene);
        film.normal[film.index(8, 8)]
    };
    let close = |a: Vec3, b: Vec3, what: &str| {
        assert!((a - b).length() < 1e-4, "{what}: normal {a}, expected {b}");
    };
    // Without tangents: the frame of the texture coordinates, u along +x
    // and v along +y.
    close(
        normal_at_centre(true, None, ""),
        frame(Vec3::X, Vec3::Y),
        "no tangents",
    );
    // Tangents along +y: the bitangent is w·(n × t), −x for w = 1 and +x
    // for w = −1.
    close(
        normal_at_centre(true, Some(1.0), ""),
        frame(Vec3::Y, -Vec3::X),
        "w = 1",
    );
    close(
        normal_at_centre(true, Some(-1.0), ""),
        frame(Vec3::Y, Vec3::X),
        "w = -1",
    );
    // A mirroring transform (x → −x) carries the frame with it: the tangent
    // stays +y, the bitangent −x becomes +x.
    close(
        normal_at_centre(true, Some(1.0), "transform = { scale = [-1, 1, 1] }"),
        frame(Vec3::Y, Vec3::X),
        "mirrored",
    );
    // Tangents without normals are ignored, as glTF says.
    close(
        normal_at_centre(false, Some(1.0), ""),
        frame(Vec3::X, Vec3::Y),
        "no normals",
    );
}

/// The quad's glTF with vertex colours `colors` (`COLOR_0`, RGB floats)
/// after its other data.
fn quad_json_with_colors(material: &str) -> String {
    quad_json(Some("quad.bin"), material)
        .replace(r#""TEXCOORD_0": 1}"#, r#""TEXCOORD_0": 1, "COLOR_0": 3}"#)
        .replace(r#""byteLength": 92"#, r#""byteLength": 140"#)
        .replace(
            r#"{"buffer": 0, "byteOffset": 80, "byteLength": 12}"#,
            r#"{"buffer": 0, "byteOffset": 80, "byteLength": 12},
    {"buffer": 0, "byteOffset": 92, "byteLength": 48}"#,
        )
        .replace(
            r#"{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}"#,
            r#"{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
    {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3"}"#,
        )
}

/// A scene of a grey backdrop behind where the glTF quad is placed (or not).
fn backdrop_scene(dir: &Path, name: &str, gltf: Option<&str>) -> std::path::PathBuf {
    let shape = gltf
        .map(|f| format!("\n[[shapes]]\ntype = \"gltf\"\nfile = \"{f}\"\n"))
        .unwrap_or_default();
    let path = dir.join(name);
    std::fs::write(
        &path,
        format!(
            "{SCENE_HEAD}\n[[materials]]\nname = \"grey\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"grey\"\n\
             transform.scale = [8, 8, 1]\ntransform.translate = [0, 0, -3]\n{shape}"
        ),
    )
    .unwrap();
    path
}

#[test]
fn gltf_samplers_and_texture_transforms_look_up_as_gltf_says() {
    // Clamp along s, mirror along t, nearest; offset, rotation and scale.
    let material = r#""materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
      "extensions": {"KHR_texture_transform": {"offset": [0.25, -0.5], "rotation": 0.3, "scale": [1.5, 2.5]}}}}}],
  "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
  "textures": [{"source": 0, "sampler": 0}], "images": [{"uri": "tex.png"}]"#;
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), material);
    let g = read_gltf(&dir.path().join("quad.gltf")).unwrap();
    let tex = g.materials[0].textures.base_color.clone().unwrap();
    let srgb = |c: u8| plsr::texture::srgb_to_linear(c as f32 / 255.0);
    let texels = [[200, 30, 30], [30, 200, 30], [30, 30, 200], [250, 250, 250]]
        .map(|t: [u8; 3]| Vec3::new(srgb(t[0]), srgb(t[1]), srgb(t[2])));
    // glTF's own rule, in its (s, t), t down the image: T·R·S, then the
    // sampler's wrap per axis and the nearest texel.
    let (sin, cos) = 0.3f32.sin_cos();
    let mut checked = 0;
    for i in 0..40 {
        for j in 0..40 {
            let (s, t) = (i as f32 / 39.0, j as f32 / 39.0);
            let (ss, tt) = (1.5 * s, 2.5 * t);
            let s2 = cos * ss + sin * tt + 0.25;
            let t2 = -sin * ss + cos * tt - 0.5;
            let (x, y) = (s2 * 2.0, t2 * 2.0);
            // Nearest lookups jump at texel edges: skip points near one.
            if (x - x.round()).abs() < 1e-3 || (y - y.round()).abs() < 1e-3 {
                continue;
            }
            let col = (x.floor() as i64).clamp(0, 1);
            let m = (y.floor() as i64).rem_euclid(4);
            let row = if m >= 2 { 3 - m } else { m };
            let want = texels[(row * 2 + col) as usize];
            let got = tex.eval(Vec2::new(s, 1.0 - t));
            assert!(
                (got - want).length() < 1e-5,
                "(s, t) = ({s}, {t}): {got} vs {want}"
            );
            checked += 1;
        }
    }
    assert!(checked > 1000);
    // A transform that is not numbers is refused naming its place.
    let bad = material.replace("0.3", "\"a lot\"");
    write_quad(dir.path(), &bad);
    let e = read_gltf(&dir.path().join("quad.gltf"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("materials[0].pbrMetallicRoughness.baseColorTexture.extensions.KHR_texture_transform.rotation"),
        "{e}"
    );
    // Extensions plsr does not read: a note each, or an error where the
    // file requires one.
    let used = |list: &str| {
        quad_json(Some("quad.bin"), material).replace(
            r#""extensionsUsed": ["KHR_lights_punctual"]"#,
            &format!(r#""extensionsUsed": ["KHR_lights_punctual", "KHR_texture_transform", "KHR_materials_anisotropy"]{list}"#),
        )
    };
    std::fs::write(dir.path().join("quad.gltf"), used("")).unwrap();
    let g = read_gltf(&dir.path().join("quad.gltf")).unwrap();
    let anisotropy: Vec<_> = g
        .notes
        .iter()
        .filter(|n| n.contains("KHR_materials_anisotropy"))
        .collect();
    assert_eq!(anisotropy.len(), 1, "{:?}", g.notes);
    assert!(!g.notes.iter().any(|n| n.contains("KHR_texture_transform")));
    std::fs::write(
        dir.path().join("quad.gltf"),
        used(r#", "extensionsRequired": ["KHR_materials_anisotropy"]"#),
    )
    .unwrap();
    let e = read_gltf(&dir.path().join("quad.gltf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("KHR_materials_anisotropy"), "{e}");
}

#[test]
fn gltf_vertex_colours_alpha_and_sides_render_as_gltf_says() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), MR);
    let render_scene = |gltf_json: String, name: &str| {
        std::fs::write(dir.path().join(format!("{name}.gltf")), gltf_json).unwrap();
        render_file(&backdrop_scene(
            dir.path(),
            &format!("{name}.toml"),
            Some(&format!("{name}.gltf")),
        ))
    };
    let empty = render_file(&backdrop_scene(dir.path(), "empty.toml", None));
    let plain = |factor: &str, extra: &str| {
        format!(
            r#""materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": {factor}, "metallicFactor": 0}}{extra}}}]"#
        )
    };

    // COLOR_0 multiplies the base colour factor: (0.8, 0.5, 1)·(0.5, 0.5,
    // 0.25) is the factor (0.4, 0.25, 0.25).
    let mut bin = quad_buffer();
    for _ in 0..4 {
        for x in [0.5f32, 0.5, 0.25] {
            bin.extend_from_slice(&x.to_le_bytes());
        }
    }
    std::fs::write(dir.path().join("quad.bin"), &bin).unwrap();
    let colored = render_scene(
        quad_json_with_colors(&plain("[0.8, 0.5, 1, 1]", "")),
        "colored",
    );
    let g = read_gltf(&dir.path().join("colored.gltf")).unwrap();
    assert_eq!(g.objects[0].colors, vec![Vec3::new(0.5, 0.5, 0.25); 4]);
    let factor = render_scene(
        quad_json(Some("quad.bin"), &plain("[0.4, 0.25, 0.25, 1]", "")),
        "factor",
    );
    assert_close("COLOR_0 against the factor", &colored, &factor, 1e-5);
    assert!(colored.color.iter().zip(&empty.color).any(|(a, b)| a != b));

    // MASK below the cutoff everywhere: the quad is not there; at the
    // cutoff it is. BLEND with alpha 0: not there either.
    let masked = render_scene(
        quad_json(
            Some("quad.bin"),
            &plain(
                "[1, 1, 1, 0.4]",
                r#", "alphaMode": "MASK", "alphaCutoff": 0.5"#,
            ),
        ),
        "masked",
    );
    assert_same_colour("a masked-out quad", &masked, &empty);
    let kept = render_scene(
        quad_json(
            Some("quad.bin"),
            &plain(
                "[1, 1, 1, 0.5]",
                r#", "alphaMode": "MASK", "alphaCutoff": 0.5"#,
            ),
        ),
        "kept",
    );
    assert!(kept.color.iter().zip(&empty.color).any(|(a, b)| a != b));
    let blended = render_scene(
        quad_json(
            Some("quad.bin"),
            &plain("[1, 1, 1, 0]", r#", "alphaMode": "BLEND""#),
        ),
        "blended",
    );
    assert_same_colour("a fully transparent quad", &blended, &empty);
    // At the cutoff the material is opaque; below, a pass-through.
    let g = read_gltf(&dir.path().join("kept.gltf")).unwrap();
    assert!(g.materials[0].composite.is_none());
    let g = read_gltf(&dir.path().join("masked.gltf")).unwrap();
    assert!(g.materials[0].composite.is_some());

    // Seen from behind (the node turns it round), a one-sided quad lets
    // the rays through; a double-sided one does not.
    let turned = |extra: &str, name: &str| {
        let json = quad_json(Some("quad.bin"), &plain("[1, 1, 1, 1]", extra)).replace(
            r#""translation": [0, 0.5, -1], "scale": [2, 2, 2]"#,
            r#""translation": [0, 0.5, -1], "rotation": [0, 1, 0, 0]"#,
        );
        render_scene(json, name)
    };
    // (The camera sees the backdrop through it; light between the quad's
    // front and the backdrop still bounces, so only the first hits agree.)
    let one_sided = turned("", "one_sided");
    assert_eq!(one_sided.object_id, empty.object_id);
    let two_sided = turned(r#", "doubleSided": true"#, "two_sided");
    assert_ne!(two_sided.object_id, empty.object_id);
}

/// The colour of `a` and `b` equal up to rounding (a ray continued through
/// a pass-through starts again at the surface it passed, so the two
/// renders' rays differ in their last bits).
fn assert_same_colour(what: &str, a: &Film, b: &Film) {
    for (i, (p, q)) in a.color.iter().zip(&b.color).enumerate() {
        assert!(
            (*p - *q).abs().max_element() <= 1e-4 * p.max_element().max(q.max_element()),
            "{what}: pixel {i}: {p} vs {q}"
        );
    }
}

/// An emissive quad: black, emitting its factor times `tex.png` (nearest
/// texels), turned round by its node where `turned` (to face −z).
fn emissive_quad_json(turned: bool) -> String {
    let material = r#""materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0},
      "emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}}],
  "samplers": [{"magFilter": 9728}],
  "textures": [{"source": 0, "sampler": 0}], "images": [{"uri": "tex.png"}]"#;
    let json = quad_json(Some("quad.bin"), material);
    match turned {
        true => json.replace(
            r#""translation": [0, 0.5, -1], "scale": [2, 2, 2]"#,
            r#""translation": [0, 0.5, -1], "rotation": [0, 1, 0, 0], "scale": [2, 2, 2]"#,
        ),
        false => json,
    }
}

#[test]
fn gltf_emissive_textures_vary_the_emission() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), MR);
    let srgb = |c: u8| plsr::texture::srgb_to_linear(c as f32 / 255.0);
    let texels = [[200, 30, 30], [30, 200, 30], [30, 30, 200], [250, 250, 250]]
        .map(|t: [u8; 3]| Vec3::new(srgb(t[0]), srgb(t[1]), srgb(t[2])));

    // Seen straight on with nothing else in the scene, each pixel is the
    // radiance of its texel: factor × texture.
    std::fs::write(dir.path().join("seen.gltf"), emissive_quad_json(false)).unwrap();
    let seen = dir.path().join("seen.toml");
    std::fs::write(
        &seen,
        "[render]\nspp = 1\nmax_depth = 2\n\n[camera]\nposition = [0, 0.5, 4]\n\
         look_at = [0, 0.5, -1]\nup = [0, 1, 0]\nvfov = 40\nresolution = [32, 32]\n\n\
         [[shapes]]\ntype = \"gltf\"\nfile = \"seen.gltf\"\n",
    )
    .unwrap();
    let film = render_file(&seen);
    // The quad spans x, y in [-2, 2] about (0, 0.5) at z = -1, 5 m from
    // the camera: ±21.8° of the ±20° view, so it fills the image.
    for (y, x, texel) in [(8, 8, 0), (8, 24, 1), (24, 8, 2), (24, 24, 3)] {
        let c = film.color[y * 32 + x];
        assert!(
            (c - texels[texel]).abs().max_element() < 1e-5,
            "pixel ({x}, {y}): {c} vs texel {texel} {}",
            texels[texel]
        );
    }

    // Lighting a backdrop, the mapped quad gives what four quads of the
    // texels' constant radiance give (its front faces the backdrop; its
    // back, one-sided, lets the camera through).
    // (The file's own point light and camera are left out.)
    let mapped = emissive_quad_json(true).replace(
        r#""scenes": [{"nodes": [0, 1, 2, 3]}]"#,
        r#""scenes": [{"nodes": [0]}]"#,
    );
    std::fs::write(dir.path().join("mapped.gltf"), mapped).unwrap();
    let quadrant = |i: usize| {
        // Texel (col, row) lies at local (x, y) = (±0.5, ±0.5) of the
        // quad, (−2x, 2y + 0.5, −1) in the world after the node.
        let (col, row) = (i % 2, i / 2);
        let (x, y) = (
            if col == 1 { 0.5 } else { -0.5 },
            if row == 0 { 0.5 } else { -0.5 },
        );
        format!(
            r#"{{"mesh": {i}, "translation": [{}, {}, -1], "rotation": [0, 1, 0, 0]}}"#,
            -2.0 * x,
            2.0 * y + 0.5
        )
    };
    let mut twin = quad_json(Some("quad.bin"), MR);
    let nodes: Vec<String> = (0..4).map(quadrant).collect();
    let start = twin.find("\"nodes\": [\n").unwrap();
    let end = start + twin[start..].find("],\n  \"cameras\"").unwrap();
    twin.replace_range(
        start..end,
        &format!("\"nodes\": [\n    {}\n  ", nodes.join(",\n    ")),
    );
    let mesh = |i: usize| {
        format!(
            r#"{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": {i}}}]}}"#
        )
    };
    let meshes: Vec<String> = (0..4).map(mesh).collect();
    let start = twin.find(r#""meshes": ["#).unwrap();
    let end = start + twin[start..].find("]}]").unwrap() + 3;
    twin.replace_range(start..end, &format!("\"meshes\": [{}]", meshes.join(", ")));
    let materials: Vec<String> = texels
        .iter()
        .map(|t| {
            format!(
                r#"{{"pbrMetallicRoughness": {{"baseColorFactor": [0, 0, 0, 1], "metallicFactor": 0}}, "emissiveFactor": [{}, {}, {}]}}"#,
                t.x, t.y, t.z
            )
        })
        .collect();
    let start = twin.find(r#""materials": ["#).unwrap();
    let end = twin.find(r#""buffers""#).unwrap();
    twin.replace_range(
        start..end,
        &format!("\"materials\": [{}],\n  ", materials.join(", ")),
    );
    std::fs::write(dir.path().join("quadrants.gltf"), twin).unwrap();
    let lit = |gltf: &str, name: &str| {
        let path = backdrop_scene(dir.path(), name, Some(gltf));
        let text = std::fs::read_to_string(&path)
            .unwrap()
            .replace("spp = 4", "spp = 256");
        // Only the quad lights the backdrop.
        let text = text.replace("intensity = [20, 20, 20]", "intensity = [0, 0, 0]");
        std::fs::write(&path, text).unwrap();
        render_file(&path)
    };
    let mapped = lit("mapped.gltf", "mapped.toml");
    let quadrants = lit("quadrants.gltf", "quadrants.toml");
    // Mean colour of each half of the image (the red texel lights the
    // left, the green the right): equal within the noise of 256 spp (0.2 % measured).
    let half = |f: &Film, left: bool| {
        let mut sum = Vec3::ZERO;
        for (i, c) in f.color.iter().enumerate() {
            if ((i % f.width as usize) < f.width as usize / 2) == left {
                sum += *c;
            }
        }
        sum
    };
    for left in [true, false] {
        let (a, b) = (half(&mapped, left), half(&quadrants, left));
        assert!(b.min_element() > 0.0, "the backdrop is lit: {b}");
        let rel = ((a - b) / b).abs().max_element();
        assert!(rel < 0.01, "left {left}: mapped {a} vs quadrants {b}");
    }
}

#[test]
fn gltf_normal_maps_on_mirrors_reflect_the_sky_not_black() {
    // A white mirror whose normal texture tilts the normal by up to 55°,
    // seen nearly head-on under a uniform sky of radiance 1: every
    // reflection must leave the surface (the shading normal is bent where
    // it would not), so every pixel, sky or mirror, is about 1. Without
    // the correction the steepest texels reflect into the quad: black.
    let material = r#""materials": [{"pbrMetallicRoughness": {"metallicFactor": 1, "roughnessFactor": 0},
      "normalTexture": {"index": 0}}],
  "textures": [{"source": 0}], "images": [{"uri": "nrm.png"}]"#;
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), material);
    let json = quad_json(Some("quad.bin"), material).replace(
        r#""scenes": [{"nodes": [0, 1, 2, 3]}]"#,
        r#""scenes": [{"nodes": [0]}]"#,
    );
    std::fs::write(dir.path().join("mirror.gltf"), json).unwrap();
    let scene = dir.path().join("mirror.toml");
    let text = SCENE_HEAD.replace("intensity = [20, 20, 20]", "intensity = [0, 0, 0]");
    std::fs::write(
        &scene,
        format!("{text}\n[environment]\nradiance = [1, 1, 1]\n\n[[shapes]]\ntype = \"gltf\"\nfile = \"mirror.gltf\"\n"),
    )
    .unwrap();
    let film = render_file(&scene);
    let darkest = film
        .color
        .iter()
        .map(|c| c.min_element())
        .fold(f32::INFINITY, f32::min);
    assert!(darkest > 0.8, "darkest pixel {darkest}");
}

#[test]
fn an_animated_gltf_is_shown_at_one_time_and_says_so() {
    // Khronos' BoxAnimated (CC BY 4.0, Cesium; tests/data/realworld/gltf):
    // node 0 rises along y by linear keys at t = 0 … 3.7 s and carries the
    // inner box (mesh 0); the outer box (mesh 1) stands still.
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/realworld/gltf/BoxAnimated.glb");
    let at = |t: f32| plsr::scene::gltf_scene::read_gltf_at(&path, t).unwrap();
    let (start, later) = (at(0.0), at(1.0));
    let animation: Vec<_> = start
        .notes
        .iter()
        .filter(|n| n.contains("animation"))
        .collect();
    assert_eq!(animation.len(), 1, "{:?}", start.notes);
    assert!(animation[0].contains("t = 0 s"), "{}", animation[0]);
    assert!(!start
        .notes
        .iter()
        .any(|n| n.contains("skins") || n.contains("morph")));
    let mut rose = None;
    for (a, b) in start.objects.iter().zip(&later.objects) {
        let shift = b.positions[0] - a.positions[0];
        for (p, q) in a.positions.iter().zip(&b.positions) {
            assert!(
                (*q - *p - shift).length() < 1e-4,
                "{}: not a translation",
                a.name
            );
        }
        assert!(
            shift.x.abs() < 1e-6 && shift.z.abs() < 1e-6,
            "{}: {shift}",
            a.name
        );
        if shift.y.abs() > 1e-3 {
            assert!(rose.is_none(), "two objects moved");
            rose = Some(shift.y);
        }
    }
    // One box rose between t = 0 and t = 1 s, by the linear keys' share.
    let rose = rose.expect("nothing moved");
    assert!(rose > 0.1, "rose by {rose}");
    // Before the first key and after the last, the keys' values hold.
    let (before, after, much_after) = (at(-5.0), at(3.8), at(100.0));
    assert_eq!(before.objects[0].positions, start.objects[0].positions);
    assert_eq!(after.objects[0].positions, much_after.objects[0].positions);
}

#[test]
fn each_texture_reads_the_uv_set_it_names() {
    // Khronos' MultiUVTest (CC BY 4.0, Hilo3d; tests/data/realworld/gltf):
    // the base colour reads TEXCOORD_0, spanning [0, 0.75] × [0, 1]; the
    // emissive texture reads TEXCOORD_1, within [0, 0.25]² (glTF's v runs
    // down, plsr's up: v in [0.75, 1]).
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/realworld/gltf/MultiUVTest.glb");
    let g = read_gltf(&path).unwrap();
    assert!(
        !g.notes.iter().any(|n| n.contains("TEXCOORD")),
        "{:?}",
        g.notes
    );
    let o = &g.objects[0];
    assert_eq!(o.emission_uvs.len(), o.positions.len());
    assert_eq!(o.uvs.len(), o.positions.len());
    let inside = |uv: &Vec2| (0.0..=0.25).contains(&uv.x) && (0.75..=1.0).contains(&uv.y);
    assert!(o.emission_uvs.iter().all(inside), "{:?}", o.emission_uvs);
    assert!(o.uvs.iter().any(|uv| uv.x > 0.5), "{:?}", o.uvs);
    // The emissive texture is decoded (its logo is bright).
    let e = g.extras[o.material.unwrap()].emission_map.as_ref().unwrap();
    assert!(e.max_value() > 0.5);
}

#[test]
fn a_gltf_rendered_on_its_own_is_shown_at_the_time_asked() {
    // `plsr render BoxAnimated.glb --anim-time 1`: the inner box has risen.
    use plsr::scene::file::load_contents_with;
    use plsr::scene::mitsuba::Options;
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/realworld/gltf/BoxAnimated.glb");
    let at = |time: Option<f32>| {
        let options = Options {
            defines: Vec::new(),
            time,
        };
        let c = load_contents_with(&path, &options).unwrap();
        c.description
            .meshes
            .iter()
            .flat_map(|m| m.positions.iter().map(|p| p.y))
            .fold(f32::MIN, f32::max)
    };
    let (start, later) = (at(None), at(Some(1.0)));
    assert_eq!(start, at(Some(0.0)));
    assert!(
        later > start + 0.1,
        "top at t = 0: {start}, at t = 1 s: {later}"
    );
    // Not a finite time, or a scene that is not a glTF file: refused.
    let e = load_contents_with(
        &path,
        &Options {
            defines: Vec::new(),
            time: Some(f32::NAN),
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--anim-time") && e.contains("finite"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let toml = dir.path().join("scene.toml");
    std::fs::write(&toml, "[camera]\nposition = [0, 0, 5]\n").unwrap();
    let e = load_contents_with(
        &toml,
        &Options {
            defines: Vec::new(),
            time: Some(1.0),
        },
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("--anim-time 1") && e.contains("time = 1"), "{e}");
}

#[test]
fn material_extensions_map_onto_the_principled_models() {
    // plsr's own model (CC0, scripts/make_material_extensions_test.py):
    // six spheres, each with one KHR_materials_* extension.
    use plsr::bsdf::Bsdf;
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/realworld/gltf/MaterialExtensionSpheres.glb");
    let g = read_gltf(&path).unwrap();
    assert!(
        !g.notes.iter().any(|n| n.contains("not supported")),
        "{:?}",
        g.notes
    );
    let kinds: Vec<&str> = g
        .materials
        .iter()
        .map(|m| match m.bsdf {
            Bsdf::Principled(_) => "principled",
            Bsdf::PrincipledThin(_) => "thin",
            Bsdf::PrincipledFull(_) => "full",
            Bsdf::Dielectric(_) => "dielectric",
            _ => "other",
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "principled",
            "thin",
            "dielectric",
            "full",
            "full",
            "principled"
        ]
    );
    // ior 1.33 and specularFactor 0.5: f₀ = 0.5·(0.33/2.33)², `specular`
    // = f₀/0.08; the plain sphere keeps glTF's 1.5 (0.5).
    let Bsdf::Principled(p) = g.materials[0].bsdf else {
        unreachable!()
    };
    assert!((p.specular - 0.5 * (0.33f32 / 2.33).powi(2) / 0.08).abs() < 1e-5);
    assert!(matches!(g.materials[5].bsdf, Bsdf::Principled(p) if p.specular == 0.5));
    // Glass is never culled (light leaves through its back faces), though
    // the file leaves `doubleSided` false; the opaque spheres are.
    let sides: Vec<bool> = g.extras.iter().map(|e| e.double_sided).collect();
    assert_eq!(sides, [false, true, true, false, false, false]);
}

#[test]
fn a_node_scaling_a_mesh_beyond_the_coordinate_limit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    write_quad(dir.path(), TEXTURED);
    let json = std::fs::read_to_string(dir.path().join("quad.gltf")).unwrap();
    let json = json.replace("\"scale\": [2, 2, 2]", "\"scale\": [2e12, 2, 2]");
    std::fs::write(dir.path().join("quad.gltf"), json).unwrap();
    let e = read_gltf(&dir.path().join("quad.gltf"))
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("meshes[0].primitives[0] (node 0): vertex 0") && e.contains("±1e12"),
        "{e}"
    );
    // As a scene: the file is named, and nothing of plsr's own is blamed.
    let e = Scene::load(&dir.path().join("quad.gltf"))
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("quad.gltf") && e.contains("meshes[0]"), "{e}");
}
