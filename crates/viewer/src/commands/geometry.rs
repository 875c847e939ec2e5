//! `viewer eval` and `viewer closest`: a patch evaluated, closest points found.

use std::io::{self};
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow};
use scene::{Patch, Scene};
use viewer::cli::{ClosestArgs, EXIT_BAD_INPUT, EXIT_BAD_SETUP, EvalArgs, PatchSelection};
use viewer::closest;
use viewer::eval::{self, EvalError};

use crate::fail;

pub(crate) fn closest_command(args: &ClosestArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let Some(object) = scene.object(args.object) else {
        let n = scene.objects().len();
        let e = anyhow!(
            "--object {}: {} has {n} object(s), indices 0..={}",
            args.object,
            args.scene.display(),
            n.saturating_sub(1)
        );
        return fail(&e, EXIT_BAD_SETUP);
    };
    match closest::run(object, io::stdin().lock(), io::stdout().lock()) {
        Ok(_) => ExitCode::SUCCESS,
        Err(EvalError::Write(e)) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => fail(
            &anyhow::Error::new(e).context(format!(
                "closest on object {} ({:?})",
                args.object,
                object.name()
            )),
            EXIT_BAD_INPUT,
        ),
    }
}

pub(crate) fn eval_command(args: &EvalArgs) -> ExitCode {
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let (label, patch) = match select(&scene, &args.scene, args.select) {
        Ok(selected) => selected,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    match eval::run(patch, io::stdin().lock(), io::stdout().lock()) {
        Ok(_) => ExitCode::SUCCESS,
        // The reader went away (`| head`): not an error of ours.
        Err(EvalError::Write(e)) if e.kind() == io::ErrorKind::BrokenPipe => ExitCode::SUCCESS,
        Err(e) => fail(
            &anyhow::Error::new(e).context(format!("eval of {label}")),
            EXIT_BAD_INPUT,
        ),
    }
}

/// The selected patch and a label naming it: `object 1 ("circle"), patch 0 (planar curve)`.
pub(crate) fn select<'a>(
    scene: &'a Scene,
    file: &Path,
    sel: PatchSelection,
) -> Result<(String, &'a Patch)> {
    let objects = scene.objects().len();
    let object = scene.object(sel.object).ok_or_else(|| {
        anyhow!(
            "--object {}: {} has {objects} object(s), indices 0..={}",
            sel.object,
            file.display(),
            objects.saturating_sub(1)
        )
    })?;
    let patches = object.patches().len();
    let patch = object.patch(sel.patch).ok_or_else(|| {
        anyhow!(
            "--patch {}: object {} ({:?}) has {patches} patch(es), indices 0..={}",
            sel.patch,
            sel.object,
            object.name(),
            patches.saturating_sub(1)
        )
    })?;
    let label = format!(
        "object {} ({:?}), patch {} ({})",
        sel.object,
        object.name(),
        sel.patch,
        patch.kind()
    );
    Ok((label, patch))
}
