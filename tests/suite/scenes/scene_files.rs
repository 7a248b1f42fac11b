//! Scene-driven builds: only the tables and sub-domains a scene needs, the
//! same values as the full default preset there, and clear rejection of bad scenes.

use crate::common;

use common::shared_tables::{shared_tables, SCENE_TABLES};
use common::{assert_ok, example_scene, run, tempdir};
use twoscale_generate::accuracy::random_points;
use twoscale_tables::interp::interpolate;
use twoscale_tables::open_table;

#[test]
fn scene_tables_match_the_full_default_preset() {
    // The shared build root holds the merl_nickel sub-domain of every default table (--table), the
    // nickel's own folder and the full default preset.
    let root = shared_tables();
    let out = root.to_str().unwrap();
    let file = example_scene("merl_nickel.toml");
    for table in ["epd_g1", "kcorr_renorm"] {
        let (m, axes, values) = open_table(&root.join("scene-merl_nickel"), table).unwrap();
        assert!(m.inputs["what"]["scene"]["sha256"].is_string(), "the manifest records the scene");
        let (_, full_axes, full_values) = open_table(&root.join("default"), table).unwrap();
        for pt in random_points(&axes, 2000, 3) {
            let a = interpolate(&axes, &values[0].1.view(), &pt).unwrap();
            let b = interpolate(&full_axes, &full_values[0].1.view(), &pt).unwrap();
            // Same nodes, same values: the sub-grid interpolates exactly like the full one.
            assert!((a - b).abs() <= 1e-12 * b.abs().max(1.0), "{table} at {pt:?}: scene {a} vs default {b}");
        }
    }
    // The same builds again do nothing (and so leave the shared tables as they are): the seven
    // sub-domain tables, then the nickel's seven tables.
    let sub_domain: Vec<&str> = SCENE_TABLES.iter().flat_map(|t| ["--table", t]).collect();
    let o = run(&[&["build", "--scene", file.to_str().unwrap(), "--out", out][..], &sub_domain[..]].concat());
    let log = String::from_utf8_lossy(&o.stderr);
    assert_eq!(log.matches("up to date").count(), 7, "{log}");
    assert!(!log.contains("building"), "{log}");
    let o = run(&["build", "--scene", file.to_str().unwrap(), "--out", out]);
    let log = String::from_utf8_lossy(&o.stderr);
    assert_eq!(log.matches("up to date").count(), 7, "{log}");
    assert!(!log.contains("building"), "{log}");
    // Lookup reads the scene's directory.
    let o = run(&[
        "lookup",
        "epd_g1",
        "--preset",
        "scene-merl_nickel",
        "--tables",
        out,
        "--at",
        "p=0.9",
        "--at",
        "a=0.5",
        "--json",
    ]);
    assert_ok(&o);
}

#[test]
fn an_epd_only_scene_builds_no_diffraction_table() {
    let dir = tempdir();
    let o = run(&[
        "build",
        "--quiet",
        "--scene",
        example_scene("epd_metal.toml").to_str().unwrap(),
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert_ok(&o);
    let mut files: Vec<String> = std::fs::read_dir(dir.path().join("scene-epd_metal"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    files.sort();
    assert_eq!(files, ["brushed_steel"]);
    let mut material: Vec<String> = std::fs::read_dir(dir.path().join("scene-epd_metal/brushed_steel"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    material.sort();
    assert_eq!(
        material,
        [
            "albedo.h5",
            "albedo.manifest.json",
            "epd_g1.h5",
            "epd_g1.manifest.json",
            "epd_sampling.h5",
            "epd_sampling.manifest.json"
        ]
    );
    let plan = run(&["plan", "--scene", example_scene("epd_metal.toml").to_str().unwrap(), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&plan.stdout).unwrap();
    // The default preset's tables over its sub-domain: the EPD's, none of the diffraction ones.
    let tables: Vec<&str> = v["tables"].as_array().unwrap().iter().map(|t| t["table"].as_str().unwrap()).collect();
    assert_eq!(tables, ["epd_g1", "epd_norm", "epd_quantile", "epd_albedo", "epd_albedo_avg"]);
    assert_eq!(
        v["materials"],
        serde_json::json!([{ "material": "brushed_steel", "output": "scene-epd_metal/brushed_steel", "tables": ["epd_g1", "epd_sampling", "albedo"] }])
    );
}

#[test]
fn malformed_scenes_are_rejected_naming_file_material_and_field() {
    let cases = [
        ("beta = -0.1\np = 1.0", "`beta`"),
        ("p = 1.0", "`beta`: missing"),
        ("beta = 0.1\np = 0.0", "`p`"),
        ("beta = 0.1\np = 1.0\nsigma_s = 0.01\nb = 1.0\nc = 1.0\nwavelengths = [0.5]", "`c`: must be > 1"),
        ("beta = 0.1\np = 1.0\nsigma_s = 0.01\nc = 2.0\nwavelengths = [0.5]", "`b`: missing"),
        ("beta = 0.1\np = 1.0\nsigma_s = 0.01\nb = 1.0\nc = 2.0\nwavelengths = []", "`wavelengths`: empty list"),
        ("beta = 0.1\np = 1.0\nroughness = 3", "unknown field `roughness`"),
        (
            "beta = 0.9\np = 1.0\nsigma_s = 0.01\nb = 1.0\nc = 2.0\nwavelengths = [0.5]",
            "outside what the tables support",
        ),
        ("beta = 0.1\np = 7.0", "`p`: 7 is outside what the tables support"),
        ("beta = nan\np = 1.0", "`beta`: must be a positive number"),
        ("beta = 0.1\np = 1.0\nsigma_s = 0.01\nb = 1.0\nc = 2.0", "`wavelengths`: missing"),
        ("beta = 0.1\np = 1.0\nsigma_s = 0.01\nb = 40.0\nc = 2.0\nwavelengths = [0.5]", "`b`: b / lambda spans"),
        // The models (docs/maths.md section 10).
        ("beta = 0.1\np = 1.0\nmodel = \"velvet\"", "`model`: unknown model \"velvet\" (conductor, plastic or subsurface)"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\ndiffuse = 0.8", "`ior`: missing"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 1.5", "`diffuse`: missing"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 0.9\ndiffuse = 0.8", "`ior`: must be in [1.01, 10]"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 1.5\ndiffuse = 1.2", "`diffuse`: albedo must be in [0, 1]"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = nan\ndiffuse = 0.5", "`ior`: must be in"),
        (
            "beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 1.5\ndiffuse = { wavelengths = [0.5, 0.4], values = [0.1, 0.2] }",
            "`diffuse`: wavelengths must be positive and increasing",
        ),
        (
            "beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 1.5\ndiffuse = { wavelengths = [0.4], values = [0.1, 0.2] }",
            "`diffuse`: needs as many values as wavelengths",
        ),
        ("beta = 0.1\np = 1.0\nior = 1.5", "`ior`: given for a conductor"),
        ("beta = 0.1\np = 1.0\nmodel = \"plastic\"\nior = 1.5\ndiffuse = 0.5\ng = 0.3", "`g`: given for a plastic"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3", "`albedo`: missing"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nalbedo = 0.9", "`ior`: missing"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nalbedo = 0.9\ng = 0.95", "`g`: must be in [-0.9, 0.9]"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nalbedo = 1.5", "`albedo`: albedo must be in [0, 1]"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nalbedo = 0.9\nmfp = -1.0", "`mfp`: must be a positive length"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nabsorption = 0.1", "`scattering`: missing"),
        (
            "beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nalbedo = 0.9\nabsorption = 0.1\nscattering = 1.0",
            "`albedo`: give either albedo (and mfp) or absorption and scattering",
        ),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nabsorption = -0.1\nscattering = 1.0", "`absorption`: must be >= 0"),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nabsorption = 0.0\nscattering = 0.0", "must be > 0 (an extinction)"),
        (
            "beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nabsorption = 0.1\nscattering = { wavelengths = [0.5], values = [1.0] }",
            "on the same wavelengths",
        ),
        ("beta = 0.1\np = 1.0\nmodel = \"subsurface\"\nior = 1.3\nalbedo = 0.9\ndiffuse = 0.5", "`diffuse`: given for a subsurface"),
    ];
    for (body, needle) in cases {
        let dir = tempdir();
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, format!("[[material]]\nname = \"m1\"\n{body}\n")).unwrap();
        let out_dir = dir.path().join("out");
        for args in [vec!["build", "--scene"], vec!["plan", "--scene"]] {
            let mut a = args.clone();
            a.push(file.to_str().unwrap());
            if args[0] == "build" {
                a.extend(["--out", out_dir.to_str().unwrap()]);
            }
            let o = run(&a);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{body}: {err}");
            assert_eq!(err.trim_end().lines().count(), 1, "{err}");
            assert!(err.contains(needle) && err.contains("bad.toml"), "{needle:?} not in {err:?}");
            if !needle.contains("unknown field") && !needle.contains("domain") {
                assert!(err.contains("\"m1\""), "material not named: {err}");
            }
        }
        assert!(!out_dir.exists(), "{body}: something was written");
    }
}

#[test]
fn material_names_are_plain_folder_names_and_unique() {
    let material = |name: &str| format!("[[material]]\nname = {name:?}\nbeta = 0.1\np = 1.0\n");
    let cases = [
        (material("a/b"), "plain folder name"),
        (material(".."), "plain folder name"),
        (material(""), "plain folder name"),
        (material(".hidden"), "plain folder name"),
        (material("x") + "\n" + &material("x"), "two materials are named \"x\""),
    ];
    for (text, needle) in cases {
        let dir = tempdir();
        let file = dir.path().join("bad.toml");
        std::fs::write(&file, &text).unwrap();
        let out_dir = dir.path().join("out");
        let o = run(&["build", "--scene", file.to_str().unwrap(), "--out", out_dir.to_str().unwrap()]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{text}: {err}");
        assert!(err.trim_end().lines().count() == 1 && err.contains(needle), "{needle:?} not in {err:?}");
        assert!(!out_dir.exists(), "{text}: something was written");
    }
}

/// Materials that share a surface (a coating over several layers) compute each table once per build:
/// the later ones' manifests name the material it was computed for (`timing.computed_for`), and
/// their files are byte-identical to the same material's built in a scene of its own.
#[test]
fn materials_that_share_a_surface_compute_its_tables_once() {
    let dir = tempdir();
    let surface = "beta = 0.1\np = 1.0\n";
    let metal = format!("[[material]]\nname = \"metal\"\n{surface}");
    let plastic = format!("[[material]]\nname = \"coat\"\n{surface}model = \"plastic\"\nior = 1.5\ndiffuse = 0.5\n");
    let medium = format!("[[material]]\nname = \"milk\"\n{surface}model = \"subsurface\"\nior = 1.5\nalbedo = 0.9\n");
    // Two scene files of one name (the files name it: scene-s/milk in both), in two folders.
    for (folder, text) in [("shared", format!("{metal}\n{plastic}\n{medium}")), ("alone", medium)] {
        let scene = dir.path().join(folder).join("s.toml");
        std::fs::create_dir_all(scene.parent().unwrap()).unwrap();
        std::fs::write(&scene, text).unwrap();
        common::build(&dir.path().join(folder), &["--scene", scene.to_str().unwrap()]);
    }
    let computed_for = |folder: &str, material: &str, table: &str| {
        let m = common::read_manifest(
            &dir.path().join(folder).join("scene-s").join(material).join(format!("{table}.manifest.json")),
        );
        (m.timing.get("computed_for").and_then(|v| v.as_str()).map(String::from), m.file.sha256)
    };
    // The surface's tables are the metal's; the interface's (ior 1.5) the plastic's.
    let expected = [("epd_g1", "metal"), ("epd_sampling", "metal"), ("albedo", "metal"), ("interface_albedo", "coat")];
    for (table, first) in expected {
        let (by, file) = computed_for("shared", "milk", table);
        assert_eq!(by.as_deref(), Some(first), "{table}");
        let (by_alone, file_alone) = computed_for("alone", "milk", table);
        assert_eq!((by_alone, file_alone), (None, file), "{table}: not the bytes of the material built alone");
    }
    assert_eq!(computed_for("shared", "coat", "albedo").0.as_deref(), Some("metal"));
    assert_eq!(computed_for("shared", "coat", "interface_albedo").0, None);
    assert_eq!(computed_for("shared", "metal", "albedo").0, None);
}
