//! Materials: a BSDF whose parameters may vary over the surface through
//! image textures looked up by UV ([`crate::texture`]).
//!
//! A material's BSDF holds its constant parameters; a texture, where given,
//! replaces one of them at each shading point:
//!
//! | texture | replaces | models |
//! | --- | --- | --- |
//! | `base_color` (sRGB) | the albedo / base colour | `diffuse` (reflectance), `blinn_phong` (diffuse), `principled` (base_color) |
//! | `roughness` (linear, red channel) | roughness (α = r²) | `principled`, `cook_torrance` |
//! | `metallic` (linear, red channel) | metallic | `principled` |
//! | `normal` (linear, tangent space) | the shading normal | all |
//!
//! A normal map holds tangent-space normals (OpenGL and glTF convention:
//! red +x along increasing u, green +y along increasing v, blue +z along
//! the surface normal), decoded when loaded (`2c − 1`, x and y times the
//! map's scale; see [`decode_normal`]). Where a mesh has texture
//! coordinates, the integrators tilt the shading normal by it
//! (`SurfacePoint` in `integrator/mod.rs`); elsewhere it is ignored.

use crate::bsdf::{microfacet::alpha_from_roughness, Bsdf, Microfacet};
use crate::texture::ImageTexture;
use glam::Vec2;
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
    /// Whether light reaching a normal-mapped surface at grazing angles is
    /// attenuated by Estevez et al.'s shadowing term (Mitsuba's
    /// `normalmap` does by default; see `integrator::general`).
    pub normal_shadowing: bool,
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
}

impl Material {
    /// An untextured material.
    pub fn new(name: impl Into<String>, bsdf: Bsdf) -> Material {
        Material {
            name: name.into(),
            bsdf,
            textures: MaterialTextures::default(),
            two_sided: true,
        }
    }

    /// Whether the BSDF depends on the tangent direction at every point
    /// ([`Bsdf::is_anisotropic`] of [`Material::bsdf_at`], the same
    /// everywhere: a roughness map makes a Cook–Torrance surface isotropic,
    /// and no map changes the other models' anisotropy).
    pub fn is_anisotropic(&self) -> bool {
        match self.bsdf {
            Bsdf::CookTorrance(_) if self.textures.roughness.is_some() => false,
            bsdf => bsdf.is_anisotropic(),
        }
    }

    /// Whether a hit whose geometric normal is `ng` (unnormalised), seen
    /// along `dir` (towards the surface), is the black back of a one-sided
    /// surface: the path ends there.
    #[inline(always)]
    pub fn black_from(&self, ng: glam::Vec3, dir: glam::Vec3) -> bool {
        !self.two_sided && !self.bsdf.transmits() && ng.dot(dir) > 0.0
    }

    /// The BSDF at surface coordinates `uv`: the constant BSDF with its
    /// textured parameters looked up.
    #[inline]
    pub fn bsdf_at(&self, uv: Vec2) -> Bsdf {
        let mut bsdf = self.bsdf;
        if self.textures.is_empty() {
            return bsdf;
        }
        let t = &self.textures;
        if let Some(tex) = &t.base_color {
            let c = tex.eval(uv).clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
            match &mut bsdf {
                Bsdf::Diffuse(p) => p.reflectance = c,
                Bsdf::BlinnPhong(p) => p.diffuse = c.min(glam::Vec3::ONE - p.specular),
                Bsdf::Principled(p) => p.base_color = c,
                Bsdf::Plastic(p) => p.diffuse_reflectance = c,
                Bsdf::RoughPlastic(p) => p.diffuse_reflectance = c,
                _ => {}
            }
        }
        if let Some(tex) = &t.roughness {
            let r = tex.eval(uv).x.clamp(0.0, 1.0);
            match &mut bsdf {
                Bsdf::Principled(p) => p.roughness = r,
                Bsdf::CookTorrance(p) => {
                    let a = alpha_from_roughness(r);
                    p.microfacet = Microfacet::new(p.microfacet.kind, a, a);
                }
                _ => {}
            }
        }
        if let Some(tex) = &t.metallic {
            if let Bsdf::Principled(p) = &mut bsdf {
                p.metallic = tex.eval(uv).x.clamp(0.0, 1.0);
            }
        }
        bsdf
    }
}
