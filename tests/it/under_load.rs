//! The renderer under load: a scene of ten million triangles rendered with
//! more threads than the machine has cores (8 on the 2 of CI) gives the
//! image one thread gives, bit for bit, without running out of anything.

use glam::Vec3;
use plsr::bsdf::Bsdf;
use plsr::camera::PinholeCamera;
use plsr::job::RenderJob;
use plsr::light::PointLight;
use plsr::render::{render, RenderOptions};
use plsr::scene::{Material, Mesh, Scene, SceneDescription};

/// A bumpy terrain of `2·n²` triangles over `[-1, 1]²` (z up).
fn terrain(n: u32) -> Mesh {
    let side = n + 1;
    let mut positions = Vec::with_capacity((side * side) as usize);
    for j in 0..side {
        for i in 0..side {
            let (x, y) = (
                2.0 * i as f32 / n as f32 - 1.0,
                2.0 * j as f32 / n as f32 - 1.0,
            );
            let z = 0.05 * ((17.0 * x).sin() * (13.0 * y).cos());
            positions.push(Vec3::new(x, y, z));
        }
    }
    let mut triangles = Vec::with_capacity(2 * (n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            let a = j * side + i;
            triangles.push([a, a + 1, a + side + 1]);
            triangles.push([a, a + side + 1, a + side]);
        }
    }
    let mut mesh = Mesh::new("terrain", positions, triangles, 0, 0).unwrap();
    mesh.name = format!("terrain of {} triangles", 2 * n * n);
    mesh
}

#[test]
fn ten_million_triangles_on_eight_threads_render_as_on_one() {
    // 2 · 2237² ≈ 10.0 million triangles.
    let mesh = terrain(2237);
    assert!(mesh.triangles.len() >= 10_000_000);
    let scene = Scene::build(SceneDescription {
        meshes: vec![mesh],
        materials: vec![Material::new("ground", Bsdf::diffuse(Vec3::splat(0.5)))],
        point_lights: vec![PointLight::isotropic(
            Vec3::new(0.5, -0.5, 2.0),
            Vec3::splat(4.0),
        )],
        directional_lights: Vec::new(),
        environment: None,
        camera: PinholeCamera::look_at(
            Vec3::new(0.0, -2.0, 1.5),
            Vec3::ZERO,
            Vec3::Z,
            40.0,
            48,
            32,
        )
        .unwrap()
        .into(),
        film: Default::default(),
        job: RenderJob {
            spp: 2,
            max_depth: 3,
            seed: 3,
            ..Default::default()
        },
        robust: false,
        light_picking: Default::default(),
        instancing: Default::default(),
    })
    .unwrap();
    let job = scene.default_job();
    let on = |threads: usize| {
        let options = RenderOptions {
            threads: Some(threads),
            ..Default::default()
        };
        render(&scene, &job, &options, &|_, _| true).unwrap().0
    };
    let (eight, one) = (on(8), on(1));
    assert!(eight.color == one.color, "8 threads and 1 differ");
    // Lit terrain, not an empty frame.
    let mean: f32 = eight.color.iter().map(|c| c.x).sum::<f32>() / eight.color.len() as f32;
    assert!(mean > 0.01 && mean.is_finite(), "mean {mean}");
}
