//! NumPy `.npy` arrays: writer (format version 1.0) and reader (versions 1.0, 2.0 and 3.0).
//!
//! A `.npy` file is the magic string `\x93NUMPY`, a two-byte format version, the length of a
//! header, the header — a Python dict literal such as
//! `{'descr': '<f8', 'fortran_order': False, 'shape': (300, 2), }` padded with spaces and ended
//! by `\n` so that the data start at a multiple of 64 bytes — and then the raw values.
//!
//! Files written here are little-endian, in C (row-major) order: for shape `(n, 3)` the values
//! are `a[0,0], a[0,1], a[0,2], a[1,0], …`. `numpy.load(path)` returns the array with the same
//! shape, dtype and bits. The supported element types and their NumPy dtypes are
//!
//! | Rust | dtype | `descr` |
//! |---|---|---|
//! | `f64` | `float64` | `<f8` |
//! | `f32` | `float32` | `<f4` |
//! | `i64` | `int64` | `<i8` |
//! | `i32` | `int32` | `<i4` |
//! | `u32` | `uint32` | `<u4` |
//! | `u8` | `uint8` | `\|u1` |
//! | `bool` | `bool` | `\|b1` |
//!
//! The reader accepts these dtypes in either byte order and in C or Fortran order (Fortran-ordered
//! arrays are returned in C order); structured and object arrays are refused with an error.

use crate::error::{OutputError, Result};
use grainwave_core::checkpoint::atomic_write;
use std::path::Path;

const MAGIC: &[u8; 6] = b"\x93NUMPY";
/// Data start at a multiple of this many bytes (NumPy ≥ 1.x uses 64 for memory-mapping).
const ALIGN: usize = 64;

mod sealed {
    pub trait Sealed {}
    impl Sealed for f64 {}
    impl Sealed for f32 {}
    impl Sealed for i64 {}
    impl Sealed for i32 {}
    impl Sealed for u32 {}
    impl Sealed for u8 {}
    impl Sealed for bool {}
}

/// An element type that can be stored in a `.npy` file (see the module table).
pub trait NpyElement: Copy + sealed::Sealed + 'static {
    /// NumPy type string of the little-endian encoding, e.g. `<f8`.
    const DESCR: &'static str;
    /// Bytes per element.
    const SIZE: usize;
    /// Appends the little-endian bytes of `values` to `out`.
    fn extend_le(values: &[Self], out: &mut Vec<u8>);
    /// Wraps owned values into the matching [`NpyData`] variant.
    fn into_data(values: Vec<Self>) -> NpyData;
    /// The values of `data` if it holds this element type.
    fn slice(data: &NpyData) -> Option<&[Self]>;
}

macro_rules! numeric_element {
    ($t:ty, $descr:literal, $variant:ident) => {
        impl NpyElement for $t {
            const DESCR: &'static str = $descr;
            const SIZE: usize = std::mem::size_of::<$t>();
            fn extend_le(values: &[Self], out: &mut Vec<u8>) {
                out.reserve(values.len() * Self::SIZE);
                for v in values {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
            fn into_data(values: Vec<Self>) -> NpyData {
                NpyData::$variant(values)
            }
            fn slice(data: &NpyData) -> Option<&[Self]> {
                match data {
                    NpyData::$variant(v) => Some(v),
                    _ => None,
                }
            }
        }
    };
}

numeric_element!(f64, "<f8", F64);
numeric_element!(f32, "<f4", F32);
numeric_element!(i64, "<i8", I64);
numeric_element!(i32, "<i4", I32);
numeric_element!(u32, "<u4", U32);
numeric_element!(u8, "|u1", U8);

impl NpyElement for bool {
    const DESCR: &'static str = "|b1";
    const SIZE: usize = 1;
    fn extend_le(values: &[Self], out: &mut Vec<u8>) {
        out.extend(values.iter().map(|&b| u8::from(b)));
    }
    fn into_data(values: Vec<Self>) -> NpyData {
        NpyData::Bool(values)
    }
    fn slice(data: &NpyData) -> Option<&[Self]> {
        match data {
            NpyData::Bool(v) => Some(v),
            _ => None,
        }
    }
}

/// The values of an array, flattened in C order, tagged with their element type.
#[derive(Clone, Debug, PartialEq)]
pub enum NpyData {
    /// `float64`.
    F64(Vec<f64>),
    /// `float32`.
    F32(Vec<f32>),
    /// `int64`.
    I64(Vec<i64>),
    /// `int32`.
    I32(Vec<i32>),
    /// `uint32`.
    U32(Vec<u32>),
    /// `uint8`.
    U8(Vec<u8>),
    /// `bool` (one byte per value, 0 or 1).
    Bool(Vec<bool>),
}

/// Applies `$body` to the vector inside any [`NpyData`] variant, bound to `$v` with element type `$t`.
macro_rules! each_variant {
    ($data:expr, $v:ident => $body:expr) => {
        match $data {
            NpyData::F64($v) => $body,
            NpyData::F32($v) => $body,
            NpyData::I64($v) => $body,
            NpyData::I32($v) => $body,
            NpyData::U32($v) => $body,
            NpyData::U8($v) => $body,
            NpyData::Bool($v) => $body,
        }
    };
}

impl NpyData {
    /// Number of values.
    pub fn len(&self) -> usize {
        each_variant!(self, v => v.len())
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// NumPy type string of the little-endian encoding (`<f8`, `|b1`, …).
    pub fn descr(&self) -> &'static str {
        fn d<T: NpyElement>(_: &[T]) -> &'static str {
            T::DESCR
        }
        each_variant!(self, v => d(v))
    }

    fn extend_le(&self, out: &mut Vec<u8>) {
        each_variant!(self, v => NpyElement::extend_le(v, out))
    }

    /// The values converted to `f64`: exact for every type except `i64` values beyond ±2⁵³
    /// (rounded to the nearest `f64`); `true`/`false` become 1 and 0.
    pub fn to_f64(&self) -> Vec<f64> {
        match self {
            NpyData::F64(v) => v.clone(),
            NpyData::F32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyData::I64(v) => v.iter().map(|&x| x as f64).collect(),
            NpyData::I32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyData::U32(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyData::U8(v) => v.iter().map(|&x| f64::from(x)).collect(),
            NpyData::Bool(v) => v.iter().map(|&x| f64::from(u8::from(x))).collect(),
        }
    }

    /// Reorders values stored in Fortran (column-major) order for `shape` into C order.
    fn fortran_to_c(self, shape: &[usize]) -> Self {
        if shape.len() < 2 {
            return self;
        }
        // For every C-order position, the Fortran-order index holding that element.
        let n: usize = shape.iter().product();
        let mut f_strides = vec![1usize; shape.len()];
        for k in 1..shape.len() {
            f_strides[k] = f_strides[k - 1] * shape[k - 1];
        }
        let mut source = Vec::with_capacity(n);
        let mut index = vec![0usize; shape.len()];
        for _ in 0..n {
            source.push(index.iter().zip(&f_strides).map(|(i, s)| i * s).sum::<usize>());
            // Advance the multi-index in C order (last axis fastest).
            for k in (0..shape.len()).rev() {
                index[k] += 1;
                if index[k] < shape[k] {
                    break;
                }
                index[k] = 0;
            }
        }
        fn permute<T: Copy>(v: Vec<T>, source: &[usize]) -> Vec<T> {
            source.iter().map(|&s| v[s]).collect()
        }
        match self {
            NpyData::F64(v) => NpyData::F64(permute(v, &source)),
            NpyData::F32(v) => NpyData::F32(permute(v, &source)),
            NpyData::I64(v) => NpyData::I64(permute(v, &source)),
            NpyData::I32(v) => NpyData::I32(permute(v, &source)),
            NpyData::U32(v) => NpyData::U32(permute(v, &source)),
            NpyData::U8(v) => NpyData::U8(permute(v, &source)),
            NpyData::Bool(v) => NpyData::Bool(permute(v, &source)),
        }
    }
}

/// An n-dimensional array: a shape and its values in C (row-major) order.
///
/// ```
/// use grainwave_io::NpyArray;
///
/// let a = NpyArray::new(&[2, 3], vec![0.0, 0.5, 1.0, 1.5, 2.0, 2.5]).unwrap();
/// let bytes = a.to_npy_bytes();
/// assert_eq!(&bytes[..6], b"\x93NUMPY");
/// let back = NpyArray::from_npy_bytes("a.npy", &bytes).unwrap();
/// assert_eq!(back.shape(), [2, 3]);
/// assert_eq!(back.as_slice::<f64>().unwrap()[4], 2.0);
/// ```
#[derive(Clone, Debug, PartialEq)]
pub struct NpyArray {
    shape: Vec<usize>,
    data: NpyData,
}

fn check_shape(name: &str, shape: &[usize], len: usize) -> Result<()> {
    let expected = shape.iter().try_fold(1usize, |a, &b| a.checked_mul(b)).unwrap_or(usize::MAX);
    if expected != len {
        return Err(OutputError::Shape { name: name.to_string(), shape: shape.to_vec(), len, expected });
    }
    Ok(())
}

impl NpyArray {
    /// An array of `shape` holding `values` in C order; fails unless the product of `shape`
    /// equals the number of values (an empty shape `[]` is a scalar: one value).
    pub fn new<T: NpyElement>(shape: &[usize], values: Vec<T>) -> Result<Self> {
        Self::from_data(shape, T::into_data(values))
    }

    /// A one-dimensional array (shape `[values.len()]`).
    pub fn vector<T: NpyElement>(values: Vec<T>) -> Self {
        let shape = vec![values.len()];
        NpyArray { shape, data: T::into_data(values) }
    }

    /// An array of `shape` holding `data` in C order (checked like [`NpyArray::new`]).
    pub fn from_data(shape: &[usize], data: NpyData) -> Result<Self> {
        check_shape("array", shape, data.len())?;
        Ok(NpyArray { shape: shape.to_vec(), data })
    }

    /// The shape (`[]` for a scalar).
    pub fn shape(&self) -> &[usize] {
        &self.shape
    }

    /// The values, flattened in C order.
    pub fn data(&self) -> &NpyData {
        &self.data
    }

    /// Number of values (the product of the shape).
    pub fn len(&self) -> usize {
        self.data.len()
    }

    /// True when the array has no values.
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }

    /// The values as a slice of `T`, if the array holds that element type.
    pub fn as_slice<T: NpyElement>(&self) -> Option<&[T]> {
        T::slice(&self.data)
    }

    /// The `f64` values, if the array holds `float64`.
    pub fn as_f64(&self) -> Option<&[f64]> {
        self.as_slice()
    }

    /// The `i64` values, if the array holds `int64`.
    pub fn as_i64(&self) -> Option<&[i64]> {
        self.as_slice()
    }

    /// Shape and values, taking the array apart.
    pub fn into_parts(self) -> (Vec<usize>, NpyData) {
        (self.shape, self.data)
    }

    /// The complete `.npy` file (format 1.0, little-endian, C order).
    pub fn to_npy_bytes(&self) -> Vec<u8> {
        let mut out = npy_header(self.data.descr(), &self.shape);
        self.data.extend_le(&mut out);
        out
    }

    /// Parses a complete `.npy` file; `name` only labels errors.
    pub fn from_npy_bytes(name: &str, bytes: &[u8]) -> Result<Self> {
        parse_npy(name, bytes)
    }
}

/// Magic, version, header length and the padded header dict, for `descr` and `shape`.
fn npy_header(descr: &str, shape: &[usize]) -> Vec<u8> {
    let shape_text = match shape {
        [] => "()".to_string(),
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(|n| n.to_string()).collect::<Vec<_>>().join(", ")),
    };
    let mut dict = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape_text}, }}");
    // Version 1.0 has a 2-byte header length; NumPy switches to 2.0 (4 bytes) beyond 65535.
    let padded_v1 = (10 + dict.len() + 1).div_ceil(ALIGN) * ALIGN - 10;
    let version1 = padded_v1 <= u16::MAX as usize;
    let prefix = if version1 { 10 } else { 12 };
    let total = (prefix + dict.len() + 1).div_ceil(ALIGN) * ALIGN;
    while prefix + dict.len() + 1 < total {
        dict.push(' ');
    }
    dict.push('\n');
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(MAGIC);
    if version1 {
        out.extend_from_slice(&[1, 0]);
        out.extend_from_slice(&(dict.len() as u16).to_le_bytes());
    } else {
        out.extend_from_slice(&[2, 0]);
        out.extend_from_slice(&(dict.len() as u32).to_le_bytes());
    }
    out.extend_from_slice(dict.as_bytes());
    out
}

/// The complete `.npy` file for `values` of `shape` (C order), checking the shape; `name` only
/// labels errors.
pub fn npy_bytes<T: NpyElement>(name: &str, shape: &[usize], values: &[T]) -> Result<Vec<u8>> {
    check_shape(name, shape, values.len())?;
    let mut out = npy_header(T::DESCR, shape);
    T::extend_le(values, &mut out);
    Ok(out)
}

/// Writes `values` (C order) with `shape` to `path` as a `.npy` file, atomically; parent
/// directories are created. Fails unless the product of `shape` equals `values.len()`.
///
/// ```
/// use grainwave_io::{read_npy, write_npy};
///
/// let dir = std::env::temp_dir().join(format!("grainwave-npy-doc-{}", std::process::id()));
/// let path = dir.join("positions.npy");
/// write_npy(&path, &[2, 2], &[0.0, 1.0, 2.5, -1.0]).unwrap(); // two points (x, y)
/// let a = read_npy(&path).unwrap();
/// assert_eq!(a.shape(), [2, 2]);
/// assert_eq!(a.as_f64().unwrap(), [0.0, 1.0, 2.5, -1.0]);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
pub fn write_npy<T: NpyElement>(path: &Path, shape: &[usize], values: &[T]) -> Result<()> {
    let bytes = npy_bytes(&path.display().to_string(), shape, values)?;
    atomic_write(path, &bytes)?;
    Ok(())
}

/// Reads a `.npy` file (see the module documentation for the accepted dtypes and layouts).
pub fn read_npy(path: &Path) -> Result<NpyArray> {
    let bytes = read_file(path)?;
    parse_npy(&path.display().to_string(), &bytes)
}

/// Reads a whole file, naming it in the error.
pub(crate) fn read_file(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| OutputError::Read { path: path.display().to_string(), source })
}

fn npy_error(name: &str, reason: impl Into<String>) -> OutputError {
    OutputError::Npy { name: name.to_string(), reason: reason.into() }
}

/// The text following `key:` in a Python dict literal, with leading white space removed.
fn after_key<'a>(header: &'a str, key: &str) -> Option<&'a str> {
    for quote in ['\'', '"'] {
        let pattern = format!("{quote}{key}{quote}");
        if let Some(k) = header.find(&pattern) {
            let rest = header[k + pattern.len()..].trim_start();
            return rest.strip_prefix(':').map(str::trim_start);
        }
    }
    None
}

struct Header {
    descr: String,
    fortran_order: bool,
    shape: Vec<usize>,
}

fn parse_header(name: &str, header: &str) -> Result<Header> {
    let descr_text = after_key(header, "descr").ok_or_else(|| npy_error(name, "the header has no 'descr'"))?;
    let quote = descr_text.chars().next().filter(|c| *c == '\'' || *c == '"').ok_or_else(|| {
        npy_error(name, format!("structured dtypes are not supported (descr = {})", descr_text.split('}').next().unwrap_or("")))
    })?;
    let descr = descr_text[1..].split(quote).next().unwrap_or("").to_string();
    let fortran_text = after_key(header, "fortran_order").ok_or_else(|| npy_error(name, "the header has no 'fortran_order'"))?;
    let fortran_order = if fortran_text.starts_with("True") {
        true
    } else if fortran_text.starts_with("False") {
        false
    } else {
        return Err(npy_error(name, "'fortran_order' is neither True nor False"));
    };
    let shape_text = after_key(header, "shape").ok_or_else(|| npy_error(name, "the header has no 'shape'"))?;
    let inner = shape_text
        .strip_prefix('(')
        .and_then(|s| s.split(')').next())
        .ok_or_else(|| npy_error(name, "'shape' is not a tuple"))?;
    let mut shape = Vec::new();
    for part in inner.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let n = part.trim_end_matches('L').parse::<usize>().map_err(|_| npy_error(name, format!("bad dimension `{part}` in 'shape'")))?;
        shape.push(n);
    }
    Ok(Header { descr, fortran_order, shape })
}

fn parse_npy(name: &str, bytes: &[u8]) -> Result<NpyArray> {
    if bytes.len() < 10 || &bytes[..6] != MAGIC {
        return Err(npy_error(name, "missing the \\x93NUMPY magic string"));
    }
    let (header_len, start) = match bytes[6] {
        1 => (u16::from_le_bytes([bytes[8], bytes[9]]) as usize, 10),
        2 | 3 if bytes.len() >= 12 => (u32::from_le_bytes([bytes[8], bytes[9], bytes[10], bytes[11]]) as usize, 12),
        v => return Err(npy_error(name, format!("unsupported format version {v}.{}", bytes[7]))),
    };
    let end = start + header_len;
    if bytes.len() < end {
        return Err(npy_error(name, "the file ends inside the header"));
    }
    let header = std::str::from_utf8(&bytes[start..end]).map_err(|_| npy_error(name, "the header is not text"))?;
    let h = parse_header(name, header)?;
    let body = &bytes[end..];
    let n = h.shape.iter().try_fold(1usize, |a, &b| a.checked_mul(b)).ok_or_else(|| npy_error(name, "the shape overflows"))?;

    let mut chars = h.descr.chars();
    let order = chars.next().unwrap_or('?');
    let code: String = chars.collect();
    let big_endian = match order {
        '<' | '|' | '=' => false,
        '>' => true,
        _ => return Err(npy_error(name, format!("unsupported dtype `{}`", h.descr))),
    };
    let size = match code.as_str() {
        "f8" | "i8" => 8,
        "f4" | "i4" | "u4" => 4,
        "u1" | "b1" => 1,
        _ => {
            return Err(npy_error(
                name,
                format!("unsupported dtype `{}` (supported: float64, float32, int64, int32, uint32, uint8, bool)", h.descr),
            ))
        }
    };
    if body.len() != n * size {
        return Err(npy_error(name, format!("shape {:?} of `{}` needs {} data bytes, the file has {}", h.shape, h.descr, n * size, body.len())));
    }
    macro_rules! decode {
        ($t:ty, $variant:ident) => {{
            const W: usize = std::mem::size_of::<$t>();
            NpyData::$variant(
                body.chunks_exact(W)
                    .map(|c| {
                        let a: [u8; W] = c.try_into().expect("chunk of the element size");
                        if big_endian {
                            <$t>::from_be_bytes(a)
                        } else {
                            <$t>::from_le_bytes(a)
                        }
                    })
                    .collect(),
            )
        }};
    }
    let data = match code.as_str() {
        "f8" => decode!(f64, F64),
        "f4" => decode!(f32, F32),
        "i8" => decode!(i64, I64),
        "i4" => decode!(i32, I32),
        "u4" => decode!(u32, U32),
        "u1" => NpyData::U8(body.to_vec()),
        _ => NpyData::Bool(body.iter().map(|&b| b != 0).collect()),
    };
    let data = if h.fortran_order { data.fortran_to_c(&h.shape) } else { data };
    Ok(NpyArray { shape: h.shape, data })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::table::tests::scratch_dir;

    #[test]
    fn header_is_aligned_and_readable() {
        for shape in [vec![], vec![0], vec![7], vec![3, 4], vec![2, 3, 5, 1]] {
            let h = npy_header("<f8", &shape);
            assert_eq!(h.len() % ALIGN, 0, "{shape:?}");
            assert_eq!(*h.last().unwrap(), b'\n');
            let text = std::str::from_utf8(&h[10..]).unwrap();
            assert_eq!(u16::from_le_bytes([h[8], h[9]]) as usize, text.len());
            let parsed = parse_header("t", text).unwrap();
            assert_eq!(parsed.shape, shape);
            assert_eq!(parsed.descr, "<f8");
            assert!(!parsed.fortran_order);
        }
        let h = npy_header("<i8", &[3]);
        assert!(std::str::from_utf8(&h[10..]).unwrap().contains("{'descr': '<i8', 'fortran_order': False, 'shape': (3,), }"));
    }

    #[test]
    fn round_trip_every_type_bit_exact() {
        let dir = scratch_dir("npy-types");
        let f64s = vec![0.0, -0.0, 1.0 / 3.0, f64::MIN_POSITIVE, f64::MAX, f64::NAN, f64::NEG_INFINITY, -2.5e-300];
        write_npy(&dir.join("f64.npy"), &[2, 4], &f64s).unwrap();
        let back = read_npy(&dir.join("f64.npy")).unwrap();
        assert_eq!(back.shape(), [2, 4]);
        let bits: Vec<u64> = back.as_f64().unwrap().iter().map(|x| x.to_bits()).collect();
        assert_eq!(bits, f64s.iter().map(|x| x.to_bits()).collect::<Vec<_>>());

        let f32s = vec![1.5f32, -3.25e-20, f32::MAX];
        write_npy(&dir.join("f32.npy"), &[3], &f32s).unwrap();
        assert_eq!(read_npy(&dir.join("f32.npy")).unwrap().as_slice::<f32>().unwrap(), f32s);

        let i64s: Vec<i64> = vec![i64::MIN, -1, 0, 1, i64::MAX, 1 << 53];
        write_npy(&dir.join("i64.npy"), &[3, 2], &i64s).unwrap();
        let a = read_npy(&dir.join("i64.npy")).unwrap();
        assert_eq!((a.shape(), a.as_i64().unwrap()), (&[3usize, 2][..], &i64s[..]));

        let i32s = vec![i32::MIN, 7, i32::MAX];
        write_npy(&dir.join("i32.npy"), &[1, 3], &i32s).unwrap();
        assert_eq!(read_npy(&dir.join("i32.npy")).unwrap().as_slice::<i32>().unwrap(), i32s);

        let u32s = vec![0u32, 17, u32::MAX];
        write_npy(&dir.join("u32.npy"), &[3], &u32s).unwrap();
        assert_eq!(read_npy(&dir.join("u32.npy")).unwrap().data(), &NpyData::U32(u32s));

        let u8s = vec![0u8, 255, 3, 4];
        write_npy(&dir.join("u8.npy"), &[2, 2], &u8s).unwrap();
        assert_eq!(read_npy(&dir.join("u8.npy")).unwrap().data(), &NpyData::U8(u8s));

        let bools = vec![true, false, true];
        write_npy(&dir.join("bool.npy"), &[3], &bools).unwrap();
        let b = read_npy(&dir.join("bool.npy")).unwrap();
        assert_eq!(b.data(), &NpyData::Bool(bools));
        assert_eq!(b.data().to_f64(), [1.0, 0.0, 1.0]);

        // A scalar (shape ()) and an empty array (shape (0, 3)).
        write_npy(&dir.join("scalar.npy"), &[], &[42.5]).unwrap();
        let s = read_npy(&dir.join("scalar.npy")).unwrap();
        assert_eq!((s.shape(), s.as_f64().unwrap()), (&[][..], &[42.5][..]));
        write_npy::<f64>(&dir.join("empty.npy"), &[0, 3], &[]).unwrap();
        let e = read_npy(&dir.join("empty.npy")).unwrap();
        assert_eq!(e.shape(), [0, 3]);
        assert!(e.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn wrong_shape_is_refused_and_nothing_written() {
        let dir = scratch_dir("npy-shape");
        let path = dir.join("bad.npy");
        let err = write_npy(&path, &[2, 3], &[1.0, 2.0]).unwrap_err();
        assert!(matches!(err, OutputError::Shape { len: 2, expected: 6, .. }), "{err}");
        assert!(err.to_string().contains("bad.npy"), "{err}");
        assert!(!path.exists());
        assert!(NpyArray::new(&[4], vec![1i64, 2]).is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// Builds a file by hand the way another writer might: version 2.0, big-endian, Fortran order.
    fn foreign_file(descr: &str, fortran: bool, shape: &str, body: &[u8]) -> Vec<u8> {
        let dict = format!("{{\"descr\": \"{descr}\", \"fortran_order\": {}, \"shape\": {shape}}}\n", if fortran { "True" } else { "False" });
        let mut out = MAGIC.to_vec();
        out.extend_from_slice(&[2, 0]);
        out.extend_from_slice(&(dict.len() as u32).to_le_bytes());
        out.extend_from_slice(dict.as_bytes());
        out.extend_from_slice(body);
        out
    }

    #[test]
    fn reads_big_endian_fortran_order_and_version_2() {
        // The 2 × 3 matrix [[0, 1, 2], [10, 11, 12]] stored column by column, big-endian.
        let column_major = [0i64, 10, 1, 11, 2, 12];
        let body: Vec<u8> = column_major.iter().flat_map(|v| v.to_be_bytes()).collect();
        let a = parse_npy("f.npy", &foreign_file(">i8", true, "(2, 3)", &body)).unwrap();
        assert_eq!(a.shape(), [2, 3]);
        assert_eq!(a.as_i64().unwrap(), [0, 1, 2, 10, 11, 12]);

        // 3-D Fortran order: element (i, j, k) sits at i + 2 j + 4 k.
        let shape = [2usize, 2, 3];
        let f: Vec<f64> = (0..12).map(|n| n as f64).collect();
        let body: Vec<u8> = f.iter().flat_map(|v| v.to_le_bytes()).collect();
        let a = parse_npy("g.npy", &foreign_file("<f8", true, "(2, 2, 3)", &body)).unwrap();
        let c = a.as_f64().unwrap();
        for i in 0..shape[0] {
            for j in 0..shape[1] {
                for k in 0..shape[2] {
                    assert_eq!(c[(i * shape[1] + j) * shape[2] + k], (i + 2 * j + 4 * k) as f64);
                }
            }
        }
    }

    #[test]
    fn malformed_files_are_errors() {
        let good = npy_bytes("x", &[2], &[1.0f64, 2.0]).unwrap();
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (b"not numpy".to_vec(), "magic"),
            (good[..good.len() - 3].to_vec(), "data bytes"),
            (foreign_file("<c16", false, "(1,)", &[0; 16]), "unsupported dtype"),
            (foreign_file("<f8", false, "(x,)", &[0; 8]), "bad dimension"),
            (foreign_file("<f8", false, "[1]", &[0; 8]), "not a tuple"),
        ];
        for (bytes, expected) in cases {
            let err = parse_npy("case.npy", &bytes).unwrap_err();
            assert!(err.to_string().contains(expected) && err.to_string().contains("case.npy"), "{err}");
        }
        let dict = "{'descr': [('x', '<f8')], 'fortran_order': False, 'shape': (1,), }\n";
        let mut structured = b"\x93NUMPY\x01\x00".to_vec();
        structured.extend_from_slice(&(dict.len() as u16).to_le_bytes());
        structured.extend_from_slice(dict.as_bytes());
        structured.extend_from_slice(&[0; 8]);
        let err = parse_npy("s.npy", &structured).unwrap_err();
        assert!(err.to_string().contains("structured"), "{err}");
    }
}
