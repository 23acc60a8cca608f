//! Parametric light sources: validation, geometry, the circle helper,
//! transforms through parameters, and the PLS file format.

use glam::{Mat3, Mat4, Quat, Vec3};
use plsr::light::pls::{file, BrightnessMode, Pls, PlsLighting};
use std::path::Path;

fn paper() -> PlsLighting {
    file::load(Path::new("assets/lights/paper.toml")).unwrap()
}

fn flashlight() -> Pls {
    paper().lights[0].clone()
}

fn lamp() -> Pls {
    paper().lights[1].clone()
}

#[test]
fn paper_lights_load_exactly() {
    let l = paper();
    assert_eq!(l.mode, BrightnessMode::Intensity);
    assert_eq!(l.lights.len(), 2);
    let f = &l.lights[0];
    assert_eq!(f.name.as_deref(), Some("flashlight"));
    assert_eq!(f.n, Vec3::new(-0.697, -0.339, -0.632));
    assert_eq!(f.a_deg, 10.983);
    assert_eq!(f.b, 7.011);
    assert_eq!(f.g.d, [0.0, 0.021, 0.021, 0.0]);
    let m = &l.lights[1];
    assert_eq!((m.g.alpha1, m.g.alpha2), (0.333, 0.666));
    assert_eq!(m.c, Vec3::new(0.753, 0.588, 0.306));
}

#[test]
fn file_round_trip_keeps_every_parameter() {
    let l = paper();
    for ext in ["toml", "json"] {
        let p = Path::new("x").with_extension(ext);
        let text = file::to_string(&l, &p).unwrap();
        assert_eq!(file::parse(&text, &p).unwrap(), l, "{ext}:\n{text}");
    }
}

fn expect_invalid(mut edit: impl FnMut(&mut Pls), parameter: &str) {
    let mut l = lamp();
    edit(&mut l);
    let e = l.validate(1).unwrap_err();
    assert_eq!(e.parameter, parameter, "{e}");
    assert!(
        e.light.contains("lights[1]") && e.light.contains("lamp"),
        "{e}"
    );
}

#[test]
fn every_invalid_parameter_is_named() {
    lamp().validate(1).unwrap();
    flashlight().validate(0).unwrap();
    expect_invalid(|l| l.n = Vec3::new(f32::NAN, 0.0, 1.0), "n");
    expect_invalid(|l| l.g.e1.y = f32::INFINITY, "e1");
    expect_invalid(|l| l.g.d[2] = f32::NAN, "d[2]");
    // Finite, but beyond where Embree places vertices (found by fuzzing).
    expect_invalid(|l| l.g.e1.y = 2.56e14, "e1");
    expect_invalid(|l| l.g.e2.x = -6e11, "e2");
    expect_invalid(|l| l.g.d[3] = 6e11, "d[3]");
    expect_invalid(|l| l.b = f32::NAN, "b");
    expect_invalid(|l| l.n = Vec3::ZERO, "n");
    expect_invalid(|l| l.g.e2 = l.g.e1, "e2");
    expect_invalid(|l| l.n = l.g.e2 - l.g.e1, "n");
    expect_invalid(|l| l.g.alpha1 = -0.1, "alpha1");
    expect_invalid(|l| l.g.alpha1 = 0.7, "alpha1");
    expect_invalid(|l| l.g.alpha2 = 1.2, "alpha2");
    expect_invalid(|l| l.g.d[1] = -0.01, "d[1]");
    expect_invalid(|l| l.g.d = [0.0; 4], "d");
    expect_invalid(|l| l.c = Vec3::new(0.1, -0.2, 0.3), "c");
    expect_invalid(|l| l.b = -1.0, "b");
    // Each finite, but b·c overflows f32 (found by fuzzing).
    expect_invalid(
        |l| {
            l.b = 1e30;
            l.c = Vec3::new(1e30, 0.2, 0.4);
        },
        "b",
    );
    expect_invalid(|l| l.a_deg = 0.0, "a");
    expect_invalid(|l| l.a_deg = 90.5, "a");
    // 90° exactly is allowed: a hemispherical emitter.
    let mut l = lamp();
    l.a_deg = 90.0;
    l.validate(0).unwrap();
}

/// The brightest light plsr accepts, spread over a tessellation of almost
/// no area, still has a finite radiance (eq. 12).
#[test]
fn the_brightest_light_has_finite_radiance_on_any_area() {
    let mut l = flashlight();
    l.c = Vec3::ONE;
    l.b = plsr::light::pls::MAX_BRIGHTNESS;
    l.validate(0).unwrap();
    for area in [1.0, 1e-10, 1e-30, f32::MIN_POSITIVE] {
        let r = l.radiance(BrightnessMode::Intensity, area);
        assert!(r.is_finite() && r.min_element() > 0.0, "{area}: {r}");
    }
    assert!(l.radiance(BrightnessMode::Radiance, 1.0).is_finite());
}

#[test]
fn file_errors_name_file_light_and_parameter() {
    let text = std::fs::read_to_string("assets/lights/paper.toml")
        .unwrap()
        .replace("alpha1 = 0.333", "alpha1 = 0.9");
    let e = file::parse(&text, Path::new("lights.toml"))
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("lights.toml: lights[1] (lamp).alpha1:"),
        "{e}"
    );
    let e = file::parse(
        "[[lights]]\nn = [0,0,1]\na = 10\nc = [1,1,1]\nb = 1\n",
        Path::new("l.toml"),
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("lights[0].e1") && e.contains("required"), "{e}");
    let e = file::parse("brightness = \"lumens\"\n", Path::new("l.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("brightness") && e.contains("lumens"), "{e}");
    let e = file::parse("[[lights]]\nnormal = [0,0,1]\n", Path::new("l.toml"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("unknown field `normal`"), "{e}");
}

#[test]
fn anchors_follow_the_definition() {
    let l = lamp();
    let v = l.g.e2 - l.g.e1;
    let p = v.cross(l.normal()).normalize();
    let c = l.anchors();
    assert!((c[1] - (l.g.e1 + 0.333 * v + 0.038 * p)).length() < 1e-6);
    assert!((c[6] - (l.g.e1 + 0.666 * v - 0.038 * p)).length() < 1e-6);
    // The boundary curves start and end at the first and last anchors.
    let (b1, b2) = l.boundary(0.0);
    assert!((b1 - c[0]).length() < 1e-6 && (b2 - c[4]).length() < 1e-6);
    let (b1, b2) = l.boundary(1.0);
    assert!((b1 - c[3]).length() < 1e-6 && (b2 - c[7]).length() < 1e-6);
}

#[test]
fn tessellation_faces_n_and_has_no_degenerate_triangles() {
    for l in [flashlight(), lamp()] {
        for nf in [1, 2, 5, 16, 64] {
            let mesh = l.tessellate(nf);
            assert!(!mesh.triangles.is_empty());
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| mesh.positions[i as usize]);
                let cross = (b - a).cross(c - a);
                assert!(
                    cross.is_finite() && cross.length() > 0.0,
                    "zero-area triangle"
                );
                assert!(cross.dot(l.normal()) > 0.0, "triangle facing away from n");
            }
            assert!(mesh.positions.iter().all(|p| p.is_finite()));
        }
        // Pointed at both ends, Nf = 1 is raised to 2 (two triangles).
        if l.g.d[0] == 0.0 && l.g.d[3] == 0.0 {
            assert_eq!(l.tessellate(1).triangles.len(), 2);
        }
        // Pointed ends (flashlight: d1 = d4 = 0) give one triangle per end quad.
        let m = l.tessellate(8);
        let expected = if l.g.d[0] == 0.0 { 14 } else { 16 };
        assert_eq!(m.triangles.len(), expected);
    }
}

#[test]
fn tessellated_area_converges_to_the_outline_area() {
    for l in [flashlight(), lamp()] {
        let exact = l.outline_area();
        let mut last = f32::INFINITY;
        for nf in [2, 4, 8, 16, 32, 64, 128] {
            let err = ((l.tessellate(nf).area() - exact) / exact).abs();
            eprintln!("{:?}: Nf = {nf}: relative area error {err:.2e}", l.name);
            assert!(
                err < last || err < 1e-5,
                "{:?} nf={nf}: {err} after {last}",
                l.name
            );
            last = err;
            if nf == plsr::light::pls::DEFAULT_NF {
                assert!(err < 2e-3, "default Nf error {err} for {:?}", l.name);
            }
        }
        assert!(last < 2e-4, "Nf = 128: {last}");
    }
    // A rectangle (all d equal, straight axis) is exact at any Nf.
    let l = lamp();
    let exact = 2.0 * 0.038 * (l.g.e2 - l.g.e1).length();
    assert!((l.outline_area() - exact).abs() < 1e-6 * exact.max(1.0) + 1e-7);
    assert!((l.tessellate(3).area() - exact).abs() < 1e-5 * exact);
}

#[test]
fn circle_helper_reproduces_the_papers_flashlight() {
    let f = flashlight();
    let centre = f.centre();
    let radius = 0.5 * (f.g.e2 - f.g.e1).length();
    let c = Pls::circle(centre, radius, f.n, f.g.e2 - f.g.e1, f.a_deg, f.c, f.b).unwrap();
    // The paper's axis is not exactly perpendicular to n; the helper projects
    // it into the disk's plane, which moves the ends by ~1.5 % of r.
    assert!((c.g.e1 - f.g.e1).length() < 0.05 * radius);
    assert!((c.g.e2 - f.g.e2).length() < 0.05 * radius);
    assert_eq!((c.g.alpha1, c.g.alpha2), (0.0, 1.0));
    assert_eq!((c.g.d[0], c.g.d[3]), (0.0, 0.0));
    for k in [1, 2] {
        let rel = (c.g.d[k] - f.g.d[k]).abs() / f.g.d[k];
        assert!(
            rel < 0.05,
            "d{} = {} vs the paper's {} ({rel})",
            k + 1,
            c.g.d[k],
            f.g.d[k]
        );
    }
    // The shape is close to a disk: area within 5 % of π r².
    let disk = std::f32::consts::PI * radius * radius;
    assert!(
        (c.outline_area() - disk).abs() < 0.05 * disk,
        "{} vs {disk}",
        c.outline_area()
    );
}

fn max_vertex_distance(a: &plsr::light::pls::PlsMesh, b: &plsr::light::pls::PlsMesh) -> f32 {
    assert_eq!(a.triangles, b.triangles);
    a.positions
        .iter()
        .zip(&b.positions)
        .map(|(p, q)| (*p - *q).length())
        .fold(0.0, f32::max)
}

#[test]
fn transforming_parameters_equals_transforming_the_mesh_for_similarities() {
    let similarities = [
        Mat4::from_translation(Vec3::new(0.5, -1.0, 2.0)),
        Mat4::from_quat(Quat::from_axis_angle(
            Vec3::new(1.0, 2.0, -0.5).normalize(),
            1.1,
        )),
        Mat4::from_scale(Vec3::splat(1.7)),
        Mat4::from_scale_rotation_translation(
            Vec3::splat(0.6),
            Quat::from_axis_angle(Vec3::Z, -2.0),
            Vec3::new(-0.3, 0.2, 0.9),
        ),
    ];
    for l in [flashlight(), lamp()] {
        for m in &similarities {
            let t = l.transform(m);
            for nf in [4, 16] {
                let d = max_vertex_distance(&t.tessellate(nf), &l.tessellate(nf).transformed(m));
                assert!(d < 1e-5, "{:?}: {d} m", l.name);
            }
            // a, c and b are unchanged; n stays unit.
            assert_eq!((t.a_deg, t.c, t.b), (l.a_deg, l.c, l.b));
            assert!((t.n.length() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn shear_and_non_uniform_scale_are_approximations_whose_error_is_measured() {
    // A shear and a non-uniform scale: the parameter transform keeps the
    // outline symmetric about its axis, the mesh transform does not.
    let shear = Mat4::from_mat3(Mat3::from_cols(
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(0.3, 1.0, 0.0),
        Vec3::new(0.0, 0.0, 1.0),
    ));
    let stretch = Mat4::from_scale(Vec3::new(1.0, 2.0, 0.5));
    for (name, m) in [("shear", shear), ("non-uniform scale", stretch)] {
        for l in [flashlight(), lamp()] {
            let a = l.transform(&m).tessellate(16);
            let b = l.tessellate(16).transformed(&m);
            let d = max_vertex_distance(&a, &b);
            let size = (l.g.e2 - l.g.e1)
                .length()
                .max(l.g.d.iter().cloned().fold(0.0, f32::max));
            // Measured (see docs/pls-format.md): the deviation is a fraction
            // of the light's size, not zero and not wild.
            eprintln!(
                "{name}, {:?}: max vertex deviation {d:.2e} m = {:.1} % of the light's size",
                l.name,
                100.0 * d / size
            );
            assert!(d > 1e-6 && d < size, "{name}: {d}");
        }
    }
}

#[test]
fn brightness_modes() {
    let l = flashlight();
    let area = l.tessellate(16).area();
    let li = l.radiance(BrightnessMode::Intensity, area);
    // Intensity mode: L·A = b·c along n.
    assert!((li * area - l.c * l.b).abs().max_element() < 1e-5);
    assert_eq!(l.radiance(BrightnessMode::Radiance, area), l.c * l.b);
}
