//! Textures, MTL materials and shading normals, end to end through scene
//! and OBJ files:
//! - a textured OBJ shows its texture the right way up and round;
//! - MTL keys map to the documented models;
//! - interpolated vertex normals shade, and do not let light leak through.

use glam::Vec3;
use plsr::bsdf::Bsdf;
use plsr::film::Film;
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;
use std::path::Path;

/// Writes a 4×4 RGB PNG whose quadrants are red (top left), green (top
/// right), blue (bottom left) and white (bottom right).
fn write_quadrant_png(path: &Path) {
    let mut img = image::RgbImage::new(4, 4);
    for (x, y, p) in img.enumerate_pixels_mut() {
        *p = match (x < 2, y < 2) {
            (true, true) => image::Rgb([255, 0, 0]),
            (false, true) => image::Rgb([0, 255, 0]),
            (true, false) => image::Rgb([0, 0, 255]),
            (false, false) => image::Rgb([255, 255, 255]),
        };
    }
    img.save(path).unwrap();
}

/// A unit quad [−1, 1]² in the z = 0 plane facing +z, with OBJ texture
/// coordinates (0, 0) at (−1, −1), and optional vertex normals.
fn quad_obj(mtl: Option<&str>, normal: Option<Vec3>) -> String {
    let mut s = String::new();
    if mtl.is_some() {
        s += "mtllib quad.mtl\nusemtl m\n";
    }
    s += "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n";
    match normal {
        Some(n) => {
            s += &format!("vn {} {} {}\n", n.x, n.y, n.z);
            s += "f 1/1/1 2/2/1 3/3/1\nf 1/1/1 3/3/1 4/4/1\n";
        }
        None => s += "f 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    }
    s
}

/// A camera 2 m above the quad looking down, image up along +y, that the
/// quad exactly fills (tan(vfov/2) = 1/2).
const TOP_CAMERA: &str = r#"
[camera]
position = [0, 0, 2]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 53.130102
resolution = [16, 16]
"#;

fn render_in(dir: &Path, scene: &str) -> Film {
    try_render_in(dir, scene).unwrap_or_else(|e| panic!("{e}"))
}

/// Writes `scene` as `scene.toml` in `dir` and renders it, or returns the
/// loader's error.
fn try_render_in(dir: &Path, scene: &str) -> Result<Film, String> {
    let path = dir.join("scene.toml");
    std::fs::write(&path, scene).unwrap();
    let scene = Scene::load(&path).map_err(|e| e.to_string())?;
    Ok(render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0)
}

fn assert_quadrants(film: &Film, what: &str) {
    // Quadrant interiors: each samples only texels of its own colour.
    for ((x, y), want) in [
        ((4, 4), Vec3::X),
        ((11, 4), Vec3::Y),
        ((4, 11), Vec3::Z),
        ((11, 11), Vec3::ONE),
    ] {
        let got = film.albedo[film.index(x, y)];
        assert!(
            (got - want).abs().max_element() < 1e-5,
            "{what}: pixel ({x}, {y}) has albedo {got}, the texture says {want}"
        );
    }
}

#[test]
fn textured_obj_shows_its_texture_the_right_way_round() {
    let dir = tempfile::tempdir().unwrap();
    write_quadrant_png(&dir.path().join("pattern.png"));
    std::fs::write(
        dir.path().join("quad.obj"),
        quad_obj(Some("quad.mtl"), None),
    )
    .unwrap();
    std::fs::write(
        dir.path().join("quad.mtl"),
        "newmtl m\nKd 1 1 1\nmap_Kd pattern.png\n",
    )
    .unwrap();
    let scene = format!(
        "[render]\nspp = 4\n{TOP_CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\n\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = [1, 1, 1]\n"
    );
    assert_quadrants(&render_in(dir.path(), &scene), "OBJ with map_Kd");

    // The same texture through a scene-file material on the built-in
    // rectangle, whose (u, v) also start at its (−1, −1) corner.
    let scene = format!(
        "[render]\nspp = 4\n{TOP_CAMERA}\n[[materials]]\nname = \"t\"\ntype = \"principled\"\n\
         base_color_map = \"pattern.png\"\n\n[[shapes]]\ntype = \"rectangle\"\nmaterial = \"t\"\n\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = [1, 1, 1]\n"
    );
    assert_quadrants(
        &render_in(dir.path(), &scene),
        "rectangle with base_color_map",
    );
}

/// Loads the quad OBJ with MTL text `mtl` from `dir` (which holds any
/// textures it names) and returns its material `m`.
fn mtl_quad_material(dir: &Path, mtl: &str) -> plsr::Result<plsr::scene::Material> {
    std::fs::write(dir.join("quad.obj"), quad_obj(Some("quad.mtl"), None)).unwrap();
    std::fs::write(dir.join("quad.mtl"), mtl).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(
        &path,
        format!(
            "[render]\nspp = 1\n{TOP_CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\n"
        ),
    )
    .unwrap();
    let scene = Scene::load(&path)?;
    Ok(scene
        .materials()
        .iter()
        .find(|m| m.name.ends_with(":m"))
        .unwrap()
        .clone())
}

/// The BSDF of MTL text `mtl`, in a fresh folder.
fn mtl_material(mtl: &str) -> plsr::Result<Bsdf> {
    let dir = tempfile::tempdir().unwrap();
    Ok(mtl_quad_material(dir.path(), mtl)?.bsdf)
}

#[test]
fn mtl_keys_map_to_the_documented_models() {
    let Bsdf::Diffuse(d) = mtl_material("newmtl m\nKd 0.2 0.3 0.4\n").unwrap() else {
        panic!("Kd alone is diffuse")
    };
    assert_eq!(d.reflectance, Vec3::new(0.2, 0.3, 0.4));

    let Bsdf::BlinnPhong(b) =
        mtl_material("newmtl m\nKd 0.8 0.8 0.8\nKs 0.5 0.5 0.5\nNs 100\n").unwrap()
    else {
        panic!("Ks makes Blinn-Phong")
    };
    // Kd + Ks = 1.3 is scaled to 1, keeping the ratio.
    assert!((b.diffuse.x - 0.8 / 1.3).abs() < 1e-6 && (b.specular.x - 0.5 / 1.3).abs() < 1e-6);
    assert_eq!(b.exponent, 100.0);

    let Bsdf::Principled(p) = mtl_material("newmtl m\nKd 0.9 0.5 0.1\nPr 0.25\nPm 1\n").unwrap()
    else {
        panic!("Pr/Pm make principled")
    };
    assert_eq!(
        (p.base_color, p.roughness, p.metallic),
        (Vec3::new(0.9, 0.5, 0.1), 0.25, 1.0)
    );

    let e = mtl_material("newmtl m\nPr 1.5\n").unwrap_err().to_string();
    assert!(
        e.contains("Pr") && e.contains("[0, 1]") && e.contains("quad.obj"),
        "{e}"
    );
    let e = mtl_material("newmtl m\nmap_Kd missing.png\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing.png") && e.contains("not found") && e.contains("scene.toml"),
        "{e}"
    );
}

#[test]
fn mtl_roughness_map_varies_the_material() {
    let dir = tempfile::tempdir().unwrap();
    // Left half smooth (0), right half rough (255), read linearly.
    let mut img = image::GrayImage::new(2, 1);
    img.put_pixel(1, 0, image::Luma([255]));
    img.save(dir.path().join("rough.png")).unwrap();
    let m = mtl_quad_material(
        dir.path(),
        "newmtl m\nKd 0.5 0.5 0.5\nPm 1\nmap_Pr rough.png\n",
    )
    .unwrap();
    let r = |u: f32| match m.bsdf_at(glam::Vec2::new(u, 0.5), glam::Vec3::ONE) {
        Bsdf::Principled(p) => p.roughness,
        other => panic!("{other:?}"),
    };
    assert_eq!((r(0.25), r(0.75)), (0.0, 1.0));
}

#[test]
fn vertex_normals_shade_and_reach_the_normal_layer() {
    let dir = tempfile::tempdir().unwrap();
    let tilted = Vec3::new(0.3, 0.0, 1.0).normalize();
    std::fs::write(dir.path().join("quad.obj"), quad_obj(None, Some(tilted))).unwrap();
    let scene = format!(
        "[render]\nspp = 4\n{TOP_CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\n\n\
         [[lights]]\ntype = \"point\"\nposition = [0, 0, 3]\nintensity = [1, 1, 1]\n"
    );
    let film = render_in(dir.path(), &scene);
    let n = film.normal[film.index(8, 8)];
    assert!(
        (n - tilted).length() < 1e-4,
        "normal layer {n}, vertex normal {tilted}"
    );
    // Lambert with the shading normal: the centre gets ρ/π · I cos θs / r².
    let want = 0.8 / std::f32::consts::PI * tilted.z / 9.0;
    let got = film.color[film.index(8, 8)].x;
    assert!(
        (got - want).abs() < 0.02 * want,
        "radiance {got}, expected {want}"
    );
}

#[test]
fn bent_normals_do_not_leak_light_through_a_surface() {
    // A floor whose shading normals lean far over (78° from its geometric
    // normal), over a large emitter facing up from below. Seen from above
    // the floor must stay black: light from below may not leak through,
    // neither by light sampling nor by BSDF sampling.
    let dir = tempfile::tempdir().unwrap();
    let bent = Vec3::new(1.0, 0.0, 0.2).normalize();
    std::fs::write(dir.path().join("quad.obj"), quad_obj(None, Some(bent))).unwrap();
    let scene = format!(
        "[render]\nspp = 16\nmax_depth = 4\n{TOP_CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\n\
         transform = {{ scale = 3 }}\n\n\
         [[shapes]]\ntype = \"rectangle\"\nemission = [5, 5, 5]\n\
         transform = {{ scale = 10, translate = [0, 0, -1] }}\n"
    );
    let film = render_in(dir.path(), &scene);
    let max = film
        .color
        .iter()
        .fold(0.0f32, |m, c| m.max(c.max_element()));
    assert_eq!(max, 0.0, "light leaked through the floor");
}

/// `smooth_normals = true` on an OBJ without `vn`: angle-weighted vertex
/// normals shade a faceted sphere with (nearly) the round sphere's normals.
#[test]
fn smooth_normals_are_generated_for_objs_without_them() {
    let dir = tempfile::tempdir().unwrap();
    let (p, t) = plsr::scene::shapes::icosphere(Vec3::ZERO, 1.0, 2);
    let mut obj = String::new();
    for q in &p {
        obj += &format!("v {} {} {}\n", q.x, q.y, q.z);
    }
    for tri in &t {
        obj += &format!("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1);
    }
    std::fs::write(dir.path().join("ball.obj"), obj).unwrap();
    let mean_error = |smooth: bool| -> f32 {
        let scene_path = dir.path().join("scene.toml");
        std::fs::write(
            &scene_path,
            format!(
                "[render]\nspp = 4\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\n\
                 vfov = 30\nresolution = [40, 40]\n[[shapes]]\ntype = \"obj\"\nfile = \"ball.obj\"\n\
                 smooth_normals = {smooth}\n"
            ),
        )
        .unwrap();
        let scene = Scene::load(&scene_path).unwrap();
        let (film, _) = render(
            &scene,
            &scene.default_job(),
            &RenderOptions::default(),
            &|_, _| true,
        )
        .unwrap();
        // The round sphere's normal where each pixel centre's ray meets it.
        let (mut sum, mut n) = (0.0, 0);
        for y in 0..40 {
            for x in 0..40 {
                let ray = scene
                    .camera()
                    .generate_ray(
                        glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                        glam::Vec2::ZERO,
                    )
                    .unwrap();
                let (o, d) = (ray.org, ray.dir.normalize());
                let b = o.dot(d);
                // Near the rim the faceted and round spheres differ: only
                // rays that also meet a sphere of radius 0.9.
                if b * b - (o.length_squared() - 0.81) <= 0.0 {
                    continue;
                }
                let disc = b * b - (o.length_squared() - 1.0);
                let hit = o + (-b - disc.sqrt()) * d;
                let normal = film.normal[film.index(x, y)];
                sum += hit.normalize().angle_between(normal.normalize());
                n += 1;
            }
        }
        assert!(n > 300);
        sum / n as f32
    };
    let (flat, smooth) = (mean_error(false), mean_error(true));
    assert!(smooth < 0.4 * flat, "smooth {smooth} rad, flat {flat} rad");
}

/// A PLY mesh renders exactly as the same triangles from an OBJ, in both
/// encodings; a broken one is refused naming the shape's `file` and the fault.
#[test]
fn ply_meshes_render_as_the_same_obj() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (p, t) = plsr::scene::shapes::icosphere(Vec3::new(0.0, 0.0, 0.0), 1.0, 1);
    let mut obj = String::new();
    let mut ascii = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {}\nproperty list uchar uint vertex_indices\nend_header\n",
        p.len(),
        t.len()
    );
    let mut binary = ascii
        .replace("format ascii", "format binary_little_endian")
        .into_bytes();
    for q in &p {
        obj += &format!("v {} {} {}\n", q.x, q.y, q.z);
        ascii += &format!("{} {} {}\n", q.x, q.y, q.z);
        for x in q.to_array() {
            binary.extend(x.to_le_bytes());
        }
    }
    for tri in &t {
        obj += &format!("f {} {} {}\n", tri[0] + 1, tri[1] + 1, tri[2] + 1);
        ascii += &format!("3 {} {} {}\n", tri[0], tri[1], tri[2]);
        binary.push(3);
        for i in tri {
            binary.extend(i.to_le_bytes());
        }
    }
    std::fs::write(d.join("ball.obj"), obj).unwrap();
    std::fs::write(d.join("ascii.ply"), ascii).unwrap();
    std::fs::write(d.join("binary.ply"), &binary).unwrap();
    std::fs::write(d.join("broken.ply"), &binary[..binary.len() - 5]).unwrap();
    let render_with = |kind: &str, file: &str| {
        try_render_in(
            d,
            &format!(
                "[render]\nspp = 2\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\n\
                 up = [0, 1, 0]\nvfov = 30\nresolution = [24, 24]\n[[shapes]]\ntype = \"{kind}\"\n\
                 file = \"{file}\"\n[[lights]]\ntype = \"point\"\nposition = [2, 2, 3]\n\
                 intensity = [20, 20, 20]\n"
            ),
        )
    };
    let reference = render_with("obj", "ball.obj").unwrap();
    assert!(reference.color.iter().any(|c| c.x > 0.0));
    for file in ["ascii.ply", "binary.ply"] {
        let film = render_with("ply", file).unwrap();
        assert!(film.bitwise_eq(&reference), "{file}");
    }
    let e = render_with("ply", "broken.ply").unwrap_err();
    assert!(
        e.contains("shapes[0].file") && e.contains("broken.ply") && e.contains("truncated"),
        "{e}"
    );
}

/// Writes a 2×2 PNG of one colour (8-bit levels).
fn write_flat_png(path: &Path, rgb: [u8; 3]) {
    image::RgbImage::from_pixel(2, 2, image::Rgb(rgb))
        .save(path)
        .unwrap();
}

/// A normal map's 8-bit texel decoded as plsr decodes it (2c − 1, x and y
/// times `scale`), in the quad's frame: u along +x, v along +y, the normal
/// along +z.
fn decoded(rgb: [u8; 3], scale: f32) -> Vec3 {
    let c = |k: u8| 2.0 * (k as f32 / 255.0) - 1.0;
    Vec3::new(scale * c(rgb[0]), scale * c(rgb[1]), c(rgb[2])).normalize()
}

/// The untextured quad (OBJ with texture coordinates, no normals) with a
/// diffuse material of reflectance 0.8 and the normal map `rgb`, lit by a
/// point light of intensity 1 at `light`, seen from above.
fn normal_mapped_quad(dir: &Path, rgb: [u8; 3], extra: &str, light: Vec3) -> String {
    write_flat_png(&dir.join("normals.png"), rgb);
    std::fs::write(dir.join("quad.obj"), quad_obj(None, None)).unwrap();
    format!(
        "[render]\nspp = 4\n{TOP_CAMERA}\n\
         [[materials]]\nname = \"bumpy\"\ntype = \"diffuse\"\nreflectance = [0.8, 0.8, 0.8]\n\
         normal_map = \"normals.png\"\n{extra}\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\nmaterial = \"bumpy\"\n\n\
         [[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = [1, 1, 1]\n",
        light.x, light.y, light.z
    )
}

#[test]
fn normal_maps_tilt_the_shading_normal_in_the_tangent_frame() {
    let dir = tempfile::tempdir().unwrap();
    // Tilted along +u (red): the normal layer holds the decoded direction,
    // and Lambert under a light straight above gives ρ/π · I cos θs / r².
    let red = [166, 128, 255];
    let film = render_in(
        dir.path(),
        &normal_mapped_quad(dir.path(), red, "", Vec3::new(0.0, 0.0, 3.0)),
    );
    let n = film.normal[film.index(8, 8)];
    let want_n = decoded(red, 1.0);
    assert!(
        (n - want_n).length() < 1e-4,
        "normal layer {n}, map {want_n}"
    );
    let want = 0.8 / std::f32::consts::PI * want_n.z / 9.0;
    let got = film.color[film.index(8, 8)].x;
    assert!(
        (got - want).abs() < 0.02 * want,
        "radiance {got}, expected {want}"
    );

    // Green tilts along +v (+y here, glTF's and OpenGL's "up"): towards a
    // light off to +y the quad's centre brightens, away from it darkens, each
    // as cos θ between the tilted normal and the light says; normal_scale
    // scales the tilt.
    let light = Vec3::new(0.0, 2.0, 3.0);
    // Pixel (8, 8)'s centre on the quad (image x is +x, rows go −y).
    let to_light = light - Vec3::new(0.0625, -0.0625, 0.0);
    let l = to_light.normalize();
    for (rgb, scale) in [
        ([128, 220, 255], 1.0),
        ([128, 36, 255], 1.0),
        ([128, 220, 255], 0.5),
    ] {
        let extra = format!("normal_scale = {scale}");
        let film = render_in(
            dir.path(),
            &normal_mapped_quad(dir.path(), rgb, &extra, light),
        );
        let n = decoded(rgb, scale);
        let want = 0.8 / std::f32::consts::PI * n.dot(l) / to_light.length_squared();
        let got = film.color[film.index(8, 8)].x;
        assert!(
            (got - want).abs() < 0.02 * want,
            "{rgb:?} × {scale}: radiance {got}, expected {want} (normal {n})"
        );
    }
    let flat = 0.8 / std::f32::consts::PI * l.z / to_light.length_squared();
    assert!(decoded([128, 220, 255], 1.0).dot(l) > 1.05 * l.z);
    assert!(decoded([128, 36, 255], 1.0).dot(l) < 0.9 * l.z);

    // Scale 0: exactly the flat quad.
    let film = render_in(
        dir.path(),
        &normal_mapped_quad(dir.path(), [200, 30, 180], "normal_scale = 0", light),
    );
    let got = film.color[film.index(8, 8)].x;
    assert!((got - flat).abs() < 0.02 * flat, "{got} vs {flat}");
    assert!((film.normal[film.index(8, 8)] - Vec3::Z).length() < 1e-6);
}

#[test]
fn a_constant_normal_map_equals_the_same_vertex_normal() {
    // A normal map of one tilted normal on a flat quad is the quad with that
    // vertex normal: the same image, to rounding.
    let dir = tempfile::tempdir().unwrap();
    let rgb = [90, 170, 230];
    let light = Vec3::new(0.5, -0.5, 3.0);
    let mapped = render_in(dir.path(), &normal_mapped_quad(dir.path(), rgb, "", light));
    std::fs::write(
        dir.path().join("quad.obj"),
        quad_obj(None, Some(decoded(rgb, 1.0))),
    )
    .unwrap();
    let scene = format!(
        "[render]\nspp = 4\n{TOP_CAMERA}\n\
         [[materials]]\nname = \"plain\"\ntype = \"diffuse\"\nreflectance = [0.8, 0.8, 0.8]\n\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\nmaterial = \"plain\"\n\n\
         [[lights]]\ntype = \"point\"\nposition = [{}, {}, {}]\nintensity = [1, 1, 1]\n",
        light.x, light.y, light.z
    );
    let vertex = render_in(dir.path(), &scene);
    for (a, b) in mapped.color.iter().zip(&vertex.color) {
        assert!(
            (*a - *b).abs().max_element() <= 1e-5 * b.max_element().max(1e-3),
            "{a} vs {b}"
        );
    }
    let lit = vertex.color.iter().filter(|c| c.x > 0.0).count();
    assert!(lit > 200, "{lit} lit pixels");
}

#[test]
fn bad_normal_map_keys_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let base = normal_mapped_quad(dir.path(), [128, 128, 255], "", Vec3::new(0.0, 0.0, 3.0));
    for (from, to, wanted) in [
        (
            "normal_map = \"normals.png\"\n",
            "normal_scale = 2\n",
            "materials[0].normal_scale: only used with a normal_map",
        ),
        (
            "normal_map = \"normals.png\"\n",
            "normal_map = \"normals.png\"\nnormal_scale = 11\n",
            "materials[0].normal_scale: must be in [0, 10], got 11",
        ),
        (
            "normal_map = \"normals.png\"\n",
            "normal_map = \"missing.png\"\n",
            "materials[0].normal_map",
        ),
    ] {
        let text = base.replace(from, to);
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, &text).unwrap();
        let err = match Scene::load(&path) {
            Ok(_) => panic!("{to:?} was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains(wanted) && err.contains("bad.toml"), "{err}");
    }
}

/// A rectangle facing +z (or −z, `flip`) between the camera at +z and a
/// point light beside the camera, with `two_sided` as given: the pixel at
/// the image's centre.
fn centre_of_a_lit_panel(two_sided: bool, flip: bool) -> Vec3 {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("panel.toml");
    std::fs::write(
        &path,
        format!(
            r#"
[render]
spp = 4
max_depth = 2

[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 30
resolution = [9, 9]

[[materials]]
name = "panel"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
two_sided = {two_sided}

[[shapes]]
type = "rectangle"
flip_normals = {flip}
material = "panel"

[[lights]]
type = "point"
position = [0.5, 0.5, 3]
intensity = [9, 9, 9]
"#
        ),
    )
    .unwrap();
    let scene = Scene::load(&path).unwrap();
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    film.color[4 * 9 + 4]
}

#[test]
fn a_one_sided_surface_is_black_from_behind() {
    let front = centre_of_a_lit_panel(false, false);
    assert!(front.min_element() > 0.1, "lit from the front: {front}");
    // Two-sided (the default), its back is lit just as its front.
    assert_eq!(centre_of_a_lit_panel(true, true), front);
    // One-sided and turned round: black, exactly.
    assert_eq!(centre_of_a_lit_panel(false, true), Vec3::ZERO);
}

#[test]
fn a_dielectric_cannot_be_one_sided() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("glass.toml");
    std::fs::write(
        &path,
        "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nresolution = [4, 4]\nvfov = 30\n\n[[materials]]\nname = \"g\"\n\
         type = \"dielectric\"\ntwo_sided = false\n\n[[shapes]]\ntype = \"sphere\"\nmaterial = \"g\"\n",
    )
    .unwrap();
    let e = match Scene::load(&path) {
        Ok(_) => panic!("a one-sided dielectric was accepted"),
        Err(e) => e.to_string(),
    };
    assert!(
        e.contains("materials[0].two_sided") && e.contains("opaque"),
        "{e}"
    );
}

/// A PLY square (±1 in x and y, facing +z) of two triangles, with linear
/// vertex colours `(0.5 + 0.4x, 0.5, 0.5 − 0.4x)` (linear in x, so
/// interpolation over either triangle gives exactly that) and one float
/// colour per face.
const COLOURED_SQUARE: &str = "ply\nformat ascii 1.0\nelement vertex 4\n\
    property float x\nproperty float y\nproperty float z\n\
    property float r\nproperty float g\nproperty float b\n\
    element face 2\nproperty list uchar int vertex_indices\n\
    property float color_0\nproperty float color_1\nproperty float color_2\nend_header\n\
    -1 -1 0 0.1 0.5 0.9\n1 -1 0 0.9 0.5 0.1\n1 1 0 0.9 0.5 0.1\n-1 1 0 0.1 0.5 0.9\n\
    3 0 1 2 0.8 0.2 0.1\n3 0 2 3 0.1 0.3 0.7\n";

fn coloured_square(dir: &Path, material: &str, file: &str) -> Result<Film, String> {
    std::fs::write(dir.join("square.ply"), COLOURED_SQUARE).unwrap();
    std::fs::write(
        dir.join("square.obj"),
        "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nf 1 2 3\n",
    )
    .unwrap();
    try_render_in(
        dir,
        &format!(
            "[render]\nspp = 4\nmax_depth = 1\n[camera]\nposition = [0, 0, 4]\nlook_at = [0, 0, 0]\n\
             up = [0, 1, 0]\nvfov = 20\nresolution = [16, 16]\n[environment]\nradiance = [1, 1, 1]\n\
             [[materials]]\nname = \"m\"\n{material}\n\
             [[shapes]]\ntype = \"{}\"\nfile = \"{file}\"\nmaterial = \"m\"\n",
            if file.ends_with(".ply") { "ply" } else { "obj" }
        ),
    )
}

#[test]
fn mesh_colours_give_the_base_colour() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Vertex colours: red + blue = 1 everywhere, green 0.5, red rising
    // from left to right across the square (it fills the frame).
    let film = coloured_square(
        d,
        "type = \"diffuse\"\nbase_color_map = { attribute = \"vertex_color\" }",
        "square.ply",
    )
    .unwrap();
    let reds: Vec<f32> = (0..16).map(|x| film.albedo[film.index(x, 8)].x).collect();
    for a in &film.albedo {
        assert!(
            (a.x + a.z - 1.0).abs() < 1e-5 && (a.y - 0.5).abs() < 1e-5,
            "{a}"
        );
    }
    assert!(reds.windows(2).all(|w| w[1] > w[0]), "{reds:?}");
    assert!(reds[0] < 0.25 && reds[15] > 0.75, "{reds:?}");
    // The colour replaces the constant: a principled material's too.
    let principled = coloured_square(
        d,
        "type = \"principled\"\nbase_color = [0.2, 0.2, 0.2]\nbase_color_map = { attribute = \"vertex_color\" }",
        "square.ply",
    )
    .unwrap();
    assert_eq!(principled.albedo, film.albedo);
    // Face colours: one per triangle, split along the diagonal y = x.
    let film = coloured_square(
        d,
        "type = \"diffuse\"\nbase_color_map = { attribute = \"face_color\" }",
        "square.ply",
    )
    .unwrap();
    let below = film.albedo[film.index(12, 12)];
    let above = film.albedo[film.index(3, 3)];
    assert_eq!(
        (below, above),
        (Vec3::new(0.8, 0.2, 0.1), Vec3::new(0.1, 0.3, 0.7))
    );
}

#[test]
fn missing_or_misplaced_mesh_colours_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (material, file, says) in [
        (
            "type = \"diffuse\"\nbase_color_map = { attribute = \"vertex_normal_color\" }",
            "square.ply",
            "shapes[0].material: material `m` takes its base colour from the mesh's `vertex_normal_color`, but its file has vertex_color, face_color",
        ),
        (
            "type = \"diffuse\"\nbase_color_map = { attribute = \"vertex_color\" }",
            "square.obj",
            "shapes[0].material: obj shapes carry none (PLY and serialized files do)",
        ),
        (
            "type = \"principled\"\nroughness_map = { attribute = \"vertex_color\" }",
            "square.ply",
            "materials[0].roughness_map: attribute `vertex_color`: only base_color_map",
        ),
        (
            "type = \"diffuse\"\nbase_color_map = { attribute = \"colour\" }",
            "square.ply",
            "named vertex_… or face_…",
        ),
        (
            "type = \"diffuse\"\nbase_color_map = { attribute = \"vertex_color\", wrap = \"clamp\" }",
            "square.ply",
            "an `attribute` map takes no filter",
        ),
    ] {
        let e = coloured_square(d, material, file).unwrap_err();
        let (field, fault) = says.split_once(": ").unwrap_or(("", says));
        assert!(e.contains(field) && e.contains(fault), "{material}: {e}");
    }
}

#[test]
fn an_objs_libraries_and_textures_stay_in_its_folder() {
    // Inside a folder of its own, next to a file it must not read.
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("asset");
    std::fs::create_dir(&dir).unwrap();
    image::RgbImage::new(2, 2)
        .save(root.path().join("secret.png"))
        .unwrap();
    for (map, fault) in [
        ("../secret.png", "climbs out"),
        ("/etc/hostname", "absolute path"),
        ("C:\\textures\\wood.png", "absolute path"),
    ] {
        let e = mtl_quad_material(&dir, &format!("newmtl m\nmap_Kd {map}\n"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("map_Kd") && e.contains(fault) && e.contains("quad.obj"),
            "{map}: {e}"
        );
    }
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(root.path().join("secret.png"), dir.join("link.png")).unwrap();
        let e = mtl_quad_material(&dir, "newmtl m\nmap_Kd link.png\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("outside an OBJ's folder"), "{e}");
    }
    // The MTL library itself: `mtllib ../x.mtl` is refused naming it.
    std::fs::write(root.path().join("x.mtl"), "newmtl m\nKd 1 0 0\n").unwrap();
    std::fs::write(
        dir.join("quad.obj"),
        "mtllib ../x.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("scene.toml"),
        format!(
            "[render]\nspp = 1\n{TOP_CAMERA}\n[[shapes]]\ntype = \"obj\"\nfile = \"quad.obj\"\n"
        ),
    )
    .unwrap();
    let Err(e) = Scene::load(&dir.join("scene.toml")) else {
        panic!("`mtllib ../x.mtl` was read")
    };
    let e = e.to_string();
    assert!(
        e.contains("mtllib \"../x.mtl\"") && e.contains("climbs out"),
        "{e}"
    );
}
