//! Mitsuba 3 XML scenes: a scene using every supported element renders bit
//! for bit as its hand-written plsr twin; Mitsuba's conventions (depth,
//! field of view, defaults, environment orientation) are converted; every
//! unsupported element is refused naming it and its line; `plsr import`
//! writes a scene file that renders as the XML does.

use plsr_testkit as common;

use common::films::assert_close;
use plsr::film::Film;
use plsr::render::{render, RenderOptions};
use plsr::scene::mitsuba::translate;
use plsr::scene::Scene;
use std::path::Path;
use std::process::Command;

fn render_file(path: &Path) -> Film {
    let scene = Scene::load(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let job = scene.default_job();
    render(&scene, &job, &RenderOptions::default(), &|_, _| true)
        .unwrap()
        .0
}

/// A small OBJ (a tetrahedron without normals) and an ASCII PLY (a
/// triangle) next to the scenes.
fn write_meshes(dir: &Path) {
    std::fs::write(
        dir.join("tet.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         -1 0 -1\n1 0 -1\n0 1 -1\n3 0 1 2\n",
    )
    .unwrap();
}

/// Every supported element: `$defaults`, the path integrator's depths, a
/// perspective sensor with box filter, every shape kind with matrices,
/// nested and referenced BSDFs of every kind, area, point and constant
/// emitters.
const XML: &str = r#"<?xml version="1.0"?>
<scene version="3.0.0">
  <default name="spp" value="4"/>
  <default name="res" value="24"/>
  <integrator type="path">
    <integer name="max_depth" value="5"/>
    <integer name="rr_depth" value="3"/>
  </integrator>
  <sensor type="perspective">
    <float name="fov" value="50"/>
    <string name="fov_axis" value="y"/>
    <float name="near_clip" value="0.01"/>
    <transform name="to_world">
      <lookat origin="0, 1, 4" target="0, 1, 0" up="0, 1, 0"/>
    </transform>
    <film type="hdrfilm">
      <integer name="width" value="$res"/>
      <integer name="height" value="16"/>
      <rfilter type="box"/>
    </film>
    <sampler type="independent">
      <integer name="sample_count" value="$spp"/>
      <integer name="seed" value="7"/>
    </sampler>
  </sensor>
  <bsdf type="twosided" id="floor">
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.25, 0.125"/></bsdf>
  </bsdf>
  <bsdf type="roughconductor" id="gold">
    <string name="material" value="Au"/>
    <string name="distribution" value="ggx"/>
    <float name="alpha" value="0.25"/>
  </bsdf>
  <bsdf type="twosided" id="tinted">
    <bsdf type="roughconductor">
      <float name="alpha_u" value="0.125"/>
      <float name="alpha_v" value="0.5"/>
      <rgb name="specular_reflectance" value="0.9, 0.5, 0.25"/>
    </bsdf>
  </bsdf>
  <bsdf type="principled" id="plastic">
    <rgb name="base_color" value="0.1, 0.3, 0.8"/>
    <float name="roughness" value="0.5"/>
    <float name="metallic" value="0.25"/>
    <float name="specular" value="0.5"/>
    <float name="clearcoat" value="0.4"/>
    <float name="sheen" value="0.3"/>
  </bsdf>
  <shape type="rectangle">
    <transform name="to_world">
      <matrix value="4 0 0 0  0 0 4 0  0 -4 0 0  0 0 0 1"/>
    </transform>
    <ref id="floor"/>
  </shape>
  <shape type="rectangle">
    <transform name="to_world">
      <scale value="0.5"/>
      <matrix value="1 0 0 0  0 0 -1 0  0 1 0 0  0 0 0 1"/>
      <translate x="0" y="3" z="0"/>
    </transform>
    <emitter type="area"><rgb name="radiance" value="8, 8, 6"/></emitter>
  </shape>
  <shape type="sphere">
    <point name="center" value="-1, 0.5, 0"/>
    <float name="radius" value="0.5"/>
    <ref name="bsdf" id="gold"/>
  </shape>
  <shape type="cube">
    <transform name="to_world">
      <scale value="0.25"/>
      <translate value="1, 0.25, 0"/>
    </transform>
    <ref id="plastic"/>
  </shape>
  <shape type="disk">
    <transform name="to_world">
      <translate value="0, 0.5, -1"/>
    </transform>
    <bsdf type="roughdielectric">
      <string name="int_ior" value="bk7"/>
      <float name="ext_ior" value="1"/>
      <float name="alpha" value="0.125"/>
    </bsdf>
  </shape>
  <shape type="obj">
    <string name="filename" value="tet.obj"/>
    <transform name="to_world"><translate value="0, 0, 1"/></transform>
    <ref id="tinted"/>
  </shape>
  <shape type="ply">
    <string name="filename" value="tri.ply"/>
    <bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>
  </shape>
  <emitter type="point">
    <point name="position" value="1, 2, 2"/>
    <rgb name="intensity" value="2, 2, 2"/>
  </emitter>
  <emitter type="constant">
    <rgb name="radiance" value="0.1, 0.1, 0.2"/>
  </emitter>
</scene>
"#;

/// The same scene written by hand in plsr's format.
fn twin_toml() -> String {
    // Mitsuba's bk7 inside, 1 outside; and 1.5 inside its default outside,
    // air.
    let bk7 = 1.5046f64;
    let in_air = 1.5 / 1.000277f64;
    format!(
        r#"
[render]
spp = 4
seed = 7
max_depth = 4
rr_depth = 2
light_picking = "uniform"

[camera]
position = [0, 1, 4]
look_at = [0, 1, 0]
up = [0, 1, 0]
vfov = 50
resolution = [24, 16]

[environment]
radiance = [0.1, 0.1, 0.2]

[[materials]]
name = "floor"
type = "diffuse"
reflectance = [0.5, 0.25, 0.125]

[[materials]]
name = "gold"
type = "cook_torrance"
fresnel = "conductor"
metal = "Au"
distribution = "ggx"
alpha = 0.25
two_sided = false

[[materials]]
name = "tinted"
type = "cook_torrance"
fresnel = "conductor"
metal = "none"
distribution = "beckmann"
alpha_u = 0.125
alpha_v = 0.5
specular_reflectance = [0.9, 0.5, 0.25]

[[materials]]
name = "plastic"
type = "principled"
base_color = [0.1, 0.3, 0.8]
roughness = 0.5
metallic = 0.25
specular = 0.5
clearcoat = 0.4
sheen = 0.3
two_sided = false

[[materials]]
name = "default"
type = "diffuse"
reflectance = [0.5, 0.5, 0.5]
two_sided = false

[[materials]]
name = "emitter-default"
type = "diffuse"
reflectance = [0, 0, 0]
two_sided = false

[[materials]]
name = "glass"
type = "dielectric"
ior = {bk7}
distribution = "beckmann"
alpha = 0.125

[[materials]]
name = "smooth-glass"
type = "dielectric"
ior = {in_air}

[[shapes]]
type = "rectangle"
material = "floor"
transform.matrix = [[4, 0, 0, 0], [0, 0, 4, 0], [0, -4, 0, 0], [0, 0, 0, 1]]

[[shapes]]
type = "rectangle"
material = "emitter-default"
emission = [8, 8, 6]
transform.matrix = [[0.5, 0, 0, 0], [0, 0, -0.5, 3], [0, 0.5, 0, 0], [0, 0, 0, 1]]

[[shapes]]
type = "sphere"
center = [-1, 0.5, 0]
radius = 0.5
material = "gold"

[[shapes]]
type = "cube"
material = "plastic"
transform.matrix = [[0.25, 0, 0, 1], [0, 0.25, 0, 0.25], [0, 0, 0.25, 0], [0, 0, 0, 1]]

[[shapes]]
type = "disk"
material = "glass"
transform.matrix = [[1, 0, 0, 0], [0, 1, 0, 0.5], [0, 0, 1, -1], [0, 0, 0, 1]]

[[shapes]]
type = "obj"
file = "tet.obj"
smooth_normals = true
material = "tinted"
transform.matrix = [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 1], [0, 0, 0, 1]]

[[shapes]]
type = "ply"
file = "tri.ply"
smooth_normals = true
material = "smooth-glass"

[[lights]]
type = "point"
position = [1, 2, 2]
intensity = [2, 2, 2]
"#
    )
}

#[test]
fn every_supported_element_renders_as_its_plsr_twin() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path());
    let xml = dir.path().join("scene.xml");
    std::fs::write(&xml, XML).unwrap();
    let toml = dir.path().join("twin.toml");
    std::fs::write(&toml, twin_toml()).unwrap();
    let a = render_file(&xml);
    let b = render_file(&toml);
    assert!(
        a.color.iter().any(|c| c.max_element() > 0.0),
        "the scene is black"
    );
    assert_close("XML against its twin", &a, &b, 0.0);
}

/// The translated TOML of `xml`, parsed.
fn translated(xml: &str) -> toml::Table {
    let t = translate(Path::new("test.xml"), xml).unwrap_or_else(|e| panic!("{e}"));
    toml::from_str(&t.toml).unwrap_or_else(|e| panic!("{e}\n{}", t.toml))
}

fn num(t: &toml::Table, section: &str, key: &str) -> f64 {
    let v = &t[section][key];
    v.as_float()
        .or_else(|| v.as_integer().map(|i| i as f64))
        .unwrap_or_else(|| panic!("{section}.{key} = {v}"))
}

fn vec3(t: &toml::Table, section: &str, key: &str) -> [f64; 3] {
    let a = t[section][key].as_array().unwrap();
    [0, 1, 2].map(|i| a[i].as_float().unwrap())
}

fn sensor(params: &str) -> String {
    format!(
        r#"<scene version="3.0.0"><sensor type="perspective">{params}
           <film type="hdrfilm"><integer name="width" value="300"/>
           <integer name="height" value="200"/></film></sensor></scene>"#
    )
}

#[test]
fn mitsuba_conventions_are_converted() {
    // Depth: plsr's = Mitsuba's − 1; -1 (unlimited) is plsr's largest.
    let t = translated(
        r#"<scene version="3.0.0"><integrator type="path">
           <integer name="max_depth" value="8"/></integrator></scene>"#,
    );
    assert_eq!(num(&t, "render", "max_depth"), 7.0);
    assert_eq!(num(&t, "render", "rr_depth"), 4.0, "Mitsuba's rr_depth 5");
    // Lights are picked as Mitsuba picks its emitters: each equally likely.
    assert_eq!(
        t["render"]["light_picking"].as_str(),
        Some("uniform"),
        "{t:?}"
    );
    let t = translated(r#"<scene version="3.0.0"><integrator type="path"/></scene>"#);
    assert_eq!(num(&t, "render", "max_depth"), 1024.0);

    // Field of view: along x by default; focal_length is 36 mm wide;
    // diagonal converted (Mitsuba 3.6 gives x_fov 33.697 for 40° on 3:2).
    let t = translated(&sensor(r#"<float name="fov" value="40"/>"#));
    assert_eq!(num(&t, "camera", "hfov"), 40.0);
    let t = translated(&sensor(r#"<string name="focal_length" value="50mm"/>"#));
    assert!((num(&t, "camera", "hfov") - 39.5978).abs() < 1e-4);
    let t = translated(&sensor(
        r#"<float name="fov" value="40"/><string name="fov_axis" value="diagonal"/>"#,
    ));
    let vfov = num(&t, "camera", "vfov");
    let hfov = 2.0 * ((vfov.to_radians() / 2.0).tan() * 1.5).atan().to_degrees();
    assert!((hfov - 33.697).abs() < 1e-3, "hfov {hfov}");
    let t = translated(&sensor(
        r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#,
    ));
    assert_eq!(num(&t, "camera", "vfov"), 40.0);

    // Mitsuba's defaults: Gaussian filter σ 0.5 cut at 4σ, 4 spp,
    // 768 × 576, a 0.5 grey diffuse BSDF, Beckmann α 0.1.
    let t = translated(&sensor(""));
    assert_eq!(t["film"]["filter"].as_str(), Some("gaussian"));
    assert_eq!(num(&t, "film", "filter_sigma"), 0.5);
    assert_eq!(num(&t, "film", "filter_radius"), 2.0);
    assert_eq!(num(&t, "render", "spp"), 4.0);
    let t = translated(
        r#"<scene version="3.0.0"><shape type="sphere"/>
           <shape type="sphere"><bsdf type="roughconductor"/></shape></scene>"#,
    );
    assert_eq!(
        t["camera"]["resolution"].as_array().unwrap(),
        &vec![toml::Value::Integer(768), toml::Value::Integer(576)]
    );
    let materials = t["materials"].as_array().unwrap();
    let default = &materials[0];
    assert_eq!(
        default["reflectance"].as_array().unwrap()[0].as_float(),
        Some(0.5)
    );
    let rough = &materials[1];
    assert_eq!(rough["distribution"].as_str(), Some("beckmann"));
    assert_eq!(rough["alpha"].as_float(), Some(0.1));
    assert_eq!(rough["metal"].as_str(), Some("none"));

    // The environment map's frame: Mitsuba's +y and +z through to_world.
    let t = translated(
        r#"<scene version="3.0.0"><emitter type="envmap">
           <string name="filename" value="sky.exr"/><float name="scale" value="2"/>
           <transform name="to_world"><rotate x="1" angle="90"/></transform>
           </emitter></scene>"#,
    );
    let up = vec3(&t, "environment", "up");
    let forward = vec3(&t, "environment", "forward");
    for (got, want) in [(up, [0.0, 0.0, 1.0]), (forward, [0.0, -1.0, 0.0])] {
        for i in 0..3 {
            assert!((got[i] - want[i]).abs() < 1e-12, "{got:?} vs {want:?}");
        }
    }
    assert_eq!(num(&t, "environment", "scale"), 2.0);
    assert_eq!(t["environment"]["filter"].as_str(), Some("bilinear"));
    assert_eq!(t["environment"]["rows"].as_str(), Some("poles"));

    // A camera given by a matrix: position, viewing direction and up.
    let t = translated(&sensor(
        r#"<transform name="to_world"><rotate y="1" angle="180"/>
           <translate value="1, 2, 3"/></transform>"#,
    ));
    let p = vec3(&t, "camera", "position");
    let look = vec3(&t, "camera", "look_at");
    assert_eq!(p, [1.0, 2.0, 3.0]);
    assert!((look[2] - 2.0).abs() < 1e-12 && (look[0] - 1.0).abs() < 1e-12);
}

fn error_of(xml: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.xml");
    std::fs::write(&path, xml).unwrap();
    match plsr::scene::file::load(&path) {
        Ok(_) => panic!("accepted:\n{xml}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn unsupported_elements_are_refused_by_name_and_line() {
    let cases: [(&str, &[&str]); 13] = [
        (
            "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n<bsdf type=\"pplastic\"/></shape></scene>",
            &["line 3", "<bsdf type=\"pplastic\">", "`pplastic` BSDF is not supported"],
        ),
        (
            "<scene version=\"3.0.0\"><emitter type=\"directionalarea\"/></scene>",
            &["<emitter type=\"directionalarea\">", "not supported"],
        ),
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><bsdf type=\"principled\">\n\
             <float name=\"eta\" value=\"1.5\"/><float name=\"specular\" value=\"0.5\"/>\
             </bsdf></shape></scene>",
            &["line 1", "<bsdf type=\"principled\">", "give one of `eta` and `specular`"],
        ),
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><bsdf type=\"diffuse\">\n\
             <float name=\"roughness\" value=\"0.5\"/></bsdf></shape></scene>",
            &["line 2", "`roughness` of a `diffuse` bsdf is not supported"],
        ),
        (
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\">\
             <integer name=\"width\" value=\"$w\"/></film></sensor></scene>",
            &["line 1, <integer>", "`$w` has no value", "-D w=…"],
        ),
        (
            "<scene version=\"3.0.0\"><include filename=\"other.xml\"/></scene>",
            &["<include>", "\"other.xml\" was not found"],
        ),
        ("<scene version=\"3.0.0\"><shape type=\"sphere\"></scene>", &["not well-formed XML"]),
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><emitter type=\"area\">\n\
             <float name=\"sampling_weight\" value=\"2\"/></emitter></shape></scene>",
            &["<emitter type=\"area\">", "sampling_weight = 2", "equally likely"],
        ),
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><bsdf type=\"diffuse\">\
             <spectrum name=\"reflectance\" value=\"700:0.1, 400:0.9\"/></bsdf></shape></scene>",
            &["<spectrum name=\"reflectance\">", "increasing"],
        ),
        (
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><transform name=\"to_world\">\
             <scale x=\"-1\"/></transform></sensor></scene>",
            &["mirrors the image"],
        ),
        (
            "<scene version=\"3.0.0\"><integrator type=\"path\">\
             <integer name=\"max_depth\" value=\"0\"/></integrator></scene>",
            &["max_depth = 0", "Mitsuba's − 1"],
        ),
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><ref id=\"nowhere\"/></shape></scene>",
            &["no element has id=\"nowhere\""],
        ),
        // Found by plsr's own checks, in the translation.
        (
            "<scene version=\"3.0.0\"><shape type=\"sphere\"><bsdf type=\"roughconductor\">\
             <float name=\"alpha\" value=\"9\"/></bsdf></shape></scene>",
            &["(translated scene) materials[0].alpha", "must be in [0, 4]", "plsr import"],
        ),
    ];
    for (xml, wanted) in cases {
        let e = error_of(xml);
        assert!(e.contains("bad.xml"), "{e}");
        for w in wanted {
            assert!(e.contains(w), "`{w}` not in: {e}");
        }
    }
}

#[test]
fn plsr_import_writes_a_scene_that_renders_as_the_xml() {
    let dir = tempfile::tempdir().unwrap();
    write_meshes(dir.path());
    let xml = dir.path().join("scene.xml");
    std::fs::write(&xml, XML).unwrap();
    // Into another folder: the mesh paths must still reach the meshes.
    let out_dir = tempfile::tempdir().unwrap();
    let out = out_dir.path().join("imported.toml");
    let plsr = env!("CARGO_BIN_EXE_plsr");
    let run = Command::new(plsr)
        .arg("import")
        .arg(&xml)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(&out).unwrap();
    assert!(
        text.starts_with("# Translated from Mitsuba 3 XML"),
        "{text}"
    );
    assert_close("imported", &render_file(&out), &render_file(&xml), 0.0);

    // Bad requests write nothing.
    for (args, wanted) in [
        (vec!["-o", "x.xml"], "name the file `.toml`"),
        (vec!["-o", "tet.obj"], "name the file `.toml`"),
    ] {
        let run = Command::new(plsr)
            .arg("import")
            .arg(&xml)
            .args(&args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && err.contains(wanted), "{err}");
    }
    let twin = dir.path().join("twin.toml");
    std::fs::write(&twin, twin_toml()).unwrap();
    let run = Command::new(plsr)
        .arg("import")
        .arg(&twin)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(!run.status.success() && err.contains("not XML"), "{err}");
    let files: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
    assert_eq!(
        files.len(),
        4,
        "scene.xml, twin.toml and the two meshes only"
    );
}

/// The `[[materials]]` entry named `name` of a translated scene.
fn material<'t>(t: &'t toml::Table, name: &str) -> &'t toml::Table {
    t["materials"]
        .as_array()
        .unwrap()
        .iter()
        .map(|m| m.as_table().unwrap())
        .find(|m| m["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no material `{name}` in {t}"))
}

#[test]
fn wrapper_bsdfs_become_materials_made_of_materials() {
    let t = translated(
        r#"<scene version="3.0.0">
        <bsdf type="blendbsdf" id="mix"><float name="weight" value="0.3"/>
          <bsdf type="diffuse" id="a"/><bsdf type="roughconductor" id="b"/></bsdf>
        <bsdf type="mask" id="leaf"><rgb name="opacity" value="0.2, 0.4, 0.6"/>
          <bsdf type="twosided" id="card"><bsdf type="diffuse" id="front"/>
          <bsdf type="diffuse" id="behind"><rgb name="reflectance" value="0.1"/></bsdf></bsdf></bsdf>
        <bsdf type="bumpmap" id="bumpy"><float name="scale" value="0.5"/>
          <texture type="bitmap" name="h"><string name="filename" value="h.png"/>
          <boolean name="raw" value="true"/></texture>
          <bsdf type="diffuse"/></bsdf>
        <bsdf type="null" id="nothing"/>
        <shape type="sphere"><ref id="mix"/></shape>
        <shape type="sphere"><ref id="leaf"/></shape>
        <shape type="sphere"><ref id="bumpy"/></shape>
        <shape type="sphere"><ref id="nothing"/></shape>
        </scene>"#,
    );
    let mix = material(&t, "mix");
    assert_eq!(mix["type"].as_str(), Some("blend"));
    assert_eq!(mix["materials"].as_array().unwrap().len(), 2);
    assert_eq!(mix["weight"].as_float(), Some(0.3));
    let leaf = material(&t, "leaf");
    assert_eq!(leaf["type"].as_str(), Some("mask"));
    assert_eq!(leaf["material"].as_str(), Some("card"));
    // Mitsuba's eval_1 of an RGB constant: the mean.
    assert!((leaf["opacity"].as_float().unwrap() - 0.4).abs() < 1e-9);
    let card = material(&t, "card");
    assert_eq!(card["back"].as_str(), Some("behind"));
    assert_eq!(card["type"].as_str(), Some("diffuse"));
    let bumpy = material(&t, "bumpy");
    assert_eq!(bumpy["bump_scale"].as_float(), Some(0.5));
    assert_eq!(bumpy["normal_shadowing"].as_bool(), Some(true));
    assert!(bumpy["bump_map"].as_str().unwrap().ends_with("h.png"));
    assert_eq!(material(&t, "nothing")["type"].as_str(), Some("null"));

    for (xml, wanted) in [
        (
            r#"<bsdf type="blendbsdf"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "`weight` is required",
        ),
        (
            r#"<bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "a mask holds one BSDF",
        ),
        (
            r#"<bsdf type="bumpmap"><bsdf type="diffuse"/></bsdf>"#,
            "one height <texture>",
        ),
        (
            r#"<bsdf type="twosided"><bsdf type="diffuse"/><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf>"#,
            "one or two BSDFs",
        ),
    ] {
        let e = error_of(&format!(
            "<scene version=\"3.0.0\"><shape type=\"sphere\">{xml}</shape></scene>"
        ));
        assert!(e.contains(wanted), "`{wanted}` not in: {e}");
    }
}

#[test]
fn textured_roughness_and_named_conductors_are_mitsubas() {
    let t = translated(
        r#"<scene version="3.0.0">
        <bsdf type="roughconductor" id="carbon"><string name="material" value="a-C"/>
          <texture name="alpha_u" type="checkerboard"><float name="color0" value="0.05"/>
          <float name="color1" value="0.3"/></texture>
          <texture name="alpha_v" type="checkerboard"><float name="color0" value="0.3"/>
          <float name="color1" value="0.05"/></texture></bsdf>
        <shape type="sphere"><ref id="carbon"/></shape></scene>"#,
    );
    let m = material(&t, "carbon");
    // Mitsuba's own RGB value of its amorphous carbon data.
    let eta = m["eta"].as_array().unwrap();
    assert!((eta[0].as_float().unwrap() - 2.94405).abs() < 1e-5, "{m}");
    // A checkerboard read as a scalar has its colours the other way round
    // in Mitsuba (eval_1 against eval): color1 first.
    let first = |key: &str| m[key]["checkerboard"][0][0].as_float().unwrap();
    assert_eq!(
        (first("alpha_u_map"), first("alpha_v_map")),
        (0.3, 0.05),
        "{m}"
    );
    let e = error_of(
        r#"<scene version="3.0.0"><shape type="sphere"><bsdf type="roughconductor">
        <string name="material" value="unobtainium"/></bsdf></shape></scene>"#,
    );
    assert!(e.contains("not one of Mitsuba's named conductors"), "{e}");
}

#[test]
fn instances_place_their_shapegroups_shapes() {
    let t = translated(
        r#"<scene version="3.0.0">
        <shape type="shapegroup" id="g">
          <shape type="sphere"><transform name="to_world"><translate x="1"/></transform></shape>
          <shape type="cube"/></shape>
        <shape type="instance"><ref id="g"/>
          <transform name="to_world"><scale value="2"/></transform></shape>
        <shape type="instance"><ref id="g"/></shape>
        </scene>"#,
    );
    // The group's two shapes written once, in the group's space, and two
    // instances placing them (the identity written as no transform).
    let shapes = t["shapes"].as_array().unwrap();
    assert_eq!(shapes.len(), 2, "{t}");
    assert!(
        shapes.iter().all(|s| s["group"].as_str() == Some("g")),
        "{t}"
    );
    let m = shapes[0]["transform"]["matrix"].as_array().unwrap();
    assert_eq!(m[0].as_array().unwrap()[3].as_float(), Some(1.0), "{m:?}");
    let instances = t["instances"].as_array().unwrap();
    assert_eq!(instances.len(), 2, "{t}");
    assert!(instances.iter().all(|i| i["group"].as_str() == Some("g")));
    let m = instances[0]["transform"]["matrix"].as_array().unwrap();
    assert_eq!(m[0].as_array().unwrap()[0].as_float(), Some(2.0), "{m:?}");
    assert!(instances[1].get("transform").is_none(), "{t}");
    for (xml, wanted) in [
        (
            r#"<shape type="shapegroup" id="g"><shape type="sphere"><emitter type="area"/></shape></shape>
               <shape type="instance"><ref id="g"/></shape>"#,
            "cannot emit",
        ),
        (
            r#"<shape type="shapegroup" id="g"><shape type="sphere"/></shape>
               <shape type="instance"><ref id="g"/><bsdf type="diffuse"/></shape>"#,
            "one shapegroup (by <ref>) and nothing else",
        ),
        (
            r#"<shape type="shapegroup" id="g"><shape type="shapegroup"/></shape>"#,
            "inside a shapegroup is refused",
        ),
        (
            r#"<shape type="instance"/>"#,
            "needs a <ref> to a shapegroup",
        ),
    ] {
        let e = error_of(&format!("<scene version=\"3.0.0\">{xml}</scene>"));
        assert!(e.contains(wanted), "`{wanted}` not in: {e}");
    }
}
