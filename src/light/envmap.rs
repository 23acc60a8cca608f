//! An infinitely distant environment emitter: an equirectangular HDR image
//! (a panorama merged from bracketed photos, the paper's baseline lighting)
//! or a constant radiance, seen in every direction from every point.
//!
//! The image is mapped to directions by the one equirectangular convention of
//! [`crate::equirect`], oriented by a [`SphereFrame`]: `up` is the image's top
//! row, `forward` its centre column. A panorama taken by the 360° camera
//! (`type = "equirectangular"`) at a pose lights the scene lined up when the
//! environment is given the camera's `up` and `forward`.
//!
//! Radiance is piecewise constant over texels (no filtering), times `scale`,
//! or with `filter = "bilinear"` interpolated between the four nearest texel
//! centres (wrapping round in azimuth, clamped at the poles). Rows cover
//! `1/height` of the image each, or with `rows = "poles"` (Mitsuba's
//! `envmap`) the first and last rows' centres sit on the zenith and nadir,
//! row `y` at `v = y/(height − 1)`. Sampling stays by texel either way. Directions are
//! importance-sampled in proportion to a texel weight × solid angle of the
//! texel (∝ sin θ), uniformly in `(u, v)` within a texel. The weight is the
//! texel's luminance, looked up by nearest texel; looked up bilinearly, it
//! is the largest luminance of the 3 × 3 texels whose values the texel's
//! lookups blend, so that the density covers the radiance interpolation
//! spreads around a bright texel (a sun's rim would otherwise be found by
//! BSDF sampling alone, as fireflies). The solid-angle density is
//! `p(ω) = p(u, v) / (2π² sin θ)`, with `θ = π v` the polar angle from `up`.
//!
//! ```toml
//! [environment]
//! file = "panorama.exr"   # OpenEXR or Radiance .hdr, linear RGB
//! up = [0, 0, 1]          # world direction of the image's top row
//! forward = [0, 1, 0]     # world direction of the image's centre column
//! scale = 1.0             # radiance multiplier
//! ```

use super::{luminance, LightSample};
use crate::elementary;
use crate::equirect::{equirect_direction, equirect_uv, SphereFrame};
use crate::prefetch::prefetch;
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// How many samples or lookups the batched functions
/// ([`EnvironmentLight::sample_li_many`],
/// [`EnvironmentLight::radiance_pdf_many`]) take through their stages at
/// once: enough cache misses in flight to overlap, few enough that a
/// chunk's arrays stay in the first-level cache.
const CHUNK: usize = 64;

/// An environment emitter at infinity.
#[derive(Debug, Clone, PartialEq)]
pub struct EnvironmentLight {
    /// Image width in texels (2π of azimuth).
    pub width: u32,
    /// Image height in texels (π of elevation).
    pub height: u32,
    /// Each texel's radiance and sampling density, row-major from the top
    /// row.
    texels: Vec<Texel>,
    /// How the image is oriented in the world.
    pub frame: SphereFrame,
    /// Marginal CDF over rows (`height + 1` entries from 0 to 1).
    row_cdf: Vec<f32>,
    /// Conditional CDFs over columns, `height × (width + 1)` entries.
    column_cdf: Vec<f32>,
    /// The guide table of `row_cdf` ([`guide`]).
    row_guide: Vec<u32>,
    /// The guide tables of the column CDFs, `height × guide_slots(width)`.
    column_guide: Vec<u32>,
    /// `∫ luminance(L) dω` (W/m² per unit projected area, luminance).
    integral: f32,
    /// Bilinear interpolation between texel centres instead of nearest.
    bilinear: bool,
    /// Rows laid out pole to pole (Mitsuba's `envmap`): the first row's
    /// centre is the zenith and the last row's the nadir, row `y` at
    /// `v = y / (height − 1)`. Otherwise (the default) row `y` covers
    /// `[y, y + 1) / height`. Only with `bilinear`.
    rows_at_poles: bool,
}

/// One texel of the map, with what a lookup needs of it in one 16-byte
/// record: a direction's radiance and density ([`EnvironmentLight::pdf`])
/// then cost one cache miss, not one for the radiance and one for the
/// column's CDF.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(16))]
struct Texel {
    /// Linear RGB radiance (already scaled).
    radiance: Vec3,
    /// The density of the samples in this texel per unit area of the image
    /// (`uv ∈ [0, 1]²`): `p_row · p_col · width · height`, the probabilities
    /// of its row and of its column in the row. Sampling and lookups both
    /// read it, so MIS weighs a direction the same whichever found it.
    pdf_uv: f32,
}

/// The sampling weights of a `w × h` map looked up bilinearly, from its
/// texels' luminance: each texel's is the largest luminance of the 3 × 3
/// texels around it (wrapping round in azimuth, clamped at the poles).
/// Every lookup in a texel blends texels of that neighbourhood with convex
/// weights, so its luminance is at most the texel's weight: light samples
/// cover the radiance bilinear lookup spreads beyond a bright texel (a sun's
/// rim), and the ratio of radiance to density stays bounded there. Weighing
/// texels by their own luminance instead leaves that rim to BSDF sampling
/// alone, and a small bright source then makes fireflies.
fn bilinear_weights(luminance: &[f32], w: usize, h: usize) -> Vec<f32> {
    let mut across = vec![0.0f32; w * h];
    for y in 0..h {
        let row = &luminance[y * w..(y + 1) * w];
        for x in 0..w {
            let (left, right) = ((x + w - 1) % w, (x + 1) % w);
            across[y * w + x] = row[left].max(row[x]).max(row[right]);
        }
    }
    (0..w * h)
        .map(|i| {
            let (y, x) = (i / w, i % w);
            let (up, down) = (y.saturating_sub(1), (y + 1).min(h - 1));
            across[up * w + x].max(across[i]).max(across[down * w + x])
        })
        .collect()
}

/// Builds a CDF (with a leading 0) from non-negative weights and returns it
/// with their sum; all-zero weights give a uniform CDF and a zero sum.
fn cdf(weights: impl Iterator<Item = f64>) -> (Vec<f32>, f64) {
    let mut out = vec![0.0f32];
    let mut acc = 0.0f64;
    let mut sums = vec![0.0f64];
    for w in weights {
        acc += w.max(0.0);
        sums.push(acc);
    }
    if acc > 0.0 {
        out.extend(sums[1..].iter().map(|s| (s / acc) as f32));
        *out.last_mut().expect("non-empty") = 1.0;
    } else {
        // Uniform fallback: never used for sampling (zero weight), but
        // keeps lookups well defined.
        let n = sums.len() - 1;
        out.extend((1..=n).map(|i| i as f32 / n as f32));
    }
    (out, acc)
}

/// Slots of the guide table of a CDF of `n` cells: the power of two at or
/// above `n`, so that `u · slots` and `j / slots` are exact in `f32`.
fn guide_slots(n: usize) -> usize {
    n.next_power_of_two()
}

/// The guide table of `cdf` (n + 1 entries; the cutpoint method of Chen and
/// Asau 1974): for each slot `j` of [`guide_slots`], the last cell `i < n`
/// whose start `cdf[i]` is ≤ `j / slots`. A number `u` in slot `j` then
/// lies in a cell between `guide[j]` and `guide[j + 1]`, found by a short
/// search instead of one over the whole CDF.
fn guide(cdf: &[f32]) -> Vec<u32> {
    let n = cdf.len() - 1;
    let m = guide_slots(n);
    let mut out = Vec::with_capacity(m);
    let mut i = 0usize;
    for j in 0..m {
        let t = j as f32 / m as f32;
        while i + 1 < n && cdf[i + 1] <= t {
            i += 1;
        }
        out.push(i as u32);
    }
    out
}

/// Samples a piecewise-constant 1D distribution given by `cdf` (n + 1
/// entries) and its [`guide`] table: returns the cell, the continuous
/// position in `[0, 1)` and the cell's probability.
#[inline]
fn sample_cdf(cdf: &[f32], guide: &[u32], u: f32) -> (usize, f32, f32) {
    let n = cdf.len() - 1;
    // The last cell whose start is ≤ u (the same cell a binary search over
    // the whole CDF finds), then skipping empty cells. `u · m` is exact
    // (m a power of two), so slot j's start j/m is ≤ u.
    let m = guide.len();
    let j = ((u * m as f32) as usize).min(m - 1);
    let lo = guide[j] as usize;
    let hi = if j + 1 < m {
        guide[j + 1] as usize
    } else {
        n - 1
    };
    sample_cell(cdf, lo + cdf[lo + 1..=hi].partition_point(|&c| c <= u), u)
}

/// The rest of [`sample_cdf`] once the last cell `i` whose start is ≤ `u`
/// is found: skips empty cells, and returns the cell, the continuous
/// position in `[0, 1)` and the cell's probability.
#[inline]
fn sample_cell(cdf: &[f32], mut i: usize, u: f32) -> (usize, f32, f32) {
    let n = cdf.len() - 1;
    while cdf[i + 1] - cdf[i] <= 0.0 && i + 1 < n {
        i += 1;
    }
    let p = cdf[i + 1] - cdf[i];
    let offset = if p > 0.0 {
        ((u - cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON)
    } else {
        0.5
    };
    (i, (i as f32 + offset) / n as f32, p)
}

impl EnvironmentLight {
    /// An environment from a `width × height` equirectangular image of
    /// linear RGB radiance (row-major from the top row), multiplied by
    /// `scale`, oriented by `frame`. Negative or non-finite texels are
    /// rejected by the caller; here they count as black.
    pub fn from_image(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        scale: f32,
        frame: SphereFrame,
    ) -> EnvironmentLight {
        assert!(width > 0 && height > 0 && texels.len() == (width * height) as usize);
        let texels: Vec<Vec3> = texels
            .into_iter()
            .map(|t| {
                if t.is_finite() {
                    t.max(Vec3::ZERO) * scale
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        EnvironmentLight::build(width, height, texels, frame, false)
    }

    /// The environment of `texels` (already scaled and clean), sampled in
    /// proportion to the radiance its lookups (`bilinear` or nearest)
    /// return, or a bound of it.
    fn build(
        width: u32,
        height: u32,
        texels: Vec<Vec3>,
        frame: SphereFrame,
        bilinear: bool,
    ) -> EnvironmentLight {
        let (w, h) = (width as usize, height as usize);
        // A row's solid angle per unit of v, exactly: (cos θ0 − cos θ1)·h/π
        // (the midpoint sin θ is 2.6 % off for rows 45° tall).
        let sin_row = |y: usize| {
            let (t0, t1) = (
                std::f64::consts::PI * y as f64 / h as f64,
                std::f64::consts::PI * (y + 1) as f64 / h as f64,
            );
            (t0.cos() - t1.cos()) * h as f64 / std::f64::consts::PI
        };
        let texel_luminance: Vec<f32> = texels.iter().map(|&t| luminance(t)).collect();
        // Σ L sin θ · (2π/w)(π/h): the integral of luminance over the sphere.
        let total: f64 = (0..h)
            .map(|y| {
                let row = &texel_luminance[y * w..(y + 1) * w];
                row.iter().map(|&l| l as f64 * sin_row(y)).sum::<f64>()
            })
            .sum();
        let integral =
            (total * 2.0 * std::f64::consts::PI * std::f64::consts::PI / (w * h) as f64) as f32;
        // What each texel is sampled in proportion to: its luminance or,
        // looked up bilinearly, the largest luminance of the texels its
        // lookups blend (see `bilinear_weights`).
        let weights = if bilinear {
            bilinear_weights(&texel_luminance, w, h)
        } else {
            texel_luminance
        };
        let mut column_cdf = Vec::with_capacity(h * (w + 1));
        let mut row_weights = Vec::with_capacity(h);
        for y in 0..h {
            let (c, total) = cdf((0..w).map(|x| weights[y * w + x] as f64 * sin_row(y)));
            column_cdf.extend(c);
            row_weights.push(total);
        }
        let (row_cdf, _) = cdf(row_weights.into_iter());
        let row_guide = guide(&row_cdf);
        let wh = (width * height) as f32;
        let texels = texels
            .into_iter()
            .enumerate()
            .map(|(i, radiance)| {
                let (y, x) = (i / w, i % w);
                let p_row = row_cdf[y + 1] - row_cdf[y];
                let p_col = column_cdf[y * (w + 1) + x + 1] - column_cdf[y * (w + 1) + x];
                Texel {
                    radiance,
                    pdf_uv: p_row * p_col * wh,
                }
            })
            .collect();
        let column_guide = column_cdf.chunks_exact(w + 1).flat_map(guide).collect();
        EnvironmentLight {
            width,
            height,
            texels,
            frame,
            row_cdf,
            column_cdf,
            row_guide,
            column_guide,
            integral,
            bilinear,
            rows_at_poles: false,
        }
    }

    /// The same environment looked up bilinearly (`true`) or by nearest
    /// texel (`false`, the default), and sampled to match.
    pub fn with_bilinear(self, bilinear: bool) -> EnvironmentLight {
        if bilinear == self.bilinear {
            return self;
        }
        assert!(!self.rows_at_poles, "set the lookup before the row layout");
        let texels = self.texels.iter().map(|t| t.radiance).collect();
        EnvironmentLight::build(self.width, self.height, texels, self.frame, bilinear)
    }

    /// The same environment with its rows laid out pole to pole (`true`, as
    /// Mitsuba's `envmap`: the first row's centre is the zenith, the last
    /// row's the nadir) or each row covering `1 / height` of the image
    /// (`false`, the default). Pole-to-pole rows need bilinear lookup
    /// ([`EnvironmentLight::with_bilinear`] first): its sampling weights
    /// (the largest of each texel's 3 × 3 neighbours) cover the rows a
    /// lookup blends in either layout, since `v·(h − 1)` lies within one
    /// row of `v·h − ½`.
    pub fn with_rows_at_poles(mut self, rows_at_poles: bool) -> EnvironmentLight {
        assert!(
            !rows_at_poles || self.bilinear,
            "pole-to-pole rows need bilinear lookup"
        );
        self.rows_at_poles = rows_at_poles;
        self
    }

    /// The radiance at image position `uv`, which lies in texel `(x, y)`:
    /// the texel's, or bilinear between the four nearest texel centres.
    #[inline]
    fn radiance_at(&self, uv: Vec2, x: usize, y: usize) -> Vec3 {
        let w = self.width as usize;
        if !self.bilinear {
            return self.texels[y * w + x].radiance;
        }
        let ([x0, x1, y0, y1], tx, ty) = self.bilinear_corners(uv);
        let t = |x: usize, y: usize| self.texels[y * w + x].radiance;
        let top = t(x0, y0) * (1.0 - tx) + t(x1, y0) * tx;
        let bottom = t(x0, y1) * (1.0 - tx) + t(x1, y1) * tx;
        top * (1.0 - ty) + bottom * ty
    }

    /// The texels that bilinear lookup at `uv` interpolates, `[x0, x1, y0,
    /// y1]`, and the weights `tx`, `ty` of `x1` and `y1`.
    #[inline]
    fn bilinear_corners(&self, uv: Vec2) -> ([usize; 4], f32, f32) {
        let (w, h) = (self.width as usize, self.height as usize);
        let fx = uv.x * w as f32 - 0.5;
        let fy = if self.rows_at_poles {
            (uv.y * (h - 1) as f32).clamp(0.0, (h - 1) as f32)
        } else {
            (uv.y * h as f32 - 0.5).clamp(0.0, (h - 1) as f32)
        };
        let (x0, y0) = (elementary::floor(fx), elementary::floor(fy));
        let (tx, ty) = (fx - x0, fy - y0);
        let x0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let x1 = (x0 + 1) % w;
        let y0 = y0 as usize;
        let y1 = (y0 + 1).min(h - 1);
        ([x0, x1, y0, y1], tx, ty)
    }

    /// Prefetches what a lookup at `uv`, in texel `(x, y)`, reads: the
    /// texel's record and, looked up bilinearly, its neighbours' (the row
    /// above or below, and across the seam).
    #[inline]
    fn prefetch_lookup(&self, uv: Vec2, x: usize, y: usize) {
        let w = self.width as usize;
        if self.bilinear {
            // The corners include the texel itself.
            let ([x0, x1, y0, y1], _, _) = self.bilinear_corners(uv);
            for (x, y) in [(x0, y0), (x1, y0), (x0, y1), (x1, y1)] {
                prefetch(&self.texels[y * w + x]);
            }
        } else {
            prefetch(&self.texels[y * w + x]);
        }
    }

    /// A constant environment of radiance `radiance` in every direction.
    pub fn constant(radiance: Vec3) -> EnvironmentLight {
        // One texel row per pole band keeps sin θ sampling accurate enough;
        // a constant map is sampled by sin θ, i.e. nearly uniformly.
        let (w, h) = (2u32, 64u32);
        EnvironmentLight::from_image(
            w,
            h,
            vec![radiance; (w * h) as usize],
            1.0,
            SphereFrame::Z_UP,
        )
    }

    fn texel_at(&self, uv: Vec2) -> (usize, usize) {
        let x = ((uv.x * self.width as f32) as usize).min(self.width as usize - 1);
        let y = ((uv.y * self.height as f32) as usize).min(self.height as usize - 1);
        (x, y)
    }

    /// Radiance arriving from direction `dir` (any length but zero).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let uv = equirect_uv(dir, &self.frame);
        let (x, y) = self.texel_at(uv);
        self.radiance_at(uv, x, y)
    }

    /// Samples a direction from `u`: radiance, unit direction and
    /// solid-angle density. `None` for a black environment.
    #[inline]
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        if self.integral <= 0.0 {
            return None;
        }
        let row = self.sample_row(u.y);
        let column = self.sample_column(row.0, u.x);
        self.finish_sample(row, column)
    }

    /// The first step of [`EnvironmentLight::sample`]: the row, `v` and the
    /// row's probability, from `u_y`.
    #[inline]
    fn sample_row(&self, u_y: f32) -> (usize, f32, f32) {
        sample_cdf(&self.row_cdf, &self.row_guide, u_y)
    }

    /// The second step: the column of row `y`, `u` and its conditional
    /// probability, from `u_x`.
    #[inline]
    fn sample_column(&self, y: usize, u_x: f32) -> (usize, f32, f32) {
        let w = self.width as usize;
        let row = &self.column_cdf[y * (w + 1)..(y + 1) * (w + 1)];
        let m = guide_slots(w);
        sample_cdf(row, &self.column_guide[y * m..(y + 1) * m], u_x)
    }

    /// The last step: the direction, its radiance and density.
    #[inline]
    fn finish_sample(
        &self,
        (y, v, p_row): (usize, f32, f32),
        (x, uu, p_col): (usize, f32, f32),
    ) -> Option<(Vec3, Vec3, f32)> {
        let (dir, sin_theta) = self.direction_at(uu, v);
        self.finish_at((y, v, p_row), (x, uu, p_col), dir, sin_theta)
    }

    /// The direction of image position `(uu, v)` and `sin θ` there (what
    /// [`EnvironmentLight::finish_at`] takes): arithmetic only, so that a
    /// loop over many positions vectorises.
    #[inline(always)]
    fn direction_at(&self, uu: f32, v: f32) -> (Vec3, f32) {
        // sin πv as a fraction of a turn (no C library call).
        let sin_theta = elementary::sin_cos_turns(0.5 * v).0;
        (equirect_direction(Vec2::new(uu, v), &self.frame), sin_theta)
    }

    /// [`EnvironmentLight::finish_sample`] given the direction and `sin θ`
    /// of the sampled position.
    #[inline(always)]
    fn finish_at(
        &self,
        (y, v, p_row): (usize, f32, f32),
        (x, uu, p_col): (usize, f32, f32),
        dir: Vec3,
        sin_theta: f32,
    ) -> Option<(Vec3, Vec3, f32)> {
        if sin_theta <= 0.0 || p_row <= 0.0 || p_col <= 0.0 {
            return None;
        }
        let pdf = self.density(x, y, sin_theta);
        Some((self.radiance_at(Vec2::new(uu, v), x, y), dir, pdf))
    }

    /// [`EnvironmentLight::sample_li`] for many numbers at once, the same
    /// results, into `out` (cleared first). The samples of a large map
    /// read memory far apart; taken one at a time each waits for its own
    /// cache misses, so this takes them [`CHUNK`] at a time in stages, each
    /// a loop over the chunk that prefetches what the next stage reads (the
    /// column's guide entry, then its CDF cells, then the texel), and the
    /// misses of many samples overlap. The directions are computed in a
    /// loop of their own, over arrays, which the compiler vectorises.
    pub fn sample_li_many(&self, us: &[Vec2], out: &mut Vec<Option<LightSample>>) {
        out.clear();
        if self.integral <= 0.0 {
            out.resize(us.len(), None);
            return;
        }
        out.reserve(us.len());
        for chunk in us.chunks(CHUNK) {
            self.sample_chunk(chunk, out);
        }
    }

    /// [`EnvironmentLight::sample_li_many`] for at most [`CHUNK`] numbers,
    /// appended to `out`.
    #[inline]
    fn sample_chunk(&self, us: &[Vec2], out: &mut Vec<Option<LightSample>>) {
        let n = us.len();
        debug_assert!(n <= CHUNK);
        let w = self.width as usize;
        let m = guide_slots(w);
        let mut rows = [(0usize, 0.0f32, 0.0f32); CHUNK];
        let mut slots = [0usize; CHUNK];
        for k in 0..n {
            rows[k] = self.sample_row(us[k].y);
            slots[k] = rows[k].0 * m + ((us[k].x * m as f32) as usize).min(m - 1);
            prefetch(&self.column_guide[slots[k]]);
        }
        for k in 0..n {
            let lo = self.column_guide[slots[k]] as usize;
            prefetch(&self.column_cdf[rows[k].0 * (w + 1) + lo + 1]);
        }
        let mut columns = [(0usize, 0.0f32, 0.0f32); CHUNK];
        let (mut uu, mut v) = ([0.0f32; CHUNK], [0.0f32; CHUNK]);
        for k in 0..n {
            columns[k] = self.sample_column(rows[k].0, us[k].x);
            (uu[k], v[k]) = (columns[k].1, rows[k].1);
            self.prefetch_lookup(Vec2::new(uu[k], v[k]), columns[k].0, rows[k].0);
        }
        let mut dir = [[0.0f32; CHUNK]; 3];
        let mut sin_theta = [0.0f32; CHUNK];
        // Over the whole chunk, a partial one's unused zeros included: a
        // fixed count the compiler vectorises without a remainder loop.
        for k in 0..CHUNK {
            let (d, s) = self.direction_at(uu[k], v[k]);
            (dir[0][k], dir[1][k], dir[2][k], sin_theta[k]) = (d.x, d.y, d.z, s);
        }
        out.extend((0..n).map(|k| {
            let d = Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            Self::light_sample(self.finish_at(rows[k], columns[k], d, sin_theta[k]))
        }));
    }

    /// Solid-angle density of [`EnvironmentLight::sample`] for `dir`.
    #[inline]
    pub fn pdf(&self, dir: Vec3) -> f32 {
        if self.integral <= 0.0 {
            return 0.0;
        }
        let uv = equirect_uv(dir, &self.frame);
        let (x, y) = self.texel_at(uv);
        self.pdf_at(uv, x, y)
    }

    /// [`EnvironmentLight::radiance`] and [`EnvironmentLight::pdf`] of many
    /// directions at once, the same values, into `out` (cleared first),
    /// [`CHUNK`] at a time: the image positions of a chunk in a loop over
    /// arrays (which vectorises), then the lookups in two stages, the first
    /// prefetching what the second reads, so that their cache misses on a
    /// large map overlap.
    pub fn radiance_pdf_many(&self, dirs: &[Vec3], out: &mut Vec<(Vec3, f32)>) {
        out.clear();
        out.reserve(dirs.len());
        for chunk in dirs.chunks(CHUNK) {
            self.radiance_pdf_chunk(chunk, out);
        }
    }

    /// [`EnvironmentLight::radiance_pdf_many`] for at most [`CHUNK`]
    /// directions, appended to `out`.
    #[inline]
    fn radiance_pdf_chunk(&self, dirs: &[Vec3], out: &mut Vec<(Vec3, f32)>) {
        let n = dirs.len();
        debug_assert!(n <= CHUNK);
        let mut d = [[0.0f32; CHUNK]; 3];
        for k in 0..n {
            (d[0][k], d[1][k], d[2][k]) = (dirs[k].x, dirs[k].y, dirs[k].z);
        }
        let (mut u, mut v, mut sin_theta) = ([0.0f32; CHUNK], [0.0f32; CHUNK], [0.0f32; CHUNK]);
        // The whole chunk, as in `sample_chunk`.
        for k in 0..CHUNK {
            let uv = equirect_uv(Vec3::new(d[0][k], d[1][k], d[2][k]), &self.frame);
            (u[k], v[k]) = (uv.x, uv.y);
            sin_theta[k] = elementary::sin_cos_turns(0.5 * uv.y).0;
        }
        let mut texel = [(0usize, 0usize); CHUNK];
        for k in 0..n {
            let uv = Vec2::new(u[k], v[k]);
            texel[k] = self.texel_at(uv);
            self.prefetch_lookup(uv, texel[k].0, texel[k].1);
        }
        out.extend((0..n).map(|k| {
            let (uv, (x, y)) = (Vec2::new(u[k], v[k]), texel[k]);
            let pdf = if self.integral <= 0.0 {
                0.0
            } else {
                self.density(x, y, sin_theta[k])
            };
            (self.radiance_at(uv, x, y), pdf)
        }));
    }

    /// The density at `uv`, in texel `(x, y)`.
    #[inline]
    fn pdf_at(&self, uv: Vec2, x: usize, y: usize) -> f32 {
        self.density(x, y, elementary::sin_cos_turns(0.5 * uv.y).0)
    }

    /// The solid-angle density in texel `(x, y)` where the polar angle's
    /// sine is `sin_theta`: 0 at the poles.
    #[inline(always)]
    fn density(&self, x: usize, y: usize, sin_theta: f32) -> f32 {
        if sin_theta <= 0.0 {
            return 0.0;
        }
        self.texels[y * self.width as usize + x].pdf_uv / (2.0 * PI * PI * sin_theta)
    }

    /// A light sample in the [light interface](super): the direction, the
    /// radiance, an infinite distance and the density.
    #[inline]
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        Self::light_sample(self.sample(u))
    }

    /// A sample of [`EnvironmentLight::sample`] as a light sample: none
    /// where its density or radiance is zero.
    #[inline]
    fn light_sample(sample: Option<(Vec3, Vec3, f32)>) -> Option<LightSample> {
        let (radiance, wi, pdf) = sample?;
        (pdf > 0.0 && radiance != Vec3::ZERO).then_some(LightSample {
            radiance,
            wi,
            dist: f32::INFINITY,
            pdf,
            delta: false,
        })
    }

    /// Multiplies the radiance of every texel by `s > 0` (the sampling
    /// distribution, proportional to radiance, stays the same).
    pub fn scale_radiance(&mut self, s: f32) {
        for t in &mut self.texels {
            t.radiance *= s;
        }
        self.integral *= s;
    }

    /// `∫ luminance(L) dω` over the sphere (W/(m²), luminance).
    pub fn luminance_integral(&self) -> f32 {
        self.integral
    }

    /// Power for light selection: the flux through a disk of radius
    /// `scene_radius` facing every direction, `π r² ∫ L dω`.
    pub fn power(&self, scene_radius: f32) -> f32 {
        PI * scene_radius * scene_radius * self.integral
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_sampling_remaps_within_cells() {
        let (c, total) = cdf([1.0f64, 0.0, 3.0].into_iter());
        assert_eq!(total, 4.0);
        assert_eq!(c, vec![0.0, 0.25, 0.25, 1.0]);
        let g = guide(&c);
        let (i, x, p) = sample_cdf(&c, &g, 0.125);
        assert_eq!((i, p), (0, 0.25));
        assert!((x - 0.5 / 3.0).abs() < 1e-6);
        // u on the empty cell's edge lands in the next non-empty cell.
        let (i, _, p) = sample_cdf(&c, &g, 0.25);
        assert_eq!((i, p), (2, 0.75));
    }

    /// `sample_cdf` as a binary search over the whole CDF does it (the
    /// guide table must not change a single result).
    fn binary_search_sample(cdf: &[f32], u: f32) -> (usize, f32, f32) {
        let n = cdf.len() - 1;
        sample_cell(cdf, cdf.partition_point(|&c| c <= u).clamp(1, n) - 1, u)
    }

    /// The guide table finds the cell a binary search over the whole CDF
    /// finds, for every kind of CDF: spikes, empty runs, ties, a single
    /// cell, sizes that are and are not powers of two.
    #[test]
    fn guided_search_finds_the_binary_searchs_cell() {
        let mut rng = crate::rng::Rng::new(7, 0);
        let shapes: Vec<Vec<f64>> = vec![
            vec![1.0],
            vec![0.0, 0.0, 5.0],
            (0..1000)
                .map(|i| if i == 500 { 1e6 } else { 1e-3 })
                .collect(),
            (0..1024)
                .map(|i| if i % 7 == 0 { 0.0 } else { (i % 13) as f64 })
                .collect(),
            (0..37).map(|i| (i as f64 * 0.3).sin().abs()).collect(),
            (0..300).map(|i| if i < 290 { 0.0 } else { 1.0 }).collect(),
        ];
        for weights in shapes {
            let (c, _) = cdf(weights.iter().copied());
            let g = guide(&c);
            let n = c.len() - 1;
            let probes = (0..20_000)
                .map(|_| rng.next_f32())
                .chain(c.iter().copied().filter(|&x| x < 1.0))
                .chain([0.0, 1.0 - f32::EPSILON / 2.0]);
            for u in probes {
                assert_eq!(
                    sample_cdf(&c, &g, u),
                    binary_search_sample(&c, u),
                    "u = {u}, n = {n}"
                );
            }
        }
    }

    /// The batched lookups give what the single ones give, bit for bit
    /// (the integrator takes either, and images must not change).
    #[test]
    fn batched_lookups_equal_single_ones() {
        let mut rng = crate::rng::Rng::new(11, 0);
        let (w, h) = (64u32, 32u32);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let spike = if i == 700 { 500.0 } else { 0.0 };
                Vec3::new(rng.next_f32(), rng.next_f32() * 2.0, spike + (i % 5) as f32)
            })
            .collect();
        let frame = SphereFrame::new(Vec3::new(0.2, -0.1, 1.0), Vec3::new(1.0, 0.4, 0.0)).unwrap();
        // Both lookups; counts that fill no, one and many chunks.
        for bilinear in [false, true] {
            let env = EnvironmentLight::from_image(w, h, texels.clone(), 1.5, frame)
                .with_bilinear(bilinear);
            for count in [0, 1, CHUNK - 1, CHUNK, 5000] {
                let us: Vec<Vec2> = (0..count).map(|_| rng.next_2d()).collect();
                let mut samples = vec![None; 3];
                env.sample_li_many(&us, &mut samples);
                assert_eq!(samples.len(), us.len());
                for (u, s) in us.iter().zip(&samples) {
                    assert_eq!(*s, env.sample_li(*u), "u = {u}, bilinear {bilinear}");
                }
                let dirs: Vec<Vec3> = samples
                    .iter()
                    .flatten()
                    .map(|s| s.wi * 3.0)
                    .chain(
                        (0..count / 2)
                            .map(|_| crate::warp::square_to_uniform_sphere(rng.next_2d())),
                    )
                    .collect();
                let mut values = vec![(Vec3::ONE, 1.0); 2];
                env.radiance_pdf_many(&dirs, &mut values);
                assert_eq!(values.len(), dirs.len());
                for (d, v) in dirs.iter().zip(&values) {
                    assert_eq!(
                        *v,
                        (env.radiance(*d), env.pdf(*d)),
                        "dir {d}, bilinear {bilinear}"
                    );
                }
            }
        }
    }

    /// The density a lookup reads from the texel's record is, to the bit,
    /// the one formed from the row's and the column's CDFs, which is how
    /// sampling forms it: MIS weighs a direction the same whichever found it.
    #[test]
    fn texel_records_hold_the_cdfs_density() {
        let mut rng = crate::rng::Rng::new(5, 0);
        let (w, h) = (48u32, 20u32);
        let texels: Vec<Vec3> = (0..w * h)
            .map(|i| {
                let dark = if i % 11 == 0 { 0.0 } else { 1.0 };
                Vec3::new(rng.next_f32(), 3.0 * rng.next_f32(), 0.1) * dark
            })
            .collect();
        for bilinear in [false, true] {
            let env = EnvironmentLight::from_image(w, h, texels.clone(), 2.0, SphereFrame::Z_UP)
                .with_bilinear(bilinear);
            let (w, h) = (w as usize, h as usize);
            for _ in 0..4000 {
                let dir = crate::warp::square_to_uniform_sphere(rng.next_2d());
                let uv = equirect_uv(dir, &env.frame);
                let (x, y) = env.texel_at(uv);
                let p_row = env.row_cdf[y + 1] - env.row_cdf[y];
                let row = &env.column_cdf[y * (w + 1)..(y + 1) * (w + 1)];
                let p_col = row[x + 1] - row[x];
                let sin_theta = elementary::sin_cos_turns(0.5 * uv.y).0;
                let want = p_row * p_col * (w * h) as f32 / (2.0 * PI * PI * sin_theta);
                assert_eq!(env.pdf(dir).to_bits(), want.to_bits(), "dir {dir}");
            }
        }
    }

    #[test]
    fn constant_environment_integrates_to_4_pi_radiance() {
        let e = EnvironmentLight::constant(Vec3::splat(2.0));
        let want = 4.0 * PI * 2.0;
        assert!(
            (e.luminance_integral() - want).abs() < 1e-3 * want,
            "{}",
            e.luminance_integral()
        );
        assert_eq!(e.radiance(Vec3::new(0.3, -0.2, 0.9)), Vec3::splat(2.0));
    }
}
