//! Materials: a BSDF whose parameters may vary over the surface through
//! image textures looked up by UV ([`crate::texture`]).
//!
//! A material's BSDF holds its constant parameters; a texture, where given,
//! replaces one of them at each shading point:
//!
//! | texture | replaces | models |
//! | --- | --- | --- |
//! | `base_color` (sRGB) | the albedo / base colour | `diffuse` (reflectance), `blinn_phong` (diffuse), `principled` (base_color), plastics (diffuse_reflectance) |
//! | `base_color_attribute` (the mesh's colours) | multiplies the base colour | as `base_color` |
//! | `roughness` (linear, red channel) | roughness (α = r²) | `principled`, `principled_thin`, `cook_torrance` |
//! | `metallic` (linear, red channel) | metallic | `principled` |
//! | `normal` (linear, tangent space) | the shading normal | all |
//! | `bump` (linear height, luminance) | the shading normal, by its slopes | all |
//! | `alpha_u`, `alpha_v` (linear, luminance) | microfacet α along each tangent | `cook_torrance`, rough `dielectric` |
//! | `scalars` (linear, luminance; [`ScalarParam`]) | one named weight each (`anisotropic`, `specular`, `spec_tint`, `spec_trans`, `sheen`, `sheen_tint`, `flatness`, `clearcoat`, `clearcoat_gloss`) | `principled`, `principled_thin` |
//!
//! A normal map holds tangent-space normals (OpenGL and glTF convention:
//! red +x along increasing u, green +y along increasing v, blue +z along
//! the surface normal), decoded when loaded (`2c − 1`, x and y times the
//! map's scale; see [`decode_normal`]). Where a mesh has texture
//! coordinates, the integrators tilt the shading normal by it
//! (`SurfacePoint` in `integrator/mod.rs`); elsewhere it is ignored.

use crate::bsdf::{microfacet::alpha_from_roughness, Bsdf, Microfacet, Mixture, Scatter};
use crate::texture::ImageTexture;
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// Textures that replace BSDF parameters over a surface.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct MaterialTextures {
    /// Base colour (linear RGB after sRGB decoding).
    pub base_color: Option<Arc<ImageTexture>>,
    /// Roughness in `[0, 1]` (red channel).
    pub roughness: Option<Arc<ImageTexture>>,
    /// Metallic in `[0, 1]` (red channel).
    pub metallic: Option<Arc<ImageTexture>>,
    /// Tangent-space normals, decoded (see [`decode_normal`]).
    pub normal: Option<Arc<ImageTexture>>,
    /// The tangent frame the normal map's directions are in.
    pub normal_frame: NormalFrame,
    /// Whether light reaching a normal- or bump-mapped surface at grazing
    /// angles is attenuated by Estevez et al.'s shadowing term (Mitsuba's
    /// `normalmap` and `bumpmap` do by default; see `integrator::general`).
    pub normal_shadowing: bool,
    /// Whether the shading normal is bent, where it must be, so that the
    /// mirror reflection of the viewing direction stays above the surface
    /// (as Cycles does; see `integrator::steps::valid_reflection_normal`):
    /// without it a smooth normal-mapped metal shows black rings where the
    /// map tilts the normal away from the viewer. glTF's normal-mapped
    /// materials set it.
    pub valid_reflection: bool,
    /// A height field whose slopes tilt the shading normal (Mitsuba's
    /// `bumpmap`): its luminance, in scene units per unit of `uv`, times
    /// `bump_scale`.
    pub bump: Option<Arc<ImageTexture>>,
    /// The height field's scale (Mitsuba's `scale`).
    pub bump_scale: f32,
    /// Microfacet α along the first tangent (luminance; Mitsuba's
    /// textured `alpha_u`, or `alpha` for both), replacing the constant
    /// one of a `cook_torrance` or rough `dielectric`.
    pub alpha_u: Option<Arc<ImageTexture>>,
    /// Microfacet α along the second tangent (the same map as `alpha_u`
    /// for an isotropic `alpha_map`).
    pub alpha_v: Option<Arc<ImageTexture>>,
    /// The name of the mesh colours (`vertex_color`, `face_color`, …) that
    /// multiply the base colour (Mitsuba's `mesh_attribute`, glTF's
    /// `COLOR_0`); the shape's loader finds them in its file and stores
    /// them in [`Mesh::colors`](crate::scene::Mesh::colors).
    pub base_color_attribute: Option<String>,
    /// Maps of the principled models' weights, one per parameter (none
    /// twice), each replacing the constant where the model has it.
    pub scalars: Vec<ScalarMap>,
}

/// A weight in `[0, 1]` of the principled models that a map may replace
/// (Mitsuba textures every parameter of `principled` and
/// `principledthin`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ScalarParam {
    /// `anisotropic` (`principled`, `principled_thin`).
    Anisotropic,
    /// `specular` (`principled`).
    Specular,
    /// `spec_tint` (`principled`, `principled_thin`).
    SpecTint,
    /// `spec_trans` (`principled`, `principled_thin`).
    SpecTrans,
    /// `sheen` (`principled`, `principled_thin`).
    Sheen,
    /// `sheen_tint` (`principled`, `principled_thin`).
    SheenTint,
    /// `flatness` (`principled`, `principled_thin`).
    Flatness,
    /// `clearcoat` (`principled`).
    Clearcoat,
    /// `clearcoat_gloss` (`principled`).
    ClearcoatGloss,
}

impl ScalarParam {
    /// The parameter's name (its map's key is the name and `_map`).
    pub fn name(self) -> &'static str {
        match self {
            ScalarParam::Anisotropic => "anisotropic",
            ScalarParam::Specular => "specular",
            ScalarParam::SpecTint => "spec_tint",
            ScalarParam::SpecTrans => "spec_trans",
            ScalarParam::Sheen => "sheen",
            ScalarParam::SheenTint => "sheen_tint",
            ScalarParam::Flatness => "flatness",
            ScalarParam::Clearcoat => "clearcoat",
            ScalarParam::ClearcoatGloss => "clearcoat_gloss",
        }
    }

    /// `bsdf` with this parameter set to `v` (clamped to `[0, 1]`);
    /// unchanged for a model without it.
    pub fn set(self, bsdf: &mut Bsdf, v: f32) {
        let v = v.clamp(0.0, 1.0);
        match (bsdf, self) {
            (Bsdf::Principled(p), ScalarParam::Anisotropic) => p.anisotropic = v,
            (Bsdf::Principled(p), ScalarParam::Specular) => p.specular = v,
            (Bsdf::Principled(p), ScalarParam::SpecTint) => p.spec_tint = v,
            (Bsdf::PrincipledThin(p), ScalarParam::Anisotropic) => p.anisotropic = v,
            (Bsdf::PrincipledThin(p), ScalarParam::SpecTint) => p.spec_tint = v,
            (Bsdf::PrincipledThin(p), ScalarParam::SpecTrans) => p.spec_trans = v,
            (Bsdf::PrincipledThin(p), ScalarParam::Sheen) => p.sheen = v,
            (Bsdf::PrincipledThin(p), ScalarParam::SheenTint) => p.sheen_tint = v,
            (Bsdf::PrincipledThin(p), ScalarParam::Flatness) => p.flatness = v,
            (Bsdf::PrincipledFull(p), param) => match param {
                ScalarParam::Anisotropic => p.anisotropic = v,
                ScalarParam::Specular => p.eta = crate::bsdf::albedo::eta_from_specular(v),
                ScalarParam::SpecTint => p.spec_tint = v,
                ScalarParam::SpecTrans => p.spec_trans = v,
                ScalarParam::Sheen => p.sheen = v,
                ScalarParam::SheenTint => p.sheen_tint = v,
                ScalarParam::Flatness => p.flatness = v,
                ScalarParam::Clearcoat => p.clearcoat = v,
                ScalarParam::ClearcoatGloss => p.clearcoat_gloss = v,
            },
            _ => {}
        }
    }
}

/// A map of one [`ScalarParam`] (its luminance, linear).
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarMap {
    /// The parameter it replaces.
    pub param: ScalarParam,
    /// Its values in `[0, 1]`.
    pub texture: Arc<ImageTexture>,
}

/// The tangent frame of a normal map: its x axis is always along ∂p/∂u
/// (made orthogonal to the normal); its y axis follows the texture
/// coordinates or the normal.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum NormalFrame {
    /// y along ∂p/∂v (glTF's and OpenGL's convention, as MikkTSpace bakes
    /// it): mirrored texture coordinates mirror the tilt.
    #[default]
    Uv,
    /// y = normal × x (Mitsuba's `normalmap`, in its shading frame),
    /// whichever way v runs.
    Tangent,
}

/// A normal map's texel decoded to a tangent-space direction: `2c − 1`,
/// with x and y times `scale` (glTF's `normalTexture.scale`; 1 for none).
/// Not normalised (the integrators normalise after filtering).
#[inline]
pub fn decode_normal(c: glam::Vec3, scale: f32) -> glam::Vec3 {
    let v = 2.0 * c - glam::Vec3::ONE;
    glam::Vec3::new(v.x * scale, v.y * scale, v.z)
}

impl MaterialTextures {
    /// Whether no parameter is textured.
    pub fn is_empty(&self) -> bool {
        self.base_color.is_none()
            && self.roughness.is_none()
            && self.metallic.is_none()
            && self.normal.is_none()
            && self.bump.is_none()
            && self.alpha_u.is_none()
            && self.base_color_attribute.is_none()
            && self.scalars.is_empty()
    }

    /// Whether the shadow terminator applies: a normal or bump map with
    /// `normal_shadowing`.
    pub fn terminator(&self) -> bool {
        self.normal_shadowing && (self.normal.is_some() || self.bump.is_some())
    }
}

/// A named material.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// Name used by shapes to refer to it.
    pub name: String,
    /// Its scattering model, with the constant parameters.
    pub bsdf: Bsdf,
    /// Textured parameters, if any.
    pub textures: MaterialTextures,
    /// Whether an opaque BSDF scatters on both sides of the surface (plsr's
    /// default); `false`: the surface is black seen from behind its
    /// geometric normal (the side its triangles' winding faces away from),
    /// as Mitsuba renders a BSDF without `twosided`. Transmissive BSDFs
    /// have two sides whatever this says.
    pub two_sided: bool,
    /// A mixture of materials and a pass-through (`blend`, `mask`, `null`,
    /// or another material behind: see [`Composite`]); then `bsdf` and
    /// `textures` are its first part's and only the surface's normal map
    /// applies from `textures`.
    pub composite: Option<Arc<Composite>>,
}

/// A material made of others: per side of the surface, layers each of
/// which is a leaf material or a straight pass-through, with weights that
/// sum to 1 (see [`crate::bsdf::mixture`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Composite {
    /// The layers seen from the front (the side the geometric normal
    /// faces), and from behind unless `back` is given.
    pub front: Vec<Layer>,
    /// The layers seen from behind, where the two sides differ.
    pub back: Option<Vec<Layer>>,
}

/// One layer of a [`Composite`].
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    /// The leaf material (its own textures; never a composite), or `None`
    /// for a straight pass-through (Mitsuba's `null`).
    pub material: Option<Material>,
    /// Its weight: a product of constants and scalar maps.
    pub weight: Weight,
}

/// A layer's weight at a surface point: the product of its factors.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Weight(pub Vec<WeightFactor>);

/// One factor of a [`Weight`].
#[derive(Debug, Clone, PartialEq)]
pub enum WeightFactor {
    /// A constant in `[0, 1]`.
    Constant(f32),
    /// A map's luminance at the point, clamped to `[0, 1]`, or one minus
    /// it (`complement`).
    Map {
        /// The map (linear values).
        map: Arc<ImageTexture>,
        /// Whether the factor is `1 − value`.
        complement: bool,
    },
}

impl Weight {
    /// The weight at surface coordinates `uv`.
    #[inline]
    pub fn at(&self, uv: Vec2) -> f32 {
        self.0.iter().fold(1.0, |w, f| {
            w * match f {
                WeightFactor::Constant(c) => *c,
                WeightFactor::Map { map, complement } => {
                    let v = crate::color::luminance(map.eval(uv)).clamp(0.0, 1.0);
                    if *complement {
                        1.0 - v
                    } else {
                        v
                    }
                }
            }
        })
    }

    /// Whether a factor is a map (the weight needs texture coordinates).
    pub fn is_mapped(&self) -> bool {
        self.0.iter().any(|f| matches!(f, WeightFactor::Map { .. }))
    }

    /// This weight times `factor`.
    pub fn times(&self, factor: WeightFactor) -> Weight {
        let mut w = self.clone();
        w.0.push(factor);
        w
    }
}

impl Composite {
    /// Every leaf material, front then back.
    pub fn leaves(&self) -> impl Iterator<Item = &Material> {
        self.front
            .iter()
            .chain(self.back.iter().flatten())
            .filter_map(|l| l.material.as_ref())
    }

    /// Whether light can pass through the surface: a pass-through layer or
    /// a transmissive leaf.
    pub fn transmits(&self) -> bool {
        self.front
            .iter()
            .chain(self.back.iter().flatten())
            .any(|l| l.material.as_ref().is_none_or(|m| m.bsdf.transmits()))
    }

    /// Whether some weight or leaf needs texture coordinates.
    pub fn needs_uv(&self) -> bool {
        self.front
            .iter()
            .chain(self.back.iter().flatten())
            .any(|l| {
                l.weight.is_mapped() || l.material.as_ref().is_some_and(|m| !m.textures.is_empty())
            })
    }

    /// The mixture at `uv` (the mesh's colour `color` there) seen from the
    /// front or from `behind`: the side's
    /// layers with their weights; on the back, a leaf without two sides is
    /// black (its weight absorbed), and where the mixture transmits (the
    /// frame is the geometric outside) the others are mirrored. `None` if
    /// the side has more parts than a [`Mixture`] holds.
    pub fn scatter_at(&self, uv: Vec2, color: Vec3, behind: bool) -> Option<Scatter> {
        let layers = match (&self.back, behind) {
            (Some(back), true) => back,
            _ => &self.front,
        };
        let transmits = self.transmits();
        let mut mix = Mixture::new();
        for layer in layers {
            let w = layer.weight.at(uv);
            match &layer.material {
                None => mix.pass_through(w),
                Some(m) => {
                    let opaque = !m.bsdf.transmits();
                    // A separate back side's leaves face the viewer there.
                    let own_side = behind && self.back.is_some();
                    if behind && opaque && !own_side && !m.two_sided {
                        continue;
                    }
                    let flip = behind && opaque && transmits;
                    if !mix.push(m.bsdf_at(uv, color), w, flip) {
                        return None;
                    }
                }
            }
        }
        Some(Scatter::Mix(mix))
    }
}

impl Material {
    /// An untextured material.
    pub fn new(name: impl Into<String>, bsdf: Bsdf) -> Material {
        Material {
            name: name.into(),
            bsdf,
            textures: MaterialTextures::default(),
            two_sided: true,
            composite: None,
        }
    }

    /// Whether light can pass through the surface.
    pub fn transmits(&self) -> bool {
        match &self.composite {
            Some(c) => c.transmits(),
            None => self.bsdf.transmits(),
        }
    }

    /// Whether shading needs the texture coordinates at the hit.
    pub fn needs_uv(&self) -> bool {
        !self.textures.is_empty() || self.composite.as_ref().is_some_and(|c| c.needs_uv())
    }

    /// The scattering at `uv` (where the mesh's colour is `color`), seen
    /// from the front or from `behind` the geometric normal:
    /// [`Material::bsdf_at`], or a composite's mixture.
    #[inline]
    pub fn scatter_at(&self, uv: Vec2, color: Vec3, behind: bool) -> Scatter {
        match &self.composite {
            None => Scatter::One(self.bsdf_at(uv, color)),
            // A side with too many parts is refused when the scene is built.
            Some(c) => c
                .scatter_at(uv, color, behind)
                .unwrap_or(Scatter::Mix(Mixture::new())),
        }
    }

    /// Whether the BSDF depends on the tangent direction at every point
    /// ([`Bsdf::is_anisotropic`] of [`Material::bsdf_at`], the same
    /// everywhere: a roughness map makes a Cook–Torrance surface isotropic,
    /// and no map changes the other models' anisotropy).
    pub fn is_anisotropic(&self) -> bool {
        if let (Some(u), Some(v)) = (&self.textures.alpha_u, &self.textures.alpha_v) {
            return !Arc::ptr_eq(u, v);
        }
        let anisotropy_mapped = self
            .textures
            .scalars
            .iter()
            .any(|m| m.param == ScalarParam::Anisotropic);
        match self.bsdf {
            Bsdf::CookTorrance(_) if self.textures.roughness.is_some() => false,
            Bsdf::Principled(_) | Bsdf::PrincipledThin(_) | Bsdf::PrincipledFull(_)
                if anisotropy_mapped =>
            {
                true
            }
            bsdf => bsdf.is_anisotropic(),
        }
    }

    /// Whether a hit whose geometric normal is `ng` (unnormalised), seen
    /// along `dir` (towards the surface), is the black back of a one-sided
    /// surface: the path ends there.
    #[inline(always)]
    pub fn black_from(&self, ng: glam::Vec3, dir: glam::Vec3) -> bool {
        !self.two_sided && self.composite.is_none() && !self.bsdf.transmits() && ng.dot(dir) > 0.0
    }

    /// The BSDF at surface coordinates `uv` where the mesh's colour is
    /// `color` (`Vec3::ONE` where it has none): the constant BSDF with its
    /// textured parameters looked up. A base colour from a map or the
    /// mesh is clamped to `[0, 1]`.
    #[inline]
    pub fn bsdf_at(&self, uv: Vec2, color: Vec3) -> Bsdf {
        let mut bsdf = self.bsdf;
        if self.textures.is_empty() {
            return bsdf;
        }
        let t = &self.textures;
        let base = t
            .base_color
            .as_ref()
            .map(|tex| tex.eval(uv).clamp(Vec3::ZERO, Vec3::ONE));
        if base.is_some() || t.base_color_attribute.is_some() {
            // The map's colour (or the constant one) times the mesh's.
            let tint = match t.base_color_attribute {
                Some(_) => color,
                None => Vec3::ONE,
            };
            if let Some(constant) = bsdf.base_color() {
                let c = base.unwrap_or(constant) * tint;
                bsdf = bsdf.with_base_color(c.clamp(Vec3::ZERO, Vec3::ONE));
            }
        }
        if let Some(tex) = &t.roughness {
            let r = tex.eval(uv).x.clamp(0.0, 1.0);
            match &mut bsdf {
                Bsdf::Principled(p) => p.roughness = r,
                Bsdf::PrincipledThin(p) => p.roughness = r,
                Bsdf::PrincipledFull(p) => p.roughness = r,
                Bsdf::CookTorrance(p) => {
                    let a = alpha_from_roughness(r);
                    p.microfacet = Microfacet::new(p.microfacet.kind, a, a);
                }
                _ => {}
            }
        }
        if let Some(tex) = &t.metallic {
            let metallic = tex.eval(uv).x.clamp(0.0, 1.0);
            match &mut bsdf {
                Bsdf::Principled(p) => p.metallic = metallic,
                Bsdf::PrincipledFull(p) => p.metallic = metallic,
                _ => {}
            }
        }
        if let (Some(u), Some(v)) = (&t.alpha_u, &t.alpha_v) {
            let au = crate::color::luminance(u.eval(uv)).max(0.0);
            let av = if Arc::ptr_eq(u, v) {
                au
            } else {
                crate::color::luminance(v.eval(uv)).max(0.0)
            };
            match &mut bsdf {
                Bsdf::CookTorrance(p) => p.microfacet = Microfacet::new(p.microfacet.kind, au, av),
                Bsdf::Dielectric(p) => {
                    if let Some(m) = &mut p.microfacet {
                        *m = Microfacet::new(m.kind, au, av);
                    }
                }
                _ => {}
            }
        }
        for map in &t.scalars {
            map.param
                .set(&mut bsdf, crate::color::luminance(map.texture.eval(uv)));
        }
        bsdf
    }
}
