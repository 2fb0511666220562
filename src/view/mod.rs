//! `haze view`: a fog, a scene or a smoke asset in the window; its flags and their
//! conversion into `haze_viewer`'s options are in [`args`].

mod args;

pub use args::*;

use anyhow::Result;
use haze_render::output::Outputs;
use haze_viewer::fog::FogViewArgs;
use haze_viewer::scene::SceneViewArgs;

/// `haze view`: a fog, a scene file or a smoke asset in the window.
pub fn run(v: ViewCli) -> Result<()> {
    let unused = v.unused_flags();
    if !unused.is_empty() {
        let (what, to) = match (&v.scene, &v.fog) {
            (Some(scene), _) => (
                format!("--scene {}", scene.display()),
                "to a smoke asset or a fog, not to a scene file (its camera, lights and media are in the file)",
            ),
            (None, Some(fog)) => (
                format!("--fog {}", fog.display()),
                "to a smoke asset, not to a fog",
            ),
            (None, None) => (
                v.input
                    .as_ref()
                    .map(|p| p.display().to_string())
                    .unwrap_or_default(),
                "to a fog (--fog FOGMAP), not to a smoke asset",
            ),
        };
        anyhow::bail!("{what}: {} {to}", crate::unused_flags::apply(&unused));
    }
    if let Some(fogmap) = v.fog {
        return haze_viewer::fog::run(FogViewArgs {
            fogmap,
            model: v.fog_model.into(),
            smoke: v.fog_smoke.into(),
            fps: v.fps,
            width: v.size.0,
            height: v.size.1,
            exposure: v.exposure,
            play_for: v.play_for,
            window: !v.no_window,
        });
    }
    if v.fog_smoke.smoke.is_some() {
        anyhow::bail!(
            "--smoke shows a smoke asset in a fog: give --fog FOGMAP too (`haze view FILE.haze` shows the asset alone)"
        );
    }
    if let (Some(scene), Some(save)) = (&v.scene, &v.save_edits) {
        haze_render::scene::files_named(scene)
            .iter()
            .fold(Outputs::new().input(scene), |f, p| f.input(p))
            .output("--save-edits", save)
            .check()?;
    }
    match v.scene {
        Some(scene) => haze_viewer::scene::run(SceneViewArgs {
            scene,
            width: v.size.0,
            height: v.size.1,
            exposure: v.exposure,
            play_for: v.play_for,
            window: !v.no_window,
            ray_traced: v.ray_traced,
            strokes: v.stroke,
            save_edits: v.save_edits,
        }),
        None => haze_viewer::smoke::run(v.into_args()),
    }
}
