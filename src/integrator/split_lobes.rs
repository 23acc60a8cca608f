//! A principled surface shaded with its diffuse and specular lobes in
//! frames of their own.
//!
//! A normal map can tilt the shading normal so far that the mirror
//! reflection of the viewing direction about it points into the surface:
//! a smooth metal's path then ends and the map draws black rings. The
//! correction (Cycles' `ensure_valid_specular_reflection`, see
//! [`super::steps::valid_reflection_normal`]) bends the normal back until
//! the reflection leaves the surface. Cycles applies it to its glossy
//! closures only; the diffuse closure keeps the mapped normal. So do
//! plsr's: the lobes are shaded apart, the diffuse lobe around the mapped
//! normal, the specular lobe around the bent one, wherever the correction
//! moved the normal of a glTF material (energy-conserving principled). On
//! Khronos' normal-map test models the difference from bending both lobes
//! is below the noise of a 1024-sample render.

use super::steps::sides_agree;
use crate::bsdf::models::PrincipledParams;
use crate::warp::Frame;
use glam::{Vec2, Vec3};

/// A principled BSDF whose lobes have two shading frames.
pub(crate) struct SplitLobes {
    /// The material at the hit (textures looked up).
    pub params: PrincipledParams,
    /// The diffuse lobe's frame (around the mapped normal).
    pub diffuse: Frame,
    /// The specular lobe's frame (around the bent normal).
    pub specular: Frame,
    /// Whether the light-leak guard applies ([`sides_agree`]: the mesh
    /// has shading normals).
    pub guard: bool,
    /// The unit geometric normal.
    pub ng: Vec3,
}

/// A direction [`SplitLobes::sample`] drew.
pub(crate) struct SplitSample {
    /// Unit direction (world).
    pub wi: Vec3,
    /// `f·|cos θi| / pdf`.
    pub weight: Vec3,
    /// Its solid-angle density.
    pub pdf: f32,
}

impl SplitLobes {
    /// `(f·|cos θi|, pdf)` for light leaving along `wo` and arriving along
    /// `wi` (world): each lobe in its frame, a lobe dropped where its frame
    /// puts `wi` on the other side of the surface than the geometry does.
    #[inline]
    pub(crate) fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        let d = (self.diffuse.to_local(wo), self.diffuse.to_local(wi));
        let s = (self.specular.to_local(wo), self.specular.to_local(wi));
        let lobes = self.params.eval_pdf_split(d, s);
        let keep = |(o, i): (Vec3, Vec3)| !self.guard || sides_agree(wo, wi, self.ng, o, i);
        let mut f = Vec3::ZERO;
        if keep(d) {
            f += lobes.diffuse;
        }
        if keep(s) {
            f += lobes.specular;
        }
        (f, lobes.pdf)
    }

    /// Draws a direction for `wo` (world): the lobe by `uc`, the direction
    /// in that lobe's frame by `u`; `None` where nothing is drawn or the
    /// sample carries nothing.
    #[inline]
    pub(crate) fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<SplitSample> {
        let m = self.params.microfacet();
        let frame = match self.params.samples_diffuse(uc) {
            true => &self.diffuse,
            false => &self.specular,
        };
        let local = self.params.sample_direction(&m, frame.to_local(wo), uc, u);
        if local.z <= 0.0 || !local.is_finite() {
            return None;
        }
        let wi = frame.to_world(local);
        let (f, pdf) = self.eval_pdf(wo, wi);
        if pdf.is_nan() || pdf <= 0.0 || f == Vec3::ZERO {
            return None;
        }
        Some(SplitSample {
            wi,
            weight: f / pdf,
            pdf,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use plsr_testkit::chi2::{chi2_test, SphereBinning};

    /// A glTF-like material: energy-conserving, half metal.
    fn params(roughness: f32, metallic: f32) -> PrincipledParams {
        PrincipledParams {
            base_color: Vec3::new(0.8, 0.5, 0.3),
            roughness,
            metallic,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving: true,
        }
    }

    /// Two lobes around `nd` (diffuse) and `ns` (specular).
    fn lobes(p: PrincipledParams, nd: Vec3, ns: Vec3) -> SplitLobes {
        SplitLobes {
            params: p,
            diffuse: Frame::from_normal(nd.normalize()),
            specular: Frame::from_normal(ns.normalize()),
            guard: true,
            ng: Vec3::Z,
        }
    }

    #[test]
    fn one_frame_for_both_lobes_is_the_principled_bsdf() {
        let p = params(0.4, 0.3);
        let n = Vec3::new(0.2, -0.1, 1.0).normalize();
        let split = lobes(p, n, n);
        let frame = Frame::from_normal(n);
        let wo = Vec3::new(0.3, 0.4, 0.8).normalize();
        for wi in [
            Vec3::new(-0.5, 0.1, 0.7),
            Vec3::new(0.1, 0.9, 0.3),
            Vec3::new(-0.3, -0.4, 0.8),
        ] {
            let wi = wi.normalize();
            let (f, pdf) = split.eval_pdf(wo, wi);
            let (wo_l, wi_l) = (frame.to_local(wo), frame.to_local(wi));
            let (g, q) = p.eval_pdf(wo_l, wi_l);
            let g = g * wi_l.z;
            assert!(
                (f - g).abs().max_element() < 1e-5 * g.max_element(),
                "{f} vs {g}"
            );
            assert!((pdf - q).abs() < 1e-5 * q, "{pdf} vs {q}");
        }
    }

    #[test]
    fn sampling_two_frames_matches_its_pdf_chi_square() {
        // The diffuse lobe around a mapped normal tilted 40° from the
        // geometric one, the specular lobe around a normal bent back.
        let nd = Vec3::new(0.64, 0.0, 0.77);
        let ns = Vec3::new(0.2, 0.1, 0.97);
        for (roughness, wo) in [
            (0.3, Vec3::new(-0.6, 0.0, 0.8)),
            (0.7, Vec3::new(-0.45, 0.2, 0.55)),
            (0.5, Vec3::new(0.1, 0.3, 0.95)),
        ] {
            let split = lobes(params(roughness, 0.4), nd, ns);
            let wo = wo.normalize();
            let mut rng = crate::rng::Rng::new(7, 3);
            let mut nonzero = 0;
            let r = chi2_test(
                SphereBinning::default(),
                200_000,
                |_| {
                    // The density covers draws whose value is zero (the
                    // path then ends): count them as drawn.
                    let (uc, u) = (rng.next_f32(), rng.next_2d());
                    let m = split.params.microfacet();
                    let frame = match split.params.samples_diffuse(uc) {
                        true => &split.diffuse,
                        false => &split.specular,
                    };
                    let local = split.params.sample_direction(&m, frame.to_local(wo), uc, u);
                    if let Some(s) = split.sample(wo, uc, u) {
                        nonzero += 1;
                        let (f, pdf) = split.eval_pdf(wo, s.wi);
                        assert!((s.weight - f / pdf).abs().max_element() < 1e-4);
                    }
                    (local.z > 0.0).then(|| frame.to_world(local))
                },
                &|wi| split.eval_pdf(wo, wi).1 as f64,
                1e-3,
            );
            assert!(r.passed, "roughness {roughness}, wo {wo}: {}", r.summary);
            assert!(nonzero > 100_000, "{nonzero} samples carried light");
        }
    }

    #[test]
    fn a_white_dielectric_reflects_at_most_what_arrives() {
        // The split lobes need not conserve energy exactly (the diffuse lobe
        // reads the specular albedos at another frame's heights), but they
        // must not create it: the estimate of the directional albedo,
        // E[f·cos/pdf], stays at or below 1 (+ 3 % noise and table error).
        let mut p = params(0.5, 0.0);
        p.base_color = Vec3::ONE;
        let split = lobes(p, Vec3::new(0.5, 0.0, 0.87), Vec3::new(0.1, 0.0, 0.99));
        for wo in [Vec3::new(-0.7, 0.0, 0.7), Vec3::new(0.3, 0.5, 0.8)] {
            let wo = wo.normalize();
            let mut rng = crate::rng::Rng::new(11, 5);
            let n = 200_000;
            let mut sum = Vec3::ZERO;
            for _ in 0..n {
                if let Some(s) = split.sample(wo, rng.next_f32(), rng.next_2d()) {
                    sum += s.weight;
                }
            }
            let albedo = sum / n as f32;
            assert!(albedo.max_element() < 1.03, "wo {wo}: albedo {albedo}");
            assert!(albedo.min_element() > 0.5, "wo {wo}: albedo {albedo}");
        }
    }
}
