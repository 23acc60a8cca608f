//! Comparing rendered films layer by layer.

use plsr::film::Film;

/// Every layer of a film as flat floats, named.
pub fn layers(f: &Film) -> Vec<(&'static str, Vec<f32>)> {
    let v3 = |v: &[glam::Vec3]| v.iter().flat_map(|c| c.to_array()).collect::<Vec<f32>>();
    vec![
        ("color", v3(&f.color)),
        ("variance", v3(&f.variance)),
        ("normal", v3(&f.normal)),
        ("albedo", v3(&f.albedo)),
        ("alpha", f.alpha.clone()),
        ("depth", f.depth.clone()),
        ("object_id", f.object_id.clone()),
    ]
}

/// Every layer equal within `rel` (relative to the value; 0: bit for bit).
pub fn assert_close(what: &str, a: &Film, b: &Film, rel: f32) {
    assert_eq!(
        (a.width, a.height, a.spp),
        (b.width, b.height, b.spp),
        "{what}"
    );
    for ((name, x), (_, y)) in layers(a).into_iter().zip(layers(b)) {
        for (i, (&p, &q)) in x.iter().zip(&y).enumerate() {
            let ok = if rel == 0.0 {
                p.to_bits() == q.to_bits()
            } else {
                (p - q).abs() <= rel * p.abs().max(q.abs()) + 1e-30
            };
            assert!(ok, "{what}: layer {name} element {i}: {p} vs {q}");
        }
    }
}
