//! The interfaces of a material kind's lane adapter: [`LaneKind`], the
//! parameters a lane of the kind takes, and [`LaneBsdf`], its evaluation,
//! density and sampling, the same as the general integrator's [`Bsdf`].

use super::*;

/// A material kind the kernel shades in a vectorised loop of its own: the
/// parameters a lane of that kind takes.
pub(super) trait LaneKind: Copy {
    /// Parameters for the lanes of a chunk that are not of this kind: they
    /// run through the loop with these, and their results are discarded.
    const IDLE: Self;
    /// The material's parameters where the kernel shades it in this kind's
    /// loop (with its constant values where a map replaces one).
    fn of(material: &crate::material::Material) -> Option<Self>;
    /// Whether a map can change this kind's parameters (then its pass loads
    /// the lanes' [`mapped_params`] in scenes that have maps).
    const MAPPABLE: bool = false;
    /// These parameters with those a lane's maps give at its hit, as
    /// [`mapped_params`] packs them from the material's
    /// [`crate::material::Material::bsdf_at`] there (unchanged for a kind
    /// no map changes).
    #[inline(always)]
    fn with_maps(self, _mapped: [f32; 3]) -> Self {
        self
    }
}

/// The BSDF of a lane in [`shade_lane`]: the same evaluation, density and
/// sampling as the general integrator's [`Bsdf`] for that model.
pub(super) trait LaneBsdf: Copy {
    /// Whether light passes through the surface ([`Bsdf::transmits`]): the
    /// lane then keeps the geometric normal as the outside, and offsets each
    /// ray's origin to the side it leaves on.
    const TRANSMITS: bool = false;
    /// Whether every lobe is a delta distribution ([`Bsdf::is_delta`]): the
    /// lane then takes no light sample and draws no numbers for one, and its
    /// sample's density is recorded as 0 (emission it finds next gets no
    /// MIS weight).
    const DELTA: bool = false;
    /// Whether a surface of this kind may be anisotropic
    /// ([`Bsdf::is_anisotropic`]): its lanes then build their shading frame
    /// around the tangent `lane_surfaces` looked up, where they have one.
    const MAY_BE_ANISOTROPIC: bool = false;
    /// `η²` of a scattering from `wo` to `wi` ([`Bsdf::eta_scale`]).
    #[inline(always)]
    fn eta_scale(&self, _wo: Vec3, _wi: Vec3) -> f32 {
        1.0
    }
    /// `f(wo, wi)` (1/sr), local frame, without the cosine.
    fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3;
    /// Solid-angle density of [`LaneBsdf::sample`] drawing `wi`.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f32;
    /// `(eval, pdf)` together, as [`Bsdf::eval_pdf`] computes them (for a
    /// light sample from a light that is not a delta light).
    #[inline(always)]
    fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (Vec3, f32) {
        (self.eval(wo, wi), self.pdf(wo, wi))
    }
    /// A direction for `wo`, `uc` picking the lobe and `u` the direction in
    /// it: (drawn, `wi` in the local frame, its density, the throughput
    /// factor `f·|cos θi|/pdf`).
    fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> (bool, Vec3, f32, Vec3);
    /// One bounce of the lanes of a chunk whose material is of this kind
    /// (`Some` in `bsdfs`; `idle` stands in for the others), for
    /// [`shade_kind`]: one loop of [`shade_lane`] ([`shade_kind_lanes`]),
    /// unless the kind needs stages of its own.
    #[inline(always)]
    fn shade_chunk<const TRIANGLES: bool, const CONES: bool, const ENV: bool, const ANISO: bool>(
        bsdfs: &[Option<Self>; W],
        idle: Self,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    ) {
        shade_kind_lanes::<Self, TRIANGLES, CONES, ENV, ANISO>(bsdfs, idle, lane_in, put, u)
    }
}

/// A general BSDF sample as [`LaneBsdf::sample`] returns it: (drawn, `wi`,
/// its density, the throughput factor), with placeholders where none was
/// drawn.
#[inline(always)]
pub(super) fn lane_sample(sample: Option<BsdfSample>) -> (bool, Vec3, f32, Vec3) {
    match sample {
        Some(s) => (true, s.wi, s.pdf, s.weight),
        None => (false, Vec3::Z, 0.0, Vec3::ZERO),
    }
}

/// The check every kind's lane adapter is tested with (rav1e's habit: each
/// vectorised kernel against its scalar reference, beside it).
#[cfg(test)]
pub(super) mod agreement {
    use super::*;
    use crate::material::Material;
    use crate::rng::Rng;
    use crate::warp::square_to_uniform_sphere;

    /// The bits of a colour, so that −0, +0 and NaNs compare exactly.
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// Asserts that `lane` evaluates, weighs and samples exactly as the
    /// general integrator's `bsdf` does, bit for bit, for 4096 random pairs
    /// of directions on both sides of the surface and random numbers.
    pub(in crate::integrator::soa) fn assert_lane_matches<B: LaneBsdf>(lane: B, bsdf: &Bsdf) {
        assert_eq!(B::TRANSMITS, bsdf.transmits(), "TRANSMITS of {bsdf:?}");
        assert_eq!(B::DELTA, bsdf.is_delta(), "DELTA of {bsdf:?}");
        let mut rng = Rng::new(2026, 12);
        let mut drawn = 0;
        for i in 0..4096 {
            let mut u2 = || Vec2::new(rng.next_f32(), rng.next_f32());
            let (wo, wi, u) = (
                square_to_uniform_sphere(u2()),
                square_to_uniform_sphere(u2()),
                u2(),
            );
            let uc = rng.next_f32();
            let at = format!("{bsdf:?}, pair {i}: wo {wo}, wi {wi}");
            assert_eq!(
                bits(lane.eval(wo, wi)),
                bits(bsdf.eval(wo, wi)),
                "eval, {at}"
            );
            assert_eq!(
                lane.pdf(wo, wi).to_bits(),
                bsdf.pdf(wo, wi).to_bits(),
                "pdf, {at}"
            );
            let (f, pdf) = lane.eval_pdf(wo, wi);
            let (f_ref, pdf_ref) = bsdf.eval_pdf(wo, wi);
            assert_eq!(
                (bits(f), pdf.to_bits()),
                (bits(f_ref), pdf_ref.to_bits()),
                "eval_pdf, {at}"
            );
            assert_eq!(
                lane.eta_scale(wo, wi).to_bits(),
                bsdf.eta_scale(wo, wi).to_bits(),
                "eta_scale, {at}"
            );
            let (sampled, s_wi, s_pdf, weight) = lane.sample(wo, uc, u);
            match bsdf.sample(wo, uc, u) {
                Some(s) => {
                    drawn += 1;
                    assert!(sampled, "the lane drew nothing where the BSDF did, {at}");
                    assert_eq!(
                        (bits(s_wi), s_pdf.to_bits(), bits(weight)),
                        (bits(s.wi), s.pdf.to_bits(), bits(s.weight)),
                        "sample, {at}"
                    );
                }
                None => assert!(!sampled, "the lane drew where the BSDF did not, {at}"),
            }
        }
        // The directions cover both sides: some draws succeed, some fail.
        assert!(drawn > 1000, "{bsdf:?}: only {drawn} of 4096 samples drawn");
    }

    /// `bsdf` as a scene's material, for [`LaneKind::of`].
    pub(in crate::integrator::soa) fn material(bsdf: Bsdf) -> Material {
        Material::new("tested", bsdf)
    }
}
