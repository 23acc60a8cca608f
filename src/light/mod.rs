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
//! proportion to its power. Where a scene has 2 to [`MAX_SPATIAL_GROUPS`]
//! groups at a finite distance, each group's power is further weighted by an
//! upper bound on what it can send to the point given its distance and which
//! way it faces ([`LightBounds`]). A parametric light whose cone cannot reach the
//! shading point is never picked ([`Reach`]). The integrator divides by the
//! probability returned with the pick ([`LightSet::pick`]) and uses
//! [`LightSet::pick_pmf`] for MIS. [`LightPicking`] chooses between that
//! (`Spatial`, the default), power alone (`Power`) and Mitsuba's rule, every
//! group equally likely (`Uniform`).

mod bounds;
mod directional;
mod envmap;
pub mod pls;
mod point;
mod projection;
mod triangle;

pub use bounds::LightBounds;
pub use directional::DirectionalLight;
pub use envmap::EnvironmentLight;
pub use pls::{Cone, Reach};
pub use point::{point_light_sample, spot_cone, PointLight};
pub use projection::{Projection, ProjectionKind};
pub use triangle::{EmissionMap, SphereCap, TriangleLight, TrianglePoint};

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
    /// Parallel light from one direction (a delta distribution); its
    /// selection power uses `scene_radius`, as the environment's does.
    Directional {
        /// The emitter.
        light: DirectionalLight,
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
            Light::Directional { light, .. } => light.sample_li(),
        }
    }

    /// Solid-angle density of `sample_li` at `p` for the point `x` on the
    /// light, reached along the unit direction `wi` (0 for delta lights).
    #[inline]
    pub fn pdf_li(&self, p: Vec3, x: Vec3, wi: Vec3) -> f32 {
        match self {
            Light::Point(_) | Light::Directional { .. } => 0.0,
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
            Light::Directional {
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
    /// power it would emit without its window; with
    /// [`LightPicking::Uniform`], 1 for a group that emits at all.
    power: f32,
    within: Distribution1D,
    /// Where the group's lights are and which way they face (`None` for
    /// the environment, which is everywhere).
    bounds: Option<LightBounds>,
}

/// How [`LightSet`] picks a group of lights at a shading point. All three
/// are unbiased; they differ in noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LightPicking {
    /// By power, and among groups at a finite distance by power times a
    /// bound on what each can send to the point (the default).
    #[default]
    Spatial,
    /// By power alone.
    Power,
    /// Every group that can reach the point equally likely, as Mitsuba 3
    /// picks emitters (each emissive shape, point light or environment is
    /// one group); within a group, by power.
    Uniform,
}

impl LightPicking {
    /// The name used in scene files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            LightPicking::Spatial => "spatial",
            LightPicking::Power => "power",
            LightPicking::Uniform => "uniform",
        }
    }

    /// The rule named `name` (see [`LightPicking::name`]).
    pub fn from_name(name: &str) -> Option<LightPicking> {
        [
            LightPicking::Spatial,
            LightPicking::Power,
            LightPicking::Uniform,
        ]
        .into_iter()
        .find(|p| p.name() == name)
    }
}

/// The most groups at a finite distance for which [`LightSet`] weighs each
/// group by its bound at the shading point ([`LightBounds::importance`]);
/// with more, each pick would cost too much and it picks by power alone.
pub const MAX_SPATIAL_GROUPS: usize = 32;

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
    /// Whether groups are weighed by distance and orientation at the
    /// shading point (2 to [`MAX_SPATIAL_GROUPS`] groups at a finite
    /// distance); see [`LightSet::pick`].
    spatial: bool,
    /// The rule the user asked for ([`LightSet::with_picking`]; kept
    /// through [`LightSet::edit`]).
    picking: LightPicking,
    /// The environment's groups and their total power (spatial picking).
    env_groups: Vec<u32>,
    env_power: f32,
    /// The groups at a finite distance, each with its index among the
    /// cone-limited groups if it is one (spatial picking).
    local_groups: Vec<(u32, Option<u32>)>,
}

/// The selection weights of the groups at a finite distance at one shading
/// point, for spatial picking.
struct LocalWeights {
    /// Each local group's power times its importance at the point.
    importance: [f32; MAX_SPATIAL_GROUPS],
    /// Their sum.
    importance_sum: f32,
    /// The power of the local groups that can reach the point: their share
    /// against the environment (0 where none can send light there).
    power: f32,
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
        LightSet::with_groups_picked_by(lights, groups, LightPicking::Spatial)
    }

    /// [`LightSet::with_groups`] picked by `picking`.
    pub fn with_groups_picked_by(
        lights: Vec<Light>,
        groups: Vec<(Range<u32>, Option<Reach>)>,
        picking: LightPicking,
    ) -> LightSet {
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
                _ if picking == LightPicking::Uniform => {
                    if total > 0.0 {
                        1.0
                    } else {
                        0.0
                    }
                }
                Some(r) if r.sin_a() > 0.0 => total / (r.sin_a() * r.sin_a()),
                _ => total,
            };
            let members = &lights[range.start as usize..range.end as usize];
            let bounds = match members {
                [Light::Point(l)] => Some(LightBounds::point(l.position)),
                _ => {
                    let triangles = members.iter().filter_map(|l| match l {
                        Light::Triangle(t) => Some((t.p, t.n, t.area)),
                        _ => None,
                    });
                    let two_sided = members
                        .iter()
                        .any(|l| matches!(l, Light::Triangle(t) if t.two_sided));
                    let only_triangles = members.iter().all(|l| matches!(l, Light::Triangle(_)));
                    only_triangles
                        .then(|| LightBounds::triangles(triangles, two_sided))
                        .flatten()
                }
            };
            built.push(LightGroup {
                power: weight,
                within: Distribution1D::new(&powers),
                range,
                reach,
                bounds,
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
        let (mut env_groups, mut local_groups, mut unplaced) = (Vec::new(), Vec::new(), 0);
        let mut limited_k = 0;
        for (g, group) in built.iter().enumerate() {
            let k = group.reach.is_some().then(|| {
                limited_k += 1;
                limited_k - 1
            });
            let range = group.range.start as usize..group.range.end as usize;
            if group.bounds.is_some() {
                local_groups.push((g as u32, k));
            } else if matches!(
                lights[range],
                [Light::Environment { .. } | Light::Directional { .. }]
            ) {
                env_groups.push(g as u32);
            } else {
                unplaced += 1;
            }
        }
        let env_power = env_groups.iter().map(|&g| built[g as usize].power).sum();
        let lit = local_groups
            .iter()
            .filter(|&&(g, _)| built[g as usize].power > 0.0)
            .count();
        // Weighing groups by where they are pays only where there is a
        // choice among them; with a group the bounds cannot place (a mix of
        // kinds), picking stays by power.
        let spatial = picking == LightPicking::Spatial
            && (2..=MAX_SPATIAL_GROUPS).contains(&local_groups.len())
            && lit >= 2
            && unplaced == 0;
        LightSet {
            spatial,
            picking,
            env_groups,
            env_power,
            local_groups,
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
                    Light::Directional { light, .. } => light.irradiance *= factor,
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
        *self = LightSet::with_groups_picked_by(lights, groups, self.picking);
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
    ///
    /// With one group at a finite distance (or more than
    /// [`MAX_SPATIAL_GROUPS`]) groups are picked by power. With 2 to
    /// [`MAX_SPATIAL_GROUPS`] of them ([`LightSet::is_spatial`]) the
    /// environment keeps its share by power, and the local groups share the
    /// rest in proportion to their power times their bound at `p`
    /// ([`LightBounds::importance`]: `cos θ′ / d²`), so a near light facing
    /// `p` is picked more often than a far one or one facing away, and one
    /// that faces away everywhere it could be is never picked.
    #[inline(always)]
    pub fn pick(&self, p: Vec3, u: Vec2) -> Option<(usize, f32)> {
        if self.spatial {
            return self.pick_spatial(|_, g| self.limited_power(g, p) > 0.0, p, u);
        }
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
        if self.limited_groups.is_empty() && !self.spatial {
            return self.pick(p, u);
        }
        let reach = |k: usize, g: u32| {
            if k < 64 {
                reaches >> k & 1 == 1
            } else {
                self.limited_power(g, p) > 0.0
            }
        };
        if self.spatial {
            return self.pick_spatial(reach, p, u);
        }
        self.pick_where(reach, u)
    }

    /// The selection weights of the local groups at `p` (spatial picking),
    /// where `reaches(k, group)` tells whether the `k`-th cone-limited group
    /// can reach `p`.
    #[inline(always)]
    fn local_weights(&self, reaches: impl Fn(usize, u32) -> bool, p: Vec3) -> LocalWeights {
        let mut w = LocalWeights {
            importance: [0.0; MAX_SPATIAL_GROUPS],
            importance_sum: 0.0,
            power: 0.0,
        };
        for (i, &(g, k)) in self.local_groups.iter().enumerate() {
            let group = &self.groups[g as usize];
            let reaching = match k {
                Some(k) => reaches(k as usize, g),
                None => true,
            };
            if !reaching || group.power <= 0.0 {
                continue;
            }
            let Some(bounds) = &group.bounds else {
                continue;
            };
            w.importance[i] = group.power * bounds.importance(p);
            w.importance_sum += w.importance[i];
            w.power += group.power;
        }
        // Where no local group can send light, the environment takes it all.
        if !(w.importance_sum > 0.0 && w.importance_sum.is_finite()) {
            w.power = 0.0;
        }
        w
    }

    /// The probability of picking local group `i` (of `local_groups`) with
    /// weights `w`, out of the total weight `total`.
    #[inline(always)]
    fn local_pmf(w: &LocalWeights, i: usize, total: f32) -> f32 {
        w.power / total * (w.importance[i] / w.importance_sum)
    }

    /// The spatial pick (see [`LightSet::pick`]): the environment by its
    /// power against the power of the local groups that reach `p`, and a
    /// local group by its power times its [`LightBounds::importance`] at `p`
    /// (paper-independent: pbrt-v4's light bounds without the receiver's
    /// normal).
    #[inline(always)]
    fn pick_spatial(
        &self,
        reaches: impl Fn(usize, u32) -> bool,
        p: Vec3,
        u: Vec2,
    ) -> Option<(usize, f32)> {
        let w = self.local_weights(reaches, p);
        let total = self.env_power + w.power;
        if total <= 0.0 {
            return None;
        }
        let target = u.x * total;
        let (group, pmf) = if target < self.env_power || w.power <= 0.0 {
            let powers = self
                .env_groups
                .iter()
                .map(|&g| (g, self.groups[g as usize].power));
            let g = walk(powers, target)?;
            (g, self.groups[g as usize].power / total)
        } else {
            let t = (target - self.env_power) / w.power * w.importance_sum;
            let i = walk(
                w.importance
                    .iter()
                    .copied()
                    .enumerate()
                    .take(self.local_groups.len()),
                t,
            )?;
            (self.local_groups[i].0, LightSet::local_pmf(&w, i, total))
        };
        let g = &self.groups[group as usize];
        let (k, pk) = g.within.sample(u.y)?;
        Some((g.range.start as usize + k, pmf * pk))
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
            let reaching = self.limited_groups.iter().enumerate();
            let powers = reaching
                .filter(|&(k, &g)| reaches(k, g))
                .map(|(_, &g)| (g, self.groups[g as usize].power));
            walk(powers, target)?
        };
        let g = &self.groups[group as usize];
        let (k, pk) = g.within.sample(u.y)?;
        Some((g.range.start as usize + k, g.power / total * pk))
    }

    /// Whether the light-picking distribution is the same at every point
    /// (no group has a reach limit).
    pub fn is_spatially_uniform(&self) -> bool {
        self.limited_groups.is_empty() && !self.spatial
    }

    /// Whether groups are picked by their bounds at the shading point as
    /// well as their power (see [`LightSet::pick`]).
    pub fn is_spatial(&self) -> bool {
        self.spatial
    }

    /// The same lights picked by `picking`.
    pub fn with_picking(mut self, picking: LightPicking) -> LightSet {
        self.picking = picking;
        self.edit(|_| {});
        self
    }

    /// The rule lights are picked by.
    pub fn picking(&self) -> LightPicking {
        self.picking
    }

    /// Probability that [`LightSet::pick`] returns light `index` at `p`.
    #[inline]
    pub fn pick_pmf(&self, index: usize, p: Vec3) -> f32 {
        let g = self.group_of[index];
        let group = &self.groups[g as usize];
        if self.spatial {
            let w = self.local_weights(|_, g| self.limited_power(g, p) > 0.0, p);
            let total = self.env_power + w.power;
            if total <= 0.0 {
                return 0.0;
            }
            let within = group.within.pmf(index - group.range.start as usize);
            return match self.local_groups.iter().position(|&(l, _)| l == g) {
                Some(i) if w.power > 0.0 && w.importance[i] > 0.0 => {
                    LightSet::local_pmf(&w, i, total) * within
                }
                Some(_) => 0.0,
                None if group.power > 0.0 => group.power / total * within,
                None => 0.0,
            };
        }
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

/// The item whose interval holds `target` when the positive weights of
/// `items` are laid end to end in their order (the last such item where
/// rounding leaves `target` past the end); `None` where no weight is
/// positive.
#[inline(always)]
fn walk<T>(items: impl Iterator<Item = (T, f32)>, mut target: f32) -> Option<T> {
    let mut chosen = None;
    for (item, weight) in items {
        if weight > 0.0 {
            chosen = Some(item);
            if target < weight {
                break;
            }
            target -= weight;
        }
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The variance of the one-light estimate of the irradiance at `p`
    /// (normal `n`) from point lights: `Σ f²/pmf − E²`, exactly.
    fn estimate_variance(set: &LightSet, p: Vec3, n: Vec3) -> f64 {
        let mut mean = 0.0;
        let mut second = 0.0;
        for (i, light) in set.lights.iter().enumerate() {
            let Light::Point(l) = light else {
                unreachable!()
            };
            let d = l.position - p;
            let f = (l.intensity.x * n.dot(d.normalize()).max(0.0) / d.length_squared()) as f64;
            let pmf = set.pick_pmf(i, p) as f64;
            mean += f;
            if f > 0.0 {
                assert!(pmf > 0.0, "light {i} contributes but is never picked");
                second += f * f / pmf;
            }
        }
        second - mean * mean
    }

    #[test]
    fn picking_by_distance_lowers_the_variance_of_direct_light() {
        // Equal lights 1, 2, 4 and 8 units above a row of points.
        let lights: Vec<Light> = [1.0, 2.0, 4.0, 8.0]
            .iter()
            .enumerate()
            .map(|(i, &h)| {
                Light::Point(PointLight {
                    position: Vec3::new(i as f32 * 0.5, 0.0, h),
                    intensity: Vec3::ONE,
                    cone: None,
                    projection: None,
                })
            })
            .collect();
        let spatial = LightSet::new(lights);
        assert!(spatial.is_spatial());
        let by_power = spatial.clone().with_picking(LightPicking::Power);
        for x in [0.0, 0.7, 1.5] {
            let p = Vec3::new(x, 0.0, 0.0);
            let (vs, vp) = (
                estimate_variance(&spatial, p, Vec3::Z),
                estimate_variance(&by_power, p, Vec3::Z),
            );
            assert!(
                vs < 0.25 * vp,
                "at {p}: variance {vs} against {vp} by power"
            );
        }
    }

    #[test]
    fn one_local_group_is_still_picked_by_power() {
        let lights = vec![
            Light::Point(PointLight {
                position: Vec3::Z,
                intensity: Vec3::ONE,
                cone: None,
                projection: None,
            }),
            Light::Environment {
                light: Box::new(EnvironmentLight::constant(Vec3::splat(0.1))),
                scene_radius: 1.0,
            },
        ];
        let set = LightSet::new(lights);
        assert!(!set.is_spatial() && set.is_spatially_uniform());
    }
}
