//! Light sources and how the integrator samples them.
//!
//! # The light interface
//!
//! - [`Light::sample_li`] picks a point on the light as seen from a shading
//!   point `p` and returns a [`LightSample`]: the incident radiance `radiance`
//!   arriving at `p` along `wi` (for a delta light, the irradiance-producing
//!   quantity `I / r²`), the unit direction `wi` *from `p` towards the light*,
//!   the distance to the sampled point (`∞` for the environment), and the
//!   density `pdf` **separately**,
//!   in solid angle measure at `p` (for a delta light, `pdf = 1` and
//!   `delta = true`). A sample that cannot contribute (back side of a one-sided
//!   emitter, zero area) is `None`, never a zero pdf.
//! - [`Light::pdf_li`] is the solid-angle density `sample_li` would have had
//!   for a direction that a BSDF sample found, the MIS counterpart.
//! - Emitters are one-sided by default: a triangle emits towards the side of
//!   its geometric normal `(p1 − p0) × (p2 − p0)` (counter-clockwise winding
//!   seen from the lit side); `two_sided = true` makes it emit on both.
//!
//! [`LightSet`] picks one light per shading point: first a *group* (a point
//! light, the triangles of one emissive mesh, or the triangles of one
//! parametric light source) with probability proportional to its power among
//! the groups that can reach the point (for a parametric light, the power it
//! would have without its window, `π·A·L`), then a light of the group in
//! proportion to its power. A parametric light whose cone cannot reach the
//! shading point is never picked ([`Reach`]). The integrator divides by the
//! probability returned with the pick ([`LightSet::pick`]) and uses
//! [`LightSet::pick_pmf`] for MIS.

mod envmap;
pub mod pls;
mod point;
mod triangle;

pub use envmap::EnvironmentLight;
pub use pls::{Cone, Reach};
pub use point::{point_light_sample, PointLight};
pub use triangle::{triangle_light_sample, TriangleLight, TrianglePoint};

use crate::color::luminance;

use crate::warp::Distribution1D;
use glam::{Vec2, Vec3};
use std::ops::Range;

/// One light source; a closed set of kinds, dispatched by `match`.
#[derive(Debug, Clone, PartialEq)]
pub enum Light {
    /// An isotropic point light.
    Point(PointLight),
    /// One triangle of an emissive mesh (an area light).
    Triangle(TriangleLight),
    /// An environment at infinity (HDR panorama or constant sky); its
    /// selection power uses `scene_radius`, the radius of the scene's
    /// bounding sphere.
    Environment {
        /// The emitter.
        light: Box<EnvironmentLight>,
        /// Radius of the scene's bounding sphere (scene units).
        scene_radius: f32,
    },
}

/// A point on a light sampled from a shading point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LightSample {
    /// Radiance arriving along `wi` (W/(m²·sr) per RGB channel); for a delta
    /// light, `I / r²`.
    pub radiance: Vec3,
    /// Unit direction from the shading point towards the light point.
    pub wi: Vec3,
    /// Distance from the shading point to the light point.
    pub dist: f32,
    /// Solid-angle density of `wi` (1 for delta lights).
    pub pdf: f32,
    /// Whether the light is a delta distribution (cannot be hit by BSDF rays).
    pub delta: bool,
}

impl Light {
    /// Samples the light from shading point `p` with the uniform pair `u`.
    #[inline]
    pub fn sample_li(&self, p: Vec3, u: Vec2) -> Option<LightSample> {
        match self {
            Light::Point(l) => l.sample_li(p),
            Light::Triangle(l) => l.sample_li(p, u),
            Light::Environment { light, .. } => light.sample_li(u),
        }
    }

    /// Solid-angle density of `sample_li` at `p` for the point `x` on the
    /// light, reached along the unit direction `wi` (0 for delta lights).
    #[inline]
    pub fn pdf_li(&self, p: Vec3, x: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::Point(_) => 0.0,
            Light::Triangle(l) => l.pdf_li(p, x, wi),
            Light::Environment { light, .. } => light.pdf(wi),
        }
    }

    /// Total emitted power (W, luminance-weighted), used to pick lights.
    pub fn power(&self) -> f32 {
        match self {
            Light::Point(l) => l.power(),
            Light::Triangle(l) => l.power(),
            Light::Environment {
                light,
                scene_radius,
            } => light.power(*scene_radius),
        }
    }
}

/// Lights picked together: `lights[range]`, optionally limited in where they
/// can send light.
#[derive(Debug, Clone)]
pub struct LightGroup {
    /// Indices into [`LightSet::lights`].
    pub range: Range<u32>,
    /// Where the group can send light; `None`: everywhere.
    pub reach: Option<Reach>,
    /// Selection weight: emitted power, or for a cone-limited group the
    /// power it would emit without its window.
    power: f32,
    within: Distribution1D,
}

/// All lights of a scene and how one is picked per shading point.
#[derive(Debug, Clone, Default)]
pub struct LightSet {
    /// The lights; the lights of one group are contiguous.
    pub lights: Vec<Light>,
    groups: Vec<LightGroup>,
    group_of: Vec<u32>,
    /// Groups without a reach limit, picked by power.
    everywhere: Distribution1D,
    everywhere_groups: Vec<u32>,
    everywhere_power: f32,
    /// Groups with a reach limit (parametric lights).
    limited_groups: Vec<u32>,
}

impl LightSet {
    /// A light set where every light is its own group, picked by power.
    pub fn new(lights: Vec<Light>) -> LightSet {
        let groups = (0..lights.len() as u32).map(|i| (i..i + 1, None)).collect();
        LightSet::with_groups(lights, groups)
    }

    /// A light set with explicit groups: `(range of lights, reach)`; every
    /// light must be in exactly one group, in order.
    pub fn with_groups(lights: Vec<Light>, groups: Vec<(Range<u32>, Option<Reach>)>) -> LightSet {
        let mut group_of = vec![u32::MAX; lights.len()];
        let mut built = Vec::with_capacity(groups.len());
        for (g, (range, reach)) in groups.into_iter().enumerate() {
            let powers: Vec<f32> = lights[range.start as usize..range.end as usize]
                .iter()
                .map(Light::power)
                .collect();
            for i in range.clone() {
                group_of[i as usize] = g as u32;
            }
            let total: f32 = powers.iter().map(|&p| p.max(0.0)).sum();
            // A cone-limited group is weighted by the power it would have
            // without its window (π·A·L): wherever it reaches, a point gets its
            // full radiance, so a narrow beam must not be picked less often
            // than a wide one of the same radiance and area.
            let weight = match &reach {
                Some(r) if r.sin_a() > 0.0 => total / (r.sin_a() * r.sin_a()),
                _ => total,
            };
            built.push(LightGroup {
                power: weight,
                within: Distribution1D::new(&powers),
                range,
                reach,
            });
        }
        assert!(
            group_of.iter().all(|&g| g != u32::MAX),
            "every light must be in a group"
        );
        let everywhere_groups: Vec<u32> = (0..built.len() as u32)
            .filter(|&g| built[g as usize].reach.is_none())
            .collect();
        let limited_groups = (0..built.len() as u32)
            .filter(|&g| built[g as usize].reach.is_some())
            .collect();
        let weights: Vec<f32> = everywhere_groups
            .iter()
            .map(|&g| built[g as usize].power)
            .collect();
        LightSet {
            everywhere: Distribution1D::new(&weights),
            everywhere_power: weights.iter().sum(),
            everywhere_groups,
            limited_groups,
            groups: built,
            group_of,
            lights,
        }
    }

    /// Multiplies the emission of the lights `range` by `factor` (per
    /// channel; an environment takes its first channel, as it has one scale)
    /// and recomputes the selection weights, which follow their power.
    pub fn scale_emission(&mut self, range: Range<usize>, factor: Vec3) {
        self.edit(|lights| {
            for light in &mut lights[range] {
                match light {
                    Light::Point(l) => l.intensity *= factor,
                    Light::Triangle(l) => l.radiance *= factor,
                    Light::Environment { light, .. } => light.scale_radiance(factor.x),
                }
            }
        });
    }

    /// Changes the lights in place (their emission, a triangle's cone; not
    /// their number or kind) and recomputes what depends on them: the
    /// selection weights, and the reach of each cone-limited group from
    /// its first triangle's cone.
    pub fn edit(&mut self, f: impl FnOnce(&mut [Light])) {
        let mut lights = std::mem::take(&mut self.lights);
        f(&mut lights);
        let groups = self
            .groups
            .iter()
            .map(|g| {
                let reach = g.reach.as_ref().map(|old| {
                    let range = g.range.start as usize..g.range.end as usize;
                    let cone = match &lights[range.start] {
                        Light::Triangle(t) => t.cone.unwrap_or(*old.cone()),
                        _ => *old.cone(),
                    };
                    let tris = lights[range]
                        .iter()
                        .filter_map(|l| match l {
                            Light::Triangle(t) => Some(t.p),
                            _ => None,
                        })
                        .collect();
                    Reach::new(cone, tris)
                });
                (g.range.clone(), reach)
            })
            .collect();
        *self = LightSet::with_groups(lights, groups);
    }

    /// Whether the scene has no light that can be sampled.
    pub fn is_empty(&self) -> bool {
        self.groups.iter().all(|g| g.power <= 0.0)
    }

    #[inline]
    fn limited_power(&self, g: u32, p: Vec3) -> f32 {
        let group = &self.groups[g as usize];
        match &group.reach {
            Some(r) if group.power > 0.0 && r.can_reach(p) => group.power,
            _ => 0.0,
        }
    }

    /// Which of the first 64 cone-limited groups can reach `p` (bit `k` for
    /// `limited_groups[k]`; the rest are recomputed when needed) and the
    /// total selection weight at `p`.
    #[inline]
    fn weights_at(&self, p: Vec3) -> (u64, f32) {
        let mut reaches = 0u64;
        let mut total = self.everywhere_power;
        for (k, &g) in self.limited_groups.iter().enumerate() {
            let x = self.limited_power(g, p);
            if k < 64 && x > 0.0 {
                reaches |= 1 << k;
            }
            total += x;
        }
        (reaches, total)
    }

    #[inline]
    fn total_power(&self, p: Vec3) -> f32 {
        if self.limited_groups.is_empty() {
            return self.everywhere_power;
        }
        self.weights_at(p).1
    }

    /// Picks a light for shading point `p`: `u.x` picks the group, `u.y` the
    /// light within it. Returns `(light index, probability)`. Lights that
    /// cannot reach `p` are never picked.
    #[inline(always)]
    pub fn pick(&self, p: Vec3, u: Vec2) -> Option<(usize, f32)> {
        if self.limited_groups.is_empty() {
            // No spatially varying group: a fixed distribution.
            let (k, _) = self.everywhere.sample(u.x)?;
            let g = &self.groups[self.everywhere_groups[k] as usize];
            let (i, pi) = g.within.sample(u.y)?;
            // Computed as pick_pmf computes it, so MIS sees the same value.
            return Some((
                g.range.start as usize + i,
                g.power / self.everywhere_power * pi,
            ));
        }
        let (reaches, _) = self.weights_at(p);
        self.pick_among(reaches, p, u)
    }

    /// The cone-limited groups in the order [`LightSet::pick_among`]'s mask
    /// numbers them: each one's reach, or `None` for a group that never
    /// reaches anything (no power).
    pub fn limited_reaches(&self) -> impl ExactSizeIterator<Item = Option<&Reach>> {
        self.limited_groups.iter().map(|&g| {
            let group = &self.groups[g as usize];
            group.reach.as_ref().filter(|_| group.power > 0.0)
        })
    }

    /// [`LightSet::pick`] at point `p`, where the first 64 cone-limited
    /// groups that can reach `p` are given by the bits of `reaches` (bit `k`
    /// for the `k`-th of [`LightSet::limited_reaches`]; any further groups
    /// are tested here), for a caller that tests the reach of many points at
    /// once. The same light and probability as `pick`.
    #[inline(always)]
    pub fn pick_among(&self, reaches: u64, p: Vec3, u: Vec2) -> Option<(usize, f32)> {
        if self.limited_groups.is_empty() {
            return self.pick(p, u);
        }
        self.pick_where(
            |k, g| {
                if k < 64 {
                    reaches >> k & 1 == 1
                } else {
                    self.limited_power(g, p) > 0.0
                }
            },
            u,
        )
    }

    /// The pick among the everywhere-groups and the cone-limited groups for
    /// which `reaches(k, group)` holds (`k`-th cone-limited group).
    #[inline(always)]
    fn pick_where(&self, reaches: impl Fn(usize, u32) -> bool, u: Vec2) -> Option<(usize, f32)> {
        // The total weight, summed in the order `weights_at` sums it (a
        // group that cannot reach adds nothing).
        let mut total = self.everywhere_power;
        for (k, &g) in self.limited_groups.iter().enumerate() {
            if reaches(k, g) {
                total += self.groups[g as usize].power;
            }
        }
        if total <= 0.0 {
            return None;
        }
        let mut target = u.x * total;
        let group = if target < self.everywhere_power {
            let (k, _) = self.everywhere.sample(target / self.everywhere_power)?;
            self.everywhere_groups[k]
        } else {
            target -= self.everywhere_power;
            let mut chosen = None;
            for (k, &g) in self.limited_groups.iter().enumerate() {
                if reaches(k, g) {
                    let w = self.groups[g as usize].power;
                    chosen = Some(g);
                    if target < w {
                        break;
                    }
                    target -= w;
                }
            }
            chosen?
        };
        let g = &self.groups[group as usize];
        let (k, pk) = g.within.sample(u.y)?;
        Some((g.range.start as usize + k, g.power / total * pk))
    }

    /// Whether the light-picking distribution is the same at every point
    /// (no group has a reach limit).
    pub fn is_spatially_uniform(&self) -> bool {
        self.limited_groups.is_empty()
    }

    /// Probability that [`LightSet::pick`] returns light `index` at `p`.
    #[inline]
    pub fn pick_pmf(&self, index: usize, p: Vec3) -> f32 {
        let g = self.group_of[index];
        let group = &self.groups[g as usize];
        let w = if group.reach.is_some() {
            self.limited_power(g, p)
        } else {
            group.power
        };
        if w <= 0.0 {
            return 0.0;
        }
        w / self.total_power(p) * group.within.pmf(index - group.range.start as usize)
    }
}
