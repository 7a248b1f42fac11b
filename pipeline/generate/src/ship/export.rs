//! Exports for other runtimes: `.npy` files and a C data header (the table,
//! its decodings and checksums) for the checked-in C reader
//! pipeline/tables/c/twoscale_tables.h, whose lookup has the semantics of
//! `twoscale lookup`.

use anyhow::{bail, Context, Result};
use ndarray::ArrayD;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use twoscale_tables::axis::{Axis, AxisEncoding};
use twoscale_tables::derived::Derivation;
use twoscale_tables::manifest::Manifest;
use twoscale_tables::spectrum::Spectrum;
use twoscale_tables::table::write_bytes_atomic;

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

fn c_array<T>(
    out: &mut String,
    ctype: &str,
    name: &str,
    data: impl ExactSizeIterator<Item = T>,
    fmt: impl Fn(T) -> String,
) {
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
/// pipeline/tables/c/twoscale_tables.h: it defines `static const
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
    let coordinates: Vec<&str> =
        axes.iter().map(|a| derived(&a.name).map_or(a.name.as_str(), |d| d.coordinate.as_str())).collect();
    let coordinate =
        |name: &str| coordinates.iter().position(|c| *c == name).expect("derived inputs are coordinates of the table");
    let value = |name: &str| values.iter().position(|(n, _)| n == name).expect("encoded values are stored values");
    // The outputs (as `Lookup::outputs`): every value but those holding control variates.
    let control: Vec<usize> =
        manifest.value_encoding.iter().flat_map(|e| e.control_variates.iter().map(|cv| value(&cv.values))).collect();
    let outputs: Vec<usize> = (0..values.len()).filter(|i| !control.contains(i)).collect();
    let mut h = String::new();
    // The manifest's free text (no checksum covers it) cannot end the comment.
    let text = |t: &str| t.replace("*/", "* /").replace("??", "? ?").replace(['\n', '\r'], " ");
    let generator = text(&format!("{} {}", manifest.generator.name, manifest.generator.version));
    let names = |v: &[&str]| v.join(", ");
    let _ = writeln!(
        h,
        "/* Generated by {generator}: table {}, preset {}. Do not edit.",
        manifest.table,
        text(&manifest.preset)
    );
    let _ = writeln!(h, " * {}", text(manifest.definition.as_str().unwrap_or_default()));
    let _ = writeln!(
        h,
        " * Axes (order of the values, C order): {}",
        axes.iter().map(|a| format!("{} [{}]", a.name, a.encoding.formula())).collect::<Vec<_>>().join("; ")
    );
    let _ = writeln!(h, " * Values: {}", names(&values.iter().map(|v| v.0.as_str()).collect::<Vec<_>>()));
    let kind =
        if manifest.interpolation.is_multilinear() { "multilinear" } else { "cubic (4-point Lagrange per axis)" };
    let _ = writeln!(
        h,
        " * Lookup: {kind} interpolation in encoded coordinates, as `twoscale lookup`, by twoscale_tables.h:"
    );
    let _ = writeln!(
        h,
        " *   twoscale_lookup(&{prefix}, point, out), point = ({}), out = ({}).",
        names(&coordinates),
        names(&outputs.iter().map(|&i| values[i].0.as_str()).collect::<Vec<_>>())
    );
    for d in &manifest.derived_axes {
        let _ = writeln!(
            h,
            " * Derived axis {} from the physical coordinate {} (point[] takes {}): {}",
            d.axis,
            d.coordinate,
            d.coordinate,
            text(&d.formula)
        );
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
        c_array(&mut h, "double", &format!("{prefix}_encoded_{}", c_ident(&axis.name)), axis.encoded().iter(), |x| {
            c_f64(*x)
        });
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
        let _ =
            writeln!(h, "static const twoscale_derived_axis {prefix}_derived[{}] = {{", manifest.derived_axes.len());
        for d in &manifest.derived_axes {
            let (kind, k, edge_d, v_anchor, theta_cap) = match d.derivation {
                Derivation::AnchoredLobeAngle { k, v_anchor, theta_cap } => {
                    ("TWOSCALE_ANCHORED_LOBE_ANGLE", k, 0.0, v_anchor, theta_cap)
                }
                Derivation::MaterialLobeAngle { edge_d, v_anchor, theta_cap } => {
                    ("TWOSCALE_MATERIAL_LOBE_ANGLE", 0.0, edge_d, v_anchor, theta_cap)
                }
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
        // Every member initialised (unused control variates 0), so that C++ (-Wextra) takes the header too.
        let mut cv: Vec<String> = cv.iter().map(usize::to_string).collect();
        cv.resize(4, "0".into());
        let _ = writeln!(
            h,
            "    {{.name = {}, .value = {i}, .encoding = {kind}, .cv = {{{}}}}},",
            c_string(name),
            cv.join(", ")
        );
    }
    let checksums = manifest.data_checksums();
    let _ = writeln!(h, "}};\nstatic const twoscale_checksum {prefix}_checksums[{}] = {{", checksums.len());
    for (name, sum) in &checksums {
        let _ = writeln!(h, "    {{{}, {}}},", c_string(name), c_string(sum));
    }
    let _ = writeln!(h, "}};\n");
    // Set in every header: C++ -Wextra wants every member initialised (0, unset, is multilinear too).
    let interpolation = if manifest.interpolation.is_multilinear() {
        "\n    .interpolation = TWOSCALE_MULTILINEAR,"
    } else {
        "\n    .interpolation = TWOSCALE_CUBIC,"
    };
    let derived_ptr = if manifest.derived_axes.is_empty() { "NULL".to_string() } else { format!("{prefix}_derived") };
    let _ = writeln!(
        h,
        "static const twoscale_table {prefix} = {{
    .table = {}, .preset = {},
    .dims = {}, .axes = {prefix}_axes,
    .nderived = {}, .derived = {derived_ptr},
    .nvalues = {}, .values = {prefix}_values,
    .noutputs = {}, .outputs = {prefix}_outputs,
    .nchecksums = {}, .checksums = {prefix}_checksums,{interpolation}
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

/// `twoscale_material_<preset>`: the material header's file stem and the name
/// of its `twoscale_material`.
pub fn c_material_prefix(preset: &str) -> String {
    format!("twoscale_material_{}", c_ident(preset))
}

/// A C99 header defining `static const twoscale_material <prefix>` for the
/// reference BRDF runtimes/c/twoscale_brdf.h: the manifests' `material`
/// section (a number absent without diffraction is 0) and pointers to the
/// tables of the data headers `c_header` wrote (`tables`: table name, its
/// prefix). Positional initialisers, in twoscale_material's order, so that C++
/// takes it too.
pub fn c_material_header(manifest: &Manifest, tables: &[(&str, String)]) -> Result<String> {
    let material = manifest.material.as_ref().with_context(|| format!("{}: no material section", manifest.table))?;
    let prefix = c_material_prefix(&manifest.preset);
    let guard = prefix.to_uppercase() + "_H";
    let number = |key: &str| material.get(key).and_then(serde_json::Value::as_f64).unwrap_or(0.0);
    let name = material.get("name").and_then(serde_json::Value::as_str).unwrap_or_default();
    let mut h = String::new();
    let _ = writeln!(
        h,
        "/* Generated by {} {}: material {} (preset {}). Do not edit.",
        manifest.generator.name,
        manifest.generator.version,
        name.replace("*/", "* /"),
        manifest.preset.replace("*/", "* /")
    );
    let _ = writeln!(h, " * The reference BRDF of runtimes/c/twoscale_brdf.h over this material's tables:");
    let _ = writeln!(h, " *   twoscale_brdf brdf; twoscale_brdf_init(&brdf, &{prefix}, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE); */");
    let _ = writeln!(h, "#ifndef {guard}\n#define {guard}\n#include \"twoscale_brdf.h\"");
    for (_, p) in tables {
        let _ = writeln!(h, "#include \"{p}.h\"");
    }
    let table = |t: &str| tables.iter().find(|(n, _)| *n == t).map_or("NULL".to_string(), |(_, p)| format!("&{p}"));
    // A layered model's layer albedo (a plastic's diffuse, a subsurface medium's reduced albedo): its samples as
    // arrays (a constant: one value, no wavelengths).
    let model = material.get("model").and_then(serde_json::Value::as_str).unwrap_or("conductor");
    let layered = match model {
        "conductor" => None,
        "plastic" | "subsurface" => {
            let key = if model == "plastic" { "diffuse" } else { "albedo" };
            let values: Spectrum = serde_json::from_value(material[key].clone())
                .with_context(|| format!("{}: {key} is not a number or a spectrum", manifest.table))?;
            let mut array = |name: &str, v: &[f64]| {
                let items: Vec<String> = v.iter().map(|&x| c_f64(x)).collect();
                let _ = writeln!(h, "static const double {prefix}_{name}[{}] = {{{}}};", v.len(), items.join(", "));
            };
            array("layer_values", values.values());
            let wavelengths = match &values {
                Spectrum::Sampled { wavelengths, .. } => {
                    array("layer_wavelengths", wavelengths);
                    format!("{prefix}_layer_wavelengths")
                }
                Spectrum::Constant(_) => "NULL".into(),
            };
            Some((values.values().len(), wavelengths))
        }
        other => bail!("{}: unknown material model {other:?}", manifest.table),
    };
    let _ = writeln!(h, "\nstatic const twoscale_material {prefix} = {{");
    let _ = writeln!(h, "    {}, /* name */", c_string(name));
    for key in ["beta", "p", "sigma_s", "b", "c", "n_p", "wavelength_min", "wavelength_max"] {
        let _ = writeln!(h, "    {}, /* {key} */", c_f64(number(key)));
    }
    for t in ["epd_g1", "epd_sampling", "kcorr_renorm", "zh_lobe", "zh_lobe_sampling", "zh_convolution", "albedo"] {
        let _ = writeln!(h, "    {},", table(t));
    }
    match layered {
        Some((n, wavelengths)) => {
            let _ =
                writeln!(h, "    TWOSCALE_MODEL_{},\n    {}, /* ior */", model.to_uppercase(), c_f64(number("ior")));
            let _ = writeln!(
                h,
                "    {n}, {wavelengths}, {prefix}_layer_values, /* the layer's albedo */\n    {},",
                table("interface_albedo")
            );
            let _ = writeln!(h, "    {}, {}, /* g, single_max */", c_f64(number("g")), c_f64(number("single_max")));
        }
        None => {
            let _ = writeln!(
                h,
                "    TWOSCALE_MODEL_CONDUCTOR,\n    0.0, 0, NULL, NULL, NULL, 0.0, 0.0, /* a layered model's */"
            );
        }
    }
    let _ = writeln!(h, "}};\n\n#endif");
    Ok(h)
}
