//! The shading passes: one pass per material kind over the lanes
//! ([`shade_lanes`]), each in chunks of [`W`] lanes ([`shade_chunks`]),
//! which lanes each pass shades ([`MaterialPass`]).

use super::*;

/// One bounce of the lanes of a chunk whose material is of one kind `B`
/// (`Some` in `bsdfs`), through [`shade_lane`] ([`LaneBsdf::shade_chunk`]);
/// the chunk's other lanes go through the same loop with `idle` (so that it
/// has no branch) and their results are discarded. A chunk with no such
/// lane is skipped.
#[inline(always)]
pub(super) fn shade_kind<B: LaneBsdf, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    bsdfs: &[Option<B>; W],
    idle: B,
    aniso: bool,
    lane_in: &impl Fn(usize) -> LaneIn,
    put: &mut impl FnMut(usize, bool, LaneOut),
    u: Uniform,
) {
    if bsdfs.iter().all(Option::is_none) {
        return;
    }
    // A chunk with an anisotropic lane (rare) takes the loop compiled for
    // every light kind (the lanes' own flags select the same results), so that it adds one variant per kind to compile.
    if B::MAY_BE_ANISOTROPIC && aniso {
        B::shade_chunk::<true, true, true, true>(bsdfs, idle, lane_in, put, u)
    } else {
        B::shade_chunk::<TRIANGLES, CONES, ENV, false>(bsdfs, idle, lane_in, put, u)
    }
}

/// The loop of [`shade_kind`], for chunks with (`ANISO`) or without an
/// anisotropic lane.
#[inline(always)]
pub(super) fn shade_kind_lanes<
    B: LaneBsdf,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
    const ANISO: bool,
>(
    bsdfs: &[Option<B>; W],
    idle: B,
    lane_in: &impl Fn(usize) -> LaneIn,
    put: &mut impl FnMut(usize, bool, LaneOut),
    u: Uniform,
) {
    for k in 0..W {
        let l = lane_in(k);
        let out = shade_lane::<B, TRIANGLES, CONES, ENV, ANISO>(l, bsdfs[k].unwrap_or(idle), u);
        if bsdfs[k].is_some() {
            put(k, l.hit, out);
        }
    }
}

/// The three stages of an energy-conserving principled chunk's bounce
/// ([`LaneBsdf::shade_chunk`]):
/// 1. a vectorised loop of [`shade_lane`] with [`PrincipledProbe`], which
///    finds where each lane's BSDF will be evaluated (`wo`, the light
///    sample's `wi`, the sampled `wi`) and nothing else;
/// 2. a scalar loop looking up the specular lobe's albedos there in each
///    lane's tables (`E(wo)`, `E(wi)` of both directions, `Ē`), exactly as
///    the general integrator looks them up;
/// 3. the vectorised loop of [`shade_lane`] with those albedos
///    ([`StagedPrincipledLane`]), which reads no table.
///
/// Stages 1 and 3 run the same code on the same numbers, so the directions
/// looked up are the ones evaluated, bit for bit.
#[inline(always)]
pub(super) fn shade_staged_lanes<
    M: PrincipledMode,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
    const ANISO: bool,
>(
    principled: &[Option<PrincipledLane<M>>; W],
    idle: PrincipledLane<M>,
    lane_in: &impl Fn(usize) -> LaneIn,
    put: &mut impl FnMut(usize, bool, LaneOut),
    u: Uniform,
) {
    // The lanes' parameters by component, without their tables: a loop
    // reading structures that hold pointers among the numbers loads each
    // lane's fields one by one, which LLVM's cost model rightly finds too
    // dear on AVX2 (the tables are read in stage 2 only).
    let mut params = [[0.0f32; W]; 8];
    let owned: [bool; W] = std::array::from_fn(|k| principled[k].is_some());
    for (k, lane) in principled.iter().enumerate() {
        let PrincipledLane(p, colour) = lane.unwrap_or(idle);
        let numbers = [
            p.metallic,
            p.roughness,
            p.specular,
            p.spec_tint,
            p.anisotropic,
            colour.x,
            colour.y,
            colour.z,
        ];
        for (c, v) in numbers.into_iter().enumerate() {
            params[c][k] = v;
        }
    }
    // Stage 1: each lane's directions, component by component (`[wo, the
    // light sample's wi, the sampled wi]` as x, y, z each), so that the
    // vectorised loop stores whole registers.
    let mut evaluated = [[0.0f32; W]; 9];
    for k in 0..W {
        let probe = PrincipledProbe(lane_numbers::<M>(&params, k));
        let dirs = shade_lane::<_, TRIANGLES, CONES, ENV, ANISO>(lane_in(k), probe, u).evaluated;
        for d in 0..3 {
            for c in 0..3 {
                evaluated[3 * d + c][k] = dirs[d][c];
            }
        }
    }
    // Stage 2: the albedos there, `[E(wo), E(light wi), E(sampled wi), Ē,
    // the metal's multiple-scattering factor at wo]` by component.
    let mut albedos = [[0.0f32; W]; 15];
    for (k, lane) in principled.iter().enumerate() {
        let Some(lane) = lane else {
            continue;
        };
        let params = lane.params();
        let m = params.microfacet();
        let tables = lane.0.mode.tables().unwrap_or(EnergyTables::NONE);
        let mut found = [params.average_dielectric_albedo(&tables, &m); 5];
        let wo = Vec3::new(evaluated[0][k], evaluated[1][k], evaluated[2][k]);
        found[4] = params.metal_multiscatter(&tables, &m, wo);
        for (d, found) in found.iter_mut().take(3).enumerate() {
            let dir = Vec3::new(
                evaluated[3 * d][k],
                evaluated[3 * d + 1][k],
                evaluated[3 * d + 2][k],
            );
            *found = params.albedo_towards(&tables, &m, dir);
        }
        for a in 0..5 {
            for c in 0..3 {
                albedos[3 * a + c][k] = found[a][c];
            }
        }
    }
    // Stage 3: the bounce with them (no closure in the loop: LLVM may leave
    // one out of line, and a call keeps the loop scalar).
    for k in 0..W {
        let l = lane_in(k);
        let eo = Vec3::new(albedos[0][k], albedos[1][k], albedos[2][k]);
        let e_light = Vec3::new(albedos[3][k], albedos[4][k], albedos[5][k]);
        let e_sampled = Vec3::new(albedos[6][k], albedos[7][k], albedos[8][k]);
        let average = Vec3::new(albedos[9][k], albedos[10][k], albedos[11][k]);
        let ms = Vec3::new(albedos[12][k], albedos[13][k], albedos[14][k]);
        let staged = StagedPrincipledLane {
            lane: lane_numbers::<M>(&params, k),
            light: KnownAlbedos([eo, e_light, average, ms]),
            sampled: KnownAlbedos([eo, e_sampled, average, ms]),
        };
        let out = shade_lane::<_, TRIANGLES, CONES, ENV, ANISO>(l, staged, u);
        if owned[k] {
            put(k, l.hit, out);
        }
    }
}

/// Lane `k` of [`shade_staged_lanes`]'s parameters by component, as a lane
/// BSDF with the mode's idle data (its tables are not read there).
#[inline(always)]
pub(super) fn lane_numbers<M: PrincipledMode>(
    params: &[[f32; W]; 8],
    k: usize,
) -> PrincipledLane<M> {
    let p = PrincipledIn {
        metallic: params[0][k],
        roughness: params[1][k],
        specular: params[2][k],
        spec_tint: params[3][k],
        anisotropic: params[4][k],
        mode: M::IDLE,
    };
    PrincipledLane(p, Vec3::new(params[5][k], params[6][k], params[7][k]))
}

/// One bounce of every lane: reads the hits in `lanes.rays`, writes the
/// shadow rays to `lanes.shadow` and the next rays back to `lanes.rays`.
///
/// Each material kind is a pass of its own over the lanes ([`shade_chunks`]
/// with a [`MaterialPass`]), which reads the state of the lanes it shades and
/// writes back their results only, so the passes can run in any order (the
/// lanes without a hit end in [`end_missed_paths`]). Each pass is a function
/// of its own compiled for the instruction set `T` ([`InstructionSet::pass`]):
/// Lambert surfaces first (compiled for every combination of the scene's
/// light kinds), then every other kind the scene has
/// (compiled only for with or without emitting triangles and an
/// environment: the lanes' own flags select the rest; a kind's maps give its
/// lanes their parameters, [`ChunkMaps`]). Compiling each kind's pass once
/// per variant that matters, not inside every Lambert variant, is what keeps
/// the kernel's build time in bounds.
#[inline(always)]
pub(super) fn shade_lanes<T: InstructionSet>(kernel: &SoaScene, lanes: &mut SoaLanes, u: Uniform) {
    let lambert = LambertPass;
    if !kernel.all_lambert {
        end_missed_paths(lanes);
    }
    shade_lambert::<T>(&lambert, kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.conductor), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.schlick), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.coated), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.conductor_beckmann), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.schlick_beckmann), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.coated_beckmann), kernel, lanes, u);
    run_material_pass::<T, _>(&PrincipledPass(&kernel.principled), kernel, lanes, u);
    run_material_pass::<T, _>(&PrincipledPass(&kernel.principled_ec), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.blinn_phong), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.dielectric), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.dielectric_beckmann), kernel, lanes, u);
    run_material_pass::<T, _>(&KindPass(&kernel.smooth_dielectric), kernel, lanes, u);
    // Every ray starts at its origin and has no hit yet.
    lanes.rays.tnear.as_mut_slice().fill(0.0);
    lanes.rays.geom_id.as_mut_slice().fill(INVALID_ID);
    lanes.shadow.tnear.as_mut_slice().fill(0.0);
}

/// The Lambert pass of [`shade_lanes`], compiled for every combination of
/// light kinds. Like every other kind's, it is compiled with vertex normals
/// whether or not the scene has any (each lane's own flag selects the
/// frame): compiled without them, LLVM left the area-light variant's loop
/// scalar.
#[inline(always)]
pub(super) fn shade_lambert<T: InstructionSet>(
    pass: &LambertPass,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    match (
        kernel.triangle_lights,
        kernel.cones,
        kernel.environment.is_some(),
    ) {
        (true, true, true) => T::pass::<_, true, true, true>(pass, kernel, lanes, u),
        (true, true, false) => T::pass::<_, true, true, false>(pass, kernel, lanes, u),
        (true, false, true) => T::pass::<_, true, false, true>(pass, kernel, lanes, u),
        (true, false, false) => T::pass::<_, true, false, false>(pass, kernel, lanes, u),
        (false, _, true) => T::pass::<_, false, false, true>(pass, kernel, lanes, u),
        (false, _, false) => T::pass::<_, false, false, false>(pass, kernel, lanes, u),
    }
}

/// The pass of one material kind (nothing where the scene has none of it),
/// through the function compiled for instruction set `T` and the scene's
/// emitting triangles and environment.
#[inline(always)]
pub(super) fn run_material_pass<T: InstructionSet, P: MaterialPass>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    if !pass.any() {
        return;
    }
    match (kernel.triangle_lights, kernel.environment.is_some()) {
        (true, true) => T::pass::<P, true, true, true>(pass, kernel, lanes, u),
        (true, false) => T::pass::<P, true, true, false>(pass, kernel, lanes, u),
        (false, true) => T::pass::<P, false, false, true>(pass, kernel, lanes, u),
        (false, false) => T::pass::<P, false, false, false>(pass, kernel, lanes, u),
    }
}

/// Which lanes of a chunk one pass of [`shade_chunks`] shades, and its
/// loop over them.
pub(super) trait MaterialPass {
    /// What the loop takes of a chunk's lanes (their BSDFs' parameters).
    type Chunk;
    /// Whether the scene has any lane for this pass.
    fn any(&self) -> bool;
    /// The lanes of the chunk of `lanes` from `start` (their geometry ids
    /// `geom`, [`INVALID_ID`] for no hit) this pass shades and what its loop
    /// takes of them; `None` where it shades none (then the chunk is
    /// skipped).
    fn select(
        &self,
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: &[u32; W],
    ) -> Option<([bool; W], Self::Chunk)>;
    /// The loop: [`shade_lane`] for the chunk's lanes (`lane_in`), their
    /// results to `put`; `albedo` is each lane's albedo (linear RGB) and
    /// `aniso` whether a lane of the chunk has a tangent frame.
    #[allow(clippy::too_many_arguments)]
    fn shade<const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        &self,
        chunk: &Self::Chunk,
        albedo: &[[f32; W]; 3],
        aniso: bool,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    );
}

/// Lambert surfaces (and, where every surface is Lambert, the lanes
/// without a hit; elsewhere [`end_missed_paths`] ends those).
pub(super) struct LambertPass;

impl MaterialPass for LambertPass {
    type Chunk = ();

    fn any(&self) -> bool {
        true
    }

    #[inline(always)]
    fn select(
        &self,
        kernel: &SoaScene,
        _lanes: &SoaLanes,
        _start: usize,
        geom: &[u32; W],
    ) -> Option<([bool; W], ())> {
        if kernel.all_lambert {
            return Some(([true; W], ()));
        }
        let last = kernel.lambert.len() - 1;
        let owned: [bool; W] =
            std::array::from_fn(|k| kernel.lambert[(geom[k] as usize).min(last)]);
        owned.contains(&true).then_some((owned, ()))
    }

    #[inline(always)]
    fn shade<const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        &self,
        _: &(),
        albedo: &[[f32; W]; 3],
        _aniso: bool,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    ) {
        for k in 0..W {
            let l = lane_in(k);
            let bsdf = LambertLane(Vec3::new(albedo[0][k], albedo[1][k], albedo[2][k]));
            let out = shade_lane::<_, TRIANGLES, CONES, ENV, false>(l, bsdf, u);
            put(k, l.hit, out);
        }
    }
}

/// Ends the paths of the lanes without a hit: no next ray, no shadow ray
/// (what the other fields of such a lane hold is never read again).
#[inline(never)]
pub(super) fn end_missed_paths(lanes: &mut SoaLanes) {
    let geom = lanes.rays.geom_id.as_slice();
    let tfar = lanes.rays.tfar.as_mut_slice();
    let shadow_tfar = lanes.shadow.tfar.as_mut_slice();
    for ((&g, t), s) in geom.iter().zip(tfar).zip(shadow_tfar) {
        if g == INVALID_ID {
            *t = f32::NEG_INFINITY;
            *s = f32::NEG_INFINITY;
        }
    }
}

/// The lanes whose material is in one kind's table (rough Cook–Torrance
/// surfaces, one table per Fresnel term and distribution, Blinn–Phong
/// surfaces, rough and smooth dielectrics).
pub(super) struct KindPass<'a, B>(pub(super) &'a KindTable<B>);

impl<B: LaneKind + LaneBsdf> MaterialPass for KindPass<'_, B> {
    type Chunk = [Option<B>; W];

    fn any(&self) -> bool {
        self.0.any
    }

    #[inline(always)]
    fn select(
        &self,
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: &[u32; W],
    ) -> Option<([bool; W], [Option<B>; W])> {
        self.0.select(kernel, lanes, start, geom, B::MAPPABLE)
    }

    #[inline(always)]
    fn shade<const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        &self,
        bsdfs: &[Option<B>; W],
        _albedo: &[[f32; W]; 3],
        aniso: bool,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    ) {
        shade_kind::<B, TRIANGLES, CONES, ENV>(bsdfs, B::IDLE, aniso, lane_in, put, u);
    }
}

/// Principled surfaces in the mode `M`: their base colour is the lane's
/// albedo (so a base-colour map works).
pub(super) struct PrincipledPass<'a, M>(pub(super) &'a KindTable<PrincipledIn<M>>);

impl<M: PrincipledMode> MaterialPass for PrincipledPass<'_, M> {
    type Chunk = [Option<PrincipledIn<M>>; W];

    fn any(&self) -> bool {
        self.0.any
    }

    #[inline(always)]
    fn select(
        &self,
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: &[u32; W],
    ) -> Option<([bool; W], [Option<PrincipledIn<M>>; W])> {
        self.0
            .select(kernel, lanes, start, geom, PrincipledIn::<M>::MAPPABLE)
    }

    #[inline(always)]
    fn shade<const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        &self,
        params: &[Option<PrincipledIn<M>>; W],
        albedo: &[[f32; W]; 3],
        aniso: bool,
        lane_in: &impl Fn(usize) -> LaneIn,
        put: &mut impl FnMut(usize, bool, LaneOut),
        u: Uniform,
    ) {
        let principled = std::array::from_fn(|k| {
            let colour = Vec3::new(albedo[0][k], albedo[1][k], albedo[2][k]);
            params[k].map(|p| PrincipledLane(p, colour))
        });
        let idle = PrincipledLane(PrincipledIn::IDLE, Vec3::splat(0.5));
        shade_kind::<_, TRIANGLES, CONES, ENV>(&principled, idle, aniso, lane_in, put, u);
    }
}

/// One pass of [`shade_lanes`]: the lanes `pass` selects, in chunks of
/// [`W`] copied into local arrays (locals cannot alias each other, so the
/// compiler vectorises the chunk's loop without run-time overlap checks,
/// which it could not generate for some thirty lane arrays and a table
/// lookup), for scenes with (`TRIANGLES`) or without emitting triangles,
/// with (`CONES`) or without emission cones among them, and with (`ENV`) or
/// without an environment (vertex normals: each lane's own flag).
/// Only the selected lanes' results are written back ([`ChunkOut::store`]).
#[inline(always)]
pub(super) fn shade_chunks<
    P: MaterialPass,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    let n = lanes.rays.len();
    // One light: the same for every lane, so no per-lane arrays.
    let single = kernel.single_light.map(LightChunk::splat);
    for start in (0..n).step_by(W) {
        let geom = load_or(lanes.rays.geom_id.as_slice(), start, INVALID_ID);
        let Some((owned, chunk)) = pass.select(kernel, lanes, start, &geom) else {
            continue;
        };
        let c = ChunkIn::load::<TRIANGLES, ENV>(kernel, lanes, start, geom);
        let loaded;
        let lights = match &single {
            Some(chunk) => chunk,
            None => {
                loaded =
                    LightChunk::load(&kernel.light_table, &lanes.light, &lanes.light_pmf, start);
                &loaded
            }
        };
        let aniso = c.tangent_valid.contains(&true);
        let mut out = ChunkOut::starting_from(&c);
        // Each lane's input to `shade_lane` (the state loaded above, before
        // any loop below changed it).
        let lane_in = |k: usize| c.lane(k, lights.lane(k));
        // Lane `k`'s results into the chunk's outputs; behind a one-sided
        // surface, the path ends with nothing from this bounce.
        let mut put = |k: usize, hit: bool, mut o: LaneOut| {
            if c.black[k] {
                o.alive = false;
                o.shadow = false;
            }
            out.put::<TRIANGLES, ENV>(k, hit, o)
        };
        pass.shade::<TRIANGLES, CONES, ENV>(&chunk, &c.albedo, aniso, &lane_in, &mut put, u);
        out.store::<TRIANGLES, ENV>(lanes, start, &owned);
    }
}

/// One chunk's state, loaded from the lane arrays: what `shade_lane`
/// reads. The environment's and the previous vertex's are loaded only
/// where the scene needs them (`ENV`, `TRIANGLES`), the shading normals
/// and tangents only where some material has them.
struct ChunkIn {
    geom: [u32; W],
    org: [[f32; W]; 3],
    dir: [[f32; W]; 3],
    t: [f32; W],
    ng: [[f32; W]; 3],
    albedo: [[f32; W]; 3],
    beta: [[f32; W]; 3],
    rng: [u32; W],
    stream: [SampleStream; W],
    eta_scale: [f32; W],
    ns: [[f32; W]; 3],
    ns_valid: [bool; W],
    tangent: [[f32; W]; 3],
    tangent_valid: [bool; W],
    env_valid: [bool; W],
    env_wi: [[f32; W]; 3],
    env_radiance: [[f32; W]; 3],
    env_pdf: [f32; W],
    prev_pdf: [f32; W],
    prev_point: [[f32; W]; 3],
    /// Whether each lane hit the back of a one-sided surface, which is
    /// black: its path ends there.
    black: [bool; W],
}

impl ChunkIn {
    #[inline(always)]
    fn load<const TRIANGLES: bool, const ENV: bool>(
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: [u32; W],
    ) -> ChunkIn {
        let rays = &lanes.rays;
        let org = [
            load(rays.org_x.as_slice(), start),
            load(rays.org_y.as_slice(), start),
            load(rays.org_z.as_slice(), start),
        ];
        let dir = [
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        ];
        let t = load(rays.tfar.as_slice(), start);
        let ng = [
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        ];
        let mut albedo = [[0.0f32; W]; 3];
        if kernel.any_textured {
            for (c, albedo) in albedo.iter_mut().enumerate() {
                *albedo = load(&lanes.albedo[c], start);
            }
        } else {
            let last = kernel.albedo[0].len() - 1;
            for k in 0..W {
                let g = (geom[k] as usize).min(last);
                for (c, albedo) in albedo.iter_mut().enumerate() {
                    albedo[k] = kernel.albedo[c][g];
                }
            }
        }
        let beta = [
            load(&lanes.beta[0], start),
            load(&lanes.beta[1], start),
            load(&lanes.beta[2], start),
        ];
        let (mut ns, mut ns_valid) = ([[0.0f32; W]; 3], [false; W]);
        if kernel.any_smooth {
            ns_valid = load(&lanes.ns_valid, start);
            for c in 0..3 {
                ns[c] = load(&lanes.ns[c], start);
            }
        }
        let (mut tangent, mut tangent_valid) = ([[0.0f32; W]; 3], [false; W]);
        if kernel.any_anisotropic {
            tangent_valid = load(&lanes.tangent_valid, start);
            for c in 0..3 {
                tangent[c] = load(&lanes.tangent[c], start);
            }
        }
        let (mut env_valid, mut env_wi, mut env_radiance, mut env_pdf) =
            ([false; W], [[0.0f32; W]; 3], [[0.0f32; W]; 3], [0.0f32; W]);
        if ENV {
            env_valid = load(&lanes.env_valid, start);
            env_pdf = load(&lanes.env_pdf, start);
            for c in 0..3 {
                env_wi[c] = load(&lanes.env_wi[c], start);
                env_radiance[c] = load(&lanes.env_radiance[c], start);
            }
        }
        let mut black = [false; W];
        if kernel.any_one_sided {
            let last = kernel.one_sided.len() - 1;
            for k in 0..W {
                let g = (geom[k] as usize).min(last);
                let ng = Vec3::new(ng[0][k], ng[1][k], ng[2][k]);
                let dir = Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
                // As `Material::black_from` decides it for the general
                // integrator.
                black[k] = kernel.one_sided[g] && ng.dot(dir) > 0.0;
            }
        }
        let (mut prev_pdf, mut prev_point) = ([0.0f32; W], [[0.0f32; W]; 3]);
        if TRIANGLES || ENV {
            prev_pdf = load(&lanes.prev_pdf, start);
            for c in 0..3 {
                prev_point[c] = load(&lanes.prev_point[c], start);
            }
        }
        ChunkIn {
            geom,
            org,
            dir,
            t,
            ng,
            albedo,
            beta,
            rng: load(&lanes.rng_dim, start),
            stream: load_streams(&lanes.rng_stream, start),
            eta_scale: load(&lanes.eta_scale, start),
            ns,
            ns_valid,
            tangent,
            tangent_valid,
            env_valid,
            env_wi,
            env_radiance,
            env_pdf,
            prev_pdf,
            prev_point,
            black,
        }
    }

    /// Lane `k`'s input to `shade_lane`, with its light sample `light`.
    #[inline(always)]
    fn lane(&self, k: usize, light: LightIn) -> LaneIn {
        let v = |a: &[[f32; W]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        LaneIn {
            org: v(&self.org),
            dir: v(&self.dir),
            t: self.t[k],
            ng: v(&self.ng),
            hit: self.geom[k] != INVALID_ID,
            ns: v(&self.ns),
            smooth: self.ns_valid[k],
            tangent: v(&self.tangent),
            anisotropic: self.tangent_valid[k],
            beta: v(&self.beta),
            eta_scale: self.eta_scale[k],
            rng: self.rng[k],
            stream: self.stream[k],
            light,
            env_valid: self.env_valid[k],
            env_wi: v(&self.env_wi),
            env_radiance: v(&self.env_radiance),
            env_pdf: self.env_pdf[k],
        }
    }
}

/// One chunk's results: the path state `shade_lane` changes and the rays
/// it spawns, written back for the lanes the pass owns.
struct ChunkOut {
    rng: [u32; W],
    eta_scale: [f32; W],
    beta: [[f32; W]; 3],
    prev_pdf: [f32; W],
    prev_point: [[f32; W]; 3],
    pending: [[f32; W]; 3],
    /// The next ray: origin x, y, z, direction x, y, z.
    next: [[f32; W]; 6],
    next_tfar: [f32; W],
    /// The shadow ray: origin x, y, z, direction x, y, z.
    shadow_ray: [[f32; W]; 6],
    shadow_tfar: [f32; W],
}

impl ChunkOut {
    /// The outputs before shading: the path state as loaded (a lane without
    /// a hit keeps it), no rays.
    #[inline(always)]
    fn starting_from(c: &ChunkIn) -> ChunkOut {
        ChunkOut {
            rng: c.rng,
            eta_scale: c.eta_scale,
            beta: c.beta,
            prev_pdf: c.prev_pdf,
            prev_point: c.prev_point,
            pending: [[0.0f32; W]; 3],
            next: [[0.0f32; W]; 6],
            next_tfar: [f32::NEG_INFINITY; W],
            shadow_ray: [[0.0f32; W]; 6],
            shadow_tfar: [f32::NEG_INFINITY; W],
        }
    }

    /// Lane `k`'s results (`hit`: whether its ray hit something).
    #[inline(always)]
    fn put<const TRIANGLES: bool, const ENV: bool>(&mut self, k: usize, hit: bool, out: LaneOut) {
        // A lane without a hit keeps its state: its path has ended.
        if hit {
            self.rng[k] = out.rng;
            self.eta_scale[k] = out.eta_scale;
            for c in 0..3 {
                self.beta[c][k] = out.beta[c];
            }
        }
        // Only emission found later needs them (for its MIS weight).
        if (TRIANGLES || ENV) && hit {
            self.prev_pdf[k] = out.pdf;
            for c in 0..3 {
                self.prev_point[c][k] = out.point[c];
            }
        }
        for c in 0..3 {
            self.pending[c][k] = out.pending[c];
            self.shadow_ray[c][k] = out.shadow_org[c];
            self.shadow_ray[3 + c][k] = out.shadow_dir[c];
            self.next[c][k] = out.next_org[c];
            self.next[3 + c][k] = out.next_dir[c];
        }
        self.shadow_tfar[k] = if out.shadow {
            out.shadow_tfar
        } else {
            f32::NEG_INFINITY
        };
        self.next_tfar[k] = if out.alive {
            f32::INFINITY
        } else {
            f32::NEG_INFINITY
        };
    }

    /// The owned lanes' results back into the lane arrays (the other lanes'
    /// are another pass's).
    #[inline(always)]
    fn store<const TRIANGLES: bool, const ENV: bool>(
        &self,
        lanes: &mut SoaLanes,
        start: usize,
        owned: &[bool; W],
    ) {
        let all = *owned == [true; W];
        store_owned(&mut lanes.rng_dim, start, &self.rng, owned, all);
        store_owned(&mut lanes.eta_scale, start, &self.eta_scale, owned, all);
        if TRIANGLES || ENV {
            store_owned(&mut lanes.prev_pdf, start, &self.prev_pdf, owned, all);
            for c in 0..3 {
                store_owned(
                    &mut lanes.prev_point[c],
                    start,
                    &self.prev_point[c],
                    owned,
                    all,
                );
            }
        }
        for c in 0..3 {
            store_owned(&mut lanes.beta[c], start, &self.beta[c], owned, all);
            store_owned(&mut lanes.pending[c], start, &self.pending[c], owned, all);
        }
        let (rays, shadow) = (&mut lanes.rays, &mut lanes.shadow);
        for (dst, src) in [
            (&mut rays.org_x, &self.next[0]),
            (&mut rays.org_y, &self.next[1]),
            (&mut rays.org_z, &self.next[2]),
            (&mut rays.dir_x, &self.next[3]),
            (&mut rays.dir_y, &self.next[4]),
            (&mut rays.dir_z, &self.next[5]),
            (&mut rays.tfar, &self.next_tfar),
            (&mut shadow.org_x, &self.shadow_ray[0]),
            (&mut shadow.org_y, &self.shadow_ray[1]),
            (&mut shadow.org_z, &self.shadow_ray[2]),
            (&mut shadow.dir_x, &self.shadow_ray[3]),
            (&mut shadow.dir_y, &self.shadow_ray[4]),
            (&mut shadow.dir_z, &self.shadow_ray[5]),
            (&mut shadow.tfar, &self.shadow_tfar),
        ] {
            store_owned(dst.as_mut_slice(), start, src, owned, all);
        }
    }
}
