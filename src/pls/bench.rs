//! `plsr bench pls`: what the parametric representation costs and saves.
//!
//! 1. Transforming 10,000 lights by a matrix through their parameters (paper
//!    eq. 15–21) versus through their tessellated vertices, at Nf = 16 and 64
//!    (the paper's claim: parameters are cheaper).
//! 2. Rendering the PLS room with its lights as PLS (window function and
//!    reach test) versus the same outlines as plain emissive meshes.

use super::{file, BrightnessMode, Pls, PlsMesh};
use crate::error::Result;
use crate::render::{render, RenderOptions};
use crate::sampler::Rng;
use crate::scene::{file as scene_file, Scene};
use glam::{Mat4, Quat, Vec3};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

const LIGHTS: usize = 10_000;

fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..runs {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("at least one run"))
}

/// Runs the PLS benchmark and prints its tables.
pub fn run(threads: Option<usize>) -> Result<()> {
    let paper = file::load(Path::new("assets/lights/paper.toml"))?;
    let mut rng = Rng::new(99, 1);
    let lights: Vec<Pls> = (0..LIGHTS)
        .map(|i| {
            let mut l = paper.lights[i % 2].clone();
            let offset = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            l.g.e1 += offset;
            l.g.e2 += offset;
            l
        })
        .collect();
    let m = Mat4::from_scale_rotation_translation(
        Vec3::splat(1.3),
        Quat::from_axis_angle(Vec3::new(0.3, -0.2, 0.9).normalize(), 0.7),
        Vec3::new(0.5, -1.0, 2.0),
    );
    println!("plsr bench pls: transforming {LIGHTS} lights by one affine matrix (best of 5)");
    println!();
    println!("| Nf | through parameters | through vertices | vertices / parameters | vertices per light |");
    println!("|---|---|---|---|---|");
    let (t_param, _) = best_of(5, || {
        black_box(lights.iter().map(|l| l.transform(&m)).collect::<Vec<_>>())
    });
    for nf in [16u32, 64] {
        let meshes: Vec<PlsMesh> = lights.iter().map(|l| l.tessellate(nf)).collect();
        let (t_vert, _) = best_of(5, || {
            black_box(
                meshes
                    .iter()
                    .map(|mesh| PlsMesh {
                        positions: mesh
                            .positions
                            .iter()
                            .map(|p| m.transform_point3(*p))
                            .collect(),
                        triangles: mesh.triangles.clone(),
                    })
                    .collect::<Vec<_>>(),
            )
        });
        println!(
            "| {nf} | {:.3} ms | {:.3} ms | {:.1}× | {} |",
            t_param * 1e3,
            t_vert * 1e3,
            t_vert / t_param,
            meshes[0].positions.len()
        );
    }
    let (t_tess, _) = best_of(3, || {
        black_box(lights.iter().map(|l| l.tessellate(16)).collect::<Vec<_>>())
    });
    println!();
    println!(
        "(tessellating the 10,000 lights at Nf = 16 takes {:.3} ms, once per render)",
        t_tess * 1e3
    );

    // 2. The window's cost in a render.
    let scene_path = Path::new("assets/scenes/pls-room/pls-room.toml");
    let mut desc = scene_file::load(scene_path)?;
    desc.settings.spp = 16;
    desc.camera = crate::camera::PinholeCamera::look_at(
        desc.camera.position,
        desc.camera.position + desc.camera.forward,
        desc.camera.up,
        desc.camera.vfov_deg(),
        320,
        240,
    )
    .expect("the scene's camera is valid");
    let mut plain = desc.clone();
    for mesh in &mut plain.meshes {
        if let Some(e) = &mut mesh.emission {
            e.cone = None;
        }
    }
    let opts = RenderOptions {
        threads,
        ..Default::default()
    };
    let pls_scene = Scene::build(desc)?;
    let plain_scene = Scene::build(plain)?;
    let (t_pls, _) = best_of(2, || render(&pls_scene, &opts, &|_, _| true));
    let (t_plain, _) = best_of(2, || render(&plain_scene, &opts, &|_, _| true));
    println!();
    println!(
        "Rendering {} at 320×240, 16 spp (best of 2):",
        scene_path.display()
    );
    println!();
    println!("| lights as | time | Msamples/s |");
    println!("|---|---|---|");
    let ms = |t: f64| 320.0 * 240.0 * 16.0 / t / 1e6;
    println!(
        "| PLS (window + reach test) | {t_pls:.3} s | {:.3} |",
        ms(t_pls)
    );
    println!(
        "| plain emissive meshes | {t_plain:.3} s | {:.3} |",
        ms(t_plain)
    );
    println!("| PLS / plain | {:.3}× | |", t_pls / t_plain);
    let _ = BrightnessMode::Intensity;
    Ok(())
}
