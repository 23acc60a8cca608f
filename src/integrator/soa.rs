//! The vectorised wavefront that renders every scene. Every BSDF model is
//! shaded in a branch-free loop of its own over structure-of-arrays lanes
//! ([`LaneBsdf`]): Lambert surfaces (their colour textured or not),
//! rough Cook–Torrance surfaces (GGX or Beckmann, isotropic or not, with a
//! conductor's, Schlick's or a dielectric coating's Fresnel term, their
//! roughness mapped or not), principled surfaces (Mitsuba's mode or the
//! energy-conserving one; base colour, roughness and metallic mapped or
//! not), Blinn–Phong surfaces (their colour mapped or not), rough
//! dielectrics (GGX or Beckmann) and smooth dielectrics; a map's values are
//! looked up per lane ([`mapped_params`]), and every kind takes vertex
//! normals and normal maps. They are lit by point lights, emissive meshes
//! (area lights), parametric lights (emitting triangles with a cone, picked
//! only where their cone reaches) and an environment (an
//! importance-sampled panorama or a constant sky; its samples and the
//! lookups of rays that leave the scene are taken for all lanes at once,
//! with the batched lookups the general integrator uses); virtual objects
//! (compositing) included: the job's ray mask on every ray, and their
//! coverage counted in the matte.
//!
//! It computes what the general integrator ([`super::render_tile`])
//! computes, in the same floating-point operations in the same order, with
//! the same random numbers; Rust never contracts `a·b + c` into a fused
//! multiply-add, so every lane rounds exactly as the scalar code does and
//! the images are bit-identical (tested in `tests/vectorised.rs`). One
//! assumption lies outside plsr: that Embree returns the same hit for the
//! same ray whether it traces it alone (the general integrator's
//! `rtcIntersect1M`) or in a packet of a structure-of-arrays stream (the
//! kernel's `rtcIntersectNp`); Embree does not promise it, and every test
//! confirms it. What
//! differs is the layout: the paths of a tile live in structure-of-arrays
//! lanes ([`RayBatch`] and the arrays of [`SoaLanes`]), and one bounce of
//! all of them is a single loop without branches (`shade_lane` per lane),
//! which the compiler turns into AVX-512 or AVX2 code, picked at run time.
//! Rays go to Embree as SoA streams (`rtcIntersectNp`, `rtcOccludedNp`).
//!
//! [`SoaScene::new`] prepares any scene for it; the general integrator
//! stays as the reference (`plsr render --scalar`), and renders a scene
//! only where a material is one no pass shades (none is today).

// Lane loops index a dozen arrays by lane; iterator chains would hide that.
#![allow(clippy::needless_range_loop)]

use super::spawn::{ray_epsilon, shadow_segment, spawn_origin};
use super::{
    camera_sample, emission_weight, environment_weight, roulette, roulette_spins,
    shading_normal_towards, sides_agree, PixelSums, PrevVertex, RayStats, Tile,
};
use crate::accel::{gather_lanes, RayBatch, INVALID_ID};
use crate::bsdf::albedo::EnergyTables;
use crate::bsdf::models::KnownAlbedos;
use crate::bsdf::{
    lambert_eval, lambert_pdf, lambert_sample, BlinnPhongParams, Bsdf, BsdfSample,
    CookTorranceParams, DielectricParams, Distribution, Fresnel, Microfacet, PrincipledParams,
};
use crate::camera::{Camera, PinholeCamera};
use crate::filter::PixelFilter;
use crate::job::RenderJob;
use crate::light::pls::SoftEdge;
use crate::light::{point_light_sample, Cone, Light, LightSample, TrianglePoint};
use crate::prefetch::prefetch;
use crate::sampler::{PathSampler, SampleStream};
use crate::scene::Scene;
use crate::warp::{power_heuristic, Frame};
use glam::{Vec2, Vec3};
use std::marker::PhantomData;
use std::time::Instant;

/// What the vectorised kernel needs of a scene it can render.
#[derive(Debug, Clone)]
pub struct SoaScene {
    /// Lambert albedo per Embree geometry id (linear RGB, one array per
    /// channel), with one extra zero entry that lanes without a hit read.
    albedo: [Vec<f32>; 3],
    /// Whether each geometry (by Embree id) emits, with one extra `false`.
    emissive: Vec<bool>,
    /// Whether each geometry's material is textured (then `albedo` holds
    /// its colour where the texture gives none), with one extra `false`.
    textured: Vec<bool>,
    /// Whether any geometry's is (then each lane's albedo is looked up by
    /// `lane_surfaces` into `SoaLanes::albedo`).
    any_textured: bool,
    /// Whether each geometry's material has a map that changes its BSDF's
    /// parameters beside its colour (a roughness or metallic map, or a
    /// Blinn–Phong colour map: [`mapped_params`]), with one extra `false`.
    mapped: Vec<bool>,
    /// Whether any geometry's has (then `lane_surfaces` looks up each such
    /// lane's parameters into `SoaLanes::mapped`).
    any_mapped: bool,
    /// Whether each geometry's material is Lambert (shaded in the first
    /// vectorised loop), with one extra `false`.
    lambert: Vec<bool>,
    /// Whether every geometry's is.
    all_lambert: bool,
    /// Rough Cook–Torrance surfaces (GGX or Beckmann, isotropic or not,
    /// roughness-mapped or not), one table per Fresnel term and distribution:
    /// each a loop of its own. Every table's entries are what the kind's
    /// [`LaneKind::of`] takes of the geometry's material.
    conductor: KindTable<CookTorranceIn<ConductorTerm, Ggx>>,
    schlick: KindTable<CookTorranceIn<SchlickTerm, Ggx>>,
    coated: KindTable<CookTorranceIn<CoatingTerm, Ggx>>,
    conductor_beckmann: KindTable<CookTorranceIn<ConductorTerm, Beckmann>>,
    schlick_beckmann: KindTable<CookTorranceIn<SchlickTerm, Beckmann>>,
    coated_beckmann: KindTable<CookTorranceIn<CoatingTerm, Beckmann>>,
    /// Principled surfaces in Mitsuba's mode and in the energy-conserving
    /// one, mapped or not ([`PrincipledIn`]).
    principled: KindTable<PrincipledIn<MitsubaMode>>,
    principled_ec: KindTable<PrincipledIn<EnergyConserving>>,
    /// Rough dielectrics, GGX or Beckmann ([`DielectricIn`]).
    dielectric: KindTable<DielectricIn<Ggx>>,
    dielectric_beckmann: KindTable<DielectricIn<Beckmann>>,
    /// Smooth dielectrics (see [`SmoothDielectricIn`]).
    smooth_dielectric: KindTable<SmoothDielectricIn>,
    /// Blinn–Phong surfaces, colour-mapped or not ([`BlinnPhongIn`]).
    blinn_phong: KindTable<BlinnPhongIn>,
    /// Whether each geometry's material transmits light (its normal layer
    /// records the geometric normal), with one extra `false`.
    transmits: Vec<bool>,
    /// Whether any geometry's does.
    any_transmits: bool,
    /// Whether each geometry (by Embree id) is a virtual object (inserted
    /// into a photograph; counted in the compositing matte), with one extra
    /// `false`.
    is_virtual: Vec<bool>,
    /// Whether each geometry's material is anisotropic
    /// ([`crate::material::Material::is_anisotropic`]: its lanes need a
    /// tangent), with one extra
    /// `false`.
    anisotropic: Vec<bool>,
    /// Whether any geometry's is (then `lane_surfaces` looks up each such
    /// lane's tangent into `SoaLanes::tangent`).
    any_anisotropic: bool,
    /// Whether each geometry (by Embree id) has shading normals (vertex
    /// normals, or a normal-mapped material and texture coordinates), with
    /// one extra `false`.
    smooth: Vec<bool>,
    /// Whether any geometry has (then each lane's interpolated normal is
    /// looked up by `lane_surfaces` into `SoaLanes::ns`).
    any_smooth: bool,
    /// The one light, when there is exactly one, with the probability of
    /// picking it: the same for every lane.
    single_light: Option<LightIn>,
    /// Each light of the scene as a lane takes it (with no pick
    /// probability), and last an entry for no light at all.
    light_table: Vec<LightIn>,
    /// The environment light (index into the scene's lights), if any.
    environment: Option<usize>,
    /// Whether any light is an emitting triangle.
    triangle_lights: bool,
    /// Whether any light is an emitting triangle with a cone (a parametric
    /// light).
    cones: bool,
}

impl SoaScene {
    /// The kernel's view of `scene`, or `None` where a material of it is one
    /// no pass of the kernel shades (none is today: every BSDF model, mapped
    /// or not, has a pass; the general integrator then renders the scene).
    pub fn new(scene: &Scene) -> Option<SoaScene> {
        let mut albedo = [Vec::new(), Vec::new(), Vec::new()];
        let mut emissive = Vec::new();
        let mut textured = Vec::new();
        let mut mapped = Vec::new();
        let mut transmits = Vec::new();
        let mut smooth = Vec::new();
        let mut anisotropic = Vec::new();
        let mut is_virtual = Vec::new();
        let conductor = KindTable::new(scene);
        let schlick = KindTable::new(scene);
        let coated = KindTable::new(scene);
        let conductor_beckmann = KindTable::new(scene);
        let schlick_beckmann = KindTable::new(scene);
        let coated_beckmann = KindTable::new(scene);
        let principled = KindTable::new(scene);
        let principled_ec = KindTable::new(scene);
        let dielectric = KindTable::new(scene);
        let dielectric_beckmann = KindTable::new(scene);
        let smooth_dielectric = KindTable::new(scene);
        let blinn_phong = KindTable::new(scene);
        let mut lambert = Vec::new();
        for (g, mesh) in scene.meshes().iter().enumerate() {
            let material = &scene.materials()[mesh.material as usize];
            // Shading normals: interpolated, or from a normal map.
            let normal_mapped = material.textures.normal.is_some() && !mesh.uvs.is_empty();
            smooth.push(!mesh.normals.is_empty() || normal_mapped);
            is_virtual.push(mesh.is_virtual);
            // Lambert's albedo is its reflectance; for the other models it
            // is what the albedo layer records.
            let a = material.bsdf.albedo();
            for (c, albedo) in albedo.iter_mut().enumerate() {
                albedo.push(a[c]);
            }
            let l = matches!(material.bsdf, Bsdf::Diffuse(_));
            lambert.push(l);
            let vectorised = l
                || conductor.covers(g)
                || schlick.covers(g)
                || coated.covers(g)
                || conductor_beckmann.covers(g)
                || schlick_beckmann.covers(g)
                || coated_beckmann.covers(g)
                || principled.covers(g)
                || principled_ec.covers(g)
                || dielectric.covers(g)
                || dielectric_beckmann.covers(g)
                || smooth_dielectric.covers(g)
                || blinn_phong.covers(g);
            if !vectorised {
                return None;
            }
            transmits.push(material.bsdf.transmits());
            anisotropic.push(material.is_anisotropic());
            emissive.push(scene.light_index(g as u32, 0).is_some());
            textured.push(!material.textures.is_empty());
            let t = &material.textures;
            mapped.push(match material.bsdf {
                Bsdf::CookTorrance(_) => t.roughness.is_some(),
                Bsdf::Principled(_) => t.roughness.is_some() || t.metallic.is_some(),
                Bsdf::BlinnPhong(_) => t.base_color.is_some(),
                Bsdf::Diffuse(_) | Bsdf::Dielectric(_) => false,
            });
        }
        for a in &mut albedo {
            a.push(0.0);
        }
        emissive.push(false);
        textured.push(false);
        mapped.push(false);
        let all_lambert = lambert.iter().all(|&l| l);
        lambert.push(false);
        transmits.push(false);
        smooth.push(false);
        anisotropic.push(false);
        is_virtual.push(false);
        let lights = scene.lights();
        // One light picked the same way everywhere: the same for every lane.
        let single_light = match lights.lights.as_slice() {
            [l] if lights.is_spatially_uniform() => lights
                .pick(Vec3::ZERO, Vec2::splat(0.5))
                .filter(|&(first, _)| first == 0)
                .map(|(_, pmf)| LightIn::new(l, pmf)),
            _ => None,
        };
        let triangle = |l: &Light| matches!(l, Light::Triangle(_));
        let cone = |l: &Light| matches!(l, Light::Triangle(t) if t.cone.is_some());
        let mut light_table: Vec<LightIn> =
            lights.lights.iter().map(|l| LightIn::new(l, 0.0)).collect();
        light_table.push(LightIn::default());
        Some(SoaScene {
            albedo,
            emissive,
            any_textured: textured.contains(&true),
            textured,
            any_mapped: mapped.contains(&true),
            mapped,
            conductor,
            schlick,
            coated,
            conductor_beckmann,
            schlick_beckmann,
            coated_beckmann,
            principled,
            principled_ec,
            dielectric,
            dielectric_beckmann,
            smooth_dielectric,
            blinn_phong,
            lambert,
            all_lambert,
            any_transmits: transmits.contains(&true),
            transmits,
            any_smooth: smooth.contains(&true),
            smooth,
            any_anisotropic: anisotropic.contains(&true),
            anisotropic,
            is_virtual,
            single_light,
            light_table,
            environment: scene.environment_index(),
            triangle_lights: lights.lights.iter().any(triangle),
            cones: lights.lights.iter().any(cone),
        })
    }
}

/// A material kind the kernel shades in a vectorised loop of its own: the
/// parameters a lane of that kind takes.
trait LaneKind: Copy {
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

/// The BSDF parameters a textured material's maps give at a hit, packed for
/// [`LaneKind::with_maps`] from the material's
/// [`crate::material::Material::bsdf_at`] there: a Cook–Torrance surface's
/// `[α_x, α_y, 0]`, a principled surface's `[roughness, metallic, 0]`, a
/// Blinn–Phong surface's diffuse colour (linear RGB); zeros for the models
/// no map changes (a base colour map of Lambert or principled surfaces is
/// the lane's albedo instead).
#[inline]
fn mapped_params(bsdf: &Bsdf) -> [f32; 3] {
    match bsdf {
        Bsdf::CookTorrance(p) => [p.microfacet.alpha_x, p.microfacet.alpha_y, 0.0],
        Bsdf::Principled(p) => [p.roughness, p.metallic, 0.0],
        Bsdf::BlinnPhong(p) => p.diffuse.to_array(),
        Bsdf::Diffuse(_) | Bsdf::Dielectric(_) => [0.0; 3],
    }
}

/// The BSDF parameters a chunk's lanes take from their materials' maps
/// (`SoaLanes::mapped`).
struct ChunkMaps {
    /// Whether the lane's material has a map [`mapped_params`] packs (else
    /// its values are unused).
    mapped: [bool; W],
    /// The lanes' [`mapped_params`], one array per component.
    values: [[f32; W]; 3],
}

impl ChunkMaps {
    /// The maps of the chunk of `lanes` from `start` (geometry ids `geom`),
    /// `None` where no lane of it has one.
    #[inline(always)]
    fn load(kernel: &SoaScene, lanes: &SoaLanes, start: usize, geom: &[u32; W]) -> Option<Self> {
        let last = kernel.mapped.len() - 1;
        let mapped: [bool; W] =
            std::array::from_fn(|k| kernel.mapped[(geom[k] as usize).min(last)]);
        mapped.contains(&true).then(|| ChunkMaps {
            mapped,
            values: [
                load(&lanes.mapped[0], start),
                load(&lanes.mapped[1], start),
                load(&lanes.mapped[2], start),
            ],
        })
    }

    /// Lane `k`'s [`mapped_params`].
    #[inline(always)]
    fn lane(&self, k: usize) -> [f32; 3] {
        [self.values[0][k], self.values[1][k], self.values[2][k]]
    }
}

/// Each geometry's material of kind `K` (by Embree id) where it is one,
/// with one extra `None` that lanes without a hit read.
#[derive(Debug, Clone)]
struct KindTable<K> {
    by_geometry: Vec<Option<K>>,
    /// Whether any geometry's material is of this kind.
    any: bool,
}

impl<K: LaneKind> KindTable<K> {
    /// The table of `scene`'s geometries.
    fn new(scene: &Scene) -> KindTable<K> {
        let mut by_geometry: Vec<Option<K>> = scene
            .meshes()
            .iter()
            .map(|mesh| K::of(&scene.materials()[mesh.material as usize]))
            .collect();
        by_geometry.push(None);
        let any = by_geometry.iter().any(Option::is_some);
        KindTable { by_geometry, any }
    }

    /// Whether geometry `g`'s material is of this kind.
    fn covers(&self, g: usize) -> bool {
        self.by_geometry[g].is_some()
    }

    /// The parameters of a chunk's lanes, by their geometry ids
    /// ([`INVALID_ID`] for no hit), with those their maps give where `maps`
    /// has them.
    #[inline(always)]
    fn chunk(&self, geom: &[u32; W], maps: Option<&ChunkMaps>) -> [Option<K>; W] {
        let last = self.by_geometry.len() - 1;
        let mut chunk = std::array::from_fn(|k| self.by_geometry[(geom[k] as usize).min(last)]);
        if let Some(maps) = maps {
            for (k, lane) in chunk.iter_mut().enumerate() {
                if maps.mapped[k] {
                    *lane = lane.map(|p| p.with_maps(maps.lane(k)));
                }
            }
        }
        chunk
    }

    /// [`ChunkPass::select`] for a kind whose lanes take their parameters
    /// from this table: the chunk's lanes of this kind and their parameters
    /// (with their maps' values where `mappable` and the scene has maps), or
    /// `None` where the chunk has none.
    #[inline(always)]
    fn select(
        &self,
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: &[u32; W],
        mappable: bool,
    ) -> Option<([bool; W], [Option<K>; W])> {
        let maps = (mappable && kernel.any_mapped)
            .then(|| ChunkMaps::load(kernel, lanes, start, geom))
            .flatten();
        let params = self.chunk(geom, maps.as_ref());
        let owned = params.map(|p| p.is_some());
        owned.contains(&true).then_some((owned, params))
    }
}

/// A microfacet distribution's kind known to the compiler ([`Ggx`] or
/// [`Beckmann`]), so that a lane loop has no branch on it.
trait LaneDistribution: Copy + PartialEq + std::fmt::Debug {
    /// The distribution.
    const KIND: Distribution;
}

/// Trowbridge–Reitz (GGX) microfacets.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Ggx;

impl LaneDistribution for Ggx {
    const KIND: Distribution = Distribution::Ggx;
}

/// Beckmann microfacets.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Beckmann;

impl LaneDistribution for Beckmann {
    const KIND: Distribution = Distribution::Beckmann;
}

/// The Fresnel term of a Cook–Torrance lane, its kind known to the
/// compiler (so the lane loop has no branch on it): [`ConductorTerm`],
/// [`SchlickTerm`] or [`CoatingTerm`], one loop each.
trait LaneFresnel: Copy + PartialEq + std::fmt::Debug {
    /// A term for lanes of other materials (their results are discarded).
    const IDLE: Self;
    /// The term, if `fresnel` is of this kind.
    fn of(fresnel: Fresnel) -> Option<Self>;
    /// The term exactly as the general integrator holds it.
    fn fresnel(&self) -> Fresnel;
}

/// A conductor's Fresnel term ([`Fresnel::Conductor`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct ConductorTerm {
    /// Complex index of refraction, real part, per RGB channel.
    eta: Vec3,
    /// Its imaginary part.
    k: Vec3,
    /// Mitsuba's `specular_reflectance` tint.
    tint: Vec3,
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
struct SchlickTerm(Vec3);

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
struct CoatingTerm(f32);

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
struct CookTorranceIn<F, D> {
    /// Roughness α along the first and the second tangent.
    alpha_x: f32,
    alpha_y: f32,
    /// The Fresnel term.
    fresnel: F,
    /// The distribution's kind.
    distribution: PhantomData<D>,
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
    fn params(&self) -> CookTorranceParams {
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

/// The BSDF of a lane in [`shade_lane`]: the same evaluation, density and
/// sampling as the general integrator's [`Bsdf`] for that model.
trait LaneBsdf: Copy {
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
fn lane_sample(sample: Option<BsdfSample>) -> (bool, Vec3, f32, Vec3) {
    match sample {
        Some(s) => (true, s.wi, s.pdf, s.weight),
        None => (false, Vec3::Z, 0.0, Vec3::ZERO),
    }
}

/// A Lambert surface's lane BSDF: its albedo.
#[derive(Clone, Copy)]
struct LambertLane(Vec3);

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

/// Which mode of the principled BSDF a loop shades, known to the compiler:
/// Mitsuba's ([`MitsubaMode`], nothing to carry) or the energy-conserving
/// one ([`EnergyConserving`], which carries its albedo table).
trait PrincipledMode: Copy + std::fmt::Debug {
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
struct MitsubaMode;

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
struct EnergyConserving(EnergyTables);

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
struct PrincipledIn<M> {
    /// Metallic blend in [0, 1].
    metallic: f32,
    /// Roughness in [0, 1].
    roughness: f32,
    /// Specular in [0, 1] (sets η).
    specular: f32,
    /// Specular tint in [0, 1].
    spec_tint: f32,
    /// Anisotropy in [0, 1].
    anisotropic: f32,
    /// What the mode carries.
    mode: M,
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
struct PrincipledLane<M>(PrincipledIn<M>, Vec3);

impl<M: PrincipledMode> PrincipledLane<M> {
    /// The parameters exactly as the general integrator holds them (the
    /// mode known to the compiler, so the lane loop has no branch on it).
    #[inline(always)]
    fn params(&self) -> PrincipledParams {
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
struct PrincipledProbe<M>(PrincipledLane<M>);

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
struct StagedPrincipledLane<M> {
    lane: PrincipledLane<M>,
    light: KnownAlbedos,
    sampled: KnownAlbedos,
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

/// A rough dielectric's parameters as a lane takes them: microfacet
/// reflection and transmission (Walter et al. 2007) with a distribution of
/// kind `D`, isotropic or not. Smooth dielectrics have a loop of their own
/// ([`SmoothDielectricIn`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct DielectricIn<D> {
    /// Relative index of refraction, inside over outside.
    eta: f32,
    /// Roughness α along the first and the second tangent.
    alpha_x: f32,
    alpha_y: f32,
    /// The distribution's kind.
    distribution: PhantomData<D>,
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
    fn params(&self) -> DielectricParams {
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

/// A smooth dielectric as a lane takes it (glass, water): mirror reflection
/// with probability F and refraction otherwise, both delta lobes
/// ([`LaneBsdf::DELTA`]).
#[derive(Debug, Clone, Copy, PartialEq)]
struct SmoothDielectricIn {
    /// Relative index of refraction, inside over outside.
    eta: f32,
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
    fn params(&self) -> DielectricParams {
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

/// A Blinn–Phong surface's parameters as a lane takes them: exactly the
/// general integrator's.
#[derive(Debug, Clone, Copy, PartialEq)]
struct BlinnPhongIn(BlinnPhongParams);

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

/// One lane's light for a light sample: a point light or an emitting
/// triangle (with the cone of a parametric light, if it has one), and the
/// probability it was picked with.
#[derive(Debug, Clone, Copy)]
struct LightIn {
    /// Whether a light was picked: picking fails where no light can reach
    /// the shading point (a parametric light's cone), and the lane then
    /// takes no light sample.
    picked: bool,
    /// An emitting triangle (else a point light or the environment).
    triangle: bool,
    /// The environment (its sample is taken per lane by `pick_lights`).
    environment: bool,
    /// The triangle emits on both sides.
    two_sided: bool,
    /// The triangle's vertices; the point light's position is `p[0]`.
    p: [Vec3; 3],
    /// The triangle's unit normal.
    n: Vec3,
    /// The triangle's area.
    area: f32,
    /// The triangle's radiance or the point light's intensity.
    emit: Vec3,
    /// Probability of picking this light.
    pmf: f32,
    /// The triangle emits only into a cone (see [`Cone`]).
    cone: bool,
    /// The cone's unit axis.
    axis: Vec3,
    /// The cosine of the cone's outer half-angle.
    cos_a: f32,
    /// The cone's window has a soft edge (`edge` holds it).
    soft: bool,
    /// The soft edge (a harmless placeholder for a hard cone).
    edge: SoftEdge,
}

/// The soft edge of a light without one: never used, but finite.
const NO_EDGE: SoftEdge = SoftEdge {
    cos_inner: 1.0,
    outer: 0.0,
    width: 1.0,
};

impl Default for LightIn {
    fn default() -> LightIn {
        LightIn {
            picked: false,
            triangle: false,
            environment: false,
            two_sided: false,
            p: [Vec3::ZERO; 3],
            n: Vec3::ZERO,
            area: 0.0,
            emit: Vec3::ZERO,
            pmf: 0.0,
            cone: false,
            axis: Vec3::Z,
            cos_a: -1.0,
            soft: false,
            edge: NO_EDGE,
        }
    }
}

impl LightIn {
    fn new(light: &Light, pmf: f32) -> LightIn {
        match light {
            Light::Point(l) => LightIn {
                picked: true,
                p: [l.position; 3],
                emit: l.intensity,
                pmf,
                ..Default::default()
            },
            Light::Triangle(t) => {
                let none = LightIn::default();
                let cone = t.cone.unwrap_or(Cone {
                    axis: none.axis,
                    cos_a: none.cos_a,
                    soft: None,
                });
                LightIn {
                    picked: true,
                    triangle: true,
                    environment: false,
                    two_sided: t.two_sided,
                    p: t.p,
                    n: t.n,
                    area: t.area,
                    emit: t.radiance,
                    pmf,
                    cone: t.cone.is_some(),
                    axis: cone.axis,
                    cos_a: cone.cos_a,
                    soft: cone.soft.is_some(),
                    edge: cone.soft.unwrap_or(NO_EDGE),
                }
            }
            Light::Environment { .. } => LightIn {
                picked: true,
                environment: true,
                pmf,
                ..Default::default()
            },
        }
    }

    /// The radiance leaving the triangle along the unit direction `w`:
    /// [`TriangleLight::emitted`](crate::light::TriangleLight::emitted)
    /// without branches, rounding as it does (a window of 1 or 0 multiplies
    /// the radiance exactly).
    #[inline(always)]
    fn emitted<const CONES: bool>(&self, w: Vec3) -> Vec3 {
        let side = self.two_sided || self.n.dot(w) > 0.0;
        let radiance = if CONES && self.cone {
            let d = w.dot(self.axis);
            let ramp = self.edge.ramp(d);
            let window = if d < self.cos_a {
                0.0
            } else if !self.soft || d >= self.edge.cos_inner {
                1.0
            } else {
                ramp
            };
            self.emit * window
        } else {
            self.emit
        };
        if side {
            radiance
        } else {
            Vec3::ZERO
        }
    }
}

/// The lights of [`W`] lanes, one array per component.
#[derive(Clone, Copy)]
struct LightChunk {
    picked: [bool; W],
    triangle: [bool; W],
    environment: [bool; W],
    two_sided: [bool; W],
    p: [[[f32; W]; 3]; 3],
    n: [[f32; W]; 3],
    area: [f32; W],
    emit: [[f32; W]; 3],
    pmf: [f32; W],
    cone: [bool; W],
    axis: [[f32; W]; 3],
    cos_a: [f32; W],
    soft: [bool; W],
    edge: [[f32; W]; 3],
}

impl LightChunk {
    /// The same light in every lane.
    #[inline(always)]
    fn splat(l: LightIn) -> LightChunk {
        let mut chunk = LightChunk::empty();
        for k in 0..W {
            chunk.set(k, &l);
        }
        chunk
    }

    /// The lights of lanes `start..start + W` (no light past the end):
    /// `table[light[i]]` picked with probability `pmf[i]`.
    #[inline(always)]
    fn load(table: &[LightIn], light: &[u32], pmf: &[f32], start: usize) -> LightChunk {
        let mut chunk = LightChunk::empty();
        let end = light.len().min(start + W);
        for (k, (&li, &pmf)) in light[start..end].iter().zip(&pmf[start..end]).enumerate() {
            chunk.set(k, &table[li as usize]);
            chunk.pmf[k] = pmf;
        }
        chunk
    }

    #[inline(always)]
    fn empty() -> LightChunk {
        LightChunk {
            picked: [false; W],
            triangle: [false; W],
            environment: [false; W],
            two_sided: [false; W],
            p: [[[0.0; W]; 3]; 3],
            n: [[0.0; W]; 3],
            area: [0.0; W],
            emit: [[0.0; W]; 3],
            pmf: [0.0; W],
            cone: [false; W],
            axis: [[0.0; W]; 3],
            cos_a: [0.0; W],
            soft: [false; W],
            edge: [[0.0; W]; 3],
        }
    }

    #[inline(always)]
    fn set(&mut self, k: usize, l: &LightIn) {
        self.picked[k] = l.picked;
        self.triangle[k] = l.triangle;
        self.environment[k] = l.environment;
        self.two_sided[k] = l.two_sided;
        for c in 0..3 {
            for v in 0..3 {
                self.p[v][c][k] = l.p[v][c];
            }
            self.n[c][k] = l.n[c];
            self.emit[c][k] = l.emit[c];
            self.axis[c][k] = l.axis[c];
        }
        self.area[k] = l.area;
        self.pmf[k] = l.pmf;
        self.cone[k] = l.cone;
        self.cos_a[k] = l.cos_a;
        self.soft[k] = l.soft;
        self.edge[0][k] = l.edge.cos_inner;
        self.edge[1][k] = l.edge.outer;
        self.edge[2][k] = l.edge.width;
    }

    #[inline(always)]
    fn lane(&self, k: usize) -> LightIn {
        let v = |a: &[[f32; W]; 3]| Vec3::new(a[0][k], a[1][k], a[2][k]);
        LightIn {
            picked: self.picked[k],
            triangle: self.triangle[k],
            environment: self.environment[k],
            two_sided: self.two_sided[k],
            p: [v(&self.p[0]), v(&self.p[1]), v(&self.p[2])],
            n: v(&self.n),
            area: self.area[k],
            emit: v(&self.emit),
            pmf: self.pmf[k],
            cone: self.cone[k],
            axis: v(&self.axis),
            cos_a: self.cos_a[k],
            soft: self.soft[k],
            edge: SoftEdge {
                cos_inner: self.edge[0][k],
                outer: self.edge[1][k],
                width: self.edge[2][k],
            },
        }
    }
}

/// The paths of one tile pass in structure-of-arrays form, reused from pass
/// to pass (allocation-free after the first).
#[derive(Default)]
pub struct SoaLanes {
    rays: RayBatch,
    shadow: RayBatch,
    pixel: Vec<u32>,
    /// Each path's random stream: the draws so far, and the fixed
    /// [`SampleStream`] (bit-reversed sample index, pixel hash's halves),
    /// one 32-bit array each so that the draws vectorise.
    rng_dim: Vec<u32>,
    rng_stream: [Vec<u32>; 3],
    beta: [Vec<f32>; 3],
    radiance: [Vec<f32>; 3],
    pending: [Vec<f32>; 3],
    /// The product of `η²` over each path's refractions so far (see
    /// `PathState::eta_scale`).
    eta_scale: Vec<f32>,
    /// Each lane's albedo at its hit, where a texture gives it.
    albedo: [Vec<f32>; 3],
    /// Each lane's BSDF parameters its material's maps give at its hit
    /// ([`mapped_params`]), where it has such maps
    /// ([`SoaScene::mapped`]).
    mapped: [Vec<f32>; 3],
    /// Each lane's interpolated unit normal at its hit, where its mesh has
    /// vertex normals (`ns_valid`; zero elsewhere).
    ns: [Vec<f32>; 3],
    ns_valid: Vec<bool>,
    /// Each lane's first tangent at its hit, where its material is
    /// anisotropic (`tangent_valid`; zero elsewhere): the general
    /// integrator's `SurfacePoint::tangent`.
    tangent: [Vec<f32>; 3],
    tangent_valid: Vec<bool>,
    /// Solid-angle density of the BSDF sample that led to the current hit.
    prev_pdf: Vec<f32>,
    /// The scattering point the current ray left from.
    prev_point: [Vec<f32>; 3],
    /// Each lane's picked light (when the scene has several), an index
    /// into [`SoaScene::light_table`], and the probability of its pick.
    light: Vec<u32>,
    light_pmf: Vec<f32>,
    /// Each lane's sample of the environment, where it picked the
    /// environment: whether it is valid, its direction, radiance and
    /// density (see [`crate::light::EnvironmentLight::sample_li`]).
    env_valid: Vec<bool>,
    env_wi: [Vec<f32>; 3],
    env_radiance: [Vec<f32>; 3],
    env_pdf: Vec<f32>,
    /// Scratch of the environment's batched lookups: lanes, their numbers
    /// or directions, and the results.
    env_lanes: Vec<u32>,
    env_us: Vec<Vec2>,
    env_samples: Vec<Option<LightSample>>,
    env_dirs: Vec<Vec3>,
    env_seen: Vec<(Vec3, f32)>,
    /// Lanes whose paths go on, ascending (rebuilt every bounce).
    kept: Vec<u32>,
    /// Lanes whose paths have ended, ascending (rebuilt every bounce).
    ended: Vec<u32>,
}

impl SoaLanes {
    #[inline(always)]
    fn resize(&mut self, n: usize) {
        self.rays.resize(n);
        self.shadow.resize(n);
        self.pixel.resize(n, 0);
        self.rng_dim.resize(n, 0);
        for part in &mut self.rng_stream {
            part.resize(n, 0);
        }
        for c in 0..3 {
            self.beta[c].resize(n, 0.0);
            self.radiance[c].resize(n, 0.0);
            self.pending[c].resize(n, 0.0);
            self.albedo[c].resize(n, 0.0);
            self.mapped[c].resize(n, 0.0);
            self.ns[c].resize(n, 0.0);
            self.tangent[c].resize(n, 0.0);
            self.prev_point[c].resize(n, 0.0);
        }
        self.ns_valid.resize(n, false);
        self.tangent_valid.resize(n, false);
        self.eta_scale.resize(n, 1.0);
        self.prev_pdf.resize(n, 0.0);
        self.light.resize(n, 0);
        self.light_pmf.resize(n, 0.0);
        self.env_valid.resize(n, false);
        self.env_pdf.resize(n, 0.0);
        for c in 0..3 {
            self.env_wi[c].resize(n, 0.0);
            self.env_radiance[c].resize(n, 0.0);
        }
    }

    /// The scattering vertex lane `i`'s ray left from, after `depth`
    /// scattering events (for the MIS weight of emission the ray finds).
    #[inline(always)]
    fn prev_vertex(&self, i: usize, depth: u32) -> PrevVertex {
        PrevVertex {
            depth,
            pdf: self.prev_pdf[i],
            point: Vec3::new(
                self.prev_point[0][i],
                self.prev_point[1][i],
                self.prev_point[2][i],
            ),
        }
    }

    /// Adds emission `le` that lane `i`'s ray found, MIS weight `weight`,
    /// through the lane's throughput: `β · le · weight`, as the general
    /// integrator adds it.
    #[inline(always)]
    fn add_found_emission(&mut self, i: usize, le: Vec3, weight: f32) {
        let beta = Vec3::new(self.beta[0][i], self.beta[1][i], self.beta[2][i]);
        let add = beta * le * weight;
        for c in 0..3 {
            self.radiance[c][i] += add[c];
        }
    }

    /// Lane `i`'s random stream as a sampler.
    #[inline(always)]
    fn sampler(&self, i: usize) -> PathSampler {
        let stream = SampleStream {
            reversed_sample: self.rng_stream[0][i],
            pixel_lo: self.rng_stream[1][i],
            pixel_hi: self.rng_stream[2][i],
        };
        PathSampler::from_parts(self.rng_dim[i], stream)
    }

    /// Sets lane `i`'s random stream.
    #[inline(always)]
    fn set_sampler(&mut self, i: usize, sampler: &PathSampler) {
        let (dim, stream) = sampler.to_parts();
        self.rng_dim[i] = dim;
        self.rng_stream[0][i] = stream.reversed_sample;
        self.rng_stream[1][i] = stream.pixel_lo;
        self.rng_stream[2][i] = stream.pixel_hi;
    }

    /// Keeps the lanes listed in `self.kept`, in order; the previous
    /// scattering points and densities only where `emitters` need them.
    #[inline(always)]
    fn retain(&mut self, emitters: bool) {
        let kept = &self.kept;
        self.rays.retain(kept);
        gather_lanes(&mut self.pixel, kept);
        gather_lanes(&mut self.rng_dim, kept);
        for part in &mut self.rng_stream {
            gather_lanes(part, kept);
        }
        gather_lanes(&mut self.eta_scale, kept);
        for c in 0..3 {
            gather_lanes(&mut self.beta[c], kept);
            gather_lanes(&mut self.radiance[c], kept);
        }
        if emitters {
            gather_lanes(&mut self.prev_pdf, kept);
            for c in 0..3 {
                gather_lanes(&mut self.prev_point[c], kept);
            }
        }
        let live = self.rays.len();
        self.resize(live);
    }
}

/// Adds the radiance of the paths of `ended` (lane indices) to their
/// pixels, as the general integrator retires a path.
#[inline(always)]
fn retire(lanes: &SoaLanes, ended: &[u32], scene: &Scene, pixels: &mut [PixelSums]) {
    let response = scene.film().response();
    for &i in ended {
        let i = i as usize;
        let radiance = Vec3::new(
            lanes.radiance[0][i],
            lanes.radiance[1][i],
            lanes.radiance[2][i],
        );
        pixels[lanes.pixel[i] as usize].add_radiance(response.apply(radiance));
    }
}

/// The arguments of one tile pass.
pub struct Pass<'a> {
    /// The kernel's view of the scene.
    pub kernel: &'a SoaScene,
    /// The scene.
    pub scene: &'a Scene,
    /// Seed and depth of the render.
    pub job: &'a RenderJob,
    /// The tile.
    pub tile: Tile,
    /// The sample index of this pass.
    pub sample: u32,
    /// Whether this is the first pass of the render over this tile (it
    /// records the object id).
    pub first: bool,
}

/// An instruction set the vectorised kernel is compiled for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Isa {
    /// The target's baseline (SSE2 on x86-64): 4 lanes per instruction.
    Baseline,
    /// AVX2 (x86-64): 8 lanes per instruction.
    Avx2,
    /// AVX-512 F/DQ/VL/BW (x86-64): 16 lanes per instruction.
    Avx512,
}

impl Isa {
    /// Whether this CPU can run the kernel compiled for `self`.
    pub fn is_available(self) -> bool {
        match self {
            Isa::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                is_x86_feature_detected!("avx2")
                    && is_x86_feature_detected!("fma")
                    && is_x86_feature_detected!("avx512f")
                    && is_x86_feature_detected!("avx512dq")
                    && is_x86_feature_detected!("avx512vl")
                    && is_x86_feature_detected!("avx512bw")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The best instruction set this CPU has.
    pub fn best() -> Isa {
        [Isa::Avx512, Isa::Avx2]
            .into_iter()
            .find(|isa| isa.is_available())
            .unwrap_or(Isa::Baseline)
    }

    /// Its name, as `plsr render` reports it.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Baseline => "baseline",
            Isa::Avx2 => "AVX2",
            Isa::Avx512 => "AVX-512",
        }
    }
}

/// Renders sample `pass.sample` of every pixel of `pass.tile`, as
/// the general integrator does. The whole pass is compiled
/// for AVX-512, for AVX2 and for the baseline instruction set; `isa` picks
/// one, or the baseline where the CPU lacks it. Every variant gives the same
/// result: no instruction set changes how an operation rounds, and Rust
/// fuses no multiply-add by itself.
pub fn trace_pass(
    isa: Isa,
    pass: &Pass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    #[cfg(target_arch = "x86_64")]
    {
        if isa == Isa::Avx512 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx512` is
            // compiled for (checked just above).
            return unsafe { trace_pass_avx512(pass, lanes, pixels, stats) };
        }
        if isa == Isa::Avx2 && isa.is_available() {
            // SAFETY: the CPU has the features `trace_pass_avx2` is compiled
            // for (checked just above).
            return unsafe { trace_pass_avx2(pass, lanes, pixels, stats) };
        }
    }
    let _ = isa;
    trace_pass_body::<Baseline>(pass, lanes, pixels, stats)
}

/// [`trace_pass_body`] compiled for AVX-512 (16 lanes per instruction).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
unsafe fn trace_pass_avx512(
    pass: &Pass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    trace_pass_body::<Avx512>(pass, lanes, pixels, stats)
}

/// [`trace_pass_body`] compiled for AVX2 (8 lanes per instruction). `fma`
/// only makes the instructions available: Rust never fuses `a·b + c` itself.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn trace_pass_avx2(
    pass: &Pass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    trace_pass_body::<Avx2>(pass, lanes, pixels, stats)
}

/// One tile pass; inlined into each instruction-set variant of
/// [`trace_pass`], which names its instruction set `T` (for the material
/// kinds' passes, which are not inlined).
#[inline(always)]
fn trace_pass_body<T: InstructionSet>(
    pass: &Pass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
) {
    let (kernel, scene) = (pass.kernel, pass.scene);

    // Camera rays: vectorised for a pinhole camera with the box filter,
    // otherwise one by one through the general code's camera and filter.
    lanes.resize((pass.tile.width * pass.tile.height) as usize);
    let n = match (&scene.camera(), &scene.film().filter) {
        (Camera::Pinhole(pinhole), PixelFilter::Box) => {
            pinhole_camera_rays(pinhole, pass, lanes);
            lanes.rays.len()
        }
        _ => general_camera_rays(pass, lanes),
    };
    lanes.resize(n);
    // The job's rays see the virtual objects or not (compositing renders
    // the scene both ways); one mask for every ray, shadow rays included.
    lanes.rays.set_mask(pass.job.ray_mask());
    lanes.shadow.set_mask(pass.job.ray_mask());
    stats.camera += n as u64;
    let clock = Instant::now();
    scene.accel().intersect_batch(&mut lanes.rays, true);
    stats.trace_nanos += clock.elapsed().as_nanos() as u64;
    if kernel.any_textured || kernel.any_smooth || kernel.any_anisotropic {
        lane_surfaces(kernel, scene, lanes);
    }

    // The camera vertex's auxiliary layers.
    camera_vertex_layers(pass, lanes, pixels);

    let max_depth = pass.job.max_depth;
    // Emission is only found on emitting triangles and in the environment
    // (and only then are the previous points and densities its MIS weight
    // needs kept).
    let has_emitters = kernel.triangle_lights || kernel.environment.is_some();
    let mut depth = 0;
    while !lanes.rays.is_empty() {
        if has_emitters {
            add_emission(kernel, scene, lanes, depth);
        }
        if depth >= max_depth {
            break;
        }
        let n = lanes.rays.len();
        let uniform = Uniform {
            // The ray after the last light sample can only find a light.
            continue_paths: depth + 1 < max_depth || scene.has_hittable_lights(),
            roulette: depth + 1 >= pass.job.rr_depth,
        };
        pick_lights(kernel, scene, lanes);
        shade_lanes::<T>(kernel, lanes, uniform);

        let shadow_tfar = lanes.shadow.tfar.as_slice();
        stats.shadow += shadow_tfar.iter().filter(|&&t| t > 0.0).count() as u64;
        let clock = Instant::now();
        scene.accel().occluded_batch(&mut lanes.shadow, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        let live = add_unoccluded(lanes);
        stats.bounce += live as u64;

        // Retire finished paths; compact once enough lanes are idle.
        if live == 0 {
            break;
        }
        if live * 3 <= n * 2 {
            retire(lanes, &lanes.ended, scene, pixels);
            lanes.retain(has_emitters);
        }
        let clock = Instant::now();
        scene.accel().intersect_batch(&mut lanes.rays, false);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        if kernel.any_textured || kernel.any_smooth || kernel.any_anisotropic {
            lane_surfaces(kernel, scene, lanes);
        }
        depth += 1;
    }
    // Every path still in a lane has ended now.
    lanes.ended.clear();
    lanes.ended.extend(0..lanes.rays.len() as u32);
    retire(lanes, &lanes.ended, scene, pixels);
}

/// Adds the emission that the lanes' rays found on emitting triangles or,
/// leaving the scene, in the environment, MIS-weighted against the light
/// sample that could have found it, as the general integrator does; lane
/// by lane, as such hits are few (but for an environment).
#[inline(always)]
fn add_emission(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes, depth: u32) {
    if let Some(env) = kernel.environment {
        add_environment(scene, lanes, env, depth);
    }
    for i in 0..lanes.rays.len() {
        let g = lanes.rays.geom_id.as_slice()[i];
        if g == INVALID_ID || !kernel.emissive[g as usize] {
            continue;
        }
        let (Some(hit), ray) = (lanes.rays.hit(i), lanes.rays.ray(i)) else {
            continue;
        };
        let Some(li) = scene.light_index(hit.geom_id, hit.prim_id) else {
            continue;
        };
        let light = &scene.lights().lights[li];
        let Light::Triangle(tl) = light else {
            continue;
        };
        let p = ray.org + hit.t * ray.dir;
        let le = tl.emitted(-ray.dir);
        if le == Vec3::ZERO {
            continue;
        }
        let prev = lanes.prev_vertex(i, depth);
        let weight = emission_weight(scene, li, &prev, p, ray.dir);
        lanes.add_found_emission(i, le, weight);
    }
}

/// Adds the environment's radiance along the rays that left the scene
/// (lanes without a hit whose paths go on: an ended path has `tfar = −∞`),
/// MIS-weighted as the general integrator weighs it; the lookups of all
/// lanes at once (`EnvironmentLight::radiance_pdf_many`).
#[inline(always)]
fn add_environment(scene: &Scene, lanes: &mut SoaLanes, env: usize, depth: u32) {
    let Light::Environment { light, .. } = &scene.lights().lights[env] else {
        return;
    };
    lanes.env_lanes.clear();
    lanes.env_dirs.clear();
    for i in 0..lanes.rays.len() {
        if lanes.rays.geom_id.as_slice()[i] == INVALID_ID && lanes.rays.tfar.as_slice()[i] > 0.0 {
            lanes.env_lanes.push(i as u32);
            lanes.env_dirs.push(lanes.rays.ray(i).dir);
        }
    }
    light.radiance_pdf_many(&lanes.env_dirs, &mut lanes.env_seen);
    for j in 0..lanes.env_lanes.len() {
        let (i, (le, pdf)) = (lanes.env_lanes[j] as usize, lanes.env_seen[j]);
        if le == Vec3::ZERO {
            continue;
        }
        let prev = lanes.prev_vertex(i, depth);
        let weight = environment_weight(scene, env, &prev, || pdf);
        lanes.add_found_emission(i, le, weight);
    }
}

/// What each lane's hit knows of its surface, looked up as the general
/// integrator looks it up (`SurfacePoint::new`, `Material::bsdf_at`): its
/// albedo into `lanes.albedo` (from the table for an untextured material,
/// else the texture at the hit's texture coordinates) and, where its mesh
/// has vertex normals, the interpolated normal into `lanes.ns`. The
/// triangles, then their vertices' attributes, are prefetched for all
/// lanes first, so that the cache misses on large meshes overlap.
#[inline(always)]
fn lane_surfaces(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    let last = kernel.albedo[0].len() - 1;
    let n = lanes.rays.len();
    let meshes = scene.meshes();
    let (geom, prim) = (lanes.rays.geom_id.as_slice(), lanes.rays.prim_id.as_slice());
    let attributes = |i: usize| {
        let g = (geom[i] as usize).min(last);
        kernel.textured[g] || kernel.smooth[g] || kernel.anisotropic[g]
    };
    for i in (0..n).filter(|&i| attributes(i)) {
        prefetch(&meshes[geom[i] as usize].triangles[prim[i] as usize]);
    }
    for i in (0..n).filter(|&i| attributes(i)) {
        let mesh = &meshes[geom[i] as usize];
        for v in mesh.triangles[prim[i] as usize] {
            if let Some(ns) = mesh.normals.get(v as usize) {
                prefetch(ns);
            }
            if let Some(uv) = mesh.uvs.get(v as usize) {
                prefetch(uv);
            }
        }
    }
    for i in 0..n {
        let g = (lanes.rays.geom_id.as_slice()[i] as usize).min(last);
        let mut albedo = Vec3::new(
            kernel.albedo[0][g],
            kernel.albedo[1][g],
            kernel.albedo[2][g],
        );
        let mut ns = None;
        if kernel.textured[g] || kernel.smooth[g] {
            if let Some(hit) = lanes.rays.hit(i) {
                let mesh = &meshes[g];
                let material = &scene.materials()[mesh.material as usize];
                let surface = super::SurfacePoint::new(mesh, &hit, material);
                if kernel.textured[g] {
                    let bsdf = material.bsdf_at(surface.uv);
                    albedo = bsdf.albedo();
                    if kernel.mapped[g] {
                        let mapped = mapped_params(&bsdf);
                        for c in 0..3 {
                            lanes.mapped[c][i] = mapped[c];
                        }
                    }
                }
                ns = surface.normal;
            }
        }
        for c in 0..3 {
            lanes.albedo[c][i] = albedo[c];
        }
        lanes.ns_valid[i] = ns.is_some();
        let ns = ns.unwrap_or(Vec3::ZERO);
        for c in 0..3 {
            lanes.ns[c][i] = ns[c];
        }
        if kernel.any_anisotropic {
            let hit = lanes.rays.hit(i).filter(|_| kernel.anisotropic[g]);
            let tangent = hit.map(|hit| super::SurfacePoint::tangent(&meshes[g], &hit));
            lanes.tangent_valid[i] = tangent.is_some();
            let tangent = tangent.unwrap_or(Vec3::ZERO);
            for c in 0..3 {
                lanes.tangent[c][i] = tangent[c];
            }
        }
    }
}

/// Adds the camera vertex's auxiliary layers (hit count, depth, normal,
/// albedo, and on the first pass the object id) to the pixels, as the
/// general integrator does at a path's first hit: per-lane values in
/// vectorised chunks, then the sums lane by lane.
#[inline(always)]
fn camera_vertex_layers(pass: &Pass, lanes: &SoaLanes, pixels: &mut [PixelSums]) {
    let rays = &lanes.rays;
    let n = rays.len();
    let last = pass.kernel.albedo[0].len() - 1;
    for start in (0..n).step_by(W) {
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        let t = load(rays.tfar.as_slice(), start);
        let dir = [
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        ];
        let ng = [
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        ];
        let (mut ns, mut ns_valid) = ([[0.0f32; W]; 3], [false; W]);
        if pass.kernel.any_smooth {
            ns_valid = load(&lanes.ns_valid, start);
            for c in 0..3 {
                ns[c] = load(&lanes.ns[c], start);
            }
        }
        let mut transmits = [false; W];
        if pass.kernel.any_transmits {
            for k in 0..W {
                transmits[k] = pass.kernel.transmits[(geom[k] as usize).min(last)];
            }
        }
        let mut normal = [[0.0f32; W]; 3];
        let mut depth = [0.0f32; W];
        for k in 0..W {
            let d = Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            let n = Vec3::new(ng[0][k], ng[1][k], ng[2][k]).normalize_or_zero();
            let facing = if n.dot(-d) >= 0.0 { n } else { -n };
            // The shading normal, as the general integrator records it (for
            // a transmissive material, the geometric normal).
            let shading = Vec3::new(ns[0][k], ns[1][k], ns[2][k]);
            let facing = if ns_valid[k] && !transmits[k] {
                shading_normal_towards(shading, facing, -d)
            } else {
                facing
            };
            for c in 0..3 {
                normal[c][k] = facing[c];
            }
            depth[k] = pass.scene.camera().depth(d, t[k]);
        }
        for k in 0..(n - start).min(W) {
            if geom[k] == INVALID_ID {
                continue;
            }
            let g = (geom[k] as usize).min(last);
            let pixel = &mut pixels[lanes.pixel[start + k] as usize];
            let albedo = if pass.kernel.any_textured {
                let i = start + k;
                Vec3::new(lanes.albedo[0][i], lanes.albedo[1][i], lanes.albedo[2][i])
            } else {
                Vec3::new(
                    pass.kernel.albedo[0][g],
                    pass.kernel.albedo[1][g],
                    pass.kernel.albedo[2][g],
                )
            };
            pixel.add_first_hit(
                depth[k],
                Vec3::new(normal[0][k], normal[1][k], normal[2][k]),
                albedo,
            );
            if pass.first {
                pixel.object_id = pass.scene.meshes()[g].object_layer();
            }
            if pass.kernel.is_virtual[g] {
                pixel.virtual_hits += 1;
            }
        }
    }
}

/// The camera rays of a tile pass through the general code's camera and
/// filter, lane by lane; a pixel the camera has no ray for (outside a
/// fisheye's circles) gets no lane. Returns the number of lanes.
#[inline(always)]
fn general_camera_rays(pass: &Pass, lanes: &mut SoaLanes) -> usize {
    let (scene, tile) = (pass.scene, pass.tile);
    let lens_sample = scene.camera().needs_lens_sample();
    let mut n = 0;
    for py in 0..tile.height {
        for px in 0..tile.width {
            let (x, y) = (tile.x0 + px, tile.y0 + py);
            let (rng, Some(ray)) =
                camera_sample(scene, pass.job.seed, lens_sample, x, y, pass.sample)
            else {
                continue;
            };
            lanes.rays.set(n, ray);
            lanes.pixel[n] = py * tile.width + px;
            lanes.set_sampler(n, &rng);
            lanes.eta_scale[n] = 1.0;
            for c in 0..3 {
                lanes.beta[c][n] = 1.0;
                lanes.radiance[c][n] = 0.0;
            }
            n += 1;
        }
    }
    n
}

/// The camera rays of a tile pass for a pinhole camera and the box filter,
/// one lane per pixel in row-major order, with each lane's random stream
/// after the filter's two numbers: the general integrator's camera stage,
/// vectorised.
#[inline(always)]
fn pinhole_camera_rays(camera: &PinholeCamera, pass: &Pass, lanes: &mut SoaLanes) {
    let (tile, seed, sample) = (pass.tile, pass.job.seed, pass.sample);
    let n = lanes.rays.len();
    for start in (0..n).step_by(W) {
        let mut dir = [[0.0f32; W]; 3];
        let mut dim = [0u32; W];
        let mut stream = [[0u32; W]; 3];
        for k in 0..W {
            let i = (start + k) as u32;
            let (px, py) = (i % tile.width, i / tile.width);
            let mut rng = PathSampler::for_sample(seed, tile.x0 + px, tile.y0 + py, sample);
            let u = rng.next_2d();
            let film = Vec2::new((tile.x0 + px) as f32, (tile.y0 + py) as f32) + u;
            let ray = camera.generate_ray(film);
            for c in 0..3 {
                dir[c][k] = ray.dir[c];
            }
            let (d, s) = rng.to_parts();
            dim[k] = d;
            (stream[0][k], stream[1][k], stream[2][k]) =
                (s.reversed_sample, s.pixel_lo, s.pixel_hi);
        }
        store(lanes.rays.dir_x.as_mut_slice(), start, &dir[0]);
        store(lanes.rays.dir_y.as_mut_slice(), start, &dir[1]);
        store(lanes.rays.dir_z.as_mut_slice(), start, &dir[2]);
        store(&mut lanes.rng_dim, start, &dim);
        for c in 0..3 {
            store(&mut lanes.rng_stream[c], start, &stream[c]);
        }
    }
    let origin = camera.pose.position;
    for (c, org) in [
        &mut lanes.rays.org_x,
        &mut lanes.rays.org_y,
        &mut lanes.rays.org_z,
    ]
    .into_iter()
    .enumerate()
    {
        org.as_mut_slice().fill(origin[c]);
    }
    lanes.rays.tnear.as_mut_slice().fill(0.0);
    lanes.rays.tfar.as_mut_slice().fill(f32::INFINITY);
    lanes.rays.geom_id.as_mut_slice().fill(INVALID_ID);
    lanes.rays.prim_id.as_mut_slice().fill(INVALID_ID);
    for (i, p) in lanes.pixel.iter_mut().enumerate() {
        *p = i as u32;
    }
    lanes.eta_scale.fill(1.0);
    for c in 0..3 {
        lanes.beta[c].fill(1.0);
        lanes.radiance[c].fill(0.0);
    }
}

/// Fills each lane's light for the next light sample: the light the
/// general integrator's [`LightSet::pick`](crate::light::LightSet::pick)
/// picks at the lane's hit point with the lane's next two random numbers
/// (the draw itself, advancing the state, happens in [`shade_lane`]), or
/// none where no light can reach the point. With one light picked the same
/// way everywhere there is nothing to fill: [`shade_lanes`] uses it for
/// every lane.
#[inline(always)]
fn pick_lights(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    if kernel.single_light.is_none() {
        pick_per_lane(kernel, scene, lanes);
    }
    if let Some(env) = kernel.environment {
        sample_environment(kernel, scene, lanes, env);
    }
}

/// The environment's light sample of each lane that picked it, with the
/// lane's numbers after the pick's two (as the general integrator draws
/// them); all lanes' samples at once (`EnvironmentLight::sample_li_many`,
/// whose cache misses on a large map overlap).
#[inline(always)]
fn sample_environment(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes, env: usize) {
    let Light::Environment { light, .. } = &scene.lights().lights[env] else {
        return;
    };
    let single = kernel.single_light.map(|l| l.environment);
    lanes.env_lanes.clear();
    lanes.env_us.clear();
    for i in 0..lanes.rays.len() {
        lanes.env_valid[i] = false;
        let picked = single.unwrap_or(lanes.light[i] == env as u32);
        let geom = lanes.rays.geom_id.as_slice()[i];
        // A delta BSDF (a smooth dielectric) takes no light sample.
        if geom == INVALID_ID || !picked || kernel.smooth_dielectric.covers(geom as usize) {
            continue;
        }
        let mut rng = lanes.sampler(i);
        let _pick = rng.next_2d();
        lanes.env_lanes.push(i as u32);
        lanes.env_us.push(rng.next_2d());
    }
    light.sample_li_many(&lanes.env_us, &mut lanes.env_samples);
    for (&i, sample) in lanes.env_lanes.iter().zip(&lanes.env_samples) {
        let i = i as usize;
        lanes.env_valid[i] = sample.is_some();
        if let Some(ls) = sample {
            for c in 0..3 {
                lanes.env_wi[c][i] = ls.wi[c];
                lanes.env_radiance[c][i] = ls.radiance[c];
            }
            lanes.env_pdf[i] = ls.pdf;
        }
    }
}

/// Each lane's light for a scene with several lights or one picked only
/// where it reaches (see [`pick_lights`]).
#[inline(always)]
fn pick_per_lane(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    let n = lanes.rays.len();
    let set = scene.lights();
    let none = (kernel.light_table.len() - 1) as u32;
    let rays = &lanes.rays;
    for start in (0..n).step_by(W) {
        // The hit points exactly as `shade_lane` computes them, and the
        // pick's two numbers, for a chunk of lanes at once.
        let t = load(rays.tfar.as_slice(), start);
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
        let mut dim = load(&lanes.rng_dim, start);
        let stream = load_streams(&lanes.rng_stream, start);
        let mut p = [[0.0f32; W]; 3];
        let mut u = [Vec2::ZERO; W];
        for k in 0..W {
            let x = Vec3::new(org[0][k], org[1][k], org[2][k])
                + t[k] * Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            for c in 0..3 {
                p[c][k] = x[c];
            }
            u[k] = PathSampler::step_2d(&mut dim[k], stream[k]);
        }
        // Which cone-limited groups reach each lane's point: the bounding
        // cones for the whole chunk, the exact test where they cannot tell.
        let mut reaches = [0u64; W];
        // (`pick_among` tests any further groups itself.)
        for (g, reach) in set.limited_reaches().take(64).enumerate() {
            let Some(reach) = reach else { continue };
            let mut decided = [false; W];
            let mut inside = [false; W];
            for k in 0..W {
                (decided[k], inside[k]) =
                    reach.bounding_cones(Vec3::new(p[0][k], p[1][k], p[2][k]));
            }
            for k in 0..W {
                let yes = if decided[k] {
                    inside[k]
                } else {
                    reach.can_reach(Vec3::new(p[0][k], p[1][k], p[2][k]))
                };
                reaches[k] |= (yes as u64) << g;
            }
        }
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        for k in 0..(n - start).min(W) {
            // A delta BSDF (a smooth dielectric) takes no light sample.
            if geom[k] == INVALID_ID || kernel.smooth_dielectric.covers(geom[k] as usize) {
                continue;
            }
            (lanes.light[start + k], lanes.light_pmf[start + k]) =
                match set.pick_among(reaches[k], Vec3::new(p[0][k], p[1][k], p[2][k]), u[k]) {
                    Some((li, pmf)) => (li as u32, pmf),
                    None => (none, 0.0),
                };
        }
    }
}

/// Adds each unoccluded shadow ray's pending radiance to its path, and
/// lists the lanes whose paths go on in `lanes.kept`; returns their number.
#[inline(always)]
fn add_unoccluded(lanes: &mut SoaLanes) -> usize {
    let n = lanes.rays.len();
    lanes.kept.resize(n, 0);
    lanes.ended.resize(n, 0);
    let mut live = 0;
    for start in (0..n).step_by(W) {
        let shadow_tfar = load(lanes.shadow.tfar.as_slice(), start);
        let tfar = load(lanes.rays.tfar.as_slice(), start);
        for c in 0..3 {
            let mut radiance = load(&lanes.radiance[c], start);
            let pending = load(&lanes.pending[c], start);
            for k in 0..W {
                // Inactive lanes have tfar = −∞, as occluded ones. A select,
                // not a branch: occlusion is unpredictable.
                radiance[k] = if shadow_tfar[k] > 0.0 {
                    radiance[k] + pending[k]
                } else {
                    radiance[k]
                };
            }
            store(&mut lanes.radiance[c], start, &radiance);
        }
        for k in 0..(n - start).min(W) {
            // Branch-free too: whether a path goes on is unpredictable.
            let i = start + k;
            lanes.kept[live] = i as u32;
            lanes.ended[i - live] = i as u32;
            live += (tfar[k] > 0.0) as usize;
        }
    }
    lanes.kept.truncate(live);
    lanes.ended.truncate(n - live);
    live
}

/// What is the same for every lane of one bounce.
#[derive(Clone, Copy)]
struct Uniform {
    /// Whether paths go on after the light sample (BSDF sampling).
    continue_paths: bool,
    /// Whether Russian roulette applies after this bounce.
    roulette: bool,
}

/// One lane's inputs to a bounce.
#[derive(Clone, Copy)]
struct LaneIn {
    org: Vec3,
    dir: Vec3,
    /// Hit distance.
    t: f32,
    /// Unnormalised geometric normal.
    ng: Vec3,
    hit: bool,
    /// The interpolated unit normal, where the mesh has vertex normals
    /// (`smooth`).
    ns: Vec3,
    smooth: bool,
    /// The first tangent, where the lane's material is anisotropic
    /// (`anisotropic`).
    tangent: Vec3,
    anisotropic: bool,
    beta: Vec3,
    eta_scale: f32,
    /// The path's draws so far and its fixed stream.
    rng: u32,
    stream: SampleStream,
    light: LightIn,
    /// The lane's sample of the environment, where it picked it.
    env_valid: bool,
    env_wi: Vec3,
    env_radiance: Vec3,
    env_pdf: f32,
}

/// One lane's results of a bounce.
#[derive(Clone, Copy)]
struct LaneOut {
    /// Whether the path goes on (then `next_org`, `next_dir` hold its ray).
    alive: bool,
    next_org: Vec3,
    next_dir: Vec3,
    /// Whether a shadow ray is to be traced (`shadow_*` hold it).
    shadow: bool,
    shadow_org: Vec3,
    shadow_dir: Vec3,
    shadow_tfar: f32,
    /// Radiance the shadow ray adds if unoccluded.
    pending: Vec3,
    beta: Vec3,
    /// Density of the BSDF sample (for the MIS weight of emission found by
    /// the next ray) and the point it left from.
    pdf: f32,
    point: Vec3,
    /// The path's draws so far.
    rng: u32,
    /// The path's η² after this bounce (see [`LaneBsdf::eta_scale`]).
    eta_scale: f32,
    /// Where the BSDF was evaluated, in its local frame: `[wo, the light
    /// sample's wi, the sampled wi]` (placeholders where there was none);
    /// read only by [`shade_staged_lanes`], and so not computed elsewhere.
    evaluated: [Vec3; 3],
}

/// One bounce of one path: the general integrator's `shade` for a surface
/// whose BSDF the lane holds (`B`: Lambert, rough Cook–Torrance, principled,
/// Blinn–Phong, a rough or smooth dielectric) and a point, area, parametric
/// or environment light, written without
/// branches (every `if` is a select) so that a loop over lanes vectorises.
/// It calls the same branch-free helpers as the general integrator (ray
/// offsets, the lights' samples, the BSDF's own code, MIS), in the same
/// order, with the same random numbers.
#[inline(always)]
fn shade_lane<
    B: LaneBsdf,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
    const ANISO: bool,
>(
    l: LaneIn,
    bsdf: B,
    u: Uniform,
) -> LaneOut {
    let mut rng = l.rng;
    let p = l.org + l.t * l.dir;
    let wo = -l.dir;
    let ng = l.ng.normalize_or_zero();
    // Opaque surfaces are two-sided: shaded in the frame facing the viewer.
    // A transmissive one keeps the geometric normal as its outside.
    let n = if B::TRANSMITS || ng.dot(wo) >= 0.0 {
        ng
    } else {
        -ng
    };
    // A shading normal bends the frame; directions on different sides for
    // it and for the geometric normal are rejected (the light-leak guard).
    let smooth = l.smooth;
    let shading_n = if smooth {
        shading_normal_towards(l.ns, n, wo)
    } else {
        n
    };
    // An anisotropic surface's frame follows its tangent (as the general
    // integrator's `SurfaceHit::frame`); `ANISO`: whether any lane of the
    // chunk has one (otherwise the tangent frame is not even computed).
    let frame = if ANISO && B::MAY_BE_ANISOTROPIC && l.anisotropic {
        Frame::from_normal_tangent(shading_n, l.tangent)
    } else {
        Frame::from_normal(shading_n)
    };
    let wo_local = frame.to_local(wo);
    let eps = ray_epsilon(p);
    // Reflected rays leave on the side of `n`; a transmissive BSDF's leave
    // on the side of their direction.
    let origin_for = |dir: Vec3| {
        if B::TRANSMITS {
            spawn_origin(p, n, eps, dir)
        } else {
            p + n * eps
        }
    };

    // The numbers of one bounce, in the general integrator's order: two
    // pick the light (`pick_lights` drew the pick from them already, or
    // there is one light), two place the sample on it (unused by a point
    // light), one picks the BSDF's lobe (principled's diffuse or specular),
    // two the direction.
    // Where no light was picked, the general integrator draws no numbers
    // for a light sample: drawn on a copy, kept where a light was picked.
    // A delta BSDF takes no light sample: none of these numbers is drawn.
    let light = l.light;
    let mut rng_light = rng;
    let _light_pick = PathSampler::step_2d(&mut rng_light, l.stream);
    let mut rng_point = rng_light;
    let light_point = PathSampler::step_2d(&mut rng_point, l.stream);
    if !B::DELTA {
        rng = if light.picked { rng_point } else { rng_light };
    }
    let lobe = PathSampler::step_f32(&mut rng, l.stream);
    let direction = PathSampler::step_2d(&mut rng, l.stream);

    // Next-event estimation (a delta BSDF takes no light sample).
    let shadow = if B::DELTA {
        LightSampleOut {
            shadow: false,
            org: p,
            dir: Vec3::Z,
            tfar: f32::NEG_INFINITY,
            pending: Vec3::ZERO,
            wi_local: Vec3::Z,
        }
    } else {
        light_sample_lane::<B, TRIANGLES, CONES, ENV>(
            &l,
            &bsdf,
            LaneFrame {
                p,
                wo,
                ng,
                n,
                frame,
                wo_local,
                smooth,
                eps,
            },
            light_point,
        )
    };

    let (sampled, local, pdf, factor) = bsdf.sample(wo_local, lobe, direction);
    // A delta lobe's density is recorded as 0 (no MIS for what it finds).
    let pdf = if B::DELTA { 0.0 } else { pdf };
    let next_dir = frame.to_world(local);
    // Where the guard rejects the direction, the path ends.
    let sampled = sampled && (!smooth || sides_agree(wo, next_dir, ng, wo_local, local));
    let mut beta = l.beta * factor;
    // The path's η² of its refractions, this one's included (as the
    // general integrator keeps it, only for a sampled direction).
    let eta_scale = if B::TRANSMITS && sampled {
        l.eta_scale * bsdf.eta_scale(wo_local, local)
    } else {
        l.eta_scale
    };

    // Russian roulette draws a number only where it spins: drawn from a
    // copy of the state, kept where it spins.
    let rr_beta = beta * eta_scale;
    let spin = roulette_spins(rr_beta, u.roulette);
    let mut rng_rr = rng;
    let (survives, beta_rr) = roulette(beta, rr_beta, PathSampler::step_f32(&mut rng_rr, l.stream));
    if spin {
        rng = rng_rr;
        beta = beta_rr;
    }
    let survived = !spin || survives;
    let alive = l.hit && u.continue_paths && sampled && survived && beta != Vec3::ZERO;
    LaneOut {
        alive,
        next_org: origin_for(next_dir),
        next_dir,
        shadow: shadow.shadow,
        shadow_org: shadow.org,
        shadow_dir: shadow.dir,
        shadow_tfar: shadow.tfar,
        pending: shadow.pending,
        beta,
        pdf,
        point: p,
        rng,
        eta_scale,
        evaluated: [wo_local, shadow.wi_local, local],
    }
}

/// A lane's light sample: the shadow ray to trace (`shadow`: whether to
/// trace one) and the radiance it adds if unoccluded.
#[derive(Clone, Copy)]
struct LightSampleOut {
    shadow: bool,
    org: Vec3,
    dir: Vec3,
    tfar: f32,
    pending: Vec3,
    /// The light sample's direction in the shading frame.
    wi_local: Vec3,
}

/// Where a lane scatters, as [`shade_lane`] computed it: the point, the
/// outgoing direction, the (unit) geometric normal, the side's normal `n`,
/// the shading frame, `wo` in it, whether the shading normal bends the
/// frame (`smooth`) and the ray offset.
#[derive(Clone, Copy)]
struct LaneFrame {
    p: Vec3,
    wo: Vec3,
    ng: Vec3,
    n: Vec3,
    frame: Frame,
    wo_local: Vec3,
    smooth: bool,
    eps: f32,
}

/// The light sample of [`shade_lane`] (not for a delta BSDF): the picked
/// light's sample at the two numbers `light_point`, the BSDF's value and
/// density there, the MIS weight and the shadow ray, as the general
/// integrator's `scatter` computes them.
#[inline(always)]
fn light_sample_lane<B: LaneBsdf, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    l: &LaneIn,
    bsdf: &B,
    at: LaneFrame,
    light_point: Vec2,
) -> LightSampleOut {
    let LaneFrame {
        p,
        wo,
        ng,
        n,
        frame,
        wo_local,
        smooth,
        eps,
    } = at;
    let light = l.light;
    let origin_for = |dir: Vec3| {
        if B::TRANSMITS {
            spawn_origin(p, n, eps, dir)
        } else {
            p + n * eps
        }
    };
    // Every kind's sample, computed for every lane and selected (the
    // triangle's only where the scene has emitting triangles, the
    // environment's, taken by `sample_environment`, where it has one).
    let (valid, ls) = if ENV && light.environment {
        let sample = LightSample {
            radiance: l.env_radiance,
            wi: l.env_wi,
            dist: f32::INFINITY,
            pdf: l.env_pdf,
            delta: false,
        };
        (l.env_valid, sample)
    } else if TRIANGLES && light.triangle {
        let point = TrianglePoint::new(light.p, light.n, light.area, p, light_point);
        point.sample(light.emitted::<CONES>(-point.wi))
    } else {
        point_light_sample(light.p[0], light.emit, p)
    };
    let wi_local = frame.to_local(ls.wi);
    let leaks = smooth && !sides_agree(wo, ls.wi, ng, wo_local, wi_local);
    // A delta light (a point light) needs no MIS weight: the general
    // integrator evaluates the BSDF alone there, and `eval_pdf` elsewhere.
    let delta_light = !((TRIANGLES && light.triangle) || (ENV && light.environment));
    let (f, bsdf_pdf) = bsdf.eval_pdf(wo_local, wi_local);
    let f = if delta_light {
        bsdf.eval(wo_local, wi_local)
    } else {
        f
    };
    let (f, bsdf_pdf) = if leaks {
        (Vec3::ZERO, 0.0)
    } else {
        (f, bsdf_pdf)
    };
    let f = f * wi_local.z.abs();
    let light_pdf = light.pmf * ls.pdf;
    // A point light is a delta light: no MIS.
    let weight = if (TRIANGLES && light.triangle) || (ENV && light.environment) {
        power_heuristic(light_pdf, bsdf_pdf)
    } else {
        1.0
    };
    let shadow_org = origin_for(ls.wi);
    let (shadow_dir, shadow_tfar) = shadow_segment(shadow_org, p, ls.wi, ls.dist);
    LightSampleOut {
        shadow: l.hit && light.picked && valid && f != Vec3::ZERO && shadow_tfar > 0.0,
        org: shadow_org,
        dir: shadow_dir,
        tfar: shadow_tfar,
        pending: l.beta * f * ls.radiance * (weight / light_pdf),
        wi_local,
    }
}

/// Lanes per chunk of [`shade_lanes`]: one AVX-512 register of `f32`.
const W: usize = 16;

/// A component of [`W`] lanes, copied out of a lane array (zero past its end).
#[inline(always)]
fn load<T: Copy + Default>(src: &[T], start: usize) -> [T; W] {
    // A whole chunk is a fixed-size copy (register moves); only the last,
    // partial one needs a variable-length copy.
    if let Some(Ok(chunk)) = src.get(start..start + W).map(<[T; W]>::try_from) {
        return chunk;
    }
    let mut out = [T::default(); W];
    let m = (src.len() - start).min(W);
    out[..m].copy_from_slice(&src[start..start + m]);
    out
}

/// The fixed random streams of [`W`] lanes (see [`SoaLanes::sampler`]).
#[inline(always)]
fn load_streams(streams: &[Vec<u32>; 3], start: usize) -> [SampleStream; W] {
    let parts = [
        load(&streams[0], start),
        load(&streams[1], start),
        load(&streams[2], start),
    ];
    std::array::from_fn(|k| SampleStream {
        reversed_sample: parts[0][k],
        pixel_lo: parts[1][k],
        pixel_hi: parts[2][k],
    })
}

/// [`load`] with `fill` past the end of the lane array.
#[inline(always)]
fn load_or<T: Copy + Default>(src: &[T], start: usize, fill: T) -> [T; W] {
    let mut out = load(src, start);
    let m = (src.len() - start).min(W);
    out[m..].fill(fill);
    out
}

/// Copies a component of [`W`] lanes back (as far as the lane array goes).
#[inline(always)]
fn store<T: Copy>(dst: &mut [T], start: usize, src: &[T; W]) {
    if let Some(chunk) = dst.get_mut(start..start + W) {
        chunk.copy_from_slice(src);
        return;
    }
    let m = (dst.len() - start).min(W);
    dst[start..start + m].copy_from_slice(&src[..m]);
}

/// One bounce of the lanes of a chunk whose material is of one kind `B`
/// (`Some` in `bsdfs`), through [`shade_lane`] ([`LaneBsdf::shade_chunk`]);
/// the chunk's other lanes go through the same loop with `idle` (so that it
/// has no branch) and their results are discarded. A chunk with no such
/// lane is skipped.
#[inline(always)]
fn shade_kind<B: LaneBsdf, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
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
fn shade_kind_lanes<
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
fn shade_staged_lanes<
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
    // Stage 2: the albedos there, `[E(wo), E(light wi), E(sampled wi), Ē]`
    // by component.
    let mut albedos = [[0.0f32; W]; 12];
    for (k, lane) in principled.iter().enumerate() {
        let Some(lane) = lane else {
            continue;
        };
        let params = lane.params();
        let m = params.microfacet();
        let tables = lane.0.mode.tables().unwrap_or(EnergyTables::NONE);
        let mut found = [params.average_dielectric_albedo(&tables, &m); 4];
        for (d, found) in found.iter_mut().take(3).enumerate() {
            let dir = Vec3::new(
                evaluated[3 * d][k],
                evaluated[3 * d + 1][k],
                evaluated[3 * d + 2][k],
            );
            *found = params.albedo_towards(&tables, &m, dir);
        }
        for a in 0..4 {
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
        let staged = StagedPrincipledLane {
            lane: lane_numbers::<M>(&params, k),
            light: KnownAlbedos([eo, e_light, average]),
            sampled: KnownAlbedos([eo, e_sampled, average]),
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
fn lane_numbers<M: PrincipledMode>(params: &[[f32; W]; 8], k: usize) -> PrincipledLane<M> {
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
/// with a [`ChunkPass`]), which reads the state of the lanes it shades and
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
fn shade_lanes<T: InstructionSet>(kernel: &SoaScene, lanes: &mut SoaLanes, u: Uniform) {
    let lambert = LambertPass;
    if !kernel.all_lambert {
        end_missed_paths(lanes);
    }
    shade_lambert::<T>(&lambert, kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.conductor), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.schlick), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.coated), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.conductor_beckmann), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.schlick_beckmann), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.coated_beckmann), kernel, lanes, u);
    shade_kind_pass::<T, _>(&PrincipledPass(&kernel.principled), kernel, lanes, u);
    shade_kind_pass::<T, _>(&PrincipledPass(&kernel.principled_ec), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.blinn_phong), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.dielectric), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.dielectric_beckmann), kernel, lanes, u);
    shade_kind_pass::<T, _>(&KindPass(&kernel.smooth_dielectric), kernel, lanes, u);
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
fn shade_lambert<T: InstructionSet>(
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
fn shade_kind_pass<T: InstructionSet, P: ChunkPass>(
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

/// An instruction set the kernel's passes are compiled for, as a type: each
/// variant of [`trace_pass`] calls the kinds' passes compiled for its own
/// set (a function that is not inlined does not inherit its caller's target
/// features).
trait InstructionSet {
    /// [`shade_chunks`] of `pass` with these parameters, in a function of
    /// its own compiled for this instruction set.
    fn pass<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    );
}

/// The baseline instruction set (every x86-64 CPU, or another architecture).
struct Baseline;

impl InstructionSet for Baseline {
    #[inline(always)]
    fn pass<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        pass_baseline::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
    }
}

/// AVX2 with FMA; only [`trace_pass_avx2`] uses it.
#[cfg(target_arch = "x86_64")]
struct Avx2;

#[cfg(target_arch = "x86_64")]
impl InstructionSet for Avx2 {
    #[inline(always)]
    fn pass<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        // SAFETY: only `trace_pass_avx2` passes this type, and `trace_pass`
        // calls that only on a CPU with AVX2 and FMA.
        unsafe { pass_avx2::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u) }
    }
}

/// AVX-512 (F, DQ, VL, BW); only [`trace_pass_avx512`] uses it.
#[cfg(target_arch = "x86_64")]
struct Avx512;

#[cfg(target_arch = "x86_64")]
impl InstructionSet for Avx512 {
    #[inline(always)]
    fn pass<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
        pass: &P,
        kernel: &SoaScene,
        lanes: &mut SoaLanes,
        u: Uniform,
    ) {
        // SAFETY: only `trace_pass_avx512` passes this type, and
        // `trace_pass` calls that only on a CPU with these features.
        unsafe { pass_avx512::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u) }
    }
}

/// A pass for the baseline instruction set.
#[inline(never)]
fn pass_baseline<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}

/// A pass compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline(never)]
unsafe fn pass_avx2<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}

/// A pass compiled for AVX-512.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx512bw,avx2,fma")]
#[inline(never)]
unsafe fn pass_avx512<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    shade_chunks::<P, TRIANGLES, CONES, ENV>(pass, kernel, lanes, u)
}

/// Which lanes of a chunk one pass of [`shade_chunks`] shades, and its
/// loop over them.
trait ChunkPass {
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
struct LambertPass;

impl ChunkPass for LambertPass {
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
fn end_missed_paths(lanes: &mut SoaLanes) {
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
struct KindPass<'a, B>(&'a KindTable<B>);

impl<B: LaneKind + LaneBsdf> ChunkPass for KindPass<'_, B> {
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
struct PrincipledPass<'a, M>(&'a KindTable<PrincipledIn<M>>);

impl<M: PrincipledMode> ChunkPass for PrincipledPass<'_, M> {
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
/// Only the selected lanes' results are written back.
#[inline(always)]
fn shade_chunks<P: ChunkPass, const TRIANGLES: bool, const CONES: bool, const ENV: bool>(
    pass: &P,
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    u: Uniform,
) {
    let n = lanes.rays.len();
    let last = kernel.albedo[0].len() - 1;
    // One light: the same for every lane, so no per-lane arrays.
    let single = kernel.single_light.map(LightChunk::splat);
    for start in (0..n).step_by(W) {
        let rays = &lanes.rays;
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        let Some((owned, chunk)) = pass.select(kernel, lanes, start, &geom) else {
            continue;
        };
        let (ox, oy, oz) = (
            load(rays.org_x.as_slice(), start),
            load(rays.org_y.as_slice(), start),
            load(rays.org_z.as_slice(), start),
        );
        let (dx, dy, dz) = (
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        );
        let t = load(rays.tfar.as_slice(), start);
        let (nx, ny, nz) = (
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        );
        let mut albedo = [[0.0f32; W]; 3];
        if kernel.any_textured {
            for (c, albedo) in albedo.iter_mut().enumerate() {
                *albedo = load(&lanes.albedo[c], start);
            }
        } else {
            for k in 0..W {
                let g = (geom[k] as usize).min(last);
                for (c, albedo) in albedo.iter_mut().enumerate() {
                    albedo[k] = kernel.albedo[c][g];
                }
            }
        }
        let (br, bg, bb) = (
            load(&lanes.beta[0], start),
            load(&lanes.beta[1], start),
            load(&lanes.beta[2], start),
        );
        let loaded;
        let lights = match &single {
            Some(chunk) => chunk,
            None => {
                loaded =
                    LightChunk::load(&kernel.light_table, &lanes.light, &lanes.light_pmf, start);
                &loaded
            }
        };
        let rng_in = load(&lanes.rng_dim, start);
        let mut rng = rng_in;
        let stream = load_streams(&lanes.rng_stream, start);
        let eta_scale_in = load(&lanes.eta_scale, start);
        let mut eta_scale = eta_scale_in;
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
        let aniso = tangent_valid.contains(&true);

        let mut next = [[0.0f32; W]; 6];
        let mut next_tfar = [f32::NEG_INFINITY; W];
        let mut shadow_ray = [[0.0f32; W]; 6];
        let mut shadow_tfar = [f32::NEG_INFINITY; W];
        let mut pending = [[0.0f32; W]; 3];
        let mut beta = [br, bg, bb];
        let (mut prev_pdf, mut prev_point) = ([0.0f32; W], [[0.0f32; W]; 3]);
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
        if TRIANGLES || ENV {
            prev_pdf = load(&lanes.prev_pdf, start);
            for c in 0..3 {
                prev_point[c] = load(&lanes.prev_point[c], start);
            }
        }
        // Each lane's input to `shade_lane` (the state loaded above, before
        // any loop below changed it).
        let lane_in = |k: usize| LaneIn {
            org: Vec3::new(ox[k], oy[k], oz[k]),
            dir: Vec3::new(dx[k], dy[k], dz[k]),
            t: t[k],
            ng: Vec3::new(nx[k], ny[k], nz[k]),
            hit: geom[k] != INVALID_ID,
            ns: Vec3::new(ns[0][k], ns[1][k], ns[2][k]),
            smooth: ns_valid[k],
            tangent: Vec3::new(tangent[0][k], tangent[1][k], tangent[2][k]),
            anisotropic: tangent_valid[k],
            beta: Vec3::new(br[k], bg[k], bb[k]),
            eta_scale: eta_scale_in[k],
            rng: rng_in[k],
            stream: stream[k],
            light: lights.lane(k),
            env_valid: env_valid[k],
            env_wi: Vec3::new(env_wi[0][k], env_wi[1][k], env_wi[2][k]),
            env_radiance: Vec3::new(env_radiance[0][k], env_radiance[1][k], env_radiance[2][k]),
            env_pdf: env_pdf[k],
        };
        // Lane `k`'s results into the chunk's outputs.
        let mut put = |k: usize, hit: bool, out: LaneOut| {
            // A lane without a hit keeps its state: its path has ended.
            if hit {
                rng[k] = out.rng;
                eta_scale[k] = out.eta_scale;
                for c in 0..3 {
                    beta[c][k] = out.beta[c];
                }
            }
            // Only emission found later needs them (for its MIS weight).
            if (TRIANGLES || ENV) && hit {
                prev_pdf[k] = out.pdf;
                for c in 0..3 {
                    prev_point[c][k] = out.point[c];
                }
            }
            for c in 0..3 {
                pending[c][k] = out.pending[c];
                shadow_ray[c][k] = out.shadow_org[c];
                shadow_ray[3 + c][k] = out.shadow_dir[c];
                next[c][k] = out.next_org[c];
                next[3 + c][k] = out.next_dir[c];
            }
            shadow_tfar[k] = if out.shadow {
                out.shadow_tfar
            } else {
                f32::NEG_INFINITY
            };
            next_tfar[k] = if out.alive {
                f32::INFINITY
            } else {
                f32::NEG_INFINITY
            };
        };
        pass.shade::<TRIANGLES, CONES, ENV>(&chunk, &albedo, aniso, &lane_in, &mut put, u);

        // The selected lanes' results back into the lane arrays (the other
        // lanes' are another pass's).
        let all = owned == [true; W];
        store_owned(&mut lanes.rng_dim, start, &rng, &owned, all);
        store_owned(&mut lanes.eta_scale, start, &eta_scale, &owned, all);
        if TRIANGLES || ENV {
            store_owned(&mut lanes.prev_pdf, start, &prev_pdf, &owned, all);
            for c in 0..3 {
                store_owned(&mut lanes.prev_point[c], start, &prev_point[c], &owned, all);
            }
        }
        for c in 0..3 {
            store_owned(&mut lanes.beta[c], start, &beta[c], &owned, all);
            store_owned(&mut lanes.pending[c], start, &pending[c], &owned, all);
        }
        let (rays, shadow) = (&mut lanes.rays, &mut lanes.shadow);
        for (dst, src) in [
            (&mut rays.org_x, &next[0]),
            (&mut rays.org_y, &next[1]),
            (&mut rays.org_z, &next[2]),
            (&mut rays.dir_x, &next[3]),
            (&mut rays.dir_y, &next[4]),
            (&mut rays.dir_z, &next[5]),
            (&mut rays.tfar, &next_tfar),
            (&mut shadow.org_x, &shadow_ray[0]),
            (&mut shadow.org_y, &shadow_ray[1]),
            (&mut shadow.org_z, &shadow_ray[2]),
            (&mut shadow.dir_x, &shadow_ray[3]),
            (&mut shadow.dir_y, &shadow_ray[4]),
            (&mut shadow.dir_z, &shadow_ray[5]),
            (&mut shadow.tfar, &shadow_tfar),
        ] {
            store_owned(dst.as_mut_slice(), start, src, &owned, all);
        }
    }
}

/// [`store`] of the lanes `owned` marks (`all`: every lane), leaving the
/// others as they are.
#[inline(always)]
fn store_owned<T: Copy + Default>(
    dst: &mut [T],
    start: usize,
    src: &[T; W],
    owned: &[bool; W],
    all: bool,
) {
    if all {
        return store(dst, start, src);
    }
    let old = load(dst, start);
    let merged = std::array::from_fn(|k| if owned[k] { src[k] } else { old[k] });
    store(dst, start, &merged);
}
