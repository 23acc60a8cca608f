//! `plsr import CALIBRATION` and `plsr undistort` as a user runs them: an
//! OpenCV calibration written into a scene keeps the scene's pose and
//! renders; a COLMAP model gives [camera], [photo] and [[views]]; the
//! undistorted photo is the library's; and bad input is refused clearly
//! (see docs/calibration.md).

use plsr::camera::Camera;
use std::path::Path;

const FIXTURES: &str = "tests/fixtures/calibration";

use crate::plsr;

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

const SCENE: &str = r#"# A room to photograph.
[camera]
position = [0, 1, 3]
look_at = [0, 0.5, 0]
up = [0, 1, 0]
vfov = 40
resolution = [64, 48]

[environment]
radiance = [1, 1, 1]

[[shapes]]
type = "sphere"
center = [0, 0.5, 0]
radius = 0.5
"#;

#[test]
fn an_opencv_calibration_goes_into_a_scene_keeping_its_pose_and_renders() {
    plsr_testkit::run_from_the_repository_root!();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("room.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let out = dir.path().join("room-phone.toml");
    let calibration = format!("{FIXTURES}/opencv/brown5.yaml");
    let (ok, _, err) = plsr(&["import", &calibration, "--scene", s(&scene), "-o", s(&out)]);
    assert!(ok, "{err}");
    assert!(
        err.contains("1 camera (brown_conrady), 0 posed photos"),
        "{err}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("# A room to photograph."),
        "the scene's comments are kept"
    );
    let before = plsr::scene::file::load(&scene).unwrap().camera;
    let after = plsr::scene::file::load(&out).unwrap().camera;
    let Camera::Calibrated(c) = &after else {
        panic!("{after:?}")
    };
    assert_eq!((c.width, c.height), (640, 480));
    assert_eq!(c.distortion.coefficients().len(), 5);
    assert!((c.pose.position - before.pose().position).length() < 1e-6);
    assert!((c.pose.forward - before.pose().forward).length() < 1e-6);
    // It renders, at a quarter of the calibration's size.
    let exr = dir.path().join("r.exr");
    let (ok, _, err) = plsr(&[
        "render",
        s(&out),
        "--resolution",
        "160,120",
        "--spp",
        "2",
        "-o",
        s(&exr),
        "-q",
    ]);
    assert!(ok, "{err}");
    // Printed without --scene: the camera table alone, no pose.
    let (ok, stdout, err) = plsr(&["import", &calibration]);
    assert!(ok, "{err}");
    assert!(
        stdout.contains("type = \"calibrated\"") && stdout.contains("no pose"),
        "{stdout}"
    );
}

#[test]
fn a_colmap_model_gives_camera_photo_and_views() {
    plsr_testkit::run_from_the_repository_root!();
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("room.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let model = plsr::calibration::read(Path::new(&format!("{FIXTURES}/colmap")), false).unwrap();
    std::fs::create_dir_all(dir.path().join("photos")).unwrap();
    for image in &model.images {
        std::fs::write(dir.path().join("photos").join(&image.name), b"").unwrap();
    }
    let chosen = &model.images[2];
    let out = dir.path().join("room-colmap.toml");
    let (ok, _, err) = plsr(&[
        "import",
        &format!("{FIXTURES}/colmap/cameras.txt"),
        "--scene",
        s(&scene),
        "--image",
        &chosen.name,
        "--photos",
        "photos",
        "-o",
        s(&out),
    ]);
    assert!(ok, "{err}");
    let contents = plsr::scene::file::load_contents(&out).unwrap();
    assert_eq!(contents.views.len(), model.images.len() - 1);
    assert!(contents.photo.unwrap().file.ends_with(&chosen.name));
    let position = contents.description.camera.pose().position;
    assert!((position - chosen.pose.position).length() < 1e-5);
    // A photo the model does not have is refused, naming some it has.
    let (ok, _, err) = plsr(&[
        "import",
        &format!("{FIXTURES}/colmap"),
        "--image",
        "nope.jpg",
    ]);
    assert!(
        !ok && err.contains("nope.jpg") && err.contains(&model.images[0].name),
        "{err}"
    );
    // The output must sit beside the scene it extends.
    let elsewhere = tempfile::tempdir().unwrap();
    let (ok, _, err) = plsr(&[
        "import",
        &format!("{FIXTURES}/colmap"),
        "--scene",
        s(&scene),
        "-o",
        s(&elsewhere.path().join("x.toml")),
    ]);
    assert!(!ok && err.contains("beside"), "{err}");
}

#[test]
fn bad_calibrations_are_refused_naming_the_file_and_key() {
    plsr_testkit::run_from_the_repository_root!();
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.yaml");
    std::fs::write(
        &bad,
        "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n   \
         rows: 3\n   cols: 3\n   dt: d\n   data: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]\n\
         distortion_coefficients: !!opencv-matrix\n   rows: 14\n   cols: 1\n   dt: d\n   \
         data: [ 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0., 0. ]\n",
    )
    .unwrap();
    let (ok, _, err) = plsr(&["import", s(&bad)]);
    assert!(!ok, "a tilted-sensor model is refused");
    assert!(
        err.contains("bad.yaml")
            && err.contains("distortion_coefficients")
            && err.contains("tilted"),
        "{err}"
    );
    let cameras = dir.path().join("cameras.txt");
    std::fs::write(&cameras, "# c\n1 FOV 640 480 500 320 240 0.9\n").unwrap();
    let (ok, _, err) = plsr(&["import", s(&cameras)]);
    assert!(
        !ok && err.contains("cameras.txt") && err.contains("line 2") && err.contains("FOV"),
        "{err}"
    );
    let (ok, _, err) = plsr(&["import", s(&dir.path().join("missing.yaml"))]);
    assert!(!ok && err.contains("missing.yaml"), "{err}");
    let (ok, _, err) = plsr(&[
        "import",
        &format!("{FIXTURES}/opencv/brown5.yaml"),
        "-D",
        "a=1",
    ]);
    assert!(!ok && err.contains("-D"), "{err}");
}

#[test]
fn undistort_writes_the_librarys_image_and_rescales_for_resized_photos() {
    plsr_testkit::run_from_the_repository_root!();
    let dir = tempfile::tempdir().unwrap();
    let input = format!("{FIXTURES}/undistort/input.exr");
    let calibration = format!("{FIXTURES}/undistort/brown.yaml");
    let out = dir.path().join("pinhole.exr");
    let (ok, _, err) = plsr(&["undistort", &input, "-c", &calibration, "-o", s(&out)]);
    assert!(ok, "{err}");
    let (info, got) = plsr_hdr::oiio::read_image_f32(&out).unwrap();
    let (_, pixels) = plsr_hdr::oiio::read_image_f32(Path::new(&input)).unwrap();
    let model = plsr::calibration::read(Path::new(&calibration), false)
        .unwrap()
        .cameras[0]
        .clone();
    let expected = plsr::calibration::undistort::undistort(&model, &pixels, info.channels);
    assert_eq!(got, expected);
    // A photo at half the size: the calibration is rescaled, not refused.
    let half = dir.path().join("half.exr");
    let (w, h) = (info.width / 2, info.height / 2);
    let small: Vec<f32> = (0..w * h * info.channels)
        .map(|i| {
            pixels[((i / info.channels / w) * 2 * info.width + (i / info.channels % w) * 2)
                * info.channels
                + i % info.channels]
        })
        .collect();
    plsr_hdr::oiio::write_image(
        &half,
        w,
        h,
        info.channels,
        plsr_hdr::oiio::PixelType::F32,
        &[],
        &small,
    )
    .unwrap();
    let (ok, _, err) = plsr(&[
        "undistort",
        s(&half),
        "-c",
        &calibration,
        "-o",
        s(&dir.path().join("h.png")),
    ]);
    assert!(ok, "{err}");
    // Another aspect ratio is another camera.
    let square = dir.path().join("square.exr");
    plsr_hdr::oiio::write_image(
        &square,
        8,
        8,
        3,
        plsr_hdr::oiio::PixelType::F32,
        &[],
        &[0.5f32; 192],
    )
    .unwrap();
    let (ok, _, err) = plsr(&[
        "undistort",
        s(&square),
        "-c",
        &calibration,
        "-o",
        s(&dir.path().join("q.exr")),
    ]);
    assert!(
        !ok && err.contains("square.exr") && err.contains("8×8"),
        "{err}"
    );
    // A scene whose camera is not calibrated cannot undistort.
    let scene = dir.path().join("room.toml");
    std::fs::write(&scene, SCENE).unwrap();
    let (ok, _, err) = plsr(&[
        "undistort",
        &input,
        "-c",
        s(&scene),
        "-o",
        s(&dir.path().join("x.exr")),
    ]);
    assert!(
        !ok && err.contains("camera.type") && err.contains("calibrated"),
        "{err}"
    );
}
