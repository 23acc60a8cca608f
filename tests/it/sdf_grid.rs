//! Signed-distance grids (`type = "sdf_grid"`, Mitsuba's `sdfgrid`): a
//! sphere's grid, read from a Mitsuba volume file, covers the sphere's
//! silhouette, and bad keys and files name their field. (Mitsuba's own
//! image of its torus grid is a z-test fixture of `mitsuba_parity.rs`.)

use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;

/// A Mitsuba volume file of an `n³` grid of the signed distance to a
/// sphere of radius 0.3 at the unit cube's centre.
fn sphere_vol(n: usize) -> Vec<u8> {
    let mut b = b"VOL\x03".to_vec();
    for v in [1, n as i32, n as i32, n as i32, 1] {
        b.extend(v.to_le_bytes());
    }
    for v in [0.0f32, 0.0, 0.0, 1.0, 1.0, 1.0] {
        b.extend(v.to_le_bytes());
    }
    for k in 0..n {
        for j in 0..n {
            for i in 0..n {
                let p = glam::Vec3::new(i as f32, j as f32, k as f32) / (n - 1) as f32;
                b.extend(((p - glam::Vec3::splat(0.5)).length() - 0.3).to_le_bytes());
            }
        }
    }
    b
}

/// The grid (scaled by 4 about the origin: a sphere of radius 1.2) seen
/// from 10 units above by a 64×64 camera 4 units wide at z = 0.
fn sdf_scene(vol: &[u8], keys: &str) -> plsr::Result<Scene> {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("sphere.vol"), vol).unwrap();
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
type = "sdf_grid"
file = "sphere.vol"
transform = {{ scale = 4, translate = [-2, -2, -2] }}
{keys}
"#,
        fov = 2.0 * (0.2f32).atan().to_degrees()
    );
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path)
}

#[test]
fn a_sphere_grid_covers_the_spheres_silhouette() {
    for keys in ["", "normals = \"analytic\"\nsubdivisions = 3"] {
        let scene = sdf_scene(&sphere_vol(16), keys).unwrap();
        let film = render(
            &scene,
            &scene.default_job(),
            &RenderOptions::default(),
            &|_, _| true,
        )
        .unwrap()
        .0;
        // Seen from 10 units, the sphere of radius 1.2 spans
        // 2·10·tan(asin 0.12) = 2.42 units of the 4 across: 38.7 pixels
        // (the trilinear sphere is up to 1 % smaller).
        let rows = (0..64)
            .filter(|&y| film.object_id[y * 64 + 32] >= 0.0)
            .count();
        assert!((37..=40).contains(&rows), "{keys}: {rows} rows");
    }
}

#[test]
fn bad_sdf_grids_name_their_field() {
    let e = sdf_scene(&sphere_vol(8), "normals = \"flat\"")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shapes[0].normals") && e.contains("flat"), "{e}");
    let e = sdf_scene(&sphere_vol(8), "subdivisions = 9")
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("shapes[0].subdivisions"), "{e}");
    let mut truncated = sphere_vol(8);
    truncated.truncate(100);
    let e = sdf_scene(&truncated, "").err().unwrap().to_string();
    assert!(
        e.contains("shapes[0].file") && e.contains("bytes of data"),
        "{e}"
    );
    // A grid without a sign change has no surface.
    let mut outside = sphere_vol(4);
    for b in outside[48..].chunks_exact_mut(4) {
        b.copy_from_slice(&1.0f32.to_le_bytes());
    }
    let e = sdf_scene(&outside, "").err().unwrap().to_string();
    assert!(e.contains("no surface"), "{e}");
}
