//! The steps both integrators take alike, so that the vectorised kernel
//! ([`super::soa`]) and the general wavefront ([`super::general`]) compute
//! the same numbers: the camera sample, the shading point and its normal,
//! the emission and environment MIS weights, Russian roulette, and the ray
//! counts both report.

use crate::accel::Ray;
use crate::sampler::PathSampler;
use crate::scene::Scene;
use crate::warp::power_heuristic;
use glam::{Vec2, Vec3};

/// A sample of light `li` from `p` with the square sample `u`: the light's
/// own [`Light::sample_li`](crate::light::Light::sample_li), except for a
/// sphere light's triangle ([`crate::light::SphereCap`]), whose sample is a
/// direction in the sphere's cone and the point where that ray (with the
/// job's ray `mask`) first meets the sphere's mesh: `None` where it meets
/// something else first or the mesh's side that does not emit.
#[inline]
pub(crate) fn sample_light(
    scene: &Scene,
    li: usize,
    p: Vec3,
    u: Vec2,
    mask: u32,
) -> Option<crate::light::LightSample> {
    let light = &scene.lights().lights[li];
    let crate::light::Light::Triangle(crate::light::TriangleLight {
        sphere: Some(cap), ..
    }) = light
    else {
        return light.sample_li(p, u);
    };
    sample_sphere(scene, cap, p, u, mask)
}

/// [`sample_light`] for a sphere light (kept out of line: most lights
/// are not spheres).
#[inline(never)]
fn sample_sphere(
    scene: &Scene,
    cap: &crate::light::SphereCap,
    p: Vec3,
    u: Vec2,
    mask: u32,
) -> Option<crate::light::LightSample> {
    if cap.share <= 0.0 {
        return None;
    }
    let (wi, pdf) = cap.sample_direction(p, u);
    let ray = Ray {
        org: p,
        dir: wi,
        tnear: super::spawn::ray_epsilon(p),
        tfar: f32::INFINITY,
    };
    let mut query = [crate::accel::RayHit::masked(ray, mask)];
    scene.accel().intersect_each(&mut query);
    let hit = query[0].hit()?;
    if hit.geom_id != cap.geom || hit.instance.is_some() {
        return None;
    }
    let li = scene.light_index(hit.geom_id, hit.prim_id)?;
    let crate::light::Light::Triangle(t) = &scene.lights().lights[li] else {
        return None;
    };
    let radiance = t.emitted_at(-wi, Vec2::new(hit.u, hit.v));
    (radiance != Vec3::ZERO).then_some(crate::light::LightSample {
        radiance,
        wi,
        dist: hit.t,
        pdf: pdf / cap.share,
        delta: false,
    })
}

/// Whether Russian roulette spins for a path that has reached
/// [`RenderJob::rr_depth`] (`at_depth`), judged by `rr_beta`, its
/// throughput `β` times `η²` of the refractions it went through (see
/// [`PathState::eta_scale`]): only where the largest channel `q` of
/// `rr_beta` is below 1, and only then does it draw a number.
#[inline(always)]
pub(crate) fn roulette_spins(rr_beta: Vec3, at_depth: bool) -> bool {
    at_depth && rr_beta.max_element() < 1.0
}

/// The roulette's outcome for the uniform number `u`: the path survives
/// with probability `q` (the largest channel of `rr_beta`), its throughput
/// `beta` divided by `q` so the estimate stays unbiased.
#[inline(always)]
pub(crate) fn roulette(beta: Vec3, rr_beta: Vec3, u: f32) -> (bool, Vec3) {
    let q = rr_beta.max_element();
    (u < q, beta / q)
}

/// Counts of rays traced and the time spent tracing them, for throughput
/// reports (not comparable between runs: it holds a timing).
#[derive(Debug, Clone, Copy, Default)]
pub struct RayStats {
    /// Camera rays (closest hit).
    pub camera: u64,
    /// Continuation rays after scattering (closest hit).
    pub bounce: u64,
    /// Shadow rays of next-event estimation (any hit).
    pub shadow: u64,
    /// Nanoseconds spent inside Embree's queries, summed over threads (the
    /// rest of a render's CPU time is shading and bookkeeping). Timed per
    /// batch of a wavefront, so the clock costs nothing measurable.
    pub trace_nanos: u64,
    /// Compositing's paired render (see
    /// [`render_tile_pair`](super::render_tile_pair)): paths that met a
    /// virtual object and were forked.
    pub forked: u64,
    /// Closest-hit rays traced for forked paths without the virtual objects
    /// (their camera and continuation rays, counted in `camera`/`bounce`
    /// too only for the continuations).
    pub o_rays: u64,
    /// Shadow rays of shared paths asked again without the virtual objects
    /// (blocked, and their segment meets a virtual object's bounds).
    pub shadow_again: u64,
}

impl RayStats {
    /// All rays.
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }

    /// Adds another count.
    pub fn add(&mut self, o: &RayStats) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
        self.trace_nanos += o.trace_nanos;
        self.forked += o.forked;
        self.o_rays += o.o_rays;
        self.shadow_again += o.shadow_again;
    }
}

/// The light-leak guard of shading normals: a direction pair must be a
/// reflection (or a transmission) both for the geometric normal `ng` and in
/// the shading frame (`*_local`), or it is discarded; otherwise a bent
/// shading normal would let light through opaque surfaces.
#[inline(always)]
pub(crate) fn sides_agree(wo: Vec3, wi: Vec3, ng: Vec3, wo_local: Vec3, wi_local: Vec3) -> bool {
    (wo.dot(ng) * wi.dot(ng) > 0.0) == (wo_local.z * wi_local.z > 0.0)
}

/// What a hit knows of its surface beyond the geometric normal: texture
/// coordinates and the shading normal.
pub(crate) struct SurfacePoint {
    /// Texture coordinates (zero where the mesh has none or none are needed).
    pub(crate) uv: Vec2,
    /// Unit shading normal: interpolated where the mesh has vertex normals,
    /// tilted by the material's normal map where it has one and the mesh
    /// has texture coordinates.
    pub(crate) normal: Option<Vec3>,
    /// The interpolated vertex normal before any normal map tilted it (for
    /// the shadow terminator), or `None` without vertex normals.
    pub(crate) base_normal: Option<Vec3>,
    /// The mesh's colour at the hit where the material takes its base
    /// colour from it ([`crate::scene::Mesh::colors`]), else one.
    pub(crate) color: Vec3,
}

impl SurfacePoint {
    /// Interpolates the mesh's vertex attributes at the hit (Embree's
    /// barycentrics: `p = (1 − u − v)·p0 + u·p1 + v·p2`); `uv` only when
    /// `material` is textured; then applies its normal map.
    #[inline]
    pub(crate) fn new(
        on: crate::scene::MeshHit,
        hit: &crate::accel::Hit,
        material: &crate::scene::Material,
    ) -> SurfacePoint {
        let point = Self::in_mesh_space(on.mesh, hit, material);
        match on.instance {
            None => point,
            // Interpolated in the group's space, the normals brought to
            // the world.
            Some(i) => SurfacePoint {
                normal: point.normal.map(|n| i.normal(n)),
                base_normal: point.base_normal.map(|n| i.normal(n)),
                ..point
            },
        }
    }

    /// [`SurfacePoint::new`] in the mesh's own space.
    #[inline]
    fn in_mesh_space(
        mesh: &crate::scene::Mesh,
        hit: &crate::accel::Hit,
        material: &crate::scene::Material,
    ) -> SurfacePoint {
        let has_uv = material.needs_uv() && !mesh.uvs.is_empty();
        let color = match &mesh.colors {
            Some(c) if material.textures.base_color_attribute.is_some() => {
                c.at(&mesh.triangles, hit.prim_id as usize, hit.u, hit.v)
            }
            _ => Vec3::ONE,
        };
        if !has_uv && mesh.normals.is_empty() {
            return SurfacePoint {
                uv: Vec2::ZERO,
                normal: None,
                base_normal: None,
                color,
            };
        }
        let [i0, i1, i2] = mesh.triangles[hit.prim_id as usize].map(|i| i as usize);
        let (b1, b2) = (hit.u, hit.v);
        let b0 = 1.0 - b1 - b2;
        let uv = if has_uv {
            let interpolated = || mesh.uvs[i0] * b0 + mesh.uvs[i1] * b1 + mesh.uvs[i2] * b2;
            match mesh.uv_map {
                crate::scene::uv_map::UvMap::Vertices => interpolated(),
                // The round shapes' exact coordinates, from the point on the
                // facet (the same direction from the centre as the sphere's).
                map => {
                    let p =
                        mesh.positions[i0] * b0 + mesh.positions[i1] * b1 + mesh.positions[i2] * b2;
                    map.at(p).unwrap_or_else(interpolated)
                }
            }
        } else {
            Vec2::ZERO
        };
        let normal = if mesh.normals.is_empty() {
            None
        } else {
            (mesh.normals[i0] * b0 + mesh.normals[i1] * b1 + mesh.normals[i2] * b2).try_normalize()
        };
        let base_normal = normal;
        let t = &material.textures;
        let normal = match (&t.normal, &t.bump) {
            (Some(map), _) if has_uv => Self::normal_mapped(
                mesh,
                [i0, i1, i2],
                [b0, b1, b2],
                uv,
                normal,
                map,
                t.normal_frame,
            ),
            (None, Some(height)) if has_uv => {
                Self::bump_mapped(mesh, [i0, i1, i2], uv, normal, height, t.bump_scale)
            }
            _ => normal,
        };
        SurfacePoint {
            uv,
            normal,
            base_normal,
            color,
        }
    }

    /// The shading normal tilted by a normal map at `uv`: the map's
    /// tangent-space direction in a frame around the interpolated normal
    /// `normal` (the triangle's own, by its winding, where there is none).
    /// Where the mesh has tangents (glTF's `TANGENT`), the frame is the
    /// interpolated tangent, made orthogonal to the normal, and the
    /// bitangent `w·(n × t)`; otherwise the triangle's ∂p/∂u and ∂p/∂v
    /// (Gram–Schmidt against the normal, so mirrored texture coordinates
    /// mirror the tilt), or with [`NormalFrame::Tangent`](crate::material::NormalFrame)
    /// ∂p/∂u and `normal × ∂p/∂u` (Mitsuba's). The untilted normal where
    /// the frame is degenerate.
    #[cold]
    pub(crate) fn normal_mapped(
        mesh: &crate::scene::Mesh,
        [i0, i1, i2]: [usize; 3],
        [b0, b1, b2]: [f32; 3],
        uv: Vec2,
        normal: Option<Vec3>,
        map: &crate::texture::ImageTexture,
        frame: crate::material::NormalFrame,
    ) -> Option<Vec3> {
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let (dp1, dp2) = (p1 - p0, p2 - p0);
        let n = normal.or_else(|| dp1.cross(dp2).try_normalize())?;
        if !mesh.tangents.is_empty() {
            let (t0, t1, t2) = (mesh.tangents[i0], mesh.tangents[i1], mesh.tangents[i2]);
            let t = t0.truncate() * b0 + t1.truncate() * b1 + t2.truncate() * b2;
            let Some(t) = (t - n * n.dot(t)).try_normalize() else {
                return Some(n);
            };
            let b = n.cross(t) * if t0.w < 0.0 { -1.0 } else { 1.0 };
            let m = map.eval(uv);
            return (t * m.x + b * m.y + n * m.z).try_normalize().or(Some(n));
        }
        let Some((dpdu, dpdv)) = Self::uv_derivatives(mesh, [i0, i1, i2], dp1, dp2) else {
            return Some(n);
        };
        let Some(t) = (dpdu - n * n.dot(dpdu)).try_normalize() else {
            return Some(n);
        };
        let b = match frame {
            crate::material::NormalFrame::Uv => {
                match (dpdv - n * n.dot(dpdv) - t * t.dot(dpdv)).try_normalize() {
                    Some(b) => b,
                    None => return Some(n),
                }
            }
            crate::material::NormalFrame::Tangent => n.cross(t),
        };
        let m = map.eval(uv);
        (t * m.x + b * m.y + n * m.z).try_normalize().or(Some(n))
    }

    /// The normal of the shading frame: the interpolated normal turned to the
    /// side of `n` (the geometric normal as the BSDF sees it), or `n` itself
    /// where there is none or where `wo` lies on different sides of the two.
    #[inline]
    pub(crate) fn shading_normal(&self, n: Vec3, wo: Vec3) -> Vec3 {
        match self.normal {
            Some(ns) => shading_normal_towards(ns, n, wo),
            None => n,
        }
    }

    /// The shading normal tilted by a height field at `uv` (Mitsuba's
    /// `bumpmap`): with `g = scale·∇h` the height's slopes per unit of u
    /// and v, the surface's derivatives `∂p/∂u`, `∂p/∂v` (the triangle's)
    /// get `g` as their component along the normal `n` (the interpolated
    /// normal, or the triangle's), `∂p/∂u' = ∂p/∂u + n·(g_u − n·∂p/∂u)`,
    /// and the tilted normal is `∂p/∂u' × ∂p/∂v'`, on the triangle's side.
    /// The untilted normal where the texture coordinates are degenerate.
    #[cold]
    pub(crate) fn bump_mapped(
        mesh: &crate::scene::Mesh,
        [i0, i1, i2]: [usize; 3],
        uv: Vec2,
        normal: Option<Vec3>,
        height: &crate::texture::ImageTexture,
        scale: f32,
    ) -> Option<Vec3> {
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let (dp1, dp2) = (p1 - p0, p2 - p0);
        let ng = dp1.cross(dp2).try_normalize()?;
        let n = normal.unwrap_or(ng);
        let Some((dpdu, dpdv)) = Self::uv_derivatives(mesh, [i0, i1, i2], dp1, dp2) else {
            return Some(n);
        };
        let [gu, gv] = height.eval_gradient(uv);
        let (gu, gv) = (
            scale * crate::color::luminance(gu),
            scale * crate::color::luminance(gv),
        );
        let dpdu = dpdu + n * (gu - n.dot(dpdu));
        let dpdv = dpdv + n * (gv - n.dot(dpdv));
        let tilted = dpdu.cross(dpdv).try_normalize()?;
        Some(if tilted.dot(ng) < 0.0 {
            -tilted
        } else {
            tilted
        })
    }

    /// The triangle's `(∂p/∂u, ∂p/∂v)` from its edges `dp1 = p1 − p0`,
    /// `dp2 = p2 − p0` and its texture coordinates; `None` where these are
    /// degenerate.
    #[inline]
    fn uv_derivatives(
        mesh: &crate::scene::Mesh,
        [i0, i1, i2]: [usize; 3],
        dp1: Vec3,
        dp2: Vec3,
    ) -> Option<(Vec3, Vec3)> {
        let (d1, d2) = (mesh.uvs[i1] - mesh.uvs[i0], mesh.uvs[i2] - mesh.uvs[i0]);
        let det = d1.x * d2.y - d1.y * d2.x;
        if det.abs() <= 1e-20 {
            return None;
        }
        Some((
            (dp1 * d2.y - dp2 * d1.y) / det,
            (dp2 * d1.x - dp1 * d2.x) / det,
        ))
    }

    /// The first tangent for anisotropic BSDFs: ∂p/∂u where the mesh has
    /// texture coordinates, else the triangle's first edge.
    pub(crate) fn tangent(on: crate::scene::MeshHit, hit: &crate::accel::Hit) -> Vec3 {
        let t = Self::tangent_in_mesh_space(on.mesh, hit);
        match on.instance {
            None => t,
            Some(i) => i.vector(t),
        }
    }

    /// [`SurfacePoint::tangent`] in the mesh's own space.
    fn tangent_in_mesh_space(mesh: &crate::scene::Mesh, hit: &crate::accel::Hit) -> Vec3 {
        let [i0, i1, i2] = mesh.triangles[hit.prim_id as usize].map(|i| i as usize);
        let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
        let (dp1, dp2) = (p1 - p0, p2 - p0);
        if !mesh.uvs.is_empty() {
            let (d1, d2) = (mesh.uvs[i1] - mesh.uvs[i0], mesh.uvs[i2] - mesh.uvs[i0]);
            let det = d1.x * d2.y - d1.y * d2.x;
            if det.abs() > 1e-12 {
                return (dp1 * d2.y - dp2 * d1.y) / det;
            }
        }
        dp1
    }
}

/// The normal of the shading frame for the interpolated unit normal `ns`:
/// `ns` turned to the side of `n` (the geometric normal as the BSDF sees
/// it), or `n` where `wo` lies on different sides of the two. Branch-free
/// (both integrators call it).
#[inline(always)]
pub(crate) fn shading_normal_towards(ns: Vec3, n: Vec3, wo: Vec3) -> Vec3 {
    let ns = if ns.dot(n) < 0.0 { -ns } else { ns };
    if ns.dot(wo) * n.dot(wo) > 0.0 {
        ns
    } else {
        n
    }
}

/// The shading normal `ns` bent, where it must be, so that the mirror
/// reflection of `wo` about it leaves the surface (whose geometric normal
/// `n` faces `wo`) at least `min(0.9·(n·wo), 0.01)` above it: the
/// reflection is lifted to that height in the plane it spans with `n`, and
/// the new normal is the half vector of `wo` and the lifted reflection
/// (the correction Cycles applies against black rings; unit vectors in,
/// unit vector out).
#[inline]
pub(crate) fn valid_reflection_normal(ns: Vec3, n: Vec3, wo: Vec3) -> Vec3 {
    let cos_o = n.dot(wo);
    if cos_o <= 0.0 {
        return ns;
    }
    let threshold = (0.9 * cos_o).min(0.01);
    let r = 2.0 * ns.dot(wo) * ns - wo;
    if n.dot(r) >= threshold {
        return ns;
    }
    let tangent = (r - n.dot(r) * n)
        .try_normalize()
        .unwrap_or_else(|| n.any_orthonormal_vector());
    let lifted = tangent * (1.0 - threshold * threshold).sqrt() + threshold * n;
    (wo + lifted).try_normalize().unwrap_or(n)
}

/// The scattering vertex a path's current ray left from.
pub(crate) struct PrevVertex {
    /// Scattering events before it (0: the ray is the camera's).
    pub depth: u32,
    /// Solid-angle density of the BSDF sample that chose the ray; 0 after a
    /// delta lobe.
    pub pdf: f32,
    /// Its position.
    pub point: Vec3,
}

/// MIS weight of emission from triangle light `li` at `p` found along `dir`
/// by a BSDF sample (power heuristic against light sampling, which could
/// have found it too); 1 for the camera ray or after a delta lobe.
#[inline]
pub(crate) fn emission_weight(
    scene: &Scene,
    li: usize,
    prev: &PrevVertex,
    p: Vec3,
    dir: Vec3,
) -> f32 {
    if prev.depth == 0 || prev.pdf == 0.0 {
        1.0
    } else {
        let light = &scene.lights().lights[li];
        let light_pdf = scene.lights().pick_pmf(li, prev.point) * light.pdf_li(prev.point, p, dir);
        power_heuristic(prev.pdf, light_pdf)
    }
}

/// MIS weight of the environment (light `env`) seen along a ray that left
/// the scene, whose direction the environment samples with density `pdf()`
/// (asked only when needed): power heuristic against light sampling; 1 for
/// the camera ray or after a delta lobe.
#[inline]
pub(crate) fn environment_weight(
    scene: &Scene,
    env: usize,
    prev: &PrevVertex,
    pdf: impl FnOnce() -> f32,
) -> f32 {
    if prev.depth == 0 || prev.pdf == 0.0 {
        1.0
    } else {
        let light_pdf = scene.lights().pick_pmf(env, prev.point) * pdf();
        power_heuristic(prev.pdf, light_pdf)
    }
}

/// Camera sample `sample` of pixel `(x, y)`: its random stream, after the
/// numbers the filter and (when `lens_sample`) the lens took, and the camera
/// ray, if the camera has one there.
#[inline(always)]
pub(crate) fn camera_sample(
    scene: &Scene,
    seed: u64,
    lens_sample: bool,
    x: u32,
    y: u32,
    sample: u32,
) -> (PathSampler, Option<Ray>) {
    let mut rng = PathSampler::for_sample(seed, x, y, sample);
    // Filter importance sampling: the filter places the sample, which keeps
    // weight 1 (see `crate::filter`).
    let camera = scene.camera();
    // Filters clipped at the border keep samples on the film: the camera's
    // image, or the scene's crop window of it (as Mitsuba's crop does).
    let window = match scene.film().crop {
        Some(c) => [c.x0, c.y0, c.x0 + c.width, c.y0 + c.height],
        None => [0, 0, camera.width(), camera.height()],
    };
    let film =
        Vec2::new(x as f32, y as f32) + scene.film().filter.sample(rng.next_2d(), [x, y], window);
    let lens = if lens_sample {
        rng.next_2d()
    } else {
        Vec2::ZERO
    };
    let ray = camera.generate_ray(film, lens);
    (rng, ray)
}

#[cfg(test)]
mod valid_reflection_tests {
    use super::valid_reflection_normal;
    use glam::Vec3;

    #[test]
    fn reflections_are_lifted_above_the_surface_and_no_more() {
        let n = Vec3::Z;
        let mut lifted = 0;
        for i in 0..40 {
            for j in 0..40 {
                // Viewing directions and shading normals over the upper
                // hemisphere, the normals tilted up to 80 degrees.
                let (a, b) = (i as f32 * 0.157, j as f32 * 0.37);
                let wo = Vec3::new(
                    a.cos() * 0.99,
                    (a * 1.7).sin() * 0.5,
                    0.05 + 0.02 * i as f32,
                )
                .normalize();
                let tilt = (j as f32 / 40.0) * 1.4;
                let ns = Vec3::new(tilt.sin() * b.cos(), tilt.sin() * b.sin(), tilt.cos());
                let bent = valid_reflection_normal(ns, n, wo);
                assert!((bent.length() - 1.0).abs() < 1e-5);
                let r = 2.0 * bent.dot(wo) * bent - wo;
                let threshold = (0.9 * n.dot(wo)).min(0.01);
                assert!(n.dot(r) >= threshold - 1e-4, "wo {wo}, ns {ns}: r {r}");
                let r0 = 2.0 * ns.dot(wo) * ns - wo;
                if n.dot(r0) >= threshold {
                    assert_eq!(bent, ns, "a valid normal is kept");
                } else {
                    lifted += 1;
                    // Bent in the plane of the reflection and the normal:
                    // no further from the original than needed.
                    assert!(bent.dot(n) > 0.0);
                }
            }
        }
        assert!(lifted > 100, "{lifted} normals lifted");
    }
}
