//! Scenes through the C ABI: loaded from a scene file, or built in code.

use super::{
    boundary, free_handle, handle_mut, handle_ref, new_handle, path_arg, plsr_result, slice_arg,
    str_arg, vec3_arg, write_out, FfiError,
};
use glam::Vec3;
use plsr::bsdf::{Bsdf, PrincipledParams};
use plsr::camera::PinholeCamera;
use plsr::job::RenderJob;
use plsr::lens_distortion::LensDistortion;
use plsr::light::{EnvironmentLight, PointLight};
use plsr::material::Material;
use plsr::scene::{Emission, Mesh, Scene, SceneDescription};
use std::ffi::c_char;

/// A scene ready to render (opaque). Immutable: may be rendered from several
/// threads at once.
#[allow(non_camel_case_types)]
pub struct plsr_scene {
    pub(crate) scene: Scene,
}

/// A scene under construction (opaque); one thread at a time.
#[allow(non_camel_case_types)]
pub struct plsr_scene_builder {
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    point_lights: Vec<PointLight>,
    environment: Option<EnvironmentLight>,
    camera: Option<plsr::camera::Camera>,
    job: RenderJob,
}

/// Parameters of a principled material (Mitsuba 3's names; all in [0, 1]
/// except `base_color`, linear RGB in [0, 1]).
#[repr(C)]
#[derive(Debug, Clone, Copy)]
#[allow(non_camel_case_types)]
pub struct plsr_principled {
    /// Base colour, linear RGB.
    pub base_color: [f32; 3],
    /// Roughness (α = roughness²).
    pub roughness: f32,
    /// 0 dielectric, 1 metal.
    pub metallic: f32,
    /// Anisotropy along the surface's first tangent.
    pub anisotropic: f32,
    /// Dielectric specular; 0.5 is η = 1.5.
    pub specular: f32,
    /// How much the dielectric specular takes the base colour's hue.
    pub spec_tint: f32,
    /// `false` (0 in an aggregate initialiser that leaves it out): Mitsuba
    /// 3's diffuse lobe, which may reflect more than it receives; `true`:
    /// the diffuse lobe coupled to the specular one, which reflects at most
    /// what it receives (anisotropic lobes up to 2.5 % more near grazing
    /// incidence). Added in 0.2.0.
    pub energy_conserving: bool,
}

/// Loads a scene file (TOML, or JSON by extension) into `*out`.
///
/// `path` is UTF-8; relative paths inside the file resolve against its
/// folder. Errors name the file, the field and the fault
/// (`PLSR_ERR_INPUT`). Free the scene with `plsr_scene_free`.
#[no_mangle]
pub extern "C" fn plsr_scene_load(path: *const c_char, out: *mut *mut plsr_scene) -> plsr_result {
    boundary(|| {
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        let path = path_arg(path, "path")?;
        let scene = Scene::load(&path)?;
        write_out(out, new_handle(plsr_scene { scene }), "out")
    })
}

/// Releases a scene; `NULL` is a no-op.
#[no_mangle]
pub extern "C" fn plsr_scene_free(scene: *mut plsr_scene) -> plsr_result {
    boundary(|| free_handle(scene, "scene"))
}

/// Image size of a scene's camera, in pixels.
#[no_mangle]
pub extern "C" fn plsr_scene_resolution(
    scene: *const plsr_scene,
    width: *mut u32,
    height: *mut u32,
) -> plsr_result {
    boundary(|| {
        let s = handle_ref(scene, "scene")?;
        if width.is_null() || height.is_null() {
            return Err(FfiError::null(if width.is_null() {
                "width"
            } else {
                "height"
            }));
        }
        write_out(width, s.scene.camera().width(), "width")?;
        write_out(height, s.scene.camera().height(), "height")
    })
}

/// Starts building a scene in code into `*out`: no meshes, no lights, no
/// camera yet, render settings 16 spp, max depth 8, seed 0.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_new(out: *mut *mut plsr_scene_builder) -> plsr_result {
    boundary(|| {
        let b = plsr_scene_builder {
            meshes: Vec::new(),
            materials: Vec::new(),
            point_lights: Vec::new(),
            environment: None,
            camera: None,
            job: RenderJob::default(),
        };
        write_out(out, new_handle(b), "out")
    })
}

/// Releases a builder; `NULL` is a no-op.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_free(builder: *mut plsr_scene_builder) -> plsr_result {
    boundary(|| free_handle(builder, "builder"))
}

fn colour_arg(p: *const f32, name: &str, max: Option<f32>) -> Result<Vec3, FfiError> {
    let c = vec3_arg(p, name)?;
    if c.min_element() < 0.0 || max.is_some_and(|m| c.max_element() > m) {
        return Err(FfiError::invalid(format!(
            "`{name}` = {c} must be in [0, {}]",
            max.map_or("∞".to_string(), |m| m.to_string())
        )));
    }
    Ok(c)
}

fn push_material(
    b: &mut plsr_scene_builder,
    name: &str,
    bsdf: Bsdf,
    out_index: *mut u32,
) -> Result<(), FfiError> {
    if b.materials.iter().any(|m| m.name == name) {
        return Err(FfiError::invalid(format!(
            "duplicate material name `{name}`"
        )));
    }
    let index = b.materials.len() as u32;
    if !out_index.is_null() {
        write_out(out_index, index, "out_index")?;
    }
    b.materials.push(Material::new(name, bsdf));
    Ok(())
}

/// Adds a Lambertian material of albedo `reflectance` (linear RGB, each in
/// [0, 1]); its index is written to `*out_index` (may be `NULL`).
#[no_mangle]
pub extern "C" fn plsr_scene_builder_add_diffuse(
    builder: *mut plsr_scene_builder,
    name: *const c_char,
    reflectance: *const f32,
    out_index: *mut u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let name = str_arg(name, "name")?;
        let r = colour_arg(reflectance, "reflectance", Some(1.0))?;
        push_material(b, name, Bsdf::diffuse(r), out_index)
    })
}

/// Adds a principled material; its index is written to `*out_index` (may be
/// `NULL`).
#[no_mangle]
pub extern "C" fn plsr_scene_builder_add_principled(
    builder: *mut plsr_scene_builder,
    name: *const c_char,
    params: *const plsr_principled,
    out_index: *mut u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let name = str_arg(name, "name")?;
        let p = slice_arg(params, 1, "params")?[0];
        let base = colour_arg(p.base_color.as_ptr(), "params.base_color", Some(1.0))?;
        let params = PrincipledParams {
            base_color: base,
            roughness: p.roughness,
            metallic: p.metallic,
            anisotropic: p.anisotropic,
            specular: p.specular,
            spec_tint: p.spec_tint,
            energy_conserving: p.energy_conserving,
        }
        .validate()
        .map_err(|e| {
            FfiError::invalid(format!(
                "`params.{}` = {} must be in {}",
                e.parameter, e.value, e.range
            ))
        })?;
        let bsdf = Bsdf::Principled(params);
        push_material(b, name, bsdf, out_index)
    })
}

/// Adds a triangle mesh: `vertex_count` positions (`3·vertex_count` floats,
/// x y z each), `triangle_count` triangles (`3·triangle_count` vertex
/// indices, counter-clockwise seen from the front), the index of a material
/// added before, and an emitted radiance (`const float[3]`, W/(m²·sr)) or
/// `NULL` for none. Its object id (the EXR mask) is its index among the
/// meshes added, written to `*out_object_id` (may be `NULL`).
#[no_mangle]
pub extern "C" fn plsr_scene_builder_add_mesh(
    builder: *mut plsr_scene_builder,
    positions: *const f32,
    vertex_count: usize,
    indices: *const u32,
    triangle_count: usize,
    material: u32,
    emission: *const f32,
    out_object_id: *mut u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let floats = vertex_count
            .checked_mul(3)
            .ok_or_else(|| FfiError::invalid("vertex_count overflows"))?;
        let ints = triangle_count
            .checked_mul(3)
            .ok_or_else(|| FfiError::invalid("triangle_count overflows"))?;
        let p = slice_arg(positions, floats, "positions")?;
        let t = slice_arg(indices, ints, "indices")?;
        if material as usize >= b.materials.len() {
            return Err(FfiError::invalid(format!(
                "material {material} does not exist ({} added)",
                b.materials.len()
            )));
        }
        let positions: Vec<Vec3> = p
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let triangles: Vec<[u32; 3]> = t.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let id = b.meshes.len() as u32;
        let mut mesh = Mesh::new(format!("mesh {id}"), positions, triangles, material, id)
            .map_err(|e| FfiError::invalid(e.to_string()))?;
        let emission = if emission.is_null() {
            None
        } else {
            Some(Emission {
                radiance: colour_arg(emission, "emission", None)?,
                two_sided: false,
                cone: None,
            })
        };
        mesh.emission = emission;
        if !out_object_id.is_null() {
            write_out(out_object_id, id, "out_object_id")?;
        }
        b.meshes.push(mesh);
        Ok(())
    })
}

/// Adds an isotropic point light at `position` of radiant intensity
/// `intensity` (W/sr, linear RGB).
#[no_mangle]
pub extern "C" fn plsr_scene_builder_add_point_light(
    builder: *mut plsr_scene_builder,
    position: *const f32,
    intensity: *const f32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let position = vec3_arg(position, "position")?;
        let intensity = colour_arg(intensity, "intensity", None)?;
        b.point_lights
            .push(PointLight::isotropic(position, intensity));
        Ok(())
    })
}

/// Adds a parametric light source (see `plsr_pls_params`), tessellated into
/// `nf` quads (0: the default, 32; at most 4096), as a black emitter that emits into its
/// cone. Invalid parameters give `PLSR_ERR_INVALID_ARGUMENT` naming them.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_add_pls(
    builder: *mut plsr_scene_builder,
    params: *const super::plsr_pls_params,
    nf: u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let p = slice_arg(params, 1, "params")?[0];
        let (light, mode) = super::pls::pls_from_params(&p)?;
        let black = match b.materials.iter().position(|m| m.name == "(pls)") {
            Some(i) => i as u32,
            None => {
                b.materials
                    .push(Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)));
                (b.materials.len() - 1) as u32
            }
        };
        // 0 asks for the default; anything else must be in range.
        let nf = if nf == 0 {
            plsr::light::pls::DEFAULT_NF
        } else {
            plsr::light::pls::check_nf(nf as u64)
                .map_err(|m| FfiError::invalid(format!("`nf` {m}")))?
        };
        let name = format!("pls {}", b.meshes.len());
        b.meshes
            .push(plsr::scene::pls_mesh(&light, mode, nf, black, name));
        Ok(())
    })
}

/// Lights the scene with an equirectangular HDR panorama (`.exr` or `.hdr`,
/// linear RGB) at infinity: `up` is the world direction of its top row,
/// `forward` of its centre column, `scale` multiplies its radiance.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_set_environment(
    builder: *mut plsr_scene_builder,
    path: *const c_char,
    up: *const f32,
    forward: *const f32,
    scale: f32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let path = path_arg(path, "path")?;
        let up = vec3_arg(up, "up")?;
        let forward = vec3_arg(forward, "forward")?;
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(FfiError::invalid(format!(
                "`scale` = {scale} must be finite and ≥ 0"
            )));
        }
        let frame = plsr::equirect::SphereFrame::new(up, forward)
            .ok_or_else(|| FfiError::invalid("`forward` is zero or parallel to `up`"))?;
        let env = plsr::scene::file::load_environment(&path, frame, scale)?;
        b.environment = Some(env);
        Ok(())
    })
}

/// Sets a pinhole camera at `position` looking at `look_at` with image-up
/// `up`, vertical field of view `vfov_deg` degrees and `width × height`
/// pixels.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_set_camera(
    builder: *mut plsr_scene_builder,
    position: *const f32,
    look_at: *const f32,
    up: *const f32,
    vfov_deg: f32,
    width: u32,
    height: u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let camera = PinholeCamera::look_at(
            vec3_arg(position, "position")?,
            vec3_arg(look_at, "look_at")?,
            vec3_arg(up, "up")?,
            vfov_deg,
            width,
            height,
        )
        .map_err(|e| FfiError::invalid(format!("camera: {e}")))?;
        if width > 1 << 16 || height > 1 << 16 {
            return Err(FfiError::invalid("camera: at most 65536 pixels a side"));
        }
        b.camera = Some(camera.into());
        Ok(())
    })
}

/// Sets a calibrated camera (a real camera's intrinsics and lens
/// distortion, as OpenCV, COLMAP, ARKit or ARCore give them; see
/// docs/calibration.md):
///
/// - `to_world`: 16 floats, the row-major 4×4 camera-to-world matrix in the
///   OpenCV convention (columns: image right, image down, view direction,
///   position). An OpenGL-style matrix (looking down −Z, +Y up) becomes one
///   by negating its second and third columns.
/// - `intrinsics`: 5 doubles, `fx, fy, cx, cy, skew` in pixels, in OpenCV's
///   pixel convention (the top-left pixel's centre is (0, 0)).
/// - `distortion`: 0 none, 1 Brown–Conrady (OpenCV's default model), 2
///   fisheye (`cv::fisheye`); `coefficients`: `count` doubles in OpenCV's
///   order (4, 5, 8 or 12 for Brown–Conrady, 4 for fisheye; 0 for none).
/// - `width × height`: the image the intrinsics are for.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_set_calibrated_camera(
    builder: *mut plsr_scene_builder,
    to_world: *const f32,
    intrinsics: *const f64,
    distortion: u32,
    coefficients: *const f64,
    count: usize,
    width: u32,
    height: u32,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        let m = slice_arg(to_world, 16, "to_world")?;
        let mut rows = [[0.0f32; 4]; 4];
        for (i, row) in rows.iter_mut().enumerate() {
            row.copy_from_slice(&m[4 * i..4 * i + 4]);
        }
        let pose = plsr::camera::Pose::from_matrix(rows)
            .map_err(|e| FfiError::invalid(format!("`to_world`: {e}")))?;
        let k = slice_arg(intrinsics, 5, "intrinsics")?;
        let coefficients = if count > 64 {
            return Err(FfiError::invalid(format!(
                "`count` {count}: too many coefficients (4 to 12)"
            )));
        } else {
            slice_arg(coefficients, count, "coefficients")?
        };
        let lens = match distortion {
            0 if coefficients.is_empty() => Ok(LensDistortion::None),
            0 => {
                return Err(FfiError::invalid(
                    "`distortion` 0 (none) takes no coefficients",
                ))
            }
            1 => LensDistortion::brown_conrady(coefficients),
            2 => LensDistortion::fisheye(coefficients),
            d => {
                return Err(FfiError::invalid(format!(
                    "`distortion` {d}: 0 (none), 1 (Brown–Conrady) or 2 (fisheye)"
                )))
            }
        }
        .map_err(|e| FfiError::invalid(format!("`coefficients`: {e}")))?;
        if width > 1 << 16 || height > 1 << 16 {
            return Err(FfiError::invalid("camera: at most 65536 pixels a side"));
        }
        let intrinsics = plsr::camera::Intrinsics {
            fx: k[0],
            fy: k[1],
            cx: k[2],
            cy: k[3],
            skew: k[4],
        };
        let camera = plsr::camera::CalibratedCamera::new(pose, width, height, intrinsics, lens)
            .map_err(|e| FfiError::invalid(format!("camera: {e}")))?;
        b.camera = Some(plsr::camera::Camera::Calibrated(camera));
        Ok(())
    })
}

/// Sets samples per pixel (≥ 1), the maximum number of scattering events
/// (≥ 1) and the seed.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_set_render(
    builder: *mut plsr_scene_builder,
    spp: u32,
    max_depth: u32,
    seed: u64,
) -> plsr_result {
    boundary(|| {
        let b = handle_mut(builder, "builder")?;
        b.job = super::image::job_arg(spp, max_depth, seed, 0)?;
        Ok(())
    })
}

/// Builds the scene into `*out` (the builder stays usable and must still be
/// freed). Fails without a camera.
#[no_mangle]
pub extern "C" fn plsr_scene_builder_build(
    builder: *const plsr_scene_builder,
    out: *mut *mut plsr_scene,
) -> plsr_result {
    boundary(|| {
        let b = handle_ref(builder, "builder")?;
        if out.is_null() {
            return Err(FfiError::null("out"));
        }
        let camera = b.camera.clone().ok_or_else(|| {
            FfiError::invalid("no camera: call plsr_scene_builder_set_camera first")
        })?;
        let scene = Scene::build(SceneDescription {
            meshes: b.meshes.clone(),
            materials: b.materials.clone(),
            point_lights: b.point_lights.clone(),
            directional_lights: Vec::new(),
            environment: b.environment.clone(),
            camera,
            film: Default::default(),
            job: b.job,
            robust: false,
            light_picking: Default::default(),
            instancing: Default::default(),
        })?;
        write_out(out, new_handle(plsr_scene { scene }), "out")
    })
}
