//! `plsr bench peers`: plsr against Mitsuba 3 (`llvm_ad_rgb`) on scenes
//! users render, in one run: samples per second, the error at equal samples
//! against a converged reference, and the time each needs for equal error.
//!
//! Four scenes, each written in plsr's format and as Mitsuba 3 XML into the
//! work folder (`--dir`, default `out/bench-peers`, kept for inspection):
//!
//! - `glossy-env`: four identical 81,920-triangle spheres (Lambert, rough
//!   gold, principled, rough glass) on a ground plane, lit only by a
//!   1024×512 HDR sky with a sun (looked up bilinearly, as Mitsuba's
//!   `envmap` always does), 512×256, max depth 15;
//! - `cornell`: the Cornell box with its area light, 512×512, max depth 7;
//! - `pls-room`: `make demo`'s room, lit by the paper's two PLS lights,
//!   which Mitsuba cannot express: it gets a spot light for the narrow one
//!   and the emitting outline for the wide one, so its image differs and
//!   only its speed is comparable;
//! - `matpreview`: Mitsuba's material-preview scene as Mitsuba's own
//!   documentation writes it (its `serialized` meshes and the museum
//!   environment from `tests/data/realworld/mitsuba/`, Mitsuba's default
//!   Gaussian pixel filter), the object in a rough plastic (GGX) and its
//!   stand in a principled material whose base colour is a checkerboard,
//!   384×288, path tracer without a depth limit. It is written as Mitsuba
//!   XML only: plsr renders it through its importer, as a user would.
//!   (Mitsuba splats each sample into the pixels its filter reaches, plsr
//!   places samples by the filter: at equal spp Mitsuba's pixels average
//!   about π pixels' worth of samples, with correlated noise.)
//!
//! Mitsuba reads the geometry plsr built, written as OBJ files (world
//! space, exact float round trip), and the same environment EXR. Both
//! render at the same spp, `--seeds` times each (two by default, with
//! seeds 1, 2, …); each time is the best of them after a warm-up
//! (Mitsuba's warm-up compiles its kernels), each relMSE their mean. More
//! seeds steady the relMSE of a scene whose error is a few rare bright
//! paths (the glass sphere's). Scene by scene, plsr is timed
//! before and again after Mitsuba and its time is the mean of the two, so
//! that the machine's drift in speed cancels to first order. The reference
//! is plsr at `--reference-spp` (cached in the folder), the mean of two
//! independent halves (different seeds); the relative MSE subtracts the
//! reference's own error, estimated from the halves' difference, so it
//! estimates the error against the converged image. (The `variance` layer
//! of one render would overestimate it: plsr's samples are stratified.)
//! plsr's `max_depth` counts scattering events, Mitsuba's path segments, so
//! Mitsuba gets plsr's + 1.

use super::python_json;
use crate::error::{Error, Result};
use plsr::bsdf::{Bsdf, Distribution, Fresnel};
use plsr::camera::Camera;
use plsr::film::Film;
use plsr::filter::PixelFilter;
use plsr::render::{render, RenderOptions};
use plsr::scene::{Scene, SceneDescription};
use plsr_base::Vocabulary;
use plsr_hdr::oiio::PixelType;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Options of `plsr bench peers`.
pub struct PeersBenchOptions {
    /// Worker threads of both renderers (default: all cores).
    pub threads: Option<usize>,
    /// The Python that runs Mitsuba 3 (`None`: plsr alone).
    pub python: Option<PathBuf>,
    /// Samples per pixel of the timed renders.
    pub spp: u32,
    /// Samples per pixel of the reference.
    pub reference_spp: u32,
    /// The work folder.
    pub dir: PathBuf,
    /// Only the scenes named (empty: all).
    pub only: Vec<String>,
    /// Timed renders per renderer and scene (seeds 1 to `seeds`): each
    /// time is their best, each relMSE their mean.
    pub seeds: u32,
    /// The Python with Blender's `bpy` (`None`: no Cycles, no denoised
    /// comparison).
    pub blender_python: Option<PathBuf>,
}

/// One scene of the suite, as both renderers get it.
pub(super) struct PeerScene {
    pub(super) name: &'static str,
    /// plsr's scene file.
    plsr: PathBuf,
    /// Mitsuba's scene file.
    pub(super) mitsuba: PathBuf,
    /// Whether Mitsuba's lights only approximate plsr's.
    approximate: bool,
}

fn io_err(file: &Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::io(file.to_path_buf(), source)
}

/// Writes a text file whole or not at all.
pub(super) fn write(path: &Path, text: &str) -> Result<()> {
    plsr::atomic_write::write_atomically(path, |w| {
        use std::io::Write as _;
        w.write_all(text.as_bytes()).map_err(io_err(path))
    })
}

/// Writes a mesh as OBJ (positions, and normals where given).
fn write_obj(
    path: &Path,
    positions: &[glam::Vec3],
    triangles: &[[u32; 3]],
    normals: &[glam::Vec3],
) -> Result<()> {
    let mut s = String::with_capacity(positions.len() * 40 + triangles.len() * 30);
    for p in positions {
        let _ = writeln!(s, "v {} {} {}", p.x, p.y, p.z);
    }
    for n in normals {
        let _ = writeln!(s, "vn {} {} {}", n.x, n.y, n.z);
    }
    for t in triangles {
        let [a, b, c] = t.map(|i| i + 1);
        if normals.is_empty() {
            let _ = writeln!(s, "f {a} {b} {c}");
        } else {
            let _ = writeln!(s, "f {a}//{a} {b}//{b} {c}//{c}");
        }
    }
    write(path, &s)
}

/// The glossy/environment scene's sky: a blue gradient over a dark ground,
/// and a sun 35° high of radius 2.5° and radiance 300, as a 1024×512
/// equirectangular EXR (the top row is +y, the centre column +z).
fn write_sky(path: &Path) -> Result<()> {
    let (w, h) = (1024usize, 512usize);
    let sun = {
        let (el, az) = (35f32.to_radians(), 0.6f32);
        glam::Vec3::new(el.cos() * az.sin(), el.sin(), el.cos() * az.cos())
    };
    let cos_sun = 2.5f32.to_radians().cos();
    let texel = |x: usize, y: usize| {
        let theta = std::f32::consts::PI * (y as f32 + 0.5) / h as f32;
        let phi = 2.0 * std::f32::consts::PI * ((x as f32 + 0.5) / w as f32 - 0.5);
        let d = glam::Vec3::new(
            theta.sin() * phi.sin(),
            theta.cos(),
            theta.sin() * phi.cos(),
        );
        if d.dot(sun) > cos_sun {
            (300.0, 280.0, 250.0)
        } else if d.y >= 0.0 {
            let t = 0.4 + 0.6 * d.y;
            (0.45 * t, 0.65 * t, 1.0 * t)
        } else {
            (0.12, 0.10, 0.08)
        }
    };
    let mut pixels = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let (r, g, b) = texel(x, y);
            pixels.extend([r, g, b]);
        }
    }
    Ok(plsr_hdr::oiio::write_image(
        path,
        w,
        h,
        3,
        PixelType::F32,
        &[],
        &pixels,
    )?)
}

/// Writes the glossy/environment scene's files into `dir`; plsr's scene file.
fn write_glossy_env(dir: &Path, spp: u32) -> Result<PathBuf> {
    let (positions, triangles) = plsr::scene::shapes::icosphere(glam::Vec3::ZERO, 1.0, 6);
    let normals: Vec<glam::Vec3> = positions.iter().map(|p| p.normalize()).collect();
    write_obj(&dir.join("sphere.obj"), &positions, &triangles, &normals)?;
    let ground = [
        glam::Vec3::new(-20.0, 0.0, -20.0),
        glam::Vec3::new(20.0, 0.0, -20.0),
        glam::Vec3::new(20.0, 0.0, 20.0),
        glam::Vec3::new(-20.0, 0.0, 20.0),
    ];
    write_obj(
        &dir.join("ground.obj"),
        &ground,
        &[[0, 2, 1], [0, 3, 2]],
        &[],
    )?;
    write_sky(&dir.join("sky.exr"))?;
    let (_, au_eta, au_k) = plsr::bsdf::METALS[0];
    debug_assert_eq!(plsr::bsdf::METALS[0].0, "Au");
    let mut s = format!(
        "# plsr bench peers: four identical 81,920-triangle spheres on a ground\n\
         # plane, lit only by an HDR sky (Y up).\n\
         [render]\nspp = {spp}\nmax_depth = 15\nseed = 0\n\n\
         [camera]\ntype = \"pinhole\"\nposition = [0, 2.2, 9]\nlook_at = [0, 0.9, 0]\n\
         up = [0, 1, 0]\nvfov = 30\nresolution = [512, 256]\n\n\
         [environment]\nfile = \"sky.exr\"\nup = [0, 1, 0]\nforward = [0, 0, 1]\n\
         # bilinear, as Mitsuba's envmap always looks it up: the same work\n\
         filter = \"bilinear\"\n\n\
         [[materials]]\nname = \"ground\"\ntype = \"diffuse\"\nreflectance = [0.5, 0.5, 0.5]\n\n\
         [[materials]]\nname = \"lambert\"\ntype = \"diffuse\"\nreflectance = [0.7, 0.7, 0.7]\n\n\
         [[materials]]\nname = \"gold\"\ntype = \"cook_torrance\"\nalpha = 0.2\n\
         fresnel = \"conductor\"\neta = [{}, {}, {}]\nk = [{}, {}, {}]\n\n\
         [[materials]]\nname = \"principled\"\ntype = \"principled\"\n\
         base_color = [0.1, 0.3, 0.8]\nroughness = 0.4\nspecular = 0.5\n\n\
         [[materials]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\nalpha = 0.1\n\n\
         [[shapes]]\ntype = \"obj\"\nname = \"ground\"\nfile = \"ground.obj\"\nmaterial = \"ground\"\n",
        au_eta[0], au_eta[1], au_eta[2], au_k[0], au_k[1], au_k[2]
    );
    for (i, material) in ["lambert", "gold", "principled", "glass"]
        .iter()
        .enumerate()
    {
        let x = -3.3 + 2.2 * i as f32;
        let _ = write!(
            s,
            "\n[[shapes]]\ntype = \"obj\"\nname = \"{material} sphere\"\nfile = \"sphere.obj\"\n\
             material = \"{material}\"\ntransform = {{ translate = [{x}, 1, 0] }}\n"
        );
    }
    let path = dir.join("glossy-env.toml");
    write(&path, &s)?;
    Ok(path)
}

fn rgb(v: glam::Vec3) -> String {
    format!("{}, {}, {}", v.x, v.y, v.z)
}

/// Mitsuba's BSDF for plsr's, or why there is none. Opaque BSDFs are
/// wrapped in `twosided`, as plsr shades opaque surfaces from both sides.
fn mitsuba_bsdf(bsdf: &Bsdf) -> std::result::Result<String, String> {
    let alpha = |m: &plsr::bsdf::Microfacet| {
        if m.alpha_x != m.alpha_y {
            return Err("anisotropic roughness".to_string());
        }
        let kind = match m.kind {
            Distribution::Ggx => "ggx",
            Distribution::Beckmann => "beckmann",
        };
        Ok(format!(
            "<string name=\"distribution\" value=\"{kind}\"/><float name=\"alpha\" value=\"{}\"/>",
            m.alpha_x
        ))
    };
    let twosided = |inner: String| format!("<bsdf type=\"twosided\">{inner}</bsdf>");
    Ok(match bsdf {
        Bsdf::Diffuse(p) => twosided(format!(
            "<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"{}\"/></bsdf>",
            rgb(p.reflectance)
        )),
        Bsdf::CookTorrance(p) => match p.fresnel {
            Fresnel::Conductor {
                eta,
                k,
                specular_reflectance,
            } => twosided(format!(
                "<bsdf type=\"roughconductor\">{}<rgb name=\"eta\" value=\"{}\"/>\
                 <rgb name=\"k\" value=\"{}\"/><rgb name=\"specular_reflectance\" value=\"{}\"/></bsdf>",
                alpha(&p.microfacet)?,
                rgb(eta),
                rgb(k),
                rgb(specular_reflectance)
            )),
            _ => return Err("a Cook–Torrance BSDF without a conductor Fresnel term".into()),
        },
        Bsdf::Dielectric(p) => match &p.microfacet {
            Some(m) => format!(
                "<bsdf type=\"roughdielectric\">{}<float name=\"int_ior\" value=\"{}\"/>\
                 <float name=\"ext_ior\" value=\"1\"/></bsdf>",
                alpha(m)?,
                p.eta
            ),
            None => format!(
                "<bsdf type=\"dielectric\"><float name=\"int_ior\" value=\"{}\"/>\
                 <float name=\"ext_ior\" value=\"1\"/></bsdf>",
                p.eta
            ),
        },
        Bsdf::Principled(p) if !p.energy_conserving => twosided(format!(
            "<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"{}\"/>\
             <float name=\"roughness\" value=\"{}\"/><float name=\"metallic\" value=\"{}\"/>\
             <float name=\"specular\" value=\"{}\"/><float name=\"spec_tint\" value=\"{}\"/>\
             <float name=\"anisotropic\" value=\"{}\"/></bsdf>",
            rgb(p.base_color),
            p.roughness,
            p.metallic,
            p.specular,
            p.spec_tint,
            p.anisotropic
        )),
        Bsdf::Principled(_) => return Err("the energy-conserving principled mode".into()),
        Bsdf::BlinnPhong(_) => return Err("Blinn–Phong".into()),
        Bsdf::ThinDielectric(p) => format!(
            "<bsdf type=\"thindielectric\"><float name=\"int_ior\" value=\"{}\"/>\
             <float name=\"ext_ior\" value=\"1\"/>\
             <rgb name=\"specular_reflectance\" value=\"{}\"/>\
             <rgb name=\"specular_transmittance\" value=\"{}\"/></bsdf>",
            p.eta,
            rgb(p.reflectance),
            rgb(p.transmittance)
        ),
        Bsdf::Plastic(p) => twosided(format!(
            "<bsdf type=\"plastic\">{}</bsdf>",
            plastic_params(
                p.diffuse_reflectance,
                p.specular_reflectance,
                (p.int_ior, p.ext_ior),
                p.nonlinear
            )
        )),
        Bsdf::RoughPlastic(p) => twosided(format!(
            "<bsdf type=\"roughplastic\">{}{}<boolean name=\"sample_visible\" value=\"{}\"/></bsdf>",
            alpha(&p.microfacet())?,
            plastic_params(
                p.diffuse_reflectance,
                p.specular_reflectance,
                (p.int_ior, p.ext_ior),
                p.nonlinear
            ),
            p.sample_visible
        )),
        Bsdf::PrincipledFull(p) => {
            let inner = format!(
                "<bsdf type=\"principled\"><rgb name=\"base_color\" value=\"{}\"/>\
                 <float name=\"roughness\" value=\"{}\"/><float name=\"metallic\" value=\"{}\"/>\
                 <float name=\"anisotropic\" value=\"{}\"/><float name=\"eta\" value=\"{}\"/>\
                 <float name=\"spec_tint\" value=\"{}\"/><float name=\"sheen\" value=\"{}\"/>\
                 <float name=\"sheen_tint\" value=\"{}\"/><float name=\"clearcoat\" value=\"{}\"/>\
                 <float name=\"clearcoat_gloss\" value=\"{}\"/><float name=\"spec_trans\" value=\"{}\"/>\
                 <float name=\"flatness\" value=\"{}\"/></bsdf>",
                rgb(p.base_color),
                p.roughness,
                p.metallic,
                p.anisotropic,
                p.eta,
                p.spec_tint,
                p.sheen,
                p.sheen_tint,
                p.clearcoat,
                p.clearcoat_gloss,
                p.spec_trans,
                p.flatness
            );
            // With a transmission lobe it has an inside; without, it is
            // opaque, and plsr's materials are two-sided by default.
            if p.has_transmission {
                inner
            } else {
                twosided(inner)
            }
        }
        Bsdf::PrincipledThin(p) => format!(
            "<bsdf type=\"principledthin\"><rgb name=\"base_color\" value=\"{}\"/>\
             <float name=\"roughness\" value=\"{}\"/><float name=\"anisotropic\" value=\"{}\"/>\
             <float name=\"spec_trans\" value=\"{}\"/><float name=\"eta\" value=\"{}\"/>\
             <float name=\"spec_tint\" value=\"{}\"/><float name=\"sheen\" value=\"{}\"/>\
             <float name=\"sheen_tint\" value=\"{}\"/><float name=\"flatness\" value=\"{}\"/>\
             <float name=\"diff_trans\" value=\"{}\"/></bsdf>",
            rgb(p.base_color),
            p.roughness,
            p.anisotropic,
            p.spec_trans,
            p.eta,
            p.spec_tint,
            p.sheen,
            p.sheen_tint,
            p.flatness,
            p.diff_trans
        ),
    })
}

/// The parameters `plastic` and `roughplastic` share, as Mitsuba XML.
fn plastic_params(
    diffuse: glam::Vec3,
    specular: glam::Vec3,
    (int_ior, ext_ior): (f32, f32),
    nonlinear: bool,
) -> String {
    format!(
        "<rgb name=\"diffuse_reflectance\" value=\"{}\"/>\
         <rgb name=\"specular_reflectance\" value=\"{}\"/>\
         <float name=\"int_ior\" value=\"{int_ior}\"/><float name=\"ext_ior\" value=\"{ext_ior}\"/>\
         <boolean name=\"nonlinear\" value=\"{nonlinear}\"/>",
        rgb(diffuse),
        rgb(specular)
    )
}

/// Writes `description` as Mitsuba 3 XML (`name.xml`, meshes under
/// `name-meshes/`); `environment` is the EXR of its sky, oriented as
/// Mitsuba's default (up +y, forward +z). Returns whether some light was
/// only approximated (PLS lights: a spot light for a cone narrower than
/// 60°, the emitting outline otherwise).
fn write_mitsuba(
    description: &SceneDescription,
    dir: &Path,
    name: &str,
    environment: Option<&Path>,
) -> Result<bool> {
    let unsupported = |what: String| {
        Error::invalid_argument(format!("bench peers: {name}: Mitsuba export: {what}"))
    };
    let meshes_dir = dir.join(format!("{name}-meshes"));
    std::fs::create_dir_all(&meshes_dir).map_err(io_err(&meshes_dir))?;
    let mut xml = String::from("<scene version=\"3.0.0\">\n");
    let _ = writeln!(
        xml,
        "<integrator type=\"path\"><integer name=\"max_depth\" value=\"{}\"/></integrator>",
        description.job.max_depth + 1
    );
    let Camera::Pinhole(camera) = &description.camera else {
        return Err(unsupported(format!(
            "a {} camera",
            description.camera.type_name()
        )));
    };
    if !matches!(description.film.filter, PixelFilter::Box) {
        return Err(unsupported("a pixel filter other than the box".into()));
    }
    let pose = &camera.pose;
    let target = pose.position + pose.forward;
    let _ = writeln!(
        xml,
        "<sensor type=\"perspective\"><float name=\"fov\" value=\"{}\"/>\
         <string name=\"fov_axis\" value=\"y\"/>\
         <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\" up=\"{}\"/></transform>\
         <film type=\"hdrfilm\"><integer name=\"width\" value=\"{}\"/>\
         <integer name=\"height\" value=\"{}\"/><string name=\"pixel_format\" value=\"rgb\"/>\
         <rfilter type=\"box\"/></film>\
         <sampler type=\"independent\"><integer name=\"sample_count\" value=\"{}\"/></sampler>\
         </sensor>",
        camera.vfov_deg(),
        rgb(pose.position),
        rgb(target),
        rgb(pose.up),
        camera.width,
        camera.height,
        description.job.spp
    );
    for (i, m) in description.materials.iter().enumerate() {
        let bsdf = mitsuba_bsdf(&m.bsdf).map_err(unsupported)?;
        if !m.textures.is_empty() {
            return Err(unsupported("a textured material".into()));
        }
        let _ = writeln!(
            xml,
            "{}",
            bsdf.replacen("<bsdf ", &format!("<bsdf id=\"m{i}\" "), 1)
        );
    }
    let mut approximate = false;
    for (i, mesh) in description.meshes.iter().enumerate() {
        let file = meshes_dir.join(format!("{i}.obj"));
        write_obj(&file, &mesh.positions, &mesh.triangles, &mesh.normals)?;
        let mut emitter = String::new();
        if let Some(e) = &mesh.emission {
            match &e.cone {
                Some(cone) if cone.cos_a > 60f32.to_radians().cos() => {
                    // A narrow PLS light as a spot light of its on-axis
                    // intensity L·A at the outline's centre.
                    approximate = true;
                    let (mut area, mut centre) = (0.0f32, glam::Vec3::ZERO);
                    for t in &mesh.triangles {
                        let [a, b, c] = t.map(|k| mesh.positions[k as usize]);
                        let ta = 0.5 * (b - a).cross(c - a).length();
                        area += ta;
                        centre += ta * (a + b + c) / 3.0;
                    }
                    centre /= area.max(1e-12);
                    let cutoff = cone.cos_a.clamp(-1.0, 1.0).acos().to_degrees();
                    let beam = match &cone.soft {
                        Some(_) => 0.75 * cutoff,
                        None => cutoff,
                    };
                    let _ = writeln!(
                        xml,
                        "<emitter type=\"spot\"><rgb name=\"intensity\" value=\"{}\"/>\
                         <float name=\"cutoff_angle\" value=\"{cutoff}\"/>\
                         <float name=\"beam_width\" value=\"{beam}\"/>\
                         <transform name=\"to_world\"><lookat origin=\"{}\" target=\"{}\"/></transform>\
                         </emitter>",
                        rgb(e.radiance * area),
                        rgb(centre),
                        rgb(centre + cone.axis)
                    );
                    continue;
                }
                Some(_) => approximate = true,
                None => {}
            }
            if e.two_sided {
                return Err(unsupported(format!("two-sided emission ({})", mesh.name)));
            }
            emitter = format!(
                "<emitter type=\"area\"><rgb name=\"radiance\" value=\"{}\"/></emitter>",
                rgb(e.radiance)
            );
        }
        let _ = writeln!(
            xml,
            "<shape type=\"obj\"><string name=\"filename\" value=\"{}\"/>\
             <boolean name=\"face_normals\" value=\"{}\"/><ref id=\"m{}\"/>{emitter}</shape>",
            file.display(),
            mesh.normals.is_empty(),
            mesh.material
        );
    }
    for light in &description.point_lights {
        let _ = writeln!(
            xml,
            "<emitter type=\"point\"><point name=\"position\" value=\"{}\"/>\
             <rgb name=\"intensity\" value=\"{}\"/></emitter>",
            rgb(light.position),
            rgb(light.intensity)
        );
    }
    match (&description.environment, environment) {
        (None, _) => {}
        (Some(_), Some(file)) => {
            let _ = writeln!(
                xml,
                "<emitter type=\"envmap\"><string name=\"filename\" value=\"{}\"/></emitter>",
                file.display()
            );
        }
        (Some(_), None) => return Err(unsupported("an environment without its file".into())),
    }
    xml.push_str("</scene>\n");
    write(&dir.join(format!("{name}.xml")), &xml)?;
    Ok(approximate)
}

/// The relative MSE of `image` against `reference`, cut into the parts of
/// the pixels that see each object. The relMSE is, per pixel and channel,
/// `((x − r)² − Var r) / (r² + 0.01)`, averaged: the reference's own
/// variance subtracted, so it estimates the error against the converged
/// image. Part `k` sums over the pixels whose reference object id is
/// `objects[k]`, the last part over all others (the background and
/// unlisted objects), each divided by the whole image's size, so the parts
/// add up to the relMSE.
fn rel_mse_by_object(image: &[glam::Vec3], reference: &Film, objects: &[f32]) -> Vec<f64> {
    let mut parts = vec![0.0f64; objects.len() + 1];
    let pixels = image
        .iter()
        .zip(&reference.color)
        .zip(&reference.variance)
        .zip(&reference.object_id);
    for (((x, r), v), id) in pixels {
        let part = objects
            .iter()
            .position(|o| o == id)
            .unwrap_or(objects.len());
        for c in 0..3 {
            let (x, r, v) = (x[c] as f64, r[c] as f64, v[c] as f64);
            parts[part] += ((x - r) * (x - r) - v) / (r * r + 0.01);
        }
    }
    let n = (3 * image.len()) as f64;
    parts.iter().map(|p| p / n).collect()
}

/// The objects of `film` (its object-id layer's ids but −1, the
/// background): each one's id, the name of its first mesh in `scene` and
/// its pixels, most pixels first.
fn objects_seen(film: &Film, scene: &Scene) -> Vec<(f32, String, usize)> {
    let mut counts: std::collections::BTreeMap<u32, usize> = Default::default();
    for &id in film.object_id.iter().filter(|&&id| id >= 0.0) {
        *counts.entry(id as u32).or_default() += 1;
    }
    let mut objects: Vec<(usize, f32, String)> = counts
        .into_iter()
        .map(|(id, n)| {
            let meshes: Vec<&str> = scene
                .meshes()
                .iter()
                .filter(|m| m.object_id == id)
                .map(|m| m.name.as_str())
                .collect();
            let name = match meshes[..] {
                [] => format!("object {id}"),
                // An OBJ's object without a name of its own is
                // `unnamed_object`: the shape's name says enough.
                [one] => one.trim_end_matches("/unnamed_object").to_string(),
                // The meshes of one shape (an OBJ's objects, `shape/object`)
                // share its id: the shape's name.
                [first, ..] => first.split('/').next().unwrap_or(first).to_string(),
            };
            (n, id as f32, name)
        })
        .collect();
    objects.sort_by_key(|o| std::cmp::Reverse(o.0));
    objects
        .into_iter()
        .map(|(n, id, name)| (id, name, n))
        .collect()
}

/// The mean of `rel_mse_by_object` over `images`.
fn mean_rel_mse_by_object(
    images: &[Vec<glam::Vec3>],
    reference: &Film,
    objects: &[f32],
) -> Vec<f64> {
    let mut sum = vec![0.0f64; objects.len() + 1];
    for image in images {
        for (s, p) in sum
            .iter_mut()
            .zip(rel_mse_by_object(image, reference, objects))
        {
            *s += p;
        }
    }
    sum.iter().map(|s| s / images.len().max(1) as f64).collect()
}

/// The relMSE of `image` against `reference` (see [`rel_mse_by_object`]).
pub(super) fn rel_mse(image: &[glam::Vec3], reference: &Film) -> f64 {
    rel_mse_by_object(image, reference, &[]).iter().sum()
}

pub(super) fn mean(image: &[glam::Vec3]) -> f64 {
    image.iter().map(|c| (c.x + c.y + c.z) as f64).sum::<f64>() / (3 * image.len()) as f64
}

/// The converged reference of `scene`: plsr at `spp`, as the mean of two
/// renders of `spp/2` with different seeds, its `variance` layer the
/// estimate `(a − b)²/4` of the mean's own error (unbiased, as the halves
/// are independent; one render's layer overestimates it for stratified
/// samples); cached in `dir` under a key of the scene file's text and `spp`.
fn reference(
    scene: &PeerScene,
    built: &Scene,
    description: &SceneDescription,
    spp: u32,
    options: &RenderOptions,
    dir: &Path,
) -> Result<Film> {
    let text = std::fs::read_to_string(&scene.plsr).map_err(io_err(&scene.plsr))?;
    let key = format!("{spp} halves {:016x}", fnv1a(text.as_bytes()));
    let exr = dir.join(format!("{}.reference.exr", scene.name));
    let key_file = dir.join(format!("{}.reference.key", scene.name));
    if exr.is_file() && std::fs::read_to_string(&key_file).ok().as_deref() == Some(key.as_str()) {
        println!("  reference: reusing {}", exr.display());
        return Ok(Film::read_exr(&exr)?);
    }
    let mut job = description.job;
    job.spp = spp.div_ceil(2);
    job.seed = 0x5EED_F2EF;
    println!("  reference: plsr at {spp} spp (two halves) …");
    let (mut film, first) = render(built, &job, options, &|_, _| true)?;
    job.seed ^= 0x9E37_79B9;
    let (other, second) = render(built, &job, options, &|_, _| true)?;
    for ((a, v), b) in film
        .color
        .iter_mut()
        .zip(&mut film.variance)
        .zip(&other.color)
    {
        let d = *a - *b;
        *v = d * d * 0.25;
        *a = (*a + *b) * 0.5;
    }
    film.spp = 2 * job.spp;
    println!("  reference: {:.1} s", first.seconds + second.seconds);
    film.write_exr(&exr)?;
    write(&key_file, &key)?;
    Ok(film)
}

/// FNV-1a, 64 bits: the cache key of a reference.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0100_0000_01b3)
    })
}

/// What one renderer measured on one scene.
struct Measured {
    seconds: f64,
    samples: u64,
    /// The relative MSE, the mean over the renders (different seeds).
    rel_mse: f64,
    /// `rel_mse` cut into the parts of each object's pixels (the objects of
    /// [`objects_seen`], then the rest), each the mean over the renders.
    rel_mse_parts: Vec<f64>,
    mean: f64,
    /// Closest-hit rate for incoherent random rays over the scene's
    /// geometry, Mrays/s: plsr's Embree (and 0), or Mitsuba's hit-only
    /// query and its query with the surface interaction.
    raw_mrays: Option<(f64, f64)>,
    /// plsr's best times (s) before and after Mitsuba's renders of the
    /// scene, whose mean is `seconds`; `None` for Mitsuba, or for plsr
    /// when Mitsuba did not run.
    bracket: Option<(f64, f64)>,
}

/// Random rays of the raw tracing measurement.
const RAW_RAYS: usize = 2_000_000;

impl Measured {
    fn msamples_per_s(&self) -> f64 {
        self.samples as f64 / self.seconds / 1e6
    }
}

/// Reads Mitsuba's raw float32 RGB images: one or more `width × height`
/// frames, one after the other.
pub(super) fn read_raw(path: &Path, width: u32, height: u32) -> Result<Vec<Vec<glam::Vec3>>> {
    let bytes = std::fs::read(path).map_err(io_err(path))?;
    let frame = (width * height) as usize * 12;
    if bytes.is_empty() || bytes.len() % frame != 0 {
        return Err(Error::invalid_argument(format!(
            "{}: {} bytes, expected whole frames of {}×{}×3 floats",
            path.display(),
            bytes.len(),
            width,
            height
        )));
    }
    Ok(bytes
        .chunks_exact(frame)
        .map(|image| {
            image
                .chunks_exact(12)
                .map(|c| {
                    let f = |i: usize| f32::from_le_bytes([c[i], c[i + 1], c[i + 2], c[i + 3]]);
                    glam::Vec3::new(f(0), f(4), f(8))
                })
                .collect()
        })
        .collect())
}

/// Runs Mitsuba 3 on one scene (`scripts/bench_peers_mitsuba.py`, in its
/// own Python process) and scores its renders against `reference`:
/// what it measured, and its version and variant.
#[allow(clippy::too_many_arguments)]
fn run_mitsuba(
    python: &Path,
    threads: usize,
    scene: &PeerScene,
    spp: u32,
    seeds: u32,
    dir: &Path,
    (w, h): (u32, u32),
    reference: &Film,
    ids: &[f32],
) -> std::result::Result<(Measured, String), String> {
    let image = dir.join(format!("{}.mitsuba.f32", scene.name));
    let jobs = serde_json::json!({
        "threads": threads,
        "scenes": [{
            "name": scene.name,
            "xml": scene.mitsuba,
            "spp": spp,
            "image": image,
            "raw_rays": RAW_RAYS,
        }],
    });
    let jobs_file = dir.join("mitsuba-jobs.json");
    write(&jobs_file, &jobs.to_string()).map_err(|e| e.to_string())?;
    let mut cmd = std::process::Command::new(python);
    cmd.arg("scripts/bench_peers_mitsuba.py")
        .arg(&jobs_file)
        .arg("--repeats")
        .arg(seeds.to_string());
    let (v, _) = python_json(&mut cmd, python)?;
    let version = format!(
        "Mitsuba {} {}",
        v["mitsuba_version"].as_str().unwrap_or("?"),
        v["variant"].as_str().unwrap_or("?")
    );
    let r = v["scenes"]
        .as_array()
        .and_then(|a| a.iter().find(|r| r["name"] == scene.name))
        .ok_or_else(|| format!("no result for {}", scene.name))?;
    let seconds = r["seconds"].as_f64().ok_or("no seconds")?;
    let images = read_raw(&image, w, h).map_err(|e| e.to_string())?;
    let rel_mse_parts = mean_rel_mse_by_object(&images, reference, ids);
    let measured = Measured {
        seconds,
        samples: w as u64 * h as u64 * spp as u64,
        rel_mse: rel_mse_parts.iter().sum(),
        rel_mse_parts,
        mean: images.iter().map(|i| mean(i)).sum::<f64>() / images.len() as f64,
        raw_mrays: r["raw_mrays_preliminary"]
            .as_f64()
            .zip(r["raw_mrays"].as_f64()),
        bracket: None,
    };
    Ok((measured, version))
}

/// Mitsuba's material-preview scene (`matpreview.xml` of its documentation
/// scenes, 384×288) with a rough plastic object on a stand in a principled
/// material with a checkerboard base colour, written into `dir`; its meshes
/// and environment are read from `tests/data/realworld/mitsuba/`.
fn write_matpreview(dir: &Path) -> Result<PathBuf> {
    let data = Path::new("tests/data/realworld/mitsuba/common");
    let common = data.canonicalize().map_err(|e| {
        Error::invalid_argument(format!(
            "bench peers: matpreview needs {} (run from plsr's source folder): {e}",
            data.display()
        ))
    })?;
    let xml = format!(
        r#"<scene version="3.0.0">
    <path value="{common}"/>
    <default name="spp" value="64"/>
    <integrator type="path"/>
    <bsdf type="roughplastic" id="object_bsdf">
        <string name="distribution" value="ggx"/>
        <float name="alpha" value="0.15"/>
        <rgb name="diffuse_reflectance" value="0.55, 0.12, 0.08"/>
        <float name="int_ior" value="1.5"/>
    </bsdf>
    <bsdf type="principled" id="stand_bsdf">
        <texture type="checkerboard" name="base_color">
            <rgb name="color0" value="0.8, 0.7, 0.3"/>
            <rgb name="color1" value="0.1, 0.1, 0.15"/>
            <transform name="to_uv"><scale x="6" y="6"/></transform>
        </texture>
        <float name="metallic" value="0.3"/>
        <float name="roughness" value="0.35"/>
    </bsdf>
    <texture type="checkerboard" id="planetex">
        <rgb name="color0" value="0.2"/>
        <rgb name="color1" value="0.4"/>
        <transform name="to_uv"><scale x="8" y="8"/></transform>
    </texture>
    <bsdf type="diffuse" id="planemat"><ref name="reflectance" id="planetex"/></bsdf>
    <shape type="serialized">
        <string name="filename" value="meshes/matpreview.serialized"/>
        <integer name="shape_index" value="2"/>
        <transform name="to_world">
            <matrix value="0.614046 0.614047 0 -1.78814e-07 -0.614047 0.614046 0 2.08616e-07 0 0 0.868393 1.02569 0 0 0 1"/>
            <translate z="0.01"/>
        </transform>
        <ref id="object_bsdf"/>
    </shape>
    <shape type="serialized">
        <string name="filename" value="meshes/matpreview.serialized"/>
        <integer name="shape_index" value="1"/>
        <transform name="to_world"><translate z="0.0252155"/></transform>
        <ref id="stand_bsdf"/>
    </shape>
    <shape type="serialized">
        <string name="filename" value="meshes/matpreview.serialized"/>
        <integer name="shape_index" value="0"/>
        <transform name="to_world">
            <rotate z="1" angle="-4.3"/>
            <matrix value="3.38818 -4.06354 0 -1.74958 4.06354 3.38818 0 1.43683 0 0 5.29076 -0.0120714 0 0 0 1"/>
        </transform>
        <ref id="planemat"/>
    </shape>
    <sensor type="perspective">
        <string name="fov_axis" value="smaller"/>
        <float name="fov" value="28.8415"/>
        <transform name="to_world">
            <lookat target="3.04072, -2.85176, 2.80939" origin="3.69558, -3.46243, 3.25463" up="-0.317366, 0.312466, 0.895346"/>
        </transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="384"/>
            <integer name="height" value="288"/>
            <rfilter type="gaussian"/>
        </film>
    </sensor>
    <emitter type="envmap">
        <string name="filename" value="textures/museum.exr"/>
        <transform name="to_world">
            <rotate y="1" angle="-180"/>
            <matrix value="-0.224951 -0.000001 -0.974370 0.000000 -0.974370 0.000000 0.224951 0.000000 0.000000 1.000000 -0.000001 8.870000 0.000000 0.000000 0.000000 1.000000"/>
        </transform>
        <float name="scale" value="3"/>
    </emitter>
</scene>
"#,
        common = common.display()
    );
    let path = dir.join("matpreview.xml");
    write(&path, &xml)?;
    Ok(path)
}

/// `plsr bench peers`.
pub fn run(o: &PeersBenchOptions) -> Result<()> {
    let dir = &o.dir;
    // Timed renders per renderer and scene (the command line asks for 1 to 64).
    let seeds = o.seeds.max(1);
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let dir = dir.canonicalize().map_err(io_err(dir))?;
    let mut scenes = suite(o, &dir)?;
    let bench = Bench {
        o,
        dir: &dir,
        seeds,
        options: RenderOptions {
            threads: o.threads,
            ..Default::default()
        },
        threads: o.threads.unwrap_or_else(|| {
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1)
        }),
    };
    let threads = bench.threads;
    // Each scene: plsr, then Mitsuba, then plsr's timing again, so that
    // Mitsuba's time is bracketed by plsr's and the machine's drift in speed
    // (±20 % within an hour on shared machines) cancels to first order.
    let mut plsr_results = Vec::new();
    let mut prepared = Vec::new();
    let mut runs = MitsubaRuns::default();
    let mut denoised = DenoisedRuns::default();
    for scene in &mut scenes {
        let (measured, p) = bench.measure(scene, &mut runs, &mut denoised)?;
        prepared.push(p);
        plsr_results.push(measured);
    }
    let mitsuba: Option<std::result::Result<(Vec<Measured>, String), String>> =
        o.python.as_ref().map(|_| match runs.failure {
            Some(why) => Err(why),
            None => Ok((runs.results, runs.version)),
        });

    println!(
        "\nplsr bench peers: {} spp, {} seeds each, reference {} spp, {threads} threads\n",
        o.spp, seeds, o.reference_spp
    );
    match &mitsuba {
        Some(Ok((m, version))) => {
            print_comparison(&scenes, &plsr_results, m, version);
            print_error_parts(&scenes, &plsr_results, m, &prepared, seeds);
            print_raw_tracing(&scenes, &plsr_results, m);
        }
        other => print_plsr_only(&scenes, &plsr_results, other),
    }
    if o.blender_python.is_some() {
        match &denoised.failure {
            None => super::peers_denoised::print(&denoised.rows, threads),
            Some(why) => println!(
                "\nCycles: not measured ({why}); install it with `python3.11 -m venv VENV && VENV/bin/pip install 'bpy==4.5.*'` and pass --blender-python VENV/bin/python"
            ),
        }
    }
    println!("\nscenes, references and images: {}", dir.display());
    Ok(())
}

/// The scenes `o.only` asks for (the glossy one written into `dir`).
fn suite(o: &PeersBenchOptions, dir: &Path) -> Result<Vec<PeerScene>> {
    let wanted = |name: &str| o.only.is_empty() || o.only.iter().any(|n| n == name);
    let mut scenes = Vec::new();
    if wanted("glossy-env") {
        scenes.push(PeerScene {
            name: "glossy-env",
            plsr: write_glossy_env(dir, o.spp)?,
            mitsuba: dir.join("glossy-env.xml"),
            approximate: false,
        });
    }
    for (name, file) in [
        ("cornell", "assets/scenes/cornell/cornell.toml"),
        ("pls-room", "assets/scenes/pls-room/pls-room.toml"),
    ] {
        if wanted(name) {
            scenes.push(PeerScene {
                name,
                plsr: PathBuf::from(file),
                mitsuba: dir.join(format!("{name}.xml")),
                approximate: false,
            });
        }
    }
    if wanted("matpreview") {
        let xml = write_matpreview(dir)?;
        scenes.push(PeerScene {
            name: "matpreview",
            plsr: xml.clone(),
            mitsuba: xml,
            approximate: false,
        });
    }
    if scenes.is_empty() {
        return Err(Error::invalid_argument(format!(
            "bench peers: no scene named {:?} (known: glossy-env, cornell, pls-room, matpreview)",
            o.only
        )));
    }
    Ok(scenes)
}

/// What a scene keeps for the tables: its size, its reference and the
/// objects it sees.
type Prepared = (u32, u32, Film, Vec<(f32, String, usize)>);

/// Mitsuba's measurements so far: one per scene, its version, or why it
/// could not run (then it is not tried again).
#[derive(Default)]
struct MitsubaRuns {
    results: Vec<Measured>,
    failure: Option<String>,
    version: String,
}

/// The denoised comparison's rows so far, or why Cycles could not run.
#[derive(Default)]
struct DenoisedRuns {
    rows: Vec<super::peers_denoised::Row>,
    failure: Option<String>,
}

/// What every scene of a run shares.
struct Bench<'a> {
    o: &'a PeersBenchOptions,
    /// The work folder (absolute).
    dir: &'a Path,
    /// Timed renders per renderer and scene.
    seeds: u32,
    /// plsr's render options.
    options: RenderOptions,
    /// Worker threads of both renderers.
    threads: usize,
}

impl Bench<'_> {
    /// One scene: plsr's timed renders and scores, then (unless it failed
    /// before) Mitsuba's, then plsr's timing again.
    fn measure(
        &self,
        scene: &mut PeerScene,
        mitsuba: &mut MitsubaRuns,
        denoised: &mut DenoisedRuns,
    ) -> Result<(Measured, Prepared)> {
        let o = self.o;
        println!("{}:", scene.name);
        let (description, built) = self.load(scene)?;
        let reference = reference(
            scene,
            &built,
            &description,
            o.reference_spp,
            &self.options,
            self.dir,
        )?;
        let mut images = Vec::new();
        let (before, size) = self.time_plsr(&built, &description, &mut images)?;
        let samples = size.0 as u64 * size.1 as u64 * o.spp as u64;
        let objects = objects_seen(&reference, &built);
        let ids: Vec<f32> = objects.iter().map(|o| o.0).collect();
        let rel_mse_parts = mean_rel_mse_by_object(&images, &reference, &ids);
        let (single, stream, batched) =
            super::core::random_ray_throughput(&built, RAW_RAYS, o.threads)?;
        let best_raw = single.max(stream).max(batched);
        let mut measured = Measured {
            seconds: before,
            samples,
            rel_mse: rel_mse_parts.iter().sum(),
            rel_mse_parts,
            mean: images.iter().map(|i| mean(i)).sum::<f64>() / images.len() as f64,
            raw_mrays: Some((best_raw, 0.0)),
            bracket: None,
        };
        println!(
            "  plsr: {:.3} s (best of {} renders), {:.3} Msamples/s, relMSE {:.5}; \
             random rays {:.2} Mrays/s",
            measured.seconds,
            images.len(),
            measured.msamples_per_s(),
            measured.rel_mse,
            best_raw
        );
        if let (Some(python), None) = (&o.python, &mitsuba.failure) {
            println!("  Mitsuba 3 …");
            match run_mitsuba(
                python,
                self.threads,
                scene,
                o.spp,
                self.seeds,
                self.dir,
                size,
                &reference,
                &ids,
            ) {
                Ok((m, v)) => {
                    println!(
                        "  Mitsuba: {:.3} s, {:.3} Msamples/s, relMSE {:.5}",
                        m.seconds,
                        m.msamples_per_s(),
                        m.rel_mse
                    );
                    mitsuba.version = v;
                    mitsuba.results.push(m);
                    // plsr's time: the mean of its best before and after.
                    let (after, _) = self.time_plsr(&built, &description, &mut images)?;
                    measured.seconds = 0.5 * (before + after);
                    measured.bracket = Some((before, after));
                    println!(
                        "  plsr after Mitsuba: {after:.3} s ({:.3} Msamples/s; {:.3} before)",
                        samples as f64 / after / 1e6,
                        samples as f64 / before / 1e6
                    );
                }
                Err(why) => mitsuba.failure = Some(why),
            }
        }
        // The denoised comparison, on the scenes Cycles reads as plsr does.
        let for_cycles = matches!(scene.name, "cornell" | "glossy-env");
        if let (Some(python), None, true) = (&o.blender_python, &denoised.failure, for_cycles) {
            match super::peers_denoised::measure(
                python,
                self.threads,
                self.seeds,
                self.dir,
                scene,
                &built,
                &description,
                &self.options,
                &reference,
            ) {
                Ok(row) => denoised.rows.push(row),
                Err(why) => denoised.failure = Some(why),
            }
        }
        Ok((measured, (size.0, size.1, reference, objects)))
    }

    /// The scene's description at the benchmark's resolution and spp, its
    /// Mitsuba twin written (marking whether its lights only approximate
    /// plsr's), and the scene built.
    fn load(&self, scene: &mut PeerScene) -> Result<(SceneDescription, Scene)> {
        let mut description = plsr::scene::file::load(&scene.plsr)?;
        if scene.plsr == scene.mitsuba {
            // A Mitsuba scene both renderers read as it is.
            description.job.spp = self.o.spp;
            let built = Scene::build(description.clone())?;
            return Ok((description, built));
        }
        if scene.name != "glossy-env" {
            // The scene files' own resolutions are for viewing; these are
            // the benchmark's.
            let (w, h) = if scene.name == "cornell" {
                (512, 512)
            } else {
                (640, 480)
            };
            description.camera = description
                .camera
                .with_resolution(w, h)
                .map_err(|e| Error::invalid_argument(e.to_string()))?;
        }
        description.job.spp = self.o.spp;
        let environment = (scene.name == "glossy-env").then(|| self.dir.join("sky.exr"));
        scene.approximate =
            write_mitsuba(&description, self.dir, scene.name, environment.as_deref())?;
        let built = Scene::build(description.clone())?;
        Ok((description, built))
    }

    /// The timed renders: the best of `seeds` (seeds 1, 2, …), their
    /// images in `images`; the best time and the image size.
    fn time_plsr(
        &self,
        built: &Scene,
        description: &SceneDescription,
        images: &mut Vec<Vec<glam::Vec3>>,
    ) -> Result<(f64, (u32, u32))> {
        let mut seconds = f64::INFINITY;
        let mut size = (0, 0);
        images.clear();
        for seed in 1..=u64::from(self.seeds) {
            let mut job = description.job;
            job.seed = seed;
            let (film, stats) = render(built, &job, &self.options, &|_, _| true)?;
            seconds = seconds.min(stats.seconds);
            size = (film.width, film.height);
            images.push(film.color);
        }
        Ok((seconds, size))
    }
}

/// The table of both renderers' speed and error, and what it means.
fn print_comparison(
    scenes: &[PeerScene],
    plsr_results: &[Measured],
    m: &[Measured],
    version: &str,
) {
    println!("| scene | plsr Msamples/s (before / after Mitsuba) | {version} Msamples/s | speed ratio | plsr relMSE | Mitsuba relMSE | time to equal error, plsr ÷ Mitsuba speed | mean ratio |");
    println!("| --- | --- | --- | --- | --- | --- | --- | --- |");
    for ((scene, p), m) in scenes.iter().zip(plsr_results).zip(m) {
        let equal_error = (m.seconds * m.rel_mse) / (p.seconds * p.rel_mse);
        let bracket = p.bracket.map_or_else(String::new, |(before, after)| {
            let rate = |s: f64| p.samples as f64 / s / 1e6;
            format!(" ({:.3} / {:.3})", rate(before), rate(after))
        });
        println!(
            "| {}{} | {:.3}{bracket} | {:.3} | {:.2}× | {:.5} | {:.5} | {:.2}× | {:.4} |",
            scene.name,
            if scene.approximate {
                " (Mitsuba's lights approximate)"
            } else {
                ""
            },
            p.msamples_per_s(),
            m.msamples_per_s(),
            p.msamples_per_s() / m.msamples_per_s(),
            p.rel_mse,
            m.rel_mse,
            equal_error,
            p.mean / m.mean
        );
    }
    println!(
        "\nplsr's time is the mean of its best before and its best after Mitsuba's \
         renders of the scene (shown in brackets), so that the machine's drift in \
         speed cancels to first order. speed ratio: plsr's samples/s over Mitsuba's; time to equal error: \
         Mitsuba's time × relMSE over plsr's (> 1: plsr reaches the same error sooner); \
         mean ratio: plsr's image mean over Mitsuba's."
    );
}

/// The table of each renderer's relMSE cut by the objects the pixels see.
fn print_error_parts(
    scenes: &[PeerScene],
    plsr_results: &[Measured],
    m: &[Measured],
    prepared: &[Prepared],
    seeds: u32,
) {
    println!(
        "\nWhere the error is: each renderer's relMSE cut into the parts of the pixels \
         that see each object (they add up to it; \"rest\": the background and light \
         fixtures); plsr's and Mitsuba's each the mean over {} renders with \
         different seeds, as are the relMSEs above.\n",
        seeds
    );
    println!("| scene | object | pixels | plsr | Mitsuba | plsr ÷ Mitsuba |");
    println!("| --- | --- | --- | --- | --- | --- |");
    for (((scene, p), m), (_, _, _, objects)) in
        scenes.iter().zip(plsr_results).zip(m).zip(prepared)
    {
        let names = objects
            .iter()
            .map(|(_, name, n)| (name.as_str(), Some(*n)))
            .chain([("rest", None)]);
        for ((name, pixels), (a, b)) in names.zip(p.rel_mse_parts.iter().zip(&m.rel_mse_parts)) {
            let ratio = if *b > 0.0 {
                format!("{:.2}", a / b)
            } else {
                "—".to_string()
            };
            println!(
                "| {} | {name} | {} | {a:.5} | {b:.5} | {ratio} |",
                scene.name,
                pixels.map_or_else(|| "".to_string(), |n| n.to_string()),
            );
        }
    }
}

/// The table of both renderers' raw tracing rates.
fn print_raw_tracing(scenes: &[PeerScene], plsr_results: &[Measured], m: &[Measured]) {
    println!(
        "\nRaw tracing, {RAW_RAYS} incoherent random rays over each scene's geometry \
         (origins uniform in its bounds, directions uniform), closest hit, Mrays/s:\n"
    );
    println!("| scene | plsr (Embree, best of rtcIntersect1/1M/Np) | Mitsuba ray_intersect_preliminary (rtcIntersect16 packets) | Mitsuba ray_intersect | plsr ÷ Mitsuba preliminary |");
    println!("| --- | --- | --- | --- | --- |");
    for ((scene, p), m) in scenes.iter().zip(plsr_results).zip(m) {
        if let (Some((plsr_rate, _)), Some((hit, full))) = (p.raw_mrays, m.raw_mrays) {
            println!(
                "| {} | {plsr_rate:.2} | {hit:.2} | {full:.2} | {:.2}× |",
                scene.name,
                plsr_rate / hit
            );
        }
    }
}

/// plsr's table alone, and why Mitsuba is missing.
fn print_plsr_only(
    scenes: &[PeerScene],
    plsr_results: &[Measured],
    other: &Option<std::result::Result<(Vec<Measured>, String), String>>,
) {
    println!("| scene | plsr Msamples/s | plsr relMSE |");
    println!("| --- | --- | --- |");
    for (scene, p) in scenes.iter().zip(plsr_results) {
        println!(
            "| {} | {:.3} | {:.5} |",
            scene.name,
            p.msamples_per_s(),
            p.rel_mse
        );
    }
    match other {
        Some(Err(why)) => println!(
            "\nMitsuba 3: not measured ({why}); install it with `pip install mitsuba` and Debian's libllvm19"
        ),
        _ => println!("\nMitsuba 3: skipped (--no-peer)"),
    }
}
