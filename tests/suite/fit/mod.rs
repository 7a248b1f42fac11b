//! `twoscale fit` (pipeline/fit, docs/fit.md): its refusals here; the recovery of synthetic materials
//! written by runtimes/testing/merl.py from the brute-force reference (pipeline/fit/tests, pytest);
//! `published`: the published ABC and SGD fits of the MERL materials against their reference values;
//! `rgl`: the RGL-EPFL reader against Mitsuba's `measured` plugin.

mod compare;
mod published;
mod rgl;

use crate::common;

use common::shared_tables::shared_tables;
use common::{assert_input_error, pytest, run, tempdir};
use std::path::Path;

/// A MERL file's bytes: the dimensions, then `values` for every bin of each channel.
fn merl(dims: [i32; 3], values: impl Fn(usize, usize) -> f64, count: usize) -> Vec<u8> {
    let mut b: Vec<u8> = dims.iter().flat_map(|d| d.to_le_bytes()).collect();
    for c in 0..3 {
        for n in 0..count {
            b.extend(values(c, n).to_le_bytes());
        }
    }
    b
}

/// A wrong size or dimension, truncation, a NaN, no valid sample, no file: one line naming the
/// file, exit status 2, neither the scene file nor the JSON written (no table is read or built),
/// with `--compare` as without, and no `--report` folder left.
#[test]
fn bad_merl_files_are_refused_with_one_line_and_nothing_written() {
    const BINS: usize = 90 * 90 * 180;
    let work = tempdir();
    let good = merl([90, 90, 180], |_, _| 0.5, BINS);
    let mut nan = good.clone();
    nan[12 + 8 * 1000..12 + 8 * 1001].copy_from_slice(&f64::NAN.to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("truncated", good[..good.len() - 4096].to_vec(), "truncated"),
        ("dims", merl([90, 90, 360], |_, _| 0.5, BINS), "dimensions [90, 90, 360]"),
        ("short", good[..10].to_vec(), "not a MERL file"),
        ("nan", nan, "NaN at bin (theta_h 0, theta_d 5, phi_d 100) of channel red"),
        ("horizon", merl([90, 90, 180], |_, _| -1.0, BINS), "no valid sample"),
    ];
    let out = work.path().join("fitted.toml");
    let fit = |file: &Path, compare: bool| {
        let tables = work.path().join("no-tables");
        let mut args =
            vec!["fit", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--tables", tables.to_str().unwrap()];
        let report = work.path().join("report");
        if compare {
            args.extend(["--compare", "--report", report.to_str().unwrap()]);
        }
        run(&args)
    };
    for (name, bytes, needle) in cases {
        let file = work.path().join(format!("{name}.binary"));
        std::fs::write(&file, bytes).unwrap();
        for compare in [false, true] {
            let o = fit(&file, compare);
            assert_input_error(&o, needle);
            assert_input_error(&o, &file.display().to_string());
        }
    }
    for compare in [false, true] {
        assert_input_error(&fit(&work.path().join("absent.binary"), compare), "absent.binary: cannot read");
    }
    // A good file with bad options: refused before any table is read.
    let file = work.path().join("good.binary");
    std::fs::write(&file, &good).unwrap();
    let f = file.to_str().unwrap();
    let nowhere = work.path().join("no/such/dir/m.toml");
    assert_input_error(&run(&["fit", f, "--out", nowhere.to_str().unwrap()]), "no such directory");
    assert_input_error(&run(&["fit", f, "--wavelengths", "0.55,0.55,0.45"]), "three different wavelengths");
    assert_input_error(&run(&["fit", f, "--wavelengths", "0.65,0.55"]), "three wavelengths");
    assert_input_error(&run(&["fit", f, "--samples", "10"]), "at least 1000 samples");
    assert_input_error(&run(&["fit", f, "--model", "glass"]), "glass");
    assert_input_error(&run(&["fit", f, "--name", "", "--out", out.to_str().unwrap()]), "empty material name");
    let png = work.path().join("no/such/dir/m.png");
    assert_input_error(&run(&["fit", f, "--render", png.to_str().unwrap()]), "no such directory");
    let folder = work.path().to_str().unwrap();
    assert_input_error(&run(&["fit", f, "--render", folder]), "give a PNG's path");
    let scene = out.to_str().unwrap();
    assert_input_error(&run(&["fit", f, "--out", scene, "--render", scene]), "give a PNG's path");
    let report = work.path().join("report");
    assert_input_error(&run(&["fit", f, "--report", report.to_str().unwrap()]), "not provided: --compare");
    let nowhere = work.path().join("no/such/dir/report");
    assert_input_error(&run(&["fit", f, "--compare", "--report", nowhere.to_str().unwrap()]), "no such directory");
    let elsewhere = tempdir();
    let full = elsewhere.path().join("full");
    std::fs::create_dir(&full).unwrap();
    std::fs::write(full.join("notes.txt"), "kept").unwrap();
    for dir in [full.as_path(), &full.join("notes.txt")] {
        let o = run(&["fit", f, "--compare", "--report", dir.to_str().unwrap()]);
        assert_input_error(&o, "is not an empty folder");
    }
    assert_eq!(std::fs::read_to_string(full.join("notes.txt")).unwrap(), "kept");
    std::fs::remove_file(&file).unwrap();
    let left: Vec<_> = std::fs::read_dir(work.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.iter().all(|f| f.to_string_lossy().ends_with(".binary")), "a refused fit wrote {left:?}");
}

/// An RGL file's field `name`: where its header entry's shape starts and the data's offset.
fn rgl_field(bytes: &[u8], name: &str) -> (usize, usize) {
    let count = u32::from_le_bytes(bytes[14..18].try_into().unwrap()) as usize;
    let mut at = 18;
    for _ in 0..count {
        let len = u16::from_le_bytes(bytes[at..at + 2].try_into().unwrap()) as usize;
        let here = &bytes[at + 2..at + 2 + len];
        at += 2 + len;
        let dims = u16::from_le_bytes(bytes[at..at + 2].try_into().unwrap()) as usize;
        let offset = u64::from_le_bytes(bytes[at + 3..at + 11].try_into().unwrap()) as usize;
        if here == name.as_bytes() {
            return (at + 11, offset);
        }
        at += 11 + 8 * dims;
    }
    panic!("no field {name}")
}

/// RGL files (a real one of the shared data, broken): a wrong magic, truncation, a NaN, a spectral file
/// (a field renamed `wavelengths`), an anisotropic one (two incident azimuths): one line naming the
/// file, exit status 2, nothing written.
#[test]
fn bad_rgl_files_are_refused_with_one_line_and_nothing_written() {
    let work = tempdir();
    let good = std::fs::read(common::shared_data().join("rgl/paper_white_rgb.bsdf")).unwrap();
    let mut magic = good.clone();
    magic[0] = b'T';
    let mut nan = good.clone();
    let (_, rgb) = rgl_field(&good, "rgb");
    nan[rgb + 4 * 1000..rgb + 4 * 1001].copy_from_slice(&f32::NAN.to_le_bytes());
    let mut spectral = good.clone();
    let at = spectral.windows(11).position(|w| w == b"description").unwrap();
    spectral[at..at + 11].copy_from_slice(b"wavelengths");
    let mut anisotropic = good.clone();
    let (shape, _) = rgl_field(&good, "phi_i");
    anisotropic[shape..shape + 8].copy_from_slice(&2u64.to_le_bytes());
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("magic", magic, "not an RGL file"),
        ("truncated", good[..good.len() / 2].to_vec(), "field"),
        ("nan", nan, "field rgb: NaN"),
        ("spectral", spectral, "a spectral RGL file"),
        ("anisotropic", anisotropic, "an anisotropic RGL file"),
    ];
    let out = work.path().join("fitted.toml");
    for (name, bytes, needle) in cases {
        let file = work.path().join(format!("{name}.bsdf"));
        std::fs::write(&file, bytes).unwrap();
        let tables = work.path().join("no-tables");
        let o =
            run(&["fit", file.to_str().unwrap(), "--out", out.to_str().unwrap(), "--tables", tables.to_str().unwrap()]);
        assert_input_error(&o, needle);
        assert_input_error(&o, &file.display().to_string());
    }
    let left: Vec<_> = std::fs::read_dir(work.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert!(left.iter().all(|f| f.to_string_lossy().ends_with(".bsdf")), "a refused fit wrote {left:?}");
}

/// pipeline/fit/tests: synthetic MERL files of three conductors (a sharp lobe with diffraction, none, a
/// broad diffraction) and a plastic (which `--model auto` must tell), without and with 5 % noise, fitted; the fitted BRDF
/// against the brute-force target at every valid sample, the scene files built, and a conductor's
/// evaluated by the Mitsuba BSDF; files outside the family with `--compare` (each comparison model
/// recovers its own file), the EPD coat's file against the reference, the MERL files of three
/// published NBRDF networks (runtimes/testing/nbrdf.py) against the networks, sample by sample, and
/// measured files judged by their render (a MERL stand-in against its published fits, an RGL file
/// against the comparison models, compare.py's independent render against the JSON's SMAPE).
#[test]
fn fit_recovers_synthetic_materials() {
    let tables = shared_tables();
    pytest("pipeline/fit/tests", &["--tables".as_ref(), tables.join("default").as_os_str()], 23);
}

/// A plastic's interface albedo as the fit integrates it (pipeline/fit/src/layer.rs, from the general
/// tables) against the per-material `interface_albedo` tables of the six test plastics (plastic1-6:
/// narrow, heavy-tailed, sharp, and three with diffraction), at the rule's incidences and three
/// wavelengths of each folder's range. The fit's rule: within 1e-3, and 5e-3 at the last, grazing
/// incidence; T_avg within 1e-3 of 1 - e_f_avg. The scout's coarser rule: 6e-3, 2e-2 and 3e-3; the
/// render's finer one (the rule a fit is judged with): 6e-4, 2e-3 and 6e-4.
#[test]
fn the_fits_interface_albedo_matches_the_per_material_tables() {
    use twoscale_fit::layer::{Beneath, Layer, Quadrature};
    use twoscale_fit::model::{GeneralTables, Surface};
    use twoscale_tables::Lookup;
    let tables = GeneralTables::open(&shared_tables().join("default")).unwrap();
    for (rule, q, limits) in [
        ("render", Quadrature::render(), [6e-4, 2e-3, 6e-4]),
        ("fit", Quadrature::fit(), [1e-3, 5e-3, 1e-3]),
        ("scout", Quadrature::scout(), [6e-3, 2e-2, 3e-3]),
    ] {
        let last = q.incidences.len() - 1;
        let (mut worst, mut grazing, mut average) = (0.0f64, 0.0f64, 0.0f64);
        for n in 1..=6 {
            let folder = common::shared_tables::test_materials().join(format!("plastic{n}"));
            let albedo = Lookup::open(&folder, "interface_albedo").unwrap();
            let m: serde_json::Value =
                serde_json::from_slice(&std::fs::read(folder.join("interface_albedo.manifest.json")).unwrap()).unwrap();
            let section = &m["material"];
            let num = |k: &str| section[k].as_f64().unwrap_or(0.0);
            let surface = Surface { beta: num("beta"), p: num("p"), sigma_s: num("sigma_s"), b: num("b"), c: num("c") };
            let lambda = albedo.axes.get(1).map_or([0.55; 3], |a| [a.min(), 0.5 * (a.min() + a.max()), a.max()]);
            let mut parts = Default::default();
            tables.parts(&surface, &lambda, &q.geometry, &q.nodes, &mut parts);
            let diffuse = Beneath::Diffuse { diffuse: [0.5; 3] };
            let layer = Layer::new(&q, &parts, surface.sigma_s, &lambda, num("ior"), &diffuse, None);
            // T_avg = 1 - e_f_avg (section 10)
            for ch in 0..3 {
                let point: Vec<f64> = if albedo.axes.len() == 2 { vec![0.0, lambda[ch]] } else { vec![0.0] };
                let want = 1.0 - albedo.decode(&point).unwrap()[1];
                average = average.max((layer.t_avg[ch] - want).abs());
                assert!(
                    (layer.t_avg[ch] - want).abs() < limits[2],
                    "{rule} rule, plastic{n}, lambda {}: T_avg {} vs {want}",
                    lambda[ch],
                    layer.t_avg[ch]
                );
            }
            for ch in 0..3 {
                for (k, &theta) in q.incidences.iter().enumerate() {
                    let point: Vec<f64> = if albedo.axes.len() == 2 { vec![theta, lambda[ch]] } else { vec![theta] };
                    let want = albedo.decode(&point).unwrap()[0];
                    let err = (layer.e_f[ch][k] - want).abs();
                    let (bound, limit) = if k == last { (&mut grazing, limits[1]) } else { (&mut worst, limits[0]) };
                    *bound = bound.max(err);
                    assert!(
                        err < limit,
                        "{rule} rule, plastic{n}, theta_i {theta:.4}, lambda {}: E_F {} vs {want}",
                        lambda[ch],
                        layer.e_f[ch][k]
                    );
                }
            }
        }
        println!(
            "{rule} rule ({} direction pairs): |E_F - interface_albedo's e_f| over 6 plastics x 3 wavelengths: \
             {worst:.2e}, {grazing:.2e} at grazing; |T_avg - (1 - e_f_avg)| {average:.2e}",
            q.geometry.len()
        );
    }
}

/// A medium's s_max as the fit computes it (pipeline/fit/src/layer.rs) against the builder's
/// (pipeline/generate/src/material/subsurface.rs: another rule, 65 incidences, panels of 8 nodes),
/// across g and the interface's index: within 3e-4 relative (it enters as 1 - alpha s_max).
#[test]
fn the_fits_single_scattering_bound_matches_the_builders() {
    let mut worst = 0.0f64;
    for g in [-0.9, -0.5, 0.0, 0.3, 0.6, 0.9] {
        for eta in [1.2, 1.5, 2.0, 2.8] {
            let (a, b) =
                (twoscale_fit::layer::single_max(g, eta), twoscale_generate::material::subsurface::single_max(g, eta));
            worst = worst.max((a - b).abs() / b);
            assert!((a - b).abs() <= 3e-4 * b, "g {g}, eta {eta}: {a} vs {b}");
        }
    }
    println!("s_max: fit against builder, largest relative difference {worst:.1e}");
}
