//! The paths of one tile pass in structure-of-arrays lanes ([`SoaLanes`]),
//! what ends them ([`retire`]), and a tile pass's arguments ([`TilePass`]).

use super::*;

/// The paths of one tile pass in structure-of-arrays form, reused from pass
/// to pass (allocation-free after the first).
#[derive(Default)]
pub struct SoaLanes {
    pub(super) rays: RayBatch,
    pub(super) shadow: RayBatch,
    pub(super) pixel: Vec<u32>,
    /// Each path's random stream: the draws so far, and the fixed
    /// [`SampleStream`] (bit-reversed sample index, pixel hash's halves),
    /// one 32-bit array each so that the draws vectorise.
    pub(super) rng_dim: Vec<u32>,
    pub(super) rng_stream: [Vec<u32>; 3],
    pub(super) beta: [Vec<f32>; 3],
    pub(super) radiance: [Vec<f32>; 3],
    pub(super) pending: [Vec<f32>; 3],
    /// The product of `η²` over each path's refractions so far (see
    /// `PathState::eta_scale`).
    pub(super) eta_scale: Vec<f32>,
    /// Each lane's albedo at its hit, where a texture gives it.
    pub(super) albedo: [Vec<f32>; 3],
    /// Each lane's BSDF parameters its material's maps give at its hit
    /// ([`mapped_params`]), where it has such maps
    /// ([`SoaScene::mapped`]).
    pub(super) mapped: [Vec<f32>; 3],
    /// Each lane's interpolated unit normal at its hit, where its mesh has
    /// vertex normals (`ns_valid`; zero elsewhere).
    pub(super) ns: [Vec<f32>; 3],
    pub(super) ns_valid: Vec<bool>,
    /// Each lane's first tangent at its hit, where its material is
    /// anisotropic (`tangent_valid`; zero elsewhere): the general
    /// integrator's `SurfacePoint::tangent`.
    pub(super) tangent: [Vec<f32>; 3],
    pub(super) tangent_valid: Vec<bool>,
    /// Solid-angle density of the BSDF sample that led to the current hit.
    pub(super) prev_pdf: Vec<f32>,
    /// The scattering point the current ray left from.
    pub(super) prev_point: [Vec<f32>; 3],
    /// Each lane's picked light (when the scene has several), an index
    /// into [`SoaScene::light_table`], and the probability of its pick.
    pub(super) light: Vec<u32>,
    pub(super) light_pmf: Vec<f32>,
    /// Each lane's sample of the environment, where it picked the
    /// environment: whether it is valid, its direction, radiance and
    /// density (see [`crate::light::EnvironmentLight::sample_li`]).
    pub(super) env_valid: Vec<bool>,
    pub(super) env_wi: [Vec<f32>; 3],
    pub(super) env_radiance: [Vec<f32>; 3],
    pub(super) env_pdf: Vec<f32>,
    /// Scratch of the environment's batched lookups: lanes, their numbers
    /// or directions, and the results.
    pub(super) env_lanes: Vec<u32>,
    pub(super) env_us: Vec<Vec2>,
    pub(super) env_samples: Vec<Option<LightSample>>,
    pub(super) env_dirs: Vec<Vec3>,
    pub(super) env_seen: Vec<(Vec3, f32)>,
    /// Lanes whose paths go on, ascending (rebuilt every bounce).
    pub(super) kept: Vec<u32>,
    /// Lanes whose paths have ended, ascending (rebuilt every bounce).
    pub(super) ended: Vec<u32>,
    /// Whether these lanes carry compositing's pair of renders (see
    /// `paired.rs`): the render with the virtual objects, and for the paths
    /// that have met none so far (`shared`), the render without them too,
    /// whose radiance is `radiance_o`. The fields below are kept only then.
    pub(super) paired: bool,
    /// Whether each path has met no virtual object yet: its path is the same
    /// in both renders, but for what its shadow rays find.
    pub(super) shared: Vec<bool>,
    /// Each path's radiance in the render without the virtual objects (read
    /// only where `shared`).
    pub(super) radiance_o: [Vec<f32>; 3],
    /// Whether each shadow ray reaches its light in the render without the
    /// virtual objects (rebuilt every bounce).
    pub(super) open_o: Vec<bool>,
    /// Scratch of the paired render: the rays' `tfar` before a closest-hit
    /// query, the shadow rays' before an occlusion query, and the shadow
    /// rays asked again without the virtual objects, with their lanes (the
    /// lanes also list the forks of `fork_virtual_hits`).
    pub(super) tfar_before: Vec<f32>,
    pub(super) shadow_before: Vec<f32>,
    pub(super) requery: RayBatch,
    pub(super) requery_lanes: Vec<u32>,
}

impl SoaLanes {
    #[inline(always)]
    pub(super) fn resize(&mut self, n: usize) {
        self.rays.resize(n);
        self.shadow.resize(n);
        self.pixel.resize(n, 0);
        self.rng_dim.resize(n, 0);
        for part in &mut self.rng_stream {
            part.resize(n, 0);
        }
        for c in 0..3 {
            self.beta[c].resize(n, 0.0);
            self.radiance[c].resize(n, 0.0);
            self.pending[c].resize(n, 0.0);
            self.albedo[c].resize(n, 0.0);
            self.mapped[c].resize(n, 0.0);
            self.ns[c].resize(n, 0.0);
            self.tangent[c].resize(n, 0.0);
            self.prev_point[c].resize(n, 0.0);
        }
        self.ns_valid.resize(n, false);
        self.tangent_valid.resize(n, false);
        self.eta_scale.resize(n, 1.0);
        self.prev_pdf.resize(n, 0.0);
        self.light.resize(n, 0);
        self.light_pmf.resize(n, 0.0);
        self.env_valid.resize(n, false);
        self.env_pdf.resize(n, 0.0);
        for c in 0..3 {
            self.env_wi[c].resize(n, 0.0);
            self.env_radiance[c].resize(n, 0.0);
        }
        if self.paired {
            self.shared.resize(n, false);
            self.open_o.resize(n, false);
            for c in 0..3 {
                self.radiance_o[c].resize(n, 0.0);
            }
        }
    }

    /// The scattering vertex lane `i`'s ray left from, after `depth`
    /// scattering events (for the MIS weight of emission the ray finds).
    #[inline(always)]
    pub(super) fn prev_vertex(&self, i: usize, depth: u32) -> PrevVertex {
        PrevVertex {
            depth,
            pdf: self.prev_pdf[i],
            point: Vec3::new(
                self.prev_point[0][i],
                self.prev_point[1][i],
                self.prev_point[2][i],
            ),
        }
    }

    /// Adds emission `le` that lane `i`'s ray found, MIS weight `weight`,
    /// through the lane's throughput: `β · le · weight`, as the general
    /// integrator adds it.
    #[inline(always)]
    pub(super) fn add_found_emission(&mut self, i: usize, le: Vec3, weight: f32) {
        let beta = Vec3::new(self.beta[0][i], self.beta[1][i], self.beta[2][i]);
        let add = beta * le * weight;
        for c in 0..3 {
            self.radiance[c][i] += add[c];
        }
        // A shared path finds the same emission in both renders (a W-only
        // path's `radiance_o` is never read).
        if self.paired {
            for c in 0..3 {
                self.radiance_o[c][i] += add[c];
            }
        }
    }

    /// Lane `i`'s random stream as a sampler.
    #[inline(always)]
    pub(super) fn sampler(&self, i: usize) -> PathSampler {
        let stream = SampleStream {
            reversed_sample: self.rng_stream[0][i],
            pixel_lo: self.rng_stream[1][i],
            pixel_hi: self.rng_stream[2][i],
        };
        PathSampler::from_parts(self.rng_dim[i], stream)
    }

    /// Sets lane `i`'s random stream.
    #[inline(always)]
    pub(super) fn set_sampler(&mut self, i: usize, sampler: &PathSampler) {
        let (dim, stream) = sampler.to_parts();
        self.rng_dim[i] = dim;
        self.rng_stream[0][i] = stream.reversed_sample;
        self.rng_stream[1][i] = stream.pixel_lo;
        self.rng_stream[2][i] = stream.pixel_hi;
    }

    /// Keeps the lanes listed in `self.kept`, in order; the previous
    /// scattering points and densities only where `emitters` need them.
    #[inline(always)]
    pub(super) fn retain(&mut self, emitters: bool) {
        let kept = &self.kept;
        self.rays.retain(kept);
        gather_lanes(&mut self.pixel, kept);
        gather_lanes(&mut self.rng_dim, kept);
        for part in &mut self.rng_stream {
            gather_lanes(part, kept);
        }
        gather_lanes(&mut self.eta_scale, kept);
        for c in 0..3 {
            gather_lanes(&mut self.beta[c], kept);
            gather_lanes(&mut self.radiance[c], kept);
        }
        if self.paired {
            gather_lanes(&mut self.shared, kept);
            for c in 0..3 {
                gather_lanes(&mut self.radiance_o[c], kept);
            }
        }
        if emitters {
            gather_lanes(&mut self.prev_pdf, kept);
            for c in 0..3 {
                gather_lanes(&mut self.prev_point[c], kept);
            }
        }
        let live = self.rays.len();
        self.resize(live);
    }
}

/// Adds the radiance of the paths of `ended` (lane indices) to their
/// pixels, as the general integrator retires a path; with `pixels_o` (a
/// paired render's main lanes), each shared path's `radiance_o` to its
/// pixel there too.
#[inline(always)]
pub(super) fn retire(
    lanes: &SoaLanes,
    ended: &[u32],
    scene: &Scene,
    pixels: &mut [PixelSums],
    mut pixels_o: Option<&mut [PixelSums]>,
) {
    let response = scene.film().response();
    for &i in ended {
        let i = i as usize;
        let radiance = Vec3::new(
            lanes.radiance[0][i],
            lanes.radiance[1][i],
            lanes.radiance[2][i],
        );
        pixels[lanes.pixel[i] as usize].add_radiance(response.apply(radiance));
        if let Some(pixels_o) = pixels_o.as_deref_mut() {
            if lanes.shared[i] {
                let radiance = Vec3::new(
                    lanes.radiance_o[0][i],
                    lanes.radiance_o[1][i],
                    lanes.radiance_o[2][i],
                );
                pixels_o[lanes.pixel[i] as usize].add_radiance(response.apply(radiance));
            }
        }
    }
}

/// The arguments of one tile pass.
pub struct TilePass<'a> {
    /// The kernel's view of the scene.
    pub kernel: &'a SoaScene,
    /// The scene.
    pub scene: &'a Scene,
    /// Seed and depth of the render.
    pub job: &'a RenderJob,
    /// The tile.
    pub tile: Tile,
    /// The sample index of this pass.
    pub sample: u32,
    /// Whether this is the first pass of the render over this tile (it
    /// records the object id).
    pub first: bool,
}
