//! Denoising a film: its colour layer through plsr's denoiser (Intel Open
//! Image Denoise's RT network, `plsr-denoise`), guided by the film's own
//! albedo and normal layers. The noisy colour is kept as the `noisy` layer
//! (`noisy.R/G/B` in the EXR); the variance layer stays that of the noisy
//! mean. Denoising is biased: renders meant for statistics, fits or
//! metrics against ground truth stay undenoised (docs/denoising.md).

use super::Film;
use crate::error::Result;
use glam::Vec3;
use plsr_denoise::{Image, Options};

/// Which layers guide the denoiser, and whether they are prefiltered.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DenoiseSettings {
    /// Use the albedo layer.
    pub albedo: bool,
    /// Use the normal layer (only with the albedo).
    pub normal: bool,
    /// Clean the albedo and normal layers with their own networks first
    /// (three networks instead of one: slower, better where the first hit
    /// varies within a pixel).
    pub prefilter: bool,
    /// The colour's scale for the network; `None`: its autoexposure (a
    /// key of 0.18 over the image's geometric-mean luminance). Films to be
    /// compared after denoising (a composite's two renders) share one.
    pub input_scale: Option<f32>,
}

impl Default for DenoiseSettings {
    /// Albedo and normal, not prefiltered.
    fn default() -> DenoiseSettings {
        DenoiseSettings {
            albedo: true,
            normal: true,
            prefilter: false,
            input_scale: None,
        }
    }
}

/// What a denoising did.
#[derive(Debug, Clone, PartialEq)]
pub struct DenoiseReport {
    /// The guides used: "colour", "colour + albedo", "colour + albedo +
    /// normal", with "(prefiltered)" when they were.
    pub guides: String,
    /// Wall time, seconds.
    pub seconds: f64,
}

fn as_arrays(v: &[Vec3]) -> Vec<[f32; 3]> {
    v.iter().map(|c| c.to_array()).collect()
}

/// What the denoiser is given for a film: its (noisy) colour and the
/// guides the settings ask for, each `width × height` RGB pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct DenoiseGuides {
    /// The colour: the `noisy` layer if the film was denoised before.
    pub color: Vec<[f32; 3]>,
    /// The albedo guide: the albedo layer (the mean over the samples that
    /// hit) weighted by the coverage, plus 1 for the fraction of each pixel
    /// where camera rays missed the scene: `α·albedo + (1 − α)`.
    pub albedo: Option<Vec<[f32; 3]>>,
    /// The normal layer.
    pub normal: Option<Vec<[f32; 3]>>,
}

/// The input scale the denoiser's autoexposure gives `film`'s (noisy)
/// colour: 0.18 over its geometric-mean luminance.
pub fn input_scale(film: &Film) -> f32 {
    let color = as_arrays(film.noisy.as_deref().unwrap_or(&film.color));
    plsr_denoise::autoexposure::input_scale(&color, film.width as usize, film.height as usize)
}

impl Film {
    /// The denoiser's inputs for this film (as [`Film::denoise`] makes
    /// them, and as a peer denoiser should be given them).
    pub fn denoise_guides(&self, settings: &DenoiseSettings) -> DenoiseGuides {
        let color = as_arrays(self.noisy.as_deref().unwrap_or(&self.color));
        // Where camera rays miss the scene the film's albedo is 0, but the
        // sky is seen as it is: its guide is 1 (colour ÷ albedo = radiance,
        // as on a surface), for the part of each pixel the sky covers.
        let albedo = settings.albedo.then(|| {
            self.albedo
                .iter()
                .zip(&self.alpha)
                .map(|(a, alpha)| {
                    let alpha = alpha.clamp(0.0, 1.0);
                    (*a * alpha + Vec3::splat(1.0 - alpha)).to_array()
                })
                .collect::<Vec<_>>()
        });
        let normal = (settings.albedo && settings.normal).then(|| as_arrays(&self.normal));
        DenoiseGuides {
            color,
            albedo,
            normal,
        }
    }

    /// Denoises the colour layer in place, keeping the noisy colour as the
    /// `noisy` layer. A film denoised before is denoised again from its
    /// noisy layer. Refuses colour, albedo or normal values that are NaN
    /// or infinite, naming how many pixels have them.
    pub fn denoise(&mut self, settings: &DenoiseSettings) -> Result<DenoiseReport> {
        let start = std::time::Instant::now();
        let (w, h) = (self.width as usize, self.height as usize);
        let DenoiseGuides {
            color,
            albedo,
            normal,
        } = self.denoise_guides(settings);
        let filter = if settings.prefilter {
            plsr_denoise::denoise_prefiltered
        } else {
            plsr_denoise::denoise
        };
        let result = filter(
            Image::new(&color, w, h),
            albedo.as_deref().map(|p| Image::new(p, w, h)),
            normal.as_deref().map(|p| Image::new(p, w, h)),
            &Options {
                hdr: true,
                clean_aux: false,
                input_scale: settings.input_scale,
            },
        );
        let denoised: Vec<Vec3> = result?.into_iter().map(Vec3::from_array).collect();
        let noisy = std::mem::replace(&mut self.color, denoised);
        if self.noisy.is_none() {
            self.noisy = Some(noisy);
        }
        let mut guides = String::from("colour");
        if albedo.is_some() {
            guides.push_str(" + albedo");
        }
        if normal.is_some() {
            guides.push_str(" + normal");
        }
        if settings.prefilter && albedo.is_some() {
            guides.push_str(" (prefiltered)");
        }
        Ok(DenoiseReport {
            guides,
            seconds: start.elapsed().as_secs_f64(),
        })
    }
}
