//! Building the presets through the `twoscale` binary: committed manifest checksums, interpolation
//! error against independent computations, determinism across thread counts, incremental builds and
//! bad input.

use crate::common;

use common::shared_tables::shared_tables;

use common::{assert_input_error, assert_ok, read_manifest, repo_root, run, run_env, tempdir};
use twoscale_generate::numerics::sampling::SplitMix64;
use twoscale_generate::tables::epd_math::g1;
use twoscale_generate::tables::kcorr;
use twoscale_generate::tables::kcorr_math::renorm;
use twoscale_generate::tables::{of_preset, Preset};
use twoscale_tables::open_table;

#[test]
fn regenerated_data_matches_committed_manifests() {
    for preset in ["paper", "default"] {
        for def in of_preset(preset.parse::<Preset>().unwrap()) {
            let committed = repo_root().join("manifests").join(preset).join(format!("{}.manifest.json", def.name));
            let fresh = shared_tables().join(preset).join(format!("{}.manifest.json", def.name));
            let (c, f) = (read_manifest(&committed), read_manifest(&fresh));
            assert_eq!(
                c.data_checksums(),
                f.data_checksums(),
                "{preset}/{}: data checksums differ from manifests/ (regenerate with `make manifests` if intended)",
                def.name
            );
            assert_eq!(c.file.sha256, f.file.sha256, "{preset}/{}: HDF5 bytes differ", def.name);
        }
    }
}

#[test]
fn default_epd_g1_lookup_error_below_target() {
    // Independent of the build's own probes: other seed, physical-log sampling.
    let (_, axes, values) = open_table(&shared_tables().join("default"), "epd_g1").unwrap();
    let mut rng = SplitMix64::new(12345);
    let mut worst = (0.0f64, 0.0, 0.0);
    for _ in 0..20_000 {
        let p = 0.05 * 100f64.powf(rng.uniform());
        let a = 10f64.powf(-20.0 + 28.0 * rng.uniform());
        let v = twoscale_tables::interp::interpolate(&axes, &values[0].1.view(), &[p, a]).unwrap();
        let err = (v - g1(p, a)).abs();
        if err > worst.0 {
            worst = (err, p, a);
        }
    }
    assert!(worst.0 < 1e-4, "worst lookup error {:e} at p={} a={}", worst.0, worst.1, worst.2);
    // The ends are stored exactly.
    for p in [0.05, 1.0, 5.0] {
        let at = |a: f64| twoscale_tables::interp::interpolate(&axes, &values[0].1.view(), &[p, a]).unwrap();
        assert_eq!(at(0.0), 1.0);
        assert_eq!(at(f64::INFINITY), 0.0);
    }
}

/// E(theta_i) of the EPD lobe integrated over the outgoing direction (theta_o, phi_o) by a
/// 600 x 300 Gauss-Legendre product: independent of the build's half-vector rule. p = 1 takes
/// Beckmann's closed-form Lambda; other p `epd_math::lambda` (tested against closed forms apart).
fn albedo_over_o(p: f64, beta: f64, theta_i: f64) -> f64 {
    use twoscale_generate::numerics::legendre::gauss_legendre;
    use twoscale_generate::tables::epd_math::{lambda, norm};
    let lam = |a: f64| {
        if a == 0.0 {
            0.0
        } else if p == 1.0 {
            let nu = 1.0 / a;
            ((-nu * nu).exp() / (nu * std::f64::consts::PI.sqrt()) - twoscale_generate::numerics::special::erfc(nu))
                / 2.0
        } else {
            lambda(p, a)
        }
    };
    let (si, mu) = theta_i.sin_cos();
    let lam_i = lam(beta * si / mu);
    let n = norm(p) / (beta * beta);
    let ((tx, tw), (fx, fw)) = (gauss_legendre(600), gauss_legendre(300));
    let mut sum = 0.0;
    for (&t, &wt) in tx.iter().zip(&tw) {
        let to = std::f64::consts::FRAC_PI_4 * (t + 1.0);
        let (so, co) = to.sin_cos();
        let lam_o = lam(beta * so / co);
        for (&f, &wf) in fx.iter().zip(&fw) {
            let phi = std::f64::consts::FRAC_PI_2 * (f + 1.0);
            let h = [si + so * phi.cos(), so * phi.sin(), mu + co];
            let tan2 = (h[0] * h[0] + h[1] * h[1]) / (h[2] * h[2]);
            let cos2 = 1.0 / (1.0 + tan2);
            let d = n * (-(tan2 / (beta * beta)).powf(p)).exp() / (cos2 * cos2);
            // rho cos theta_o = D G2 / (4 mu_i); do = sin theta_o dtheta_o dphi, phi in [0, pi] doubled.
            sum += wt * wf * d / (1.0 + lam_i + lam_o) / (4.0 * mu) * so;
        }
    }
    sum * std::f64::consts::FRAC_PI_4 * std::f64::consts::FRAC_PI_2 * 2.0
}

#[test]
fn default_epd_albedo_lookup_meets_the_target_against_an_independent_integral() {
    // Broad enough lobes for the product rule over o (beta >= 0.1), heavy to light tails, normal to grazing incidence.
    let lookup = twoscale_tables::Lookup::open(&shared_tables().join("default"), "epd_albedo").unwrap();
    assert_eq!(lookup.interpolation, twoscale_tables::interp::Interpolation::Cubic);
    let mut worst = (0.0f64, [0.0; 3]);
    for p in [0.5, 1.0, 2.0, 4.0] {
        for beta in [0.1, 0.23, 0.5] {
            for theta_i in [0.0, 0.4, 0.9, 1.2, 1.4] {
                let pt = [p, beta, theta_i];
                let err = (lookup.decode(&pt).unwrap()[0] - albedo_over_o(p, beta, theta_i)).abs();
                if err > worst.0 {
                    worst = (err, pt);
                }
            }
        }
    }
    assert!(worst.0 < 1e-4, "lookup error {:e} at (p, beta, theta_i) = {:?}", worst.0, worst.1);
    // Beckmann at normal incidence with a narrow lobe: E -> 1 as beta -> 0 (G2 -> 1).
    assert!((lookup.decode(&[1.0, 0.005, 0.0]).unwrap()[0] - 1.0).abs() < 1e-4);
    let avg = twoscale_tables::Lookup::open(&shared_tables().join("default"), "epd_albedo_avg").unwrap();
    assert!((avg.decode(&[1.0, 0.005]).unwrap()[0] - 1.0).abs() < 1e-3);
}

#[test]
fn a_scene_epd_albedo_reads_as_the_whole_table() {
    // The sub-domain keeps a node beyond each end of the scene's range: the same 4^3 stencils.
    let scene = twoscale_tables::Lookup::open(&shared_tables().join("scene-merl_nickel"), "epd_albedo").unwrap();
    let whole = twoscale_tables::Lookup::open(&shared_tables().join("default"), "epd_albedo").unwrap();
    let m = twoscale_generate::scene::Scene::load(&repo_root().join("examples/scenes/merl_nickel.toml")).unwrap();
    let ranges = m.ranges();
    let range = |name: &str| ranges.iter().find(|(n, _)| *n == name).unwrap().1;
    let mut rng = SplitMix64::new(4);
    for _ in 0..2000 {
        let (p, b) = (range("p"), range("beta"));
        let pt = [p.lo + (p.hi - p.lo) * rng.uniform(), b.lo + (b.hi - b.lo) * rng.uniform(), 1.5 * rng.uniform()];
        let (a, w) = (scene.decode(&pt).unwrap()[0], whole.decode(&pt).unwrap()[0]);
        assert!((a - w).abs() <= 1e-12 * w.abs().max(1e-300), "at {pt:?}: scene {a} vs whole {w}");
    }
}

#[test]
fn default_kcorr_renorm_lookup_error_below_target() {
    let (_, axes, values) = open_table(&shared_tables().join("default"), "kcorr_renorm").unwrap();
    let mut rng = SplitMix64::new(777);
    let mut worst = (0.0f64, [0.0; 3]);
    for k in 0..20_000 {
        let u = rng.uniform();
        let s = if k % 2 == 0 { u } else { 1.0 - 10f64.powf(-4.0 * u) };
        let b = 0.1 * 1e4f64.powf(rng.uniform());
        let c = 1.0 + 0.01 * 1e4f64.powf(rng.uniform());
        let (s, c) = (s.clamp(0.0, 1.0), c.clamp(1.01, 101.0));
        let v = twoscale_tables::interp::interpolate(&axes, &values[0].1.view(), &[s, b, c]).unwrap();
        let r = renorm(s, b, c);
        let ratio = (v - r).abs() / kcorr::target(r);
        if ratio > worst.0 {
            worst = (ratio, [s, b, c]);
        }
    }
    assert!(worst.0 <= 1.0, "lookup error {}x the target at (s, B, c) = {:?}", worst.0, worst.1);
}

#[test]
fn every_stored_value_is_finite_and_in_range() {
    for preset in ["paper", "default"] {
        for def in of_preset(preset.parse::<Preset>().unwrap()) {
            let (_, _, values) = open_table(&shared_tables().join(preset), def.name).unwrap();
            for (name, data) in &values {
                assert!(data.iter().all(|v| v.is_finite()), "{preset}/{}: non-finite {name}", def.name);
                if matches!(def.name, "epd_g1" | "kcorr_renorm" | "epd_albedo" | "epd_albedo_avg") {
                    assert!(
                        data.iter().all(|v| (0.0..=1.0).contains(v)),
                        "{preset}/{}: {name} outside [0, 1]",
                        def.name
                    );
                }
                // s and s_cos are stored as their ln (any sign); the shapes g, g_cos are >= 0.
                if def.name == "zh_convolution" && name.starts_with('g') {
                    assert!(data.iter().all(|v| *v >= 0.0), "{preset}/{}: negative {name}", def.name);
                }
            }
        }
    }
}

#[test]
fn same_bytes_with_one_thread_and_all_threads() {
    let one = tempdir();
    let out = run_env(
        &["build", "--quiet", "--preset", "paper", "--out", one.path().to_str().unwrap()],
        &[("RAYON_NUM_THREADS", "1")],
    );
    assert_ok(&out);
    for def in of_preset(Preset::Paper) {
        let a = std::fs::read(one.path().join("paper").join(format!("{}.h5", def.name))).unwrap();
        let b = std::fs::read(shared_tables().join("paper").join(format!("{}.h5", def.name))).unwrap();
        assert!(a == b, "{}: HDF5 bytes differ between 1 thread and all threads", def.name);
        let ma = read_manifest(&one.path().join("paper").join(format!("{}.manifest.json", def.name)));
        assert_eq!(ma.timing["threads"], 1);
    }
}

#[test]
fn zh_lobe_built_alone_measures_the_fitted_lobes_as_the_whole_preset_does() {
    // Its accuracy compares zh_convolution's fitted lobes: without zh_convolution in the same
    // run it builds them itself, so the manifest does not depend on what was built with it.
    let alone = tempdir();
    let out = run(&["build", "--quiet", "--table", "zh_lobe", "--out", alone.path().to_str().unwrap()]);
    assert_ok(&out);
    assert!(!alone.path().join("default/zh_convolution.h5").exists(), "only zh_lobe is written");
    let a = read_manifest(&alone.path().join("default/zh_lobe.manifest.json"));
    let whole = read_manifest(&shared_tables().join("default/zh_lobe.manifest.json"));
    assert!(a.accuracy["zh_convolution_fitted_lobes"]["plain"]["pointwise"]["p99"].as_f64().unwrap() > 1.0);
    assert_eq!(a.accuracy, whole.accuracy);
}

#[test]
fn build_rejects_unknown_tables_and_presets() {
    assert_input_error(&run(&["build", "--table", "nope"]), "unknown table");
    assert_input_error(&run(&["build", "--preset", "nope"]), "unknown preset");
    assert_input_error(&run(&["build", "--table", "zh_convolution", "--method", "fast"]), "unknown method");
    assert_input_error(&run(&["build", "--table", "zh_convolution", "--degree", "0"]), "--degree");
    assert_input_error(&run(&["build", "--table", "epd_g1", "--degree", "50"]), "apply to zh_convolution only");
}

#[test]
fn zh_fits_all_converged_and_budget_recorded() {
    for preset in ["paper", "default"] {
        let m = read_manifest(&shared_tables().join(preset).join("zh_convolution.manifest.json"));
        let budget = &m.accuracy;
        assert_eq!(budget["fit_residual"]["non_converged"], 0, "{preset}");
        assert!(budget["coefficients"]["f_max_rel_change"].as_f64().unwrap() <= 1e-12, "{preset}");
        assert!(budget["coefficients"]["g_max_rel_change"].as_f64().unwrap() <= 1e-12, "{preset}");
        assert!(budget["truncation"]["summary"]["max"].is_number(), "{preset}");
    }
    // The default preset's method keeps C within 1e-3 of the direct integral.
    let m = read_manifest(&shared_tables().join("default").join("zh_convolution.manifest.json"));
    let t = m.accuracy["truncation"]["summary"]["max"].as_f64().unwrap();
    assert!(t < 1e-3, "default truncation {t:e}");
}

#[test]
fn unwritable_output_fails_cleanly() {
    let dir = tempdir();
    let blocker = dir.path().join("file");
    std::fs::write(&blocker, b"not a directory").unwrap();
    let out = run(&["build", "--quiet", "--table", "epd_norm", "--out", blocker.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    assert!(err.contains("cannot create output directory"), "{err}");
    // A read-only preset directory: no table file, no temporary left behind.
    let ro = dir.path().join("ro");
    std::fs::create_dir_all(ro.join("paper")).unwrap();
    let mut perm = std::fs::metadata(ro.join("paper")).unwrap().permissions();
    perm.set_readonly(true);
    std::fs::set_permissions(ro.join("paper"), perm).unwrap();
    let out = run(&["build", "--quiet", "--preset", "paper", "--table", "epd_norm", "--out", ro.to_str().unwrap()]);
    let listing: Vec<_> = std::fs::read_dir(ro.join("paper")).unwrap().collect();
    // root ignores the read-only bit; either way nothing partial may remain.
    if out.status.success() {
        assert_eq!(listing.len(), 2, "table and manifest");
    } else {
        assert!(listing.is_empty(), "partial files left: {listing:?}");
        assert!(String::from_utf8_lossy(&out.stderr).contains("cannot"));
    }
}

#[test]
fn unchanged_tables_are_not_rebuilt_and_changed_ones_are() {
    let dir = tempdir();
    let out = dir.path().to_str().unwrap();
    let build = || {
        let o = run(&["build", "--preset", "paper", "--table", "epd_norm", "--table", "epd_g1", "--out", out]);
        assert_ok(&o);
        String::from_utf8_lossy(&o.stderr).into_owned()
    };
    let status = |log: &str, table: &str| {
        let line = log.lines().find(|l| {
            l.contains(&format!("table=\"{table}\"")) && (l.contains("building") || l.contains("up to date"))
        });
        line.map(|l| if l.contains("up to date") { "up to date" } else { "built" }).unwrap_or("missing")
    };
    let manifest = |t: &str| dir.path().join("paper").join(format!("{t}.manifest.json"));
    let first = build();
    assert_eq!((status(&first, "epd_norm"), status(&first, "epd_g1")), ("built", "built"), "{first}");
    let before = std::fs::read_to_string(manifest("epd_g1")).unwrap();
    let second = build();
    assert_eq!((status(&second, "epd_norm"), status(&second, "epd_g1")), ("up to date", "up to date"), "{second}");
    assert_eq!(std::fs::read_to_string(manifest("epd_g1")).unwrap(), before, "an up-to-date table was rewritten");
    // Other inputs recorded for epd_g1: only it is rebuilt.
    let mut m: serde_json::Value = serde_json::from_str(&before).unwrap();
    m["inputs"]["sha256"] = serde_json::json!("0".repeat(64));
    std::fs::write(manifest("epd_g1"), serde_json::to_string_pretty(&m).unwrap()).unwrap();
    let third = build();
    assert_eq!((status(&third, "epd_norm"), status(&third, "epd_g1")), ("up to date", "built"), "{third}");
    // A damaged file is rebuilt too.
    std::fs::write(dir.path().join("paper/epd_norm.h5"), b"damaged").unwrap();
    let fourth = build();
    assert_eq!((status(&fourth, "epd_norm"), status(&fourth, "epd_g1")), ("built", "up to date"), "{fourth}");
}
