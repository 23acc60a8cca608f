//! The denoiser on renders of analytic scenes: a plane of two albedos lit
//! by a spherical light and a constant sky, whose radiance is known in
//! closed form, and a white furnace. Denoising must keep the image's mean
//! and the albedo step where it is, while removing most of the noise.

use plsr::film::denoise::DenoiseSettings;
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;

fn render_text(text: &str) -> plsr::film::Film {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0
}

const W: usize = 64;
const H: usize = 48;

/// Two 2 m squares side by side at z = 0 (albedo 0.2 for x < 0, 0.8 for
/// x > 0) seen from 3 m straight above; a sky of radiance 0.2 and, out of
/// view, a black sphere of radius 0.3 emitting 20, centred 1 m above
/// (1.5, 0). Direct light only.
const PLANE: &str = r#"
[render]
spp = 4
max_depth = 1
seed = 3

[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 30
resolution = [64, 48]

[environment]
radiance = [0.2, 0.2, 0.2]

[[materials]]
name = "dark"
type = "diffuse"
reflectance = [0.2, 0.2, 0.2]

[[materials]]
name = "light"
type = "diffuse"
reflectance = [0.8, 0.8, 0.8]

[[materials]]
name = "black"
type = "diffuse"
reflectance = [0, 0, 0]

[[shapes]]
type = "rectangle"
material = "dark"
transform = { translate = [-1, 0, 0] }

[[shapes]]
type = "rectangle"
material = "light"
transform = { translate = [1, 0, 0] }

[[shapes]]
type = "sphere"
material = "black"
center = [1.5, 0, 1]
radius = 0.3
emission = [20, 20, 20]
"#;

/// The irradiance factor at pixel `(x, y)`'s centre: the plane's radiance
/// there divided by its albedo. A sphere of radiance `Ls` subtending a
/// half-angle `α` at an angle `θ` from the normal covers a projected solid
/// angle `π sin²α cos θ`, and hides the sky behind it, so
/// `L = ρ (Lsky + sin²α cos θ (Ls − Lsky))`.
fn illumination(x: usize, y: usize) -> f64 {
    let t = 15f64.to_radians().tan();
    let u = (x as f64 + 0.5) / W as f64 * 2.0 - 1.0;
    let v = 1.0 - (y as f64 + 0.5) / H as f64 * 2.0;
    let (px, py) = (3.0 * u * t * W as f64 / H as f64, 3.0 * v * t);
    let (dx, dy, dz) = (1.5 - px, -py, 1.0);
    let d = (dx * dx + dy * dy + dz * dz).sqrt();
    let sin2 = (0.3 / d).powi(2);
    0.2 + sin2 * (dz / d) * (20.0 - 0.2)
}

fn albedo_at(x: usize) -> f64 {
    if x < W / 2 {
        0.2
    } else {
        0.8
    }
}

#[test]
fn denoising_a_lit_plane_keeps_its_mean_and_its_edge() {
    let mut film = render_text(PLANE);
    let truth: Vec<f64> = (0..W * H)
        .map(|i| albedo_at(i % W) * illumination(i % W, i / W))
        .collect();
    let rel_mse = |c: &[glam::Vec3]| {
        c.iter()
            .zip(&truth)
            .map(|(c, t)| ((f64::from(c.x) - t) / t).powi(2))
            .sum::<f64>()
            / truth.len() as f64
    };
    let noisy_error = rel_mse(&film.color);
    let noisy_color = film.color.clone();
    let report = film.denoise(&DenoiseSettings::default()).unwrap();
    assert_eq!(report.guides, "colour + albedo + normal");
    let denoised_error = rel_mse(&film.color);
    let mean = |c: &[glam::Vec3]| c.iter().map(|c| f64::from(c.x)).sum::<f64>() / c.len() as f64;
    let truth_mean = truth.iter().sum::<f64>() / truth.len() as f64;
    eprintln!(
        "relMSE {noisy_error:.4} noisy, {denoised_error:.5} denoised; mean {:.4} denoised, {truth_mean:.4} true",
        mean(&film.color)
    );
    assert!(((mean(&film.color) - truth_mean) / truth_mean).abs() < 0.01);
    assert!(denoised_error < noisy_error / 10.0);
    // The noisy colour is kept, unchanged.
    assert_eq!(film.noisy.as_ref(), Some(&noisy_color));
    // The step from albedo 0.2 to 0.8 lies between columns 31 and 32 (at
    // x = 32 in pixel units): find, row by row, where the albedo the
    // denoised image implies crosses 0.5 between pixel centres.
    let mut offsets = Vec::new();
    for y in 0..H {
        let rho = |x: usize| f64::from(film.color[y * W + x].x) / illumination(x, y);
        let x = (W / 2 - 4..W / 2 + 4)
            .find(|&x| rho(x) < 0.5 && rho(x + 1) >= 0.5)
            .unwrap_or_else(|| panic!("row {y}: no step near the centre"));
        let at = x as f64 + 0.5 + (0.5 - rho(x)) / (rho(x + 1) - rho(x));
        offsets.push(at - W as f64 / 2.0);
    }
    let mean_offset = offsets.iter().sum::<f64>() / H as f64;
    let worst = offsets.iter().fold(0.0f64, |m, o| m.max(o.abs()));
    eprintln!("step edge: {mean_offset:+.3} px on average, {worst:.3} px at worst");
    assert!(mean_offset.abs() < 0.5 && worst < 1.0);
}

#[test]
fn a_denoised_white_furnace_stays_white() {
    let mut film = render_text(
        r#"
[render]
spp = 4
max_depth = 64
seed = 2

[camera]
position = [0, -3, 0.5]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov = 60
resolution = [48, 48]

[environment]
radiance = [1, 1, 1]

[[materials]]
name = "white"
type = "diffuse"
reflectance = [1, 1, 1]

[[shapes]]
type = "sphere"
radius = 1
material = "white"
"#,
    );
    let mse = |c: &[glam::Vec3]| {
        c.iter()
            .map(|c| f64::from((*c - glam::Vec3::ONE).length_squared()))
            .sum::<f64>()
            / c.len() as f64
    };
    let noisy = mse(&film.color);
    film.denoise(&DenoiseSettings::default()).unwrap();
    let mean = film.mean_color();
    eprintln!(
        "furnace: MSE {noisy:.5} noisy, {:.5} denoised; mean {mean}",
        mse(&film.color)
    );
    assert!(
        (mean - glam::Vec3::ONE).abs().max_element() < 0.01,
        "mean {mean}"
    );
    assert!(mse(&film.color) < noisy / 4.0);
}

/// A smooth glass sphere in front of a red wall, seen head on.
const GLASS: &str = r#"
[render]
spp = 8
max_depth = 8
seed = 1

[camera]
position = [0, 0, 4]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 40
resolution = [32, 32]

[environment]
radiance = [1, 1, 1]

[[materials]]
name = "glass"
type = "dielectric"
ior = 1.5

[[materials]]
name = "red"
type = "diffuse"
reflectance = [0.8, 0.1, 0.1]

[[shapes]]
type = "sphere"
material = "glass"
radius = 0.8

[[shapes]]
type = "rectangle"
material = "red"
transform = { scale = 10, translate = [0, 0, -2] }
"#;

#[test]
fn the_guides_see_through_smooth_glass() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, GLASS).unwrap();
    let scene = Scene::load(&path).unwrap();
    let job = scene.default_job();
    let (mut film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true).unwrap();
    let centre = film.index(16, 16);
    let corner = film.index(1, 1);
    let before = film.clone();
    // The render's layers record the glass at the centre.
    assert!(before.albedo[centre].y > 0.5, "{}", before.albedo[centre]);
    plsr::integrator::guides::see_through_glass(&scene, &job, &mut film);
    // Behind the glass: the red wall, facing the camera.
    let a = film.albedo[centre];
    assert!(
        (a - glam::Vec3::new(0.8, 0.1, 0.1)).abs().max_element() < 1e-4,
        "{a}"
    );
    assert!(film.normal[centre].z > 0.99, "{}", film.normal[centre]);
    // Where the camera sees the wall directly nothing changes, bit for bit;
    // nor does the colour.
    assert_eq!(film.albedo[corner], before.albedo[corner]);
    assert_eq!(film.normal[corner], before.normal[corner]);
    assert_eq!(film.color, before.color);
    // Without glass, the pass changes nothing.
    let plain = GLASS.replace("type = \"dielectric\"\nior = 1.5", "type = \"diffuse\"");
    std::fs::write(&path, plain).unwrap();
    let scene = Scene::load(&path).unwrap();
    let (mut film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true).unwrap();
    let before = film.clone();
    plsr::integrator::guides::see_through_glass(&scene, &job, &mut film);
    assert_eq!(film.albedo, before.albedo);
    assert_eq!(film.normal, before.normal);
}

/// The renders whose denoising is compared with Intel's OIDN: name, scene,
/// spp, size. The composite's two renders (with and without its virtual
/// objects) are both denoised from the guides of the first, as `plsr
/// composite --denoise` does.
const PARITY_CASES: &[(&str, &str, u32, (u32, u32))] = &[
    (
        "cornell-16",
        "assets/scenes/cornell/cornell.toml",
        16,
        (160, 120),
    ),
    (
        "cornell-64",
        "assets/scenes/cornell/cornell.toml",
        64,
        (160, 120),
    ),
    (
        "cornell-256",
        "assets/scenes/cornell/cornell.toml",
        256,
        (160, 120),
    ),
    (
        "cornell-odd-16",
        "assets/scenes/cornell/cornell.toml",
        16,
        (517, 389),
    ),
    ("glossy-16", "tests/data/denoise/glossy.toml", 16, (160, 80)),
    ("glossy-64", "tests/data/denoise/glossy.toml", 64, (160, 80)),
    (
        "pls-room-16",
        "assets/scenes/pls-room/pls-room.toml",
        16,
        (160, 120),
    ),
    (
        "composite-with-16",
        "assets/scenes/ar-demo/ar-demo.toml",
        16,
        (160, 120),
    ),
    (
        "composite-without-16",
        "assets/scenes/ar-demo/ar-demo.toml",
        16,
        (160, 120),
    ),
];

const PARITY_DIR: &str = "tests/fixtures/denoise";

fn write_f16_gz(path: &std::path::Path, pixels: &[[f32; 3]]) {
    use std::io::Write;
    let mut gz = flate2::write::GzEncoder::new(
        std::fs::File::create(path).unwrap(),
        flate2::Compression::best(),
    );
    for v in pixels.iter().flatten() {
        gz.write_all(&exr::prelude::f16::from_f32(*v).to_le_bytes())
            .unwrap();
    }
    gz.finish().unwrap();
}

fn read_f16_gz(path: &std::path::Path) -> Vec<[f32; 3]> {
    use std::io::Read;
    let mut bytes = Vec::new();
    flate2::read::GzDecoder::new(std::fs::File::open(path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (made by scripts/oidn_render_fixtures.py)",
            path.display()
        )
    }))
    .read_to_end(&mut bytes)
    .unwrap();
    bytes
        .chunks_exact(6)
        .map(|b| {
            let h = |i: usize| exr::prelude::f16::from_le_bytes([b[i], b[i + 1]]).to_f32();
            [h(0), h(2), h(4)]
        })
        .collect()
}

/// Renders the inputs of [`PARITY_CASES`] (colour, albedo and normal as
/// plsr's denoiser is given them, in half floats) into
/// `tests/fixtures/denoise/`, for `scripts/oidn_render_fixtures.py` to
/// filter with OIDN: `cargo test --test it write_denoise_fixtures --
/// --ignored`.
#[test]
#[ignore = "writes the fixtures; run by hand, then scripts/oidn_render_fixtures.py"]
fn write_denoise_fixtures() {
    use plsr::job::RenderJob;
    let dir = std::path::Path::new(PARITY_DIR);
    std::fs::create_dir_all(dir).unwrap();
    let mut list = String::new();
    let mut composite_guides = None;
    for &(name, file, spp, (w, h)) in PARITY_CASES {
        let mut description = plsr::scene::file::load_contents(std::path::Path::new(file))
            .unwrap()
            .description;
        description.camera = description.camera.with_resolution(w, h).unwrap();
        let scene = Scene::build(description).unwrap();
        let job = RenderJob {
            spp,
            hide_virtual: name.starts_with("composite-without"),
            ..scene.default_job()
        };
        let (mut film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true).unwrap();
        if name.starts_with("composite-with-") {
            plsr::integrator::guides::see_through_glass(&scene, &job, &mut film);
            composite_guides = Some((film.albedo.clone(), film.normal.clone(), film.alpha.clone()));
        } else if name.starts_with("composite-without") {
            let (a, n, alpha) = composite_guides
                .clone()
                .expect("the with-render comes first");
            (film.albedo, film.normal, film.alpha) = (a, n, alpha);
        } else {
            plsr::integrator::guides::see_through_glass(&scene, &job, &mut film);
        }
        let guides = film.denoise_guides(&DenoiseSettings::default());
        write_f16_gz(&dir.join(format!("{name}.color.f16.gz")), &guides.color);
        write_f16_gz(
            &dir.join(format!("{name}.albedo.f16.gz")),
            guides.albedo.as_ref().unwrap(),
        );
        write_f16_gz(
            &dir.join(format!("{name}.normal.f16.gz")),
            guides.normal.as_ref().unwrap(),
        );
        list.push_str(&format!("{name} {w} {h}\n"));
    }
    std::fs::write(dir.join("cases.txt"), list).unwrap();
}

#[test]
fn renders_are_denoised_as_oidn_denoises_them() {
    let dir = std::path::Path::new(PARITY_DIR);
    let cases = std::fs::read_to_string(dir.join("cases.txt")).unwrap();
    assert_eq!(cases.lines().count(), PARITY_CASES.len());
    let tone = |v: f32| (f64::from(v.max(0.0)) / (1.0 + f64::from(v.max(0.0)))).powf(1.0 / 2.2);
    for line in cases.lines() {
        let mut fields = line.split_whitespace();
        let name = fields.next().unwrap();
        let w: usize = fields.next().unwrap().parse().unwrap();
        let h: usize = fields.next().unwrap().parse().unwrap();
        let read = |what: &str| read_f16_gz(&dir.join(format!("{name}.{what}.f16.gz")));
        let (color, albedo, normal, theirs) =
            (read("color"), read("albedo"), read("normal"), read("oidn"));
        for (what, image) in [
            ("color", &color),
            ("albedo", &albedo),
            ("normal", &normal),
            ("oidn", &theirs),
        ] {
            assert_eq!(image.len(), w * h, "{name}.{what}");
        }
        let image = |pixels| plsr_denoise::Image {
            pixels,
            width: w,
            height: h,
        };
        let ours = plsr_denoise::denoise(
            image(&color),
            Some(image(&albedo)),
            Some(image(&normal)),
            &plsr_denoise::Options {
                hdr: true,
                clean_aux: false,
                input_scale: None,
            },
        )
        .unwrap();
        let squared = |a: &[[f32; 3]], b: &[[f32; 3]]| {
            a.iter()
                .zip(b)
                .flat_map(|(p, q)| (0..3).map(move |c| (tone(p[c]) - tone(q[c])).powi(2)))
                .sum::<f64>()
                / (a.len() * 3) as f64
        };
        let psnr = 10.0 * (1.0 / squared(&ours, &theirs).max(1e-30)).log10();
        let noisy_psnr = 10.0 * (1.0 / squared(&color, &theirs).max(1e-30)).log10();
        eprintln!("{name} ({w}×{h}): PSNR {psnr:.1} dB against OIDN (the noisy input: {noisy_psnr:.1} dB)");
        // The issue asks for 45 dB; the same network on the same input
        // gives about 90 (the fixtures' half floats bound it).
        assert!(psnr >= 85.0, "{name}: {psnr:.1} dB");
        // Not vacuous: the input itself is far from OIDN's output.
        assert!(
            psnr > noisy_psnr + 20.0,
            "{name}: the input is {noisy_psnr:.1} dB"
        );
    }
}
