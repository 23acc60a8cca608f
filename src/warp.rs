//! Warps from the unit square to directions and points, discrete
//! distributions, and the MIS heuristic.
//!
//! Every warp comes with its density so that `sample` and `pdf` cannot drift
//! apart; the chi-square tests in `tests/it/sampling_chi2.rs` check each pair.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, PI};

/// An orthonormal basis around a unit normal `n` (Duff et al. 2017).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// The normal.
    pub n: Vec3,
}

impl Frame {
    /// A frame whose third axis is the unit vector `n`.
    #[inline]
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame with normal `n` (unit) and first tangent along the part of
    /// `tangent` perpendicular to `n` (Gram–Schmidt); an arbitrary tangent
    /// where that part vanishes.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, tangent: Vec3) -> Frame {
        match (tangent - n * n.dot(tangent)).try_normalize() {
            Some(s) => Frame {
                s,
                t: n.cross(s),
                n,
            },
            None => Frame::from_normal(n),
        }
    }

    /// World to local coordinates.
    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Local to world coordinates.
    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

/// Concentric map of the unit square onto the unit disk (Shirley–Chiu).
#[inline(always)]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    // Written with selects, not branches, so that the vectorised kernel
    // calls it lane by lane (the same operations either way).
    let o = 2.0 * u - Vec2::ONE;
    // θ = φ in the wedges around ±x and θ = π/2 − φ in those around ±y, with
    // φ ∈ [−π/4, π/4]; cos(π/2 − φ) = sin φ, so only (cos φ, sin φ) is needed.
    let wide = o.x.abs() > o.y.abs();
    let (major, minor) = if wide { (o.x, o.y) } else { (o.y, o.x) };
    let (sin, cos) = sin_cos_quarter((PI / 4.0) * (minor / major));
    let d = if wide {
        major * Vec2::new(cos, sin)
    } else {
        major * Vec2::new(sin, cos)
    };
    if o.x == 0.0 && o.y == 0.0 {
        Vec2::ZERO
    } else {
        d
    }
}

/// `(sin φ, cos φ)` for `φ ∈ [−π/4, π/4]` by Taylor polynomials (absolute
/// error below 4e-7, about the spacing of `f32` near 1), several times
/// cheaper than the library's `sin_cos`, which reduces arbitrary arguments.
#[inline(always)]
pub(crate) fn sin_cos_quarter(phi: f32) -> (f32, f32) {
    let x2 = phi * phi;
    let sin = phi * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0))));
    let cos = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0))));
    (sin, cos)
}

/// Cosine-weighted direction on the hemisphere around +z (local frame).
#[inline(always)]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// Solid-angle density of [`square_to_cosine_hemisphere`]: `cos θ / π`.
#[inline(always)]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    if cos_theta > 0.0 {
        cos_theta * FRAC_1_PI
    } else {
        0.0
    }
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Solid-angle density of [`square_to_uniform_sphere`]: `1 / 4π`.
pub const UNIFORM_SPHERE_PDF: f32 = 1.0 / (4.0 * PI);

/// Barycentrics `(b1, b2)` of a uniform point on a triangle (the point is
/// `(1 − b1 − b2)·p0 + b1·p1 + b2·p2`); area density is `1 / area`.
#[inline(always)]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    // Heitz 2019, "A low-distortion map between triangle and square";
    // selects rather than branches, for the vectorised kernel.
    let upper = u.y > u.x;
    let half = if upper { u.x } else { u.y } / 2.0;
    let (b0, b1) = if upper {
        (half, u.y - half)
    } else {
        (u.x - half, half)
    };
    Vec2::new(b1, 1.0 - b0 - b1)
}

/// Solid angle (sr) subtended at the origin by the triangle with unit
/// vertex directions `a`, `b`, `c` (Van Oosterom and Strackee 1983).
#[inline]
pub fn spherical_triangle_area(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    2.0 * num.atan2(den)
}

/// A direction uniformly distributed over the solid angle of the triangle
/// `v` seen from `p` (Arvo 1995, in the form of pbrt-v4's
/// `SampleSphericalTriangle`), and its density `1 / solid angle`. `None` for
/// a degenerate or vanishing triangle.
pub fn sample_spherical_triangle(v: &[Vec3; 3], p: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
    let a = (v[0] - p).try_normalize()?;
    let b = (v[1] - p).try_normalize()?;
    let c = (v[2] - p).try_normalize()?;
    let n_ab = a.cross(b).try_normalize()?;
    let n_bc = b.cross(c).try_normalize()?;
    let n_ca = c.cross(a).try_normalize()?;
    let angle = |x: Vec3, y: Vec3| x.dot(y).clamp(-1.0, 1.0).acos();
    let alpha = angle(n_ab, -n_ca);
    let beta = angle(n_bc, -n_ab);
    let gamma = angle(n_ca, -n_bc);
    let area = alpha + beta + gamma - PI;
    if area.is_nan() || area <= 0.0 {
        return None;
    }
    // Sample the sub-triangle area A' uniformly in [0, A].
    let ap_pi = PI + u.x * area;
    let (sin_alpha, cos_alpha) = alpha.sin_cos();
    let (sin_ap, cos_ap) = ap_pi.sin_cos();
    let sin_phi = sin_ap * cos_alpha - cos_ap * sin_alpha;
    let cos_phi = cos_ap * cos_alpha + sin_ap * sin_alpha;
    let k1 = cos_phi + cos_alpha;
    let k2 = sin_phi - sin_alpha * a.dot(b);
    let cos_bp = ((k2 + (k2 * cos_phi - k1 * sin_phi) * cos_alpha)
        / ((k2 * sin_phi + k1 * cos_phi) * sin_alpha))
        .clamp(-1.0, 1.0);
    let sin_bp = (1.0 - cos_bp * cos_bp).max(0.0).sqrt();
    let c_perp = (c - c.dot(a) * a).try_normalize()?;
    let cp = cos_bp * a + sin_bp * c_perp;
    // Sample the arc between b and c'.
    let cos_theta = 1.0 - u.y * (1.0 - cp.dot(b));
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let cp_perp = (cp - cp.dot(b) * b).try_normalize()?;
    let w = cos_theta * b + sin_theta * cp_perp;
    Some((w.normalize(), 1.0 / area))
}

/// The power heuristic with β = 2 (Veach 1997) for two strategies with
/// `n = 1` sample each: the MIS weight of the strategy with density `pdf_a`.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a == 0.0 {
        0.0
    } else if a.is_infinite() {
        1.0
    } else {
        a / (a + b)
    }
}

/// Up to this many items, [`Distribution1D::sample`] searches the whole CDF
/// (a few steps), as the guide table would cost more than it saves.
const SMALL: usize = 16;

/// A discrete distribution over `n` items, sampled by a search on its CDF
/// that a guide table narrows to a few entries (the cutpoint method of Chen
/// and Asau, 1974) when there are more than [`SMALL`] items.
#[derive(Debug, Clone, Default)]
pub struct Distribution1D {
    pmf: Vec<f32>,
    /// `cdf[i]`: the probability of items `0..=i` (the last is exactly 1).
    cdf: Vec<f32>,
    /// `guide[j]`: the item a number `j / m` picks, for `m = guide.len()`
    /// (a power of two ≥ n, so `j / m` and `u · m` are exact); empty for
    /// [`SMALL`] items or fewer.
    guide: Vec<u32>,
    /// `skip[i]`: the first item from `i` on with a non-zero probability
    /// (the last item if none has), where a search landing on `i` ends.
    skip: Vec<u32>,
}

impl Distribution1D {
    /// A distribution proportional to `weights` (non-negative, finite). All-zero
    /// weights give an empty distribution that never samples.
    pub fn new(weights: &[f32]) -> Distribution1D {
        let total: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        if total <= 0.0 || !total.is_finite() {
            return Distribution1D {
                pmf: vec![0.0; weights.len()],
                cdf: vec![],
                guide: vec![],
                skip: vec![],
            };
        }
        let mut acc = 0.0f64;
        let mut cdf = Vec::with_capacity(weights.len());
        let pmf: Vec<f32> = weights
            .iter()
            .map(|&w| {
                let p = w.max(0.0) as f64 / total;
                acc += p;
                cdf.push(acc as f32);
                p as f32
            })
            .collect();
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let guide = if cdf.len() > SMALL {
            let m = cdf.len().next_power_of_two();
            (0..m)
                .map(|j| first_above(&cdf, j as f32 / m as f32) as u32)
                .collect()
        } else {
            Vec::new()
        };
        let mut skip = vec![0u32; cdf.len()];
        let mut next = cdf.len() - 1;
        for i in (0..cdf.len()).rev() {
            if pmf[i] != 0.0 {
                next = i;
            }
            skip[i] = next as u32;
        }
        Distribution1D {
            pmf,
            cdf,
            guide,
            skip,
        }
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.pmf.len()
    }

    /// Whether nothing can be sampled (no items or all weights zero).
    pub fn is_empty(&self) -> bool {
        self.cdf.is_empty()
    }

    /// Picks an item for `u ∈ [0, 1)`; returns `(index, probability)`.
    #[inline(always)]
    pub fn sample(&self, u: f32) -> Option<(usize, f32)> {
        if self.cdf.is_empty() {
            return None;
        }
        // The first item whose CDF exceeds u, then skipping zero-probability
        // items a rounding tie may land on.
        if self.guide.is_empty() {
            let i = self.skip[first_above(&self.cdf, u)] as usize;
            return Some((i, self.pmf[i]));
        }
        // With a guide: between the items of u's slot and of the next
        // slot's start, as the search is monotone in u.
        let m = self.guide.len();
        let j = ((u * m as f32) as usize).min(m - 1);
        let lo = self.guide[j] as usize;
        let hi = self
            .guide
            .get(j + 1)
            .map_or(self.cdf.len(), |&g| g as usize + 1);
        let i = self.skip[lo + first_above(&self.cdf[lo..hi], u)] as usize;
        Some((i, self.pmf[i]))
    }

    /// Probability of item `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.pmf.get(i).copied().unwrap_or(0.0)
    }
}

/// The first index of the non-decreasing `cdf` whose value exceeds `u`, at
/// most its last index.
#[inline]
fn first_above(cdf: &[f32], u: f32) -> usize {
    cdf.partition_point(|&c| c <= u).min(cdf.len() - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_for_all_normals() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.8).normalize(),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(n).abs() < 1e-5);
            let v = Vec3::new(0.2, 0.4, -0.7);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn distribution_matches_its_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert_eq!(d.pmf(1), 0.0);
        assert!((d.pmf(2) - 0.75).abs() < 1e-6);
        assert_eq!(d.sample(0.1).unwrap().0, 0);
        assert_eq!(d.sample(0.25).unwrap().0, 2);
        assert_eq!(d.sample(0.9999).unwrap().0, 2);
        assert!(Distribution1D::new(&[0.0, 0.0]).sample(0.5).is_none());
    }

    #[test]
    fn guided_sampling_picks_what_a_binary_search_picks() {
        let mut rng = crate::rng::Rng::new(3, 0);
        for n in [1usize, 2, 3, 5, 8, 9, 64, 100, 1000] {
            let weights: Vec<f32> = (0..n)
                .map(|i| match i % 4 {
                    0 => 0.0,
                    1 => rng.next_f32() * 1e-6,
                    _ => rng.next_f32(),
                })
                .collect();
            let d = Distribution1D::new(&weights);
            let reference = |u: f32| {
                let mut i = d.cdf.partition_point(|&c| c <= u).min(d.cdf.len() - 1);
                while d.pmf[i] == 0.0 && i + 1 < d.pmf.len() {
                    i += 1;
                }
                (i, d.pmf[i])
            };
            // Random numbers, and every CDF value and its neighbours.
            let mut us: Vec<f32> = (0..20_000).map(|_| rng.next_f32()).collect();
            for &c in &d.cdf {
                us.extend(
                    [c, c.next_down(), c.next_up()]
                        .into_iter()
                        .filter(|u| *u < 1.0),
                );
            }
            us.extend([0.0, 1.0f32.next_down()]);
            for u in us {
                if d.is_empty() {
                    assert!(d.sample(u).is_none());
                } else {
                    assert_eq!(d.sample(u), Some(reference(u)), "n = {n}, u = {u}");
                }
            }
        }
    }

    #[test]
    fn power_heuristic_weights_sum_to_one() {
        let (a, b) = (0.3, 1.7);
        assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        assert_eq!(power_heuristic(f32::INFINITY, 1.0), 1.0);
    }

    #[test]
    fn quarter_sin_cos_matches_the_library() {
        let q = std::f64::consts::FRAC_PI_4;
        for i in 0..=10_000 {
            let phi = (-q + 2.0 * q * i as f64 / 10_000.0) as f32;
            let (s, c) = sin_cos_quarter(phi);
            let (s64, c64) = (phi as f64).sin_cos();
            assert!((s as f64 - s64).abs() < 4e-7, "sin {phi}: {s} vs {s64}");
            assert!((c as f64 - c64).abs() < 4e-7, "cos {phi}: {c} vs {c64}");
        }
    }

    #[test]
    fn concentric_map_is_continuous_and_onto_the_disk() {
        // Points on the square's diagonals and edges land on the expected
        // radii and angles; every image lies in the unit disk.
        let d = square_to_disk_concentric(Vec2::new(1.0, 0.5));
        assert!((d - Vec2::X).length() < 1e-6, "{d}");
        let d = square_to_disk_concentric(Vec2::new(0.5, 1.0));
        assert!((d - Vec2::Y).length() < 1e-6, "{d}");
        let d = square_to_disk_concentric(Vec2::new(1.0, 1.0));
        let want = Vec2::splat(std::f32::consts::FRAC_1_SQRT_2);
        assert!((d - want).length() < 1e-6, "{d}");
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new(i as f32 / 63.0, j as f32 / 63.0);
                let d = square_to_disk_concentric(u);
                assert!(d.length() <= 1.0 + 1e-6, "{u}: {d}");
                // Radius is the square's L∞ distance from the centre.
                let r = (2.0 * u - Vec2::ONE).abs().max_element();
                assert!((d.length() - r).abs() < 1e-5, "{u}: {d}");
            }
        }
    }
}
