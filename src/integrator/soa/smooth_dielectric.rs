//! The smooth dielectric lane adapter (glass, water): mirror reflection
//! and refraction, both delta lobes.

use super::*;

/// A smooth dielectric as a lane takes it (glass, water): mirror reflection
/// with probability F and refraction otherwise, both delta lobes
/// ([`LaneBsdf::DELTA`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SmoothDielectricIn {
    /// Relative index of refraction, inside over outside.
    pub(super) eta: f32,
}

impl LaneKind for SmoothDielectricIn {
    const IDLE: SmoothDielectricIn = SmoothDielectricIn { eta: 1.5 };

    /// A smooth dielectric (no texture changes one).
    fn of(material: &crate::material::Material) -> Option<SmoothDielectricIn> {
        match material.bsdf {
            Bsdf::Dielectric(DielectricParams {
                eta,
                microfacet: None,
            }) => Some(SmoothDielectricIn { eta }),
            _ => None,
        }
    }
}

impl SmoothDielectricIn {
    /// The parameters exactly as the general integrator holds them.
    #[inline(always)]
    pub(super) fn params(&self) -> DielectricParams {
        DielectricParams {
            eta: self.eta,
            microfacet: None,
        }
    }
}

impl LaneBsdf for SmoothDielectricIn {
    const TRANSMITS: bool = true;
    const DELTA: bool = true;
    #[inline(always)]
    fn eta_scale(&self, wo: Vec3, wi: Vec3) -> f32 {
        Bsdf::Dielectric(self.params()).eta_scale(wo, wi)
    }
    // A delta BSDF's value and density for any given pair of directions is
    // zero (the lane takes no light sample, so neither is used).
    #[inline(always)]
    fn eval(&self, _wo: Vec3, _wi: Vec3) -> Vec3 {
        Vec3::ZERO
    }
    #[inline(always)]
    fn pdf(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        0.0
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

    #[test]
    fn smooth_dielectric_lanes_match_the_general_integrator() {
        for eta in [1.5, 1.33, 2.4] {
            let bsdf = Bsdf::Dielectric(DielectricParams {
                eta,
                microfacet: None,
            });
            let lane = SmoothDielectricIn::of(&material(bsdf)).expect("a smooth dielectric lane");
            assert_lane_matches(lane, &bsdf);
        }
    }
}
