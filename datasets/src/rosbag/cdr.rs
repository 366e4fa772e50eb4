//! A reader of OMG CDR (XCDR1, plain), the serialization of ROS 2 messages in bags.
//!
//! Written here rather than taken from a crate: the CDR crates on crates.io (`cdr`,
//! `cdr-encoding`) deserialize through serde into Rust types mirroring the whole message, so
//! every field of `LaserScan`, `Odometry` (two 36-element covariances) and friends would need
//! a serde struct, and their errors do not say which field ran out; the five messages read
//! here need only primitives, strings and sequences, which take under a hundred lines.
//!
//! Layout (OMG DDS-XTypes 1.3, §7.4.3.5 "XCDR1"; ROS 2 `rmw` "CDR" encapsulation): a 4-byte
//! encapsulation header (`00 00` big-endian or `00 01` little-endian, then 2 option bytes),
//! then the fields in declaration order, each primitive aligned to its own size (1, 2, 4, 8)
//! counted from the end of the header; a string is a `u32` length that includes the
//! terminating NUL, then the bytes; a sequence is a `u32` element count, then the elements;
//! a fixed array has no count.

/// Why a message could not be decoded.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CdrError {
    /// The message is shorter than its encapsulation header.
    #[error("{len} bytes: shorter than the 4-byte CDR encapsulation header")]
    NoHeader {
        /// Bytes in the message.
        len: usize,
    },
    /// The encapsulation is not plain CDR (e.g. XCDR2 or parameter lists).
    #[error(
        "encapsulation {kind:#06x} is not plain CDR (0x0000 big-endian, 0x0001 little-endian)"
    )]
    Encapsulation {
        /// The encapsulation identifier read.
        kind: u16,
    },
    /// The message ends inside a field.
    #[error("field {field}: needs {need} bytes at offset {at}, the message has {len}")]
    Truncated {
        /// The field being read.
        field: &'static str,
        /// Offset of the field in the payload (after the header), bytes.
        at: usize,
        /// Bytes the field needs.
        need: usize,
        /// Bytes in the payload.
        len: usize,
    },
    /// Bytes left after the last field beyond what alignment padding explains: the message
    /// is of another type.
    #[error("{left} bytes left after the last field: not this message type")]
    TrailingBytes {
        /// Bytes left.
        left: usize,
    },
    /// A string without its terminating NUL, or not UTF-8.
    #[error("field {field}: not a NUL-terminated UTF-8 string")]
    BadString {
        /// The field being read.
        field: &'static str,
    },
}

/// A cursor over one CDR message.
pub struct CdrReader<'a> {
    /// The payload after the encapsulation header.
    payload: &'a [u8],
    pos: usize,
    little_endian: bool,
}

impl<'a> CdrReader<'a> {
    /// A reader over `message`, header included.
    pub fn new(message: &'a [u8]) -> Result<Self, CdrError> {
        let header = message
            .get(..4)
            .ok_or(CdrError::NoHeader { len: message.len() })?;
        let kind = u16::from_be_bytes([header[0], header[1]]);
        let little_endian = match kind {
            0x0000 => false,
            0x0001 => true,
            _ => return Err(CdrError::Encapsulation { kind }),
        };
        Ok(Self {
            payload: &message[4..],
            pos: 0,
            little_endian,
        })
    }

    /// The next `n` bytes after aligning to `align`.
    fn take<const N: usize>(&mut self, field: &'static str) -> Result<[u8; N], CdrError> {
        let at = self.pos.next_multiple_of(N.max(1));
        let bytes = at
            .checked_add(N)
            .and_then(|end| self.payload.get(at..end))
            .ok_or(CdrError::Truncated {
                field,
                at,
                need: N,
                len: self.payload.len(),
            })?;
        self.pos = at + N;
        let mut out = [0u8; N];
        out.copy_from_slice(bytes);
        if self.little_endian != cfg!(target_endian = "little") {
            out.reverse();
        }
        Ok(out)
    }

    /// An `int8` / `uint8` / `byte`.
    pub fn u8(&mut self, field: &'static str) -> Result<u8, CdrError> {
        Ok(self.take::<1>(field)?[0])
    }

    /// An `int8`.
    pub fn i8(&mut self, field: &'static str) -> Result<i8, CdrError> {
        Ok(i8::from_ne_bytes(self.take::<1>(field)?))
    }

    /// A `uint16`.
    pub fn u16(&mut self, field: &'static str) -> Result<u16, CdrError> {
        Ok(u16::from_ne_bytes(self.take(field)?))
    }

    /// A `uint32`.
    pub fn u32(&mut self, field: &'static str) -> Result<u32, CdrError> {
        Ok(u32::from_ne_bytes(self.take(field)?))
    }

    /// An `int32`.
    pub fn i32(&mut self, field: &'static str) -> Result<i32, CdrError> {
        Ok(i32::from_ne_bytes(self.take(field)?))
    }

    /// A `float32`.
    pub fn f32(&mut self, field: &'static str) -> Result<f32, CdrError> {
        Ok(f32::from_ne_bytes(self.take(field)?))
    }

    /// A `float64`.
    pub fn f64(&mut self, field: &'static str) -> Result<f64, CdrError> {
        Ok(f64::from_ne_bytes(self.take(field)?))
    }

    /// A `string`.
    pub fn string(&mut self, field: &'static str) -> Result<&'a str, CdrError> {
        let len = self.u32(field)? as usize;
        let at = self.pos;
        let bytes = at
            .checked_add(len)
            .and_then(|end| self.payload.get(at..end))
            .ok_or(CdrError::Truncated {
                field,
                at,
                need: len,
                len: self.payload.len(),
            })?;
        self.pos = at + len;
        match bytes.split_last() {
            Some((0, text)) => std::str::from_utf8(text).map_err(|_| CdrError::BadString { field }),
            _ => Err(CdrError::BadString { field }),
        }
    }

    /// A `float32[]` (unbounded sequence), appended to `out` as `f64`.
    pub fn f32_sequence(
        &mut self,
        field: &'static str,
        out: &mut Vec<f64>,
    ) -> Result<(), CdrError> {
        let n = self.u32(field)? as usize;
        // Check the length before reserving, so a corrupt count cannot ask for gigabytes.
        let need = n.saturating_mul(4);
        let at = self.pos.next_multiple_of(4);
        if at.saturating_add(need) > self.payload.len() {
            return Err(CdrError::Truncated {
                field,
                at,
                need,
                len: self.payload.len(),
            });
        }
        out.reserve(n);
        for _ in 0..n {
            out.push(f64::from(self.f32(field)?));
        }
        Ok(())
    }

    /// Checks that the message ends here, but for alignment padding (under 8 bytes).
    pub fn finish(&self) -> Result<(), CdrError> {
        let left = self.payload.len().saturating_sub(self.pos);
        if left >= 8 {
            return Err(CdrError::TrailingBytes { left });
        }
        Ok(())
    }

    /// Skips a `float64[N]` fixed array.
    pub fn skip_f64_array(&mut self, field: &'static str, n: usize) -> Result<(), CdrError> {
        for _ in 0..n {
            self.f64(field)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_both_byte_orders_with_alignment() {
        // u8 1, then (padding to 4) u32 7, then (padding to 8) f64 1.5, then string "ab".
        let le: Vec<u8> = [
            &[0u8, 1, 0, 0][..],
            &[1, 0xee, 0xee, 0xee],
            &7u32.to_le_bytes(),
            &1.5f64.to_le_bytes(),
            &3u32.to_le_bytes(),
            b"ab\0",
        ]
        .concat();
        let be: Vec<u8> = [
            &[0u8, 0, 0, 0][..],
            &[1, 0xee, 0xee, 0xee],
            &7u32.to_be_bytes(),
            &1.5f64.to_be_bytes(),
            &3u32.to_be_bytes(),
            b"ab\0",
        ]
        .concat();
        for bytes in [le, be] {
            let mut r = CdrReader::new(&bytes).unwrap();
            assert_eq!(r.u8("a").unwrap(), 1);
            assert_eq!(r.u32("b").unwrap(), 7);
            assert_eq!(r.f64("c").unwrap(), 1.5);
            assert_eq!(r.string("d").unwrap(), "ab");
            assert!(matches!(
                r.u8("e"),
                Err(CdrError::Truncated { field: "e", .. })
            ));
        }
    }

    #[test]
    fn rejects_other_encapsulations_and_huge_counts() {
        assert_eq!(
            CdrReader::new(&[0, 0x07, 0, 0]).err(),
            Some(CdrError::Encapsulation { kind: 7 })
        );
        assert_eq!(
            CdrReader::new(&[0, 1]).err(),
            Some(CdrError::NoHeader { len: 2 })
        );
        let bytes = [&[0u8, 1, 0, 0][..], &u32::MAX.to_le_bytes()].concat();
        let mut out = Vec::new();
        let err = CdrReader::new(&bytes)
            .unwrap()
            .f32_sequence("ranges", &mut out)
            .unwrap_err();
        assert!(
            matches!(
                err,
                CdrError::Truncated {
                    field: "ranges",
                    ..
                }
            ),
            "{err}"
        );
        let unterminated = [&[0u8, 1, 0, 0][..], &2u32.to_le_bytes(), b"ab"].concat();
        assert_eq!(
            CdrReader::new(&unterminated)
                .unwrap()
                .string("frame_id")
                .err(),
            Some(CdrError::BadString { field: "frame_id" })
        );
    }
}
