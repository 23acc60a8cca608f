//! `[[lights]]` (point and spot lights) and `[[pls]]` (parametric light
//! sources from PLS files).

use super::map::MapKey;
use super::shape::TransformSection;
use super::Builder;
use crate::bsdf::Bsdf;
use crate::error::Result;
use crate::scene::{Material, Mesh};
use glam::Vec3;
use serde::Deserialize;
use std::path::PathBuf;

/// A projector's field of view without `hfov` or `vfov` (Mitsuba's 50 mm
/// lens, `2·atan(18/50)`), degrees.
const DEFAULT_PROJECTOR_HFOV: f32 = 39.597_75;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct LightSection {
    #[serde(rename = "type")]
    pub(super) kind: String,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) position: Option<[f32; 3]>,
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) intensity: Option<[f32; 3]>,
    /// A spot light's beam axis.
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) direction: Option<[f32; 3]>,
    /// A spot light's cutoff, degrees (default 20).
    pub(super) cutoff_angle: Option<f32>,
    /// A spot light's full-intensity width, degrees (default ¾ cutoff).
    pub(super) beam_width: Option<f32>,
    /// A directional light's irradiance, W/m²; a projector's scale.
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) irradiance: Option<[f32; 3]>,
    /// A projected image's up direction (spot with `intensity_map`,
    /// projector).
    #[serde(default, deserialize_with = "crate::input::exact::option")]
    pub(super) up: Option<[f32; 3]>,
    /// A spot light's projected image.
    pub(super) intensity_map: Option<MapKey>,
    /// A projector's image.
    pub(super) irradiance_map: Option<MapKey>,
    /// A projector's field of view along the image's width, degrees.
    pub(super) hfov: Option<f32>,
    /// A projector's field of view along the image's height, degrees.
    pub(super) vfov: Option<f32>,
}

impl LightSection {
    /// The optional keys given.
    pub(super) fn keys_given(&self) -> Vec<&'static str> {
        [
            ("position", self.position.is_some()),
            ("intensity", self.intensity.is_some()),
            ("direction", self.direction.is_some()),
            ("cutoff_angle", self.cutoff_angle.is_some()),
            ("beam_width", self.beam_width.is_some()),
            ("irradiance", self.irradiance.is_some()),
            ("up", self.up.is_some()),
            ("intensity_map", self.intensity_map.is_some()),
            ("irradiance_map", self.irradiance_map.is_some()),
            ("hfov", self.hfov.is_some()),
            ("vfov", self.vfov.is_some()),
        ]
        .into_iter()
        .filter_map(|(k, given)| given.then_some(k))
        .collect()
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct PlsSection {
    pub(super) file: PathBuf,
    pub(super) nf: Option<u32>,
    pub(super) transform: Option<TransformSection>,
}

impl Builder<'_> {
    /// Refuses the keys of `l` that a light of kind `what` does not take
    /// (those not in `takes`).
    pub(super) fn light_keys(
        &self,
        field: &str,
        l: &LightSection,
        what: &str,
        takes: &[&str],
    ) -> Result<()> {
        match l.keys_given().into_iter().find(|k| !takes.contains(k)) {
            Some(key) => Err(self.err(
                format!("{field}.{key}"),
                format!("not used by a {what} ({})", takes.join(", ")),
            )),
            None => Ok(()),
        }
    }

    /// A light's `direction` as a unit vector (refused if zero).
    fn light_direction(&self, field: &str, direction: [f32; 3]) -> Result<Vec3> {
        self.vec3(&format!("{field}.direction"), direction)?
            .try_normalize()
            .ok_or_else(|| self.err(format!("{field}.direction"), "must not be the zero vector"))
    }

    /// A `directional` light: `direction` (the way the light travels) and
    /// `irradiance` (W/m² on a surface facing it), as Mitsuba's
    /// `directional`.
    pub(super) fn directional_light(
        &self,
        field: &str,
        l: &LightSection,
    ) -> Result<crate::light::DirectionalLight> {
        self.light_keys(field, l, "directional light", &["direction", "irradiance"])?;
        let direction = l.direction.ok_or_else(|| {
            self.err(
                format!("{field}.direction"),
                "required for a directional light: the way the light travels",
            )
        })?;
        let irradiance = l.irradiance.ok_or_else(|| {
            self.err(
                format!("{field}.irradiance"),
                "required for a directional light: W/m² on a surface facing it",
            )
        })?;
        let direction = self.light_direction(field, direction)?;
        Ok(crate::light::DirectionalLight {
            direction,
            irradiance: self.colour(&format!("{field}.irradiance"), irradiance, None)?,
        })
    }

    /// A `spot` light: `position`, `direction` (the beam's axis),
    /// `intensity` on the axis (W/sr), `cutoff_angle` (degrees, default 20,
    /// at most 180) and `beam_width` (degrees, default ¾ of the cutoff, at
    /// most the cutoff), as Mitsuba's `spot`.
    pub(super) fn spot_light(
        &self,
        field: &str,
        l: &LightSection,
    ) -> Result<crate::light::PointLight> {
        let required = |key: &str, v: Option<[f32; 3]>, what: &str| {
            v.ok_or_else(|| {
                self.err(
                    format!("{field}.{key}"),
                    format!("required for a spot light: {what}"),
                )
            })
        };
        self.light_keys(
            field,
            l,
            "spot light",
            &[
                "position",
                "direction",
                "intensity",
                "cutoff_angle",
                "beam_width",
                "intensity_map",
                "up",
            ],
        )?;
        let position = required("position", l.position, "where it is")?;
        let direction = required("direction", l.direction, "the beam's axis")?;
        let intensity = required("intensity", l.intensity, "W/sr on the axis")?;
        let position = self.vec3(&format!("{field}.position"), position)?;
        let axis = self.light_direction(field, direction)?;
        let intensity = self.colour(&format!("{field}.intensity"), intensity, None)?;
        let cutoff = self.finite(
            &format!("{field}.cutoff_angle"),
            l.cutoff_angle.unwrap_or(20.0),
        )?;
        if !(cutoff > 0.0 && cutoff <= 180.0) {
            return Err(self.err(
                format!("{field}.cutoff_angle"),
                format!("must be in (0, 180] degrees, got {cutoff}"),
            ));
        }
        let beam = self.finite(
            &format!("{field}.beam_width"),
            l.beam_width.unwrap_or(0.75 * cutoff),
        )?;
        if !(0.0..=cutoff).contains(&beam) {
            return Err(self.err(
                format!("{field}.beam_width"),
                format!("must be between 0 and the cutoff angle {cutoff} degrees, got {beam}"),
            ));
        }
        let projection = match &l.intensity_map {
            None => {
                if l.up.is_some() {
                    return Err(self.err(format!("{field}.up"), "only used with an intensity_map"));
                }
                None
            }
            Some(map) => {
                if cutoff >= 90.0 {
                    return Err(self.err(
                        format!("{field}.intensity_map"),
                        format!(
                            "a projected image needs a cutoff_angle below 90 degrees, got {cutoff}"
                        ),
                    ));
                }
                let image = self.light_image(field, "intensity_map", map)?;
                Some(std::sync::Arc::new(crate::light::Projection {
                    frame: self.light_frame(field, axis, l.up)?,
                    image,
                    kind: crate::light::ProjectionKind::Spot {
                        tan_cutoff: cutoff.to_radians().tan(),
                    },
                }))
            }
        };
        Ok(crate::light::PointLight {
            position,
            intensity,
            cone: Some(crate::light::spot_cone(
                axis,
                cutoff.to_radians(),
                beam.to_radians(),
            )),
            projection,
        })
    }

    /// A projected image (`key`, sRGB unless its map says otherwise).
    fn light_image(
        &self,
        field: &str,
        key: &str,
        map: &MapKey,
    ) -> Result<std::sync::Arc<crate::texture::ImageTexture>> {
        let t = self.textures(
            field,
            Some(map.clone().rebased(self.base)),
            None,
            None,
            [key, "", ""],
        )?;
        if t.base_color_attribute.is_some() {
            return Err(self.err(
                format!("{field}.{key}"),
                "a light's image is a file or a checkerboard, not a mesh attribute",
            ));
        }
        t.base_color
            .ok_or_else(|| self.err(format!("{field}.{key}"), "no image"))
    }

    /// The frame of a projected image from the light's unit `axis` and
    /// its `up` key (required).
    fn light_frame(&self, field: &str, axis: Vec3, up: Option<[f32; 3]>) -> Result<[Vec3; 3]> {
        let up = up.ok_or_else(|| {
            self.err(
                format!("{field}.up"),
                "required with a projected image: which way is up in it",
            )
        })?;
        let up = self.vec3(&format!("{field}.up"), up)?;
        crate::light::Projection::frame_from(axis, up).ok_or_else(|| {
            self.err(
                format!("{field}.up"),
                "must not be zero or parallel to the direction",
            )
        })
    }

    /// A `projector` (Mitsuba's): a point light at `position` projecting
    /// `irradiance_map` (or a constant) along `direction`, with `up` up in
    /// the image and `hfov` (along its width) or `vfov` (degrees; default
    /// Mitsuba's 39.6 across); `irradiance` scales it (W/m² on a plane
    /// facing it at distance 1 is `π` times `irradiance` times the image).
    pub(super) fn projector(
        &self,
        field: &str,
        l: &LightSection,
    ) -> Result<crate::light::PointLight> {
        self.light_keys(
            field,
            l,
            "projector",
            &[
                "position",
                "direction",
                "up",
                "irradiance",
                "irradiance_map",
                "hfov",
                "vfov",
            ],
        )?;
        let position = l.position.ok_or_else(|| {
            self.err(
                format!("{field}.position"),
                "required for a projector: where it is",
            )
        })?;
        let position = self.vec3(&format!("{field}.position"), position)?;
        let direction = l.direction.ok_or_else(|| {
            self.err(
                format!("{field}.direction"),
                "required for a projector: where it points",
            )
        })?;
        let axis = self.light_direction(field, direction)?;
        let frame = self.light_frame(field, axis, l.up)?;
        let scale = self.colour(
            &format!("{field}.irradiance"),
            l.irradiance.unwrap_or([1.0; 3]),
            None,
        )?;
        let image = match &l.irradiance_map {
            Some(map) => self.light_image(field, "irradiance_map", map)?,
            None => std::sync::Arc::new(crate::texture::ImageTexture::from_texels(
                1,
                1,
                vec![Vec3::ONE],
            )),
        };
        let aspect = image.width as f32 / image.height as f32;
        let half_tan = |key: &str, deg: f32| -> Result<f32> {
            let deg = self.finite(&format!("{field}.{key}"), deg)?;
            if !(deg > 0.0 && deg < 180.0) {
                return Err(self.err(
                    format!("{field}.{key}"),
                    format!("must be in (0, 180) degrees, got {deg}"),
                ));
            }
            Ok((deg.to_radians() / 2.0).tan())
        };
        let tan_x = match (l.hfov, l.vfov) {
            (Some(_), Some(_)) => {
                return Err(self.err(format!("{field}.vfov"), "give hfov or vfov, not both"))
            }
            (Some(h), None) => half_tan("hfov", h)?,
            (None, Some(v)) => half_tan("vfov", v)? * aspect,
            (None, None) => half_tan("hfov", DEFAULT_PROJECTOR_HFOV)?,
        };
        Ok(crate::light::PointLight {
            position,
            intensity: scale,
            cone: None,
            projection: Some(std::sync::Arc::new(crate::light::Projection {
                frame,
                image,
                kind: crate::light::ProjectionKind::Projector {
                    cot_half_fov: 1.0 / tan_x,
                    aspect,
                },
            })),
        })
    }

    /// Adds the lights of a PLS file as cone-limited emissive meshes.
    pub(super) fn pls(
        &self,
        index: usize,
        s: &PlsSection,
        materials: &mut Vec<Material>,
        meshes: &mut Vec<Mesh>,
    ) -> Result<()> {
        let field = format!("pls[{index}]");
        let path = self.base.join(&s.file);
        crate::input::check_regular_file(&path).map_err(|m| {
            self.err(
                format!("{field}.file"),
                format!(
                    "{}: PLS file {m} (paths are relative to the scene file)",
                    path.display()
                ),
            )
        })?;
        // Errors inside the PLS file keep its name, light and parameter,
        // behind the scene field that referred to it.
        self.read_input(&path);
        let mut lighting = crate::light::pls::file::load(&path)
            .map_err(|e| self.err(format!("{field}.file"), e.to_string()))?;
        if let Some(t) = &s.transform {
            let m = self.transform(&format!("{field}.transform"), t)?;
            lighting = lighting.transform(&m);
            lighting.validate().map_err(|e| {
                self.err(
                    format!("{field}.transform"),
                    format!("makes {} invalid: {}", e.light, e.message),
                )
            })?;
        }
        let nf = crate::light::pls::check_nf(s.nf.unwrap_or(crate::light::pls::DEFAULT_NF) as u64)
            .map_err(|m| self.err(format!("{field}.nf"), m.to_string()))?;
        // PLS emitters do not reflect: a black material.
        let black = match materials.iter().position(|m| m.name == "(pls)") {
            Some(i) => i as u32,
            None => {
                materials.push(Material::new("(pls)", Bsdf::diffuse(Vec3::ZERO)));
                (materials.len() - 1) as u32
            }
        };
        for (k, light) in lighting.lights.iter().enumerate() {
            let name = format!("{field}/{}", light.label(k));
            meshes.push(crate::scene::pls_mesh(
                light,
                lighting.mode,
                nf,
                black,
                name,
            ));
        }
        Ok(())
    }
}
