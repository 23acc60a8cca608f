//! The farm plan: how a render is cut into pieces, written once to
//! `OUTDIR/farm.toml` and read by every piece and by the merge.
//!
//! Piece `i` (0 ≤ i < frames × parts) renders frame `frames[i / parts]`
//! and part `k = i % parts`, whose sample indices are
//! `[k·spp/parts, (k+1)·spp/parts)`: the parts of a frame cover its samples
//! exactly once, so their merge is the image one render of all `spp`
//! samples gives. A piece writes `parts/[frame-NNNN/]samples-START-END.exr`
//! under the plan's folder; the merge writes `NAME.exr` (`NAME-NNNN.exr`
//! per frame) and its PNG there.

use crate::error::{Error, Result};
use crate::render::part_hash;
use plsr::atomic_write::OutputSet;
use plsr::film::part::{scene_files_hasher, Part, StableHasher};
use plsr_base::Vocabulary;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::path::{Path, PathBuf};

/// The plan's file name in the output folder.
pub const PLAN_FILE: &str = "farm.toml";

/// The most pieces (frames × parts) a plan may have, written or read
/// back: Kubernetes takes at most 100,000 completions per Job and Slurm's
/// arrays are smaller still by default.
pub const MAX_PIECES: u64 = 1_000_000;

/// The plan: everything a piece or the merge needs besides the scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FarmPlan {
    /// The scene file, relative to the plan's folder (so that the plan
    /// works wherever the shared folder is mounted) or absolute.
    pub scene: PathBuf,
    /// Samples per pixel of each frame, all parts together.
    pub spp: u32,
    /// Parts per frame (each a range of sample indices), 1 to `spp`.
    pub parts: u32,
    /// First and last frame (both included) of the camera path to render;
    /// absent: the scene's camera as it is.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub frames: Option<[u32; 2]>,
    /// The merged outputs' name: `NAME.exr`, or `NAME-NNNN.exr` per frame.
    pub name: String,
    /// Whether the merge writes a PNG beside each EXR.
    pub png: bool,
    /// A Mitsuba scene's `-D NAME=VALUE` parameters, in order, as
    /// `[name, value]` pairs.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub defines: Vec<[String; 2]>,
    /// For a glTF file as the scene: `--anim-time`, the time (s) its animations
    /// are shown at.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<f32>,
    /// The random seed, instead of the scene's `[render] seed`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub seed: Option<u64>,
    /// The image size `[width, height]` in pixels, instead of the scene's
    /// `camera.resolution` (the vertical field of view is kept).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<[u32; 2]>,
}

/// One piece of a plan: a sample range of one frame.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Piece {
    /// Its index: the Slurm array task id or Kubernetes completion index.
    pub index: u32,
    /// The frame, or `None` for a still.
    pub frame: Option<u32>,
    /// The sample indices it renders.
    pub samples: Range<u32>,
}

impl FarmPlan {
    /// Reads a plan file.
    pub fn read(path: &Path) -> Result<FarmPlan> {
        let text = std::fs::read_to_string(path)
            .map_err(|source| Error::io(path.to_path_buf(), source))?;
        let plan: FarmPlan = toml::from_str(&text).map_err(|e| {
            // The key and line the parser stopped at (a value out of
            // range names only its type otherwise).
            let (key, line) = match e.span() {
                Some(span) => {
                    let line = text[..span.start.min(text.len())].lines().count().max(1);
                    let key = text
                        .lines()
                        .nth(line - 1)
                        .and_then(|l| l.split_once('='))
                        .map_or("", |(k, _)| k.trim());
                    (key, format!("line {line}: "))
                }
                None => ("", String::new()),
            };
            Error::input(
                path,
                key,
                format!("not a farm plan: {line}{}", e.message().trim_end()),
            )
        })?;
        plan.check()
            .map_err(|(field, m)| Error::input(path, field, m))?;
        Ok(plan)
    }

    /// Checks the numbers: spp between 1 and [`plsr::job::MAX_SPP`], parts
    /// between 1 and spp, frames in order, a name that is a plain file
    /// name, and at most [`MAX_PIECES`] pieces.
    pub fn check(&self) -> std::result::Result<(), (&'static str, String)> {
        if self.spp == 0 || self.spp > plsr::job::MAX_SPP {
            return Err((
                "spp",
                format!(
                    "must be between 1 and {}, got {}",
                    plsr::job::MAX_SPP,
                    self.spp
                ),
            ));
        }
        if self.parts == 0 || self.parts > self.spp {
            return Err((
                "parts",
                format!(
                    "must be between 1 and spp ({}): each part renders at least one sample, got {}",
                    self.spp, self.parts
                ),
            ));
        }
        if let Some([w, h]) = self.resolution {
            if !(1..=1 << 16).contains(&w) || !(1..=1 << 16).contains(&h) {
                return Err((
                    "resolution",
                    format!("{w}×{h}: each side must be 1 to 65536 pixels"),
                ));
            }
        }
        if let Some([a, b]) = self.frames {
            if a > b {
                return Err(("frames", format!("first frame {a} is after the last, {b}")));
            }
        }
        if self.name.is_empty() || self.name.contains(['/', '\\']) || self.name.starts_with('.') {
            return Err(("name", format!("{:?} is not a plain file name", self.name)));
        }
        if let Some([n, _]) = self.defines.iter().find(|[n, _]| {
            n.is_empty() || !n.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        }) {
            return Err((
                "defines",
                format!("`{n}` is not a parameter name (letters, digits and `_`)"),
            ));
        }
        if self.piece_count_u64() > MAX_PIECES {
            return Err((
                "parts",
                format!(
                    "{} pieces (frames × parts): at most {MAX_PIECES}, so that `farm status` \
                     and `farm merge` check a bounded number of files",
                    self.piece_count_u64()
                ),
            ));
        }
        Ok(())
    }

    /// Writes the plan to `dir/farm.toml` (atomically).
    pub fn write(&self, dir: &Path) -> Result<PathBuf> {
        let path = dir.join(PLAN_FILE);
        let text = format!(
            "# A render cut into pieces by `plsr farm` (see docs/farm.md): piece i renders\n\
             # frame (i / parts) and sample range (i % parts); `plsr farm piece {PLAN_FILE} i`\n\
             # renders it, `plsr farm merge {PLAN_FILE}` merges them, `plsr farm status` lists them.\n{}",
            toml::to_string(self).expect("a plan serialises")
        );
        let mut outputs = OutputSet::new();
        outputs.stage_bytes(&path, text.as_bytes())?;
        outputs.commit()?;
        Ok(path)
    }

    fn piece_count_u64(&self) -> u64 {
        let frames = match self.frames {
            Some([a, b]) => u64::from(b.saturating_sub(a)) + 1,
            None => 1,
        };
        frames * u64::from(self.parts)
    }

    /// The samples of one part, as a message says it: `16 spp` when the
    /// parts are equal, `16–17 spp` when they are not.
    pub fn part_spp(&self) -> String {
        let low = self.spp / self.parts;
        if self.spp.is_multiple_of(self.parts) {
            format!("{low} spp")
        } else {
            format!("{low}–{} spp", low + 1)
        }
    }

    /// How many pieces: frames × parts.
    pub fn piece_count(&self) -> u32 {
        self.piece_count_u64() as u32
    }

    /// The frames, in order (`[None]` for a still).
    pub fn frame_list(&self) -> Vec<Option<u32>> {
        match self.frames {
            Some([a, b]) => (a..=b).map(Some).collect(),
            None => vec![None],
        }
    }

    /// Piece `index`, or `None` past the last.
    pub fn piece(&self, index: u32) -> Option<Piece> {
        if index >= self.piece_count() {
            return None;
        }
        let frame = self.frames.map(|[a, _]| a + index / self.parts);
        let k = (index % self.parts) as u64;
        let bound = |k: u64| (k * self.spp as u64 / self.parts as u64) as u32;
        Some(Piece {
            index,
            frame,
            samples: bound(k)..bound(k + 1),
        })
    }

    /// Every piece, in index order.
    pub fn pieces(&self) -> impl Iterator<Item = Piece> + '_ {
        (0..self.piece_count()).filter_map(|i| self.piece(i))
    }

    /// The scene file's path, seen from where the plan is (`dir`).
    pub fn scene_path(&self, dir: &Path) -> PathBuf {
        dir.join(&self.scene)
    }

    /// The `-D` parameters the scene is read with.
    pub fn scene_params(&self) -> crate::scene_params::SceneParams {
        crate::scene_params::SceneParams {
            define: self
                .defines
                .iter()
                .map(|[n, v]| (n.clone(), v.clone()))
                .collect(),
            anim_time: self.time,
        }
    }

    /// The part file piece `p` writes.
    pub fn part_path(&self, dir: &Path, p: &Piece) -> PathBuf {
        let file = format!("samples-{:06}-{:06}.exr", p.samples.start, p.samples.end);
        match p.frame {
            Some(f) => dir.join("parts").join(format!("frame-{f:04}")).join(file),
            None => dir.join("parts").join(file),
        }
    }

    /// The merged EXR (and PNG) of `frame`.
    pub fn output_paths(&self, dir: &Path, frame: Option<u32>) -> (PathBuf, Option<PathBuf>) {
        let stem = match frame {
            Some(f) => format!("{}-{f:04}", self.name),
            None => self.name.clone(),
        };
        (
            dir.join(format!("{stem}.exr")),
            self.png.then(|| dir.join(format!("{stem}.png"))),
        )
    }
}

/// Decides which pieces are done: a piece is done when its part file reads
/// as a part of the scene as it is now (same scene hash: same files, same
/// settings, same frame) with the piece's sample range over the whole image.
pub struct DoneCheck {
    files_hasher: StableHasher,
    job: plsr::job::RenderJob,
    image: (u32, u32),
    /// The window a part holds: the image, or the film's crop window.
    window: plsr::film::Tile,
}

impl DoneCheck {
    /// Reads the scene of the plan in `dir` (its files, not its geometry's
    /// acceleration structure).
    pub fn new(plan: &FarmPlan, dir: &Path) -> Result<DoneCheck> {
        let scene = plan.scene_path(dir);
        let params = plan.scene_params();
        let contents = plsr::scene::file::load_contents_with(&scene, &params.options())?;
        let mut files = vec![scene];
        files.extend(contents.inputs);
        let camera = &contents.description.camera;
        // As `plsr render` hashes a part's scene: its files, then its -D.
        let mut files_hasher = scene_files_hasher(&files)?;
        for field in params.hash_fields() {
            files_hasher.field(field.as_bytes());
        }
        let image = match plan.resolution {
            Some([w, h]) => (w, h),
            None => (camera.width(), camera.height()),
        };
        let mut job = contents.description.job;
        if let Some(seed) = plan.seed {
            job.seed = seed;
        }
        Ok(DoneCheck {
            files_hasher,
            job,
            image,
            window: plsr::film::part::image_window(contents.description.film, image),
        })
    }

    /// Whether piece `p`'s part file is there and is the piece.
    pub fn is_done(&self, plan: &FarmPlan, dir: &Path, p: &Piece) -> bool {
        let path = plan.part_path(dir, p);
        path.is_file() && self.is_current(&path, p.frame, p.samples.clone())
    }

    /// Whether `path` reads as a render of the scene as it is now (its
    /// files, settings and `frame`) holding `samples` of its window.
    pub fn is_current(&self, path: &Path, frame: Option<u32>, samples: Range<u32>) -> bool {
        let Ok(part) = Part::read_exr(path) else {
            return false;
        };
        let i = &part.info;
        i.scene_hash == part_hash(self.files_hasher, &self.job, frame)
            && i.image == self.image
            && i.samples() == samples
            && i.window == self.window
    }

    /// The indices of the pieces not done.
    pub fn missing(&self, plan: &FarmPlan, dir: &Path) -> Vec<u32> {
        plan.pieces()
            .filter(|p| !self.is_done(plan, dir, p))
            .map(|p| p.index)
            .collect()
    }

    /// Of the pieces not done, those whose part file is there but is not
    /// the piece (rendered before the scene or its settings changed).
    pub fn stale(&self, plan: &FarmPlan, dir: &Path) -> Vec<u32> {
        plan.pieces()
            .filter(|p| plan.part_path(dir, p).is_file() && !self.is_done(plan, dir, p))
            .map(|p| p.index)
            .collect()
    }
}

/// Indices as Slurm's `--array` writes them: runs joined, `0-3,5,7-9`.
pub fn index_list(indices: &[u32]) -> String {
    let mut out: Vec<String> = Vec::new();
    let mut i = 0;
    while i < indices.len() {
        let mut j = i;
        while j + 1 < indices.len() && indices[j + 1] == indices[j] + 1 {
            j += 1;
        }
        out.push(if i == j {
            indices[i].to_string()
        } else {
            format!("{}-{}", indices[i], indices[j])
        });
        i = j + 1;
    }
    out.join(",")
}

/// `to` relative to the folder `from` (both made absolute first), or `to`
/// made absolute where they share nothing but the root.
pub fn relative_path(from: &Path, to: &Path) -> Result<PathBuf> {
    let abs =
        |p: &Path| std::fs::canonicalize(p).map_err(|source| Error::io(p.to_path_buf(), source));
    let (from, to) = (abs(from)?, abs(to)?);
    Ok(plsr_base::paths::relative_between(&from, &to))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plan(spp: u32, parts: u32, frames: Option<[u32; 2]>) -> FarmPlan {
        FarmPlan {
            scene: "s.toml".into(),
            spp,
            parts,
            frames,
            name: "image".into(),
            png: false,
            defines: Vec::new(),
            time: None,
            seed: None,
            resolution: None,
        }
    }

    #[test]
    fn a_part_s_samples_are_said_as_a_range_when_unequal() {
        assert_eq!(plan(64, 4, None).part_spp(), "16 spp");
        assert_eq!(plan(66, 4, None).part_spp(), "16–17 spp");
        assert_eq!(plan(3, 3, None).part_spp(), "1 spp");
    }

    #[test]
    fn hand_edited_counts_are_refused_before_anything_loops_over_them() {
        // Parts = spp = 10⁹: beyond the most samples one render takes.
        let e = plan(1_000_000_000, 1_000_000_000, None)
            .check()
            .unwrap_err();
        assert_eq!(e.0, "spp", "{e:?}");
        // Frames 0 to 4·10⁹ of one part each: too many pieces to list.
        let e = plan(1, 1, Some([0, 4_000_000_000])).check().unwrap_err();
        assert_eq!(e.0, "parts", "{e:?}");
        assert!(e.1.contains("4000000001 pieces"), "{e:?}");
        assert!(plan(1 << 24, 1000, Some([1, 1000])).check().is_ok());
        // A value beyond u32 names its key and line.
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join(PLAN_FILE);
        std::fs::write(
            &file,
            "scene = \"s.toml\"\nspp = 1099511627776\nparts = 4\nname = \"image\"\npng = false\n",
        )
        .unwrap();
        let e = FarmPlan::read(&file).unwrap_err().to_string();
        assert!(
            e.contains("farm.toml") && e.contains("spp") && e.contains("line 2"),
            "{e}"
        );
    }

    #[test]
    fn the_parts_of_a_frame_cover_its_samples_once() {
        for (spp, parts) in [(16, 4), (10, 3), (7, 7), (1000, 999)] {
            let p = plan(spp, parts, Some([5, 7]));
            assert_eq!(p.piece_count(), 3 * parts);
            for frame in 5..=7 {
                let mut next = 0;
                for piece in p.pieces().filter(|x| x.frame == Some(frame)) {
                    assert_eq!(piece.samples.start, next);
                    assert!(piece.samples.end > piece.samples.start);
                    next = piece.samples.end;
                }
                assert_eq!(next, spp);
            }
        }
        assert!(plan(16, 4, None).piece(4).is_none());
        assert!(plan(4, 5, None).check().is_err());
    }

    #[test]
    fn index_lists_join_runs() {
        assert_eq!(index_list(&[0, 1, 2, 3, 5, 7, 8, 9]), "0-3,5,7-9");
        assert_eq!(index_list(&[4]), "4");
        assert_eq!(index_list(&[]), "");
    }
}
