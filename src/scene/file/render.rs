//! `[render]`: the job the scene file asks for (spp, depth, seed),
//! Embree's robust mode and how lights are picked.

use super::Builder;
use crate::error::Result;
use crate::job::RenderJob;
use crate::light::LightPicking;
use serde::Deserialize;

#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct RenderSection {
    pub(super) spp: Option<i64>,
    pub(super) max_depth: Option<i64>,
    pub(super) seed: Option<u64>,
    pub(super) rr_depth: Option<i64>,
    pub(super) robust: Option<bool>,
    pub(super) light_picking: Option<String>,
}

impl Builder<'_> {
    /// `render.light_picking`: `spatial` (default), `power` or `uniform`.
    pub(super) fn light_picking(&self, r: &RenderSection) -> Result<LightPicking> {
        match r.light_picking.as_deref() {
            None => Ok(LightPicking::default()),
            Some(name) => LightPicking::from_name(name).ok_or_else(|| {
                self.err(
                    "render.light_picking",
                    format!("unknown rule {name:?} (spatial, power or uniform)"),
                )
            }),
        }
    }

    pub(super) fn job(&self, r: &RenderSection) -> Result<RenderJob> {
        let d = RenderJob::default();
        Ok(RenderJob {
            spp: match r.spp {
                Some(v) => self.positive_count("render.spp", v, 1 << 24)?,
                None => d.spp,
            },
            // 0: only what the camera sees emit (Mitsuba's max_depth 1).
            max_depth: match r.max_depth {
                Some(v) if (0..=1024).contains(&v) => v as u32,
                Some(v) => {
                    return Err(self.err(
                        "render.max_depth",
                        format!("must be between 0 and 1024, got {v}"),
                    ))
                }
                None => d.max_depth,
            },
            seed: r.seed.unwrap_or(d.seed),
            sample_start: 0,
            hide_virtual: false,
            rr_depth: match r.rr_depth {
                Some(v) => self.positive_count("render.rr_depth", v, 1024)?,
                None => d.rr_depth,
            },
        })
    }
}
