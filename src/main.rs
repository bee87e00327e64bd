//! The `mavterm` binary: argument parsing, logging, and choosing a front end.

use std::io::Write;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use clap::Parser;

use mavterm::app::AppConfig;
use mavterm::cli::{Cli, Command, ReportFormat};
use mavterm::clock::SECOND;
use mavterm::config::FileConfig;
use mavterm::driver::real_time::{RealTime, RealTimeRunner};
use mavterm::driver::record::TlogTarget;
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

/// The core's settings: flags given, then the config file, then the defaults. `wall_clock`:
/// the run is on the wall clock (real links, or the terminal), so the signing timestamp is kept
/// across runs; a virtual run neither reads nor writes it.
fn app_config(cli: &Cli, file: &FileConfig, wall_clock: bool) -> Result<AppConfig> {
    Ok(AppConfig {
        param_meta: load_param_meta(cli)?,
        param_meta_cache: mavterm::paths::cache_dir(),
        logs_dir: mavterm::paths::logs_dir(),
        param_meta_url: std::env::var("MAVTERM_PARAM_META_URL")
            .ok()
            .filter(|u| !u.trim().is_empty()),
        signing: load_signing(cli, file, wall_clock)?,
        zone: cli.display_zone(file, chrono::Utc::now()),
        ..cli.app_config(file)
    })
}

/// `--signing-key` (else the config file's `signing_key`): the key, and the timestamp kept.
fn load_signing(
    cli: &Cli,
    file: &FileConfig,
    wall_clock: bool,
) -> Result<Option<mavterm::app::signing::SigningConfig>> {
    let Some(spec) = cli.signing_key.as_deref().or(file.signing_key.as_deref()) else {
        return Ok(None);
    };
    let allow_hb =
        cli.signing_allow_unsigned_heartbeat || file.signing_allow_unsigned_heartbeat == Some(true);
    let state = if wall_clock {
        let path = mavterm::signing_store::state_path();
        if path.is_none() {
            eprintln!("mavterm: no home directory: the signing timestamp is not kept between runs");
        }
        path
    } else {
        None
    };
    Ok(Some(mavterm::signing_store::signing_config(
        spec, allow_hb, state,
    )?))
}

/// Keep the last signing timestamp for the next run (when signing).
fn save_signing(app: &mavterm::app::App) -> Result<()> {
    mavterm::signing_store::save_final(app).context("keeping the signing timestamp")
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
    let text = mavterm::fsio::read_text(&path, 64 * 1024 * 1024)
        .with_context(|| format!("reading parameter metadata {}", path.display()))?;
    let meta = mavterm::params::meta::MetaSet::parse(&text)
        .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(Some(std::sync::Arc::new(meta)))
}

/// Errors are printed once, on stderr; a closed stdout (`mavterm ... | head -1`) ends the run
/// quietly with status 0, as `head`'s users expect.
fn main() -> ExitCode {
    // Only the pages of code and data it runs stay resident (see the module): trimmed now, once
    // starting up is over, then twice a minute. A failure to read smaps leaves them as mapped.
    if mavterm::resident::trim_file_mappings().is_ok() {
        mavterm::resident::keep_trimmed(Duration::from_secs(5), Duration::from_secs(30));
    }
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if broken_pipe(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{}", error_text(&e));
            ExitCode::FAILURE
        }
    }
}

/// Set when a write to stdout failed because its reader went away.
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The error is stdout's reader going away (not a broken pipe of a link or a GCS).
fn broken_pipe(e: &anyhow::Error) -> bool {
    STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed)
        && e.chain().any(|c| {
            c.downcast_ref::<std::io::Error>()
                .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
        })
}

/// Stdout, noting in [`STDOUT_CLOSED`] when its reader has gone.
struct Stdout(std::io::StdoutLock<'static>);

impl Stdout {
    fn lock() -> Stdout {
        Stdout(std::io::stdout().lock())
    }

    fn note<T>(r: std::io::Result<T>) -> std::io::Result<T> {
        if let Err(e) = &r {
            if e.kind() == std::io::ErrorKind::BrokenPipe {
                STDOUT_CLOSED.store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
        r
    }
}

impl Write for Stdout {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        Stdout::note(self.0.write(buf))
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Stdout::note(self.0.flush())
    }
}

/// `Error: MESSAGE`, then each cause whose text the lines before do not already say (an error
/// that shows its source, e.g. `keymap FILE: No such file`, is not followed by the same cause
/// again).
fn error_text(e: &anyhow::Error) -> String {
    let mut text = format!("Error: {e}");
    for cause in e.chain().skip(1) {
        let cause = cause.to_string();
        if !text.contains(&cause) {
            text.push_str(&format!("\nCaused by: {cause}"));
        }
    }
    text
}

/// Write one line to stdout, an error when nobody reads it any more.
fn print_line(line: &str) -> Result<()> {
    let mut out = Stdout::lock();
    writeln!(out, "{line}")?;
    out.flush()?;
    Ok(())
}

/// Print the headless report; then refuse a run in which no link ever came up (the report is
/// printed all the same, for the reasons in it).
fn print_report(app: &mavterm::app::App) -> Result<()> {
    print_line(&serde_json::to_string(&app.report())?)?;
    if let Some(why) = app.all_links_stayed_down() {
        bail!("{why}");
    }
    Ok(())
}

fn run(cli: Cli) -> Result<()> {
    init_logging(cli.log.as_deref())?;
    // The terminal and a headless report run their loop, links and timers on this one thread
    // (`Runtime::block_on`): a frame, a key or a timer wakes no other thread (with worker
    // threads, each was a wake-up of another thread, most of what an idle session cost). The
    // simulator serving many vehicles, and the script-driven headless runs (which step the
    // links from outside the runtime, by `Handle::block_on`, which only drives a runtime with
    // workers), have two workers.
    let stepped =
        cli.headless && (cli.params_out.is_some() || cli.logs_out.is_some() || cli.input.is_some());
    let rt = if stepped || matches!(cli.command, Some(Command::Sim { .. })) {
        tokio::runtime::Builder::new_multi_thread()
            .worker_threads(2)
            .enable_all()
            .build()?
    } else {
        tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .build()?
    };
    let result = run_on(cli, &rt);
    // A worker still blocked in the kernel (a file that never answers) must not keep the process
    // alive after quit; a save in progress gets this long to finish.
    rt.shutdown_timeout(Duration::from_secs(2));
    result
}

fn run_on(cli: Cli, rt: &tokio::runtime::Runtime) -> Result<()> {
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
        return rt.block_on(async {
            // Bound first: "serving" is said only of a socket that is there.
            let bound = mavterm::sim::server::bind(listen).await?;
            eprintln!(
                "mavterm sim: serving {} simulated ArduCopter V{} vehicle(s) on {listen}; Ctrl-C to stop",
                cfg.vehicles,
                mavterm::sim::ARDUCOPTER_VERSION
            );
            tokio::select! {
                r = mavterm::sim::server::serve_bound(bound, cfg) => r.map_err(anyhow::Error::from),
                _ = tokio::signal::ctrl_c() => Ok(()),
            }
        });
    }

    let file = mavterm::config::load_user(cli.config.as_deref())?;
    // A replay script, loaded first: its `# link` lines (from --record) are the links when no
    // --link is given.
    let script = match (&cli.input, cli.headless) {
        (Some(input), true) => Some(Script::load(input)?),
        _ => None,
    };
    let links = match &script {
        Some(s) if cli.links.is_empty() && !s.links.is_empty() => {
            script_links(s, cli.input.as_deref())?
        }
        _ => cli.links(&file),
    };
    let cfg = app_config(&cli, &file, !cli.headless || !all_virtual(&links))?;
    // A run that reads no keys (a headless report, a parameter download) does not need the
    // keymap: a broken one is a warning there, and the default is used.
    let reads_keys = !cli.headless || cli.input.is_some();
    let keymap = match Keymap::load_user(cli.keymap.as_deref()) {
        Ok(k) => k,
        Err(e) if !reads_keys => {
            eprintln!("warning: {e}\n(this run reads no keys: the default keymap is used)");
            Keymap::default()
        }
        Err(e) => return Err(e.into()),
    };
    let edge = Edge {
        tlog: cli.tlog_target(&links),
        outs: cli.outs.clone(),
        utc: cli.wants_utc(&file),
    };
    // Forwarding is to ground stations in real time: `sim://` then runs on the wall clock too.
    let virtual_clock = all_virtual(&links) && edge.outs.is_empty();

    if cli.headless {
        if let Some(out) = &cli.params_out {
            return params_out(&cli, cfg, out, &links, &edge, rt.handle());
        }
        if let Some(dir) = &cli.logs_out {
            return logs_out(&cli, cfg, dir, &links, &edge, rt.handle());
        }
        if let Some(script) = &script {
            return replay(&cli, cfg, script, &links, &edge, keymap, rt.handle());
        }
        let Some(ReportFormat::Json) = cli.report else {
            bail!("--headless needs --report json or --input FILE");
        };
        let secs = cli.duration.unwrap_or(10.0).max(0.0);
        let app = if virtual_clock {
            let mut r = VirtualRunner::from_specs(&links, cfg)?;
            edge.start_virtual(&mut r);
            // With a replay and no --duration: to the end of every log (a sim alongside runs as
            // long); otherwise for the duration.
            let to_end = cli.duration.is_none() && r.run_to_end_of_replays(u64::MAX);
            if !to_end {
                r.advance_to((secs * SECOND as f64) as u64);
            }
            r.finish_recording();
            r.app
        } else {
            rt.block_on(mavterm::driver::real_time::run_for_with(
                &links,
                cfg,
                Duration::from_secs_f64(secs),
                |r| edge.start_real(r),
            ))
        };
        save_signing(&app)?;
        return print_report(&app);
    }
    if cli.input.is_some() || cli.report.is_some() {
        bail!("--input and --report need --headless");
    }
    rt.block_on(terminal(&cli, cfg, &links, &edge, keymap))
}

/// What runs at the edge besides the links: the telemetry log and the forwarding outputs.
struct Edge {
    tlog: Result<Option<TlogTarget>, String>,
    outs: Vec<LinkSpec>,
    /// Times shown in UTC (`--utc`, config `utc`), else in local time.
    utc: bool,
}

impl Edge {
    fn start_real(&self, r: &mut RealTime) {
        match &self.tlog {
            Ok(Some(t)) => r.record(t),
            Ok(None) => {}
            Err(e) => r.step(not_recording(e)),
        }
        r.forward(&self.outs);
    }

    /// On the virtual clock: recording only (forwarding runs on the wall clock). Local time is
    /// shown as it was at the run's start (a tlog's first record), daylight saving included.
    fn start_virtual(&self, r: &mut VirtualRunner) {
        if !self.utc {
            r.app.cfg.zone = mavterm::cli::local_zone(r.app.cfg.epoch);
        }
        match &self.tlog {
            Ok(Some(t)) => r.record(t),
            Ok(None) => {}
            // The default log (the only one that can be missing a place) is the terminal's.
            Err(_) => {}
        }
    }
}

fn not_recording(why: &str) -> mavterm::app::Event {
    mavterm::app::Event::Recording(mavterm::app::tap::RecordingStatus {
        path: std::path::PathBuf::new(),
        bytes: 0,
        dropped: 0,
        error: Some(why.to_string()),
    })
}

/// `--headless --logs-out DIR`: the first autopilot's onboard logs, progress on stderr.
fn logs_out(
    cli: &Cli,
    mut cfg: AppConfig,
    dir: &std::path::Path,
    links: &[LinkSpec],
    edge: &Edge,
    rt: &tokio::runtime::Handle,
) -> Result<()> {
    use mavterm::headless::logs::{drive, Progress, StopWhenDone};
    // Logs only: no parameter or component metadata download shares the link with them.
    cfg.fetch_params = false;
    let limit = (cli.duration.unwrap_or(3600.0) * SECOND as f64) as u64;
    let (app, p) = if all_virtual(links) && edge.outs.is_empty() {
        let mut r = VirtualRunner::from_specs(links, cfg)?;
        edge.start_virtual(&mut r);
        let (mut t, mut asked, mut last) = (0, false, String::new());
        let mut p = Progress::NoVehicle;
        // What the links carried (time, bytes heard) while downloads ran: how full they were.
        let mut carried: Option<((u64, u64), (u64, u64))> = None;
        while t < limit && !p.ended() {
            t += SECOND / 4;
            r.advance_to(t);
            p = drive(&mut r.app, dir, &cli.log_ids, &mut asked);
            let line = format!("{p:?}");
            if line != last {
                eprintln!("{line}");
                last = line;
            }
            let running = r.app.sessions.values().any(|s| {
                s.logs
                    .transfer
                    .as_ref()
                    .is_some_and(|t| t.state == mavterm::proto::logs::State::Running)
            });
            if running {
                let heard = (r.now(), r.app.links.iter().map(|l| l.parser.bytes).sum());
                carried = Some((carried.map_or(heard, |c| c.0), heard));
            }
        }
        if let Some(((t0, b0), (t1, b1))) = carried.filter(|c| c.1 .0 > c.0 .0) {
            eprintln!(
                "links carried {:.0} B/s while downloading",
                (b1 - b0) as f64 * 1e6 / (t1 - t0) as f64
            );
        }
        // Time is up with a download running: LOG_REQUEST_END (the vehicle logs again).
        r.event(mavterm::app::Event::Ending);
        r.finish_recording();
        (r.app, p)
    } else {
        let mut runner = RealTimeRunner::start(rt.clone(), links, cfg);
        {
            let _in_rt = rt.enter();
            edge.start_real(&mut runner.inner);
        }
        let start = runner.inner.now();
        let mut front = StopWhenDone {
            dir: dir.to_path_buf(),
            ids: cli.log_ids.clone(),
            asked: false,
            last: String::new(),
            progress: None,
        };
        let _ = rt.block_on(runner.inner.run(Some(start + limit), &mut front));
        runner.inner.finish();
        (
            runner.inner.app,
            front.progress.unwrap_or(Progress::NoVehicle),
        )
    };
    save_signing(&app)?;
    match p {
        Progress::Done(saved) => {
            if let Some(s) = app.target.and_then(|k| app.sessions.get(&k)) {
                let l = &s.logs.list;
                if let Some(done) = l.done {
                    eprintln!(
                        "listed {} logs in {:.2} s ({} requests, {} again)",
                        l.entries.len(),
                        done.saturating_sub(l.started) as f64 / 1e6,
                        l.requests,
                        l.retries
                    );
                }
                for (id, bytes, us, requests, retries) in &s.logs.stats {
                    let secs = *us as f64 / 1e6;
                    eprintln!(
                        "log {id}: {bytes} bytes in {secs:.2} s = {:.0} B/s ({requests} requests, {retries} retries)",
                        *bytes as f64 / secs.max(1e-6)
                    );
                }
            }
            for (id, path) in saved {
                eprintln!("log {id}: wrote {}", path.display());
            }
            Ok(())
        }
        Progress::Failed(why) => bail!("{why}"),
        Progress::NoVehicle => bail!("no autopilot heard"),
        Progress::Running(at) => bail!("not complete in the time given: {at}"),
    }
}

/// `--headless --params-out FILE`: the first autopilot's parameters, progress on stderr.
fn params_out(
    cli: &Cli,
    cfg: AppConfig,
    out: &std::path::Path,
    links: &[LinkSpec],
    edge: &Edge,
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
    let app = if all_virtual(links) && edge.outs.is_empty() {
        let mut r = VirtualRunner::from_specs(links, cfg)?;
        edge.start_virtual(&mut r);
        let mut t = 0;
        while t < limit && !progress(&r.app).ended() {
            t += SECOND / 4;
            r.advance_to(t);
            show(&progress(&r.app));
        }
        r.finish_recording();
        r.app
    } else {
        let mut runner = RealTimeRunner::start(rt.clone(), links, cfg);
        {
            let _in_rt = rt.enter();
            edge.start_real(&mut runner.inner);
        }
        let start = runner.inner.now();
        let mut front = mavterm::headless::params::StopWhenDone::default();
        let _ = rt.block_on(runner.inner.run(Some(start + limit), &mut front));
        runner.inner.finish();
        runner.inner.app
    };
    save_signing(&app)?;
    let p = progress(&app);
    show(&p);
    let text = file_text(&app, out);
    let result = params_result(&app, &p, text, out);
    // `--report json` with `--params-out`: the report too, whatever became of the file.
    if let Some(ReportFormat::Json) = cli.report {
        print_line(&serde_json::to_string(&app.report())?)?;
    }
    result
}

/// The file written (or what came, as `.partial`), or why not.
fn params_result(
    app: &mavterm::app::App,
    p: &mavterm::headless::params::Progress,
    text: Option<String>,
    out: &std::path::Path,
) -> Result<()> {
    use mavterm::headless::params::Progress;
    match (p, text) {
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
        (Progress::NoVehicle, _) => match app.all_links_stayed_down() {
            Some(why) => bail!("no autopilot heard: {why}"),
            None => bail!("no autopilot heard"),
        },
        (Progress::Running { got, count, .. }, _) => bail!(
            "timed out with {} parameters missing",
            count.map_or("all".to_string(), |c| (c as usize)
                .saturating_sub(*got)
                .to_string())
        ),
    }
}

/// A script's `# link SPEC` lines as links.
fn script_links(script: &Script, path: Option<&std::path::Path>) -> Result<Vec<LinkSpec>> {
    let name = path.map(|p| p.display().to_string()).unwrap_or_default();
    script
        .links
        .iter()
        .map(|(line, spec)| {
            spec.parse::<LinkSpec>()
                .map_err(|e| anyhow::anyhow!("{name} line {line}: link `{spec}`: {e}"))
        })
        .collect()
}

/// `--headless --input FILE`: replay recorded input on a virtual clock; exit 0 only if the script
/// ran to its end.
/// With only `sim://` and `tlog:` links the run is on a virtual clock (fast, deterministic);
/// otherwise the script's times are real seconds on real links.
fn replay(
    cli: &Cli,
    cfg: AppConfig,
    script: &Script,
    links: &[LinkSpec],
    edge: &Edge,
    keymap: Keymap,
    rt: &tokio::runtime::Handle,
) -> Result<()> {
    if let Some(dir) = &cli.screens {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let opts = ReplayOptions {
        size: cli
            .size
            .or(script.size)
            .unwrap_or(mavterm::headless::replay::DEFAULT_SIZE),
        screens_dir: cli.screens.clone(),
        ..ReplayOptions::default()
    };
    let (outcome, report, down) = if all_virtual(links) && edge.outs.is_empty() {
        let mut runner = VirtualRunner::from_specs(links, cfg)?;
        runner.app.keymap = keymap;
        edge.start_virtual(&mut runner);
        let outcome = run_script(script, &mut runner, &opts, &mut Stdout::lock());
        runner.finish_recording(); // also when stdout was closed: the log is kept whole
        (
            outcome?,
            runner.app.report(),
            runner.app.all_links_stayed_down(),
        )
    } else {
        let mut runner = RealTimeRunner::start(rt.clone(), links, cfg);
        runner.app_mut().keymap = keymap;
        {
            let _in_rt = rt.enter();
            edge.start_real(&mut runner.inner);
        }
        let outcome = run_script(script, &mut runner, &opts, &mut Stdout::lock());
        runner.inner.finish();
        save_signing(runner.app())?;
        let down = runner.app().all_links_stayed_down();
        (outcome?, runner.app().report(), down)
    };
    let reported = cli.report.is_some();
    if let Some(ReportFormat::Json) = cli.report {
        print_line(&serde_json::to_string(&report)?)?;
    }
    if !outcome.completed {
        bail!(
            "the script stopped after {} of its steps (the app quit early)",
            outcome.steps_run
        );
    }
    if let (true, Some(why)) = (reported, down) {
        bail!("{why}");
    }
    Ok(())
}

/// The terminal front end over real links (and `sim://` in real time).
async fn terminal(
    cli: &Cli,
    cfg: AppConfig,
    links: &[LinkSpec],
    edge: &Edge,
    keymap: Keymap,
) -> Result<()> {
    let mut rt = RealTime::start(links, cfg);
    rt.app.keymap = keymap;
    edge.start_real(&mut rt);
    let opts = TuiOptions {
        fps: cli.fps,
        record: cli.record.clone(),
        links: links.iter().map(ToString::to_string).collect(),
        theme: Theme::from_env(),
    };
    let app = run_terminal(rt, opts).await?;
    save_signing(&app)?;
    // Where the flight went, once the screen is back.
    if let Some(st) = &app.recording {
        match &st.error {
            None => eprintln!(
                "telemetry log: {} ({})",
                st.path.display(),
                mavterm::ui::fmt::size(st.bytes)
            ),
            Some(e) if !st.path.as_os_str().is_empty() => {
                eprintln!("telemetry log {}: {e}", st.path.display())
            }
            Some(e) => eprintln!("no telemetry log: {e}"),
        }
    }
    Ok(())
}
