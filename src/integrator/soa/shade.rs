//! One bounce of one lane ([`shade_lane`]): the general integrator's
//! `shade` without branches, and its light sample ([`light_sample_lane`]).

use super::*;

/// What is the same for every lane of one bounce.
#[derive(Clone, Copy)]
pub(super) struct Uniform {
    /// Whether paths go on after the light sample (BSDF sampling).
    pub(super) continue_paths: bool,
    /// Whether Russian roulette applies after this bounce.
    pub(super) roulette: bool,
}

/// One lane's inputs to a bounce.
#[derive(Clone, Copy)]
pub(super) struct LaneIn {
    pub(super) org: Vec3,
    pub(super) dir: Vec3,
    /// Hit distance.
    pub(super) t: f32,
    /// Unnormalised geometric normal.
    pub(super) ng: Vec3,
    pub(super) hit: bool,
    /// The interpolated unit normal, where the mesh has vertex normals
    /// (`smooth`).
    pub(super) ns: Vec3,
    pub(super) smooth: bool,
    /// The first tangent, where the lane's material is anisotropic
    /// (`anisotropic`).
    pub(super) tangent: Vec3,
    pub(super) anisotropic: bool,
    pub(super) beta: Vec3,
    pub(super) eta_scale: f32,
    /// The path's draws so far and its fixed stream.
    pub(super) rng: u32,
    pub(super) stream: SampleStream,
    pub(super) light: LightIn,
    /// The lane's sample of the environment, where it picked it.
    pub(super) env_valid: bool,
    pub(super) env_wi: Vec3,
    pub(super) env_radiance: Vec3,
    pub(super) env_pdf: f32,
}

/// One lane's results of a bounce.
#[derive(Clone, Copy)]
pub(super) struct LaneOut {
    /// Whether the path goes on (then `next_org`, `next_dir` hold its ray).
    pub(super) alive: bool,
    pub(super) next_org: Vec3,
    pub(super) next_dir: Vec3,
    /// Whether a shadow ray is to be traced (`shadow_*` hold it).
    pub(super) shadow: bool,
    pub(super) shadow_org: Vec3,
    pub(super) shadow_dir: Vec3,
    pub(super) shadow_tfar: f32,
    /// Radiance the shadow ray adds if unoccluded.
    pub(super) pending: Vec3,
    pub(super) beta: Vec3,
    /// Density of the BSDF sample (for the MIS weight of emission found by
    /// the next ray) and the point it left from.
    pub(super) pdf: f32,
    pub(super) point: Vec3,
    /// The path's draws so far.
    pub(super) rng: u32,
    /// The path's η² after this bounce (see [`LaneBsdf::eta_scale`]).
    pub(super) eta_scale: f32,
    /// Where the BSDF was evaluated, in its local frame: `[wo, the light
    /// sample's wi, the sampled wi]` (placeholders where there was none);
    /// read only by [`shade_staged_lanes`], and so not computed elsewhere.
    pub(super) evaluated: [Vec3; 3],
}

/// One bounce of one path: the general integrator's `shade` for a surface
/// whose BSDF the lane holds (`B`: Lambert, rough Cook–Torrance, principled,
/// Blinn–Phong, a rough or smooth dielectric) and a point, area, parametric
/// or environment light, written without
/// branches (every `if` is a select) so that a loop over lanes vectorises.
/// It calls the same branch-free helpers as the general integrator (ray
/// offsets, the lights' samples, the BSDF's own code, MIS), in the same
/// order, with the same random numbers.
#[inline(always)]
pub(super) fn shade_lane<
    B: LaneBsdf,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
    const ANISO: bool,
>(
    l: LaneIn,
    bsdf: B,
    u: Uniform,
) -> LaneOut {
    let mut rng = l.rng;
    let p = l.org + l.t * l.dir;
    let wo = -l.dir;
    let ng = l.ng.normalize_or_zero();
    // Opaque surfaces are two-sided: shaded in the frame facing the viewer.
    // A transmissive one keeps the geometric normal as its outside.
    let n = if B::TRANSMITS || ng.dot(wo) >= 0.0 {
        ng
    } else {
        -ng
    };
    // A shading normal bends the frame; directions on different sides for
    // it and for the geometric normal are rejected (the light-leak guard).
    let smooth = l.smooth;
    let shading_n = if smooth {
        shading_normal_towards(l.ns, n, wo)
    } else {
        n
    };
    // An anisotropic surface's frame follows its tangent (as the general
    // integrator's `SurfaceHit::frame`); `ANISO`: whether any lane of the
    // chunk has one (otherwise the tangent frame is not even computed).
    let frame = if ANISO && B::MAY_BE_ANISOTROPIC && l.anisotropic {
        Frame::from_normal_tangent(shading_n, l.tangent)
    } else {
        Frame::from_normal(shading_n)
    };
    let wo_local = frame.to_local(wo);
    let eps = ray_epsilon(p);
    // Reflected rays leave on the side of `n`; a transmissive BSDF's leave
    // on the side of their direction.
    let origin_for = |dir: Vec3| {
        if B::TRANSMITS {
            spawn_origin(p, n, eps, dir)
        } else {
            p + n * eps
        }
    };

    // The numbers of one bounce, in the general integrator's order: two
    // pick the light (`pick_lights` drew the pick from them already, or
    // there is one light), two place the sample on it (unused by a point
    // light), one picks the BSDF's lobe (principled's diffuse or specular),
    // two the direction.
    // Where no light was picked, the general integrator draws no numbers
    // for a light sample: drawn on a copy, kept where a light was picked.
    // A delta BSDF takes no light sample: none of these numbers is drawn.
    let light = l.light;
    let mut rng_light = rng;
    let _light_pick = PathSampler::step_2d(&mut rng_light, l.stream);
    let mut rng_point = rng_light;
    let light_point = PathSampler::step_2d(&mut rng_point, l.stream);
    if !B::DELTA {
        rng = if light.picked { rng_point } else { rng_light };
    }
    let lobe = PathSampler::step_f32(&mut rng, l.stream);
    let direction = PathSampler::step_2d(&mut rng, l.stream);

    // Next-event estimation (a delta BSDF takes no light sample).
    let shadow = if B::DELTA {
        LightSampleOut {
            shadow: false,
            org: p,
            dir: Vec3::Z,
            tfar: f32::NEG_INFINITY,
            pending: Vec3::ZERO,
            wi_local: Vec3::Z,
        }
    } else {
        light_sample_lane::<B, TRIANGLES, CONES, ENV>(
            &l,
            &bsdf,
            LaneFrame {
                p,
                wo,
                ng,
                n,
                frame,
                wo_local,
                smooth,
                eps,
            },
            light_point,
        )
    };

    let (sampled, local, pdf, factor) = bsdf.sample(wo_local, lobe, direction);
    // A delta lobe's density is recorded as 0 (no MIS for what it finds).
    let pdf = if B::DELTA { 0.0 } else { pdf };
    let next_dir = frame.to_world(local);
    // Where the guard rejects the direction, the path ends.
    let sampled = sampled && (!smooth || sides_agree(wo, next_dir, ng, wo_local, local));
    let mut beta = l.beta * factor;
    // The path's η² of its refractions, this one's included (as the
    // general integrator keeps it, only for a sampled direction).
    let eta_scale = if B::TRANSMITS && sampled {
        l.eta_scale * bsdf.eta_scale(wo_local, local)
    } else {
        l.eta_scale
    };

    // Russian roulette draws a number only where it spins: drawn from a
    // copy of the state, kept where it spins.
    let rr_beta = beta * eta_scale;
    let spin = roulette_spins(rr_beta, u.roulette);
    let mut rng_rr = rng;
    let (survives, beta_rr) = roulette(beta, rr_beta, PathSampler::step_f32(&mut rng_rr, l.stream));
    if spin {
        rng = rng_rr;
        beta = beta_rr;
    }
    let survived = !spin || survives;
    let alive = l.hit && u.continue_paths && sampled && survived && beta != Vec3::ZERO;
    LaneOut {
        alive,
        next_org: origin_for(next_dir),
        next_dir,
        shadow: shadow.shadow,
        shadow_org: shadow.org,
        shadow_dir: shadow.dir,
        shadow_tfar: shadow.tfar,
        pending: shadow.pending,
        beta,
        pdf,
        point: p,
        rng,
        eta_scale,
        evaluated: [wo_local, shadow.wi_local, local],
    }
}

/// A lane's light sample: the shadow ray to trace (`shadow`: whether to
/// trace one) and the radiance it adds if unoccluded.
#[derive(Clone, Copy)]
pub(super) struct LightSampleOut {
    pub(super) shadow: bool,
    pub(super) org: Vec3,
    pub(super) dir: Vec3,
    pub(super) tfar: f32,
    pub(super) pending: Vec3,
    /// The light sample's direction in the shading frame.
    pub(super) wi_local: Vec3,
}

/// Where a lane scatters, as [`shade_lane`] computed it: the point, the
/// outgoing direction, the (unit) geometric normal, the side's normal `n`,
/// the shading frame, `wo` in it, whether the shading normal bends the
/// frame (`smooth`) and the ray offset.
#[derive(Clone, Copy)]
pub(super) struct LaneFrame {
    pub(super) p: Vec3,
    pub(super) wo: Vec3,
    pub(super) ng: Vec3,
    pub(super) n: Vec3,
    pub(super) frame: Frame,
    pub(super) wo_local: Vec3,
    pub(super) smooth: bool,
    pub(super) eps: f32,
}

/// The light sample of [`shade_lane`] (not for a delta BSDF): the picked
/// light's sample at the two numbers `light_point`, the BSDF's value and
/// density there, the MIS weight and the shadow ray, as the general
/// integrator's `scatter` computes them.
#[inline(always)]
pub(super) fn light_sample_lane<
    B: LaneBsdf,
    const TRIANGLES: bool,
    const CONES: bool,
    const ENV: bool,
>(
    l: &LaneIn,
    bsdf: &B,
    at: LaneFrame,
    light_point: Vec2,
) -> LightSampleOut {
    let LaneFrame {
        p,
        wo,
        ng,
        n,
        frame,
        wo_local,
        smooth,
        eps,
    } = at;
    let light = l.light;
    let origin_for = |dir: Vec3| {
        if B::TRANSMITS {
            spawn_origin(p, n, eps, dir)
        } else {
            p + n * eps
        }
    };
    // Every kind's sample, computed for every lane and selected (the
    // triangle's only where the scene has emitting triangles, the
    // environment's, taken by `sample_environment`, where it has one).
    let (valid, ls) = if ENV && light.environment {
        let sample = LightSample {
            radiance: l.env_radiance,
            wi: l.env_wi,
            dist: f32::INFINITY,
            pdf: l.env_pdf,
            delta: false,
        };
        (l.env_valid, sample)
    } else if TRIANGLES && light.triangle {
        let point = TrianglePoint::new(light.p, light.n, light.area, p, light_point);
        point.sample(light.emitted::<CONES>(-point.wi))
    } else {
        point_light_sample(light.p[0], light.emit, p)
    };
    let wi_local = frame.to_local(ls.wi);
    let leaks = smooth && !sides_agree(wo, ls.wi, ng, wo_local, wi_local);
    // A delta light (a point light) needs no MIS weight: the general
    // integrator evaluates the BSDF alone there, and `eval_pdf` elsewhere.
    let delta_light = !((TRIANGLES && light.triangle) || (ENV && light.environment));
    let (f, bsdf_pdf) = bsdf.eval_pdf(wo_local, wi_local);
    let f = if delta_light {
        bsdf.eval(wo_local, wi_local)
    } else {
        f
    };
    let (f, bsdf_pdf) = if leaks {
        (Vec3::ZERO, 0.0)
    } else {
        (f, bsdf_pdf)
    };
    let f = f * wi_local.z.abs();
    let light_pdf = light.pmf * ls.pdf;
    // A point light is a delta light: no MIS.
    let weight = if (TRIANGLES && light.triangle) || (ENV && light.environment) {
        power_heuristic(light_pdf, bsdf_pdf)
    } else {
        1.0
    };
    let shadow_org = origin_for(ls.wi);
    let (shadow_dir, shadow_tfar) = shadow_segment(shadow_org, p, ls.wi, ls.dist);
    LightSampleOut {
        shadow: l.hit && light.picked && valid && f != Vec3::ZERO && shadow_tfar > 0.0,
        org: shadow_org,
        dir: shadow_dir,
        tfar: shadow_tfar,
        pending: l.beta * f * ls.radiance * (weight / light_pdf),
        wi_local,
    }
}
