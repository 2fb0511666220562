//! `haze render`: a scene file or a smoke frame rendered to an image; its flags and their
//! conversion into `haze_render`'s options are in [`args`].

pub(crate) mod args;

pub use args::*;

use anyhow::Result;
use haze_render::output::Outputs;
use haze_render::scene::SceneJob;
use haze_tradeoff::render_choice;

/// `haze render`: a scene file, or a smoke frame (its knobs first chosen for a goal).
pub fn run(r: RenderCli) -> Result<()> {
    if let (Some(input), Some(scene)) = (&r.input, &r.scene) {
        anyhow::bail!(
            "{} and --scene {}: render a volume or asset, or a scene file, not both",
            input.display(),
            scene.display()
        );
    }
    if let Some(scene) = &r.scene {
        let ignored = r.smoke_flags_given();
        if !ignored.is_empty() {
            anyhow::bail!(
                "--scene {}: {} to a volume or asset, not to a scene file (its camera, lights and media are in the file)",
                scene.display(),
                crate::unused_flags::apply(&ignored)
            );
        }
    }
    let mut files = Outputs::new();
    if let Some(input) = &r.input {
        files = files.input(input);
    }
    if let Some(scene) = &r.scene {
        files = haze_render::scene::files_named(scene)
            .iter()
            .fold(files.input(scene), |f, p| f.input(p));
    }
    if r.lights.env != "sky" && r.lights.env != "glow" {
        files = files.input(std::path::Path::new(&r.lights.env));
    }
    if let Some(t) = &r.tradeoff {
        files = files.input(t);
    }
    files.output("--out", &r.out).check()?;
    let (width, height) = (r.width(), r.height());
    match r.scene {
        Some(scene) => haze_render::scene::render_scene(SceneJob {
            scene,
            width,
            height,
            out: r.out,
            reference: r.reference,
            gpu: r.gpu,
            exposure: r.exposure,
            tone: r.tone,
            time: r.time,
            march: r.march,
            exact_per_pair: r.exact_per_pair.map(usize::from),
            pair_reuse: usize::from(r.pair_reuse),
            sky_shadow: r.sky_shadow == args::SkyShadowArg::Exact,
        }),
        None => {
            let (options, goal, tradeoff) = r.into_args();
            match goal {
                Some(goal) => {
                    // The values a choice keeps are checked before its sweep.
                    haze_render::smoke::check_exposure(options.exposure)?;
                    render_choice::render_for_goal(options, goal, tradeoff.as_deref())
                }
                None => haze_render::smoke::render(options).map(|_| ()),
            }
        }
    }
}
