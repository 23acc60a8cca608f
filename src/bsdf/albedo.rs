//! Directional albedo of the principled BSDF's specular lobe, tabulated for
//! its energy-conserving mode (`energy_conserving = true`).
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
//! - `F = 1` and Schlick's weight `F = (1 − wo·h)⁵` ([`SpecularAlbedo`],
//!   once per process), so that Schlick with any `f0` is
//!   `f0·(E₁ − E_w) + E_w`;
//! - the exact dielectric Fresnel term with `η` from `specular`
//!   ([`DielectricAlbedo`], once per distinct `specular`: `E` jumps from 0 to
//!   nearly 1 at grazing angles as `η` leaves 1, so no interpolation over
//!   `specular` is accurate near 0).
//!
//! Alongside each, the hemispherical average `Ē = 2 ∫₀¹ E(μ) μ dμ`,
//! integrated exactly over the same piecewise-linear interpolant, so that
//! the coupled diffuse term of [`PrincipledParams`](super::PrincipledParams)
//! integrates to exactly what the specular lobe leaves (Kelemen and
//! Szirmay-Kalos 2001).

use super::fresnel;
use super::microfacet::{Distribution, Microfacet};
use glam::{Vec2, Vec3};
use std::cell::RefCell;
use std::sync::Mutex;

/// Grid points over `μ = cos θ`, at `μ = (i/(n − 1))²`: denser at grazing
/// angles, where the Fresnel terms change fastest.
const MU_POINTS: usize = 32;
/// Grid points over `√α` in `[0, SQRT_ALPHA_MAX]`.
const SQRT_ALPHA_POINTS: usize = 32;
/// Largest tabulated `√α`: principled's anisotropy stretches `α = r²` up to
/// `1/√0.1 ≈ 3.16`, i.e. `√α ≈ 1.78`.
const SQRT_ALPHA_MAX: f32 = 1.8;
/// Stratified visible-normal samples per table entry, per side, for the
/// dielectric tables (whose Fresnel term is small where a narrow lobe
/// loses its tail below the horizon).
const SAMPLES_PER_SIDE: usize = 24;
/// The same for the `F = 1` and Schlick tables, computed once per process:
/// the metal's multiple-scattering factor divides by `E(F = 1)`, and 24 per
/// side overestimate it by 3 % at roughness 0.4 (the stratified quadrature
/// misses much of the tail below the horizon); 64 leave 1 %.
const SPECULAR_SAMPLES_PER_SIDE: usize = 64;

/// A `[√α][μ]` table of directional albedos, row-major over `√α`. A fixed
/// size, so that every index [`lookup`] forms is provably in bounds and the
/// vectorised kernel's loops have no bounds checks.
type Table = [f32; SQRT_ALPHA_POINTS * MU_POINTS];
/// The `[√α]` hemispherical averages of a [`Table`].
type Averages = [f32; SQRT_ALPHA_POINTS];

/// `η` from principled's `specular` (Mitsuba's mapping).
#[inline(always)]
pub fn eta_from_specular(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

/// Principled's `specular` for an index of refraction `eta`, the inverse of
/// [`eta_from_specular`]: `((η − 1)/(η + 1))² / 0.08`, or `None` where no
/// `specular` in `[0, 1]` gives `eta` (below 1 or above about 1.79).
pub fn specular_from_eta(eta: f32) -> Option<f32> {
    let s = ((eta - 1.0) / (eta + 1.0)).powi(2) / 0.08;
    (eta >= 1.0 && s <= 1.0).then_some(s)
}

fn mu_at(i: usize) -> f32 {
    let t = i as f32 / (MU_POINTS - 1) as f32;
    t * t
}

fn sqrt_alpha_at(j: usize) -> f32 {
    SQRT_ALPHA_MAX * j as f32 / (SQRT_ALPHA_POINTS - 1) as f32
}

/// A grid coordinate for `x ∈ [0, 1]` on `points` even steps: the lower
/// index and the weight of the upper one.
///
/// The index goes through `i32`, not `usize`: AVX2 converts packed `f32` to
/// 32-bit integers only (a conversion to 64 bits is one instruction per
/// lane).
#[inline(always)]
fn cell(x: f32, points: usize) -> (usize, f32) {
    let t = x.clamp(0.0, 1.0) * (points - 1) as f32;
    let i = (t as i32).clamp(0, points as i32 - 2);
    (i as usize, t - i as f32)
}

/// Exact `2 ∫₀¹ e(μ) μ dμ` of the piecewise-linear interpolant of `e` over
/// the `μ` grid.
fn hemispherical_average(e: &[f32]) -> f32 {
    let mut sum = 0.0;
    for i in 0..MU_POINTS - 1 {
        let (a, b) = (mu_at(i), mu_at(i + 1));
        sum += (b - a) / 6.0 * (e[i] * (2.0 * a + b) + e[i + 1] * (a + 2.0 * b));
    }
    2.0 * sum
}

/// Tabulates `E` for each Fresnel term of `fresnels` (functions of
/// `cos θd = wo·h`): one `[α][μ]` table each, with its `[α]` averages, from
/// `n × n` stratified samples per entry.
///
/// Serial on purpose: the tables may first be needed inside a render's
/// rayon worker, where a nested parallel loop could steal a job that waits
/// on this very initialisation.
fn tabulate<const N: usize>(
    fresnels: [&dyn Fn(f32) -> f32; N],
    n: usize,
) -> [(Table, Averages); N] {
    let mut out = [(
        [0.0; SQRT_ALPHA_POINTS * MU_POINTS],
        [0.0; SQRT_ALPHA_POINTS],
    ); N];
    for j in 0..SQRT_ALPHA_POINTS {
        let a = sqrt_alpha_at(j);
        let m = Microfacet::isotropic(Distribution::Ggx, a * a);
        let mut rows = [[0.0f32; MU_POINTS]; N];
        for i in 0..MU_POINTS {
            // μ = 0 itself has no visible microfacets: use a nearly grazing
            // direction instead.
            let mu = mu_at(i).max(2e-4);
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let mut sums = [0.0f64; N];
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
                for (sum, f) in sums.iter_mut().zip(&fresnels) {
                    *sum += g1 * f(cos_d) as f64;
                }
            }
            for (row, sum) in rows.iter_mut().zip(sums) {
                row[i] = (sum / (n * n) as f64) as f32;
            }
        }
        for (table, row) in out.iter_mut().zip(&rows) {
            table.0[j * MU_POINTS..(j + 1) * MU_POINTS].copy_from_slice(row);
            table.1[j] = hemispherical_average(row);
        }
    }
    out
}

/// Bilinear lookup in a `[α][μ]` table: linear in `μ` between its grid
/// points (the interpolant [`hemispherical_average`] integrates), linear in
/// `√α`.
#[inline(always)]
fn lookup(table: &Table, mu: f32, alpha: f32) -> f32 {
    let mu = mu.clamp(0.0, 1.0);
    let (i, _) = cell(mu.sqrt(), MU_POINTS);
    let fi = ((mu - mu_at(i)) / (mu_at(i + 1) - mu_at(i))).clamp(0.0, 1.0);
    let (j, fj) = cell(alpha.sqrt() / SQRT_ALPHA_MAX, SQRT_ALPHA_POINTS);
    let at = |j: usize, i: usize| table[j * MU_POINTS + i];
    let lo = at(j, i) + fi * (at(j, i + 1) - at(j, i));
    let hi = at(j + 1, i) + fi * (at(j + 1, i + 1) - at(j + 1, i));
    lo + fj * (hi - lo)
}

/// Linear lookup in an `[α]` table of averages.
#[inline(always)]
fn lookup_average(table: &Averages, alpha: f32) -> f32 {
    let (j, fj) = cell(alpha.sqrt() / SQRT_ALPHA_MAX, SQRT_ALPHA_POINTS);
    table[j] + fj * (table[j + 1] - table[j])
}

/// Albedos of the lobe with `F = 1` and with Schlick's weight as `F`.
pub struct SpecularAlbedo {
    white: Table,
    schlick: Table,
    white_avg: Averages,
    schlick_avg: Averages,
}

/// Tables of zeros, for a material that never reads them (no `spec_tint`)
/// or a lane that shades nothing.
static NO_SPECULAR_ALBEDO: SpecularAlbedo = SpecularAlbedo {
    white: [0.0; SQRT_ALPHA_POINTS * MU_POINTS],
    schlick: [0.0; SQRT_ALPHA_POINTS * MU_POINTS],
    white_avg: [0.0; SQRT_ALPHA_POINTS],
    schlick_avg: [0.0; SQRT_ALPHA_POINTS],
};

/// A table of zeros (for a lane that shades nothing).
static NO_DIELECTRIC_ALBEDO: DielectricAlbedo = DielectricAlbedo {
    specular: 0.0,
    e: [0.0; SQRT_ALPHA_POINTS * MU_POINTS],
    avg: [0.0; SQRT_ALPHA_POINTS],
};

/// The tables the energy-conserving principled BSDF reads for one material:
/// the dielectric albedo of its `specular` and, where it has `spec_tint`,
/// the Schlick albedos. Looked up once per material by whoever shades many
/// points of it, so that evaluation itself is pure arithmetic and loads.
#[derive(Debug, Clone, Copy)]
pub struct EnergyTables {
    /// [`DielectricAlbedo::for_specular`] of the material's `specular`.
    pub dielectric: &'static DielectricAlbedo,
    /// [`SpecularAlbedo::get`]: the tinted dielectric's albedo (where
    /// `spec_tint > 0`) and the metal's (`F = 1`, for its multiple
    /// scattering); tables of zeros in [`EnergyTables::NONE`].
    pub schlick: &'static SpecularAlbedo,
}

impl EnergyTables {
    /// Tables of zeros, for a lane that shades nothing: every lookup is 0.
    pub const NONE: EnergyTables = EnergyTables {
        dielectric: &NO_DIELECTRIC_ALBEDO,
        schlick: &NO_SPECULAR_ALBEDO,
    };

    /// The tables of a material with `specular`, computing any not computed
    /// yet.
    pub fn of(specular: f32) -> EnergyTables {
        EnergyTables {
            dielectric: DielectricAlbedo::for_specular(specular),
            schlick: SpecularAlbedo::get(),
        }
    }
}

/// The tables [`SpecularAlbedo::compute`] gives, embedded
/// (`albedo_specular.rs`, written by the test
/// `embedded_specular_tables_are_what_tabulate_computes`): computing them
/// takes about 0.2 s, which every process that renders a glTF would pay.
static SPECULAR_ALBEDO: SpecularAlbedo = SpecularAlbedo {
    white: super::albedo_specular::WHITE,
    schlick: super::albedo_specular::SCHLICK,
    white_avg: super::albedo_specular::WHITE_AVG,
    schlick_avg: super::albedo_specular::SCHLICK_AVG,
};

impl SpecularAlbedo {
    /// The tables (embedded in plsr).
    pub fn get() -> &'static SpecularAlbedo {
        &SPECULAR_ALBEDO
    }

    /// The tables computed: `SPECULAR_SAMPLES_PER_SIDE²` stratified
    /// visible-normal samples per entry (about 0.2 s).
    pub fn compute() -> SpecularAlbedo {
        let [(white, white_avg), (schlick, schlick_avg)] = tabulate(
            [&|_| 1.0, &fresnel::schlick_weight],
            SPECULAR_SAMPLES_PER_SIDE,
        );
        SpecularAlbedo {
            white,
            schlick,
            white_avg,
            schlick_avg,
        }
    }

    /// `[E(F = 1), E(F = Schlick weight)]` for `μo = cos θo` and roughness
    /// `alpha`.
    #[inline(always)]
    pub fn directional(&self, mu: f32, alpha: f32) -> [f32; 2] {
        [
            lookup(&self.white, mu, alpha),
            lookup(&self.schlick, mu, alpha),
        ]
    }

    /// The hemispherical averages `Ē = 2∫E(μ)μ dμ` of the two.
    #[inline(always)]
    pub fn average(&self, alpha: f32) -> [f32; 2] {
        [
            lookup_average(&self.white_avg, alpha),
            lookup_average(&self.schlick_avg, alpha),
        ]
    }
}

/// Albedo of the lobe with the exact dielectric Fresnel term of one
/// `specular` value.
pub struct DielectricAlbedo {
    specular: f32,
    e: Table,
    avg: Averages,
}

impl std::fmt::Debug for SpecularAlbedo {
    /// Whether the tables are the computed ones (not their entries).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let computed = !std::ptr::eq(self, &NO_SPECULAR_ALBEDO);
        f.debug_struct("SpecularAlbedo")
            .field("computed", &computed)
            .finish_non_exhaustive()
    }
}

impl std::fmt::Debug for DielectricAlbedo {
    /// The table's `specular` alone (not its entries).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DielectricAlbedo")
            .field("specular", &self.specular)
            .finish_non_exhaustive()
    }
}

impl DielectricAlbedo {
    /// The table of `specular` (in `[0, 1]`), computed on first use for
    /// each distinct value (a few tens of milliseconds) and kept for the
    /// life of the process; later calls are a lookup in a per-thread list.
    pub fn for_specular(specular: f32) -> &'static DielectricAlbedo {
        /// Tables computed so far, shared by all threads.
        static ALL: Mutex<Vec<&'static DielectricAlbedo>> = Mutex::new(Vec::new());
        thread_local! {
            /// The last few tables this thread used.
            static RECENT: RefCell<Vec<&'static DielectricAlbedo>> = const { RefCell::new(Vec::new()) };
        }
        let bits = specular.to_bits();
        super::table_cache::interned(
            &ALL,
            &RECENT,
            |t| t.specular.to_bits() == bits,
            || DielectricAlbedo::compute(specular),
        )
    }

    fn compute(specular: f32) -> DielectricAlbedo {
        let eta = eta_from_specular(specular);
        let [(e, avg)] = tabulate([&|c| fresnel::dielectric(c, eta)], SAMPLES_PER_SIDE);
        DielectricAlbedo { specular, e, avg }
    }

    /// `E(μo)` for roughness `alpha`.
    #[inline(always)]
    pub fn directional(&self, mu: f32, alpha: f32) -> f32 {
        lookup(&self.e, mu, alpha)
    }

    /// The hemispherical average `Ē = 2∫E(μ)μ dμ` for roughness `alpha`.
    #[inline(always)]
    pub fn average(&self, alpha: f32) -> f32 {
        lookup_average(&self.avg, alpha)
    }
}

#[cfg(test)]
mod embedded_tests {
    use super::*;

    /// The embedded tables are what [`SpecularAlbedo::compute`] gives
    /// (within 1e-6, for another platform's `sin` and `cos`). With
    /// `PLSR_WRITE_TABLES=1` the test writes them instead.
    #[test]
    fn embedded_specular_tables_are_what_tabulate_computes() {
        let computed = SpecularAlbedo::compute();
        if std::env::var_os("PLSR_WRITE_TABLES").is_some() {
            let list = |v: &[f32]| {
                v.iter()
                    .map(|x| format!("{x:?}"))
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            let text = format!(
                "//! The `F = 1` and Schlick-weight albedo tables of [`super::albedo`], as\n\
                 //! `SpecularAlbedo::compute` gives them. Generated by\n\
                 //! `PLSR_WRITE_TABLES=1 cargo test -p plsr --lib embedded_specular`.\n\n\
                 #[rustfmt::skip]\npub(super) const WHITE: [f32; {n}] = [{}];\n\
                 #[rustfmt::skip]\npub(super) const SCHLICK: [f32; {n}] = [{}];\n\
                 #[rustfmt::skip]\npub(super) const WHITE_AVG: [f32; {m}] = [{}];\n\
                 #[rustfmt::skip]\npub(super) const SCHLICK_AVG: [f32; {m}] = [{}];\n",
                list(&computed.white),
                list(&computed.schlick),
                list(&computed.white_avg),
                list(&computed.schlick_avg),
                n = computed.white.len(),
                m = computed.white_avg.len(),
            );
            let path = concat!(env!("CARGO_MANIFEST_DIR"), "/src/bsdf/albedo_specular.rs");
            std::fs::write(path, text).unwrap();
            return;
        }
        let embedded = SpecularAlbedo::get();
        let pairs = [
            (&computed.white[..], &embedded.white[..]),
            (&computed.schlick[..], &embedded.schlick[..]),
            (&computed.white_avg[..], &embedded.white_avg[..]),
            (&computed.schlick_avg[..], &embedded.schlick_avg[..]),
        ];
        for (k, (c, e)) in pairs.into_iter().enumerate() {
            for (i, (c, e)) in c.iter().zip(e).enumerate() {
                assert!(
                    (c - e).abs() < 1e-6,
                    "table {k} entry {i}: {c} computed, {e} embedded"
                );
            }
        }
    }
}
