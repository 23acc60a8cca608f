//! The principled lane adapter, in Mitsuba's mode or the energy-conserving
//! one (its albedo tables looked up between the stages of a bounce).

use super::*;

/// Which mode of the principled BSDF a loop shades, known to the compiler:
/// Mitsuba's ([`MitsubaMode`], nothing to carry) or the energy-conserving
/// one ([`EnergyConserving`], which carries its albedo table).
pub(super) trait PrincipledMode: Copy + std::fmt::Debug {
    /// Whether this is the energy-conserving mode.
    const ENERGY_CONSERVING: bool;
    /// What [`LaneKind::IDLE`] carries.
    const IDLE: Self;
    /// The mode's data for a principled material.
    fn of(params: &PrincipledParams) -> Self;
    /// The albedo tables to evaluate with (`None`: none needed).
    fn tables(&self) -> Option<EnergyTables>;
}

/// Mitsuba's mode of the principled BSDF: nothing to carry, so its lanes'
/// parameters are plain numbers.
#[derive(Debug, Clone, Copy)]
pub(super) struct MitsubaMode;

impl PrincipledMode for MitsubaMode {
    const ENERGY_CONSERVING: bool = false;
    const IDLE: MitsubaMode = MitsubaMode;
    #[inline(always)]
    fn of(_params: &PrincipledParams) -> MitsubaMode {
        MitsubaMode
    }
    #[inline(always)]
    fn tables(&self) -> Option<EnergyTables> {
        None
    }
}

/// The energy-conserving mode: the material's albedo tables, looked up once
/// per material, not at every evaluation, so that the lane loop has no call
/// in it (tables of zeros in [`LaneKind::IDLE`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct EnergyConserving(pub(super) EnergyTables);

impl PrincipledMode for EnergyConserving {
    const ENERGY_CONSERVING: bool = true;
    const IDLE: EnergyConserving = EnergyConserving(EnergyTables::NONE);
    fn of(params: &PrincipledParams) -> EnergyConserving {
        EnergyConserving(params.energy_tables())
    }
    #[inline(always)]
    fn tables(&self) -> Option<EnergyTables> {
        Some(self.0)
    }
}

/// A principled surface's parameters as a lane takes them (its base colour
/// is the lane's albedo, looked up as a Lambert surface's colour is): the
/// principled BSDF in the mode `M`, isotropic or not.
#[derive(Debug, Clone, Copy)]
pub(super) struct PrincipledIn<M> {
    /// Metallic blend in [0, 1].
    pub(super) metallic: f32,
    /// Roughness in [0, 1].
    pub(super) roughness: f32,
    /// Specular in [0, 1] (sets η).
    pub(super) specular: f32,
    /// Specular tint in [0, 1].
    pub(super) spec_tint: f32,
    /// Anisotropy in [0, 1].
    pub(super) anisotropic: f32,
    /// What the mode carries.
    pub(super) mode: M,
}

impl<M: PrincipledMode> LaneKind for PrincipledIn<M> {
    const IDLE: PrincipledIn<M> = PrincipledIn {
        metallic: 0.0,
        roughness: 0.5,
        specular: 0.5,
        spec_tint: 0.0,
        anisotropic: 0.0,
        mode: M::IDLE,
    };

    /// Principled in the mode `M`; roughness and metallic maps replace
    /// those at each lane (`with_maps`), a base colour map is the lane's
    /// albedo.
    fn of(material: &crate::material::Material) -> Option<PrincipledIn<M>> {
        let Bsdf::Principled(p) = material.bsdf else {
            return None;
        };
        (p.energy_conserving == M::ENERGY_CONSERVING).then(|| PrincipledIn {
            metallic: p.metallic,
            roughness: p.roughness,
            specular: p.specular,
            spec_tint: p.spec_tint,
            anisotropic: p.anisotropic,
            mode: M::of(&p),
        })
    }

    const MAPPABLE: bool = true;

    /// Roughness and metallic from their maps ([`mapped_params`]:
    /// `[roughness, metallic, 0]`).
    #[inline(always)]
    fn with_maps(self, mapped: [f32; 3]) -> PrincipledIn<M> {
        PrincipledIn {
            roughness: mapped[0],
            metallic: mapped[1],
            ..self
        }
    }
}

/// A principled lane: its parameters and base colour.
#[derive(Clone, Copy)]
pub(super) struct PrincipledLane<M>(pub(super) PrincipledIn<M>, pub(super) Vec3);

impl<M: PrincipledMode> PrincipledLane<M> {
    /// The parameters exactly as the general integrator holds them (the
    /// mode known to the compiler, so the lane loop has no branch on it).
    #[inline(always)]
    pub(super) fn params(&self) -> PrincipledParams {
        let p = self.0;
        PrincipledParams {
            base_color: self.1,
            roughness: p.roughness,
            metallic: p.metallic,
            anisotropic: p.anisotropic,
            specular: p.specular,
            spec_tint: p.spec_tint,
            energy_conserving: M::ENERGY_CONSERVING,
        }
    }
}

impl<M: PrincipledMode> LaneBsdf for PrincipledLane<M> {
    const MAY_BE_ANISOTROPIC: bool = true;
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.params().eval_with(self.0.mode.tables(), wo, wi)
    }
    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.params().pdf(wo, wi)
    }
    #[inline(always)]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        self.params().eval_pdf_with(self.0.mode.tables(), wo, wi)
    }
    #[inline(always)]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        lane_sample(self.params().sample_with(self.0.mode.tables(), wo, uc, u))
    }
    /// The energy-conserving mode's lanes read albedo tables: a loop that
    /// reads a table at each lane's own place stays scalar (LLVM prices a
    /// gather as one load per lane, and cannot bound reads through each
    /// lane's table pointer), so their bounce is taken in three stages
    /// ([`shade_staged_lanes`]); Mitsuba's mode in the one loop.
    #[inline(always)]
    fn shade_chunk<const TRIANGLES: bool, const CONES: bool, const ENV: bool, const ANISO: bool>(
        bsdfs: &[Option<Self>; W],
        idle: Self,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    ) {
        if M::ENERGY_CONSERVING {
            shade_staged_lanes::<M, TRIANGLES, CONES, ENV, ANISO>(bsdfs, idle, lane_in, put, u)
        } else {
            shade_kind_lanes::<Self, TRIANGLES, CONES, ENV, ANISO>(bsdfs, idle, lane_in, put, u)
        }
    }
}

/// The first stage of an energy-conserving principled lane's bounce
/// ([`shade_staged_lanes`]): a lane BSDF that evaluates nothing but draws
/// the same direction as the principled BSDF, so that [`shade_lane`] with
/// it finds the directions the BSDF will be evaluated at
/// ([`LaneOut::evaluated`]); everything else it computes is discarded (and
/// so not computed at all).
#[derive(Clone, Copy)]
pub(super) struct PrincipledProbe<M>(pub(super) PrincipledLane<M>);

impl<M: PrincipledMode> LaneBsdf for PrincipledProbe<M> {
    // The same frame as the lane's own BSDF.
    const MAY_BE_ANISOTROPIC: bool = PrincipledLane::<M>::MAY_BE_ANISOTROPIC;
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
        let params = self.0.params();
        let wi = params.sample_direction(&params.microfacet(), wo, uc, u);
        (true, wi, 0.0, Vec3::ZERO)
    }
}

/// The last stage of an energy-conserving principled lane's bounce
/// ([`shade_staged_lanes`]): the lane with the specular lobe's albedos
/// looked up in advance for the light sample's direction (`light`: what
/// `eval` and `eval_pdf` are called with) and for the direction `sample`
/// draws (`sampled`), so that its loop reads no table.
#[derive(Clone, Copy)]
pub(super) struct StagedPrincipledLane<M> {
    pub(super) lane: PrincipledLane<M>,
    pub(super) light: KnownAlbedos,
    pub(super) sampled: KnownAlbedos,
}

impl<M: PrincipledMode> LaneBsdf for StagedPrincipledLane<M> {
    const MAY_BE_ANISOTROPIC: bool = PrincipledLane::<M>::MAY_BE_ANISOTROPIC;
    #[inline(always)]
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        self.lane.params().eval_with(self.light, wo, wi)
    }
    #[inline(always)]
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        self.lane.params().pdf(wo, wi)
    }
    #[inline(always)]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        self.lane.params().eval_pdf_with(self.light, wo, wi)
    }
    #[inline(always)]
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3) {
        lane_sample(self.lane.params().sample_with(self.sampled, wo, uc, u))
    }
}

#[cfg(test)]
mod tests {
    use super::super::lane_bsdf::agreement::{assert_lane_matches, material};
    use super::*;

    fn check<M: PrincipledMode>(energy_conserving: bool) {
        for (roughness, metallic, anisotropic) in
            [(0.5, 0.0, 0.0), (0.2, 1.0, 0.0), (0.7, 0.3, 0.6)]
        {
            let base_color = Vec3::new(0.7, 0.4, 0.2);
            let bsdf = Bsdf::Principled(PrincipledParams {
                base_color,
                roughness,
                metallic,
                anisotropic,
                specular: 0.5,
                spec_tint: 0.2,
                energy_conserving,
            });
            let lane = PrincipledIn::<M>::of(&material(bsdf)).expect("a lane of this mode");
            assert_lane_matches(PrincipledLane(lane, base_color), &bsdf);
        }
    }

    #[test]
    fn principled_lanes_match_the_general_integrator_in_both_modes() {
        check::<MitsubaMode>(false);
        check::<EnergyConserving>(true);
    }
}
