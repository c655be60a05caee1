//! VTK files read back by independent readers: meshio (`.vtu`), VTK itself — the library inside
//! ParaView — (`.vtp` and `.vtu`), and a plain XML + base64 + NumPy decoder (`.vtp`).
//!
//! Each reader's test skips, with a message on standard error, when its Python package cannot be
//! imported; `.ci/run` installs them so that they run in CI.

use crate::common;

use common::{hex, periodic_pile, python_with, run_python, scratch_dir, settled_pile};
use grainwave_core::prelude::*;
use grainwave_io::vtk::{contacts_dataset, grains_dataset, write_contacts_vtp, write_contacts_vtu, write_grains_vtp, write_grains_vtu, PvdCollection, VtkCells, VtkDataSet, VtkValues};
use serde_json::Value;
use std::path::{Path, PathBuf};

/// Every script prints, per file: point count, point coordinates (hex of little-endian f64),
/// cell type and count, connectivity, and per array [components, dtype, hex of values], plus
/// the TimeValue field — one normalized description whatever the reader.
const MESHIO: &str = r#"
import sys, json
import numpy as np
import meshio
le = lambda a: np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<")).tobytes().hex()
desc = lambda a: [1 if a.ndim == 1 else int(a.shape[1]), a.dtype.name, le(a)]
out = {}
for path in sys.argv[1:]:
    m = meshio.read(path)
    assert len(m.cells) <= 1, m.cells
    block = m.cells[0] if m.cells else None
    out[path] = {
        "n_points": int(m.points.shape[0]),
        "points": le(m.points.astype(np.float64)),
        "cell_type": block.type if block else None,
        "n_cells": int(block.data.shape[0]) if block else 0,
        "connectivity": block.data.ravel().tolist() if block else [],
        "point_data": {k: desc(v) for k, v in m.point_data.items()},
        "cell_data": {k: desc(v[0]) for k, v in m.cell_data.items()},
        "time": float(np.asarray(m.field_data["TimeValue"]).ravel()[0]) if "TimeValue" in m.field_data else None,
    }
print(json.dumps(out))
"#;

const VTK: &str = r#"
import sys, json
import numpy as np
from vtkmodules.vtkIOXML import vtkXMLPolyDataReader, vtkXMLUnstructuredGridReader
from vtkmodules.util.numpy_support import vtk_to_numpy
le = lambda a: np.ascontiguousarray(a).astype(a.dtype.newbyteorder("<")).tobytes().hex()
def arrays(data):
    out = {}
    for k in range(data.GetNumberOfArrays()):
        a = data.GetArray(k)
        v = vtk_to_numpy(a)
        out[a.GetName()] = [a.GetNumberOfComponents(), v.dtype.name, le(v)]
    return out
out = {}
for path in sys.argv[1:]:
    poly = path.endswith(".vtp")
    r = vtkXMLPolyDataReader() if poly else vtkXMLUnstructuredGridReader()
    r.SetFileName(path)
    r.Update()
    assert r.GetErrorCode() == 0, r.GetErrorCode()
    o = r.GetOutput()
    if poly:
        verts = o.GetNumberOfVerts() > 0
        cells = o.GetVerts() if verts else o.GetLines()
        cell_type = "vertex" if verts else ("line" if o.GetNumberOfLines() > 0 else None)
        assert o.GetNumberOfPolys() == 0 and o.GetNumberOfStrips() == 0
    else:
        cells = o.GetCells()
        types = {o.GetCellType(k) for k in range(o.GetNumberOfCells())}
        assert len(types) <= 1, types
        cell_type = {1: "vertex", 3: "line"}[types.pop()] if types else None
    fd = o.GetFieldData().GetArray("TimeValue")
    out[path] = {
        "n_points": o.GetNumberOfPoints(),
        "points": le(vtk_to_numpy(o.GetPoints().GetData()).astype(np.float64)) if o.GetNumberOfPoints() else "",
        "cell_type": cell_type,
        "n_cells": o.GetNumberOfCells(),
        "connectivity": vtk_to_numpy(cells.GetConnectivityArray()).tolist(),
        "point_data": arrays(o.GetPointData()),
        "cell_data": arrays(o.GetCellData()),
        "time": fd.GetValue(0) if fd is not None else None,
    }
print(json.dumps(out))
"#;

/// Reads the XML with ElementTree and decodes each inline binary DataArray by hand
/// (base64 → 8-byte little-endian byte count → values), independent of any VTK library.
const PLAIN_XML: &str = r#"
import sys, json, base64
import numpy as np
import xml.etree.ElementTree as ET
types = {"Float64": "<f8", "Int64": "<i8", "Int32": "<i4", "UInt32": "<u4", "UInt8": "u1"}
def decode(da):
    assert da.get("format") == "binary"
    raw = base64.b64decode("".join(da.text.split()))
    n = int(np.frombuffer(raw[:8], "<u8")[0])
    assert n == len(raw) - 8, (n, len(raw))
    return np.frombuffer(raw[8:], types[da.get("type")])
def arrays(node):
    out = {}
    if node is not None:
        for da in node.findall("DataArray"):
            v = decode(da)
            out[da.get("Name")] = [int(da.get("NumberOfComponents")), v.dtype.name, v.tobytes().hex()]
    return out
out = {}
for path in sys.argv[1:]:
    root = ET.parse(path).getroot()
    assert root.get("type") == "PolyData" and root.get("header_type") == "UInt64" and root.get("byte_order") == "LittleEndian"
    grid = root.find("PolyData")
    piece = grid.find("Piece")
    verts, lines = int(piece.get("NumberOfVerts")), int(piece.get("NumberOfLines"))
    section = piece.find("Verts") if verts else piece.find("Lines")
    conn = {da.get("Name"): decode(da) for da in section.findall("DataArray")} if section is not None else {}
    offsets = conn.get("offsets", np.zeros(0, "<i8"))
    per = 1 if verts else 2
    assert (offsets == per * np.arange(1, len(offsets) + 1)).all()
    fd = grid.find("FieldData")
    time = float(decode(fd.find("DataArray"))[0]) if fd is not None else None
    out[path] = {
        "n_points": int(piece.get("NumberOfPoints")),
        "points": decode(piece.find("Points").find("DataArray")).tobytes().hex(),
        "cell_type": "vertex" if verts else ("line" if lines else None),
        "n_cells": verts + lines,
        "connectivity": conn.get("connectivity", np.zeros(0, "<i8")).tolist(),
        "point_data": arrays(piece.find("PointData")),
        "cell_data": arrays(piece.find("CellData")),
        "time": time,
    }
print(json.dumps(out))
"#;

fn values_desc(components: usize, values: &VtkValues) -> Value {
    let (dtype, bytes): (&str, Vec<u8>) = match values {
        VtkValues::Float64(v) => ("float64", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
        VtkValues::Int64(v) => ("int64", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
        VtkValues::Int32(v) => ("int32", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
        VtkValues::UInt32(v) => ("uint32", v.iter().flat_map(|x| x.to_le_bytes()).collect()),
        VtkValues::UInt8(v) => ("uint8", v.clone()),
    };
    serde_json::json!([components, dtype, hex(&bytes)])
}

/// Checks a reader's description of a file against the dataset that was written.
fn check(found: &Value, d: &VtkDataSet, what: &str) {
    let points: Vec<u8> = d.points().iter().flatten().flat_map(|x| x.to_le_bytes()).collect();
    assert_eq!(found["n_points"], d.points().len(), "{what}: point count");
    assert_eq!(found["points"], hex(&points), "{what}: coordinates");
    let (cell_type, connectivity): (&str, Vec<u64>) = match d.cells() {
        VtkCells::Vertices(v) => ("vertex", v.clone()),
        VtkCells::Lines(l) => ("line", l.iter().flatten().copied().collect()),
    };
    assert_eq!(found["n_cells"], d.cells().len(), "{what}: cell count");
    if !d.cells().is_empty() {
        assert_eq!(found["cell_type"], cell_type, "{what}: cell type");
    }
    assert_eq!(found["connectivity"], serde_json::json!(connectivity), "{what}: connectivity");
    for (kind, arrays) in [("point_data", d.point_data()), ("cell_data", d.cell_data())] {
        let names: Vec<&str> = found[kind].as_object().unwrap().keys().map(String::as_str).collect();
        assert_eq!(names.len(), arrays.len(), "{what}: {kind} names {names:?}");
        for a in arrays {
            assert_eq!(found[kind][&a.name], values_desc(a.components, &a.values), "{what}: {kind} `{}`", a.name);
        }
    }
    assert_eq!(found["time"], serde_json::json!(d.time()), "{what}: TimeValue");
}

/// Spot checks straight against the snapshot, not through the dataset.
fn check_against_snapshot(grains: &Value, contacts: &Value, s: &Snapshot<D2>, what: &str) {
    let f64_hex = |v: &[f64]| hex(&v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<_>>());
    assert_eq!(grains["n_points"], s.len(), "{what}");
    assert_eq!(grains["point_data"]["radius"], serde_json::json!([1, "float64", f64_hex(&s.radius)]), "{what}");
    let vel: Vec<f64> = s.vel.iter().flat_map(|v| [v.x, v.y, 0.0]).collect();
    assert_eq!(grains["point_data"]["velocity"], serde_json::json!([3, "float64", f64_hex(&vel)]), "{what}");
    let omega: Vec<f64> = s.omega.iter().flat_map(|&w| [0.0, 0.0, w]).collect();
    assert_eq!(grains["point_data"]["angular_velocity"][2], f64_hex(&omega), "{what}");
    assert_eq!(grains["point_data"]["id"][1], "int64", "{what}");
    assert_eq!(contacts["n_cells"], s.contacts.len(), "{what}");
    let fnorm: Vec<f64> = s.contacts.iter().map(|c| c.normal_force).collect();
    assert_eq!(contacts["cell_data"]["normal_force"][2], f64_hex(&fnorm), "{what}");
    let kn: Vec<f64> = s.contacts.iter().map(|c| c.normal_stiffness).collect();
    assert_eq!(contacts["cell_data"]["normal_stiffness"][2], f64_hex(&kn), "{what}");
    assert_eq!(contacts["cell_data"]["sliding"][1], "uint8", "{what}");
    assert_eq!(contacts["cell_data"]["wall"][1], "int32", "{what}");
    for name in ["tangential_force", "force", "normal"] {
        assert_eq!(contacts["cell_data"][name][0], 3, "{what}: {name} has 3 components");
    }
}

struct Files {
    dir: PathBuf,
    snapshots: Vec<(String, Snapshot<D2>)>,
    /// Leave out snapshots without contacts: meshio (5.3) cannot read a `.vtu` without cells.
    skip_empty: bool,
}

/// Writes grains and contacts of three snapshots (a periodic pile with wall contacts, a settled
/// pile, a lone grain without contacts) in both dataset types.
fn write_files(name: &str) -> Files {
    let dir = scratch_dir(name);
    let mut lone = periodic_pile();
    lone.id.truncate(1);
    lone.radius.truncate(1);
    lone.mass.truncate(1);
    lone.pos.truncate(1);
    lone.vel.truncate(1);
    lone.omega.truncate(1);
    lone.rotation.truncate(1);
    lone.force.truncate(1);
    lone.torque.truncate(1);
    lone.contacts.clear();
    let snapshots = vec![("periodic".to_string(), periodic_pile()), ("settled".to_string(), settled_pile()), ("lone".to_string(), lone)];
    for (stem, s) in &snapshots {
        write_grains_vtp(&dir.join(format!("{stem}_grains.vtp")), s).unwrap();
        write_contacts_vtp(&dir.join(format!("{stem}_contacts.vtp")), s).unwrap();
        write_grains_vtu(&dir.join(format!("{stem}_grains.vtu")), s).unwrap();
        write_contacts_vtu(&dir.join(format!("{stem}_contacts.vtu")), s).unwrap();
    }
    Files { dir, snapshots, skip_empty: false }
}

fn read_all(py: &str, script: &str, files: &Files, extension: &str) -> Value {
    let paths: Vec<PathBuf> = files
        .snapshots
        .iter()
        .filter(|(_, s)| !files.skip_empty || !s.contacts.is_empty())
        .flat_map(|(stem, _)| ["grains", "contacts"].map(|kind| files.dir.join(format!("{stem}_{kind}.{extension}"))))
        .collect();
    let refs: Vec<&Path> = paths.iter().map(PathBuf::as_path).collect();
    serde_json::from_str(&run_python(py, script, &refs)).unwrap()
}

fn check_all(found: &Value, files: &Files, extension: &str, reader: &str) {
    for (stem, s) in files.snapshots.iter().filter(|(_, s)| !files.skip_empty || !s.contacts.is_empty()) {
        let key = |kind: &str| files.dir.join(format!("{stem}_{kind}.{extension}")).display().to_string();
        let (g, c) = (&found[key("grains")], &found[key("contacts")]);
        check(g, &grains_dataset(s).unwrap(), &format!("{reader}: {stem} grains"));
        check(c, &contacts_dataset(s).unwrap(), &format!("{reader}: {stem} contacts"));
        check_against_snapshot(g, c, s, &format!("{reader}: {stem}"));
    }
    // The periodic pile: 4 contacts drawn with 3 extra points (one periodic image, two on the floor).
    let periodic = &found[files.dir.join(format!("periodic_contacts.{extension}")).display().to_string()];
    assert_eq!((periodic["n_points"].as_u64(), periodic["n_cells"].as_u64()), (Some(6), Some(4)), "{reader}");
}

#[test]
fn meshio_reads_grains_and_contacts_vtu() {
    let Some(py) = python_with(&["numpy", "meshio"]) else { return };
    let mut files = write_files("meshio");
    files.skip_empty = true;
    let found = read_all(&py, MESHIO, &files, "vtu");
    check_all(&found, &files, "vtu", "meshio");
    std::fs::remove_dir_all(&files.dir).unwrap();
}

#[test]
fn vtk_library_reads_vtp_and_vtu() {
    let Some(py) = python_with(&["numpy", "vtkmodules.vtkIOXML"]) else { return };
    let files = write_files("vtk");
    for extension in ["vtp", "vtu"] {
        let found = read_all(&py, VTK, &files, extension);
        check_all(&found, &files, extension, &format!("vtk ({extension})"));
    }
    std::fs::remove_dir_all(&files.dir).unwrap();
}

#[test]
fn plain_xml_decoder_reads_vtp() {
    let Some(py) = python_with(&["numpy"]) else { return };
    let files = write_files("xml");
    let found = read_all(&py, PLAIN_XML, &files, "vtp");
    check_all(&found, &files, "vtp", "xml+numpy");
    std::fs::remove_dir_all(&files.dir).unwrap();
}

#[test]
fn pvd_collection_lists_snapshot_files() {
    let Some(py) = python_with(&["numpy"]) else { return };
    let dir = scratch_dir("pvd-it");
    let s = periodic_pile();
    let mut pvd = PvdCollection::new();
    for k in 0..3 {
        let file = format!("snapshots/grains_{k:06}.vtp");
        write_grains_vtp(&dir.join(&file), &s).unwrap();
        pvd.push(0.5 * k as f64, file).unwrap();
    }
    pvd.write(&dir.join("grains.pvd")).unwrap();
    let script = r#"
import sys, os
import xml.etree.ElementTree as ET
root = ET.parse(sys.argv[1]).getroot()
assert root.get("type") == "Collection"
for ds in root.find("Collection").findall("DataSet"):
    path = os.path.join(os.path.dirname(sys.argv[1]), ds.get("file"))
    print(ds.get("timestep"), ds.get("part"), os.path.exists(path))
"#;
    let out = run_python(&py, script, &[&dir.join("grains.pvd")]);
    assert_eq!(out, "0.0 0 True\n0.5 0 True\n1.0 0 True\n");
    std::fs::remove_dir_all(&dir).unwrap();
}
