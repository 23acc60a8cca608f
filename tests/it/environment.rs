//! The environment emitter (HDR panorama lighting): importance sampling
//! checked by chi-square, its density integrated, continuity across the
//! seam and at the poles, the white furnace under a constant sky, and a
//! single bright texel lighting a plane as a directional light would.

use plsr_testkit as common;

use common::chi2::{chi2_test, SphereBinning};
use glam::{Vec2, Vec3};
use plsr::equirect::{equirect_direction, SphereFrame};
use plsr::light::EnvironmentLight;
use plsr::render::{render, RenderOptions};
use plsr::rng::Rng;
use plsr::scene::Scene;

const SIGNIFICANCE: f64 = 0.01 / 8.0;

fn tilted_frame() -> SphereFrame {
    SphereFrame::new(Vec3::new(0.2, -0.1, 1.0), Vec3::new(1.0, 0.4, 0.0)).unwrap()
}

/// Test maps: one lit texel, a constant map, a small 3×2 map, and a random
/// 16×8 map, the last two in a tilted frame.
fn maps() -> Vec<(&'static str, EnvironmentLight)> {
    let mut one = vec![Vec3::ZERO; 8 * 4];
    one[8 + 5] = Vec3::new(10.0, 5.0, 1.0);
    let mut rng = Rng::new(3, 4);
    let random: Vec<Vec3> = (0..16 * 8)
        .map(|_| Vec3::splat(rng.next_f32().powi(3) * 10.0))
        .collect();
    vec![
        (
            "one texel",
            EnvironmentLight::from_image(8, 4, one, 1.0, SphereFrame::Z_UP),
        ),
        ("constant", EnvironmentLight::constant(Vec3::ONE)),
        (
            "3×2",
            EnvironmentLight::from_image(
                3,
                2,
                vec![
                    Vec3::splat(1.0),
                    Vec3::splat(4.0),
                    Vec3::splat(0.5),
                    Vec3::splat(2.0),
                    Vec3::ZERO,
                    Vec3::splat(8.0),
                ],
                1.0,
                tilted_frame(),
            ),
        ),
        (
            "random 16×8",
            EnvironmentLight::from_image(16, 8, random, 2.0, tilted_frame()),
        ),
    ]
}

#[test]
fn sampling_matches_the_density_chi_square() {
    for (name, env) in maps().into_iter().chain(bilinear_maps()) {
        let mut rng = Rng::new(17, 2);
        let r = chi2_test(
            SphereBinning {
                theta_bins: 21,
                phi_bins: 41,
                subdivisions: 64,
            },
            300_000,
            |_| env.sample(rng.next_2d()).map(|(_, d, _)| d),
            &|w| env.pdf(w) as f64,
            SIGNIFICANCE,
        );
        assert!(r.passed, "{name}: {}", r.summary);
    }
}

/// Maps looked up bilinearly: one lit texel, and the random 16×8 map, with
/// rows at texel centres and pole to pole (Mitsuba's layout).
fn bilinear_maps() -> Vec<(&'static str, EnvironmentLight)> {
    let mut maps = maps();
    let random = maps.pop().expect("four maps").1;
    let one = maps.swap_remove(0).1;
    vec![
        ("one texel, bilinear", one.clone().with_bilinear(true)),
        ("random 16×8, bilinear", random.clone().with_bilinear(true)),
        (
            "one texel, bilinear, rows at the poles",
            one.with_bilinear(true).with_rows_at_poles(true),
        ),
        (
            "random 16×8, bilinear, rows at the poles",
            random.with_bilinear(true).with_rows_at_poles(true),
        ),
    ]
}

/// `rows = "poles"`: the first and last rows' centres are the zenith and
/// the nadir, row `y` at `v = y/(h − 1)`, as Mitsuba's `envmap` reads its
/// image; between rows the lookup interpolates, and samples carry what a
/// lookup of their direction gives.
#[test]
fn rows_at_the_poles_put_the_first_and_last_rows_on_the_poles() {
    let (w, h) = (4u32, 3u32);
    let texels: Vec<Vec3> = (0..w * h).map(|i| Vec3::splat(1.0 + i as f32)).collect();
    let env = EnvironmentLight::from_image(w, h, texels, 1.0, SphereFrame::Z_UP)
        .with_bilinear(true)
        .with_rows_at_poles(true);
    let at = |u: f32, v: f32| env.radiance(equirect_direction(Vec2::new(u, v), &SphereFrame::Z_UP));
    let close = |a: Vec3, b: f32| (a - Vec3::splat(b)).abs().max_element() < 1e-4;
    // Column 0 holds 1, 5, 9 from the top: row 0 at v = 0 (just below the
    // zenith), row 1 at v = ½, row 2 at v = 1; a quarter of the way is a
    // quarter of the way between rows 0 and 1.
    assert!(close(at(0.125, 1e-6), 1.0), "{}", at(0.125, 1e-6));
    assert!(close(at(0.125, 0.5), 5.0), "{}", at(0.125, 0.5));
    assert!(
        close(at(0.125, 1.0 - 1e-6), 9.0),
        "{}",
        at(0.125, 1.0 - 1e-6)
    );
    assert!(close(at(0.125, 0.25), 3.0), "{}", at(0.125, 0.25));
    // With rows at texel centres, v = ¼ is row 0's lower half: row 0 and
    // a quarter of row 1 (v·h − ½ = 0.25).
    let centred = EnvironmentLight::from_image(
        w,
        h,
        (0..w * h).map(|i| Vec3::splat(1.0 + i as f32)).collect(),
        1.0,
        SphereFrame::Z_UP,
    )
    .with_bilinear(true);
    let c = centred.radiance(equirect_direction(
        Vec2::new(0.125, 0.25),
        &SphereFrame::Z_UP,
    ));
    assert!(close(c, 2.0), "{c}");
    let mut rng = Rng::new(3, 9);
    for _ in 0..2000 {
        let (l, d, pdf) = env.sample(rng.next_2d()).unwrap();
        let r = env.radiance(d);
        assert!(
            (l - r).abs().max_element() <= 1e-3 * r.max_element(),
            "{l} vs {r}"
        );
        assert!(
            (pdf - env.pdf(d)).abs() <= 1e-3 * pdf,
            "{pdf} vs {}",
            env.pdf(d)
        );
    }
}

/// Looked up bilinearly, a lit texel's radiance reaches into its
/// neighbours; light sampling must reach there too, with a density that
/// keeps radiance ÷ density bounded (else a small bright source, a sun,
/// is found there only by BSDF sampling: fireflies). Weighing each texel by
/// its own luminance gave those directions density 0.
#[test]
fn bilinear_sampling_covers_the_interpolated_radiance() {
    for (name, env) in bilinear_maps() {
        let integral = env.luminance_integral();
        let mut rng = Rng::new(23, 1);
        let mut lit = 0;
        for _ in 0..200_000 {
            let d = plsr::warp::square_to_uniform_sphere(rng.next_2d());
            let l = plsr::color::luminance(env.radiance(d));
            if l <= 0.0 {
                continue;
            }
            lit += 1;
            let pdf = env.pdf(d);
            assert!(pdf > 0.0, "{name}: radiance {l} but density 0 at {d}");
            assert!(
                l / pdf <= 20.0 * integral,
                "{name}: radiance {l} ÷ density {pdf} at {d}, ∫L = {integral}"
            );
        }
        assert!(lit > 1000, "{name}: only {lit} lit directions");
    }
}

#[test]
fn samples_carry_their_own_density_and_radiance() {
    for (name, env) in maps() {
        let mut rng = Rng::new(5, 5);
        for _ in 0..10_000 {
            let Some((l, d, pdf)) = env.sample(rng.next_2d()) else {
                panic!("{name}: a lit map always samples")
            };
            assert!((d.length() - 1.0).abs() < 1e-5);
            let p = env.pdf(d);
            // The density has 1/sin θ in it: near a pole, `v` recovered from
            // the direction may differ from the sample's own by a few ulp of
            // `v` (≈ 6e-8 each near 1), a relative change of π·Δv / sin θ
            // in the density.
            let sin_polar = d.cross(env.frame.up).length();
            let rounding = std::f32::consts::PI * 3.0 * f32::EPSILON / sin_polar;
            assert!(
                (p - pdf).abs() <= (1e-3 + rounding) * pdf,
                "{name}: pdf {pdf} vs {p} at {d}"
            );
            assert_eq!(l, env.radiance(d), "{name}");
            assert!(l != Vec3::ZERO, "{name}: sampled a black texel");
        }
    }
}

#[test]
fn density_integrates_to_one_and_the_integral_is_right() {
    for (name, env) in maps() {
        // Midpoint rule in (u, v) over the image: dω = 2π² sin(πv) du dv.
        let (nu, nv) = (720, 360);
        let (mut pdf_sum, mut lum_sum) = (0.0f64, 0.0f64);
        for j in 0..nv {
            let v = (j as f32 + 0.5) / nv as f32;
            let dw = 2.0 * std::f64::consts::PI.powi(2) * (std::f64::consts::PI * v as f64).sin()
                / (nu * nv) as f64;
            for i in 0..nu {
                let d = equirect_direction(Vec2::new((i as f32 + 0.5) / nu as f32, v), &env.frame);
                pdf_sum += env.pdf(d) as f64 * dw;
                lum_sum += plsr::color::luminance(env.radiance(d)) as f64 * dw;
            }
        }
        assert!((pdf_sum - 1.0).abs() < 2e-3, "{name}: ∫pdf = {pdf_sum}");
        let want = env.luminance_integral() as f64;
        assert!(
            (lum_sum - want).abs() < 2e-3 * want,
            "{name}: ∫L = {lum_sum} vs {want}"
        );
    }
}

#[test]
fn seam_and_poles_are_well_behaved() {
    let (_, env) = maps().pop().unwrap();
    let f = env.frame;
    // Either side of the seam (behind, u = 0 and u → 1) belong to the first
    // and last columns; both are finite and positive where lit.
    for v in [0.1f32, 0.5, 0.9] {
        for u in [1e-6f32, 1.0 - 1e-6] {
            let d = equirect_direction(Vec2::new(u, v), &f);
            let (l, p) = (env.radiance(d), env.pdf(d));
            assert!(
                l.is_finite() && p.is_finite() && p >= 0.0,
                "u={u} v={v}: {l} {p}"
            );
        }
        // Exactly on the seam (−forward tilted by v), no gap.
        let d = equirect_direction(Vec2::new(0.0, v), &f);
        assert!(env.pdf(d).is_finite() && env.radiance(d).is_finite());
    }
    // Near and at the poles: finite densities, no NaN.
    for d in [
        f.up,
        -f.up,
        (f.up + 1e-4 * f.forward).normalize(),
        (-f.up + 1e-4 * f.right).normalize(),
    ] {
        let p = env.pdf(d);
        assert!(p.is_finite() && p >= 0.0, "pole {d}: pdf {p}");
        assert!(env.radiance(d).is_finite());
    }
    // Sampling never returns a direction at an exact pole or a NaN.
    let mut rng = Rng::new(1, 1);
    for _ in 0..100_000 {
        let (_, d, p) = env.sample(rng.next_2d()).unwrap();
        assert!(d.is_finite() && p.is_finite() && p > 0.0);
    }
}

fn scene_in(dir: &std::path::Path, text: &str) -> Scene {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn constant_environment_white_furnace() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_in(
        dir.path(),
        r#"
[render]
spp = 64
max_depth = 32
seed = 2

[camera]
position = [0, -3, 0.5]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov = 60
resolution = [24, 24]

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
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    let mean = film.mean_color();
    assert!((mean.x - 1.0).abs() < 0.01, "furnace mean {mean}");
    for (i, (c, v)) in film.color.iter().zip(&film.variance).enumerate() {
        let tol = 5.0 * v.x.sqrt() + 1e-4;
        assert!((c.x - 1.0).abs() <= tol, "pixel {i}: {c} ± {v}");
    }
    // The sphere covers the centre, the sky the corners.
    assert_eq!(film.alpha[film.index(12, 12)], 1.0);
    assert_eq!(film.alpha[film.index(0, 0)], 0.0);
}

#[test]
fn one_bright_texel_lights_a_plane_like_a_directional_light() {
    // A 16×8 black panorama (z up) with one texel lit, written as EXR; a
    // large diffuse floor at z = 0 seen from above. Direct light only.
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (16u32, 8u32);
    let (tx, ty) = (11u32, 2u32); // 22.5°–45° above the horizon
    let radiance = 50.0f32;
    let mut film = plsr::film::Film::new(w, h);
    film.color[(ty * w + tx) as usize] = Vec3::splat(radiance);
    film.spp = 1;
    film.write_exr(&dir.path().join("sky.exr")).unwrap();
    let scene = scene_in(
        dir.path(),
        r#"
[render]
spp = 256
max_depth = 1
seed = 9

[camera]
position = [0, 0, 3]
look_at = [0, 0, 0]
up = [0, 1, 0]
vfov = 20
resolution = [8, 8]

[environment]
file = "sky.exr"
up = [0, 0, 1]
forward = [0, 1, 0]

[[materials]]
name = "floor"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "rectangle"
material = "floor"
transform = { scale = 50 }
"#,
    );
    let out = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    // Irradiance from the texel: ∫ L cos θz dω over its patch of the sphere,
    // with elevation e: cos θz = sin e, dω = cos e de dφ.
    let (e0, e1) = (
        std::f64::consts::PI * (0.5 - (ty + 1) as f64 / h as f64),
        std::f64::consts::PI * (0.5 - ty as f64 / h as f64),
    );
    let dphi = 2.0 * std::f64::consts::PI / w as f64;
    let irradiance = radiance as f64 * dphi * 0.5 * (e1.sin().powi(2) - e0.sin().powi(2));
    let want = 0.5 / std::f64::consts::PI * irradiance;
    let got = out.mean_color().x as f64;
    assert!(
        (got - want).abs() < 0.02 * want,
        "floor radiance {got}, directional estimate {want}"
    );
}

#[test]
fn environment_errors_name_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let base = "[camera]\nposition = [0, -3, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 40\nresolution = [4, 4]\n";
    let cases = [
        (
            "[environment]\nradiance = [1, 1, 1]\nfile = \"x.exr\"",
            "environment.radiance",
            "not both",
        ),
        (
            "[environment]\nscale = 2",
            "environment.file",
            "give an image",
        ),
        (
            "[environment]\nfile = \"missing.exr\"\nup = [0, 0, 1]\nforward = [0, 1, 0]",
            "environment.file",
            "not found",
        ),
        (
            "[environment]\nfile = \"x.exr\"\nforward = [0, 1, 0]",
            "environment.up",
            "required",
        ),
        (
            "[environment]\nfile = \"x.exr\"\nup = [0, 0, 1]\nforward = [0, 0, 2]",
            "environment.forward",
            "parallel",
        ),
        (
            "[environment]\nradiance = [1, 1, 1]\nup = [0, 0, 1]",
            "environment.up",
            "only used",
        ),
        (
            "[environment]\nradiance = [1, 1, 1]\nscale = -1",
            "environment.scale",
            "negative",
        ),
        (
            "[environment]\nfile = \"sky.png\"\nup = [0, 0, 1]\nforward = [0, 1, 0]",
            "environment.file",
            "unsupported",
        ),
    ];
    std::fs::write(dir.path().join("x.exr"), b"not an exr").unwrap();
    std::fs::write(dir.path().join("sky.png"), b"png").unwrap();
    for (section, field, fault) in cases {
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, format!("{base}\n{section}\n")).unwrap();
        let e = match Scene::load(&path) {
            Ok(_) => panic!("`{section}` should be refused"),
            Err(e) => e.to_string(),
        };
        assert!(
            e.contains("scene.toml") && e.contains(field) && e.contains(fault),
            "`{section}`: {e}"
        );
    }
}

#[test]
fn equirect_camera_sees_the_environment_texel_for_texel() {
    // The 360° camera and the environment share one convention: a camera at
    // the environment's orientation, with its resolution, records the
    // panorama back exactly (each pixel sees only its own texel).
    let dir = tempfile::tempdir().unwrap();
    let (w, h) = (16u32, 8u32);
    let mut sky = plsr::film::Film::new(w, h);
    let mut rng = Rng::new(8, 8);
    for c in sky.color.iter_mut() {
        *c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 4.0;
    }
    sky.spp = 1;
    sky.write_exr(&dir.path().join("sky.exr")).unwrap();
    let scene = scene_in(
        dir.path(),
        r#"
[render]
spp = 4

[camera]
type = "equirectangular"
position = [0, 0, 0]
look_at = [0, 1, 0]
up = [0, 0, 1]
resolution = [16, 8]

[environment]
file = "sky.exr"
up = [0, 0, 1]
forward = [0, 1, 0]
"#,
    );
    let out = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    for (i, (got, want)) in out.color.iter().zip(&sky.color).enumerate() {
        assert!(
            (*got - *want).abs().max_element() < 1e-5,
            "pixel {i}: {got} vs texel {want}"
        );
    }
}

/// `filter = "bilinear"`: texel centres keep their texels, points between
/// them interpolate (wrapping round the seam, clamped at the poles), the
/// samples carry the interpolated radiance, and both integrators render
/// the same image.
#[test]
fn bilinear_lookup_interpolates_between_texel_centres() {
    let (w, h) = (4u32, 2u32);
    let texels: Vec<Vec3> = (0..w * h).map(|i| Vec3::splat(1.0 + i as f32)).collect();
    let env = EnvironmentLight::from_image(w, h, texels.clone(), 1.0, SphereFrame::Z_UP)
        .with_bilinear(true);
    let at = |u: f32, v: f32| env.radiance(equirect_direction(Vec2::new(u, v), &SphereFrame::Z_UP));
    let close = |a: Vec3, b: f32| (a - Vec3::splat(b)).abs().max_element() < 1e-4;
    // Texel centres of the top row: 1, 2, 3, 4.
    for x in 0..4 {
        assert!(close(at((x as f32 + 0.5) / 4.0, 0.25), 1.0 + x as f32));
    }
    // Between columns 1 and 2 (values 2 and 3), and across the seam
    // (columns 3 and 0: 4 and 1).
    assert!(close(at(0.5, 0.25), 2.5));
    assert!(
        close(at(0.999, 0.25), 4.0 - 3.0 * 0.496), // 0.496 of the way from column 3 to 0
        "{}",
        at(0.999, 0.25)
    );
    // Between the rows (top 1, bottom 5 in column 0): halfway at v = 0.5;
    // above the top row's centres, clamped to the top row.
    assert!(close(at(0.125, 0.5), 3.0));
    assert!(close(at(0.125, 0.05), 1.0));
    // Samples carry the interpolated radiance of their direction.
    let mut rng = Rng::new(1, 2);
    for _ in 0..2000 {
        let (l, d, _) = env.sample(rng.next_2d()).unwrap();
        let r = env.radiance(d);
        assert!(
            (l - r).abs().max_element() <= 1e-3 * r.max_element(),
            "{l} vs {r}"
        );
    }
    // Nearest and bilinear differ; the kernel and the general integrator
    // agree bit for bit on a bilinear sky.
    let dir = tempfile::tempdir().unwrap();
    let mut sky = plsr::film::Film::new(16, 8);
    let mut rng = Rng::new(7, 7);
    for c in &mut sky.color {
        *c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 3.0;
    }
    sky.write_exr(&dir.path().join("sky.exr")).unwrap();
    let scene_text = |filter: &str| {
        format!(
            "[render]\nspp = 8\nmax_depth = 3\n[camera]\nposition = [0, -3, 1]\nlook_at = [0, 0, 0.5]\n\
             up = [0, 0, 1]\nvfov = 60\nresolution = [16, 12]\n[environment]\nfile = \"sky.exr\"\n\
             up = [0, 0, 1]\nforward = [0, 1, 0]\nfilter = \"{filter}\"\n[[shapes]]\ntype = \"sphere\"\n\
             center = [0, 0, 0.5]\nradius = 0.5\n[[shapes]]\ntype = \"rectangle\"\ntransform = {{ scale = 3 }}\n"
        )
    };
    let render_it = |filter: &str, vectorised: bool| {
        let scene = scene_in(dir.path(), &scene_text(filter));
        let options = RenderOptions {
            vectorised,
            ..Default::default()
        };
        render(&scene, &scene.default_job(), &options, &|_, _| true)
            .unwrap()
            .0
    };
    let bilinear = render_it("bilinear", true);
    assert!(bilinear.bitwise_eq(&render_it("bilinear", false)));
    assert!(!bilinear.bitwise_eq(&render_it("nearest", true)));
}
