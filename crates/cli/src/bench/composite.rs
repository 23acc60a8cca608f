//! `plsr bench composite`: what compositing costs against one render.

use crate::error::{Error, Result};
use plsr::film::ToneMap;
use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::composite::{composite_scene, CompositeOptions, Mode, Retrace};
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

/// The AR demo's scene (a sphere into a simulated camera's 8-bit photo
/// of a small room, through its recovered response curve), where the
/// repository is at hand.
const AR_DEMO: &str = "assets/scenes/ar-demo/ar-demo.toml";

/// `plsr bench composite`: what a composite costs against one plain
/// render of the same scene at the same spp, both timed from the scene
/// file (load, build, render) as the commands run, best of three
/// interleaved runs each: a composite whose render without the virtual
/// objects is made alongside the one with them (forked paths, the
/// default) and one that makes it as a second whole render
/// (`--two-renders`). Two cases: a virtual sphere into a photo of a proxy
/// room (320×240, 32 spp), and the AR demo (320×240, 64 spp) when run
/// from the repository.
/// Returns the default composite's ratio to one render on the first case
/// (the issue's target: ≤ 1.3×).
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
    println!("plsr bench composite: a composite against one render of the same scene (load, build, render), best of 3 interleaved runs");
    println!();
    println!(
        "| scene | work | seconds | of which rendering | Msamples/s (per render) | ÷ one render |"
    );
    println!("|---|---|---|---|---|---|");
    let room = measure("proxy room, 320×240, 32 spp", &scene_path, None, options)?;
    let _ = std::fs::remove_dir_all(&dir);
    let ar = if Path::new(AR_DEMO).is_file() {
        Some(measure(
            "AR demo, 320×240, 64 spp",
            Path::new(AR_DEMO),
            Some(64),
            options,
        )?)
    } else {
        None
    };
    println!();
    println!("| scene | paths forked (met a virtual object) | rays traced again without the objects ÷ rays of the render with them | shadow rays asked again ÷ shadow rays |");
    println!("|---|---|---|---|");
    for m in std::iter::once(&room).chain(&ar) {
        let r = &m.rays;
        // The paired render counts the rays of both renders; those of the
        // render with the objects are the whole minus the O-only lanes'
        // continuations (`o_rays` also counts each fork's first ray, which
        // `camera` and `bounce` do not).
        let with_rays = (r.camera + r.bounce + r.forked - r.o_rays) as f64;
        println!(
            "| {} | {:.1} % | {:.1} % | {:.2} % |",
            m.name,
            100.0 * r.forked as f64 / m.paths as f64,
            100.0 * r.o_rays as f64 / with_rays,
            100.0 * r.shadow_again as f64 / r.shadow.max(1) as f64
        );
    }
    if ar.is_none() {
        println!();
        println!("(the AR demo case needs {AR_DEMO}: run from the repository)");
    }
    if let Some(f) = room.fit {
        println!();
        println!(
            "proxy room's exposure fit: k = {:.4} on {} of {} pixels, relative RMS residual {:.4}",
            f.k, f.used, f.considered, f.relative_rms
        );
    }
    Ok(room.paired / room.render)
}

/// One case's best times (seconds) and the paired composite's counts.
struct Measured {
    name: &'static str,
    render: f64,
    paired: f64,
    paths: u64,
    rays: plsr::integrator::RayStats,
    fit: Option<plsr_apps::composite::ExposureFit>,
}

/// Times one render and both kinds of composite of `scene_path`
/// (interleaved, best of three) at `spp` (default: the scene's), prints
/// the case's table rows and returns the measurements.
fn measure(
    name: &'static str,
    scene_path: &Path,
    spp: Option<u32>,
    options: RenderOptions,
) -> Result<Measured> {
    let scene = Scene::load(scene_path)?;
    let (width, height) = (scene.camera().width(), scene.camera().height());
    let mut job = scene.default_job();
    drop(scene);
    if let Some(spp) = spp {
        job.spp = spp;
    }
    let composite_options = |retrace| CompositeOptions {
        mode: Mode::Differential,
        spp,
        render: options,
        retrace,
        ..Default::default()
    };
    let mut best = [f64::INFINITY; 3];
    // Of each best run, the seconds of rendering alone.
    let mut rendering = [0.0; 3];
    let mut report = None;
    for _ in 0..3 {
        let start = Instant::now();
        let plain = Scene::load(scene_path)?;
        let (_, stats) = render(&plain, &job, &options, &|_, _| true)?;
        let seconds = start.elapsed().as_secs_f64();
        if seconds < best[0] {
            (best[0], rendering[0]) = (seconds, stats.seconds);
        }
        for (i, retrace) in [(1, Retrace::All), (2, Retrace::Touched)] {
            let start = Instant::now();
            let contents = plsr::scene::file::load_contents(scene_path)?;
            let (_, _, r) = composite_scene(
                scene_path,
                contents,
                &composite_options(retrace),
                &|_, _| true,
            )?;
            let seconds = start.elapsed().as_secs_f64();
            if seconds < best[i] {
                (best[i], rendering[i]) = (seconds, r.render_seconds);
            }
            if retrace == Retrace::Touched {
                report = Some(r);
            }
        }
    }
    let report = report.expect("three runs");
    let samples = width as f64 * height as f64 * job.spp as f64;
    let [one, two, paired] = best;
    let [r1, r2, rp] = rendering;
    println!(
        "| {name} | one render | {one:.3} | {r1:.3} | {:.3} | 1.000× |",
        samples / one / 1e6
    );
    println!(
        "| {name} | composite, two whole renders (`--two-renders`) | {two:.3} | {r2:.3} | {:.3} | {:.3}× |",
        2.0 * samples / two / 1e6,
        two / one
    );
    println!(
        "| {name} | composite, forked paths (default) | {paired:.3} | {rp:.3} | {:.3} | **{:.3}×** |",
        2.0 * samples / paired / 1e6,
        paired / one
    );
    Ok(Measured {
        name,
        render: one,
        paired,
        paths: report.samples / 2,
        rays: report.rays,
        fit: report.fit,
    })
}

/// Writes a scene file of the benchmark.
fn write(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(|source| Error::io(path.to_path_buf(), source))
}
