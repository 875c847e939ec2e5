//! `viewer gui` (and `viewer` alone): the desktop app.

use std::process::ExitCode;

#[cfg(feature = "gui")]
use anyhow::Context;
#[cfg(not(feature = "gui"))]
use anyhow::anyhow;
#[cfg(feature = "gui")]
use scene::Scene;
#[cfg(feature = "gui")]
use viewer::cli::EXIT_BAD_INPUT;
use viewer::cli::{EXIT_BAD_SETUP, GuiArgs};

use crate::fail;
#[cfg(feature = "gui")]
use crate::{interrupt_or_default, interrupted_or_success};

#[cfg(feature = "gui")]
pub(crate) fn gui_command(args: &GuiArgs) -> ExitCode {
    // The scene is checked before the window opens, so that a bad one is a setup error.
    if let Some(path) = &args.scene
        && let Err(e) = Scene::load(path).context("invalid scene")
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    if let Some(path) = &args.mesh
        && let Err(e) = viewer::gui::surface_scene::load_mesh(path).context("invalid mesh")
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    if let Some(path) = &args.record
        && let Err(e) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .with_context(|| format!("cannot create the record file {}", path.display()))
    {
        return fail(&e, EXIT_BAD_SETUP);
    }
    let spec = match crate::device_spec(args.device_spec.as_deref()) {
        Ok(spec) => spec,
        Err(code) => return code,
    };
    let options = viewer::gui::GuiOptions {
        spec,
        scene: args.scene.clone(),
        record: args.record.clone(),
        quit_after_frames: args.quit_after_frames,
        device: args.device.0.clone(),
        demo: args.demo,
        mesh: args.mesh.clone(),
        // Ctrl-C or SIGTERM closes the window as a click would; the recording is completed.
        interrupt: Some(interrupt_or_default("viewer gui")),
    };
    let interrupt = options.interrupt.clone().unwrap_or_default();
    match viewer::gui::run(options) {
        Ok(summary) => {
            eprintln!("viewer gui: {summary}");
            interrupted_or_success(&interrupt)
        }
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}

#[cfg(not(feature = "gui"))]
pub(crate) fn gui_command(_: &GuiArgs) -> ExitCode {
    let e = anyhow!(
        "this viewer was built without its `gui` feature; use a subcommand (viewer --help) \
         or rebuild with the default features"
    );
    fail(&e, EXIT_BAD_SETUP)
}
