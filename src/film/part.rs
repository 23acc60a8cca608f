//! A piece of a render on disk (a *part*): the samples `[start, end)` of
//! every pixel of a window of the image, written as an OpenEXR file that
//! holds, beside the usual layers of the piece (for looking at it), every
//! pixel's exact sums and counts and, in its header, what merging needs:
//! the scene's hash, the image size, the window and the sample range.
//! [`merge_parts`] combines parts into the image one render of their union
//! gives: sample ranges of the same window add sum by sum
//! ([`FilmSums::merge`]), windows are stitched.
//!
//! Exact sums: the path tracer accumulates in `f64`, which EXR cannot
//! store. Each `f64` sum is written as its difference from a prediction
//! made from the image layers in the same file, cut into four 16-bit words
//! (see [`super::exact_sums`]: exact by construction, and compact once
//! compressed); parts of older versions, with each sum's bits in two
//! 32-bit channels (`part.sum.R.hi`, `part.sum.R.lo`), are still read.
//! Counts are 32-bit unsigned channels and the `f32` sums (normals,
//! albedos) float channels, so a part read back holds exactly what was
//! rendered.
//!
//! A plain `plsr render` writes the same sums beside its image (a part of
//! the whole image holding samples `0..N`, ZIP-compressed), so that
//! `--resume` can add samples to any render ([`Part::stage_exr_beside`]).
//!
//! Header attributes (text): `plsrPartScene` (the scene's hash, 16 hex
//! digits), `plsrPartImage` (`W H`), `plsrPartWindow` (`x0 y0 x1 y1`, the
//! window's columns `[x0, x1)` and rows `[y0, y1)`), `plsrPartSamples`
//! (`start end`).

use super::{exact_sums, FilmSums, PixelSums, Tile};
use crate::atomic_write::OutputSet;
use crate::error::{Error, Result};
use exr::prelude::{self as exrp, AnyChannel, FlatSamples};
use plsr_base::Vocabulary;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Header attribute: the scene's hash.
const SCENE: &str = "plsrPartScene";
/// Header attribute: the full image's size.
const IMAGE: &str = "plsrPartImage";
/// Header attribute: the window.
const WINDOW: &str = "plsrPartWindow";
/// Header attribute: the sample range.
const SAMPLES: &str = "plsrPartSamples";

/// What a part is a piece of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PartInfo {
    /// Hash of everything the image depends on but the sample range and
    /// the window (see [`scene_hash`]).
    pub scene_hash: u64,
    /// Width and height of the full image, pixels.
    pub image: (u32, u32),
    /// The window of the image the part covers.
    pub window: Tile,
    /// Start of the part's sample indices.
    pub sample_start: u32,
    /// End (exclusive) of its sample indices.
    pub sample_end: u32,
}

impl PartInfo {
    /// The part's sample indices.
    pub fn samples(&self) -> Range<u32> {
        self.sample_start..self.sample_end
    }
}

/// A part in memory: what it is a piece of, and its sums (window-sized).
#[derive(Debug, Clone)]
pub struct Part {
    /// What it is a piece of.
    pub info: PartInfo,
    /// The window's per-pixel sums and counts.
    pub sums: FilmSums,
    /// What its scene hash was made of, where the writer said (for
    /// messages that name what differs).
    pub provenance: Option<Provenance>,
}

/// What a part's scene hash is made of, kept in its header (`plsrPartFiles`,
/// `plsrPartSettings`) so that a refusal can say what differs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Provenance {
    /// The hash of the scene's files (and of the command line's scene
    /// options: `-D`, `--anim-time`, `--light-picking`).
    pub files_hash: u64,
    /// The render settings in the hash, as `key value` pairs separated by
    /// spaces (`seed 0 max_depth 8 rr_depth 4 hide_virtual false`).
    pub settings: String,
}

impl Provenance {
    /// What differs between `self` (a file's) and `now` (this run's), in
    /// words, or `None` if nothing does.
    pub fn differences(&self, now: &Provenance) -> Option<String> {
        let pairs = |s: &str| -> Vec<(String, String)> {
            let words: Vec<&str> = s.split_whitespace().collect();
            words
                .chunks(2)
                .map(|c| (c[0].to_string(), c.get(1).unwrap_or(&"").to_string()))
                .collect()
        };
        let (then, here) = (pairs(&self.settings), pairs(&now.settings));
        let mut said: Vec<String> = Vec::new();
        for (key, value) in &here {
            match then.iter().find(|(k, _)| k == key) {
                Some((_, old)) if old != value => {
                    said.push(format!("{key} {old} in the file, {value} now"))
                }
                None => said.push(format!("{key} {value} now, none in the file")),
                _ => {}
            }
        }
        for (key, old) in &then {
            if !here.iter().any(|(k, _)| k == key) {
                said.push(format!("{key} {old} in the file, none now"));
            }
        }
        if self.files_hash != now.files_hash {
            said.push(
                "the scene file or a file it reads has changed since (or -D, --anim-time or \
                 --light-picking differ)"
                    .to_string(),
            );
        }
        (!said.is_empty()).then(|| said.join("; "))
    }
}

/// Header attribute: [`Provenance::files_hash`].
const FILES: &str = "plsrPartFiles";
/// Header attribute: [`Provenance::settings`].
const SETTINGS: &str = "plsrPartSettings";

/// FNV-1a, 64 bits: a hash that is the same on every machine and in every
/// build (unlike `std`'s), for [`scene_hash`].
#[derive(Debug, Clone, Copy)]
pub struct StableHasher(u64);

impl Default for StableHasher {
    fn default() -> Self {
        StableHasher(0xcbf2_9ce4_8422_2325)
    }
}

impl StableHasher {
    /// Adds bytes.
    pub fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0100_0000_01b3);
        }
    }

    /// Adds a length-prefixed field, so that fields cannot run into each other.
    pub fn field(&mut self, bytes: &[u8]) {
        self.write(&(bytes.len() as u64).to_le_bytes());
        self.write(bytes);
    }

    /// The hash.
    pub fn finish(&self) -> u64 {
        self.0
    }
}

/// The hash that says two parts are pieces of the same image: of the scene
/// file and every file it reads (`files`, their contents), and of `extra`
/// (the render settings that change the image: seed, depths, and what else
/// the caller overrides), but not of the sample range or the window.
pub fn scene_hash(files: &[PathBuf], extra: &str) -> Result<u64> {
    let mut h = scene_files_hasher(files)?;
    h.field(extra.as_bytes());
    Ok(h.finish())
}

/// [`scene_hash`] before its `extra` is added: the files are read once and
/// the hasher copied for each frame of an animation.
pub fn scene_files_hasher(files: &[PathBuf]) -> Result<StableHasher> {
    let mut h = StableHasher::default();
    for file in files {
        let bytes = std::fs::read(file).map_err(|source| Error::io(file.clone(), source))?;
        h.field(&bytes);
    }
    Ok(h)
}

impl Part {
    /// The part of `sums` (a full-image render of `info.samples()`) that
    /// lies in `info.window`.
    pub fn from_render(info: PartInfo, full: &FilmSums) -> Part {
        let w = info.window;
        let mut pixels = Vec::with_capacity(w.width as usize * w.height as usize);
        for y in w.y0..w.y0 + w.height {
            for x in w.x0..w.x0 + w.width {
                pixels.push(*full.pixel(x, y));
            }
        }
        Part {
            info,
            sums: FilmSums::from_pixels(
                w.width,
                w.height,
                info.sample_start,
                pixels,
                full.settings(),
            ),
            provenance: None,
        }
    }

    /// Writes the part into `outputs` as `path` (an OpenEXR file: the
    /// piece's developed layers, its exact sums and the header),
    /// uncompressed: parts are written and read once, on the way to the
    /// merge, and compression would cost more than the disk.
    pub fn stage_exr(&self, outputs: &mut OutputSet, path: &Path) -> Result<()> {
        let spp = self.info.sample_end - self.info.sample_start;
        let film = self.sums.develop_all(spp);
        self.stage_exr_beside(&film, outputs, path, false)
    }

    /// Writes `film`'s layers (the image a plain render shows, denoised or
    /// not) with the part's exact sums and header into `outputs` as
    /// `path`; `compressed`: losslessly (ZIP), for a file that is kept.
    pub fn stage_exr_beside(
        &self,
        film: &super::Film,
        outputs: &mut OutputSet,
        path: &Path,
        compressed: bool,
    ) -> Result<()> {
        let pixels = self.sums.pixels();
        if (film.width, film.height) != (self.sums.width(), self.sums.height()) {
            return Err(Error::output(
                path,
                format!(
                    "the image is {}×{} pixels but the sums beside it {}×{}",
                    film.width,
                    film.height,
                    self.sums.width(),
                    self.sums.height()
                ),
            ));
        }
        let mut channels = exact_sums::encode(pixels, &exact_sums::Guide::of_film(film));
        let mut u32_channel = |name: &str, get: &dyn Fn(&PixelSums) -> u32| {
            channels.push(AnyChannel::new(
                format!("part.{name}").as_str(),
                FlatSamples::U32(pixels.iter().map(get).collect()),
            ));
        };
        u32_channel("samples", &|p| p.samples);
        u32_channel("hits", &|p| p.hits);
        u32_channel("virtual_hits", &|p| p.virtual_hits);
        let mut f32_channel = |name: &str, get: &dyn Fn(&PixelSums) -> f32| {
            channels.push(AnyChannel::new(
                format!("part.{name}").as_str(),
                FlatSamples::F32(pixels.iter().map(get).collect()),
            ));
        };
        for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
            f32_channel(&format!("normal.{n}"), &|p| p.normal[c]);
        }
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            f32_channel(&format!("albedo.{n}"), &|p| p.albedo[c]);
        }
        f32_channel("object_id", &|p| p.object_id);
        let i = &self.info;
        let w = i.window;
        let text = |k: &str, v: String| {
            (
                exrp::Text::from(k),
                exrp::AttributeValue::Text(exrp::Text::from(v.as_str())),
            )
        };
        let attributes = vec![
            text(SCENE, format!("{:016x}", i.scene_hash)),
            text(IMAGE, format!("{} {}", i.image.0, i.image.1)),
            text(
                WINDOW,
                format!("{} {} {} {}", w.x0, w.y0, w.x0 + w.width, w.y0 + w.height),
            ),
            text(SAMPLES, format!("{} {}", i.sample_start, i.sample_end)),
        ];
        let mut attributes = attributes;
        if let Some(p) = &self.provenance {
            attributes.push(text(FILES, format!("{:016x}", p.files_hash)));
            attributes.push(text(SETTINGS, p.settings.clone()));
        }
        let encoding = if compressed {
            exrp::Encoding::SMALL_LOSSLESS
        } else {
            exrp::Encoding::UNCOMPRESSED
        };
        film.stage_exr_with(outputs, path, channels, attributes, encoding)
    }

    /// Reads a part written by [`Part::stage_exr`]; a file that is not one
    /// (a plain render, a truncated file) is an error naming it.
    pub fn read_exr(path: &Path) -> Result<Part> {
        let layer = super::read_flat_layer(path)?;
        let (width, height) = (layer.size.0 as u32, layer.size.1 as u32);
        let attrs = &layer.attributes.other;
        let header = |key: &str| -> Result<Vec<u64>> {
            let Some(exrp::AttributeValue::Text(t)) = attrs.get(&exrp::Text::from(key)) else {
                return Err(Error::input(
                    path,
                    key,
                    "missing from the header: the file holds no render sums (a part of \
                     `plsr render --samples START..END` or `--crop X0,Y0,X1,Y1` has them, and \
                     so does a plain render unless written with --no-resume-data)",
                ));
            };
            let text = t.to_string();
            let radix = if key == SCENE { 16 } else { 10 };
            text.split_whitespace()
                .map(|s| u64::from_str_radix(s, radix))
                .collect::<std::result::Result<Vec<u64>, _>>()
                .map_err(|_| Error::input(path, key, format!("cannot read {text:?}")))
        };
        let bad = |key: &str, message: String| Error::input(path, key, message);
        let scene_hash = match header(SCENE)?.as_slice() {
            [h] => *h,
            _ => return Err(bad(SCENE, "expected one hash".into())),
        };
        let image = match header(IMAGE)?.as_slice() {
            &[w, h] if w > 0 && h > 0 && w <= u32::MAX as u64 && h <= u32::MAX as u64 => {
                (w as u32, h as u32)
            }
            _ => return Err(bad(IMAGE, "expected the width and height".into())),
        };
        let window = match header(WINDOW)?.as_slice() {
            &[x0, y0, x1, y1]
                if x0 < x1
                    && y0 < y1
                    && x1 <= image.0 as u64
                    && y1 <= image.1 as u64
                    && (x1 - x0, y1 - y0) == (width as u64, height as u64) =>
            {
                Tile {
                    x0: x0 as u32,
                    y0: y0 as u32,
                    width,
                    height,
                }
            }
            _ => {
                return Err(bad(
                    WINDOW,
                    format!(
                        "expected x0 y0 x1 y1 inside the {}×{} image, of the file's {width}×{height} pixels",
                        image.0, image.1
                    ),
                ))
            }
        };
        let (sample_start, sample_end) = match header(SAMPLES)?.as_slice() {
            &[s, e] if s < e && e <= u32::MAX as u64 => (s as u32, e as u32),
            _ => return Err(bad(SAMPLES, "expected start < end".into())),
        };
        let channel = |name: &str| -> Result<&FlatSamples> {
            layer
                .channel_data
                .list
                .iter()
                .find(|c| c.name.to_string() == name)
                .map(|c| &c.sample_data)
                .ok_or_else(|| Error::input(path, name, "channel missing from the part"))
        };
        let u32s = |name: &str| -> Result<&Vec<u32>> {
            match channel(name)? {
                FlatSamples::U32(v) => Ok(v),
                _ => Err(Error::input(path, name, "expected 32-bit unsigned samples")),
            }
        };
        let f32s = |name: &str| -> Result<&Vec<f32>> {
            match channel(name)? {
                FlatSamples::F32(v) => Ok(v),
                _ => Err(Error::input(path, name, "expected 32-bit float samples")),
            }
        };
        let words = |name: &str| -> Result<&Vec<exrp::f16>> {
            match channel(name)? {
                FlatSamples::F16(v) => Ok(v),
                _ => Err(Error::input(path, name, "expected 16-bit samples")),
            }
        };
        let n = width as usize * height as usize;
        let mut pixels = vec![PixelSums::default(); n];
        // The counts and the f32 sums first: the f64 sums' predictions
        // need the counts.
        let (samples, hits, virtual_hits) = (
            u32s("part.samples")?,
            u32s("part.hits")?,
            u32s("part.virtual_hits")?,
        );
        let object_id = f32s("part.object_id")?;
        // Counts beyond the part's sample range (a damaged or forged file)
        // would overflow when added to.
        let range = sample_end - sample_start;
        if let Some(i) = (0..n)
            .find(|&i| samples[i] > range || hits[i] > samples[i] || virtual_hits[i] > samples[i])
        {
            return Err(Error::input(
                path,
                "part.samples",
                format!(
                    "pixel ({}, {}) counts {} samples, {} hits and {} virtual hits: more than \
                     the part's {range} samples, or more hits than samples",
                    i as u32 % width,
                    i as u32 / width,
                    samples[i],
                    hits[i],
                    virtual_hits[i]
                ),
            ));
        }
        for i in 0..n {
            let p = &mut pixels[i];
            p.samples = samples[i];
            p.hits = hits[i];
            p.virtual_hits = virtual_hits[i];
            p.object_id = object_id[i];
        }
        for (c, name) in ["R", "G", "B"].iter().enumerate() {
            let albedo = f32s(&format!("part.albedo.{name}"))?;
            for i in 0..n {
                pixels[i].albedo[c] = albedo[i];
            }
        }
        for (c, name) in ["X", "Y", "Z"].iter().enumerate() {
            let normal = f32s(&format!("part.normal.{name}"))?;
            for i in 0..n {
                pixels[i].normal[c] = normal[i];
            }
        }
        if channel("part.sum.R.hi").is_ok() {
            // The layout of older parts: each f64 as two 32-bit halves.
            for (k, name) in exact_sums::NAMES.iter().enumerate() {
                let (hi, lo) = (
                    u32s(&format!("part.{name}.hi"))?,
                    u32s(&format!("part.{name}.lo"))?,
                );
                for (i, p) in pixels.iter_mut().enumerate() {
                    let x = f64::from_bits((hi[i] as u64) << 32 | lo[i] as u64);
                    match k {
                        0..=2 => p.sum[k] = x,
                        3..=5 => p.sum_sq[k - 3] = x,
                        _ => p.depth = x,
                    }
                }
            }
        } else {
            // Differences from predictions made from the image layers.
            let mean_layer = |c: &str| {
                let noisy = format!("noisy.{c}");
                f32s(if channel(&noisy).is_ok() { &noisy } else { c })
            };
            let guide = exact_sums::Guide {
                mean: [
                    mean_layer("R")?.clone(),
                    mean_layer("G")?.clone(),
                    mean_layer("B")?.clone(),
                ],
                variance: [
                    f32s("variance.R")?.clone(),
                    f32s("variance.G")?.clone(),
                    f32s("variance.B")?.clone(),
                ],
                depth: f32s("Z")?.clone(),
            };
            let mut stored = Vec::with_capacity(7);
            for name in exact_sums::NAMES {
                let mut w = Vec::with_capacity(4);
                for word in 0..4 {
                    w.push(words(&format!("part.{name}.r{word}"))?);
                }
                stored.push([w[0], w[1], w[2], w[3]]);
            }
            let stored: [[&Vec<exrp::f16>; 4]; 7] =
                stored.try_into().expect("seven sums of four words");
            exact_sums::decode(&mut pixels, &guide, &stored, u32s("part.raw")?);
        }
        let settings = super::settings_from_header(&layer.attributes);
        // Only for messages: a damaged or missing provenance is none.
        let text_attr = |key: &str| match attrs.get(&exrp::Text::from(key)) {
            Some(exrp::AttributeValue::Text(t)) => Some(t.to_string()),
            _ => None,
        };
        let provenance = match (text_attr(FILES), text_attr(SETTINGS)) {
            (Some(f), Some(settings)) => {
                u64::from_str_radix(&f, 16)
                    .ok()
                    .map(|files_hash| Provenance {
                        files_hash,
                        settings,
                    })
            }
            _ => None,
        };
        Ok(Part {
            info: PartInfo {
                scene_hash,
                image,
                window,
                sample_start,
                sample_end,
            },
            sums: FilmSums::from_pixels(width, height, sample_start, pixels, settings),
            provenance,
        })
    }
}

/// The window of a `size` image that a render with film `settings` fills:
/// the film's crop window if it has one (inside the image), else the whole
/// image. Parts must cover it, and a render keeps its sums.
pub fn image_window(settings: super::FilmSettings, (width, height): (u32, u32)) -> Tile {
    match settings.crop {
        Some(c) if c.x0 + c.width <= width && c.y0 + c.height <= height => Tile {
            x0: c.x0,
            y0: c.y0,
            width: c.width,
            height: c.height,
        },
        _ => Tile {
            x0: 0,
            y0: 0,
            width,
            height,
        },
    }
}

/// Combines parts (each with the file it came from, for messages) into the
/// sums of the whole image and their number of samples per pixel: the
/// parts must be pieces of one scene (same hash, image size and film
/// settings); the parts of each window must cover one range of samples
/// without gaps or overlaps, the same range for every window; and the
/// windows must cover the image without overlapping. Sample ranges of a
/// window are added in sample order.
pub fn merge_parts(parts: &[(PathBuf, Part)]) -> Result<(FilmSums, u32)> {
    let Some((first_file, first)) = parts.first() else {
        return Err(Error::invalid_argument("no parts to merge"));
    };
    let name = |f: &Path| f.display().to_string();
    for (file, part) in parts {
        if part.info.scene_hash != first.info.scene_hash {
            return Err(Error::input(
                file,
                SCENE,
                format!(
                    "scene hash {:016x} differs from {:016x} of {}: parts of different scenes or settings",
                    part.info.scene_hash,
                    first.info.scene_hash,
                    name(first_file)
                ),
            ));
        }
        if part.info.image != first.info.image {
            return Err(Error::input(
                file,
                IMAGE,
                format!(
                    "image size {}×{} differs from {}×{} of {}",
                    part.info.image.0,
                    part.info.image.1,
                    first.info.image.0,
                    first.info.image.1,
                    name(first_file)
                ),
            ));
        }
        if part.sums.settings() != first.sums.settings() {
            return Err(Error::input(
                file,
                "plsrFilter",
                format!("film settings differ from those of {}", name(first_file)),
            ));
        }
    }
    // The parts of each window, in sample order.
    let mut windows: Vec<(Tile, Vec<&(PathBuf, Part)>)> = Vec::new();
    for entry in parts {
        let w = entry.1.info.window;
        match windows.iter_mut().find(|(t, _)| *t == w) {
            Some((_, list)) => list.push(entry),
            None => windows.push((w, vec![entry])),
        }
    }
    let mut union: Option<(Range<u32>, &Path)> = None;
    for (_, list) in &mut windows {
        list.sort_by_key(|(_, p)| (p.info.sample_start, p.info.sample_end));
        for pair in list.windows(2) {
            let ((fa, a), (fb, b)) = (pair[0], pair[1]);
            let (ra, rb) = (a.info.samples(), b.info.samples());
            if rb.start < ra.end {
                return Err(Error::input(
                    fb,
                    SAMPLES,
                    format!(
                        "samples {}..{} overlap samples {}..{} of {}",
                        rb.start,
                        rb.end,
                        ra.start,
                        ra.end,
                        name(fa)
                    ),
                ));
            }
            if rb.start > ra.end {
                return Err(Error::input(
                    fb,
                    SAMPLES,
                    format!(
                        "samples {}..{} are missing between {} (samples {}..{}) and this part (samples {}..{})",
                        ra.end,
                        rb.start,
                        name(fa),
                        ra.start,
                        ra.end,
                        rb.start,
                        rb.end
                    ),
                ));
            }
        }
        let range = list[0].1.info.sample_start..list[list.len() - 1].1.info.sample_end;
        let file = list[0].0.as_path();
        match &union {
            None => union = Some((range, file)),
            Some((r, f)) if *r != range => {
                return Err(Error::input(
                    file,
                    SAMPLES,
                    format!(
                        "its window's parts cover samples {}..{}, but the window of {} has samples {}..{}",
                        range.start,
                        range.end,
                        name(f),
                        r.start,
                        r.end
                    ),
                ))
            }
            Some(_) => {}
        }
    }
    let (range, _) = union.expect("at least one part");
    // The image size comes from the parts' headers: what merging it needs
    // must fit in memory before anything of that size is allocated.
    let (width, height) = first.info.image;
    let needed = crate::render::memory_needed(width, height, 1, 1)
        + width as u64 * height as u64 * std::mem::size_of::<Option<&Path>>() as u64;
    if let Some(available) = crate::memory::available_bytes().filter(|&a| needed > a) {
        return Err(Error::input(
            first_file,
            IMAGE,
            format!(
                "the merged {width}×{height} image needs about {} of memory, more than the {} \
                 available (a damaged header, or merge on a larger machine)",
                crate::memory::human_bytes(needed),
                crate::memory::human_bytes(available)
            ),
        ));
    }
    // The windows must cover every pixel once: of the image, or of the
    // film's crop window if it has one.
    let required = image_window(first.sums.settings(), (width, height));
    let mut owner: Vec<Option<&Path>> = vec![None; width as usize * height as usize];
    for (w, list) in &windows {
        let file = list[0].0.as_path();
        for y in w.y0..w.y0 + w.height {
            for x in w.x0..w.x0 + w.width {
                let slot = &mut owner[y as usize * width as usize + x as usize];
                if let Some(other) = slot {
                    return Err(Error::input(
                        file,
                        WINDOW,
                        format!(
                            "its window overlaps that of {} at pixel ({x}, {y})",
                            name(other)
                        ),
                    ));
                }
                *slot = Some(file);
            }
        }
    }
    let uncovered = (required.y0..required.y0 + required.height)
        .flat_map(|y| (required.x0..required.x0 + required.width).map(move |x| (x, y)))
        .find(|&(x, y)| owner[y as usize * width as usize + x as usize].is_none());
    if let Some((x, y)) = uncovered {
        return Err(Error::invalid_argument(format!(
            "no part covers pixel ({x}, {y}) of the {width}×{height} image: a window is missing"
        )));
    }
    let mut whole = FilmSums::new(width, height, range.start, first.sums.settings());
    for (w, list) in &windows {
        let mut sums = list[0].1.sums.clone();
        for (file, part) in &list[1..] {
            sums.merge(&part.sums)
                .map_err(|e| Error::input(file, "", e.to_string()))?;
        }
        whole.add_tile(*w, sums.pixels());
    }
    Ok((whole, range.end - range.start))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::FilmSettings;
    use glam::DVec3;

    /// A part of an 8×6 window of a `image`-sized image.
    fn part(image: (u32, u32)) -> (PathBuf, Part) {
        let window = Tile {
            x0: 0,
            y0: 0,
            width: 8,
            height: 6,
        };
        let info = PartInfo {
            scene_hash: 7,
            image,
            window,
            sample_start: 0,
            sample_end: 4,
        };
        let sums = FilmSums::new(8, 6, 0, FilmSettings::default());
        (
            PathBuf::from("part.exr"),
            Part {
                info,
                sums,
                provenance: None,
            },
        )
    }

    /// Sums with awkward bit patterns (every word set, subnormals, −0,
    /// the largest finite value) in every pixel of a 5×3 part.
    fn awkward_part() -> Part {
        let patterns = [
            0x7fef_ffff_ffff_ffff_u64,
            0x0000_0000_0000_0001,
            0x8000_0000_0000_0000,
            0x3ff0_0000_0000_0001,
            0x7c00_7e00_fc00_ffff, // words that are half infinities and NaNs
            0x4059_0000_0000_0000,
        ];
        let pixels = (0..15u64)
            .map(|i| {
                let f = |k: u64| f64::from_bits(patterns[((i + k) % 6) as usize]);
                PixelSums {
                    sum: DVec3::new(f(0), f(1), f(2)),
                    sum_sq: DVec3::new(f(3), f(4), f(5)),
                    depth: f(i),
                    samples: 9,
                    hits: (i % 10) as u32,
                    virtual_hits: (i % 3) as u32,
                    normal: glam::Vec3::new(0.5, -0.25, i as f32),
                    albedo: glam::Vec3::splat(1.0 / (i + 1) as f32),
                    object_id: i as f32 - 1.0,
                }
            })
            .collect();
        let info = PartInfo {
            scene_hash: 0xfeed_beef,
            image: (5, 3),
            window: Tile {
                x0: 0,
                y0: 0,
                width: 5,
                height: 3,
            },
            sample_start: 0,
            sample_end: 9,
        };
        Part {
            info,
            sums: FilmSums::from_pixels(5, 3, 0, pixels, FilmSettings::default()),
            provenance: Some(Provenance {
                files_hash: 0x0123_4567_89ab_cdef,
                settings: "seed 3 max_depth 8".into(),
            }),
        }
    }

    fn assert_same_sums(a: &Part, b: &Part) {
        assert_eq!(a.info, b.info);
        assert_eq!(a.provenance, b.provenance);
        for (p, q) in a.sums.pixels().iter().zip(b.sums.pixels()) {
            for c in 0..3 {
                assert_eq!(p.sum[c].to_bits(), q.sum[c].to_bits());
                assert_eq!(p.sum_sq[c].to_bits(), q.sum_sq[c].to_bits());
            }
            assert_eq!(p.depth.to_bits(), q.depth.to_bits());
            assert_eq!(
                (p.samples, p.hits, p.virtual_hits, p.object_id),
                (q.samples, q.hits, q.virtual_hits, q.object_id)
            );
            assert_eq!((p.normal, p.albedo), (q.normal, q.albedo));
        }
    }

    #[test]
    fn sums_come_back_bit_for_bit_from_parts_and_compressed_renders() {
        let part = awkward_part();
        let dir = tempfile::tempdir().unwrap();
        for compressed in [false, true] {
            let path = dir.path().join(format!("p{compressed}.exr"));
            let mut outputs = OutputSet::new();
            let film = part.sums.develop(9);
            part.stage_exr_beside(&film, &mut outputs, &path, compressed)
                .unwrap();
            outputs.commit().unwrap();
            assert_same_sums(&part, &Part::read_exr(&path).unwrap());
        }
    }

    #[test]
    fn a_provenance_says_what_differs() {
        let file = Provenance {
            files_hash: 1,
            settings: "seed 0 max_depth 8 frame 3".into(),
        };
        let same = file.clone();
        assert_eq!(file.differences(&same), None);
        let now = Provenance {
            files_hash: 2,
            settings: "seed 7 max_depth 8 rr_depth 2".into(),
        };
        let said = file.differences(&now).unwrap();
        assert_eq!(
            said,
            "seed 0 in the file, 7 now; rr_depth 2 now, none in the file; frame 3 in the \
             file, none now; the scene file or a file it reads has changed since (or -D, \
             --anim-time or --light-picking differ)"
        );
    }

    #[test]
    fn counts_beyond_the_parts_sample_range_are_refused() {
        // The header says samples 0..5, the pixels count 9.
        let mut part = awkward_part();
        part.info.sample_end = 5;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("forged.exr");
        let mut outputs = OutputSet::new();
        part.stage_exr(&mut outputs, &path).unwrap();
        outputs.commit().unwrap();
        let e = Part::read_exr(&path).unwrap_err().to_string();
        assert!(
            e.contains("forged.exr")
                && e.contains("part.samples")
                && e.contains("pixel (0, 0) counts 9 samples"),
            "{e}"
        );
    }

    #[test]
    fn parts_of_the_older_layout_are_read() {
        // Each f64 sum as two 32-bit halves, as plsr wrote parts before
        // (without a provenance).
        let mut part = awkward_part();
        part.provenance = None;
        let pixels = part.sums.pixels();
        let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::new();
        let mut f64_channels = |name: &str, get: &dyn Fn(&PixelSums) -> f64| {
            for (half, shift) in [("hi", 32), ("lo", 0)] {
                channels.push(AnyChannel::new(
                    format!("part.{name}.{half}").as_str(),
                    FlatSamples::U32(
                        pixels
                            .iter()
                            .map(|p| (get(p).to_bits() >> shift) as u32)
                            .collect(),
                    ),
                ));
            }
        };
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            f64_channels(&format!("sum.{n}"), &|p| p.sum[c]);
            f64_channels(&format!("sum_sq.{n}"), &|p| p.sum_sq[c]);
        }
        f64_channels("depth", &|p| p.depth);
        let u32s =
            |get: &dyn Fn(&PixelSums) -> u32| FlatSamples::U32(pixels.iter().map(get).collect());
        let f32s =
            |get: &dyn Fn(&PixelSums) -> f32| FlatSamples::F32(pixels.iter().map(get).collect());
        channels.push(AnyChannel::new("part.samples", u32s(&|p| p.samples)));
        channels.push(AnyChannel::new("part.hits", u32s(&|p| p.hits)));
        channels.push(AnyChannel::new(
            "part.virtual_hits",
            u32s(&|p| p.virtual_hits),
        ));
        channels.push(AnyChannel::new("part.object_id", f32s(&|p| p.object_id)));
        for (c, n) in ["X", "Y", "Z"].iter().enumerate() {
            channels.push(AnyChannel::new(
                format!("part.normal.{n}").as_str(),
                f32s(&|p| p.normal[c]),
            ));
        }
        for (c, n) in ["R", "G", "B"].iter().enumerate() {
            channels.push(AnyChannel::new(
                format!("part.albedo.{n}").as_str(),
                f32s(&|p| p.albedo[c]),
            ));
        }
        let text = |k: &str, v: &str| {
            (
                exrp::Text::from(k),
                exrp::AttributeValue::Text(exrp::Text::from(v)),
            )
        };
        let attributes = vec![
            text(SCENE, "00000000feedbeef"),
            text(IMAGE, "5 3"),
            text(WINDOW, "0 0 5 3"),
            text(SAMPLES, "0 9"),
        ];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.exr");
        let mut outputs = OutputSet::new();
        part.sums
            .develop(9)
            .stage_exr_with(
                &mut outputs,
                &path,
                channels,
                attributes,
                exrp::Encoding::UNCOMPRESSED,
            )
            .unwrap();
        outputs.commit().unwrap();
        assert_same_sums(&part, &Part::read_exr(&path).unwrap());
    }

    #[test]
    fn a_header_claiming_an_image_too_large_to_merge_is_refused_before_allocating() {
        let e = merge_parts(&[part((30000, 30000))])
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("part.exr") && e.contains(IMAGE) && e.contains("30000×30000"),
            "{e}"
        );
        let (sums, spp) = merge_parts(&[part((8, 6))]).unwrap();
        assert_eq!((sums.width(), sums.height(), spp), (8, 6, 4));
    }
}
