//! Checkpoints: the complete state of a run, versioned, checksummed, written atomically.
//!
//! File layout (little endian): magic `GRNWCKPT` (8 bytes) | format version u32 | content tag
//! length u32 | content tag (UTF-8) | payload length u64 | CRC-32 of tag + payload u32 | payload
//! (bincode). A truncated or corrupted file, a wrong version or a wrong content tag is refused
//! with a message saying which.

use crate::dim::{Dim, D2, D3};
use crate::error::{CoreError, Result};
use crate::sim::Simulation;
use serde::{de::DeserializeOwned, Serialize};
use std::io::Write;
use std::path::Path;

/// Magic bytes at the start of every checkpoint.
pub const MAGIC: &[u8; 8] = b"GRNWCKPT";
/// Version of the file layout and of the serialized state. Version 3 added the laws' own
/// per-contact history ([`crate::contact::HistoryColumn`]) after each pair list's histories;
/// version 4 that of the grain–wall contacts ([`crate::contact::WallHistory`]) after the
/// neighbor list's other fields.
pub const FORMAT_VERSION: u32 = 4;
/// The oldest version read: version 2 files are read with every history column absent (their
/// laws had none), version 3 files without the grain–wall columns (their wall laws could keep
/// no history); both resume bit for bit.
pub const OLDEST_READ_VERSION: u32 = 2;

/// Writes `bytes` to `path` atomically: a temporary file in the same directory, flushed and
/// synced, then renamed over `path`. Readers see either the old file or the complete new one.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<()> {
    let io = |action: &str, p: &Path, e| CoreError::Io { action: action.into(), path: p.display().to_string(), error: e };
    let dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir).map_err(|e| io("cannot create directory", dir, e))?;
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "out".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = (|| {
        let mut f = std::fs::File::create(&tmp).map_err(|e| io("cannot create", &tmp, e))?;
        f.write_all(bytes).map_err(|e| io("cannot write", &tmp, e))?;
        f.sync_all().map_err(|e| io("cannot sync", &tmp, e))?;
        std::fs::rename(&tmp, path).map_err(|e| io("cannot rename into", path, e))
    })();
    if written.is_err() {
        // never leave the temporary file behind
        let _ = std::fs::remove_file(&tmp);
    }
    written
}

/// Removes the temporary files that [`atomic_write`] leaves behind when its process is killed
/// (SIGKILL, power loss) between creating and renaming them: files named `.NAME.PID.tmp` in
/// `dir` and its subdirectories whose process `PID` is not running (on systems without `/proc`,
/// every such file not belonging to this process). Called before a run is resumed, so that a
/// resumed directory holds only complete files. Returns the paths removed.
pub fn remove_stale_temporaries(dir: &Path) -> Vec<std::path::PathBuf> {
    let me = std::process::id();
    let alive = |pid: u32| pid == me || (Path::new("/proc/self").exists() && Path::new("/proc").join(pid.to_string()).exists());
    let mut removed = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if e.file_type().map(|t| t.is_dir()).unwrap_or(false) {
                stack.push(p);
                continue;
            }
            let name = e.file_name().to_string_lossy().into_owned();
            let pid = name
                .strip_prefix('.')
                .and_then(|n| n.strip_suffix(".tmp"))
                .and_then(|n| n.rsplit_once('.'))
                .and_then(|(_, pid)| pid.parse::<u32>().ok());
            if let Some(pid) = pid {
                if !alive(pid) && std::fs::remove_file(&p).is_ok() {
                    removed.push(p);
                }
            }
        }
    }
    removed.sort();
    removed
}

/// Serializes `payload` under content tag `tag` into checkpoint bytes.
pub fn encode<T: Serialize>(tag: &str, payload: &T) -> Result<Vec<u8>> {
    let body = bincode::serialize(payload).map_err(|e| CoreError::Inconsistent(format!("cannot serialize checkpoint: {e}")))?;
    let mut crc = crc32fast::Hasher::new();
    crc.update(tag.as_bytes());
    crc.update(&body);
    let mut out = Vec::with_capacity(body.len() + 64);
    out.extend_from_slice(MAGIC);
    out.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    out.extend_from_slice(&(tag.len() as u32).to_le_bytes());
    out.extend_from_slice(tag.as_bytes());
    out.extend_from_slice(&(body.len() as u64).to_le_bytes());
    out.extend_from_slice(&crc.finalize().to_le_bytes());
    out.extend_from_slice(&body);
    Ok(out)
}

/// Reads the content tag of checkpoint bytes after verifying magic, version, length and checksum.
pub fn verify<'a>(bytes: &'a [u8], path: &str) -> Result<(String, &'a [u8])> {
    let bad = |reason: String| CoreError::Checkpoint { path: path.into(), reason };
    if bytes.len() < 16 || &bytes[..8] != MAGIC {
        return Err(bad("not a grainwave checkpoint (bad magic bytes)".into()));
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    if !(OLDEST_READ_VERSION..=FORMAT_VERSION).contains(&version) {
        return Err(bad(format!("format version {version}, but this grainwave reads versions {OLDEST_READ_VERSION} to {FORMAT_VERSION}")));
    }
    let tag_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    if tag_len > 256 {
        // content tags are short names; a long one is a corrupted header (and is not echoed)
        return Err(bad(format!("corrupted header (content tag of {tag_len} bytes)")));
    }
    let head = 16 + tag_len + 12;
    if bytes.len() < head {
        return Err(bad("truncated header".into()));
    }
    let tag = std::str::from_utf8(&bytes[16..16 + tag_len]).map_err(|_| bad("corrupted header (content tag)".into()))?;
    let len = u64::from_le_bytes(bytes[16 + tag_len..24 + tag_len].try_into().unwrap()) as usize;
    let crc = u32::from_le_bytes(bytes[24 + tag_len..28 + tag_len].try_into().unwrap());
    let body = &bytes[head..];
    if body.len() < len {
        return Err(bad(format!("truncated: payload has {} bytes, header says {len} ({} bytes missing)", body.len(), len - body.len())));
    }
    if body.len() > len {
        return Err(bad(format!(
            "{} unexpected bytes after the end of the checkpoint (payload of {len} bytes, as its header says): the file was appended to or corrupted",
            body.len() - len
        )));
    }
    let mut h = crc32fast::Hasher::new();
    h.update(tag.as_bytes());
    h.update(body);
    if h.finalize() != crc {
        return Err(bad("checksum mismatch: the file is corrupted".into()));
    }
    Ok((tag.to_string(), body))
}

/// Decodes checkpoint bytes whose content tag must be `tag`.
///
/// A [`Simulation`] anywhere in the payload (a simulation checkpoint, a study state holding one)
/// is checked for every invariant the engine relies on as it is decoded (`sim::validate`): a
/// crafted payload with a recomputed checksum is refused with "inconsistent: …" naming what is
/// wrong, never handed to the force passes.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], tag: &str, path: &str) -> Result<T> {
    let (found, body) = verify(bytes, path)?;
    if found != tag {
        return Err(CoreError::Checkpoint { path: path.into(), reason: format!("holds `{found}`, expected `{tag}`") });
    }
    // bincode's own defaults (fixed-width integers, trailing bytes allowed) with a size limit:
    // no length field inside the payload can make the decoder allocate more than the payload's
    // own size, whatever the bytes
    use bincode::Options;
    // (version and length verified above)
    let version = u32::from_le_bytes(bytes[8..12].try_into().unwrap());
    crate::contact::decoding_version(version, || {
        bincode::DefaultOptions::new().with_fixint_encoding().allow_trailing_bytes().with_limit(body.len() as u64).deserialize(body)
    })
    .map_err(|e| {
        // a decoded simulation that fails its consistency checks (`sim::validate`) says so
        // in its own words: "inconsistent: …"
        let reason = match &*e {
            bincode::ErrorKind::Custom(m) if m.starts_with(crate::sim::INCONSISTENT) => m.clone(),
            _ => format!("cannot decode state: {e}"),
        };
        CoreError::Checkpoint { path: path.into(), reason }
    })
}

/// Writes any serializable state atomically as a checkpoint with content tag `tag`.
pub fn save<T: Serialize>(path: &Path, tag: &str, payload: &T) -> Result<()> {
    atomic_write(path, &encode(tag, payload)?)
}

/// Reads the bytes of a checkpoint file. Only a regular file is read, so its size bounds the
/// allocation: a device or a pipe (`/dev/zero`, a FIFO) would otherwise be read until memory runs
/// out.
pub fn read_bytes(path: &Path) -> Result<Vec<u8>> {
    let io = |e| CoreError::Io { action: "cannot read".into(), path: path.display().to_string(), error: e };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file (a device, a pipe or a socket)" };
        return Err(CoreError::Checkpoint { path: path.display().to_string(), reason: format!("{what}: a checkpoint is a file written by grainwave") });
    }
    let mut bytes = Vec::new();
    // the size it had when opened (+1 to notice growth), never more
    std::io::Read::read_to_end(&mut std::io::Read::take(std::fs::File::open(path).map_err(io)?, meta.len().saturating_add(1)), &mut bytes).map_err(io)?;
    Ok(bytes)
}

/// Reads a checkpoint with content tag `tag`.
pub fn load<T: DeserializeOwned>(path: &Path, tag: &str) -> Result<T> {
    let bytes = read_bytes(path)?;
    decode(&bytes, tag, &path.display().to_string())
}

/// Content tag of a simulation checkpoint in dimension `D`.
pub fn simulation_tag<D: Dim>() -> String {
    format!("simulation-{}", D::NAME)
}

/// Recomputes the CRC-32 of tag + payload where [`encode`] writes it
/// (header: 8-byte magic, u32 version, u32 tag length, tag, u64 payload length, u32 CRC);
/// false when the header is too short to hold one. For tests and fuzz targets that craft
/// checkpoints: a mutated file with its checksum refreshed reaches the decoder and its checks
/// (the checksum guards against accidents, not against a crafted file).
pub fn refresh_crc(bytes: &mut [u8]) -> bool {
    if bytes.len() < 16 {
        return false;
    }
    let tag_len = u32::from_le_bytes([bytes[12], bytes[13], bytes[14], bytes[15]]) as usize;
    let head = 16usize.saturating_add(tag_len).saturating_add(12);
    if tag_len > 256 || bytes.len() < head {
        return false;
    }
    let mut h = crc32fast::Hasher::new();
    h.update(&bytes[16..16 + tag_len]);
    h.update(&bytes[head..]);
    let crc = h.finalize().to_le_bytes();
    bytes[24 + tag_len..28 + tag_len].copy_from_slice(&crc);
    true
}

/// A simulation of either dimension, as read from a checkpoint or built from a config. Its
/// serialized form (a study state holds one) is the variant index followed by the simulation.
#[derive(Clone, Debug, Serialize, serde::Deserialize)]
pub enum AnySimulation {
    /// Two dimensions.
    D2(Simulation<D2>),
    /// Three dimensions.
    D3(Simulation<D3>),
}

impl<D: Dim> Simulation<D> {
    /// Saves the complete state (atomically).
    pub fn save_checkpoint(&self, path: &Path) -> Result<()> {
        save(path, &simulation_tag::<D>(), self)
    }

    /// Loads a simulation of dimension `D`.
    pub fn load_checkpoint(path: &Path) -> Result<Self> {
        load(path, &simulation_tag::<D>())
    }
}

/// Loads a simulation checkpoint of either dimension.
pub fn load_simulation(path: &Path) -> Result<AnySimulation> {
    let bytes = read_bytes(path)?;
    let p = path.display().to_string();
    let (tag, _) = verify(&bytes, &p)?;
    if tag == simulation_tag::<D2>() {
        Ok(AnySimulation::D2(decode(&bytes, &tag, &p)?))
    } else if tag == simulation_tag::<D3>() {
        Ok(AnySimulation::D3(decode(&bytes, &tag, &p)?))
    } else {
        let reason = format!("holds `{tag}`, not a simulation");
        Err(CoreError::Checkpoint { path: p, reason })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_temporaries_of_dead_processes_are_removed_and_nothing_else() {
        let dir = std::env::temp_dir().join(format!("grainwave-stale-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        // a pid far above any pid_max in use is not running
        let dead = dir.join("sub/.checkpoint.gwck.4000000000.tmp");
        let own = dir.join(format!(".series.csv.{}.tmp", std::process::id()));
        let keep = [dir.join("checkpoint.gwck"), dir.join("notes.tmp"), dir.join(".x.abc.tmp"), own.clone()];
        for p in keep.iter().chain([&dead]) {
            std::fs::write(p, b"x").unwrap();
        }
        assert_eq!(remove_stale_temporaries(&dir), vec![dead.clone()]);
        assert!(!dead.exists());
        assert!(keep.iter().all(|p| p.exists()), "only stale temporaries are removed");
        atomic_write(&dir.join("out.bin"), b"abc").unwrap();
        assert_eq!(std::fs::read(dir.join("out.bin")).unwrap(), b"abc");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn appended_bytes_huge_lengths_and_long_tags_are_refused_by_name() {
        let bytes = encode("state", &vec![1.5f64, 2.5]).unwrap();
        assert_eq!(decode::<Vec<f64>>(&bytes, "state", "c").unwrap(), vec![1.5, 2.5]);
        // before: bytes appended were reported as "truncated"
        let mut longer = bytes.clone();
        longer.extend_from_slice(b"junk");
        let e = decode::<Vec<f64>>(&longer, "state", "c").unwrap_err().to_string();
        assert!(e.contains("4 unexpected bytes after the end of the checkpoint"), "{e}");
        let e = decode::<Vec<f64>>(&bytes[..bytes.len() - 3], "state", "c").unwrap_err().to_string();
        assert!(e.contains("truncated"), "{e}");
        // a payload whose vector length claims 2^60 elements, with a valid checksum: refused by
        // the size limit, nothing allocated for the claim
        let mut body = (1u64 << 60).to_le_bytes().to_vec();
        body.extend_from_slice(&1.0f64.to_le_bytes());
        let mut crc = crc32fast::Hasher::new();
        crc.update(b"state");
        crc.update(&body);
        let mut forged = MAGIC.to_vec();
        forged.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
        forged.extend_from_slice(&5u32.to_le_bytes());
        forged.extend_from_slice(b"state");
        forged.extend_from_slice(&(body.len() as u64).to_le_bytes());
        forged.extend_from_slice(&crc.finalize().to_le_bytes());
        forged.extend_from_slice(&body);
        let e = decode::<Vec<f64>>(&forged, "state", "c").unwrap_err().to_string();
        assert!(e.contains("cannot decode state"), "{e}");
        // a content tag length of 3 GB is not echoed
        let mut long_tag = bytes.clone();
        long_tag[12..16].copy_from_slice(&3_000_000_000u32.to_le_bytes());
        let e = decode::<Vec<f64>>(&long_tag, "state", "c").unwrap_err().to_string();
        assert!(e.contains("content tag of 3000000000 bytes"), "{e}");
    }

    /// Checkpoints of format versions 2 (before the laws' own history columns) and 3 (before
    /// the grain–wall columns) load and resume to the bits of the run they were taken from;
    /// versions 1 and 5 are refused by name. (The old bytes are written by this encoder with
    /// the columns of the later versions left out, which is those layouts: a pair list then
    /// ends with its twist springs, a neighbor list with its build counters.)
    #[test]
    fn version_2_and_3_checkpoints_still_load() {
        use crate::contact::{ContactParams, Partner};
        use crate::dim::D2;
        use crate::domain::Domain;
        use crate::grains::{GrainKind, Grains};
        use crate::sim::SimulationBuilder;
        use glam::DVec2;
        let mut p = ContactParams::preset("hooke_cundall_strack");
        p.normal_stiffness = Some(1e4);
        p.restitution = Some(0.8);
        let law = p.build(Partner::Grain, "contact").unwrap();
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        grains.push(DVec2::new(1.0, 1.0), 0.5, 1.0, DVec2::new(0.5, 0.1));
        grains.push(DVec2::new(2.01, 1.05), 0.5, 1.0, DVec2::new(-0.5, 0.0));
        let domain = Domain::new(DVec2::ZERO, DVec2::new(4.0, 4.0), [true; 3]);
        let mut a = SimulationBuilder::new(grains, domain, law).dt(1e-4).build().unwrap();
        // (in contact from step ≈ 110 for ≈ 220 steps)
        for _ in 0..150 {
            a.step().unwrap();
        }
        assert_eq!(a.counters.contacts, 1);
        let old = |version: u32| {
            let mut bytes = crate::contact::decoding_version(version, || encode("simulation-2d", &a)).unwrap();
            bytes[8..12].copy_from_slice(&version.to_le_bytes());
            bytes
        };
        let (v2, v3, v4) = (old(2), old(3), encode("simulation-2d", &a).unwrap());
        assert!(v2.len() < v3.len() && v3.len() < v4.len());
        let mut b: Simulation<D2> = decode(&v2, "simulation-2d", "v2").unwrap();
        let mut c: Simulation<D2> = decode(&v3, "simulation-2d", "v3").unwrap();
        for _ in 0..200 {
            a.step().unwrap();
            b.step().unwrap();
            c.step().unwrap();
        }
        assert_eq!(a.state_hash(), b.state_hash());
        assert_eq!(a.state_hash(), c.state_hash());
        for version in [1u32, 5] {
            let mut other = v4.clone();
            other[8..12].copy_from_slice(&version.to_le_bytes());
            let e = decode::<Simulation<D2>>(&other, "simulation-2d", "c").unwrap_err().to_string();
            assert!(e.contains(&format!("format version {version}")) && e.contains("versions 2 to 4"), "{e}");
        }
    }
}
