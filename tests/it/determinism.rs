//! Renders are reproducible: the same scene, seed and spp give a bit-identical
//! image whatever the number of threads or the tile size.

use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use std::path::Path;

fn cornell() -> Scene {
    Scene::load(Path::new("tests/data/cornell-64.toml")).unwrap()
}

/// The scene file's job at 8 spp.
fn job(scene: &Scene) -> RenderJob {
    RenderJob {
        spp: 8,
        ..scene.default_job()
    }
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
        render(&scene, &job(&scene), &o, &|_, _| true).unwrap().0
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
    let scene = cornell();
    let a = render(&scene, &job(&scene), &RenderOptions::default(), &|_, _| {
        true
    })
    .unwrap()
    .0;
    let seed_1 = RenderJob {
        seed: 1,
        ..job(&scene)
    };
    let b = render(&scene, &seed_1, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0;
    assert_ne!(a.color, b.color);
}

#[test]
fn cancelling_stops_the_render() {
    let scene = cornell();
    let r = render(
        &scene,
        &job(&scene),
        &RenderOptions::default(),
        &|done, _| done < 2,
    );
    assert!(matches!(
        r,
        Err(plsr::Error::Base(plsr_base::Error::Cancelled))
    ));
}

#[test]
fn pieces_of_a_sample_range_merge_into_the_whole() {
    use plsr::render::render_sums;
    let scene = cornell();
    let whole = job(&scene);
    let piece = |start, spp| RenderJob {
        sample_start: start,
        spp,
        ..whole
    };
    let o = RenderOptions::default();
    let (a, _) = render(&scene, &whole, &o, &|_, _| true).unwrap();
    let (mut late, _) = render_sums(&scene, &piece(3, 5), &o, &|_, _| true).unwrap();
    let (early, _) = render_sums(&scene, &piece(0, 3), &o, &|_, _| true).unwrap();
    late.merge(&early).unwrap();
    let b = late.develop(whole.spp);
    // Sums add in another order than one render's, so means agree to
    // rounding; counts (coverage) and the first sample's object exactly.
    for (x, y) in a.color.iter().zip(&b.color) {
        assert!(
            (*x - *y).abs().max_element() <= 1e-5 * (1.0 + x.max_element()),
            "{x} {y}"
        );
    }
    assert_eq!(a.alpha, b.alpha);
    assert_eq!(a.object_id, b.object_id);
    assert!(a.mean_color().x > 0.01);
    // A piece alone is not the whole.
    let (c, _) = render(&scene, &piece(0, 3), &o, &|_, _| true).unwrap();
    assert_ne!(a.color, c.color);
}

/// A render resumed from the sums of its first samples
/// ([`plsr::render::continue_sums`]) holds bit for bit the sums of one
/// render of all of them, with the general integrator and the vectorised
/// kernel, whatever the tiling of either run.
#[test]
fn a_resumed_render_holds_the_sums_of_one_render() {
    use plsr::render::{continue_sums, render_sums};
    let scene = cornell();
    let all = RenderJob {
        spp: 13,
        ..scene.default_job()
    };
    let first = RenderJob { spp: 5, ..all };
    let rest = RenderJob {
        sample_start: 5,
        spp: 8,
        ..all
    };
    let bits = |s: &plsr::film::FilmSums| -> Vec<u64> {
        s.pixels()
            .iter()
            .flat_map(|p| {
                let mut v: Vec<u64> = p.sum.to_array().iter().map(|x| x.to_bits()).collect();
                v.extend(p.sum_sq.to_array().iter().map(|x| x.to_bits()));
                v.push(p.depth.to_bits());
                v.extend(p.normal.to_array().iter().map(|x| x.to_bits() as u64));
                v.extend(p.albedo.to_array().iter().map(|x| x.to_bits() as u64));
                v.extend([
                    p.samples as u64,
                    p.hits as u64,
                    p.virtual_hits as u64,
                    p.object_id.to_bits() as u64,
                ]);
                v
            })
            .collect()
    };
    for vectorised in [false, true] {
        let o = |tile_size| RenderOptions {
            tile_size,
            vectorised,
            ..Default::default()
        };
        let one = render_sums(&scene, &all, &o(16), &|_, _| true).unwrap().0;
        let start = render_sums(&scene, &first, &o(16), &|_, _| true).unwrap().0;
        let resumed = continue_sums(&scene, &rest, &o(7), &start, &|_, _| true)
            .unwrap()
            .0;
        assert_eq!(resumed.sample_start(), 0);
        assert!(
            bits(&resumed) == bits(&one),
            "vectorised {vectorised}: the resumed sums differ"
        );
        // Merging the two pieces instead adds in another order.
        let mut merged = start.clone();
        let piece = render_sums(&scene, &rest, &o(16), &|_, _| true).unwrap().0;
        merged.merge(&piece).unwrap();
        assert!(bits(&merged) != bits(&one), "the check cannot tell");
    }
}
