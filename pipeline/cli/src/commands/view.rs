//! `twoscale view`: the BRDF explorer (runtimes/webgl) on one material folder, exported for WebGL
//! as `twoscale export --format webgl` does and served on 127.0.0.1 until the process is killed.
//! The export is served from memory rather than from a temporary folder: Ctrl-C ends the process
//! without running destructors, which would leave a folder behind at every view.
//!
//! The server is hand-written on std::net, HTTP/1.0 style: one thread per connection, one request,
//! then `Connection: close`. Under tiny_http 0.12 (keep-alive connections) headless Chromium stalled
//! 2 page loads in 24, every response sent and the page waiting still; a connection closed after each
//! response, as Python's http.server does, stalled none in the tests' loads.

use crate::flags::ViewArgs;
use crate::glue::input_error;
use anyhow::{anyhow, Result};
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;

/// A file of runtimes/webgl, compiled in: (URL path, content, Content-Type).
macro_rules! webgl_file {
    ($path:literal, $kind:literal) => {
        (concat!("/", $path), include_str!(concat!("../../../../runtimes/webgl/", $path)), $kind)
    };
}

/// The page and its modules, compiled in so that an installed binary serves them from anywhere:
/// (URL path, content, Content-Type). Browsers run an ES module only when it is served as JavaScript.
const PAGES: &[(&str, &str, &str)] = &[
    ("/", include_str!("../../../../runtimes/webgl/index.html"), "text/html; charset=utf-8"),
    webgl_file!("index.html", "text/html; charset=utf-8"),
    webgl_file!("explorer.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/page.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/colour.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/material.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/map.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/sphere_shader.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/sphere_renderer.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/sphere.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/plot.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/polar.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/slice.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/albedo.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/controls.js", "text/javascript; charset=utf-8"),
    webgl_file!("explorer/bench.js", "text/javascript; charset=utf-8"),
    webgl_file!("twoscale.js", "text/javascript; charset=utf-8"),
    webgl_file!("verify.js", "text/javascript; charset=utf-8"),
    webgl_file!("gl.js", "text/javascript; charset=utf-8"),
    webgl_file!("twoscale_general.js", "text/javascript; charset=utf-8"),
    webgl_file!("twoscale_brdf.glsl", "text/plain; charset=utf-8"),
];

/// Where the export's files are served: /material/<file>, or the general export's /tables/<file>.
const MATERIAL: &str = "/material/";
const TABLES: &str = "/tables/";

/// What is served: a material's export, or the general export and the query the page starts from.
struct Served {
    prefix: &'static str,
    files: Vec<(String, Vec<u8>)>,
    /// General tables: the page's query ("tables=tables/tables.json&beta=..."), "/" redirected to it.
    start: Option<String>,
}

pub fn run_view(args: &ViewArgs) -> Result<()> {
    let served = Arc::new(served(args)?);
    let what = match (&args.folder, &args.preset) {
        (Some(f), _) => f.display().to_string(),
        (None, _) => args.tables.join("default").display().to_string(),
    };
    let listener = TcpListener::bind(("127.0.0.1", args.port))
        .map_err(|e| anyhow!("cannot listen on 127.0.0.1:{}: {e}", args.port))?;
    let url = format!("http://127.0.0.1:{}/", listener.local_addr()?.port());
    // The URL alone on stdout, at once: a script or test reads it while the server runs.
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{url}")?;
    stdout.flush()?;
    tracing::info!("serving {what} at {url} (Ctrl-C to stop)");
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        let served = served.clone();
        // A client that goes away is its own business, not the server's.
        std::thread::spawn(move || {
            let _ = serve(stream, &served);
        });
    }
    Ok(())
}

/// A material folder's export; or, for a default-preset folder or --preset, the general export and the
/// parameters to start from (--scene's material, or the explorer's own defaults).
fn served(args: &ViewArgs) -> Result<Served> {
    let folder = match (&args.folder, &args.preset) {
        (Some(f), _) if twoscale_tables::file::manifest_path(f, "epd_g1").is_file() && is_material(f)? => {
            if args.scene.is_some() {
                return Err(input_error(
                    "view: --scene starts the general tables' sliders; a material folder has its own parameters",
                ));
            }
            return Ok(Served { prefix: MATERIAL, files: super::export::webgl_files(f)?, start: None });
        }
        (Some(_), Some(_)) => return Err(input_error("view: give a folder or --preset, not both")),
        (Some(f), _) if !twoscale_tables::file::manifest_path(f, "epd_g1").is_file() => {
            return Err(input_error(format!(
                "{} is not a material folder or a default-preset folder (no epd_g1.manifest.json)",
                f.display()
            )));
        }
        (Some(f), _) => f.clone(),
        (None, Some(_)) => args.tables.join("default"),
        (None, None) => {
            return Err(input_error("view: give a material folder, a default-preset folder, or --preset default"))
        }
    };
    // The start first: a bad --scene is refused before the tables are read.
    let mut start = String::from("tables=tables/tables.json");
    if let Some(scene) = &args.scene {
        for (k, v) in start_parameters(scene, args.material.as_deref())? {
            match k {
                "fresnel_conductor" => start.push_str("&fresnel=conductor"),
                _ => start.push_str(&format!("&{k}={v}")),
            }
        }
    }
    let files = super::export::general_webgl_folder(&folder)?;
    Ok(Served { prefix: TABLES, files, start: Some(start) })
}

/// Whether a folder holding epd_g1 is a material's (its manifest has a material section).
fn is_material(folder: &std::path::Path) -> Result<bool> {
    Ok(twoscale_tables::file::read_manifest(folder, "epd_g1")?.material.is_some())
}

/// The explorer's sliders' ranges (explorer/material.js PARAMS): a start outside them is refused, not clamped.
const SLIDERS: [(&str, f64, f64); 5] =
    [("beta", 0.005, 0.5), ("p", 0.2, 5.0), ("sigma_s", 0.0, 0.3), ("b", 0.083, 36.0), ("c", 1.02, 3.02)];

/// (beta, p, sigma_s, b, c) of the scene file's material `name` (default its first), or of a fit's .fit.json (and
/// its middle channel's eta and k, a conductor's), each within the explorer's sliders.
fn start_parameters(file: &std::path::Path, name: Option<&str>) -> Result<Vec<(&'static str, f64)>> {
    let bad = |e: String| input_error(format!("view --scene {}: {e}", file.display()));
    let mut params = scene_parameters(file, name)?;
    for &(k, v) in &params {
        if let Some(&(_, lo, hi)) = SLIDERS.iter().find(|s| s.0 == k) {
            if !(lo..=hi).contains(&v) {
                return Err(bad(format!("{k} = {v} is outside the explorer's range [{lo}, {hi}]")));
            }
        }
    }
    if params.iter().all(|&(k, v)| k != "sigma_s" || v == 0.0) {
        params.retain(|&(k, _)| k != "b" && k != "c"); // no diffraction: the sliders' own b and c
    }
    Ok(params)
}

fn scene_parameters(file: &std::path::Path, name: Option<&str>) -> Result<Vec<(&'static str, f64)>> {
    let bad = |e: String| input_error(format!("view --scene {}: {e}", file.display()));
    if file.to_string_lossy().ends_with(".fit.json") {
        if name.is_some() {
            return Err(bad("a fit's .fit.json holds one material: no --material".into()));
        }
        let text = std::fs::read_to_string(file).map_err(|e| bad(format!("cannot read it: {e}")))?;
        let json: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(format!("not JSON: {e}")))?;
        let m = &json["material"];
        let num = |k: &str, dflt: Option<f64>| {
            m[k].as_f64().or(dflt).ok_or_else(|| bad(format!("material.{k} is not a number")))
        };
        let mut out = vec![
            ("beta", num("beta", None)?),
            ("p", num("p", None)?),
            ("sigma_s", num("sigma_s", Some(0.0))?),
            ("b", num("b", Some(1.0))?),
            ("c", num("c", Some(2.0))?),
        ];
        // A conductor's middle channel's index (the explorer has one eta and k).
        let channels = json["channels"].as_array().map(Vec::as_slice).unwrap_or_default();
        if let (Some("conductor") | None, Some(ch)) = (json["model"].as_str(), channels.get(channels.len() / 2)) {
            if let (Some(eta), Some(k)) = (ch["eta"].as_f64(), ch["k"].as_f64()) {
                out.extend([("fresnel_conductor", 1.0), ("eta", eta), ("kappa", k)]);
            }
        }
        return Ok(out);
    }
    let scene = twoscale_generate::scene::Scene::load(file).map_err(|e| input_error(format!("view: {e:#}")))?;
    let m = match name {
        Some(n) => scene.materials.iter().find(|m| m.name == n).ok_or_else(|| {
            let names: Vec<&str> = scene.materials.iter().map(|m| m.name.as_str()).collect();
            bad(format!("no material {n:?} (it has {})", names.join(", ")))
        })?,
        None => &scene.materials[0],
    };
    Ok(vec![("beta", m.beta), ("p", m.p), ("sigma_s", m.sigma_s), ("b", m.b.unwrap_or(1.0)), ("c", m.c.unwrap_or(2.0))])
}

/// Reads one request's head from `stream`, answers it and closes the connection.
fn serve(mut stream: TcpStream, served: &Served) -> std::io::Result<()> {
    stream.set_read_timeout(Some(std::time::Duration::from_secs(30)))?;
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut line = String::new();
    reader.read_line(&mut line)?;
    let (method, target) = {
        let mut parts = line.split_whitespace();
        (parts.next().unwrap_or_default().to_string(), parts.next().unwrap_or_default().to_string())
    };
    // The rest of the head (headers) up to its blank line; no request here has a body.
    let mut header = String::new();
    while reader.read_line(&mut header)? > 2 {
        header.clear();
    }
    let (status, body, content_type) = respond(&method, &target, served);
    let reason = match status {
        200 => "OK",
        302 => "Found",
        404 => "Not Found",
        _ => "Method Not Allowed",
    };
    let mut head = format!(
        "HTTP/1.0 {status} {reason}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\nConnection: close\r\n",
        body.len()
    );
    if status == 405 {
        head.push_str("Allow: GET, HEAD\r\n");
    }
    if let (302, Some(start)) = (status, &served.start) {
        let extra = target.split_once('?').map(|(_, q)| format!("&{q}")).unwrap_or_default();
        head.push_str(&format!("Location: /?{start}{extra}\r\n"));
    }
    head.push_str("\r\n");
    stream.write_all(head.as_bytes())?;
    if method != "HEAD" {
        stream.write_all(body)?;
    }
    stream.flush()?;
    tracing::debug!("{method} {target} {status}");
    Ok(())
}

/// (status, body, Content-Type) of a request. Only the page's files and the export's own file names
/// are served (a URL is compared with those names, never made into a path), so nothing else is reachable.
fn respond<'a>(method: &str, target: &str, served: &'a Served) -> (u16, &'a [u8], &'static str) {
    let path = target.split(['?', '#']).next().unwrap_or_default();
    // The general tables: the page without `tables` in its query starts from the served parameters (its own
    // query, if any, after them).
    if served.start.is_some()
        && matches!(method, "GET" | "HEAD")
        && (path == "/" || path == "/index.html")
        && !target.contains("tables=")
    {
        return (302, b"", "text/plain; charset=utf-8");
    }
    let page = PAGES.iter().find(|(p, _, _)| *p == path);
    let file = path.strip_prefix(served.prefix).and_then(|name| served.files.iter().find(|(n, _)| n == name));
    match (method, page, file) {
        ("GET" | "HEAD", Some((_, text, kind)), _) => (200, text.as_bytes(), kind),
        ("GET" | "HEAD", None, Some((name, bytes))) => {
            (200, bytes, if name.ends_with(".json") { "application/json" } else { "application/octet-stream" })
        }
        ("GET" | "HEAD", None, None) => (404, b"not found\n", "text/plain; charset=utf-8"),
        _ => (405, b"method not allowed\n", "text/plain; charset=utf-8"),
    }
}
