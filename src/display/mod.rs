//! Live preview: the image of a render shown in the [tev](https://github.com/Tom94/tev) viewer while it
//! renders (`caustica render --display-server HOST:PORT`, pbrt-v4's flag; tev listens on
//! `127.0.0.1:14158` by default). The packets are [`tev`]'s; this file sends them.
//!
//! [`Display::show`] hands an image to a background thread and returns: the render threads never wait for
//! the viewer. The thread connects (at most [`CONNECT_TIMEOUT`]), creates the image (channels R, G, B,
//! taking the viewer's focus) and sends it as tiles; each later image is sent as tiles into the same image.
//! Images waiting to be sent are kept up to [`QUEUE_BYTES`], the oldest dropped first, the newest always
//! kept: a slow viewer sees fewer, later images, never a stale one last.
//!
//! A viewer that is absent, closed or stops reading never stops the render: a failed connection or send
//! (a send waits at most [`WRITE_TIMEOUT`], pbrt-v4's `SO_SNDTIMEO`) is reported once through the
//! caller's [`Event`] callback, the connection is dropped, and the next image tries to connect again (at
//! most one attempt per image, so a viewer started or restarted during the render is found at the next
//! pass; pbrt-v4 also reconnects on its next send). [`Display::finish`] sends the last image, then
//! closes: it waits for the send under way, if any, then at most one connection attempt and one send of
//! the last image (a few seconds at worst, after the outputs are written).

pub mod tev;

use std::collections::VecDeque;
use std::io::Write as _;
use std::net::{TcpStream, ToSocketAddrs};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use crate::film::Image;

/// How long a connection attempt may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(1);
/// How long one write may wait for a viewer that does not read (pbrt-v4: 3 s).
pub const WRITE_TIMEOUT: Duration = Duration::from_secs(3);
/// Images waiting to be sent are kept up to this many bytes of pixels (the newest always).
pub const QUEUE_BYTES: usize = 64 << 20;

/// Checks a display server's address, `HOST:PORT` (`localhost:14158`, `[::1]:14158`): a non-empty host
/// and a port number. The host is looked up when the first image is sent.
pub fn check_address(s: &str) -> Result<(), String> {
    let (host, port) = s.rsplit_once(':').ok_or_else(|| format!("{s:?} is not HOST:PORT (tev listens on 127.0.0.1:14158)"))?;
    if host.is_empty() || host == "[]" {
        return Err(format!("{s:?}: no host before the port"));
    }
    port.parse::<u16>().map_err(|_| format!("{s:?}: {port:?} is not a port number (0 to 65535)"))?;
    Ok(())
}

/// What the sending thread reports (from its own thread) to [`Display::start`]'s callback.
#[derive(Debug)]
pub enum Event {
    /// Connected; `again`: there was a connection before (the viewer was restarted, or appeared late).
    Connected { again: bool },
    /// A connection or a send failed; the connection, if any, is dropped and the next image tries again.
    /// `first`: no failure was reported before.
    Failed { error: String, first: bool },
    /// An image was sent whole.
    Sent { bytes: usize, seconds: f64 },
}

/// The sending thread's queue.
#[derive(Default)]
struct Queue {
    images: VecDeque<Image>,
    closed: bool,
}

fn image_bytes(image: &Image) -> usize {
    image.pixels().len() * 12
}

struct Shared {
    queue: Mutex<Queue>,
    ready: Condvar,
}

/// A connection to a display server, fed by a background thread.
pub struct Display {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl Display {
    /// Starts the sending thread for the server at `address` (`HOST:PORT`, [`check_address`]); the images
    /// are shown under `name`. Nothing is connected before the first image.
    pub fn start(address: &str, name: &str, report: impl Fn(Event) + Send + 'static) -> std::io::Result<Display> {
        let shared = Arc::new(Shared { queue: Mutex::new(Queue::default()), ready: Condvar::new() });
        let sender = Sender { address: address.to_string(), name: name.to_string(), report: Box::new(report), stream: None, ever_connected: false, failed: false };
        let s = shared.clone();
        let thread = std::thread::Builder::new().name("display-server".into()).spawn(move || sender.run(&s))?;
        Ok(Display { shared, thread: Some(thread) })
    }

    /// Queues `image` to be sent and returns at once; older queued images beyond [`QUEUE_BYTES`] are
    /// dropped.
    pub fn show(&self, image: Image) {
        let Ok(mut q) = self.shared.queue.lock() else { return };
        q.images.push_back(image);
        let mut bytes: usize = q.images.iter().map(image_bytes).sum();
        while q.images.len() > 1 && bytes > QUEUE_BYTES {
            if let Some(old) = q.images.pop_front() {
                bytes -= image_bytes(&old);
            }
        }
        self.shared.ready.notify_one();
    }

    /// Sends the newest queued image (the older ones are dropped), then closes the connection.
    pub fn finish(mut self) {
        self.close();
    }

    fn close(&mut self) {
        if let Ok(mut q) = self.shared.queue.lock() {
            q.closed = true;
            self.shared.ready.notify_one();
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for Display {
    fn drop(&mut self) {
        self.close();
    }
}

/// The sending thread's state.
struct Sender {
    address: String,
    name: String,
    report: Box<dyn Fn(Event) + Send>,
    stream: Option<TcpStream>,
    ever_connected: bool,
    failed: bool,
}

impl Sender {
    fn run(mut self, shared: &Shared) {
        loop {
            let image = {
                let Ok(mut q) = shared.queue.lock() else { return };
                while q.images.is_empty() && !q.closed {
                    q = match shared.ready.wait(q) {
                        Ok(q) => q,
                        Err(_) => return,
                    };
                }
                if q.closed {
                    // Only the newest image is still worth sending.
                    let newest = q.images.pop_back();
                    q.images.clear();
                    match newest {
                        Some(i) => i,
                        None => return,
                    }
                } else {
                    match q.images.pop_front() {
                        Some(i) => i,
                        None => continue,
                    }
                }
            };
            self.send(&image);
        }
    }

    /// Sends one image, connecting first if need be (one attempt).
    fn send(&mut self, image: &Image) {
        let t = Instant::now();
        let fresh = self.stream.is_none();
        if fresh {
            match connect(&self.address) {
                Ok(s) => {
                    self.stream = Some(s);
                    (self.report)(Event::Connected { again: self.ever_connected });
                    self.ever_connected = true;
                }
                Err(e) => return self.fail(&e),
            }
        }
        let Some(stream) = self.stream.as_mut() else { return };
        match write_image(stream, &self.name, image, fresh) {
            Ok(bytes) => (self.report)(Event::Sent { bytes, seconds: t.elapsed().as_secs_f64() }),
            Err(e) => {
                self.stream = None;
                self.fail(&e);
            }
        }
    }

    fn fail(&mut self, e: &std::io::Error) {
        (self.report)(Event::Failed { error: e.to_string(), first: !self.failed });
        self.failed = true;
    }
}

/// A connection to `address`: each of its addresses tried, each within [`CONNECT_TIMEOUT`].
fn connect(address: &str) -> std::io::Result<TcpStream> {
    let mut last = std::io::Error::new(std::io::ErrorKind::NotFound, format!("{address}: no address found"));
    for addr in address.to_socket_addrs()? {
        match TcpStream::connect_timeout(&addr, CONNECT_TIMEOUT) {
            Ok(s) => {
                s.set_write_timeout(Some(WRITE_TIMEOUT))?;
                let _ = s.set_nodelay(true);
                return Ok(s);
            }
            Err(e) => last = e,
        }
    }
    Err(last)
}

/// Writes `image` as tiles (after a CreateImage when `create`); the bytes written.
fn write_image(stream: &mut TcpStream, name: &str, image: &Image, create: bool) -> std::io::Result<usize> {
    let mut bytes = 0;
    if create {
        let p = tev::create_image(name, true, image.width(), image.height());
        stream.write_all(&p)?;
        bytes += p.len();
    }
    for tile in tev::tiles(image.width(), image.height()) {
        let p = tev::update_image(name, false, image, tile);
        stream.write_all(&p)?;
        bytes += p.len();
    }
    stream.flush()?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read as _;
    use std::net::TcpListener;
    use std::sync::mpsc;

    #[test]
    fn addresses_are_host_and_port() {
        for ok in ["localhost:14158", "127.0.0.1:0", "[::1]:14158", "tev.example:1"] {
            assert_eq!(check_address(ok), Ok(()), "{ok}");
        }
        for bad in ["localhost", ":14158", "localhost:", "localhost:65536", "localhost:x"] {
            assert!(check_address(bad).is_err(), "{bad}");
        }
    }

    /// Reads packets (length-prefixed) until the peer closes.
    fn read_packets(mut s: TcpStream) -> Vec<Vec<u8>> {
        let mut all = Vec::new();
        s.read_to_end(&mut all).unwrap();
        let mut packets = Vec::new();
        let mut at = 0;
        while at < all.len() {
            let len = u32::from_le_bytes(all[at..at + 4].try_into().unwrap()) as usize;
            packets.push(all[at..at + len].to_vec());
            at += len;
        }
        packets
    }

    /// One create, then one update per tile per image, in order; the events say so.
    #[test]
    fn images_are_sent_as_a_create_then_tiles() {
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        let (tx, rx) = mpsc::channel();
        let display = Display::start(&address, "test", move |e| tx.send(format!("{e:?}")).unwrap()).unwrap();
        let a = Image::from_fn(130, 3, |x, y| crate::math::Vec3::splat((x + y) as f32));
        display.show(a.clone());
        display.show(Image::new(130, 3));
        let (conn, _) = listener.accept().unwrap();
        display.finish();
        let packets = read_packets(conn);
        let kinds: Vec<u8> = packets.iter().map(|p| p[4]).collect();
        // Two images queued: both are sent unless the second arrived after finish began (never here:
        // finish comes after both shows, and only then are older images dropped).
        assert_eq!(kinds, [tev::CREATE_IMAGE, 6, 6, 6, 6]);
        assert_eq!(packets[1], tev::update_image("test", false, &a, tev::Tile { x: 0, y: 0, width: 128, height: 3 }));
        let events: Vec<String> = rx.try_iter().collect();
        assert!(events[0].starts_with("Connected { again: false }"), "{events:?}");
        assert_eq!(events.iter().filter(|e| e.starts_with("Sent")).count(), 2, "{events:?}");
    }

    /// No server: one failure per image, the first marked first, and `show` never waits.
    #[test]
    fn an_absent_server_is_reported_and_does_not_block() {
        let address = {
            let l = TcpListener::bind("127.0.0.1:0").unwrap();
            l.local_addr().unwrap().to_string()
        };
        let (tx, rx) = mpsc::channel();
        let display = Display::start(&address, "test", move |e| tx.send(e).unwrap()).unwrap();
        let t = Instant::now();
        for _ in 0..3 {
            display.show(Image::new(64, 64));
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(t.elapsed() < Duration::from_secs(1));
        display.finish();
        let events: Vec<Event> = rx.try_iter().collect();
        assert!(!events.is_empty() && events.iter().all(|e| matches!(e, Event::Failed { .. })), "{events:?}");
        assert!(matches!(events[0], Event::Failed { first: true, .. }));
        assert!(events[1..].iter().all(|e| matches!(e, Event::Failed { first: false, .. })), "{events:?}");
    }

    /// Beyond the byte bound, the oldest queued images are dropped, never the newest.
    #[test]
    fn the_queue_keeps_the_newest_image() {
        // A server that accepts and never reads: the thread blocks in a send; images pile up.
        let listener = TcpListener::bind("127.0.0.1:0").unwrap();
        let address = listener.local_addr().unwrap().to_string();
        let display = Display::start(&address, "test", |_| {}).unwrap();
        let side = 2048; // 48 MB per image: two exceed the bound.
        for v in 0..3 {
            display.show(Image::from_fn(side, side, |_, _| crate::math::Vec3::splat(v as f32)));
        }
        {
            let q = display.shared.queue.lock().unwrap();
            assert!(q.images.len() <= 2, "{}", q.images.len());
            assert_eq!(q.images.back().unwrap().get(0, 0).x, 2.0);
        }
        drop(listener);
        display.finish();
    }
}
