//! `plsr pls check | mesh | transform`.

use crate::error::{Error, Result};
use clap::Subcommand;
use glam::{Mat4, Quat, Vec3};
use plsr::color::luminance;
use plsr::light::pls::{file, BrightnessMode};
use plsr_base::Vocabulary;
use std::path::Path;
use std::path::PathBuf;

/// `plsr pls …` subcommands.
#[derive(Debug, Subcommand)]
pub enum PlsCommand {
    /// Validate a PLS file and print a table of its lights: area, centre,
    /// normal, cone angle and total emitted power.
    Check {
        /// The PLS file (TOML or JSON).
        file: PathBuf,
        /// Quads along each light's axis for the tessellated area.
        #[arg(long, default_value_t = plsr::light::pls::DEFAULT_NF as u64)]
        nf: u64,
    },
    /// Export the tessellated emitters as a Wavefront OBJ (one object per light).
    Mesh {
        /// The PLS file.
        file: PathBuf,
        /// Output OBJ file.
        #[arg(short, long)]
        output: PathBuf,
        /// Quads along each light's axis.
        #[arg(long, default_value_t = plsr::light::pls::DEFAULT_NF as u64)]
        nf: u64,
    },
    /// Transform every light through its parameters (paper eq. 15–21) and
    /// write a new PLS file. Give a matrix, or any of translate/rotate/scale
    /// (applied scale, then rotate, then translate).
    Transform {
        /// The PLS file.
        file: PathBuf,
        /// Output PLS file (TOML, or JSON by extension).
        #[arg(short, long)]
        output: PathBuf,
        /// A 4×4 affine matrix, 16 numbers row by row ("m00 m01 … m33").
        #[arg(long, allow_hyphen_values = true)]
        matrix: Option<String>,
        /// Translation "x,y,z" (metres).
        #[arg(long, allow_hyphen_values = true)]
        translate: Option<String>,
        /// Rotation axis "x,y,z" (with --rotate-deg).
        #[arg(long, allow_hyphen_values = true)]
        rotate_axis: Option<String>,
        /// Rotation angle in degrees (with --rotate-axis).
        #[arg(long, allow_hyphen_values = true)]
        rotate_deg: Option<f32>,
        /// Uniform scale factor.
        #[arg(long)]
        scale: Option<f32>,
    },
}

/// Runs one `plsr pls` subcommand.
pub fn run(command: PlsCommand) -> Result<()> {
    match command {
        PlsCommand::Check { file, nf } => check(&file, nf_arg(nf)?),
        PlsCommand::Mesh { file, output, nf } => mesh(&file, &output, nf_arg(nf)?),
        PlsCommand::Transform {
            file,
            output,
            matrix,
            translate,
            rotate_axis,
            rotate_deg,
            scale,
        } => {
            let m = transform_matrix(
                matrix.as_deref(),
                translate.as_deref(),
                rotate_axis.as_deref(),
                rotate_deg,
                scale,
            )?;
            let lighting = file::load(&file)?;
            file::save(&lighting.transform(&m), &output)?;
            crate::note!(
                "transformed {} light(s) from {} → {}",
                lighting.lights.len(),
                file.display(),
                output.display()
            );
            Ok(())
        }
    }
}

/// `--nf`, checked as scene files check `nf`.
fn nf_arg(nf: u64) -> Result<u32> {
    plsr::light::pls::check_nf(nf).map_err(|m| Error::invalid_argument(format!("--nf: {m}")))
}

fn check(path: &Path, nf: u32) -> Result<()> {
    let lighting = file::load(path)?;
    let mode = match lighting.mode {
        BrightnessMode::Intensity => "intensity (b in W/sr along n)",
        BrightnessMode::Radiance => "radiance (b in W/(m²·sr))",
    };
    println!(
        "{}: {} light(s), brightness mode {mode}",
        path.display(),
        lighting.lights.len()
    );
    println!();
    println!(
        "| # | name | area (m², Nf={nf}) | outline area (m²) | centre (m) | n | a (°) | radiance (RGB) | power (W, luminance) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    for (i, l) in lighting.lights.iter().enumerate() {
        let area = l.tessellate(nf).area();
        let c = l.centre();
        let n = l.normal();
        let r = l.radiance(lighting.mode, area);
        let p = luminance(l.power(lighting.mode, area));
        println!(
            "| {i} | {} | {area:.6} | {:.6} | ({:.3}, {:.3}, {:.3}) | ({:.3}, {:.3}, {:.3}) | {:.3} | ({:.3}, {:.3}, {:.3}) | {p:.4} |",
            l.name.as_deref().unwrap_or("-"),
            l.outline_area(),
            c.x,
            c.y,
            c.z,
            n.x,
            n.y,
            n.z,
            l.a_deg,
            r.x,
            r.y,
            r.z,
        );
    }
    Ok(())
}

fn mesh(path: &Path, output: &Path, nf: u32) -> Result<()> {
    let lighting = file::load(path)?;
    file::save_obj(&lighting, nf, output)?;
    crate::note!(
        "wrote {} light(s) at Nf = {nf} → {}",
        lighting.lights.len(),
        output.display()
    );
    Ok(())
}

fn numbers(what: &str, text: &str, count: usize) -> Result<Vec<f32>> {
    let v: Vec<f32> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|s| !s.is_empty())
        .map(|s| s.parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|e| Error::invalid_argument(format!("--{what}: {e} in {text:?}")))?;
    if v.len() != count || v.iter().any(|x| !x.is_finite()) {
        return Err(Error::invalid_argument(format!(
            "--{what}: expected {count} finite numbers, got {text:?}"
        )));
    }
    Ok(v)
}

/// Builds the transform of `plsr pls transform` from its flags.
pub fn transform_matrix(
    matrix: Option<&str>,
    translate: Option<&str>,
    rotate_axis: Option<&str>,
    rotate_deg: Option<f32>,
    scale: Option<f32>,
) -> Result<Mat4> {
    if let Some(m) = matrix {
        if translate.is_some() || rotate_axis.is_some() || rotate_deg.is_some() || scale.is_some() {
            return Err(Error::invalid_argument(
                "--matrix cannot be combined with --translate/--rotate-*/--scale",
            ));
        }
        let v = numbers("matrix", m, 16)?;
        if v[12..16] != [0.0, 0.0, 0.0, 1.0] {
            return Err(Error::invalid_argument(format!(
                "--matrix: the last row must be 0 0 0 1 for an affine transform, got {:?}",
                &v[12..16]
            )));
        }
        let mat = Mat4::from_cols_slice(&v).transpose();
        if mat.determinant() == 0.0 {
            return Err(Error::invalid_argument("--matrix is singular"));
        }
        return Ok(mat);
    }
    let t = match translate {
        Some(t) => Vec3::from_slice(&numbers("translate", t, 3)?),
        None => Vec3::ZERO,
    };
    let r = match (rotate_axis, rotate_deg) {
        (Some(a), Some(deg)) if deg.is_finite() => {
            let axis = Vec3::from_slice(&numbers("rotate-axis", a, 3)?)
                .try_normalize()
                .ok_or_else(|| Error::invalid_argument("--rotate-axis must not be zero"))?;
            Quat::from_axis_angle(axis, deg.to_radians())
        }
        (None, None) => Quat::IDENTITY,
        _ => {
            return Err(Error::invalid_argument(
                "--rotate-axis and --rotate-deg (finite) go together",
            ))
        }
    };
    let s = match scale {
        Some(s) if s.is_finite() && s > 0.0 => s,
        Some(s) => {
            return Err(Error::invalid_argument(format!(
                "--scale must be positive, got {s}"
            )))
        }
        None => 1.0,
    };
    Ok(Mat4::from_scale_rotation_translation(Vec3::splat(s), r, t))
}
