//! Replay and mutation tests of the three loaders that read untrusted bytes: the config loader
//! (TOML → validated plan, for every protocol), the checkpoint decoder and the LAMMPS data
//! reader. The seed corpus is every example config, every adversarial fixture, a checkpoint of
//! each protocol made here, and the LAMMPS fixtures. Each seed is replayed as it is, then
//! mutated deterministically (ChaCha8, fixed seeds: byte flips, cuts, repeated lines, extreme
//! numbers in place of values, arrays and tables in place of values). Property: no input makes a
//! loader panic — each either loads or returns an error with a message. That the configs
//! `check` accepts also run without a panic is the property test of `tests/run_property.rs`.
//!
//! `GRAINWAVE_FUZZ_CASES` sets the mutations per seed (default 40: the whole file runs in
//! seconds; a long session uses 10⁴ or more).

use grainwave_experiments::config::ConfigSource;
use grainwave_experiments::registry;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cases() -> usize {
    std::env::var("GRAINWAVE_FUZZ_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(40)
}

fn files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.filter_map(|e| e.ok()).map(|e| e.path()).filter(|p| p.extension().is_some_and(|x| x == ext)).collect())
        .unwrap_or_default();
    v.sort();
    v
}

fn config_corpus() -> Vec<(String, String)> {
    let r = root();
    let mut paths = files(&r.join("examples"), "toml");
    paths.extend(files(&r.join("examples/papers"), "toml"));
    paths.extend(files(&r.join("crates/grainwave-cli/tests/adversarial"), "toml"));
    paths.extend(files(&r.join("crates/grainwave-experiments/tests/fuzz-regressions/config"), "toml"));
    paths.push(r.join("crates/grainwave-cli/tests/interrupt.toml"));
    paths.into_iter().map(|p| (p.display().to_string(), std::fs::read_to_string(&p).unwrap())).collect()
}

/// Values put in place of a value: extremes of every type, empty and wrong shapes.
const REPLACEMENTS: &[&str] = &[
    "0", "-1", "1e308", "-1e308", "5e-324", "nan", "inf", "-inf", "4294967296", "18446744073709551615", "-0.0", "1e-12", "1e30",
    "\"\"", "\"x\"", "[]", "[[]]", "{}", "true", "[1e308, -1e308]", "[0.0, 0.0]", "[nan, 1]",
];

/// One random mutation of a text config.
fn mutate_text(text: &str, rng: &mut ChaCha8Rng) -> String {
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    if lines.is_empty() {
        return text.to_string();
    }
    let k = rng.random_range(0..lines.len());
    match rng.random_range(0..6u32) {
        // a value replaced by an extreme or a wrong shape
        0 | 1 | 2 => {
            if let Some(eq) = lines[k].find('=') {
                let key = lines[k][..eq].to_string();
                let r = REPLACEMENTS[rng.random_range(0..REPLACEMENTS.len())];
                lines[k] = format!("{key}= {r}");
            }
        }
        // a line repeated
        3 => {
            let l = lines[k].clone();
            lines.insert(k, l);
        }
        // a line removed
        4 => {
            lines.remove(k);
        }
        // a byte flipped
        _ => {
            let mut b = lines[k].clone().into_bytes();
            if !b.is_empty() {
                let i = rng.random_range(0..b.len());
                b[i] = rng.random_range(0x20..0x7fu8);
            }
            lines[k] = String::from_utf8_lossy(&b).into_owned();
        }
    }
    lines.join("\n")
}

/// `registry::check` must return (valid or an error naming the problem), never panic.
fn check_no_panic(name: &str, text: &str) -> bool {
    let src = ConfigSource::from_text(name, text);
    match catch_unwind(AssertUnwindSafe(|| registry::check(&src))) {
        Ok(Ok(_)) => true,
        Ok(Err(e)) => {
            assert!(!e.message.is_empty(), "{name}: an error without a message");
            assert!(e.message.len() < 2000, "{name}: {} bytes of message", e.message.len());
            false
        }
        Err(_) => panic!("check panicked on a mutation of {name}:\n{text}"),
    }
}

#[test]
fn config_loader_never_panics() {
    let corpus = config_corpus();
    assert!(corpus.len() >= 20, "corpus of {} configs", corpus.len());
    let (mut accepted, mut total) = (0usize, 0usize);
    for (i, (name, text)) in corpus.iter().enumerate() {
        check_no_panic(name, text);
        let mut rng = ChaCha8Rng::seed_from_u64(1000 + i as u64);
        for _ in 0..cases() {
            let m = mutate_text(text, &mut rng);
            total += 1;
            if check_no_panic(name, &m) {
                accepted += 1;
            }
        }
    }
    eprintln!("config loader: {total} mutated configs, {accepted} accepted, no panic");
    assert!(accepted > 0 && accepted < total, "the mutations exercise both outcomes");
}

/// A checkpoint of each protocol, made from example configs without running them.
fn checkpoint_corpus() -> Vec<(String, Vec<u8>)> {
    use grainwave_core::checkpoint::encode;
    let r = root();
    let read = |p: &str| ConfigSource::from_text(p, std::fs::read_to_string(r.join(p)).unwrap());
    let mut v = Vec::new();
    let sim = grainwave_experiments::simulation::prepare(&read("crates/grainwave-cli/tests/adversarial/quick.toml")).unwrap();
    let state = grainwave_experiments::simulation::SimulationState::new(sim);
    v.push(("simulation".to_string(), encode(grainwave_experiments::simulation::TAG, &state).unwrap()));
    let plan = grainwave_experiments::e1::prepare(&read("examples/e1-pulse-2d.toml")).unwrap();
    v.push(("e1".to_string(), encode(grainwave_experiments::e1::TAG, &grainwave_experiments::e1::E1State::new(&plan)).unwrap()));
    v
}

fn refresh_crc(bytes: &mut [u8]) {
    if bytes.len() < 16 {
        return;
    }
    let tag_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    let head = 16 + tag_len + 12;
    if bytes.len() < head {
        return;
    }
    let mut h = crc32fast::Hasher::new();
    h.update(&bytes[16..16 + tag_len]);
    h.update(&bytes[head..]);
    let crc = h.finalize().to_le_bytes();
    bytes[24 + tag_len..28 + tag_len].copy_from_slice(&crc);
}

fn decode_all(bytes: &[u8]) {
    use grainwave_core::checkpoint::decode;
    let _ = decode::<grainwave_experiments::simulation::SimulationState>(bytes, grainwave_experiments::simulation::TAG, "c");
    let _ = decode::<grainwave_experiments::e1::E1State>(bytes, grainwave_experiments::e1::TAG, "c");
    let _ = decode::<grainwave_experiments::e2::E2State>(bytes, grainwave_experiments::e2::TAG, "c");
    let _ = decode::<grainwave_experiments::e3::E3State>(bytes, grainwave_experiments::e3::TAG, "c");
}

#[test]
fn checkpoint_decoder_never_panics() {
    let corpus = checkpoint_corpus();
    let mut total = 0;
    for (i, (name, bytes)) in corpus.iter().enumerate() {
        decode_all(bytes);
        let mut rng = ChaCha8Rng::seed_from_u64(2000 + i as u64);
        for _ in 0..cases() * 10 {
            let mut b = bytes.clone();
            match rng.random_range(0..4u32) {
                0 => b.truncate(rng.random_range(0..b.len())),
                1 => b.extend((0..rng.random_range(1..64)).map(|_| rng.random::<u8>())),
                _ => {
                    for _ in 0..rng.random_range(1..8) {
                        let k = rng.random_range(0..b.len());
                        b[k] = rng.random();
                    }
                }
            }
            // half the cases get a valid checksum, so that the payload decoder itself is reached
            if rng.random::<bool>() {
                refresh_crc(&mut b);
            }
            total += 1;
            if catch_unwind(AssertUnwindSafe(|| decode_all(&b))).is_err() {
                panic!("the checkpoint decoder panicked on a mutation of the {name} checkpoint ({} bytes)", b.len());
            }
        }
    }
    eprintln!("checkpoint decoder: {total} mutated checkpoints, no panic");
}

#[test]
fn lammps_reader_never_panics() {
    use grainwave_io::lammps::{parse_data, ImportOptions};
    let r = root();
    let mut corpus: Vec<String> = files(&r.join("crates/grainwave-io/tests/fixtures/lammps"), "data").iter().map(|p| std::fs::read_to_string(p).unwrap()).collect();
    corpus.push("LAMMPS data file\n\n2 atoms\n1 atom types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n0.5 0 0 xy xz yz\n\nAtoms # sphere\n\n7 1 1.0 1.0 1.0 2.0 2.0 0 0 0\n3 1 1.0 1.0 1.9 2.0 2.0 0 0 0\n\nVelocities\n\n7 0.5 0 0 0 0 1\n3 0 0 0 0 0 0\n".into());
    let mut total = 0;
    for (i, text) in corpus.iter().enumerate() {
        let mut rng = ChaCha8Rng::seed_from_u64(3000 + i as u64);
        for _ in 0..cases() * 5 {
            let m = mutate_text(text, &mut rng);
            total += 1;
            let r = catch_unwind(AssertUnwindSafe(|| {
                if let Ok(d) = parse_data(&m, "t.data") {
                    let _ = d.to_packing_3d(&ImportOptions::default());
                    let _ = d.to_packing_2d(&ImportOptions::default());
                }
            }));
            assert!(r.is_ok(), "the LAMMPS reader panicked on:\n{}", &m[..m.len().min(3000)]);
        }
    }
    eprintln!("LAMMPS reader: {total} mutated files, no panic");
}
