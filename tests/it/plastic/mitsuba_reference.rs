//! `PlasticParams` and `RoughPlasticParams` against Mitsuba 3's `plastic`
//! and `roughplastic`: the values Mitsuba computed for 56 fixed direction
//! pairs under 15 parameter sets (`mitsuba_reference.py` wrote them to
//! `mitsuba_reference/data.rs`), and Mitsuba's directional albedos.

use super::common;

#[rustfmt::skip]
mod data;

use common::{integrated_albedo, sampled_albedo, Model};
use glam::Vec3;
use plsr::bsdf::plastic::mitsuba_smith_g1;
use plsr::bsdf::plastic::RoughPlasticTable;
use plsr::bsdf::{Distribution, PlasticParams, RoughPlasticParams};

/// One parameter set and what Mitsuba computed for it.
pub struct Case {
    pub name: &'static str,
    pub model: Model,
    pub pairs: &'static [Pair],
    pub albedos: &'static [Albedo],
}

/// Mitsuba's values for a pair of directions (plsr's convention: `wo`
/// towards the viewer, Mitsuba's `si.wi`; `f` without the cosine).
pub struct Pair {
    pub wo: [f32; 3],
    pub wi: [f32; 3],
    pub f: [f64; 3],
    pub pdf: f64,
    /// The probability of Mitsuba's specular lobe from `wo`.
    pub p_spec: f32,
}

/// Mitsuba's directional albedo towards `wo` (its delta lobe included),
/// by Monte Carlo with its own sampling: mean and standard error.
pub struct Albedo {
    pub wo: [f32; 3],
    pub mean: [f64; 3],
    pub se: [f64; 3],
}

/// A roughplastic table's entries as Mitsuba computed them (recovered
/// from its values).
pub struct Table {
    pub distribution: Distribution,
    pub alpha: f32,
    pub int_ior: f32,
    pub ext_ior: f32,
    pub transmittance: [f64; 64],
    pub internal_reflectance: f64,
}

/// Relative tolerance of values and densities.
const RELATIVE: f64 = 1e-4;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= RELATIVE * a.abs().max(b.abs()) + 1e-30
}

#[test]
fn eval_matches_mitsuba() {
    let (mut checked, mut nonzero, mut worst) = (0, 0, 0.0f64);
    for case in data::CASES {
        for p in case.pairs {
            let (wo, wi) = (Vec3::from(p.wo), Vec3::from(p.wi));
            let f = case.model.eval(wo, wi);
            for c in 0..3 {
                let (got, want) = (f[c] as f64, p.f[c]);
                assert!(
                    close(got, want),
                    "{}: wo {wo}, wi {wi}, channel {c}: f = {got:e}, Mitsuba {want:e}",
                    case.name
                );
                if want != 0.0 {
                    nonzero += 1;
                    worst = worst.max((got - want).abs() / want.abs());
                }
                checked += 1;
            }
            // eval_pdf gives the same value.
            assert_eq!(case.model.eval_pdf(wo, wi).0, f, "{}", case.name);
        }
    }
    println!("{checked} values ({nonzero} non-zero), worst relative difference {worst:e}");
    assert!(nonzero > 2000);
}

/// Mitsuba's density with its (rational, Walter et al.) Beckmann masking
/// term in the visible-normal density replaced by Smith's exact one, which
/// plsr uses because it is the density the sampler draws from: Mitsuba's
/// `pdf` plus `P_spec·D(h)·(G1(wo) − G1_rational(wo))/(4 cos θo)`.
fn mitsuba_pdf_with_exact_masking(model: &Model, p: &Pair) -> f64 {
    let Model::Rough(r) = model else {
        return p.pdf;
    };
    let (wo, wi) = (Vec3::from(p.wo), Vec3::from(p.wi));
    if !(r.distribution == Distribution::Beckmann && r.sample_visible) || wo.z <= 0.0 || wi.z <= 0.0
    {
        return p.pdf;
    }
    let m = r.microfacet();
    let h = (wo + wi).normalize();
    let exact = m.g1(wo, h) as f64;
    let rational = mitsuba_smith_g1(&m, wo, h) as f64;
    p.pdf + p.p_spec as f64 * m.d(h) as f64 * (exact - rational) / (4.0 * wo.z as f64)
}

#[test]
fn pdf_matches_mitsuba() {
    let (mut worst, mut worst_raw) = (0.0f64, 0.0f64);
    for case in data::CASES {
        for p in case.pairs {
            let (wo, wi) = (Vec3::from(p.wo), Vec3::from(p.wi));
            let got = case.model.pdf(wo, wi) as f64;
            let want = mitsuba_pdf_with_exact_masking(&case.model, p);
            assert!(
                close(got, want),
                "{}: wo {wo}, wi {wi}: pdf = {got:e}, Mitsuba {want:e} (its own {:e})",
                case.name,
                p.pdf
            );
            assert_eq!(case.model.eval_pdf(wo, wi).1 as f64, got, "{}", case.name);
            if want > 0.0 {
                worst = worst.max((got - want).abs() / want);
                worst_raw = worst_raw.max((got - p.pdf).abs() / p.pdf);
            }
        }
    }
    println!(
        "worst relative difference {worst:e}; from Mitsuba's own pdf (rational \
         Beckmann masking in the density) {worst_raw:e}"
    );
}

#[test]
fn specular_lobe_probability_matches_mitsuba() {
    let mut worst = 0.0f64;
    for case in data::CASES {
        for p in case.pairs.iter().filter(|p| p.wo[2] > 0.0) {
            let wo = Vec3::from(p.wo);
            let got = case.model.specular_probability(wo);
            assert!(
                (got - p.p_spec).abs() as f64 <= RELATIVE * p.p_spec as f64,
                "{}: wo {wo}: P_spec = {got}, Mitsuba {}",
                case.name,
                p.p_spec
            );
            if p.p_spec > 0.0 {
                worst = worst.max(((got - p.p_spec) / p.p_spec).abs() as f64);
            }
        }
    }
    println!("worst relative difference {worst:e}");
}

#[test]
fn directional_albedo_matches_mitsuba() {
    // Two estimates of ours: the hemisphere integral of f·cos plus the
    // delta lobe's F·ks (quadrature, nearly exact), and the mean sample
    // weight (Monte Carlo with our sampling); both against Mitsuba's Monte
    // Carlo with its own sampling, within 4.5 standard errors (60 values
    // each way: 1 in 10⁴ false alarms) plus the quadrature's error.
    let (mut worst_integral, mut worst_sampled) = (0.0f64, 0.0f64);
    for case in data::CASES {
        for a in case.albedos {
            let wo = Vec3::from(a.wo);
            let mut integral = integrated_albedo(&case.model, wo);
            for (c, i) in integral.iter_mut().enumerate() {
                *i += case.model.delta_albedo(wo)[c] as f64;
            }
            let sampled = sampled_albedo(&case.model, wo, 1 << 18, 11);
            for c in 0..3 {
                let (m, se) = (a.mean[c], a.se[c]);
                assert!(
                    (integral[c] - m).abs() < 4.5 * se + 2e-4,
                    "{}: wo {wo}, channel {c}: ∫f cos = {}, Mitsuba {m} ± {se}",
                    case.name,
                    integral[c]
                );
                let (ours, our_se) = sampled[c];
                let both = (se * se + our_se * our_se).sqrt();
                worst_integral = worst_integral.max((integral[c] - m).abs() / se);
                worst_sampled = worst_sampled.max((ours - m).abs() / both);
                assert!(
                    (ours - m).abs() < 4.5 * both,
                    "{}: wo {wo}, channel {c}: sampled {ours} ± {our_se}, Mitsuba {m} ± {se}",
                    case.name
                );
            }
        }
    }
    println!(
        "largest deviation from Mitsuba: integral {worst_integral:.2} σ, \
         sampled {worst_sampled:.2} σ"
    );
}

#[test]
fn reference_parameters_are_valid() {
    for case in data::CASES {
        match case.model {
            Model::Plastic(p) => assert_eq!(PlasticParams::validate(p), Ok(p)),
            Model::Rough(p) => assert_eq!(RoughPlasticParams::validate(p), Ok(p)),
        }
    }
    // Mitsuba's defaults are `Default`.
    assert_eq!(
        data::CASES[0].model,
        Model::Plastic(PlasticParams::default())
    );
    assert_eq!(
        data::CASES[5].model,
        Model::Rough(RoughPlasticParams::default())
    );
}

#[test]
fn tables_match_mitsubas() {
    // T looked up where the entries were recovered, at μ = k/63 (10⁻⁶ for
    // k = 0), as Mitsuba looked them up; the recovered values carry the
    // f32 rounding of Mitsuba's: 2e-6 relative, or 2e-8 absolute where the
    // transmittance vanishes. F_i is recovered from a ratio near 1 − F_i/2,
    // so to 1e-6 absolute.
    let mut worst = 0.0f64;
    for t in data::TABLES {
        let eta = t.int_ior / t.ext_ior;
        let ours = RoughPlasticTable::of(t.distribution, t.alpha, eta);
        for (k, &want) in t.transmittance.iter().enumerate() {
            let mu = (k as f32 / 63.0).max(1e-6);
            let got = ours.transmittance(mu) as f64;
            assert!(
                (got - want).abs() <= 2e-6 * want + 2e-8,
                "{:?} α {} η {eta}: T(μ_{k}) = {got}, Mitsuba {want}",
                t.distribution,
                t.alpha
            );
            worst = worst.max((got - want).abs() / want.max(1e-3));
        }
        let (got, want) = (ours.internal_reflectance as f64, t.internal_reflectance);
        assert!(
            (got - want).abs() <= 2e-6 * want + 1e-6,
            "{:?} α {} η {eta}: F_i = {got}, Mitsuba {want}",
            t.distribution,
            t.alpha
        );
    }
    println!("worst relative difference of T {worst:e}");
}
