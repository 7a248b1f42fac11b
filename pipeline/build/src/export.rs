//! Exports for other runtimes: `.npy` files and a self-contained C header
//! with the table, its checksums and a lookup with the semantics of
//! `twoscale lookup` (multilinear in encoded coordinates, see `grid`).

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

/// The encoding as a C expression in `x`.
fn c_encoding(e: &AxisEncoding) -> String {
    match *e {
        AxisEncoding::Linear => "x".into(),
        AxisEncoding::Log => "log(x)".into(),
        AxisEncoding::Reciprocal => "1.0 / x".into(),
        AxisEncoding::ExpNegPower { k } => format!("exp(-pow(x, -1.0 / {}))", c_f64(k)),
        AxisEncoding::BoundedLog { eps, delta } => {
            format!("isinf(x) ? -log({d}) : log((x + {e}) / (1.0 + {d} * x))", d = c_f64(delta), e = c_f64(eps))
        }
        AxisEncoding::ShiftedReciprocal { shift } => format!("1.0 / (x + {})", c_f64(shift)),
        AxisEncoding::ShiftedLog { shift } => format!("log(x - {})", c_f64(shift)),
        AxisEncoding::LogGap { end, eps } => format!("-log({} + {} - x)", c_f64(end), c_f64(eps)),
        AxisEncoding::LogPlusLogLog1pSq => "log(x) + log(log1p(x * x))".into(),
        AxisEncoding::Log1pSq { scale } => format!("log1p((x / {s}) * (x / {s}))", s = c_f64(scale)),
        AxisEncoding::BoundedLogTan { eps, delta } => format!("log((tan(x) + {}) / (1.0 + {} * tan(x)))", c_f64(eps), c_f64(delta)),
        AxisEncoding::AsinSqrt => "asin(sqrt(x))".into(),
    }
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

/// C pieces of the lookup: the derived axes (x[] from point[], -1 when the
/// physical coordinate is outside its range), what is computed once the cell
/// is known, what each corner subtracts from the stored values, the value
/// decodings, and the helper functions they call.
struct CLookup {
    derive: String,
    cell: String,
    corner: String,
    decode: String,
    helpers: String,
}

fn c_derived(manifest: &Manifest, axes: &[Axis], values: &[(String, ArrayD<f32>)], prefix: &str) -> CLookup {
    let coordinate = |name: &str| {
        let i = axes.iter().position(|a| {
            a.name == name || manifest.derived_axes.iter().any(|d| d.axis == a.name && d.coordinate == name)
        });
        i.expect("derived inputs are coordinates of the table")
    };
    let mut c = CLookup { derive: String::new(), cell: String::new(), corner: String::new(), decode: String::new(), helpers: String::new() };
    for (j, d) in manifest.derived_axes.iter().enumerate() {
        let i = coordinate(&d.coordinate);
        let arg: Vec<String> = d.inputs.iter().map(|n| format!("point[{}]", coordinate(n))).collect();
        let _ = writeln!(c.derive, "    if (isnan(point[{i}]) || point[{i}] < {} || point[{i}] > {}) return -1;", c_f64(d.min), c_f64(d.max));
        let (edge, v_anchor) = match d.derivation {
            Derivation::AnchoredLobeAngle { k, v_anchor, theta_cap } => (
                format!(
                    "/* The edge a(u, beta, p) of derived axis {j}: min(sqrt(1/(1 + 4u^2) + atan(beta k^(1/(2p)))^2), theta_cap). */
static double {prefix}_edge{j}(double u, double beta, double p) {{
    double wd = atan(beta * pow({}, 0.5 / p));
    return fmin(sqrt(1.0 / (1.0 + 4.0 * u * u) + wd * wd), {});
}}

",
                    c_f64(k), c_f64(theta_cap)
                ),
                v_anchor,
            ),
            Derivation::MaterialLobeAngle { edge_d, v_anchor, theta_cap } => (
                format!(
                    "/* The edge a(u) of derived axis {j}: min(sqrt(1/(1 + 4u^2) + edge_d^2), theta_cap). */
static double {prefix}_edge{j}(double u) {{
    return fmin(sqrt(1.0 / (1.0 + 4.0 * u * u) + {ed} * {ed}), {});
}}

",
                    c_f64(theta_cap),
                    ed = c_f64(edge_d)
                ),
                v_anchor,
            ),
        };
        c.helpers += &edge;
        let _ = writeln!(
            c.derive,
            "    {{ /* {} */
        double t = point[{i}], a = {prefix}_edge{j}({});
        x[{i}] = t <= a ? {va} * log1p(t / a) / log(2.0) : {va} + (1.0 - {va}) * log(t / a) / log({} / a);
    }}",
            d.formula,
            arg.join(", "),
            c_f64(std::f64::consts::FRAC_PI_2),
            va = c_f64(v_anchor)
        );
    }
    for e in &manifest.value_encoding {
        let v = values.iter().position(|(n, _)| *n == e.value).expect("encoded values exist");
        assert!(e.control_variates.is_empty(), "C export of control variates: being rewritten (issue 26)");
        let _ = writeln!(c.decode, "    out[{v}] = exp(out[{v}]); /* {} */", e.formula);
    }
    c
}

/// `twoscale_<table>_<preset>`, a C identifier (a scene's `-` and any other
/// character that is not one become `_`): the header's file stem and the prefix of its names.
pub fn c_prefix(manifest: &Manifest) -> String {
    format!("twoscale_{}_{}", manifest.table, manifest.preset.replace(|c: char| !c.is_ascii_alphanumeric(), "_"))
}

/// A self-contained C99 header for one table: `<prefix>_lookup(point, out)`
/// returns 0 and fills one value per dataset, or -1 when the point is
/// outside the domain or NaN. `prefix` = twoscale_<table>_<preset>.
pub fn c_header(manifest: &Manifest, axes: &[Axis], values: &[(String, ArrayD<f32>)]) -> String {
    let prefix = c_prefix(manifest);
    let guard = prefix.to_uppercase() + "_H";
    let (d, nv) = (axes.len(), values.len());
    let mut h = String::new();
    // The manifest's free text (no checksum covers it) cannot end the comment.
    let text = |t: &str| t.replace("*/", "* /").replace(['\n', '\r'], " ");
    let generator = text(&format!("{} {}", manifest.generator.name, manifest.generator.version));
    let _ = writeln!(h, "/* Generated by {generator}: table {}, preset {}. Do not edit.", manifest.table, text(&manifest.preset));
    let _ = writeln!(h, " * {}", text(manifest.definition.as_str().unwrap_or_default()));
    let _ = writeln!(h, " * Axes (order of the values, C order): {}", axes.iter().map(|a| format!("{} [{}]", a.name, a.encoding.formula())).collect::<Vec<_>>().join("; "));
    let _ = writeln!(h, " * Values: {}", values.iter().map(|v| v.0.as_str()).collect::<Vec<_>>().join(", "));
    let _ = writeln!(h, " * Lookup: multilinear interpolation in encoded coordinates, as `twoscale lookup`.");
    for d in &manifest.derived_axes {
        let _ = writeln!(h, " * Derived axis {} from the physical coordinate {} (point[] takes {}): {}", d.axis, d.coordinate, d.coordinate, d.formula);
    }
    for e in &manifest.value_encoding {
        let _ = writeln!(h, " * Value encoding: {}", e.formula);
    }
    let _ = writeln!(h, " * Data SHA-256 (little-endian C order, float64 axes, float32 values):");
    for (name, sum) in manifest.data_checksums() {
        let _ = writeln!(h, " *   {name} {sum}");
    }
    let _ = writeln!(h, " */\n#ifndef {guard}\n#define {guard}\n#include <math.h>\n#include <stddef.h>\n");
    let _ = writeln!(h, "#define {}_DIMS {d}\n#define {}_VALUES {nv}\n", prefix.to_uppercase(), prefix.to_uppercase());
    for (name, sum) in manifest.data_checksums() {
        let _ = writeln!(h, "static const char {prefix}_sha256_{}[] = \"{sum}\";", name.replace('/', "_"));
    }
    for axis in axes {
        c_array(&mut h, "double", &format!("{prefix}_axis_{}", axis.name), axis.nodes.iter(), |x| c_f64(*x));
        c_array(&mut h, "double", &format!("{prefix}_enc_{}", axis.name), axis.encoded().iter(), |x| c_f64(*x));
    }
    for (name, data) in values {
        c_array(&mut h, "float", &format!("{prefix}_value_{name}"), data.iter(), |x| format!("{x:e}f"));
    }
    let list = |f: &dyn Fn(&Axis) -> String| axes.iter().map(f).collect::<Vec<_>>().join(", ");
    let _ = writeln!(h, "static const double *const {prefix}_enc[{d}] = {{{}}};", list(&|a| format!("{prefix}_enc_{}", a.name)));
    let _ = writeln!(h, "static const int {prefix}_size[{d}] = {{{}}};", list(&|a| a.len().to_string()));
    let _ = writeln!(h, "static const float *const {prefix}_values[{nv}] = {{{}}};", values.iter().map(|v| format!("{prefix}_value_{}", v.0)).collect::<Vec<_>>().join(", "));
    let _ = writeln!(h, "\nstatic double {prefix}_encode(int axis, double x) {{\n    switch (axis) {{");
    for (i, axis) in axes.iter().enumerate() {
        let _ = writeln!(h, "    case {i}: return {};", c_encoding(&axis.encoding));
    }
    let _ = writeln!(h, "    }}\n    return NAN;\n}}\n");
    let CLookup { derive, cell, corner, decode, helpers } = c_derived(manifest, axes, values, &prefix);
    if !cell.is_empty() {
        let _ = writeln!(h, "static const double *const {prefix}_axis[{d}] = {{{}}};", list(&|a| format!("{prefix}_axis_{}", a.name)));
    }
    let (adjust_decl, adjusted) = if corner.is_empty() { (String::new(), "") } else { (format!(", adjust[{nv}] = {{0}}"), " - adjust[v]") };
    let _ = writeln!(
        h,
        r#"/* Cell i and weight t of x on one axis (encoded nodes monotone either way); -1 outside or NaN. */
static int {prefix}_locate(int axis, double x, int *cell, double *t) {{
    const double *enc = {prefix}_enc[axis];
    int n = {prefix}_size[axis], lo = 0, hi = n, i;
    double e = {prefix}_encode(axis, x), sign = enc[n - 1] > enc[0] ? 1.0 : -1.0, w;
    if (isnan(x) || isnan(e) || sign * e < sign * enc[0] || sign * e > sign * enc[n - 1]) return -1;
    while (lo < hi) {{ int mid = (lo + hi) / 2; if (sign * enc[mid] <= sign * e) lo = mid + 1; else hi = mid; }}
    i = (lo < 1 ? 1 : (lo > n - 1 ? n - 1 : lo)) - 1;
    w = (e - enc[i]) / (enc[i + 1] - enc[i]);
    *cell = i;
    *t = w < 0.0 ? 0.0 : (w > 1.0 ? 1.0 : w);
    return 0;
}}

{helpers}/* out[v] for every value at point[axis] (physical units: a derived axis takes its physical
 * coordinate, see the header comment); 0, or -1 when outside the domain or NaN. */
static int {prefix}_lookup(const double point[{d}], double out[{nv}]) {{
    int cell[{d}], a, v;
    double t[{d}], x[{d}]{adjust_decl};
    unsigned corner;
    for (a = 0; a < {d}; a++) x[a] = point[a];
{derive}    for (a = 0; a < {d}; a++)
        if ({prefix}_locate(a, x[a], &cell[a], &t[a])) return -1;
{cell}    for (v = 0; v < {nv}; v++) out[v] = 0.0;
    for (corner = 0; corner < (1u << {d}); corner++) {{
        double w = 1.0;
        size_t index = 0;
        for (a = 0; a < {d}; a++) {{
            int up = (corner >> a) & 1;
            w *= up ? t[a] : 1.0 - t[a];
            index = index * (size_t){prefix}_size[a] + (size_t)(cell[a] + up);
        }}
        if (w != 0.0) {{
{corner}            for (v = 0; v < {nv}; v++) out[v] += w * ((double){prefix}_values[v][index]{adjusted});
        }}
    }}
{decode}    return 0;
}}

#endif"#
    );
    h
}
