//! `-D NAME=VALUE`: a Mitsuba scene's parameters from the command line, as
//! `mitsuba -D` takes them; `--anim-time`: the moment a glTF file is shown at.

/// The `-D` options of a command that reads a scene.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SceneParams {
    /// Set the Mitsuba XML scene's parameter `$NAME` (it overrides the
    /// scene's `<default name="NAME">`), as `mitsuba -D NAME=VALUE`;
    /// repeatable. Each must be used by the scene.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
    /// For a glTF file given as the scene: show its animations at this
    /// time, in seconds (default 0, the first keyframe's pose).
    #[arg(
        long = "anim-time",
        value_name = "SECONDS",
        allow_negative_numbers = true
    )]
    pub anim_time: Option<f32>,
}

impl SceneParams {
    /// What identifies these options in a part file's scene hash: each
    /// `-D NAME=VALUE`, then `--anim-time T` if given.
    pub fn hash_fields(&self) -> Vec<String> {
        let mut fields: Vec<String> = self
            .define
            .iter()
            .map(|(name, value)| format!("-D {name}={value}"))
            .collect();
        if let Some(t) = self.anim_time {
            fields.push(format!("--anim-time {t:?}"));
        }
        fields
    }

    /// The options the scene is read with.
    pub fn options(&self) -> plsr::scene::mitsuba::Options {
        plsr::scene::mitsuba::Options {
            defines: self.define.clone(),
            time: self.anim_time,
        }
    }
}

/// `NAME=VALUE`, the name letters, digits and `_`.
fn parse_define(s: &str) -> Result<(String, String), String> {
    let (name, value) = s
        .split_once('=')
        .ok_or_else(|| format!("`{s}` is not NAME=VALUE (e.g. -D spp=64)"))?;
    if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
        return Err(format!(
            "`{name}`: a parameter's name is letters, digits and `_` (e.g. -D spp=64)"
        ));
    }
    Ok((name.to_string(), value.to_string()))
}
