//! `plsr info`: what an OpenEXR file holds — its size, layers and
//! channels, compression, and header attributes (plsr's own: spp, film
//! settings, a part's scene hash and range, an HDR merge's exposure data);
//! for a Radiance HDR, TIFF, PNG or JPEG file its size, channels, pixel type
//! and EXIF exposure.

use crate::error::{Error, Result};
use exr::meta::attribute::{AttributeValue, SampleType};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The image: OpenEXR, Radiance HDR (.hdr), TIFF, PNG or JPEG.
    #[arg(value_name = "IN.exr")]
    pub input: PathBuf,
}

/// One attribute's value as text.
fn value(v: &AttributeValue) -> String {
    match v {
        AttributeValue::Text(t) => format!("{:?}", t.to_string()),
        AttributeValue::F32(x) => format!("{x}"),
        AttributeValue::F64(x) => format!("{x}"),
        AttributeValue::I32(x) => format!("{x}"),
        other => format!("{other:?}"),
    }
}

/// The longest attribute value printed whole (characters).
const LONGEST_VALUE: usize = 160;

/// An attribute's value as `plsr info` prints it: a response curve
/// (`plsr:response_curve`, one line of numbers per channel) summarised by
/// its size and range, any other value longer than [`LONGEST_VALUE`] cut
/// with its length said.
fn shown(key: &str, value: &str) -> String {
    if key == "plsr:response_curve" {
        let text = value.trim_matches('"');
        let rows: Vec<Vec<f64>> = text
            .split("\\n")
            .flat_map(|r| r.split('\n'))
            .map(|r| {
                r.split_whitespace()
                    .filter_map(|x| x.parse().ok())
                    .collect()
            })
            .filter(|r: &Vec<f64>| !r.is_empty())
            .collect();
        if let Some(first) = rows.first() {
            let all = rows.iter().flatten();
            let (lo, hi) = all.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &x| {
                (lo.min(x), hi.max(x))
            });
            return format!(
                "{} channel{} × {} levels, values {lo:.4} to {hi:.4} (`plsr hdr merge --curve` \
                 writes the whole curve as CSV)",
                rows.len(),
                if rows.len() == 1 { "" } else { "s" },
                first.len()
            );
        }
    }
    let chars = value.chars().count();
    if chars <= LONGEST_VALUE {
        return value.to_string();
    }
    let head: String = value.chars().take(LONGEST_VALUE - 40).collect();
    format!("{head}… ({chars} characters in all)")
}

/// What `plsr info` says of a Radiance HDR or TIFF file: its size,
/// channels and pixel type, and the exposure its metadata states.
fn run_other(path: &std::path::Path) -> Result<()> {
    let reader = plsr_hdr::oiio::ImageReader::open(path)?;
    let info = reader.info();
    println!("{}", path.display());
    println!(
        "{}×{} pixels, {} channel(s), {:?} ({} significant bits)",
        info.width, info.height, info.channels, info.format, info.bits
    );
    let exif = reader.exif();
    for (k, v) in [
        ("ExposureTime", exif.exposure_time),
        ("FNumber", exif.f_number),
        ("ISO", exif.iso),
    ] {
        if let Some(v) = v {
            println!("  {k} = {v}");
        }
    }
    Ok(())
}

/// Runs `plsr info`.
pub fn run(a: &InfoArgs) -> Result<()> {
    plsr::input::check_input_file(&a.input)?;
    let ext = a
        .input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    if ext == "hdr" {
        // Read by plsr's own decoder (which takes Radiance headers that
        // OpenImageIO refuses); Radiance files carry no attributes.
        let (w, h, _) = plsr::film::radiance::read_radiance_hdr(&a.input)?;
        println!("{}", a.input.display());
        println!("{w}×{h} pixels, 3 channels, Radiance RGBE (8-bit mantissas, shared exponent)");
        return Ok(());
    }
    if matches!(ext.as_str(), "tif" | "tiff" | "png" | "jpg" | "jpeg") {
        return run_other(&a.input);
    }
    plsr::film::check_exr_header(&a.input)?;
    let meta = exr::meta::MetaData::read_from_file(&a.input, false)
        .map_err(|e| Error::input(&a.input, "", format!("cannot read as OpenEXR: {e}")))?;
    println!("{}", a.input.display());
    for (i, h) in meta.headers.iter().enumerate() {
        let name = h
            .own_attributes
            .layer_name
            .as_ref()
            .map(|n| format!(" `{n}`"))
            .unwrap_or_default();
        let compression = match h.compression {
            exr::prelude::Compression::Uncompressed => "uncompressed".to_string(),
            other => format!("{other:?} compression"),
        };
        println!(
            "layer {i}{name}: {}×{} pixels{}, {compression}",
            h.layer_size.0,
            h.layer_size.1,
            if h.deep { ", deep" } else { "" },
        );
        // The exact sums of a part or a resumable render (`part.*`) are
        // counted, not listed: they are not for looking at.
        let (sums, image): (Vec<_>, Vec<_>) = h
            .channels
            .list
            .iter()
            .partition(|c| c.name.to_string().starts_with("part."));
        let channels: Vec<String> = image
            .iter()
            .map(|c| {
                let t = match c.sample_type {
                    SampleType::F16 => "half",
                    SampleType::F32 => "float",
                    SampleType::U32 => "uint",
                };
                format!("{} ({t})", c.name)
            })
            .collect();
        println!("  {} channels: {}", channels.len(), channels.join(", "));
        if !sums.is_empty() {
            println!(
                "  and {} channels part.* of the render's exact sums, for `plsr merge` and `--resume`",
                sums.len()
            );
            // What the sums are of, from the part's header.
            let attr = |key: &str| {
                h.own_attributes
                    .other
                    .get(&exr::prelude::Text::from(key))
                    .map(value)
                    .map(|v| v.trim_matches('"').to_string())
            };
            if let (Some(samples), Some(window), Some(image)) = (
                attr("plsrPartSamples"),
                attr("plsrPartWindow"),
                attr("plsrPartImage"),
            ) {
                let n =
                    |s: &str| -> Vec<String> { s.split_whitespace().map(String::from).collect() };
                let (samples, window, image) = (n(&samples), n(&window), n(&image));
                if let ([s0, s1], [x0, y0, x1, y1], [w, hh]) =
                    (&samples[..], &window[..], &image[..])
                {
                    let whole = x0 == "0" && y0 == "0" && x1 == w && y1 == hh;
                    println!(
                        "  {}: samples {s0}..{s1} of {}",
                        if s0 == "0" {
                            "resumable (plsr render --resume)"
                        } else {
                            "a part"
                        },
                        if whole {
                            format!("the whole {w}×{hh} image")
                        } else {
                            format!("the window {x0},{y0},{x1},{y1} of a {w}×{hh} image")
                        }
                    );
                }
            }
        }
        let mut attributes: Vec<(String, String)> = h
            .shared_attributes
            .other
            .iter()
            .chain(&h.own_attributes.other)
            .map(|(k, v)| (k.to_string(), value(v)))
            .collect();
        let own = &h.own_attributes;
        for (k, v) in [
            ("exposure", own.exposure),
            ("aperture", own.aperture),
            ("isoSpeed", own.iso_speed),
            ("whiteLuminance", own.white_luminance),
        ] {
            if let Some(v) = v {
                attributes.push((k.into(), format!("{v}")));
            }
        }
        for (k, v) in [
            ("owner", &own.owner),
            ("comments", &own.comments),
            ("capDate", &own.capture_date),
        ] {
            if let Some(v) = v {
                attributes.push((k.into(), format!("{:?}", v.to_string())));
            }
        }
        attributes.sort();
        if !attributes.is_empty() {
            println!("  attributes:");
            for (k, v) in attributes {
                println!("    {k} = {}", shown(&k, &v));
            }
        }
    }
    Ok(())
}
