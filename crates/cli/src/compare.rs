//! `plsr compare`: scores a test image against a reference (CW-SSIM,
//! LPIPS, SSIM, PSNR, RMSE, FLIP), over a crop and a mask.

use crate::error::{Error, Result};
use plsr::atomic_write::{check_extension, same_file, OutputSet};
use plsr_base::Vocabulary;
use plsr_metrics::{compare_files, CompareOptions, Crop, CropSpec, Metric};
use std::path::PathBuf;

/// Arguments of `plsr compare`.
#[derive(Debug, clap::Args)]
pub struct CompareArgs {
    /// The reference image (e.g. the photo with the real object).
    pub reference: PathBuf,
    /// The image to score (e.g. the composite with the virtual object).
    pub test: PathBuf,
    /// A mask image of the same size (pixels above 0.5 are in), with the
    /// channel to read after a colon: `--mask matte.png`, `--mask
    /// composite.exr:A` (a composite's matte). The pixel metrics average
    /// over it, and `--crop auto` crops to it.
    #[arg(long, value_name = "MASK[:CHANNEL]")]
    pub mask: Option<String>,
    /// `auto` (the mask's bounding box grown by 16 pixels, at least 64
    /// pixels a side) or the corners `X0,Y0,X1,Y1` in pixels (columns
    /// X0..X1, rows Y0..Y1, as `render --crop`); default: the whole image.
    #[arg(long, value_name = "auto|X0,Y0,X1,Y1")]
    pub crop: Option<String>,
    /// Comma-separated metrics: cwssim, lpips, ssim, psnr, rmse, flip
    /// (default: all).
    #[arg(long = "metric", value_name = "LIST", value_delimiter = ',')]
    pub metrics: Vec<String>,
    /// CW-SSIM: pyramid levels (the last level's bands are compared).
    #[arg(long, default_value_t = 4)]
    pub cwssim_level: u32,
    /// CW-SSIM: orientations.
    #[arg(long, default_value_t = 8)]
    pub cwssim_orientations: u32,
    /// CW-SSIM: the stabilising constant K (0: scale invariant).
    #[arg(long, default_value_t = 0.0)]
    pub cwssim_k: f64,
    /// CW-SSIM: border left out of the bands, in pixels of the image.
    #[arg(long, default_value_t = 0)]
    pub cwssim_guard: u32,
    /// FLIP: pixels per degree of visual angle (default: a 0.7 m wide
    /// 3840-pixel display seen from 0.7 m, 67.02).
    #[arg(long)]
    pub flip_ppd: Option<f64>,
    /// Print the scores as JSON.
    #[arg(long)]
    pub json: bool,
    /// Write FLIP's error map of the crop (PNG, magma colours: black for no
    /// visible difference, yellow-white for the largest).
    #[arg(long, value_name = "OUT.png")]
    pub map: Option<PathBuf>,
}

/// The crop of `--crop`.
fn parse_crop(text: Option<&str>) -> Result<CropSpec> {
    let Some(text) = text else {
        return Ok(CropSpec::Whole);
    };
    if text == "auto" {
        return Ok(CropSpec::Auto);
    }
    // The images' size is known only once they are read, which checks
    // the window against it.
    let [x0, y0, x1, y1] = crate::pixel_args::parse_rect("--crop", text, None)?.map(|v| v as usize);
    Ok(CropSpec::Window(Crop {
        x: x0,
        y: y0,
        w: x1 - x0,
        h: y1 - y0,
    }))
}

/// Runs `plsr compare`.
pub fn run(a: &CompareArgs) -> Result<()> {
    let crop = parse_crop(a.crop.as_deref())?;
    let metrics = if a.metrics.is_empty() {
        Metric::ALL.to_vec()
    } else {
        a.metrics
            .iter()
            .map(|m| {
                Metric::parse(m.trim()).ok_or_else(|| {
                    Error::invalid_argument(format!(
                        "--metric {m}: unknown metric (known: {})",
                        Metric::ALL.map(Metric::name).join(", ")
                    ))
                })
            })
            .collect::<Result<Vec<_>>>()?
    };
    if let Some(p) = &a.map {
        let output_error = |message: String| Error::output(p.clone(), message);
        check_extension(p, "png", "PNG").map_err(|m| output_error(format!("--map: {m}")))?;
        let mask_path = a
            .mask
            .as_deref()
            .map(|m| plsr_metrics::MaskSource::parse(m).path);
        let inputs = [Some(&a.reference), Some(&a.test), mask_path.as_ref()];
        let clash = inputs
            .into_iter()
            .flatten()
            .find(|i| same_file(p, i))
            .cloned();
        if let Some(input) = clash {
            return Err(output_error(format!(
                "--map names the input {}; it would be overwritten",
                input.display()
            )));
        }
    }
    let options = CompareOptions {
        metrics,
        cwssim: plsr_metrics::cwssim::CwSsimOptions {
            level: a.cwssim_level,
            orientations: a.cwssim_orientations,
            guard: a.cwssim_guard,
            k: a.cwssim_k,
        },
        flip: plsr_metrics::flip::FlipOptions {
            pixels_per_degree: a
                .flip_ppd
                .unwrap_or(plsr_metrics::flip::FlipOptions::default().pixels_per_degree),
            ..Default::default()
        },
    };
    let mask = a.mask.as_deref().map(plsr_metrics::MaskSource::parse);
    let report = compare_files(&a.reference, &a.test, mask.as_ref(), crop, &options)?;
    if let Some(p) = &a.map {
        let mut out = OutputSet::new();
        let map = plsr_metrics::flip_map(&report.reference, &report.test, &options.flip)?;
        out.stage_png(p, &map.magma())?;
        out.commit()?;
    }
    let c = report.crop;
    if a.json {
        let scores: serde_json::Map<String, serde_json::Value> = report
            .scores
            .iter()
            .map(|s| (s.metric.name().to_string(), json_number(s.value)))
            .collect();
        let doc = serde_json::json!({
            "reference": a.reference.display().to_string(),
            "test": a.test.display().to_string(),
            "crop": [c.x, c.y, c.x + c.w, c.y + c.h],
            "pixels": report.pixels,
            "scores": scores,
        });
        println!(
            "{}",
            serde_json::to_string_pretty(&doc).expect("plain JSON values")
        );
    } else {
        println!(
            "crop {},{},{},{} ({} pixels compared)",
            c.x,
            c.y,
            c.x + c.w,
            c.y + c.h,
            report.pixels
        );
        for s in &report.scores {
            println!("{:<8} {:.6}", s.metric.name(), s.value);
        }
    }
    Ok(())
}

/// A score as JSON (infinite PSNR as the string "inf").
fn json_number(v: f64) -> serde_json::Value {
    serde_json::Number::from_f64(v)
        .map(serde_json::Value::Number)
        .unwrap_or_else(|| serde_json::Value::String(format!("{v}")))
}
