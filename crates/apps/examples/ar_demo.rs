//! Makes the "photograph" of the AR demo (`assets/scenes/ar-demo/`): the
//! demo room, real box included, without the virtual sphere, rendered with
//! many samples and taken by plsr's simulated camera (a filmic response,
//! noise, 8 bits) as three brackets; `plsr hdr merge --curve` recovers the
//! camera's response from them, and the middle bracket becomes the photo.
//!
//! The same camera also photographs the room with a real sphere where the
//! virtual one goes (`real-object.png`), to score the composite against
//! (`plsr compare`).
//!
//! It then composites the sphere into the photo and writes the figure of
//! `docs/compositing.md` (`docs/img/compositing.png`): photo, matte,
//! difference layer (grey is no change, darker is shadow), composite.
//!
//! ```sh
//! cargo run --release -p plsr-apps --example ar_demo   # photo.png, real-object.png, curve.csv, the figure
//! cargo run --release -p plsr-apps --example ar_demo -- --figure-only
//! ```

use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::composite::{composite_scene, CompositeOptions};
use plsr_apps::{Error, Result};
use plsr_base::Vocabulary;
use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::synth::{write_brackets, BracketOptions, CameraModel};
use std::path::Path;

fn main() -> Result<()> {
    let dir = Path::new("assets/scenes/ar-demo");
    // `-- --figure-only`: the figure from the photo already there.
    if std::env::args().any(|a| a == "--figure-only") {
        return figure(dir);
    }
    let scene = Scene::load(&dir.join("ar-demo.toml"))?;
    // The real room: the sphere hidden; other samples than the composite's.
    let job = RenderJob {
        hide_virtual: true,
        spp: 1024,
        seed: 2024,
        ..scene.default_job()
    };
    eprintln!("rendering the room without the sphere at {} spp…", job.spp);
    let (film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true)?;
    let work = std::env::temp_dir().join(format!("plsr-ar-demo-{}", std::process::id()));
    std::fs::create_dir_all(&work).map_err(|source| Error::io(work.clone(), source))?;
    let brackets = write_brackets(
        &plsr_apps::capture::FilmRadiance(&film),
        &CameraModel::default(),
        &[0.25, 1.0, 4.0],
        &work,
        &BracketOptions {
            extension: "png".into(),
            ..Default::default()
        },
    )?;
    let options = MergeOptions {
        exposures: Some(vec![0.25, 1.0, 4.0]),
        curve_csv: Some(dir.join("curve.csv")),
        ..Default::default()
    };
    merge(&brackets, &work.join("room.exr"), &options, &|_, _, _| {})?;
    std::fs::copy(&brackets[1], dir.join("photo.png"))
        .map_err(|source| Error::io(dir.join("photo.png"), source))?;
    // The same camera's photo of the room with a real sphere where the
    // virtual one goes: what a composite is scored against.
    let job = RenderJob {
        hide_virtual: false,
        ..job
    };
    eprintln!("rendering the room with a real sphere at {} spp…", job.spp);
    let (film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true)?;
    let real = work.join("real");
    std::fs::create_dir_all(&real).map_err(|source| Error::io(real.clone(), source))?;
    let shots = write_brackets(
        &plsr_apps::capture::FilmRadiance(&film),
        &CameraModel::default(),
        &[1.0],
        &real,
        &BracketOptions {
            extension: "png".into(),
            ..Default::default()
        },
    )?;
    std::fs::copy(&shots[0], dir.join("real-object.png"))
        .map_err(|source| Error::io(dir.join("real-object.png"), source))?;
    let _ = std::fs::remove_dir_all(&work);
    figure(dir)?;
    eprintln!(
        "wrote {}, {} and {}",
        dir.join("photo.png").display(),
        dir.join("real-object.png").display(),
        dir.join("curve.csv").display()
    );
    Ok(())
}

/// Composites the sphere into the photo and writes the four panels side by
/// side: photo, matte, difference layer, composite.
fn figure(dir: &Path) -> Result<()> {
    let scene_file = dir.join("ar-demo.toml");
    let contents = plsr::scene::file::load_contents(&scene_file)?;
    let (c, transfer, report) = composite_scene(
        &scene_file,
        contents,
        &CompositeOptions::default(),
        &|_, _| true,
    )?;
    eprintln!("composited: {:?}", report.fit);
    let photo = image::open(dir.join("photo.png"))
        .map_err(|e| Error::invalid_argument(e.to_string()))?
        .to_rgb8();
    let (w, h) = (c.width, c.height);
    let composite_png = std::env::temp_dir().join(format!("plsr-ar-{}.png", std::process::id()));
    let mut outputs = plsr::atomic_write::OutputSet::new();
    c.stage_png(&mut outputs, &composite_png, &transfer)?;
    outputs.commit()?;
    let composite = image::open(&composite_png)
        .map_err(|e| Error::invalid_argument(e.to_string()))?
        .to_rgb8();
    let _ = std::fs::remove_file(&composite_png);
    let gap = 4;
    let mut fig = image::RgbImage::from_pixel(4 * w + 3 * gap, h, image::Rgb([255, 255, 255]));
    // The difference in units of the photo's mean, around mid-grey.
    let mean = c
        .color
        .iter()
        .map(|v| plsr::color::luminance(*v))
        .sum::<f32>()
        / c.color.len() as f32;
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) as usize;
            let a = (c.matte[i] * 255.0).round() as u8;
            let d = plsr::color::luminance(c.difference[i]) / mean;
            let g = ((0.5 + 0.5 * d).clamp(0.0, 1.0) * 255.0).round() as u8;
            fig.put_pixel(x, y, *photo.get_pixel(x, y));
            fig.put_pixel(w + gap + x, y, image::Rgb([a, a, a]));
            fig.put_pixel(2 * (w + gap) + x, y, image::Rgb([g, g, g]));
            fig.put_pixel(3 * (w + gap) + x, y, *composite.get_pixel(x, y));
        }
    }
    let out = Path::new("docs/img/compositing.png");
    std::fs::create_dir_all("docs/img").map_err(|source| Error::io(out.to_path_buf(), source))?;
    fig.save(out)
        .map_err(|e| Error::output(out.to_path_buf(), e.to_string()))?;
    eprintln!("wrote {}", out.display());
    Ok(())
}
