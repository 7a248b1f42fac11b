//! The GPU export (`export --format webgl`, runtimes/webgl/README.md's `twoscale-webgl/1`) and the
//! explorer's server (`twoscale view`): the descriptor against the manifests, each binary against its
//! HDF5 table bit for bit, determinism, scene directories, refusals; the server's pages, types and
//! 404s. The page itself is tested in a browser by runtimes/webgl/tests.

use crate::common;

use common::shared_tables::{shared_tables, test_materials};
use common::{assert_input_error, ok, run, tempdir, BIN};
use serde_json::Value;
use sha2::{Digest, Sha256};
use std::io::{BufRead, BufReader, Read, Write};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use twoscale_tables::file::open_table;

fn sha256_hex(bytes: &[u8]) -> String {
    Sha256::digest(bytes).iter().map(|b| format!("{b:02x}")).collect()
}

/// `twoscale export --format webgl --dir DIR --out OUT`, which must succeed; returns the printed paths.
#[track_caller]
fn export(dir: &Path, out: &Path) -> Vec<String> {
    let o = run(&["export", "--format", "webgl", "--dir", dir.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    ok(o);
    stdout.lines().map(str::to_string).collect()
}

fn keys(v: &Value) -> Vec<&str> {
    let mut k: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    k.sort();
    k
}

/// Checks an export of the material folder `dir` in `out` against the folder's tables.
#[track_caller]
fn check_export(dir: &Path, out: &Path) {
    let text = std::fs::read_to_string(out.join("material.json")).unwrap();
    let d: Value = serde_json::from_str(&text).unwrap();
    // The README's keys, in its order (the text's, since a parsed object sorts them).
    let order = ["\"format\"", "\"generator\"", "\"preset\"", "\"material\"", "\"wavelength_range\"", "\"tables\""];
    let at: Vec<usize> = order.iter().map(|k| text.find(k).unwrap()).collect();
    assert!(at.windows(2).all(|w| w[0] < w[1]), "{at:?}");
    assert_eq!(keys(&d), ["format", "generator", "material", "preset", "tables", "wavelength_range"]);
    assert_eq!(d["format"], "twoscale-webgl/1");
    assert_eq!(d["generator"]["name"], "twoscale");
    let first = common::read_manifest(&dir.join("epd_g1.manifest.json"));
    assert_eq!(d["preset"], first.preset.as_str());
    let material = first.material.unwrap();
    assert_eq!(d["material"], material);
    let range = if material["wavelength_min"].is_null() {
        Value::Null
    } else {
        serde_json::json!([material["wavelength_min"], material["wavelength_max"]])
    };
    assert_eq!(d["wavelength_range"], range);
    let tables = d["tables"].as_array().unwrap();
    let names: Vec<&str> = tables.iter().map(|t| t["table"].as_str().unwrap()).collect();
    let expected = twoscale_generate::material::Material::from_section(&material).unwrap().table_names();
    assert_eq!(names, expected);
    let mut files: Vec<String> = names.iter().map(|n| format!("{n}.bin")).chain(["material.json".into()]).collect();
    let mut written: Vec<String> =
        std::fs::read_dir(out).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    files.sort();
    // SHA256SUMS: every other file's digest, the descriptor's included, in name order (`sha256sum -c`).
    let sums: Vec<String> =
        files.iter().map(|f| format!("{}  {f}\n", sha256_hex(&std::fs::read(out.join(f)).unwrap()))).collect();
    assert_eq!(std::fs::read_to_string(out.join("SHA256SUMS")).unwrap(), sums.concat());
    files.push("SHA256SUMS".into());
    files.sort();
    written.sort();
    assert_eq!(written, files, "the export holds the binaries, the descriptor and SHA256SUMS, nothing else");
    for t in tables {
        let name = t["table"].as_str().unwrap();
        let (manifest, axes, values) = open_table(dir, name).unwrap();
        assert_eq!(
            keys(t),
            ["axes", "bytes", "data_sha256", "derived_axes", "file", "sha256", "table", "texture", "values"]
        );
        assert_eq!(t["file"], format!("{name}.bin"));
        let bytes = std::fs::read(out.join(format!("{name}.bin"))).unwrap();
        assert_eq!(t["bytes"], bytes.len());
        assert_eq!(t["sha256"], sha256_hex(&bytes), "{name}");
        let nc = values.len();
        let value_names: Vec<&str> = values.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(t["values"], serde_json::json!(value_names));
        // Bit for bit: element [node][c] at byte (node nc + c) 4, the HDF5 value in C order.
        let floats: Vec<u32> = bytes.chunks_exact(4).map(|b| u32::from_le_bytes(b.try_into().unwrap())).collect();
        let nodes: usize = axes.iter().map(|a| a.len()).product();
        assert_eq!(floats.len(), nodes * nc, "{name}");
        for (c, (v, data)) in values.iter().enumerate() {
            assert!(
                data.iter().enumerate().all(|(n, x)| floats[n * nc + c] == x.to_bits()),
                "{name}: channel {c} ({v}) differs from the HDF5 values"
            );
            // The channel's bytes are the dataset data_sha256 names.
            let channel: Vec<u8> = (0..nodes).flat_map(|n| floats[n * nc + c].to_le_bytes()).collect();
            let entry = manifest.values.iter().find(|e| e.name == *v).unwrap();
            assert_eq!(t["data_sha256"][v.as_str()], entry.sha256.as_str());
            assert_eq!(sha256_hex(&channel), entry.sha256, "{name}: {v}");
        }
        // The texture: width the last axis, height the first (1 for one axis), one channel per value.
        let tex = &t["texture"];
        assert_eq!(keys(tex), ["format", "height", "width"]);
        assert_eq!(tex["width"], axes.last().unwrap().len());
        assert_eq!(tex["height"], if axes.len() == 2 { axes[0].len() } else { 1 });
        let format = |n: usize| ["R32F", "RG32F", "RGB32F", "RGBA32F"][n - 1];
        let expected_format = if nc <= 4 {
            serde_json::json!(format(nc))
        } else {
            serde_json::json!((0..nc).step_by(4).map(|c| format((nc - c).min(4))).collect::<Vec<_>>())
        };
        assert_eq!(tex["format"], expected_format, "{name}");
        // The axes: the manifest's entries plus the encoded ends, between which the nodes are uniform.
        let entries = t["axes"].as_array().unwrap();
        assert_eq!(entries.len(), axes.len());
        for ((e, axis), m) in entries.iter().zip(&axes).zip(&manifest.axes) {
            assert_eq!(
                keys(e),
                ["encoded_first", "encoded_last", "encoding", "encoding_formula", "max", "min", "name", "size"]
            );
            assert_eq!(e["name"], m.name.as_str());
            assert_eq!(e["size"], m.size);
            assert_eq!(e["min"].as_f64().unwrap(), m.min);
            assert_eq!(e["max"].as_f64().unwrap(), m.max);
            assert_eq!(e["encoding"], serde_json::to_value(m.encoding).unwrap());
            assert_eq!(e["encoding_formula"], m.encoding_formula.as_str());
            let (first, last) = (e["encoded_first"].as_f64().unwrap(), e["encoded_last"].as_f64().unwrap());
            // Nodes rise from min to max on every material axis.
            assert_eq!((axis.nodes[0], axis.nodes[axis.len() - 1]), (m.min, m.max), "{name}: {}", m.name);
            assert_eq!(first, m.encoding.encode(m.min), "{name}: {}", m.name);
            assert_eq!(last, m.encoding.encode(m.max), "{name}: {}", m.name);
            let n = axis.len() - 1;
            assert!(axis.nodes.iter().enumerate().all(|(i, &x)| {
                (m.encoding.encode(x) - (first + i as f64 * (last - first) / n as f64)).abs()
                    <= 1e-9 * (last - first).abs()
            }));
        }
        assert_eq!(t["derived_axes"], serde_json::to_value(&manifest.derived_axes).unwrap());
    }
}

/// A diffracting conductor, a plastic without diffraction (its interface_albedo) and a subsurface
/// material: each export is its HDF5 tables, bit for bit, described as the README says.
#[test]
fn webgl_export_holds_the_tables_bit_for_bit() {
    let work = tempdir();
    for material in ["chi5", "plastic6", "plastic7", "subsurface7"] {
        let dir = test_materials().join(material);
        let out = work.path().join(material);
        let paths = export(&dir, &out);
        // The binaries first, then the descriptor, SHA256SUMS last.
        let n = paths.len();
        assert_eq!(
            paths[n - 2..],
            [out.join("material.json"), out.join("SHA256SUMS")].map(|p| p.display().to_string())
        );
        assert!(paths[..n - 2].iter().all(|p| p.ends_with(".bin")));
        check_export(&dir, &out);
    }
}

/// The same folder gives the same bytes; a scene directory gives one folder per material, each the
/// material's own export.
#[test]
fn webgl_export_is_deterministic_and_takes_scene_directories() {
    let work = tempdir();
    let chi5 = test_materials().join("chi5");
    let (a, b) = (work.path().join("a"), work.path().join("b"));
    export(&chi5, &a);
    export(&chi5, &b);
    for e in std::fs::read_dir(&a).unwrap() {
        let name = e.unwrap().file_name();
        assert_eq!(std::fs::read(a.join(&name)).unwrap(), std::fs::read(b.join(&name)).unwrap(), "{name:?}");
    }
    // A scene directory of two materials (links to the shared folders, which stay read-only).
    let scene = work.path().join("scene-two");
    std::fs::create_dir(&scene).unwrap();
    for m in ["chi5", "subsurface7"] {
        std::os::unix::fs::symlink(test_materials().join(m), scene.join(m)).unwrap();
    }
    let out = work.path().join("scene-out");
    export(&scene, &out);
    let mut folders: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
    folders.sort();
    assert_eq!(folders, ["chi5", "subsurface7"]);
    check_export(&test_materials().join("subsurface7"), &out.join("subsurface7"));
    assert_eq!(std::fs::read(out.join("chi5/material.json")).unwrap(), std::fs::read(a.join("material.json")).unwrap());
}

/// --table with webgl, a folder that is not a material folder (or a scene directory of them), one that
/// lacks a table: one line, exit status 2, nothing written. A table a texture cannot hold as it is read
/// (an axis not uniform in its encoding, cubic interpolation) is refused; without --dir, a folder lacking the
/// default preset's tables, or another preset.
#[test]
fn webgl_export_refuses_what_it_cannot_export() {
    let work = tempdir();
    let out = work.path().join("out");
    let (o, chi5) = (out.to_str().unwrap(), test_materials().join("chi5"));
    let webgl = |args: &[&str]| run(&[&["export", "--format", "webgl", "--out", o], args].concat());
    assert_input_error(&webgl(&["--dir", chi5.to_str().unwrap(), "--table", "epd_g1"]), "--table");
    // Without --dir: the default preset's general tables (runtimes/webgl/README.md "The general export").
    let no_tables = work.path().join("no-tables");
    assert_input_error(&webgl(&["--tables", no_tables.to_str().unwrap()]), "no epd_g1.manifest.json (build the preset");
    assert_input_error(&webgl(&["--preset", "paper"]), "exports the default preset's general tables, not paper");
    let empty = work.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    assert_input_error(&webgl(&["--dir", empty.to_str().unwrap()]), "is not a material folder");
    assert_input_error(&webgl(&["--dir", work.path().join("absent").to_str().unwrap()]), "is not a material folder");
    let partial = work.path().join("partial");
    std::fs::create_dir(&partial).unwrap();
    for f in std::fs::read_dir(&chi5).unwrap().map(|e| e.unwrap().path()) {
        if !f.file_name().unwrap().to_string_lossy().starts_with("zh_lobe.") {
            std::fs::copy(&f, partial.join(f.file_name().unwrap())).unwrap();
        }
    }
    assert_input_error(&webgl(&["--dir", partial.to_str().unwrap()]), "lacks its table zh_lobe");
    assert!(!out.exists(), "an export that failed wrote {}", out.display());
    // The manifests are checksummed, so the refusals are checked on the table as read.
    let table = open_table(&chi5, "epd_g1").unwrap();
    let mut bent = table.clone();
    bent.0.axes[0].uniform = false;
    let err = twoscale_generate::ship::webgl::export_files(&[bent]).unwrap_err().to_string();
    assert!(err.contains("axis theta is not uniform in its encoding"), "{err}");
    let mut cubic = table;
    cubic.0.interpolation = twoscale_tables::interp::Interpolation::Cubic;
    let err = twoscale_generate::ship::webgl::export_files(&[cubic]).unwrap_err().to_string();
    assert!(err.contains("cubic"), "{err}");
}

/// `twoscale view` killed when the test ends, passed or not.
struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// An HTTP/1.0 request: (status, headers lowercased, body).
fn http(port: u16, method: &str, path: &str) -> (u16, String, Vec<u8>) {
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    s.set_read_timeout(Some(std::time::Duration::from_secs(10))).unwrap();
    write!(s, "{method} {path} HTTP/1.0\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n").unwrap();
    let mut raw = Vec::new();
    s.read_to_end(&mut raw).unwrap();
    let end = raw.windows(4).position(|w| w == b"\r\n\r\n").expect("a header");
    let head = String::from_utf8_lossy(&raw[..end]).to_lowercase();
    let status = head.split_whitespace().nth(1).unwrap().parse().unwrap();
    (status, head, raw[end + 4..].to_vec())
}

/// `twoscale view ARGS` started, and the port of the URL it printed.
fn start_view(args: &[&str]) -> (Server, u16) {
    let child = Command::new(BIN)
        .args(["view", "--quiet"])
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut server = Server(child);
    // The URL line, read on a thread: a server that prints nothing fails the test in 30 s rather than hangs it.
    let stdout = server.0.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let mut line = String::new();
        let _ = tx.send(BufReader::new(stdout).read_line(&mut line).map(|_| line));
    });
    let line = match rx.recv_timeout(std::time::Duration::from_secs(30)) {
        Ok(line) => line.unwrap(),
        Err(_) => {
            let _ = server.0.kill();
            panic!("twoscale view printed no URL within 30 s");
        }
    };
    let port: u16 = line
        .trim()
        .strip_prefix("http://127.0.0.1:")
        .and_then(|p| p.strip_suffix('/'))
        .unwrap_or_else(|| panic!("not the URL: {line:?}"))
        .parse()
        .unwrap();
    (server, port)
}

/// The explorer's server: the page and its modules with their types, the export under /material/ (the
/// descriptor and a binary that matches its SHA-256), 404 for anything else (no way out of the lists),
/// GET and HEAD only; a bad folder is refused before serving.
#[test]
fn view_serves_the_explorer_and_the_export() {
    let chi5 = test_materials().join("chi5");
    let (server, port) = start_view(&[chi5.to_str().unwrap()]);
    let content_type =
        |head: &str| head.lines().find_map(|l| l.strip_prefix("content-type:")).unwrap().trim().to_string();
    let (status, head, body) = http(port, "GET", "/");
    assert_eq!(status, 200);
    assert!(content_type(&head).starts_with("text/html"), "{head}");
    assert!(head.contains("cache-control: no-store"), "{head}");
    assert_eq!(body, include_bytes!("../../../runtimes/webgl/index.html"));
    for (path, kind) in [
        ("/index.html", "text/html"),
        ("/twoscale.js", "text/javascript"),
        ("/twoscale_general.js", "text/javascript"),
        ("/verify.js", "text/javascript"),
        ("/gl.js", "text/javascript"),
        ("/explorer.js", "text/javascript"),
        ("/twoscale_brdf.glsl", "text/plain"),
    ] {
        let (status, head, _) = http(port, "GET", path);
        assert_eq!(status, 200, "{path}");
        assert!(content_type(&head).starts_with(kind), "{path}: {head}");
    }
    // every module of the runtime and the explorer (runtimes/webgl and explorer/, not tools/ or tests/) is served
    let webgl = common::repo_root().join("runtimes/webgl");
    for dir in ["", "explorer"] {
        for e in std::fs::read_dir(webgl.join(dir)).unwrap().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.ends_with(".js") {
                let path = if dir.is_empty() { format!("/{name}") } else { format!("/{dir}/{name}") };
                let (status, head, body) = http(port, "GET", &path);
                assert_eq!(status, 200, "{path} is not served");
                assert!(content_type(&head).starts_with("text/javascript"), "{path}: {head}");
                assert_eq!(body, std::fs::read(e.path()).unwrap(), "{path}");
            }
        }
    }
    let (status, head, body) = http(port, "GET", "/material/material.json");
    assert_eq!(status, 200);
    assert_eq!(content_type(&head), "application/json");
    let d: Value = serde_json::from_slice(&body).unwrap();
    let zh_lobe = d["tables"].as_array().unwrap().iter().find(|t| t["table"] == "zh_lobe").unwrap();
    let (status, head, bin) = http(port, "GET", "/material/zh_lobe.bin?v=1");
    assert_eq!(status, 200);
    assert_eq!(content_type(&head), "application/octet-stream");
    assert_eq!(zh_lobe["sha256"], sha256_hex(&bin));
    let (status, _, body) = http(port, "HEAD", "/material/zh_lobe.bin");
    assert_eq!((status, body.len()), (200, 0));
    for path in ["/../Cargo.toml", "/material/../x", "/material/", "/material/../../Cargo.toml", "/README.md", "/x"] {
        assert_eq!(http(port, "GET", path).0, 404, "{path}");
    }
    assert_eq!(http(port, "POST", "/").0, 405);
    drop(server);
    // A folder that is not a material folder: one line, exit status 2, before any URL.
    let empty = tempdir();
    assert_input_error(
        &run(&["view", empty.path().to_str().unwrap()]),
        "is not a material folder or a default-preset folder",
    );
}

/// `twoscale view --preset default` (or a default-preset folder) serves the general export at /tables/ and sends
/// the page without a query to its start: the tables, and with --scene that scene material's parameters.
#[test]
fn view_serves_the_general_tables() {
    let tables = shared_tables();
    let scene = common::repo_root().join("examples/mitsuba/render_materials.toml");
    let (server, port) = start_view(&[
        "--preset",
        "default",
        "--tables",
        tables.to_str().unwrap(),
        "--scene",
        scene.to_str().unwrap(),
        "--material",
        "nickel",
    ]);
    let (status, head, _) = http(port, "GET", "/");
    assert_eq!(status, 302, "{head}");
    let location = head.lines().find_map(|l| l.strip_prefix("location:")).unwrap().trim().to_string();
    assert_eq!(location, "/?tables=tables/tables.json&beta=0.03&p=0.9&sigma_s=0.004&b=0.8&c=2.3");
    let (status, _, body) = http(port, "GET", &location);
    assert_eq!(status, 200);
    assert_eq!(body, include_bytes!("../../../runtimes/webgl/index.html"));
    let (status, _, body) = http(port, "GET", "/tables/tables.json");
    assert_eq!(status, 200);
    let d: Value = serde_json::from_slice(&body).unwrap();
    assert_eq!(d["format"], "twoscale-webgl-general/1");
    let zh_lobe = d["tables"].as_array().unwrap().iter().find(|t| t["table"] == "zh_lobe").unwrap();
    let (status, _, bin) = http(port, "GET", "/tables/zh_lobe.bin");
    assert_eq!(status, 200);
    assert_eq!(zh_lobe["sha256"], sha256_hex(&bin));
    assert_eq!(http(port, "GET", "/material/material.json").0, 404);
    // A query without the tables keeps its own parameters after the start's.
    let (status, head, _) = http(port, "GET", "/?spp=4");
    assert_eq!(status, 302, "{head}");
    assert!(
        head.contains("location: /?tables=tables/tables.json&beta=0.03&p=0.9&sigma_s=0.004&b=0.8&c=2.3&spp=4"),
        "{head}"
    );
    drop(server);
    // A fit's .fit.json: its material and a conductor's middle channel's index; outside the sliders: one line.
    let work = tempdir();
    let fit = work.path().join("m.fit.json");
    let write_fit = |sigma_s: f64| {
        let channels = r#"[{"eta": 1.0, "k": 2.0}, {"eta": 1.5, "k": 3.5}, {"eta": 2.0, "k": 4.0}]"#;
        std::fs::write(
            &fit,
            format!(r#"{{"material": {{"beta": 0.05, "p": 1.1, "sigma_s": {sigma_s}, "b": 1.2, "c": 2.1}}, "channels": {channels}}}"#),
        )
        .unwrap();
    };
    write_fit(0.01);
    let (server, port) =
        start_view(&["--preset", "default", "--tables", tables.to_str().unwrap(), "--scene", fit.to_str().unwrap()]);
    let (_, head, _) = http(port, "GET", "/");
    assert!(
        head.contains("location: /?tables=tables/tables.json&beta=0.05&p=1.1&sigma_s=0.01&b=1.2&c=2.1&fresnel=conductor&eta=1.5&kappa=3.5"),
        "{head}"
    );
    drop(server);
    write_fit(0.5);
    assert_input_error(
        &run(&["view", "--preset", "default", "--scene", fit.to_str().unwrap()]),
        "sigma_s = 0.5 is outside the explorer's range [0, 0.3]",
    );
    // The folder itself serves the same; a scene's unknown material, or --scene with a material folder: one line.
    let (server, port) = start_view(&[tables.join("default").to_str().unwrap()]);
    let (status, head, _) = http(port, "GET", "/");
    assert_eq!(status, 302, "{head}");
    assert_eq!(
        head.lines().find_map(|l| l.strip_prefix("location:")).map(str::trim),
        Some("/?tables=tables/tables.json")
    );
    drop(server);
    let s = scene.to_str().unwrap();
    assert_input_error(
        &run(&["view", "--preset", "default", "--scene", s, "--material", "nope"]),
        "no material \"nope\"",
    );
    let chi5 = test_materials().join("chi5");
    assert_input_error(
        &run(&["view", chi5.to_str().unwrap(), "--scene", s]),
        "a material folder has its own parameters",
    );
}

/// The general export reads zh_lobe's values (310 MB of float32) once and moves them into the lookup that
/// measures the export's accuracy, instead of copying them (issue 72): its peak resident memory stays under
/// the tables' bytes plus twice zh_lobe's (the float16 residual and its bytes, and the export), where the copy
/// took it a third zh_lobe above that. wait4's rusage is the child's own.
#[test]
#[allow(clippy::zombie_processes)] // reaped by wait4, which also gives its rusage
fn the_general_export_does_not_copy_zh_lobe() {
    let dir = shared_tables().join("default");
    let work = tempdir();
    let size = |t: &str| std::fs::metadata(dir.join(format!("{t}.h5"))).unwrap().len();
    let tables: u64 = twoscale_generate::ship::webgl_general::TABLES.iter().map(|t| size(t)).sum();
    let child = Command::new(BIN)
        .args(["export", "--quiet", "--format", "webgl", "--preset", "default", "--tables"])
        .arg(dir.parent().unwrap())
        .arg("--out")
        .arg(work.path().join("out"))
        .stdout(Stdio::null())
        .spawn()
        .unwrap();
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    // SAFETY: waits for our own child, into locals of the right types.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    assert!(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0, "export failed: {status}");
    let peak = usage.ru_maxrss as u64 * 1024;
    let bound = tables + 2 * size("zh_lobe");
    println!("peak {} MB, bound {} MB (tables {} MB)", peak >> 20, bound >> 20, tables >> 20);
    assert!(peak < bound, "peak resident memory {} MB above {} MB: zh_lobe copied?", peak >> 20, bound >> 20);
}
