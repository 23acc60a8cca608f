//! Directional albedo of the principled BSDF's specular lobe, tabulated
//! once, for its energy-conserving mode (`energy_conserving = true`).
//!
//! The directional albedo of a GGX reflection lobe with Fresnel term `F` is
//!
//! ```text
//! E(μo) = ∫ F(wo·h) D(h) G1(wo) G1(wi) / (4 μo μi) · μi dωi
//!       = E_h~VNDF(wo) [ F(wo·h) G1(wi) ]        (visible-normal sampling)
//! ```
//!
//! with `μ = cos θ`. It is tabulated over `μo` and `√α` for three Fresnel
//! terms, from which every Fresnel term the principled lobe uses follows
//! linearly:
//! - `F = 1` ([`SpecularAlbedo::directional`]`[0]`);
//! - Schlick's weight `F = (1 − wo·h)⁵` (`[1]`), so that Schlick with any
//!   `f0` is `f0·(E₀ − E₁) + E₁`;
//! - the exact dielectric Fresnel term with `η` from `specular` (`[2]`,
//!   also tabulated over `specular`).
//!
//! Alongside each, the hemispherical average `Ē = 2 ∫₀¹ E(μ) μ dμ`
//! ([`SpecularAlbedo::average`]), integrated exactly over the same
//! piecewise-linear interpolant, so that the coupled diffuse term of
//! [`PrincipledParams`](super::PrincipledParams) integrates to exactly what
//! the specular lobe leaves (Kelemen and Szirmay-Kalos 2001).

use super::fresnel;
use super::microfacet::{Distribution, Microfacet};
use glam::{Vec2, Vec3};
use std::sync::OnceLock;

/// Grid points over `μ = cos θ` in `[0, 1]`.
const MU_POINTS: usize = 32;
/// Grid points over `√α` in `[0, SQRT_ALPHA_MAX]`.
const SQRT_ALPHA_POINTS: usize = 32;
/// Largest tabulated `√α`: principled's anisotropy stretches `α = r²` up to
/// `1/√0.1 ≈ 3.16`, i.e. `√α ≈ 1.78`.
const SQRT_ALPHA_MAX: f32 = 1.8;
/// Grid points over `specular` in `[0, 1]`.
const SPECULAR_POINTS: usize = 9;
/// Stratified visible-normal samples per table entry (a square number).
const SAMPLES_PER_SIDE: usize = 24;

/// The tabulated albedos; see the module documentation.
pub struct SpecularAlbedo {
    /// `E` with `F = 1`, `[alpha][mu]`.
    white: Vec<f32>,
    /// `E` with Schlick's weight as `F`, `[alpha][mu]`.
    schlick: Vec<f32>,
    /// `E` with the dielectric Fresnel term, `[specular][alpha][mu]`.
    dielectric: Vec<f32>,
    /// Hemispherical averages of the three, `[alpha]` and `[specular][alpha]`.
    white_avg: Vec<f32>,
    schlick_avg: Vec<f32>,
    dielectric_avg: Vec<f32>,
}

/// `η` from principled's `specular` (Mitsuba's mapping).
pub fn eta_from_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

fn mu_at(i: usize) -> f32 {
    i as f32 / (MU_POINTS - 1) as f32
}

fn sqrt_alpha_at(j: usize) -> f32 {
    SQRT_ALPHA_MAX * j as f32 / (SQRT_ALPHA_POINTS - 1) as f32
}

fn specular_at(k: usize) -> f32 {
    k as f32 / (SPECULAR_POINTS - 1) as f32
}

/// A grid coordinate: the lower index and the weight of the upper one.
#[inline]
fn cell(x: f32, points: usize) -> (usize, f32) {
    let t = x.clamp(0.0, 1.0) * (points - 1) as f32;
    let i = (t as usize).min(points - 2);
    (i, t - i as f32)
}

/// Exact `∫₀¹ e(μ) μ dμ · 2` of the piecewise-linear interpolant of `e`
/// over the `μ` grid.
fn hemispherical_average(e: &[f32]) -> f32 {
    let mut sum = 0.0;
    for i in 0..MU_POINTS - 1 {
        let (a, b) = (mu_at(i), mu_at(i + 1));
        sum += (b - a) / 6.0 * (e[i] * (2.0 * a + b) + e[i + 1] * (a + 2.0 * b));
    }
    2.0 * sum
}

impl SpecularAlbedo {
    /// The tables, computed on first use (about 0.1 s).
    pub fn get() -> &'static SpecularAlbedo {
        static TABLES: OnceLock<SpecularAlbedo> = OnceLock::new();
        TABLES.get_or_init(SpecularAlbedo::compute)
    }

    fn compute() -> SpecularAlbedo {
        let etas: Vec<f32> = (0..SPECULAR_POINTS)
            .map(|k| eta_from_specular(specular_at(k)))
            .collect();
        // One row per α: [white; schlick; dielectric per specular] over μ.
        // Serial on purpose: the tables may first be needed inside a
        // render's rayon worker, where a nested parallel loop could steal a
        // job that waits on this very initialisation.
        let rows: Vec<Vec<f32>> = (0..SQRT_ALPHA_POINTS)
            .map(|j| {
                let a = sqrt_alpha_at(j);
                let m = Microfacet::isotropic(Distribution::Ggx, a * a);
                let mut row = vec![0.0f32; (2 + SPECULAR_POINTS) * MU_POINTS];
                for i in 0..MU_POINTS {
                    // μ = 0 itself has no visible microfacets: use a nearly
                    // grazing direction instead.
                    let mu = mu_at(i).max(2e-3);
                    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                    let mut sums = [0.0f64; 2 + SPECULAR_POINTS];
                    let n = SAMPLES_PER_SIDE;
                    for s in 0..n * n {
                        let u = Vec2::new(
                            ((s % n) as f32 + 0.5) / n as f32,
                            ((s / n) as f32 + 0.5) / n as f32,
                        );
                        let h = m.sample_h(wo, u);
                        let wi = fresnel::reflect(wo, h);
                        if wi.z <= 0.0 {
                            continue;
                        }
                        let g1 = m.g1(wi, h) as f64;
                        let cos_d = wo.dot(h);
                        sums[0] += g1;
                        sums[1] += g1 * fresnel::schlick_weight(cos_d) as f64;
                        for (k, &eta) in etas.iter().enumerate() {
                            sums[2 + k] += g1 * fresnel::dielectric(cos_d, eta) as f64;
                        }
                    }
                    for (t, s) in sums.iter().enumerate() {
                        row[t * MU_POINTS + i] = (s / (n * n) as f64) as f32;
                    }
                }
                row
            })
            .collect();
        let per_alpha = SQRT_ALPHA_POINTS * MU_POINTS;
        let mut t = SpecularAlbedo {
            white: Vec::with_capacity(per_alpha),
            schlick: Vec::with_capacity(per_alpha),
            dielectric: vec![0.0; SPECULAR_POINTS * per_alpha],
            white_avg: Vec::new(),
            schlick_avg: Vec::new(),
            dielectric_avg: vec![0.0; SPECULAR_POINTS * SQRT_ALPHA_POINTS],
        };
        for (j, row) in rows.iter().enumerate() {
            let part = |t: usize| &row[t * MU_POINTS..(t + 1) * MU_POINTS];
            t.white.extend_from_slice(part(0));
            t.schlick.extend_from_slice(part(1));
            t.white_avg.push(hemispherical_average(part(0)));
            t.schlick_avg.push(hemispherical_average(part(1)));
            for k in 0..SPECULAR_POINTS {
                let at = k * per_alpha + j * MU_POINTS;
                t.dielectric[at..at + MU_POINTS].copy_from_slice(part(2 + k));
                t.dielectric_avg[k * SQRT_ALPHA_POINTS + j] = hemispherical_average(part(2 + k));
            }
        }
        t
    }

    /// `[E(F = 1), E(F = Schlick weight), E(F = dielectric(η(specular)))]`
    /// for `μo = cos θo` and roughness `alpha` (bilinear in `μ`, `√α`;
    /// linear in `specular`). Without `schlick_too` only the last is looked
    /// up and the first two are 0.
    #[inline]
    pub fn directional(&self, mu: f32, alpha: f32, specular: f32, schlick_too: bool) -> [f32; 3] {
        let (i, fi) = cell(mu, MU_POINTS);
        let (j, fj) = cell(alpha.sqrt() / SQRT_ALPHA_MAX, SQRT_ALPHA_POINTS);
        let (k, fk) = cell(specular, SPECULAR_POINTS);
        let bilinear = |table: &[f32]| {
            let at = |j: usize, i: usize| table[j * MU_POINTS + i];
            let lo = at(j, i) + fi * (at(j, i + 1) - at(j, i));
            let hi = at(j + 1, i) + fi * (at(j + 1, i + 1) - at(j + 1, i));
            lo + fj * (hi - lo)
        };
        let per_alpha = SQRT_ALPHA_POINTS * MU_POINTS;
        let d0 = bilinear(&self.dielectric[k * per_alpha..(k + 1) * per_alpha]);
        let d1 = bilinear(&self.dielectric[(k + 1) * per_alpha..(k + 2) * per_alpha]);
        if !schlick_too {
            return [0.0, 0.0, d0 + fk * (d1 - d0)];
        }
        [
            bilinear(&self.white),
            bilinear(&self.schlick),
            d0 + fk * (d1 - d0),
        ]
    }

    /// The hemispherical averages `Ē = 2∫E(μ)μ dμ` of the three albedos of
    /// [`SpecularAlbedo::directional`], for roughness `alpha`.
    #[inline]
    pub fn average(&self, alpha: f32, specular: f32) -> [f32; 3] {
        let (j, fj) = cell(alpha.sqrt() / SQRT_ALPHA_MAX, SQRT_ALPHA_POINTS);
        let (k, fk) = cell(specular, SPECULAR_POINTS);
        let lerp = |t: &[f32], j: usize| t[j] + fj * (t[j + 1] - t[j]);
        let d = &self.dielectric_avg;
        let d0 = lerp(&d[k * SQRT_ALPHA_POINTS..], j);
        let d1 = lerp(&d[(k + 1) * SQRT_ALPHA_POINTS..], j);
        [
            lerp(&self.white_avg, j),
            lerp(&self.schlick_avg, j),
            d0 + fk * (d1 - d0),
        ]
    }
}
