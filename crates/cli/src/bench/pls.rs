//! `plsr bench pls`: what the parametric representation costs and saves.
//!
//! 1. Transforming 10,000 lights by a matrix through their parameters (paper
//!    eq. 15–21) versus through their tessellated vertices, at Nf = 16 and 64
//!    (the paper's claim: parameters are cheaper).
//! 2. Rendering the PLS room with its lights as PLS (window function and
//!    reach test) versus the same outlines as plain emissive meshes.

use crate::error::Result;
use glam::{Mat4, Quat, Vec3};
use plsr::light::pls::{file, BrightnessMode, Pls, PlsMesh};
use plsr::render::{render, RenderOptions};
use plsr::rng::Rng;
use plsr::scene::{file as scene_file, Scene};
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
                    .map(|mesh| mesh.transformed(&m))
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
    desc.job.spp = 16;
    let job = desc.job;
    desc.camera = desc
        .camera
        .with_resolution(320, 240)
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
    let (t_pls, _) = best_of(2, || render(&pls_scene, &job, &opts, &|_, _| true));
    let (t_plain, _) = best_of(2, || render(&plain_scene, &job, &opts, &|_, _| true));
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
    sampling_comparison(&paper.lights, paper.mode);
    Ok(())
}

/// Irradiance at `p` (receiver normal `normal`) from one tessellated PLS,
/// estimated with `n` samples: a triangle picked by area, then a point on it
/// by area (`solid_angle = false`) or a direction uniform in its solid angle.
/// Returns (mean, relative standard deviation of one sample, ns per sample).
fn irradiance_estimate(
    light: &Pls,
    mode: BrightnessMode,
    p: Vec3,
    normal: Vec3,
    n: usize,
    solid_angle: bool,
) -> (f64, f64, f64) {
    use plsr::light::{Cone, TriangleLight};
    use plsr::warp::{sample_spherical_triangle, Distribution1D};
    let mesh = light.tessellate(plsr::light::pls::DEFAULT_NF);
    let radiance = light.radiance(mode, mesh.area()).x;
    let cone = Cone::new(light.normal(), light.a_deg);
    let tris: Vec<TriangleLight> = mesh
        .triangles
        .iter()
        .filter_map(|t| {
            TriangleLight::new(
                t.map(|i| mesh.positions[i as usize]),
                Vec3::splat(radiance),
                false,
            )
        })
        .map(|t| t.with_cone(cone))
        .collect();
    let pick = Distribution1D::new(&tris.iter().map(|t| t.area).collect::<Vec<_>>());
    let mut rng = Rng::new(7, 7);
    let (mut sum, mut sum_sq) = (0.0f64, 0.0f64);
    let start = Instant::now();
    for _ in 0..n {
        let (i, pmf) = pick.sample(rng.next_f32()).expect("the light has area");
        let t = &tris[i];
        let u = rng.next_2d();
        let value = if solid_angle {
            match sample_spherical_triangle(&t.p, p, u) {
                Some((w, pdf)) => {
                    let cos = w.dot(normal).max(0.0);
                    (t.emitted(-w).x * cos / (pdf * pmf)) as f64
                }
                None => 0.0,
            }
        } else {
            match t.sample_li(p, u) {
                Some(ls) => (ls.radiance.x * ls.wi.dot(normal).max(0.0) / (ls.pdf * pmf)) as f64,
                None => 0.0,
            }
        };
        sum += value;
        sum_sq += value * value;
    }
    let ns = start.elapsed().as_secs_f64() * 1e9 / n as f64;
    let mean = sum / n as f64;
    let var = (sum_sq / n as f64 - mean * mean).max(0.0);
    (mean, var.sqrt() / mean.abs().max(1e-300), ns)
}

/// Area versus solid-angle sampling of the paper's lights, at receivers on
/// their axes at several distances: which gives less noise per unit time.
fn sampling_comparison(lights: &[Pls], mode: BrightnessMode) {
    println!();
    println!("Sampling a point on a PLS for next-event estimation: area vs solid angle");
    println!("(receiver on the light's axis facing it; 200,000 samples; lower relative");
    println!("std. dev. is better; efficiency = 1 / (variance × time), ratio solid/area):");
    println!();
    println!("| light | distance | rel. std. dev. area | rel. std. dev. solid angle | ns/sample area | ns/sample solid angle | efficiency ratio |");
    println!("|---|---|---|---|---|---|---|");
    for l in lights {
        for dist in [0.02f32, 0.1, 0.5, 2.0] {
            let p = l.centre() + dist * l.normal();
            let normal = -l.normal();
            let (_, sa, ta) = irradiance_estimate(l, mode, p, normal, 200_000, false);
            let (_, ss, ts) = irradiance_estimate(l, mode, p, normal, 200_000, true);
            let eff = (sa * sa * ta) / (ss * ss * ts).max(1e-300);
            println!(
                "| {} | {dist} m | {sa:.4} | {ss:.4} | {ta:.1} | {ts:.1} | {eff:.2}× |",
                l.name.as_deref().unwrap_or("-")
            );
        }
    }
}
