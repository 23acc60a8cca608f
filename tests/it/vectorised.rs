//! The vectorised kernel (plain Lambert scenes lit by point lights) renders
//! exactly the image of the general integrator: every layer, bit for bit,
//! for every instruction set this CPU has, and it takes only the scenes it
//! can render.

use plsr::film::Film;
use plsr::integrator::Isa;
use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::{file::load, Scene};
use std::path::Path;

/// A scene and what to render of it.
pub(crate) struct Case {
    pub(crate) scene: Scene,
    pub(crate) job: RenderJob,
}

impl Case {
    fn new(scene: Scene) -> Case {
        let job = scene.default_job();
        Case { scene, job }
    }
}

fn embree_demo(size: u32, spp: u32) -> Case {
    let mut desc = load(Path::new("assets/scenes/cornell/embree-demo.toml")).unwrap();
    desc.camera = desc.camera.with_resolution(size, size).unwrap();
    desc.job.spp = spp;
    Case::new(Scene::build(desc).unwrap())
}

/// Loads a scene written to a temporary file; `OBJ` in `text` stands for
/// the absolute path of Embree's Cornell box.
pub(crate) fn scene_from(name: &str, text: &str) -> Case {
    let obj =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/scenes/cornell/embree_cornell_box.obj");
    // The scene is built once loaded: its file may go with the folder.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{name}.toml"));
    std::fs::write(
        &path,
        text.replace("OBJ", &obj.display().to_string().replace('\\', "/")),
    )
    .unwrap();
    Case::new(Scene::load(&path).unwrap())
}

/// A box of coloured Lambert walls and a floating panel, lit by three point
/// lights of different colours, seen through a thin lens with the Gaussian
/// filter at an odd resolution (partial tiles and partial SIMD chunks).
fn three_lights() -> Case {
    scene_from(
        "three-lights",
        r#"
[render]
spp = 3
max_depth = 6
seed = 11

[camera]
type = "thin_lens"
position = [278, 273, -800]
look_at = [278, 273, 0]
up = [0, 1, 0]
vfov = 37
aperture_radius = 8
resolution = [37, 29]

[film]
filter = "gaussian"
exposure_ev = 1

[[materials]]
name = "teal"
type = "diffuse"
reflectance = [0.1, 0.6, 0.5]

[[materials]]
name = "white"
type = "diffuse"
reflectance = [0.9, 0.9, 0.9]

[[shapes]]
type = "obj"
file = "OBJ"
material = "teal"

[[shapes]]
type = "rectangle"
material = "white"
transform = { scale = 60, translate = [278, 200, 200] }

[[lights]]
type = "point"
position = [213, 300, 227]
intensity = [100000, 50000, 20000]

[[lights]]
type = "point"
position = [400, 100, 100]
intensity = [5000, 20000, 40000]

[[lights]]
type = "point"
position = [100, 500, 300]
intensity = [30000, 30000, 30000]
"#,
    )
}

/// A dual-fisheye camera inside the box: the corners of the image have no
/// rays, so lanes and pixels no longer correspond one to one.
fn fisheye() -> Case {
    scene_from(
        "fisheye",
        r#"
[render]
spp = 2
max_depth = 8

[camera]
type = "dual_fisheye"
position = [278, 273, 250]
look_at = [278, 273, 500]
up = [0, 1, 0]
resolution = [40, 20]

[[shapes]]
type = "obj"
file = "OBJ"

[[lights]]
type = "point"
position = [213, 300, 227]
intensity = [100000, 100000, 100000]
"#,
    )
}

fn render_with(case: &Case, kernel: Option<Isa>, threads: usize, tile_size: u32) -> Film {
    let o = RenderOptions {
        threads: Some(threads),
        tile_size,
        vectorised: kernel.is_some(),
        isa: kernel,
    };
    let (film, stats) = render(&case.scene, &case.job, &o, &|_, _| true).unwrap();
    assert_eq!(stats.vectorised, kernel, "kernel choice");
    film
}

/// Every layer of a film as bit patterns, with the layer's name.
fn layers(f: &Film) -> Vec<(&'static str, Vec<u32>)> {
    let v3 = |v: &[glam::Vec3]| -> Vec<u32> {
        v.iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_bits)
            .collect()
    };
    let v1 = |v: &[f32]| -> Vec<u32> { v.iter().map(|x| x.to_bits()).collect() };
    vec![
        ("color", v3(&f.color)),
        ("variance", v3(&f.variance)),
        ("normal", v3(&f.normal)),
        ("albedo", v3(&f.albedo)),
        ("alpha", v1(&f.alpha)),
        ("depth", v1(&f.depth)),
        ("object_id", v1(&f.object_id)),
    ]
}

fn assert_same(what: &str, general: &Film, fast: &Film) {
    for ((name, a), (_, b)) in layers(general).into_iter().zip(layers(fast)) {
        if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
            panic!(
                "{what}: layer {name} differs at element {i}: general {} vectorised {} \
                 ({} of {} elements differ)",
                f32::from_bits(a[i]),
                f32::from_bits(b[i]),
                (0..a.len()).filter(|&i| a[i] != b[i]).count(),
                a.len()
            );
        }
    }
}

/// The instruction sets this CPU can run.
pub(crate) fn isas() -> Vec<Isa> {
    [Isa::Baseline, Isa::Avx2, Isa::Avx512]
        .into_iter()
        .filter(|i| i.is_available())
        .collect()
}

fn assert_identical(what: &str, scene: &Case) {
    let general = render_with(scene, None, 1, 16);
    // The image must not be trivially black, or the comparison proves little.
    assert!(
        general.color.iter().any(|c| c.max_element() > 0.0),
        "{what} is lit"
    );
    for isa in isas() {
        let fast = render_with(scene, Some(isa), 2, 16);
        assert_same(&format!("{what}, {}", isa.name()), &general, &fast);
    }
    let odd_tiles = render_with(scene, Some(Isa::best()), 2, 7);
    assert_same(&format!("{what}, 7-pixel tiles"), &general, &odd_tiles);
}

#[test]
fn embree_demo_is_bit_identical() {
    assert_identical("Embree's demo", &embree_demo(48, 4));
}

#[test]
fn every_path_length_is_bit_identical() {
    // 1: direct light only; 2–3: before Russian roulette starts; 4: after.
    for max_depth in [1, 2, 3, 4] {
        let mut scene = embree_demo(24, 2);
        scene.job.max_depth = max_depth;
        assert_identical(&format!("max_depth {max_depth}"), &scene);
    }
}

/// The roulette's depth (`rr_depth`) is the job's: each depth gives its own
/// image, the same on both kernels (7, above `max_depth`, turns the
/// roulette off).
#[test]
fn every_roulette_depth_is_bit_identical() {
    let mut images = Vec::new();
    // Coloured walls (throughput below 1, so the roulette spins), max_depth 6.
    for rr_depth in [1, 2, 4, 7] {
        let mut scene = three_lights();
        scene.job.rr_depth = rr_depth;
        assert_identical(&format!("rr_depth {rr_depth}"), &scene);
        images.push(render_with(&scene, None, 1, 16));
    }
    for (i, a) in images.iter().enumerate() {
        for b in &images[i + 1..] {
            assert!(!a.bitwise_eq(b), "rr_depth changes the image ({i})");
        }
    }
}

#[test]
fn several_lights_thin_lens_and_gaussian_filter_are_bit_identical() {
    assert_identical("three lights", &three_lights());
}

#[test]
fn cameras_with_pixels_without_rays_are_bit_identical() {
    let scene = fisheye();
    let film = render_with(&scene, None, 1, 16);
    assert!(film.alpha.contains(&0.0), "the corners have no rays");
    assert_identical("dual fisheye", &scene);
}

#[test]
fn sample_ranges_are_bit_identical() {
    // A render of samples [5, 8) (as a piece of a split render).
    let scene = embree_demo(24, 3);
    let job = RenderJob {
        sample_start: 5,
        ..scene.job
    };
    let run = |vectorised| {
        let o = RenderOptions {
            threads: Some(2),
            vectorised,
            ..Default::default()
        };
        render(&scene.scene, &job, &o, &|_, _| true).unwrap().0
    };
    let (general, fast) = (run(false), run(true));
    assert_same("samples 5..8", &general, &fast);
    assert!(general.bitwise_eq(&fast));
}

#[test]
fn vectorised_kernel_counts_the_same_rays() {
    assert_same_ray_counts(&embree_demo(32, 2));
}

/// Asserts that both integrators trace as many camera, bounce and shadow
/// rays for `case`.
fn assert_same_ray_counts(case: &Case) {
    let run = |vectorised| {
        let o = RenderOptions {
            threads: Some(1),
            vectorised,
            ..Default::default()
        };
        render(&case.scene, &case.job, &o, &|_, _| true)
            .unwrap()
            .1
            .rays
    };
    let (a, b) = (run(false), run(true));
    assert_eq!(
        (a.camera, a.bounce, a.shadow),
        (b.camera, b.bounce, b.shadow)
    );
}

#[test]
fn area_lights_are_bit_identical() {
    // The Cornell box lit by its emissive quad: emission found by BSDF
    // sampling, MIS against light sampling, the ray after the last light
    // sample.
    let mut desc = load(Path::new("tests/data/cornell-64.toml")).unwrap();
    desc.camera = desc.camera.with_resolution(40, 40).unwrap();
    desc.job.spp = 3;
    let mut cornell = Case::new(Scene::build(desc).unwrap());
    assert_identical("Cornell box", &cornell);
    for max_depth in [0, 1, 2, 4] {
        cornell.job.max_depth = max_depth;
        cornell.job.spp = 1;
        assert_identical(&format!("Cornell box, max_depth {max_depth}"), &cornell);
    }
}

#[test]
fn point_and_area_lights_together_are_bit_identical() {
    // A two-sided emissive panel beside three point lights: per-lane picks
    // of both kinds.
    let scene = scene_from(
        "mixed-lights",
        r#"
[render]
spp = 2
max_depth = 5

[camera]
position = [278, 273, -800]
look_at = [278, 273, 0]
up = [0, 1, 0]
vfov = 37
resolution = [33, 33]

[[shapes]]
type = "obj"
file = "OBJ"

[[shapes]]
type = "rectangle"
emission = [20, 15, 10]
two_sided = true
transform = { scale = 40, rotate = { axis = [0, 1, 0], angle = 30 }, translate = [350, 300, 300] }

[[lights]]
type = "point"
position = [213, 300, 227]
intensity = [100000, 50000, 20000]

[[lights]]
type = "point"
position = [400, 100, 100]
intensity = [5000, 20000, 40000]
"#,
    );
    assert_identical("point and area lights", &scene);
}

/// Two parametric lights under the Cornell box's ceiling (Y up, units as
/// the box): a narrow spot with a hard cone and a wide lamp with a soft
/// edge, both aimed down at the floor, so that much of the box is out of
/// their reach.
const CORNELL_PLS: &str = r#"
brightness = "intensity"

[[lights]]
name = "spot"
n = [0.3, -1, 0.2]
a = 14
c = [1, 0.9, 0.7]
b = 40000
circle = { center = [200, 540, 250], radius = 12, axis = [1, 0, 0] }

[[lights]]
name = "lamp"
n = [-0.2, -1, 0]
a = 35
penumbra = 20
c = [0.6, 0.7, 1]
b = 30000
e1 = [330, 540, 330]
e2 = [330, 540, 400]
alpha1 = 0.3
alpha2 = 0.7
d = [20, 25, 25, 20]
"#;

#[test]
fn parametric_lights_are_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let pls = dir.path().join("cornell-pls.toml");
    std::fs::write(&pls, CORNELL_PLS).unwrap();
    let pls = pls.display().to_string().replace('\\', "/");
    let base = |extra: &str| {
        format!(
            "[render]\nspp = 3\nmax_depth = 5\nseed = 4\n\n             [camera]\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n             vfov = 37\nresolution = [37, 29]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n             [[pls]]\nfile = \"{pls}\"\nnf = 12\n\n{extra}"
        )
    };
    // Alone: where neither cone reaches, no light is picked at all (the
    // lane draws no numbers for a light sample, as the general integrator).
    let alone = scene_from("pls-alone", &base(""));
    assert!(!alone.scene.lights().is_spatially_uniform());
    assert_identical("parametric lights alone", &alone);
    // With a point light and an area light picked everywhere beside them.
    let mixed = scene_from(
        "pls-mixed",
        &base(
            "[[lights]]\ntype = \"point\"\nposition = [100, 300, 100]\nintensity = [20000, 20000, 20000]\n\n             [[shapes]]\ntype = \"rectangle\"\nemission = [3, 3, 3]\n             transform = { scale = 30, rotate = { axis = [1, 0, 0], angle = 90 }, translate = [450, 500, 200] }\n",
        ),
    );
    assert_identical("parametric, point and area lights", &mixed);
}

#[test]
fn environments_are_bit_identical() {
    // A 64×32 panorama of random colours with one bright patch (its
    // importance sampling then matters), lighting the Cornell box through
    // its open side; rays that leave the box see it, MIS-weighted.
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (64u32, 32u32);
    let mut sky = plsr::film::Film::new(w, h);
    let mut rng = plsr::rng::Rng::new(21, 3);
    for (i, c) in sky.color.iter_mut().enumerate() {
        let bright = (i as u32 % w).abs_diff(40) < 3 && (i as u32 / w).abs_diff(12) < 2;
        let scale = if bright { 400.0 } else { 2.0 };
        *c = glam::Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * scale;
    }
    sky.spp = 1;
    let sky_path = dir.path().join("sky.exr");
    sky.write_exr(&sky_path).unwrap();
    let sky_path = sky_path.display().to_string().replace('\\', "/");
    let base = |extra: &str| {
        format!(
            "[render]\nspp = 3\nmax_depth = 5\nseed = 6\n\n\
             [camera]\nposition = [278, 273, -500]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
             vfov = 60\nresolution = [31, 27]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n{extra}"
        )
    };
    // The panorama alone: the one light, the same in every lane.
    let map =
        format!("[environment]\nfile = \"{sky_path}\"\nup = [0, 1, 0]\nforward = [0, 0, -1]\n");
    let alone = scene_from("env-map", &base(&map));
    assert_identical("environment map alone", &alone);
    // With a point light: picked per lane beside it.
    let mixed = scene_from(
        "env-map-point",
        &base(&format!(
            "{map}\n[[lights]]\ntype = \"point\"\nposition = [278, 500, 250]\nintensity = [90000, 90000, 90000]\n"
        )),
    );
    assert_identical("environment map and a point light", &mixed);
    // A constant sky with an area light.
    let sky = scene_from(
        "constant-sky",
        &base(
            "[environment]\nradiance = [0.4, 0.5, 0.7]\n\n[[shapes]]\ntype = \"rectangle\"\nemission = [3, 3, 3]\n\
             transform = { scale = 30, rotate = { axis = [1, 0, 0], angle = 90 }, translate = [450, 500, 200] }\n",
        ),
    );
    assert_identical("constant sky and an area light", &sky);
}

/// A `size`×`size` PNG of random colours (`Rng::new(seed, stream)`) in
/// `dir`.
fn random_texture(dir: &Path, size: u32, seed: u64, stream: u64) -> std::path::PathBuf {
    let path = dir.join("texture.png");
    let mut rng = plsr::rng::Rng::new(seed, stream);
    image::RgbImage::from_fn(size, size, |_, _| {
        image::Rgb([0, 0, 0].map(|_: u8| (rng.next_f32() * 255.0) as u8))
    })
    .save(&path)
    .unwrap();
    path
}

#[test]
fn textured_lambert_is_bit_identical() {
    // A panel with an 8×8 texture of random colours in the Cornell box, lit
    // by a point light and the box's walls; its texels show in the image,
    // in the light it reflects and in the albedo layer.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 8, 2, 9);
    let texture = texture.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "textured",
        &format!(
            "[render]\nspp = 3\nmax_depth = 4\nseed = 2\n\n\
             [camera]\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
             vfov = 37\nresolution = [35, 31]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n\
             [[materials]]\nname = \"t\"\ntype = \"diffuse\"\nbase_color_map = \"{texture}\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"t\"\n\
             transform = {{ scale = 150, rotate = {{ axis = [0, 1, 0], angle = 20 }}, translate = [278, 250, 300] }}\n\n\
             [[lights]]\ntype = \"point\"\nposition = [278, 400, 50]\nintensity = [90000, 90000, 90000]\n"
        ),
    );
    assert_identical("textured Lambert", &scene);
}

/// An OBJ latitude–longitude sphere (12 × 8 quads as triangles) with
/// vertex normals and texture coordinates.
fn smooth_sphere_obj(center: [f32; 3], radius: f32) -> String {
    let (nu, nv) = (12, 8);
    let mut obj = String::new();
    for j in 0..=nv {
        for i in 0..=nu {
            let (u, v) = (i as f32 / nu as f32, j as f32 / nv as f32);
            let (phi, theta) = (u * std::f32::consts::TAU, v * std::f32::consts::PI);
            let n = [
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ];
            obj += &format!(
                "v {} {} {}\nvt {u} {v}\nvn {} {} {}\n",
                center[0] + radius * n[0],
                center[1] + radius * n[1],
                center[2] + radius * n[2],
                n[0],
                n[1],
                n[2]
            );
        }
    }
    let at = |i: usize, j: usize| j * (nu + 1) + i + 1;
    for j in 0..nv {
        for i in 0..nu {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            // No degenerate triangles at the poles.
            if j > 0 {
                obj += &format!("f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\n");
            }
            if j + 1 < nv {
                obj += &format!("f {a}/{a}/{a} {c}/{c}/{c} {d}/{d}/{d}\n");
            }
        }
    }
    obj
}

/// The `[[shapes]]` entry of sphere `i` of a row of material samples (four
/// to a row), radius `radius`, in material `name`: every other one a smooth
/// OBJ sphere (vertex normals, written into `dir`), the rest faceted.
fn material_sphere(dir: &Path, i: usize, name: &str, radius: f32) -> String {
    let (x, y, z) = (
        110.0 + 110.0 * (i % 4) as f32,
        90.0 + 150.0 * (i / 4) as f32,
        150.0 + 60.0 * (i % 2) as f32,
    );
    if i.is_multiple_of(2) {
        let sphere = dir.join(format!("{name}.obj"));
        std::fs::write(&sphere, smooth_sphere_obj([x, y, z], radius)).unwrap();
        let sphere = sphere.display().to_string().replace('\\', "/");
        format!("[[shapes]]\ntype = \"obj\"\nfile = \"{sphere}\"\nmaterial = \"{name}\"\n\n")
    } else {
        format!(
            "[[shapes]]\ntype = \"sphere\"\ncenter = [{x}, {y}, {z}]\nradius = {radius}\n\
             subdivisions = 2\nmaterial = \"{name}\"\n\n"
        )
    }
}

#[test]
fn every_material_kind_is_bit_identical() {
    // Every scattering model beside Lambert walls, each kind's lanes in
    // chunks shared with the others':
    // Blinn–Phong, an isotropic and a roughness-mapped GGX metal (on a
    // panel with texture coordinates; the map makes its anisotropic α
    // isotropic), a smooth glass sphere (no light sample; refraction
    // raises η², which the roulette of the Lambert lanes behind it then
    // uses), a rough glass sphere, and the principled BSDF in both modes,
    // one textured, and normal-mapped Lambert and metal; smooth spheres
    // (vertex normals), lit by an environment
    // map through the open side, an area light and a point light; roulette
    // from depth 2 so that it spins on glass-filtered paths.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 4, 9, 2);
    let texture = texture.display().to_string().replace('\\', "/");
    let panel = dir.path().join("panel.obj");
    let mut obj = String::new();
    for (x, y) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        obj += &format!(
            "v {} {} 420\nvt {} {}\nvn {} {} -1\n",
            278.0 + 90.0 * x,
            300.0 + 90.0 * y,
            (x + 1.0) / 2.0,
            (y * 0.7 + 1.0) / 2.0,
            0.8 * x,
            0.5 * y
        );
    }
    obj += "f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n";
    std::fs::write(&panel, obj).unwrap();
    let panel = panel.display().to_string().replace('\\', "/");
    let materials = [
        ("phong", "type = \"blinn_phong\"\ndiffuse = [0.4, 0.3, 0.2]\nspecular = [0.3, 0.3, 0.3]\nexponent = 40"),
        ("gold", "type = \"cook_torrance\"\nmetal = \"Au\"\nroughness = 0.2"),
        ("brushed", &format!(
            "type = \"cook_torrance\"\nalpha_u = 0.05\nalpha_v = 0.4\nfresnel = \"schlick\"\n\
             f0 = [0.9, 0.8, 0.6]\nroughness_map = \"{texture}\""
        )),
        ("glass", "type = \"dielectric\"\nior = 1.5"),
        ("frosted", "type = \"dielectric\"\nior = 1.33\nroughness = 0.3"),
        ("plastic", "type = \"principled\"\nbase_color = [0.2, 0.5, 0.8]\nroughness = 0.4\nanisotropic = 0.5"),
        ("painted", &format!(
            "type = \"principled\"\nbase_color_map = \"{texture}\"\nmetallic = 0.3\n\
             roughness = 0.3\nenergy_conserving = true"
        )),
        // Normal maps: on a Lambert material (a vectorised lane with a
        // shading normal from the map) and on a metal.
        ("bumpy", &format!(
            "type = \"diffuse\"\nreflectance = [0.7, 0.6, 0.5]\nnormal_map = \"{texture}\"\n\
             normal_scale = 0.8"
        )),
        ("bumpy_gold", &format!(
            "type = \"cook_torrance\"\nmetal = \"Au\"\nroughness = 0.3\nnormal_map = \"{texture}\""
        )),
        // A bump map: its slopes tilt a Lambert lane's shading normal.
        ("ridged", &format!(
            "type = \"diffuse\"\nreflectance = [0.6, 0.6, 0.7]\nbump_map = \"{texture}\"\n\
             bump_scale = 0.3"
        )),
    ];
    let mut text = String::from(
        "[render]\nspp = 3\nmax_depth = 7\nrr_depth = 2\nseed = 12\n\n\
         [camera]\nposition = [278, 273, -600]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
         vfov = 50\nresolution = [37, 31]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n\
         [environment]\nradiance = [0.3, 0.4, 0.6]\n\n\
         [[shapes]]\ntype = \"rectangle\"\nemission = [5, 5, 5]\n\
         transform = { scale = 40, rotate = { axis = [1, 0, 0], angle = 90 }, translate = [150, 500, 150] }\n\n\
         [[lights]]\ntype = \"point\"\nposition = [278, 450, -100]\nintensity = [60000, 60000, 60000]\n\n",
    );
    text += &format!("[[shapes]]\ntype = \"obj\"\nfile = \"{panel}\"\nmaterial = \"brushed\"\n\n");
    for (i, (name, body)) in materials.iter().enumerate() {
        text += &format!("[[materials]]\nname = \"{name}\"\n{body}\n\n");
        if *name == "brushed" {
            continue;
        }
        text += &material_sphere(dir.path(), i, name, 60.0);
    }
    let scene = scene_from("materials", &text);
    assert_identical("every material kind", &scene);
}

/// The frame of the material tests: 37×29 pixels at 3 spp with roulette
/// from depth 2, the Cornell box's walls in material `box_material`, a
/// constant sky, an area light and a point light; the test adds its
/// materials and further shapes.
fn lit_box(box_material: &str, max_depth: u32, seed: u32) -> String {
    format!(
        "[render]\nspp = 3\nmax_depth = {max_depth}\nrr_depth = 2\nseed = {seed}\n\n\
         [camera]\nposition = [278, 273, -600]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
         vfov = 50\nresolution = [37, 29]\n\n\
         [environment]\nradiance = [0.3, 0.4, 0.6]\n\n\
         [[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\nmaterial = \"{box_material}\"\n\n\
         [[shapes]]\ntype = \"rectangle\"\nemission = [5, 5, 5]\n\
         transform = {{ scale = 40, rotate = {{ axis = [1, 0, 0], angle = 90 }}, translate = [150, 500, 150] }}\n\n\
         [[lights]]\ntype = \"point\"\nposition = [278, 450, -100]\nintensity = [60000, 60000, 60000]\n\n"
    )
}

#[test]
fn rough_conductors_are_bit_identical() {
    // Isotropic GGX conductors are shaded in a vectorised loop of their own:
    // a box of tinted "none" metal (its reflectance the tint alone), so
    // that whole chunks hold no Lambert lane; gold nearly a mirror and
    // rough copper, smooth (vertex normals) and faceted; a Beckmann
    // aluminium sphere in the Beckmann conductors' loop beside them, and a
    // Lambert panel; lit by a point light, an area light and a
    // constant sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let smooth = dir.path().join("gold.obj");
    std::fs::write(&smooth, smooth_sphere_obj([170.0, 120.0, 200.0], 80.0)).unwrap();
    let smooth = smooth.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "conductors",
        &format!(
            "{}[[materials]]\nname = \"tinted\"\ntype = \"cook_torrance\"\nmetal = \"none\"\n\
             specular_reflectance = [0.9, 0.5, 0.2]\nroughness = 0.35\n\n\
             [[materials]]\nname = \"gold\"\ntype = \"cook_torrance\"\nmetal = \"Au\"\nalpha = 0.02\n\n\
             [[materials]]\nname = \"copper\"\ntype = \"cook_torrance\"\nmetal = \"Cu\"\nroughness = 0.7\n\n\
             [[materials]]\nname = \"aluminium\"\ntype = \"cook_torrance\"\nmetal = \"Al\"\n\
             distribution = \"beckmann\"\nroughness = 0.3\n\n\
             [[shapes]]\ntype = \"obj\"\nfile = \"{smooth}\"\nmaterial = \"gold\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [390, 120, 250]\nradius = 80\n\
             subdivisions = 2\nmaterial = \"copper\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [280, 330, 300]\nradius = 60\n\
             subdivisions = 2\nmaterial = \"aluminium\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\n\
             transform = {{ scale = 60, translate = [400, 380, 420] }}\n",
            lit_box("tinted", 6, 3)
        ),
    );
    assert_identical("rough conductors", &scene);
}

#[test]
fn rough_schlick_and_coated_reflectors_are_bit_identical() {
    // GGX Cook–Torrance surfaces with Schlick's Fresnel term and with a
    // dielectric coating's are shaded in vectorised loops of their own, one
    // per Fresnel kind: a box of the Schlick kind (chunks with no Lambert
    // lane), a coated sphere with vertex normals, a faceted Schlick sphere
    // and a rough conductor beside them in its own loop, a Beckmann one in
    // the Beckmann Schlick loop and an anisotropic coated one, with a
    // Lambert panel; lit by a point light, an area light and a constant
    // sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let smooth = dir.path().join("coated.obj");
    std::fs::write(&smooth, smooth_sphere_obj([170.0, 120.0, 200.0], 80.0)).unwrap();
    let smooth = smooth.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "schlick and coated",
        &format!(
            "{}[[materials]]\nname = \"box\"\ntype = \"cook_torrance\"\nfresnel = \"schlick\"\n\
             f0 = [0.6, 0.5, 0.4]\nroughness = 0.5\n\n\
             [[materials]]\nname = \"coated\"\ntype = \"cook_torrance\"\nfresnel = \"dielectric\"\n\
             ior = 1.6\nroughness = 0.2\n\n\
             [[materials]]\nname = \"shiny\"\ntype = \"cook_torrance\"\nfresnel = \"schlick\"\n\
             f0 = [0.95, 0.9, 0.7]\nalpha = 0.03\n\n\
             [[materials]]\nname = \"copper\"\ntype = \"cook_torrance\"\nmetal = \"Cu\"\nroughness = 0.4\n\n\
             [[materials]]\nname = \"beckmann\"\ntype = \"cook_torrance\"\nfresnel = \"schlick\"\n\
             distribution = \"beckmann\"\nroughness = 0.3\n\n\
             [[materials]]\nname = \"brushed\"\ntype = \"cook_torrance\"\nfresnel = \"dielectric\"\n\
             alpha_u = 0.05\nalpha_v = 0.3\n\n\
             [[shapes]]\ntype = \"obj\"\nfile = \"{smooth}\"\nmaterial = \"coated\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [390, 120, 250]\nradius = 80\n\
             subdivisions = 2\nmaterial = \"shiny\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [280, 330, 300]\nradius = 60\n\
             subdivisions = 2\nmaterial = \"copper\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [420, 360, 200]\nradius = 40\n\
             subdivisions = 2\nmaterial = \"beckmann\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [130, 380, 260]\nradius = 40\n\
             subdivisions = 2\nmaterial = \"brushed\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\n\
             transform = {{ scale = 60, translate = [400, 380, 420] }}\n",
            lit_box("box", 6, 6)
        ),
    );
    assert_identical("Schlick and coated reflectors", &scene);
}

#[test]
fn rough_dielectrics_are_bit_identical() {
    // Isotropic GGX dielectrics are shaded in a vectorised loop of their
    // own, which refracts: the outside is the geometric normal's side, each
    // ray leaves on the side it goes, and the path's η² reaches Russian
    // roulette. A box of rough glass (chunks with no Lambert lane), a
    // frosted sphere with vertex normals, a rough sphere of η < 1 (total
    // internal reflection from outside), and beside them a smooth and a
    // Beckmann one (in loops of their own), an anisotropic one and a
    // Lambert panel; lit by a point light, an area light
    // and a constant sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let smooth = dir.path().join("frosted.obj");
    std::fs::write(&smooth, smooth_sphere_obj([170.0, 120.0, 200.0], 80.0)).unwrap();
    let smooth = smooth.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "dielectrics",
        &format!(
            "{}[[materials]]\nname = \"box\"\ntype = \"dielectric\"\nior = 1.33\nroughness = 0.5\n\n\
             [[materials]]\nname = \"frosted\"\ntype = \"dielectric\"\nior = 1.5\nalpha = 0.05\n\n\
             [[materials]]\nname = \"bubble\"\ntype = \"dielectric\"\nior = 0.75\nroughness = 0.3\n\n\
             [[materials]]\nname = \"smooth\"\ntype = \"dielectric\"\nior = 1.5\n\n\
             [[materials]]\nname = \"beckmann\"\ntype = \"dielectric\"\ndistribution = \"beckmann\"\n\
             roughness = 0.3\n\n\
             [[materials]]\nname = \"brushed\"\ntype = \"dielectric\"\nalpha_u = 0.05\nalpha_v = 0.3\n\n\
             [[shapes]]\ntype = \"obj\"\nfile = \"{smooth}\"\nmaterial = \"frosted\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [390, 120, 250]\nradius = 80\n\
             subdivisions = 2\nmaterial = \"bubble\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [280, 330, 300]\nradius = 60\n\
             subdivisions = 2\nmaterial = \"smooth\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [420, 360, 200]\nradius = 40\n\
             subdivisions = 2\nmaterial = \"beckmann\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [130, 380, 260]\nradius = 40\n\
             subdivisions = 2\nmaterial = \"brushed\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\n\
             transform = {{ scale = 60, translate = [400, 380, 420] }}\n",
            lit_box("box", 8, 5)
        ),
    );
    assert_identical("rough dielectrics", &scene);
}

/// The `[[shapes]]` entry of a faceted sphere (an icosphere, subdivided
/// twice) in material `material`.
fn sphere(center: [f32; 3], radius: f32, material: &str) -> String {
    let [x, y, z] = center;
    format!(
        "[[shapes]]\ntype = \"sphere\"\ncenter = [{x}, {y}, {z}]\nradius = {radius}\n\
         subdivisions = 2\nmaterial = \"{material}\"\n\n"
    )
}

/// The `[[shapes]]` entry of a smooth OBJ sphere (vertex normals) written
/// into `dir` as `{material}.obj`, in material `material`.
fn smooth_sphere(dir: &Path, center: [f32; 3], radius: f32, material: &str) -> String {
    let file = dir.join(format!("{material}.obj"));
    std::fs::write(&file, smooth_sphere_obj(center, radius)).unwrap();
    let file = file.display().to_string().replace('\\', "/");
    format!("[[shapes]]\ntype = \"obj\"\nfile = \"{file}\"\nmaterial = \"{material}\"\n\n")
}

#[test]
fn smooth_dielectrics_are_bit_identical() {
    // Smooth dielectrics (delta lobes) are shaded in a vectorised loop of
    // their own, which takes no light sample and draws no numbers for one:
    // a box of glass (chunks with no Lambert lane, paths refracting in and
    // out), a glass sphere with vertex normals, faceted water, a bubble of
    // η < 1 (total internal reflection), beside a rough glass sphere and
    // an anisotropic one in their own loop and a Lambert panel; lit by a point light, an area light and a constant
    // sky (each lane picks one), with roulette from depth 2 on the paths'
    // η². Then a glass sphere on a Lambert floor under a sky alone (the
    // same light for every lane), which the refracted paths find with no
    // MIS weight.
    let dir = tempfile::tempdir().unwrap();
    let mut text = lit_box("box", 8, 9);
    for (name, body) in [
        ("box", "ior = 1.5"),
        ("glass", "ior = 1.5"),
        ("water", "ior = 1.33"),
        ("bubble", "ior = 0.75"),
        ("frosted", "ior = 1.5\nroughness = 0.3"),
        ("brushed", "alpha_u = 0.05\nalpha_v = 0.3"),
    ] {
        text += &format!("[[materials]]\nname = \"{name}\"\ntype = \"dielectric\"\n{body}\n\n");
    }
    text += &smooth_sphere(dir.path(), [170.0, 120.0, 200.0], 80.0, "glass");
    text += &sphere([390.0, 120.0, 250.0], 80.0, "water");
    text += &sphere([280.0, 330.0, 300.0], 60.0, "bubble");
    text += &sphere([420.0, 360.0, 200.0], 40.0, "frosted");
    text += &sphere([130.0, 380.0, 260.0], 40.0, "brushed");
    text += "[[shapes]]\ntype = \"rectangle\"\n\
             transform = { scale = 60, translate = [400, 380, 420] }\n";
    assert_identical(
        "smooth dielectrics",
        &scene_from("smooth dielectrics", &text),
    );

    let mut text = String::from(
        "[render]\nspp = 4\nmax_depth = 6\nrr_depth = 2\nseed = 2\n\n\
         [camera]\nposition = [0, 2, -6]\nlook_at = [0, 0.5, 0]\nup = [0, 1, 0]\n\
         vfov = 40\nresolution = [31, 23]\n\n\
         [[materials]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\n\n\
         [[shapes]]\ntype = \"rectangle\"\n\
         transform = { scale = 4, rotate = { axis = [1, 0, 0], angle = -90 }, translate = [0, -1, 0] }\n\n\
         [environment]\nradiance = [0.8, 0.9, 1.0]\n\n",
    );
    text += &smooth_sphere(dir.path(), [0.0, 0.2, 0.0], 1.0, "glass");
    assert_identical(
        "a glass sphere under the sky",
        &scene_from("glass sphere", &text),
    );
}

#[test]
fn beckmann_microfacets_are_bit_identical() {
    // Isotropic Beckmann distributions have loops of their own beside the
    // GGX ones (the distribution known to the compiler, as the Fresnel
    // term is): a box of a Beckmann conductor (chunks with no Lambert
    // lane), Beckmann reflectors with Schlick's and a coating's Fresnel
    // term, smooth and faceted, Beckmann rough glass and a Beckmann bubble,
    // an anisotropic Beckmann conductor (vertex normals and texture
    // coordinates: its tangent is ∂p/∂u), beside a GGX conductor and a
    // Lambert panel; lit by a point light, an area
    // light and a constant sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let mut text = lit_box("box", 7, 11);
    for (name, body) in [
        (
            "box",
            "type = \"cook_torrance\"\nmetal = \"Al\"\nroughness = 0.5",
        ),
        (
            "schlick",
            "type = \"cook_torrance\"\nfresnel = \"schlick\"\nf0 = [0.9, 0.6, 0.3]\nalpha = 0.05",
        ),
        (
            "coated",
            "type = \"cook_torrance\"\nfresnel = \"dielectric\"\nior = 1.6\nroughness = 0.3",
        ),
        ("glass", "type = \"dielectric\"\nior = 1.5\nroughness = 0.3"),
        ("bubble", "type = \"dielectric\"\nior = 0.8\nalpha = 0.1"),
        (
            "brushed",
            "type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha_u = 0.05\nalpha_v = 0.3",
        ),
    ] {
        text +=
            &format!("[[materials]]\nname = \"{name}\"\n{body}\ndistribution = \"beckmann\"\n\n");
    }
    text += "[[materials]]\nname = \"gold\"\ntype = \"cook_torrance\"\nmetal = \"Au\"\nroughness = 0.3\n\n";
    text += &smooth_sphere(dir.path(), [170.0, 120.0, 200.0], 80.0, "schlick");
    text += &sphere([390.0, 120.0, 250.0], 80.0, "coated");
    text += &smooth_sphere(dir.path(), [280.0, 330.0, 300.0], 60.0, "glass");
    text += &sphere([420.0, 360.0, 200.0], 40.0, "bubble");
    text += &smooth_sphere(dir.path(), [130.0, 380.0, 260.0], 40.0, "brushed");
    text += &sphere([160.0, 260.0, 120.0], 30.0, "gold");
    text += "[[shapes]]\ntype = \"rectangle\"\n\
             transform = { scale = 60, translate = [400, 380, 420] }\n";
    assert_identical("Beckmann microfacets", &scene_from("Beckmann", &text));
}

#[test]
fn anisotropic_surfaces_are_bit_identical() {
    // Anisotropic microfacets are shaded in their kinds' vectorised loops,
    // each lane's frame built around the tangent the general integrator
    // takes (∂p/∂u where the mesh has texture coordinates, else the
    // triangle's first edge): a box of anisotropic GGX metal (chunks with
    // no Lambert lane; the box has no texture coordinates), anisotropic
    // principled, rough glass and coated spheres with vertex normals and
    // texture coordinates, a faceted anisotropic Beckmann one, an
    // isotropic one beside them in the same loop, and an anisotropic one
    // that its roughness map makes isotropic (no tangent frame); lit by a
    // point light, an area light and a constant sky, with roulette from
    // depth 2.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 4, 6, 7);
    let texture = texture.display().to_string().replace('\\', "/");
    let mut text = lit_box("box", 6, 13);
    for (name, body) in [
        (
            "box",
            "type = \"cook_torrance\"\nmetal = \"Ag\"\nalpha_u = 0.4\nalpha_v = 0.05".to_string(),
        ),
        (
            "plastic",
            "type = \"principled\"\nbase_color = [0.2, 0.5, 0.8]\nroughness = 0.4\nanisotropic = 0.8"
                .into(),
        ),
        (
            "glass",
            "type = \"dielectric\"\nior = 1.5\nalpha_u = 0.3\nalpha_v = 0.02".into(),
        ),
        (
            "coated",
            "type = \"cook_torrance\"\nfresnel = \"dielectric\"\nior = 1.6\nalpha_u = 0.02\nalpha_v = 0.2"
                .into(),
        ),
        (
            "beckmann",
            "type = \"cook_torrance\"\nfresnel = \"schlick\"\ndistribution = \"beckmann\"\n\
             alpha_u = 0.1\nalpha_v = 0.5"
                .into(),
        ),
        (
            "round",
            "type = \"cook_torrance\"\nmetal = \"Ag\"\nroughness = 0.3".into(),
        ),
        (
            "mapped",
            format!(
                "type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha_u = 0.05\nalpha_v = 0.4\n\
                 roughness_map = \"{texture}\""
            ),
        ),
    ] {
        text += &format!("[[materials]]\nname = \"{name}\"\n{body}\n\n");
    }
    text += &smooth_sphere(dir.path(), [170.0, 120.0, 200.0], 80.0, "plastic");
    text += &smooth_sphere(dir.path(), [390.0, 120.0, 250.0], 80.0, "glass");
    text += &smooth_sphere(dir.path(), [280.0, 330.0, 300.0], 60.0, "coated");
    text += &sphere([420.0, 360.0, 200.0], 40.0, "beckmann");
    text += &sphere([130.0, 380.0, 260.0], 40.0, "round");
    text += &smooth_sphere(dir.path(), [160.0, 260.0, 120.0], 30.0, "mapped");
    text += "[[shapes]]\ntype = \"rectangle\"\n\
             transform = { scale = 60, translate = [400, 380, 420] }\n";
    assert_identical("anisotropic surfaces", &scene_from("anisotropic", &text));
}

#[test]
fn blinn_phong_is_bit_identical() {
    // Blinn–Phong surfaces are shaded in a vectorised loop of their own: a
    // box of it (chunks with no Lambert lane), a shiny and a dull sphere,
    // smooth and faceted, one purely specular, one normal-mapped (its BSDF
    // unchanged by the map), one colour-mapped (its diffuse colour per
    // lane), and a Lambert panel; lit by a point light, an area light and a
    // constant sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 4, 3, 5);
    let texture = texture.display().to_string().replace('\\', "/");
    let materials = [
        (
            "box",
            "diffuse = [0.5, 0.45, 0.4]\nspecular = [0.2, 0.2, 0.2]\nexponent = 8".to_string(),
        ),
        (
            "shiny",
            "diffuse = [0.1, 0.2, 0.35]\nspecular = [0.6, 0.6, 0.6]\nexponent = 300".into(),
        ),
        (
            "dull",
            "diffuse = [0.6, 0.3, 0.1]\nspecular = [0.1, 0.1, 0.1]\nexponent = 2".into(),
        ),
        (
            "specular",
            "diffuse = [0, 0, 0]\nspecular = [0.8, 0.7, 0.5]\nexponent = 60".into(),
        ),
        (
            "bumpy",
            format!(
                "diffuse = [0.4, 0.4, 0.3]\nspecular = [0.4, 0.4, 0.4]\nexponent = 25\n\
             normal_map = \"{texture}\""
            ),
        ),
        (
            "mapped",
            format!("specular = [0.3, 0.3, 0.3]\nexponent = 40\nbase_color_map = \"{texture}\""),
        ),
    ];
    let mut text = lit_box("box", 6, 4);
    for (i, (name, body)) in materials.iter().enumerate() {
        text += &format!("[[materials]]\nname = \"{name}\"\ntype = \"blinn_phong\"\n{body}\n\n");
        if i == 0 {
            continue;
        }
        text += &material_sphere(dir.path(), i, name, 55.0);
    }
    text += "[[shapes]]\ntype = \"rectangle\"\n\
             transform = { scale = 60, translate = [400, 380, 420] }\n";
    let scene = scene_from("blinn-phong", &text);
    assert_identical("Blinn–Phong surfaces", &scene);
}

/// The scene of [`lit_box`] with principled `materials` (name, body): the
/// first is the box's, each other one a sphere's (in `dir`).
fn principled_box(dir: &Path, materials: &[(&str, String)]) -> String {
    let mut text = lit_box(materials[0].0, 6, 8);
    for (i, (name, body)) in materials.iter().enumerate() {
        text += &format!("[[materials]]\nname = \"{name}\"\ntype = \"principled\"\n{body}\n\n");
        if i == 0 {
            continue;
        }
        text += &material_sphere(dir, i, name, 55.0);
    }
    text
}

#[test]
fn principled_surfaces_are_bit_identical() {
    // The principled BSDF in Mitsuba's mode is shaded in a vectorised loop
    // of its own: a box of it (chunks with no Lambert lane), spheres from
    // dielectric to metal with and without specular tint, smooth and
    // faceted, one with a base-colour map (the lane's albedo), an
    // anisotropic one, one roughness-mapped, and beside them one in the
    // energy-conserving mode (a loop of its own); lit by a point light, an
    // area light and a constant sky, with roulette from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 4, 5, 3);
    let texture = texture.display().to_string().replace('\\', "/");
    let materials = [
        (
            "box",
            "base_color = [0.7, 0.6, 0.5]\nroughness = 0.6".to_string(),
        ),
        (
            "dielectric",
            "base_color = [0.1, 0.3, 0.8]\nroughness = 0.3\nspecular = 0.8".into(),
        ),
        (
            "tinted",
            "base_color = [0.8, 0.3, 0.1]\nroughness = 0.2\nmetallic = 0.5\nspec_tint = 0.7".into(),
        ),
        (
            "metal",
            "base_color = [0.9, 0.7, 0.3]\nroughness = 0.05\nmetallic = 1".into(),
        ),
        (
            "mapped",
            format!("base_color_map = \"{texture}\"\nroughness = 0.45\nspec_tint = 1"),
        ),
        (
            "anisotropic",
            "base_color = [0.5, 0.5, 0.5]\nroughness = 0.4\nanisotropic = 0.6".into(),
        ),
        (
            "conserving",
            "base_color = [0.5, 0.6, 0.5]\nroughness = 0.4\nenergy_conserving = true".into(),
        ),
        (
            "rough_map",
            format!("base_color = [0.6, 0.5, 0.5]\nroughness_map = \"{texture}\""),
        ),
    ];
    let scene = scene_from("principled", &principled_box(dir.path(), &materials));
    assert_identical("principled surfaces", &scene);
}

#[test]
fn energy_conserving_tables_are_bit_identical() {
    // The energy-conserving mode's albedo tables and average albedo in
    // every combination that selects different tables or entries: two
    // `specular` values (one table each), two materials sharing one,
    // `spec_tint` (the Schlick tables, weighted by a mapped base colour),
    // anisotropy (the average over azimuths) and a roughness map.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 4, 9, 4);
    let texture = texture.display().to_string().replace('\\', "/");
    let ec = "energy_conserving = true";
    let materials = [
        ("box", format!("base_color = [0.7, 0.6, 0.5]\nroughness = 0.6\n{ec}")),
        (
            "same_tables",
            format!("base_color = [0.2, 0.5, 0.8]\nroughness = 0.2\n{ec}"),
        ),
        (
            "other_specular",
            format!("base_color = [0.1, 0.3, 0.8]\nroughness = 0.3\nspecular = 0.9\n{ec}"),
        ),
        (
            "tinted_map",
            format!("base_color_map = \"{texture}\"\nroughness = 0.45\nspec_tint = 0.8\n{ec}"),
        ),
        (
            "rough_map",
            format!("base_color = [0.6, 0.5, 0.5]\nroughness_map = \"{texture}\"\nspecular = 0.9\n{ec}"),
        ),
        (
            "anisotropic",
            format!("base_color = [0.5, 0.5, 0.5]\nroughness = 0.4\nanisotropic = 0.7\nspecular = 0.2\n{ec}"),
        ),
    ];
    let scene = scene_from("energy-conserving", &principled_box(dir.path(), &materials));
    assert_identical("energy-conserving tables", &scene);
}

#[test]
fn mapped_parameters_are_bit_identical() {
    // Roughness, metallic and colour maps give each lane its own BSDF
    // parameters (looked up per lane as the general integrator's
    // `Material::bsdf_at` does), shaded in their kinds' vectorised loops: a
    // box of energy-conserving principled with roughness and metallic maps
    // (chunks of that mode alone; the box has no texture coordinates, so one
    // texel each), roughness-mapped GGX and Beckmann metals and a coating
    // (an anisotropic one made isotropic by its map: no tangent frame),
    // principled spheres in Mitsuba's mode with one map each and with all
    // three (one anisotropic), a colour-mapped Blinn–Phong sphere, and an
    // energy-conserving one with all three maps among other kinds' lanes;
    // lit by a point light, an area light and a constant sky, with roulette
    // from depth 2.
    let dir = tempfile::tempdir().unwrap();
    let map = |name: &str, seed: u64| {
        let folder = dir.path().join(name);
        std::fs::create_dir(&folder).unwrap();
        let texture = random_texture(&folder, 4, seed, 11);
        texture.display().to_string().replace('\\', "/")
    };
    let (rough, metal, colour) = (map("rough", 1), map("metal", 2), map("colour", 3));
    let materials = [
        (
            "box",
            format!(
                "type = \"principled\"\nbase_color = [0.6, 0.55, 0.5]\nspec_tint = 0.3\n\
                 roughness_map = \"{rough}\"\nmetallic_map = \"{metal}\"\nenergy_conserving = true"
            ),
        ),
        (
            "gold",
            format!("type = \"cook_torrance\"\nmetal = \"Au\"\nroughness_map = \"{rough}\""),
        ),
        (
            "brushed",
            format!(
                "type = \"cook_torrance\"\nmetal = \"Ag\"\ndistribution = \"beckmann\"\n\
                 alpha_u = 0.05\nalpha_v = 0.4\nroughness_map = \"{rough}\""
            ),
        ),
        (
            "coated",
            format!(
                "type = \"cook_torrance\"\nfresnel = \"dielectric\"\nior = 1.6\n\
                 roughness_map = \"{metal}\""
            ),
        ),
        (
            "rough",
            format!(
                "type = \"principled\"\nbase_color = [0.2, 0.5, 0.8]\nmetallic = 0.4\n\
                 roughness_map = \"{rough}\""
            ),
        ),
        (
            "metal",
            format!(
                "type = \"principled\"\nbase_color = [0.9, 0.6, 0.3]\nroughness = 0.3\n\
                 anisotropic = 0.7\nmetallic_map = \"{metal}\""
            ),
        ),
        (
            "painted",
            format!(
                "type = \"principled\"\nbase_color_map = \"{colour}\"\nspec_tint = 0.5\n\
                 roughness_map = \"{rough}\"\nmetallic_map = \"{metal}\""
            ),
        ),
        (
            "phong",
            format!(
                "type = \"blinn_phong\"\nspecular = [0.3, 0.2, 0.2]\nexponent = 30\n\
                 base_color_map = \"{colour}\""
            ),
        ),
        (
            "conserving",
            format!(
                "type = \"principled\"\nbase_color_map = \"{colour}\"\n\
                 roughness_map = \"{rough}\"\nmetallic_map = \"{metal}\"\nenergy_conserving = true"
            ),
        ),
    ];
    let mut text = lit_box("box", 6, 21);
    for (i, (name, body)) in materials.iter().enumerate() {
        text += &format!("[[materials]]\nname = \"{name}\"\n{body}\n\n");
        if i > 0 {
            text += &material_sphere(dir.path(), i - 1, name, 50.0);
        }
    }
    assert_identical("mapped parameters", &scene_from("mapped", &text));
}

#[test]
fn normal_maps_alone_are_bit_identical() {
    // Normal-mapped Lambert rectangles and no mesh with vertex normals: the
    // kernel must look up shading normals for the map alone.
    let dir = tempfile::tempdir().unwrap();
    let texture = random_texture(dir.path(), 5, 7, 4);
    let texture = texture.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "normal maps",
        &format!(
            "[render]\nspp = 3\nmax_depth = 4\nseed = 5\n\n\
             [camera]\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
             vfov = 37\nresolution = [35, 31]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n\
             [[materials]]\nname = \"bumpy\"\ntype = \"diffuse\"\nnormal_map = \"{texture}\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"bumpy\"\n\
             transform = {{ scale = 150, rotate = {{ axis = [0, 1, 0], angle = 20 }}, translate = [278, 250, 300] }}\n\n\
             [[lights]]\ntype = \"point\"\nposition = [278, 400, 50]\nintensity = [90000, 90000, 90000]\n"
        ),
    );
    assert_identical("normal maps", &scene);
}

#[test]
fn asking_for_an_instruction_set_the_cpu_lacks_is_an_error() {
    let Some(missing) = [Isa::Avx2, Isa::Avx512]
        .into_iter()
        .find(|i| !i.is_available())
    else {
        return; // this CPU has them all: nothing to check here
    };
    let o = RenderOptions {
        isa: Some(missing),
        ..Default::default()
    };
    let demo = embree_demo(8, 1);
    let err = render(&demo.scene, &demo.job, &o, &|_, _| true).unwrap_err();
    assert!(err.to_string().contains(missing.name()), "{err}");
}

#[test]
fn shading_normals_are_bit_identical() {
    // A sphere (smooth vertex normals) and a panel whose vertex normals
    // lean 68° outwards at its corners, so that the light-leak guard
    // (directions on different sides for the geometric and the shading
    // normal) rejects many light and BSDF samples; one colour of the panel
    // comes from a texture. Lit by a point light, an area light and a
    // constant sky through the box's open side; the normal layer shows
    // the shading normals.
    let dir = tempfile::tempdir().unwrap();
    let panel = dir.path().join("panel.obj");
    let mut obj = String::new();
    for (x, y) in [(-1.0f32, -1.0f32), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
        obj += &format!(
            "v {} {} 300\nvt {} {}\n",
            278.0 + 120.0 * x,
            220.0 + 120.0 * y,
            (x + 1.0) / 2.0,
            (y + 1.0) / 2.0
        );
        obj += &format!("vn {} {} -1\n", 2.5 * x, 2.5 * y);
    }
    obj += "f 1/1/1 2/2/2 3/3/3\nf 1/1/1 3/3/3 4/4/4\n";
    std::fs::write(&panel, obj).unwrap();
    let texture = random_texture(dir.path(), 4, 4, 1);
    let path = |p: &Path| p.display().to_string().replace('\\', "/");
    let scene = scene_from(
        "shading-normals",
        &format!(
            "[render]\nspp = 3\nmax_depth = 5\nseed = 8\n\n\
             [camera]\nposition = [278, 273, -600]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
             vfov = 50\nresolution = [33, 29]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n\
             [environment]\nradiance = [0.3, 0.4, 0.6]\n\n\
             [[materials]]\nname = \"t\"\ntype = \"diffuse\"\nbase_color_map = \"{}\"\n\n\
             [[materials]]\nname = \"grey\"\ntype = \"diffuse\"\nreflectance = [0.6, 0.6, 0.6]\n\n\
             [[shapes]]\ntype = \"obj\"\nfile = \"{}\"\nmaterial = \"t\"\n\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [400, 90, 200]\nradius = 80\nmaterial = \"grey\"\n\n\
             [[shapes]]\ntype = \"rectangle\"\nemission = [5, 5, 5]\n\
             transform = {{ scale = 40, rotate = {{ axis = [1, 0, 0], angle = 90 }}, translate = [150, 500, 150] }}\n\n\
             [[lights]]\ntype = \"point\"\nposition = [278, 450, -100]\nintensity = [60000, 60000, 60000]\n",
            path(&texture),
            path(&panel)
        ),
    );
    assert_identical("shading normals", &scene);
}

#[test]
fn virtual_objects_are_bit_identical() {
    // A virtual sphere and panel (objects inserted into a photograph) in
    // the Cornell box, rendered as `plsr composite` renders a scene: with
    // them, their coverage counted in the matte, and without them
    // (`hide_virtual`: camera, bounce and shadow rays pass through them).
    let mut case = scene_from(
        "virtual",
        "[render]\nspp = 3\nmax_depth = 4\nseed = 3\n\n\
         [camera]\nposition = [278, 273, -800]\nlook_at = [278, 273, 0]\nup = [0, 1, 0]\n\
         vfov = 37\nresolution = [29, 27]\n\n[[shapes]]\ntype = \"obj\"\nfile = \"OBJ\"\n\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [300, 120, 250]\nradius = 110\nvirtual = true\n\n\
         [[shapes]]\ntype = \"rectangle\"\nvirtual = true\n\
         transform = { scale = 60, rotate = { axis = [0, 1, 0], angle = 30 }, translate = [150, 300, 200] }\n\n\
         [[lights]]\ntype = \"point\"\nposition = [278, 500, 100]\nintensity = [90000, 90000, 90000]\n",
    );
    let sums = |case: &Case, kernel: Option<Isa>| {
        let o = RenderOptions {
            threads: Some(2),
            tile_size: 16,
            vectorised: kernel.is_some(),
            isa: kernel,
        };
        let (sums, stats) =
            plsr::render::render_sums(&case.scene, &case.job, &o, &|_, _| true).unwrap();
        assert_eq!(stats.vectorised, kernel, "kernel choice");
        (0..27)
            .flat_map(|y| (0..29).map(move |x| (x, y)))
            .map(|(x, y)| sums.pixel(x, y).virtual_hits)
            .collect::<Vec<u32>>()
    };
    let mut colours = Vec::new();
    for hide in [false, true] {
        case.job.hide_virtual = hide;
        let what = if hide {
            "virtual objects hidden"
        } else {
            "virtual objects seen"
        };
        assert_identical(what, &case);
        let matte = sums(&case, None);
        assert_eq!(matte.iter().any(|&m| m > 0), !hide, "{what}: the matte");
        for isa in isas() {
            assert_eq!(
                matte,
                sums(&case, Some(isa)),
                "{what}, {}: the matte",
                isa.name()
            );
        }
        colours.push(render_with(&case, None, 1, 16).color);
    }
    assert_ne!(
        colours[0], colours[1],
        "hiding the virtual objects changes the image"
    );
}

#[test]
fn one_sided_surfaces_are_bit_identical() {
    // The Cornell box with every material one-sided: the walls' backs face
    // away from the camera, but light and paths reach the boxes' and the
    // light panel's backs, where paths end.
    let mut desc = load(Path::new("tests/data/cornell-64.toml")).unwrap();
    desc.camera = desc.camera.with_resolution(40, 40).unwrap();
    desc.job.spp = 3;
    for m in &mut desc.materials {
        m.two_sided = false;
    }
    let mut cornell = Case::new(Scene::build(desc).unwrap());
    assert_identical("one-sided Cornell box", &cornell);
    cornell.job.max_depth = 1;
    assert_identical("one-sided Cornell box, max_depth 1", &cornell);
    assert_same_ray_counts(&cornell);
}

/// `max_depth = 0` (Mitsuba's 1): the camera sees the emitters and nothing
/// else, the same in both integrators; every pixel is the light's radiance
/// or black.
#[test]
fn depth_zero_shows_only_emitters_in_both_integrators() {
    let mut desc = load(Path::new("tests/data/cornell-64.toml")).unwrap();
    desc.camera = desc.camera.with_resolution(40, 40).unwrap();
    desc.job.spp = 2;
    desc.job.max_depth = 0;
    let radiance: Vec<glam::Vec3> = desc
        .meshes
        .iter()
        .filter_map(|m| m.emission.map(|e| e.radiance))
        .collect();
    let cornell = Case::new(Scene::build(desc).unwrap());
    assert_identical("Cornell box, max_depth 0", &cornell);
    let (film, _) = render(
        &cornell.scene,
        &cornell.job,
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap();
    let mut lit = 0;
    for c in &film.color {
        // A pixel on the light's edge averages light and black.
        let on_light = radiance
            .iter()
            .any(|r| (c.x / r.x - c.y / r.y).abs() < 1e-4);
        assert!(*c == glam::Vec3::ZERO || on_light, "{c}");
        lit += (*c != glam::Vec3::ZERO) as usize;
    }
    assert!(lit > 0, "the light is in view");
}
