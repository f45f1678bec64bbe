//! The little-endian field codec every message and record is written with,
//! and the macro that writes a message's encoder and decoder from its one
//! list of fields (so the two cannot disagree).
//!
//! serde + postcard is the ecosystem's way to the same end; this codec was
//! kept because it is fixed-width (a field's offset is the same in every
//! frame, which a logic analyser or a C host reads without a library) and
//! because its flash was measured against postcard's (the book's Firmware chapter).

use crate::frame::FrameError;

/// Writes fields into a fixed buffer; running out is remembered, not a panic.
pub struct Writer<'a> {
    buf: &'a mut [u8],
    n: usize,
    ok: bool,
}

impl<'a> Writer<'a> {
    /// A writer at the start of `buf`.
    pub fn new(buf: &'a mut [u8]) -> Self {
        Self {
            buf,
            n: 0,
            ok: true,
        }
    }

    /// Appends raw bytes.
    pub fn bytes(&mut self, b: &[u8]) {
        match self.buf.get_mut(self.n..self.n + b.len()) {
            Some(dst) => {
                dst.copy_from_slice(b);
                self.n += b.len();
            }
            None => self.ok = false,
        }
    }

    /// Appends one field.
    pub fn put<T: Wire>(&mut self, v: &T) {
        v.put(self);
    }

    /// The length written.
    ///
    /// # Errors
    /// [`FrameError::BufferTooSmall`] when a field did not fit.
    pub fn finish(self) -> Result<usize, FrameError> {
        if self.ok {
            Ok(self.n)
        } else {
            Err(FrameError::BufferTooSmall)
        }
    }
}

/// Reads fields from a buffer.
pub struct Reader<'a> {
    buf: &'a [u8],
    n: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of `buf`.
    pub fn new(buf: &'a [u8]) -> Self {
        Self { buf, n: 0 }
    }

    /// The next `N` bytes.
    ///
    /// # Errors
    /// [`FrameError::BadLength`] past the end.
    pub fn take<const N: usize>(&mut self) -> Result<[u8; N], FrameError> {
        let s = self
            .buf
            .get(self.n..self.n + N)
            .ok_or(FrameError::BadLength)?;
        self.n += N;
        let mut a = [0u8; N];
        a.copy_from_slice(s);
        Ok(a)
    }

    /// The next field.
    ///
    /// # Errors
    /// What the field's decoder refuses.
    pub fn get<T: Wire>(&mut self) -> Result<T, FrameError> {
        T::get(self)
    }

    /// Bytes read so far.
    pub fn position(&self) -> usize {
        self.n
    }

    /// Checks that every byte was read.
    ///
    /// # Errors
    /// [`FrameError::BadLength`] when bytes are left.
    pub fn end(&self) -> Result<(), FrameError> {
        if self.n == self.buf.len() {
            Ok(())
        } else {
            Err(FrameError::BadLength)
        }
    }
}

/// A field type on the wire.
pub trait Wire: Sized {
    /// Writes it.
    fn put(&self, w: &mut Writer<'_>);
    /// Reads it.
    ///
    /// # Errors
    /// A short buffer, an unknown code.
    fn get(r: &mut Reader<'_>) -> Result<Self, FrameError>;
}

macro_rules! le_numbers {
    ($($t:ty),*) => {$(
        impl Wire for $t {
            fn put(&self, w: &mut Writer<'_>) {
                w.bytes(&self.to_le_bytes());
            }
            fn get(r: &mut Reader<'_>) -> Result<Self, FrameError> {
                Ok(<$t>::from_le_bytes(r.take()?))
            }
        }
    )*};
}
le_numbers!(u8, u16, u32, u64, i16, i32, i64, f32, f64);

impl<T: Wire + Copy + Default, const N: usize> Wire for [T; N] {
    fn put(&self, w: &mut Writer<'_>) {
        for x in self {
            x.put(w);
        }
    }
    fn get(r: &mut Reader<'_>) -> Result<Self, FrameError> {
        let mut a = [T::default(); N];
        for x in a.iter_mut() {
            *x = T::get(r)?;
        }
        Ok(a)
    }
}

impl Wire for core_nav::aided::GnssFix {
    fn put(&self, w: &mut Writer<'_>) {
        w.put(&self.lat_e7);
        w.put(&self.lon_e7);
        w.put(&self.height_mm);
        w.put(&self.v_n_mmps);
        w.put(&self.sigma_h_mm);
        w.put(&self.sigma_v_mm);
        w.put(&self.sigma_vel_mmps);
    }
    fn get(r: &mut Reader<'_>) -> Result<Self, FrameError> {
        Ok(Self {
            lat_e7: r.get()?,
            lon_e7: r.get()?,
            height_mm: r.get()?,
            v_n_mmps: r.get()?,
            sigma_h_mm: r.get()?,
            sigma_v_mm: r.get()?,
            sigma_vel_mmps: r.get()?,
        })
    }
}

/// One enum of messages, each `Variant = tag { field: Type, ... }`: the
/// enum, `tag()`, `encode(seq, out)` (tag, sequence number, the fields in
/// order) and `decode(payload)` (refuses an unknown tag, a short or a long
/// payload), all from the one list.
macro_rules! messages {
    (
        $(#[$m:meta])*
        pub enum $name:ident {
            $(
                $(#[$vm:meta])*
                $var:ident = $tag:literal {
                    $( $(#[$fm:meta])* $f:ident : $t:ty ),* $(,)?
                }
            ),* $(,)?
        }
    ) => {
        $(#[$m])*
        pub enum $name {
            $(
                $(#[$vm])*
                $var { $( $(#[$fm])* $f: $t ),* },
            )*
        }

        impl $name {
            /// The type byte that starts its payload.
            pub fn tag(&self) -> u8 {
                match self {
                    $( $name::$var { .. } => $tag, )*
                }
            }

            /// The payload (type, sequence number, fields) into `out`;
            /// returns its length.
            ///
            /// # Errors
            /// [`FrameError::BufferTooSmall`].
            pub fn encode(&self, seq: u16, out: &mut [u8]) -> Result<usize, FrameError> {
                let mut w = $crate::wire::Writer::new(out);
                w.put(&self.tag());
                w.put(&seq);
                match self {
                    $( $name::$var { $( $f ),* } => { $( w.put($f); )* } )*
                }
                w.finish()
            }

            /// Parses a payload into (sequence number, message).
            ///
            /// # Errors
            /// An unknown type, a wrong length, an unknown code in a field.
            pub fn decode(p: &[u8]) -> Result<(u16, Self), FrameError> {
                let mut r = $crate::wire::Reader::new(p);
                let tag: u8 = r.get()?;
                let seq: u16 = r.get()?;
                let m = match tag {
                    $( $tag => $name::$var { $( $f: r.get()? ),* }, )*
                    other => return Err(FrameError::UnknownType(other)),
                };
                r.end()?;
                Ok((seq, m))
            }
        }
    };
}
pub(crate) use messages;
