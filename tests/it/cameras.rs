//! Cameras and film controls (issue 4, items 5–9): every camera projects a
//! known point to the expected pixel and its ray through that pixel's centre
//! passes through the point; the thin lens focuses; the equirectangular and
//! dual-fisheye mappings round-trip; matrix poses equal look-at poses; the
//! paper's Table 1 preset; scene-file errors; the Gaussian pixel filter's
//! sampling (chi-square) and determinism; exposure and white balance.

use plsr_testkit as common;

use common::chi2::{chi2_from_counts, regularized_gamma_p};
use glam::{Vec2, Vec3};
use plsr::camera::{Camera, Pose, PAPER_TABLE1};
use plsr::color::{planckian_xy, white_balance_matrix, xy_to_xyz, xyz_to_rec709};
use plsr::equirect::{equirect_direction, equirect_uv, SphereFrame};
use plsr::film::Film;
use plsr::filter::{GaussianFilter, PixelFilter, TentFilter};
use plsr::render::{render, RenderOptions};
use plsr::rng::Rng;
use plsr::scene::file::load;
use plsr::scene::{Scene, SceneDescription};
use std::path::Path;

/// Loads a scene file written from `text` into a fresh folder as `scene.toml`.
fn load_text(text: &str) -> plsr::Result<SceneDescription> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    load(&path)
}

fn camera_of(camera_table: &str) -> Camera {
    load_text(camera_table).unwrap().camera
}

fn error_of(text: &str) -> String {
    match load_text(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

/// Distance from `p` to the ray's line, relative to the distance to `p`.
fn miss_distance(ray: &plsr::accel::Ray, p: Vec3) -> f32 {
    let d = ray.dir.normalize();
    let v = p - ray.org;
    let along = v.dot(d);
    assert!(along > 0.0, "the point is behind the ray");
    (v - along * d).length() / v.length()
}

fn assert_ray_through(camera: &Camera, film: Vec2, p: Vec3) {
    let ray = camera.generate_ray(film, Vec2::splat(0.5)).expect("a ray");
    let m = miss_distance(&ray, p);
    assert!(m < 1e-4, "{} ray misses {p} by {m}", camera.type_name());
}

// Z-up, metres: camera at (1, −2, 1.5) looking along +y.
const POSE: &str = "position = [1, -2, 1.5]\nlook_at = [1, 0, 1.5]\nup = [0, 0, 1]\n";

#[test]
fn pinhole_projects_a_known_point_to_its_pixel() {
    // vfov 90° (tan = 1), 40×30 (aspect 4/3). Pixel (27, 11)'s centre
    // (27.5, 11.5) is at x-offset (2·27.5/40 − 1)·4/3 = 0.5 and y-offset
    // 1 − 2·11.5/30 = 7/30 at unit depth: 2 m ahead that is the point below.
    let cam = camera_of(&format!(
        "[camera]\n{POSE}vfov = 90\nresolution = [40, 30]\n"
    ));
    let p = Vec3::new(1.0 + 1.0, -2.0 + 2.0, 1.5 + 2.0 * 7.0 / 30.0);
    let film = cam.project(p).unwrap();
    assert!((film - Vec2::new(27.5, 11.5)).length() < 1e-4, "{film}");
    assert_eq!((film.x as u32, film.y as u32), (27, 11));
    assert_ray_through(&cam, Vec2::new(27.5, 11.5), p);
    // Behind the camera: no projection.
    assert!(cam.project(Vec3::new(1.0, -3.0, 1.5)).is_none());
}

#[test]
fn horizontal_fov_and_focal_length_give_the_same_camera_as_vfov() {
    // 40×30 with vfov 90°: hfov = 2·atan(4/3) = 106.26°; 12 mm on a 24 mm
    // high sensor is also 90°.
    let a = camera_of(&format!(
        "[camera]\n{POSE}vfov = 90\nresolution = [40, 30]\n"
    ));
    let b = camera_of(&format!(
        "[camera]\n{POSE}hfov = {}\nresolution = [40, 30]\n",
        2.0 * (4.0f64 / 3.0).atan().to_degrees()
    ));
    let c = camera_of(&format!(
        "[camera]\n{POSE}focal_length = 12\nresolution = [40, 30]\n"
    ));
    let d = camera_of(&format!(
        "[camera]\n{POSE}focal_length = 12\nsensor_width = 32\nresolution = [40, 30]\n"
    ));
    for other in [&b, &c, &d] {
        for film in [Vec2::new(0.0, 0.0), Vec2::new(31.2, 7.9)] {
            let (r1, r2) = (
                a.generate_ray(film, Vec2::ZERO).unwrap(),
                other.generate_ray(film, Vec2::ZERO).unwrap(),
            );
            assert!((r1.dir - r2.dir).length() < 1e-5);
        }
    }
}

#[test]
fn zoom_narrows_the_field_of_view() {
    // zoom 2 at vfov 90° is vfov 2·atan(1/2): the point at the top edge of the
    // zoomed image is at height 0.5 at unit depth.
    let cam = camera_of(&format!(
        "[camera]\n{POSE}vfov = 90\nzoom = 2\nresolution = [30, 30]\n"
    ));
    let film = cam.project(Vec3::new(1.0, 0.0, 1.5 + 1.0)).unwrap();
    assert!((film - Vec2::new(15.0, 0.0)).length() < 1e-4, "{film}");
}

#[test]
fn thin_lens_projects_like_a_pinhole_and_focuses_on_the_focus_plane() {
    let cam = camera_of(&format!(
        "[camera]\ntype = \"thin_lens\"\n{POSE}vfov = 90\nresolution = [40, 30]\n\
         aperture_radius = 0.05\nfocus_distance = 2\n"
    ));
    assert!(cam.needs_lens_sample());
    // The same point as the pinhole test, on the focus plane (depth 2).
    let p = Vec3::new(2.0, 0.0, 1.5 + 2.0 * 7.0 / 30.0);
    let film = cam.project(p).unwrap();
    assert!((film - Vec2::new(27.5, 11.5)).length() < 1e-4, "{film}");
    let mut origins = Vec::new();
    for lens in [
        Vec2::new(0.5, 0.5),
        Vec2::new(0.0, 0.0),
        Vec2::new(0.99, 0.1),
        Vec2::new(0.3, 0.95),
    ] {
        let ray = cam.generate_ray(film, lens).unwrap();
        let m = miss_distance(&ray, p);
        assert!(m < 1e-4, "lens {lens}: misses by {m}");
        // Origins lie on the aperture disk, in the lens plane.
        let o = ray.org - Vec3::new(1.0, -2.0, 1.5);
        assert!(o.length() <= 0.05 + 1e-6 && o.y.abs() < 1e-6);
        origins.push(ray.org);
    }
    assert!(
        (origins[1] - origins[2]).length() > 0.05,
        "the aperture is used"
    );
    // Out of focus: a point at depth 4 on the same pixel's pinhole ray is
    // missed by rays through the lens edge.
    let q = Vec3::new(1.0, -2.0, 1.5) + 2.0 * (p - Vec3::new(1.0, -2.0, 1.5));
    let ray = cam.generate_ray(film, Vec2::new(0.0, 0.5)).unwrap();
    assert!(miss_distance(&ray, q) > 1e-3);
    // focus_distance defaults to the distance to look_at.
    let d = camera_of(&format!(
        "[camera]\ntype = \"thin_lens\"\n{POSE}vfov = 90\nresolution = [4, 4]\naperture_radius = 0.1\n"
    ));
    let Camera::ThinLens(t) = d else { panic!() };
    assert!((t.focus_distance - 2.0).abs() < 1e-6);
}

#[test]
fn equirect_convention_round_trips() {
    let frame = SphereFrame::new(Vec3::Z, Vec3::new(1.0, 1.0, 0.0)).unwrap();
    for i in 0..48 {
        for j in 1..24 {
            let uv = Vec2::new((i as f32 + 0.25) / 48.0, j as f32 / 24.0);
            let back = equirect_uv(equirect_direction(uv, &frame), &frame);
            assert!((back - uv).length() < 1e-5, "{uv} -> {back}");
        }
    }
}

#[test]
fn equirect_camera_projects_known_points_and_matches_the_convention() {
    // 66×33: azimuth +90° (u = ¾) is column 49.5, the horizon row 16.5: the
    // centre of pixel (49, 16).
    let cam = camera_of(&format!(
        "[camera]\ntype = \"equirectangular\"\n{POSE}resolution = [66, 33]\n"
    ));
    let o = Vec3::new(1.0, -2.0, 1.5);
    let right = o + Vec3::new(3.0, 0.0, 0.0);
    let film = cam.project(right).unwrap();
    assert!((film - Vec2::new(49.5, 16.5)).length() < 1e-4, "{film}");
    assert_ray_through(&cam, Vec2::new(49.5, 16.5), right);
    // Forward is the centre column, left is u = ¼, up is the top row.
    let f = cam.project(o + Vec3::Y).unwrap();
    assert!((f - Vec2::new(33.0, 16.5)).length() < 1e-4, "{f}");
    let l = cam.project(o - Vec3::X).unwrap();
    assert!((l - Vec2::new(16.5, 16.5)).length() < 1e-4, "{l}");
    let u = cam.project(o + Vec3::new(0.0, 0.1, 5.0)).unwrap();
    assert!(u.y < 0.5, "{u}");
    // Every pixel's ray is equirect_direction of that pixel's uv.
    let frame = SphereFrame::new(Vec3::Z, Vec3::Y).unwrap();
    for (x, y) in [(0, 0), (10, 3), (33, 16), (65, 32), (49, 16)] {
        let film = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
        let uv = film / Vec2::new(66.0, 33.0);
        let ray = cam.generate_ray(film, Vec2::ZERO).unwrap();
        assert!((ray.dir - equirect_direction(uv, &frame)).length() < 1e-5);
        assert!((ray.org - o).length() < 1e-6);
    }
}

#[test]
fn dual_fisheye_projects_known_points_and_round_trips() {
    // 66×33 with 180° lenses: circles of radius 16.5 around (16.5, 16.5)
    // (front) and (49.5, 16.5) (back); 90° off-axis is the rim.
    let cam = camera_of(&format!(
        "[camera]\ntype = \"dual_fisheye\"\n{POSE}fov = 180\nresolution = [66, 33]\n"
    ));
    let o = Vec3::new(1.0, -2.0, 1.5);
    let deg = |a: f32| a.to_radians();
    // 60° above the front axis: 11 px above the front centre, pixel (16, 5).
    let up60 = o + 2.0 * Vec3::new(0.0, deg(60.0).cos(), deg(60.0).sin());
    let film = cam.project(up60).unwrap();
    assert!((film - Vec2::new(16.5, 5.5)).length() < 1e-4, "{film}");
    assert_ray_through(&cam, Vec2::new(16.5, 5.5), up60);
    // 60° from the back axis towards world right: the back lens sees world
    // right on its left, 11 px left of the back centre, pixel (38, 16).
    let back_right = o + 3.0 * Vec3::new(deg(60.0).sin(), -deg(60.0).cos(), 0.0);
    let film = cam.project(back_right).unwrap();
    assert!((film - Vec2::new(38.5, 16.5)).length() < 1e-4, "{film}");
    assert_ray_through(&cam, Vec2::new(38.5, 16.5), back_right);
    // Straight ahead and straight behind are the circle centres.
    let f = cam.project(o + Vec3::Y).unwrap();
    let b = cam.project(o - Vec3::Y).unwrap();
    assert!((f - Vec2::new(16.5, 16.5)).length() < 1e-4);
    assert!((b - Vec2::new(49.5, 16.5)).length() < 1e-4);
    // Outside both circles: no ray.
    assert!(cam.generate_ray(Vec2::new(0.5, 0.5), Vec2::ZERO).is_none());
    assert!(cam.generate_ray(Vec2::new(33.0, 1.0), Vec2::ZERO).is_none());

    // Round trip direction → film → direction over the whole sphere, with
    // overlapping 200° lenses.
    let cam = camera_of(&format!(
        "[camera]\ntype = \"dual_fisheye\"\n{POSE}fov = 200\nresolution = [128, 64]\n"
    ));
    let Camera::DualFisheye(fe) = &cam else {
        panic!()
    };
    let mut rng = Rng::new(5, 5);
    for _ in 0..2000 {
        let d = plsr::warp::square_to_uniform_sphere(rng.next_2d());
        let film = fe.project_direction(d).unwrap();
        let back = fe.film_direction(film).expect("inside a circle");
        assert!((back - d).length() < 1e-4, "{d} -> {film} -> {back}");
    }
}

#[test]
fn matrix_pose_equals_the_look_at_pose() {
    // OpenCV camera-to-world: columns right (+x), down (−z), forward (+y),
    // position (1, −2, 1.5).
    let matrix =
        "to_world = [\n  [1, 0, 0, 1],\n  [0, 0, 1, -2],\n  [0, -1, 0, 1.5],\n  [0, 0, 0, 1],\n]\n";
    for kind in ["pinhole", "equirectangular", "dual_fisheye"] {
        let fov = if kind == "pinhole" { "vfov = 50\n" } else { "" };
        let a = camera_of(&format!(
            "[camera]\ntype = \"{kind}\"\n{POSE}{fov}resolution = [32, 16]\n"
        ));
        let b = camera_of(&format!(
            "[camera]\ntype = \"{kind}\"\n{matrix}{fov}resolution = [32, 16]\n"
        ));
        for film in [
            Vec2::new(8.5, 8.5),
            Vec2::new(3.2, 12.9),
            Vec2::new(20.0, 4.0),
        ] {
            let (ra, rb) = (
                a.generate_ray(film, Vec2::ZERO),
                b.generate_ray(film, Vec2::ZERO),
            );
            assert_eq!(ra.is_some(), rb.is_some());
            if let (Some(ra), Some(rb)) = (ra, rb) {
                assert!((ra.dir - rb.dir).length() < 1e-6, "{kind}");
                assert!((ra.org - rb.org).length() < 1e-6, "{kind}");
            }
        }
    }
    // And Pose::to_matrix writes the same matrix.
    let pose = Pose::look_at(Vec3::new(1.0, -2.0, 1.5), Vec3::new(1.0, 0.0, 1.5), Vec3::Z).unwrap();
    let m = pose.to_matrix();
    let want = [
        [1.0, 0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0, -2.0],
        [0.0, -1.0, 0.0, 1.5],
        [0.0, 0.0, 0.0, 1.0],
    ];
    for r in 0..4 {
        for c in 0..4 {
            assert!((m[r][c] - want[r][c]).abs() < 1e-6, "{m:?}");
        }
    }
}

#[test]
fn paper_table1_preset() {
    let desc = load_text(&format!("[camera]\npreset = \"paper-table1\"\n{POSE}")).unwrap();
    let Camera::Pinhole(c) = &desc.camera else {
        panic!("the preset is a pinhole camera")
    };
    assert_eq!((c.width, c.height), (4000, 3000));
    assert!((c.vfov_deg() - 43.6).abs() < 1e-3, "{}", c.vfov_deg());
    // 50 mm on the implied 40 mm sensor is the same field of view.
    assert!((plsr::camera::fov_from_focal_length(50.0, 40.0) - 43.6).abs() < 0.02);
    assert_eq!(PAPER_TABLE1.shutter_s, 0.25);
    assert_eq!(PAPER_TABLE1.iso, 400.0);
    assert_eq!(desc.film.white_balance_k, Some(4400.0));
    // Camera 7: zoom 1.8, and a smaller resolution for previews.
    let desc = load_text(&format!(
        "[camera]\npreset = \"paper-table1\"\nzoom = 1.8\nresolution = [400, 300]\n{POSE}\n\
         [film]\nf_number = 4\n"
    ))
    .unwrap();
    let Camera::Pinhole(c) = &desc.camera else {
        panic!()
    };
    assert_eq!((c.width, c.height), (400, 300));
    let want = 2.0 * ((21.8f32).to_radians().tan() / 1.8).atan().to_degrees();
    assert!((c.vfov_deg() - want).abs() < 1e-3, "{}", c.vfov_deg());
    // With an f-number, shutter and ISO come from the preset: 0.25·400/(100·16).
    let e = desc.film.camera_exposure.unwrap();
    assert_eq!((e.shutter_s, e.iso, e.f_number), (0.25, 400.0, 4.0));
    assert_eq!(desc.film.exposure_scale(), 0.0625);
}

#[test]
fn bad_camera_and_film_input_names_the_field() {
    let cases: &[(&str, &str, &str)] = &[
        (
            "[camera]\nto_world = [[2, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]\nvfov = 40\nresolution = [8, 8]\n",
            "scene.toml: camera.to_world:",
            "rigid",
        ),
        (
            "[camera]\nto_world = [[1, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 0, 1]]\nvfov = 40\nresolution = [8, 8]\n",
            "scene.toml: camera.to_world:",
            "determinant",
        ),
        (
            "[camera]\nto_world = [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 1, 1]]\nvfov = 40\nresolution = [8, 8]\n",
            "scene.toml: camera.to_world:",
            "last row",
        ),
        (
            &format!("[camera]\nto_world = [[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]]\n{POSE}vfov = 40\nresolution = [8, 8]\n"),
            "scene.toml: camera.position:",
            "not both",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nzoom = 0\nresolution = [8, 8]\n"),
            "scene.toml: camera.zoom:",
            "positive",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nzoom = -2\nresolution = [8, 8]\n"),
            "scene.toml: camera.zoom:",
            "positive",
        ),
        (
            &format!("[camera]\ntype = \"fisheye\"\n{POSE}resolution = [8, 8]\n"),
            "scene.toml: camera.type:",
            "unknown camera type `fisheye`",
        ),
        (
            &format!("[camera]\ntype = \"dual_fisheye\"\nfov = 170\n{POSE}resolution = [8, 4]\n"),
            "scene.toml: camera.fov:",
            "[180, 360)",
        ),
        (
            &format!("[camera]\ntype = \"dual_fisheye\"\nfov = 360\n{POSE}resolution = [8, 4]\n"),
            "scene.toml: camera.fov:",
            "[180, 360)",
        ),
        (
            &format!("[camera]\ntype = \"equirectangular\"\nvfov = 40\n{POSE}resolution = [8, 4]\n"),
            "scene.toml: camera.vfov:",
            "not used by cameras of type `equirectangular`",
        ),
        (
            &format!("[camera]\ntype = \"thin_lens\"\n{POSE}vfov = 40\nresolution = [8, 8]\n"),
            "scene.toml: camera.aperture_radius:",
            "required",
        ),
        (
            &format!("[camera]\ntype = \"thin_lens\"\n{POSE}vfov = 40\naperture_radius = -1\nresolution = [8, 8]\n"),
            "scene.toml: camera.aperture_radius:",
            "≥ 0",
        ),
        (
            &format!("[camera]\npreset = \"paper-table2\"\n{POSE}"),
            "scene.toml: camera.preset:",
            "paper-table1",
        ),
        (
            &format!("[camera]\npreset = \"paper-table1\"\nvfov = 30\n{POSE}"),
            "scene.toml: camera.vfov:",
            "preset",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nhfov = 50\nresolution = [8, 8]\n"),
            "scene.toml: camera.hfov:",
            "only one",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\n"),
            "scene.toml: camera.resolution:",
            "required",
        ),
        (
            "[camera]\nposition = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 40\nresolution = [8, 8]\n",
            "scene.toml: camera.look_at:",
            "required",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nfilter = \"mitchell\"\n"),
            "scene.toml: film.filter:",
            "unknown filter `mitchell`",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nfilter_sigma = 0.5\n"),
            "scene.toml: film.filter_sigma:",
            "gaussian",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nfilter = \"gaussian\"\nfilter_sigma = 0\n"),
            "scene.toml: film.filter_sigma:",
            "positive",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nshutter = 0.25\niso = 400\n"),
            "scene.toml: film.f_number:",
            "required",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nf_number = 4\niso = 400\n"),
            "scene.toml: film.shutter:",
            "required",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nwhite_balance = 1000\n"),
            "scene.toml: film.white_balance:",
            "between 1667 and 25000",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\nexposure_ev = nan\n"),
            "scene.toml: film.exposure_ev:",
            "finite",
        ),
        (
            &format!("[camera]\n{POSE}vfov = 40\nresolution = [8, 8]\n[film]\ngain = 2\n"),
            "scene.toml: film.gain:",
            "unknown field",
        ),
    ];
    for (text, field, words) in cases {
        let e = error_of(text);
        assert!(e.contains(field), "expected `{field}` in: {e}");
        assert!(e.contains(words), "expected `{words}` in: {e}");
    }
}

/// Pearson's test of a filter's sample positions against its density
/// `weight(offset)` per axis, integrated numerically (independently of the
/// inverse distribution functions the sampler uses) over a grid of cells;
/// clipped at the film's border (`filter_border = "clip"`), a pixel near an
/// edge samples the filter restricted to the film.
fn check_filter_sampling(
    filter: PixelFilter,
    weight: &dyn Fn(f64) -> f64,
    seed: u64,
    pixel: [u32; 2],
    size: [u32; 2],
    trials: usize,
) {
    const N: usize = 400_000;
    const BINS: usize = 23;
    let (radius, clip) = (filter.radius(), filter.clips_at_border());
    // The interval of offsets from the pixel centre along each axis.
    let interval = |axis: usize| {
        let c = pixel[axis] as f64 + 0.5;
        let r = radius as f64;
        if clip {
            ((-c).max(-r), (size[axis] as f64 - c).min(r))
        } else {
            (-r, r)
        }
    };
    let (ix, iy) = (interval(0), interval(1));
    let mut observed = vec![0.0f64; BINS * BINS];
    let mut rng = Rng::new(seed, 9);
    let cell = |x: f32, (lo, hi): (f64, f64)| {
        (((x as f64 - lo) / (hi - lo) * BINS as f64) as usize).min(BINS - 1)
    };
    for _ in 0..N {
        let o = filter.sample(rng.next_2d(), pixel, [0, 0, size[0], size[1]]) - Vec2::splat(0.5);
        assert!(o.abs().max_element() <= radius, "{o}");
        for (v, (lo, hi)) in [(o.x, ix), (o.y, iy)] {
            assert!(
                v as f64 >= lo - 1e-6 && v as f64 <= hi + 1e-6,
                "{o} off the film"
            );
        }
        observed[cell(o.y, iy) * BINS + cell(o.x, ix)] += 1.0;
    }
    // 1D cell masses of the weight on the interval by the midpoint rule.
    let masses = |(lo, hi): (f64, f64)| {
        let sub = 200;
        let width = (hi - lo) / BINS as f64;
        let mut mass = [0.0f64; BINS];
        for (i, m) in mass.iter_mut().enumerate() {
            for k in 0..sub {
                *m += weight(lo + width * (i as f64 + (k as f64 + 0.5) / sub as f64));
            }
        }
        let total: f64 = mass.iter().sum();
        mass.map(|m| m / total)
    };
    let (mx, my) = (masses(ix), masses(iy));
    let mut expected = vec![0.0f64; BINS * BINS];
    for j in 0..BINS {
        for i in 0..BINS {
            expected[j * BINS + i] = N as f64 * my[j] * mx[i];
        }
    }
    let (chi2, dof) = chi2_from_counts(&observed, &expected, 5.0);
    let p = 1.0 - regularized_gamma_p(dof as f64 / 2.0, chi2 / 2.0);
    assert!(
        p > 0.01 / trials as f64,
        "{filter:?} at {pixel:?}: chi2 = {chi2:.1}, dof = {dof}, p = {p:.2e}"
    );
}

/// The Gaussian filter's samples follow the truncated Gaussian.
#[test]
fn gaussian_filter_sampling_matches_its_density() {
    // σ, radius, seed, clipped, pixel, film size.
    let cases = [
        (0.5f32, 1.5f32, 1u64, false, [0u32, 0u32], [1u32, 1u32]),
        (1.0, 1.6, 2, false, [0, 0], [1, 1]),
        (0.3, 2.0, 3, false, [0, 0], [1, 1]),
        // A corner pixel and one a pixel in from the right edge.
        (0.5, 2.0, 4, true, [0, 0], [32, 24]),
        (1.0, 2.5, 5, true, [30, 1], [32, 3]),
        // Far from the edges, clipping changes nothing.
        (0.5, 2.0, 6, true, [10, 10], [32, 24]),
    ];
    for (sigma, radius, seed, clip, pixel, size) in cases {
        let g = GaussianFilter::new(sigma, radius)
            .unwrap()
            .clipped_at_border(clip);
        let s = sigma as f64;
        let weight = move |x: f64| (-x * x / (2.0 * s * s)).exp();
        check_filter_sampling(
            PixelFilter::Gaussian(g),
            &weight,
            seed,
            pixel,
            size,
            cases.len(),
        );
    }
}

/// The tent filter's samples follow `max(0, 1 − |t|/radius)` on each axis,
/// whole or clipped at the film's border.
#[test]
fn tent_filter_sampling_matches_its_density() {
    // radius, seed, clipped, pixel, film size.
    let cases = [
        (1.0f32, 11u64, false, [0u32, 0u32], [1u32, 1u32]),
        (2.5, 12, false, [0, 0], [1, 1]),
        (1.0, 13, true, [0, 0], [32, 24]),
        (2.0, 14, true, [31, 1], [32, 3]),
        (1.5, 15, true, [10, 10], [32, 24]),
    ];
    for (radius, seed, clip, pixel, size) in cases {
        let t = TentFilter::new(radius).unwrap().clipped_at_border(clip);
        let r = radius as f64;
        let weight = move |x: f64| (1.0 - x.abs() / r).max(0.0);
        check_filter_sampling(
            PixelFilter::Tent(t),
            &weight,
            seed,
            pixel,
            size,
            cases.len(),
        );
    }
}

fn cornell(spp: u32) -> Scene {
    let mut desc = load(Path::new("tests/data/cornell-64.toml")).unwrap();
    desc.job.spp = spp;
    desc.camera = desc.camera.with_resolution(24, 24).unwrap();
    Scene::build(desc).unwrap()
}

fn render_with(scene: &Scene, threads: usize) -> Film {
    let o = RenderOptions {
        threads: Some(threads),
        tile_size: 8,
        ..Default::default()
    };
    render(scene, &scene.default_job(), &o, &|_, _| true)
        .unwrap()
        .0
}

fn bits(f: &Film) -> Vec<u32> {
    f.color
        .iter()
        .chain(&f.variance)
        .chain(&f.normal)
        .flat_map(|v| v.to_array())
        .chain(f.alpha.iter().copied())
        .chain(f.depth.iter().copied())
        .map(f32::to_bits)
        .collect()
}

#[test]
fn gaussian_filter_and_thin_lens_renders_are_identical_for_one_and_two_threads() {
    let mut scene = cornell(4);
    let box_image = render_with(&scene, 2);
    scene.film_mut().filter = PixelFilter::Gaussian(GaussianFilter::new(0.5, 1.5).unwrap());
    let a = render_with(&scene, 1);
    let b = render_with(&scene, 2);
    assert_eq!(bits(&a), bits(&b), "Gaussian filter: 1 vs 2 threads");
    assert_ne!(a.color, box_image.color, "the filter changes the image");
    assert!(a.mean_color().x > 0.01);
    // A thin lens draws lens samples from the same per-sample streams.
    let Camera::Pinhole(p) = scene.camera() else {
        panic!()
    };
    let lens = plsr::camera::ThinLensCamera::new(p.clone(), 20.0, 800.0).unwrap();
    scene.set_camera(Camera::ThinLens(lens));
    let c = render_with(&scene, 1);
    let d = render_with(&scene, 2);
    assert_eq!(bits(&c), bits(&d), "thin lens: 1 vs 2 threads");
    assert_ne!(c.color, a.color);
}

#[test]
fn one_more_stop_doubles_the_written_values_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let mut scene = cornell(2);
    let write = |scene: &Scene, name: &str| -> Film {
        let film = render_with(scene, 2);
        let path = dir.path().join(name);
        film.write_exr(&path).unwrap();
        Film::read_exr(&path).unwrap()
    };
    let a = write(&scene, "a.exr");
    scene.film_mut().exposure_ev = 1.0;
    let b = write(&scene, "b.exr");
    assert_eq!(
        b.settings.exposure_ev, 1.0,
        "the EXR header keeps the setting"
    );
    assert!(a.mean_color().x > 0.01);
    for (x, y) in a.color.iter().zip(&b.color) {
        assert_eq!(*y, *x * 2.0);
    }
    for (x, y) in a.variance.iter().zip(&b.variance) {
        assert_eq!(*y, *x * 4.0);
    }
    // Geometry layers are untouched.
    assert_eq!(a.depth, b.depth);
    assert_eq!(a.alpha, b.alpha);
}

#[test]
fn white_balance_is_identity_at_d65_and_neutralises_its_temperature() {
    let m = white_balance_matrix(6504.0);
    let err = (m - glam::Mat3::IDENTITY)
        .to_cols_array()
        .iter()
        .fold(0.0f32, |a, x| a.max(x.abs()));
    assert!(err < 1e-3, "{m}");
    let white = xyz_to_rec709(xy_to_xyz(planckian_xy(4400.0))).as_vec3();
    let out = white_balance_matrix(4400.0) * white;
    let n = out / out.y;
    assert!((n - Vec3::ONE).abs().max_element() < 1e-2, "{n}");
    // Unbalanced, that white is visibly warm.
    let raw = white / white.y;
    assert!(raw.x - raw.z > 0.2, "{raw}");
}

#[test]
fn white_balance_reaches_the_rendered_image_and_its_header() {
    let mut scene = cornell(2);
    let plain = render_with(&scene, 2);
    scene.film_mut().white_balance_k = Some(4400.0);
    let balanced = render_with(&scene, 2);
    assert_eq!(balanced.settings.white_balance_k, Some(4400.0));
    let m = white_balance_matrix(4400.0);
    for (p, b) in plain.color.iter().zip(&balanced.color) {
        let want = m * *p;
        assert!((want - *b).abs().max_element() <= 1e-5 * (1.0 + want.abs().max_element()));
    }
    // A 4400 K balance cools the image: blue up, red down.
    assert!(balanced.mean_color().z > plain.mean_color().z);
    assert!(balanced.mean_color().x < plain.mean_color().x);
}

#[test]
fn dual_fisheye_pixels_outside_the_circles_are_black_and_count() {
    // Inside an emitting black sphere of radiance 1 every ray sees exactly 1.
    let text = "[render]\nspp = 4\nmax_depth = 1\n\
        [camera]\ntype = \"dual_fisheye\"\nposition = [0, 0, 0]\nlook_at = [0, 1, 0]\nup = [0, 0, 1]\n\
        fov = 180\nresolution = [16, 8]\n\
        [[materials]]\nname = \"black\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\
        [[shapes]]\ntype = \"sphere\"\nradius = 5\nflip_normals = true\nemission = [1, 1, 1]\nmaterial = \"black\"\n";
    let scene = Scene::build(load_text(text).unwrap()).unwrap();
    let film = render_with(&scene, 2);
    assert_eq!(film.spp, 4);
    // Corner pixels lie outside both circles (radius 4 around (4, 4) and (12, 4)).
    for (x, y) in [(0, 0), (15, 0), (0, 7), (15, 7), (8, 0)] {
        let i = film.index(x, y);
        assert_eq!(film.color[i], Vec3::ZERO, "({x}, {y})");
        assert_eq!(film.alpha[i], 0.0);
    }
    // Pixels well inside a circle see the emitter.
    for (x, y) in [(4, 4), (3, 3), (12, 4), (11, 4)] {
        let i = film.index(x, y);
        assert!(
            (film.color[i] - Vec3::ONE).abs().max_element() < 1e-4,
            "({x}, {y}): {}",
            film.color[i]
        );
        assert_eq!(film.alpha[i], 1.0);
        // Depth of a 360° camera is the distance: the sphere's radius.
        assert!((film.depth[i] - 5.0).abs() < 0.1, "{}", film.depth[i]);
    }
}

/// Every `camera-*.toml` and `film-*.toml` example of docs/scene-format.md
/// loads and renders (at a tiny size).
#[test]
fn scene_format_camera_and_film_examples_load() {
    let doc = std::fs::read_to_string("docs/scene-format.md").unwrap();
    let dir = tempfile::tempdir().unwrap();
    for f in ["cornell.obj", "cornell.mtl"] {
        std::fs::copy(
            Path::new("assets/scenes/cornell").join(f),
            dir.path().join(f),
        )
        .unwrap();
    }
    let mut found = Vec::new();
    let lines: Vec<&str> = doc.lines().collect();
    let mut i = 0;
    while i < lines.len() {
        let l = lines[i].trim();
        // A line ending in "`NAME.toml`:" introduces the example below it.
        let name = l
            .strip_suffix("`:")
            .and_then(|r| r.rsplit('`').next())
            .filter(|n| {
                (n.starts_with("camera-") || n.starts_with("film-")) && n.ends_with(".toml")
            });
        if let (Some(name), Some(fence)) = (name, lines.get(i + 2)) {
            if lines[i + 1].trim().is_empty() && fence.trim() == "```toml" {
                let mut body = String::new();
                let mut j = i + 3;
                while lines[j].trim() != "```" {
                    body.push_str(lines[j]);
                    body.push('\n');
                    j += 1;
                }
                let path = dir.path().join(name);
                std::fs::write(&path, &body).unwrap();
                let mut desc = load(&path).unwrap_or_else(|e| panic!("{name}: {e}"));
                desc.job.spp = 1;
                desc.camera = desc.camera.with_resolution(8, 6).unwrap();
                let scene = Scene::build(desc).unwrap();
                let film = render_with(&scene, 1);
                assert!(film.color.iter().all(|c| c.is_finite()), "{name}");
                found.push(name.to_string());
                i = j;
            }
        }
        i += 1;
    }
    for want in [
        "camera-focal.toml",
        "camera-path.toml",
        "camera-paper.toml",
        "camera-thin-lens.toml",
        "camera-matrix.toml",
        "camera-equirect.toml",
        "camera-dual-fisheye.toml",
        "film-photo.toml",
    ] {
        assert!(
            found.iter().any(|f| f == want),
            "{want} missing from the docs: found {found:?}"
        );
    }
}

/// The orthographic camera: parallel rays along the view, from a
/// `view_width × view_height` rectangle whose left edge is image left and
/// top edge image top; `project` inverts `generate_ray`; and a sphere of
/// radius r covers π r² of the view's area in the rendered mask.
#[test]
fn orthographic_rays_are_parallel_and_project_back() {
    use plsr::camera::{OrthographicCamera, Pose};
    let pose = Pose::look_at(Vec3::new(0.0, -5.0, 1.0), Vec3::new(0.0, 0.0, 1.0), Vec3::Z).unwrap();
    let cam = OrthographicCamera::new(pose, 4.0, 2.0, 40, 20).unwrap();
    let top_left = cam.generate_ray(Vec2::ZERO);
    assert!(
        (top_left.org - Vec3::new(-2.0, -5.0, 2.0)).length() < 1e-5,
        "{}",
        top_left.org
    );
    assert!((top_left.dir - Vec3::Y).length() < 1e-6);
    let bottom_right = cam.generate_ray(Vec2::new(40.0, 20.0));
    assert!((bottom_right.org - Vec3::new(2.0, -5.0, 0.0)).length() < 1e-5);
    for film in [Vec2::new(3.5, 7.25), Vec2::new(39.0, 0.5)] {
        let r = cam.generate_ray(film);
        let back = cam.project(r.org + r.dir * 3.0).unwrap();
        assert!((back - film).length() < 1e-4, "{film} → {back}");
    }
    assert!(OrthographicCamera::new(pose, 0.0, 1.0, 4, 4).is_err());
    // A black sphere of radius 0.5 against a white sky, seen in a 4 × 2
    // view: it covers π/4 of the 8 units², the image's mean is 1 − that.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("o.toml");
    std::fs::write(
        &path,
        "[render]\nspp = 64\nmax_depth = 1\n[camera]\ntype = \"orthographic\"\nposition = [0, -5, 1]\n\
         look_at = [0, 0, 1]\nup = [0, 0, 1]\nview_width = 4\nresolution = [80, 40]\n\
         [environment]\nradiance = [1, 1, 1]\n[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 1]\nradius = 0.5\nsubdivisions = 6\n\
         [[materials]]\nname = \"black\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n",
    )
    .unwrap();
    let text = std::fs::read_to_string(&path).unwrap().replace(
        "subdivisions = 6\n",
        "subdivisions = 6\nmaterial = \"black\"\n",
    );
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    let (film, _) = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap();
    // Sky is 1, the black sphere 0: the mean is 1 − covered share.
    let mean = film.color.iter().map(|c| c.x as f64).sum::<f64>() / film.color.len() as f64;
    let covered = 1.0 - mean;
    let want = std::f64::consts::PI * 0.25 / 8.0;
    assert!((covered - want).abs() < 0.01 * want, "{covered} vs {want}");
}

/// `[film] crop`: the film is the window's size and holds the whole
/// image's pixels there (bit for bit with the box filter); a clipped
/// Gaussian keeps the window's edge pixels' samples inside the window, so
/// only pixels within its radius of the window's edge differ; windows
/// outside the image are refused.
#[test]
fn a_film_crop_renders_its_window_of_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let film_of = |film: &str| -> plsr::Result<Film> {
        let path = dir.path().join("scene.toml");
        let text = format!(
            "[render]\nspp = 4\nseed = 3\n[film]\n{film}\n\
             [camera]\nposition = [0, -3, 1]\nlook_at = [0, 0, 0.3]\nup = [0, 0, 1]\nvfov = 45\n\
             resolution = [32, 24]\n[environment]\nradiance = [0.2, 0.3, 0.4]\n\
             [[lights]]\ntype = \"point\"\nposition = [1, -1, 3]\nintensity = [10, 10, 10]\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0.5]\nradius = 0.5\n\
             [[shapes]]\ntype = \"rectangle\"\ntransform = {{ scale = 3 }}\n"
        );
        std::fs::write(&path, text).unwrap();
        let scene = Scene::load(&path)?;
        Ok(render(
            &scene,
            &scene.default_job(),
            &RenderOptions::default(),
            &|_, _| true,
        )?
        .0)
    };
    let window = |f: &Film, [x0, y0, x1, y1]: [u32; 4]| -> Vec<u32> {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| (x, y)))
            .flat_map(|(x, y)| f.color[(y * f.width + x) as usize].to_array())
            .map(f32::to_bits)
            .collect()
    };
    let whole = film_of("").unwrap();
    let crop = film_of("crop = [5, 4, 21, 15]").unwrap();
    assert_eq!((crop.width, crop.height), (16, 11));
    assert_eq!(
        window(&crop, [0, 0, 16, 11]),
        window(&whole, [5, 4, 21, 15])
    );
    // Gaussian of radius 2, clipped: 2 pixels in from the window's edges,
    // the pixels are the whole image's; at its edges they differ.
    let g = "filter = \"gaussian\"\nfilter_radius = 2\nfilter_border = \"clip\"";
    let whole = film_of(g).unwrap();
    let crop = film_of(&format!("{g}\ncrop = [5, 4, 21, 15]")).unwrap();
    assert_eq!(window(&crop, [2, 2, 14, 9]), window(&whole, [7, 6, 19, 13]));
    assert_ne!(window(&crop, [0, 0, 16, 1]), window(&whole, [5, 4, 21, 5]));
    for bad in [
        "crop = [5, 4, 5, 15]",
        "crop = [5, 4, 33, 15]",
        "crop = [-1, 0, 4, 4]",
    ] {
        let e = film_of(bad)
            .err()
            .unwrap_or_else(|| panic!("{bad} accepted"))
            .to_string();
        assert!(e.contains("film.crop") && e.contains("32×24"), "{e}");
    }
}
