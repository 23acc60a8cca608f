//! The C ABI called from Rust, as a host calls it: scenes rendered from
//! two threads at once, progress callbacks and cancellation, the bracket
//! merge, render settings, the PLS builder's limits. (The C and C++ hosts
//! themselves, built against `libplsr.so` and an installed prefix, are
//! tested in the program's crate: `crates/cli/tests/it/c_hosts.rs`.)

use super::root;
use crate::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};

extern "C" fn count_progress(user: *mut std::ffi::c_void, done: u32, total: u32) -> bool {
    // SAFETY: `user` is the `Vec<(u32, u32)>` the test passes, used by one
    // call at a time (the API serialises progress calls).
    let seen = unsafe { &mut *(user as *mut Vec<(u32, u32)>) };
    seen.push((done, total));
    true
}

extern "C" fn cancel_at_once(_: *mut std::ffi::c_void, _: u32, _: u32) -> bool {
    false
}

#[test]
fn two_threads_render_two_scenes_at_once() {
    // Two scene files rendered concurrently through the C API, each equal to
    // its render alone.
    let dir = tempfile::tempdir().unwrap();
    let scenes =
        ["cornell/cornell.toml", "demo/demo.toml"].map(|s| root().join("assets/scenes").join(s));
    let render_one = |path: &Path| -> Vec<f32> {
        let c = CString::new(path.to_str().unwrap()).unwrap();
        let mut scene = std::ptr::null_mut();
        assert_eq!(plsr_scene_load(c.as_ptr(), &mut scene), PLSR_OK);
        let mut img = std::ptr::null_mut();
        assert_eq!(
            plsr_render(scene, 1, None, std::ptr::null_mut(), &mut img),
            PLSR_OK
        );
        let (mut w, mut h) = (0, 0);
        assert_eq!(plsr_image_size(img, &mut w, &mut h), PLSR_OK);
        let px = plsr_image_rgba(img);
        // SAFETY: the image holds w·h·4 floats until it is freed below.
        let v = unsafe { std::slice::from_raw_parts(px, (w * h * 4) as usize) }.to_vec();
        assert_eq!(plsr_image_free(img), PLSR_OK);
        assert_eq!(plsr_scene_free(scene), PLSR_OK);
        v
    };
    // Small versions of the two scenes, to keep the test quick.
    let small: Vec<PathBuf> = scenes
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let text = std::fs::read_to_string(s).unwrap();
            let base = s.parent().unwrap().display().to_string();
            let text = text
                .replace("file = \"", &format!("file = \"{base}/"))
                .replace("resolution = [", "resolution = [32, 24] # [");
            let p = dir.path().join(format!("scene{i}.toml"));
            std::fs::write(&p, format!("{text}\n")).unwrap();
            p
        })
        .collect();
    let alone: Vec<Vec<f32>> = small.iter().map(|p| render_one(p)).collect();
    let together: Vec<Vec<f32>> = std::thread::scope(|s| {
        let handles: Vec<_> = small.iter().map(|p| s.spawn(|| render_one(p))).collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert_eq!(alone, together);
}

#[test]
fn progress_callback_reports_every_tile_and_can_cancel() {
    let path = CString::new(
        root()
            .join("assets/scenes/cornell/cornell.toml")
            .to_str()
            .unwrap(),
    )
    .unwrap();
    let mut scene = std::ptr::null_mut();
    assert_eq!(plsr_scene_load(path.as_ptr(), &mut scene), PLSR_OK);
    let mut seen: Vec<(u32, u32)> = Vec::new();
    let mut img = std::ptr::null_mut();
    let user = &mut seen as *mut Vec<(u32, u32)> as *mut std::ffi::c_void;
    assert_eq!(
        plsr_render(scene, 2, Some(count_progress), user, &mut img),
        PLSR_OK
    );
    let total = seen[0].1;
    assert!(total > 1);
    let mut done: Vec<u32> = seen
        .iter()
        .map(|&(d, t)| {
            assert_eq!(t, total);
            d
        })
        .collect();
    done.sort_unstable();
    assert_eq!(done, (1..=total).collect::<Vec<_>>());
    assert_eq!(plsr_image_free(img), PLSR_OK);

    let mut img = std::ptr::null_mut();
    assert_eq!(
        plsr_render(
            scene,
            2,
            Some(cancel_at_once),
            std::ptr::null_mut(),
            &mut img
        ),
        PLSR_ERR_CANCELLED
    );
    assert!(img.is_null(), "no image on cancel");
    // SAFETY: plsr_last_error returns a NUL-terminated string owned by the library.
    let msg = unsafe { std::ffi::CStr::from_ptr(plsr_last_error()) }
        .to_string_lossy()
        .into_owned();
    assert!(msg.contains("cancelled"), "{msg}");
    assert_eq!(plsr_scene_free(scene), PLSR_OK);
}

#[test]
fn hdr_merge_through_the_api() {
    use plsr_hdr::synth::{write_brackets, BracketOptions, CameraModel, SyntheticScene};
    let dir = tempfile::tempdir().unwrap();
    let scene = SyntheticScene::new(48, 24);
    let times = [1.0 / 30.0, 1.0 / 8.0, 0.5, 2.0, 8.0];
    let paths = write_brackets(
        &scene,
        &CameraModel::default(),
        &times,
        dir.path(),
        &BracketOptions::default(),
    )
    .unwrap();
    let c: Vec<CString> = paths
        .iter()
        .map(|p| CString::new(p.to_str().unwrap()).unwrap())
        .collect();
    let ptrs: Vec<*const std::ffi::c_char> = c.iter().map(|s| s.as_ptr()).collect();
    let out = dir.path().join("pano.exr");
    let out_c = CString::new(out.to_str().unwrap()).unwrap();
    // Exposures from EXIF (NULL), Debevec.
    assert_eq!(
        plsr_hdr_merge(
            ptrs.as_ptr(),
            ptrs.len(),
            std::ptr::null(),
            0,
            out_c.as_ptr()
        ),
        PLSR_OK
    );
    let merged = plsr::film::Film::read_exr(&out).unwrap();
    assert_eq!((merged.width, merged.height), (48, 24));
    assert!(merged.color.iter().all(|c| c.is_finite()) && merged.mean_color().x > 0.0);
    // Errors: one bracket, bad response, wrong exposures, NULL.
    std::fs::remove_file(&out).unwrap();
    assert_eq!(
        plsr_hdr_merge(ptrs.as_ptr(), 1, std::ptr::null(), 0, out_c.as_ptr()),
        PLSR_ERR_INVALID_ARGUMENT
    );
    assert_eq!(
        plsr_hdr_merge(
            ptrs.as_ptr(),
            ptrs.len(),
            std::ptr::null(),
            9,
            out_c.as_ptr()
        ),
        PLSR_ERR_INVALID_ARGUMENT
    );
    let bad = [1.0f64, -1.0, 1.0, 1.0, 1.0];
    assert_eq!(
        plsr_hdr_merge(ptrs.as_ptr(), ptrs.len(), bad.as_ptr(), 0, out_c.as_ptr()),
        PLSR_ERR_INVALID_ARGUMENT
    );
    assert_eq!(
        plsr_hdr_merge(std::ptr::null(), 5, std::ptr::null(), 0, out_c.as_ptr()),
        PLSR_ERR_NULL_ARGUMENT
    );
    assert!(!out.exists(), "no output on failure");
}

#[test]
fn render_settings_change_without_rebuilding_the_scene() {
    use plsr::render::{render, RenderJob, RenderOptions};
    use plsr::scene::Scene;
    let file = root().join("tests/data/cornell-64.toml");
    let path = CString::new(file.to_str().unwrap()).unwrap();
    let mut scene = std::ptr::null_mut();
    assert_eq!(plsr_scene_load(path.as_ptr(), &mut scene), PLSR_OK);
    let settings = plsr_render_settings {
        spp: 2,
        max_depth: 3,
        seed: 7,
        sample_start: 4,
    };
    let mut img = std::ptr::null_mut();
    assert_eq!(
        plsr_render_with_settings(scene, &settings, 0, None, std::ptr::null_mut(), &mut img),
        PLSR_OK
    );
    let (mut w, mut h) = (0, 0);
    assert_eq!(plsr_image_size(img, &mut w, &mut h), PLSR_OK);
    // SAFETY: the image holds w·h·4 floats until it is freed below.
    let rgba =
        unsafe { std::slice::from_raw_parts(plsr_image_rgba(img), (w * h * 4) as usize) }.to_vec();
    assert_eq!(plsr_image_free(img), PLSR_OK);
    // The same job through the Rust API gives the same image.
    let rust_scene = Scene::load(&file).unwrap();
    let job = RenderJob {
        spp: 2,
        max_depth: 3,
        seed: 7,
        sample_start: 4,
        hide_virtual: false,
        ..Default::default()
    };
    let (film, _) = render(&rust_scene, &job, &RenderOptions::default(), &|_, _| true).unwrap();
    let want: Vec<f32> = film
        .color
        .iter()
        .zip(&film.alpha)
        .flat_map(|(c, a)| [c.x, c.y, c.z, *a])
        .collect();
    assert_eq!(rgba, want);
    // Bad settings are refused with the field's name; NULL settings too.
    for (bad, field) in [
        (plsr_render_settings { spp: 0, ..settings }, "spp"),
        (
            plsr_render_settings {
                max_depth: 0,
                ..settings
            },
            "max_depth",
        ),
        (
            plsr_render_settings {
                sample_start: u32::MAX,
                ..settings
            },
            "sample_start",
        ),
    ] {
        let mut img = std::ptr::null_mut();
        assert_eq!(
            plsr_render_with_settings(scene, &bad, 0, None, std::ptr::null_mut(), &mut img),
            PLSR_ERR_INVALID_ARGUMENT
        );
        assert!(img.is_null());
        // SAFETY: plsr_last_error returns a NUL-terminated string owned by the library.
        let msg = unsafe { std::ffi::CStr::from_ptr(plsr_last_error()) }.to_string_lossy();
        assert!(msg.contains(field), "{msg}");
    }
    let mut img = std::ptr::null_mut();
    assert_eq!(
        plsr_render_with_settings(
            scene,
            std::ptr::null(),
            0,
            None,
            std::ptr::null_mut(),
            &mut img
        ),
        PLSR_ERR_NULL_ARGUMENT
    );
    assert_eq!(plsr_scene_free(scene), PLSR_OK);
}

#[test]
fn builder_refuses_nf_beyond_the_range_of_the_command_line() {
    // `plsr pls check --nf` and the library refuse the same values
    // (crates/cli/tests/it/bad_options.rs).
    // The builder refuses 4e9 (it used to clamp), 0 is the default.
    let params = plsr_pls_params {
        n: [0.0, 0.0, -1.0],
        e1: [0.0, 0.0, 1.0],
        e2: [0.1, 0.0, 1.0],
        alpha1: 0.3,
        alpha2: 0.6,
        d: [0.05; 4],
        a_deg: 30.0,
        c: [1.0; 3],
        b: 1.0,
        brightness_is_radiance: 0,
    };
    let mut b = std::ptr::null_mut();
    assert_eq!(plsr_scene_builder_new(&mut b), PLSR_OK);
    assert_eq!(
        plsr_scene_builder_add_pls(b, &params, 4_000_000_000),
        PLSR_ERR_INVALID_ARGUMENT
    );
    // SAFETY: plsr_last_error returns a NUL-terminated string owned by the library.
    let msg = unsafe { std::ffi::CStr::from_ptr(plsr_last_error()) }.to_string_lossy();
    assert!(msg.contains("nf") && msg.contains("4096"), "{msg}");
    assert_eq!(plsr_scene_builder_add_pls(b, &params, 0), PLSR_OK);
    assert_eq!(plsr_scene_builder_add_pls(b, &params, 4096), PLSR_OK);
    assert_eq!(plsr_scene_builder_free(b), PLSR_OK);
}

/// An image's RGBA floats (copied).
fn rgba_of(img: *const plsr_image) -> Vec<f32> {
    let (mut w, mut h) = (0, 0);
    assert_eq!(plsr_image_size(img, &mut w, &mut h), PLSR_OK);
    // SAFETY: the image holds w·h·4 floats while it lives.
    unsafe { std::slice::from_raw_parts(plsr_image_rgba(img), (w * h * 4) as usize) }.to_vec()
}

#[test]
fn a_denoised_render_is_the_render_denoised_whatever_the_threads() {
    let file = root().join("tests/data/cornell-64.toml");
    let path = CString::new(file.to_str().unwrap()).unwrap();
    let mut scene = std::ptr::null_mut();
    assert_eq!(plsr_scene_load(path.as_ptr(), &mut scene), PLSR_OK);
    let settings = plsr_render_settings {
        spp: 4,
        max_depth: 5,
        seed: 3,
        sample_start: 0,
    };
    let null = std::ptr::null_mut();
    let none = std::ptr::null_mut::<plsr_image>;
    let (mut noisy, mut denoised, mut direct) = (none(), none(), none());
    assert_eq!(
        plsr_render_with_settings(scene, &settings, 0, None, null, &mut noisy),
        PLSR_OK
    );
    assert_eq!(plsr_image_denoise(noisy, 0, 1, &mut denoised), PLSR_OK);
    assert_eq!(
        plsr_render_denoised(scene, &settings, 0, 2, None, null, &mut direct),
        PLSR_OK
    );
    let (noisy_rgba, denoised_rgba) = (rgba_of(noisy), rgba_of(denoised));
    assert_eq!(denoised_rgba, rgba_of(direct));
    assert_ne!(denoised_rgba, noisy_rgba);
    // Coverage is the render's.
    let alpha = |v: &[f32]| v.iter().skip(3).step_by(4).copied().collect::<Vec<_>>();
    assert_eq!(alpha(&denoised_rgba), alpha(&noisy_rgba));
    // The host's buffers: colour alone, as OIDN takes it.
    let color: Vec<f32> = noisy_rgba
        .chunks_exact(4)
        .flat_map(|p| [p[0], p[1], p[2]])
        .collect();
    let mut out = vec![0.0f32; color.len()];
    assert_eq!(
        plsr_denoise(
            64,
            64,
            color.as_ptr(),
            std::ptr::null(),
            std::ptr::null(),
            std::ptr::null(),
            0,
            out.as_mut_ptr()
        ),
        PLSR_OK
    );
    let pixels: Vec<[f32; 3]> = color.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
    let want = plsr_denoise::denoise(
        plsr_denoise::Image {
            pixels: &pixels,
            width: 64,
            height: 64,
        },
        None,
        None,
        &plsr_denoise::Options {
            hdr: true,
            clean_aux: false,
            input_scale: None,
        },
    )
    .unwrap();
    assert_eq!(out, want.concat());
    // A part is denoised only once merged.
    let part = plsr_render_settings {
        sample_start: 4,
        ..settings
    };
    let mut refused = none();
    assert_eq!(
        plsr_render_denoised(scene, &part, 0, 0, None, null, &mut refused),
        PLSR_ERR_INVALID_ARGUMENT
    );
    assert!(refused.is_null());
    for img in [noisy, denoised, direct] {
        assert_eq!(plsr_image_free(img), PLSR_OK);
    }
    assert_eq!(plsr_scene_free(scene), PLSR_OK);
}
