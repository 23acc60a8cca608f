//! The paper's experiment (its Tables 4 and 5), redone on the synthetic
//! [`PaperRoom`]: `plsr experiment paper`.
//!
//! 1. **Ground truth.** plsr's simulated camera ([`CameraModel`]: filmic
//!    response, noise, 8 bits) photographs the room lit by its physical
//!    fixtures, from each position's camera: without objects, with each
//!    object, and with each object again from other samples (the noise
//!    floor: what a second photo of the same scene scores).
//! 2. **Lighting capture.** The PLS lights are derived from the fixtures'
//!    geometry ([`crate::experiment::fixture`]). The HDR panorama is
//!    captured by a simulated 360° camera at the sensor position
//!    ([`crate::capture`], the paper's ten exposures) and merged
//!    ([`plsr_hdr::merge`]), which also recovers the camera's response
//!    curve; the photos are read through that curve.
//!    **Fitted from photos** (`Run::fit_from_photos`): the PLS lights'
//!    windows and brightness and the room's albedos are also fitted
//!    ([`crate::fit`]) to the two photos without objects, from guesses.
//! 3. **Insertion.** Each object is composited ([`crate::composite`],
//!    differential rendering) into the photo without objects, lit by the
//!    measured PLS lights and by the fitted ones (with the whole room as the
//!    proxy, the fitted albedos for the fitted lights) and by the panorama
//!    as an infinitely distant environment (with the floor and table as the
//!    proxy).
//! 4. **Scores.** Each composite is scored against the photo with the real
//!    object by CW-SSIM, LPIPS and FLIP over the object's crop
//!    ([`CropSpec::Auto`]: the matte's bounding box plus a margin).
//!
//! Everything is written into one new folder, staged and renamed at the
//! end: the scene files of every step (re-runnable with `plsr render` and
//! `plsr composite`), the photos, the panorama, the composites, the table
//! (`results.md`, `results.json`) and a figure of the crops
//! (`figure.png`).

use crate::capture::{capture, CaptureOptions, PAPER_EXPOSURES};
use crate::composite::{composite_scene, CompositeOptions};
use crate::error::{Error, Result};
use crate::experiment::paper_room::{
    FitPhotos, Lighting, Object, PaperRoom, SceneSpec, Surroundings,
};
use crate::fit::{fit_scene_file, FitOptions, FitOutcome};
use glam::Vec3;
use plsr::film::Film;
use plsr::render::{render, RenderOptions};
use plsr::scene::{file, Scene};
use plsr_base::Vocabulary;
use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::synth::{write_brackets, BracketOptions, CameraModel};
use plsr_metrics::{compare_files, CompareOptions, Crop, CropSpec, Metric, MetricImage};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Sizes and samples of a run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    /// Size of the photos (pixels).
    pub resolution: (u32, u32),
    /// Samples per pixel of the ground-truth photos.
    pub truth_spp: u32,
    /// Samples per pixel of each of a composite's two renders.
    pub composite_spp: u32,
    /// Size of the panorama (pixels, 2:1).
    pub panorama_size: (u32, u32),
    /// Samples per pixel of the panorama.
    pub panorama_spp: u32,
    /// Samples per pixel of the fit's renders (its window search renders
    /// at 4×).
    pub fit_spp: u32,
    /// Adam iterations of the fit.
    pub fit_iterations: u32,
    /// The most renders the fit's window search makes per light and pass.
    pub fit_window_evaluations: u32,
}

impl Settings {
    /// The full experiment (about 13 minutes on two cores before the fit from
    /// photos was added; not yet timed with it).
    pub fn full() -> Settings {
        Settings {
            resolution: (256, 192),
            truth_spp: 1024,
            composite_spp: 512,
            panorama_size: (512, 256),
            panorama_spp: 256,
            fit_spp: 4,
            fit_iterations: 100,
            fit_window_evaluations: 80,
        }
    }

    /// The whole pipeline, small (about 100 s on two cores).
    pub fn quick() -> Settings {
        Settings {
            resolution: (192, 144),
            truth_spp: 64,
            composite_spp: 32,
            panorama_size: (128, 64),
            panorama_spp: 32,
            fit_spp: 1,
            fit_iterations: 40,
            fit_window_evaluations: 40,
        }
    }
}

/// How to run the experiment.
#[derive(Debug, Clone)]
pub struct PaperOptions {
    /// The new folder everything is written into (must not exist or be
    /// empty).
    pub out: PathBuf,
    /// The Stanford bunny's OBJ file.
    pub bunny: PathBuf,
    /// Sizes and samples.
    pub settings: Settings,
    /// Worker threads (`None`: all cores).
    pub threads: Option<usize>,
}

/// How an object was lit in a row of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// The PLS lights derived from the fixtures' geometry ("measured").
    Pls,
    /// The PLS lights' windows and brightness, and the room's albedos,
    /// fitted from the photos without objects.
    Fitted,
    /// The HDR panorama as an infinitely distant environment.
    Panorama,
    /// Not composited: a second photo of the real object (other samples
    /// and camera noise), the best score any method can expect.
    NoiseFloor,
}

impl Method {
    /// All four, in the table's order.
    pub const ALL: [Method; 4] = [
        Method::Pls,
        Method::Fitted,
        Method::Panorama,
        Method::NoiseFloor,
    ];

    /// Its name in tables and file names.
    pub fn name(self) -> &'static str {
        match self {
            Method::Pls => "pls",
            Method::Fitted => "fitted",
            Method::Panorama => "panorama",
            Method::NoiseFloor => "noise-floor",
        }
    }

    /// Its label in the table.
    pub fn label(self) -> &'static str {
        match self {
            Method::Pls => "PLS, measured",
            Method::Fitted => "PLS, fitted from photos",
            Method::Panorama => "panorama",
            Method::NoiseFloor => "noise floor (2nd photo)",
        }
    }
}

/// One scored image: an object at a position, lit by a method.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    /// The object.
    pub object: Object,
    /// Its position (0: the flashlight's beam, 1: under the lamp).
    pub position: usize,
    /// How it was lit.
    pub method: Method,
    /// The window compared.
    pub crop: Crop,
    /// CW-SSIM (higher is better, 1 is identical).
    pub cwssim: f64,
    /// LPIPS (lower is better, 0 is identical).
    pub lpips: f64,
    /// Mean FLIP error (lower is better, 0 is identical).
    pub flip: f64,
}

/// What a run found.
#[derive(Debug, Clone)]
pub struct PaperResults {
    /// Every score: object × position × method.
    pub rows: Vec<Row>,
    /// The derived PLS lights' windows: name, `a` and `w` in degrees.
    pub windows: Vec<(String, f32, f32)>,
    /// What the fit from photos found.
    pub fit: FitFromPhotos,
    /// Wall-clock seconds of the whole run.
    pub seconds: f64,
}

impl PaperResults {
    /// The row of an object at a position lit by a method.
    pub fn row(&self, object: Object, position: usize, method: Method) -> Option<&Row> {
        self.rows
            .iter()
            .find(|r| r.object == object && r.position == position && r.method == method)
    }

    /// The table, as Markdown: one column per position and object, rows
    /// per metric and method.
    pub fn table(&self) -> String {
        let mut s = String::new();
        let cases: Vec<(usize, Object)> = [0, 1]
            .iter()
            .flat_map(|&p| Object::ALL.iter().map(move |&o| (p, o)))
            .collect();
        let _ = write!(s, "| metric | method |");
        for (p, o) in &cases {
            let _ = write!(s, " {} at {} |", o.name(), POSITION_NAMES[*p]);
        }
        let _ = writeln!(s);
        let _ = writeln!(s, "|---|---|{}", "---:|".repeat(cases.len()));
        let metrics: [(&str, MetricOf); 3] = [
            ("CW-SSIM ↑", |r| r.cwssim),
            ("LPIPS ↓", |r| r.lpips),
            ("FLIP ↓", |r| r.flip),
        ];
        for (name, value) in metrics {
            for method in Method::ALL {
                let _ = write!(s, "| {name} | {} |", method.label());
                for (p, o) in &cases {
                    match self.row(*o, *p, method) {
                        Some(r) => {
                            let _ = write!(s, " {:.4} |", value(r));
                        }
                        None => s.push_str(" – |"),
                    }
                }
                let _ = writeln!(s);
            }
        }
        s
    }

    /// The results as JSON.
    pub fn json(&self) -> String {
        let rows: Vec<serde_json::Value> = self
            .rows
            .iter()
            .map(|r| {
                serde_json::json!({
                    "object": r.object.name(),
                    "position": r.position + 1,
                    "method": r.method.name(),
                    "crop": [r.crop.x, r.crop.y, r.crop.w, r.crop.h],
                    "cwssim": r.cwssim,
                    "lpips": r.lpips,
                    "flip": r.flip,
                })
            })
            .collect();
        let windows: Vec<serde_json::Value> = self
            .windows
            .iter()
            .map(|(n, a, w)| serde_json::json!({"light": n, "a": a, "penumbra": w}))
            .collect();
        let fit = serde_json::json!({
            "lights": self.fit.lights.iter().map(|(n, a, w, b)| {
                serde_json::json!({"light": n, "a": a, "penumbra": w, "b": b})
            }).collect::<Vec<_>>(),
            "albedos": self.fit.albedos.iter().map(|(n, v)| {
                serde_json::json!({"material": n, "reflectance": v})
            }).collect::<Vec<_>>(),
            "loss": [self.fit.loss.0, self.fit.loss.1],
            "seconds": self.fit.seconds,
        });
        let v = serde_json::json!({
            "rows": rows,
            "pls_windows": windows,
            "fit_from_photos": fit,
            "seconds": self.seconds,
        });
        serde_json::to_string_pretty(&v).expect("JSON of numbers and strings")
    }
}

/// Reads one metric's value from a row.
type MetricOf = fn(&Row) -> f64;

/// The positions' names in tables.
pub const POSITION_NAMES: [&str; 2] = ["1 (flashlight)", "2 (lamp)"];

/// Render seeds: the photo without objects, the photos with them, the
/// second photos with them, and the composites.
const SEED_EMPTY: u64 = 1;
const SEED_TRUTH: u64 = 2;
const SEED_SECOND: u64 = 3;
const SEED_COMPOSITE: u64 = 4;
/// The fit's base seed.
const SEED_FIT: u64 = 5;

/// Runs the experiment into the new folder `options.out`; `log` receives
/// one line per step. On failure nothing is left behind.
pub fn run(options: &PaperOptions, log: &(dyn Fn(&str) + Sync)) -> Result<PaperResults> {
    let out = &options.out;
    if out.exists()
        && std::fs::read_dir(out)
            .map(|mut d| d.next().is_some())
            .unwrap_or(true)
    {
        return Err(Error::output(
            out.clone(),
            "the output folder exists and is not empty: remove it or choose another",
        ));
    }
    let bunny = std::fs::canonicalize(&options.bunny)
        .map_err(|source| Error::io(options.bunny.clone(), source))?;
    plsr_base::atomic_write::sweep_stale_partials(out);
    let staging = plsr_base::atomic_write::partial_path(out);
    plsr_base::atomic_write::register_partial(&staging);
    let result = run_in(&staging, &bunny, options, log);
    let placed = result.and_then(|results| {
        if out.exists() {
            std::fs::remove_dir(out).map_err(|source| Error::io(out.clone(), source))?;
        }
        std::fs::rename(&staging, out).map_err(|source| Error::io(out.clone(), source))?;
        Ok(results)
    });
    if placed.is_err() {
        let _ = std::fs::remove_dir_all(&staging);
    }
    plsr_base::atomic_write::forget_partial(&staging);
    placed
}

fn io(file: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::io(file.to_path_buf(), source)
}

fn mkdir(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir).map_err(io(dir))
}

fn write_text(path: &Path, text: &str) -> Result<()> {
    std::fs::write(path, text).map_err(io(path))
}

/// The experiment, written into `dir` (the staging folder).
fn run_in(
    dir: &Path,
    bunny: &Path,
    options: &PaperOptions,
    log: &(dyn Fn(&str) + Sync),
) -> Result<PaperResults> {
    let start = Instant::now();
    let mut run = Run::new(dir, bunny, options, log);
    let windows = run.prepare()?;

    // 1. The ground-truth photos.
    for position in 0..2 {
        run.photograph_position(position)?;
    }

    // 2. The panorama, captured where the flashlight's beam does not reach.
    let panorama = run.capture_panorama()?;

    // 2b. The PLS lights' windows and the room's albedos, fitted from the
    // photos without objects (read through the panorama's curve).
    let fit = run.fit_from_photos(&panorama)?;

    // 3 and 4. Composites and scores.
    let compare_options = CompareOptions {
        metrics: vec![Metric::CwSsim, Metric::Lpips, Metric::Flip],
        cwssim: Default::default(),
        flip: Default::default(),
    };
    let mut rows = Vec::new();
    for position in 0..2 {
        for object in Object::ALL {
            run.composite_and_score(object, position, &panorama, &compare_options, &mut rows)?;
        }
    }

    let results = PaperResults {
        rows,
        windows,
        fit,
        seconds: start.elapsed().as_secs_f64(),
    };
    run.write_results(&results)?;
    Ok(results)
}

/// Progress callback of the experiment's renders: never cancels.
fn no_progress(_: usize, _: usize) -> bool {
    true
}

/// What every step of a run shares: where it writes, what it renders,
/// how, and where it logs.
struct Run<'a> {
    /// The staging folder.
    dir: &'a Path,
    /// The Stanford bunny's OBJ (absolute).
    bunny: &'a Path,
    /// Sizes and samples.
    settings: Settings,
    /// Worker threads (`None`: all cores).
    threads: Option<usize>,
    /// The room.
    room: PaperRoom,
    /// Options of every render.
    render_options: RenderOptions,
    /// The scene files (and their meshes and PLS file).
    scenes: PathBuf,
    /// The ground-truth photos.
    photos: PathBuf,
    /// The panorama's brackets, merge and response curve.
    panorama_dir: PathBuf,
    /// The composites and their masks.
    composites: PathBuf,
    /// One line per step.
    log: &'a (dyn Fn(&str) + Sync),
    /// Noise seed of the last photo taken (each photo takes the next).
    camera_seed: u64,
    /// The fit's loss curves.
    fit_dir: PathBuf,
    /// Each position's photo exposure time (seconds), once photographed.
    exposures: [f64; 2],
    /// What the fit from photos found, once fitted.
    fitted: Option<FitFromPhotos>,
}

/// What the fit from photos found (see `Run::fit_from_photos`).
#[derive(Debug, Clone, PartialEq)]
pub struct FitFromPhotos {
    /// Each fitted PLS light: its name, window `a` and soft edge `w`
    /// (degrees) and brightness `b` (in the photos' units: the panorama's).
    pub lights: Vec<(String, f32, f32, f32)>,
    /// The fitted albedos, by material name.
    pub albedos: Vec<(String, [f32; 3])>,
    /// The loss before and after the fit.
    pub loss: (f64, f64),
    /// Wall-clock seconds of the fit.
    pub seconds: f64,
    /// The fitted PLS file, as the scenes folder names it.
    pls: PathBuf,
}

/// The merged panorama and how the 360° camera was oriented.
struct Panorama {
    /// The panorama (OpenEXR).
    file: PathBuf,
    /// The response curve recovered by the merge (CSV).
    curve: PathBuf,
    /// The camera's zenith.
    up: Vec3,
    /// Its centre column's direction.
    forward: Vec3,
}

impl<'a> Run<'a> {
    /// The context of a run into `dir`.
    fn new(
        dir: &'a Path,
        bunny: &'a Path,
        options: &PaperOptions,
        log: &'a (dyn Fn(&str) + Sync),
    ) -> Run<'a> {
        Run {
            dir,
            bunny,
            settings: options.settings,
            threads: options.threads,
            room: PaperRoom::new(),
            render_options: RenderOptions {
                threads: options.threads,
                ..Default::default()
            },
            scenes: dir.join("scenes"),
            photos: dir.join("photos"),
            panorama_dir: dir.join("panorama"),
            composites: dir.join("composites"),
            log,
            camera_seed: 100,
            fit_dir: dir.join("fit"),
            exposures: [f64::NAN; 2],
            fitted: None,
        }
    }

    /// Makes the folders, writes the room's meshes and the PLS file
    /// derived from its fixtures; returns the PLS lights' windows.
    fn prepare(&self) -> Result<Vec<(String, f32, f32)>> {
        for d in [
            &self.scenes,
            &self.photos,
            &self.panorama_dir,
            &self.composites,
            &self.fit_dir,
        ] {
            mkdir(d)?;
        }
        mkdir(&self.scenes.join("meshes"))?;
        for (name, text) in self.room.meshes() {
            write_text(&self.scenes.join("meshes").join(name), &text)?;
        }
        let pls = self.room.pls();
        let pls_file = self.scenes.join("lights.pls.toml");
        write_text(
            &pls_file,
            &plsr::light::pls::file::to_string(&pls, &pls_file)?,
        )?;
        let windows: Vec<(String, f32, f32)> = pls
            .lights
            .iter()
            .map(|l| (l.name.clone().unwrap_or_default(), l.a_deg, l.penumbra_deg))
            .collect();
        for (n, a, w) in &windows {
            (self.log)(&format!(
                "derived the {n}'s PLS light from its geometry: a = {a:.2}°, soft edge w = {w:.2}°"
            ));
        }
        Ok(windows)
    }

    /// The room seen by a camera, lit by its fixtures, without objects.
    fn spec(&self, title: String, camera: usize, spp: u32, seed: u64) -> SceneSpec {
        SceneSpec {
            title,
            meshes: PathBuf::from("meshes"),
            bunny: self.bunny.to_path_buf(),
            camera,
            resolution: self.settings.resolution,
            spp,
            seed,
            surroundings: Surroundings::Room,
            lighting: Lighting::Fixtures,
            objects: Vec::new(),
            photo: None,
            albedos: Vec::new(),
            fit_photos: None,
        }
    }

    /// Writes a scene file into the scenes' folder; returns its path.
    fn write_scene(&self, name: &str, spec: &SceneSpec) -> Result<PathBuf> {
        let path = self.scenes.join(name);
        write_text(&path, &self.room.scene_text(spec))?;
        Ok(path)
    }

    /// Renders a scene file.
    fn render_file(&self, path: &Path) -> Result<Film> {
        let scene = Scene::build(file::load(path)?)?;
        let (film, _) = render(
            &scene,
            &scene.default_job(),
            &self.render_options,
            &no_progress,
        )?;
        Ok(film)
    }

    /// Photographs a film with the simulated camera (the next noise seed)
    /// at exposure time `t` into the PNG `path`.
    fn photograph(&mut self, film: &Film, t: f64, path: &Path) -> Result<()> {
        self.camera_seed += 1;
        let tmp = self.photos.join(".bracket");
        mkdir(&tmp)?;
        let camera = CameraModel {
            seed: self.camera_seed,
            ..CameraModel::default()
        };
        let written = write_brackets(
            &crate::capture::FilmRadiance(film),
            &camera,
            &[t],
            &tmp,
            &BracketOptions {
                extension: "png".into(),
                ..Default::default()
            },
        )?;
        std::fs::rename(&written[0], path).map_err(io(path))?;
        std::fs::remove_dir(&tmp).map_err(io(&tmp))
    }

    /// Step 1 at one position: the photo without objects, then each
    /// object's photo and second photo, all at the empty room's exposure.
    fn photograph_position(&mut self, position: usize) -> Result<()> {
        let step = Instant::now();
        let p = position + 1;
        let truth_spp = self.settings.truth_spp;
        let path = self.write_scene(
            &format!("truth-empty-{p}.toml"),
            &self.spec(
                format!("Ground truth: the room seen by camera {p}, no objects."),
                position,
                truth_spp,
                SEED_EMPTY,
            ),
        )?;
        let film = self.render_file(&path)?;
        let t = exposure_time(&film);
        self.exposures[position] = t;
        let empty = self.photos.join(format!("empty-{p}.png"));
        self.photograph(&film, t, &empty)?;
        for object in Object::ALL {
            let o = object.name();
            for (seed, suffix, what) in [
                (SEED_TRUTH, "", "the photo"),
                (
                    SEED_SECOND,
                    "-second",
                    "a second photo (other samples and noise)",
                ),
            ] {
                let path = self.write_scene(
                    &format!("truth-{o}-{p}{suffix}.toml"),
                    &SceneSpec {
                        objects: vec![(object, position, false)],
                        ..self.spec(
                            format!("Ground truth: {what} of the real {o} at position {p}."),
                            position,
                            truth_spp,
                            seed,
                        )
                    },
                )?;
                let film = self.render_file(&path)?;
                let photo = self.photos.join(format!("{o}-{p}{suffix}.png"));
                self.photograph(&film, t, &photo)?;
            }
        }
        (self.log)(&format!(
            "photographed position {}: 5 photos at {} spp, exposure {t:.3} s, {:.1} s",
            POSITION_NAMES[position],
            truth_spp,
            step.elapsed().as_secs_f64()
        ));
        Ok(())
    }

    /// Step 2: captures the brackets at the sensor and merges them into
    /// the panorama and the camera's response curve.
    fn capture_panorama(&self) -> Result<Panorama> {
        let step = Instant::now();
        let settings = self.settings;
        let capture_scene = self.write_scene(
            "capture.toml",
            &self.spec(
                "The room for the 360° capture (the camera is replaced by the panorama's).".into(),
                0,
                settings.panorama_spp,
                SEED_EMPTY,
            ),
        )?;
        let (up, forward) = (Vec3::Z, Vec3::Y);
        let brackets = capture(
            &capture_scene,
            &self.panorama_dir.join("brackets"),
            &CaptureOptions {
                at: self.room.sensor,
                up: Some(up),
                forward: Some(forward),
                size: settings.panorama_size,
                spp: Some(settings.panorama_spp),
                // The paper's ten, as its capture used.
                exposures: Some(PAPER_EXPOSURES.to_vec()),
                camera: CameraModel {
                    seed: 7,
                    ..CameraModel::default()
                },
                format: "tif".into(),
                threads: self.threads,
            },
            &no_progress,
        )?
        .paths;
        let panorama = self.panorama_dir.join("panorama.exr");
        let curve = self.panorama_dir.join("curve.csv");
        merge(
            &brackets,
            &panorama,
            &MergeOptions {
                curve_csv: Some(curve.clone()),
                threads: self.threads,
                ..Default::default()
            },
            &|_, _, _| {},
        )?;
        (self.log)(&format!(
            "captured and merged the {}×{} panorama at ({:.2}, {:.2}, {:.2}) from {} brackets, {:.1} s",
            settings.panorama_size.0,
            settings.panorama_size.1,
            self.room.sensor.x,
            self.room.sensor.y,
            self.room.sensor.z,
            brackets.len(),
            step.elapsed().as_secs_f64()
        ));
        Ok(Panorama {
            file: panorama,
            curve,
            up,
            forward,
        })
    }

    /// Step 2b: fits the PLS lights and the room's albedos to the two
    /// photos without objects, as a user with only those photos, the
    /// fixtures' outlines and the panorama's response curve would:
    /// - the photos are read through the panorama's curve and divided by
    ///   their exposure times, which puts them in the panorama's units;
    /// - the lights start from guessed windows (flashlight 15° and 10°,
    ///   lamp 60° and 30°) and brightness 1; their outlines and directions
    ///   are the fixtures' (measured geometry);
    /// - the walls, table, bookcase and cabinet start grey (0.5); the floor
    ///   keeps its known albedo (it pins the split between albedo and
    ///   brightness, as a grey card would); the ceiling, which neither
    ///   camera sees, keeps its guess.
    ///
    /// Two passes: the windows (each light's search renders the other at
    /// its current brightness), then the windows again and Adam on both
    /// brightnesses and the four albedos. Writes `scenes/fit.toml`, the
    /// fitted scenes and PLS files, and the loss curves into `fit/`.
    fn fit_from_photos(&mut self, panorama: &Panorama) -> Result<FitFromPhotos> {
        let step = Instant::now();
        let mut guess = self.room.pls();
        for light in &mut guess.lights {
            let (a, w) = match light.name.as_deref() {
                Some("flashlight") => (15.0, 10.0),
                _ => (60.0, 30.0),
            };
            (light.a_deg, light.penumbra_deg, light.b) = (a, w, 1.0);
        }
        let guess_file = self.scenes.join("guess.pls.toml");
        write_text(
            &guess_file,
            &plsr::light::pls::file::to_string(&guess, &guess_file)?,
        )?;
        let fitted_materials = ["wall", "table", "bookcase", "cabinet"];
        let albedos = fitted_materials
            .iter()
            .chain(&["ceiling"])
            .map(|name| (name.to_string(), [0.5; 3]))
            .collect();
        let photos = (0..2)
            .map(|position| {
                let photo = self.photos.join(format!("empty-{}.png", position + 1));
                (position, self.rel(&photo), self.exposures[position])
            })
            .collect();
        let settings = self.settings;
        let scene = self.write_scene(
            "fit.toml",
            &SceneSpec {
                lighting: Lighting::Pls("guess.pls.toml".into()),
                albedos,
                fit_photos: Some(FitPhotos {
                    curve: self.rel(&panorama.curve),
                    photos,
                }),
                ..self.spec(
                    "The room to fit to the photos without objects: guessed windows and albedos."
                        .into(),
                    0,
                    settings.fit_spp,
                    SEED_FIT,
                )
            },
        )?;
        let base = FitOptions {
            iterations: settings.fit_iterations,
            spp: settings.fit_spp,
            seed: Some(SEED_FIT),
            threads: self.threads,
            windows: vec!["flashlight".into(), "lamp".into()],
            window_evaluations: Some(settings.fit_window_evaluations),
            ..Default::default()
        };
        let windows_only = self.scenes.join("fit-windows.toml");
        let first = self.fit_pass(&scene, &windows_only, "windows", &base)?;
        let fitted_scene = self.scenes.join("fitted.toml");
        let params = fitted_materials
            .iter()
            .map(|m| format!("{m}.reflectance"))
            .chain(["flashlight.b".into(), "lamp.b".into()])
            .collect();
        let second = self.fit_pass(
            &windows_only,
            &fitted_scene,
            "fitted",
            &FitOptions { params, ..base },
        )?;
        let value = |owner: &str, field: &str| {
            second
                .parameters
                .iter()
                .find(|p| p.field == field && p.name == format!("{owner}.{field}"))
                .map(|p| p.value.clone())
        };
        let lights = second
            .windows
            .iter()
            .map(|(name, w)| {
                let b = value(name, "b").map_or(w.b, |v| v[0]);
                (name.clone(), w.a_deg, w.penumbra_deg, b)
            })
            .collect();
        let albedos = fitted_materials
            .iter()
            .filter_map(|m| {
                let v = value(m, "reflectance")?;
                Some((m.to_string(), [v[0], v[1], v[2]]))
            })
            .collect();
        let pls = second
            .fitted
            .pls
            .first()
            .and_then(|(path, _)| path.file_name())
            .map(PathBuf::from)
            .ok_or_else(|| Error::invalid_argument("the fit wrote no PLS file"))?;
        let fit = FitFromPhotos {
            lights,
            albedos,
            loss: (
                first.losses.first().copied().unwrap_or(f64::NAN),
                second.losses.last().copied().unwrap_or(f64::NAN),
            ),
            seconds: step.elapsed().as_secs_f64(),
            pls,
        };
        for (name, a, w, b) in &fit.lights {
            (self.log)(&format!(
                "fitted the {name}'s PLS light from the photos: a = {a:.2}°, soft edge w = {w:.2}°, b = {b:.4}"
            ));
        }
        (self.log)(&format!(
            "fitted {} from the photos without objects: loss {:.3e} → {:.3e}, {:.1} s",
            fit.albedos
                .iter()
                .map(|(n, v)| format!("{n} [{:.2}, {:.2}, {:.2}]", v[0], v[1], v[2]))
                .collect::<Vec<_>>()
                .join(", "),
            fit.loss.0,
            fit.loss.1,
            fit.seconds
        ));
        self.fitted = Some(fit.clone());
        Ok(fit)
    }

    /// One pass of the fit: `scene` fitted into `out`, its loss curve
    /// written into `fit/NAME.loss.csv` and `.png`.
    fn fit_pass(
        &self,
        scene: &Path,
        out: &Path,
        name: &str,
        options: &FitOptions,
    ) -> Result<FitOutcome> {
        let outcome = fit_scene_file(scene, out, options, &mut |_, _| true)?;
        let mut inputs = file::load_contents(scene)?.inputs;
        inputs.push(scene.to_path_buf());
        outcome.write(
            out,
            &self.fit_dir.join(format!("{name}.loss.csv")),
            &self.fit_dir.join(format!("{name}.loss.png")),
            &inputs,
        )?;
        Ok(outcome)
    }

    /// A path inside the run as written into a scene file (relative to
    /// the scenes' folder).
    fn rel(&self, p: &Path) -> PathBuf {
        Path::new("..").join(p.strip_prefix(self.dir).expect("inside the run"))
    }

    /// Steps 3 and 4 for one object at one position: its two composites,
    /// then the scores of those and of its second photo, appended to
    /// `rows`.
    fn composite_and_score(
        &self,
        object: Object,
        position: usize,
        panorama: &Panorama,
        compare_options: &CompareOptions,
        rows: &mut Vec<Row>,
    ) -> Result<()> {
        let step = Instant::now();
        let p = position + 1;
        let o = object.name();
        let truth = self.photos.join(format!("{o}-{p}.png"));
        let mask = self.composites.join(format!("mask-{o}-{p}.png"));
        let mask_source = plsr_metrics::MaskSource {
            path: mask.clone(),
            channel: None,
        };
        let mut scored = Vec::new();
        for method in [Method::Pls, Method::Fitted, Method::Panorama] {
            let png = self.composite(object, position, method, panorama, &mask)?;
            scored.push((method, png));
        }
        scored.push((
            Method::NoiseFloor,
            self.photos.join(format!("{o}-{p}-second.png")),
        ));
        for (method, test) in scored {
            let report = compare_files(
                &truth,
                &test,
                Some(&mask_source),
                CropSpec::Auto,
                compare_options,
            )?;
            let score = |metric: Metric| {
                report
                    .scores
                    .iter()
                    .find(|s| s.metric == metric)
                    .map_or(f64::NAN, |s| s.value)
            };
            rows.push(Row {
                object,
                position,
                method,
                crop: report.crop,
                cwssim: score(Metric::CwSsim),
                lpips: score(Metric::Lpips),
                flip: score(Metric::Flip),
            });
        }
        let line = |m: Method| {
            let r = rows
                .iter()
                .rev()
                .find(|r| r.method == m)
                .expect("just scored");
            format!("{} CW-SSIM {:.4} LPIPS {:.4}", m.label(), r.cwssim, r.lpips)
        };
        (self.log)(&format!(
            "{o} at position {p}: {}; {}; {}; {}; {:.1} s",
            line(Method::Pls),
            line(Method::Fitted),
            line(Method::Panorama),
            line(Method::NoiseFloor),
            step.elapsed().as_secs_f64()
        ));
        Ok(())
    }

    /// Step 3 for one object, position and method: writes the composite's
    /// scene file, composites it into the photo without objects, writes
    /// the composite (and, for PLS, the object's mask); returns its PNG.
    fn composite(
        &self,
        object: Object,
        position: usize,
        method: Method,
        panorama: &Panorama,
        mask: &Path,
    ) -> Result<PathBuf> {
        let p = position + 1;
        let o = object.name();
        let mut albedos = Vec::new();
        let (surroundings, lighting) = match method {
            Method::Pls => (Surroundings::Room, Lighting::Pls("lights.pls.toml".into())),
            Method::Fitted => {
                let fitted = self
                    .fitted
                    .as_ref()
                    .expect("the fit runs before the composites");
                albedos = fitted.albedos.clone();
                (Surroundings::Room, Lighting::Pls(fitted.pls.clone()))
            }
            _ => (
                Surroundings::Local,
                Lighting::Panorama {
                    file: self.rel(&panorama.file),
                    up: panorama.up,
                    forward: panorama.forward,
                },
            ),
        };
        let m = method.name();
        let path = self.write_scene(
            &format!("{m}-{o}-{p}.toml"),
            &SceneSpec {
                surroundings,
                lighting,
                albedos,
                objects: vec![(object, position, true)],
                photo: Some((
                    self.rel(&self.photos.join(format!("empty-{p}.png"))),
                    self.rel(&panorama.curve),
                )),
                ..self.spec(
                    format!("The virtual {o} composited at position {p}, lit by {m}."),
                    position,
                    self.settings.composite_spp,
                    SEED_COMPOSITE,
                )
            },
        )?;
        let contents = file::load_contents(&path)?;
        let (c, transfer, _) = composite_scene(
            &path,
            contents,
            &CompositeOptions {
                render: self.render_options,
                ..Default::default()
            },
            &no_progress,
        )?;
        let mut outputs = plsr_base::atomic_write::OutputSet::new();
        let png = self.composites.join(format!("{m}-{o}-{p}.png"));
        c.stage_exr(
            &mut outputs,
            &self.composites.join(format!("{m}-{o}-{p}.exr")),
        )?;
        c.stage_png(&mut outputs, &png, &transfer)?;
        outputs.commit()?;
        if method == Method::Pls {
            write_mask(&c.matte, c.width, c.height, mask)?;
        }
        Ok(png)
    }

    /// Writes the figure, `results.json` and `results.md`.
    fn write_results(&self, results: &PaperResults) -> Result<()> {
        let settings = self.settings;
        let dir = self.dir;
        figure(dir, results)?;
        write_text(&dir.join("results.json"), &results.json())?;
        write_text(
            &dir.join("results.md"),
            &format!(
                "# plsr experiment paper\n\n{}\nPhotos {}×{} at {} spp; composites at {} spp; panorama {}×{} at {} spp; fit from photos at {} spp, {} iterations ({:.0} s). {:.0} s.\n",
                results.table(),
                settings.resolution.0,
                settings.resolution.1,
                settings.truth_spp,
                settings.composite_spp,
                settings.panorama_size.0,
                settings.panorama_size.1,
                settings.panorama_spp,
                settings.fit_spp,
                settings.fit_iterations,
                results.fit.seconds,
                results.seconds
            ),
        )
    }
}

/// The exposure time (seconds) that puts the 99.5th percentile of the
/// brightest channel at 15 % of the simulated camera's clipping exposure
/// (72 % of its output range), clear of its compressed highlights, where
/// the recovered response curve magnifies noise.
fn exposure_time(film: &Film) -> f64 {
    let mut v: Vec<f32> = film.color.iter().map(|c| c.max_element()).collect();
    v.sort_by(f32::total_cmp);
    let p = v[(v.len() as f64 * 0.995) as usize % v.len()].max(1e-6);
    0.15 / p as f64
}

/// Writes the matte as an 8-bit mask: white where the object covers at
/// least half a pixel.
fn write_mask(matte: &[f32], width: u32, height: u32, path: &Path) -> Result<()> {
    let pixels: Vec<u8> = matte
        .iter()
        .map(|&a| if a >= 0.5 { 255 } else { 0 })
        .collect();
    let image = image::GrayImage::from_raw(width, height, pixels).expect("one value per pixel");
    image
        .save(path)
        .map_err(|e| Error::output(path.to_path_buf(), e.to_string()))
}

/// Height of a row of the figure (pixels).
const FIGURE_ROW: u32 = 160;

/// `figure.png`: one row per object and position, in the table's order;
/// columns: the photo of the real object, the composites lit by the
/// measured PLS lights, by the ones fitted from photos and by the
/// panorama, each the crop that was scored, scaled to one height.
fn figure(dir: &Path, results: &PaperResults) -> Result<()> {
    let gap = 4;
    let mut tiles: Vec<Vec<image::RgbImage>> = Vec::new();
    for position in 0..2 {
        let p = position + 1;
        for object in Object::ALL {
            let o = object.name();
            let Some(row) = results.row(object, position, Method::Pls) else {
                continue;
            };
            let mut line = Vec::new();
            for file in [
                dir.join("photos").join(format!("{o}-{p}.png")),
                dir.join("composites").join(format!("pls-{o}-{p}.png")),
                dir.join("composites").join(format!("fitted-{o}-{p}.png")),
                dir.join("composites").join(format!("panorama-{o}-{p}.png")),
            ] {
                let img = MetricImage::load(&file)?.crop(row.crop);
                let rgb: Vec<u8> = img
                    .display()
                    .iter()
                    .map(|v| (v.clamp(0.0, 1.0) * 255.0).round() as u8)
                    .collect();
                let (w, h) = (img.width as u32, img.height as u32);
                let tile = image::RgbImage::from_raw(w, h, rgb).expect("three values per pixel");
                let w = (w as f32 * FIGURE_ROW as f32 / h as f32).round() as u32;
                line.push(image::imageops::resize(
                    &tile,
                    w.max(1),
                    FIGURE_ROW,
                    image::imageops::FilterType::Nearest,
                ));
            }
            tiles.push(line);
        }
    }
    let width = tiles
        .iter()
        .map(|l| l.iter().map(|t| t.width() + gap).sum::<u32>() - gap)
        .max()
        .unwrap_or(1);
    let height = tiles.len() as u32 * (FIGURE_ROW + gap) - gap;
    let mut fig = image::RgbImage::from_pixel(width, height.max(1), image::Rgb([255, 255, 255]));
    for (r, line) in tiles.iter().enumerate() {
        let mut x = 0;
        for t in line {
            image::imageops::replace(
                &mut fig,
                t,
                x as i64,
                (r as u32 * (FIGURE_ROW + gap)) as i64,
            );
            x += t.width() + gap;
        }
    }
    let path = dir.join("figure.png");
    fig.save(&path)
        .map_err(|e| Error::output(path.clone(), e.to_string()))
}
