//! The `mavterm` binary: argument parsing, logging, and choosing a front end.

use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Parser;

use mavterm::app::AppConfig;
use mavterm::cli::{Cli, Command, ReportFormat};
use mavterm::clock::SECOND;
use mavterm::config::FileConfig;
use mavterm::driver::real_time::{RealTime, RealTimeRunner};
use mavterm::driver::virtual_time::{all_virtual, Driver, VirtualRunner};
use mavterm::headless::replay::{run_script, ReplayOptions};
use mavterm::headless::script::Script;
use mavterm::keymap::Keymap;
use mavterm::link::LinkSpec;
use mavterm::tui::{run_terminal, TuiOptions};
use mavterm::ui::Theme;

fn init_logging(path: Option<&std::path::Path>) -> Result<()> {
    let Some(path) = path else { return Ok(()) };
    let file = std::fs::OpenOptions::new()
        .create(true)
        .append(true)
        .open(path)
        .with_context(|| format!("opening log file {}", path.display()))?;
    tracing_subscriber::fmt()
        .with_writer(std::sync::Mutex::new(file))
        .with_ansi(false)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info")),
        )
        .init();
    Ok(())
}

/// The core's settings: flags given, then the config file, then the defaults.
fn app_config(cli: &Cli, file: &FileConfig) -> Result<AppConfig> {
    Ok(AppConfig {
        param_meta: load_param_meta(cli)?,
        ..cli.app_config(file)
    })
}

/// `--param-meta FILE`, or `param-meta.xml` in the config directory when it is there.
fn load_param_meta(cli: &Cli) -> Result<Option<std::sync::Arc<mavterm::params::meta::MetaSet>>> {
    let path = match &cli.param_meta {
        Some(p) => p.clone(),
        None => match mavterm::config::dir().map(|d| d.join("param-meta.xml")) {
            Some(p) if p.is_file() => p,
            _ => return Ok(None),
        },
    };
    let text = std::fs::read_to_string(&path)
        .with_context(|| format!("reading parameter metadata {}", path.display()))?;
    let meta = mavterm::params::meta::MetaSet::parse(&text)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(Some(std::sync::Arc::new(meta)))
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    init_logging(cli.log.as_deref())?;
    let rt = tokio::runtime::Builder::new_multi_thread()
        .worker_threads(2)
        .enable_all()
        .build()?;

    if let Some(Command::Sim {
        listen,
        vehicles,
        options,
    }) = &cli.command
    {
        // --vehicles is the query's `vehicles`, with the same checks.
        let query = match vehicles {
            Some(n) => format!("{options}&vehicles={n}"),
            None => options.clone(),
        };
        let cfg = mavterm::sim::SimConfig::from_query(&query)?;
        eprintln!(
            "mavterm sim: serving {} vehicle(s) on {listen}; Ctrl-C to stop",
            cfg.vehicles
        );
        return rt.block_on(async {
            tokio::select! {
                r = mavterm::sim::serve(listen, cfg) => r.map_err(anyhow::Error::from),
                _ = tokio::signal::ctrl_c() => Ok(()),
            }
        });
    }

    let file = mavterm::config::load_user(cli.config.as_deref())?;
    let links = cli.links(&file);
    let cfg = app_config(&cli, &file)?;
    let keymap = Keymap::load_user(cli.keymap.as_deref())?;

    if cli.headless {
        if let Some(out) = &cli.params_out {
            return params_out(&cli, cfg, out, &links, rt.handle());
        }
        if let Some(input) = &cli.input {
            return replay(&cli, cfg, input, &links, keymap, rt.handle());
        }
        let Some(ReportFormat::Json) = cli.report else {
            bail!("--headless needs --report json or --input FILE");
        };
        let secs = cli.duration.unwrap_or(10.0).max(0.0);
        let app = if all_virtual(&links) {
            let mut r = VirtualRunner::from_specs(&links, cfg)?;
            // With a replay and no --duration: to the end of every log (a sim alongside runs as
            // long); otherwise for the duration.
            let to_end = cli.duration.is_none() && r.run_to_end_of_replays(u64::MAX);
            if !to_end {
                r.advance_to((secs * SECOND as f64) as u64);
            }
            r.app
        } else {
            rt.block_on(mavterm::driver::real_time::run_for(
                &links,
                cfg,
                Duration::from_secs_f64(secs),
            ))
        };
        println!("{}", serde_json::to_string(&app.report())?);
        return Ok(());
    }
    if cli.input.is_some() || cli.report.is_some() {
        bail!("--input and --report need --headless");
    }
    rt.block_on(terminal(&cli, cfg, &links, keymap))
}

/// `--headless --params-out FILE`: the first autopilot's parameters, progress on stderr.
fn params_out(
    cli: &Cli,
    cfg: AppConfig,
    out: &std::path::Path,
    links: &[LinkSpec],
    rt: &tokio::runtime::Handle,
) -> Result<()> {
    use mavterm::headless::params::{file_text, progress, Progress};
    let limit = (cli.duration.unwrap_or(300.0) * SECOND as f64) as u64;
    let mut last = String::new();
    let mut show = |p: &Progress| {
        let line = p.line();
        if line != last {
            eprintln!("{line}");
            last = line;
        }
    };
    let app = if all_virtual(links) {
        let mut r = VirtualRunner::from_specs(links, cfg)?;
        let mut t = 0;
        while t < limit && !progress(&r.app).ended() {
            t += SECOND / 4;
            r.advance_to(t);
            show(&progress(&r.app));
        }
        r.app
    } else {
        let mut runner = RealTimeRunner::start(rt.clone(), links, cfg);
        let start = runner.inner.now();
        let mut front = mavterm::headless::params::StopWhenDone::default();
        let _ = rt.block_on(runner.inner.run(Some(start + limit), &mut front));
        runner.inner.app
    };
    let p = progress(&app);
    show(&p);
    let text = file_text(&app, out);
    match (&p, text) {
        (Progress::Ended { missing: 0, .. }, Some(text)) => {
            mavterm::driver::write_atomic(out, text.as_bytes())
                .with_context(|| format!("writing {}", out.display()))?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        (Progress::Ended { count: 0, .. }, _) => bail!("no parameter came from the vehicle"),
        (Progress::Ended { missing, count, .. }, text) => {
            if let Some(text) = text {
                let partial = out.with_extension("partial");
                mavterm::driver::write_atomic(&partial, text.as_bytes())
                    .with_context(|| format!("writing {}", partial.display()))?;
                eprintln!("wrote what came to {}", partial.display());
            }
            bail!("{missing} of {count} parameters missing")
        }
        (Progress::NoVehicle, _) => bail!("no autopilot heard"),
        (Progress::Running { got, count, .. }, _) => bail!(
            "timed out with {} parameters missing",
            count.map_or("all".to_string(), |c| (c as usize)
                .saturating_sub(*got)
                .to_string())
        ),
    }
}

/// `--headless --input FILE`: replay recorded input on a virtual clock; exit 0 only if the script
/// ran to its end.
/// With only `sim://` and `tlog:` links the run is on a virtual clock (fast, deterministic);
/// otherwise the script's times are real seconds on real links.
fn replay(
    cli: &Cli,
    cfg: AppConfig,
    input: &std::path::Path,
    links: &[LinkSpec],
    keymap: Keymap,
    rt: &tokio::runtime::Handle,
) -> Result<()> {
    let script = Script::load(input)?;
    if let Some(dir) = &cli.screens {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let opts = ReplayOptions {
        size: cli.size,
        screens_dir: cli.screens.clone(),
        ..ReplayOptions::default()
    };
    let stdout = std::io::stdout();
    let (outcome, report) = if all_virtual(links) {
        let mut runner = VirtualRunner::from_specs(links, cfg)?;
        runner.app.keymap = keymap;
        let outcome = run_script(&script, &mut runner, &opts, &mut stdout.lock())?;
        (outcome, runner.app.report())
    } else {
        let mut runner = RealTimeRunner::start(rt.clone(), links, cfg);
        runner.app_mut().keymap = keymap;
        let outcome = run_script(&script, &mut runner, &opts, &mut stdout.lock())?;
        (outcome, runner.app().report())
    };
    if let Some(ReportFormat::Json) = cli.report {
        println!("{}", serde_json::to_string(&report)?);
    }
    if !outcome.completed {
        bail!(
            "the script stopped after {} of its steps (the app quit early)",
            outcome.steps_run
        );
    }
    Ok(())
}

/// The terminal front end over real links (and `sim://` in real time).
async fn terminal(cli: &Cli, cfg: AppConfig, links: &[LinkSpec], keymap: Keymap) -> Result<()> {
    let mut rt = RealTime::start(links, cfg);
    rt.app.keymap = keymap;
    let opts = TuiOptions {
        fps: cli.fps,
        record: cli.record.clone(),
        theme: Theme::from_env(),
    };
    run_terminal(rt, opts).await?;
    Ok(())
}
