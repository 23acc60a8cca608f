//! The denoiser's guides behind glass. A render's albedo and normal layers
//! record the first surface each camera sample hits; behind smooth glass
//! (a delta surface) that is the glass, whose albedo and normal say
//! nothing about the image seen through it. Intel's OIDN asks for the
//! first surface that is not a delta instead, so that the denoiser keeps
//! the edges it sees through glass. This pass traces the pixels' first
//! camera samples again and follows them through the glass (refracted, or
//! reflected where the reflection is total) to that surface; through glass
//! to the sky it records albedo 1 and normal 0, as the denoiser's guide
//! takes the sky.
//!
//! Only pixels where some sample met glass first are changed; elsewhere
//! the render's own layers stay, bit for bit. Scenes without smooth glass
//! are left alone at no cost.

use super::general::{guide_hit, GuideHit};
use super::steps::camera_sample;
use crate::film::Film;
use crate::job::RenderJob;
use crate::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;

/// Camera samples per pixel the pass traces at most (the job's first ones).
pub const GUIDE_SAMPLES: u32 = 8;

/// Rewrites `film`'s albedo and normal layers (a whole image of `job`)
/// where camera samples met smooth glass first: each such pixel's layers
/// become the mean, over its first [`GUIDE_SAMPLES`] samples, of what lies
/// behind the glass. Runs on the current rayon pool; the result does not
/// depend on its size.
pub fn see_through_glass(scene: &Scene, job: &RenderJob, film: &mut Film) {
    let any_delta = scene
        .materials()
        .iter()
        .any(|m| m.bsdf.is_delta() || m.composite.is_some());
    let (w, h) = (film.width, film.height);
    if !any_delta || (w, h) != (scene.camera().width(), scene.camera().height()) {
        return;
    }
    let lens = scene.camera().needs_lens_sample();
    let samples = job.samples().start..job.samples().start + job.spp.min(GUIDE_SAMPLES);
    let mask = job.ray_mask();
    let rows: Vec<Vec<Option<(Vec3, Vec3)>>> = (0..h)
        .into_par_iter()
        .map(|y| {
            (0..w)
                .map(|x| {
                    let (mut albedo, mut normal, mut hits) = (Vec3::ZERO, Vec3::ZERO, 0u32);
                    let mut through = false;
                    for s in samples.clone() {
                        let (_, Some(ray)) = camera_sample(scene, job.seed, lens, x, y, s) else {
                            continue;
                        };
                        match guide_hit(scene, ray, mask) {
                            GuideHit::First(a, n) => {
                                albedo += a;
                                normal += n;
                                hits += 1;
                            }
                            GuideHit::Through(a, n) => {
                                albedo += a;
                                normal += n;
                                hits += 1;
                                through = true;
                            }
                            GuideHit::Sky => {
                                albedo += Vec3::ONE;
                                hits += 1;
                                through = true;
                            }
                            GuideHit::Lost => {}
                        }
                    }
                    (through && hits > 0).then(|| (albedo / hits as f32, normal / hits as f32))
                })
                .collect()
        })
        .collect();
    for (y, row) in rows.into_iter().enumerate() {
        for (x, guide) in row.into_iter().enumerate() {
            if let Some((albedo, normal)) = guide {
                let i = y * w as usize + x;
                film.albedo[i] = albedo;
                film.normal[i] = normal;
            }
        }
    }
}
