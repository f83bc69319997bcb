//! MATLAB's MAT-file format, level 5 (what `save` writes by default, `-v7`, and `-v6`):
//! a 128-byte header (text, version 0x0100, the endian mark `IM`), then data elements,
//! each a tag (type, byte count, or the packed small form) and its data padded to 8 bytes.
//! A variable is an `miMATRIX` element (array flags, dimensions, name, real part), possibly
//! inside an `miCOMPRESSED` (zlib) element.
//!
//! Read here: numeric arrays of every class (as f64), logical, and character arrays;
//! cells, structs, sparse and complex arrays are listed by name and class but not decoded.
//! Written here: double matrices and character rows, and cell rows of text (names), which
//! MATLAB's `load` and SciPy's `loadmat` read. Version 7.3 files are HDF5, another format
//! (no maintained pure-Rust reader is cheap enough to build on two cores): refused with
//! that said.

use std::io::Read as _;

/// A variable's contents.
#[derive(Debug, Clone, PartialEq)]
pub enum Data {
    /// A real numeric or logical array, column-major (MATLAB's order), as f64.
    Numeric(Vec<f64>),
    /// A character array (one row, or rows joined by newlines).
    Text(String),
    /// A row of texts (a cell array of character rows).
    Texts(Vec<String>),
    /// A class this reader does not decode, by MATLAB's name for it.
    Other(&'static str),
}

/// One variable.
#[derive(Debug, Clone, PartialEq)]
pub struct Variable {
    /// The variable's name.
    pub name: String,
    /// Dimensions (rows, columns, ...).
    pub dims: Vec<usize>,
    /// Its values.
    pub data: Data,
}

/// Where a file breaks the format.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("byte {offset}: {message}")]
pub struct MatError {
    /// Byte offset of the fault.
    pub offset: usize,
    /// What was wrong there.
    pub message: String,
}

fn err<T>(offset: usize, message: impl Into<String>) -> Result<T, MatError> {
    Err(MatError {
        offset,
        message: message.into(),
    })
}

// Data types of elements.
const MI_INT8: u32 = 1;
const MI_UINT8: u32 = 2;
const MI_INT16: u32 = 3;
const MI_UINT16: u32 = 4;
const MI_INT32: u32 = 5;
const MI_UINT32: u32 = 6;
const MI_SINGLE: u32 = 7;
const MI_DOUBLE: u32 = 9;
const MI_INT64: u32 = 12;
const MI_UINT64: u32 = 13;
const MI_MATRIX: u32 = 14;
const MI_COMPRESSED: u32 = 15;
const MI_UTF8: u32 = 16;
const MI_UTF16: u32 = 17;
// Array classes.
const MX_CELL: u8 = 1;
const MX_CHAR: u8 = 4;
const MX_DOUBLE: u8 = 6;

/// One element: its type, its data and the offset of its tag.
struct Element<'a> {
    kind: u32,
    data: &'a [u8],
    offset: usize,
}

/// Reads the element at `*at` (little-endian) and moves past it and its padding.
fn element<'a>(bytes: &'a [u8], at: &mut usize, base: usize) -> Result<Element<'a>, MatError> {
    let offset = base + *at;
    let Some(tag) = bytes.get(*at..*at + 8) else {
        return err(offset, "the file ends inside an element's tag");
    };
    let first = u32::from_le_bytes([tag[0], tag[1], tag[2], tag[3]]);
    if first >> 16 != 0 {
        // The small form: type and size in the first word, up to 4 data bytes after.
        let (kind, n) = (first & 0xffff, (first >> 16) as usize);
        if n > 4 {
            return err(
                offset,
                format!("a small element claims {n} bytes (at most 4)"),
            );
        }
        let data = &bytes[*at + 4..*at + 4 + n];
        *at += 8;
        return Ok(Element { kind, data, offset });
    }
    let n = u32::from_le_bytes([tag[4], tag[5], tag[6], tag[7]]) as usize;
    let start = *at + 8;
    let Some(data) = start.checked_add(n).and_then(|end| bytes.get(start..end)) else {
        return err(
            offset,
            format!("an element of {n} bytes runs past the end of the file"),
        );
    };
    // Compressed elements are not padded; all others are, to 8 bytes.
    let padded = if first == MI_COMPRESSED {
        n
    } else {
        n.div_ceil(8) * 8
    };
    *at = (start + padded).min(bytes.len());
    Ok(Element {
        kind: first,
        data,
        offset,
    })
}

/// The numbers of a numeric element, as f64.
fn numbers(e: &Element) -> Result<Vec<f64>, MatError> {
    let d = e.data;
    let conv: (usize, fn(&[u8]) -> f64) = match e.kind {
        MI_DOUBLE => (8, |b| f64::from_le_bytes(b.try_into().unwrap())),
        MI_SINGLE => (4, |b| f64::from(f32::from_le_bytes(b.try_into().unwrap()))),
        MI_INT8 => (1, |b| f64::from(b[0] as i8)),
        MI_UINT8 => (1, |b| f64::from(b[0])),
        MI_INT16 => (2, |b| f64::from(i16::from_le_bytes(b.try_into().unwrap()))),
        MI_UINT16 => (2, |b| f64::from(u16::from_le_bytes(b.try_into().unwrap()))),
        MI_INT32 => (4, |b| f64::from(i32::from_le_bytes(b.try_into().unwrap()))),
        MI_UINT32 => (4, |b| f64::from(u32::from_le_bytes(b.try_into().unwrap()))),
        MI_INT64 => (8, |b| i64::from_le_bytes(b.try_into().unwrap()) as f64),
        MI_UINT64 => (8, |b| u64::from_le_bytes(b.try_into().unwrap()) as f64),
        k => return err(e.offset, format!("data type {k} is not numeric")),
    };
    if !d.len().is_multiple_of(conv.0) {
        return err(e.offset, "numeric data not a whole number of values");
    }
    Ok(d.chunks_exact(conv.0).map(conv.1).collect())
}

/// Characters of a text element.
fn text(e: &Element) -> Result<String, MatError> {
    match e.kind {
        MI_UTF8 | MI_INT8 | MI_UINT8 => Ok(String::from_utf8_lossy(e.data).into_owned()),
        MI_UTF16 | MI_UINT16 | MI_INT16 => {
            let units: Vec<u16> = e
                .data
                .chunks_exact(2)
                .map(|b| u16::from_le_bytes([b[0], b[1]]))
                .collect();
            Ok(String::from_utf16_lossy(&units))
        }
        k => err(e.offset, format!("character data of type {k}")),
    }
}

/// MATLAB's name of an array class.
fn class_name(c: u8) -> &'static str {
    match c {
        1 => "cell",
        2 => "struct",
        3 => "object",
        4 => "char",
        5 => "sparse",
        6 => "double",
        7 => "single",
        8 => "int8",
        9 => "uint8",
        10 => "int16",
        11 => "uint16",
        12 => "int32",
        13 => "uint32",
        14 => "int64",
        15 => "uint64",
        _ => "unknown",
    }
}

/// Decodes an `miMATRIX` element's contents.
/// Deepest nesting of cells read: a recording's variables are vectors and cell arrays of
/// text, never cells of cells of cells; a file nested deeper is refused before it can
/// exhaust the stack.
pub const MAX_NESTING: usize = 16;

/// Most bytes one compressed element may inflate to (256 MB, far beyond a recording's
/// variables): a compression bomb is refused before it fills memory.
pub const MAX_INFLATED_BYTES: u64 = 256 << 20;

fn matrix(e: &Element) -> Result<Variable, MatError> {
    matrix_at(e, 0)
}

fn matrix_at(e: &Element, depth: usize) -> Result<Variable, MatError> {
    if depth > MAX_NESTING {
        return err(
            e.offset,
            format!("cells nested more than {MAX_NESTING} deep: not a recording's variable"),
        );
    }
    let d = e.data;
    let mut at = 0;
    let base = e.offset + 8;
    let flags = element(d, &mut at, base)?;
    if flags.data.len() < 4 {
        return err(flags.offset, "array flags too short");
    }
    let class = flags.data[0];
    let complex = flags.data[1] & 0x08 != 0;
    let dims: Vec<usize> = numbers(&element(d, &mut at, base)?)?
        .iter()
        .map(|v| *v as usize)
        .collect();
    let name = text(&element(d, &mut at, base)?)?;
    let count: usize = dims.iter().product();
    let data = match class {
        _ if complex => Data::Other("complex"),
        MX_CHAR => {
            let chars = if count == 0 {
                String::new()
            } else {
                text(&element(d, &mut at, base)?)?
            };
            // Column-major rows x columns: read row by row.
            let rows = dims.first().copied().unwrap_or(1).max(1);
            let c: Vec<char> = chars.chars().collect();
            let cols = c.len() / rows;
            let lines: Vec<String> = (0..rows)
                .map(|r| (0..cols).map(|j| c[j * rows + r]).collect::<String>())
                .collect();
            Data::Text(lines.join("\n"))
        }
        MX_CELL => {
            let mut texts = Vec::new();
            let mut all_text = true;
            for _ in 0..count {
                let inner = element(d, &mut at, base)?;
                match matrix_at(&inner, depth + 1)?.data {
                    Data::Text(t) => texts.push(t),
                    _ => all_text = false,
                }
            }
            if all_text {
                Data::Texts(texts)
            } else {
                Data::Other("cell")
            }
        }
        6..=15 => {
            let v = if count == 0 {
                Vec::new()
            } else {
                numbers(&element(d, &mut at, base)?)?
            };
            if v.len() != count {
                return err(
                    e.offset,
                    format!("`{name}`: {} values for dimensions {dims:?}", v.len()),
                );
            }
            Data::Numeric(v)
        }
        c => Data::Other(class_name(c)),
    };
    Ok(Variable { name, dims, data })
}

/// Reads every variable of a level-5 MAT-file.
pub fn read(bytes: &[u8]) -> Result<Vec<Variable>, MatError> {
    if bytes.len() < 128 {
        return err(0, "shorter than a MAT-file's 128-byte header");
    }
    match &bytes[126..128] {
        b"IM" => {}
        b"MI" => {
            return err(
                126,
                "a big-endian MAT-file: not read here (save it on a little-endian machine)",
            )
        }
        _ => {
            return err(
                126,
                "not a MAT-file (level 5): no endian mark `IM` at byte 126",
            )
        }
    }
    let version = u16::from_le_bytes([bytes[124], bytes[125]]);
    if version == 0x0200 {
        return err(
            124,
            "a MATLAB 7.3 file (HDF5 inside): not read here; save it with `save(FILE, '-v7')`",
        );
    }
    if version != 0x0100 {
        return err(
            124,
            format!("MAT-file version {version:#06x}; level 5 is 0x0100"),
        );
    }
    let mut vars = Vec::new();
    let mut at = 128;
    while at < bytes.len() {
        let e = element(bytes, &mut at, 0)?;
        match e.kind {
            MI_MATRIX => vars.push(matrix(&e)?),
            MI_COMPRESSED => {
                let mut inflated = Vec::new();
                flate2::read::ZlibDecoder::new(e.data)
                    .take(MAX_INFLATED_BYTES + 1)
                    .read_to_end(&mut inflated)
                    .or_else(|x| {
                        err(
                            e.offset,
                            format!("compressed element does not inflate: {x}"),
                        )
                    })?;
                if inflated.len() as u64 > MAX_INFLATED_BYTES {
                    return err(
                        e.offset,
                        format!(
                            "a compressed element inflates beyond {} MB: refused (a recording is far smaller)",
                            MAX_INFLATED_BYTES >> 20
                        ),
                    );
                }
                let mut inner_at = 0;
                let inner = element(&inflated, &mut inner_at, 0)?;
                if inner.kind == MI_MATRIX {
                    let v = matrix(&inner).map_err(|x| MatError {
                        offset: e.offset,
                        message: format!("inside the compressed element: {}", x.message),
                    })?;
                    vars.push(v);
                }
            }
            _ => {}
        }
    }
    Ok(vars)
}

/// Builds a level-5 MAT-file (uncompressed).
#[derive(Debug, Clone)]
pub struct Writer {
    bytes: Vec<u8>,
}

fn put_element(out: &mut Vec<u8>, kind: u32, data: &[u8]) {
    out.extend_from_slice(&kind.to_le_bytes());
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    out.extend_from_slice(data);
    out.resize(out.len().div_ceil(8) * 8, 0);
}

/// The body of an `miMATRIX` element: flags, dimensions, name, then `parts`.
fn matrix_body(class: u8, dims: &[usize], name: &str, parts: &[u8]) -> Vec<u8> {
    let mut b = Vec::new();
    put_element(&mut b, MI_UINT32, &[class, 0, 0, 0, 0, 0, 0, 0]);
    let d: Vec<u8> = dims
        .iter()
        .flat_map(|v| (*v as i32).to_le_bytes())
        .collect();
    put_element(&mut b, MI_INT32, &d);
    put_element(&mut b, MI_INT8, name.as_bytes());
    b.extend_from_slice(parts);
    b
}

fn char_row(name: &str, s: &str) -> Vec<u8> {
    let units: Vec<u8> = s.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
    let mut part = Vec::new();
    put_element(&mut part, MI_UINT16, &units);
    matrix_body(MX_CHAR, &[1, s.encode_utf16().count()], name, &part)
}

impl Writer {
    /// A file whose header text says what wrote it.
    pub fn new(description: &str) -> Writer {
        let mut head = format!("MATLAB 5.0 MAT-file, {description}").into_bytes();
        head.resize(116, b' ');
        head.extend_from_slice(&[0; 8]);
        head.extend_from_slice(&0x0100u16.to_le_bytes());
        head.extend_from_slice(b"IM");
        Writer { bytes: head }
    }

    /// A real double matrix, `values` row by row (rows x columns).
    pub fn matrix(&mut self, name: &str, rows: usize, cols: usize, values: &[f64]) -> &mut Self {
        debug_assert_eq!(values.len(), rows * cols);
        let column_major: Vec<u8> = (0..cols)
            .flat_map(|j| (0..rows).map(move |i| values[i * cols + j]))
            .flat_map(f64::to_le_bytes)
            .collect();
        let mut part = Vec::new();
        put_element(&mut part, MI_DOUBLE, &column_major);
        let body = matrix_body(MX_DOUBLE, &[rows, cols], name, &part);
        put_element(&mut self.bytes, MI_MATRIX, &body);
        self
    }

    /// A character row.
    pub fn text(&mut self, name: &str, s: &str) -> &mut Self {
        put_element(&mut self.bytes, MI_MATRIX, &char_row(name, s));
        self
    }

    /// A 1 x n cell array of character rows.
    pub fn texts(&mut self, name: &str, items: &[&str]) -> &mut Self {
        let mut part = Vec::new();
        for s in items {
            put_element(&mut part, MI_MATRIX, &char_row("", s));
        }
        let body = matrix_body(MX_CELL, &[1, items.len()], name, &part);
        put_element(&mut self.bytes, MI_MATRIX, &body);
        self
    }

    /// The file's bytes.
    pub fn finish(&self) -> Vec<u8> {
        self.bytes.clone()
    }
}

/// A compressed copy of a writer's variables (as MATLAB's default `-v7` saves them):
/// each `miMATRIX` element wrapped in an `miCOMPRESSED` one.
pub fn compress(file: &[u8]) -> Vec<u8> {
    use std::io::Write as _;
    let mut out = file[..128].to_vec();
    let mut at = 128;
    while at < file.len() {
        let start = at;
        let n = u32::from_le_bytes(file[at + 4..at + 8].try_into().unwrap()) as usize;
        at += 8 + n.div_ceil(8) * 8;
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        let _ = z.write_all(&file[start..at]);
        let packed = z.finish().unwrap_or_default();
        out.extend_from_slice(&MI_COMPRESSED.to_le_bytes());
        out.extend_from_slice(&(packed.len() as u32).to_le_bytes());
        out.extend_from_slice(&packed);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_nested_deeper_than_a_recording_are_refused_before_the_stack_runs_out() {
        let mut inner = char_row("x", "a");
        for _ in 0..200 {
            let mut wrapped = Vec::new();
            put_element(&mut wrapped, MI_MATRIX, &inner);
            inner = matrix_body(MX_CELL, &[1, 1], "c", &wrapped);
        }
        let mut w = Writer::new("nested");
        put_element(&mut w.bytes, MI_MATRIX, &inner);
        let e = read(&w.finish()).unwrap_err();
        assert!(
            e.message.contains("nested more than 16 deep"),
            "{}",
            e.message
        );
    }

    #[test]
    fn written_variables_read_back_plain_and_compressed() {
        let mut w = Writer::new("agvsim test");
        w.matrix("A", 2, 3, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
            .text("unit", "rad_s")
            .texts("names", &["x_m", "heading_rad"]);
        for file in [w.finish(), compress(&w.finish())] {
            let v = read(&file).unwrap();
            assert_eq!(v[0].name, "A");
            assert_eq!(v[0].dims, vec![2, 3]);
            // Column-major, as MATLAB stores it.
            assert_eq!(v[0].data, Data::Numeric(vec![1.0, 4.0, 2.0, 5.0, 3.0, 6.0]));
            assert_eq!(v[1].data, Data::Text("rad_s".into()));
            assert_eq!(
                v[2].data,
                Data::Texts(vec!["x_m".into(), "heading_rad".into()])
            );
        }
    }

    #[test]
    fn broken_files_are_refused_with_the_place() {
        assert!(read(b"short")
            .unwrap_err()
            .message
            .contains("128-byte header"));
        let mut w = Writer::new("t");
        w.matrix("A", 1, 2, &[1.0, 2.0]);
        let mut f = w.finish();
        f.truncate(f.len() - 9);
        let e = read(&f).unwrap_err();
        assert_eq!(e.offset, 128, "{e}");
    }
}
