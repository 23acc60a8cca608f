//! Lens distortion: where a real lens moves the image of a direction, as
//! OpenCV and COLMAP model it.
//!
//! Both models act on a direction `(x, y, z)` in the camera's frame in the
//! **OpenCV convention** (x to the image's right, y down, z along the view)
//! and give *distorted normalised coordinates* `(x_d, y_d)`, which the
//! camera's intrinsics then map to pixels (`u = f_x·x_d + s·y_d + c_x`,
//! `v = f_y·y_d + c_y`; see [`crate::calibrated_camera`]).
//!
//! - [`LensDistortion::BrownConrady`], OpenCV's default model (its
//!   `calibrateCamera`, COLMAP's `OPENCV` and `FULL_OPENCV`): with
//!   `(x', y') = (x/z, y/z)` and `r² = x'² + y'²`,
//!
//!   ```text
//!   x_d = x'·R + 2p₁x'y' + p₂(r² + 2x'²) + s₁r² + s₂r⁴
//!   y_d = y'·R + p₁(r² + 2y'²) + 2p₂x'y' + s₃r² + s₄r⁴
//!   R   = (1 + k₁r² + k₂r⁴ + k₃r⁶) / (1 + k₄r² + k₅r⁴ + k₆r⁶)
//!   ```
//!
//!   radial `k₁…k₃`, tangential (decentring) `p₁, p₂`, the rational model's
//!   `k₄…k₆` and the thin prism's `s₁…s₄`. Coefficients are given in
//!   OpenCV's order: `k₁, k₂, p₁, p₂[, k₃[, k₄, k₅, k₆[, s₁, s₂, s₃, s₄]]]`
//!   (4, 5, 8 or 12 numbers). OpenCV's tilted-sensor model (14 numbers) is
//!   not supported.
//! - [`LensDistortion::Fisheye`], OpenCV's `cv::fisheye` model (COLMAP's
//!   `OPENCV_FISHEYE`): with `θ` the angle from the optical axis,
//!   `θ_d = θ(1 + k₁θ² + k₂θ⁴ + k₃θ⁶ + k₄θ⁸)` and
//!   `(x_d, y_d) = θ_d·(x, y)/√(x² + y²)`. OpenCV computes `θ = atan(r)`,
//!   valid in front of the lens; plsr uses `θ = atan2(r, z)`, the same there
//!   and defined up to 180°, for lenses that see behind their centre.
//!
//! **Inversion.** Rendering needs the other direction: the ray through a
//! pixel. Neither model has a closed-form inverse; plsr solves it by a
//! damped Newton iteration in double precision (2-D for Brown–Conrady, on
//! `θ` for the fisheye) to 1e-12. A polynomial fitted to a lens is only
//! valid out to where its radial map stops growing (beyond, it folds back
//! and two directions would share a pixel): each model finds that radius
//! when it is built ([`LensDistortion::max_radius`]), and directions and
//! pixels beyond it have no image and no ray (such pixels stay black).

use glam::{DVec2, DVec3};

/// Why a set of distortion coefficients is refused.
#[derive(Debug, Clone, PartialEq)]
pub enum DistortionError {
    /// Not 4, 5, 8 or 12 numbers (Brown–Conrady), or not 4 (fisheye).
    Count {
        /// The model's name.
        model: &'static str,
        /// How many were given.
        given: usize,
    },
    /// A coefficient that is not a finite number.
    NotFinite {
        /// Its index in OpenCV's order.
        index: usize,
    },
}

impl std::fmt::Display for DistortionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DistortionError::Count { model, given } if *model == "fisheye" => write!(
                f,
                "the fisheye model takes 4 coefficients (k1, k2, k3, k4), got {given}"
            ),
            DistortionError::Count { given, .. } => write!(
                f,
                "the Brown–Conrady model takes 4, 5, 8 or 12 coefficients in OpenCV's order \
                 (k1, k2, p1, p2[, k3[, k4, k5, k6[, s1, s2, s3, s4]]]), got {given}{}",
                if *given == 14 {
                    " (OpenCV's tilted-sensor model, τx and τy, is not supported)"
                } else {
                    ""
                }
            ),
            DistortionError::NotFinite { index } => {
                write!(f, "coefficient {index} is not a finite number")
            }
        }
    }
}

impl std::error::Error for DistortionError {}

/// The coefficients of OpenCV's standard (Brown–Conrady) model.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BrownConrady {
    /// Radial `k₁…k₆` (`k₄…k₆` are the rational model's denominator).
    pub k: [f64; 6],
    /// Tangential `p₁, p₂`.
    pub p: [f64; 2],
    /// Thin prism `s₁…s₄`.
    pub s: [f64; 4],
}

/// A lens's distortion model and its coefficients (see the module's doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LensDistortion {
    /// An ideal pinhole: `(x_d, y_d) = (x/z, y/z)`.
    None,
    /// OpenCV's standard model (radial, tangential, rational, thin prism),
    /// valid out to `max_radius` (of `r`, before distortion).
    BrownConrady {
        /// The coefficients.
        coefficients: BrownConrady,
        /// Where `r·R(r)` stops growing (or a large bound).
        max_radius: f64,
    },
    /// OpenCV's fisheye model, valid out to `max_theta` radians.
    Fisheye {
        /// `k₁…k₄`.
        k: [f64; 4],
        /// Where `θ_d(θ)` stops growing, at most π.
        max_theta: f64,
    },
}

/// Largest undistorted radius `r = tan θ` searched for a fold: 89.5° off axis.
const MAX_PINHOLE_RADIUS: f64 = 114.6;
/// Newton's tolerance on the solution, in normalised coordinates or radians.
const NEWTON_TOLERANCE: f64 = 1e-12;
/// Newton's iterations before giving up.
const NEWTON_ITERATIONS: usize = 50;

impl BrownConrady {
    /// The radial factor `R(r²)` and its derivative with respect to `r²`.
    #[inline]
    fn radial(&self, r2: f64) -> (f64, f64) {
        let k = &self.k;
        let a = 1.0 + r2 * (k[0] + r2 * (k[1] + r2 * k[2]));
        let b = 1.0 + r2 * (k[3] + r2 * (k[4] + r2 * k[5]));
        let da = k[0] + r2 * (2.0 * k[1] + 3.0 * r2 * k[2]);
        let db = k[3] + r2 * (2.0 * k[4] + 3.0 * r2 * k[5]);
        (a / b, (da * b - a * db) / (b * b))
    }

    /// The distorted coordinates of undistorted `(x', y')`, and the 2×2
    /// Jacobian `∂(x_d, y_d)/∂(x', y')` as rows.
    #[inline]
    fn apply(&self, q: DVec2) -> (DVec2, [[f64; 2]; 2]) {
        let (x, y) = (q.x, q.y);
        let r2 = x * x + y * y;
        let (rad, drad) = self.radial(r2);
        let [p1, p2] = self.p;
        let [s1, s2, s3, s4] = self.s;
        let d = DVec2::new(
            x * rad + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x) + s1 * r2 + s2 * r2 * r2,
            y * rad + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y + s3 * r2 + s4 * r2 * r2,
        );
        let sx = s1 + 2.0 * s2 * r2;
        let sy = s3 + 2.0 * s4 * r2;
        let j = [
            [
                rad + 2.0 * x * x * drad + 2.0 * p1 * y + 6.0 * p2 * x + 2.0 * x * sx,
                2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * y * sx,
            ],
            [
                2.0 * x * y * drad + 2.0 * p1 * x + 2.0 * p2 * y + 2.0 * x * sy,
                rad + 2.0 * y * y * drad + 6.0 * p1 * y + 2.0 * p2 * x + 2.0 * y * sy,
            ],
        ];
        (d, j)
    }

    /// Where the radial map `r·R(r²)` first stops growing, searched out to
    /// [`MAX_PINHOLE_RADIUS`] (which it returns if it never does).
    fn fold_radius(&self) -> f64 {
        fold_of(MAX_PINHOLE_RADIUS, |r| {
            let (rad, drad) = self.radial(r * r);
            // d/dr (r·R(r²)) = R + 2r²·R'; a pole of the rational model
            // (a denominator through zero) counts as a fold too.
            let b = 1.0 + r * r * (self.k[3] + r * r * (self.k[4] + r * r * self.k[5]));
            if b <= 0.0 {
                -1.0
            } else {
                rad + 2.0 * r * r * drad
            }
        })
    }
}

/// The first `x` in `(0, limit]` where `slope(x) ≤ 0`, searched on a
/// geometric-then-uniform grid and refined by bisection; `limit` if none.
fn fold_of(limit: f64, slope: impl Fn(f64) -> f64) -> f64 {
    const STEPS: usize = 20_000;
    let mut prev = 0.0;
    for i in 1..=STEPS {
        // Fine steps near the axis, where the image is, coarser beyond.
        let t = i as f64 / STEPS as f64;
        let x = limit * t * t;
        let s = slope(x);
        if s.is_nan() || s <= 0.0 {
            let (mut lo, mut hi) = (prev, x);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if slope(mid) > 0.0 {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            return lo;
        }
        prev = x;
    }
    limit
}

/// The fisheye's `θ_d(θ)` and its derivative.
#[inline]
fn fisheye_theta_d(k: &[f64; 4], theta: f64) -> (f64, f64) {
    let t2 = theta * theta;
    let poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
    let dpoly = t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
    (theta * poly, 1.0 + dpoly)
}

impl LensDistortion {
    /// The Brown–Conrady model from OpenCV's coefficient vector
    /// (`k₁, k₂, p₁, p₂[, k₃[, k₄, k₅, k₆[, s₁, s₂, s₃, s₄]]]`).
    pub fn brown_conrady(coefficients: &[f64]) -> Result<LensDistortion, DistortionError> {
        if !matches!(coefficients.len(), 4 | 5 | 8 | 12) {
            return Err(DistortionError::Count {
                model: "brown_conrady",
                given: coefficients.len(),
            });
        }
        check_finite(coefficients)?;
        let c = |i: usize| coefficients.get(i).copied().unwrap_or(0.0);
        let coefficients = BrownConrady {
            k: [c(0), c(1), c(4), c(5), c(6), c(7)],
            p: [c(2), c(3)],
            s: [c(8), c(9), c(10), c(11)],
        };
        Ok(LensDistortion::BrownConrady {
            max_radius: coefficients.fold_radius(),
            coefficients,
        })
    }

    /// OpenCV's fisheye model from `k₁…k₄`.
    pub fn fisheye(coefficients: &[f64]) -> Result<LensDistortion, DistortionError> {
        let k: [f64; 4] = coefficients
            .try_into()
            .map_err(|_| DistortionError::Count {
                model: "fisheye",
                given: coefficients.len(),
            })?;
        check_finite(&k)?;
        let max_theta = fold_of(std::f64::consts::PI, |t| fisheye_theta_d(&k, t).1);
        Ok(LensDistortion::Fisheye { k, max_theta })
    }

    /// The model's name in scene files: `none`, `brown_conrady`, `fisheye`.
    pub fn model_name(&self) -> &'static str {
        match self {
            LensDistortion::None => "none",
            LensDistortion::BrownConrady { .. } => "brown_conrady",
            LensDistortion::Fisheye { .. } => "fisheye",
        }
    }

    /// The coefficients in OpenCV's order, as few as say them all (4, 5, 8
    /// or 12 for Brown–Conrady; 4 for the fisheye; none for `None`).
    pub fn coefficients(&self) -> Vec<f64> {
        match self {
            LensDistortion::None => Vec::new(),
            LensDistortion::BrownConrady {
                coefficients: c, ..
            } => {
                let all = [
                    c.k[0], c.k[1], c.p[0], c.p[1], c.k[2], c.k[3], c.k[4], c.k[5], c.s[0], c.s[1],
                    c.s[2], c.s[3],
                ];
                let n = if c.s.iter().any(|&s| s != 0.0) {
                    12
                } else if c.k[3..].iter().any(|&k| k != 0.0) {
                    8
                } else if c.k[2] != 0.0 {
                    5
                } else {
                    4
                };
                all[..n].to_vec()
            }
            LensDistortion::Fisheye { k, .. } => k.to_vec(),
        }
    }

    /// How far from the axis the model is valid: the undistorted radius
    /// `r = tan θ` for a pinhole model, the angle `θ` (radians) for the
    /// fisheye.
    pub fn max_radius(&self) -> f64 {
        match self {
            LensDistortion::None => MAX_PINHOLE_RADIUS,
            LensDistortion::BrownConrady { max_radius, .. } => *max_radius,
            LensDistortion::Fisheye { max_theta, .. } => *max_theta,
        }
    }

    /// The distorted normalised coordinates of a direction in the camera's
    /// frame (OpenCV axes), or `None` where the model has no image of it:
    /// behind a pinhole model (`z ≤ 0`) or beyond [`Self::max_radius`].
    #[inline]
    pub fn distort(&self, dir: DVec3) -> Option<DVec2> {
        match self {
            LensDistortion::None => (dir.z > 0.0).then(|| DVec2::new(dir.x / dir.z, dir.y / dir.z)),
            LensDistortion::BrownConrady {
                coefficients,
                max_radius,
            } => {
                if dir.z.is_nan() || dir.z <= 0.0 {
                    return None;
                }
                let q = DVec2::new(dir.x / dir.z, dir.y / dir.z);
                // The slack keeps the image of a direction that undistort
                // found at the fold itself, whatever the rounding.
                if q.length_squared() > max_radius * max_radius * (1.0 + 1e-9) {
                    return None;
                }
                Some(coefficients.apply(q).0)
            }
            LensDistortion::Fisheye { k, max_theta } => {
                let r = dir.x.hypot(dir.y);
                let theta = r.atan2(dir.z);
                if theta.is_nan() || theta > *max_theta * (1.0 + 1e-12) {
                    return None;
                }
                if r == 0.0 {
                    return (dir.z > 0.0).then_some(DVec2::ZERO);
                }
                let (theta_d, _) = fisheye_theta_d(k, theta);
                Some(DVec2::new(dir.x, dir.y) * (theta_d / r))
            }
        }
    }

    /// The unit direction in the camera's frame (OpenCV axes) whose image is
    /// at distorted normalised coordinates `d`, or `None` where no direction
    /// within [`Self::max_radius`] has its image there.
    #[inline]
    pub fn undistort(&self, d: DVec2) -> Option<DVec3> {
        match self {
            LensDistortion::None => Some(DVec3::new(d.x, d.y, 1.0).normalize()),
            LensDistortion::BrownConrady {
                coefficients,
                max_radius,
            } => {
                let q = newton_2d(coefficients, d, *max_radius)?;
                Some(DVec3::new(q.x, q.y, 1.0).normalize())
            }
            LensDistortion::Fisheye { k, max_theta } => {
                let theta_d = d.length();
                if !theta_d.is_finite() {
                    return None;
                }
                if theta_d == 0.0 {
                    return Some(DVec3::Z);
                }
                let theta = newton_theta(k, theta_d, *max_theta)?;
                let (s, c) = theta.sin_cos();
                let xy = d * (s / theta_d);
                Some(DVec3::new(xy.x, xy.y, c))
            }
        }
    }
}

fn check_finite(c: &[f64]) -> Result<(), DistortionError> {
    match c.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(DistortionError::NotFinite { index }),
        None => Ok(()),
    }
}

/// Undistorts `target` by damped Newton steps on `apply(q) = target`,
/// starting from the target divided by its radial factor; `None` if it does
/// not converge within `max_radius` to a point where the map is locally
/// invertible and orientation-preserving.
fn newton_2d(model: &BrownConrady, target: DVec2, max_radius: f64) -> Option<DVec2> {
    if !target.is_finite() {
        return None;
    }
    let r2_max = max_radius * max_radius;
    let mut q = target;
    if q.length_squared() <= r2_max {
        let (rad, _) = model.radial(q.length_squared());
        if rad > 0.0 {
            q /= rad;
        }
    }
    if q.length_squared() > r2_max {
        q *= max_radius / q.length();
    }
    let (mut image, mut jac) = model.apply(q);
    let mut residual = (image - target).length_squared();
    for _ in 0..NEWTON_ITERATIONS {
        let e = image - target;
        let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
        if det.is_nan() || det <= 0.0 {
            return None;
        }
        let step = DVec2::new(
            (jac[1][1] * e.x - jac[0][1] * e.y) / det,
            (jac[0][0] * e.y - jac[1][0] * e.x) / det,
        );
        // Halve the step until the residual falls (or the step vanishes).
        let mut scale = 1.0;
        let mut accepted = false;
        for _ in 0..30 {
            let next = q - step * scale;
            if next.length_squared() <= r2_max {
                let (next_image, next_jac) = model.apply(next);
                let next_residual = (next_image - target).length_squared();
                if next_residual < residual || next_residual == 0.0 {
                    q = next;
                    (image, jac, residual) = (next_image, next_jac, next_residual);
                    accepted = true;
                    break;
                }
            }
            scale *= 0.5;
        }
        let moved = (step * scale).length();
        if !accepted || moved <= NEWTON_TOLERANCE * (1.0 + q.length()) {
            break;
        }
    }
    let det = jac[0][0] * jac[1][1] - jac[0][1] * jac[1][0];
    let tolerance = 1e-9 * (1.0 + target.length());
    (residual.sqrt() <= tolerance && det > 0.0).then_some(q)
}

/// Solves `θ_d(θ) = theta_d` for `θ ∈ [0, max_theta]` by Newton steps kept
/// inside the bracket (bisection when a step leaves it).
fn newton_theta(k: &[f64; 4], theta_d: f64, max_theta: f64) -> Option<f64> {
    let (top, _) = fisheye_theta_d(k, max_theta);
    if theta_d > top {
        return None;
    }
    let (mut lo, mut hi) = (0.0, max_theta);
    let mut theta = theta_d.min(max_theta);
    for _ in 0..NEWTON_ITERATIONS * 2 {
        let (f, df) = fisheye_theta_d(k, theta);
        let e = f - theta_d;
        if e > 0.0 {
            hi = theta;
        } else {
            lo = theta;
        }
        let mut next = theta - e / df;
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        let moved = (next - theta).abs();
        theta = next;
        if moved <= NEWTON_TOLERANCE * (1.0 + theta) {
            break;
        }
    }
    let (f, _) = fisheye_theta_d(k, theta);
    ((f - theta_d).abs() <= 1e-9 * (1.0 + theta_d)).then_some(theta)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn models() -> Vec<LensDistortion> {
        vec![
            LensDistortion::None,
            LensDistortion::brown_conrady(&[-0.28, 0.09, 0.0012, -0.0008, -0.012]).unwrap(),
            LensDistortion::brown_conrady(&[
                0.8, -0.2, 0.001, -0.002, 0.04, 1.1, -0.15, 0.05, 0.001, -0.0005, 0.0007, 0.0002,
            ])
            .unwrap(),
            LensDistortion::fisheye(&[0.05, -0.01, 0.003, -0.0005]).unwrap(),
        ]
    }

    #[test]
    fn undistort_inverts_distort_over_the_valid_domain() {
        let mut rng = crate::rng::Rng::new(7, 1);
        for model in models() {
            // Directions up to 60° off axis, or the model's fold.
            let max_angle = match model {
                LensDistortion::Fisheye { max_theta, .. } => max_theta.min(1.5) * 0.95,
                _ => model.max_radius().atan().min(60f64.to_radians()) * 0.95,
            };
            for _ in 0..2000 {
                let theta = max_angle * rng.next_f32() as f64;
                let phi = std::f64::consts::TAU * rng.next_f32() as f64;
                let dir = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let d = model.distort(dir).expect("inside the domain");
                let back = model.undistort(d).expect("invertible");
                assert!(
                    (back - dir).length() < 1e-9,
                    "{model:?}: {dir} -> {d} -> {back}"
                );
            }
        }
    }

    #[test]
    fn the_jacobian_is_the_derivative() {
        let LensDistortion::BrownConrady { coefficients, .. } = models()[2] else {
            unreachable!()
        };
        for q in [
            DVec2::new(0.3, -0.2),
            DVec2::new(-0.5, 0.45),
            DVec2::new(0.05, 0.7),
        ] {
            let (_, j) = coefficients.apply(q);
            let h = 1e-6;
            for (axis, dq) in [DVec2::new(h, 0.0), DVec2::new(0.0, h)]
                .into_iter()
                .enumerate()
            {
                let numeric =
                    (coefficients.apply(q + dq).0 - coefficients.apply(q - dq).0) / (2.0 * h);
                assert!((numeric.x - j[0][axis]).abs() < 1e-7, "{q} axis {axis}");
                assert!((numeric.y - j[1][axis]).abs() < 1e-7, "{q} axis {axis}");
            }
        }
    }

    #[test]
    fn a_folding_polynomial_has_no_image_beyond_its_fold() {
        // r·(1 − 0.3r²) grows until r = 1/√0.9.
        let model = LensDistortion::brown_conrady(&[-0.3, 0.0, 0.0, 0.0]).unwrap();
        let fold = (1.0f64 / 0.9).sqrt();
        assert!(
            (model.max_radius() - fold).abs() < 1e-9,
            "{}",
            model.max_radius()
        );
        assert!(model.distort(DVec3::new(1.1, 0.0, 1.0)).is_none());
        // The fold's image is the largest distorted radius: beyond, no ray.
        let top = fold * (1.0 - 0.3 * fold * fold);
        assert!(model.undistort(DVec2::new(top * 1.001, 0.0)).is_none());
        assert!(model.undistort(DVec2::new(top * 0.99, 0.0)).is_some());
    }

    #[test]
    fn coefficients_round_trip_in_opencvs_order() {
        for c in [
            vec![0.1, -0.2, 0.01, 0.02],
            vec![0.1, -0.2, 0.01, 0.02, 0.3],
            vec![0.1, -0.2, 0.01, 0.02, 0.3, 0.4, 0.5, 0.6],
            vec![
                0.1, -0.2, 0.01, 0.02, 0.3, 0.4, 0.5, 0.6, 0.07, 0.08, 0.09, 0.1,
            ],
        ] {
            assert_eq!(LensDistortion::brown_conrady(&c).unwrap().coefficients(), c);
        }
        assert_eq!(
            LensDistortion::fisheye(&[0.1, 0.2, 0.3, 0.4])
                .unwrap()
                .coefficients(),
            vec![0.1, 0.2, 0.3, 0.4]
        );
        let e = LensDistortion::brown_conrady(&[0.0; 14]).unwrap_err();
        assert!(e.to_string().contains("tilted"), "{e}");
        let e = LensDistortion::fisheye(&[0.0, f64::NAN, 0.0, 0.0]).unwrap_err();
        assert_eq!(e, DistortionError::NotFinite { index: 1 });
    }
}
