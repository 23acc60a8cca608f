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
    assert!(((mean(film.noisy.as_ref().unwrap()) - truth_mean) / truth_mean).abs() < 0.05);
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
