//! Groups placed by instances (Embree instances of one BVH per group)
//! render as copies of their shapes would: a group of a sphere with a
//! brushed (anisotropic) metal and a rectangle with a textured anisotropy,
//! placed twice (once mirrored), against the same shapes written out with
//! the composed transforms; and bad `[[instances]]` name their field.

use crate::materials::load;
use glam::{Mat4, Quat, Vec3};
use plsr::render::{render, RenderOptions};

const COMMON: &str = r#"
[render]
spp = 8
max_depth = 4
seed = 3

[camera]
position = [0, -6, 3]
look_at = [0, 0, 0.5]
up = [0, 0, 1]
vfov = 45
resolution = [48, 32]

[environment]
radiance = [0.4, 0.45, 0.5]

[[lights]]
type = "point"
position = [1, -2, 4]
intensity = [20, 20, 20]

[[materials]]
name = "brushed"
type = "cook_torrance"
alpha_u = 0.05
alpha_v = 0.4
metal = "Cu"

[[materials]]
name = "paint"
type = "principled"
base_color = [0.7, 0.3, 0.2]
roughness = 0.4
anisotropic_map = { checkerboard = [0.0, 0.8], to_uv = [[4, 0, 0], [0, 4, 0]] }

[[materials]]
name = "glass"
type = "dielectric"
ior = 1.5

[[materials]]
name = "floor"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]

[[shapes]]
type = "rectangle"
material = "floor"
transform = { scale = 5 }
"#;

/// A transform as a scene file's `transform.matrix` (rows).
fn matrix(m: Mat4) -> String {
    let rows: Vec<String> = (0..4)
        .map(|r| {
            let row = m.row(r);
            format!("[{}, {}, {}, {}]", row.x, row.y, row.z, row.w)
        })
        .collect();
    format!("transform.matrix = [{}]", rows.join(", "))
}

/// The group's shapes, each placed by `placed` (and in the group
/// `group`, when given).
fn shapes(placed: Mat4, group: Option<&str>) -> String {
    let group = group.map_or(String::new(), |g| format!("group = \"{g}\"\n"));
    let card = Mat4::from_scale_rotation_translation(
        Vec3::splat(0.5),
        Quat::from_axis_angle(Vec3::X, 70f32.to_radians()),
        Vec3::new(0.0, 0.3, 0.4),
    );
    let pebble = Mat4::from_scale_rotation_translation(
        Vec3::new(0.3, 0.2, 0.25),
        Quat::from_axis_angle(Vec3::Z, 0.4),
        Vec3::new(0.5, -0.4, 0.3),
    );
    format!(
        "\n[[shapes]]\ntype = \"sphere\"\n{group}center = [0, 0, 0.9]\nradius = 0.4\n\
         material = \"brushed\"\n{}\n\
         \n[[shapes]]\ntype = \"rectangle\"\n{group}material = \"paint\"\n{}\n\
         \n[[shapes]]\ntype = \"sphere\"\n{group}material = \"glass\"\n{}\n",
        matrix(placed),
        matrix(placed * card),
        matrix(placed * pebble),
    )
}

/// Where the two instances go: a translation, and a mirror with a
/// rotation and a translation.
fn placements() -> [Mat4; 2] {
    [
        Mat4::from_translation(Vec3::new(-1.4, 0.0, 0.0)),
        Mat4::from_scale_rotation_translation(
            Vec3::new(-1.2, 1.2, 1.2),
            Quat::from_axis_angle(Vec3::Z, 30f32.to_radians()),
            Vec3::new(1.4, 0.2, 0.0),
        ),
    ]
}

#[test]
fn instances_render_as_copies_of_their_group() {
    let mut instanced = format!("{COMMON}{}", shapes(Mat4::IDENTITY, Some("thing")));
    for m in placements() {
        instanced += &format!("\n[[instances]]\ngroup = \"thing\"\n{}\n", matrix(m));
    }
    let mut copies = COMMON.to_string();
    for m in placements() {
        copies += &shapes(m, None);
    }
    let scenes = [instanced, copies].map(|text| load(&text).unwrap_or_else(|e| panic!("{e}")));
    assert_eq!(scenes[0].instancing().instances.len(), 2);
    assert_eq!(
        scenes[0].meshes().len(),
        1,
        "only the floor is outside the group"
    );
    let films = scenes.map(|s| {
        let job = s.default_job();
        render(&s, &job, &RenderOptions::default(), &|_, _| true)
            .unwrap()
            .0
    });
    let (a, b) = (&films[0].color, &films[1].color);
    let mean = b.iter().map(|c| c.element_sum() as f64).sum::<f64>() / b.len() as f64;
    assert!(mean > 0.05, "the scene is lit: {mean}");
    // Embree intersects an instance in its own space, so a few paths may
    // part at grazing hits; the images agree pixel for pixel elsewhere.
    let differing = a
        .iter()
        .zip(b)
        .filter(|(x, y)| (**x - **y).abs().max_element() > 1e-3 * (1.0 + y.max_element()))
        .count();
    assert!(
        differing * 100 <= a.len(),
        "{differing} of {} pixels differ",
        a.len()
    );
    let total = |f: &[Vec3]| f.iter().map(|c| c.element_sum() as f64).sum::<f64>();
    let ratio = total(a) / total(b);
    assert!((ratio - 1.0).abs() < 2e-3, "means differ: ratio {ratio}");
    // The object layer tells the instances apart (shape count + index).
    let ids: std::collections::BTreeSet<u32> =
        films[0].object_id.iter().map(|&i| i as u32).collect();
    assert!(ids.contains(&4) && ids.contains(&5), "{ids:?}");
}

#[test]
fn bad_instances_name_their_field() {
    let group = shapes(Mat4::IDENTITY, Some("thing"));
    for (extra, field, fault) in [
        (
            "[[instances]]\ngroup = \"thin\"".to_string(),
            "instances[0].group",
            "no shape is in group `thin` (groups: thing)",
        ),
        (
            "[[instances]]\ngroup = \"thing\"\n\
             transform.matrix = [[1, 0, 0, 0], [0, 0, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]"
                .to_string(),
            "instances[0].transform.matrix",
            "singular",
        ),
        (
            "[[instances]]\ngroup = \"thing\"\nmaterial = \"glass\"".to_string(),
            "instances[0]",
            "material",
        ),
    ] {
        let e = load(&format!("{COMMON}{group}\n{extra}\n"))
            .err()
            .unwrap()
            .to_string();
        assert!(e.contains(field) && e.contains(fault), "{extra}: {e}");
    }
    let emitting = format!(
        "{COMMON}\n[[shapes]]\ntype = \"sphere\"\ngroup = \"lamp\"\nemission = [1, 1, 1]\n"
    );
    let e = load(&emitting).err().unwrap().to_string();
    assert!(
        e.contains("shapes[1].emission") && e.contains("cannot emit"),
        "{e}"
    );
}

#[test]
fn documented_instances_example_loads_and_renders() {
    let doc = include_str!("../../docs/scene-format.md");
    let start = doc
        .find("`instances-spheres.toml`")
        .expect("the example is in the docs");
    let block = &doc[start..];
    let open = block.find("```toml\n").unwrap() + "```toml\n".len();
    let close = block[open..].find("```").unwrap();
    let scene = load(&block[open..open + close]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.instancing().instances.len(), 3);
    assert_eq!(scene.instancing().groups[0].meshes.len(), 2);
    let job = scene.default_job();
    let film = render(&scene, &job, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0;
    // Every instance shows: the object layer holds the three instances'
    // ids (3, 4, 5: after the three shapes).
    let ids: std::collections::BTreeSet<i64> = film.object_id.iter().map(|&i| i as i64).collect();
    assert!([3, 4, 5].iter().all(|i| ids.contains(i)), "{ids:?}");
}
