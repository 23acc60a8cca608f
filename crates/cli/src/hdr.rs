//! `plsr hdr merge`.

use crate::error::{Error, Result};
use crate::progress::progress_bar;
use clap::Subcommand;
use plsr_base::Vocabulary;
use plsr_hdr::merge::{merge, parse_exposures, Calibration, MergeOptions};
use plsr_hdr::response::ResponseMethod;
use std::cell::RefCell;
use std::path::PathBuf;

/// `plsr hdr …` subcommands.
#[derive(Debug, Subcommand)]
pub enum HdrCommand {
    /// Merge bracketed exposures (any order, any format OpenImageIO reads:
    /// JPEG, PNG, TIFF 8/16-bit, EXR, HDR, camera raw) into one float or half
    /// OpenEXR (or Radiance .hdr), recovering the camera response. Exposure
    /// times come from EXIF (ExposureTime, with FNumber and ISO when they
    /// differ) or from --exposures.
    Merge(HdrMergeArgs),
    /// Simulate a 360° camera's bracket capture: render the scene's
    /// equirectangular panorama at a position and write bracketed 8-bit
    /// photos through a camera response, with noise, clipping and EXIF
    /// exposure data (and the rendered truth as truth.exr), ready for
    /// `plsr hdr merge`. The panorama is never denoised: a capture's noise
    /// is a camera's, and denoising would bias the light it measures.
    Capture(HdrCaptureArgs),
}

/// Arguments of `plsr hdr capture`.
#[derive(Debug, clap::Args)]
pub struct HdrCaptureArgs {
    /// The scene file.
    pub scene: PathBuf,
    /// Camera position `X,Y,Z` (scene units).
    #[arg(long, value_name = "X,Y,Z")]
    pub at: String,
    /// Output folder (created; must not exist or be empty).
    #[arg(short, long, value_name = "DIR")]
    pub output: PathBuf,
    /// Zenith of the panorama `X,Y,Z` (default: the scene camera's up).
    #[arg(long, value_name = "X,Y,Z")]
    pub up: Option<String>,
    /// Centre column direction `X,Y,Z` (default: the scene camera's view).
    #[arg(long, value_name = "X,Y,Z")]
    pub forward: Option<String>,
    /// Panorama size `W,H` in pixels (the Theta Z1 records 6720,3360).
    #[arg(long, default_value = "512,256", value_name = "W,H")]
    pub size: String,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Exposure times in seconds (`1/30,1/15,…`), `paper` (the paper's ten,
    /// 1/30 s to 15 s) or `auto` (default: from the panorama's dynamic
    /// range, brightest light unclipped to darkest 1 % at mid-range, at
    /// most two stops apart).
    #[arg(long, value_name = "auto|paper|T1,T2,…", default_value = "auto")]
    pub exposures: String,
    /// Camera response: `filmic` (an 8-bit camera's curve) or `linear` (raw).
    #[arg(long, default_value = "filmic")]
    pub response: String,
    /// Turn off shot and read noise.
    #[arg(long)]
    pub no_noise: bool,
    /// Photo format: tif, png or jpg. (OpenImageIO 2.4's JPEG writer
    /// garbles some EXIF exposure times, e.g. 1/8 s; TIFF keeps them.)
    #[arg(long, default_value = "tif")]
    pub format: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
}

/// Arguments of `plsr hdr merge`.
#[derive(Debug, clap::Args)]
pub struct HdrMergeArgs {
    /// The bracketed images (at least two, same size), or a folder: every
    /// image in it (by extension), in name order.
    #[arg(required = true, value_name = "IMG")]
    pub images: Vec<PathBuf>,
    /// Output: OpenEXR (.exr), Radiance HDR (.hdr) or 32-bit float TIFF (.tif).
    #[arg(short, long, value_name = "PANO.exr")]
    pub output: PathBuf,
    /// Exposure times in seconds, one per image in the order given
    /// ("1/30,1/15,0.5,2"); default: from each image's EXIF.
    #[arg(long, value_name = "T1,T2,…")]
    pub exposures: Option<String>,
    /// Camera response: recovered (debevec, robertson) or a preset (linear
    /// for raw/linear data, srgb).
    #[arg(long, default_value = "debevec", value_parser = ["debevec", "robertson", "linear", "srgb"])]
    pub response: String,
    /// Use this response curve instead of recovering one: a CSV written by
    /// --curve (one camera's calibration, reused), or OpenCV's response
    /// saved as 256 rows of blue,green,red.
    #[arg(long, value_name = "CURVE.csv", conflicts_with = "response")]
    pub response_curve: Option<PathBuf>,
    /// Align the brackets first (translation, median threshold bitmaps).
    #[arg(long)]
    pub align: bool,
    /// Crop the output to the area every aligned bracket covers (auto: when
    /// --align moved any bracket; no: keep the whole frame, whose border
    /// repeats the shifted brackets' edge pixels).
    #[arg(long, value_name = "auto|yes|no", default_value = "auto")]
    pub crop_to_common: plsr_hdr::merge::CropMode,
    /// Deghost: where something moved between exposures (people, leaves),
    /// leave out the brackets that disagree with the best-exposed one, so the
    /// moving thing appears once, as that bracket saw it.
    #[arg(long)]
    pub deghost: bool,
    /// Write the response curve as CSV here, and its plot as PNG next to it.
    #[arg(long, value_name = "CURVE.csv")]
    pub curve: Option<PathBuf>,
    /// Store half floats instead of 32-bit floats (EXR only).
    #[arg(long)]
    pub half: bool,
    /// Debevec smoothness weight λ.
    #[arg(long, default_value_t = plsr_hdr::response::DEFAULT_LAMBDA)]
    pub lambda: f64,
    /// Debevec sample pixels, chosen spread over the image and the middle
    /// exposure's intensities (default: every point of a ~40,000-pixel lattice).
    #[arg(long)]
    pub samples: Option<usize>,
    /// The camera's black level, as a code value of the input (0–255 for
    /// 8-bit): values at and below it are the pedestal and its noise and
    /// carry no signal. `auto` finds it from the darkest bracket.
    #[arg(long, value_name = "auto|CODE", default_value = "auto")]
    pub black_level: String,
    /// The code value at and above which values are clipped. `auto` finds
    /// it from the brightest bracket.
    #[arg(long, value_name = "auto|CODE", default_value = "auto")]
    pub white_level: String,
    /// OpenEXR compression (zip, piz, zips, rle, dwaa, none, …); default:
    /// zip for --half, none for float (noisy float data barely compresses).
    #[arg(long)]
    pub compression: Option<String>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Print nothing but warnings and errors: no progress, no summary.
    #[arg(short, long)]
    pub quiet: bool,
    /// Absolute units from the EXIF f-number and ISO of the bracket of
    /// least exposure (any order of the files gives the same result): luminance L = K·N²·v/(t·S) cd/m² (v the linear pixel value,
    /// 1 at clipping), then 683 cd/m² = radiance 1.
    #[arg(long, conflicts_with_all = ["known_luminance", "known_radiance", "grey_card"])]
    pub exif_calibration: bool,
    /// K of --exif-calibration, in cd/m² (ISO 12232: 78/0.65 = 120).
    #[arg(long, requires = "exif_calibration", default_value_t = plsr_hdr::merge::DEFAULT_CALIBRATION_CONSTANT)]
    pub calibration_constant: f64,
    /// Absolute units from a window of known mean luminance in cd/m²
    /// (measured with a luminance meter): X0,Y0,X1,Y1=CD.
    #[arg(long, value_name = "X0,Y0,X1,Y1=CD", conflicts_with_all = ["known_radiance", "grey_card"])]
    pub known_luminance: Option<String>,
    /// Absolute units from a window of known mean radiance in plsr's units,
    /// W/(m²·sr) (luminance-weighted): X0,Y0,X1,Y1=L.
    #[arg(long, value_name = "X0,Y0,X1,Y1=L", conflicts_with = "grey_card")]
    pub known_radiance: Option<String>,
    /// Absolute units from a grey card in this window, lit by the
    /// --illuminance measured at the card: its luminance is ρ·E/π.
    #[arg(long, value_name = "X0,Y0,X1,Y1", requires = "illuminance")]
    pub grey_card: Option<String>,
    /// Illuminance at the grey card, in lux (a light meter's reading).
    #[arg(long, value_name = "LUX", requires = "grey_card")]
    pub illuminance: Option<f64>,
    /// The grey card's reflectance.
    #[arg(long, default_value_t = 0.18, requires = "grey_card")]
    pub card_reflectance: f64,
}

/// The window and value of `X0,Y0,X1,Y1=VALUE` (`with_value`) or
/// `X0,Y0,X1,Y1`.
fn calibration_window(flag: &str, s: &str, with_value: bool) -> Result<([usize; 4], f64)> {
    let bad = || {
        Error::invalid_argument(format!(
            "{flag} `{s}`: expected {}",
            if with_value {
                "X0,Y0,X1,Y1=VALUE (pixels, then a positive number)"
            } else {
                "X0,Y0,X1,Y1 (pixels)"
            }
        ))
    };
    let (window, value, rest) = match s.split_once('=') {
        Some((w, v)) if with_value => (
            w,
            v.trim().parse::<f64>().map_err(|_| bad())?,
            &s[w.len()..],
        ),
        None if !with_value => (s, 1.0, ""),
        _ => return Err(bad()),
    };
    // The image's size is known only when merging, which checks the
    // window against it.
    let [x0, y0, x1, y1] =
        crate::pixel_args::parse_rect_before(flag, window, rest, None)?.map(|v| v as usize);
    if !(value.is_finite() && value > 0.0) {
        return Err(Error::invalid_argument(format!(
            "{flag} `{s}`: the value must be positive"
        )));
    }
    Ok(([x0, y0, x1, y1], value))
}

/// The calibration `plsr hdr merge`'s options ask for.
fn calibration(a: &HdrMergeArgs) -> Result<Calibration> {
    use plsr_hdr::merge::LUMENS_PER_WATT;
    if a.exif_calibration {
        return Ok(Calibration::Exif {
            constant: a.calibration_constant,
        });
    }
    if let Some(s) = &a.known_luminance {
        let (window, cd) = calibration_window("--known-luminance", s, true)?;
        return Ok(Calibration::Region {
            window,
            luminance: cd / LUMENS_PER_WATT,
            source: format!("known luminance {cd} cd/m^2 over {s}, 683 lm/W"),
        });
    }
    if let Some(s) = &a.known_radiance {
        let (window, l) = calibration_window("--known-radiance", s, true)?;
        return Ok(Calibration::Region {
            window,
            luminance: l,
            source: format!("known radiance {l} W/(m^2 sr) over {s}"),
        });
    }
    if let Some(s) = &a.grey_card {
        let (window, _) = calibration_window("--grey-card", s, false)?;
        let e = a.illuminance.unwrap_or(0.0);
        let rho = a.card_reflectance;
        if !(e.is_finite() && e > 0.0) {
            return Err(Error::invalid_argument(format!(
                "--illuminance {e}: must be a positive number of lux"
            )));
        }
        if !(rho > 0.0 && rho <= 1.0) {
            return Err(Error::invalid_argument(format!(
                "--card-reflectance {rho}: must be in (0, 1]"
            )));
        }
        let cd = rho * e / std::f64::consts::PI;
        return Ok(Calibration::Region {
            window,
            luminance: cd / LUMENS_PER_WATT,
            source: format!(
                "grey card of reflectance {rho} over {s} under {e} lx: {cd:.4} cd/m^2, 683 lm/W"
            ),
        });
    }
    Ok(Calibration::Relative)
}

/// Runs one `plsr hdr` subcommand.
pub fn run(command: HdrCommand) -> Result<()> {
    match command {
        HdrCommand::Merge(a) => merge_command(&a),
        HdrCommand::Capture(a) => capture_command(&a),
    }
}

fn triple(flag: &str, s: &str) -> Result<glam::Vec3> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| Error::invalid_argument(format!("{flag}: expected X,Y,Z, got `{s}`")))?;
    match v[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(glam::Vec3::new(x, y, z))
        }
        _ => Err(Error::invalid_argument(format!(
            "{flag}: expected three finite numbers X,Y,Z, got `{s}`"
        ))),
    }
}

fn capture_command(a: &HdrCaptureArgs) -> Result<()> {
    use plsr_apps::capture::{capture, CaptureOptions, PAPER_EXPOSURES};
    use plsr_hdr::synth::CameraModel;
    let size = crate::pixel_args::parse_size("--size", &a.size, 1 << 15)?;
    let exposures = match a.exposures.trim() {
        "auto" => None,
        "paper" => Some(PAPER_EXPOSURES.to_vec()),
        s => Some(
            parse_exposures(s).map_err(|m| Error::invalid_argument(format!("--exposures: {m}")))?,
        ),
    };
    let mut camera = match a.response.as_str() {
        "filmic" => CameraModel::default(),
        "linear" => CameraModel::linear(),
        other => {
            return Err(Error::invalid_argument(format!(
                "--response: unknown camera response `{other}` (filmic, linear)"
            )))
        }
    };
    if a.no_noise {
        camera.read_noise = 0.0;
        camera.shot_noise = 0.0;
    }
    let options = CaptureOptions {
        at: triple("--at", &a.at)?,
        up: a.up.as_deref().map(|s| triple("--up", s)).transpose()?,
        forward: a
            .forward
            .as_deref()
            .map(|s| triple("--forward", s))
            .transpose()?,
        size,
        spp: a.spp,
        exposures,
        camera,
        format: a.format.to_ascii_lowercase(),
        threads: a.threads,
    };
    let bar = progress_bar(
        false,
        "{spinner} [{elapsed_precise}] rendering {wide_bar} {pos}/{len} tiles (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    let captured = capture(&a.scene, &a.output, &options, &progress)?;
    bar.finish_and_clear();
    println!(
        "plsr hdr capture: {} brackets of a {}×{} panorama at {} in {} (truth.exr beside them)",
        captured.paths.len(),
        size.0,
        size.1,
        a.at,
        a.output.display()
    );
    let times: Vec<String> = captured.exposures.iter().map(|&t| seconds(t)).collect();
    match &captured.plan {
        Some(plan) => println!(
            "  exposures from the panorama's dynamic range (radiance {:.3e} to {:.3e}, {:.1} stops apart): {} s",
            plan.darkest,
            plan.brightest,
            plan.step_stops,
            times.join(", ")
        ),
        None => println!("  exposures: {} s", times.join(", ")),
    }
    Ok(())
}

/// An exposure time as a photographer writes it: `1/250` below a tenth
/// of a second (rounded), `0.25` or `2.5` above.
fn seconds(t: f64) -> String {
    if t < 0.1 {
        format!("1/{:.0}", 1.0 / t)
    } else {
        format!("{:.3}", t)
            .trim_end_matches('0')
            .trim_end_matches('.')
            .to_string()
    }
}

/// `auto` (None) or a code value ≥ 0 of `--black-level`/`--white-level`.
fn level_option(value: &str, name: &str) -> Result<Option<f64>> {
    if value.eq_ignore_ascii_case("auto") {
        return Ok(None);
    }
    match value.parse::<f64>() {
        Ok(v) if v.is_finite() && v >= 0.0 => Ok(Some(v)),
        _ => Err(Error::invalid_argument(format!(
            "{name}: `{value}` is neither `auto` nor a code value ≥ 0 (0–255 for 8-bit input, \
             0–65535 for 16-bit, 0–1 for float)"
        ))),
    }
}

fn merge_command(a: &HdrMergeArgs) -> Result<()> {
    let exposures = match &a.exposures {
        Some(s) => Some(
            parse_exposures(s).map_err(|m| Error::invalid_argument(format!("--exposures: {m}")))?,
        ),
        None => None,
    };
    let response: ResponseMethod =
        a.response
            .parse()
            .map_err(|e: plsr_hdr::error::UnknownResponseMethod| {
                Error::invalid_argument(e.to_string())
            })?;
    if !(a.lambda.is_finite() && a.lambda >= 0.0) {
        return Err(Error::invalid_argument(
            "--lambda must be a finite number ≥ 0",
        ));
    }
    if a.samples == Some(0) {
        return Err(Error::invalid_argument("--samples must be at least 1"));
    }
    if let Some(c) = &a.response_curve {
        if a.curve
            .as_deref()
            .is_some_and(|out| plsr_base::atomic_write::same_file(c, out))
        {
            return Err(Error::invalid_argument(format!(
                "--curve {} names the --response-curve it reads",
                c.display()
            )));
        }
    }
    let options = MergeOptions {
        response,
        response_curve: a.response_curve.clone(),
        exposures,
        align: a.align,
        half: a.half,
        lambda: a.lambda,
        samples: a.samples,
        curve_csv: a.curve.clone(),
        threads: a.threads,
        compression: a.compression.clone(),
        calibration: calibration(a)?,
        black_level: level_option(&a.black_level, "--black-level")?,
        white_level: level_option(&a.white_level, "--white-level")?,
        crop: a.crop_to_common,
        deghost: a.deghost,
    };
    let bar = progress_bar(
        a.quiet,
        "{spinner} [{elapsed_precise}] {msg:>9} {wide_bar} {pos}/{len} (eta {eta})",
    );
    let phase = RefCell::new(String::new());
    let progress = |p: &str, done: u64, total: u64| {
        if *phase.borrow() != p {
            *phase.borrow_mut() = p.to_string();
            bar.set_message(p.to_string());
            bar.reset();
        }
        bar.set_length(total);
        bar.set_position(done);
    };
    // A folder's listing leaves out what this merge writes (an earlier
    // run's output and curve plot in the brackets' folder).
    let mut outputs = vec![a.output.clone()];
    if let Some(c) = &a.curve {
        outputs.extend([c.clone(), c.with_extension("png")]);
    }
    let images = bracket_files(&a.images, &outputs)?;
    let summary = merge(&images, &a.output, &options, &progress);
    bar.finish_and_clear();
    let s = summary?;
    for w in &s.warnings {
        eprintln!("plsr: warning: {w}");
    }
    let peak = plsr::memory::peak_bytes()
        .map(|b| format!("; peak memory {:.1} MiB", b as f64 / (1u64 << 20) as f64))
        .unwrap_or_default();
    let depth = match s.format {
        plsr_hdr::oiio::PixelType::U8 => "8-bit".to_string(),
        plsr_hdr::oiio::PixelType::U16 => format!("16-bit ({} significant)", s.bits),
        _ => "float".to_string(),
    };
    crate::note!(
        "merged {} brackets ({}×{}, {depth}, {}) in {:.2} s{peak} → {}",
        s.brackets.len(),
        s.width,
        s.height,
        s.curve.method,
        s.seconds,
        a.output.display()
    );
    if s.camera_raw {
        crate::note!(
            "  camera raw: merged as linear data (each file's black and white levels and as-shot \
             white balance, through LibRaw)"
        );
    }
    if s.saturated_values > 0 || s.dark_values > 0 {
        crate::note!(
            "  {} channel value(s) clipped in every bracket (took the shortest exposure's estimate), {} dark in every bracket (took the longest's)",
            s.saturated_values, s.dark_values
        );
    }
    if a.align {
        let shifts: Vec<String> = s
            .brackets
            .iter()
            .map(|b| format!("{},{}", b.shift.0, b.shift.1))
            .collect();
        crate::note!(
            "  alignment shifts (dx,dy, shortest exposure first): {}",
            shifts.join(" ")
        );
    }
    if let Some((reference, f)) = &s.deghost {
        crate::note!(
            "  deghosting: {:.1} % of the image left out some bracket that disagreed with the \
             best-exposed one, {}",
            100.0 * f,
            reference.display()
        );
    }
    if let Some([x0, y0, x1, y1]) = s.crop {
        crate::note!(
            "  cropped to {x0},{y0},{x1},{y1} (X0,Y0,X1,Y1 of the brackets' frame), the area every \
             bracket covers; --crop-to-common no keeps the whole frame"
        );
    }
    match &s.calibration {
        Some((scale, source)) => crate::note!(
            "  absolute radiance, W/(m²·sr): relative values × {scale:.6e} ({source})"
        ),
        None => crate::note!(
            "  relative radiance (calibrate with --exif-calibration, --grey-card or --known-luminance)"
        ),
    }
    if let Some(c) = &a.curve {
        crate::note!(
            "  response curve → {}, {}",
            c.display(),
            c.with_extension("png").display()
        );
    }
    Ok(())
}

/// The extensions of the images a folder given to `plsr hdr merge` is
/// searched for (camera raw formats besides).
const IMAGE_EXTENSIONS: [&str; 9] = [
    "jpg", "jpeg", "png", "tif", "tiff", "exr", "hdr", "pfm", "dng",
];

/// The bracket files: each path given, with a folder replaced by the
/// images in it (by extension, in name order; files of other kinds, the
/// merge's own `outputs`, and EXR, HDR and PFM files beside 8- or 16-bit
/// images are left out). A folder without images is an error naming it.
fn bracket_files(given: &[PathBuf], outputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
    let mut files = Vec::new();
    for path in given {
        if !path.is_dir() {
            files.push(path.clone());
            continue;
        }
        let entries = std::fs::read_dir(path).map_err(|e| Error::io(path.clone(), e))?;
        let mut images = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| Error::io(path.clone(), e))?;
            let file = entry.path();
            let ext = file
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .unwrap_or_default();
            let image =
                IMAGE_EXTENSIONS.contains(&ext.as_str()) || plsr_hdr::oiio::is_camera_raw(&file);
            let written_here = outputs
                .iter()
                .any(|o| plsr::atomic_write::same_file(&file, o));
            if file.is_file() && image && !written_here {
                images.push(file);
            }
        }
        if images.is_empty() {
            return Err(Error::input(
                path,
                "",
                format!(
                    "is a folder without images ({} or camera raw files)",
                    IMAGE_EXTENSIONS.join(", ")
                ),
            ));
        }
        images.sort();
        // High-dynamic-range files among low-dynamic-range brackets are a
        // reference or an earlier merge, not brackets: left out, saying so.
        let is_hdr = |f: &PathBuf| {
            f.extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .is_some_and(|e| ["exr", "hdr", "pfm"].contains(&e.as_str()))
        };
        let (hdr, ldr): (Vec<PathBuf>, Vec<PathBuf>) = images.into_iter().partition(is_hdr);
        if !hdr.is_empty() && !ldr.is_empty() {
            let names: Vec<String> = hdr.iter().map(|f| f.display().to_string()).collect();
            crate::note!(
                "note: left out {}: high-dynamic-range among {} low-dynamic-range brackets \
                 (name it to merge it)",
                names.join(", "),
                ldr.len()
            );
            files.extend(ldr);
        } else {
            files.extend(hdr);
            files.extend(ldr);
        }
    }
    Ok(files)
}
