//! Chi-square goodness-of-fit test for direction-sampling routines.
//!
//! Used by the test suite on every warp, light and BSDF: it checks that the
//! directions a routine draws are distributed as the pdf it reports. Follows
//! Mitsuba 3's `chi2.py`: the sphere is cut into `theta_bins × phi_bins` cells
//! of equal `cos θ` and `φ` extent (odd counts keep cell boundaries off
//! symmetric features), expected counts integrate the pdf over each cell
//! (a midpoint rule on a sub-grid), cells with small expectations are pooled,
//! and any sample drawn where the reported pdf is zero fails outright.

use glam::Vec3;
use std::f64::consts::PI;

/// Outcome of a chi-square test.
#[derive(Debug, Clone, PartialEq)]
pub struct Chi2Result {
    /// The statistic.
    pub chi2: f64,
    /// Degrees of freedom after pooling.
    pub dof: usize,
    /// Probability of a statistic at least this large if the pdf is right.
    pub p_value: f64,
    /// Samples drawn where the reported pdf is zero, or not unit vectors.
    pub stray_samples: usize,
    /// Whether the test passed at the given significance.
    pub passed: bool,
    /// Human-readable summary for assertion messages.
    pub summary: String,
}

/// The sphere of directions cut into `(cos θ, φ)` cells.
#[derive(Debug, Clone, Copy)]
pub struct SphereBinning {
    /// Cells along `cos θ ∈ [-1, 1]`.
    pub theta_bins: usize,
    /// Cells along `φ ∈ [0, 2π)`.
    pub phi_bins: usize,
    /// Sub-grid edge used to integrate the pdf in each cell.
    pub subdivisions: usize,
}

impl Default for SphereBinning {
    fn default() -> Self {
        SphereBinning {
            theta_bins: 21,
            phi_bins: 41,
            subdivisions: 8,
        }
    }
}

impl SphereBinning {
    fn cell(&self, w: Vec3) -> usize {
        let z = (w.z as f64).clamp(-1.0, 1.0);
        let t = (((z + 1.0) * 0.5) * self.theta_bins as f64) as usize;
        let mut phi = (w.y as f64).atan2(w.x as f64);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let p = (phi / (2.0 * PI) * self.phi_bins as f64) as usize;
        t.min(self.theta_bins - 1) * self.phi_bins + p.min(self.phi_bins - 1)
    }

    /// Expected probability of every cell: the pdf (solid angle) integrated
    /// over it, by the midpoint rule on a `subdivisions`² sub-grid that is
    /// uniform in `θ` (not in `cos θ`) within each cell, so that lobes
    /// sharply peaked at the poles, where `cos θ` changes slowest, are
    /// resolved as finely as anywhere else.
    pub fn integrate(&self, pdf: &dyn Fn(Vec3) -> f64) -> Vec<f64> {
        let (nt, np, k) = (self.theta_bins, self.phi_bins, self.subdivisions);
        let dphi = 2.0 * PI / (np * k) as f64;
        let mut out = vec![0.0; nt * np];
        for t in 0..nt {
            // The cell's z range, and the θ range it spans.
            let z_lo = -1.0 + 2.0 * t as f64 / nt as f64;
            let z_hi = -1.0 + 2.0 * (t + 1) as f64 / nt as f64;
            let (theta_lo, theta_hi) = (z_hi.clamp(-1.0, 1.0).acos(), z_lo.clamp(-1.0, 1.0).acos());
            let dtheta = (theta_hi - theta_lo) / k as f64;
            for si in 0..k {
                let theta = theta_lo + (si as f64 + 0.5) * dtheta;
                let (r, z) = theta.sin_cos();
                for pi in 0..np * k {
                    let phi = (pi as f64 + 0.5) * dphi;
                    let w = Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32);
                    out[t * np + pi / k] += pdf(w) * r * dtheta * dphi;
                }
            }
        }
        out
    }
}

/// Runs the test: `sample(i)` draws the i-th direction (or `None` for a failed
/// sample, which is allowed: the pdf then integrates to less than one),
/// `pdf(w)` is the routine's solid-angle density, `n` the number of draws and
/// `significance` the level (e.g. 0.01, divided by the number of tests run).
pub fn chi2_test(
    binning: SphereBinning,
    n: usize,
    mut sample: impl FnMut(usize) -> Option<Vec3>,
    pdf: &dyn Fn(Vec3) -> f64,
    significance: f64,
) -> Chi2Result {
    let cells = binning.theta_bins * binning.phi_bins;
    let mut observed = vec![0.0f64; cells];
    let mut stray = 0usize;
    for i in 0..n {
        if let Some(w) = sample(i) {
            let density = pdf(w);
            let zero_pdf = density.is_nan() || density <= 0.0;
            if !w.is_finite() || (w.length() - 1.0).abs() > 1e-3 || zero_pdf {
                stray += 1;
                continue;
            }
            observed[binning.cell(w)] += 1.0;
        }
    }
    let expected: Vec<f64> = binning
        .integrate(pdf)
        .into_iter()
        .map(|p| p * n as f64)
        .collect();
    // Cells whose integrated pdf is zero but which hold samples (a sliver of
    // the support the sub-grid missed) are left out of the statistic; the
    // samples themselves were checked against the pdf above.
    let result = chi2_from_counts(&observed, &expected, 5.0);
    let (chi2, dof) = result;
    let p_value = if dof == 0 {
        1.0
    } else {
        1.0 - regularized_gamma_p(dof as f64 / 2.0, chi2 / 2.0)
    };
    let passed = stray == 0 && p_value >= significance;
    let summary = format!(
        "chi2 = {chi2:.2}, dof = {dof}, p = {p_value:.4} (needs ≥ {significance:.2e}), stray samples = {stray}, draws = {n}, expected total = {:.1}, observed total = {}",
        expected.iter().sum::<f64>(),
        observed.iter().sum::<f64>()
    );
    Chi2Result {
        chi2,
        dof,
        p_value,
        stray_samples: stray,
        passed,
        summary,
    }
}

/// Pearson's statistic after pooling cells whose expectation is below
/// `min_expected` (sorted by expectation, pooled until the pool reaches it).
/// Returns `(chi2, degrees of freedom)`.
pub fn chi2_from_counts(observed: &[f64], expected: &[f64], min_expected: f64) -> (f64, usize) {
    let mut order: Vec<usize> = (0..expected.len()).filter(|&i| expected[i] > 0.0).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let mut chi2 = 0.0;
    let mut cells = 0usize;
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for i in order {
        if expected[i] < min_expected {
            pool_o += observed[i];
            pool_e += expected[i];
            if pool_e >= min_expected {
                chi2 += (pool_o - pool_e).powi(2) / pool_e;
                cells += 1;
                pool_o = 0.0;
                pool_e = 0.0;
            }
        } else {
            chi2 += (observed[i] - expected[i]).powi(2) / expected[i];
            cells += 1;
        }
    }
    if pool_e > 0.0 {
        chi2 += (pool_o - pool_e).powi(2) / pool_e;
        cells += 1;
    }
    (chi2, cells.saturating_sub(1))
}

/// `ln Γ(x)` for `x > 0` (Lanczos approximation, g = 7, n = 9).
pub fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection formula.
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + G + 0.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised lower incomplete gamma function `P(a, x)`: the chi-square CDF
/// with `2a` degrees of freedom at `2x`.
pub fn regularized_gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x < a + 1.0 {
        // Series expansion.
        let mut sum = 1.0 / a;
        let mut term = sum;
        let mut n = a;
        for _ in 0..10_000 {
            n += 1.0;
            term *= x / n;
            sum += term;
            if term.abs() < sum.abs() * 1e-15 {
                break;
            }
        }
        (sum.ln() - x + a * x.ln() - ln_gamma(a)).exp()
    } else {
        // Continued fraction for Q(a, x) (modified Lentz).
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let delta = d * c;
            h *= delta;
            if (delta - 1.0).abs() < 1e-15 {
                break;
            }
        }
        1.0 - (-x + a * x.ln() - ln_gamma(a)).exp() * h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gamma_function_matches_known_values() {
        assert!((ln_gamma(5.0) - 24f64.ln()).abs() < 1e-12);
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-12);
        // Chi-square with 2 dof: CDF(x) = 1 − exp(−x/2).
        for x in [0.1, 1.0, 3.0, 10.0] {
            let p = regularized_gamma_p(1.0, x / 2.0);
            assert!((p - (1.0 - (-x / 2.0f64).exp())).abs() < 1e-10);
        }
        // Chi-square with 10 dof: median ≈ 9.341818.
        assert!((regularized_gamma_p(5.0, 9.341818 / 2.0) - 0.5).abs() < 1e-6);
    }

    #[test]
    fn detects_a_wrong_pdf() {
        // Uniform sphere sampling tested against the cosine pdf must fail.
        let mut rng = plsr::rng::Rng::new(1, 2);
        let r = chi2_test(
            SphereBinning::default(),
            200_000,
            |_| Some(plsr::warp::square_to_uniform_sphere(rng.next_2d())),
            &|w| (w.z.max(0.0) as f64) / PI,
            0.01,
        );
        assert!(!r.passed, "{}", r.summary);
    }
}
