//! The safe Embree layer: hits, ids, occlusion, batches, and the error path.

use glam::Vec3;
use plsr::accel::{flush_to_zero_enabled, Device, Ray, RayHit, SceneOptions, ShadowRay};
use plsr::rng::Rng;
use plsr::warp::square_to_uniform_sphere;

/// Geometry 7: one triangle in the plane z = 1. Geometry 3: a square
/// [-2, 2]² at z = 3 as two triangles.
fn two_layers(options: SceneOptions) -> plsr::accel::Accel {
    let device = Device::new().unwrap();
    let mut b = device.scene_builder(options).unwrap();
    b.add_triangle_mesh(
        7,
        &[
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ],
        &[[0, 1, 2]],
        plsr::accel::REAL_MASK,
        false,
    )
    .unwrap();
    b.add_triangle_mesh(
        3,
        &[
            Vec3::new(-2.0, -2.0, 3.0),
            Vec3::new(2.0, -2.0, 3.0),
            Vec3::new(2.0, 2.0, 3.0),
            Vec3::new(-2.0, 2.0, 3.0),
        ],
        &[[0, 1, 2], [0, 2, 3]],
        plsr::accel::REAL_MASK,
        false,
    )
    .unwrap();
    b.commit().unwrap()
}

#[test]
fn closest_hit_reports_distance_ids_and_barycentrics() {
    for robust in [false, true] {
        let accel = two_layers(SceneOptions { robust });
        let hit = accel
            .intersect(&Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z))
            .unwrap();
        assert!((hit.t - 1.0).abs() < 1e-6);
        assert_eq!((hit.geom_id, hit.prim_id), (7, 0));
        assert!((hit.u - 0.25).abs() < 1e-5 && (hit.v - 0.25).abs() < 1e-5);
        assert!(hit.ng.normalize().dot(Vec3::Z).abs() > 0.9999);

        // Past the small triangle: the square's second triangle (x < y side).
        let hit = accel
            .intersect(&Ray::new(
                Vec3::new(-1.0, 1.0, 0.0),
                Vec3::new(0.0, 0.0, 2.0),
            ))
            .unwrap();
        assert!(
            (hit.t - 1.5).abs() < 1e-6,
            "t is in units of |dir|: {}",
            hit.t
        );
        assert_eq!((hit.geom_id, hit.prim_id), (3, 1));

        // A ray whose segment ends before the geometry misses.
        let mut r = Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z);
        r.tfar = 0.99;
        assert!(accel.intersect(&r).is_none());
        assert!(accel.intersect(&Ray::new(Vec3::ZERO, -Vec3::Z)).is_none());
    }
}

#[test]
fn occlusion_respects_the_segment() {
    let accel = two_layers(SceneOptions::default());
    let mut r = Ray::new(Vec3::new(0.25, 0.25, 0.0), Vec3::Z);
    r.tfar = 0.999;
    assert!(!accel.occluded(&r));
    r.tfar = 1.001;
    assert!(accel.occluded(&r));
    r.tnear = 1.001;
    r.tfar = 2.9;
    assert!(!accel.occluded(&r));
    r.tfar = 3.1;
    assert!(accel.occluded(&r));
}

#[test]
fn stream_queries_agree_with_single_ray_queries() {
    let accel = two_layers(SceneOptions::default());
    let mut rng = Rng::new(5, 5);
    let rays: Vec<Ray> = (0..2000)
        .map(|_| {
            let o = Vec3::new(
                rng.next_f32() - 0.5,
                rng.next_f32() - 0.5,
                rng.next_f32() * 4.0,
            );
            let mut r = Ray::new(o, square_to_uniform_sphere(rng.next_2d()));
            r.tfar = 1.0 + 3.0 * rng.next_f32();
            r
        })
        .collect();
    for coherent in [false, true] {
        let mut batch: Vec<RayHit> = rays.iter().map(|r| RayHit::new(*r)).collect();
        accel.intersect_stream(&mut batch, coherent);
        let mut shadow: Vec<ShadowRay> = rays.iter().map(|r| ShadowRay::new(*r)).collect();
        accel.occluded_stream(&mut shadow, coherent);
        let mut hits = 0;
        for ((r, b), s) in rays.iter().zip(&batch).zip(&shadow) {
            let single = accel.intersect(r);
            assert_eq!(b.hit(), single);
            assert_eq!(s.occluded(), accel.occluded(r));
            assert_eq!(s.occluded(), single.is_some());
            hits += single.is_some() as u32;
        }
        assert!(
            hits > 100 && hits < 1900,
            "test rays should both hit and miss: {hits}"
        );
    }
}

#[test]
fn embree_errors_become_rust_errors() {
    let device = Device::new().unwrap();
    let mut b = device.scene_builder(SceneOptions::default()).unwrap();
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    b.add_triangle_mesh(0, &tri, &[[0, 1, 2]], plsr::accel::REAL_MASK, false)
        .unwrap();
    // Embree itself rejects a second geometry under a taken id; its error
    // callback's code and message must come back as an error.
    let e = b
        .add_triangle_mesh(0, &tri, &[[0, 1, 2]], plsr::accel::REAL_MASK, false)
        .unwrap_err();
    assert_eq!(e.code, plsr::sys::RTC_ERROR_INVALID_OPERATION, "{e}");
    assert!(e.message.contains("invalid geometry ID"), "{e}");
    assert!(e.message.contains("attaching geometry 0"), "{e}");
    assert!(
        e.message.len() > "attaching geometry 0: ".len(),
        "Embree's message is kept: {e}"
    );
    // Our own checks catch what Embree would read out of bounds.
    let e = b
        .add_triangle_mesh(1, &tri, &[[0, 1, 3]], plsr::accel::REAL_MASK, false)
        .unwrap_err();
    assert!(e.to_string().contains("indexes past the 3 vertices"), "{e}");
    let e = b
        .add_triangle_mesh(
            2,
            &[Vec3::ZERO, Vec3::X, Vec3::NAN],
            &[[0, 1, 2]],
            plsr::accel::REAL_MASK,
            false,
        )
        .unwrap_err();
    assert!(e.to_string().contains("non-finite"), "{e}");
    // The device is still usable after errors.
    b.add_triangle_mesh(4, &tri, &[[0, 1, 2]], plsr::accel::REAL_MASK, false)
        .unwrap();
    let accel = b.commit().unwrap();
    assert!(accel
        .intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z))
        .is_some());
}

#[test]
fn a_bad_device_configuration_is_an_error() {
    let e = Device::with_config("threads=1\0")
        .err()
        .expect("NUL byte rejected");
    assert!(e.message.contains("NUL"));
}

#[test]
fn render_workers_flush_denormals_to_zero() {
    let pool = plsr::render::thread_pool(Some(2)).unwrap();
    let flags: Vec<bool> = pool.broadcast(|_| flush_to_zero_enabled());
    assert_eq!(flags, vec![true, true]);
}

#[test]
fn culled_back_faces_let_rays_through_from_behind_only() {
    let device = Device::new().unwrap();
    let mut b = device.scene_builder(SceneOptions::default()).unwrap();
    // Counter-clockwise seen from +z: its normal (p1 − p0) × (p2 − p0) is +z.
    let tri = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    b.add_triangle_mesh(0, &tri, &[[0, 1, 2]], plsr::accel::REAL_MASK, true)
        .unwrap();
    let accel = b.commit().unwrap();
    let down = Ray::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z);
    let up = Ray::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z);
    assert!(accel.intersect(&down).is_some() && accel.occluded(&down));
    assert!(accel.intersect(&up).is_none() && !accel.occluded(&up));
    // The streamed queries the renderer uses cull the same way.
    let mut rays = [RayHit::new(down), RayHit::new(up)];
    accel.intersect_stream(&mut rays, false);
    assert!(rays[0].hit().is_some() && rays[1].hit().is_none());
    let mut shadows = [ShadowRay::new(down), ShadowRay::new(up)];
    accel.occluded_stream(&mut shadows, false);
    assert!(shadows[0].occluded() && !shadows[1].occluded());
}
