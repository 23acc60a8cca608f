//! Parametric light sources in the renderer: inverse-square law, the closed
//! form in radiance mode, the hard edge of the cone, and the closed form of
//! the soft edge (eq. 12′).

use glam::{Mat4, Vec3};
use plsr::bsdf::Bsdf;
use plsr::camera::PinholeCamera;
use plsr::job::RenderJob;
use plsr::light::pls::{BrightnessMode, Pls};
use plsr::render::{render, RenderOptions};
use plsr::scene::shapes::{rectangle, transform_mesh};
use plsr::scene::{pls_mesh, Material, Mesh, Scene, SceneDescription};

const ALBEDO: f32 = 0.6;

/// The square `[-half, half]²` at z = 0 facing up, with material 0.
fn floor(half: f32) -> Mesh {
    let (mut p, mut t) = rectangle();
    transform_mesh(&Mat4::from_scale(Vec3::splat(half)), &mut p, &mut t);
    Mesh::new("floor", p, t, 0, 0).unwrap()
}

/// Radiance of the floor point `target` (z = 0) lit only by `light`,
/// direct lighting only, seen by a narrow camera.
fn floor_radiance(light: &Pls, mode: BrightnessMode, target: Vec3, spp: u32) -> (f64, f64) {
    let floor = floor(20.0);
    let materials = vec![
        Material {
            name: "floor".into(),
            bsdf: Bsdf::diffuse(Vec3::splat(ALBEDO)),
            textures: Default::default(),
            two_sided: true,
            composite: None,
        },
        Material {
            name: "black".into(),
            bsdf: Bsdf::diffuse(Vec3::ZERO),
            textures: Default::default(),
            two_sided: true,
            composite: None,
        },
    ];
    let eye = target + Vec3::new(0.0, -0.3, 0.3);
    let scene = Scene::build(SceneDescription {
        meshes: vec![floor, pls_mesh(light, mode, 32, 1, "light".into())],
        materials,
        point_lights: vec![],
        camera: PinholeCamera::look_at(eye, target, Vec3::Z, 0.2, 3, 3)
            .unwrap()
            .into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: None,
        job: RenderJob {
            spp,
            max_depth: 1,
            seed: 5,
            sample_start: 0,
            hide_virtual: false,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    })
    .unwrap();
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    let n = film.color.len() as f64;
    let mean = film.color.iter().map(|c| c.x as f64).sum::<f64>() / n;
    let var = film.variance.iter().map(|v| v.x as f64).sum::<f64>() / (n * n);
    (mean, var.sqrt())
}

/// A small disk light of radius 5 mm at height `h`, facing down.
fn small_light(h: f32, a_deg: f32, b: f32) -> Pls {
    Pls::circle(
        Vec3::new(0.0, 0.0, h),
        0.005,
        -Vec3::Z,
        Vec3::X,
        a_deg,
        Vec3::ONE,
        b,
    )
    .unwrap()
}

#[test]
fn intensity_mode_obeys_the_inverse_square_law() {
    let b = 3.0;
    for h in [0.5f32, 1.0] {
        let (got, se) = floor_radiance(
            &small_light(h, 60.0, b),
            BrightnessMode::Intensity,
            Vec3::ZERO,
            256,
        );
        let want = (ALBEDO / std::f32::consts::PI * b / (h * h)) as f64;
        eprintln!("h = {h}: rendered {got:.5} ± {se:.5}, b/r² gives {want:.5}");
        assert!((got - want).abs() < 0.02 * want, "h = {h}: {got} vs {want}");
    }
}

#[test]
fn radiance_mode_matches_the_closed_form_for_its_area() {
    let (b, h) = (40.0f32, 0.4f32);
    let light = small_light(h, 60.0, b);
    let area = light.tessellate(32).area();
    let (got, _) = floor_radiance(&light, BrightnessMode::Radiance, Vec3::ZERO, 256);
    // A small Lambertian patch of radiance L and area A, on axis at
    // distance h: E = L·A/h² (to O(R²/h²) = 1e-4).
    let want = (ALBEDO / std::f32::consts::PI * b * area / (h * h)) as f64;
    assert!((got - want).abs() < 0.02 * want, "{got} vs {want}");
}

#[test]
fn the_cone_has_a_hard_edge() {
    let (h, a) = (1.0f32, 20.0f32);
    let light = small_light(h, a, 2.0);
    let edge = h * a.to_radians().tan();
    // The light is 5 mm in radius: its penumbra is that wide. Step 3 cm in
    // and out of the geometric edge.
    let (inside, _) = floor_radiance(
        &light,
        BrightnessMode::Intensity,
        Vec3::new(edge - 0.03, 0.0, 0.0),
        64,
    );
    let (outside, _) = floor_radiance(
        &light,
        BrightnessMode::Intensity,
        Vec3::new(edge + 0.03, 0.0, 0.0),
        64,
    );
    let on_axis = ALBEDO / std::f32::consts::PI * 2.0 / (h * h);
    assert!(inside > 0.5 * on_axis as f64, "inside the cone: {inside}");
    assert_eq!(outside, 0.0, "outside the cone no direct light arrives");
}

/// The paper's flashlight on the floor: the lit patch in a top-down render is
/// where the cone (apex at the light's centre, axis n, half-angle a) meets
/// the plane, checked by its centroid, its extent and pixel agreement.
#[test]
fn the_papers_flashlight_lights_the_ellipse_the_geometry_predicts() {
    let lighting =
        plsr::light::pls::file::load(std::path::Path::new("assets/lights/paper.toml")).unwrap();
    let flashlight = lighting.lights[0].clone();
    let floor = floor(10.0);
    let look = Vec3::new(0.95, 1.85, 0.0);
    let (res, fov) = (128, 6.0f32);
    let camera = PinholeCamera::look_at(
        look + Vec3::new(0.0, 0.0, 20.0),
        look,
        Vec3::Y,
        fov,
        res,
        res,
    )
    .unwrap();
    let scene = Scene::build(SceneDescription {
        meshes: vec![
            floor,
            pls_mesh(&flashlight, lighting.mode, 32, 1, "flashlight".into()),
        ],
        materials: vec![
            Material {
                name: "floor".into(),
                bsdf: Bsdf::diffuse(Vec3::splat(0.5)),
                textures: Default::default(),
                two_sided: true,
                composite: None,
            },
            Material {
                name: "black".into(),
                bsdf: Bsdf::diffuse(Vec3::ZERO),
                textures: Default::default(),
                two_sided: true,
                composite: None,
            },
        ],
        point_lights: vec![],
        camera: camera.clone().into(),
        film: Default::default(),
        directional_lights: Vec::new(),
        environment: None,
        job: RenderJob {
            spp: 16,
            max_depth: 1,
            seed: 2,
            sample_start: 0,
            hide_virtual: false,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    })
    .unwrap();
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    let peak = film.color.iter().map(|c| c.x).fold(0.0, f32::max);
    assert!(peak > 0.0);
    let apex = flashlight.centre();
    let n = flashlight.normal();
    let cos_a = flashlight.a_deg.to_radians().cos();
    let (mut agree, mut lit) = (0u32, 0u32);
    let (mut centroid_img, mut centroid_geo) = (Vec3::ZERO, Vec3::ZERO);
    let mut n_geo = 0u32;
    let (mut min_img, mut max_img, mut min_geo, mut max_geo) =
        (f32::MAX, f32::MIN, f32::MAX, f32::MIN);
    // The ellipse's major axis is the floor projection of n.
    let major = Vec3::new(n.x, n.y, 0.0).normalize();
    for y in 0..res {
        for x in 0..res {
            let ray = camera.generate_ray(glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let s = -ray.org.z / ray.dir.z;
            let q = ray.org + s * ray.dir;
            let d = (q - apex).normalize();
            let geo = d.dot(n) >= cos_a;
            // Compare with the unwindowed point-source radiance at q, so the
            // fall-off across the long oblique ellipse does not matter.
            let r2 = (q - apex).length_squared();
            let cos_floor = (apex - q).normalize().z;
            let unwindowed =
                0.5 / std::f32::consts::PI * flashlight.b * flashlight.c.x * cos_floor / r2;
            let img = film.color[film.index(x, y)].x > 0.5 * unwindowed;
            agree += (geo == img) as u32;
            if img {
                lit += 1;
                centroid_img += q;
                min_img = min_img.min(q.dot(major));
                max_img = max_img.max(q.dot(major));
            }
            if geo {
                assert!(
                    x > 0 && y > 0 && x + 1 < res && y + 1 < res,
                    "the whole ellipse is in view"
                );
                n_geo += 1;
                centroid_geo += q;
                min_geo = min_geo.min(q.dot(major));
                max_geo = max_geo.max(q.dot(major));
            }
        }
    }
    let (centroid_img, centroid_geo) = (centroid_img / lit as f32, centroid_geo / n_geo as f32);
    let pixel = 2.0 * 20.0 * (fov / 2.0).to_radians().tan() / res as f32;
    eprintln!(
        "lit pixels {lit} (geometry {n_geo}), agreement {:.1} %, centroid offset {:.1} mm, major extent [{min_img:.3}, {max_img:.3}] vs [{min_geo:.3}, {max_geo:.3}] m, pixel {pixel:.4} m",
        100.0 * agree as f32 / (res * res) as f32,
        1000.0 * (centroid_img - centroid_geo).length()
    );
    assert!(
        n_geo > 500 && lit > 500,
        "the ellipse covers a good part of the image"
    );
    assert!(agree as f32 >= 0.97 * (res * res) as f32);
    assert!((centroid_img - centroid_geo).length() < 2.0 * pixel);
    // The light is 3 cm across: its penumbra blurs the edge by about that.
    assert!((min_img - min_geo).abs() < 0.03 + pixel && (max_img - max_geo).abs() < 0.03 + pixel);
}

#[test]
fn the_built_scene_keeps_its_pls_lights_with_their_parameters() {
    use plsr::light::pls::{file, DEFAULT_NF};
    let scene = Scene::load(std::path::Path::new("assets/scenes/pls-room/pls-room.toml")).unwrap();
    let paper = file::load(std::path::Path::new("assets/lights/paper.toml")).unwrap();
    let kept: Vec<_> = scene.pls_emitters().collect();
    assert_eq!(kept.len(), paper.lights.len());
    for ((geom, emitter), light) in kept.iter().zip(&paper.lights) {
        assert_eq!(&emitter.light, light, "the file's parameters");
        assert_eq!(emitter.mode, paper.mode);
        assert_eq!(emitter.nf, DEFAULT_NF);
        // The mesh Embree traces is the emitter's tessellation.
        let mesh = &scene.meshes()[*geom as usize];
        assert_eq!(mesh.positions, emitter.tessellate().positions);
    }
}

#[test]
fn meshes_and_materials_check_their_own_rules() {
    use plsr::bsdf::{Bsdf, PrincipledParams};
    use plsr::scene::MeshError;
    let tri = vec![[0, 1, 2]];
    let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
    assert!(Mesh::new("ok", p.clone(), tri.clone(), 0, 0).is_ok());
    assert_eq!(
        Mesh::new("empty", vec![], vec![], 0, 0).unwrap_err(),
        MeshError::Empty
    );
    assert_eq!(
        Mesh::new("index", p.clone(), vec![[0, 1, 3]], 0, 0).unwrap_err(),
        MeshError::IndexOutOfRange {
            triangle: 0,
            vertices: 3
        }
    );
    let mut nan = p.clone();
    nan[1].y = f32::NAN;
    assert_eq!(
        Mesh::new("nan", nan, tri.clone(), 0, 0).unwrap_err(),
        MeshError::NonFinitePosition(1)
    );
    // A mesh built in code with a bad attribute count is refused by the scene.
    let mut mesh = Mesh::new("normals", p, tri, 0, 0).unwrap();
    mesh.normals = vec![Vec3::Z];
    let desc = |meshes, materials| SceneDescription {
        meshes,
        materials,
        point_lights: vec![],
        directional_lights: Vec::new(),
        environment: None,
        camera: PinholeCamera::look_at(Vec3::Z, Vec3::ZERO, Vec3::Y, 40.0, 4, 4)
            .unwrap()
            .into(),
        film: Default::default(),
        job: Default::default(),
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    };
    let err = Scene::build(desc(
        vec![mesh],
        vec![Material::new("m", Bsdf::diffuse(Vec3::ONE))],
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("1 normals for 3 vertices"), "{err}");
    // Principled parameters out of range: NaN and 1.5.
    let good = PrincipledParams {
        base_color: Vec3::splat(0.5),
        roughness: 0.5,
        metallic: 0.0,
        anisotropic: 0.0,
        specular: 0.5,
        spec_tint: 0.0,
        energy_conserving: false,
    };
    assert!(good.validate().is_ok());
    let e = PrincipledParams {
        roughness: f32::NAN,
        ..good
    }
    .validate()
    .unwrap_err();
    assert_eq!(e.parameter, "roughness");
    let bad = PrincipledParams {
        metallic: 1.5,
        ..good
    };
    let err = Scene::build(desc(
        vec![Mesh::new(
            "t",
            vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            vec![[0, 1, 2]],
            0,
            0,
        )
        .unwrap()],
        vec![Material::new("m", Bsdf::Principled(bad))],
    ))
    .err()
    .unwrap()
    .to_string();
    assert!(err.contains("metallic = 1.5 must be in [0, 1]"), "{err}");
}

/// The soft edge (eq. 12′): a small light at height h facing down (a
/// Lambertian emitter: intensity `b·cos θ`) gives the floor point at angle
/// θ off its axis the irradiance `b·W(θ)·cos⁴θ/h²`,
/// with `W` falling linearly from 1 at `a − w/2` to 0 at `a + w/2`.
#[test]
fn the_soft_edge_matches_its_closed_form_on_a_plane() {
    let (h, a, w, b) = (1.0f32, 30.0f32, 12.0f32, 2.0f32);
    let mut light = small_light(h, a, b);
    light.penumbra_deg = w;
    light.validate(0).unwrap();
    for theta in [15.0f32, 25.0, 28.0, 30.0, 33.0, 35.5, 38.0] {
        let t = theta.to_radians();
        let target = Vec3::new(h * t.tan(), 0.0, 0.0);
        let (got, se) = floor_radiance(&light, BrightnessMode::Intensity, target, 256);
        let window = ((a + 0.5 * w - theta) / w).clamp(0.0, 1.0);
        let want = (ALBEDO / std::f32::consts::PI * b * window * t.cos().powi(4) / (h * h)) as f64;
        eprintln!("θ = {theta}°: rendered {got:.5} ± {se:.5}, closed form {want:.5}");
        assert!(
            (got - want).abs() <= 0.02 * want.max(0.05 * ALBEDO as f64) + 3.0 * se,
            "θ = {theta}°: {got} vs {want}"
        );
    }
    // A penumbra of 0 is the paper's hard edge, bit for bit.
    let hard = small_light(h, a, b);
    let mut zero = hard.clone();
    zero.penumbra_deg = 0.0;
    let target = Vec3::new(0.5, 0.1, 0.0);
    assert_eq!(
        floor_radiance(&hard, BrightnessMode::Intensity, target, 8),
        floor_radiance(&zero, BrightnessMode::Intensity, target, 8)
    );
}

#[test]
fn a_penumbra_beyond_the_hemisphere_is_refused() {
    let mut light = small_light(1.0, 80.0, 1.0);
    light.penumbra_deg = 30.0;
    let e = light.validate(0).unwrap_err();
    assert_eq!(e.parameter, "penumbra");
    assert!(e.message.contains("must be in [0°, 20°]"), "{}", e.message);
}
