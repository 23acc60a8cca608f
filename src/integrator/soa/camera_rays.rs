//! The camera rays of a tile pass: through the general code's camera, or
//! for a pinhole camera and the box filter in a loop of their own.

use super::*;

/// The camera rays of a tile pass through the general code's camera and
/// filter, lane by lane; a pixel the camera has no ray for (outside a
/// fisheye's circles) gets no lane. Returns the number of lanes.
#[inline(always)]
pub(super) fn general_camera_rays(pass: &TilePass, lanes: &mut SoaLanes) -> usize {
    let (scene, tile) = (pass.scene, pass.tile);
    let lens_sample = scene.camera().needs_lens_sample();
    let mut n = 0;
    for py in 0..tile.height {
        for px in 0..tile.width {
            let (x, y) = (tile.x0 + px, tile.y0 + py);
            let (rng, Some(ray)) =
                camera_sample(scene, pass.job.seed, lens_sample, x, y, pass.sample)
            else {
                continue;
            };
            lanes.rays.set(n, ray);
            lanes.pixel[n] = py * tile.width + px;
            lanes.set_sampler(n, &rng);
            lanes.eta_scale[n] = 1.0;
            for c in 0..3 {
                lanes.beta[c][n] = 1.0;
                lanes.radiance[c][n] = 0.0;
            }
            n += 1;
        }
    }
    n
}

/// The camera rays of a tile pass for a pinhole camera and the box filter,
/// one lane per pixel in row-major order, with each lane's random stream
/// after the filter's two numbers: the general integrator's camera stage,
/// vectorised.
#[inline(always)]
pub(super) fn pinhole_camera_rays(camera: &PinholeCamera, pass: &TilePass, lanes: &mut SoaLanes) {
    let (tile, seed, sample) = (pass.tile, pass.job.seed, pass.sample);
    let n = lanes.rays.len();
    for start in (0..n).step_by(W) {
        let mut dir = [[0.0f32; W]; 3];
        let mut dim = [0u32; W];
        let mut stream = [[0u32; W]; 3];
        for k in 0..W {
            let i = (start + k) as u32;
            let (px, py) = (i % tile.width, i / tile.width);
            let mut rng = PathSampler::for_sample(seed, tile.x0 + px, tile.y0 + py, sample);
            let u = rng.next_2d();
            let film = Vec2::new((tile.x0 + px) as f32, (tile.y0 + py) as f32) + u;
            let ray = camera.generate_ray(film);
            for c in 0..3 {
                dir[c][k] = ray.dir[c];
            }
            let (d, s) = rng.to_parts();
            dim[k] = d;
            (stream[0][k], stream[1][k], stream[2][k]) =
                (s.reversed_sample, s.pixel_lo, s.pixel_hi);
        }
        store(lanes.rays.dir_x.as_mut_slice(), start, &dir[0]);
        store(lanes.rays.dir_y.as_mut_slice(), start, &dir[1]);
        store(lanes.rays.dir_z.as_mut_slice(), start, &dir[2]);
        store(&mut lanes.rng_dim, start, &dim);
        for c in 0..3 {
            store(&mut lanes.rng_stream[c], start, &stream[c]);
        }
    }
    let origin = camera.pose.position;
    for (c, org) in [
        &mut lanes.rays.org_x,
        &mut lanes.rays.org_y,
        &mut lanes.rays.org_z,
    ]
    .into_iter()
    .enumerate()
    {
        org.as_mut_slice().fill(origin[c]);
    }
    lanes.rays.tnear.as_mut_slice().fill(0.0);
    lanes.rays.tfar.as_mut_slice().fill(f32::INFINITY);
    lanes.rays.geom_id.as_mut_slice().fill(INVALID_ID);
    lanes.rays.prim_id.as_mut_slice().fill(INVALID_ID);
    for (i, p) in lanes.pixel.iter_mut().enumerate() {
        *p = i as u32;
    }
    lanes.eta_scale.fill(1.0);
    for c in 0..3 {
        lanes.beta[c].fill(1.0);
        lanes.radiance[c].fill(0.0);
    }
}
