//! Camera response curves in CSV (OpenCV's layout, `hdr merge --response`):
//! a curve of finite, non-decreasing values, or an error naming the file.

/// Checks one input.
pub fn check(data: &[u8]) {
    let path = crate::common::input_file("response.csv", data);
    match plsr_hdr::response::ResponseCurve::read_csv(&path) {
        Err(e) => crate::common::assert_clean_error(&e.to_string(), &["response.csv"]),
        Ok(curve) => {
            for c in 0..curve.channels() {
                let mut last = f32::NEG_INFINITY;
                for i in 0..curve.levels() {
                    let v = curve.eval(c, i as f32 / (curve.levels() - 1).max(1) as f32);
                    assert!(v.is_finite(), "channel {c} level {i}: {v}");
                    assert!(v >= last, "channel {c} decreases at level {i}");
                    last = v;
                }
            }
        }
    }
}
