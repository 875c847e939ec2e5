//! `viewer deform`: a deformable object pushed or released, its static or dynamic shape.

use std::io::{self, Write};
use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, Result, anyhow};
use scene::Scene;
use viewer::cli::{EXIT_BAD_INPUT, EXIT_BAD_SETUP};
use viewer::output::AtomicFile;

use crate::fail;

pub(crate) fn deform_command(args: &viewer::cli::DeformArgs) -> ExitCode {
    use host::deform::{self, Load};
    let scene = match Scene::load(&args.scene).context("invalid scene") {
        Ok(scene) => scene,
        Err(e) => return fail(&e, EXIT_BAD_SETUP),
    };
    let setup = deform::body(&scene, args.object).and_then(|(object, body)| {
        let load = Load::parse(&args.load, object)?;
        let probe = match &args.probe {
            Some(p) => Some(deform::parse_probe(p, object)?),
            None => None,
        };
        Ok((object.space(), body, load, probe))
    });
    let (space, body, load, probe) = match setup {
        Ok(s) => s,
        Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
    };
    match body.lowest_mode_hz() {
        Ok(f) => eprintln!("deform: lowest natural frequency {f:.4} Hz"),
        Err(e) => eprintln!("deform: no natural frequency: {e}"),
    }
    type Writer = Box<dyn FnOnce(&mut std::fs::File) -> Result<()>>;
    let (path, write): (&Path, Writer) = match (&args.out, &args.trace) {
        (Some(out), _) => {
            let (shaped, body) = match deform::static_shape(&scene, args.object, load) {
                Ok(s) => s,
                Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
            };
            let largest = body
                .displacement()
                .iter()
                .map(|d| (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt())
                .fold(0.0, f64::max);
            eprintln!("deform: static: largest control-point displacement {largest:e} m");
            if let Some(plot) = &args.plot {
                let drawn = AtomicFile::create(plot)
                    .with_context(|| format!("cannot create plot {}", plot.display()))
                    .and_then(|file| {
                        viewer::deform_plot::write_png(
                            &scene.objects()[args.object],
                            &shaped.objects()[args.object],
                            load,
                            file.temp_path(),
                            plot,
                        )?;
                        file.commit()
                            .with_context(|| format!("cannot write plot {}", plot.display()))
                    });
                if let Err(e) = drawn {
                    return fail(&e, EXIT_BAD_INPUT);
                }
            }
            (
                out,
                Box::new(move |f| Ok(f.write_all(shaped.to_json_string().as_bytes())?)),
            )
        }
        (None, Some(trace_path)) => {
            let (Some(duration), Some(dt), Some(probe)) = (args.duration, args.dt, probe) else {
                return fail(&anyhow!("--release needs --duration, --dt and --probe"), 2);
            };
            let trace = match deform::release(&scene, args.object, load, duration, dt, probe) {
                Ok(t) => t,
                Err(e) => return fail(&anyhow::Error::new(e), EXIT_BAD_SETUP),
            };
            eprintln!("deform: release: {} steps", trace.len() - 1);
            (
                trace_path,
                Box::new(move |f| Ok(deform::write_trace(io::BufWriter::new(f), space, &trace)?)),
            )
        }
        (None, None) => return fail(&anyhow!("--static needs --out, --release --trace"), 2),
    };
    let out = match AtomicFile::create(path)
        .with_context(|| format!("cannot create {}", path.display()))
    {
        Ok(f) => f,
        Err(e) => return fail(&e, EXIT_BAD_INPUT),
    };
    let written = out
        .file()
        .map_err(anyhow::Error::from)
        .and_then(|mut f| write(&mut f))
        .and_then(|()| out.commit().map_err(anyhow::Error::from))
        .with_context(|| format!("cannot write {}", path.display()));
    match written {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => fail(&e, EXIT_BAD_INPUT),
    }
}
