//! The kernel's per-scene tables: what it needs of a scene it renders
//! ([`SoaScene`]), each geometry's material of one kind ([`KindTable`]) and
//! the parameters a chunk's lanes take from their materials' maps.

use super::*;

/// What the vectorised kernel needs of a scene it can render.
#[derive(Debug, Clone)]
pub struct SoaScene {
    /// Lambert albedo per Embree geometry id (linear RGB, one array per
    /// channel), with one extra zero entry that lanes without a hit read.
    pub(super) albedo: [Vec<f32>; 3],
    /// Whether each geometry (by Embree id) emits, with one extra `false`.
    pub(super) emissive: Vec<bool>,
    /// Whether each geometry's material is textured (then `albedo` holds
    /// its colour where the texture gives none), with one extra `false`.
    pub(super) textured: Vec<bool>,
    /// Whether any geometry's is (then each lane's albedo is looked up by
    /// `lane_surfaces` into `SoaLanes::albedo`).
    pub(super) any_textured: bool,
    /// Whether each geometry's material has a map that changes its BSDF's
    /// parameters beside its colour (a roughness or metallic map, or a
    /// Blinn–Phong colour map: [`mapped_params`]), with one extra `false`.
    pub(super) mapped: Vec<bool>,
    /// Whether any geometry's has (then `lane_surfaces` looks up each such
    /// lane's parameters into `SoaLanes::mapped`).
    pub(super) any_mapped: bool,
    /// Whether each geometry's material is Lambert (shaded in the first
    /// vectorised loop), with one extra `false`.
    pub(super) lambert: Vec<bool>,
    /// Whether every geometry's is.
    pub(super) all_lambert: bool,
    /// Rough Cook–Torrance surfaces (GGX or Beckmann, isotropic or not,
    /// roughness-mapped or not), one table per Fresnel term and distribution:
    /// each a loop of its own. Every table's entries are what the kind's
    /// [`LaneKind::of`] takes of the geometry's material.
    pub(super) conductor: KindTable<CookTorranceIn<ConductorTerm, Ggx>>,
    pub(super) schlick: KindTable<CookTorranceIn<SchlickTerm, Ggx>>,
    pub(super) coated: KindTable<CookTorranceIn<CoatingTerm, Ggx>>,
    pub(super) conductor_beckmann: KindTable<CookTorranceIn<ConductorTerm, Beckmann>>,
    pub(super) schlick_beckmann: KindTable<CookTorranceIn<SchlickTerm, Beckmann>>,
    pub(super) coated_beckmann: KindTable<CookTorranceIn<CoatingTerm, Beckmann>>,
    /// Principled surfaces in Mitsuba's mode and in the energy-conserving
    /// one, mapped or not ([`PrincipledIn`]).
    pub(super) principled: KindTable<PrincipledIn<MitsubaMode>>,
    pub(super) principled_ec: KindTable<PrincipledIn<EnergyConserving>>,
    /// Rough dielectrics, GGX or Beckmann ([`DielectricIn`]).
    pub(super) dielectric: KindTable<DielectricIn<Ggx>>,
    pub(super) dielectric_beckmann: KindTable<DielectricIn<Beckmann>>,
    /// Smooth dielectrics (see [`SmoothDielectricIn`]).
    pub(super) smooth_dielectric: KindTable<SmoothDielectricIn>,
    /// Blinn–Phong surfaces, colour-mapped or not ([`BlinnPhongIn`]).
    pub(super) blinn_phong: KindTable<BlinnPhongIn>,
    /// Whether each geometry's material transmits light (its normal layer
    /// records the geometric normal), with one extra `false`.
    pub(super) transmits: Vec<bool>,
    /// Whether any geometry's does.
    pub(super) any_transmits: bool,
    /// Whether each geometry's material is opaque and one-sided (black
    /// seen from behind: [`crate::material::Material::black_from`]), with
    /// one extra `false`.
    pub(super) one_sided: Vec<bool>,
    /// Whether any geometry's is.
    pub(super) any_one_sided: bool,
    /// Whether each geometry (by Embree id) is a virtual object (inserted
    /// into a photograph; counted in the compositing matte), with one extra
    /// `false`.
    pub(super) is_virtual: Vec<bool>,
    /// The virtual objects' bounds, padded ([`padded_box`]): one box per
    /// virtual mesh, or their union when there are more than 16 (for the
    /// paired render's shadow rays, see `paired.rs`).
    pub(super) virtual_bounds: Vec<(Vec3, Vec3)>,
    /// Whether each geometry's material is anisotropic
    /// ([`crate::material::Material::is_anisotropic`]: its lanes need a
    /// tangent), with one extra
    /// `false`.
    pub(super) anisotropic: Vec<bool>,
    /// Whether any geometry's is (then `lane_surfaces` looks up each such
    /// lane's tangent into `SoaLanes::tangent`).
    pub(super) any_anisotropic: bool,
    /// Whether each geometry (by Embree id) has shading normals (vertex
    /// normals, or a normal-mapped material and texture coordinates), with
    /// one extra `false`.
    pub(super) smooth: Vec<bool>,
    /// Whether any geometry has (then each lane's interpolated normal is
    /// looked up by `lane_surfaces` into `SoaLanes::ns`).
    pub(super) any_smooth: bool,
    /// The one light, when there is exactly one, with the probability of
    /// picking it: the same for every lane.
    pub(super) single_light: Option<LightIn>,
    /// Each light of the scene as a lane takes it (with no pick
    /// probability), and last an entry for no light at all.
    pub(super) light_table: Vec<LightIn>,
    /// The environment light (index into the scene's lights), if any.
    pub(super) environment: Option<usize>,
    /// Whether any light is an emitting triangle.
    pub(super) triangle_lights: bool,
    /// Whether any light is an emitting triangle with a cone (a parametric
    /// light).
    pub(super) cones: bool,
}

impl SoaScene {
    /// The kernel's view of `scene`, or `None` where a material of it is one
    /// no pass of the kernel shades (`plastic`, `rough_plastic`,
    /// `thin_dielectric`, `principled_thin`, `principled` with sheen,
    /// clearcoat, transmission or flatness, and composites; every
    /// other model, mapped or not, has a pass), it has a spot, projector,
    /// directional, sphere or emission-mapped light, a normal map with the shadow
    /// terminator or bent for valid reflections, or alpha maps: the general integrator then renders the
    /// scene.
    pub fn new(scene: &Scene) -> Option<SoaScene> {
        // Spot, projector, directional and sphere lights are sampled by the
        // general integrator only.
        let spot = |l: &crate::light::Light| {
            matches!(l, crate::light::Light::Point(p) if p.cone.is_some() || p.projection.is_some())
                || matches!(l, crate::light::Light::Directional { .. })
                || matches!(l, crate::light::Light::Triangle(t) if t.sphere.is_some() || t.map.is_some())
        };
        if scene.lights().lights.iter().any(spot) {
            return None;
        }
        // So are instanced groups (the kernel's tables are per mesh of the
        // top-level scene).
        if !scene.instancing().instances.is_empty() {
            return None;
        }
        // So are normal maps with the shadow terminator, composites,
        // roughness maps along two tangents and maps of principled weights.
        if scene.materials().iter().any(|m| {
            m.textures.terminator()
                || m.textures.valid_reflection
                || m.composite.is_some()
                || m.textures.alpha_u.is_some()
                || !m.textures.scalars.is_empty()
        }) {
            return None;
        }
        let mut albedo = [Vec::new(), Vec::new(), Vec::new()];
        let mut emissive = Vec::new();
        let mut textured = Vec::new();
        let mut mapped = Vec::new();
        let mut transmits = Vec::new();
        let mut one_sided = Vec::new();
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
            let normal_mapped = (material.textures.normal.is_some()
                || material.textures.bump.is_some())
                && !mesh.uvs.is_empty();
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
            one_sided.push(!material.two_sided && !material.bsdf.transmits());
            anisotropic.push(material.is_anisotropic());
            emissive.push(scene.light_index(g as u32, 0).is_some());
            textured.push(!material.textures.is_empty());
            let t = &material.textures;
            mapped.push(match material.bsdf {
                Bsdf::CookTorrance(_) => t.roughness.is_some(),
                Bsdf::Principled(_) => t.roughness.is_some() || t.metallic.is_some(),
                Bsdf::BlinnPhong(_) => t.base_color.is_some() || t.base_color_attribute.is_some(),
                Bsdf::Diffuse(_) | Bsdf::Dielectric(_) => false,
                // Not reached: no pass shades them (the scene is rendered by
                // the general integrator).
                Bsdf::Plastic(_)
                | Bsdf::RoughPlastic(_)
                | Bsdf::ThinDielectric(_)
                | Bsdf::PrincipledThin(_)
                | Bsdf::PrincipledFull(_) => false,
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
        one_sided.push(false);
        smooth.push(false);
        anisotropic.push(false);
        is_virtual.push(false);
        let mut virtual_bounds: Vec<(Vec3, Vec3)> = scene
            .meshes()
            .iter()
            .filter(|m| m.is_virtual && !m.positions.is_empty())
            .map(|m| {
                let lo = m.positions.iter().fold(Vec3::INFINITY, |a, &p| a.min(p));
                let hi = m
                    .positions
                    .iter()
                    .fold(Vec3::NEG_INFINITY, |a, &p| a.max(p));
                (lo, hi)
            })
            .collect();
        if virtual_bounds.len() > 16 {
            let union = virtual_bounds
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &(lo, hi)| {
                    (l.min(lo), h.max(hi))
                });
            virtual_bounds = vec![union];
        }
        let virtual_bounds = virtual_bounds
            .into_iter()
            .map(|(lo, hi)| padded_box(lo, hi))
            .collect();
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
            any_one_sided: one_sided.contains(&true),
            one_sided,
            any_smooth: smooth.contains(&true),
            smooth,
            any_anisotropic: anisotropic.contains(&true),
            anisotropic,
            is_virtual,
            virtual_bounds,
            single_light,
            light_table,
            environment: scene.environment_index(),
            triangle_lights: lights.lights.iter().any(triangle),
            cones: lights.lights.iter().any(cone),
        })
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
pub(super) fn mapped_params(bsdf: &Bsdf) -> [f32; 3] {
    match bsdf {
        Bsdf::CookTorrance(p) => [p.microfacet.alpha_x, p.microfacet.alpha_y, 0.0],
        Bsdf::Principled(p) => [p.roughness, p.metallic, 0.0],
        Bsdf::BlinnPhong(p) => p.diffuse.to_array(),
        Bsdf::Diffuse(_)
        | Bsdf::Dielectric(_)
        | Bsdf::Plastic(_)
        | Bsdf::RoughPlastic(_)
        | Bsdf::ThinDielectric(_)
        | Bsdf::PrincipledThin(_)
        | Bsdf::PrincipledFull(_) => [0.0; 3],
    }
}

/// The BSDF parameters a chunk's lanes take from their materials' maps
/// (`SoaLanes::mapped`).
pub(super) struct ChunkMaps {
    /// Whether the lane's material has a map [`mapped_params`] packs (else
    /// its values are unused).
    pub(super) mapped: [bool; W],
    /// The lanes' [`mapped_params`], one array per component.
    pub(super) values: [[f32; W]; 3],
}

impl ChunkMaps {
    /// The maps of the chunk of `lanes` from `start` (geometry ids `geom`),
    /// `None` where no lane of it has one.
    #[inline(always)]
    pub(super) fn load(
        kernel: &SoaScene,
        lanes: &SoaLanes,
        start: usize,
        geom: &[u32; W],
    ) -> Option<Self> {
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
    pub(super) fn lane(&self, k: usize) -> [f32; 3] {
        [self.values[0][k], self.values[1][k], self.values[2][k]]
    }
}

/// Each geometry's material of kind `K` (by Embree id) where it is one,
/// with one extra `None` that lanes without a hit read.
#[derive(Debug, Clone)]
pub(super) struct KindTable<K> {
    pub(super) by_geometry: Vec<Option<K>>,
    /// Whether any geometry's material is of this kind.
    pub(super) any: bool,
}

impl<K: LaneKind> KindTable<K> {
    /// The table of `scene`'s geometries.
    pub(super) fn new(scene: &Scene) -> KindTable<K> {
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
    pub(super) fn covers(&self, g: usize) -> bool {
        self.by_geometry[g].is_some()
    }

    /// The parameters of a chunk's lanes, by their geometry ids
    /// ([`INVALID_ID`] for no hit), with those their maps give where `maps`
    /// has them.
    #[inline(always)]
    pub(super) fn chunk(&self, geom: &[u32; W], maps: Option<&ChunkMaps>) -> [Option<K>; W] {
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

    /// [`MaterialPass::select`] for a kind whose lanes take their parameters
    /// from this table: the chunk's lanes of this kind and their parameters
    /// (with their maps' values where `mappable` and the scene has maps), or
    /// `None` where the chunk has none.
    #[inline(always)]
    pub(super) fn select(
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
