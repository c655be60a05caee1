//! Reading LAMMPS data files (`atom_style sphere`) into grainwave packings.
//!
//! A LAMMPS data file written by `write_data` for `atom_style sphere` holds a header (atom
//! count, box bounds, optionally the tilt factors `xy xz yz` of a triclinic box) and sections:
//!
//! * `Atoms # sphere`: `id type diameter density x y z [ix iy iz]` — `density` is mass per
//!   volume, so LAMMPS sets m = ρ (4/3) π (d/2)³ when it reads the file;
//! * `Velocities`: `id vx vy vz wx wy wz` (angular velocities ω).
//!
//! Other sections are skipped. Gzip-compressed files (`.data.gz`) are recognised by their first
//! bytes and decompressed on the fly.
//!
//! **Masses of disks.** In 2D, LAMMPS keeps the same file format: a disk packing prepared with
//! `set density/disc` (m = ρ_area π r²) is written with the *volume* density that reproduces that
//! mass, ρ = m / ((4/3) π r³), and read back the same way (checked with LAMMPS 2022). The default
//! [`Density2d::Volume`] therefore gives every disk exactly the mass LAMMPS has; choose
//! [`Density2d::Area`] for files whose density column is an areal density (m = ρ π r²). Either
//! way the moment of inertia of a disk is ½ m r², as LAMMPS's `fix nve/sphere disc` uses.
//!
//! The file does not say which axes are periodic (that is the input script's `boundary`
//! command): [`ImportOptions::periodic`] does, all periodic by default. A triclinic box (header
//! line `xy xz yz`) becomes a sheared periodic cell with the same tilt factors
//! ([`Domain::tilt`](grainwave_core::domain::Domain::tilt)).
//!
//! ```
//! use grainwave_io::lammps::{parse_data, ImportOptions};
//!
//! let text = "\
//! LAMMPS data file
//!
//! 2 atoms
//! 1 atom types
//!
//! 0 4 xlo xhi
//! 0 4 ylo yhi
//! 0 4 zlo zhi
//!
//! Atoms # sphere
//!
//! 7 1 1.0 1.0 1.0 2.0 2.0 0 0 0
//! 3 1 1.0 1.0 1.9 2.0 2.0 0 0 0
//!
//! Velocities
//!
//! 7 0.5 0 0 0 0 1
//! 3 0 0 0 0 0 0
//! ";
//! let data = parse_data(text, "example").unwrap();
//! let (grains, domain) = data.to_packing_3d(&ImportOptions::default()).unwrap();
//! assert_eq!(grains.id, vec![7, 3]);
//! assert_eq!(grains.radius[0], 0.5);
//! assert!((grains.mass[0] - std::f64::consts::PI / 6.0).abs() < 1e-15);
//! assert_eq!(grains.vel[0].x, 0.5);
//! assert_eq!(grains.omega[0].z, 1.0);
//! assert_eq!(domain.hi.x, 4.0);
//! ```

use glam::{DVec2, DVec3};
use grainwave_core::dim::{D2, D3};
use grainwave_core::domain::Domain;
use grainwave_core::grains::{GrainKind, Grains};
use std::f64::consts::PI;
use std::io::Read;
use std::path::Path;
use thiserror::Error;

/// Why a LAMMPS data file could not be read.
#[derive(Debug, Error)]
pub enum LammpsDataError {
    /// The file could not be opened, read or decompressed.
    #[error("cannot read LAMMPS data file `{path}`: {error}")]
    Io {
        /// File path.
        path: String,
        /// Underlying error.
        error: std::io::Error,
    },
    /// The contents are not a valid `atom_style sphere` data file.
    #[error("LAMMPS data file `{path}`, line {line}: {message}")]
    Parse {
        /// File path (or the name given to [`parse_data`]).
        path: String,
        /// 1-based line number (0: the file as a whole).
        line: usize,
        /// What is wrong.
        message: String,
    },
    /// The data cannot become a grainwave packing (e.g. a 3D file read as 2D).
    #[error("LAMMPS data file `{path}` cannot be imported: {message}")]
    Import {
        /// File path.
        path: String,
        /// Why.
        message: String,
    },
}

/// Result alias of this module.
pub type Result<T, E = LammpsDataError> = std::result::Result<T, E>;

/// The contents of a LAMMPS `atom_style sphere` data file, in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct LammpsData {
    /// Where it was read from (for messages).
    pub source: String,
    /// First line of the file.
    pub title: String,
    /// Box bounds `[lo, hi]` along x, y, z.
    pub bounds: [[f64; 2]; 3],
    /// Tilt factors `xy`, `xz`, `yz` of a triclinic box (zeros for an orthogonal box).
    pub tilt: [f64; 3],
    /// True when the header had a `xy xz yz` line.
    pub triclinic: bool,
    /// Atom ids (LAMMPS tags).
    pub id: Vec<u32>,
    /// Atom types.
    pub atom_type: Vec<u32>,
    /// Diameters.
    pub diameter: Vec<f64>,
    /// Densities as written in the file.
    pub density: Vec<f64>,
    /// Positions.
    pub pos: Vec<[f64; 3]>,
    /// Image flags (zeros when the file has none).
    pub image: Vec<[i32; 3]>,
    /// Velocities (zeros without a `Velocities` section).
    pub vel: Vec<[f64; 3]>,
    /// Angular velocities (zeros without a `Velocities` section).
    pub omega: Vec<[f64; 3]>,
}

/// How to read the density column of a 2D file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Density2d {
    /// m = ρ (4/3) π r³, as LAMMPS itself reads every `atom_style sphere` file (default).
    #[default]
    Volume,
    /// m = ρ π r²: the column is an areal density.
    Area,
}

/// Options of the conversion into grains and a domain.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImportOptions {
    /// Periodicity of x, y, z (LAMMPS `boundary p p p` by default).
    pub periodic: [bool; 3],
    /// Mass convention of 2D files.
    pub density_2d: Density2d,
}

impl Default for ImportOptions {
    fn default() -> Self {
        ImportOptions { periodic: [true; 3], density_2d: Density2d::Volume }
    }
}

/// Reads a LAMMPS data file, plain or gzip-compressed.
pub fn read_data(path: &Path) -> Result<LammpsData> {
    parse_data(&read_text(path)?, &path.display().to_string())
}

/// Longest line of a data file [bytes]: an atom line of 10 numbers at full precision is under
/// 300 bytes; a longer line means the file is not a data file (and is not read further).
pub const MAX_LINE_BYTES: usize = 4096;

/// Largest decompression ratio of a gzip file accepted (deflate's own maximum is about 1032:1).
pub const MAX_GZIP_RATIO: u64 = 1100;

/// Longest excerpt of the file that an error message quotes [characters].
pub const MAX_ECHO_CHARS: usize = 200;

/// `text` cut to [`MAX_ECHO_CHARS`] characters, with a note of what was left out.
pub fn clip(text: &str) -> String {
    match text.char_indices().nth(MAX_ECHO_CHARS) {
        None => text.to_string(),
        Some((cut, _)) => format!("{}… ({} more bytes)", &text[..cut], text.len() - cut),
    }
}

/// Decompressed text allowed per atom the header announces [bytes]: an `Atoms` line (under 300
/// bytes at full precision) and a `Velocities` line, with room to spare.
pub const MAX_BYTES_PER_ATOM: u64 = 1024;

/// Decompressed text allowed besides the atoms' lines [bytes]: header, comments, blank lines,
/// `Masses` and other short sections.
pub const TEXT_SLACK_BYTES: u64 = 1 << 20;

/// The text of a file, decompressed when it is gzip-compressed (recognised by its first bytes).
///
/// Only a regular file is read (a FIFO would block for ever, a device never end). Memory is
/// bounded: a gzip file's text may be at most [`MAX_GZIP_RATIO`] times the compressed size, and
/// at most [`MAX_BYTES_PER_ATOM`] per atom its header announces plus [`TEXT_SLACK_BYTES`]
/// (checked as the text arrives, once the `atoms` count line has been read, and before it ends);
/// reading stops at the first line longer than [`MAX_LINE_BYTES`].
pub fn read_text(path: &Path) -> Result<String> {
    let io = |error| LammpsDataError::Io { path: path.display().to_string(), error };
    let meta = std::fs::metadata(path).map_err(io)?;
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file (a FIFO, a device or a socket)" };
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            format!("{what}; allowed: a LAMMPS data file, plain or gzip-compressed"),
        )));
    }
    let mut file = std::fs::File::open(path).map_err(io)?;
    let mut magic = [0u8; 2];
    let got = file.read(&mut magic).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    let head = std::io::Cursor::new(magic[..got].to_vec());
    let gz = got == 2 && magic == [0x1f, 0x8b];
    if gz {
        let reader = flate2::read::MultiGzDecoder::new(head.chain(file)).take(len.saturating_mul(MAX_GZIP_RATIO));
        read_checked(reader, &path.display().to_string(), true)
    } else {
        // a regular file: its size bounds the text
        read_checked(head.chain(file), &path.display().to_string(), false)
    }
}

/// Reads `reader` to its end as UTF-8, refusing a line longer than [`MAX_LINE_BYTES`] as soon
/// as it is seen (so a huge line is never held in memory).
pub fn bounded_text(reader: impl Read, source: &str) -> Result<String> {
    read_checked(reader, source, false)
}

/// The atom count of a header line `N atoms`, if `line` is one.
fn atoms_line(line: &[u8]) -> Option<u64> {
    let line = std::str::from_utf8(line).ok()?;
    let line = line.split('#').next()?;
    let mut words = line.split_whitespace();
    let (count, keyword) = (words.next()?, words.next()?);
    (keyword == "atoms" && words.next().is_none()).then(|| count.parse().ok()).flatten()
}

/// [`bounded_text`]; with `per_atom`, also refuses text beyond [`MAX_BYTES_PER_ATOM`] per atom
/// of the header's `atoms` line plus [`TEXT_SLACK_BYTES`] as soon as it is exceeded (a
/// decompressed file holds no more than its atoms need).
fn read_checked(mut reader: impl Read, source: &str, per_atom: bool) -> Result<String> {
    let io = |error| LammpsDataError::Io { path: source.to_string(), error };
    let mut bytes = Vec::new();
    let mut chunk = vec![0u8; 1 << 16];
    let (mut line, mut line_len, mut line_start) = (1usize, 0usize, 0usize);
    // the budget once the atom count is known (the header comes before any section)
    let mut budget: Option<u64> = None;
    loop {
        let n = match reader.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(io(e)),
        };
        let base = bytes.len();
        bytes.extend_from_slice(&chunk[..n]);
        for k in base..base + n {
            if bytes[k] == b'\n' {
                if per_atom && budget.is_none() {
                    if let Some(atoms) = atoms_line(&bytes[line_start..k]) {
                        budget = Some(atoms.saturating_mul(MAX_BYTES_PER_ATOM).saturating_add(TEXT_SLACK_BYTES));
                    }
                }
                line += 1;
                line_len = 0;
                line_start = k + 1;
            } else {
                line_len += 1;
                if line_len > MAX_LINE_BYTES {
                    return Err(LammpsDataError::Parse {
                        path: source.to_string(),
                        line,
                        message: format!("line longer than {MAX_LINE_BYTES} bytes (the lines of a LAMMPS data file are short): not a data file"),
                    });
                }
            }
        }
        // before the count is known, the header alone may take the slack
        let allowed = budget.unwrap_or(TEXT_SLACK_BYTES);
        if per_atom && bytes.len() as u64 > allowed {
            return Err(LammpsDataError::Parse {
                path: source.to_string(),
                line,
                message: match budget {
                    Some(b) => format!(
                        "the decompressed text exceeds {b} bytes, more than the atoms the header announces need ({MAX_BYTES_PER_ATOM} bytes per atom + {TEXT_SLACK_BYTES}): not a data file"
                    ),
                    None => format!("no `N atoms` line in the first {TEXT_SLACK_BYTES} bytes of decompressed text: not a data file"),
                },
            });
        }
    }
    String::from_utf8(bytes).map_err(|e| io(std::io::Error::new(std::io::ErrorKind::InvalidData, e)))
}

/// Header keywords whose count line is understood (others, such as `bonds`, must be zero).
const SECTIONS_WITH_ATOM_LINES: &[&str] = &["Atoms", "Velocities"];

/// Parses the text of a data file; `source` names it in messages.
pub fn parse_data(text: &str, source: &str) -> Result<LammpsData> {
    let err = |line: usize, message: String| LammpsDataError::Parse { path: source.to_string(), line, message };
    let mut lines = text.lines().enumerate().map(|(k, l)| (k + 1, l)).peekable();
    let title = lines.next().map(|(_, l)| l.trim().to_string()).unwrap_or_default();

    let mut atoms: Option<usize> = None;
    let mut bounds = [[f64::NAN; 2]; 3];
    let mut tilt = [0.0; 3];
    let mut triclinic = false;
    // Header: until the first section keyword.
    let mut section: Option<(usize, String)> = None;
    for (no, raw) in lines.by_ref() {
        let line = strip_comment(raw);
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        // a section keyword starts with a letter; `nan` and `inf` do too, but are numbers of a
        // header line (`nan 0 0 xy xz yz` was taken for a section and its tilt dropped)
        if words[0].chars().next().is_some_and(|c| c.is_ascii_alphabetic()) && words[0].parse::<f64>().is_err() {
            section = Some((no, raw.to_string()));
            break;
        }
        let number = |k: usize| -> Result<f64> {
            words.get(k).and_then(|w| w.parse::<f64>().ok()).ok_or_else(|| err(no, format!("expected a number in `{}`", clip(line))))
        };
        match &words[1..] {
            ["atoms"] => {
                atoms = Some(words[0].parse().map_err(|_| err(no, format!("bad atom count `{}`", clip(words[0]))))?);
            }
            ["xlo", "xhi"] | ["ylo", "yhi"] | ["zlo", "zhi"] | [_, "xlo", "xhi"] | [_, "ylo", "yhi"] | [_, "zlo", "zhi"] => {
                let axis = match words[words.len() - 1] {
                    "xhi" => 0,
                    "yhi" => 1,
                    _ => 2,
                };
                bounds[axis] = [number(0)?, number(1)?];
            }
            [_, _, "xy", "xz", "yz"] => {
                tilt = [number(0)?, number(1)?, number(2)?];
                // a NaN tilt was dropped without a word (the box came out untilted)
                if let Some(t) = tilt.iter().position(|t| !t.is_finite()) {
                    return Err(err(no, format!("tilt factor {} = {} (allowed: finite tilt factors `xy xz yz`)", ["xy", "xz", "yz"][t], tilt[t])));
                }
                triclinic = true;
            }
            ["atom", "types"] | ["extra", "bond", "per", "atom"] | ["extra", "special", "per", "atom"] => {}
            [kind] | [_, kind] if ["bonds", "angles", "dihedrals", "impropers", "ellipsoids", "lines", "triangles", "bodies"]
                .contains(kind) =>
            {
                if words[0] != "0" {
                    return Err(err(no, format!("{} {kind}: only atoms of `atom_style sphere` can be imported", clip(words[0]))));
                }
            }
            _ if words.len() >= 2 && words[words.len() - 1] == "types" => {}
            _ => return Err(err(no, format!("unknown header line `{}`", clip(line)))),
        }
    }
    let n = atoms.ok_or_else(|| err(0, "the header gives no atom count (`N atoms`)".into()))?;
    // every atom needs a line of at least 7 numbers ("1 1 1 1 0 0 0\n", 14 bytes): a count the
    // text cannot hold is refused before anything is allocated for it
    if n > text.len() / 14 {
        return Err(err(0, format!("the header announces {n} atoms, but the file ({} bytes) cannot hold that many atom lines", text.len())));
    }
    for (axis, name) in ["x", "y", "z"].iter().enumerate() {
        let [lo, hi] = bounds[axis];
        if !(lo.is_finite() && hi.is_finite() && hi > lo) {
            return Err(err(0, format!("missing or empty box bounds `{name}lo {name}hi`")));
        }
    }

    let mut data = LammpsData {
        source: source.to_string(),
        title,
        bounds,
        tilt,
        triclinic,
        id: Vec::with_capacity(n),
        atom_type: Vec::with_capacity(n),
        diameter: Vec::with_capacity(n),
        density: Vec::with_capacity(n),
        pos: Vec::with_capacity(n),
        image: Vec::with_capacity(n),
        vel: vec![[0.0; 3]; n],
        omega: vec![[0.0; 3]; n],
    };
    let mut velocities: Vec<(usize, u32, [f64; 6])> = Vec::new();
    let mut seen_atoms = false;
    while let Some((no, header)) = section.take() {
        let line = strip_comment(&header);
        let name = line.split_whitespace().next().unwrap_or_default().to_string();
        let style = header.split_once('#').map(|(_, s)| s.trim().to_string()).unwrap_or_default();
        if name == "Atoms" && !style.is_empty() && style != "sphere" {
            return Err(err(no, format!("atom style `{}`: only `atom_style sphere` files can be imported", clip(&style))));
        }
        // Section body: until the next keyword; atom sections must have one line per atom.
        let mut body = Vec::new();
        for (no, raw) in lines.by_ref() {
            let line = strip_comment(raw);
            if line.is_empty() {
                continue;
            }
            if line.chars().next().is_some_and(|c| c.is_ascii_alphabetic()) {
                section = Some((no, raw.to_string()));
                break;
            }
            if SECTIONS_WITH_ATOM_LINES.contains(&name.as_str()) {
                body.push((no, line));
            }
        }
        if SECTIONS_WITH_ATOM_LINES.contains(&name.as_str()) && body.len() != n {
            return Err(err(no, format!("section `{name}` has {} lines, the header announces {n} atoms", body.len())));
        }
        match name.as_str() {
            "Atoms" => {
                seen_atoms = true;
                for (no, line) in body {
                    let w: Vec<&str> = line.split_whitespace().collect();
                    if w.len() != 7 && w.len() != 10 {
                        return Err(err(
                            no,
                            format!("expected `id type diameter density x y z [ix iy iz]` (7 or 10 columns), found {}", w.len()),
                        ));
                    }
                    let int = |k: usize| w[k].parse::<i64>().map_err(|_| err(no, format!("column {} is not an integer: `{}`", k + 1, clip(w[k]))));
                    let real = |k: usize| w[k].parse::<f64>().map_err(|_| err(no, format!("column {} is not a number: `{}`", k + 1, clip(w[k]))));
                    let id = int(0)?;
                    let id = u32::try_from(id).map_err(|_| err(no, format!("atom id {id} is outside 0..{}", u32::MAX)))?;
                    let ty = int(1)?;
                    data.id.push(id);
                    data.atom_type.push(u32::try_from(ty).map_err(|_| err(no, format!("bad atom type {ty}")))?);
                    let (d, rho) = (real(2)?, real(3)?);
                    if !(d.is_finite() && d > 0.0) {
                        return Err(err(no, format!("atom {id} has diameter {d}: point particles (diameter 0) cannot be imported")));
                    }
                    if !(rho.is_finite() && rho > 0.0) {
                        return Err(err(no, format!("atom {id} has density {rho}")));
                    }
                    data.diameter.push(d);
                    data.density.push(rho);
                    data.pos.push([real(4)?, real(5)?, real(6)?]);
                    let mut im = [0i32; 3];
                    if w.len() == 10 {
                        for (k, slot) in im.iter_mut().enumerate() {
                            *slot = i32::try_from(int(7 + k)?).map_err(|_| err(no, "image flag out of range".into()))?;
                        }
                    }
                    data.image.push(im);
                }
            }
            "Velocities" => {
                for (no, line) in body {
                    let w: Vec<&str> = line.split_whitespace().collect();
                    if w.len() != 7 {
                        return Err(err(no, format!("expected `id vx vy vz wx wy wz` (7 columns), found {}", w.len())));
                    }
                    let id = w[0].parse::<u32>().map_err(|_| err(no, format!("bad atom id `{}`", clip(w[0]))))?;
                    let mut v = [0.0; 6];
                    for (k, slot) in v.iter_mut().enumerate() {
                        *slot = w[k + 1].parse().map_err(|_| err(no, format!("column {} is not a number: `{}`", k + 2, clip(w[k + 1]))))?;
                    }
                    velocities.push((no, id, v));
                }
            }
            _ => {} // Masses, Pair Coeffs, … : not needed for sphere packings
        }
    }
    if !seen_atoms {
        return Err(err(0, "no `Atoms` section".into()));
    }
    // Velocities are matched by id (LAMMPS writes them in the same order, but need not).
    let mut order: Vec<(u32, usize)> = data.id.iter().enumerate().map(|(k, &id)| (id, k)).collect();
    order.sort_unstable();
    if let Some(w) = order.windows(2).find(|w| w[0].0 == w[1].0) {
        return Err(err(0, format!("atom id {} appears twice in `Atoms`", w[0].0)));
    }
    for (no, id, v) in velocities {
        let k = order.binary_search_by_key(&id, |e| e.0).map_err(|_| err(no, format!("velocity of unknown atom id {id}")))?;
        let k = order[k].1;
        // named here: the engine's refusal quoted the atom's position and velocity, not the spin
        if let Some(c) = v.iter().position(|x| !x.is_finite()) {
            return Err(err(no, format!("atom {id} has {} = {} (allowed: finite velocities and angular velocities)", ["vx", "vy", "vz", "wx", "wy", "wz"][c], v[c])));
        }
        data.vel[k] = [v[0], v[1], v[2]];
        data.omega[k] = [v[3], v[4], v[5]];
    }
    // Positions inside the box, or at most one box length (plus the tilts) outside it, as LAMMPS
    // writes atoms that moved across a periodic face since the last re-neighboring; a
    // coordinate such as 1e300 is a damaged file, not a periodic image.
    let slack = data.tilt.iter().map(|t| t.abs()).sum::<f64>();
    for (k, p) in data.pos.iter().enumerate() {
        for axis in 0..3 {
            let [lo, hi] = data.bounds[axis];
            let l = hi - lo;
            if !(p[axis].is_finite() && p[axis] >= lo - l - slack && p[axis] <= hi + l + slack) {
                return Err(err(
                    0,
                    format!("atom {} has {} = {} (allowed: inside the box [{lo}, {hi}], or within one box length of it)", data.id[k], ["x", "y", "z"][axis], p[axis]),
                ));
            }
        }
    }
    Ok(data)
}

fn strip_comment(line: &str) -> &str {
    line.split_once('#').map_or(line, |(a, _)| a).trim()
}

impl LammpsData {
    /// Number of atoms.
    pub fn len(&self) -> usize {
        self.id.len()
    }

    /// True when there are no atoms.
    pub fn is_empty(&self) -> bool {
        self.id.is_empty()
    }

    /// True when every atom lies in the z = 0 plane with no velocity along z and no spin about
    /// x or y: the file comes from a `dimension 2` run.
    pub fn is_planar(&self) -> bool {
        self.pos.iter().all(|p| p[2] == 0.0)
            && self.vel.iter().all(|v| v[2] == 0.0)
            && self.omega.iter().all(|w| w[0] == 0.0 && w[1] == 0.0)
    }

    fn import_error(&self, message: String) -> LammpsDataError {
        LammpsDataError::Import { path: self.source.clone(), message }
    }

    fn domain_bounds(&self, opts: &ImportOptions, dim: usize) -> Result<()> {
        for (t, (edge, along)) in [(1, 0), (2, 0), (2, 1)].into_iter().enumerate() {
            if self.tilt[t] != 0.0 && !(edge < dim && opts.periodic[edge] && opts.periodic[along]) {
                return Err(self.import_error(format!(
                    "the box is triclinic (tilt xy xz yz = {:?}) but tilt {} needs periodic axes {} and {} in {dim}D",
                    self.tilt,
                    ["xy", "xz", "yz"][t],
                    ["x", "y", "z"][along],
                    ["x", "y", "z"][edge]
                )));
            }
        }
        Ok(())
    }

    /// Spheres in a 3D domain: m = ρ (4/3) π r³, I = (2/5) m r².
    pub fn to_packing_3d(&self, opts: &ImportOptions) -> Result<(Grains<D3>, Domain<D3>)> {
        self.domain_bounds(opts, 3)?;
        let mut grains = Grains::<D3>::new(GrainKind::Sphere);
        for k in 0..self.len() {
            let r = 0.5 * self.diameter[k];
            let mass = 4.0 * PI / 3.0 * r * r * r * self.density[k];
            grains.push_with_mass(DVec3::from_array(self.pos[k]), r, mass, DVec3::from_array(self.vel[k]));
            grains.omega[k] = DVec3::from_array(self.omega[k]);
        }
        self.finish(&mut grains.id, &mut grains.image);
        let b = &self.bounds;
        let mut domain = Domain::new(DVec3::new(b[0][0], b[1][0], b[2][0]), DVec3::new(b[0][1], b[1][1], b[2][1]), opts.periodic);
        domain.tilt = self.tilt;
        Ok((grains, domain))
    }

    /// Disks in a 2D domain (the x–y plane): mass from [`ImportOptions::density_2d`],
    /// I = ½ m r². Refused unless [`LammpsData::is_planar`].
    pub fn to_packing_2d(&self, opts: &ImportOptions) -> Result<(Grains<D2>, Domain<D2>)> {
        self.domain_bounds(opts, 2)?;
        if !self.is_planar() {
            return Err(self.import_error("not a 2D packing: some atoms have z ≠ 0, v_z ≠ 0 or spin about x or y".into()));
        }
        let mut grains = Grains::<D2>::new(GrainKind::Disk { thickness: 1.0 });
        for k in 0..self.len() {
            let r = 0.5 * self.diameter[k];
            let mass = match opts.density_2d {
                Density2d::Volume => 4.0 * PI / 3.0 * r * r * r * self.density[k],
                Density2d::Area => PI * r * r * self.density[k],
            };
            let [x, y, _] = self.pos[k];
            let [vx, vy, _] = self.vel[k];
            grains.push_with_mass(DVec2::new(x, y), r, mass, DVec2::new(vx, vy));
            grains.omega[k] = self.omega[k][2];
        }
        self.finish(&mut grains.id, &mut grains.image);
        let b = &self.bounds;
        let mut domain = Domain::new(DVec2::new(b[0][0], b[1][0]), DVec2::new(b[0][1], b[1][1]), [opts.periodic[0], opts.periodic[1], false]);
        domain.tilt = [self.tilt[0], 0.0, 0.0];
        Ok((grains, domain))
    }

    /// Ids and image flags from the file.
    fn finish(&self, id: &mut [u32], image: &mut [[i32; 3]]) {
        id.copy_from_slice(&self.id);
        image.copy_from_slice(&self.image);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SMALL_3D: &str = "\
LAMMPS data file via write_data, version 29 Sep 2021, timestep = 19000

3 atoms
1 atom types

0 10.5 xlo xhi
-1 9 ylo yhi
0 12 zlo zhi

Atoms # sphere

12 1 1 1 0.5 0.5 0.5 0 0 1
4 1 1.2 2 2.5 0.5 0.5 -1 0 0
9 1 0.8 1 4.5 0.5 0.5 0 2 0

Velocities

9 0.1 0.2 0.3 0.4 0.5 0.6
12 1 2 3 4 5 6
4 0 0 0 0 0 0
";

    #[test]
    fn reads_header_atoms_and_velocities_by_id() {
        let d = parse_data(SMALL_3D, "small").unwrap();
        assert_eq!(d.len(), 3);
        assert_eq!(d.bounds, [[0.0, 10.5], [-1.0, 9.0], [0.0, 12.0]]);
        assert!(!d.triclinic);
        assert_eq!(d.id, vec![12, 4, 9]);
        assert_eq!(d.image[0], [0, 0, 1]);
        assert_eq!(d.image[1], [-1, 0, 0]);
        assert_eq!(d.vel[2], [0.1, 0.2, 0.3]);
        assert_eq!(d.omega[0], [4.0, 5.0, 6.0]);
        assert!(!d.is_planar());
        let (g, dom) = d.to_packing_3d(&ImportOptions::default()).unwrap();
        // m = ρ (4/3) π r³ = ρ (π/6) d³, I = (2/5) m r²
        assert!((g.mass[1] - 2.0 * PI / 6.0 * 1.2f64.powi(3)).abs() < 1e-14);
        assert!((g.inertia[1] - 0.4 * g.mass[1] * 0.36).abs() < 1e-14);
        assert_eq!(g.radius[2], 0.4);
        assert_eq!(g.image[1], [-1, 0, 0]);
        assert_eq!(g.vel[0], DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(dom.lo, DVec3::new(0.0, -1.0, 0.0));
        assert_eq!(dom.periodic, [true; 3]);
        assert!(d.to_packing_2d(&ImportOptions::default()).unwrap_err().to_string().contains("not a 2D packing"));
    }

    #[test]
    fn disks_get_the_mass_lammps_gives_them() {
        // From a `dimension 2` file written after `set density/disc 1.0`: density column
        // 1.535445687612726 for d = 0.9769150495529175 is m/((4/3)π r³) with m = π r².
        let text = "\
2D

1 atoms
1 atom types
0 124.639885321597 xlo xhi
0 124.639885321597 ylo yhi
-0.5 0.5 zlo zhi

Atoms # sphere

1901 1 0.9769150495529175 1.535445687612726 0.24655795810155753 0.3140596037412733 0 0 1 0

Velocities

1901 -0.024292796522486 0.018149039052323856 0 0 0 0.003691561781469778
";
        let d = parse_data(text, "disk").unwrap();
        assert!(d.is_planar());
        let (g, dom) = d.to_packing_2d(&ImportOptions::default()).unwrap();
        let r = 0.5 * 0.9769150495529175;
        assert!((g.mass[0] / (PI * r * r) - 1.0).abs() < 1e-14, "mass {}", g.mass[0]);
        assert!((g.inertia[0] - 0.5 * g.mass[0] * r * r).abs() < 1e-16);
        assert_eq!(g.omega[0], 0.003691561781469778);
        assert_eq!(g.vel[0], DVec2::new(-0.024292796522486, 0.018149039052323856));
        assert_eq!(dom.hi, DVec2::splat(124.639885321597));
        assert_eq!(dom.periodic, [true, true, false]);
        // an areal density column
        let opts = ImportOptions { density_2d: Density2d::Area, ..Default::default() };
        let (g, _) = d.to_packing_2d(&opts).unwrap();
        assert!((g.mass[0] - 1.535445687612726 * PI * r * r).abs() < 1e-14);
    }

    #[test]
    fn gzip_files_are_read_transparently() {
        use std::io::Write;
        let dir = std::env::temp_dir().join(format!("grainwave-lammps-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("small.data.gz");
        let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        enc.write_all(SMALL_3D.as_bytes()).unwrap();
        std::fs::write(&path, enc.finish().unwrap()).unwrap();
        let d = read_data(&path).unwrap();
        assert_eq!(d, LammpsData { source: path.display().to_string(), ..parse_data(SMALL_3D, "x").unwrap() });
        let plain = dir.join("small.data");
        std::fs::write(&plain, SMALL_3D).unwrap();
        assert_eq!(read_data(&plain).unwrap().id, vec![12, 4, 9]);
        let err = read_data(&dir.join("missing.data")).unwrap_err().to_string();
        assert!(err.contains("missing.data"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn malformed_files_are_refused_with_the_line() {
        let bad_count = SMALL_3D.replace("3 atoms", "4 atoms");
        let err = parse_data(&bad_count, "f").unwrap_err().to_string();
        assert!(err.contains("`Atoms` has 3 lines") && err.contains("4 atoms"), "{err}");
        let bad_number = SMALL_3D.replace("4.5 0.5 0.5", "4.5 zero 0.5");
        let err = parse_data(&bad_number, "f").unwrap_err().to_string();
        assert!(err.contains("line 14") && err.contains("zero"), "{err}");
        let atomic = SMALL_3D.replace("Atoms # sphere", "Atoms # atomic");
        assert!(parse_data(&atomic, "f").unwrap_err().to_string().contains("atom_style sphere"));
        let no_box = SMALL_3D.replace("0 12 zlo zhi\n", "");
        assert!(parse_data(&no_box, "f").unwrap_err().to_string().contains("zlo zhi"));
        let twice = SMALL_3D.replace("9 1 0.8", "12 1 0.8");
        assert!(parse_data(&twice, "f").unwrap_err().to_string().contains("atom id 12 appears twice"));
        let bonds = SMALL_3D.replace("1 atom types", "1 atom types\n2 bonds");
        assert!(parse_data(&bonds, "f").unwrap_err().to_string().contains("2 bonds"));
        let point = SMALL_3D.replace("4 1 1.2 2", "4 1 0 2");
        assert!(parse_data(&point, "f").unwrap_err().to_string().contains("diameter 0"));
    }

    #[test]
    fn atoms_far_outside_the_box_are_refused() {
        // less than one box length outside (a periodic image LAMMPS may write) is read; 1e300 is not
        let atoms = SMALL_3D.find("Atoms").unwrap();
        let line_start = SMALL_3D[atoms..].find("\n\n").unwrap() + atoms + 2;
        let line_end = SMALL_3D[line_start..].find('\n').unwrap() + line_start;
        let line = &SMALL_3D[line_start..line_end];
        let mut w: Vec<String> = line.split_whitespace().map(String::from).collect();
        for (x, ok) in [("15.0", true), ("-8", true), ("1e300", false), ("inf", false), ("-1e30", false)] {
            w[4] = x.to_string();
            let text = format!("{}{}{}", &SMALL_3D[..line_start], w.join(" "), &SMALL_3D[line_end..]);
            let r = parse_data(&text, "f");
            assert_eq!(r.is_ok(), ok, "x = {x}: {r:?}");
            if let Err(e) = r {
                assert!(e.to_string().contains(&format!("has x = {}", x.parse::<f64>().unwrap())), "{e}");
            }
        }
    }

    #[test]
    fn triclinic_boxes_become_sheared_cells() {
        let tri = SMALL_3D.replace("0 12 zlo zhi\n", "0 12 zlo zhi\n1.5 0 -0.5 xy xz yz\n");
        let d = parse_data(&tri, "f").unwrap();
        assert!(d.triclinic);
        assert_eq!(d.tilt, [1.5, 0.0, -0.5]);
        let (_, dom) = d.to_packing_3d(&ImportOptions::default()).unwrap();
        assert_eq!(dom.tilt, [1.5, 0.0, -0.5]);
        let walls_in_z = ImportOptions { periodic: [true, true, false], ..Default::default() };
        assert!(d.to_packing_3d(&walls_in_z).unwrap_err().to_string().contains("tilt yz needs periodic axes y and z"));
    }
}
