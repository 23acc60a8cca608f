//! `[photo] exposure = "exif"`: a photo's exposure from its EXIF exposure
//! time, f-number and ISO, in the units of a panorama `plsr hdr merge`
//! made (issue 54, point 3), checked against the pixels of a merge of
//! simulated brackets, and through `plsr composite`.

use plsr::scene::photo::{ExifUnits, PhotoExposure, PhotoResponse, PhotoSpec};
use plsr_apps::composite::Photo;
use plsr_hdr::merge::{merge, MergeOptions};
use plsr_hdr::oiio::{self, AttrValue, ImageReader, PixelType};
use plsr_hdr::synth::{self, BracketOptions, CameraModel, SyntheticScene};
use std::path::{Path, PathBuf};

/// Five JPEG brackets of one synthetic scene at 0.3 s, by aperture and ISO
/// (f/8 ISO 100 to f/2 ISO 1600: relative exposures 0.3 to 76.8 s), from a
/// camera whose noise has seed `seed`.
fn brackets(dir: &Path, seed: u64) -> Vec<PathBuf> {
    std::fs::create_dir_all(dir).unwrap();
    synth::write_brackets(
        &SyntheticScene::new(64, 32),
        &CameraModel {
            seed,
            ..Default::default()
        },
        &[0.3; 5],
        dir,
        &BracketOptions {
            extension: "jpg".into(),
            f_numbers: vec![8.0, 4.0, 4.0, 2.0, 2.0],
            isos: vec![100.0, 100.0, 400.0, 400.0, 1600.0],
            attributes: vec![("CompressionQuality".into(), AttrValue::Int(100))],
            ..Default::default()
        },
    )
    .unwrap()
}

/// Merges brackets into `dir/pano.exr`, its curve into `dir/curve.csv`.
fn merged(dir: &Path) -> (PathBuf, PathBuf) {
    let (pano, curve) = (dir.join("pano.exr"), dir.join("curve.csv"));
    let options = MergeOptions {
        curve_csv: Some(curve.clone()),
        ..Default::default()
    };
    merge(
        &brackets(&dir.join("brackets"), 7),
        &pano,
        &options,
        &|_, _, _| {},
    )
    .unwrap();
    (pano, curve)
}

/// A photo of the panorama's scene by another exposure of the same camera
/// (f/4, ISO 400, 0.3 s: 4.8 s at the panorama's f/8, ISO 100), read
/// through the merge's curve, is 4.8 times the panorama: the factor EXIF
/// gives, and the one its pixels show.
#[test]
fn exif_gives_the_exposure_a_merged_panorama_s_pixels_show() {
    let dir = tempfile::tempdir().unwrap();
    let (pano, curve) = merged(dir.path());
    let photo_file = brackets(&dir.path().join("photo"), 99)[2].clone();
    let spec = PhotoSpec {
        file: photo_file,
        response: PhotoResponse::Curve(curve),
        exposure: PhotoExposure::Exif(ExifUnits {
            panorama: pano.clone(),
            scale: 1.0,
        }),
        reference: None,
    };
    let photo = Photo::load(&spec).unwrap();
    let k = photo.exposure.unwrap();
    assert!((k / 4.8 - 1.0).abs() < 1e-6, "{k}");
    let source = photo.exposure_source.unwrap();
    assert_eq!(
        source,
        "EXIF 0.3 s, f/4, ISO 400 against f/8, ISO 100 of pano.exr"
    );
    // The pixels: the photo's linear values over the panorama's, where the
    // photo is well exposed (between 5 % and 80 % of its clipping level).
    let mut reader = ImageReader::open(&pano).unwrap();
    let info = reader.info().clone();
    assert_eq!((info.width, info.height), (64, 32));
    let values = reader.read_all::<f32>().unwrap();
    let clip = photo.clip.unwrap().min_element();
    let mut ratios = Vec::new();
    for (i, p) in photo.radiance.iter().enumerate() {
        for c in 0..3 {
            let q = values[i * info.channels + c];
            if p[c] > 0.05 * clip && p[c] < 0.8 * clip && q > 0.0 {
                ratios.push(f64::from(p[c] / q));
            }
        }
    }
    assert!(ratios.len() > 1000, "{} well-exposed values", ratios.len());
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    eprintln!(
        "photo ÷ panorama: median {median:.4} over {} values, EXIF k = {k}",
        ratios.len()
    );
    assert!(
        (median / f64::from(k) - 1.0).abs() < 0.03,
        "{median} vs {k}"
    );
}

/// The composite room of `composite.rs`, as a scene that reads its photo's
/// exposure from EXIF against `pano.exr`.
fn scene(dir: &Path, photo: &str) -> PathBuf {
    let path = dir.join("ar.toml");
    let text = crate::composite::room("virtual = true", photo).replace("spp = 256", "spp = 4");
    std::fs::write(&path, text).unwrap();
    path
}

/// A 48×32 photo (the room's size) with `attributes`, as 8-bit TIFF.
fn photo(path: &Path, attributes: &[oiio::Attribute]) {
    let pixels = vec![128u8; 48 * 32 * 3];
    oiio::write_image(path, 48, 32, 3, PixelType::U8, attributes, &pixels).unwrap();
}

#[test]
fn composite_reads_the_exposure_from_exif() {
    let dir = tempfile::tempdir().unwrap();
    merged(dir.path());
    // TIFF: OpenImageIO 2.4 keeps 1/4 s exactly there, but writes no ISO.
    photo(
        &dir.path().join("photo.tif"),
        &[
            ("ExposureTime".into(), AttrValue::Float(0.25)),
            ("FNumber".into(), AttrValue::Float(16.0)),
        ],
    );
    let ar = scene(
        dir.path(),
        "[photo]\nfile = \"photo.tif\"\nexposure = \"exif\"\npanorama = \"pano.exr\"\n",
    );
    let out = dir.path().join("c.exr");
    let (ok, _, stderr) = crate::plsr(&[
        "composite",
        ar.to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(ok, "{stderr}");
    // 0.25 s × (8/16)² = 0.0625, the ISO taken as equal.
    assert!(
        stderr.contains(
            "exposure k = 0.06250 (from EXIF 1/4 s, f/16 against f/8 of pano.exr; the ISO taken \
             as the panorama's (not in both files))"
        ),
        "{stderr}"
    );
}

#[test]
fn exif_exposures_that_cannot_be_worked_out_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    photo(&d.join("bare.tif"), &[]);
    photo(
        &d.join("timed.tif"),
        &[("ExposureTime".into(), AttrValue::Float(0.25))],
    );
    // An EXR plsr did not merge.
    oiio::write_image(
        &d.join("other.exr"),
        2,
        1,
        3,
        PixelType::F32,
        &[],
        &[1f32; 6],
    )
    .unwrap();
    let refused = |photo: &str, wants: &[&str]| {
        let ar = scene(d, photo);
        let out = d.join("c.exr");
        let (ok, _, stderr) = crate::plsr(&[
            "composite",
            ar.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(!ok && !stderr.contains("panicked"), "{stderr}");
        assert!(!out.exists());
        for w in wants {
            assert!(stderr.contains(w), "{w}: {stderr}");
        }
    };
    // No panorama, no environment map: nothing says the render's units.
    refused(
        "[photo]\nfile = \"timed.tif\"\nexposure = \"exif\"\n",
        &["photo.exposure", "panorama = "],
    );
    // A panorama without `exposure = "exif"`.
    refused(
        "[photo]\nfile = \"timed.tif\"\nexposure = 1\npanorama = \"other.exr\"\n",
        &["photo.panorama", "only read with exposure = \"exif\""],
    );
    // A photo without an exposure time.
    refused(
        "[photo]\nfile = \"bare.tif\"\nexposure = \"exif\"\npanorama = \"other.exr\"\n",
        &["other.exr", "plsr:relative_exposures"],
    );
    merged(d);
    refused(
        "[photo]\nfile = \"bare.tif\"\nexposure = \"exif\"\npanorama = \"pano.exr\"\n",
        &["bare.tif", "ExposureTime", "not in the photo's EXIF"],
    );
}

/// Without `panorama`, the units are the environment map's, and its
/// `scale` brightens the render: `k` is divided by it.
#[test]
fn the_environment_map_gives_the_units_by_default() {
    let dir = tempfile::tempdir().unwrap();
    let (pano, _) = merged(dir.path());
    let text = crate::composite::room(
        "virtual = true",
        "[photo]\nfile = \"p.tif\"\nexposure = \"exif\"\n",
    )
        + "\n[environment]\nfile = \"pano.exr\"\nscale = 2\nup = [0, 0, 1]\nforward = [0, 1, 0]\n";
    let path = dir.path().join("lit.toml");
    let contents = plsr::scene::file::load_contents_from_text(&path, &text).unwrap();
    assert_eq!(
        contents.photo.unwrap().exposure,
        PhotoExposure::Exif(ExifUnits {
            panorama: pano,
            scale: 2.0
        })
    );
}

/// On real photographs (Debevec's Memorial Church stack): the other 15
/// brackets merged, the held-out 1/4 s one given its exposure time in EXIF
/// is read through the merge's curve at `k` = 0.25 of the panorama, and its
/// pixels show the same factor.
#[test]
fn a_held_out_real_bracket_is_at_its_exif_exposure_of_the_merge() {
    use plsr_hdr::merge::parse_exposure;
    let real = std::path::Path::new("tests/data/realworld/hdr/memorial");
    let times: Vec<f64> = std::fs::read_to_string(real.join("shutter_times.txt"))
        .unwrap()
        .lines()
        .filter(|l| !l.trim().is_empty())
        .map(|l| parse_exposure(l.trim()).unwrap())
        .collect();
    let held_out = 7; // memorial0068.png, 1/4 s
    assert_eq!(times[held_out], 0.25);
    let (files, merged_times): (Vec<PathBuf>, Vec<f64>) = (0..16)
        .filter(|&i| i != held_out)
        .map(|i| (real.join(format!("memorial{:04}.png", 61 + i)), times[i]))
        .unzip();
    let dir = tempfile::tempdir().unwrap();
    let (pano, curve) = (dir.path().join("pano.exr"), dir.path().join("curve.csv"));
    let options = MergeOptions {
        exposures: Some(merged_times),
        curve_csv: Some(curve.clone()),
        ..Default::default()
    };
    merge(&files, &pano, &options, &|_, _, _| {}).unwrap();
    // The held-out scan with its exposure time in EXIF (TIFF keeps 1/4 s).
    let mut scan = ImageReader::open(&real.join("memorial0068.png")).unwrap();
    let info = scan.info().clone();
    let codes = scan.read_all::<u8>().unwrap();
    let photo_file = dir.path().join("photo.tif");
    oiio::write_image(
        &photo_file,
        info.width,
        info.height,
        info.channels,
        PixelType::U8,
        &[("ExposureTime".into(), AttrValue::Float(0.25))],
        &codes,
    )
    .unwrap();
    let photo = Photo::load(&PhotoSpec {
        file: photo_file,
        response: PhotoResponse::Curve(curve),
        exposure: PhotoExposure::Exif(ExifUnits {
            panorama: pano.clone(),
            scale: 1.0,
        }),
        reference: None,
    })
    .unwrap();
    let k = photo.exposure.unwrap();
    assert_eq!(k, 0.25);
    let (pinfo, values) = oiio::read_image_f32(&pano).unwrap();
    assert_eq!((pinfo.width, pinfo.height), (info.width, info.height));
    let clip = photo.clip.unwrap().min_element();
    let mut ratios = Vec::new();
    for (i, p) in photo.radiance.iter().enumerate() {
        for c in 0..3 {
            let q = values[i * pinfo.channels + c];
            if p[c] > 0.1 * clip && p[c] < 0.8 * clip && q > 0.0 {
                ratios.push(f64::from(p[c] / q));
            }
        }
    }
    assert!(ratios.len() > 1000, "{} well-exposed values", ratios.len());
    ratios.sort_by(f64::total_cmp);
    let median = ratios[ratios.len() / 2];
    eprintln!(
        "Memorial, held-out 1/4 s: photo ÷ panorama median {median:.4} over {} values, EXIF k = {k}",
        ratios.len()
    );
    // Measured 0.2486 (0.6 % low).
    assert!(
        (median / f64::from(k) - 1.0).abs() < 0.02,
        "{median} vs {k}"
    );
}
