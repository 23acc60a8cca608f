//! glTF animations sampled at one time.
//!
//! plsr renders still images: a file's animations are shown at one time
//! `t` (seconds; 0 by default, a `gltf` shape's `time` otherwise). Each
//! channel sets its node's translation, rotation or scale to its sampler's
//! value at `t`, as glTF 2.0 defines it (§3.11): before the first key the
//! first key's value, after the last the last's; `STEP` holds a key's value
//! until the next, `LINEAR` interpolates (rotations by spherical linear
//! interpolation), `CUBICSPLINE` is the Hermite spline through the keys with
//! their in- and out-tangents scaled by the interval. Morph-target weights
//! are not animated (morph targets are not applied).

use crate::error::FormatError;
use glam::{Quat, Vec3, Vec4};
use gltf::animation::util::ReadOutputs;
use gltf::animation::Property;

/// The animated parts of one node's local transform at the sampled time;
/// `None` where no channel animates that part.
#[derive(Debug, Default, Clone, Copy, PartialEq)]
pub struct NodePose {
    /// Translation (metres).
    pub translation: Option<Vec3>,
    /// Unit rotation quaternion.
    pub rotation: Option<Quat>,
    /// Scale, per axis.
    pub scale: Option<Vec3>,
}

/// How a sampler interpolates between keys.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

/// Every node's pose at time `t` (seconds) under every animation of `doc`
/// (by node index; later channels override earlier ones on the same part).
/// Key times must be finite and increasing; the error names the sampler.
pub fn poses_at(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    t: f32,
) -> std::result::Result<Vec<NodePose>, FormatError> {
    let mut poses = vec![NodePose::default(); doc.nodes().len()];
    for animation in doc.animations() {
        for channel in animation.channels() {
            let field = format!(
                "animations[{}].samplers[{}]",
                animation.index(),
                channel.sampler().index()
            );
            let reader = channel.reader(|b| buffers.get(b.index()).map(|d| &d[..]));
            let times: Vec<f32> = reader
                .read_inputs()
                .ok_or_else(|| format!("{field}.input: cannot be read"))?
                .collect();
            if times.iter().any(|x| !x.is_finite()) || times.windows(2).any(|w| w[1] <= w[0]) {
                return Err(
                    format!("{field}.input: key times are not finite and increasing").into(),
                );
            }
            let interpolation = match channel.sampler().interpolation() {
                gltf::animation::Interpolation::Step => Interpolation::Step,
                gltf::animation::Interpolation::Linear => Interpolation::Linear,
                gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
            };
            let values: Vec<Vec4> = match reader.read_outputs() {
                Some(ReadOutputs::Translations(it)) | Some(ReadOutputs::Scales(it)) => {
                    it.map(|v| Vec3::from_array(v).extend(0.0)).collect()
                }
                Some(ReadOutputs::Rotations(it)) => it.into_f32().map(Vec4::from_array).collect(),
                // Morph-target weights: morph targets are not applied.
                Some(ReadOutputs::MorphTargetWeights(_)) => continue,
                None => return Err(format!("{field}.output: cannot be read").into()),
            };
            let per_key = if interpolation == Interpolation::CubicSpline {
                3
            } else {
                1
            };
            if times.is_empty() || values.len() != times.len() * per_key {
                return Err(format!(
                    "{field}: {} output values for {} key times",
                    values.len(),
                    times.len()
                )
                .into());
            }
            if values.iter().any(|v| !v.is_finite()) {
                return Err(format!("{field}.output: values are not finite").into());
            }
            let node = channel.target().node().index();
            let Some(pose) = poses.get_mut(node) else {
                continue;
            };
            match channel.target().property() {
                Property::Translation => {
                    pose.translation =
                        Some(sample(&times, &values, interpolation, t, false).truncate())
                }
                Property::Scale => {
                    pose.scale = Some(sample(&times, &values, interpolation, t, false).truncate())
                }
                Property::Rotation => {
                    let q = Quat::from_vec4(sample(&times, &values, interpolation, t, true));
                    pose.rotation = Some(q.normalize());
                }
                Property::MorphTargetWeights => {}
            }
        }
    }
    Ok(poses)
}

/// The sampler's value at `t`: `values` holds one value per key (three for
/// a cubic spline: in-tangent, value, out-tangent); `rotation` interpolates
/// quaternions (spherical for `LINEAR`, normalised by the caller).
fn sample(
    times: &[f32],
    values: &[Vec4],
    interpolation: Interpolation,
    t: f32,
    rotation: bool,
) -> Vec4 {
    let value = |k: usize| match interpolation {
        Interpolation::CubicSpline => values[3 * k + 1],
        _ => values[k],
    };
    let last = times.len() - 1;
    if t <= times[0] {
        return value(0);
    }
    if t >= times[last] {
        return value(last);
    }
    // The interval [times[k], times[k + 1]) holding t.
    let k = times.partition_point(|&x| x <= t) - 1;
    let dt = times[k + 1] - times[k];
    let s = (t - times[k]) / dt;
    match interpolation {
        Interpolation::Step => value(k),
        Interpolation::Linear if rotation => {
            let (a, b) = (Quat::from_vec4(value(k)), Quat::from_vec4(value(k + 1)));
            Vec4::from(a.normalize().slerp(b.normalize(), s))
        }
        Interpolation::Linear => value(k).lerp(value(k + 1), s),
        Interpolation::CubicSpline => {
            let (s2, s3) = (s * s, s * s * s);
            let out_tangent = values[3 * k + 2];
            let in_tangent = values[3 * (k + 1)];
            value(k) * (2.0 * s3 - 3.0 * s2 + 1.0)
                + out_tangent * (dt * (s3 - 2.0 * s2 + s))
                + value(k + 1) * (-2.0 * s3 + 3.0 * s2)
                + in_tangent * (dt * (s3 - s2))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f32) -> Vec4 {
        Vec4::new(x, 0.0, 0.0, 0.0)
    }

    #[test]
    fn keys_hold_outside_and_interpolate_inside() {
        let times = [1.0, 2.0, 4.0];
        let values = [v(10.0), v(20.0), v(0.0)];
        let at = |i, t| sample(&times, &values, i, t, false).x;
        // Before the first key and after the last: their values.
        assert_eq!(at(Interpolation::Linear, 0.0), 10.0);
        assert_eq!(at(Interpolation::Linear, 9.0), 0.0);
        assert_eq!(at(Interpolation::Linear, 1.5), 15.0);
        assert_eq!(at(Interpolation::Linear, 3.0), 10.0);
        assert_eq!(at(Interpolation::Step, 1.99), 10.0);
        assert_eq!(at(Interpolation::Step, 2.0), 20.0);
    }

    #[test]
    fn cubic_spline_passes_its_keys_with_their_slopes() {
        // Keys at t = 0 (value 0, slope 1) and t = 2 (value 2, slope 1): the
        // spline is the line x = t.
        let times = [0.0, 2.0];
        let values = [v(1.0), v(0.0), v(1.0), v(1.0), v(2.0), v(1.0)];
        for t in [0.0, 0.5, 1.0, 1.7, 2.0] {
            let x = sample(&times, &values, Interpolation::CubicSpline, t, false).x;
            assert!((x - t).abs() < 1e-6, "t = {t}: {x}");
        }
    }

    #[test]
    fn rotations_interpolate_on_the_sphere() {
        let a = Quat::IDENTITY;
        let b = Quat::from_rotation_y(std::f32::consts::FRAC_PI_2);
        let times = [0.0, 1.0];
        let values = [Vec4::from(a), Vec4::from(b)];
        let q = Quat::from_vec4(sample(&times, &values, Interpolation::Linear, 0.5, true));
        let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
        assert!(q.normalize().angle_between(expected) < 1e-5, "{q}");
    }
}
