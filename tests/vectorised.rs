//! The vectorised kernel (plain Lambert scenes lit by point lights) renders
//! exactly the image of the general integrator: every layer, bit for bit.

use plsr::film::Film;
use plsr::integrator::DiffuseScene;
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;
use std::path::Path;

fn embree_demo(size: u32, spp: u32) -> Scene {
    let mut s = Scene::load(Path::new("assets/scenes/cornell/embree-demo.toml")).unwrap();
    s.camera = s.camera.with_resolution(size, size).unwrap();
    s.settings.spp = spp;
    s
}

fn render_with(scene: &Scene, vectorised: bool, threads: usize) -> Film {
    let o = RenderOptions {
        threads: Some(threads),
        vectorised,
        ..Default::default()
    };
    let (film, stats) = render(scene, &o, &|_, _| true).unwrap();
    assert_eq!(stats.vectorised, vectorised, "kernel choice");
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

fn assert_identical(scene: &Scene) {
    assert!(DiffuseScene::new(scene).is_some(), "scene qualifies");
    let general = render_with(scene, false, 1);
    let fast = render_with(scene, true, 2);
    for ((name, a), (_, b)) in layers(&general).into_iter().zip(layers(&fast)) {
        if let Some(i) = (0..a.len()).find(|&i| a[i] != b[i]) {
            panic!(
                "layer {name} differs at element {i}: general {} vectorised {} ({} of {} elements differ)",
                f32::from_bits(a[i]),
                f32::from_bits(b[i]),
                (0..a.len()).filter(|&i| a[i] != b[i]).count(),
                a.len()
            );
        }
    }
}

#[test]
fn embree_demo_is_bit_identical() {
    assert_identical(&embree_demo(48, 4));
}
