//! The C ABI from real C and C++ hosts:
//! - a C program calls every function with NULL and invalid arguments;
//! - the C++ host of examples/cpp builds a scene with a PLS light, renders
//!   it, and its image equals the Rust API's render bit for bit;
//! - the C++ host runs clean under valgrind (no leaks, no invalid reads);
//! - two threads render two scenes through the API at the same time;
//! - `make install` installs what a pkg-config or CMake host needs.
//!
//! The shared library is built once, by a nested `cargo build --release
//! --lib` into `target/capi` (a separate target directory, since the outer
//! cargo holds the lock on `target`).

use glam::Vec3;
use plsr::capi::*;
use std::ffi::CString;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn capi_target() -> PathBuf {
    root().join("target").join("capi")
}

/// Builds libplsr.so once; returns its folder.
fn library() -> &'static Path {
    static LIB: OnceLock<PathBuf> = OnceLock::new();
    LIB.get_or_init(|| {
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let status = Command::new(cargo)
            .args(["build", "--release", "--lib", "--target-dir"])
            .arg(capi_target())
            .current_dir(root())
            .status()
            .expect("run cargo");
        assert!(status.success(), "building libplsr failed");
        let dir = capi_target().join("release");
        assert!(dir.join("libplsr.so").is_file() && dir.join("libplsr.a").is_file());
        dir
    })
}

/// Runs `cmd`, which must succeed. `cargo test` puts its own target folders
/// on `LD_LIBRARY_PATH`, which outranks the programs' rpath (a `RUNPATH`):
/// a host would load whatever `libplsr.so` the test profile left there,
/// not the library built above, so the variable is removed.
fn run(cmd: &mut Command) -> std::process::Output {
    cmd.env_remove("LD_LIBRARY_PATH");
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?} failed: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

#[test]
fn c_program_checks_every_error_path() {
    let lib = library();
    let dir = tempfile::tempdir().unwrap();
    let exe = dir.path().join("api_errors");
    run(Command::new("cc")
        .args([
            "-std=c99",
            "-Wall",
            "-Wextra",
            "-Werror",
            "-Wno-div-by-zero",
            "-o",
        ])
        .arg(&exe)
        .arg(root().join("tests/c/api_errors.c"))
        .arg(format!("-I{}", root().join("include").display()))
        .arg(format!("-L{}", lib.display()))
        .arg("-lplsr")
        .arg("-lm")
        .arg(format!("-Wl,-rpath,{}", lib.display())));
    let out = run(Command::new(&exe).arg(dir.path()));
    assert!(String::from_utf8_lossy(&out.stdout).contains("all C API error checks passed"));
}

/// Builds the C++ host into `dir`.
fn build_host(dir: &Path) -> PathBuf {
    let lib = library();
    run(Command::new("make")
        .arg("-C")
        .arg(root().join("examples/cpp"))
        .arg(format!("PLSR_LIBDIR={}", lib.display()))
        .arg(format!("BUILD_DIR={}", dir.display())));
    dir.join("host")
}

/// The host's scene (examples/cpp/host.cpp) through the Rust API.
fn host_scene_in_rust() -> plsr::scene::Scene {
    use plsr::bsdf::Bsdf;
    use plsr::camera::PinholeCamera;
    use plsr::job::RenderJob;
    use plsr::light::pls::{BrightnessMode, Pls, PlsGeometry};
    use plsr::scene::{pls_mesh, Material, Mesh, Scene, SceneDescription};
    let mesh = |id: u32, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>, material| {
        Mesh::new(format!("mesh {id}"), positions, triangles, material, id).unwrap()
    };
    let floor = mesh(
        0,
        vec![
            Vec3::new(-2.0, -2.0, 0.0),
            Vec3::new(2.0, -2.0, 0.0),
            Vec3::new(2.0, 2.0, 0.0),
            Vec3::new(-2.0, 2.0, 0.0),
        ],
        vec![[0, 1, 2], [0, 2, 3]],
        0,
    );
    let corners = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 != 0 { 0.25 } else { -0.25 },
                if i & 2 != 0 { 0.25 } else { -0.25 },
                if i & 4 != 0 { 0.5 } else { 0.0 },
            )
        })
        .collect();
    let tris = [
        0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6, 0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7, 0, 4, 2, 2, 4, 6,
        1, 3, 5, 3, 7, 5,
    ];
    let boxm = mesh(
        1,
        corners,
        tris.chunks(3).map(|c| [c[0], c[1], c[2]]).collect(),
        1,
    );
    let light = Pls {
        name: Some("params".into()),
        n: Vec3::new(0.0, 0.0, -1.0),
        g: PlsGeometry {
            e1: Vec3::new(-0.015, 0.0, 1.2),
            e2: Vec3::new(0.015, 0.0, 1.2),
            alpha1: 0.0,
            alpha2: 1.0,
            d: [0.0, 0.02, 0.02, 0.0],
        },
        a_deg: 30.0,
        penumbra_deg: 0.0,
        c: Vec3::new(1.0, 0.9, 0.7),
        b: 4.0,
    };
    let pls = pls_mesh(&light, BrightnessMode::Intensity, 16, 2, "pls 2".into());
    Scene::build(SceneDescription {
        meshes: vec![floor, boxm, pls],
        materials: vec![
            Material::new("floor", Bsdf::diffuse(Vec3::splat(0.7))),
            Material::new("box", Bsdf::diffuse(Vec3::new(0.2, 0.4, 0.8))),
            Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)),
        ],
        point_lights: vec![plsr::light::PointLight {
            position: Vec3::new(1.5, -1.5, 2.0),
            intensity: Vec3::splat(0.5),
        }],
        environment: None,
        camera: PinholeCamera::look_at(
            Vec3::new(0.0, -3.0, 1.5),
            Vec3::new(0.0, 0.0, 0.2),
            Vec3::Z,
            40.0,
            48,
            32,
        )
        .unwrap()
        .into(),
        film: Default::default(),
        job: RenderJob {
            spp: 8,
            max_depth: 6,
            seed: 42,
            sample_start: 0,
            hide_virtual: false,
            ..Default::default()
        },
        robust: false,
    })
    .unwrap()
}

fn read_rgba(path: &Path) -> Vec<u32> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .collect()
}

#[test]
fn cpp_host_image_equals_the_rust_render_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let host = build_host(dir.path());
    let prefix = dir.path().join("host-out");
    run(Command::new(&host).arg(&prefix).arg("2"));
    assert!(prefix.with_extension("exr").is_file() && prefix.with_extension("png").is_file());
    let from_host = read_rgba(&prefix.with_extension("rgba"));
    let scene = host_scene_in_rust();
    let (film, _) = plsr::render::render(
        &scene,
        &scene.default_job(),
        &Default::default(),
        &|_, _| true,
    )
    .unwrap();
    let from_rust: Vec<u32> = film
        .color
        .iter()
        .zip(&film.alpha)
        .flat_map(|(c, a)| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits(), a.to_bits()])
        .collect();
    assert_eq!(from_host.len(), 48 * 32 * 4);
    assert!(from_rust.iter().any(|&b| b != 0), "the render is black");
    let differ: Vec<usize> = (0..from_rust.len())
        .filter(|&i| from_host[i] != from_rust[i])
        .collect();
    assert!(
        differ.is_empty(),
        "the C++ host's image differs from the Rust render in {} of {} values; the first at \
         pixel {} channel {}: {} against {}",
        differ.len(),
        from_rust.len(),
        differ[0] / 4,
        differ[0] % 4,
        f32::from_bits(from_host[differ[0]]),
        f32::from_bits(from_rust[differ[0]])
    );
}

#[test]
fn cpp_host_is_clean_under_valgrind() {
    if Command::new("valgrind").arg("--version").output().is_err() {
        eprintln!("valgrind is not installed: skipped (apt-get install valgrind)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let host = build_host(dir.path());
    let out = Command::new("valgrind")
        .env_remove("LD_LIBRARY_PATH")
        .args([
            "--error-exitcode=42",
            "--leak-check=full",
            "--errors-for-leak-kinds=definite",
            "--show-leak-kinds=definite",
        ])
        .arg(&host)
        .arg(dir.path().join("vg"))
        .arg("1")
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(0), "valgrind found errors:\n{log}");
    assert!(log.contains("ERROR SUMMARY: 0 errors"), "{log}");
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
fn make_install_serves_pkg_config_and_cmake_hosts() {
    library(); // builds target/capi/release, which `make install` reuses
    let prefix = tempfile::tempdir().unwrap();
    run(Command::new("make")
        .arg("-C")
        .arg(root())
        .arg("install")
        .arg(format!("PREFIX={}", prefix.path().display()))
        .arg(format!("CARGO_TARGET_DIR={}", capi_target().display())));
    let p = prefix.path();
    for f in [
        "lib/libplsr.so",
        "lib/libplsr.a",
        "include/plsr.h",
        "include/plsr.hpp",
        "lib/pkgconfig/plsr.pc",
        "lib/cmake/plsr/plsrConfig.cmake",
    ] {
        assert!(p.join(f).is_file(), "{f} not installed");
    }
    // The library is only the library: none of the program's crates (clap,
    // indicatif) is linked into it, and the installed copy has no debug info.
    let so = p.join("lib/libplsr.so");
    let symbols = run(Command::new("nm").arg(&so)).stdout;
    let symbols = String::from_utf8_lossy(&symbols);
    assert!(symbols.contains("plsr_render"), "nm lists no plsr symbols");
    for program_crate in ["clap", "indicatif"] {
        assert!(
            !symbols.contains(program_crate),
            "libplsr.so carries {program_crate} symbols"
        );
    }
    let sections = run(Command::new("readelf").arg("-S").arg(&so)).stdout;
    assert!(
        !String::from_utf8_lossy(&sections).contains(".debug_info"),
        "the installed libplsr.so has debug info"
    );
    // A pkg-config host builds and runs against the installed files.
    let build = tempfile::tempdir().unwrap();
    run(Command::new("make")
        .arg("-C")
        .arg(root().join("examples/cpp"))
        .arg("USE_PKG_CONFIG=1")
        .arg(format!("BUILD_DIR={}", build.path().display()))
        .env("PKG_CONFIG_PATH", p.join("lib/pkgconfig")));
    run(Command::new(build.path().join("host"))
        .arg(build.path().join("out"))
        .arg("1"));
    // And a CMake host, through the installed package file.
    if Command::new("cmake").arg("--version").output().is_err() {
        eprintln!("cmake is not installed: CMake host skipped (apt-get install cmake)");
        return;
    }
    let cmake_build = build.path().join("cmake");
    run(Command::new("cmake")
        .arg("-S")
        .arg(root().join("examples/cpp"))
        .arg("-B")
        .arg(&cmake_build)
        .arg(format!("-DCMAKE_PREFIX_PATH={}", p.display())));
    run(Command::new("cmake").arg("--build").arg(&cmake_build));
    run(Command::new(cmake_build.join("host"))
        .arg(build.path().join("out-cmake"))
        .arg("1"));
}

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
    use plsr::hdr::synth::{write_brackets, BracketOptions, CameraModel, SyntheticScene};
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
