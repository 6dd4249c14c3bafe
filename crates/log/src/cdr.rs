//! OMG CDR (XCDR1, little endian) as ROS 2 serializes messages on the wire and in bags.
//!
//! A message is a 4-byte encapsulation header (`00 01 00 00`: plain CDR, little endian)
//! followed by the fields in declaration order. Every primitive is aligned to its own size
//! (float64 to 8) counted from the end of the encapsulation header; strings are a `u32` length
//! that includes a terminating NUL, the bytes and the NUL; sequences are a `u32` count followed
//! by the elements; fixed-size arrays have no count.
//!
//! Hand-written rather than taken from a crate: the handful of types the DRIVE logs use need
//! only these rules, the decoder must report *which field* at *which byte* failed (a serde-based
//! crate reports neither), and the maintained CDR crates are either unmaintained (`cdr`) or
//! carry a DDS stack.

/// Encapsulation header of a little-endian plain-CDR payload.
pub const ENCAPSULATION_CDR_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// Serializes one CDR message into a byte buffer.
#[derive(Debug, Clone)]
pub struct CdrWriter {
    buf: Vec<u8>,
}

impl Default for CdrWriter {
    fn default() -> Self {
        Self::new()
    }
}

impl CdrWriter {
    /// A writer holding just the encapsulation header.
    pub fn new() -> Self {
        Self::reusing(Vec::with_capacity(256))
    }

    /// A writer that reuses `buf`'s allocation (its content is discarded).
    pub fn reusing(mut buf: Vec<u8>) -> Self {
        buf.clear();
        buf.extend_from_slice(&ENCAPSULATION_CDR_LE);
        Self { buf }
    }

    /// The serialized message, header included.
    pub fn into_bytes(self) -> Vec<u8> {
        self.buf
    }

    /// The serialized message so far.
    pub fn as_bytes(&self) -> &[u8] {
        &self.buf
    }

    fn align(&mut self, n: usize) {
        // Alignment counts from the end of the 4-byte encapsulation header.
        let pos = self.buf.len() - ENCAPSULATION_CDR_LE.len();
        let pad = (n - pos % n) % n;
        self.buf.extend(std::iter::repeat_n(0u8, pad));
    }

    /// Writes a `uint8` (or `bool`, `byte`, `char`).
    pub fn u8(&mut self, v: u8) {
        self.buf.push(v);
    }

    /// Writes an `int32`.
    pub fn i32(&mut self, v: i32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// Writes a `uint32`.
    pub fn u32(&mut self, v: u32) {
        self.align(4);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// Writes a `float64`.
    pub fn f64(&mut self, v: f64) {
        self.align(8);
        self.buf.extend_from_slice(&v.to_le_bytes());
    }

    /// Writes a `string` (length with the NUL, bytes, NUL).
    ///
    /// # Panics
    /// If the string is longer than 4 GiB (no DRIVE message comes close).
    pub fn string(&mut self, s: &str) {
        let len = u32::try_from(s.len() + 1).expect("CDR string longer than 4 GiB");
        self.u32(len);
        self.buf.extend_from_slice(s.as_bytes());
        self.buf.push(0);
    }

    /// Writes the element count of a sequence.
    ///
    /// # Panics
    /// If the count does not fit a `u32` (no DRIVE message comes close).
    pub fn seq_len(&mut self, n: usize) {
        self.u32(u32::try_from(n).expect("CDR sequence longer than u32::MAX"));
    }

    /// Writes a `float64[]` sequence.
    pub fn f64_seq(&mut self, v: &[f64]) {
        self.seq_len(v.len());
        self.f64_array(v);
    }

    /// Writes a fixed-size `float64[N]` array (no count). Aligned once: the elements after the
    /// first are 8-byte multiples from it (the two 36-element covariances of an odometry
    /// message were 72 alignment checks).
    pub fn f64_array(&mut self, v: &[f64]) {
        if v.is_empty() {
            return;
        }
        self.align(8);
        self.buf.reserve(8 * v.len());
        for x in v {
            self.buf.extend_from_slice(&x.to_le_bytes());
        }
    }
}

/// Why a payload does not decode: the field being read, and the byte offset in the payload.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CdrError {
    /// Dotted path of the field being read, e.g. `header.frame_id`.
    pub field: String,
    /// Byte offset in the payload (encapsulation header included).
    pub offset: usize,
    /// What is wrong.
    pub message: String,
}

impl std::fmt::Display for CdrError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "field `{}` at payload byte {}: {}",
            self.field, self.offset, self.message
        )
    }
}

impl std::error::Error for CdrError {}

/// Result of CDR decoding.
pub type CdrResult<T> = Result<T, CdrError>;

/// Deserializes one CDR message, bounds-checked, naming the field on failure.
#[derive(Debug)]
pub struct CdrReader<'a> {
    buf: &'a [u8],
    pos: usize,
    path: Vec<&'static str>,
}

/// Longest sequence accepted: guards against a corrupted count allocating gigabytes.
const MAX_SEQ_LEN: usize = 1 << 20;

impl<'a> CdrReader<'a> {
    /// Checks the encapsulation header (little-endian plain CDR only, as ROS 2 writes).
    pub fn new(buf: &'a [u8]) -> CdrResult<Self> {
        let r = Self {
            buf,
            pos: 0,
            path: Vec::new(),
        };
        match buf.get(..4) {
            Some(h) if h[..2] == ENCAPSULATION_CDR_LE[..2] => Ok(Self { pos: 4, ..r }),
            Some(h) => Err(r.err(format!(
                "encapsulation {:02x} {:02x} is not little-endian CDR (00 01)",
                h[0], h[1]
            ))),
            None => Err(r.err(format!(
                "payload of {} bytes is shorter than the CDR header",
                buf.len()
            ))),
        }
    }

    /// Reads the fields of `name` with `f`; errors inside name `name` in their path.
    pub fn field<T>(
        &mut self,
        name: &'static str,
        f: impl FnOnce(&mut Self) -> CdrResult<T>,
    ) -> CdrResult<T> {
        self.path.push(name);
        let v = f(self)?;
        self.path.pop();
        Ok(v)
    }

    /// An error at the current position and field.
    pub fn err(&self, message: impl Into<String>) -> CdrError {
        CdrError {
            field: if self.path.is_empty() {
                "(message)".into()
            } else {
                self.path.join(".")
            },
            offset: self.pos,
            message: message.into(),
        }
    }

    fn take(&mut self, align: usize, n: usize) -> CdrResult<&'a [u8]> {
        let rel = self.pos.saturating_sub(4);
        let start = self.pos + (align - rel % align) % align;
        match self.buf.get(start..start + n) {
            Some(s) => {
                self.pos = start + n;
                Ok(s)
            }
            None => Err(self.err(format!(
                "needs {n} bytes at {start}, payload has {}",
                self.buf.len()
            ))),
        }
    }

    /// Reads a `uint8` (or `bool`, `byte`, `char`).
    pub fn u8(&mut self) -> CdrResult<u8> {
        Ok(self.take(1, 1)?[0])
    }

    /// Reads an `int32`.
    pub fn i32(&mut self) -> CdrResult<i32> {
        let b = self.take(4, 4)?;
        Ok(i32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Reads a `uint32`.
    pub fn u32(&mut self) -> CdrResult<u32> {
        let b = self.take(4, 4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    /// Reads a `float64`.
    pub fn f64(&mut self) -> CdrResult<f64> {
        let b = self.take(8, 8)?;
        let mut a = [0u8; 8];
        a.copy_from_slice(b);
        Ok(f64::from_le_bytes(a))
    }

    /// Reads a `string`: UTF-8, NUL-terminated.
    pub fn string(&mut self) -> CdrResult<String> {
        let len = self.u32()? as usize;
        if len == 0 {
            // Some writers emit an empty string as length 0 without the NUL.
            return Ok(String::new());
        }
        let b = self.take(1, len)?;
        let (text, nul) = b.split_at(len - 1);
        if nul != [0] {
            return Err(self.err("string is not NUL-terminated"));
        }
        String::from_utf8(text.to_vec()).map_err(|e| self.err(format!("string is not UTF-8: {e}")))
    }

    /// Reads the element count of a sequence, rejecting absurd counts.
    pub fn seq_len(&mut self) -> CdrResult<usize> {
        let n = self.u32()? as usize;
        // Each element takes at least one byte: a count beyond the rest of the payload is
        // corruption, caught here before allocating.
        if n > MAX_SEQ_LEN || n > self.buf.len().saturating_sub(self.pos) {
            return Err(self.err(format!(
                "sequence count {n} exceeds the {} bytes left",
                self.buf.len().saturating_sub(self.pos)
            )));
        }
        Ok(n)
    }

    /// Reads a `float64[]` sequence.
    pub fn f64_seq(&mut self) -> CdrResult<Vec<f64>> {
        let n = self.seq_len()?;
        (0..n).map(|_| self.f64()).collect()
    }

    /// Reads a `string[]` sequence.
    pub fn string_seq(&mut self) -> CdrResult<Vec<String>> {
        let n = self.seq_len()?;
        (0..n).map(|_| self.string()).collect()
    }

    /// Reads a fixed-size `float64[N]` array.
    pub fn f64_array<const N: usize>(&mut self) -> CdrResult<[f64; N]> {
        let mut a = [0.0; N];
        for x in &mut a {
            *x = self.f64()?;
        }
        Ok(a)
    }

    /// Bytes left after the last field read. ROS 2 pads messages to 4 bytes, so up to 3
    /// trailing bytes are normal; more means the payload is not the declared type.
    pub fn remaining(&self) -> usize {
        self.buf.len().saturating_sub(self.pos)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layout_matches_the_cdr_rules_by_hand() {
        // int32 sec = 1, uint32 nanosec = 5, string "odom", float64 1.5.
        let mut w = CdrWriter::new();
        w.i32(1);
        w.u32(5);
        w.string("odom");
        w.f64(1.5);
        let mut expected = vec![0x00, 0x01, 0x00, 0x00]; // encapsulation
        expected.extend([1, 0, 0, 0]); // sec at 0
        expected.extend([5, 0, 0, 0]); // nanosec at 4
        expected.extend([5, 0, 0, 0]); // "odom" + NUL: length 5, at 8
        expected.extend(b"odom\0"); // 12..17
        expected.extend([0; 7]); // pad 17 -> 24
        expected.extend(1.5f64.to_le_bytes()); // at 24
        assert_eq!(w.as_bytes(), &expected[..]);

        let mut r = CdrReader::new(&expected).unwrap();
        assert_eq!(r.i32().unwrap(), 1);
        assert_eq!(r.u32().unwrap(), 5);
        assert_eq!(r.string().unwrap(), "odom");
        assert_eq!(r.f64().unwrap(), 1.5);
        assert_eq!(r.remaining(), 0);
    }

    #[test]
    fn truncated_and_corrupted_payloads_name_the_field() {
        let mut w = CdrWriter::new();
        w.string("left_wheel");
        w.f64_seq(&[1.0, 2.0]);
        let bytes = w.into_bytes();
        for cut in 0..bytes.len() {
            let r = CdrReader::new(&bytes[..cut]).and_then(|mut r| {
                r.field("name", |r| r.string())?;
                r.field("velocity", |r| r.f64_seq())
            });
            assert!(r.is_err(), "cut at {cut} decoded");
        }
        // A huge sequence count is refused before allocating.
        let mut bad = bytes.clone();
        let count_at = 4 + 4 + 11 + 1; // after the string, aligned to 4 (19 -> 20)
        bad[count_at..count_at + 4].copy_from_slice(&u32::MAX.to_le_bytes());
        let mut r = CdrReader::new(&bad).unwrap();
        r.string().unwrap();
        let e = r.field("velocity", |r| r.f64_seq()).unwrap_err();
        assert_eq!(e.field, "velocity");
        assert_eq!(e.offset, count_at + 4);
        // Big-endian encapsulation is refused.
        assert!(CdrReader::new(&[0, 0, 0, 0]).is_err());
    }
}
