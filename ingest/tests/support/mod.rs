//! Helpers shared by the test modules: mutations of layer files for the fuzzer (`mutate`) and zip
//! checksum repair for mutated packages (`zip`), and a tiny PNG for stages that bake a texture.

pub mod mutate;
pub mod zip;

/// A grey 2×2 RGBA8 PNG (stored deflate block), so the stage bakes a real texture.
pub fn tiny_png() -> Vec<u8> {
    fn crc32(bytes: &[u8]) -> u32 {
        let mut crc = !0u32;
        for &b in bytes {
            crc ^= u32::from(b);
            for _ in 0..8 {
                crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
            }
        }
        !crc
    }
    let raw: Vec<u8> = (0..18).map(|i| if i % 9 == 0 { 0 } else { 128 }).collect();
    let (mut a, mut b) = (1u32, 0u32);
    for &x in &raw {
        a = (a + u32::from(x)) % 65521;
        b = (b + a) % 65521;
    }
    let mut zlib = vec![0x78, 0x01, 0x01, 18, 0, !18u8, 0xff];
    zlib.extend_from_slice(&raw);
    zlib.extend_from_slice(&((b << 16) | a).to_be_bytes());
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    for (kind, data) in
        [(&b"IHDR"[..], &[0, 0, 0, 2, 0, 0, 0, 2, 8, 6, 0, 0, 0][..]), (b"IDAT", &zlib), (b"IEND", &[])]
    {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let body: Vec<u8> = kind.iter().chain(data).copied().collect();
        out.extend_from_slice(&body);
        out.extend_from_slice(&crc32(&body).to_be_bytes());
    }
    out
}
