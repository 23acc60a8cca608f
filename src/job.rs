//! What to render of a scene: which samples of every pixel, how deep the
//! paths go and with which seed. Kept apart from the scene, so that one
//! built scene (and its Embree acceleration structure) serves any number of
//! renders with different settings.

use std::fmt;
use std::ops::Range;

/// The most samples per pixel one render may take (2²⁴).
pub const MAX_SPP: u32 = 1 << 24;
/// The deepest path a render may trace, in scattering events.
pub const MAX_DEPTH: u32 = 1024;
/// The default [`RenderJob::rr_depth`]: Russian roulette from the fourth
/// scattering event on, where Mitsuba 3 starts it (its default 5 counts
/// the camera ray). With stratified samples this reaches a given error
/// sooner than 3: 15–20 % on the PLS room and the glossy spheres under a
/// sky, level on the Cornell box (`plsr bench peers`' scenes, 64 spp).
pub const DEFAULT_RR_DEPTH: u32 = 4;

/// Which samples of every pixel to render, how deep, with which seed.
///
/// The image is a function of the scene, the seed and the sample range
/// only: never of the thread count or tile size.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RenderJob {
    /// Samples per pixel, 1 to [`MAX_SPP`].
    pub spp: u32,
    /// Index of the first sample: the job renders samples
    /// `[sample_start, sample_start + spp)` of every pixel, so pieces with
    /// disjoint ranges add up to the image of their union.
    pub sample_start: u32,
    /// Maximum number of scattering events on a path, 0 to [`MAX_DEPTH`]
    /// (1: direct lighting only; 0: only light seen directly by the camera).
    pub max_depth: u32,
    /// Seed of the random streams.
    pub seed: u64,
    /// Render the real scene alone: virtual meshes ([`Mesh::is_virtual`](crate::scene::Mesh::is_virtual))
    /// are invisible to every ray (camera, bounce and shadow), through
    /// Embree's ray masks on the same acceleration structure.
    pub hide_virtual: bool,
    /// Scattering events after which Russian roulette may end a path (by
    /// its throughput), 0 to [`MAX_DEPTH`]; a value above `max_depth`
    /// turns the roulette off.
    pub rr_depth: u32,
}

impl Default for RenderJob {
    /// 16 spp from sample 0, depth 8, seed 0.
    fn default() -> Self {
        RenderJob {
            spp: 16,
            sample_start: 0,
            max_depth: 8,
            seed: 0,
            hide_virtual: false,
            rr_depth: DEFAULT_RR_DEPTH,
        }
    }
}

/// Why a [`RenderJob`] is invalid.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum JobError {
    /// `spp` is 0 or above [`MAX_SPP`].
    Spp(u32),
    /// `max_depth` is above [`MAX_DEPTH`].
    MaxDepth(u32),
    /// `rr_depth` is above [`MAX_DEPTH`].
    RrDepth(u32),
    /// `sample_start + spp` does not fit in 32 bits.
    SampleRangeOverflows,
}

impl fmt::Display for JobError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            JobError::Spp(v) => write!(f, "spp = {v} must be in [1, {MAX_SPP}]"),
            JobError::MaxDepth(v) => write!(f, "max_depth = {v} must be in [0, {MAX_DEPTH}]"),
            JobError::RrDepth(v) => write!(f, "rr_depth = {v} must be in [0, {MAX_DEPTH}]"),
            JobError::SampleRangeOverflows => write!(f, "sample range overflows"),
        }
    }
}

impl std::error::Error for JobError {}

impl RenderJob {
    /// The Embree ray mask of this job's rays.
    #[inline]
    pub fn ray_mask(&self) -> u32 {
        if self.hide_virtual {
            crate::accel::REAL_MASK
        } else {
            crate::accel::ALL_MASK
        }
    }

    /// A job of `spp` samples from sample 0, checked.
    pub fn new(spp: u32, max_depth: u32, seed: u64) -> Result<RenderJob, JobError> {
        let job = RenderJob {
            spp,
            sample_start: 0,
            max_depth,
            seed,
            hide_virtual: false,
            rr_depth: DEFAULT_RR_DEPTH,
        };
        job.validate()?;
        Ok(job)
    }

    /// Checks the ranges of every field.
    pub fn validate(&self) -> Result<(), JobError> {
        if self.spp == 0 || self.spp > MAX_SPP {
            return Err(JobError::Spp(self.spp));
        }
        if self.max_depth > MAX_DEPTH {
            return Err(JobError::MaxDepth(self.max_depth));
        }
        if self.rr_depth > MAX_DEPTH {
            return Err(JobError::RrDepth(self.rr_depth));
        }
        self.sample_start
            .checked_add(self.spp)
            .ok_or(JobError::SampleRangeOverflows)?;
        Ok(())
    }

    /// The sample indices rendered, `[sample_start, sample_start + spp)`
    /// (saturating; [`RenderJob::validate`] rejects ranges that overflow).
    pub fn samples(&self) -> Range<u32> {
        self.sample_start..self.sample_start.saturating_add(self.spp)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_are_checked() {
        assert!(RenderJob::new(1, 1, 0).is_ok());
        assert!(RenderJob::new(MAX_SPP, MAX_DEPTH, 0).is_ok());
        assert_eq!(RenderJob::new(0, 8, 0), Err(JobError::Spp(0)));
        assert_eq!(
            RenderJob::new(MAX_SPP + 1, 8, 0),
            Err(JobError::Spp(MAX_SPP + 1))
        );
        assert!(RenderJob::new(4, 0, 0).is_ok(), "emission only");
        assert_eq!(
            RenderJob::new(4, MAX_DEPTH + 1, 0),
            Err(JobError::MaxDepth(MAX_DEPTH + 1))
        );
        let job = RenderJob {
            sample_start: u32::MAX - 2,
            ..RenderJob::new(4, 8, 0).unwrap()
        };
        assert_eq!(job.validate(), Err(JobError::SampleRangeOverflows));
        let job = RenderJob {
            sample_start: 10,
            ..RenderJob::new(4, 8, 0).unwrap()
        };
        assert_eq!(job.samples(), 10..14);
    }
}
