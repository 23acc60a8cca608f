//! Makes the "photograph" of the fitting demo (`assets/scenes/fit-room/`):
//! the room of `truth.toml` (the true materials) rendered with many samples
//! and written as a linear half-float RGB EXR (`photo.exr`). It then fits
//! `fit-room.toml` (the same room with guessed materials) to the photo as
//! `plsr fit` does, prints the true, guessed and fitted values, and writes
//! the loss plot of `docs/fitting.md` (`docs/img/fitting-loss.png`).
//!
//! ```sh
//! cargo run --release -p plsr-apps --example fit_demo   # writes photo.exr and the figure
//! ```

use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::fit::{fit_scene_file, FitOptions};
use plsr_apps::{Error, Result};
use plsr_base::Vocabulary;
use std::path::Path;

/// The parameters the demo fits (10): every colour and roughness, and the
/// ball's metallic.
pub const PARAMS: [&str; 4] = [
    "*.base_color",
    "*.reflectance",
    "*.roughness",
    "ball.metallic",
];

fn main() -> Result<()> {
    let dir = Path::new("assets/scenes/fit-room");
    let truth = Scene::load(&dir.join("truth.toml"))?;
    let job = RenderJob {
        spp: 1024,
        seed: 2024,
        ..truth.default_job()
    };
    let (film, _) = render(&truth, &job, &RenderOptions::default(), &|_, _| true)?;
    let (w, h) = (film.width as usize, film.height as usize);
    let photo = dir.join("photo.exr");
    let rgb = |x: usize, y: usize| {
        let c = film.color[y * w + x];
        (
            exr::prelude::f16::from_f32(c.x),
            exr::prelude::f16::from_f32(c.y),
            exr::prelude::f16::from_f32(c.z),
        )
    };
    exr::prelude::write_rgb_file(&photo, w, h, rgb)
        .map_err(|e| Error::output(photo.clone(), e.to_string()))?;
    println!("wrote {} ({w}×{h}, {} spp)", photo.display(), job.spp);

    let options = FitOptions {
        params: PARAMS.iter().map(|s| s.to_string()).collect(),
        ..FitOptions::default()
    };
    let out = std::env::temp_dir().join("plsr-fit-demo.toml");
    let outcome = fit_scene_file(&dir.join("fit-room.toml"), &out, &options, &mut |it, _| {
        if it.index % 10 == 0 {
            eprintln!("iteration {:3}: loss {:.4e}", it.index, it.loss);
        }
        true
    })?;
    println!(
        "loss {:.4e} → {:.4e} in {} iterations, {:.3} s each",
        outcome.losses[0],
        outcome.losses.last().copied().unwrap_or(0.0),
        options.iterations,
        outcome.seconds_per_iteration
    );
    for p in &outcome.parameters {
        println!("| `{}` | {:?} | {:?} |", p.name, p.initial, p.value);
    }
    let img = plsr_apps::fit::plot::loss_plot(&outcome.losses, 640, 400);
    let figure = Path::new("docs/img/fitting-loss.png");
    img.save(figure)
        .map_err(|e| Error::output(figure.to_path_buf(), e.to_string()))?;
    println!("wrote {}", figure.display());
    Ok(())
}
