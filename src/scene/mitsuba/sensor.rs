//! Sensors: `perspective`, `thinlens` and `orthographic` cameras with
//! their `hdrfilm`, pixel filter and sampler.

use super::document::Element;
use super::table::{dvec, float, Table};
use super::translator::{Params, Translator};
use crate::error::Result;
use glam::{DMat4, DVec3};
use toml::Value;

/// Mitsuba's field of view without `fov` or `focal_length`: its default
/// 50 mm lens, `2·atan(18/50)`, horizontal.
pub(super) const DEFAULT_HFOV_DEG: f64 = 39.597_752_709_049_864;

impl<'a> Translator<'a> {
    pub(super) fn sensor(&mut self, node: &'a Element) -> Result<()> {
        let kind = self.required_attr(node, "type")?;
        let mut camera = Table::new();
        match kind.as_str() {
            "perspective" => {}
            "thinlens" => {
                camera.insert("type", Value::String("thin_lens".into()));
            }
            "orthographic" => {
                camera.insert("type", Value::String("orthographic".into()));
            }
            other => {
                return Err(self.err(
                    node,
                    format!(
                        "the `{other}` sensor is not supported (supported: perspective, \
                         thinlens, orthographic)"
                    ),
                ))
            }
        }
        let mut p = self.params(node)?;
        // The film, filter and sampler first: the field of view needs the size.
        let mut settings = SensorSettings::default();
        for c in node
            .children
            .iter()
            .filter(|c| c.attribute("name").is_none())
        {
            let c = self.deref(c)?;
            match c.tag.as_str() {
                "film" => self.sensor_film(c, &mut settings)?,
                "sampler" => self.sensor_sampler(c, &mut settings)?,
                other => return Err(self.err(c, format!("<{other}> is not supported in a sensor"))),
            }
        }
        let SensorSettings {
            width,
            height,
            filter,
            spp,
            seed,
            sample_border,
            crop,
        } = settings;
        if !(1..=65536).contains(&width) || !(1..=65536).contains(&height) {
            return Err(self.err(
                node,
                format!("the film's size {width} × {height} is out of range"),
            ));
        }
        camera.insert(
            "resolution",
            Value::Array(vec![Value::Integer(width), Value::Integer(height)]),
        );
        if let Some(c) = crop {
            self.film.insert(
                "crop",
                Value::Array(c.iter().map(|&v| Value::Integer(v)).collect()),
            );
        }
        self.render.insert("spp", Value::Integer(spp));
        if let Some(seed) = seed {
            self.render.insert("seed", Value::Integer(seed));
        }
        let border = |film: &mut Table| {
            // Mitsuba's films take samples on the film only unless
            // `sample_border` is set: edge pixels average what is inside.
            let border = if sample_border { "extend" } else { "clip" };
            film.insert("filter_border", Value::String(border.into()));
        };
        match filter {
            SensorFilter::Box => {}
            SensorFilter::Gaussian(sigma) => {
                self.film.insert("filter", Value::String("gaussian".into()));
                self.film.insert("filter_sigma", float(sigma));
                // Mitsuba cuts its Gaussian at 4 σ.
                self.film
                    .insert("filter_radius", float((4.0 * sigma).min(64.0)));
                border(&mut self.film);
            }
            SensorFilter::Tent(radius) => {
                self.film.insert("filter", Value::String("tent".into()));
                self.film.insert("filter_radius", float(radius));
                border(&mut self.film);
            }
        }

        let to_world = self.sensor_pose(node, &mut p, &mut camera)?;
        if kind == "orthographic" {
            // The view spans [−1, 1] across and [−1/a, 1/a] down, times
            // to_world's scale; rays start on the near plane.
            let near = self.take_float(&mut p, "near_clip")?.unwrap_or(1e-2);
            let sx = to_world.transform_vector3(DVec3::X).length();
            let sy = to_world.transform_vector3(DVec3::Y).length();
            let aspect = width as f64 / height as f64;
            camera.insert("view_width", float(2.0 * sx));
            camera.insert("view_height", float(2.0 * sy / aspect));
            let start = to_world.transform_point3(DVec3::new(0.0, 0.0, near));
            let forward = to_world.transform_vector3(DVec3::Z).normalize();
            camera.insert("position", dvec(start));
            camera.insert("look_at", dvec(start + forward));
        } else {
            self.sensor_fov(node, &mut p, (width as f64, height as f64), &mut camera)?;
        }
        for s in ["principal_point_offset_x", "principal_point_offset_y"] {
            if let Some(v) = self.take_float(&mut p, s)? {
                if v != 0.0 {
                    return Err(self.err(node, format!("`{s}` is not supported")));
                }
            }
        }
        // Mitsuba's projective cameras all read a focus distance (default:
        // the far clip plane); only a thin lens uses it.
        let far_clip = self.take_float(&mut p, "far_clip")?.unwrap_or(1e4);
        let focus = self
            .take_float(&mut p, "focus_distance")?
            .unwrap_or(far_clip);
        if kind == "thinlens" {
            let r = self.take_float(&mut p, "aperture_radius")?.unwrap_or(1.0);
            camera.insert("aperture_radius", float(r));
            if focus <= 0.0 || focus.is_nan() {
                return Err(self.err(node, format!("focus_distance = {focus} must be positive")));
            }
            camera.insert("focus_distance", float(focus));
        }
        if let Some(s) = self.take_float(&mut p, "shutter_close")? {
            if s != 0.0 {
                self.note(node, "shutter_close: plsr renders no motion blur");
            }
        }
        self.leftovers(&p)?;
        self.camera = Some(camera);
        Ok(())
    }

    /// A sensor's `<film>`: its size, and its `<rfilter>` children.
    pub(super) fn sensor_film(
        &mut self,
        c: &'a Element,
        settings: &mut SensorSettings,
    ) -> Result<()> {
        let film_kind = self.required_attr(c, "type")?;
        if film_kind != "hdrfilm" {
            return Err(self.err(
                c,
                format!("the `{film_kind}` film is not supported (supported: hdrfilm)"),
            ));
        }
        let mut f = self.params(c)?;
        settings.width = self.take_int(&mut f, "width")?.unwrap_or(settings.width);
        settings.height = self.take_int(&mut f, "height")?.unwrap_or(settings.height);
        // Mitsuba's crop window: offset and size, within the film.
        let crop = [
            self.take_int(&mut f, "crop_offset_x")?,
            self.take_int(&mut f, "crop_offset_y")?,
            self.take_int(&mut f, "crop_width")?,
            self.take_int(&mut f, "crop_height")?,
        ];
        settings.crop = if crop.iter().all(Option::is_none) {
            None
        } else {
            let (w, h) = (settings.width, settings.height);
            let [ox, oy] = [crop[0].unwrap_or(0), crop[1].unwrap_or(0)];
            let [cw, ch] = [crop[2].unwrap_or(w), crop[3].unwrap_or(h)];
            if ox < 0 || oy < 0 || cw < 1 || ch < 1 || ox + cw > w || oy + ch > h {
                return Err(self.err(
                    c,
                    format!(
                        "the crop window {cw} × {ch} at ({ox}, {oy}) does not lie inside the \
                         {w} × {h} film"
                    ),
                ));
            }
            Some([ox, oy, ox + cw, oy + ch])
        };
        settings.sample_border = self.take_bool(&mut f, "sample_border")?.unwrap_or(false);
        self.leftovers(&f)?;
        for r in c.children.iter().filter(|r| r.attribute("name").is_none()) {
            if r.tag.as_str() != "rfilter" {
                return Err(self.err(r, "not supported inside a film"));
            }
            self.sensor_filter(r, settings)?;
        }
        Ok(())
    }

    /// A film's `<rfilter>`: box, Gaussian or tent (others become the
    /// default Gaussian, with a note).
    pub(super) fn sensor_filter(
        &mut self,
        r: &'a Element,
        settings: &mut SensorSettings,
    ) -> Result<()> {
        let rk = self.required_attr(r, "type")?;
        let mut rp = self.params(r)?;
        match rk.as_str() {
            "box" => settings.filter = SensorFilter::Box,
            "gaussian" => {
                let sigma = self.take_float(&mut rp, "stddev")?.unwrap_or(0.5);
                if !(sigma > 0.0 && sigma <= 16.0) {
                    return Err(self.err(
                        r,
                        format!("`stddev` must be in (0, 16] pixels, got {sigma}"),
                    ));
                }
                settings.filter = SensorFilter::Gaussian(sigma);
            }
            "tent" => {
                let radius = self.take_float(&mut rp, "radius")?.unwrap_or(1.0);
                if !(radius > 0.0 && radius <= 64.0) {
                    return Err(self.err(
                        r,
                        format!("`radius` must be in (0, 64] pixels, got {radius}"),
                    ));
                }
                settings.filter = SensorFilter::Tent(radius);
            }
            other => {
                self.note(
                    r,
                    format!(
                        "the `{other}` pixel filter is rendered with a Gaussian \
                         of σ 0.5 px (plsr has box, gaussian and tent)"
                    ),
                );
                rp.used.extend(rp.named.iter().map(|(n, _)| n.clone()));
            }
        }
        self.leftovers(&rp)?;
        Ok(())
    }

    /// A sensor's `<sampler>`: the sample count and seed.
    pub(super) fn sensor_sampler(
        &mut self,
        c: &'a Element,
        settings: &mut SensorSettings,
    ) -> Result<()> {
        let mut s = self.params(c)?;
        let sk = self.attr(c, "type")?.unwrap_or_default();
        if !matches!(
            sk.as_str(),
            "independent" | "stratified" | "multijitter" | "ldsampler" | "orthogonal"
        ) {
            return Err(self.err(c, format!("the `{sk}` sampler is not known")));
        }
        if sk != "independent" {
            self.note(
                c,
                format!(
                    "the `{sk}` sampler: plsr uses its own stratified samples \
                     (the sample count is kept)"
                ),
            );
        }
        settings.spp = self
            .take_int(&mut s, "sample_count")?
            .unwrap_or(settings.spp);
        settings.seed = self.take_int(&mut s, "seed")?;
        for ignored in ["jitter", "scramble", "strength"] {
            self.take(&mut s, ignored);
        }
        self.leftovers(&s)?;
        Ok(())
    }

    /// The sensor's pose from its `to_world`: position, look-at point, up;
    /// returns `to_world`.
    pub(super) fn sensor_pose(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        camera: &mut Table,
    ) -> Result<DMat4> {
        let m = self
            .take_transform(p, "to_world")?
            .unwrap_or(DMat4::IDENTITY);
        let position = m.transform_point3(DVec3::ZERO);
        let forward = m.transform_vector3(DVec3::Z);
        let up = m.transform_vector3(DVec3::Y);
        let left = m.transform_vector3(DVec3::X);
        if forward.length_squared() == 0.0 || up.cross(forward).length_squared() == 0.0 {
            return Err(self.err(node, "the sensor's to_world is degenerate"));
        }
        if left.dot(up.cross(forward)) < 0.0 {
            return Err(self.err(
                node,
                "the sensor's to_world mirrors the image (plsr's cameras do not mirror)",
            ));
        }
        camera.insert("position", dvec(position));
        camera.insert("look_at", dvec(position + forward.normalize()));
        camera.insert("up", dvec(up.normalize()));
        Ok(m)
    }

    /// The field of view from `fov` and `fov_axis` or `focal_length`, for a
    /// film of `(w, h)` pixels.
    pub(super) fn sensor_fov(
        &mut self,
        node: &'a Element,
        p: &mut Params<'a>,
        (w, h): (f64, f64),
        camera: &mut Table,
    ) -> Result<()> {
        // Field of view: Mitsuba's `fov` is along `fov_axis` (default x);
        // `focal_length` is a 35 mm equivalent, 36 mm wide.
        let fov = self.take_float(p, "fov")?;
        let focal = self.take_string(p, "focal_length")?;
        let axis = self.take_string(p, "fov_axis")?;
        let half_tan = |deg: f64| (deg.to_radians() / 2.0).tan();
        let from_half_tan = |t: f64| 2.0 * t.atan().to_degrees();
        let (key, deg) = match (fov, focal) {
            (Some(_), Some(_)) => {
                return Err(self.err(node, "give fov or focal_length, not both"));
            }
            (None, Some(f)) => {
                let mm = f.trim().trim_end_matches("mm").trim();
                let mm = self.number(node, mm)?;
                if mm <= 0.0 {
                    return Err(self.err(node, format!("focal_length {f} must be positive")));
                }
                ("hfov", from_half_tan(18.0 / mm))
            }
            (fov, None) => {
                let fov = fov.unwrap_or(DEFAULT_HFOV_DEG);
                if !(fov > 0.0 && fov < 180.0) {
                    return Err(self.err(node, format!("fov = {fov} must be in (0, 180)")));
                }
                match axis.as_deref().unwrap_or("x") {
                    "x" => ("hfov", fov),
                    "y" => ("vfov", fov),
                    "smaller" if w <= h => ("hfov", fov),
                    "smaller" => ("vfov", fov),
                    "larger" if w >= h => ("hfov", fov),
                    "larger" => ("vfov", fov),
                    "diagonal" => ("vfov", from_half_tan(half_tan(fov) * h / w.hypot(h))),
                    other => {
                        return Err(self.err(
                            node,
                            format!(
                                "fov_axis `{other}` is not one of x, y, diagonal, smaller, larger"
                            ),
                        ))
                    }
                }
            }
        };
        camera.insert(key, float(deg));
        Ok(())
    }
}

/// A film's `<rfilter>`, with its size in pixels.
#[derive(Debug, Clone, Copy)]
pub(super) enum SensorFilter {
    /// `box`.
    Box,
    /// `gaussian` of this σ.
    Gaussian(f64),
    /// `tent` of this radius.
    Tent(f64),
}

/// What a sensor's film and sampler set, with Mitsuba's defaults.
pub(super) struct SensorSettings {
    /// Film width, pixels.
    width: i64,
    /// Film height, pixels.
    height: i64,
    /// The pixel filter.
    filter: SensorFilter,
    /// Samples per pixel.
    spp: i64,
    /// The sampler's seed, if given.
    seed: Option<i64>,
    /// The film's `sample_border`: samples may fall beyond the film's edge.
    sample_border: bool,
    /// The crop window `[x0, y0, x1, y1]`, if any.
    crop: Option<[i64; 4]>,
}

impl Default for SensorSettings {
    fn default() -> SensorSettings {
        SensorSettings {
            width: 768,
            height: 576,
            filter: SensorFilter::Gaussian(0.5), // Mitsuba's default
            spp: 4,
            seed: None,
            sample_border: false,
            crop: None,
        }
    }
}
