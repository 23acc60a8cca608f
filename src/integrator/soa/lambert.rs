//! The Lambert lane adapter: a surface's albedo.

use super::*;

/// A Lambert surface's lane BSDF: its albedo.
#[derive(Clone, Copy)]
pub(super) struct LambertLane(pub(super) Vec3);

impl LaneBsdf for LambertLane {
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        lambert_eval(self.0, wo, wi)
    }
    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        lambert_pdf(wo, wi)
    }
    #[inline(always)]
    fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        // Cosine-weighted: the factor is the albedo itself.
        let (sampled, wi, pdf) = lambert_sample(wo, u);
        (sampled, wi, pdf, self.0)
    }
}

#[cfg(test)]
mod tests {
    use super::super::lane_bsdf::agreement::assert_lane_matches;
    use super::*;
    use crate::bsdf::DiffuseParams;

    #[test]
    fn lambert_lanes_match_the_general_integrator() {
        for albedo in [Vec3::new(0.8, 0.5, 0.2), Vec3::ZERO, Vec3::ONE] {
            let bsdf = Bsdf::Diffuse(DiffuseParams {
                reflectance: albedo,
            });
            assert_lane_matches(LambertLane(albedo), &bsdf);
        }
    }
}
