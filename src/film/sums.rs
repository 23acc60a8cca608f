//! The film as a render accumulates it: per-pixel sums and counts, into
//! which each tile is folded as it finishes, and from which the image's
//! means and variances are developed ([`FilmSums::develop`]).
//!
//! Sums, not means, so that pieces of a render merge exactly: two renders
//! of disjoint sample ranges (or disjoint windows) of the same scene add up
//! sum by sum and count by count ([`FilmSums::merge`]). (Floating-point
//! addition is not associative, so the merged sums equal a single run's
//! bit for bit only where both group their additions alike.)

use super::{Film, FilmSettings};
use crate::error::{Error, Result};
use glam::{DVec3, Vec3};
use plsr_base::Vocabulary;

/// A rectangle of pixels `[x0, x0+width) × [y0, y0+height)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Tile {
    /// Left column.
    pub x0: u32,
    /// Top row.
    pub y0: u32,
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
}

/// What one pixel accumulated over its samples.
#[derive(Debug, Clone, Copy)]
pub struct PixelSums {
    /// Sum of sample radiance (after the sensor response).
    pub sum: DVec3,
    /// Sum of squared sample radiance.
    pub sum_sq: DVec3,
    /// Camera samples taken.
    pub samples: u32,
    /// Camera samples that hit geometry.
    pub hits: u32,
    /// Sum of camera-space depths of hits (scene units).
    pub depth: f64,
    /// Sum of first-hit normals.
    pub normal: Vec3,
    /// Sum of first-hit albedos.
    pub albedo: Vec3,
    /// Object id of the first sample's hit (−1: none).
    pub object_id: f32,
    /// Camera samples whose first hit is a virtual object: over `samples`,
    /// the virtual objects' coverage of the pixel (the compositing matte).
    pub virtual_hits: u32,
}

impl Default for PixelSums {
    /// No samples; object id −1.
    fn default() -> Self {
        PixelSums {
            sum: DVec3::ZERO,
            sum_sq: DVec3::ZERO,
            samples: 0,
            hits: 0,
            depth: 0.0,
            normal: Vec3::ZERO,
            albedo: Vec3::ZERO,
            object_id: -1.0,
            virtual_hits: 0,
        }
    }
}

impl PixelSums {
    /// Adds one path's radiance `l` (after the sensor response).
    #[inline(always)]
    pub fn add_radiance(&mut self, l: Vec3) {
        let l = l.as_dvec3();
        self.sum += l;
        self.sum_sq += l * l;
    }

    /// Adds the first-hit layers of a camera sample that hit: camera-space
    /// depth (scene units), normal and albedo.
    #[inline(always)]
    pub fn add_first_hit(&mut self, depth: f32, normal: Vec3, albedo: Vec3) {
        self.hits += 1;
        self.depth += depth as f64;
        self.normal += normal;
        self.albedo += albedo;
    }

    /// Adds the sums and counts of `later`, a piece of later samples: the
    /// object id stays this piece's unless it has no samples.
    #[inline]
    pub fn add(&mut self, later: &PixelSums) {
        if self.samples == 0 {
            self.object_id = later.object_id;
        }
        self.sum += later.sum;
        self.sum_sq += later.sum_sq;
        self.samples += later.samples;
        self.hits += later.hits;
        self.virtual_hits += later.virtual_hits;
        self.depth += later.depth;
        self.normal += later.normal;
        self.albedo += later.albedo;
    }
}

/// Per-pixel sums and counts of a whole image.
#[derive(Debug, Clone)]
pub struct FilmSums {
    width: u32,
    height: u32,
    /// Index of the first sample these sums hold (orders merged pieces).
    sample_start: u32,
    pixels: Vec<PixelSums>,
    settings: FilmSettings,
}

impl FilmSums {
    /// An empty `width × height` film recording with `settings`, for
    /// samples from `sample_start` on.
    pub fn new(width: u32, height: u32, sample_start: u32, settings: FilmSettings) -> FilmSums {
        FilmSums {
            width,
            height,
            sample_start,
            pixels: vec![PixelSums::default(); width as usize * height as usize],
            settings,
        }
    }

    /// Sums of `width × height` pixels (row-major) for samples from
    /// `sample_start` on, recorded with `settings`.
    ///
    /// # Panics
    /// If `pixels` does not hold `width × height` entries.
    pub fn from_pixels(
        width: u32,
        height: u32,
        sample_start: u32,
        pixels: Vec<PixelSums>,
        settings: FilmSettings,
    ) -> FilmSums {
        assert_eq!(pixels.len(), width as usize * height as usize);
        FilmSums {
            width,
            height,
            sample_start,
            pixels,
            settings,
        }
    }

    /// Index of the first sample these sums hold.
    pub fn sample_start(&self) -> u32 {
        self.sample_start
    }

    /// A copy of the sums of the pixels of `tile` (row-major within it),
    /// which must lie inside the image.
    pub fn tile_pixels(&self, tile: Tile) -> Vec<PixelSums> {
        let mut out = Vec::with_capacity((tile.width * tile.height) as usize);
        for y in tile.y0..tile.y0 + tile.height {
            let row = y as usize * self.width as usize + tile.x0 as usize;
            out.extend_from_slice(&self.pixels[row..row + tile.width as usize]);
        }
        out
    }

    /// Every pixel's sums, row-major.
    pub fn pixels(&self) -> &[PixelSums] {
        &self.pixels
    }

    /// The film settings the sums were recorded with.
    pub fn settings(&self) -> FilmSettings {
        self.settings
    }

    /// Width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// The sums of pixel `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> &PixelSums {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Folds in the sums of one tile (row-major within the tile), which
    /// must lie inside the image.
    pub fn add_tile(&mut self, tile: Tile, pixels: &[PixelSums]) {
        debug_assert_eq!(pixels.len(), (tile.width * tile.height) as usize);
        for py in 0..tile.height {
            let row = (tile.y0 + py) as usize * self.width as usize + tile.x0 as usize;
            let src = &pixels[(py * tile.width) as usize..][..tile.width as usize];
            for (dst, s) in self.pixels[row..row + tile.width as usize]
                .iter_mut()
                .zip(src)
            {
                dst.add(s);
            }
        }
    }

    /// Adds another piece of the same image (same size and settings): its
    /// sums and counts add to these. The object id comes from the piece
    /// whose samples come first.
    pub fn merge(&mut self, other: &FilmSums) -> Result<()> {
        if (self.width, self.height) != (other.width, other.height) {
            return Err(Error::invalid_argument(format!(
                "cannot merge a {}×{} film into a {}×{} one",
                other.width, other.height, self.width, self.height
            )));
        }
        if self.settings != other.settings {
            return Err(Error::invalid_argument(
                "cannot merge films recorded with different film settings",
            ));
        }
        let other_first = other.sample_start < self.sample_start;
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            let id = if other_first && b.samples > 0 {
                b.object_id
            } else {
                a.object_id
            };
            a.add(b);
            a.object_id = id;
        }
        self.sample_start = self.sample_start.min(other.sample_start);
        Ok(())
    }

    /// Each pixel's mean recorded value (0 where it has no samples),
    /// row-major: the colour [`FilmSums::develop`] gives, without the rest.
    pub fn means(&self) -> Vec<glam::Vec3> {
        self.pixels
            .iter()
            .map(|s| (s.sum / s.samples.max(1) as f64).as_vec3())
            .collect()
    }

    /// The image: per pixel the mean of its samples, the variance of that
    /// mean, coverage, and the mean first-hit layers, over the settings'
    /// crop window if there is one. `spp` is recorded as the film's
    /// samples per pixel.
    pub fn develop(&self, spp: u32) -> Film {
        let crop = self
            .settings
            .crop
            .filter(|c| c.x0 + c.width <= self.width && c.y0 + c.height <= self.height);
        self.develop_window(spp, crop)
    }

    /// [`FilmSums::develop`] of every pixel, whatever the settings' crop
    /// window: for the sums of a window already cut out (a part's).
    pub fn develop_all(&self, spp: u32) -> Film {
        self.develop_window(spp, None)
    }

    /// The image of the pixels of `crop` (all for `None`).
    fn develop_window(&self, spp: u32, crop: Option<crate::film::Crop>) -> Film {
        let crop = crop.unwrap_or(crate::film::Crop {
            x0: 0,
            y0: 0,
            width: self.width,
            height: self.height,
        });
        let mut film = Film::new(crop.width, crop.height);
        film.spp = spp;
        film.settings = self.settings;
        for fy in 0..crop.height {
            for fx in 0..crop.width {
                let i = (fy * crop.width + fx) as usize;
                let s = &self.pixels[((crop.y0 + fy) * self.width + crop.x0 + fx) as usize];
                if s.samples == 0 {
                    continue;
                }
                let n = s.samples as f64;
                let mean = s.sum / n;
                film.color[i] = mean.as_vec3();
                film.variance[i] = if s.samples > 1 {
                    ((s.sum_sq - s.sum * mean) / (n * (n - 1.0)))
                        .max(DVec3::ZERO)
                        .as_vec3()
                } else {
                    Vec3::ZERO
                };
                film.alpha[i] = s.hits as f32 / s.samples as f32;
                film.object_id[i] = s.object_id;
                if s.hits > 0 {
                    let h = s.hits as f32;
                    film.depth[i] = (s.depth / s.hits as f64) as f32;
                    film.normal[i] = s.normal / h;
                    film.albedo[i] = s.albedo / h;
                }
            }
        }
        film
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(l: f64, hit: bool, id: f32) -> PixelSums {
        PixelSums {
            sum: DVec3::splat(l),
            sum_sq: DVec3::splat(l * l),
            samples: 1,
            hits: hit as u32,
            depth: if hit { 2.0 } else { 0.0 },
            normal: if hit { Vec3::Z } else { Vec3::ZERO },
            albedo: if hit { Vec3::splat(0.5) } else { Vec3::ZERO },
            object_id: id,
            // Every hit of these samples is a virtual object's.
            virtual_hits: hit as u32,
        }
    }

    #[test]
    fn pieces_merge_into_the_sums_of_the_whole() {
        let tile = Tile {
            x0: 0,
            y0: 0,
            width: 1,
            height: 1,
        };
        let settings = FilmSettings::default();
        let values = [(1.0, true, 3.0), (3.0, false, -1.0), (2.0, true, 5.0)];
        let mut whole = FilmSums::new(1, 1, 0, settings);
        for &(l, hit, id) in &values {
            whole.add_tile(tile, &[sample(l, hit, id)]);
        }
        // Samples 1.. and 0 rendered apart, merged in the "wrong" order.
        let mut late = FilmSums::new(1, 1, 1, settings);
        late.add_tile(tile, &[sample(values[1].0, values[1].1, values[1].2)]);
        late.add_tile(tile, &[sample(values[2].0, values[2].1, values[2].2)]);
        let mut early = FilmSums::new(1, 1, 0, settings);
        early.add_tile(tile, &[sample(values[0].0, values[0].1, values[0].2)]);
        late.merge(&early).unwrap();
        assert_eq!(whole.pixel(0, 0).virtual_hits, 2);
        assert_eq!(late.pixel(0, 0).virtual_hits, 2, "the matte merges too");
        let (a, b) = (whole.develop(3), late.develop(3));
        assert!(a.bitwise_eq(&b), "{a:?} != {b:?}");
        assert_eq!(a.color[0], Vec3::splat(2.0));
        assert_eq!(a.variance[0], Vec3::splat(1.0 / 3.0));
        assert_eq!(a.alpha[0], 2.0 / 3.0);
        assert_eq!(a.object_id[0], 3.0, "the first sample's object");
        assert_eq!(a.depth[0], 2.0);
        assert!(FilmSums::new(2, 1, 0, settings).merge(&whole).is_err());
    }
}
