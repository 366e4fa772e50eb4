//! A minimal MATLAB v5 writer for real double matrices: used by tests to make broken and
//! synthetic inputs, and by anyone who wants to hand our loaders a file of their own.

/// Bytes of a MATLAB v5 file holding the given real double matrices (column-major data).
/// Returns `None` when a shape does not match its data or does not fit the format.
pub fn write_doubles(vars: &[(&str, usize, usize, &[f64])]) -> Option<Vec<u8>> {
    let mut out = Vec::new();
    let mut header = b"MATLAB 5.0 MAT-file, written by icp-bench datasets::matv5".to_vec();
    header.resize(116, b' ');
    out.extend_from_slice(&header);
    out.extend_from_slice(&[0u8; 8]); // subsystem data offset
    out.extend_from_slice(&0x0100u16.to_le_bytes());
    out.extend_from_slice(b"IM");
    for &(name, rows, cols, data) in vars {
        if rows.checked_mul(cols)? != data.len() {
            return None;
        }
        let mut body = Vec::new();
        element(
            &mut body,
            6,
            &[6u32.to_le_bytes(), 0u32.to_le_bytes()].concat(),
        ); // flags: double
        let dims = [
            i32::try_from(rows).ok()?.to_le_bytes(),
            i32::try_from(cols).ok()?.to_le_bytes(),
        ]
        .concat();
        element(&mut body, 5, &dims);
        element(&mut body, 1, name.as_bytes());
        let real: Vec<u8> = data.iter().flat_map(|v| v.to_le_bytes()).collect();
        element(&mut body, 9, &real);
        element(&mut out, 14, &body);
    }
    Some(out)
}

/// One tagged data element, padded to 8 bytes.
fn element(out: &mut Vec<u8>, kind: u32, payload: &[u8]) {
    out.extend_from_slice(&kind.to_le_bytes());
    out.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    out.extend_from_slice(payload);
    out.resize(out.len().next_multiple_of(8), 0);
}
