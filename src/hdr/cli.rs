//! `plsr hdr merge`.

use super::merge::{merge, parse_exposures, MergeOptions};
use super::response::ResponseMethod;
use crate::cli::{HdrCaptureArgs, HdrCommand, HdrMergeArgs};
use crate::error::{Error, Result};
use std::cell::RefCell;

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
        .map_err(|_| Error::InvalidArgument(format!("{flag}: expected X,Y,Z, got `{s}`")))?;
    match v[..] {
        [x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => {
            Ok(glam::Vec3::new(x, y, z))
        }
        _ => Err(Error::InvalidArgument(format!(
            "{flag}: expected three finite numbers X,Y,Z, got `{s}`"
        ))),
    }
}

fn capture_command(a: &HdrCaptureArgs) -> Result<()> {
    use super::capture::{capture, CaptureOptions, PAPER_EXPOSURES};
    use super::synth::CameraModel;
    let size = a
        .size
        .split_once(['x', 'X'])
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .filter(|&(w, h)| w > 0 && h > 0 && w <= 1 << 15 && h <= 1 << 15)
        .ok_or_else(|| Error::InvalidArgument(format!("--size: expected WxH, got `{}`", a.size)))?;
    let exposures = match &a.exposures {
        Some(s) => {
            parse_exposures(s).map_err(|m| Error::InvalidArgument(format!("--exposures: {m}")))?
        }
        None => PAPER_EXPOSURES.to_vec(),
    };
    let mut camera = match a.response.as_str() {
        "filmic" => CameraModel::default(),
        "linear" => CameraModel::linear(),
        other => {
            return Err(Error::InvalidArgument(format!(
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
    let bar = crate::cli::progress_bar(
        false,
        "{spinner} [{elapsed_precise}] rendering {wide_bar} {pos}/{len} tiles (eta {eta})",
    );
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
        true
    };
    let paths = capture(&a.scene, &a.output, &options, &progress)?;
    bar.finish_and_clear();
    println!(
        "plsr hdr capture: {} brackets of a {}×{} panorama at {} in {} (truth.exr beside them)",
        paths.len(),
        size.0,
        size.1,
        a.at,
        a.output.display()
    );
    Ok(())
}

fn merge_command(a: &HdrMergeArgs) -> Result<()> {
    let exposures = match &a.exposures {
        Some(s) => Some(
            parse_exposures(s).map_err(|m| Error::InvalidArgument(format!("--exposures: {m}")))?,
        ),
        None => None,
    };
    let response: ResponseMethod = a.response.parse().map_err(Error::InvalidArgument)?;
    if !(a.lambda.is_finite() && a.lambda >= 0.0) {
        return Err(Error::InvalidArgument(
            "--lambda must be a finite number ≥ 0".into(),
        ));
    }
    if a.samples == Some(0) {
        return Err(Error::InvalidArgument(
            "--samples must be at least 1".into(),
        ));
    }
    let options = MergeOptions {
        response,
        exposures,
        align: a.align,
        half: a.half,
        lambda: a.lambda,
        samples: a.samples,
        curve_csv: a.curve.clone(),
        threads: a.threads,
        compression: a.compression.clone(),
    };
    let bar = crate::cli::progress_bar(
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
    let summary = merge(&a.images, &a.output, &options, &progress);
    bar.finish_and_clear();
    let s = summary?;
    let peak = super::peak_memory_bytes()
        .map(|b| format!("; peak memory {:.1} MiB", b as f64 / (1u64 << 20) as f64))
        .unwrap_or_default();
    let depth = match s.format {
        super::oiio::PixelType::U8 => "8-bit".to_string(),
        super::oiio::PixelType::U16 => format!("16-bit ({} significant)", s.bits),
        _ => "float".to_string(),
    };
    eprintln!(
        "merged {} brackets ({}×{}, {depth}, {}) in {:.2} s{peak} → {}",
        s.brackets.len(),
        s.width,
        s.height,
        s.curve.method,
        s.seconds,
        a.output.display()
    );
    if s.saturated_values > 0 || s.dark_values > 0 {
        eprintln!(
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
        eprintln!(
            "  alignment shifts (dx,dy, shortest exposure first): {}",
            shifts.join(" ")
        );
    }
    if let Some(c) = &a.curve {
        eprintln!(
            "  response curve → {}, {}",
            c.display(),
            c.with_extension("png").display()
        );
    }
    Ok(())
}
