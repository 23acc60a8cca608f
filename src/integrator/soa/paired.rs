//! Compositing's pair of renders in one wavefront: the render with the
//! virtual objects (W) and the one without them (O), sample for sample
//! what two renders with the same seed give, bit for bit.
//!
//! A path's random numbers depend only on its pixel, sample and draw
//! index, and every step of the path tracer is a pure function of the
//! path's state, but for the ray queries. So a path is the same in both
//! renders until a query answers otherwise without the virtual objects:
//! - a closest hit differs exactly where W's hit is on a virtual object
//!   (masks only remove candidates: a real closest hit stays the closest);
//!   there the path **forks** ([`fork_virtual_hits`]): the lane goes on as
//!   W's only, and a copy of its state, its ray as it was before the query
//!   and O's radiance so far, becomes an O-only lane traced without the
//!   virtual objects ([`PairedLanes`]);
//! - a shadow ray that reaches its light in W reaches it in O; one that is
//!   blocked is asked again without the virtual objects only where its
//!   segment meets a virtual object's bounds ([`requery_shadows`]); a
//!   shadow ray does not change the path, only what it adds.
//!
//! So a *shared* lane carries both renders (two radiance sums), and every
//! pass still adds one W value and one O value to each pixel, in sample
//! order: both films sum exactly as two renders do.

use super::*;
use crate::accel::{Ray, REAL_MASK};

/// The O-only lanes of a paired render (paths that forked from a shared
/// one), reused from pass to pass.
#[derive(Default)]
pub struct PairedLanes {
    pub(super) o: SoaLanes,
}

/// The pair of a paired tile pass: its O-only lanes and the pixels of the
/// render without the virtual objects.
pub struct PairPass<'a> {
    /// The O-only lanes.
    pub lanes: &'a mut PairedLanes,
    /// The tile's sums of the render without the virtual objects.
    pub pixels: &'a mut [PixelSums],
}

/// Marks every lane of a new pass shared, with no radiance yet in either
/// render, and empties the O-only lanes.
#[inline(always)]
pub(super) fn start_shared(lanes: &mut SoaLanes, pair: &mut PairPass) {
    lanes.shared.fill(true);
    for c in 0..3 {
        lanes.radiance_o[c].fill(0.0);
    }
    let o = &mut pair.lanes.o;
    o.paired = false;
    o.kept.clear();
    o.retain(false);
}

/// Forks every shared lane whose ray has just hit a virtual object: the lane
/// becomes W's only, and a copy (the ray as it was before the query, the
/// path's state, O's radiance) is appended to `o`, not yet traced. Returns
/// the number of forks.
#[inline(always)]
pub(super) fn fork_virtual_hits(
    kernel: &SoaScene,
    lanes: &mut SoaLanes,
    o: &mut SoaLanes,
) -> usize {
    let last = kernel.is_virtual.len() - 1;
    let geom = lanes.rays.geom_id.as_slice();
    lanes.requery_lanes.clear();
    for (i, &g) in geom.iter().enumerate() {
        if g != INVALID_ID && lanes.shared[i] && kernel.is_virtual[(g as usize).min(last)] {
            lanes.requery_lanes.push(i as u32);
        }
    }
    let start = o.rays.len();
    o.resize(start + lanes.requery_lanes.len());
    for (j, &i) in lanes.requery_lanes.iter().enumerate() {
        let (i, j) = (i as usize, start + j);
        lanes.shared[i] = false;
        let ray = Ray {
            tfar: lanes.tfar_before[i],
            ..lanes.rays.ray(i)
        };
        o.rays.set(j, ray);
        o.pixel[j] = lanes.pixel[i];
        o.rng_dim[j] = lanes.rng_dim[i];
        for part in 0..3 {
            o.rng_stream[part][j] = lanes.rng_stream[part][i];
        }
        o.eta_scale[j] = lanes.eta_scale[i];
        o.prev_pdf[j] = lanes.prev_pdf[i];
        for c in 0..3 {
            o.beta[c][j] = lanes.beta[c][i];
            o.radiance[c][j] = lanes.radiance_o[c][i];
            o.prev_point[c][j] = lanes.prev_point[c][i];
        }
    }
    lanes.requery_lanes.len()
}

/// After the occlusion query of a paired render's lanes (`shadow_before`
/// holding their `tfar` before it), decides for each shadow ray whether it
/// reaches its light without the virtual objects (`open_o`): where it does
/// with them, or, for a shared lane's blocked ray whose segment meets a
/// virtual object's bounds, by asking Embree again without them. Returns
/// the number asked again.
#[inline(always)]
pub(super) fn requery_shadows(kernel: &SoaScene, scene: &Scene, lanes: &mut SoaLanes) -> usize {
    let n = lanes.shadow.len();
    lanes.requery_lanes.clear();
    for start in (0..n).step_by(W) {
        // Which lanes are candidates, for a chunk at once: most are not.
        let after = load(lanes.shadow.tfar.as_slice(), start);
        let before = load(&lanes.shadow_before, start);
        let shared = load(&lanes.shared, start);
        let mut open = [false; W];
        let mut candidate = [false; W];
        for k in 0..W {
            open[k] = after[k] > 0.0;
            candidate[k] = !open[k] & shared[k] & (before[k] > 0.0);
        }
        store(&mut lanes.open_o, start, &open);
        if !candidate.contains(&true) {
            continue;
        }
        for k in 0..(n - start).min(W) {
            if !candidate[k] {
                continue;
            }
            let i = start + k;
            let ray = Ray {
                tfar: before[k],
                ..lanes.shadow.ray(i)
            };
            if kernel
                .virtual_bounds
                .iter()
                .any(|&(lo, hi)| segment_meets_box(&ray, lo, hi))
            {
                lanes.requery_lanes.push(i as u32);
            }
        }
    }
    let m = lanes.requery_lanes.len();
    if m == 0 {
        return 0;
    }
    lanes.requery.resize(m);
    for (j, &i) in lanes.requery_lanes.iter().enumerate() {
        let i = i as usize;
        let ray = Ray {
            tfar: lanes.shadow_before[i],
            ..lanes.shadow.ray(i)
        };
        lanes.requery.set(j, ray);
    }
    lanes.requery.set_mask(REAL_MASK);
    scene.accel().occluded_batch(&mut lanes.requery, false);
    for (j, &i) in lanes.requery_lanes.iter().enumerate() {
        lanes.open_o[i as usize] = lanes.requery.tfar.as_slice()[j] > 0.0;
    }
    m
}

/// The box `lo..hi` grown by 10⁻⁴ of its size and distance from the
/// origin: a box of a virtual object's vertices, padded so that a hit
/// Embree reports on one of its triangles, rounded as it is, lies inside.
pub(super) fn padded_box(lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let scale = lo.abs().max(hi.abs()).max_element() + (hi - lo).max_element();
    let pad = 1e-4 * scale + 1e-6;
    (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
}

/// Whether the segment `[tnear, tfar]` of `ray` may meet the box `lo..hi`:
/// a slab test in `f64` over the segment lengthened by 10⁻⁴ of itself at
/// both ends (one that meets the box is never missed; one that passes
/// within rounding of it may count as meeting it). A NaN anywhere counts
/// as meeting.
pub(super) fn segment_meets_box(ray: &Ray, lo: Vec3, hi: Vec3) -> bool {
    let (tnear, tfar) = (ray.tnear as f64, ray.tfar as f64);
    let (mut t0, mut t1) = (tnear - 1e-4 * tnear.abs(), tfar + 1e-4 * tfar.abs());
    if t0.is_nan() || t1.is_nan() {
        return true;
    }
    for a in 0..3 {
        let (o, d) = (ray.org[a] as f64, ray.dir[a] as f64);
        let (l, h) = (lo[a] as f64, hi[a] as f64);
        if o.is_nan() || d.is_nan() || l.is_nan() || h.is_nan() {
            return true;
        }
        if d == 0.0 {
            if o < l || o > h {
                return false;
            }
            continue;
        }
        let (mut near, mut far) = ((l - o) / d, (h - o) / d);
        if near > far {
            std::mem::swap(&mut near, &mut far);
        }
        t0 = t0.max(near);
        t1 = t1.min(far);
        if t0 > t1 {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn segment(org: Vec3, dir: Vec3, tfar: f32) -> Ray {
        Ray {
            org,
            dir,
            tnear: 0.0,
            tfar,
        }
    }

    #[test]
    fn a_segment_meets_a_box_it_crosses_touches_or_ends_in() {
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        // Through the middle, along an axis (two direction components 0).
        assert!(segment_meets_box(
            &segment(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 10.0),
            lo,
            hi
        ));
        // Grazing a face and an edge exactly.
        assert!(segment_meets_box(
            &segment(Vec3::new(-5.0, 1.0, 0.0), Vec3::X, 10.0),
            lo,
            hi
        ));
        assert!(segment_meets_box(
            &segment(Vec3::new(-5.0, 1.0, 1.0), Vec3::X, 10.0),
            lo,
            hi
        ));
        // Ending inside, starting inside, ending on the face.
        assert!(segment_meets_box(
            &segment(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 4.5),
            lo,
            hi
        ));
        assert!(segment_meets_box(
            &segment(Vec3::ZERO, Vec3::Y, 0.1),
            lo,
            hi
        ));
        assert!(segment_meets_box(
            &segment(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 4.0),
            lo,
            hi
        ));
        // A diagonal through a corner.
        let d = Vec3::ONE.normalize();
        assert!(segment_meets_box(
            &segment(Vec3::splat(-3.0), d, 10.0),
            lo,
            hi
        ));
        // An infinite segment, and a non-unit direction.
        assert!(segment_meets_box(
            &segment(Vec3::new(0.5, -9.0, 0.5), Vec3::Y * 3.0, f32::INFINITY),
            lo,
            hi
        ));
        // NaN counts as meeting.
        assert!(segment_meets_box(
            &segment(Vec3::new(9.0, 9.0, 9.0), Vec3::new(f32::NAN, 0.0, 0.0), 1.0),
            lo,
            hi
        ));
    }

    #[test]
    fn a_segment_misses_a_box_it_stops_short_of_or_passes_by() {
        let (lo, hi) = (Vec3::splat(-1.0), Vec3::splat(1.0));
        assert!(!segment_meets_box(
            &segment(Vec3::new(-5.0, 0.0, 0.0), Vec3::X, 3.99),
            lo,
            hi
        ));
        assert!(!segment_meets_box(
            &segment(Vec3::new(-5.0, 0.0, 0.0), -Vec3::X, 100.0),
            lo,
            hi
        ));
        assert!(!segment_meets_box(
            &segment(Vec3::new(-5.0, 1.01, 0.0), Vec3::X, 10.0),
            lo,
            hi
        ));
        // Parallel to a slab, outside it.
        assert!(!segment_meets_box(
            &segment(Vec3::new(0.0, 2.0, -5.0), Vec3::Z, 10.0),
            lo,
            hi
        ));
        // Past both corners' diagonal.
        let d = Vec3::new(1.0, -1.0, 0.0).normalize();
        assert!(!segment_meets_box(
            &segment(Vec3::new(0.0, 3.1, 0.0), d, 10.0),
            lo,
            hi
        ));
    }

    #[test]
    fn random_segments_that_pass_through_a_box_point_meet_it() {
        // Segments built through a point of the box (on its surface too)
        // must meet it, whatever their direction and length beyond.
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (lo, hi) = (Vec3::new(-0.3, 0.2, 1.0), Vec3::new(0.7, 0.25, 4.0));
        let (plo, phi) = padded_box(lo, hi);
        assert!(plo.cmplt(lo).all() && phi.cmpgt(hi).all());
        for _ in 0..100_000 {
            let mut inside = lo + (hi - lo) * Vec3::new(next(), next(), next());
            // A third of the points on a face.
            let face = (next() * 9.0) as usize;
            if face < 6 {
                inside[face % 3] = if face < 3 { lo[face % 3] } else { hi[face % 3] };
            }
            let dir = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5);
            if dir.length() < 1e-3 {
                continue;
            }
            let t = 0.1 + 10.0 * next();
            let org = inside - t * dir;
            // Ending at the point (as a shadow ray ends at its light).
            let ray = Ray {
                org,
                dir,
                tnear: 0.0,
                tfar: t,
            };
            assert!(segment_meets_box(&ray, plo, phi), "{ray:?}");
        }
    }
}
