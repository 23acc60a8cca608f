//! Curves (`type = "curves"`, Mitsuba's `bsplinecurve` and `linearcurve`):
//! a straight tube covers exactly its diameter in the image, its inside
//! lets rays through, the transform leaves radii alone, and bad keys and
//! files name their field. (Mitsuba's own images of its curve scenes are
//! the z-test fixtures of `mitsuba_parity.rs`.)

use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;

/// A scene around a curve file `curve` (written beside it) and a shape
/// entry `shape`, looked at from straight above by a 64×64 camera whose
/// view is 4 units wide at the curve (z = 0).
fn curve_scene(curve: &str, shape: &str) -> plsr::Result<Scene> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("curve.txt"), curve).unwrap();
    let text = format!(
        r#"
[render]
spp = 4
max_depth = 2

[camera]
position = [0, 0, 10]
look_at = [0, 0, 0]
up = [0, 1, 0]
hfov = {fov}
resolution = [64, 64]

[environment]
radiance = [1, 1, 1]

[[shapes]]
type = "curves"
file = "curve.txt"
{shape}
"#,
        fov = 2.0 * (0.2f32).atan().to_degrees()
    );
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path)
}

/// Rows of the middle column that the curve covers (object layer).
fn covered_rows(scene: &Scene) -> usize {
    let film = render(
        scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    (0..64)
        .filter(|&y| film.object_id[y * 64 + 32] >= 0.0)
        .count()
}

const STRAIGHT: &str = "-3 0 0 0.5\n-1 0 0 0.5\n1 0 0 0.5\n3 0 0 0.5\n";

#[test]
fn a_straight_tube_covers_its_diameter() {
    // Radius 0.5 in a view 4 units (64 pixels) wide: 16 pixels.
    let scene = curve_scene(STRAIGHT, "").unwrap();
    let rows = covered_rows(&scene);
    assert!((15..=17).contains(&rows), "{rows} rows");
    // Scaled by 2 across: the control points move, the radius does not.
    let scene = curve_scene(STRAIGHT, "transform = { scale = [1, 2, 2] }").unwrap();
    let rows = covered_rows(&scene);
    assert!((15..=17).contains(&rows), "{rows} rows");
    // As a polyline, the same.
    let scene = curve_scene(STRAIGHT, "basis = \"linear\"").unwrap();
    assert!((15..=17).contains(&covered_rows(&scene)));
}

#[test]
fn the_inside_of_a_tube_lets_rays_through() {
    // A camera inside the tube, looking along it to its open end and
    // across it through its wall: nothing is hit (Mitsuba culls the
    // inside of its curves).
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("curve.txt"), STRAIGHT).unwrap();
    let text = r#"
[render]
spp = 1
[camera]
position = [0, 0, 0]
look_at = [1, 0.3, 0.2]
up = [0, 0, 1]
hfov = 120
resolution = [16, 16]
[[shapes]]
type = "curves"
file = "curve.txt"
"#;
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap();
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    assert!(film.object_id.iter().all(|&i| i < 0.0));
}

#[test]
fn bad_curves_name_their_field() {
    let e = curve_scene(STRAIGHT, "basis = \"bezier\"")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shapes[0].basis") && e.contains("bezier"), "{e}");
    let e = curve_scene(STRAIGHT, "sides = 2")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shapes[0].sides"), "{e}");
    let e = curve_scene("0 0 0 0.1\n1 0 0 0.1\n", "")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("shapes[0].file") && e.contains("at least 4"),
        "{e}"
    );
    let e = curve_scene("0 0 0 0.1\n1 0 x 0.1\n", "basis = \"linear\"")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("line 2") && e.contains("`x`"), "{e}");
    // 37 segments × 1024 rings × 2048 triangles: more than the cap, refused
    // before any is made.
    let long: String = (0..40).map(|i| format!("{i} 0 0 0.1\n")).collect();
    let e = curve_scene(&long, "sides = 1024\nsteps = 1024")
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("shapes[0].file") && e.contains("triangles"),
        "{e}"
    );
}
