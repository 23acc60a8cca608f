//! Parametric light sources (PLS): the paper's lighting representation.
//!
//! A light is the 5-tuple `l = (n, g, a, c, b)` (paper eq. 1–2) and a
//! lighting is a list of them (eq. 8):
//!
//! | symbol | field | meaning | unit |
//! | --- | --- | --- | --- |
//! | n | [`Pls::n`] | unit normal of the planar emitter; the side it emits towards | — |
//! | g | [`Pls::g`] | outline: `(e1, e2, α1, α2, d1, d2, d3, d4)` | metres |
//! | a | [`Pls::a_deg`] | divergence half-angle of the emitted beam around n | degrees |
//! | c | [`Pls::c`] | colour | linear RGB |
//! | b | [`Pls::b`] | brightness, see [`BrightnessMode`] | W/sr or W/(m²·sr) |
//!
//! The outline (eq. 3–7, 9–11) is symmetric about the axis from `e1` to
//! `e2`. With `v = e2 − e1` and `p = normalize(v × n)` (eq. 7), the axis points
//! are `a1 = e1 + α1·v`, `a2 = e1 + α2·v` and the Bézier anchors
//! `c1 = e1 + d1·p, c2 = a1 + d2·p, c3 = a2 + d3·p, c4 = e2 + d4·p`, mirrored
//! to `c5..c8` with `−d·p`. Because the anchors are the axis control points
//! offset along `p`, the curves are `B1(t) = A(t) + w(t)·p` and
//! `B2(t) = A(t) − w(t)·p`, with `A` the cubic Bézier over `(e1, a1, a2, e2)`
//! and `w` the scalar cubic over `(d1, d2, d3, d4)`; plsr uses that form.
//!
//! Transforms act on the parameters (eq. 15–21), not on the tessellated
//! vertices: see [`Pls::transform`].

pub mod file;

use glam::{Mat3, Mat4, Vec3};
use std::fmt;

/// Default number of quads along the axis ([`Pls::tessellate`]).
///
/// The error of the tessellated area falls as 1/Nf² (chords of the curved
/// sides). For the paper's disk-like flashlight it is 0.65 % at Nf = 16 and
/// 0.16 % at Nf = 32; the lamp (a rectangle) is exact at any Nf (see the test
/// `tessellated_area_converges_to_the_outline_area`). 32 quads keep the area
/// error under 0.2 % at 62–64 triangles per light, which costs Embree
/// nothing noticeable.
pub const DEFAULT_NF: u32 = 32;

/// Factor of the circle approximation: `d2 = d3 = 1.35·r` (the paper, sec. 3).
pub const CIRCLE_FACTOR: f32 = 1.35;

/// How the brightness `b` becomes emitted radiance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BrightnessMode {
    /// `b` is the radiant intensity (W/sr) of the whole light along `n`: the
    /// radiance inside the cone is `L = b·c / A` with `A` the emitter's area,
    /// and a small light gives on-axis irradiance `b / r²` at distance `r`.
    #[default]
    Intensity,
    /// `b` is the radiance (W/(m²·sr)): `L = b·c`.
    Radiance,
}

/// The outline `g = (e1, e2, α1, α2, d1, d2, d3, d4)` (paper eq. 2), metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PlsGeometry {
    /// Start of the symmetry axis.
    pub e1: Vec3,
    /// End of the symmetry axis.
    pub e2: Vec3,
    /// Position of the first inner axis point along `e2 − e1`, in `[0, α2]`.
    pub alpha1: f32,
    /// Position of the second inner axis point, in `[α1, 1]`.
    pub alpha2: f32,
    /// Half-widths of the four anchors from the axis (metres, ≥ 0).
    pub d: [f32; 4],
}

/// One parametric light source `l = (n, g, a, c, b)`.
#[derive(Debug, Clone, PartialEq)]
pub struct Pls {
    /// Optional name, used in messages.
    pub name: Option<String>,
    /// Unit normal: the emitter emits towards this side.
    pub n: Vec3,
    /// The outline.
    pub g: PlsGeometry,
    /// Divergence half-angle of the beam around `n`, degrees in (0, 90].
    pub a_deg: f32,
    /// Colour, linear RGB, non-negative.
    pub c: Vec3,
    /// Brightness, non-negative; its unit depends on the [`BrightnessMode`].
    pub b: f32,
}

/// A validation failure: which light, which parameter, what is wrong.
#[derive(Debug, Clone, PartialEq)]
pub struct PlsError {
    /// The light: its name, or `lights[i]`.
    pub light: String,
    /// The parameter (`n`, `e1`, `alpha1`, `d[2]`, …).
    pub parameter: String,
    /// What is wrong.
    pub message: String,
}

impl fmt::Display for PlsError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{}: {}", self.light, self.parameter, self.message)
    }
}

impl std::error::Error for PlsError {}

/// Cubic Bézier over four points at `t`.
#[inline]
fn bezier3(p: [Vec3; 4], t: f32) -> Vec3 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

/// Scalar cubic Bézier at `t`.
#[inline]
fn bezier3_scalar(p: [f32; 4], t: f32) -> f32 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

/// The tessellated emitter: positions and counter-clockwise triangles (seen
/// from the side `n` points to).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlsMesh {
    /// Vertex positions (metres).
    pub positions: Vec<Vec3>,
    /// Triangles; no zero-area ones.
    pub triangles: Vec<[u32; 3]>,
}

impl PlsMesh {
    /// The mesh with every vertex transformed by the affine `m` (what
    /// transforming a light through its vertices means).
    pub fn transformed(&self, m: &Mat4) -> PlsMesh {
        PlsMesh {
            positions: self
                .positions
                .iter()
                .map(|p| m.transform_point3(*p))
                .collect(),
            triangles: self.triangles.clone(),
        }
    }

    /// Total area (m²).
    pub fn area(&self) -> f32 {
        self.triangles
            .iter()
            .map(|t| {
                let [a, b, c] = t.map(|i| self.positions[i as usize]);
                0.5 * (b - a).cross(c - a).length()
            })
            .sum()
    }
}

impl Pls {
    /// The name for messages: the light's name, or `lights[index]`.
    pub fn label(&self, index: usize) -> String {
        match &self.name {
            Some(n) => format!("lights[{index}] ({n})"),
            None => format!("lights[{index}]"),
        }
    }

    /// Checks every parameter; `index` names the light in errors.
    pub fn validate(&self, index: usize) -> Result<(), PlsError> {
        let err = |parameter: &str, message: String| PlsError {
            light: self.label(index),
            parameter: parameter.into(),
            message,
        };
        let finite3 = |name: &str, v: Vec3| -> Result<(), PlsError> {
            if v.is_finite() {
                Ok(())
            } else {
                Err(err(name, format!("must be finite, got {v}")))
            }
        };
        let finite = |name: &str, x: f32| -> Result<(), PlsError> {
            if x.is_finite() {
                Ok(())
            } else {
                Err(err(name, format!("must be finite, got {x}")))
            }
        };
        finite3("n", self.n)?;
        finite3("e1", self.g.e1)?;
        finite3("e2", self.g.e2)?;
        finite("alpha1", self.g.alpha1)?;
        finite("alpha2", self.g.alpha2)?;
        for (k, d) in self.g.d.iter().enumerate() {
            finite(&format!("d[{k}]"), *d)?;
        }
        finite("a", self.a_deg)?;
        finite3("c", self.c)?;
        finite("b", self.b)?;

        let n_len = self.n.length();
        if n_len == 0.0 {
            return Err(err("n", "must not be the zero vector".into()));
        }
        let v = self.g.e2 - self.g.e1;
        let v_len = v.length();
        if v_len == 0.0 {
            return Err(err(
                "e2",
                format!("equals e1 ({}): the axis has no length", self.g.e1),
            ));
        }
        // Eq. 7 divides by |v × n|; demand a clearly non-zero sine.
        let sin = v.cross(self.n).length() / (v_len * n_len);
        if sin < 1e-4 {
            return Err(err(
                "n",
                format!("is parallel to the axis e2 − e1 = {v}: p = normalize(v × n) is undefined"),
            ));
        }
        let (a1, a2) = (self.g.alpha1, self.g.alpha2);
        if !(0.0..=1.0).contains(&a1) || a1 > a2 {
            return Err(err(
                "alpha1",
                format!("must satisfy 0 ≤ alpha1 ≤ alpha2, got alpha1 = {a1}, alpha2 = {a2}"),
            ));
        }
        if a2 > 1.0 {
            return Err(err(
                "alpha2",
                format!("must satisfy alpha1 ≤ alpha2 ≤ 1, got {a2}"),
            ));
        }
        for (k, d) in self.g.d.iter().enumerate() {
            if *d < 0.0 {
                return Err(err(
                    &format!("d[{k}]"),
                    format!("must not be negative, got {d}"),
                ));
            }
        }
        if self.g.d.iter().all(|d| *d == 0.0) {
            return Err(err(
                "d",
                "all four widths are zero: the light has no area".into(),
            ));
        }
        if self.c.min_element() < 0.0 {
            return Err(err("c", format!("must not be negative, got {}", self.c)));
        }
        if self.b < 0.0 {
            return Err(err("b", format!("must not be negative, got {}", self.b)));
        }
        if !(self.a_deg > 0.0 && self.a_deg <= 90.0) {
            return Err(err(
                "a",
                format!("must be in (0°, 90°], got {}°", self.a_deg),
            ));
        }
        Ok(())
    }

    /// Unit normal (the stored `n` normalised).
    pub fn normal(&self) -> Vec3 {
        self.n.normalize()
    }

    /// The in-plane direction `p = normalize(v × n)` (eq. 7).
    pub fn p(&self) -> Vec3 {
        (self.g.e2 - self.g.e1).cross(self.normal()).normalize()
    }

    /// Axis control points `(e1, a1, a2, e2)` (eq. 3–4).
    pub fn axis_points(&self) -> [Vec3; 4] {
        let v = self.g.e2 - self.g.e1;
        [
            self.g.e1,
            self.g.e1 + self.g.alpha1 * v,
            self.g.e1 + self.g.alpha2 * v,
            self.g.e2,
        ]
    }

    /// The eight Bézier anchors `c1..c8` (eq. 5–6, 9).
    pub fn anchors(&self) -> [Vec3; 8] {
        let a = self.axis_points();
        let p = self.p();
        let d = self.g.d;
        [
            a[0] + d[0] * p,
            a[1] + d[1] * p,
            a[2] + d[2] * p,
            a[3] + d[3] * p,
            a[0] - d[0] * p,
            a[1] - d[1] * p,
            a[2] - d[2] * p,
            a[3] - d[3] * p,
        ]
    }

    /// The two boundary curves at `t ∈ [0, 1]`: `(B1(t), B2(t))` (eq. 10–11).
    pub fn boundary(&self, t: f32) -> (Vec3, Vec3) {
        let axis = bezier3(self.axis_points(), t);
        let w = bezier3_scalar(self.g.d, t) * self.p();
        (axis + w, axis - w)
    }

    /// Tessellates the outline into `nf` quads between consecutive samples of
    /// `B1` and `B2` at `t = k/nf`, as triangles facing `n`. Where a width is
    /// zero (a pointed end) the quad degenerates to one triangle; zero-area
    /// triangles are never emitted. An outline pointed at both ends needs
    /// `nf ≥ 2` to have any area, so `nf` is raised to 2 there.
    pub fn tessellate(&self, nf: u32) -> PlsMesh {
        let pointed_both_ends = self.g.d[0] == 0.0 && self.g.d[3] == 0.0;
        let nf = if pointed_both_ends {
            nf.max(2)
        } else {
            nf.max(1)
        };
        let axis = self.axis_points();
        let p = self.p();
        let mut positions = Vec::with_capacity(2 * (nf as usize + 1));
        let mut widths = Vec::with_capacity(nf as usize + 1);
        for k in 0..=nf {
            let t = k as f32 / nf as f32;
            let a = bezier3(axis, t);
            let w = bezier3_scalar(self.g.d, t);
            positions.push(a + w * p); // 2k: on B1
            positions.push(a - w * p); // 2k + 1: on B2
            widths.push(w);
        }
        let mut triangles = Vec::with_capacity(2 * nf as usize);
        let n = self.normal();
        let mut push = |t: [u32; 3], positions: &[Vec3]| {
            let [a, b, c] = t.map(|i| positions[i as usize]);
            let cross = (b - a).cross(c - a);
            // Keep only triangles with real area that face n.
            if cross.dot(n) > 0.0 && cross.length_squared() > 0.0 {
                triangles.push(t);
            }
        };
        for k in 0..nf {
            let (b1k, b2k) = (2 * k, 2 * k + 1);
            let (b1n, b2n) = (2 * k + 2, 2 * k + 3);
            let (wk, wn) = (widths[k as usize], widths[k as usize + 1]);
            match (wk > 0.0, wn > 0.0) {
                (true, true) => {
                    push([b1k, b1n, b2n], &positions);
                    push([b1k, b2n, b2k], &positions);
                }
                // Pointed start: B1(t_k) = B2(t_k).
                (false, true) => push([b1k, b1n, b2n], &positions),
                // Pointed end: B1(t_k+1) = B2(t_k+1).
                (true, false) => push([b1k, b1n, b2k], &positions),
                (false, false) => {}
            }
        }
        // Drop vertices no triangle uses (the duplicated tips).
        let mut remap = vec![u32::MAX; positions.len()];
        let mut used = Vec::new();
        for t in &mut triangles {
            for i in t.iter_mut() {
                if remap[*i as usize] == u32::MAX {
                    remap[*i as usize] = used.len() as u32;
                    used.push(positions[*i as usize]);
                }
                *i = remap[*i as usize];
            }
        }
        PlsMesh {
            positions: used,
            triangles,
        }
    }

    /// Exact area of the Bézier outline (m²): `2·|v|·∫ w(t)·x'(t) dt`, with
    /// `x(t)` the axis parameter, by 3-point Gauss–Legendre quadrature (exact
    /// for the degree-5 integrand).
    pub fn outline_area(&self) -> f32 {
        let v_len = (self.g.e2 - self.g.e1).length() as f64;
        let (a1, a2) = (self.g.alpha1 as f64, self.g.alpha2 as f64);
        // x(t) = Bézier(0, α1, α2, 1); x'(t) = 3[(α1)(1−t)² + 2(α2−α1)(1−t)t + (1−α2)t²].
        let dx = |t: f64| {
            let s = 1.0 - t;
            3.0 * (a1 * s * s + 2.0 * (a2 - a1) * s * t + (1.0 - a2) * t * t)
        };
        let w = |t: f64| bezier3_scalar(self.g.d, t as f32) as f64;
        let r = (3.0f64 / 5.0).sqrt() / 2.0;
        let nodes = [
            (0.5 - r, 5.0 / 18.0),
            (0.5, 8.0 / 18.0),
            (0.5 + r, 5.0 / 18.0),
        ];
        let integral: f64 = nodes.iter().map(|&(t, wt)| wt * w(t) * dx(t)).sum();
        (2.0 * v_len * integral) as f32
    }

    /// Centre of the outline's axis, `(e1 + e2) / 2` (metres).
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.g.e1 + self.g.e2)
    }

    /// Emitted radiance inside the cone (linear RGB) for a brightness mode and
    /// the emitter's area (eq. 12–14 with plsr's brightness semantics).
    pub fn radiance(&self, mode: BrightnessMode, area: f32) -> Vec3 {
        match mode {
            BrightnessMode::Intensity => {
                if area > 0.0 {
                    self.c * (self.b / area)
                } else {
                    Vec3::ZERO
                }
            }
            BrightnessMode::Radiance => self.c * self.b,
        }
    }

    /// Total emitted power per channel (W): radiance × area × the projected
    /// solid angle of the cone, `π·sin²a`.
    pub fn power(&self, mode: BrightnessMode, area: f32) -> Vec3 {
        let s = self.a_deg.to_radians().sin();
        self.radiance(mode, area) * area * std::f32::consts::PI * s * s
    }

    /// The light transformed by the affine 4×4 `m = [R T; 0 1]`, acting on
    /// the parameters (eq. 15–21): `n' = normalize(R·n)`, `e1' = M·e1`,
    /// `e2' = M·e2`, α unchanged, `d' = s·d` with
    /// `s = |R·(v × n)| / |v × n|`; `a`, `c`, `b` unchanged.
    ///
    /// For rotations, translations and uniform scales this equals transforming
    /// the tessellated mesh; for shears and non-uniform scales it is an
    /// approximation (the outline stays symmetric), measured in the tests.
    pub fn transform(&self, m: &Mat4) -> Pls {
        let r = Mat3::from_mat4(*m);
        let n = self.normal();
        let v = self.g.e2 - self.g.e1;
        let vxn = v.cross(n);
        let s = (r * vxn).length() / vxn.length();
        Pls {
            name: self.name.clone(),
            n: (r * n).normalize(),
            g: PlsGeometry {
                e1: m.transform_point3(self.g.e1),
                e2: m.transform_point3(self.g.e2),
                alpha1: self.g.alpha1,
                alpha2: self.g.alpha2,
                d: self.g.d.map(|d| d * s),
            },
            a_deg: self.a_deg,
            c: self.c,
            b: self.b,
        }
    }

    /// A disk of radius `radius` (metres) around `centre`, facing `n`, with its
    /// symmetry axis along `axis` projected into the disk's plane: the paper's
    /// approximation `d1 = d4 = 0`, `d2 = d3 = 1.35·r`, `α1 = 0`, `α2 = 1`,
    /// with `e1`, `e2` one radius either side of the centre. Returns `None`
    /// if `n` is zero or `axis` is parallel to it.
    pub fn circle(
        centre: Vec3,
        radius: f32,
        n: Vec3,
        axis: Vec3,
        a_deg: f32,
        c: Vec3,
        b: f32,
    ) -> Option<Pls> {
        let n = n.try_normalize()?;
        let axis = (axis - axis.dot(n) * n).try_normalize()?;
        Some(Pls {
            name: None,
            n,
            g: PlsGeometry {
                e1: centre - radius * axis,
                e2: centre + radius * axis,
                alpha1: 0.0,
                alpha2: 1.0,
                d: [0.0, CIRCLE_FACTOR * radius, CIRCLE_FACTOR * radius, 0.0],
            },
            a_deg,
            c,
            b,
        })
    }
}

/// A lighting: a list of lights and the brightness mode of their `b` (eq. 8).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlsLighting {
    /// How `b` is read.
    pub mode: BrightnessMode,
    /// The lights.
    pub lights: Vec<Pls>,
}

impl PlsLighting {
    /// Validates every light.
    pub fn validate(&self) -> Result<(), PlsError> {
        self.lights
            .iter()
            .enumerate()
            .try_for_each(|(i, l)| l.validate(i))
    }

    /// Transforms every light (see [`Pls::transform`]).
    pub fn transform(&self, m: &Mat4) -> PlsLighting {
        PlsLighting {
            mode: self.mode,
            lights: self.lights.iter().map(|l| l.transform(m)).collect(),
        }
    }
}
