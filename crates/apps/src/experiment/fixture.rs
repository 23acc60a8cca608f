//! Physical light fixtures, modelled as real geometry, and the PLS lights
//! derived from that geometry (the paper's Fig. 11, done on the model
//! instead of on photos).
//!
//! - A **flashlight**: an emitting disk of radius `r` at the bottom of an
//!   absorbing tube of length `L` and the same radius.
//! - A **ceiling lamp**: an emitting rectangle under an absorbing rim of
//!   depth `h`: a box open at the bottom.
//!
//! Both emit uniformly (Lambertian, radiance `Le`) into an absorbing
//! shaft. Seen from far away in a direction at angle `θ` from the axis,
//! the part of the emitter visible through the opening is the overlap of
//! the opening and the emitter shifted by `depth·tan θ`; its share `V(θ)`
//! of the whole is the fixture's *visibility*. The fixture's radiant
//! intensity is `Le·A·cos θ·V(θ)`, so a PLS light on the opening, of
//! radiance `b = Le` (brightness mode `radiance`) and window `W(θ)`,
//! reproduces it in the far field where `W = V`.
//!
//! `V` falls from 1 on the axis (any tilt hides part of the emitter) to 0
//! at the cut-off angle. The PLS window (eq. 12 with plsr's soft edge,
//! eq. 12′) is a linear ramp in angle from `a − w/2` to `a + w/2`. We
//! choose the ramp that emits the fixture's power,
//! `∫ W(θ) sin θ cos θ dθ = ∫ V(θ) sin θ cos θ dθ`, and among those the one
//! closest to `V` ([`window_from_visibility`]). `a` is then about the angle
//! where the beam has fallen to half, which is what the paper measures in
//! its Fig. 11 as the edge of the lit patch.
//!
//! The PLS outline is the emitter itself, not the opening: on the axis the
//! whole emitter shows, so the irradiance there is `Le·A/d²` with `d`
//! measured from the emitter. An outline at the opening would be `L`
//! closer to every surface, `((d + L)/d)²` too bright on the axis (10 % at
//! 2.3 m from a 12 cm tube, 44 % at 0.6 m).

use crate::experiment::mesh::MeshBuilder;
use glam::Vec3;
use plsr::light::pls::{Pls, PlsGeometry};
use std::f64::consts::{FRAC_PI_2, PI};

/// Polygon corners of the flashlight's tube and emitter.
pub const FLASHLIGHT_SEGMENTS: u32 = 64;

/// How far the flashlight's tube reaches behind its emitter (metres).
const SEAM: f32 = 0.002;

/// A flashlight: an emitting disk at the bottom of an absorbing tube.
#[derive(Debug, Clone, PartialEq)]
pub struct Flashlight {
    /// Name, used for the PLS light and the mesh files.
    pub name: String,
    /// Centre of the tube's open end (metres).
    pub mouth: Vec3,
    /// Unit direction the flashlight points to (out of the mouth).
    pub axis: Vec3,
    /// Radius of the emitter and the tube (metres; the circumradius of a
    /// regular [`FLASHLIGHT_SEGMENTS`]-gon).
    pub radius: f32,
    /// Length of the tube from the emitter to the mouth (metres).
    pub length: f32,
    /// Emitted radiance of the disk, W/(m²·sr), times `color`.
    pub radiance: f32,
    /// Colour of the emitted light, linear RGB.
    pub color: [f32; 3],
}

impl Flashlight {
    /// Centre of the emitting disk, at the tube's closed end.
    pub fn emitter_center(&self) -> Vec3 {
        self.mouth - self.length * self.axis
    }

    /// Area of the emitter polygon (m²).
    pub fn emitter_area(&self) -> f32 {
        let n = FLASHLIGHT_SEGMENTS as f32;
        0.5 * n * self.radius * self.radius * (std::f32::consts::TAU / n).sin()
    }

    /// The emitting disk, facing along the axis.
    pub fn emitter_mesh(&self) -> MeshBuilder {
        let mut m = MeshBuilder::new();
        m.disk(
            self.emitter_center(),
            self.axis,
            any_orthogonal(self.axis),
            self.radius,
            FLASHLIGHT_SEGMENTS,
        );
        m
    }

    /// The absorbing tube (open at the mouth, closed by the emitter), with
    /// a closed end 2 mm behind the emitter, so that no ray slips through
    /// the seam between the emitter's rim and the tube.
    pub fn body_mesh(&self) -> MeshBuilder {
        let mut m = MeshBuilder::new();
        let back = self.emitter_center() - SEAM * self.axis;
        let u = any_orthogonal(self.axis);
        m.tube(
            back,
            self.axis,
            u,
            self.radius,
            self.length + SEAM,
            FLASHLIGHT_SEGMENTS,
        );
        m.disk(back, -self.axis, u, self.radius, FLASHLIGHT_SEGMENTS);
        m
    }

    /// Share of the emitter visible through the mouth from far away at
    /// angle `theta` (radians) from the axis: the overlap of two disks of
    /// radius `r` whose centres are `s·r = L·tan θ` apart,
    /// `(2/π)·(acos(s/2) − (s/2)·√(1 − s²/4))`.
    pub fn visibility(&self, theta: f64) -> f64 {
        if theta >= FRAC_PI_2 {
            return 0.0;
        }
        let s = self.length as f64 * theta.tan() / self.radius as f64;
        if s >= 2.0 {
            return 0.0;
        }
        let h = s / 2.0;
        (2.0 / PI) * (h.acos() - h * (1.0 - h * h).sqrt())
    }

    /// The angle beyond which no part of the emitter shows (radians):
    /// `atan(2r/L)`.
    pub fn cutoff(&self) -> f64 {
        (2.0 * self.radius as f64 / self.length as f64).atan()
    }

    /// The PLS light of this fixture (brightness mode `radiance`): the
    /// emitter as a circle-like outline of its area, `b` its radiance, and
    /// the window that emits the fixture's power (see the module docs for
    /// why the outline is the emitter, not the mouth).
    pub fn pls(&self) -> Pls {
        let (a_deg, penumbra_deg) = window_from_visibility(|t| self.visibility(t));
        let u = any_orthogonal(self.axis);
        let r = self.radius;
        // The outline `d1 = d4 = 0`, `d2 = d3 = d`, `α = (0, 1)` between
        // `e1, e2` two radii apart encloses `2.4·r·d` (each side is the
        // cubic `(2r(3t² − 2t³), 3d·t(1 − t))`): choose `d` for the area
        // of the emitter, so that the PLS emits its power exactly.
        let d = self.emitter_area() / (2.4 * r);
        Pls {
            name: Some(self.name.clone()),
            n: self.axis,
            g: PlsGeometry {
                e1: self.emitter_center() - r * u,
                e2: self.emitter_center() + r * u,
                alpha1: 0.0,
                alpha2: 1.0,
                d: [0.0, d, d, 0.0],
            },
            a_deg,
            penumbra_deg,
            c: Vec3::from(self.color),
            b: self.radiance,
        }
    }
}

/// A ceiling lamp: an emitting rectangle at the top of an absorbing box
/// open at the bottom (the rim).
#[derive(Debug, Clone, PartialEq)]
pub struct Lamp {
    /// Name, used for the PLS light and the mesh files.
    pub name: String,
    /// Centre of the emitting rectangle (metres).
    pub emitter_center: Vec3,
    /// Unit direction the lamp emits to (out of the opening).
    pub normal: Vec3,
    /// Direction of the rectangle's first side (projected orthogonal to
    /// `normal`).
    pub u: Vec3,
    /// Half-lengths of the rectangle's sides along `u` and `normal × u`
    /// (metres).
    pub half_size: [f32; 2],
    /// Depth of the rim below the emitter (metres).
    pub depth: f32,
    /// Emitted radiance, W/(m²·sr), times `color`.
    pub radiance: f32,
    /// Colour of the emitted light, linear RGB.
    pub color: [f32; 3],
}

impl Lamp {
    fn frame(&self) -> (Vec3, Vec3, Vec3) {
        let n = self.normal.normalize();
        let u = (self.u - n * self.u.dot(n)).normalize();
        (n, u, n.cross(u))
    }

    /// The emitter's corners, counter-clockwise seen from the lit side,
    /// offset by `lift` along the normal.
    fn corners(&self, lift: f32) -> [Vec3; 4] {
        let (n, u, v) = self.frame();
        let [hx, hy] = self.half_size;
        let c = self.emitter_center + lift * n;
        [
            c - hx * u - hy * v,
            c + hx * u - hy * v,
            c + hx * u + hy * v,
            c - hx * u + hy * v,
        ]
    }

    /// The emitting rectangle, facing along the normal.
    pub fn emitter_mesh(&self) -> MeshBuilder {
        let mut m = MeshBuilder::new();
        let [a, b, c, d] = self.corners(0.0);
        m.quad(a, b, c, d);
        m
    }

    /// The absorbing rim: four walls from the emitter to the opening.
    pub fn body_mesh(&self) -> MeshBuilder {
        let mut m = MeshBuilder::new();
        let top = self.corners(0.0);
        let bottom = self.corners(self.depth);
        for k in 0..4 {
            let j = (k + 1) % 4;
            m.quad(top[k], top[j], bottom[j], bottom[k]);
        }
        m
    }

    /// Share of the emitter visible through the opening from far away at
    /// angle `theta` (radians) from the normal, averaged over the azimuth:
    /// for azimuth `φ` the shift `h·tan θ` leaves
    /// `(1 − h·tan θ·|cos φ|/2x)·(1 − h·tan θ·|sin φ|/2y)` of the
    /// rectangle in view (each factor clamped at 0).
    pub fn visibility(&self, theta: f64) -> f64 {
        if theta >= FRAC_PI_2 {
            return 0.0;
        }
        let shift = self.depth as f64 * theta.tan();
        let (sx, sy) = (
            2.0 * self.half_size[0] as f64,
            2.0 * self.half_size[1] as f64,
        );
        const STEPS: usize = 720;
        (0..STEPS)
            .map(|k| {
                let phi = (k as f64 + 0.5) / STEPS as f64 * FRAC_PI_2;
                (1.0 - shift * phi.cos() / sx).max(0.0) * (1.0 - shift * phi.sin() / sy).max(0.0)
            })
            .sum::<f64>()
            / STEPS as f64
    }

    /// The PLS light of this fixture (brightness mode `radiance`): the
    /// emitter as the outline (a rectangle: `α = (1/3, 2/3)`, equal `d`),
    /// `b` its radiance, and the window that emits the fixture's power.
    pub fn pls(&self) -> Pls {
        let (a_deg, penumbra_deg) = window_from_visibility(|t| self.visibility(t));
        let (n, u, v) = self.frame();
        let centre = self.emitter_center;
        let [hx, hy] = self.half_size;
        // The axis runs along `v` so that `p = normalize(v × n)` is `u`'s
        // direction and `d` the half-size along `u`.
        let _ = u;
        Pls {
            name: Some(self.name.clone()),
            n,
            g: PlsGeometry {
                e1: centre - hy * v,
                e2: centre + hy * v,
                alpha1: 1.0 / 3.0,
                alpha2: 2.0 / 3.0,
                d: [hx; 4],
            },
            a_deg,
            penumbra_deg,
            c: Vec3::from(self.color),
            b: self.radiance,
        }
    }
}

/// The soft-edged window `(a, w)` in degrees that emits the power of the
/// visibility `v(θ)` (`θ` in radians) and, among such windows, follows it
/// best; see the module docs. The window's ramp runs from `θ0 = a − w/2`
/// to `θ1 = a + w/2`: for each `θ0` on a grid, `θ1` is found by bisection
/// to match the power `∫ W sin θ cos θ dθ`, and the `θ0` whose window has
/// the least power-weighted squared difference `∫ (W − V)² sin θ cos θ dθ`
/// wins.
pub fn window_from_visibility(v: impl Fn(f64) -> f64) -> (f32, f32) {
    const N: usize = 2048;
    let h = FRAC_PI_2 / N as f64;
    let theta: Vec<f64> = (0..N).map(|k| (k as f64 + 0.5) * h).collect();
    let weight: Vec<f64> = theta.iter().map(|t| t.sin() * t.cos() * h).collect();
    let vis: Vec<f64> = theta.iter().map(|&t| v(t)).collect();
    let target: f64 = vis.iter().zip(&weight).map(|(v, w)| v * w).sum();
    let ramp = |t: f64, t0: f64, t1: f64| ((t1 - t) / (t1 - t0).max(1e-12)).clamp(0.0, 1.0);
    let power = |t0: f64, t1: f64| -> f64 {
        theta
            .iter()
            .zip(&weight)
            .map(|(&t, w)| ramp(t, t0, t1) * w)
            .sum()
    };
    let misfit = |t0: f64, t1: f64| -> f64 {
        theta
            .iter()
            .zip(&weight)
            .zip(&vis)
            .map(|((&t, w), v)| (ramp(t, t0, t1) - v).powi(2) * w)
            .sum()
    };
    let mut best: Option<(f64, f64, f64)> = None;
    const GRID: usize = 200;
    for i in 0..GRID {
        let t0 = FRAC_PI_2 * i as f64 / GRID as f64;
        // A hard edge at t0 already emits too much, or the widest ramp
        // too little: no window starts here.
        if power(t0, t0 + 1e-9) > target || power(t0, FRAC_PI_2) < target {
            continue;
        }
        let (mut lo, mut hi) = (t0, FRAC_PI_2);
        for _ in 0..50 {
            let mid = 0.5 * (lo + hi);
            if power(t0, mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let t1 = 0.5 * (lo + hi);
        let e = misfit(t0, t1);
        if best.is_none_or(|(_, _, b)| e < b) {
            best = Some((t0, t1, e));
        }
    }
    let (t0, t1, _) = best.expect("a visibility between 0 and 1 has a window of its power");
    let a = (0.5 * (t0 + t1)).to_degrees() as f32;
    let w = (t1 - t0).to_degrees() as f32;
    // Rounding must not break the window's validity (w/2 ≤ a).
    (a, w.min(2.0 * a))
}

/// A unit vector orthogonal to `n`, fixed by `n` alone.
fn any_orthogonal(n: Vec3) -> Vec3 {
    let helper = if n.z.abs() < 0.9 { Vec3::Z } else { Vec3::X };
    n.cross(helper).normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flashlight() -> Flashlight {
        Flashlight {
            name: "f".into(),
            mouth: Vec3::new(0.0, 0.0, 1.0),
            axis: Vec3::new(0.0, 0.0, -1.0),
            radius: 0.02,
            length: 0.1,
            radiance: 100.0,
            color: [1.0; 3],
        }
    }

    #[test]
    fn a_tubes_visibility_falls_from_one_to_zero_at_its_cutoff() {
        let f = flashlight();
        assert_eq!(f.visibility(0.0), 1.0);
        let cut = f.cutoff();
        assert!(f.visibility(cut * 0.999) > 0.0);
        assert!(f.visibility(cut * 0.999) < 1e-3);
        assert_eq!(f.visibility(cut * 1.001), 0.0);
        // Two unit disks one radius apart overlap 2π/3 − √3/2.
        let theta = (f.radius as f64 / f.length as f64).atan();
        let expected = (2.0 * PI / 3.0 - 3f64.sqrt() / 2.0) / PI;
        assert!((f.visibility(theta) - expected).abs() < 1e-12);
    }

    /// Power `∫ f sin θ cos θ dθ` over [0, π/2] (radians).
    fn power(f: impl Fn(f64) -> f64) -> f64 {
        let n = 100_000;
        let h = FRAC_PI_2 / n as f64;
        (0..n)
            .map(|k| {
                let t = (k as f64 + 0.5) * h;
                f(t) * t.sin() * t.cos()
            })
            .sum::<f64>()
            * h
    }

    fn window(a: f32, w: f32) -> impl Fn(f64) -> f64 {
        let (t0, t1) = (
            (a - w / 2.0).to_radians() as f64,
            (a + w / 2.0).to_radians() as f64,
        );
        move |t| ((t1 - t) / (t1 - t0)).clamp(0.0, 1.0)
    }

    #[test]
    fn the_window_emits_the_fixtures_power_and_follows_its_visibility() {
        // The disk's visibility falls almost linearly from the axis
        // (1 − 2s/π): the window starts there. Power: ∫ V θ dθ = (r/L)²/2
        // for small angles.
        let f = flashlight();
        let (a, w) = window_from_visibility(|t| f.visibility(t));
        assert!(a - w / 2.0 < 0.2, "a {a} w {w}");
        let p_fixture = power(|t| f.visibility(t));
        let p_window = power(window(a, w));
        assert!(
            (p_window / p_fixture - 1.0).abs() < 1e-3,
            "{p_window} {p_fixture}"
        );
        // (exact in the limit of a long tube)
        let thin = Flashlight {
            length: 2.0,
            ..flashlight()
        };
        let p_thin = power(|t| thin.visibility(t));
        assert!(
            (p_thin / (0.5 * 0.01f64.powi(2)) - 1.0).abs() < 1e-3,
            "{p_thin}"
        );
        // a is where the beam has about halved.
        let v_at_a = f.visibility((a as f64).to_radians());
        assert!((0.4..0.6).contains(&v_at_a), "V(a) = {v_at_a}");
        // A wide, shallow lamp needs a window that starts off the axis.
        let lamp = lamp();
        let (a, w) = window_from_visibility(|t| lamp.visibility(t));
        assert!(a - w / 2.0 > 5.0 && a + w / 2.0 <= 90.0, "a {a} w {w}");
        let p = power(|t| lamp.visibility(t));
        assert!((power(window(a, w)) / p - 1.0).abs() < 1e-3);
    }

    fn lamp() -> Lamp {
        Lamp {
            name: "l".into(),
            emitter_center: Vec3::new(0.0, 0.0, 2.5),
            normal: Vec3::new(0.0, 0.0, -1.0),
            u: Vec3::X,
            half_size: [0.2, 0.2],
            depth: 0.1,
            radiance: 10.0,
            color: [1.0; 3],
        }
    }

    #[test]
    fn a_lamps_visibility_is_one_on_axis_and_matches_a_square_along_its_sides() {
        let lamp = lamp();
        assert!((lamp.visibility(0.0) - 1.0).abs() < 1e-12);
        assert!(lamp.visibility(89f64.to_radians()) == 0.0);
        // Halfway to the cut-off along the sides, `(1 − s/2)` on one axis;
        // averaged over φ it lies between the side and diagonal values.
        let theta = (2.0f64).atan(); // shift = 0.2 = half the side
        let v = lamp.visibility(theta);
        assert!(v > 0.35 && v < 0.5, "{v}");
    }

    #[test]
    fn the_derived_lights_are_valid_and_have_the_emitters_area() {
        let f = flashlight();
        let pls = f.pls();
        pls.validate(0).unwrap();
        let area = pls.outline_area();
        assert!((area - f.emitter_area()).abs() / f.emitter_area() < 1e-4);
    }
}
