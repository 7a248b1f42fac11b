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
use anyhow::{anyhow, Result};
use std::io::{BufRead, BufReader, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::Arc;

/// The page and its modules, compiled in so that an installed binary serves them from anywhere:
/// (URL path, content, Content-Type).
const PAGES: &[(&str, &str, &str)] = &[
    ("/", include_str!("../../../../runtimes/webgl/index.html"), "text/html; charset=utf-8"),
    ("/index.html", include_str!("../../../../runtimes/webgl/index.html"), "text/html; charset=utf-8"),
    // Browsers run an ES module only when it is served as JavaScript.
    ("/explorer.js", include_str!("../../../../runtimes/webgl/explorer.js"), "text/javascript; charset=utf-8"),
    ("/twoscale.js", include_str!("../../../../runtimes/webgl/twoscale.js"), "text/javascript; charset=utf-8"),
    (
        "/twoscale_general.js",
        include_str!("../../../../runtimes/webgl/twoscale_general.js"),
        "text/javascript; charset=utf-8",
    ),
    ("/twoscale_brdf.glsl", include_str!("../../../../runtimes/webgl/twoscale_brdf.glsl"), "text/plain; charset=utf-8"),
];

/// Where the export's files are served: /material/<file>.
const MATERIAL: &str = "/material/";

pub fn run_view(args: &ViewArgs) -> Result<()> {
    let files = Arc::new(super::export::webgl_files(&args.folder)?);
    let listener = TcpListener::bind(("127.0.0.1", args.port))
        .map_err(|e| anyhow!("cannot listen on 127.0.0.1:{}: {e}", args.port))?;
    let url = format!("http://127.0.0.1:{}/", listener.local_addr()?.port());
    // The URL alone on stdout, at once: a script or test reads it while the server runs.
    let mut stdout = std::io::stdout().lock();
    writeln!(stdout, "{url}")?;
    stdout.flush()?;
    tracing::info!("serving {} at {url} (Ctrl-C to stop)", args.folder.display());
    for stream in listener.incoming() {
        let Ok(stream) = stream else { continue };
        let files = files.clone();
        // A client that goes away is its own business, not the server's.
        std::thread::spawn(move || {
            let _ = serve(stream, &files);
        });
    }
    Ok(())
}

/// Reads one request's head from `stream`, answers it and closes the connection.
fn serve(mut stream: TcpStream, export: &[(String, Vec<u8>)]) -> std::io::Result<()> {
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
    let (status, body, content_type) = respond(&method, &target, export);
    let reason = match status {
        200 => "OK",
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
fn respond<'a>(method: &str, target: &str, export: &'a [(String, Vec<u8>)]) -> (u16, &'a [u8], &'static str) {
    let path = target.split(['?', '#']).next().unwrap_or_default();
    let page = PAGES.iter().find(|(p, _, _)| *p == path);
    let file = path.strip_prefix(MATERIAL).and_then(|name| export.iter().find(|(n, _)| n == name));
    match (method, page, file) {
        ("GET" | "HEAD", Some((_, text, kind)), _) => (200, text.as_bytes(), kind),
        ("GET" | "HEAD", None, Some((name, bytes))) => {
            (200, bytes, if name.ends_with(".json") { "application/json" } else { "application/octet-stream" })
        }
        ("GET" | "HEAD", None, None) => (404, b"not found\n", "text/plain; charset=utf-8"),
        _ => (405, b"method not allowed\n", "text/plain; charset=utf-8"),
    }
}
