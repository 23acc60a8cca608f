//! Calibrated cameras (issue 54, point 1), against the tools that make
//! calibrations: OpenCV's `projectPoints` and `undistort` and pycolmap's
//! projection, on files those tools wrote (`tests/fixtures/calibration/`,
//! made by `scripts/calibration_fixtures.py`); scene-file keys and their
//! errors; and a render through a distorted lens whose markers land where
//! the camera projects them.

use glam::{DVec2, DVec3, Vec3};
use plsr::calibration::{self, colmap, scene_toml, undistort, Calibration};
use plsr::camera::Camera;
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;
use serde_json::Value;
use std::path::{Path, PathBuf};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/calibration")
        .join(rel)
}

fn json(rel: &str) -> Value {
    serde_json::from_str(&std::fs::read_to_string(fixture(rel)).unwrap()).unwrap()
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

fn points(v: &Value) -> Vec<Vec<f64>> {
    v.as_array().unwrap().iter().map(numbers).collect()
}

const OPENCV_CASES: [&str; 5] = ["brown4", "brown5", "rational8", "thinprism12", "fisheye"];

/// Projects the fixture's 1,000 points with the camera read from OpenCV's
/// own file; returns the largest distance to `projectPoints`, pixels.
fn opencv_worst_error(calibration: &Calibration, points_file: &str) -> f64 {
    let data = json(points_file);
    let (rvec, tvec) = (numbers(&data["rvec"]), numbers(&data["tvec"]));
    let r = plsr::calibration::rodrigues_matrix([rvec[0], rvec[1], rvec[2]]);
    let pose =
        plsr::calibration::pose_from_world_to_camera(r, [tvec[0], tvec[1], tvec[2]]).unwrap();
    let camera = calibration.cameras[0].at(pose).unwrap();
    let object = points(&data["object_points"]);
    let image = points(&data["image_points"]);
    assert_eq!(object.len(), 1000);
    let mut worst = 0.0f64;
    for (p, expected) in object.iter().zip(&image) {
        let world = DVec3::new(p[0], p[1], p[2]);
        let got = camera
            .project_pixel(world)
            .expect("the lens sees every fixture point");
        worst = worst.max((got - DVec2::new(expected[0], expected[1])).length());
        // The ray through OpenCV's pixel (plsr's film = OpenCV's + 0.5)
        // passes through the point.
        let film = glam::Vec2::new(expected[0] as f32 + 0.5, expected[1] as f32 + 0.5);
        let ray = camera.generate_ray(film).expect("a ray");
        let v = world - ray.org.as_dvec3();
        let miss = (v - v.dot(ray.dir.as_dvec3()) * ray.dir.as_dvec3()).length() / v.length();
        assert!(miss < 2e-5, "{points_file}: ray misses by {miss} rad");
    }
    worst
}

#[test]
fn opencv_files_project_as_project_points_does() {
    for case in OPENCV_CASES {
        for ext in ["yaml", "json"] {
            let c = calibration::read(&fixture(&format!("opencv/{case}.{ext}")), false).unwrap();
            let expected_model = if case == "fisheye" {
                "fisheye"
            } else {
                "brown_conrady"
            };
            assert_eq!(
                c.cameras[0].distortion.model_name(),
                expected_model,
                "{case}.{ext}"
            );
            let worst = opencv_worst_error(&c, &format!("opencv/{case}_points.json"));
            eprintln!("{case}.{ext}: worst {worst:.2e} px from projectPoints");
            assert!(worst <= 0.01, "{case}.{ext}: {worst} px from projectPoints");
        }
    }
}

#[test]
fn a_ros_camera_info_file_reads_as_opencvs() {
    let ros = calibration::read(&fixture("opencv/ros_brown5.yaml"), false).unwrap();
    let opencv = calibration::read(&fixture("opencv/brown5.yaml"), false).unwrap();
    assert_eq!(ros.cameras[0].width, opencv.cameras[0].width);
    let (a, b) = (&ros.cameras[0], &opencv.cameras[0]);
    for (x, y) in [
        (a.intrinsics.fx, b.intrinsics.fx),
        (a.intrinsics.cy, b.intrinsics.cy),
    ]
    .into_iter()
    .chain(
        a.distortion
            .coefficients()
            .into_iter()
            .zip(b.distortion.coefficients()),
    ) {
        assert!((x - y).abs() <= 1e-9 * x.abs().max(1.0), "{x} vs {y}");
    }
}

#[test]
fn colmap_models_project_as_pycolmap_does() {
    let model = calibration::read(&fixture("colmap"), false).unwrap();
    let expected = json("colmap/expected.json");
    let images = expected["images"].as_array().unwrap();
    assert!(images.len() >= 18, "every camera model twice");
    let mut models_seen = std::collections::BTreeSet::new();
    for image in images {
        let name = image["name"].as_str().unwrap();
        let posed = model
            .images
            .iter()
            .find(|i| i.name == name)
            .unwrap_or_else(|| panic!("{name} missing"));
        let camera = model.cameras[posed.camera].at(posed.pose).unwrap();
        models_seen.insert(image["camera_model"].as_str().unwrap().to_string());
        let mut worst = 0.0f64;
        for (p, px) in points(&image["points"])
            .iter()
            .zip(points(&image["pixels"]))
        {
            // COLMAP's pixel convention is plsr's film convention.
            let got = camera
                .project_pixel(DVec3::new(p[0], p[1], p[2]))
                .map(|g| g + DVec2::splat(0.5))
                .expect("seen");
            assert!(got.is_finite());
            worst = worst.max((got - DVec2::new(px[0], px[1])).length());
        }
        eprintln!("{name}: worst {worst:.2e} px from pycolmap");
        assert!(worst <= 0.01, "{name}: {worst} px from pycolmap");
    }
    assert_eq!(models_seen.len(), 9, "{models_seen:?}");
}

#[test]
fn a_colmap_model_round_trips_through_plsrs_writer_and_scene_files() {
    let model = calibration::read(&fixture("colmap"), false).unwrap();
    // Written back in COLMAP's text form and read again: the same cameras
    // (exactly) and poses (to f32).
    let (ids, cameras) =
        colmap::parse_cameras(&colmap::write_cameras(&model.cameras).unwrap()).unwrap();
    assert_eq!(cameras, model.cameras);
    let images = colmap::parse_images(&colmap::write_images(&model.images), &ids).unwrap();
    assert_eq!(images.len(), model.images.len());
    for (a, b) in model.images.iter().zip(&images) {
        assert_eq!((&a.name, a.camera), (&b.name, b.camera));
        assert!((a.pose.position - b.pose.position).length() < 1e-5);
        assert!((a.pose.forward - b.pose.forward).length() < 1e-6);
        assert!((a.pose.up - b.pose.up).length() < 1e-6);
    }
    // Written as a scene file, with every photo a view: the scene's cameras
    // are the model's.
    let dir = tempfile::tempdir().unwrap();
    let base = "[[shapes]]\ntype = \"sphere\"\nradius = 1\n";
    let options = scene_toml::SceneTomlOptions {
        image: Some(model.images[3].name.clone()),
        photos: Some("photos".into()),
        views: true,
    };
    let text = scene_toml::scene_toml(Some(base), &model, &options).unwrap();
    std::fs::create_dir_all(dir.path().join("photos")).unwrap();
    for i in &model.images {
        std::fs::write(dir.path().join("photos").join(&i.name), b"").unwrap();
    }
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, &text).unwrap();
    let contents = plsr::scene::file::load_contents(&path).unwrap();
    assert_eq!(contents.views.len(), model.images.len() - 1);
    let check = |camera: &Camera, posed: &calibration::PosedImage| {
        let Camera::Calibrated(c) = camera else {
            panic!("not calibrated")
        };
        let m = &model.cameras[posed.camera];
        assert_eq!((c.width, c.height), (m.width, m.height));
        assert_eq!(c.intrinsics, m.intrinsics);
        assert_eq!(c.distortion, m.distortion);
        assert!((c.pose.position - posed.pose.position).length() < 1e-5);
        assert!((c.pose.forward - posed.pose.forward).length() < 1e-6);
    };
    check(&contents.description.camera, &model.images[3]);
    assert!(contents
        .photo
        .unwrap()
        .file
        .ends_with(&model.images[3].name));
    let others: Vec<_> = model
        .images
        .iter()
        .filter(|i| i.name != model.images[3].name)
        .collect();
    for (view, posed) in contents.views.iter().zip(others) {
        check(&view.camera, posed);
        assert!(view.photo.file.ends_with(&posed.name));
    }
}

/// The first three channels of an EXR fixture.
fn exr(rel: &str) -> (usize, usize, Vec<[f32; 3]>) {
    let (info, data) = plsr_hdr::oiio::read_image_f32(&fixture(rel)).unwrap();
    let px = data
        .chunks_exact(info.channels)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width, info.height, px)
}

#[test]
fn undistortion_samples_where_opencvs_maps_do() {
    let (w, h, input) = exr("undistort/input.exr");
    for cam in ["brown", "fisheye"] {
        let c = calibration::read(&fixture(&format!("undistort/{cam}.yaml")), false).unwrap();
        let model = &c.cameras[0];
        assert_eq!((model.width as usize, model.height as usize), (w, h));
        // The source position of every pixel: OpenCV's float maps.
        let (_, _, map) = exr(&format!("undistort/{cam}_map.exr"));
        let ours = undistort::source_positions(model);
        let mut worst = 0.0f64;
        for (o, m) in ours.iter().zip(&map) {
            let o = o.expect("every pixel has a source");
            worst = worst.max((o - DVec2::new(m[0] as f64, m[1] as f64)).length());
        }
        eprintln!("{cam}: source positions within {worst:.2e} px of OpenCV's maps");
        assert!(worst <= 0.01, "{cam}: maps differ by {worst} px");
        // The image: OpenCV's remap of float images with float maps.
        let flat: Vec<f32> = input.iter().flatten().copied().collect();
        let out = undistort::undistort(model, &flat, 3);
        let (_, _, reference) = exr(&format!("undistort/{cam}_opencv.exr"));
        let reference: Vec<f32> = reference.iter().flatten().copied().collect();
        let mut sum = 0.0f64;
        let mut worst = 0.0f32;
        for (a, b) in out.iter().zip(&reference) {
            sum += (a - b).abs() as f64;
            worst = worst.max((a - b).abs());
        }
        let mean = sum / out.len() as f64;
        eprintln!("{cam}: image within {mean:.2e} (mean), {worst:.2e} (worst) of OpenCV's remap");
        assert!(
            mean < 1e-5 && worst < 1e-4,
            "{cam}: mean {mean}, worst {worst}"
        );
    }
}

fn load_text(text: &str) -> plsr::Result<plsr::scene::SceneDescription> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    plsr::scene::file::load(&path)
}

const CALIBRATED: &str = "[camera]\ntype = \"calibrated\"\nposition = [0, 0, 0]\n\
    look_at = [0, 0, 1]\nup = [0, -1, 0]\nresolution = [160, 120]\n";

#[test]
fn calibrated_camera_keys_and_their_errors() {
    let d = load_text(&format!(
        "{CALIBRATED}fx = 100\nfy = 101\ndistortion = \"brown_conrady\"\n\
         coefficients = [-0.2, 0.05, 0, 0]\n"
    ))
    .unwrap();
    let Camera::Calibrated(c) = &d.camera else {
        panic!("not calibrated")
    };
    // The principal point defaults to the image's centre (OpenCV's convention).
    assert_eq!((c.intrinsics.cx, c.intrinsics.cy), (79.5, 59.5));
    for (extra, field, words) in [
        ("fy = 100\n", "camera.fx", "required"),
        ("fx = 0\nfy = 100\n", "camera.fx", "positive"),
        (
            "fx = 1\nfy = 1\ndistortion = \"kb\"\n",
            "camera.distortion",
            "unknown distortion",
        ),
        (
            "fx = 1\nfy = 1\ndistortion = \"brown_conrady\"\ncoefficients = [1, 2, 3]\n",
            "camera.coefficients",
            "4, 5, 8 or 12",
        ),
        (
            "fx = 1\nfy = 1\ncoefficients = [1, 2, 3, 4]\n",
            "camera.coefficients",
            "none",
        ),
        ("fx = 1\nfy = 1\nvfov = 40\n", "camera.vfov", "not used"),
    ] {
        let e = load_text(&format!("{CALIBRATED}{extra}"))
            .unwrap_err()
            .to_string();
        assert!(e.contains(field) && e.contains(words), "{extra}: {e}");
    }
}

/// A render through a strongly distorted lens: small glowing spheres land
/// where the camera projects their centres (the centroid of each blob).
#[test]
fn a_render_through_a_distorted_lens_puts_markers_where_the_camera_projects_them() {
    let (w, h) = (160u32, 120u32);
    let markers = [
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::new(-2.2, -1.6, 4.0),
        Vec3::new(2.3, 1.5, 4.2),
        Vec3::new(2.2, -1.7, 3.8),
    ];
    let mut text = format!(
        "{CALIBRATED}fx = 70\nfy = 72\ncx = 83.2\ncy = 57.9\ndistortion = \"brown_conrady\"\n\
         coefficients = [-0.25, 0.06, 0.002, -0.001, -0.005]\n\
         [render]\nspp = 64\nmax_depth = 0\n"
    )
    .replace("[160, 120]", &format!("[{w}, {h}]"));
    for m in &markers {
        text.push_str(&format!(
            "[[shapes]]\ntype = \"sphere\"\ncenter = [{}, {}, {}]\nradius = 0.06\nemission = [1, 1, 1]\n",
            m.x, m.y, m.z
        ));
    }
    let description = load_text(&text).unwrap();
    let scene = Scene::build(description).unwrap();
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    for m in markers {
        let expected = scene.camera().project(m).unwrap();
        // The luminance centroid within 6 px of the expected position.
        let (mut sum, mut weight) = (glam::DVec2::ZERO, 0.0f64);
        for y in 0..h {
            for x in 0..w {
                let centre = glam::Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                if (centre - expected).length() > 6.0 {
                    continue;
                }
                let v = film.color[(y * w + x) as usize].element_sum() as f64;
                sum += centre.as_dvec2() * v;
                weight += v;
            }
        }
        assert!(weight > 0.0, "marker {m} not seen near {expected}");
        let centroid = sum / weight;
        let miss = (centroid - expected.as_dvec2()).length();
        eprintln!("marker {m}: centroid {miss:.3} px from its projection");
        assert!(
            miss < 0.1,
            "marker {m}: centroid {centroid}, projected {expected}"
        );
    }
}

/// The end-to-end check: a chessboard rendered by plsr through a
/// known distorted lens (14 views), its corners found by OpenCV
/// (`findChessboardCorners`, `cornerSubPix`) and the camera calibrated by
/// OpenCV (`calibrateCamera`; `scripts/calibration_checkerboard.py`). The
/// imported calibration reprojects the detected corners within 0.1 px and
/// agrees with the true camera within 0.1 px over the board.
#[test]
fn checkerboard_renders_calibrate_to_the_true_camera() {
    let calibration = calibration::read(&fixture("checkerboard/calibration.yaml"), false).unwrap();
    let truth = json("checkerboard/views.json");
    let views = truth["views"].as_array().unwrap();
    assert_eq!(calibration.images.len(), views.len());
    assert!(views.len() >= 10, "{} views", views.len());
    let k = &truth["intrinsics"];
    let true_model = calibration::CameraModel {
        width: truth["width"].as_u64().unwrap() as u32,
        height: truth["height"].as_u64().unwrap() as u32,
        intrinsics: plsr::camera::Intrinsics {
            fx: k["fx"].as_f64().unwrap(),
            fy: k["fy"].as_f64().unwrap(),
            cx: k["cx"].as_f64().unwrap(),
            cy: k["cy"].as_f64().unwrap(),
            skew: 0.0,
        },
        distortion: plsr::lens_distortion::LensDistortion::brown_conrady(&numbers(
            &truth["coefficients"],
        ))
        .unwrap(),
    };
    let pattern = numbers(&truth["pattern"]);
    let square = truth["square"].as_f64().unwrap();
    let board: Vec<DVec3> = (0..pattern[1] as usize)
        .flat_map(|j| {
            (0..pattern[0] as usize)
                .map(move |i| DVec3::new(i as f64 * square, j as f64 * square, 0.0))
        })
        .collect();
    let (mut sum_sq, mut count, mut worst_truth) = (0.0f64, 0usize, 0.0f64);
    for (view, posed) in views.iter().zip(&calibration.images) {
        let v = &view["view"];
        let v3 = |key: &str| {
            let n = numbers(&v[key]);
            Vec3::new(n[0] as f32, n[1] as f32, n[2] as f32)
        };
        let true_pose =
            plsr::camera::Pose::look_at(v3("position"), v3("look_at"), v3("up")).unwrap();
        assert!(
            (posed.pose.position - true_pose.position).length() < 2e-3,
            "{}: calibrated at {}, true {}",
            posed.name,
            posed.pose.position,
            true_pose.position
        );
        let fitted = calibration.cameras[0].at(posed.pose).unwrap();
        let true_camera = true_model.at(true_pose).unwrap();
        for (corner, detected) in board.iter().zip(points(&view["corners"])) {
            let p = fitted.project_pixel(*corner).unwrap();
            sum_sq += (p - DVec2::new(detected[0], detected[1])).length_squared();
            count += 1;
            let t = true_camera.project_pixel(*corner).unwrap();
            worst_truth = worst_truth.max((p - t).length());
        }
    }
    let rms = (sum_sq / count as f64).sqrt();
    eprintln!("checkerboard: reprojection RMS {rms:.4} px, {worst_truth:.4} px from the true camera at worst");
    assert!(rms <= 0.1, "reprojection error {rms} px");
    assert!(worst_truth <= 0.1, "{worst_truth} px from the true camera");
    // The calibration's own figure agrees with plsr's.
    let stated = calibration.reprojection_error.unwrap();
    assert!(
        (stated - rms).abs() < 0.01,
        "OpenCV says {stated}, plsr {rms}"
    );
}
