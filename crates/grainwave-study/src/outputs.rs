//! The outputs every protocol writes the same way: the resolved config and the summary.
//!
//! * `config.resolved.toml` ([`write_resolved_config`]): the config of the run with every default
//!   filled in, under a comment header naming the protocol and the engine version. `grainwave
//!   resume` compares it with the config a checkpoint carries (`registry::belongs_to`).
//! * `summary.json` ([`write_summary`]): the protocol's typed report, written atomically.
//!
//! And the declaration of the files a study writes ([`OutputFile`]): every study lists its
//! outputs once (`OUTPUTS` of its crate, [`crate::study::Protocol::OUTPUTS`]), with a path
//! pattern ([`pattern_matches`]), a format and a description. `grainwave inspect DIR` names the
//! files of a run directory by them, the output reference (`docs/outputs.md`, [`markdown`]) is
//! generated from them, and each study's tests check that a run writes no undeclared file.

use crate::error::Result;
use serde::Serialize;
use std::path::Path;

/// Name of the resolved config in an output directory.
pub const RESOLVED_CONFIG_FILE: &str = "config.resolved.toml";
/// Name of the summary (the report as JSON) in an output directory.
pub const SUMMARY_FILE: &str = "summary.json";

/// Writes `config.resolved.toml` into `out` (atomically): a header naming the protocol
/// `experiment` and the engine version, then `note` (lines of comment about keys whose values
/// are computed during the run; empty when there is none), then `config` as TOML.
pub fn write_resolved_config<C: Serialize>(out: &Path, experiment: &str, config: &C, note: &str) -> Result<()> {
    let text = resolved_config_text(experiment, config, note);
    grainwave_core::checkpoint::atomic_write(&out.join(RESOLVED_CONFIG_FILE), text.as_bytes())?;
    Ok(())
}

/// The text of `config.resolved.toml` ([`write_resolved_config`]).
pub fn resolved_config_text<C: Serialize>(experiment: &str, config: &C, note: &str) -> String {
    let text = toml::to_string_pretty(config).expect("a config serializes to TOML");
    let mut header = format!("# The config of this {experiment} run with every default filled in (grainwave {}).\n", grainwave_core::VERSION);
    for line in note.lines() {
        header.push_str(&format!("# {line}\n"));
    }
    header.push_str("# Running it again gives the same results, bit for bit.\n\n");
    format!("{header}{text}")
}

/// Writes the report `report` as `summary.json` into `out` (atomically).
pub fn write_summary<R: Serialize>(out: &Path, report: &R) -> Result<()> {
    grainwave_io::write_json_atomic(&out.join(SUMMARY_FILE), report)?;
    Ok(())
}

/// The format of an output file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// CSV table (header line, then rows; `grainwave_io::CsvTable`).
    Csv,
    /// JSON document.
    Json,
    /// TOML document.
    Toml,
    /// NumPy archive of named arrays (`.npz`).
    Npz,
    /// NumPy array (`.npy`).
    Npy,
    /// PNG image (plot).
    Png,
    /// SVG image (plot).
    Svg,
    /// VTK XML poly data (`.vtp`, ParaView).
    Vtp,
    /// ParaView collection of VTK files over time (`.pvd`).
    Pvd,
    /// grainwave checkpoint (`.gwck`: checksummed, tagged binary state; `grainwave inspect` reads it).
    Checkpoint,
    /// Plain text.
    Text,
}

impl Format {
    /// The name the output reference and `grainwave inspect` show.
    pub fn name(self) -> &'static str {
        match self {
            Format::Csv => "CSV",
            Format::Json => "JSON",
            Format::Toml => "TOML",
            Format::Npz => "NPZ",
            Format::Npy => "NPY",
            Format::Png => "PNG",
            Format::Svg => "SVG",
            Format::Vtp => "VTP",
            Format::Pvd => "PVD",
            Format::Checkpoint => "checkpoint",
            Format::Text => "text",
        }
    }
}

/// The declaration of one kind of file a study writes into its output directory.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct OutputFile {
    /// Path relative to the output directory, `/`-separated, with placeholders `<name>` for the
    /// parts that vary (a replay's name, an amplitude's index…): [`pattern_matches`].
    pub pattern: &'static str,
    /// Format of the file.
    pub format: Format,
    /// What the file holds (with units where it has numbers).
    pub description: &'static str,
    /// When the file is written: empty for every run that finishes; otherwise the condition
    /// (`output.plots = true`, "per paired replay", "while a run is in progress"…). A finished run
    /// need not have the files of a conditional declaration.
    pub when: &'static str,
}

impl OutputFile {
    /// A file every finished run writes.
    pub const fn always(pattern: &'static str, format: Format, description: &'static str) -> Self {
        OutputFile { pattern, format, description, when: "" }
    }

    /// A file written only under condition `when`.
    pub const fn when(pattern: &'static str, format: Format, description: &'static str, when: &'static str) -> Self {
        OutputFile { pattern, format, description, when }
    }

    /// True when every finished run writes it (no condition).
    pub fn is_always(&self) -> bool {
        self.when.is_empty()
    }

    /// True when `path` (relative to the output directory, `/`-separated) is a file of this
    /// declaration.
    pub fn matches(&self, path: &str) -> bool {
        pattern_matches(self.pattern, path)
    }
}

/// `config.resolved.toml` ([`write_resolved_config`]), written by every study.
pub const RESOLVED_CONFIG: OutputFile =
    OutputFile::always(RESOLVED_CONFIG_FILE, Format::Toml, "the config with every default filled in; running it again gives the same results");
/// `summary.json` ([`write_summary`]), written by every study at the end of a run.
pub const SUMMARY: OutputFile = OutputFile::always(SUMMARY_FILE, Format::Json, "the report: every scalar result, with units, the version and the files written");
// The names of the files below are the protocol module's (`protocol::CHECKPOINT_FILE` … are
// these patterns), so that the two modules do not import each other.

/// `checkpoint.gwck`: the resumable state of the run (`grainwave resume`, `inspect`, `plot`).
pub const CHECKPOINT: OutputFile = OutputFile::always("checkpoint.gwck", Format::Checkpoint, "the complete state of the run (resume, inspect or re-plot it)");
/// `run.log`: the log of the run (appended to by every resume).
pub const LOG: OutputFile = OutputFile::always("run.log", Format::Text, "log of the run, appended to by each resume");
/// `.grainwave.lock`: the directory's advisory lock, held by the process that runs in it and
/// left in place afterwards (its text names the last holder's process id).
pub const LOCK: OutputFile =
    OutputFile::always(".grainwave.lock", Format::Text, "the directory's advisory lock, held by the process that runs in it (its text: the last holder's process id)");
/// `run.failed`: the failure marker with the diagnosis of a failed run.
pub const FAILED: OutputFile = OutputFile::when("run.failed", Format::Text, "the diagnosis of a failed run (`grainwave resume --retry` tries again)", "after a failure");
/// The files every study's run directory has (the kernel writes them the same way for all).
pub const COMMON: [OutputFile; 6] = [RESOLVED_CONFIG, SUMMARY, CHECKPOINT, LOG, LOCK, FAILED];

/// Whether relative path `path` is matched by `pattern`.
///
/// A pattern is literal text, `/`-separated like the path, except placeholders `<name>`: each
/// matches one or more characters other than `/` (so it never spans two directory levels).
/// `replays/<name>/a<k>_arrivals.csv` matches `replays/pulse/a0_arrivals.csv` and
/// `replays/r1/a12_arrivals.csv`, but not `replays/a0_arrivals.csv` (no `<name>` level),
/// `replays/x/y/a0_arrivals.csv` (two levels) nor `replays/pulse/a_arrivals.csv` (empty `<k>`).
/// A `<` without a closing `>` is literal text. The comparison is exact (case-sensitive).
pub fn pattern_matches(pattern: &str, path: &str) -> bool {
    let Some((open, close)) = pattern.find('<').and_then(|i| pattern[i..].find('>').map(|j| (i, i + j))) else {
        return pattern == path;
    };
    let Some(rest) = path.strip_prefix(&pattern[..open]) else { return false };
    let tail = &pattern[close + 1..];
    // the placeholder takes 1 to (up to the next `/`) characters: try every split
    let level = rest.find('/').unwrap_or(rest.len());
    rest.char_indices().map(|(k, c)| k + c.len_utf8()).take_while(|&k| k <= level).any(|k| pattern_matches(tail, &rest[k..]))
}

/// Why `pattern` is not a usable declaration pattern (`None`: it is): it must be a non-empty
/// relative path (no leading `/`, no empty, `.` or `..` level), and every `<` must open a
/// placeholder with a non-empty name made of letters, digits and `_`, closed by `>`.
pub fn pattern_problem(pattern: &str) -> Option<String> {
    if pattern.is_empty() {
        return Some("the pattern is empty".into());
    }
    if pattern.split('/').any(|level| level.is_empty() || level == "." || level == "..") {
        return Some(format!("`{pattern}` is not a relative path of named levels (no leading `/`, `//`, `.` or `..`)"));
    }
    let mut rest = pattern;
    while let Some(i) = rest.find(['<', '>']) {
        if rest[i..].starts_with('>') {
            return Some(format!("`{pattern}` has a `>` that closes no placeholder"));
        }
        let Some(j) = rest[i..].find('>') else { return Some(format!("`{pattern}` has a `<` without its `>`")) };
        let name = &rest[i + 1..i + j];
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Some(format!("`{pattern}` has a placeholder `<{name}>` whose name is not letters, digits and `_`"));
        }
        rest = &rest[i + j + 1..];
    }
    None
}

/// The first declaration of `outputs` that matches `path` (relative, `/`-separated).
pub fn declaration_of<'a>(outputs: &'a [OutputFile], path: &str) -> Option<&'a OutputFile> {
    outputs.iter().find(|o| o.matches(path))
}

/// Every file under `dir`, as paths relative to it with `/` separators, sorted (directories are
/// walked, not listed; symbolic links are listed, not followed).
pub fn files_under(dir: &Path) -> std::io::Result<Vec<String>> {
    fn walk(dir: &Path, prefix: &str, out: &mut Vec<String>) -> std::io::Result<()> {
        for e in std::fs::read_dir(dir)? {
            let e = e?;
            let name = e.file_name().to_string_lossy().into_owned();
            let rel = if prefix.is_empty() { name } else { format!("{prefix}/{name}") };
            if e.file_type()?.is_dir() {
                walk(&e.path(), &rel, out)?;
            } else {
                out.push(rel);
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(dir, "", &mut out)?;
    out.sort();
    Ok(out)
}

/// What a declaration check of a run directory found ([`check_directory`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DirectoryCheck {
    /// Files that match no declaration.
    pub undeclared: Vec<String>,
    /// Patterns of the unconditional declarations that no file matches.
    pub missing: Vec<&'static str>,
}

/// Compares the files under `dir` with the declarations `outputs`: the files no declaration
/// matches, and the declarations without a condition that no file matches (the common files
/// of a run that has not failed included; [`FAILED`] and the other conditional ones excluded).
pub fn check_directory(dir: &Path, outputs: &[OutputFile]) -> std::io::Result<DirectoryCheck> {
    let files = files_under(dir)?;
    Ok(DirectoryCheck {
        undeclared: files.iter().filter(|f| declaration_of(outputs, f).is_none()).cloned().collect(),
        missing: outputs.iter().filter(|o| o.is_always() && !files.iter().any(|f| o.matches(f))).map(|o| o.pattern).collect(),
    })
}

/// The Markdown table of `outputs` (columns: file, format, when, what it holds). A `|` in a
/// cell is escaped; so are `<` and `>` outside code spans (a placeholder such as `load_<wall>` in
/// a description would otherwise be read as an HTML tag and vanish).
pub fn markdown(outputs: &[OutputFile]) -> String {
    let cell = |s: &str| {
        let s = s.replace('|', "\\|");
        // the pieces between backticks at odd positions are code spans
        s.split('`').enumerate().map(|(k, piece)| if k % 2 == 0 { piece.replace('<', "&lt;").replace('>', "&gt;") } else { piece.to_string() }).collect::<Vec<_>>().join("`")
    };
    let mut s = String::from("| File | Format | Written | Contents |\n|---|---|---|---|\n");
    for o in outputs {
        let when = if o.is_always() { "always" } else { o.when };
        s.push_str(&format!("| `{}` | {} | {} | {} |\n", o.pattern.replace('|', "\\|"), o.format.name(), cell(when), cell(o.description)));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_match_one_level_of_one_or_more_characters() {
        let p = "replays/<name>/a<k>_arrivals.csv";
        for path in ["replays/pulse/a0_arrivals.csv", "replays/r1/a12_arrivals.csv", "replays/a_b.c/a3_arrivals.csv"] {
            assert!(pattern_matches(p, path), "{path}");
        }
        for path in [
            "replays/a0_arrivals.csv",        // no <name> level
            "replays/x/y/a0_arrivals.csv",    // <name> would span two levels
            "replays/pulse/a_arrivals.csv",   // empty <k>
            "replays/pulse/a0_arrivals.csvx", // trailing text
            "replays/pulse/a0_arrivals.cs",
            "Replays/pulse/a0_arrivals.csv", // case-sensitive
            "replays/pulse/a0_sliding.csv",
        ] {
            assert!(!pattern_matches(p, path), "{path} must not match");
        }
        // literal patterns match themselves only
        assert!(pattern_matches("summary.json", "summary.json"));
        assert!(!pattern_matches("summary.json", "run/summary.json"));
        assert!(!pattern_matches("summary.json", "summary.json.tmp"));
        // a placeholder at the end takes the rest of its level, not more
        assert!(pattern_matches("plots/<stem>", "plots/energy.png"));
        assert!(!pattern_matches("plots/<stem>", "plots/a/energy.png"));
        // backtracking: the placeholder's text may contain what follows it in the pattern
        assert!(pattern_matches("<a>_x.csv", "b_x_x.csv"));
        assert!(pattern_matches("checkpoints/ck-<k>.gwck", "checkpoints/ck-000012.gwck"));
        assert!(!pattern_matches("checkpoints/ck-<k>.gwck", "checkpoints/ck-.gwck"));
        // multi-byte characters are compared whole
        assert!(pattern_matches("<σ>.csv", "σ_zz.csv"));
    }

    #[test]
    fn malformed_patterns_are_named() {
        assert_eq!(pattern_problem("replays/<name>/a<k>_arrivals.csv"), None);
        assert_eq!(pattern_problem("summary.json"), None);
        for (bad, why) in [
            ("", "empty"),
            ("/abs.csv", "relative"),
            ("a//b.csv", "relative"),
            ("../up.csv", "relative"),
            ("a/<name.csv", "without its `>`"),
            ("a/name>.csv", "closes no placeholder"),
            ("a/<>.csv", "`<>`"),
            ("a/<a b>.csv", "`<a b>`"),
        ] {
            let p = pattern_problem(bad).unwrap_or_else(|| panic!("{bad:?} accepted"));
            assert!(p.contains(why), "{bad:?}: {p}");
        }
        // an unclosed `<` is literal for the matcher
        assert!(pattern_matches("a<b", "a<b") && !pattern_matches("a<b", "axb"));
    }

    #[test]
    fn a_directory_is_checked_against_its_declarations() {
        let dir = std::env::temp_dir().join(format!("grainwave-study-outputs-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        for f in ["summary.json", "config.resolved.toml", "checkpoint.gwck", "run.log", ".grainwave.lock", "replays/p/a0_times.npy", "replays/p/stray.txt"] {
            let p = dir.join(f);
            std::fs::create_dir_all(p.parent().unwrap()).unwrap();
            std::fs::write(&p, b"").unwrap();
        }
        let outputs = [
            COMMON[0],
            COMMON[1],
            COMMON[2],
            COMMON[3],
            COMMON[4],
            COMMON[5],
            OutputFile::always("replays/<name>/a<k>_times.npy", Format::Npy, "sample times"),
            OutputFile::always("loading.csv", Format::Csv, "the loading"),
            OutputFile::when("plots/<stem>.png", Format::Png, "plots", "output.plots = true"),
        ];
        let c = check_directory(&dir, &outputs).unwrap();
        assert_eq!(c.undeclared, ["replays/p/stray.txt"]);
        // run.failed and the plots are conditional: not missing
        assert_eq!(c.missing, ["loading.csv"]);
        assert_eq!(declaration_of(&outputs, "replays/p/a0_times.npy").map(|o| o.description), Some("sample times"));
        assert_eq!(files_under(&dir).unwrap().len(), 7);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn the_markdown_table_has_a_row_per_declaration() {
        let t = markdown(&[RESOLVED_CONFIG, FAILED, OutputFile::when("a|b.csv", Format::Csv, "x | y", "per replay"), OutputFile::always("s/<k>.csv", Format::Csv, "load_<wall> and `<k>`")]);
        let rows: Vec<&str> = t.lines().collect();
        assert_eq!(rows.len(), 6, "{t}");
        assert_eq!(rows[0], "| File | Format | Written | Contents |");
        assert!(rows[2].starts_with("| `config.resolved.toml` | TOML | always |"), "{t}");
        assert!(rows[3].contains("| after a failure |"), "{t}");
        // a `|` in a cell is escaped so that the row keeps four cells
        assert!(rows[4].ends_with("| per replay | x \\| y |"), "{t}");
        // placeholders: literal in the code span of the pattern and of a description, escaped
        // outside it
        assert_eq!(rows[5], "| `s/<k>.csv` | CSV | always | load_&lt;wall&gt; and `<k>` |");
    }

    #[test]
    fn the_common_declarations_are_well_formed() {
        for o in COMMON {
            assert_eq!(pattern_problem(o.pattern), None);
            assert!(o.matches(o.pattern), "{}", o.pattern);
        }
    }

    #[derive(Serialize, serde::Deserialize, PartialEq, Debug)]
    struct Example {
        seed: u64,
        friction: f64,
        label: String,
    }

    #[test]
    fn the_resolved_config_reads_back_as_the_config_under_its_header() {
        let c = Example { seed: 7, friction: 0.5, label: "a".into() };
        let text = resolved_config_text("e3", &c, "Keys left out are computed per parameter set.\nSee docs/e3.md.");
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].starts_with("# The config of this e3 run") && lines[0].contains(grainwave_core::VERSION), "{text}");
        assert_eq!(lines[1], "# Keys left out are computed per parameter set.");
        assert_eq!(lines[2], "# See docs/e3.md.");
        assert_eq!(lines[3], "# Running it again gives the same results, bit for bit.");
        let back: Example = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
        // no note: the header is two lines
        let plain = resolved_config_text("simulation", &c, "");
        assert_eq!(plain.lines().filter(|l| l.starts_with('#')).count(), 2, "{plain}");
    }
}
