//! The viewer's HTTP server (issue 28, item 4: safe to run): `GET` (and `HEAD`) of a fixed set
//! of paths, nothing else. It binds where it is told (127.0.0.1 unless `--bind` says
//! otherwise), answers 404 for any other path (no file of the machine is ever read from a
//! request), 405 for any other method, 431 for a request line and headers over
//! [`MAX_REQUEST_BYTES`], and closes every connection after one answer. A connection that
//! sends nothing for [`READ_TIMEOUT`] is dropped. Each connection runs on its own thread, at
//! most [`MAX_CONNECTIONS`] at once (more wait in the listen queue).

use std::collections::HashMap;
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// Longest request line plus headers accepted (bytes).
pub const MAX_REQUEST_BYTES: usize = 8 * 1024;
/// A connection silent this long is dropped.
pub const READ_TIMEOUT: Duration = Duration::from_secs(10);
/// Connections served at once.
pub const MAX_CONNECTIONS: usize = 16;

/// One resource: its media type and bytes.
#[derive(Clone, Debug)]
pub struct Resource {
    pub content_type: &'static str,
    pub body: Arc<Vec<u8>>,
}

/// What a request asked for (`GET /done?...` reports of the page reach the caller this way).
pub type OnRequest = dyn Fn(&str) + Send + Sync;

/// The request's path, or the status to answer.
fn parse(head: &[u8]) -> Result<(bool, String), u16> {
    let text = std::str::from_utf8(head).map_err(|_| 400u16)?;
    let line = text.lines().next().ok_or(400u16)?;
    let mut parts = line.split(' ');
    let (method, target, version) = (parts.next().ok_or(400u16)?, parts.next().ok_or(400u16)?, parts.next().ok_or(400u16)?);
    if parts.next().is_some() || !version.starts_with("HTTP/1.") {
        return Err(400);
    }
    let head_only = match method {
        "GET" => false,
        "HEAD" => true,
        _ => return Err(405),
    };
    if !target.starts_with('/') {
        return Err(400);
    }
    Ok((head_only, target.to_string()))
}

fn reason(status: u16) -> &'static str {
    match status {
        200 => "OK",
        400 => "Bad Request",
        404 => "Not Found",
        405 => "Method Not Allowed",
        431 => "Request Header Fields Too Large",
        _ => "Error",
    }
}

fn answer(stream: &mut TcpStream, status: u16, content_type: &str, body: &[u8], head_only: bool) {
    let head = format!(
        "HTTP/1.1 {status} {}\r\nContent-Type: {content_type}\r\nContent-Length: {}\r\nCache-Control: no-store\r\n\
         X-Content-Type-Options: nosniff\r\nConnection: close\r\n\r\n",
        reason(status),
        body.len()
    );
    let _ = stream.write_all(head.as_bytes());
    if !head_only {
        let _ = stream.write_all(body);
    }
    let _ = stream.flush();
}

/// Read the request head (up to the blank line), at most [`MAX_REQUEST_BYTES`].
fn read_head(stream: &mut TcpStream) -> Result<Vec<u8>, u16> {
    let mut head = Vec::with_capacity(512);
    let mut buf = [0u8; 1024];
    loop {
        let n = stream.read(&mut buf).map_err(|_| 400u16)?;
        if n == 0 {
            return Err(400);
        }
        head.extend_from_slice(&buf[..n]);
        if let Some(end) = head.windows(4).position(|w| w == b"\r\n\r\n") {
            head.truncate(end);
            return Ok(head);
        }
        if head.len() > MAX_REQUEST_BYTES {
            return Err(431);
        }
    }
}

fn serve_one(mut stream: TcpStream, routes: &HashMap<String, Resource>, on_request: &OnRequest) {
    let _ = stream.set_read_timeout(Some(READ_TIMEOUT));
    let _ = stream.set_write_timeout(Some(READ_TIMEOUT));
    let (head_only, target) = match read_head(&mut stream).and_then(|h| parse(&h)) {
        Ok(r) => r,
        Err(status) => return answer(&mut stream, status, "text/plain", reason(status).as_bytes(), false),
    };
    on_request(&target);
    let path = target.split('?').next().unwrap_or("");
    match routes.get(path) {
        Some(r) => answer(&mut stream, 200, r.content_type, &r.body, head_only),
        None => answer(&mut stream, 404, "text/plain", b"Not Found", head_only),
    }
}

/// Serve `routes` on `listener` until `stop` is set (checked between connections, and every
/// 100 ms while none comes).
pub fn serve(
    listener: TcpListener,
    routes: HashMap<String, Resource>,
    stop: Arc<AtomicBool>,
    on_request: Arc<OnRequest>,
) -> std::io::Result<()> {
    listener.set_nonblocking(true)?;
    let routes = Arc::new(routes);
    let active = Arc::new(AtomicUsize::new(0));
    while !stop.load(Ordering::SeqCst) {
        match listener.accept() {
            Ok((stream, _)) => {
                while active.load(Ordering::SeqCst) >= MAX_CONNECTIONS {
                    std::thread::sleep(Duration::from_millis(10));
                }
                let _ = stream.set_nonblocking(false);
                let (routes, active, on_request) = (routes.clone(), active.clone(), on_request.clone());
                active.fetch_add(1, Ordering::SeqCst);
                std::thread::spawn(move || {
                    serve_one(stream, &routes, &*on_request);
                    active.fetch_sub(1, Ordering::SeqCst);
                });
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => std::thread::sleep(Duration::from_millis(20)),
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_get_and_head_of_an_absolute_path_parse() {
        assert_eq!(parse(b"GET / HTTP/1.1\r\nHost: x"), Ok((false, "/".into())));
        assert_eq!(parse(b"HEAD /meta.json HTTP/1.0"), Ok((true, "/meta.json".into())));
        assert_eq!(parse(b"POST / HTTP/1.1"), Err(405));
        assert_eq!(parse(b"GET http://evil/ HTTP/1.1"), Err(400));
        assert_eq!(parse(b"GET / HTTP/2 extra"), Err(400));
        assert_eq!(parse(b"\xff\xfe"), Err(400));
    }
}
