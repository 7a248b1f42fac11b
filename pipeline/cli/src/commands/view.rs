//! `twoscale view`: the BRDF explorer (runtimes/webgl) on one material folder, exported for WebGL
//! as `twoscale export --format webgl` does and served on 127.0.0.1 until the process is killed.
//! The export is served from memory rather than from a temporary folder: Ctrl-C ends the process
//! without running destructors, which would leave a folder behind at every view.

use crate::flags::ViewArgs;
use anyhow::{anyhow, Context, Result};
use std::io::Write as _;
use tiny_http::{Header, Method, Request, Response, Server};

/// The page and its modules, compiled in so that an installed binary serves them from anywhere:
/// (URL path, content, Content-Type).
const PAGES: &[(&str, &str, &str)] = &[
    ("/", include_str!("../../../../runtimes/webgl/index.html"), "text/html; charset=utf-8"),
    ("/index.html", include_str!("../../../../runtimes/webgl/index.html"), "text/html; charset=utf-8"),
    // Browsers run an ES module only when it is served as JavaScript.
    ("/explorer.js", include_str!("../../../../runtimes/webgl/explorer.js"), "text/javascript; charset=utf-8"),
    ("/twoscale.js", include_str!("../../../../runtimes/webgl/twoscale.js"), "text/javascript; charset=utf-8"),
    ("/twoscale_brdf.glsl", include_str!("../../../../runtimes/webgl/twoscale_brdf.glsl"), "text/plain; charset=utf-8"),
];

/// Where the export's files are served: /material/<file>.
const MATERIAL: &str = "/material/";

pub fn run_view(args: &ViewArgs) -> Result<()> {
    let files = super::export::webgl_files(&args.folder)?;
    let server =
        Server::http(("127.0.0.1", args.port)).map_err(|e| anyhow!("cannot listen on 127.0.0.1:{}: {e}", args.port))?;
    let port = server.server_addr().to_ip().context("not an IP listener")?.port();
    let url = format!("http://127.0.0.1:{port}/");
    // The URL alone on stdout, at once: a script or test reads it while the server runs.
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{url}")?;
    stdout.flush()?;
    tracing::info!("serving {} at {url} (Ctrl-C to stop)", args.folder.display());
    // Several workers: with one, a response that waits on the browser (which reads its connections
    // in its own order) held up every other, and a page load stalled now and then (1 in 8 measured).
    let (server, files) = (std::sync::Arc::new(server), std::sync::Arc::new(files));
    let workers: Vec<_> = (0..WORKERS)
        .map(|_| {
            let (server, files) = (server.clone(), files.clone());
            std::thread::spawn(move || {
                for request in server.incoming_requests() {
                    let (method, path) = (request.method().clone(), request.url().to_string());
                    let status = respond(request, &files);
                    tracing::debug!("{method} {path} {status}");
                }
            })
        })
        .collect();
    for worker in workers {
        worker.join().map_err(|_| anyhow!("a server thread panicked"))?;
    }
    Ok(())
}

/// Threads answering requests: as many as a browser opens connections to one host (6).
const WORKERS: usize = 6;

/// Answers one request; returns its status. Only the page's files and the export's own file names
/// are served (a URL is compared with those names, never made into a path), so nothing else is reachable.
fn respond(request: Request, export: &[(String, Vec<u8>)]) -> u16 {
    let header = |k: &str, v: &str| Header::from_bytes(k.as_bytes(), v.as_bytes()).expect("an ASCII header");
    let path = request.url().split(['?', '#']).next().unwrap_or_default();
    let page = PAGES.iter().find(|(p, _, _)| *p == path);
    let file = path.strip_prefix(MATERIAL).and_then(|name| export.iter().find(|(n, _)| n == name));
    let (status, body, content_type): (u16, &[u8], &str) = match (request.method(), page, file) {
        (Method::Get | Method::Head, Some((_, text, kind)), _) => (200, text.as_bytes(), kind),
        (Method::Get | Method::Head, None, Some((name, bytes))) => {
            (200, bytes, if name.ends_with(".json") { "application/json" } else { "application/octet-stream" })
        }
        (Method::Get | Method::Head, None, None) => (404, b"not found\n", "text/plain; charset=utf-8"),
        _ => (405, b"method not allowed\n", "text/plain; charset=utf-8"),
    };
    let mut response = Response::from_data(body)
        .with_status_code(status)
        .with_header(header("Content-Type", content_type))
        .with_header(header("Cache-Control", "no-store"));
    if status == 405 {
        response.add_header(header("Allow", "GET, HEAD"));
    }
    // A client that went away is its own business, not the server's.
    request.respond(response).ok();
    status
}
