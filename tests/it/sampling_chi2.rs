//! Chi-square goodness-of-fit tests for every sampling routine of the core:
//! cosine-weighted hemisphere, uniform sphere, the Lambertian BSDF, triangle
//! area lights (solid-angle pdf), sphere lights (their cone), and light
//! selection.

use plsr_testkit as common;

use common::chi2::{chi2_from_counts, chi2_test, regularized_gamma_p, SphereBinning};
use glam::{Vec2, Vec3};
use plsr::bsdf::Bsdf;
use plsr::light::{Light, LightSet, PointLight, TriangleLight};
use plsr::rng::Rng;
use plsr::warp::{
    cosine_hemisphere_pdf, square_to_cosine_hemisphere, square_to_uniform_sphere,
    UNIFORM_SPHERE_PDF,
};

/// Significance per test: 1 % overall, Bonferroni-corrected over the tests here.
const SIGNIFICANCE: f64 = 0.01 / 16.0;
const DRAWS: usize = 400_000;

#[test]
fn cosine_hemisphere() {
    let mut rng = Rng::new(11, 1);
    let r = chi2_test(
        SphereBinning::default(),
        DRAWS,
        |_| Some(square_to_cosine_hemisphere(rng.next_2d())),
        &|w| cosine_hemisphere_pdf(w.z) as f64,
        SIGNIFICANCE,
    );
    assert!(r.passed, "{}", r.summary);
}

#[test]
fn uniform_sphere() {
    let mut rng = Rng::new(12, 1);
    let r = chi2_test(
        SphereBinning::default(),
        DRAWS,
        |_| Some(square_to_uniform_sphere(rng.next_2d())),
        &|_| UNIFORM_SPHERE_PDF as f64,
        SIGNIFICANCE,
    );
    assert!(r.passed, "{}", r.summary);
}

#[test]
fn lambertian_bsdf_sampling_matches_its_pdf() {
    let bsdf = Bsdf::diffuse(Vec3::splat(0.5));
    for wo in [
        Vec3::Z,
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::new(0.999, 0.0, 0.0447).normalize(),
    ] {
        let mut rng = Rng::new(13, 1);
        let r = chi2_test(
            SphereBinning::default(),
            DRAWS,
            |_| bsdf.sample(wo, rng.next_f32(), rng.next_2d()).map(|s| s.wi),
            &|wi| bsdf.pdf(wo, wi) as f64,
            SIGNIFICANCE,
        );
        assert!(r.passed, "wo = {wo}: {}", r.summary);
        // eval and sample agree on the value.
        let s = bsdf.sample(wo, 0.5, Vec2::new(0.3, 0.7)).unwrap();
        assert_eq!(s.f, bsdf.eval(wo, s.wi));
        let w = s.f * s.wi.z.abs() / s.pdf;
        assert!(
            (s.weight - w).abs().max_element() < 1e-5,
            "{} vs {w}",
            s.weight
        );
    }
}

/// Ray–triangle intersection (Möller–Trumbore) for the test's pdf lookups.
fn hit_triangle(o: Vec3, d: Vec3, p: &[Vec3; 3]) -> Option<Vec3> {
    hit_triangle_tolerant(o, d, p, 0.0)
}

/// As `hit_triangle`, accepting points up to `tol` (barycentric) outside, so
/// that a direction through a shared edge finds a triangle despite rounding.
fn hit_triangle_tolerant(o: Vec3, d: Vec3, p: &[Vec3; 3], tol: f32) -> Option<Vec3> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let h = d.cross(e2);
    let a = e1.dot(h);
    if a.abs() < 1e-12 {
        return None;
    }
    let s = o - p[0];
    let u = s.dot(h) / a;
    let q = s.cross(e1);
    let v = d.dot(q) / a;
    let t = e2.dot(q) / a;
    (u >= -tol && v >= -tol && u + v <= 1.0 + tol && t > 0.0).then(|| o + t * d)
}

#[test]
fn triangle_light_solid_angle_sampling() {
    // A large, close, oblique triangle: its solid angle spans many cells and
    // the area-to-solid-angle conversion varies a lot across it.
    let tri = [
        Vec3::new(-1.0, -0.5, 0.4),
        Vec3::new(1.5, -0.2, 0.9),
        Vec3::new(-0.3, 1.2, 0.3),
    ];
    let p = Vec3::new(0.1, 0.05, 0.0);
    for two_sided in [false, true] {
        // Seen from p the triangle's normal points away for one winding;
        // order the vertices so that p is on its lit side when one-sided.
        let light = TriangleLight::new([tri[0], tri[2], tri[1]], Vec3::ONE, two_sided).unwrap();
        assert!(
            light.n.dot(p - tri[0]) > 0.0,
            "test set-up: p must be on the lit side"
        );
        let mut rng = Rng::new(14, 1);
        let r = chi2_test(
            SphereBinning {
                subdivisions: 16,
                ..Default::default()
            },
            DRAWS,
            |_| light.sample_li(p, rng.next_2d()).map(|s| s.wi),
            &|w| match hit_triangle(p, w, &light.p) {
                Some(x) => light.pdf_li(p, x, w) as f64,
                None => 0.0,
            },
            SIGNIFICANCE,
        );
        assert!(r.passed, "two_sided = {two_sided}: {}", r.summary);
    }
    // From the back of a one-sided light, nothing is ever sampled.
    let light = TriangleLight::new(tri, Vec3::ONE, false).unwrap();
    let mut rng = Rng::new(15, 1);
    assert!((0..1000).all(|_| light.sample_li(p, rng.next_2d()).is_none()));
}

#[test]
fn light_selection_is_proportional_to_power() {
    let lights = vec![
        Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::splat(1.0),
            cone: None,
            projection: None,
        }),
        Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::splat(3.0),
            cone: None,
            projection: None,
        }),
        Light::Point(PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::ZERO,
            cone: None,
            projection: None,
        }),
        Light::Triangle(
            TriangleLight::new([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::splat(2.0), false).unwrap(),
        ),
    ];
    let powers: Vec<f64> = lights.iter().map(|l| l.power() as f64).collect();
    let total: f64 = powers.iter().sum();
    // By power alone (with several groups, `pick` would also weigh them by
    // where they are: `spatial_light_selection_matches_its_pmf`).
    let set = LightSet::new(lights).with_picking(plsr::light::LightPicking::Power);
    let n = 200_000;
    let mut observed = vec![0.0; 4];
    let mut rng = Rng::new(16, 1);
    for _ in 0..n {
        let (i, pmf) = set.pick(Vec3::ZERO, rng.next_2d()).unwrap();
        assert!((pmf as f64 - powers[i] / total).abs() < 1e-6);
        assert_eq!(pmf, set.pick_pmf(i, Vec3::ZERO));
        observed[i] += 1.0;
    }
    assert_eq!(observed[2], 0.0, "a light of zero power was picked");
    let expected: Vec<f64> = powers.iter().map(|p| p / total * n as f64).collect();
    let (chi2, dof) = chi2_from_counts(&observed, &expected, 5.0);
    let p = 1.0 - regularized_gamma_p(dof as f64 / 2.0, chi2 / 2.0);
    assert!(p >= SIGNIFICANCE, "chi2 = {chi2}, dof = {dof}, p = {p}");
}

/// Lights picked by distance and orientation as well as power: at points
/// around a scene of point lights, a panel of two triangles and an
/// environment, the picks are distributed as `pick_pmf` says (chi-square),
/// the probabilities sum to 1, the probability returned with a pick is
/// `pick_pmf`'s to the bit, and a panel facing away is never picked.
#[test]
fn spatial_light_selection_matches_its_pmf() {
    use plsr::light::EnvironmentLight;
    let panel = |z: f32| {
        let (a, b, c, d) = (
            Vec3::new(-0.5, -0.5, z),
            Vec3::new(0.5, -0.5, z),
            Vec3::new(0.5, 0.5, z),
            Vec3::new(-0.5, 0.5, z),
        );
        // Wound to face down (−z).
        [[a, c, b], [a, d, c]]
            .map(|t| Light::Triangle(TriangleLight::new(t, Vec3::splat(4.0), false).unwrap()))
    };
    let [t0, t1] = panel(2.0);
    let lights = vec![
        Light::Point(PointLight {
            position: Vec3::new(0.0, 0.0, 3.0),
            intensity: Vec3::splat(1.0),
            cone: None,
            projection: None,
        }),
        Light::Point(PointLight {
            position: Vec3::new(4.0, 0.0, 1.0),
            intensity: Vec3::splat(3.0),
            cone: None,
            projection: None,
        }),
        t0,
        t1,
        Light::Environment {
            light: Box::new(EnvironmentLight::constant(Vec3::splat(0.05))),
            scene_radius: 3.0,
        },
    ];
    let set = LightSet::with_groups(
        lights,
        vec![(0..1, None), (1..2, None), (2..4, None), (4..5, None)],
    );
    assert!(set.is_spatial() && !set.is_spatially_uniform());
    let n = 200_000;
    for (s, p) in [
        Vec3::ZERO,
        Vec3::new(3.0, 0.5, 0.5),
        Vec3::new(-1.0, 1.0, 1.5),
        // Above the panel, which faces down, beyond its bounding sphere:
        // never picked there.
        Vec3::new(0.2, 0.1, 3.5),
    ]
    .into_iter()
    .enumerate()
    {
        let pmf: Vec<f64> = (0..5).map(|i| set.pick_pmf(i, p) as f64).collect();
        let sum: f64 = pmf.iter().sum();
        assert!(
            (sum - 1.0).abs() < 1e-5,
            "at {p}: pmfs {pmf:?} sum to {sum}"
        );
        let mut observed = vec![0.0; 5];
        let mut rng = Rng::new(40 + s as u64, 1);
        for _ in 0..n {
            let (i, prob) = set.pick(p, rng.next_2d()).unwrap();
            assert_eq!(prob, set.pick_pmf(i, p), "at {p}, light {i}");
            observed[i] += 1.0;
        }
        if p.z > 3.0 {
            assert_eq!(pmf[2] + pmf[3], 0.0, "the panel faces away from {p}");
            assert_eq!(observed[2] + observed[3], 0.0);
        }
        let expected: Vec<f64> = pmf.iter().map(|q| q * n as f64).collect();
        let (chi2, dof) = chi2_from_counts(&observed, &expected, 5.0);
        let pv = 1.0 - regularized_gamma_p(dof as f64 / 2.0, chi2 / 2.0);
        assert!(
            pv >= SIGNIFICANCE,
            "at {p}: chi2 = {chi2}, dof = {dof}, p = {pv}"
        );
    }
    // Nearer lights are picked more often: at the origin the point light 3
    // units away gets 3 times its power share against the one √17 away
    // (intensity ratio 1:3, squared distances 9 and 17).
    let p = Vec3::ZERO;
    let ratio = set.pick_pmf(0, p) / set.pick_pmf(1, p);
    assert!((ratio - (1.0 / 9.0) / (3.0 / 17.0)).abs() < 1e-4, "{ratio}");
}

/// Mitsuba's rule (`LightPicking::Uniform`): every group that emits is
/// equally likely, whatever its power or where it is; a group of zero power
/// is never picked; within a group, lights go by power. Picks are
/// distributed as `pick_pmf` says (chi-square) and return its value.
#[test]
fn uniform_light_selection_picks_every_emitter_equally() {
    use plsr::light::{EnvironmentLight, LightPicking};
    let point = |position: Vec3, intensity: f32| {
        Light::Point(PointLight {
            position,
            intensity: Vec3::splat(intensity),
            cone: None,
            projection: None,
        })
    };
    let lights = vec![
        point(Vec3::new(0.0, 0.0, 3.0), 1.0),
        point(Vec3::new(4.0, 0.0, 1.0), 300.0),
        point(Vec3::new(1.0, 0.0, 1.0), 0.0),
        // One mesh of two triangles, the second four times the first.
        Light::Triangle(
            TriangleLight::new([Vec3::ZERO, Vec3::X, Vec3::Y], Vec3::splat(2.0), true).unwrap(),
        ),
        Light::Triangle(
            TriangleLight::new(
                [Vec3::Z, Vec3::Z + 2.0 * Vec3::X, Vec3::Z + 2.0 * Vec3::Y],
                Vec3::splat(2.0),
                true,
            )
            .unwrap(),
        ),
        Light::Environment {
            light: Box::new(EnvironmentLight::constant(Vec3::splat(5.0))),
            scene_radius: 10.0,
        },
    ];
    let groups = vec![
        (0..1, None),
        (1..2, None),
        (2..3, None),
        (3..5, None),
        (5..6, None),
    ];
    let set = LightSet::with_groups_picked_by(lights, groups, LightPicking::Uniform);
    assert!(!set.is_spatial() && set.picking() == LightPicking::Uniform);
    let expected_pmf: [f32; 6] = [0.25, 0.25, 0.0, 0.05, 0.2, 0.25];
    let n = 200_000;
    for (s, p) in [Vec3::ZERO, Vec3::new(3.0, 0.5, 0.5)]
        .into_iter()
        .enumerate()
    {
        for (i, &q) in expected_pmf.iter().enumerate() {
            let pmf = set.pick_pmf(i, p);
            assert!(
                (pmf - q).abs() < 1e-6,
                "at {p}: light {i} pmf {pmf}, not {q}"
            );
        }
        let mut observed = vec![0.0; 6];
        let mut rng = Rng::new(70 + s as u64, 1);
        for _ in 0..n {
            let (i, prob) = set.pick(p, rng.next_2d()).unwrap();
            assert_eq!(prob, set.pick_pmf(i, p), "at {p}, light {i}");
            observed[i] += 1.0;
        }
        assert_eq!(observed[2], 0.0, "a light of zero power was picked");
        let expected: Vec<f64> = expected_pmf.iter().map(|&q| q as f64 * n as f64).collect();
        let (chi2, dof) = chi2_from_counts(&observed, &expected, 5.0);
        let pv = 1.0 - regularized_gamma_p(dof as f64 / 2.0, chi2 / 2.0);
        assert!(
            pv >= SIGNIFICANCE,
            "at {p}: chi2 = {chi2}, dof = {dof}, p = {pv}"
        );
    }
    // Editing the lights (as fitting does) keeps the rule.
    let mut edited = set.clone();
    edited.scale_emission(1..2, Vec3::splat(10.0));
    assert_eq!(edited.pick_pmf(1, Vec3::ZERO), 0.25);
}

/// Next-event estimation on a parametric light (the paper's lamp): picking a
/// triangle by area and a point on it, seen from a point close by, draws
/// directions distributed as `pick_pmf × pdf_li` of the triangle they hit,
/// restricted to the light's cone.
#[test]
fn pls_light_sampling_matches_its_pdf() {
    let lighting =
        plsr::light::pls::file::load(std::path::Path::new("assets/lights/paper.toml")).unwrap();
    let lamp = &lighting.lights[1];
    pls_sampling_chi2(lamp, plsr::light::Cone::new(lamp.normal(), lamp.a_deg), 17);
}

/// The same with a soft-edged window (eq. 12′, 8° wide around the lamp's
/// 85°): the sampled directions cover the outer cone, where the window is
/// not zero, with the same density.
#[test]
fn pls_light_with_a_soft_edge_samples_as_its_pdf() {
    let lighting =
        plsr::light::pls::file::load(std::path::Path::new("assets/lights/paper.toml")).unwrap();
    let lamp = &lighting.lights[1];
    let cone = plsr::light::Cone::with_penumbra(lamp.normal(), lamp.a_deg, 8.0);
    assert!(cone.soft.is_some());
    pls_sampling_chi2(lamp, cone, 23);
}

fn pls_sampling_chi2(lamp: &plsr::light::pls::Pls, cone: plsr::light::Cone, seed: u64) {
    use plsr::light::Reach;
    let mesh = lamp.tessellate(8);
    let tris: Vec<[Vec3; 3]> = mesh
        .triangles
        .iter()
        .map(|t| t.map(|i| mesh.positions[i as usize]))
        .collect();
    let lights: Vec<Light> = tris
        .iter()
        .map(|&t| {
            Light::Triangle(
                TriangleLight::new(t, Vec3::ONE, false)
                    .unwrap()
                    .with_cone(cone),
            )
        })
        .collect();
    let set = LightSet::with_groups(
        lights,
        vec![(0..tris.len() as u32, Some(Reach::new(cone, tris.clone())))],
    );
    // A point 15 cm in front of the lamp, off to the side so that part of
    // the lamp is seen outside its 85° cone.
    let p = lamp.centre() + 0.15 * lamp.normal() + 0.2 * (lamp.g.e2 - lamp.g.e1).normalize();
    let mut rng = Rng::new(seed, 1);
    let r = chi2_test(
        SphereBinning {
            subdivisions: 48,
            ..Default::default()
        },
        DRAWS,
        |_| {
            let (i, _) = set.pick(p, rng.next_2d())?;
            set.lights[i].sample_li(p, rng.next_2d()).map(|s| s.wi)
        },
        &|w| {
            tris.iter()
                .enumerate()
                .find_map(|(i, t)| {
                    let x = hit_triangle_tolerant(p, w, t, 1e-5)?;
                    let Light::Triangle(tl) = &set.lights[i] else {
                        unreachable!()
                    };
                    // The window, with the same rounding slack.
                    let inside = -w.dot(tl.cone.unwrap().axis) >= tl.cone.unwrap().cos_a - 1e-6;
                    inside.then(|| (set.pick_pmf(i, p) * tl.pdf_li(p, x, w)) as f64)
                })
                .unwrap_or(0.0)
        },
        SIGNIFICANCE,
    );
    assert!(r.passed, "{}", r.summary);
}

/// Arvo's spherical-triangle sampling: uniform over the solid angle.
#[test]
fn spherical_triangle_sampling() {
    use plsr::warp::{sample_spherical_triangle, spherical_triangle_area};
    let tri = [
        Vec3::new(-1.0, -0.5, 0.4),
        Vec3::new(1.5, -0.2, 0.9),
        Vec3::new(-0.3, 1.2, 0.3),
    ];
    let p = Vec3::new(0.1, 0.05, 0.0);
    let omega = spherical_triangle_area(
        (tri[0] - p).normalize(),
        (tri[1] - p).normalize(),
        (tri[2] - p).normalize(),
    );
    let mut rng = Rng::new(18, 1);
    let r = chi2_test(
        SphereBinning {
            subdivisions: 16,
            ..Default::default()
        },
        DRAWS,
        |_| {
            let (w, pdf) = sample_spherical_triangle(&tri, p, rng.next_2d())?;
            assert!((pdf - 1.0 / omega).abs() < 1e-3 * pdf);
            Some(w)
        },
        &|w| {
            if hit_triangle_tolerant(p, w, &tri, 1e-6).is_some() {
                1.0 / omega as f64
            } else {
                0.0
            }
        },
        SIGNIFICANCE,
    );
    assert!(r.passed, "{}", r.summary);
}

/// A sphere light's cone sampling ([`plsr::light::SphereCap`]): directions
/// uniform in the cone the sphere subtends from outside (near and far),
/// uniform over all directions from inside, each as its pdf says.
#[test]
fn sphere_cone_sampling_matches_its_pdf() {
    let cap = plsr::light::SphereCap {
        center: Vec3::new(0.3, -0.2, 1.5),
        radius: 1.0,
        geom: 0,
        share: 1.0,
    };
    for (seed, p) in [
        (31, Vec3::ZERO),
        (32, Vec3::new(0.0, 0.5, -2.0)),
        (33, Vec3::new(0.2, 0.0, 1.2)),
    ] {
        let mut rng = Rng::new(seed, 1);
        // The pdf steps at the cone's edge: a fine sub-grid integrates it.
        let r = chi2_test(
            SphereBinning {
                subdivisions: 32,
                ..Default::default()
            },
            DRAWS,
            |_| Some(cap.sample_direction(p, rng.next_2d()).0),
            &|w| cap.pdf(p, w) as f64,
            SIGNIFICANCE,
        );
        assert!(r.passed, "from {p}: {}", r.summary);
    }
    // Every direction sampled reports the density it was drawn with.
    let mut rng = Rng::new(34, 1);
    for _ in 0..1000 {
        let p = Vec3::new(0.0, 0.5, -2.0);
        let (w, pdf) = cap.sample_direction(p, rng.next_2d());
        assert!((cap.pdf(p, w) - pdf).abs() <= 1e-5 * pdf, "{w}: {pdf}");
    }
}
