//! Little-endian byte reading for FMU states (FMI 2.0.x §2.1.8): the envelope
//! ([`super::blob`]) and the models' payloads share it. A read past the end is an error that
//! names the byte offset, never a panic, because serialized states come from outside.

/// Cursor over untrusted bytes.
pub struct Reader<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Reader<'a> {
    pub fn new(bytes: &'a [u8]) -> Self {
        Reader { bytes, pos: 0 }
    }

    /// Bytes consumed so far.
    pub fn pos(&self) -> usize {
        self.pos
    }

    /// Bytes not yet consumed.
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    pub fn take(&mut self, n: usize) -> Result<&'a [u8], String> {
        let end = self
            .pos
            .checked_add(n)
            .filter(|e| *e <= self.bytes.len())
            .ok_or_else(|| format!("truncated at byte {}", self.pos))?;
        let s = &self.bytes[self.pos..end];
        self.pos = end;
        Ok(s)
    }

    fn array<const N: usize>(&mut self) -> Result<[u8; N], String> {
        let mut a = [0u8; N];
        a.copy_from_slice(self.take(N)?);
        Ok(a)
    }

    pub fn u8(&mut self) -> Result<u8, String> {
        Ok(self.array::<1>()?[0])
    }

    pub fn u32(&mut self) -> Result<u32, String> {
        Ok(u32::from_le_bytes(self.array()?))
    }

    pub fn u64(&mut self) -> Result<u64, String> {
        Ok(u64::from_le_bytes(self.array()?))
    }

    pub fn f64(&mut self) -> Result<f64, String> {
        Ok(f64::from_le_bytes(self.array()?))
    }

    /// Fails unless every byte was consumed (a longer payload is not the one written).
    pub fn finish(&self, what: &str) -> Result<(), String> {
        match self.remaining() {
            0 => Ok(()),
            n => Err(format!("{what} has {n} trailing bytes")),
        }
    }
}

/// Appends `f64` values little-endian.
pub fn put_f64s(out: &mut Vec<u8>, values: &[f64]) {
    for x in values {
        out.extend_from_slice(&x.to_le_bytes());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_and_reports_truncation() {
        let mut b = vec![7u8];
        b.extend_from_slice(&5u32.to_le_bytes());
        put_f64s(&mut b, &[1.5]);
        let mut r = Reader::new(&b);
        assert_eq!(r.u8().unwrap(), 7);
        assert_eq!(r.u32().unwrap(), 5);
        assert_eq!(r.f64().unwrap(), 1.5);
        assert!(r.finish("x").is_ok());
        assert_eq!(r.u8().unwrap_err(), "truncated at byte 13");
        let mut r = Reader::new(&b[..3]);
        r.u8().unwrap();
        assert!(r.u32().is_err());
        assert!(r.finish("x").unwrap_err().contains("2 trailing"));
    }
}
