//! The C ABI's scene builder: a sequence of `plsr_scene_builder_*` calls
//! with fuzzed arguments, then `plsr_scene_builder_build` and, when the
//! camera is small, `plsr_render`. Every call returns a result code (no
//! unwinding, no abort), and a failed call leaves an error message.

use arbitrary::Arbitrary;
use plsr_capi::*;
use std::ffi::CString;
use std::ptr;

/// One call of the builder, with its arguments.
#[derive(Debug, Arbitrary)]
enum Call {
    Diffuse {
        name: String,
        rgb: [f32; 3],
    },
    Principled {
        name: String,
        base: [f32; 3],
        values: [f32; 5],
        energy: bool,
    },
    Mesh {
        positions: Vec<f32>,
        vertices: u8,
        indices: Vec<u32>,
        material: u32,
        emission: Option<[f32; 3]>,
    },
    PointLight {
        position: [f32; 3],
        intensity: [f32; 3],
    },
    Pls {
        params: [f32; 22],
        nf: u16,
        radiance: bool,
    },
    Camera {
        position: [f32; 3],
        look_at: [f32; 3],
        up: [f32; 3],
        vfov: f32,
        width: u32,
        height: u32,
    },
    Render {
        spp: u32,
        max_depth: u32,
        seed: u64,
    },
    Environment {
        path: String,
        up: [f32; 3],
        forward: [f32; 3],
        scale: f32,
    },
}

/// A failed call must leave a message.
fn check_result(result: plsr_result) {
    if result != PLSR_OK {
        // SAFETY: plsr_last_error returns a NUL-terminated string the
        // library owns until the next failing call on this thread.
        let message = unsafe { std::ffi::CStr::from_ptr(plsr_last_error()) };
        assert!(
            !message.to_bytes().is_empty(),
            "{result:?} without a message"
        );
    }
}

/// `s` without its NUL bytes, as a C string.
fn c_string(s: &str) -> CString {
    CString::new(s.replace('\0', "")).unwrap()
}

/// Runs the calls `data` decodes to (as libFuzzer's `arbitrary` input).
pub fn check(data: &[u8]) {
    let Ok(calls) = Vec::<Call>::arbitrary_take_rest(arbitrary::Unstructured::new(data)) else {
        return;
    };
    let dir = crate::common::workdir();
    let mut builder = ptr::null_mut();
    check_result(plsr_scene_builder_new(&mut builder));
    let mut small = false;
    for call in calls.iter().take(16) {
        let r = match call {
            Call::Diffuse { name, rgb } => {
                let name = c_string(name);
                plsr_scene_builder_add_diffuse(
                    builder,
                    name.as_ptr(),
                    rgb.as_ptr(),
                    ptr::null_mut(),
                )
            }
            Call::Principled {
                name,
                base,
                values,
                energy,
            } => {
                let name = c_string(name);
                let params = plsr_principled {
                    base_color: *base,
                    roughness: values[0],
                    metallic: values[1],
                    anisotropic: values[2],
                    specular: values[3],
                    spec_tint: values[4],
                    energy_conserving: *energy,
                };
                plsr_scene_builder_add_principled(builder, name.as_ptr(), &params, ptr::null_mut())
            }
            Call::Mesh {
                positions,
                vertices,
                indices,
                material,
                emission,
            } => {
                // The counts never exceed the arrays: a C host that lies
                // about them is undefined behaviour, not an input.
                let vertex_count = usize::from(*vertices).min(positions.len() / 3);
                let emission = emission.as_ref().map_or(ptr::null(), |e| e.as_ptr());
                plsr_scene_builder_add_mesh(
                    builder,
                    positions.as_ptr(),
                    vertex_count,
                    indices.as_ptr(),
                    indices.len() / 3,
                    *material,
                    emission,
                    ptr::null_mut(),
                )
            }
            Call::PointLight {
                position,
                intensity,
            } => plsr_scene_builder_add_point_light(builder, position.as_ptr(), intensity.as_ptr()),
            Call::Pls {
                params,
                nf,
                radiance,
            } => {
                let p = plsr_pls_params {
                    n: [params[0], params[1], params[2]],
                    e1: [params[3], params[4], params[5]],
                    e2: [params[6], params[7], params[8]],
                    alpha1: params[9],
                    alpha2: params[10],
                    d: [params[11], params[12], params[13], params[14]],
                    a_deg: params[15],
                    c: [params[16], params[17], params[18]],
                    b: params[19],
                    brightness_is_radiance: u32::from(*radiance),
                };
                plsr_scene_builder_add_pls(builder, &p, u32::from(*nf))
            }
            Call::Camera {
                position,
                look_at,
                up,
                vfov,
                width,
                height,
            } => {
                let r = plsr_scene_builder_set_camera(
                    builder,
                    position.as_ptr(),
                    look_at.as_ptr(),
                    up.as_ptr(),
                    *vfov,
                    *width,
                    *height,
                );
                // A refused camera leaves the one before in place (found
                // by fuzzing: a big earlier camera was then rendered).
                if r == PLSR_OK {
                    small = u64::from(*width) * u64::from(*height) <= 64;
                }
                r
            }
            Call::Render {
                spp,
                max_depth,
                seed,
            } => plsr_scene_builder_set_render(builder, spp % 5, max_depth % 6, *seed),
            Call::Environment {
                path,
                up,
                forward,
                scale,
            } => {
                // Only the fixture folder: the target reads no other file.
                let name = if path.len() % 2 == 0 {
                    "sky.exr"
                } else {
                    "tex.png"
                };
                let path = c_string(&dir.join(name).to_string_lossy());
                plsr_scene_builder_set_environment(
                    builder,
                    path.as_ptr(),
                    up.as_ptr(),
                    forward.as_ptr(),
                    *scale,
                )
            }
        };
        check_result(r);
    }
    let mut scene = ptr::null_mut();
    let built = plsr_scene_builder_build(builder, &mut scene);
    check_result(built);
    if built == PLSR_OK && small {
        let mut image = ptr::null_mut();
        let r = plsr_render(scene, 1, None, ptr::null_mut(), &mut image);
        check_result(r);
        check_result(plsr_image_free(image));
    }
    check_result(plsr_scene_free(scene));
    check_result(plsr_scene_builder_free(builder));
}
