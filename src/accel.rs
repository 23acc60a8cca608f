//! Safe layer over Embree 3: device, scene, triangle geometry and ray queries.
//!
//! This is the only module (with `sys/`) that talks to Embree. The life cycle is:
//!
//! 1. [`Device::new`] creates an Embree device and installs an error callback
//!    that records Embree's error code and message, so that every failing call
//!    turns into an [`EmbreeError`] instead of a silent null handle.
//! 2. [`SceneBuilder`] collects triangle meshes (each attached under an explicit
//!    geometry id, so `Hit::geom_id` is the caller's shape index) and is turned
//!    by [`SceneBuilder::commit`] into an immutable [`Accel`].
//! 3. [`Accel`] answers closest-hit ([`Accel::intersect`]) and any-hit
//!    ([`Accel::occluded`]) queries for single rays, and for batches through
//!    Embree's stream API ([`Accel::intersect_stream`], [`Accel::occluded_stream`]),
//!    which the integrator uses for the coherent rays of a tile, and for
//!    structure-of-arrays batches ([`RayBatch`], [`Accel::intersect_batch`],
//!    [`Accel::occluded_batch`]), which the vectorised kernel uses.
//!
//! Threads: Embree's ray queries on a committed scene are thread-safe, and
//! every worker that traces rays must run with flush-to-zero and
//! denormals-are-zero set (Embree's documented requirement for speed); see
//! [`enable_flush_to_zero`] (in `plsr-base`), which plsr's thread pools call in their start
//! handler.

pub use crate::error::EmbreeError;
pub use crate::threads::{enable_flush_to_zero, flush_to_zero_enabled};

/// The largest coordinate (absolute, scene units) a scene may use: Embree
/// refuses rays whose origin leaves ±1.8·10^18, and f32 geometry far
/// beyond this has no precision left to render. Meshes, lights and the
/// camera (with its aperture) are checked against it.
pub const MAX_COORDINATE: f32 = 1e12;

/// The mask bit of geometry that stands for the real scene (the proxy).
pub const REAL_MASK: u32 = 1;

/// The mask bit of virtual geometry (objects inserted into a photograph).
pub const VIRTUAL_MASK: u32 = 2;

/// The ray mask that sees every geometry.
pub const ALL_MASK: u32 = u32::MAX;

/// Whether `p` is finite and within [`MAX_COORDINATE`] on every axis.
pub fn within_coordinates(p: glam::Vec3) -> bool {
    p.is_finite() && p.abs().max_element() <= MAX_COORDINATE
}

use crate::sys;
use glam::Vec3;
use std::ffi::{c_void, CStr, CString};
use std::sync::Mutex;

/// Embree's "no geometry" id (`RTC_INVALID_GEOMETRY_ID`).
pub const INVALID_ID: u32 = u32::MAX;

/// Where the error callback of one device writes; boxed so its address is stable.
#[derive(Default)]
struct ErrorSlot {
    first: Mutex<Option<EmbreeError>>,
}

unsafe extern "C" fn error_callback(
    user_ptr: *mut c_void,
    code: sys::RTCError,
    message: *const std::os::raw::c_char,
) {
    // A panic must not unwind into Embree's C++ frames.
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `user_ptr` is the `ErrorSlot` boxed in the `Device` that
        // registered this callback; the device (and so the box) outlives every
        // Embree call made through it. `message` is null or a NUL-terminated
        // string owned by Embree for the duration of the call.
        let slot = unsafe { &*(user_ptr as *const ErrorSlot) };
        let text = if message.is_null() {
            String::from("(no message)")
        } else {
            // SAFETY: not null, so a NUL-terminated string owned by Embree
            // for the duration of this call (above).
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        if let Ok(mut first) = slot.first.lock() {
            first.get_or_insert(EmbreeError {
                code,
                message: text,
            });
        }
    });
}

/// An Embree device: the context that owns scenes and geometries.
///
/// Released (`rtcReleaseDevice`) on drop; scenes keep their own reference, so
/// a device may be dropped before the `Accel`s built on it.
pub struct Device {
    raw: sys::RTCDevice,
    errors: Box<ErrorSlot>,
}

// SAFETY: an Embree device is reference counted and internally synchronised;
// Embree's API may be called on it from any thread. The error slot is a Mutex.
unsafe impl Send for Device {}
// SAFETY: as above; `&Device` only allows creating scenes and reading errors,
// both thread-safe in Embree.
unsafe impl Sync for Device {}

impl Device {
    /// Creates a device with Embree's default configuration.
    pub fn new() -> Result<Device, EmbreeError> {
        Device::with_config("")
    }

    /// Creates a device with an Embree configuration string (e.g. `"threads=1"`).
    pub fn with_config(config: &str) -> Result<Device, EmbreeError> {
        let c_config = CString::new(config).map_err(|_| EmbreeError {
            code: sys::RTC_ERROR_INVALID_ARGUMENT,
            message: "device configuration contains a NUL byte".into(),
        })?;
        // SAFETY: `c_config` is a valid NUL-terminated string for the call.
        let raw = unsafe { sys::rtcNewDevice(c_config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: rtcGetDeviceError(NULL) reads the thread-local error of a
            // failed device creation.
            let code = unsafe { sys::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(EmbreeError {
                code,
                message: format!("cannot create a device with configuration {config:?}"),
            });
        }
        let errors = Box::<ErrorSlot>::default();
        // SAFETY: `raw` is a live device; the slot pointer stays valid as long as
        // the device, which owns the box, lives.
        unsafe {
            sys::rtcSetDeviceErrorFunction(
                raw,
                Some(error_callback),
                &*errors as *const ErrorSlot as *mut c_void,
            )
        };
        Ok(Device { raw, errors })
    }

    /// Takes the first error Embree reported since the last check, if any.
    pub fn take_error(&self) -> Option<EmbreeError> {
        // SAFETY: `self.raw` is a live device; the call resets its error code.
        let code = unsafe { sys::rtcGetDeviceError(self.raw) };
        let recorded = self.errors.first.lock().ok().and_then(|mut e| e.take());
        match (recorded, code) {
            (Some(e), _) => Some(e),
            (None, sys::RTC_ERROR_NONE) => None,
            (None, code) => Some(EmbreeError {
                code,
                message: "(no message)".into(),
            }),
        }
    }

    fn check(&self, what: &str) -> Result<(), EmbreeError> {
        match self.take_error() {
            None => Ok(()),
            Some(mut e) => {
                e.message = format!("{what}: {}", e.message);
                Err(e)
            }
        }
    }

    /// Starts building a scene on this device.
    pub fn scene_builder(&self, options: SceneOptions) -> Result<SceneBuilder<'_>, EmbreeError> {
        // SAFETY: `self.raw` is a live device.
        let raw = unsafe { sys::rtcNewScene(self.raw) };
        self.check("rtcNewScene")?;
        if raw.is_null() {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_UNKNOWN,
                message: "rtcNewScene returned no scene".into(),
            });
        }
        let mut flags = sys::RTC_SCENE_FLAG_NONE;
        if options.robust {
            flags |= sys::RTC_SCENE_FLAG_ROBUST;
        }
        // SAFETY: `raw` is the scene just created on this device.
        unsafe {
            sys::rtcSetSceneFlags(raw, flags);
            sys::rtcSetSceneBuildQuality(raw, sys::RTC_BUILD_QUALITY_HIGH);
        }
        self.check("rtcSetSceneFlags")?;
        Ok(SceneBuilder {
            device: self,
            scene: SceneHandle(raw),
        })
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: we own one reference to the device; the error callback is
        // removed first so it can no longer reach the slot we are about to free
        // (scenes may keep the device alive past this point).
        unsafe {
            sys::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            sys::rtcReleaseDevice(self.raw);
        }
    }
}

/// Options of an Embree scene.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct SceneOptions {
    /// Embree's robust mode (`RTC_SCENE_FLAG_ROBUST`): watertight traversal
    /// and intersection, a little slower. Off by default.
    pub robust: bool,
}

/// Owns one reference to an `RTCScene`.
struct SceneHandle(sys::RTCScene);

impl Drop for SceneHandle {
    fn drop(&mut self) {
        // SAFETY: we own one reference to the scene.
        unsafe { sys::rtcReleaseScene(self.0) };
    }
}

/// A scene being built: triangle meshes are attached, then [`commit`](Self::commit)ed.
pub struct SceneBuilder<'d> {
    device: &'d Device,
    scene: SceneHandle,
}

impl SceneBuilder<'_> {
    /// Attaches a triangle mesh under geometry id `geom_id`.
    ///
    /// `positions` are world-space vertices (any unit), `triangles` index them.
    /// With `cull_back`, rays (and shadow rays) pass through a triangle they
    /// meet from behind (`dir · ng > 0`, `ng` = `(p1 − p0) × (p2 − p0)`), as
    /// through the inside of Mitsuba's curves.
    /// Fails if an index is out of range, a position is not finite, or the id is
    /// already used.
    pub fn add_triangle_mesh(
        &mut self,
        geom_id: u32,
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        mask: u32,
        cull_back: bool,
    ) -> Result<(), EmbreeError> {
        let invalid = |message: String| EmbreeError {
            code: sys::RTC_ERROR_INVALID_ARGUMENT,
            message,
        };
        if let Some(t) = triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as usize >= positions.len()))
        {
            return Err(invalid(format!(
                "triangle {t:?} indexes past the {} vertices of geometry {geom_id}",
                positions.len()
            )));
        }
        if positions.iter().any(|p| !p.is_finite()) {
            return Err(invalid(format!(
                "geometry {geom_id} has a non-finite vertex"
            )));
        }
        let device = self.device;
        // SAFETY: the device is live; the geometry is released by `GeometryHandle`.
        let geom = GeometryHandle(unsafe {
            sys::rtcNewGeometry(device.raw, sys::RTC_GEOMETRY_TYPE_TRIANGLE)
        });
        device.check("rtcNewGeometry")?;
        // SAFETY: `rtcSetNewGeometryBuffer` allocates Embree-owned buffers of the
        // requested size (with the padding Embree needs) and returns pointers to
        // them, or null on failure, which is checked before writing. We write
        // exactly `len` elements of the declared layout into each.
        unsafe {
            let vb = sys::rtcSetNewGeometryBuffer(
                geom.0,
                sys::RTC_BUFFER_TYPE_VERTEX,
                0,
                sys::RTC_FORMAT_FLOAT3,
                12,
                positions.len(),
            ) as *mut [f32; 3];
            device.check("vertex buffer")?;
            let ib = sys::rtcSetNewGeometryBuffer(
                geom.0,
                sys::RTC_BUFFER_TYPE_INDEX,
                0,
                sys::RTC_FORMAT_UINT3,
                12,
                triangles.len(),
            ) as *mut [u32; 3];
            device.check("index buffer")?;
            if vb.is_null() || ib.is_null() {
                return Err(EmbreeError {
                    code: sys::RTC_ERROR_OUT_OF_MEMORY,
                    message: format!("cannot allocate buffers of geometry {geom_id}"),
                });
            }
            for (i, p) in positions.iter().enumerate() {
                vb.add(i).write(p.to_array());
            }
            for (i, t) in triangles.iter().enumerate() {
                ib.add(i).write(*t);
            }
            // Rays see this geometry when their mask shares a bit with it.
            sys::rtcSetGeometryMask(geom.0, mask);
            if cull_back {
                sys::rtcSetGeometryIntersectFilterFunction(geom.0, Some(cull_back_faces));
                sys::rtcSetGeometryOccludedFilterFunction(geom.0, Some(cull_back_faces));
            }
            sys::rtcCommitGeometry(geom.0);
            device.check("rtcCommitGeometry")?;
            sys::rtcAttachGeometryByID(self.scene.0, geom.0, geom_id);
            device.check(&format!("attaching geometry {geom_id}"))?;
        }
        Ok(())
    }

    /// Attaches an instance of the committed scene `prototype` under
    /// geometry id `geom_id`, placed by the affine `to_world` (object to
    /// world). Rays that hit it report `geom_id` as [`Hit::instance`] and
    /// the prototype's own geometry id and triangle. `prototype` must
    /// outlive the scene this builds (Embree keeps a reference to it, and
    /// the caller keeps the [`Accel`]).
    pub fn add_instance(
        &mut self,
        geom_id: u32,
        prototype: &Accel,
        to_world: &glam::Affine3A,
    ) -> Result<(), EmbreeError> {
        let columns = to_world.to_cols_array();
        if columns.iter().any(|x| !x.is_finite()) {
            return Err(EmbreeError {
                code: sys::RTC_ERROR_INVALID_ARGUMENT,
                message: format!("instance {geom_id} has a non-finite transform"),
            });
        }
        let device = self.device;
        // SAFETY: the device is live; the geometry is released by `GeometryHandle`.
        let geom = GeometryHandle(unsafe {
            sys::rtcNewGeometry(device.raw, sys::RTC_GEOMETRY_TYPE_INSTANCE)
        });
        device.check("rtcNewGeometry")?;
        // SAFETY: `prototype.scene` is a committed scene of the same device
        // (Embree retains it); `columns` is 12 floats, the 3×4 column-major
        // layout the format names, read during the call.
        unsafe {
            sys::rtcSetGeometryInstancedScene(geom.0, prototype.scene.0);
            sys::rtcSetGeometryTransform(
                geom.0,
                0,
                sys::RTC_FORMAT_FLOAT3X4_COLUMN_MAJOR,
                columns.as_ptr().cast(),
            );
            // The prototype's geometries keep their own masks.
            sys::rtcSetGeometryMask(geom.0, u32::MAX);
            sys::rtcCommitGeometry(geom.0);
            device.check("rtcCommitGeometry (instance)")?;
            sys::rtcAttachGeometryByID(self.scene.0, geom.0, geom_id);
            device.check(&format!("attaching instance {geom_id}"))?;
        }
        Ok(())
    }

    /// Builds the acceleration structure and returns the immutable scene.
    pub fn commit(self) -> Result<Accel, EmbreeError> {
        // SAFETY: the scene is live and only reachable through `self`.
        unsafe { sys::rtcCommitScene(self.scene.0) };
        self.device.check("rtcCommitScene")?;
        let mut bounds = sys::RTCBounds::default();
        // SAFETY: the scene is committed; `bounds` is a valid, aligned RTCBounds.
        unsafe { sys::rtcGetSceneBounds(self.scene.0, &mut bounds) };
        // SAFETY: the device is live (borrowed by the builder); the retained
        // reference is released by `DeviceRef::drop`.
        unsafe { sys::rtcRetainDevice(self.device.raw) };
        Ok(Accel {
            scene: self.scene,
            _device: DeviceRef(self.device.raw),
            lower: Vec3::new(bounds.lower_x, bounds.lower_y, bounds.lower_z),
            upper: Vec3::new(bounds.upper_x, bounds.upper_y, bounds.upper_z),
        })
    }
}

/// Embree's filter callback that rejects hits on the back of a triangle:
/// `valid[i]` is cleared where the ray's direction and the hit's geometric
/// normal point the same way.
///
/// `RTCRayN` and `RTCHitN` are structures of `N`-wide arrays (Embree's
/// `rtcore_ray.h`): the ray's direction is at float offsets `4N`, `5N`, `6N`,
/// the hit's normal at `0`, `N`, `2N`.
unsafe extern "C" fn cull_back_faces(args: *const sys::RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a valid argument record whose `valid`, `ray` and
    // `hit` point to `N` lanes of the layouts above, alive for the call;
    // only `valid` is written, within its `N` entries.
    unsafe {
        let args = &*args;
        let n = args.N as usize;
        let ray = args.ray as *const f32;
        let hit = args.hit as *const f32;
        for i in 0..n {
            let valid = args.valid.add(i);
            if *valid == 0 {
                continue;
            }
            let d = Vec3::new(
                *ray.add(4 * n + i),
                *ray.add(5 * n + i),
                *ray.add(6 * n + i),
            );
            let ng = Vec3::new(*hit.add(i), *hit.add(n + i), *hit.add(2 * n + i));
            if d.dot(ng) > 0.0 {
                *valid = 0;
            }
        }
    }
}

/// Owns one reference to an `RTCGeometry`.
struct GeometryHandle(sys::RTCGeometry);

impl Drop for GeometryHandle {
    fn drop(&mut self) {
        // SAFETY: we own one reference; an attached scene holds its own.
        unsafe { sys::rtcReleaseGeometry(self.0) };
    }
}

/// A ray segment `org + t·dir` for `t` in `[tnear, tfar]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ray {
    /// Origin (scene units).
    pub org: Vec3,
    /// Direction; need not be normalised (t is then in units of |dir|).
    pub dir: Vec3,
    /// Start of the segment.
    pub tnear: f32,
    /// End of the segment (`f32::INFINITY` for an unbounded ray).
    pub tfar: f32,
}

impl Ray {
    /// An unbounded ray starting at `tnear = 0`.
    pub fn new(org: Vec3, dir: Vec3) -> Ray {
        Ray {
            org,
            dir,
            tnear: 0.0,
            tfar: f32::INFINITY,
        }
    }

    fn to_rtc(self, mask: u32) -> sys::RTCRay {
        sys::RTCRay {
            org_x: self.org.x,
            org_y: self.org.y,
            org_z: self.org.z,
            tnear: self.tnear,
            dir_x: self.dir.x,
            dir_y: self.dir.y,
            dir_z: self.dir.z,
            time: 0.0,
            tfar: self.tfar,
            mask,
            id: 0,
            flags: 0,
        }
    }
}

/// The closest intersection found along a ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit.
    pub t: f32,
    /// Geometry id given to [`SceneBuilder::add_triangle_mesh`].
    pub geom_id: u32,
    /// Triangle index within that geometry.
    pub prim_id: u32,
    /// Barycentric coordinate of vertex 1.
    pub u: f32,
    /// Barycentric coordinate of vertex 2.
    pub v: f32,
    /// Unnormalised geometric normal, `(p1 − p0) × (p2 − p0)`, in the
    /// space of the geometry hit (an instance's prototype: object space).
    pub ng: Vec3,
    /// The geometry id given to [`SceneBuilder::add_instance`] when the
    /// triangle belongs to an instance (then `geom_id` is the prototype's).
    pub instance: Option<u32>,
}

/// A ray and its hit record in Embree's layout, for batched queries.
///
/// After [`Accel::intersect_stream`], [`RayHit::hit`] reads the result.
#[derive(Clone, Copy, Default)]
#[repr(transparent)]
pub struct RayHit(sys::RTCRayHit);

impl RayHit {
    /// A ray with no hit yet, that sees every geometry.
    pub fn new(ray: Ray) -> RayHit {
        RayHit::masked(ray, ALL_MASK)
    }

    /// A ray with no hit yet, that sees only geometry whose mask shares a
    /// bit with `mask` ([`REAL_MASK`], [`VIRTUAL_MASK`]).
    pub fn masked(ray: Ray, mask: u32) -> RayHit {
        RayHit(sys::RTCRayHit {
            ray: ray.to_rtc(mask),
            hit: sys::RTCHit {
                geomID: INVALID_ID,
                primID: INVALID_ID,
                instID: [INVALID_ID],
                ..Default::default()
            },
        })
    }

    /// The ray (with `tfar` shortened to the hit distance after a query).
    #[inline]
    pub fn ray(&self) -> Ray {
        let r = &self.0.ray;
        Ray {
            org: Vec3::new(r.org_x, r.org_y, r.org_z),
            dir: Vec3::new(r.dir_x, r.dir_y, r.dir_z),
            tnear: r.tnear,
            tfar: r.tfar,
        }
    }

    /// The hit found by the last query, if any.
    #[inline]
    pub fn hit(&self) -> Option<Hit> {
        let h = &self.0.hit;
        (h.geomID != INVALID_ID).then(|| Hit {
            t: self.0.ray.tfar,
            geom_id: h.geomID,
            prim_id: h.primID,
            u: h.u,
            v: h.v,
            ng: Vec3::new(h.Ng_x, h.Ng_y, h.Ng_z),
            instance: (h.instID[0] != INVALID_ID).then_some(h.instID[0]),
        })
    }
}

/// A shadow ray in Embree's layout, for batched occlusion queries.
#[derive(Clone, Copy, Default)]
#[repr(transparent)]
pub struct ShadowRay(sys::RTCRay);

impl ShadowRay {
    /// A shadow ray over `[tnear, tfar]`.
    pub fn new(ray: Ray) -> ShadowRay {
        ShadowRay::masked(ray, ALL_MASK)
    }

    /// A shadow ray blocked only by geometry whose mask shares a bit with
    /// `mask`.
    pub fn masked(ray: Ray, mask: u32) -> ShadowRay {
        ShadowRay(ray.to_rtc(mask))
    }

    /// Whether the last occlusion query found a blocker.
    #[inline]
    pub fn occluded(&self) -> bool {
        self.0.tfar == f32::NEG_INFINITY
    }
}

/// A committed, immutable Embree scene answering ray queries.
pub struct Accel {
    // Field order is drop order: the scene is released before the device
    // reference it was built on.
    scene: SceneHandle,
    _device: DeviceRef,
    lower: Vec3,
    upper: Vec3,
}

/// One counted reference to an Embree device, kept by each [`Accel`] so that
/// its device outlives it: Embree frees a device whose last reference goes
/// inside `rtcReleaseScene` while the scene is still being torn down (an
/// invalid read that valgrind reports), so the scene is released first.
struct DeviceRef(sys::RTCDevice);

impl Drop for DeviceRef {
    fn drop(&mut self) {
        // SAFETY: we own one reference, taken with rtcRetainDevice.
        unsafe { sys::rtcReleaseDevice(self.0) };
    }
}

// SAFETY: a committed Embree scene is immutable and Embree documents its
// rtcIntersect*/rtcOccluded* calls as thread-safe on it; the scene and device
// handles are only released on drop, which needs exclusive ownership, and
// Embree's reference counts are thread-safe.
unsafe impl Send for Accel {}
// SAFETY: as above: `&Accel` only permits queries, which are thread-safe.
unsafe impl Sync for Accel {}

fn context(coherent: bool) -> sys::RTCIntersectContext {
    // Equivalent of the header's inline rtcInitIntersectContext.
    sys::RTCIntersectContext {
        flags: if coherent {
            sys::RTC_INTERSECT_CONTEXT_FLAG_COHERENT
        } else {
            sys::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT
        },
        filter: None,
        instID: [INVALID_ID],
    }
}

impl Accel {
    /// Axis-aligned bounds of the scene: (lower, upper) corners.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (self.lower, self.upper)
    }

    /// The closest hit along `ray`, if any.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        let mut rh = RayHit::new(*ray);
        let mut ctx = context(false);
        // SAFETY: the scene is committed; `ctx` and `rh` are valid, aligned
        // (RTCRayHit is 16-byte aligned by its repr) and live for the call.
        unsafe { sys::rtcIntersect1(self.scene.0, &mut ctx, &mut rh.0) };
        rh.hit()
    }

    /// Whether anything blocks `ray` within `[tnear, tfar]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut r = ray.to_rtc(ALL_MASK);
        let mut ctx = context(false);
        // SAFETY: as in `intersect`.
        unsafe { sys::rtcOccluded1(self.scene.0, &mut ctx, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }

    /// Closest-hit queries for a batch (Embree's stream API, `rtcIntersect1M`).
    ///
    /// `coherent` tells Embree the rays are coherent (camera rays of a tile),
    /// letting it trace them as packets.
    pub fn intersect_stream(&self, rays: &mut [RayHit], coherent: bool) {
        if rays.is_empty() {
            return;
        }
        let mut ctx = context(coherent);
        // SAFETY: `RayHit` is a transparent RTCRayHit, so the slice is an array
        // of `rays.len()` RTCRayHit with stride size_of::<RTCRayHit>().
        unsafe {
            sys::rtcIntersect1M(
                self.scene.0,
                &mut ctx,
                rays.as_mut_ptr() as *mut sys::RTCRayHit,
                rays.len() as u32,
                std::mem::size_of::<sys::RTCRayHit>(),
            )
        };
    }

    /// Closest-hit queries for a batch of incoherent rays, one `rtcIntersect1`
    /// call per ray (Embree's single-ray traversal suits incoherent rays best).
    pub fn intersect_each(&self, rays: &mut [RayHit]) {
        let mut ctx = context(false);
        for r in rays {
            // SAFETY: as in `intersect`; `r.0` is an aligned RTCRayHit.
            unsafe { sys::rtcIntersect1(self.scene.0, &mut ctx, &mut r.0) };
        }
    }

    /// Occlusion queries for a batch (Embree's stream API, `rtcOccluded1M`).
    pub fn occluded_stream(&self, rays: &mut [ShadowRay], coherent: bool) {
        if rays.is_empty() {
            return;
        }
        let mut ctx = context(coherent);
        // SAFETY: `ShadowRay` is a transparent RTCRay; see `intersect_stream`.
        unsafe {
            sys::rtcOccluded1M(
                self.scene.0,
                &mut ctx,
                rays.as_mut_ptr() as *mut sys::RTCRay,
                rays.len() as u32,
                std::mem::size_of::<sys::RTCRay>(),
            )
        };
    }
}

/// A block of 16 lanes, 64-byte aligned (Embree's SoA streams need 16).
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
struct LaneBlock<T: Copy + Default>([T; 16]);

/// One component of a structure-of-arrays ray batch: a growable array whose
/// storage is 64-byte aligned. Its length is set by the owning [`RayBatch`]
/// only; a component replaced by another of a different length makes the
/// batch's queries panic.
#[derive(Clone, Default)]
pub struct LaneArray<T: Copy + Default> {
    blocks: Vec<LaneBlock<T>>,
    len: usize,
}

impl<T: Copy + Default> LaneArray<T> {
    fn resize(&mut self, len: usize, fill: T) {
        let blocks = len.div_ceil(16);
        if blocks > self.blocks.len() {
            self.blocks.resize(blocks, LaneBlock::default());
        }
        let old = self.len;
        self.len = len;
        if len > old {
            self.as_mut_slice()[old..].fill(fill);
        }
    }

    /// A block must hold its 16 lanes without padding (true for the 4-byte
    /// lane types used here), or the blocks would not be contiguous lanes.
    const NO_PADDING: () = assert!(
        std::mem::size_of::<LaneBlock<T>>() == 16 * std::mem::size_of::<T>(),
        "lane type too small for a 64-byte block of 16"
    );

    /// The lanes.
    #[inline]
    pub fn as_slice(&self) -> &[T] {
        let () = Self::NO_PADDING;
        // SAFETY: `LaneBlock` is `repr(C)` over `[T; 16]` without padding
        // (`NO_PADDING`), so the blocks are `16 · blocks.len()` contiguous,
        // initialised `T`s, and `resize` keeps `len` within them.
        unsafe { std::slice::from_raw_parts(self.blocks.as_ptr().cast::<T>(), self.len) }
    }

    /// The lanes, mutable.
    #[inline]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        let () = Self::NO_PADDING;
        // SAFETY: as in `as_slice`; `&mut self` makes the borrow exclusive.
        unsafe { std::slice::from_raw_parts_mut(self.blocks.as_mut_ptr().cast::<T>(), self.len) }
    }

    fn as_mut_ptr(&mut self) -> *mut T {
        self.blocks.as_mut_ptr().cast::<T>()
    }
}

/// Rays and hit records in Embree's structure-of-arrays layout
/// (`RTCRayHitNp`): lane `i` of every component is ray `i`. This is the
/// layout of the vectorised kernels, which read and write whole components.
///
/// A lane whose `tnear > tfar` is inactive: queries skip it (the kernels
/// mark ended paths with `tfar = −∞`). After [`Accel::intersect_batch`], a lane with
/// `geom_id == INVALID_ID` hit nothing, and `tfar` of a hit lane is the hit
/// distance; after [`Accel::occluded_batch`], `tfar == −∞` marks an occluded
/// lane.
#[derive(Clone, Default)]
pub struct RayBatch {
    len: usize,
    /// Origin, x (scene units).
    pub org_x: LaneArray<f32>,
    /// Origin, y.
    pub org_y: LaneArray<f32>,
    /// Origin, z.
    pub org_z: LaneArray<f32>,
    /// Direction, x (need not be unit length).
    pub dir_x: LaneArray<f32>,
    /// Direction, y.
    pub dir_y: LaneArray<f32>,
    /// Direction, z.
    pub dir_z: LaneArray<f32>,
    /// Start of the segment.
    pub tnear: LaneArray<f32>,
    /// End of the segment; the hit distance after a closest-hit query.
    pub tfar: LaneArray<f32>,
    time: LaneArray<f32>,
    mask: LaneArray<u32>,
    id: LaneArray<u32>,
    flags: LaneArray<u32>,
    /// Unnormalised geometric normal of the hit, x.
    pub ng_x: LaneArray<f32>,
    /// Geometric normal, y.
    pub ng_y: LaneArray<f32>,
    /// Geometric normal, z.
    pub ng_z: LaneArray<f32>,
    /// Barycentric coordinate of vertex 1.
    pub u: LaneArray<f32>,
    /// Barycentric coordinate of vertex 2.
    pub v: LaneArray<f32>,
    /// Triangle index of the hit.
    pub prim_id: LaneArray<u32>,
    /// Geometry id of the hit; [`INVALID_ID`] where nothing was hit.
    pub geom_id: LaneArray<u32>,
    inst_id: LaneArray<u32>,
}

impl RayBatch {
    /// Number of lanes.
    #[inline]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the batch has no lanes.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Sets the number of lanes; new lanes are inactive rays with no hit.
    pub fn resize(&mut self, len: usize) {
        self.len = len;
        for c in [
            &mut self.org_x,
            &mut self.org_y,
            &mut self.org_z,
            &mut self.dir_x,
            &mut self.dir_y,
            &mut self.dir_z,
            &mut self.tnear,
            &mut self.time,
            &mut self.ng_x,
            &mut self.ng_y,
            &mut self.ng_z,
            &mut self.u,
            &mut self.v,
        ] {
            c.resize(len, 0.0);
        }
        self.tfar.resize(len, f32::NEG_INFINITY);
        // `id`, `flags` and `time` are never written after this fill, so
        // they hold Embree's defaults in every lane; `mask` only by
        // `set_mask`, with one value for every lane.
        self.mask.resize(len, ALL_MASK);
        self.id.resize(len, 0);
        self.flags.resize(len, 0);
        for c in [&mut self.prim_id, &mut self.geom_id, &mut self.inst_id] {
            c.resize(len, INVALID_ID);
        }
    }

    /// Sets the Embree ray mask of every lane: rays see (or are blocked by)
    /// only geometry whose mask shares a bit with it ([`REAL_MASK`],
    /// [`VIRTUAL_MASK`], [`ALL_MASK`]). Lanes added later by
    /// [`RayBatch::resize`] get [`ALL_MASK`].
    pub fn set_mask(&mut self, mask: u32) {
        self.mask.as_mut_slice().fill(mask);
    }

    /// Replaces lane `i` by `ray`, with no hit yet.
    #[inline]
    pub fn set(&mut self, i: usize, ray: Ray) {
        self.org_x.as_mut_slice()[i] = ray.org.x;
        self.org_y.as_mut_slice()[i] = ray.org.y;
        self.org_z.as_mut_slice()[i] = ray.org.z;
        self.dir_x.as_mut_slice()[i] = ray.dir.x;
        self.dir_y.as_mut_slice()[i] = ray.dir.y;
        self.dir_z.as_mut_slice()[i] = ray.dir.z;
        self.tnear.as_mut_slice()[i] = ray.tnear;
        self.tfar.as_mut_slice()[i] = ray.tfar;
        self.geom_id.as_mut_slice()[i] = INVALID_ID;
        self.prim_id.as_mut_slice()[i] = INVALID_ID;
    }

    /// The ray of lane `i` (`tfar` is the hit distance after a query).
    pub fn ray(&self, i: usize) -> Ray {
        Ray {
            org: Vec3::new(
                self.org_x.as_slice()[i],
                self.org_y.as_slice()[i],
                self.org_z.as_slice()[i],
            ),
            dir: Vec3::new(
                self.dir_x.as_slice()[i],
                self.dir_y.as_slice()[i],
                self.dir_z.as_slice()[i],
            ),
            tnear: self.tnear.as_slice()[i],
            tfar: self.tfar.as_slice()[i],
        }
    }

    /// The hit of lane `i` after a closest-hit query, if any.
    pub fn hit(&self, i: usize) -> Option<Hit> {
        let geom_id = self.geom_id.as_slice()[i];
        (geom_id != INVALID_ID).then(|| Hit {
            t: self.tfar.as_slice()[i],
            geom_id,
            prim_id: self.prim_id.as_slice()[i],
            u: self.u.as_slice()[i],
            v: self.v.as_slice()[i],
            ng: Vec3::new(
                self.ng_x.as_slice()[i],
                self.ng_y.as_slice()[i],
                self.ng_z.as_slice()[i],
            ),
            instance: {
                let id = self.inst_id.as_slice()[i];
                (id != INVALID_ID).then_some(id)
            },
        })
    }

    /// Keeps the rays of the lanes listed in `kept` (ascending), in that
    /// order, and drops the others. The hit records are not kept: every kept
    /// lane has no hit (as after [`RayBatch::set`]), ready for the next query.
    pub fn retain(&mut self, kept: &[u32]) {
        for c in [
            &mut self.org_x,
            &mut self.org_y,
            &mut self.org_z,
            &mut self.dir_x,
            &mut self.dir_y,
            &mut self.dir_z,
            &mut self.tnear,
            &mut self.tfar,
        ] {
            gather_lanes(c.as_mut_slice(), kept);
        }
        self.resize(kept.len());
        self.geom_id.as_mut_slice().fill(INVALID_ID);
        self.prim_id.as_mut_slice().fill(INVALID_ID);
    }

    /// Panics unless every component has the batch's length: components
    /// are public fields, so safe code could replace one (with a
    /// `LaneArray::default()`, say) and Embree would then read past it.
    fn check_lengths(&self) {
        let f32s = [
            &self.org_x,
            &self.org_y,
            &self.org_z,
            &self.dir_x,
            &self.dir_y,
            &self.dir_z,
            &self.tnear,
            &self.tfar,
            &self.time,
            &self.ng_x,
            &self.ng_y,
            &self.ng_z,
            &self.u,
            &self.v,
        ];
        let u32s = [
            &self.mask,
            &self.id,
            &self.flags,
            &self.prim_id,
            &self.geom_id,
            &self.inst_id,
        ];
        assert!(
            f32s.iter().all(|c| c.len == self.len) && u32s.iter().all(|c| c.len == self.len),
            "a RayBatch component was replaced by one of another length"
        );
    }

    fn rtc_rays(&mut self) -> sys::RTCRayNp {
        self.check_lengths();
        sys::RTCRayNp {
            org_x: self.org_x.as_mut_ptr(),
            org_y: self.org_y.as_mut_ptr(),
            org_z: self.org_z.as_mut_ptr(),
            tnear: self.tnear.as_mut_ptr(),
            dir_x: self.dir_x.as_mut_ptr(),
            dir_y: self.dir_y.as_mut_ptr(),
            dir_z: self.dir_z.as_mut_ptr(),
            time: self.time.as_mut_ptr(),
            tfar: self.tfar.as_mut_ptr(),
            mask: self.mask.as_mut_ptr(),
            id: self.id.as_mut_ptr(),
            flags: self.flags.as_mut_ptr(),
        }
    }

    fn rtc_hits(&mut self) -> sys::RTCHitNp {
        self.check_lengths();
        sys::RTCHitNp {
            Ng_x: self.ng_x.as_mut_ptr(),
            Ng_y: self.ng_y.as_mut_ptr(),
            Ng_z: self.ng_z.as_mut_ptr(),
            u: self.u.as_mut_ptr(),
            v: self.v.as_mut_ptr(),
            primID: self.prim_id.as_mut_ptr(),
            geomID: self.geom_id.as_mut_ptr(),
            instID: [self.inst_id.as_mut_ptr()],
        }
    }
}

/// Moves the lanes listed in `kept` (ascending lane indices) to the front,
/// in order: lane `j` becomes old lane `kept[j]`. Each lane moves
/// independently of the others (no running count), which keeps the loop
/// fast when the kept lanes are scattered unpredictably.
///
/// # Panics
/// If an index is out of range or the list is not ascending.
#[inline]
pub fn gather_lanes<T: Copy>(lanes: &mut [T], kept: &[u32]) {
    for (j, &i) in kept.iter().enumerate() {
        assert!(i as usize >= j, "kept lanes must be ascending");
        lanes[j] = lanes[i as usize];
    }
}

impl Accel {
    /// Closest-hit queries for a structure-of-arrays batch (Embree's
    /// `rtcIntersectNp`); inactive lanes are skipped.
    pub fn intersect_batch(&self, batch: &mut RayBatch, coherent: bool) {
        if batch.is_empty() {
            return;
        }
        let mut ctx = context(coherent);
        let rayhit = sys::RTCRayHitNp {
            ray: batch.rtc_rays(),
            hit: batch.rtc_hits(),
        };
        // SAFETY: every component of `batch` has `batch.len()` initialised
        // lanes (`check_lengths`, called by `rtc_rays`/`rtc_hits`) in
        // 64-byte-aligned storage (Embree needs 16), all exclusively borrowed
        // for the call; the scene is committed.
        unsafe { sys::rtcIntersectNp(self.scene.0, &mut ctx, &rayhit, batch.len() as u32) };
    }

    /// Occlusion queries for a structure-of-arrays batch (Embree's
    /// `rtcOccludedNp`): an occluded lane gets `tfar = −∞`; inactive lanes
    /// are skipped. The hit components are left alone.
    pub fn occluded_batch(&self, batch: &mut RayBatch, coherent: bool) {
        if batch.is_empty() {
            return;
        }
        let mut ctx = context(coherent);
        let rays = batch.rtc_rays();
        // SAFETY: as in `intersect_batch`.
        unsafe { sys::rtcOccludedNp(self.scene.0, &mut ctx, &rays, batch.len() as u32) };
    }
}

#[cfg(test)]
mod tests {
    use crate::sys;

    /// `EmbreeError`'s names (in `plsr-base`, which cannot see the
    /// bindings) use Embree's error codes.
    #[test]
    fn error_codes_are_embrees() {
        let named = [
            (sys::RTC_ERROR_UNKNOWN, "unknown error"),
            (sys::RTC_ERROR_INVALID_ARGUMENT, "invalid argument"),
            (sys::RTC_ERROR_INVALID_OPERATION, "invalid operation"),
            (sys::RTC_ERROR_OUT_OF_MEMORY, "out of memory"),
            (sys::RTC_ERROR_UNSUPPORTED_CPU, "unsupported CPU"),
            (sys::RTC_ERROR_CANCELLED, "cancelled"),
        ];
        for (code, name) in named {
            let e = super::EmbreeError {
                code,
                message: "m".into(),
            };
            assert_eq!(e.to_string(), format!("Embree {name}: m"));
        }
    }
}
