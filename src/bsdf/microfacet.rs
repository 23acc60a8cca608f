//! Microfacet distributions: GGX (Trowbridge–Reitz) and Beckmann, both
//! anisotropic, with Smith masking-shadowing.
//!
//! Directions are in the local shading frame (normal = +z, the first tangent
//! = +x). Roughness is the pair `(alpha_x, alpha_y)` of slope standard
//! deviations along the two tangents; artists' `roughness` maps to
//! `alpha = roughness²` ([`alpha_from_roughness`]).
//!
//! - `D(h)`: the normal distribution ([`Microfacet::d`]), normalised so that
//!   `∫ D(h) cos θh dh = 1`.
//! - `G1(w, h) = 1 / (1 + Λ(w))` for a microfacet that `w` sees from its
//!   front (Smith), and the separable `G(wo, wi) = G1(wo)·G1(wi)`, as Mitsuba
//!   uses, so that parameters fitted in either renderer carry over.
//! - Sampling: both sample the distribution of normals *visible* from `wo`,
//!   `pdf(h) = G1(wo) · max(0, wo·h) · D(h) / cos θo` ([`Microfacet::pdf_h`]):
//!   GGX by Heitz 2018, Beckmann by Jakob 2014 (Mitsuba's routine, its
//!   `sample_visible` default). Beckmann used to sample `D(h) cos θh`
//!   (Walter et al. 2007), which wastes samples on normals `wo` cannot see:
//!   rough Beckmann glass had 1.2–1.9 times Mitsuba's variance.

use crate::elementary::{self, erf, erfc_fit, erfinv};
use crate::warp::square_to_disk_concentric;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Which normal distribution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Distribution {
    /// Trowbridge–Reitz (GGX), long tails; sampled by visible normals.
    Ggx,
    /// Beckmann (Gaussian slopes); sampled by visible normals.
    Beckmann,
}

/// Smallest alpha used (Mitsuba 3 clamps its microfacets there too): below
/// it the lobe is numerically a mirror.
pub const MIN_ALPHA: f32 = 1e-4;

/// `alpha = roughness²` (the usual artist mapping), clamped to [`MIN_ALPHA`].
#[inline]
pub fn alpha_from_roughness(roughness: f32) -> f32 {
    (roughness * roughness).max(MIN_ALPHA)
}

/// An anisotropic microfacet distribution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Microfacet {
    /// Which distribution.
    pub kind: Distribution,
    /// Roughness (slope standard deviation) along the first tangent.
    pub alpha_x: f32,
    /// Roughness along the second tangent.
    pub alpha_y: f32,
}

/// `1/√π`.
const FRAC_1_SQRT_PI: f32 = 0.5 * std::f32::consts::FRAC_2_SQRT_PI;

/// A microfacet normal from the Beckmann distribution of normals visible
/// from `wo` (above the surface), roughness `ax` and `ay` along the two
/// tangents: Mitsuba's routine
/// (Jakob 2014, "An improved visible normal sampling routine for the
/// Beckmann distribution"): `wo` stretched to unit roughness, the slope
/// along its azimuth by three Newton steps on its CDF
/// ([`beckmann_visible_slope`]), the other slope `erfinv(2u.y − 1)`, both
/// rotated to `wo`'s azimuth and unstretched (`beckmann_slope_normal`).
/// Elementary functions from [`elementary`] (so that a vectorised loop may
/// call it).
#[inline(always)]
pub fn sample_visible_beckmann(ax: f32, ay: f32, wo: Vec3, u: Vec2) -> Vec3 {
    let (cos, cos_phi, sin_phi) = stretched(ax, ay, wo);
    let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
    let slopes = Vec2::new(beckmann_visible_slope(cos, u.x), erfinv(2.0 * u.y - 1.0));
    beckmann_slope_normal(ax, ay, cos_phi, sin_phi, slopes)
}

/// `wo` (above the surface) stretched to the configuration of unit
/// roughness (`ax`, `ay` along the tangents): `(cos θ, cos φ, sin φ)` of
/// the stretched direction (`φ = 0` at the pole), as Mitsuba's
/// `Frame::sincos_phi`.
#[inline(always)]
pub fn stretched(ax: f32, ay: f32, wo: Vec3) -> (f32, f32, f32) {
    let w = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    let sin2 = 1.0 - w.z * w.z;
    let inv = 1.0 / sin2.sqrt();
    if sin2 <= 4.0 * f32::EPSILON {
        (w.z, 1.0, 0.0)
    } else {
        (
            w.z,
            (w.x * inv).clamp(-1.0, 1.0),
            (w.y * inv).clamp(-1.0, 1.0),
        )
    }
}

/// The slope along the (stretched) viewing azimuth of a visible Beckmann
/// normal of unit roughness for a direction of cosine `cos` and the
/// uniform number `u` (in `[10⁻⁶, 1 − 10⁻⁶]`): Mitsuba's inversion of the
/// visible slopes' CDF, `1 + x + tan θ·exp(−erfinv(x)²)/√π = u·(1 + erf(cot
/// θ) + tan θ·exp(−cot² θ)/√π)` in `x = erf(slope)`, from the exact
/// solution at grazing incidence and by three Newton steps.
#[inline(always)]
pub fn beckmann_visible_slope(cos: f32, u: f32) -> f32 {
    let tan = (1.0 - cos * cos).max(0.0).sqrt() / cos;
    let cot = 1.0 / tan;
    let max = erf(cot);
    let mut x = max - (max + 1.0) * erf((-elementary::ln(u)).sqrt());
    let u = u * (1.0 + max + FRAC_1_SQRT_PI * tan * elementary::exp(-cot * cot));
    // Three steps written out: a loop here, too long to be unrolled fully,
    // would stop the vectorised kernel's lane loop (an outer loop) from
    // vectorising.
    let newton = |x: f32| {
        let slope = erfinv(x);
        let value = 1.0 + x + FRAC_1_SQRT_PI * tan * elementary::exp(-slope * slope) - u;
        let derivative = 1.0 - slope * tan;
        x - value / derivative
    };
    x = newton(newton(newton(x)));
    erfinv(x)
}

/// The microfacet normal of the unit-roughness `slopes` (along and across
/// the stretched viewing azimuth `(cos φ, sin φ)`), rotated to that azimuth
/// and unstretched to roughness `ax`, `ay`.
#[inline(always)]
pub fn beckmann_slope_normal(ax: f32, ay: f32, cos_phi: f32, sin_phi: f32, slopes: Vec2) -> Vec3 {
    let (sx, sy) = (slopes.x, slopes.y);
    let (mx, my) = (
        (cos_phi * sx - sin_phi * sy) * ax,
        (sin_phi * sx + cos_phi * sy) * ay,
    );
    Vec3::new(-mx, -my, 1.0).normalize()
}

impl Microfacet {
    /// An isotropic distribution of roughness `alpha`.
    pub fn isotropic(kind: Distribution, alpha: f32) -> Microfacet {
        Microfacet::new(kind, alpha, alpha)
    }

    /// An anisotropic distribution; alphas are clamped to [`MIN_ALPHA`].
    pub fn new(kind: Distribution, alpha_x: f32, alpha_y: f32) -> Microfacet {
        Microfacet {
            kind,
            alpha_x: alpha_x.max(MIN_ALPHA),
            alpha_y: alpha_y.max(MIN_ALPHA),
        }
    }

    /// The normal distribution `D(h)` (1/sr), 0 below the horizon.
    #[inline(always)]
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        let cos2 = h.z * h.z;
        match self.kind {
            Distribution::Ggx => {
                let s = (h.x / ax) * (h.x / ax) + (h.y / ay) * (h.y / ay) + cos2;
                1.0 / (PI * ax * ay * s * s)
            }
            Distribution::Beckmann => {
                let e = ((h.x / ax) * (h.x / ax) + (h.y / ay) * (h.y / ay)) / cos2;
                elementary::exp(-e) / (PI * ax * ay * cos2 * cos2)
            }
        }
    }

    /// Smith's `Λ(w)`, the ratio of hidden to visible projected microfacet area.
    #[inline(always)]
    pub fn lambda(&self, w: Vec3) -> f32 {
        let cos2 = w.z * w.z;
        if cos2 == 0.0 {
            return f32::INFINITY;
        }
        // α(w)²·tan²θ, with α(w) the roughness along w's azimuth.
        let a2_tan2 = ((self.alpha_x * w.x).powi(2) + (self.alpha_y * w.y).powi(2)) / cos2;
        match self.kind {
            Distribution::Ggx => 0.5 * ((1.0 + a2_tan2).sqrt() - 1.0),
            Distribution::Beckmann => {
                if a2_tan2 == 0.0 {
                    return 0.0;
                }
                // Λ = (erf(a) − 1)/2 + exp(−a²)/(2a√π), a = 1/(α tan θ),
                // with erfc(a) = t·exp(−a² + P(t)) ([`erfc_fit`]): both terms
                // share exp(−a²), so Λ = ½·exp(−a²)·(1/(a√π) − t·exp(P(t))),
                // which keeps its precision as Λ → 0 and needs no f64 (whose
                // conversions would keep the vectorised kernel's loop scalar).
                let a = 1.0 / a2_tan2.sqrt();
                let t = 1.0 / (1.0 + 0.5 * a);
                let frac_1_sqrt_pi = 0.5 * std::f32::consts::FRAC_2_SQRT_PI;
                let l = 0.5
                    * elementary::exp(-a * a)
                    * (frac_1_sqrt_pi / a - t * elementary::exp(erfc_fit(t)));
                l.max(0.0)
            }
        }
    }

    /// Smith masking of microfacet `h` seen from `w`: 0 if `w` sees its back.
    #[inline(always)]
    pub fn g1(&self, w: Vec3, h: Vec3) -> f32 {
        if w.dot(h) * w.z <= 0.0 {
            return 0.0;
        }
        1.0 / (1.0 + self.lambda(w))
    }

    /// Separable masking-shadowing `G1(wo, h)·G1(wi, h)`.
    #[inline(always)]
    pub fn g(&self, wo: Vec3, wi: Vec3, h: Vec3) -> f32 {
        self.g1(wo, h) * self.g1(wi, h)
    }

    /// Draws a microfacet normal (upper hemisphere) for `wo` from `u`.
    /// `wo` may lie below the surface (inside a dielectric); it is mirrored.
    #[inline(always)]
    pub fn sample_h(&self, wo: Vec3, u: Vec2) -> Vec3 {
        match self.kind {
            Distribution::Ggx => self.sample_visible_ggx(if wo.z < 0.0 { -wo } else { wo }, u),
            Distribution::Beckmann => sample_visible_beckmann(
                self.alpha_x,
                self.alpha_y,
                if wo.z < 0.0 { -wo } else { wo },
                u,
            ),
        }
    }

    /// Density (solid angle, over `h`) of [`Microfacet::sample_h`].
    #[inline(always)]
    pub fn pdf_h(&self, wo: Vec3, h: Vec3) -> f32 {
        let wo = if wo.z < 0.0 { -wo } else { wo };
        if wo.z == 0.0 {
            return 0.0;
        }
        self.g1(wo, h) * wo.dot(h).max(0.0) * self.d(h) / wo.z
    }

    /// Heitz 2018, "Sampling the GGX distribution of visible normals".
    #[inline(always)]
    fn sample_visible_ggx(&self, wo: Vec3, u: Vec2) -> Vec3 {
        let (ax, ay) = (self.alpha_x, self.alpha_y);
        // Stretch the view direction to the hemisphere configuration.
        let vh = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
        let len2 = vh.x * vh.x + vh.y * vh.y;
        let t1 = if len2 > 0.0 {
            Vec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
        } else {
            Vec3::X
        };
        let t2 = vh.cross(t1);
        // A uniform point on the disk (the concentric map: uniform like
        // Heitz's polar map, without a sine and cosine), warped onto the
        // visible half.
        let d = square_to_disk_concentric(u);
        let p1 = d.x;
        let s = 0.5 * (1.0 + vh.z);
        let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * d.y;
        let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
        // Unstretch.
        Vec3::new(ax * nh.x, ay * nh.y, nh.z.max(1e-6)).normalize()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// ∫ D(h) cos θh dω = 1 over the hemisphere, by a midpoint rule in
    /// (cos θ, φ) with a change of variables that resolves sharp lobes.
    fn projected_area(m: &Microfacet) -> f64 {
        let (nt, np) = (2000, 400);
        let mut sum = 0.0f64;
        for i in 0..nt {
            // θ = (π/2)·s², dense near the pole.
            let s = (i as f64 + 0.5) / nt as f64;
            let theta = 0.5 * std::f64::consts::PI * s * s;
            let dtheta = std::f64::consts::PI * s / nt as f64;
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let h = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    (theta.sin() * phi.sin()) as f32,
                    theta.cos() as f32,
                );
                sum += m.d(h) as f64
                    * theta.cos()
                    * theta.sin()
                    * dtheta
                    * (2.0 * std::f64::consts::PI / np as f64);
            }
        }
        sum
    }

    #[test]
    fn distributions_are_normalised() {
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            for (ax, ay) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                let m = Microfacet::new(kind, ax, ay);
                let a = projected_area(&m);
                assert!((a - 1.0).abs() < 5e-3, "{kind:?} {ax} {ay}: {a}");
            }
        }
    }

    #[test]
    fn erf_matches_known_values() {
        for (x, want) in [
            (0.0f32, 0.0f32),
            (0.5, 0.520_499_9),
            (1.0, 0.842_700_8),
            (-2.0, -0.995_322_3),
        ] {
            assert!((erf(x) - want).abs() < 2e-7, "erf({x}) = {}", erf(x));
        }
    }

    #[test]
    fn beckmann_lambda_matches_its_closed_form() {
        // Λ(a) = (erf(a) − 1)/2 + exp(−a²)/(2a√π) in f64, with the filter
        // module's erf; compared absolutely (what G1 = 1/(1 + Λ) sees) and
        // relatively where Λ is not tiny.
        let m = Microfacet::isotropic(Distribution::Beckmann, 1.0);
        for i in 1..2000 {
            let cos = i as f32 / 2000.0;
            let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
            let a = (w.z / w.x) as f64;
            let want = (crate::filter::erf(a) - 1.0) / 2.0
                + (-a * a).exp() / (2.0 * a * std::f64::consts::PI.sqrt());
            let got = m.lambda(w) as f64;
            assert!(
                (got - want).abs() < 2e-6 * want.max(1.0),
                "cos θ {cos}: Λ {got}, want {want}"
            );
            if want > 1e-3 {
                assert!(
                    (got - want).abs() < 1e-4 * want,
                    "cos θ {cos}: Λ {got}, want {want}"
                );
            }
        }
    }

    #[test]
    fn smith_g1_is_one_at_normal_incidence_and_falls_at_grazing() {
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            let m = Microfacet::isotropic(kind, 0.5);
            assert!((m.g1(Vec3::Z, Vec3::Z) - 1.0).abs() < 1e-6);
            let grazing = Vec3::new(0.999, 0.0, 0.0447).normalize();
            assert!(m.g1(grazing, Vec3::Z) < 0.5);
            // Back-facing microfacet.
            assert_eq!(
                m.g1(Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0)),
                0.0
            );
        }
    }

    /// `∫ g(h) dω` over the upper hemisphere, by a midpoint rule in
    /// (θ, φ) on a 1000 × 400 grid.
    fn over_hemisphere(g: impl Fn(Vec3) -> f64) -> f64 {
        let (nt, np) = (1000, 400);
        let mut sum = 0.0f64;
        for i in 0..nt {
            let theta = 0.5 * std::f64::consts::PI * (i as f64 + 0.5) / nt as f64;
            for j in 0..np {
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let h = Vec3::new(
                    (theta.sin() * phi.cos()) as f32,
                    (theta.sin() * phi.sin()) as f32,
                    theta.cos() as f32,
                );
                sum += g(h) * theta.sin();
            }
        }
        sum * 0.5 * std::f64::consts::PI / nt as f64 * 2.0 * std::f64::consts::PI / np as f64
    }

    #[test]
    fn sampled_normals_follow_the_visible_density() {
        // The mean of a test function over sampled normals equals its
        // integral against pdf_h (midpoint rule), for both distributions,
        // anisotropic, at normal and oblique incidence.
        let f = |h: Vec3| (h.x + 0.3 * h.y + h.z * h.z) as f64;
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            let m = Microfacet::new(kind, 0.4, 0.2);
            for wo in [
                Vec3::Z,
                Vec3::new(0.8, 0.0, 0.6),
                Vec3::new(-0.3, 0.9, 0.3).normalize(),
            ] {
                let n = 400;
                let mut mean = 0.0f64;
                for i in 0..n {
                    for j in 0..n {
                        let u = Vec2::new((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                        mean += f(m.sample_h(wo, u));
                    }
                }
                mean /= (n * n) as f64;
                let integral = over_hemisphere(|h| f(h) * m.pdf_h(wo, h) as f64);
                assert!(
                    (mean - integral).abs() < 2e-3,
                    "{kind:?} wo={wo}: {mean} against {integral}"
                );
            }
        }
    }

    #[test]
    fn visible_normal_density_integrates_to_one() {
        // ∫ pdf_h(wo, h) dh = 1 for every wo (the projected visible area).
        for kind in [Distribution::Ggx, Distribution::Beckmann] {
            let m = Microfacet::new(kind, 0.4, 0.2);
            for wo in [
                Vec3::Z,
                Vec3::new(0.8, 0.0, 0.6),
                Vec3::new(0.0, -0.98, 0.199).normalize(),
            ] {
                let sum = over_hemisphere(|h| m.pdf_h(wo, h) as f64);
                assert!((sum - 1.0).abs() < 5e-3, "{kind:?} wo={wo}: {sum}");
            }
        }
    }
}
