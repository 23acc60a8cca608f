//! The Blinn–Phong lane adapter.

use super::*;

/// A Blinn–Phong surface's parameters as a lane takes them: exactly the
/// general integrator's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct BlinnPhongIn(pub(super) BlinnPhongParams);

impl LaneKind for BlinnPhongIn {
    const IDLE: BlinnPhongIn = BlinnPhongIn(BlinnPhongParams {
        diffuse: Vec3::splat(0.5),
        specular: Vec3::splat(0.5),
        exponent: 1.0,
    });

    /// Blinn–Phong (a colour map replaces the diffuse colour at each lane:
    /// `with_maps`; no other texture changes its BSDF).
    fn of(material: &crate::material::Material) -> Option<BlinnPhongIn> {
        let Bsdf::BlinnPhong(p) = material.bsdf else {
            return None;
        };
        Some(BlinnPhongIn(p))
    }

    const MAPPABLE: bool = true;

    /// The diffuse colour from a colour map ([`mapped_params`]: linear RGB).
    #[inline(always)]
    fn with_maps(self, mapped: [f32; 3]) -> BlinnPhongIn {
        BlinnPhongIn(BlinnPhongParams {
            diffuse: Vec3::from_array(mapped),
            ..self.0
        })
    }
}

impl LaneBsdf for BlinnPhongIn {
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.0.eval(wo, wi)
    }
    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.0.pdf(wo, wi)
    }
    #[inline(always)]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        lane_sample(self.0.sample(wo, uc, u))
    }
}

#[cfg(test)]
mod tests {
    use super::super::lane_bsdf::agreement::{assert_lane_matches, material};
    use super::*;

    #[test]
    fn blinn_phong_lanes_match_the_general_integrator() {
        for exponent in [1.0, 20.0, 500.0] {
            let bsdf = Bsdf::BlinnPhong(BlinnPhongParams {
                diffuse: Vec3::new(0.5, 0.3, 0.1),
                specular: Vec3::splat(0.3),
                exponent,
            });
            let lane = BlinnPhongIn::of(&material(bsdf)).expect("a Blinn-Phong lane");
            assert_lane_matches(lane, &bsdf);
        }
    }
}
