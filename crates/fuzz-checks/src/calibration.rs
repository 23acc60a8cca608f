//! Camera calibrations (`plsr import`, `plsr undistort`): an OpenCV or ROS
//! file (YAML or JSON), or a COLMAP text model (`cameras.txt` and
//! `images.txt`, cut from the input at its first NUL byte). Every camera
//! read must trace a ray through pixels of its image that projects back to
//! where it started, and every pose must be finite; or the error names the
//! file.

use glam::Vec2;

/// Checks one input.
pub fn check(data: &[u8]) {
    let (calibration, names): (_, &[&str]) = match data.iter().position(|&b| b == 0) {
        None => {
            let path = crate::common::input_file("calibration.yaml", data);
            (plsr::calibration::read(&path, false), &["calibration.yaml"])
        }
        Some(cut) => {
            let dir = crate::common::workdir().join("colmap");
            std::fs::create_dir_all(&dir).expect("the model folder can be made");
            std::fs::write(dir.join("cameras.txt"), &data[..cut]).expect("writable");
            std::fs::write(dir.join("images.txt"), &data[cut + 1..]).expect("writable");
            (
                plsr::calibration::read(&dir, false),
                &["cameras.txt", "images.txt"],
            )
        }
    };
    let calibration = match calibration {
        Err(e) => return crate::common::assert_clean_error(&e.to_string(), names),
        Ok(c) => c,
    };
    for image in &calibration.images {
        let p = image.pose;
        assert!(p.position.is_finite() && p.forward.is_finite() && p.up.is_finite());
        assert!(image.camera < calibration.cameras.len());
    }
    let pose = plsr::camera::Pose::look_at(glam::Vec3::ZERO, glam::Vec3::Z, glam::Vec3::NEG_Y)
        .expect("a valid pose");
    for model in &calibration.cameras {
        let camera = model.at(pose).expect("a camera read is a valid camera");
        let (w, h) = (model.width as f32, model.height as f32);
        for (fx, fy) in [(0.5, 0.5), (0.1, 0.2), (0.9, 0.95), (0.0, 1.0)] {
            let film = Vec2::new(fx * w, fy * h);
            if let Some(ray) = camera.generate_ray(film) {
                assert!(ray.dir.is_finite(), "ray {:?} at {film}", ray.dir);
            }
            // In double precision, the direction's image is the pixel, to
            // Newton's tolerance (1e-9 of a normalised coordinate).
            let Some(dir) = camera.film_direction(film) else {
                continue;
            };
            let d = model
                .distortion
                .distort(dir)
                .expect("a direction found has an image");
            let back = model.intrinsics.to_pixel(d) + glam::DVec2::splat(0.5);
            let k = model.intrinsics;
            let tolerance = 1e-6 + 4e-9 * (k.fx + k.fy + k.skew.abs()) * (1.0 + d.length());
            let miss = (back - film.as_dvec2()).length();
            assert!(miss <= tolerance, "{film} -> {back} ({model:?})");
        }
    }
}
