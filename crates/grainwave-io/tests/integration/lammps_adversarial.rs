//! Adversarial LAMMPS data files: sizes declared or contained that would exhaust memory, and
//! values that would be echoed at full length. Each is refused with a short message, without
//! allocating more than a small multiple of the file's size.

use grainwave_io::lammps::{parse_data, read_data, LammpsDataError, MAX_ECHO_CHARS, MAX_LINE_BYTES};
use std::io::Write;

const HEADER: &str = "LAMMPS data file\n\n1000000000000 atoms\n1 atom types\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # sphere\n\n";

fn temp(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("grainwave-lammps-adv-{}-{name}", std::process::id()))
}

#[test]
fn an_atom_count_the_file_cannot_hold_is_refused_before_allocating() {
    // before: SIGABRT "memory allocation failed" (vectors reserved for 1e12 atoms)
    let e = parse_data(HEADER, "t.data").unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, LammpsDataError::Parse { .. }), "{msg}");
    assert!(msg.contains("1000000000000 atoms") && msg.contains("cannot hold"), "{msg}");
    // the same count with a few atom lines behind it
    let text = format!("{HEADER}1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n");
    assert!(parse_data(&text, "t.data").unwrap_err().to_string().contains("cannot hold"));
    // a count the file can hold is still checked against the lines
    let ok = HEADER.replace("1000000000000 atoms", "3 atoms") + "1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n";
    let msg = parse_data(&ok, "t.data").unwrap_err().to_string();
    assert!(msg.contains("has 2 lines, the header announces 3 atoms"), "{msg}");
}

#[test]
fn a_gzip_file_with_one_huge_line_is_refused_at_the_line_limit() {
    // before: a gzip file holding one 200 MB line took 605 MB of memory and echoed the whole
    // line. Here 16 MB (the limit is reached after 4 kB whatever the length).
    let path = temp("long.data.gz");
    {
        let f = std::fs::File::create(&path).unwrap();
        let mut gz = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
        gz.write_all(b"LAMMPS data file\n\n2 atoms\n").unwrap();
        let chunk = vec![b'7'; 1 << 20];
        for _ in 0..16 {
            gz.write_all(&chunk).unwrap();
        }
        gz.finish().unwrap();
    }
    let e = read_data(&path).unwrap_err();
    let msg = e.to_string();
    let _ = std::fs::remove_file(&path);
    assert!(msg.contains(&format!("longer than {MAX_LINE_BYTES} bytes")), "{msg}");
    assert!(msg.contains("line 4"), "{msg}");
    assert!(msg.len() < 400, "{} bytes of message", msg.len());
}

#[test]
fn long_values_are_echoed_at_most_200_characters() {
    let long = "x".repeat(3000);
    let digits = "1".repeat(3000);
    for text in [
        // a header line starts with a number (a letter starts a section)
        format!("LAMMPS data file\n\n2 atoms\n{digits} frobs\n"),
        HEADER.replace("1000000000000", "2") + &format!("1 1 1 1 {long} 1 1\n2 1 1 1 2 2 2\n"),
    ] {
        let msg = parse_data(&text, "t.data").unwrap_err().to_string();
        assert!(msg.contains("more bytes)"), "{msg}");
        assert!(msg.len() < MAX_ECHO_CHARS + 200, "{} bytes of message", msg.len());
    }
}

#[test]
fn decompressed_text_is_bounded_by_the_atoms_the_header_announces() {
    use grainwave_io::lammps::{MAX_BYTES_PER_ATOM, TEXT_SLACK_BYTES};
    // before (issue 41, reproducer 09): a valid 27-atom file followed by 1000 MiB of newlines in
    // a 1 MB gzip file took 1 GB of memory and was accepted. Here 2 atoms and 24 MiB of
    // newlines: refused once the text passes 2 × MAX_BYTES_PER_ATOM + TEXT_SLACK_BYTES.
    let path = temp("padded.data.gz");
    {
        let f = std::fs::File::create(&path).unwrap();
        let mut gz = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
        gz.write_all(HEADER.replace("1000000000000 atoms", "2 atoms").as_bytes()).unwrap();
        gz.write_all(b"1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n").unwrap();
        let chunk = vec![b'\n'; 1 << 20];
        for _ in 0..24 {
            gz.write_all(&chunk).unwrap();
        }
        gz.finish().unwrap();
    }
    let msg = read_data(&path).unwrap_err().to_string();
    let _ = std::fs::remove_file(&path);
    let limit = 2 * MAX_BYTES_PER_ATOM + TEXT_SLACK_BYTES;
    assert!(msg.contains(&format!("exceeds {limit} bytes")) && msg.contains("padded.data.gz"), "{msg}");
    // the same file without the padding reads
    let path = temp("plain2.data.gz");
    {
        let f = std::fs::File::create(&path).unwrap();
        let mut gz = flate2::write::GzEncoder::new(f, flate2::Compression::fast());
        gz.write_all(HEADER.replace("1000000000000 atoms", "2 atoms").as_bytes()).unwrap();
        gz.write_all(b"1 1 1 1 1 1 1\n2 1 1 1 2 2 2\n").unwrap();
        gz.finish().unwrap();
    }
    let text = grainwave_io::lammps::read_text(&path);
    let _ = std::fs::remove_file(&path);
    assert!(text.unwrap().contains("2 1 1 1 2 2 2"));
}

#[cfg(unix)]
#[test]
fn a_fifo_or_a_device_is_refused_not_read() {
    // before (issue 41, reproducer 08): a FIFO named like a data file blocked `bench` for ever
    let path = temp("fifo.data.gz");
    let _ = std::fs::remove_file(&path);
    let made = std::process::Command::new("mkfifo").arg(&path).status().map(|s| s.success()).unwrap_or(false);
    if made {
        let msg = read_data(&path).unwrap_err().to_string();
        let _ = std::fs::remove_file(&path);
        assert!(msg.contains("not a regular file") && msg.contains("fifo.data.gz"), "{msg}");
    }
    let msg = read_data(std::path::Path::new("/dev/zero")).unwrap_err().to_string();
    assert!(msg.contains("not a regular file") && msg.contains("/dev/zero"), "{msg}");
}
