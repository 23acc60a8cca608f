//! The rough dielectric lane adapter (GGX or Beckmann).

use super::*;

/// A rough dielectric's parameters as a lane takes them: microfacet
/// reflection and transmission (Walter et al. 2007) with a distribution of
/// kind `D`, isotropic or not. Smooth dielectrics have a loop of their own
/// ([`SmoothDielectricIn`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct DielectricIn<D> {
    /// Relative index of refraction, inside over outside.
    pub(super) eta: f32,
    /// Roughness α along the first and the second tangent.
    pub(super) alpha_x: f32,
    pub(super) alpha_y: f32,
    /// The distribution's kind.
    pub(super) distribution: PhantomData<D>,
}

impl<D: LaneDistribution> LaneKind for DielectricIn<D> {
    const IDLE: DielectricIn<D> = DielectricIn {
        eta: 1.5,
        alpha_x: 0.5,
        alpha_y: 0.5,
        distribution: PhantomData,
    };

    /// A rough dielectric with a distribution of kind `D` (no texture
    /// changes a dielectric).
    fn of(material: &crate::material::Material) -> Option<DielectricIn<D>> {
        let Bsdf::Dielectric(DielectricParams {
            eta,
            microfacet: Some(m),
        }) = material.bsdf
        else {
            return None;
        };
        (m.kind == D::KIND).then_some(DielectricIn {
            eta,
            alpha_x: m.alpha_x,
            alpha_y: m.alpha_y,
            distribution: PhantomData,
        })
    }
}

impl<D: LaneDistribution> DielectricIn<D> {
    /// The parameters exactly as the general integrator holds them (the
    /// distribution known to the compiler).
    #[inline(always)]
    pub(super) fn params(&self) -> DielectricParams {
        DielectricParams {
            eta: self.eta,
            microfacet: Some(Microfacet {
                kind: D::KIND,
                alpha_x: self.alpha_x,
                alpha_y: self.alpha_y,
            }),
        }
    }
}

impl<D: LaneDistribution> LaneBsdf for DielectricIn<D> {
    const TRANSMITS: bool = true;
    const MAY_BE_ANISOTROPIC: bool = true;
    #[inline(always)]
    fn eta_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        Bsdf::Dielectric(self.params()).eta_scale(wo, wi)
    }
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.params().eval(wo, wi)
    }
    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.params().pdf(wo, wi)
    }
    #[inline(always)]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        self.params().eval_pdf(wo, wi)
    }
    #[inline(always)]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        lane_sample(self.params().sample(wo, uc, u))
    }
}

#[cfg(test)]
mod tests {
    use super::super::lane_bsdf::agreement::{assert_lane_matches, material};
    use super::*;

    fn check<D: LaneDistribution>(kind: Distribution) {
        for (eta, alpha) in [(1.5, 0.3), (1.33, 0.05), (1.0 / 1.5, 0.6)] {
            let bsdf = Bsdf::Dielectric(DielectricParams {
                eta,
                microfacet: Some(Microfacet::isotropic(kind, alpha)),
            });
            let lane = DielectricIn::<D>::of(&material(bsdf)).expect("a lane of this kind");
            assert_lane_matches(lane, &bsdf);
        }
    }

    #[test]
    fn rough_dielectric_lanes_match_the_general_integrator() {
        check::<Ggx>(Distribution::Ggx);
        check::<Beckmann>(Distribution::Beckmann);
    }
}
