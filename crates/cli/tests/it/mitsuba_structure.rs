//! Mitsuba scenes as Mitsuba's parser reads them: `<path>`, `<include>`,
//! `<default>` with `$name` and `-D`, `<ref>` and `<alias>` anywhere, the
//! integrators that wrap or stand for the path tracer, sampled spectra as
//! Mitsuba's RGB variants convert them, `serialized` meshes; Mitsuba's own
//! documentation scenes (copied in `tests/data/realworld/mitsuba/`); and
//! every structural fault refused naming the file and line.

use plsr::scene::mitsuba::{translate_with, Options, MAX_NESTING};
use std::path::Path;
use std::process::Command;

const DOCS: &str = "tests/data/realworld/mitsuba/docs/scenes";

fn options(defines: &[(&str, &str)]) -> Options {
    Options {
        defines: defines
            .iter()
            .map(|(n, v)| (n.to_string(), v.to_string()))
            .collect(),
        time: None,
    }
}

/// The translation of the scene file `path` as a TOML table, and its notes.
fn translation(path: &Path, defines: &[(&str, &str)]) -> (toml::Table, Vec<String>) {
    let text = std::fs::read_to_string(path).unwrap();
    let t = translate_with(path, &text, &options(defines))
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (toml::from_str(&t.toml).unwrap(), t.notes)
}

fn error_of(path: &Path, defines: &[(&str, &str)]) -> String {
    let text = std::fs::read_to_string(path).unwrap();
    match translate_with(path, &text, &options(defines)) {
        Ok(t) => panic!("accepted:\n{}", t.toml),
        Err(e) => e.to_string(),
    }
}

fn array<'t>(t: &'t toml::Table, key: &str) -> &'t Vec<toml::Value> {
    t[key].as_array().unwrap()
}

fn floats(v: &toml::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_float().unwrap())
        .collect()
}

fn material<'t>(t: &'t toml::Table, name: &str) -> &'t toml::Table {
    array(t, "materials")
        .iter()
        .map(|m| m.as_table().unwrap())
        .find(|m| m["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no material {name}"))
}

fn assert_rgb(got: &[f64], want: [f64; 3], what: &str) {
    for (g, w) in got.iter().zip(want) {
        assert!(
            (g - w).abs() <= 1e-5 * w.abs().max(1.0),
            "{what}: {got:?} ≠ {want:?}"
        );
    }
}

#[test]
fn mitsubas_cornell_box_loads_with_its_path_defaults_and_spectra() {
    let scene = Path::new(DOCS).join("variants_cbox_rgb.xml");
    let (t, _) = translation(&scene, &[("spp", "3"), ("max_depth", "4")]);
    // `-D` wins over the scene's <default>s; Mitsuba's depth is plsr's + 1.
    assert_eq!(t["render"]["spp"].as_integer(), Some(3));
    assert_eq!(t["render"]["max_depth"].as_integer(), Some(3));
    // File names are found through <path value="../../common"/>.
    let first_mesh = array(&t, "shapes")[0].as_table().unwrap();
    assert_eq!(
        first_mesh["file"].as_str(),
        Some("../../common/meshes/cbox/luminaire.obj")
    );
    // Sampled spectra become the RGB Mitsuba 3.9.1's `scalar_rgb` gives
    // them (reflectances under D65, emission as it is).
    assert_rgb(
        &floats(&material(&t, "white")["reflectance"]),
        [0.735013, 0.735625, 0.736264],
        "white",
    );
    assert_rgb(
        &floats(&material(&t, "red")["reflectance"]),
        [0.491320, 0.049228, 0.050922],
        "red",
    );
    assert_rgb(
        &floats(&material(&t, "green")["reflectance"]),
        [0.068283, 0.397760, 0.086291],
        "green",
    );
    let light = array(&t, "shapes")
        .iter()
        .map(|s| s.as_table().unwrap())
        .find(|s| s.contains_key("emission"))
        .unwrap();
    assert_rgb(
        &floats(&light["emission"]),
        [20.71084, 10.85463, 2.77115],
        "the light's radiance",
    );
    // The translation builds: every mesh is found.
    let contents =
        plsr::scene::file::load_contents_with(&scene, &options(&[("spp", "1")])).unwrap();
    assert_eq!(contents.description.meshes.len(), 8);
    // Without the -D the scene's own defaults hold.
    let (t, _) = translation(&scene, &[]);
    assert_eq!(t["render"]["spp"].as_integer(), Some(256));
    assert_eq!(t["render"]["max_depth"].as_integer(), Some(5));
}

#[test]
fn includes_paths_defaults_and_references_as_mitsuba_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("assets")).unwrap();
    std::fs::create_dir_all(d.join("parts")).unwrap();
    std::fs::write(
        d.join("assets/tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         -1 0 -1\n1 0 -1\n0 1 -1\n3 0 1 2\n",
    )
    .unwrap();
    // An included scene: its <default> does not replace the includer's, and
    // its BSDF is referred to before it is defined (Mitsuba resolves
    // references after reading everything).
    std::fs::write(
        d.join("parts/materials.xml"),
        r#"<scene version="3.0.0">
  <default name="grey" value="0.9"/>
  <default name="spp_extra" value="7"/>
  <bsdf type="diffuse" id="matte"><rgb name="reflectance" value="$grey"/></bsdf>
</scene>"#,
    )
    .unwrap();
    // An included object (its root is not a <scene>).
    std::fs::write(
        d.join("parts/light.xml"),
        r#"<emitter type="point"><point name="position" value="0, 2, 0"/>
  <rgb name="intensity" value="$power"/></emitter>"#,
    )
    .unwrap();
    let scene = d.join("scene.xml");
    std::fs::write(
        &scene,
        r#"<?xml version="1.0"?>
<scene version="2.1.0">
  <path value="assets"/>
  <default name="grey" value="0.25"/>
  <default name="power" value="5"/>
  <default name="spp" value="2"/>
  <default name="note" value="costs \$5"/>
  <shape type="ply">
    <string name="filename" value="tri.ply"/>
    <string name="label" value="$note"/>
    <ref name="bsdf" id="flat"/>
  </shape>
  <alias id="matte" as="flat"/>
  <include filename="parts/materials.xml"/>
  <include filename="parts/light.xml"/>
  <sensor type="perspective">
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
  </sensor>
</scene>"#,
    )
    .unwrap();
    let err = error_of(&scene, &[]);
    // The `label` string is not a ply parameter: refused, its `$note`
    // substituted with the escaped `$` kept.
    assert!(
        err.contains("`label` of a `ply` shape is not supported"),
        "{err}"
    );
    let text = std::fs::read_to_string(&scene)
        .unwrap()
        .replace("    <string name=\"label\" value=\"$note\"/>\n", "");
    std::fs::write(&scene, text).unwrap();
    let (t, notes) = translation(&scene, &[]);
    let shape = array(&t, "shapes")[0].as_table().unwrap();
    assert_eq!(shape["file"].as_str(), Some("assets/tri.ply"));
    assert_eq!(shape["material"].as_str(), Some("matte"));
    assert_eq!(floats(&material(&t, "matte")["reflectance"]), [0.25; 3]);
    let light = array(&t, "lights")[0].as_table().unwrap();
    assert_eq!(floats(&light["intensity"]), [5.0; 3]);
    assert_eq!(t["render"]["spp"].as_integer(), Some(2));
    assert!(notes.iter().all(|n| !n.contains("-D")), "{notes:?}");

    // -D replaces the <default>s, in the included file too; one that
    // nothing uses is noted.
    let (t, notes) = translation(&scene, &[("grey", "0.5"), ("spp", "4"), ("unused", "1")]);
    assert_eq!(floats(&material(&t, "matte")["reflectance"]), [0.5; 3]);
    assert_eq!(t["render"]["spp"].as_integer(), Some(4));
    assert!(
        notes
            .iter()
            .any(|n| n.contains("-D unused=1") && n.contains("changes nothing")),
        "{notes:?}"
    );
    // The included files are inputs of the scene (a render's output may
    // not replace them; parts hash them).
    let contents = plsr::scene::file::load_contents_with(&scene, &options(&[])).unwrap();
    for f in ["parts/materials.xml", "parts/light.xml", "assets/tri.ply"] {
        assert!(
            contents.inputs.iter().any(|i| i.ends_with(f)),
            "{f} not in {:?}",
            contents.inputs
        );
    }
}

#[test]
fn integrators_that_wrap_or_stand_for_the_path_tracer() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    let with = |integrator: &str| {
        std::fs::write(
            &scene,
            format!("<scene version=\"3.0.0\">{integrator}<shape type=\"sphere\"/></scene>"),
        )
        .unwrap();
        translation(&scene, &[])
    };
    let (t, notes) = with(
        r#"<integrator type="moment"><integrator type="path">
             <integer name="max_depth" value="4"/></integrator></integrator>"#,
    );
    assert_eq!(t["render"]["max_depth"].as_integer(), Some(3));
    assert!(notes.iter().any(|n| n.contains("variance")), "{notes:?}");
    let (t, notes) = with(
        r#"<integrator type="aov"><string name="aovs" value="dd.y:depth, nn:sh_normal, p:position"/>
             <integrator type="path" name="image"><integer name="max_depth" value="3"/></integrator>
           </integrator>"#,
    );
    assert_eq!(t["render"]["max_depth"].as_integer(), Some(2));
    let all = notes.join("\n");
    assert!(all.contains("`dd.y:depth` is plsr's EXR layer Z"), "{all}");
    assert!(
        all.contains("`nn:sh_normal` is plsr's EXR layer normal"),
        "{all}"
    );
    assert!(
        all.contains("`p:position`: plsr's EXR has no such layer"),
        "{all}"
    );
    for kind in ["volpath", "ptracer", "prb", "prb_projective"] {
        let (t, notes) = with(&format!(
            "<integrator type=\"{kind}\"><integer name=\"max_depth\" value=\"6\"/></integrator>"
        ));
        assert_eq!(t["render"]["max_depth"].as_integer(), Some(5), "{kind}");
        assert!(
            notes
                .iter()
                .any(|n| n.contains(&format!("the `{kind}` integrator"))),
            "{kind}: {notes:?}"
        );
    }
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<integrator type=\"stokes\"/></scene>",
    )
    .unwrap();
    let err = error_of(&scene, &[]);
    assert!(
        err.contains("line 2") && err.contains("`stokes` integrator is not supported"),
        "{err}"
    );
}

#[test]
fn structural_faults_are_refused_naming_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, text: &str| {
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let check = |path: &Path, defines: &[(&str, &str)], wanted: &[&str]| {
        let e = error_of(path, defines);
        for w in wanted {
            assert!(e.contains(w), "`{w}` not in: {e}");
        }
    };
    // An include loop, named as a chain.
    write(
        "a.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/></scene>",
    );
    write(
        "b.xml",
        "<scene version=\"3.0.0\">\n\n<include filename=\"a.xml\"/></scene>",
    );
    check(
        &d.join("a.xml"),
        &[],
        &[
            "b.xml",
            "line 3, <include>",
            "an include loop",
            "a.xml → ",
            "b.xml → ",
            "a.xml",
        ],
    );
    // A missing include, and a missing <path> folder.
    let p = write(
        "missing.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"nowhere/x.xml\"/></scene>",
    );
    check(
        &p,
        &[],
        &[
            "missing.xml",
            "line 2, <include>",
            "\"nowhere/x.xml\" was not found",
        ],
    );
    let p = write(
        "nofolder.xml",
        "<scene version=\"3.0.0\">\n<path value=\"no_such_folder\"/></scene>",
    );
    check(
        &p,
        &[],
        &["line 2, <path>", "\"no_such_folder\" does not exist"],
    );
    let p = write(
        "deep_path.xml",
        "<scene version=\"3.0.0\"><shape type=\"sphere\">\n<path value=\".\"/></shape></scene>",
    );
    check(&p, &[], &["line 2, <path>", "directly inside the <scene>"]);
    // A $name without a value.
    let p = write(
        "undefined.xml",
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n\
         <float name=\"radius\" value=\"$r\"/></shape></scene>",
    );
    check(&p, &[], &["line 3, <float>", "`$r` has no value", "-D r="]);
    // Defaults defined through each other double at each step: 41 of them
    // would make 2⁴¹ bytes; the expansion is capped.
    let mut chained =
        String::from("<scene version=\"3.0.0\">\n<default name=\"d0\" value=\"xx\"/>\n");
    for i in 1..=41 {
        chained.push_str(&format!(
            "<default name=\"d{i}\" value=\"$d{}$d{}\"/>\n",
            i - 1,
            i - 1
        ));
    }
    chained.push_str("<shape type=\"sphere\"><string name=\"s\" value=\"$d41\"/></shape></scene>");
    let p = write("chained.xml", &chained);
    check(
        &p,
        &[],
        &["chained.xml", "<default>", "longer than plsr accepts"],
    );
    // XML nested 100 000 deep: refused before any tree is built.
    let deep = format!(
        "<scene version=\"3.0.0\">{}{}</scene>",
        "<shape>".repeat(100_000),
        "</shape>".repeat(100_000)
    );
    let p = write("deep.xml", &deep);
    check(&p, &[], &[&format!("nested more than {MAX_NESTING} deep")]);
    // Versions plsr does not read, and a duplicate id.
    let p = write(
        "old.xml",
        "<scene version=\"0.6.0\"><shape type=\"sphere\"/></scene>",
    );
    check(&p, &[], &["version=\"0.6.0\"", "Mitsuba 2 and 3"]);
    let p = write(
        "twice.xml",
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\" id=\"m\"/>\n\
         <bsdf type=\"diffuse\" id=\"m\"/></scene>",
    );
    check(&p, &[], &["line 2", "id=\"m\" is used twice"]);
    // A -D with a name that cannot be a parameter.
    let p = write(
        "ok.xml",
        "<scene version=\"3.0.0\"><shape type=\"sphere\"/></scene>",
    );
    check(
        &p,
        &[("a-b", "1")],
        &["-D a-b=1", "letters, digits and `_`"],
    );
}

#[test]
fn serialized_meshes_are_read_by_shape_index() {
    let dir = tempfile::tempdir().unwrap();
    let mesh =
        std::fs::canonicalize("tests/data/realworld/mitsuba/common/meshes/matpreview.serialized")
            .unwrap();
    let scene = dir.path().join("s.xml");
    let with_index = |i: i64| {
        std::fs::write(
            &scene,
            format!(
                "<scene version=\"3.0.0\"><shape type=\"serialized\">\n\
                 <string name=\"filename\" value=\"{}\"/>\n\
                 <integer name=\"shape_index\" value=\"{i}\"/></shape></scene>",
                mesh.display()
            ),
        )
        .unwrap();
        plsr::scene::file::load_contents(&scene)
    };
    // Mitsuba 3.9.1 reports 289, 2078 and 29439 vertices for shapes 0–2.
    for (i, vertices) in [(0, 289), (1, 2078), (2, 29439)] {
        let c = with_index(i).unwrap();
        assert_eq!(
            c.description.meshes[0].positions.len(),
            vertices,
            "shape {i}"
        );
    }
    let e = with_index(3).unwrap_err().to_string();
    assert!(
        e.contains("shapes[0].shape_index") && e.contains("the file holds 3 shapes"),
        "{e}"
    );
}

#[test]
fn plsr_render_and_import_take_mitsubas_d_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0"><default name="spp" value="64"/>
  <sensor type="perspective"><transform name="to_world"><lookat origin="0,0,-4" target="0,0,0" up="0,1,0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
    <film type="hdrfilm"><integer name="width" value="6"/><integer name="height" value="4"/></film></sensor>
  <emitter type="constant"/><shape type="sphere"/></scene>"#,
    )
    .unwrap();
    let plsr = env!("CARGO_BIN_EXE_plsr");
    let out = dir.path().join("out.exr");
    let run = Command::new(plsr)
        .args(["render", "-D", "spp=2"])
        .arg(&scene)
        .arg("-o")
        .arg(&out)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let film = plsr::film::Film::read_exr(&out).unwrap();
    assert_eq!(film.spp, 2);
    let run = Command::new(plsr)
        .arg("import")
        .arg(&scene)
        .args(["-D", "spp=5"])
        .output()
        .unwrap();
    let toml = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success() && toml.contains("spp = 5"), "{toml}");
    for (arg, wanted) in [("spp", "not NAME=VALUE"), ("s-p=1", "letters, digits")] {
        let run = Command::new(plsr)
            .arg("import")
            .arg(&scene)
            .args(["-D", arg])
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&run.stderr);
        assert!(!run.status.success() && err.contains(wanted), "{err}");
    }
    // -D is for Mitsuba scenes only.
    let toml_scene = dir.path().join("s.toml");
    std::fs::write(&toml_scene, toml.as_bytes()).unwrap();
    let run = Command::new(plsr)
        .args(["render", "-D", "spp=2"])
        .arg(&toml_scene)
        .arg("-o")
        .arg(dir.path().join("o2.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        !run.status.success() && err.contains("parameters are for Mitsuba XML"),
        "{err}"
    );
}

#[test]
fn a_checkerboard_lands_where_mitsuba_puts_it() {
    // The rectangle [-1, 1]² fills an 8 × 8 image seen head-on from +z;
    // Mitsuba's uv there is ((x + 1)/2, (y + 1)/2), and its checkerboard
    // scaled by 2 is color0 where frac(2u) > ½ and frac(2v) > ½ agree.
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("checker.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="53.13010235415598"/>
    <transform name="to_world"><lookat origin="0, 0, 2" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/>
      <rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
  </sensor>
  <emitter type="constant"/>
  <shape type="rectangle">
    <bsdf type="diffuse">
      <texture type="checkerboard" name="reflectance">
        <rgb name="color0" value="0.2"/><rgb name="color1" value="0.6"/>
        <transform name="to_uv"><scale x="2" y="2"/></transform>
      </texture>
    </bsdf>
  </shape>
</scene>"#,
    )
    .unwrap();
    let (t, _) = translation(&scene, &[]);
    let shape = array(&t, "shapes")[0].as_table().unwrap();
    assert_eq!(shape["flip_v"].as_bool(), Some(true));
    let s = plsr::scene::Scene::load(&scene).unwrap();
    let film = plsr::render::render(
        &s,
        &s.default_job(),
        &plsr::render::RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    for j in 0..8 {
        for i in 0..8 {
            let x = -1.0 + (i as f64 + 0.5) / 4.0;
            let y = 1.0 - (j as f64 + 0.5) / 4.0;
            let (su, sv) = (x + 1.0, y + 1.0);
            let agree = (su - su.floor() > 0.5) == (sv - sv.floor() > 0.5);
            let want = if agree { 0.2 } else { 0.6 };
            let got = film.albedo[j * 8 + i];
            assert!(
                (got.x as f64 - want).abs() < 1e-5,
                "pixel ({i}, {j}) at ({x}, {y}): albedo {got}, Mitsuba's {want}"
            );
        }
    }
}

/// A shape without a BSDF gets Mitsuba's default: a one-sided diffuse 0.5
/// grey, black on a shape that emits (Mitsuba's `Shape` sets the default's
/// reflectance to 0 there: its sphere-light scenes show no reflection on
/// the light).
#[test]
fn shapes_without_a_bsdf_get_mitsubas_default_black_on_lights() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\"/>\n\
         <shape type=\"sphere\"><emitter type=\"area\"><rgb name=\"radiance\" value=\"20\"/></emitter></shape>\n\
         </scene>",
    )
    .unwrap();
    let (t, _) = translation(&scene, &[]);
    let shapes = array(&t, "shapes");
    let of = |i: usize| material(&t, shapes[i]["material"].as_str().unwrap());
    assert_eq!(floats(&of(0)["reflectance"]), vec![0.5; 3]);
    assert_eq!(floats(&of(1)["reflectance"]), vec![0.0; 3]);
    assert_eq!(of(1)["two_sided"].as_bool(), Some(false));
}

/// Mitsuba's `spot`: at `to_world`'s origin, its beam along `to_world`'s
/// +z, `beam_width` ¾ of the cutoff by default; a `texture` is refused
/// naming its line.
#[test]
fn spot_lights_are_placed_and_aimed_as_mitsuba_does() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<emitter type=\"spot\">\n\
         <rgb name=\"intensity\" value=\"200, 0, 0\"/>\n<float name=\"cutoff_angle\" value=\"20\"/>\n\
         <transform name=\"to_world\"><lookat origin=\"4, 0, 3.5\" target=\"0, 0, 1\" up=\"-1, 0, 0\"/></transform>\n\
         </emitter>\n</scene>",
    )
    .unwrap();
    let (t, _) = translation(&scene, &[]);
    let l = array(&t, "lights")[0].as_table().unwrap();
    assert_eq!(l["type"].as_str(), Some("spot"));
    assert_rgb(&floats(&l["position"]), [4.0, 0.0, 3.5], "position");
    let d = floats(&l["direction"]);
    let want = [-4.0, 0.0, -2.5].map(|x: f64| x / (16.0f64 + 6.25).sqrt());
    assert_rgb(&d, want, "direction");
    assert_eq!(l["cutoff_angle"].as_float(), Some(20.0));
    assert_eq!(l["beam_width"].as_float(), Some(15.0));
    // A texture: the image, with the frame's +y as its up.
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<emitter type=\"spot\">\n\
         <texture type=\"bitmap\" name=\"texture\"><string name=\"filename\" value=\"x.png\"/></texture>\n\
         <transform name=\"to_world\"><lookat origin=\"0, 0, 3\" target=\"0, 0, 0\" up=\"0, 1, 0\"/></transform>\n\
         </emitter>\n</scene>",
    )
    .unwrap();
    let (t, _) = translation(&scene, &[]);
    let l = array(&t, "lights")[0].as_table().unwrap();
    assert!(l["intensity_map"].as_str().unwrap().ends_with("x.png"));
    assert_rgb(&floats(&l["up"]), [0.0, 1.0, 0.0], "up");
    // A constant is refused (Mitsuba wants a varying texture), and so is a
    // frame with a scale.
    for (inner, says) in [
        ("<rgb name=\"texture\" value=\"0.5\"/>", "must vary"),
        (
            "<texture type=\"bitmap\" name=\"texture\"><string name=\"filename\" value=\"x.png\"/></texture>\n\
             <transform name=\"to_world\"><scale value=\"2\"/></transform>",
            "rotation and a translation",
        ),
    ] {
        std::fs::write(
            &scene,
            format!("<scene version=\"3.0.0\">\n<emitter type=\"spot\">\n{inner}\n</emitter>\n</scene>"),
        )
        .unwrap();
        let e = error_of(&scene, &[]);
        assert!(e.contains("line ") && e.contains(says), "{e}");
    }
}

/// Mitsuba's `directional`: along `direction`, or along `to_world`'s +z,
/// with its irradiance.
#[test]
fn directional_lights_shine_along_their_direction() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("s.xml");
    for (body, want) in [
        (
            "<vector name=\"direction\" x=\"0\" y=\"0\" z=\"-2\"/>",
            [0.0, 0.0, -1.0],
        ),
        (
            "<transform name=\"to_world\"><rotate x=\"1\" angle=\"90\"/></transform>",
            [0.0, -1.0, 0.0],
        ),
    ] {
        std::fs::write(
            &scene,
            format!(
                "<scene version=\"3.0.0\"><emitter type=\"directional\">\n{body}\n\
                 <rgb name=\"irradiance\" value=\"3, 2, 1\"/></emitter></scene>"
            ),
        )
        .unwrap();
        let (t, _) = translation(&scene, &[]);
        let l = array(&t, "lights")[0].as_table().unwrap();
        assert_eq!(l["type"].as_str(), Some("directional"));
        assert_rgb(&floats(&l["direction"]), want, "direction");
        assert_rgb(&floats(&l["irradiance"]), [3.0, 2.0, 1.0], "irradiance");
    }
}
