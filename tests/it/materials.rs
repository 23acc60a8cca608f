//! Materials from scene files: every model's keys parse into the right BSDF,
//! bad keys name their field, and the transmissive model renders a white
//! furnace correctly (radiance leaving a glass sphere in a uniform enclosure
//! equals the enclosure's: the 1/η² on entering and η² on leaving cancel).

use glam::Vec3;
use plsr::bsdf::{Bsdf, Distribution, Fresnel};
use plsr::render::{render, RenderOptions};
use plsr::scene::Scene;

const CAMERA: &str = r#"
[camera]
position = [0, -3, 0.5]
look_at = [0, 0, 0]
up = [0, 0, 1]
vfov = 60
resolution = [24, 24]
"#;

/// A scene from TOML text (written to a temporary file and loaded).
pub(crate) fn load(text: &str) -> plsr::Result<Scene> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    Scene::load(&path)
}

fn material_scene(material: &str) -> String {
    format!(
        "[render]\nspp = 1\n{CAMERA}\n[[materials]]\nname = \"m\"\n{material}\n\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
    )
}

fn bsdf_of(material: &str) -> Bsdf {
    let scene = load(&material_scene(material)).unwrap_or_else(|e| panic!("{e}"));
    scene
        .materials()
        .iter()
        .find(|m| m.name == "m")
        .unwrap()
        .bsdf
}

fn error_of(material: &str) -> String {
    match load(&material_scene(material)) {
        Ok(_) => panic!("`{material}` should be refused"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn every_material_type_parses() {
    let Bsdf::BlinnPhong(b) = bsdf_of(
        "type = \"blinn_phong\"\ndiffuse = [0.5, 0.4, 0.3]\nspecular = [0.3, 0.3, 0.3]\nexponent = 50",
    ) else {
        panic!("not blinn_phong")
    };
    assert_eq!(
        (b.diffuse, b.specular.x, b.exponent),
        (Vec3::new(0.5, 0.4, 0.3), 0.3, 50.0)
    );

    let Bsdf::CookTorrance(c) = bsdf_of(
        "type = \"cook_torrance\"\ndistribution = \"beckmann\"\nroughness = 0.5\nmetal = \"Au\"",
    ) else {
        panic!("not cook_torrance")
    };
    assert_eq!(c.microfacet.kind, Distribution::Beckmann);
    assert!((c.microfacet.alpha_x - 0.25).abs() < 1e-6);
    assert!(matches!(c.fresnel, Fresnel::Conductor { .. }));

    let Bsdf::CookTorrance(c) = bsdf_of(
        "type = \"cook_torrance\"\nalpha_u = 0.1\nalpha_v = 0.4\nfresnel = \"schlick\"\nf0 = [0.9, 0.6, 0.3]",
    ) else {
        panic!("not cook_torrance")
    };
    assert_eq!(c.microfacet.kind, Distribution::Ggx);
    assert_eq!((c.microfacet.alpha_x, c.microfacet.alpha_y), (0.1, 0.4));
    assert_eq!(
        c.fresnel,
        Fresnel::Schlick {
            f0: Vec3::new(0.9, 0.6, 0.3)
        }
    );

    let Bsdf::Dielectric(d) = bsdf_of("type = \"dielectric\"\nior = 1.33") else {
        panic!("not dielectric")
    };
    assert_eq!((d.eta, d.microfacet), (1.33, None));
    let Bsdf::Dielectric(d) = bsdf_of("type = \"dielectric\"\nalpha = 0.2") else {
        panic!("not dielectric")
    };
    assert_eq!((d.eta, d.microfacet.unwrap().alpha_x), (1.5, 0.2));

    let Bsdf::Principled(p) = bsdf_of(
        "type = \"principled\"\nbase_color = [0.8, 0.2, 0.1]\nroughness = 0.3\nmetallic = 1\nanisotropic = 0.5\nspecular = 0.6\nspec_tint = 0.1",
    ) else {
        panic!("not principled")
    };
    assert_eq!(
        (
            p.base_color,
            p.roughness,
            p.metallic,
            p.anisotropic,
            p.specular,
            p.spec_tint
        ),
        (Vec3::new(0.8, 0.2, 0.1), 0.3, 1.0, 0.5, 0.6, 0.1)
    );

    let Bsdf::PrincipledThin(t) = bsdf_of(
        "type = \"principled_thin\"\nbase_color = [0.7, 0.5, 0.3]\nroughness = 0.2\nanisotropic = 0.3\n\
         spec_trans = 0.4\neta = 1.33\nspec_tint = 0.1\nsheen = 0.6\nsheen_tint = 0.2\n\
         flatness = 0.5\ndiff_trans = 1.5",
    ) else {
        panic!("not principled_thin")
    };
    assert_eq!(
        (
            t.base_color,
            t.roughness,
            t.anisotropic,
            t.spec_trans,
            t.eta
        ),
        (Vec3::new(0.7, 0.5, 0.3), 0.2, 0.3, 0.4, 1.33)
    );
    assert_eq!(
        (t.spec_tint, t.sheen, t.sheen_tint, t.flatness, t.diff_trans),
        (0.1, 0.6, 0.2, 0.5, 1.5)
    );
    // Mitsuba's defaults.
    let Bsdf::PrincipledThin(t) = bsdf_of("type = \"principled_thin\"") else {
        panic!("not principled_thin")
    };
    assert_eq!(t, plsr::bsdf::PrincipledThinParams::default());
}

#[test]
fn principled_takes_every_lobe_of_mitsubas() {
    // Any of the four lobes beyond diffuse and specular makes the full model.
    let Bsdf::PrincipledFull(p) = bsdf_of(
        "type = \"principled\"\nbase_color = [0.7, 0.5, 0.3]\nroughness = 0.2\nmetallic = 0.1\n\
         sheen = 0.6\nsheen_tint = 0.2\nclearcoat = 0.8\nclearcoat_gloss = 0.9\nflatness = 0.5\n\
         eta = 2.5",
    ) else {
        panic!("not the full principled model")
    };
    assert_eq!(
        (
            p.sheen,
            p.sheen_tint,
            p.clearcoat,
            p.clearcoat_gloss,
            p.flatness
        ),
        (0.6, 0.2, 0.8, 0.9, 0.5)
    );
    assert_eq!((p.eta, p.spec_trans, p.has_transmission), (2.5, 0.0, false));
    // A transmission lobe gives it an inside; Mitsuba's specular = 0 with
    // transmission becomes 0.001.
    let Bsdf::PrincipledFull(p) = bsdf_of("type = \"principled\"\nspec_trans = 0.5\nspecular = 0")
    else {
        panic!("not the full principled model")
    };
    assert!(p.has_transmission && Bsdf::PrincipledFull(p).transmits());
    assert_eq!(p.eta, plsr::bsdf::albedo::eta_from_specular(1e-3));
    // Only a map of spec_trans: an inside too.
    let Bsdf::PrincipledFull(p) = bsdf_of(
        "type = \"principled\"\nspec_trans_map = { checkerboard = [[0, 0, 0], [1, 1, 1]] }",
    ) else {
        panic!("not the full principled model")
    };
    assert!(p.has_transmission);
    // Zero weights and an η that `specular` can express: the two-lobe model.
    let Bsdf::Principled(p) = bsdf_of("type = \"principled\"\nsheen = 0\nclearcoat = 0\neta = 1.5")
    else {
        panic!("not the two-lobe principled model")
    };
    assert!((p.eta() - 1.5).abs() < 1e-5, "{}", p.eta());
    // Faults, by key.
    let e = error_of("type = \"principled\"\neta = 1.5\nspecular = 0.5");
    assert!(
        e.contains("materials[0].eta") && e.contains("give one of eta and specular"),
        "{e}"
    );
    let e = error_of("type = \"principled\"\nsheen = 0.5\nenergy_conserving = true");
    assert!(e.contains("materials[0].energy_conserving"), "{e}");
    let e = error_of("type = \"principled\"\nclearcoat = 1.5");
    assert!(e.contains("clearcoat") && e.contains("[0, 1]"), "{e}");
}

#[test]
fn weight_maps_replace_the_principled_weights() {
    // A checkerboard of 0.2 and 0.8 for `sheen`: the BSDF at a point of
    // each square takes that value; the constant is kept where no map is.
    let scene = load(&material_scene(
        "type = \"principled_thin\"\nsheen = 0.5\nspec_trans = 0.3\n\
         sheen_map = { checkerboard = [0.2, 0.8] }",
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let m = scene.materials().iter().find(|m| m.name == "m").unwrap();
    for (uv, want) in [
        (glam::Vec2::new(0.25, 0.25), 0.2),
        (glam::Vec2::new(0.75, 0.25), 0.8),
    ] {
        let Bsdf::PrincipledThin(t) = m.bsdf_at(uv, Vec3::ONE) else {
            panic!("not principled_thin")
        };
        assert!((t.sheen - want).abs() < 1e-6, "{uv}: {}", t.sheen);
        assert_eq!(t.spec_trans, 0.3);
    }
    let scene = load(&material_scene(
        "type = \"principled\"\nroughness = 0.4\nanisotropic_map = { checkerboard = [0.0, 0.9] }",
    ))
    .unwrap_or_else(|e| panic!("{e}"));
    let m = scene.materials().iter().find(|m| m.name == "m").unwrap();
    assert!(m.is_anisotropic());
    let Bsdf::Principled(p) = m.bsdf_at(glam::Vec2::new(0.75, 0.25), Vec3::ONE) else {
        panic!("not principled")
    };
    assert!((p.anisotropic - 0.9).abs() < 1e-6);
}

#[test]
fn bad_material_keys_name_the_field() {
    let cases = [
        (
            "type = \"velvet\"",
            "materials[0].type",
            "unknown material type",
        ),
        (
            "type = \"diffuse\"\nexponent = 3",
            "materials[0].exponent",
            "not a parameter",
        ),
        (
            "type = \"principled\"\nroughness = 1.5",
            "materials[0].roughness",
            "[0, 1]",
        ),
        (
            "type = \"principled\"\nspecular = [1, 1, 1]",
            "materials[0].specular",
            "number",
        ),
        (
            "type = \"blinn_phong\"\nspecular = 0.5",
            "materials[0].specular",
            "RGB",
        ),
        (
            "type = \"blinn_phong\"\ndiffuse = [0.8, 0.8, 0.8]\nspecular = [0.5, 0.5, 0.5]",
            "materials[0].specular",
            "exceed 1",
        ),
        (
            "type = \"cook_torrance\"\nmetal = \"Unobtainium\"",
            "materials[0].metal",
            "unknown metal",
        ),
        (
            "type = \"cook_torrance\"\nfresnel = \"schlick\"\nior = 1.5",
            "materials[0].ior",
            "not used",
        ),
        (
            "type = \"cook_torrance\"\nroughness = 0.2\nalpha = 0.1",
            "materials[0].roughness",
            "one of",
        ),
        (
            "type = \"cook_torrance\"\nalpha_u = 0.2",
            "materials[0].alpha_u",
            "together",
        ),
        (
            "type = \"cook_torrance\"\ndistribution = \"phong\"",
            "materials[0].distribution",
            "unknown distribution",
        ),
        (
            "type = \"dielectric\"\nior = 1",
            "materials[0].ior",
            "not 1",
        ),
        (
            "type = \"dielectric\"\nior = nan",
            "materials[0].ior",
            "finite",
        ),
        (
            "type = \"dielectric\"\ndistribution = \"ggx\"",
            "materials[0].distribution",
            "only used with a roughness",
        ),
        (
            "type = \"principled_thin\"\ndiff_trans = 2.5",
            "materials[0].diff_trans",
            "[0, 2]",
        ),
        (
            "type = \"principled_thin\"\nmetallic = 0.5",
            "materials[0].metallic",
            "not a parameter of a `principled_thin` material",
        ),
        (
            "type = \"principled_thin\"\nsheen_map = { checkerboard = [0.2, 1.5] }",
            "materials[0].sheen_map",
            "[0, 1]",
        ),
    ];
    for (material, field, fault) in cases {
        let e = error_of(material);
        assert!(e.contains("scene.toml"), "{e}");
        assert!(e.contains(field), "`{material}`: {e}");
        assert!(e.contains(fault), "`{material}`: {e}");
    }
}

/// A sphere of material `material` in an enclosure of radiance 1.
fn furnace(material: &str) -> plsr::film::Film {
    let text = format!(
        "[render]\nspp = 64\nmax_depth = 48\nseed = 5\n{CAMERA}\n\
         [[materials]]\nname = \"black\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\n\
         [[materials]]\nname = \"m\"\n{material}\n\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 10\nsubdivisions = 3\n\
         flip_normals = true\nmaterial = \"black\"\nemission = [1, 1, 1]\n\n\
         [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nsubdivisions = 4\nmaterial = \"m\"\n"
    );
    let scene = load(&text).unwrap_or_else(|e| panic!("{e}"));
    render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0
}

fn assert_furnace(film: &plsr::film::Film, what: &str) {
    let mean = film.mean_color();
    for c in mean.to_array() {
        assert!((c - 1.0).abs() < 0.01, "{what}: furnace mean {mean}");
    }
    for (i, (c, v)) in film.color.iter().zip(&film.variance).enumerate() {
        for k in 0..3 {
            let tol = 5.0 * v[k].sqrt() + 1e-3;
            assert!((c[k] - 1.0).abs() <= tol, "{what}: pixel {i}: {c} ± {v}");
        }
    }
}

#[test]
fn glass_spheres_vanish_in_a_white_furnace() {
    assert_furnace(&furnace("type = \"dielectric\"\nior = 1.5"), "smooth glass");
    // Nearly smooth rough glass (α = 0.01) loses almost nothing.
    assert_furnace(
        &furnace("type = \"dielectric\"\nior = 1.5\nroughness = 0.1"),
        "rough glass α = 0.01",
    );
    // Rougher glass loses what single scattering misses, but never gains.
    let mean = furnace("type = \"dielectric\"\nior = 1.5\nroughness = 0.3").mean_color();
    assert!(
        mean.x <= 1.0 && mean.x > 0.95,
        "rough glass α = 0.09: {mean}"
    );
}

/// A white principled sphere: with `energy_conserving` it vanishes in the
/// furnace (its diffuse lobe takes exactly what the specular lobe leaves);
/// in Mitsuba's mode it glows brighter than its surroundings.
#[test]
fn energy_conserving_principled_sphere_vanishes_in_a_white_furnace() {
    let white = "type = \"principled\"\nbase_color = [1, 1, 1]\nroughness = 0.6";
    assert_furnace(
        &furnace(&format!("{white}\nenergy_conserving = true")),
        "energy-conserving principled",
    );
    // The centre pixels see the sphere head-on, where Mitsuba's model
    // reflects about 1.05.
    let film = furnace(white);
    let centre = [(11, 11), (11, 12), (12, 11), (12, 12)]
        .map(|(x, y)| film.color[film.index(x, y)].x)
        .iter()
        .sum::<f32>()
        / 4.0;
    assert!(centre > 1.03, "Mitsuba-mode principled: {centre}");
}

#[test]
fn rough_white_metal_in_a_white_furnace_shows_its_albedo() {
    // The centre pixels see the sphere head-on, so their radiance is the
    // directional albedo at normal incidence, which single-scattering GGX
    // keeps well below 1 at α = 0.49 (energy lost to masking).
    let material =
        "type = \"cook_torrance\"\nroughness = 0.7\nfresnel = \"schlick\"\nf0 = [1, 1, 1]";
    let bsdf = bsdf_of(material);
    let mut rng = plsr::rng::Rng::new(9, 9);
    let n = 400_000;
    let albedo = (0..n)
        .filter_map(|_| bsdf.sample(Vec3::Z, rng.next_f32(), rng.next_2d()))
        .map(|s| s.weight.x as f64)
        .sum::<f64>()
        / n as f64;
    let film = furnace(material);
    let (mut sum, mut var) = (0.0f64, 0.0f64);
    for (x, y) in [(11, 11), (11, 12), (12, 11), (12, 12)] {
        let i = film.index(x, y);
        sum += film.color[i].x as f64;
        var += film.variance[i].x as f64;
    }
    let (mean, se) = (sum / 4.0, var.sqrt() / 4.0);
    assert!(albedo < 0.75, "{albedo}");
    // 4σ of the pixels plus 1 % for the pixels' footprint and the facets.
    assert!(
        (mean - albedo).abs() < 4.0 * se + 0.01,
        "rendered {mean} ± {se}, albedo {albedo}"
    );
}

/// The scene-format documentation's example of every material type loads
/// and renders.
#[test]
fn documented_material_example_loads_and_renders() {
    let doc = include_str!("../../docs/scene-format.md");
    let start = doc
        .find("`materials-models.toml`")
        .expect("the example is in the docs");
    let block = &doc[start..];
    let open = block.find("```toml\n").unwrap() + "```toml\n".len();
    let close = block[open..].find("```").unwrap();
    let scene = load(&block[open..open + close]).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(scene.materials().len(), 7, "seven named, no default needed");
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    assert!(film.mean_color().x > 0.0 && film.mean_color().is_finite());
}

/// Mitsuba's conductor `specular_reflectance`: a tint on the Fresnel term;
/// `metal = "none"` has reflectance exactly 1, so the tint is the
/// reflectance.
#[test]
fn conductor_specular_reflectance_tints_and_none_reflects_everything() {
    let Bsdf::CookTorrance(plain) =
        bsdf_of("type = \"cook_torrance\"\nroughness = 0.4\nmetal = \"Au\"")
    else {
        panic!("not cook_torrance")
    };
    let tint = Vec3::new(0.9, 0.5, 0.2);
    let Bsdf::CookTorrance(tinted) = bsdf_of(
        "type = \"cook_torrance\"\nroughness = 0.4\nmetal = \"Au\"\nspecular_reflectance = [0.9, 0.5, 0.2]",
    ) else {
        panic!("not cook_torrance")
    };
    let Bsdf::CookTorrance(none) = bsdf_of(
        "type = \"cook_torrance\"\nroughness = 0.4\nmetal = \"none\"\nspecular_reflectance = [0.9, 0.5, 0.2]",
    ) else {
        panic!("not cook_torrance")
    };
    for cos in [1.0f32, 0.7, 0.3, 0.05] {
        let f = plain.fresnel.eval(cos);
        let g = tinted.fresnel.eval(cos);
        assert!(
            ((g - f * tint) / (f * tint)).abs().max_element() < 1e-6,
            "{f} {g}"
        );
        assert!(
            (none.fresnel.eval(cos) - tint).abs().max_element() < 1e-6,
            "cos {cos}"
        );
    }
    // And through the whole BSDF: eval scales by the tint.
    let (wo, wi) = (
        Vec3::new(0.3, 0.1, 0.95).normalize(),
        Vec3::new(-0.2, -0.3, 0.9).normalize(),
    );
    let (a, b) = (
        Bsdf::CookTorrance(plain).eval(wo, wi),
        Bsdf::CookTorrance(tinted).eval(wo, wi),
    );
    assert!(((b - a * tint) / (a * tint)).abs().max_element() < 1e-5);
    for (keys, says) in [
        (
            "fresnel = \"schlick\"\nspecular_reflectance = [1, 1, 1]",
            "materials[0].specular_reflectance: not used",
        ),
        ("specular_reflectance = [1.5, 1, 1]", "specular_reflectance"),
        ("metal = \"pewter\"", "known: Au, Ag, Cu, Al, none"),
    ] {
        let e = error_of(&format!("type = \"cook_torrance\"\n{keys}"));
        assert!(e.contains(says), "{keys}: {e}");
    }
}
