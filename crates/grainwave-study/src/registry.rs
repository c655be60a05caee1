//! Dispatch by the `experiment` key: a [`Registry`] is a table with an [`Entry`] per protocol,
//! built from its [`Protocol`] implementation ([`entry`]); check, run, resume and re-plot any
//! protocol of the table through it, and generate the config reference.
//!
//! The kernel knows no study. The table of grainwave's studies is made by the crate above them
//! (`grainwave-experiments`: `registry::PROTOCOLS`); a study's own tests make a table of one:
//!
//! ```ignore
//! static ONE: [Entry; 1] = [entry::<MyProtocol>()];
//! static REGISTRY: Registry = Registry::new(&ONE);
//! REGISTRY.run(&src, &mut ctx)?;
//! ```

use crate::config::{did_you_mean, reference, ConfigError, ConfigSource};
use crate::error::{ExperimentError, Result};
use crate::protocol::{checkpoint_tag, load_state, RunContext};
use crate::study::Protocol;
use crate::work::{Message, Unit, WorkerLink};
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::path::Path;

/// One protocol, as the registry dispatches it: the functions of its [`Protocol`]
/// implementation with the types erased.
pub struct Entry {
    /// The name a config selects it with (`experiment = "…"`).
    pub name: &'static str,
    /// Content tag of its state in `checkpoint.gwck`.
    pub tag: &'static str,
    /// Content tags of earlier layouts of its state that it still reads ([`Protocol::upgrade`]).
    pub earlier_tags: &'static [&'static str],
    /// Introduction of its section of the config reference.
    pub reference: &'static str,
    /// The JSON schema of its raw config.
    pub schema: fn() -> serde_json::Value,
    /// Shape check, validation and the description `grainwave check` prints.
    pub check: fn(&ConfigSource) -> Result<Vec<String>, ConfigError>,
    /// Shape check, validation and the check of the inputs the config names outside itself
    /// ([`Protocol::check_inputs`]).
    pub inputs: fn(&ConfigSource) -> Result<(), ConfigError>,
    /// Shape check, validation and the units of work of the run ([`Protocol::plan`]).
    pub plan: fn(&ConfigSource) -> Result<Vec<Unit>, ConfigError>,
    /// Validates and runs a config into the context's directory.
    pub run: fn(&ConfigSource, &mut RunContext<'_>) -> Result<RunSummary>,
    /// Continues the run of directory `dir` from its checkpoint file.
    pub resume: fn(&Path, &Path, &str, &mut RunContext<'_>) -> Result<RunSummary>,
    /// Re-makes the plots of directory `dir` from its checkpoint file.
    pub plot: fn(&Path, &Path, &str) -> Result<Vec<String>>,
    /// Decodes checkpoint bytes as this protocol's state: the error message, if refused.
    pub decode: fn(&[u8]) -> Option<String>,
    /// Runs, in a worker process, the units of the run whose state (checkpoint bytes) the
    /// coordinator sent, in the given output directory ([`Protocol::serve`]).
    pub serve: fn(&[u8], &Path, &dyn WorkerLink, Arc<AtomicBool>) -> Result<()>,
    /// The files a run writes ([`Protocol::OUTPUTS`]).
    pub outputs: &'static [crate::outputs::OutputFile],
}

fn schema<P: Protocol>() -> serde_json::Value {
    serde_json::to_value(schemars::schema_for!(P::Config)).expect("a schema serializes")
}

/// The schema of protocol `name` (made by `make`), generated once per process: it depends on
/// the types only, and generating it took most of the time of a `check` of a small config.
fn cached_schema(name: &'static str, make: fn() -> serde_json::Value) -> &'static serde_json::Value {
    use std::sync::Mutex;
    static CACHE: Mutex<Vec<(&'static str, &'static serde_json::Value)>> = Mutex::new(Vec::new());
    let mut cache = CACHE.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((_, v)) = cache.iter().find(|(n, _)| *n == name) {
        return v;
    }
    let v: &'static serde_json::Value = Box::leak(Box::new(make()));
    cache.push((name, v));
    v
}

fn check_with<P: Protocol>(src: &ConfigSource) -> Result<Vec<String>, ConfigError> {
    crate::config::check_shapes(src, cached_schema(P::NAME, schema::<P>))?;
    Ok(P::describe(&P::validate(src)?))
}

fn inputs_with<P: Protocol>(src: &ConfigSource) -> Result<(), ConfigError> {
    crate::config::check_shapes(src, cached_schema(P::NAME, schema::<P>))?;
    P::check_inputs(src, &P::validate(src)?)
}

fn plan_with<P: Protocol>(src: &ConfigSource) -> Result<Vec<Unit>, ConfigError> {
    crate::config::check_shapes(src, cached_schema(P::NAME, schema::<P>))?;
    Ok(P::plan(&P::validate(src)?))
}

fn finish<P: Protocol>(state: &mut P::State, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    let out = ctx.out_dir().to_path_buf();
    // A new run saves its starting state before it computes anything: a run killed at any
    // moment leaves a directory that `grainwave resume` continues (a study's own saves come
    // later — e2's every `output.save_every` seconds — and a kill before the first one used to
    // leave a directory that neither `run` nor `resume` accepted).
    if !ctx.path(crate::protocol::CHECKPOINT_FILE).exists() {
        ctx.save_checkpoint(P::TAG, &*state)?;
    }
    if let Some(link) = ctx.remote() {
        // the workers build the same plan from the same state
        let dir = std::fs::canonicalize(&out).unwrap_or_else(|_| out.clone());
        let begin = Message::Begin { tag: P::TAG.to_string(), state: grainwave_core::checkpoint::encode(P::TAG, &*state)?, out: dir }.encode()?;
        for r in 1..=link.workers() {
            link.send(r, &begin).map_err(|e| ExperimentError::Rank { rank: r, message: format!("cannot start: {e}") })?;
        }
    }
    let report = P::run(state, ctx)?;
    Ok(RunSummary { lines: P::summary_lines(&report, &out), report: serde_json::to_value(&report).unwrap_or_default() })
}

fn run_with<P: Protocol>(src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    crate::config::check_shapes(src, cached_schema(P::NAME, schema::<P>))?;
    let spec = P::validate(src)?;
    P::check_inputs(src, &spec)?;
    let mut state = P::start(spec);
    finish::<P>(&mut state, ctx)
}

/// The state in checkpoint `file`, whose content tag `tag` the dispatch has read: the current
/// layout, or an earlier one through [`Protocol::upgrade`].
fn load<P: Protocol>(file: &Path, tag: &str) -> Result<P::State> {
    if tag != P::TAG && P::EARLIER_TAGS.contains(&tag) {
        return P::upgrade(tag, file);
    }
    load_state(file, P::TAG)
}

fn resume_with<P: Protocol>(dir: &Path, file: &Path, tag: &str, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
    let mut state: P::State = load::<P>(file, tag)?;
    belongs_to(dir, P::config(&state))?;
    ctx.log(&format!("resuming from {}", file.display()));
    finish::<P>(&mut state, ctx)
}

fn plot_with<P: Protocol>(dir: &Path, file: &Path, tag: &str) -> Result<Vec<String>> {
    let state: P::State = load::<P>(file, tag)?;
    P::replot(dir, &state)
}

fn serve_with<P: Protocol>(bytes: &[u8], out: &Path, link: &dyn WorkerLink, interrupt: Arc<AtomicBool>) -> Result<()> {
    let mut state: P::State = grainwave_core::checkpoint::decode(bytes, P::TAG, "the state sent by rank 0")?;
    P::serve(&mut state, out, link, interrupt)
}

fn decode_with<P: Protocol>(bytes: &[u8]) -> Option<String> {
    grainwave_core::checkpoint::decode::<P::State>(bytes, P::TAG, "fuzz").err().map(|e| e.to_string())
}

/// The registry entry of protocol `P`.
pub const fn entry<P: Protocol>() -> Entry {
    Entry {
        name: P::NAME,
        tag: P::TAG,
        earlier_tags: P::EARLIER_TAGS,
        reference: P::REFERENCE,
        schema: schema::<P>,
        check: check_with::<P>,
        inputs: inputs_with::<P>,
        plan: plan_with::<P>,
        run: run_with::<P>,
        resume: resume_with::<P>,
        plot: plot_with::<P>,
        decode: decode_with::<P>,
        serve: serve_with::<P>,
        outputs: P::OUTPUTS,
    }
}

/// A table of protocols, in the order of the config reference: dispatch by a config's
/// `experiment` key or a checkpoint's content tag.
#[derive(Clone, Copy)]
pub struct Registry {
    protocols: &'static [Entry],
}

impl Registry {
    /// The registry of the protocols of `protocols` (names and tags distinct).
    pub const fn new(protocols: &'static [Entry]) -> Self {
        Registry { protocols }
    }

    /// Every entry, in the order of the config reference.
    pub fn entries(&self) -> &'static [Entry] {
        self.protocols
    }

    /// Names of the protocols a config can select with `experiment = "…"`.
    pub fn names(&self) -> Vec<&'static str> {
        self.protocols.iter().map(|p| p.name).collect()
    }

    /// The entry of protocol `name`.
    pub fn protocol(&self, name: &str) -> Option<&'static Entry> {
        self.protocols.iter().find(|p| p.name == name)
    }

    /// The protocol a config selects, from its top-level `experiment` key.
    pub fn experiment(&self, src: &ConfigSource) -> Result<&'static Entry, ConfigError> {
        let names = self.names();
        let table: toml::Table = src.parse()?;
        match table.get("experiment") {
            None => Err(src.error_at_key("experiment", format!("missing: say which protocol this file configures (allowed: {})", names.join(", ")))),
            Some(toml::Value::String(name)) => match self.protocol(name) {
                Some(p) => Ok(p),
                None => {
                    let mut msg = format!("unknown experiment `{}`", crate::config::clip(name, 60));
                    if let Some(best) = did_you_mean(name, &names) {
                        msg.push_str(&format!(" — did you mean `{best}`?"));
                    }
                    msg.push_str(&format!(" (allowed: {})", names.join(", ")));
                    Err(src.error_at_key("experiment", msg))
                }
            },
            Some(other) => Err(src.error_at_key("experiment", format!("{} is not a name (allowed: {})", crate::config::clip(&other.to_string(), 60), names.join(", ")))),
        }
    }

    /// Checks the shapes of the file's values against the schema of protocol `name`
    /// ([`crate::config::check_shapes`]); a name that is not a protocol's passes.
    pub fn check_shapes(&self, src: &ConfigSource, name: &str) -> Result<(), ConfigError> {
        match self.protocol(name) {
            Some(p) => crate::config::check_shapes(src, cached_schema(p.name, p.schema)),
            None => Ok(()),
        }
    }

    /// What `grainwave check` prints about a valid config.
    pub fn check(&self, src: &ConfigSource) -> Result<Vec<String>, ConfigError> {
        (self.experiment(src)?.check)(src)
    }

    /// Checks what a valid config names outside itself ([`Protocol::check_inputs`]): `grainwave
    /// check` and `run` call it after [`Registry::check`].
    pub fn check_inputs(&self, src: &ConfigSource) -> Result<(), ConfigError> {
        (self.experiment(src)?.inputs)(src)
    }

    /// The units of work of a run of a config ([`Protocol::plan`]): what a driver of the
    /// scheduler lists and places.
    pub fn plan(&self, src: &ConfigSource) -> Result<Vec<Unit>, ConfigError> {
        (self.experiment(src)?.plan)(src)
    }

    /// Parses, validates and runs a config.
    pub fn run(&self, src: &ConfigSource, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
        (self.experiment(src)?.run)(src, ctx)
    }

    fn by_tag(&self, dir: &Path, tag: &str, what: &str) -> Result<&'static Entry> {
        self.protocols
            .iter()
            .find(|p| p.tag == tag || p.earlier_tags.contains(&tag))
            .ok_or_else(|| ExperimentError::Resume { path: dir.to_path_buf(), reason: format!("its checkpoint holds `{tag}`, which {what}") })
    }

    /// Continues the run whose checkpoint is in `dir`.
    pub fn resume(&self, dir: &Path, ctx: &mut RunContext<'_>) -> Result<RunSummary> {
        let (file, tag) = checkpoint_tag(dir)?;
        // a process killed while writing leaves its temporary file; the resumed run rewrites the file
        for stale in grainwave_core::checkpoint::remove_stale_temporaries(dir) {
            ctx.log(&format!("removed the temporary file {} left by an interrupted write", stale.display()));
        }
        (self.by_tag(dir, &tag, "is not a protocol state")?.resume)(dir, &file, &tag, ctx)
    }

    /// A worker process's whole part in a distributed run (an MPI rank ≠ 0): waits for the
    /// coordinator's [`Message::Begin`] (the protocol state and the output directory), then runs
    /// the units it is sent until [`Message::Quit`] ([`crate::work::serve`]). A `Quit` first (the
    /// coordinator stopped before its run began: bad config, busy directory…) ends it at once.
    pub fn serve(&self, link: &dyn WorkerLink, interrupt: Arc<AtomicBool>) -> Result<()> {
        let rank = link.rank();
        let bytes = link.receive().map_err(|e| crate::work::lost_coordinator(rank, e))?;
        match Message::decode(&bytes)? {
            Message::Begin { tag, state, out } => {
                let entry = self.protocols.iter().find(|p| p.tag == tag).ok_or_else(|| ExperimentError::Rank {
                    rank,
                    message: format!("rank 0 sent the state of an unknown protocol `{}`", crate::config::clip(&tag, 60)),
                })?;
                (entry.serve)(&state, &out, link, interrupt)
            }
            Message::Quit => Ok(()),
            _ => Err(ExperimentError::Rank { rank, message: "rank 0 sent a unit before the run began".into() }),
        }
    }

    /// Re-makes the plots of the run in `dir` from its saved data (series and checkpoint).
    /// Returns the files written, relative to `dir`.
    pub fn plot(&self, dir: &Path) -> Result<Vec<String>> {
        let (file, tag) = checkpoint_tag(dir).map_err(|e| match e {
            // the same checks as `resume`, worded for `plot`
            ExperimentError::Resume { path, reason } => ExperimentError::Plot { path, reason },
            e => e,
        })?;
        match (self.by_tag(dir, &tag, "has no plots")?.plot)(dir, &file, &tag) {
            // a run that has not finished (interrupted, or still running) has not written the
            // data its plots are drawn from: say so, as bad input (exit 2), rather than
            // "cannot write the outputs … No such file" (exit 1)
            Err(ExperimentError::Output(e))
                if !dir.join(crate::outputs::SUMMARY_FILE).exists() && !dir.join(crate::protocol::FAILED_FILE).exists() =>
            {
                Err(ExperimentError::Plot {
                    path: dir.to_path_buf(),
                    reason: format!(
                        "the run has not finished (no {}: interrupted, or still running), so the data of its plots is not there yet ({e}); `grainwave resume {}` finishes it and draws them",
                        crate::outputs::SUMMARY_FILE,
                        dir.display()
                    ),
                })
            }
            other => other,
        }
    }

    /// The protocol whose run directory `dir` is: by the `experiment` key of its
    /// `config.resolved.toml` (written when a run starts), or else by its checkpoint's content
    /// tag. `None` when neither names a protocol of the table.
    pub fn of_directory(&self, dir: &Path) -> Option<&'static Entry> {
        let by_config = || -> Option<&'static Entry> {
            let path = dir.join(crate::outputs::RESOLVED_CONFIG_FILE);
            let bytes = grainwave_core::files::read_bounded(&path, crate::config::MAX_CONFIG_BYTES, "the run's config.resolved.toml").ok()?;
            let table: toml::Table = toml::from_str(std::str::from_utf8(&bytes).ok()?).ok()?;
            self.protocol(table.get("experiment")?.as_str()?)
        };
        by_config().or_else(|| {
            let (_, tag) = checkpoint_tag(dir).ok()?;
            self.protocols.iter().find(|p| p.tag == tag || p.earlier_tags.contains(&tag.as_str()))
        })
    }

    /// The output reference (`docs/outputs.md`): a table of the files of each protocol, generated
    /// from their declarations ([`Protocol::OUTPUTS`]).
    pub fn outputs_markdown(&self) -> String {
        let mut s = String::from(
            "# Output files\n\n\
             Generated from each study's declaration of its outputs (`OUTPUTS` of its crate) by `grainwave reference --outputs`;\n\
             do not edit by hand (a test fails when this file is stale). Paths are relative to the output directory;\n\
             `<name>` stands for one level of a path (a replay's name, an index…). `grainwave inspect DIR` names the files\n\
             of a run directory by these declarations. Files written only under a condition say when.\n\n",
        );
        for p in self.protocols {
            s.push_str(&format!("## `experiment = \"{}\"`\n\n", p.name));
            s.push_str(&crate::outputs::markdown(p.outputs));
            s.push('\n');
        }
        s
    }

    /// The config reference (`docs/config.md`), generated from the key definitions.
    pub fn reference_markdown(&self) -> String {
        let mut s = String::from(
            "# Config reference\n\n\
             Generated from the key definitions by `grainwave reference`; do not edit by hand (a test fails when this file\n\
             is stale). Every config file names its protocol with `experiment = \"…\"`. Units are given per key in the units\n\
             of the user's choice (grainwave is unit-agnostic): `length`, `time`, `mass`, `force` and their combinations;\n\
             keys without a unit are dimensionless. Unknown keys are refused.\n\n",
        );
        for p in self.protocols {
            s.push_str(&reference::markdown(&format!("`experiment = \"{}\"`", p.name), p.reference, &reference::sections(&(p.schema)())));
        }
        s
    }
}

/// The outcome of a run, for the command line.
#[derive(Clone, Debug)]
pub struct RunSummary {
    /// Lines describing the result.
    pub lines: Vec<String>,
    /// The report as JSON.
    pub report: serde_json::Value,
}

/// Checks that a checkpoint belongs to output directory `dir`: the config it carries (every
/// state holds its resolved config) must be the one in the directory's `config.resolved.toml`
/// (experiment, seed and every other key). A checkpoint copied from another run is refused,
/// naming the first key that differs. The directory's file is read as a config of the same type
/// first, so that a key added to the config since the run started (absent from its
/// `config.resolved.toml`) compares with its default: a run started by an earlier version
/// resumes when the checkpoint holds that default, and is refused naming the key otherwise.
pub fn belongs_to<C: serde::Serialize + serde::de::DeserializeOwned>(dir: &Path, config: &C) -> Result<()> {
    let path = dir.join(crate::outputs::RESOLVED_CONFIG_FILE);
    let refuse = |reason: String| ExperimentError::Resume { path: dir.to_path_buf(), reason };
    // written at the start of a run; absent before (then there is nothing to compare)
    if std::fs::symlink_metadata(&path).is_err() {
        return Ok(());
    }
    // a regular file of at most MAX_CONFIG_BYTES: a FIFO would block for ever, `/dev/zero` fill
    // the memory
    let bytes = grainwave_core::files::read_bounded(&path, crate::config::MAX_CONFIG_BYTES, "the run's config.resolved.toml").map_err(|e| refuse(e.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|_| refuse("its config.resolved.toml is not UTF-8 text (allowed: the file grainwave wrote)".into()))?;
    let on_disk: toml::Table = toml::from_str(&text).map_err(|e| refuse(format!("its config.resolved.toml cannot be read: {}", crate::config::clip(e.message(), 200))))?;
    // with the keys it lacks at their defaults, when it reads as a config (else as it is, for
    // the comparison to name what differs)
    let on_disk = match toml::from_str::<C>(&text).ok().and_then(|c| toml::Value::try_from(&c).ok()) {
        Some(filled) => filled,
        None => toml::Value::Table(on_disk),
    };
    let carried = toml::Value::try_from(config).map_err(|e| refuse(format!("the checkpoint's config cannot be compared: {e}")))?;
    if let Some((key, a, b)) = first_difference(&carried, &on_disk, "") {
        return Err(refuse(format!(
            "its checkpoint belongs to another run: key `{key}` is {} in the checkpoint but {} in the directory's config.resolved.toml \
             (copy a run's whole directory, or start a new run)",
            crate::config::clip(&a, 60),
            crate::config::clip(&b, 60)
        )));
    }
    Ok(())
}

/// The first key path where `a` and `b` differ, with both values as text.
fn first_difference(a: &toml::Value, b: &toml::Value, path: &str) -> Option<(String, String, String)> {
    let show = |v: Option<&toml::Value>| v.map_or("absent".to_string(), |v| v.to_string());
    match (a, b) {
        (toml::Value::Table(x), toml::Value::Table(y)) => {
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                let p = if path.is_empty() { k.clone() } else { format!("{path}.{k}") };
                match (x.get(k), y.get(k)) {
                    (Some(u), Some(v)) => {
                        if let Some(d) = first_difference(u, v, &p) {
                            return Some(d);
                        }
                    }
                    (u, v) => return Some((p, show(u), show(v))),
                }
            }
            None
        }
        (toml::Value::Array(x), toml::Value::Array(y)) if x.len() == y.len() => {
            x.iter().zip(y).enumerate().find_map(|(i, (u, v))| first_difference(u, v, &format!("{path}[{i}]")))
        }
        (toml::Value::Float(x), toml::Value::Float(y)) if x == y || (x.is_nan() && y.is_nan()) => None,
        _ if a == b => None,
        _ => Some((path.to_string(), a.to_string(), b.to_string())),
    }
}

