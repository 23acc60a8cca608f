//! `plsr bench materials`: what the richer BSDFs cost against Lambert.

use plsr::error::{Error, Result};
use plsr::film::Film;
use plsr::render::{render, RenderOptions, RenderStats};
use plsr::scene::Scene;
use std::path::Path;

/// `plsr bench materials`: the Cornell box rendered with all-diffuse
/// materials and again with every material replaced by a principled BSDF of
/// the same base colour (roughness 0.5, specular 0.5), in Mitsuba's mode and
/// in the energy-conserving mode, in the same run, all with the general
/// integrator; the ratios say what the richer BSDF costs. The all-diffuse
/// scene is also timed on the vectorised kernel. Returns `(diffuse,
/// principled, energy-conserving principled)` in Msamples/s (general
/// integrator).
pub fn run(threads: Option<usize>) -> Result<(f64, f64, f64)> {
    use plsr::bsdf::{Bsdf, PrincipledParams};
    let path = Path::new("assets/scenes/cornell/cornell.toml");
    let mut diffuse = plsr::scene::file::load(path)?;
    diffuse.job.spp = 32;
    let job = diffuse.job;
    diffuse.camera = diffuse
        .camera
        .with_resolution(256, 256)
        .map_err(|e| Error::InvalidArgument(e.to_string()))?;
    let principled = |energy_conserving: bool| {
        let mut scene = diffuse.clone();
        for m in &mut scene.materials {
            m.bsdf = Bsdf::Principled(PrincipledParams {
                base_color: m.bsdf.albedo(),
                roughness: 0.5,
                metallic: 0.0,
                anisotropic: 0.0,
                specular: 0.5,
                spec_tint: 0.0,
                energy_conserving,
            });
        }
        scene
    };
    // The general integrator for all three, so that the ratios are the
    // BSDFs' cost; the all-diffuse scene also runs on the vectorised kernel.
    let opts = RenderOptions {
        threads,
        vectorised: false,
        ..Default::default()
    };
    let vectorised_opts = RenderOptions {
        threads,
        ..Default::default()
    };
    let scenes = [
        Scene::build(diffuse.clone())?,
        Scene::build(principled(false))?,
        Scene::build(principled(true))?,
    ];
    // Interleaved runs, best of three each, so drift hits all alike.
    let mut best = [0.0f64; 3];
    let mut best_vectorised = 0.0f64;
    for _ in 0..3 {
        for (k, scene) in scenes.iter().enumerate() {
            let (_, stats): (Film, RenderStats) = render(scene, &job, &opts, &|_, _| true)?;
            best[k] = best[k].max(stats.msamples_per_s());
        }
        let (_, stats) = render(&scenes[0], &job, &vectorised_opts, &|_, _| true)?;
        best_vectorised = best_vectorised.max(stats.msamples_per_s());
    }
    println!(
        "plsr bench materials: {} at 256×256, 32 spp, best of 3 interleaved runs",
        path.display()
    );
    println!();
    println!("| materials | Msamples/s | ÷ all diffuse |");
    println!("|---|---|---|");
    println!("| all diffuse | {:.3} | 1.000× |", best[0]);
    println!(
        "| all diffuse, vectorised kernel | {:.3} | {:.3}× |",
        best_vectorised,
        best_vectorised / best[0]
    );
    println!(
        "| all principled (Mitsuba's) | {:.3} | {:.3}× |",
        best[1],
        best[1] / best[0]
    );
    println!(
        "| all principled, energy-conserving | {:.3} | {:.3}× |",
        best[2],
        best[2] / best[0]
    );
    Ok((best[0], best[1], best[2]))
}
