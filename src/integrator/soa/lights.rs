//! The lights of the lanes for a light sample, one array per component
//! ([`LightChunk`]): point lights, emitting triangles, parametric lights.

use super::*;

/// One lane's light for a light sample: a point light or an emitting
/// triangle (with the cone of a parametric light, if it has one), and the
/// probability it was picked with.
#[derive(Debug, Clone, Copy)]
pub(super) struct LightIn {
    /// Whether a light was picked: picking fails where no light can reach
    /// the shading point (a parametric light's cone), and the lane then
    /// takes no light sample.
    pub(super) picked: bool,
    /// An emitting triangle (else a point light or the environment).
    pub(super) triangle: bool,
    /// The environment (its sample is taken per lane by `pick_lights`).
    pub(super) environment: bool,
    /// The triangle emits on both sides.
    pub(super) two_sided: bool,
    /// The triangle's vertices; the point light's position is `p[0]`.
    pub(super) p: [Vec3; 3],
    /// The triangle's unit normal.
    pub(super) n: Vec3,
    /// The triangle's area.
    pub(super) area: f32,
    /// The triangle's radiance or the point light's intensity.
    pub(super) emit: Vec3,
    /// Probability of picking this light.
    pub(super) pmf: f32,
    /// The triangle emits only into a cone (see [`Cone`]).
    pub(super) cone: bool,
    /// The cone's unit axis.
    pub(super) axis: Vec3,
    /// The cosine of the cone's outer half-angle.
    pub(super) cos_a: f32,
    /// The cone's window has a soft edge (`edge` holds it).
    pub(super) soft: bool,
    /// The soft edge (a harmless placeholder for a hard cone).
    pub(super) edge: SoftEdge,
}

/// The soft edge of a light without one: never used, but finite.
pub(super) const NO_EDGE: SoftEdge = SoftEdge {
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
    pub(super) fn new(light: &Light, pmf: f32) -> LightIn {
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
            // Not reached: scenes with directional lights are rendered by
            // the general integrator (`SoaScene::new`).
            Light::Directional { .. } => LightIn::default(),
        }
    }

    /// The radiance leaving the triangle along the unit direction `w`:
    /// [`TriangleLight::emitted`](crate::light::TriangleLight::emitted)
    /// without branches, rounding as it does (a window of 1 or 0 multiplies
    /// the radiance exactly).
    #[inline(always)]
    pub(super) fn emitted<const CONES: bool>(&self, w: Vec3) -> Vec3 {
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
pub(super) struct LightChunk {
    pub(super) picked: [bool; W],
    pub(super) triangle: [bool; W],
    pub(super) environment: [bool; W],
    pub(super) two_sided: [bool; W],
    pub(super) p: [[[f32; W]; 3]; 3],
    pub(super) n: [[f32; W]; 3],
    pub(super) area: [f32; W],
    pub(super) emit: [[f32; W]; 3],
    pub(super) pmf: [f32; W],
    pub(super) cone: [bool; W],
    pub(super) axis: [[f32; W]; 3],
    pub(super) cos_a: [f32; W],
    pub(super) soft: [bool; W],
    pub(super) edge: [[f32; W]; 3],
}

impl LightChunk {
    /// The same light in every lane.
    #[inline(always)]
    pub(super) fn splat(l: LightIn) -> LightChunk {
        let mut chunk = LightChunk::empty();
        for k in 0..W {
            chunk.set(k, &l);
        }
        chunk
    }

    /// The lights of lanes `start..start + W` (no light past the end):
    /// `table[light[i]]` picked with probability `pmf[i]`.
    #[inline(always)]
    pub(super) fn load(table: &[LightIn], light: &[u32], pmf: &[f32], start: usize) -> LightChunk {
        let mut chunk = LightChunk::empty();
        let end = light.len().min(start + W);
        for (k, (&li, &pmf)) in light[start..end].iter().zip(&pmf[start..end]).enumerate() {
            chunk.set(k, &table[li as usize]);
            chunk.pmf[k] = pmf;
        }
        chunk
    }

    #[inline(always)]
    pub(super) fn empty() -> LightChunk {
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
    pub(super) fn set(&mut self, k: usize, l: &LightIn) {
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
    pub(super) fn lane(&self, k: usize) -> LightIn {
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
