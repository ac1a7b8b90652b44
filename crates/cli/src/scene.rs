//! `fiberlab scene --default [--out FILE]`: the built-in default scene (what `fiberlab render`
//! renders without a scene file) as a TOML template to start a scene from — to standard output,
//! or written to `FILE`.

use crate::files::{output_file_or_stdout, stream_output};
use fiberlab_render::scene_file::DEFAULT_SCENE;
use std::path::PathBuf;

/// Flags of `fiberlab scene`.
#[derive(clap::Args)]
pub struct Args {
    /// Print the built-in default scene (every section documented in
    /// crates/render/src/scene_file.rs), the one `fiberlab render` uses without SCENE.
    #[arg(long = "default", required = true)]
    default_scene: bool,
    /// Write the scene to this file instead of standard output (`-`: standard output); its
    /// directory is checked writable when the command line is read.
    #[arg(long, value_name = "FILE", value_parser = output_file_or_stdout)]
    out: Option<PathBuf>,
}

/// The template text: the default scene without its leading blank line.
fn template() -> &'static str {
    DEFAULT_SCENE.trim_start_matches('\n')
}

/// Prints or writes the default scene.
pub fn run(args: &Args) -> anyhow::Result<()> {
    debug_assert!(args.default_scene);
    stream_output(args.out.as_deref(), false, |out| Ok(out.write_all(template().as_bytes())?))?;
    if let Some(path) = args.out.as_deref().filter(|p| *p != std::path::Path::new("-")) {
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use fiberlab_render::scene_file::SceneFile;
    use std::path::Path;

    /// The template is the default scene: the same text, and it reads as a scene whose
    /// parsed form and settings are the built-in one's.
    #[test]
    fn the_template_is_the_default_scene_and_parses() {
        assert_eq!(template().trim(), DEFAULT_SCENE.trim());
        let printed = SceneFile::parse(template(), Path::new("template.toml")).unwrap();
        let builtin = SceneFile::default_scene();
        assert_eq!(printed.image_size(), builtin.image_size());
        assert_eq!(format!("{:?}", printed.render_settings()), format!("{:?}", builtin.render_settings()));
    }
}
