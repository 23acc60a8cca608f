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

mod emitter;
pub mod file;
mod outline;
mod reach;
mod transform;
mod window;

pub use emitter::{check_nf, PlsEmitter, MAX_NF};
pub use outline::PlsMesh;
pub use reach::Reach;
pub use window::{Cone, SoftEdge};

use glam::Vec3;
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

/// The smallest outline area a light may have (m², one square of 10 µm):
/// below it the radiance `b·c/A` (eq. 12) is out of reach of `f32`.
pub const MIN_AREA: f32 = 1e-10;

/// How far from the origin a light's axis ends and widths may reach
/// (metres): half of what Embree places (`accel::MAX_COORDINATE`), so every
/// vertex of the emitter stays within it.
pub const MAX_EXTENT: f32 = 0.5 * crate::accel::MAX_COORDINATE;

/// The largest brightness `b·max(c)` a light may have: the radiance in
/// [`BrightnessMode::Radiance`] (W·m⁻²·sr⁻¹), the intensity in
/// [`BrightnessMode::Intensity`]. Spread over at least [`MIN_AREA`] it stays
/// within `f32` (eq. 12); the Sun's radiance is about 2·10⁷.
pub const MAX_BRIGHTNESS: f32 = 1e20;

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
    /// Width of the beam's soft edge, degrees (plsr's extension of the
    /// paper's hard window, eq. 12): the window falls linearly from 1 at
    /// `a − w/2` to 0 at `a + w/2` ([`Cone::window`]); 0 is the paper's
    /// hard edge.
    pub penumbra_deg: f32,
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
        finite("penumbra", self.penumbra_deg)?;
        finite3("c", self.c)?;
        finite("b", self.b)?;

        // The emitter's vertices lie within |e| + max(d) of the origin; keep
        // them where Embree can place them (accel::MAX_COORDINATE).
        for (name, e) in [("e1", self.g.e1), ("e2", self.g.e2)] {
            if e.abs().max_element() > MAX_EXTENT {
                return Err(err(
                    name,
                    format!(
                        "must lie within ±{MAX_EXTENT:e} m of the origin on each axis, got {e}"
                    ),
                ));
            }
        }
        for (k, d) in self.g.d.iter().enumerate() {
            if *d > MAX_EXTENT {
                return Err(err(
                    &format!("d[{k}]"),
                    format!("must be at most {MAX_EXTENT:e} m, got {d}"),
                ));
            }
        }
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
        // Widths far below a millimetre pass the checks above but make an
        // emitter whose radiance b·c/A overflows (eq. 12) and whose
        // triangles Embree cannot bound.
        let area = self.outline_area();
        if area.is_nan() || area < MIN_AREA {
            return Err(err(
                "d",
                format!(
                    "the outline's area is {area:e} m², below the smallest plsr renders \
                     ({MIN_AREA:e} m²): widths are in metres"
                ),
            ));
        }
        if self.c.min_element() < 0.0 {
            return Err(err("c", format!("must not be negative, got {}", self.c)));
        }
        if self.b < 0.0 {
            return Err(err("b", format!("must not be negative, got {}", self.b)));
        }
        let brightness = f64::from(self.b) * f64::from(self.c.max_element());
        if brightness > f64::from(MAX_BRIGHTNESS) {
            return Err(err(
                "b",
                format!(
                    "b × the largest channel of c is {brightness:e}, above the largest plsr \
                     renders ({MAX_BRIGHTNESS:e}): the radiance would overflow"
                ),
            ));
        }
        if !(self.a_deg > 0.0 && self.a_deg <= 90.0) {
            return Err(err(
                "a",
                format!("must be in (0°, 90°], got {}°", self.a_deg),
            ));
        }
        let half = 0.5 * self.penumbra_deg;
        if self.penumbra_deg < 0.0 || half > self.a_deg || self.a_deg + half > 90.0 {
            return Err(err(
                "penumbra",
                format!(
                    "must be in [0°, {}°] for a = {}° (the soft edge runs from a − w/2 ≥ 0° to \
                     a + w/2 ≤ 90°), got {}°",
                    2.0 * self.a_deg.min(90.0 - self.a_deg),
                    self.a_deg,
                    self.penumbra_deg
                ),
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

    /// Centre of the outline's axis, `(e1 + e2) / 2` (metres).
    pub fn centre(&self) -> Vec3 {
        0.5 * (self.g.e1 + self.g.e2)
    }

    /// Emitted radiance inside the cone (linear RGB) for a brightness mode and
    /// the emitter's area (eq. 12–14 with plsr's brightness semantics).
    pub fn radiance(&self, mode: BrightnessMode, area: f32) -> Vec3 {
        match mode {
            BrightnessMode::Intensity => {
                // A coarse tessellation of a sliver can have far less area
                // than the outline; below MIN_AREA the quotient could
                // overflow, so it is taken at MIN_AREA.
                if area > 0.0 {
                    self.c * (self.b / area.max(MIN_AREA))
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
            penumbra_deg: 0.0,
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
}
