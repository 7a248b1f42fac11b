//! Exports for other runtimes: `.npy` files and a C data header (the table,
//! its decodings and checksums) for the checked-in C reader
//! pipeline/contract/c/twoscale_tables.h, whose lookup has the semantics of
//! `twoscale lookup`.

use twoscale_tables::derived::Derivation;
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::manifest::Manifest;
use crate::table::write_bytes_atomic;
use anyhow::{Context, Result};
use ndarray::ArrayD;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// NPY format 1.0: magic, version, header length, a Python dict padded with
/// spaces to a multiple of 64 bytes, then little-endian C-order data.
fn npy(descr: &str, shape: &[usize], payload: &[u8]) -> Vec<u8> {
    let dims: Vec<String> = shape.iter().map(|d| d.to_string()).collect();
    let shape_txt = if dims.len() == 1 { format!("({},)", dims[0]) } else { format!("({})", dims.join(", ")) };
    let mut header = format!("{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape_txt}, }}");
    let total = 10 + header.len() + 1;
    header.push_str(&" ".repeat((64 - total % 64) % 64));
    header.push('\n');
    let mut out = b"\x93NUMPY\x01\x00".to_vec();
    out.extend_from_slice(&(header.len() as u16).to_le_bytes());
    out.extend_from_slice(header.as_bytes());
    out.extend_from_slice(payload);
    out
}

/// Writes `<table>.axis.<name>.npy` (float64) and `<table>.value.<name>.npy`
/// (float32) into `out`; returns the paths.
pub fn export_npy(table: &str, axes: &[Axis], values: &[(String, ArrayD<f32>)], out: &Path) -> Result<Vec<PathBuf>> {
    std::fs::create_dir_all(out).with_context(|| format!("cannot create output directory {}", out.display()))?;
    let mut written = Vec::new();
    for axis in axes {
        let bytes: Vec<u8> = axis.nodes.iter().flat_map(|x| x.to_le_bytes()).collect();
        let path = out.join(format!("{table}.axis.{}.npy", axis.name));
        let data = npy("<f8", &[axis.len()], &bytes);
        write_bytes_atomic(&path, &data)?;
        written.push(path);
    }
    for (name, data) in values {
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let path = out.join(format!("{table}.value.{name}.npy"));
        let npy_bytes = npy("<f4", data.shape(), &bytes);
        write_bytes_atomic(&path, &npy_bytes)?;
        written.push(path);
    }
    Ok(written)
}

/// A C double literal (+inf as INFINITY), exact to the last bit.
fn c_f64(x: f64) -> String {
    if x.is_infinite() {
        (if x > 0.0 { "INFINITY" } else { "-INFINITY" }).into()
    } else {
        format!("{x:e}")
    }
}

/// A C string literal of `s` (quotes, backslashes, `?` of trigraphs and
/// non-printable or non-ASCII bytes escaped).
fn c_string(s: &str) -> String {
    let mut out = String::from("\"");
    for b in s.bytes() {
        match b {
            b'"' | b'\\' | b'?' => {
                out.push('\\');
                out.push(b as char);
            }
            0x20..=0x7e => out.push(b as char),
            _ => {
                let _ = write!(out, "\\{b:03o}");
            }
        }
    }
    out.push('"');
    out
}

/// `name` as part of a C identifier.
fn c_ident(name: &str) -> String {
    name.replace(|c: char| !c.is_ascii_alphanumeric(), "_")
}

fn c_array<T>(out: &mut String, ctype: &str, name: &str, data: impl ExactSizeIterator<Item = T>, fmt: impl Fn(T) -> String) {
    let n = data.len();
    let _ = write!(out, "static const {ctype} {name}[{n}] = {{");
    for (i, x) in data.enumerate() {
        if i % 8 == 0 {
            out.push_str("\n    ");
        }
        out.push_str(&fmt(x));
        out.push_str(", ");
    }
    out.push_str("\n};\n");
}

/// The axis encoding as twoscale_tables.h's enum constant and parameters.
fn c_axis_encoding(e: &AxisEncoding) -> (&'static str, [f64; 2]) {
    match *e {
        AxisEncoding::Linear => ("TWOSCALE_LINEAR", [0.0; 2]),
        AxisEncoding::Log => ("TWOSCALE_LOG", [0.0; 2]),
        AxisEncoding::Reciprocal => ("TWOSCALE_RECIPROCAL", [0.0; 2]),
        AxisEncoding::ExpNegPower { k } => ("TWOSCALE_EXP_NEG_POWER", [k, 0.0]),
        AxisEncoding::BoundedLog { eps, delta } => ("TWOSCALE_BOUNDED_LOG", [eps, delta]),
        AxisEncoding::ShiftedReciprocal { shift } => ("TWOSCALE_SHIFTED_RECIPROCAL", [shift, 0.0]),
        AxisEncoding::ShiftedLog { shift } => ("TWOSCALE_SHIFTED_LOG", [shift, 0.0]),
        AxisEncoding::LogGap { end, eps } => ("TWOSCALE_LOG_GAP", [end, eps]),
        AxisEncoding::LogPlusLogLog1pSq => ("TWOSCALE_LOG_PLUS_LOG_LOG1P_SQ", [0.0; 2]),
        AxisEncoding::Log1pSq { scale } => ("TWOSCALE_LOG1P_SQ", [scale, 0.0]),
        AxisEncoding::BoundedLogTan { eps, delta } => ("TWOSCALE_BOUNDED_LOG_TAN", [eps, delta]),
        AxisEncoding::AsinSqrt => ("TWOSCALE_ASIN_SQRT", [0.0; 2]),
    }
}

/// The most axes twoscale_tables.h reads (its TWOSCALE_MAX_DIMS).
const C_MAX_DIMS: usize = 8;

/// `twoscale_<table>_<preset>`, a C identifier (a scene's `-` and any other
/// character that is not one become `_`): the header's file stem and the name of its table.
pub fn c_prefix(manifest: &Manifest) -> String {
    format!("twoscale_{}_{}", manifest.table, c_ident(&manifest.preset))
}

/// A C99 data header for one table, read by the checked-in lookup code
/// pipeline/contract/c/twoscale_tables.h: it defines `static const
/// twoscale_table <prefix>` (axes, derived axes, stored values, outputs and
/// their decodings, data checksums), `prefix` = twoscale_<table>_<preset>, for
/// `twoscale_lookup(&<prefix>, point, out)`. An error when the table has more
/// axes than the C reader takes.
pub fn c_header(manifest: &Manifest, axes: &[Axis], values: &[(String, ArrayD<f32>)]) -> Result<String> {
    if axes.len() > C_MAX_DIMS {
        anyhow::bail!("{}: {} axes, the C reader takes at most {C_MAX_DIMS}", manifest.table, axes.len());
    }
    let prefix = c_prefix(manifest);
    let guard = prefix.to_uppercase() + "_H";
    let derived = |axis: &str| manifest.derived_axes.iter().find(|d| d.axis == axis);
    // The physical coordinate of each axis, the order of a lookup's point[].
    let coordinates: Vec<&str> = axes.iter().map(|a| derived(&a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str())).collect();
    let coordinate = |name: &str| coordinates.iter().position(|c| *c == name).expect("derived inputs are coordinates of the table");
    let value = |name: &str| values.iter().position(|(n, _)| n == name).expect("encoded values are stored values");
    // The outputs (as `Lookup::outputs`): every value but those holding control variates.
    let control: Vec<usize> = manifest.value_encoding.iter().flat_map(|e| e.control_variates.iter().map(|cv| value(&cv.values))).collect();
    let outputs: Vec<usize> = (0..values.len()).filter(|i| !control.contains(i)).collect();
    let mut h = String::new();
    // The manifest's free text (no checksum covers it) cannot end the comment.
    let text = |t: &str| t.replace("*/", "* /").replace("??", "? ?").replace(['\n', '\r'], " ");
    let generator = text(&format!("{} {}", manifest.generator.name, manifest.generator.version));
    let names = |v: &[&str]| v.join(", ");
    let _ = writeln!(h, "/* Generated by {generator}: table {}, preset {}. Do not edit.", manifest.table, text(&manifest.preset));
    let _ = writeln!(h, " * {}", text(manifest.definition.as_str().unwrap_or_default()));
    let _ = writeln!(h, " * Axes (order of the values, C order): {}", axes.iter().map(|a| format!("{} [{}]", a.name, a.encoding.formula())).collect::<Vec<_>>().join("; "));
    let _ = writeln!(h, " * Values: {}", names(&values.iter().map(|v| v.0.as_str()).collect::<Vec<_>>()));
    let _ = writeln!(h, " * Lookup: multilinear interpolation in encoded coordinates, as `twoscale lookup`, by twoscale_tables.h:");
    let _ = writeln!(
        h,
        " *   twoscale_lookup(&{prefix}, point, out), point = ({}), out = ({}).",
        names(&coordinates),
        names(&outputs.iter().map(|&i| values[i].0.as_str()).collect::<Vec<_>>())
    );
    for d in &manifest.derived_axes {
        let _ = writeln!(h, " * Derived axis {} from the physical coordinate {} (point[] takes {}): {}", d.axis, d.coordinate, d.coordinate, text(&d.formula));
    }
    for e in &manifest.value_encoding {
        let _ = writeln!(h, " * Value encoding: {}", text(&e.formula));
    }
    let _ = writeln!(h, " * Data SHA-256 (little-endian C order, float64 axes, float32 values):");
    for (name, sum) in manifest.data_checksums() {
        let _ = writeln!(h, " *   {name} {sum}");
    }
    let _ = writeln!(h, " */\n#ifndef {guard}\n#define {guard}\n#include \"twoscale_tables.h\"\n");
    for axis in axes {
        c_array(&mut h, "double", &format!("{prefix}_nodes_{}", c_ident(&axis.name)), axis.nodes.iter(), |x| c_f64(*x));
        c_array(&mut h, "double", &format!("{prefix}_encoded_{}", c_ident(&axis.name)), axis.encoded().iter(), |x| c_f64(*x));
    }
    for (name, data) in values {
        c_array(&mut h, "float", &format!("{prefix}_values_{}", c_ident(name)), data.iter(), |x| format!("{x:e}f"));
    }
    let _ = writeln!(h, "\nstatic const twoscale_axis {prefix}_axes[{}] = {{", axes.len());
    for (axis, coordinate) in axes.iter().zip(&coordinates) {
        let (kind, [p0, p1]) = c_axis_encoding(&axis.encoding);
        let id = c_ident(&axis.name);
        let _ = writeln!(
            h,
            "    {{.name = {}, .coordinate = {}, .size = {}, .encoding = {kind}, .param = {{{}, {}}},\n     .nodes = {prefix}_nodes_{id}, .encoded = {prefix}_encoded_{id}}},",
            c_string(&axis.name),
            c_string(coordinate),
            axis.len(),
            c_f64(p0),
            c_f64(p1)
        );
    }
    let _ = writeln!(h, "}};");
    if !manifest.derived_axes.is_empty() {
        let _ = writeln!(h, "static const twoscale_derived_axis {prefix}_derived[{}] = {{", manifest.derived_axes.len());
        for d in &manifest.derived_axes {
            let (kind, k, edge_d, v_anchor, theta_cap) = match d.derivation {
                Derivation::AnchoredLobeAngle { k, v_anchor, theta_cap } => ("TWOSCALE_ANCHORED_LOBE_ANGLE", k, 0.0, v_anchor, theta_cap),
                Derivation::MaterialLobeAngle { edge_d, v_anchor, theta_cap } => ("TWOSCALE_MATERIAL_LOBE_ANGLE", 0.0, edge_d, v_anchor, theta_cap),
            };
            let mut inputs: Vec<String> = d.inputs.iter().map(|n| coordinate(n).to_string()).collect();
            let ninputs = inputs.len();
            inputs.resize(3, "0".into());
            let _ = writeln!(
                h,
                "    {{.axis = {}, .min = {}, .max = {}, .kind = {kind}, .k = {}, .edge_d = {}, .v_anchor = {}, .theta_cap = {},\n     .ninputs = {ninputs}, .inputs = {{{}}}}}, /* {}: {} */",
                coordinate(&d.coordinate),
                c_f64(d.min),
                c_f64(d.max),
                c_f64(k),
                c_f64(edge_d),
                c_f64(v_anchor),
                c_f64(theta_cap),
                inputs.join(", "),
                d.axis,
                names(&d.inputs.iter().map(String::as_str).collect::<Vec<_>>())
            );
        }
        let _ = writeln!(h, "}};");
    }
    let _ = writeln!(h, "static const twoscale_values {prefix}_values[{}] = {{", values.len());
    for (name, _) in values {
        let _ = writeln!(h, "    {{{}, {prefix}_values_{}}},", c_string(name), c_ident(name));
    }
    let _ = writeln!(h, "}};\nstatic const twoscale_output {prefix}_outputs[{}] = {{", outputs.len());
    for &i in &outputs {
        let name = &values[i].0;
        let (kind, cv) = match manifest.value_encoding.iter().find(|e| e.value == *name) {
            None => ("TWOSCALE_VALUE_NONE", vec![]),
            Some(e) if e.control_variates.is_empty() => ("TWOSCALE_VALUE_LN", vec![]),
            // `open_table` checked the four terms of `Term::ALL` in order.
            Some(e) => ("TWOSCALE_VALUE_LN_CV", e.control_variates.iter().map(|cv| value(&cv.values)).collect()),
        };
        let cv_text = if cv.is_empty() { String::new() } else { format!(", .cv = {{{}}}", cv.iter().map(usize::to_string).collect::<Vec<_>>().join(", ")) };
        let _ = writeln!(h, "    {{.name = {}, .value = {i}, .encoding = {kind}{cv_text}}},", c_string(name));
    }
    let checksums = manifest.data_checksums();
    let _ = writeln!(h, "}};\nstatic const twoscale_checksum {prefix}_checksums[{}] = {{", checksums.len());
    for (name, sum) in &checksums {
        let _ = writeln!(h, "    {{{}, {}}},", c_string(name), c_string(sum));
    }
    let _ = writeln!(h, "}};\n");
    let derived_ptr = if manifest.derived_axes.is_empty() { "NULL".to_string() } else { format!("{prefix}_derived") };
    let _ = writeln!(
        h,
        "static const twoscale_table {prefix} = {{
    .table = {}, .preset = {},
    .dims = {}, .axes = {prefix}_axes,
    .nderived = {}, .derived = {derived_ptr},
    .nvalues = {}, .values = {prefix}_values,
    .noutputs = {}, .outputs = {prefix}_outputs,
    .nchecksums = {}, .checksums = {prefix}_checksums,
}};

#endif",
        c_string(&manifest.table),
        c_string(&manifest.preset),
        axes.len(),
        manifest.derived_axes.len(),
        values.len(),
        outputs.len(),
        checksums.len()
    );
    Ok(h)
}
