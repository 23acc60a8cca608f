//! `plsr info`: what an OpenEXR file holds — its size, layers and
//! channels, compression, and header attributes (plsr's own: spp, film
//! settings, a part's scene hash and range, an HDR merge's exposure data).

use crate::error::{Error, Result};
use exr::meta::attribute::{AttributeValue, SampleType};
use plsr_base::Vocabulary;
use std::path::PathBuf;

/// Arguments of `plsr info`.
#[derive(Debug, clap::Args)]
pub struct InfoArgs {
    /// The OpenEXR file.
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

/// Runs `plsr info`.
pub fn run(a: &InfoArgs) -> Result<()> {
    plsr::input::check_input_file(&a.input)?;
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
        println!(
            "layer {i}{name}: {}×{} pixels{}, {:?} compression",
            h.layer_size.0,
            h.layer_size.1,
            if h.deep { ", deep" } else { "" },
            h.compression
        );
        let channels: Vec<String> = h
            .channels
            .list
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
                println!("    {k} = {v}");
            }
        }
    }
    Ok(())
}
