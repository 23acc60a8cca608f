//! Materials made of others (`blend`, `mask`, `null`, `back`) and bump
//! maps: the mixture's sampling against its density (chi-square), its
//! samples' weights, energy in a white furnace, analytic renders of a mask
//! and of a card's two sides, and the errors of composites that cannot be.

use glam::{Vec2, Vec3};
use plsr::bsdf::{Bsdf, CookTorranceParams, DielectricParams, Distribution, Fresnel, Microfacet};
use plsr::bsdf::{Mixture, Scatter};
use plsr::render::{render, RenderOptions};
use plsr::rng::Rng;
use plsr::scene::Scene;
use plsr_testkit::chi2::{chi2_test, SphereBinning};

use crate::materials::load;

fn rough_gold(alpha: f32) -> Bsdf {
    Bsdf::CookTorrance(CookTorranceParams {
        microfacet: Microfacet::new(Distribution::Ggx, alpha, alpha),
        fresnel: Fresnel::Schlick {
            f0: Vec3::new(1.0, 0.78, 0.34),
        },
    })
}

/// Mixtures with smooth parts, a delta part, a pass-through and a part
/// seen from the back (mirrored), with the directions to test from.
fn mixtures() -> Vec<(&'static str, Scatter, Vec<Vec3>)> {
    let above = vec![
        Vec3::new(0.3, 0.2, 0.93).normalize(),
        Vec3::new(-0.8, 0.1, 0.3).normalize(),
    ];
    let mut a = Mixture::new();
    a.push(Bsdf::diffuse(Vec3::splat(0.6)), 0.3, false);
    a.push(rough_gold(0.3), 0.5, false);
    a.pass_through(0.2);
    let mut b = Mixture::new();
    b.push(Bsdf::diffuse(Vec3::splat(0.9)), 0.4, true);
    b.push(
        Bsdf::Dielectric(DielectricParams {
            eta: 1.5,
            microfacet: Some(Microfacet::new(Distribution::Ggx, 0.4, 0.4)),
        }),
        0.6,
        false,
    );
    let below = above.iter().map(|w| -*w).collect();
    let mut c = Mixture::new();
    c.push(rough_gold(0.2), 0.5, false);
    c.push(
        Bsdf::Dielectric(DielectricParams {
            eta: 1.5,
            microfacet: None,
        }),
        0.25,
        false,
    );
    c.push(Bsdf::diffuse(Vec3::splat(0.5)), 0.25, false);
    vec![
        (
            "diffuse + rough gold + pass-through",
            Scatter::Mix(a),
            above.clone(),
        ),
        (
            "mirrored diffuse + rough glass, from behind",
            Scatter::Mix(b),
            below,
        ),
        (
            "rough gold + smooth glass + diffuse",
            Scatter::Mix(c),
            above,
        ),
    ]
}

#[test]
fn mixtures_sample_their_density() {
    let binning = SphereBinning {
        theta_bins: 20,
        phi_bins: 41,
        subdivisions: 32,
    };
    let mut failures = Vec::new();
    for (name, s, dirs) in mixtures() {
        for wo in dirs {
            let mut rng = Rng::new(77, 3);
            // Delta samples have no density: they count as failed draws,
            // which the pdf's integral (below one) accounts for.
            let r = chi2_test(
                binning,
                400_000,
                |_| {
                    s.sample(wo, rng.next_f32(), rng.next_2d())
                        .filter(|b| !b.delta)
                        .map(|b| b.wi)
                },
                &|wi| s.pdf(wo, wi) as f64,
                0.01 / 6.0,
            );
            if !r.passed {
                failures.push(format!("{name}, wo = {wo}: {}", r.summary));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn mixture_samples_carry_the_mixtures_value_and_density() {
    for (name, s, dirs) in mixtures() {
        for wo in dirs {
            let mut rng = Rng::new(5, 9);
            for _ in 0..3000 {
                let Some(b) = s.sample(wo, rng.next_f32(), rng.next_2d()) else {
                    continue;
                };
                if b.delta {
                    continue;
                }
                let (f, pdf) = s.eval_pdf(wo, b.wi);
                let tol = |x: f32, y: f32| (x - y).abs() <= 1e-4 * x.abs().max(y.abs()) + 1e-7;
                assert!(tol(pdf, b.pdf), "{name}: pdf {pdf} vs {}", b.pdf);
                for k in 0..3 {
                    assert!(tol(f[k], b.f[k]), "{name}: f {f} vs {}", b.f);
                    let w = f[k] * b.wi.z.abs() / pdf;
                    assert!(tol(w, b.weight[k]), "{name}: weight {} vs {w}", b.weight);
                }
            }
        }
    }
}

/// A lossless thin glass sheet (all delta lobes) and a white Lambertian
/// surface blended half and half scatter everything: the mean weight of
/// the mixture's samples is 1 whichever part is drawn (Mitsuba 3.8–3.9's
/// `blendbsdf` gives less, adding the other part's density to a delta
/// sample's: 0.69 for a white mirror blended with white diffuse under a
/// uniform sky, against 0.75).
#[test]
fn a_blend_of_delta_and_smooth_lobes_conserves_energy() {
    let mut m = Mixture::new();
    m.push(Bsdf::diffuse(Vec3::ONE), 0.5, false);
    m.push(
        Bsdf::ThinDielectric(plsr::bsdf::ThinDielectricParams {
            eta: 1.5,
            reflectance: Vec3::ONE,
            transmittance: Vec3::ONE,
        }),
        0.5,
        false,
    );
    let s = Scatter::Mix(m);
    let wo = Vec3::Z;
    let mut rng = Rng::new(1, 2);
    let n = 200_000;
    let mut sum = 0.0f64;
    for _ in 0..n {
        if let Some(b) = s.sample(wo, rng.next_f32(), rng.next_2d()) {
            sum += b.weight.x as f64;
        }
    }
    let mean = sum / n as f64;
    assert!((mean - 1.0).abs() < 2e-3, "mean weight {mean}");
}

/// A 2 × 2 rectangle facing the camera (or facing away, `flip`) beyond
/// the edges of an 8 × 8 film, under a uniform environment of radiance 1.
fn card_scene(materials: &str, material: &str, flip: bool) -> String {
    format!(
        "[render]\nspp = 1024\nmax_depth = 3\nseed = 3\n\
         [camera]\ntype = \"orthographic\"\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\n\
         up = [0, 1, 0]\nview_width = 0.5\nresolution = [8, 8]\n\
         [environment]\nradiance = [1, 1, 1]\n\
         {materials}\n\
         [[shapes]]\ntype = \"rectangle\"\nflip_normals = {flip}\nmaterial = \"{material}\"\n"
    )
}

fn mean_of(text: &str) -> (Vec3, Vec3) {
    let scene = load(text).unwrap_or_else(|e| panic!("{e}"));
    let film = render(
        &scene,
        &scene.default_job(),
        &RenderOptions::default(),
        &|_, _| true,
    )
    .unwrap()
    .0;
    let n = film.color.len() as f32;
    let var: Vec3 = film.variance.iter().copied().sum::<Vec3>() / (n * n);
    (film.mean_color(), var)
}

/// A mask of opacity ¼ over a grey Lambertian card in a white enclosure:
/// ¾ of the camera's paths pass straight through to the environment (1),
/// ¼ see the card's albedo (0.5) lit by the whole environment.
#[test]
fn a_masked_card_shows_the_environment_through_it() {
    let materials = "[[materials]]\nname = \"grey\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\
                     [[materials]]\nname = \"leaf\"\ntype = \"mask\"\nmaterial = \"grey\"\nopacity = 0.25\n";
    for flip in [false, true] {
        let (mean, var) = mean_of(&card_scene(materials, "leaf", flip));
        let want = 0.75 + 0.25 * 0.5;
        for k in 0..3 {
            let tol = 5.0 * var[k].sqrt() + 1e-3;
            assert!(
                (mean[k] - want).abs() < tol,
                "flip {flip}: {mean} vs {want} ± {tol}"
            );
        }
    }
}

/// A card with another material behind it shows each from its side; a
/// `null` card is invisible.
#[test]
fn a_card_with_a_back_shows_each_side_and_null_is_invisible() {
    let materials = "[[materials]]\nname = \"red\"\ntype = \"diffuse\"\nreflectance = [0.8, 0.1, 0.1]\n\
                     back = \"blue\"\n\
                     [[materials]]\nname = \"blue\"\ntype = \"diffuse\"\nreflectance = [0.1, 0.2, 0.7]\n\
                     [[materials]]\nname = \"nothing\"\ntype = \"null\"\n";
    for (material, flip, want) in [
        ("red", false, Vec3::new(0.8, 0.1, 0.1)),
        ("red", true, Vec3::new(0.1, 0.2, 0.7)),
        ("nothing", false, Vec3::ONE),
    ] {
        let (mean, var) = mean_of(&card_scene(materials, material, flip));
        for k in 0..3 {
            let tol = 5.0 * var[k].sqrt() + 1e-3;
            assert!(
                (mean[k] - want[k]).abs() < tol,
                "{material}, flip {flip}: {mean} vs {want}"
            );
        }
    }
}

#[test]
fn composites_that_cannot_be_are_refused_by_name() {
    let base = "[[materials]]\nname = \"a\"\ntype = \"diffuse\"\n\
                [[materials]]\nname = \"glass\"\ntype = \"dielectric\"\n";
    for (extra, field, words) in [
        (
            "[[materials]]\nname = \"m\"\ntype = \"mask\"\nmaterial = \"n\"\nopacity = 0.5\n\
             [[materials]]\nname = \"n\"\ntype = \"mask\"\nmaterial = \"m\"\nopacity = 0.5\n",
            "materials[2]",
            "loop: m → n → m",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"mask\"\nmaterial = \"zz\"\nopacity = 0.5\n",
            "materials[2].material",
            "no material named `zz`",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"blend\"\nmaterials = [\"a\", \"a\", \"a\"]\nweight = 0.5\n",
            "materials[2].materials",
            "two materials, got 3",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"blend\"\nmaterials = [\"a\", \"a\"]\n",
            "materials[2].weight",
            "required",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"blend\"\nmaterials = [\"a\", \"a\"]\nweight = 1.5\n",
            "materials[2].weight",
            "must be in [0, 1]",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"mask\"\nmaterial = \"a\"\nopacity = 0.5\ntwo_sided = false\n",
            "materials[2].two_sided",
            "give it to the materials",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"diffuse\"\nback = \"glass\"\n",
            "materials[2].back",
            "must both be opaque",
        ),
        (
            "[[materials]]\nname = \"m\"\ntype = \"diffuse\"\nbump_scale = 2\n",
            "materials[2].bump_scale",
            "only used with a bump_map",
        ),
    ] {
        let text = format!(
            "[camera]\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nvfov = 40\nresolution = [4, 4]\n\
             {base}{extra}\n[[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\n\
             material = \"a\"\n"
        );
        let e = match load(&text) {
            Ok(_) => panic!("accepted: {extra}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(field) && e.contains(words), "{extra}\n→ {e}");
    }
}

/// A bump map whose height rises along u by `g` per unit of u tilts a
/// flat card's normal: the rectangle spans 2 units per unit of u and v,
/// so `∂p/∂u' = (2, 0, g)`, `∂p/∂v' = (0, 2, 0)` and the normal is
/// `(−g, 0, 2)/√(g² + 4)`. Lit straight from above, a Lambertian card
/// with `g = 2` is `1/√2` as bright as without it.
#[test]
fn a_height_ramp_tilts_the_normal_by_its_slope() {
    // A 4 × 1 ramp 0, ⅓, ⅔, 1 across u: between texel centres its
    // bilinear slope is ⅓ per texel, 4/3 per unit of u.
    let ramp = plsr::texture::ImageTexture::from_texels(
        4,
        1,
        (0..4).map(|i| Vec3::splat(i as f32 / 3.0)).collect(),
    );
    let [du, dv] = ramp.eval_gradient(Vec2::new(0.5, 0.5));
    assert!(
        (du.x - 4.0 / 3.0).abs() < 1e-5 && dv == Vec3::ZERO,
        "{du} {dv}"
    );
    let dir = tempfile::tempdir().unwrap();
    image::GrayImage::from_raw(4, 1, vec![0, 85, 170, 255])
        .unwrap()
        .save(dir.path().join("ramp.png"))
        .unwrap();
    let scene = |bump: &str| {
        format!(
            "[render]\nspp = 16\nmax_depth = 1\n\
             [camera]\ntype = \"orthographic\"\nposition = [0, 0, 2]\nlook_at = [0, 0, 0]\n\
             up = [0, 1, 0]\nview_width = 0.4\nresolution = [8, 8]\n\
             [[lights]]\ntype = \"directional\"\ndirection = [0, 0, -1]\nirradiance = [3, 3, 3]\n\
             [[materials]]\nname = \"m\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n{bump}\n\
             [[shapes]]\ntype = \"rectangle\"\nmaterial = \"m\"\n"
        )
    };
    let render_mean = |text: String| {
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, text).unwrap();
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        render(
            &scene,
            &scene.default_job(),
            &RenderOptions::default(),
            &|_, _| true,
        )
        .unwrap()
        .0
        .mean_color()
    };
    let flat = render_mean(scene(""));
    assert!((flat.x - 1.5 / std::f32::consts::PI).abs() < 1e-4, "{flat}");
    // g = 1.5 · 4/3 = 2.
    let bumped = render_mean(scene("bump_map = \"ramp.png\"\nbump_scale = 1.5"));
    let want = flat.x / 2f32.sqrt();
    assert!((bumped.x - want).abs() < 1e-3 * want, "{bumped} vs {want}");
}

/// The documentation's example of materials made of materials loads, with
/// the maps it names, and its mask and blend are composites.
#[test]
fn documented_composite_example_loads() {
    let doc = include_str!("../../docs/scene-format.md");
    let start = doc
        .find("### Materials made of materials")
        .expect("the section is in the docs");
    let block = &doc[start..];
    let open = block.find("```toml\n").unwrap() + "```toml\n".len();
    let close = block[open..].find("```").unwrap();
    let dir = tempfile::tempdir().unwrap();
    for name in ["leaf_alpha.png", "wear.png"] {
        image::GrayImage::from_raw(2, 2, vec![0, 255, 128, 64])
            .unwrap()
            .save(dir.path().join(name))
            .unwrap();
    }
    let text = format!(
        "[camera]\nposition = [0, 0, 3]\nlook_at = [0, 0, 0]\nup = [0, 1, 0]\nvfov = 40\n\
         resolution = [8, 8]\n{}\n[[shapes]]\ntype = \"rectangle\"\nmaterial = \"leaf\"\n",
        &block[open..open + close]
    );
    let path = dir.path().join("scene.toml");
    std::fs::write(&path, text).unwrap();
    let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
    for name in ["leaf", "worn paint", "card"] {
        let m = scene.materials().iter().find(|m| m.name == name).unwrap();
        assert!(m.composite.is_some(), "{name}");
    }
}

/// An alpha map replaces a microfacet material's α at each point: a map
/// whose every texel is 0.3 renders exactly as `alpha = 0.3`, along one
/// tangent or both; maps that cannot go together are refused.
#[test]
fn alpha_maps_replace_the_constant_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let scene = |material: &str| {
        format!(
            "[render]\nspp = 8\nmax_depth = 3\nseed = 4\n\
             [camera]\nposition = [0, -3, 1]\nlook_at = [0, 0, 0]\nup = [0, 0, 1]\nvfov = 40\n\
             resolution = [12, 10]\n[environment]\nradiance = [0.5, 0.6, 0.7]\n\
             [[lights]]\ntype = \"point\"\nposition = [1, -2, 3]\nintensity = [20, 20, 20]\n\
             [[materials]]\nname = \"m\"\n{material}\n\
             [[shapes]]\ntype = \"sphere\"\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"m\"\n"
        )
    };
    let render_bits = |text: String| -> Vec<u32> {
        let path = dir.path().join("scene.toml");
        std::fs::write(&path, text).unwrap();
        let scene = Scene::load(&path).unwrap_or_else(|e| panic!("{e}"));
        let options = RenderOptions {
            vectorised: false,
            ..Default::default()
        };
        let film = render(&scene, &scene.default_job(), &options, &|_, _| true)
            .unwrap()
            .0;
        film.color
            .iter()
            .flat_map(|c| c.to_array())
            .map(f32::to_bits)
            .collect()
    };
    let flat = "{ checkerboard = [[0.3, 0.3, 0.3], [0.3, 0.3, 0.3]] }";
    let other = "{ checkerboard = [[0.05, 0.05, 0.05], [0.05, 0.05, 0.05]] }";
    for (constant, mapped) in [
        (
            "type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha = 0.3".to_string(),
            format!("type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha_map = {flat}"),
        ),
        (
            "type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha_u = 0.3\nalpha_v = 0.05".to_string(),
            format!(
                "type = \"cook_torrance\"\nmetal = \"Cu\"\nalpha_u_map = {flat}\nalpha_v_map = {other}"
            ),
        ),
        (
            "type = \"dielectric\"\nior = 1.5\nalpha = 0.3".to_string(),
            format!("type = \"dielectric\"\nior = 1.5\nalpha_map = {flat}"),
        ),
    ] {
        assert_eq!(
            render_bits(scene(&constant)),
            render_bits(scene(&mapped)),
            "{mapped}"
        );
    }
    for (material, words) in [
        (
            format!("type = \"cook_torrance\"\nalpha_u_map = {flat}"),
            "alpha_u_map and alpha_v_map go together",
        ),
        (
            format!("type = \"cook_torrance\"\nalpha_map = {flat}\nalpha_u_map = {flat}\nalpha_v_map = {flat}"),
            "not both",
        ),
        (
            format!("type = \"cook_torrance\"\nalpha_map = {flat}\nroughness_map = {flat}"),
            "give roughness_map or alpha maps, not both",
        ),
        (
            format!("type = \"principled\"\nalpha_map = {flat}"),
            "alpha_map",
        ),
    ] {
        let path = dir.path().join("bad.toml");
        std::fs::write(&path, scene(&material)).unwrap();
        let e = match Scene::load(&path) {
            Ok(_) => panic!("accepted: {material}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(words), "{material}\n→ {e}");
    }
}
