//! `-D NAME=VALUE`: a Mitsuba scene's parameters from the command line, as
//! `mitsuba -D` takes them.

/// The `-D` options of a command that reads a scene.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct SceneParams {
    /// Set the Mitsuba XML scene's parameter `$NAME` (it overrides the
    /// scene's `<default name="NAME">`), as `mitsuba -D NAME=VALUE`;
    /// repeatable. Each must be used by the scene.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define)]
    pub define: Vec<(String, String)>,
}

impl SceneParams {
    /// The options the scene is read with.
    pub fn options(&self) -> plsr::scene::mitsuba::Options {
        plsr::scene::mitsuba::Options {
            defines: self.define.clone(),
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
