//! Compositing virtual objects into photographs (`plsr composite`):
//! hiding virtual geometry by ray masks, the matte, the exposure fit, the
//! round trip of untouched pixels, and the contact shadow against a
//! synthetic ground truth (a "photo" of the room with a real object).

use glam::Vec3;
use plsr::film::{Film, ToneMap};
use plsr::render::{render, RenderJob, RenderOptions};
use plsr::scene::Scene;
use plsr_apps::composite::{composite_scene, fit_exposure, CompositeOptions, Mode, Retrace};
use std::path::Path;
use std::process::Command;

/// A floor lit by a point light, seen from above at an angle, with a
/// sphere standing on it; `SPHERE` is replaced by the sphere's extra keys
/// (`virtual = true`, or nothing for a real one) and `PHOTO` by a `[photo]`
/// table.
const ROOM: &str = r#"
[render]
spp = 256
max_depth = 3
seed = 7

[camera]
position = [0, -4, 3]
look_at = [0, 0, 0.3]
up = [0, 0, 1]
vfov = 40
resolution = [48, 32]

PHOTO

[[materials]]
name = "floor"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]

[[materials]]
name = "object"
type = "diffuse"
reflectance = [0.8, 0.3, 0.2]

[[shapes]]
type = "rectangle"
material = "floor"
transform = { scale = 3 }

[[lights]]
type = "point"
position = [1.5, -1, 3]
intensity = [6, 6, 6]

[[shapes]]
type = "sphere"
material = "object"
center = [0, 0, 0.5]
radius = 0.5
subdivisions = 3
SPHERE
"#;

pub(crate) fn room(sphere: &str, photo: &str) -> String {
    ROOM.replace("SPHERE", sphere).replace("PHOTO", photo)
}

/// Renders scene text written to `dir/name` with its own job.
fn render_text(dir: &Path, name: &str, text: &str, hide_virtual: bool) -> Film {
    let path = dir.join(name);
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    let job = RenderJob {
        hide_virtual,
        ..scene.default_job()
    };
    render(&scene, &job, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0
}

#[test]
fn hidden_virtual_objects_render_as_if_absent_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    // The scene without the sphere at all, and with it virtual but hidden:
    // the same samples meet the same surfaces.
    let absent = room("", "").replace(
        "[[shapes]]\ntype = \"sphere\"",
        "[[unused]]\ntype = \"sphere\"",
    );
    let absent: String = absent.split("[[unused]]").next().unwrap().to_string();
    let without = render_text(dir.path(), "absent.toml", &absent, false);
    let hidden = render_text(dir.path(), "hidden.toml", &room("virtual = true", ""), true);
    assert!(without.color == hidden.color, "hiding is not absence");
    assert!(without.alpha == hidden.alpha);
    // Seen, the sphere changes the image (the test is not vacuous).
    let seen = render_text(dir.path(), "seen.toml", &room("virtual = true", ""), false);
    assert!(seen.color != hidden.color);
}

/// Writes the photos of the room: `without.png` (no object) and
/// `truth.png` (a real object), through sRGB at `stops` of exposure, from
/// renders with many samples and another seed than the composite's.
fn photos(dir: &Path, stops: f32) {
    let tone = ToneMap {
        exposure: stops,
        filmic: false,
    };
    // The `sel-` pair, of other seeds, only chooses the pixels to compare,
    // so that the choice does not favour the noise of the compared images.
    for (name, sphere, hide, seed) in [
        ("without", "virtual = true", true, 99),
        ("truth", "", false, 99),
        ("sel-without", "virtual = true", true, 5),
        ("sel-truth", "", false, 6),
    ] {
        let text = room(sphere, "")
            .replace("spp = 256", "spp = 1024")
            .replace("seed = 7", &format!("seed = {seed}"));
        let film = render_text(dir, &format!("{name}.toml"), &text, hide);
        film.write_png(&dir.join(format!("{name}.png")), tone)
            .unwrap();
    }
}

/// One channel of an OpenEXR file.
fn exr_channel(path: &Path, name: &str) -> Vec<f32> {
    let exr = exr::prelude::read_first_flat_layer_from_file(path).unwrap();
    exr.layer_data
        .channel_data
        .list
        .iter()
        .find(|c| c.name.to_string() == name)
        .unwrap_or_else(|| panic!("no channel {name}"))
        .sample_data
        .values_as_f32()
        .collect()
}

fn read_png(path: &Path) -> image::RgbImage {
    image::open(path).unwrap().to_rgb8()
}

/// Composites the virtual sphere into `without.png` in `dir` with the
/// command line; returns the PNG and stderr.
fn composite_cli(dir: &Path, exposure: &str, mode: &str) -> (image::RgbImage, String) {
    let photo = format!("[photo]\nfile = \"without.png\"\nexposure = {exposure}\n");
    std::fs::write(dir.join("ar.toml"), room("virtual = true", &photo)).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir)
        .args(["composite", "ar.toml", "-o", "c.exr", "--png", "c.png"])
        .args(["--mode", mode, "--spp", "1024"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert!(output.status.success(), "{stderr}");
    (read_png(&dir.join("c.png")), stderr)
}

#[test]
fn the_composite_matches_a_photo_of_the_real_object_with_its_shadow() {
    let dir = tempfile::tempdir().unwrap();
    photos(dir.path(), 0.0);
    let truth = read_png(&dir.path().join("truth.png"));
    let without = read_png(&dir.path().join("without.png"));
    let (sel_truth, sel_without) = (
        read_png(&dir.path().join("sel-truth.png")),
        read_png(&dir.path().join("sel-without.png")),
    );
    let (differential, _) = composite_cli(dir.path(), "1.0", "differential");
    let (superimposed, _) = composite_cli(dir.path(), "1.0", "superimpose");
    let matte = exr_channel(&dir.path().join("c.exr"), "A");
    assert_eq!(matte.len(), 48 * 32);

    // The contact shadow: floor pixels (outside the matte) the object
    // darkens in the truth by more than 10 %.
    let lum = |p: &image::Rgb<u8>| p.0.iter().map(|&v| v as f64).sum::<f64>();
    let shadow: Vec<(u32, u32)> = sel_truth
        .enumerate_pixels()
        .filter(|(x, y, p)| {
            // Away from the object's outline, which other samples cover
            // differently.
            let clear = (-1i32..=1).all(|dy| {
                (-1i32..=1).all(|dx| {
                    let (u, v) = (*x as i32 + dx, *y as i32 + dy);
                    !(0..48).contains(&u)
                        || !(0..32).contains(&v)
                        || matte[(v * 48 + u) as usize] == 0.0
                })
            });
            clear && lum(p) < 0.9 * lum(sel_without.get_pixel(*x, *y))
        })
        .map(|(x, y, _)| (x, y))
        .collect();
    assert!(
        shadow.len() > 10,
        "the scene casts a shadow ({} pixels)",
        shadow.len()
    );
    let mean = |img: &image::RgbImage| {
        shadow
            .iter()
            .map(|&(x, y)| lum(img.get_pixel(x, y)))
            .sum::<f64>()
            / shadow.len() as f64
    };
    let (t, d, s, w) = (
        mean(&truth),
        mean(&differential),
        mean(&superimposed),
        mean(&without),
    );
    eprintln!(
        "shadow of {} pixels, summed 8-bit RGB: truth {t:.1}, differential {d:.1}, superimpose {s:.1}, photo {w:.1}",
        shadow.len()
    );
    // Differential compositing finds the shadow within 3 %; pasting the
    // object over the photo misses it (those pixels stay the photo's).
    assert!(
        (d - t).abs() < 0.03 * t,
        "shadow: truth {t:.1}, differential {d:.1}"
    );
    assert!(
        (s - w).abs() < 1e-9,
        "superimpose keeps the photo: {s} vs {w}"
    );
    assert!(
        (s - t).abs() > 0.1 * t,
        "superimpose misses the shadow: {s:.1} vs {t:.1}"
    );
}

#[test]
fn untouched_pixels_are_the_photo_and_auto_exposure_finds_k() {
    let dir = tempfile::tempdir().unwrap();
    // Photos one stop darker than the render: k = 0.5.
    photos(dir.path(), -1.0);
    let without = read_png(&dir.path().join("without.png"));
    let (composite, stderr) = composite_cli(dir.path(), "\"auto\"", "differential");
    let k: f64 = stderr
        .split("exposure k = ")
        .nth(1)
        .and_then(|s| s.split_whitespace().next())
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| panic!("no fitted k in: {stderr}"));
    assert!(
        (k - 0.5).abs() < 0.005,
        "fitted k = {k}, expected 0.5 within 1 %"
    );
    // Where nothing virtual has any effect (matte 0, difference exactly 0),
    // the composite's PNG is the photo's, code for code.
    let path = dir.path().join("c.exr");
    let channel = |name: &str| exr_channel(&path, name);
    let (alpha, dr, dg, db) = (
        channel("A"),
        channel("difference.R"),
        channel("difference.G"),
        channel("difference.B"),
    );
    let mut untouched = 0;
    for (i, (a, p)) in alpha.iter().zip(composite.pixels()).enumerate() {
        if *a == 0.0 && dr[i] == 0.0 && dg[i] == 0.0 && db[i] == 0.0 {
            untouched += 1;
            let q = without.get_pixel(i as u32 % 48, i as u32 / 48);
            for c in 0..3 {
                assert!(
                    (p.0[c] as i32 - q.0[c] as i32).abs() <= 1,
                    "pixel {i}: {:?} vs the photo's {:?}",
                    p.0,
                    q.0
                );
            }
        }
    }
    assert!(untouched > 100, "only {untouched} untouched pixels");
}

#[test]
fn the_exposure_fit_ignores_what_the_proxy_does_not_model() {
    // photo = 0.25 · render, but for 20 % of pixels that hold something
    // the proxy lacks (much brighter).
    let render: Vec<Vec3> = (0..1000)
        .map(|i| Vec3::splat(0.1 + (i % 37) as f32 * 0.01))
        .collect();
    let photo: Vec<Vec3> = render
        .iter()
        .enumerate()
        .map(|(i, r)| if i % 5 == 0 { *r * 3.0 } else { *r * 0.25 })
        .collect();
    let matte = vec![0.0; 1000];
    let fit = fit_exposure(&photo, &render, &matte).unwrap();
    assert!((fit.k - 0.25).abs() < 0.0025, "{fit:?}");
    assert!(fit.used <= 800 && fit.used >= 700, "{fit:?}");
}

/// Runs `plsr composite` on a scene text in `dir` and returns stderr after
/// checking it failed cleanly and wrote nothing.
fn refused(dir: &Path, text: &str) -> String {
    std::fs::write(dir.join("bad.toml"), text).unwrap();
    let output = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir)
        .args([
            "composite",
            "bad.toml",
            "-o",
            "out.exr",
            "--png",
            "out.png",
            "--quiet",
        ])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    assert_eq!(output.status.code(), Some(1), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert!(!dir.join("out.exr").exists() && !dir.join("out.png").exists());
    stderr
}

#[test]
fn bad_composites_are_clear_errors() {
    let dir = tempfile::tempdir().unwrap();
    photos(dir.path(), 0.0);
    let photo = "[photo]\nfile = \"without.png\"\n";
    // No [photo].
    let e = refused(dir.path(), &room("virtual = true", ""));
    assert!(
        e.contains("bad.toml") && e.contains("photo") && e.contains("required"),
        "{e}"
    );
    // No virtual shape.
    let e = refused(dir.path(), &room("", photo));
    assert!(
        e.contains("bad.toml: shapes") && e.contains("virtual = true"),
        "{e}"
    );
    // A photo of another size than the camera's.
    let e = refused(
        dir.path(),
        &room("virtual = true", photo).replace("[48, 32]", "[40, 32]"),
    );
    assert!(
        e.contains("photo.file") && e.contains("48×32") && e.contains("40×32"),
        "{e}"
    );
    // An unreadable photo.
    std::fs::write(dir.path().join("broken.png"), b"not a png").unwrap();
    let e = refused(
        dir.path(),
        &room("virtual = true", "[photo]\nfile = \"broken.png\"\n"),
    );
    assert!(e.contains("broken.png"), "{e}");
    // A response curve of the wrong length (16 levels for an 8-bit photo).
    let mut csv = String::from("level,pixel_value,r,g,b\n");
    for l in 0..16 {
        csv += &format!("{l},{},{l},{l},{l}\n", l as f32 / 15.0);
    }
    std::fs::write(dir.path().join("curve.csv"), csv).unwrap();
    let e = refused(
        dir.path(),
        &room(
            "virtual = true",
            "[photo]\nfile = \"without.png\"\nresponse = \"curve.csv\"\n",
        ),
    );
    assert!(
        e.contains("photo.response") && e.contains("16 levels") && e.contains("256"),
        "{e}"
    );
    // A bad exposure, and an emitting virtual object.
    let e = refused(
        dir.path(),
        &room(
            "virtual = true",
            "[photo]\nfile = \"without.png\"\nexposure = -2\n",
        ),
    );
    assert!(e.contains("photo.exposure"), "{e}");
    let e = refused(
        dir.path(),
        &room("virtual = true\nemission = [1, 1, 1]", photo),
    );
    assert!(e.contains("emission") && e.contains("virtual"), "{e}");
}

#[test]
fn the_library_composites_without_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    photos(dir.path(), 0.0);
    let path = dir.path().join("ar.toml");
    std::fs::write(
        &path,
        room(
            "virtual = true",
            "[photo]\nfile = \"without.png\"\nexposure = 1\n",
        ),
    )
    .unwrap();
    let contents = plsr::scene::file::load_contents(&path).unwrap();
    let options = CompositeOptions {
        mode: Mode::Differential,
        spp: Some(4),
        ..Default::default()
    };
    let (result, _, report) = composite_scene(&path, contents, &options, &|_, _| true).unwrap();
    assert_eq!((result.width, result.height), (48, 32));
    assert_eq!(report.samples, 2 * 48 * 32 * 4);
    // The sphere covers some pixels fully and some in part (anti-aliased).
    assert!(result.matte.contains(&1.0));
    assert!(result.matte.iter().any(|&a| a > 0.0 && a < 1.0));
    // Its shadow darkens the floor: some differences are negative.
    assert!(result.difference.iter().any(|d| d.max_element() < 0.0));
}

#[test]
fn the_demo_composites_through_its_recovered_curve() {
    // assets/scenes/ar-demo: an 8-bit photo from plsr's simulated camera
    // and the response curve `hdr merge --curve` recovered for it.
    let path = Path::new("assets/scenes/ar-demo/ar-demo.toml");
    let contents = plsr::scene::file::load_contents(path).unwrap();
    let options = CompositeOptions {
        spp: Some(2),
        ..Default::default()
    };
    let (result, transfer, report) =
        composite_scene(path, contents, &options, &|_, _| true).unwrap();
    assert!(matches!(transfer, plsr_apps::composite::Transfer::Curve(_)));
    let fit = report.fit.expect("the demo fits its exposure");
    assert!(fit.k > 0.0 && fit.used > fit.considered / 2, "{fit:?}");
    assert!(result.matte.iter().filter(|&&a| a == 1.0).count() > 1000);
}

#[test]
fn tracing_the_pair_together_composites_as_two_renders_do() {
    // The demo's composite with the render without the virtual objects
    // made alongside the one with them (forked paths) and as a second
    // whole render: the same composite, matte, difference and fitted
    // exposure, bit for bit.
    let path = Path::new("assets/scenes/ar-demo/ar-demo.toml");
    let run = |retrace| {
        let contents = plsr::scene::file::load_contents(path).unwrap();
        let options = CompositeOptions {
            spp: Some(2),
            retrace,
            ..Default::default()
        };
        let (result, _, report) = composite_scene(path, contents, &options, &|_, _| true).unwrap();
        (result, report)
    };
    let (paired, report) = run(Retrace::Touched);
    let (apart, apart_report) = run(Retrace::All);
    let bits = |v: &[Vec3]| -> Vec<u32> {
        v.iter()
            .flat_map(|c| c.to_array().map(f32::to_bits))
            .collect()
    };
    assert!(bits(&paired.color) == bits(&apart.color), "the composite");
    assert!(
        bits(&paired.difference) == bits(&apart.difference),
        "the difference"
    );
    assert!(paired.matte == apart.matte, "the matte");
    assert_eq!(paired.k.to_bits(), apart.k.to_bits(), "the exposure");
    assert_eq!(report.samples, apart_report.samples);
    // Some paths met the ball, not most.
    let paths = report.samples / 2;
    assert!(
        report.rays.forked > 0 && report.rays.forked < paths / 2,
        "{:?} of {paths} paths forked",
        report.rays.forked
    );
    assert_eq!(apart_report.rays.forked, 0);
}

#[test]
fn two_renders_on_the_command_line_write_the_same_composite() {
    let dir = tempfile::tempdir().unwrap();
    let scene = "assets/scenes/ar-demo/ar-demo.toml";
    let mut outputs = Vec::new();
    for (name, extra) in [("paired", None), ("apart", Some("--two-renders"))] {
        let exr = dir.path().join(format!("{name}.exr"));
        let exr_arg = exr.to_str().unwrap();
        let mut args = vec!["composite", scene, "-o", exr_arg, "--spp", "1"];
        args.extend(extra);
        let (ok, _, err) = crate::plsr(&args);
        assert!(ok, "{err}");
        // Only the default says how many paths it traced apart.
        assert_eq!(err.contains("traced apart"), extra.is_none(), "{err}");
        outputs.push(std::fs::read(&exr).unwrap());
    }
    assert!(outputs[0] == outputs[1], "the two EXRs differ");
}

/// The room lit by a sphere light instead of the point light (soft,
/// noisy shadows), at 96×64.
fn soft_room(sphere: &str, photo: &str) -> String {
    room(sphere, photo)
        .replace("resolution = [48, 32]", "resolution = [96, 64]")
        .replace(
            "[[lights]]\ntype = \"point\"\nposition = [1.5, -1, 3]\nintensity = [6, 6, 6]",
            "[[materials]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\n\
             [[shapes]]\ntype = \"sphere\"\nmaterial = \"lamp\"\ncenter = [1.5, -1, 3]\n\
             radius = 0.6\nemission = [5.3, 5.3, 5.3]",
        )
}

#[test]
fn denoising_both_renders_keeps_the_shadow_s_mean() {
    // The sphere's soft shadow in `difference` = k·(W − O): at 1024 spp
    // unbiased (the reference), and at 16 spp with and without denoising
    // both renders.
    let dir = tempfile::tempdir().unwrap();
    let text = soft_room("virtual = true", "").replace("spp = 256", "spp = 1024");
    assert!(text.contains("emission"));
    let photo = render_text(dir.path(), "photo.toml", &text, true);
    photo
        .write_png(
            &dir.path().join("without.png"),
            ToneMap {
                exposure: 0.0,
                filmic: false,
            },
        )
        .unwrap();
    let path = dir.path().join("ar.toml");
    std::fs::write(
        &path,
        soft_room(
            "virtual = true",
            "[photo]\nfile = \"without.png\"\nexposure = 1\n",
        ),
    )
    .unwrap();
    let run = |spp: u32, seed: u64, denoise: bool| {
        let contents = plsr::scene::file::load_contents(&path).unwrap();
        let options = CompositeOptions {
            spp: Some(spp),
            seed: Some(seed),
            denoise: denoise.then(Default::default),
            ..Default::default()
        };
        composite_scene(&path, contents, &options, &|_, _| true)
            .unwrap()
            .0
    };
    let reference = run(1024, 11, false);
    // Shadow pixels: outside the matte (one pixel clear of it), darkened
    // by more than 10 % in the reference.
    let (w, h) = (96i32, 64i32);
    let lum = |v: Vec3| f64::from(v.x + v.y + v.z);
    let shadow: Vec<usize> = (0..(w * h) as usize)
        .filter(|&i| {
            let (x, y) = (i as i32 % w, i as i32 / w);
            let clear = (-1..=1).all(|dy| {
                (-1..=1).all(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    !(0..w).contains(&u)
                        || !(0..h).contains(&v)
                        || reference.matte[(v * w + u) as usize] == 0.0
                })
            });
            let before = lum(reference.color[i] - reference.difference[i]);
            clear && lum(reference.difference[i]) < -0.1 * before
        })
        .collect();
    assert!(shadow.len() > 50, "a shadow of {} pixels", shadow.len());
    let mean = |c: &plsr_apps::composite::Composite| {
        shadow.iter().map(|&i| lum(c.difference[i])).sum::<f64>() / shadow.len() as f64
    };
    let error = |c: &plsr_apps::composite::Composite| {
        shadow
            .iter()
            .map(|&i| (lum(c.difference[i]) - lum(reference.difference[i])).powi(2))
            .sum::<f64>()
            / shadow.len() as f64
    };
    let (noisy, denoised) = (run(16, 3, false), run(16, 3, true));
    let (r, n, d) = (mean(&reference), mean(&noisy), mean(&denoised));
    eprintln!(
        "shadow of {} pixels, mean difference: reference {r:.4}, 16 spp {n:.4}, denoised {d:.4}; \
         squared error per pixel {:.2e} noisy, {:.2e} denoised",
        shadow.len(),
        error(&noisy),
        error(&denoised)
    );
    assert!((d - r).abs() < 0.03 * r.abs(), "denoised {d} vs {r}");
    assert!(error(&denoised) < error(&noisy) / 2.0);
}

/// HSV hue of a linear RGB colour, degrees.
fn hue_degrees(c: Vec3) -> f64 {
    let (r, g, b) = (c.x as f64, c.y as f64, c.z as f64);
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    if max - min <= 0.0 {
        return 0.0;
    }
    let h = if max == r {
        (g - b) / (max - min)
    } else if max == g {
        2.0 + (b - r) / (max - min)
    } else {
        4.0 + (r - g) / (max - min)
    };
    (h * 60.0).rem_euclid(360.0)
}

/// The issue's point 2: a real floor whose colour the proxy gets wrong
/// (warm in the photos, grey in the scene). The differential composite's
/// contact shadow keeps the truth's hue within a few degrees and its mean
/// within 3 %; Debevec's additive form, measured beside it, subtracts
/// the grey proxy's shadow from a photo darker in blue, clamps, and shifts
/// the hue.
#[test]
fn shadows_keep_the_photos_hue_when_the_proxy_colour_is_wrong() {
    let dir = tempfile::tempdir().unwrap();
    let warm = "reflectance = [0.75, 0.45, 0.2]";
    // The photos: the warm floor, without and with a real object.
    let mut films = Vec::new();
    for (name, sphere, hide) in [("without", "virtual = true", true), ("truth", "", false)] {
        let text = room(sphere, "")
            .replacen("reflectance = [0.6, 0.6, 0.6]", warm, 1)
            .replace("spp = 256", "spp = 1024")
            .replace("seed = 7", "seed = 99");
        let film = render_text(dir.path(), &format!("{name}.toml"), &text, hide);
        film.write_png(&dir.path().join(format!("{name}.png")), ToneMap::default())
            .unwrap();
        films.push(film);
    }
    let (without, truth) = (&films[0], &films[1]);
    let mut measured = Vec::new();
    for mode in ["differential", "additive"] {
        composite_cli(dir.path(), "1.0", mode);
        let channel = |c| exr_channel(&dir.path().join("c.exr"), c);
        let (r, g, b, a) = (channel("R"), channel("G"), channel("B"), channel("A"));
        // Contact shadow: floor pixels clear of the object's outline that
        // the truth darkens by more than a third against the photo.
        let (mut worst_hue, mut sum_c, mut sum_t, mut n) = (0.0f64, 0.0f64, 0.0f64, 0);
        for y in 0..32u32 {
            for x in 0..48u32 {
                let i = (y * 48 + x) as usize;
                let clear = (-1i32..=1).all(|dy| {
                    (-1i32..=1).all(|dx| {
                        let (u, v) = (x as i32 + dx, y as i32 + dy);
                        !(0..48).contains(&u)
                            || !(0..32).contains(&v)
                            || a[(v * 48 + u) as usize] == 0.0
                    })
                });
                let t = truth.color[i];
                if !clear || t.element_sum() > 0.66 * without.color[i].element_sum() {
                    continue;
                }
                let c = Vec3::new(r[i], g[i], b[i]);
                // Hue is compared where the shadow leaves at least 2 % of
                // the light (below, about 3 of 255 sRGB levels: no hue to see).
                if t.element_sum() >= 0.02 * without.color[i].element_sum() {
                    let dh = (hue_degrees(c) - hue_degrees(t)).abs();
                    worst_hue = worst_hue.max(dh.min(360.0 - dh));
                }
                sum_c += c.element_sum() as f64;
                sum_t += t.element_sum() as f64;
                n += 1;
            }
        }
        assert!(n > 10, "a contact shadow ({n} pixels)");
        let mean_error = sum_c / sum_t - 1.0;
        eprintln!(
            "{mode}: {n} shadow pixels, worst hue error {worst_hue:.1}°, mean {:+.1} %",
            100.0 * mean_error
        );
        measured.push((worst_hue, mean_error));
    }
    let (hue, mean) = measured[0];
    assert!(hue <= 4.0, "differential: hue off by {hue:.1}°");
    assert!(
        mean.abs() <= 0.03,
        "differential: shadow mean off by {:.1} %",
        100.0 * mean
    );
    // The additive form does worse here (what the ratio is for).
    assert!(
        measured[1].0 > hue || measured[1].1.abs() > mean.abs(),
        "{measured:?}"
    );
}

/// Point 7: a video. Two frames of a camera path, each with its own photo
/// (`{frame}` in the names), the second photo a stop brighter: the
/// exposure fitted on the first frame is kept (no flicker), or fitted per
/// frame with --refit-exposure; each frame is seen from its own pose.
#[test]
fn a_video_composites_each_frame_through_its_camera() {
    let dir = tempfile::tempdir().unwrap();
    let path = "[[camera.path]]\nframe = 0\nposition = [0, -4, 3]\nlook_at = [0, 0, 0.3]\n\
                [[camera.path]]\nframe = 2\nposition = [1.5, -3.5, 2.5]\nlook_at = [0, 0, 0.3]\n";
    let with_path = |photo: &str| {
        room("virtual = true", photo).replace(
            "resolution = [48, 32]",
            &format!("resolution = [48, 32]\n{path}"),
        )
    };
    // The photos: the room without the sphere from each frame's pose.
    let text = with_path("");
    std::fs::write(dir.path().join("video.toml"), &text).unwrap();
    let contents = plsr::scene::file::load_contents(&dir.path().join("video.toml")).unwrap();
    let camera_path = contents.camera_path.clone().unwrap();
    let base = contents.description.camera.clone();
    let mut scene = Scene::build(contents.description).unwrap();
    for frame in 0..2u32 {
        scene.set_camera(base.with_pose(camera_path.pose_at(frame).unwrap()));
        let job = RenderJob {
            hide_virtual: true,
            spp: 256,
            seed: 99,
            ..scene.default_job()
        };
        let (film, _) = render(&scene, &job, &RenderOptions::default(), &|_, _| true).unwrap();
        let tone = ToneMap {
            exposure: frame as f32,
            filmic: false,
        };
        film.write_png(&dir.path().join(format!("photo-{frame:04}.png")), tone)
            .unwrap();
    }
    std::fs::write(
        dir.path().join("video.toml"),
        with_path("[photo]\nfile = \"photo-{frame}.png\"\n"),
    )
    .unwrap();
    let run = |extra: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
            .current_dir(dir.path())
            .args([
                "composite",
                "video.toml",
                "--frames",
                "0..2",
                "-o",
                "c-{frame}.exr",
                "--spp",
                "16",
            ])
            .args(extra)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
        assert!(out.status.success(), "{stderr}");
        let k: Vec<f64> = stderr
            .lines()
            .filter_map(|l| l.split("exposure k = ").nth(1))
            .map(|t| t.split(' ').next().unwrap().parse().unwrap())
            .collect();
        (k, stderr)
    };
    let (kept, stderr) = run(&[]);
    assert_eq!(kept.len(), 2, "{stderr}");
    assert_eq!(kept[0], kept[1], "{stderr}");
    assert!(stderr.contains("kept from the first frame"), "{stderr}");
    let (refit, stderr) = run(&["--refit-exposure"]);
    assert!((refit[1] / refit[0] - 2.0).abs() < 0.05, "{stderr}");
    // Each frame from its own pose: the sphere is elsewhere in the image.
    let a0 = exr_channel(&dir.path().join("c-0000.exr"), "A");
    let a1 = exr_channel(&dir.path().join("c-0001.exr"), "A");
    assert!(a0.iter().any(|&a| a > 0.5) && a1.iter().any(|&a| a > 0.5));
    assert_ne!(a0, a1);
    // A [[views]] entry naming frame 1's photo gives that frame its camera
    // (here frame 0's pose): the two mattes are then the same.
    let view =
        "[[views]]\ncamera = { position = [0, -4, 3], look_at = [0, 0, 0.3], up = [0, 0, 1], \
                vfov = 40, resolution = [48, 32] }\nphoto = { file = \"photo-0001.png\" }\n";
    std::fs::write(
        dir.path().join("video.toml"),
        format!(
            "{}\n{view}",
            with_path("[photo]\nfile = \"photo-{frame}.png\"\n")
        ),
    )
    .unwrap();
    run(&[]);
    let a0 = exr_channel(&dir.path().join("c-0000.exr"), "A");
    let a1 = exr_channel(&dir.path().join("c-0001.exr"), "A");
    assert_eq!(a0, a1);
    // Output names without {frame} are refused before any work.
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args(["composite", "video.toml", "--frames", "0..2", "-o", "c.exr"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("{frame}"),
        "{stderr}"
    );
    // Nor may a frame's output replace that frame's photo.
    let before = std::fs::read(dir.path().join("photo-0000.png")).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_plsr"))
        .current_dir(dir.path())
        .args([
            "composite",
            "video.toml",
            "--frames",
            "0..2",
            "-o",
            "c-{frame}.exr",
        ])
        .args(["--png", "photo-{frame}.png"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && stderr.contains("overwritten"),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(dir.path().join("photo-0000.png")).unwrap(),
        before
    );
}
