//! A point-and-cell dataset and its VTK XML serialization (PolyData `.vtp` or UnstructuredGrid `.vtu`).

use crate::error::{OutputError, Result};
use grainwave_core::checkpoint::atomic_write;
use std::fmt::Write as _;
use std::path::Path;

/// The VTK XML dataset type of a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VtkFormat {
    /// `vtkPolyData`, extension `.vtp`: vertices and lines as `Verts` and `Lines`.
    PolyData,
    /// `vtkUnstructuredGrid`, extension `.vtu`: vertices (`VTK_VERTEX` = 1) and lines
    /// (`VTK_LINE` = 3) as `Cells`. This is the type `meshio` reads.
    UnstructuredGrid,
}

impl VtkFormat {
    /// The file extension without the dot (`vtp` or `vtu`).
    pub fn extension(self) -> &'static str {
        match self {
            VtkFormat::PolyData => "vtp",
            VtkFormat::UnstructuredGrid => "vtu",
        }
    }

    /// The format that matches the extension of `path` (`.vtp` or `.vtu`, any case).
    pub fn from_path(path: &Path) -> Result<Self> {
        match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
            Some("vtp") => Ok(VtkFormat::PolyData),
            Some("vtu") => Ok(VtkFormat::UnstructuredGrid),
            _ => Err(OutputError::VtkExtension {
                path: path.display().to_string(),
                reason: "the name must end in `.vtp` (PolyData) or `.vtu` (UnstructuredGrid)".into(),
            }),
        }
    }

    fn type_name(self) -> &'static str {
        match self {
            VtkFormat::PolyData => "PolyData",
            VtkFormat::UnstructuredGrid => "UnstructuredGrid",
        }
    }
}

/// The values of a data array, tuple after tuple (component fastest).
#[derive(Clone, Debug, PartialEq)]
pub enum VtkValues {
    /// VTK `Float64`.
    Float64(Vec<f64>),
    /// VTK `Int64`.
    Int64(Vec<i64>),
    /// VTK `Int32`.
    Int32(Vec<i32>),
    /// VTK `UInt32`.
    UInt32(Vec<u32>),
    /// VTK `UInt8` (flags: 0 or 1).
    UInt8(Vec<u8>),
}

impl VtkValues {
    /// Number of values (tuples × components).
    pub fn len(&self) -> usize {
        match self {
            VtkValues::Float64(v) => v.len(),
            VtkValues::Int64(v) => v.len(),
            VtkValues::Int32(v) => v.len(),
            VtkValues::UInt32(v) => v.len(),
            VtkValues::UInt8(v) => v.len(),
        }
    }

    /// True when there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    fn type_name(&self) -> &'static str {
        match self {
            VtkValues::Float64(_) => "Float64",
            VtkValues::Int64(_) => "Int64",
            VtkValues::Int32(_) => "Int32",
            VtkValues::UInt32(_) => "UInt32",
            VtkValues::UInt8(_) => "UInt8",
        }
    }

    fn le_bytes(&self) -> Vec<u8> {
        fn collect<const N: usize, T: Copy>(v: &[T], f: impl Fn(T) -> [u8; N]) -> Vec<u8> {
            v.iter().flat_map(|&x| f(x)).collect()
        }
        match self {
            VtkValues::Float64(v) => collect(v, f64::to_le_bytes),
            VtkValues::Int64(v) => collect(v, i64::to_le_bytes),
            VtkValues::Int32(v) => collect(v, i32::to_le_bytes),
            VtkValues::UInt32(v) => collect(v, u32::to_le_bytes),
            VtkValues::UInt8(v) => v.clone(),
        }
    }
}

/// A named data array attached to points or cells: `components` values per point or cell.
#[derive(Clone, Debug, PartialEq)]
pub struct VtkArray {
    /// Name shown in ParaView and used as key by meshio.
    pub name: String,
    /// Values per tuple (1 for scalars, 3 for vectors).
    pub components: usize,
    /// The values, tuple after tuple.
    pub values: VtkValues,
}

/// The cells of a dataset: all vertices or all lines (the two kinds grainwave writes).
#[derive(Clone, Debug, PartialEq)]
pub enum VtkCells {
    /// One vertex cell per entry, holding that point index.
    Vertices(Vec<u64>),
    /// One line cell per entry, from the first point index to the second.
    Lines(Vec<[u64; 2]>),
}

impl VtkCells {
    /// Number of cells.
    pub fn len(&self) -> usize {
        match self {
            VtkCells::Vertices(v) => v.len(),
            VtkCells::Lines(l) => l.len(),
        }
    }

    /// True when there are no cells.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Point indices of all cells, concatenated (VTK's `connectivity`).
    fn connectivity(&self) -> Vec<i64> {
        match self {
            VtkCells::Vertices(v) => v.iter().map(|&p| p as i64).collect(),
            VtkCells::Lines(l) => l.iter().flat_map(|&[a, b]| [a as i64, b as i64]).collect(),
        }
    }

    /// End of each cell in the connectivity (VTK's `offsets`).
    fn offsets(&self) -> Vec<i64> {
        let per_cell = match self {
            VtkCells::Vertices(_) => 1,
            VtkCells::Lines(_) => 2,
        };
        (1..=self.len() as i64).map(|k| k * per_cell).collect()
    }

    fn vtk_type(&self) -> u8 {
        match self {
            VtkCells::Vertices(_) => 1,
            VtkCells::Lines(_) => 3,
        }
    }

    fn max_index(&self) -> Option<u64> {
        match self {
            VtkCells::Vertices(v) => v.iter().copied().max(),
            VtkCells::Lines(l) => l.iter().flat_map(|c| c.iter().copied()).max(),
        }
    }
}

/// Points in 3D, cells over them (vertices or lines), and named arrays on points and cells —
/// everything a grainwave VTK file holds.
///
/// Serialization ([`VtkDataSet::to_xml`]): VTK XML file format version 1.0, `byte_order =
/// "LittleEndian"`, `header_type = "UInt64"`, every `DataArray` inline in `format = "binary"`
/// (base64 of an 8-byte little-endian byte count followed by the raw little-endian values), so
/// values are stored bit for bit. The simulated time, if set, is stored as the field-data array
/// `TimeValue` (one `Float64`), which ParaView uses as the time of the file.
///
/// Experiments add their own per-grain or per-contact fields to the datasets made by
/// [`grains_dataset`](crate::vtk::grains_dataset) and
/// [`contacts_dataset`](crate::vtk::contacts_dataset) with [`push_point_data`](Self::push_point_data)
/// and [`push_cell_data`](Self::push_cell_data).
#[derive(Clone, Debug, PartialEq)]
pub struct VtkDataSet {
    points: Vec<[f64; 3]>,
    cells: VtkCells,
    point_data: Vec<VtkArray>,
    cell_data: Vec<VtkArray>,
    time: Option<f64>,
}

fn check_array(kind: &str, arrays: &[VtkArray], name: &str, components: usize, values: &VtkValues, tuples: usize) -> Result<()> {
    if name.is_empty() || name.contains(['<', '>', '&', '"', '\'']) {
        return Err(OutputError::Name { name: name.to_string(), reason: "VTK array names must be non-empty and free of < > & \" '".into() });
    }
    if arrays.iter().any(|a| a.name == name) {
        return Err(OutputError::Name { name: name.to_string(), reason: format!("the dataset already has {kind} data of that name") });
    }
    if components == 0 || values.len() != tuples * components {
        return Err(OutputError::Length {
            what: format!("{kind} data `{name}` ({tuples} tuples of {components} components)"),
            expected: tuples * components,
            len: values.len(),
        });
    }
    Ok(())
}

impl VtkDataSet {
    /// A dataset of `points` and `cells`; fails if a cell refers to a point that does not exist.
    pub fn new(points: Vec<[f64; 3]>, cells: VtkCells) -> Result<Self> {
        if let Some(max) = cells.max_index() {
            if max >= points.len() as u64 {
                return Err(OutputError::Length { what: format!("points of a VTK dataset whose cells use point index {max}"), expected: max as usize + 1, len: points.len() });
            }
        }
        Ok(VtkDataSet { points, cells, point_data: Vec::new(), cell_data: Vec::new(), time: None })
    }

    /// Sets the simulated time stored as `TimeValue`.
    pub fn set_time(&mut self, time: f64) {
        self.time = Some(time);
    }

    /// The simulated time, if set.
    pub fn time(&self) -> Option<f64> {
        self.time
    }

    /// Adds a point array of `components` values per point (`values.len()` must be
    /// `components × points`); names must be unique among the point arrays.
    pub fn push_point_data(&mut self, name: impl Into<String>, components: usize, values: VtkValues) -> Result<()> {
        let name = name.into();
        check_array("point", &self.point_data, &name, components, &values, self.points.len())?;
        self.point_data.push(VtkArray { name, components, values });
        Ok(())
    }

    /// Adds a cell array of `components` values per cell (`values.len()` must be
    /// `components × cells`); names must be unique among the cell arrays.
    pub fn push_cell_data(&mut self, name: impl Into<String>, components: usize, values: VtkValues) -> Result<()> {
        let name = name.into();
        check_array("cell", &self.cell_data, &name, components, &values, self.cells.len())?;
        self.cell_data.push(VtkArray { name, components, values });
        Ok(())
    }

    /// The points (x, y, z).
    pub fn points(&self) -> &[[f64; 3]] {
        &self.points
    }

    /// The cells.
    pub fn cells(&self) -> &VtkCells {
        &self.cells
    }

    /// The point arrays, in order.
    pub fn point_data(&self) -> &[VtkArray] {
        &self.point_data
    }

    /// The cell arrays, in order.
    pub fn cell_data(&self) -> &[VtkArray] {
        &self.cell_data
    }

    /// The complete XML file of the given dataset type.
    pub fn to_xml(&self, format: VtkFormat) -> String {
        let mut x = String::with_capacity(64 + 12 * 8 * (self.points.len() * 8 + self.cells.len() * 8));
        let w = &mut x;
        let kind = format.type_name();
        w.push_str("<?xml version=\"1.0\"?>\n");
        let _ = writeln!(w, "<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">");
        let _ = writeln!(w, "  <{kind}>");
        if let Some(t) = self.time {
            w.push_str("    <FieldData>\n");
            data_array(w, 6, "TimeValue", 1, &VtkValues::Float64(vec![t]), Some(1));
            w.push_str("    </FieldData>\n");
        }
        let (np, nc) = (self.points.len(), self.cells.len());
        match format {
            VtkFormat::PolyData => {
                let (verts, lines) = match self.cells {
                    VtkCells::Vertices(_) => (nc, 0),
                    VtkCells::Lines(_) => (0, nc),
                };
                let _ = writeln!(
                    w,
                    "    <Piece NumberOfPoints=\"{np}\" NumberOfVerts=\"{verts}\" NumberOfLines=\"{lines}\" NumberOfStrips=\"0\" NumberOfPolys=\"0\">"
                );
            }
            VtkFormat::UnstructuredGrid => {
                let _ = writeln!(w, "    <Piece NumberOfPoints=\"{np}\" NumberOfCells=\"{nc}\">");
            }
        }
        attribute_block(w, "PointData", &self.point_data);
        attribute_block(w, "CellData", &self.cell_data);
        w.push_str("      <Points>\n");
        let coords: Vec<f64> = self.points.iter().flatten().copied().collect();
        data_array(w, 8, "Points", 3, &VtkValues::Float64(coords), None);
        w.push_str("      </Points>\n");
        let connectivity = VtkValues::Int64(self.cells.connectivity());
        let offsets = VtkValues::Int64(self.cells.offsets());
        match format {
            VtkFormat::PolyData => {
                let section = match self.cells {
                    VtkCells::Vertices(_) => "Verts",
                    VtkCells::Lines(_) => "Lines",
                };
                let _ = writeln!(w, "      <{section}>");
                data_array(w, 8, "connectivity", 1, &connectivity, None);
                data_array(w, 8, "offsets", 1, &offsets, None);
                let _ = writeln!(w, "      </{section}>");
            }
            VtkFormat::UnstructuredGrid => {
                w.push_str("      <Cells>\n");
                data_array(w, 8, "connectivity", 1, &connectivity, None);
                data_array(w, 8, "offsets", 1, &offsets, None);
                data_array(w, 8, "types", 1, &VtkValues::UInt8(vec![self.cells.vtk_type(); nc]), None);
                w.push_str("      </Cells>\n");
            }
        }
        w.push_str("    </Piece>\n");
        let _ = writeln!(w, "  </{kind}>");
        w.push_str("</VTKFile>\n");
        x
    }

    /// Writes the dataset to `path`, atomically (parent directories are created), as PolyData
    /// if the name ends in `.vtp` and as UnstructuredGrid if it ends in `.vtu`; any other
    /// extension is an error.
    pub fn write(&self, path: &Path) -> Result<()> {
        let format = VtkFormat::from_path(path)?;
        atomic_write(path, self.to_xml(format).as_bytes())?;
        Ok(())
    }

    /// Writes the dataset to `path` as `format`, atomically; refuses a name whose extension is
    /// not the one of `format` (ParaView picks its reader by extension).
    pub fn write_as(&self, path: &Path, format: VtkFormat) -> Result<()> {
        if VtkFormat::from_path(path).ok() != Some(format) {
            return Err(OutputError::VtkExtension {
                path: path.display().to_string(),
                reason: format!("a {} file name must end in `.{}`", format.type_name(), format.extension()),
            });
        }
        self.write(path)
    }
}

/// `<PointData>` or `<CellData>` with ParaView's default scalars/vectors set to the first
/// scalar and first 3-component array.
fn attribute_block(w: &mut String, tag: &str, arrays: &[VtkArray]) {
    if arrays.is_empty() {
        return;
    }
    let _ = write!(w, "      <{tag}");
    if let Some(a) = arrays.iter().find(|a| a.components == 1) {
        let _ = write!(w, " Scalars=\"{}\"", a.name);
    }
    if let Some(a) = arrays.iter().find(|a| a.components == 3) {
        let _ = write!(w, " Vectors=\"{}\"", a.name);
    }
    w.push_str(">\n");
    for a in arrays {
        data_array(w, 8, &a.name, a.components, &a.values, None);
    }
    let _ = writeln!(w, "      </{tag}>");
}

fn data_array(w: &mut String, indent: usize, name: &str, components: usize, values: &VtkValues, tuples: Option<usize>) {
    let _ = write!(w, "{:indent$}<DataArray type=\"{}\" Name=\"{name}\" NumberOfComponents=\"{components}\"", "", values.type_name());
    if let Some(n) = tuples {
        let _ = write!(w, " NumberOfTuples=\"{n}\"");
    }
    w.push_str(" format=\"binary\">\n");
    let body = values.le_bytes();
    let mut block = Vec::with_capacity(8 + body.len());
    block.extend_from_slice(&(body.len() as u64).to_le_bytes());
    block.extend_from_slice(&body);
    let _ = write!(w, "{:width$}", "", width = indent + 2);
    base64_encode(&block, w);
    let _ = writeln!(w, "\n{:indent$}</DataArray>", "");
}

const BASE64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

/// Standard base64 (RFC 4648, with `=` padding), appended to `out`.
pub(crate) fn base64_encode(bytes: &[u8], out: &mut String) {
    out.reserve(bytes.len().div_ceil(3) * 4);
    for chunk in bytes.chunks(3) {
        let b = [chunk[0], chunk.get(1).copied().unwrap_or(0), chunk.get(2).copied().unwrap_or(0)];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        let sextets = [(n >> 18) & 63, (n >> 12) & 63, (n >> 6) & 63, n & 63];
        for (k, s) in sextets.iter().enumerate() {
            out.push(if k <= chunk.len() { BASE64[*s as usize] as char } else { '=' });
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Independent decoder for checking files: standard alphabet, padding, white space ignored.
    pub(crate) fn base64_decode(text: &str) -> Vec<u8> {
        let value = |c: u8| match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => panic!("not base64: {c}"),
        };
        let clean: Vec<u8> = text.bytes().filter(|c| !c.is_ascii_whitespace()).collect();
        assert_eq!(clean.len() % 4, 0);
        let mut out = Vec::new();
        for quad in clean.chunks(4) {
            let pad = quad.iter().filter(|&&c| c == b'=').count();
            let n = quad.iter().take(4 - pad).enumerate().fold(0u32, |n, (k, &c)| n | (u32::from(value(c)) << (18 - 6 * k)));
            out.extend_from_slice(&[(n >> 16) as u8, (n >> 8) as u8, n as u8][..3 - pad]);
        }
        out
    }

    /// The decoded payload (without the 8-byte length header) of the `DataArray` called `name`
    /// inside section `section` (e.g. `PointData`), checking the header.
    pub(crate) fn array_bytes(xml: &str, section: &str, name: &str) -> Vec<u8> {
        let start = xml.find(&format!("<{section}")).unwrap_or_else(|| panic!("no <{section}>"));
        let end = start + xml[start..].find(&format!("</{section}>")).unwrap();
        let part = &xml[start..end];
        let tag = part.find(&format!("Name=\"{name}\"")).unwrap_or_else(|| panic!("no array {name} in {section}"));
        let open = tag + part[tag..].find('>').unwrap() + 1;
        let close = open + part[open..].find("</DataArray>").unwrap();
        let bytes = base64_decode(&part[open..close]);
        let n = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
        assert_eq!(n, bytes.len() - 8, "header byte count of {name}");
        bytes[8..].to_vec()
    }

    pub(crate) fn f64s(bytes: &[u8]) -> Vec<f64> {
        bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap())).collect()
    }

    pub(crate) fn i64s(bytes: &[u8]) -> Vec<i64> {
        bytes.chunks_exact(8).map(|c| i64::from_le_bytes(c.try_into().unwrap())).collect()
    }

    #[test]
    fn base64_matches_rfc_4648_vectors() {
        for (plain, encoded) in [("", ""), ("f", "Zg=="), ("fo", "Zm8="), ("foo", "Zm9v"), ("foob", "Zm9vYg=="), ("fooba", "Zm9vYmE="), ("foobar", "Zm9vYmFy")] {
            let mut s = String::new();
            base64_encode(plain.as_bytes(), &mut s);
            assert_eq!(s, encoded);
            assert_eq!(base64_decode(&s), plain.as_bytes());
        }
        let all: Vec<u8> = (0..=255).collect();
        let mut s = String::new();
        base64_encode(&all, &mut s);
        assert_eq!(base64_decode(&s), all);
    }

    #[test]
    fn both_formats_carry_the_same_arrays() {
        let mut d = VtkDataSet::new(vec![[0.0, 1.0, 2.0], [3.5, -1.0, 0.0], [1e-300, 0.0, 7.0]], VtkCells::Lines(vec![[0, 1], [1, 2]])).unwrap();
        d.set_time(0.125);
        d.push_cell_data("force", 3, VtkValues::Float64(vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0])).unwrap();
        d.push_cell_data("sliding", 1, VtkValues::UInt8(vec![0, 1])).unwrap();
        d.push_point_data("id", 1, VtkValues::Int64(vec![5, 6, -1])).unwrap();
        for format in [VtkFormat::PolyData, VtkFormat::UnstructuredGrid] {
            let xml = d.to_xml(format);
            assert!(xml.starts_with("<?xml version=\"1.0\"?>\n<VTKFile type=\""), "{xml}");
            assert_eq!(f64s(&array_bytes(&xml, "Points", "Points")), [0.0, 1.0, 2.0, 3.5, -1.0, 0.0, 1e-300, 0.0, 7.0]);
            assert_eq!(f64s(&array_bytes(&xml, "CellData", "force")), [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
            assert_eq!(array_bytes(&xml, "CellData", "sliding"), [0, 1]);
            assert_eq!(i64s(&array_bytes(&xml, "PointData", "id")), [5, 6, -1]);
            assert_eq!(f64s(&array_bytes(&xml, "FieldData", "TimeValue")), [0.125]);
            let cells = if format == VtkFormat::PolyData { "Lines" } else { "Cells" };
            assert_eq!(i64s(&array_bytes(&xml, cells, "connectivity")), [0, 1, 1, 2]);
            assert_eq!(i64s(&array_bytes(&xml, cells, "offsets")), [2, 4]);
            if format == VtkFormat::UnstructuredGrid {
                assert_eq!(array_bytes(&xml, "Cells", "types"), [3, 3]);
                assert!(xml.contains("<Piece NumberOfPoints=\"3\" NumberOfCells=\"2\">"));
            } else {
                assert!(xml.contains("NumberOfVerts=\"0\" NumberOfLines=\"2\""));
            }
        }
    }

    #[test]
    fn inconsistent_datasets_are_refused() {
        assert!(VtkDataSet::new(vec![[0.0; 3]], VtkCells::Lines(vec![[0, 1]])).is_err());
        let mut d = VtkDataSet::new(vec![[0.0; 3]; 2], VtkCells::Vertices(vec![0, 1])).unwrap();
        assert!(d.push_point_data("v", 3, VtkValues::Float64(vec![0.0; 5])).is_err());
        d.push_point_data("v", 3, VtkValues::Float64(vec![0.0; 6])).unwrap();
        assert!(matches!(d.push_point_data("v", 1, VtkValues::Float64(vec![0.0; 2])), Err(OutputError::Name { .. })));
        assert!(d.push_cell_data("a<b", 1, VtkValues::Int32(vec![0; 2])).is_err());
        assert!(matches!(d.write(Path::new("/tmp/x.vtk")), Err(OutputError::VtkExtension { .. })));
        let err = d.write_as(Path::new("/tmp/x.vtu"), VtkFormat::PolyData).unwrap_err();
        assert!(err.to_string().contains("must end in `.vtp`"), "{err}");
    }
}
