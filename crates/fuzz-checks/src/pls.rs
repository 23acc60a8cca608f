//! PLS files (docs/pls-format.md), TOML or JSON by the first input byte:
//! lights that tessellate into valid emitters of finite, non-negative
//! radiance, or an error naming the file.

/// Checks one input.
pub fn check(data: &[u8]) {
    let Some((&kind, text)) = data.split_first() else {
        return;
    };
    let name = if kind & 1 == 0 {
        "lights.toml"
    } else {
        "lights.json"
    };
    let path = crate::common::workdir().join(name);
    let Ok(text) = std::str::from_utf8(text) else {
        return;
    };
    let lighting = match plsr::light::pls::file::parse(text, &path) {
        Ok(l) => l,
        Err(e) => return crate::common::assert_clean_error(&e.to_string(), &[name]),
    };
    let nf = 1 + u32::from(kind >> 2);
    for light in &lighting.lights {
        let mesh = plsr::scene::pls_mesh(light, lighting.mode, nf, 0, "fuzz".into());
        assert!(mesh.validate().is_ok(), "{:?}", mesh.validate());
        let e = mesh.emission.unwrap();
        assert!(e.radiance.is_finite() && e.radiance.min_element() >= 0.0);
    }
}
