//! Structured byte mutations for the fuzz tests (proptest, on stable) and the cargo-fuzz targets:
//! bit flips, byte edits, truncations, insertions, deletions, duplicated chunks, and the edits
//! that find bugs in parsers of counts and sizes — a number in text, or a little-endian u32,
//! replaced by an interesting value (0, −1, 2^31, 2^32 − 1, 1e38, NaN …).

/// Integers that break count and size arithmetic.
pub const INTERESTING_U32: [u32; 10] = [0, 1, 3, 0x7f, 0xff, 0xffff, 0x7fff_ffff, 0x8000_0000, 0xffff_fffe, 0xffff_ffff];

/// Numbers to splice into text formats (JSON, OBJ, TOML).
pub const INTERESTING_TEXT: [&str; 14] = [
    "0",
    "-1",
    "1",
    "4294967295",
    "2147483648",
    "18446744073709551615",
    "1e38",
    "-1e38",
    "nan",
    "inf",
    "1e-45",
    "0.0",
    "99999999999",
    "-0",
];

/// One mutation: `kind` picks the edit, `at` where (modulo the length), `value` its parameter.
#[derive(Clone, Copy, Debug)]
pub struct Mutation {
    pub kind: u8,
    pub at: u32,
    pub value: u32,
}

pub const KINDS: u8 = 8;

/// Applies `m` to `data` in place.
pub fn apply(data: &mut Vec<u8>, m: Mutation) {
    let len = data.len();
    let at = if len == 0 { 0 } else { m.at as usize % len };
    match m.kind % KINDS {
        0 if len > 0 => data[at] ^= 1 << (m.value % 8),
        1 if len > 0 => data[at] = m.value as u8,
        2 => data.truncate(at),
        3 => data.insert(at.min(len), m.value as u8),
        4 if len > 0 => {
            let end = (at + 1 + m.value as usize % 16).min(len);
            data.drain(at..end);
        }
        5 if len > 0 => {
            let end = (at + 1 + m.value as usize % 64).min(len);
            let chunk = data[at..end].to_vec();
            let to = (m.value as usize / 64) % (len + 1);
            data.splice(to..to, chunk);
        }
        6 => {
            // The next run of digits at or after `at` becomes an interesting number.
            let Some(start) = data[at.min(len)..].iter().position(u8::is_ascii_digit).map(|p| p + at) else { return };
            let end = data[start..].iter().position(|b| !b.is_ascii_digit() && *b != b'.').map_or(len, |p| p + start);
            let text = INTERESTING_TEXT[m.value as usize % INTERESTING_TEXT.len()];
            data.splice(start..end, text.bytes());
        }
        7 if len >= 4 => {
            let at = (at & !3).min(len - 4);
            data[at..at + 4].copy_from_slice(&INTERESTING_U32[m.value as usize % INTERESTING_U32.len()].to_le_bytes());
        }
        _ => {}
    }
}

/// Applies every mutation in order to a copy of `seed`.
pub fn mutated(seed: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut data = seed.to_vec();
    for &m in mutations {
        apply(&mut data, m);
    }
    data
}

/// Mutations from raw fuzzer bytes (cargo-fuzz): 9 bytes each.
pub fn from_bytes(bytes: &[u8]) -> Vec<Mutation> {
    bytes
        .chunks_exact(9)
        .map(|c| Mutation {
            kind: c[0],
            at: u32::from_le_bytes([c[1], c[2], c[3], c[4]]),
            value: u32::from_le_bytes([c[5], c[6], c[7], c[8]]),
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_changes_or_keeps_the_data_without_panicking() {
        let seed = b"count: 42, size 7.5\x00\x01\x02\x03".to_vec();
        for kind in 0..KINDS {
            for at in [0, 3, 17, 1000] {
                for value in [0, 5, 1000, u32::MAX] {
                    let out = mutated(&seed, &[Mutation { kind, at, value }]);
                    assert!(out.len() <= seed.len() + 64 + 20);
                }
            }
            // And on empty input.
            let _ = mutated(&[], &[Mutation { kind, at: 5, value: 5 }]);
        }
        let out = mutated(b"count: 42", &[Mutation { kind: 6, at: 0, value: 4 }]);
        assert_eq!(out, b"count: 2147483648");
    }
}
