//! `plsr bench materials`: what the richer BSDFs cost against Lambert.

use crate::error::{Error, Result};
use plsr::bsdf::{
    BlinnPhongParams, Bsdf, CookTorranceParams, DielectricParams, Distribution, Fresnel,
    Microfacet, PrincipledParams, METALS,
};
use plsr::film::Film;
use plsr::job::RenderJob;
use plsr::render::{render, RenderOptions, RenderStats};
use plsr::scene::{Scene, SceneDescription};
use plsr_base::Vocabulary;
use std::path::Path;

/// `plsr bench materials`: the Cornell box rendered with all-diffuse
/// materials and again with every material replaced by a principled BSDF of
/// the same base colour (roughness 0.5, specular 0.5), in Mitsuba's mode and
/// in the energy-conserving mode, each with the general integrator and with
/// the vectorised kernel, and with every material a rough gold (isotropic
/// GGX, then Beckmann, α 0.2, gold's complex index), every material a rough
/// glass (isotropic GGX, then Beckmann, α 0.2, η 1.5: the light sits inside
/// a box of glass walls), every material a smooth glass (η 1.5) and every material
/// Blinn–Phong (the diffuse colour, specular 0.2, exponent 40), and every
/// material the principled one with 4×4 roughness and metallic maps (the
/// box has no texture coordinates, so each lane looks up one texel: this row
/// measures the per-lane lookups' cost), interleaved in the same run: the ratios to the
/// all-diffuse scene say what the richer BSDF costs, the kernel's ratio to
/// the general integrator what the wavefront gains. Returns each scene's
/// `(general, vectorised)` Msamples/s.
pub fn run(threads: Option<usize>) -> Result<[(f64, f64); 10]> {
    let path = Path::new("assets/scenes/cornell/cornell.toml");
    let mut diffuse = plsr::scene::file::load(path)?;
    diffuse.job.spp = 32;
    let job = diffuse.job;
    diffuse.camera = diffuse
        .camera
        .with_resolution(256, 256)
        .map_err(|e| Error::invalid_argument(e.to_string()))?;
    let scenes = scenes(&diffuse)?;
    let (best, same) = measure(&scenes, &job, threads)?;
    print_table(path, &scenes, &best, &same);
    Ok(best)
}

/// The benchmark's scenes: the box with each kind of material, by name.
fn scenes(diffuse: &SceneDescription) -> Result<[(&'static str, Scene); 10]> {
    let smooth_glass = smooth_glass(diffuse);
    let blinn_phong = blinn_phong(diffuse);
    let mapped = mapped(diffuse);
    Ok([
        ("all diffuse", Scene::build(diffuse.clone())?),
        (
            "all principled (Mitsuba's)",
            Scene::build(principled(diffuse, false))?,
        ),
        (
            "all principled, energy-conserving",
            Scene::build(principled(diffuse, true))?,
        ),
        (
            "all rough gold (GGX α 0.2)",
            Scene::build(gold(diffuse, Distribution::Ggx))?,
        ),
        (
            "all rough gold (Beckmann α 0.2)",
            Scene::build(gold(diffuse, Distribution::Beckmann))?,
        ),
        (
            "all rough glass (GGX α 0.2, η 1.5)",
            Scene::build(glass(diffuse, Distribution::Ggx))?,
        ),
        (
            "all rough glass (Beckmann α 0.2, η 1.5)",
            Scene::build(glass(diffuse, Distribution::Beckmann))?,
        ),
        ("all smooth glass (η 1.5)", Scene::build(smooth_glass)?),
        ("all Blinn–Phong (exponent 40)", Scene::build(blinn_phong)?),
        (
            "all principled, roughness and metallic maps",
            Scene::build(mapped)?,
        ),
    ])
}

/// Every material principled, of the same base colour.
fn principled(diffuse: &SceneDescription, energy_conserving: bool) -> SceneDescription {
    let mut scene = diffuse.clone();
    for m in &mut scene.materials {
        m.bsdf = Bsdf::Principled(PrincipledParams {
            base_color: m.bsdf.albedo(),
            roughness: 0.5,
            metallic: 0.0,
            anisotropic: 0.0,
            specular: 0.5,
            spec_tint: 0.0,
            energy_conserving,
        });
    }
    scene
}

/// Every material a rough gold.
fn gold(diffuse: &SceneDescription, distribution: Distribution) -> SceneDescription {
    let mut scene = diffuse.clone();
    let (_, eta, k) = METALS[0];
    for m in &mut scene.materials {
        m.bsdf = Bsdf::CookTorrance(CookTorranceParams {
            microfacet: Microfacet::isotropic(distribution, 0.2),
            fresnel: Fresnel::Conductor {
                eta: eta.into(),
                k: k.into(),
                specular_reflectance: glam::Vec3::ONE,
            },
        });
    }
    scene
}

/// Every material a rough glass.
fn glass(diffuse: &SceneDescription, distribution: Distribution) -> SceneDescription {
    let mut scene = diffuse.clone();
    for m in &mut scene.materials {
        m.bsdf = Bsdf::Dielectric(DielectricParams {
            eta: 1.5,
            microfacet: Some(Microfacet::isotropic(distribution, 0.2)),
        });
    }
    scene
}

/// Every material a smooth glass.
fn smooth_glass(diffuse: &SceneDescription) -> SceneDescription {
    let mut scene = diffuse.clone();
    for m in &mut scene.materials {
        m.bsdf = Bsdf::Dielectric(DielectricParams {
            eta: 1.5,
            microfacet: None,
        });
    }
    scene
}

/// Every material Blinn–Phong.
fn blinn_phong(diffuse: &SceneDescription) -> SceneDescription {
    let mut scene = diffuse.clone();
    for m in &mut scene.materials {
        m.bsdf = Bsdf::BlinnPhong(BlinnPhongParams {
            diffuse: m.bsdf.albedo().min(glam::Vec3::splat(0.8)),
            specular: glam::Vec3::splat(0.2),
            exponent: 40.0,
        });
    }
    scene
}

/// Every material Mitsuba's principled, with roughness and metallic maps.
fn mapped(diffuse: &SceneDescription) -> SceneDescription {
    let mut scene = principled(diffuse, false);
    // 4×4 maps of values in [0.1, 0.9] (the red channel is read).
    let map = |seed: u32| {
        let texels = (0..16u32)
            .map(|i| glam::Vec3::splat(0.1 + 0.8 * ((i * 7 + seed * 5) % 16) as f32 / 15.0))
            .collect();
        std::sync::Arc::new(plsr::texture::ImageTexture::from_texels(4, 4, texels))
    };
    for m in &mut scene.materials {
        m.textures.roughness = Some(map(1));
        m.textures.metallic = Some(map(2));
    }
    scene
}

/// Each scene's best `(general, vectorised)` Msamples/s.
type Rates = [(f64, f64); 10];

/// Interleaved runs, best of three each, so drift hits all alike: each
/// scene's best `(general, vectorised)` Msamples/s, and whether the two
/// integrators' images were the same every time.
fn measure(
    scenes: &[(&str, Scene); 10],
    job: &RenderJob,
    threads: Option<usize>,
) -> Result<(Rates, [bool; 10])> {
    let options = |vectorised: bool| RenderOptions {
        threads,
        vectorised,
        ..Default::default()
    };
    let mut best = [(0.0f64, 0.0f64); 10];
    let mut same = [true; 10];
    for _ in 0..3 {
        for (k, (_, scene)) in scenes.iter().enumerate() {
            let (general, stats): (Film, RenderStats) =
                render(scene, job, &options(false), &|_, _| true)?;
            best[k].0 = best[k].0.max(stats.msamples_per_s());
            let (fast, stats) = render(scene, job, &options(true), &|_, _| true)?;
            best[k].1 = best[k].1.max(stats.msamples_per_s());
            same[k] &= general.color == fast.color;
        }
    }
    Ok((best, same))
}

/// The table of the measurements.
fn print_table(path: &Path, scenes: &[(&str, Scene); 10], best: &Rates, same: &[bool; 10]) {
    println!(
        "plsr bench materials: {} at 256×256, 32 spp, best of 3 interleaved runs",
        path.display()
    );
    println!();
    println!(
        "| materials | general integrator, Msamples/s | ÷ all diffuse | vectorised kernel, Msamples/s | ÷ all diffuse | kernel ÷ general | same image |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (k, (name, _)) in scenes.iter().enumerate() {
        let (g, v) = best[k];
        println!(
            "| {name} | {g:.3} | {:.3}× | {v:.3} | {:.3}× | {:.2}× | {} |",
            g / best[0].0,
            v / best[0].1,
            v / g,
            if same[k] { "yes" } else { "NO" }
        );
    }
}
