//! The `mavterm` binary: argument parsing, logging, and choosing a front end.

use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Parser;

use mavterm::app::AppConfig;
use mavterm::cli::{Cli, Command, ReportFormat};
use mavterm::clock::SECOND;
use mavterm::headless::runner::{all_virtual, VirtualRunner};
use mavterm::link::LinkSpec;

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

fn app_config(cli: &Cli) -> AppConfig {
    AppConfig {
        sysid: cli.sysid,
        compid: cli.compid,
        lost_timeout: (cli.lost_timeout.max(0.1) * SECOND as f64) as u64,
        ..AppConfig::default()
    }
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    init_logging(cli.log.as_deref())?;
    let mut links = cli.links.clone();
    if links.is_empty() {
        links.push(LinkSpec::Sim {
            query: String::new(),
        });
    }
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
        let mut cfg = mavterm::sim::SimConfig::from_query(options)?;
        if let Some(n) = vehicles {
            cfg.vehicles = *n;
        }
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

    if cli.headless {
        if cli.input.is_some() {
            bail!("--input replay is not built in yet");
        }
        let Some(ReportFormat::Json) = cli.report else {
            bail!("--headless needs --report json or --input FILE");
        };
        let secs = cli.duration.unwrap_or(10.0).max(0.0);
        let app = if all_virtual(&links) {
            let mut r = VirtualRunner::from_specs(&links, app_config(&cli))?;
            r.advance_to((secs * SECOND as f64) as u64);
            r.app
        } else {
            rt.block_on(mavterm::link::manager::run_for(
                &links,
                app_config(&cli),
                Duration::from_secs_f64(secs),
            ))
        };
        println!("{}", serde_json::to_string(&app.report())?);
        return Ok(());
    }
    bail!("the terminal UI is not built in yet; use --headless --report json")
}
