//! The bounce driver: one tile pass, bounce by bounce ([`trace_pass_body`]):
//! emission and environment found, surfaces looked up, lights picked and
//! sampled, shadow rays' radiance added.

use super::*;

/// One tile pass; inlined into each instruction-set variant of
/// [`trace_pass`], which names its instruction set `T` (for the material
/// kinds' passes, which are not inlined). With `pair`, the pass renders
/// compositing's pair of renders at once (see `paired.rs`): `pixels` gets
/// the render with the virtual objects, the pair's pixels the one without
/// them.
#[inline(always)]
pub(super) fn trace_pass_body<T: InstructionSet>(
    pass: &TilePass,
    lanes: &mut SoaLanes,
    pixels: &mut [PixelSums],
    stats: &mut RayStats,
    mut pair: Option<PairPass>,
) {
    let scene = pass.scene;
    lanes.paired = pair.is_some();

    // Camera rays: vectorised for a pinhole camera with the box filter,
    // otherwise one by one through the general code's camera and filter.
    lanes.resize((pass.tile.width * pass.tile.height) as usize);
    let n = match (&scene.camera(), &scene.film().filter) {
        (Camera::Pinhole(pinhole), PixelFilter::Box) => {
            pinhole_camera_rays(pinhole, pass, lanes);
            lanes.rays.len()
        }
        _ => general_camera_rays(pass, lanes),
    };
    lanes.resize(n);
    // The job's rays see the virtual objects or not (compositing renders
    // the scene both ways); one mask for every ray, shadow rays included.
    lanes.rays.set_mask(pass.job.ray_mask());
    lanes.shadow.set_mask(pass.job.ray_mask());
    stats.camera += n as u64;
    if let Some(pair) = pair.as_mut() {
        start_shared(lanes, pair);
    }
    trace_next(pass, lanes, pair.as_mut(), stats, true);

    // The camera vertex's auxiliary layers.
    camera_vertex_layers(pass, lanes, pixels, None);
    if let Some(pair) = pair.as_mut() {
        camera_vertex_layers(pass, lanes, pair.pixels, Some(&lanes.shared));
        camera_vertex_layers(pass, &pair.lanes.o, pair.pixels, None);
    }

    let mut depth = 0;
    loop {
        let pixels_o = pair.as_mut().map(|p| &mut *p.pixels);
        let mut going = bounce::<T>(pass, lanes, depth, pixels, pixels_o, stats);
        if let Some(pair) = pair.as_mut() {
            going |= bounce::<T>(pass, &mut pair.lanes.o, depth, pair.pixels, None, stats);
        }
        if !going {
            break;
        }
        trace_next(pass, lanes, pair.as_mut(), stats, false);
        depth += 1;
    }
}

/// One bounce of the paths in `lanes` at `depth` scattering events: the
/// emission their rays found, then (below the maximum depth) a light sample
/// and the next ray; ended paths are retired (with `pixels_o`, a paired
/// render's shared paths into those pixels too). Returns whether any path
/// goes on; if none does, every path has been retired and `lanes` is empty.
#[inline(always)]
pub(super) fn bounce<T: InstructionSet>(
    pass: &TilePass,
    lanes: &mut SoaLanes,
    depth: u32,
    pixels: &mut [PixelSums],
    pixels_o: Option<&mut [PixelSums]>,
    stats: &mut RayStats,
) -> bool {
    let (kernel, scene) = (pass.kernel, pass.scene);
    if lanes.rays.is_empty() {
        return false;
    }
    // Emission is only found on emitting triangles and in the environment
    // (and only then are the previous points and densities its MIS weight
    // needs kept).
    let has_emitters = kernel.triangle_lights || kernel.environment.is_some();
    if has_emitters {
        add_emission(kernel, scene, lanes, depth);
    }
    let retire_all = |lanes: &mut SoaLanes, pixels: &mut [PixelSums], pixels_o| {
        lanes.ended.clear();
        lanes.ended.extend(0..lanes.rays.len() as u32);
        retire(lanes, &lanes.ended, scene, pixels, pixels_o);
        lanes.kept.clear();
        lanes.retain(false);
    };
    if depth >= pass.job.max_depth {
        retire_all(lanes, pixels, pixels_o);
        return false;
    }
    let n = lanes.rays.len();
    let uniform = Uniform {
        // The ray after the last light sample can only find a light.
        continue_paths: depth + 1 < pass.job.max_depth || scene.has_hittable_lights(),
        roulette: depth + 1 >= pass.job.rr_depth,
    };
    pick_lights(kernel, scene, lanes);
    shade_lanes::<T>(kernel, lanes, uniform);

    let shadow_tfar = lanes.shadow.tfar.as_slice();
    stats.shadow += shadow_tfar.iter().filter(|&&t| t > 0.0).count() as u64;
    if lanes.paired {
        lanes.shadow_before.clear();
        lanes.shadow_before.extend_from_slice(shadow_tfar);
    }
    let clock = Instant::now();
    scene.accel().occluded_batch(&mut lanes.shadow, false);
    if lanes.paired {
        stats.shadow_again += requery_shadows(kernel, scene, lanes) as u64;
    }
    stats.trace_nanos += clock.elapsed().as_nanos() as u64;
    let live = add_unoccluded(lanes);
    stats.bounce += live as u64;

    // Retire finished paths; compact once enough lanes are idle.
    if live == 0 {
        retire_all(lanes, pixels, pixels_o);
        return false;
    }
    if live * 3 <= n * 2 {
        retire(lanes, &lanes.ended, scene, pixels, pixels_o);
        lanes.retain(has_emitters);
    }
    true
}

/// Traces the lanes' next rays (`coherent` for camera rays) and looks up
/// their surfaces; with `pair`, forks the shared paths whose ray met a
/// virtual object, then traces the pair's O-only lanes (new forks
/// included) without the virtual objects.
#[inline(always)]
pub(super) fn trace_next(
    pass: &TilePass,
    lanes: &mut SoaLanes,
    pair: Option<&mut PairPass>,
    stats: &mut RayStats,
    coherent: bool,
) {
    let (kernel, scene) = (pass.kernel, pass.scene);
    if lanes.paired {
        lanes.tfar_before.clear();
        lanes
            .tfar_before
            .extend_from_slice(lanes.rays.tfar.as_slice());
    }
    let clock = Instant::now();
    scene.accel().intersect_batch(&mut lanes.rays, coherent);
    stats.trace_nanos += clock.elapsed().as_nanos() as u64;
    let surfaces = kernel.any_textured || kernel.any_smooth || kernel.any_anisotropic;
    if surfaces {
        lane_surfaces(kernel, scene, lanes);
    }
    if let Some(pair) = pair {
        let o = &mut pair.lanes.o;
        stats.forked += fork_virtual_hits(kernel, lanes, o) as u64;
        o.rays.set_mask(REAL_MASK);
        o.shadow.set_mask(REAL_MASK);
        stats.o_rays += o.rays.tfar.as_slice().iter().filter(|&&t| t > 0.0).count() as u64;
        let clock = Instant::now();
        scene.accel().intersect_batch(&mut o.rays, coherent);
        stats.trace_nanos += clock.elapsed().as_nanos() as u64;
        if surfaces {
            lane_surfaces(kernel, scene, o);
        }
    }
}

/// Adds the emission that the lanes' rays found on emitting triangles or,
/// leaving the scene, in the environment, MIS-weighted against the light
/// sample that could have found it, as the general integrator does; lane
/// by lane, as such hits are few (but for an environment).
#[inline(always)]
pub(super) fn add_emission(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes, depth: u32) {
    if let Some(env) = kernel.environment {
        add_environment(scene, lanes, env, depth);
    }
    for i in 0..lanes.rays.len() {
        let g = lanes.rays.geom_id.as_slice()[i];
        if g == INVALID_ID || !kernel.emissive[g as usize] {
            continue;
        }
        let (Some(hit), ray) = (lanes.rays.hit(i), lanes.rays.ray(i)) else {
            continue;
        };
        let Some(li) = scene.light_index(hit.geom_id, hit.prim_id) else {
            continue;
        };
        let light = &scene.lights().lights[li];
        let Light::Triangle(tl) = light else {
            continue;
        };
        let p = ray.org + hit.t * ray.dir;
        let le = tl.emitted(-ray.dir);
        if le == Vec3::ZERO {
            continue;
        }
        let prev = lanes.prev_vertex(i, depth);
        let weight = emission_weight(scene, li, &prev, p, ray.dir);
        lanes.add_found_emission(i, le, weight);
    }
}

/// Adds the environment's radiance along the rays that left the scene
/// (lanes without a hit whose paths go on: an ended path has `tfar = −∞`),
/// MIS-weighted as the general integrator weighs it; the lookups of all
/// lanes at once (`EnvironmentLight::radiance_pdf_many`).
#[inline(always)]
pub(super) fn add_environment(scene: &Scene, lanes: &mut SoaLanes, env: usize, depth: u32) {
    let Light::Environment { light, .. } = &scene.lights().lights[env] else {
        return;
    };
    lanes.env_lanes.clear();
    lanes.env_dirs.clear();
    for i in 0..lanes.rays.len() {
        if lanes.rays.geom_id.as_slice()[i] == INVALID_ID && lanes.rays.tfar.as_slice()[i] > 0.0 {
            lanes.env_lanes.push(i as u32);
            lanes.env_dirs.push(lanes.rays.ray(i).dir);
        }
    }
    light.radiance_pdf_many(&lanes.env_dirs, &mut lanes.env_seen);
    for j in 0..lanes.env_lanes.len() {
        let (i, (le, pdf)) = (lanes.env_lanes[j] as usize, lanes.env_seen[j]);
        if le == Vec3::ZERO {
            continue;
        }
        let prev = lanes.prev_vertex(i, depth);
        let weight = environment_weight(scene, env, &prev, || pdf);
        lanes.add_found_emission(i, le, weight);
    }
}

/// What each lane's hit knows of its surface, looked up as the general
/// integrator looks it up (`SurfacePoint::new`, `Material::bsdf_at`): its
/// albedo into `lanes.albedo` (from the table for an untextured material,
/// else the texture at the hit's texture coordinates) and, where its mesh
/// has vertex normals, the interpolated normal into `lanes.ns`. The
/// triangles, then their vertices' attributes, are prefetched for all
/// lanes first, so that the cache misses on large meshes overlap.
#[inline(always)]
pub(super) fn lane_surfaces(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    let last = kernel.albedo[0].len() - 1;
    let n = lanes.rays.len();
    let meshes = scene.meshes();
    let (geom, prim) = (lanes.rays.geom_id.as_slice(), lanes.rays.prim_id.as_slice());
    let attributes = |i: usize| {
        let g = (geom[i] as usize).min(last);
        kernel.textured[g] || kernel.smooth[g] || kernel.anisotropic[g]
    };
    for i in (0..n).filter(|&i| attributes(i)) {
        prefetch(&meshes[geom[i] as usize].triangles[prim[i] as usize]);
    }
    for i in (0..n).filter(|&i| attributes(i)) {
        let mesh = &meshes[geom[i] as usize];
        for v in mesh.triangles[prim[i] as usize] {
            if let Some(ns) = mesh.normals.get(v as usize) {
                prefetch(ns);
            }
            if let Some(uv) = mesh.uvs.get(v as usize) {
                prefetch(uv);
            }
        }
    }
    for i in 0..n {
        let g = (lanes.rays.geom_id.as_slice()[i] as usize).min(last);
        let mut albedo = Vec3::new(
            kernel.albedo[0][g],
            kernel.albedo[1][g],
            kernel.albedo[2][g],
        );
        let mut ns = None;
        if kernel.textured[g] || kernel.smooth[g] {
            if let Some(hit) = lanes.rays.hit(i) {
                let mesh = &meshes[g];
                let material = &scene.materials()[mesh.material as usize];
                // (No instances here: their scenes go to the general integrator.)
                let on = crate::scene::MeshHit {
                    mesh,
                    instance: None,
                };
                let surface = SurfacePoint::new(on, &hit, material);
                if kernel.textured[g] {
                    let bsdf = material.bsdf_at(surface.uv, surface.color);
                    albedo = bsdf.albedo();
                    if kernel.mapped[g] {
                        let mapped = mapped_params(&bsdf);
                        for c in 0..3 {
                            lanes.mapped[c][i] = mapped[c];
                        }
                    }
                }
                ns = surface.normal;
            }
        }
        for c in 0..3 {
            lanes.albedo[c][i] = albedo[c];
        }
        lanes.ns_valid[i] = ns.is_some();
        let ns = ns.unwrap_or(Vec3::ZERO);
        for c in 0..3 {
            lanes.ns[c][i] = ns[c];
        }
        if kernel.any_anisotropic {
            let hit = lanes.rays.hit(i).filter(|_| kernel.anisotropic[g]);
            let tangent = hit.map(|hit| {
                let on = crate::scene::MeshHit {
                    mesh: &meshes[g],
                    instance: None,
                };
                SurfacePoint::tangent(on, &hit)
            });
            lanes.tangent_valid[i] = tangent.is_some();
            let tangent = tangent.unwrap_or(Vec3::ZERO);
            for c in 0..3 {
                lanes.tangent[c][i] = tangent[c];
            }
        }
    }
}

/// Adds the camera vertex's auxiliary layers (hit count, depth, normal,
/// albedo, and on the first pass the object id) to the pixels, as the
/// general integrator does at a path's first hit: per-lane values in
/// vectorised chunks, then the sums lane by lane; with `only`, for the
/// lanes it marks only.
#[inline(always)]
pub(super) fn camera_vertex_layers(
    pass: &TilePass,
    lanes: &SoaLanes,
    pixels: &mut [PixelSums],
    only: Option<&[bool]>,
) {
    let rays = &lanes.rays;
    let n = rays.len();
    let last = pass.kernel.albedo[0].len() - 1;
    for start in (0..n).step_by(W) {
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        let t = load(rays.tfar.as_slice(), start);
        let dir = [
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        ];
        let ng = [
            load(rays.ng_x.as_slice(), start),
            load(rays.ng_y.as_slice(), start),
            load(rays.ng_z.as_slice(), start),
        ];
        let (mut ns, mut ns_valid) = ([[0.0f32; W]; 3], [false; W]);
        if pass.kernel.any_smooth {
            ns_valid = load(&lanes.ns_valid, start);
            for c in 0..3 {
                ns[c] = load(&lanes.ns[c], start);
            }
        }
        let mut transmits = [false; W];
        if pass.kernel.any_transmits {
            for k in 0..W {
                transmits[k] = pass.kernel.transmits[(geom[k] as usize).min(last)];
            }
        }
        let mut normal = [[0.0f32; W]; 3];
        let mut depth = [0.0f32; W];
        for k in 0..W {
            let d = Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            let n = Vec3::new(ng[0][k], ng[1][k], ng[2][k]).normalize_or_zero();
            let facing = if n.dot(-d) >= 0.0 { n } else { -n };
            // The shading normal, as the general integrator records it (for
            // a transmissive material, the geometric normal).
            let shading = Vec3::new(ns[0][k], ns[1][k], ns[2][k]);
            let facing = if ns_valid[k] && !transmits[k] {
                shading_normal_towards(shading, facing, -d)
            } else {
                facing
            };
            for c in 0..3 {
                normal[c][k] = facing[c];
            }
            depth[k] = pass.scene.camera().depth(d, t[k]);
        }
        for k in 0..(n - start).min(W) {
            if geom[k] == INVALID_ID || only.is_some_and(|only| !only[start + k]) {
                continue;
            }
            let g = (geom[k] as usize).min(last);
            let pixel = &mut pixels[lanes.pixel[start + k] as usize];
            let albedo = if pass.kernel.any_textured {
                let i = start + k;
                Vec3::new(lanes.albedo[0][i], lanes.albedo[1][i], lanes.albedo[2][i])
            } else {
                Vec3::new(
                    pass.kernel.albedo[0][g],
                    pass.kernel.albedo[1][g],
                    pass.kernel.albedo[2][g],
                )
            };
            pixel.add_first_hit(
                depth[k],
                Vec3::new(normal[0][k], normal[1][k], normal[2][k]),
                albedo,
            );
            if pass.first {
                pixel.object_id = pass.scene.meshes()[g].object_layer();
            }
            if pass.kernel.is_virtual[g] {
                pixel.virtual_hits += 1;
            }
        }
    }
}

/// Fills each lane's light for the next light sample: the light the
/// general integrator's [`LightSet::pick`](crate::light::LightSet::pick)
/// picks at the lane's hit point with the lane's next two random numbers
/// (the draw itself, advancing the state, happens in [`shade_lane`]), or
/// none where no light can reach the point. With one light picked the same
/// way everywhere there is nothing to fill: [`shade_lanes`] uses it for
/// every lane.
#[inline(always)]
pub(super) fn pick_lights(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    if kernel.single_light.is_none() {
        pick_per_lane(kernel, scene, lanes);
    }
    if let Some(env) = kernel.environment {
        sample_environment(kernel, scene, lanes, env);
    }
}

/// The environment's light sample of each lane that picked it, with the
/// lane's numbers after the pick's two (as the general integrator draws
/// them); all lanes' samples at once (`EnvironmentLight::sample_li_many`,
/// whose cache misses on a large map overlap).
#[inline(always)]
pub(super) fn sample_environment(
    kernel: &SoaScene,
    scene: &Scene,
    lanes: &mut SoaLanes,
    env: usize,
) {
    let Light::Environment { light, .. } = &scene.lights().lights[env] else {
        return;
    };
    let single = kernel.single_light.map(|l| l.environment);
    lanes.env_lanes.clear();
    lanes.env_us.clear();
    for i in 0..lanes.rays.len() {
        lanes.env_valid[i] = false;
        let picked = single.unwrap_or(lanes.light[i] == env as u32);
        let geom = lanes.rays.geom_id.as_slice()[i];
        // A delta BSDF (a smooth dielectric) takes no light sample.
        if geom == INVALID_ID || !picked || kernel.smooth_dielectric.covers(geom as usize) {
            continue;
        }
        let mut rng = lanes.sampler(i);
        let _pick = rng.next_2d();
        lanes.env_lanes.push(i as u32);
        lanes.env_us.push(rng.next_2d());
    }
    light.sample_li_many(&lanes.env_us, &mut lanes.env_samples);
    for (&i, sample) in lanes.env_lanes.iter().zip(&lanes.env_samples) {
        let i = i as usize;
        lanes.env_valid[i] = sample.is_some();
        if let Some(ls) = sample {
            for c in 0..3 {
                lanes.env_wi[c][i] = ls.wi[c];
                lanes.env_radiance[c][i] = ls.radiance[c];
            }
            lanes.env_pdf[i] = ls.pdf;
        }
    }
}

/// Each lane's light for a scene with several lights or one picked only
/// where it reaches (see [`pick_lights`]).
#[inline(always)]
pub(super) fn pick_per_lane(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) {
    let n = lanes.rays.len();
    let set = scene.lights();
    let none = (kernel.light_table.len() - 1) as u32;
    let rays = &lanes.rays;
    for start in (0..n).step_by(W) {
        // The hit points exactly as `shade_lane` computes them, and the
        // pick's two numbers, for a chunk of lanes at once.
        let t = load(rays.tfar.as_slice(), start);
        let org = [
            load(rays.org_x.as_slice(), start),
            load(rays.org_y.as_slice(), start),
            load(rays.org_z.as_slice(), start),
        ];
        let dir = [
            load(rays.dir_x.as_slice(), start),
            load(rays.dir_y.as_slice(), start),
            load(rays.dir_z.as_slice(), start),
        ];
        let mut dim = load(&lanes.rng_dim, start);
        let stream = load_streams(&lanes.rng_stream, start);
        let mut p = [[0.0f32; W]; 3];
        let mut u = [Vec2::ZERO; W];
        for k in 0..W {
            let x = Vec3::new(org[0][k], org[1][k], org[2][k])
                + t[k] * Vec3::new(dir[0][k], dir[1][k], dir[2][k]);
            for c in 0..3 {
                p[c][k] = x[c];
            }
            u[k] = PathSampler::step_2d(&mut dim[k], stream[k]);
        }
        // Which cone-limited groups reach each lane's point: the bounding
        // cones for the whole chunk, the exact test where they cannot tell.
        let mut reaches = [0u64; W];
        // (`pick_among` tests any further groups itself.)
        for (g, reach) in set.limited_reaches().take(64).enumerate() {
            let Some(reach) = reach else { continue };
            let mut decided = [false; W];
            let mut inside = [false; W];
            for k in 0..W {
                (decided[k], inside[k]) =
                    reach.bounding_cones(Vec3::new(p[0][k], p[1][k], p[2][k]));
            }
            for k in 0..W {
                let yes = if decided[k] {
                    inside[k]
                } else {
                    reach.can_reach(Vec3::new(p[0][k], p[1][k], p[2][k]))
                };
                reaches[k] |= (yes as u64) << g;
            }
        }
        let geom = load_or(rays.geom_id.as_slice(), start, INVALID_ID);
        for k in 0..(n - start).min(W) {
            // A delta BSDF (a smooth dielectric) takes no light sample.
            if geom[k] == INVALID_ID || kernel.smooth_dielectric.covers(geom[k] as usize) {
                continue;
            }
            (lanes.light[start + k], lanes.light_pmf[start + k]) =
                match set.pick_among(reaches[k], Vec3::new(p[0][k], p[1][k], p[2][k]), u[k]) {
                    Some((li, pmf)) => (li as u32, pmf),
                    None => (none, 0.0),
                };
        }
    }
}

/// Adds each unoccluded shadow ray's pending radiance to its path, and
/// lists the lanes whose paths go on in `lanes.kept`; returns their number.
#[inline(always)]
pub(super) fn add_unoccluded(lanes: &mut SoaLanes) -> usize {
    let n = lanes.rays.len();
    lanes.kept.resize(n, 0);
    lanes.ended.resize(n, 0);
    let mut live = 0;
    for start in (0..n).step_by(W) {
        let shadow_tfar = load(lanes.shadow.tfar.as_slice(), start);
        let tfar = load(lanes.rays.tfar.as_slice(), start);
        for c in 0..3 {
            let mut radiance = load(&lanes.radiance[c], start);
            let pending = load(&lanes.pending[c], start);
            for k in 0..W {
                // Inactive lanes have tfar = −∞, as occluded ones. A select,
                // not a branch: occlusion is unpredictable.
                radiance[k] = if shadow_tfar[k] > 0.0 {
                    radiance[k] + pending[k]
                } else {
                    radiance[k]
                };
            }
            store(&mut lanes.radiance[c], start, &radiance);
        }
        if lanes.paired {
            // The render without the virtual objects: its own verdicts.
            let open = load(&lanes.open_o, start);
            for c in 0..3 {
                let mut radiance = load(&lanes.radiance_o[c], start);
                let pending = load(&lanes.pending[c], start);
                for k in 0..W {
                    radiance[k] = if open[k] {
                        radiance[k] + pending[k]
                    } else {
                        radiance[k]
                    };
                }
                store(&mut lanes.radiance_o[c], start, &radiance);
            }
        }
        for k in 0..(n - start).min(W) {
            // Branch-free too: whether a path goes on is unpredictable.
            let i = start + k;
            lanes.kept[live] = i as u32;
            lanes.ended[i - live] = i as u32;
            live += (tfar[k] > 0.0) as usize;
        }
    }
    lanes.kept.truncate(live);
    lanes.ended.truncate(n - live);
    live
}
