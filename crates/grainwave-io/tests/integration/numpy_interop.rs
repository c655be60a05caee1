//! `.npy`, `.npz` and series files checked by NumPy itself, and NumPy's files read back here.
//!
//! Each test skips (with a message on standard error) when `python3 -c 'import numpy'` fails;
//! `.ci/run` installs numpy so that they run in CI.

use crate::common;

use common::{hex, python_with, run_python, scratch_dir};
use grainwave_io::{read_npy, write_npy, NpyArray, NpyData, NpyElement, Npz, NpzCompression, Series};
use serde_json::Value;
use std::collections::BTreeMap;

/// Prints, for every array of every `.npy`/`.npz` path given, its shape, dtype (as NumPy names
/// it) and its values as little-endian C-order bytes in hex — everything needed for a bit-exact
/// comparison without trusting any float formatting.
const DESCRIBE: &str = r#"
import json, sys
import numpy as np
out = {}
for path in sys.argv[1:]:
    loaded = np.load(path, allow_pickle=False)
    items = loaded.items() if hasattr(loaded, "files") else [("", loaded)]
    for name, a in items:
        le = np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<"))
        out[path + ":" + name] = {"shape": list(a.shape), "dtype": a.dtype.name, "hex": le.tobytes().hex()}
print(json.dumps(out))
"#;

fn describe(exe: &str, paths: &[&std::path::Path]) -> BTreeMap<String, Value> {
    serde_json::from_str(&run_python(exe, DESCRIBE, paths)).expect("python prints JSON")
}

fn expect<T: NpyElement>(found: &Value, shape: &[usize], dtype: &str, values: &[T]) {
    let mut bytes = Vec::new();
    T::extend_le(values, &mut bytes);
    assert_eq!(found["shape"], serde_json::json!(shape), "{found}");
    assert_eq!(found["dtype"], dtype, "{found}");
    assert_eq!(found["hex"], hex(&bytes), "values differ: {found}");
}

#[test]
fn numpy_loads_npy_files_with_right_shapes_dtypes_and_values() {
    let Some(py) = python_with(&["numpy"]) else { return };
    let dir = scratch_dir("numpy-npy");
    let f64s: Vec<f64> = (0..12).map(|k| (k as f64 * 0.7).sin() / 3.0).chain([f64::NAN, -0.0, 1e-310, f64::INFINITY]).collect();
    let i64s = vec![i64::MIN, -3, 0, 5, i64::MAX, 1 << 60];
    let i32s = vec![-7i32, 0, i32::MAX];
    let u32s = vec![0u32, 1, 300, u32::MAX];
    let f32s = vec![0.1f32, -2.5, f32::MIN_POSITIVE];
    let u8s = vec![0u8, 128, 255];
    let bools = vec![true, false, false, true];
    type Writer<'a> = Box<dyn Fn(&std::path::Path) + 'a>;
    let cases: Vec<(&str, Writer)> = vec![
        ("f64_4x2x2", Box::new(|p| write_npy(p, &[4, 2, 2], &f64s).unwrap())),
        ("i64_3x2", Box::new(|p| write_npy(p, &[3, 2], &i64s).unwrap())),
        ("i32", Box::new(|p| write_npy(p, &[3], &i32s).unwrap())),
        ("u32_2x2", Box::new(|p| write_npy(p, &[2, 2], &u32s).unwrap())),
        ("f32", Box::new(|p| write_npy(p, &[3], &f32s).unwrap())),
        ("u8", Box::new(|p| write_npy(p, &[1, 3], &u8s).unwrap())),
        ("bool", Box::new(|p| write_npy(p, &[4], &bools).unwrap())),
        ("scalar", Box::new(|p| write_npy(p, &[], &[2.5f64]).unwrap())),
        ("empty", Box::new(|p| write_npy::<f64>(p, &[0, 3], &[]).unwrap())),
    ];
    let paths: Vec<_> = cases.iter().map(|(name, _)| dir.join(format!("{name}.npy"))).collect();
    for ((_, write), path) in cases.iter().zip(&paths) {
        write(path);
    }
    let refs: Vec<&std::path::Path> = paths.iter().map(|p| p.as_path()).collect();
    let found = describe(&py, &refs);
    let get = |name: &str| &found[&format!("{}:", dir.join(format!("{name}.npy")).display())];
    expect(get("f64_4x2x2"), &[4, 2, 2], "float64", &f64s);
    expect(get("i64_3x2"), &[3, 2], "int64", &i64s);
    expect(get("i32"), &[3], "int32", &i32s);
    expect(get("u32_2x2"), &[2, 2], "uint32", &u32s);
    expect(get("f32"), &[3], "float32", &f32s);
    expect(get("u8"), &[1, 3], "uint8", &u8s);
    expect(get("bool"), &[4], "bool", &bools);
    expect(get("scalar"), &[], "float64", &[2.5f64]);
    expect::<f64>(get("empty"), &[0, 3], "float64", &[]);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn numpy_loads_npz_archives_and_series() {
    let Some(py) = python_with(&["numpy"]) else { return };
    let dir = scratch_dir("numpy-npz");
    let mut npz = Npz::new();
    let pos: Vec<f64> = (0..30).map(|k| k as f64 / 7.0).collect();
    npz.push_values("positions", &[10, 3], pos.clone()).unwrap();
    npz.push_values("ids", &[10], (0..10i64).collect()).unwrap();
    npz.push_values("sliding", &[2, 5], (0..10).map(|k| k % 3 == 0).collect()).unwrap();
    npz.write(&dir.join("stored.npz"), NpzCompression::Stored).unwrap();
    npz.write(&dir.join("deflated.npz"), NpzCompression::Deflated).unwrap();
    let mut series = Series::new(["t", "kinetic_energy"]).unwrap();
    for k in 0..50 {
        let t = k as f64 * 0.01;
        series.push_row(&[t, 0.5 * (-t / 0.3).exp()]).unwrap();
    }
    let files = series.write(&dir, "energy").unwrap();
    let found = describe(&py, &[&dir.join("stored.npz"), &dir.join("deflated.npz"), &files.npz]);
    for archive in ["stored.npz", "deflated.npz"] {
        let key = |name: &str| format!("{}:{name}", dir.join(archive).display());
        expect(&found[&key("positions")], &[10, 3], "float64", &pos);
        expect(&found[&key("ids")], &[10], "int64", &(0..10i64).collect::<Vec<_>>());
        expect(&found[&key("sliding")], &[2, 5], "bool", &(0..10).map(|k| k % 3 == 0).collect::<Vec<_>>());
    }
    for name in ["t", "kinetic_energy"] {
        expect(&found[&format!("{}:{name}", files.npz.display())], &[50], "float64", series.column(name).unwrap());
    }
    // The CSV twin loads with numpy too, names from the header.
    let script = "import sys, numpy as np; a = np.genfromtxt(sys.argv[1], delimiter=',', names=True); print(a.dtype.names, len(a), repr(float(a['kinetic_energy'][7])))";
    let out = run_python(&py, script, &[&files.csv]);
    assert_eq!(out.trim(), format!("('t', 'kinetic_energy') 50 {:?}", series.column("kinetic_energy").unwrap()[7]));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn files_written_by_numpy_are_read_here() {
    let Some(py) = python_with(&["numpy"]) else { return };
    let dir = scratch_dir("numpy-written");
    let script = r#"
import sys, os
import numpy as np
d = sys.argv[1]
a = np.arange(24, dtype=np.float64).reshape(2, 3, 4) / 7.0
np.save(os.path.join(d, "c.npy"), a)
np.save(os.path.join(d, "fortran.npy"), np.asfortranarray(a))
np.save(os.path.join(d, "big.npy"), np.arange(6, dtype=">i8").reshape(3, 2) - 2)
np.save(os.path.join(d, "f4.npy"), np.array([0.5, -1.25], dtype=np.float32))
np.savez(os.path.join(d, "plain.npz"), t=np.linspace(0, 1, 5), n=np.array([3, 1, 4], dtype=np.int64))
np.savez_compressed(os.path.join(d, "packed.npz"), t=np.linspace(0, 1, 5), mask=np.array([True, False]))
"#;
    run_python(&py, script, &[&dir]);
    let expected: Vec<f64> = (0..24).map(|k| k as f64 / 7.0).collect();
    for name in ["c.npy", "fortran.npy"] {
        let a = read_npy(&dir.join(name)).unwrap();
        assert_eq!(a.shape(), [2, 3, 4], "{name}");
        assert_eq!(a.as_f64().unwrap(), expected, "{name}: C order after reading");
    }
    let big = read_npy(&dir.join("big.npy")).unwrap();
    assert_eq!((big.shape(), big.as_i64().unwrap()), (&[3usize, 2][..], &[-2i64, -1, 0, 1, 2, 3][..]));
    assert_eq!(read_npy(&dir.join("f4.npy")).unwrap().data(), &NpyData::F32(vec![0.5, -1.25]));
    let linspace: Vec<f64> = (0..5).map(|k| k as f64 * 0.25).collect();
    let plain = Npz::read(&dir.join("plain.npz")).unwrap();
    assert_eq!(plain.get("t").unwrap().as_f64().unwrap(), linspace);
    assert_eq!(plain.get("n").unwrap(), &NpyArray::new(&[3], vec![3i64, 1, 4]).unwrap());
    let packed = Npz::read(&dir.join("packed.npz")).unwrap();
    assert_eq!(packed.get("t").unwrap().as_f64().unwrap(), linspace);
    assert_eq!(packed.get("mask").unwrap().data(), &NpyData::Bool(vec![true, false]));
    std::fs::remove_dir_all(&dir).unwrap();
}
