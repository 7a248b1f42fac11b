//! The per-material `albedo` table (docs/material_tables.md): E against a brute quadrature of the
//! EPD microfacet BRDF from the maths (closed-form D, G1 by its own quadrature, no table) over
//! outgoing directions; E_avg against the integral of the table's E; E <= 1 without diffraction;
//! the known white-furnace excess with diffraction; `lookup` and `export --dir` read it.

use crate::common;

use common::shared_tables::test_materials;
use common::{assert_ok, run};
use std::f64::consts::FRAC_PI_2;
use std::path::{Path, PathBuf};
use twoscale_generate::numerics::legendre::{composite_rule, gauss_legendre};
use twoscale_generate::tables::epd_math::{g1, norm};
use twoscale_tables::lookup::Lookup;

/// The test materials' folders (runtimes/testing/test_materials.toml): "gauss" is furnace1 (beta 0.1,
/// p 1), "heavy" furnace2 (beta 0.3, p 0.5), "diffracting" furnace5 (beta 0.05, p 2, sigma_s 0.05,
/// b 0.3 um, c 2.8, 0.36-0.83 um).
fn folder(material: &str) -> PathBuf {
    let name = match material {
        "gauss" => "furnace1",
        "heavy" => "furnace2",
        "diffracting" => "furnace5",
        _ => unreachable!("no test material {material}"),
    };
    test_materials().join(name)
}

fn albedo(dir: &Path) -> Lookup {
    Lookup::open(dir, "albedo").unwrap()
}

/// E(theta_i) of D G2 / (4 cos_i cos_o) over o in (theta_o, phi_o): composite Gauss-Legendre,
/// 128 panels x 8 in theta_o, 512 nodes in phi_o over [0, pi] doubled; G2 height-correlated
/// with G1 = epd_math::g1 (its Lambda quadrature), D closed form with N(p) = p / (pi Gamma(1/p)).
/// With `ior`, weighted by the dielectric's Fresnel reflectance at cos theta_d = i.h (a plastic's E_F,
/// docs/maths.md section 10), from the s and p amplitudes.
fn brute_albedo(beta: f64, p: f64, theta_i: f64, ior: Option<f64>) -> f64 {
    let lambda = |theta: f64| 1.0 / g1(p, beta * theta.tan()) - 1.0;
    let breaks: Vec<f64> = (0..=128).map(|k| FRAC_PI_2 * k as f64 / 128.0).collect();
    let (to, tw) = composite_rule(&breaks, 8);
    let (px, pw) = gauss_legendre(512);
    let (si, ci) = theta_i.sin_cos();
    let lambda_i = lambda(theta_i);
    let n = norm(p) / (beta * beta);
    let mut e = 0.0;
    for (&t, &wt) in to.iter().zip(&tw) {
        let (so, co) = t.sin_cos();
        let lambda_o = lambda(t);
        for (&x, &wx) in px.iter().zip(&pw) {
            let phi = FRAC_PI_2 * (x + 1.0);
            let h = [si + so * phi.cos(), so * phi.sin(), ci + co];
            let len2 = h[0] * h[0] + h[1] * h[1] + h[2] * h[2];
            let tan2 = (h[0] * h[0] + h[1] * h[1]) / (h[2] * h[2]);
            let d = n * (-(tan2 / (beta * beta)).powf(p)).exp() * (len2 / (h[2] * h[2])).powi(2);
            let f = ior.map_or(1.0, |eta| fresnel_amplitudes((si * h[0] + ci * h[2]) / len2.sqrt(), eta));
            // rho cos_o = D G2 / (4 cos_i); do = sin theta_o dtheta_o dphi_o, phi over [0, 2 pi] by symmetry
            e += 2.0 * wt * wx * FRAC_PI_2 * so * f * d / (1.0 + lambda_i + lambda_o) / (4.0 * ci);
        }
    }
    e
}

/// (r_s^2 + r_p^2) / 2 at cos theta_i = c for a dielectric of index eta (Snell's law).
fn fresnel_amplitudes(c: f64, eta: f64) -> f64 {
    let cos_t = (1.0 - (1.0 - c * c) / (eta * eta)).sqrt();
    let rs = (c - eta * cos_t) / (c + eta * cos_t);
    let rp = (eta * c - cos_t) / (eta * c + cos_t);
    0.5 * (rs * rs + rp * rp)
}

#[test]
fn a_plastics_interface_albedo_matches_the_brute_quadrature_with_fresnel() {
    // plastic1 (beta 0.1, p 1, ior 1.5) and plastic2 (beta 0.3, p 0.4, ior 1.33) of test_materials.toml.
    let mut worst = 0.0f64;
    for (material, beta, p, ior) in [("plastic1", 0.1, 1.0, 1.5), ("plastic2", 0.3, 0.4, 1.33)] {
        let table = Lookup::open(&test_materials().join(material), "interface_albedo").unwrap();
        for theta_i in [0.0, 0.4, 0.9, 1.3, 1.5] {
            let e_f = table.decode(&[theta_i]).unwrap()[0];
            let brute = brute_albedo(beta, p, theta_i, Some(ior));
            worst = worst.max((e_f - brute).abs());
            assert!((e_f - brute).abs() <= 5e-5, "{material} theta_i {theta_i}: table {e_f}, brute {brute}");
        }
        // Normal incidence, a narrow lobe: E_F tends to F(0) E; here within the lobe's spread of cos theta_d.
        let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
        let (e, e_f) =
            (albedo(&test_materials().join(material)).decode(&[0.0]).unwrap()[0], table.decode(&[0.0]).unwrap()[0]);
        assert!(e_f > 0.9 * f0 * e && e_f < 1.5 * f0 * e, "{material}: E_F(0) {e_f} against F(0) E(0) {}", f0 * e);
    }
    println!("interface_albedo: largest |e_f - brute| {worst:.2e} at 10 points of plastic1 and plastic2 (tol 5e-5)");
}

#[test]
fn without_diffraction_e_matches_a_brute_quadrature_of_the_maths_and_stays_below_one() {
    for (material, beta, p) in [("gauss", 0.1, 1.0), ("heavy", 0.3, 0.5)] {
        let table = albedo(&folder(material));
        assert_eq!(table.coordinates(), ["theta_i"], "no lambda axis without diffraction");
        for theta_i in [0.05, 0.4, 0.8, 1.1, 1.3, 1.45, 1.52] {
            let e = table.decode(&[theta_i]).unwrap()[0];
            let brute = brute_albedo(beta, p, theta_i, None);
            assert!((e - brute).abs() <= 5e-5, "{material} theta_i {theta_i}: table {e}, brute {brute}");
        }
        let max = table.value("e").unwrap().iter().fold(0.0f32, |m, &e| m.max(e));
        assert!(max <= 1.0 + 3e-5, "{material}: E up to {max}");
    }
    // The heavy tail (p 0.5, beta 0.3) loses about a quarter of the energy (the white furnace: 0.76).
    let min = albedo(&folder("heavy")).value("e").unwrap().iter().fold(1.0f32, |m, &e| m.min(e));
    assert!((0.74..0.78).contains(&min), "heavy: E down to {min}");
}

#[test]
fn e_avg_is_the_cosine_weighted_average_of_e() {
    for (material, point) in [("gauss", vec![0.3]), ("heavy", vec![1.2]), ("diffracting", vec![0.7, 0.45])] {
        let table = albedo(&folder(material));
        let at = |theta: f64| {
            let mut pt = point.clone();
            pt[0] = theta;
            table.decode(&pt).unwrap()
        };
        let e_avg = at(point[0])[1];
        assert!((at(0.0)[1] - e_avg).abs() <= 1e-15, "{material}: e_avg does not depend on theta_i");
        // 2 int_0^1 E mu dmu = int_0^(pi/2) E sin 2 theta dtheta, E clamped beyond the last node: midpoint rule.
        let theta_max = table.axes[0].max();
        let n = 200_000;
        let h = theta_max / n as f64;
        let sum: f64 = (0..n).map(|k| (k as f64 + 0.5) * h).map(|t| at(t)[0] * (2.0 * t).sin() * h).sum();
        let sum = sum + at(theta_max)[0] * theta_max.cos().powi(2);
        assert!((sum - e_avg).abs() <= 2e-6, "{material}: e_avg {e_avg}, integral {sum}");
    }
}

#[test]
fn with_diffraction_the_known_white_furnace_excess() {
    // beta 0.05, p 2, B = b / lambda = 0.55, theta_i = 75 deg: E = 1.139 (docs/maths.md section 9;
    // an independent Python prototype's quadrature, which sample()'s Monte-Carlo mean weight confirmed to 0.003).
    let table = albedo(&folder("diffracting"));
    assert_eq!(table.coordinates(), ["theta_i", "lambda"]);
    let e = table.decode(&[75f64.to_radians(), 0.3 / 0.55]).unwrap()[0];
    assert!((e - 1.139).abs() <= 3e-3, "E = {e}");
    // Accuracy after interpolation, recorded by the build against nested adaptive Gauss-Kronrod.
    for material in ["gauss", "heavy", "diffracting"] {
        let m = common::read_manifest(&folder(material).join("albedo.manifest.json"));
        assert!(m.accuracy["max"].as_f64().unwrap() <= 1e-4, "{material}: {}", m.accuracy);
    }
}

#[test]
fn lookup_and_whole_material_export_read_it() {
    let dir = folder("diffracting");
    let out = run(&[
        "lookup",
        "albedo",
        "--dir",
        dir.to_str().unwrap(),
        "--at",
        "theta_i=0.7",
        "--at",
        "lambda=0.5",
        "--json",
    ]);
    assert_ok(&out);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rust = albedo(&dir).decode(&[0.7, 0.5]).unwrap();
    assert_eq!(v["values"]["e"].as_f64().unwrap(), rust[0]);
    assert_eq!(v["values"]["e_avg"].as_f64().unwrap(), rust[1]);
    let work = common::tempdir();
    assert_ok(&run(&[
        "export",
        "--format",
        "c-header",
        "--dir",
        dir.to_str().unwrap(),
        "--out",
        work.path().to_str().unwrap(),
    ]));
    let header =
        std::fs::read_to_string(work.path().join("twoscale_material_scene_test_materials_furnace5.h")).unwrap();
    assert!(header.contains("#include \"twoscale_albedo_scene_test_materials_furnace5.h\""), "{header}");
    assert!(
        header.contains("&twoscale_albedo_scene_test_materials_furnace5,\n    TWOSCALE_MODEL_CONDUCTOR,"),
        "{header}"
    );
}

/// `n` random (wi, wo): half uniform over the hemisphere, half near the mirror direction.
fn random_pairs(seed: u64, n: usize) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = twoscale_generate::numerics::sampling::SplitMix64::new(seed);
    let mut direction = |spread: f64| {
        let (ct, phi) = (1.0 - spread * rng.uniform(), 2.0 * std::f64::consts::PI * rng.uniform());
        let st = (1.0 - ct * ct).sqrt();
        [st * phi.cos(), st * phi.sin(), ct]
    };
    (0..n)
        .map(|k| {
            let wi = direction(1.0);
            let wo = if k % 2 == 0 {
                direction(1.0)
            } else {
                let d = direction(0.02);
                [-wi[0] + 0.1 * d[0], -wi[1] + 0.1 * d[1], wi[2]]
            };
            let norm = (wo[0] * wo[0] + wo[1] * wo[1] + wo[2] * wo[2]).sqrt();
            (wi, wo.map(|x| x / norm))
        })
        .collect()
}

#[test]
fn the_rust_brdf_is_the_c_runtimes_eval_parts() {
    // twoscale_tables::brdf (what the albedo integrates) against twoscale_brdf.h over the exported folder.
    let dir = folder("diffracting");
    let work = common::tempdir();
    assert_ok(&run(&[
        "export",
        "--format",
        "c-header",
        "--dir",
        dir.to_str().unwrap(),
        "--out",
        work.path().to_str().unwrap(),
    ]));
    let program = work.path().join("parts.c");
    std::fs::write(
        &program,
        "#include <stdio.h>\n#include \"twoscale_material_scene_test_materials_furnace5.h\"\n\
         int main(void) {\n    twoscale_brdf brdf;\n    double wi[3], wo[3], lambda, parts[2];\n\
             const char *err = twoscale_brdf_init(&brdf, &twoscale_material_scene_test_materials_furnace5, TWOSCALE_LOBE_EXACT, TWOSCALE_ENERGY_SINGLE);\n\
             if (err || !twoscale_material_scene_test_materials_furnace5.albedo) return 1;\n\
             while (scanf(\"%lf %lf %lf %lf %lf %lf %lf\", &wi[0], &wi[1], &wi[2], &wo[0], &wo[1], &wo[2], &lambda) == 7) {\n\
                 twoscale_brdf_eval_parts(&brdf, wi, wo, lambda, parts);\n        printf(\"%.17g %.17g\\n\", parts[0], parts[1]);\n    }\n\
             return 0;\n}\n",
    )
    .unwrap();
    let exe = work.path().join("parts");
    let o = common::c_lookup::cc()
        .arg("-I")
        .arg(work.path())
        .arg(&program)
        .arg("-o")
        .arg(&exe)
        .arg("-lm")
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let pairs: Vec<([f64; 3], [f64; 3], f64)> = random_pairs(28, 400)
        .into_iter()
        .enumerate()
        .map(|(k, (wi, wo))| (wi, wo, 0.36 + 0.47 * (k as f64 / 400.0)))
        .collect();
    let input: String = pairs
        .iter()
        .map(|(i, o, l)| format!("{:e} {:e} {:e} {:e} {:e} {:e} {l:e}\n", i[0], i[1], i[2], o[0], o[1], o[2]))
        .collect();
    let mut child = std::process::Command::new(&exe)
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::io::Write::write_all(&mut child.stdin.take().unwrap(), input.as_bytes()).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(out.status.success());
    let brdf = twoscale_tables::brdf::MaterialBrdf::open(&dir).unwrap();
    let c_parts: Vec<Vec<f64>> = String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(|l| l.split(' ').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(c_parts.len(), pairs.len());
    let mut worst = 0.0f64;
    for ((wi, wo, l), c) in pairs.iter().zip(&c_parts) {
        // The C reads what the text carries: the same rounded inputs.
        let parse = |v: &[f64; 3]| v.map(|x| format!("{x:e}").parse::<f64>().unwrap());
        let rust = brdf.eval_parts(parse(wi), parse(wo), format!("{l:e}").parse().unwrap());
        for k in 0..2 {
            let rel = (rust[k] - c[k]).abs() / c[k].abs().max(1e-300);
            worst = worst.max(if c[k] == 0.0 { rust[k].abs() } else { rel });
        }
    }
    assert!(worst <= 1e-9, "worst relative difference {worst:e}");
}

#[test]
fn the_batched_brdf_is_eval_parts_at_every_wavelength() {
    // MaterialBrdf::wave_parts (the albedo quadrature's inner loop: vector_math ln and exp, the reads shared
    // over the wavelengths) against eval_parts (libm, one wavelength at a time) at random pairs.
    use twoscale_tables::brdf::{MaterialBrdf, WaveParts};
    let lambdas: Vec<f64> = (0..42).map(|k| 0.36 * (0.83f64 / 0.36).powf(k as f64 / 41.0)).collect();
    let mut worst = [0.0f64; 3];
    let mut compared = 0;
    for name in ["furnace5", "chi7", "chi9", "rand3", "furnace1"] {
        let brdf = MaterialBrdf::open(&test_materials().join(name)).unwrap();
        let mut parts = WaveParts::default();
        for (wi, wo) in random_pairs(29, 200) {
            let Some(pair) = brdf.pair(wi, wo) else { continue };
            let (sin_i, sin_o) = (wi[0].hypot(wi[1]), wo[0].hypot(wo[1]));
            brdf.wave_parts(&pair, sin_o, &brdf.waves(sin_i, &lambdas), &mut parts);
            for (j, &l) in lambdas.iter().enumerate() {
                let [s, d] = brdf.eval_parts(wi, wo, l);
                let sym = if brdf.has_diffraction() {
                    (0.5 * (brdf.ln_r(sin_i, brdf.b / l) - brdf.ln_r(sin_o, brdf.b / l))).exp()
                } else {
                    1.0
                };
                for (w, (batched, single)) in
                    worst.iter_mut().zip([(parts.s[j], s), (parts.d[j], d), (parts.sym[j], sym)])
                {
                    let diff = (batched - single).abs();
                    *w = w.max(if single == 0.0 { diff } else { diff / single.abs() });
                }
                compared += 1;
            }
        }
    }
    assert!(compared > 30_000, "{compared} comparisons");
    // Measured: s 1.4e-14 and d 2.3e-14 (A = exp(-t^2) carries t^2's rounding times t^2), sym 2.2e-16.
    assert!(
        worst[0] <= 1e-12 && worst[1] <= 1e-12 && worst[2] <= 1e-14,
        "worst relative differences (s, d, sym) {worst:?}"
    );
}
