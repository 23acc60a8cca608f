//! One triangle of an emissive mesh: a uniform area emitter, optionally
//! limited to a cone of directions (the window function of a parametric light
//! source, paper eq. 12–14).
//!
//! A shape becomes an area light by giving it an `emission`:
//!
//! ```toml
//! [[shapes]]
//! type = "rectangle"
//! emission = [17, 12, 4]   # emitted radiance, W/(m²·sr) per RGB channel
//! two_sided = false        # default: emit on the geometric normal's side only
//! ```
//!
//! A mesh's emission may vary over its surface by a map of its texture
//! coordinates (glTF's emissive texture): each triangle then carries an
//! [`EmissionMap`], its radiance is the constant times the map, and it is
//! picked by its power estimated over the map.
//!
//! The triangles of a tessellated sphere light (the built-in `sphere`
//! shape, Mitsuba's `sphere` emitters) are sampled together by the cone the
//! exact sphere subtends ([`SphereCap`]), as Mitsuba and pbrt sample a
//! sphere: a direction uniform in the cone, the point where its ray meets
//! the mesh. Area sampling wastes the half of the sphere facing away and
//! weighs the rest by `cos/r²`; on Veach's MIS scene it had 3–8 times
//! Mitsuba's variance under the glossy plates.
use super::pls::Cone;
use super::LightSample;
use crate::color::luminance;
use crate::texture::ImageTexture;
use crate::warp::{square_to_uniform_sphere, square_to_uniform_triangle, Frame};
use glam::{Vec2, Vec3};
use std::sync::Arc;

/// A map that multiplies a triangle light's radiance over its surface.
#[derive(Debug, Clone, PartialEq)]
pub struct EmissionMap {
    /// The map (linear RGB factors), looked up by texture coordinates.
    pub texture: Arc<ImageTexture>,
    /// The texture coordinates of the triangle's three vertices.
    pub uv: [Vec2; 3],
    /// The map's mean luminance over the triangle, estimated from 16
    /// stratified points and never below 10⁻³ of the map's largest value
    /// (so that no triangle the map lights is never picked): the factor
    /// of the triangle's power.
    pub mean: f32,
}

impl EmissionMap {
    /// The map over the triangle with vertex coordinates `uv`; `peak` is
    /// the map's largest value ([`ImageTexture::max_value`], found once
    /// for all the triangles of a mesh).
    pub fn new(texture: Arc<ImageTexture>, uv: [Vec2; 3], peak: f32) -> EmissionMap {
        let mut map = EmissionMap {
            texture,
            uv,
            mean: 0.0,
        };
        let mut sum = 0.0;
        for i in 0..4 {
            for j in 0..4 {
                let u = Vec2::new((i as f32 + 0.5) / 4.0, (j as f32 + 0.5) / 4.0);
                sum += luminance(map.at(square_to_uniform_triangle(u))).max(0.0);
            }
        }
        let floor = 1e-3 * peak.max(0.0);
        map.mean = (sum / 16.0).max(floor);
        map
    }

    /// The factor at barycentrics `b` (Embree's: `(1 − b.x − b.y)·p0 +
    /// b.x·p1 + b.y·p2`).
    #[inline]
    pub fn at(&self, b: Vec2) -> Vec3 {
        let [a, c, d] = self.uv;
        self.texture.eval(a * (1.0 - b.x - b.y) + c * b.x + d * b.y)
    }
}

/// A triangle emitting constant radiance.
#[derive(Debug, Clone, PartialEq)]
pub struct TriangleLight {
    /// Vertices (scene units).
    pub p: [Vec3; 3],
    /// Unit geometric normal, the emitting side when one-sided.
    pub n: Vec3,
    /// Area (scene units²).
    pub area: f32,
    /// Emitted radiance, per linear RGB channel.
    pub radiance: Vec3,
    /// Whether both sides emit.
    pub two_sided: bool,
    /// The emission cone of a parametric light source; `None` emits into
    /// the whole hemisphere (a Lambertian emitter).
    pub cone: Option<Cone>,
    /// For a triangle of a tessellated sphere light: the sphere, by whose
    /// cone the group's triangles are sampled together.
    pub sphere: Option<SphereCap>,
    /// A map multiplying `radiance` over the triangle, if any.
    pub map: Option<EmissionMap>,
}

/// The exact sphere a sphere light's mesh is inscribed in, for sampling its
/// triangles together by the cone of directions the sphere subtends.
///
/// The light set picks one of the group's triangles by its share of the
/// group's power; whichever it picks, the sample is a direction uniform in
/// the cone (uniform over all directions from inside the sphere) and the
/// point where that ray meets the mesh, found by tracing it
/// (`integrator::steps::sample_light`). So that the set's pick probability
/// times the sample's density is the group's probability times the cone's,
/// each triangle reports the cone's density divided by its `share`, when
/// sampled and when a BSDF ray hits it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SphereCap {
    /// Centre (scene units).
    pub center: Vec3,
    /// Radius (scene units).
    pub radius: f32,
    /// The mesh's Embree geometry id: a cone sample counts where its ray
    /// first meets this mesh.
    pub geom: u32,
    /// The probability that the light set picks this triangle among its
    /// group's (its share of the group's power).
    pub share: f32,
}

impl SphereCap {
    /// The cone seen from `p`: its unit axis towards the centre and
    /// `1 − cos θmax` (computed as `sin²/(1 + cos)` for far spheres), or
    /// `None` from inside the sphere.
    #[inline]
    fn cone(&self, p: Vec3) -> Option<(Vec3, f32)> {
        let d = self.center - p;
        let dist2 = d.length_squared();
        let r2 = self.radius * self.radius;
        if dist2 <= r2 {
            return None;
        }
        let sin2 = r2 / dist2;
        let cos = (1.0 - sin2).max(0.0).sqrt();
        Some((d / dist2.sqrt(), sin2 / (1.0 + cos)))
    }

    /// A unit direction from `p` uniform in the cone the sphere subtends
    /// (over the whole sphere of directions from inside), and its
    /// solid-angle density.
    #[inline]
    pub fn sample_direction(&self, p: Vec3, u: Vec2) -> (Vec3, f32) {
        let Some((axis, one_minus_cos_max)) = self.cone(p) else {
            return (
                square_to_uniform_sphere(u),
                0.25 * std::f32::consts::FRAC_1_PI,
            );
        };
        let one_minus_cos = u.x * one_minus_cos_max;
        let cos = 1.0 - one_minus_cos;
        let sin = (one_minus_cos * (2.0 - one_minus_cos)).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * u.y;
        let local = Vec3::new(sin * phi.cos(), sin * phi.sin(), cos);
        let pdf = 1.0 / (std::f32::consts::TAU * one_minus_cos_max);
        (Frame::from_normal(axis).to_world(local), pdf)
    }

    /// The density [`SphereCap::sample_direction`] gives the unit direction
    /// `wi` from `p` (0 outside the cone; a direction to the inscribed mesh
    /// is inside it up to rounding, which is allowed for).
    #[inline]
    pub fn pdf(&self, p: Vec3, wi: Vec3) -> f32 {
        let Some((axis, one_minus_cos_max)) = self.cone(p) else {
            return 0.25 * std::f32::consts::FRAC_1_PI;
        };
        if 1.0 - wi.dot(axis) > one_minus_cos_max + 2e-6 {
            return 0.0;
        }
        1.0 / (std::f32::consts::TAU * one_minus_cos_max)
    }
}

impl TriangleLight {
    /// A triangle light; `None` for a degenerate (zero-area) triangle.
    pub fn new(p: [Vec3; 3], radiance: Vec3, two_sided: bool) -> Option<TriangleLight> {
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = c.length();
        (len > 0.0 && len.is_finite()).then(|| TriangleLight {
            p,
            n: c / len,
            area: 0.5 * len,
            radiance,
            two_sided,
            cone: None,
            sphere: None,
            map: None,
        })
    }

    /// The same triangle limited to a cone of emission.
    pub fn with_cone(mut self, cone: Cone) -> TriangleLight {
        self.cone = Some(cone);
        self
    }

    /// Radiance leaving the triangle towards direction `w` (unit, pointing
    /// away from the triangle).
    #[inline]
    pub fn emitted(&self, w: Vec3) -> Vec3 {
        let side = self.two_sided || self.n.dot(w) > 0.0;
        match &self.cone {
            _ if !side => Vec3::ZERO,
            None => self.radiance,
            // A hard cone's window is 0 or 1: the radiance itself, exactly.
            Some(c) if c.soft.is_none() => {
                if c.contains(w) {
                    self.radiance
                } else {
                    Vec3::ZERO
                }
            }
            Some(c) => self.radiance * c.window(w),
        }
    }

    /// Radiance leaving the triangle's point at barycentrics `b` towards
    /// `w`: [`TriangleLight::emitted`] times the map there, if any.
    #[inline]
    pub fn emitted_at(&self, w: Vec3, b: Vec2) -> Vec3 {
        match &self.map {
            None => self.emitted(w),
            Some(m) => self.emitted(w) * m.at(b),
        }
    }

    /// Uniform-area sample converted to solid angle at `p`:
    /// `pdf = r² / (|cos θ_light| · A)` (never for a sphere light's
    /// triangle, which is sampled by tracing: see [`SphereCap`]).
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        let point = TrianglePoint::new(self.p, self.n, self.area, p, u);
        let (valid, sample) = point.sample(self.emitted_at(-point.wi, point.b));
        valid.then_some(sample)
    }

    /// Solid-angle density of [`TriangleLight::sample_li`] for the point `x`
    /// on the triangle seen from `p` along `wi`.
    #[inline]
    /// For a sphere light's triangle, the cone's density over its share
    /// ([`SphereCap`]).
    pub fn pdf_li(&self, p: Vec3, x: Vec3, wi: Vec3) -> f32 {
        if let Some(s) = &self.sphere {
            return if s.share > 0.0 {
                s.pdf(p, wi) / s.share
            } else {
                0.0
            };
        }
        let cos_light = self.n.dot(wi).abs();
        if cos_light == 0.0 {
            return 0.0;
        }
        (x - p).length_squared() / (cos_light * self.area)
    }

    /// Emitted power `π·A·L` (luminance), doubled when two-sided; within a
    /// cone of half-angle `a` around the normal, `π·A·L·sin²a` (a soft edge:
    /// its [`Cone::power_fraction`]).
    pub fn power(&self) -> f32 {
        let sides = if self.two_sided { 2.0 } else { 1.0 };
        let window = self.cone.map_or(1.0, |c| c.power_fraction());
        let map = self.map.as_ref().map_or(1.0, |m| m.mean);
        std::f32::consts::PI * self.area * luminance(self.radiance) * sides * window * map
    }
}

/// A point sampled uniformly on a triangle light, seen from a shading
/// point (uniform over the area; its density converted to solid angle is
/// `r² / (|cos θ_light|·A)`). Branch-free: [`TriangleLight::sample_li`]
/// and the vectorised kernel (per lane) take the same steps, so that their
/// samples agree bit for bit.
#[derive(Debug, Clone, Copy)]
pub struct TrianglePoint {
    /// Unit direction from the shading point to the light point.
    pub wi: Vec3,
    /// The light point's barycentrics (as [`EmissionMap::at`] takes them).
    pub b: Vec2,
    /// Distance and squared distance to the light point.
    pub dist: f32,
    dist2: f32,
    /// Cosine between the light's normal and `−wi`.
    cos_light: f32,
    area: f32,
}

impl TrianglePoint {
    /// The triangle `vertices` with unit normal `n` and area `area` (scene
    /// units²) sampled from `p` with the square sample `u`.
    #[inline(always)]
    pub fn new(vertices: [Vec3; 3], n: Vec3, area: f32, p: Vec3, u: Vec2) -> TrianglePoint {
        let b = square_to_uniform_triangle(u);
        let x = vertices[0] * (1.0 - b.x - b.y) + vertices[1] * b.x + vertices[2] * b.y;
        let d = x - p;
        let dist2 = d.length_squared();
        let dist = dist2.sqrt();
        let wi = d / dist;
        TrianglePoint {
            wi,
            b,
            dist,
            dist2,
            cos_light: n.dot(-wi),
            area,
        }
    }

    /// The light sample for the radiance `radiance` leaving the point
    /// towards the shading point (along `−wi`), and whether it is valid
    /// (non-zero distance, cosine and radiance).
    #[inline(always)]
    pub fn sample(&self, radiance: Vec3) -> (bool, LightSample) {
        let valid = self.dist2 != 0.0 && !(self.cos_light == 0.0 || radiance == Vec3::ZERO);
        let sample = LightSample {
            radiance,
            wi: self.wi,
            dist: self.dist,
            pdf: self.dist2 / (self.cos_light.abs() * self.area),
            delta: false,
        };
        (valid, sample)
    }
}
