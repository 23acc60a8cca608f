//! Every BSDF verified as pbrt-v4 and Mitsuba 3 verify theirs:
//! - chi-square goodness-of-fit of `sample` against `pdf`, at several
//!   roughness values and incident angles, grazing included;
//! - `sample`, `eval` and `pdf` agree on every drawn direction;
//! - energy: `∫ f |cos θi| dωi ≤ 1`, and `= 1` where the model is lossless;
//! - reciprocity `f(wo, wi) = f(wi, wo)` (with the η² factor across a
//!   refracting interface);
//! - the pdf integrates to the probability that sampling succeeds.

use plsr_testkit as common;

use common::chi2::{chi2_test, SphereBinning};
use glam::{Vec2, Vec3};
use plsr::bsdf::{
    BlinnPhongParams, Bsdf, CookTorranceParams, DielectricParams, Distribution, Fresnel,
    Microfacet, PrincipledFullParams, PrincipledParams, PrincipledThinParams,
};
use plsr::rng::Rng;

/// Significance of each chi-square test: 1 % overall, Bonferroni-corrected
/// over the (BSDF, wo) pairs tested below (about 100).
const SIGNIFICANCE: f64 = 0.01 / 100.0;
const DRAWS: usize = 200_000;

/// Incident directions: normal, 45°, 75° and grazing 88°, at two azimuths.
fn incident_directions() -> Vec<Vec3> {
    [0.0f32, 45.0, 75.0, 88.0]
        .iter()
        .zip([0.0f32, 30.0, 200.0, 110.0])
        .map(|(t, p)| {
            let (t, p) = (t.to_radians(), p.to_radians());
            Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
        })
        .collect()
}

fn ct(kind: Distribution, ax: f32, ay: f32, fresnel: Fresnel) -> Bsdf {
    Bsdf::CookTorrance(CookTorranceParams {
        microfacet: Microfacet::new(kind, ax, ay),
        fresnel,
    })
}

fn gold() -> Fresnel {
    Fresnel::Conductor {
        eta: Vec3::new(0.143, 0.374, 1.442),
        k: Vec3::new(3.983, 2.385, 1.603),
        specular_reflectance: Vec3::ONE,
    }
}

fn rough_glass(kind: Distribution, alpha: f32) -> Bsdf {
    Bsdf::Dielectric(DielectricParams {
        eta: 1.5,
        microfacet: Some(Microfacet::isotropic(kind, alpha)),
    })
}

fn principled(roughness: f32, metallic: f32, anisotropic: f32) -> Bsdf {
    Bsdf::Principled(PrincipledParams {
        base_color: Vec3::new(0.8, 0.5, 0.2),
        roughness,
        metallic,
        anisotropic,
        specular: 0.5,
        spec_tint: 0.2,
        energy_conserving: false,
    })
}

/// The same, with the energy-conserving diffuse lobe.
fn principled_conserving(roughness: f32, metallic: f32, anisotropic: f32) -> Bsdf {
    let Bsdf::Principled(p) = principled(roughness, metallic, anisotropic) else {
        unreachable!()
    };
    Bsdf::Principled(PrincipledParams {
        energy_conserving: true,
        ..p
    })
}

fn blinn(exponent: f32) -> Bsdf {
    Bsdf::BlinnPhong(BlinnPhongParams {
        diffuse: Vec3::splat(0.4),
        specular: Vec3::splat(0.5),
        exponent,
    })
}

/// The non-delta BSDFs under test, with names for messages.
fn cases() -> Vec<(String, Bsdf)> {
    let mut v = Vec::new();
    v.push(("diffuse".into(), Bsdf::diffuse(Vec3::splat(0.7))));
    for n in [2.0, 20.0, 200.0] {
        v.push((format!("blinn-phong n={n}"), blinn(n)));
    }
    for kind in [Distribution::Ggx, Distribution::Beckmann] {
        for (ax, ay) in [(0.1, 0.1), (0.5, 0.5), (1.0, 1.0), (0.15, 0.6)] {
            v.push((
                format!("cook-torrance {kind:?} α=({ax},{ay})"),
                ct(kind, ax, ay, gold()),
            ));
        }
        // Transmission compresses the lobe by about (η−1)/η: α = 0.3 is as
        // sharp as the chi-square grid resolves at the poles.
        for alpha in [0.3, 0.6] {
            v.push((
                format!("rough dielectric {kind:?} α={alpha}"),
                rough_glass(kind, alpha),
            ));
        }
    }
    for (r, m, a) in [(0.3, 0.0, 0.0), (0.7, 0.5, 0.0), (0.4, 1.0, 0.8)] {
        v.push((
            format!("principled r={r} m={m} aniso={a}"),
            principled(r, m, a),
        ));
    }
    for (r, m, a) in [(0.5, 0.0, 0.0), (0.4, 0.3, 0.8)] {
        v.push((
            format!("principled energy-conserving r={r} m={m} aniso={a}"),
            principled_conserving(r, m, a),
        ));
    }
    // Thin sheets: every lobe, then glossy only and anisotropic (the
    // transmission's α is (0.65η − 0.35)²·r², 0.14 and 0.12 here).
    v.push((
        "principled thin, every lobe".into(),
        Bsdf::PrincipledThin(PrincipledThinParams {
            base_color: Vec3::new(0.8, 0.5, 0.3),
            roughness: 0.6,
            spec_trans: 0.5,
            diff_trans: 0.8,
            sheen: 0.5,
            sheen_tint: 0.4,
            spec_tint: 0.3,
            flatness: 0.5,
            ..Default::default()
        }),
    ));
    v.push((
        "principled thin, glossy, anisotropic".into(),
        Bsdf::PrincipledThin(PrincipledThinParams {
            base_color: Vec3::splat(0.9),
            roughness: 0.8,
            anisotropic: 0.6,
            spec_trans: 1.0,
            eta: 1.2,
            ..Default::default()
        }),
    ));
    // Principled with every lobe: opaque with sheen, clearcoat (its widest
    // GTR1, α = 0.1) and flatness; then with a transmission lobe, seen from
    // both sides.
    v.push((
        "principled full, opaque".into(),
        Bsdf::PrincipledFull(PrincipledFullParams {
            base_color: Vec3::new(0.8, 0.5, 0.3),
            metallic: 0.2,
            spec_tint: 0.3,
            sheen: 0.6,
            sheen_tint: 0.5,
            clearcoat: 0.8,
            flatness: 0.4,
            ..Default::default()
        }),
    ));
    v.push((
        "principled full, transmission".into(),
        Bsdf::PrincipledFull(PrincipledFullParams {
            base_color: Vec3::new(0.9, 0.7, 0.5),
            roughness: 0.6,
            metallic: 0.1,
            anisotropic: 0.4,
            spec_trans: 0.6,
            clearcoat: 0.5,
            sheen: 0.3,
            has_transmission: true,
            ..Default::default()
        }),
    ));
    v
}

/// Binning fine enough to integrate the sharpest lobes tested (α = 0.1).
/// An even number of `cos θ` bins puts the horizon, where every BSDF's pdf
/// jumps, on a cell edge, so the midpoint rule never straddles it.
fn binning() -> SphereBinning {
    SphereBinning {
        theta_bins: 20,
        phi_bins: 41,
        subdivisions: 32,
    }
}

/// The directions to test from: above only for opaque models, and also
/// from inside for transmissive ones.
fn directions_for(bsdf: &Bsdf) -> Vec<Vec3> {
    let mut dirs = incident_directions();
    if bsdf.transmits() {
        dirs.extend(incident_directions().into_iter().map(|w| -w));
    }
    dirs
}

#[test]
fn sampling_matches_pdf_chi_square() {
    let mut failures = Vec::new();
    for (name, bsdf) in cases() {
        for wo in directions_for(&bsdf) {
            let mut rng = Rng::new(1234, 5);
            let r = chi2_test(
                binning(),
                DRAWS,
                |_| bsdf.sample(wo, rng.next_f32(), rng.next_2d()).map(|s| s.wi),
                &|wi| bsdf.pdf(wo, wi) as f64,
                SIGNIFICANCE,
            );
            if !r.passed {
                failures.push(format!("{name}, wo = {wo}: {}", r.summary));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn sample_eval_and_pdf_agree() {
    for (name, bsdf) in cases() {
        for wo in directions_for(&bsdf) {
            let mut rng = Rng::new(99, 1);
            for _ in 0..2000 {
                let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) else {
                    continue;
                };
                assert!(!s.delta, "{name}");
                assert!(
                    (s.wi.length() - 1.0).abs() < 1e-4,
                    "{name}: |wi| = {}",
                    s.wi.length()
                );
                let f = bsdf.eval(wo, s.wi);
                let pdf = bsdf.pdf(wo, s.wi);
                let tol = |a: f32, b: f32| (a - b).abs() <= 1e-3 * a.abs().max(b.abs()) + 1e-6;
                assert!(
                    tol(pdf, s.pdf),
                    "{name}, wo={wo}, wi={}: pdf {pdf} vs {}",
                    s.wi,
                    s.pdf
                );
                for c in 0..3 {
                    assert!(tol(f[c], s.f[c]), "{name}: f {f} vs {}", s.f);
                    let w = s.f[c] * s.wi.z.abs() / s.pdf;
                    assert!(tol(w, s.weight[c]), "{name}: weight {} vs {w}", s.weight);
                }
            }
        }
    }
}

/// `∫ g(w) dω` over the sphere: the midpoint rule in `(s, φ)` with
/// `θ = π(1 − cos πs)/2`, which crowds nodes at both poles, where refraction
/// makes the sharpest lobes, and puts the horizon (`s = 1/2`) on a node edge.
fn integrate_sphere(g: &dyn Fn(Vec3) -> f64) -> f64 {
    use std::f64::consts::PI;
    let (ns, np) = (6000, 300);
    let mut sum = 0.0;
    for i in 0..ns {
        let s = (i as f64 + 0.5) / ns as f64;
        let theta = 0.5 * PI * (1.0 - (PI * s).cos());
        let dtheta = 0.5 * PI * PI * (PI * s).sin() / ns as f64;
        let (st, ct) = theta.sin_cos();
        let mut row = 0.0;
        for j in 0..np {
            let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            row += g(Vec3::new(
                (st * phi.cos()) as f32,
                (st * phi.sin()) as f32,
                ct as f32,
            ));
        }
        sum += row * st * dtheta * 2.0 * PI / np as f64;
    }
    sum
}

/// Fraction of successful samples from `wo`, with its standard error.
fn success_rate(bsdf: &Bsdf, wo: Vec3, n: usize) -> (f64, f64) {
    let mut rng = Rng::new(7, 7);
    let ok = (0..n)
        .filter(|_| bsdf.sample(wo, rng.next_f32(), rng.next_2d()).is_some())
        .count() as f64
        / n as f64;
    (ok, (ok * (1.0 - ok) / n as f64).sqrt())
}

#[test]
fn pdf_integrates_to_the_probability_of_a_sample() {
    // Up to 75°: at 88° a sharp lobe's reflection sits 4° from −wo, where the
    // half-vector Jacobian 1/(4 wo·h) peaks too steeply for a fixed grid;
    // the chi-square test above covers grazing incidence.
    for (name, bsdf) in cases() {
        for wo in directions_for(&bsdf)
            .into_iter()
            .filter(|w| w.z.abs() > 0.2)
        {
            let integral = integrate_sphere(&|wi| bsdf.pdf(wo, wi) as f64);
            let (rate, se) = success_rate(&bsdf, wo, 200_000);
            assert!(
                integral <= 1.0 + 5e-3,
                "{name}, wo = {wo}: ∫pdf = {integral}"
            );
            assert!(
                (integral - rate).abs() < 4.0 * se + 5e-3,
                "{name}, wo = {wo}: ∫pdf = {integral} but {rate} of samples succeed"
            );
        }
    }
}

/// Directional albedo `∫ f(wo, wi) |cos θi| dωi` (of the first channel; the
/// furnace models are grey).
fn albedo(bsdf: &Bsdf, wo: Vec3) -> f32 {
    integrate_sphere(&|wi| (bsdf.eval(wo, wi).x * wi.z.abs()) as f64) as f32
}

#[test]
fn white_furnace_energy_is_at_most_one() {
    // Models made white: nothing may reflect more than it receives.
    let mut white = vec![
        ("diffuse".to_string(), Bsdf::diffuse(Vec3::ONE)),
        (
            "blinn-phong kd+ks=1".into(),
            Bsdf::BlinnPhong(BlinnPhongParams {
                diffuse: Vec3::splat(0.5),
                specular: Vec3::splat(0.5),
                exponent: 30.0,
            }),
        ),
        (
            "blinn-phong ks=1 n=1".into(),
            Bsdf::BlinnPhong(BlinnPhongParams {
                diffuse: Vec3::ZERO,
                specular: Vec3::ONE,
                exponent: 1.0,
            }),
        ),
    ];
    for r in [0.2, 0.5, 1.0] {
        white.push((format!("principled metallic r={r}"), {
            let Bsdf::Principled(p) = principled(r, 1.0, 0.0) else {
                unreachable!()
            };
            Bsdf::Principled(PrincipledParams {
                base_color: Vec3::ONE,
                ..p
            })
        }));
    }
    for kind in [Distribution::Ggx, Distribution::Beckmann] {
        for alpha in [0.1, 0.5, 1.0] {
            white.push((
                format!("cook-torrance {kind:?} α={alpha} F=1"),
                ct(kind, alpha, alpha, Fresnel::Schlick { f0: Vec3::ONE }),
            ));
            white.push((
                format!("rough dielectric {kind:?} α={alpha}"),
                rough_glass(kind, alpha),
            ));
        }
    }
    for wo in incident_directions() {
        for (name, bsdf) in &white {
            let mut dirs = vec![wo];
            if bsdf.transmits() {
                dirs.push(-wo);
            }
            for wo in dirs {
                // Transmission carries the 1/η² radiance factor: undo it to
                // count energy.
                let a = if bsdf.transmits() {
                    energy_of_dielectric(bsdf, wo)
                } else {
                    albedo(bsdf, wo)
                };
                assert!(a <= 1.0 + 3e-3, "{name}, wo = {wo}: albedo {a}");
            }
        }
    }
    // Lossless models reflect everything.
    for wo in incident_directions() {
        let a = albedo(&Bsdf::diffuse(Vec3::ONE), wo);
        assert!((a - 1.0).abs() < 2e-3, "diffuse: {a}");
        // Nearly smooth microfacets with F = 1 lose almost nothing away from
        // grazing (single scattering loses energy only at high roughness).
        if wo.z > 0.5 {
            let smoothish = ct(
                Distribution::Ggx,
                0.1,
                0.1,
                Fresnel::Schlick { f0: Vec3::ONE },
            );
            let a = albedo(&smoothish, wo);
            assert!(a > 0.98, "GGX α=0.1, wo={wo}: {a}");
        }
    }
}

/// Energy leaving a dielectric for light arriving along `wo`: the integral
/// of `f |cos θi|` with the radiance factor `1/η'²` undone for transmission.
fn energy_of_dielectric(bsdf: &Bsdf, wo: Vec3) -> f32 {
    let Bsdf::Dielectric(p) = bsdf else {
        unreachable!()
    };
    let e = integrate_sphere(&|wi| {
        let f = bsdf.eval(wo, wi).x as f64 * wi.z.abs() as f64;
        if wi.z * wo.z < 0.0 {
            let etap = if wo.z > 0.0 { p.eta } else { 1.0 / p.eta } as f64;
            f * etap * etap
        } else {
            f
        }
    });
    e as f32
}

/// A smooth dielectric reflects `F` of the energy and transmits the rest,
/// nothing lost; it draws the mirror direction with its reflection
/// probability (`F` from outside, `√F` from inside), each sample weighted
/// so that the expected energies are exactly `F` and `1 − F`.
#[test]
fn smooth_dielectric_is_lossless_and_obeys_fresnel() {
    let glass = Bsdf::Dielectric(DielectricParams {
        eta: 1.5,
        microfacet: None,
    });
    assert!(glass.is_delta() && glass.transmits());
    for wo in incident_directions()
        .into_iter()
        .chain(incident_directions().into_iter().map(|w| -w))
    {
        let mut rng = Rng::new(3, 3);
        let n = 200_000;
        let (mut energy, mut energy_sq, mut reflected_energy, mut reflected) =
            (0.0f64, 0.0f64, 0.0f64, 0usize);
        for _ in 0..n {
            let s = glass
                .sample(wo, rng.next_f32(), rng.next_2d())
                .expect("a smooth dielectric always scatters");
            assert!(s.delta);
            assert_eq!(glass.eval(wo, s.wi), Vec3::ZERO);
            assert_eq!(glass.pdf(wo, s.wi), 0.0);
            // Undo the radiance factor 1/η'² of a refraction.
            let etap2 = if s.wi.z * wo.z < 0.0 {
                let etap = if wo.z > 0.0 { 1.5f32 } else { 1.0 / 1.5 };
                etap * etap
            } else {
                1.0
            };
            let e = (s.weight.x * etap2) as f64;
            if s.wi.z * wo.z > 0.0 {
                reflected += 1;
                reflected_energy += e;
            }
            energy += e;
            energy_sq += e * e;
        }
        let nf = n as f64;
        let f = plsr::bsdf::fresnel::dielectric(wo.z, 1.5) as f64;
        let p = DielectricParams::reflect_probability(f as f32, wo.z > 0.0) as f64;
        // Every sample's energy is 1 when the probability is F; otherwise
        // F/p or (1 − F)/(1 − p), which average to 1.
        let mean = energy / nf;
        let se = ((energy_sq / nf - mean * mean) / nf).sqrt();
        assert!(
            (mean - 1.0).abs() < 4.0 * se + 1e-5,
            "wo = {wo}: energy {mean} ± {se}"
        );
        let se_r = (p * (1.0 - p) / nf).sqrt().max(1e-6);
        let got = reflected as f64 / nf;
        assert!(
            (got - p).abs() < 4.0 * se_r + 1e-6,
            "wo = {wo}: reflected {got} of the samples, want {p} (F = {f})"
        );
        // The reflected energy is F: each reflection weighs F/p.
        let got = reflected_energy / nf;
        assert!(
            (got - f).abs() < 4.0 * se_r * f / p.max(1e-9) + 1e-6,
            "wo = {wo}: reflected energy {got} vs F = {f}"
        );
    }
    // From inside, at normal incidence, the mirror is drawn √F of the
    // time: 0.2 in glass, not F = 0.04.
    let f = plsr::bsdf::fresnel::dielectric(-1.0, 1.5);
    assert!((DielectricParams::reflect_probability(f, false) - 0.2).abs() < 1e-6);
    assert_eq!(DielectricParams::reflect_probability(f, true), f);
}

#[test]
fn reciprocity() {
    let mut rng = Rng::new(5, 5);
    let random_dir = |rng: &mut Rng| {
        plsr::warp::square_to_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()))
    };
    for (name, bsdf) in cases() {
        for _ in 0..500 {
            let (a, b) = (random_dir(&mut rng), random_dir(&mut rng));
            // Mitsuba's thin sheet tests the microfacet's side against the
            // transmitted direction itself, not its mirror image, so its
            // glossy transmission is not reciprocal (plsr keeps Mitsuba's
            // model); its reflection is.
            if matches!(bsdf, Bsdf::PrincipledThin(_)) && a.z * b.z < 0.0 {
                continue;
            }
            // The energy-conserving metal's multiple-scattering factor
            // depends on wo alone (Turquin's compensation, as Cycles'), so
            // it is not reciprocal; the rest of that BSDF is (checked with
            // metallic 0 in `cases`).
            if matches!(bsdf, Bsdf::Principled(p) if p.energy_conserving && p.metallic > 0.0) {
                continue;
            }
            let (fab, fba) = (bsdf.eval(a, b), bsdf.eval(b, a));
            // Radiance crossing a refracting interface scales by η²: the
            // symmetric quantity is f(wo, wi)/η(wo)² (Veach 1997, eq. 5.14),
            // with η(w) the index of the medium `w` points into.
            let scale = |wo: Vec3, wi: Vec3| -> f32 {
                let eta = match bsdf {
                    Bsdf::Dielectric(p) => Some(p.eta),
                    Bsdf::PrincipledFull(p) => Some(p.eta),
                    _ => None,
                };
                if let (Some(inside), true) = (eta, wo.z * wi.z < 0.0) {
                    let eta = |w: Vec3| if w.z > 0.0 { 1.0f32 } else { inside };
                    1.0 / (eta(wo) * eta(wo))
                } else {
                    1.0
                }
            };
            let (x, y) = (fab * scale(a, b), fba * scale(b, a));
            let tol = 1e-3 * x.max_element().max(y.max_element()) + 1e-6;
            assert!(
                (x - y).abs().max_element() <= tol,
                "{name}: f(a,b) = {fab}, f(b,a) = {fba}, a = {a}, b = {b}"
            );
        }
    }
}

#[test]
fn principled_metal_and_dielectric_limits() {
    // metallic = 1, roughness → 0: a mirror tinted by base_color at normal
    // incidence (Schlick with f0 = base colour).
    let metal = PrincipledParams {
        base_color: Vec3::new(0.9, 0.6, 0.3),
        roughness: 0.2,
        metallic: 1.0,
        anisotropic: 0.0,
        specular: 0.5,
        spec_tint: 0.0,
        energy_conserving: false,
    };
    let a = albedo(&Bsdf::Principled(metal), Vec3::Z);
    // A rough-ish GGX lobe keeps most energy; the albedo is close to base colour.
    assert!((a - metal.base_color.x).abs() < 0.05, "{a}");
    // specular 0.5 is η = 1.5 (Mitsuba's mapping).
    assert!((metal.eta() - 1.5).abs() < 1e-3, "{}", metal.eta());
    // metallic = 0 reflects at normal incidence about f0(1.5) = 4 % specularly
    // plus the diffuse base colour.
    let plastic = PrincipledParams {
        metallic: 0.0,
        spec_tint: 0.0,
        ..metal
    };
    let a = albedo(&Bsdf::Principled(plastic), Vec3::Z);
    assert!(a > 0.8 && a < 1.0, "{a}");
}

/// The principled BSDF follows Mitsuba 3's (Burley 2012) exactly, and that
/// model is not energy-conserving where it is a dielectric: the diffuse lobe
/// is not reduced by the specular one, and its retro-reflection term grows
/// at grazing angles. With a white base colour it reflects more than it
/// receives. Pinned here so that a change of model is deliberate.
#[test]
fn principled_dielectric_exceeds_one_like_its_reference_model() {
    let white = |roughness: f32| {
        Bsdf::Principled(PrincipledParams {
            base_color: Vec3::ONE,
            roughness,
            metallic: 0.0,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving: false,
        })
    };
    let grazing = incident_directions()[3];
    // Normal incidence: diffuse (1 − F_i/2)(1 − F_o/2) plus 4 % specular.
    let a = albedo(&white(0.5), Vec3::Z);
    assert!((1.0..1.1).contains(&a), "{a}");
    // Rough and grazing: the retro-reflection term dominates.
    let a = albedo(&white(1.0), grazing);
    assert!((1.4..1.7).contains(&a), "{a}");
}

/// Directional albedo per channel estimated from `sample`'s weights, with
/// its standard error.
fn sampled_albedo(bsdf: &Bsdf, wo: Vec3) -> [(f64, f64); 3] {
    let mut rng = Rng::new(11, 3);
    let n = 200_000;
    let (mut sum, mut sum2) = ([0.0f64; 3], [0.0f64; 3]);
    for _ in 0..n {
        if let Some(s) = bsdf.sample(wo, rng.next_f32(), rng.next_2d()) {
            for c in 0..3 {
                let w = s.weight[c] as f64;
                sum[c] += w;
                sum2[c] += w * w;
            }
        }
    }
    [0, 1, 2].map(|c| {
        let mean = sum[c] / n as f64;
        (mean, ((sum2[c] / n as f64 - mean * mean) / n as f64).sqrt())
    })
}

/// With `energy_conserving`, the diffuse lobe receives exactly what the
/// specular lobe leaves: a white dielectric reflects everything (= 1 at
/// every angle and roughness, anisotropic and tinted included), and no
/// base colour or metallic mix reflects more than 1 in any channel.
#[test]
fn energy_conserving_principled_reflects_at_most_one() {
    let with_specular = |base: Vec3, roughness: f32, specular: f32, spec_tint: f32| {
        Bsdf::Principled(PrincipledParams {
            base_color: base,
            roughness,
            metallic: 0.0,
            anisotropic: 0.0,
            specular,
            spec_tint,
            energy_conserving: true,
        })
    };
    let make = |base: Vec3, roughness: f32, metallic: f32, anisotropic: f32, spec_tint: f32| {
        let Bsdf::Principled(p) = with_specular(base, roughness, 0.5, spec_tint) else {
            unreachable!()
        };
        Bsdf::Principled(PrincipledParams {
            metallic,
            anisotropic,
            ..p
        })
    };
    for wo in incident_directions() {
        // Any `specular`, including small ones, where the dielectric albedo
        // jumps from 0 to nearly 1 at grazing angles as η leaves 1.
        for specular in [0.0, 0.01, 0.03, 0.1, 0.3, 1.0] {
            for (r, t) in [(0.05, 0.0), (0.3, 0.5), (0.8, 0.0)] {
                let (e, se) = sampled_albedo(&with_specular(Vec3::ONE, r, specular, t), wo)[0];
                assert!(
                    (e - 1.0).abs() < 4.0 * se + 6e-3,
                    "white r={r} specular={specular} tint={t}, wo = {wo}: albedo {e} ± {se}"
                );
            }
        }
        for (r, a, t) in [
            (0.05, 0.0, 0.0),
            (0.3, 0.0, 0.0),
            (0.7, 0.0, 0.5),
            (1.0, 0.0, 0.0),
            (0.5, 0.8, 0.0),
        ] {
            // White dielectric: lossless, within the tables' sampling and
            // interpolation (measured ±0.3 %). An anisotropic lobe's albedo
            // is approximated by the isotropic one at the roughness along
            // each direction's azimuth: within 0.5 % up to 75°, 1.8 % over
            // at 88° for this lobe (up to 2.5 % with anisotropic = 1). The albedo is estimated by importance sampling, which
            // resolves the sharpest lobes a fixed grid misses.
            let (e, se) = sampled_albedo(&make(Vec3::ONE, r, 0.0, a, t), wo)[0];
            let tolerance = if a > 0.0 && wo.z < 0.1 { 0.025 } else { 6e-3 };
            assert!(
                (e - 1.0).abs() < 4.0 * se + tolerance,
                "white r={r} aniso={a} tint={t}, wo = {wo}: albedo {e} ± {se}"
            );
        }
        for (base, r, m, a, t) in [
            (Vec3::new(0.9, 0.5, 0.1), 0.4, 0.0, 0.0, 1.0),
            (Vec3::new(1.0, 0.2, 1.0), 0.8, 0.5, 0.0, 0.3),
            (Vec3::new(0.95, 0.95, 0.95), 0.2, 0.3, 0.6, 0.0),
        ] {
            let e = sampled_albedo(&make(base, r, m, a, t), wo);
            let tolerance = if a > 0.0 && wo.z < 0.1 { 0.025 } else { 5e-3 };
            for (c, (e, se)) in e.into_iter().enumerate() {
                assert!(
                    e <= 1.0 + 4.0 * se + tolerance,
                    "base {base} r={r} m={m} aniso={a} tint={t}, wo = {wo}: channel {c} albedo {e} ± {se}"
                );
            }
        }
    }
    // The specular lobe is untouched: a rough black dielectric reflects the
    // same in both modes.
    let black = |conserving| {
        Bsdf::Principled(PrincipledParams {
            base_color: Vec3::ZERO,
            roughness: 0.4,
            metallic: 0.0,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving: conserving,
        })
    };
    let wo = incident_directions()[1];
    assert_eq!(albedo(&black(false), wo), albedo(&black(true), wo));
}

/// With `energy_conserving`, the metal's lobe gets back what single
/// scattering loses between the microfacets (Turquin's compensation, as
/// Cycles): a white metal reflects everything at every angle and roughness,
/// alone or mixed with a white dielectric, where Mitsuba's mode loses up to
/// a third at roughness 1.
#[test]
fn energy_conserving_white_metal_reflects_everything() {
    let metal = |roughness: f32, metallic: f32, conserving: bool| {
        Bsdf::Principled(PrincipledParams {
            base_color: Vec3::ONE,
            roughness,
            metallic,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving: conserving,
        })
    };
    let mut lossiest = 1.0f64;
    for wo in incident_directions() {
        for r in [0.1, 0.4, 0.7, 1.0] {
            for m in [1.0, 0.5] {
                // Within the tables' accuracy: their stratified quadrature
                // misses part of a narrow lobe's tail below the horizon
                // (measured up to 1 % at roughness 0.4).
                let (e, se) = sampled_albedo(&metal(r, m, true), wo)[0];
                assert!(
                    (e - 1.0).abs() < 4.0 * se + 0.012,
                    "white metal r={r} metallic={m}, wo = {wo}: albedo {e} ± {se}"
                );
            }
            lossiest = lossiest.min(sampled_albedo(&metal(r, 1.0, false), wo)[0].0);
        }
    }
    assert!(
        lossiest < 0.8,
        "Mitsuba's mode lost only {}",
        1.0 - lossiest
    );
}

/// The tabulated specular albedo agrees with direct integration of the
/// specular lobe between grid points.
#[test]
fn specular_albedo_table_matches_integration() {
    for (mu, roughness, specular) in [
        (0.37f32, 0.23f32, 0.3f32),
        (0.9, 0.61, 0.5),
        (0.12, 0.9, 0.85),
        (0.21, 0.4, 0.03),
    ] {
        let tables = plsr::bsdf::albedo::DielectricAlbedo::for_specular(specular);
        let black = Bsdf::Principled(PrincipledParams {
            base_color: Vec3::ZERO,
            roughness,
            metallic: 0.0,
            anisotropic: 0.0,
            specular,
            spec_tint: 0.0,
            energy_conserving: false,
        });
        let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let want = albedo(&black, wo);
        let got = tables.directional(mu, roughness * roughness);
        assert!(
            (got - want).abs() < 3e-3,
            "μ={mu} r={roughness} specular={specular}: table {got}, integral {want}"
        );
    }
}

#[test]
fn eval_pdf_equals_eval_and_pdf() {
    let mut rng = Rng::new(21, 2);
    for (name, bsdf) in cases() {
        for _ in 0..2000 {
            let a = plsr::warp::square_to_uniform_sphere(rng.next_2d());
            let b = plsr::warp::square_to_uniform_sphere(rng.next_2d());
            let (f, p) = bsdf.eval_pdf(a, b);
            let (f2, p2) = (bsdf.eval(a, b), bsdf.pdf(a, b));
            // Cook–Torrance's and dielectrics' eval and pdf are eval_pdf's
            // halves: the same bits; the principled BSDF's eval_pdf
            // reorders its sums.
            let exact = matches!(bsdf, Bsdf::CookTorrance(_) | Bsdf::Dielectric(_));
            let close = |x: f32, y: f32| {
                if exact {
                    x.to_bits() == y.to_bits()
                } else {
                    (x - y).abs() <= 1e-4 * x.abs().max(y.abs()) + 1e-7
                }
            };
            assert!(close(p, p2), "{name}: pdf {p} vs {p2}");
            for c in 0..3 {
                assert!(close(f[c], f2[c]), "{name}: f {f} vs {f2}");
            }
        }
    }
}

/// Dielectrics test their configurations with flags and select at the end
/// (so that the vectorised kernel's loops stay vector code): a direction in
/// the surface's plane, or a microfacet that either direction sees from
/// behind, must still give nothing, not the arithmetic computed for it.
#[test]
fn dielectrics_give_nothing_for_degenerate_or_back_facing_configurations() {
    let (s, c) = (60f32.to_radians().sin(), 60f32.to_radians().cos());
    let wo = Vec3::new(s, 0.0, c);
    // From inside near the normal (5°) out at 85° on the same side: the
    // half vector η'·wi + wo faces away from wi, while the Fresnel term
    // there is 0.07 and a Beckmann density D(h)·cos θh at α = 1 is 0.45, so
    // computed regardless the density would be far from zero.
    let (s5, c5) = (5f32.to_radians().sin(), 5f32.to_radians().cos());
    let (s85, c85) = (85f32.to_radians().sin(), 85f32.to_radians().cos());
    let (wo_inside, wi_back) = (Vec3::new(s5, 0.0, -c5), Vec3::new(s85, 0.0, c85));
    // Through the interface the way Snell's law bends it.
    let wi_snell = Vec3::new(-s / 1.5, 0.0, -(1.0 - (s / 1.5).powi(2)).sqrt());
    let grazing = Vec3::X;
    let smooth = Bsdf::Dielectric(DielectricParams {
        eta: 1.5,
        microfacet: None,
    });
    let mut rng = Rng::new(4, 1);
    for kind in [Distribution::Ggx, Distribution::Beckmann] {
        let rough = rough_glass(kind, 1.0);
        let (f, pdf) = rough.eval_pdf(wo_inside, wi_back);
        assert_eq!((f, pdf), (Vec3::ZERO, 0.0), "{kind:?}: back-facing h");
        let (f, pdf) = rough.eval_pdf(wo, wi_snell);
        assert!(f.x > 0.0 && pdf > 0.0, "{kind:?}: {f} {pdf}");
        for (a, b) in [(grazing, wi_snell), (wo, grazing)] {
            assert_eq!(rough.eval_pdf(a, b), (Vec3::ZERO, 0.0), "{kind:?}");
        }
        for _ in 0..100 {
            let (uc, u) = (rng.next_f32(), rng.next_2d());
            assert!(rough.sample(grazing, uc, u).is_none(), "{kind:?}");
        }
    }
    for _ in 0..100 {
        let (uc, u) = (rng.next_f32(), rng.next_2d());
        assert!(smooth.sample(grazing, uc, u).is_none());
    }
}

/// Mitsuba 3.9.1's own values of its `principled` BSDF (f without the
/// cosine and the sampling density, for six parameter sets and ten pairs of
/// directions from outside and inside), written by
/// `scripts/mitsuba_bsdf_values.py`.
const MITSUBA_PRINCIPLED: &str = include_str!("../data/mitsuba_bsdf/principled.json");

#[test]
fn principled_with_every_lobe_gives_mitsubas_values() {
    let json: serde_json::Value = serde_json::from_str(MITSUBA_PRINCIPLED).unwrap();
    let vec3 = |v: &serde_json::Value| {
        let a: Vec<f32> = v
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        Vec3::new(a[0], a[1], a[2])
    };
    let mut compared = 0;
    for case in json["cases"].as_array().unwrap() {
        let params = &case["params"];
        let number = |k: &str, default: f32| params[k].as_f64().map_or(default, |v| v as f32);
        let spec_trans = number("spec_trans", 0.0);
        let p = PrincipledFullParams {
            base_color: vec3(&params["base_color"]),
            roughness: number("roughness", 0.5),
            metallic: number("metallic", 0.0),
            anisotropic: number("anisotropic", 0.0),
            eta: number("eta", plsr::bsdf::albedo::eta_from_specular(0.5)),
            spec_tint: number("spec_tint", 0.0),
            sheen: number("sheen", 0.0),
            sheen_tint: number("sheen_tint", 0.0),
            clearcoat: number("clearcoat", 0.0),
            clearcoat_gloss: number("clearcoat_gloss", 0.0),
            spec_trans,
            flatness: number("flatness", 0.0),
            has_transmission: spec_trans != 0.0,
        };
        let bsdf = Bsdf::PrincipledFull(p.validate().unwrap());
        for pair in case["pairs"].as_array().unwrap() {
            let (wo, wi) = (vec3(&pair["wo"]), vec3(&pair["wi"]));
            let (f, pdf) = (bsdf.eval(wo, wi), bsdf.pdf(wo, wi));
            let expected = vec3(&pair["f"]);
            let tol = 2e-4 * expected.max_element() + 1e-6;
            assert!(
                (f - expected).abs().max_element() <= tol,
                "{params}: wo {wo}, wi {wi}: f {f}, Mitsuba's {expected}"
            );
            // Mitsuba reports a density from behind an opaque surface, where
            // its sampler (like plsr's) draws nothing; plsr gives 0 there.
            if wo.z > 0.0 || p.has_transmission {
                let expected = pair["pdf"].as_f64().unwrap() as f32;
                assert!(
                    (pdf - expected).abs() <= 2e-4 * expected + 1e-6,
                    "{params}: wo {wo}, wi {wi}: pdf {pdf}, Mitsuba's {expected}"
                );
            }
            compared += 1;
        }
    }
    assert_eq!(compared, 60);
}

/// With `spec_trans = 1`, no metal and a white base, the principled BSDF is
/// the rough GGX dielectric of the same `α` and `η`, from both sides.
#[test]
fn principled_with_full_transmission_is_the_rough_dielectric() {
    let p = PrincipledFullParams {
        base_color: Vec3::ONE,
        roughness: 0.6,
        eta: 1.4,
        spec_trans: 1.0,
        has_transmission: true,
        ..Default::default()
    };
    let glass = DielectricParams {
        eta: 1.4,
        microfacet: Some(Microfacet::isotropic(Distribution::Ggx, 0.36)),
    };
    let (a, b) = (Bsdf::PrincipledFull(p), Bsdf::Dielectric(glass));
    let mut rng = Rng::new(9, 9);
    for _ in 0..2000 {
        let wo = plsr::warp::square_to_uniform_sphere(rng.next_2d());
        let wi = plsr::warp::square_to_uniform_sphere(rng.next_2d());
        let (x, y) = (a.eval(wo, wi), b.eval(wo, wi));
        assert!(
            (x - y).abs().max_element() <= 1e-4 * y.max_element() + 1e-6,
            "wo {wo}, wi {wi}: {x} against the dielectric's {y}"
        );
        assert_eq!(a.eta_scale(wo, wi), b.eta_scale(wo, wi));
    }
}
