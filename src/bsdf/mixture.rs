//! What a surface does at one shading point: one BSDF, or a mixture of a
//! few BSDFs and a straight pass-through (Mitsuba's `blendbsdf`, `mask`
//! and `null`, flattened by [`crate::material::Composite`]).
//!
//! A [`Scatter::Mix`] is `Σ wᵢ·fᵢ` plus a pass-through of probability `q`,
//! with `Σ wᵢ + q = 1`:
//!
//! - `eval = Σ wᵢ fᵢ(wo, wi)` and `pdf = Σ wᵢ pᵢ(wo, wi)` (the
//!   pass-through is a delta lobe, never evaluated);
//! - `sample` picks a part with probability `wᵢ` (or `q`) by `uc`, then
//!   samples it with `uc` rescaled. A smooth direction is weighted by the
//!   whole mixture, `Σ wᵢ fᵢ |cos| / Σ wᵢ pᵢ` (the one-sample estimator of
//!   the sum, as pbrt and Mitsuba 3.8 do); a delta lobe's sample keeps its
//!   own weight, its probability times `wᵢ`; the pass-through continues
//!   along `−wo` with weight 1 and probability `q`, and counts as a bounce
//!   (as in Mitsuba, whose shadow rays such a surface blocks too).
//!
//! Directions are in the local frame of the surface's outside. Opaque parts
//! expect `wo` above the surface: on the back of a surface whose mixture
//! transmits (the integrator then keeps the geometric outside) an opaque
//! part that has two sides is evaluated mirrored through the tangent plane
//! (`flip`), as Mitsuba's `twosided` does.

use super::{Bsdf, BsdfSample};
use glam::{Vec2, Vec3};

/// At most this many BSDFs in one mixture.
pub const MAX_PARTS: usize = 4;

/// A surface's scattering at one shading point.
// Built per shading point and `Copy`: boxing the mixture would allocate at
// every hit on a composite.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scatter {
    /// One BSDF (every material that is not a composite).
    One(Bsdf),
    /// A mixture of BSDFs and a pass-through.
    Mix(Mixture),
}

/// A mixture of up to [`MAX_PARTS`] BSDFs and a straight pass-through; see
/// the module's documentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mixture {
    parts: [Bsdf; MAX_PARTS],
    /// Each part's weight `wᵢ` (probability of being sampled).
    weights: [f32; MAX_PARTS],
    /// Whether each part is evaluated mirrored through the tangent plane.
    flips: [bool; MAX_PARTS],
    /// How many parts there are.
    len: usize,
    /// The pass-through's probability `q`.
    pass: f32,
}

impl Default for Mixture {
    fn default() -> Mixture {
        Mixture {
            parts: [Bsdf::diffuse(Vec3::ZERO); MAX_PARTS],
            weights: [0.0; MAX_PARTS],
            flips: [false; MAX_PARTS],
            len: 0,
            pass: 0.0,
        }
    }
}

/// A mirror through the tangent plane.
#[inline(always)]
fn mirror(w: Vec3) -> Vec3 {
    Vec3::new(w.x, w.y, -w.z)
}

impl Mixture {
    /// An empty mixture: absorbs everything.
    pub fn new() -> Mixture {
        Mixture::default()
    }

    /// Adds `bsdf` with weight `weight` (ignored if not positive), mirrored
    /// through the tangent plane if `flip`. Returns `false` when the
    /// mixture is full.
    pub fn push(&mut self, bsdf: Bsdf, weight: f32, flip: bool) -> bool {
        if weight <= 0.0 || weight.is_nan() {
            return true;
        }
        if self.len == MAX_PARTS {
            return false;
        }
        self.parts[self.len] = bsdf;
        self.weights[self.len] = weight;
        self.flips[self.len] = flip;
        self.len += 1;
        true
    }

    /// Adds `weight` to the pass-through's probability.
    pub fn pass_through(&mut self, weight: f32) {
        if weight > 0.0 {
            self.pass += weight;
        }
    }

    /// The parts with their weights and flips.
    fn parts(&self) -> impl Iterator<Item = (&Bsdf, f32, bool)> {
        (0..self.len).map(|i| (&self.parts[i], self.weights[i], self.flips[i]))
    }

    /// Part `i`'s directions: mirrored if it is flipped.
    #[inline]
    fn local(&self, i: usize, w: Vec3) -> Vec3 {
        if self.flips[i] {
            mirror(w)
        } else {
            w
        }
    }

    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let (mut f, mut pdf) = (Vec3::ZERO, 0.0);
        for i in 0..self.len {
            let (fi, pi) = self.parts[i].eval_pdf(self.local(i, wo), self.local(i, wi));
            f += self.weights[i] * fi;
            pdf += self.weights[i] * pi;
        }
        (f, pdf)
    }

    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        // Pick a part by `uc` over [w₀, w₁, …, q], then rescale `uc`.
        let mut start = 0.0;
        let mut picked = None;
        for i in 0..self.len {
            let w = self.weights[i];
            if uc < start + w {
                picked = Some((i, ((uc - start) / w).clamp(0.0, 1.0 - f32::EPSILON)));
                break;
            }
            start += w;
        }
        let Some((i, uc)) = picked else {
            if self.pass <= 0.0 {
                return None;
            }
            return Some(BsdfSample {
                wi: -wo,
                f: Vec3::ZERO,
                pdf: self.pass,
                weight: Vec3::ONE,
                delta: true,
            });
        };
        let bs = self.parts[i].sample(self.local(i, wo), uc, u)?;
        let wi = self.local(i, bs.wi);
        if bs.delta {
            return Some(BsdfSample {
                wi,
                pdf: bs.pdf * self.weights[i],
                f: bs.f * self.weights[i],
                ..bs
            });
        }
        let (f, pdf) = self.eval_pdf(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wi,
            f,
            pdf,
            weight: f * (wi.z.abs() / pdf),
            delta: false,
        })
    }
}

impl Scatter {
    /// `f(wo, wi)` in 1/sr, without the cosine ([`Bsdf::eval`]).
    #[inline]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        match self {
            Scatter::One(b) => b.eval(wo, wi),
            Scatter::Mix(m) => m.eval_pdf(wo, wi).0,
        }
    }

    /// Draws `wi` for `wo` ([`Bsdf::sample`]).
    #[inline]
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        match self {
            Scatter::One(b) => b.sample(wo, uc, u),
            Scatter::Mix(m) => m.sample(wo, uc, u),
        }
    }

    /// `(eval, pdf)` together ([`Bsdf::eval_pdf`]).
    #[inline]
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        match self {
            Scatter::One(b) => b.eval_pdf(wo, wi),
            Scatter::Mix(m) => m.eval_pdf(wo, wi),
        }
    }

    /// The density [`Scatter::sample`] picks `wi` with.
    #[inline]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Scatter::One(b) => b.pdf(wo, wi),
            Scatter::Mix(m) => m.eval_pdf(wo, wi).1,
        }
    }

    /// Whether light can leave on the other side ([`Bsdf::transmits`]):
    /// a transmissive part or a pass-through.
    #[inline]
    pub fn transmits(&self) -> bool {
        match self {
            Scatter::One(b) => b.transmits(),
            Scatter::Mix(m) => m.pass > 0.0 || m.parts().any(|(b, _, _)| b.transmits()),
        }
    }

    /// Whether every lobe is a delta (light sampling is skipped).
    #[inline]
    pub fn is_delta(&self) -> bool {
        match self {
            Scatter::One(b) => b.is_delta(),
            Scatter::Mix(m) => m.parts().all(|(b, _, _)| b.is_delta()),
        }
    }

    /// Whether a part depends on the tangent direction.
    #[inline]
    pub fn is_anisotropic(&self) -> bool {
        match self {
            Scatter::One(b) => b.is_anisotropic(),
            Scatter::Mix(m) => m.parts().any(|(b, _, _)| b.is_anisotropic()),
        }
    }

    /// `η²` of the scattering from `wo` to `wi` ([`Bsdf::eta_scale`]): a
    /// pass-through is 1; otherwise the first transmissive part's.
    #[inline]
    pub fn eta_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Scatter::One(b) => b.eta_scale(wo, wi),
            Scatter::Mix(m) => {
                if wi == -wo {
                    return 1.0;
                }
                m.parts()
                    .find(|(b, _, _)| b.transmits())
                    .map_or(1.0, |(b, _, _)| b.eta_scale(wo, wi))
            }
        }
    }

    /// The albedo layer's value: the parts' albedos, weighted.
    pub fn albedo(&self) -> Vec3 {
        match self {
            Scatter::One(b) => b.albedo(),
            Scatter::Mix(m) => m.parts().map(|(b, w, _)| w * b.albedo()).sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pass_through_continues_straight_with_weight_one() {
        let mut m = Mixture::new();
        assert!(m.push(Bsdf::diffuse(Vec3::splat(0.5)), 0.25, false));
        m.pass_through(0.75);
        let s = Scatter::Mix(m);
        let wo = Vec3::new(0.3, 0.1, 0.9).normalize();
        let bs = s.sample(wo, 0.5, Vec2::splat(0.3)).unwrap();
        assert_eq!(bs.wi, -wo);
        assert!(bs.delta && bs.weight == Vec3::ONE && bs.pdf == 0.75);
        assert_eq!(s.eta_scale(wo, bs.wi), 1.0);
        // Diffuse picked: eval and pdf are a quarter of the diffuse's.
        let bs = s.sample(wo, 0.1, Vec2::splat(0.3)).unwrap();
        let d = Bsdf::diffuse(Vec3::splat(0.5));
        assert!((bs.f - 0.25 * d.eval(wo, bs.wi)).abs().max_element() < 1e-7);
        assert!((bs.pdf - 0.25 * d.pdf(wo, bs.wi)).abs() < 1e-6);
        assert!(s.transmits() && !s.is_delta());
    }

    #[test]
    fn a_full_mixture_refuses_more_parts_and_an_empty_one_absorbs() {
        let mut m = Mixture::new();
        for _ in 0..MAX_PARTS {
            assert!(m.push(Bsdf::diffuse(Vec3::ONE), 0.25, false));
        }
        assert!(!m.push(Bsdf::diffuse(Vec3::ONE), 0.25, false));
        assert!(
            m.push(Bsdf::diffuse(Vec3::ONE), 0.0, false),
            "weight 0 is skipped"
        );
        let empty = Scatter::Mix(Mixture::new());
        assert!(empty.sample(Vec3::Z, 0.5, Vec2::splat(0.5)).is_none());
        assert_eq!(empty.eval(Vec3::Z, Vec3::Z), Vec3::ZERO);
    }

    #[test]
    fn a_flipped_part_sees_the_back_as_its_front() {
        let mut m = Mixture::new();
        m.push(Bsdf::diffuse(Vec3::splat(0.6)), 1.0, true);
        let s = Scatter::Mix(m);
        let (wo, wi) = (Vec3::new(0.2, 0.0, -0.98), Vec3::new(-0.1, 0.3, -0.95));
        assert!(
            (s.eval(wo, wi) - Vec3::splat(0.6 / std::f32::consts::PI))
                .abs()
                .max_element()
                < 1e-6
        );
        let bs = s.sample(wo, 0.3, Vec2::new(0.4, 0.7)).unwrap();
        assert!(bs.wi.z < 0.0, "sampled on the viewer's side: {}", bs.wi);
    }
}
