//! Pixel reconstruction filters, applied by filter importance sampling.
//!
//! A pixel's value is the filter-weighted average of the radiance around its
//! centre. Instead of splatting each sample into several pixels with weights
//! (which couples neighbouring pixels and breaks per-pixel sample
//! statistics), every camera sample of pixel `(x, y)` is *placed* with the
//! filter's density around the pixel centre and keeps weight 1 (Ernst et al.
//! 2006, "Filter importance sampling"; pbrt-v4 does the same). So each pixel
//! still averages independent samples: images are the same for any thread
//! count, and the variance layer remains the variance of the mean.
//!
//! - [`PixelFilter::Box`]: uniform over the pixel's own square
//!   `[x, x+1) × [y, y+1)` (radius ½ pixel): plain supersampling.
//! - [`PixelFilter::Gaussian`]: `exp(−r²/(2σ²))`, separable, truncated to
//!   `[−radius, radius]²` around the pixel centre (σ and radius in pixels;
//!   pbrt's defaults σ = 0.5, radius = 1.5). Each axis is drawn by inverting
//!   the truncated normal's distribution function. With
//!   `filter_border = "clip"` (Mitsuba's films: samples are only taken
//!   on the film), a pixel near the edge draws its offsets from the
//!   Gaussian restricted to the film, `[−x − ½, width − x − ½]` across.
//! - [`PixelFilter::Tent`]: `max(0, 1 − |t|/radius)` per axis, separable
//!   (Mitsuba's `tent`, radius 1 pixel by default), drawn by inverting its
//!   piecewise-quadratic distribution function exactly; clipped at the
//!   border like the Gaussian.
//!
//! ```toml
//! [film]
//! filter = "gaussian"   # or "box" (the default), or "tent"
//! filter_sigma = 0.5    # pixels (Gaussian only)
//! filter_radius = 1.5   # pixels (Gaussian: 1.5, tent: 1)
//! filter_border = "extend"  # or "clip": keep samples on the film
//! ```

use crate::elementary::erfinv;
use glam::Vec2;

/// Default standard deviation of the Gaussian filter, pixels.
pub const DEFAULT_GAUSSIAN_SIGMA: f32 = 0.5;
/// Default radius of the Gaussian filter, pixels.
pub const DEFAULT_GAUSSIAN_RADIUS: f32 = 1.5;

/// Default radius of the tent filter, pixels (Mitsuba's).
pub const DEFAULT_TENT_RADIUS: f32 = 1.0;

/// A pixel reconstruction filter.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum PixelFilter {
    /// Uniform over the pixel (radius ½ pixel).
    #[default]
    Box,
    /// Truncated Gaussian around the pixel centre.
    Gaussian(GaussianFilter),
    /// Separable tent (triangle) around the pixel centre.
    Tent(TentFilter),
}

/// A separable tent filter, `max(0, 1 − |t|/radius)` on each axis; build it
/// with [`TentFilter::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TentFilter {
    /// Where the tent reaches 0, pixels from the centre.
    pub radius: f32,
    /// Whether a pixel's samples stay on the film (`filter_border = "clip"`).
    pub clip_at_border: bool,
}

/// A tent radius outside (0, 64] pixels.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("radius must be in (0, 64] pixels, got {0}")]
pub struct BadTent(pub f32);

impl TentFilter {
    /// A tent reaching 0 at `radius` pixels (in `(0, 64]`).
    pub fn new(radius: f32) -> Result<TentFilter, BadTent> {
        if !(radius > 0.0 && radius <= 64.0) {
            return Err(BadTent(radius));
        }
        Ok(TentFilter {
            radius,
            clip_at_border: false,
        })
    }

    /// The same filter keeping every pixel's samples on the film (`true`)
    /// or letting them fall beyond its edges.
    pub fn clipped_at_border(self, clip: bool) -> TentFilter {
        TentFilter {
            clip_at_border: clip,
            ..self
        }
    }

    /// The tent's distribution function at `t` (pixels from the centre).
    #[inline]
    fn cdf(&self, t: f32) -> f32 {
        let s = (t / self.radius).clamp(-1.0, 1.0);
        if s < 0.0 {
            0.5 * (1.0 + s) * (1.0 + s)
        } else {
            1.0 - 0.5 * (1.0 - s) * (1.0 - s)
        }
    }

    /// The inverse of [`TentFilter::cdf`] at `c ∈ [0, 1]`.
    #[inline]
    fn inverse_cdf(&self, c: f32) -> f32 {
        let s = if c < 0.5 {
            (2.0 * c).sqrt() - 1.0
        } else {
            1.0 - (2.0 * (1.0 - c)).max(0.0).sqrt()
        };
        s * self.radius
    }

    /// One axis of pixel `x` of a film spanning `[start, end)`: the tent,
    /// or near an edge of a clipped filter the tent restricted to the film.
    #[inline]
    fn sample_axis(&self, u: f32, x: u32, [start, end]: [u32; 2]) -> f32 {
        let centre = x as f32 + 0.5;
        let (lo, hi) = (start as f32 - centre, end as f32 - centre);
        if !self.clip_at_border || (lo <= -self.radius && hi >= self.radius) {
            return self.inverse_cdf(u).clamp(-self.radius, self.radius);
        }
        let (lo, hi) = (lo.max(-self.radius), hi.min(self.radius));
        let (c_lo, c_hi) = (self.cdf(lo), self.cdf(hi));
        self.inverse_cdf(c_lo + u * (c_hi - c_lo)).clamp(lo, hi)
    }

    /// Normalised 1D density at offset `t` from the pixel centre (pixels).
    pub fn pdf_1d(&self, t: f32) -> f32 {
        (1.0 - t.abs() / self.radius).max(0.0) / self.radius
    }
}

/// A truncated Gaussian filter; build it with [`GaussianFilter::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GaussianFilter {
    /// Standard deviation, pixels.
    pub sigma: f32,
    /// Truncation radius, pixels (per axis).
    pub radius: f32,
    /// `erf(radius / (σ√2))`: the mass of `[−radius, radius]`.
    erf_radius: f32,
    /// Whether a pixel's samples stay on the film (`filter_border =
    /// "clip"`): near an edge the Gaussian is restricted to the film.
    pub clip_at_border: bool,
}

/// Parameters no Gaussian filter can have.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum BadGaussian {
    /// σ is not a positive number (pixels).
    #[error("sigma must be a positive number, got {0}")]
    Sigma(f32),
    /// The radius is outside (0, 64] pixels.
    #[error("radius must be in (0, 64] pixels, got {0}")]
    Radius(f32),
}

impl GaussianFilter {
    /// A Gaussian of standard deviation `sigma` truncated at `radius` (both
    /// pixels, positive and finite; `radius ≤ 64`). Errors name the parameter.
    pub fn new(sigma: f32, radius: f32) -> Result<GaussianFilter, BadGaussian> {
        if !(sigma > 0.0 && sigma.is_finite()) {
            return Err(BadGaussian::Sigma(sigma));
        }
        if !(radius > 0.0 && radius <= 64.0) {
            return Err(BadGaussian::Radius(radius));
        }
        let erf_radius = erf(radius as f64 / (sigma as f64 * std::f64::consts::SQRT_2)) as f32;
        // Beyond ~5.5σ the float mass rounds to 1 and erfinv(±1) is infinite.
        let erf_radius = erf_radius.min(1.0 - 1e-7);
        Ok(GaussianFilter {
            sigma,
            radius,
            erf_radius,
            clip_at_border: false,
        })
    }

    /// The same filter keeping every pixel's samples on the film (`true`,
    /// as Mitsuba's films do) or letting them fall beyond its edges.
    pub fn clipped_at_border(self, clip: bool) -> GaussianFilter {
        GaussianFilter {
            clip_at_border: clip,
            ..self
        }
    }

    /// One axis of pixel `x` of a film spanning `[start, end)`: the full
    /// truncated normal, or near an edge of a clipped filter the normal
    /// restricted to `[max(−radius, start − x − ½), min(radius, end − x − ½)]`
    /// (inverting its distribution function: `erf` in double precision).
    #[inline]
    fn sample_axis(&self, u: f32, x: u32, [start, end]: [u32; 2]) -> f32 {
        let centre = x as f32 + 0.5;
        let (lo, hi) = (start as f32 - centre, end as f32 - centre);
        if !self.clip_at_border || (lo <= -self.radius && hi >= self.radius) {
            return self.sample_1d(u);
        }
        let (lo, hi) = (lo.max(-self.radius), hi.min(self.radius));
        let k = 1.0 / (self.sigma as f64 * std::f64::consts::SQRT_2);
        let (e_lo, e_hi) = (erf(lo as f64 * k), erf(hi as f64 * k));
        let e = (e_lo + u as f64 * (e_hi - e_lo)).clamp(-1.0 + 1e-7, 1.0 - 1e-7);
        let t = self.sigma * std::f32::consts::SQRT_2 * erfinv(e as f32);
        t.clamp(lo, hi)
    }

    /// One axis: the inverse distribution function of the truncated normal at `u ∈ [0, 1)`.
    #[inline]
    fn sample_1d(&self, u: f32) -> f32 {
        let x = self.sigma * std::f32::consts::SQRT_2 * erfinv((2.0 * u - 1.0) * self.erf_radius);
        x.clamp(-self.radius, self.radius)
    }

    /// Normalised 1D density at offset `x` from the pixel centre (pixels).
    pub fn pdf_1d(&self, x: f32) -> f32 {
        if x.abs() > self.radius {
            return 0.0;
        }
        let s = self.sigma as f64;
        let norm = s * (2.0 * std::f64::consts::PI).sqrt() * self.erf_radius as f64;
        ((-(x as f64).powi(2) / (2.0 * s * s)).exp() / norm) as f32
    }
}

impl PixelFilter {
    /// Film offset from the top-left corner of pixel `pixel` for a sample
    /// drawn with `u ∈ [0, 1)²`: `u` itself for the box filter, `(½, ½)`
    /// plus the filter's offset for the others (kept on the film, the
    /// pixels `[x0, x1) × [y0, y1)` of `film = [x0, y0, x1, y1]`, if the
    /// filter is clipped at the border).
    #[inline]
    pub fn sample(&self, u: Vec2, pixel: [u32; 2], film: [u32; 4]) -> Vec2 {
        let (xs, ys) = ([film[0], film[2]], [film[1], film[3]]);
        match self {
            PixelFilter::Box => u,
            PixelFilter::Gaussian(g) => Vec2::new(
                0.5 + g.sample_axis(u.x, pixel[0], xs),
                0.5 + g.sample_axis(u.y, pixel[1], ys),
            ),
            PixelFilter::Tent(t) => Vec2::new(
                0.5 + t.sample_axis(u.x, pixel[0], xs),
                0.5 + t.sample_axis(u.y, pixel[1], ys),
            ),
        }
    }

    /// Whether edge pixels keep their samples on the film.
    pub fn clips_at_border(&self) -> bool {
        match self {
            PixelFilter::Box => true,
            PixelFilter::Gaussian(g) => g.clip_at_border,
            PixelFilter::Tent(t) => t.clip_at_border,
        }
    }

    /// Radius of the filter's support around the pixel centre, pixels.
    pub fn radius(&self) -> f32 {
        match self {
            PixelFilter::Box => 0.5,
            PixelFilter::Gaussian(g) => g.radius,
            PixelFilter::Tent(t) => t.radius,
        }
    }

    /// The filter's name in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            PixelFilter::Box => "box",
            PixelFilter::Gaussian(_) => "gaussian",
            PixelFilter::Tent(_) => "tent",
        }
    }
}

/// The error function, to about 1e-15 relative: the series
/// `erf(x) = 2/√π · e^(−x²) · Σ 2ⁿ x^(2n+1) / (1·3·…·(2n+1))`, whose terms
/// are all positive (no cancellation).
pub fn erf(x: f64) -> f64 {
    let a = x.abs();
    if a > 6.0 {
        return x.signum();
    }
    let mut term = a;
    let mut sum = a;
    let mut n = 0.0;
    while term > sum * 1e-17 {
        n += 1.0;
        term *= 2.0 * a * a / (2.0 * n + 1.0);
        sum += term;
    }
    let r = 2.0 / std::f64::consts::PI.sqrt() * (-a * a).exp() * sum;
    r.min(1.0).copysign(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erf_matches_known_values() {
        for (x, want) in [
            (0.0, 0.0),
            (0.5, 0.520_499_877_813_046_5),
            (1.0, 0.842_700_792_949_714_9),
            (2.0, 0.995_322_265_018_952_7),
            (-1.5, -0.966_105_146_475_310_7),
        ] {
            assert!((erf(x) - want).abs() < 1e-14, "erf({x}) = {}", erf(x));
        }
    }

    #[test]
    fn tent_inverse_cdf_inverts_cdf_and_clips() {
        let t = TentFilter::new(1.5).unwrap();
        for i in 0..=1000 {
            let c = i as f32 / 1000.0;
            let x = t.inverse_cdf(c);
            assert!((t.cdf(x) - c).abs() < 2e-6, "{c}: {x}");
            assert!(x.abs() <= 1.5);
        }
        assert_eq!(t.inverse_cdf(0.5), 0.0);
        assert!(TentFilter::new(0.0).is_err() && TentFilter::new(65.0).is_err());
        let c = PixelFilter::Tent(t.clipped_at_border(true));
        for u in [0.0, 1e-7, 0.5, 0.999_999_94] {
            let s = c.sample(Vec2::splat(u), [0, 0], [0, 0, 10, 10]);
            assert!(s.min_element() >= 0.0 && s.max_element() <= 2.0, "{s}");
        }
    }

    #[test]
    fn gaussian_samples_stay_in_the_support_and_are_centred() {
        let g = GaussianFilter::new(0.5, 1.5).unwrap();
        let f = PixelFilter::Gaussian(g);
        for u in [0.0, 1e-7, 0.25, 0.5, 0.75, 0.999_999_94] {
            let s = f.sample(Vec2::splat(u), [5, 5], [0, 0, 10, 10]);
            assert!((s.x - 0.5).abs() <= 1.5, "{s}");
        }
        assert!(
            (f.sample(Vec2::splat(0.5), [5, 5], [0, 0, 10, 10]) - Vec2::splat(0.5)).length() < 1e-6
        );
        // The median of each axis sits at the centre, the quartiles at ±0.6745σ
        // (essentially unaffected by the truncation at 3σ).
        let q = f.sample(Vec2::splat(0.75), [5, 5], [0, 0, 10, 10]).x - 0.5;
        assert!((q - 0.6745 * 0.5).abs() < 2e-3, "{q}");
        assert!(GaussianFilter::new(0.0, 1.0).is_err());
        assert!(GaussianFilter::new(0.5, -1.0).is_err());
        // Clipped, the corner pixel's samples stay on the film, even at the
        // extremes of u.
        let c = PixelFilter::Gaussian(g.clipped_at_border(true));
        for u in [0.0, 1e-7, 0.5, 0.999_999_94] {
            let s = c.sample(Vec2::splat(u), [0, 0], [0, 0, 10, 10]);
            assert!(s.min_element() >= 0.0 && s.max_element() <= 2.0, "{s}");
        }
    }
}
