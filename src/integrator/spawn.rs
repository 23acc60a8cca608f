//! Where the rays of a path start and end: the offsets that keep a ray off
//! the surface it leaves, and the segment a shadow ray tests. Shared, as
//! branch-free functions, by the general integrator and the vectorised
//! kernel, so both trace the same rays.

use glam::Vec3;

/// Offset along the normal that keeps spawned rays off their own surface,
/// relative to the magnitude of the coordinates (scene units).
#[inline(always)]
pub fn ray_epsilon(p: Vec3) -> f32 {
    1e-4 * (1.0 + p.abs().max_element())
}

/// Origin of a ray leaving surface point `p` along `dir`: offset by `eps`
/// along the normal `n`, to the side `dir` leaves on (refracted rays leave
/// on the far side).
#[inline(always)]
pub fn spawn_origin(p: Vec3, n: Vec3, eps: f32, dir: Vec3) -> Vec3 {
    if n.dot(dir) >= 0.0 {
        p + n * eps
    } else {
        p - n * eps
    }
}

/// The shadow ray from `origin` (the offset shading point `p`) towards a
/// light sample at distance `dist` along `wi`: its direction and `tfar`.
/// For a point at finite distance, `t ∈ [0, tfar]` along `target − origin`
/// ends just short of the light; towards the environment (at infinity),
/// the ray is unbounded.
#[inline(always)]
pub fn shadow_segment(origin: Vec3, p: Vec3, wi: Vec3, dist: f32) -> (Vec3, f32) {
    let target = p + wi * dist;
    if dist.is_finite() {
        (target - origin, 1.0 - ray_epsilon(target) / dist)
    } else {
        (wi, f32::INFINITY)
    }
}
