//! A client for tev's IPC protocol (the HDR viewer renderer users keep open; pbrt-v4 and Mitsuba
//! stream to it the same way): `CreateImage` once, then `UpdateImageV3` with the pixels as they
//! converge. Packets are little-endian: a u32 total length (itself included), a type byte,
//! then the fields: bools as one byte, strings NUL-terminated, i32/i64 counts and rectangles,
//! and the f32 samples addressed by per-channel offset and stride.

use crate::Image;
use std::io::Write;
use std::net::{TcpStream, ToSocketAddrs};
use std::time::Duration;

/// tev's default address.
pub const DEFAULT_ADDRESS: &str = "127.0.0.1:14158";

const CREATE_IMAGE: u8 = 4;
const UPDATE_IMAGE_V3: u8 = 6;
/// Rows per update packet (tev takes any size; this keeps packets a few MB).
const ROWS_PER_PACKET: u32 = 64;

/// One image in a running tev.
pub struct Tev {
    stream: TcpStream,
    name: String,
    width: u32,
    height: u32,
}

/// A packet under construction.
struct Packet(Vec<u8>);

impl Packet {
    fn new(kind: u8) -> Self {
        Packet(vec![0, 0, 0, 0, kind])
    }
    fn bool(mut self, v: bool) -> Self {
        self.0.push(v as u8);
        self
    }
    fn str(mut self, s: &str) -> Self {
        self.0.extend(s.bytes().filter(|&b| b != 0));
        self.0.push(0);
        self
    }
    fn i32(mut self, v: i32) -> Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn i64(mut self, v: i64) -> Self {
        self.0.extend(v.to_le_bytes());
        self
    }
    fn f32s(mut self, v: impl Iterator<Item = f32>) -> Self {
        for x in v {
            self.0.extend(x.to_le_bytes());
        }
        self
    }
    fn finish(mut self) -> Vec<u8> {
        let n = self.0.len() as u32;
        self.0[..4].copy_from_slice(&n.to_le_bytes());
        self.0
    }
}

impl Tev {
    /// Connects to tev at `address` (HOST:PORT) and creates an RGB image `name` of the given size.
    pub fn connect(address: &str, name: &str, width: u32, height: u32) -> std::io::Result<Tev> {
        let addr = address
            .to_socket_addrs()?
            .next()
            .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{address}: no such address")))?;
        let stream = TcpStream::connect_timeout(&addr, Duration::from_secs(2))?;
        stream.set_write_timeout(Some(Duration::from_secs(10)))?;
        let mut tev = Tev { stream, name: name.to_owned(), width, height };
        let mut p = Packet::new(CREATE_IMAGE).bool(true).str(name).i32(width as i32).i32(height as i32).i32(3);
        for c in ["R", "G", "B"] {
            p = p.str(c);
        }
        tev.stream.write_all(&p.finish())?;
        Ok(tev)
    }

    /// Sends every pixel of `image` (the size given to [`Tev::connect`]), in bands of rows.
    pub fn update(&mut self, image: &Image) -> std::io::Result<()> {
        if (image.width, image.height) != (self.width, self.height) {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "the image's size changed"));
        }
        for y0 in (0..self.height).step_by(ROWS_PER_PACKET as usize) {
            let rows = ROWS_PER_PACKET.min(self.height - y0);
            let mut p = Packet::new(UPDATE_IMAGE_V3).bool(false).str(&self.name).i32(3);
            for c in ["R", "G", "B"] {
                p = p.str(c);
            }
            p = p.i32(0).i32(y0 as i32).i32(self.width as i32).i32(rows as i32);
            // Interleaved RGB: channel c at offset c, stride 3.
            p = p.i64(0).i64(1).i64(2).i64(3).i64(3).i64(3);
            let band = &image.pixels[(y0 * self.width) as usize..((y0 + rows) * self.width) as usize];
            let p = p.f32s(band.iter().flat_map(|c| [c.x, c.y, c.z]));
            self.stream.write_all(&p.finish())?;
        }
        self.stream.flush()
    }
}

/// Whether a tev listens at `address` (a connection opened and closed, nothing sent).
pub fn check_reachable(address: &str) -> std::io::Result<()> {
    let addr = address
        .to_socket_addrs()?
        .next()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("{address}: no such address")))?;
    TcpStream::connect_timeout(&addr, Duration::from_secs(2)).map(drop)
}

/// Sends `image` to tev at `address` as the image `name` (created, or replaced if it exists).
pub fn send_image(address: &str, name: &str, image: &Image) -> std::io::Result<()> {
    Tev::connect(address, name, image.width, image.height)?.update(image)
}
