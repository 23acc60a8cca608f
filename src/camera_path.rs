//! Camera paths: the camera's pose per animation frame.
//!
//! A scene file gives keyframes in `[[camera.path]]` tables, each at a
//! whole frame number with a look-at pose:
//!
//! ```toml
//! [[camera.path]]
//! frame = 0
//! position = [0, 1, 4]
//! look_at = [0, 1, 0]
//! [[camera.path]]
//! frame = 24
//! position = [2, 1, 3]
//! look_at = [0, 1, 0]
//! up = [0, 1, 0]          # default: camera.up, or +y
//! ```
//!
//! Frames run from the first key's to the last key's, both included.
//! Between two keys, `position`, `look_at` and `up` are interpolated
//! linearly (`a + (b − a)·t` with `t = (frame − frame_a)/(frame_b − frame_a)`),
//! and the pose is built from them as `[camera]`'s own look-at. Everything
//! else about the camera (type, field of view, resolution, focus) is the
//! `[camera]` table's and the same in every frame; so is the rest of the
//! scene, which is why one process can render many frames over one
//! acceleration structure.

use crate::camera::{CameraError, Pose};
use glam::Vec3;
use std::ops::RangeInclusive;

/// The largest frame number a path may name.
pub const MAX_FRAME: u32 = 9_999_999;

/// One keyframe of a [`CameraPath`]: a look-at pose (scene units) at a frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathKey {
    /// The frame number (0 to [`MAX_FRAME`]).
    pub frame: u32,
    /// Centre of projection.
    pub position: Vec3,
    /// The point the camera looks at.
    pub look_at: Vec3,
    /// Which way is up in the image (need not be perpendicular to the view).
    pub up: Vec3,
}

/// Why a camera path cannot be built; `key` indexes the offending keyframe.
#[derive(Debug, Clone, PartialEq)]
pub enum CameraPathError {
    /// No keyframes.
    Empty,
    /// A frame number beyond [`MAX_FRAME`].
    FrameTooLarge { key: usize, frame: u32 },
    /// Frame numbers not strictly increasing.
    NotIncreasing {
        key: usize,
        frame: u32,
        previous: u32,
    },
    /// A frame whose interpolated pose is not a camera (its position and
    /// look-at coincide, or up is parallel to the view).
    BadPose { frame: u32, error: CameraError },
}

impl std::fmt::Display for CameraPathError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CameraPathError::Empty => write!(f, "a camera path needs at least one keyframe"),
            CameraPathError::FrameTooLarge { frame, .. } => {
                write!(f, "frame {frame} is beyond the largest, {MAX_FRAME}")
            }
            CameraPathError::NotIncreasing {
                frame, previous, ..
            } => write!(
                f,
                "frame {frame} does not follow the previous key's frame {previous} (frames must increase)"
            ),
            CameraPathError::BadPose { frame, error } => {
                write!(f, "the pose interpolated at frame {frame} is not a camera: {error}")
            }
        }
    }
}

/// A camera path: keyframes with increasing frame numbers, linearly
/// interpolated between (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct CameraPath {
    keys: Vec<PathKey>,
}

impl CameraPath {
    /// A path through `keys`, checked: at least one key, frames strictly
    /// increasing and at most [`MAX_FRAME`], and a valid pose at every
    /// frame of the path (so that rendering any frame cannot fail).
    pub fn new(keys: Vec<PathKey>) -> Result<CameraPath, CameraPathError> {
        if keys.is_empty() {
            return Err(CameraPathError::Empty);
        }
        for (key, k) in keys.iter().enumerate() {
            if k.frame > MAX_FRAME {
                return Err(CameraPathError::FrameTooLarge {
                    key,
                    frame: k.frame,
                });
            }
            if key > 0 && k.frame <= keys[key - 1].frame {
                return Err(CameraPathError::NotIncreasing {
                    key,
                    frame: k.frame,
                    previous: keys[key - 1].frame,
                });
            }
        }
        let path = CameraPath { keys };
        for frame in path.frames() {
            path.pose_at(frame)
                .map_err(|error| CameraPathError::BadPose { frame, error })?;
        }
        Ok(path)
    }

    /// The keyframes.
    pub fn keys(&self) -> &[PathKey] {
        &self.keys
    }

    /// The frames of the path: the first key's to the last key's.
    pub fn frames(&self) -> RangeInclusive<u32> {
        self.keys[0].frame..=self.keys[self.keys.len() - 1].frame
    }

    /// The look-at pose at `frame`, which must lie in [`CameraPath::frames`]
    /// (outside, the nearest end's pose).
    pub fn pose_at(&self, frame: u32) -> Result<Pose, CameraError> {
        // The last key at or before `frame`, and the one after it.
        let i = self.keys.partition_point(|k| k.frame <= frame);
        let (position, look_at, up) = if i == 0 {
            let k = &self.keys[0];
            (k.position, k.look_at, k.up)
        } else if i == self.keys.len() {
            let k = &self.keys[i - 1];
            (k.position, k.look_at, k.up)
        } else {
            let (a, b) = (&self.keys[i - 1], &self.keys[i]);
            // In f64 so that the weight of long paths stays exact enough.
            let t = ((frame - a.frame) as f64 / (b.frame - a.frame) as f64) as f32;
            let lerp = |x: Vec3, y: Vec3| x + (y - x) * t;
            (
                lerp(a.position, b.position),
                lerp(a.look_at, b.look_at),
                lerp(a.up, b.up),
            )
        };
        Pose::look_at(position, look_at, up)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(frame: u32, x: f32) -> PathKey {
        PathKey {
            frame,
            position: Vec3::new(x, 0.0, 5.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
        }
    }

    #[test]
    fn keys_are_hit_exactly_and_frames_between_interpolate() {
        let path = CameraPath::new(vec![key(10, 0.0), key(20, 4.0), key(22, -2.0)]).unwrap();
        assert_eq!(path.frames(), 10..=22);
        assert_eq!(path.pose_at(10).unwrap().position.x, 0.0);
        assert_eq!(path.pose_at(20).unwrap().position.x, 4.0);
        assert_eq!(path.pose_at(15).unwrap().position.x, 2.0);
        assert_eq!(path.pose_at(21).unwrap().position.x, 1.0);
        assert_eq!(path.pose_at(22).unwrap().position.x, -2.0);
        // The pose looks at look_at.
        let p = path.pose_at(15).unwrap();
        let to_target = (Vec3::ZERO - p.position).normalize();
        assert!((p.forward - to_target).length() < 1e-6);
    }

    #[test]
    fn bad_paths_are_refused() {
        assert_eq!(CameraPath::new(vec![]), Err(CameraPathError::Empty));
        assert!(matches!(
            CameraPath::new(vec![key(3, 0.0), key(3, 1.0)]),
            Err(CameraPathError::NotIncreasing { key: 1, .. })
        ));
        // Passing through the look-at point at frame 1.
        let through = vec![
            PathKey {
                frame: 0,
                position: Vec3::new(-1.0, 0.0, 0.0),
                look_at: Vec3::ZERO,
                up: Vec3::Y,
            },
            PathKey {
                frame: 2,
                position: Vec3::new(1.0, 0.0, 0.0),
                look_at: Vec3::ZERO,
                up: Vec3::Y,
            },
        ];
        assert!(matches!(
            CameraPath::new(through),
            Err(CameraPathError::BadPose { frame: 1, .. })
        ));
    }
}
