//! Renders are reproducible: the same scene, seed and spp give a bit-identical
//! image whatever the number of threads or the tile size.

use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;
use std::path::Path;

fn cornell() -> Scene {
    let mut s = Scene::load(Path::new("tests/data/cornell-64.toml")).unwrap();
    s.settings.spp = 8;
    s
}

#[test]
fn one_and_two_threads_give_identical_images() {
    let scene = cornell();
    let run = |threads, tile_size| {
        let o = RenderOptions {
            threads: Some(threads),
            tile_size,
            ..Default::default()
        };
        render(&scene, &o, &|_, _| true).unwrap().0
    };
    let a = run(1, 16);
    let b = run(2, 16);
    let c = run(2, 7);
    // Bitwise comparison of every layer (PartialEq on f32 would accept −0 = +0).
    let bits = |f: &plsr::film::Film| -> Vec<u32> {
        f.color
            .iter()
            .chain(&f.variance)
            .chain(&f.normal)
            .chain(&f.albedo)
            .flat_map(|v| v.to_array())
            .chain(f.alpha.iter().copied())
            .chain(f.depth.iter().copied())
            .chain(f.object_id.iter().copied())
            .map(f32::to_bits)
            .collect()
    };
    assert_eq!(bits(&a), bits(&b), "1 vs 2 threads");
    assert_eq!(bits(&a), bits(&c), "tile size 16 vs 7");
    assert!(a.mean_color().x > 0.01, "the image is not black");
}

#[test]
fn a_different_seed_gives_a_different_image() {
    let mut scene = cornell();
    let a = render(&scene, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0;
    scene.settings.seed = 1;
    let b = render(&scene, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0;
    assert_ne!(a.color, b.color);
}

#[test]
fn cancelling_stops_the_render() {
    let scene = cornell();
    let r = render(&scene, &RenderOptions::default(), &|done, _| done < 2);
    assert!(matches!(r, Err(plsr::Error::Cancelled)));
}
