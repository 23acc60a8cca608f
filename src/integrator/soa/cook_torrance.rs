//! The rough Cook–Torrance lane adapter: its Fresnel terms known to the
//! compiler (a conductor's, Schlick's, a dielectric coating's) and its
//! parameters as a lane takes them.

use super::*;

/// The Fresnel term of a Cook–Torrance lane, its kind known to the
/// compiler (so the lane loop has no branch on it): [`ConductorTerm`],
/// [`SchlickTerm`] or [`CoatingTerm`], one loop each.
pub(super) trait LaneFresnel: Copy + PartialEq + std::fmt::Debug {
    /// A term for lanes of other materials (their results are discarded).
    const IDLE: Self;
    /// The term, if `fresnel` is of this kind.
    fn of(fresnel: Fresnel) -> Option<Self>;
    /// The term exactly as the general integrator holds it.
    fn fresnel(&self) -> Fresnel;
}

/// A conductor's Fresnel term ([`Fresnel::Conductor`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct ConductorTerm {
    /// Complex index of refraction, real part, per RGB channel.
    pub(super) eta: Vec3,
    /// Its imaginary part.
    pub(super) k: Vec3,
    /// Mitsuba's `specular_reflectance` tint.
    pub(super) tint: Vec3,
}

impl LaneFresnel for ConductorTerm {
    const IDLE: ConductorTerm = ConductorTerm {
        eta: Vec3::ONE,
        k: Vec3::ZERO,
        tint: Vec3::ONE,
    };
    fn of(fresnel: Fresnel) -> Option<ConductorTerm> {
        match fresnel {
            Fresnel::Conductor {
                eta,
                k,
                specular_reflectance,
            } => Some(ConductorTerm {
                eta,
                k,
                tint: specular_reflectance,
            }),
            _ => None,
        }
    }
    #[inline(always)]
    fn fresnel(&self) -> Fresnel {
        Fresnel::Conductor {
            eta: self.eta,
            k: self.k,
            specular_reflectance: self.tint,
        }
    }
}

/// Schlick's Fresnel term ([`Fresnel::Schlick`]): the reflectance at normal
/// incidence, linear RGB.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct SchlickTerm(pub(super) Vec3);

impl LaneFresnel for SchlickTerm {
    const IDLE: SchlickTerm = SchlickTerm(Vec3::splat(0.04));
    fn of(fresnel: Fresnel) -> Option<SchlickTerm> {
        match fresnel {
            Fresnel::Schlick { f0 } => Some(SchlickTerm(f0)),
            _ => None,
        }
    }
    #[inline(always)]
    fn fresnel(&self) -> Fresnel {
        Fresnel::Schlick { f0: self.0 }
    }
}

/// A dielectric coating's exact Fresnel term ([`Fresnel::Dielectric`]):
/// its index of refraction relative to the outside.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CoatingTerm(pub(super) f32);

impl LaneFresnel for CoatingTerm {
    const IDLE: CoatingTerm = CoatingTerm(1.5);
    fn of(fresnel: Fresnel) -> Option<CoatingTerm> {
        match fresnel {
            Fresnel::Dielectric { eta } => Some(CoatingTerm(eta)),
            _ => None,
        }
    }
    #[inline(always)]
    fn fresnel(&self) -> Fresnel {
        Fresnel::Dielectric { eta: self.0 }
    }
}

/// A rough Cook–Torrance surface's parameters as a lane takes them: a
/// distribution of kind `D`, isotropic or not, and a Fresnel term of kind
/// `F` (a rough conductor, or a Schlick or dielectric-coated reflector).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct CookTorranceIn<F, D> {
    /// Roughness α along the first and the second tangent.
    pub(super) alpha_x: f32,
    pub(super) alpha_y: f32,
    /// The Fresnel term.
    pub(super) fresnel: F,
    /// The distribution's kind.
    pub(super) distribution: PhantomData<D>,
}

impl<F: LaneFresnel, D: LaneDistribution> LaneKind for CookTorranceIn<F, D> {
    const IDLE: CookTorranceIn<F, D> = CookTorranceIn {
        alpha_x: 1.0,
        alpha_y: 1.0,
        fresnel: F::IDLE,
        distribution: PhantomData,
    };

    /// A distribution of kind `D` (isotropic or not) and a Fresnel term of
    /// kind `F` (a roughness map replaces α at each lane: `with_maps`; its
    /// other textures do not change the BSDF).
    fn of(material: &crate::material::Material) -> Option<CookTorranceIn<F, D>> {
        let Bsdf::CookTorrance(p) = material.bsdf else {
            return None;
        };
        let m = p.microfacet;
        if m.kind != D::KIND {
            return None;
        }
        F::of(p.fresnel).map(|fresnel| CookTorranceIn {
            alpha_x: m.alpha_x,
            alpha_y: m.alpha_y,
            fresnel,
            distribution: PhantomData,
        })
    }

    const MAPPABLE: bool = true;

    /// α from a roughness map ([`mapped_params`]: `[α_x, α_y, 0]`).
    #[inline(always)]
    fn with_maps(self, mapped: [f32; 3]) -> CookTorranceIn<F, D> {
        CookTorranceIn {
            alpha_x: mapped[0],
            alpha_y: mapped[1],
            ..self
        }
    }
}

impl<F: LaneFresnel, D: LaneDistribution> CookTorranceIn<F, D> {
    /// The BSDF's parameters, exactly as the general integrator holds them
    /// (the kinds of distribution and Fresnel term known to the compiler,
    /// so the lane loop has no branch on them).
    #[inline(always)]
    pub(super) fn params(&self) -> CookTorranceParams {
        CookTorranceParams {
            microfacet: Microfacet {
                kind: D::KIND,
                alpha_x: self.alpha_x,
                alpha_y: self.alpha_y,
            },
            fresnel: self.fresnel.fresnel(),
        }
    }
}

impl<F: LaneFresnel, D: LaneDistribution> LaneBsdf for CookTorranceIn<F, D> {
    const MAY_BE_ANISOTROPIC: bool = true;
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
    fn sample(&self, wo: Vec3, _uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        // [`Bsdf::sample`] of a Cook–Torrance surface (one lobe: no lobe
        // number).
        lane_sample(self.params().sample(wo, u))
    }
}

#[cfg(test)]
mod tests {
    use super::super::lane_bsdf::agreement::{assert_lane_matches, material};
    use super::*;

    fn check<F: LaneFresnel, D: LaneDistribution>(fresnel: Fresnel, kind: Distribution) {
        for (ax, ay) in [(0.3, 0.3), (0.05, 0.4), (0.9, 0.9)] {
            let bsdf = Bsdf::CookTorrance(CookTorranceParams {
                microfacet: Microfacet::new(kind, ax, ay),
                fresnel,
            });
            let lane = CookTorranceIn::<F, D>::of(&material(bsdf)).expect("a lane of this kind");
            assert_lane_matches(lane, &bsdf);
        }
    }

    #[test]
    fn cook_torrance_lanes_match_the_general_integrator() {
        let conductor = Fresnel::Conductor {
            eta: Vec3::new(0.2, 0.9, 1.1),
            k: Vec3::new(3.9, 2.4, 2.2),
            specular_reflectance: Vec3::ONE,
        };
        let schlick = Fresnel::Schlick {
            f0: Vec3::new(0.9, 0.6, 0.3),
        };
        let coating = Fresnel::Dielectric { eta: 1.5 };
        check::<ConductorTerm, Ggx>(conductor, Distribution::Ggx);
        check::<ConductorTerm, Beckmann>(conductor, Distribution::Beckmann);
        check::<SchlickTerm, Ggx>(schlick, Distribution::Ggx);
        check::<SchlickTerm, Beckmann>(schlick, Distribution::Beckmann);
        check::<CoatingTerm, Ggx>(coating, Distribution::Ggx);
        check::<CoatingTerm, Beckmann>(coating, Distribution::Beckmann);
    }
}
