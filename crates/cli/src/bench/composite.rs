//! `plsr bench composite`: what compositing costs against one render.

use crate::error::{Error, Result};
use plsr::film::ToneMap;
use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::composite::{composite_scene, CompositeOptions, Mode};
use plsr_base::Vocabulary;
use std::path::Path;
use std::time::Instant;

/// A proxy room (floor, two walls, a point light) with a virtual sphere;
/// `PHOTO` is replaced by the `[photo]` table.
const ROOM: &str = r#"
[render]
spp = 32
max_depth = 4
seed = 1

[camera]
position = [0, -5, 2.5]
look_at = [0, 0, 0.6]
up = [0, 0, 1]
vfov = 45
resolution = [320, 240]

PHOTO

[[materials]]
name = "wall"
type = "diffuse"
reflectance = [0.7, 0.65, 0.6]

[[materials]]
name = "object"
type = "diffuse"
reflectance = [0.8, 0.3, 0.2]

[[shapes]]
type = "rectangle"
material = "wall"
transform = { scale = 4 }

[[shapes]]
type = "rectangle"
material = "wall"
transform = { scale = 4, rotate = { axis = [1, 0, 0], angle = 90 }, translate = [0, 3, 0] }

[[shapes]]
type = "rectangle"
material = "wall"
transform = { scale = 4, rotate = { axis = [0, 1, 0], angle = -90 }, translate = [-3, 0, 0] }

[[lights]]
type = "point"
position = [1.5, -1.5, 3.5]
intensity = [20, 20, 20]

[[shapes]]
type = "sphere"
material = "object"
center = [0, 0, 0.6]
radius = 0.6
virtual = true
"#;

/// `plsr bench composite`: a composite of a virtual sphere into a photo of
/// a proxy room (320×240, 32 spp, both renders), against one plain render
/// of the same scene at the same spp, best of three interleaved runs each;
/// both are timed from the scene file (load, build, render), as the
/// commands run.
/// Returns the ratio composite / render (the issue's target: ≤ 2.1×).
pub fn run(threads: Option<usize>) -> Result<f64> {
    let dir = super::bench_dir("composite")?;
    let scene_path = dir.join("room.toml");
    // The "photo": the room without the object, from other samples.
    write(&scene_path, &ROOM.replace("PHOTO", ""))?;
    let scene = Scene::load(&scene_path)?;
    let options = RenderOptions {
        threads,
        ..Default::default()
    };
    let photo_job = RenderJob {
        hide_virtual: true,
        spp: 64,
        seed: 99,
        ..scene.default_job()
    };
    let (photo, _) = render(&scene, &photo_job, &options, &|_, _| true)?;
    photo.write_png(&dir.join("photo.png"), ToneMap::default())?;
    write(
        &scene_path,
        &ROOM.replace(
            "PHOTO",
            "[photo]\nfile = \"photo.png\"\nexposure = \"auto\"\n",
        ),
    )?;
    let job = scene.default_job();
    let composite_options = CompositeOptions {
        mode: Mode::Differential,
        render: options,
        ..Default::default()
    };
    let (mut best_render, mut best_composite) = (f64::INFINITY, f64::INFINITY);
    let mut fit = None;
    for _ in 0..3 {
        // Both from the scene file, as the commands run: load, build, render.
        let start = Instant::now();
        let plain = Scene::load(&scene_path)?;
        render(&plain, &job, &options, &|_, _| true)?;
        best_render = best_render.min(start.elapsed().as_secs_f64());
        let start = Instant::now();
        let contents = plsr::scene::file::load_contents(&scene_path)?;
        let (_, _, report) =
            composite_scene(&scene_path, contents, &composite_options, &|_, _| true)?;
        best_composite = best_composite.min(start.elapsed().as_secs_f64());
        fit = report.fit;
    }
    let _ = std::fs::remove_dir_all(&dir);
    let ratio = best_composite / best_render;
    let samples = 320.0 * 240.0 * job.spp as f64;
    println!("plsr bench composite: a virtual sphere into a photo of a proxy room, 320×240, {} spp, best of 3 interleaved runs", job.spp);
    println!();
    println!("| work | seconds | Msamples/s (per render) | ÷ one render |");
    println!("|---|---|---|---|");
    println!(
        "| one render of the scene (load, build, render) | {best_render:.3} | {:.3} | 1.000× |",
        samples / best_render / 1e6
    );
    println!(
        "| composite (load, build, photo, two renders, fit, blend) | {best_composite:.3} | {:.3} | {ratio:.3}× |",
        2.0 * samples / best_composite / 1e6
    );
    if let Some(f) = fit {
        println!();
        println!(
            "exposure fit: k = {:.4} on {} of {} pixels, relative RMS residual {:.4}",
            f.k, f.used, f.considered, f.relative_rms
        );
    }
    Ok(ratio)
}

/// Writes a scene file of the benchmark.
fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|source| Error::io(path.to_path_buf(), source))
}
