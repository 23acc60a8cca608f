//! Analytic radiometry: the white furnace and closed-form irradiance from a
//! rectangular Lambertian emitter.

use glam::{Mat4, Vec3};
use plsr::bsdf::Bsdf;
use plsr::camera::PinholeCamera;
use plsr::film::Film;
use plsr::job::RenderJob;
use plsr::render::{render, RenderOptions};
use plsr::scene::shapes::{disk, flip_winding, icosphere, rectangle, transform_mesh};
use plsr::scene::{Emission, Material, Mesh, Scene, SceneDescription};

fn material(name: &str, albedo: f32) -> Material {
    Material {
        name: name.into(),
        bsdf: Bsdf::diffuse(Vec3::splat(albedo)),
        textures: Default::default(),
        two_sided: true,
        composite: None,
    }
}

fn mesh(
    name: &str,
    (positions, triangles): (Vec<Vec3>, Vec<[u32; 3]>),
    material: u32,
    emission: Option<Emission>,
) -> Mesh {
    Mesh {
        emission,
        ..Mesh::new(name, positions, triangles, material, 0).unwrap()
    }
}

fn render_scene(desc: SceneDescription) -> Film {
    let scene = Scene::build(desc).unwrap();
    render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0
}

/// A diffuse sphere of albedo 1 inside an enclosure of uniform radiance 1
/// (that reflects nothing) must look exactly like the enclosure: radiance 1
/// everywhere, whatever the viewpoint.
#[test]
fn white_furnace() {
    let (p, mut t) = icosphere(Vec3::ZERO, 10.0, 3);
    flip_winding(&mut t); // emit inwards
    let enclosure = mesh(
        "enclosure",
        (p, t),
        0,
        Some(Emission {
            radiance: Vec3::ONE,
            two_sided: false,
            cone: None,
        }),
    );
    let sphere = mesh("sphere", icosphere(Vec3::ZERO, 1.0, 4), 1, None);
    let film = render_scene(SceneDescription {
        meshes: vec![enclosure, sphere],
        materials: vec![material("black", 0.0), material("white", 1.0)],
        point_lights: vec![],
        camera: PinholeCamera::look_at(
            Vec3::new(0.0, -3.0, 0.5),
            Vec3::ZERO,
            Vec3::Z,
            60.0,
            24,
            24,
        )
        .unwrap()
        .into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: None,
        job: RenderJob {
            spp: 64,
            max_depth: 16,
            seed: 3,
            sample_start: 0,
            hide_virtual: false,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    });
    // The sphere fills the middle of the image.
    let centre = film.index(12, 12);
    assert_eq!(film.object_id[centre], 0.0);
    let mean = film.mean_color();
    for c in mean.to_array() {
        assert!((c - 1.0).abs() < 0.01, "furnace mean {mean}");
    }
    // Every pixel agrees with 1 within 5 of its own standard errors (plus
    // a floor for pixels whose estimate has no variance).
    for (i, (c, v)) in film.color.iter().zip(&film.variance).enumerate() {
        for k in 0..3 {
            let tol = 5.0 * v[k].sqrt() + 1e-4;
            assert!((c[k] - 1.0).abs() <= tol, "pixel {i}: {c} ± {v}");
        }
    }
}

/// Irradiance at a point at height 0 below one corner of an `a × b` rectangle
/// parallel to the plane at height `h`, of radiance `l` (form factor of a
/// differential area to a parallel rectangle, e.g. Howell's catalogue, C-11).
fn corner_irradiance(a: f64, b: f64, h: f64, l: f64) -> f64 {
    let (x, y) = (a / h, b / h);
    let f = (x / (1.0 + x * x).sqrt() * (y / (1.0 + x * x).sqrt()).atan()
        + y / (1.0 + y * y).sqrt() * (x / (1.0 + y * y).sqrt()).atan())
        / (2.0 * std::f64::consts::PI);
    std::f64::consts::PI * l * f
}

/// Irradiance at `(px, py, 0)` from the rectangle `[x0, x1] × [y0, y1]` at
/// height `h`, by superposition of corner rectangles.
fn rectangle_irradiance(
    px: f64,
    py: f64,
    (x0, x1, y0, y1): (f64, f64, f64, f64),
    h: f64,
    l: f64,
) -> f64 {
    let signed = |dx: f64, dy: f64| -> f64 {
        dx.signum() * dy.signum() * corner_irradiance(dx.abs(), dy.abs(), h, l)
    };
    signed(x1 - px, y1 - py) - signed(x0 - px, y1 - py) - signed(x1 - px, y0 - py)
        + signed(x0 - px, y0 - py)
}

/// Direct light only (2048 spp, depth 1) on a 20 × 20 diffuse floor of
/// `albedo` at z = 0 under `emitter`, a black emitter of `radiance`, seen by
/// `camera`.
fn floor_under_emitter(
    emitter: (Vec<Vec3>, Vec<[u32; 3]>),
    radiance: f32,
    albedo: f32,
    camera: PinholeCamera,
    seed: u64,
) -> Film {
    let (mut fp, mut ft) = rectangle();
    transform_mesh(&Mat4::from_scale(Vec3::splat(10.0)), &mut fp, &mut ft);
    render_scene(SceneDescription {
        meshes: vec![
            mesh("floor", (fp, ft), 1, None),
            mesh(
                "emitter",
                emitter,
                0,
                Some(Emission {
                    radiance: Vec3::splat(radiance),
                    two_sided: false,
                    cone: None,
                }),
            ),
        ],
        materials: vec![material("black", 0.0), material("floor", albedo)],
        point_lights: vec![],
        camera: camera.into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: None,
        job: RenderJob {
            spp: 2048,
            max_depth: 1,
            seed,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    })
}

/// The mean red value of a film and its standard error (from the variance
/// layer).
fn mean_and_stderr(film: &Film) -> (f64, f64) {
    let n = film.color.len() as f64;
    let mean = film.color.iter().map(|c| c.x as f64).sum::<f64>() / n;
    let var = film.variance.iter().map(|v| v.x as f64).sum::<f64>();
    (mean, var.sqrt() / n)
}

#[test]
fn closed_form_irradiance_under_a_rectangular_emitter() {
    let (albedo, radiance, h) = (0.5f32, 3.0f32, 1.0f32);
    // Emitter [−0.5, 0.5] × [−0.25, 0.25] at z = h, facing down.
    let (mut ep, mut et) = rectangle();
    transform_mesh(
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, h))
            * Mat4::from_rotation_x(std::f32::consts::PI)
            * Mat4::from_scale(Vec3::new(0.5, 0.25, 1.0))),
        &mut ep,
        &mut et,
    );
    for (px, py) in [(0.0f32, 0.0f32), (0.4, 0.1), (1.2, -0.7)] {
        // A narrow camera looking down at (px, py) from below the emitter's
        // height, off to the side so it does not shadow the point.
        let target = Vec3::new(px, py, 0.0);
        let eye = target + Vec3::new(0.05, -0.3, 0.6);
        let camera = PinholeCamera::look_at(eye, target, Vec3::Z, 0.5, 5, 5).unwrap();
        let film = floor_under_emitter((ep.clone(), et.clone()), radiance, albedo, camera, 9);
        let (mean, stderr) = mean_and_stderr(&film);
        let e = rectangle_irradiance(
            px as f64,
            py as f64,
            (-0.5, 0.5, -0.25, 0.25),
            h as f64,
            radiance as f64,
        );
        let want = albedo as f64 / std::f64::consts::PI * e;
        assert!(
            (mean - want).abs() < 0.02 * want,
            "at ({px}, {py}): rendered {mean:.5} ± {stderr:.5}, closed form {want:.5}"
        );
        // The film's variance estimate is consistent with the error too.
        assert!(
            (mean - want).abs() < 5.0 * stderr + 1e-3 * want,
            "{mean} vs {want} ± {stderr}"
        );
        eprintln!(
            "irradiance at ({px}, {py}): rendered {mean:.5} ± {stderr:.5}, closed form {want:.5}"
        );
    }
}

/// A Lambertian disk of radius R and radiance L gives, on its axis at
/// distance h, irradiance π·L·R²/(h² + R²): the `disk` shape (a fan of 128
/// triangles, 0.04 % less area than the round disk) as an area light.
#[test]
fn closed_form_irradiance_on_the_axis_of_a_disk_emitter() {
    let (albedo, radiance, h, r) = (0.5f32, 2.0f32, 0.8f32, 0.6f32);
    let (p, t, _) = disk(128);
    let (mut ep, mut et) = (p, t);
    transform_mesh(
        &(Mat4::from_translation(Vec3::new(0.0, 0.0, h))
            * Mat4::from_rotation_x(std::f32::consts::PI)
            * Mat4::from_scale(Vec3::new(r, r, 1.0))),
        &mut ep,
        &mut et,
    );
    let target = Vec3::ZERO;
    let eye = target + Vec3::new(0.02, -0.1, 0.3);
    let camera = PinholeCamera::look_at(eye, target, Vec3::Z, 0.3, 5, 5).unwrap();
    let film = floor_under_emitter((ep, et), radiance, albedo, camera, 3);
    let (mean, stderr) = mean_and_stderr(&film);
    let (h, r, l) = (h as f64, r as f64, radiance as f64);
    let e = std::f64::consts::PI * l * r * r / (h * h + r * r);
    let want = albedo as f64 / std::f64::consts::PI * e;
    assert!(
        (mean - want).abs() < 0.01 * want && (mean - want).abs() < 5.0 * stderr + 1e-3 * want,
        "rendered {mean:.5} ± {stderr:.5}, closed form {want:.5}"
    );
}

/// A point light gives irradiance I cos θ / r² on a plane: the inverse-square
/// law, which Embree's demo scene relies on.
#[test]
fn point_light_inverse_square_law() {
    for (height, px) in [(1.0f32, 0.0f32), (2.0, 0.0), (2.0, 1.5)] {
        let got = floor_lit_by(
            plsr::light::PointLight::isotropic(Vec3::new(0.0, 0.0, height), Vec3::splat(5.0)),
            px,
        );
        let r2 = height * height + px * px;
        let cos = height / r2.sqrt();
        let want = 0.7 / std::f32::consts::PI * 5.0 * cos / r2;
        assert!(
            (got - want).abs() < 0.005 * want,
            "h={height}, x={px}: {got} vs {want}"
        );
    }
}

/// The radiance of a diffuse floor (albedo 0.7, `z = 0`) lit by `light`
/// alone, seen at `(px, 0, 0)` by a narrow camera (the red channel of the
/// centre of 3 × 3 pixels, 4 spp, direct light only).
fn floor_lit_by(light: plsr::light::PointLight, px: f32) -> f32 {
    let (mut fp, mut ft) = rectangle();
    transform_mesh(&Mat4::from_scale(Vec3::splat(20.0)), &mut fp, &mut ft);
    let target = Vec3::new(px, 0.0, 0.0);
    let camera = PinholeCamera::look_at(
        target + Vec3::new(0.0, -0.5, 0.5),
        target,
        Vec3::Z,
        0.5,
        3,
        3,
    )
    .unwrap();
    let film = render_scene(SceneDescription {
        meshes: vec![mesh("floor", (fp, ft), 0, None)],
        materials: vec![material("floor", 0.7)],
        point_lights: vec![light],
        camera: camera.into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: None,
        job: RenderJob {
            spp: 4,
            max_depth: 1,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    });
    film.color[film.index(1, 1)].x
}

/// A spot light as Mitsuba 3.9.1's `spot` computes it (`sample_direction`
/// in `scalar_rgb`: cutoff 30°, beam 10°, intensity (2, 3, 4), at (1, 2, 3)
/// looking at (1, 2, 0)): `I·falloff/r²`, full inside the beam, linear in
/// angle to the cutoff, nothing beyond.
#[test]
fn spot_light_matches_mitsubas_numbers() {
    let light = plsr::light::PointLight {
        position: Vec3::new(1.0, 2.0, 3.0),
        intensity: Vec3::new(2.0, 3.0, 4.0),
        cone: Some(plsr::light::spot_cone(
            -Vec3::Z,
            30f32.to_radians(),
            10f32.to_radians(),
        )),
        projection: None,
    };
    for (p, want) in [
        ([1.0, 2.0, 0.0], [0.222_222_24, 0.333_333_37, 0.444_444_48]),
        ([1.2, 2.1, 0.0], [0.220_994_49, 0.331_491_74, 0.441_988_97]),
        ([2.0, 2.0, 0.5], [0.113_084_02, 0.169_626_03, 0.226_168_04]),
    ] {
        let s = light.sample_li(Vec3::from_array(p)).unwrap();
        let got = s.radiance.to_array();
        for k in 0..3 {
            assert!(
                (got[k] - want[k]).abs() < 2e-6 * want[k].max(1.0),
                "{p:?}: {got:?} vs {want:?}"
            );
        }
        assert!(s.delta && s.pdf == 1.0);
    }
    // Beyond the cutoff (31° and 34° off the axis): no light.
    assert!(light.sample_li(Vec3::new(1.0, 3.2, 1.0)).is_none());
    assert!(light.sample_li(Vec3::new(3.0, 2.0, 0.0)).is_none());
    // It emits I·∫ window dω: numerically, 2π ∫ W(θ) sin θ dθ.
    let cone = light.cone.unwrap();
    let n = 200_000;
    let integral: f64 = (0..n)
        .map(|i| {
            let theta = std::f64::consts::PI * (i as f64 + 0.5) / n as f64;
            let u = Vec3::new(theta.sin() as f32, 0.0, -theta.cos() as f32);
            cone.window(u) as f64 * theta.sin() * std::f64::consts::PI / n as f64
        })
        .sum::<f64>()
        * std::f64::consts::TAU;
    let lum = plsr::color::luminance(light.intensity) as f64;
    assert!(
        (light.emitted_power() as f64 - integral * lum).abs() < 1e-4 * integral * lum,
        "{} vs {}",
        light.emitted_power(),
        integral * lum
    );
}

/// A spot light over a diffuse floor, rendered: inside the beam the floor
/// is lit as by a point light, on the edge by the linear fall-off, beyond
/// the cutoff not at all.
#[test]
fn spot_light_lights_the_floor_inside_its_cone() {
    let height = 2.0f32;
    let (cutoff, beam) = (40f32, 20f32);
    for px in [0.3f32, 1.2, 2.5] {
        let got = floor_lit_by(
            plsr::light::PointLight {
                position: Vec3::new(0.0, 0.0, height),
                intensity: Vec3::splat(5.0),
                cone: Some(plsr::light::spot_cone(
                    -Vec3::Z,
                    cutoff.to_radians(),
                    beam.to_radians(),
                )),
                projection: None,
            },
            px,
        );
        let r2 = height * height + px * px;
        let cos = height / r2.sqrt();
        let theta = (px / height).atan().to_degrees();
        let falloff = ((cutoff - theta) / (cutoff - beam)).clamp(0.0, 1.0);
        let want = 0.7 / std::f32::consts::PI * 5.0 * falloff * cos / r2;
        assert!(
            (got - want).abs() <= 0.005 * want + 1e-7,
            "x={px} ({theta:.1}°): {got} vs {want}"
        );
    }
}

/// A directional light over a diffuse floor, from a scene file: the
/// floor's radiance is `ρ/π · E · cos θ` everywhere, whatever the distance.
#[test]
fn directional_light_lights_a_floor_by_the_cosine_law() {
    let dir = tempfile::tempdir().unwrap();
    for (angle, seed) in [(0.0f32, 1u64), (50.0, 2)] {
        let (s, c) = angle.to_radians().sin_cos();
        let scene = dir.path().join(format!("d{seed}.toml"));
        std::fs::write(
            &scene,
            format!(
                "[render]\nspp = 4\nmax_depth = 1\nseed = {seed}\n\
                 [camera]\nposition = [0, -1, 4]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 20\nresolution = [8, 8]\n\
                 [[materials]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\
                 [[shapes]]\ntype = \"rectangle\"\nmaterial = \"floor\"\ntransform = {{ scale = 20 }}\n\
                 [[lights]]\ntype = \"directional\"\ndirection = [{s}, 0, {m}]\nirradiance = [2, 3, 4]\n",
                m = -c
            ),
        )
        .unwrap();
        let film = render_scene(plsr::scene::file::load(&scene).unwrap());
        for (k, e) in [2.0f32, 3.0, 4.0].into_iter().enumerate() {
            let want = 0.7 / std::f32::consts::PI * e * c;
            for px in &film.color {
                let got = px.to_array()[k];
                assert!(
                    (got - want).abs() < 1e-4 * want,
                    "{angle}°: {got} vs {want}"
                );
            }
        }
    }
}

/// A thin dielectric sheet with untinted lobes reflects `R′` and transmits
/// `1 − R′`: in a uniform sky every path ends in the sky with weight 1, so
/// a sphere of it (two sheets on every line of sight) is invisible; tinted
/// transmission darkens it by the tint twice where both walls are seen.
#[test]
fn thin_dielectric_sphere_in_a_furnace_is_invisible() {
    let dir = tempfile::tempdir().unwrap();
    let text = |transmittance: f32| {
        format!(
            "[render]\nspp = 16\nmax_depth = 16\nrr_depth = 100\n\
             [camera]\nposition = [0, -4, 0]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 20\nresolution = [8, 8]\n\
             [environment]\nradiance = [1, 1, 1]\n\
             [[materials]]\nname = \"sheet\"\ntype = \"thin_dielectric\"\nior = 1.5\n\
             specular_transmittance = [{transmittance}, {transmittance}, {transmittance}]\n\
             [[shapes]]\ntype = \"sphere\"\nmaterial = \"sheet\"\n"
        )
    };
    let path = dir.path().join("t.toml");
    std::fs::write(&path, text(1.0)).unwrap();
    let film = render_scene(plsr::scene::file::load(&path).unwrap());
    for c in &film.color {
        assert!((c.x - 1.0).abs() < 1e-5, "{c}");
    }
    // Through the centre, a ray passes both walls or is mirrored by the
    // first: with transmittance 0.5 the centre pixel is R′ + (1 − R′)·(…)
    // < 1, and never below 0.25.
    std::fs::write(&path, text(0.5)).unwrap();
    let film = render_scene(plsr::scene::file::load(&path).unwrap());
    let centre = film.color[film.index(4, 4)].x;
    assert!(centre < 0.9 && centre > 0.25, "{centre}");
}

/// A smooth glass sphere under a uniform sky of radiance 1, rendered with
/// Russian roulette from `rr_depth` on: the film, and the pixels the sphere
/// covers.
fn glass_sphere_in_a_furnace(spp: u32, rr_depth: u32) -> (Film, Vec<usize>) {
    use plsr::bsdf::DielectricParams;
    use plsr::light::EnvironmentLight;
    let glass = Material {
        name: "glass".into(),
        bsdf: Bsdf::Dielectric(DielectricParams {
            eta: 1.5,
            microfacet: None,
        }),
        textures: Default::default(),
        two_sided: true,
        composite: None,
    };
    let sphere = mesh("sphere", icosphere(Vec3::ZERO, 1.0, 4), 0, None);
    let film = render_scene(SceneDescription {
        meshes: vec![sphere],
        materials: vec![glass],
        point_lights: vec![],
        camera: PinholeCamera::look_at(
            Vec3::new(0.0, -3.0, 0.5),
            Vec3::ZERO,
            Vec3::Z,
            50.0,
            16,
            16,
        )
        .unwrap()
        .into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: Some(EnvironmentLight::constant(Vec3::ONE)),
        job: RenderJob {
            spp,
            // The sphere is a polyhedron (flat facets): total internal
            // reflection can keep a path inside for dozens of bounces,
            // hence the deep `max_depth`.
            max_depth: 1024,
            seed: 5,
            rr_depth,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    });
    let centre = film.index(8, 8);
    assert_eq!(film.object_id[centre], 0.0, "the sphere fills the middle");
    let on_sphere = (0..film.color.len())
        .filter(|&i| film.object_id[i] == 0.0)
        .collect();
    (film, on_sphere)
}

/// The mean over `pixels` of `film`'s colour, its standard error, and the
/// mean variance of one sample (the variance layer times spp).
fn mean_and_sample_variance(film: &Film, pixels: &[usize]) -> (f64, f64, f64) {
    let n = (3 * pixels.len()) as f64;
    let (mut sum, mut var) = (0.0f64, 0.0f64);
    for &i in pixels {
        for c in 0..3 {
            sum += film.color[i][c] as f64;
            var += film.variance[i][c] as f64;
        }
    }
    (sum / n, var.sqrt() / n, var / n * film.spp as f64)
}

/// A smooth glass sphere under a uniform sky of radiance 1 must look like the
/// sky: glass absorbs nothing. Refraction scales the throughput by 1/η²
/// going in and η² coming out, and the Russian roulette judges the
/// throughput times the η² of the refractions so far, so it spins inside
/// the glass only after an internal reflection (drawn with probability
/// `√F` and weighted by `F/√F = √F`), never on a path that merely entered,
/// whose throughput alone is 1/η² < 1. A sample's variance on the sphere
/// with the roulette from the first bounce on is therefore near its
/// variance without it (1.4× here); a roulette that judged the throughput
/// alone would end more than half the paths that enter (9.5× here).
#[test]
fn glass_sphere_in_a_furnace_is_invisible_and_the_roulette_spares_it() {
    let spp = 128;
    let (film, on_sphere) = glass_sphere_in_a_furnace(spp, 1);
    let (mean, se, noise) = mean_and_sample_variance(&film, &on_sphere);
    let (free_film, free_pixels) = glass_sphere_in_a_furnace(spp, 1024);
    let (free_mean, free_se, free_noise) = mean_and_sample_variance(&free_film, &free_pixels);
    eprintln!(
        "roulette from 1: mean {mean} ± {se}, sample variance {noise}; \
         without: mean {free_mean} ± {free_se}, sample variance {free_noise}"
    );
    // A path trapped by total internal reflection until max_depth returns
    // nothing; few are (see above), so the mean is 1 within its noise.
    for (m, e) in [(mean, se), (free_mean, free_se)] {
        assert!((m - 1.0).abs() < 4.0 * e + 1e-4, "mean {m} ± {e}, not 1");
    }
    assert!(
        noise < 3.0 * free_noise,
        "the roulette from the first bounce makes a sample's variance {noise}, \
         against {free_noise} without it"
    );
}

/// A projector `h` above the floor, pointing down with `+y` up in its
/// image (`hfov` 60°, the image's width along `x`), scaled by `scale`.
fn projector(h: f32, scale: f32, image: plsr::texture::ImageTexture) -> plsr::light::PointLight {
    let aspect = image.width as f32 / image.height as f32;
    plsr::light::PointLight {
        position: Vec3::new(0.0, 0.0, h),
        intensity: Vec3::splat(scale),
        cone: None,
        projection: Some(std::sync::Arc::new(plsr::light::Projection {
            frame: plsr::light::Projection::frame_from(-Vec3::Z, Vec3::Y).unwrap(),
            image: std::sync::Arc::new(image),
            kind: plsr::light::ProjectionKind::Projector {
                cot_half_fov: 1.0 / 30f32.to_radians().tan(),
                aspect,
            },
        })),
    }
}

/// Mitsuba's `projector` makes the irradiance on a plane facing it at
/// distance `h` the same everywhere in its frustum, `π·scale·image / h²`:
/// on a Lambertian floor of albedo 0.7 the radiance is `0.7·scale / h²`
/// under the axis and off it alike, and nothing falls outside the frustum
/// (`h·tan 30°` = 1.155 across at `h` = 2).
#[test]
fn a_projector_lights_a_facing_plane_evenly() {
    let white = || plsr::texture::ImageTexture::from_texels(1, 1, vec![Vec3::ONE]);
    let want = 0.7 * 3.0 / 4.0;
    for px in [0.0f32, 0.3, 1.0] {
        let got = floor_lit_by(projector(2.0, 3.0, white()), px);
        assert!(
            (got - want).abs() < 1e-4 * want,
            "at x = {px}: {got}, want {want}"
        );
    }
    assert_eq!(floor_lit_by(projector(2.0, 3.0, white()), 1.3), 0.0);
    // The image's right half (blue) lands on +x, its left (red) on −x.
    let halves = plsr::texture::ImageTexture::from_texels(2, 1, vec![Vec3::X, Vec3::Z])
        .with_sampling(plsr::texture::Sampling {
            filter: plsr::texture::Filter::Nearest,
            ..Default::default()
        });
    let red = |px: f32| floor_lit_by(projector(2.0, 1.0, halves.clone()), px);
    assert!((red(-0.5) - 0.7 / 4.0).abs() < 1e-4, "red on the left");
    assert_eq!(red(0.5), 0.0, "blue on the right has no red");
}

/// Writes `text` as the scene file `path`, renders it and returns its
/// middle pixel (a 3 × 3 film), or the loader's error.
fn middle_pixel_of_file(path: &std::path::Path, text: &str) -> Result<Vec3, String> {
    std::fs::write(path, text).unwrap();
    let scene = Scene::load(path).map_err(|e| e.to_string())?;
    let (film, _) = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap();
    Ok(film.color[film.index(1, 1)])
}

/// The scene file's `projector`: `irradiance` scales the image, and the
/// floor below it is lit as [`a_projector_lights_a_facing_plane_evenly`]
/// computes; a spot light's `intensity_map` and a projector's keys are
/// checked by name.
#[test]
fn projector_and_spot_images_in_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    let floor_under = |light: &str| {
        middle_pixel_of_file(
            &path,
            &format!(
                "[render]\nspp = 1\nmax_depth = 1\n[camera]\nposition = [0.3, -0.5, 0.5]\n\
                 look_at = [0.3, 0, 0]\nup = [0, 0, 1]\nhfov = 0.5\nresolution = [3, 3]\n\
                 [[materials]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\
                 [[shapes]]\ntype = \"rectangle\"\nmaterial = \"floor\"\ntransform.scale = 20\n\
                 [[lights]]\n{light}\n"
            ),
        )
    };
    let lit = floor_under(
        "type = \"projector\"\nposition = [0, 0, 2]\ndirection = [0, 0, -1]\nup = [0, 1, 0]\n\
         hfov = 60\nirradiance = [3, 3, 3]",
    )
    .unwrap();
    assert!(
        (lit - Vec3::splat(0.7 * 3.0 / 4.0)).abs().max_element() < 1e-4,
        "{lit}"
    );
    // The same frustum by its vertical field of view (a square image).
    let by_vfov = floor_under(
        "type = \"projector\"\nposition = [0, 0, 2]\ndirection = [0, 0, -1]\nup = [0, 1, 0]\n\
         vfov = 60\nirradiance = [3, 3, 3]",
    )
    .unwrap();
    assert_eq!(by_vfov, lit);
    std::fs::write(dir.path().join("white.png"), {
        let mut png = Vec::new();
        image::RgbImage::from_pixel(2, 2, image::Rgb([255, 255, 255]))
            .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        png
    })
    .unwrap();
    let spot =
        "type = \"spot\"\nposition = [0, 0, 2]\ndirection = [0, 0, -1]\nintensity = [4, 4, 4]\n\
                cutoff_angle = 30\nbeam_width = 30";
    let plain = floor_under(spot).unwrap();
    let white_image = floor_under(&format!(
        "{spot}\nup = [0, 1, 0]\nintensity_map = \"white.png\""
    ));
    assert_eq!(white_image.unwrap(), plain, "a white image changes nothing");
    for (light, says) in [
        (
            format!("{spot}\nintensity_map = \"white.png\""),
            "lights[0].up: required with a projected image",
        ),
        (format!("{spot}\nup = [0, 1, 0]"), "lights[0].up: only used with an intensity_map"),
        (
            format!("{spot}\nup = [0, 0, 1]\nintensity_map = \"white.png\""),
            "lights[0].up: must not be zero or parallel",
        ),
        (
            "type = \"projector\"\nposition = [0, 0, 2]\ndirection = [0, 0, -1]\nup = [0, 1, 0]\nhfov = 30\nvfov = 30".into(),
            "lights[0].vfov: give hfov or vfov, not both",
        ),
        (
            "type = \"projector\"\nposition = [0, 0, 2]\ndirection = [0, 0, -1]\nup = [0, 1, 0]\ncutoff_angle = 30".into(),
            "lights[0].cutoff_angle: not used by a projector",
        ),
        (
            "type = \"point\"\nposition = [0, 0, 2]\nintensity = [1, 1, 1]\nintensity_map = \"white.png\"".into(),
            "lights[0].intensity_map: not used by a point light (position, intensity)",
        ),
    ] {
        let e = floor_under(&light).unwrap_err();
        assert!(e.contains(says), "{light}: {e}");
    }
}

/// A sphere light of radiance `L` and radius `R` whose centre is `d` above
/// a floor point gives it irradiance `π·L·(R/d)²`: on a Lambertian floor
/// of albedo ρ the radiance is `ρ·L·(R/d)²`, here 0.5 · 2 / 9. The sphere's
/// triangles are sampled by its cone; its mesh is inscribed in the sphere,
/// which the tolerance allows for.
#[test]
fn a_sphere_light_gives_its_analytic_irradiance() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    let got = middle_pixel_of_file(
        &path,
        "[render]\nspp = 256\nmax_depth = 1\n[camera]\nposition = [0, -0.5, 0.5]\n\
         look_at = [0, 0, 0]\nup = [0, 0, 1]\nhfov = 0.5\nresolution = [3, 3]\n\
         [[materials]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
         [[shapes]]\ntype = \"rectangle\"\nmaterial = \"floor\"\ntransform.scale = 20\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 3]\nradius = 1\nemission = [2, 2, 2]\n",
    )
    .unwrap();
    let want = 0.5 * 2.0 / 9.0;
    assert!(
        (got - Vec3::splat(want)).abs().max_element() < 0.004 * want,
        "{got}, want {want}"
    );
}

/// Every light-picking rule (`[render] light_picking`) renders the same
/// closed-form image: a floor of albedo ρ under a constant sky L and a point
/// light of intensity I at height h, direct light only, has radiance
/// `ρ·L + ρ/π·I·h/d³` at distance `d` from the light. The image means agree
/// with it within 4 standard errors, and an unknown rule is refused naming
/// the key.
#[test]
fn every_light_picking_rule_renders_the_closed_form_image() {
    let (rho, sky, intensity, h) = (0.5f64, 0.2f64, 2.0f64, 1.0f64);
    let dir = tempfile::tempdir().unwrap();
    let text = |rule: &str| {
        format!(
            "[render]\nspp = 64\nmax_depth = 1\nlight_picking = \"{rule}\"\n\
             [camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nvfov = 20\nresolution = [16, 16]\n\
             [film]\nfilter = \"box\"\n\
             [environment]\nradiance = [{sky}, {sky}, {sky}]\n\
             [[materials]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [{rho}, {rho}, {rho}]\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"floor\"\ntransform = {{ scale = 50 }}\n\
             [[lights]]\ntype = \"point\"\nposition = [0, 0, {h}]\nintensity = [{intensity}, {intensity}, {intensity}]\n"
        )
    };
    // The closed form averaged over the image's footprint on the floor
    // (a box filter: each pixel is the mean over its square).
    let half = 3.0 * (10f64).to_radians().tan();
    let n = 400;
    let mut expected = 0.0;
    for i in 0..n {
        for j in 0..n {
            let x = -half + (i as f64 + 0.5) / n as f64 * 2.0 * half;
            let y = -half + (j as f64 + 0.5) / n as f64 * 2.0 * half;
            let d = (x * x + y * y + h * h).sqrt();
            expected += rho * sky + rho / std::f64::consts::PI * intensity * h / (d * d * d);
        }
    }
    expected /= (n * n) as f64;
    for rule in ["spatial", "power", "uniform"] {
        let path = dir.path().join(format!("{rule}.toml"));
        std::fs::write(&path, text(rule)).unwrap();
        let film = render_scene(plsr::scene::file::load(&path).unwrap());
        let (mean, stderr) = mean_and_stderr(&film);
        assert!(
            (mean - expected).abs() < 4.0 * stderr + 1e-4 * expected,
            "{rule}: mean {mean} against {expected} (standard error {stderr})"
        );
    }
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text("random")).unwrap();
    let err = plsr::scene::file::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("render.light_picking") && err.contains("\"random\""),
        "{err}"
    );
}
