//! Fresnel reflectance: the fraction of light a smooth interface reflects.
//!
//! - [`schlick`]: Schlick's approximation from the normal-incidence
//!   reflectance `f0` (per RGB channel);
//! - [`dielectric`]: the exact unpolarised reflectance of a dielectric
//!   interface with relative index of refraction `eta` (inside over outside);
//! - [`conductor`]: the exact reflectance of a conductor with complex index
//!   `eta + i·k` (per RGB channel).
//!
//! All take `cos θi`, the cosine between the incident direction and the
//! (micro)surface normal.

use glam::Vec3;

/// Schlick's weight `(1 − cos θ)⁵`.
#[inline(always)]
pub fn schlick_weight(cos_theta: f32) -> f32 {
    let m = (1.0 - cos_theta).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// Schlick's approximation `F = f0 + (1 − f0)(1 − cos θ)⁵`.
#[inline(always)]
pub fn schlick(f0: Vec3, cos_theta: f32) -> Vec3 {
    f0 + (Vec3::ONE - f0) * schlick_weight(cos_theta)
}

/// Normal-incidence reflectance `((η − 1)/(η + 1))²` of a dielectric.
#[inline(always)]
pub fn dielectric_f0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// Exact Fresnel reflectance of a dielectric interface.
///
/// `cos_theta_i` is signed: positive when the incident direction lies on the
/// outside (the side the normal points to), negative inside, where the
/// relative index `eta` (inside / outside) is inverted. Total internal
/// reflection gives 1.
#[inline(always)]
pub fn dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parallel = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perpendicular = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular)
}

/// A complex number, just enough arithmetic for [`conductor`].
#[derive(Debug, Clone, Copy, PartialEq)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    #[inline(always)]
    fn new(re: f32, im: f32) -> Complex {
        Complex { re, im }
    }
    #[inline(always)]
    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }
    #[inline(always)]
    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }
    #[inline(always)]
    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    #[inline(always)]
    fn div(self, o: Complex) -> Complex {
        let d = o.re * o.re + o.im * o.im;
        Complex::new(
            (self.re * o.re + self.im * o.im) / d,
            (self.im * o.re - self.re * o.im) / d,
        )
    }
    #[inline(always)]
    fn norm(self) -> f32 {
        self.re * self.re + self.im * self.im
    }
    /// Principal square root.
    #[inline(always)]
    fn sqrt(self) -> Complex {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Exact Fresnel reflectance of one channel of a conductor with complex
/// index of refraction `eta + i·k` (relative to the outside medium).
#[inline(always)]
fn conductor_channel(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let eta = Complex::new(eta, k);
    let cos_i_c = Complex::new(cos_i, 0.0);
    let sin2_i = Complex::new(1.0 - cos_i * cos_i, 0.0);
    let sin2_t = sin2_i.div(eta.mul(eta));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let r_parallel = eta.mul(cos_i_c).sub(cos_t).div(eta.mul(cos_i_c).add(cos_t));
    let r_perpendicular = cos_i_c.sub(eta.mul(cos_t)).div(cos_i_c.add(eta.mul(cos_t)));
    0.5 * (r_parallel.norm() + r_perpendicular.norm())
}

/// Exact Fresnel reflectance of a conductor, per RGB channel.
#[inline(always)]
pub fn conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        conductor_channel(cos_theta_i, eta.x, k.x),
        conductor_channel(cos_theta_i, eta.y, k.y),
        conductor_channel(cos_theta_i, eta.z, k.z),
    )
}

/// Refracts `wi` (pointing away from the surface) through the interface with
/// normal `n` and relative index `eta` (inside / outside, the normal pointing
/// outside): `(direction, relative index η_t/η_i crossed, total internal
/// reflection?)`, the direction pointing away on the other side, and
/// meaningless where the last is true.
///
/// The flag rather than an `Option`: a lane loop that tests it with a select,
/// instead of returning early, stays vector code (see
/// [`super::DielectricParams`]).
#[inline(always)]
pub fn refract_or_total(wi: Vec3, n: Vec3, eta: f32) -> (Vec3, f32, bool) {
    let cos_i = n.dot(wi);
    // From inside, the index is inverted and the normal turned around.
    let inside = cos_i < 0.0;
    let (eta, cos_i, n) = if inside {
        (1.0 / eta, -cos_i, -n)
    } else {
        (eta, cos_i, n)
    };
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    (-wi / eta + (cos_i / eta - cos_t) * n, eta, sin2_t >= 1.0)
}

/// Mirror reflection of `wo` about `n`.
#[inline(always)]
pub fn reflect(wo: Vec3, n: Vec3) -> Vec3 {
    -wo + 2.0 * wo.dot(n) * n
}

/// Complex indices of refraction `(eta, k)` of common metals at the red,
/// green and blue primaries (about 650, 550 and 450 nm).
pub const METALS: [(&str, [f32; 3], [f32; 3]); 4] = [
    ("Au", [0.143, 0.374, 1.442], [3.983, 2.385, 1.603]),
    ("Ag", [0.155, 0.117, 0.138], [4.828, 3.122, 2.147]),
    ("Cu", [0.200, 0.924, 1.102], [3.912, 2.452, 2.142]),
    ("Al", [1.657, 0.880, 0.521], [9.224, 6.270, 4.837]),
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_at_normal_incidence_is_f0() {
        for eta in [1.33f32, 1.5, 2.4] {
            assert!((dielectric(1.0, eta) - dielectric_f0(eta)).abs() < 1e-6);
            // From inside, normal incidence gives the same value.
            assert!((dielectric(-1.0, eta) - dielectric_f0(eta)).abs() < 1e-6);
        }
    }

    #[test]
    fn dielectric_total_internal_reflection_and_grazing() {
        // Inside glass (η = 1.5) beyond the critical angle asin(1/1.5) ≈ 41.8°.
        let cos = 45f32.to_radians().cos();
        assert_eq!(dielectric(-cos, 1.5), 1.0);
        assert!(dielectric(1e-4, 1.5) > 0.99);
        // Brewster's angle: the parallel component vanishes, F = r_perp² / 2.
        let tb = 1.5f32.atan();
        let (ci, ct) = (tb.cos(), (tb.sin() / 1.5).asin().cos());
        let rs = (ci - 1.5 * ct) / (ci + 1.5 * ct);
        assert!((dielectric(ci, 1.5) - 0.5 * rs * rs).abs() < 1e-5);
    }

    #[test]
    fn conductor_with_zero_k_matches_dielectric() {
        for cos in [1.0f32, 0.7, 0.3, 0.05] {
            let c = conductor(cos, Vec3::splat(1.5), Vec3::ZERO);
            assert!((c.x - dielectric(cos, 1.5)).abs() < 1e-5, "{cos}");
        }
    }

    #[test]
    fn conductor_at_normal_incidence() {
        // ((η−1)² + k²) / ((η+1)² + k²), gold's red channel.
        let (eta, k) = (0.143f32, 3.983f32);
        let want = ((eta - 1.0).powi(2) + k * k) / ((eta + 1.0).powi(2) + k * k);
        let got = conductor(1.0, Vec3::splat(eta), Vec3::splat(k)).x;
        assert!((got - want).abs() < 1e-5, "{got} vs {want}");
    }

    #[test]
    fn refraction_obeys_snell_and_reverses() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let (wt, eta, total) = refract_or_total(wi, Vec3::Z, 1.5);
        assert!(!total);
        assert_eq!(eta, 1.5);
        assert!(wt.z < 0.0);
        assert!((wt.length() - 1.0).abs() < 1e-6);
        // sin θi = η sin θt
        assert!((0.6 - 1.5 * wt.x.abs()).abs() < 1e-6);
        let (back, _, total) = refract_or_total(wt, Vec3::Z, 1.5);
        assert!(!total);
        assert!((back - wi).length() < 1e-5);
        // Beyond the critical angle from inside (sin θ > 1/1.5): total
        // internal reflection.
        let (_, eta, total) = refract_or_total(Vec3::new(0.8, 0.0, -0.6), Vec3::Z, 1.5);
        assert!(total);
        assert_eq!(eta, 1.0 / 1.5);
    }
}
